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
from ema_pipeline.report.scripts import page_script

__all__ = ["MAX_LINES", "hit_choice_html"]

#: Most frequency lines per hit in the page (the band is thinned to these).
MAX_LINES = 400

#: The section's script (``hit_choice.js``).
_SCRIPT = page_script("hit_choice.js")


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
