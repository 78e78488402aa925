"""Every option of ``IdentificationOptions`` changes the result, in the direction
its documentation gives, checked against the known truth of simulated data.

Options tested elsewhere: ``band_hz`` and ``max_order`` (test_identification.py:
test_band_of_few_lines_finds_its_modes, test_too_few_lines_for_order), ``method``
(test_sdypy_backend_agrees), ``expect_hz`` (test_expect_picks_nearest_clusters),
``weighting`` (test_coherence_weighting_helps_against_a_bad_channel).
"""

from __future__ import annotations

import re
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
    """Hard case mimo-1 (6 modes, 2 references, noisy) and its fixed-order run's
    raw selection (the trajectory medians, untested)."""
    case = make_case("mimo", 1)
    base = identify(case.frf, band_hz=case.band_hz, max_order=40, refine=False, accept=False)
    return case, base


def test_stabilization_tolerances_reach_the_selection(mimo):
    """Stricter tolerances (1 %/30 %/0.05 -> 0.2 %/10 %/0.01) break the pole
    trajectories into more pieces, each mode's trajectory holds fewer orders and
    the diagram flags fewer poles stable; looser ones (3 %/60 %/0.15) the
    opposite. The same diagram (fixed order): only the linking differs. The
    trajectory medians move with them (refine=False reports them)."""
    case, base = mimo
    run = {"band_hz": case.band_hz, "max_order": 40, "refine": False, "accept": False}
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
                      accept=False, min_fraction=0.6)
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


@pytest.fixture(scope="module")
def impact_switches():
    """Hard case impact-1 (6 modes, 2-900 Hz, one hammer recording per point)
    identified with each combination of ``refine`` and ``accept``."""
    case = make_case("impact", 1)
    runs = {(refine, accept): identify(case.frf, band_hz=case.band_hz, refine=refine,
                                       accept=accept)
            for refine in (True, False) for accept in (True, False)}
    return case, runs


def test_refine_reports_the_refined_or_the_start_poles(impact_switches):
    """``refine=False`` keeps the final tests: the same six modes are kept as
    by default, the true ones (fn within 0.1 %), but their poles are the
    start poles the default refined (``stabilization.mode_pole``), not the
    refined ones, and the uncertainty is the trajectories' scatter. It
    changes what is reported, not what is kept."""
    case, runs = impact_switches
    default, start = runs[True, True], runs[False, True]
    for res in (default, start):
        assert res.modes.n_modes == case.fn_hz.size == 6
        np.testing.assert_allclose(res.fn_hz, case.fn_hz, rtol=1e-3)
        assert res.settings.accept
    np.testing.assert_array_equal(np.sort_complex(start.selected.pole),
                                  np.sort_complex(default.stabilization.mode_pole))
    np.testing.assert_array_equal(start.stabilization.mode_pole, start.selected.pole)
    assert np.max(np.abs(start.fn_hz - default.fn_hz) / default.fn_hz) > 1e-5
    assert start.settings.uncertainty.startswith("scatter")
    assert default.settings.uncertainty.startswith("least-squares")
    # the refined damping is nearer the truth (within 3.1 % against up to 4.8 %)
    err = {k: np.max(np.abs(r.zeta - case.zeta) / case.zeta) for k, r in
           (("refined", default), ("start", start))}
    assert err["refined"] < 0.031 < 0.04 < err["start"], err


def test_accept_runs_the_final_tests(impact_switches):
    """``accept=False`` keeps the refinement but skips the final tests: every
    candidate of the diagrams is kept, the six true modes with the same
    refined poles as by default (rtol 1e-7) and three candidates above 780 Hz
    where there is no mode (the true ones end at 241 Hz), which the final
    tests reject; the uncertainty is still the refined poles' covariance and
    no resonance is listed as not kept. With ``refine=False`` as well: the
    same nine candidates at their start poles (the raw selection)."""
    case, runs = impact_switches
    default, untested, raw = runs[True, True], runs[True, False], runs[False, False]
    assert untested.modes.n_modes == raw.modes.n_modes == 9
    true = untested.fn_hz < 300.0
    np.testing.assert_allclose(untested.pole[true], default.pole, rtol=1e-7)
    np.testing.assert_allclose(untested.modes.fn_std_hz[true], default.modes.fn_std_hz,
                               rtol=1e-3)
    spurious = untested.fn_hz[~true]
    assert spurious.size == 3 and spurious.min() > 780.0
    assert np.min(np.abs(spurious[:, None] - case.fn_hz[None, :]) / spurious[:, None]) > 0.5
    assert untested.settings.uncertainty.startswith("least-squares")
    assert not untested.settings.accept and untested.not_kept_hz.size == 0
    np.testing.assert_array_equal(raw.selected.pole, untested.stabilization.mode_pole)
    assert raw.settings.uncertainty.startswith("scatter")


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
                   accept=False, thresholds=strict)
    assert res.settings.thresholds is strict
    assert all("few_stable_orders" in r for r in doubtful_reasons(res))


# ------------------------------------------------------------ validation in one place
#: (field, impossible value, the CLI arguments that give it or None, the TOML
#: line that gives it or None, what the message says)
REFUSED = [
    ("max_order", 1, ["--max-order", "1"], "max_order = 1", "at least 12 for method 'plscf'"),
    ("max_order", 0, ["--max-order", "0"], "max_order = 0", "at least 12"),
    ("max_order", 40.5, None, "max_order = 40.5", "an integer"),
    ("max_order", 2000, ["--max-order", "2000"], "max_order = 2000", "an integer <= 1000"),
    ("exp_window_tau_s", -1.0, ["--exp-window-tau=-1"], None, "> 0"),
    ("exp_window_tau_s", float("inf"), ["--exp-window-tau=inf"], None, "finite"),
    ("min_fraction", 5, None, "min_fraction = 5", "in (0, 1]"),
    ("min_fraction", 0.0, None, "min_fraction = 0.0", "in (0, 1]"),
    ("band_hz", (300.0, 100.0), ["--band", "300", "100"], "band_hz = [300.0, 100.0]",
     "0 <= low < high"),
    ("band_hz", (-10.0, 100.0), ["--band", "-10", "100"], "band_hz = [-10.0, 100.0]",
     "0 <= low < high"),
    ("expect_hz", (-5.0, 20.0), ["--expect=-5,20"], "expect_hz = [-5.0, 20.0]",
     "entry 1 must be a finite number > 0, got -5.0"),
    ("method", "magic", None, 'method = "magic"', "one of 'plscf', 'sdypy-lscf'"),
    ("weighting", "snr", None, 'weighting = "snr"', "one of 'none', 'coherence'"),
    ("tol_freq", 0.0, None, "tol_freq = 0.0", "in (0, 1]"),
    ("tol_zeta", 20.0, None, "tol_zeta = 20.0", "in (0, 10]"),
    ("tol_mac", -0.1, None, "tol_mac = -0.1", "in (0, 1]"),
    ("refine", "yes", None, 'refine = "yes"', "a boolean"),
    ("accept", 0, None, "accept = 0", "a boolean"),
    ("window_searches", 1, None, "window_searches = 1", "a boolean"),
]


@pytest.mark.parametrize(("name", "value", "argv", "toml", "says"), REFUSED,
                         ids=[f"{r[0]}={r[1]!r}" for r in REFUSED])
def test_impossible_values_are_refused_everywhere(name, value, argv, toml, says, tmp_path,
                                                  example_dir, capsys):
    """Each impossible value is refused by ``IdentificationOptions`` itself (an
    OptionError, a ValueError, naming the field), by the command line (exit 2,
    one line naming the option, nothing written) and by the experiment file
    (one line naming the file, the table and the key): one rule, three doors."""
    from ema_pipeline.cli import main
    from ema_pipeline.data import DataError, OptionError
    from ema_pipeline.identification import IdentificationOptions
    from ema_pipeline.io.experiment import read_experiment

    with pytest.raises(OptionError, match=re.escape(says)) as info:
        IdentificationOptions(**{name: value})
    assert isinstance(info.value, ValueError) and info.value.field == name
    rule = "entry 1 must be " if name == "expect_hz" else "must be "  # which entry, for lists
    assert str(info.value).startswith(f"{name} {rule}")
    if argv is not None:
        out = tmp_path / "out"
        code = main(["identify", str(example_dir / "genuine.uff"), "--out", str(out), *argv])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1, err
        flag = argv[0].split("=")[0]
        assert f"error: {flag} {rule}" in err[0] and says in err[0], err
        assert not out.exists()
    if toml is not None:
        text = (example_dir / "experiment.toml").read_text()
        anchor = "[identification]\n"
        assert anchor in text
        if name in ("band_hz", "method"):  # keys the example sets: replace them
            text = re.sub(rf"(?m)^{name} = .*$", toml, text, count=1)
        else:
            text = text.replace(anchor, anchor + toml + "\n", 1)
        path = tmp_path / "experiment.toml"
        path.write_text(text)
        with pytest.raises(DataError) as info:
            read_experiment(path, check_files=False)
        message = str(info.value)
        assert message.startswith(f"{path}: [identification] {name}: {rule}"), message
        assert says in message and "\n" not in message


def test_experiment_configuration_window_uses_the_options_rule(tmp_path, example_dir):
    """``[[configurations]] exp_window_tau_s`` is checked by the rule of the
    option of that name."""
    from ema_pipeline.data import DataError
    from ema_pipeline.io.experiment import read_experiment

    text = (example_dir / "experiment.toml").read_text()
    path = tmp_path / "experiment.toml"
    path.write_text(text.replace('file = "larger_tank.h5"',
                                 'file = "larger_tank.h5"\nexp_window_tau_s = -1.0', 1))
    with pytest.raises(DataError, match=r"\[\[configurations\]\] 2 exp_window_tau_s: must be "
                                        r"a finite number of seconds > 0, got -1.0"):
        read_experiment(path, check_files=False)


def test_names_and_rules_have_one_home():
    """The method and weighting names are the ``Literal`` types of the options;
    the backends, the command line's choices, the order minimum per method and
    the experiment file's keys all derive from them."""
    from typing import get_args

    from ema_pipeline.cli.parser import build_parser
    from ema_pipeline.identification import METHODS, IdentificationOptions
    from ema_pipeline.identification.options import (
        METHOD_NAMES,
        MIN_ORDER,
        WEIGHTING_NAMES,
        Method,
        Weighting,
    )
    from ema_pipeline.io.experiment import SCHEMA

    assert METHOD_NAMES == get_args(Method) == ("plscf", "sdypy-lscf")
    assert WEIGHTING_NAMES == get_args(Weighting) == ("none", "coherence")
    assert tuple(METHODS) == tuple(MIN_ORDER) == METHOD_NAMES
    parser = build_parser()
    for command in ("identify", "batch"):
        method = next(a for a in parser.commands[command]._actions if a.dest == "method")
        assert tuple(method.choices) == METHOD_NAMES
    fields = set(IdentificationOptions.__dataclass_fields__)
    # the memory limit is the machine's (command line), not the experiment's
    assert set(SCHEMA["identification"]) == fields - {"exp_window_tau_s", "thresholds",
                                                      "memory_limit_gb"}
    assert IdentificationOptions(method="sdypy-lscf", max_order=10).max_order == 10


@pytest.mark.parametrize(("name", "value", "says"), [
    ("link_tol_freq", 0.0, "> 0"), ("min_members", 2.5, "an integer"),
    ("max_zeta", 2.0, "a number in (0, 1], got 2.0"),
    ("band_edge", (0.6, 0.0), "entry 1 must be a number in [0, 0.5), got 0.6"),
    ("peak_lines", float("nan"), "a number > 0"), ("min_frfs", -1, "an integer > 0"),
    ("link_max_gap", True, "an integer >= 0"), ("duplicate_min_mac", 1.5, "in [0, 1]"),
    ("band_edge", [0.1], "must have 2 entries, got 1"),
])
def test_thresholds_refuse_impossible_values(name, value, says):
    """``SelectionThresholds`` refuses what no threshold can be, naming the
    field; a value that is only strict (1e-9, 1000, inf) is kept."""
    from ema_pipeline.data import OptionError

    with pytest.raises(OptionError, match=re.escape(says)) as info:
        replace(SelectionThresholds(), **{name: value})
    assert info.value.field == name
    for field, fine in (("max_rel_decay_std", 1e-9), ("min_stable_orders", 1000),
                        ("min_weak_peak_snr", float("inf"))):
        assert getattr(replace(SelectionThresholds(), **{field: fine}), field) == fine


def test_the_alternates_gate_has_thresholds_of_its_own():
    """Issue 38, item 6: the gate of the narrower searches' alternates
    (``alternate_min_frfs``, ``alternate_peak_lines``) is not the listing of
    resonances not kept (``min_frfs``, ``peak_lines``): changing one leaves
    the other's rule alone."""
    from dataclasses import replace

    from ema_pipeline.identification.diagram.narrower_searches import shown_by_the_frfs
    from ema_pipeline.identification.thresholds import SelectionThresholds

    f = np.linspace(0.0, 100.0, 401)
    jw = 2j * np.pi * f
    lam = -0.5 + 2j * np.pi * 40.0
    H = np.tile(1 / (jw - lam) + 1 / (jw - np.conj(lam)), (2, 1))  # 2 FRFs show it
    poles = np.array([lam])
    th = SelectionThresholds()
    assert shown_by_the_frfs(f, H, poles, thresholds=th).tolist() == [True]
    assert shown_by_the_frfs(f, H, poles,
                             thresholds=replace(th, min_frfs=3, peak_lines=0.1)).tolist() == [True]
    assert shown_by_the_frfs(f, H, poles,
                             thresholds=replace(th, alternate_min_frfs=3)).tolist() == [False]
    # a peak 1 line off the pole's frequency: inside 1.5 lines, outside 0.5
    off = np.array([-0.5 + 2j * np.pi * 40.25])
    assert shown_by_the_frfs(f, H, off, thresholds=th).tolist() == [True]
    assert shown_by_the_frfs(f, H, off,
                             thresholds=replace(th, alternate_peak_lines=0.5)).tolist() == [False]
