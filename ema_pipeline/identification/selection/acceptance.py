"""Which refined candidates are modes: the final tests of the ``"plscf"``
backend, and the step that adds the modes found outside the diagrams.

Every candidate of :func:`~ema_pipeline.identification.plscf_backend.identify_plscf`
(a trajectory of a diagram, a close partner, a residual peak) is refined by
:func:`~ema_pipeline.identification.refinement.refine.refine_poles` and then judged here
(:func:`final_tests`):

1. its decay rate is determined
   (:func:`~ema_pipeline.identification.refinement.refine.decay_determined`,
   ``max_rel_decay_std``);
2. it is a resonance of the data (:func:`resonant`): its own peak, its peak
   over the local residual, or with 3 or more channels a nearly real shape
   in its own local fit;
3. it is not one mode found twice (:func:`distinct_shapes`), nor the split of
   a neighbour (a complex shape beside a real one).

The candidates that pass are refined and tested again without those that
failed (:func:`refit_kept`); where a candidate of the full band failed, the
candidate of a narrower search that it covered is tried
(:func:`~ema_pipeline.identification.diagram.narrower_searches.uncovered_alternates`,
through :func:`add_found`).

Close modes hidden in a kept resonance are looked for by
:func:`.close_partners` (one
pole more in that mode's local fit); those and the starts of
:func:`~ema_pipeline.identification.selection.residual_search.residual_peaks` join the
kept modes through :func:`add_found`, which refines and tests all together
and keeps the previous fit when none of the new ones passes.

The thresholds (``weak_peak_ratio``, ``max_rel_decay_std``, ...) are fields
of :class:`~ema_pipeline.identification.thresholds.SelectionThresholds`,
passed in as ``thresholds``; they were chosen on the measured beam
(``../shared/data``) and the hard families of ``tests/hardcases.py``, and each
field's comment there says on what.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ema_pipeline.identification.refinement.local_band import (
    background_columns,
    global_residues,
    local_problem,
    pole_columns,
    scaled_solve,
)
from ema_pipeline.identification.refinement.local_fits import (
    local_shapes,
    quick_significance,
)
from ema_pipeline.identification.refinement.lsfd import lsfd, mpc
from ema_pipeline.identification.refinement.refine import (
    RefinedPoles,
    decay_determined,
)
from ema_pipeline.identification.result import SelectedPoles, found_by_code
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import mac, pole_fd_hz


@dataclass(frozen=True)
class Candidates:
    """Candidates, their refinement and the verdict of :func:`final_tests`
    (``keep``); ``partner`` and ``strict`` mark how each was found (the
    arguments of :func:`final_tests`)."""

    sel: SelectedPoles
    ref: RefinedPoles
    keep: np.ndarray
    partner: np.ndarray
    strict: np.ndarray

    def kept_poles(self) -> np.ndarray:
        """The refined poles that passed."""
        return np.asarray(self.ref.pole[self.keep])


def add_found(
    found: Candidates,
    new: np.ndarray,
    *,
    partner: bool,
    strict: np.ndarray,
    retest: Callable[[SelectedPoles, np.ndarray, np.ndarray], tuple[RefinedPoles, np.ndarray]],
    found_by: str = "residual",
    screen: Callable[[SelectedPoles, np.ndarray], np.ndarray] | None = None,
) -> Candidates:
    """``found``'s kept candidates plus the start poles ``new`` (found outside
    the diagrams, each ``partner`` or not, ``strict`` per pole), refined and
    tested together by ``retest(candidates, partner, strict)`` -> (refined,
    keep); ``found_by`` says how ``new`` were found (``SelectedPoles.found_by``).
    When none of ``new`` passes, ``found`` stands (a failed candidate bends
    its neighbours' local fits: on the measured beam two model-error
    peaks beside 414.6 Hz cost that mode); else the fit is repeated with
    those that pass until all do.

    ``screen(candidates, indices)`` says which of the candidates at
    ``indices`` (the new ones) can pass at all, before the fit of all of
    them (:meth:`~ema_pipeline.identification.plscf_final_tests.Retest.could_pass`:
    the tests of each pole on its own local fit); where none can, that fit
    is not made, and ``found`` stands as it would after it. On a simulated
    paper file the residual peaks of the noise, whose decay rates the data
    do not determine, cost the fit of every mode again (0.07-0.18 s). Those
    that cannot pass leave before the fit (it would fail them and be
    repeated without them), and the rest are screened again among the kept
    ones alone: on the pyFRF recording four of six residual peaks cannot
    pass, and the fit of all 40 poles that failed them is not made.

    Examples
    --------
    >>> none = SelectedPoles(*(np.zeros(0) for _ in range(5)))
    >>> empty = Candidates(none, None, np.zeros(0, bool), np.zeros(0, bool), np.zeros(0, bool))
    >>> add_found(empty, np.zeros(0, complex), partner=False, strict=np.zeros(0, bool),
    ...           retest=None) is empty
    True
    """
    is_partner = np.full(new.size, partner)
    while new.size:
        sel = found.sel.subset(found.keep).concatenate(unseen_candidates(new, found_by))
        partner_all = np.concatenate([found.partner[found.keep], is_partner])
        strict_all = np.concatenate([found.strict[found.keep], strict])
        if screen is not None:
            can = screen(sel, np.arange(sel.pole.size - new.size, sel.pole.size))
            if not can.any():
                break
            if not can.all():  # those that cannot pass leave before the fit of all
                new, is_partner, strict = new[can], is_partner[can], strict[can]
                continue
        ref, keep = retest(sel, partner_all, strict_all)
        passed = keep[-new.size:]
        if not passed.any():
            break
        if passed.all():
            return Candidates(sel, ref, keep, partner_all, strict_all)
        new, is_partner, strict = new[passed], is_partner[passed], strict[passed]
    return found


def refit_kept(
    found: Candidates,
    retest: Callable[[SelectedPoles, np.ndarray, np.ndarray], tuple[RefinedPoles, np.ndarray]],
    rounds: int,
) -> Candidates:
    """``found``'s kept candidates refined and tested again without those that
    failed (``retest`` as in :func:`add_found`), repeated while some fail.

    A failed candidate bends its neighbours' local fits: on the measured beam
    a pole of zeta 1.1 % at 362.3 Hz, which fails the resonance test, shares
    the 362.8 Hz peak with the kept pole and pushes it to 363.9 Hz in the
    bands 5-790 and 250-700 Hz; refined without it, the kept pole is
    362.86 Hz, as without a band. A candidate that passed and fails once
    refined alone is dropped (its verdict leaned on the failed one).

    Examples
    --------
    >>> none = SelectedPoles(*(np.zeros(0) for _ in range(5)))
    >>> empty = Candidates(none, None, np.zeros(0, bool), np.zeros(0, bool), np.zeros(0, bool))
    >>> refit_kept(empty, None, SelectionThresholds().refit_rounds) is empty
    True
    """
    for _ in range(rounds):
        if found.keep.all() or not found.keep.any():
            return found
        sel = found.sel.subset(found.keep)
        partner, strict = found.partner[found.keep], found.strict[found.keep]
        ref, keep = retest(sel, partner, strict)
        found = Candidates(sel, ref, keep, partner, strict)
    return found


def unseen_candidates(pole: np.ndarray, found_by: str = "residual") -> SelectedPoles:
    """Candidates found outside the diagrams (trajectory label -1, no orders),
    found by ``found_by`` (an entry of :data:`~ema_pipeline.identification.result.FOUND_BY`).

    Examples
    --------
    >>> unseen_candidates(np.array([-1 + 100j])).cluster.tolist()
    [-1]
    """
    n = pole.size
    return SelectedPoles(pole, np.full(n, -1), np.zeros(n, int), np.zeros(n), np.zeros(n),
                         np.zeros(n, int), found_by_code(found_by, n))


def inside_band(freq_hz: np.ndarray, pole: np.ndarray,
                *, thresholds: SelectionThresholds) -> np.ndarray:
    """True where the damped natural frequency of ``pole`` lies inside the band
    of the lines ``freq_hz`` less the fractions ``thresholds.band_edge`` of its
    width at the bottom and the top, as the selection asks of a trajectory: a
    refined pole or a residual peak that ends up beyond it models what lies
    outside the band (band 100-400 Hz of the measured beam: a pole of zeta
    6 % at 405 Hz, the tail of its 414 Hz mode).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(100.0, 400.0, 301)
    >>> inside_band(f, 2j * np.pi * np.array([150.0, 395.0, 405.0]), thresholds=th).tolist()
    [True, False, False]
    """
    th = thresholds
    lo, hi = float(freq_hz[0]), float(freq_hz[-1])
    fd = pole_fd_hz(np.asarray(pole))
    return np.asarray((fd > lo + th.band_edge[0] * (hi - lo))
                      & (fd < hi - th.band_edge[1] * (hi - lo)))


def final_tests(
    freq_hz: np.ndarray,
    H: np.ndarray,
    Hn: np.ndarray,
    refined: RefinedPoles,
    quantity: str,
    n_orders: np.ndarray | None = None,
    partner: np.ndarray | None = None,
    strict: np.ndarray | None = None,
    *,
    thresholds: SelectionThresholds,
) -> tuple[np.ndarray, np.ndarray]:
    """Which ``refined`` poles are modes (thresholds of ``thresholds``): their
    decay rate is determined
    (:func:`~ema_pipeline.identification.refinement.refine.decay_determined`),
    they are resonances (:func:`resonant`, judged among the determined poles only: an undetermined
    one takes part of a neighbour's response and bends its shape) and not one
    mode twice (:func:`distinct_shapes`). ``H`` (n_ch, n_freq) the FRFs,
    ``Hn`` the same normalised per FRF. Poles marked ``partner`` (found by
    :func:`.close_partners`, whose tests -- a residual that drops by a quarter
    or more, two nearly real shapes -- already show a resonance) skip the
    resonance test; a weak partner's shape in its neighbour's shadow has an
    MPC of 0.9-0.95, which the resonance test asks only of lone weak poles.
    Poles marked ``strict`` (a residual slope into the band's edge,
    :func:`~ema_pipeline.identification.selection.residual_search.residual_peaks`) must
    pass the resonance test by their peak, not by their shape alone.

    Returns ``keep`` and ``twin``: the poles that passed every other test and
    that :func:`distinct_shapes` dropped as one mode found twice (the
    doubtful rule ``found_twice_apart`` reads them).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.ones((3, 1))
    >>> H = H + 1e-5 * np.random.default_rng(1).standard_normal(H.shape)
    >>> from ema_pipeline.identification.refinement.refine import refine_poles
    >>> ref = refine_poles(f, H, lam, quantity="receptance", thresholds=th)
    >>> keep, twin = final_tests(f, H, H, ref, "receptance", thresholds=th)
    >>> keep.tolist(), twin.tolist()
    ([True], [False])
    """
    keep = decay_determined(refined.pole, refined.cov, thresholds=thresholds) & inside_band(
        freq_hz, refined.pole, thresholds=thresholds)
    by_shape = None if strict is None else ~strict[keep]
    keep[keep] = resonant(freq_hz, Hn, refined.pole[keep], quantity, by_shape=by_shape,
                          thresholds=thresholds)
    if partner is not None:
        keep |= (decay_determined(refined.pole, refined.cov, thresholds=thresholds) & partner
                 & inside_band(freq_hz, refined.pole, thresholds=thresholds))
    distinct = keep & distinct_shapes(freq_hz, H, refined.pole, quantity, keep, n_orders,
                                      thresholds=thresholds)
    return distinct, keep & ~distinct


def resonant(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str = "accelerance",
    by_shape: np.ndarray | None = None,
    *,
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """True for poles that are resonances of the data: own peak ratio at least
    ``weak_peak_ratio``, or peak SNR at least ``min_weak_peak_snr``
    (both from :func:`~ema_pipeline.identification.refinement.local_fits.quick_significance`),
    or, with at least 3 channels ``H`` (n_ch, n_freq), whatever the shape
    (complex modes too), a peak SNR of at least ``complex_min_snr`` with a
    residual drop (:func:`residual_drop`) of at least
    ``complex_min_residual_drop``, or a local shape
    (:func:`~ema_pipeline.identification.refinement.local_fits.local_shapes`) of
    MPC >= ``weak_min_mpc`` (only the poles marked ``by_shape``, when
    given); with fewer channels every pole is kept. Thresholds of
    ``thresholds``.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0, -2.0 + 2j * np.pi * 120.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.ones((3, 1))
    >>> H = H + 1e-3 * np.random.default_rng(1).standard_normal(H.shape) * (1 + 1j)
    >>> resonant(f, H, lam, "receptance", thresholds=th).tolist()
    [True, False]
    """
    th = thresholds
    shape_ok = np.ones(pole.size, bool) if by_shape is None else np.asarray(by_shape, bool)
    if H.shape[0] < th.min_shape_channels and np.all(shape_ok):
        return np.ones(pole.size, bool)
    _, peak, snr = quick_significance(freq_hz, H, pole, thresholds=th)
    ok = (peak >= th.weak_peak_ratio) | (snr >= th.min_weak_peak_snr)
    if np.all(ok | ~shape_ok):
        return np.asarray(ok)
    if H.shape[0] < th.min_shape_channels:
        return np.asarray(ok | shape_ok)
    # complex or real: a clear peak whose own term explains its local residual
    ask = ~ok & shape_ok & (snr >= th.complex_min_snr)
    if ask.any():
        drop = np.nan_to_num(residual_drop(freq_hz, H, pole, quantity, thresholds=th, only=ask))
        ok |= ask & (drop >= th.complex_min_residual_drop)
        if np.all(ok | ~shape_ok):
            return np.asarray(ok)
    try:
        shapes = local_shapes(freq_hz, H, pole, quantity=quantity, thresholds=th).T
    except (np.linalg.LinAlgError, ValueError):
        return np.asarray(ok | shape_ok)
    return np.asarray(ok | (shape_ok & (np.nan_to_num(mpc(shapes)) >= th.weak_min_mpc)))


def residual_drop(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str | None = "accelerance",
    *,
    thresholds: SelectionThresholds,
    only: np.ndarray | None = None,
) -> np.ndarray:
    """For each pole (of those marked ``only``, when given; NaN for the
    others), the residual of its local problem without it over the
    residual with it (sums of squares over the local band and all channels;
    the problem of :func:`~ema_pipeline.identification.refinement.local_band.local_problem`
    at the given poles, its residues and background solved linearly); NaN
    where the band is too short.

    A pole that models noise lowers the residual by the share of its
    parameters, 2 n_ch + 2 of 2 n_lines n_ch equations: a ratio near 1. A
    resonance leaves, without its own term, its own response in the
    residual: a ratio far above 1, whatever the phase of its residues across
    the channels (complex modes as normal ones).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0, -2.0 + 2j * np.pi * 120.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.array([[1], [1j], [-1]])
    >>> H = H + 1e-4 * np.random.default_rng(1).standard_normal(H.shape)
    >>> drop = residual_drop(f, H, lam, "receptance", thresholds=th)
    >>> bool(drop[0] > 100), bool(drop[1] < 1.5)
    (True, True)
    """
    th = thresholds
    a_all = global_residues(freq_hz, H, pole, quantity)
    out = np.full(pole.size, np.nan)
    for r in np.flatnonzero(np.ones(pole.size, bool) if only is None else only).tolist():
        local = local_problem(freq_hz, H, pole, r, th.local_half_width, th.local_min_lines,
                              a_all, thresholds=th)
        if local is None:
            continue
        f, Y, members, background, k, _ = local
        A = pole_columns(f, pole[members], background_columns(background))
        others = np.delete(np.arange(A.shape[1]), [2 * k, 2 * k + 1])
        try:
            with_r = np.sum(scaled_solve(A, Y)[1] ** 2)
            without_r = np.sum(scaled_solve(A[:, others], Y)[1] ** 2)
        except np.linalg.LinAlgError:
            continue
        out[r] = without_r / max(with_r, 1e-300)
    return out


def distinct_shapes(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str,
    keep: np.ndarray,
    n_orders: np.ndarray | None = None,
    *,
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """``keep`` less duplicates: of two kept poles that coincide within their
    half-power bands and have parallel LSFD shapes (MAC >
    ``thresholds.duplicate_min_mac``) one stays (one mode found twice): the
    one stable at more model orders ``n_orders``, else (equal or not given)
    the one with the larger response. Close modes with different shapes stay
    apart, unless one of them is the split of the other (see
    ``split_max_mpc``, ``split_mpc_gap``, ``split_max_gap``: less than 2 %
    apart by default). Both tests judge neighbours closer than the sum of
    their decay rates only: where none are, no LSFD is solved.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0, -2.0 + 2j * np.pi * 100.1])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.ones((3, 1))
    >>> distinct_shapes(f, H, lam, "receptance", np.array([True, True]), thresholds=th).sum()
    np.int64(1)
    """
    th = thresholds
    out = keep.copy()
    idx = np.flatnonzero(keep)
    if idx.size < 2:
        return out
    s = np.argsort(pole[idx].imag)
    # each neighbour pair (ascending frequency): its gap and the sum of its
    # decay rates; both tests below judge pairs closer than that sum only:
    # with none, the shapes are not needed and no LSFD is solved (the pyFRF
    # recording: one LSFD of 34 poles over 4487 lines, 29 ms, saved)
    ordered = pole[idx][s]
    gaps = np.abs(np.diff(ordered.imag))
    widths = np.abs(ordered.real[:-1]) + np.abs(ordered.real[1:])
    if not np.any(gaps < widths):
        return out
    try:
        fit = lsfd(freq_hz, H, pole[idx], quantity)
    except (np.linalg.LinAlgError, ValueError):
        return out
    M = mac(fit.a.T)
    collinear = mpc(fit.a.T)
    for a, b, gap, width in zip(s[:-1], s[1:], gaps, widths, strict=True):
        if not (out[idx[a]] and out[idx[b]]):
            continue
        pa, pb = pole[idx[a]], pole[idx[b]]
        if gap < 0.5 * width and M[a, b] > th.duplicate_min_mac:
            na, nb = np.linalg.norm(fit.a[a]), np.linalg.norm(fit.a[b])
            if n_orders is not None and n_orders[idx[a]] != n_orders[idx[b]]:
                na, nb = n_orders[idx[a]], n_orders[idx[b]]
            out[idx[b] if na >= nb else idx[a]] = False
        elif gap < min(width, th.split_max_gap * max(pa.imag, pb.imag)) and min(
                collinear[a], collinear[b]) < th.split_max_mpc and (
                abs(collinear[a] - collinear[b]) >= th.split_mpc_gap):
            out[idx[a] if collinear[a] < collinear[b] else idx[b]] = False
    return out
