"""The errors ema-pipeline raises on bad input or settings.

Their home is :mod:`ema_pipeline.data` (``from ema_pipeline.data import
DataError``), and a traceback names them there
(``ema_pipeline.data.DataError: ...``), as the users' code catches them.
"""

from __future__ import annotations


class EMAError(Exception):
    """Base class of the errors ema-pipeline raises on bad input or settings."""

    __module__ = "ema_pipeline.data"  # the public home, as tracebacks name it


class ConfigError(EMAError, ValueError):
    """A usage or configuration problem (unknown name, unreadable experiment file)."""

    __module__ = "ema_pipeline.data"


class DataError(EMAError, ValueError):
    """Input data that cannot be used (wrong shape, NaN, unknown units, ...).

    The message names the source (file) when known.
    """

    __module__ = "ema_pipeline.data"


class OptionError(ConfigError):
    """An impossible value of a field of an option record
    (:class:`~ema_pipeline.identification.IdentificationOptions`,
    :class:`~ema_pipeline.identification.SelectionThresholds`): ``field`` names
    it, ``reason`` says what it must be and what it got. The command line and
    the experiment file put their own name of the field (``--max-order``,
    ``[identification] max_order``) before the reason.

    Examples
    --------
    >>> str(OptionError("min_fraction", "must be a number in (0, 1], got 5"))
    'min_fraction must be a number in (0, 1], got 5'
    """

    __module__ = "ema_pipeline.data"

    def __init__(self, field: str, reason: str) -> None:
        self.field, self.reason = field, reason
        super().__init__(f"{field} {reason}")
