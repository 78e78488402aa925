"""Identification of the measured roving-hammer beam (``../shared/data``): the
published modes and the resonances the data show, in every band, with the
shapes and the damping independent of the band (skipped where the file is
absent)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ema_pipeline.acquisition import modal_frf
from ema_pipeline.data import DOF, FRFSet, ModalParameters
from ema_pipeline.identification import (
    FOUND_BY,
    IdentificationResult,
    doubtful_reasons,
    identify,
    modes_table,
)
from ema_pipeline.identification.result import doubtful_flags

PUBLISHED_HZ = np.array([17.212, 68.840, 118.878, 155.391, 226.395, 235.230, 265.219,
                         362.805, 414.118, 567.539, 602.292, 643.435, 707.200, 740.567])


#: the published modes the measured beam's data show (235.2 Hz is not in the
#: data, 707.2 Hz is a weak broad peak; test_real_beam_235_hz_is_not_in_the_data)
SHOWN_PUBLISHED_HZ = PUBLISHED_HZ[~np.isin(PUBLISHED_HZ, [235.230, 707.200])]
#: resonances the beam's FRFs show that are not published
#: (test_real_beam_has_resonances_the_published_list_lacks)
SHOWN_OTHER_HZ = np.array([42.1, 274.6, 325.1])
#: issue 31's bands of the measured beam (None: no band)
BEAM_BANDS = (None, (5.0, 400.0), (5.0, 790.0), (100.0, 400.0), (250.0, 700.0))


@pytest.fixture(scope="module")
def beam_results(real_uff, beam_identified) -> dict:
    """The measured beam identified at the defaults with no band and in each
    band of :data:`BEAM_BANDS` (about 10 s in all), by band. No band is the
    session's ``identify(read_frf(real_uff))`` (conftest.py; ``identify``
    identifies the roving-hammer file in its reciprocal form)."""
    from ema_pipeline.io import read_frf

    frf = read_frf(real_uff)
    assert frf.n_out == 1 and frf.n_in == 30
    return {None: beam_identified,
            **{band: identify(frf.reciprocal(), band_hz=band) for band in BEAM_BANDS[1:]}}


def test_refinement_failed_marks_the_start_poles_reported(beam_identified):
    """A mode whose local fit wandered off is reported at its start pole and
    marked ``refinement_failed`` (the rule: its selected pole is its start
    pole, bit for bit). On the measured beam at the defaults two are: the
    weak, strongly complex 602.95 Hz mode (the one a change of the FRFs in
    their last bits moves between 603.04 and 601.21 Hz in 5-790 Hz,
    docs/validation.md) and 925.48 Hz; on a clean simulation none is."""
    res = beam_identified
    flagged = doubtful_flags(res)["refinement_failed"]
    start = res.stabilization.mode_pole
    assert np.array_equal(flagged, res.selected.pole == start)
    np.testing.assert_allclose(res.fn_hz[flagged], [602.95, 925.48], atol=0.05)
    assert all("refinement_failed" in r for r, f in zip(doubtful_reasons(res), flagged,
                                                          strict=True) if f)
    # every other mode moved away from its start pole
    assert np.all(np.abs(res.selected.pole - start)[~flagged] > 0)
    f = np.linspace(0.0, 100.0, 401)
    truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    clean = identify(FRFSet(freq_hz=f, H=H))
    assert not doubtful_flags(clean)["refinement_failed"].any()
    assert not doubtful_flags(identify(FRFSet(freq_hz=f, H=H), refine=False))[
        "refinement_failed"].any()  # without refinement the rule does not apply


def test_real_roving_hammer_data(beam_results):
    res = beam_results[None]  # defaults: no band, adaptive order
    dist = np.abs(res.fn_hz[:, None] - PUBLISHED_HZ[None, :])
    matched = np.sum(dist.min(axis=0) < 1.0)
    shown = np.abs(res.fn_hz[:, None] - np.array([42.1, 274.6, 325.1])[None, :]).min(axis=1) < 1
    extra = np.sum((dist.min(axis=1) >= 1.0) & (res.fn_hz < 800) & ~shown)
    assert matched >= 12, res.fn_hz  # issue 11 asks for 13 (measured 12)
    # issue 31: nothing that is neither published nor a resonance the FRFs
    # show (42.1 and 325.1 Hz are kept since the residual-drop test: SNR
    # 58-72, their own terms explain 6-10 times their local residual)
    assert extra == 0, res.fn_hz
    # (the README's example with --band 5 790 runs in tests/test_readme.py)
    # every mode is held by the narrower searches of the band (its lowest
    # eighth, the windows) and found by one of them at least
    assert res.band_support.shape == (res.modes.n_modes, 2)
    assert np.all(res.band_support[:, 0] >= 1) and np.all(res.band_support[:, 1] >= 1)
    assert res.modes.shapes.shape == (30, res.modes.n_modes)
    # issue 38: a mode outside the stored diagram (0 stable orders) says how it
    # was found (the beam: 42.2 and 119.4 Hz by windows, 118.0, 879.3 and
    # 941.2 Hz by the band's diagrams at other orders)
    table = modes_table(res)
    assert set(table["found_by"]) <= set(FOUND_BY) and "window" in set(table["found_by"])
    unstored = table["n_stable_orders"] == 0
    assert unstored.any() and not (table["found_by"][unstored] == "diagram").any()
    assert (table["found_by"][~unstored] == "diagram").all()
    assert np.all(res.zeta > 0) and np.all(res.zeta < 0.05)
    assert np.median(res.frac) > 0.8
    # resonances the FRFs show that are not published are kept or listed as
    # not kept (test_real_beam_has_resonances_the_published_list_lacks)
    for f_hz in (42.0, 274.7, 325.1):
        if np.min(np.abs(res.fn_hz - f_hz)) < 1.0:
            continue
        k = np.argmin(np.abs(res.not_kept_hz - f_hz))
        assert abs(res.not_kept_hz[k] - f_hz) < 1.0, res.not_kept_hz
        assert res.not_kept_frfs[k] >= 6, res.not_kept_frfs


@pytest.mark.parametrize("band", BEAM_BANDS[1:])
def test_real_beam_modes_do_not_depend_on_the_band(beam_results, band):
    """Issue 31: every published mode inside the band (3 % margin) is found
    at the no-band frequency within max(0.2 Hz, 3 sigma), and nothing below
    800 Hz is neither published nor a resonance the FRFs show. Measured
    (benchmarks/issue31_measurements.md): largest shift 0.13 Hz (362.71
    against 362.84 Hz in 5-400 Hz); before, 362.8 Hz came out at 363.9 Hz in
    5-790 and 250-700 Hz, 643.4 Hz moved by 0.67 Hz (3 sigma 0.56), 602.3 Hz
    was missed in 250-700 Hz and 156.5 Hz appeared beside 155.4 Hz in
    100-400 Hz."""
    free, res = beam_results[None], beam_results[band]
    lo, hi = band
    inside = SHOWN_PUBLISHED_HZ[(SHOWN_PUBLISHED_HZ > 1.03 * lo) & (SHOWN_PUBLISHED_HZ < hi / 1.03)]
    for published in inside:
        k0 = np.argmin(np.abs(free.fn_hz - published))
        k = np.argmin(np.abs(res.fn_hz - free.fn_hz[k0]))
        sigma = max(res.modes.fn_std_hz[k], free.modes.fn_std_hz[k0])
        assert abs(res.fn_hz[k] - free.fn_hz[k0]) <= max(0.2, 3 * sigma), (
            published, res.fn_hz[k], free.fn_hz[k0], sigma)
    # the band changes the model (the adaptive order search stops elsewhere),
    # and the console and the report say so (report.wording.model_text)
    assert np.max(res.settings.orders) != np.max(free.settings.orders)
    known = np.concatenate([PUBLISHED_HZ, SHOWN_OTHER_HZ])
    unexplained = np.min(np.abs(res.fn_hz[:, None] - known[None, :]), axis=1) >= 1.0
    assert not np.any(unexplained & (res.fn_hz < 800)), res.fn_hz


def _shape_mac(a: IdentificationResult, i: int, b: IdentificationResult, j: int) -> float:
    """MAC of mode i's shape of ``a`` with mode j's of ``b``."""
    from ema_pipeline.modal import mac_pairs

    return float(mac_pairs(a.modes.shapes[:, [i]], b.modes.shapes[:, [j]])[0])


def test_wide_band_keeps_a_low_mode_shape() -> None:
    """Issue 42: shapes do not depend on the band. 8 accelerometers along a
    simply supported beam (sine shapes), modes at 12-430 Hz inside the band
    and three strong ones at 515-590 Hz just above it (which the wide
    band's two residual terms follow only roughly), 2 % noise proportional
    to |H|. The whole band's LSFD gave the 12 Hz mode MAC 0.974 between the
    band 4-500 Hz and 4-80 Hz (0.974 with the true shape, MPC 0.90 against
    1.00): the misfit of lines far from the mode went into its residues.
    From each mode's local band: MAC 1.0000 and MPC 1.000 in both."""
    from ema_pipeline.modal import mac_pairs

    f = np.arange(0.0, 600.25, 0.5)
    fn = np.array([12.0, 48.0, 110.0, 195.0, 300.0, 430.0, 515.0, 545.0, 590.0])
    zeta = np.array([0.01, 0.008, 0.006, 0.005, 0.005, 0.004, 0.004, 0.004, 0.004])
    phi = np.sin(np.pi * np.outer(np.linspace(0.05, 0.95, 8), np.arange(1, 10)))
    lam = -zeta * 2 * np.pi * fn + 2j * np.pi * fn * np.sqrt(1 - zeta**2)
    mass = np.array([1.0] * 6 + [0.1] * 3)
    A = phi * phi[2][None, :] / (2j * lam.imag * mass)  # receptance residues, hammer at 3
    jw = 2j * np.pi * f[:, None]
    H0 = (jw**2 * ((1 / (jw - lam)) @ A.T + (1 / (jw - lam.conj())) @ A.conj().T)).T[:, None]
    rng = np.random.default_rng(0)
    std = 0.02 * np.abs(H0) + 1e-3 * np.sqrt(np.mean(np.abs(H0) ** 2, axis=-1, keepdims=True))
    H = H0 + std * (rng.standard_normal(H0.shape) + 1j * rng.standard_normal(H0.shape)) / 2**0.5
    frf = FRFSet(freq_hz=f, H=H, response_dofs=tuple(DOF(k + 1, 3) for k in range(8)),
                 reference_dofs=(DOF(3, 3),), quantity="accelerance")
    wide = identify(frf, band_hz=(4.0, 500.0))
    narrow = identify(frf, band_hz=(4.0, 80.0))
    assert np.allclose(wide.fn_hz, fn[:6], rtol=2e-3), wide.fn_hz
    for r in (0, 1):  # 12 and 48 Hz
        i = int(np.argmin(np.abs(wide.fn_hz - fn[r])))
        j = int(np.argmin(np.abs(narrow.fn_hz - fn[r])))
        assert _shape_mac(wide, i, narrow, j) >= 0.999, (fn[r], _shape_mac(wide, i, narrow, j))
        truth = mac_pairs(wide.modes.shapes[:, [i]], phi[:, [r]].astype(complex))[0]
        assert truth >= 0.999 and wide.mpc[i] >= 0.99, (fn[r], truth, wide.mpc[i])


def test_real_beam_shapes_do_not_depend_on_the_band(beam_results):
    """Issue 42: every published mode (and its neighbour beside 118.9 Hz)
    found at the defaults and in a band of :data:`BEAM_BANDS` (5 Hz inside
    it) has the same shape there: MAC >= 0.98 (measured: 33 pairs, >= 0.994;
    before, with the whole band's LSFD: 17.1 Hz 0.88 against 5-400 Hz and
    0.89 against 10-130 Hz, 118.0 and 119.4 Hz 0.77-0.81 against 10-130 and
    100-400 Hz). The first mode is a half sine
    along each of the two lines of hammer points (2-16, 19-33): MAC 0.996
    (0.90 before; 0.98 in 10-130 Hz)."""
    from ema_pipeline.modal import mac_pairs

    free = beam_results[None]
    near = np.min(np.abs(free.fn_hz[:, None] - PUBLISHED_HZ[None, :]), axis=1) <= 1.0
    assert {118.0, 119.4} <= {round(float(f_hz), 1) for f_hz in free.fn_hz[near]}
    n_pairs = 0
    for band, res in beam_results.items():
        if band is None:
            continue
        for i in np.flatnonzero(near & (free.fn_hz > band[0] + 5) & (free.fn_hz < band[1] - 5)):
            j = int(np.argmin(np.abs(res.fn_hz - free.fn_hz[i])))
            assert abs(res.fn_hz[j] - free.fn_hz[i]) < 1.0, (band, free.fn_hz[i], res.fn_hz)
            assert _shape_mac(free, i, res, j) >= 0.98, (band, free.fn_hz[i],
                                                         _shape_mac(free, i, res, j))
            n_pairs += 1
    assert n_pairs >= 30, n_pairs
    nodes = np.array([d.node for d in free.modes.dofs])
    x = np.where(nodes <= 17, nodes - 1.0, nodes - 18.0) / 16.0
    first = int(np.argmin(np.abs(free.fn_hz - 17.1)))
    sine = np.sin(np.pi * x)[:, None].astype(complex)
    assert mac_pairs(free.modes.shapes[:, [first]], sine)[0] >= 0.98
    assert free.mpc[first] >= 0.95, free.mpc[first]


def test_real_beam_expect_gives_the_automatic_damping(real_uff, beam_results):
    """Issue 31: --expect gives the automatic selection's damping for the same
    pole, within its sigma (119.4 Hz: 0.468 % with --expect against 0.106 %
    automatic before; the expected pole was refined without its neighbour at
    118.0 Hz). Band 5-400 Hz keeps it cheap."""
    from ema_pipeline.io import read_frf

    auto = beam_results[(5.0, 400.0)]
    frf = read_frf(real_uff).reciprocal()
    res = identify(frf, band_hz=(5.0, 400.0), expect_hz=(17, 69, 119, 155))
    assert res.modes.n_modes == 4
    for f_hz, zeta, zeta_std in zip(res.fn_hz, res.zeta, res.modes.zeta_std, strict=True):
        k = np.argmin(np.abs(auto.fn_hz - f_hz))
        assert abs(auto.fn_hz[k] - f_hz) < 0.05, (f_hz, auto.fn_hz)
        assert abs(auto.zeta[k] - zeta) <= max(zeta_std, auto.modes.zeta_std[k]), (
            f_hz, zeta, auto.zeta[k])
    k = np.argmin(np.abs(res.fn_hz - 119.4))
    assert abs(res.fn_hz[k] - 119.4) < 0.1 and res.zeta[k] < 0.002, (res.fn_hz, res.zeta)


def _peak_prominence(real_uff: Path, freq_hz: np.ndarray, within_hz: float = 3.0
                     ) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``freq_hz``: the largest prominence of log|H| of a peak
    within ``within_hz`` over the 30 FRFs of the measured beam, and in how many
    FRFs such a peak stands out by more than a factor e^0.5 = 1.65."""
    from scipy.signal import find_peaks

    from ema_pipeline.io import read_frf

    frf = read_frf(real_uff)
    best = np.zeros(freq_hz.size)
    count = np.zeros(freq_hz.size, dtype=int)
    for a in np.abs(frf.H[0]):
        peaks, props = find_peaks(np.log(a), prominence=0)
        near = np.abs(frf.freq_hz[peaks][:, None] - freq_hz[None, :]) <= within_hz
        prom = np.where(near, props["prominences"][:, None], 0.0).max(axis=0, initial=0.0)
        best = np.maximum(best, prom)
        count += prom > 0.5
    return best, count


def test_real_beam_235_hz_is_not_in_the_data(real_uff):
    """The published 235.23 Hz mode is not observable from response point 3:
    no FRF of the 30 has a peak within 3 Hz of it that stands out of its
    surroundings (largest prominence of log|H| 0.05, a factor 1.05), while
    every other published mode has one in some FRF (prominence factor 2.6 at
    707.2 Hz, 18 or more at the others). No identification can find it here."""
    best, _ = _peak_prominence(real_uff, PUBLISHED_HZ)
    at_235 = np.isclose(PUBLISHED_HZ, 235.23)
    assert best[at_235][0] < 0.1, best
    assert np.all(best[~at_235] > 0.9), best


def test_real_beam_has_resonances_the_published_list_lacks(real_uff):
    """The published list is not every resonance of the file: 274.6 and
    325.1 Hz stand out of their surroundings in 16 and 15 of the 30 FRFs
    (largest prominence factors 254 and 5.9; the FRFs at the nodal lines of
    the 265.2 Hz bending mode, x = 0.2, 0.4, 0.6 m, on both edges), while the
    published 707.2 Hz does so in one FRF (factor 2.6). A rule that finds
    707.2 Hz from this data finds these two as well, so issue 11's "13 of the
    14 published modes and at most 1 other below 800 Hz" cannot both hold
    for a rule that treats the file consistently (README, measured beam)."""
    published, n_published = _peak_prominence(real_uff, np.array([707.2]), within_hz=1.5)
    others, n_others = _peak_prominence(real_uff, np.array([274.6, 325.1]), within_hz=1.5)
    assert published[0] < 1.0 and n_published[0] <= 2, (published, n_published)
    assert np.all(others > 1.5 * published[0]), others
    assert np.all(n_others >= 10), n_others


def test_found_twice_apart_marks_the_modes_whose_twins_refined_elsewhere(beam_results, real_uff):
    """A mode the final tests found twice (two candidates, one kept) whose
    other candidate refined more than ``twin_max_sigma`` (1) of its f sigma
    away is marked ``found_twice_apart``: which start was kept moves its value
    by more than its sigma says. On the measured beam in 100-400 Hz the
    155.5 Hz resonance has three diagram candidates within 1 Hz; a change of
    the FRFs in their last bits can keep the other twin (155.50 -> 155.48 Hz,
    0.6 sigma, docs/validation.md): the mode is marked in both answers. The
    rule off (``twin_max_sigma`` inf) marks none; a clean simulation has no
    twins."""
    from dataclasses import replace

    from ema_pipeline.identification import IdentificationOptions
    from ema_pipeline.identification.thresholds import SelectionThresholds
    from ema_pipeline.io import read_frf

    def marked(res: IdentificationResult) -> np.ndarray:
        return res.fn_hz[doubtful_flags(res)["found_twice_apart"]]

    band = (100.0, 400.0)
    np.testing.assert_allclose(marked(beam_results[band]), [155.50, 362.91], atol=0.05)
    np.testing.assert_allclose(marked(beam_results[None]), [362.84], atol=0.05)
    assert all("found_twice_apart" in r for r, f in zip(
        doubtful_reasons(beam_results[band]), doubtful_flags(beam_results[band])[
            "found_twice_apart"], strict=True) if f)
    frf = read_frf(real_uff)
    changed = replace(frf, H=frf.H * (1 + 1e-12 * np.random.default_rng(4).standard_normal(
        frf.H.shape))).reciprocal()
    other = identify(changed, band_hz=band)
    assert np.min(np.abs(marked(other) - 155.49)) < 0.05  # 155.50 or 155.48: marked either way
    off = identify(frf.reciprocal(), IdentificationOptions(
        band_hz=band, thresholds=replace(SelectionThresholds(), twin_max_sigma=np.inf)))
    assert marked(off).size == 0
    np.testing.assert_array_equal(off.fn_hz, beam_results[band].fn_hz)  # a mark, not a number
    f = np.linspace(0.0, 100.0, 401)
    truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    assert marked(identify(FRFSet(freq_hz=f, H=H))).size == 0
