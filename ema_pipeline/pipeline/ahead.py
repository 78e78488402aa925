"""FRF files read ahead, in a process of their own, while the command's
process imports the identification chain (:func:`read_ahead`).

The chain (numpy's linear algebra, scipy's LAPACK wrappers and their
array-API layer) takes about a third of a second to import, on one core;
the files are read on another meanwhile. Only :mod:`ema_pipeline.io` is
imported here, so that this module can be imported before that chain.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ema_pipeline import io
from ema_pipeline.data import MIN_FRF_LINES, FRFSet

__all__ = ["READ_AHEAD_BYTES", "read_ahead"]

#: The files read ahead, in order, are at most this many bytes in all (the
#: FRFs wait in memory for their worker; an import reads about 40 files of
#: the paper's 0.7 MB in the time it takes, so more gains nothing).
READ_AHEAD_BYTES = 64 * 2**20


def read_ahead(paths: Sequence[str | Path]) -> tuple[FRFSet | None, ...]:
    """The FRFs of each of ``paths`` as identification reads them
    (:func:`ema_pipeline.io.read_frf` with
    :data:`~ema_pipeline.data.MIN_FRF_LINES`, the paths checked by the
    caller), in order, up to :data:`READ_AHEAD_BYTES` of files; None for a
    file past that, or one that fails to read: its worker reads it again and
    reports what is wrong, as without reading ahead.

    Examples
    --------
    >>> read_ahead(["missing.uff"])
    (None,)
    """
    out: list[FRFSet | None] = []
    left = READ_AHEAD_BYTES
    for path in paths:
        frf = None
        try:
            size = Path(path).stat().st_size
            if size <= left:
                left -= size
                frf = io.read_frf(path, min_lines=MIN_FRF_LINES, checked=True)
        except Exception:  # noqa: BLE001 - read again by its worker, which reports it
            frf = None
        out.append(frf)
    return tuple(out)
