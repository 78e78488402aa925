"""Tests of ``ema-pipeline batch`` (ema_pipeline.pipeline.batch).

The simulated files hold only the 2-400 Hz lines of the default impact test
(three modes, about 170 kB each), so one identification takes a fraction of a
second; the batch identifies in 5-395 Hz.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

from ema_pipeline import acquisition, io, paper
from ema_pipeline.cli import main
from ema_pipeline.data import Beam, ConfigError, Geometry
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.pipeline import batch
from ema_pipeline.pipeline.batch import BatchReport, run_batch
from ema_pipeline.pipeline.reports import batch_file_report_path, write_batch_report
from ema_pipeline.pipeline.simulate import simulate_paper_test
from tests.paths import THREE_SENSORS

FILE_BAND_HZ = (2.0, 400.0)
OPTIONS = IdentificationOptions(band_hz=(5.0, 395.0))
CLI_BAND = ["--band", "5", "395"]
N_MODES = 3  # Table 1 modes below 395 Hz

#: (relative path, configuration, seed, format): equal stems in one folder
#: (a.uff, a.h5) and in different folders (genuine_1.h5).
GOOD_FILES = (
    ("genuine_1.h5", "genuine", 1, "h5"),
    ("a.uff", "larger_tank", 2, "uff"),
    ("a.h5", "smaller_tank", 3, "h5"),
    ("day2/genuine_1.h5", "genuine", 4, "h5"),
    ("day2/b.uff", "smaller_tank", 5, "uff-binary"),
    ("day2/deep/c.h5", "larger_tank", 6, "h5"),
)
BAD_FILES = ("corrupt.uff", "day2/nan.h5", "truncated.uff")


def _simulate(path: Path, configuration: str, seed: int, fmt: str,
              sensors: tuple[int, ...] | None = None) -> None:
    """A simulated test of the paper's beam: its two sensors, or ``sensors``."""
    setup = None if sensors is None else acquisition.TestSetup(response_nodes=sensors)
    frf = simulate_paper_test(configuration, setup, seed=seed).band(*FILE_BAND_HZ)
    path.parent.mkdir(parents=True, exist_ok=True)
    io.write_frf(frf, path, fmt)


def _read_summary(out: Path) -> pd.DataFrame:
    return pd.read_csv(out / "summary.csv", keep_default_na=False, dtype=str)


def _without_timing(summary: pd.DataFrame) -> pd.DataFrame:
    return summary.drop(columns=["seconds"]).reset_index(drop=True)


def _temporaries(out: Path) -> list[Path]:
    return [p for p in out.rglob("*") if p.name.endswith(".tmp")]


def _result_files(out: Path) -> list[Path]:
    return sorted(p for p in out.rglob("*_result.h5") if not p.name.startswith("."))


@pytest.fixture(scope="module")
def good_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("raw")
    for rel, configuration, seed, fmt in GOOD_FILES:
        _simulate(folder / rel, configuration, seed, fmt)
    return folder


@pytest.fixture(scope="module")
def local_run(good_folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The good files through two local worker processes."""
    out = tmp_path_factory.mktemp("out_local")
    report = run_batch(
        good_folder, out, options=OPTIONS, workers=2, scheduler=None, force=False, progress=False
    )
    assert (report.n_ok, report.n_failed) == (len(GOOD_FILES), 0), report.summary_line()
    return out


def _bad_folder(good_folder: Path, target: Path) -> Path:
    """The good files plus two corrupt ones and a truncated one."""
    folder = target / "raw"
    shutil.copytree(good_folder, folder)
    (folder / "corrupt.uff").write_bytes(b"    -1\n    58\nthis is not a UFF record\n" * 5)
    nan_h5 = folder / "day2" / "nan.h5"
    _simulate(nan_h5, "genuine", 7, "h5")
    with h5py.File(nan_h5, "r+") as h5:
        H = h5["frf/H"][()]
        H[0, 0, 100] = np.nan
        h5["frf/H"][...] = H
    whole = (folder / "a.uff").read_bytes()  # cut inside the second record
    (folder / "truncated.uff").write_bytes(whole[: int(0.7 * len(whole))])
    return folder


def test_cli_batch_good_and_bad_files(
    good_folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every good file is identified (Table 1 within 0.1 %), with outputs that
    mirror the input folders; the three bad files are in failures.csv with
    reasons naming them, and the exit status is 1."""
    folder = _bad_folder(good_folder, tmp_path)
    out = tmp_path / "out"
    code = main(["batch", str(folder), "--out", str(out), "--workers", "2", "--quiet", *CLI_BAND])
    assert code == 1
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith(f"batch: {len(GOOD_FILES) + 3} files: {len(GOOD_FILES)} ok, 0 skipped")
    assert "3 failed" in line and "failures.csv" in line

    summary = _read_summary(out).set_index("file")
    assert list(summary.index) == sorted(summary.index)  # input order
    assert set(summary.index) == {rel for rel, *_ in GOOD_FILES} | set(BAD_FILES)
    expected_dirs = {  # equal stems in one folder get a folder named after the file
        "genuine_1.h5": ".",
        "a.uff": "a.uff",
        "a.h5": "a.h5",
        "day2/genuine_1.h5": "day2",
        "day2/b.uff": "day2",
        "day2/deep/c.h5": "day2/deep",
    }
    for rel, configuration, _, _ in GOOD_FILES:
        row = summary.loc[rel]
        assert row["status"] == "ok", rel
        assert row["configuration"] == configuration
        assert row["sha256"] == io.sha256_file(folder / rel)
        stem = Path(rel).stem
        modes_csv = Path(expected_dirs[rel]) / f"{stem}_modes.csv"
        assert Path(row["modes_csv"]) == modes_csv
        assert Path(row["result_h5"]) == modes_csv.with_name(f"{stem}_result.h5")
        assert io.results_complete(out / row["result_h5"])
        modes = io.read_csv(out / modes_csv, required=("fd_hz",))
        truth = paper.TABLE1_FD_HZ[configuration][:N_MODES]
        assert int(row["n_modes"]) == N_MODES == len(modes)
        np.testing.assert_allclose(modes["fd_hz"], truth, rtol=1e-3)
        freqs = [float(f) for f in row["frequencies_hz"].split(";")]
        np.testing.assert_allclose(freqs, modes["fn_hz"], rtol=1e-9)
        # fit_error_pct in per cent (40 dB: 5-7 %), fit_frac a ratio
        assert 0 < float(row["fit_error_pct"]) < 10 and 0.9 < float(row["fit_frac"]) <= 1.0

    failures = pd.read_csv(out / "failures.csv", keep_default_na=False, dtype=str)
    assert sorted(failures["file"]) == sorted(BAD_FILES)
    for _, row in failures.iterrows():
        assert Path(row["file"]).name in row["reason"], row["reason"]
        assert row["sha256"] == io.sha256_file(folder / row["file"])
        assert summary.loc[row["file"], "status"] == "failed"
    reasons = dict(zip(failures["file"], failures["reason"], strict=True))
    assert "NaN" in reasons["day2/nan.h5"]
    assert not _temporaries(out)
    assert not list(out.rglob("corrupt*")) and not list(out.rglob("truncated*"))


#: The files of the workers/rerun and scheduler tests: one of each configuration,
#: an HDF5 file at the top and UFF / HDF5 files in subfolders (their output
#: folders are the same as in the whole good folder: no equal stems among them).
RERUN_FILES = ("genuine_1.h5", "day2/b.uff", "day2/deep/c.h5")


def _rerun_folder(good_folder: Path, target: Path) -> Path:
    """A folder with the :data:`RERUN_FILES` of the good folder."""
    folder = target / "raw"
    for rel in RERUN_FILES:
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(good_folder / rel, folder / rel)
    return folder


def _local_rows(local_run: Path) -> pd.DataFrame:
    """The rows of :data:`RERUN_FILES` in the summary of ``local_run`` (in input order)."""
    rows = _read_summary(local_run)
    rows = rows[rows["file"].isin(RERUN_FILES)]
    assert sorted(rows["file"]) == sorted(RERUN_FILES)
    return rows


def test_warnings_of_a_file_are_in_the_summary(good_folder: Path, tmp_path: Path) -> None:
    """What ``identify`` warns about a file (here a guess that no mode
    answers) is in summary.csv's ``warnings`` column, also when a rerun skips
    the file (read back from its result)."""
    folder = tmp_path / "raw"
    folder.mkdir()
    shutil.copy(good_folder / "genuine_1.h5", folder / "genuine_1.h5")
    options = IdentificationOptions(band_hz=OPTIONS.band_hz, expect_hz=(18.0, 112.0, 250.0))
    out = tmp_path / "out"
    for skipped in (0, 1):
        report = run_batch(folder, out, options=options, workers=1, force=False, progress=False)
        assert (report.n_ok, report.n_skipped) == (1 - skipped, skipped)
        warning = _read_summary(out)["warnings"].iloc[0]
        assert warning.startswith(str(folder / "genuine_1.h5")), warning
        assert "not found within 15 % of 250 Hz" in warning, warning


def test_progress_bar_leaves_no_thread(
    good_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A batch with its progress bar leaves no thread behind: tqdm's monitor
    thread (started by a bar at tqdm's default ``monitor_interval``; the suite
    sets it to 0) outlives the bars, and a second thread makes the fork rule
    refuse every later fork of the process: io.check_hdf5, such as the batch
    report's of each result, would start a fresh interpreter instead (measured: ``batch raw_frf
    --report`` 25 s with it, 15 s without, loaded machine)."""
    import tqdm

    from ema_pipeline.runner import fork_is_safe

    monkeypatch.setattr(tqdm.tqdm, "monitor_interval", 10)  # tqdm's default
    folder = tmp_path / "raw"
    folder.mkdir()
    shutil.copy(good_folder / "a.uff", folder / "a.uff")
    try:
        report = run_batch(folder, tmp_path / "out", options=OPTIONS, workers=1, progress=True)
        assert report.n_ok == 1
        assert fork_is_safe(), [t.name for t in threading.enumerate()]
    finally:  # a monitor left running would slow every later test of the process
        if tqdm.tqdm.monitor is not None:
            tqdm.tqdm.monitor.exit()
            tqdm.tqdm.monitor = None


def test_workers_1_and_2_identical_and_rerun_skips(
    good_folder: Path, local_run: Path, tmp_path: Path
) -> None:
    """--workers 1 and --workers 2 give the same summary rows; a rerun skips every
    file without rewriting it (same summary rows, status skipped); --force
    recomputes. Three of the good files: none of these behaviours needs all six."""
    folder = _rerun_folder(good_folder, tmp_path)
    n = len(RERUN_FILES)
    out = tmp_path / "out"
    report = run_batch(folder, out, options=OPTIONS, workers=1, force=False, progress=False)
    assert (report.n_ok, report.n_skipped, report.n_failed) == (n, 0, 0)
    one, two = _read_summary(out), _local_rows(local_run)
    pd.testing.assert_frame_equal(_without_timing(one), _without_timing(two))

    stamps = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in out.rglob("*_*.*")}
    assert len(stamps) == 2 * n  # <stem>_modes.csv and <stem>_result.h5 per file
    again = run_batch(folder, out, options=OPTIONS, workers=2, force=False, progress=False)
    assert (again.n_ok, again.n_skipped, again.n_failed) == (0, n, 0)
    assert f"0 ok, {n} skipped, 0 failed" in again.summary_line()
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in stamps} == stamps
    skipped = _without_timing(_read_summary(out))
    assert set(skipped["status"]) == {"skipped"}
    pd.testing.assert_frame_equal(
        skipped.drop(columns="status"), _without_timing(one).drop(columns="status")
    )

    forced = run_batch(folder, out, options=OPTIONS, workers=2, force=True, progress=False)
    assert (forced.n_ok, forced.n_skipped) == (n, 0)
    assert all(p.stat().st_ino != ino for p, (ino, _) in stamps.items())
    pd.testing.assert_frame_equal(_without_timing(_read_summary(out)), _without_timing(one))


def test_scheduler_matches_local_processes(
    good_folder: Path, local_run: Path, tmp_path: Path
) -> None:
    """--scheduler on a dask LocalCluster gives the results of local processes.

    The cluster and the CLI run in a child interpreter: dask leaves a thread
    (Dask-Offload) in the process that used it, and a second thread makes every
    later io.check_hdf5 of the test process start a fresh interpreter (~2 s).
    Three of the good files (one per configuration, HDF5 and binary UFF, in
    subfolders): what is compared does not need all six, and the dask worker
    identifies them in one process."""
    pytest.importorskip("distributed")
    folder = _rerun_folder(good_folder, tmp_path)
    out = tmp_path / "out"
    script = (
        "import sys\n"
        "import distributed\n"
        "from ema_pipeline.cli import main\n"
        "if __name__ == '__main__':\n"
        "    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True,\n"
        "                                  dashboard_address=None) as cluster:\n"
        "        address = cluster.scheduler_address\n"
        "        if not address.startswith('tcp://'):\n"
        "            sys.exit(f'scheduler address {address!r}')\n"
        "        code = main(['batch', sys.argv[1], '--out', sys.argv[2], '--scheduler', address,\n"
        "                     '--quiet', *sys.argv[3:]])\n"
        "    sys.exit(code)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    done = subprocess.run(
        [sys.executable, "-c", script, str(folder), str(out), *CLI_BAND],
        capture_output=True, text=True, env=env, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    dask_summary, local_summary = _read_summary(out), _local_rows(local_run)
    pd.testing.assert_frame_equal(
        _without_timing(dask_summary).drop(columns="frequencies_hz"),
        _without_timing(local_summary).drop(columns="frequencies_hz"),
    )
    for rel in dask_summary["result_h5"]:
        with h5py.File(out / rel) as a, h5py.File(local_run / rel) as b:
            np.testing.assert_allclose(a["modes/fn_hz"][()], b["modes/fn_hz"][()], rtol=1e-9)
            np.testing.assert_allclose(a["modes/zeta_pct"][()], b["modes/zeta_pct"][()], rtol=1e-6)


def _start_batch(folder: Path, out: Path, workers: int) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "ema_pipeline.cli", "batch", str(folder), "--out", str(out),
           "--workers", str(workers), "--quiet", *CLI_BAND]  # fmt: skip
    return subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )


def _wait_for_results(out: Path, n: int, proc: subprocess.Popen[str], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while len(_result_files(out)) < n:
        if proc.poll() is not None:
            pytest.fail(f"batch ended early ({proc.returncode}): {proc.stderr.read()}")
        if time.monotonic() > deadline:
            os.killpg(proc.pid, signal.SIGKILL)
            pytest.fail("no results appeared")
        time.sleep(0.02)


@pytest.fixture(scope="module")
def many_files(good_folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """8 files (copies of the good UFF ones under other names): more than the
    kill and SIGINT tests can see finished before they stop the batch (at most
    2 x workers files are in flight). UFF only: a worker checks each HDF5 input
    in a fresh interpreter (its parent-watcher thread rules out a fork), about
    2 s per file on a loaded machine, and what these tests stop and resume does
    not depend on the input format (HDF5 inputs run in the other batch tests)."""
    folder = tmp_path_factory.mktemp("many")
    sources = [good_folder / rel for rel, *_ in GOOD_FILES if rel.endswith(".uff")]
    for k in range(8):
        src = sources[k % len(sources)]
        shutil.copy(src, folder / f"run{k:02d}{src.suffix}")
    return folder


def test_killed_batch_resumes(many_files: Path, tmp_path: Path) -> None:
    """SIGKILL a running batch (the whole process group): only complete results
    remain; the rerun skips them without rewriting, and finishes the rest."""
    out = tmp_path / "out"
    proc = _start_batch(many_files, out, workers=1)
    _wait_for_results(out, 3, proc, timeout=120)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate()

    done = _result_files(out)
    n_total = len(io.find_frf_files(many_files))
    assert 3 <= len(done) < n_total, "the batch finished before it was killed"
    assert all(io.results_complete(p) for p in done)  # atomic: nothing half-written
    assert all(p.name.startswith(".") for p in _temporaries(out))  # only hidden temporaries
    assert not (out / "summary.csv").exists()  # written only at the end
    stamps = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in done}

    report = run_batch(many_files, out, options=OPTIONS, workers=2, progress=False)
    assert report.n_skipped == len(done)
    assert report.n_ok == n_total - len(done) and report.n_failed == 0
    summary = _read_summary(out)
    skipped = {out / p for p in summary.loc[summary["status"] == "skipped", "result_h5"]}
    assert skipped == set(done)
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in done} == stamps
    assert len(_result_files(out)) == n_total
    assert all(io.results_complete(p) for p in _result_files(out))
    assert not _temporaries(out)  # the killed run's temporaries are gone


def test_sigint_stops_cleanly(many_files: Path, tmp_path: Path) -> None:
    """Ctrl-C (SIGINT to the process group): running files finish, the rest is
    cancelled, summary.csv lists what was done, the exit status is 1, nothing
    partial is left."""
    out = tmp_path / "out"
    proc = _start_batch(many_files, out, workers=2)
    _wait_for_results(out, 2, proc, timeout=120)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    assert "batch: interrupted after" in err and "not run" in err

    summary = _read_summary(out)
    n_total = len(io.find_frf_files(many_files))
    assert 2 <= len(summary) < n_total
    assert set(summary["status"]) == {"ok"}
    assert {out / p for p in summary["result_h5"]} == set(_result_files(out))
    assert all(io.results_complete(p) for p in _result_files(out))
    assert not _temporaries(out)


def test_missing_distributed_is_a_clear_error(
    good_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    with pytest.raises(ConfigError, match=r"\[distributed\]"):
        run_batch(good_folder, tmp_path / "out", scheduler="tcp://127.0.0.1:1", progress=False)
    code = main(["batch", str(good_folder), "--out", str(tmp_path / "o"), "--scheduler", "x"])
    assert code == 2


def test_bad_arguments_and_lock(good_folder: Path, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such folder"):
        run_batch(tmp_path / "missing", tmp_path / "out", progress=False)
    with pytest.raises(ConfigError, match="at least 1"):
        run_batch(good_folder, tmp_path / "out", workers=0, progress=False)
    for out in (good_folder, good_folder.parent):  # results would become inputs
        with pytest.raises(ConfigError, match="read back as inputs"):
            run_batch(good_folder, out, progress=False)
    out = tmp_path / "locked"
    out.mkdir()
    with batch.batch_lock(out), pytest.raises(ConfigError, match="another batch"):
        run_batch(good_folder, out, progress=False)
    assert not (out / batch.LOCK_NAME).exists()  # a batch that ends leaves no lock


def test_empty_folder(tmp_path: Path) -> None:
    """Nothing to do is a usage error, found before OUT (and its lock) exist."""
    (tmp_path / "raw").mkdir()
    (tmp_path / "raw" / "notes.txt").write_text("no FRFs here")
    with pytest.raises(ConfigError, match="no FRF files"):
        run_batch(tmp_path / "raw", tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match="a file, not a folder"):
        run_batch(tmp_path / "raw" / "notes.txt", tmp_path / "out", progress=False)


def test_inputs_layout_and_stale_temporaries(good_folder: Path, tmp_path: Path) -> None:
    """Outputs under DIR are not inputs; equal stems get their own folders;
    hidden temporaries of a killed run are removed."""
    folder = tmp_path / "raw"
    shutil.copytree(good_folder, folder)
    out = folder / "results"
    (out / "x").mkdir(parents=True)
    shutil.copy(folder / "a.h5", out / "x" / "old_result.h5")
    (out / "x" / ".a_result.h5.abc123.tmp").write_bytes(b"half")
    (out / "keep.tmp").write_bytes(b"not ours")
    files = batch.find_inputs(folder, out)
    assert [p.relative_to(folder).as_posix() for p in files] == sorted(
        rel for rel, *_ in GOOD_FILES
    )
    layout = dict(batch.output_dirs(files, folder, out))
    assert layout["a.uff"] == out / "a.uff" and layout["a.h5"] == out / "a.h5"
    assert layout["day2/genuine_1.h5"] == out / "day2"
    assert batch.remove_stale_temporaries(out) == 1
    assert (out / "keep.tmp").exists()


def test_summary_line() -> None:
    report = BatchReport(
        folder=Path("raw"),
        out=Path("OUT"),
        n_files=200,
        n_ok=197,
        n_errors=3,
        seconds=81.2,
        failures_csv=Path("OUT/failures.csv"),
    )
    assert report.summary_line() == (
        "batch: 200 files: 197 ok, 0 skipped, 3 failed (see OUT/failures.csv) "
        "in 81.2 s, 2.46 files/s"
    )
    assert report.n_failed == 3
    stopped = BatchReport(
        folder=Path("raw"), out=Path("OUT"), n_files=10, n_ok=4, n_not_run=6, seconds=2.0,
        interrupted=True,
    )  # fmt: skip
    assert stopped.n_failed == 6
    assert stopped.summary_line().startswith("batch: interrupted after 4 of 10 files: 4 ok")


def _crash_on_name(task: batch.FileTask) -> batch.FileRecord:
    """Like process_file, but the worker dies on files named crash*."""
    if Path(task.file).name.startswith("crash"):
        os._exit(3)
    return batch.process_file(task)


def _local_batch(good_folder: Path, tmp_path: Path, names: tuple[str, ...],
                 backend: type[batch.LocalBackend]) -> tuple[BatchReport, Path]:
    """Copies of ``a.uff`` under ``names`` run by ``backend(2, _crash_on_name)``:
    the batch's report and its output folder."""
    folder = tmp_path / "raw"
    folder.mkdir()
    for name in names:
        shutil.copy(good_folder / "a.uff", folder / name)
    out = tmp_path / "out"
    out.mkdir()
    files = batch.find_inputs(folder, out)
    tasks = (
        batch.FileTask(path=p, file=name, out_dir=target, options=OPTIONS, force=False)
        for p, (name, target) in zip(files, batch.output_dirs(files, folder, out), strict=True)
    )
    report = BatchReport(
        folder=folder, out=out, n_files=len(files), summary_csv=out / "summary.csv",
        failures_csv=out / "failures.csv",
    )  # fmt: skip
    batch.run_tasks(tasks, report, lambda: backend(2, _crash_on_name), progress=False)
    return report, out


def test_worker_crash_is_isolated(good_folder: Path, tmp_path: Path) -> None:
    """A file that kills its worker process is recorded as failed; the files
    that were in the pool with it are retried and succeed. (UFF copies: no
    fresh-interpreter HDF5 check per file in the workers, see ``many_files``.)"""
    report, out = _local_batch(good_folder, tmp_path, ("a1.uff", "crash.uff", "a3.uff", "a4.uff"),
                               batch.LocalBackend)
    assert (report.n_ok, report.n_errors) == (3, 1)
    failures = pd.read_csv(out / "failures.csv")
    assert list(failures["file"]) == ["crash.uff"]
    assert "worker process died" in failures["reason"][0] and "crash.uff" in failures["reason"][0]
    assert list(_read_summary(out)["status"]) == ["ok", "ok", "ok", "failed"]


class _RefusingBackend(batch.LocalBackend):
    """A local backend whose submit of crash.uff returns only once that
    task's worker has died: the next submit meets a broken pool."""

    def submit(self, task: batch.FileTask):
        future = super().submit(task)
        if Path(task.file).name.startswith("crash"):
            future.exception(timeout=120)
        return future


def test_a_pool_broken_while_tasks_are_submitted_is_restarted(good_folder: Path,
                                                                tmp_path: Path) -> None:
    """A file that kills its worker before the next file is submitted: the
    refused submit is a task whose worker died (before, BrokenProcessPool
    escaped the batch); the pool restarts, the crash is recorded once and the
    other files succeed."""
    # crash.uff first in the batch's order
    report, out = _local_batch(good_folder, tmp_path, ("crash.uff", "d2.uff", "d3.uff"),
                               _RefusingBackend)
    assert (report.n_ok, report.n_errors) == (2, 1)
    assert list(pd.read_csv(out / "failures.csv")["file"]) == ["crash.uff"]


# ------------------------------------------------------------------ report page per file
def _json_blocks(html: str, cls: str) -> list:
    """The JSON of every ``<script type="application/json" class="cls">`` of a page."""
    return [json.loads(b) for b in re.findall(
        rf'<script type="application/json" class="{cls}">(.*?)</script>', html, re.S)]


def _mode_diamonds(html: str) -> list[float]:
    """f (Hz) of the diagram's kept-mode start poles, which open ``selected``."""
    return [float(f) for f in re.findall(
        r'<polygon class="pole mode selected"[^>]*data-freq-hz="([^"]+)"', html)]


def _loads_from_outside(html: str) -> list[str]:
    """Anything a browser would fetch from elsewhere (scripts, styles, images, links)."""
    return (re.findall(r'(?:src|href)\s*=\s*["\']?\s*(?:[a-z]+:)?//|<link\b|<script[^>]*\bsrc=|'
                       r"@import", html, re.I)
            + re.findall(r"\burl\(", html))  # CSS (not the script's URL.createObjectURL)


def test_batch_report_writes_the_identify_page_of_every_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``batch --report`` writes, beside each file's result and linked from the
    batch page, the page ``identify --report`` writes for that file (same
    diagram poles, same kept modes, same animated shapes), rebuilt from the
    stored result: a rerun that skips every file rewrites them. Shapes are
    animated on the geometry in a UFF file (none in an HDF5 file); with
    ``--geometry FILE`` on that file's nodes for every file. Nothing is loaded
    from outside the pages. Three sensors: two make shapes of two points,
    which the pages do not draw (issue 41)."""
    folder = tmp_path / "raw"
    folder.mkdir()
    _simulate(tmp_path / "a3.uff", "larger_tank", 2, "uff", sensors=THREE_SENSORS)
    _simulate(folder / "genuine_1.h5", "genuine", 1, "h5", sensors=THREE_SENSORS)
    ids = np.arange(1, 12)  # the beam's measurement nodes; a.uff's own are bent in y
    own_xyz = np.column_stack([0.065 * (ids - 1), 0.02 * (ids - 1), np.zeros(ids.size)])
    own = io.write_geometry_uff(Geometry(node_ids=ids, xyz_m=own_xyz, lines=(tuple(ids),)),
                                tmp_path / "own.uff")
    (folder / "a.uff").write_bytes(own.read_bytes() + (tmp_path / "a3.uff").read_bytes())
    configurations = {"a.uff": "larger_tank", "genuine_1.h5": "genuine"}
    given = io.write_geometry_uff(Beam().measurement_geometry(), tmp_path / "given.uff")
    out = tmp_path / "out"
    cli = ["batch", str(folder), "--out", str(out), "--workers", "1", "--quiet", "--report",
           *CLI_BAND]

    def pages(status: str) -> dict[str, str]:
        summary = _read_summary(out).set_index("file")
        assert list(summary["status"]) == [status, status]
        batch_html = (out / "report.html").read_text(encoding="utf-8")
        links = re.findall(r'<a class="file-page" href="([^"]+)">([^<]+)</a>', batch_html)
        expected = [(batch_file_report_path(summary.loc[f, "result_h5"]).as_posix(), f)
                    for f in summary.index]
        assert links == expected
        assert not _loads_from_outside(batch_html)
        return {f: (out / href).read_text(encoding="utf-8") for href, f in links}

    start = time.perf_counter()
    assert main(cli) == 0
    first = pages("ok")
    for name, html in first.items():
        assert not _loads_from_outside(html)
        assert 'href="report.html">Back to the batch report</a>' in html  # both in OUT itself
        modes = io.read_csv(out / f"{Path(name).stem}_modes.csv", required=("fn_hz", "fd_hz"))
        truth = paper.TABLE1_FD_HZ[configurations[name]][:N_MODES]
        np.testing.assert_allclose(modes["fd_hz"], truth, rtol=1e-3)
        # the diagram: its poles (JSON the script draws) and the kept modes' start
        # poles, selected, one per mode at the mode's frequency (start poles are
        # the trajectories' medians, before refinement: within 0.1 %)
        np.testing.assert_allclose(_mode_diamonds(html), modes["fn_hz"], rtol=1e-3)
        (poles,) = _json_blocks(html, "stab-poles")
        f, stable = np.array(poles["f"]), np.array(list(poles["s"])) == "s"  # all stable
        assert len({len(poles[k]) for k in "fzomgs"}) == 1 and f.size > 100
        assert np.all((f >= 5.0) & (f <= 395.0))
        for fn in modes["fn_hz"]:  # every kept mode stands on a column of stable poles
            assert np.count_nonzero(stable & (np.abs(f - fn) < 2e-3 * fn)) >= 5, fn
        assert '<pre class="picks" id="picks">' in html
    # a.uff: animated on its own nodes; genuine_1.h5 holds no geometry: no views
    assert first["a.uff"].count("data-mode-shape=") == N_MODES
    shapes = _json_blocks(first["a.uff"], "shape-data")
    assert len(shapes) == 2  # the mode-shape views and the diagram's preview, on one geometry
    for shape in shapes:
        np.testing.assert_allclose(shape["nodes"], own_xyz, atol=1e-6)
    assert "data-mode-shape=" not in first["genuine_1.h5"]
    # the same content as identify --report of the file
    assert main(["identify", str(folder / "a.uff"), "--out", str(tmp_path / "id"), "--report",
                 "--quiet", *CLI_BAND]) == 0
    alone = (tmp_path / "id" / "a_report.html").read_text(encoding="utf-8")
    for cls in ("stab-poles", "shape-data"):
        assert _json_blocks(alone, cls) == _json_blocks(first["a.uff"], cls), cls
    assert _mode_diamonds(alone) == _mode_diamonds(first["a.uff"])
    capsys.readouterr()

    assert main([*cli, "--geometry", str(given)]) == 0  # skipped: pages from the results
    assert capsys.readouterr().err == ""  # every measured DOF has a node
    second = pages("skipped")
    beam_xyz = Beam().measurement_geometry().xyz_m
    for name, html in second.items():
        assert html.count("data-mode-shape=") == N_MODES, name
        shapes = _json_blocks(html, "shape-data")
        assert len(shapes) == 2, name  # the mode-shape views and the diagram's preview
        for shape in shapes:
            np.testing.assert_allclose(shape["nodes"], beam_xyz, atol=1e-6)
        assert _json_blocks(html, "stab-poles") == _json_blocks(first[name], "stab-poles")
        assert _mode_diamonds(html) == _mode_diamonds(first[name])
    # a result without its identification section (an older or foreign file): no
    # page, no link, a warning naming the file; the other file's page is still there
    stored = out / "genuine_1_result.h5"
    io.write_results_h5({"frf": io.read_frf(folder / "genuine_1.h5")}, stored)
    warnings: list[str] = []
    write_batch_report(out, folder, OPTIONS, warnings=warnings)
    assert len(warnings) == 1 and warnings[0].startswith("genuine_1.h5: no report page: ")
    assert "/identification is missing" in warnings[0]
    links = re.findall(r'class="file-page" href="([^"]+)"', (out / "report.html").read_text())
    assert links == ["a_report.html"]
    assert not (out / "genuine_1_report.html").exists()  # not left from the earlier result
    assert time.perf_counter() - start < 60

