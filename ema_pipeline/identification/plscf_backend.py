"""The ``"plscf"`` backend of :func:`ema_pipeline.identification.identify`: pLSCF
diagrams of adaptive order, pole trajectories, refinement with covariance, LSFD
and per-mode quality.

:func:`identify_with` runs the stages in order, each a function of this module
(stage 1 in :mod:`~ema_pipeline.identification.plscf_band`, stage 5 in
:mod:`~ema_pipeline.identification.plscf_final_tests`) whose inputs and outputs
are its arguments and its return value:

1. :func:`~ema_pipeline.identification.plscf_band.band_data`: the band's FRFs
   as the stages see them (scaled, weighted, one row per channel).
2. :func:`search_diagrams`: the candidates of the adaptive order search of
   :mod:`~ema_pipeline.identification.diagram.order_search` (diagrams of
   growing order, pole trajectories) and of the narrower searches (a wide
   band's lowest part, windows of a dense band), and the chosen diagram's
   stabilization data.
3. :func:`start_poles`: with ``expect_hz``, the expected candidates, answered
   from the automatic selection, whose other modes are refined beside them.
4. :func:`refine_candidates`: every candidate's pole refined by the local fit
   of :func:`~ema_pipeline.identification.refinement.refine.refine_poles`.
5. The final tests over all FRFs (``options.accept``, not with ``expect_hz``):
   :func:`~ema_pipeline.identification.plscf_final_tests.first_verdict` keeps a
   candidate when its refined decay rate is determined, when it is a resonance
   of the data and when it is not the same mode found twice (the final tests of
   :mod:`ema_pipeline.identification.selection.acceptance`), and refits the
   kept ones without those that failed;
   :func:`~ema_pipeline.identification.plscf_final_tests.try_alternates` tries
   a narrower search's candidate where the one covering it failed; then two
   searches look for modes that the diagrams missed: close modes hidden in a
   kept resonance
   (:func:`~ema_pipeline.identification.plscf_final_tests.add_close_partners`)
   and peaks of the residual of the kept modes' fit
   (:func:`~ema_pipeline.identification.plscf_final_tests.add_residual_peaks`).
   Their
   candidates are refined and tested together with the kept ones; when none
   passes, the previous fit stands (a failed candidate bends its neighbours'
   local fits: on the measured beam two model-error peaks beside 414.6 Hz cost
   that mode), else the fit is repeated with those that pass. With fewer than
   three channels a close pair of kept poles that the data do not prefer to one
   pole, and whose peaks do not show apart, is one mode
   (:func:`~ema_pipeline.identification.plscf_final_tests.merge_unsupported_pairs`).
6. :func:`kept_modes`: the kept modes at their refined poles with covariance
   (``options.refine``) or at their start poles; :func:`with_edge_poles`
   (judged and refined): resonances at the band's edges, found past it,
   kept in their neighbours' refinement and the shapes' fits, not reported
   (:mod:`~ema_pipeline.identification.selection.edge_poles`).
7. :func:`finished`, :func:`with_band_support`, :func:`with_pair_flags`,
   :func:`with_twin_flags`, :func:`with_not_kept`: LSFD and the result,
   which narrower searches hold each mode, which close pairs fewer than
   three channels cannot support, which modes the final tests found twice
   with the twins apart, the resonances the FRFs show that no mode was kept
   for.

``options.accept`` switches the final tests and searches of stage 5 (off: every
selected candidate is kept, untested); ``options.refine`` decides whether the
kept modes are reported at their refined poles or at their start poles (the
final tests judge refined poles either way).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ema_pipeline.data import FRFSet
from ema_pipeline.identification.common import (
    default_max_order,
    finish_identification,
    usable_top_hz,
)
from ema_pipeline.identification.diagram.narrower_searches import (
    band_support,
)
from ema_pipeline.identification.diagram.order_search import (
    OrderSearch,
    SearchedBand,
    add_window_modes,
    add_zoom_modes,
)
from ema_pipeline.identification.diagram.plscf import PoleSet
from ema_pipeline.identification.diagram.resources import order_cap
from ema_pipeline.identification.diagram.stabilization import StabilizationData, stabilization
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.plscf_band import BandData, band_data
from ema_pipeline.identification.plscf_final_tests import (
    Retest,
    add_close_partners,
    add_residual_peaks,
    first_verdict,
    merge_unsupported_pairs,
    try_alternates,
)
from ema_pipeline.identification.refinement.lsfd import reused_lsfds
from ema_pipeline.identification.refinement.refine import (
    RefinedPoles,
    band_sensitivity,
    refine_poles,
)
from ema_pipeline.identification.result import (
    PAIR_UNDER_ONE_PEAK,
    SECOND_POLE_DROPPED,
    TWIN_APART,
    IdentificationResult,
    ResolvedSettings,
    found_by_code,
)
from ema_pipeline.identification.selection.acceptance import (
    Candidates,
)
from ema_pipeline.identification.selection.edge_poles import (
    edge_fit,
    edge_neighbours,
)
from ema_pipeline.identification.selection.not_kept import resonances_not_kept
from ema_pipeline.identification.selection.pairs import (
    close_pairs,
    pair_significance,
    peaks_apart,
)
from ema_pipeline.identification.selection.partners import SplitCalibration
from ema_pipeline.identification.selection.trajectories import (
    SelectedPoles,
    expected_from_automatic,
    select_expected,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fn_hz, poles_overlap
from ema_pipeline.runner import Mapper, process_map


def identify_plscf(frf: FRFSet, options: IdentificationOptions, *,
                   workers: int = 1) -> IdentificationResult:
    """Identify with this package's pLSCF chain.

    Called by :func:`ema_pipeline.identification.identify`, which checks the
    FRF set and the options first (band, order, coherence, ``expect_hz``
    sorted and inside the band) and applies ``options.exp_window_tau_s``;
    call that, not this, with unchecked input. Independent work (the
    companion eigenvalues of a large diagram, the searches of a dense band's
    windows, the local fits of the modes) is shared out among worker
    processes (``workers`` of them, :func:`ema_pipeline.runner.process_map`;
    1: none); the numbers are those of one process. The stages' LSFDs of
    the same poles over the band are solved once (:func:`reused_lsfds`).
    """
    with process_map(workers, workers) as map_, reused_lsfds():
        return identify_with(frf, options, map_)


def identify_with(frf: FRFSet, options: IdentificationOptions,
                  map_: Mapper) -> IdentificationResult:
    """:func:`identify_plscf` with the worker processes of ``map_``: the
    stages of the module's description, in order."""
    data = band_data(frf, options)
    diagrams = search_diagrams(data, options, map_)
    start = start_poles(frf, data, diagrams, options, map_)
    judged = options.accept and data.expect_hz is None
    retest = Retest(data, map_)
    merged = np.zeros(0, dtype=complex)
    calibration = None
    edge: EdgeFit | None = None
    if start.sel.pole.size and (options.refine or judged):
        found, near = refine_candidates(data, start, map_)
        if judged:
            found = first_verdict(found, retest)
            found = try_alternates(found, diagrams.searched, retest)
            found, calibration = add_close_partners(found, retest)
            found = add_residual_peaks(found, retest)
            found, merged = merge_unsupported_pairs(found, retest)
        kept = kept_modes(found, start.neighbours, near, data, refine=options.refine,
                          map_=map_)
        if judged and options.refine:
            kept, edge = with_edge_poles(frf, data, kept, map_)
    else:
        kept = as_selected(start.sel)
    result = finished(data, diagrams, kept, options, edge)
    result = with_band_support(result, start.auto, kept.sel.pole, diagrams.searched,
                               data.thresholds)
    if judged:
        result = with_pair_flags(result, data, kept.judged, merged, calibration)
        result = with_twin_flags(result, kept.judged, retest.twins, data.thresholds)
    # a resonance at the band's edge is in the model: not also listed as not kept
    return with_not_kept(result, data, retest.rejected,
                         kept.judged if edge is None else np.concatenate([kept.judged, edge.pole]))


# ------------------------------------------------------------------ 2. the diagrams
@dataclass(frozen=True)
class Diagrams:
    """What the diagrams found (:func:`search_diagrams`).

    Attributes
    ----------
    sel : the candidates (start poles, their trajectories).
    poles : the chosen diagram's poles.
    stab : its stabilization data, with the trajectory labels as clusters.
    searched : the narrower searches (band, candidates, those covered).
    """

    sel: SelectedPoles
    poles: PoleSet
    stab: StabilizationData
    searched: tuple[SearchedBand, ...]


def search_diagrams(data: BandData, options: IdentificationOptions,
                    map_: Mapper) -> Diagrams:
    """Stage 2: the adaptive order search (from :func:`default_max_order` up
    to :func:`order_cap`, or ``options.max_order`` alone), then, with the
    adaptive order and without ``expect_hz``, the search of the band's lowest
    part and (``options.window_searches``) of the windows of a dense band;
    the chosen diagram's stabilization flags with the diagram tolerances."""
    n_in, n_freq = data.Hn.shape[1], data.Hn.shape[2]
    cap = order_cap(n_freq, n_in, data.thresholds.max_poles)
    fixed = options.max_order is not None
    p = min(default_max_order(n_in, n_freq), cap)
    if options.max_order is not None:
        p = int(options.max_order)
    decay, th = data.window_decay_rate, data.thresholds
    search = OrderSearch(weights=data.weights, window_decay_rate=decay,
                         min_peak=data.min_peak, min_fraction=options.min_fraction,
                         expect=data.expect_hz is not None, thresholds=th,
                         tolerances=options.link_tolerances(), map_=map_)
    sel, traj, poles = search.run(data.freq_hz, data.Hn, data.band_hz, p, cap, fixed=fixed)
    searched: list[SearchedBand] = []
    if not fixed and data.expect_hz is None:
        sel, zoom = add_zoom_modes(sel, search, data.freq_hz, data.Hn, data.band_hz)
        searched += zoom
        if options.window_searches:
            sel, windows = add_window_modes(sel, search, data.freq_hz, data.Hn, data.band_hz)
            searched += windows
    diagram_freq, diagram_zeta, diagram_mac = options.diagram_tolerances()
    stab = stabilization(
        poles, decay, tol_freq=diagram_freq, tol_zeta=diagram_zeta, tol_mac=diagram_mac,
    )
    stab = StabilizationData(**{**stab.__dict__, "cluster": traj})
    return Diagrams(sel=sel, poles=poles, stab=stab, searched=tuple(searched))


# ------------------------------------------------------------------ 3. the start poles
@dataclass(frozen=True)
class StartPoles:
    """The candidates to refine (:func:`start_poles`).

    Attributes
    ----------
    sel : the candidates (start poles).
    neighbours : (n,) complex  poles refined beside them and then dropped
        (with ``expect_hz``: the automatic selection's other modes, then its
        dropped candidates).
    n_kept_neighbours : the first ``n_kept_neighbours`` of ``neighbours`` are
        automatic modes (their refined poles enter the band-sensitivity term).
    auto : with ``expect_hz`` and refinement, the automatic selection.
    """

    sel: SelectedPoles
    neighbours: np.ndarray
    n_kept_neighbours: int = 0
    auto: IdentificationResult | None = None


def start_poles(frf: FRFSet, data: BandData, diagrams: Diagrams,
                options: IdentificationOptions, map_: Mapper) -> StartPoles:
    """Stage 3: the diagrams' candidates; with ``expect_hz`` the candidate
    nearest each guess (:func:`select_expected`) and, with refinement, each
    guess answered by the automatic selection's mode (:func:`identify_with`
    without ``expect_hz``; :func:`expected_from_automatic`), whose other modes
    and dropped candidates are refined alongside."""
    none = np.zeros(0, dtype=complex)
    if data.expect_hz is None:
        return StartPoles(sel=diagrams.sel, neighbours=none)
    decay, th = data.window_decay_rate, data.thresholds
    sel = select_expected(diagrams.sel, data.expect_hz, decay, thresholds=th)
    sel = replace(sel, found_by=found_by_code("expected", sel.pole.size))
    if not options.refine:
        return StartPoles(sel=sel, neighbours=none)
    auto = identify_with(frf, replace(options, expect_hz=()), map_)
    auto_start = auto.stabilization.mode_pole
    sel, rest = expected_from_automatic(sel, data.expect_hz, auto.fn_hz, auto_start, decay,
                                        thresholds=th)
    dropped = auto.stabilization.companion_pole
    if sel.pole.size and dropped.size:  # none on a pole of the expected ones
        dropped = dropped[~np.any(poles_overlap(dropped, sel.pole), axis=1)]
    return StartPoles(sel=sel, neighbours=np.concatenate([auto_start[rest], dropped]),
                      n_kept_neighbours=rest.size, auto=auto)


# ------------------------------------------------------------------ 4. refinement
def refine_candidates(data: BandData, start: StartPoles,
                      map_: Mapper) -> tuple[Candidates, np.ndarray]:
    """Stage 4: the candidates refined together with their neighbours, all
    kept (no verdict yet), and the kept neighbours' refined poles."""
    ref = refine_poles(data.freq_hz, data.Hc, np.concatenate([start.sel.pole, start.neighbours]),
                       quantity=data.quantity, window_tau_s=data.window_tau_s,
                       force_window_s=data.force_window_s, thresholds=data.thresholds,
                       map_=map_)
    m = start.sel.pole.size
    near = ref.pole[m : m + start.n_kept_neighbours]  # the automatic modes' refined poles
    ref = RefinedPoles(*(np.asarray(a)[:m] for a in (
        ref.pole, ref.cov, ref.noise_std, ref.band_hz, ref.n_iter)))
    none = np.zeros(m, bool)
    return Candidates(start.sel, ref, np.ones(m, bool), none, none), near


# ------------------------------------------------------------------ 6. the kept modes
@dataclass(frozen=True)
class KeptModes:
    """The modes kept (:func:`kept_modes`, :func:`as_selected`).

    Attributes
    ----------
    sel : the kept modes at their reported poles (refined or start),
        ascending in frequency.
    start : (n,) complex  their start poles (stored with the diagram: ``--picks``).
    companions : (n,) complex  start poles refined with them and then dropped.
    cov : (n, 2, 2) covariance of the refined poles (with the
        band-sensitivity term), or None (the trajectories' scatter).
    judged : (n,) complex  the kept poles as the final tests saw them.
    """

    sel: SelectedPoles
    start: np.ndarray
    companions: np.ndarray
    cov: np.ndarray | None
    judged: np.ndarray


def as_selected(sel: SelectedPoles) -> KeptModes:
    """Stage 6 without refinement and tests: every candidate, at its start pole."""
    return KeptModes(sel=sel, start=sel.pole, companions=np.zeros(0, dtype=complex),
                     cov=None, judged=sel.pole)


def kept_modes(found: Candidates, neighbours: np.ndarray, near: np.ndarray, data: BandData,
               *, refine: bool, map_: Mapper) -> KeptModes:
    """Stage 6: the candidates ``found`` kept, ascending in refined frequency,
    at their refined poles with their covariance plus the band-sensitivity
    term (:func:`band_sensitivity`, with the automatic neighbours' refined
    poles ``near``) when ``refine``, else at their start poles, ascending,
    with the trajectories' scatter (NaN for one found outside the diagrams)."""
    sel, ref, keep = found.sel, found.ref, found.keep
    companions = np.concatenate([sel.pole[~keep], neighbours])
    order_s = np.argsort(ref.pole[keep].imag)
    judged = ref.pole[keep][order_s]
    if not refine:
        kept = sel.subset(keep)
        kept = kept.subset(np.argsort(kept.pole.imag))
        none = kept.n_members == 0
        kept = replace(kept, scatter_fn_hz=np.where(none, np.nan, kept.scatter_fn_hz),
                       scatter_zeta=np.where(none, np.nan, kept.scatter_zeta))
        return KeptModes(sel=kept, start=kept.pole, companions=companions, cov=None,
                         judged=judged)
    start = sel.pole[keep][order_s]
    kept = replace(sel.subset(keep), pole=ref.pole[keep]).subset(order_s)
    cov = ref.cov[keep][order_s]
    # the local model's own error (band choice), added in quadrature
    cov = cov + band_sensitivity(data.freq_hz, data.Hc, np.concatenate([kept.pole, near]),
                                 quantity=data.quantity, window_tau_s=data.window_tau_s,
                                 force_window_s=data.force_window_s,
                                 thresholds=data.thresholds, map_=map_)[: kept.pole.size]
    return KeptModes(sel=kept, start=start, companions=companions, cov=cov, judged=judged)


@dataclass(frozen=True)
class EdgeFit:
    """Resonances at the band's edges (:func:`with_edge_poles`).

    Attributes
    ----------
    sub : the FRF set cut to the widened band.
    pole : (n,) complex  the poles at the band's edges (not reported).
    reaches : whether the local band of a kept mode holds one of them: only
        then are the shapes fitted on the widened band with them (else they
        change no number of the result).
    """

    sub: FRFSet
    pole: np.ndarray
    reaches: bool


def with_edge_poles(frf: FRFSet, data: BandData, kept: KeptModes,
                    map_: Mapper) -> tuple[KeptModes, EdgeFit | None]:
    """Stage 6b: where the kept modes' residual rises into an edge of the band
    and the FRFs go on past it, the resonances there
    (:func:`~ema_pipeline.identification.selection.edge_poles.edge_poles` on
    the band widened by
    :func:`~ema_pipeline.identification.selection.edge_poles.widened_band`),
    and the kept modes whose local band holds one
    (:func:`~ema_pipeline.identification.selection.edge_poles.edge_neighbours`)
    refined again on the widened band beside them (:func:`refine_poles`, the
    covariance with :func:`band_sensitivity`); the kept modes unchanged and
    None without edge poles."""
    th = data.thresholds
    pole = kept.sel.pole
    tau, force = data.window_tau_s, data.force_window_s
    # the FRFs go on past the band where the hammer still drove the structure
    # (above the force's -20 dB point they hold noise: no resonance to find)
    top = usable_top_hz(frf)
    usable = frf.freq_hz <= (np.inf if top is None else max(top, data.band_hz[1]))
    found = edge_fit(frf.freq_hz[usable], frf.H.reshape(-1, frf.freq_hz.size)[:, usable],
                     data.band_hz, pole, data.quantity, thresholds=th, window_tau_s=tau,
                     force_window_s=force)
    if found is None:
        return kept, None
    band, edge = found
    sub = frf.band(*band)
    Hc = sub.H.reshape(-1, sub.freq_hz.size)
    both = np.concatenate([pole, edge])
    near = edge_neighbours(sub.freq_hz, both, pole.size, thresholds=th)
    if near.size and kept.cov is not None:
        ref = refine_poles(sub.freq_hz, Hc, both, quantity=data.quantity, thresholds=th,
                           map_=map_, modes=near, window_tau_s=tau, force_window_s=force)
        both[near] = ref.pole[near]
        cov = kept.cov.copy()
        cov[near] = ref.cov[near] + band_sensitivity(
            sub.freq_hz, Hc, both, quantity=data.quantity, thresholds=th, map_=map_,
            window_tau_s=tau, force_window_s=force)[near]
        kept = replace(kept, sel=replace(kept.sel, pole=both[: pole.size]), cov=cov)
    return kept, EdgeFit(sub=sub, pole=edge, reaches=bool(near.size))


# ------------------------------------------------------------------ 7. the result
def finished(data: BandData, diagrams: Diagrams, kept: KeptModes,
             options: IdentificationOptions, edge: EdgeFit | None = None) -> IdentificationResult:
    """Stage 7a: LSFD, window correction and indicators of the kept modes
    (:func:`finish_identification`; with ``edge`` that reaches a kept mode's
    local band, on the widened band with the edge poles), with the settings
    used and the edge poles' natural frequencies."""
    link_freq, link_zeta, link_mac = options.link_tolerances()
    poles = diagrams.poles
    result = finish_identification(
        data.sub,
        kept.sel.pole,
        decay=data.window_decay_rate,
        lower_residual=options.lower_residual,
        upper_residual=options.upper_residual,
        stab=replace(diagrams.stab, mode_pole=kept.start, companion_pole=kept.companions),
        selected=kept.sel,
        pole_cov=kept.cov,
        settings=ResolvedSettings(
            method="plscf",
            band_hz=data.band_hz,
            max_order=int(poles.orders[-1]),
            orders=poles.orders,
            dt_s=poles.dt,
            weighting=options.weighting,
            window_decay_rate=data.window_decay_rate,
            tol_freq=link_freq,
            tol_zeta=link_zeta,
            tol_mac=link_mac,
            min_fraction=options.min_fraction,
            refine=options.refine,
            lower_residual=options.lower_residual,
            upper_residual=options.upper_residual,
            expect_hz=data.expect_hz,
            uncertainty="least-squares covariance of the refined poles"
            if options.refine
            else "scatter of the trajectory's poles over model orders",
            window_searches=options.window_searches,
            accept=options.accept,
            thresholds=data.thresholds,
        ),
        edge=(edge.sub, edge.pole) if edge is not None and edge.reaches else None,
    )
    if edge is None:
        return result
    return replace(result, edge_hz=np.sort(pole_fn_hz(edge.pole + data.window_decay_rate)))


def with_band_support(result: IdentificationResult, auto: IdentificationResult | None,
                      pole: np.ndarray, searched: tuple[SearchedBand, ...],
                      thresholds: SelectionThresholds) -> IdentificationResult:
    """Stage 7b: how many narrower searches hold and find each mode (poles
    ``pole``; :func:`band_support`); with ``expect_hz``, the automatic
    selection's ``auto`` support where the mode is its."""
    if auto is not None:  # --expect: the automatic modes' support, where the pole is theirs
        support = np.zeros((result.fn_hz.size, 2), dtype=int)
        if auto.band_support.shape[0] == auto.fn_hz.size:
            for i, f_hz in enumerate(result.fn_hz):
                same = np.flatnonzero(np.isclose(auto.fn_hz, f_hz, rtol=1e-6, atol=0.0))
                if same.size:
                    support[i] = auto.band_support[same[0]]
        return replace(result, band_support=support)
    if searched:
        support = band_support(pole, list(searched), thresholds=thresholds)
        return replace(result, band_support=support)
    return result


def with_pair_flags(result: IdentificationResult, data: BandData, judged: np.ndarray,
                    merged: np.ndarray,
                    calibration: SplitCalibration | None = None) -> IdentificationResult:
    """Stage 7c, with fewer than ``min_shape_channels`` channels: which kept
    modes (refined poles ``judged``, result order) one channel cannot support
    as two (``IdentificationResult.pair_flags``): a close pair
    (:func:`~ema_pipeline.identification.selection.pairs.close_pairs`) whose
    peaks do not show apart (:data:`PAIR_UNDER_ONE_PEAK`), unless the F test
    is calibrated on these data (``calibration``,
    :func:`~ema_pipeline.identification.plscf_final_tests.add_close_partners`) and prefers
    the two poles to one clearly
    (:func:`~ema_pipeline.identification.selection.pairs.pair_significance`
    with the window's line correlation, at least ``pair_clear_significance``);
    and the mode nearest each pole of ``merged``
    (:func:`~ema_pipeline.identification.plscf_final_tests.merge_unsupported_pairs`:
    a second pole beside it was dropped, :data:`SECOND_POLE_DROPPED`)."""
    th = data.thresholds
    if data.Hc.shape[0] >= th.min_shape_channels or judged.size == 0:
        return result
    flags = np.zeros(judged.size, dtype=int)
    for i, j in close_pairs(judged, thresholds=th):
        if peaks_apart(data.freq_hz, data.Hc, judged[i], judged[j], thresholds=th):
            continue
        if calibration is not None and calibration.calibrated and pair_significance(
                data.freq_hz, data.Hc, judged, i, j, data.quantity,
                window_tau_s=data.window_tau_s, thresholds=th) >= th.pair_clear_significance:
            continue  # the data show two modes: the test that found partners says so
        flags[[i, j]] |= PAIR_UNDER_ONE_PEAK
    for p in merged:
        flags[int(np.argmin(np.abs(judged - p)))] |= SECOND_POLE_DROPPED
    return replace(result, pair_flags=flags)


def with_twin_flags(result: IdentificationResult, judged: np.ndarray, twins: list[np.ndarray],
                    thresholds: SelectionThresholds) -> IdentificationResult:
    """Stage 7d: the kept modes (refined poles ``judged``, result order) that
    the final tests found twice with the twins apart: a pole of ``twins``
    (the candidates :func:`~ema_pipeline.identification.selection.acceptance.distinct_shapes`
    dropped as one mode found twice, in any verdict) within the mode's
    half-power band whose frequency lies more than
    ``thresholds.twin_max_sigma`` of the mode's ``fn_std_hz`` from its own
    (the bit :data:`TWIN_APART` of ``pair_flags``, doubtful
    ``found_twice_apart``). Unchanged when no mode has such a twin."""
    twin = np.concatenate([np.zeros(0, dtype=complex), *twins])
    if twin.size == 0 or judged.size == 0:
        return result
    near = poles_overlap(judged, twin)  # (n_modes, n_twins)
    apart = np.abs(pole_fn_hz(twin)[None, :] - pole_fn_hz(judged)[:, None]) > (
        thresholds.twin_max_sigma * np.asarray(result.modes.fn_std_hz, float)[:, None])
    marked = np.any(near & apart, axis=1)
    if not marked.any():
        return result
    flags = np.asarray(result.pair_flags, dtype=int).reshape(-1)
    flags = flags.copy() if flags.size == judged.size else np.zeros(judged.size, dtype=int)
    flags[marked] |= TWIN_APART
    return replace(result, pair_flags=flags)


def with_not_kept(result: IdentificationResult, data: BandData, rejected: list[np.ndarray],
                  kept: np.ndarray) -> IdentificationResult:
    """Stage 7e: the resonances the FRFs show at the ``rejected`` poles away
    from the ``kept`` ones (:func:`resonances_not_kept`); unchanged when the
    final tests did not run."""
    if not rejected:
        return result
    not_kept_hz, not_kept_frfs = resonances_not_kept(data.freq_hz, data.Hc,
                                                     np.concatenate(rejected), kept,
                                                     thresholds=data.thresholds)
    return replace(result, not_kept_hz=not_kept_hz, not_kept_frfs=not_kept_frfs)
