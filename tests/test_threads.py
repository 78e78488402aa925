"""The tool owns its BLAS threads: one per process whatever the environment,
``$EMA_PIPELINE_BLAS_THREADS`` the documented override (the worker processes
are tested in test_runner.py)."""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from ema_pipeline.cli import main
from ema_pipeline.cli.support import WORKERS_ENV, command_workers
from ema_pipeline.data import ConfigError, FRFSet, ModalParameters
from ema_pipeline.identification import core
from ema_pipeline.identification.core import identify
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.threads import (
    BLAS_THREADS_ENV,
    THREAD_VARIABLES,
    blas_threads,
    entry_thread_environment,
    owned_blas_threads,
    thread_environment,
)
from tests.forking import here_or_fresh

TH = SelectionThresholds()  # the tuned defaults


def _blas_counts() -> set[int]:
    return {int(lib["num_threads"]) for lib in threadpool_info() if lib["user_api"] == "blas"}


def _two_mode_frf() -> FRFSet:
    from ema_pipeline.acquisition import modal_frf

    f = np.linspace(0.0, 100.0, 401)
    truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    return FRFSet(freq_hz=f, H=H)


def test_owned_blas_threads_sets_one_thread_and_the_override(monkeypatch):
    if not _blas_counts():
        pytest.skip("threadpoolctl finds no BLAS library in this process")
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    with threadpool_limits(limits=2):  # as a user's machine: several threads
        assert _blas_counts() == {2}
        with owned_blas_threads():
            assert _blas_counts() == {1}
        assert _blas_counts() == {2}  # restored after the block
        monkeypatch.setenv(BLAS_THREADS_ENV, "3")
        with owned_blas_threads():
            assert _blas_counts() == {3}
        monkeypatch.setenv(BLAS_THREADS_ENV, "auto")
        with owned_blas_threads():
            assert _blas_counts() == {2}


def _counting_limits(monkeypatch) -> list[int]:
    """threadpoolctl's ``threadpool_limits`` replaced by itself that records
    each count it is asked for (forked workers inherit the replacement)."""
    import threadpoolctl

    asked: list[int] = []
    real = threadpoolctl.threadpool_limits

    def counting(limits=None, **kwargs):
        asked.append(limits)
        return real(limits=limits, **kwargs)

    monkeypatch.setattr(threadpoolctl, "threadpool_limits", counting)
    return asked


def test_a_block_inside_a_block_of_the_same_count_asks_nothing(monkeypatch):
    """``identify`` inside the command line's block, or in a worker, set the
    threads again for each file: now a nested block of the same count asks
    threadpoolctl nothing, one of another count still sets its own."""
    if not _blas_counts():
        pytest.skip("threadpoolctl finds no BLAS library in this process")
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    asked = _counting_limits(monkeypatch)
    with threadpool_limits(limits=2):
        with owned_blas_threads():
            with owned_blas_threads():
                assert _blas_counts() == {1}
            assert _blas_counts() == {1}  # the inner block restored nothing
            monkeypatch.setenv(BLAS_THREADS_ENV, "3")
            with owned_blas_threads():
                assert _blas_counts() == {3}
            monkeypatch.delenv(BLAS_THREADS_ENV)
        assert _blas_counts() == {2}
        with owned_blas_threads():  # after the block: set again
            assert _blas_counts() == {1}
    assert asked == [1, 3, 1]


def _worker_threads(_: object) -> tuple[set[int], int]:
    """A worker's BLAS counts and how often it asked threadpoolctl for them
    (the list that :func:`_counting_limits` left in this module)."""
    with owned_blas_threads():  # as identify() in a worker
        counts = _blas_counts()
    return counts, len(_ASKED)


_ASKED: list[int] = []


def test_a_worker_forked_inside_the_block_keeps_its_count_without_asking(monkeypatch, request):
    """A worker forked inside :func:`owned_blas_threads` has the block's count
    (the fork carries it) and asks threadpoolctl nothing, at its start or in
    its files; one forked outside a block sets it at its start. Where another
    test's thread stops the fork here, it runs in a fresh process (it was
    skipped in one CI run)."""
    from ema_pipeline import runner

    if not _blas_counts():
        pytest.skip("threadpoolctl finds no BLAS library in this process")
    if not here_or_fresh(request):
        return
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    asked = _counting_limits(monkeypatch)
    monkeypatch.setattr(f"{__name__}._ASKED", asked)
    with threadpool_limits(limits=2):
        for inside in (True, False):
            with owned_blas_threads() if inside else threadpool_limits(limits=2):
                before = len(asked)
                pool = runner.ProcessPool(1)
                try:
                    counts, n_asked = pool.submit(_worker_threads, None).result(timeout=60)
                finally:
                    pool.close()
            assert counts == {1}, inside
            assert n_asked - before == (0 if inside else 1), inside


def test_identify_runs_on_one_blas_thread(monkeypatch):
    """The library's entry point owns the threads too, not only the CLI."""
    if not _blas_counts():
        pytest.skip("threadpoolctl finds no BLAS library in this process")
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    seen: list[set[int]] = []
    backend = core.METHODS["plscf"]

    def recording(frf, options, **kwargs):
        seen.append(_blas_counts())
        return backend(frf, options, **kwargs)

    monkeypatch.setitem(core.METHODS, "plscf", recording)
    with threadpool_limits(limits=2):
        result = identify(_two_mode_frf())
    assert seen == [{1}]
    np.testing.assert_allclose(result.fn_hz, [30.0, 70.0], rtol=1e-6)


@pytest.mark.parametrize("text", ["0", "-2", "two", "1.5"])
def test_bad_thread_variables_are_refused_by_name(monkeypatch, text, capsys):
    monkeypatch.setenv(BLAS_THREADS_ENV, text)
    with pytest.raises(ConfigError, match=BLAS_THREADS_ENV):
        blas_threads()
    assert main(["identify", "missing.uff", "--out", "/tmp/x"]) == 2
    assert BLAS_THREADS_ENV in capsys.readouterr().err
    monkeypatch.delenv(BLAS_THREADS_ENV)
    monkeypatch.setenv(WORKERS_ENV, text)  # read by the command line only
    with pytest.raises(ConfigError, match=WORKERS_ENV):
        command_workers(None)
    assert main(["identify", "missing.uff", "--out", "/tmp/x"]) == 2


def test_thread_environment(monkeypatch):
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    assert thread_environment()["OPENBLAS_NUM_THREADS"] == "1"
    assert entry_thread_environment() == thread_environment()
    monkeypatch.setenv(BLAS_THREADS_ENV, "3")
    assert entry_thread_environment()["OPENBLAS_NUM_THREADS"] == "3"
    monkeypatch.setenv(BLAS_THREADS_ENV, "auto")
    assert thread_environment() == {} == entry_thread_environment()
    monkeypatch.setenv(BLAS_THREADS_ENV, "0")  # invalid: left to the command's refusal
    assert entry_thread_environment() == {}


def _same_modes(a, b) -> None:
    assert a.fn_hz.size == b.fn_hz.size
    np.testing.assert_allclose(np.sort(a.fn_hz), np.sort(b.fn_hz), rtol=0, atol=0.01)


def test_same_modes_whatever_the_blas_threads(monkeypatch):
    """Close modes at one reference: the modes at two BLAS threads
    (``EMA_PIPELINE_BLAS_THREADS=2``) are those of one, within 0.01 Hz."""
    from tests.hardcases import make_case

    case = make_case("close_1ref", 7)
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    base = identify(case.frf, band_hz=case.band_hz)
    assert base.fn_hz.size == case.fn_hz.size
    monkeypatch.setenv(BLAS_THREADS_ENV, "2")
    _same_modes(base, identify(case.frf, band_hz=case.band_hz))


def test_same_modes_whatever_the_last_bits():
    """An impact hard case (dense band searched in windows, adaptive order):
    the FRFs changed by a relative 1e-12 give the same modes within 0.01 Hz
    (the measured beam in 5-790 Hz is the known exception,
    docs/guide/identification.md)."""
    from dataclasses import replace

    from tests.hardcases import make_case

    case = make_case("impact", 7)
    base = identify(case.frf, band_hz=case.band_hz)
    assert base.fn_hz.size == case.fn_hz.size
    assert base.band_support[:, 0].max() >= 2  # the windows were searched
    rng = np.random.default_rng(1)
    H = case.frf.H * (1 + 1e-12 * rng.standard_normal(case.frf.H.shape))
    _same_modes(base, identify(replace(case.frf, H=H), band_hz=case.band_hz))


def _entry_threads(tmp_path, blas_setting: str | None) -> tuple[int, str]:
    """The OS threads of a command's process at its exit (started as the
    ``ema-pipeline`` script starts it: :func:`ema_pipeline.cli.run`) and its
    stderr; no thread variable in its environment."""
    import os
    import subprocess
    import sys

    code = ("import atexit, os, sys; from ema_pipeline.cli import run; "
            "sys.argv = ['ema-pipeline', 'identify', 'missing.uff', '--out', 'out']; "
            "atexit.register(lambda: print(len(os.listdir('/proc/self/task')))); "
            "sys.exit(run())")
    env = {k: v for k, v in os.environ.items()
           if k not in (*THREAD_VARIABLES, BLAS_THREADS_ENV)}
    if blas_setting is not None:
        env[BLAS_THREADS_ENV] = blas_setting
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2  # missing.uff: refused after start-up
    return int(done.stdout.split()[-1]), done.stderr


def test_the_command_starts_no_blas_threads_of_its_own(tmp_path):
    """The entry point sets the thread variables before numpy loads its BLAS:
    the process has its one thread, where a BLAS loaded with its default
    (``auto``: left to BLAS) starts one per core, idle beside the work."""
    import os

    if not os.path.isdir("/proc/self/task"):
        pytest.skip("counting a process's threads needs Linux's /proc")
    assert _entry_threads(tmp_path, None)[0] == 1
    assert _entry_threads(tmp_path, "1")[0] == 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    if cores >= 2 and _blas_counts():
        assert _entry_threads(tmp_path, "auto")[0] > 1
    threads, err = _entry_threads(tmp_path, "two")  # refused by name, as before
    assert BLAS_THREADS_ENV in err and "positive integer" in err


def test_the_entry_point_imports_no_numpy_before_it_sets_the_threads():
    """What :func:`ema_pipeline.cli.run` relies on: importing the package,
    its command-line package and :mod:`ema_pipeline.threads` loads no numpy
    (the names of the package and of the command line load on first use)."""
    import subprocess
    import sys

    code = ("import sys, ema_pipeline, ema_pipeline.cli, ema_pipeline.threads; "
            "print('numpy' in sys.modules); from ema_pipeline import FRFSet; "
            "from ema_pipeline.cli import build_parser, main; "
            "print('numpy' in sys.modules, FRFSet.__name__, callable(main), "
            "callable(build_parser))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.split() == ["False", "True", "FRFSet", "True", "True"]
