"""Two close poles where the shapes tell nothing: the tests of a pair with
fewer than ``min_shape_channels`` channels (impact tests with one or two
accelerometers).

With so few channels the residues of any extra pole fit every channel, so a
second pole beside a close partner is a mode only on evidence one channel
can give: two poles fit the pair's local problem better than one beyond what
the noise explains (:func:`pair_significance`, an F test, with
:func:`f_quantile`), and only where that test sees the noise alone on the
file (:func:`f_test_calibrated`), or the FRFs show two peaks
(:func:`peaks_apart`). Of the close pairs of the kept poles
(:func:`close_pairs`) that have neither, the weaker pole is dropped
(:func:`unsupported_partners`). The thresholds are fields of
:class:`~ema_pipeline.identification.thresholds.SelectionThresholds`, passed
in as ``thresholds``.
"""

from __future__ import annotations

from statistics import NormalDist

import numpy as np

from ema_pipeline.identification.refinement.local_band import (
    WeightedPoleDesign,
    background_columns,
    global_residues,
    local_problem,
)
from ema_pipeline.identification.refinement.local_fits import (
    quick_significance,
)
from ema_pipeline.identification.refinement.refine import (
    vp_fit,
)
from ema_pipeline.identification.refinement.uncertainty import exponential_window_correlation
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fd_hz, pole_half_width_hz


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
    residues: np.ndarray | None = None,
    thresholds: SelectionThresholds,
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

    The terms of the modes outside the local band are subtracted with
    ``residues`` (n_modes, n_ch), by default one global LSFD of ``pole``
    (:func:`~ema_pipeline.identification.refinement.local_band.global_residues`);
    a caller that judges many variants of one set of poles passes the
    residues of that set (the far modes' residues hardly depend on how one
    resonance is modelled) and saves an LSFD of the whole band per variant.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(80.0, 120.0, 401)
    >>> lam = np.array([-3.0 + 2j * np.pi * 99.0, -3.0 + 2j * np.pi * 101.0])
    >>> jw = 2j * np.pi * f
    >>> rng = np.random.default_rng(1)
    >>> noise = 1e-3 * (rng.standard_normal((1, f.size)) + 1j * rng.standard_normal((1, f.size)))
    >>> two = (1 / (jw - lam[0]) + 0.7 / (jw - lam[1]))[None] + noise
    >>> one = (1 / (jw - lam[0]))[None] + noise
    >>> bool(pair_significance(f, two, lam, 0, 1, None, thresholds=th) > 10)
    True
    >>> bool(pair_significance(f, one, lam, 0, 1, None, thresholds=th) < 1)
    True
    """
    th = thresholds
    a_all = global_residues(freq_hz, H, pole, quantity) if residues is None else residues
    for r, other in ((a, b), (b, a)):
        local = local_problem(freq_hz, H, pole, r, th.split_half_width, th.local_min_lines,
                              a_all, thresholds=th)
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


def f_test_calibrated(significance: np.ndarray,
                      *, thresholds: SelectionThresholds) -> bool:
    """Whether the F test of :func:`pair_significance` sees only the noise
    on a file: the median of the ``significance`` of every kept mode's split
    fit (a second pole beside each, NaN where none was fitted) is below
    ``thresholds.partner_max_split_median`` (most modes have no hidden
    partner, so most splits must not be significant; model error, e.g. the
    leakage of short records, makes them significant beside most modes).
    False when no split was judged.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> (f_test_calibrated(np.array([0.3, 0.5, 40.0]), thresholds=th),
    ...  f_test_calibrated(np.array([5.8, 0.4, 9.0]), thresholds=th))
    (True, False)
    """
    th = thresholds
    sig = np.asarray(significance, dtype=float)
    if not np.isfinite(sig).any():
        return False
    return bool(np.nanmedian(sig) < th.partner_max_split_median)


def peaks_apart(freq_hz: np.ndarray, H: np.ndarray, pa: complex, pb: complex,
                *, thresholds: SelectionThresholds) -> bool:
    """True when an FRF of ``H`` (n_ch, n_freq) shows the poles ``pa`` and
    ``pb`` as two peaks: a local maximum of |H| within each pole's
    half-power half-width (at least its nearest line) and between them a
    valley of at most ``thresholds.pair_min_dip`` times the lower of the two
    maxima (the peak's shape shows two modes).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(90.0, 110.0, 201)
    >>> jw = 2j * np.pi * f
    >>> lam = -1.0 + 2j * np.pi * np.array([99.0, 101.0, 99.3])
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[1]))[None]
    >>> (peaks_apart(f, H, lam[0], lam[1], thresholds=th),
    ...  peaks_apart(f, H, lam[0], lam[2], thresholds=th))
    (True, False)
    """
    th = thresholds
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
                *, thresholds: SelectionThresholds) -> list[tuple[int, int]]:
    """Neighbours (i, j), ascending frequency, of the poles ``pole`` that lie
    within ``thresholds.pair_max_gap`` times the sum of their half-power
    half-widths of each other (indices into ``pole``).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> lam = np.array([-1.0 + 2j * np.pi * 100.0, -1.0 + 2j * np.pi * 100.5,
    ...                 -1.0 + 2j * np.pi * 110.0])
    >>> close_pairs(lam, thresholds=th)
    [(0, 1)]
    """
    th = thresholds
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
    thresholds: SelectionThresholds,
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
    is dropped (the shape tests of :func:`.final_tests` and
    :func:`.close_partners` judge a pair).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(80.0, 120.0, 401)
    >>> lam = np.array([-3.0 + 2j * np.pi * 99.0, -3.0 + 2j * np.pi * 99.8])
    >>> jw = 2j * np.pi * f
    >>> rng = np.random.default_rng(2)
    >>> H = (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj()))[None]
    >>> H = H + 1e-3 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    >>> drop, merged = unsupported_partners(f, H, lam, "receptance", thresholds=th)
    >>> drop.tolist(), merged.tolist()
    ([False, True], [True, False])
    """
    th = thresholds
    drop, merged = np.zeros(pole.size, bool), np.zeros(pole.size, bool)
    if H.shape[0] >= th.min_shape_channels or pole.size < 2:
        return drop, merged
    snr = None
    for i, j in close_pairs(pole, thresholds=th):
        if drop[i] or drop[j] or peaks_apart(freq_hz, H, pole[i], pole[j], thresholds=th):
            continue
        sig = pair_significance(freq_hz, H, pole, i, j, quantity, thresholds=th)
        if not sig < 1.0:  # significant, or not judged (NaN)
            continue
        if snr is None:
            snr = quick_significance(freq_hz, H, pole, thresholds=th)[2]
        weak, strong = (i, j) if snr[i] < snr[j] else (j, i)
        drop[weak], merged[strong] = True, True
    return drop, merged & ~drop
