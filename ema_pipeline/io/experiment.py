"""The experiment description (TOML, read with ``tomllib``).

See ``raw_frf/experiment.toml`` for a commented example.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ema_pipeline.data import Beam, ConfigurationSpec, DataError, Experiment
from ema_pipeline.identification.options import IdentificationOptions


def _get(table: Mapping[str, Any], key: str, kind: type, path: Path, default: Any = ...) -> Any:
    if key not in table:
        if default is ...:
            raise DataError(f"{path}: missing required key {key!r}")
        return default
    value = table[key]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise DataError(f"{path}: {key!r} must be {kind.__name__}, got {value!r}")
    return value


def read_experiment(path: str | os.PathLike[str]) -> Experiment:
    """Read an experiment description (TOML). See ``raw_frf/experiment.toml``."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: experiment file not found")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not valid TOML ({exc})") from exc
    beam_t = doc.get("beam", {})
    try:
        beam = Beam(
            length_m=_get(beam_t, "length_m", float, path, 0.65),
            width_m=_get(beam_t, "width_m", float, path, 0.05),
            thickness_m=_get(beam_t, "thickness_m", float, path, 0.01),
            youngs_modulus_pa=_get(beam_t, "youngs_modulus_pa", float, path, 210e9),
            density_kg_m3=_get(beam_t, "density_kg_m3", float, path, 7800.0),
            n_elements=_get(beam_t, "n_elements", int, path, 100),
            n_measurement_elements=_get(beam_t, "n_measurement_elements", int, path, 10),
        )
    except DataError as exc:
        raise DataError(f"{path}: [beam] {exc}") from exc
    sensors = doc.get("sensors", {})
    ident = doc.get("identification", {})
    fe = doc.get("fe", {})
    configs = doc.get("configurations", [])
    if not isinstance(configs, list) or not configs:
        raise DataError(f"{path}: needs at least one [[configurations]] entry")
    specs = []
    for k, c in enumerate(configs, start=1):
        if isinstance(c, dict) and "name" in c and "added_mass" in c:
            specs.append(read_simulated_configuration(c, k, beam, path))
            continue
        if not isinstance(c, dict) or "name" not in c or "file" not in c:
            raise DataError(
                f"{path}: configuration {k} needs 'name' and 'file' (or 'added_mass' for a "
                "simulated one)"
            )
        tau = c.get("exp_window_tau_s")
        specs.append(
            ConfigurationSpec(
                name=str(c["name"]),
                file=str(c["file"]),
                description=str(c.get("description", "")),
                exp_window_tau_s=None if tau is None else float(tau),
            )
        )
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise DataError(f"{path}: configuration names repeat: {names}")
    genuine = str(doc.get("experiment", {}).get("genuine", names[0]))
    if genuine not in names:
        raise DataError(f"{path}: genuine configuration {genuine!r} is not among {names}")
    identification = read_identification_options(ident, path)
    n_nodes = beam.n_measurement_elements + 1
    immersed = tuple(int(e) for e in fe.get("immersed_elements", [beam.n_measurement_elements]))
    for e in immersed:
        if not 1 <= e <= beam.n_measurement_elements:
            raise DataError(
                f"{path}: immersed element {e} does not exist (1..{beam.n_measurement_elements})"
            )
    response_nodes = tuple(int(n) for n in sensors.get("response_nodes", [3, 6]))
    hammer = int(sensors.get("hammer_node", 8))
    for node in (*response_nodes, hammer):
        if not 1 <= node <= n_nodes:
            raise DataError(f"{path}: sensor node {node} does not exist (1..{n_nodes})")
    return Experiment(
        name=str(doc.get("experiment", {}).get("name", path.stem)),
        beam=beam,
        configurations=tuple(specs),
        base_dir=str(path.parent),
        genuine=genuine,
        response_nodes=response_nodes,
        hammer_node=hammer,
        direction=int(sensors.get("direction", 3)),
        identification=identification,
        immersed_elements=immersed,
        n_modes=int(fe.get("n_modes", 4)),
        update_repeats=int(fe.get("update_repeats", 5)),
        seed=int(fe.get("seed", 0)),
    )


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
        if isinstance(frac, bool) or not isinstance(frac, int | float) or not frac > -1:
            raise DataError(f"{where}: added_mass of element {el_i} must be a number > -1, "
                            f"got {frac!r}")
        pairs.append((el_i, float(frac)))
    zeta = table.get("zeta_pct")
    if zeta is not None and (
        not isinstance(zeta, list)
        or not all(isinstance(z, int | float) and not isinstance(z, bool) for z in zeta)
    ):
        raise DataError(f"{where}: zeta_pct must be a list of numbers (percent), got {zeta!r}")
    snr = _get(table, "snr_db", float, path, 40.0)
    return ConfigurationSpec(
        name=str(table["name"]),
        file="",
        description=str(table.get("description", "")),
        added_mass=tuple(sorted(pairs)),
        zeta_pct=None if zeta is None else tuple(float(z) for z in zeta),
        snr_db=snr if snr > 0 else None,
        seed=_get(table, "seed", int, path, position),
    )


def read_identification_options(
    table: Mapping[str, Any], path: Path
) -> IdentificationOptions:
    """The ``[identification]`` table as :class:`IdentificationOptions`.

    Keys: ``band_hz`` = [low, high], ``max_order``, ``method``, ``expect_hz`` =
    [f1, ...], ``weighting``, ``tol_freq``, ``tol_zeta``, ``tol_mac``,
    ``min_fraction``, ``refine``, ``lower_residual``, ``upper_residual``; each
    missing key keeps the option's default. (The exponential window's time
    constant is per configuration: ``[[configurations]] exp_window_tau_s``.)
    """
    default = IdentificationOptions()
    band = table.get("band_hz")
    if band is not None and (len(band) != 2 or not float(band[0]) < float(band[1])):
        raise DataError(f"{path}: identification.band_hz must be [low, high], got {band}")
    max_order = table.get("max_order")
    floats = ("tol_freq", "tol_zeta", "tol_mac", "min_fraction")
    flags = ("refine", "lower_residual", "upper_residual")
    return IdentificationOptions(
        band_hz=None if band is None else (float(band[0]), float(band[1])),
        max_order=None if max_order is None else int(max_order),
        method=str(table.get("method", default.method)),  # type: ignore[arg-type]
        expect_hz=tuple(float(f) for f in table.get("expect_hz", [])),
        weighting=_get(table, "weighting", str, path, default.weighting),
        **{key: _get(table, key, float, path, getattr(default, key)) for key in floats},
        **{key: _get(table, key, bool, path, getattr(default, key)) for key in flags},
    )


def experiment_file_path(experiment: Experiment, spec: ConfigurationSpec) -> Path:
    """Absolute path of a configuration's FRF file (relative to the experiment file)."""
    p = Path(spec.file)
    return p if p.is_absolute() else Path(experiment.base_dir) / p
