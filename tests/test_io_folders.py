"""The atomic results folder of ``run`` (:mod:`ema_pipeline.io.folders`)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ema_pipeline import io
from ema_pipeline.io import folders


def dead_pid() -> int:
    """The pid of a process that has exited."""
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    return int(done.stdout)


def filled(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "report.md").write_text(text)
    return folder


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two renames"])
def test_swap_in_replaces_the_folder_and_leaves_nothing_beside_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, exchange: bool
) -> None:
    results = filled(tmp_path / "results", "old")
    if not exchange:  # a filesystem without RENAME_EXCHANGE
        monkeypatch.setattr(folders, "_exchange", lambda a, b: False)
    new = filled(io.partial_folder(results), "new")
    assert new.name.startswith(".results.partial-")
    io.swap_in(new, results)
    assert (results / "report.md").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


def test_swap_in_without_an_earlier_folder(tmp_path: Path) -> None:
    results = tmp_path / "results"
    io.swap_in(filled(io.partial_folder(results), "first"), results)
    assert (results / "report.md").read_text() == "first"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]


def test_remove_stale_partials_keeps_live_runs_and_restores_a_backup(tmp_path: Path) -> None:
    dead = dead_pid()
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        filled(tmp_path / f".results.partial-{dead}-abc", "killed run")
        filled(tmp_path / f".results.partial-{live.pid}-def", "running")
        # a run killed between the two renames: the old results are the backup
        filled(tmp_path / f".results.old-{dead}", "the earlier results")
        assert not io.pid_alive(dead) and io.pid_alive(live.pid)
        assert io.remove_stale_partials(tmp_path / "results") == 1
        names = sorted(p.name for p in tmp_path.iterdir())
        assert names == [f".results.partial-{live.pid}-def", "results"]
        assert (tmp_path / "results" / "report.md").read_text() == "the earlier results"
    finally:
        live.kill()
        live.wait()
