"""Physical units of the data ema-pipeline reads: unit labels and their SI factors.

This module is the one home of the unit factors ema-pipeline applies to file
data (the SI value of an inch, a pound-force, a g, ...). It sits low in the
import layers so that every stage (the readers of :mod:`ema_pipeline.io`, the
SEP-005 converter of :mod:`ema_pipeline.acquisition`) uses the same rules;
:mod:`ema_pipeline.io.uff_units` adds the Universal File specifics (dataset 164,
unit exponents of the specific data types).

A unit label such as ``g/N``, ``(m/s)/N``, ``(1/N)*(m/s^2)``, ``m/s2/N``,
``in/s^2/lbf`` or ``m / s^2 / N`` is parsed by a small recursive-descent
parser into an SI factor and the exponents of metre, second and newton, from
which the FRF quantity follows (m s^-2 N^-1 = accelerance, m s^-1 N^-1 =
mobility, m N^-1 = receptance) or the signal kind of a time record (m s^-2 =
acceleration, N = force, ...). Written here rather than taken from a units
library (pint, astropy) because those know neither ``g`` as the standard
gravity, nor ``s2`` for s^2, nor the text damage real files carry (``m/s≤``,
``m/sÂ²``: a superscript two written in one code page and read in another).

Label grammar: ``expr := term (('/' | '*' | '.' | '·' | 'per' | juxtaposition) term)*``,
left-associative (``m/s^2/N`` = (m/s^2)/N); ``term := unit [exponent] | '(' expr ')'
[exponent] | number``; exponent ``^n``, ``**n``, trailing digits (``s2``) or
superscripts (``²``, ``³``, ``⁻¹``). Case matters only where it must (``mN`` vs
``MN`` are not distinguished: both unusual; ``g``/``G`` is the standard gravity
9.80665 m/s^2, never the gram).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: Standard gravity (m/s^2), the ``g`` of accelerometer units.
STANDARD_GRAVITY = 9.80665
#: One pound-force in newtons.
LBF_N = 4.4482216152605
#: One inch in metres.
INCH_M = 0.0254
FOOT_M = 0.3048
KGF_N = 9.80665
POUNDAL_N = 0.138254954376

# exponent order: (metre, second, newton)
_Dims = tuple[int, int, int]

# symbol -> (SI factor, dims). Lower-case keys; looked up case-insensitively.
_UNITS: dict[str, tuple[float, _Dims]] = {
    "m": (1.0, (1, 0, 0)),
    "mm": (1e-3, (1, 0, 0)),
    "cm": (1e-2, (1, 0, 0)),
    "um": (1e-6, (1, 0, 0)),
    "µm": (1e-6, (1, 0, 0)),
    "μm": (1e-6, (1, 0, 0)),
    "micron": (1e-6, (1, 0, 0)),
    "nm": (1e-9, (1, 0, 0)),
    "km": (1e3, (1, 0, 0)),
    "in": (INCH_M, (1, 0, 0)),
    "inch": (INCH_M, (1, 0, 0)),
    "ft": (FOOT_M, (1, 0, 0)),
    "mil": (INCH_M * 1e-3, (1, 0, 0)),
    "s": (1.0, (0, 1, 0)),
    "sec": (1.0, (0, 1, 0)),
    "ms": (1e-3, (0, 1, 0)),
    "hz": (1.0, (0, -1, 0)),
    "n": (1.0, (0, 0, 1)),
    "kn": (1e3, (0, 0, 1)),
    "mn": (1e-3, (0, 0, 1)),
    "lbf": (LBF_N, (0, 0, 1)),
    "lb": (LBF_N, (0, 0, 1)),
    "lbs": (LBF_N, (0, 0, 1)),
    "kgf": (KGF_N, (0, 0, 1)),
    "kg": (1.0, (-1, 2, 1)),  # N s^2 / m
    "g": (STANDARD_GRAVITY, (1, -2, 0)),
    "gn": (STANDARD_GRAVITY, (1, -2, 0)),
    "mg": (STANDARD_GRAVITY * 1e-3, (1, -2, 0)),  # milli-g, as in vibration
}

#: Dimensions (metre, second, newton exponents) of each FRF quantity.
QUANTITY_DIMS: dict[str, _Dims] = {
    "accelerance": (1, -2, -1),
    "mobility": (1, -1, -1),
    "receptance": (1, 0, -1),
}
#: Dimensions of the responses and forces of time records.
SIGNAL_DIMS: dict[str, _Dims] = {
    "acceleration": (1, -2, 0),
    "velocity": (1, -1, 0),
    "displacement": (1, 0, 0),
    "force": (0, 0, 1),
}

_SUPERSCRIPTS = str.maketrans("⁰¹²³⁴⁵⁶⁷⁸⁹⁻", "0123456789-")
# Superscript two/three damaged by a code-page round trip, seen in real files:
# UTF-8 read as Latin-1 ("Â²"), Latin-1 read as Mac Roman ("≤", "≥"), CP437
# read as Latin-1 ("ý"), and the replacement character of a failed decode.
_MOJIBAKE = {"Â²": "²", "Â³": "³", "≤": "²", "≥": "³", "ý": "²", "\ufffd": "²"}
_BLANK = {"", "none", "-", "n/a"}



@dataclass(frozen=True)
class Unit:
    """A parsed unit label: SI factor and (metre, second, newton) exponents."""

    factor: float
    dims: _Dims
    label: str = ""

    def __truediv__(self, other: Unit) -> Unit:
        return Unit(
            self.factor / other.factor,
            (self.dims[0] - other.dims[0], self.dims[1] - other.dims[1],
             self.dims[2] - other.dims[2]),
            f"{self.label}/{other.label}",
        )

    @property
    def quantity(self) -> str | None:
        """FRF quantity of the dimension, or None."""
        for name, dims in QUANTITY_DIMS.items():
            if dims == self.dims:
                return name
        return None

    @property
    def signal(self) -> str | None:
        """Signal kind (acceleration, force, ...) of the dimension, or None."""
        for name, dims in SIGNAL_DIMS.items():
            if dims == self.dims:
                return name
        return None


DIMENSIONLESS = Unit(1.0, (0, 0, 0), "1")


def is_blank_label(label: str) -> bool:
    """True for an absent unit label (empty or ``NONE``).

    Examples
    --------
    >>> is_blank_label(" NONE "), is_blank_label(""), is_blank_label("m/s^2")
    (True, True, False)
    """
    return label.strip().lower() in _BLANK


def clean_label(label: str) -> str:
    """The label with code-page damage to superscripts repaired, stripped."""
    text = label.strip()
    for bad, good in _MOJIBAKE.items():
        text = text.replace(bad, good)
    return text


_TOKEN = re.compile(
    r"\s*(?:(?P<num>\d+(?:\.\d*)?)|(?P<name>[A-Za-zµμ]+)|(?P<op>\*\*|[()/*^.·])|(?P<sup>[⁰¹²³⁴⁵⁶⁷⁸⁹⁻]+)|(?P<minus>-))"
)


def parse_unit_label(label: str) -> Unit:
    """Parse a unit label into an SI factor and dimensions.

    Parameters
    ----------
    label : str
        A unit label as files write it: ``g/N``, ``(m/s)/N``, ``m/s^2/N``,
        ``in/s^2/lbf``, ``(1/N)*(m/s²)``, ``m s^-2 N^-1``, ...

    Returns
    -------
    Unit
        ``factor`` turns a value in these units into SI; ``dims`` are the
        exponents of (metre, second, newton).

    Raises
    ------
    ValueError
        When the label is not a unit this parser knows (the caller turns it
        into a DataError naming the file and record).

    Examples
    --------
    >>> u = parse_unit_label("in/s^2/lbf")
    >>> round(u.factor, 6), u.quantity
    (0.00571, 'accelerance')
    >>> parse_unit_label("(m/s)/N").quantity
    'mobility'
    >>> round(parse_unit_label("g/N").factor, 5)
    9.80665
    """
    text = clean_label(label).translate(_SUPERSCRIPTS)
    text = re.sub(r"(?i)\bper\b", "/", text)
    tokens: list[tuple[str, str]] = []
    pos = 0
    while pos < len(text):
        if text[pos:].strip() == "":
            break
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            raise ValueError(f"unexpected character {text[pos:].strip()[:1]!r}")
        kind = m.lastgroup or ""
        value = m.group(kind)
        if kind == "sup":  # superscript exponent, already translated to digits
            kind = "num"
        tokens.append((kind, value))
        pos = m.end()
    parser = _Parser(tokens)
    unit = parser.expr()
    if parser.i != len(tokens):
        raise ValueError(f"unexpected {tokens[parser.i][1]!r}")
    return Unit(unit.factor, unit.dims, label.strip())


class _Parser:
    def __init__(self, tokens: list[tuple[str, str]]) -> None:
        self.tokens = tokens
        self.i = 0

    def peek(self) -> tuple[str, str]:
        return self.tokens[self.i] if self.i < len(self.tokens) else ("end", "")

    def take(self) -> tuple[str, str]:
        tok = self.peek()
        self.i += 1
        return tok

    def expr(self) -> Unit:
        acc = self.term()
        while True:
            kind, value = self.peek()
            if kind == "op" and value == "/":
                self.take()
                acc = _combine(acc, self.term(), -1)
            elif kind == "op" and value in ("*", ".", "·"):
                self.take()
                acc = _combine(acc, self.term(), 1)
            elif kind in ("name", "num") or (kind == "op" and value == "("):
                acc = _combine(acc, self.term(), 1)  # juxtaposition: m s^-2
            else:
                return acc

    def term(self) -> Unit:
        kind, value = self.take()
        if kind == "op" and value == "(":
            inner = self.expr()
            if self.take() != ("op", ")"):
                raise ValueError("unbalanced parenthesis")
            return _power(inner, self.exponent())
        if kind == "num":
            if float(value) != 1.0:
                raise ValueError(f"numeric factor {value!r}")
            return DIMENSIONLESS
        if kind == "name":
            name, digits = re.fullmatch(r"([^\d]+)(\d*)", value).groups()  # type: ignore[union-attr]
            key = name.lower()
            if key not in _UNITS:
                raise ValueError(f"unknown unit {name!r}")
            factor, dims = _UNITS[key]
            base = Unit(factor, dims, name)
            exp = int(digits) if digits else self.exponent()
            return _power(base, exp)
        raise ValueError(f"unexpected {value!r}")

    def exponent(self) -> int:
        kind, value = self.peek()
        if kind == "op" and value in ("^", "**"):
            self.take()
            sign = 1
            if self.peek()[0] == "minus":
                self.take()
                sign = -1
            k, v = self.take()
            if k != "num":
                raise ValueError("exponent expected")
            return sign * int(float(v))
        if kind == "num" and value.lstrip("-").isdigit() and self.i > 0:
            # superscript digits follow directly (translated to plain digits)
            self.take()
            return int(value)
        if kind == "minus":  # translated superscript minus: s⁻¹
            self.take()
            k, v = self.take()
            if k != "num":
                raise ValueError("exponent expected")
            return -int(v)
        return 1


def _combine(a: Unit, b: Unit, sign: int) -> Unit:
    dims = tuple(x + sign * y for x, y in zip(a.dims, b.dims, strict=True))
    return Unit(a.factor * b.factor**sign, dims, "")  # type: ignore[arg-type]


def _power(u: Unit, n: int) -> Unit:
    return Unit(u.factor**n, tuple(d * n for d in u.dims), "")  # type: ignore[arg-type]
