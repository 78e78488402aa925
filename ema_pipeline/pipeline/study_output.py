"""The study's outputs: the results folder (tables, HDF5 store, UFF modes, the
report, written by :func:`write_study`) and the summary of a run.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline import io, paper
from ema_pipeline.data import DOF
from ema_pipeline.experiment import Experiment
from ema_pipeline.pipeline.single import write_result_uff
from ema_pipeline.pipeline.study_run import Progress, StudyResult


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
