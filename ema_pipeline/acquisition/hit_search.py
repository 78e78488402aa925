"""Finding the hits of an impact recording on its force channel, and placing and
cutting their records.

Numerics only (no files): a :class:`~ema_pipeline.data.Recording` in, a
:class:`HitSearch` and :class:`~ema_pipeline.data.TimeRecords` out; the checks of
the hits are :mod:`ema_pipeline.acquisition.hit_checks`, and
:mod:`ema_pipeline.acquisition.hits` gathers both. The rules, with their constants
(module attributes):

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import MIN_DF_HZ, DataError, Recording, TimeRecords

__all__ = [
    "BOUNCE_WINDOW_S",
    "MAX_EXP_WINDOW_TAU_S",
    "MAX_PRETRIGGER_S",
    "MAX_RECORD_LENGTH_S",
    "NOISE_FACTOR",
    "PULSE_GAP_S",
    "TRIGGER_FRACTION",
    "HitSearch",
    "cut_records",
    "find_hits",
    "found_force",
    "pulse_end",
    "pulse_end_s",
    "recording_segments",
]

TRIGGER_FRACTION = 0.05
NOISE_FACTOR = 8.0
BOUNCE_WINDOW_S = 0.1
PULSE_GAP_S = 0.5e-3
#: Longest pretrigger, record length (also force window) and exponential window
#: time constant (s) a setting may give: the limits of the experiment file's ``frf``
#: table and of ``ema-pipeline frf``'s options.
MAX_PRETRIGGER_S = 1e3
MAX_RECORD_LENGTH_S = 1e4
MAX_EXP_WINDOW_TAU_S = 1e4


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


def recording_segments(recording: Recording) -> list[tuple[int, int]]:
    """The [start, end) samples of each segment of ``recording``.

    Examples
    --------
    >>> from ema_pipeline.data import Channel
    >>> rec = Recording(np.zeros((1, 10)), 100.0, (Channel("f", "force"),), (0, 4))
    >>> recording_segments(rec)
    [(0, 4), (4, 10)]
    """
    starts = list(recording.segment_starts) + [recording.n_samples]
    return list(zip(starts[:-1], starts[1:], strict=True))


def _centred_force(recording: Recording, force_index: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Force minus its median per segment, with the polarity of its largest excursion."""
    force = recording.signals[force_index]
    g = np.empty_like(force)
    offsets = []
    for a, b in recording_segments(recording):
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
    longest = max(b - a for a, b in recording_segments(recording))  # samples
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
    for seg, (a, b) in enumerate(recording_segments(recording)):
        above = g[a:b] > trigger
        ups = np.flatnonzero(~above[:-1] & above[1:]) + 1 + a
        last = -bounce - 1
        for c in ups:
            if c - last > bounce:
                crosses.append(int(c))
                segment.append(seg)
                last = int(c)
    segments = recording_segments(recording)
    cut = ("; the force is above the trigger from the first sample on (a hit cut off by the "
           "start of the data)") if any(g[a] > trigger for a, _ in segments) else ""
    if not crosses:
        raise DataError(f"{where}no hit found: the force never crosses the trigger "
                        f"({trigger:.4g} N) upwards{cut}")
    cross = np.array(crosses)
    seg_arr = np.array(segment)
    frac = (trigger - g[cross - 1]) / (g[cross] - g[cross - 1])
    time_s = (cross - 1 + frac) / fs
    ends = np.array([e for _, e in recording_segments(recording)])
    peaks = np.empty(cross.size)
    for k, c in enumerate(cross):
        stop = pulse_end(g, c, trigger, min(int(ends[seg_arr[k]]), c + bounce), fs)
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


def pulse_end(g: np.ndarray, c: int, level: float, hi: int, fs: float) -> int:
    """First sample after the crossing ``c`` from which the force stays at or below
    ``level`` for ``PULSE_GAP_S`` (at least 2 samples): ringing of an anti-aliasing
    filter that crosses the level again belongs to the pulse; ``hi`` when it never does.

    Examples
    --------
    >>> g = np.array([0.0, 5.0, 9.0, 4.0, 0.0, 0.0, 0.0])
    >>> pulse_end(g, 1, 1.0, g.size, 1000.0)  # below 1 from sample 4 on, for 2 samples
    4
    """
    need = max(2, int(round(PULSE_GAP_S * fs)))
    below = g[c:hi] <= level
    if below.size < need:
        return hi
    run = np.convolve(below.astype(int), np.ones(need, dtype=int), mode="valid")
    full = np.flatnonzero(run == need)
    return c + int(full[0]) if full.size else hi


def found_force(recording: Recording, force_index: int, found: HitSearch) -> np.ndarray:
    """The force centred and turned as :func:`find_hits` did (its offsets, polarity).

    Examples
    --------
    >>> from ema_pipeline.data import Channel
    >>> force = np.full((1, 4096), 2.0)
    >>> force[0, [500, 1700, 3500]] = [-98.0, -78.0, -88.0]  # hits downwards, offset 2 N
    >>> rec = Recording(force, 1024.0, (Channel("hammer", "force"),))
    >>> found_force(rec, 0, find_hits(rec, 0, pretrigger_s=0.01))[[0, 500]].tolist()
    [-0.0, 100.0]
    """
    g = recording.signals[force_index].copy()
    for (a, b), offset in zip(recording_segments(recording), found.offset_n, strict=True):
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
    g = found_force(recording, force_index, found)
    fs, n = recording.sample_rate_hz, found.n_samples
    latest = 0.0
    for k in np.asarray(which, dtype=int):
        a = int(found.start[k])
        if a < 0:
            continue
        c = int(found.cross[k])
        pad = int(found.padding()[k])
        end = pulse_end(g, c, found.trigger_n, a + n - pad, fs)
        latest = max(latest, (end - a + pad) / fs)
    return latest


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
