"""What the command line's modules share: exit statuses and where messages go.

The exit statuses are the contract of every subcommand (see :mod:`ema_pipeline.cli`);
:func:`capture_warnings` and :func:`verbose_logging` set up, once per run, where
the libraries' warnings and the package's INFO messages end up;
:func:`command_workers` is the worker count a command passes on.
"""

from __future__ import annotations

import logging
import os

from ema_pipeline.data import ConfigError
from ema_pipeline.pipeline.logs import verbose_logging

__all__ = [
    "EXIT_INPUT",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_RUNTIME",
    "EXIT_STATUSES",
    "LOG_ENV",
    "WORKERS_ENV",
    "command_workers",
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
#: Environment variable: the worker processes of a command without ``--workers``.
WORKERS_ENV = "EMA_PIPELINE_WORKERS"


def command_workers(requested: int | None) -> int:
    """The worker processes of a command: ``--workers`` (``requested``), else
    ``$EMA_PIPELINE_WORKERS``, else the cores this process may use. The one
    place the environment's worker count is read; the library gets it as an
    argument.

    Raises
    ------
    ConfigError
        ``--workers`` below 1, or a variable that is not a positive integer.

    Examples
    --------
    >>> command_workers(3)
    3
    """
    from ema_pipeline.runner import available_cores
    from ema_pipeline.threads import positive_int_setting

    if requested is not None:
        if requested < 1:
            raise ConfigError(f"--workers must be at least 1, got {requested}")
        return int(requested)
    text = os.environ.get(WORKERS_ENV, "").strip()
    return positive_int_setting(WORKERS_ENV, text) if text else available_cores()


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
