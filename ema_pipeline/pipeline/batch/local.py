"""Local worker processes for the batch: a spawn-started process pool with
single-threaded BLAS, workers that ignore SIGINT and exit with their parent,
restarted when a worker dies."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator

from ema_pipeline.io import FORK_SAFE_THREAD_NAME
from ema_pipeline.pipeline.batch.tasks import FileRecord, FileTask, process_file

__all__ = ["THREAD_VARIABLES", "LocalBackend", "default_workers"]

#: Environment variables that make BLAS/OpenMP single-threaded in the workers.
THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)


def _init_worker(parent_pid: int) -> None:
    """Worker start-up: leave SIGINT to the parent, and exit if the parent dies."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # named fork-safe: it only polls and sleeps, so the worker can still check
    # HDF5 inputs in a forked child (65 ms) rather than a fresh interpreter (~2 s)
    watcher = threading.Thread(
        target=_exit_with_parent, args=(parent_pid,), name=FORK_SAFE_THREAD_NAME, daemon=True
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
    added = [name for name in THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


class LocalBackend:
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


def default_workers() -> int:
    """The cores this process may use (at least 1)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1
