"""Shared fixtures: the measured data set beside the project, and simulated FRFs."""

from __future__ import annotations

from pathlib import Path

import pytest

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
