"""Report stage: figures, tables beside the paper's values, Markdown and HTML.

Everything here is computed from a :class:`ReportInput` (plain arrays, tables
and the stages' result objects); nothing is read from disk. Figures are drawn
on :class:`matplotlib.figure.Figure` objects directly (no pyplot, so no global
backend state) and returned as PNG bytes; :mod:`ema_pipeline.io` writes them.
The HTML report is self-contained: figures are embedded as base64 PNG and the
style sheet is inline, so it opens anywhere without external resources.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from io import BytesIO
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ema_pipeline import paper
from ema_pipeline.data import FRFSet
from ema_pipeline.plots import plot_fit_quality, plot_stabilization

#: Titles of the six tables, as in the paper.
TABLE_TITLES = {
    "table1_modal_parameters": "Table 1 - Measured natural frequencies and damping ratios",
    "table2_modal_added_mass": "Table 2 - Modal added mass (ratio m_ar/m_r, eq. 10)",
    "table3_fe_initial": "Table 3 - Natural frequencies of the initial FE model",
    "table4_updated_parameters": "Table 4 - Updated design parameters",
    "table5_fe_updated": "Table 5 - Natural frequencies of the updated FE model",
    "table6_local_added_mass": "Table 6 - Local added mass on the immersed element(s)",
}

#: Table 4 parameter names (as the FE stage writes them) -> keys of paper.TABLE4_*.
_TABLE4_BY_NAME = {
    "thickness": "thickness_m",
    "width": "width_m",
    "length": "length_m",
    "youngs_modulus": "youngs_modulus_pa",
    "density": "density_kg_m3",
}

_COLORS = ("#1f4e79", "#c0504d", "#4f8a3c", "#7f6084", "#d08b26", "#3a9ca6")


@dataclass
class ReportInput:
    """What the report shows.

    ``tables`` are the six result tables in DESIGN.md form (any may be missing);
    ``frfs`` and ``identification`` are keyed by configuration name;
    ``fe_node_x``/``fe_shapes`` (n_points, n_modes) the updated FE mode shapes
    along the beam and ``sensor_x`` the accelerometer positions, both as x/L;
    ``compare_with_paper`` adds the paper's values and deviations to the tables.
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


# --------------------------------------------------------------------------
# Tables beside the paper
# --------------------------------------------------------------------------


def _paper_table1() -> pd.DataFrame:
    rows = [
        (cfg, k + 1, fd, 100 * z)
        for cfg in paper.CONFIGURATIONS
        for k, (fd, z) in enumerate(
            zip(paper.TABLE1_FD_HZ[cfg], paper.TABLE1_ZETA[cfg], strict=True)
        )
    ]
    return pd.DataFrame(rows, columns=["configuration", "mode", "paper_fd_hz", "paper_zeta_pct"])


def _paper_table2() -> pd.DataFrame:
    rows = [
        (cfg, k + 1, r) for cfg, ratios in paper.TABLE2_RATIO.items() for k, r in enumerate(ratios)
    ]
    return pd.DataFrame(rows, columns=["configuration", "mode", "paper_added_mass_ratio"])


def _paper_fn(values: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame({"mode": np.arange(1, values.size + 1), "paper_fn_hz": values})


def compare_with_paper(name: str, table: pd.DataFrame) -> pd.DataFrame:
    """The table with the paper's values and the deviations added as columns."""
    t = table.copy()
    if name == "table1_modal_parameters":
        t = t.merge(_paper_table1(), on=["configuration", "mode"], how="left")
        t["dev_fd_hz"] = t["fd_hz"] - t["paper_fd_hz"]
        t["dev_zeta_rel_pct"] = 100 * (t["zeta_pct"] / t["paper_zeta_pct"] - 1)
    elif name == "table2_modal_added_mass":
        t = t.merge(_paper_table2(), on=["configuration", "mode"], how="left")
        t["dev_ratio"] = t["added_mass_ratio"] - t["paper_added_mass_ratio"]
    elif name in ("table3_fe_initial", "table5_fe_updated"):
        ref = paper.TABLE3_FN_HZ if name == "table3_fe_initial" else paper.TABLE5_FN_HZ
        t = t.merge(_paper_fn(ref), on="mode", how="left")
        t["dev_pct"] = 100 * (t["fn_hz"] / t["paper_fn_hz"] - 1)
    elif name == "table4_updated_parameters":
        t["paper_updated"] = t["parameter"].map(_TABLE4_BY_NAME).map(paper.TABLE4_UPDATED)
        if "identifiable" in t:  # the only combination the frequencies determine
            p = paper.TABLE4_UPDATED
            combination = (
                p["thickness_m"] * np.sqrt(p["youngs_modulus_pa"] / p["density_kg_m3"])
                / p["length_m"] ** 2
            )
            t.loc[t["identifiable"].astype(bool), "paper_updated"] = combination
        t["dev_pct"] = 100 * (t["updated"] / t["paper_updated"] - 1)
    elif name == "table6_local_added_mass":
        t["paper_delta_k"] = t["configuration"].map(
            lambda c: paper.TABLE6.get(c, {}).get("delta_k")
        )
        t["paper_delta_m"] = t["configuration"].map(
            lambda c: paper.TABLE6.get(c, {}).get("delta_m")
        )
        t["dev_delta_m_pct"] = 100 * (
            t["delta_m"] / pd.to_numeric(t["paper_delta_m"], errors="coerce") - 1
        )
    return t


# --------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------


def _png(fig: Figure) -> bytes:
    buf = BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight", metadata={"Software": None})
    return buf.getvalue()


def _first_frf(frf: FRFSet) -> np.ndarray:
    return np.abs(frf.H[0, 0])


def figure_frf_overlay(
    frfs: Mapping[str, FRFSet], zoom_hz: tuple[float, float] | None = None, title: str = ""
) -> bytes:
    """|H| of the first response of every configuration, overlaid (paper Fig. 4/5)."""
    fig = Figure(figsize=(8.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    for k, (name, frf) in enumerate(frfs.items()):
        f = frf.freq_hz
        sel = (f >= (zoom_hz[0] if zoom_hz else 2.0)) & (f <= (zoom_hz[1] if zoom_hz else f[-1]))
        ax.semilogy(
            f[sel],
            _first_frf(frf)[sel],
            color=_COLORS[k % len(_COLORS)],
            lw=1.0,
            label=name.replace("_", " "),
        )
    first = next(iter(frfs.values()))
    ax.set_xlabel("frequency / Hz")
    ax.set_ylabel(f"|H| / ({first.units})  response {first.response_dofs[0].label()}")
    ax.set_title(title or "FRF overlay of the configurations")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return _png(fig)


def figure_stabilization(result: Any, frf: FRFSet, title: str) -> bytes:
    """Stabilization diagram over the FRF sum, selected modes marked."""
    fig = Figure(figsize=(8.0, 4.6), layout="constrained")
    ax = fig.add_subplot()
    lo, hi = result.settings.band_hz
    band = frf.band(lo, hi)
    plot_stabilization(
        ax,
        result.stabilization,
        freq_hz=band.freq_hz,
        frf_sum=np.abs(band.H).sum(axis=(0, 1)),
        selected_hz=result.modes.fn_hz,
    )
    ax.set_title(title)
    return _png(fig)


def figure_fit_quality(result: Any, frf: FRFSet, title: str) -> bytes:
    """Measured against synthesised FRFs (LSFD), one panel per response."""
    lo, hi = result.settings.band_hz
    H = frf.band(lo, hi).H
    fig = Figure(figsize=(8.0, 3.2 * H.shape[0]), layout="constrained")
    for o in range(H.shape[0]):
        ax = fig.add_subplot(H.shape[0], 1, o + 1)
        plot_fit_quality(ax, result, H, o, 0)
    fig.suptitle(title)
    return _png(fig)


def figure_mode_shapes(
    fe_x: np.ndarray,
    fe_shapes: np.ndarray,
    sensor_x: np.ndarray,
    measured: Mapping[str, np.ndarray],
) -> bytes:
    """Measured mode shapes at the sensors against the updated FE shapes.

    Positions are relative, x/L (0 = clamp, 1 = tip), so that the updated beam
    length and the measurement mesh line up. ``measured[config]`` is
    (n_sensors, n_modes) real-normalised; each measured shape is scaled onto the
    FE shape at the sensors by least squares, so only the shape (ratio between
    sensors and sign) is compared.
    """
    n_modes = fe_shapes.shape[1]
    fig = Figure(figsize=(8.0, 2.2 * n_modes), layout="constrained")
    for r in range(n_modes):
        ax = fig.add_subplot(n_modes, 1, r + 1)
        shape = fe_shapes[:, r] / np.max(np.abs(fe_shapes[:, r]))
        ax.plot(fe_x, shape, color="0.3", lw=1.2, label="FE (updated)")
        at_sensors = np.interp(sensor_x, fe_x, shape)
        for k, (name, phi) in enumerate(measured.items()):
            if phi.shape[1] <= r:
                continue
            m = np.real(phi[:, r])
            scale = float(m @ at_sensors / max(m @ m, 1e-300))
            ax.plot(
                sensor_x,
                scale * m,
                "osD^v<>"[k % 7],
                ms=9 - 2 * min(k, 3),
                color=_COLORS[k % len(_COLORS)],
                label=name.replace("_", " "),
                linestyle="none",
            )
        ax.axhline(0, color="0.8", lw=0.8)
        ax.set_ylabel(f"mode {r + 1}")
        if r == 0:
            ax.legend(fontsize=8, ncols=4)
    ax.set_xlabel("x / L (0 = clamp, 1 = tip)")
    fig.suptitle("Mode shapes: measured at the sensors vs updated FE")
    return _png(fig)


def figure_added_mass(table2: pd.DataFrame) -> bytes:
    """Modal added-mass ratio per mode with +-1 sigma error bars and the paper's values."""
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    configs = list(dict.fromkeys(table2["configuration"]))
    width = 0.8 / max(len(configs), 1)
    for k, cfg in enumerate(configs):
        t = table2[table2["configuration"] == cfg]
        x = t["mode"].to_numpy() + (k - (len(configs) - 1) / 2) * width
        err = t["added_mass_ratio_std"].to_numpy() if "added_mass_ratio_std" in t else None
        ax.bar(
            x,
            t["added_mass_ratio"],
            width=width * 0.9,
            yerr=err,
            capsize=3,
            color=_COLORS[(k + 1) % len(_COLORS)],
            label=cfg.replace("_", " "),
        )
        if cfg in paper.TABLE2_RATIO:
            ref = paper.TABLE2_RATIO[cfg]
            ax.plot(
                np.arange(1, ref.size + 1) + (k - (len(configs) - 1) / 2) * width,
                ref,
                "k_",
                ms=14,
                mew=2,
            )
    ax.plot([], [], "k_", ms=14, mew=2, label="paper")
    ax.set_xlabel("mode")
    ax.set_ylabel("modal added mass m_ar / m_r")
    ax.set_xticks(sorted(set(table2["mode"])))
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend()
    return _png(fig)


def make_figures(report: ReportInput) -> dict[str, bytes]:
    """All figures of the report as ``{name: PNG bytes}`` (names without suffix)."""
    figures: dict[str, bytes] = {}
    if report.frfs:
        figures["fig4_frf_overlay"] = figure_frf_overlay(report.frfs)
        ident = report.identification.get(report.genuine)
        if ident is not None and ident.modes.n_modes >= 2:
            f2 = float(ident.modes.fd_hz[1])
            figures["fig5_zoom_mode2"] = figure_frf_overlay(
                report.frfs, (0.9 * f2, 1.04 * f2), title=f"Zoom on mode 2 ({f2:.2f} Hz in air)"
            )
    for name, result in report.identification.items():
        frf = report.frfs.get(name)
        if frf is None:
            continue
        if result.stabilization.order.size:
            figures[f"stabilization_{name}"] = figure_stabilization(
                result, frf, f"Stabilization diagram - {name.replace('_', ' ')}"
            )
        figures[f"fit_{name}"] = figure_fit_quality(
            result, frf, f"LSFD fit - {name.replace('_', ' ')}"
        )
    if report.fe_shapes is not None and report.sensor_x is not None and report.identification:
        measured = {n: r.shapes_real for n, r in report.identification.items()}
        figures["mode_shapes"] = figure_mode_shapes(
            report.fe_node_x, report.fe_shapes, report.sensor_x, measured
        )
    if "table2_modal_added_mass" in report.tables and len(report.tables["table2_modal_added_mass"]):
        figures["modal_added_mass"] = figure_added_mass(report.tables["table2_modal_added_mass"])
    return figures


# --------------------------------------------------------------------------
# Markdown and HTML
# --------------------------------------------------------------------------


def _fmt(value: Any) -> str:
    if isinstance(value, float | np.floating):
        if not np.isfinite(value):
            return "" if np.isnan(value) else str(value)
        a = abs(value)
        if a != 0 and (a < 1e-3 or a >= 1e6):
            return f"{value:.5g}"
        return f"{value:.6g}" if a >= 1 else f"{value:.4f}"
    return str(value)


def markdown_table(table: pd.DataFrame) -> str:
    """A GitHub-flavoured Markdown table (no extra dependency)."""
    cols = [str(c) for c in table.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in table.itertuples(index=False):
        lines.append("| " + " | ".join(_fmt(v) for v in row) + " |")
    return "\n".join(lines)


def report_tables(report: ReportInput) -> dict[str, pd.DataFrame]:
    """The tables as printed: with the paper's values and deviations when comparing."""
    out = {}
    for name in TABLE_TITLES:
        if name in report.tables:
            t = report.tables[name]
            out[name] = compare_with_paper(name, t) if report.compare_with_paper else t
    return out


def render_markdown(report: ReportInput, figures: Sequence[str]) -> str:
    """The Markdown report; figures are referenced as ``figures/<name>.png``."""
    parts = [f"# {report.title}", ""]
    if report.problems:
        parts += ["## Problems", ""] + [f"- {p}" for p in report.problems] + [""]
    if report.notes:
        parts += ["## Notes", ""] + [f"- {n}" for n in report.notes] + [""]
    for name, table in report_tables(report).items():
        parts += [f"## {TABLE_TITLES[name]}", "", markdown_table(table), ""]
    if figures:
        parts += ["## Figures", ""]
        parts += [f"![{name}](figures/{name}.png)" for name in figures]
        parts.append("")
    return "\n".join(parts)


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:2em auto;
max-width:1100px;color:#222;line-height:1.45;padding:0 1em}
h1{color:#1f4e79;border-bottom:2px solid #1f4e79;padding-bottom:.2em}
h2{color:#1f4e79;margin-top:1.6em}
table{border-collapse:collapse;margin:.6em 0 1.2em;font-size:.9em}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#eef3f8}
td:first-child,th:first-child{text-align:left}
figure{margin:1em 0 2em}
figure img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.9em;color:#555}
.problems{background:#fff3f3;border-left:4px solid #c0504d;padding:.5em 1em}
.notes{background:#f4f8fb;border-left:4px solid #1f4e79;padding:.5em 1em}
"""


def _html_table(table: pd.DataFrame) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in table.columns)
    rows = "".join(
        "<tr>" + "".join(f"<td>{html.escape(_fmt(v))}</td>" for v in row) + "</tr>"
        for row in table.itertuples(index=False)
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"


def render_html(report: ReportInput, figures: Mapping[str, bytes]) -> str:
    """The self-contained HTML report (figures embedded as base64 PNG)."""
    esc = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(report.title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{esc(report.title)}</h1>",
    ]
    if report.problems:
        items = "".join(f"<li>{esc(p)}</li>" for p in report.problems)
        parts.append(f'<div class="problems"><h2>Problems</h2><ul>{items}</ul></div>')
    if report.notes:
        items = "".join(f"<li>{esc(n)}</li>" for n in report.notes)
        parts.append(f'<div class="notes"><h2>Notes</h2><ul>{items}</ul></div>')
    for name, table in report_tables(report).items():
        parts.append(f'<h2 id="{name}">{esc(TABLE_TITLES[name])}</h2>')
        parts.append(_html_table(table))
    if figures:
        parts.append("<h2>Figures</h2>")
    for name, png in figures.items():
        data = base64.b64encode(png).decode("ascii")
        parts.append(
            f'<figure id="fig-{name}"><img alt="{esc(name)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{esc(name.replace('_', ' '))}</figcaption></figure>"
        )
    parts.append("</body></html>")
    return "\n".join(parts)
