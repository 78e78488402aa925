"""Which figures the report pages show, and under which names: the set of inline
SVG figures of the study page (:func:`make_figures`) and of one identified file
(:func:`identification_figures`). The drawing itself is :mod:`.figures`.
"""

from __future__ import annotations

import re
from typing import Any

from ema_pipeline.data import FRFSet
from ema_pipeline.report import figures as figs
from ema_pipeline.report.inputs import ReportInput

__all__ = ["identification_figures", "make_figures", "safe_name"]


def safe_name(name: str) -> str:
    """A file-name-safe form of a configuration name."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name) or "unnamed"


def identification_figures(
    name: str, frf: FRFSet, result: Any, figures: dict[str, str], pretty: str
) -> None:
    """Add the figures of one identified file to ``figures``: FRF and coherence,
    stabilization diagram (when computed) and LSFD fit, keyed
    ``<kind>_<safe_name(name)>``; ``pretty`` is the name shown in the titles."""
    slug = safe_name(name)
    figures[f"frf_{slug}"] = figs.figure_frf_coherence(frf, f"FRF and coherence - {pretty}")
    if result is None:
        return
    if result.stabilization.order.size:
        figures[f"stabilization_{slug}"] = figs.figure_stabilization(
            result, frf, f"Stabilization diagram - {pretty}"
        )
    figures[f"fit_{slug}"] = figs.figure_fit(result, frf, f"LSFD fit - {pretty}")


def make_figures(report: ReportInput) -> dict[str, str]:
    """All figures of the study report as ``{name: inline SVG}``."""
    figures: dict[str, str] = {}
    if report.geometry is not None:
        g = report.geometry
        figures["geometry"] = figs.figure_geometry(
            g.length_m, g.n_elements, g.response_nodes, g.hammer_node,
            immersed_elements=g.immersed_elements, direction_label=g.direction_label,
        )
    if report.frfs:
        figures["fig4_frf_overlay"] = figs.figure_frf_overlay(report.frfs)
        ident = report.identification.get(report.genuine)
        if ident is not None and ident.modes.n_modes >= 2:
            f2 = float(ident.modes.fd_hz[1])
            figures["fig5_zoom_mode2"] = figs.figure_frf_overlay(
                report.frfs, (0.9 * f2, 1.04 * f2), title=f"Zoom on mode 2 ({f2:.2f} Hz in air)"
            )
    for name, frf in report.frfs.items():
        identification_figures(
            name, frf, report.identification.get(name), figures, name.replace("_", " ")
        )
    if (
        report.fe_shapes is not None
        and report.fe_node_x is not None
        and report.sensor_x is not None
        and report.identification
    ):
        measured = {n: r.shapes_real for n, r in report.identification.items()}
        figures["mode_shapes"] = figs.figure_mode_shapes(
            report.fe_node_x, report.fe_shapes, report.sensor_x, measured
        )
    t2 = report.tables.get("table2_modal_added_mass")
    if t2 is not None and len(t2):
        figures["modal_added_mass"] = figs.figure_added_mass(t2)
    return figures
