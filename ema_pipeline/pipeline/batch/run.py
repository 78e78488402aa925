"""The batch run: :func:`run_batch` plans the tasks and runs them through the
streaming loop (a sliding window of submitted tasks, rows written in input
order, retries after a worker death, a clean stop on the first SIGINT/SIGTERM).
See the package docstring for the design.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any, Protocol

from tqdm import tqdm

from ema_pipeline.data import ConfigError, EMAError
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.io import FRF_SUFFIXES, sha256_file
from ema_pipeline.pipeline.batch.dask import DaskBackend
from ema_pipeline.pipeline.batch.local import LocalBackend
from ema_pipeline.pipeline.batch.resume import batch_lock, remove_stale_temporaries
from ema_pipeline.pipeline.batch.scan import find_inputs, is_inside, output_dirs
from ema_pipeline.pipeline.batch.summary import (
    FAILURE_COLUMNS,
    SUMMARY_COLUMNS,
    BatchReport,
    count_record,
    csv_stream,
    summary_row,
)
from ema_pipeline.pipeline.batch.tasks import FileRecord, FileTask, naming

__all__ = ["Backend", "StopRequest", "run_batch", "run_tasks"]

#: At most this many positions between the first unwritten row and the next task.
_MAX_AHEAD = 4096
#: How often the parent wakes up to look at the stop flag (seconds).
_POLL_S = 0.2


class Backend(Protocol):
    """A concurrent.futures executor plus what the batch needs around it."""

    label: str
    concurrency: int
    can_restart: bool

    def submit(self, task: FileTask) -> cf.Future[FileRecord]: ...

    def restart(self) -> None: ...

    def close(self, *, abort: bool) -> None: ...


class StopRequest:
    """SIGINT/SIGTERM while the batch runs: the first sets :attr:`requested`,
    the second raises KeyboardInterrupt (abort). Only in the main thread."""

    _SIGNALS = ("SIGINT", "SIGTERM")

    def __init__(self) -> None:
        self.requested = False
        self._previous: dict[int, Any] = {}

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            for name in self._SIGNALS:
                sig = getattr(signal, name, None)
                if sig is not None:
                    self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)


def run_batch(
    folder: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    options: IdentificationOptions | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    force: bool = False,
    progress: bool = True,
    uff: bool = False,
) -> BatchReport:
    """Identify every FRF file under ``folder``; write per-file results, the
    summary and the failures under ``out``.

    Parameters
    ----------
    folder : searched recursively for FRF files (:data:`ema_pipeline.io.FRF_SUFFIXES`,
        any letter case); hidden files, our own ``*_result.h5`` outputs and
        files inside ``out`` are not inputs.
    out : output folder (created). Per file ``<stem>_modes.csv`` and
        ``<stem>_result.h5`` in the mirrored sub-folder (see the module
        docstring), plus ``summary.csv`` and ``failures.csv``.
    options : identification settings, the same for every file (default
        :class:`IdentificationOptions()`).
    workers : local worker processes (default 1: one process beside this one,
        which a crashed or hung file cannot take down; ``ema-pipeline batch``
        passes the cores).
        With ``scheduler``: how many tasks may run at once (default: the
        cluster's worker threads).
    scheduler : address of a dask.distributed scheduler (``tcp://host:8786``)
        to run on instead of local processes.
    force : recompute files that already have a complete result.
    progress : show a progress bar with rate and ETA on stderr.
    uff : also write ``<stem>_modes.uff`` (identified modes as UFF 164/55/58).

    Returns
    -------
    BatchReport; ``n_failed > 0`` if a file failed or the run was interrupted.

    Raises
    ------
    ConfigError : no such folder (or a file), no FRF file in it, ``out`` is or
        contains ``folder``, bad ``workers``, unreachable scheduler or missing
        ``distributed``, another batch writing to ``out``, or worker processes that keep dying.
    KeyboardInterrupt : on a second SIGINT/SIGTERM (abort).
    """
    options = IdentificationOptions() if options is None else options
    folder, out = Path(folder).absolute(), Path(out).absolute()
    if not folder.is_dir():
        raise ConfigError(
            f"{folder}: a file, not a folder (batch takes a folder; identify takes files)"
            if folder.exists() else f"{folder}: no such folder"
        )
    if workers is not None and workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers}")
    if is_inside(folder, out):
        raise ConfigError(
            f"the output folder {out} is (or contains) the input folder {folder}: results "
            "would be read back as inputs; choose an output folder outside it or below it"
        )
    files = find_inputs(folder, out)
    if not files:  # before OUT and its lock exist: nothing is left behind
        raise ConfigError(
            f"{folder}: no FRF files in this folder or below it (suffixes "
            f"{', '.join(sorted(FRF_SUFFIXES))}, any letter case; hidden files and "
            "*_result.h5 outputs are not inputs)"
        )
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with batch_lock(out):
        report = BatchReport(
            folder=folder,
            out=out,
            summary_csv=out / "summary.csv",
            failures_csv=out / "failures.csv",
        )
        report.n_stale_removed = remove_stale_temporaries(out)
        report.n_files = len(files)
        tasks = (
            FileTask(path=p, file=name, out_dir=target, options=options, force=force, uff=uff)
            for p, (name, target) in zip(files, output_dirs(files, folder, out), strict=True)
        )

        def make_backend() -> Backend:
            if scheduler:
                return DaskBackend(scheduler, workers)
            return LocalBackend(max(1, min(workers or 1, len(files))))

        run_tasks(tasks, report, make_backend, progress=progress)
    report.seconds = time.perf_counter() - start
    return report


@dataclass
class _Slot:
    """A submitted task: its position in the input order and attempts so far."""

    index: int
    task: FileTask
    attempts: int = 1


#: Abort when the worker pool dies this many times in a row without finishing a file.
_MAX_BREAKS = 5


class _Loop:
    """The streaming loop over one backend: fill the window, collect the
    finished tasks, write the rows in input order.

    After the process pool dies, the tasks that were in it are retried one at
    a time (the pool holds only that task), so a file that kills its worker is
    found and recorded as failed, and the others are not blamed.
    """

    def __init__(
        self,
        tasks: Iterator[FileTask],
        report: BatchReport,
        backend: Backend,
        summary: Any,
        failures: Any,
        bar: tqdm,
    ) -> None:
        self.tasks, self.report, self.backend = tasks, report, backend
        self.summary, self.failures, self.bar = summary, failures, bar
        self.window = 2 * backend.concurrency
        self.running: dict[cf.Future[FileRecord], _Slot] = {}
        self.buffer: dict[int, FileRecord | None] = {}  # finished, unwritten (None: not run)
        self.retry: deque[_Slot] = deque()
        self.next_submit = self.next_write = 0
        self.breaks = 0  # pool deaths since a file last finished
        self.stopping = False

    def run(self, stop: StopRequest) -> None:
        """Until every file is written (or, after a stop request, all running ones)."""
        n = self.report.n_files
        while True:
            if stop.requested and not self.stopping:
                self._stop()
            self._fill(n)
            if not self.running:
                break
            done, _ = cf.wait(self.running, timeout=_POLL_S, return_when=cf.FIRST_COMPLETED)
            self._collect(done)
            self._write_ready()
        for slot in self.retry:  # stopped while retrying
            self.buffer[slot.index] = None
        self._write_ready(everything=True)
        self.report.n_not_run = n - self.report.n_done

    def _stop(self) -> None:
        self.stopping = True
        self.report.interrupted = True
        for future in self.running:
            future.cancel()
        if not self.bar.disable:
            self.bar.write(
                "batch: stopping: waiting for the files in progress (signal again to abort)",
                file=sys.stderr,
            )

    def _fill(self, n: int) -> None:
        if self.stopping:
            return
        if self.retry:  # isolate: one task at a time in a fresh pool
            if not self.running:
                slot = self.retry.popleft()
                self.running[self.backend.submit(slot.task)] = slot
            return
        while (
            self.next_submit < n
            and len(self.running) < self.window
            and self.next_submit - self.next_write < _MAX_AHEAD
        ):
            task = next(self.tasks)
            self.running[self.backend.submit(task)] = _Slot(self.next_submit, task)
            self.next_submit += 1

    def _collect(self, done: set[cf.Future[FileRecord]]) -> None:
        broken = self.backend.can_restart and any(_died(f) for f in done)
        if broken:  # every task in the pool fails with it: take them all now
            cf.wait(self.running)
            done = set(self.running)
        died: list[_Slot] = []
        for future in done:
            slot = self.running.pop(future)
            if broken and _died(future) and slot.attempts == 1 and not self.stopping:
                died.append(slot)
                continue
            if not _died(future) and not future.cancelled():
                self.breaks = 0
            self._finish(slot, _collect(future, slot))
        if broken:
            self.breaks += 1
            if self.breaks >= _MAX_BREAKS:
                raise ConfigError(
                    f"the worker processes died {self.breaks} times in a row without "
                    "finishing a file; see the errors above (cannot start? out of memory?)"
                )
            self.backend.restart()
            for slot in sorted(died, key=lambda s: s.index):
                slot.attempts += 1
                self.retry.append(slot)

    def _finish(self, slot: _Slot, rec: FileRecord | None) -> None:
        self.buffer[slot.index] = rec
        if rec is None:
            return
        count_record(rec, self.report)
        self.bar.update(1)
        if rec.status == "failed":
            self.bar.set_postfix(failed=self.report.n_errors, refresh=False)

    def _write_ready(self, everything: bool = False) -> None:
        buffer = self.buffer
        while self.next_write in buffer or (everything and buffer):
            index = self.next_write if self.next_write in buffer else min(buffer)
            rec = buffer.pop(index)
            self.next_write = index + 1
            if rec is None:
                continue
            self.summary.writerow(summary_row(rec, self.report.out))
            if rec.status == "failed":
                self.failures.writerow([rec.file, rec.sha256 or "-", rec.reason])


class _Bar(tqdm):
    """The batch's progress bar, without tqdm's monitor thread (it is updated at
    every file): the monitor outlives the bars (tqdm 4.70), and a second thread
    makes the runner's fork-safety rule refuse every later fork of the process
    (:func:`ema_pipeline.runner.fork_is_safe`): each
    :func:`ema_pipeline.io.check_hdf5` (the batch report reads each file's
    result) would start a fresh interpreter, 1-3 s per file."""

    monitor_interval = 0


def run_tasks(
    tasks: Iterator[FileTask],
    report: BatchReport,
    make_backend: Callable[[], Backend],
    *,
    progress: bool,
) -> None:
    """Run the tasks on a backend (made by ``make_backend``), counting into
    ``report`` and showing a tqdm bar when ``progress``; summary.csv and failures.csv are renamed
    into place at the end (also after a stop request), not after an abort."""
    with contextlib.ExitStack() as stack:
        summary = stack.enter_context(csv_stream(report.summary_csv, SUMMARY_COLUMNS))
        failures = stack.enter_context(csv_stream(report.failures_csv, FAILURE_COLUMNS))
        if report.n_files == 0:
            return
        backend = make_backend()
        report.backend = backend.label
        aborted = True
        stack.callback(lambda: backend.close(abort=aborted))
        bar = stack.enter_context(
            _Bar(
                total=report.n_files,
                unit="file",
                desc="batch",
                file=sys.stderr,
                disable=not progress,
                dynamic_ncols=True,
                smoothing=0.05,
            )
        )
        if progress:
            stale = report.n_stale_removed
            note = f"; removed {stale} temporary files of an interrupted run" if stale else ""
            bar.write(f"batch: {report.n_files} files on {backend.label}{note}", file=sys.stderr)
        stop = stack.enter_context(StopRequest())
        _Loop(tasks, report, backend, summary, failures, bar).run(stop)
        aborted = False


def _died(future: cf.Future[FileRecord]) -> bool:
    """Whether a finished future failed because its worker process died."""
    return not future.cancelled() and isinstance(future.exception(), BrokenProcessPool)


def _collect(future: cf.Future[FileRecord], slot: _Slot) -> FileRecord | None:
    """The record of a finished future (None if it was cancelled)."""
    if future.cancelled():
        return None
    exc = future.exception()
    if exc is None:
        return future.result()
    if isinstance(exc, BrokenProcessPool):
        reason = "the worker process died while processing this file (crash or out of memory?)"
    else:
        reason = f"{type(exc).__name__}: {exc}"
    try:  # regular files only: never blocks on a FIFO or reads a device
        sha256 = sha256_file(slot.task.path)
    except (EMAError, OSError):
        sha256 = "-"
    return FileRecord(file=slot.task.file, status="failed", sha256=sha256,
                      reason=naming(reason, slot.task))
