"""The package's worker processes: one runner for every parallel job.

Every piece of work that runs in other processes goes through this module:
several files of ``identify FILE...`` (:func:`process_imap`), one file's
windows, diagrams and local fits (:func:`process_map` and the maps of a
:class:`Mapper`), and the files of ``batch`` on local processes
(:class:`ProcessPool`). dask.distributed is the scale-out path of ``batch``
(:mod:`ema_pipeline.pipeline.batch.dask`) and does not come here.

The rules it keeps:

* **Workers from an argument.** ``workers`` is passed by the caller (the
  library's default is 1: no process is started; the CLI passes the cores,
  ``--workers`` or ``$EMA_PIPELINE_WORKERS``, read by the CLI). No parameter
  travels through ``os.environ``.
* **One fork-safety rule, checked at the fork.** A process may be forked when
  the platform forks and no other thread runs, apart from threads named
  :data:`FORK_SAFE_THREAD_NAME` that hold no lock (:func:`fork_is_safe`;
  forking beside a thread that holds a lock leaves the lock held forever in
  the child). The rule is asked right before the fork (:func:`checked_fork`,
  the first map of a :func:`process_map` block, :func:`process_imap`), never
  earlier; where it says no, the work runs in this process, with the same
  numbers.
* **One level of processes.** A worker starts no workers of its own
  (:func:`in_worker`): cores x cores processes would fight for the cores.
* **Ctrl-C stops at once.** Workers ignore SIGINT (the parent decides); a
  Ctrl-C in the parent terminates the running workers instead of waiting
  for their files.
* **Forked with the objects frozen.** This process's objects are frozen
  (``gc.freeze``) for the fork and unfrozen after it here
  (:func:`frozen_for_fork`), as the :mod:`gc` module's documentation advises:
  a child's garbage collections then never walk what it inherited.
* **A crashed worker is reported.** A worker killed (out of memory, a signal,
  a crash in a C library) breaks its pool; :func:`process_imap` runs the items
  that were in flight again one at a time, and an item that kills its worker
  alone is reported (:class:`WorkerCrashed`, or the caller's ``crashed``
  result), never waited on.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import gc
import multiprocessing
import os
import select
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures.process import BrokenProcessPool
from typing import Literal, Protocol, TypeVar

from ema_pipeline.threads import blas_threads, own_process_blas_threads

__all__ = [
    "FORK_SAFE_THREAD_NAME",
    "Mapper",
    "ProcessPool",
    "SerialMap",
    "WorkerCrashed",
    "available_cores",
    "checked_fork",
    "deal_by_cost",
    "fork_is_safe",
    "frozen_for_fork",
    "in_worker",
    "map_costliest_first",
    "map_each",
    "pid_alive",
    "process_imap",
    "process_map",
    "split",
    "started_ahead",
    "worker_count",
]

#: Threads with this name hold no lock (they only sleep and poll, e.g. a batch
#: worker's parent watcher): :func:`fork_is_safe` lets a fork happen beside them.
FORK_SAFE_THREAD_NAME = "ema-fork-safe"

R = TypeVar("R")
T = TypeVar("T")

_in_worker = False  # set in each worker process by its start-up


class WorkerCrashed(ChildProcessError):
    """A worker process died (killed, out of memory, a crash) while it ran an item
    (an :class:`OSError`: the machine's trouble, not the input's)."""


class Mapper(Protocol):
    """``map_(func, items)``: ``[func(item) for item in items]``, maybe in
    ``map_.workers`` worker processes (callers split their work in that
    many pieces)."""

    workers: int

    def __call__(self, func: Callable[[T], R], items: Iterable[T]) -> list[R]: ...


def available_cores() -> int:
    """The cores this process may use (its CPU affinity; at least 1).

    Examples
    --------
    >>> available_cores() >= 1
    True
    """
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def worker_count(n_tasks: int, workers: int = 1) -> int:
    """Worker processes for ``n_tasks`` independent pieces of work: ``workers``,
    never more than ``n_tasks``, at least 1, and 1 inside a worker (one level
    of processes).

    Examples
    --------
    >>> worker_count(1, 4), worker_count(10, 3), worker_count(10)
    (1, 3, 1)
    """
    if _in_worker:
        return 1
    return max(1, min(int(workers), int(n_tasks)))


def in_worker() -> bool:
    """Whether this process is a worker of this module's pools.

    Examples
    --------
    >>> in_worker()
    False
    """
    return _in_worker


def pid_alive(pid: int) -> bool:
    """Whether a process with this id exists (ours or another user's).

    Examples
    --------
    >>> pid_alive(os.getpid())
    True
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists, owned by someone else
        return True
    return True


def fork_is_safe() -> bool:
    """The fork-safety rule: the platform forks, and every thread of this
    process other than the calling one is named :data:`FORK_SAFE_THREAD_NAME`.

    Examples
    --------
    >>> fork_is_safe()
    True
    """
    if "fork" not in multiprocessing.get_all_start_methods():  # pragma: no cover
        return False
    me = threading.current_thread()
    return all(t is me or t.name == FORK_SAFE_THREAD_NAME for t in threading.enumerate())


def checked_fork() -> int | None:
    """``os.fork()`` when :func:`fork_is_safe` says so at this moment: the
    child's id in the parent, 0 in the child; ``None`` (no fork) otherwise.
    The child must end with ``os._exit``. Forked in :func:`frozen_for_fork`."""
    if not fork_is_safe():
        return None
    with frozen_for_fork():
        return os.fork()


@contextlib.contextmanager
def frozen_for_fork() -> Iterator[None]:
    """Run the block (a fork) with every object of this process frozen
    (``gc.freeze``), unfrozen after it in this process, as before: the
    children keep them frozen, so their garbage collections never walk them.

    What it saves: a worker's first full collection walked the objects it
    inherited (numpy's, scipy's, h5py's and the package's), 27-28 ms in each
    worker of ``identify`` on the 12 paper files, and every page it touched
    was copied from the parent. The :mod:`gc` module's documentation advises
    this for processes that fork without exec. Objects frozen before the
    block (by the caller, or the parent of a worker) are left as they are:
    nothing is frozen or unfrozen then. A forked child leaves the block with
    its objects still frozen.

    Examples
    --------
    >>> import gc
    >>> with frozen_for_fork():
    ...     during = gc.get_freeze_count() > 0
    >>> during, gc.get_freeze_count() == 0
    (True, True)
    """
    if gc.get_freeze_count():
        yield
        return
    froze_in = os.getpid()
    gc.freeze()
    try:
        yield
    finally:
        if os.getpid() == froze_in:
            gc.unfreeze()


def _start_worker(blas: int | None) -> None:
    """A worker's start-up: SIGINT is the parent's business, it starts no
    workers of its own, and its BLAS runs on ``blas`` threads (None: BLAS's
    own count)."""
    global _in_worker
    _in_worker = True
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    own_process_blas_threads(blas)


def _start_server_worker(parent_pid: int, environ: Mapping[str, str],
                         setup: Callable[[], object] | None, blas: int | None) -> None:
    """A fork-server worker's start-up: :func:`_start_worker`, the parent's
    environment, the pool's ``setup`` (a log, say), and an exit when the
    parent dies."""
    if os.environ != environ:  # a fork server started by an earlier pool
        os.environ.clear()
        os.environ.update(environ)
    if setup is not None:
        setup()
    _start_worker(blas)
    threading.Thread(target=_exit_with_parent, args=(parent_pid,), name=FORK_SAFE_THREAD_NAME,
                     daemon=True).start()


def _exit_with_parent(parent_pid: int) -> None:
    """Exit this worker once the process that made the pool is gone (no
    orphans that keep writing outputs while a rerun starts). A fork-server
    worker's parent is the server: wait on a pidfd of the pool's process, or
    else poll it every 0.5 s."""
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


class ProcessPool:
    """Worker processes that survive what a file does to them.

    ``start="fork"``: forked from this process at the first submit (check
    :func:`fork_is_safe` first); ``start="server"``: forked by a fork server
    (``spawn`` where there is none), a fresh single-threaded interpreter that
    imports ``preload`` once, for a process that may run threads or hold
    files open (``batch``). Workers ignore SIGINT, run BLAS on
    :func:`ema_pipeline.threads.blas_threads` threads and start no workers;
    server workers also take this process's environment, run ``setup`` (a
    module-level function: it travels by reference) and exit when it dies.
    :meth:`restart` replaces a broken pool (a worker that died) or a hung
    one; ``close(abort=True)`` terminates the running workers at once.
    """

    def __init__(self, workers: int, *, start: Literal["fork", "server"] = "fork",
                 preload: Sequence[str] = (), setup: Callable[[], object] | None = None) -> None:
        self.workers = workers
        self.start = start
        self.preload = tuple(preload)
        self.setup = setup
        self._executor = self._new_executor()

    def _new_executor(self) -> cf.ProcessPoolExecutor:
        self._before = set(multiprocessing.active_children())
        self._threads_before = set(threading.enumerate())
        self._seen: set[multiprocessing.process.BaseProcess] = set()
        self._forked = False  # a fork executor forks its workers at its first submit
        if self.start == "fork":
            return cf.ProcessPoolExecutor(
                max_workers=self.workers, mp_context=multiprocessing.get_context("fork"),
                initializer=_start_worker, initargs=(blas_threads(),))
        context: multiprocessing.context.BaseContext
        if "forkserver" in multiprocessing.get_all_start_methods():
            server = multiprocessing.get_context("forkserver")
            server.set_forkserver_preload(list(self.preload))
            context = server
        else:  # pragma: no cover - no fork server on this platform
            context = multiprocessing.get_context("spawn")
        return cf.ProcessPoolExecutor(
            max_workers=self.workers, mp_context=context, initializer=_start_server_worker,
            initargs=(os.getpid(), dict(os.environ), self.setup, blas_threads()))

    def submit(self, func: Callable[[T], R], item: T) -> cf.Future[R]:
        """``func(item)`` in a worker; the first submit of a ``"fork"`` pool
        forks its workers (in :func:`frozen_for_fork`)."""
        forks = self.start == "fork" and not self._forked
        self._forked = True
        with frozen_for_fork() if forks else contextlib.nullcontext():
            future = self._executor.submit(func, item)
        self.processes()  # the workers it started
        return future

    def processes(self) -> list[multiprocessing.process.BaseProcess]:
        """The pool's live worker processes (the children started since it was made)."""
        live = [p for p in multiprocessing.active_children() if p not in self._before]
        self._seen.update(live)
        return live

    def death(self) -> str:
        """How the pool's workers that died ended (after a break; a worker just
        killed may take a moment to be reaped: waited for up to 1 s)."""
        deadline = time.monotonic() + 1.0
        codes = sorted({p.exitcode for p in self._seen if p.exitcode})
        while not codes and time.monotonic() < deadline:
            time.sleep(0.01)
            codes = sorted({p.exitcode for p in self._seen if p.exitcode})
        if not codes:
            return "its worker process died"
        how = [f"killed by {signal.Signals(-c).name}" if c < 0 else f"exit status {c}"
               for c in codes]
        return f"its worker process died ({', '.join(how)})"

    def restart(self) -> None:
        """Terminate the workers and start a fresh pool (after a death or a hang)."""
        self._terminate()
        self._join_threads()
        self._executor = self._new_executor()

    def _terminate(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)
        for process in self.processes():
            process.terminate()
        for process in self.processes():
            process.join(timeout=5.0)

    def close(self, *, abort: bool = False) -> None:
        """Shut the pool down: after the running items (``abort=False``) or at
        once; either way its threads have ended when it returns, so that a
        fork right after is safe (:func:`fork_is_safe`)."""
        if abort:
            self._terminate()
        self._executor.shutdown(wait=True, cancel_futures=True)
        self._join_threads()

    def _join_threads(self) -> None:
        """Wait for the threads the executor started (its manager, its queues'
        feeders): a shutdown without waiting, as an abort makes, forgets its
        manager thread, and a second shutdown no longer joins it, so for a
        moment after an abort the threads run on (measured: 28 of 30 pools
        aborted with work running; the next fork was then refused). A thread
        is listed from the moment another thread starts it, before it can be
        joined (the manager thread starts a queue's feeder as this one closes:
        29 and 30 of 1000 pools closed right after their submit): it is waited
        for, and the threads are listed again until none is left (5 s in all)."""
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            running = [thread for thread in set(threading.enumerate()) - self._threads_before
                       if type(thread).__module__ == cf.process.__name__
                       or thread.name == "QueueFeederThread"]
            if not running:
                return
            for thread in running:
                try:
                    thread.join(timeout=max(0.0, deadline - time.monotonic()))
                except RuntimeError:  # not started yet: listed again in a moment
                    time.sleep(0.001)


def process_imap(func: Callable[[T], R], items: Sequence[T], workers: int = 1, *,
                 crashed: Callable[[T, str], R] | None = None) -> Iterator[R]:
    """``func(item)`` for each of ``items`` in :func:`worker_count` worker
    processes forked from this one, yielded in the items' order as they are
    done (a caller can report progress); in this process with one worker or
    where :func:`fork_is_safe` says no at the fork.

    A worker that dies breaks the pool: the items then in flight run again
    one at a time, and one that kills its worker alone gives
    ``crashed(item, reason)`` (default: :class:`WorkerCrashed` naming the
    item). When the caller stops early (an error, a Ctrl-C, a closed
    generator), the running workers are terminated and no item starts.

    Examples
    --------
    >>> list(process_imap(abs, [-1, 2, -3]))
    [1, 2, 3]
    """
    items = list(items)
    n = worker_count(len(items), workers)
    if n == 1 or not fork_is_safe():
        for item in items:
            yield func(item)
        return
    done: dict[int, R] = {}
    todo = list(range(len(items)))  # not yielded yet, in order
    suspects: list[int] = []  # in flight when a pool broke: each runs alone
    while todo:
        batch = suspects[:1] if suspects else [k for k in todo if k not in done]
        pool = ProcessPool(1 if suspects else n)
        finished = False
        try:
            futures = _submitted(pool, func, [(k, items[k]) for k in batch])
            for k, future in futures:
                try:
                    done[k] = future.result()
                except BrokenProcessPool:
                    if not suspects:
                        suspects = [j for j in todo if j not in done][: n + 1]
                        break
                    reason = f"{items[k]}: {pool.death()}"
                    if crashed is None:
                        raise WorkerCrashed(reason) from None
                    done[k] = crashed(items[k], reason)
                if suspects:
                    suspects.pop(0)
                while todo and todo[0] in done:
                    yield done.pop(todo.pop(0))
            else:
                finished = True
        finally:
            pool.close(abort=not finished)


def _submitted(pool: ProcessPool, func: Callable[[T], R],
              items: list[tuple[int, T]]) -> list[tuple[int, cf.Future[R]]]:
    """``pool.submit(func, item)`` of each ``(key, item)``, with its key, up to
    the first the pool refuses because a worker has died (an item that kills
    its worker at once can break the pool before the next one goes out): the
    futures submitted, one of which reports the death (``BrokenProcessPool``);
    the caller runs the rest again."""
    futures = []
    for key, item in items:
        try:
            futures.append((key, pool.submit(func, item)))
        except BrokenProcessPool:
            break
    return futures


class _LazyPool:
    """The :class:`Mapper` of :func:`process_map`: forks its workers at the
    first map of two or more items (a file with little work forks none) that
    finds :func:`fork_is_safe` true; until then it maps in this process."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.pool: ProcessPool | None = None

    def __call__(self, func: Callable[[T], R], items: Iterable[T]) -> list[R]:
        items = list(items)
        if len(items) < 2 or (self.pool is None and not fork_is_safe()):
            return [func(item) for item in items]
        if self.pool is None:
            self.pool = ProcessPool(self.workers)
        try:
            # a worker that died breaks the pool: a submit refused or a result lost
            futures = [self.pool.submit(func, item) for item in items]
            return [future.result() for future in futures]
        except BrokenProcessPool:
            raise WorkerCrashed("a worker process died (killed, out of memory or a crash) "
                                "while it computed a share of the identification") from None

    def close(self, *, abort: bool) -> None:
        if self.pool is not None:
            self.pool.close(abort=abort)


@contextlib.contextmanager
def process_map(n_tasks: int, workers: int = 1) -> Iterator[Mapper]:
    """A map over worker processes forked from this one, for up to
    ``n_tasks`` independent pieces of work at a time (:func:`worker_count`
    processes): the block gets ``map_(func, items)``, which returns
    ``[func(item) for item in items]`` in the items' order, the same numbers
    as a serial loop (each worker has this process's BLAS threads). The
    workers are forked at the first map of two or more items, if
    :func:`fork_is_safe` says so then, and serve every later map of the
    block; a Ctrl-C or an error in the block terminates them. ``func`` and the
    items travel to the workers by reference to module-level functions and
    as copies of their data (a forked worker already has the code).

    Examples
    --------
    >>> with process_map(3) as map_:
    ...     map_(abs, [-1, 2, -3])
    [1, 2, 3]
    """
    n = worker_count(n_tasks, workers)
    if n == 1:
        yield SerialMap()
        return
    lazy = _LazyPool(n)
    aborted = True
    try:
        yield lazy
        aborted = False
    finally:
        lazy.close(abort=aborted)


@contextlib.contextmanager
def started_ahead(func: Callable[[T], R], item: T, workers: int = 1) -> Iterator[Callable[[], R]]:
    """``func(item)`` begun now in a worker process of its own, for a result
    the caller may or may not need (work begun ahead, beside its own): the
    block gets a function that returns the result, waiting for the worker.
    With ``workers`` < 2, inside a worker (one level of processes) or where
    :func:`fork_is_safe` says no, no worker is started and the function
    computes the result in this process when first called. On leaving the
    block a worker still running is terminated: work begun ahead and not
    needed costs no waiting (a fork and a kill, about 10 ms). The worker is
    gone once its result is taken (a map may fork the workers of
    :func:`process_map` right after). The result is the serial computation's
    (the worker has this process's BLAS threads).

    Examples
    --------
    >>> with started_ahead(abs, -3, workers=2) as result:
    ...     result()
    3
    """
    pool = ProcessPool(1) if worker_count(2, workers) >= 2 and fork_is_safe() else None
    future = pool.submit(func, item) if pool is not None else None
    here: list[R] = []

    def closed(*, abort: bool) -> None:
        nonlocal pool
        if pool is not None:
            pool.close(abort=abort)  # its threads ended: a fork right after is safe
            pool = None

    def result() -> R:
        if not here:
            if future is None:
                here.append(func(item))
            else:
                try:
                    here.append(future.result())
                except BrokenProcessPool:
                    raise WorkerCrashed("a worker process died (killed, out of memory or a "
                                        "crash) while it computed work begun ahead") from None
                closed(abort=False)  # done with: the cores are free for other workers
        return here[0]

    try:
        yield result
    finally:
        closed(abort=True)


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
             min_items: int, cost: Sequence[float] | None = None) -> list[R]:
    """``func_all(items)`` (one result per item, in order), shared out among
    the worker processes of ``map_`` when it has two or more and there are
    at least ``min_items`` items; the results are put back in the order of
    ``items``, so they are the serial run's. ``func_all`` must be picklable
    (a bound method of a frozen dataclass holding the data, a module-level
    function). The shares are dealt round-robin (:func:`split`) or, with
    ``cost`` (an estimate per item, any unit), costliest first, each item to
    the share with the least cost so far (:func:`deal_by_cost`): one share
    then seldom holds the few long items while the other workers idle.

    Examples
    --------
    >>> map_each(None, lambda xs: [x * x for x in xs], [1, 2, 3], 2)
    [1, 4, 9]
    >>> map_each(SerialMap(), lambda xs: [-x for x in xs], [1, 2, 3], 2, cost=[1, 5, 2])
    [-1, -2, -3]
    """
    if map_ is None or map_.workers < 2 or len(items) < min_items:
        return func_all(items)
    if cost is None:
        dealt = split(list(range(len(items))), map_.workers)
    else:
        dealt = deal_by_cost(cost, map_.workers)
    done = map_(func_all, [[items[k] for k in share] for share in dealt])
    out: list[R] = [None] * len(items)  # type: ignore[list-item]
    for share, results in zip(dealt, done, strict=True):
        for k, result in zip(share, results, strict=True):
            out[k] = result
    return out


def deal_by_cost(cost: Sequence[float], n: int) -> list[list[int]]:
    """The indices of ``cost`` dealt into at most ``n`` non-empty shares,
    costliest first, each to the share with the least total so far (the
    longest-processing-time rule; ties: the item first in the list, the
    lowest share). Each share keeps its items in ascending order.

    Examples
    --------
    >>> deal_by_cost([1.0, 9.0, 4.0, 3.0, 2.0], 2)
    [[0, 1], [2, 3, 4]]
    >>> deal_by_cost([5.0], 3)
    [[0]]
    """
    shares: list[list[int]] = [[] for _ in range(min(n, len(cost)))]
    totals = [0.0] * len(shares)
    for k in sorted(range(len(cost)), key=lambda k: -cost[k]):  # stable on ties
        least = totals.index(min(totals))
        shares[least].append(k)
        totals[least] += float(cost[k])
    return [sorted(share) for share in shares]
