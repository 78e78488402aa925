"""A local fit that wanders far from its start stops in its first weighting
round (``SelectionThresholds.refine_stop_shift``), with the outcome of the fit
run to the end: its start pole and the covariance there."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ema_pipeline.data import OptionError
from ema_pipeline.identification.refinement import refine
from ema_pipeline.identification.refinement.refine import refine_poles
from ema_pipeline.identification.thresholds import SelectionThresholds

FREQ = np.linspace(50.0, 250.0, 1601)
_VP_FIT = refine.vp_fit
LAM = -2.0 + 2j * np.pi * 100.0


def _frfs() -> np.ndarray:
    """Three channels of one mode at 100 Hz (receptance) with 2e-4 noise."""
    jw = 2j * np.pi * FREQ
    rng = np.random.default_rng(3)
    H = np.stack([a * (1 / (jw - LAM) + 1 / (jw - np.conj(LAM))) for a in (1.0, -0.6, 0.3)])
    return H + 2e-4 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))


def _refined(monkeypatch: pytest.MonkeyPatch, start: complex, stop_shift: float):
    """``refine_poles`` of ``start`` alone and its local fits as they ended
    (iterations, whether both rounds ran)."""
    fits: list[tuple[int, bool]] = []

    def spy(*args, **kwargs):
        fit = _VP_FIT(*args, **kwargs)
        fits.append((fit.n_iter, fit.finished))
        return fit

    monkeypatch.setattr(refine, "vp_fit", spy)
    th = replace(SelectionThresholds(), refine_stop_shift=stop_shift)
    ref = refine_poles(FREQ, _frfs(), np.array([start]), quantity="receptance", thresholds=th)
    return ref, fits


def test_a_fit_that_wanders_far_stops_in_its_first_round(monkeypatch) -> None:
    """Started 3 Hz above the mode with a decay rate of 1/s, the fit runs to the
    mode, 15 times its reach (0.5 decay rates plus a line, 1.3 rad/s) away:
    by default it stops in the first round, once 3 times the reach away;
    with ``refine_stop_shift=inf`` it runs both rounds. Either way the
    refinement wandered off: the start pole is kept with the covariance and
    noise of the fit there (a fit of no iterations), to the last bit."""
    start = -1.0 + 2j * np.pi * 103.0
    stopped, fits = _refined(monkeypatch, start, SelectionThresholds().refine_stop_shift)
    full, full_fits = _refined(monkeypatch, start, np.inf)
    assert stopped.pole[0] == full.pole[0] == start
    np.testing.assert_array_equal(stopped.cov, full.cov)
    np.testing.assert_array_equal(stopped.noise_std, full.noise_std)
    assert np.all(np.isfinite(stopped.cov))
    # the first fit: stopped in its first round, fewer iterations than in full
    assert fits[0][1] is False and full_fits[0][1] is True
    assert 0 < fits[0][0] < full_fits[0][0]
    # the second: the start pole's fit of no iterations, in both
    assert len(fits) == len(full_fits) == 2
    assert fits[1] == full_fits[1] == (0, True)


def test_a_fit_near_its_start_runs_both_rounds(monkeypatch) -> None:
    """Started at the mode, the fit stays within its reach: both rounds run and
    the refined pole is the one of ``refine_stop_shift=inf``, to the last bit,
    within 1 % of the decay rate of the truth."""
    start = LAM * (1 + 1e-4)
    ref, fits = _refined(monkeypatch, start, SelectionThresholds().refine_stop_shift)
    full, _ = _refined(monkeypatch, start, np.inf)
    assert len(fits) == 1 and fits[0][1] is True
    assert ref.pole[0] == full.pole[0]
    np.testing.assert_array_equal(ref.cov, full.cov)
    assert abs(ref.pole[0] - LAM) < 0.01 * abs(LAM.real) + 0.01


def test_refine_stop_shift_is_at_least_one() -> None:
    """A fit stopped closer than ``refine_max_shift`` would not count as
    wandered off and would leave an unfinished fit: refused by name."""
    for bad in (0.0, 0.5, float("nan")):
        with pytest.raises(OptionError, match="refine_stop_shift"):
            SelectionThresholds(refine_stop_shift=bad)
    assert SelectionThresholds(refine_stop_shift=1.0).refine_stop_shift == 1.0
