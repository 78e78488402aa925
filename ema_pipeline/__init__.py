"""ema-pipeline: experimental modal analysis from impact-test FRFs to modal and
local added mass (see README.md).

The package's own names (:class:`FRFSet`, :class:`ModalParameters`, ...) come
from :mod:`ema_pipeline.data` when first used, so that importing a part of the
package (the command line's entry point, :mod:`ema_pipeline.threads`) does not
load numpy: the entry point sets the process's BLAS thread variables before
numpy and scipy load their BLAS libraries (:func:`ema_pipeline.cli.run`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ema_pipeline.lazy import lazy_exports

if TYPE_CHECKING:
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

# the names of ema_pipeline.data in __all__, imported on first use
__getattr__, __dir__ = lazy_exports(__name__, {name: "data" for name in __all__
                                               if name != "__version__"})
