"""Shared fixtures: the measured data set beside the project, and simulated FRFs."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest
import tqdm

# tqdm starts a monitor thread with its first bar, even a disabled one (batch
# --quiet), and keeps it for the life of the process. Any second thread makes
# every later io.check_hdf5 in the test process start a fresh interpreter
# (about 2 s on the loaded 2-core machine) instead of forking (about 0.1 s),
# for every test that runs after the first batch. Bars refresh without it.
tqdm.tqdm.monitor_interval = 0

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
REAL_UFF = SHARED_DATA / "ufsc-beam-hammer.uff"


@pytest.fixture(scope="session")
def real_uff() -> Path:
    """The measured roving-hammer test in ../shared/data (skipped where absent)."""
    if not REAL_UFF.is_file():
        pytest.skip(f"measured data not available at {REAL_UFF}")
    return REAL_UFF


@pytest.fixture(scope="session")
def example_dir() -> Path:
    return REPO / "raw_frf"


#: ``python -m mypy ema_pipeline`` (settings in pyproject.toml), started in the
#: background when test_style.py::test_mypy_clean is collected.
MYPY_COMMAND = [sys.executable, "-m", "mypy", "ema_pipeline"]
_MYPY_KEY = pytest.StashKey[subprocess.Popen[str]]()


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start mypy as soon as its test is collected: a cold run takes 15-50 s of
    one core, and the rest of the suite mostly runs on the other one meanwhile;
    test_mypy_clean then only waits for it."""
    if importlib.util.find_spec("mypy") is None:
        return
    if any(item.name == "test_mypy_clean" for item in session.items):
        session.config.stash[_MYPY_KEY] = subprocess.Popen(
            MYPY_COMMAND, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL, text=True,
        )


def pytest_unconfigure(config: pytest.Config) -> None:
    proc = config.stash.get(_MYPY_KEY, None)
    if proc is not None and proc.poll() is None:  # the run stopped before the test
        proc.kill()
        proc.wait()


@pytest.fixture
def mypy_outcome(request: pytest.FixtureRequest) -> tuple[int, str]:
    """(exit status, output) of :data:`MYPY_COMMAND`, started at collection (or now)."""
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy not installed (it is in the [test] extra)")
    proc = request.config.stash.get(_MYPY_KEY, None)
    if proc is None:
        proc = subprocess.Popen(MYPY_COMMAND, cwd=REPO, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True)
    output, _ = proc.communicate()
    return proc.returncode, output
