"""Small typed containers that the pipeline stages pass to each other.

Only plain numpy arrays and scalars live here; file layouts are the business of
:mod:`ema_pipeline.io`. Every container validates itself on construction so that
bad data is rejected at the border of the library, with a message that names the
problem (and the source file, when there is one), instead of failing later deep
inside numpy.

Every name is imported from here (``from ema_pipeline.data import FRFSet``); the
modules hold one concern each: :mod:`.errors` (the error classes),
:mod:`.quantities` (FRF quantities and their conversion, plausible frequency
axes), :mod:`.tables` (:class:`Table` and the notebook tables), :mod:`.frf`
(:class:`DOF`, :class:`AcquisitionInfo`, :class:`Provenance`, :class:`FRFSet`),
:mod:`.records` (:class:`TimeRecords`, :class:`Channel`, :class:`Recording`),
:mod:`.modes` (:func:`damped`, :class:`ModalParameters`, :class:`Beam`) and
:mod:`.geometry` (:class:`Geometry`, :class:`DofMap`).
"""

from ema_pipeline.data.errors import ConfigError, DataError, EMAError, OptionError
from ema_pipeline.data.frf import DOF, AcquisitionInfo, FRFSet, Provenance
from ema_pipeline.data.geometry import DofMap, Geometry
from ema_pipeline.data.modes import Beam, ModalParameters, damped
from ema_pipeline.data.quantities import (
    MAX_AXIS_HZ,
    MIN_DF_HZ,
    MIN_FRF_LINES,
    QUANTITY_POWER,
    QUANTITY_UNITS,
    Quantity,
    axis_is_uniform,
    quantity_factor,
    quantity_power,
)
from ema_pipeline.data.records import CHANNEL_SI_UNITS, Channel, Recording, TimeRecords
from ema_pipeline.data.tables import Table, notebook_table_html, std_column

__all__ = [
    "Quantity", "QUANTITY_UNITS", "QUANTITY_POWER", "MIN_FRF_LINES", "MIN_DF_HZ",
    "MAX_AXIS_HZ", "EMAError", "ConfigError", "DataError", "OptionError", "quantity_power",
    "quantity_factor", "axis_is_uniform", "std_column", "notebook_table_html", "Table", "DOF",
    "AcquisitionInfo", "Provenance", "FRFSet", "TimeRecords", "CHANNEL_SI_UNITS", "Channel",
    "Recording", "damped", "ModalParameters", "Beam", "DofMap", "Geometry",
]
