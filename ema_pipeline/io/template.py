"""The commented experiment-file template that ``ema-pipeline init DIR`` writes,
and the example study's experiment file that ``init DIR --example`` writes.

The template describes the test of any structure (geometry, DOFs, metadata, two
configurations); the keys are those of :mod:`ema_pipeline.io.experiment`, every
one documented in ``docs/guide/experiment.md``. The example's experiment file
(the paper's cantilever, three configurations) is package data,
``example_experiment.toml``, the same file as the repository's
``raw_frf/experiment.toml``.
"""

from __future__ import annotations

import os
import tomllib
from importlib import resources
from pathlib import Path

from ema_pipeline.data import ConfigError, DataError
from ema_pipeline.io.channel_sheet import write_channel_sheet
from ema_pipeline.io.files import write_text
from ema_pipeline.io.recording import is_recording, recording_channels
from ema_pipeline.units import parse_unit_label

#: The channel sheet ``init --recordings`` writes beside the experiment file.
CHANNEL_SHEET_FILE = "channels.csv"

#: The file name ``init`` writes and ``run --raw DIR`` reads.
EXPERIMENT_FILE = "experiment.toml"


def example_experiment() -> tuple[str, dict[str, str]]:
    """The example study's experiment file: its text, and the FRF file name of
    each configuration in the file's order.

    Examples
    --------
    >>> text, files = example_experiment()
    >>> files
    {'genuine': 'genuine.uff', 'larger_tank': 'larger_tank.h5', 'smaller_tank': 'smaller_tank.uff'}
    """
    text = (resources.files("ema_pipeline.io") / "example_experiment.toml").read_text(
        encoding="utf-8")
    return text, {c["name"]: c["file"] for c in tomllib.loads(text)["configurations"]}

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


#: What replaces the ``[[configurations]]`` of the template when ``init --recordings``
#: writes a channel sheet: one roving test from the recordings it names.
RECORDINGS_TEMPLATE = """\
[recordings]                   # a roving test: every file of the channel sheet is one point
channels = "channels.csv"      # file,channel,role,node,direction,scale,unit: complete it
name = "test"                  # the configuration's name in the report
# [recordings.frf]             # settings of `ema-pipeline frf` (defaults shown)
# pretrigger_s = 0.01
# exp_window_tau = "auto"
"""

_SHEET_HELP = """\
Channel sheet written by `ema-pipeline init --recordings`: one row per channel per file.
Complete node (a whole number >= 1, the geometry's node) and direction (+X .. -Z) of
every row; check role (force or response, one force per file), unit (after scaling:
N, kN, g, m/s^2, ...; blank: the file's) and scale (multiplies the stored numbers;
integer WAV samples are fractions of full scale). channel: the name in the file, or
its 0-based position. Delete the rows of channels you do not use."""


def _role(name: str, unit: str) -> str:
    try:
        if parse_unit_label(unit).signal == "force":
            return "force"
    except ValueError:
        pass
    return "force" if any(w in name.lower() for w in ("force", "hammer")) else "response"


def write_channel_template(
    folder: str | os.PathLike[str], recordings: str | os.PathLike[str], *, force: bool = False
) -> tuple[Path, int]:
    """Write ``folder/channels.csv``, a channel-sheet template with one row per
    channel of every recording under ``recordings`` (found by
    :func:`ema_pipeline.io.recording.is_recording`, sorted): file (relative to
    ``folder``), channel name, role (force when in a force unit or named force or
    hammer; else, when nothing tells, the first channel), the unit the file gives;
    node and direction blank for the engineer (the DOF of a UFF channel filled in).
    Returns the path and the number of files. An existing sheet is kept unless
    ``force``; no recording is a ConfigError."""
    folder, recordings = Path(folder), Path(recordings)
    path = folder / CHANNEL_SHEET_FILE
    if path.exists() and not force:
        raise ConfigError(f"{path} exists; give --force to overwrite it")
    if not recordings.is_dir():
        raise ConfigError(f"{recordings}: --recordings must be a folder of recordings")
    files = sorted(p for p in recordings.rglob("*") if p.is_file() and not p.name.startswith(".")
                   and p.resolve() != path.resolve() and is_recording(p))
    if not files:
        raise ConfigError(f"{recordings}: no recording found (CSV with a time column, WAV, "
                          "TDMS, UFF-58 time records)")
    rows = []
    for file in files:
        try:
            channels = recording_channels(file)
        except DataError as exc:
            raise ConfigError(f"--recordings: {exc}") from None
        rel = Path(os.path.relpath(file.absolute(), folder.absolute())).as_posix()
        roles = [_role(name, unit) for name, unit, _ in channels]
        if "force" not in roles:  # nothing tells (WAV): the hammer on the first channel
            roles[0] = "force"
        for (name, unit, dof), role in zip(channels, roles, strict=True):
            node, direction = (dof[:-2], dof[-2:]) if dof else ("", "")
            rows.append({"file": rel, "channel": name, "role": role,
                         "node": node, "direction": direction, "scale": "", "unit": unit})
    folder.mkdir(parents=True, exist_ok=True)
    return write_channel_sheet(rows, path, _SHEET_HELP), len(files)


def write_experiment_template(folder: str | os.PathLike[str], *, force: bool = False,
                              recordings: bool = False) -> Path:
    """Write ``folder/experiment.toml`` from :data:`EXPERIMENT_TEMPLATE` (the
    folder is created; ``recordings``: with :data:`RECORDINGS_TEMPLATE`, the channel
    sheet's test, instead of the two configurations); an existing file is kept unless
    ``force``
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
    text = EXPERIMENT_TEMPLATE
    if recordings:  # the channel sheet's test instead of two FRF files
        start = text.index("[[configurations]]")
        end = text.index("# A cantilever beam")
        text = text[:start] + RECORDINGS_TEMPLATE + "\n" + text[end:]
        text = text.replace('genuine = "reference"', 'genuine = "test"  ')
    return write_text(text, path)
