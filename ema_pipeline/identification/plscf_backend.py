"""The ``"plscf"`` backend of :func:`ema_pipeline.identification.identify`:
pLSCF diagrams of adaptive order, pole trajectories, refinement with
covariance, LSFD and per-mode quality.

Candidates: the adaptive order search of
:mod:`~ema_pipeline.identification.order_search` (diagrams of growing
order, pole trajectories, the searches of a wide band's lowest part and of
windows of a dense band).

Selection: every selected trajectory's pole is refined by the local fit of
:func:`~ema_pipeline.identification.refine.refine_poles`; it is kept when the
refined decay rate is determined, when it is a resonance of the data and
when it is not the same mode found twice (the final tests of
:mod:`ema_pipeline.identification.acceptance`). Then two searches look for
modes that the diagrams missed: close modes hidden in a kept resonance
(:func:`~ema_pipeline.identification.acceptance.close_partners`) and peaks of the residual of
the kept modes' fit
(:func:`~ema_pipeline.identification.residual_search.residual_peaks`; on four
seed ranges of the hard cases, 2712 modes, missed 22 -> 1). Their candidates
are refined and tested together with the kept ones; when none passes, the
previous fit stands (a failed candidate bends its neighbours' local fits:
on the measured beam two model-error peaks beside 414.6 Hz cost that mode),
else the fit is repeated with those that pass.

``options.accept`` switches these final tests and searches (off: every
selected candidate is kept, untested); ``options.refine`` decides whether the
kept modes are reported at their refined poles or at their start poles (the
final tests judge refined poles either way).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ema_pipeline.data import FRFSet
from ema_pipeline.identification.acceptance import (
    Candidates,
    add_found,
    close_partners,
    decay_determined,
    final_tests,
    refit_kept,
)
from ema_pipeline.identification.common import (
    default_max_order,
    finish_identification,
    resolve_band,
)
from ema_pipeline.identification.narrower_searches import (
    band_support,
    shown_by_the_frfs,
    uncovered_alternates,
)
from ema_pipeline.identification.not_kept import resonances_not_kept
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.order_search import (
    OrderSearch,
    SearchedBand,
    add_window_modes,
    add_zoom_modes,
)
from ema_pipeline.identification.refine import RefinedPoles, band_sensitivity, refine_poles
from ema_pipeline.identification.residual_search import residual_peaks
from ema_pipeline.identification.resources import order_cap
from ema_pipeline.identification.result import (
    IdentificationResult,
    ResolvedSettings,
    found_by_code,
)
from ema_pipeline.identification.selection import (
    SelectedPoles,
    expected_from_automatic,
    select_expected,
)
from ema_pipeline.identification.stabilization import StabilizationData, stabilization
from ema_pipeline.modal import poles_overlap
from ema_pipeline.threads import Mapper, available_cores, process_map


def identify_plscf(frf: FRFSet, options: IdentificationOptions) -> IdentificationResult:
    """Identify with this package's pLSCF chain.

    Called by :func:`ema_pipeline.identification.identify`, which checks the
    FRF set and the options first (band, order, coherence, ``expect_hz``
    sorted and inside the band) and applies ``options.exp_window_tau_s``;
    call that, not this, with unchecked input. Independent work (the
    companion eigenvalues of a large diagram, the searches of a dense band's
    windows, the local fits of the modes) is shared out among worker
    processes (:func:`ema_pipeline.threads.process_map`: the cores, or
    ``$EMA_PIPELINE_WORKERS``); the numbers are those of one process.
    """
    with process_map(available_cores()) as map_:
        return identify_with(frf, options, map_)


def identify_with(frf: FRFSet, options: IdentificationOptions,
                  map_: Mapper) -> IdentificationResult:
    """:func:`identify_plscf` with the worker processes of ``map_``."""
    lo, hi = resolve_band(frf, options.band_hz)
    sub = frf.band(lo, hi)
    n_out, n_in, n_freq = sub.H.shape
    cap = order_cap(n_freq, n_in)
    fixed = options.max_order is not None
    p = min(default_max_order(n_in, n_freq), cap)
    if options.max_order is not None:
        p = int(options.max_order)
    expect_hz = np.asarray(options.expect_hz, dtype=float) if options.expect_hz else None
    decay = float(frf.acquisition.window_decay_rate)
    freq = sub.freq_hz
    th = options.thresholds
    rms = np.sqrt(np.mean(np.abs(sub.H) ** 2, axis=(1, 2)))
    Hn = sub.H / rms[:, None, None]
    Hn_c = Hn.reshape(n_out * n_in, n_freq)
    min_peak = th.min_peak_ratio_shapes if n_out * n_in >= 3 else th.min_peak_ratio
    weights = None
    if options.weighting == "coherence":
        assert sub.coherence is not None  # identify() refuses coherence weighting without it
        weights = np.sqrt(np.clip(np.mean(sub.coherence, axis=1), 0.0, 1.0))

    link_freq, link_zeta, link_mac = options.link_tolerances()
    search = OrderSearch(weights=weights, window_decay_rate=decay, min_peak=min_peak,
                         min_fraction=options.min_fraction, expect=expect_hz is not None,
                         thresholds=th, tolerances=(link_freq, link_zeta, link_mac),
                         map_=map_)
    sel, traj, poles = search.run(freq, Hn, (lo, hi), p, cap, fixed)
    # the narrower searches: bands, candidates, those covered by one already there
    searched: list[SearchedBand] = []
    if not fixed and expect_hz is None:
        sel = add_zoom_modes(sel, search, freq, Hn, (lo, hi), searched)
        if options.window_searches:
            sel = add_window_modes(sel, search, freq, Hn, (lo, hi), searched)
    p = int(poles.orders[-1])
    diagram_freq, diagram_zeta, diagram_mac = options.diagram_tolerances()
    stab = stabilization(
        poles, decay, tol_freq=diagram_freq, tol_zeta=diagram_zeta, tol_mac=diagram_mac,
    )
    stab = StabilizationData(**{**stab.__dict__, "cluster": traj})
    # with expected frequencies: the automatic selection's other modes and
    # dropped candidates, refined alongside the expected poles and then dropped
    neighbours = np.zeros(0, dtype=complex)
    n_kept_neighbours = 0
    auto: IdentificationResult | None = None
    if expect_hz is not None:
        sel = select_expected(sel, expect_hz, decay, thresholds=th)
        sel = replace(sel, found_by=found_by_code("expected", sel.pole.size))
        if options.refine:
            auto = identify_with(frf, replace(options, expect_hz=()), map_)
            auto_start = auto.stabilization.mode_pole
            sel, rest = expected_from_automatic(sel, expect_hz, auto.fn_hz, auto_start, decay,
                                                thresholds=th)
            dropped = auto.stabilization.companion_pole
            if sel.pole.size and dropped.size:  # none on a pole of the expected ones
                dropped = dropped[~np.any(poles_overlap(dropped, sel.pole), axis=1)]
            neighbours = np.concatenate([auto_start[rest], dropped])
            n_kept_neighbours = rest.size

    Hc = sub.H.reshape(n_out * n_in, n_freq)
    cov = None
    tau, force_s = frf.acquisition.exp_window_tau_s, frf.acquisition.force_window_s
    rejected: list[np.ndarray] = []  # refined candidates that failed the final tests
    start = sel.pole  # the kept modes' start poles, stored with the diagram (--picks)
    # the start poles of the candidates refined with them and then dropped
    companions = np.zeros(0, dtype=complex)
    # the final tests judge refined poles: with ``accept``, the candidates are
    # refined even when ``refine`` is off (then the start poles are reported)
    judged = options.accept and expect_hz is None
    judged_poles = sel.pole  # the kept modes' poles as the final tests saw them
    if (options.refine or judged) and sel.pole.size:
        ref = refine_poles(freq, Hc, np.concatenate([sel.pole, neighbours]),
                           quantity=sub.quantity, window_tau_s=tau, force_window_s=force_s,
                           thresholds=th, map_=map_)
        m = sel.pole.size
        near = ref.pole[m : m + n_kept_neighbours]  # the automatic modes' refined poles
        ref = RefinedPoles(*(np.asarray(a)[:m] for a in (
            ref.pole, ref.cov, ref.noise_std, ref.band_hz, ref.n_iter)))
        keep = np.ones(sel.pole.size, bool)
        if judged:

            def retest(c: SelectedPoles, partner: np.ndarray,
                       strict: np.ndarray) -> tuple[RefinedPoles, np.ndarray]:
                r = refine_poles(freq, Hc, c.pole, quantity=sub.quantity, window_tau_s=tau,
                                 force_window_s=force_s, thresholds=th, map_=map_)
                ok = final_tests(freq, Hc, Hn_c, r, sub.quantity, c.n_members,
                                 partner=partner, strict=strict, thresholds=th)
                rejected.append(r.pole[~ok & decay_determined(r.pole, r.cov, th)])
                return r, ok

            none = np.zeros(sel.pole.size, bool)
            found = Candidates(sel, ref, final_tests(freq, Hc, Hn_c, ref, sub.quantity,
                                                     sel.n_members, thresholds=th), none, none)
            rejected.append(ref.pole[~found.keep & decay_determined(ref.pole, ref.cov, th)])
            # the kept candidates refined without those that failed
            found = refit_kept(found, retest, th.refit_rounds)
            # where a candidate failed, the narrower searches' candidate it covered
            alt = uncovered_alternates(found.kept_poles(), [e[2] for e in searched])
            alt = alt[shown_by_the_frfs(freq, Hc, alt, th)]
            found = add_found(found, alt, False, np.zeros(alt.size, bool), retest, "alternate")
            # close modes hidden in a kept resonance, then modes that no
            # diagram resolved (peaks of the residual)
            partners = close_partners(freq, Hc, found.kept_poles(), sub.quantity,
                                      window_tau_s=tau, force_window_s=force_s, thresholds=th)
            found = add_found(found, partners, True, np.zeros(partners.size, bool), retest,
                              "partner")
            # starts from a slope into the band's edge (a mode outside the band
            # looks the same) must pass the resonance test by their peak
            peaks, from_edge = residual_peaks(freq, Hc, found.kept_poles(), sub.quantity,
                                              thresholds=th)
            found = add_found(found, peaks, False, from_edge, retest, "residual")
            sel, ref, keep = found.sel, found.ref, found.keep
        companions = np.concatenate([sel.pole[~keep], neighbours])
        order_s = np.argsort(ref.pole[keep].imag)
        judged_poles = ref.pole[keep][order_s]
        if options.refine:
            start = sel.pole[keep][order_s]
            sel = replace(sel.subset(keep), pole=ref.pole[keep]).subset(order_s)
            cov = ref.cov[keep][order_s]
            # the local model's own error (band choice), added in quadrature
            cov = cov + band_sensitivity(freq, Hc, np.concatenate([sel.pole, near]),
                                         quantity=sub.quantity, window_tau_s=tau,
                                         force_window_s=force_s, thresholds=th,
                                         map_=map_)[: sel.pole.size]
        else:  # the start poles of the candidates that passed, their scatter (none
            # for a candidate found outside the diagrams)
            sel = sel.subset(keep)
            sel = sel.subset(np.argsort(sel.pole.imag))
            start = sel.pole
            none = sel.n_members == 0
            sel = replace(sel, scatter_fn_hz=np.where(none, np.nan, sel.scatter_fn_hz),
                          scatter_zeta=np.where(none, np.nan, sel.scatter_zeta))
    result = finish_identification(
        sub,
        sel.pole,
        decay=decay,
        lower_residual=options.lower_residual,
        upper_residual=options.upper_residual,
        stab=replace(stab, mode_pole=start, companion_pole=companions),
        selected=sel,
        pole_cov=cov,
        settings=ResolvedSettings(
            method="plscf",
            band_hz=(lo, hi),
            max_order=p,
            orders=poles.orders,
            dt_s=poles.dt,
            weighting=options.weighting,
            window_decay_rate=decay,
            tol_freq=link_freq,
            tol_zeta=link_zeta,
            tol_mac=link_mac,
            min_fraction=options.min_fraction,
            refine=options.refine,
            lower_residual=options.lower_residual,
            upper_residual=options.upper_residual,
            expect_hz=expect_hz,
            uncertainty="least-squares covariance of the refined poles"
            if options.refine
            else "scatter of the trajectory's poles over model orders",
            window_searches=options.window_searches,
            accept=options.accept,
            thresholds=th,
        ),
    )
    if auto is not None:  # --expect: the automatic modes' support, where the pole is theirs
        support = np.zeros((result.fn_hz.size, 2), dtype=int)
        if auto.band_support.shape[0] == auto.fn_hz.size:
            for i, f_hz in enumerate(result.fn_hz):
                same = np.flatnonzero(np.isclose(auto.fn_hz, f_hz, rtol=1e-6, atol=0.0))
                if same.size:
                    support[i] = auto.band_support[same[0]]
        result = replace(result, band_support=support)
    elif searched:
        result = replace(result, band_support=band_support(sel.pole, searched, th))
    if not rejected:
        return result
    not_kept_hz, not_kept_frfs = resonances_not_kept(freq, Hc, np.concatenate(rejected),
                                                     judged_poles, th)
    return replace(result, not_kept_hz=not_kept_hz, not_kept_frfs=not_kept_frfs)
