"""Modes that the diagrams missed, found as peaks of the fit's residual.

After the selection, one global LSFD of the kept poles (with the residual
terms of the quantity) is subtracted from the data. A mode that no diagram
resolved leaves its own resonance in that residual: at low SNR the poles of
a clearly visible mode scatter too much between orders to form a trajectory
at the orders the search reaches; a heavily damped mode's trajectory breaks
up; a weak mode beside strong ones loses its poles to them. The noise leaves
a floor, and a missed mode stands well above it (measured on the hard
cases: docs/validation.md).

:func:`residual_peaks` finds those peaks: the squared residual of each
channel over its median (the floor; a median ignores the peaks), averaged
over the channels and over 3 lines, above ``residual_peak_ratio``,
outside the half-power bands of the kept modes (a kept mode's misfit, and
the part of the noise proportional to |H|, peak there; close modes hidden in
a kept resonance are the business of ``partners.close_partners``), and
at least ``residual_peak_contrast`` times its surroundings (fields of
:class:`~ema_pipeline.identification.thresholds.SelectionThresholds`). A residual
that rises into the band's edge is the tail of a mode outside the band or a
heavily damped mode whose resonance the edge cuts; it gives a start pole
only when a pole fitted up to the band's end lies inside the band, and that
start is marked (``from_edge``) for a stricter resonance test.
:func:`peak_pole` gives each a start pole, one pole common to all channels
fitted to the residual around the peak (linearised like Levy's method: no
iteration); the candidate then goes through the same refinement and the same
tests as every other, so a peak of model error on measured data is judged
like any pole of the diagrams.

Why written here: sdypy-EMA and scipy have no residual check of a modal fit.
:func:`mean_of_three_lines` stands for ``scipy.ndimage.uniform_filter1d``, whose
import would cost every command's start-up more than the whole filter.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.identification.refinement.lsfd import GrowingResidual
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fd_hz, pole_half_width_hz


def residual_ratio(R: np.ndarray) -> np.ndarray:
    """(n_freq,) squared residual over its floor: each channel's |R|^2 of the
    residual ``R`` (n_ch, n_freq) divided by its median over the lines,
    averaged over the channels and over 3 neighbouring lines.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ratio = residual_ratio(rng.standard_normal((2, 801)) + 1j * rng.standard_normal((2, 801)))
    >>> bool(1.2 < np.mean(ratio) < 1.7), bool(np.max(ratio) < 8.0)
    (True, True)
    """
    p = np.abs(R) ** 2
    floor = np.maximum(np.median(p, axis=1, keepdims=True), np.finfo(float).tiny)
    return mean_of_three_lines(np.mean(p / floor, axis=0))


def mean_of_three_lines(x: np.ndarray) -> np.ndarray:
    """The mean of each line and its two neighbours, the end lines repeated
    beyond the ends, computed as ``scipy.ndimage.uniform_filter1d(x, 3,
    mode="nearest")`` computes it: a running sum (the first three lines, then
    each next sum by adding entering - leaving, in order) over 3. The same
    arithmetic gives the same numbers (tests/test_residual_search.py).
    Written here because importing scipy.ndimage costs every ``identify``
    30-170 ms of start-up, more than the filter itself.

    Examples
    --------
    >>> mean_of_three_lines(np.array([3.0, 0.0, 0.0, 6.0]))
    array([2., 1., 2., 4.])
    """
    x = np.asarray(x, dtype=float)
    padded = np.concatenate((x[:1], x, x[-1:]))
    first = padded[0] + padded[1] + padded[2]
    return np.add.accumulate(np.concatenate(([first], padded[3:] - padded[:-3]))) / 3.0


def residual_peaks(
    freq_hz: np.ndarray,
    H: np.ndarray,
    pole: np.ndarray,
    quantity: str,
    *,
    thresholds: SelectionThresholds,
) -> tuple[np.ndarray, np.ndarray]:
    """Start poles (rad/s, ascending frequency) at the peaks of the residual of
    the global LSFD of the kept ``pole`` that stand
    ``thresholds.residual_peak_ratio`` above its
    floor (:func:`residual_ratio`), outside 3 half-power half-widths plus 2
    lines of every pole (:func:`near`) and outside the band's edge zones,
    the fractions ``thresholds.band_edge`` of its lines at the bottom and the
    top (0.5 and 2 %, as :func:`~ema_pipeline.identification.selection.acceptance.inside_band`
    asks of a pole; why the bottom zone is the narrower: docs/validation.md).

    A peak that does not fall to half its height before the band's edge
    zone is the tail of a mode outside the band or a heavily damped mode
    whose half-power band reaches past the edge: a pole is fitted to the
    lines from the peak to the band's end (:func:`peak_pole`), and it is a
    start pole (marked in ``from_edge``; the caller asks more of it) when it
    lies inside the band, outside the edge zone, else the slope is passed
    over with the lines down to half its height. A peak that goes on rising
    into a kept mode's zone (its misfit) is passed over too. Greedy, at most
    ``thresholds.max_residual_peaks`` times: the highest peak gets a start pole (:func:`peak_pole`
    on the lines around it, the peak's half-height width and as much again
    on each side, or, when that pole lies outside the half-height width, the
    peak's frequency with that width as half-power band; the half-power band
    at least 2 lines, narrower is not resolved), which joins the LSFD before
    the next peak is sought (a strong missed mode's tails stand above the
    floor far from it; the LSFD's QR is extended by it,
    :class:`~ema_pipeline.identification.refinement.lsfd.GrowingResidual`).
    ``H`` (n_ch, n_freq) on the lines ``freq_hz``.
    Returns the start poles and ``from_edge`` (bool, each).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 801)
    >>> lam = np.array([-2.0 + 2j * np.pi * 80.0, -1.5 + 2j * np.pi * 120.0])
    >>> jw = 2j * np.pi * f
    >>> terms = [1 / (jw - p) + 1 / (jw - p.conj()) for p in lam]
    >>> rng = np.random.default_rng(0)
    >>> H = np.stack([terms[0] + s * terms[1] for s in (1.0, -0.7, 0.4)])
    >>> H = H + 1e-4 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    >>> start, from_edge = residual_peaks(f, H, lam[:1], "receptance", thresholds=th)
    >>> (start.imag / (2 * np.pi)).round(1).tolist(), from_edge.tolist()
    ([120.0], [False])
    """
    th = thresholds
    min_ratio, max_peaks = th.residual_peak_ratio, th.max_residual_peaks
    freq_hz = np.asarray(freq_hz, dtype=float)
    n = freq_hz.size
    start = np.zeros(0, complex)
    from_edge = np.zeros(0, bool)
    if n < 16:
        return start, from_edge
    df = freq_hz[1] - freq_hz[0]
    edge = np.zeros(n, bool)  # the band's edges, as inside_band has them
    edge[: max(2, int(th.band_edge[0] * n))] = True
    edge[-max(2, int(th.band_edge[1] * n)):] = True
    skip = np.zeros(n, bool)  # slopes into an excluded zone: not peaks
    R = None
    # the LSFD grows by each start pole: its QR extended, not solved again
    grown = GrowingResidual(freq_hz, H, pole, quantity)
    while start.size < max_peaks:
        lam_all = np.concatenate([pole, start])
        if R is None:
            try:
                R = grown.residual()
            except (np.linalg.LinAlgError, ValueError):
                break
            raw = residual_ratio(R)
            excluded = edge | near(freq_hz, lam_all, df)
        ratio = np.where(excluded | skip, 0.0, raw)
        k = int(np.argmax(ratio))
        if ratio[k] < min_ratio:
            break
        lo, hi = peak_region(ratio, k)
        ends = [j for j in (lo - 1, hi + 1) if 0 <= j < n]
        width = hi - lo + 1
        at_edge = [j for j in ends if edge[j] and raw[j] > ratio[k] / 2]
        if at_edge:
            # not down to half its height before the band's edge zone: the
            # tail of a mode outside the band, or a heavily damped mode whose
            # half-power band reaches past the edge. A pole fitted to the
            # lines from the peak to the band's end tells them apart.
            skip[lo : hi + 1] = True  # a bump beside it continues the slope
            sl = slice(max(0, lo - width - 3), n) if at_edge[0] > k else slice(
                0, min(n, hi + width + 4))
            lam = peak_pole(freq_hz[sl], R[:, sl])
            f_lam = pole_fd_hz(lam)
            j = int(np.argmin(np.abs(freq_hz - f_lam)))
            inner = freq_hz[0] < f_lam < freq_hz[-1] and not edge[j]
            if not (is_physical(lam, thresholds=th) and inner):
                continue
        else:
            if any(skip[j] and raw[j] > ratio[k] / 2 for j in ends) or any(
                    excluded[j] and raw[j] >= ratio[k] for j in ends):
                # the continuation of a slope passed over, or still rising
                # into a kept mode's zone (its misfit): a slope
                skip[lo : hi + 1] = True
                continue
            # the surroundings: 1 to residual_contrast_widths widths (plus
            # residual_contrast_lines lines) away
            reach = th.residual_contrast_widths * width + th.residual_contrast_lines
            around = np.zeros(n, bool)
            around[max(0, lo - reach) : min(n, hi + reach + 1)] = True
            around[max(0, lo - width) : min(n, hi + width + 1)] = False
            around &= ~(excluded | skip)
            if around.any() and ratio[k] < th.residual_peak_contrast * np.median(raw[around]):
                # no higher than its surroundings: a noisy stretch (the top of
                # a measured axis, where the anti-alias filter acts), not a mode
                skip[lo : hi + 1] = True
                continue
            sl = slice(max(0, lo - width - 3), min(n, hi + width + 4))
            lam = peak_pole(freq_hz[sl], R[:, sl])
            inside = freq_hz[lo] <= pole_fd_hz(lam) <= freq_hz[hi]
            if not (is_physical(lam, thresholds=th) and inside):
                lam = 2 * np.pi * freq_hz[k] * (-width * df / (2 * freq_hz[k]) + 1j)
        # a half-power band of at least 2 lines (narrower is not resolved)
        start = np.append(start, complex(min(lam.real, -2 * np.pi * df), lam.imag))
        from_edge = np.append(from_edge, bool(at_edge))
        grown.add(start[-1])
        R = None
    order = np.argsort(start.imag)
    return start[order], from_edge[order]


def is_physical(lam: complex, *, thresholds: SelectionThresholds) -> bool:
    """True for a decaying pole with a damping ratio below
    ``thresholds.max_zeta``.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> [is_physical(lam, thresholds=th) for lam in (-1.0 + 100j, 1.0 + 100j, -50.0 + 100j)]
    [True, False, False]
    """
    max_zeta = thresholds.max_zeta
    return bool(lam.real < 0 and -lam.real < max_zeta * abs(lam))


def peak_region(ratio: np.ndarray, k: int) -> tuple[int, int]:
    """First and last line (inclusive) of the run of lines around ``k`` where
    ``ratio`` stays above half of ``ratio[k]``.

    Examples
    --------
    >>> peak_region(np.array([0.0, 1.0, 3.0, 8.0, 5.0, 4.5, 1.0]), 3)
    (3, 5)
    """
    lo, hi = k, k
    while lo > 0 and ratio[lo - 1] > ratio[k] / 2:
        lo -= 1
    while hi < ratio.size - 1 and ratio[hi + 1] > ratio[k] / 2:
        hi += 1
    return lo, hi


def near(freq_hz: np.ndarray, pole: np.ndarray, df: float) -> np.ndarray:
    """(n_freq,) True within 3 half-power half-widths plus 2 lines of any ``pole``.

    Examples
    --------
    >>> lam = np.array([-1.0 + 2j * np.pi * 100.0])
    >>> near(np.arange(95.0, 106.0), lam, 1.0).astype(int).tolist()
    [0, 0, 0, 1, 1, 1, 1, 1, 0, 0, 0]
    """
    if pole.size == 0:
        return np.zeros(freq_hz.size, bool)
    reach = 3 * pole_half_width_hz(pole) + 2 * df
    gap = np.abs(freq_hz[:, None] - pole_fd_hz(pole)[None, :])
    return np.asarray(np.any(gap < reach[None, :], axis=1))


def peak_pole(freq_hz: np.ndarray, R: np.ndarray) -> complex:
    """One pole common to all channels of ``R`` (n_ch, n_lines) around a peak:
    R_c = a_c / (jw - lambda) + b_c locally, multiplied out,
    jw R_c = lambda R_c + u_c + b_c jw, is linear in lambda, u_c and b_c;
    with the last two projected out channel by channel, lambda is the
    least-squares ratio (Levy's linearisation, no iteration). A start value
    for the refinement.

    Examples
    --------
    >>> f = np.linspace(95.0, 105.0, 41)
    >>> lam = -3.0 + 2j * np.pi * 100.0
    >>> R = np.stack([2 / (2j * np.pi * f - lam), -1 / (2j * np.pi * f - lam) + 0.01])
    >>> got = peak_pole(f, R)
    >>> round(got.real, 3), round(got.imag / (2 * np.pi), 3)
    (-3.0, 100.0)
    """
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    x = (jw - jw.mean()) / (jw[-1] - jw[0] if jw.size > 1 else 1.0)
    Q, _ = np.linalg.qr(np.stack([np.ones_like(x), x], axis=1))
    a = R - (R @ Q.conj()) @ Q.T  # the terms u_c, b_c projected out
    b = R * jw - ((R * jw) @ Q.conj()) @ Q.T
    den = np.sum(np.abs(a) ** 2)
    return complex(np.sum(np.conj(a) * b) / den) if den > 0 else complex(np.nan)
