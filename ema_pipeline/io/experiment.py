"""The experiment description (TOML, read with ``tomllib``), checked against a typed schema.

See ``raw_frf/experiment.toml`` for a commented example.

:func:`read_experiment` validates the whole file before anything else runs:
every table and key against :data:`SCHEMA` (unknown keys are errors, with a
"did you mean" hint from :mod:`difflib`), every value's type (``3.7`` is not a
node number, ``true`` is not a number) and range, configuration names from a
safe character set (they become file names and report text), and every
referenced FRF file present, a regular file and readable (``stat`` only: a
FIFO or a device is refused without being opened). Every problem is one
:class:`~ema_pipeline.data.DataError` line naming the file and the key
(``experiment.toml: [identification] band_hz: ...``).

The schema is a small table of rules (:mod:`ema_pipeline.validation`: a
number in a range, an integer, a list, a choice ...; the identification
options' own rules, :func:`~ema_pipeline.identification.options.check_option`;
the settings of ``ema-pipeline frf``,
:data:`~ema_pipeline.acquisition.frf_settings.FRF_SETTING_RULES`) rather than
a schema library (jsonschema, pydantic): none is a dependency, and the checks
that matter (node ranges from the beam, names that are safe file names, the
"did you mean" hint) are project-specific anyway.
"""

from __future__ import annotations

import difflib
import os
import re
from collections.abc import Mapping
from dataclasses import fields
from functools import partial
from pathlib import Path
from typing import Any

from ema_pipeline.acquisition import noise_snr_db
from ema_pipeline.acquisition.frf_settings import FRF_SETTING_RULES
from ema_pipeline.data import DOF, Beam, DataError, OptionError
from ema_pipeline.experiment import ConfigurationSpec, Experiment
from ema_pipeline.identification.options import IdentificationOptions, check_option
from ema_pipeline.io.channel_sheet import (
    ChannelSheet,
    channel_sheet_from_rows,
    read_channel_sheet,
)
from ema_pipeline.io.files import check_readable, read_toml
from ema_pipeline.io.geometry import geometry_from_table
from ema_pipeline.validation import (
    Rule,
    choice,
    integer,
    nonzero,
    number,
    refusal,
    sequence,
    text,
)

#: Configuration names: letters, digits, ``_-.``, no leading dot, at most 64 characters.
SAFE_NAME = re.compile(r"[A-Za-z0-9_\-][A-Za-z0-9_\-.]{0,63}")
#: The fields of :class:`IdentificationOptions` the ``[identification]`` table
#: may set (the window's time constant is per configuration; the tuned
#: thresholds are for studies of the method, in Python; the memory limit is the
#: machine's: ``run --memory-limit-gb``).
IDENTIFICATION_KEYS = tuple(f.name for f in fields(IdentificationOptions)
                            if f.name not in ("exp_window_tau_s", "thresholds",
                                              "memory_limit_gb"))

def name_is_safe(name: str) -> bool:
    """Whether ``name`` may be a configuration name (it becomes part of file names).

    Examples
    --------
    >>> [name_is_safe(n) for n in ("larger_tank", "run-2.b", "../x", ".hidden", "a/b", "")]
    [True, True, False, False, False, False]
    """
    return bool(SAFE_NAME.fullmatch(name))


def _name(name: str, v: Any) -> str:
    if not name_is_safe(text(name, v)):
        raise OptionError(name, f"{v!r} is not a safe name: use 1-64 letters, digits, '_', "
                                "'-', '.', not starting with a dot")
    return v


def _direction(name: str, v: Any) -> int:
    if integer(name, v, at_least=-3, at_most=3) == 0:
        raise refusal(name, "1, 2 or 3 (x, y, z; negative: minus)", v)
    return v


_AXES = {"X": 1, "Y": 2, "Z": 3, "1": 1, "2": 2, "3": 3}
_DOF_LABEL = re.compile(r"\s*(\d+)\s*([+-]?)\s*([XYZxyz123])\s*")


def dof_from_label(name: str, v: Any) -> DOF:
    """A DOF from its label: node, sign, axis (``"3-Z"``, ``"12+X"``, ``"7Y"``);
    another value is an :class:`~ema_pipeline.data.OptionError` naming ``name``.

    Examples
    --------
    >>> dof_from_label("fixed", "3-Z").label(), dof_from_label("fixed", "12x").label()
    ('3-Z', '12+X')
    """
    match = _DOF_LABEL.fullmatch(text(name, v))
    if not match:
        raise refusal(name, "a DOF label NODE+AXIS such as '3-Z' or '12+X'", v)
    node, sign, axis = match.groups()
    return DOF(int(node), (-1 if sign == "-" else 1) * _AXES[axis.upper()])


def _text_or_list(name: str, v: Any) -> str:
    if isinstance(v, list):
        return "; ".join(sequence(name, v, item=text))
    return text(name, v)


def _table(value: Rule, key: Rule, shape: str) -> Rule:
    """The rule of a TOML table ``{KEY = VALUE, ...}`` (``shape`` as the message
    shows it): (key, value) pairs, each checked; a bad one is named by its key."""
    def check(name: str, v: Any) -> tuple[tuple[Any, Any], ...]:
        if not isinstance(v, dict):
            raise refusal(name, f"a table {shape}", v)
        out = []
        for k, x in v.items():
            try:
                out.append((key(name, k), value(name, x)))
            except OptionError as exc:
                raise OptionError(name, f"{k}: {exc.reason}") from None
        return tuple(out)

    return check


def _given(name: str, v: Any) -> Any:
    """Any value: checked later, with what it refers to."""
    return v


#: table -> key -> rule. ``configurations`` entries are checked per entry.
SCHEMA: dict[str, dict[str, Rule]] = {
    "experiment": {"name": text, "genuine": text},
    "test": {
        "object": text,
        "date": lambda name, v: str(v) if not isinstance(v, bool | int | float | list | dict)
        else text(name, v),
        "operator": text,
        "equipment": _text_or_list,
        "description": text,
    },
    "dofs": {
        "roving": partial(choice, names=("hammer", "sensor", "none")),
        "fixed": partial(sequence, item=dof_from_label, min_len=1, max_len=1000),
        "map": _table(dof_from_label, dof_from_label, '{"FILE_DOF" = "GEOMETRY_DOF", ...}'),
    },
    "beam": {
        "length_m": partial(number, above=0.0, at_most=1e3),
        "width_m": partial(number, above=0.0, at_most=1e2),
        "thickness_m": partial(number, above=0.0, at_most=1e2),
        "youngs_modulus_pa": partial(number, above=0.0, at_most=1e13),
        "density_kg_m3": partial(number, above=0.0, at_most=1e5),
        "n_elements": partial(integer, at_least=1, at_most=10_000),
        "n_measurement_elements": partial(integer, at_least=1, at_most=1_000),
    },
    "sensors": {
        "response_nodes": partial(sequence, item=integer, min_len=1, max_len=1000),
        "hammer_node": integer,
        "direction": _direction,
    },
    # the options' own rules (one home: IdentificationOptions)
    "identification": {name: check_option for name in IDENTIFICATION_KEYS},
    "fe": {
        "immersed_elements": partial(sequence, item=integer, min_len=1, max_len=1000),
        "n_modes": partial(integer, at_least=1, at_most=50),
        "update_repeats": partial(integer, at_least=1, at_most=1000),
        "seed": partial(integer, at_least=0, at_most=2**32 - 1),
    },
}


#: keys of a ``[[configurations]]`` entry read from a file / simulated on the FE beam.
FILE_CONFIGURATION: dict[str, Rule] = {
    "name": _name,
    "file": text,
    "description": text,
    "exp_window_tau_s": check_option,
}
SIMULATED_CONFIGURATION: dict[str, Rule] = {
    "name": _name,
    "added_mass": _given,  # checked with the beam below
    "description": text,
    "zeta_pct": partial(sequence, item=partial(number, above=0.0, at_most=100.0), min_len=1,
                        max_len=100),
    "snr_db": partial(number, at_most=400.0),
    "seed": partial(integer, at_least=0, at_most=2**32 - 1),
}


def _recording_files(name: str, v: Any) -> tuple[str, ...]:
    if isinstance(v, str):
        return (v,)
    return sequence(name, v, item=text, min_len=1, max_len=1000)


def _channel(name: str, key: Any) -> str:
    return str(key)


#: keys of a ``[[configurations]]`` entry that names raw impact recordings.
RECORDING_CONFIGURATION: dict[str, Rule] = {
    "name": _name,
    "recording": _recording_files,
    "description": text,
    "frf": _given,  # checked against FRF_SETTINGS
}
#: keys of its ``frf`` table: the settings of ``ema-pipeline frf``
#: (:data:`~ema_pipeline.acquisition.frf_settings.FRF_SETTING_RULES`) and the reader's.
FRF_SETTINGS: dict[str, Rule] = {
    **FRF_SETTING_RULES,
    "force_channel": text,
    "scale": _table(nonzero, _channel, "{CHANNEL = VALUE, ...}"),
    "units": _table(text, _channel, "{CHANNEL = VALUE, ...}"),
}


def read_recording_configuration(
    table: Mapping[str, Any], position: int, path: Path
) -> ConfigurationSpec:
    """A ``[[configurations]]`` entry with ``recording`` (a file, or a list of files:
    segments of one test) instead of an FRF file, and an optional ``frf`` table
    (:data:`FRF_SETTINGS`: ``pretrigger_s``, ``record_length_s``, ``force_window_s``,
    ``exp_window_tau`` = "auto" | "none" | seconds, ``estimator``, ``keep_all``,
    ``force_channel``, ``scale`` = {CHANNEL = FACTOR}, ``units`` = {CHANNEL = UNIT}).
    """
    where = f"{path}: [[configurations]] {position}"
    for other in ("file", "added_mass"):
        if other in table:
            raise DataError(f"{where}: give either 'recording' or '{other}', not both")
    entry = _check_table(table, RECORDING_CONFIGURATION, where)
    settings = _check_table(table.get("frf", {}), FRF_SETTINGS, f"{where} frf:")
    files = entry["recording"]
    return ConfigurationSpec(
        name=entry["name"],
        file=files[0],
        description=entry.get("description", ""),
        recording=files,
        frf=tuple(settings.items()),
    )


#: keys of a ``[[configurations]]`` entry (or of the ``[recordings]`` table) that
#: names a channel sheet: a roving test from many recordings.
SHEET_CONFIGURATION: dict[str, Rule] = {
    "name": _name,
    "channels": _given,  # a file name or inline rows, checked below
    "description": text,
    "frf": _given,  # checked against FRF_SETTINGS
}
#: Settings of FRF_SETTINGS that a channel sheet gives itself.
_SHEET_GIVES = ("force_channel", "scale", "units")


def read_sheet_configuration(
    table: Mapping[str, Any], where: str, path: Path, default_name: str | None = None
) -> ConfigurationSpec:
    """A configuration whose recordings a channel sheet names: ``channels`` = the
    sheet's file (relative to the experiment file) or its rows inline (a list of
    tables with the sheet's columns, :func:`ema_pipeline.io.channel_sheet.
    channel_sheet_from_rows`), an optional ``frf`` table (:data:`FRF_SETTINGS`
    but ``force_channel``, ``scale`` and ``units``, which the sheet gives)."""
    for other in ("file", "added_mass", "recording"):
        if other in table:
            raise DataError(f"{where}: give either 'channels' or '{other}', not both")
    if default_name is not None and "name" not in table:
        table = {**table, "name": default_name}
    entry = _check_table(table, SHEET_CONFIGURATION, where, required=("name",))
    settings = _check_table(table.get("frf", {}), FRF_SETTINGS, f"{where} frf:")
    given = [k for k in _SHEET_GIVES if k in settings]
    if given:
        raise DataError(f"{where} frf: {', '.join(given)}: the channel sheet gives the force "
                        "channel, scales and units (its role, scale and unit columns)")
    channels = entry["channels"]
    sheet = ""
    rows: tuple[tuple[tuple[str, Any], ...], ...] = ()
    if isinstance(channels, str) and channels.strip():
        sheet = channels
    elif isinstance(channels, list) and channels:
        channel_sheet_from_rows(channels, path.parent, f"{where} channels")  # checked now
        rows = tuple(tuple((str(k), v) for k, v in row.items()) for row in channels)
    else:
        raise DataError(f"{where} channels: must be a channel sheet's file name or a list of "
                        f"its rows (tables with file, channel, role, node, direction, scale, "
                        f"unit), got {channels!r}")
    return ConfigurationSpec(
        name=entry["name"], file=sheet or path.name, description=entry.get("description", ""),
        recording=(sheet or path.name,), frf=tuple(settings.items()), channels=sheet,
        channel_rows=rows,
    )


def _hint(key: str, known: list[str]) -> str:
    close = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(known)})"


def _check_table(
    table: Any, schema: Mapping[str, Rule], where: str, required: tuple[str, ...] = ()
) -> dict[str, Any]:
    """The keys of ``table`` checked against ``schema`` (normalised values)."""
    if not isinstance(table, dict):
        raise DataError(f"{where}: must be a table, got {table!r}")
    for key in table:
        if key not in schema:
            raise DataError(f"{where} {key}: unknown key{_hint(key, list(schema))}")
    for key in required:
        if key not in table:
            raise DataError(f"{where}: missing required key {key!r}")
    out = {}
    for key, value in table.items():
        try:
            out[key] = schema[key](key, value)
        except OptionError as exc:
            raise DataError(f"{where} {key}: {exc.reason}") from None
    return out


def read_experiment(path: str | os.PathLike[str], *, check_files: bool = True) -> Experiment:
    """Read and validate an experiment description (TOML). See ``raw_frf/experiment.toml``.

    ``check_files=False`` skips the check that every referenced FRF file is a
    readable regular file. Raises :class:`~ema_pipeline.data.DataError` (one
    line naming the file and the key) on any problem.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     toml = pathlib.Path(tmp) / "experiment.toml"
    ...     _ = toml.write_text('[identification]\\nbandhz = [5, 400]\\n')
    ...     read_experiment(toml)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: ...[identification] bandhz: unknown key (did you mean 'band_hz'?)
    """
    path = Path(path)
    doc = read_toml(path, "an experiment file (TOML)")
    known = [*SCHEMA, "configurations", "geometry", "recordings"]
    for key in doc:
        if key not in known:
            raise DataError(f"{path}: [{key}]: unknown table{_hint(key, known)}")
    t = {name: _check_table(doc.get(name, {}), schema, f"{path}: [{name}]")
         for name, schema in SCHEMA.items()}
    try:
        beam = Beam(**t["beam"])
    except DataError as exc:
        raise DataError(f"{path}: [beam] {exc}") from exc
    configs = doc.get("configurations", [])
    specs = []
    if "recordings" in doc:  # [recordings] channels = "channels.csv": one roving test
        if not isinstance(doc["recordings"], dict):
            raise DataError(f"{path}: [recordings] must be a table")
        if "channels" not in doc["recordings"]:
            raise DataError(f"{path}: [recordings]: missing required key 'channels' (the "
                            "channel sheet, e.g. channels = \"channels.csv\")")
        specs.append(read_sheet_configuration(doc["recordings"], f"{path}: [recordings]", path,
                                              default_name="test"))
    if not isinstance(configs, list) or not (configs or specs):
        raise DataError(f"{path}: needs at least one [[configurations]] entry (or a "
                        "[recordings] table with a channel sheet)")
    for k, c in enumerate(configs, start=1):
        where = f"{path}: [[configurations]] {k}"
        if isinstance(c, dict) and "name" in c and "channels" in c:
            specs.append(read_sheet_configuration(c, where, path))
            continue
        if isinstance(c, dict) and "name" in c and "recording" in c:
            specs.append(read_recording_configuration(c, k, path))
            continue
        if isinstance(c, dict) and "name" in c and "added_mass" in c:
            specs.append(read_simulated_configuration(c, k, beam, path))
            continue
        if not isinstance(c, dict) or "name" not in c or "file" not in c:
            raise DataError(
                f"{where}: configuration {k} needs 'name' and 'file' (or 'added_mass' for a "
                "simulated one, 'recording' for raw impact recordings)"
            )
        entry = _check_table(c, FILE_CONFIGURATION, where)
        specs.append(
            ConfigurationSpec(
                name=entry["name"],
                file=entry["file"],
                description=entry.get("description", ""),
                exp_window_tau_s=entry.get("exp_window_tau_s"),
            )
        )
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise DataError(f"{path}: [[configurations]] name: names repeat: {names}")
    genuine = t["experiment"].get("genuine", names[0])
    if genuine not in names:
        raise DataError(
            f"{path}: [experiment] genuine: genuine configuration {genuine!r} is not among {names}"
        )
    # a file with a [geometry] and no [beam] describes some other structure: no
    # FE model, update or added mass (beam defaults stay for the types only)
    has_beam = "beam" in doc or "geometry" not in doc
    if not has_beam:
        for table in ("fe",):  # [sensors] may place a recording's channels on any structure
            if table in doc:
                raise DataError(f"{path}: [{table}] describes the beam's test: it needs a "
                                "[beam] table (this file has a [geometry] and no [beam])")
        for spec in specs:
            if spec.added_mass is not None:
                raise DataError(f"{path}: configuration {spec.name!r} is simulated on the FE "
                                "beam (added_mass): it needs a [beam] table")
    n_nodes = beam.n_measurement_elements + 1
    fe = t["fe"]
    immersed = fe.get("immersed_elements", (beam.n_measurement_elements,))
    for e in immersed:
        if not 1 <= e <= beam.n_measurement_elements:
            raise DataError(
                f"{path}: [fe] immersed_elements: immersed element {e} does not exist "
                f"(1..{beam.n_measurement_elements})"
            )
    sensors = t["sensors"]
    response_nodes = sensors.get("response_nodes", (3, 6))
    hammer = sensors.get("hammer_node", 8)
    for key, nodes in (("response_nodes", response_nodes), ("hammer_node", (hammer,))):
        for node in nodes:
            if not 1 <= node <= (n_nodes if has_beam else 10**9):
                raise DataError(
                    f"{path}: [sensors] {key}: sensor node {node} does not exist (1..{n_nodes})"
                )
    if len(set(response_nodes)) != len(response_nodes):
        raise DataError(f"{path}: [sensors] response_nodes: nodes repeat: {list(response_nodes)}")
    geometry = None
    if "geometry" in doc:  # nodes, trace lines, surfaces (io.geometry.geometry_from_table)
        if not isinstance(doc["geometry"], dict):
            raise DataError(f"{path}: [geometry] must be a table")
        geometry = geometry_from_table(doc["geometry"], str(path), path.parent)
    experiment = Experiment(
        geometry=geometry,
        name=t["experiment"].get("name", path.stem),
        beam=beam,
        configurations=tuple(specs),
        base_dir=str(path.parent),
        genuine=genuine,
        response_nodes=tuple(response_nodes),
        hammer_node=hammer,
        direction=sensors.get("direction", 3),
        identification=read_identification_options(doc.get("identification", {}), path),
        immersed_elements=tuple(immersed),
        n_modes=fe.get("n_modes", 4),
        update_repeats=fe.get("update_repeats", 5),
        seed=fe.get("seed", 0),
        has_beam=has_beam,
        test=tuple((k, str(v)) for k, v in t["test"].items()),
        roving=t["dofs"].get("roving", ""),
        fixed_dofs=tuple(t["dofs"].get("fixed", ())),
        dof_map=tuple(t["dofs"].get("map", ())),
    )
    if check_files:
        for k, spec in enumerate(specs, start=1):
            if spec.channels:  # the sheet and every file it names
                try:
                    for file in read_channel_sheet(Path(path.parent) / spec.channels).files():
                        check_readable(file, "a recording")
                except DataError as exc:
                    raise DataError(f"{path}: configuration {spec.name!r} channels: {exc}") \
                        from None
            elif spec.channel_rows:
                pass  # inline rows: their files are checked when read
            elif spec.recording:
                for file in experiment_recording_paths(experiment, spec):
                    try:
                        check_readable(file, "a recording")
                    except DataError as exc:
                        raise DataError(
                            f"{path}: [[configurations]] {k} recording ({spec.name}): {exc}"
                        ) from None
            elif spec.added_mass is None:
                try:
                    check_readable(experiment_file_path(experiment, spec), "an FRF file")
                except DataError as exc:
                    raise DataError(
                        f"{path}: [[configurations]] {k} file ({spec.name}): {exc}"
                    ) from None
    return experiment


def read_simulated_configuration(
    table: Mapping[str, Any], position: int, beam: Beam, path: Path
) -> ConfigurationSpec:
    """A ``[[configurations]]`` entry simulated on the FE beam (no ``file``).

    Keys: ``name``; ``added_mass`` = {ELEMENT = FRACTION, ...} (measurement
    element, 1-based, tip = n: extra mass as a fraction of the element's mass;
    ``{}`` is the genuine beam); optional ``zeta_pct`` = [damping of the lowest
    modes in percent] (default: the paper's genuine damping), ``snr_db``
    (default 40; 0 = noise-free), ``seed`` (default: the entry's 1-based
    ``position`` in the file), ``description``.
    """
    where = f"{path}: configuration {position} ({table.get('name')!r})"
    if "file" in table:
        raise DataError(f"{where}: give either 'file' or 'added_mass', not both")
    entry = _check_table(table, SIMULATED_CONFIGURATION, where)
    added = table["added_mass"]
    if not isinstance(added, dict):
        raise DataError(f"{where}: added_mass must be a table such as {{10 = 0.3}}, got {added!r}")
    pairs = []
    for el, frac in added.items():
        try:
            el_i = int(el)
        except ValueError:
            raise DataError(f"{where}: added_mass key {el!r} is not an element number") from None
        if not 1 <= el_i <= beam.n_measurement_elements:
            raise DataError(
                f"{where}: added_mass element {el_i} does not exist "
                f"(1..{beam.n_measurement_elements})"
            )
        try:
            pairs.append((el_i, number(f"added_mass of element {el_i}", frac, above=-1.0,
                                       at_most=1e3)))
        except OptionError as exc:
            raise DataError(f"{where}: {exc}") from None
    snr = entry.get("snr_db", 40.0)
    zeta = entry.get("zeta_pct")
    return ConfigurationSpec(
        name=entry["name"],
        file="",
        description=entry.get("description", ""),
        added_mass=tuple(sorted(pairs)),
        zeta_pct=zeta,
        snr_db=noise_snr_db(snr),  # 0: noise-free, as for simulate --snr-db
        seed=entry.get("seed", position),
    )


def read_identification_options(
    table: Mapping[str, Any], path: Path
) -> IdentificationOptions:
    """The ``[identification]`` table as :class:`IdentificationOptions`.

    Keys: ``band_hz`` = [low, high], ``max_order``, ``method``, ``expect_hz`` =
    [f1, ...], ``weighting``, ``tol_freq``, ``tol_zeta``, ``tol_mac``,
    ``min_fraction``, ``refine``, ``lower_residual``, ``upper_residual``,
    ``window_searches``; each missing key keeps the option's default. (The
    exponential window's time constant is per configuration:
    ``[[configurations]] exp_window_tau_s``.) Every value is checked by the
    rule of its field (:func:`~ema_pipeline.identification.options.check_option`),
    and the options as a whole (``max_order`` at least the method's minimum)
    by :class:`IdentificationOptions`; a refusal is a DataError naming the
    file, the table and the key.
    """
    where = f"{path}: [identification]"
    values = _check_table(table, SCHEMA["identification"], where)
    try:
        return IdentificationOptions(**values)
    except OptionError as exc:
        raise DataError(f"{where} {exc.field}: {exc.reason}") from None


def experiment_file_path(experiment: Experiment, spec: ConfigurationSpec) -> Path:
    """Absolute path of a configuration's FRF file (relative to the experiment file)."""
    p = Path(spec.file)
    return p if p.is_absolute() else Path(experiment.base_dir) / p


def experiment_recording_paths(experiment: Experiment, spec: ConfigurationSpec) -> list[Path]:
    """Absolute paths of a recorded configuration's files (relative to the experiment
    file); empty for other configurations."""
    return [p if p.is_absolute() else Path(experiment.base_dir) / p
            for p in map(Path, spec.recording)]


def experiment_channel_sheet(experiment: Experiment, spec: ConfigurationSpec) -> ChannelSheet:
    """The channel sheet of a configuration that names one (``channels`` file,
    relative to the experiment file, or inline ``channel_rows``)."""
    if spec.channels:
        p = Path(spec.channels)
        return read_channel_sheet(p if p.is_absolute() else Path(experiment.base_dir) / p)
    rows = [dict(row) for row in spec.channel_rows]
    return channel_sheet_from_rows(rows, experiment.base_dir,
                                   str(Path(experiment.base_dir) / "experiment file"))
