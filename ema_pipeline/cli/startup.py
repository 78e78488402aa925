"""A command's start-up in its own process: its imports' objects frozen as they are made.

A command imports numpy, scipy, h5py and the package before its work begins:
about 100 000 objects that live as long as the process. The cyclic garbage
collector walked them as they were made (``identify`` of the 12 paper files:
about 100 young and 8 middle collections, 16-19 ms of the 0.35 s before its
workers fork), though none of them is garbage. In the command's own process
(:func:`ema_pipeline.cli.run` calls :func:`mark_own_process`) the collector
is paused while :func:`start_up_imports` runs, and what the block made is
frozen (``gc.freeze``): never walked again, here or in a worker forked from
here. Where a program calls :func:`ema_pipeline.cli.main` itself (the tests),
the block changes nothing: the program's objects are its own.

This module imports nothing that loads numpy: :func:`ema_pipeline.cli.run`
uses it before numpy loads.
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator
from contextvars import ContextVar

__all__ = ["mark_own_process", "start_up_imports"]

#: True in the command's own process (set by :func:`mark_own_process`).
_OWN_PROCESS: ContextVar[bool] = ContextVar("ema_pipeline_cli_own_process", default=False)


def mark_own_process() -> None:
    """Mark this process as the command's own (:func:`ema_pipeline.cli.run`,
    the process's entry point): :func:`start_up_imports` then freezes.

    Examples
    --------
    In a context of its own (the mark is a context variable), then undone:

    >>> import contextvars, gc
    >>> def command_process() -> bool:
    ...     mark_own_process()
    ...     with start_up_imports():
    ...         made = [[i] for i in range(1000)]
    ...     frozen = gc.get_freeze_count() >= 1000
    ...     gc.unfreeze()
    ...     return frozen
    >>> contextvars.copy_context().run(command_process)
    True
    """
    _OWN_PROCESS.set(True)


@contextlib.contextmanager
def start_up_imports() -> Iterator[None]:
    """Run the block (a command's imports) with the garbage collector paused
    and freeze the objects that exist after it, in the command's own process
    (:func:`mark_own_process`); elsewhere, or with the collector off, run it
    as it is.

    Examples
    --------
    >>> import gc
    >>> before = gc.get_freeze_count()
    >>> with start_up_imports():  # not the command's own process: no change
    ...     import json
    >>> gc.get_freeze_count() == before, gc.isenabled()
    (True, True)
    """
    if not _OWN_PROCESS.get() or not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        gc.enable()
