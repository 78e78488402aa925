"""Issue 42: impact tests with one to three channels, and pyFRF's real
one-channel recording.

With fewer than three channels no shape tells two close modes from one
(``SelectionThresholds.min_shape_channels``), so a pole is kept as a second
mode beside a close partner only on evidence one channel can give: two poles
fit the pair's local problem better than one beyond what the noise explains
(``pairs.pair_significance``, an F test) or the FRFs show two peaks
(``pairs.peaks_apart``); otherwise the weaker pole is dropped and the
mode marked ``second_pole_not_significant``. Two poles kept under one peak
are marked ``pair_under_one_peak`` (doubtful, kept).

The generator families of ``tests/hardcases.py`` (``FEW_CHANNEL_FAMILIES``:
``impact_1ch``, ``impact_2ch``, one hammer point and one or two
accelerometers, a close partner in half of the cases; ``impact_close`` with
one accelerometer too) are identified on seeds 1-3 here by the background
job of ``tests/conftest.py`` (about 2 s a file); the measurement seeds of
``benchmarks/issue42_measurements.md`` (200-207) and the development seeds
(300-339) are not used. Target, as for the other families: at most 2 % of
the true modes missed and 2 % spurious (on these seeds: none).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline.data import FRFSet
from ema_pipeline.identification import (
    SelectionThresholds,
    doubtful_reasons,
    identify,
)
from ema_pipeline.identification.selection.pairs import (
    close_pairs,
    f_quantile,
    pair_significance,
    peaks_apart,
    unsupported_partners,
)
from ema_pipeline.identification.selection.partners import close_partners
from tests import hardcases
from tests.jobs import Background
from tests.test_identification_hard import scores

TH = SelectionThresholds()  # the tuned defaults

SEEDS = (1, 2, 3)
BACKGROUND = {f"hard:{f}": SEEDS for f in hardcases.FEW_CHANNEL_FAMILIES}


# --------------------------------------------------------------------------- generators
def test_few_channel_families_have_one_or_two_channels_and_visible_modes() -> None:
    """impact_1ch and impact_2ch are impact tests (exponential window, H1 of
    3-5 hits) with one and two accelerometers; impact_close-1, which drew one
    accelerometer, now keeps it (it had two before issue 42). In each, every
    true mode stands at least 20 dB over the noise (hardcases.impact_visibility:
    weak residues are scaled up)."""
    for family, n_out in (("impact_1ch", 1), ("impact_2ch", 2), ("impact_close", 1)):
        case = hardcases.make_case(family, 1)
        frf = case.frf
        assert frf.n_out == n_out and frf.n_in == 1, (family, frf.H.shape)
        assert frf.acquisition.exp_window_tau_s > 0 and frf.acquisition.n_averages >= 3
        lam = hardcases.modal_poles(case.fn_hz, case.zeta) - 1 / frf.acquisition.exp_window_tau_s
        vis = hardcases.impact_visibility(frf.freq_hz, frf.H[:, 0, :], lam)
        assert vis.min() >= hardcases.MIN_VISIBILITY, (family, vis.round(1))
    assert set(hardcases.FEW_CHANNEL_FAMILIES).isdisjoint(hardcases.FAMILIES)


# --------------------------------------------------------------------------- the rule
def _one_channel(fn_hz: list[float], amp: list[float], noise: float = 1e-3,
                 seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lines, a one-channel receptance of modes ``fn_hz`` (decay rate 3 1/s,
    residues ``amp``) with complex noise of std ``noise``, and their poles."""
    f = np.linspace(80.0, 120.0, 801)
    jw = 2j * np.pi * f
    lam = -3.0 + 2j * np.pi * np.asarray(fn_hz)
    H = sum(a / (jw - p) + a / (jw - p.conj()) for a, p in zip(amp, lam, strict=True))
    rng = np.random.default_rng(seed)
    H = H + noise * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    return f, np.asarray(H)[None, :], lam


def test_one_channel_keeps_a_pair_only_on_evidence() -> None:
    """One channel, a pole 0.8 Hz (1.7 half-power bandwidths) beside a lone
    mode: the data do not prefer the pair to one pole (significance below 1),
    no second peak shows, so the weaker is dropped. Two true modes as far
    apart under one peak (no dip between them): the F test prefers the pair
    by far (significance above 100), both stay. Two modes 4 Hz apart show two
    peaks. With three channels nothing is dropped here (their shapes are
    judged by the final tests instead)."""
    f, H, lam = _one_channel([99.0, 99.8], [1.0, 0.0])
    assert pair_significance(f, H, lam, 0, 1, "receptance", thresholds=TH) < 1.0
    drop, merged = unsupported_partners(f, H, lam, "receptance", thresholds=TH)
    assert drop.tolist() == [False, True] and merged.tolist() == [True, False]
    f, H, lam = _one_channel([99.0, 99.8], [1.0, 0.6])
    assert not peaks_apart(f, H, lam[0], lam[1], thresholds=TH)
    assert pair_significance(f, H, lam, 0, 1, "receptance", thresholds=TH) > 100
    assert not unsupported_partners(f, H, lam, "receptance", thresholds=TH)[0].any()
    f, H2, lam2 = _one_channel([98.0, 102.0], [1.0, 0.6])
    assert peaks_apart(f, H2, lam2[0], lam2[1], thresholds=TH)
    f, H, lam = _one_channel([99.0, 99.8], [1.0, 0.0])
    three = np.concatenate([H, 0.5 * H, -H])
    assert not unsupported_partners(f, three, lam, "receptance", thresholds=TH)[0].any()


def test_window_correlation_raises_the_bar() -> None:
    """An exponential window correlates the noise of neighbouring lines; the
    critical value of the F test is raised by sum |rho|^2 (tau of 0.1 s at
    0.05 Hz lines: about 200), so the same data are less
    significant with the window than without."""
    f, H, lam = _one_channel([99.0, 99.8], [1.0, 0.05], noise=2e-3, seed=3)
    plain = pair_significance(f, H, lam, 0, 1, "receptance", thresholds=TH)
    windowed = pair_significance(f, H, lam, 0, 1, "receptance", window_tau_s=0.1, thresholds=TH)
    assert plain > 1.0 and windowed < plain / 20, (plain, windowed)


def test_f_quantile_matches_the_tables() -> None:
    """Paulson's approximation against tabulated F quantiles (within 2 %)."""
    for (p, d1, d2), exact in {(0.999, 4, 60): 5.307, (0.999, 6, 120): 4.036,
                               (0.99, 4, 1e9): 3.319, (0.999, 2, 30): 8.773}.items():
        assert abs(f_quantile(p, d1, d2) / exact - 1) < 0.02, (p, d1, d2)


@pytest.mark.parametrize(("field", "value"), [("pair_significance_level", 1e-12),
                                               ("pair_max_gap", 1.0), ("pair_min_dip", 0.1)])
def test_pair_thresholds_change_the_verdict(field: str, value: float) -> None:
    """Each threshold of the one-channel pair rule changes its verdict: a
    pair 1.6 Hz apart (3.4 half-power half-widths), its weaker mode 0.2 % of
    the other, is kept at the defaults (significance 1.8); at the level
    1e-12 it is not (0.45) and the weaker pole is dropped; with a close-pair
    distance of 1 half-width it is no pair to judge; and a dip of 0.1 asked
    of two peaks no longer sees the pair 4 Hz apart (valley 0.14 of the
    lower peak) as two peaks."""
    from dataclasses import replace

    th = replace(SelectionThresholds(), **{field: value})
    if field == "pair_min_dip":
        f, H, lam = _one_channel([98.0, 102.0], [1.0, 0.6])
        assert peaks_apart(f, H, lam[0], lam[1], thresholds=TH)
        assert not peaks_apart(f, H, lam[0], lam[1], thresholds=th)
        return
    f, H, lam = _one_channel([99.0, 100.6], [1.0, 0.002], noise=4e-4, seed=5)
    assert close_pairs(lam, thresholds=TH) == [(0, 1)]
    assert not unsupported_partners(f, H, lam, "receptance", thresholds=TH)[0].any()
    if field == "pair_max_gap":
        assert close_pairs(lam, thresholds=th) == []
        return
    assert unsupported_partners(f, H, lam, "receptance", thresholds=th)[0].tolist() == [
        False, True]


def test_one_channel_partner_is_added_where_the_test_is_calibrated() -> None:
    """One channel, a weak mode (30 %) 0.8 Hz beside a strong one that the
    diagram gave alone: the split fit's extra pole is significant and the
    other modes' splits are not (the test sees only noise), so it is added.
    With ``partner_max_split_median`` 0 (as if model error made every split
    significant, as on the pyFRF recording) it is not."""
    from dataclasses import replace

    f = np.linspace(60.0, 160.0, 2001)
    jw = 2j * np.pi * f
    lam = -3.0 + 2j * np.pi * np.array([75.0, 100.0, 100.8, 130.0])
    amp = [1.0, 1.0, 0.3, 0.8]
    H = sum(a / (jw - p) + a / (jw - p.conj()) for a, p in zip(amp, lam, strict=True))
    rng = np.random.default_rng(7)
    H = (H + 1e-3 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)))[None]
    kept = lam[[0, 1, 3]]
    found = close_partners(f, H, kept, "receptance", thresholds=TH).pole
    # the split's two poles are the pair: the extra one is either
    assert found.size == 1 and np.min(np.abs(found[0] - lam[1:3])) < 2 * np.pi * 0.05, found
    none = replace(SelectionThresholds(), partner_max_split_median=0.0)
    assert close_partners(f, H, kept, "receptance", thresholds=none).pole.size == 0


def _hits(drift: float = 0.0, pair_amp: float = 0.6) -> FRFSet:
    """One-channel receptance, 60-160 Hz at 0.05 Hz lines: modes at 75, 100,
    100.8 (residue ``pair_amp``; 0.8 Hz = 1.7 half-power bandwidths from
    100 Hz, under its peak) and 130 Hz, decay rate 3 1/s, complex noise of
    std 1e-3; the mean of five hits whose frequencies are scaled by 1 +
    (-drift ... +drift) (a structure whose frequencies vary between hits)."""
    f = np.linspace(60.0, 160.0, 2001)
    jw = 2j * np.pi * f
    fn = np.array([75.0, 100.0, 100.8, 130.0])
    amp = np.array([1.0, 1.0, pair_amp, 0.8])
    H = np.zeros(f.size, complex)
    for scale in 1 + np.linspace(-drift, drift, 5):
        lam = -3.0 + 2j * np.pi * fn * scale
        H += sum(a / (jw - p) + a / (jw - p.conj()) for a, p in zip(amp, lam, strict=True))
    rng = np.random.default_rng(7)
    H = H / 5 + 1e-3 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    return FRFSet(freq_hz=f, H=H[None, None, :], quantity="receptance")


def _marked(frf: FRFSet, **overrides: object) -> tuple[np.ndarray, np.ndarray, list[bool]]:
    """Identified f_n (Hz), their poles and which are ``pair_under_one_peak``."""
    res = identify(frf, **overrides)
    marked = ["pair_under_one_peak" in r.split(";") for r in doubtful_reasons(res)]
    return res.modes.fn_hz, hardcases.modal_poles(res.modes.fn_hz, res.modes.zeta), marked


def test_pair_under_one_peak_is_not_marked_where_the_f_test_shows_two_modes() -> None:
    """One channel, two true modes 0.8 Hz apart under one peak (no dip):
    the F test of two poles against one prefers the pair by far (5600 times
    its critical value) and is calibrated on the file (the other modes'
    splits are not significant), so the pair is not marked doubtful (it was
    before: every pair under one peak was). With
    ``pair_clear_significance`` above that, or without calibration
    (``partner_max_split_median`` 0, as on the pyFRF recording), it is."""
    from dataclasses import replace

    frf = _hits()
    f_hz, lam, marked = _marked(frf)
    assert np.allclose(f_hz, [75.0, 100.0, 100.8, 130.0], atol=0.02), f_hz
    assert marked == [False] * 4
    f, H = frf.freq_hz, frf.H[:, 0, :]
    assert close_pairs(lam, thresholds=TH) == [(1, 2)]
    assert not peaks_apart(f, H, lam[1], lam[2], thresholds=TH)
    sig = pair_significance(f, H, lam, 1, 2, "receptance", thresholds=TH)
    assert 2000 < sig < 2e4, sig
    found = close_partners(f, H, lam, "receptance", thresholds=TH)
    assert found.calibrated
    # the splits stopped on their residual ratio (none is a partner) and are
    # fitted to the end for the calibration: the significances of finished fits
    search = found.calibration.search
    assert all(s.refit and s.split_poles is None for s in found.calibration.splits)
    finished = [search.significance(r, search.split_poles(r, search.split(r)))
                for r in range(lam.size)]
    assert found.calibration.significances().tolist() == finished
    th = SelectionThresholds()
    for change in ({"pair_clear_significance": 1e5}, {"partner_max_split_median": 0.0}):
        _, _, marked = _marked(frf, thresholds=replace(th, **change))
        assert marked == [False, True, True, False], change


def test_a_mode_whose_frequency_varies_stays_marked() -> None:
    """Three lone modes (75, 100, 130 Hz) whose frequencies vary by +-0.5 %
    over five hits: each is fitted as two poles 0.55-1.05 Hz apart under
    one peak, and the F test prefers two poles by far (500-820 times its
    critical value). But it does so beside every mode (the test is not
    calibrated on this file: model error, not noise), so all six stay
    marked ``pair_under_one_peak``, as on pyFRF's recording."""
    frf = _hits(drift=0.005, pair_amp=0.0)
    f_hz, lam, marked = _marked(frf)
    assert np.allclose(f_hz, [74.72, 75.29, 99.60, 100.39, 129.48, 130.53], atol=0.05), f_hz
    f, H = frf.freq_hz, frf.H[:, 0, :]
    pairs = close_pairs(lam, thresholds=TH)
    assert pairs == [(0, 1), (2, 3), (4, 5)]
    sig = [pair_significance(f, H, lam, i, j, "receptance", thresholds=TH) for i, j in pairs]
    assert min(sig) > 100 * SelectionThresholds().pair_clear_significance, sig
    assert not close_partners(f, H, lam, "receptance", thresholds=TH).calibrated
    assert marked == [True] * 6


# --------------------------------------------------------------------------- targets
@pytest.mark.parametrize("family", hardcases.FEW_CHANNEL_FAMILIES)
def test_few_channel_impact_tests_no_mode_missed_or_invented(family: str,
                                                             background: Background) -> None:
    """Seeds 1-3 of each family (about 20 true modes): none missed, none
    invented (at most 2 %)."""
    s = scores(family, SEEDS, background)
    assert s["n_true"] >= 18, s["n_true"]
    assert s["missed"] <= 0.02 * s["n_true"], s
    assert s["spurious"] <= 0.02 * s["n_true"], s


# --------------------------------------------------------------------------- the real recording
def test_real_one_channel_recording_marks_what_one_channel_cannot_split(
        pyfrf_identified: Path) -> None:
    """pyFRF's recording (one hammer, one accelerometer, 0.64 s records:
    1.56 Hz lines) at the defaults (up to the force's -20 dB point, 7017 Hz):
    35 modes, as before issue 42 (none dropped, none added). The pairs 2-4 Hz
    apart (1.3-2.6 lines: 1518.1/1520.2, 3664.9/3668.9, 4163.2/4166.4 Hz)
    are two poles under one peak; the fit prefers two poles (F 20-1e4 times
    its critical value), but that is leakage-shaped model error as much as
    a mode, and one channel has no shape to tell: both of each pair are
    marked ``pair_under_one_peak``, in words in the report, and so are three
    more pairs (899.95/906.25, 5969.5/5983.5, 6060.5/6077.2 Hz): twelve
    modes. The F test is not calibrated on this recording (it prefers two
    poles beside most modes), so it does not lift these marks. Modes with a
    peak of their own (810.4, 851.6, 2640.3, 4421.0 Hz) are not."""
    table = pd.read_csv(pyfrf_identified / "id" / "real_modes.csv")
    assert len(table) == 35, table["fn_hz"].round(1).tolist()
    assert table["fn_hz"].max() < 7017.2
    reasons = dict(zip(table["fn_hz"].round(1), table["doubtful_reason"].fillna(""),
                       strict=True))
    pairs = ((900.0, 906.3), (1518.1, 1520.2), (3664.9, 3668.9), (4163.2, 4166.4),
             (5969.5, 5983.5), (6060.5, 6077.2))
    for pair in pairs:
        for f_hz in pair:
            assert "pair_under_one_peak" in reasons[f_hz], (f_hz, reasons)
    assert sum("pair_under_one_peak" in r for r in reasons.values()) == 12
    for f_hz in (810.4, 851.6, 2640.3, 4421.0):
        assert "pair" not in reasons[f_hz] and "second_pole" not in reasons[f_hz], f_hz
    assert not any("second_pole_not_significant" in r for r in reasons.values())
    page = (pyfrf_identified / "id" / "real_report.html").read_text(encoding="utf-8")
    assert "pair under one peak" in page
    # the flags are stored with the result: read back, the same reasons
    from ema_pipeline import io
    from ema_pipeline.identification import doubtful_reasons

    _, back = io.read_identification_result(pyfrf_identified / "id" / "real_result.h5")
    assert back.pair_flags.size == 35
    order = np.argsort(back.fn_hz)
    assert [doubtful_reasons(back)[k] for k in order] == list(table["doubtful_reason"].fillna(""))
