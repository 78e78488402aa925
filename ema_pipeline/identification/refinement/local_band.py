"""The local problem of one mode, shared by pole refinement and the local screens.

:func:`local_problem` cuts mode r's local band (a number of half-power
bandwidths around it), its member poles (the modes whose half-power band reaches
into it) and a complex quadratic background per channel, and subtracts the terms
of the other modes from one global LSFD (:func:`global_residues`).
:func:`pole_columns` and :func:`background_columns` are the real-stacked design
of that local model, :func:`pole_jacobian` its derivative with respect to the
poles, and :func:`scaled_solve` the one least-squares projection that serves
every channel. The variable-projection fit of
:mod:`ema_pipeline.identification.refinement.refine` and the screens of
:mod:`ema_pipeline.identification.refinement.local_fits` are built on these.

Why written here: what makes the local fits cheap enough to run on every mode
is eliminating the linear terms (variable projection) and sharing one
projection between channels, neither of which scipy's ``least_squares`` does.
This module holds the pieces both need for that: the design of the linear
terms apart from the poles, the poles' Jacobian and one projection for all
channels.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.identification.refinement.lsfd import (
    column_scale,
    design_matrix,
    lsfd,
    qr_factor,
    real_stack,
    solve_r,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fd_hz, pole_half_width_hz


def pole_columns(freq_hz: np.ndarray, lam: np.ndarray, bg_r: np.ndarray) -> np.ndarray:
    """Real-stacked design (2n, 2m + K_bg) of sum_r a_r/(jw - l_r) + conj + background:
    the modal columns of :func:`~ema_pipeline.identification.refinement.lsfd.design_matrix`
    (no residual terms) and ``bg_r``, the real-stacked background columns."""
    modal = design_matrix(freq_hz, lam, "receptance", lower=False, upper=False)
    n, m2 = modal.shape
    # real_stack(modal) and bg_r in one column-major array (LAPACK's QR in
    # scaled_solve takes it without a copy)
    A = np.empty((2 * n, m2 + bg_r.shape[1]), order="F")
    A[:n, :m2], A[n:, :m2], A[:, m2:] = modal.real, modal.imag, bg_r
    return A


def pole_jacobian(jw: np.ndarray, lam: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Real-stacked derivative (2n, 2m, n_ch) of the model of :func:`pole_columns`
    with coefficients ``X`` (K, n_ch) with respect to (sigma_r, omega_dr)."""
    m = lam.size
    n = jw.shape[0]
    a = X[0 : 2 * m : 2] + 1j * X[1 : 2 * m : 2]  # (m, n_ch)
    t1 = (1.0 / (jw - lam[None, :]) ** 2)[:, :, None] * a[None, :, :]
    t2 = (1.0 / (jw - np.conj(lam)[None, :]) ** 2)[:, :, None] * np.conj(a)[None, :, :]
    # written straight into the real-stacked result (no complex J and no
    # concatenation: a third less time, the same numbers): d/d sigma is
    # -(t1 + t2), d/d omega_d is 1j (t1 - t2) = -Im(t1 - t2) + 1j Re(t1 - t2)
    out = np.empty((2 * n, 2 * m, a.shape[1]))
    s = t1 + t2
    np.negative(s.real, out=out[:n, 0::2])
    np.negative(s.imag, out=out[n:, 0::2])
    d = t1 - t2
    np.negative(d.imag, out=out[:n, 1::2])
    out[n:, 1::2] = d.real
    return out


def pole_jacobian_factors(
    jw: np.ndarray, lam: np.ndarray, X: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pole_jacobian` as a product: ``B`` (2n, 2m) and ``W`` (n_ch, 2m, 2m)
    with ``pole_jacobian(jw, lam, X)[:, :, c] == B @ W[c]``.

    The derivative of channel c's model with respect to (sigma_r, omega_dr)
    is the residue a_rc = ar + j ai times fixed functions of the lines,
    P_r = g1 + g2 and Q_r = j (g1 - g2) (g1, g2 = 1/(jw - l_r)^2,
    1/(jw - conj l_r)^2): d/d sigma = -(ar P + ai Q), d/d omega_d =
    ar Q - ai P. ``B`` holds the real-stacked P_r, Q_r (the same for every
    channel), ``W[c]`` the 2 x 2 blocks [[-ar, -ai], [-ai, ar]]. What this
    saves: the projection off the linear terms and the Fisher matrix are
    formed on the 2m columns of ``B`` once instead of on 2m columns per
    channel (30 channels on the measured beam: the refinement's normal
    equations about 5x cheaper); the same numbers up to rounding.

    Examples
    --------
    >>> jw = 2j * np.pi * np.linspace(90.0, 110.0, 5)[:, None]
    >>> lam = np.array([-3.0 + 2j * np.pi * 100.0])
    >>> X = np.array([[1.0, -2.0], [0.5, 0.25], [0.0, 0.0]])  # 2 channels, 1 background column
    >>> B, W = pole_jacobian_factors(jw, lam, X)
    >>> bool(np.allclose(np.einsum("ki,cij->kjc", B, W), pole_jacobian(jw, lam, X)))
    True
    """
    m = lam.size
    n = jw.shape[0]
    g1 = 1.0 / (jw - lam[None, :]) ** 2
    g2 = 1.0 / (jw - np.conj(lam)[None, :]) ** 2
    p, q = g1 + g2, 1j * (g1 - g2)
    B = np.empty((2 * n, 2 * m))
    B[:n, 0::2], B[n:, 0::2] = p.real, p.imag
    B[:n, 1::2], B[n:, 1::2] = q.real, q.imag
    ar, ai = X[0 : 2 * m : 2].T, X[1 : 2 * m : 2].T  # (n_ch, m)
    W = np.zeros((X.shape[1], 2 * m, 2 * m))
    # the 2 x 2 diagonal blocks through strided views of the flattened W
    # (entry (2r + i, 2r + j) sits at r (4m + 2) + 2m i + j): no index arrays
    Wf = W.reshape(X.shape[1], 4 * m * m)
    step = 4 * m + 2
    Wf[:, 0::step] = -ar
    Wf[:, 1::step] = -ai
    Wf[:, 2 * m :: step] = -ai
    Wf[:, 2 * m + 1 :: step] = ar
    return B, W


def block_fisher(G: np.ndarray, X: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """sum_c weights_c W_c^T G W_c (2m, 2m) for the ``W`` of
    :func:`pole_jacobian_factors` (from the coefficients ``X``), G (2m, 2m),
    using that each W_c is block diagonal: its 2 x 2 blocks w_rc enter as
    F_rs = sum_c weights_c w_rc^T G_rs w_sc, O(m^2 n_ch) instead of the
    O(m^3 n_ch) of the dense products (a candidate with 20 member poles:
    ~10x cheaper; the same numbers up to rounding).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> X, G = rng.standard_normal((7, 4)), rng.standard_normal((6, 6))
    >>> _, W = pole_jacobian_factors(np.ones((2, 1)) * 1j, np.array([-1 + 2j, -1 + 3j, -2 + 5j]), X)
    >>> wt = np.array([1.0, 2.0, 0.5, 3.0])
    >>> dense = np.einsum("c,cki,kl,clj->ij", wt, W, G, W)
    >>> bool(np.allclose(block_fisher(G, X, wt), dense, rtol=1e-13, atol=0))
    True
    """
    m = G.shape[0] // 2
    ar, ai = X[0 : 2 * m : 2].T, X[1 : 2 * m : 2].T  # (n_ch, m)
    # w[c, r, k, i]: the block of W_c at (2r + k, 2r + i): [[-ar, -ai], [-ai, ar]]
    w = np.stack([-ar, -ai, -ai, ar], axis=2).reshape(ar.shape[0], 4 * m)
    T = ((w * weights[:, None]).T @ w).reshape(m, 2, 2, m, 2, 2)  # [r, k, i, s, l, j]
    F = np.einsum("rksl,rkislj->risj", G.reshape(m, 2, m, 2), T)
    return np.asarray(F.reshape(2 * m, 2 * m))


def background_columns(background: np.ndarray) -> np.ndarray:
    """Real-stacked columns (2n, 2 K) of a complex background with real
    coefficients: each basis column and 1j times it."""
    bg = np.empty((background.shape[0], 2 * background.shape[1]), dtype=complex)
    bg[:, 0::2] = background
    bg[:, 1::2] = 1j * background
    return real_stack(bg)


def scaled_solve(A: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares of Y (2n, n_ch) on the real design A (2n, K) with its
    columns scaled to unit maximum: the orthonormal basis Q of A, the
    residual (2n, n_ch) and the solution X (K, n_ch). One projection serves
    every channel (the local problems of :func:`local_problem`)."""
    scale = column_scale(A)
    Q, R, triangular = qr_factor(A / scale)
    QtY = Q.T @ Y
    return Q, Y - Q @ QtY, solve_r(R, QtY, triangular) / scale[:, None]


class WeightedPoleDesign:
    """``scaled_solve(pole_columns(freq_hz, lam, bg_r) * u[:, None], Yw)`` for
    many ``lam`` with the same lines, background and row weights ``u`` (2n,):
    the steps of one Levenberg-Marquardt round. The background columns do not
    depend on the poles: they are weighted and scaled once (the column scale
    of :func:`scaled_solve` is per column, so the same numbers), and each
    step forms only the 2m modal columns, written straight into the
    column-major array that LAPACK's QR takes.

    Examples
    --------
    >>> f = np.linspace(90.0, 110.0, 21)
    >>> lam = np.array([-3.0 + 2j * np.pi * 100.0])
    >>> bg_r = background_columns(np.ones((21, 1), dtype=complex))
    >>> u = np.linspace(1.0, 2.0, 42)
    >>> Y = np.random.default_rng(1).standard_normal((42, 3))
    >>> ref = scaled_solve(pole_columns(f, lam, bg_r) * u[:, None], Y)
    >>> new = WeightedPoleDesign(f, bg_r, u).solve(lam, Y)
    >>> all(np.array_equal(a, b) for a, b in zip(ref, new))
    True
    """

    def __init__(self, freq_hz: np.ndarray, bg_r: np.ndarray, u: np.ndarray) -> None:
        # jw exactly as design_matrix forms it
        self.jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)[:, None]
        self.u = u[:, None]
        bg_w = bg_r * self.u
        self.bg_scale = column_scale(bg_w)
        self.bg_scaled = bg_w / self.bg_scale

    def solve(
        self, lam: np.ndarray, Yw: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`scaled_solve` of the weighted design at ``lam`` for the
        weighted data ``Yw`` (2n, n_ch): Q, the weighted residual and X."""
        jw = self.jw
        n = jw.shape[0]
        m2 = 2 * lam.size
        # the modal columns of design_matrix, in its arithmetic
        g = 1.0 / (jw - lam[None, :])
        gc = 1.0 / (jw - np.conj(lam)[None, :])
        p, q = g + gc, 1j * (g - gc)
        A = np.empty((2 * n, m2 + self.bg_scaled.shape[1]), order="F")
        M = A[:, :m2]
        M[:n, 0::2], M[n:, 0::2] = p.real, p.imag
        M[:n, 1::2], M[n:, 1::2] = q.real, q.imag
        M *= self.u
        scale = column_scale(M)
        M /= scale
        A[:, m2:] = self.bg_scaled
        Q, R, triangular = qr_factor(A)
        QtY = Q.T @ Yw
        X = solve_r(R, QtY, triangular)
        X[:m2] /= scale[:, None]
        X[m2:] /= self.bg_scale[:, None]
        return Q, Yw - Q @ QtY, X


def global_residues(
    freq_hz: np.ndarray, H: np.ndarray, poles: np.ndarray, quantity: str | None
) -> np.ndarray | None:
    """Residues (n_modes, n_ch) of one global LSFD of ``poles``, whose terms
    are subtracted from the local problems; None without ``quantity``, for a
    single pole or when the fit fails."""
    if quantity is None or poles.size < 2:
        return None
    try:
        return lsfd(freq_hz, H, poles, quantity).a
    except (np.linalg.LinAlgError, ValueError):
        return None


def local_bands(
    freq_hz: np.ndarray,
    poles: np.ndarray,
    half_width: float,
    min_lines: int,
    *,
    thresholds: SelectionThresholds,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every mode's local band as :func:`local_problem` cuts it: the damped
    frequencies, the half-power bandwidths and the band's half widths (Hz),
    each (m,); mode r's band is f_r -+ its half width.

    Examples
    --------
    >>> f = np.linspace(0.0, 200.0, 2001)
    >>> th = SelectionThresholds()
    >>> f_r, hpb, width = local_bands(f, np.array([-2.0 + 2j * np.pi * 100.0]), 12.0, 40,
    ...                               thresholds=th)
    >>> ((f_r - width).round(3).tolist(), (f_r + width).round(3).tolist())
    ([92.36], [107.64])
    """
    df = freq_hz[1] - freq_hz[0]
    f_r = pole_fd_hz(poles)
    hpb = 2 * pole_half_width_hz(poles)  # half-power bandwidth in Hz
    width = np.maximum(half_width * hpb, 0.5 * min_lines * df)
    cap = thresholds.local_max_fraction * f_r
    width = np.where(cap > 0.5 * thresholds.local_cap_min_lines * df, np.minimum(width, cap),
                     width)
    return f_r, hpb, width


def reaches_band(f_r: np.ndarray, hpb: np.ndarray, lo: np.ndarray | float,
                 hi: np.ndarray | float) -> np.ndarray:
    """Which modes (damped frequencies ``f_r``, half-power bandwidths ``hpb``,
    Hz) reach into the band ``lo``-``hi`` with their half-power band: the
    members of a local problem (broadcast: bands as a column give one row
    per band).

    Examples
    --------
    >>> reaches_band(np.array([10.0, 20.0]), np.array([1.0, 1.0]), 10.5, 18.5).tolist()
    [True, False]
    """
    return np.asarray((f_r + hpb > lo) & (f_r - hpb < hi))


def local_sizes(
    freq_hz: np.ndarray,
    poles: np.ndarray,
    half_width: float,
    min_lines: int,
    *,
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """An estimate of each mode's local fit cost (m,): the lines of its
    local band (:func:`local_bands`) times the columns of its design, two per
    member pole and the background's three. It follows the fits' times
    closely (correlation 0.95-0.98 on the measured beam and the pyFRF
    recording), which is what sharing the fits out among workers needs
    (:func:`ema_pipeline.runner.map_each`'s ``cost``).

    Examples
    --------
    >>> f = np.linspace(0.0, 200.0, 2001)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0, -2.0 + 2j * np.pi * 101.0,
    ...                 -2.0 + 2j * np.pi * 180.0])
    >>> local_sizes(f, lam, 12.0, 40, thresholds=SelectionThresholds()).tolist()
    [1071.0, 1071.0, 765.0]
    """
    f_r, hpb, width = local_bands(freq_hz, poles, half_width, min_lines,
                                  thresholds=thresholds)
    lo, hi = f_r - width, f_r + width
    lines = np.searchsorted(freq_hz, hi, "right") - np.searchsorted(freq_hz, lo, "left")
    member = reaches_band(f_r, hpb, lo[:, None], hi[:, None])  # (m, m): row r's members
    np.fill_diagonal(member, True)
    return np.asarray(lines * (2.0 * member.sum(axis=1) + 3.0), dtype=float)


def local_problem(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    r: int,
    half_width: float,
    min_lines: int,
    a_all: np.ndarray | None = None,
    *,
    thresholds: SelectionThresholds,
) -> tuple | None:
    """Lines, data, member poles and background of mode r's local band
    (less the terms of the other modes with residues ``a_all`` (m, n_ch)).

    Returns (f, Y, members, background, k, (lo, hi)): the lines (Hz), the
    real-stacked data (2n, n_ch), the indices of the member poles, the complex
    quadratic background (n, 3), the position of r among the members and the
    band; None when the band holds fewer than
    ``thresholds.local_band_min_lines`` lines. The band is +-``half_width``
    half-power bandwidths, at least ``min_lines`` lines (the default band:
    ``thresholds.local_half_width`` and ``local_min_lines``, passed in by the
    callers), at most ``thresholds.local_max_fraction`` of the mode's
    frequency on each side where that leaves more than
    ``thresholds.local_cap_min_lines`` lines."""
    f_r, hpb, widths = local_bands(freq_hz, poles, half_width, min_lines,
                                   thresholds=thresholds)
    width = widths[r]
    lo, hi = f_r[r] - width, f_r[r] + width
    sel = (freq_hz >= lo) & (freq_hz <= hi)
    if sel.sum() < thresholds.local_band_min_lines:
        return None
    f = freq_hz[sel]
    # the member mask, r included: its indices are the sorted union, the rest
    # the others (np.union1d and np.setdiff1d without their sorting)
    member = reaches_band(f_r, hpb, lo, hi)
    member[r] = True
    members = np.flatnonzero(member)
    x = (f - f_r[r]) / width
    background = np.empty((x.size, 3), dtype=complex)  # 1, x, x^2
    background[:, 0], background[:, 1], background[:, 2] = 1.0, x, x**2
    Hl = H[:, sel].T
    if a_all is not None:
        other = np.flatnonzero(~member)
        if other.size:
            jw = 2j * np.pi * f[:, None]
            lam = poles[other][None, :]
            Hl = Hl - (1.0 / (jw - lam)) @ a_all[other] - (1.0 / (jw - lam.conj())) @ a_all[
                other].conj()
    Y = real_stack(Hl)
    k = int(np.flatnonzero(members == r)[0])
    return f, Y, members, background, k, (lo, hi)
