"""The package's one runner of worker processes (ema_pipeline.runner): the
library is serial by default, ``workers=2`` gives the serial numbers bit for
bit, the fork-safety rule is asked at the fork, a crashed worker is reported
naming its item, and Ctrl-C stops a command with workers at once."""

from __future__ import annotations

import gc
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import runner
from ema_pipeline.cli import main
from ema_pipeline.cli.support import WORKERS_ENV, command_workers
from ema_pipeline.data import ConfigError, FRFSet, ModalParameters
from ema_pipeline.identification.core import identify
from ema_pipeline.identification.thresholds import SelectionThresholds
from tests.forking import here_or_fresh
from tests.paths import REAL_UFF as BEAM
from tests.paths import REPO


def _twelve_mode_frf() -> tuple[FRFSet, ModalParameters]:
    """A noisy twelve-mode FRF whose dense band is searched again in windows."""
    from ema_pipeline.acquisition import modal_frf

    twelve = ModalParameters(fn_hz=[40.0, 85.0, 130.0, 180.0, 225.0, 270.0, 330.0, 380.0,
                                    430.0, 490.0, 545.0, 610.0], zeta=[0.01] * 12)
    f = np.linspace(0.0, 800.0, 2049)
    rng = np.random.default_rng(5)
    phi = rng.standard_normal((3, 12))
    H = modal_frf(f, twelve, phi, phi[:1], quantity="receptance")
    H = H + 0.002 * np.std(H) * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    return FRFSet(freq_hz=f, H=H, quantity="receptance"), twelve


# ------------------------------------------------------------------ worker counts
def test_worker_count_comes_from_the_argument_only(monkeypatch):
    monkeypatch.setenv(WORKERS_ENV, "7")  # the library does not read it
    assert runner.worker_count(12) == 1
    assert runner.worker_count(5, 2) == 2
    assert runner.worker_count(2, 8) == 2  # never more than the tasks
    assert runner.worker_count(0, 3) == 1
    assert command_workers(None) == 7  # the command line does
    assert command_workers(3) == 3
    monkeypatch.delenv(WORKERS_ENV)
    assert command_workers(None) == runner.available_cores()
    with pytest.raises(ConfigError, match="--workers must be at least 1"):
        command_workers(0)


# ------------------------------------------------------------------ work begun ahead
def _pid_and(x: int) -> tuple[int, int]:
    return os.getpid(), x


def _sleep_long(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def test_a_pool_aborted_with_work_running_leaves_no_thread(request):
    """``ProcessPool.close(abort=True)`` while its workers compute: when it
    returns, the executor's threads have ended and a fork is safe at once
    (before, an aborted executor's manager thread ran on for a moment: 28
    of 30 such pools left the next fork refused)."""
    if not here_or_fresh(request):
        return
    for _ in range(5):
        pool = runner.ProcessPool(1)
        pool.submit(_sleep_long, 60.0)
        time.sleep(0.05)
        t0 = time.perf_counter()
        pool.close(abort=True)
        assert time.perf_counter() - t0 < 10.0
        assert runner.fork_is_safe(), [t.name for t in threading.enumerate()]


def test_a_pool_closed_right_after_its_submit_waits_for_its_starting_threads(request):
    """A pool aborted the moment its work is submitted (``identify`` whose
    options are refused while its files are read ahead): the executor's
    manager thread may be starting a queue's feeder thread just then, listed
    but not yet joinable. Before, ``close`` then raised "cannot join thread
    before it is started" (29 and 30 of 1000 such pools; the CI met it
    once); now it waits for it, and a fork is safe after every close."""
    if not here_or_fresh(request):
        return
    for _ in range(300):
        pool = runner.ProcessPool(1)
        pool.submit(abs, -3)
        pool.close(abort=True)
        assert runner.fork_is_safe(), [t.name for t in threading.enumerate()]


def _gc_state(_: object) -> tuple[int, int]:
    """A worker's frozen objects and the objects its full collections walk."""
    return gc.get_freeze_count(), len(gc.get_objects(generation=2))


def test_workers_are_forked_with_this_process_objects_frozen(request):
    """A fork pool's workers and :func:`runner.checked_fork`'s child inherit
    this process's objects frozen (``gc.freeze``), so that their full
    collections do not walk them (before, each worker of ``identify`` on the
    paper files spent 27-28 ms in one such walk); here they are unfrozen
    after the fork, and objects the caller froze stay frozen."""
    if not here_or_fresh(request):
        return
    gc.unfreeze()  # an earlier test's cli.run() froze this process's objects at its end
    before = len(gc.get_objects(generation=2))
    pool = runner.ProcessPool(1)
    try:
        frozen, walked = pool.submit(_gc_state, None).result(timeout=60)
    finally:
        pool.close()
    assert gc.get_freeze_count() == 0
    assert frozen > 10_000 and walked < before / 10, (frozen, walked, before)
    read, write = os.pipe()
    pid = runner.checked_fork()
    if pid == 0:  # the child: its frozen objects, through the pipe
        os.write(write, str(gc.get_freeze_count()).encode())
        os._exit(0)
    os.close(write)
    os.waitpid(pid, 0)
    with os.fdopen(read) as pipe:
        assert int(pipe.read()) > 10_000
    assert gc.get_freeze_count() == 0
    gc.freeze()  # the caller's own freeze: left as it is
    frozen_by_caller = gc.get_freeze_count()
    try:
        with runner.frozen_for_fork():
            pass
        assert gc.get_freeze_count() == frozen_by_caller
    finally:
        gc.unfreeze()


def test_work_begun_ahead_runs_beside_and_is_dropped_when_not_needed(request):
    """``started_ahead``: with two workers the work runs in another process
    and its result comes back (the worker then gone); work not asked for is
    stopped when the block ends (no waiting for it, no process or thread left: a fork right after is
    safe); with one worker nothing runs until the result is asked for, and
    then once."""
    if not here_or_fresh(request):
        return
    with runner.started_ahead(_pid_and, 7, workers=2) as result:
        pid, x = result()
        assert (pid != os.getpid(), x) == (True, 7)
        assert runner.fork_is_safe()  # the worker gone with its result taken
    t0 = time.perf_counter()
    with runner.started_ahead(_sleep_long, 60.0, workers=2):
        pass  # not needed
    assert time.perf_counter() - t0 < 10.0
    assert runner.fork_is_safe() and not runner.ProcessPool(1).processes()
    calls: list[int] = []
    with runner.started_ahead(calls.append, 1, workers=1) as result:
        assert calls == []
        result()
        result()
    assert calls == [1]
    with runner.started_ahead(calls.append, 2, workers=1):
        pass
    assert calls == [1]


# ------------------------------------------------------------------ identify()
def test_identify_in_a_thread_starts_no_process_and_workers_2_gives_the_same_numbers(
        request, monkeypatch):
    """``identify()`` called from a thread (a web server, a notebook's worker
    thread) forks nothing by default; ``workers=2`` in the main thread forks
    two workers (the windows' searches and the local fits) and gives exactly
    the numbers of ``workers=1``."""
    if not here_or_fresh(request):
        return
    frf, twelve = _twelve_mode_frf()
    forks: list[int] = []
    real_fork = os.fork

    def counted_fork():
        forks.append(threading.get_ident())
        return real_fork()

    monkeypatch.setattr(os, "fork", counted_fork)
    results = {}
    thread = threading.Thread(target=lambda: results.setdefault("thread", identify(frf)))
    thread.start()
    thread.join()
    assert forks == [] and not runner.ProcessPool(1).processes()
    results["1"] = identify(frf, workers=1)
    assert forks == []
    results["2"] = identify(frf, workers=2)
    # the search grows: the cap's diagram begun ahead in a worker of its own
    # (runner.started_ahead), then the pool's two workers, forked at its first map
    assert len(forks) == 3
    a = results["1"]
    assert a.fn_hz.size == 12
    np.testing.assert_allclose(np.sort(a.fn_hz), twelve.fn_hz, rtol=2e-3)
    assert a.band_support[:, 0].max() >= 2  # the windows held modes
    for other in ("thread", "2"):
        b = results[other]
        for name in ("fn_hz", "zeta", "fn_std_hz", "zeta_std"):
            np.testing.assert_array_equal(getattr(a.modes, name), getattr(b.modes, name),
                                          err_msg=f"{other}: {name}")
        np.testing.assert_array_equal(a.band_support, b.band_support)


def test_a_thread_started_after_the_block_opened_keeps_the_map_serial(request):
    """The rule is asked at the fork (the first map of two or more items), not
    when the block opens: a thread started in between keeps it in this process."""
    if not here_or_fresh(request):
        return
    stop = threading.Event()
    with runner.process_map(4, workers=2) as map_:
        assert map_.workers == 2
        other = threading.Thread(target=stop.wait)
        other.start()
        try:
            assert not runner.fork_is_safe()
            assert map_(_pid, [1, 2, 3]) == [os.getpid()] * 3
            assert map_.pool is None  # nothing forked
        finally:
            stop.set()
            other.join()
        assert runner.fork_is_safe()
        pids = map_(_pid, [1, 2, 3, 4])  # now it forks
        assert map_.pool is not None and os.getpid() not in pids


def _pid(_item: int) -> int:
    return os.getpid()


def test_a_progress_bar_leaves_the_fork_rule_true(request, monkeypatch):
    """The FE stage's model-update bar starts no tqdm monitor thread (at tqdm's
    default ``monitor_interval``), which would make every later map serial."""
    if not here_or_fresh(request):
        return
    import tqdm

    from ema_pipeline.pipeline.fe_stage import update_progress_bar

    monkeypatch.setattr(tqdm.tqdm, "monitor_interval", 10)  # tqdm's default
    try:
        with update_progress_bar() as advance:
            assert advance is not None
            advance(1, 10)
            assert runner.fork_is_safe(), [t.name for t in threading.enumerate()]
        assert runner.fork_is_safe()
    finally:  # a monitor left running would slow every later test of the process
        if tqdm.tqdm.monitor is not None:
            tqdm.tqdm.monitor.exit()
            tqdm.tqdm.monitor = None


# ------------------------------------------------------------------ crashes
def _die_on_three(item: int) -> int:
    if item == 3:
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.05)
    return item * item


def test_process_imap_reports_the_item_that_kills_its_worker(request):
    """A worker killed (SIGKILL) while it runs item 3: the items in flight
    with it are run again and give their results; item 3 is reported, not
    waited on."""
    if not here_or_fresh(request):
        return
    start = time.perf_counter()
    got = list(runner.process_imap(_die_on_three, [1, 2, 3, 4, 5], 2,
                                   crashed=lambda item, reason: reason))
    assert got[:2] == [1, 4] and got[3:] == [16, 25]
    assert got[2].startswith("3: its worker process died (killed by SIGKILL)"), got[2]
    with pytest.raises(runner.WorkerCrashed, match="^3: its worker process died"):
        list(runner.process_imap(_die_on_three, [1, 2, 3, 4], 2))
    assert time.perf_counter() - start < 60


def test_an_item_that_kills_its_worker_before_the_next_goes_out(request, monkeypatch):
    """The pool breaks while the items are still being submitted (an item
    that kills its worker at once; the CI met it once): a map of a file's
    shares reports the death, and ``process_imap`` runs the items that had
    not gone out in a fresh pool and reports the one that killed its
    worker. Forced here: each submit of the killing item waits until its
    future reports the death."""
    if not here_or_fresh(request):
        return
    real = runner.ProcessPool.submit

    def waits_for_the_death(self, func, item):
        future = real(self, func, item)
        if item in (3, [3]):
            future.exception(timeout=60)  # the pool is broken once this returns
        return future

    monkeypatch.setattr(runner.ProcessPool, "submit", waits_for_the_death)
    with runner.process_map(2, workers=2) as map_:
        with pytest.raises(runner.WorkerCrashed, match="worker process died"):
            map_(_killed_share, [[3], [2]])
    got = list(runner.process_imap(_die_on_three, [3, 1, 2, 4], 2,
                                   crashed=lambda item, reason: reason))
    assert got[0].startswith("3: its worker process died"), got[0]
    assert got[1:] == [1, 4, 16]


def _crash_on_name(path, job, frf=None):
    from ema_pipeline.pipeline.single import FileOutcome

    if Path(path).name.startswith("crash"):
        os._exit(3)
    return FileOutcome(path=path, reason=str(os.getpid())), None


def test_identify_files_reports_a_crashed_worker_naming_the_file(request, monkeypatch, tmp_path):
    from ema_pipeline.identification import IdentificationOptions
    from ema_pipeline.pipeline import many

    if not here_or_fresh(request):
        return
    monkeypatch.setattr(many, "identify_one", _crash_on_name)
    paths = [Path(name) for name in ("a.uff", "crash.uff", "c.uff", "d.uff")]
    outcomes = [o for o, _ in many.identify_files(paths, many.FileJob(tmp_path,
                                                  IdentificationOptions()), workers=2)]
    assert [o.path for o in outcomes] == paths
    assert [o.status for o in outcomes] == ["ok", "failed", "ok", "ok"]
    crashed = outcomes[1]
    assert crashed.runtime and crashed.reason == "crash.uff: its worker process died " \
                                                 "(exit status 3)", crashed.reason


def _killed_share(items: list[int]) -> list[int]:
    os.kill(os.getpid(), signal.SIGKILL)
    return items  # pragma: no cover


def test_a_share_of_a_file_whose_worker_dies_is_an_error_not_a_hang(request):
    if not here_or_fresh(request):
        return
    with runner.process_map(2, workers=2) as map_:
        with pytest.raises(runner.WorkerCrashed, match="worker process died") as info:
            map_(_killed_share, [[1], [2]])
    assert isinstance(info.value, OSError)  # the CLI's runtime error, exit status 1


# ------------------------------------------------------------------ identify FILE...
def _fake_identify_one(path, job, frf=None):
    from ema_pipeline.pipeline.single import FileOutcome

    return FileOutcome(path=path, reason=f"{os.getpid()} {job.workers}"), None


def test_identify_files_runs_in_worker_processes_in_order(request, monkeypatch, tmp_path):
    from ema_pipeline.identification import IdentificationOptions
    from ema_pipeline.pipeline import many

    if not here_or_fresh(request):
        return
    monkeypatch.setattr(many, "identify_one", _fake_identify_one)
    paths = [Path(f"f{i}.uff") for i in range(6)]
    job = many.FileJob(tmp_path, IdentificationOptions())
    outcomes = [o for o, _ in many.identify_files(paths, job, workers=2)]
    assert [o.path for o in outcomes] == paths  # the files' order
    pids = {o.reason.split()[0] for o in outcomes}
    assert str(os.getpid()) not in pids and 1 <= len(pids) <= 2
    serial = [o.reason for o, _ in many.identify_files(paths, job)]  # default: one process
    assert set(serial) == {f"{os.getpid()} 1"}
    one = [o.reason for o, _ in many.identify_files(paths[:1], job, workers=2)]
    assert one == [f"{os.getpid()} 2"]  # one file: here, its windows in two workers
    with pytest.raises(ConfigError, match="same outputs"):
        list(many.identify_files([Path("a/x.uff"), Path("b/x.h5")], job))


def test_identify_several_files_in_workers_equals_serial(monkeypatch, tmp_path, example_dir,
                                                         capsys):
    """The outputs of ``identify`` on three files, in two workers and in one
    process (``--workers`` and ``$EMA_PIPELINE_WORKERS``): byte-identical
    modes tables, the same lines in the same order."""
    files = [str(example_dir / name) for name in ("genuine.uff", "smaller_tank.uff",
                                                  "larger_tank.h5")]
    runs = {}
    for how in (["--workers", "1"], "2"):
        if isinstance(how, str):
            monkeypatch.setenv(WORKERS_ENV, how)
            how = []
        out = tmp_path / f"w{len(runs)}"
        assert main(["identify", *files, "--out", str(out), *how]) == 0
        lines = [line.split(" (")[0] for line in capsys.readouterr().out.splitlines()]
        tables = {p.name: p.read_bytes() for p in sorted(out.glob("*_modes.csv"))}
        runs[len(runs)] = ([line.replace(str(out), "OUT") for line in lines], tables)
    assert len(runs[0][1]) == 3
    assert runs[0] == runs[1]


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(p) for p in text.split()]


def _sigint_as_in_a_terminal() -> None:
    """A command started from a terminal has SIGINT at its default, which
    Python turns into KeyboardInterrupt. A suite run as a background job
    (``cmd &`` in a script: measured, a CI runner started that way) passes
    SIGINT ignored to its children, and Python then leaves it ignored, as
    a background job should."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.skipif(not BEAM.exists(), reason="the measured beam in ../shared/data is absent")
def test_ctrl_c_of_identify_with_workers_stops_within_2_s(tmp_path):
    """``identify A B C --workers 2`` on three copies of the measured beam
    (several seconds each): SIGINT to the command while both workers run
    files ends it within 2 s, with the interrupted status, and leaves no
    worker behind."""
    files = []
    for name in ("a", "b", "c"):
        shutil.copy(BEAM, tmp_path / f"{name}.uff")
        files.append(str(tmp_path / f"{name}.uff"))
    env = dict(os.environ, PYTHONPATH=str(REPO))
    env.pop(WORKERS_ENV, None)
    proc = subprocess.Popen([sys.executable, "-m", "ema_pipeline", "identify", *files,
                             "--out", str(tmp_path / "out"), "--workers", "2", "--quiet"],
                            env=env, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_sigint_as_in_a_terminal)
    try:
        deadline = time.monotonic() + 120
        while len(_children(proc.pid)) < 2 and time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
            time.sleep(0.05)
        workers = _children(proc.pid)
        assert len(workers) == 2
        time.sleep(1.0)  # the workers are identifying
        assert proc.poll() is None
        start = time.monotonic()
        os.kill(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=30)
        seconds = time.monotonic() - start
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130 and "interrupted" in err, err
    assert seconds < 2.0, seconds
    assert not [pid for pid in workers if Path(f"/proc/{pid}").exists()
                and "Z" not in Path(f"/proc/{pid}/stat").read_text().split()[2]]
    assert not list((tmp_path / "out").glob("*_modes.csv"))  # no file had finished


# ------------------------------------------------------------------ maps
class RecordingMap(runner.SerialMap):
    """A two-worker :class:`~ema_pipeline.runner.Mapper` that runs in this
    process and records the items of each call (``calls``)."""

    workers = 2

    def __init__(self) -> None:
        self.calls: list[list] = []

    def __call__(self, func, items):
        items = list(items)
        self.calls.append(items)
        return [func(item) for item in items]


def test_windows_go_to_the_workers_longest_first_and_come_back_in_order(monkeypatch):
    """``add_window_modes`` hands the windows' searches to the workers'
    map longest first (more lines: a higher order cap, more work; a long
    search started last would leave the other workers idle) and folds what
    each found in in the windows' own order, so the result is the serial
    loop's."""
    from ema_pipeline.identification.diagram import order_search
    from ema_pipeline.identification.result import SelectedPoles
    fn = np.geomspace(20.0, 900.0, 18)  # ever wider windows up the band
    lam = -0.01 * 2 * np.pi * fn + 2j * np.pi * fn
    sel = SelectedPoles(lam, np.arange(18), np.full(18, 10), np.zeros(18), np.zeros(18),
                         np.ones(18, int), np.zeros(18, int))
    freq = np.arange(5.0, 1000.0, 0.5)

    def one_pole_at_the_middle(search, freq_hz, Hn, window_hz):
        mid = 2j * np.pi * float(np.mean(window_hz)) - 1.0
        return SelectedPoles(np.array([mid]), np.array([0]), np.array([10]), np.zeros(1),
                             np.zeros(1), np.ones(1, int), np.zeros(1, int))

    recorded = RecordingMap()
    monkeypatch.setattr(order_search, "search_window", one_pole_at_the_middle)
    search = order_search.OrderSearch(None, 0.0, 0.05, 0.3, expect=False, map_=recorded,
                                      thresholds=SelectionThresholds())
    _, searched = order_search.add_window_modes(sel, search, freq, np.ones((1, 1, freq.size)),
                                                (5.0, 1000.0))
    windows = order_search.mode_windows(np.imag(lam) / (2 * np.pi), (5.0, 1000.0),
                                        thresholds=SelectionThresholds())
    assert len(windows) >= 3
    seen = [window for call in recorded.calls for window in call]
    widths = [hi - lo for lo, hi in seen]
    assert sorted(seen) == sorted(windows)
    assert widths == sorted(widths, reverse=True) and widths != [hi - lo for lo, hi in windows]
    assert [w for w, _, _ in searched] == windows  # back in the windows' order
    for window, found, _ in searched:
        np.testing.assert_allclose(found.pole.imag / (2 * np.pi), np.mean(window))


def test_diagram_orders_in_workers_give_the_serial_poles(request):
    """A diagram of two references large enough to share out
    (``plscf.PARALLEL_MIN_SIZE3``): its orders' block-companion eigenvalues,
    one order per task, largest first, in two worker processes give the
    poles of the serial loop bit for bit, in the orders' order. With one
    reference the roots come order after order from the previous ones
    (``diagram.roots``), in this process."""
    from ema_pipeline.acquisition import modal_frf
    from ema_pipeline.identification.diagram import plscf

    if not here_or_fresh(request):
        return
    modes = ModalParameters(fn_hz=[50.0, 120.0, 260.0, 410.0], zeta=[0.01] * 4)
    f = np.linspace(5.0, 500.0, 991)
    phi = np.random.default_rng(3).standard_normal((2, 4))
    with runner.process_map(2, workers=2) as map_:  # one reference: no pool
        plscf.plscf(f, modal_frf(f, modes, phi, phi[:1], quantity="receptance"),
                    max_order=200, orders=np.arange(2, 201, 6), map_=map_)
        assert map_.pool is None
    H = modal_frf(f, modes, phi, phi, quantity="receptance")  # two references
    orders = np.arange(2, 101, 3)
    assert sum(float(2 * n) ** 3 for n in orders) >= plscf.PARALLEL_MIN_SIZE3
    serial = plscf.plscf(f, H, max_order=100, orders=orders)
    with runner.process_map(len(orders), workers=2) as map_:
        assert map_.workers == 2
        shared = plscf.plscf(f, H, max_order=100, orders=orders, map_=map_)
        assert map_.pool is not None  # it did run in the pool
    np.testing.assert_array_equal(shared.order, serial.order)
    np.testing.assert_array_equal(shared.pole, serial.pole)
    np.testing.assert_array_equal(shared.participation, serial.participation)
    fn = np.abs(serial.pole[serial.order == orders[-1]]) / (2 * np.pi)
    assert np.all([np.min(np.abs(fn - f0)) < 0.5 for f0 in modes.fn_hz])


def test_run_gives_each_identification_its_workers(monkeypatch, tmp_path, example_dir):
    """``run --workers N`` hands N worker processes to every configuration's
    identification (the study's three files); without it, the command line's
    count (``$EMA_PIPELINE_WORKERS`` here); the library's ``run_study``
    defaults to one process."""
    from ema_pipeline.pipeline import study_run

    seen: list[int] = []
    real = study_run.identify

    def spy(frf, options=None, *, workers=1, **kwargs):  # frf: run's CheckedInput
        seen.append(workers)
        return real(frf, options, workers=1, **kwargs)  # the numbers of one process

    monkeypatch.setattr(study_run, "identify", spy)
    argv = ["run", "--raw", str(example_dir), "--no-figures", "--quiet"]
    assert main([*argv, "--results", str(tmp_path / "a"), "--workers", "3"]) == 0
    assert seen == [3, 3, 3]
    seen.clear()
    monkeypatch.setenv(WORKERS_ENV, "2")
    assert main([*argv, "--results", str(tmp_path / "b")]) == 0
    assert seen == [2, 2, 2]


def test_map_each_deals_by_cost_and_gives_the_serial_results(monkeypatch):
    """With ``cost``, ``map_each`` deals the items costliest first to the
    share with the least cost so far (the two long fits go to different
    workers, where round-robin put both in one share) and puts the results
    back in the items' order; the refinement passes its local fits' sizes
    (:func:`local_sizes`), and refining with two workers gives the serial
    numbers."""
    from ema_pipeline.identification.refinement import refine
    from ema_pipeline.identification.refinement.local_band import local_sizes
    from ema_pipeline.runner import deal_by_cost, map_each, split

    cost = [9.0, 1.0, 8.0, 1.0, 1.0, 1.0]
    assert split(list(range(6)), 2) == [[0, 2, 4], [1, 3, 5]]  # both long ones together
    shares = deal_by_cost(cost, 2)
    assert [0 in s and 2 in s for s in shares] == [False, False]
    assert sorted(k for s in shares for k in s) == list(range(6))

    recorded = RecordingMap()
    out = map_each(recorded, lambda xs: [10 * x for x in xs], [5, 6, 7, 8, 9, 10], 2, cost)
    assert out == [50, 60, 70, 80, 90, 100]
    assert recorded.calls == [[[[5, 6, 7, 8, 9, 10][k] for k in s] for s in shares]]

    # the refinement deals its fits by their sizes and keeps the serial numbers
    th = SelectionThresholds()
    f = np.linspace(50.0, 250.0, 2001)
    fn = np.array([80.0, 120.0, 121.5, 123.0, 180.0, 220.0])
    lam = -0.01 * 2 * np.pi * fn + 2j * np.pi * fn
    jw = 2j * np.pi * f
    H = sum(1 / (jw - p) + 1 / (jw - p.conj()) for p in lam)[None]
    H = H + 1e-4 * np.random.default_rng(0).standard_normal(H.shape)
    serial = refine.refine_poles(f, H, lam * (1 + 1e-4), quantity="receptance", thresholds=th)
    recorded = RecordingMap()
    dealt = refine.refine_poles(f, H, lam * (1 + 1e-4), quantity="receptance", thresholds=th,
                                map_=recorded)
    np.testing.assert_array_equal(dealt.pole, serial.pole)
    np.testing.assert_array_equal(dealt.cov, serial.cov)
    sizes = local_sizes(f, lam * (1 + 1e-4), th.local_half_width, th.local_min_lines,
                        thresholds=th)
    assert recorded.calls == [[list(s) for s in deal_by_cost(sizes, 2)]]
