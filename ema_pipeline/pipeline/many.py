"""Several FRF files of one ``identify`` command, identified side by side in
worker processes, with the results given back in the order of the files.

Each file is independent (its own outputs, its own identification), so the
outputs are those of a serial run, byte for byte; only the wall time changes.
Workers are forked from the command's process (:func:`ema_pipeline.runner.process_imap`),
which has imported the identification chain and opened no file by then (a
fork costs milliseconds, a fresh interpreter 2-3 s of imports), and inherit
its BLAS threads (:mod:`ema_pipeline.threads`); a worker starts no workers of
its own (the windows of a dense band are searched in the process that has the
file). One file, or ``workers=1``, is identified in the process itself, its
windows in ``workers`` processes. A file that kills its worker (out of
memory, a crash) is reported as failed, naming it; the others go on.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path

from ema_pipeline.data import ConfigError, FRFSet, Geometry
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.picked import Picks
from ema_pipeline.pipeline.reports import write_identify_report
from ema_pipeline.pipeline.single import FileOutcome, identify_file, output_paths
from ema_pipeline.runner import process_imap

__all__ = ["FileItem", "FileJob", "crashed_file", "identify_files",
           "identify_one", "identify_read"]


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
    workers: int = 1  # worker processes of one file's identification
    checked: bool = False  # the files passed paths.check_readable (the command line's check)


def identify_one(path: Path, job: FileJob,
                 frf: FRFSet | None = None) -> tuple[FileOutcome, Path | None]:
    """One file: identified, its outputs written, its report page when asked;
    ``frf`` its FRFs read ahead (:func:`ema_pipeline.pipeline.ahead.read_ahead`;
    None: read here).

    Returns the outcome without the FRFs and the result (what the caller
    prints) and the report page (``None`` without one)."""
    outcome = identify_file(path, job.out_dir, job.options, keep=job.report, uff=job.uff,
                            picks=job.picks, workers=job.workers, checked=job.checked,
                            frf=frf)
    page = None
    if job.report and outcome.status != "failed":
        page = write_identify_report(outcome, job.out_dir, job.options, figures=job.figures,
                                     geometry=job.geometry)
    return replace(outcome, frf=None, result=None), page


def identify_files(
    paths: list[Path], job: FileJob, workers: int = 1, *,
    frfs: Sequence[FRFSet | None] | None = None,
) -> Iterator[tuple[FileOutcome, Path | None]]:
    """:func:`identify_one` for each file, in ``workers`` processes
    (:func:`ema_pipeline.runner.process_imap`; one file: in this process, its
    identification in ``workers`` processes), yielded in the files' order. A
    file whose worker process dies gives a failed outcome naming it.
    ``frfs``: each file's FRFs read ahead
    (:func:`ema_pipeline.pipeline.ahead.read_ahead`; None: read by its
    worker), the same outputs.

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
    read = [None] * len(paths) if frfs is None else list(frfs)
    if len(read) != len(paths):
        raise ValueError(f"identify_files: {len(read)} FRF sets read ahead for "
                         f"{len(paths)} files")
    items = [FileItem(Path(path), frf) for path, frf in zip(paths, read, strict=True)]
    yield from process_imap(partial(identify_read, job=replace(job, workers=workers)),
                            items, workers, crashed=crashed_file)


@dataclass(frozen=True)
class FileItem:
    """One file of :func:`identify_files`: its path and its FRFs read ahead
    (None: read by its worker); as text, the path (the message of a worker
    that died names it)."""

    path: Path
    frf: FRFSet | None = None

    def __str__(self) -> str:
        return str(self.path)


def identify_read(item: FileItem, job: FileJob) -> tuple[FileOutcome, Path | None]:
    """:func:`identify_one` of an item of :func:`identify_files`."""
    return identify_one(item.path, job, item.frf)


def crashed_file(item: FileItem, reason: str) -> tuple[FileOutcome, Path | None]:
    """The outcome of a file of :func:`identify_files` whose worker process
    died (``reason`` names the file)."""
    return FileOutcome(path=item.path, status="failed", runtime=True, reason=reason), None
