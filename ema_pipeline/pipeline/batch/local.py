"""Local worker processes for the batch: :class:`ema_pipeline.runner.ProcessPool`
with a fork server that imports the worker code once.

Workers are forked by a fork server (the ``forkserver`` start method, ``spawn``
where there is none): a fresh single-threaded interpreter that imports the
worker code (:data:`PRELOAD`: numpy, scipy, h5py, the identification) once and
forks every worker from there. A spawned worker imports all of it itself, about
2-3 s of CPU each; the fork server pays that once per batch process (and once
for all the batches of a long-lived process). No worker is forked from the
batch process itself, which may have h5py files open and threads running. A
worker gets the batch process's working folder, ``sys.path``, environment and
log level, ignores SIGINT, exits when the batch process dies, and runs BLAS on
the batch process's threads (:mod:`ema_pipeline.runner`).
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
from collections.abc import Callable
from concurrent.futures.process import BrokenProcessPool
from functools import partial

from ema_pipeline.pipeline.batch.tasks import FileRecord, FileTask, process_file
from ema_pipeline.pipeline.logs import verbose_logging
from ema_pipeline.runner import ProcessPool

__all__ = ["PRELOAD", "LocalBackend"]

#: Modules the fork server imports before it forks the workers (the worker code).
PRELOAD = ("ema_pipeline.pipeline.batch.tasks",)


def _worker_log(level: int) -> None:
    """A worker's log at the batch process's level (``--verbose``: INFO on stderr)."""
    log = logging.getLogger("ema_pipeline")
    if level and level <= logging.INFO and not log.handlers:
        verbose_logging()
    log.setLevel(level)


class LocalBackend:
    """The batch's tasks on ``workers`` local processes (see the module docstring)."""

    can_restart = True

    def __init__(
        self, workers: int, process: Callable[[FileTask], FileRecord] = process_file
    ) -> None:
        self.concurrency = workers
        self._process = process
        self.label = f"{workers} local process{'es' if workers > 1 else ''}"
        level = logging.getLogger("ema_pipeline").level
        self._pool = ProcessPool(workers, start="server", preload=PRELOAD,
                                 setup=partial(_worker_log, level))

    def submit(self, task: FileTask) -> cf.Future[FileRecord]:
        """The task in a worker; where the pool is broken already (a worker
        died since the batch last looked, e.g. a file that kills its worker
        at once while the next is submitted), a future that reports it, as
        the running tasks' do: the batch restarts the pool and retries."""
        try:
            return self._pool.submit(self._process, task)
        except BrokenProcessPool as exc:
            refused: cf.Future[FileRecord] = cf.Future()
            refused.set_exception(exc)
            return refused

    def restart(self) -> None:
        self._pool.restart()

    def close(self, *, abort: bool) -> None:
        self._pool.close(abort=abort)
