"""Issue 30: every option of the CLI and every key of the experiment file changes
what it says, checked against an expectation stated independently of the code
(closed-form scaling laws, the paper's tables, the values given).

:data:`INVENTORY` names, for every option of every subcommand of
:func:`ema_pipeline.cli.parser.build_parser` and every key of the experiment
file's schema (:mod:`ema_pipeline.io.experiment`), the test that shows its
effect; :func:`test_inventory_is_complete` fails when an option or key has none
(a new option needs a test). The inputs are small: a noise-free two-mode FRF,
the simulated paper test, a two-configuration simulated study.
"""

from __future__ import annotations

import argparse
import contextlib
import html
import json
import logging
import re
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io, paper
from ema_pipeline.acquisition import modal_frf
from ema_pipeline.cli import main
from ema_pipeline.cli.parser import build_parser
from ema_pipeline.data import DOF, FRFSet, ModalParameters
from ema_pipeline.identification import IdentificationOptions
from ema_pipeline.io import experiment as schema
from ema_pipeline.io.hdf5 import read_results_h5

TESTS = Path(__file__).resolve().parent
HERE = "test_option_effects.py"

# ------------------------------------------------------------------ inventory
# the tests of this file that several entries name
RUN_SIMULATED = f"{HERE}::test_run_options_and_experiment_keys"
RUN_FILES = f"{HERE}::test_run_file_configurations_geometry_and_verbose"
FRF_READER = f"{HERE}::test_frf_reader_options_and_quiet"
FRF_KEYS = f"{HERE}::test_recorded_configuration_frf_keys"
SIMULATED_NOISE = f"{HERE}::test_simulated_configuration_snr_and_seed"
INIT = f"{HERE}::test_init_writes_the_template_and_force_overwrites"
# batch --report's page per file, on each file's own geometry or --geometry's
BATCH_PAGES = "test_batch.py::test_batch_report_writes_the_identify_page_of_every_file"
#: "COMMAND --option" (or "COMMAND positional") and "[table] key" -> the tests
#: ("file.py::test_name") that show the option or key changes the result.
SHEET_RUN = ("test_channel_sheet.py::"
             "test_init_recordings_then_run_has_shapes_over_the_hammer_points")
SHEET_KEYS = ("test_channel_sheet.py::"
              "test_experiment_file_takes_the_sheet_inline_or_per_configuration")
# ema-pipeline live: the replay and simulate browser tests, the options of the virtual hammer
LIVE_REPLAY = ("test_live_browser.py::"
               "test_live_replay_of_the_plate_resumes_after_kill_and_matches_frf")
LIVE_SIMULATE = ("test_live_browser.py::"
                 "test_live_simulated_plate_struck_with_the_virtual_hammer")
LIVE_HAMMER = "test_live.py::test_simulate_options_clip_scatter_noise_seed_double_hit"
INVENTORY: dict[str, tuple[str, ...]] = {
    # live
    **{f"live {o}": (LIVE_REPLAY,) for o in ("--channels", "--geometry", "--session",
                                             "--replay", "--speed", "--band", "--port",
                                             "--no-browser")},
    "live --simulate": (LIVE_SIMULATE, LIVE_HAMMER,
                        "test_live.py::test_simulate_a_universal_file_of_modes"),
    **{f"live {o}": (LIVE_HAMMER,) for o in ("--seed", "--double-hit", "--force-scatter",
                                             "--clip-n", "--noise")},
    "live --host": ("test_live.py::test_live_host_option_listens_there_only",),
    **{f"live {o}": ("test_live.py::test_sounddevice_backend_at_its_interface",)
       for o in ("--device", "--sample-rate")},
    # simulate
    "simulate --configuration": (f"{HERE}::test_simulate_configuration_and_zeta_pct",),
    "simulate --added-mass": ("test_closed_loop.py::test_simulate_added_mass_command",
                              "test_closed_loop.py::test_run_checks_itself_against_the_truth"),
    "simulate --experiment": (f"{HERE}::test_simulate_experiment_beam_and_sensors",),
    "simulate --format": ("test_report.py::test_simulate_format_follows_the_suffix",),
    "simulate --binary": (f"{HERE}::test_simulate_binary_and_coherence",),
    "simulate --out": ("test_cli_simulate.py::test_simulate_custom_modes_and_time_records",),
    "simulate --seed": (f"{HERE}::test_simulate_seed_snr_and_quiet",),
    "simulate --snr-db": (f"{HERE}::test_simulate_seed_snr_and_quiet",),
    "simulate --fd-hz": ("test_cli_simulate.py::test_simulate_custom_modes_and_time_records",),
    "simulate --zeta-pct": (f"{HERE}::test_simulate_configuration_and_zeta_pct",),
    "simulate --coherence": (f"{HERE}::test_simulate_binary_and_coherence",),
    "simulate --time-records": (
        "test_cli_simulate.py::test_simulate_custom_modes_and_time_records",),
    "simulate --quiet": (f"{HERE}::test_simulate_seed_snr_and_quiet",),
    # identify
    "identify files": ("test_report.py::test_identify_report_per_file",),
    "identify --out": (f"{HERE}::test_identify_options_change_the_result",),
    "identify --report": ("test_report.py::test_identify_report_per_file",),
    "identify --no-figures": (
        "test_shape_views.py::test_identify_report_animates_the_modes_on_a_given_geometry",),
    "identify --geometry": (
        "test_shape_views.py::test_identify_report_animates_the_modes_on_a_given_geometry",),
    "identify --picks": ("test_picks.py::test_untouched_page_picks_reproduce_the_automatic_result",
                        "test_picks.py::test_a_picked_diagram_pole_gives_the_mode_and_a_dropped_one_is_gone"),
    "identify --band": (f"{HERE}::test_identify_options_change_the_result",),
    "identify --max-order": (f"{HERE}::test_identify_options_change_the_result",),
    "identify --method": (f"{HERE}::test_identify_options_change_the_result",),
    "identify --expect": ("test_cli_identify.py::test_expect_not_found_is_an_empty_row",),
    "identify --exp-window-tau": (
        "test_cli_identify.py::test_exp_window_tau_gives_structural_damping",),
    "identify --quiet": (f"{HERE}::test_identify_options_change_the_result",),
    "identify --no-window-search": (f"{HERE}::test_no_window_search_skips_the_window_searches",),
    "identify --no-accept": (f"{HERE}::test_no_accept_keeps_the_untested_candidates",),
    "identify --memory-limit-gb": (f"{HERE}::test_memory_limit_refuses_before_any_work",),
    "identify --uff": ("test_uff_export_cli.py::test_identify_uff_round_trips_through_pyuff",),
    "identify --verbose": (f"{HERE}::test_verbose_reaches_the_batch_workers",),
    # batch
    "batch folder": ("test_batch.py::test_cli_batch_good_and_bad_files",),
    "batch --out": ("test_batch.py::test_cli_batch_good_and_bad_files",),
    "batch --workers": ("test_batch.py::test_workers_1_and_2_identical_and_rerun_skips",),
    "identify --workers": ("test_runner.py::test_ctrl_c_of_identify_with_workers_stops_within_2_s",
                           "test_runner.py::test_identify_several_files_in_workers_equals_serial"),
    "run --workers": ("test_runner.py::test_run_gives_each_identification_its_workers",),
    "batch --scheduler": ("test_batch.py::test_scheduler_matches_local_processes",),
    "batch --force": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --report": (
        "test_report.py::test_batch_report_lists_failures_with_reason_and_the_trend",
        BATCH_PAGES),
    "batch --no-figures": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --band": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --max-order": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --method": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --expect": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --exp-window-tau": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --quiet": (f"{HERE}::test_batch_options_change_the_result",),
    "batch --no-window-search": (f"{HERE}::test_no_window_search_skips_the_window_searches",),
    "batch --no-accept": (f"{HERE}::test_no_accept_keeps_the_untested_candidates",),
    "batch --memory-limit-gb": (f"{HERE}::test_memory_limit_refuses_before_any_work",),
    "batch --uff": ("test_uff_export_cli.py::test_batch_uff_writes_one_file_per_input",),
    "batch --verbose": (f"{HERE}::test_verbose_reaches_the_batch_workers",),
    "batch --geometry": (f"{HERE}::test_batch_geometry", BATCH_PAGES),
    # run
    "run --raw": ("test_study.py::test_table1_reproduces_the_paper",),
    "run --results": ("test_study.py::test_rerun_is_reproducible_and_replaces_the_folder",),
    "run --experiment": (RUN_SIMULATED,),
    "run --quiet": (RUN_SIMULATED,),
    "run --json": (RUN_SIMULATED,),
    "run --no-figures": ("test_report.py::test_no_figures",),
    "run --geometry": (RUN_FILES,),
    "run --memory-limit-gb": (f"{HERE}::test_memory_limit_refuses_before_any_work",),
    "run --uff": ("test_uff_export_cli.py::test_run_uff_carries_the_beam_geometry",),
    "run --verbose": (RUN_FILES,),
    # fe
    "fe table1": ("test_cli_fe.py::test_fe_command_writes_tables_2_to_6_matching_the_paper",),
    "fe --out": ("test_cli_fe.py::test_fe_command_writes_tables_2_to_6_matching_the_paper",),
    "fe --experiment": (f"{HERE}::test_fe_experiment_keys",),
    "fe --quiet": (f"{HERE}::test_fe_experiment_keys",),
    # frf
    "frf inputs": ("test_hits.py::test_uff_and_tdms_copies_give_the_same_frf_and_identify_"
                   "recovers_the_damping",),
    "frf --out": ("test_hits.py::test_each_option_changes_the_result",),
    "frf --pretrigger-s": ("test_hits.py::test_each_option_changes_the_result",),
    "frf --record-length-s": ("test_hits.py::test_each_option_changes_the_result",),
    "frf --force-window-s": ("test_hits.py::test_each_option_changes_the_result",),
    "frf --exp-window-tau": ("test_hits.py::test_each_option_changes_the_result",),
    "frf --estimator": ("test_hits.py::test_each_option_changes_the_result",),
    "frf --keep-all": ("test_hits.py::test_each_option_changes_the_result",),
    "frf --force-channel": (FRF_READER,),
    "frf --scale": (FRF_READER,),
    "frf --unit": (FRF_READER,),
    "frf --report": ("test_frf_report.py::test_no_page_without_report",),
    "frf --quiet": (FRF_READER,),
    # init
    "init folder": (INIT,
                    "test_init_run.py::test_run_on_a_plate_identifies_both_configurations"),
    "init --force": (INIT, "test_init_run.py::test_init_refuses_to_overwrite"),
    "init --example": ("test_example_study.py::test_init_example_then_run_outside_the_checkout",),
    "init --recordings": (SHEET_RUN,),
    "frf --hits": ("test_channel_sheet.py::test_hits_chosen_by_hand",),
    "frf --channels": ("test_channel_sheet.py::test_roving_hammer_plate_frf_and_modes",
                       "test_channel_sheet.py::test_roving_sensor_layout_and_mismatches"),
    # a configuration given by a channel sheet ([recordings] or [[configurations]] channels)
    "[[configurations]] sheet: name": (SHEET_RUN, SHEET_KEYS),
    "[[configurations]] sheet: channels": (SHEET_RUN, SHEET_KEYS),
    "[[configurations]] sheet: description": (SHEET_KEYS,),
    "[[configurations]] sheet: frf": (SHEET_KEYS,),
    # the experiment file
    "[experiment] name": (RUN_SIMULATED,),
    **{f"[test] {k}": (RUN_SIMULATED,)
       for k in ("date", "description", "equipment", "object", "operator")},
    "[dofs] fixed": (RUN_FILES,
                     "test_init_run.py::test_dofs_map_puts_the_file_points_on_the_geometry"),
    "[dofs] map": (RUN_FILES,
                   "test_init_run.py::test_dofs_map_puts_the_file_points_on_the_geometry"),
    "[dofs] roving": (RUN_FILES,
                      "test_init_run.py::test_plate_report_has_animated_shapes_and_cross_mac"),
    "[experiment] genuine": (f"{HERE}::test_fe_experiment_keys",),
    **{f"[beam] {k}": (f"{HERE}::test_fe_experiment_keys",) for k in (
        "length_m", "width_m", "thickness_m", "youngs_modulus_pa", "density_kg_m3")},
    "[beam] n_elements": (f"{HERE}::test_fe_mesh_and_seed_keys",),
    "[beam] n_measurement_elements": (f"{HERE}::test_simulate_experiment_beam_and_sensors",),
    **{f"[sensors] {k}": (f"{HERE}::test_simulate_experiment_beam_and_sensors",) for k in (
        "response_nodes", "hammer_node", "direction")},
    # [identification]: each key becomes the IdentificationOptions field of its name
    # (test_identification_keys_reach_the_options); the field's effect is shown by
    "[identification] band_hz": ("test_identification.py::test_band_of_few_lines_finds_its_modes",),
    "[identification] max_order": ("test_identification.py::test_too_few_lines_for_order",),
    "[identification] method": ("test_identification.py::test_sdypy_backend_agrees",),
    "[identification] expect_hz": (
        "test_identification.py::test_expect_picks_nearest_clusters",),
    "[identification] weighting": (
        "test_identification.py::test_coherence_weighting_helps_against_a_bad_channel",),
    **{f"[identification] {k}": (
        "test_identification_options.py::test_stabilization_tolerances_reach_the_selection",)
       for k in ("tol_freq", "tol_zeta", "tol_mac")},
    "[identification] min_fraction": (
        "test_identification_options.py::test_min_fraction_drops_short_trajectories",),
    "[identification] refine": (
        "test_identification_options.py::test_refine_moves_the_poles_to_the_truth",
        "test_identification_options.py::test_refine_reports_the_refined_or_the_start_poles"),
    "[identification] accept": (
        "test_identification_options.py::test_accept_runs_the_final_tests",
        f"{HERE}::test_no_accept_keeps_the_untested_candidates"),
    **{f"[identification] {k}": (
        "test_identification_options.py::test_residual_terms_stand_for_the_modes_outside_the_"
        "band",) for k in ("lower_residual", "upper_residual")},
    "[identification] window_searches": (
        f"{HERE}::test_no_window_search_skips_the_window_searches",),
    "[fe] immersed_elements": (f"{HERE}::test_fe_experiment_keys",),
    "[fe] n_modes": (f"{HERE}::test_fe_n_modes", RUN_SIMULATED),
    "[fe] update_repeats": (f"{HERE}::test_fe_experiment_keys",),
    "[fe] seed": (f"{HERE}::test_fe_mesh_and_seed_keys",),
    # [[configurations]] read from an FRF file
    "[[configurations]] file: name": (RUN_FILES,),
    "[[configurations]] file: file": ("test_study.py::test_table1_reproduces_the_paper",),
    "[[configurations]] file: description": (RUN_FILES,),
    "[[configurations]] file: exp_window_tau_s": (RUN_FILES,),
    # simulated on the FE beam
    "[[configurations]] simulated: name": (RUN_SIMULATED,),
    "[[configurations]] simulated: added_mass": (
        "test_closed_loop.py::test_run_checks_itself_against_the_truth",),
    "[[configurations]] simulated: description": (RUN_SIMULATED,),
    "[[configurations]] simulated: zeta_pct": (RUN_SIMULATED,),
    "[[configurations]] simulated: snr_db": (SIMULATED_NOISE,),
    "[[configurations]] simulated: seed": (SIMULATED_NOISE,),
    # raw impact recordings
    "[[configurations]] recording: name": (
        "test_frf_pipeline.py::test_experiment_with_a_recorded_configuration_runs",),
    "[[configurations]] recording: recording": (
        "test_frf_pipeline.py::test_experiment_with_a_recorded_configuration_runs",),
    "[[configurations]] recording: description": (RUN_SIMULATED,),
    "[[configurations]] recording: frf": (FRF_KEYS,),
    **{f"[[configurations]] frf: {k}": (FRF_KEYS,) for k in schema.FRF_SETTINGS},
    **{f"[geometry] {k}": (RUN_FILES,) for k in ("file", "nodes", "lines", "surfaces")},
}


def _cli_options() -> set[str]:
    """Every "COMMAND --option" / "COMMAND positional" of the parser (help excluded)."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    found = set()
    for name, command in sub.choices.items():
        for action in command._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            long = [s for s in action.option_strings if s.startswith("--")]
            found.add(f"{name} {long[0] if long else action.dest}")
    return found


def _experiment_keys() -> set[str]:
    """Every key of the experiment file's schema."""
    keys = {f"[{table}] {key}" for table, checks in schema.SCHEMA.items() for key in checks}
    for kind, checks in (("file", schema.FILE_CONFIGURATION),
                         ("simulated", schema.SIMULATED_CONFIGURATION),
                         ("recording", schema.RECORDING_CONFIGURATION),
                         ("sheet", schema.SHEET_CONFIGURATION),
                         ("frf", schema.FRF_SETTINGS)):
        keys |= {f"[[configurations]] {kind}: {key}" for key in checks}
    try:  # the [geometry] table's keys, as io.geometry.geometry_from_table states them
        io.geometry_from_table({"no_such_key": 1}, "x")
    except io.DataError as exc:
        keys |= {f"[geometry] {k}" for k in re.findall(r"'(\w+)'", str(exc).split("expected")[1])}
    return keys


def test_inventory_is_complete() -> None:
    """Every CLI option and experiment-file key has a test that shows its effect
    (a new option without an entry in INVENTORY fails here), and every named
    test exists."""
    wanted = _cli_options() | _experiment_keys()
    assert any(k.startswith("[geometry]") for k in wanted)
    missing = sorted(wanted - set(INVENTORY))
    assert not missing, f"options/keys without a test in INVENTORY: {missing}"
    stale = sorted(set(INVENTORY) - wanted)
    assert not stale, f"INVENTORY names options/keys that no longer exist: {stale}"
    untested = sorted(k for k, tests in INVENTORY.items() if not tests)
    assert not untested, f"options/keys listed without a test: {untested}"
    for option, tests in INVENTORY.items():
        for test in tests:
            file, name = test.split("::")
            path = TESTS / file
            assert path.is_file() and re.search(rf"^def {name}\(", path.read_text(), re.M), (
                f"{option}: no test {test}")


# ------------------------------------------------------------------ helpers
def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``ema-pipeline ARGV`` in this process: (exit status, stdout, stderr)."""
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _peak_hz(frf: FRFSet, lo: float, hi: float, row: int = 0) -> float:
    """The line of largest |H| of response ``row`` between lo and hi Hz."""
    band = (frf.freq_hz > lo) & (frf.freq_hz < hi)
    return float(frf.freq_hz[band][np.argmax(np.abs(frf.H[row, 0, band]))])


def _cantilever_shape(x_rel: np.ndarray) -> np.ndarray:
    """First bending mode of a clamped-free Euler-Bernoulli beam at x/L (closed form)."""
    bl, sigma = 1.8751040687, 0.7340955137
    z = bl * np.asarray(x_rel)
    return np.cosh(z) - np.cos(z) - sigma * (np.sinh(z) - np.sin(z))


#: the two-mode test FRF: receptance of 30 Hz / 1 % and 70 Hz / 2 %, noise-free
TWO_MODES = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])


@pytest.fixture(scope="module")
def two_mode_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with one noise-free two-mode FRF file, ``two.uff`` (2 x 1, 801 lines)."""
    f = np.linspace(0.0, 100.0, 801)
    phi = np.array([[1.0, 0.6], [0.5, -1.0]])
    H = modal_frf(f, TWO_MODES, phi, phi[:1], quantity="receptance")
    frf = FRFSet(freq_hz=f, H=H, quantity="receptance", response_dofs=(DOF(1), DOF(2)),
                 reference_dofs=(DOF(1),))
    folder = tmp_path_factory.mktemp("two") / "in"
    folder.mkdir()
    io.write_frf(frf, folder / "two.uff", "uff")
    return folder


def _orders(result_h5: Path) -> np.ndarray:
    return np.asarray(read_results_h5(result_h5)["identification"]["settings"]["orders"])


# ------------------------------------------------------------------ simulate
def test_simulate_seed_snr_and_quiet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Same --seed: identical FRFs; another seed: other noise. --snr-db 20 has 10x the
    noise amplitude of 40 dB (20 dB = a factor 10), so about 10x the FRF error
    against the noise-free (--snr-db 0) simulation. --quiet prints nothing."""
    def sim(name: str, *options: str) -> tuple[np.ndarray, str]:
        code, out, _ = _run(["simulate", "--out", tmp_path / f"{name}.h5", *options], capsys)
        assert code == 0
        return io.read_frf(tmp_path / f"{name}.h5").H, out

    truth, _ = sim("free", "--snr-db", "0", "--quiet")
    a, said = sim("a", "--seed", "1")
    again, quiet = sim("again", "--seed", "1", "--quiet")
    b, _ = sim("b", "--seed", "2", "--quiet")
    low, _ = sim("low", "--seed", "1", "--snr-db", "20", "--quiet")
    assert "wrote" in said and "seed 1" in said and quiet == ""
    np.testing.assert_array_equal(a, again)
    # the median over lines of the relative error (robust to the antiresonances)
    err = {name: np.median(np.abs(x / truth - 1)) for name, x in (("a", a), ("b", b),
                                                                ("low", low))}
    assert np.median(np.abs(a / b - 1)) > 0.5 * err["a"]  # other noise, of the same size
    assert 0.7 < err["b"] / err["a"] < 1.4
    assert 7.0 < err["low"] / err["a"] < 13.0, err


def test_simulate_configuration_and_zeta_pct(tmp_path: Path) -> None:
    """--configuration larger_tank puts the first peak at Table 1's 16.93 Hz (genuine
    18.14 Hz). --zeta-pct: doubling the damping of an isolated mode lowers its peak
    |H| by (sigma_2 + 1/tau) / (sigma_1 + 1/tau), sigma = 2 pi fn zeta, the
    exponential window's 1/tau = 5/8.192 s adding to both."""
    out = tmp_path / "lt.h5"
    assert main(["simulate", "--configuration", "larger_tank", "--snr-db", "0", "--out",
                 str(out), "--quiet"]) == 0
    fd = paper.TABLE1_FD_HZ["larger_tank"][0]
    assert _peak_hz(io.read_frf(out), 10, 40) == pytest.approx(fd, abs=0.13)  # one line
    assert abs(fd - paper.TABLE1_FD_HZ["genuine"][0]) > 1.0
    peaks = []
    for zeta in ("1", "2"):
        path = tmp_path / f"z{zeta}.h5"
        assert main(["simulate", "--configuration", "custom", "--fd-hz", "20,120",
                     "--zeta-pct", f"{zeta},0.5", "--snr-db", "0", "--out", str(path),
                     "--quiet"]) == 0
        frf = io.read_frf(path)
        peaks.append(np.abs(frf.H[0, 0, (frf.freq_hz > 15) & (frf.freq_hz < 25)]).max())
    rate = 5 / 8.192
    sigma = 2 * np.pi * 20 * np.array([0.01, 0.02])
    assert peaks[0] / peaks[1] == pytest.approx((sigma[1] + rate) / (sigma[0] + rate), rel=0.08)


def test_simulate_binary_and_coherence(tmp_path: Path) -> None:
    """--binary writes binary UFF (not text) with the same FRFs; --coherence adds the
    coherence records to a UFF file, near 1 at the first resonance (40 dB SNR)."""
    paths = {k: tmp_path / f"{k}.uff" for k in ("plain", "binary", "coherence")}
    for name, options in (("plain", []), ("binary", ["--binary"]),
                          ("coherence", ["--coherence"])):
        assert main(["simulate", "--seed", "3", "--out", str(paths[name]), "--quiet",
                     *options]) == 0
    plain, binary, coh = (io.read_frf(paths[k]) for k in ("plain", "binary", "coherence"))
    assert b"\x00" in paths["binary"].read_bytes()
    assert b"\x00" not in paths["plain"].read_bytes()
    np.testing.assert_allclose(binary.H, plain.H, rtol=0, atol=1e-6 * np.abs(plain.H).max())
    assert plain.coherence is None and coh.coherence is not None
    k = np.argmin(np.abs(coh.freq_hz - paper.TABLE1_FD_HZ["genuine"][0]))
    assert np.all(coh.coherence[:, 0, k] > 0.99) and np.all(coh.coherence <= 1 + 1e-9)


def _write_experiment(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_simulate_experiment_beam_and_sensors(tmp_path: Path) -> None:
    """simulate --experiment: the experiment's beam and sensors. A beam 1.1 times
    longer has its first mode at 1/1.1^2 of the paper beam's 19.84 Hz (Table 3);
    with 5 measurement elements node 3 is at 0.4 L and node 6 at the tip, so the
    ratio of the two responses at the first peak is the cantilever's first mode
    shape phi(0.4)/phi(1.0); the FRF's DOFs are the given nodes and direction."""
    exp = _write_experiment(tmp_path / "exp.toml", """
[beam]
length_m = 0.715
n_elements = 50
n_measurement_elements = 5
[sensors]
response_nodes = [3, 6]
hammer_node = 6
direction = -3
[[configurations]]
name = "genuine"
added_mass = {}
""")
    out = tmp_path / "g.h5"
    assert main(["simulate", "--added-mass", "none", "--experiment", str(exp), "--snr-db", "0",
                 "--out", str(out), "--quiet"]) == 0
    frf = io.read_frf(out)
    assert frf.response_dofs == (DOF(3, -3), DOF(6, -3)) and frf.reference_dofs == (DOF(6, -3),)
    f1 = _peak_hz(frf, 5, 40)
    assert f1 == pytest.approx(paper.TABLE3_FN_HZ[0] / 1.1**2, abs=0.13)  # one line
    k = np.argmin(np.abs(frf.freq_hz - f1))
    ratio = np.abs(frf.H[0, 0, k] / frf.H[1, 0, k])
    expected = _cantilever_shape(0.4) / _cantilever_shape(1.0)  # 0.19
    assert ratio == pytest.approx(expected, rel=0.03)


# ------------------------------------------------------------------ identify, batch
def test_identify_options_change_the_result(two_mode_folder: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """On the noise-free 30/70 Hz FRF: --band 50 100 keeps only the 70 Hz mode;
    --max-order 16 is the diagram's highest order; --method sdypy-lscf is the
    stored method and still finds both modes; --quiet prints nothing; --out is
    where the tables go."""
    src = two_mode_folder / "two.uff"
    code, said, _ = _run(["identify", src, "--out", tmp_path / "base"], capsys)
    assert code == 0 and "2 modes" in said
    base = pd.read_csv(tmp_path / "base" / "two_modes.csv")
    np.testing.assert_allclose(base["fn_hz"], TWO_MODES.fn_hz, rtol=1e-5)
    assert _orders(tmp_path / "base" / "two_result.h5").max() != 16
    code, said, _ = _run(["identify", src, "--out", tmp_path / "band", "--band", "50", "100",
                          "--quiet"], capsys)
    assert code == 0 and said == ""
    np.testing.assert_allclose(pd.read_csv(tmp_path / "band" / "two_modes.csv")["fn_hz"],
                               [70.0], rtol=1e-5)
    assert _run(["identify", src, "--out", tmp_path / "order", "--max-order", "16", "--quiet"],
                capsys)[0] == 0
    assert _orders(tmp_path / "order" / "two_result.h5").max() == 16
    assert _run(["identify", src, "--out", tmp_path / "sdypy", "--method", "sdypy-lscf",
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
    code, said, _ = _run(["batch", two_mode_folder, "--out", out, *options, "--quiet",
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
    code, said, _ = _run(["batch", two_mode_folder, "--out", out, *options, "--report"], capsys)
    assert code == 0 and "1 skipped" in said
    code, said, _ = _run(["batch", two_mode_folder, "--out", out, *options, "--force",
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
    assert _run(["identify", src, "--out", tmp_path / "off", "--quiet", "--no-window-search"],
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
    assert _run(["batch", folder, "--out", tmp_path / "batch", "--workers", "1", "--quiet",
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
    from hardcases import make_case

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
        assert _run(["identify", src, "--out", tmp_path / name, "--quiet", *band, *extra],
                    capsys)[0] == 0
        table[name] = pd.read_csv(tmp_path / name / "impact_modes.csv")
        stored[name] = read_results_h5(tmp_path / name / "impact_result.h5")["identification"]
    np.testing.assert_allclose(table["default"]["fn_hz"], case.fn_hz, rtol=1e-3)
    untested = table["untested"]["fn_hz"].to_numpy()
    assert untested.size == 9 and np.all(untested[6:] > 780.0)
    np.testing.assert_allclose(untested[:6], table["default"]["fn_hz"], rtol=1e-6)
    assert bool(stored["default"]["settings"]["accept"]) is True
    assert bool(stored["untested"]["settings"]["accept"]) is False
    assert _run(["batch", folder, "--out", tmp_path / "batch", "--workers", "1", "--quiet",
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
    assert _run(["identify", src, "--out", tmp_path / "ok", "--max-order", "40", "--quiet"],
                capsys)[0] == 0
    code, _, err = _run(["identify", src, "--out", tmp_path / "id", "--max-order", "40",
                         "--memory-limit-gb", "1e-6"], capsys)
    assert code == 2 and "more than the limit" in err and "--memory-limit-gb" in err
    assert not (tmp_path / "id" / "two_modes.csv").exists()
    code, _, err = _run(["identify", src, "--out", tmp_path / "ad", "--memory-limit-gb", "1e-6"],
                        capsys)
    assert code == 2 and "more than the limit" in err
    assert not (tmp_path / "ad" / "two_modes.csv").exists()
    code, _, err = _run(["batch", two_mode_folder, "--out", tmp_path / "b", "--max-order", "40",
                         "--memory-limit-gb", "1e-6", "--workers", "1", "--quiet"], capsys)
    assert code == 1 and "more than the limit" in (tmp_path / "b" / "failures.csv").read_text()


# ------------------------------------------------------------------ fe and the experiment file
@pytest.fixture(scope="module")
def table1_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The paper's Table 1 in the form ``fe`` reads."""
    rows = [{"configuration": cfg, "mode": k + 1, "fd_hz": fd, "zeta_pct": 100 * z}
            for cfg in paper.CONFIGURATIONS
            for k, (fd, z) in enumerate(zip(paper.TABLE1_FD_HZ[cfg], paper.TABLE1_ZETA[cfg],
                                            strict=True))]
    path = tmp_path_factory.mktemp("t1") / "table1.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


#: three configurations the fe experiment files list (simulated: no files needed)
FE_CONFIGURATIONS = "".join(f'[[configurations]]\nname = "{c}"\nadded_mass = {{}}\n'
                            for c in paper.CONFIGURATIONS)


def _fe(table1: Path, out: Path, experiment: str | None, capsys) -> dict[str, pd.DataFrame]:
    argv = ["fe", table1, "--out", out, "--quiet"]
    if experiment is not None:
        argv += ["--experiment", _write_experiment(out.parent / f"{out.name}.toml",
                                                   experiment + FE_CONFIGURATIONS)]
    code, said, _ = _run(argv, capsys)
    assert code == 0 and said == ""
    return {p.stem.split("_")[0]: pd.read_csv(p) for p in out.glob("*.csv")}


def test_fe_experiment_keys(table1_csv: Path, tmp_path: Path,
                            capsys: pytest.CaptureFixture[str]) -> None:
    """fe --experiment: the beam's parameters are Table 4's initial values, and its
    frequencies scale as h sqrt(E/rho) / L^2 from the paper's Table 3 (the width
    cancels); immersed_elements is Table 6's element;
    genuine is the reference of Table 2 (ratio (f_ref / f)^2 - 1 from Table 1);
    update_repeats 1 leaves the runs' spread undefined. --quiet prints nothing."""
    base = _fe(table1_csv, tmp_path / "base", None, capsys)
    beam = dict(length_m=0.715, width_m=0.06, thickness_m=0.012, youngs_modulus_pa=2.73e11,
                density_kg_m3=7020.0)
    t = _fe(table1_csv, tmp_path / "var", "[experiment]\ngenuine = \"larger_tank\"\n[beam]\n"
            + "".join(f"{k} = {v!r}\n" for k, v in beam.items())
            + "[fe]\nupdate_repeats = 1\nimmersed_elements = [9]\n", capsys)
    scale = (0.012 / 0.01) / (0.715 / 0.65) ** 2 * np.sqrt((2.73e11 / 2.1e11) / (7020 / 7800))
    np.testing.assert_allclose(t["table3"]["fn_hz"], paper.TABLE3_FN_HZ * scale, rtol=5e-4)
    initial = t["table4"].set_index("parameter")["initial"]
    for key, name in (("length_m", "length"), ("width_m", "width"), ("thickness_m", "thickness"),
                      ("youngs_modulus_pa", "youngs_modulus"), ("density_kg_m3", "density")):
        assert initial[name] == pytest.approx(beam[key], rel=1e-9), name
    assert set(t["table6"]["element"]) == {9} and set(base["table6"]["element"]) == {10}
    assert t["table4"]["run_std"].isna().all() and base["table4"]["run_std"].notna().all()
    t2 = t["table2"].query("mode == 1").set_index("configuration")["added_mass_ratio"]
    fd = {c: paper.TABLE1_FD_HZ[c][0] for c in paper.CONFIGURATIONS}
    assert set(t2.index) == {"genuine", "smaller_tank"}
    assert t2["genuine"] == pytest.approx((fd["larger_tank"] / fd["genuine"]) ** 2 - 1, rel=0.02)


def test_fe_mesh_and_seed_keys(table1_csv: Path, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    """n_elements = 10 (a coarse mesh) raises the fourth frequency above the
    Euler-Bernoulli value (consistent-mass FE is an upper bound; about +0.1 %),
    where the default 100 elements are within 1e-5; [fe] seed changes the
    differential evolution's point in the non-identifiable valley (Table 4), the
    same seed repeats it."""
    bl = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])
    exact = bl**2 / (2 * np.pi * 0.65**2) * np.sqrt(2.1e11 * 0.01**2 / 12 / 7800.0)
    runs = {name: _fe(table1_csv, tmp_path / name, text, capsys) for name, text in (
        ("fine", "[fe]\nupdate_repeats = 1\nseed = 1\n"),
        ("same", "[fe]\nupdate_repeats = 1\nseed = 1\n"),
        ("other", "[fe]\nupdate_repeats = 1\nseed = 2\n"),
        ("coarse", "[beam]\nn_elements = 10\n[fe]\nupdate_repeats = 1\n"))}
    fine = runs["fine"]["table3"]["fn_hz"].to_numpy()
    coarse = runs["coarse"]["table3"]["fn_hz"].to_numpy()
    np.testing.assert_allclose(fine, exact, rtol=1e-5)
    assert 3e-4 < coarse[3] / exact[3] - 1 < 3e-3 and np.all(coarse >= exact * (1 - 1e-9))
    updated = {k: runs[k]["table4"]["updated"].to_numpy() for k in ("fine", "same", "other")}
    np.testing.assert_array_equal(updated["fine"], updated["same"])
    assert np.max(np.abs(updated["other"] / updated["fine"] - 1)) > 1e-4


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


# ------------------------------------------------------------------ run (a simulated study)
#: A study simulated on the paper's FE beam, band 5-200 Hz (its first two modes,
#: Table 3's 19.84 and 124.33 Hz), two simulated configurations and one given as
#: the raw hammer records of the paper's genuine beam (Table 1: 18.14, 112.07 Hz).
STUDY_A = """
[experiment]
name = "Option effects: two masses"
[test]
object = "steel cantilever"
date = 2024-05-06
operator = "A. Tester"
equipment = ["PCB 086C03 hammer", "PCB 352C23 accelerometer"]
description = "a three-configuration check"
[identification]
band_hz = [5.0, 200.0]
[fe]
n_modes = 2
update_repeats = 1
[[configurations]]
name = "as_built"
added_mass = {}
description = "the beam as built"
zeta_pct = [1.0, 0.8]
snr_db = 0
[[configurations]]
name = "tip_mass"
added_mass = {10 = 0.3}
description = "thirty per cent at the tip"
[[configurations]]
name = "recorded"
recording = "hits.uff"
description = "hammer records of the paper's beam"
"""
#: RAW/experiment.toml beside it: no name (the file's stem), one noise-free
#: configuration, the FE stage on the first mode only.
STUDY_B = """
[identification]
band_hz = [5.0, 200.0]
[fe]
n_modes = 1
update_repeats = 1
[[configurations]]
name = "as_built"
added_mass = {}
snr_db = 0
"""


@pytest.fixture(scope="module")
def study_raw(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """RAW with experiment.toml (:data:`STUDY_B`), a.toml (:data:`STUDY_A`) and the
    paper genuine beam's hammer records ``hits.uff`` (UFF-58 time records)."""
    from ema_pipeline import acquisition
    from ema_pipeline.pipeline.simulate import paper_modes

    raw = tmp_path_factory.mktemp("study")
    setup = acquisition.TestSetup()
    records = acquisition.simulate_time_records(paper_modes("genuine", setup), setup,
                                                snr_db=50, seed=3, configuration="genuine")
    io.write_time_uff(records, raw / "hits.uff", binary=True)
    _write_experiment(raw / "a.toml", STUDY_A)
    _write_experiment(raw / "experiment.toml", STUDY_B)
    return raw


def _cells(page: str) -> dict[str, str]:
    """The report's two-cell rows ``<tr><th>key</th><td>value</td></tr>`` as a dict."""
    return {html.unescape(m.group(1)): html.unescape(m.group(2)) for m in re.finditer(
        r"<tr><th>([^<]*)</th><td>([^<]*)</td></tr>", page)}


def test_run_options_and_experiment_keys(study_raw: Path, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    """run --experiment a.toml replaces RAW/experiment.toml; --json prints the
    summary as JSON only; --quiet prints nothing; the default prints the progress
    (stderr) and the summary (stdout).

    The keys, against the values given and the paper: [experiment] name is the
    report's title and the summary's name (default: the file's stem); the
    configurations' names are Table 1's; zeta_pct is the identified damping
    (noise-free, 1e-3), the paper's genuine damping where not given; [fe] n_modes
    is the number of modes of Tables 3 and 5 (Table 3 = the paper's, 1e-3);
    descriptions and [test] appear in the report as given; the recorded
    configuration's frequencies are the paper's Table 1 (1e-3)."""
    code, said, err = _run(["run", "--raw", study_raw, "--experiment", study_raw / "a.toml",
                            "--results", tmp_path / "a", "--no-figures", "--json"], capsys)
    assert code == 0, err
    payload = json.loads(said)  # nothing but the JSON on stdout
    assert payload["experiment"] == "Option effects: two masses"
    assert payload["results"] == str(tmp_path / "a")
    modes = payload["modes"]
    assert list(modes) == ["as_built", "tip_mass", "recorded"]
    np.testing.assert_allclose(modes["as_built"]["fn_hz"], paper.TABLE3_FN_HZ[:2], rtol=1e-3)
    np.testing.assert_allclose(modes["as_built"]["zeta_pct"], [1.0, 0.8], rtol=1e-3)
    np.testing.assert_allclose(modes["tip_mass"]["zeta_pct"],
                               100 * paper.TABLE1_ZETA["genuine"][:2], rtol=0.01)
    np.testing.assert_allclose(modes["recorded"]["fd_hz"], paper.TABLE1_FD_HZ["genuine"][:2],
                               rtol=1e-3)
    tables = tmp_path / "a" / "tables"
    np.testing.assert_allclose(pd.read_csv(tables / "table3_fe_initial.csv")["fn_hz"],
                               paper.TABLE3_FN_HZ[:2], rtol=1e-3)
    assert len(pd.read_csv(tables / "table5_fe_updated.csv")) == 2
    page = (tmp_path / "a" / "report.html").read_text()
    assert "<title>Option effects: two masses" in page
    cells = _cells(page)
    for key, value in (("object", "steel cantilever"), ("date", "2024-05-06"),
                       ("operator", "A. Tester"),
                       ("equipment", "PCB 086C03 hammer; PCB 352C23 accelerometer"),
                       ("description", "a three-configuration check")):
        assert cells[key] == value, key
    for name, text in (("as_built", "the beam as built"),
                       ("tip_mass", "thirty per cent at the tip"),
                       ("recorded", "hammer records of the paper&#x27;s beam")):
        assert f"<tr><td>{name}</td><td>{text}</td>" in page, name

    # RAW/experiment.toml (no --experiment), --quiet: nothing printed
    code, said, err = _run(["run", "--raw", study_raw, "--results", tmp_path / "b",
                            "--no-figures", "--quiet"], capsys)
    assert (code, said, err) == (0, "", "")
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert summary["experiment"] == "experiment" and list(summary["modes"]) == ["as_built"]
    np.testing.assert_allclose(pd.read_csv(tmp_path / "b" / "tables" / "table3_fe_initial.csv")
                               ["fn_hz"], paper.TABLE3_FN_HZ[:1], rtol=1e-3)
    # neither: progress on stderr, the summary on stdout
    code, said, err = _run(["run", "--raw", study_raw, "--results", tmp_path / "c",
                            "--no-figures"], capsys)
    assert code == 0
    assert said.startswith("ema-pipeline run: experiment") and "[identify 1/1] as_built" in err


# ------------------------------------------------------------------ run (FRF files, a geometry)
#: Any structure (a [geometry], no [beam]: identification only): the noise-free
#: two-mode FRF twice, once said to carry a 10 s exponential window; its DOFs
#: 1+Z and 2+Z (hammer at 1+Z) are put on nodes 1 and 3 of the geometry.
STUDY_FILES = """
[experiment]
name = "Two modes"
[geometry]
nodes = [[1, 0.0, 0.0, 0.0], [2, 0.3, 0.0, 0.0], [3, 0.3, 0.2, 0.0]]
lines = [[1, 2]]
surfaces = [[1, 2, 3]]
[dofs]
roving = "sensor"
fixed = ["1+Z"]
map = {"2+Z" = "3+Z"}
[identification]
band_hz = [5.0, 95.0]
[[configurations]]
name = "windowed"
file = "two.uff"
description = "said to be windowed, tau 10 s"
exp_window_tau_s = 10.0
[[configurations]]
name = "plain"
file = "two.uff"
"""


def _shape_data(page: str) -> dict:
    """The first animated shape view's JSON (nodes, ids, lines, surfaces, modes)."""
    blob = re.search(r'<script type="application/json" class="shape-data">(.*?)</script>', page)
    assert blob, "no shape view"
    return json.loads(blob.group(1))


@contextlib.contextmanager
def _logging_restored() -> Iterator[None]:
    """--verbose adds a handler to the package's logger (for the process): removed
    again on leaving."""
    log = logging.getLogger("ema_pipeline")
    handlers, level = list(log.handlers), log.level
    try:
        yield
    finally:
        log.handlers[:] = handlers
        log.setLevel(level)


def test_run_file_configurations_geometry_and_verbose(
        two_mode_folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Configurations read from a file: name and description as given;
    exp_window_tau_s = 10 s removes 1/tau from the decay rate of the file's
    30 Hz / 1 % and 70 Hz / 2 % modes (zeta = (sigma - 1/tau) / |lambda|), the
    other stays at 1 % / 2 % (1e-4). [geometry] nodes, lines and surfaces are
    the report's animated model; [geometry] file reads the nodes and trace lines
    of a UFF file, lines and surfaces add to them; run --geometry FILE replaces
    [geometry]. [dofs] map puts the file's 2+Z on node 3 (measured nodes 1, 3;
    without it 1, 2), roving and fixed are the report's description of the test.
    --verbose prints the reader's INFO message about the UFF dataset it skips
    (2420), without it nothing."""
    raw = tmp_path / "raw"
    raw.mkdir()
    text = (two_mode_folder / "two.uff").read_text()
    (raw / "two.uff").write_text(text + "    -1\n  2420\n         1\nSI\n    -1\n")
    _write_experiment(raw / "experiment.toml", STUDY_FILES)
    with _logging_restored():
        code, said, err = _run(["run", "--raw", raw, "--results", tmp_path / "a", "--quiet",
                                "--verbose"], capsys)
    assert code == 0 and said == ""
    assert "skipped datasets not needed for FRFs: 2420" in err
    t1 = pd.read_csv(tmp_path / "a" / "tables" / "table1_modal_parameters.csv")
    assert t1["configuration"].tolist() == ["windowed"] * 2 + ["plain"] * 2
    plain = t1[t1["configuration"] == "plain"]
    np.testing.assert_allclose(plain["fn_hz"], TWO_MODES.fn_hz, rtol=1e-4)
    np.testing.assert_allclose(plain["zeta_pct"], 100 * TWO_MODES.zeta, rtol=1e-4)
    wd = 2 * np.pi * TWO_MODES.fn_hz * np.sqrt(1 - TWO_MODES.zeta**2)
    sigma = TWO_MODES.zeta * 2 * np.pi * TWO_MODES.fn_hz - 1 / 10.0
    np.testing.assert_allclose(t1.loc[t1["configuration"] == "windowed", "zeta_pct"],
                               100 * sigma / np.hypot(wd, sigma), rtol=1e-4)  # 0.947, 1.977
    page = (tmp_path / "a" / "report.html").read_text()
    assert "<tr><td>windowed</td><td>said to be windowed, tau 10 s</td>" in page
    cells = _cells(page)
    assert cells["test"] == "roving accelerometer(s), fixed hammer at 1+Z"
    assert cells["DOF map (file -> geometry)"] == "2+Z -> 3+Z"
    data = _shape_data(page)
    assert data["ids"] == [1, 2, 3]
    np.testing.assert_allclose(data["nodes"], [[0, 0, 0], [0.3, 0, 0], [0.3, 0.2, 0]])
    assert data["lines"] == [[0, 1]] and data["surfaces"] == [[0, 1, 2]]
    assert data["modes"][0]["m"] == [0, 2]  # measured: nodes 1 and 3 (the map)

    # a UFF geometry (nodes 1-3 elsewhere, one trace line 1-2-3)
    from ema_pipeline.data import Geometry
    xyz = np.array([[0.0, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.5, 0.25]])
    io.write_geometry_uff(Geometry(node_ids=np.array([1, 2, 3]), xyz_m=xyz, lines=((1, 2, 3),)),
                          raw / "geometry.uff")
    code, said, err = _run(["run", "--raw", raw, "--results", tmp_path / "b", "--quiet",
                            "--geometry", raw / "geometry.uff"], capsys)
    assert (code, said, err) == (0, "", "")  # no --verbose: no INFO message
    data = _shape_data((tmp_path / "b" / "report.html").read_text())
    np.testing.assert_allclose(data["nodes"], xyz)
    assert data["lines"] == [[0, 1, 2]] and data["surfaces"] == []
    _write_experiment(raw / "experiment.toml", STUDY_FILES.replace(
        "nodes = [[1, 0.0, 0.0, 0.0], [2, 0.3, 0.0, 0.0], [3, 0.3, 0.2, 0.0]]",
        'file = "geometry.uff"').replace("lines = [[1, 2]]", "lines = [[3, 1]]").replace(
        'map = {"2+Z" = "3+Z"}\n', "").replace('roving = "sensor"\n', ""))
    assert _run(["run", "--raw", raw, "--results", tmp_path / "c", "--quiet"], capsys)[0] == 0
    page = (tmp_path / "c" / "report.html").read_text()
    data = _shape_data(page)
    np.testing.assert_allclose(data["nodes"], xyz)
    assert data["lines"] == [[0, 1, 2], [2, 0]] and data["surfaces"] == [[0, 1, 2]]
    assert data["modes"][0]["m"] == [0, 1]  # no map: the file's nodes 1 and 2
    cells = _cells(page)  # fixed without roving: said as such
    assert cells["fixed DOFs"] == "1+Z" and "test" not in cells


# ------------------------------------------------------------------ frf: options and keys
@pytest.fixture(scope="module")
def hammer_csv(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """Six hits (the second a double hit) from tests/impact_recordings.py as CSV:
    the hammer force (N), the acceleration (m/s^2) and a "load cell" in N that reads
    twice the hammer's force."""
    from impact_recordings import make_recording

    rec = make_recording(5, n_resp=1, n_hits=6, n_double=1, last_hit_short=False)
    time_s = np.arange(rec.force_n.size) / rec.sample_rate_hz
    path = tmp_path_factory.mktemp("hammer") / "hits.csv"
    np.savetxt(path, np.c_[time_s, rec.force_n, rec.response[0], 2 * rec.force_n],
               delimiter=",", header="time [s],hammer force [N],acc [m/s^2],load cell [N]",
               comments="", fmt="%.17g")  # 17 digits: read back exactly
    return path, rec


def _ratio(a: FRFSet, b: FRFSet) -> np.ndarray:
    """a.H / b.H on the lines where b is not zero."""
    assert a.H.shape == b.H.shape
    keep = np.abs(b.H) > 1e-12 * np.abs(b.H).max()
    return a.H[keep] / b.H[keep]


def test_frf_reader_options_and_quiet(hammer_csv: tuple[Path, object], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    """frf --force-channel "load cell" (twice the force) halves H; --scale acc=2
    doubles it; --unit acc=g (the header says m/s^2) multiplies it by g =
    9.80665 m/s^2 (H1 is linear in the response, inverse in the force; 1e-9).
    Without --quiet the console counts the generator's 6 hits, 5 averaged (one
    double hit); --quiet prints nothing."""
    src, rec = hammer_csv

    def frf(name: str, *options: str) -> tuple[FRFSet, str]:
        code, said, _ = _run(["frf", src, "--out", tmp_path / f"{name}.h5", *options], capsys)
        assert code == 0
        return io.read_frf(tmp_path / f"{name}.h5"), said

    base, said = frf("base")
    assert rec.hit_times_s.size == 6
    assert "6 hits found, 5 averaged" in said and "rejected: double_hit" in said
    load, quiet = frf("load", "--force-channel", "load cell", "--quiet")
    assert quiet == ""
    np.testing.assert_allclose(_ratio(load, base), 0.5, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf("scale", "--scale", "acc=2", "--quiet")[0], base),
                               2.0, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf("unit", "--unit", "acc=g", "--quiet")[0], base),
                               9.80665, rtol=1e-9)


def test_recorded_configuration_frf_keys(hammer_csv: tuple[Path, object], tmp_path: Path) -> None:
    """Each key of a recorded configuration's ``frf`` table changes the FRFs that
    run uses (:func:`ema_pipeline.pipeline.study.recorded_frf`), as its name says:
    record_length_s = 0.5 gives lines 1 / 0.5 s = 2 Hz apart (default the
    generator's 1 s record: 1 Hz); pretrigger_s = 0.03 moves the default force
    window, the pretrigger + 0.05 s, from 0.06 to 0.08 s (one sample); force_window_s
    and exp_window_tau are stored as given; estimator H2 gives H1 / H2 = the
    coherence (single reference, 1e-9); keep_all averages the double hit too (6
    averages, else 5); force_channel, scale and units as the frf options (0.5, 2,
    g). The same table without a key gives the default result."""
    from ema_pipeline.pipeline.study import recorded_frf

    src, rec = hammer_csv

    def frf(table: str) -> FRFSet:
        path = _write_experiment(tmp_path / "exp.toml", f"""
[sensors]
response_nodes = [6]
[[configurations]]
name = "hammer"
recording = "{src}"
frf = {{{table}}}
""")
        exp = io.read_experiment(path)
        return recorded_frf(exp, exp.configurations[0])[0]

    base = frf("")
    acq = base.acquisition
    assert base.df_hz == pytest.approx(1 / rec.record_s) and acq.n_averages == 5
    dt = 1 / rec.sample_rate_hz
    assert acq.force_window_s == pytest.approx(0.01 + 0.05, abs=dt)
    assert frf("record_length_s = 0.5").df_hz == pytest.approx(2.0, rel=1e-12)
    assert frf("pretrigger_s = 0.03").acquisition.force_window_s == pytest.approx(0.08, abs=dt)
    assert frf("force_window_s = 0.1").acquisition.force_window_s == pytest.approx(0.1, abs=dt)
    assert acq.exp_window_tau_s != 0.2
    assert frf("exp_window_tau = 0.2").acquisition.exp_window_tau_s == 0.2
    h2 = frf('estimator = "H2"')
    assert h2.acquisition.estimator == "H2" and acq.estimator == "H1"
    keep = base.coherence[0, 0] > 1e-3
    np.testing.assert_allclose((base.H / h2.H)[0, 0, keep].real, base.coherence[0, 0, keep],
                               rtol=1e-9)
    assert frf("keep_all = true").acquisition.n_averages == 6
    np.testing.assert_allclose(_ratio(frf('force_channel = "load cell"'), base), 0.5, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf("scale = {acc = 2.0}"), base), 2.0, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf('units = {acc = "g"}'), base), 9.80665, rtol=1e-9)


# ------------------------------------------------------------------ simulated configurations
def test_simulated_configuration_snr_and_seed(tmp_path: Path) -> None:
    """A simulated configuration's FRFs (what run identifies,
    :func:`ema_pipeline.pipeline.simulate.simulate_configuration`): the same seed
    gives the same noise, another seed other noise of the same size, the default
    seed is the entry's position (entry 5 without a seed = seed 5); snr_db = 20 has
    10x the noise amplitude of 40 dB, so about 10x the FRF error against the
    noise-free snr_db = 0; a negative snr_db is noise stronger than the signal
    (as ``simulate --snr-db``), not noise-free."""
    from ema_pipeline.pipeline.simulate import simulate_configuration

    entries = (("free", "snr_db = 0"), ("a", "seed = 5"), ("again", "seed = 5"),
               ("other", "seed = 6"), ("fifth", ""), ("low", "seed = 5\nsnr_db = 20"),
               ("loud", "snr_db = -10"))
    exp = io.read_experiment(_write_experiment(tmp_path / "exp.toml", "".join(
        f'[[configurations]]\nname = "{name}"\nadded_mass = {{}}\n{keys}\n'
        for name, keys in entries)))
    snr = {spec.name: spec.snr_db for spec in exp.configurations}
    assert snr["free"] is None and snr["loud"] == -10.0 and snr["a"] == 40.0
    H = {spec.name: simulate_configuration(exp, spec).H for spec in exp.configurations
         if spec.name != "loud"}
    np.testing.assert_array_equal(H["a"], H["again"])
    np.testing.assert_array_equal(H["a"], H["fifth"])
    err = {k: np.median(np.abs(H[k] / H["free"] - 1)) for k in ("a", "other", "low")}
    assert np.median(np.abs(H["a"] / H["other"] - 1)) > 0.5 * err["a"]
    assert 0.7 < err["other"] / err["a"] < 1.4
    assert 7.0 < err["low"] / err["a"] < 13.0, err


# ------------------------------------------------------------------ init
def test_init_writes_the_template_and_force_overwrites(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """init DIR creates DIR (nested) with experiment.toml, a TOML template with the
    [test], [geometry], [dofs] and [[configurations]] tables; an existing file is
    kept (exit 2) unless --force, which replaces it with the template."""
    folder = tmp_path / "new" / "test"
    assert _run(["init", folder], capsys)[0] == 0
    template = (folder / "experiment.toml").read_text()
    assert {"test", "geometry", "dofs", "configurations"} <= set(tomllib.loads(template))
    (folder / "experiment.toml").write_text("# mine\n")
    code, _, err = _run(["init", folder], capsys)
    assert code == 2 and "--force" in err
    assert (folder / "experiment.toml").read_text() == "# mine\n"
    assert _run(["init", folder, "--force"], capsys)[0] == 0
    assert (folder / "experiment.toml").read_text() == template


# ------------------------------------------------------------------ [fe] n_modes
def test_fe_n_modes(table1_csv: Path, tmp_path: Path,
                    capsys: pytest.CaptureFixture[str]) -> None:
    """[fe] n_modes = 2: fe uses the lowest two modes of the four in Table 1:
    Tables 3 and 5 have two rows (Table 3 the paper's first two, 1e-3) and
    Table 2 modes 1 and 2, against four with the default (n_modes = 4); a note
    says so. (run uses it as well: test_run_options_and_experiment_keys.)"""
    two = _fe(table1_csv, tmp_path / "two", "[fe]\nn_modes = 2\nupdate_repeats = 1\n", capsys)
    four = _fe(table1_csv, tmp_path / "four", "[fe]\nupdate_repeats = 1\n", capsys)
    np.testing.assert_allclose(two["table3"]["fn_hz"], paper.TABLE3_FN_HZ[:2], rtol=1e-3)
    np.testing.assert_allclose(four["table3"]["fn_hz"], paper.TABLE3_FN_HZ, rtol=1e-3)
    assert len(two["table5"]) == 2 and len(four["table5"]) == 4
    assert set(two["table2"]["mode"]) == {1, 2} and set(four["table2"]["mode"]) == {1, 2, 3, 4}
    exp = _write_experiment(tmp_path / "n2.toml", "[fe]\nn_modes = 2\nupdate_repeats = 1\n"
                            + FE_CONFIGURATIONS)
    code, said, _ = _run(["fe", table1_csv, "--out", tmp_path / "said", "--experiment", exp],
                         capsys)
    assert code == 0 and "genuine: 4 modes given, the lowest 2 are used ([fe] n_modes)" in said


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
    code, _, err = _run(["batch", folder, "--out", out, "--geometry", geometry,
                         "--workers", "1", "--quiet"], capsys)
    assert code == 2 and "--report" in err and not out.exists()
    assert _run(["batch", folder, "--out", out, "--report", "--geometry", geometry,
                 "--workers", "1", "--quiet"], capsys)[0] == 0
    data = _shape_data((out / "three_report.html").read_text())
    np.testing.assert_allclose(data["nodes"], xyz)
    assert data["lines"] == [[0, 1, 2]] and data["modes"][0]["m"] == [0, 1, 2]
    assert "data-mode-shape" not in (out / "two_report.html").read_text()
    assert _run(["batch", folder, "--out", out, "--report", "--force",
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
    code, _, err = _run(["identify", src, "--out", tmp_path / "fixed", "--quiet",
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
        code, _, err = _run([*base, "--out", tmp_path / "fixed"], capsys)
    assert code == 0
    assert err.strip() == (
        f"ema-pipeline identify: warning: {src}: max_order (--max-order) turned off the "
        "narrower searches that run with the adaptive order only (the windows of a dense "
        "band): the modes found make no dense band, but those of the adaptive order may")
    code, _, err = _run([*base, "--out", tmp_path / "off", "--no-window-search"], capsys)
    assert (code, err) == (0, "")


def test_a_fixed_order_in_the_experiment_file_is_a_note_of_run(
        example_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``[identification] max_order`` in the study: ``run`` says once, in its notes
    (console and report), for which configurations it turned the
    narrower searches off (the warning of ``identify`` went to the log only)."""
    raw = tmp_path / "raw"
    shutil.copytree(example_dir, raw)
    toml = raw / "experiment.toml"
    toml.write_text(toml.read_text().replace("# max_order = 40", "max_order = 40"))
    with pytest.warns(UserWarning, match="turned off the narrower searches"):
        code, out, _ = _run(["run", "--raw", raw, "--results", tmp_path / "results",
                             "--no-figures"], capsys)
    assert code == 0
    note = ("genuine, larger_tank, smaller_tank: max_order (--max-order) turned off the "
            "narrower searches that run with the adaptive order only (the band's lowest 1/8 "
            "and the windows of a dense band)")
    assert [line for line in out.splitlines() if "narrower searches" in line] == [
        f"note: {note}: the modes found make no dense band, but those of the adaptive order may"]
