"""The package's log on stderr (``--verbose``): one home for its set-up, used by
the command line and by the batch worker processes (which do not inherit the
parent's logging set-up)."""

from __future__ import annotations

import logging
import sys

__all__ = ["verbose_logging"]


def verbose_logging() -> None:
    """``--verbose``: the package's INFO messages (skipped UFF datasets, ...) on stderr.

    Examples
    --------
    >>> verbose_logging()
    >>> logging.getLogger("ema_pipeline").level == logging.INFO
    True
    >>> logging.getLogger("ema_pipeline").handlers.clear()
    >>> logging.getLogger("ema_pipeline").setLevel(logging.NOTSET)
    """
    log = logging.getLogger("ema_pipeline")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("ema-pipeline: %(message)s"))
    log.addHandler(handler)
    log.setLevel(logging.INFO)
