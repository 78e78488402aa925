"""Which refined candidates are modes: the final tests of the ``"plscf"``
backend, and the step that adds the modes found outside the diagrams.

Every candidate of :func:`~ema_pipeline.identification.plscf_backend.identify_plscf`
(a trajectory of a diagram, a close partner, a residual peak) is refined by
:func:`~ema_pipeline.identification.refinement.refine.refine_poles` and then judged here
(:func:`final_tests`):

1. its decay rate is determined (:func:`decay_determined`,
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
:func:`close_partners` (one pole more in that mode's local fit,
:func:`pair_is_real`); those and the starts of
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
from statistics import NormalDist

import numpy as np

from ema_pipeline.identification.refinement.local_band import (
    WeightedPoleDesign,
    background_columns,
    global_residues,
    local_problem,
    pole_columns,
    scaled_solve,
)
from ema_pipeline.identification.refinement.local_fits import (
    local_shapes,
    quick_significance,
    split_fit,
)
from ema_pipeline.identification.refinement.lsfd import lsfd, mpc
from ema_pipeline.identification.refinement.refine import (
    PARALLEL_MIN_MODES,
    RefinedPoles,
    vp_fit,
)
from ema_pipeline.identification.refinement.uncertainty import exponential_window_correlation
from ema_pipeline.identification.result import SelectedPoles, found_by_code
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import mac, pole_fd_hz, pole_half_width_hz
from ema_pipeline.runner import Mapper, map_each


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
    them (:meth:`~ema_pipeline.identification.plscf_backend.Retest.could_pass`:
    the tests of each pole on its own local fit); where none can, that fit
    is not made, and ``found`` stands as it would after it. On a simulated
    paper file the residual peaks of the noise, whose decay rates the data
    do not determine, cost the fit of every mode again (0.07-0.18 s).

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
        if screen is not None and not screen(sel, np.arange(sel.pole.size - new.size,
                                                             sel.pole.size)).any():
            break
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
    rounds: int = SelectionThresholds.refit_rounds,
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
    >>> refit_kept(empty, None) is empty
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


def decay_determined(pole: np.ndarray, cov: np.ndarray,
                     thresholds: SelectionThresholds | None = None) -> np.ndarray:
    """True where the decay rate sigma = -Re(pole) is determined:
    std(sigma) / sigma < ``thresholds.max_rel_decay_std``; ``cov`` (n, 2, 2)
    is the covariance of (Re, Im) of each pole, in (rad/s)^2.

    Examples
    --------
    >>> pole = np.array([-2.0 + 600j, -2.0 + 900j])
    >>> cov = np.array([np.diag([0.1, 0.1]), np.diag([2.5, 2.5])])  # std 0.32 and 1.6 rad/s
    >>> decay_determined(pole, cov).tolist()
    [True, False]
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.sqrt(np.asarray(cov)[:, 0, 0]) / np.abs(np.real(pole))
    limit = (thresholds or SelectionThresholds()).max_rel_decay_std
    return np.asarray(np.nan_to_num(rel, nan=np.inf) < limit)


def inside_band(freq_hz: np.ndarray, pole: np.ndarray,
                thresholds: SelectionThresholds | None = None) -> np.ndarray:
    """True where the damped natural frequency of ``pole`` lies inside the band
    of the lines ``freq_hz`` less the fractions ``thresholds.band_edge`` of its
    width at the bottom and the top, as the selection asks of a trajectory: a
    refined pole or a residual peak that ends up beyond it models what lies
    outside the band (band 100-400 Hz of the measured beam: a pole of zeta
    6 % at 405 Hz, the tail of its 414 Hz mode).

    Examples
    --------
    >>> f = np.linspace(100.0, 400.0, 301)
    >>> inside_band(f, 2j * np.pi * np.array([150.0, 395.0, 405.0])).tolist()
    [True, False, False]
    """
    th = thresholds or SelectionThresholds()
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
    thresholds: SelectionThresholds | None = None,
) -> np.ndarray:
    """Which ``refined`` poles are modes (thresholds of ``thresholds``): their decay rate is
    determined (:func:`decay_determined`), they are resonances
    (:func:`resonant`, judged among the determined poles only: an undetermined
    one takes part of a neighbour's response and bends its shape) and not one
    mode twice (:func:`distinct_shapes`). ``H`` (n_ch, n_freq) the FRFs,
    ``Hn`` the same normalised per FRF. Poles marked ``partner`` (found by
    :func:`close_partners`, whose tests -- a residual that drops by a quarter
    or more, two nearly real shapes -- already show a resonance) skip the
    resonance test; a weak partner's shape in its neighbour's shadow has an
    MPC of 0.9-0.95, which the resonance test asks only of lone weak poles.
    Poles marked ``strict`` (a residual slope into the band's edge,
    :func:`~ema_pipeline.identification.selection.residual_search.residual_peaks`) must
    pass the resonance test by their peak, not by their shape alone.

    Examples
    --------
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.ones((3, 1))
    >>> H = H + 1e-5 * np.random.default_rng(1).standard_normal(H.shape)
    >>> from ema_pipeline.identification.refinement.refine import refine_poles
    >>> ref = refine_poles(f, H, lam, quantity="receptance")
    >>> final_tests(f, H, H, ref, "receptance").tolist()
    [True]
    """
    keep = decay_determined(refined.pole, refined.cov, thresholds) & inside_band(
        freq_hz, refined.pole, thresholds)
    by_shape = None if strict is None else ~strict[keep]
    keep[keep] = resonant(freq_hz, Hn, refined.pole[keep], quantity, by_shape=by_shape,
                          thresholds=thresholds)
    if partner is not None:
        keep |= decay_determined(refined.pole, refined.cov, thresholds) & partner & inside_band(
            freq_hz, refined.pole, thresholds)
    return keep & distinct_shapes(freq_hz, H, refined.pole, quantity, keep, n_orders,
                                  thresholds=thresholds)


@dataclass(frozen=True)
class ClosePartners:
    """What :func:`close_partners` found: the partners' poles (rad/s,
    ascending frequency) and, with fewer than ``min_shape_channels``
    channels, whether the F test of :func:`pair_significance` is calibrated
    on these data (:attr:`calibrated`: :func:`f_test_calibrated` of the kept
    modes' split fits; False with more channels, where the test is not
    asked)."""

    pole: np.ndarray
    calibration: SplitCalibration

    @property
    def calibrated(self) -> bool:
        return self.calibration.calibrated


class SplitCalibration:
    """The significances of the kept modes' split fits
    (:meth:`PartnerSearch.partner`) and :func:`f_test_calibrated` of them,
    computed when first asked: the F tests of splits that failed the
    partner's other tests are needed only for that median (when some split
    passed them, or a close pair is to be judged), so a file where nothing
    asks does without their fits. ``search`` None: more channels, never
    calibrated. Not shared between processes."""

    def __init__(self, search: PartnerSearch | None, splits: tuple[Split, ...],
                 map_: Mapper | None) -> None:
        self.search, self.splits, self.map_ = search, splits, map_
        self._sig: np.ndarray | None = None

    def significances(self) -> np.ndarray:
        """Each split's :func:`pair_significance` (NaN: no split fit)."""
        if self._sig is None:
            sig = np.array([s.significance for s in self.splits], dtype=float)
            todo = [(k, s.split_poles) for k, s in enumerate(self.splits)
                    if np.isnan(s.significance) and s.split_poles is not None]
            if todo and self.search is not None:
                sig[[k for k, _ in todo]] = map_each(
                    self.map_, self.search.significances_of, [lam for _, lam in todo],
                    PARALLEL_MIN_MODES)
            self._sig = sig
        return self._sig

    @property
    def calibrated(self) -> bool:
        if self.search is None:
            return False
        return f_test_calibrated(self.significances(), self.search.thresholds)


def f_test_calibrated(significance: np.ndarray,
                      thresholds: SelectionThresholds | None = None) -> bool:
    """Whether the F test of :func:`pair_significance` sees only the noise
    on a file: the median of the ``significance`` of every kept mode's split
    fit (a second pole beside each, NaN where none was fitted) is below
    ``thresholds.partner_max_split_median`` (most modes have no hidden
    partner, so most splits must not be significant; model error, e.g. the
    leakage of short records, makes them significant beside most modes).
    False when no split was judged.

    Examples
    --------
    >>> f_test_calibrated(np.array([0.3, 0.5, 40.0])), f_test_calibrated(np.array([5.8, 0.4, 9.0]))
    (True, False)
    """
    th = thresholds or SelectionThresholds()
    sig = np.asarray(significance, dtype=float)
    if not np.isfinite(sig).any():
        return False
    return bool(np.nanmedian(sig) < th.partner_max_split_median)


def close_partners(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str,
    *,
    window_tau_s: float | None = None,
    force_window_s: float | None = None,
    thresholds: SelectionThresholds | None = None,
    map_: Mapper | None = None,
) -> ClosePartners:
    """Poles of close modes hidden in the resonances of the kept ``pole``: for
    each, the extra pole of :func:`~ema_pipeline.identification.refinement.local_fits.split_fit`
    when it passes the tests of ``thresholds.partner_max_residual_ratio``
    (``ClosePartners.pole``, rad/s, ascending frequency; empty when there is
    none). ``H`` (n_ch, n_freq) on the lines ``freq_hz``. With
    ``thresholds.min_shape_channels`` channels or more the two shapes must be
    nearly real (:func:`pair_is_real`); with fewer no shape tells two modes
    from one, and the pair must instead be significant
    (:func:`pair_significance`: two poles fit better than one beyond what
    the noise explains), and only where that F test is calibrated
    (:func:`f_test_calibrated` of all the modes' split fits,
    ``ClosePartners.calibrated``: the model error of measured data makes a
    split significant beside most modes, and one channel cannot tell a
    hidden mode from it). With ``map_`` (worker processes,
    :func:`ema_pipeline.threads.map_each`) the modes' split fits are shared
    out from :data:`~ema_pipeline.identification.refinement.refine.PARALLEL_MIN_MODES`
    modes on; the same numbers.

    Examples
    --------
    >>> f = np.linspace(80.0, 120.0, 801)
    >>> lam = np.array([-3.0 + 2j * np.pi * 100.0, -3.0 + 2j * np.pi * 100.6])
    >>> jw = 2j * np.pi * f
    >>> terms = [1 / (jw - p) + 1 / (jw - p.conj()) for p in lam]
    >>> H = np.stack([terms[0] + s * terms[1] for s in (0.5, -0.5, 0.3)])
    >>> H = H + 1e-6 * np.random.default_rng(0).standard_normal(H.shape)
    >>> found = close_partners(f, H, lam[:1], "receptance")
    >>> (found.pole.imag / (2 * np.pi)).round(2).tolist(), found.calibrated
    ([100.6], False)
    """
    th = thresholds or SelectionThresholds()
    none = ClosePartners(np.zeros(0, complex), SplitCalibration(None, (), None))
    if pole.size == 0:
        return none
    try:
        residues = lsfd(freq_hz, H, pole, quantity).a
    except (np.linalg.LinAlgError, ValueError):
        return none
    search = PartnerSearch(freq_hz, H, pole, quantity, window_tau_s, force_window_s,
                           residues, th)
    splits = map_each(map_, search.partners_of, list(range(pole.size)), PARALLEL_MIN_MODES)
    calibration = SplitCalibration(search, tuple(splits), map_) if (
        H.shape[0] < th.min_shape_channels) else none.calibration
    found = [(s.pole, s.significance) for s in splits]
    if calibration.search is not None and any(b is not None for b, _ in found):
        # significant against the noise, where the noise is what the split
        # fits see, else model error makes every split significant and no
        # test of one channel tells a hidden mode from it
        sig, calibrated = calibration.significances(), calibration.calibrated
        found = [(b, s) if calibrated and s >= 1.0 else (None, s)
                 for (b, _), s in zip(found, sig, strict=True)]
    out = np.array([b for b, _ in found if b is not None], dtype=complex)
    return ClosePartners(out[np.argsort(out.imag)], calibration)


@dataclass(frozen=True)
class PartnerSearch:
    """What :func:`close_partners` needs to look for one kept mode's partner
    (a picklable unit of work for worker processes)."""

    freq_hz: np.ndarray
    H: np.ndarray
    pole: np.ndarray
    quantity: str
    window_tau_s: float | None
    force_window_s: float | None
    residues: np.ndarray
    thresholds: SelectionThresholds

    def partner(self, r: int) -> Split:
        """Mode ``r``'s split fit: its extra pole when it passes the tests of
        :func:`close_partners` (else None); with fewer than
        ``min_shape_channels`` channels the poles with the split in place of
        mode ``r`` and, for a split that passed those tests, its
        significance (:meth:`significance`), which :func:`close_partners`
        then asks of it (NaN otherwise: not computed, or no split fit)."""
        th, pole = self.thresholds, self.pole
        fit = split_fit(self.freq_hz, self.H, pole, r, quantity=self.quantity,
                        window_tau_s=self.window_tau_s, force_window_s=self.force_window_s,
                        residues=self.residues, thresholds=th)
        if fit is None:
            return Split(None, None, float("nan"))
        lam = np.concatenate([np.delete(pole, r), fit.pole])
        few = self.H.shape[0] < th.min_shape_channels
        a, b = fit.pole
        if fit.residual_ratio > th.partner_max_residual_ratio or abs(a.imag - b.imag) < 0.5 * (
                abs(a.real) + abs(b.real)) or not np.all(decay_determined(fit.pole, fit.cov, th)):
            return Split(None, lam if few else None, float("nan"))
        if few:  # no shape: the fit must prefer two poles
            return Split(complex(b), lam, self.significance(lam))
        if pair_is_real(self.freq_hz, self.H, lam, self.quantity, th):
            return Split(complex(b), None, float("nan"))
        return Split(None, None, float("nan"))

    def significance(self, lam: np.ndarray) -> float:
        """:func:`pair_significance` of the split, the last two poles of
        ``lam``; 0 where the extra pole left the band (no split)."""
        sig = pair_significance(self.freq_hz, self.H, lam, lam.size - 2, lam.size - 1,
                                self.quantity, window_tau_s=self.window_tau_s,
                                thresholds=self.thresholds)
        return 0.0 if sig == np.inf else sig

    def partners_of(self, modes: list[int]) -> list[Split]:
        """:meth:`partner` of each of ``modes`` (one worker's share)."""
        return [self.partner(r) for r in modes]

    def significances_of(self, splits: list[np.ndarray]) -> list[float]:
        """:meth:`significance` of each split (one worker's share)."""
        return [self.significance(lam) for lam in splits]


@dataclass(frozen=True)
class Split:
    """One kept mode's split fit as :meth:`PartnerSearch.partner` judged it:
    ``pole`` the partner (None: none), ``split_poles`` all poles with the
    split in the mode's place (kept with fewer than ``min_shape_channels``
    channels), ``significance`` its :func:`pair_significance` (NaN: not
    computed or no split fit)."""

    pole: complex | None
    split_poles: np.ndarray | None
    significance: float


def f_quantile(p: float, d1: float, d2: float) -> float:
    """The ``p`` quantile of the F distribution with ``d1``, ``d2`` degrees of
    freedom, by Paulson's cube-root normal approximation (relative error
    below 2 % for d1 >= 2, d2 >= 20 at p <= 0.9999; scipy.stats, which has it
    exactly, costs every command 0.7-1.2 s of start-up).

    Examples
    --------
    >>> round(f_quantile(0.999, 4, 60), 2), round(f_quantile(0.999, 4, 1e6), 2)  # exact 5.31, 4.62
    (5.36, 4.68)
    """
    z = NormalDist().inv_cdf(p)
    a1, a2 = 2.0 / (9.0 * d1), 2.0 / (9.0 * d2)
    # ((1 - a2) x - (1 - a1))^2 = z^2 (a1 + a2 x^2), x = F^(1/3), the larger root
    qa = (1 - a2) ** 2 - z**2 * a2
    qb = -2 * (1 - a1) * (1 - a2)
    qc = (1 - a1) ** 2 - z**2 * a1
    x = (-qb + np.sqrt(max(qb**2 - 4 * qa * qc, 0.0))) / (2 * qa)
    return float(x**3)


def pair_significance(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    a: int,
    b: int,
    quantity: str | None,
    *,
    window_tau_s: float | None = None,
    thresholds: SelectionThresholds | None = None,
) -> float:
    """How strongly the data prefer the two poles ``pole[a]``, ``pole[b]`` to
    one pole: the F statistic of the local problem with both (of the pole
    whose local band, ``thresholds.split_half_width``, holds the other) against
    the same problem with one pole in their place, over the critical value
    at ``thresholds.pair_significance_level``; 1 or more: the pair is
    significant, inf when neither band holds the other (two resonances).

    Both models are fitted (:func:`~ema_pipeline.identification.refinement.refine.vp_fit`;
    the single pole started from each of the two, the better kept) and
    judged with the noise weights of the two-pole fit (the noise level from
    its residual): F = ((C1 - C2) / dp) / (C2 / (N - p2)), C the weighted
    squared residuals, dp = 2 + 2 n_ch the parameters of one pole more, N the
    real equations, p2 the parameters of the pair's model. An exponential
    window correlates the noise of neighbouring lines (``window_tau_s``,
    :func:`~ema_pipeline.identification.refinement.uncertainty.exponential_window_correlation`):
    a second pole then takes up about sum_l |rho_l|^2 (about 1/(tau df))
    times more of it than of white noise (measured: 5.6 and 20 times at
    tau = T/5 and T/16, where that sum is 5 and 16), and the critical value
    is raised by that factor. NaN where the band is too short.

    Examples
    --------
    >>> f = np.linspace(80.0, 120.0, 401)
    >>> lam = np.array([-3.0 + 2j * np.pi * 99.0, -3.0 + 2j * np.pi * 101.0])
    >>> jw = 2j * np.pi * f
    >>> rng = np.random.default_rng(1)
    >>> noise = 1e-3 * (rng.standard_normal((1, f.size)) + 1j * rng.standard_normal((1, f.size)))
    >>> two = (1 / (jw - lam[0]) + 0.7 / (jw - lam[1]))[None] + noise
    >>> one = (1 / (jw - lam[0]))[None] + noise
    >>> bool(pair_significance(f, two, lam, 0, 1, None) > 10)
    True
    >>> bool(pair_significance(f, one, lam, 0, 1, None) < 1)
    True
    """
    th = thresholds or SelectionThresholds()
    a_all = global_residues(freq_hz, H, pole, quantity)
    for r, other in ((a, b), (b, a)):
        local = local_problem(freq_hz, H, pole, r, th.split_half_width, th.local_min_lines,
                              a_all)
        if local is None:
            return float("nan")
        f, Y, members, background, _, _ = local
        if other in members:
            break
    else:
        return float("inf")
    bg_r = background_columns(background)
    try:
        two = vp_fit(f, Y, pole[members], background, 20)
        design = WeightedPoleDesign(f, bg_r, two.u)
        Yw = Y * two.u[:, None]

        def cost(lam: np.ndarray) -> float:
            return float(np.sum(design.solve(lam, Yw)[1] ** 2 * two.inv_s2))

        c2 = cost(two.lam)
        costs = [cost(vp_fit(f, Y, pole[members[members != drop]], background, 20).lam)
                 for drop in (a, b)]
    except (np.linalg.LinAlgError, ValueError):
        return float("nan")
    n_ch = Y.shape[1]
    m = members.size
    p2 = n_ch * (2 * m + bg_r.shape[1]) + 2 * m
    dp = 2 + 2 * n_ch
    dof = Y.size - p2
    if dof <= 0 or c2 <= 0:
        return float("nan")
    stat = (min(costs) - c2) / dp / (c2 / dof)
    spread = 1.0
    if window_tau_s is not None and window_tau_s > 0:
        rho = exponential_window_correlation(window_tau_s * (f[1] - f[0]), f.size)
        spread = float(1 + 2 * np.sum(np.abs(rho[1:]) ** 2))
    return float(stat / (spread * f_quantile(1 - th.pair_significance_level, dp, dof)))


def peaks_apart(freq_hz: np.ndarray, H: np.ndarray, pa: complex, pb: complex,
                thresholds: SelectionThresholds | None = None) -> bool:
    """True when an FRF of ``H`` (n_ch, n_freq) shows the poles ``pa`` and
    ``pb`` as two peaks: a local maximum of |H| within each pole's
    half-power half-width (at least its nearest line) and between them a
    valley of at most ``thresholds.pair_min_dip`` times the lower of the two
    maxima (the peak's shape shows two modes).

    Examples
    --------
    >>> f = np.linspace(90.0, 110.0, 201)
    >>> jw = 2j * np.pi * f
    >>> lam = -1.0 + 2j * np.pi * np.array([99.0, 101.0, 99.3])
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[1]))[None]
    >>> peaks_apart(f, H, lam[0], lam[1]), peaks_apart(f, H, lam[0], lam[2])
    (True, False)
    """
    th = thresholds or SelectionThresholds()
    lo, hi = sorted([pa, pb], key=lambda p: p.imag)
    df = freq_hz[1] - freq_hz[0]

    def window(p: complex) -> np.ndarray:
        reach = max(float(pole_half_width_hz(p)), 0.5 * df)
        return np.flatnonzero(np.abs(freq_hz - pole_fd_hz(p)) <= reach + 1e-9 * df)

    wa, wb = window(lo), window(hi)
    if wa.size == 0 or wb.size == 0:
        return False
    for h in np.abs(H):
        ia = int(wa[np.argmax(h[wa])])
        ib = int(wb[np.argmax(h[wb])])
        if ib - ia < 2 or ia < 1 or ib > h.size - 2:
            continue
        is_max = h[ia] >= max(h[ia - 1], h[ia + 1]) and h[ib] >= max(h[ib - 1], h[ib + 1])
        if is_max and h[ia + 1 : ib].min() <= th.pair_min_dip * min(h[ia], h[ib]):
            return True
    return False


def close_pairs(pole: np.ndarray,
                thresholds: SelectionThresholds | None = None) -> list[tuple[int, int]]:
    """Neighbours (i, j), ascending frequency, of the poles ``pole`` that lie
    within ``thresholds.pair_max_gap`` times the sum of their half-power
    half-widths of each other (indices into ``pole``).

    Examples
    --------
    >>> lam = np.array([-1.0 + 2j * np.pi * 100.0, -1.0 + 2j * np.pi * 100.5,
    ...                 -1.0 + 2j * np.pi * 110.0])
    >>> close_pairs(lam)
    [(0, 1)]
    """
    th = thresholds or SelectionThresholds()
    order = np.argsort(pole.imag)
    fd, hw = pole_fd_hz(pole), pole_half_width_hz(pole)
    return [(int(i), int(j)) for i, j in zip(order[:-1], order[1:], strict=True)
            if fd[j] - fd[i] < th.pair_max_gap * (hw[i] + hw[j])]


def unsupported_partners(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str,
    *,
    thresholds: SelectionThresholds | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Of each close pair (:func:`close_pairs`) of the kept ``pole`` that the
    data do not prefer to one pole (:func:`pair_significance` below 1, judged
    as if the noise were white: both poles passed the diagrams' and the final
    tests, and under an exponential window the full correction of the noise's
    line correlation rejects true pairs of the impact families, e.g. two modes
    0.75 Hz apart at 12 Hz, 0.52) and whose peaks do not show apart
    (:func:`peaks_apart`), the weaker pole (the
    lower peak SNR, :func:`~ema_pipeline.identification.refinement.local_fits.quick_significance`):
    with fewer than ``thresholds.min_shape_channels`` channels (``H``, (n_ch,
    n_freq)) nothing else tells a second mode beside a close partner, and
    the pair is one mode. Returns ``drop`` (bool, each pole) and ``merged``
    (bool, each pole: the partner that stays). With more channels nothing
    is dropped (the shape tests of :func:`final_tests` and
    :func:`close_partners` judge a pair).

    Examples
    --------
    >>> f = np.linspace(80.0, 120.0, 401)
    >>> lam = np.array([-3.0 + 2j * np.pi * 99.0, -3.0 + 2j * np.pi * 99.8])
    >>> jw = 2j * np.pi * f
    >>> rng = np.random.default_rng(2)
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None]
    >>> H = H + 1e-3 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    >>> drop, merged = unsupported_partners(f, H, lam, "receptance")
    >>> drop.tolist(), merged.tolist()
    ([False, True], [True, False])
    """
    th = thresholds or SelectionThresholds()
    drop, merged = np.zeros(pole.size, bool), np.zeros(pole.size, bool)
    if H.shape[0] >= th.min_shape_channels or pole.size < 2:
        return drop, merged
    snr = None
    for i, j in close_pairs(pole, th):
        if drop[i] or drop[j] or peaks_apart(freq_hz, H, pole[i], pole[j], th):
            continue
        sig = pair_significance(freq_hz, H, pole, i, j, quantity, thresholds=th)
        if not sig < 1.0:  # significant, or not judged (NaN)
            continue
        if snr is None:
            snr = quick_significance(freq_hz, H, pole, thresholds=th)[2]
        weak, strong = (i, j) if snr[i] < snr[j] else (j, i)
        drop[weak], merged[strong] = True, True
    return drop, merged & ~drop


def pair_is_real(freq_hz: np.ndarray, H: np.ndarray, pole: np.ndarray, quantity: str,
                 thresholds: SelectionThresholds | None = None) -> bool:
    """True when the last two of ``pole`` have nearly real shapes (MPC >=
    ``thresholds.partner_min_mpc``) in one global LSFD of all of them or, failing
    that, each in its own local fit
    (:func:`~ema_pipeline.identification.refinement.local_fits.local_shapes`). A weak mode
    beside a strong one has its shape bent by what either model misses (on
    the hard close pairs the true partners reach 0.9 in one of the two, at
    0.82-0.91 in the other); the measured beam's split pairs stay below 0.75
    in both.

    Examples
    --------
    >>> f = np.linspace(90.0, 110.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 99.0, -2.0 + 2j * np.pi * 101.0])
    >>> t0, t1 = (1 / (2j * np.pi * f - p) + 1 / (2j * np.pi * f - p.conj()) for p in lam)
    >>> real, cplx = np.stack([t0 + t1, t0 - t1, 2 * t0]), np.stack([t0 + t1, t0 + 1j * t1, t0])
    >>> pair_is_real(f, real, lam, "receptance"), pair_is_real(f, cplx, lam, "receptance")
    (True, False)
    """
    th = thresholds or SelectionThresholds()
    for shapes_of in (lambda: lsfd(freq_hz, H, pole, quantity).a,
                      lambda: local_shapes(freq_hz, H, pole, quantity=quantity, thresholds=th)):
        try:
            shapes = shapes_of().T
        except (np.linalg.LinAlgError, ValueError):
            continue
        if np.min(np.nan_to_num(mpc(shapes)[-2:])) >= th.partner_min_mpc:
            return True
    return False


def resonant(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str = "accelerance",
    by_shape: np.ndarray | None = None,
    thresholds: SelectionThresholds | None = None,
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
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0, -2.0 + 2j * np.pi * 120.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.ones((3, 1))
    >>> H = H + 1e-3 * np.random.default_rng(1).standard_normal(H.shape) * (1 + 1j)
    >>> resonant(f, H, lam, "receptance").tolist()
    [True, False]
    """
    th = thresholds or SelectionThresholds()
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
        drop = np.nan_to_num(residual_drop(freq_hz, H, pole, quantity, th, only=ask))
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
    thresholds: SelectionThresholds | None = None,
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
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0, -2.0 + 2j * np.pi * 120.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.array([[1], [1j], [-1]])
    >>> H = H + 1e-4 * np.random.default_rng(1).standard_normal(H.shape)
    >>> drop = residual_drop(f, H, lam, "receptance")
    >>> bool(drop[0] > 100), bool(drop[1] < 1.5)
    (True, True)
    """
    th = thresholds or SelectionThresholds()
    a_all = global_residues(freq_hz, H, pole, quantity)
    out = np.full(pole.size, np.nan)
    for r in np.flatnonzero(np.ones(pole.size, bool) if only is None else only).tolist():
        local = local_problem(freq_hz, H, pole, r, th.local_half_width, th.local_min_lines,
                              a_all)
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
    thresholds: SelectionThresholds | None = None,
) -> np.ndarray:
    """``keep`` less duplicates: of two kept poles that coincide within their
    half-power bands and have parallel LSFD shapes (MAC >
    ``thresholds.duplicate_min_mac``) one stays (one mode found twice): the
    one stable at more model orders ``n_orders``, else (equal or not given)
    the one with the larger response. Close modes with different shapes stay
    apart, unless one of them is the split of the other (see
    ``split_max_mpc``, ``split_mpc_gap``).

    Examples
    --------
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0, -2.0 + 2j * np.pi * 100.1])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None] * np.ones((3, 1))
    >>> distinct_shapes(f, H, lam, "receptance", np.array([True, True])).sum()
    np.int64(1)
    """
    th = thresholds or SelectionThresholds()
    out = keep.copy()
    idx = np.flatnonzero(keep)
    if idx.size < 2:
        return out
    try:
        fit = lsfd(freq_hz, H, pole[idx], quantity)
    except (np.linalg.LinAlgError, ValueError):
        return out
    M = mac(fit.a.T)
    collinear = mpc(fit.a.T)
    s = np.argsort(pole[idx].imag)
    for a, b in zip(s[:-1], s[1:], strict=True):
        if not (out[idx[a]] and out[idx[b]]):
            continue
        pa, pb = pole[idx[a]], pole[idx[b]]
        gap, width = abs(pa.imag - pb.imag), abs(pa.real) + abs(pb.real)
        if gap < 0.5 * width and M[a, b] > th.duplicate_min_mac:
            na, nb = np.linalg.norm(fit.a[a]), np.linalg.norm(fit.a[b])
            if n_orders is not None and n_orders[idx[a]] != n_orders[idx[b]]:
                na, nb = n_orders[idx[a]], n_orders[idx[b]]
            out[idx[b] if na >= nb else idx[a]] = False
        elif gap < width and min(collinear[a], collinear[b]) < th.split_max_mpc and (
                abs(collinear[a] - collinear[b]) >= th.split_mpc_gap):
            out[idx[a] if collinear[a] < collinear[b] else idx[b]] = False
    return out
