"""Running the batch on an existing dask.distributed cluster, through
``Client(address).get_executor()`` (a :class:`concurrent.futures.Executor`).
``distributed`` is imported only here, and only when used (extra ``[distributed]``)."""

from __future__ import annotations

import concurrent.futures as cf

from ema_pipeline.data import ConfigError
from ema_pipeline.pipeline.batch.tasks import FileRecord, FileTask, process_file

__all__ = ["DaskBackend"]


class DaskBackend:
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
