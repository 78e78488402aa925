"""Finding a batch's inputs and where each one's outputs go (the output layout
of the package docstring)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path

from ema_pipeline import io
from ema_pipeline.data import DataError
from ema_pipeline.io.channel_sheet import is_channel_sheet, read_channel_sheet
from ema_pipeline.io.recording import RECORDING_ONLY_SUFFIXES, is_recording

__all__ = ["find_inputs", "is_inside", "output_dirs"]


def is_inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or lies below it."""
    try:
        path.relative_to(folder)
    except ValueError:
        return False
    return True


def find_inputs(folder: Path, out: Path) -> list[Path]:
    """The FRF files and raw recordings under ``folder`` (sorted), without those
    inside ``out`` and without result stores of ``identify`` / ``batch``
    (``*_result.h5``): a batch never ingests its own outputs. Recordings are the
    ``.tdms`` and ``.wav`` files and the ``.csv`` files whose first column is a
    time (:func:`ema_pipeline.io.recording.is_recording`); UFF files are inputs
    either way (FRFs or time records, told apart when processed). A channel sheet
    (:func:`ema_pipeline.io.channel_sheet.is_channel_sheet`) is one input, a whole
    roving test: the recordings it names are not inputs of their own."""
    folder, out = folder.absolute(), out.absolute()
    files = [p for p in io.find_frf_files(folder) if not p.name.endswith("_result.h5")]
    files += [p for p in folder.rglob("*") if p.is_file() and not p.name.startswith(".")
              and p.suffix.lower() in RECORDING_ONLY_SUFFIXES | {".csv"} and is_recording(p)]
    sheets = [p for p in folder.rglob("*.csv") if p.is_file() and is_channel_sheet(p)]
    named: set[Path] = set()
    for sheet in sheets:  # a sheet is one test; the files it names are its points
        try:
            named |= {f.absolute() for f in read_channel_sheet(sheet).files()}
        except DataError:
            pass  # the sheet's own error is reported when it is processed
    files = [p for p in files if p.absolute() not in named] + sheets
    files.sort()
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
