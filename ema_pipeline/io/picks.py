"""Picks files (TOML): the poles a user picked in the report's stabilization
diagram, for ``ema-pipeline identify FILE --picks PICKS.toml``. The one home
of the layout: its version, its keys and its comments, the writer
(:func:`picks_toml`) and the reader (:func:`picks_from_mapping`).

The layout (version :data:`PICKS_VERSION`)::

    # ema-pipeline picks: ...            (the comment lines of HEADER)
    version = 1

    [diagram]  # the settings that reproduce the stabilization diagram
    band_hz = [5.0, 790.0]                (Hz)
    orders = [2, 4, ..., 64]              (the model orders of the diagram)
    weighting = "none"                    (an IdentificationOptions weighting)
    # poles fitted alongside ...          (optional, COMPANIONS_COMMENT)
    companions = [[-2.5, 300.0], ...]     (rad/s, before the window correction)

    [[pick]]                              (one per mode)
    freq_hz = 30.0                        (Hz, window-corrected)
    zeta = 0.01                           (ratio; nan when not known)
    order = 40                            (a pole of the diagram at this order, or)
    pole = [-1.9, 188.5]                  (a mode's start pole by value, rad/s)

A file without ``version`` (written before the key) is read as version 1;
a later version, an unknown key and a value of the wrong kind are errors
naming the file. Floats are written in full precision (``repr``; ``nan`` for
NaN). The report's interactive diagram writes this layout from its script
(:mod:`ema_pipeline.report.stab_diagram`); ``tests/test_picks_format.py``
checks that the two agree. The picks as data are
:class:`~ema_pipeline.identification.picked.Picks`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ema_pipeline.data import DataError, OptionError
from ema_pipeline.identification.options import check_option
from ema_pipeline.identification.picked import PICK_TOL_REL, Pick, Picks
from ema_pipeline.io.files import read_toml, write_text

__all__ = [
    "COMPANIONS_COMMENT",
    "DIAGRAM_KEYS",
    "HEADER",
    "PICKS_VERSION",
    "PICK_KEYS",
    "picks_from_mapping",
    "picks_toml",
    "read_picks",
    "write_picks",
]

#: The version of the layout, written as the top-level key ``version``.
PICKS_VERSION = 1
#: The comment lines the file starts with.
HEADER: tuple[str, ...] = (
    "# ema-pipeline picks: `ema-pipeline identify FILE --picks THIS_FILE` fits exactly",
    "# these poles (refinement, LSFD and uncertainty as for automatic modes).",
    "# A pick with `order` is the pole of that model order nearest to freq_hz",
    f"# (within {100 * PICK_TOL_REL:g} %); a pick with `pole` (rad/s) is the start pole "
    "of a mode the",
    "# automatic selection kept, taken as given.",
)
#: The comment beside the ``[diagram]`` header.
DIAGRAM_COMMENT = "# the settings that reproduce the stabilization diagram"
#: The comment lines above ``companions``.
COMPANIONS_COMMENT: tuple[str, ...] = (
    "# poles fitted alongside the picks, not reported: candidates the automatic",
    "# selection refined with its modes and then dropped (rad/s)",
)
#: The keys of ``[diagram]`` and of each ``[[pick]]``, in the order written.
DIAGRAM_KEYS: tuple[str, ...] = ("band_hz", "orders", "weighting", "companions")
PICK_KEYS: tuple[str, ...] = ("freq_hz", "zeta", "order", "pole")
#: The top-level keys and tables.
TOP_KEYS: tuple[str, ...] = ("version", "diagram", "pick")


def _num(x: float) -> str:
    """A float as TOML (``nan`` for NaN, full precision)."""
    return "nan" if not math.isfinite(x) else repr(float(x))


def picks_toml(picks: Picks) -> str:
    """The text of the picks file of ``picks`` (the layout of this module).

    Examples
    --------
    >>> import tomllib
    >>> p = Picks((5.0, 100.0), (2, 4, 6), (Pick(30.0, 0.01, order=6),))
    >>> print(picks_toml(p).split("\\n\\n", 1)[1])  # after the header
    [diagram]  # the settings that reproduce the stabilization diagram
    band_hz = [5.0, 100.0]
    orders = [2, 4, 6]
    weighting = "none"
    <BLANKLINE>
    [[pick]]
    freq_hz = 30.0
    zeta = 0.01
    order = 6
    <BLANKLINE>
    >>> picks_from_mapping(tomllib.loads(picks_toml(p))) == p
    True
    """
    lines = [*HEADER, f"version = {PICKS_VERSION}", "",
             f"[diagram]  {DIAGRAM_COMMENT}",
             f"band_hz = [{_num(picks.band_hz[0])}, {_num(picks.band_hz[1])}]",
             f"orders = [{', '.join(str(int(o)) for o in picks.orders)}]",
             f'weighting = "{picks.weighting}"']
    if picks.companions:
        lines += [*COMPANIONS_COMMENT,
                  "companions = [" + ", ".join(f"[{_num(c.real)}, {_num(c.imag)}]"
                                               for c in picks.companions) + "]"]
    for pk in picks.picks:
        lines += ["", "[[pick]]", f"freq_hz = {_num(pk.freq_hz)}", f"zeta = {_num(pk.zeta)}"]
        if pk.order is not None:
            lines.append(f"order = {int(pk.order)}")
        if pk.pole is not None:
            lines.append(f"pole = [{_num(pk.pole.real)}, {_num(pk.pole.imag)}]")
    return "\n".join(lines) + "\n"


def _unknown(where: str, given: Mapping[str, Any], known: tuple[str, ...]) -> None:
    extra = sorted(set(given) - set(known))
    if extra:
        raise DataError(f"{where}unknown key{'s' if len(extra) > 1 else ''} "
                        f"{', '.join(extra)} (known: {', '.join(known)})")


def picks_from_mapping(data: Mapping[str, Any], source: str = "") -> Picks:
    """Picks from the parsed TOML of a picks file; a missing, unknown or wrong
    key is a :class:`DataError` naming ``source`` and the key.

    Examples
    --------
    >>> picks_from_mapping({"diagram": {"band_hz": [5, 100], "orders": [2, 4]},
    ...                     "pick": [{"freq_hz": 30, "order": 4}]}).picks
    (Pick(freq_hz=30.0, zeta=nan, order=4, pole=None),)
    >>> picks_from_mapping({"diagram": {"band_hz": [5, 100], "orders": [2, 4]}}, "p.toml")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: p.toml: no [[pick]] table: pick at least one pole
    >>> picks_from_mapping({"version": 2}, "p.toml")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: p.toml: picks file version 2 is newer than this \
ema-pipeline reads (1); update ema-pipeline
    """
    where = f"{source}: " if source else ""
    _unknown(where, data, TOP_KEYS)
    version = data.get("version", PICKS_VERSION)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise DataError(f"{where}version must be a whole number >= 1, got {version!r}")
    if version > PICKS_VERSION:
        raise DataError(f"{where}picks file version {version} is newer than this "
                        f"ema-pipeline reads ({PICKS_VERSION}); update ema-pipeline")
    diagram = data.get("diagram")
    if not isinstance(diagram, Mapping):
        raise DataError(f"{where}no [diagram] table (band_hz, orders)")
    _unknown(f"{where}[diagram] ", diagram, DIAGRAM_KEYS)
    try:
        band = tuple(float(b) for b in diagram["band_hz"])
        orders = tuple(int(o) for o in diagram["orders"])
    except (KeyError, TypeError, ValueError) as exc:
        raise DataError(f"{where}[diagram] needs band_hz = [LO, HI] and orders = [...] "
                        f"({exc})") from None
    if len(band) != 2 or not band[0] < band[1] or not orders or min(orders) < 1:
        raise DataError(f"{where}[diagram] band_hz must be [LO, HI] with LO < HI and "
                        "orders positive integers")
    try:
        weighting = check_option("weighting", diagram.get("weighting", "none"))
    except OptionError as exc:
        raise DataError(f"{where}[diagram] weighting {exc.reason}") from None
    try:
        companions = tuple(complex(float(re), float(im))
                           for re, im in diagram.get("companions", []))
    except (TypeError, ValueError) as exc:
        raise DataError(f"{where}[diagram] companions must be [[RE, IM], ...] ({exc})") from None
    rows = data.get("pick")
    if not rows:
        raise DataError(f"{where}no [[pick]] table: pick at least one pole")
    if not isinstance(rows, list) or not all(isinstance(row, Mapping) for row in rows):
        raise DataError(f"{where}pick must be [[pick]] tables, one per mode")
    picks = []
    for k, row in enumerate(rows, start=1):
        _unknown(f"{where}pick {k}: ", row, PICK_KEYS)
        try:
            f = float(row["freq_hz"])
            zeta = float(row.get("zeta", float("nan")))
            order = None if row.get("order") is None else int(row["order"])
            pole = None if row.get("pole") is None else complex(*(float(v) for v in row["pole"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise DataError(f"{where}pick {k}: needs freq_hz and order, or freq_hz and "
                            f"pole = [RE, IM] ({exc!r})") from None
        if (order is None) == (pole is None):
            raise DataError(f"{where}pick {k} ({f:g} Hz): give either order (a pole of the "
                            "diagram) or pole = [RE, IM] (a mode pole), not both nor neither")
        picks.append(Pick(freq_hz=f, zeta=zeta, order=order, pole=pole))
    return Picks(band_hz=(band[0], band[1]), orders=orders, picks=tuple(picks),
                 weighting=weighting, source=source, companions=companions)


def read_picks(path: str | os.PathLike[str]) -> Picks:
    """Read a picks file; a bad file is a :class:`DataError` naming it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "picks.toml"
    ...     _ = write_picks(Picks((5.0, 100.0), (2, 4), (Pick(30.0, 0.01, order=4),)), path)
    ...     read_picks(path).picks[0].order
    4
    """
    path = Path(path)
    return picks_from_mapping(read_toml(path, "a picks file (TOML)"), str(path))


def write_picks(picks: Picks, path: str | os.PathLike[str]) -> Path:
    """Write ``picks`` as a picks file (atomically); returns the path."""
    return write_text(picks_toml(picks), Path(path))
