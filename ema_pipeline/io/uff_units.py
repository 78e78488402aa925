"""Units of Universal File records: unit labels, dataset 164 and unit exponents.

The unit factors and the label parser live in :mod:`ema_pipeline.units` (their
one home, re-exported here); this module adds the Universal File rules.

A unit label such as ``g/N``, ``(m/s)/N``, ``(1/N)*(m/s^2)``, ``m/s2/N``,
``in/s^2/lbf`` or ``m / s^2 / N`` is parsed by a small recursive-descent
parser into an SI factor and the exponents of metre, second and newton, from
which the FRF quantity follows (m s^-2 N^-1 = accelerance, m s^-1 N^-1 =
mobility, m N^-1 = receptance). Written here rather than taken from a units
library (pint, astropy) because those know neither ``g`` as the standard
gravity, nor ``s2`` for s^2, nor the text damage real files carry (``m/s≤``,
``m/sÂ²``: a superscript two written in one code page and read in another).

Rules
-----
* Label grammar: ``expr := term (('/' | '*' | '.' | '·' | 'per' | juxtaposition) term)*``,
  left-associative (``m/s^2/N`` = (m/s^2)/N); ``term := unit [exponent] | '(' expr ')'
  [exponent] | number``; exponent ``^n``, ``**n``, trailing digits (``s2``) or
  superscripts (``²``, ``³``, ``⁻¹``). Case matters only where it must (``mN`` vs
  ``MN`` are not distinguished: both unusual; ``g``/``G`` is the standard gravity
  9.80665 m/s^2, never the gram).
* A dataset 164 gives the factors of the file's unit system: a value in file
  units divided by ``length_factor**L * force_factor**F`` is SI, with L and F
  the length and force exponents of the value's dimension.
* The exponents come from the UFF table (Addendum A of dataset 58) for a
  specific data type (displacement, velocity, acceleration, force, ...) and
  from the record's own exponent fields for the data types "unknown" (0) and
  "general" (1), as the specification says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ema_pipeline.units import (  # re-exported: the UFF readers use them from here
    DIMENSIONLESS,
    FOOT_M,
    INCH_M,
    KGF_N,
    LBF_N,
    POUNDAL_N,
    QUANTITY_DIMS,
    SIGNAL_DIMS,
    STANDARD_GRAVITY,
    Unit,
    clean_label,
    is_blank_label,
    parse_unit_label,
)

__all__ = [
    "DIMENSIONLESS", "FOOT_M", "INCH_M", "KGF_N", "LBF_N", "POUNDAL_N", "QUANTITY_DIMS",
    "SIGNAL_DIMS", "STANDARD_GRAVITY", "Unit", "clean_label", "is_blank_label",
    "parse_unit_label", "TYPE_QUANTITY", "QUANTITY_TYPE", "FORCE_TYPES", "UNIT_SYSTEMS",
    "UnitSystem", "SI", "type_exponents", "type_unit",
]

# UFF Addendum A: (length, force) exponents per specific data type, translational
# and rotational direction. Temperature is not needed for FRFs.
_TYPE_EXPONENTS: dict[int, tuple[tuple[int, int], tuple[int, int]]] = {
    2: ((-2, 1), (-1, 1)),  # stress
    3: ((0, 0), (0, 0)),  # strain
    5: ((0, 0), (0, 0)),  # temperature
    6: ((1, 1), (1, 1)),  # heat flux
    8: ((1, 0), (0, 0)),  # displacement
    9: ((0, 1), (1, 1)),  # reaction force
    11: ((1, 0), (0, 0)),  # velocity
    12: ((1, 0), (0, 0)),  # acceleration
    13: ((0, 1), (1, 1)),  # excitation force
    15: ((-2, 1), (-1, 1)),  # pressure
    16: ((-1, 1), (-1, 1)),  # mass
    17: ((0, 0), (0, 0)),  # time
    18: ((0, 0), (0, 0)),  # frequency
    19: ((0, 0), (0, 0)),  # rpm
    20: ((0, 0), (0, 0)),  # order
}
#: Time exponent of the specific data types that carry one (displacement 8,
#: velocity 11, acceleration 12); the UFF unit system has no time unit.
_TYPE_TIME = {8: 0, 11: -1, 12: -2}
#: FRF quantity of a specific data type of the ordinate numerator.
TYPE_QUANTITY = {8: "receptance", 11: "mobility", 12: "accelerance"}
QUANTITY_TYPE = {v: k for k, v in TYPE_QUANTITY.items()}
FORCE_TYPES = (9, 13)

#: Standard factors of the dataset-164 unit codes (length, force): file units per SI unit.
UNIT_SYSTEMS: dict[int, tuple[str, float, float]] = {
    1: ("SI: Meter (newton)", 1.0, 1.0),
    2: ("BG: Foot (pound f)", 1 / FOOT_M, 1 / LBF_N),
    3: ("MG: Meter (kilogram f)", 1.0, 1 / KGF_N),
    4: ("BA: Foot (poundal)", 1 / FOOT_M, 1 / POUNDAL_N),
    5: ("MM: mm (milli newton)", 1e3, 1e3),
    6: ("CM: cm (centi newton)", 1e2, 1e2),
    7: ("IN: Inch (pound f)", 1 / INCH_M, 1 / LBF_N),
    8: ("GM: mm (kilogram f)", 1e3, 1 / KGF_N),
}


@dataclass(frozen=True)
class UnitSystem:
    """A dataset 164: file units per SI unit (a file value / factor = SI value)."""

    length_factor: float = 1.0
    force_factor: float = 1.0
    code: int = 1
    description: str = "SI (default: no dataset 164)"

    def to_si(self, length_exp: int, force_exp: int) -> float:
        """Factor that turns a file value of dimension length^L force^F into SI."""
        return 1.0 / (self.length_factor**length_exp * self.force_factor**force_exp)

    @property
    def is_si(self) -> bool:
        return math.isclose(self.length_factor, 1.0) and math.isclose(self.force_factor, 1.0)


SI = UnitSystem()


def type_exponents(
    data_type: int, length_exp: int, force_exp: int, direction: int = 1
) -> tuple[int, int]:
    """(length, force) exponents of a record field: the UFF table for a specific
    data type, the record's own fields for unknown (0) and general (1)."""
    if data_type in _TYPE_EXPONENTS:
        trans, rot = _TYPE_EXPONENTS[data_type]
        return rot if abs(direction) in (4, 5, 6) else trans
    return int(length_exp), int(force_exp)


def type_unit(data_type: int, length_exp: int, force_exp: int, system: UnitSystem,
              direction: int = 1) -> Unit | None:
    """Unit of a record field from its specific data type and the dataset-164
    system, or None when the data type does not tell the time dimension
    (needed to tell accelerance, mobility and receptance apart)."""
    L, F = type_exponents(data_type, length_exp, force_exp, direction)
    if data_type in _TYPE_TIME:
        time = _TYPE_TIME[data_type]
    elif data_type in FORCE_TYPES or data_type == 0 and (L, F) == (0, 0):
        time = 0
    else:
        return None
    return Unit(system.to_si(L, F), (L, time, F), f"file units L^{L} F^{F}")
