"""The close-partner split fit (``refinement.local_fits.split_fit``): one
pole more in a kept mode's local fit, started on the side of the mode where
the fit without it leaves more of the residual."""

from __future__ import annotations

import numpy as np
import pytest

from ema_pipeline.identification.refinement.local_fits import split_fit
from ema_pipeline.identification.thresholds import SelectionThresholds

TH = SelectionThresholds()  # the tuned defaults


def _pair(partner_hz: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two channels of a mode at 100 Hz (zeta 0.5 %) and a weaker partner at
    ``partner_hz`` with another shape, 1e-5 noise; the lines, the FRFs and
    the strong mode's pole (rad/s)."""
    f = np.linspace(80.0, 120.0, 801)
    lam = np.array([-np.pi + 2j * np.pi * 100.0, -np.pi + 2j * np.pi * partner_hz])
    jw = 2j * np.pi * f
    H = np.stack([1 / (jw - lam[0]) + 0.5 / (jw - lam[1]),
                  1 / (jw - lam[0]) - 0.5 / (jw - lam[1])])
    H = H + 1e-5 * np.random.default_rng(seed).standard_normal(H.shape)
    return f, H, lam[:1]


def _single() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two channels of one mode at 100 Hz (zeta 0.5 %), 1e-5 noise: the
    lines, the FRFs and its pole (rad/s)."""
    f = np.linspace(80.0, 120.0, 801)
    lam = np.array([-np.pi + 2j * np.pi * 100.0])
    jw = 2j * np.pi * f
    H = np.stack([1 / (jw - lam[0]), 0.7 / (jw - lam[0])])
    return f, H + 1e-5 * np.random.default_rng(2).standard_normal(H.shape), lam


@pytest.mark.parametrize("partner_hz", [99.4, 100.6])
def test_a_partner_on_either_side_is_found(partner_hz: float, monkeypatch) -> None:
    """The extra pole starts on the partner's side (where the fit without it
    leaves more of the residual), once, and converges to it, below the mode
    as above it: the two poles at 100.0 Hz and the partner within 0.01 Hz,
    the residual variance down by more than 100 times."""
    from ema_pipeline.identification.refinement import local_fits

    starts: list[np.ndarray] = []
    real_fit = local_fits.vp_fit

    def recorded(f, Y, poles, background, max_iter, **kw):
        starts.append(poles.copy())
        return real_fit(f, Y, poles, background, max_iter, **kw)

    monkeypatch.setattr(local_fits, "vp_fit", recorded)
    f, H, pole = _pair(partner_hz, seed=1)
    fit = split_fit(f, H, pole, 0, quantity=None, thresholds=TH)
    extra = [s[-1] for s in starts if s.size == 2]  # the split's start(s)
    assert len(extra) == 1
    assert np.sign(extra[0].imag - pole[0].imag) == np.sign(partner_hz - 100.0)
    got = np.sort(fit.pole.imag / (2 * np.pi))
    np.testing.assert_allclose(got, np.sort([100.0, partner_hz]), atol=0.01)
    assert fit.residual_ratio < 0.01


def test_noise_alone_leaves_the_residual() -> None:
    """A single mode: the extra pole finds only noise, the residual variance
    stays within 20 % of the fit without it."""
    f, H, lam = _single()
    fit = split_fit(f, H, lam, 0, quantity=None, thresholds=TH)
    assert fit is not None and fit.residual_ratio > 0.8


def test_a_split_that_fails_its_ratio_stops_with_the_same_ratio() -> None:
    """The residual ratio is known once the second weighting round has its
    weights: with ``max_ratio`` below it, the noise-only split stops there
    (not finished, no covariance, fewer iterations) with the ratio of the
    finished fit to the last bit; a true partner passes and its fit is the
    finished one's, pole for pole."""
    f, H, lam = _single()
    full = split_fit(f, H, lam, 0, quantity=None, thresholds=TH)
    stopped = split_fit(f, H, lam, 0, quantity=None, max_ratio=0.75, thresholds=TH)
    assert full.finished and not stopped.finished
    assert full.residual_ratio > 0.8
    assert stopped.residual_ratio == full.residual_ratio
    assert stopped.fit.n_iter < full.fit.n_iter
    assert np.isnan(stopped.cov).all() and np.isfinite(full.cov).all()
    # a ratio at or below max_ratio: the finished fit, the same numbers
    kept = split_fit(f, H, lam, 0, quantity=None, max_ratio=1.0, thresholds=TH)
    assert kept.finished and np.array_equal(kept.pole, full.pole)

    f, H, pole = _pair(100.6, seed=1)
    full = split_fit(f, H, pole, 0, quantity=None, thresholds=TH)
    passed = split_fit(f, H, pole, 0, quantity=None, max_ratio=0.75, thresholds=TH)
    assert passed.finished and passed.residual_ratio < 0.01
    assert np.array_equal(passed.pole, full.pole)
    np.testing.assert_array_equal(passed.cov, full.cov)
