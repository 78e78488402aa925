"""The report pages: a study (``run``), one FRF file (``identify --report``) and
a batch (``batch --report``), as self-contained HTML, and the study as Markdown.

Every string that comes from data (configuration and file names, problems,
settings) goes through :func:`html.escape`; figures are inline SVG.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from html import escape
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ema_pipeline.data import FRFSet
from ema_pipeline.modal import mac
from ema_pipeline.report import figures as figs
from ema_pipeline.report.tables import (
    TABLE_TITLES,
    compare_with_paper,
    html_matrix,
    html_table,
    markdown_table,
)

if TYPE_CHECKING:  # pragma: no cover
    from ema_pipeline.identification.result import IdentificationResult

__all__ = [
    "BatchReportInput",
    "Geometry",
    "ReportInput",
    "make_figures",
    "mode_table",
    "mode_table_html",
    "render_batch_html",
    "render_html",
    "render_identify_html",
    "render_markdown",
    "report_tables",
    "stable_order_range",
]


@dataclass(frozen=True)
class Geometry:
    """Where the sensors and the hammer are: a cantilever of ``length_m``
    divided into ``n_elements`` measurement elements (node 1 clamped)."""

    length_m: float
    n_elements: int
    response_nodes: tuple[int, ...]
    hammer_node: int
    immersed_elements: tuple[int, ...] = ()
    direction: int = 3

    @property
    def direction_label(self) -> str:
        axis = "SXYZ"[abs(self.direction)] if abs(self.direction) <= 3 else "?"
        return ("-" if self.direction < 0 else "+") + axis

    def node_x_m(self, node: int) -> float:
        return (node - 1) * self.length_m / self.n_elements


@dataclass
class ReportInput:
    """What the study report shows.

    ``tables`` are the six result tables in DESIGN.md form (any may be missing);
    ``frfs`` and ``identification`` are keyed by configuration name;
    ``fe_node_x``/``fe_shapes`` (n_points, n_modes) the updated FE mode shapes
    along the beam and ``sensor_x`` the accelerometer positions, both as x/L;
    ``compare_with_paper`` adds the paper's values and deviations to the tables.
    ``descriptions`` maps configuration names to what was tested; ``inputs``
    are ``(role, path, sha256)`` of every input file; ``settings`` the
    settings as text; ``version`` the package version; ``generated`` the date.
    """

    title: str
    tables: dict[str, pd.DataFrame]
    frfs: dict[str, FRFSet] = field(default_factory=dict)
    identification: dict[str, Any] = field(default_factory=dict)
    genuine: str = "genuine"
    fe_node_x: np.ndarray | None = None
    fe_shapes: np.ndarray | None = None
    sensor_x: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    compare_with_paper: bool = True
    descriptions: dict[str, str] = field(default_factory=dict)
    geometry: Geometry | None = None
    inputs: list[tuple[str, str, str]] = field(default_factory=list)
    settings: dict[str, str] = field(default_factory=dict)
    version: str = ""
    generated: str = ""


@dataclass
class BatchReportInput:
    """What the batch page shows: ``summary`` and ``failures`` are the rows of
    ``summary.csv`` and ``failures.csv`` (:mod:`ema_pipeline.pipeline.batch`)."""

    title: str
    folder: str
    summary: pd.DataFrame
    failures: pd.DataFrame
    settings: dict[str, str] = field(default_factory=dict)
    seconds: float = float("nan")
    interrupted: bool = False
    version: str = ""
    generated: str = ""


# --------------------------------------------------------------------------
# Tables computed from the results
# --------------------------------------------------------------------------


def report_tables(report: ReportInput) -> dict[str, pd.DataFrame]:
    """The tables as printed: with the paper's values and deviations when comparing."""
    out = {}
    for name in TABLE_TITLES:
        if name in report.tables:
            t = report.tables[name]
            out[name] = compare_with_paper(name, t) if report.compare_with_paper else t
    return out


def stable_order_range(result: IdentificationResult) -> list[str]:
    """Per selected mode (ascending frequency) the model orders at which its pole
    cluster is stable, ``"lo-hi (n of N)"``; empty strings without cluster data."""
    from ema_pipeline.identification.result import stable_orders

    if result.selected is None or result.stabilization.order.size == 0:
        return [""] * result.modes.n_modes
    first, last, count = stable_orders(result)
    n_orders = np.unique(result.stabilization.order).size
    return [
        f"{first[k]}-{last[k]} ({count[k]} of {n_orders})" if count[k] else ""
        for k in np.argsort(result.modes.fn_hz)
    ]


def mode_table(result: IdentificationResult) -> pd.DataFrame:
    """The modal table of one identification, ascending frequency: ``mode,
    fn_hz, fn_std_hz, fd_hz, zeta_pct, zeta_std_pct, sigma_1_s`` (decay rate
    -Re(lambda), 1/s), ``mpc``, ``mpd_deg``, ``doubtful`` and ``stable_orders``
    (first-last order, count)."""
    from ema_pipeline.identification.result import modes_table

    table = modes_table(result)
    order = np.argsort(result.modes.fn_hz)
    table["sigma_1_s"] = -np.real(np.asarray(result.pole))[order]
    table["stable_orders"] = stable_order_range(result)
    columns = ["mode", "fn_hz", "fn_std_hz", "fd_hz", "zeta_pct", "zeta_std_pct", "sigma_1_s",
               "mpc", "stable_orders", "mpd_deg", "doubtful"]
    return table[columns]


def mode_table_html(result: IdentificationResult) -> str:
    """The modal table as HTML (``value ± std`` cells, consistent decimals)."""
    return html_table(mode_table(result), titles=_COLUMN_TITLES)


_COLUMN_TITLES = {
    "fn_hz": "undamped natural frequency, Hz, ± one standard deviation",
    "fd_hz": "damped natural frequency, Hz (eq. 4)",
    "zeta_pct": "damping ratio in per cent, ± one standard deviation",
    "sigma_1_s": "decay rate sigma = zeta omega_n = -Re(lambda), 1/s",
    "mpc": "modal phase collinearity (1 = real mode)",
    "mpd_deg": "mean phase deviation, degrees (0 = real mode)",
    "doubtful": "marked for a second look: few stable orders, loose damping or complex shape",
    "stable_orders": "model orders at which the pole is stable (count of orders computed)",
    "frac": "FRF assurance criterion of the synthesis",
    "error_pct": "normalised fit error ||H - H_fit|| / ||H||, per cent",
}


def _fit_table(identification: Mapping[str, Any], frfs: Mapping[str, FRFSet]) -> pd.DataFrame:
    rows = []
    for name, r in identification.items():
        frf = frfs.get(name)
        for o in range(r.frac.shape[0]):
            for i in range(r.frac.shape[1]):
                rows.append(
                    {
                        "configuration": name,
                        "response": frf.response_dofs[o].label() if frf else str(o + 1),
                        "reference": frf.reference_dofs[i].label() if frf else str(i + 1),
                        "frac": float(r.frac[o, i]),
                        "error_pct": 100 * float(r.error[o, i]),
                    }
                )
    return pd.DataFrame(rows, columns=["configuration", "response", "reference", "frac",
                                       "error_pct"])


def _setup_table(frfs: Mapping[str, FRFSet], geometry: Geometry | None) -> pd.DataFrame:
    """Test setup, one column per configuration (rows: what an engineer checks)."""

    def fmt(v: Any, unit: str = "", spec: str = "g") -> str:
        return "" if v is None else f"{v:{spec}}{unit}"

    def positions(dofs: Sequence[Any]) -> str:
        if geometry is None:
            return ", ".join(d.label() for d in dofs)
        return ", ".join(
            f"{d.label()} (x = {geometry.node_x_m(d.node):.4g} m)"
            if 1 <= d.node <= geometry.n_elements + 1 else d.label()
            for d in dofs
        )

    rows: dict[str, list[str]] = {}
    for frf in frfs.values():
        a = frf.acquisition
        col = {
            "file": frf.source.path or "(in memory)",
            "sample rate": fmt(a.sample_rate_hz, " Hz"),
            "record length": (
                f"{a.duration_s:.4g} s ({a.n_samples} samples)" if a.duration_s else ""
            ),
            "frequency lines": f"{frf.freq_hz.size}, df = {frf.df_hz:.5g} Hz, "
            f"{frf.freq_hz[0]:.4g}-{frf.freq_hz[-1]:.5g} Hz",
            "averages": fmt(a.n_averages),
            "estimator": a.estimator,
            "force window": a.force_window,
            "response window": a.response_window,
            "exponential window tau": (
                f"{a.exp_window_tau_s:.5g} s (adds {a.window_decay_rate:.4g} 1/s to sigma)"
                if a.exp_window_tau_s else "none"
            ),
            "quantity": f"{frf.quantity} ({frf.units})",
            "hammer (reference)": positions(frf.reference_dofs),
            "sensors (responses)": positions(frf.response_dofs),
            "coherence": "in the file" if frf.coherence is not None else "not in the file",
        }
        for key, value in col.items():
            rows.setdefault(key, []).append(value)
    return pd.DataFrame(
        [[k, *v] for k, v in rows.items()], columns=["", *[str(n) for n in frfs]]
    )


# --------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------


def _slug(name: str) -> str:
    """A file-name-safe form of a configuration name."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name) or "unnamed"


def _identification_figures(
    name: str, frf: FRFSet, result: Any, figures: dict[str, str], pretty: str
) -> None:
    slug = _slug(name)
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
        _identification_figures(
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


# --------------------------------------------------------------------------
# Page
# --------------------------------------------------------------------------

_CSS = """
*{box-sizing:border-box}
body{font:15px/1.45 system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:0 auto;
max-width:1000px;color:#222;padding:0 14px 3em}
h1{color:#1f4e79;border-bottom:2px solid #1f4e79;padding-bottom:.2em;font-size:1.6em}
h2{color:#1f4e79;margin-top:1.8em;border-bottom:1px solid #c9d6e3}
h3{margin:1.2em 0 .3em;font-size:1.05em}
nav.toc{font-size:.9em;background:#f4f8fb;padding:.4em .8em;border-radius:4px}
nav.toc a{margin-right:.9em;white-space:nowrap}
.tablewrap{max-width:100%;overflow-x:auto;margin:.4em 0 1.1em}
table{border-collapse:collapse;font-size:.86em}
caption{text-align:left;font-weight:600;padding:.2em 0}
th,td{border:1px solid #ccc;padding:.2em .45em;text-align:left;vertical-align:top}
th{background:#eef3f8;font-weight:600}
td{overflow-wrap:anywhere}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
td.pm{white-space:normal;overflow-wrap:normal}
td.hash,td.path{font-family:ui-monospace,Menlo,Consolas,monospace;font-size:.92em;
word-break:break-all}
table.mac td{min-width:3.6em}
figure{margin:.8em 0 1.6em;break-inside:avoid;page-break-inside:avoid}
svg.fig{display:block;width:100%;max-width:720px;height:auto}
figcaption{font-size:.88em;color:#555}
.status{padding:.5em .9em;border-radius:4px;font-weight:600}
.ok{background:#eaf6ec;border-left:5px solid #2e8b3a}
.bad{background:#fff3f3;border-left:5px solid #c0504d}
.problems{background:#fff3f3;border-left:4px solid #c0504d;padding:.3em 1em}
.notes{background:#f4f8fb;border-left:4px solid #1f4e79;padding:.3em 1em}
.muted{color:#777}
@media print{
 @page{size:A4;margin:14mm}
 body{font-size:10pt;max-width:none;padding:0}
 nav.toc{display:none}
 h2{break-after:avoid;page-break-after:avoid}
 h3{break-after:avoid}
 .tablewrap{overflow:visible}
 table{font-size:8pt;break-inside:auto}
 tr,figure,svg.fig{break-inside:avoid;page-break-inside:avoid}
 svg.fig{max-width:100%}
 a{color:inherit;text-decoration:none}
}
"""


def _h(text: str) -> str:
    return escape(str(text))


class _Page:
    """Sections collected in order, with a table of contents."""

    def __init__(self, title: str) -> None:
        self.title = title
        self.sections: list[tuple[str, str, list[str]]] = []

    def section(self, ident: str, title: str) -> list[str]:
        parts: list[str] = []
        self.sections.append((ident, title, parts))
        return parts

    def html(self) -> str:
        toc = " ".join(f'<a href="#{_h(i)}">{_h(t)}</a>' for i, t, _ in self.sections)
        body = "".join(
            f'<section id="{_h(i)}"><h2>{_h(t)}</h2>{"".join(parts)}</section>'
            for i, t, parts in self.sections
        )
        return (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            '<meta name="viewport" content="width=device-width,initial-scale=1">'
            f"<title>{_h(self.title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{_h(self.title)}</h1><nav class=\"toc\">{toc}</nav>{body}</body></html>\n"
        )


def _figure(name: str, figures: Mapping[str, str], caption: str) -> str:
    svg = figures.get(name)
    if svg is None:
        return ""
    return f'<figure id="fig-{_h(name)}">{svg}<figcaption>{_h(caption)}</figcaption></figure>'


def _no_figures(figures: Mapping[str, str] | None) -> str:
    return '<p class="muted">Figures not drawn (--no-figures).</p>' if figures is None else ""


def _list(items: Sequence[str], cls: str) -> str:
    if not items:
        return ""
    return f'<div class="{cls}"><ul>' + "".join(f"<li>{_h(x)}</li>" for x in items) + "</ul></div>"


def _kv_table(rows: Mapping[str, str], caption: str = "", cls: str = "") -> str:
    attr = f' class="{cls}"' if cls else ""
    body = "".join(f"<tr><th>{_h(k)}</th><td{attr}>{_h(v)}</td></tr>" for k, v in rows.items())
    cap = f"<caption>{_h(caption)}</caption>" if caption else ""
    return f'<div class="tablewrap"><table>{cap}<tbody>{body}</tbody></table></div>'


def _provenance(
    inputs: Sequence[tuple[str, str, str]], settings: Mapping[str, str], version: str,
    generated: str,
) -> str:
    rows = "".join(
        f'<tr><td>{_h(role)}</td><td class="path">{_h(path)}</td>'
        f'<td class="hash">{_h(sha)}</td></tr>'
        for role, path, sha in inputs
    )
    import platform

    import numpy
    import scipy

    software = {
        "ema-pipeline": version,
        "Python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "pandas": pd.__version__,
        "report generated": generated,
    }
    return (
        '<h3>Input files</h3><div class="tablewrap"><table class="inputs"><thead><tr>'
        "<th>input</th><th>path</th><th>sha256</th></tr></thead>"
        f"<tbody>{rows}</tbody></table></div>"
        + "<h3>Software</h3>" + _kv_table(software)
        + ("<h3>Settings</h3>" + _kv_table(settings) if settings else "")
    )


def _mac_section(identification: Mapping[str, Any], genuine: str) -> str:
    parts = []
    for name, r in identification.items():
        labels = [f"{f:.2f} Hz" for f in r.modes.fn_hz]
        parts.append(html_matrix(r.mac, labels, labels, caption=f"AutoMAC - {name}"))
    ref = identification.get(genuine)
    if ref is not None and ref.modes.shapes is not None:
        for name, r in identification.items():
            if name == genuine or r.modes.shapes is None:
                continue
            if r.modes.shapes.shape[0] != ref.modes.shapes.shape[0]:
                continue
            m = mac(ref.modes.shapes, r.modes.shapes)
            parts.append(html_matrix(
                m, [f"{f:.2f} Hz" for f in ref.modes.fn_hz],
                [f"{f:.2f} Hz" for f in r.modes.fn_hz],
                caption=f"MAC {genuine} (rows) vs {name} (columns)",
            ))
    note = (
        '<p class="muted">With few sensors the AutoMAC cannot separate all modes: '
        "off-diagonal values near 1 say the sensors do not tell those shapes apart, "
        "not that the modes are the same.</p>"
    )
    return "".join(parts) + note


def _summary_study(report: ReportInput) -> str:
    n_prob = len(report.problems)
    status = (
        '<p class="status ok">Complete: every configuration identified, no problems.</p>'
        if not n_prob
        else f'<p class="status bad">{n_prob} problem(s): see the list below; what could be '
        "computed is shown.</p>"
    )
    what = []
    g = report.geometry
    if g is not None:
        what.append(
            f"Cantilever beam, L = {g.length_m:g} m, measured at nodes "
            f"{', '.join(str(n) for n in g.response_nodes)} (accelerometers, "
            f"{g.direction_label}) with the hammer at node {g.hammer_node}"
            + (f"; immersed element(s) {', '.join(map(str, g.immersed_elements))}"
               if g.immersed_elements else "")
            + "."
        )
    rows = []
    t2 = report.tables.get("table2_modal_added_mass")
    t6 = report.tables.get("table6_local_added_mass")
    for name in report.descriptions or report.identification:
        r = report.identification.get(name)
        desc = report.descriptions.get(name, "")
        if r is None:
            rows.append({"configuration": name, "description": desc,
                         "natural frequencies / Hz": "not identified"})
            continue
        row = {
            "configuration": name,
            "description": desc,
            "natural frequencies / Hz": ", ".join(f"{f:.2f}" for f in np.sort(r.modes.fn_hz)),
            "damping / %": ", ".join(f"{100 * z:.3f}" for z in r.modes.zeta[
                np.argsort(r.modes.fn_hz)]),
            "fit error / %": f"{100 * float(np.mean(r.error)):.2f}",
        }
        if t2 is not None and len(t2):
            sub = t2[t2["configuration"] == name]
            row["added mass m_ar/m_r"] = ", ".join(f"{v:.4f}" for v in sub["added_mass_ratio"])
        if t6 is not None and len(t6):
            sub = t6[(t6["configuration"] == name) & (t6["method"] == "block")]
            row["local delta_m (block, eq. 20)"] = ", ".join(f"{v:.4f}" for v in sub["delta_m"])
        rows.append(row)
    table = html_table(pd.DataFrame(rows).fillna(""), split=False) if rows else ""
    return (
        status + "".join(f"<p>{_h(w)}</p>" for w in what) + table
        + _list(report.problems, "problems") + _list(report.notes, "notes")
    )


def render_html(report: ReportInput, figures: Mapping[str, str] | None) -> str:
    """The self-contained HTML study report; ``figures`` from :func:`make_figures`
    (``None``: drawn without figures)."""
    fg = figures or {}
    page = _Page(report.title)
    page.section("summary", "Summary").append(_summary_study(report))
    if report.frfs:
        page.section("setup", "Test setup").append(
            html_table(_setup_table(report.frfs, report.geometry), split=False)
        )
    if report.geometry is not None:
        g = report.geometry
        sec = page.section("geometry", "Geometry: sensors and hammer")
        sec.append(_figure("geometry", fg, "Measurement mesh, accelerometers (squares), "
                           "hammer (arrow), immersed element(s) (blue)"))
        nodes = pd.DataFrame(
            [("accelerometer", n, g.node_x_m(n)) for n in g.response_nodes]
            + [("hammer", g.hammer_node, g.node_x_m(g.hammer_node))],
            columns=["role", "node", "x_m"],
        )
        sec.append(html_table(nodes))
    if report.frfs:
        sec = page.section("frf", "FRFs and coherence")
        sec.append(_no_figures(figures))
        for name in report.frfs:
            sec.append(_figure(f"frf_{_slug(name)}", fg, f"|H| and coherence: {name}"))
        sec.append(_figure("fig4_frf_overlay", fg, "FRF overlay of the configurations "
                           "(paper Fig. 4)"))
        sec.append(_figure("fig5_zoom_mode2", fg, "Zoom on mode 2 (paper Fig. 5)"))
    if report.identification:
        sec = page.section("stabilization", "Stabilization diagrams")
        sec.append(_no_figures(figures))
        for name in report.identification:
            sec.append(_figure(f"stabilization_{_slug(name)}", fg,
                               f"Stabilization diagram: {name}"))
        sec = page.section("modes", "Modes (MPC, MPD, stable orders)")
        for name, r in report.identification.items():
            sec.append(f"<h3>{_h(name)}</h3>" + mode_table_html(r))
        if not any(getattr(r, "mpd", None) is not None for r in report.identification.values()):
            sec.append('<p class="muted">MPD: not provided by this identification result.</p>')
        page.section("mac", "AutoMAC").append(
            _mac_section(report.identification, report.genuine)
        )
        sec = page.section("shapes", "Mode shapes")
        sec.append(_no_figures(figures))
        if "mode_shapes" in fg:
            sec.append(_figure("mode_shapes", fg, "Measured mode shapes at the sensors vs "
                               "the updated FE model"))
        sec = page.section("fit", "Measured vs synthesised FRFs")
        sec.append(html_table(_fit_table(report.identification, report.frfs),
                              titles=_COLUMN_TITLES))
        sec.append(_no_figures(figures))
        for name in report.identification:
            sec.append(_figure(f"fit_{_slug(name)}", fg, f"LSFD fit: {name}"))
    tables = report_tables(report)
    if tables:
        title = "Tables 1-6 beside the paper" if report.compare_with_paper else "Tables 1-6"
        sec = page.section("tables", title)
        for name, table in tables.items():
            sec.append(f'<h3 id="{name}">{_h(TABLE_TITLES[name])}</h3>')
            sec.append(html_table(table))
            if name == "table2_modal_added_mass":
                sec.append(_figure("modal_added_mass", fg, "Modal added mass per mode"))
    page.section("provenance", "Provenance").append(
        _provenance(report.inputs, report.settings, report.version, report.generated)
    )
    return page.html()


def render_markdown(report: ReportInput, figures: Sequence[str]) -> str:
    """The Markdown report; figures are referenced as ``figures/<name>.svg``."""
    parts = [f"# {report.title}", ""]
    if report.problems:
        parts += ["## Problems", ""] + [f"- {p}" for p in report.problems] + [""]
    if report.notes:
        parts += ["## Notes", ""] + [f"- {n}" for n in report.notes] + [""]
    if report.frfs:
        parts += ["## Test setup", "", markdown_table(_setup_table(report.frfs,
                                                                   report.geometry)), ""]
    for name, r in report.identification.items():
        parts += [f"## Modes: {name}", "", markdown_table(mode_table(r)), ""]
    if report.identification:
        parts += ["## Fit quality", "",
                  markdown_table(_fit_table(report.identification, report.frfs)), ""]
    for name, table in report_tables(report).items():
        parts += [f"## {TABLE_TITLES[name]}", "", markdown_table(table), ""]
    if figures:
        parts += ["## Figures", ""]
        parts += [f"![{name}](figures/{name}.svg)" for name in figures]
        parts.append("")
    if report.inputs:
        parts += ["## Provenance", "", "| input | path | sha256 |", "|---|---|---|"]
        parts += [f"| {r} | {p} | {s} |" for r, p, s in report.inputs]
        parts += ["", f"ema-pipeline {report.version}, generated {report.generated}", ""]
    return "\n".join(parts)


# --------------------------------------------------------------------------
# One file: identify --report
# --------------------------------------------------------------------------


def render_identify_html(
    frf: FRFSet,
    result: IdentificationResult,
    *,
    settings: Mapping[str, str] | None = None,
    version: str = "",
    generated: str = "",
    figures: bool = True,
) -> str:
    """The report of one identified FRF file: the study report's sections that
    apply to a single file (no geometry, FE or paper tables)."""
    name = frf.configuration or frf.source.path or "FRF set"
    fg: dict[str, str] = {}
    if figures:
        _identification_figures("one", frf, result, fg, name)
        fg["shapes_one"] = figs.figure_shapes_by_dof(
            result, [d.label() for d in frf.response_dofs]
        )
    page = _Page(f"Modal identification: {frf.source.path or name}")
    m = result.modes
    summary = pd.DataFrame(
        {
            "file": [frf.source.path],
            "configuration": [frf.configuration],
            "modes": [m.n_modes],
            "natural frequencies / Hz": [", ".join(f"{f:.3f}" for f in np.sort(m.fn_hz))],
            "mean fit error / %": [f"{100 * float(np.mean(result.error)):.2f}"],
        }
    )
    page.section("summary", "Summary").append(html_table(summary))
    page.section("setup", "Test setup").append(
        html_table(_setup_table({name: frf}, None), split=False)
    )
    no = _no_figures(None if not figures else fg)
    page.section("frf", "FRFs and coherence").append(
        no + _figure("frf_one", fg, f"|H| and coherence: {name}")
    )
    page.section("stabilization", "Stabilization diagram").append(
        no + _figure("stabilization_one", fg, "Stabilization diagram")
    )
    page.section("modes", "Modes (MPC, MPD, stable orders)").append(mode_table_html(result))
    page.section("mac", "AutoMAC").append(_mac_section({name: result}, name))
    page.section("shapes", "Mode shapes").append(
        no + _figure("shapes_one", fg, "Real-normalised mode shapes at the measured DOFs")
    )
    sec = page.section("fit", "Measured vs synthesised FRFs")
    sec.append(html_table(_fit_table({name: result}, {name: frf}), titles=_COLUMN_TITLES))
    sec.append(no + _figure("fit_one", fg, "LSFD fit"))
    inputs = [("FRF file", frf.source.path, frf.source.sha256)]
    page.section("provenance", "Provenance").append(
        _provenance(inputs, dict(settings or {}), version, generated)
    )
    return page.html()


# --------------------------------------------------------------------------
# A batch: batch --report
# --------------------------------------------------------------------------


def _frequencies(cell: Any) -> list[float]:
    if cell is None or (isinstance(cell, float) and np.isnan(cell)) or str(cell) == "":
        return []
    return [float(v) for v in str(cell).split(";") if v]


def render_batch_html(batch: BatchReportInput, *, figures: bool = True) -> str:
    """One page over a batch: status per file (with the failure reason), modes
    per file, each mode's frequency across the files."""
    s = batch.summary.copy()
    reasons = dict(zip(batch.failures.get("file", []), batch.failures.get("reason", []),
                       strict=False))
    page = _Page(batch.title)
    counts = s["status"].value_counts() if len(s) else pd.Series(dtype=int)
    n_failed = int(counts.get("failed", 0))
    state = "interrupted; " if batch.interrupted else ""
    cls = "bad" if n_failed or batch.interrupted else "ok"
    head = (
        f'<p class="status {cls}">{state}{len(s)} files: {int(counts.get("ok", 0))} ok, '
        f'{int(counts.get("skipped", 0))} skipped, {n_failed} failed'
        + (f" in {batch.seconds:.1f} s" if np.isfinite(batch.seconds) else "") + "</p>"
        + f"<p>Input folder: <code>{_h(batch.folder)}</code></p>"
    )
    page.section("summary", "Summary").append(head)
    if n_failed:
        failed = s[s["status"] == "failed"]
        ft = pd.DataFrame({"file": failed["file"],
                           "reason": [reasons.get(f, "") for f in failed["file"]]})
        page.section("failures", "Failed files").append(html_table(ft))
    freqs = [_frequencies(c) for c in s.get("frequencies_hz", [])]
    n_modes = max((len(f) for f in freqs), default=0)
    table = pd.DataFrame({"#": np.arange(1, len(s) + 1), "file": s["file"],
                          "status": s["status"], "configuration": s.get("configuration", "")})
    for k in range(n_modes):
        table[f"f{k + 1}_hz"] = [f[k] if len(f) > k else np.nan for f in freqs]
    if "fit_error" in s:
        table["fit_error_pct"] = 100 * pd.to_numeric(s["fit_error"], errors="coerce")
    table = table.fillna({"configuration": ""})
    page.section("files", "Status and modes per file").append(
        html_table(table) + ('<p class="muted">Failed files and why: see above.</p>'
                             if n_failed else "")
    )
    sec = page.section("trend", "Each mode's frequency across the files")
    if figures:
        ok = [(str(f), fr) for f, fr, st in zip(s["file"], freqs, s["status"], strict=True)]
        sec.append(
            '<figure id="fig-batch_frequencies">'
            + figs.figure_batch_frequencies([f for f, _ in ok], [fr for _, fr in ok])
            + "<figcaption>Deviation of each file's natural frequency from the mode's median "
            "(red: outliers); file numbers as in the table above.</figcaption></figure>"
        )
    else:
        sec.append(_no_figures(None))
    inputs = [("FRF file", str(f), str(h) if isinstance(h, str) else "")
              for f, h in zip(s["file"], s.get("sha256", [""] * len(s)), strict=False)]
    page.section("provenance", "Provenance").append(
        _provenance(inputs, batch.settings, batch.version, batch.generated)
    )
    return page.html()
