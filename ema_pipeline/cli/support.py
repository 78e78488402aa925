"""What the command line's modules share: exit statuses and where messages go.

The exit statuses are the contract of every subcommand (see :mod:`ema_pipeline.cli`);
:func:`capture_warnings` and :func:`verbose_logging` set up, once per run, where
the libraries' warnings and the package's INFO messages end up.
"""

from __future__ import annotations

import logging
import os

from ema_pipeline.pipeline.logs import verbose_logging

__all__ = [
    "EXIT_INPUT",
    "EXIT_OK",
    "EXIT_RUNTIME",
    "EXIT_USAGE",
    "LOG_ENV",
    "capture_warnings",
    "verbose_logging",
]

#: Exit statuses: 0 success, 2 input or usage error, 1 runtime failure.
EXIT_OK, EXIT_INPUT, EXIT_USAGE = 0, 1, 2
EXIT_RUNTIME = EXIT_INPUT  # 1: runtime failure; input errors exit with EXIT_USAGE (2)
#: Environment variable naming a log file for library warnings (default: discarded).
LOG_ENV = "EMA_PIPELINE_LOG"


def capture_warnings() -> None:
    """Route ``warnings`` (numpy, h5py, pyuff, sdypy) into the ``py.warnings``
    logger: a file when ``$EMA_PIPELINE_LOG`` is set, else nowhere."""
    logging.captureWarnings(True)
    log = logging.getLogger("py.warnings")
    log.propagate = False
    if not log.handlers:
        target = os.environ.get(LOG_ENV)
        handler: logging.Handler = logging.NullHandler()
        if target:
            try:
                handler = logging.FileHandler(target, delay=True)
            except OSError:
                pass
        log.addHandler(handler)
