"""The tool's own thread and process counts: one BLAS thread per process, and
worker processes over the machine's cores.

Identification makes hundreds of thousands of small linear-algebra calls
(companion eigenvalues, QR and solves of a few dozen columns). A threaded
BLAS (OpenBLAS starts one thread per core) splits each of them over its
threads, which spin, wait for each other and fight every other process on
the machine: on a quiet 2-core machine the measured beam took 2.7x as long
as on one thread, on a busy one 25x. So every stage runs its linear algebra
on one BLAS thread whatever ``OPENBLAS_NUM_THREADS`` and its kind say, and
the cores are used by worker processes where the work splits into
independent pieces (several files, the windows of a dense band).

The one override is the environment variable :data:`BLAS_THREADS_ENV`
(``EMA_PIPELINE_BLAS_THREADS``): a positive integer sets the BLAS threads
of each process, ``auto`` leaves them to BLAS and its own variables.
:data:`WORKERS_ENV` (``EMA_PIPELINE_WORKERS``) caps the worker processes
(default: the cores this process may use; 1 runs everything in the process
itself). Both are read when a stage starts, never stored.

Why threadpoolctl: it is the maintained way (scikit-learn's) to set the
thread count of BLAS libraries already loaded into the process, which the
environment variables cannot do once numpy is imported.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Protocol, TypeVar

from ema_pipeline.data import ConfigError

__all__ = [
    "BLAS_THREADS_ENV",
    "THREAD_VARIABLES",
    "WORKERS_ENV",
    "available_cores",
    "blas_threads",
    "can_fork",
    "init_worker_process",
    "map_costliest_first",
    "owned_blas_threads",
    "Mapper",
    "SerialMap",
    "process_map",
    "split",
    "worker_count",
]

#: Environment variable: BLAS threads per process (a positive integer, or
#: ``auto`` to leave them to BLAS); default 1.
BLAS_THREADS_ENV = "EMA_PIPELINE_BLAS_THREADS"

#: Environment variable: the most worker processes a command starts (default:
#: the cores this process may use).
WORKERS_ENV = "EMA_PIPELINE_WORKERS"

#: The variables BLAS and OpenMP libraries read when they are loaded (set in a
#: process before it loads them, and so in worker processes).
THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)

R = TypeVar("R")
T = TypeVar("T")



class Mapper(Protocol):
    """``map_(func, items)``: ``[func(item) for item in items]``, maybe in
    ``map_.workers`` worker processes (callers split their work in that
    many pieces)."""

    workers: int

    def __call__(self, func: Callable[[T], R], items: Iterable[T]) -> list[R]: ...


def _positive_int(name: str, text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise ConfigError(f"${name} must be a positive integer, got {text!r}")
    return value


def blas_threads() -> int | None:
    """BLAS threads per process: 1, or ``$EMA_PIPELINE_BLAS_THREADS``
    (``None`` for ``auto``: leave them to BLAS).

    Examples
    --------
    >>> import os
    >>> blas_threads() if BLAS_THREADS_ENV not in os.environ else 1
    1
    """
    text = os.environ.get(BLAS_THREADS_ENV, "").strip()
    if not text:
        return 1
    if text.lower() == "auto":
        return None
    return _positive_int(BLAS_THREADS_ENV, text)


def available_cores() -> int:
    """The cores this process may use (its CPU affinity; at least 1)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def worker_count(n_tasks: int, requested: int | None = None) -> int:
    """Worker processes for ``n_tasks`` independent pieces of work.

    ``requested`` (e.g. ``--workers``) wins; else ``$EMA_PIPELINE_WORKERS``,
    else :func:`available_cores`; never more than ``n_tasks``, at least 1.

    Examples
    --------
    >>> worker_count(1)
    1
    >>> worker_count(10, requested=3)
    3
    """
    if requested is None:
        text = os.environ.get(WORKERS_ENV, "").strip()
        requested = _positive_int(WORKERS_ENV, text) if text else available_cores()
    return max(1, min(int(requested), int(n_tasks)))


@contextlib.contextmanager
def owned_blas_threads() -> Iterator[None]:
    """Run the block with :func:`blas_threads` BLAS threads in every BLAS
    library loaded into the process (restored after it).

    Libraries loaded inside the block keep their own count: callers import
    their numerics (numpy, scipy.linalg) before entering it.

    Examples
    --------
    >>> import numpy as np
    >>> with owned_blas_threads():
    ...     float(np.linalg.det(np.eye(3)))
    1.0
    """
    n = blas_threads()
    if n is None:
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=n):
        yield


def thread_environment() -> dict[str, str]:
    """The thread variables for a process that loads BLAS after this call
    (a child process, or this one before it imports numpy): each of
    :data:`THREAD_VARIABLES` at :func:`blas_threads` (none for ``auto``)."""
    n = blas_threads()
    return {} if n is None else {name: str(n) for name in THREAD_VARIABLES}


def init_worker_process() -> None:
    """A worker process: SIGINT is the parent's business, and it starts no
    workers of its own (one level of processes, never cores x cores)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ[WORKERS_ENV] = "1"


def can_fork() -> bool:
    """Whether worker processes may be forked from this process: the
    platform forks, and this process runs no other thread (a fork copies a
    lock another thread holds, locked forever)."""
    return "fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1


def forked_pool(workers: int) -> cf.ProcessPoolExecutor:
    """``workers`` worker processes forked from this one (check
    :func:`can_fork` first), each with one BLAS thread as this process and
    no workers of its own (:func:`init_worker_process`): the one place the
    package's per-command workers are made (``batch``'s, which must survive
    a crashed or hung file, come from a fork server instead)."""
    return cf.ProcessPoolExecutor(max_workers=workers,
                                  mp_context=multiprocessing.get_context("fork"),
                                  initializer=init_worker_process)


def process_imap(func: Callable[[T], R], items: list[T],
                 workers: int | None = None) -> Iterator[R]:
    """``func(item)`` for each of ``items`` in :func:`worker_count` worker
    processes (:func:`forked_pool`), yielded in the items' order as they are
    done (a caller can report progress); serial in this process with one
    worker or where it cannot fork. When the caller stops early (an error, a
    Ctrl-C, a closed generator), no item starts after that.

    Examples
    --------
    >>> list(process_imap(abs, [-1, 2, -3], workers=1))
    [1, 2, 3]
    """
    n = worker_count(len(items), workers)
    if n == 1 or not can_fork():
        for item in items:
            yield func(item)
        return
    with forked_pool(n) as pool:
        futures = [pool.submit(func, item) for item in items]
        try:
            for future in futures:
                yield future.result()
        finally:
            for future in futures:
                future.cancel()


class _LazyPool:
    """The :class:`Mapper` of :func:`process_map`: forks its workers at the
    first map of two or more items (a file with little work forks none)."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.pool: cf.ProcessPoolExecutor | None = None

    def __call__(self, func: Callable[[T], R], items: Iterable[T]) -> list[R]:
        items = list(items)
        if len(items) < 2:
            return [func(item) for item in items]
        if self.pool is None:
            self.pool = forked_pool(self.workers)
        return list(self.pool.map(func, items))

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)


@contextlib.contextmanager
def process_map(n_tasks: int, workers: int | None = None) -> Iterator[Mapper]:
    """A map over worker processes forked from this one, for up to
    ``n_tasks`` independent pieces of work at a time (:func:`worker_count`
    processes): the block gets ``map_(func, items)``, which returns
    ``[func(item) for item in items]`` in the items' order, the same numbers
    as a serial loop (each worker has one BLAS thread, as this process). The
    workers are forked at the first map of two or more items and serve every
    later map of the block. Serial in this process with one worker, or where
    it cannot fork (:func:`can_fork`). ``func`` and the items travel to the
    workers by reference to module-level functions and as copies of their
    data (a forked worker already has the code).

    Examples
    --------
    >>> with process_map(3, workers=1) as map_:
    ...     map_(abs, [-1, 2, -3])
    [1, 2, 3]
    """
    n = worker_count(n_tasks, workers)
    if n == 1 or not can_fork():
        yield SerialMap()
        return
    lazy = _LazyPool(n)
    try:
        yield lazy
    finally:
        lazy.close()


class SerialMap:
    """The :class:`Mapper` of one process: ``[func(item) for item in items]``.

    Examples
    --------
    >>> serial_map = SerialMap()
    >>> serial_map(abs, [-1, 2]), serial_map.workers
    ([1, 2], 1)
    """

    workers = 1

    def __call__(self, func: Callable[[T], R], items: Iterable[T]) -> list[R]:
        return [func(item) for item in items]


def split(items: list[T], n: int) -> list[list[T]]:
    """``items`` dealt round-robin into at most ``n`` non-empty lists (similar
    shares of work where the items grow or shrink along the list).

    Examples
    --------
    >>> split([1, 2, 3, 4, 5], 2)
    [[1, 3, 5], [2, 4]]
    """
    return [items[k::n] for k in range(min(n, len(items)))]


def map_costliest_first(map_: Mapper, func: Callable[[T], R], items: Sequence[T],
                         cost: Sequence[float]) -> list[R]:
    """``map_(func, items)``, the items handed out in descending ``cost``
    (a pool gives each to the next worker that is free, so no long task
    starts last while the others idle), the results in the items' order:
    the serial loop's.

    Examples
    --------
    >>> map_costliest_first(SerialMap(), abs, [-1, 2, -3], cost=[1.0, 9.0, 4.0])
    [1, 2, 3]
    """
    order = sorted(range(len(items)), key=lambda k: -cost[k])  # stable on ties
    done = map_(func, [items[k] for k in order])
    out: list[R] = [None] * len(items)  # type: ignore[list-item]
    for k, result in zip(order, done, strict=True):
        out[k] = result
    return out


def map_each(map_: Mapper | None, func_all: Callable[[list[T]], list[R]], items: list[T],
             min_items: int) -> list[R]:
    """``func_all(items)`` (one result per item, in order), shared out among
    the worker processes of ``map_`` in round-robin shares (:func:`split`)
    when it has two or more and there are at least ``min_items`` items; the
    results are put back in the order of ``items``, so they are the serial
    run's. ``func_all`` must be picklable (a bound method of a frozen
    dataclass holding the data, a module-level function).

    Examples
    --------
    >>> map_each(None, lambda xs: [x * x for x in xs], [1, 2, 3], 2)
    [1, 4, 9]
    >>> map_each(SerialMap(), lambda xs: [-x for x in xs], [1, 2, 3], 2)
    [-1, -2, -3]
    """
    if map_ is None or map_.workers < 2 or len(items) < min_items:
        return func_all(items)
    shares = split(items, map_.workers)
    done = map_(func_all, shares)
    out: list[R] = [None] * len(items)  # type: ignore[list-item]
    for k, results in enumerate(done):  # share k holds items k, k + n, k + 2n, ...
        out[k :: len(shares)] = results
    return out
