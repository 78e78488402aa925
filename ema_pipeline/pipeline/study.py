"""The whole study of an experiment: ``ema-pipeline run``.

Driven entirely by the experiment file (``raw_frf/experiment.toml``): read each
configuration's FRFs, identify its modes (Table 1), compute the modal added mass
(Table 2), run the FE stage (Tables 3-6) and write tables, the HDF5 store, the
Markdown/HTML report and its figures.

Failures are collected, not raised: a missing FRF file, an unknown
configuration or too few identified modes becomes a *problem* that is printed
and written into the report, and everything that can still be computed is.
Inputs are validated before anything is computed or written
(:func:`prepare_study`): the experiment file against its schema, every FRF
file read and checked (sensor DOFs, band, orders, window, memory estimate); any
problem there is an input error (exit 2) and nothing is written.

Results are never lost. The results folder is written into a fresh sibling
folder ``.NAME.partial-PID-XXXX`` and swapped in only when complete
(:func:`ema_pipeline.io.swap_in`): with Linux ``renameat2(RENAME_EXCHANGE)`` the old and the new
folder trade places in one atomic step, then the old one is removed; where
that call is unavailable, two renames (old -> ``.NAME.old-PID``, new -> NAME)
and a killed run's backup is put back by the next run. A failure anywhere
(settings, inputs, a full disk) leaves an existing results folder
byte-identical; a run whose study has *problems* (exit 1) writes its incomplete
results only when there is no earlier results folder to lose. Partial folders
of killed runs (their process is gone) are removed by the next run
(:func:`ema_pipeline.io.remove_stale_partials`). The numbers are reproducible (fixed seeds, no
time stamps in the outputs).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ema_pipeline import io, paper
from ema_pipeline.data import (
    DOF,
    ConfigError,
    DataError,
    EMAError,
    FRFSet,
    ModalParameters,
)
from ema_pipeline.experiment import ConfigurationSpec, Experiment
from ema_pipeline.identification import identify
from ema_pipeline.identification.common import single_reference
from ema_pipeline.identification.diagram.narrower_searches import searches_turned_off
from ema_pipeline.identification.diagram.resources import check_identification
from ema_pipeline.io.experiment import experiment_channel_sheet, experiment_recording_paths
from ema_pipeline.pipeline.frf import FRFSettings, configuration_frf
from ema_pipeline.pipeline.roving import sheet_frf
from ema_pipeline.pipeline.simulate import simulate_configuration
from ema_pipeline.pipeline.single import load_frf, write_result_uff
from ema_pipeline.report.wording import plural

Progress = Callable[[str], None]


@dataclass
class StudyResult:
    """Everything ``run`` computed, plus the problems met on the way."""

    experiment: Experiment
    frfs: dict[str, FRFSet] = field(default_factory=dict)
    identification: dict[str, Any] = field(default_factory=dict)
    measured: dict[str, ModalParameters] = field(default_factory=dict)
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    fe: Any = None
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)
    hits: dict[str, pd.DataFrame] = field(default_factory=dict)  # recorded configurations

    @property
    def ok(self) -> bool:
        return not self.problems


def load_experiment(path: str | os.PathLike[str]) -> Experiment:
    """Read the experiment file; an unreadable one is a configuration error (exit 2)."""
    try:
        return io.read_experiment(path)
    except DataError as exc:
        raise ConfigError(str(exc)) from exc


def table1(measured: dict[str, ModalParameters]) -> pd.DataFrame:
    """Table 1 in long form: configuration, mode, fd_hz, zeta_pct (+ fn and std)."""
    rows = []
    for name, m in measured.items():
        for k in range(m.n_modes):
            rows.append(
                {
                    "configuration": name,
                    "mode": k + 1,
                    "fd_hz": m.fd_hz[k],
                    "zeta_pct": 100 * m.zeta[k],
                    "fn_hz": m.fn_hz[k],
                    "fn_std_hz": m.fn_std_hz[k],
                    "zeta_std_pct": 100 * m.zeta_std[k],
                }
            )
    columns = ["configuration", "mode", "fd_hz", "zeta_pct", "fn_hz", "fn_std_hz", "zeta_std_pct"]
    return pd.DataFrame(rows, columns=columns)


def _check_sensors(exp: Experiment, frf: FRFSet, path: Path, experiment_file: str) -> None:
    """The FRF file's DOFs must be the experiment's sensors (or, after reciprocity
    of a roving-hammer set, the other way round)."""
    resp = sorted({d.node for d in frf.response_dofs})
    ref = sorted({d.node for d in frf.reference_dofs})
    want_resp, want_ref = sorted(set(exp.response_nodes)), [exp.hammer_node]
    if (resp, ref) in ((want_resp, want_ref), (want_ref, want_resp)):
        return
    raise DataError(
        f"{path}: its FRFs are measured at response nodes {resp}, reference nodes {ref}; "
        f"{experiment_file} [sensors] says response_nodes {want_resp}, hammer_node "
        f"{exp.hammer_node}"
    )


def recorded_frf(exp: Experiment, spec: ConfigurationSpec) -> tuple[FRFSet, pd.DataFrame]:
    """The FRFs and the hit table of a configuration that names raw recordings
    (:func:`ema_pipeline.pipeline.frf.configuration_frf` with its ``frf`` settings).

    Channels without a DOF (TDMS, WAV, CSV) are placed on the experiment's sensors:
    the force at ``hammer_node``, the responses at ``response_nodes`` in channel
    order (their numbers must agree), in ``direction``.
    """
    if spec.channels or spec.channel_rows:  # a channel sheet: a roving test
        sheet = experiment_channel_sheet(exp, spec)
        settings = FRFSettings(**dict(spec.frf))  # type: ignore[arg-type]
        roving = sheet_frf(sheet, settings, configuration=spec.name)
        return roving.frf, roving.hits_table()
    paths = experiment_recording_paths(exp, spec)
    result = configuration_frf(paths, spec.frf, configuration=spec.name)
    frf = result.frf
    rec = result.recording
    if rec is not None and all(ch.dof is None for ch in rec.channels):
        if frf.n_out != len(exp.response_nodes):
            raise DataError(
                f"{paths[0]}: {frf.n_out} response channel(s) without DOFs, but [sensors] "
                f"response_nodes has {len(exp.response_nodes)} (they are placed in channel "
                "order); give each channel its node and direction in a channel sheet "
                "([recordings] channels = \"channels.csv\"; `ema-pipeline init DIR "
                "--recordings RECORDINGS` writes one)"
            )
        frf = replace(frf, response_dofs=tuple(DOF(n, exp.direction) for n in exp.response_nodes),
                      reference_dofs=(DOF(exp.hammer_node, exp.direction),))
    return single_reference(frf), result.hits_table()


def map_dofs(exp: Experiment, frf: FRFSet, path: Path | str = "") -> FRFSet:
    """``frf`` with the experiment's ``[dofs] map`` applied (file DOF -> geometry
    DOF) and its ``[dofs] fixed`` DOFs checked: each must be one of the FRFs'
    DOFs (a :class:`DataError` naming the file otherwise).

    Examples
    --------
    >>> from ema_pipeline.data import Beam
    >>> from ema_pipeline.identification import IdentificationOptions
    >>> exp = Experiment(name="x", beam=Beam(), configurations=(),
    ...                  identification=IdentificationOptions(),
    ...                  dof_map=((DOF(101, 3), DOF(1, 3)),), fixed_dofs=(DOF(2, -3),))
    >>> frf = FRFSet(freq_hz=np.arange(3.0), H=np.ones((1, 1, 3), complex),
    ...              response_dofs=(DOF(101, 3),), reference_dofs=(DOF(2, -3),))
    >>> [d.label() for d in map_dofs(exp, frf).response_dofs]
    ['1+Z']
    """
    if exp.dof_map:
        table = dict(exp.dof_map)
        frf = replace(frf, response_dofs=tuple(table.get(d, d) for d in frf.response_dofs),
                      reference_dofs=tuple(table.get(d, d) for d in frf.reference_dofs))
    dofs = set(frf.response_dofs) | set(frf.reference_dofs)
    missing = [d.label() for d in exp.fixed_dofs if d not in dofs]
    if missing:
        where = f"{path}: " if path else ""
        raise DataError(f"{where}[dofs] fixed {', '.join(missing)}: not among the file's DOFs "
                        f"({', '.join(sorted({d.label() for d in dofs}))})")
    return frf


def prepare_study(
    experiment: Experiment, experiment_file: str | os.PathLike[str] = "experiment.toml",
    *, hits: dict[str, pd.DataFrame] | None = None,
) -> dict[str, FRFSet]:
    """Read and check every configuration's FRF file before anything is computed.

    Each file is read (HDF5 checked in a child process first, see
    :func:`ema_pipeline.io.check_hdf5`), its sensors compared with the
    experiment's, and the identification settings checked against it
    (:func:`ema_pipeline.identification.diagram.resources.check_identification`: band,
    orders, window time constant, memory). Returns the FRF sets by
    configuration name; raises DataError / ConfigError (input errors) naming
    the file. A configuration naming raw recordings gets its FRFs from them
    (:func:`recorded_frf`); its hit table goes into ``hits`` when given.
    """
    frfs: dict[str, FRFSet] = {}
    for spec in experiment.configurations:
        options = replace(experiment.identification, exp_window_tau_s=spec.exp_window_tau_s)
        if spec.added_mass is not None:
            continue
        path = io.experiment_file_path(experiment, spec)
        if spec.recording:
            frf, table = recorded_frf(experiment, spec)
            if hits is not None:
                hits[spec.name] = table
        else:
            frf = replace(load_frf(path, options), configuration=spec.name)
        frf = map_dofs(experiment, frf, path)
        if experiment.has_beam:  # the beam's [sensors]; any other structure: its own DOFs
            _check_sensors(experiment, frf, path, str(experiment_file))
        check_identification(frf, options, source=f"{path} ({spec.name})")
        frfs[spec.name] = frf
    return frfs


def _identify_all(exp: Experiment, result: StudyResult, say: Progress,
                  loaded: dict[str, FRFSet] | None = None, workers: int = 1) -> None:
    loaded = loaded or {}
    turned_off: dict[str, list[str]] = {}  # a fixed order's note: the configurations
    for k, spec in enumerate(exp.configurations, start=1):
        # a configuration declared with added_mass has no file: simulated on the FE beam
        path = None if spec.added_mass is not None else io.experiment_file_path(exp, spec)
        source = path or f"simulated, added mass {dict(spec.added_mass or ())}, seed {spec.seed}"
        start = time.perf_counter()
        say(f"[identify {k}/{len(exp.configurations)}] {spec.name}: {source}")
        try:
            options = replace(exp.identification, exp_window_tau_s=spec.exp_window_tau_s)
            if spec.name in loaded:
                frf = loaded[spec.name]
            elif spec.recording:
                frf, result.hits[spec.name] = recorded_frf(exp, spec)
            else:
                frf = simulate_configuration(exp, spec) if path is None else map_dofs(
                    exp, replace(load_frf(path, options), configuration=spec.name), path)
            ident = identify(frf, options, workers=workers)
        except DataError as exc:
            result.problems.append(f"configuration {spec.name!r}: {exc}")
            say(f"    failed: {exc}")
            continue
        result.frfs[spec.name] = frf
        result.identification[spec.name] = ident
        note = (searches_turned_off(options, ident.settings.band_hz, ident.fn_hz)
                if ident.settings.method == "plscf" else "")  # identify()'s warning, a note
        if note:
            turned_off.setdefault(note, []).append(spec.name)
        modes = ident.modes
        n_use = min(exp.n_modes, modes.n_modes) if exp.has_beam else modes.n_modes
        if not exp.has_beam:
            pass  # no FE stage: every mode is used
        elif modes.n_modes < exp.n_modes:
            result.problems.append(
                f"configuration {spec.name!r}: only {plural(modes.n_modes, 'mode')} identified, "
                f"the FE stage needs {exp.n_modes}"
                + ("" if spec.name == exp.genuine_name else "; the missing ones are paired as such")
            )
        elif modes.n_modes > exp.n_modes:
            result.notes.append(
                f"{spec.name}: {plural(modes.n_modes, 'mode')} identified, the lowest "
                f"{exp.n_modes} are used"
            )
        result.measured[spec.name] = ModalParameters(
            fn_hz=modes.fn_hz[:n_use],
            zeta=modes.zeta[:n_use],
            fn_std_hz=modes.fn_std_hz[:n_use],
            zeta_std=modes.zeta_std[:n_use],
            shapes=None if modes.shapes is None else modes.shapes[:, :n_use],
            dofs=modes.dofs,
            configuration=spec.name,
        )
        seconds = time.perf_counter() - start
        result.seconds[f"identify_{spec.name}"] = seconds
        freqs = ", ".join(f"{f:.2f}" for f in modes.fn_hz)
        say(f"    {plural(modes.n_modes, 'mode')} [{freqs}] Hz in {seconds:.1f} s")
    result.notes += [f"{', '.join(names)}: {note}" for note, names in turned_off.items()]


def _fe_stage(exp: Experiment, result: StudyResult, say: Progress, progress_bars: bool) -> None:
    from ema_pipeline import fe
    from ema_pipeline.pipeline.fe_stage import fe_stage_tables, run_fe_stage, update_statement

    genuine = exp.genuine_name
    # The genuine state defines the mode numbers and must be complete; a modified
    # state with fewer modes is still used: its missing modes are reported as such.
    usable = {n: m for n, m in result.measured.items() if m.n_modes >= exp.n_modes or n != genuine}
    start = time.perf_counter()
    say(
        "[fe] modal added mass, initial FE model, update (differential evolution), SEREP, "
        "local added mass"
    )
    if genuine not in usable:
        result.problems.append(
            f"the genuine configuration {genuine!r} has no complete modal table: Tables 2-6 "
            "need it; only Table 3 (initial FE model) is computed"
        )
        result.tables["table3_fe_initial"] = pd.DataFrame(
            {
                "mode": np.arange(1, exp.n_modes + 1),
                "fn_hz": fe.beam_frequencies(exp.beam, exp.n_modes),
            }
        )
        return
    try:
        stage = run_fe_stage(
            exp.beam,
            usable,
            genuine=genuine,
            immersed_elements=exp.immersed_elements,
            n_repeats=exp.update_repeats,
            seed=exp.seed,
            progress=progress_bars,
        )
    except EMAError as exc:
        result.problems.append(f"FE stage: {exc}")
        say(f"    failed: {exc}")
        return
    result.fe = stage
    result.tables.update(fe_stage_tables(stage))
    upd = stage.update
    result.notes.append(update_statement(upd))
    result.notes.extend(stage.messages)
    result.seconds["fe"] = time.perf_counter() - start
    say(f"    done in {result.seconds['fe']:.1f} s (update {upd.wall_time_s:.1f} s)")


def run_study(
    experiment: Experiment, *, progress: Progress | None = None, progress_bars: bool = False,
    frfs: dict[str, FRFSet] | None = None, hits: dict[str, pd.DataFrame] | None = None,
    workers: int = 1,
) -> StudyResult:
    """Run identification, added mass and the FE stage for an experiment
    (``frfs``: the FRF sets :func:`prepare_study` read, by configuration;
    ``hits``: the hit tables of the recorded configurations among them;
    ``workers``: worker processes of each identification)."""
    say = progress or (lambda _msg: None)
    result = StudyResult(experiment=experiment, hits=dict(hits or {}))
    names = [c.name for c in experiment.configurations]
    if experiment.genuine_name not in names:
        raise ConfigError(f"genuine configuration {experiment.genuine_name!r} not in {names}")
    start = time.perf_counter()
    _identify_all(experiment, result, say, frfs, workers)
    result.tables["table1_modal_parameters"] = table1(result.measured)
    if experiment.has_beam:
        _fe_stage(experiment, result, say, progress_bars)
    else:
        result.notes.append("the experiment file describes no beam ([geometry], no [beam]): "
                            "the FE model, its update and the added mass are not computed")
    result.seconds["total"] = time.perf_counter() - start
    return result


def _is_paper_experiment(exp: Experiment) -> bool:
    beam = exp.beam
    same_beam = np.allclose(
        [beam.length_m, beam.width_m, beam.thickness_m, beam.youngs_modulus_pa, beam.density_kg_m3],
        [
            paper.TABLE4_INITIAL[k]
            for k in ("length_m", "width_m", "thickness_m", "youngs_modulus_pa", "density_kg_m3")
        ],
    )
    return same_beam and set(c.name for c in exp.configurations) <= set(paper.CONFIGURATIONS)


def report_input(result: StudyResult, experiment_file: str | os.PathLike[str] | None = None):
    """The :class:`~ema_pipeline.report.ReportInput` of a study.

    ``experiment_file`` (the TOML the study was read from) is listed with its
    sha256 among the inputs when given.
    """
    from ema_pipeline import __version__
    from ema_pipeline.pipeline.reports import report_date
    from ema_pipeline.report import BeamSetup, ReportInput

    exp = result.experiment
    fe_x = fe_shapes = None
    if result.fe is not None:
        from ema_pipeline import fe

        modes = fe.beam_modes(result.fe.beam_updated, exp.n_modes)
        trans = modes.model.translational_dof(np.arange(1, exp.beam.n_elements + 1))
        fe_x = modes.model.node_x_m / modes.model.node_x_m[-1]
        fe_shapes = np.vstack([np.zeros((1, exp.n_modes)), modes.shapes[trans]])
    sensors = np.array([exp.beam.node_x_m(n) for n in exp.response_nodes]) / exp.beam.length_m
    inputs = []
    if experiment_file is not None and Path(experiment_file).is_file():
        inputs.append(("experiment", str(experiment_file), io.sha256_file(experiment_file)))
    for spec in exp.configurations:
        frf = result.frfs.get(spec.name)
        if frf is not None and frf.source.path:
            inputs.append((spec.name, frf.source.path, frf.source.sha256))
        elif frf is None:
            inputs.append((spec.name, spec.file, "(not read)"))
    return ReportInput(
        title=exp.name,
        tables=result.tables,
        frfs=result.frfs,
        identification=result.identification,
        genuine=exp.genuine_name,
        fe_node_x=fe_x,
        fe_shapes=fe_shapes,
        sensor_x=sensors,
        notes=result.notes,
        problems=result.problems,
        compare_with_paper=_is_paper_experiment(exp),
        descriptions={c.name: c.description for c in exp.configurations},
        geometry=BeamSetup(
            length_m=exp.beam.length_m,
            n_elements=exp.beam.n_measurement_elements,
            response_nodes=tuple(exp.response_nodes),
            hammer_node=exp.hammer_node,
            immersed_elements=tuple(exp.immersed_elements),
            direction=exp.direction,
        ) if exp.has_beam else None,
        test_info=_test_info(exp),
        inputs=inputs,
        hits=result.hits,
        test_geometry=exp.geometry or (exp.beam.measurement_geometry() if exp.has_beam
                                       else None),
        shape_sets=_expanded_shapes(result, fe_x, fe_shapes),
        settings=_settings_text(exp),
        version=__version__,
        generated=report_date(),
    )


def _expanded_shapes(
    result: StudyResult, fe_x: np.ndarray | None, fe_shapes: np.ndarray | None
) -> dict[str, Any]:
    """The report's animated shapes on the beam's measurement mesh when the
    experiment gives no ``[geometry]``: each measured mode is the updated FE mode
    paired with it (``added_mass.modal.pair_modes``, by frequency) scaled by least
    squares to the measured values, which replace it at the sensors. With a
    few sensors on a cantilever this draws the whole beam instead of a tip at
    rest; the sensors are drawn as measured, the other nodes as not measured."""
    from ema_pipeline.added_mass.modal import pair_modes
    from ema_pipeline.report.shape_views import ModeSet

    exp = result.experiment
    if exp.geometry is not None or fe_x is None or fe_shapes is None or result.fe is None:
        return {}
    n_meas = exp.beam.n_measurement_elements
    at_nodes = fe_shapes[np.searchsorted(fe_x, np.arange(n_meas + 1) / n_meas - 1e-9)]
    fe_fn = np.asarray(result.fe.fn_updated_hz, dtype=float)[: at_nodes.shape[1]]
    dofs = tuple(DOF(n, exp.direction) for n in range(1, n_meas + 2))
    out = {}
    for name, r in result.identification.items():
        m = r.modes
        rows = [d.node - 1 for d in m.dofs]
        if m.shapes is None or any(not 0 <= k <= n_meas for k in rows):
            continue
        partner, _ = pair_modes(m.fn_hz, fe_fn)
        full = np.zeros((n_meas + 1, m.n_modes), dtype=complex)
        for k, j in enumerate(partner):
            if j >= 0:
                psi = at_nodes[:, j]
                full[:, k] = psi * (psi[rows] @ m.shapes[:, k]) / (psi[rows] @ psi[rows])
            full[rows, k] = m.shapes[:, k]
        out[name] = ModeSet(m.fn_hz, m.zeta, full, dofs, measured=tuple(m.dofs))
    return out


def _test_info(exp: Experiment) -> dict[str, str]:
    """The report's rows of the ``[test]`` and ``[dofs]`` tables."""
    out = {key.replace("_", " "): value for key, value in exp.test}
    if exp.roving in ("hammer", "sensor"):
        fixed = ", ".join(d.label() for d in exp.fixed_dofs)
        what = ("roving hammer, fixed accelerometer(s)" if exp.roving == "hammer"
                else "roving accelerometer(s), fixed hammer")
        out["test"] = what + (f" at {fixed}" if fixed else "")
    elif exp.fixed_dofs:
        out["fixed DOFs"] = ", ".join(d.label() for d in exp.fixed_dofs)
    if exp.dof_map:
        out["DOF map (file -> geometry)"] = ", ".join(f"{a.label()} -> {b.label()}"
                                                      for a, b in exp.dof_map)
    return out


def _settings_text(exp: Experiment) -> dict[str, str]:
    """The settings the study used, as text for the report's provenance."""
    from dataclasses import fields

    out = {
        f"identification.{f.name}": str(getattr(exp.identification, f.name))
        for f in fields(exp.identification)
    }
    beam = exp.beam
    out["beam"] = (
        f"L {beam.length_m} m, b {beam.width_m} m, h {beam.thickness_m} m, "
        f"E {beam.youngs_modulus_pa:g} Pa, rho {beam.density_kg_m3} kg/m^3, "
        f"{beam.n_elements} FE / {beam.n_measurement_elements} measurement elements"
    )
    out["fe"] = (
        f"immersed elements {list(exp.immersed_elements)}, {exp.n_modes} modes, "
        f"{exp.update_repeats} update repeats, seed {exp.seed}"
    )
    return out


def summary(result: StudyResult) -> dict[str, Any]:
    """A JSON-able summary: modes, added mass, update, local added mass, problems."""
    out: dict[str, Any] = {
        "experiment": result.experiment.name,
        "ok": result.ok,
        "problems": result.problems,
        "modes": {
            name: {
                "fn_hz": m.fn_hz.tolist(),
                "fd_hz": m.fd_hz.tolist(),
                "zeta_pct": (100 * m.zeta).tolist(),
            }
            for name, m in result.measured.items()
        },
        "seconds": {k: round(v, 3) for k, v in result.seconds.items()},
    }
    for name in ("table2_modal_added_mass", "table6_local_added_mass", "table5_fe_updated"):
        if name in result.tables:
            out[name] = json.loads(result.tables[name].to_json(orient="records"))
    return out


def write_modes_uff_files(result: StudyResult, folder: Path) -> list[Path]:
    """``folder/<configuration>.uff`` for every identified configuration, with
    the measurement nodes' coordinates along the beam (x in m, y = z = 0)."""
    beam = result.experiment.beam
    geometry = result.experiment.geometry
    written = []
    for name, ident in result.identification.items():
        frf = result.frfs.get(name)
        if frf is None or ident is None:
            continue
        nodes = sorted({abs(d.node) for d in ident.modes.dofs})
        if result.experiment.has_beam:
            coords = {
                n: (beam.node_x_m(n), 0.0, 0.0)
                for n in nodes
                if 1 <= n <= beam.n_measurement_elements + 1
            }
        else:  # the nodes of the [geometry]
            xyz = {} if geometry is None else dict(zip(geometry.node_ids.tolist(),
                                                       geometry.xyz_m.tolist(), strict=True))
            coords = {n: tuple(xyz[n]) for n in nodes if n in xyz}
        written.append(
            write_result_uff(ident, frf, folder / f"{name}.uff", node_coordinates=coords or None)
        )
    return written


def write_study(
    result: StudyResult,
    results_dir: str | os.PathLike[str],
    say: Progress | None = None,
    *,
    figures: bool = True,
    experiment_file: str | os.PathLike[str] | None = None,
    uff: bool = False,
) -> list[Path]:
    """Write tables, HDF5 store, figures (SVG, unless ``figures=False``) and
    reports; with ``uff`` also ``modes/<configuration>.uff`` per identified
    configuration (modes, beam node coordinates, synthesised FRFs); returns
    the files written.

    Everything goes to a fresh folder beside ``results_dir`` first, which
    replaces ``results_dir`` only when complete
    (:func:`ema_pipeline.io.atomic_folder`); on any failure it is removed and
    ``results_dir`` is untouched.
    """
    from ema_pipeline import report

    say = say or (lambda _msg: None)
    results_dir = Path(os.path.realpath(results_dir))  # a loop: an OSError on writing
    with io.atomic_folder(results_dir) as tmp_dir:
        for name, table in result.tables.items():
            io.write_csv(table, tmp_dir / "tables" / f"{name}.csv")
        for name, table in result.hits.items():
            io.write_csv(table, tmp_dir / "hits" / f"{name}_hits.csv")
        say("[report] report.html" + ("" if figures else " (no figures)"))
        rin = report_input(result, experiment_file)
        drawn = report.make_figures(rin) if figures else None
        for name, svg in (drawn or {}).items():
            io.write_text(report.standalone_svg(svg), tmp_dir / "figures" / f"{name}.svg")
        io.write_text(report.render_markdown(rin, list(drawn or ())), tmp_dir / "report.md")
        io.write_text(report.render_html(rin, drawn), tmp_dir / "report.html")
        reproducible = {k: v for k, v in summary(result).items() if k != "seconds"}
        io.write_text(json.dumps(reproducible, indent=2) + "\n", tmp_dir / "summary.json")
        if uff:
            write_modes_uff_files(result, tmp_dir / "modes")
        say("[store] ema_results.h5")
        io.write_results_h5(
            {
                "experiment": result.experiment,
                "frf": result.frfs,
                "identification": result.identification,
                "tables": result.tables,
                "fe": result.fe,
                "problems": {f"{k}": p for k, p in enumerate(result.problems)},
            },
            tmp_dir / "ema_results.h5",
        )
    return sorted(p for p in results_dir.rglob("*") if p.is_file())


def summary_text(result: StudyResult, results_dir: Path) -> str:
    """The one-screen summary printed at the end of ``run``."""
    lines = [f"ema-pipeline run: {result.experiment.name}", ""]
    t1 = result.tables.get("table1_modal_parameters")
    if t1 is not None and len(t1):
        lines.append("modes (fd Hz / zeta %):")
        for name, grp in t1.groupby("configuration", sort=False):
            cells = "  ".join(f"{r.fd_hz:8.2f}/{r.zeta_pct:.3f}" for r in grp.itertuples())
            lines.append(f"  {name:<14} {cells}")
    t2 = result.tables.get("table2_modal_added_mass")
    if t2 is not None and len(t2):
        lines.append("modal added mass m_ar/m_r (eq. 10):")
        for name, grp in t2.groupby("configuration", sort=False):
            cells = "  ".join(f"{v:.4f}" for v in grp["added_mass_ratio"])
            lines.append(f"  {name:<14} {cells}")
    t6 = result.tables.get("table6_local_added_mass")
    if t6 is not None and len(t6):
        lines.append("local added mass (eq. 20):")
        for r in t6.itertuples():
            dk = f"{r.delta_k:+.4f}" if np.isfinite(r.delta_k) else "not fitted"  # exact: none
            lines.append(
                f"  {r.configuration:<14} {r.method:<10} delta_k = {dk:<10} "
                f"delta_m = {r.delta_m:+.4f}"
            )
    for note in result.notes:
        lines.append(f"note: {note}")
    for problem in result.problems:
        lines.append(f"PROBLEM: {problem}")
    lines.append(f"results in {results_dir} ({result.seconds.get('total', 0):.1f} s)")
    return "\n".join(lines)
