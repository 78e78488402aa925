"""Picks files (TOML): the poles a user picked in the report's stabilization
diagram, for ``ema-pipeline identify FILE --picks PICKS.toml``.

The layout (a ``[diagram]`` table and one ``[[pick]]`` table per mode) is
described by :mod:`ema_pipeline.identification.picks`, which also writes it
(:meth:`~ema_pipeline.identification.picks.Picks.toml`).
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from ema_pipeline.data import DataError
from ema_pipeline.identification.picks import Picks, picks_from_mapping
from ema_pipeline.io.files import check_readable, write_text


def read_picks(path: str | os.PathLike[str]) -> Picks:
    """Read a picks file; a bad file is a :class:`DataError` naming it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ema_pipeline.identification.picks import Pick
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "picks.toml"
    ...     _ = write_picks(Picks((5.0, 100.0), (2, 4), (Pick(30.0, 0.01, order=4),)), path)
    ...     read_picks(path).picks[0].order
    4
    """
    path = Path(path)
    check_readable(path, "a picks file (TOML)")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not valid TOML ({exc})") from exc
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror or exc})") from exc
    return picks_from_mapping(doc, str(path))


def write_picks(picks: Picks, path: str | os.PathLike[str]) -> Path:
    """Write ``picks`` as a picks file (atomically); returns the path."""
    return write_text(picks.toml(), Path(path))
