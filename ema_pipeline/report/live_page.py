"""The page of a live impact test (``ema-pipeline live``) and its figures:
presentation only.

The page is one self-contained HTML document (no file or script from outside:
labs are often offline). Its script opens a WebSocket to the server, receives the
test's state as JSON and redraws: the point plan (``[data-point]`` with
``data-node``, ``data-state`` todo / current / done and ``data-accepted``), the
hits of the current point (``[data-hit]`` with ``data-status`` and
``data-reasons``, shown as chips in words), the live trace with the trigger
level, the running FRF and coherence (:func:`running_frf_figure`, the report's
:func:`~ema_pipeline.report.figures.figure_frf_coherence`), the modes of the
points so far (``[data-live-mode]`` with ``data-fn-hz`` and ``data-zeta``) and
their shapes on the geometry (the report's animated shape views,
:func:`~ema_pipeline.report.shape_views.shape_views_html`, ``[data-mode-shape]``).
Buttons ``[data-next-point]``, ``[data-finish]`` (and ``[data-virtual-hit]`` for a
virtual hammer) send commands; keys: A accept, R reject, U undo the last choice,
N next point, H strike (virtual hammer).
"""

from __future__ import annotations

import json

import numpy as np

from ema_pipeline.data import FRFSet, Geometry
from ema_pipeline.report.figures import figure_frf_coherence
from ema_pipeline.report.htmlparts import esc
from ema_pipeline.report.scripts import page_script
from ema_pipeline.report.svg import Canvas

__all__ = ["REASON_WORDS", "live_page_html", "plan_layout", "running_frf_figure",
           "trace_figure"]

#: The hit checks' reasons in words, for the chips.
REASON_WORDS = {"past_end": "record past the end of the data", "double_hit": "double hit",
                "overload": "overload", "not_decayed": "not decayed", "low_force": "low force",
                "outlier": "outlier", "data_lost": "data lost (dropout)"}


def running_frf_figure(frf: FRFSet | None, title: str) -> str:
    """The running FRF and coherence of a point (an empty note when no hit is
    accepted yet).

    Examples
    --------
    >>> running_frf_figure(None, "point 1")
    '<p class="muted">point 1: no hit accepted yet</p>'
    """
    if frf is None:
        return f'<p class="muted">{esc(title)}: no hit accepted yet</p>'
    n = frf.acquisition.n_averages
    return figure_frf_coherence(frf, f"{title}: {n} hit{'s' if n != 1 else ''} averaged")


def trace_figure(data: np.ndarray, sample_rate_hz: float, t0_s: float,
                 trigger_n: float) -> str:
    """The live trace: force (with its trigger level, dashed) over the first
    response, the last samples of ``data`` (n_channels, n) from ``t0_s``.

    Examples
    --------
    >>> svg = trace_figure(np.zeros((2, 100)), 100.0, 0.0, 5.0)
    >>> svg.startswith("<svg") and "trigger" in svg
    True
    """
    c = Canvas(520, 250, "live trace: force and response")
    n = data.shape[1]
    t = t0_s + np.arange(n) / sample_rate_hz
    xlim = (t0_s, t0_s + max(n, 2) / sample_rate_hz)
    for k, (name, top) in enumerate((("force / N", 20), ("response", 125))):
        y = data[k].astype(float) if k < data.shape[0] and n else np.zeros(2)
        base = float(np.median(y)) if y.size else 0.0
        span = max(float(np.max(np.abs(y - base))) if y.size else 0.0,
                   1.5 * trigger_n if k == 0 else 0.0, 1e-12)
        ax = c.axes((60, top, 440, 85), xlim, (base - 1.1 * span, base + 1.1 * span))
        if n:
            ax.line(t, y, "#1f4e79" if k == 0 else "#b35900", width=0.8)
        if k == 0 and trigger_n > 0:
            ax.hline(base + trigger_n, "#c00", dash="6 4")
            c.text(505, top + 10, "trigger", anchor="end", color="#c00")
        ax.frame(ylabel=name, show_x=k == 1, xlabel="time / s" if k == 1 else "")
    return c.to_svg()


def plan_layout(geometry: Geometry | None, width: float = 240.0, height: float = 150.0) -> dict:
    """The point plan's drawing: every node of ``geometry`` at its place in a
    ``width`` x ``height`` px view (seen from above, +Z towards the reader, for a
    flat structure; else an isometric view) and its trace lines as segments;
    ``{}`` without a geometry.

    Examples
    --------
    >>> g = Geometry(node_ids=[1, 2], xyz_m=[[0, 0, 0], [1, 0, 0]], lines=((1, 2),))
    >>> plan_layout(g, 100, 50)
    {'nodes': {'1': [10.0, 25.0], '2': [90.0, 25.0]}, 'lines': [[10.0, 25.0, 90.0, 25.0]]}
    """
    if geometry is None:
        return {}
    xyz = np.asarray(geometry.xyz_m, dtype=float)
    if np.ptp(xyz[:, 2]) <= 1e-9 * max(float(np.ptp(xyz)), 1e-12):
        xy = np.c_[xyz[:, 0], -xyz[:, 1]]
    else:
        c = np.cos(np.pi / 6)
        xy = np.c_[(xyz[:, 0] - xyz[:, 1]) * c, (xyz[:, 0] + xyz[:, 1]) * 0.5 - xyz[:, 2]]
    lo, span = xy.min(axis=0), np.maximum(np.ptp(xy, axis=0), 1e-12)
    pad = 10.0
    scale = min((width - 2 * pad) / span[0], (height - 2 * pad) / span[1])
    px = (xy - lo) * scale + np.array([(width - scale * span[0]) / 2,
                                       (height - scale * span[1]) / 2])
    px = np.round(px, 1)
    at = {int(n): k for k, n in enumerate(geometry.node_ids)}
    segments = [[*px[at[a]].tolist(), *px[at[b]].tolist()] for line in geometry.lines
                for a, b in zip(line[:-1], line[1:], strict=True)]
    return {"nodes": {str(int(n)): px[k].tolist() for k, n in enumerate(geometry.node_ids)},
            "lines": segments}


_CSS = """
body{font-family:system-ui,Segoe UI,Helvetica,Arial,sans-serif;margin:0;color:#222}
header{background:#1f4e79;color:#fff;padding:.4em 1em;display:flex;gap:1em;align-items:center}
header h1{font-size:1.1em;margin:0}
main{display:grid;grid-template-columns:260px 1fr 1fr;gap:.6em;padding:.6em}
section{border:1px solid #dde5ee;border-radius:4px;padding:.4em}
h2{font-size:.95em;margin:.1em 0 .4em}
.muted{color:#777;font-size:.85em}
ol.plan{list-style:none;padding:0;margin:0;display:grid;grid-template-columns:repeat(4,1fr);
gap:3px}
ol.plan li{border:1px solid #ccc;border-radius:3px;text-align:center;font-size:.8em;padding:3px}
ol.plan li[data-state=current]{background:#ffd966;font-weight:600}
ol.plan li[data-state=done]{background:#d9ead3}
ul.hits{list-style:none;padding:0;margin:0}
ul.hits li{margin:2px 0;font-size:.85em}
.chip{display:inline-block;border-radius:9px;padding:0 .5em;margin-left:.3em;font-size:.85em}
li[data-status=accepted] .verdict{background:#d9ead3}
li[data-status=rejected] .verdict{background:#f4cccc}
.reason{background:#fce5cd}
button{margin:2px}
svg.fig{max-width:100%;height:auto}
table{border-collapse:collapse;font-size:.85em}td,th{padding:1px 6px;border-bottom:1px solid #eee}
.wide{grid-column:span 3}
svg.plan line{stroke:#bbb;stroke-width:1}
svg.plan circle{stroke:#444;stroke-width:1;fill:#fff}
svg.plan circle.done{fill:#93c47d}svg.plan circle.current{fill:#ffd966;stroke:#c00;stroke-width:2}
#state{font-size:.85em}
"""



def live_page_html(ws_path: str, title: str, channels: list[tuple[str, str, str]],
                   plan: dict | None = None) -> str:
    """The live page: ``ws_path`` the WebSocket's path (with the token),
    ``channels`` the channel table's rows (name, quantity, DOF), ``plan`` the
    point plan's drawing (:func:`plan_layout`; none: the list only).

    Examples
    --------
    >>> page = live_page_html("/t/ws", "plate", [("hammer", "force", "1-Z")])
    >>> page.count("data-next-point>"), "http" in page.split("<script")[0]
    (1, False)
    """
    config = json.dumps({"ws": ws_path, "words": REASON_WORDS, "plan": plan or {}}
                        ).replace("</", "<\\/")
    rows = "".join(f"<tr><td>{esc(n)}</td><td>{esc(q)}</td><td>{esc(d)}</td></tr>"
                   for n, q, d in channels)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{esc(title)}</title>
<style>{_CSS}</style></head>
<body data-live data-streaming="false">
<header><h1>Live impact test: {esc(title)}</h1><span id="current"></span>
<span id="state">connecting</span></header>
<main>
<section><h2>Points</h2><div id="plan-view"></div><ol class="plan" id="plan"></ol>
<p><button type="button" data-next-point>next point (N)</button>
<button type="button" data-finish>finish</button>
<button type="button" data-virtual-hit hidden>strike (H)</button></p>
<h2>Channels</h2><table><thead><tr><th>channel</th><th>quantity</th><th>DOF</th></tr>
</thead><tbody id="channels">{rows}</tbody></table>
<ul id="messages" class="muted"></ul></section>
<section><h2>Hits of the current point</h2>
<p><button type="button" data-accept>accept (A)</button>
<button type="button" data-reject>reject (R)</button>
<button type="button" data-undo>undo (U)</button></p>
<ul class="hits" id="hits"></ul><div id="trace"></div></section>
<section><h2>Running FRF and coherence</h2><div id="frf"></div></section>
<section class="wide"><h2>Modes of the points so far</h2><div id="modes"></div>
<div id="shapes"></div></section>
</main>
<script type="application/json" id="live-config">{config}</script>
<script>{page_script('live.js')}</script>
</body></html>
"""
