"""`identify` / `batch` options of issue 11: the exponential window's time
constant for files that do not carry it, roving sets in the Python API, the
minimum number of lines, input suffixes in any letter case, ``--expect`` with
a tolerance, the sdypy-EMA backend (one row per mode, orders too low), and
``--geometry`` without ``--report`` (refused by both commands)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.acquisition import modal_frf
from ema_pipeline.cli import main
from ema_pipeline.data import DOF, MIN_FRF_LINES, DataError, FRFSet, ModalParameters, OptionError
from ema_pipeline.identification import identify
from ema_pipeline.identification.selection.expect import match_expected, with_expected_rows
from ema_pipeline.pipeline.batch import run_batch
from ema_pipeline.pipeline.simulate import paper_modes, simulate_paper_test
from ema_pipeline.pipeline.single import identify_file
from tests.paths import REPO

TAU_S = 8.192 / 5  # the simulated test's window: tau = T / 5


@pytest.fixture(scope="module")
def foreign_uff(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The paper's simulated impact test (exponential window, tau = 1.64 s)
    written as UFF without the window record, as another tool would."""
    frf = simulate_paper_test("genuine", seed=5)
    assert frf.acquisition.exp_window_tau_s == pytest.approx(TAU_S)
    bare = replace(frf, acquisition=replace(frf.acquisition, exp_window_tau_s=None))
    path = tmp_path_factory.mktemp("foreign") / "windowed.uff"
    io.write_frf(bare, path, "uff")
    assert io.read_frf(path).acquisition.exp_window_tau_s is None
    return path


def _zeta_pct(out: Path) -> np.ndarray:
    table = pd.read_csv(out / "windowed_modes.csv")
    return table["zeta_pct"].to_numpy()


def test_exp_window_tau_gives_structural_damping(foreign_uff: Path, tmp_path: Path) -> None:
    truth = 100 * paper_modes("genuine").zeta[:4]  # 0.50 0.67 0.29 0.38 %
    assert main(["identify", str(foreign_uff), "--out", str(tmp_path / "tau"), "--quiet",
                 "--exp-window-tau", str(TAU_S)]) == 0
    with_tau = _zeta_pct(tmp_path / "tau")
    assert with_tau.size == 4
    np.testing.assert_allclose(with_tau, truth, rtol=0.05)  # within 5 %
    assert main(["identify", str(foreign_uff), "--out", str(tmp_path / "raw"), "--quiet"]) == 0
    raw = _zeta_pct(tmp_path / "raw")
    # without it the window's 1/tau = 0.61 1/s is taken as structural damping:
    # zeta' = zeta + 1/(tau w_n): mode 1 (18 Hz) 0.50 % -> 1.04 %
    np.testing.assert_allclose(raw, truth + 100 / (TAU_S * 2 * np.pi * paper_modes(
        "genuine").fn_hz[:4]), rtol=0.05)
    assert raw[0] > 1.9 * truth[0]


@pytest.mark.parametrize("bad", ["0", "-1.5", "nan", "inf"])
@pytest.mark.parametrize("command", ["identify", "batch"])
def test_exp_window_tau_must_be_positive(bad: str, command: str, foreign_uff: Path,
                                         tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                         ) -> None:
    target = str(foreign_uff if command == "identify" else foreign_uff.parent)
    code = main([command, target, "--out", str(tmp_path / "o"), f"--exp-window-tau={bad}"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--exp-window-tau" in err[0] and "> 0" in err[0], err
    assert not (tmp_path / "o").exists()


def _two_mode_frf(n_out: int, n_in: int, n_lines: int = 401) -> tuple[FRFSet, ModalParameters]:
    """Receptance of 30 Hz / 1 % and 70 Hz / 2 % at n_out x n_in points, noise-free."""
    f = np.linspace(0.0, 100.0, n_lines)
    truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    x = np.linspace(0.1, 0.9, max(n_out, n_in))
    phi = np.stack([np.sin(np.pi * x), np.sin(2 * np.pi * x)], axis=1)
    H = modal_frf(f, truth, phi[:n_out], phi[-n_in:], quantity="receptance")
    frf = FRFSet(freq_hz=f, H=H, quantity="receptance",
                 response_dofs=tuple(DOF(k + 1) for k in range(n_out)),
                 reference_dofs=tuple(DOF(20 + k) for k in range(n_in)))
    return frf, truth


def test_identify_applies_reciprocity_to_roving_sets() -> None:
    roving, truth = _two_mode_frf(1, 8)  # one accelerometer, 8 hammer points
    res = identify(roving)
    ref = identify(roving.reciprocal())
    np.testing.assert_allclose(res.fn_hz, truth.fn_hz, rtol=1e-6)
    np.testing.assert_allclose(res.zeta, truth.zeta, rtol=1e-3)
    np.testing.assert_allclose(res.fn_hz, ref.fn_hz, rtol=1e-12)
    assert res.modes.shapes.shape == (8, 2)  # one row per hammer point
    assert res.modes.dofs == roving.reference_dofs
    assert res.settings.max_order == ref.settings.max_order


def test_identify_file_refuses_too_few_lines(tmp_path: Path) -> None:
    frf, _ = _two_mode_frf(2, 1, n_lines=MIN_FRF_LINES - 4)
    path = io.write_frf(frf, tmp_path / "short.uff", "uff")
    outcome = identify_file(path, tmp_path / "out")
    assert outcome.status == "failed"
    assert str(path) in outcome.reason and f"at least {MIN_FRF_LINES}" in outcome.reason


def test_batch_takes_suffixes_in_any_letter_case(tmp_path: Path) -> None:
    frf, truth = _two_mode_frf(2, 1)
    folder = tmp_path / "in"
    folder.mkdir()
    names = {"A.UFF": "uff", "b.Unv": "uff", "c.UFB": "uff-binary", "d.H5": "h5", "e.FRF": "h5",
             "f.Frf": "uff"}
    for name, fmt in names.items():
        io.write_frf(frf, folder / name, fmt)
    (folder / "notes.TXT").write_text("not an FRF file")
    report = run_batch(folder, tmp_path / "out", workers=1, progress=False)
    summary = pd.read_csv(tmp_path / "out" / "summary.csv")
    assert sorted(summary["file"]) == sorted(names)
    assert report.n_failed == 0 and set(summary["status"]) == {"ok"}
    for name in names:
        stem = Path(name).stem
        modes = pd.read_csv(tmp_path / "out" / f"{stem}_modes.csv")
        np.testing.assert_allclose(modes["fn_hz"], truth.fn_hz, rtol=1e-5)


# ------------------------------------------------------------------ --expect
def test_match_expected_never_takes_a_distant_mode() -> None:
    fn = [18.1, 112.0, 327.5, 629.0]
    guesses = [18.0, 60.0, 112.0, 650.0]
    assert match_expected(fn, guesses, 0.05).tolist() == [0, -1, 1, 3]  # 650: 3.2 % off 629
    assert match_expected(fn, guesses, tol=0.02).tolist() == [0, -1, 1, -1]
    # two guesses near one mode: the nearer guess gets it, the other is not found
    assert match_expected([100.0, 300.0], [98.0, 100.5], 0.05).tolist() == [-1, 0]
    # equally near: the mode with more stable orders
    assert match_expected([99.0, 101.0], [100.0], 0.05, priority=[3, 9]).tolist() == [1]
    assert match_expected([], [100.0], 0.05).tolist() == [-1]


def test_with_expected_rows_adds_empty_rows() -> None:
    table = pd.DataFrame({"mode": [1, 2, 3], "fn_hz": [18.1, 112.0, 327.5],
                          "zeta_pct": [0.5, 0.67, 0.29]})
    out = with_expected_rows(table, [60.0, 112.0, 700.0], 0.15)
    np.testing.assert_array_equal(out["expect_hz"], [np.nan, 60.0, 112.0, np.nan, 700.0])
    assert out["mode"].isna().tolist() == [False, True, False, False, True]
    assert np.isnan(out.loc[1, "fn_hz"]) and np.isnan(out.loc[4, "zeta_pct"])
    assert out.loc[2, "fn_hz"] == 112.0 and out.loc[3, "fn_hz"] == 327.5


EXAMPLES = {"genuine.uff": "genuine", "larger_tank.h5": "larger_tank",
            "smaller_tank.uff": "smaller_tank"}


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_sdypy_backend_one_row_per_mode(name: str, example_dir: Path) -> None:
    frf = io.read_frf(example_dir / name)
    res = identify(frf, method="sdypy-lscf", max_order=60)
    truth = paper_modes(EXAMPLES[name]).fn_hz[:4]
    assert res.modes.n_modes == 4, res.fn_hz
    np.testing.assert_allclose(res.fn_hz, truth, rtol=2e-3)
    assert np.all(np.diff(res.fn_hz) > 1.0) and np.all(res.zeta > 0)


def test_sdypy_backend_refuses_too_low_order(example_dir: Path, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """Below the method's minimum (10 for sdypy-lscf) the options refuse the
    order, in the library and on the command line alike; above it, sdypy-EMA's
    LSCF still needs 2 orders per mode looked for (6 guesses: 12)."""
    frf = io.read_frf(example_dir / "genuine.uff")
    with pytest.raises(OptionError, match=r"max_order must be at least 10 for method "
                                          r"'sdypy-lscf'.*got 2"):
        identify(frf, method="sdypy-lscf", max_order=2)
    code = main(["identify", str(example_dir / "genuine.uff"), "--out", str(tmp_path),
                 "--method", "sdypy-lscf", "--max-order", "2"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--max-order must be at least 10" in err[0], err
    assert not (tmp_path / "genuine_modes.csv").exists()
    with pytest.raises(DataError, match=r"max_order 10 is too low for 6 mode\(s\).*at least 12"):
        identify(frf, method="sdypy-lscf", max_order=10, expect_hz=[18, 112, 327, 500, 629, 700])


def test_expect_not_found_is_an_empty_row(example_dir: Path, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """--expect 18,60,112 on the genuine beam (modes 18.1, 112.1, 327.6, 629.6 Hz):
    60 Hz has no mode within 15 % (``expect_tol``): a warning and an empty row,
    not the 112 Hz mode."""
    code = main(["identify", str(example_dir / "genuine.uff"), "--out", str(tmp_path),
                 "--method", "sdypy-lscf", "--max-order", "60", "--expect", "18,60,112",
                 "--quiet"])
    assert code == 0
    assert "not found within 15 % of 60 Hz" in capsys.readouterr().err
    table = pd.read_csv(tmp_path / "genuine_modes.csv")
    assert table["expect_hz"].tolist() == [18.0, 60.0, 112.0]
    np.testing.assert_allclose(table["fn_hz"][[0, 2]], [18.129, 112.067], rtol=1e-3)
    assert table.iloc[1].drop("expect_hz").isna().all()
    with pytest.warns(UserWarning, match="not found within 15 % of 60 Hz"):
        res = identify(io.read_frf(example_dir / "genuine.uff"), method="sdypy-lscf",
                       max_order=60, expect_hz=[18.0, 60.0, 112.0])
    assert res.modes.n_modes == 2


def test_narrow_band_far_from_zero_runs_to_the_end(real_uff: Path, tmp_path: Path) -> None:
    """The pLSCF numerator Gram matrix of a band starting far above 0 Hz is
    numerically singular at high order (it raised LinAlgError from the Cholesky
    factorisation); a small ridge keeps the fit going, and the measured modes in
    the band are found (published 118.9, 155.4, 226.4, 265.2, 362.8 Hz)."""
    assert main(["identify", str(real_uff), "--out", str(tmp_path), "--band", "100", "400",
                 "--quiet"]) == 0
    fn = pd.read_csv(tmp_path / "ufsc-beam-hammer_modes.csv")["fn_hz"].to_numpy()
    for published in (155.391, 226.395, 265.219, 362.805):
        assert np.min(np.abs(fn - published)) < 1.0, (published, fn)


def test_console_says_the_model_each_band_fitted(example_dir: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """Issue 31: the band changes the model, and `identify` says so under the
    modes: band, diagram orders and residual terms, the numbers of the stored
    result's settings (on the measured beam the orders differ by band:
    test_identification.test_real_beam_modes_do_not_depend_on_the_band)."""
    for band in ((5.0, 200.0), (5.0, 700.0)):
        out = tmp_path / f"b{band[1]:g}"
        assert main(["identify", str(example_dir / "genuine.uff"), "--out", str(out),
                     "--band", *map(str, band)]) == 0
        line = [s for s in capsys.readouterr().out.splitlines() if s.startswith("  model: ")]
        assert len(line) == 1
        orders = io.read_identification_result(out / "genuine_result.h5")[1].settings.orders
        assert line[0] == (f"  model: band {band[0]:g}-{band[1]:g} Hz, diagram orders "
                           f"{int(np.min(orders))}-{int(np.max(orders))}, lower and upper "
                           "residual terms")


def test_geometry_without_report_is_refused_by_identify_and_batch(
        example_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--geometry`` draws the modes in the report pages; ``identify`` and
    ``batch`` without ``--report`` (with or without ``--uff``, whose modes UFF
    holds no geometry) both refuse it with the same one line, exit 2, before
    any work (``identify`` used to ignore it)."""
    geometry = REPO / "examples" / "ufsc-beam-geometry.uff"
    messages = []
    for command, target in (("identify", example_dir / "genuine.uff"), ("batch", example_dir)):
        out = tmp_path / command
        code = main([command, str(target), "--out", str(out), "--geometry", str(geometry),
                     "--uff", "--quiet"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1, err
        assert "--geometry draws the modes in the report pages: add --report" in err[0]
        messages.append(err[0].split("error: ", 1)[1])
        assert not out.exists()
    assert messages[0] == messages[1]


def test_run_geometry_help_states_one_default() -> None:
    """The help of ``run --geometry`` gives its one default (the experiment's
    geometry, else its FE beam), not also the FRF file's (which is identify's
    and batch's)."""
    from ema_pipeline.cli.parser import build_parser

    parser = build_parser()

    def geometry_help(command: str) -> str:
        action = next(a for a in parser.commands[command]._actions if a.dest == "geometry")
        return str(action.help)

    run_help = geometry_help("run")
    assert run_help.count("default") == 1, run_help
    assert run_help.endswith("default: the experiment's [geometry], else its FE beam")
    for command in ("identify", "batch"):
        text = geometry_help(command)
        assert text.count("default") == 1 and text.endswith("default: the geometry in the "
                                                            "FRF file"), text
