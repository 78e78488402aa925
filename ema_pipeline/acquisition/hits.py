"""Hits of an impact recording: find them on the force channel, check them, cut records.

Numerics only (no files): a :class:`~ema_pipeline.data.Recording` in, hit tables and
:class:`~ema_pipeline.data.TimeRecords` out; :func:`ema_pipeline.acquisition.estimate_frf`
makes the FRFs. The rules, with their constants (module attributes):

Finding hits
    The force is taken relative to its median per segment (the offset) and with
    the polarity of its largest excursion. The trigger level is
    ``TRIGGER_FRACTION`` (5 %) of the largest force peak of the recording, and
    at least ``NOISE_FACTOR`` (8) times the force noise (robust std of the
    sample-to-sample differences). A hit is an upward crossing of the trigger;
    its time is the crossing, linearly interpolated between samples, from the
    start of the recording; its peak is the largest force of its pulse.
    Crossings less than ``BOUNCE_WINDOW_S`` (0.1 s) after a hit belong to that
    hit (bounces: a double hit, not a new hit).
    Hits never join across the segments of pre-cut records.

Records
    A record starts ``pretrigger_s`` before the sample of the crossing. Its
    default length is the longest power of two of samples that fits between
    consecutive hits of a segment (records never overlap, so a record never
    holds two hits); a segment with one hit only offers the space up to its
    end. Pre-cut records (several segments, one hit each) are kept as cut: the
    records start at the segments' starts, with the longest power of two of
    samples that the shortest holds, and the pretrigger is the median time of
    the crossings in their records. A hit whose record would run past the end of its
    segment is dropped with the reason ``past_end``. A hit closer to the start of
    its segment than the pretrigger (a file that starts 3 ms before the hit) is
    kept: its record is padded at the front with the segment's first sample (the
    records keep one common pretrigger, where the exponential window starts), and
    its row says how much (``Hit.padded``, the hit table's ``note``); only a hit
    whose crossing is the segment's first sample (the pulse may have begun before
    the data) is ``past_end``.

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
    ``outlier`` (only for hits without another reason, at least 3 of them): the
    force peak, the pulse width (samples above half the peak) or some response's
    RMS per unit force impulse lies further from the median of those hits than
    ``OUTLIER_Z`` (5) robust standard deviations (1.4826 MAD) and more than a
    factor ``OUTLIER_RATIO`` (2; for the width also 2 samples) from it.

The exponential window ``auto`` (:func:`auto_exp_window_tau`) brings the response
level at the record end (as above, median over the hits of the largest over the
responses) to ``AUTO_TAU_LEVEL`` (1 %); a response already below that needs none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import MIN_DF_HZ, DataError, Recording, TimeRecords

__all__ = [
    "AUTO_TAU_LEVEL",
    "LEFT_OUT_BY_HAND",
    "MAX_EXP_WINDOW_TAU_S",
    "MAX_PRETRIGGER_S",
    "MAX_RECORD_LENGTH_S",
    "REASONS",
    "Hit",
    "HitSearch",
    "auto_exp_window_tau",
    "check_hits",
    "cut_records",
    "find_hits",
    "force_band",
    "hit_note",
    "hits_columns",
    "pulse_end_s",
]

TRIGGER_FRACTION = 0.05
NOISE_FACTOR = 8.0
BOUNCE_WINDOW_S = 0.1
GUARD_S = 1e-3
PULSE_GAP_S = 0.5e-3
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
AUTO_TAU_LEVEL = 0.01
#: Longest pretrigger, record length (also force window) and exponential window
#: time constant (s) a setting may give: the limits of the experiment file's ``frf``
#: table and of ``ema-pipeline frf``'s options.
MAX_PRETRIGGER_S = 1e3
MAX_RECORD_LENGTH_S = 1e4
MAX_EXP_WINDOW_TAU_S = 1e4

#: Median hit force peaks (N) outside this range are implausible for an impact hammer
#: (a modal hammer on a light part gives a few N, a sledge up to about 20 kN): a unit
#: off by 1000 (a [kN] label on data in N) is the usual cause.
PLAUSIBLE_HAMMER_PEAK_N = (0.05, 30e3)
#: A share of double hits from which the "force" is likely a response (it rings).
RESPONSE_LIKE_DOUBLE_SHARE = 0.5


def force_warnings(hits: tuple[Hit, ...] | list[Hit], force_name: str) -> list[str]:
    """Warnings about the force channel from its hits: a median peak implausible for
    a hammer (:data:`PLAUSIBLE_HAMMER_PEAK_N`), and at least
    :data:`RESPONSE_LIKE_DOUBLE_SHARE` of 2 or more hits ``double_hit`` (a ringing
    pulse: the channel may be a response).

    Examples
    --------
    >>> force_warnings([Hit(1, 0.5, 80e3, True), Hit(2, 1.5, 75e3, True)], "hammer")[0][:50]
    "force channel 'hammer': hit peaks of 77.5 kN (medi"
    """
    out: list[str] = []
    if not hits:
        return out
    median = float(np.median([h.force_peak_n for h in hits]))
    lo, hi = PLAUSIBLE_HAMMER_PEAK_N
    if not lo <= median <= hi:
        shown = f"{median / 1e3:.3g} kN" if median >= 1e3 else f"{median:.3g} N"
        out.append(f"force channel {force_name!r}: hit peaks of {shown} (median) are "
                   f"implausible for an impact hammer ({lo:g} N to {hi / 1e3:g} kN): is its "
                   "unit right? (a [kN] label on data in N gives 1000 times too much)")
    doubles = sum("double_hit" in h.reasons for h in hits)
    if len(hits) >= 2 and doubles >= RESPONSE_LIKE_DOUBLE_SHARE * len(hits):
        out.append(f"force channel {force_name!r}: {doubles} of {len(hits)} hits are double "
                   "hits (a ringing pulse): is it a response? check the force channel "
                   "(--force-channel, or the role column of a channel sheet)")
    return out


#: The fixed vocabulary of rejection reasons, in the order they are reported.
#: Why a hit that passed every check is not averaged (a choice by hand).
LEFT_OUT_BY_HAND = "left out by hand (--hits)"
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


@dataclass(frozen=True)
class HitSearch:
    """What :func:`find_hits` found: per hit the crossing sample ``cross``, its time
    ``time_s``, ``peak_n`` (force above the offset), ``segment``, and the record
    ``start`` (-1 when it does not fit); the common ``n_samples`` and
    ``n_pretrigger`` of the records, the ``trigger_n`` level, the force ``offset_n``
    per segment and its ``polarity`` (+1 or -1). ``pad`` (per hit; None: none)
    counts the samples a record lacks before the data start: its record is
    ``pad`` copies of sample ``start``, then ``n_samples - pad`` samples from
    ``start`` on."""

    cross: np.ndarray
    time_s: np.ndarray
    peak_n: np.ndarray
    segment: np.ndarray
    start: np.ndarray
    n_samples: int
    n_pretrigger: int
    trigger_n: float
    offset_n: np.ndarray
    polarity: float
    pad: np.ndarray | None = None

    @property
    def n_hits(self) -> int:
        return int(self.cross.size)

    def padding(self) -> np.ndarray:
        """Samples padded at the front of each hit's record (zeros when none)."""
        return np.zeros(self.n_hits, dtype=int) if self.pad is None else self.pad

    def trigger_offsets(self, which: np.ndarray | list[int]) -> np.ndarray:
        """The sample of each record of hits ``which`` where its crossing lies:
        the pretrigger for records cut around their hit, the crossing's place
        in its segment for pre-cut records (kept as cut)."""
        which = np.asarray(which, dtype=int)
        return self.cross[which] - self.start[which] + self.padding()[which]

    def record_index(self, which: np.ndarray | list[int]) -> np.ndarray:
        """(len(which), n_samples) sample indices of the records of hits ``which``
        (the padded front repeats the first sample of the data)."""
        which = np.asarray(which, dtype=int)
        first = self.start[which][:, None]
        idx = first - self.padding()[which][:, None] + np.arange(self.n_samples)[None, :]
        return np.maximum(idx, first)


def _segments(recording: Recording) -> list[tuple[int, int]]:
    starts = list(recording.segment_starts) + [recording.n_samples]
    return list(zip(starts[:-1], starts[1:], strict=True))


def _centred_force(recording: Recording, force_index: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Force minus its median per segment, with the polarity of its largest excursion."""
    force = recording.signals[force_index]
    g = np.empty_like(force)
    offsets = []
    for a, b in _segments(recording):
        offsets.append(float(np.median(force[a:b])))
        g[a:b] = force[a:b] - offsets[-1]
    polarity = 1.0 if g.max() >= -g.min() else -1.0
    return polarity * g, np.array(offsets), polarity


def _noise_std(x: np.ndarray) -> float:
    """Robust noise std from sample-to-sample differences (pulses are rare outliers)."""
    d = np.diff(x)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0)) if d.size else 0.0


def find_hits(
    recording: Recording,
    force_index: int,
    *,
    pretrigger_s: float,
    record_length_s: float | None = None,
) -> HitSearch:
    """Find the hits on the force channel and place their records (rules: module doc).

    Parameters
    ----------
    recording : the recording (one or more segments).
    force_index : row of the force channel in ``recording.signals``.
    pretrigger_s : time kept before each trigger crossing, s (>= 0).
    record_length_s : record length in s; ``None``: the longest power of two of
        samples that fits between consecutive hits.

    Returns
    -------
    HitSearch (no hit: a DataError naming the source).

    Examples
    --------
    >>> from ema_pipeline.data import Channel
    >>> force = np.zeros((1, 4096))
    >>> force[0, [500, 1700, 3500]] = [100.0, 80.0, 90.0]
    >>> rec = Recording(force, 1024.0, (Channel("hammer", "force"),))
    >>> found = find_hits(rec, 0, pretrigger_s=0.01)
    >>> found.time_s.round(3).tolist(), found.n_samples, found.start.tolist()
    ([0.487, 1.659, 3.417], 1024, [490, 1690, -1])
    """
    where = f"{recording.source.path}: " if recording.source.path else ""
    fs = recording.sample_rate_hz
    if not (np.isfinite(pretrigger_s) and 0 <= pretrigger_s <= MAX_PRETRIGGER_S):
        raise DataError(f"{where}pretrigger (pretrigger_s / --pretrigger-s) must be 0 to "
                        f"{MAX_PRETRIGGER_S:g} s, got {pretrigger_s:g}")
    if record_length_s is not None and not (
        np.isfinite(record_length_s) and 0 < record_length_s <= MAX_RECORD_LENGTH_S
    ):
        raise DataError(f"{where}record length (record_length_s / --record-length-s) must be "
                        f"> 0 and at most {MAX_RECORD_LENGTH_S:g} s, got {record_length_s:g}")
    longest = max(b - a for a, b in _segments(recording))  # samples
    span = f"{longest / fs:g} s" + (" (its longest segment)" if recording.segment_starts[1:]
                                    else "")
    if pretrigger_s * fs >= longest - 1:
        raise DataError(f"{where}pretrigger (pretrigger_s / --pretrigger-s) {pretrigger_s:g} s "
                        f"is not shorter than the recording, {span}; it is in seconds")
    if record_length_s is not None and record_length_s * fs > longest:
        raise DataError(f"{where}record length (record_length_s / --record-length-s) "
                        f"{record_length_s:g} s is longer than the recording, {span}")
    g, offsets, polarity = _centred_force(recording, force_index)
    peak_max = float(g.max())
    trigger = max(TRIGGER_FRACTION * peak_max, NOISE_FACTOR * _noise_std(g))
    if not peak_max > 0 or not trigger < peak_max:
        raise DataError(f"{where}no hit found: the force channel shows no pulse above its noise")
    crosses: list[int] = []
    segment: list[int] = []
    bounce = int(round(BOUNCE_WINDOW_S * fs))
    for seg, (a, b) in enumerate(_segments(recording)):
        above = g[a:b] > trigger
        ups = np.flatnonzero(~above[:-1] & above[1:]) + 1 + a
        last = -bounce - 1
        for c in ups:
            if c - last > bounce:
                crosses.append(int(c))
                segment.append(seg)
                last = int(c)
    cut = ("; the force is above the trigger from the first sample on (a hit cut off by the "
           "start of the data)") if any(g[a] > trigger for a, _ in _segments(recording)) else ""
    if not crosses:
        raise DataError(f"{where}no hit found: the force never crosses the trigger "
                        f"({trigger:.4g} N) upwards{cut}")
    cross = np.array(crosses)
    seg_arr = np.array(segment)
    frac = (trigger - g[cross - 1]) / (g[cross] - g[cross - 1])
    time_s = (cross - 1 + frac) / fs
    ends = np.array([e for _, e in _segments(recording)])
    peaks = np.empty(cross.size)
    for k, c in enumerate(cross):
        stop = _pulse_end(g, c, trigger, min(int(ends[seg_arr[k]]), c + bounce), fs)
        peaks[k] = g[c:max(stop, c + 1)].max()
    n_pre = int(round(pretrigger_s * fs))
    if record_length_s is None:
        space, alone_hit = [], []  # alone_hit: the hit alone in its segment, else -1
        for k in range(cross.size):
            same_next = k + 1 < cross.size and seg_arr[k + 1] == seg_arr[k]
            alone = not same_next and (k == 0 or seg_arr[k - 1] != seg_arr[k])
            if same_next or alone:
                space.append(cross[k + 1] - cross[k] if same_next
                             else ends[seg_arr[k]] - (cross[k] - n_pre))
                alone_hit.append(-1 if same_next else k)
        usable = min(space) if space else 0
        if usable < 2:
            raise DataError(f"{where}no room for a record: the hits are too close to each "
                            "other or to the end of the data")
        n_samples = 2 ** int(np.floor(np.log2(usable)))
    else:
        n_samples = int(round(record_length_s * fs))
        if n_samples <= n_pre + 1:
            raise DataError(f"{where}record length (--record-length-s) {record_length_s:g} s "
                            f"leaves no samples after the pretrigger (--pretrigger-s) "
                            f"{pretrigger_s:g} s")
    seg_starts = np.array(recording.segment_starts)
    start = cross - n_pre
    n_seg = len(recording.segment_starts)
    precut = record_length_s is None and n_seg > 1 and np.array_equal(seg_arr,
                                                                       np.arange(n_seg))
    if precut:  # pre-cut records, one hit each: kept as cut (from their start), not shortened
        start = seg_starts.copy()
        n_samples = 2 ** int(np.floor(np.log2(np.min(ends - seg_starts))))
        n_pre = int(np.median(cross - seg_starts))
    if n_pre >= n_samples - 1:  # the trigger would lie at or past the record's end
        if precut:
            raise DataError(f"{where}the hits lie {n_pre / fs:g} s into their pre-cut records, "
                            f"not before the end of the {n_samples / fs:g} s they all hold")
        late = alone_hit[int(np.argmin(space))] if record_length_s is None else -1
        if late >= 0:  # the data end right after the only hit: no room, whatever the pretrigger
            after = int(ends[seg_arr[late]] - cross[late])
            raise DataError(f"{where}no room for a record: the data end {after} sample(s) after "
                            f"the hit at {time_s[late]:.4g} s{cut}")
        raise DataError(f"{where}the pretrigger (--pretrigger-s) {pretrigger_s:g} s is not "
                        f"shorter than the records, {n_samples / fs:g} s ({n_samples} samples: "
                        "the longest power of two between hits); it is in seconds")
    if n_samples / fs > 1.0 / MIN_DF_HZ:
        raise DataError(f"{where}records of {n_samples / fs:g} s would give FRF lines "
                        f"{fs / n_samples:.3g} Hz apart, finer than the {MIN_DF_HZ:g} Hz an FRF "
                        "file may hold; give a shorter --record-length-s")
    seg_lo = seg_starts[seg_arr]
    room = start + n_samples <= ends[seg_arr]
    # near the data start: pad the record's front, when the pulse's start is in the data
    pad = np.where(room & (start < seg_lo) & (cross > seg_lo), seg_lo - start, 0)
    fits = room & (start + pad >= seg_lo)
    start = start + pad
    pad = np.where(fits, pad, 0).astype(int)
    return HitSearch(
        cross=cross,
        time_s=time_s,
        peak_n=peaks,
        segment=seg_arr,
        start=np.where(fits, start, -1),
        n_samples=int(n_samples),
        n_pretrigger=n_pre,
        trigger_n=float(trigger),
        offset_n=offsets,
        polarity=polarity,
        pad=pad,
    )


def _pulse_end(g: np.ndarray, c: int, level: float, hi: int, fs: float) -> int:
    """First sample after the crossing ``c`` from which the force stays at or below
    ``level`` for ``PULSE_GAP_S`` (at least 2 samples): ringing of an anti-aliasing
    filter that crosses the level again belongs to the pulse."""
    need = max(2, int(round(PULSE_GAP_S * fs)))
    below = g[c:hi] <= level
    if below.size < need:
        return hi
    run = np.convolve(below.astype(int), np.ones(need, dtype=int), mode="valid")
    full = np.flatnonzero(run == need)
    return c + int(full[0]) if full.size else hi


def _main_pulse(g: np.ndarray, c: int, level: float, lo: int, hi: int, guard: int,
                fs: float) -> tuple[int, int]:
    """Samples [a, b) of the pulse crossing at c: from the last sample at or below
    ``level`` before c to ``guard`` samples after its end (:func:`_pulse_end`)."""
    before = np.flatnonzero(g[lo:c] <= level)
    a = lo + (before[-1] if before.size else 0)
    return a, min(hi, _pulse_end(g, c, level, hi, fs) + guard)


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


def _found_force(recording: Recording, force_index: int, found: HitSearch) -> np.ndarray:
    """The force centred and turned as :func:`find_hits` did (its offsets, polarity)."""
    g = recording.signals[force_index].copy()
    for (a, b), offset in zip(_segments(recording), found.offset_n, strict=True):
        g[a:b] -= offset
    return g * found.polarity


def pulse_end_s(
    recording: Recording,
    force_index: int,
    found: HitSearch,
    which: np.ndarray | list[int],
) -> float:
    """Latest end of the main force pulse, in s from the record start, over the hits
    ``which`` (0-based indices into ``found``, hits with a record): where the force
    has fallen back below the trigger for ``PULSE_GAP_S`` (as the ``double_hit``
    check reads the pulse). A force window shorter than this cuts a pulse.

    Examples
    --------
    >>> from ema_pipeline.data import Channel
    >>> force = np.zeros((1, 4096))
    >>> force[0, 500:510] = 100.0  # a 10-sample pulse, 10 samples of pretrigger
    >>> rec = Recording(force, 1000.0, (Channel("hammer", "force"),))
    >>> found = find_hits(rec, 0, pretrigger_s=0.01)
    >>> pulse_end_s(rec, 0, found, [0])  # 10 ms pretrigger + 10 ms pulse
    0.02
    """
    g = _found_force(recording, force_index, found)
    fs, n = recording.sample_rate_hz, found.n_samples
    latest = 0.0
    for k in np.asarray(which, dtype=int):
        a = int(found.start[k])
        if a < 0:
            continue
        c = int(found.cross[k])
        pad = int(found.padding()[k])
        end = _pulse_end(g, c, found.trigger_n, a + n - pad, fs)
        latest = max(latest, (end - a + pad) / fs)
    return latest


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
    >>> from ema_pipeline.data import Channel
    >>> force = np.zeros((1, 4096))
    >>> force[0, [500, 1700, 1720, 3500]] = [100.0, 80.0, 40.0, 90.0]  # hit 2 bounces
    >>> rec = Recording(force, 1024.0, (Channel("hammer", "force"),))
    >>> found = find_hits(rec, 0, pretrigger_s=0.01)
    >>> [(h.index, h.accepted, h.reasons) for h in check_hits(rec, 0, found, exp_window=True)]
    [(1, True, ()), (2, False, ('double_hit',)), (3, False, ('past_end',))]
    """
    fs = recording.sample_rate_hz
    g = _found_force(recording, force_index, found)
    n, n_pre = found.n_samples, found.n_pretrigger
    guard = max(1, int(round(GUARD_S * fs)))
    responses = [k for k in range(len(recording.channels)) if k != force_index]
    reasons: list[set[str]] = [set() for _ in range(found.n_hits)]
    median_peak = float(np.median(found.peak_n))
    width = np.full(found.n_hits, np.nan)
    level = np.full((found.n_hits, len(responses)), np.nan)
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
        width[k] = np.count_nonzero(pulse >= peak / 2) / fs
        impulse = max(float(pulse.sum()) / fs, np.finfo(float).tiny)
        if responses:
            rms = np.sqrt(np.mean(recording.signals[responses, a:b] ** 2, axis=-1))
            level[k] = rms / impulse
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
        tiny = np.finfo(float).tiny
        med_width = float(np.median(width[clean]))
        features = [(np.log(found.peak_n), np.log(OUTLIER_RATIO)),
                    (width, max(2.0 / fs, (OUTLIER_RATIO - 1.0) * med_width))]
        features += [(np.log(np.maximum(level[:, j], tiny)), np.log(OUTLIER_RATIO))
                     for j in range(len(responses))]
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


def cut_records(
    recording: Recording,
    force_index: int,
    found: HitSearch,
    which: np.ndarray | list[int],
) -> TimeRecords:
    """The records of hits ``which`` (0-based indices into ``found``) as TimeRecords.

    Force (the raw force channel, offset included) and every other channel as
    responses, in the order of the recording; ``trigger_s`` is the pretrigger.
    Response and reference DOFs come from the channels (``DOF(k)`` for response
    k, ``DOF(0)`` for the force, when a channel has none).
    """
    from ema_pipeline.data import DOF

    which = np.asarray(which, dtype=int)
    if which.size == 0:
        raise DataError(f"{recording.source.path or 'recording'}: no hit to cut")
    if np.any(found.start[which] < 0):
        raise DataError("a hit without a record (past_end) cannot be cut")
    idx = found.record_index(which)  # (n_rec, n)
    responses = [k for k in range(len(recording.channels)) if k != force_index]
    force = recording.signals[force_index][idx]
    response = recording.signals[responses][:, idx].transpose(1, 0, 2)
    dofs = tuple(recording.channels[k].dof or DOF(j + 1) for j, k in enumerate(responses))
    return TimeRecords(
        force=force,
        response=response,
        sample_rate_hz=recording.sample_rate_hz,
        trigger_s=found.n_pretrigger / recording.sample_rate_hz,
        response_dofs=dofs,
        reference_dof=recording.channels[force_index].dof or DOF(0),
        source=recording.source,
    )


def auto_exp_window_tau(records: TimeRecords, trigger_offsets: np.ndarray | None = None,
                        pretrigger_n: int = 0) -> float | None:
    """Time constant (s) of the exponential window that brings the response level
    at the record end to ``AUTO_TAU_LEVEL`` (1 %) of its peak; ``None`` when it is
    there already.

    The level r (:func:`tail_level`: median over the records of the largest over
    the responses) is measured over 1/16 of the record length ending t_end after
    each record's own trigger crossing (``trigger_offsets``, samples into each
    record; default: the records' common trigger), with t_end the record length
    less the longest of the pretrigger asked for (``pretrigger_n``, samples) and
    the crossings' offsets: for records cut around their hits, the last 1/16 of
    the record; for pre-cut ones (kept from their start, their crossings a few
    samples in) the same time after the crossing. So a hit's window depends on
    its own data, not on how the recording is laid out: pyFRF's five hits as
    one file (records cut 10 ms before each hit) or as five (pre-cut records,
    the hit under 1 ms in) get the same window. The window exp(-t/tau) must
    bring r down to 1 %: tau = t_mid / ln(r / 0.01), t_mid the middle of the
    last 1/16 (the time after the trigger where r is measured).

    Examples
    --------
    >>> t = np.arange(1024) / 1024.0
    >>> x = np.exp(-t / 0.5) * np.sin(2 * np.pi * 64 * t)  # about 14 % left at the end
    >>> rec = TimeRecords(force=np.eye(1, 1024), response=x[None, :], sample_rate_hz=1024.0)
    >>> round(auto_exp_window_tau(rec), 3)  # 1/tau + 1/0.5 = ln(100) / 0.97
    0.362

    The same decay 16 samples into a pre-cut record, with 32 samples of
    pretrigger asked for: measured up to 992 samples after the crossing, as in a
    record cut 32 samples before it.

    >>> late = np.concatenate([np.zeros(16), x[:-16]])
    >>> pre = TimeRecords(force=np.eye(1, 1024), response=late[None, :],
    ...                   sample_rate_hz=1024.0, trigger_s=16 / 1024)
    >>> cut = TimeRecords(force=np.eye(1, 1024), response=np.concatenate(
    ...     [np.zeros(32), x[:-32]])[None, :], sample_rate_hz=1024.0, trigger_s=32 / 1024)
    >>> auto_exp_window_tau(pre, np.array([16]), 32) == auto_exp_window_tau(cut, None, 32)
    True
    """
    n, fs = records.n_samples, records.sample_rate_hz
    at = np.full(records.n_averages, int(round(records.trigger_s * fs)))
    if trigger_offsets is not None:
        at = np.asarray(trigger_offsets, dtype=int)
    n_tail = max(8, n // 16)
    span = n - max(int(pretrigger_n), int(at.max()))  # samples after every trigger
    if span < n_tail + 1:  # a pretrigger asked for that the records cannot follow
        span = n - int(at.max())
    # each record from its crossing for ``span`` samples: the peak after the
    # trigger and the level over the stretch's last n_tail samples
    after = np.stack([records.response[k, :, a:a + span] for k, a in enumerate(at)])
    end, _ = tail_level(after, 0, n_tail)
    r = float(np.median(end.max(axis=1)))
    if not r > AUTO_TAU_LEVEL:
        return None
    t_mid = (span - n_tail / 2) / fs
    return t_mid / float(np.log(r / AUTO_TAU_LEVEL))


def force_band(freq_hz: np.ndarray, force_auto: np.ndarray) -> tuple[float, float]:
    """Frequencies where the force autospectrum falls 10 dB and 20 dB below its
    low-frequency level.

    The level is the median over the first 2 % of the lines (at least 3, DC
    excluded); the spectrum is smoothed over 5 lines; each point is the first
    line below the level minus 10 (20) dB, the last frequency when there is none.

    Examples
    --------
    >>> f = np.linspace(0.0, 1000.0, 1001)
    >>> s = 1.0 / (1.0 + (f / 100.0) ** 4)  # -10 dB at 173.2 Hz, -20 dB at 315.4 Hz
    >>> tuple(round(x) for x in force_band(f, s))
    (174, 316)
    """
    power = np.convolve(np.asarray(force_auto, dtype=float), np.ones(5) / 5, mode="same")
    db = 10 * np.log10(np.maximum(power, np.finfo(float).tiny))
    n_ref = max(3, db.size // 50)
    ref = float(np.median(db[1:1 + n_ref]))
    out = []
    for drop in (10.0, 20.0):
        below = np.flatnonzero(db[1:] < ref - drop)
        out.append(float(freq_hz[1 + below[0]]) if below.size else float(freq_hz[-1]))
    return out[0], out[1]


def hits_columns(hits: tuple[Hit, ...] | list[Hit]) -> dict[str, list]:
    """The hit table as columns ``hit,time_s,force_peak_n,accepted,reasons,note``
    (reasons joined by ``;``; ``note``: a record padded at the front, e.g.
    ``pretrigger 3 ms of 10 ms: 7 ms padded``), for a CSV or a report.

    Examples
    --------
    >>> hits_columns([Hit(1, 0.5, 120.0, False, ("double_hit", "overload"))])["reasons"]
    ['double_hit;overload']
    """
    return {
        "hit": [h.index for h in hits],
        "time_s": [h.time_s for h in hits],
        "force_peak_n": [h.force_peak_n for h in hits],
        "accepted": [h.accepted for h in hits],
        "reasons": [";".join(h.reasons) for h in hits],
        "note": [hit_note(h) for h in hits],
    }


def hit_note(hit: Hit) -> str:
    """The hit table's note of a hit: its record padded at the front, else ``""``.

    Examples
    --------
    >>> hit_note(Hit(1, 0.003, 90.0, True, (), 0, padded=13))
    'near the data start: its record padded with 13 samples before the data'
    """
    if not hit.padded or hit.record_start < 0:
        return ""
    return f"near the data start: its record padded with {hit.padded} samples before the data"
