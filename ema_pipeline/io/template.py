"""The commented experiment-file template that ``ema-pipeline init DIR`` writes.

It describes the test of any structure (geometry, DOFs, metadata, two
configurations); the keys are those of :mod:`ema_pipeline.io.experiment`, every
one documented in ``docs/guide/experiment.md``.
"""

from __future__ import annotations

import os
from pathlib import Path

from ema_pipeline.data import ConfigError
from ema_pipeline.io.files import write_text

#: The file name ``init`` writes and ``run --raw DIR`` reads.
EXPERIMENT_FILE = "experiment.toml"

EXPERIMENT_TEMPLATE = """\
# ema-pipeline experiment file: the test of one structure (a plate, a frame, a
# beam, ...). `ema-pipeline run --raw THIS_FOLDER --results OUT` identifies every
# configuration and writes the report: geometry, animated mode shapes, the MAC
# between each configuration's modes and the reference's. Paths are relative
# to this file. Every key and its default: the user guide's "Experiment file".

[experiment]
name = "My structure"          # title of the report
genuine = "reference"          # the reference configuration (default: the first)

[test]                         # what the report says of the test (all optional)
object = "the test object: material, size, boundary conditions"
date = "2026-01-31"
operator = "who measured"
equipment = ["impact hammer (model, sensitivity)", "accelerometer(s)", "acquisition system"]
# description = "free text"

[geometry]                     # the wireframe the modes are animated on
file = "geometry.uff"          # UFF datasets 15 or 2411 (nodes, m) and 82 (trace lines)
# nodes = [[1, 0.0, 0.0, 0.0], [2, 0.1, 0.0, 0.0]]   # or here: [node, x_m, y_m, z_m]
# lines = [[1, 2]]             # trace lines through node numbers (added to the file's)
# surfaces = [[1, 2, 3, 4]]    # optional filled triangles or quads

[dofs]                         # how the test was done
roving = "hammer"              # "hammer": roving hammer, fixed accelerometer(s);
                               # "sensor": roving accelerometers, fixed hammer; "none"
# fixed = ["1+Z"]              # the DOF(s) that stayed put: NODE, sign, axis X/Y/Z
# map = {"101+Z" = "1+Z"}      # file DOF -> geometry DOF where the numbering differs

[identification]               # all optional; see `ema-pipeline identify --help`
# band_hz = [5.0, 1000.0]      # default: the whole axis above the first lines
# max_order = 60               # default: the adaptive order search
# expect_hz = [20.0, 110.0]    # guesses instead of the automatic selection

[[configurations]]             # one per tested state; FRFs as UFF-58 or HDF5
name = "reference"
file = "reference.uff"
description = "the structure as built"

[[configurations]]
name = "modified"
file = "modified.uff"
description = "the structure with the modification"
# exp_window_tau_s = 1.0       # exponential window's time constant, if the file lacks it

# A cantilever beam with added mass (the paper's study): add these tables and `run`
# also computes the FE model, its update and the modal and local added mass
# (without [geometry] the report draws the beam's measurement mesh).
# [beam]
# length_m = 0.65
# width_m = 0.05
# thickness_m = 0.01
# youngs_modulus_pa = 210e9
# density_kg_m3 = 7800.0
# n_elements = 100
# n_measurement_elements = 10
# [sensors]
# response_nodes = [3, 6]
# hammer_node = 8
# [fe]
# immersed_elements = [10]
# n_modes = 4
"""


def write_experiment_template(folder: str | os.PathLike[str], *, force: bool = False) -> Path:
    """Write ``folder/experiment.toml`` from :data:`EXPERIMENT_TEMPLATE` (the
    folder is created); an existing file is kept unless ``force``
    (:class:`ConfigError` naming it).

    Examples
    --------
    >>> import tempfile, tomllib
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_experiment_template(tmp)
    ...     sorted(tomllib.loads(path.read_text()))
    ['configurations', 'dofs', 'experiment', 'geometry', 'identification', 'test']
    """
    path = Path(folder) / EXPERIMENT_FILE
    if path.exists() and not force:
        raise ConfigError(f"{path} exists; give --force to overwrite it")
    if Path(folder).exists() and not Path(folder).is_dir():
        raise ConfigError(f"{folder} is not a folder")
    Path(folder).mkdir(parents=True, exist_ok=True)
    return write_text(EXPERIMENT_TEMPLATE, path)
