"""Local worker processes for the batch: a process pool with single-threaded
BLAS, workers that ignore SIGINT and exit with their parent, restarted when a
worker dies.

Workers are forked by a fork server (the ``forkserver`` start method, ``spawn``
where there is none): a fresh single-threaded interpreter that imports the
worker code (:data:`PRELOAD`: numpy, scipy, h5py, the identification) once and
forks every worker from there. A spawned worker imports all of it itself, about
2-3 s of CPU each; the fork server pays that once per batch process (and once
for all the batches of a long-lived process). No worker is forked from the
batch process itself, which may have h5py files open and threads running. A
forked worker gets the batch process's working folder and ``sys.path`` (as a
spawned one) and, from :func:`_init_worker`, its environment at the time the
pool starts (the fork server keeps the one it was started with).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import logging
import multiprocessing
import os
import select
import signal
import threading
import time
from collections.abc import Callable, Iterator

from ema_pipeline.io import FORK_SAFE_THREAD_NAME, pid_alive
from ema_pipeline.pipeline.batch.tasks import FileRecord, FileTask, process_file
from ema_pipeline.pipeline.logs import verbose_logging
from ema_pipeline.threads import (
    WORKERS_ENV,
    available_cores,
    thread_environment,
    worker_count,
)

__all__ = ["PRELOAD", "LocalBackend", "default_workers"]

#: Modules the fork server imports before it forks the workers (the worker code).
PRELOAD = ("ema_pipeline.pipeline.batch.tasks",)


def _init_worker(parent_pid: int, environ: dict[str, str], log_level: int) -> None:
    """Worker start-up: take the parent's environment and the level of the
    package's log (``--verbose``: INFO messages on stderr, as in the parent),
    leave SIGINT to the parent, and exit if the parent dies."""
    if os.environ != environ:  # a fork server started by an earlier batch
        os.environ.clear()
        os.environ.update(environ)
    log = logging.getLogger("ema_pipeline")
    if log_level and log_level <= logging.INFO and not log.handlers:
        verbose_logging()
    log.setLevel(log_level)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # named fork-safe: it only polls and sleeps, so the worker can still check
    # HDF5 inputs in a forked child (65 ms) rather than a fresh interpreter (~2 s)
    watcher = threading.Thread(
        target=_exit_with_parent, args=(parent_pid,), name=FORK_SAFE_THREAD_NAME, daemon=True
    )
    watcher.start()


def _exit_with_parent(parent_pid: int) -> None:
    """Exit this worker once the batch process is gone (SIGKILLed batch: no
    orphans that keep writing into OUT while a rerun starts).

    The batch process is not the worker's parent (the fork server is): wait on a
    pidfd of it (readable when it exits), or else poll it every 0.5 s."""
    try:
        pidfd = os.pidfd_open(parent_pid)
    except ProcessLookupError:
        os._exit(1)
    except (AttributeError, OSError):  # not Linux >= 5.3: poll
        while pid_alive(parent_pid):
            time.sleep(0.5)
        os._exit(1)
    select.select([pidfd], [], [])
    os._exit(1)


@contextlib.contextmanager
def _single_threaded_children() -> Iterator[None]:
    """Set the BLAS/OpenMP thread variables (:func:`ema_pipeline.threads.thread_environment`:
    1 unless ``$EMA_PIPELINE_BLAS_THREADS`` says otherwise) while workers start."""
    wanted = thread_environment()
    before = {name: os.environ.get(name) for name in wanted}
    os.environ.update(wanted)
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _worker_context() -> multiprocessing.context.BaseContext:
    """The fork server (with :data:`PRELOAD`) where the platform has one, else spawn."""
    if "forkserver" not in multiprocessing.get_all_start_methods():  # pragma: no cover
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(PRELOAD))
    return context


class LocalBackend:
    """A pool of local worker processes (forked by a fork server, see the module docstring)."""

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
            mp_context=_worker_context(),
            initializer=_init_worker,
            # one level of processes: a worker searches a file's windows itself
            initargs=(os.getpid(), {**os.environ, WORKERS_ENV: "1"},
                      logging.getLogger("ema_pipeline").level),
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
    """The worker processes of a batch without ``--workers``: the cores this
    process may use, or ``$EMA_PIPELINE_WORKERS``."""
    return worker_count(available_cores())
