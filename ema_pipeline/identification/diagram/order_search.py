"""The adaptive order search of the ``"plscf"`` backend
(:func:`~ema_pipeline.identification.plscf_backend.identify_plscf`): pLSCF
diagrams of growing order, pole trajectories, the cheap screen that counts
the determined modes, and the second searches of a wide band's lowest part
and of windows of a dense band. It yields the candidates that the backend
refines and tests.

Order (unless ``max_order`` fixes it): the first diagram is computed at
:func:`~ema_pipeline.identification.common.default_max_order`. The order is
doubled while the diagram may be short of modes -- when physical
trajectories that the data determine are still young at its last order
(:func:`young_trajectories`: a mode that stabilised late), or when it has
fewer than ``room_pairs_per_mode`` (4) pole pairs per mode found plus
``room_spare_pairs`` (16) to spare (noise and the modes outside the band take
poles too) -- and stops after two doublings without a gain in determined
modes (:meth:`OrderSearch.grows`), or at
:func:`~ema_pipeline.identification.diagram.resources.order_cap`, which depends on the number
of lines and references only. "Determined" is the screen
:func:`~ema_pipeline.identification.refinement.local_fits.quick_significance`
(std(sigma)/sigma below ``max_rel_sigma_std``, own peak above
``min_peak_ratio`` of the local data) over the *mature* trajectories
(started at or below ``mature_fraction`` of the order). The thresholds named
here are fields of
:class:`~ema_pipeline.identification.thresholds.SelectionThresholds`
(``OrderSearch.thresholds``). The diagram with
the most determined modes is used, plus the determined resonances (the peak
test of :func:`~ema_pipeline.identification.selection.acceptance.resonant` passed too) of the other
diagrams that none of its candidates covers: at low SNR a mode is sometimes
resolved at one order and a neighbour's trajectory at another, and the best
diagram alone loses one of them (measured on the SNR hard cases:
``docs/validation.md``).

Wide bands: when the band's top is more than ``zoom_ratio`` times its
bottom, the same search runs once more on its lowest 1/``zoom_ratio``
(:func:`add_zoom_modes`) and adds the candidates that the full band missed:
pLSCF's time step follows the band top, so low modes of a wide band are poorly
resolved (their poles crowd near z = 1).

Dense bands: when the search selects ``window_min_modes`` candidates or
more, it runs again in overlapping windows of ``window_modes``
consecutive candidates (:func:`mode_windows`, :func:`add_window_modes`) and
adds what they find that no candidate covers. With one common denominator for
20-40 modes the strong modes take the poles and a weak mode between them
(a few per cent of the local response) never forms a trajectory; in a window
of ten it does. The added candidates pass the same tests as all others.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from ema_pipeline.data import DataError
from ema_pipeline.identification.common import default_max_order
from ema_pipeline.identification.diagram.plscf import PoleSet, plscf
from ema_pipeline.identification.diagram.resources import order_cap
from ema_pipeline.identification.diagram.stabilization import pole_to_modal
from ema_pipeline.identification.refinement.local_fits import quick_significance
from ema_pipeline.identification.result import found_by_code
from ema_pipeline.identification.selection.trajectories import (
    SelectedPoles,
    link_fragments,
    merge_coincident,
    select_trajectories,
    track_poles,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fd_hz, poles_overlap
from ema_pipeline.runner import Mapper, SerialMap, map_costliest_first, started_ahead


def diagram_orders(p: int, n_in: int, max_orders: int) -> np.ndarray:
    """Orders of one diagram: every order (every second for one reference, whose
    odd orders only add a real pole) up to ``max_orders`` of them (default
    ``SelectionThresholds.diagram_orders``), else that many evenly spaced up to
    p (the companion eigenvalues, O(sum n^3), dominate the cost at high order).

    Examples
    --------
    >>> diagram_orders(10, 1, 40).tolist(), diagram_orders(200, 2, 4).tolist()
    ([2, 4, 6, 8, 10], [1, 67, 134, 200])
    """
    step = 2 if n_in == 1 else 1
    orders = np.arange(step, p + 1, step)
    if orders.size > max_orders:
        pick = np.unique(np.round(np.linspace(0, orders.size - 1, max_orders)).astype(int))
        orders = orders[pick]
    return orders


def young_trajectories(
    poles: PoleSet,
    traj: np.ndarray,
    selected: SelectedPoles,
    band_hz: tuple[float, float],
    window_decay_rate: float,
    *,
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """Last poles of the trajectories that are still young: alive at the last
    order, at least ``young_min_members`` members, physical (0 < zeta <
    ``max_zeta``, inside the band less its edges ``band_edge``) and not among
    ``selected`` -- modes that stabilised late and need more orders to be
    counted (if the data determine them); thresholds of ``thresholds``.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> order = np.array([2, 4, 6, 6])
    >>> lam = np.array([-1 + 300j, -1 + 300j, -1 + 300j, -1 + 600j])
    >>> ps = PoleSet(order=order, pole=lam, participation=np.ones((4, 1), complex),
    ...              orders=np.array([2, 4, 6]), dt=1 / 400)
    >>> none = SelectedPoles(*(np.zeros(0) for _ in range(5)))
    >>> traj = track_poles(ps, thresholds=th)
    >>> young_trajectories(ps, traj, none, (1.0, 190.0), 0.0, thresholds=th).size
    1
    """
    th = thresholds
    p = int(poles.orders[-1])
    last = np.flatnonzero(poles.order == p)
    ids, counts = np.unique(traj, return_counts=True)
    n_of = counts[np.searchsorted(ids, traj[last])]
    fn, _, zeta = pole_to_modal(poles.pole[last], window_decay_rate)
    lo, hi = band_hz
    ok = (
        (n_of >= th.young_min_members)
        & ~np.isin(traj[last], selected.cluster)
        & (zeta > 0) & (zeta < th.max_zeta)
        & (fn > lo + th.band_edge[0] * (hi - lo)) & (fn < hi - th.band_edge[1] * (hi - lo))
    )
    return np.asarray(poles.pole[last[ok]])


def cap_workers(map_: Mapper | None, n_in: int) -> int:
    """Worker processes for the cap's diagram, begun ahead
    (:func:`~ema_pipeline.runner.started_ahead`) once a search grows with a
    diagram still to compute below the cap: those of ``map_`` with one
    reference, else 1 (none: the eigenvalues of several references are
    shared out among the workers already). The largest diagram of a
    measured search (its roots one chain that cannot be shared out) is
    then computed beside the lower ones, with the same numbers: the main
    search of the pyFRF recording 0.46-0.48 -> 0.35-0.38 s, of the measured
    beam 0.40-0.42 -> 0.37-0.38 s (the command, 2 cores).

    Examples
    --------
    >>> from ema_pipeline.runner import SerialMap
    >>> two = SerialMap()
    >>> two.workers = 2
    >>> cap_workers(two, 1), cap_workers(two, 2), cap_workers(None, 1)
    (2, 1, 1)
    """
    return map_.workers if map_ is not None and n_in == 1 else 1


@dataclass(frozen=True)
class OrderSearch:
    """The adaptive order search of one band (see the module docstring):
    diagrams of growing order, pole trajectories, the cheap screen, the
    diagram with the most determined modes (and the other diagrams'
    determined resonances that it does not cover).

    ``min_peak`` is ``thresholds.min_peak_ratio`` or, with 3 or more
    channels, ``min_peak_ratio_shapes``; ``tolerances`` those of the pole
    linking (:func:`~ema_pipeline.identification.selection.trajectories.track_poles`;
    ``None``: ``thresholds.link_tol_*``)."""

    weights: np.ndarray | None
    window_decay_rate: float
    min_peak: float
    min_fraction: float
    expect: bool
    thresholds: SelectionThresholds
    tolerances: tuple[float, float, float] | None = None
    #: worker processes for the diagrams' eigenvalues and the windows'
    #: searches (:func:`ema_pipeline.runner.process_map`; None: this process)
    map_: Mapper | None = field(default=None, compare=False, repr=False)

    def run(
        self,
        freq: np.ndarray,
        Hn: np.ndarray,
        band: tuple[float, float],
        p: int,
        cap: int,
        *,
        fixed: bool,
    ) -> tuple[SelectedPoles, np.ndarray, PoleSet]:
        """Selected candidates, trajectory labels and poles of the chosen diagram.
        ``Hn`` (n_out, n_in, n_freq) normalised FRFs on the lines ``freq``; the
        search starts at order ``p`` and grows up to ``cap``
        (:meth:`grows`), or computes order ``p`` alone when ``fixed``
        (:meth:`screened`). Of the grown diagrams (:meth:`count`) the one
        with the most determined modes is chosen, with the others'
        determined resonances that it does not cover (:meth:`chosen`)."""
        Hn_c = Hn.reshape(-1, Hn.shape[-1])
        counts: list[DiagramCount] = []
        best: Diagram | None = None
        best_at = 0
        # once the search grows, the cap's diagram (the largest) is begun
        # ahead in a worker of its own while the lower orders are searched
        # here (:func:`cap_workers`)
        with contextlib.ExitStack() as ahead:
            at_cap: Callable[[], Diagram | None] | None = None
            while True:
                if p == cap and at_cap is not None:
                    diagram = at_cap()
                else:
                    diagram = self.diagram(freq, Hn, band, p)
                if diagram is None:  # singular normal equations
                    if best is None:
                        raise DataError(
                            f"pLSCF normal equations at order {p} are singular; give a lower "
                            "max_order or a wider band"
                        )
                    break  # too ill-conditioned to grow further: keep the last diagram
                if fixed:
                    return self.screened(freq, Hn_c, diagram)
                count = self.count(freq, Hn_c, band, p, cap, diagram)
                counts.append(count)
                if best is None or count.n_modes > counts[best_at].n_modes:
                    best, best_at = (count.offered, diagram[1], diagram[2]), len(counts) - 1
                if p >= cap or not self.grows(counts, Hn.shape[1]):
                    break
                p = min(2 * p, cap)
                if at_cap is None and p < cap:
                    at_cap = ahead.enter_context(started_ahead(
                        partial(replace(self, map_=None).diagram, freq, Hn, band), cap,
                        cap_workers(self.map_, Hn.shape[1])))
        assert best is not None
        return self.chosen(best, best_at, counts)

    def diagram(self, freq: np.ndarray, Hn: np.ndarray, band: tuple[float, float],
                p: int) -> Diagram | None:
        """The diagram of order ``p`` (up to ``thresholds.diagram_orders``
        orders, :func:`diagram_orders`), its pole trajectories (linked,
        fragments joined) and the trajectories selected as candidates (the
        coincident ones merged); None when pLSCF's normal equations are
        singular. A guess (``expect``) needs fewer members than an automatic
        pick, and any fraction of the orders."""
        th = self.thresholds
        min_fraction, min_members = ((0.0, th.expect_min_members) if self.expect
                                     else (self.min_fraction, th.min_members))
        orders = diagram_orders(p, Hn.shape[1], th.diagram_orders)
        try:
            poles = plscf(freq, Hn, max_order=p, orders=orders, weights=self.weights,
                          map_=self.map_)
        except (np.linalg.LinAlgError, DataError):
            return None
        # a band of few lines allows few orders (46 lines at one reference:
        # orders 2-10): a mode stable from the second of them on still counts
        members = min(min_members, max(orders.size - 1, 2))
        decay = self.window_decay_rate
        traj = link_fragments(poles, track_poles(poles, self.tolerances, thresholds=th), decay,
                              min_fraction=min_fraction, min_members=members, thresholds=th)
        sel = select_trajectories(poles, traj, band, decay, min_fraction=min_fraction,
                                  min_members=members, thresholds=th)
        return merge_coincident(sel, thresholds=th), traj, poles

    def screened(self, freq: np.ndarray, Hn_c: np.ndarray, diagram: Diagram) -> Diagram:
        """A fixed order's diagram with the candidates whose own peak is above
        ``min_peak``; for a guess (``expect``) only the determined
        resonances (the peak test of
        :func:`~ema_pipeline.identification.selection.acceptance.resonant`)."""
        th = self.thresholds
        sel, traj, poles = diagram
        rel, peak, snr = quick_significance(freq, Hn_c, sel.pole, thresholds=th)
        screen = peak > self.min_peak
        if self.expect:  # a guess is answered by a determined resonance
            screen &= (rel < th.max_rel_sigma_std) & (
                (peak >= th.weak_peak_ratio) | (snr >= th.min_weak_peak_snr))
        return sel.subset(screen), traj, poles

    def count(self, freq: np.ndarray, Hn_c: np.ndarray, band: tuple[float, float], p: int,
              cap: int, diagram: Diagram) -> DiagramCount:
        """What the cheap screen
        (:func:`~ema_pipeline.identification.refinement.local_fits.quick_significance`,
        one linear fit) finds determined in the diagram of order ``p``: the
        mature candidates it determines, the young trajectories
        (:func:`young_trajectories`) that ask for a higher order, the
        determined resonances and the candidates the diagram offers if it is
        the best."""
        th = self.thresholds
        sel, traj, poles = diagram
        young = young_trajectories(poles, traj, sel, band, self.window_decay_rate,
                                   thresholds=th)
        rel, peak, snr = quick_significance(freq, Hn_c, np.concatenate([sel.pole, young]),
                                            thresholds=th)
        n = sel.pole.size
        ok = (rel < th.max_rel_sigma_std) & (peak > self.min_peak)
        # determined resonances (the peak test of acceptance.resonant):
        # what answers an expected frequency
        counted = ok & ((peak >= th.weak_peak_ratio) | (snr >= th.min_weak_peak_snr))
        # mature: stable over at least the last quarter of the orders (a
        # trajectory born later is confirmed by the next, larger diagram)
        mature = (sel.first_order < th.mature_fraction * p) | (p >= cap)
        ok_young = (rel < th.young_max_rel_sigma_std) & (peak > th.young_min_peak_ratio)
        # a guess is answered by a determined resonance
        offer = counted[:n] if self.expect else (peak[:n] > self.min_peak) & mature
        return DiagramCount(
            p=p, n_modes=int(np.sum(ok[:n] & mature)), n_young=int(np.sum(ok_young[n:])),
            # determined resonances of every diagram: a mode that one diagram
            # resolves and the best one (more modes in all) lost is kept
            resolved=sel.subset(counted[:n] & mature), offered=sel.subset(offer))

    def grows(self, counts: list[DiagramCount], n_in: int) -> bool:
        """Whether the search doubles the order after ``counts[-1]``: while
        young trajectories ask for it or the diagram has fewer than
        ``room_pairs_per_mode`` pole pairs per determined mode plus
        ``room_spare_pairs``, and not after two doublings without a gain in
        determined modes (the data hold no more)."""
        th, last = self.thresholds, counts[-1]
        room = last.p * n_in / 2 >= th.room_pairs_per_mode * last.n_modes + th.room_spare_pairs
        if len(counts) >= 3 and last.n_modes <= counts[-2].n_modes <= counts[-3].n_modes:
            return False
        return last.n_young > 0 or not room

    def chosen(self, best: Diagram, best_at: int, counts: list[DiagramCount]) -> Diagram:
        """The best diagram's candidates plus, without a guess, the determined
        resonances of the other diagrams that none of them covers
        (:func:`add_uncovered`, ``"other_order"``)."""
        if self.expect:
            return best
        sel = best[0]
        for k, count in enumerate(counts):
            if k != best_at:
                sel = add_uncovered(sel, count.resolved, "other_order")
        return sel, best[1], best[2]


#: One diagram of the search: its candidates, trajectory labels and poles.
Diagram = tuple[SelectedPoles, np.ndarray, PoleSet]


@dataclass(frozen=True)
class DiagramCount:
    """What :meth:`OrderSearch.count` found in the diagram of order ``p``:
    ``n_modes`` mature candidates the screen determines, ``n_young`` young
    trajectories it determines, the determined resonances (``resolved``) and
    the candidates the diagram offers if it is the best (``offered``)."""

    p: int
    n_modes: int
    n_young: int
    resolved: SelectedPoles
    offered: SelectedPoles


def search_window(
    search: OrderSearch,
    freq: np.ndarray,
    Hn: np.ndarray,
    window_hz: tuple[float, float],
) -> SelectedPoles | None:
    """Candidates of ``search`` run on the lines of ``freq`` inside ``window_hz``
    alone, from the default order up to the window's cap (:func:`order_cap`
    with ``window=True``: 4:1 equations to coefficients); None when the window has
    fewer than ``thresholds.window_min_lines`` lines or its normal equations
    are singular.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> search = OrderSearch(None, 0.0, 0.05, 0.3, expect=False, thresholds=th)
    >>> search_window(search, np.arange(10.0, 60.0), np.ones((1, 1, 50)), (10, 60)) is None
    True
    """
    lines = (freq >= window_hz[0]) & (freq <= window_hz[1])
    if lines.sum() < search.thresholds.window_min_lines:
        return None
    fz, Hz = freq[lines], Hn[:, :, lines]
    if search.weights is not None:
        search = replace(search, weights=search.weights[..., lines])
    n_in = Hz.shape[1]
    cap = order_cap(fz.size, n_in, search.thresholds.max_poles, window=True)
    try:
        zsel, _, _ = search.run(fz, Hz, window_hz, min(default_max_order(n_in, fz.size), cap),
                                cap, fixed=False)
    except DataError:
        return None
    return zsel


def add_uncovered(sel: SelectedPoles, new: SelectedPoles | None,
                  found_by: str | None = None) -> SelectedPoles:
    """``sel`` plus the candidates of ``new`` (from another diagram) that no
    candidate of ``sel`` covers (within the sum of their half-power
    half-widths); they carry trajectory label -1 (their diagram is not the one
    stored) and, when given, ``found_by`` (``SelectedPoles.found_by``: a
    narrower search's are ``"window"``). Sorted by frequency.

    Examples
    --------
    >>> one = SelectedPoles(np.array([-1 + 100j]), np.zeros(1, int), np.ones(1, int),
    ...                     np.zeros(1), np.zeros(1), np.zeros(1, int))
    >>> two = SelectedPoles(np.array([-1 + 100.5j, -1 + 150j]), np.zeros(2, int),
    ...                     np.ones(2, int), np.zeros(2), np.zeros(2), np.zeros(2, int))
    >>> add_uncovered(one, two).pole.imag.tolist(), add_uncovered(one, two).cluster.tolist()
    ([100.0, 150.0], [0, -1])
    """
    if new is None or new.pole.size == 0:
        return sel
    fresh = ~np.any(poles_overlap(new.pole, sel.pole), axis=1)
    if not fresh.any():
        return sel
    add = new.subset(fresh)
    add = replace(add, cluster=np.full(add.pole.size, -1))
    if found_by is not None:
        add = replace(add, found_by=found_by_code(found_by, add.pole.size))
    merged = sel.concatenate(add)
    return merged.subset(np.argsort(merged.pole.imag))


#: One narrower search of :func:`add_zoom_modes` or :func:`add_window_modes`:
#: its band (Hz), its candidates (None: too few lines or singular) and those of
#: them that a candidate already selected covered (None: none).
SearchedBand = tuple[tuple[float, float], SelectedPoles | None, SelectedPoles | None]


def covered_candidates(sel: SelectedPoles, new: SelectedPoles | None) -> SelectedPoles | None:
    """The candidates of ``new`` that a candidate of ``sel`` covers (within
    the sum of their half-power half-widths): those :func:`add_uncovered`
    leaves out. They are alternates: when the candidate that covers one fails
    the final tests, the alternate, from a search of a narrower band, may be
    the mode (band 250-700 Hz of the measured beam: the full band gives a
    pole of zeta 0.9 % at 603.8 Hz that fails, a window 0.17 % at 603.0 Hz).

    Examples
    --------
    >>> def candidates(*pole):
    ...     n = len(pole)
    ...     return SelectedPoles(np.array(pole), np.zeros(n, int), np.ones(n, int),
    ...                          np.zeros(n), np.zeros(n), np.zeros(n, int))
    >>> covered_candidates(candidates(-2 + 300j), candidates(-1 + 296j, -1 + 301j)).pole.tolist()
    [(-1+301j)]
    """
    if new is None or new.pole.size == 0 or sel.pole.size == 0:
        return None
    return new.subset(np.any(poles_overlap(new.pole, sel.pole), axis=1))


def add_zoom_modes(
    sel: SelectedPoles,
    search: OrderSearch,
    freq: np.ndarray,
    Hn: np.ndarray,
    band: tuple[float, float],
) -> tuple[SelectedPoles, list[SearchedBand]]:
    """``sel`` plus the uncovered candidates (:func:`add_uncovered`) of a
    second search of the band's lowest 1/``zoom_ratio`` (of
    ``search.thresholds``), and that search: its band, its candidates and
    those of them that ``sel`` covers (:func:`covered_candidates`). ``sel``
    unchanged and no search for a narrower band or one with too few lines in
    that part.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> none = SelectedPoles(*(np.zeros(0) for _ in range(5)))
    >>> search = OrderSearch(None, 0.0, 0.05, 0.3, expect=False, thresholds=th)
    >>> sel, searched = add_zoom_modes(none, search, np.arange(10.0, 60.0),
    ...                                np.ones((1, 1, 50)), (10, 60))
    >>> sel.pole.size, searched
    (0, [])
    """
    lo, hi = band
    zoom = search.thresholds.zoom_ratio
    if hi < zoom * lo:
        return sel, []
    zsel = search_window(search, freq, Hn, (lo, lo + (hi - lo) / zoom))
    sel = without_merged(sel, zsel)
    searched = [((lo, lo + (hi - lo) / zoom), zsel, covered_candidates(sel, zsel))]
    return add_uncovered(sel, zsel, "window"), searched


def without_merged(sel: SelectedPoles, new: SelectedPoles | None) -> SelectedPoles:
    """``sel`` less the candidates that cover two or more candidates of ``new``
    (within the sum of their half-power half-widths): a wide pole of a
    diagram that resolves the band poorly standing for a close pair that
    ``new``, a search of a narrower band, separates (impact tests with a
    pair 5 % apart at 17 Hz: the full band of 2-900 Hz gives one pole of
    zeta 4 % which fails the final tests, its lowest eighth the two modes).

    Examples
    --------
    >>> def cands(p):
    ...     n = len(p)
    ...     return SelectedPoles(np.array(p), np.zeros(n, int), np.ones(n, int),
    ...                          np.zeros(n), np.zeros(n), np.zeros(n, int))
    >>> wide, pair = cands([-8 + 100j, -1 + 300j]), cands([-1 + 97j, -1 + 103j])
    >>> without_merged(wide, pair).pole.tolist()
    [(-1+300j)]
    """
    if new is None or new.pole.size < 2 or sel.pole.size == 0:
        return sel
    merged = np.sum(poles_overlap(sel.pole, new.pole), axis=1) >= 2
    return sel.subset(~merged) if merged.any() else sel


def mode_windows(
    fn_hz: np.ndarray, band: tuple[float, float], *, thresholds: SelectionThresholds
) -> list[tuple[float, float]]:
    """Windows of ``window_modes`` consecutive candidate frequencies
    ``fn_hz`` inside ``band``, shifted by ``window_step``, each reaching to
    halfway between its outermost candidates and their outer neighbours (the
    band's edges at the ends); none with fewer than ``window_min_modes``
    candidates (fields of ``thresholds``).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> mode_windows(np.arange(1.0, 15.0) * 10, (5.0, 145.0), thresholds=th)
    [(5.0, 105.0), (45.0, 145.0)]
    """
    th = thresholds
    lo, hi = band
    f = np.sort(fn_hz[(fn_hz > lo) & (fn_hz < hi)])
    n = f.size
    if n < th.window_min_modes:
        return []
    edge = np.concatenate([[lo], (f[1:] + f[:-1]) / 2, [hi]])  # edge[k]: below candidate k
    out = []
    for s in range(0, n, th.window_step):
        e = min(s + th.window_modes, n)
        out.append((float(edge[s]), float(edge[e])))
        if e == n:
            break
    return out


def add_window_modes(
    sel: SelectedPoles,
    search: OrderSearch,
    freq: np.ndarray,
    Hn: np.ndarray,
    band: tuple[float, float],
) -> tuple[SelectedPoles, list[SearchedBand]]:
    """``sel`` plus the uncovered candidates (:func:`add_uncovered`) of searches
    in the windows of :func:`mode_windows` (a dense band; unchanged with fewer
    than ``window_min_modes`` candidates), and each window's search, as by
    :func:`add_zoom_modes`.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> none = SelectedPoles(*(np.zeros(0) for _ in range(5)))
    >>> search = OrderSearch(None, 0.0, 0.05, 0.3, expect=False, thresholds=th)
    >>> f = np.arange(10.0, 60.0)
    >>> sel, searched = add_window_modes(none, search, f, np.ones((1, 1, 50)), (10, 60))
    >>> sel.pole.size, searched
    (0, [])
    """
    windows = mode_windows(pole_fd_hz(sel.pole), band, thresholds=search.thresholds)
    # the windows' searches are independent: side by side in the worker
    # processes of search.map_, folded in in the windows' order as a serial
    # loop would
    local = replace(search, map_=None)  # a worker's search runs in the worker
    map_ = search.map_ if search.map_ is not None else SerialMap()
    # the longest first: a window's lines set its order cap, hence its cost
    lines = [float(np.sum((freq >= lo) & (freq <= hi))) for lo, hi in windows]
    found = map_costliest_first(map_, partial(search_window, local, freq, Hn), windows, lines)
    searched: list[SearchedBand] = []
    for window, wsel in zip(windows, found, strict=True):
        searched.append((window, wsel, covered_candidates(sel, wsel)))
        sel = add_uncovered(sel, wsel, "window")
    return sel, searched
