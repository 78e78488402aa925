"""Shared fixtures: the measured data set beside the project, and simulated FRFs."""

from __future__ import annotations

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
