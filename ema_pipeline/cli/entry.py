"""The command line's :func:`main`: parse, run the subcommand's handler, and
turn exceptions into one-line errors on stderr and the exit statuses of
:mod:`ema_pipeline.cli.support` (the process's entry point is
:func:`ema_pipeline.cli.run`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from ema_pipeline.cli.parser import build_parser
from ema_pipeline.cli.support import (
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_RUNTIME,
    capture_warnings,
    verbose_logging,
)
from ema_pipeline.data import EMAError
from ema_pipeline.threads import owned_blas_threads, thread_variables

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run ``ema-pipeline ARGV`` (default ``sys.argv[1:]``) and return its exit status.

    The command owns its threads (:mod:`ema_pipeline.threads`): one BLAS
    thread in this process and its workers, whatever the environment's
    ``OPENBLAS_NUM_THREADS`` and its kind say, unless ``$EMA_PIPELINE_BLAS_THREADS``
    overrides; the libraries loaded and the processes started during the
    command read the variables set here, restored when it returns."""
    capture_warnings()
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "verbose", False):
        verbose_logging()
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        with thread_variables(), owned_blas_threads():
            return func(args)
    except EMAError as exc:  # bad input or settings (DataError, ConfigError)
        print(f"ema-pipeline {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_INPUT
    except OSError as exc:  # unwritable output folder, disk full, ...
        where = f" {exc.filename}:" if getattr(exc, "filename", None) else ""
        print(f"ema-pipeline {args.command}: error:{where} {_one_line(exc.strerror or exc)}",
              file=sys.stderr)
        return EXIT_RUNTIME
    except MemoryError:
        print(f"ema-pipeline {args.command}: error: out of memory; lower the order or narrow "
              "the band (see --memory-limit-gb)", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt:
        print(f"ema-pipeline {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _one_line(message: object) -> str:
    """An error message on one line."""
    return " ".join(str(message).split())
