"""The checks of the hits of an impact recording: why a hit is not averaged.

Numerics only: the hits :func:`ema_pipeline.acquisition.hit_search.find_hits`
found, checked on the :class:`~ema_pipeline.data.Recording`, one :class:`Hit` each
(:mod:`ema_pipeline.acquisition.hits` gathers both). The rules, with their
constants (module attributes):

Checks (the reasons, :data:`REASONS`)
    ``past_end``: the record does not fit in its segment (never kept); the
    other checks still look at the part of the record that exists.
    ``double_hit``: outside the main pulse (from the last sample below the
    trigger before the crossing to ``GUARD_S`` (1 ms) after the force has
    fallen back below the trigger for ``PULSE_GAP_S`` (0.5 ms, at least 2
    samples: the ringing of an anti-aliasing filter belongs to the pulse)), a
    force sample in the record exceeds ``DOUBLE_HIT_FRACTION`` (10 %) of its
    peak (and the trigger); or the force spectrum of the pulse
    (``RIPPLE_WINDOW_S`` after it) has ripple: it dips more than
    ``RIPPLE_DB`` (3 dB) below its decreasing upper envelope where that envelope
    is within 10 dB of its low-frequency level (below 80 % of Nyquist; not
    for a clipped force pulse, whose flat top has ripple of its own).
    ``overload``: some channel reaches ``FULL_SCALE_FRACTION`` (99 %) of its
    ``Channel.full_scale`` in the record, or has flat tops: at least
    ``CLIP_RUN`` (3) samples exactly equal to the record's maximum (or
    minimum; non-zero, at least half its largest magnitude), counted in runs
    entered or left by a step of more than 4 quantization steps (the smallest
    non-zero step of the channel), so that a smooth, finely quantized peak is
    not a flat top; when the maximum is exactly minus the minimum (a symmetric
    range clipped on both sides) both count together. Two such samples suffice
    when the record's largest magnitude is at least ``FINE_STEPS`` (2^15)
    quantization steps (finer than 16 bits: a tie by chance is then very
    unlikely), e.g. a short force pulse clipped on 2 samples. A channel clipped
    on a single sample is seen only through its full scale. Two-level clipping
    (the channel sits at two values, e.g. a square wave at +-1000 N, whose
    quantization step is its whole swing) is an overload as well: at least half
    the record's samples exactly at its maximum or its minimum, at least
    ``CLIP_RUN`` at each, one positive and one negative, both at least half the
    channel's largest magnitude over the recording. The hit names the channels
    (``Hit.overloaded``).
    ``not_decayed`` (only when no exponential window is allowed): some
    response's level at the record end (sqrt(2) times its RMS over the last
    1/16 of the record) is above ``NOT_DECAYED_LEVEL`` (5 %) of its peak after
    the trigger and above 3 times its pretrigger level.
    ``low_force``: the force peak is below ``LOW_FORCE_FRACTION`` (25 %) of the
    median peak of the hits.
    ``outlier`` (only for hits without another reason, at least 3 of them): a
    hit that would corrupt the average, judged against the median of those hits,
    never by its force level (the FRF is divided by the force; ``low_force``
    guards against hits too weak to trust). Three measures: the pulse width (its
    area over its peak, ``2 T / pi`` for a half-sine of duration ``T``), and per
    response the gain and the mismatch of the hit's FRF against the median FRF
    of those hits (:func:`frf_agreement`: the response per unit force, and the
    part of the response that FRF does not explain, such as modes that moved or
    a response that drops out). A hit is an outlier when one of them lies
    further from its median than ``OUTLIER_Z`` (5) robust standard deviations
    (1.4826 MAD) and further than a floor: a factor ``OUTLIER_RATIO`` (2) for the
    width (and 2 samples) and for the gain, ``OUTLIER_MISMATCH`` (0.5) for the
    mismatch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.acquisition.hit_search import (
    HitSearch,
    cut_records,
    found_force,
    pulse_end,
)
from ema_pipeline.data import Recording

__all__ = [
    "CLIP_RUN",
    "DOUBLE_HIT_FRACTION",
    "FINE_STEPS",
    "FULL_SCALE_FRACTION",
    "GUARD_S",
    "LEFT_OUT_BY_HAND",
    "LOW_FORCE_FRACTION",
    "NOT_DECAYED_LEVEL",
    "OUTLIER_MISMATCH",
    "OUTLIER_RATIO",
    "OUTLIER_Z",
    "REASONS",
    "RIPPLE_DB",
    "RIPPLE_WINDOW_S",
    "Hit",
    "check_hits",
    "frf_agreement",
    "tail_level",
]

GUARD_S = 1e-3
DOUBLE_HIT_FRACTION = 0.10
RIPPLE_WINDOW_S = 0.05
RIPPLE_DB = 3.0
FULL_SCALE_FRACTION = 0.99
CLIP_RUN = 3
FINE_STEPS = 2.0**15
NOT_DECAYED_LEVEL = 0.05
LOW_FORCE_FRACTION = 0.25
OUTLIER_Z = 5.0
OUTLIER_RATIO = 2.0
OUTLIER_MISMATCH = 0.5

#: Why a hit that passed every check is not averaged (a choice by hand).
LEFT_OUT_BY_HAND = "left out by hand (--hits)"
#: The fixed vocabulary of rejection reasons, in the order they are reported.
REASONS = ("past_end", "double_hit", "overload", "not_decayed", "low_force", "outlier")


@dataclass(frozen=True)
class Hit:
    """One hit: ``index`` (1-based), ``time_s`` (trigger crossing from the start of
    the recording), ``force_peak_n``, ``accepted`` and ``reasons`` (of
    :data:`REASONS`; a hit kept by ``keep_all`` is accepted with its reasons).
    ``record_start`` is the first sample of its record (-1: none, ``past_end``);
    ``overloaded`` names the channels of an ``overload``; ``padded`` is the number
    of samples its record is padded with at the front (a hit nearer the start of
    the data than the pretrigger), 0 for most."""

    index: int
    time_s: float
    force_peak_n: float
    accepted: bool
    reasons: tuple[str, ...] = ()
    record_start: int = -1
    #: Names of the channels that made it an ``overload``.
    overloaded: tuple[str, ...] = ()
    #: Samples of its record before the data start (padded with the first sample).
    padded: int = 0

    def reasons_text(self) -> str:
        """The reasons for a console line, the overloaded channels named.

        Examples
        --------
        >>> Hit(3, 2.5, 900.0, False, ("double_hit", "overload"), 10, ("force",)).reasons_text()
        "double_hit, overload ('force')"
        >>> Hit(4, 4.5, 90.0, False, (), 10).reasons_text()
        'left out by hand (--hits)'
        """
        if not self.accepted and not self.reasons:  # only a choice by hand leaves one out
            return LEFT_OUT_BY_HAND
        return ", ".join(
            f"{r} ({', '.join(repr(c) for c in self.overloaded)})"
            if r == "overload" and self.overloaded else r for r in self.reasons)


def _main_pulse(g: np.ndarray, c: int, level: float, lo: int, hi: int, guard: int,
                fs: float) -> tuple[int, int]:
    """Samples [a, b) of the pulse crossing at c: from the last sample at or below
    ``level`` before c to ``guard`` samples after its end
    (:func:`~ema_pipeline.acquisition.hit_search.pulse_end`)."""
    before = np.flatnonzero(g[lo:c] <= level)
    a = lo + (before[-1] if before.size else 0)
    return a, min(hi, pulse_end(g, c, level, hi, fs) + guard)


def _ripple_db(pulse: np.ndarray) -> float:
    """Largest dip (dB) of the pulse's amplitude spectrum below its decreasing upper
    envelope, where the envelope is within 10 dB of the low-frequency level and
    below 80 % of Nyquist."""
    n_fft = max(1024, 8 * pulse.size)
    spec = np.abs(np.fft.rfft(pulse, n_fft))
    db = 20 * np.log10(np.maximum(spec, np.finfo(float).tiny))
    envelope = np.maximum.accumulate(db[::-1])[::-1]
    ref = float(np.median(db[: max(3, spec.size // 100)]))
    keep = (envelope >= ref - 10.0) & (np.arange(spec.size) < 0.8 * spec.size)
    return float(np.max(envelope[keep] - db[keep])) if keep.any() else 0.0


def _quantization_step(full_x: np.ndarray) -> float:
    """The smallest non-zero step between consecutive samples of a channel (0: none)."""
    steps = np.abs(np.diff(full_x))
    nonzero = steps[steps > 0]
    return float(nonzero.min()) if nonzero.size else 0.0


def _two_levels(x: np.ndarray, channel_peak: float) -> bool:
    """Record ``x`` sits at two values: two-level clipping (module doc, ``overload``)."""
    top, bottom = float(x.max()), float(x.min())
    if not (top > 0 > bottom and min(top, -bottom) >= 0.5 * channel_peak):
        return False
    n_top, n_bottom = int(np.count_nonzero(x == top)), int(np.count_nonzero(x == bottom))
    return min(n_top, n_bottom) >= CLIP_RUN and n_top + n_bottom >= 0.5 * x.size


def _flat_top(x: np.ndarray, q: float) -> bool:
    """Flat tops (clipping) in record ``x`` of a channel whose quantization step is
    ``q`` (:func:`_quantization_step`); the rule is in the module doc (``overload``)."""
    biggest = float(np.abs(x).max())

    def clipped_samples(value: float) -> int:
        if value == 0 or abs(value) < 0.5 * biggest:
            return 0
        at = np.flatnonzero(x == value)
        count = 0
        for run in np.split(at, np.flatnonzero(np.diff(at) > 1) + 1):
            i0, i1 = run[0], run[-1]
            step_in = abs(x[i0] - x[i0 - 1]) if i0 > 0 else 0.0
            step_out = abs(x[i1 + 1] - x[i1]) if i1 + 1 < x.size else 0.0
            if max(step_in, step_out) > 4 * q:
                count += run.size
        return count

    top, bottom = float(x.max()), float(x.min())
    counts = [clipped_samples(top), clipped_samples(bottom)]
    if top == -bottom:  # a symmetric input range clipped on both sides
        counts.append(counts[0] + counts[1])
    fine = q == 0 or biggest >= FINE_STEPS * q  # a tie by chance is then very rare
    return max(counts) >= (2 if fine else CLIP_RUN)


def tail_level(response: np.ndarray, n_pretrigger: int,
               n_tail: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Level at the record end relative to the peak, and pretrigger level relative
    to the peak, per record and response.

    ``response`` (n_records, n_out, n_samples). The end level is sqrt(2) times the
    RMS over the last ``n_tail`` samples (default 1/16 of the record, at least 8),
    the peak the largest absolute value after the trigger, the pretrigger level
    sqrt(2) times the RMS before the trigger (0 without pretrigger).

    Examples
    --------
    >>> t = np.arange(1024) / 1024.0
    >>> x = (np.exp(-t / 0.25) * np.sin(2 * np.pi * 64 * t))[None, None, :]
    >>> float(tail_level(x, 0)[0][0, 0].round(3))  # exp(-4 * 31/32): about 2 %
    0.021
    """
    n = response.shape[-1]
    n_tail = max(8, n // 16) if n_tail is None else n_tail
    peak = np.abs(response[..., n_pretrigger:]).max(axis=-1)
    peak = np.where(peak > 0, peak, np.inf)
    end = np.sqrt(2 * np.mean(response[..., -n_tail:] ** 2, axis=-1)) / peak
    pre = np.zeros_like(end)
    if n_pretrigger >= 4:
        pre = np.sqrt(2 * np.mean(response[..., :n_pretrigger] ** 2, axis=-1)) / peak
    return end, pre


def frf_agreement(force: np.ndarray, response: np.ndarray,
                  among: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How well each hit's FRF agrees with the median FRF of the hits ``among``.

    ``force`` (n_hits, n) the records' force (the pulse only), ``response``
    (n_hits, n_out, n). Per line, the median FRF ``Hm`` is the median of the real
    and of the imaginary parts of ``X / F`` over the hits ``among`` (boolean,
    n_hits); the response it predicts for hit k is ``P = Hm F_k``. The gain is
    ``|a|`` of the least-squares ``a = sum(conj(P) X_k) / sum(|P|^2)`` and the
    mismatch ``sqrt(sum(|X_k - a P|^2) / sum(|a P|^2))``: the part of the
    response the median FRF does not explain, as a fraction of the part it does.
    Sums over every line but DC, so the force spectrum weights them: lines the
    hammer does not excite count little. Both are independent of the force level;
    noise raises the mismatch of a soft hit as noise over signal does.

    Returns
    -------
    gain, mismatch : (n_hits, n_out); a hit without response gets gain 1 and
        mismatch 0.

    Examples
    --------
    >>> t = np.arange(512) / 512.0
    >>> pulse = np.zeros(512); pulse[1:4] = [0.5, 1.0, 0.5]
    >>> h = np.exp(-8 * t) * np.sin(2 * np.pi * 40 * t)  # impulse response
    >>> ring = np.convolve(pulse, h)[:512]
    >>> force = np.array([100.0, 40.0, 90.0, 110.0])[:, None] * pulse
    >>> response = np.array([100.0, 40.0, 90.0, 2.5 * 110.0])[:, None, None] * ring
    >>> gain, mismatch = frf_agreement(force, response, np.ones(4, bool))
    >>> gain[:, 0].round(2).tolist(), mismatch[:, 0].round(2).tolist()
    ([1.0, 1.0, 1.0, 2.5], [0.0, 0.0, 0.0, 0.0])
    """
    f = np.fft.rfft(force, axis=-1)[:, 1:]
    x = np.fft.rfft(response, axis=-1)[:, :, 1:]
    tiny = np.finfo(float).tiny
    live = np.abs(f) > tiny
    h = np.where(live[:, None], x / np.where(live, f, 1.0)[:, None], 0.0)
    hm = np.median(h[among].real, axis=0) + 1j * np.median(h[among].imag, axis=0)
    predicted = hm[None] * f[:, None]
    power = np.sum(np.abs(predicted) ** 2, axis=-1)
    a = np.sum(np.conj(predicted) * x, axis=-1) / np.maximum(power, tiny)
    left = np.sum(np.abs(x - a[..., None] * predicted) ** 2, axis=-1)
    explained = np.abs(a) ** 2 * power
    gain = np.where(power > tiny, np.abs(a), 1.0)
    mismatch = np.where(explained > tiny, np.sqrt(left / np.maximum(explained, tiny)), 0.0)
    return np.maximum(gain, tiny), mismatch


def check_hits(
    recording: Recording,
    force_index: int,
    found: HitSearch,
    *,
    exp_window: bool,
    keep_all: bool = False,
) -> tuple[Hit, ...]:
    """Check every hit with the rules of the module doc; one :class:`Hit` each.

    ``exp_window`` True: an exponential window will be applied (``not_decayed`` is
    not checked). ``keep_all`` accepts every hit that has a record, with its reasons.

    Examples
    --------
    >>> from ema_pipeline.acquisition.hit_search import find_hits
    >>> from ema_pipeline.data import Channel
    >>> force = np.zeros((1, 4096))
    >>> force[0, [500, 1700, 1720, 3500]] = [100.0, 80.0, 40.0, 90.0]  # hit 2 bounces
    >>> rec = Recording(force, 1024.0, (Channel("hammer", "force"),))
    >>> found = find_hits(rec, 0, pretrigger_s=0.01)
    >>> [(h.index, h.accepted, h.reasons) for h in check_hits(rec, 0, found, exp_window=True)]
    [(1, True, ()), (2, False, ('double_hit',)), (3, False, ('past_end',))]
    """
    fs = recording.sample_rate_hz
    g = found_force(recording, force_index, found)
    n, n_pre = found.n_samples, found.n_pretrigger
    guard = max(1, int(round(GUARD_S * fs)))
    responses = [k for k in range(len(recording.channels)) if k != force_index]
    reasons: list[set[str]] = [set() for _ in range(found.n_hits)]
    median_peak = float(np.median(found.peak_n))
    width = np.full(found.n_hits, np.nan)
    force_rec = np.zeros((found.n_hits, n))  # the main pulse only, at its place
    resp_rec = np.zeros((found.n_hits, len(responses), n))
    seg_starts = np.array(recording.segment_starts)
    seg_ends = np.append(seg_starts[1:], recording.n_samples)
    steps = [_quantization_step(x) for x in recording.signals]  # once per channel
    channel_peaks = np.abs(recording.signals).max(axis=1)
    overloaded: list[list[str]] = [[] for _ in range(found.n_hits)]
    for k in range(found.n_hits):
        c, peak = found.cross[k], found.peak_n[k]
        a, b = found.start[k], found.start[k] + n - found.padding()[k]
        if a < 0:  # no record; the other checks still look at the data there is
            reasons[k].add("past_end")
            seg = found.segment[k]
            a, b = max(c - n_pre, seg_starts[seg]), min(c - n_pre + n, seg_ends[seg])
        force_clipped = False
        for ch, channel in enumerate(recording.channels):
            x = recording.signals[ch, a:b]
            full = channel.full_scale
            if (full is not None and np.abs(x).max() >= FULL_SCALE_FRACTION * full) or _flat_top(
                x, steps[ch]
            ) or _two_levels(x, float(channel_peaks[ch])):
                reasons[k].add("overload")
                overloaded[k].append(channel.name)
                force_clipped = force_clipped or ch == force_index
        p0, p1 = _main_pulse(g, c, found.trigger_n, a, b, guard, fs)
        outside = np.concatenate([g[a:p0], g[p1:b]])
        limit = max(DOUBLE_HIT_FRACTION * peak, found.trigger_n)
        ripple_stop = min(b, c + int(round(RIPPLE_WINDOW_S * fs)))
        if (outside.size and outside.max() > limit) or (
            not force_clipped and _ripple_db(g[a:ripple_stop]) > RIPPLE_DB
        ):
            reasons[k].add("double_hit")
        if peak < LOW_FORCE_FRACTION * median_peak:
            reasons[k].add("low_force")
        pulse = g[p0:p1]
        width[k] = float(pulse.sum()) / fs / peak  # area over peak: 2 T / pi for a half-sine
        if responses and not reasons[k]:
            m = min(b - a, n)
            force_rec[k, p0 - a:p1 - a] = pulse
            resp_rec[k, :, :m] = recording.signals[responses, a:a + m]
    if not exp_window and found.n_hits and responses:
        fits = found.start >= 0
        if fits.any():
            records = cut_records(recording, force_index, found, np.flatnonzero(fits))
            end, pre = tail_level(records.response, n_pre)
            bad = np.any((end > NOT_DECAYED_LEVEL) & (end > 3 * pre), axis=1)
            for i in np.flatnonzero(fits)[bad]:
                reasons[int(i)].add("not_decayed")
    clean = np.array([not r for r in reasons])
    if clean.sum() >= 3:
        features = [(width, max(2.0 / fs, (OUTLIER_RATIO - 1.0) * float(np.median(width[clean]))))]
        if responses:
            gain, mismatch = frf_agreement(force_rec, resp_rec, clean)
            features += [(np.log(gain[:, j]), np.log(OUTLIER_RATIO)) for j in range(len(responses))]
            features += [(mismatch[:, j], OUTLIER_MISMATCH) for j in range(len(responses))]
        for values, floor in features:
            med = np.median(values[clean])
            mad = 1.4826 * np.median(np.abs(values[clean] - med))
            far = clean & (np.abs(values - med) > max(OUTLIER_Z * mad, floor))
            for i in np.flatnonzero(far):
                reasons[int(i)].add("outlier")
    hits = []
    for k in range(found.n_hits):
        ordered = tuple(r for r in REASONS if r in reasons[k])
        has_record = found.start[k] >= 0
        hits.append(Hit(
            index=k + 1,
            time_s=float(found.time_s[k]),
            force_peak_n=float(found.peak_n[k]),
            accepted=bool(has_record and (keep_all or not ordered)),
            reasons=ordered,
            record_start=int(found.start[k]),
            overloaded=tuple(overloaded[k]),
            padded=int(found.padding()[k]),
        ))
    return tuple(hits)
