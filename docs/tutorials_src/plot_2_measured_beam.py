"""
The measured beam
=================

A roving-hammer test of a free beam (30 hammer positions, one accelerometer),
``../shared/data/ufsc-beam-hammer.uff`` beside the repository. Where that folder
is absent (a clone on its own), this page says so and shows nothing else.
"""

# %%
from pathlib import Path

from ema_pipeline import io
from ema_pipeline.identification import IdentificationOptions, identify, modes_table

repo = Path.cwd()  # the repository: the folder that holds raw_frf/
while not (repo / "raw_frf").is_dir() and repo != repo.parent:
    repo = repo.parent
path = repo.parent / "shared" / "data" / "ufsc-beam-hammer.uff"
if not path.is_file():
    path = None
if path is None:
    print("../shared/data/ufsc-beam-hammer.uff is absent here: this tutorial is skipped.")

# %%
# Reciprocity turns 30 references and one response into one reference and 30
# responses, which keeps the poly-reference model small (``identify`` on the
# command line does it by itself). A band of 100-400 Hz keeps the example fast;
# the whole band is identified in ``tests/test_identification_real.py``.
if path is not None:
    roving = io.read_frf(path).reciprocal()
    print(roving)
    result = identify(roving, IdentificationOptions(band_hz=(100.0, 400.0)))
    print(modes_table(result)[["mode", "fn_hz", "zeta_pct", "mpc", "doubtful"]])
    print("resonances not kept (Hz):", [round(float(f), 1) for f in result.not_kept_hz])
