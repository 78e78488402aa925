"""Hit-choice files (TOML): the hits an engineer chose by hand on the hit page, for
``ema-pipeline frf ... --hits hits.toml`` (as ``--picks`` is for ``identify``).

The layout: one ``[[recording]]`` table per recording file, with ``file`` (as the
hit table's ``file`` column says it for a channel sheet's test; ``""`` for the
recording(s) of a plain ``frf INPUT...``) and ``accepted``, the hit numbers (as the
hit table's ``hit`` column, 1-based) to average; every other hit of that file is
left out::

    [[recording]]
    file = "p1.csv"
    accepted = [1, 2, 4]
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from ema_pipeline.data import DataError
from ema_pipeline.io.files import read_toml, write_text

__all__ = ["hit_choice_toml", "read_hit_choice", "write_hit_choice"]


def read_hit_choice(path: str | os.PathLike[str]) -> dict[str, tuple[int, ...]]:
    """{file: accepted hit numbers} of a hit-choice file; a bad file is one
    :class:`DataError` naming it and the entry.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     p = write_hit_choice({"p1.csv": (1, 3)}, pathlib.Path(tmp) / "hits.toml")
    ...     read_hit_choice(p)
    {'p1.csv': (1, 3)}
    """
    path = Path(path)
    doc = read_toml(path, "a hit-choice file (TOML)")
    entries = doc.get("recording")
    unknown = sorted(set(doc) - {"recording"})
    if unknown or not isinstance(entries, list) or not entries:
        raise DataError(f"{path}: a hit-choice file holds [[recording]] tables (file, "
                        f"accepted){'; unknown: ' + ', '.join(unknown) if unknown else ''}")
    out: dict[str, tuple[int, ...]] = {}
    for k, entry in enumerate(entries, start=1):
        where = f"{path}: [[recording]] {k}"
        if not isinstance(entry, dict) or set(entry) - {"file", "accepted"}:
            raise DataError(f"{where}: keys must be file and accepted")
        file, hits = entry.get("file", ""), entry.get("accepted")
        if not isinstance(file, str):
            raise DataError(f"{where}: file must be text, got {file!r}")
        if not isinstance(hits, list) or not all(
            isinstance(h, int) and not isinstance(h, bool) and h >= 1 for h in hits
        ):
            raise DataError(f"{where}: accepted must be a list of hit numbers >= 1, got "
                            f"{hits!r}")
        if file in out:
            raise DataError(f"{where}: file {file!r} is given twice")
        out[file] = tuple(sorted(set(hits)))
    return out


def hit_choice_toml(choice: Mapping[str, tuple[int, ...] | list[int]]) -> str:
    """The TOML text of a hit choice {file: accepted hit numbers}."""
    lines = ["# ema-pipeline hit choice: ema-pipeline frf ... --hits THIS_FILE", ""]
    for file, hits in choice.items():
        escaped = file.replace("\\", "\\\\").replace('"', '\\"')
        lines += ["[[recording]]", f'file = "{escaped}"',
                  f"accepted = [{', '.join(str(h) for h in hits)}]", ""]
    return "\n".join(lines)


def write_hit_choice(choice: Mapping[str, tuple[int, ...] | list[int]],
                     path: str | os.PathLike[str]) -> Path:
    """Write a hit-choice file (atomically); returns the path."""
    return write_text(hit_choice_toml(choice), Path(path))
