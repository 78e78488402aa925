"""Command-line interface of ema-pipeline (thin: parses, calls the library, prints).

Exit status: 0 success; 2 input or usage error (bad option, bad experiment
file, unreadable or implausible input file, settings the data cannot support);
1 runtime failure (disk full, out of memory, a study with problems, a batch with
failed files). Every error is one line on stderr; warnings of the libraries
(numpy, h5py, pyuff, sdypy) go to the ``py.warnings`` log (a file when
``EMA_PIPELINE_LOG`` names one), not to the terminal.

Modules: :mod:`~ema_pipeline.cli.parser` (the argparse declarations),
:mod:`~ema_pipeline.cli.commands` (one handler per subcommand),
:mod:`~ema_pipeline.cli.entry` (:func:`main` and its error handling) and
:mod:`~ema_pipeline.cli.support` (exit statuses, warnings and logging set-up).
``python -m ema_pipeline.cli``, ``python -m ema_pipeline`` and the ``ema-pipeline``
script run :func:`run`, the process's entry point. This package loads
nothing else until it is used (:func:`main` and :func:`build_parser` are
imported on first use), so that :func:`run` sets the BLAS thread variables
before numpy loads.
"""

from __future__ import annotations

import gc
import os
from typing import TYPE_CHECKING

from ema_pipeline.cli.startup import mark_own_process, start_up_imports
from ema_pipeline.lazy import lazy_exports
from ema_pipeline.threads import entry_thread_environment

if TYPE_CHECKING:
    from ema_pipeline.cli.entry import main
    from ema_pipeline.cli.parser import build_parser

__all__ = ["build_parser", "main", "run"]


def run() -> int:
    """The process's own entry point (the ``ema-pipeline`` script, ``python -m
    ema_pipeline``): the thread variables set for the whole process
    (:func:`ema_pipeline.threads.entry_thread_environment`) before numpy and
    scipy load, so that their BLAS libraries start no threads beside the
    one that does the work; then :func:`main`; then the objects that exist
    at that moment frozen (``gc.freeze``), so that the interpreter's exit
    does not walk them all again in its final garbage collections (the walk
    over the objects of numpy, scipy and h5py was a measurable share of
    every command: docs/validation.md). Every output is written, closed and
    renamed into place before :func:`main` returns, and the exit handlers
    (``atexit``) still run. Code that calls :func:`main` in its own process
    (the tests) is not affected.

    Examples
    --------
    >>> import subprocess, sys, tempfile
    >>> code = ("import atexit, gc, os, sys; from ema_pipeline.cli import run; "
    ...         "sys.argv = ['ema-pipeline', 'identify', 'missing.uff', '--out', 'out']; "
    ...         "atexit.register(lambda: print(gc.get_freeze_count() > 0, "
    ...         "os.environ['OPENBLAS_NUM_THREADS'])); sys.exit(run())")
    >>> env = {k: v for k, v in os.environ.items() if k != "EMA_PIPELINE_BLAS_THREADS"}
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     done = subprocess.run([sys.executable, "-c", code], cwd=folder, env=env,
    ...                           capture_output=True, text=True)
    >>> done.returncode, done.stdout.strip()
    (2, 'True 1')
    """
    os.environ.update(entry_thread_environment())
    mark_own_process()
    with start_up_imports():
        from ema_pipeline.cli.entry import main  # numpy and scipy load from here on

    status = main()
    gc.freeze()
    return status


# main and build_parser, imported on first use
__getattr__, __dir__ = lazy_exports(__name__, {"main": "entry", "build_parser": "parser"})
