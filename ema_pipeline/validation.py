"""The checks of a setting's value, written once: a number in a range, a
number of seconds, an integer, a pair low < high, a choice among names, a
flag, a list, an optional value.

Each check is a *rule*: a function ``rule(name, value)`` that returns the value
normalised (a float, an int, a tuple) or raises an
:class:`~ema_pipeline.data.OptionError` ``"<name> must be <rule>, got
<value>"`` (its ``field`` is ``name``, its ``reason`` the rest). The option
records (:class:`~ema_pipeline.identification.IdentificationOptions`,
:class:`~ema_pipeline.identification.SelectionThresholds`), the settings of
``ema-pipeline frf`` (:mod:`ema_pipeline.acquisition.frf_settings`), the
experiment file (:mod:`ema_pipeline.io.experiment`, which puts the file, the
table and the key before the reason) and the command line (which puts the
option) all check with them. The rules with parameters take them by keyword,
so that a table of rules holds ``functools.partial(number, above=0,
at_most=1)``.

This module imports only numpy and the error of :mod:`ema_pipeline.data`, so
that every layer above it can use it.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ema_pipeline.data import OptionError

__all__ = [
    "Rule",
    "choice",
    "flag",
    "integer",
    "is_real",
    "nonzero",
    "number",
    "optional",
    "pair",
    "refusal",
    "seconds",
    "sequence",
    "shown",
    "text",
]

#: A rule: ``rule(name, value)`` -> the value normalised, or an OptionError naming ``name``.
Rule = Callable[[str, Any], Any]


def shown(value: Any) -> str:
    """``value`` as a message shows it: a sequence as the list of its items, a
    numpy scalar as the Python number, anything else by ``repr``.

    Examples
    --------
    >>> shown((300, np.float64(100.0))), shown(np.float64(0.5)), shown("x")
    ('[300, 100.0]', '0.5', "'x'")
    """
    return repr(_plain(value))


def _plain(value: Any) -> Any:
    """Sequences as lists, numpy scalars as Python numbers (at every depth)."""
    if isinstance(value, tuple | list | np.ndarray):
        return [_plain(x) for x in value]
    return value.item() if isinstance(value, np.generic) else value


def refusal(name: str, rule: str, value: Any) -> OptionError:
    """The error of a value that breaks a rule: ``"<name> must be <rule>, got <value>"``.

    Examples
    --------
    >>> error = refusal("method", "one of 'plscf', 'sdypy-lscf'", "magic")
    >>> str(error), error.field
    ("method must be one of 'plscf', 'sdypy-lscf', got 'magic'", 'method')
    """
    return OptionError(name, f"must be {rule}, got {shown(value)}")


def is_real(value: Any) -> bool:
    """Whether ``value`` is a real number (an int, a float, a numpy scalar), not a bool.

    Examples
    --------
    >>> [is_real(v) for v in (1, 2.5, np.float32(1), True, "1", 1j)]
    [True, True, True, False, False, False]
    """
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def _written(x: float) -> str:
    return str(x) if isinstance(x, int) else f"{x:g}"


def _bounds(above: float | None, at_least: float | None, below: float | None,
            at_most: float | None) -> str:
    """The range in words: ``" > 0"``, ``" <= 400"``, ``" in (0, 1]"`` or ``""``."""
    lo = above if above is not None else at_least
    hi = below if below is not None else at_most
    if lo is not None and hi is not None:
        return (f" in {'(' if above is not None else '['}{_written(lo)}, "
                f"{_written(hi)}{')' if below is not None else ']'}")
    if lo is not None:
        return f" {'>' if above is not None else '>='} {_written(lo)}"
    if hi is not None:
        return f" {'<' if below is not None else '<='} {_written(hi)}"
    return ""


def _inside(x: float, above: float | None, at_least: float | None, below: float | None,
            at_most: float | None) -> bool:
    return ((above is None or x > above) and (at_least is None or x >= at_least)
            and (below is None or x < below) and (at_most is None or x <= at_most))


def number(name: str, value: Any, *, above: float | None = None, at_least: float | None = None,
           below: float | None = None, at_most: float | None = None, finite: bool = True,
           noun: str = "number") -> float:
    """``value`` as a float when it is a real number (not a bool, not NaN) in
    the range: greater than ``above``, at least ``at_least``, less than
    ``below``, at most ``at_most`` (each None: no such bound). ``finite=False``
    lets +-inf pass (a limit of "none"). ``noun`` names the quantity in the
    message (``"number of seconds"``).

    Examples
    --------
    >>> number("min_fraction", 1, above=0, at_most=1)
    1.0
    >>> number("min_fraction", 0.0, above=0, at_most=1)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: min_fraction must be a number in (0, 1], got 0.0
    >>> number("snr_db", float("inf"), at_most=400)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: snr_db must be a finite number <= 400, got inf
    >>> number("max_rel_zeta_std", float("inf"), at_least=0, finite=False)
    inf
    """
    try:
        x = float(value) if is_real(value) else math.nan
    except OverflowError:  # an int too large for a float
        x = math.inf
    if not (math.isfinite(x) or (not finite and math.isinf(x))) or not _inside(
            x, above, at_least, below, at_most):
        two_sided = (above, at_least) != (None, None) and (below, at_most) != (None, None)
        article = "a finite " if finite and not two_sided else "a "
        raise refusal(name, f"{article}{noun}{_bounds(above, at_least, below, at_most)}", value)
    return x


def seconds(name: str, value: Any, *, at_most: float | None = None, zero: bool = False) -> float:
    """``value`` as a float when it is a finite time in s above 0 (at least 0
    with ``zero``), at most ``at_most``.

    Examples
    --------
    >>> seconds("pretrigger_s", 0, at_most=1e3, zero=True)
    0.0
    >>> seconds("exp_window_tau_s", -1.0)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: exp_window_tau_s must be a finite number of seconds > 0, got -1.0
    """
    return number(name, value, above=None if zero else 0.0, at_least=0.0 if zero else None,
                  at_most=at_most, noun="number of seconds")


def nonzero(name: str, value: Any) -> float:
    """``value`` as a float when it is a finite real number other than 0 (a scale factor).

    Examples
    --------
    >>> nonzero("scale", -2)
    -2.0
    >>> nonzero("scale", 0)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: scale must be a finite non-zero number, got 0
    """
    if not (is_real(value) and math.isfinite(value) and value != 0):
        raise refusal(name, "a finite non-zero number", value)
    return float(value)


def integer(name: str, value: Any, *, above: int | None = None, at_least: int | None = None,
            at_most: int | None = None) -> int:
    """``value`` as an int when it is an integer (a Python or numpy integer, not
    a bool) greater than ``above``, at least ``at_least``, at most ``at_most``.

    Examples
    --------
    >>> integer("n_modes", 50, at_least=1, at_most=50)
    50
    >>> integer("n_modes", 3.0, at_least=1, at_most=50)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: n_modes must be an integer in [1, 50], got 3.0
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral) or not (
            _inside(int(value), above, at_least, None, at_most)):
        raise refusal(name, f"an integer{_bounds(above, at_least, None, at_most)}", value)
    return int(value)


def pair(name: str, value: Any, *, at_least: float | None = None,
         unit: str = "") -> tuple[float, float]:
    """``value`` as (low, high) floats when it is two finite real numbers with
    low < high (and ``at_least`` <= low); ``unit`` is said in the message.

    Examples
    --------
    >>> pair("band_hz", [5, 395], at_least=0, unit="Hz")
    (5.0, 395.0)
    >>> pair("band_hz", (300, 100), at_least=0, unit="Hz")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: band_hz must be (low, high) in Hz with 0 <= low < high, ...
    """
    low = "low" if at_least is None else f"{_written(at_least)} <= low"
    rule = f"(low, high){f' in {unit}' if unit else ''} with {low} < high, both finite"
    ok = (isinstance(value, tuple | list | np.ndarray) and len(value) == 2
          and all(is_real(x) and math.isfinite(x) for x in value))
    if not (ok and (at_least is None or value[0] >= at_least) and value[0] < value[1]):
        raise refusal(name, rule, value)
    return float(value[0]), float(value[1])


def choice(name: str, value: Any, *, names: Sequence[str]) -> str:
    """``value`` when it is one of the strings ``names``.

    Examples
    --------
    >>> choice("estimator", "H1", names=("H1", "H2", "Hv"))
    'H1'
    >>> choice("estimator", "h1", names=("H1", "H2", "Hv"))
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: estimator must be one of 'H1', 'H2', 'Hv', got 'h1'
    """
    if not isinstance(value, str) or value not in names:
        raise refusal(name, f"one of {', '.join(map(repr, names))}", value)
    return value


def flag(name: str, value: Any) -> bool:
    """``value`` when it is a boolean (``True``/``False``; TOML's ``true``/``false``).

    Examples
    --------
    >>> flag("refine", False)
    False
    >>> flag("refine", 1)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: refine must be a boolean (true or false), got 1
    """
    if not isinstance(value, bool | np.bool_):
        raise refusal(name, "a boolean (true or false)", value)
    return bool(value)


def text(name: str, value: Any) -> str:
    """``value`` when it is a string.

    Examples
    --------
    >>> text("description", "beam in air")
    'beam in air'
    >>> text("description", 3)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: description must be a string, got 3
    """
    if not isinstance(value, str):
        raise refusal(name, "a string", value)
    return value


def sequence(name: str, value: Any, *, item: Rule, min_len: int = 0,
             max_len: int | None = None) -> tuple:
    """``value`` (a list, tuple or array) as a tuple of its entries, each
    checked by ``item``, when it has ``min_len`` to ``max_len`` entries. A bad
    entry is named by its position (``"entry 2 must be ..."``).

    Examples
    --------
    >>> from functools import partial
    >>> sequence("response_nodes", [3, 6], item=integer, min_len=1)
    (3, 6)
    >>> sequence("expect_hz", [18.0, -5.0], item=partial(number, above=0))
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: expect_hz entry 2 must be a finite number > 0, got -5.0
    >>> sequence("band_edge", (0.1,), item=number, min_len=2, max_len=2)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: band_edge must have 2 entries, got 1
    """
    if not isinstance(value, list | tuple | np.ndarray):
        raise refusal(name, "a list", value)
    if len(value) < min_len or max_len is not None and len(value) > max_len:
        n = (f"at least {min_len}" if max_len is None else f"{min_len}" if max_len == min_len
             else f"{min_len} to {max_len}")
        raise OptionError(name, f"must have {n} entries, got {len(value)}")
    out = []
    for k, x in enumerate(value, start=1):
        try:
            out.append(item(name, x))
        except OptionError as exc:
            raise OptionError(name, f"entry {k} {exc.reason}") from None
    return tuple(out)


def optional(rule: Rule) -> Rule:
    """``rule`` that lets ``None`` pass (the setting's default).

    Examples
    --------
    >>> check = optional(seconds)
    >>> check("exp_window_tau_s", None), check("exp_window_tau_s", 2)
    (None, 2.0)
    """
    return lambda name, value: None if value is None else rule(name, value)
