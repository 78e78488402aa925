"""The FE stage of the study (paper Tables 2-6) from measured modal parameters.

Orchestration only: the numerics are :mod:`ema_pipeline.added_mass` (eq. 10,
eq. 14-20, the exact eigenvalue fit, the tables) and :mod:`ema_pipeline.fe`
(beam FE, SEREP, model update); this module runs them in order, shows the model
update's progress bar and assembles the tables (:func:`fe_stage_tables`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from ema_pipeline import fe, paper
from ema_pipeline.added_mass import (
    EXACT_METHOD,
    METHODS,
    TABLE4_PARAMETER_NAMES,
    AddedMassResult,
    ExactOutcome,
    LocalAddedMassResult,
    exact_added_mass_all,
    exact_method_notes,
    fe_frequency_table,
    local_added_mass,
    local_added_mass_table,
    modal_added_mass_all,
    modal_added_mass_table,
    replace_configuration,
    require_genuine,
    updated_parameters_table,
)
from ema_pipeline.data import Beam, DataError, ModalParameters

__all__ = [
    "TABLE6_METHODS",
    "FEStageResult",
    "fe_stage_tables",
    "lowest_modes",
    "run_fe_stage",
    "update_progress_bar",
    "update_statement",
]

#: The local added mass methods of Table 6, in table order.
TABLE6_METHODS: tuple[str, ...] = (*METHODS, EXACT_METHOD)


class _Bar(tqdm):
    """The model update's bar, without tqdm's monitor thread: the monitor
    outlives the bars, and a thread beside this one makes the runner's
    fork-safety rule (:func:`ema_pipeline.runner.fork_is_safe`) refuse every
    later fork of the process (worker pools, HDF5 checks)."""

    monitor_interval = 0


@contextmanager
def update_progress_bar(enabled: bool = True) -> Iterator[Callable[[int, int], None] | None]:
    """A tqdm bar over the model update's runs, as the ``progress`` callback of
    :func:`ema_pipeline.fe.update_beam` (None when not ``enabled``)."""
    if not enabled:
        yield None
        return
    bars: list[_Bar] = []  # created at the first call, when the total is known

    def advance(done: int, total: int) -> None:
        if not bars:
            desc = "model update (differential evolution)"
            bars.append(_Bar(total=total, desc=desc, leave=False))
        bars[0].update(done - bars[0].n)

    try:
        yield advance
    finally:
        for bar in bars:
            bar.close()


@dataclass(frozen=True)
class FEStageResult:
    """Everything the FE stage produces (paper Tables 2-6).

    Attributes
    ----------
    beam_initial, beam_updated : the Table 3 model and the updated one.
    genuine : name of the genuine configuration in ``measured``.
    measured : measured modal parameters per configuration.
    fn_initial_hz : Table 3, the initial FE frequencies (as many as genuine modes).
    update : Table 4 (:class:`ema_pipeline.fe.UpdateResult`, all runs,
        identifiable combination and its value, parameter spread).
    fn_updated_hz : Table 5.
    reduced : SEREP model of the updated beam (10 masters, 10 modes in the paper).
    modal_added_mass : Table 2, per modified configuration.
    local_added_mass : Table 6, one entry per configuration and first-order
        method (``block``, ``projected``).
    messages : notes for the report (mode pairing, the exact method beside
        the first-order one).
    exact_added_mass : Table 6 method ``exact`` per modified configuration
        (:class:`ema_pipeline.added_mass.ExactOutcome`: the fit on the updated
        beam, or the reason it was refused); also Table 2's FE-based modal
        added mass.
    """

    beam_initial: Beam
    beam_updated: Beam
    genuine: str
    measured: dict[str, ModalParameters]
    fn_initial_hz: np.ndarray
    update: fe.UpdateResult
    fn_updated_hz: np.ndarray
    reduced: fe.SerepModel
    modal_added_mass: dict[str, AddedMassResult]
    local_added_mass: tuple[LocalAddedMassResult, ...]
    messages: tuple[str, ...] = ()
    exact_added_mass: dict[str, ExactOutcome] = field(default_factory=dict)


def run_fe_stage(
    beam: Beam,
    measured: Mapping[str, ModalParameters],
    *,
    immersed_elements: Sequence[int] = (10,),
    genuine: str = "genuine",
    methods: Sequence[str] = TABLE6_METHODS,
    n_repeats: int = 5,
    seed: int = 0,
    progress: bool = True,
    n_modes: int | None = None,
) -> FEStageResult:
    """Modal added mass, FE model, model update, SEREP and local added mass.

    1. Table 2: eq. (10) for every modified configuration.
    2. Table 3: FE frequencies of ``beam`` (as many modes as genuine measured).
    3. Table 4: :func:`ema_pipeline.fe.update_beam` on the genuine undamped
       frequencies, eq. (26), differential evolution repeated ``n_repeats`` times.
    4. Table 5: FE frequencies of the updated beam.
    5. Table 6: :func:`local_added_mass` per modified configuration and
       first-order method, on the SEREP-reduced updated model, and method
       ``exact`` (:func:`ema_pipeline.added_mass.exact_added_mass_all`: the
       updated beam's eigenvalues fitted to the measured frequency ratios, all
       genuine modes, the eq. (10) pairing); a configuration whose modes cannot
       determine the unknowns gets a refusal with the reason, the stage goes on.

    ``measured`` maps configuration names to modal parameters (see
    :func:`modal_parameters_from_table`); ``measured[genuine]`` must have every
    mode (it defines the FE mode numbers 1..p). ``n_modes`` (the experiment
    file's ``[fe] n_modes``): use only the lowest ``n_modes`` modes of every
    configuration (all of them where it has fewer; a note says what was left
    out); ``None`` uses every mode given.
    """
    require_genuine(measured, genuine)
    cut: list[str] = []
    if n_modes is not None:
        if n_modes < 1:
            raise DataError(f"n_modes must be at least 1, got {n_modes}")
        cut = [f"{name}: {m.n_modes} modes given, the lowest {n_modes} are used ([fe] n_modes)"
               for name, m in measured.items() if m.n_modes > n_modes]
        measured = {name: lowest_modes(m, n_modes) for name, m in measured.items()}
    for m in methods:
        if m not in TABLE6_METHODS:
            raise DataError(f"unknown local added mass method {m!r}; use {TABLE6_METHODS}")
    gen = replace_configuration(measured[genuine], genuine)
    p = gen.n_modes
    if p < 1:
        raise DataError(f"configuration {genuine!r} has no modes")
    n_mod = len(measured) - 1
    if n_mod and any(m in METHODS for m in methods) and 2 * len(tuple(immersed_elements)) > p:
        raise DataError(
            f"{len(tuple(immersed_elements))} immersed element(s) need at least "
            f"{2 * len(tuple(immersed_elements))} measured modes, got {p}: the number of "
            "modified elements must not exceed half the number of measured modes"
        )
    modal = modal_added_mass_all(measured, genuine)
    fn_init = fe.beam_frequencies(beam, p)
    with update_progress_bar(progress) as bar:
        upd = fe.update_beam(beam, gen.fn_hz, n_repeats=n_repeats, seed=seed, progress=bar)
    n_red = max(p, beam.n_measurement_elements)
    modes_upd, reduced = fe.reduce_beam(upd.beam, n_red)
    local: list[LocalAddedMassResult] = []
    for name, pair in modal.items():
        mod = replace_configuration(measured[name], name)
        for m in (m for m in methods if m in METHODS):
            local.append(
                local_added_mass(upd.beam, gen, mod, immersed_elements=immersed_elements,
                                 method=m, reduced=reduced, pairing=pair)  # type: ignore[arg-type]
            )
    exact = (
        exact_added_mass_all(upd.beam, measured, genuine, immersed_elements=immersed_elements,
                             pairing=modal)
        if EXACT_METHOD in methods else {}
    )
    msgs = tuple(cut) + tuple(msg for res in modal.values() for msg in res.messages) + tuple(
        exact_method_notes(local_added_mass_table(local, exact))
    )
    return FEStageResult(
        beam_initial=beam,
        beam_updated=upd.beam,
        genuine=genuine,
        measured=dict(measured),
        fn_initial_hz=fn_init,
        update=upd,
        fn_updated_hz=modes_upd.fn_hz[:p],
        reduced=reduced,
        modal_added_mass=modal,
        local_added_mass=tuple(local),
        messages=msgs,
        exact_added_mass=exact,
    )


def lowest_modes(modes: ModalParameters, n_modes: int) -> ModalParameters:
    """Modes 1..``n_modes`` of ``modes`` (the lowest: modes are in ascending
    order; all of them when it has fewer), with their std, shapes and
    configuration name.

    Examples
    --------
    >>> m = ModalParameters(fn_hz=[18.1, 112.1, 327.6], zeta=[0.005, 0.0067, 0.0029])
    >>> lowest_modes(m, 2).fn_hz.tolist(), lowest_modes(m, 5).n_modes
    ([18.1, 112.1], 3)
    """
    keep = slice(0, n_modes)
    return ModalParameters(
        fn_hz=modes.fn_hz[keep], zeta=modes.zeta[keep], fn_std_hz=modes.fn_std_hz[keep],
        zeta_std=modes.zeta_std[keep],
        shapes=None if modes.shapes is None else modes.shapes[:, keep], dofs=modes.dofs,
        configuration=modes.configuration,
    )


def fe_stage_tables(result: FEStageResult) -> dict[str, pd.DataFrame]:
    """Tables 2-6 as DataFrames in the DESIGN.md CSV forms (ratios as ratios).

    Keys are the CSV file stems (``table2_modal_added_mass`` ...); the required
    columns come first (:data:`ema_pipeline.added_mass.TABLE_COLUMNS`), extra
    columns after them: Table 2 std, frequencies, ``paired``; Table 4 the spread
    over the runs (``run_min, run_max, run_std``), the paper's row label and a
    last row with the identifiable combination h*sqrt(E/rho)/L^2
    (``identifiable`` True); Table 5 the measured frequency and relative
    deviation; Table 6 (one row per configuration, method and element) the
    std, residual, condition number, rank, modes used and status of the
    ``exact`` fit (:data:`ema_pipeline.added_mass.TABLE6_EXTRA_COLUMNS`), and
    Table 2 the FE-based modal added mass of the exact fit
    (``added_mass_ratio_fe``).
    """
    fx = result.measured[result.genuine].fn_hz
    return {
        "table2_modal_added_mass": modal_added_mass_table(result.modal_added_mass,
                                                          result.exact_added_mass),
        "table3_fe_initial": fe_frequency_table(result.fn_initial_hz),
        "table4_updated_parameters": updated_parameters_table(result.update, paper.TABLE4_LABELS),
        "table5_fe_updated": fe_frequency_table(result.fn_updated_hz, fx),
        "table6_local_added_mass": local_added_mass_table(result.local_added_mass,
                                                          result.exact_added_mass),
    }


def update_statement(update: fe.UpdateResult) -> str:
    """What the model update determined, in words for the report and the console:
    the identifiable combination h*sqrt(E/rho)/L^2 with its value and its spread
    over the differential-evolution runs, and the spread of the five parameters
    (3 significant digits). The individual ``updated`` values of Table 4 are one
    point of a valley whose digits differ between machines (BLAS builds), so
    they are not quoted here.

    Examples
    --------
    >>> from ema_pipeline.data import Beam
    >>> fx = fe.beam_frequencies(Beam(), 4) * 0.8  # the same beam, 20 % slower
    >>> text = update_statement(fe.update_beam(Beam(), fx, n_repeats=2, seed=0))
    >>> text[text.index("h*"):text.index(" (initial")]  # 0.8 * 122.8105 = 98.2484
    'h*sqrt(E/rho)/L^2 = 98.248 1/s'
    """
    runs = np.asarray(update.identifiable_runs, dtype=float)
    if runs.size > 1:
        std = float(np.std(runs, ddof=1))
        over = (f", the same in the {runs.size} differential-evolution runs to "
                f"{std / float(np.mean(runs)):.1g} (std {std:.2g} 1/s)")
    else:
        over = " (one differential-evolution run)"
    parameters = ", ".join(
        f"{TABLE4_PARAMETER_NAMES[name]} {lo:.4g} to {hi:.4g} {unit}"
        for name, unit, lo, hi in zip(update.parameter_names, update.units, update.run_min,
                                      update.run_max, strict=True)
    )
    which = ("a uniform beam's frequencies depend on the five parameters only through it "
             "(the width b cancels)" if update.identifiable_exact else
             "with point masses it is only the leading combination")
    return (
        f"model update (Table 4): the frequencies determine {update.identifiable_name} = "
        f"{update.identifiable_updated:.3f} 1/s (initial {update.identifiable_initial:.3f})"
        f"{over}; {which}. The five parameters are not identifiable one by one: the runs "
        f"spread them over {parameters}; Table 4's 'updated' column is one point of that "
        f"valley, its digits differ between machines. "
        f"Objective eq. (26): {update.objective:.5f} (initial {update.objective_initial:.4f})."
    )
