"""Resonances the FRFs show but no mode was kept for
(:mod:`ema_pipeline.identification.selection.not_kept`)."""

from __future__ import annotations

import numpy as np
import pytest

from ema_pipeline.identification.selection.not_kept import (
    not_kept_message,
    prominent_peaks,
    resonances_not_kept,
    visible_peaks,
)
from ema_pipeline.identification.thresholds import SelectionThresholds

TH = SelectionThresholds()  # the tuned defaults

MIN_FRF_SHARE = SelectionThresholds().min_frf_share

FREQ = np.linspace(0.0, 200.0, 801)  # 0.25 Hz lines


def mode(fn_hz: float, zeta: float = 0.005) -> np.ndarray:
    """Receptance of one mode (unit residue) on FREQ."""
    wn = 2 * np.pi * fn_hz
    lam = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    jw = 2j * np.pi * FREQ
    return 1 / (jw - lam) + 1 / (jw - np.conj(lam))


def pole(fn_hz: float, zeta: float = 0.005) -> complex:
    wn = 2 * np.pi * fn_hz
    return complex(-zeta * wn, wn * np.sqrt(1 - zeta**2))


def frfs(n_ch: int, n_seeing_weak: int, weak_hz: float = 110.0) -> np.ndarray:
    """n_ch FRFs of a strong mode at 100 Hz; the first n_seeing_weak of them
    sit on its nodal line (strong mode 1000 times smaller) and see a weak mode
    at weak_hz, 30 times smaller than the strong mode elsewhere."""
    rng = np.random.default_rng(3)
    H = np.empty((n_ch, FREQ.size), complex)
    for c in range(n_ch):
        strong = (1e-3 if c < n_seeing_weak else 1.0) * rng.uniform(0.5, 1.5)
        weak = 1 / 30 if c < n_seeing_weak else 0.0
        H[c] = strong * mode(100.0) + weak * mode(weak_hz)
    return H + 1e-6 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))


def test_a_rejected_resonance_seen_by_enough_frfs_is_listed() -> None:
    n_ch = 10
    kept = np.array([pole(100.0)])
    rejected = np.array([pole(110.2)])  # the rejected candidate, a little off the peak
    need = int(np.ceil(MIN_FRF_SHARE * n_ch))
    f_hz, n = resonances_not_kept(FREQ, frfs(n_ch, need), rejected, kept, thresholds=TH)
    assert f_hz.size == 1 and n.tolist() == [need]
    assert f_hz[0] == pytest.approx(110.2, abs=0.01)
    f_hz, n = resonances_not_kept(FREQ, frfs(n_ch, need - 1), rejected, kept, thresholds=TH)
    assert f_hz.size == 0  # seen by fewer than MIN_FRF_SHARE of the FRFs


def test_peaks_of_kept_modes_never_count() -> None:
    """A rejected pole inside the kept mode's half-power band (a split of it)
    is not a resonance of its own, though all FRFs peak there."""
    H = frfs(8, 0)
    kept = np.array([pole(100.0)])
    f_hz, _ = resonances_not_kept(FREQ, H, np.array([pole(100.3, 0.01)]), kept, thresholds=TH)
    assert f_hz.size == 0
    # without the kept mode, every FRF has that peak
    assert visible_peaks(FREQ, H, np.array([100.3]), 1.0, thresholds=TH).tolist() == [8]


def test_one_entry_per_resonance() -> None:
    """Two rejected poles on one peak: one entry."""
    f_hz, n = resonances_not_kept(FREQ, frfs(6, 3), np.array([pole(110.0), pole(110.2)]),
                                  np.array([pole(100.0)]), thresholds=TH)
    assert f_hz.size == 1 and n.tolist() == [3]


def test_message_names_each_resonance() -> None:
    text = not_kept_message(np.array([42.06, 274.69]), np.array([9, 16]), 30)
    assert "42.1 Hz (a peak in 9 of 30 FRFs)" in text
    assert "274.7 Hz (a peak in 16 of 30 FRFs)" in text
    assert not_kept_message(np.zeros(0), np.zeros(0, int), 30) == ""


def test_prominent_peaks_are_scipy_find_peaks():
    """The numpy peak finder returns scipy.signal.find_peaks' indices (flat
    tops, ends, far and near higher ground, several prominence thresholds)."""
    from scipy.signal import find_peaks

    rng = np.random.default_rng(3)
    for t in range(600):
        n = int(rng.integers(1, 300))
        # quantised samples give flat tops; a random walk gives far higher ground
        x = rng.integers(0, 5, n).astype(float) if t % 2 else rng.standard_normal(n).cumsum()
        for p_min in (0.0, 0.4, 2.0):
            assert np.array_equal(prominent_peaks(x, p_min), find_peaks(x, prominence=p_min)[0])
