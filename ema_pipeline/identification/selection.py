"""Automatic pole selection: clustering of the stable poles over model orders."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import squareform

from ema_pipeline.data import DataError
from ema_pipeline.identification.stabilization import (
    STABLE_FREQ,
    STABLE_VECTOR,
    StabilizationData,
)


@dataclass(frozen=True)
class SelectedPoles:
    """Physical poles chosen from the stabilization data, ascending frequency.

    Attributes
    ----------
    pole : (n_modes,) complex   identified pole (cluster median, before window correction)
    cluster : (n_modes,) int    cluster label in :attr:`StabilizationData.cluster`
    n_members : (n_modes,) int  number of model orders in the cluster
    scatter_fn_hz, scatter_zeta : (n_modes,) std of f_n and zeta over the members
    """

    pole: np.ndarray
    cluster: np.ndarray
    n_members: np.ndarray
    scatter_fn_hz: np.ndarray
    scatter_zeta: np.ndarray


def _distance(fn: np.ndarray, zeta: np.ndarray, tol_freq: float, tol_zeta: float) -> np.ndarray:
    """d_ij = |ln f_i - ln f_j| / tol_freq + |zeta_i - zeta_j| / (tol_zeta max(zeta_i, zeta_j))."""
    lf = np.log(fn)
    d = np.abs(lf[:, None] - lf[None, :]) / tol_freq
    zmax = np.maximum(np.maximum(zeta[:, None], zeta[None, :]), 1e-6)
    d += np.abs(zeta[:, None] - zeta[None, :]) / (tol_zeta * zmax)
    np.fill_diagonal(d, 0.0)
    return d


def cluster_poles(
    stab: StabilizationData,
    band_hz: tuple[float, float],
    *,
    tol_freq: float = 0.005,
    tol_zeta: float = 0.5,
    zeta_max: float = 0.2,
    edge: tuple[float, float] = (0.005, 0.02),
) -> np.ndarray:
    """Cluster labels (-1 = not a candidate) of the stable physical poles.

    Candidates: stable in frequency and participation vector (damping
    stability is not required: the damping of a lightly damped mode in noisy
    data wanders more than 5 % between orders while its frequency holds), a
    positive identified decay (sigma > 0) and window-corrected damping
    0 < zeta < ``zeta_max``, frequency inside ``band_hz`` less the fractions
    ``edge`` of its width at the bottom and top (poles at a band edge model the
    truncation, e.g. a mode just above the band or an anti-aliasing roll-off). They are grouped by
    average-linkage hierarchical clustering with the distance of
    :func:`_distance` (1 = a relative frequency difference of ``tol_freq``, or
    a relative damping difference of ``tol_zeta``), cut at distance 1.
    """
    need = STABLE_FREQ | STABLE_VECTOR
    cand = (
        ((stab.flags & need) == need)
        & (stab.pole.real < 0)
        & (stab.zeta > 0)
        & (stab.zeta < zeta_max)
        & (stab.freq_hz > band_hz[0] + edge[0] * (band_hz[1] - band_hz[0]))
        & (stab.freq_hz < band_hz[1] - edge[1] * (band_hz[1] - band_hz[0]))
    )
    labels = np.full(stab.order.size, -1)
    idx = np.flatnonzero(cand)
    if idx.size == 0:
        return labels
    # Poles more than tol_freq apart in frequency can never share a cluster
    # (their distance exceeds 1), so split the sorted candidates at such gaps
    # first and cluster each group on its own: memory and time stay small.
    idx = idx[np.argsort(stab.freq_hz[idx])]
    lf = np.log(stab.freq_hz[idx])
    cuts = np.flatnonzero(np.diff(lf) > tol_freq) + 1
    next_label = 0
    for group in np.split(idx, cuts):
        if group.size == 1:
            labels[group] = next_label
            next_label += 1
            continue
        d = _distance(stab.freq_hz[group], stab.zeta[group], tol_freq, tol_zeta)
        Z = linkage(squareform(d, checks=False), method="average")
        sub = fcluster(Z, t=1.0, criterion="distance") - 1
        labels[group] = sub + next_label
        next_label += int(sub.max()) + 1
    return labels


def select_poles(
    stab: StabilizationData,
    labels: np.ndarray,
    *,
    expect_hz: np.ndarray | None = None,
    min_fraction: float = 0.3,
    min_members: int = 4,
    expect_tol: float = 0.15,
) -> SelectedPoles:
    """One pole per physical mode from the clusters.

    A cluster is kept when it holds poles of at least
    ``max(min_members, min_fraction * n_orders)`` distinct model orders
    (computational poles do not stabilise over many orders). Its representative
    is the pole, one per order, nearest the cluster's median -- the complex
    median of the member poles. With ``expect_hz`` the cluster nearest each
    expected frequency (relative distance < ``expect_tol``) among those with at
    least ``min_members`` orders is taken instead, the largest first if several.
    """
    n_orders = np.unique(stab.order).size
    clusters = np.unique(labels[labels >= 0])
    info = []
    for c in clusters:
        m = np.flatnonzero(labels == c)
        # one pole per order: the one closest to the cluster median
        med = np.median(stab.pole[m].real) + 1j * np.median(stab.pole[m].imag)
        order_m = stab.order[m]
        dist = np.abs(stab.pole[m] - med)
        picked: list[int] = []
        for o in np.unique(order_m):
            mo = np.flatnonzero(order_m == o)
            picked.append(m[mo[np.argmin(dist[mo])]])
        keep = np.asarray(picked)
        rep = np.median(stab.pole[keep].real) + 1j * np.median(stab.pole[keep].imag)
        info.append(
            (c, rep, keep.size, np.std(stab.freq_hz[keep]), np.std(stab.zeta[keep]),
             float(np.median(stab.freq_hz[keep])))
        )
    if expect_hz is None:
        need = max(min_members, int(np.ceil(min_fraction * n_orders)))
        chosen = [row for row in info if row[2] >= need]
    else:
        pool = [row for row in info if row[2] >= min_members]
        chosen = []
        for fe in np.atleast_1d(np.asarray(expect_hz, dtype=float)):
            near = [row for row in pool if abs(row[5] - fe) < expect_tol * fe
                    and row not in chosen]
            if not near:
                raise DataError(
                    f"no stable pole cluster within {expect_tol:.0%} of the expected "
                    f"{fe:g} Hz; widen the band, raise max_order or drop the guess"
                )
            chosen.append(min(near, key=lambda row: abs(row[5] - fe) / fe - 1e-3 * row[2]))
    chosen.sort(key=lambda row: row[5])
    return SelectedPoles(
        pole=np.array([row[1] for row in chosen], dtype=complex),
        cluster=np.array([row[0] for row in chosen], dtype=int),
        n_members=np.array([row[2] for row in chosen], dtype=int),
        scatter_fn_hz=np.array([row[3] for row in chosen], dtype=float),
        scatter_zeta=np.array([row[4] for row in chosen], dtype=float),
    )
