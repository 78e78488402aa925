"""``ema-pipeline init DIR --example`` writes the example study where the package is
installed, without the repository: ``cd DIR && ema-pipeline run`` runs it and finds
the shipped example's modes."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.io.template import example_experiment

REPO = Path(__file__).resolve().parents[1]
TABLE1 = Path("tables") / "table1_modal_parameters.csv"


def installed_copy(site: Path) -> Path:
    """The package as a wheel installs it: its modules and the package data that
    pyproject.toml declares, copied into ``site`` (nothing else of the repository)."""
    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    for source in (REPO / "ema_pipeline").rglob("*.py"):
        target = site / source.relative_to(REPO)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source, target)
    for package, patterns in config["package-data"].items():
        folder = REPO.joinpath(*package.split("."))
        for pattern in patterns:
            for source in folder.glob(pattern):
                target = site / source.relative_to(REPO)
                target.parent.mkdir(parents=True, exist_ok=True)  # e.g. report/js/
                shutil.copy2(source, target)
    return site


def test_init_example_then_run_outside_the_checkout(example_study, example_dir, tmp_path):
    """From a copy of the installed package, in a folder outside the checkout: ``init
    study --example`` writes the shipped example (experiment file byte for byte, the
    FRFs within a rounding of their last bits), and ``run`` in ``study`` finds the
    modes of the shipped example's run (``example_study``) within 1e-6 Hz relative
    and 1e-5 percentage points of damping."""
    site, work = installed_copy(tmp_path / "site"), tmp_path / "work"
    work.mkdir()
    env = {**os.environ, "PYTHONPATH": str(site)}

    def cli(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
        done = subprocess.run([sys.executable, "-m", "ema_pipeline", *argv], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        return done

    where = subprocess.run([sys.executable, "-c", "import ema_pipeline as e; print(e.__file__)"],
                           cwd=work, env=env, capture_output=True, text=True, check=True)
    assert Path(where.stdout.strip()).is_relative_to(site)  # the copy, not the checkout
    said = cli("init", "study", "--example", cwd=work).stdout
    assert "cd study && ema-pipeline run" in said
    raw = work / "study" / "raw_frf"
    assert sorted(p.name for p in raw.iterdir()) == sorted(p.name for p in example_dir.iterdir())
    assert (raw / "experiment.toml").read_bytes() == (example_dir / "experiment.toml").read_bytes()
    for name in example_experiment()[1].values():
        again, shipped = io.read_frf(raw / name), io.read_frf(example_dir / name)
        np.testing.assert_allclose(again.H, shipped.H, rtol=0,
                                   atol=1e-9 * np.max(np.abs(shipped.H)))
        assert again.acquisition == shipped.acquisition
    cli("run", "--quiet", cwd=work / "study")
    ours = pd.read_csv(work / "study" / "results" / TABLE1)
    shipped_modes = pd.read_csv(example_study / TABLE1)
    assert list(ours["configuration"]) == list(shipped_modes["configuration"])
    assert len(ours) == 12  # four modes of each of the three configurations
    np.testing.assert_allclose(ours["fd_hz"], shipped_modes["fd_hz"], rtol=1e-6)
    np.testing.assert_allclose(ours["zeta_pct"], shipped_modes["zeta_pct"], rtol=0, atol=1e-5)


def test_the_shipped_experiment_file_is_the_package_data():
    assert example_experiment()[0] == (REPO / "raw_frf" / "experiment.toml").read_text()


def test_init_example_keeps_existing_files_and_refuses_recordings(tmp_path, capsys):
    raw = tmp_path / "raw_frf"
    raw.mkdir()
    (raw / "genuine.uff").write_text("mine")
    assert main(["init", str(tmp_path), "--example"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"ema-pipeline init: error: {raw / 'genuine.uff'} exists; give --force to "
                   "overwrite the example study")
    assert [p.name for p in raw.iterdir()] == ["genuine.uff"]
    assert (raw / "genuine.uff").read_text() == "mine"
    assert main(["init", str(tmp_path), "--example", "--recordings", str(raw)]) == 2
    assert "drop --recordings" in capsys.readouterr().err


def test_run_without_an_experiment_file_offers_the_example(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ema-pipeline run: error: raw_frf/experiment.toml: no such file; "
                          "`ema-pipeline init DIR --example` writes the example study")
    assert len(err.splitlines()) == 1
    assert not (tmp_path / "results").exists()


@pytest.mark.parametrize("folder, file", [("file", "file"), ("file/sub", "file"),
                                          ("dir", "dir/raw_frf")])
def test_init_example_into_a_file_is_refused_by_name(tmp_path, capsys, folder, file):
    (tmp_path / "dir").mkdir()
    (tmp_path / file).write_text("x")
    assert main(["init", str(tmp_path / folder), "--example"]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path / file) in err and len(err.splitlines()) == 1
    assert (tmp_path / file).read_text() == "x"
