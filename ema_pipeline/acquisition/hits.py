"""Hits of an impact recording: find them on the force channel, check them, cut records.

Numerics only (no files): a :class:`~ema_pipeline.data.Recording` in, hit tables and
:class:`~ema_pipeline.data.TimeRecords` out; :func:`ema_pipeline.acquisition.estimate_frf`
makes the FRFs. The rules live beside their code, with their constants:

* finding the hits, placing and cutting their records:
  :mod:`ema_pipeline.acquisition.hit_search`;
* the checks (the reasons a hit is not averaged, :data:`REASONS`):
  :mod:`ema_pipeline.acquisition.hit_checks`;
* here: the exponential window ``auto``, the usable band of the force spectrum, the
  warnings about the force channel and the hit table. The names of the other two
  are re-exported here (``from ema_pipeline.acquisition.hits import find_hits``).

The exponential window ``auto`` (:func:`auto_exp_window_tau`) brings the response
level at the record end (as above, median over the hits of the largest over the
responses) to ``AUTO_TAU_LEVEL`` (1 %); a response already below that needs none.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.acquisition.hit_checks import (
    CLIP_RUN,
    DOUBLE_HIT_FRACTION,
    FINE_STEPS,
    FULL_SCALE_FRACTION,
    GUARD_S,
    LEFT_OUT_BY_HAND,
    LOW_FORCE_FRACTION,
    NOT_DECAYED_LEVEL,
    OUTLIER_MISMATCH,
    OUTLIER_RATIO,
    OUTLIER_Z,
    REASONS,
    RIPPLE_DB,
    RIPPLE_WINDOW_S,
    Hit,
    check_hits,
    frf_agreement,
    tail_level,
)
from ema_pipeline.acquisition.hit_search import (
    BOUNCE_WINDOW_S,
    MAX_EXP_WINDOW_TAU_S,
    MAX_PRETRIGGER_S,
    MAX_RECORD_LENGTH_S,
    NOISE_FACTOR,
    PULSE_GAP_S,
    TRIGGER_FRACTION,
    HitSearch,
    cut_records,
    find_hits,
    pulse_end_s,
)
from ema_pipeline.data import TimeRecords

__all__ = [
    "AUTO_TAU_LEVEL",
    "BOUNCE_WINDOW_S",
    "CLIP_RUN",
    "DOUBLE_HIT_FRACTION",
    "FINE_STEPS",
    "FULL_SCALE_FRACTION",
    "GUARD_S",
    "LEFT_OUT_BY_HAND",
    "LOW_FORCE_FRACTION",
    "MAX_EXP_WINDOW_TAU_S",
    "MAX_PRETRIGGER_S",
    "MAX_RECORD_LENGTH_S",
    "NOISE_FACTOR",
    "NOT_DECAYED_LEVEL",
    "OUTLIER_MISMATCH",
    "OUTLIER_RATIO",
    "OUTLIER_Z",
    "PLAUSIBLE_HAMMER_PEAK_N",
    "PULSE_GAP_S",
    "REASONS",
    "RESPONSE_LIKE_DOUBLE_SHARE",
    "RIPPLE_DB",
    "RIPPLE_WINDOW_S",
    "TRIGGER_FRACTION",
    "Hit",
    "HitSearch",
    "auto_exp_window_tau",
    "check_hits",
    "cut_records",
    "find_hits",
    "force_band",
    "force_warnings",
    "frf_agreement",
    "hit_note",
    "hits_columns",
    "pulse_end_s",
    "tail_level",
]

AUTO_TAU_LEVEL = 0.01

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
