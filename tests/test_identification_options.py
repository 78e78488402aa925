"""Every option of ``IdentificationOptions`` changes the result, in the direction
its documentation gives, checked against the known truth of simulated data.

Options tested elsewhere: ``band_hz`` and ``max_order`` (test_identification.py:
test_band_of_few_lines_finds_its_modes, test_too_few_lines_for_order), ``method``
(test_sdypy_backend_agrees), ``expect_hz`` (test_expect_picks_nearest_clusters),
``weighting`` (test_coherence_weighting_helps_against_a_bad_channel).

The command line's identification options (``identify`` and ``batch``: band,
order, method, window searches, final tests, memory limit, verbosity,
geometry) change what they write, on noise-free FRFs of known modes (every
option's test: test_option_inventory.py).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.acquisition import modal_frf
from ema_pipeline.cli import main
from ema_pipeline.data import DOF, FRFSet, ModalParameters
from ema_pipeline.identification import (
    IdentificationOptions,
    SelectionThresholds,
    doubtful_reasons,
    identify,
)
from ema_pipeline.io import experiment as schema
from ema_pipeline.io.hdf5 import read_results_h5
from tests.cli_runs import TWO_MODES, run_cli, shape_data
from tests.hardcases import make_case

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


# the command line's identification options (identify, batch)
def _orders(result_h5: Path) -> np.ndarray:
    return np.asarray(read_results_h5(result_h5)["identification"]["settings"]["orders"])


def test_identify_options_change_the_result(two_mode_folder: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """On the noise-free 30/70 Hz FRF: --band 50 100 keeps only the 70 Hz mode;
    --max-order 16 is the diagram's highest order; --method sdypy-lscf is the
    stored method and still finds both modes; --quiet prints nothing; --out is
    where the tables go."""
    src = two_mode_folder / "two.uff"
    code, said, _ = run_cli(["identify", src, "--out", tmp_path / "base"], capsys)
    assert code == 0 and "2 modes" in said
    base = pd.read_csv(tmp_path / "base" / "two_modes.csv")
    np.testing.assert_allclose(base["fn_hz"], TWO_MODES.fn_hz, rtol=1e-5)
    assert _orders(tmp_path / "base" / "two_result.h5").max() != 16
    code, said, _ = run_cli(["identify", src, "--out", tmp_path / "band", "--band", "50", "100",
                          "--quiet"], capsys)
    assert code == 0 and said == ""
    np.testing.assert_allclose(pd.read_csv(tmp_path / "band" / "two_modes.csv")["fn_hz"],
                               [70.0], rtol=1e-5)
    assert run_cli(["identify", src, "--out", tmp_path / "order", "--max-order", "16", "--quiet"],
                capsys)[0] == 0
    assert _orders(tmp_path / "order" / "two_result.h5").max() == 16
    assert run_cli(["identify", src, "--out", tmp_path / "sdypy", "--method", "sdypy-lscf",
                 "--max-order", "20", "--quiet"], capsys)[0] == 0
    stored = read_results_h5(tmp_path / "sdypy" / "two_result.h5")["identification"]
    assert stored["settings"]["method"] == "sdypy-lscf"
    assert read_results_h5(tmp_path / "base" / "two_result.h5")["identification"][
        "settings"]["method"] == "plscf"
    np.testing.assert_allclose(pd.read_csv(tmp_path / "sdypy" / "two_modes.csv")["fn_hz"],
                               TWO_MODES.fn_hz, rtol=1e-3)


def test_batch_options_change_the_result(two_mode_folder: Path, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    """batch passes the identification options on: --band 50 100 keeps the 70 Hz
    mode, --expect 70 fills expect_hz, --exp-window-tau 10 s removes
    1/(tau 2 pi fn) from the damping (2 % -> 1.977 %), --max-order 20 and --method
    sdypy-lscf reach the stored settings; --quiet prints nothing, --no-figures
    leaves the report without figures; a rerun skips the file, --force redoes it."""
    out = tmp_path / "out"
    options = ["--band", "50", "100", "--expect", "70", "--exp-window-tau", "10",
               "--max-order", "20", "--method", "sdypy-lscf", "--workers", "1"]
    code, said, _ = run_cli(["batch", two_mode_folder, "--out", out, *options, "--quiet",
                          "--report", "--no-figures"], capsys)
    assert code == 0 and said == ""
    modes = pd.read_csv(out / "two_modes.csv")
    assert modes["expect_hz"].tolist() == [70.0]
    assert modes["fn_hz"].tolist() == pytest.approx([70.0], rel=1e-4)
    zeta_pct = 2.0 - 100 / (10 * 2 * np.pi * 70.0)
    assert modes["zeta_pct"].iloc[0] == pytest.approx(zeta_pct, rel=2e-3)
    stored = read_results_h5(out / "two_result.h5")["identification"]["settings"]
    assert stored["method"] == "sdypy-lscf" and stored["max_order"] == 20
    assert "<svg" not in (out / "report.html").read_text()
    code, said, _ = run_cli(["batch", two_mode_folder, "--out", out, *options, "--report"], capsys)
    assert code == 0 and "1 skipped" in said
    code, said, _ = run_cli(["batch", two_mode_folder, "--out", out, *options, "--force",
                          "--report"], capsys)
    assert code == 0 and "1 ok, 0 skipped" in said
    assert "<svg" in (out / "report.html").read_text()


#: Twelve well-separated modes, enough candidates for the window searches of a
#: dense band (``SelectionThresholds.window_min_modes``).
TWELVE_MODES = ModalParameters(
    fn_hz=[40.0, 85.0, 130.0, 180.0, 225.0, 270.0, 330.0, 380.0, 430.0, 490.0, 545.0, 610.0],
    zeta=[0.01] * 12)


def _twelve_frf() -> FRFSet:
    """:data:`TWELVE_MODES` noise-free, 3 x 1 receptances, 0-800 Hz."""
    f = np.linspace(0.0, 800.0, 2049)
    phi = np.random.default_rng(3).standard_normal((3, 12))
    return FRFSet(freq_hz=f, H=modal_frf(f, TWELVE_MODES, phi, phi[:1], quantity="receptance"),
                  quantity="receptance")


@pytest.fixture(scope="module")
def twelve(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str]:
    """:func:`_twelve_frf` as IN/twelve.uff and ``identify --quiet`` of it at the
    defaults, run once for the window-search and fixed-order tests: (the file,
    the output folder, the run's stderr)."""
    import contextlib
    import io as text_io

    root = tmp_path_factory.mktemp("twelve")
    (root / "in").mkdir()
    src = io.write_frf(_twelve_frf(), root / "in" / "twelve.uff", "uff")
    err = text_io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["identify", str(src), "--out", str(root / "default"), "--quiet"])
    assert code == 0, err.getvalue()
    return src, root / "default", err.getvalue()


def test_no_window_search_skips_the_window_searches(twelve: tuple[Path, Path, str],
                                                    tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """On a noise-free twelve-mode FRF (3 x 1, 0-800 Hz): by default the band is
    searched again in windows of consecutive candidates, so the middle modes are
    held by two of the narrower searches (``band_support``); with
    ``--no-window-search`` (identify and batch) only the low-band search is left,
    which holds none of them, the stored settings say so, and the twelve modes
    are the same. The experiment file's ``[identification] window_searches``
    is the same option. The default run is the module's (``twelve``)."""
    toml = tmp_path / "experiment.toml"
    assert schema.read_identification_options({"window_searches": False}, toml) == \
        IdentificationOptions(window_searches=False)
    with pytest.raises(io.DataError, match="window_searches"):
        schema.read_identification_options({"window_searches": "no"}, toml)
    src, default, _ = twelve
    folder = src.parent
    assert run_cli(["identify", src, "--out", tmp_path / "off", "--quiet", "--no-window-search"],
                capsys)[0] == 0
    stored = {}
    for name, out in (("default", default), ("off", tmp_path / "off")):
        stored[name] = read_results_h5(out / "twelve_result.h5")["identification"]
        np.testing.assert_allclose(pd.read_csv(out / "twelve_modes.csv")["fn_hz"],
                                   TWELVE_MODES.fn_hz, rtol=1e-5)
    middle = (np.asarray(TWELVE_MODES.fn_hz) > 200) & (np.asarray(TWELVE_MODES.fn_hz) < 500)
    held = {k: np.asarray(v["band_support"])[:, 0] for k, v in stored.items()}
    assert np.all(held["default"][middle] >= 2) and np.all(held["off"][middle] == 0)
    assert bool(stored["default"]["settings"]["window_searches"]) is True
    assert bool(stored["off"]["settings"]["window_searches"]) is False
    assert run_cli(["batch", folder, "--out", tmp_path / "batch", "--workers", "1", "--quiet",
                 "--no-window-search"], capsys)[0] == 0
    batch = read_results_h5(tmp_path / "batch" / "twelve_result.h5")["identification"]
    assert bool(batch["settings"]["window_searches"]) is False
    np.testing.assert_array_equal(np.asarray(batch["band_support"]), stored["off"]["band_support"])


def test_no_accept_keeps_the_untested_candidates(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """Hard case impact-1 (six modes, 2-900 Hz): ``identify`` keeps the six
    true modes; with ``--no-accept`` (identify and batch) the final tests are
    skipped and the three untested candidates above 780 Hz stay as well, with
    the same refined poles for the six (the library's ``accept=False``,
    ``test_identification_options.py::test_accept_runs_the_final_tests``);
    the stored settings say so. The experiment file's ``[identification]
    accept`` is the same option."""
    from tests.hardcases import make_case

    toml = tmp_path / "experiment.toml"
    assert schema.read_identification_options({"accept": False}, toml) == \
        IdentificationOptions(accept=False)
    with pytest.raises(io.DataError, match="accept"):
        schema.read_identification_options({"accept": "no"}, toml)
    case = make_case("impact", 1)
    folder = tmp_path / "in"
    folder.mkdir()
    io.write_frf(case.frf, folder / "impact.h5", "h5")
    src = folder / "impact.h5"
    band = ["--band", *map(str, case.band_hz)]
    table, stored = {}, {}
    for name, extra in (("default", []), ("untested", ["--no-accept"])):
        assert run_cli(["identify", src, "--out", tmp_path / name, "--quiet", *band, *extra],
                    capsys)[0] == 0
        table[name] = pd.read_csv(tmp_path / name / "impact_modes.csv")
        stored[name] = read_results_h5(tmp_path / name / "impact_result.h5")["identification"]
    np.testing.assert_allclose(table["default"]["fn_hz"], case.fn_hz, rtol=1e-3)
    untested = table["untested"]["fn_hz"].to_numpy()
    assert untested.size == 9 and np.all(untested[6:] > 780.0)
    np.testing.assert_allclose(untested[:6], table["default"]["fn_hz"], rtol=1e-6)
    assert bool(stored["default"]["settings"]["accept"]) is True
    assert bool(stored["untested"]["settings"]["accept"]) is False
    assert run_cli(["batch", folder, "--out", tmp_path / "batch", "--workers", "1", "--quiet",
                 *band, "--no-accept"], capsys)[0] == 0
    batch = pd.read_csv(tmp_path / "batch" / "impact_modes.csv")
    np.testing.assert_allclose(batch["fn_hz"], untested, rtol=1e-12)


def test_memory_limit_refuses_before_any_work(two_mode_folder: Path, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str],
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """--memory-limit-gb below the estimate of a fixed --max-order refuses it (exit 2
    in identify, a failed file in batch) and writes no result; the default limit
    lets the same settings run. Without --max-order the adaptive order search is
    estimated at the highest order it may reach, so the limit refuses it too."""
    src = two_mode_folder / "two.uff"
    # the option travels in the options (to batch workers too) and wins over the variable
    monkeypatch.setenv("EMA_PIPELINE_MEMORY_LIMIT_GB", "4")
    assert run_cli(["identify", src, "--out", tmp_path / "ok", "--max-order", "40", "--quiet"],
                capsys)[0] == 0
    code, _, err = run_cli(["identify", src, "--out", tmp_path / "id", "--max-order", "40",
                         "--memory-limit-gb", "1e-6"], capsys)
    assert code == 2 and "more than the limit" in err and "--memory-limit-gb" in err
    assert not (tmp_path / "id" / "two_modes.csv").exists()
    code, _, err = run_cli(["identify", src, "--out", tmp_path / "ad", "--memory-limit-gb", "1e-6"],
                        capsys)
    assert code == 2 and "more than the limit" in err
    assert not (tmp_path / "ad" / "two_modes.csv").exists()
    code, _, err = run_cli(["batch", two_mode_folder, "--out", tmp_path / "b", "--max-order", "40",
                         "--memory-limit-gb", "1e-6", "--workers", "1", "--quiet"], capsys)
    assert code == 1 and "more than the limit" in (tmp_path / "b" / "failures.csv").read_text()


def test_verbose_reaches_the_batch_workers(two_mode_folder: Path, tmp_path: Path) -> None:
    """--verbose prints the package's INFO messages (here: a UFF dataset the reader
    skips) on stderr, in identify and from batch's worker processes (which do not
    inherit the parent's logging set-up by themselves); without it they stay quiet."""
    folder = tmp_path / "in"
    folder.mkdir()
    text = (two_mode_folder / "two.uff").read_text()
    (folder / "two.uff").write_text(text + "    -1\n  2420\n         1\nSI\n    -1\n")
    def run(*argv: object) -> str:
        done = subprocess.run([sys.executable, "-m", "ema_pipeline", *map(str, argv)],
                              capture_output=True, text=True, check=True)
        return done.stderr
    said = "skipped datasets not needed for FRFs: 2420"
    for verbose in (True, False):
        extra = ["--verbose"] if verbose else []
        assert (said in run("identify", folder / "two.uff", "--out", tmp_path / f"i{verbose}",
                            "--quiet", *extra)) is verbose
        assert (said in run("batch", folder, "--out", tmp_path / f"b{verbose}", "--workers", "2",
                            *extra)) is verbose


def test_batch_geometry(two_mode_folder: Path, tmp_path: Path,
                        capsys: pytest.CaptureFixture[str]) -> None:
    """batch --report --geometry FILE: each file's report page animates its modes on
    the given nodes (the UFF file three.uff holds none: without --geometry no shape
    view); --geometry without --report is a usage error (exit 2) before any work.
    three.uff is two.uff with a third response: shapes of two points are not
    drawn (issue 41), as two.uff's page shows."""
    from ema_pipeline.data import Geometry

    folder = tmp_path / "in"
    folder.mkdir()
    shutil.copy(two_mode_folder / "two.uff", folder / "two.uff")
    f = np.linspace(0.0, 100.0, 801)
    phi = np.array([[1.0, 0.6], [0.5, -1.0], [-0.4, 0.8]])
    frf = FRFSet(freq_hz=f, H=modal_frf(f, TWO_MODES, phi, phi[:1], quantity="receptance"),
                 quantity="receptance", response_dofs=(DOF(1), DOF(2), DOF(3)),
                 reference_dofs=(DOF(1),))
    io.write_frf(frf, folder / "three.uff", "uff")
    xyz = np.array([[0.0, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.5, 0.25]])
    geometry = io.write_geometry_uff(Geometry(node_ids=np.array([1, 2, 3]), xyz_m=xyz,
                                              lines=((1, 2, 3),)), tmp_path / "geometry.uff")
    out = tmp_path / "out"
    code, _, err = run_cli(["batch", folder, "--out", out, "--geometry", geometry,
                         "--workers", "1", "--quiet"], capsys)
    assert code == 2 and "--report" in err and not out.exists()
    assert run_cli(["batch", folder, "--out", out, "--report", "--geometry", geometry,
                 "--workers", "1", "--quiet"], capsys)[0] == 0
    data = shape_data((out / "three_report.html").read_text())
    np.testing.assert_allclose(data["nodes"], xyz)
    assert data["lines"] == [[0, 1, 2]] and data["modes"][0]["m"] == [0, 1, 2]
    assert "data-mode-shape" not in (out / "two_report.html").read_text()
    assert run_cli(["batch", folder, "--out", out, "--report", "--force",
                 "--workers", "1", "--quiet"], capsys)[0] == 0
    assert "data-mode-shape" not in (out / "three_report.html").read_text()


def test_a_fixed_order_says_it_turned_the_narrower_searches_off(
        twelve: tuple[Path, Path, str], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Issue 38, item 3: ``--max-order`` fixes the diagram and turns off the
    narrower searches, which run with the adaptive order only. On the twelve-mode
    FRF (a dense band, 0-800 Hz) ``identify --max-order 60`` says so on stderr and
    the stored band support is empty; the adaptive run (the module's,
    ``twelve``) says nothing and its windows hold the middle modes."""
    from ema_pipeline.identification import identify

    src, default, default_err = twelve
    code, _, err = run_cli(["identify", src, "--out", tmp_path / "fixed", "--quiet",
                         "--max-order", "60"], capsys)
    assert code == 0
    assert "--max-order" in err and "the windows of a dense band" in err
    fixed = read_results_h5(tmp_path / "fixed" / "twelve_result.h5")["identification"]
    assert np.asarray(fixed["band_support"]).sum() == 0
    assert "narrower searches" not in default_err
    auto = read_results_h5(default / "twelve_result.h5")["identification"]
    middle = (np.asarray(TWELVE_MODES.fn_hz) > 200) & (np.asarray(TWELVE_MODES.fn_hz) < 500)
    assert np.all(np.asarray(auto["band_support"])[middle, 0] >= 2)
    with pytest.warns(UserWarning, match="turned off the narrower searches"):
        identify(_twelve_frf(), max_order=60)


def test_a_fixed_order_says_so_where_the_modes_look_sparse(
        example_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--max-order`` on a band the window searches would search only if its modes
    were dense (the example beam, 100-700 Hz: three modes, no band of their lowest
    1/8): the warning still says the window searches are off, since the modes of a
    fixed order need not be the adaptive order's; with ``--no-window-search`` nothing
    the user left on is turned off, and nothing is said."""
    src = example_dir / "genuine.uff"
    base = ["identify", src, "--band", "100", "700", "--max-order", "40", "--quiet"]
    with pytest.warns(UserWarning, match="the modes found make no dense band"):  # identify()'s
        code, _, err = run_cli([*base, "--out", tmp_path / "fixed"], capsys)
    assert code == 0
    assert err.strip() == (
        f"ema-pipeline identify: warning: {src}: max_order (--max-order) turned off the "
        "narrower searches that run with the adaptive order only (the windows of a dense "
        "band): the modes found make no dense band, but those of the adaptive order may")
    code, _, err = run_cli([*base, "--out", tmp_path / "off", "--no-window-search"], capsys)
    assert (code, err) == (0, "")
