"""The batch's tables and counts: ``summary.csv`` and ``failures.csv`` rows,
streamed into temporary files renamed into place, and :class:`BatchReport`."""

from __future__ import annotations

import contextlib
import csv
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ema_pipeline import io
from ema_pipeline.pipeline.batch.tasks import FileRecord
from ema_pipeline.report.wording import plural

__all__ = [
    "FAILURE_COLUMNS",
    "SUMMARY_COLUMNS",
    "BatchReport",
    "count_record",
    "csv_stream",
    "summary_row",
]

#: ``summary.csv``: ``fit_frac`` is the mean FRAC (ratio, 1 = perfect), ``fit_error_pct``
#: the mean normalised fit error ||H - H_fit|| / ||H|| in per cent (the unit of the reports).
SUMMARY_COLUMNS = (
    "file",
    "sha256",
    "configuration",
    "n_modes",
    "frequencies_hz",
    "fit_frac",
    "fit_error_pct",
    "status",
    "seconds",
    "modes_csv",
    "result_h5",
    "warnings",
)
FAILURE_COLUMNS = ("file", "sha256", "reason")


@dataclass
class BatchReport:
    """Counts and timing of one batch run."""

    folder: Path
    out: Path
    n_files: int = 0
    n_ok: int = 0
    n_skipped: int = 0
    n_errors: int = 0  # files that failed (rows of failures.csv)
    n_not_run: int = 0  # after an interrupt: files neither done nor failed
    seconds: float = 0.0
    interrupted: bool = False
    backend: str = ""
    n_stale_removed: int = 0  # temporary files of an earlier, killed run
    summary_csv: Path = field(default_factory=Path)
    failures_csv: Path = field(default_factory=Path)

    @property
    def n_done(self) -> int:
        """Files that got a row in summary.csv (ok, skipped or failed)."""
        return self.n_ok + self.n_skipped + self.n_errors

    @property
    def n_failed(self) -> int:
        """Files without a result from this run: failed ones and, after an
        interrupt, those not run. Non-zero means exit status 1."""
        return self.n_errors + self.n_not_run

    @property
    def files_per_second(self) -> float:
        return self.n_done / self.seconds if self.seconds > 0 else 0.0

    def summary_line(self) -> str:
        """One line, e.g. ``batch: 200 files: 197 ok, 0 skipped, 3 failed (see
        OUT/failures.csv) in 81.2 s, 2.46 files/s``."""
        failed = f"{self.n_errors} failed"
        if self.n_errors:
            failed += f" (see {self.failures_csv})"
        counts = f"{self.n_ok} ok, {self.n_skipped} skipped, {failed}"
        if self.interrupted:
            head = f"batch: interrupted after {self.n_done} of {self.n_files} files: "
            counts += f", {self.n_not_run} not run (run again to finish)"
        else:
            head = f"batch: {plural(self.n_files, 'file')}: "
        return f"{head}{counts} in {self.seconds:.1f} s, {self.files_per_second:.3g} files/s"


@contextlib.contextmanager
def csv_stream(path: Path, columns: Sequence[str]) -> Iterator[Any]:
    """A csv writer on a temporary file renamed onto ``path`` on success."""
    with io.atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(columns)
        yield writer


def _num(value: float) -> str:
    return "" if value is None or not math.isfinite(value) else f"{value:.10g}"


def _relative(path: str, out: Path) -> str:
    if not path:
        return ""
    try:
        return Path(path).relative_to(out).as_posix()
    except ValueError:
        return path


def summary_row(rec: FileRecord, out: Path) -> list[str]:
    """The ``summary.csv`` row of a record (output paths relative to ``out``)."""
    return [
        rec.file,
        rec.sha256,
        rec.configuration,
        str(rec.n_modes) if rec.status != "failed" else "",
        ";".join(f"{f:.10g}" for f in rec.fn_hz),
        _num(rec.fit_frac),
        _num(100 * rec.fit_error),  # fit_error_pct: per cent, as the reports print it
        rec.status,
        f"{rec.seconds:.3f}",
        _relative(rec.modes_csv, out),
        _relative(rec.result_h5, out),
        " | ".join(rec.warnings),
    ]


def count_record(rec: FileRecord, report: BatchReport) -> None:
    """Count a finished file in the report by its status."""
    if rec.status == "ok":
        report.n_ok += 1
    elif rec.status == "skipped":
        report.n_skipped += 1
    else:
        report.n_errors += 1
