"""Report pages of ``identify --report`` and ``batch --report``: gather what the
page shows, render it with :mod:`ema_pipeline.report`, write it with :mod:`ema_pipeline.io`.

(The study report is assembled by :func:`ema_pipeline.pipeline.study.report_input`.)
"""

from __future__ import annotations

import datetime as dt
import os
from dataclasses import fields
from pathlib import Path

import numpy as np
import pandas as pd

from ema_pipeline import __version__, io
from ema_pipeline.data import DataError, Geometry
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.pipeline.single import FileOutcome

__all__ = [
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


def write_identify_report(
    outcome: FileOutcome, out_dir: str | Path, options: IdentificationOptions, *,
    figures: bool = True, geometry: Geometry | None = None,
) -> Path:
    """Write the report page of one identified file (``identify_file(..., keep=True)``),
    its modes animated on ``geometry`` or on the file's own (:func:`file_geometry`);
    DOFs without a node are added to ``outcome.warnings``."""
    from ema_pipeline.report import render_identify_html

    if outcome.frf is None or outcome.result is None:
        raise DataError(f"{outcome.path}: no identification result to report")
    geometry = file_geometry(outcome.path, geometry)
    outcome.warnings.extend(geometry_warnings(outcome, geometry))
    settings = options_text(options)
    settings["identification.resolved"] = (
        f"method {outcome.result.settings.method}, band {outcome.result.settings.band_hz} Hz, "
        f"max order {outcome.result.settings.max_order}"
    )
    page = render_identify_html(
        outcome.frf, outcome.result, settings=settings, version=__version__,
        generated=report_date(), figures=figures, geometry=geometry,
    )
    return io.write_text(page, identify_report_path(outcome.path, out_dir))


def _stored_shapes(out: Path, result_h5: object) -> np.ndarray | None:
    """The mode shapes (n_dofs, n_modes) of one file's ``<stem>_result.h5`` (for
    pairing modes by MAC in the batch report); None when it cannot be read."""
    if not isinstance(result_h5, str) or not result_h5:
        return None
    try:
        tree = io.read_results_h5(out / result_h5)
        shapes = tree["identification"]["modes"]["shapes"]
    except (DataError, OSError, KeyError, TypeError):
        return None
    return np.asarray(shapes) if isinstance(shapes, np.ndarray) else None


def write_batch_report(
    out: str | Path,
    folder: str | Path,
    options: IdentificationOptions,
    *,
    seconds: float = float("nan"),
    interrupted: bool = False,
    figures: bool = True,
) -> Path:
    """Write ``OUT/report.html`` from ``OUT/summary.csv`` and ``OUT/failures.csv``."""
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
    shapes = [_stored_shapes(out, rel) for rel in summary.get("result_h5", [""] * len(summary))]
    page = render_batch_html(
        BatchReportInput(
            title=f"Batch identification: {Path(folder).name or folder}",
            folder=str(folder),
            summary=summary,
            failures=failures,
            shapes=shapes,
            settings=options_text(options),
            seconds=seconds,
            interrupted=interrupted,
            version=__version__,
            generated=report_date(),
        ),
        figures=figures,
    )
    return io.write_text(page, out / "report.html")
