"""ema-pipeline: experimental modal analysis from impact-test FRFs to modal and
local added mass (see README.md)."""

from ema_pipeline.data import (
    DOF,
    AcquisitionInfo,
    DataError,
    EMAError,
    FRFSet,
    ModalParameters,
    Provenance,
)

__version__ = "0.1.0"

__all__ = [
    "DOF",
    "AcquisitionInfo",
    "DataError",
    "EMAError",
    "FRFSet",
    "ModalParameters",
    "Provenance",
    "__version__",
]
