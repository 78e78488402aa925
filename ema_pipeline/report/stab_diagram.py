"""The interactive stabilization diagram of the report pages: pick the modes by hand.

Inline SVG and a little JavaScript, nothing loaded from outside the page.
The page holds the diagram's poles as compact columns of numbers (a JSON
``script.stab-poles``, about 30 bytes a pole, so that a study report with
three diagrams stays small); its script makes every pole of the stored
diagram a ``circle.pole`` element carrying
``data-freq-hz`` (natural frequency, window-corrected), ``data-zeta``,
``data-order`` (model order), ``data-mpc`` (MPC of the pole's one-pole local
fit, :func:`ema_pipeline.identification.selection.picks.pole_mpc`), ``data-group`` (its
trajectory: the poles of one mode) and ``data-stable`` (``1`` when stable in
frequency, damping and vector). Every mode the automatic selection kept is
drawn as a diamond in the top row ("modes") at its refined frequency (the
tables', ``data-x-hz``), with ``data-kind="mode"`` and its start pole
(:attr:`StabilizationData.mode_pole`: ``data-freq-hz``, ``data-zeta`` and the
exact ``data-pole-re``, ``data-pole-im``, rad/s, which the picks file gives);
these carry ``selected`` when the page opens.

The sum of |H| over all channels in the band (:func:`.figures.sum_abs_frf`) is
drawn under the poles on a log scale (``path[data-frf-overlay]``; its log10
at every line, or the largest of each run of lines above 2000, one character
a value in 32768 levels from the smallest to the largest). The wheel,
a drag and the buttons ``[data-zoom-in]``, ``[data-zoom-out]`` and
``[data-zoom-reset]`` zoom and pan the frequency axis; the range shown is kept
in ``data-x-min-hz`` / ``data-x-max-hz`` of the ``[data-diagram]`` element and
the tick labels (``[data-axis-tick]``) are redrawn in 1-2-5 steps. The legend
lists only the stability classes drawn. Over the sum FRF, ``path[data-synthesis]``
is the same sum synthesised from the picked poles, refitted in the page
whenever a pole is picked or unpicked (:mod:`.synthesis_view`).

Hovering a pole shows f, zeta, MPC and its order (in the line under the
diagram and as the pole's tooltip); clicking it also fills ``[data-pole-preview]``
with these values and, for a kept mode, its real-normalised shape by DOF
(``svg[data-shape]``; not for shapes of fewer than
:data:`~.shape_views.MIN_SHAPE_DOFS` points, where a sentence says so) and,
where the page animates the shapes on a geometry, a button
(``[data-show-shape]``) that brings that mode's view into sight. Clicking a
pole toggles it; a mode has one pole, so clicking another pole of the same trajectory
moves the pick there. The element ``#picks`` always holds the picks file
of the current selection, with a copy and a download button:
``ema-pipeline identify FILE --picks picks.toml`` fits exactly those poles.
The script writes it (when the page opens and at every click) in the layout
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

from ema_pipeline.data import FRFSet
from ema_pipeline.identification.result import (
    STABLE_ALL,
    STABLE_DAMP,
    STABLE_FREQ,
    IdentificationResult,
)
from ema_pipeline.identification.selection.picks import is_picked, picks_from_result, pole_mpc
from ema_pipeline.report.figures import sum_abs_frf
from ema_pipeline.report.htmlparts import esc
from ema_pipeline.report.result_tables import label_as_tested
from ema_pipeline.report.shape_views import MIN_SHAPE_DOFS, shape_dof_count
from ema_pipeline.report.synthesis_view import CODE_0, SYNTHESIS_JS, synthesis_data

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
.stabd svg.stab{cursor:grab;touch-action:none}.stabd svg.stab.dragging{cursor:grabbing}
.stabd .frf-overlay{fill:none;stroke:#555;stroke-width:.8;opacity:.55;pointer-events:none}
.stabd .synthesis{fill:none;stroke:#d62728;stroke-width:.9;stroke-dasharray:4 2;opacity:.8;
pointer-events:none}
.stabd .legend span{margin-right:1.2em;white-space:nowrap}
.stabd .legend i{display:inline-block;width:.7em;height:.7em;border-radius:50%;margin-right:.3em}
.stabd .preview{border:1px solid #ccc;padding:.3em .6em;margin:.3em 0;font-size:.9em}
.stabd .preview svg{max-width:520px}
@media print{.stabd button,.stabd pre.picks,.stabd .zoom{display:none}}
</style>"""

#: The levels of the overlay's characters (15 bits, from synthesis_view.CODE_0).
CURVE_LEVELS = 32767

_SCRIPT = (r"""(function(){""" + SYNTHESIS_JS
           + f"var CURVE_LEVELS={CURVE_LEVELS};" + r"""
var root=document.currentScript.parentNode;
var out=root.querySelector('pre.picks'), info=root.querySelector('.info');
var count=root.querySelector('.npicks'), cfg=JSON.parse(root.getAttribute('data-diagram'));
var svg=root.querySelector('svg.stab'), NS='http://www.w3.org/2000/svg';
var preview=root.querySelector('[data-pole-preview]');
var d=JSON.parse(root.querySelector('script.stab-poles').textContent);
d.fl=Array.prototype.map.call(d.fl,function(c){
 return d.lmin+(c.charCodeAt(0)-CODE0)/CURVE_LEVELS*(d.lmax-d.lmin);});
var lo=d.lo, hi=d.hi, view=[lo,hi], dragged=false, SL=null;
function num(x){x=+x;if(!isFinite(x))return 'nan';var s=String(x);
 return /[.eEn]/.test(s)?s:s+'.0';}
(function(){
 var g=root.querySelector('g.diagram-poles'),oi={};
 d.orders.forEach(function(o,k){oi[o]=k;});
 for(var j=0;j<d.f.length;j++){var c=document.createElementNS(NS,'circle');
  c.setAttribute('class','pole s'+d.s[j]);
  c.setAttribute('cy',(d.y0-(oi[d.o[j]]+0.5)*d.row).toFixed(1));c.setAttribute('r','2.6');
  c.setAttribute('data-freq-hz',d.f[j]);c.setAttribute('data-zeta',d.z[j]);
  c.setAttribute('data-order',d.o[j]);c.setAttribute('data-mpc',d.m[j]);
  c.setAttribute('data-group',d.g[j]);c.setAttribute('data-stable',d.s[j]===3?'1':'0');
  g.appendChild(c);}
})();
function xof(f){return d.x0+(f-view[0])/(view[1]-view[0])*d.pw;}
function fof(x){return view[0]+(x-d.x0)/d.pw*(view[1]-view[0]);}
function ticks(a,b){var raw=(b-a)/7,mag=Math.pow(10,Math.floor(Math.log10(raw))),step=mag;
 [1,2,5,10].some(function(m){step=m*mag;return m*mag>=raw*0.999;});
 var dec=Math.max(0,-Math.floor(Math.log10(step)+1e-9)),t=[];
 for(var v=Math.ceil(a/step-1e-9)*step;v<=b+step*1e-6;v+=step){t.push(v.toFixed(dec));}
 return t;}
function draw(){
 root.setAttribute('data-x-min-hz',view[0]);root.setAttribute('data-x-max-hz',view[1]);
 root.querySelectorAll('circle.pole').forEach(function(c){var f=+c.dataset.freqHz;
  c.setAttribute('cx',xof(f).toFixed(1));
  c.style.display=(f<view[0]||f>view[1])?'none':'';});
 root.querySelectorAll('polygon.pole').forEach(function(p){var f=+p.dataset.xHz,
  cx=xof(f),y=+p.dataset.y,r=5;
  p.setAttribute('points',[cx,y-r,cx+r,y,cx,y+r,cx-r,y].map(function(v){
   return v.toFixed(1);}).join(' '));
  p.style.display=(f<view[0]||f>view[1])?'none':'';});
 var tg=root.querySelector('g.ticks');tg.textContent='';
 ticks(view[0],view[1]).forEach(function(t){var e=document.createElementNS(NS,'text');
  e.setAttribute('x',xof(+t).toFixed(1));e.setAttribute('y',d.y0+14);
  e.setAttribute('text-anchor','middle');e.setAttribute('data-axis-tick',t);
  e.textContent=t;tg.appendChild(e);
  var l=document.createElementNS(NS,'path');
  l.setAttribute('d','M'+xof(+t).toFixed(1)+' '+d.y0+'v4');l.setAttribute('stroke','#999');
  tg.appendChild(l);});
 curve(root.querySelector('[data-frf-overlay]'),d.fl.length?d.fl:null);
 curve(root.querySelector('[data-synthesis]'),SL);
}
function curve(el,vals){var pts=[];
 if(el&&vals){var n=vals.length,
  a=Math.max(0,Math.floor((view[0]-d.f0)/d.df)),b=Math.min(n-1,Math.ceil((view[1]-d.f0)/d.df));
  for(var k=a;k<=b;k++){pts.push((k===a?'M':'L')+
   Math.min(d.x0+d.pw,Math.max(d.x0,xof(d.f0+k*d.df))).toFixed(1)+' '+
   Math.min(d.y0,Math.max(d.y0-d.oh,d.y0-(vals[k]-d.lmin)/(d.lmax-d.lmin||1)*d.oh)).toFixed(1));}}
 if(el){el.setAttribute('d',pts.join(''));}}
function lambdas(sel){
 var l=sel.map(function(p){var m=p.dataset.kind==='mode',
  w=2*Math.PI*(m?p.dataset.xHz:p.dataset.freqHz),z=+(m?p.dataset.zetaFit:p.dataset.zeta);
  return [-z*w-d.sy.wdr,w*Math.sqrt(Math.max(0,1-z*z))];});
 if(cfg.companions.length&&sel.every(function(p){return p.dataset.kind==='mode';})){
  l=l.concat(cfg.companions);}
 return l.filter(function(x){return isFinite(x[0])&&isFinite(x[1])&&x[1]>0;});}
function resynth(){
 SL=d.sy&&d.sy.n?synthesis(lambdas(poles().filter(function(p){
  return p.classList.contains('selected');}))):null;}
function setView(a,b){var w=Math.max(b-a,(hi-lo)*1e-3);
 w=Math.min(w,hi-lo);if(a<lo){a=lo;}if(a+w>hi){a=hi-w;}view=[a,a+w];draw();}
function zoom(factor,center){var c=center===undefined?(view[0]+view[1])/2:center;
 setView(c-(c-view[0])*factor,c-(c-view[0])*factor+(view[1]-view[0])*factor);}
function svgx(ev){var r=svg.getBoundingClientRect();
 return (ev.clientX-r.left)*svg.viewBox.baseVal.width/r.width;}
root.querySelector('[data-zoom-in]').addEventListener('click',function(){zoom(0.5);});
root.querySelector('[data-zoom-out]').addEventListener('click',function(){zoom(2);});
root.querySelector('[data-zoom-reset]').addEventListener('click',function(){setView(lo,hi);});
svg.addEventListener('wheel',function(ev){ev.preventDefault();
 var x=svgx(ev);if(x<d.x0||x>d.x0+d.pw)return;
 zoom(ev.deltaY<0?0.8:1.25,fof(x));},{passive:false});
var drag=null;
svg.addEventListener('mousedown',function(ev){dragged=false;
 drag={x:svgx(ev),view:view.slice()};});
window.addEventListener('mousemove',function(ev){if(!drag)return;var dx=svgx(ev)-drag.x;
 if(Math.abs(dx)>4){dragged=true;svg.classList.add('dragging');}
 if(dragged){var df=dx/d.pw*(drag.view[1]-drag.view[0]);
  setView(drag.view[0]-df,drag.view[1]-df);}});
window.addEventListener('mouseup',function(){drag=null;svg.classList.remove('dragging');});
resynth();draw();
function poles(){return Array.prototype.slice.call(root.querySelectorAll('.pole'));}
function text(){
 var sel=poles().filter(function(p){return p.classList.contains('selected');});
 sel.sort(function(a,b){return a.dataset.freqHz-b.dataset.freqHz;});
 var t=['# ema-pipeline picks: `ema-pipeline identify FILE --picks THIS_FILE` fits exactly',
  '# these poles (refinement, LSFD and uncertainty as for automatic modes).',
  '# A pick with `order` is the pole of that model order nearest to freq_hz',
  '# (within 0.1 %); a pick with `pole` (rad/s) is the start pole of a mode the',
  '# automatic selection kept, taken as given.','version = 1','',
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
 var m=p.dataset.kind==='mode';
 return (m?'mode '+p.dataset.mode:'order '+p.dataset.order)+': f = '+
  (+(m?p.dataset.xHz:p.dataset.freqHz)).toFixed(3)+' Hz, ζ = '+
  (100*(m?p.dataset.zetaFit:p.dataset.zeta)).toFixed(3)+
  ' %, MPC = '+(+p.dataset.mpc).toFixed(3)+(p.dataset.stable==='1'&&!m?' (stable)':'');
}
function showPreview(p){
 preview.hidden=false;preview.textContent='';
 var h=document.createElement('p');h.setAttribute('data-preview-freq-hz',
  p.dataset.kind==='mode'?p.dataset.xHz:p.dataset.freqHz);
 h.textContent=describe(p);preview.appendChild(h);
 var sh=p.dataset.kind==='mode'?d.shapes[+p.dataset.mode-1]:null;
 if(!sh){var q=document.createElement('p');q.className='muted';
  q.textContent=d.noshape||('The shape is known for the kept modes (diamonds): pick '+
   'this pole and fit the picks to see its shape.');preview.appendChild(q);return;}
 var n=sh.length,W=520,H=120,bw=(W-40)/n,s=document.createElementNS(NS,'svg');
 s.setAttribute('viewBox','0 0 '+W+' '+H);s.setAttribute('data-shape','');
 s.setAttribute('role','img');s.setAttribute('aria-label','real-normalised shape by DOF');
 var z=document.createElementNS(NS,'path');z.setAttribute('d','M30 60H'+(W-10));
 z.setAttribute('stroke','#999');s.appendChild(z);
 var every=Math.max(1,Math.ceil(n*40/(W-40)));
 sh.forEach(function(v,k){var r=document.createElementNS(NS,'rect'),x=30+k*bw;
  r.setAttribute('x',(x+bw*0.15).toFixed(1));r.setAttribute('width',(bw*0.7).toFixed(1));
  r.setAttribute('y',(60-Math.max(v,0)*50).toFixed(1));
  r.setAttribute('height',(Math.abs(v)*50).toFixed(1));r.setAttribute('fill','#1f4e79');
  s.appendChild(r);
  if(k%every===0){var t=document.createElementNS(NS,'text');t.setAttribute('x',
   (x+bw/2).toFixed(1));t.setAttribute('y',H-2);t.setAttribute('text-anchor','middle');
   t.setAttribute('font-size','9');t.textContent=d.dofs[k];s.appendChild(t);}});
 preview.appendChild(s);
 var view=Array.prototype.find.call(document.querySelectorAll('figure.shape-view'),
  function(v){return v.dataset.modeShape===p.dataset.mode;});
 if(view){var b=document.createElement('button');b.type='button';
  b.setAttribute('data-show-shape',p.dataset.mode);
  b.textContent='Show its shape on the geometry';
  b.addEventListener('click',function(){view.scrollIntoView({block:'center'});
   view.style.outline='3px solid #c00000';
   setTimeout(function(){view.style.outline='';},2500);});
  preview.appendChild(b);}
}
poles().forEach(function(p){
 p.addEventListener('mouseover',function(){info.textContent=describe(p);
  if(!p.firstChild){var t=document.createElementNS('http://www.w3.org/2000/svg','title');
   t.textContent=describe(p);p.appendChild(t);}});
 p.addEventListener('click',function(){
  if(dragged){return;}
  showPreview(p);
  if(p.classList.contains('selected')){p.classList.remove('selected');}
  else{poles().forEach(function(q){if(q.dataset.group===p.dataset.group)
    q.classList.remove('selected');});p.classList.add('selected');}
  info.textContent=(p.classList.contains('selected')?'picked ':'unpicked ')+describe(p);
  text();resynth();draw();
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
})();""")


_CLASSES = {0: "unstable", 1: "stable frequency", 2: "stable frequency and damping",
            3: "stable frequency, damping and shape"}
_COLORS = {0: "#b0b0b0", 1: "#d08b26", 2: "#1f77b4", 3: "#2e8b3a"}
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
    smallest (0) to the largest (:data:`CURVE_LEVELS`): 3 bytes a value and
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

    y_modes = _TOP + 0.7 * row
    level = _stability(stab.flags)
    inside = np.flatnonzero(np.isfinite(stab.freq_hz) & np.isfinite(stab.zeta)
                            & (stab.freq_hz >= lo) & (stab.freq_hz <= hi))
    parts = [f'<svg class="stab" viewBox="0 0 {_W:g} {_H:g}" role="img" '
             'aria-label="Interactive stabilization diagram">',
             f'<rect x="{_LEFT}" y="{_TOP}" width="{pw}" height="{ph}" fill="none" '
             'stroke="#999"/>',
             '<path class="frf-overlay" data-frf-overlay="" d=""/>',
             '<path class="synthesis" data-synthesis="" d=""/>',
             '<g class="ticks"></g>']
    parts.append(f'<text x="{_LEFT + pw / 2}" y="{_H - 4}" text-anchor="middle">'
                 "natural frequency (Hz)</text>")
    for o in orders[:: max(1, orders.size // 8)]:
        parts.append(f'<text x="{_LEFT - 4}" y="{y_of(o) + 4:.1f}" text-anchor="end">'
                     f"{int(o)}</text>")
    parts.append(f'<text x="{_LEFT - 4}" y="{y_modes + 4:.1f}" text-anchor="end">modes</text>')
    parts.append(f'<text x="12" y="{_TOP + ph / 2:.1f}" transform="rotate(-90 12 '
                 f'{_TOP + ph / 2:.1f})" text-anchor="middle">model order</text>')
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
    # the sum FRF of the band on a log scale, under the poles
    f0_sum, df_sum, l_sum = _overlay(sub.freq_hz, sum_abs_frf(sub.H))
    columns["fl"] = json.dumps(_curve_text(l_sum), ensure_ascii=False)
    n_dof = shape_dof_count(frf)
    shapes = _mode_shapes(result, start.size) if n_dof >= MIN_SHAPE_DOFS else []
    frame = {"lo": float(lo), "hi": float(hi), "x0": _LEFT, "pw": pw, "y0": _TOP + ph,
             "row": row, "orders": [int(o) for o in orders],
             "lmin": float(l_sum.min()) if l_sum.size else 0.0,
             "lmax": float(l_sum.max()) if l_sum.size else 1.0,
             "oh": ph - 1.5 * row, "f0": f0_sum, "df": df_sum, "shapes": shapes,
             "dofs": _dof_labels(result, len(shapes[0]) if shapes else 0,
                                 frf.acquisition.response_negative),
             "sy": synthesis_data(sub, s),
             "noshape": "" if n_dof >= MIN_SHAPE_DOFS else
             f"A mode shape of this test has {n_dof} measured point"
             f"{'' if n_dof == 1 else 's'} only: no shape is drawn."}
    data = ("{" + ",".join(f'"{k}":{v}' for k, v in columns.items()) + ","
            + json.dumps(frame, ensure_ascii=False)[1:])
    parts.append('<g class="diagram-poles"></g>')
    groups = _mode_groups(result, f_mode)
    fn_fit = np.asarray(result.modes.fn_hz, dtype=float)
    zeta_fit = np.asarray(result.modes.zeta, dtype=float)
    if fn_fit.size != start.size:
        fn_fit, zeta_fit = f_mode, z_mode
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
            f'data-stable="1" data-pole-re="{float(p.real)!r}" '
            f'data-pole-im="{float(p.imag)!r}"/>')
    parts.append("</svg>")
    cfg = json.dumps({"band_hz": [float(lo), float(hi)],
                      "orders": [int(o) for o in picks.orders],
                      "weighting": picks.weighting, "file": file_name,
                      "companions": [[c.real, c.imag] for c in picks.companions]})
    picked = (" This result was fitted from picks (<code>--picks</code>): every mode is "
              "picked." if is_picked(result) else "")
    present = set(int(v) for v in level[inside])
    legend = "".join(
        f'<span data-legend="{k}"><i style="background:{_COLORS[k]}"></i>{_CLASSES[k]}'
        "</span>" for k in sorted(present))
    legend += ('<span data-legend="mode"><i style="background:#ff4040;border-radius:0">'
               "</i>kept mode, at its refined frequency</span>" if start.size else "")
    legend += ('<span data-legend="frf"><i style="background:#888;height:2px"></i>'
               "sum of |H| over all channels (log scale)</span>"
               '<span data-legend="synthesis"><i style="background:#d62728;height:2px">'
               "</i>the same sum synthesised from the picked poles (residues fitted in "
               "the page)</span>")
    return (
        f'{_CSS}<div class="stabd" data-diagram="{esc(cfg)}">'
        '<p class="muted">Click a pole to pick or unpick it and to see its values (one '
        "pole per mode: a pole of a picked trajectory moves the pick); the diamonds on "
        "top are the kept modes, drawn at the refined frequencies of the tables. Zoom "
        "with the mouse wheel or the buttons, pan by dragging. The picks file below "
        "reproduces the selection with "
        f"<code>ema-pipeline identify FILE --picks {esc(file_name)}</code>.{picked}</p>"
        f'<p class="legend">{legend}</p>'
        '<p class="zoom"><button type="button" data-zoom-in="">Zoom in</button> '
        '<button type="button" data-zoom-out="">Zoom out</button> '
        '<button type="button" data-zoom-reset="">Whole band</button></p>'
        + "".join(parts)
        + '<p class="info"></p><div class="preview" data-pole-preview="" hidden></div>'
        '<p><span class="npicks">0</span> poles picked '
        '<button type="button" class="copy-picks">Copy picks</button> '
        '<button type="button" class="download-picks">Download picks</button></p>'
        f'<pre class="picks" id="{esc(picks_id)}"></pre>'
        f'<script type="application/json" class="stab-poles">{data}</script>'
        f"<script>{_SCRIPT}</script></div>"
    )
