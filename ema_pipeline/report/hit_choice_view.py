"""The hit page's "Choose the hits" section: accept or reject each hit by hand.

Each hit with a record carries its auto and cross spectra (force ``Sff``, force x
first response ``Sfx``, response ``Sxx``, on at most :data:`MAX_LINES` lines of the
usable band, windows applied as for the FRFs). The hits are grouped by point of the
test, one element ``[data-hit-choice-point]`` per recording file (one for a plain
recording): its checkboxes (ticked: accepted by the checks) and a plot of every
ticked hit's FRF ``Sfx / Sff`` (grey) over the point's H1 average ``sum Sfx / sum
Sff`` (black) and its coherence ``|sum Sfx|^2 / (sum Sff sum Sxx)``, redrawn as
that point's hits are toggled. One download for the whole test gives the choice as
``hits.toml`` (:mod:`ema_pipeline.io.hit_choice`), which ``ema-pipeline frf ...
--hits hits.toml`` reproduces.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import numpy as np

from ema_pipeline.report.htmlparts import esc

__all__ = ["MAX_LINES", "hit_choice_html"]

#: Most frequency lines per hit in the page (the band is thinned to these).
MAX_LINES = 400

_SCRIPT = r"""
(function(){
var box=document.currentScript.parentNode;
var d=JSON.parse(box.querySelector('.hit-data').textContent);
var W=440,H=150,HC=60,L=50;
var pts=Array.from(box.querySelectorAll('[data-hit-choice-point]'));
function on(el){return Array.from(el.querySelectorAll('input.hit-pick'))
 .map(function(c){return c.checked;});}
function xs(f){var a=d.freq[0],b=d.freq[d.freq.length-1];return L+(W-L-10)*(f-a)/(b-a);}
function line(v,lo,hi,top,h,col,wd){var p=[];
 for(var k=0;k<v.length;k++){if(!isFinite(v[k]))continue;
  var y=top+h-h*(Math.min(Math.max(v[k],lo),hi)-lo)/(hi-lo);
  p.push(xs(d.freq[k]).toFixed(1)+','+y.toFixed(1));}
 return '<polyline fill="none" stroke="'+col+'" stroke-width="'+wd+'" points="'
  +p.join(' ')+'"/>';}
function draw(j){var el=pts[j],pt=d.points[j],c=on(el),n=d.freq.length,m=0,hits=[];
 var sf=new Array(n).fill(0),sr=new Array(n).fill(0),si=new Array(n).fill(0);
 var sx=new Array(n).fill(0);
 pt.hits.forEach(function(h,i){if(!c[i]||!h.sff)return;m++;var db=[];
  for(var k=0;k<n;k++){sf[k]+=h.sff[k];sr[k]+=h.sfr[k];si[k]+=h.sfi[k];sx[k]+=h.sxx[k];
   var a=h.sfr[k]*h.sfr[k]+h.sfi[k]*h.sfi[k];db.push(10*Math.log10(a/(h.sff[k]*h.sff[k])));}
  hits.push(db);});
 var avg=[],coh=[];
 for(var k=0;k<n;k++){var a=sr[k]*sr[k]+si[k]*si[k];
  avg.push(10*Math.log10(a/(sf[k]*sf[k])));coh.push(a/(sf[k]*sx[k]));}
 var all=hits.concat([avg]).flat().filter(isFinite);
 var hi=Math.max.apply(null,all),lo=Math.max(Math.min.apply(null,all),hi-80);
 var s='<svg class="fig" viewBox="0 0 '+W+' '+(H+HC+40)+'" width="'+W+'">';
 s+='<text x="4" y="'+(H+10)+'" font-size="10">'+lo.toFixed(0)+'</text>';
 s+='<text x="4" y="32" font-size="10">'+hi.toFixed(0)+'</text>';
 hits.forEach(function(v){s+=line(v,lo,hi,10,H,'#bbb',1);});
 if(m){s+=line(avg,lo,hi,10,H,'#000',2);s+=line(coh,0,1,H+30,HC,'#1f77b4',1.5);}
 s+='<text x="4" y="20" font-size="11">|H| dB</text>';
 s+='<text x="4" y="'+(H+40)+'" font-size="11">coh.</text>';
 s+='<text x="'+L+'" y="'+(H+HC+38)+'" font-size="11">'+d.freq[0].toFixed(0)+' Hz</text>';
 s+='<text x="'+(W-60)+'" y="'+(H+HC+38)+'" font-size="11">'+d.freq[n-1].toFixed(0)
  +' Hz</text></svg>';
 el.querySelector('.hit-plot').innerHTML=s;
 el.querySelector('.hit-count').textContent=m+' of '+pt.hits.length+' hits averaged.';}
function toml(){
 var t='# ema-pipeline hit choice: ema-pipeline frf ... --hits hits.toml\n';
 pts.forEach(function(el,j){var c=on(el),pt=d.points[j],acc=[];
  pt.hits.forEach(function(h,i){if(c[i]&&h.sff)acc.push(h.number);});
  t+='\n[[recording]]\nfile = '+JSON.stringify(pt.file)+'\naccepted = ['+acc.join(', ')+']\n';});
 box.querySelector('.hit-toml').textContent=t;}
pts.forEach(function(el,j){el.addEventListener('change',function(){draw(j);toml();});
 draw(j);});
toml();
box.querySelector('.hit-download').addEventListener('click',function(){
 var b=new Blob([box.querySelector('.hit-toml').textContent],{type:'text/plain'});
 var a=document.createElement('a');a.href=URL.createObjectURL(b);
 a.download='hits.toml';document.body.appendChild(a);a.click();a.remove();});
})();
"""


def _round(values: np.ndarray) -> list[float]:
    return [float(f"{v:.6g}") for v in np.asarray(values, dtype=float)]


def hit_choice_html(hits: Sequence[Any], freq_hz: np.ndarray, band_hz: tuple[float, float]
                    ) -> str:
    """The section's HTML: per point (file) its checkboxes and plot; the choice of
    the whole test as TOML and its download.

    ``hits``: the page's :class:`~ema_pipeline.report.hits_page.HitView` (``spectra``
    = (Sff, Sfx, Sxx) on ``freq_hz`` for a hit with a record, else None; ``file`` and
    ``number`` name it, ``point`` heads its file's group); the lines shown are those
    up to 1.2 times the top of the usable ``band_hz``, thinned to :data:`MAX_LINES`.
    Empty when no hit has spectra.
    """
    if not any(getattr(v, "spectra", None) is not None for v in hits):
        return ""
    f = np.asarray(freq_hz, dtype=float)
    keep = np.flatnonzero((f > 0) & (f <= max(1.2 * band_hz[1], f[min(8, f.size - 1)])))
    keep = keep[:: max(1, int(np.ceil(keep.size / MAX_LINES)))]
    points: dict[str, list[Any]] = {}
    for v in hits:
        points.setdefault(v.file, []).append(v)
    data: dict[str, Any] = {"freq": _round(f[keep]), "points": []}
    groups = []
    for file, views in points.items():
        entries, boxes = [], []
        for k, v in enumerate(views):
            entry: dict[str, Any] = {"number": v.number or v.hit.index}
            if v.spectra is not None:
                sff, sfx, sxx = v.spectra
                entry.update(sff=_round(sff[keep]), sfr=_round(sfx[keep].real),
                             sfi=_round(sfx[keep].imag), sxx=_round(sxx[keep]))
            entries.append(entry)
            state = " checked" if v.hit.accepted and v.spectra is not None else ""
            off = "" if v.spectra is not None else " disabled"
            boxes.append(f'<label style="margin-right:1em;white-space:nowrap"><input '
                         'type="checkbox" '
                         f'class="hit-pick" data-k="{k}"{state}{off}> hit '
                         f"{entry['number']}</label>")
        data["points"].append({"file": file, "hits": entries})
        head = ", ".join(x for x in (file, views[0].point) if x)
        response = (f"FRF to the response {views[0].response_name}."
                    if views[0].response_name else "")
        title = f"<h3>{esc(head)}</h3>" if head else ""
        groups.append(
            f'<div class="hit-choice-point" data-hit-choice-point="{esc(file)}" style="display:'
            'inline-block;vertical-align:top;width:440px;margin:0 1.5em 1em 0">'
            f'{title}<p>{"".join(boxes)}<br><span class="hit-count"></span> {esc(response)}'
            '</p><div class="hit-plot"></div></div>')
    text = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    intro = ("per point (recording file), each ticked hit's FRF (grey) over the point's "
             "H1 average (black) and its coherence (blue), redrawn as you toggle the "
             "point's hits; then download the choice of the whole test"
             if len(points) > 1 else
             "each ticked hit's FRF (grey) over their H1 average (black) and its coherence "
             "(blue), redrawn as you toggle the hits; then download the choice")
    return (
        f'<div class="hit-choice"><p>Tick the hits to average: {intro} and run '
        "<code>ema-pipeline frf ... --hits hits.toml</code>, which reproduces it.</p>"
        + "".join(groups)
        + '<p><button type="button" class="hit-download">Download hits.toml</button></p>'
        '<pre class="hit-toml"></pre>'
        f'<script type="application/json" class="hit-data">{text}</script>'
        f"<script>{_SCRIPT}</script></div>"
    )
