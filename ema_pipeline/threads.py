"""The tool's own BLAS thread count: one BLAS thread per process.

Identification makes hundreds of thousands of small linear-algebra calls
(companion eigenvalues, QR and solves of a few dozen columns). A threaded
BLAS (OpenBLAS starts one thread per core) splits each of them over its
threads, which spin, wait for each other and fight every other process on
the machine (measured: docs/validation.md). So every stage runs its linear algebra
on one BLAS thread whatever ``OPENBLAS_NUM_THREADS`` and its kind say, and
the cores are used by worker processes where the work splits into
independent pieces (:mod:`ema_pipeline.runner`).

The one override is the environment variable :data:`BLAS_THREADS_ENV`
(``EMA_PIPELINE_BLAS_THREADS``), read like the BLAS libraries' own
variables: a positive integer sets the BLAS threads of each process,
``auto`` leaves them to BLAS and its own variables. The worker processes
are not set here: they are an argument (``workers=``) of the functions that
start them.

Why threadpoolctl: it is the maintained way (scikit-learn's) to set the
thread count of BLAS libraries already loaded into the process, which the
environment variables cannot do once numpy is imported.

The command line's process sets the variables too, before numpy and scipy
load their BLAS libraries (:func:`entry_thread_environment`, read by
:func:`ema_pipeline.cli.run`): a library loaded with its default starts one
thread per core, which spin at start-up beside the process's own work and
are then never used (measured: one process burned 0.3-0.4 s of CPU more,
and ``identify`` took 3-4 % longer on two cores). This module imports
nothing that loads numpy, for that reason.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from contextvars import ContextVar

__all__ = [
    "BLAS_THREADS_ENV",
    "THREAD_VARIABLES",
    "blas_threads",
    "entry_thread_environment",
    "own_process_blas_threads",
    "owned_blas_threads",
    "positive_int_setting",
    "thread_environment",
    "thread_variables",
]

#: Environment variable: BLAS threads per process (a positive integer, or
#: ``auto`` to leave them to BLAS); default 1.
BLAS_THREADS_ENV = "EMA_PIPELINE_BLAS_THREADS"

#: The variables BLAS and OpenMP libraries read when they are loaded (set in a
#: process before it loads them, and so in worker processes).
THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)


def positive_int_setting(name: str, text: str) -> int:
    """The positive integer of the environment variable ``name`` set to ``text``,
    else ConfigError naming it.

    Examples
    --------
    >>> positive_int_setting("EMA_PIPELINE_WORKERS", " 3")
    3
    """
    value = _positive_int(text)
    if value is None:
        # here, not at the top: importing ema_pipeline.data loads numpy
        from ema_pipeline.data import ConfigError

        raise ConfigError(f"${name} must be a positive integer, got {text!r}")
    return value


def _positive_int(text: str) -> int | None:
    """``text`` as a positive integer, else None."""
    try:
        value = int(text)
    except ValueError:
        return None
    return value if value >= 1 else None


def _blas_setting() -> tuple[str, bool, int | None]:
    """``$EMA_PIPELINE_BLAS_THREADS`` read: its text, whether it is valid, and
    the threads it asks for (1 when unset or empty, None for ``auto``)."""
    text = os.environ.get(BLAS_THREADS_ENV, "").strip()
    if not text:
        return text, True, 1
    if text.lower() == "auto":
        return text, True, None
    n = _positive_int(text)
    return text, n is not None, n


def blas_threads() -> int | None:
    """BLAS threads per process: 1, or ``$EMA_PIPELINE_BLAS_THREADS``
    (``None`` for ``auto``: leave them to BLAS).

    Examples
    --------
    >>> import os
    >>> blas_threads() if BLAS_THREADS_ENV not in os.environ else 1
    1
    """
    text, valid, n = _blas_setting()
    return n if valid else positive_int_setting(BLAS_THREADS_ENV, text)  # refused by name


#: The BLAS threads that :func:`owned_blas_threads` (a block) or
#: :func:`own_process_blas_threads` (a worker process) has set here; None:
#: not set. A fork carries it to the child with the libraries' counts.
_OWNED: ContextVar[int | None] = ContextVar("ema_pipeline_owned_blas_threads", default=None)


@contextlib.contextmanager
def owned_blas_threads() -> Iterator[None]:
    """Run the block with :func:`blas_threads` BLAS threads in every BLAS
    library loaded into the process (restored after it).

    Libraries loaded inside the block keep their own count: callers import
    their numerics (numpy, scipy.linalg) before entering it. Inside a block
    (or a worker process, :func:`own_process_blas_threads`) that already set
    the same count, it does nothing: ``identify`` inside the command line's
    block or inside a worker asked threadpoolctl again for every file (about
    1 ms each, and 5-11 ms at each worker's start).

    Examples
    --------
    >>> import numpy as np
    >>> with owned_blas_threads():
    ...     float(np.linalg.det(np.eye(3)))
    1.0
    """
    n = blas_threads()
    if n is None or _OWNED.get() == n:
        yield
        return
    from threadpoolctl import threadpool_limits

    token = _OWNED.set(n)
    try:
        with threadpool_limits(limits=n):
            yield
    finally:
        _OWNED.reset(token)


def own_process_blas_threads(n: int | None) -> None:
    """Set ``n`` BLAS threads in every BLAS library loaded into this process,
    for the rest of its life (a worker's start-up,
    :mod:`ema_pipeline.runner`); None leaves them to BLAS. A process forked
    inside :func:`owned_blas_threads` (or from a worker) with the same count
    has nothing to do: its libraries' counts came with the fork.

    Examples
    --------
    >>> own_process_blas_threads(None)  # "auto": BLAS's own count
    """
    if n is None or _OWNED.get() == n:
        return
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=n)
    _OWNED.set(n)


@contextlib.contextmanager
def thread_variables() -> Iterator[None]:
    """Run the block with :func:`thread_environment` in ``os.environ`` (for the
    libraries loaded and the processes started in it), restored after it.

    Examples
    --------
    >>> before = dict(os.environ)
    >>> with thread_variables():
    ...     os.environ.get("OPENBLAS_NUM_THREADS") in (None, str(blas_threads()))
    True
    >>> dict(os.environ) == before
    True
    """
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


def entry_thread_environment() -> dict[str, str]:
    """:func:`thread_environment` for a process's entry point, before it
    loads numpy: the same variables, and none when
    ``$EMA_PIPELINE_BLAS_THREADS`` is not valid (the command then refuses it
    by name through :func:`blas_threads`, as without this call).

    Examples
    --------
    >>> import os
    >>> env = entry_thread_environment()
    >>> env == thread_environment() if BLAS_THREADS_ENV not in os.environ else True
    True
    """
    _, valid, n = _blas_setting()
    return _variables(n) if valid else {}


def thread_environment() -> dict[str, str]:
    """The thread variables for a process that loads BLAS after this call
    (a child process, or this one before it imports numpy): each of
    :data:`THREAD_VARIABLES` at :func:`blas_threads` (none for ``auto``)."""
    return _variables(blas_threads())


def _variables(n: int | None) -> dict[str, str]:
    """Each of :data:`THREAD_VARIABLES` at ``n`` threads (none for None: ``auto``)."""
    return {} if n is None else {name: str(n) for name in THREAD_VARIABLES}
