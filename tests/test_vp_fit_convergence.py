"""When a local fit's rounds stop (``refine.COST_REL_TOL``,
``refine.STEP_TOL_SIGMA``): a split fit that creeps along a flat valley stops
its first round on its cost, within a small fraction of sigma of the fit run
on; FRFs without noise are still fitted to the end (no pole found in misfit
left over)."""

from __future__ import annotations

import numpy as np
import pytest

from ema_pipeline.identification.refinement import refine
from ema_pipeline.identification.refinement.local_fits import split_fit
from ema_pipeline.identification.selection.edge_poles import edge_poles
from ema_pipeline.identification.thresholds import SelectionThresholds


def test_a_noise_free_edge_mode_is_found_alone() -> None:
    """The example of ``edge_poles`` (two modes, no noise, the one at 102 Hz
    past the band 20-100 Hz): one edge pole, at 102 Hz. With the first round
    stopped at 0.1 sigma (``STEP_TOL_SIGMA``), its misfit makes a second one
    at 102.27 Hz (measured); the cost criterion of 1e-6 does not stop a fit
    whose cost falls by orders of magnitude a step."""
    th = SelectionThresholds()
    f = np.arange(20.0, 104.25, 0.25)
    lam = np.array([-2.0 + 2j * np.pi * 60.0, -4.0 + 2j * np.pi * 102.0])
    jw = 2j * np.pi * f[:, None]
    H = ((1 / (jw - lam) + 1 / (jw - lam.conj())) @ np.array([[1.0, 0.5], [0.8, -1.0]])).T
    got, complete = edge_poles(f, H, (20.0, 100.0), lam[:1], "receptance", thresholds=th)
    assert complete and got.shape == (1,)
    np.testing.assert_allclose(got, lam[1:], rtol=1e-9)


@pytest.mark.parametrize(("seed", "fewer"), [(3, 1), (5, 2), (9, 1)])
def test_a_split_fit_that_creeps_stops_on_its_cost(monkeypatch, seed: int, fewer: int) -> None:
    """A split fit of a single mode with noise: the extra pole has nothing to
    fit and the first round creeps along a flat valley. Against the first
    round stopped at 1e-8 of its cost: ``fewer`` iterations less (measured:
    20, 14 and 30 at 1e-8), the residual ratio within 1e-5 of itself, the
    mode's pole within 0.01 of its sigma."""
    th = SelectionThresholds()
    f = np.linspace(80.0, 120.0, 801)
    lam = np.array([-3.0 + 2j * np.pi * 100.0])
    jw = 2j * np.pi * f
    mode = 1 / (jw - lam[0]) + 1 / (jw - np.conj(lam[0]))
    rng = np.random.default_rng(seed)
    H = np.stack([mode, -0.7 * mode])
    H = H + 2e-4 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    default = split_fit(f, H, lam, 0, quantity="receptance", thresholds=th)
    assert refine.COST_REL_TOL == (1e-6, 1e-8) and refine.STEP_TOL_SIGMA == 1e-3
    monkeypatch.setattr(refine, "COST_REL_TOL", (1e-8, 1e-8))
    tight = split_fit(f, H, lam, 0, quantity="receptance", thresholds=th)
    assert default.fit.n_iter <= tight.fit.n_iter - fewer
    assert abs(default.residual_ratio / tight.residual_ratio - 1) < 1e-5
    k = default.at[0]
    sd = np.sqrt(np.diag(refine.fisher_inverse(tight.fit.F))[2 * k : 2 * k + 2])
    shift = np.abs([default.pole[0].real - tight.pole[0].real,
                    default.pole[0].imag - tight.pole[0].imag]) / sd
    assert np.all(shift < 0.01)
