"""Acceptance tests of identification on the hard cases of ``tests/hardcases.py``:
every family meets the detection and sigma targets below (a regression of any
family fails). The checks of the generator itself are real tests.

Targets, at the defaults (only the band given):
each family <= 2 % of the true modes missed and <= 2 % spurious, a match being
|f_id - f_true| <= (zeta_true + 0.005) f_true one-to-one; over the matched
modes 90-98 % of the errors within 2 sigma and the 68th percentile of
|error| / sigma in 0.75-1.35, for f_n and zeta separately.

Budget: a few seeds per family, most of them identified by the background
job of ``tests/conftest.py`` on the second core: detection on seeds 1-3,
the sigmas on seeds 1-9 (1-2 for the dense families, 5-11 s a file). The
held-out ranges of the README (400+) are not used here.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ema_pipeline.identification import doubtful_reasons, identify
from ema_pipeline.identification.thresholds import SelectionThresholds
from tests import hardcases
from tests.jobs import Background

TH = SelectionThresholds()  # the tuned defaults

SEEDS = (1, 2, 3)
#: the dense families take 5-11 s a file; two seeds (55-75 modes each) keep
#: the suite within its budget (the benchmark runs hundreds of files)
DENSE_SEEDS = (1, 2)
#: the sigma targets are checked on more files than detection: on each
#: family's seeds 1-9 or more, up to MIN_SIGMA_MODES true modes (the dense
#: families: DENSE_SEEDS, 64-77 modes). The 68th percentile of |error|/sigma
#: of n modes scatters by 0.96/sqrt(n) (sample quantile of |N(0, 1)|): 0.15
#: with the 38-46 modes that seeds 1-9 give the families of 3-6 modes a file,
#: where the target's half-width of 0.25-0.35 is under 2 standard errors,
#: 0.12 with 60 (80 would cost the suite another 40 s).
#: ``test_sigmas_are_calibrated_per_family`` checks the counts.
MIN_SIGMA_MODES = 60
_N_SIGMA_SEEDS = {"baseline": 13, "close_1ref": 9, "close_2ref": 9, "damping": 15,
                  "snr": 15, "mimo": 9, "roving": 12, "impact": 9, "quantity": 15}
SIGMA_SEEDS = {f: DENSE_SEEDS if f.startswith("dense") else tuple(range(1, _N_SIGMA_SEEDS[f] + 1))
               for f in hardcases.FAMILIES}
#: hard cases that ``tests/background_job.py`` identifies in a background
#: process (started by conftest.py at collection, read through the
#: ``background`` fixture), so that they run on the second core
BACKGROUND = {f"hard:{f}": (*DENSE_SEEDS, 803) if f == "dense_log" else SIGMA_SEEDS[f]
              for f in hardcases.FAMILIES}


def identify_case(case: hardcases.HardCase) -> dict[str, np.ndarray]:
    """The one call of the identification (adapt to identify(frf, options));
    ``tests/background_job.py`` runs it for the dense families in the background."""
    frf = case.frf.reciprocal() if case.roving else case.frf
    res = identify(frf, band_hz=case.band_hz)
    m = res.modes
    return {"fn_hz": m.fn_hz, "zeta": m.zeta, "fn_std_hz": m.fn_std_hz, "zeta_std": m.zeta_std,
            "not_kept_hz": res.not_kept_hz,
            "only_some_bands": np.array(["found_only_in_some_bands" in r
                                         for r in doubtful_reasons(res)], dtype=float)}


def _match(f_true: np.ndarray, z_true: np.ndarray, f_id: np.ndarray) -> list[tuple[int, int]]:
    from scipy.optimize import linear_sum_assignment

    if f_true.size == 0 or f_id.size == 0:
        return []
    d = np.abs(f_id[None, :] - f_true[:, None]) / ((z_true + 0.005) * f_true)[:, None]
    rows, cols = linear_sum_assignment(np.where(d <= 1, d, 1e6))
    return [(i, j) for i, j in zip(rows, cols, strict=True) if d[i, j] <= 1]


def scores(family: str, seeds: tuple[int, ...] | list[int], background: Background) -> dict:
    """Missed, spurious, false alarms (a resonance listed as not kept where no
    true mode was missed) and |error|/sigma of f and zeta of ``family`` on
    ``seeds``; the identification outputs come from ``background`` (the
    fixture) where it has them."""
    n_true = missed = spurious = false_alarms = only_some_bands = 0
    rf: list[float] = []
    rz: list[float] = []
    done = background.outputs(f"hard:{family}")
    for seed in seeds:
        case = hardcases.make_case(family, seed)
        out = done[seed] if seed in done else identify_case(case)
        pairs = _match(case.fn_hz, case.zeta, out["fn_hz"])
        n_true += case.fn_hz.size
        missed += case.fn_hz.size - len(pairs)
        spurious += out["fn_hz"].size - len(pairs)
        # a resonance listed as not kept where no true mode was missed
        lost = np.ones(case.fn_hz.size, bool)
        lost[[i for i, _ in pairs]] = False
        for f_hz in out["not_kept_hz"]:
            false_alarms += not _match(case.fn_hz[lost], case.zeta[lost], np.array([f_hz]))
        # true modes marked doubtful as found only in some bands
        flagged = np.asarray(out.get("only_some_bands", np.zeros(out["fn_hz"].size)), bool)
        only_some_bands += int(np.sum(flagged[[j for _, j in pairs]]))
        for i, j in pairs:
            sf, sz = out["fn_std_hz"][j], out["zeta_std"][j]
            rf.append(abs(out["fn_hz"][j] - case.fn_hz[i]) / sf if sf > 0 else np.inf)
            rz.append(abs(out["zeta"][j] - case.zeta[i]) / sz if sz > 0 else np.inf)
    return {"n_true": n_true, "missed": missed, "spurious": spurious,
            "false_alarms": false_alarms, "only_some_bands": only_some_bands,
            "rf": np.nan_to_num(np.array(rf), nan=np.inf),
            "rz": np.nan_to_num(np.array(rz), nan=np.inf)}


_CACHE: dict[tuple[str, tuple[int, ...]], dict] = {}


def _family_scores(family: str, background: Background, sigma: bool = False) -> dict:
    """Scores of ``family`` on its seeds (``sigma``: on SIGMA_SEEDS); the
    identification outputs come from ``background`` (the fixture) where it
    has them."""
    seeds = SIGMA_SEEDS[family] if sigma else DENSE_SEEDS if family.startswith("dense") else SEEDS
    if (family, seeds) in _CACHE:
        return _CACHE[family, seeds]
    _CACHE[family, seeds] = scores(family, seeds, background)
    return _CACHE[family, seeds]


# --------------------------------------------------------------------------- generator
@pytest.mark.parametrize("family", hardcases.FAMILIES)
def test_generator_truth_is_in_the_data(family: str) -> None:
    """Deterministic, modes inside the band, and each true mode visible as a
    peak: the noise-free model is what the FRF shows within the noise."""
    a = hardcases.make_case(family, 1)
    b = hardcases.make_case(family, 1)
    np.testing.assert_array_equal(a.frf.H, b.frf.H)
    lo, hi = a.band_hz
    assert np.all((a.fn_hz > lo) & (a.fn_hz < hi))
    assert np.all((a.zeta > 0) & (a.zeta < 0.1))
    assert a.frf.freq_hz.size >= 1000
    if family == "impact":
        assert a.frf.acquisition.exp_window_tau_s > 0
        assert a.frf.coherence is not None and a.frf.acquisition.n_averages >= 3
    if family == "roving":
        assert a.frf.n_out == 1 and 8 <= a.frf.n_in <= 12


def test_generator_frf_matches_pole_residue_model() -> None:
    """An exact LS fit with the true poles leaves only noise (frequency-domain
    case at 35-55 dB): residual below 3 % of the FRF norm."""
    case = hardcases.make_case("baseline", 1)
    frf = case.frf.band(*case.band_hz)
    lam = hardcases.modal_poles(case.fn_hz, case.zeta)
    jw = 2j * np.pi * frf.freq_hz[:, None]
    B = np.concatenate([jw**2 / (jw - lam), jw**2 / (jw - lam.conj()),
                        np.ones_like(jw), jw**2, jw**4], axis=1)
    for h in frf.H[:, 0, :]:
        x = np.linalg.lstsq(B, h, rcond=None)[0]
        assert np.linalg.norm(h - B @ x) < 0.03 * np.linalg.norm(h)


@pytest.mark.parametrize(("family", "seed"), [("damping", 602), ("roving", 600), ("mimo", 603)])
def test_true_modes_have_real_local_shapes(family: str, seed: int) -> None:
    """The resonance test judges a weak mode by the MPC of its shape. At the
    exact poles, one global LSFD gives weak real modes of these cases MPC
    0.09-0.87; each mode's own local fit (local_fits.local_shapes) gives > 0.98."""
    from ema_pipeline.identification.refinement.local_fits import local_shapes
    from ema_pipeline.identification.refinement.lsfd import mpc

    case = hardcases.make_case(family, seed)
    frf = case.frf.reciprocal() if case.roving else case.frf
    sub = frf.band(*case.band_hz)
    H = sub.H.reshape(-1, sub.H.shape[-1])
    lam = hardcases.modal_poles(case.fn_hz, case.zeta)
    local = mpc(local_shapes(sub.freq_hz, H, lam, quantity=sub.quantity, thresholds=TH).T)
    assert np.all(local > 0.98), local


def test_complex_modes_generator_and_their_strong_modes_are_found() -> None:
    """hardcases.complex_shapes turns the shapes complex without changing the
    rest of the case (same truth, same FRFs at 0 degrees); at +-15 degrees the
    true modes' local MPCs drop below 0.97, and every mode whose own peak is
    clear (quick_significance ratio >= SelectionThresholds.weak_peak_ratio) is still
    found (weak complex modes may not be: README, "Known limitation")."""
    from ema_pipeline.identification.refinement.local_fits import local_shapes, quick_significance
    from ema_pipeline.identification.refinement.lsfd import mpc
    from ema_pipeline.identification.thresholds import SelectionThresholds

    real, same = hardcases.make_case("mimo", 6), hardcases.make_case("mimo", 6, 0.0)
    np.testing.assert_array_equal(real.frf.H, same.frf.H)
    case = hardcases.make_case("mimo", 6, 15.0)
    np.testing.assert_array_equal(case.fn_hz, real.fn_hz)
    sub = case.frf.band(*case.band_hz)
    H = sub.H.reshape(-1, sub.H.shape[-1])
    lam = hardcases.modal_poles(case.fn_hz, case.zeta)
    shapes = local_shapes(sub.freq_hz, H, lam, quantity=sub.quantity, thresholds=TH)
    assert np.median(mpc(shapes.T)) < 0.97
    _, peak, _ = quick_significance(sub.freq_hz, H, lam, thresholds=TH)
    strong = set(np.flatnonzero(peak >= SelectionThresholds().weak_peak_ratio).tolist())
    assert len(strong) >= 4
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = identify_case(case)["fn_hz"]
    matched = {i for i, _ in _match(case.fn_hz, case.zeta, found)}
    assert strong <= matched, (case.fn_hz[sorted(strong - matched)], found)


def test_mode_resolved_in_another_diagram_is_kept() -> None:
    """SNR 15-25 dB, 5 modes: at order 128 the full band determines 76,
    147.8 and 186.7 Hz (54.5 Hz is still young), at order 220 54.5 Hz is
    determined but 147.7 Hz is not; 3 each, so order 128 stays the best
    diagram, and 54.5 Hz, a determined resonance at 220, is added to it.
    (34.2 Hz comes from the search of the band's lowest eighth.)"""
    case = hardcases.make_case("snr", 609)
    out = identify_case(case)
    pairs = _match(case.fn_hz, case.zeta, out["fn_hz"])
    assert len(pairs) == case.fn_hz.size == 5, out["fn_hz"]
    assert out["fn_hz"].size == 5, out["fn_hz"]


def test_weak_close_partner_is_kept() -> None:
    """One reference, a pair 1.6 % apart (218.1 and 221.7 Hz, zeta 0.75 %,
    modal overlap about 1): the full search finds only the stronger mode; one
    pole more in its local fit halves the residual (ratio 0.56) and gives the
    weaker one with local shapes of MPC 1.0 and 0.91. The partner is kept,
    though a lone weak pole with that MPC would fail the resonance test."""
    case = hardcases.make_case("close_1ref", 702)
    out = identify_case(case)
    pairs = _match(case.fn_hz, case.zeta, out["fn_hz"])
    assert len(pairs) == case.fn_hz.size, (case.fn_hz, out["fn_hz"])
    assert out["fn_hz"].size == case.fn_hz.size, out["fn_hz"]


def test_low_cluster_of_a_wide_band_is_found(background: Background) -> None:
    """23 modes at 10-24.5 Hz (2-6 % apart, zeta 0.2-0.8 %) in a band of
    4.7-162 Hz, one reference, 4 outputs. The full band's diagram holds 4
    poorly resolved candidates there, and a wide one (15.95 Hz) bent the
    local fits of 16.6-18.0 Hz, which failed the resonance test; 23.3 and
    24.5 Hz lie just above the zoom's window (24.3 Hz). Before the residual
    check 5 were missed (23.29 Hz: its residual peak 52 times the floor)."""
    case = hardcases.make_case("dense_log", 803)
    out = background.outputs("hard:dense_log").get(803) or identify_case(case)
    pairs = _match(case.fn_hz, case.zeta, out["fn_hz"])
    assert case.fn_hz.size == 23
    assert len(pairs) == 23, (case.fn_hz, out["fn_hz"])
    assert out["fn_hz"].size == len(pairs), out["fn_hz"]


def test_impact_case_window_shift_is_exact() -> None:
    """Time-domain impact case: with the poles shifted by 1/tau the true model
    fits the H1 estimate to within 1 % (window theory and simulation agree)."""
    assert_window_shift_exact(hardcases.make_case("impact", 1))


def assert_window_shift_exact(case: hardcases.HardCase) -> None:
    """The true poles shifted by -1/tau (the exponential window) and a
    constant fit each of the case's H1 estimates within 1 % on 5-900 Hz."""
    frf = case.frf
    tau = frf.acquisition.exp_window_tau_s
    lam = hardcases.modal_poles(case.fn_hz, case.zeta) - 1.0 / tau
    sel = (frf.freq_hz > 5) & (frf.freq_hz < 900)
    jw = 2j * np.pi * frf.freq_hz[sel, None]
    B = np.concatenate([1 / (jw - lam), 1 / (jw - lam.conj()), np.ones_like(jw)], axis=1)
    for h in frf.H[:, 0, sel]:
        x = np.linalg.lstsq(B, h, rcond=None)[0]
        assert np.linalg.norm(h - B @ x) < 0.01 * np.linalg.norm(h)


# --------------------------------------------------------------------------- targets
@pytest.mark.parametrize("family", hardcases.FAMILIES)
def test_no_mode_missed_or_invented(family: str, background: Background) -> None:
    s = _family_scores(family, background)
    assert s["missed"] <= 0.02 * s["n_true"], s
    assert s["spurious"] <= 0.02 * s["n_true"], s


@pytest.mark.parametrize("family", hardcases.FAMILIES)
def test_sigmas_are_calibrated_per_family(family: str, background: Background) -> None:
    """68th percentile of |error|/sigma in 0.75-1.35 (f and zeta) on
    SIGMA_SEEDS (60 or more modes a family); the coverage is only checked
    loosely here (>= 80 %)."""
    s = _family_scores(family, background, sigma=True)
    assert s["n_true"] >= MIN_SIGMA_MODES, s["n_true"]
    for key in ("rf", "rz"):
        r = s[key]
        assert 0.75 <= np.percentile(r, 68) <= 1.35, (key, np.percentile(r, 68))
        assert np.mean(r <= 2) >= 0.80, (key, np.mean(r <= 2))


def test_no_resonance_listed_as_not_kept_where_no_mode_was_missed(
        background: Background) -> None:
    """``IdentificationResult.not_kept_hz`` lists only what the data show:
    over SIGMA_SEEDS of all families (about 150 files) no entry lies away
    from a true mode that the identification missed (measured: none listed
    at all; on the measured beam 42.1, 274.7 and 325.1 Hz, in
    tests/test_identification_real.py)."""
    alarms = {f: _family_scores(f, background, sigma=True)["false_alarms"]
              for f in hardcases.FAMILIES}
    assert sum(alarms.values()) == 0, alarms


def test_no_true_mode_marked_found_only_in_some_bands(background: Background) -> None:
    """The doubtful rule ``found_only_in_some_bands`` (held by three or more of
    the narrower searches of the band, found by none) marks no true mode over
    SIGMA_SEEDS of all families (measured on seeds 1-9 of every family and
    1-2 of the dense ones: none marked at all). Two is too few: it marks a
    close partner hidden in its neighbour (impact_close-9 23.1 Hz) and a weak
    mode of a dense band (dense_log-1 48.7 Hz), both true
    (benchmarks/issue31_measurements.md)."""
    marked = {f: _family_scores(f, background, sigma=True)["only_some_bands"]
              for f in hardcases.FAMILIES}
    assert sum(marked.values()) == 0, marked


def test_sigma_coverage_over_all_families(background: Background) -> None:
    """90-98 % of the errors within 2 sigma and p68 of |error|/sigma in
    0.75-1.35 over all families on SIGMA_SEEDS."""
    for key in ("rf", "rz"):
        r = np.concatenate([_family_scores(f, background, sigma=True)[key]
                            for f in hardcases.FAMILIES])
        assert 0.90 <= np.mean(r <= 2) <= 0.98, (key, np.mean(r <= 2))
        assert 0.75 <= np.percentile(r, 68) <= 1.35, (key, np.percentile(r, 68))
