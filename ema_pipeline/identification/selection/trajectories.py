"""Automatic pole selection: pole trajectories over model orders.

Every pole of a model order is linked one-to-one to a pole of one of the
previous computed orders (:func:`track_poles`), so each physical mode becomes
one *trajectory* through the stabilization diagram, even when its frequency
drifts slowly with the order or when it stabilises only at high order. A
trajectory with enough members whose settled poles are physical is a mode
(:func:`select_trajectories`); two trajectories that coexist at the same
orders stay two modes however close they are (close modes), unless their poles
coincide numerically (:func:`merge_coincident`).

Why written here: scipy's hierarchical clustering needs the dense all-pairs
distance matrix of every candidate pole (O(n^2) memory: 4.8 GiB at order 400)
and cannot use the order structure; the linking needs only one
(poles of order n) x (open trajectories) distance matrix at a time.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ema_pipeline.identification.diagram.plscf import PoleSet
from ema_pipeline.identification.diagram.stabilization import pole_to_modal
from ema_pipeline.identification.result import (  # light result types
    SelectedPoles,
    found_by_code,
)
from ema_pipeline.identification.selection.expect import within_tolerance
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import mac, poles_overlap


def track_poles(
    poles: PoleSet,
    tolerances: tuple[float, float, float] | None = None,
    *,
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """Trajectory label of every pole of ``poles`` (sorted by order).

    A pole of order n is linked to the open end of a trajectory whose last
    pole is at one of the ``thresholds.link_max_gap`` previous computed
    orders, one-to-one, smallest distance first, if

        d = |df| / (tol_freq f) + |dzeta| / (tol_zeta max(zeta)) + (1 - MAC(l)) / tol_mac < 1,

    with l the participation vectors and ``tolerances`` = (tol_freq,
    tol_zeta, tol_mac) (default ``thresholds.link_tol_*``; see
    ``IdentificationOptions.link_tolerances``); otherwise it starts a new
    trajectory. Memory: one (poles of order n) x (open trajectories) matrix at
    a time.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> from ema_pipeline.identification.diagram.plscf import PoleSet
    >>> lam = np.array([-1 + 100j, -1 + 100.2j, -5 + 300j, -1 + 100.3j])
    >>> ps = PoleSet(order=np.array([2, 4, 4, 6]), pole=lam,
    ...              participation=np.ones((4, 1), complex), orders=np.array([2, 4, 6]), dt=1e-3)
    >>> track_poles(ps, thresholds=th).tolist()
    [0, 0, 1, 0]
    """
    th = thresholds
    tol_freq, tol_zeta, tol_mac = tolerances or (th.link_tol_freq, th.link_tol_zeta,
                                                 th.link_tol_mac)
    max_gap = th.link_max_gap
    fn, _, zeta = pole_to_modal(poles.pole)
    zeta = np.abs(zeta)
    part = poles.participation
    traj = np.full(poles.pole.size, -1)
    starts = np.searchsorted(poles.order, poles.orders)
    ends = np.append(starts[1:], poles.order.size)
    tail = np.zeros(0, dtype=int)  # last pole of each trajectory
    tail_k = np.zeros(0, dtype=int)  # index of its order
    for k in range(poles.orders.size):
        cur = np.arange(starts[k], ends[k])
        if cur.size == 0:
            continue
        open_t = np.flatnonzero(k - tail_k <= max_gap)
        if open_t.size:
            tp = tail[open_t]
            d = np.abs(fn[cur][:, None] - fn[tp][None, :]) / (tol_freq * fn[tp][None, :])
            zmax = np.maximum(np.maximum(zeta[cur][:, None], zeta[tp][None, :]), 1e-4)
            d += np.abs(zeta[cur][:, None] - zeta[tp][None, :]) / (tol_zeta * zmax)
            if part.shape[1] > 1:
                d += (1 - mac(part[cur].T, part[tp].T)) / tol_mac
            ii, jj = np.nonzero(d < 1)
            if ii.size:
                o = np.argsort(d[ii, jj], kind="stable")
                ii, jj = ii[o], jj[o]
                # greedy one-to-one matching, smallest distance first
                used_c = np.zeros(cur.size, bool)
                used_t = np.zeros(open_t.size, bool)
                for i, j in zip(ii.tolist(), jj.tolist(), strict=True):
                    if used_c[i] or used_t[j]:
                        continue
                    used_c[i] = used_t[j] = True
                    t = open_t[j]
                    traj[cur[i]] = t
                    tail[t] = cur[i]
                    tail_k[t] = k
        new = cur[traj[cur] < 0]
        traj[new] = tail.size + np.arange(new.size)
        tail = np.concatenate([tail, new])
        tail_k = np.concatenate([tail_k, np.full(new.size, k)])
    return traj


def link_fragments(
    poles: PoleSet,
    traj: np.ndarray,
    window_decay_rate: float = 0.0,
    *,
    min_fraction: float,
    min_members: int,
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """``traj`` with the pieces of one heavily damped mode's trajectory joined.

    The pole of a mode with zeta of several per cent moves between orders by
    more than the 1 % that :func:`track_poles` allows, so its trajectory
    breaks into pieces too short to be selected. A piece (2 members or more,
    fewer than ``max(min_members, min_fraction * n_orders)``: one that
    :func:`select_trajectories` would not take on its own) whose median pole
    has structural damping (``window_decay_rate`` 1/tau
    removed) of at least ``thresholds.fragment_min_zeta`` is joined to a later
    piece that starts within ``fragment_max_gap`` computed orders of its end,
    when their median frequencies differ by less than half the half-power
    half-width zeta f and their damping by less than ``fragment_tol_zeta`` of
    the larger (closest first,
    one-to-one). The joined trajectory is then judged like any other by
    :func:`select_trajectories`.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> order = np.repeat(np.arange(2, 14, 2), 1)
    >>> f = np.array([100.0, 100.4, 100.2, 102.5, 102.2, 102.8])
    >>> lam = -0.05 * 2 * np.pi * f + 2j * np.pi * f
    >>> ps = PoleSet(order=order, pole=lam, participation=np.ones((6, 1), complex),
    ...              orders=np.arange(2, 14, 2), dt=1e-3)
    >>> tr = track_poles(ps, thresholds=th)
    >>> joined = link_fragments(ps, tr, min_fraction=0.3, min_members=6, thresholds=th)
    >>> len(set(tr.tolist())), len(set(joined.tolist()))  # 3 + 3 < 6 members
    (2, 1)
    """
    th = thresholds
    min_zeta, tol_zeta, max_gap = th.fragment_min_zeta, th.fragment_tol_zeta, th.fragment_max_gap
    ids, inv, counts = np.unique(traj, return_inverse=True, return_counts=True)
    if ids.size < 2:
        return traj
    k_of = np.searchsorted(poles.orders, poles.order)  # computed-order index of each pole
    first = np.full(ids.size, np.iinfo(np.int64).max)
    last = np.full(ids.size, -1)
    np.minimum.at(first, inv, k_of)
    np.maximum.at(last, inv, k_of)
    fn_all, _, z_all = pole_to_modal(poles.pole, window_decay_rate)
    fn, zs = _group_median(fn_all, inv, counts), _group_median(z_all, inv, counts)
    short = counts < max(min_members, int(np.ceil(min_fraction * poles.orders.size)))
    cand = np.flatnonzero((counts >= 2) & short & (zs >= min_zeta) & (zs < th.max_zeta))
    if cand.size < 2:
        return traj
    a, b = cand[:, None], cand[None, :]
    gap = first[b] - last[a]
    zmax = np.maximum(zs[a], zs[b])
    d = np.abs(fn[a] - fn[b]) / (0.5 * zmax * fn[a]) + np.abs(zs[a] - zs[b]) / (tol_zeta * zmax)
    ok = (gap >= 1) & (gap <= max_gap) & (d < 1)
    parent = np.arange(ids.size)
    used_a = np.zeros(ids.size, bool)
    used_b = np.zeros(ids.size, bool)
    ii, jj = np.nonzero(ok)
    for i, j in sorted(zip(ii.tolist(), jj.tolist(), strict=True), key=lambda p: d[p]):
        ta, tb = cand[i], cand[j]
        if used_a[ta] or used_b[tb]:
            continue
        used_a[ta] = used_b[tb] = True
        parent[tb] = ta
    root = parent.copy()
    for _ in range(ids.size):  # follow the chains to their first piece
        nxt = parent[root]
        if np.array_equal(nxt, root):
            break
        root = nxt
    return np.asarray(ids[root][inv])


def _group_median(values: np.ndarray, group: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Median of ``values`` per group label ``group`` (0 .. counts.size - 1)."""
    order = np.lexsort((values, group))
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    lo = order[start + (counts - 1) // 2]
    hi = order[start + counts // 2]
    return np.asarray((values[lo] + values[hi]) / 2)


def select_trajectories(
    poles: PoleSet,
    traj: np.ndarray,
    band_hz: tuple[float, float],
    window_decay_rate: float = 0.0,
    *,
    min_fraction: float,
    min_members: int,
    thresholds: SelectionThresholds,
) -> SelectedPoles:
    """The trajectories that are physical modes, ascending frequency.

    A trajectory is a mode when

    * it holds at least ``max(min_members, min_fraction * n_orders)`` poles
      (however late it starts: a mode that stabilises at high order is kept);
    * its pole -- the median of the last half of its members -- has a positive
      decay, window-corrected damping 0 < zeta < ``thresholds.max_zeta`` and a
      frequency inside ``band_hz`` less the fractions ``thresholds.band_edge``
      of its width at the bottom and top (poles at a band edge model the
      truncation);
    * it has settled: over that last half f_n and zeta scatter by less than
      ``thresholds.max_scatter`` of the half-power half-width (zeta f_n) and
      of zeta.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> from ema_pipeline.identification.diagram.plscf import PoleSet
    >>> order = np.repeat(np.arange(2, 22, 2), 2)
    >>> lam = np.tile([-2 + 2 * np.pi * 50j, -900 + 2 * np.pi * 80j], 10)
    >>> ps = PoleSet(order=order, pole=lam, participation=np.ones((20, 1), complex),
    ...              orders=np.arange(2, 22, 2), dt=1 / 200)
    >>> sel = select_trajectories(ps, track_poles(ps, thresholds=th), (1.0, 100.0),
    ...                           min_fraction=0.3, min_members=6, thresholds=th)
    >>> (sel.pole.imag / (2 * np.pi)).round(1).tolist(), sel.n_members.tolist()
    ([50.0], [10])
    """
    th = thresholds
    edge, zeta_max, max_scatter = th.band_edge, th.max_zeta, th.max_scatter
    n_orders = poles.orders.size
    need = max(min_members, int(np.ceil(min_fraction * n_orders)))
    lo, hi = band_hz
    w = hi - lo
    rows = []
    if traj.size:
        ids, counts = np.unique(traj, return_counts=True)
        order_idx = np.argsort(traj, kind="stable")
        bounds = np.concatenate([[0], np.cumsum(counts)])
        for t in np.flatnonzero(counts >= need):
            m = order_idx[bounds[t] : bounds[t + 1]]  # members, ascending order
            tail = m[m.size // 2 :]
            rep = np.median(poles.pole[tail].real) + 1j * np.median(poles.pole[tail].imag)
            fn, _, z = pole_to_modal(np.array([rep]), window_decay_rate)
            if not (rep.real < 0 and 0 < z[0] < zeta_max
                    and lo + edge[0] * w < fn[0] < hi - edge[1] * w):
                continue
            f_i, _, z_i = pole_to_modal(poles.pole[tail])
            zi = max(float(np.median(z_i)), 1e-6)
            if np.std(f_i) > max_scatter * zi * np.median(f_i) or np.std(z_i) > max_scatter * zi:
                continue
            f_c, _, z_c = pole_to_modal(poles.pole[tail], window_decay_rate)
            rows.append((rep, int(ids[t]), m.size, float(np.std(f_c)), float(np.std(z_c)),
                         int(poles.order[m[0]])))
    rows.sort(key=lambda row: row[0].imag)
    return _selected(rows)


def _selected(rows: list[tuple]) -> SelectedPoles:
    return SelectedPoles(
        pole=np.array([r[0] for r in rows], dtype=complex),
        cluster=np.array([r[1] for r in rows], dtype=int),
        n_members=np.array([r[2] for r in rows], dtype=int),
        scatter_fn_hz=np.array([r[3] for r in rows], dtype=float),
        scatter_zeta=np.array([r[4] for r in rows], dtype=float),
        first_order=np.array([r[5] for r in rows], dtype=int),
        found_by=found_by_code("diagram", len(rows)),
    )


def merge_coincident(sel: SelectedPoles, *, thresholds: SelectionThresholds
                     ) -> SelectedPoles:
    """Drop a trajectory whose pole lies within ``thresholds.coincident_rel``
    of a decay rate of the
    pole of a longer one (numerically the same pole, e.g. a trajectory broken
    by a gap); close modes, whose poles differ by more, are kept.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> sel = SelectedPoles(pole=np.array([-1 + 100j, -1 + 100.1j, -1 + 110j]),
    ...                     cluster=np.arange(3), n_members=np.array([10, 4, 8]),
    ...                     scatter_fn_hz=np.zeros(3), scatter_zeta=np.zeros(3))
    >>> merge_coincident(sel, thresholds=th).pole.imag.tolist()
    [100.0, 110.0]
    """
    rel = thresholds.coincident_rel
    pole = sel.pole
    keep = np.ones(pole.size, bool)
    for a in np.argsort(-sel.n_members, kind="stable"):
        if not keep[a]:
            continue
        near = np.abs(pole - pole[a]) < rel * np.abs(pole[a].real)
        near[a] = False
        keep &= ~near
    return sel.subset(keep)


def select_expected(
    candidates: SelectedPoles,
    expect_hz: np.ndarray,
    window_decay_rate: float = 0.0,
    *,
    thresholds: SelectionThresholds,
) -> SelectedPoles:
    """For each expected frequency the candidate trajectory nearest to it
    (relative distance < ``thresholds.expect_tol``,
    :func:`~ema_pipeline.identification.selection.expect.within_tolerance`: the
    tolerance by which a guess is reported not found; the longer one when equally near),
    each candidate used once. A guess with no candidate that near gets none:
    :func:`ema_pipeline.identification.identify` then reports it as not
    found (a warning; an empty row in the modes table), it is never an error.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> sel = SelectedPoles(pole=np.array([-1 + 2j * np.pi * 50, -1 + 2j * np.pi * 80]),
    ...                     cluster=np.arange(2), n_members=np.array([10, 8]),
    ...                     scatter_fn_hz=np.zeros(2), scatter_zeta=np.zeros(2))
    >>> fn_hz = lambda s: (s.pole.imag / (2 * np.pi)).round(1).tolist()
    >>> fn_hz(select_expected(sel, np.array([78.0]), thresholds=th))
    [80.0]
    >>> fn_hz(select_expected(sel, np.array([20.0, 52.0]), thresholds=th))
    [50.0]
    """
    expect_tol = thresholds.expect_tol
    fn, _, _ = pole_to_modal(candidates.pole, window_decay_rate)
    chosen: list[int] = []
    for fe in np.atleast_1d(np.asarray(expect_hz, dtype=float)):
        d = np.abs(fn - fe) / fe - 1e-4 * candidates.n_members
        ok = within_tolerance(fn, fe, expect_tol)
        ok[chosen] = False
        if ok.any():
            chosen.append(int(np.argmin(np.where(ok, d, np.inf))))
    idx = np.array(sorted(chosen, key=lambda i: fn[i]), dtype=int)
    return candidates.subset(idx)


def expected_from_automatic(
    expected: SelectedPoles,
    expect_hz: np.ndarray,
    auto_fn_hz: np.ndarray,
    auto_start: np.ndarray,
    window_decay_rate: float = 0.0,
    *,
    thresholds: SelectionThresholds,
) -> tuple[SelectedPoles, np.ndarray]:
    """The expected candidates with the automatic selection's modes put in.

    A guess that an automatic mode answers (frequency ``auto_fn_hz`` within
    ``thresholds.expect_tol`` of it, nearest first, each mode once) gets that
    mode's start pole ``auto_start``, in the row of the expected candidate
    nearest to it (its trajectory; a row of its own with label -1 and no
    orders when there is none). An expected candidate left over is kept when no
    automatic mode covers it (within the sum of their half-power
    half-widths). Returns those rows, ascending frequency, and the indices of
    the automatic modes not used: refined alongside them as neighbours, so
    that an expected pole is the automatic one (the measured beam's 119.4 Hz
    mode refined without its neighbour at 118.0 Hz took both: zeta 0.47 %
    against 0.11 %).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> lam = np.array([-1 + 2j * np.pi * 50.0, -1 + 2j * np.pi * 81.0])
    >>> sel = SelectedPoles(pole=lam, cluster=np.arange(2), n_members=np.array([10, 8]),
    ...                     scatter_fn_hz=np.zeros(2), scatter_zeta=np.zeros(2))
    >>> auto = np.array([-0.5 + 2j * np.pi * 79.0, -0.5 + 2j * np.pi * 80.0])
    >>> rows, rest = expected_from_automatic(sel, np.array([50.0, 80.0]), np.array([79.0, 80.0]),
    ...                                      auto, thresholds=th)
    >>> (rows.pole.imag / (2 * np.pi)).round(1).tolist(), rows.cluster.tolist(), rest.tolist()
    ([50.0, 80.0], [0, 1], [0])
    """
    expect_tol = thresholds.expect_tol
    fn_e, _, _ = pole_to_modal(expected.pole, window_decay_rate)
    used_a = np.zeros(auto_fn_hz.size, bool)
    used_e = np.zeros(expected.pole.size, bool)
    rows = []
    for fe in np.atleast_1d(np.asarray(expect_hz, dtype=float)):
        d = np.where(used_a, np.inf, np.abs(auto_fn_hz - fe))
        if not d.size or d.min() >= expect_tol * fe:
            continue
        a = int(np.argmin(d))
        used_a[a] = True
        de = np.where(used_e, np.inf, np.abs(fn_e - auto_fn_hz[a]))
        if de.size and de.min() < expect_tol * fe:
            e = int(np.argmin(de))
            used_e[e] = True
            rows.append(replace(expected.subset(np.array([e])), pole=auto_start[[a]]))
        else:
            n = 1
            rows.append(SelectedPoles(auto_start[[a]], np.full(n, -1), np.zeros(n, int),
                                      np.zeros(n), np.zeros(n), np.zeros(n, int),
                                      found_by_code("expected", n)))
    left = expected.subset(~used_e)
    if left.pole.size and auto_start.size:
        left = left.subset(~np.any(poles_overlap(left.pole, auto_start), axis=1))
    out = expected.subset(np.zeros(0, int))
    for row in [*rows, left]:
        out = out.concatenate(row)
    return out.subset(np.argsort(out.pole.imag)), np.flatnonzero(~used_a)
