"""Several FRF files of one ``identify`` command, identified side by side in
worker processes, with the results given back in the order of the files.

Each file is independent (its own outputs, its own identification), so the
outputs are those of a serial run, byte for byte; only the wall time changes.
Workers are forked from the command's process, which has imported the
identification chain and opened no file by then (a fork costs milliseconds,
a fresh interpreter 2-3 s of imports), and inherit its one BLAS thread
(:mod:`ema_pipeline.threads`); a worker starts no workers of its own (the
windows of a dense band are searched in the process that has the file).
``$EMA_PIPELINE_WORKERS=1`` runs the files in the process itself.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path

from ema_pipeline.data import ConfigError, Geometry
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.picked import Picks
from ema_pipeline.pipeline.reports import write_identify_report
from ema_pipeline.pipeline.single import FileOutcome, identify_file, output_paths
from ema_pipeline.threads import process_imap

__all__ = ["FileJob", "identify_files"]


@dataclass(frozen=True)
class FileJob:
    """What ``identify`` does with each file: identification options, and
    which outputs beside ``<stem>_modes.csv`` and ``<stem>_result.h5``."""

    out_dir: Path
    options: IdentificationOptions
    report: bool = False  # <stem>_report.html
    figures: bool = True  # the report's figures
    uff: bool = False  # <stem>_modes.uff
    picks: Picks | None = None
    geometry: Geometry | None = None


def identify_one(path: Path, job: FileJob) -> tuple[FileOutcome, Path | None]:
    """One file: identified, its outputs written, its report page when asked.

    Returns the outcome without the FRFs and the result (what the caller
    prints) and the report page (``None`` without one)."""
    outcome = identify_file(path, job.out_dir, job.options, keep=job.report, uff=job.uff,
                            picks=job.picks)
    page = None
    if job.report and outcome.status != "failed":
        page = write_identify_report(outcome, job.out_dir, job.options, figures=job.figures,
                                     geometry=job.geometry)
    return replace(outcome, frf=None, result=None), page


def identify_files(
    paths: list[Path], job: FileJob, workers: int | None = None,
) -> Iterator[tuple[FileOutcome, Path | None]]:
    """:func:`identify_one` for each file, in ``workers`` processes (default
    :func:`ema_pipeline.threads.worker_count`;
    :func:`ema_pipeline.threads.process_imap`), yielded in the files' order.

    Raises
    ------
    ConfigError
        Two files whose outputs would overwrite each other (the same stem).
    """
    by_output: dict[Path, Path] = {}
    for path in paths:
        key = Path(os.path.realpath(output_paths(Path(path), job.out_dir)[0]))
        if key in by_output:
            raise ConfigError(f"{by_output[key]} and {path} would write the same outputs "
                              f"({key.name}); identify them into different --out folders")
        by_output[key] = Path(path)
    yield from process_imap(partial(identify_one, job=job), list(paths), workers)
