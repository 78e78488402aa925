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
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_RUNTIME",
    "EXIT_STATUSES",
    "LOG_ENV",
    "capture_warnings",
    "verbose_logging",
]

#: Exit status of success.
EXIT_OK = 0
#: Exit status of an input or usage error: a bad option, experiment file or input
#: file, settings the data cannot support (an :class:`~ema_pipeline.data.EMAError`).
EXIT_INPUT = 2
#: Exit status of a runtime failure: disk full, out of memory, a study with
#: problems, a batch with failed files.
EXIT_RUNTIME = 1
#: Exit status of a command interrupted by Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130
#: What each exit status means, in the words of the README and ``docs/cli.rst``.
EXIT_STATUSES = {EXIT_OK: "success", EXIT_INPUT: "input or usage error",
                 EXIT_RUNTIME: "runtime failure"}
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
