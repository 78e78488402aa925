"""Command-line interface of ema-pipeline (thin: parses, calls the library, prints).

Exit status: 0 success; 2 input or usage error (bad option, bad experiment
file, unreadable or implausible input file, settings the data cannot support);
1 runtime failure (disk full, out of memory, a study with problems, a batch with
failed files). Every error is one line on stderr; warnings of the libraries
(numpy, h5py, pyuff, sdypy) go to the ``py.warnings`` log (a file when
``EMA_PIPELINE_LOG`` names one), not to the terminal.

Modules: :mod:`~ema_pipeline.cli.parser` (the argparse declarations),
:mod:`~ema_pipeline.cli.commands` (one handler per subcommand),
:mod:`~ema_pipeline.cli.entry` (:func:`main` and its error handling, :func:`run`
the process's entry point) and
:mod:`~ema_pipeline.cli.support` (exit statuses, warnings and logging set-up).
``python -m ema_pipeline.cli``, ``python -m ema_pipeline`` and the ``ema-pipeline``
script run :func:`run`.
"""

from ema_pipeline.cli.entry import main, run
from ema_pipeline.cli.parser import build_parser

__all__ = ["build_parser", "main", "run"]
