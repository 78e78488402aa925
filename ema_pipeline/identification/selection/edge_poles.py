"""Resonances at the band's edges: poles kept in their neighbours' fits, not reported.

A mode just past the band's top (or bottom), or in the band's edge zone
(``SelectionThresholds.band_edge``, where a pole is taken to model the
truncation and is not selected), is not in the model of the band. Its
resonance, whose half-power band reaches into the band, is then fitted by
the nearest kept mode: its pole is pulled towards it and its shape bent (a
plate's top mode at MAC 0.84 with its analytic shape, the next mode 0.8 %
above the band's top; docs/validation.md).

Where the FRFs go on past the band, :func:`edge_fit` finds such poles:
when the residual of the kept modes' fit over the band (the global LSFD with
the residual terms) rises into an edge zone to ``residual_peak_ratio`` times
its floor -- the slope that
:func:`~ema_pipeline.identification.selection.residual_search.residual_peaks`
passes over -- the band is widened on that side by ``edge_margin`` of its
width, as far as the lines go (:func:`widened_band`); the peaks of the kept
poles' residual over the widened band that lie in the edge zone or past it
(measured as the residual check measures them) get start poles, refined
there beside the kept poles (:func:`edge_poles`), and while the residual
still rises into a widened end, that end is widened once more
(``edge_steps``). The backend
(:func:`~ema_pipeline.identification.plscf_backend.with_edge_poles`) refines
the kept modes whose local band holds an edge pole (:func:`edge_neighbours`)
and fits every mode's shape on the widened band with the edge poles among
the poles; it reports only the band's modes, lists the edge poles
(``IdentificationResult.edge_hz``) and names one that lies inside the band
in a warning (:func:`edge_message`). Without a rising residual at an edge,
without lines past it, or when no kept mode's local band holds an edge
pole, no number changes.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ema_pipeline.identification.refinement.local_band import local_problem
from ema_pipeline.identification.refinement.lsfd import lsfd_residual
from ema_pipeline.identification.refinement.refine import refine_poles
from ema_pipeline.identification.selection.not_kept import half_width_hz, visible_peaks
from ema_pipeline.identification.selection.residual_search import (
    is_physical,
    near,
    peak_pole,
    residual_ratio,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fd_hz, pole_fn_hz, pole_half_width_hz

__all__ = ["descent_region", "edge_fit", "edge_message", "edge_neighbours", "edge_poles",
           "edge_zones", "widened_band"]


def edge_zones(band_hz: tuple[float, float], *,
               thresholds: SelectionThresholds) -> tuple[float, float]:
    """The inner ends (Hz) of the band's bottom and top edge zones: the
    fractions ``thresholds.band_edge`` of its width.

    Examples
    --------
    >>> edge_zones((0.0, 100.0), thresholds=SelectionThresholds())
    (0.5, 98.0)
    """
    lo, hi = band_hz
    e_lo, e_hi = thresholds.band_edge
    return lo + e_lo * (hi - lo), hi - e_hi * (hi - lo)


def widened_band(
    axis_hz: np.ndarray, freq_hz: np.ndarray, H: np.ndarray, pole: np.ndarray, quantity: str,
    *, thresholds: SelectionThresholds,
) -> tuple[float, float] | None:
    """The band widened at each edge where the residual of the global LSFD of
    ``pole`` over the band's lines ``freq_hz`` (``H`` (n_ch, n_freq)) rises
    into that edge's zone (its last lines, the fraction ``band_edge`` of them
    and at least 2, reach ``residual_peak_ratio`` times the floor of
    :func:`~ema_pipeline.identification.selection.residual_search.residual_ratio`)
    and the frequency axis ``axis_hz`` goes on past it: by ``edge_margin`` of
    the band's width, as far as the axis goes (the bottom not below its 6th
    line, the default band's start). None when no edge is widened.

    Examples
    --------
    A mode at 102 Hz, just past a band of 20-100 Hz, beside a kept one at
    60 Hz: the band's top is widened by 5 % of its width.

    >>> th = SelectionThresholds()
    >>> axis = np.arange(0.0, 200.0, 0.25)
    >>> lam = np.array([-2.0 + 2j * np.pi * 60.0, -4.0 + 2j * np.pi * 102.0])
    >>> jw = 2j * np.pi * axis[:, None]
    >>> H = ((1 / (jw - lam) + 1 / (jw - lam.conj())) @ np.array([[1.0, 0.5], [0.8, -1.0]])).T
    >>> s = (axis >= 20.0) & (axis <= 100.0)
    >>> widened_band(axis, axis[s], H[:, s], lam[:1], "receptance", thresholds=th)
    (20.0, 104.0)
    """
    th = thresholds
    n = freq_hz.size
    if n < 16 or pole.size == 0:
        return None
    try:
        raw = residual_ratio(lsfd_residual(freq_hz, H, pole, quantity))
    except (np.linalg.LinAlgError, ValueError):
        return None
    lo, hi = float(freq_hz[0]), float(freq_hz[-1])
    margin = th.edge_margin * (hi - lo)
    bottom = float(axis_hz[min(5, axis_hz.size - 1)])
    rises = (raw[: max(2, int(th.band_edge[0] * n))].max() >= th.residual_peak_ratio,
             raw[-max(2, int(th.band_edge[1] * n)):].max() >= th.residual_peak_ratio)
    new_lo = max(lo - margin, bottom) if rises[0] and bottom < lo else lo
    new_hi = min(hi + margin, float(axis_hz[-1])) if rises[1] and axis_hz[-1] > hi else hi
    if new_lo == lo and new_hi == hi:
        return None
    return new_lo, new_hi


def edge_fit(
    axis_hz: np.ndarray, H: np.ndarray, band_hz: tuple[float, float], pole: np.ndarray,
    quantity: str, *, window_tau_s: float | None = None, force_window_s: float | None = None,
    thresholds: SelectionThresholds,
) -> tuple[tuple[float, float], np.ndarray] | None:
    """The widened band and the edge poles of the band ``band_hz`` beside the
    kept ``pole``, on the FRFs ``H`` (n_ch, n_freq) of the whole axis
    ``axis_hz``: :func:`widened_band`, then :func:`edge_poles` on its lines;
    while the residual of the kept and edge poles' fit still rises into a
    widened end (a resonance past it, which would bend the fits as the first
    did), that end is widened again, at most ``edge_steps`` times in all. A
    widening whose fit leaves a resonance out (:func:`edge_poles` not
    complete) is undone: the last complete one stands. None when no edge is
    widened or none gives edge poles.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> axis = np.arange(0.0, 200.0, 0.25)
    >>> lam = np.array([-2.0 + 2j * np.pi * 60.0, -4.0 + 2j * np.pi * 102.0])
    >>> jw = 2j * np.pi * axis[:, None]
    >>> H = ((1 / (jw - lam) + 1 / (jw - lam.conj())) @ np.array([[1.0, 0.5], [0.8, -1.0]])).T
    >>> rng = np.random.default_rng(0)
    >>> H = H + 1e-5 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    >>> band, got = edge_fit(axis, H, (20.0, 100.0), lam[:1], "receptance", thresholds=th)
    >>> band, np.round(got.imag / (2 * np.pi), 3).tolist()
    ((20.0, 104.0), [102.0])
    """
    th = thresholds
    lines = (axis_hz >= band_hz[0]) & (axis_hz <= band_hz[1])
    wide = widened_band(axis_hz, axis_hz[lines], H[:, lines], pole, quantity, thresholds=th)
    found = None
    for step in range(th.edge_steps):
        if wide is None:
            break
        band = wide
        lines = (axis_hz >= band[0]) & (axis_hz <= band[1])
        edge, complete = edge_poles(axis_hz[lines], H[:, lines], band_hz, pole, quantity,
                                    window_tau_s=window_tau_s, force_window_s=force_window_s,
                                    thresholds=th)
        if not complete:
            break  # a resonance left out of the model: the last complete fit stands
        found = (band, edge) if edge.size else None
        if step + 1 == th.edge_steps:
            break
        wide = widened_band(axis_hz, axis_hz[lines], H[:, lines], np.concatenate([pole, edge]),
                            quantity, thresholds=th)
        if wide is not None:  # only the ends already widened go on
            wide = (wide[0] if band[0] < band_hz[0] else band[0],
                    wide[1] if band[1] > band_hz[1] else band[1])
            wide = None if wide == band else wide
    return found


def edge_poles(
    freq_hz: np.ndarray, H: np.ndarray, band_hz: tuple[float, float], pole: np.ndarray,
    quantity: str, *, window_tau_s: float | None = None, force_window_s: float | None = None,
    thresholds: SelectionThresholds,
) -> tuple[np.ndarray, bool]:
    """The poles (rad/s, ascending) of resonances in the edge zones of
    ``band_hz`` or past them, found on the widened band's lines ``freq_hz``
    (``H`` (n_ch, n_freq), :func:`widened_band`) beside the kept ``pole``:
    the residual peaks of the kept poles' fit
    that stand ``residual_peak_ratio`` above the floor outside the band's
    inner part (:func:`edge_zones`), the highest first, each with a start
    pole fitted to the residual around it
    (:func:`~ema_pipeline.identification.selection.residual_search.peak_pole`)
    and refined beside the kept poles, which are refined with it where their
    local band holds it (:func:`~ema_pipeline.identification.refinement.refine.refine_poles`,
    the new pole free to move, before the next residual is formed). A peak
    that does not fall to half its height before the lines' ends (a
    resonance past them) is passed over, and so is one after whose
    refinement not every edge pole ends decaying, below ``max_zeta``, on
    the lines outside the band's inner part, with a half-power bandwidth of
    at least ``min_bandwidth_lines`` lines and a line or more from each
    other (a pole that splits one resonance into two makes them narrower,
    or closer, than the lines resolve). The poles are then
    kept when not within a kept mode's half-power half-width (nor it within
    theirs); one inside the band (in an edge zone) only when it also shows
    as a peak of its own in at least ``min_frf_share`` (and ``min_frfs``) of
    the FRFs within half its half-power half-width (the test of a resonance
    not kept, :func:`~ema_pipeline.identification.selection.not_kept.visible_peaks`):
    it is named in a warning.

    Returns the poles and whether the fit is complete: False when a pole lay
    on a kept mode, or there were more than ``max_residual_peaks`` peaks
    (the fit then leaves a resonance of the widened band out of the model).

    Examples
    --------
    The mode at 102 Hz past the band 20-100 Hz of :func:`widened_band`:

    >>> th = SelectionThresholds()
    >>> f = np.arange(20.0, 104.25, 0.25)
    >>> lam = np.array([-2.0 + 2j * np.pi * 60.0, -4.0 + 2j * np.pi * 102.0])
    >>> jw = 2j * np.pi * f[:, None]
    >>> H = ((1 / (jw - lam) + 1 / (jw - lam.conj())) @ np.array([[1.0, 0.5], [0.8, -1.0]])).T
    >>> got, complete = edge_poles(f, H, (20.0, 100.0), lam[:1], "receptance", thresholds=th)
    >>> np.round(got.real, 3).tolist(), np.round(got.imag / (2 * np.pi), 3).tolist(), complete
    ([-4.0], [102.0], True)
    """
    th = thresholds
    inner_lo, inner_hi = edge_zones(band_hz, thresholds=th)
    outer = (freq_hz <= inner_lo) | (freq_hz >= inner_hi)
    df = freq_hz[1] - freq_hz[0]
    start = np.zeros(0, dtype=complex)
    skip = np.zeros(freq_hz.size, dtype=bool)  # slopes into the widened band's ends
    kept = np.array(pole, dtype=complex, copy=True)
    free = replace(th, refine_max_shift=np.inf)
    m = kept.size
    complete = True
    while start.size < th.max_residual_peaks:
        try:
            R = lsfd_residual(freq_hz, H, np.concatenate([kept, start]), quantity)
        except (np.linalg.LinAlgError, ValueError):
            complete = False
            break
        raw = residual_ratio(R)
        ratio = np.where(outer & ~skip & ~near(freq_hz, start, df), raw, 0.0)
        k = int(np.argmax(ratio))
        if ratio[k] < th.residual_peak_ratio:
            break
        lo, hi = descent_region(ratio, k)
        if lo == 0 or hi == freq_hz.size - 1 or any(
                skip[j] and raw[j] >= raw[k] for j in (k - 1, k + 1) if 0 <= j < raw.size):
            # not down to half its height at the widened band's end (a mode
            # past it), or rising into such a slope
            skip[lo : hi + 1] = True
            continue
        width = hi - lo + 1
        sl = slice(max(0, lo - width - 3), min(freq_hz.size, hi + width + 4))
        lam = peak_pole(freq_hz[sl], R[:, sl])
        if not (is_physical(lam, thresholds=th) and freq_hz[lo] <= pole_fd_hz(lam) <= freq_hz[hi]):
            lam = 2 * np.pi * freq_hz[k] * (-width * df / (2 * freq_hz[k]) + 1j)
        start = np.append(start, complex(min(lam.real, -2 * np.pi * df), lam.imag))
        # the new pole and the kept modes beside it refined together, so that
        # the next residual holds no misfit of a kept mode bent by it
        # (the new poles free to move: a start from a residual that a bent
        # kept mode shapes can lie far from the resonance; where they end up
        # is checked below)
        before = kept, start[:-1]
        both = np.concatenate([kept, start])
        both = refine_poles(freq_hz, H, both, quantity=quantity, thresholds=free,
                            modes=np.arange(m, both.size), window_tau_s=window_tau_s,
                            force_window_s=force_window_s).pole
        both = refine_poles(freq_hz, H, both, quantity=quantity, thresholds=th,
                            modes=edge_neighbours(freq_hz, both, m, thresholds=th),
                            window_tau_s=window_tau_s, force_window_s=force_window_s).pole
        kept, start = both[:m], both[m:]
        f_got = pole_fd_hz(start)
        if not (all(is_physical(p, thresholds=th) for p in start)
                and np.all((f_got > freq_hz[0]) & (f_got < freq_hz[-1]))
                and outer[np.argmin(np.abs(freq_hz[:, None] - f_got[None, :]), axis=0)].all()
                and np.all(2 * pole_half_width_hz(start) >= th.min_bandwidth_lines * df)
                and np.all(np.diff(np.sort(f_got)) >= df)):
            # not a resonance outside the band's inner part that the lines
            # resolve, or one that splits a resonance found before into two
            # the lines do not resolve: passed over
            skip[lo : hi + 1] = True
            kept, start = before
    else:
        complete = False  # more peaks than max_residual_peaks
    # kept when outside the band's inner part and not within a kept mode's
    # half-power band (nor it within its); one inside the band (in an edge
    # zone, named in a warning) only when it is a resonance of the data, not
    # a kept mode's misfit: a peak of its own in enough FRFs (as a resonance
    # not kept must show, not_kept.visible_peaks), within half its half-power
    # half-width (a neighbour's slope shifts it)
    f_got = pole_fd_hz(start)
    ok = outer[np.clip(np.searchsorted(freq_hz, f_got), 0, freq_hz.size - 1)]
    if m:
        gap = np.abs(start[:, None].imag - kept[None, :].imag)
        ok &= ~np.any(gap < np.maximum(np.abs(start.real)[:, None], np.abs(kept.real)[None, :]),
                      axis=1)
    within = 0.5 * pole_half_width_hz(start) + th.peak_lines * df
    n_frfs = np.array([visible_peaks(freq_hz, H, pole_fn_hz(p)[None], w, pole_fd_hz(kept),
                                     half_width_hz(freq_hz, kept, thresholds=th),
                                     thresholds=th)[0]
                       for p, w in zip(start, within, strict=True)], dtype=int)
    inside = (f_got >= band_hz[0]) & (f_got <= band_hz[1])
    shown = n_frfs >= max(th.min_frfs, int(np.ceil(th.min_frf_share * H.shape[0])))
    complete = complete and bool(ok.all())
    start = start[ok & (shown | ~inside)]
    return np.asarray(start[np.argsort(start.imag)]), complete


def descent_region(ratio: np.ndarray, k: int) -> tuple[int, int]:
    """First and last line (inclusive) of the run around ``k`` where
    ``ratio`` stays above half of ``ratio[k]`` and falls away from ``k``
    (it ends at a valley: a peak beside another is its own).

    Examples
    --------
    >>> descent_region(np.array([0.0, 5.0, 6.0, 8.0, 5.0, 4.5, 7.0]), 3)
    (1, 5)
    """
    lo, hi = k, k
    half = ratio[k] / 2
    while lo > 0 and half < ratio[lo - 1] <= ratio[lo]:
        lo -= 1
    while hi < ratio.size - 1 and half < ratio[hi + 1] <= ratio[hi]:
        hi += 1
    return lo, hi


def edge_neighbours(freq_hz: np.ndarray, pole: np.ndarray, n_kept: int, *,
                    thresholds: SelectionThresholds) -> np.ndarray:
    """Indices of the first ``n_kept`` poles of ``pole`` (the kept modes;
    the rest the edge poles of :func:`edge_poles`) whose local band on the
    lines ``freq_hz`` holds an edge pole among its members
    (:func:`~ema_pipeline.identification.refinement.local_band.local_problem`,
    the local band of the pole refinement).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.arange(20.0, 104.25, 0.25)
    >>> lam = np.array([-2.0 + 2j * np.pi * 30.0, -2.0 + 2j * np.pi * 97.0,
    ...                 -4.0 + 2j * np.pi * 102.0])
    >>> edge_neighbours(f, lam, 2, thresholds=th).tolist()
    [1]
    """
    th = thresholds
    H = np.zeros((1, freq_hz.size), dtype=complex)
    out = []
    for r in range(n_kept):
        local = local_problem(freq_hz, H, pole, r, th.local_half_width, th.local_min_lines,
                              thresholds=th)
        if local is not None and np.any(local[2] >= n_kept):
            out.append(r)
    return np.asarray(out, dtype=int)


def edge_message(edge_hz: np.ndarray, band_hz: tuple[float, float], *,
                 thresholds: SelectionThresholds) -> str:
    """The warning for the edge poles (``edge_hz``, natural frequencies)
    inside the band, in its edge zones: not reported; widen the band.
    ``""`` when there is none.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> print(edge_message(np.array([99.0, 103.0]), (20.0, 100.0), thresholds=th))
    a resonance at 99 Hz lies at the top edge of the band [20, 100] Hz (within 2 % ...
    """
    lo, hi = band_hz
    inner_lo, inner_hi = edge_zones(band_hz, thresholds=thresholds)
    lines = []
    for side, sel, frac in (("bottom", (edge_hz >= lo) & (edge_hz <= inner_lo),
                             thresholds.band_edge[0]),
                            ("top", (edge_hz >= inner_hi) & (edge_hz <= hi),
                             thresholds.band_edge[1])):
        if sel.any():
            where = ", ".join(f"{f:.5g}" for f in edge_hz[sel])
            many = int(sel.sum()) > 1
            lines.append(
                f"{'resonances' if many else 'a resonance'} at {where} Hz "
                f"{'lie' if many else 'lies'} at the {side} edge of the band "
                f"[{lo:.5g}, {hi:.5g}] Hz (within {100 * frac:.3g} % of its width, where a "
                f"pole is taken to model the truncation): fitted but not reported as "
                f"{'modes' if many else 'a mode'}; widen the band past "
                f"{'them' if many else 'it'} to identify {'them' if many else 'it'}")
    return "; ".join(lines)
