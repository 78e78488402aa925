"""The hit page of ``ema-pipeline frf --report``: every hit, why it was kept or not,
and the averaged FRF.

Presentation only: :class:`HitsPageInput` holds what the page shows, already
computed (:func:`ema_pipeline.pipeline.hit_page.hits_page_input` gathers it); the
page is self-contained HTML with inline SVG figures (:mod:`.svg` reduces every
curve to its per-pixel envelope, so a 16384-sample record costs a few hundred
points). Sections: summary (hits found and averaged, the averages per point,
record length, windows, estimator, the usable band), the hit table (with the
notes), the choice by hand per point (:mod:`.hit_choice_view`), one section per
hit (its verdict with the reasons spelled out, its notes, the force pulse zoomed,
the force spectrum, the first response with its decay and the windows used, the
other responses), the averaged FRF with coherence and the usable band,
provenance (every input with its sha256).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ema_pipeline.acquisition.hits import LEFT_OUT_BY_HAND, NOT_DECAYED_LEVEL, Hit
from ema_pipeline.data import FRFSet
from ema_pipeline.report.figures import COLORS, figure_frf_coherence
from ema_pipeline.report.htmlparts import Page, esc, kv_table, provenance
from ema_pipeline.report.svg import Canvas
from ema_pipeline.report.tables import html_table

__all__ = ["ACCEPTED_TEXT", "LEFT_OUT_TEXT", "REASON_TEXT", "HitView", "HitsPageInput",
           "averages_text", "render_hits_html", "verdict_text"]

#: What each rejection reason means, as the page says it (rules:
#: :mod:`ema_pipeline.acquisition.hits`).
REASON_TEXT = {
    "past_end": "past end: the record would run past the end of the data (or the hit "
                "is the data's first sample)",
    "double_hit": "double hit: a second force pulse in the record (or ripple in the "
                  "force spectrum)",
    "overload": "overload: a channel reaches its full scale or has flat tops (clipped)",
    "not_decayed": "not decayed: the response has not decayed at the record end and no "
                   "exponential window is allowed",
    "low_force": "low force: the force peak is far below the other hits'",
    "outlier": "outlier: pulse width, response per unit force or FRF shape far from "
               "the other hits' (a soft hit is not an outlier)",
}

#: The verdict of a hit that passes every check (the checks of REASON_TEXT).
ACCEPTED_TEXT = ("accepted: passed every check (one force pulse, inside the data, no "
                 "clipping, response decayed, force not far below the other hits, "
                 "pulse and FRF in line with theirs)")

_W = 720
_PANEL_W, _PANEL_H = 170, 150


@dataclass
class HitView:
    """One hit as the page draws it: the :class:`~ema_pipeline.acquisition.hits.Hit`,
    the data of its record (``time_s`` from the recording start; ``force_n``;
    ``response`` (n,) of the first response, ``response_name`` in ``response_unit``;
    shorter when the record runs past the data), the force window and exponential window over those
    samples (ones: none), the force spectrum (``freq_hz``, ``force_db`` re its
    largest line) and the response level at the record end relative to its peak
    (``end_level``); ``file``: the recording it is in (a channel sheet's test; ``""``:
    the page's one recording), with the hit's number within that file ``number``
    (0: ``hit.index``)."""

    hit: Hit
    time_s: np.ndarray
    force_n: np.ndarray
    response: np.ndarray
    response_name: str
    force_window: np.ndarray
    exp_window: np.ndarray
    freq_hz: np.ndarray
    force_db: np.ndarray
    end_level: float
    file: str = ""
    number: int = 0
    #: (Sff, Sfx, Sxx) of the record on ``freq_hz`` (force x first response), for the
    #: choice by hand (:mod:`ema_pipeline.report.hit_choice_view`); None: no record.
    spectra: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    #: The other response channels over the same samples: (name with its unit, data).
    others: tuple[tuple[str, np.ndarray], ...] = ()
    response_unit: str = ""
    #: Every response's level at the record end relative to its peak: (name, level).
    end_levels: tuple[tuple[str, float], ...] = ()
    #: The hits of its file were chosen by hand (``--hits``), not by the checks.
    by_hand: bool = False
    #: What else to know about the hit (its record padded at the front, ...).
    note: str = ""
    #: Its point of the test, as the choice by hand heads it (e.g. ``hammer at 5-Z``).
    point: str = ""


@dataclass
class HitsPageInput:
    """Everything the hit page shows (see the module docstring)."""

    title: str
    source: str
    sha256: str
    frf: FRFSet
    hits: list[HitView]
    n_samples: int
    record_length_s: float
    pretrigger_s: float
    force_window_s: float | None
    exp_window_tau_s: float | None
    estimator: str
    force_band_hz: tuple[float, float]
    keep_all: bool = False
    settings: Mapping[str, str] = field(default_factory=dict)
    #: More input files for the provenance: (role, path, sha256), e.g. a sheet's recordings.
    inputs: tuple[tuple[str, str, str], ...] = ()
    #: What ``source`` is, as the provenance says it.
    source_role: str = "recording"
    version: str = ""
    generated: str = ""


#: The verdict's reason for a hit that passed the checks but was left out by hand.
LEFT_OUT_TEXT = LEFT_OUT_BY_HAND


def verdict_text(hit: Hit, keep_all: bool = False, by_hand: bool = False) -> str:
    """``accepted``, ``kept (--keep-all) despite``, ``kept by hand (--hits)
    despite`` or ``rejected``, then the reasons (a hit that passed every check but
    is not averaged was left out by hand).

    Examples
    --------
    >>> verdict_text(Hit(2, 1.5, 80.0, False, ("double_hit",)))
    'rejected: double hit: a second force pulse in the record (or ripple in the force spectrum)'
    >>> verdict_text(Hit(3, 2.5, 80.0, False), by_hand=True)
    'rejected: left out by hand (--hits); it passed every check'
    """
    if hit.accepted and not hit.reasons:
        return ACCEPTED_TEXT
    if not hit.accepted and not hit.reasons:
        return f"rejected: {LEFT_OUT_TEXT}; it passed every check"
    if hit.accepted:
        state = "kept by hand (--hits) despite" if by_hand else "kept (--keep-all) despite"
    else:
        state = "rejected"

    def text(reason: str) -> str:
        said = REASON_TEXT.get(reason, reason)
        if reason == "overload" and hit.overloaded:
            said += f" (channel {', '.join(hit.overloaded)})"
        return said

    return f"{state}: " + "; ".join(text(r) for r in hit.reasons)


def averages_text(hits: Sequence[HitView]) -> str:
    """How many hits each point (file) averages: one number, or the range over the
    points (``3-4 per point``) when they differ.

    Examples
    --------
    >>> t = np.zeros(4)
    >>> views = [HitView(Hit(k, 0.0, 1.0, k != 2), t, t, t, "a", t, t, t, t, 0.0, file=f)
    ...          for f in ("p1.csv", "p2.csv") for k in (1, 2, 3)]
    >>> averages_text(views[:3]), averages_text(views[:2] + views[3:])
    ('2', '1-2 per point')
    """
    counts: dict[str, int] = {}
    for v in hits:
        counts[v.file] = counts.get(v.file, 0) + int(v.hit.accepted)
    lo, hi = min(counts.values(), default=0), max(counts.values(), default=0)
    if len(counts) < 2:
        return f"{hi}"
    return f"{lo} per point" if lo == hi else f"{lo}-{hi} per point"


def _pulse_panel(c: Canvas, left: float, view: HitView) -> None:
    """The force pulse zoomed: from 2 ms before the hit to 8 ms after it, or 3 ms after
    the last force above 10 % of the peak within 0.1 s (a second pulse shows)."""
    t_ms = (view.time_s - view.hit.time_s) * 1e3
    level = np.abs(view.force_n - np.median(view.force_n))
    late = (t_ms > 0) & (t_ms < 100.0) & (level > 0.1 * level.max())
    stop = max(8.0, float(t_ms[late].max()) + 3.0 if late.any() else 0.0)
    sel = (t_ms >= -2.0) & (t_ms <= stop)
    if sel.sum() < 2:
        sel = np.ones(t_ms.size, dtype=bool)
    f = view.force_n[sel]
    lo, hi = float(min(f.min(), 0.0)), float(f.max())
    pad = 0.05 * (hi - lo or 1.0)
    ax = c.axes((left, 30, _PANEL_W, _PANEL_H), (float(t_ms[sel][0]), float(t_ms[sel][-1])),
                (lo - pad, hi + pad))
    ax.line(t_ms[sel], f, COLORS[0], width=1.0)
    ax.vline(0.0, "#888", dash="4 4")
    ax.frame(xlabel="time from hit / ms", ylabel="force / N", title="force pulse")


def _spectrum_panel(c: Canvas, left: float, view: HitView, band: tuple[float, float]) -> None:
    """The force spectrum (dB re its largest line) with the usable band's limits."""
    f, db = view.freq_hz, view.force_db
    # kHz above 2 kHz: five-digit labels in Hz run together in a 170 px panel
    scale, unit = (1e3, "kHz") if f.size and f[-1] >= 2e3 else (1.0, "Hz")
    lo = max(-60.0, float(np.nanmin(db)) if db.size else -60.0)
    ax = c.axes((left, 30, _PANEL_W, _PANEL_H), (float(f[0]) / scale, float(f[-1]) / scale),
                (lo - 2, 3.0))
    ax.line(f / scale, db, COLORS[0], width=1.0)
    for x, color in zip(band, (COLORS[2], COLORS[1]), strict=True):
        ax.vline(x / scale, color, dash="6 4")
    ax.frame(xlabel=f"frequency / {unit}", ylabel="|F| / dB", title="force spectrum")


def _response_panel(c: Canvas, left: float, view: HitView) -> None:
    """The response over the record with the exponential window (scaled to its peak)
    and the force window."""
    t = view.time_s - view.time_s[0]
    x = view.response
    peak = float(np.abs(x).max()) or 1.0
    ax = c.axes((left, 30, _PANEL_W, _PANEL_H), (0.0, float(t[-1]) or 1.0),
                (-1.1 * peak, 1.1 * peak))
    ax.line(t, x, COLORS[3], width=0.6)
    if np.any(view.exp_window != 1.0):
        ax.line(t, peak * view.exp_window / view.exp_window.max(), COLORS[1], width=1.0,
                dash="6 4")
    if np.any(view.force_window != 1.0):
        ax.line(t, peak * view.force_window, COLORS[2], width=1.0, dash="2 3")
    unit = f" [{view.response_unit}]" if view.response_unit else ""
    ax.frame(xlabel="time in record / s", ylabel=view.response_name[:24 - len(unit)] + unit,
             title="response and windows")


def hit_figure(view: HitView, band: tuple[float, float]) -> str:
    """Three panels of one hit: force pulse, force spectrum, response with windows;
    then a row of three panels per three other response channels (``view.others``)."""
    rows = 1 + (len(view.others) + 2) // 3
    c = Canvas(_W, rows * (30 + _PANEL_H + 48), f"hit {view.hit.index}")
    _pulse_panel(c, 60, view)
    _spectrum_panel(c, 60 + 240, view, band)
    _response_panel(c, 60 + 480, view)
    t = view.time_s - view.time_s[0]
    for k, (name, x) in enumerate(view.others):
        top = (1 + k // 3) * (30 + _PANEL_H + 48) + 30
        peak = float(np.abs(x).max()) or 1.0
        ax = c.axes((60 + 240 * (k % 3), top, _PANEL_W, _PANEL_H),
                    (0.0, float(t[-1]) or 1.0), (-1.1 * peak, 1.1 * peak))
        ax.line(t, x, COLORS[3], width=0.6)
        ax.frame(xlabel="time in record / s", ylabel=name[:24], title="response")
    return c.to_svg()


def _reasons(view: HitView) -> str:
    """The hit table's reasons: the checks', or that the hit was left out by hand."""
    if not view.hit.accepted and not view.hit.reasons:
        return LEFT_OUT_TEXT
    return "; ".join(r.replace("_", " ") for r in view.hit.reasons)


def _hit_table(hits: Sequence[HitView]) -> pd.DataFrame:
    files = {"file": [v.file for v in hits]} if any(v.file for v in hits) else {}
    return pd.DataFrame({
        **files,
        "hit": [v.number or v.hit.index for v in hits],
        "time / s": [f"{v.hit.time_s:.4f}" for v in hits],
        "force peak / N": [f"{v.hit.force_peak_n:.4g}" for v in hits],
        "accepted": ["yes" if v.hit.accepted else "no" for v in hits],
        "reasons": [_reasons(v) for v in hits],
        **({"note": [v.note for v in hits]} if any(v.note for v in hits) else {}),
        "end level / % of peak": [f"{100 * v.end_level:.2g}" if np.isfinite(v.end_level)
                                  else "" for v in hits],
    })


def _caption(p: HitsPageInput) -> str:
    """The caption of a hit's figure, naming only the windows used."""
    windows = []
    if p.exp_window_tau_s is not None:
        windows.append("the exponential window scaled to its peak (red dashed)")
    if p.force_window_s:
        windows.append("the force window (green dotted)")
    response = ("response with " + " and ".join(windows) if windows
                else "response (no window)")
    return ("Force pulse (dashed: the hit time), force spectrum (dashed: -10 dB green, "
            f"-20 dB red), {response}")


def _decay_text(v: HitView) -> str:
    """Every response's level at the record end, and the limit without an
    exponential window."""
    levels = v.end_levels or ((v.response_name, v.end_level),)
    shown = [f"{name} {100 * level:.2g} %" for name, level in levels if np.isfinite(level)]
    if not shown:
        return ""
    return (f"Level at the record end, of the response's peak: {', '.join(shown)} (limit "
            f"without exponential window {100 * NOT_DECAYED_LEVEL:g} %).")


def render_hits_html(page_input: HitsPageInput, *, figures: bool = True) -> str:
    """The hit page as one self-contained HTML string.

    Examples
    --------
    >>> from ema_pipeline.data import FRFSet
    >>> f = np.linspace(0.0, 100.0, 101)
    >>> frf = FRFSet(freq_hz=f, H=(1.0 + f)[None, None, :] + 0j, coherence=np.ones((1, 1, 101)))
    >>> t = np.arange(256) / 256.0
    >>> view = HitView(Hit(1, 0.01, 90.0, True), t, np.exp(-((t - 0.01) / 0.002) ** 2),
    ...                np.sin(60 * t), "acc", np.ones(256), np.ones(256), f[:50],
    ...                np.zeros(50), 0.01)
    >>> page = render_hits_html(HitsPageInput("Hits", "rec.uff", "", frf, [view], 256, 1.0,
    ...                         0.01, None, None, "H1", (40.0, 70.0)))
    >>> page.count('class="hit"'), "-10 dB at 40 Hz" in page
    (1, True)
    """
    p = page_input
    f10, f20 = p.force_band_hz
    band_text = f"-10 dB at {f10:.5g} Hz, -20 dB at {f20:.5g} Hz"
    n_acc = sum(v.hit.accepted for v in p.hits)
    n_points = len({v.file for v in p.hits})
    page = Page(p.title)
    by_hand = any(v.by_hand for v in p.hits)
    summary = {
        p.source_role: p.source,
        "hits": f"{len(p.hits)} found, {n_acc} averaged"
                + (f" over {n_points} points" if n_points > 1 else "")
                + (" (--keep-all: rejected hits kept)" if p.keep_all else "")
                + (" (chosen by hand: --hits)" if by_hand else ""),
        "averages": averages_text(p.hits),
        "records": f"{p.n_samples} samples ({p.record_length_s:.4g} s), pretrigger "
                   f"{p.pretrigger_s:.4g} s",
        "force window": "none" if not p.force_window_s else f"{p.force_window_s:.4g} s "
                        "(then a 10 ms cosine taper)",
        "exponential window": "none" if p.exp_window_tau_s is None
        else f"tau = {p.exp_window_tau_s:.4g} s (stored with the FRFs; identification "
             "corrects the damping)",
        "estimator": p.estimator,
        "usable band (force spectrum)": band_text,
    }
    page.section("summary", "Summary").append(kv_table(summary))
    page.section("hits", "Hit table").append(html_table(_hit_table(p.hits), split=False))
    if p.hits:
        from ema_pipeline.report.hit_choice_view import hit_choice_html

        choice = hit_choice_html(p.hits, p.hits[0].freq_hz, p.force_band_hz)
        if choice:
            page.section("choose", "Choose the hits").append(choice)
    for v in p.hits:
        cls = "ok" if v.hit.accepted and not v.hit.reasons else "bad"
        body = [f'<p class="status {cls}">{esc(verdict_text(v.hit, p.keep_all, v.by_hand))}'
                "</p>"]
        if v.note:
            body.append('<p class="status" style="background:#fff8e6;border-left:5px solid '
                        f'#d08a00">note: {esc(v.note)}</p>')
        decay = _decay_text(v)
        body.append(f"<p>{esc(decay)}</p>" if decay else "")
        if figures:
            body.append(f"<figure>{hit_figure(v, p.force_band_hz)}<figcaption>"
                        f"{esc(_caption(p))}</figcaption></figure>")
        where = f"{v.file}, hit {v.number or v.hit.index}" if v.file else f"Hit {v.hit.index}"
        sec = page.section(f"hit-{v.hit.index}", f"{where} at {v.hit.time_s:.3f} s")
        sec.append(f'<div class="hit" id="hit-body-{v.hit.index}">{"".join(body)}</div>')
    frf_part = [f"<p>Usable band of the averaged force spectrum: {esc(band_text)}.</p>"]
    if figures:
        frf_part.append("<figure>" + figure_frf_coherence(p.frf, "Averaged FRF",
                                                          marks_hz=p.force_band_hz)
                        + "<figcaption>Averaged FRF and coherence; dashed: the usable band "
                          "(-10 dB, -20 dB)</figcaption></figure>")
    page.section("frf", "Averaged FRF and coherence").append("".join(frf_part))
    page.section("provenance", "Provenance").append(
        provenance([(p.source_role, p.source, p.sha256), *p.inputs], dict(p.settings),
                   p.version, p.generated)
    )
    return page.html()
