"""Picks files (TOML): the poles a user picked in the report's stabilization
diagram, for ``ema-pipeline identify FILE --picks PICKS.toml``.

The layout (a ``[diagram]`` table and one ``[[pick]]`` table per mode) is
described by :mod:`ema_pipeline.identification.picks`, which also writes it
(:meth:`~ema_pipeline.identification.picks.Picks.toml`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from ema_pipeline.io.files import read_toml, write_text

if TYPE_CHECKING:  # pragma: no cover
    from ema_pipeline.identification.picks import Picks


def read_picks(path: str | os.PathLike[str]) -> Picks:
    """Read a picks file; a bad file is a :class:`DataError` naming it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ema_pipeline.identification.picks import Pick, Picks
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "picks.toml"
    ...     _ = write_picks(Picks((5.0, 100.0), (2, 4), (Pick(30.0, 0.01, order=4),)), path)
    ...     read_picks(path).picks[0].order
    4
    """
    # imported here: the picks module fits poles (scipy), which reading and
    # writing other files does not need (``import ema_pipeline.io`` stays light)
    from ema_pipeline.identification.picks import picks_from_mapping

    path = Path(path)
    doc = read_toml(path, "a picks file (TOML)")
    return picks_from_mapping(doc, str(path))


def write_picks(picks: Picks, path: str | os.PathLike[str]) -> Path:
    """Write ``picks`` as a picks file (atomically); returns the path."""
    return write_text(picks.toml(), Path(path))
