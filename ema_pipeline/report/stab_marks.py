"""The marks, axes and legend of the interactive stabilization diagram
(:mod:`.stab_diagram`).

Every pole of the diagram is drawn as its stability symbol, as PolyMAX
charts draw them, each in its colour (:data:`STABILITY`, from the flags of
:class:`~ema_pipeline.identification.result.StabilizationData`): ``o`` not
stable in frequency (new or unstable), ``f`` stable in frequency only, ``d``
in frequency and damping, ``v`` in frequency and vector (the participation
vector's MAC), ``s`` in all three. A pole is never stable in damping or vector
without being stable in frequency. The legend draws each mark as the diagram
does (the same SVG element and class), every stability symbol drawn and every
other kind of mark (a picked pole, a kept mode picked or not, the previewed
pole's ring, the two curves).

The axes' ticks are round: the frequency's and the model order's 1, 2 or 5
times a power of ten apart (:func:`.svg.nice_step`; the frequency axis is
redrawn by the page's script at every zoom, from :func:`frequency_steps`),
the amplitude's (the sum of |H|, log scale) the decades, or 1, 2 and 5 times
them within less than two decades (:func:`.svg.log_ticks`). Each tick label
is a ``text`` element with ``data-axis-tick``, ``data-axis`` (``frequency``,
``order`` or ``amplitude``) and ``data-value`` (its value).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

import numpy as np

from ema_pipeline.identification.result import STABLE_ALL, STABLE_DAMP, STABLE_FREQ, STABLE_VECTOR
from ema_pipeline.report.htmlparts import esc
from ema_pipeline.report.svg import log_ticks, nice_steps, nice_ticks

__all__ = ["FREQUENCY_PARTS", "MARKS_CSS", "STABILITY", "amplitude_axis", "frequency_steps",
           "legend_html", "order_axis", "stability_symbols"]

#: Stability symbol -> (what it means, its colour), in the legend's order.
STABILITY = {
    "o": ("new or unstable (not stable in frequency)", "#8a8a8a"),
    "f": ("stable frequency", "#e08214"),
    "d": ("stable frequency and damping", "#8c510a"),
    "v": ("stable frequency and vector", "#1f77b4"),
    "s": ("stable frequency, damping and vector", "#2e8b3a"),
}
#: The frequency axis has at most this many steps between ticks.
FREQUENCY_PARTS = 7
_ORDER_PARTS = 7

#: The marks' look (the diagram's and the legend's).
MARKS_CSS = "".join(f".stabd .st-{k}{{fill:{c}}}" for k, (_, c) in STABILITY.items()) + """
.stabd text.pole,.stabd .legend text{text-anchor:middle;dominant-baseline:central;
font-family:monospace;font-weight:bold}
.stabd text.selected{fill:#d00000;font-size:1.6em;paint-order:stroke;stroke:#fff;stroke-width:2px}
.stabd .mode{fill:#7a3e9d;stroke:#7a3e9d;stroke-width:.7}
.stabd .mode.selected{fill:#ff4040;stroke:#c00000;stroke-width:2.4}
.stabd .previewed{fill:none;stroke:#000;stroke-width:1.3;pointer-events:none}
.stabd .frf-overlay{fill:none;stroke:#555;stroke-width:.8;opacity:.55;pointer-events:none}
.stabd .synthesis{fill:none;stroke:#d62728;stroke-width:.9;stroke-dasharray:4 2;opacity:.8;
pointer-events:none}
.stabd .amplitude{fill:#666}
"""


def stability_symbols(flags: np.ndarray) -> np.ndarray:
    """The stability symbol of each pole (a key of :data:`STABILITY`) from its
    flags (``STABLE_FREQ``, ``STABLE_DAMP``, ``STABLE_VECTOR``).

    Examples
    --------
    >>> stability_symbols(np.array([0, 1, 3, 5, 7])).tolist()
    ['o', 'f', 'd', 'v', 's']
    """
    fl = np.asarray(flags).astype(int)
    return np.select(
        [fl & STABLE_FREQ == 0, fl & STABLE_ALL == STABLE_ALL, fl & STABLE_DAMP > 0,
         fl & STABLE_VECTOR > 0], ["o", "s", "d", "v"], "f")


def frequency_steps(lo_hz: float, hi_hz: float, narrowest_hz: float) -> list[float]:
    """The steps the page's script chooses the frequency ticks from, for every
    range from ``narrowest_hz`` wide to the band [lo_hz, hi_hz]: the first at
    least the range over :data:`FREQUENCY_PARTS` is :func:`.svg.nice_step`'s.

    Examples
    --------
    >>> frequency_steps(5.0, 1024.0, 1.019)[-3:]
    [50.0, 100.0, 200.0]
    """
    return nice_steps(narrowest_hz, hi_hz - lo_hz, FREQUENCY_PARTS)


def _tick(axis: str, value: float, x: float, y: float, anchor: str, label: str,
          cls: str = "") -> str:
    c = f' class="{cls}"' if cls else ""
    return (f'<text x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}" dominant-baseline="central"'
            f'{c} data-axis-tick="" data-axis="{axis}" data-value="{value!r}">{label}</text>')


def order_axis(orders: np.ndarray, y_of: Callable[[float], float], x: float) -> str:
    """The model order's ticks (round values within the orders, placed between
    the rows of the orders around them, :func:`.svg.nice_ticks` with
    :func:`.svg.nice_step` for 7 parts) left of ``x``, with their marks.

    Examples
    --------
    >>> axis = order_axis(np.arange(2, 256, 6), lambda o: 400.0 - o, 48.0)
    >>> [float(v.split('"')[0]) for v in axis.split('data-value="')[1:]]
    [50.0, 100.0, 150.0, 200.0, 250.0]
    """
    o = np.asarray(orders, dtype=float)
    values = nice_ticks(float(o[0]), float(o[-1]), _ORDER_PARTS + 1) if o.size > 1 else o
    parts = []
    for v in values:
        y = y_of(float(v))
        parts.append(f'<path class="tick" d="M{x - 4:.1f} {y:.1f}h4"/>'
                     + _tick("order", float(v), x - 6, y, "end", f"{v:g}"))
    return "".join(parts)


def _power_label(value: float) -> str:
    """A tick label of a log axis: plain between 0.01 and 10000, else
    ``m·10`` with the exponent raised."""
    if 1e-2 <= value < 1e4:
        return f"{value:g}"
    k = math.floor(math.log10(value) + 1e-9)
    m = round(value / 10.0**k, 6)
    return (f"{m:g}·" if m != 1 else "") + f'10<tspan dy="-5" font-size="8">{k}</tspan>'


def amplitude_axis(lmin: float, lmax: float, y_of: Callable[[float], float], x: float) -> str:
    """The sum of |H|'s ticks (log scale, the curve from 10**lmin to
    10**lmax) right of ``x``, with their marks.

    Examples
    --------
    >>> axis = amplitude_axis(-3.2, 0.4, lambda l: 100.0 - 10 * l, 800.0)
    >>> [float(v.split('"')[0]) for v in axis.split('data-value="')[1:]]
    [0.001, 0.01, 0.1, 1.0]
    """
    if not lmax > lmin:
        return ""
    parts = []
    for v in log_ticks(10.0**lmin, 10.0**lmax)[0]:
        y = y_of(math.log10(float(v)))
        parts.append(f'<path class="tick" d="M{x:.1f} {y:.1f}h4"/>'
                     + _tick("amplitude", float(v), x + 6, y, "start", _power_label(float(v)),
                             "amplitude"))
    return "".join(parts)


def _entry(key: str, mark: str, text: str) -> str:
    return (f'<span data-legend="{key}"><svg class="mark" viewBox="0 0 16 16" width="16" '
            f'height="16" aria-hidden="true">{mark}</svg>{esc(text)}</span>')


def legend_html(symbols: Iterable[str], n_modes: int) -> str:
    """The legend's entries (``[data-legend]``): the stability ``symbols``
    drawn, then the other marks (kept modes when there are ``n_modes``)."""
    drawn = set(symbols)
    diamond = 'points="8,3 13,8 8,13 3,8"'
    out = [_entry(k, f'<text class="st-{k}" x="8" y="8" font-size="12">{k}</text>',
                  f"{k}: {meaning}") for k, (meaning, _) in STABILITY.items() if k in drawn]
    out.append(_entry("picked", '<text class="st-s selected" x="8" y="8" font-size="9">s</text>',
                      "a picked pole of the diagram (its symbol, red)"))
    if n_modes:
        out.append(_entry("mode", f'<polygon class="mode selected" {diamond}/>',
                          "kept mode, picked (top row, at its refined frequency)"))
        out.append(_entry("mode-unpicked", f'<polygon class="mode" {diamond}/>',
                          "kept mode, unpicked"))
    out.append(_entry("previewed", '<circle class="previewed" cx="8" cy="8" r="6"/>',
                      "the pole in the preview"))
    out.append(_entry("frf", '<path class="frf-overlay" d="M1 8H15" style="opacity:1"/>',
                      "sum of |H| over all channels (log scale, right axis)"))
    out.append(_entry("synthesis", '<path class="synthesis" d="M1 8H15"/>',
                      "the same sum synthesised from the picked poles (residues fitted "
                      "in the page)"))
    return "".join(out)
