"""Modes picked by hand: the poles a user chose in the stabilization diagram.

A *picks file* (TOML, written by the interactive diagram of the identify
report, :mod:`ema_pipeline.report.stab_diagram`; its layout, reader and
writer are :mod:`ema_pipeline.io.picks`, its content as data
:class:`~ema_pipeline.identification.picked.Picks`) records the settings that
reproduce the diagram (band, orders, weighting) and one ``[[pick]]`` table per
mode:

* a pole of the diagram, by its model ``order``, natural frequency
  ``freq_hz`` and damping ratio ``zeta``: it is looked up in the diagram
  recomputed with the recorded settings, the pole of that order nearest in
  frequency within :data:`PICK_TOL_REL` (a pick that matches no pole is an
  error naming it);
* or the start pole of a mode that the automatic selection kept, given by its
  value ``pole = [re, im]`` (rad/s, before the window correction): the
  trajectory's median pole, or a pole found by the searches outside the
  diagram (windows of a dense band, close partners, residual peaks). The
  stored diagram holds these poles (:attr:`StabilizationData.mode_pole`), the
  report draws them in its top row, and the untouched page lists them, so
  that ``--picks`` with that page's text reproduces the automatic result.

``[diagram]`` may also hold ``companions = [[re, im], ...]`` (rad/s, before the
window correction): poles fitted alongside the picks and not reported. They
are the start poles of the candidates that the automatic selection refined
together with its kept modes and then dropped (a candidate in a mode's local
band bends its fit); the picks fit refines them with the picks and drops
them as well, so the untouched page reproduces the automatic modes exactly.
The page writes them while its picks are mode poles only; a pole picked from
the diagram drops them (it may be the resonance a companion stood for).

:func:`identify_picks` fits exactly the picked poles with the chain of the
automatic modes -- refinement with covariance, the band-sensitivity term,
LSFD, window correction, indicators -- and runs no automatic selection (no
trajectory selection, no final tests, no searches).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ema_pipeline.data import DataError, FRFSet
from ema_pipeline.identification.common import finish_identification, resolve_band
from ema_pipeline.identification.diagram.plscf import plscf
from ema_pipeline.identification.diagram.stabilization import pole_to_modal, stabilization
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.picked import PICK_TOL_REL, Pick, Picks
from ema_pipeline.identification.refinement.lsfd import mpc
from ema_pipeline.identification.refinement.refine import (
    RefinedPoles,
    band_sensitivity,
    refine_poles,
)
from ema_pipeline.identification.result import (
    IdentificationResult,
    ResolvedSettings,
    SelectedPoles,
    StabilizationData,
    found_by_code,
)
from ema_pipeline.identification.selection.trajectories import link_fragments, track_poles

#: ``IdentificationResult.extras`` key set on a result of :func:`identify_picks`
#: (its value: the number of picked modes).
PICKED = "picked_modes"


def picks_from_result(result: IdentificationResult) -> Picks:
    """The picks of an automatic result: every kept mode by its start pole
    (``result.stabilization.mode_pole``), with the result's band, orders,
    weighting and companions (``stabilization.companion_pole``).
    ``identify(frf, picks=picks_from_result(r))`` gives ``r``'s modes again
    (see :func:`identify_picks`)."""
    stab, s = result.stabilization, result.settings
    stored = stab.mode_pole.size == result.pole.size
    start = stab.mode_pole if stored else result.pole - s.window_decay_rate
    companions = tuple(complex(c) for c in stab.companion_pole) if stored else ()
    fn, _, zeta = pole_to_modal(start, s.window_decay_rate)
    picks = tuple(Pick(freq_hz=float(f), zeta=float(z), pole=complex(p))
                  for f, z, p in zip(fn, zeta, start, strict=True))
    return Picks(band_hz=s.band_hz, orders=tuple(int(o) for o in s.orders), picks=picks,
                 weighting=s.weighting, companions=companions)


def diagram_poles(frf: FRFSet, picks: Picks, window_decay_rate: float,
                  options: IdentificationOptions) -> tuple[Any, StabilizationData]:
    """The pLSCF poles of the picks file's diagram (the band's FRFs scaled by
    each output's RMS, as the automatic search does) and its stabilization
    data with trajectory labels."""
    lo, hi = picks.band_hz
    sub = frf.band(lo, hi)
    rms = np.sqrt(np.mean(np.abs(sub.H) ** 2, axis=(1, 2)))
    Hn = sub.H / np.where(rms > 0, rms, 1.0)[:, None, None]
    weights = None
    if picks.weighting == "coherence":
        if sub.coherence is None:
            raise DataError(f"{picks.source}: coherence weighting but the FRFs have no "
                            "coherence")
        weights = np.sqrt(np.clip(np.mean(sub.coherence, axis=1), 0.0, 1.0))
    orders = np.array(sorted(set(picks.orders)), dtype=int)
    poles = plscf(sub.freq_hz, Hn, max_order=int(orders[-1]), orders=orders, weights=weights)
    th = options.thresholds
    traj = link_fragments(poles, track_poles(poles, options.link_tolerances(), thresholds=th),
                          window_decay_rate, min_fraction=options.min_fraction,
                          min_members=th.min_members, thresholds=th)
    f_tol, z_tol, m_tol = options.diagram_tolerances()
    stab = stabilization(poles, window_decay_rate, tol_freq=f_tol, tol_zeta=z_tol,
                         tol_mac=m_tol)
    return poles, replace(stab, cluster=traj)


def match_picks(picks: Picks, stab: StabilizationData) -> tuple[np.ndarray, np.ndarray]:
    """The start pole of every pick (rad/s, before window correction) and the
    trajectory label of the diagram pole it matched (-1 for a pole given by
    value). A diagram pick matches the pole of its order nearest in frequency
    within :data:`PICK_TOL_REL`; a pick that matches none, or two picks of one
    pole, is a :class:`DataError` naming the pick.

    Examples
    --------
    >>> stab = StabilizationData(order=np.array([2, 2]), freq_hz=np.array([30.0, 70.0]),
    ...     zeta=np.array([0.01, 0.02]), flags=np.zeros(2, np.uint8),
    ...     pole=np.array([-1.9 + 188.5j, -8.8 + 439.7j]), cluster=np.array([0, 1]))
    >>> match_picks(Picks((5, 100), (2,), (Pick(70.02, order=2),)), stab)[1].tolist()
    [1]
    >>> match_picks(Picks((5, 100), (2,), (Pick(50.0, order=2),), source="p.toml"), stab)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: p.toml: pick 50 Hz at order 2 matches no pole of the \
diagram (nearest at that order: 30 Hz; band 5-100 Hz, orders 2-2)
    """
    where = f"{picks.source}: " if picks.source else ""
    start = np.zeros(len(picks.picks), dtype=complex)
    cluster = np.full(len(picks.picks), -1, dtype=int)
    used: dict[int, str] = {}
    lo, hi = picks.band_hz
    span = f"band {lo:g}-{hi:g} Hz, orders {min(picks.orders)}-{max(picks.orders)}"
    for k, pk in enumerate(picks.picks):
        if pk.pole is not None:
            if not (pk.pole.real < 0 and lo * 2 * np.pi < pk.pole.imag < hi * 2 * np.pi):
                raise DataError(f"{where}pick {pk.label()}: pole {pk.pole} is not a decaying "
                                f"pole inside the band ({span})")
            start[k] = pk.pole
            continue
        at = np.flatnonzero(stab.order == pk.order)
        if at.size == 0:
            raise DataError(f"{where}pick {pk.label()} matches no pole of the diagram: "
                            f"order {pk.order} is not one of its orders ({span})")
        rel = np.abs(stab.freq_hz[at] - pk.freq_hz) / pk.freq_hz
        j = int(at[np.argmin(rel)])
        if rel.min() > PICK_TOL_REL:
            raise DataError(f"{where}pick {pk.label()} matches no pole of the diagram "
                            f"(nearest at that order: {stab.freq_hz[j]:.6g} Hz; {span})")
        if j in used:
            raise DataError(f"{where}picks {used[j]} and {pk.label()} are the same pole")
        used[j] = pk.label()
        start[k], cluster[k] = stab.pole[j], stab.cluster[j]
    return start, cluster


def identify_picks(frf: FRFSet, options: IdentificationOptions,
                   picks: Picks) -> IdentificationResult:
    """Fit exactly the picked poles (see the module's description).

    ``frf`` has the window applied and ``options`` are checked, as
    :func:`ema_pipeline.identification.identify` (which calls this with
    ``picks=``) does. The diagram is recomputed with the picks file's band,
    orders and weighting; each pick is matched (:func:`match_picks`); the
    start poles are refined together (``options.refine``) with the picks
    file's companions, which are then dropped; their covariance
    gets the band-sensitivity term, and LSFD, window correction and
    indicators follow as for automatic modes. ``result.extras[PICKED]`` is the
    number of picked modes; ``result.not_kept_hz`` is empty (no candidate
    was rejected).

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import ModalParameters
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> frf = FRFSet(freq_hz=f, H=H)
    >>> auto = identify(frf)
    >>> only_70 = replace(picks_from_result(auto), picks=picks_from_result(auto).picks[1:])
    >>> identify(frf, picks=only_70).fn_hz.round(4)
    array([70.])
    """
    decay = float(frf.acquisition.window_decay_rate)
    where = f"{picks.source}: " if picks.source else ""
    lo, hi = resolve_band(frf, picks.band_hz)
    sub = frf.band(lo, hi)
    n_out, n_in, n_freq = sub.H.shape
    poles, stab = diagram_poles(frf, picks, decay, options)
    start, cluster = match_picks(picks, stab)
    order = np.argsort(start.imag, kind="stable")
    start, cluster = start[order], cluster[order]
    th = options.thresholds
    n_members = np.array([np.unique(stab.order[stab.cluster == c]).size if c >= 0 else 0
                          for c in cluster], dtype=int)
    first = np.array([stab.order[stab.cluster == c].min() if c >= 0 else 0
                      for c in cluster], dtype=int)
    nan = np.full(start.size, np.nan)
    sel = SelectedPoles(pole=start, cluster=cluster, n_members=n_members,
                        scatter_fn_hz=nan, scatter_zeta=nan.copy(), first_order=first,
                        found_by=found_by_code("picked", start.size))
    freq = sub.freq_hz
    Hc = sub.H.reshape(n_out * n_in, n_freq)
    cov = None
    tau, force_s = frf.acquisition.exp_window_tau_s, frf.acquisition.force_window_s
    companions = np.array(picks.companions, dtype=complex)
    if options.refine and start.size:
        inside = (companions.real < 0) & (companions.imag > lo * 2 * np.pi) & (
            companions.imag < hi * 2 * np.pi)
        if not inside.all():
            raise DataError(f"{where}companion pole {companions[~inside][0]} is not a decaying "
                            "pole inside the band")
        ref = refine_poles(freq, Hc, np.concatenate([start, companions]), quantity=sub.quantity,
                           window_tau_s=tau, force_window_s=force_s, thresholds=th)
        ref = RefinedPoles(*(np.asarray(a)[: start.size] for a in (
            ref.pole, ref.cov, ref.noise_std, ref.band_hz, ref.n_iter)))
        order_s = np.argsort(ref.pole.imag, kind="stable")
        sel = replace(sel.subset(order_s), pole=ref.pole[order_s])
        start = start[order_s]
        cov = ref.cov[order_s] + band_sensitivity(
            freq, Hc, sel.pole, quantity=sub.quantity, window_tau_s=tau,
            force_window_s=force_s, thresholds=th)
    link = options.link_tolerances()
    stab = replace(stab, mode_pole=start)
    result = finish_identification(
        sub, sel.pole, decay=decay, lower_residual=options.lower_residual,
        upper_residual=options.upper_residual, stab=stab, selected=sel, pole_cov=cov,
        settings=ResolvedSettings(
            method="plscf", band_hz=(lo, hi), max_order=int(poles.orders[-1]),
            orders=poles.orders, dt_s=poles.dt, weighting=picks.weighting,
            window_decay_rate=decay, tol_freq=link[0], tol_zeta=link[1], tol_mac=link[2],
            min_fraction=options.min_fraction, refine=options.refine,
            lower_residual=options.lower_residual, upper_residual=options.upper_residual,
            expect_hz=None,
            uncertainty=("least-squares covariance of the refined poles" if options.refine
                         else "none (picked poles, not refined)"),
            window_searches=False,  # the picked poles are fitted, nothing is searched
            accept=False,  # nor tested
            thresholds=th,
        ),
    )
    return replace(result, extras={**result.extras, PICKED: float(start.size)})


def is_picked(result: IdentificationResult) -> bool:
    """True for a result of :func:`identify_picks` (every mode picked by hand)."""
    return PICKED in getattr(result, "extras", {})


def pole_mpc(freq_hz: np.ndarray, H: np.ndarray, poles: np.ndarray,
             n_lines: int = 16) -> np.ndarray:
    """MPC of each pole's shape in a one-pole local fit (for the diagram's tooltips).

    For every pole the ``n_lines`` lines nearest its damped frequency are
    fitted per channel by ``r / (j w - lambda) + c0 + c1 j w`` (complex linear
    least squares); the MPC (:func:`ema_pipeline.identification.refinement.lsfd.mpc`) of
    the residues r over the channels is returned. A cheap indicator for every
    pole of a diagram, not the MPC of an identified mode (that is ``result.mpc``).

    Parameters
    ----------
    freq_hz : (n_freq,) Hz.   H : (n_ch, n_freq) complex.   poles : (n,) rad/s.

    Examples
    --------
    >>> f = np.linspace(50.0, 150.0, 201)
    >>> lam = -3.0 + 2j * np.pi * 100.0
    >>> H = np.array([[1.0], [-2.0]]) / (2j * np.pi * f - lam)
    >>> pole_mpc(f, H, np.array([lam])).round(6)
    array([1.])
    """
    poles = np.asarray(poles, dtype=complex)
    H = np.atleast_2d(np.asarray(H))
    if poles.size == 0 or freq_hz.size < 3:
        return np.zeros(poles.size)
    L = min(n_lines, freq_hz.size)
    k0 = np.searchsorted(freq_hz, poles.imag / (2 * np.pi))
    start = np.clip(k0 - L // 2, 0, freq_hz.size - L)
    idx = start[:, None] + np.arange(L)[None, :]  # (n, L)
    jw = 2j * np.pi * freq_hz[idx]
    A = np.stack([1.0 / (jw - poles[:, None]), np.ones_like(jw), jw / jw.std(axis=1,
                 keepdims=True).clip(1e-30)], axis=2)  # (n, L, 3)
    Y = np.transpose(H[:, idx], (1, 2, 0))  # (n, L, n_ch)
    coef = np.linalg.pinv(A) @ Y  # (n, 3, n_ch)
    return np.asarray(mpc(coef[:, 0, :].T))
