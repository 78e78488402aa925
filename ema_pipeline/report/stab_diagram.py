"""The interactive stabilization diagram of the report pages: preview the
poles and pick the modes by hand.

Inline SVG and a little JavaScript (:mod:`.stab_script`), nothing loaded
from outside the page. The page holds the diagram's poles as compact columns
of numbers (a JSON ``script.stab-poles``, about 30 bytes a pole, so that a
study report with three diagrams stays small); its script makes every pole
of the stored diagram a ``text.pole`` element, its stability symbol in its
colour (:mod:`.stab_marks`: ``o``, ``f``, ``d``, ``v``, ``s``), carrying
``data-freq-hz`` (natural frequency, window-corrected), ``data-zeta``,
``data-order`` (model order), ``data-mpc`` (MPC of the pole's one-pole local
fit, :func:`ema_pipeline.identification.selection.picks.pole_mpc`),
``data-group`` (its trajectory: the poles of one mode), ``data-stability``
(its symbol) and ``data-stable`` (``1`` when stable in frequency, damping
and vector). Every mode the automatic selection kept is drawn as a diamond in
the top row ("modes") at its refined frequency (the tables', ``data-x-hz``),
with ``data-kind="mode"``, its start pole
(:attr:`StabilizationData.mode_pole`: ``data-freq-hz``, ``data-zeta`` and the
exact ``data-pole-re``, ``data-pole-im``, rad/s, which the picks file gives),
the orders at which it is stable and how it was found; these carry
``selected`` when the page opens.

The sum of |H| over all channels in the band (:func:`.figures.sum_abs_frf`) is
drawn under the poles on a log scale (``path[data-frf-overlay]``; its log10
at every line, or the largest of each run of lines above 2000, one character
a value in 32768 levels from the smallest to the largest), with its axis on
the right. The wheel, a drag and the buttons ``[data-zoom-in]``,
``[data-zoom-out]`` and ``[data-zoom-reset]`` zoom and pan the frequency
axis; the range shown is kept in ``data-x-min-hz`` / ``data-x-max-hz`` of the
``[data-diagram]`` element and the frequency ticks are redrawn in 1-2-5
steps (the axes: :mod:`.stab_marks`). The legend draws every kind of mark as
the diagram does. Over the sum FRF, ``path[data-synthesis]`` is the same sum
synthesised from the picked poles, refitted in the page whenever a pole is
picked or unpicked (:mod:`.synthesis_view`).

Hovering a pole shows its values in the line under the diagram and as the
pole's tooltip. Clicking a pole previews it and picks nothing: a ring marks
it and ``[data-pole-preview]`` gives its frequency, damping, MPC, order and
stability and, for a kept mode, its real-normalised shape by DOF
(``svg[data-shape]``; not for shapes of fewer than
:data:`~.shape_views.MIN_SHAPE_DOFS` points, where a sentence says so), its
shape animated on the test geometry when the page has one
(:func:`.shape_views.shape_preview_html`) and, where the page's mode shapes
section animates the shapes, a button (``[data-show-shape]``) that brings
that mode's view into sight. Picking is its own act: the preview's button
``[data-pick-toggle]`` or the key P picks or unpicks the previewed pole; a
mode has one pole, so picking another pole of the same trajectory moves the
pick there. The element ``#picks`` always holds the picks file of the
current selection, with a copy and a download button:
``ema-pipeline identify FILE --picks picks.toml`` fits exactly those poles.
The script writes it (when the page opens and at every pick) in the layout
of :mod:`ema_pipeline.io.picks`, the one home of the format (its version,
keys and comments; ``tests/test_picks_format.py`` runs the script in a
browser and reads its text with the io reader). Untouched, the page's picks
are the automatic result's (:func:`~ema_pipeline.identification.selection.picks.picks_from_result`),
with its companions (candidates refined beside the kept modes, then dropped);
the script writes these only while no pole of the diagram itself is picked.
"""

from __future__ import annotations

import json

import numpy as np

from ema_pipeline.data import FRFSet, Geometry
from ema_pipeline.identification.result import (
    IdentificationResult,
    found_by_names,
    stable_orders,
)
from ema_pipeline.identification.selection.picks import is_picked, picks_from_result, pole_mpc
from ema_pipeline.report.figures import sum_abs_frf
from ema_pipeline.report.htmlparts import esc
from ema_pipeline.report.result_tables import label_as_tested
from ema_pipeline.report.shape_views import (
    MIN_SHAPE_DOFS,
    ModeSet,
    shape_dof_count,
    shape_preview_html,
)
from ema_pipeline.report.stab_marks import (
    FREQUENCY_PARTS,
    MARKS_CSS,
    STABILITY,
    amplitude_axis,
    frequency_steps,
    legend_html,
    order_axis,
    stability_symbols,
)
from ema_pipeline.report.stab_script import CURVE_LEVELS, PICK_KEY, STAB_CALL, STAB_SCRIPT
from ema_pipeline.report.synthesis_view import CODE_0, synthesis_data

__all__ = ["stab_diagram_html"]

_W, _H = 900.0, 440.0
_LEFT, _RIGHT, _TOP, _BOTTOM = 48.0, 62.0, 34.0, 36.0

_CSS = """<style>
.stabd svg{display:block;width:100%;max-width:900px;height:auto;font:11px sans-serif}
.stabd svg.stab .pole{cursor:pointer}
.stabd svg.stab text.pole:hover{stroke:#000;stroke-width:.6}
.stabd svg.stab polygon.pole:hover{stroke:#000;stroke-width:2}
.stabd .tick{stroke:#999}.stabd .grid{stroke:#e4e4e4;pointer-events:none}
.stabd pre.picks{max-height:14em;overflow:auto;background:#f6f6f6;padding:.4em;font-size:.8em}
.stabd .info{min-height:1.3em;font-size:.9em}
.stabd svg.stab{cursor:grab;touch-action:none}.stabd svg.stab.dragging{cursor:grabbing}
.stabd .legend span{margin-right:1.1em;white-space:nowrap;display:inline-flex;align-items:center}
.stabd .legend svg.mark{display:inline;width:16px;margin-right:.25em;overflow:visible}
.stabd .preview{border:1px solid #ccc;padding:.3em .6em;margin:.3em 0;font-size:.9em}
.stabd .preview p{margin:.25em 0}.stabd .preview .pv-head{font-weight:600}
.stabd .pv-shapes{display:flex;flex-wrap:wrap;gap:.3em 1em;align-items:flex-start}
.stabd .pv-bars{flex:1 1 400px;max-width:520px}.stabd .pv-geometry{flex:0 1 360px}
.stabd kbd{border:1px solid #aaa;border-radius:3px;padding:0 .3em;font-size:.9em}
@media print{.stabd button,.stabd pre.picks,.stabd .zoom{display:none}}
""" + MARKS_CSS + "</style>"

_OVERLAY_POINTS = 2000  # at most this many points of the sum FRF in the page


def _overlay(freq_hz: np.ndarray, total: np.ndarray) -> tuple[float, float, np.ndarray]:
    """The sum FRF as ``(f0_hz, df_hz, log10 values)`` on a uniform grid: the
    lines themselves, or, above :data:`_OVERLAY_POINTS` lines, the largest value
    of each run of ``k`` lines at the run's centre (peaks are kept); zeros and
    NaN become the curve's lowest value."""
    v = np.where(np.isfinite(total) & (total > 0), total, np.nan)
    if freq_hz.size < 2 or np.all(np.isnan(v)):
        return 0.0, 1.0, np.zeros(0)
    v = np.where(np.isnan(v), np.nanmin(v), v)
    df = float(freq_hz[1] - freq_hz[0])
    k = max(1, -(-v.size // _OVERLAY_POINTS))
    n = v.size // k
    peaks = v[: n * k].reshape(n, k).max(axis=1)
    return float(freq_hz[0]) + df * (k - 1) / 2, df * k, np.log10(peaks)


def _curve_text(values: np.ndarray) -> str:
    """``values`` as one character each, ``CODE_0`` plus the level from the
    smallest (0) to the largest (:data:`.stab_script.CURVE_LEVELS`): 3 bytes a value and
    1e-4 decade for the log10 curve, where "-2.35," takes 6 bytes to 0.005.

    Examples
    --------
    >>> [ord(c) - CODE_0 for c in _curve_text(np.array([-3.0, -1.0, -2.0]))]
    [0, 32767, 16384]
    """
    if values.size == 0:
        return ""
    lo, hi = float(values.min()), float(values.max())
    q = np.rint((values - lo) / ((hi - lo) or 1.0) * CURVE_LEVELS).astype(np.int64)
    return "".join(map(chr, (CODE_0 + q).tolist()))


def _mode_shapes(result: IdentificationResult, n_modes: int) -> list[list[float]]:
    """Each kept mode's real-normalised shape scaled to a largest value of 1
    (empty when the result has no shapes for every mode)."""
    phi = np.real(np.asarray(result.shapes_real))
    if phi.ndim != 2 or phi.shape[1] != n_modes or n_modes == 0:
        return []
    peak = np.max(np.abs(phi), axis=0)
    phi = phi / np.where(peak > 0, peak, 1.0)
    return [[round(float(v), 3) for v in phi[:, k]] for k in range(n_modes)]


def _dof_labels(result: IdentificationResult, n_dof: int, negative: str) -> list[str]:
    """The labels of the shapes' DOFs with the sign as tested (``negative``: the
    acquisition's ``response_negative``, as the setup table), their numbers
    when the result has none."""
    dofs = tuple(result.modes.dofs)
    if len(dofs) == n_dof:
        return [label_as_tested(d, negative) for d in dofs]
    return [str(k + 1) for k in range(n_dof)]


def _join(values: np.ndarray, fmt: str) -> str:
    """A JSON array of ``values`` formatted with ``fmt`` (finite values only)."""
    cast = int if fmt.endswith("d}") else float
    return "[" + ",".join(fmt.format(cast(v)) for v in values) + "]"


def _mode_groups(result: IdentificationResult, f_mode: np.ndarray) -> list[str]:
    """The group of each mode pole: its trajectory's when the diagram holds
    poles of that trajectory within 2 % of its frequency, else its own."""
    stab, sel = result.stabilization, result.selected
    groups = []
    for k, f in enumerate(f_mode):
        c = int(sel.cluster[k]) if sel is not None and k < sel.cluster.size else -1
        near = (stab.cluster == c) & (np.abs(stab.freq_hz - f) < 0.02 * f)
        groups.append(str(c) if c >= 0 and near.any() else f"m{k}")
    return groups


def _preview_geometry(frf: FRFSet, result: IdentificationResult, geometry: Geometry | None,
                      mode_set: ModeSet | None, n_modes: int) -> str:
    """The preview's animated view on ``geometry`` of the kept modes
    (``mode_set``, else the result's shapes at the measured DOFs); empty
    without a geometry, without shapes for every kept mode or with fewer than
    :data:`MIN_SHAPE_DOFS` measured points."""
    m = result.modes
    if mode_set is None and m.shapes is not None:
        mode_set = ModeSet(m.fn_hz, m.zeta, m.shapes, m.dofs)
    if (geometry is None or mode_set is None or n_modes == 0
            or shape_dof_count(frf) < MIN_SHAPE_DOFS
            or np.shape(mode_set.shapes)[-1] != n_modes):
        return ""
    return f'<div class="pv-geometry" hidden>{shape_preview_html(geometry, mode_set)}</div>'


def stab_diagram_html(frf: FRFSet, result: IdentificationResult, *,
                      picks_id: str = "picks", file_name: str = "picks.toml",
                      geometry: Geometry | None = None,
                      mode_set: ModeSet | None = None, with_code: bool = True) -> str:
    """The interactive diagram of ``result`` (identified from ``frf``, the FRF
    set it was given) with its ``<pre id="picks_id">`` picks file; empty
    without a diagram (sdypy backend). With ``geometry``, the preview of a
    kept mode animates its shape on it (``mode_set``: the shapes to draw,
    one per kept mode, by default the result's). ``with_code=False``: the
    style and the script's code are left to an earlier diagram of the page
    (a study report's first), which holds them.

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import ModalParameters
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> frf = FRFSet(freq_hz=f, H=H)
    >>> page = stab_diagram_html(frf, identify(frf))
    >>> page.count('class="pole mode selected"'), 'id="picks"' in page
    (2, True)
    """
    stab, s = result.stabilization, result.settings
    if stab.order.size == 0:
        return ""
    lo, hi = s.band_hz
    sub = frf.band(lo, hi)
    Hc = sub.H.reshape(-1, sub.freq_hz.size)
    picks = picks_from_result(result)
    start = np.array([p.pole for p in picks.picks], dtype=complex)
    f_mode = np.array([p.freq_hz for p in picks.picks])
    z_mode = np.array([p.zeta for p in picks.picks])
    mpc_d = pole_mpc(sub.freq_hz, Hc, stab.pole)
    mpc_m = np.asarray(result.mpc, dtype=float)
    if mpc_m.size != start.size:
        mpc_m = pole_mpc(sub.freq_hz, Hc, start)
    orders = np.unique(stab.order)
    o_max = int(orders.max())
    pw, ph = _W - _LEFT - _RIGHT, _H - _TOP - _BOTTOM
    row = ph / (orders.size + 2)  # the modes' row on top, a gap below it

    def x_of(f: np.ndarray) -> np.ndarray:
        return _LEFT + (np.asarray(f) - lo) / (hi - lo) * pw

    def y_of_order(o: float) -> float:  # between the rows of the orders around it
        return float(_TOP + ph - (np.interp(o, orders, np.arange(orders.size)) + 0.5) * row)

    y_modes = _TOP + 0.7 * row
    symbol = stability_symbols(stab.flags)
    inside = np.flatnonzero(np.isfinite(stab.freq_hz) & np.isfinite(stab.zeta)
                            & (stab.freq_hz >= lo) & (stab.freq_hz <= hi))
    # the sum FRF of the band on a log scale, under the poles
    f0_sum, df_sum, l_sum = _overlay(sub.freq_hz, sum_abs_frf(sub.H))
    lmin = float(l_sum.min()) if l_sum.size else 0.0
    lmax = float(l_sum.max()) if l_sum.size else 1.0
    oh = ph - 1.5 * row

    def y_of_level(level: float) -> float:
        return _TOP + ph - (level - lmin) / ((lmax - lmin) or 1.0) * oh

    x_right, mid = _LEFT + pw, _TOP + ph / 2
    parts = [f'<svg class="stab" viewBox="0 0 {_W:g} {_H:g}" role="img" '
             'aria-label="Interactive stabilization diagram">',
             '<g class="ticks"></g>',
             f'<rect x="{_LEFT}" y="{_TOP}" width="{pw}" height="{ph}" fill="none" '
             'stroke="#999"/>',
             '<path class="frf-overlay" data-frf-overlay="" d=""/>',
             '<path class="synthesis" data-synthesis="" d=""/>',
             f'<text x="{_LEFT + pw / 2}" y="{_H - 4}" text-anchor="middle">'
             "natural frequency (Hz)</text>",
             order_axis(orders, y_of_order, _LEFT),
             f'<text x="{_LEFT - 6}" y="{y_modes:.1f}" text-anchor="end" '
             'dominant-baseline="central">modes</text>',
             f'<text x="12" y="{mid:.1f}" transform="rotate(-90 12 {mid:.1f})" '
             'text-anchor="middle">model order</text>']
    if l_sum.size:
        parts += [amplitude_axis(lmin, lmax, y_of_level, x_right),
                  f'<text class="amplitude" x="{_W - 6:.1f}" y="{mid:.1f}" '
                  f'transform="rotate(90 {_W - 6:.1f} {mid:.1f})" text-anchor="middle">'
                  f"sum of |H| ({esc(frf.units)})</text>"]
    # the diagram's poles as compact columns; the page's script makes them
    # text.pole elements (the static figure beside it is the no-script view)
    columns = {
        "f": _join(stab.freq_hz[inside], "{:.7g}"),
        "z": _join(stab.zeta[inside], "{:.4g}"),
        "o": _join(stab.order[inside], "{:d}"),
        "m": _join(np.nan_to_num(mpc_d[inside]), "{:.2f}"),
        "g": _join(stab.cluster[inside], "{:d}"),
        "s": json.dumps("".join(symbol[inside])),
    }
    columns["fl"] = json.dumps(_curve_text(l_sum), ensure_ascii=False)
    n_dof = shape_dof_count(frf)
    shapes = _mode_shapes(result, start.size) if n_dof >= MIN_SHAPE_DOFS else []
    frame = {"lo": float(lo), "hi": float(hi), "x0": _LEFT, "pw": pw, "y0": _TOP + ph,
             "ph": ph, "row": row, "orders": [int(o) for o in orders], "lmin": lmin,
             "lmax": lmax, "oh": oh, "f0": f0_sum, "df": df_sum, "shapes": shapes,
             "parts": FREQUENCY_PARTS, "steps": frequency_steps(lo, hi, (hi - lo) * 1e-3),
             "stab": {k: meaning for k, (meaning, _) in STABILITY.items()},
             "dofs": _dof_labels(result, len(shapes[0]) if shapes else 0,
                                 frf.acquisition.response_negative),
             "sy": synthesis_data(sub, s),
             "noshape": "" if n_dof >= MIN_SHAPE_DOFS else
             f"A mode shape of this test has {n_dof} measured point"
             f"{'' if n_dof == 1 else 's'} only: no shape is drawn."}
    data = ("{" + ",".join(f'"{k}":{v}' for k, v in columns.items()) + ","
            + json.dumps(frame, ensure_ascii=False)[1:])
    size = float(np.clip(1.1 * row, 6.0, 11.0))  # the symbols' font size (px)
    parts.append(f'<g class="diagram-poles" font-size="{size:.1f}"></g>')
    groups = _mode_groups(result, f_mode)
    fn_fit = np.asarray(result.modes.fn_hz, dtype=float)
    zeta_fit = np.asarray(result.modes.zeta, dtype=float)
    if fn_fit.size != start.size:
        fn_fit, zeta_fit = f_mode, z_mode
    first, last, n_stable = (np.resize(v, start.size) for v in stable_orders(result))
    found = (found_by_names(result) + [""] * start.size)[: start.size]
    for k, p in enumerate(start):
        cx, r = float(x_of(fn_fit[k])), 5.0
        pts = f"{cx:.1f},{y_modes - r:.1f} {cx + r:.1f},{y_modes:.1f} " \
              f"{cx:.1f},{y_modes + r:.1f} {cx - r:.1f},{y_modes:.1f}"
        parts.append(
            f'<polygon class="pole mode selected" points="{pts}" '
            f'data-kind="mode" data-mode="{k + 1}" data-freq-hz="{float(f_mode[k])!r}" '
            f'data-zeta="{float(z_mode[k])!r}" data-x-hz="{float(fn_fit[k])!r}" '
            f'data-zeta-fit="{float(zeta_fit[k])!r}" data-y="{y_modes:.1f}" '
            f'data-order="{o_max}" data-mpc="{mpc_m[k]:.3f}" data-group="{groups[k]}" '
            f'data-stable="1" data-stable-first="{first[k]}" data-stable-last="{last[k]}" '
            f'data-stable-count="{n_stable[k]}" data-found-by="{esc(found[k])}" '
            f'data-pole-re="{float(p.real)!r}" data-pole-im="{float(p.imag)!r}"/>')
    parts.append('<circle class="previewed" r="7" cx="0" cy="0" style="display:none"/></svg>')
    cfg = json.dumps({"band_hz": [float(lo), float(hi)],
                      "orders": [int(o) for o in picks.orders],
                      "weighting": picks.weighting, "file": file_name,
                      "companions": [[c.real, c.imag] for c in picks.companions]})
    picked = (" This result was fitted from picks (<code>--picks</code>): every mode is "
              "picked." if is_picked(result) else "")
    key = PICK_KEY.upper()
    return (
        f'{_CSS if with_code else ""}<div class="stabd" data-diagram="{esc(cfg)}">'
        '<p class="muted" data-help="">Click a pole (a symbol) or a kept mode (a diamond '
        "on top) to preview it: its frequency, damping, MPC, order and stability and, for "
        "a kept mode, its shape. A click picks nothing: the preview's button "
        f"<i>Pick</i> / <i>Unpick</i> or the key <kbd>{key}</kbd> picks or unpicks the "
        "previewed pole (one pole per mode: picking a pole of a picked trajectory moves "
        "the pick). The diamonds on top are the kept modes, drawn at the refined "
        "frequencies of the tables. Zoom with the mouse wheel or the buttons, pan by "
        "dragging. The picks file below reproduces the selection with "
        f"<code>ema-pipeline identify FILE --picks {esc(file_name)}</code>.{picked}</p>"
        f'<p class="legend">{legend_html(symbol[inside], start.size)}</p>'
        '<p class="zoom"><button type="button" data-zoom-in="">Zoom in</button> '
        '<button type="button" data-zoom-out="">Zoom out</button> '
        '<button type="button" data-zoom-reset="">Whole band</button></p>'
        + "".join(parts)
        + '<p class="info"></p><div class="preview" data-pole-preview="" hidden>'
        '<div class="pv-text"></div><p><button type="button" data-pick-toggle="" '
        f'aria-pressed="false">Pick this pole ({key})</button></p><div class="pv-shapes">'
        '<div class="pv-bars"></div>'
        + _preview_geometry(frf, result, geometry, mode_set, start.size) + "</div></div>"
        '<p><span class="npicks">0</span> poles picked '
        '<button type="button" class="copy-picks">Copy picks</button> '
        '<button type="button" class="download-picks">Download picks</button></p>'
        f'<pre class="picks" id="{esc(picks_id)}"></pre>'
        f'<script type="application/json" class="stab-poles">{data}</script>'
        f"<script>{STAB_SCRIPT if with_code else ''}{STAB_CALL}</script></div>"
    )
