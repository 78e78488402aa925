"""Hits judged on the stream of one hammer point, and its running FRF.

The samples of the current point grow block by block (:meth:`PointStream.append`).
A cheap look at each new block (the force above a provisional trigger:
:data:`~ema_pipeline.acquisition.hits.TRIGGER_FRACTION` of the largest pulse so
far and :data:`~ema_pipeline.acquisition.hits.NOISE_FACTOR` times the noise)
only decides *when* to judge: once a pulse's record is complete (its record
length known) or the next pulse has come. The judgement itself is ``frf``'s:
:func:`~ema_pipeline.acquisition.hits.find_hits` and
:func:`~ema_pipeline.acquisition.hits.check_hits` on the point's data so far.
A hit, once judged, keeps its verdict; the hits that the data after it
completes are added in time order. A hit whose record touches samples lost in
a dropout is rejected with the reason ``data_lost``.

The running FRF of the point is ``frf``'s too: the accepted hits cut
(:func:`~ema_pipeline.pipeline.frf.cut_impact_hits`, by hand: exactly those
accepted) and averaged (:func:`~ema_pipeline.pipeline.frf.estimate_impact_frf`,
H1 by :func:`~ema_pipeline.acquisition.estimate_frf_windows`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ema_pipeline.acquisition import hits as hitlib
from ema_pipeline.data import DataError, FRFSet, Provenance, Recording
from ema_pipeline.pipeline.frf import (
    FRFSettings,
    cut_impact_hits,
    estimate_impact_frf,
    impact_channels,
)

__all__ = ["DATA_LOST", "LiveHit", "PointStream", "match_hits"]

#: The reason of a hit whose record touches samples lost in a dropout.
DATA_LOST = "data_lost"


@dataclass
class LiveHit:
    """A hit judged live: ``number`` (1-based, in the point), ``time_s`` from the
    point's start, ``peak_n``, the checks' ``reasons`` and verdict ``auto``,
    ``accepted`` (the verdict, or the choice by hand), ``record_end_s`` (the stream
    time of its record's last sample) and ``record_end_wall`` (when that sample
    arrived, ``time.time()``)."""

    number: int
    time_s: float
    peak_n: float
    reasons: tuple[str, ...]
    auto: bool
    accepted: bool
    record_end_s: float = 0.0
    record_end_wall: float = 0.0

    def as_dict(self) -> dict:
        return {"number": self.number, "time_s": self.time_s, "peak_n": self.peak_n,
                "reasons": list(self.reasons), "auto": self.auto, "accepted": self.accepted,
                "record_end_s": self.record_end_s, "record_end_wall": self.record_end_wall}

    @classmethod
    def from_dict(cls, d: dict) -> LiveHit:
        return cls(int(d["number"]), float(d["time_s"]), float(d["peak_n"]),
                   tuple(d["reasons"]), bool(d["auto"]), bool(d["accepted"]),
                   float(d.get("record_end_s", 0.0)), float(d.get("record_end_wall", 0.0)))


def match_hits(times_s: np.ndarray, found_s: np.ndarray, tol_s: float) -> np.ndarray:
    """For each time of ``times_s`` the index of the nearest of ``found_s`` within
    ``tol_s``, else -1.

    Examples
    --------
    >>> match_hits(np.array([0.5, 2.6, 9.0]), np.array([0.5001, 2.6, 4.7]), 1e-3).tolist()
    [0, 1, -1]
    """
    if found_s.size == 0:
        return np.full(np.size(times_s), -1)
    gap = np.abs(np.asarray(times_s)[:, None] - found_s[None, :])
    best = np.argmin(gap, axis=1)
    return np.where(gap[np.arange(best.size), best] <= tol_s, best, -1)


class PointStream:
    """The samples of one point as they arrive, its hits judged and its running FRF
    (module docstring). ``record_n``: the record length in samples when known
    (``settings.record_length_s``, or learnt from a point with two hits)."""

    def __init__(self, channels: tuple, sample_rate_hz: float, settings: FRFSettings,
                 record_n: int | None = None, name: str = "") -> None:
        self.channels = channels
        self.fs = float(sample_rate_hz)
        self.settings = settings
        self.name = name
        if settings.record_length_s is not None:
            record_n = int(round(settings.record_length_s * self.fs))
        self.record_n = record_n
        self._buf = np.zeros((len(channels), 1 << 14), dtype=np.float32)
        self.n = 0
        self.hits: list[LiveHit] = []
        self.lost: list[tuple[int, int]] = []  # (first, end) samples lost
        self._wall: list[tuple[int, float]] = []  # (end sample, arrival time) per block
        self._pending: list[int] = []  # pulses seen, not yet judged
        self._base: float | None = None
        self._noise: float | None = None
        self._peak = 0.0
        self._last_pulse = -(1 << 40)
        self.frf: FRFSet | None = None

    # -- data ---------------------------------------------------------------
    @property
    def data(self) -> np.ndarray:
        return self._buf[:, :self.n]

    def _grow(self, need: int) -> None:
        if need > self._buf.shape[1]:
            bigger = np.zeros((self._buf.shape[0], max(need, 2 * self._buf.shape[1])),
                              dtype=np.float32)
            bigger[:, :self.n] = self._buf[:, :self.n]
            self._buf = bigger

    def append(self, data: np.ndarray, lost: int = 0, wall_s: float = 0.0) -> None:
        """Add a block (float32 already journaled); ``lost`` samples before it are
        held at the last value and remembered."""
        data = np.asarray(data, dtype=np.float32)
        if lost:
            self._grow(self.n + lost)
            last = self._buf[:, self.n - 1:self.n] if self.n else data[:, :1]
            self._buf[:, self.n:self.n + lost] = last
            self.lost.append((self.n, self.n + lost))
            self.n += lost
        self._grow(self.n + data.shape[1])
        first = self.n
        self._buf[:, first:first + data.shape[1]] = data
        self.n += data.shape[1]
        self._wall.append((self.n, wall_s))
        self._look(first)

    def _look(self, first: int) -> None:
        """Note the pulses of the force since sample ``first`` (when to judge)."""
        force = self._buf[0, :self.n]
        if self._base is None:
            if self.n < int(0.1 * self.fs):
                return
            head = force[:self.n].astype(float)
            self._base = float(np.median(head))
            d = np.diff(head)
            self._noise = float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0))
            first = 0
        g = np.abs(force[first:].astype(float) - self._base)
        if g.size == 0:
            return
        self._peak = max(self._peak, float(g.max()))
        level = self.trigger_n
        above = np.flatnonzero(g > level) + first
        bounce = int(round(hitlib.BOUNCE_WINDOW_S * self.fs))
        above = above[above > self._last_pulse + bounce]
        while above.size:  # one pulse per bounce window
            self._last_pulse = int(above[0])
            self._pending.append(self._last_pulse)
            above = above[above > self._last_pulse + bounce]

    @property
    def trigger_n(self) -> float:
        """The provisional trigger level above the force's offset (N)."""
        return max(hitlib.TRIGGER_FRACTION * self._peak,
                   hitlib.NOISE_FACTOR * (self._noise or 0.0))

    def due(self) -> bool:
        """Whether a pulse's record is complete (or a later pulse has come)."""
        if not self._pending:
            return False
        if len(self._pending) > 1:
            return True
        if self.record_n is None:
            return False
        n_pre = int(round(self.settings.pretrigger_s * self.fs))
        return self.n >= self._pending[0] - n_pre + self.record_n

    def recording(self) -> Recording:
        rec = Recording(self.data.astype(float), self.fs, self.channels,
                        source=Provenance(path=self.name))
        return impact_channels(rec, self.channels[0].name)[0]

    def _wall_of(self, sample: int) -> float:
        for end, wall in self._wall:
            if end >= sample:
                return wall
        return self._wall[-1][1] if self._wall else 0.0

    # -- judging ------------------------------------------------------------
    def judge(self, final: bool = False) -> list[LiveHit]:
        """Judge the hits whose records are complete (``final``: every hit, the
        point's data ended); returns the hits new since the last call."""
        if self.n < 2:
            return []
        rec = self.recording()
        length = None if self.record_n is None else self.record_n / self.fs
        try:
            found = hitlib.find_hits(rec, 0, pretrigger_s=self.settings.pretrigger_s,
                                     record_length_s=length)
        except DataError:
            if final or length is not None:
                self._pending.clear()
            return []
        checked = hitlib.check_hits(rec, 0, found,
                                    exp_window=self.settings.exp_window_tau is not None,
                                    keep_all=self.settings.keep_all)
        if self.record_n is None and found.n_hits >= 2 and found.start[0] >= 0:
            self.record_n = found.n_samples  # records of this length from now on
        tol = 2.0 / self.fs
        known = np.array([h.time_s for h in self.hits])
        new: list[LiveHit] = []
        for k, hit in enumerate(checked):
            if known.size and match_hits(np.array([hit.time_s]), known, tol)[0] >= 0:
                continue
            if hit.time_s < (self.hits[-1].time_s if self.hits else -1.0):
                continue
            last = k == found.n_hits - 1
            complete = found.start[k] >= 0 and (not last or length is not None)
            if not (complete or final):
                break
            end = int(found.start[k] - found.padding()[k] + found.n_samples)
            reasons = tuple(hit.reasons)
            if found.start[k] >= 0 and any(a < end and b > found.start[k] for a, b in self.lost):
                reasons += (DATA_LOST,)
            ok = hit.accepted and DATA_LOST not in reasons
            live = LiveHit(len(self.hits) + 1, float(hit.time_s), float(hit.force_peak_n),
                           reasons, ok, ok, min(end, self.n) / self.fs,
                           self._wall_of(min(end, self.n)))
            self.hits.append(live)
            new.append(live)
        judged_to = (self.hits[-1].time_s * self.fs) if self.hits else -1
        self._pending = [c for c in self._pending if c > judged_to + 2]
        if final:
            self._pending.clear()
        return new

    def accepted_numbers(self, final_found: bool = False) -> list[int]:
        """The hit numbers of ``find_hits`` on the whole data so far that are the
        accepted live hits (what ``hits.toml`` says for this point)."""
        if not any(h.accepted for h in self.hits):
            return []
        rec = self.recording()
        found = hitlib.find_hits(rec, 0, pretrigger_s=self.settings.pretrigger_s,
                                 record_length_s=self.settings.record_length_s)
        at = match_hits(np.array([h.time_s for h in self.hits if h.accepted]), found.time_s,
                        2.0 / self.fs)
        return sorted(int(k) + 1 for k in at if k >= 0)

    def running_frf(self) -> FRFSet | None:
        """The FRF of the accepted hits so far (None: none accepted)."""
        chosen = [h for h in self.hits if h.accepted]
        if not chosen:
            self.frf = None
            return None
        rec = self.recording()
        length = None if self.record_n is None else self.record_n / self.fs
        settings = replace(self.settings, record_length_s=length)
        try:
            found = hitlib.find_hits(rec, 0, pretrigger_s=settings.pretrigger_s,
                                     record_length_s=length)
            at = match_hits(np.array([h.time_s for h in chosen]), found.time_s, 2.0 / self.fs)
            numbers = [int(k) + 1 for k in at if k >= 0 and found.start[k] >= 0]
            if not numbers:
                return self.frf
            _, quantity = impact_channels(rec)
            cut = cut_impact_hits(rec, found, settings, quantity, chosen=numbers)
            self.frf = estimate_impact_frf(cut, settings, cut.tau_s).frf
        except DataError:
            pass
        return self.frf
