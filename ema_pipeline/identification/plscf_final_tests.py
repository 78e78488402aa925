"""Stage 5 of the ``"plscf"`` backend
(:mod:`~ema_pipeline.identification.plscf_backend`): the final tests over all
FRFs and the searches for modes the diagrams missed, each a function of the
candidates and a :class:`Retest` (refine candidates and judge them):
:func:`first_verdict`, :func:`try_alternates`, :func:`add_close_partners`,
:func:`add_residual_peaks`, :func:`merge_unsupported_pairs`."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ema_pipeline.identification.diagram.narrower_searches import (
    shown_by_the_frfs,
    uncovered_alternates,
)
from ema_pipeline.identification.diagram.order_search import SearchedBand
from ema_pipeline.identification.plscf_band import BandData
from ema_pipeline.identification.refinement.refine import (
    FitMemo,
    RefinedPoles,
    decay_determined,
    refine_poles,
)
from ema_pipeline.identification.selection.acceptance import (
    Candidates,
    add_found,
    final_tests,
    inside_band,
    refit_kept,
)
from ema_pipeline.identification.selection.pairs import unsupported_partners
from ema_pipeline.identification.selection.partners import SplitCalibration, close_partners
from ema_pipeline.identification.selection.residual_search import residual_peaks
from ema_pipeline.identification.selection.trajectories import SelectedPoles
from ema_pipeline.runner import Mapper

__all__ = ["Retest", "add_close_partners", "add_residual_peaks", "first_verdict",
           "merge_unsupported_pairs", "try_alternates"]


@dataclass
class Retest:
    """Refine candidates and run the final tests over all FRFs on them: the
    ``retest(candidates, partner, strict) -> (refined, keep)`` of
    :func:`~ema_pipeline.identification.selection.acceptance.add_found` and
    :func:`~ema_pipeline.identification.selection.acceptance.refit_kept`. Every
    verdict's failed poles whose decay rate is determined are collected in
    ``rejected`` (for :func:`~ema_pipeline.identification.plscf_backend.with_not_kept`),
    the refined poles it dropped as one mode found twice in ``twins`` (for
    :func:`~ema_pipeline.identification.plscf_backend.with_twin_flags`)."""

    data: BandData
    map_: Mapper
    rejected: list[np.ndarray] = field(default_factory=list)
    twins: list[np.ndarray] = field(default_factory=list)
    #: the last refinement's fits: :meth:`__call__` takes those :meth:`could_pass` made
    memo: FitMemo = field(default_factory=FitMemo)

    def verdict(self, ref: RefinedPoles, n_members: np.ndarray, partner: np.ndarray | None = None,
                strict: np.ndarray | None = None) -> np.ndarray:
        """Which refined poles ``ref`` pass the final tests; the failed ones
        with a determined decay rate go to ``rejected``, those dropped as one
        mode found twice to ``twins``."""
        d, th = self.data, self.data.thresholds
        ok, twin = final_tests(d.freq_hz, d.Hc, d.Hn_c, ref, d.quantity, n_members,
                               partner=partner, strict=strict, thresholds=th)
        self.rejected.append(ref.pole[~ok & decay_determined(ref.pole, ref.cov, thresholds=th)])
        self.twins.append(ref.pole[twin])
        return ok

    def could_pass(self, candidates: SelectedPoles, indices: np.ndarray) -> np.ndarray:
        """Whether each candidate at ``indices`` can pass :meth:`verdict` when
        all ``candidates`` are refined together: its own local fit among them
        (the fit that refinement would give it: each mode's local fit is its
        own, :func:`refine_poles` with ``modes``) has a determined decay rate
        and lies inside the band, which every pole that passes has. Those
        that cannot, the caller leaves out of that refinement: the ones with
        a determined decay rate go to ``rejected`` as its verdict would send
        them. (A kept
        pole that the joint fit bent until it failed would have gone there
        too; unrefitted, none does. On the snapshot cases, the measured beam
        in five bands and the pyFRF recording the not-kept lists are the
        same.)"""
        d, th = self.data, self.data.thresholds
        ref = refine_poles(d.freq_hz, d.Hc, candidates.pole, quantity=d.quantity,
                           window_tau_s=d.window_tau_s, force_window_s=d.force_window_s,
                           thresholds=th, map_=self.map_, modes=indices, memo=self.memo,
                           decay_screen=True)
        pole, cov = ref.pole[indices], ref.cov[indices]
        determined = decay_determined(pole, cov, thresholds=th)
        ok = determined & inside_band(d.freq_hz, pole, thresholds=th)
        self.rejected.append(pole[determined & ~ok])
        return ok

    def __call__(self, candidates: SelectedPoles, partner: np.ndarray,
                 strict: np.ndarray) -> tuple[RefinedPoles, np.ndarray]:
        d = self.data
        ref = refine_poles(d.freq_hz, d.Hc, candidates.pole, quantity=d.quantity,
                           window_tau_s=d.window_tau_s, force_window_s=d.force_window_s,
                           thresholds=d.thresholds, map_=self.map_, memo=self.memo)
        # a close partner whose local fit wandered off (refinement returns its
        # start pole) has no fit of its own to stand on: it fails
        wandered = np.asarray(partner, bool) & (ref.pole == candidates.pole)
        return ref, self.verdict(ref, candidates.n_members, partner, strict) & ~wandered


def first_verdict(found: Candidates, retest: Retest) -> Candidates:
    """Stage 5a: the final tests on the refined candidates, then the kept
    ones refined and tested again without those that failed
    (:func:`~ema_pipeline.identification.selection.acceptance.refit_kept`)."""
    found = replace(found, keep=retest.verdict(found.ref, found.sel.n_members))
    return refit_kept(found, retest, retest.data.thresholds.refit_rounds)


def try_alternates(found: Candidates, searched: tuple[SearchedBand, ...],
                   retest: Retest) -> Candidates:
    """Stage 5b: where a candidate failed, the narrower searches' candidate it
    covered (:func:`uncovered_alternates`), when the FRFs show a peak there
    (:func:`shown_by_the_frfs`)."""
    d = retest.data
    alt = uncovered_alternates(found.kept_poles(), [e[2] for e in searched])
    alt = alt[shown_by_the_frfs(d.freq_hz, d.Hc, alt, thresholds=d.thresholds)]
    return add_found(found, alt, partner=False, strict=np.zeros(alt.size, bool),
                     retest=retest, found_by="alternate", screen=retest.could_pass)


def add_close_partners(found: Candidates,
                       retest: Retest) -> tuple[Candidates, SplitCalibration]:
    """Stage 5c: close modes hidden in a kept resonance
    (:func:`~ema_pipeline.identification.selection.partners.close_partners`).
    Returns the candidates and, with fewer than ``min_shape_channels``
    channels, whether the two-poles-against-one F test is calibrated on the
    band's data (``ClosePartners.calibration``, evaluated when
    :func:`~ema_pipeline.identification.plscf_backend.with_pair_flags` asks)."""
    d = retest.data
    partners = close_partners(d.freq_hz, d.Hc, found.kept_poles(), d.quantity,
                              window_tau_s=d.window_tau_s, force_window_s=d.force_window_s,
                              thresholds=d.thresholds, map_=retest.map_)
    found = add_found(found, partners.pole, partner=True,
                      strict=np.zeros(partners.pole.size, bool), retest=retest,
                      found_by="partner", screen=retest.could_pass)
    return found, partners.calibration


def add_residual_peaks(found: Candidates, retest: Retest) -> Candidates:
    """Stage 5d: modes that no diagram resolved, from the peaks of the kept
    modes' residual (:func:`residual_peaks`); starts from a slope into the
    band's edge (a mode outside the band looks the same) must pass the
    resonance test by their peak."""
    d = retest.data
    peaks, from_edge = residual_peaks(d.freq_hz, d.Hc, found.kept_poles(), d.quantity,
                                      thresholds=d.thresholds)
    return add_found(found, peaks, partner=False, strict=from_edge, retest=retest,
                     found_by="residual", screen=retest.could_pass)


def merge_unsupported_pairs(found: Candidates,
                            retest: Retest) -> tuple[Candidates, np.ndarray]:
    """Stage 5e, with fewer than ``min_shape_channels`` channels: of a close
    pair of kept poles that one channel cannot support (not significant, its
    peaks not apart:
    :func:`~ema_pipeline.identification.selection.pairs.unsupported_partners`),
    the weaker is dropped and the rest refitted
    (:func:`~ema_pipeline.identification.selection.acceptance.refit_kept`).
    Returns the candidates and the poles of the partners that stayed (before
    the refit), whose modes
    :func:`~ema_pipeline.identification.plscf_backend.with_pair_flags` marks."""
    d = retest.data
    none = np.zeros(0, dtype=complex)
    if d.Hc.shape[0] >= d.thresholds.min_shape_channels or not found.keep.any():
        return found, none
    drop, merged = unsupported_partners(d.freq_hz, d.Hc, found.kept_poles(), d.quantity,
                                        thresholds=d.thresholds)
    if not drop.any():
        return found, none
    kept_at = np.flatnonzero(found.keep)
    keep = found.keep.copy()
    keep[kept_at[drop]] = False
    staying = found.kept_poles()[merged]
    return refit_kept(replace(found, keep=keep), retest, d.thresholds.refit_rounds), staying
