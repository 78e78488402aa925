"""Report pages of ``identify --report`` and ``batch --report``: gather what the
page shows, render it with :mod:`ema_pipeline.report`, write it with :mod:`ema_pipeline.io`.

(The study report is assembled by :func:`ema_pipeline.pipeline.study.report_input`.)
"""

from __future__ import annotations

import datetime as dt
import os
from dataclasses import fields
from pathlib import Path
from urllib.parse import quote

import numpy as np

from ema_pipeline import __version__, io
from ema_pipeline.data import DataError, FRFSet, Geometry
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.result import IdentificationResult
from ema_pipeline.pipeline.single import FileOutcome

__all__ = [
    "batch_file_report_path",
    "file_geometry",
    "geometry_warnings",
    "identify_report_path",
    "options_text",
    "report_date",
    "write_batch_report",
    "write_identify_report",
]


def report_date() -> str:
    """The report's date (UTC); ``SOURCE_DATE_EPOCH`` fixes it for reproducible outputs."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    when = (
        dt.datetime.fromtimestamp(int(epoch), dt.UTC) if epoch and epoch.isdigit()
        else dt.datetime.now(dt.UTC)
    )
    return when.strftime("%Y-%m-%d %H:%M UTC")


def options_text(options: IdentificationOptions) -> dict[str, str]:
    """The identification options as ``{"identification.<name>": text}``."""
    return {f"identification.{f.name}": str(getattr(options, f.name)) for f in fields(options)}


def identify_report_path(path: str | Path, out_dir: str | Path) -> Path:
    """``<out_dir>/<stem>_report.html`` for an input file."""
    return Path(out_dir) / f"{Path(path).stem}_report.html"


def file_geometry(path: str | Path, geometry: Geometry | None = None) -> Geometry | None:
    """The geometry to draw a file's modes on: ``geometry`` (``--geometry``) when
    given, else the nodes and trace lines of the FRF file itself (UFF datasets
    15/2411 and 82), else None."""
    if geometry is not None:
        return geometry
    if io.frf_format(path) != "uff":
        return None
    return io.read_geometry_uff(path)


def geometry_warnings(outcome: FileOutcome, geometry: Geometry | None) -> list[str]:
    """One warning naming the measured DOFs of ``outcome`` that have no node in
    ``geometry`` (drawn nowhere; the report lists them too), or none."""
    if geometry is None or outcome.result is None:
        return []
    missing = geometry.map_dofs(outcome.result.modes.dofs).missing
    if not missing:
        return []
    return [f"{outcome.path}: DOF(s) {', '.join(d.label() for d in missing)} have no node in "
            f"the geometry ({geometry.source or 'given'}); their shape values are not drawn"]


def _identify_page(
    frf: FRFSet, result: IdentificationResult, settings: dict[str, str], *,
    figures: bool, geometry: Geometry | None, batch_page: str = "",
    picks: tuple[str, str] | None = None,
) -> str:
    """The identify report page (:func:`ema_pipeline.report.render_identify_html`)
    with the resolved settings of ``result`` added to ``settings``."""
    from ema_pipeline.report import render_identify_html

    settings = dict(settings)
    settings["identification.resolved"] = (
        f"method {result.settings.method}, band {result.settings.band_hz} Hz, "
        f"max order {result.settings.max_order}"
    )
    return render_identify_html(
        frf, result, settings=settings, version=__version__, generated=report_date(),
        figures=figures, geometry=geometry, batch_page=batch_page, picks=picks,
    )


def write_identify_report(
    outcome: FileOutcome, out_dir: str | Path, options: IdentificationOptions, *,
    figures: bool = True, geometry: Geometry | None = None,
) -> Path:
    """Write the report page of one identified file (``identify_file(..., keep=True)``),
    its modes animated on ``geometry`` or on the file's own (:func:`file_geometry`);
    DOFs without a node are added to ``outcome.warnings``."""
    if outcome.frf is None or outcome.result is None:
        raise DataError(f"{outcome.path}: no identification result to report")
    geometry = file_geometry(outcome.path, geometry)
    outcome.warnings.extend(geometry_warnings(outcome, geometry))
    page = _identify_page(outcome.frf, outcome.result, options_text(options),
                          figures=figures, geometry=geometry,
                          picks=(outcome.picks_path, outcome.picks_sha256)
                          if outcome.picks_path else None)
    return io.write_text(page, identify_report_path(outcome.path, out_dir))


def batch_file_report_path(result_h5: str | Path) -> Path:
    """The report page of one batch file: ``<stem>_report.html`` beside its
    ``<stem>_result.h5`` (pages of equal stems do not collide, as results do not).

    Examples
    --------
    >>> batch_file_report_path("out/day2/a.uff/a_result.h5").as_posix()
    'out/day2/a.uff/a_report.html'
    """
    result_h5 = Path(result_h5)
    return result_h5.with_name(f"{result_h5.name.removesuffix('_result.h5')}_report.html")


def _file_page(
    out: Path, folder: Path, file: str, result_h5: object, *,
    figures: bool, geometry: Geometry | None, warnings: list[str],
) -> tuple[str, np.ndarray | None]:
    """Write the report page of one batch file from its stored result (no
    identification); return its path relative to ``out`` ("" when the file has no
    result or it cannot be read: a warning says why) and its mode shapes."""
    if not isinstance(result_h5, str) or not result_h5:
        return "", None
    stored = out / result_h5
    path = batch_file_report_path(stored)
    try:
        frf, result = io.read_identification_result(stored)
    except (DataError, OSError) as exc:
        warnings.append(f"{file}: no report page: {exc}")
        path.unlink(missing_ok=True)  # not the page of an earlier result
        return "", None
    source = folder / file
    try:  # a .tdms, .wav or .csv recording holds no geometry (a UFF recording may)
        own = geometry is None and source.suffix.lower() in io.FRF_SUFFIXES
        geometry = file_geometry(source) if own else geometry
    except (DataError, OSError) as exc:
        warnings.append(f"{file}: its geometry is not drawn: {exc}")
        geometry = None
    warnings.extend(geometry_warnings(FileOutcome(path=source, result=result), geometry))
    try:
        page = _identify_page(
            frf, result, {"batch.result_file": result_h5}, figures=figures, geometry=geometry,
            batch_page=Path(os.path.relpath(out / "report.html", path.parent)).as_posix(),
        )
    except (ValueError, IndexError, TypeError, KeyError, AttributeError) as exc:
        warnings.append(f"{file}: no report page: {stored}: malformed result "
                        f"({type(exc).__name__}: {exc})")
        path.unlink(missing_ok=True)
        return "", None
    io.write_text(page, path)
    shapes = result.modes.shapes
    return (Path(os.path.relpath(path, out)).as_posix(),
            None if shapes is None else np.asarray(shapes))


def write_batch_report(
    out: str | Path,
    folder: str | Path,
    options: IdentificationOptions,
    *,
    seconds: float = float("nan"),
    interrupted: bool = False,
    figures: bool = True,
    geometry: Geometry | None = None,
    warnings: list[str] | None = None,
) -> Path:
    """Write ``OUT/report.html`` from ``OUT/summary.csv`` and ``OUT/failures.csv``,
    and for every file with a result its identify report page
    (:func:`batch_file_report_path`, linked from ``report.html``), rebuilt from its
    ``<stem>_result.h5`` (:func:`ema_pipeline.io.read_identification_result`; no
    identification), its modes animated on ``geometry`` (``--geometry``), else on
    the file's own (:func:`file_geometry`). Why a page is missing or drawn without
    some shape values is appended to ``warnings``."""
    import pandas as pd  # here: identify without --report does without it

    from ema_pipeline.report import BatchReportInput, render_batch_html

    out = Path(out)
    summary = io.read_csv(out / "summary.csv", required=("file", "status"))
    failures_csv = out / "failures.csv"
    failures = (
        io.read_csv(failures_csv, required=("file", "reason")) if failures_csv.is_file()
        else pd.DataFrame(columns=["file", "sha256", "reason"])
    )
    for table in (summary, failures):
        for col in ("file", "reason", "configuration", "sha256", "frequencies_hz"):
            if col in table:
                table[col] = table[col].astype(object).fillna("").astype(str)
    warnings = [] if warnings is None else warnings
    pages: list[str] = []
    shapes: list[np.ndarray | None] = []
    for file, rel in zip(summary["file"], summary.get("result_h5", [""] * len(summary)),
                         strict=True):
        page, shape = _file_page(out, Path(folder), str(file), rel, figures=figures,
                                 geometry=geometry, warnings=warnings)
        pages.append(quote(page))
        shapes.append(shape)
    page = render_batch_html(
        BatchReportInput(
            title=f"Batch identification: {Path(folder).name or folder}",
            folder=str(folder),
            summary=summary,
            failures=failures,
            shapes=shapes,
            pages=pages,
            settings=options_text(options),
            seconds=seconds,
            interrupted=interrupted,
            version=__version__,
            generated=report_date(),
        ),
        figures=figures,
    )
    return io.write_text(page, out / "report.html")
