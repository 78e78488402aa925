"""Close modes hidden in a kept resonance: one pole more in each kept mode's
local fit (:func:`close_partners`, one :class:`PartnerSearch` per band).

A split (:func:`~ema_pipeline.identification.refinement.local_fits.split_fit`)
is a partner when it leaves little of the residual, both poles are
determined and apart, and either both shapes are nearly real
(:func:`pair_is_real`, with ``min_shape_channels`` channels or more) or,
with fewer channels, the F test of
:func:`.pair_significance`
prefers two poles and is calibrated on the file (:class:`SplitCalibration`,
:func:`.f_test_calibrated`).
The partners join the kept modes through
:func:`.add_found`. The
thresholds are fields of
:class:`~ema_pipeline.identification.thresholds.SelectionThresholds`, passed
in as ``thresholds``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.identification.refinement.local_band import local_sizes
from ema_pipeline.identification.refinement.local_fits import (
    SplitFit,
    local_shapes,
    split_fit,
)
from ema_pipeline.identification.refinement.lsfd import lsfd, mpc
from ema_pipeline.identification.refinement.refine import (
    PARALLEL_MIN_MODES,
    decay_determined,
)
from ema_pipeline.identification.selection.pairs import f_test_calibrated, pair_significance
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.runner import Mapper, map_each


@dataclass(frozen=True)
class ClosePartners:
    """What :func:`close_partners` found: the partners' poles (rad/s,
    ascending frequency) and, with fewer than ``min_shape_channels``
    channels, whether the F test of :func:`.pair_significance` is calibrated
    on these data (:attr:`calibrated`: :func:`.f_test_calibrated` of the kept
    modes' split fits; False with more channels, where the test is not
    asked)."""

    pole: np.ndarray
    calibration: SplitCalibration

    @property
    def calibrated(self) -> bool:
        return self.calibration.calibrated


class SplitCalibration:
    """The significances of the kept modes' split fits
    (:meth:`PartnerSearch.partner`) and :func:`.f_test_calibrated` of them,
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
        """Each split's :func:`.pair_significance` (NaN: no split fit)."""
        if self._sig is None:
            sig = np.array([s.significance for s in self.splits], dtype=float)
            todo = [(k, s.split_poles) for k, s in enumerate(self.splits)
                    if np.isnan(s.significance) and (s.split_poles is not None or s.refit)]
            if todo and self.search is not None:
                # split k is mode k's (splits in the kept modes' order)
                sig[[k for k, _ in todo]] = map_each(
                    self.map_, self.search.significances_of, todo, PARALLEL_MIN_MODES)
            self._sig = sig
        return self._sig

    @property
    def calibrated(self) -> bool:
        if self.search is None:
            return False
        return f_test_calibrated(self.significances(), thresholds=self.search.thresholds)


def close_partners(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str,
    *,
    window_tau_s: float | None = None,
    force_window_s: float | None = None,
    thresholds: SelectionThresholds,
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
    (:func:`.pair_significance`: two poles fit better than one beyond what
    the noise explains), and only where that F test is calibrated
    (:func:`.f_test_calibrated` of all the modes' split fits,
    ``ClosePartners.calibrated``: the model error of measured data makes a
    split significant beside most modes, and one channel cannot tell a
    hidden mode from it). With ``map_`` (worker processes,
    :func:`ema_pipeline.runner.map_each`) the modes' split fits are shared
    out from :data:`~ema_pipeline.identification.refinement.refine.PARALLEL_MIN_MODES`
    modes on; the same numbers.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(80.0, 120.0, 801)
    >>> lam = np.array([-3.0 + 2j * np.pi * 100.0, -3.0 + 2j * np.pi * 100.6])
    >>> jw = 2j * np.pi * f
    >>> terms = [1 / (jw - p) + 1 / (jw - p.conj()) for p in lam]
    >>> H = np.stack([terms[0] + s * terms[1] for s in (0.5, -0.5, 0.3)])
    >>> H = H + 1e-6 * np.random.default_rng(0).standard_normal(H.shape)
    >>> found = close_partners(f, H, lam[:1], "receptance", thresholds=th)
    >>> (found.pole.imag / (2 * np.pi)).round(2).tolist(), found.calibrated
    ([100.6], False)
    """
    th = thresholds
    none = ClosePartners(np.zeros(0, complex), SplitCalibration(None, (), None))
    if pole.size == 0:
        return none
    try:
        residues = lsfd(freq_hz, H, pole, quantity).a
    except (np.linalg.LinAlgError, ValueError):
        return none
    search = PartnerSearch(freq_hz, H, pole, quantity, window_tau_s, force_window_s,
                           residues, th)
    cost = local_sizes(freq_hz, pole, th.split_half_width, th.local_min_lines,
                       thresholds=th).tolist()
    splits = map_each(map_, search.partners_of, list(range(pole.size)), PARALLEL_MIN_MODES,
                      cost)
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
        th = self.thresholds
        fit = self.split(r, finish=False)
        if fit is None:
            return Split(None, None, float("nan"))
        few = self.H.shape[0] < th.min_shape_channels
        if not fit.finished:  # its residual ratio failed: the split poles when asked
            return Split(None, None, float("nan"), refit=few)
        lam = self.split_poles(r, fit)
        a, b = fit.pole
        if fit.residual_ratio > th.partner_max_residual_ratio or abs(a.imag - b.imag) < 0.5 * (
                abs(a.real) + abs(b.real)) or not np.all(
                    decay_determined(fit.pole, fit.cov, thresholds=th)):
            return Split(None, lam if few else None, float("nan"))
        if few:  # no shape: the fit must prefer two poles
            return Split(complex(b), lam, self.significance(r, lam))
        if pair_is_real(self.freq_hz, self.H, lam, self.quantity, thresholds=th):
            return Split(complex(b), None, float("nan"))
        return Split(None, None, float("nan"))

    def split(self, r: int, *, finish: bool = True) -> SplitFit | None:
        """Mode ``r``'s :func:`~ema_pipeline.identification.refinement.local_fits.split_fit`;
        ``finish`` False: stopped where its residual ratio fails
        ``partner_max_residual_ratio`` (the same ratio; ``SplitFit.finished``)."""
        th = self.thresholds
        return split_fit(self.freq_hz, self.H, self.pole, r, quantity=self.quantity,
                         window_tau_s=self.window_tau_s, force_window_s=self.force_window_s,
                         residues=self.residues,
                         max_ratio=None if finish else th.partner_max_residual_ratio,
                         thresholds=th)

    def split_poles(self, r: int, fit: SplitFit) -> np.ndarray:
        """The kept poles with mode ``r``'s split ``fit`` in its place (the
        pair last)."""
        return np.concatenate([np.delete(self.pole, r), fit.pole])

    def significance(self, r: int, lam: np.ndarray) -> float:
        """:func:`.pair_significance` of mode ``r``'s split, the last two
        poles of ``lam`` (``np.delete(pole, r)`` then the pair); 0 where the
        extra pole left the band (no split). The other modes' terms are
        subtracted with the kept poles' residues (:attr:`residues`), the
        pair's rows hold those of mode ``r`` (members of the local band,
        never subtracted)."""
        residues = None
        if self.residues is not None:
            residues = np.concatenate([np.delete(self.residues, r, axis=0),
                                       self.residues[[r, r]]])
        sig = pair_significance(self.freq_hz, self.H, lam, lam.size - 2, lam.size - 1,
                                self.quantity, window_tau_s=self.window_tau_s,
                                residues=residues, thresholds=self.thresholds)
        return 0.0 if sig == np.inf else sig

    def partners_of(self, modes: list[int]) -> list[Split]:
        """:meth:`partner` of each of ``modes`` (one worker's share)."""
        return [self.partner(r) for r in modes]

    def significances_of(self, splits: list[tuple[int, np.ndarray | None]]) -> list[float]:
        """:meth:`significance` of each (mode, split poles) (one worker's
        share); split poles None: the split stopped on its residual ratio
        (``Split.refit``), fitted again to the end first."""
        out = []
        for r, lam in splits:
            if lam is None:
                fit = self.split(r)  # the stopped fit, to the end
                lam = self.split_poles(r, fit) if fit is not None else None
            out.append(float("nan") if lam is None else self.significance(r, lam))
        return out


@dataclass(frozen=True)
class Split:
    """One kept mode's split fit as :meth:`PartnerSearch.partner` judged it:
    ``pole`` the partner (None: none), ``split_poles`` all poles with the
    split in the mode's place (kept with fewer than ``min_shape_channels``
    channels), ``significance`` its :func:`.pair_significance` (NaN: not
    computed or no split fit), ``refit`` True where those split poles are
    needed but the split stopped on its residual ratio
    (:meth:`PartnerSearch.split`): :class:`SplitCalibration` fits it to the
    end when it asks for its significance."""

    pole: complex | None
    split_poles: np.ndarray | None
    significance: float
    refit: bool = False


def pair_is_real(freq_hz: np.ndarray, H: np.ndarray, pole: np.ndarray, quantity: str,
                 *, thresholds: SelectionThresholds) -> bool:
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
    >>> th = SelectionThresholds()
    >>> f = np.linspace(90.0, 110.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 99.0, -2.0 + 2j * np.pi * 101.0])
    >>> t0, t1 = (1 / (2j * np.pi * f - p) + 1 / (2j * np.pi * f - p.conj()) for p in lam)
    >>> real, cplx = np.stack([t0 + t1, t0 - t1, 2 * t0]), np.stack([t0 + t1, t0 + 1j * t1, t0])
    >>> (pair_is_real(f, real, lam, "receptance", thresholds=th),
    ...  pair_is_real(f, cplx, lam, "receptance", thresholds=th))
    (True, False)
    """
    th = thresholds
    for shapes_of in (lambda: lsfd(freq_hz, H, pole, quantity).a,
                      lambda: local_shapes(freq_hz, H, pole, quantity=quantity, thresholds=th)):
        try:
            shapes = shapes_of().T
        except (np.linalg.LinAlgError, ValueError):
            continue
        if np.min(np.nan_to_num(mpc(shapes)[-2:])) >= th.partner_min_mpc:
            return True
    return False
