"""The study's computation: identify every configuration (Table 1), the modal
added mass and the FE stage (:func:`run_study`), problems collected in the
:class:`StudyResult`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ema_pipeline import io
from ema_pipeline.data import ConfigError, DataError, EMAError, FRFSet, ModalParameters
from ema_pipeline.experiment import Experiment
from ema_pipeline.identification import CheckedInput, check_input, identify
from ema_pipeline.identification.diagram.narrower_searches import searches_turned_off
from ema_pipeline.pipeline.simulate import simulate_configuration
from ema_pipeline.pipeline.study_inputs import (
    configuration_options,
    read_configuration,
    recorded_frf,
)
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


def _identify_all(exp: Experiment, result: StudyResult, say: Progress,
                  loaded: dict[str, CheckedInput] | None = None, workers: int = 1) -> None:
    loaded = loaded or {}
    turned_off: dict[str, list[str]] = {}  # a fixed order's note: the configurations
    for k, spec in enumerate(exp.configurations, start=1):
        # a configuration declared with added_mass has no file: simulated on the FE beam
        path = None if spec.added_mass is not None else io.experiment_file_path(exp, spec)
        source = path or f"simulated, added mass {dict(spec.added_mass or ())}, seed {spec.seed}"
        start = time.perf_counter()
        say(f"[identify {k}/{len(exp.configurations)}] {spec.name}: {source}")
        try:
            checked = loaded.get(spec.name)  # checked by prepare_study
            if checked is None:
                if spec.recording:
                    frf, result.hits[spec.name] = recorded_frf(exp, spec)
                else:
                    frf = (simulate_configuration(exp, spec) if path is None
                           else read_configuration(exp, spec))
                checked = check_input(frf, configuration_options(exp, spec))
            ident = identify(checked, workers=workers)
        except DataError as exc:
            result.problems.append(f"configuration {spec.name!r}: {exc}")
            say(f"    failed: {exc}")
            continue
        options = configuration_options(exp, spec)
        result.frfs[spec.name] = checked.frf  # as identified: the result's shapes are of these
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
    frfs: dict[str, CheckedInput] | None = None, hits: dict[str, pd.DataFrame] | None = None,
    workers: int = 1,
) -> StudyResult:
    """Run identification, added mass and the FE stage for an experiment
    (``frfs``: the checked inputs :func:`prepare_study` read, by configuration,
    identified as they are; the other configurations are read and checked here;
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
