"""Local screens and fits of single modes, used by the acceptance tests.

Each solves the local problem of
:func:`~ema_pipeline.identification.refinement.refine.refine_poles`
(:func:`~ema_pipeline.identification.refinement.local_band.local_problem`: the mode's
band, its member poles, a quadratic background, the other modes' global LSFD
terms subtracted) in a cheaper or a different way:
:func:`quick_significance` solves it once, without iterating (a screen of
candidate poles); :func:`local_shapes` takes each mode's residues from it (a
weak mode's shape, which one global LSFD bends); :func:`split_fit` solves one
mode's problem with one pole more (a hidden close mode). The refinement itself
lives in :mod:`ema_pipeline.identification.refinement.refine`, the tests that use these
in :mod:`ema_pipeline.identification.selection.acceptance`.

Why written here: as for the refinement, scipy's ``least_squares`` would
neither eliminate the linear terms (variable projection) nor share one
projection between channels, and the screens run on every candidate pole, so
they must be cheaper still than the refinement.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ema_pipeline.identification.refinement.local_band import (
    background_columns,
    block_fisher,
    global_residues,
    local_problem,
    pole_columns,
    pole_jacobian_factors,
    scaled_solve,
)
from ema_pipeline.identification.refinement.refine import VPFit, vp_covariance, vp_fit
from ema_pipeline.identification.thresholds import SelectionThresholds


def quick_significance(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    *,
    thresholds: SelectionThresholds,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cheap screen of candidate poles: std(sigma_r)/sigma_r, peak ratio and peak SNR.

    The local problem of :func:`~ema_pipeline.identification.refinement.refine.refine_poles`
    (band ``thresholds.local_half_width``, ``local_min_lines``)
    at the given poles, solved once without iterating, with white noise per
    channel whose variance is the residual's mean square over the degrees of
    freedom. The *peak ratio* is the peak of the mode's own term,
    sqrt(sum_c |a_rc|^2) / sigma_r, relative to the RMS of the data in its local
    band: a pole that models a small part of the
    response (leakage, a smooth background) has a small ratio even in
    noise-free data. The *peak SNR* is that peak over the residual's standard
    deviation, sqrt(sum_c |a_rc|^2 / s2_c) / sigma_r: everything the local model
    does not explain (noise, and on measured data model error) is the floor a
    mode must stand out from. inf / 0 / 0 where the local band is too short.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None]
    >>> H = H + 1e-5 * np.random.default_rng(1).standard_normal(H.shape)
    >>> rel, peak, snr = quick_significance(f, H, lam, thresholds=th)
    >>> bool(rel[0] < 0.01), bool(peak[0] > 1), bool(snr[0] > 1e3)
    (True, True, True)
    """
    th = thresholds
    half_width, min_lines = th.local_half_width, th.local_min_lines
    freq_hz = np.asarray(freq_hz, dtype=float)
    H = np.asarray(H)
    rel = np.full(poles.size, np.inf)
    peak = np.zeros(poles.size)
    snr = np.zeros(poles.size)
    for r in range(poles.size):
        local = local_problem(freq_hz, H, poles, r, half_width, min_lines, thresholds=th)
        if local is None:
            continue
        f, Y, members, background, k, _ = local
        lam = poles[members]
        m = lam.size
        jw = 2j * np.pi * f[:, None]
        A = pole_columns(f, lam, background_columns(background))
        try:
            Qm, res, X = scaled_solve(A, Y)  # X (K, n_ch)
        except np.linalg.LinAlgError:
            continue
        dof = max(Y.shape[0] - A.shape[1] - 2 * m / Y.shape[1], 1.0)
        s2 = np.maximum(np.sum(res**2, axis=0) / dof, 1e-300)
        a = X[0 : 2 * m : 2] + 1j * X[1 : 2 * m : 2]  # (m, n_ch)
        # the Fisher matrix sum_c Jp_c^T Jp_c / s2_c with Jp_c = Bp W_c: one
        # projection of the 2m columns of B for all channels
        # (local_band.pole_jacobian_factors; 30 channels: ~5x cheaper)
        B, _ = pole_jacobian_factors(jw, lam, X)
        Bp = B - Qm @ (Qm.T @ B)
        # sum_c W_c^T (Bp^T Bp) W_c / s2_c from the 2 x 2 blocks of W_c
        F = block_fisher(Bp.T @ Bp, X, 1.0 / s2)
        try:
            var = np.linalg.inv(0.5 * (F + F.T))[2 * k, 2 * k]
        except np.linalg.LinAlgError:
            continue
        sigma_r = abs(lam[k].real)
        rel[r] = np.sqrt(max(var, 0.0)) / sigma_r
        ak = a[k]
        n = f.size
        data_ms = np.mean(np.sum(Y[:n] ** 2 + Y[n:] ** 2, axis=1))
        peak[r] = np.sqrt(np.sum(np.abs(ak) ** 2) / max(data_ms, 1e-300)) / sigma_r
        snr[r] = np.sqrt(np.sum(np.abs(ak) ** 2 / s2)) / sigma_r
    return rel, peak, snr


def local_shapes(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    *,
    quantity: str | None = "accelerance",
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """(n_modes, n_ch) complex residues of each pole from its own local
    problem (the band, member poles and quadratic background of
    :func:`~ema_pipeline.identification.refinement.refine.refine_poles`, the global LSFD
    terms of the other modes subtracted), at the given poles; NaN where the
    band is too short.

    A weak mode's shape from one global LSFD is bent by everything the global
    model misses across the band (its MPC can drop to 0.2 for a real mode);
    its local fit, with a background of its own, sees the shape the data
    hold around its resonance.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0])
    >>> jw = 2j * np.pi * f
    >>> H = np.array([[1.0], [-2.0]]) * (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None]
    >>> a = local_shapes(f, H, lam, quantity=None, thresholds=th)
    >>> np.round(a[0] / a[0, 0], 6).tolist()
    [(1+0j), (-2+0j)]
    """
    th = thresholds
    half_width, min_lines = th.local_half_width, th.local_min_lines
    freq_hz = np.asarray(freq_hz, dtype=float)
    H = np.asarray(H)
    out = np.full((poles.size, H.shape[0]), np.nan + 0j)
    a_all = global_residues(freq_hz, H, poles, quantity)
    for r in range(poles.size):
        local = local_problem(freq_hz, H, poles, r, half_width, min_lines, a_all,
                              thresholds=th)
        if local is None:
            continue
        f, Y, members, background, k, _ = local
        _, _, X = scaled_solve(pole_columns(f, poles[members], background_columns(background)), Y)
        out[r] = X[2 * k] + 1j * X[2 * k + 1]
    return out


@dataclass(frozen=True)
class SplitFit:
    """One pole's local problem fitted with one extra pole (:func:`split_fit`).

    Attributes
    ----------
    pole : (2,) complex   the refined pole and the extra one (rad/s); the
        first weighting round's where the fit is not :attr:`finished`
    residual_ratio : float  residual variance with the extra pole over without it
    cov : (2, 2, 2)       their covariance in (sigma, omega_d), (rad/s)^2,
        computed when first asked (the sandwich covariance of
        :func:`~ema_pipeline.identification.refinement.refine.vp_covariance`:
        a split that fails on its residual ratio never needs it)
    """

    pole: np.ndarray
    residual_ratio: float
    fit: VPFit = field(repr=False)
    at: tuple[int, int] = field(repr=False)
    windows_s: tuple[float | None, float | None] = field(repr=False)

    @property
    def finished(self) -> bool:
        """False where ``max_ratio`` stopped the fit (:func:`split_fit`)."""
        return self.fit.finished

    @cached_property
    def cov(self) -> np.ndarray:
        try:
            Finv = vp_covariance(self.fit, *self.windows_s)
        except (np.linalg.LinAlgError, ValueError):  # undetermined: NaN, as no decay rate
            return np.full((2, 2, 2), np.nan)
        k, j = self.at
        return np.stack([Finv[2 * k : 2 * k + 2, 2 * k : 2 * k + 2], Finv[2 * j :, 2 * j :]])


def split_fit(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    r: int,
    *,
    quantity: str | None = "accelerance",
    window_tau_s: float | None = None,
    force_window_s: float | None = None,
    residues: np.ndarray | None = None,
    max_ratio: float | None = None,
    thresholds: SelectionThresholds,
) -> SplitFit | None:
    """Refit pole r's local problem (as
    :func:`~ema_pipeline.identification.refinement.refine.refine_poles`, on
    +-``thresholds.split_half_width`` half-power bandwidths) with one extra
    pole started one decay rate above or below it, on the side where the fit
    without it leaves more of the residual (``thresholds.split_max_iter``
    iterations per round), or None when the band is too short. Fitting both
    sides and keeping the better, as before, cost twice the time and gave the
    same modes on the 117 cases of ``benchmarks/speed_rules.py``, 166
    held-out cases and the suite's hard cases.

    A close mode that the diagram merged with pole r (one reference, a weak
    partner inside its resonance) leaves a residual that the extra pole
    removes: ``residual_ratio`` well below 1. On noise alone the ratio stays
    near 1 (one pole more of 2 + 2 n_ch parameters among 2 n_lines n_ch
    equations). ``residues`` (n_modes, n_ch): a global LSFD of ``poles``
    (its other modes' terms are subtracted; computed when not given).

    The ratio is known once the split's second weighting round has its
    weights (:func:`~ema_pipeline.identification.refinement.refine.vp_fit`'s
    ``go_on``): a split whose ratio is above ``max_ratio`` stops there
    (``SplitFit.finished`` False, ``pole`` the first round's, ``cov`` NaN),
    the same ratio without the iterations that only move its poles. On noise
    they are most of a split's time.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(80.0, 120.0, 801)
    >>> lam = np.array([-3.0 + 2j * np.pi * 100.0, -3.0 + 2j * np.pi * 100.6])
    >>> jw = 2j * np.pi * f
    >>> H = np.stack([1 / (jw - lam[0]) + 0.5 / (jw - lam[1]),
    ...               1 / (jw - lam[0]) - 0.5 / (jw - lam[1])])
    >>> H = H + 1e-5 * np.random.default_rng(0).standard_normal(H.shape)
    >>> fit = split_fit(f, H, lam[:1], 0, quantity=None, thresholds=th)
    >>> np.sort(fit.pole.imag / (2 * np.pi)).round(2).tolist(), fit.residual_ratio < 0.01
    ([100.0, 100.6], True)
    """
    th = thresholds
    freq_hz = np.asarray(freq_hz, dtype=float)
    H = np.asarray(H)
    a_all = residues if residues is not None else global_residues(freq_hz, H, poles, quantity)
    local = local_problem(freq_hz, H, poles, r, th.split_half_width, th.local_min_lines, a_all,
                          thresholds=th)
    if local is None:
        return None
    f, Y, members, background, k, _ = local
    # the covariance of the better split only, when asked (SplitFit.cov: the
    # fit without the extra pole and the worse split need none)
    fits = []
    try:
        one = vp_fit(f, Y, poles[members], background, 10)
        var_a = np.mean(one.noise_std**2)  # the residual variance without the extra pole
        sides: tuple[float, ...] = (1.0, -1.0)
        if one.solved is not None:  # the side where the fit leaves more residual
            Rw, n = one.solved[1], f.size
            e = (Rw[:n] ** 2 + Rw[n:] ** 2).sum(axis=1)
            above = f > abs(poles[r].imag) / (2 * np.pi)
            sides = (1.0,) if e[above].sum() >= e[~above].sum() else (-1.0,)
        def ratio_of(fit: VPFit) -> float:
            return float(np.mean(fit.noise_std**2) / var_a)

        go_on = None if max_ratio is None else (lambda fit: ratio_of(fit) <= max_ratio)
        for side in sides:
            start = np.append(poles[members], poles[r] + side * 1j * abs(poles[r].real))
            fit = vp_fit(f, Y, start, background, th.split_max_iter, go_on=go_on)
            fits.append((ratio_of(fit), fit))
        ratio, best = min(fits, key=lambda fit: fit[0])
    except (np.linalg.LinAlgError, ValueError):
        return None
    lam = best.lam
    j = lam.size - 1
    return SplitFit(pole=lam[[k, j]], residual_ratio=ratio, fit=best, at=(k, j),
                    windows_s=(window_tau_s, force_window_s))
