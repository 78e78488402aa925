"""Report stage: the modal test report of a study, of one FRF file, of a batch.

Everything here is computed from plain inputs (a :class:`ReportInput`, an
identification result, a batch summary table); nothing is read from disk and
nothing is written (:mod:`ema_pipeline.pipeline` does both through
:mod:`ema_pipeline.io`). Figures are SVG drawn by :mod:`.svg` (see its
docstring for why not matplotlib) and embedded inline, so ``report.html`` is
self-contained, small and prints sharply; every name or text that comes from
the data is HTML-escaped.

Sections of the study report, in order: summary, test setup, geometry, FRFs
with coherence, stabilization diagrams, mode tables (f, zeta, sigma, MPC, MPD,
stable orders), AutoMAC, mode shapes, measured vs synthesised FRFs with their
fit error, the paper's Tables 1-6 beside ours, provenance.

Modules: :mod:`.inputs` (what a page is drawn from), :mod:`.result_tables`
(tables computed from the results), :mod:`.tables` (the paper's values and
number formatting), :mod:`.page_figures` (which figures a page shows),
:mod:`.figures` and :mod:`.svg` (drawing), :mod:`.htmlparts` (HTML building
blocks) and :mod:`.renderers` (the pages).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ema_pipeline.lazy import lazy_exports

#: Where each public name lives: (submodule, its name there). The submodules
#: load on first use (PEP 562), so a command that needs one small helper
#: (``report.wording``) does not pay for the pages' imports (added mass, FE,
#: pandas): 0.1-0.2 s of start-up.
_HOMES = {
    "BatchReportInput": ("inputs", "BatchReportInput"),
    "BeamSetup": ("inputs", "BeamSetup"),
    "ReportInput": ("inputs", "ReportInput"),
    "make_figures": ("page_figures", "make_figures"),
    "render_batch_html": ("renderers", "render_batch_html"),
    "render_html": ("renderers", "render_html"),
    "render_identify_html": ("renderers", "render_identify_html"),
    "render_markdown": ("renderers", "render_markdown"),
    "mode_table": ("result_tables", "mode_table"),
    "mode_table_html": ("result_tables", "mode_table_html"),
    "report_tables": ("result_tables", "report_tables"),
    "stable_order_range": ("result_tables", "stable_order_range"),
    "standalone_svg": ("svg", "standalone"),
    "TABLE_TITLES": ("tables", "TABLE_TITLES"),
    "compare_with_paper": ("tables", "compare_with_paper"),
    "html_table": ("tables", "html_table"),
    "markdown_table": ("tables", "markdown_table"),
}

if TYPE_CHECKING:
    from ema_pipeline.report.inputs import BatchReportInput, BeamSetup, ReportInput
    from ema_pipeline.report.page_figures import make_figures
    from ema_pipeline.report.renderers import (
        render_batch_html,
        render_html,
        render_identify_html,
        render_markdown,
    )
    from ema_pipeline.report.result_tables import (
        mode_table,
        mode_table_html,
        report_tables,
        stable_order_range,
    )
    from ema_pipeline.report.svg import standalone as standalone_svg
    from ema_pipeline.report.tables import (
        TABLE_TITLES,
        compare_with_paper,
        html_table,
        markdown_table,
    )


__getattr__, __dir__ = lazy_exports(__name__, _HOMES)


__all__ = [
    "TABLE_TITLES",
    "BatchReportInput",
    "BeamSetup",
    "ReportInput",
    "compare_with_paper",
    "html_table",
    "make_figures",
    "markdown_table",
    "mode_table",
    "mode_table_html",
    "render_batch_html",
    "render_html",
    "render_identify_html",
    "render_markdown",
    "report_tables",
    "stable_order_range",
    "standalone_svg",
]
