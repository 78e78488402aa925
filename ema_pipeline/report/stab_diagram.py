"""The interactive stabilization diagram of the report pages: pick the modes by hand.

Inline SVG and a little JavaScript, nothing loaded from outside the page.
The page holds the diagram's poles as compact columns of numbers (a JSON
``script.stab-poles``, about 30 bytes a pole, so that a study report with
three diagrams stays small); its script makes every pole of the stored
diagram a ``circle.pole`` element carrying
``data-freq-hz`` (natural frequency, window-corrected), ``data-zeta``,
``data-order`` (model order), ``data-mpc`` (MPC of the pole's one-pole local
fit, :func:`ema_pipeline.identification.picks.pole_mpc`), ``data-group`` (its
trajectory: the poles of one mode) and ``data-stable`` (``1`` when stable in
frequency, damping and vector). The start pole of every mode the automatic
selection kept (:attr:`StabilizationData.mode_pole`: a trajectory's median or a
pole found by the searches outside the diagram) is drawn as a diamond in the
top row ("modes"), with ``data-kind="mode"`` and its exact value
(``data-pole-re``, ``data-pole-im``, rad/s); these carry ``selected`` when
the page opens.

Hovering a pole shows f, zeta, MPC and its order (in the line under the
diagram and as the pole's tooltip). Clicking a pole toggles
it; a mode has one pole, so clicking another pole of the same trajectory
moves the pick there. The element ``#picks`` always holds the picks file
(TOML, :class:`ema_pipeline.identification.picks.Picks`) of the current
selection, with a copy and a download button: ``ema-pipeline identify FILE
--picks picks.toml`` fits exactly those poles. Untouched, the page's picks
are the automatic result's (:func:`~ema_pipeline.identification.picks.picks_from_result`),
with its companions (candidates refined beside the kept modes, then dropped);
the script writes these only while no pole of the diagram itself is picked.
"""

from __future__ import annotations

import json

import numpy as np

from ema_pipeline.data import FRFSet
from ema_pipeline.identification.picks import is_picked, picks_from_result, pole_mpc
from ema_pipeline.identification.result import (
    STABLE_ALL,
    STABLE_DAMP,
    STABLE_FREQ,
    IdentificationResult,
)
from ema_pipeline.report.htmlparts import esc

__all__ = ["stab_diagram_html"]

_W, _H = 900.0, 430.0
_LEFT, _RIGHT, _TOP, _BOTTOM = 48.0, 12.0, 34.0, 36.0

_CSS = """<style>
.stabd svg{display:block;width:100%;max-width:900px;height:auto;font:11px sans-serif}
.stabd .pole{cursor:pointer;stroke-width:.7}
.stabd .pole.s0{fill:none;stroke:#b0b0b0}.stabd .pole.s1{fill:#d08b26;stroke:#d08b26}
.stabd .pole.s2{fill:#1f77b4;stroke:#1f77b4}.stabd .pole.s3{fill:#2e8b3a;stroke:#2e8b3a}
.stabd .pole.mode{fill:#7a3e9d;stroke:#7a3e9d}
.stabd .pole.selected{stroke:#c00000;stroke-width:2.4;fill:#ff4040}
.stabd .pole:hover{stroke:#000;stroke-width:2}
.stabd pre.picks{max-height:14em;overflow:auto;background:#f6f6f6;padding:.4em;font-size:.8em}
.stabd .info{min-height:1.3em;font-size:.9em}
@media print{.stabd button,.stabd pre.picks{display:none}}
</style>"""

_SCRIPT = r"""(function(){
var root=document.currentScript.parentNode;
var out=root.querySelector('pre.picks'), info=root.querySelector('.info');
var count=root.querySelector('.npicks'), cfg=JSON.parse(root.getAttribute('data-diagram'));
function num(x){x=+x;if(!isFinite(x))return 'nan';var s=String(x);
 return /[.eEn]/.test(s)?s:s+'.0';}
(function(){
 var d=JSON.parse(root.querySelector('script.stab-poles').textContent);
 var g=root.querySelector('g.diagram-poles'),NS='http://www.w3.org/2000/svg',oi={};
 d.orders.forEach(function(o,k){oi[o]=k;});
 for(var j=0;j<d.f.length;j++){var c=document.createElementNS(NS,'circle');
  c.setAttribute('class','pole s'+d.s[j]);
  c.setAttribute('cx',(d.x0+(d.f[j]-d.lo)/(d.hi-d.lo)*d.pw).toFixed(1));
  c.setAttribute('cy',(d.y0-(oi[d.o[j]]+0.5)*d.row).toFixed(1));c.setAttribute('r','2.6');
  c.setAttribute('data-freq-hz',d.f[j]);c.setAttribute('data-zeta',d.z[j]);
  c.setAttribute('data-order',d.o[j]);c.setAttribute('data-mpc',d.m[j]);
  c.setAttribute('data-group',d.g[j]);c.setAttribute('data-stable',d.s[j]===3?'1':'0');
  g.appendChild(c);}
})();
function poles(){return Array.prototype.slice.call(root.querySelectorAll('.pole'));}
function text(){
 var sel=poles().filter(function(p){return p.classList.contains('selected');});
 sel.sort(function(a,b){return a.dataset.freqHz-b.dataset.freqHz;});
 var t=['# ema-pipeline picks: `ema-pipeline identify FILE --picks THIS_FILE` fits exactly',
  '# these poles (refinement, LSFD and uncertainty as for automatic modes).',
  '# A pick with `order` is the pole of that model order nearest to freq_hz',
  '# (within 0.1 %); a pick with `pole` (rad/s) is the start pole of a mode the',
  '# automatic selection kept, taken as given.','',
  '[diagram]  # the settings that reproduce the stabilization diagram',
  'band_hz = ['+num(cfg.band_hz[0])+', '+num(cfg.band_hz[1])+']',
  'orders = ['+cfg.orders.join(', ')+']','weighting = "'+cfg.weighting+'"'];
 if(cfg.companions.length&&sel.every(function(p){return p.dataset.kind==='mode';})){
  t.push('# poles fitted alongside the picks, not reported: candidates the automatic',
   '# selection refined with its modes and then dropped (rad/s)',
   'companions = ['+cfg.companions.map(function(c){return '['+num(c[0])+', '+num(c[1])+
   ']';}).join(', ')+']');}
 sel.forEach(function(p){
  t.push('','[[pick]]','freq_hz = '+num(p.dataset.freqHz),'zeta = '+num(p.dataset.zeta));
  if(p.dataset.kind==='mode'){t.push('pole = ['+num(p.dataset.poleRe)+', '+
    num(p.dataset.poleIm)+']');}
  else{t.push('order = '+p.dataset.order);}
 });
 out.textContent=t.join('\n')+'\n';
 count.textContent=sel.length;
}
function describe(p){
 return (p.dataset.kind==='mode'?'mode pole':'order '+p.dataset.order)+': f = '+
  (+p.dataset.freqHz).toFixed(3)+' Hz, zeta = '+(100*p.dataset.zeta).toFixed(3)+
  ' %, MPC = '+(+p.dataset.mpc).toFixed(3)+(p.dataset.stable==='1'?' (stable)':'');
}
poles().forEach(function(p){
 p.addEventListener('mouseover',function(){info.textContent=describe(p);
  if(!p.firstChild){var t=document.createElementNS('http://www.w3.org/2000/svg','title');
   t.textContent=describe(p);p.appendChild(t);}});
 p.addEventListener('click',function(){
  if(p.classList.contains('selected')){p.classList.remove('selected');}
  else{poles().forEach(function(q){if(q.dataset.group===p.dataset.group)
    q.classList.remove('selected');});p.classList.add('selected');}
  info.textContent=(p.classList.contains('selected')?'picked ':'unpicked ')+describe(p);
  text();
 });
});
root.querySelector('.copy-picks').addEventListener('click',function(){
 var s=out.textContent;
 function fallback(){var a=document.createElement('textarea');a.value=s;
  document.body.appendChild(a);a.select();try{document.execCommand('copy');}catch(e){}
  document.body.removeChild(a);}
 if(navigator.clipboard&&navigator.clipboard.writeText){
  navigator.clipboard.writeText(s).catch(fallback);}else{fallback();}
});
root.querySelector('.download-picks').addEventListener('click',function(){
 var a=document.createElement('a');
 a.href=URL.createObjectURL(new Blob([out.textContent],{type:'application/toml'}));
 a.download=cfg.file;document.body.appendChild(a);a.click();document.body.removeChild(a);
});
text();
})();"""


def _stability(flags: np.ndarray) -> np.ndarray:
    """0 unstable, 1 stable f, 2 stable f and zeta, 3 stable f, zeta and vector."""
    fl = flags.astype(int)
    return np.where((fl & STABLE_ALL) == STABLE_ALL, 3,
                    np.where(fl & STABLE_DAMP, 2, np.where(fl & STABLE_FREQ, 1, 0)))


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


def stab_diagram_html(frf: FRFSet, result: IdentificationResult, *,
                      picks_id: str = "picks", file_name: str = "picks.toml") -> str:
    """The interactive diagram of ``result`` (identified from ``frf``, the FRF
    set it was given) with its ``<pre id="picks_id">`` picks file; empty
    without a diagram (sdypy backend).

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

    def y_of(o: np.ndarray) -> np.ndarray:
        k = np.searchsorted(orders, o)
        return _TOP + ph - (k + 0.5) * row

    parts = [f'<svg class="stab" viewBox="0 0 {_W:g} {_H:g}" role="img" '
             'aria-label="Interactive stabilization diagram">',
             f'<rect x="{_LEFT}" y="{_TOP}" width="{pw}" height="{ph}" fill="none" '
             'stroke="#999"/>']
    for tick in np.linspace(lo, hi, 9):
        parts.append(f'<text x="{x_of(tick):.1f}" y="{_H - _BOTTOM + 14}" '
                     f'text-anchor="middle">{tick:.4g}</text>')
    parts.append(f'<text x="{_LEFT + pw / 2}" y="{_H - 4}" text-anchor="middle">'
                 "natural frequency / Hz</text>")
    for o in orders[:: max(1, orders.size // 8)]:
        parts.append(f'<text x="{_LEFT - 4}" y="{y_of(o) + 4:.1f}" text-anchor="end">'
                     f"{int(o)}</text>")
    y_modes = _TOP + 0.7 * row
    parts.append(f'<text x="{_LEFT - 4}" y="{y_modes + 4:.1f}" text-anchor="end">modes</text>')
    parts.append(f'<text x="12" y="{_TOP + ph / 2:.1f}" transform="rotate(-90 12 '
                 f'{_TOP + ph / 2:.1f})" text-anchor="middle">model order</text>')
    level = _stability(stab.flags)
    inside = np.flatnonzero(np.isfinite(stab.freq_hz) & np.isfinite(stab.zeta)
                            & (stab.freq_hz >= lo) & (stab.freq_hz <= hi))
    # the diagram's poles as compact columns; the page's script makes them
    # circle.pole elements (the static figure beside it is the no-script view)
    columns = {
        "f": _join(stab.freq_hz[inside], "{:.7g}"),
        "z": _join(stab.zeta[inside], "{:.4g}"),
        "o": _join(stab.order[inside], "{:d}"),
        "m": _join(np.nan_to_num(mpc_d[inside]), "{:.2f}"),
        "g": _join(stab.cluster[inside], "{:d}"),
        "s": _join(level[inside], "{:d}"),
    }
    frame = {"lo": float(lo), "hi": float(hi), "x0": _LEFT, "pw": pw, "y0": _TOP + ph,
             "row": row, "orders": [int(o) for o in orders]}
    data = ("{" + ",".join(f'"{k}":{v}' for k, v in columns.items()) + ","
            + json.dumps(frame)[1:])
    parts.append('<g class="diagram-poles"></g>')
    groups = _mode_groups(result, f_mode)
    for k, p in enumerate(start):
        cx, r = float(x_of(f_mode[k])), 5.0
        pts = f"{cx:.1f},{y_modes - r:.1f} {cx + r:.1f},{y_modes:.1f} " \
              f"{cx:.1f},{y_modes + r:.1f} {cx - r:.1f},{y_modes:.1f}"
        parts.append(
            f'<polygon class="pole mode selected" points="{pts}" '
            f'data-kind="mode" data-freq-hz="{float(f_mode[k])!r}" '
            f'data-zeta="{float(z_mode[k])!r}" '
            f'data-order="{o_max}" data-mpc="{mpc_m[k]:.3f}" data-group="{groups[k]}" '
            f'data-stable="1" data-pole-re="{float(p.real)!r}" '
            f'data-pole-im="{float(p.imag)!r}"/>')
    parts.append("</svg>")
    cfg = json.dumps({"band_hz": [float(lo), float(hi)],
                      "orders": [int(o) for o in picks.orders],
                      "weighting": picks.weighting, "file": file_name,
                      "companions": [[c.real, c.imag] for c in picks.companions]})
    picked = (" This result was fitted from picks (<code>--picks</code>): every mode is "
              "picked." if is_picked(result) else "")
    return (
        f'{_CSS}<div class="stabd" data-diagram="{esc(cfg)}">'
        '<p class="muted">Click a pole to pick or unpick it (one pole per mode: a pole of '
        "a picked trajectory moves the pick); diamonds on top are the start poles of the "
        "modes kept automatically. Grey: unstable; orange: stable f; blue: f and zeta; "
        "green: f, zeta and vector. The picks file below reproduces the selection with "
        f"<code>ema-pipeline identify FILE --picks {esc(file_name)}</code>.{picked}</p>"
        + "".join(parts)
        + '<p class="info"></p><p><span class="npicks">0</span> poles picked '
        '<button type="button" class="copy-picks">Copy picks</button> '
        '<button type="button" class="download-picks">Download picks</button></p>'
        f'<pre class="picks" id="{esc(picks_id)}">{esc(picks.toml())}</pre>'
        f'<script type="application/json" class="stab-poles">{data}</script>'
        f"<script>{_SCRIPT}</script></div>"
    )
