"""Where the suite finds its data: the repository, and the measured data beside it
in ``../shared/data`` (read only; tests that need a file skip where it is absent)."""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
#: The measured roving-hammer test of the UFSC beam.
REAL_UFF = SHARED_DATA / "ufsc-beam-hammer.uff"
#: pyFRF's showcase recording (five hits, LGPL-3.0; ../shared/data/README.md).
PYFRF_UFF = SHARED_DATA / "pyfrf-impact.uff"
#: Three of pyuff's public test files, with pyuff's MIT licence.
PYUFF_DIR = SHARED_DATA / "pyuff"
#: The measured beam's geometry (examples/make_ufsc_geometry.py).
BEAM_GEOMETRY = REPO / "examples" / "ufsc-beam-geometry.uff"
#: The sensor nodes of the three-sensor test (``three_sensor_h5`` in conftest.py;
#: the shipped example has two).
THREE_SENSORS = (3, 6, 9)
