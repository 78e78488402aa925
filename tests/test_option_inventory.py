"""Every option of the CLI and every key of the experiment file has a test that
shows what it changes, checked against an expectation stated independently of
the code (closed-form scaling laws, the paper's tables, the values given).

:data:`INVENTORY` names, for every option of every subcommand of
:func:`ema_pipeline.cli.parser.build_parser` and every key of the experiment
file's schema (:mod:`ema_pipeline.io.experiment`), the test that shows its
effect; :func:`test_inventory_is_complete` fails when an option or key has none
(a new option needs a test). The option tests live beside the stage they
exercise: test_simulate_options.py, test_identification_options.py,
test_fe_options.py, test_run_options.py, test_frf_options.py, ...
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from ema_pipeline import io
from ema_pipeline.cli.parser import build_parser
from ema_pipeline.io import experiment as schema

TESTS = Path(__file__).resolve().parent
#: the files of the option tests that the entries name most
SIMULATE = "test_simulate_options.py"
IDENT = "test_identification_options.py"
FE = "test_fe_options.py"
RUN = "test_run_options.py"
FRF = "test_frf_options.py"
INIT_RUN = "test_init_run.py"
# the tests of this file that several entries name
RUN_SIMULATED = f"{RUN}::test_run_options_and_experiment_keys"
RUN_FILES = f"{RUN}::test_run_file_configurations_geometry_and_verbose"
FRF_READER = f"{FRF}::test_frf_reader_options_and_quiet"
FRF_KEYS = f"{FRF}::test_recorded_configuration_frf_keys"
SIMULATED_NOISE = f"{SIMULATE}::test_simulated_configuration_snr_and_seed"
INIT = f"{INIT_RUN}::test_init_writes_the_template_and_force_overwrites"
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
    "simulate --configuration": (f"{SIMULATE}::test_simulate_configuration_and_zeta_pct",),
    "simulate --added-mass": ("test_closed_loop.py::test_simulate_added_mass_command",
                              "test_closed_loop.py::test_run_checks_itself_against_the_truth"),
    "simulate --experiment": (f"{SIMULATE}::test_simulate_experiment_beam_and_sensors",),
    "simulate --format": ("test_report.py::test_simulate_format_follows_the_suffix",),
    "simulate --binary": (f"{SIMULATE}::test_simulate_binary_and_coherence",),
    "simulate --out": ("test_cli_simulate.py::test_simulate_custom_modes_and_time_records",),
    "simulate --seed": (f"{SIMULATE}::test_simulate_seed_snr_and_quiet",),
    "simulate --snr-db": (f"{SIMULATE}::test_simulate_seed_snr_and_quiet",),
    "simulate --fd-hz": ("test_cli_simulate.py::test_simulate_custom_modes_and_time_records",),
    "simulate --zeta-pct": (f"{SIMULATE}::test_simulate_configuration_and_zeta_pct",),
    "simulate --coherence": (f"{SIMULATE}::test_simulate_binary_and_coherence",),
    "simulate --time-records": (
        "test_cli_simulate.py::test_simulate_custom_modes_and_time_records",),
    "simulate --quiet": (f"{SIMULATE}::test_simulate_seed_snr_and_quiet",),
    # identify
    "identify files": ("test_report.py::test_identify_report_per_file",),
    "identify --out": (f"{IDENT}::test_identify_options_change_the_result",),
    "identify --report": ("test_report.py::test_identify_report_per_file",),
    "identify --no-figures": (
        "test_shape_views.py::test_identify_report_animates_the_modes_on_a_given_geometry",),
    "identify --geometry": (
        "test_shape_views.py::test_identify_report_animates_the_modes_on_a_given_geometry",),
    "identify --picks": ("test_picks.py::test_untouched_page_picks_reproduce_the_automatic_result",
                        "test_picks.py::test_a_picked_diagram_pole_gives_the_mode_and_a_dropped_one_is_gone"),
    "identify --band": (f"{IDENT}::test_identify_options_change_the_result",),
    "identify --max-order": (f"{IDENT}::test_identify_options_change_the_result",),
    "identify --method": (f"{IDENT}::test_identify_options_change_the_result",),
    "identify --expect": ("test_cli_identify.py::test_expect_not_found_is_an_empty_row",),
    "identify --exp-window-tau": (
        "test_cli_identify.py::test_exp_window_tau_gives_structural_damping",),
    "identify --quiet": (f"{IDENT}::test_identify_options_change_the_result",),
    "identify --no-window-search": (f"{IDENT}::test_no_window_search_skips_the_window_searches",),
    "identify --no-accept": (f"{IDENT}::test_no_accept_keeps_the_untested_candidates",),
    "identify --memory-limit-gb": (f"{IDENT}::test_memory_limit_refuses_before_any_work",),
    "identify --uff": ("test_uff_export_cli.py::test_identify_uff_round_trips_through_pyuff",),
    "identify --verbose": (f"{IDENT}::test_verbose_reaches_the_batch_workers",),
    # batch
    "batch folder": ("test_batch.py::test_cli_batch_good_and_bad_files",),
    "batch --out": ("test_batch.py::test_cli_batch_good_and_bad_files",),
    "batch --workers": ("test_batch.py::test_workers_1_and_2_identical_and_rerun_skips",),
    "identify --workers": ("test_runner.py::test_ctrl_c_of_identify_with_workers_stops_within_2_s",
                           "test_runner.py::test_identify_several_files_in_workers_equals_serial"),
    "run --workers": ("test_runner.py::test_run_gives_each_identification_its_workers",),
    "batch --scheduler": ("test_batch.py::test_scheduler_matches_local_processes",),
    "batch --force": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --report": (
        "test_report.py::test_batch_report_lists_failures_with_reason_and_the_trend",
        BATCH_PAGES),
    "batch --no-figures": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --band": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --max-order": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --method": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --expect": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --exp-window-tau": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --quiet": (f"{IDENT}::test_batch_options_change_the_result",),
    "batch --no-window-search": (f"{IDENT}::test_no_window_search_skips_the_window_searches",),
    "batch --no-accept": (f"{IDENT}::test_no_accept_keeps_the_untested_candidates",),
    "batch --memory-limit-gb": (f"{IDENT}::test_memory_limit_refuses_before_any_work",),
    "batch --uff": ("test_uff_export_cli.py::test_batch_uff_writes_one_file_per_input",),
    "batch --verbose": (f"{IDENT}::test_verbose_reaches_the_batch_workers",),
    "batch --geometry": (f"{IDENT}::test_batch_geometry", BATCH_PAGES),
    # run
    "run --raw": ("test_study.py::test_table1_reproduces_the_paper",),
    "run --results": ("test_study.py::test_rerun_is_reproducible_and_replaces_the_folder",),
    "run --experiment": (RUN_SIMULATED,),
    "run --quiet": (RUN_SIMULATED,),
    "run --json": (RUN_SIMULATED,),
    "run --no-figures": ("test_report.py::test_no_figures",),
    "run --geometry": (RUN_FILES,),
    "run --memory-limit-gb": (f"{IDENT}::test_memory_limit_refuses_before_any_work",),
    "run --uff": ("test_uff_export_cli.py::test_run_uff_carries_the_beam_geometry",),
    "run --verbose": (RUN_FILES,),
    # fe
    "fe table1": ("test_cli_fe.py::test_fe_command_writes_tables_2_to_6_matching_the_paper",),
    "fe --out": ("test_cli_fe.py::test_fe_command_writes_tables_2_to_6_matching_the_paper",),
    "fe --experiment": (f"{FE}::test_fe_experiment_keys",),
    "fe --quiet": (f"{FE}::test_fe_experiment_keys",),
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
                    f"{INIT_RUN}::test_run_on_a_plate_identifies_both_configurations"),
    "init --force": (INIT, f"{INIT_RUN}::test_init_refuses_to_overwrite"),
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
                     f"{INIT_RUN}::test_dofs_map_puts_the_file_points_on_the_geometry"),
    "[dofs] map": (RUN_FILES,
                   f"{INIT_RUN}::test_dofs_map_puts_the_file_points_on_the_geometry"),
    "[dofs] roving": (RUN_FILES,
                      f"{INIT_RUN}::test_plate_report_has_animated_shapes_and_cross_mac"),
    "[experiment] genuine": (f"{FE}::test_fe_experiment_keys",),
    **{f"[beam] {k}": (f"{FE}::test_fe_experiment_keys",) for k in (
        "length_m", "width_m", "thickness_m", "youngs_modulus_pa", "density_kg_m3")},
    "[beam] n_elements": (f"{FE}::test_fe_mesh_and_seed_keys",),
    "[beam] n_measurement_elements": (f"{SIMULATE}::test_simulate_experiment_beam_and_sensors",),
    **{f"[sensors] {k}": (f"{SIMULATE}::test_simulate_experiment_beam_and_sensors",) for k in (
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
        f"{IDENT}::test_stabilization_tolerances_reach_the_selection",)
       for k in ("tol_freq", "tol_zeta", "tol_mac")},
    "[identification] min_fraction": (
        f"{IDENT}::test_min_fraction_drops_short_trajectories",),
    "[identification] refine": (
        f"{IDENT}::test_refine_moves_the_poles_to_the_truth",
        f"{IDENT}::test_refine_reports_the_refined_or_the_start_poles"),
    "[identification] accept": (
        f"{IDENT}::test_accept_runs_the_final_tests",
        f"{IDENT}::test_no_accept_keeps_the_untested_candidates"),
    **{f"[identification] {k}": (
        f"{IDENT}::test_residual_terms_stand_for_the_modes_outside_the_"
        "band",) for k in ("lower_residual", "upper_residual")},
    "[identification] window_searches": (
        f"{IDENT}::test_no_window_search_skips_the_window_searches",),
    "[fe] immersed_elements": (f"{FE}::test_fe_experiment_keys",),
    "[fe] n_modes": (f"{FE}::test_fe_n_modes", RUN_SIMULATED),
    "[fe] update_repeats": (f"{FE}::test_fe_experiment_keys",),
    "[fe] seed": (f"{FE}::test_fe_mesh_and_seed_keys",),
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
