"""Resuming a batch: what a complete result says, stale temporaries of a
killed run, and the lock that keeps two batches out of one output folder.

Completeness and the input hash of a result are read by :mod:`ema_pipeline.io`
(the only module that opens HDF5 files).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline import io
from ema_pipeline.data import ConfigError, DataError

__all__ = ["LOCK_NAME", "batch_lock", "completed_details", "remove_stale_temporaries"]

#: Lock file in the output folder (see :func:`batch_lock`).
LOCK_NAME = ".batch.lock"


def completed_details(result_h5: Path) -> dict[str, Any]:
    """Configuration, frequencies and fit quality stored in a complete result file
    (the :class:`~ema_pipeline.pipeline.batch.tasks.FileRecord` fields of a skipped file)."""
    try:
        stored = io.result_details(result_h5)
    except DataError:
        return {}  # the row just stays less informative; the result itself is complete
    details: dict[str, Any] = {"configuration": stored["configuration"]}
    if "fn_hz" in stored:
        details["fn_hz"] = tuple(float(f) for f in stored["fn_hz"])
    if "warnings" in stored:
        details["warnings"] = tuple(stored["warnings"])
    if "frac" in stored and "error" in stored:
        details["fit_frac"] = float(np.mean(stored["frac"]))
        details["fit_error"] = float(np.mean(stored["error"]))
    return details


@contextlib.contextmanager
def batch_lock(out: Path) -> Iterator[None]:
    """Hold ``OUT/.batch.lock`` (flock) so two batches do not share one OUT.

    The lock goes with the process, so a killed batch never leaves it stale;
    a batch that ends removes the file (while it still holds the lock, so no
    other batch can have taken it).
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - no flock (Windows): no lock
        yield
        return
    with open(out / LOCK_NAME, "a+", encoding="utf-8") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as exc:
            raise ConfigError(
                f"{out}: another batch is writing to this folder (lock {out / LOCK_NAME})"
            ) from exc
        try:
            yield
        finally:
            (out / LOCK_NAME).unlink(missing_ok=True)
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def remove_stale_temporaries(out: Path) -> int:
    """Delete the hidden temporary files (``.*.tmp``) a killed run left in ``out``."""
    removed = 0
    for tmp in out.rglob(".*.tmp"):
        if tmp.is_file():
            tmp.unlink(missing_ok=True)
            removed += 1
    return removed
