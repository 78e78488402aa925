"""The report's figures as SVG text (drawn with :mod:`ema_pipeline.report.svg`).

Each function takes plain arrays or the stages' result objects and returns an
SVG element (``standalone=True``: a complete ``.svg`` file). Lines are reduced
to per-pixel envelopes, so an 8193-line FRF costs the same as one of 700 lines.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ema_pipeline import paper
from ema_pipeline.data import FRFSet
from ema_pipeline.report.result_tables import dof_labels
from ema_pipeline.report.stab_marks import STABILITY, stability_symbols
from ema_pipeline.report.svg import SCALE, Canvas, legend_size

if TYPE_CHECKING:  # pragma: no cover
    from ema_pipeline.identification.result import IdentificationResult

__all__ = [
    "COLORS",
    "figure_added_mass",
    "figure_batch_frequencies",
    "figure_fit",
    "figure_frf_coherence",
    "figure_frf_overlay",
    "figure_geometry",
    "figure_mode_shapes",
    "figure_shapes_by_dof",
    "figure_stabilization",
    "sum_abs_frf",
]

COLORS = ("#1f4e79", "#c0504d", "#4f8a3c", "#7f6084", "#d08b26", "#3a9ca6", "#8c564b")
_W = 720  # figure width, CSS px
_LEFT, _RIGHT = 70, 20
#: At most this many curves are labelled inside an FRF panel; more, below the figure.
LEGEND_INSIDE = 6


def sum_abs_frf(H: np.ndarray) -> np.ndarray:
    """The sum of |H| over every output and input at each line: the curve drawn
    under the stabilization diagrams (static and interactive)."""
    return np.abs(H).sum(axis=(0, 1))


def _log_limits(values: np.ndarray, floor_decades: float = 6.0) -> tuple[float, float]:
    v = np.abs(np.asarray(values, dtype=float))
    v = v[np.isfinite(v) & (v > 0)]
    if v.size == 0:
        return 1e-3, 1.0
    hi = float(v.max())
    lo = max(float(v.min()), hi * 10 ** (-floor_decades))
    return 10 ** np.floor(np.log10(lo)), 10 ** np.ceil(np.log10(hi))


def _label(name: str) -> str:
    return name.replace("_", " ")


def figure_frf_coherence(frf: FRFSet, title: str = "", *, standalone: bool = False,
                         marks_hz: Sequence[float] = ()) -> str:
    """|H| of every response (log scale) with the coherence below it.

    Without coherence in the data the lower panel says so. ``marks_hz``: dashed
    vertical lines on both panels (e.g. the usable band of the force spectrum).
    The curves are labelled ``response / reference`` with the signs as tested
    (:func:`~ema_pipeline.report.result_tables.dof_labels`); up to
    :data:`LEGEND_INSIDE` of them in the emptiest corner of the panel, more
    below the figure, where they cover no curve.
    """
    f = frf.freq_hz
    sel = f >= max(f[0], f[min(5, f.size - 1)])  # the first lines hold no information
    H = np.abs(frf.H[..., sel])
    responses, references = dof_labels(frf)
    labels = [f"{r} / {q}" for r in responses for q in references]
    n_panel_h, c_h = 250, 110
    height = 30 + n_panel_h + 24 + c_h + 48
    box = (_LEFT, 30, _W - _LEFT - _RIGHT, n_panel_h)
    columns = 1
    if len(labels) > LEGEND_INSIDE:  # below the coherence panel: as many columns as fit
        col_w = legend_size(labels)[0] - 6
        columns = max(1, min(len(labels), int((box[2] - 6) // col_w)))
        height += round(legend_size(labels, columns)[1])
    c = Canvas(_W, height, title or f"FRF and coherence - {frf.configuration}")
    xlim = (float(f[sel][0]), float(f[-1]))
    ax = c.axes(box, xlim, _log_limits(H, 5), ylog=True)
    for k, label in enumerate(labels):
        o, i = divmod(k, frf.n_in)
        ax.line(f[sel], H[o, i], COLORS[k % len(COLORS)], width=0.8, label=label)
    marks = [x for x in marks_hz if xlim[0] < x < xlim[1]]
    for x in marks:
        ax.vline(x, "#888", dash="6 4")
    ax.frame(ylabel=f"|H| / ({frf.units})", title=title, show_x=False)
    cax = c.axes((_LEFT, 30 + n_panel_h + 24, _W - _LEFT - _RIGHT, c_h), xlim, (0.0, 1.05))
    if len(labels) > LEGEND_INSIDE:
        cax.legend_items = ax.legend_items
        cax.legend("below", columns=columns)
    else:
        ax.legend("best")
    for x in marks:
        cax.vline(x, "#888", dash="6 4")
    if frf.coherence is None:
        cax.text(
            sum(xlim) / 2, 0.5, "no coherence in this file", color="#888", size=12 * SCALE
        )
    else:
        k = 0
        for o in range(frf.n_out):
            for i in range(frf.n_in):
                cax.line(f[sel], frf.coherence[o, i, sel], COLORS[k % len(COLORS)], width=0.8)
                k += 1
    cax.frame(xlabel="frequency / Hz", ylabel="coherence")
    return c.to_svg(standalone)


def figure_frf_overlay(
    frfs: Mapping[str, FRFSet],
    zoom_hz: tuple[float, float] | None = None,
    title: str = "",
    *,
    standalone: bool = False,
) -> str:
    """|H| of the first response of every configuration, overlaid (paper Fig. 4/5)."""
    first = next(iter(frfs.values()))
    lo = zoom_hz[0] if zoom_hz else 2.0
    hi = zoom_hz[1] if zoom_hz else float(first.freq_hz[-1])
    curves = {}
    for name, frf in frfs.items():
        sel = (frf.freq_hz >= lo) & (frf.freq_hz <= hi)
        curves[name] = (frf.freq_hz[sel], np.abs(frf.H[0, 0, sel]))
    allv = np.concatenate([v for _, v in curves.values()]) if curves else np.ones(1)
    height = 300 if zoom_hz else 330
    title = title or "FRF overlay of the configurations"
    c = Canvas(_W, height, title)
    ax = c.axes((_LEFT, 30, _W - _LEFT - _RIGHT, height - 80), (lo, hi), _log_limits(allv, 5),
                ylog=True)
    for k, (name, (f, v)) in enumerate(curves.items()):
        ax.line(f, v, COLORS[k % len(COLORS)], width=1.0, label=_label(name))
    ax.frame(
        xlabel="frequency / Hz",
        ylabel=f"|H| / ({first.units})  {dof_labels(first)[0][0]}",
        title=title,
    )
    ax.legend("best")
    return c.to_svg(standalone)


def figure_stabilization(
    result: IdentificationResult, frf: FRFSet, title: str = "", *, standalone: bool = False
) -> str:
    """Stabilization diagram over the sum of |H|, selected modes marked.

    The poles are marked by the stability classes of the interactive diagram
    (:data:`.stab_marks.STABILITY`, in its colours): a grey cross new or
    unstable, a dot stable in frequency only, in frequency and vector, or in
    all three, a square in frequency and damping.
    """
    stab = result.stabilization
    lo, hi = result.settings.band_hz
    band = frf.band(lo, hi)
    symbols = stability_symbols(stab.flags)
    labels = [f"{k}: {text}" for k, (text, _) in STABILITY.items() if np.any(symbols == k)]
    # the legend below the figure in as many columns as fit its width
    columns = max([1] + [n for n in range(1, 5) if legend_size(labels, n)[0] <= _W - _LEFT])
    height = 369 + int(legend_size(labels, columns)[1])
    c = Canvas(_W, height, title or "Stabilization diagram")
    orders = stab.order
    top = float(orders.max()) + 2 if orders.size else 10.0
    box = (_LEFT, 30, _W - _LEFT - 70, 280)
    ax = c.axes(box, (lo, hi), (0.0, top))
    total = sum_abs_frf(band.H)
    tw = c.axes(box, (lo, hi), _log_limits(total, 5), ylog=True)
    tw.line(band.freq_hz, total, "#222", width=0.7, opacity=0.55)
    # the interactive diagram's classes and colours (stab_marks.STABILITY), as marker shapes
    shapes = {"o": ("x", 3.0), "f": ("o", 3.5), "d": ("s", 3.5), "v": ("o", 3.5), "s": ("o", 4.5)}
    for key, (label, color) in STABILITY.items():
        mask = symbols == key
        if np.any(mask):
            shape, size = shapes[key]
            ax.markers(stab.freq_hz[mask], orders[mask], color, shape=shape, size=size,
                       label=f"{key}: {label}")
    for fs in np.atleast_1d(result.modes.fn_hz):
        ax.vline(float(fs), "#c0504d", width=0.8, dash="6 4")
    ax.frame(xlabel="frequency / Hz", ylabel="model order", title=title)
    tw.frame(ylabel="sum |H|", yside="right", show_x=False, grid=False, draw_box=False)
    ax.legend("below", columns=columns)
    return c.to_svg(standalone)


def figure_fit(
    result: IdentificationResult, frf: FRFSet, title: str = "", *, standalone: bool = False
) -> str:
    """Measured against synthesised FRF (LSFD), one panel per response, with the
    FRAC and the normalised error ||H - H_fit|| / ||H|| in each panel's title."""
    lo, hi = result.settings.band_hz
    H = frf.band(lo, hi).H
    f = result.freq_hz
    n = H.shape[0]
    panel = 190
    height = 30 + n * (panel + 30) + 20
    c = Canvas(_W, height, title or "Measured vs synthesised FRF")
    ref = result.shape_reference if H.shape[1] > result.shape_reference else 0
    responses = dof_labels(frf)[0]
    for o in range(n):
        top = 30 + o * (panel + 30)
        meas, fit = np.abs(H[o, ref]), np.abs(result.H_fit[o, ref])
        ax = c.axes((_LEFT, top, _W - _LEFT - _RIGHT, panel), (lo, hi),
                    _log_limits(np.r_[meas, fit], 5), ylog=True)
        ax.line(f, meas, "#777", width=1.0, label="measured")
        ax.line(f, fit, "#c0504d", width=0.9, dash="5 3", label="synthesised")
        dof = responses[o] if o < len(responses) else str(o + 1)
        ptitle = (
            f"{dof}: FRAC {float(result.frac[o, ref]):.4f}, "
            f"fit error {100 * float(result.error[o, ref]):.2f} %"
        )
        ax.frame(ylabel="|H|", title=ptitle, xlabel="frequency / Hz" if o == n - 1 else "",
                 show_x=o == n - 1)
        ax.legend("best", columns=2)
    return c.to_svg(standalone)


def figure_mode_shapes(
    fe_x: np.ndarray,
    fe_shapes: np.ndarray,
    sensor_x: np.ndarray,
    measured: Mapping[str, np.ndarray],
    *,
    standalone: bool = False,
) -> str:
    """Measured mode shapes at the sensors against the updated FE shapes.

    Positions are relative, x/L (0 = clamp, 1 = tip). ``measured[config]`` is
    (n_sensors, n_modes) real-normalised; each measured shape is scaled onto the
    FE shape at the sensors by least squares, so only the shape (ratio between
    sensors and sign) is compared.
    """
    n_modes = fe_shapes.shape[1]
    cols = 2
    rows = -(-n_modes // cols)
    pw, ph = (_W - 40) // cols - 40, 150
    height = 40 + rows * (ph + 40) + 30
    c = Canvas(_W, height, "Mode shapes: measured at the sensors vs updated FE")
    for r in range(n_modes):
        left = 50 + (r % cols) * (pw + 60)
        top = 40 + (r // cols) * (ph + 40)
        ax = c.axes((left, top, pw, ph), (0.0, 1.0), (-1.15, 1.15))
        shape = fe_shapes[:, r] / np.max(np.abs(fe_shapes[:, r]))
        ax.hline(0.0, "#bbb", width=0.8)
        ax.line(fe_x, shape, "#444", width=1.2, label="FE (updated)" if r == 0 else "")
        at_sensors = np.interp(sensor_x, fe_x, shape)
        for k, (name, phi) in enumerate(measured.items()):
            if phi.shape[1] <= r:
                continue
            m = np.real(phi[:, r])
            scale = float(m @ at_sensors / max(m @ m, 1e-300))
            ax.markers(sensor_x, scale * m, COLORS[k % len(COLORS)], shape="os"[k % 2],
                       size=9 - 2 * min(k, 3), label=_label(name) if r == 0 else "")
        ax.frame(title=f"mode {r + 1}", xlabel="x / L" if r // cols == rows - 1 else "",
                 show_x=r // cols == rows - 1)
        if r == 0:
            ax.legend("lower left")
    return c.to_svg(standalone)


def figure_shapes_by_dof(
    result: IdentificationResult, dof_labels: Sequence[str], *, standalone: bool = False
) -> str:
    """Real-normalised mode shapes, one small panel per mode, one stem per DOF
    (for a single file, where the DOFs' positions are unknown)."""
    phi = np.real(result.shapes_real)
    n_dof, n_modes = phi.shape
    cols = min(4, max(n_modes, 1))
    rows = -(-n_modes // cols)
    pw, ph = (_W - 20) // cols - 50, 120
    height = 40 + rows * (ph + 56) + 10
    c = Canvas(_W, height, "Mode shapes at the measured DOFs")
    x = np.arange(1, n_dof + 1, dtype=float)
    labels = list(dof_labels)
    if len(labels) != n_dof:  # e.g. a roving hammer: the shapes are at the hammer points
        labels = [d.label() for d in result.modes.dofs] if len(result.modes.dofs) == n_dof \
            else [str(k + 1) for k in range(n_dof)]
    # one label per ~34 px (a label such as "11+Z" is about 28 px wide): never smeared
    every = max(1, -(-n_dof * 34 // pw))
    for r in range(n_modes):
        left = 50 + (r % cols) * (pw + 50)
        top = 30 + (r // cols) * (ph + 56)
        ax = c.axes((left, top, pw, ph), (0.4, n_dof + 0.6), (-1.15, 1.15))
        ax.hline(0.0, "#bbb", width=0.8)
        ax.bars(x, phi[:, r], 0.5, COLORS[0])
        ax.frame(title=f"mode {r + 1}: {float(result.modes.fn_hz[r]):.2f} Hz",
                 xticks=x[::every].tolist(), xticklabels=labels[::every], grid=False)
    return c.to_svg(standalone)


def figure_added_mass(table2: pd.DataFrame, *, standalone: bool = False) -> str:
    """Modal added-mass ratio per mode with +-1 sigma bars and the paper's values."""
    configs = list(dict.fromkeys(table2["configuration"]))
    modes = sorted(set(int(m) for m in table2["mode"]))
    vals = table2["added_mass_ratio"].to_numpy(dtype=float)
    top = max(float(np.nanmax(vals)) if vals.size else 0.1, 0.01) * 1.25
    height = 300
    c = Canvas(_W, height, "Modal added mass per mode")
    ax = c.axes((_LEFT, 30, _W - _LEFT - _RIGHT, height - 80),
                (modes[0] - 0.6, modes[-1] + 0.6), (0.0, top))
    width = 0.8 / max(len(configs), 1)
    for k, cfg in enumerate(configs):
        t = table2[table2["configuration"] == cfg]
        x = t["mode"].to_numpy(dtype=float) + (k - (len(configs) - 1) / 2) * width
        err = t["added_mass_ratio_std"].to_numpy() if "added_mass_ratio_std" in t else None
        ax.bars(x, t["added_mass_ratio"].to_numpy(), width * 0.9,
                COLORS[(k + 1) % len(COLORS)], err=err, label=_label(cfg))
        if cfg in paper.TABLE2_RATIO:
            ref = paper.TABLE2_RATIO[cfg]
            xr = np.arange(1, ref.size + 1) + (k - (len(configs) - 1) / 2) * width
            ax.markers(xr, ref, "#000", shape="+", size=10 * width / 0.4,
                       label="paper" if k == 0 else "")
    ax.frame(xlabel="mode", ylabel="m_ar / m_r", xticks=modes,
             xticklabels=[str(m) for m in modes], title="Modal added mass (eq. 10)")
    ax.legend("upper right")
    return c.to_svg(standalone)


def figure_geometry(
    length_m: float,
    n_elements: int,
    response_nodes: Sequence[int],
    hammer_node: int,
    *,
    immersed_elements: Sequence[int] = (),
    direction_label: str = "+Z",
    standalone: bool = False,
) -> str:
    """Sketch of the cantilever: clamp at node 1, the measurement nodes, the
    accelerometers (squares, above) and the hammer (arrow), immersed elements in water."""
    height = 190
    c = Canvas(_W, height, "Test geometry: sensors and hammer on the beam")
    S = SCALE
    x0, x1, yb = 70, _W - 40, 100  # beam from x0 to x1 at height yb (px)
    n_nodes = n_elements + 1

    def xn(node: float) -> float:
        return x0 + (node - 1) / n_elements * (x1 - x0)

    for e in immersed_elements:
        a, b = xn(e) - 10, xn(e + 1) + 14
        c.add(f'<rect x="{round(a * S)}" y="{(yb - 4) * S}" width="{round((b - a) * S)}" '
              f'height="{60 * S}" fill="#cfe6f7" stroke="#7fb2d9" stroke-width="2"/>')
        c.text((a + b) / 2, yb + 50, "water", size=9 * S, color="#3b78a8")
    # clamp (hatched wall)
    hatch = "".join(f"M{(x0 - 14) * S} {(yb - 34 + 10 * k) * S}l{-10 * S} {10 * S}"
                    for k in range(8))
    c.add(f'<path d="M{x0 * S} {(yb - 40) * S}V{(yb + 40) * S}{hatch}" stroke="#333" '
          f'stroke-width="{2 * S}" fill="none"/>')
    c.add(f'<rect x="{x0 * S}" y="{(yb - 4) * S}" width="{(x1 - x0) * S}" height="{8 * S}" '
          'fill="#9aa5b1" stroke="#333" stroke-width="2"/>')
    for node in range(1, n_nodes + 1):
        x = xn(node)
        c.add(f'<path d="M{round(x * S)} {(yb + 4) * S}v{6 * S}" stroke="#333" stroke-width="2"/>')
        c.text(x, yb + 24, str(node), size=9 * S, color="#444")
    for node in response_nodes:
        x = xn(node)
        c.add(f'<rect x="{round((x - 7) * S)}" y="{(yb - 18) * S}" width="{14 * S}" '
              f'height="{14 * S}" fill="#1f4e79"/>')
        c.text(x, yb - 26, f"acc. {node}{direction_label}", size=9 * S, color="#1f4e79")
    xh = xn(hammer_node)
    c.add(f'<path d="M{round(xh * S)} {(yb - 62) * S}V{(yb - 8) * S}m-{7 * S}-{12 * S}'
          f'l{7 * S} {12 * S}l{7 * S}-{12 * S}" stroke="#c0504d" stroke-width="{2 * S}" '
          'fill="none"/>')
    c.text(xh, yb - 68, f"hammer {hammer_node}{direction_label}", size=9 * S, color="#c0504d")
    # dimension line
    yd = yb + 62
    c.add(f'<path d="M{x0 * S} {yd * S}H{x1 * S}M{x0 * S} {(yd - 5) * S}v{10 * S}'
          f'M{x1 * S} {(yd - 5) * S}v{10 * S}" stroke="#555" stroke-width="2"/>')
    c.text((x0 + x1) / 2, yd - 4, f"L = {length_m:g} m, {n_elements} measurement elements",
           size=9 * S, color="#333")
    return c.to_svg(standalone)


def figure_batch_frequencies(
    files: Sequence[str], fn_hz: np.ndarray, *, standalone: bool = False
) -> str:
    """Each mode's natural frequency across the files of a batch, one panel per
    mode, in per cent from the mode's median; values more than 3 scaled median
    absolute deviations (and 0.5 %) away are drawn red. ``fn_hz`` is
    ``(n_files, n_modes)``, the modes paired across the files
    (:func:`ema_pipeline.report.trends.pair_modes`), NaN where a file lacks one."""
    table = np.asarray(fn_hz, dtype=float).reshape(len(files), -1)
    n_files, n_modes = table.shape
    if n_files == 0 or n_modes == 0:
        c = Canvas(_W, 60, "No modes identified")
        c.text(_W / 2, 35, "no file gave modes")
        return c.to_svg(standalone)
    ph = 80
    height = 30 + n_modes * (ph + 22) + 30
    c = Canvas(_W, height, "Natural frequency of each mode across the files")
    x = np.arange(1, n_files + 1, dtype=float)
    for m in range(n_modes):
        v = table[:, m]
        ok = np.isfinite(v)
        med = float(np.median(v[ok])) if ok.any() else np.nan
        dev = 100 * (v / med - 1)
        mad = 1.4826 * float(np.median(np.abs(dev[ok]))) if ok.any() else 0.0
        out = ok & (np.abs(dev) > max(3 * mad, 0.5))
        span = max(float(np.nanmax(np.abs(dev))) if ok.any() else 0.0, 0.2) * 1.15
        top = 30 + m * (ph + 22)
        ax = c.axes((_LEFT, top, _W - _LEFT - _RIGHT, ph), (0.5, n_files + 0.5), (-span, span))
        ax.hline(0.0, "#999", width=0.8)
        ax.line(x[ok], dev[ok], COLORS[0], width=0.6, opacity=0.5)
        ax.markers(x[ok & ~out], dev[ok & ~out], COLORS[0], size=4)
        ax.markers(x[out], dev[out], "#d62728", size=6)
        last = m == n_modes - 1
        step = max(1, int(np.ceil(n_files / 20)))
        ticks = x[::step]
        n_out = int(out.sum())
        missing = n_files - int(ok.sum())
        title = (f"mode {m + 1}: median {med:.4g} Hz, {n_out} outlier{'' if n_out == 1 else 's'}"
                 + (f", missing in {missing} file{'' if missing == 1 else 's'}" if missing else ""))
        ax.frame(ylabel="%", title=title,
                 xticks=ticks.tolist(), xticklabels=[str(int(t)) for t in ticks], show_x=last,
                 xlabel="file (number as in the table)" if last else "")
    return c.to_svg(standalone)
