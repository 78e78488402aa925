"""Where ``ema-pipeline frf`` writes its outputs, and how: the hit table and the hit
page beside the FRF file, an output refused before any work when it would
overwrite an input, and the outputs replaced together.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from ema_pipeline import io
from ema_pipeline.data import DataError, FRFSet, Table

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["check_output", "frf_output_paths", "hits_csv_path", "hits_report_path",
           "write_frf_outputs"]


def hits_csv_path(out: str | os.PathLike[str]) -> Path:
    """``<stem>_hits.csv`` beside the FRF file ``out``.

    Examples
    --------
    >>> hits_csv_path("out/test.h5").as_posix()
    'out/test_hits.csv'
    """
    out = Path(out)
    return out.with_name(f"{out.stem}_hits.csv")


def write_frf_outputs(frf: FRFSet, hits: pd.DataFrame | Table, page: str | None,
                      out: str | os.PathLike[str], fmt: str) -> None:
    """The outputs of one ``frf`` command, replaced together or not at all
    (:func:`ema_pipeline.io.replace_together`): the hit table
    (:func:`hits_csv_path`), the FRF file ``out`` in format ``fmt`` and, when
    given, the hit page ``page`` (:func:`hits_report_path`)."""
    with io.replace_together():
        io.write_csv(hits, hits_csv_path(out))
        io.write_frf(frf, out, fmt)
        if page is not None:
            io.write_text(page, hits_report_path(out))


def hits_report_path(out: str | os.PathLike[str]) -> Path:
    """``<stem>_hits.html`` beside the FRF file ``out`` (the hit page of ``--report``).

    Examples
    --------
    >>> hits_report_path("out/test.h5").as_posix()
    'out/test_hits.html'
    """
    out = Path(out)
    return out.with_name(f"{out.stem}_hits.html")


def frf_output_paths(out: str | os.PathLike[str], report: bool = False) -> dict[str, Path]:
    """What ``frf --out OUT`` writes, as {what it is: path}: the FRF file, the hit
    table and (``report``) the hit page.

    Examples
    --------
    >>> sorted(p.name for p in frf_output_paths("o/t.h5", report=True).values())
    ['t.h5', 't_hits.csv', 't_hits.html']
    """
    out = Path(out)
    paths = {"--out": out, f"the hit table of --out {out}": hits_csv_path(out)}
    if report:
        paths[f"the hit page of --out {out}"] = hits_report_path(out)
    return paths


def check_output(
    out: str | os.PathLike[str],
    inputs: list[str | os.PathLike[str]] | list[Path] | tuple[Path, ...] = (),
    *,
    report: bool = False,
) -> str:
    """The FRF format of ``out`` (by suffix), refused before any work when the
    suffix is unknown, when ``out``, its hit table or (``report``) its hit page is
    a folder, or is one of the ``inputs`` (the same file by resolved path or hard
    link: :func:`ema_pipeline.io.same_file`), so that no input is ever overwritten.

    Examples
    --------
    >>> check_output("a/rec.uff", ["a/rec.uff"])
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: a/rec.uff: --out would overwrite the input a/rec.uff; ...
    >>> check_output("a/rec.h5", ["a/rec_hits.csv"])
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: a/rec_hits.csv: the hit table of --out a/rec.h5 would
    overwrite the input a/rec_hits.csv; ...
    """
    out = Path(out)
    fmt = io.frf_format_for_writing(out)
    targets = frf_output_paths(out, report)
    for what, path in targets.items():
        if path.is_dir():
            raise DataError(f"{path}: is a folder; {what} must be a file (choose another "
                            "--out)")
    if out.parent.exists() and not out.parent.is_dir():
        raise DataError(f"{out.parent}: not a folder")
    io.check_not_inputs(targets, [Path(p) for p in inputs])
    return fmt
