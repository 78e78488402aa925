"""Identify every FRF file under a folder: parallel, streaming, resumable.

``ema-pipeline batch DIR --out OUT`` runs :func:`~ema_pipeline.pipeline.single.identify_file`
(acquisition checks + identification + atomic outputs) on every UFF-58 and
HDF5 file under ``DIR`` and writes ``OUT/summary.csv`` (one row per file) and
``OUT/failures.csv`` (one row per bad file, with the reason).

Design
------
Output layout
    The outputs of ``DIR/sub/a.uff`` go to ``OUT/sub/`` (``a_modes.csv``,
    ``a_result.h5``), mirroring the input's sub-folder, so equal stems in
    different folders do not collide. Files that share a stem in one folder
    (``a.uff`` and ``a.h5``) each get a folder named after the whole file
    name instead: ``OUT/sub/a.uff/a_modes.csv``, ``OUT/sub/a.h5/a_modes.csv``
    (no input folder can have that name, because the file has it). The
    ``modes_csv`` and ``result_h5`` columns of the summary say where each
    file's outputs are. Input files inside ``OUT`` (``--out`` under ``DIR``)
    are not inputs.

Streaming window
    The parent never holds FRFs or results: it submits at most
    ``2 * concurrency`` tasks at a time (a sliding window refilled as results
    arrive) and a worker returns only a :class:`FileRecord` (a summary row:
    hash, configuration, frequencies, fit quality, status, reason). Rows are
    written as they arrive, in input order (a reorder buffer, bounded because
    no task is submitted more than ``_MAX_AHEAD`` positions past the first
    unwritten one), into temporary files beside ``summary.csv`` and
    ``failures.csv`` that are renamed into place at the end. Memory therefore
    stays flat; only the list of input paths grows with the number of files.

Atomic writes and resume by content hash
    Every output is written to a hidden temporary file in its folder and
    renamed when complete (:func:`ema_pipeline.io.atomic_path`); the result
    HDF5 file, written last, records the SHA-256 of the input and a
    ``complete`` flag. A batch killed at any moment (even SIGKILL) therefore
    leaves only complete results, and a rerun skips every file whose content
    hash already has a complete result (``force=True`` recomputes). Stray
    temporary files of a killed run (``.*.tmp``) are removed when the next run
    starts; a lock file (``OUT/.batch.lock``, ``flock``) keeps two batches from
    writing into one ``OUT`` at the same time.

Local processes
    By default tasks run in ``os.cpu_count()`` worker processes
    (:class:`concurrent.futures.ProcessPoolExecutor`, ``spawn`` start method:
    no fork of a parent that has h5py open and threads running). Workers are
    started with single-threaded BLAS (``OMP_NUM_THREADS=1`` etc., unless
    already set): N processes with N BLAS threads each would oversubscribe the
    cores, and the results do not depend on the number of workers. Workers
    ignore SIGINT (the parent coordinates the stop) and exit when the parent
    dies. A worker that dies (crash, out of memory) breaks the pool: it is
    restarted, the files then in progress are retried once, and a file in
    progress at a second death is recorded as failed.

Interrupts
    The first SIGINT (Ctrl-C) or SIGTERM stops submitting, cancels the queued
    tasks and lets the running ones finish (their results are complete); the
    summary and failures of what was done are written and the report says
    ``interrupted`` and how many files were not run (they count as failed, so
    the exit status is 1; a rerun finishes them). A second signal aborts at
    once: workers are terminated, ``summary.csv`` and ``failures.csv`` are left
    as they were, and ``KeyboardInterrupt`` propagates.

dask.distributed
    With ``scheduler="tcp://host:port"`` the same tasks go to an existing
    dask.distributed cluster through ``Client(address).get_executor()`` (a
    :class:`concurrent.futures.Executor`), so the streaming window, ordering
    and interrupts are the same code. The workers must see ``DIR`` and ``OUT``
    under the same absolute paths (shared file system) and have ema-pipeline
    installed. ``distributed`` is imported only then (extra ``[distributed]``).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import csv
import math
import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
from collections import Counter, deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any, Protocol

import h5py
import numpy as np
from tqdm import tqdm

from ema_pipeline import io
from ema_pipeline.data import ConfigError
from ema_pipeline.pipeline.single import IdentifyOptions, identify_file

SUMMARY_COLUMNS = (
    "file",
    "sha256",
    "configuration",
    "n_modes",
    "frequencies_hz",
    "fit_frac",
    "fit_error",
    "status",
    "seconds",
    "modes_csv",
    "result_h5",
)
FAILURE_COLUMNS = ("file", "sha256", "reason")

#: Environment variables that make BLAS/OpenMP single-threaded in the workers.
_THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)
#: At most this many positions between the first unwritten row and the next task.
_MAX_AHEAD = 4096
#: How often the parent wakes up to look at the stop flag (seconds).
_POLL_S = 0.2
_LOCK_NAME = ".batch.lock"


# --------------------------------------------------------------------------
# What travels between parent and workers
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class FileTask:
    """One input file and where its outputs go (absolute paths)."""

    path: Path
    file: str  # path relative to the batch folder, for the tables
    out_dir: Path
    options: IdentifyOptions
    force: bool


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

    @property
    def n_modes(self) -> int:
        return len(self.fn_hz)


def _naming(reason: str, task: FileTask) -> str:
    """``reason``, prefixed with the file's path unless it already names the file."""
    if str(task.path) in reason or task.file in reason:
        return reason
    return f"{task.path}: {reason}"


def _completed_details(result_h5: Path) -> dict[str, Any]:
    """Configuration, frequencies and fit quality stored in a complete result file."""
    details: dict[str, Any] = {}
    try:
        with h5py.File(result_h5, "r") as h5:
            cfg = h5["frf"].attrs.get("configuration", "") if "frf" in h5 else ""
            details["configuration"] = cfg.decode() if isinstance(cfg, bytes) else str(cfg)
            if "modes" in h5 and "fn_hz" in h5["modes"]:
                details["fn_hz"] = tuple(float(f) for f in h5["modes"]["fn_hz"][()])
            ident = h5["identification"] if "identification" in h5 else None
            if ident is not None and "frac" in ident and "error" in ident:
                details["fit_frac"] = float(np.mean(ident["frac"][()]))
                details["fit_error"] = float(np.mean(ident["error"][()]))
    except (OSError, KeyError, ValueError, TypeError):
        pass  # the row just stays less informative; the result itself is complete
    return details


def process_file(task: FileTask) -> FileRecord:
    """Identify one file (in a worker) and return its summary row; never raises."""
    start = time.perf_counter()
    try:
        outcome = identify_file(task.path, task.out_dir, task.options, force=task.force)
    except Exception as exc:  # one file must never stop the batch
        frames = traceback.extract_tb(exc.__traceback__)
        where = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
        return FileRecord(
            file=task.file,
            status="failed",
            reason=_naming(f"unexpected {type(exc).__name__}: {exc}{where}", task),
            seconds=time.perf_counter() - start,
        )
    outputs = {
        "modes_csv": str(outcome.modes_csv or ""),
        "result_h5": str(outcome.result_h5 or ""),
    }
    if outcome.status == "failed":
        return FileRecord(
            file=task.file,
            status="failed",
            sha256=outcome.sha256,
            configuration=outcome.configuration,
            reason=_naming(outcome.reason, task),
            seconds=outcome.seconds,
        )
    if outcome.status == "skipped":
        details = _completed_details(outcome.result_h5) if outcome.result_h5 else {}
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
        **outputs,
    )


# --------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------


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
            head = f"batch: {self.n_files} files: "
        return f"{head}{counts} in {self.seconds:.1f} s, {self.files_per_second:.3g} files/s"


# --------------------------------------------------------------------------
# Where tasks run
# --------------------------------------------------------------------------


class _Backend(Protocol):
    """A concurrent.futures executor plus what the batch needs around it."""

    label: str
    concurrency: int
    can_restart: bool

    def submit(self, task: FileTask) -> cf.Future[FileRecord]: ...

    def restart(self) -> None: ...

    def close(self, *, abort: bool) -> None: ...


def _init_worker(parent_pid: int) -> None:
    """Worker start-up: leave SIGINT to the parent, and exit if the parent dies."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    watcher = threading.Thread(
        target=_exit_with_parent, args=(parent_pid,), name="ema-batch-parent", daemon=True
    )
    watcher.start()


def _exit_with_parent(parent_pid: int) -> None:
    """Exit this worker once its parent is gone (SIGKILLed batch: no orphans
    that keep writing into OUT while a rerun starts)."""
    while os.getppid() == parent_pid:
        time.sleep(0.5)
    os._exit(1)


@contextlib.contextmanager
def _single_threaded_children() -> Iterator[None]:
    """Set the BLAS/OpenMP thread variables to 1 (unless set) while workers start."""
    added = [name for name in _THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


class _LocalBackend:
    """A pool of local worker processes (spawn start method)."""

    can_restart = True

    def __init__(
        self, workers: int, process: Callable[[FileTask], FileRecord] = process_file
    ) -> None:
        self.concurrency = workers
        self._process = process
        self.label = f"{workers} local process{'es' if workers > 1 else ''}"
        self._env = contextlib.ExitStack()
        self._env.enter_context(_single_threaded_children())
        self._executor = self._new_executor()

    def _new_executor(self) -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(
            max_workers=self.concurrency,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_worker,
            initargs=(os.getpid(),),
        )

    def submit(self, task: FileTask) -> cf.Future[FileRecord]:
        return self._executor.submit(self._process, task)

    def restart(self) -> None:
        self._terminate()
        self._executor = self._new_executor()

    def _terminate(self) -> None:
        executor = self._executor
        executor.shutdown(wait=False, cancel_futures=True)
        terminate = getattr(executor, "terminate_workers", None)  # Python >= 3.14
        if terminate is not None:
            terminate()
            return
        for process in list((getattr(executor, "_processes", None) or {}).values()):
            process.terminate()

    def close(self, *, abort: bool) -> None:
        try:
            if abort:
                self._terminate()
            self._executor.shutdown(wait=True, cancel_futures=True)
        finally:
            self._env.close()


class _DaskBackend:
    """An existing dask.distributed cluster, through ``Client.get_executor()``."""

    can_restart = False

    def __init__(self, address: str, workers: int | None) -> None:
        try:
            import distributed
        except ImportError as exc:
            raise ConfigError(
                f"--scheduler {address} needs dask.distributed, which is not installed; "
                "install the extra: pip install 'ema-pipeline[distributed]'"
            ) from exc
        try:
            self._client = distributed.Client(address, timeout="10s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"cannot connect to the dask scheduler at {address}: {exc}") from exc
        self._executor = self._client.get_executor(pure=False)
        n_threads = sum(self._client.nthreads().values())
        self.concurrency = workers or max(n_threads, 1)
        self.label = f"dask {address} ({n_threads} worker threads)"

    def submit(self, task: FileTask) -> cf.Future[FileRecord]:
        return self._executor.submit(process_file, task)

    def restart(self) -> None:  # pragma: no cover - dask reschedules by itself
        raise RuntimeError("a dask backend does not restart")

    def close(self, *, abort: bool) -> None:
        try:
            self._executor.shutdown(wait=not abort)
        finally:
            self._client.close()


# --------------------------------------------------------------------------
# Planning, locking, signals, streaming tables
# --------------------------------------------------------------------------


def _is_inside(path: Path, folder: Path) -> bool:
    try:
        path.relative_to(folder)
    except ValueError:
        return False
    return True


def find_inputs(folder: Path, out: Path) -> list[Path]:
    """The FRF files under ``folder`` (sorted), without those inside ``out``."""
    folder, out = folder.absolute(), out.absolute()
    files = io.find_frf_files(folder)
    if _is_inside(out, folder):
        files = [p for p in files if not _is_inside(p, out)]
    return files


def output_dirs(files: Sequence[Path], folder: Path, out: Path) -> Iterator[tuple[str, Path]]:
    """``(relative name, output folder)`` per input file, in order.

    ``DIR/sub/a.uff`` -> ``OUT/sub``; when several files in one folder share a
    stem (``a.uff``, ``a.h5``), each gets ``OUT/sub/<file name>``.
    """
    folder, out = folder.absolute(), out.absolute()
    rel = [p.relative_to(folder) for p in files]
    counts = Counter((r.parent, r.stem.casefold()) for r in rel)
    shared = {key for key, n in counts.items() if n > 1}
    del counts
    for r in rel:
        target = out / r.parent
        if (r.parent, r.stem.casefold()) in shared:
            target = target / r.name
        yield r.as_posix(), target


@contextlib.contextmanager
def _exclusive(out: Path) -> Iterator[None]:
    """Hold ``OUT/.batch.lock`` (flock) so two batches do not share one OUT.

    The lock goes with the process, so a killed batch never leaves it stale.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - no flock (Windows): no lock
        yield
        return
    with open(out / _LOCK_NAME, "a+", encoding="utf-8") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as exc:
            raise ConfigError(
                f"{out}: another batch is writing to this folder (lock {out / _LOCK_NAME})"
            ) from exc
        try:
            yield
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def remove_stale_temporaries(out: Path) -> int:
    """Delete the hidden temporary files (``.*.tmp``) a killed run left in ``out``."""
    removed = 0
    for tmp in out.rglob(".*.tmp"):
        if tmp.is_file():
            tmp.unlink(missing_ok=True)
            removed += 1
    return removed


class _StopRequest:
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

    def __enter__(self) -> _StopRequest:
        if threading.current_thread() is threading.main_thread():
            for name in self._SIGNALS:
                sig = getattr(signal, name, None)
                if sig is not None:
                    self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)


@contextlib.contextmanager
def _csv_stream(path: Path, columns: Sequence[str]) -> Iterator[Any]:
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


def _summary_row(rec: FileRecord, out: Path) -> list[str]:
    return [
        rec.file,
        rec.sha256,
        rec.configuration,
        str(rec.n_modes) if rec.status != "failed" else "",
        ";".join(f"{f:.10g}" for f in rec.fn_hz),
        _num(rec.fit_frac),
        _num(rec.fit_error),
        rec.status,
        f"{rec.seconds:.3f}",
        _relative(rec.modes_csv, out),
        _relative(rec.result_h5, out),
    ]


def _default_workers() -> int:
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


# --------------------------------------------------------------------------
# The batch
# --------------------------------------------------------------------------


def run_batch(
    folder: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    options: IdentifyOptions | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    force: bool = False,
    progress: bool = True,
) -> BatchReport:
    """Identify every FRF file under ``folder``; write per-file results, the
    summary and the failures under ``out``.

    Parameters
    ----------
    folder : searched recursively for UFF-58 (.uff, .unv, .58) and HDF5
        (.h5, .hdf5, .hdf) files; hidden files and files inside ``out`` are not
        inputs.
    out : output folder (created). Per file ``<stem>_modes.csv`` and
        ``<stem>_result.h5`` in the mirrored sub-folder (see the module
        docstring), plus ``summary.csv`` and ``failures.csv``.
    options : identification settings, the same for every file (default
        :class:`IdentifyOptions()`).
    workers : local worker processes (default: the cores this process may use).
        With ``scheduler``: how many tasks may run at once (default: the
        cluster's worker threads).
    scheduler : address of a dask.distributed scheduler (``tcp://host:8786``)
        to run on instead of local processes.
    force : recompute files that already have a complete result.
    progress : show a progress bar with rate and ETA on stderr.

    Returns
    -------
    BatchReport; ``n_failed > 0`` if a file failed or the run was interrupted.

    Raises
    ------
    ConfigError : no such folder, ``out`` is or contains ``folder``, bad
        ``workers``, unreachable scheduler or missing ``distributed``, another
        batch writing to ``out``, or worker processes that keep dying.
    KeyboardInterrupt : on a second SIGINT/SIGTERM (abort).
    """
    options = IdentifyOptions() if options is None else options
    folder, out = Path(folder).absolute(), Path(out).absolute()
    if not folder.is_dir():
        raise ConfigError(f"{folder}: no such folder")
    if workers is not None and workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers}")
    if _is_inside(folder, out):
        raise ConfigError(
            f"the output folder {out} is (or contains) the input folder {folder}: results "
            "would be read back as inputs; choose an output folder outside it or below it"
        )
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with _exclusive(out):
        report = BatchReport(
            folder=folder,
            out=out,
            summary_csv=out / "summary.csv",
            failures_csv=out / "failures.csv",
        )
        report.n_stale_removed = remove_stale_temporaries(out)
        files = find_inputs(folder, out)
        report.n_files = len(files)
        tasks = (
            FileTask(path=p, file=name, out_dir=target, options=options, force=force)
            for p, (name, target) in zip(files, output_dirs(files, folder, out), strict=True)
        )

        def make_backend() -> _Backend:
            if scheduler:
                return _DaskBackend(scheduler, workers)
            n = workers or _default_workers()
            return _LocalBackend(max(1, min(n, len(files))))

        _run(tasks, report, make_backend, progress=progress)
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
        backend: _Backend,
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

    def run(self, stop: _StopRequest) -> None:
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
        _count(rec, self.report)
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
            self.summary.writerow(_summary_row(rec, self.report.out))
            if rec.status == "failed":
                self.failures.writerow([rec.file, rec.sha256, rec.reason])


def _run(
    tasks: Iterator[FileTask],
    report: BatchReport,
    make_backend: Callable[[], _Backend],
    *,
    progress: bool,
) -> None:
    """Run the tasks on a backend; summary.csv and failures.csv are renamed
    into place at the end (also after a stop request), not after an abort."""
    with contextlib.ExitStack() as stack:
        summary = stack.enter_context(_csv_stream(report.summary_csv, SUMMARY_COLUMNS))
        failures = stack.enter_context(_csv_stream(report.failures_csv, FAILURE_COLUMNS))
        if report.n_files == 0:
            return
        backend = make_backend()
        report.backend = backend.label
        aborted = True
        stack.callback(lambda: backend.close(abort=aborted))
        bar = stack.enter_context(
            tqdm(
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
        stop = stack.enter_context(_StopRequest())
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
    return FileRecord(file=slot.task.file, status="failed", reason=_naming(reason, slot.task))


def _count(rec: FileRecord, report: BatchReport) -> None:
    if rec.status == "ok":
        report.n_ok += 1
    elif rec.status == "skipped":
        report.n_skipped += 1
    else:
        report.n_errors += 1


__all__ = [
    "FAILURE_COLUMNS",
    "SUMMARY_COLUMNS",
    "BatchReport",
    "FileRecord",
    "FileTask",
    "find_inputs",
    "output_dirs",
    "process_file",
    "remove_stale_temporaries",
    "run_batch",
]
