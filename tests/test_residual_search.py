"""The residual check of the identification (``identification.selection.residual_search``):
modes that no diagram resolved are found as peaks of the fit's residual, and
noise alone gives none."""

from __future__ import annotations

import numpy as np
import pytest

from ema_pipeline.data import DOF, FRFSet
from ema_pipeline.identification import identify
from ema_pipeline.identification.selection.residual_search import (
    mean_of_three_lines,
    peak_pole,
    residual_peaks,
    residual_ratio,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from tests import hardcases

TH = SelectionThresholds()  # the tuned defaults

RESIDUAL_PEAK_RATIO = SelectionThresholds().residual_peak_ratio


def _modes(rng: np.random.Generator, f: np.ndarray, fn: np.ndarray, zeta: np.ndarray,
           n_ch: int, snr_db: float) -> tuple[np.ndarray, np.ndarray]:
    """Accelerance of real modes with random shapes plus circular noise
    ``snr_db`` below each channel's RMS; the poles (rad/s)."""
    lam = hardcases.modal_poles(fn, zeta)
    jw = 2j * np.pi * f[:, None]
    H = rng.standard_normal((n_ch, fn.size)) @ (jw**2 * (1 / (jw - lam)
                                                        + 1 / (jw - lam.conj()))).T
    std = np.sqrt(np.mean(np.abs(H) ** 2, axis=1, keepdims=True)) * 10 ** (-snr_db / 20)
    H = H + std * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    return H, lam


@pytest.mark.parametrize("seed", range(4))
def test_missed_mode_is_the_residual_peak(seed: int) -> None:
    """Four modes at 25 dB SNR; given three, the residual's one peak above
    the threshold is the fourth, and its start pole lies within a quarter of
    its half-power band (frequency) and within 40 % (decay rate)."""
    rng = np.random.default_rng(seed)
    f = np.linspace(10.0, 200.0, 1901)
    fn = np.sort(rng.uniform(25.0, 185.0, 4))
    while np.min(np.diff(fn) / fn[:-1]) < 0.1:
        fn = np.sort(rng.uniform(25.0, 185.0, 4))
    zeta = rng.uniform(0.003, 0.02, 4)
    H, lam = _modes(rng, f, fn, zeta, 4, 25.0)
    miss = int(rng.integers(4))
    start, _ = residual_peaks(f, H, np.delete(lam, miss), "accelerance", thresholds=TH)
    assert start.size == 1, start / (2 * np.pi)
    hw = abs(lam[miss].real)  # half-power half-width, rad/s
    assert abs(start[0].imag - lam[miss].imag) < 0.5 * hw
    assert abs(start[0].real - lam[miss].real) < 0.4 * hw


@pytest.mark.parametrize("seed", range(6))
def test_noise_gives_no_residual_peak(seed: int) -> None:
    """With all modes given, the residual is the noise: over 1901 lines and
    2-6 channels its highest peak stays below the threshold (white noise gives
    1/ln 2 on average)."""
    rng = np.random.default_rng(100 + seed)
    f = np.linspace(10.0, 200.0, 1901)
    fn = np.array([40.0, 90.0, 150.0]) * rng.uniform(0.95, 1.05, 3)
    zeta = rng.uniform(0.003, 0.02, 3)
    H, lam = _modes(rng, f, fn, zeta, int(rng.integers(2, 7)), 30.0)
    assert residual_peaks(f, H, lam, "accelerance", thresholds=TH)[0].size == 0
    R = rng.standard_normal((1, 1901)) + 1j * rng.standard_normal((1, 1901))
    ratio = residual_ratio(R)
    assert abs(np.mean(ratio) - 1 / np.log(2)) < 0.1
    assert np.max(ratio) < RESIDUAL_PEAK_RATIO


def _frf(f: np.ndarray, H: np.ndarray) -> FRFSet:
    return FRFSet(freq_hz=f, H=H[:, None, :],
                  response_dofs=tuple(DOF(k + 1, 3) for k in range(H.shape[0])),
                  reference_dofs=(DOF(1, 3),), quantity="accelerance")


@pytest.mark.parametrize("seed", range(4))
def test_tail_of_a_mode_above_the_band_is_no_mode(seed: int) -> None:
    """A strong mode 4-15 % above the band's top: its tail rises towards the
    top and the residual terms follow it only in part. Whatever the residual
    check makes of that slope, no mode is reported there; a missed mode in
    the same data is still a plain residual peak."""
    rng = np.random.default_rng(200 + seed)
    f = np.linspace(10.0, 200.0, 1901)
    fn = np.array([45.0, 95.0, 140.0, 200.0 * rng.uniform(1.04, 1.15)])
    zeta = np.array([0.01, 0.008, 0.006, 0.01])
    H, lam = _modes(rng, f, fn, zeta, int(rng.integers(4, 9)), 35.0)
    res = identify(_frf(f, H))
    np.testing.assert_allclose(res.fn_hz, fn[:3], rtol=1e-3)
    start, from_edge = residual_peaks(f, H, lam[[0, 2]], "accelerance", thresholds=TH)
    plain = start[~from_edge]
    assert np.min(np.abs(plain - lam[1])) < abs(lam[1].real)


@pytest.mark.parametrize("seed", range(3))
def test_heavily_damped_mode_at_the_band_top_is_found(seed: int) -> None:
    """zeta 5-8 % at 95-97 % of the band's top: the half-power band reaches
    past the top, and the residual rises into the edge zone like a tail. A
    pole fitted from the peak to the band's end lies inside the band: a
    start marked ``from_edge``, kept when its own peak passes the resonance
    test (hard cases damping-611 and damping-900 were missed without it)."""
    rng = np.random.default_rng(300 + seed)
    f = np.linspace(10.0, 200.0, 1901)
    fn = np.array([40.0, 90.0, 200.0 * rng.uniform(0.95, 0.97)])
    zeta = np.array([0.02, 0.03, rng.uniform(0.05, 0.08)])
    H, lam = _modes(rng, f, fn, zeta, 5, 35.0)
    start, from_edge = residual_peaks(f, H, lam[:2], "accelerance", thresholds=TH)
    assert start.size >= 1 and from_edge[np.argmin(np.abs(start - lam[2]))]
    res = identify(_frf(f, H))
    assert res.fn_hz.size == 3
    np.testing.assert_allclose(res.fn_hz, fn, rtol=(zeta[2] + 0.005))


def test_peak_pole_starts_near_the_true_pole() -> None:
    """Three channels, 9-25 lines around a peak (half-power band about 3
    lines) at a local SNR of 15 dB: over 100 noise draws the median decay rate
    is within 10 % of the true one, the frequency within a tenth of a
    half-power half-width (the refinement takes over from there)."""
    df = 0.11
    lam = -1.17 + 2j * np.pi * 39.0
    rng = np.random.default_rng(7)
    for n_lines in (9, 15, 25):
        f = 39.0 + df * (np.arange(n_lines) - n_lines // 2)
        clean = np.stack([s / (2j * np.pi * f - lam) for s in (1.0, -0.6, 0.3)])
        std = 10 ** (-15 / 20) * np.sqrt(np.mean(np.abs(clean) ** 2))
        got = np.array([peak_pole(f, clean + std * (
            rng.standard_normal(clean.shape) + 1j * rng.standard_normal(clean.shape))
            / np.sqrt(2)) for _ in range(100)])
        assert abs(np.median(got.real) / lam.real - 1) < 0.1, (n_lines, np.median(got.real))
        assert abs(np.median(got.imag) - lam.imag) < 0.1 * abs(lam.real)


@pytest.mark.parametrize(("family", "seed"), [("snr", 801), ("damping", 403)])
def test_modes_no_diagram_resolves_are_found(family: str, seed: int) -> None:
    """snr-801 (SNR about 20 dB): 38.9 and 69.3 Hz, own peaks 2.2-2.7 times
    the local response, form no trajectory at the orders the search reaches;
    damping-403: 139.8 Hz at zeta 5.7 % at the top of a 2-channel band. Both
    were missed before the residual check; their residual peaks stood 20 and
    12 times above the floor."""
    case = hardcases.make_case(family, seed)
    res = identify(case.frf, band_hz=case.band_hz)
    tol = (case.zeta + 0.005) * case.fn_hz
    d = np.abs(res.fn_hz[None, :] - case.fn_hz[:, None]) <= tol[:, None]
    assert d.any(axis=1).all(), (case.fn_hz, res.fn_hz)
    assert d.any(axis=0).all(), (case.fn_hz, res.fn_hz)


def test_mean_of_three_lines_is_scipy_uniform_filter() -> None:
    """The running mean written to spare scipy.ndimage's import gives
    ``uniform_filter1d(x, 3, mode="nearest")``'s numbers (relative 1e-12; the
    same arithmetic in the same order), on noise spanning ten decades, where a
    mean computed another way differs by far more, and on the shortest inputs."""
    from scipy.ndimage import uniform_filter1d

    rng = np.random.default_rng(3)
    for x in (10 ** rng.uniform(-5, 5, 4097), np.array([2.0]), np.array([1.0, 7.0])):
        np.testing.assert_allclose(mean_of_three_lines(x),
                                   uniform_filter1d(x, 3, mode="nearest"), rtol=1e-12)


def _three_modes_to_refine(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Three modes in 50-150 Hz (3 channels, 40 dB): the lines, the FRFs,
    the true poles and start poles 0.2 % off them."""
    f = np.linspace(50.0, 150.0, 801)
    fn, zeta = np.array([70.0, 100.0, 125.0]), np.array([0.01, 0.008, 0.012])
    H, lam = _modes(np.random.default_rng(seed), f, fn, zeta, n_ch=3, snr_db=40.0)
    return f, H, lam, lam * (1 + 0.002)


def test_refining_some_modes_gives_them_the_numbers_of_refining_all() -> None:
    """``refine_poles(..., modes=...)``: each mode's local fit is its own, so
    the modes refined alone have the numbers of the full refinement to the
    last bit; the others keep their start poles with a NaN covariance."""
    from ema_pipeline.identification.refinement.refine import refine_poles

    f, H, lam, start = _three_modes_to_refine(seed=3)
    every = refine_poles(f, H, start, thresholds=TH)
    some = refine_poles(f, H, start, modes=[1], thresholds=TH)
    assert some.pole[1] == every.pole[1] and np.array_equal(some.cov[1], every.cov[1])
    assert np.array_equal(some.noise_std[1], every.noise_std[1])
    assert some.pole[0] == start[0] and np.isnan(some.cov[[0, 2]]).all()
    assert abs(every.pole[1] - lam[1]) < abs(start[1] - lam[1])  # it did refine


def test_a_fit_memo_gives_the_fits_of_the_same_poles_only() -> None:
    """``refine_poles(..., memo=FitMemo())``: the modes refined first (the
    final tests' screen) are taken by the next refinement of the same poles,
    to the last bit of refining all without a memo; other poles or another
    iteration budget fit again."""
    from ema_pipeline.identification.refinement.refine import FitMemo, refine_poles

    f, H, _, start = _three_modes_to_refine(seed=5)
    every = refine_poles(f, H, start, thresholds=TH)
    memo = FitMemo()
    refine_poles(f, H, start, modes=[0, 2], thresholds=TH, memo=memo)
    taken = refine_poles(f, H, start, thresholds=TH, memo=memo)
    assert memo.taken == 2
    for a, b in zip((taken.pole, taken.cov, taken.noise_std, taken.band_hz, taken.n_iter),
                    (every.pole, every.cov, every.noise_std, every.band_hz, every.n_iter),
                    strict=True):
        np.testing.assert_array_equal(a, b)
    other = start * (1 + 1e-4)
    moved = refine_poles(f, H, other, thresholds=TH, memo=memo)
    shorter = refine_poles(f, H, other, max_iter=3, thresholds=TH, memo=memo)
    assert memo.taken == 2
    np.testing.assert_array_equal(moved.pole, refine_poles(f, H, other, thresholds=TH).pole)
    np.testing.assert_array_equal(shorter.pole,
                                  refine_poles(f, H, other, max_iter=3, thresholds=TH).pole)


def test_a_residual_peak_that_cannot_pass_costs_no_refit_of_every_mode(monkeypatch) -> None:
    """A simulated paper file (genuine, seed 0): its noise leaves a residual
    peak whose decay rate the data do not determine. ``Retest.could_pass``
    (its own local fit, the one the joint refinement would give it) shows it
    cannot pass, so the refit of every mode with it is skipped: one refit
    fewer, and the result of the full path to the last bit (screen off:
    every candidate may pass)."""
    from ema_pipeline.identification import plscf_backend
    from ema_pipeline.pipeline.simulate import simulate_paper_test

    frf = simulate_paper_test("genuine", seed=0)
    calls = []
    real_call = plscf_backend.Retest.__call__

    def counted(self, candidates, partner, strict):
        calls.append(candidates.pole.size)
        return real_call(self, candidates, partner, strict)

    monkeypatch.setattr(plscf_backend.Retest, "__call__", counted)
    screened = identify(frf)
    n_screened = len(calls)
    calls.clear()
    monkeypatch.setattr(plscf_backend.Retest, "could_pass",
                        lambda self, candidates, indices: np.ones(len(indices), bool))
    full = identify(frf)
    assert n_screened < len(calls), (n_screened, calls)
    np.testing.assert_array_equal(screened.selected.pole, full.selected.pole)
    np.testing.assert_array_equal(screened.modes.fn_std_hz, full.modes.fn_std_hz)
    np.testing.assert_array_equal(screened.not_kept_hz, full.not_kept_hz)
    assert screened.fn_hz.size == 4


def test_candidates_that_cannot_pass_leave_before_the_fit_of_all() -> None:
    """``add_found`` with a screen: of three new candidates the screen says
    the middle one cannot pass. The joint fit (``retest``) never sees it: the
    other two are screened again among the kept mode alone and then fitted
    with it, once, and that fit is the result. Without a screen the joint fit
    sees all three."""
    from ema_pipeline.identification.refinement.refine import RefinedPoles
    from ema_pipeline.identification.selection.acceptance import (
        Candidates,
        add_found,
        unseen_candidates,
    )

    kept_pole = np.array([-1.0 + 2j * np.pi * 50.0])
    new = -1.0 + 2j * np.pi * np.array([80.0, 90.0, 100.0])
    bad = new[1]

    def refined(pole: np.ndarray) -> RefinedPoles:
        m = pole.size
        return RefinedPoles(pole, np.zeros((m, 2, 2)), np.ones((m, 1)), np.zeros((m, 2)),
                            np.ones(m, int))

    found = Candidates(unseen_candidates(kept_pole), refined(kept_pole), np.ones(1, bool),
                       np.zeros(1, bool), np.zeros(1, bool))
    screened: list[list[float]] = []
    fitted: list[np.ndarray] = []

    def screen(candidates, indices):
        screened.append(sorted(np.round(candidates.pole[indices].imag / (2 * np.pi)).tolist()))
        return candidates.pole[indices] != bad

    def retest(candidates, partner, strict):
        fitted.append(candidates.pole.copy())
        return refined(candidates.pole), candidates.pole != bad

    out = add_found(found, new, partner=False, strict=np.zeros(3, bool), retest=retest,
                    screen=screen)
    assert screened == [[80.0, 90.0, 100.0], [80.0, 100.0]]
    assert len(fitted) == 1 and bad not in fitted[0] and fitted[0].size == 3
    np.testing.assert_array_equal(out.sel.pole, fitted[0])
    assert out.keep.all()
    fitted.clear()
    unscreened = add_found(found, new, partner=False, strict=np.zeros(3, bool), retest=retest)
    assert [f.size for f in fitted] == [4, 3]  # all three, then again without the bad one
    np.testing.assert_array_equal(unscreened.sel.pole, out.sel.pole)


def test_the_grown_lsfd_residual_is_a_new_lsfds() -> None:
    """GrowingResidual: poles added one at a time (the QR extended) leave the
    residual of a new LSFD of all of them, to rounding (1e-12 of the data);
    two equal poles (a singular design) give lsfd()'s minimum-norm fit."""
    from ema_pipeline.acquisition import modal_frf
    from ema_pipeline.data import ModalParameters
    from ema_pipeline.identification.refinement.lsfd import GrowingResidual, lsfd

    fn = np.array([30.0, 55.0, 61.0, 90.0, 140.0, 170.0])
    modes = ModalParameters(fn_hz=fn, zeta=np.full(fn.size, 0.01))
    f = np.linspace(10.0, 200.0, 1501)
    rng = np.random.default_rng(3)
    phi = rng.standard_normal((3, fn.size))
    H = modal_frf(f, modes, phi, phi[:1], quantity="accelerance").reshape(3, -1)
    H = H + 1e-3 * np.std(H) * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    lam = -0.01 * 2 * np.pi * fn + 2j * np.pi * fn * np.sqrt(1 - 1e-4)
    grown = GrowingResidual(f, H, lam[:2], "accelerance")
    scale = np.abs(H).max()
    for k in range(2, fn.size):
        grown.add(lam[k])
        fresh = H - lsfd(f, H, lam[: k + 1], "accelerance").H_fit
        assert np.abs(grown.residual() - fresh).max() < 1e-12 * scale
    assert np.abs(grown.residual()).max() < 0.05 * scale  # every mode in the fit
    grown.add(lam[-1])  # a coincident pole: lsfd() takes over
    assert grown.factor is None
    np.testing.assert_array_equal(grown.residual(), H - lsfd(f, H, np.append(lam, lam[-1]),
                                                            "accelerance").H_fit)


def test_a_decay_screen_skips_only_sandwiches_that_cannot_change_a_verdict(monkeypatch) -> None:
    """``refine_poles(..., decay_screen=True)`` (the final tests' screen): a
    pole where the data hold only noise (85 Hz, between the modes) has a
    decay rate that the inverse Fisher matrix already leaves undetermined,
    so its sandwich covariance is not computed; its pole and verdict are
    those of the full refinement, its covariance that matrix's block (never
    above the sandwich's), and its fit does not stay in the memo. A true
    mode gets the sandwich, to the last bit."""
    from ema_pipeline.identification.refinement import refine
    from ema_pipeline.identification.refinement.refine import (
        FitMemo,
        decay_determined,
        refine_poles,
    )

    f, H, _, start = _three_modes_to_refine(seed=7)
    noise_pole = -2 * np.pi * 85.0 * 0.002 + 2j * np.pi * 85.0
    start = np.insert(start, 1, noise_pole)  # modes at 70, (85: noise), 100, 125 Hz
    full = refine_poles(f, H, start, modes=[1, 2], thresholds=TH)
    sandwiches = []
    real = refine.vp_covariance
    monkeypatch.setattr(refine, "vp_covariance",
                        lambda *a, **k: sandwiches.append(1) or real(*a, **k))
    memo = FitMemo()
    screened = refine_poles(f, H, start, modes=[1, 2], thresholds=TH, memo=memo,
                            decay_screen=True)
    assert len(sandwiches) == 1  # the true mode's only
    np.testing.assert_array_equal(screened.pole, full.pole)
    np.testing.assert_array_equal(screened.cov[2], full.cov[2])
    np.testing.assert_array_equal(decay_determined(screened.pole, screened.cov, thresholds=TH),
                                  decay_determined(full.pole, full.cov, thresholds=TH))
    assert not decay_determined(full.pole[1:2], full.cov[1:2], thresholds=TH)[0]
    assert 0 < screened.cov[1, 0, 0] <= full.cov[1, 0, 0]
    assert sorted(memo.fits) == [2]  # the noise pole's fit is not left for a refinement
    again = refine_poles(f, H, start, modes=[1, 2], thresholds=TH, memo=memo)
    assert memo.taken == 1
    np.testing.assert_array_equal(again.cov, full.cov)
