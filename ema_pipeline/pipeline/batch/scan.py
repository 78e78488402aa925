"""Finding a batch's inputs and where each one's outputs go (the output layout
of the package docstring)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path

from ema_pipeline import io

__all__ = ["find_inputs", "is_inside", "output_dirs"]


def is_inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or lies below it."""
    try:
        path.relative_to(folder)
    except ValueError:
        return False
    return True


def find_inputs(folder: Path, out: Path) -> list[Path]:
    """The FRF files under ``folder`` (sorted), without those inside ``out`` and
    without result stores of ``identify`` / ``batch`` (``*_result.h5``): a batch
    never ingests its own outputs."""
    folder, out = folder.absolute(), out.absolute()
    files = [p for p in io.find_frf_files(folder) if not p.name.endswith("_result.h5")]
    if is_inside(out, folder):
        files = [p for p in files if not is_inside(p, out)]
    return files


def output_dirs(files: Sequence[Path], folder: Path, out: Path) -> Iterator[tuple[str, Path]]:
    """``(relative name, output folder)`` per input file, in order.

    ``DIR/sub/a.uff`` -> ``OUT/sub``; when several files in one folder share a
    stem (``a.uff``, ``a.h5``), each gets ``OUT/sub/<file name>``.
    """
    folder, out = folder.absolute(), out.absolute()
    rel = [p.relative_to(folder) for p in files]
    counts = Counter((r.parent, r.stem.casefold()) for r in rel)
    shared = {key for key, n in counts.items() if n > 1}
    del counts
    for r in rel:
        target = out / r.parent
        if (r.parent, r.stem.casefold()) in shared:
            target = target / r.name
        yield r.as_posix(), target
