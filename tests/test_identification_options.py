"""Every option of ``IdentificationOptions`` changes the result, in the direction
its documentation gives, checked against the known truth of simulated data.

Options tested elsewhere: ``band_hz`` and ``max_order`` (test_identification.py:
test_band_of_few_lines_finds_its_modes, test_too_few_lines_for_order), ``method``
(test_sdypy_backend_agrees), ``expect_hz`` (test_expect_picks_nearest_clusters),
``weighting`` (test_coherence_weighting_helps_against_a_bad_channel).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hardcases import make_case

from ema_pipeline.acquisition import modal_frf
from ema_pipeline.data import FRFSet, ModalParameters
from ema_pipeline.identification import SelectionThresholds, doubtful_reasons, identify

# four modes; a band of 50-110 Hz leaves 30 Hz below it and 160 Hz above it
FREQ = np.linspace(0.0, 200.0, 2001)
TRUTH = ModalParameters(fn_hz=[30.0, 70.0, 85.0, 160.0], zeta=[0.01, 0.01, 0.012, 0.01])
PHI_OUT = np.array([[1.0, 0.5, 0.7, 1.0], [0.3, -1.0, 0.6, 0.8]])
PHI_IN = np.array([[1.0, -0.8, 0.9, 0.7]])


@pytest.fixture(scope="module")
def mimo():
    """Hard case mimo-1 (6 modes, 2 references, noisy) and its fixed-order run."""
    case = make_case("mimo", 1)
    base = identify(case.frf, band_hz=case.band_hz, max_order=40, refine=False)
    return case, base


def test_stabilization_tolerances_reach_the_selection(mimo):
    """Stricter tolerances (1 %/30 %/0.05 -> 0.2 %/10 %/0.01) break the pole
    trajectories into more pieces, each mode's trajectory holds fewer orders and
    the diagram flags fewer poles stable; looser ones (3 %/60 %/0.15) the
    opposite. The same diagram (fixed order): only the linking differs. The
    trajectory medians move with them (refine=False reports them)."""
    case, base = mimo
    run = {"band_hz": case.band_hz, "max_order": 40, "refine": False}
    strict = identify(case.frf, tol_freq=0.002, tol_zeta=0.1, tol_mac=0.01, **run)
    loose = identify(case.frf, tol_freq=0.03, tol_zeta=0.6, tol_mac=0.15, **run)
    assert base.settings.tol_zeta == 0.3 and strict.settings.tol_zeta == 0.1
    n_traj = [np.unique(r.stabilization.cluster).size for r in (strict, base, loose)]
    assert n_traj[0] > n_traj[1] > n_traj[2], n_traj
    members = [r.selected.n_members for r in (strict, base, loose)]
    assert all(m.size == case.fn_hz.size for m in members)  # the six true modes, each time
    assert np.all(members[0] <= members[1]) and np.any(members[0] < members[1])
    assert np.all(members[2] >= members[1]) and np.any(members[2] > members[1])
    n_stable = [int(r.stabilization.stable.sum()) for r in (strict, base, loose)]
    assert n_stable[0] < n_stable[1] < n_stable[2], n_stable
    assert strict.stabilization.tol_zeta == 0.1 and base.stabilization.tol_zeta == 0.05
    for other in (strict, loose):
        assert np.max(np.abs(other.fn_hz - base.fn_hz) / base.fn_hz) > 1e-4


def test_min_fraction_drops_short_trajectories(mimo):
    """min_fraction 0.6 of the 40 orders: the true modes at 18.2 and 23.4 Hz,
    whose trajectories hold 18 and 17 orders at 0.3, are no longer modes."""
    case, base = mimo
    n_orders = base.settings.orders.size
    assert n_orders == 40 and base.modes.n_modes == 6
    strict = identify(case.frf, band_hz=case.band_hz, max_order=40, refine=False,
                      min_fraction=0.6)
    long_enough = base.selected.n_members >= 0.6 * n_orders
    assert long_enough.sum() == 4
    np.testing.assert_allclose(strict.fn_hz, base.fn_hz[long_enough], rtol=1e-9)
    np.testing.assert_allclose(strict.fn_hz, case.fn_hz[2:], rtol=1e-4)


def test_refine_moves_the_poles_to_the_truth(mimo):
    """The variable-projection refinement against the trajectory medians: the
    damping of mimo-1's six modes within 2 % of the truth instead of up to 30 %."""
    case, base = mimo
    refined = identify(case.frf, band_hz=case.band_hz, max_order=40)
    err_median = np.abs(base.zeta - case.zeta) / case.zeta
    err_refined = np.abs(refined.zeta - case.zeta) / case.zeta
    assert err_median.max() > 0.2 and err_refined.max() < 0.02
    assert np.abs(refined.fn_hz - case.fn_hz).max() < 0.2 * np.abs(base.fn_hz - case.fn_hz).max()
    assert refined.settings.uncertainty.startswith("least-squares")
    assert base.settings.uncertainty.startswith("scatter")


def test_residual_terms_stand_for_the_modes_outside_the_band():
    """Noise-free data, band 50-110 Hz: the modes at 30 Hz (below) and 160 Hz
    (above) are what the lower and upper residual terms stand for. Without
    either the synthesis misses them (larger error), and the term is zero."""
    H = modal_frf(FREQ, TRUTH, PHI_OUT, PHI_IN)
    frf = FRFSet(freq_hz=FREQ, H=H)
    error = {}
    for lower in (True, False):
        for upper in (True, False):
            res = identify(frf, band_hz=(50, 110), lower_residual=lower, upper_residual=upper)
            np.testing.assert_allclose(res.fn_hz, [70.0, 85.0], rtol=1e-6)
            assert np.any(res.lower_residual != 0) == lower
            assert np.any(res.upper_residual != 0) == upper
            error[lower, upper] = float(np.mean(res.error))
    assert error[True, True] < 0.01
    assert error[False, True] > 5 * error[True, True]
    assert error[True, False] > 5 * error[True, True]
    assert error[False, False] > max(error[False, True], error[True, False])


def test_exp_window_tau_s_corrects_the_damping():
    """FRFs under an exponential window (tau 0.5 s) that do not record it: the
    damping is that of the windowed FRF, zeta + 1/(tau omega_n), unless the
    option gives tau."""
    tau = 0.5
    H = modal_frf(FREQ, TRUTH, PHI_OUT, PHI_IN, extra_decay=1 / tau)
    frf = FRFSet(freq_hz=FREQ, H=H)
    windowed = identify(frf)
    corrected = identify(frf, exp_window_tau_s=tau)
    wn = 2 * np.pi * TRUTH.fn_hz
    np.testing.assert_allclose(windowed.zeta, TRUTH.zeta + 1 / (tau * wn), rtol=1e-3)
    np.testing.assert_allclose(corrected.zeta, TRUTH.zeta, rtol=1e-3)
    np.testing.assert_allclose(corrected.fn_hz, TRUTH.fn_hz, rtol=1e-6)


def test_thresholds_are_passed_down(mimo):
    """``thresholds`` reaches the final tests (a decay rate determined to 1e-9
    is never; no mode is kept) and the doubtful rule (every mode is stable at
    fewer than 1000 orders)."""
    case, _ = mimo
    never = replace(SelectionThresholds(), max_rel_decay_std=1e-9)
    assert identify(case.frf, band_hz=case.band_hz, max_order=40,
                    thresholds=never).modes.n_modes == 0
    strict = replace(SelectionThresholds(), min_stable_orders=1000)
    res = identify(case.frf, band_hz=case.band_hz, max_order=40, refine=False,
                   thresholds=strict)
    assert res.settings.thresholds is strict
    assert all("few_stable_orders" in r for r in doubtful_reasons(res))
