"""What travels between the batch's parent and its workers: one input file's
task (:class:`FileTask`) and its summary row (:class:`FileRecord`), and the
worker function :func:`process_file`.
"""

from __future__ import annotations

import math
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.io.channel_sheet import is_channel_sheet
from ema_pipeline.io.recording import is_recording
from ema_pipeline.pipeline.batch.resume import completed_details
from ema_pipeline.pipeline.frf import identify_recording
from ema_pipeline.pipeline.roving import identify_sheet
from ema_pipeline.pipeline.single import identify_file

__all__ = ["FileRecord", "FileTask", "naming", "process_file"]


@dataclass(frozen=True)
class FileTask:
    """One input file and where its outputs go (absolute paths)."""

    path: Path
    file: str  # path relative to the batch folder, for the tables
    out_dir: Path
    options: IdentificationOptions
    force: bool
    uff: bool = False  # also write <stem>_modes.uff


@dataclass(frozen=True)
class FileRecord:
    """What a worker returns for one file: one summary row, nothing big."""

    file: str
    status: str  # ok | skipped | failed
    sha256: str = ""
    configuration: str = ""
    fn_hz: tuple[float, ...] = ()
    fit_frac: float = math.nan
    fit_error: float = math.nan
    reason: str = ""
    seconds: float = 0.0
    modes_csv: str = ""
    result_h5: str = ""
    warnings: tuple[str, ...] = ()  # e.g. resonances not kept (identify's warnings)

    @property
    def n_modes(self) -> int:
        return len(self.fn_hz)


def naming(reason: str, task: FileTask) -> str:
    """``reason``, prefixed with the file's path unless it already names the file."""
    if str(task.path) in reason or task.file in reason:
        return reason
    return f"{task.path}: {reason}"


def process_file(task: FileTask) -> FileRecord:
    """Identify one file (in a worker) and return its summary row; never raises."""
    start = time.perf_counter()
    try:
        if is_channel_sheet(task.path):  # a roving test: frf from its files first
            outcome = identify_sheet(task.path, task.out_dir, task.options,
                                     force=task.force, uff=task.uff)
        elif is_recording(task.path):  # raw impact data: frf first (pipeline.frf)
            outcome = identify_recording(task.path, task.out_dir, task.options,
                                         force=task.force, uff=task.uff)
        else:
            outcome = identify_file(
                task.path, task.out_dir, task.options, force=task.force, uff=task.uff
            )
    except Exception as exc:  # one file must never stop the batch
        frames = traceback.extract_tb(exc.__traceback__)
        where = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
        return FileRecord(
            file=task.file,
            status="failed",
            reason=naming(f"unexpected {type(exc).__name__}: {exc}{where}", task),
            seconds=time.perf_counter() - start,
        )
    outputs: dict[str, Any] = {
        "modes_csv": str(outcome.modes_csv or ""),
        "result_h5": str(outcome.result_h5 or ""),
    }
    if outcome.status == "failed":
        return FileRecord(
            file=task.file,
            status="failed",
            sha256=outcome.sha256,
            configuration=outcome.configuration,
            reason=naming(outcome.reason, task),
            seconds=outcome.seconds,
        )
    if outcome.status == "skipped":
        details = completed_details(outcome.result_h5) if outcome.result_h5 else {}
        return FileRecord(
            file=task.file,
            status="skipped",
            sha256=outcome.sha256,
            seconds=outcome.seconds,
            **details,
            **outputs,
        )
    return FileRecord(
        file=task.file,
        status="ok",
        sha256=outcome.sha256,
        configuration=outcome.configuration,
        fn_hz=tuple(float(f) for f in np.sort(outcome.fn_hz)),
        fit_frac=outcome.fit_frac,
        fit_error=outcome.fit_error,
        seconds=outcome.seconds,
        warnings=tuple(outcome.warnings),
        **outputs,
    )
