"""Poly-reference least-squares complex-frequency (pLSCF, "PolyMAX") pole estimation.

Model (right matrix fraction, z-domain, real matrix coefficients)::

    H_o(w) = B_o(z) A(z)^-1,   A(z) = sum_{j=0}^{n} alpha_j z^j,   B_o(z) = sum_j beta_oj z^j,
    z = exp(1j * w * dt),      dt = 1 / (2 * f_hi)

``H_o`` is the 1 x n_in row of output o, ``alpha_j`` real n_in x n_in, ``beta_oj``
real 1 x n_in. The sampling time is that of the **band top** ``f_hi`` (the
highest frequency line used), so [0, f_hi] maps onto the upper half of the unit
circle and the real coefficients supply the mirrored half. Poles are
``lambda = ln(z) / dt``.

Linearised least squares: with the weighted basis rows
``Gamma_o(k) = w_ok [z_k^0 .. z_k^p]`` and ``Upsilon_o(k) = -w_ok [z_k^0 .. z_k^p] kron H_o(k)``,

    R_o = Re(Gamma_o^H Gamma_o),  S_o = Re(Gamma_o^H Upsilon_o),  T_o = Re(Upsilon_o^H Upsilon_o)
    M   = 2 sum_o (T_o - S_o^T R_o^-1 S_o)

and the denominator minimises ``alpha^T M alpha`` with the top coefficient fixed
to the identity. Every entry of R, S and T depends only on the lag ``l - j``:

    R[j, l] = Re sum_k w^2 z_k^(l-j),   S[j, (l, b)] = -Re sum_k w^2 H_b z_k^(l-j),
    T[(j, a), (l, b)] = Re sum_k w^2 conj(H_a) H_b z_k^(l-j)

so the lag sums for all lags -p..p come from one inverse FFT per data channel
(when the lines are integer multiples of the line spacing, as from any FFT
analyser; otherwise from one matrix product).

M is built once, for the highest order p, with the numerator at order p. The
normal equations of a lower denominator order n are its leading
(n+1) n_in block (numerator order stays p). With the Cholesky factor M = L L^T
and U = L^-T, column block n of U solves the leading block system, so the
denominators of *all* orders come from one Cholesky factorisation and one
triangular inverse:

    [alpha_0; ...; alpha_n] = U[:(n+1) n_in, blk n] @ U[blk n, blk n]^-1   (alpha_n = I)

Poles are the eigenvalues of the block companion matrix of ``alpha^T``; the
participation vector ``l_r`` of pole ``z_r`` is the null vector of
``A(z_r)^T`` (l_r^T A(z_r) = 0), found by a small SVD per pole.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy import linalg

from ema_pipeline.data import DataError
from ema_pipeline.identification.diagram.roots import companion_eigenvalues, diagram_roots
from ema_pipeline.runner import Mapper, map_costliest_first


@dataclass(frozen=True)
class PoleSet:
    """Poles of the pLSCF models of every computed order (flattened).

    Attributes
    ----------
    order : (n_poles,) int
        Polynomial (denominator) order n of the model the pole belongs to.
    pole : (n_poles,) complex
        Continuous-time pole lambda = -sigma + 1j*omega_d in rad/s (as identified,
        i.e. of the possibly windowed FRFs), Im > 0 only.
    participation : (n_poles, n_in) complex
        Participation vector (unit norm; 1 for a single reference).
    orders : (n_orders,) int
        The orders computed.
    dt : float
        Sampling time of the z-domain model in s.
    """

    order: np.ndarray
    pole: np.ndarray
    participation: np.ndarray
    orders: np.ndarray
    dt: float


def lag_sums(freq_hz: np.ndarray, C: np.ndarray, dt: float, p: int) -> np.ndarray:
    """g[..., p + m] = sum_k C[..., k] exp(1j * 2 pi f_k dt m) for m = -p..p.

    Uses one inverse FFT per channel when f_k * 2 dt * L is an integer grid
    (FFT analyser lines), else one matrix product.
    """
    lags = np.arange(-p, p + 1)
    df = freq_hz[1] - freq_hz[0]
    bins = freq_hz / df
    n_hi = 1.0 / (2.0 * dt * df)  # f_hi / df
    on_grid = (
        np.allclose(bins, np.round(bins), rtol=0, atol=1e-6)
        and abs(n_hi - round(n_hi)) < 1e-6
    )
    if on_grid:
        L = 2 * int(round(n_hi))
        if L >= 2 * p + 1:
            full = np.zeros(C.shape[:-1] + (L,), dtype=complex)
            full[..., np.round(bins).astype(int) % L] = C
            g = np.fft.ifft(full, axis=-1) * L
            return g[..., lags % L]
    E = np.exp(1j * 2 * np.pi * dt * np.outer(freq_hz, lags))
    return C @ E


def gram_cholesky(R: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of the Gram matrix R of the numerator basis.

    R = Re(Gamma^H Gamma) of the basis z^0 .. z^p is positive definite in exact
    arithmetic, but numerically singular at high order when the band covers
    only a small arc of the unit circle (a band starting well above 0 Hz). A
    ridge of 1e-13, 1e-11, ... times the mean diagonal is then added: it only
    removes basis directions the data cannot distinguish.

    Examples
    --------
    >>> gram_cholesky(np.array([[4.0, 2.0], [2.0, 1.0]])).shape  # singular
    (2, 2)
    """
    scale = float(np.mean(np.diag(R))) or 1.0
    ridge = 0.0
    for _ in range(8):
        try:
            return np.linalg.cholesky(R + ridge * scale * np.eye(R.shape[0]))
        except np.linalg.LinAlgError:
            ridge = 1e-13 if ridge == 0 else ridge * 100
    raise DataError("pLSCF numerator basis is singular (band too narrow for the model order)")


def plscf_normal_matrix(
    freq_hz: np.ndarray,
    H: np.ndarray,
    max_order: int,
    dt: float,
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """Reduced normal matrix M of pLSCF for denominator and numerator order ``max_order``.

    Parameters
    ----------
    freq_hz : (n_freq,) frequency lines in Hz.
    H : (n_out, n_in, n_freq) complex FRFs.
    max_order : highest polynomial order p.
    dt : sampling time of the z-domain basis in s.
    weights : (n_freq,) or (n_out, n_freq) real, optional
        Weight w_ok of each line; ``None`` = 1. With weights per output the
        matrices R_o differ per output and are factorised one by one.

    Returns
    -------
    M : ((p+1) n_in, (p+1) n_in) real symmetric, M = 2 sum_o (T_o - S_o^T R_o^-1 S_o).
    """
    n_out, n_in, _ = H.shape
    p = int(max_order)
    q = p + 1
    idx = (np.arange(q)[None, :] - np.arange(q)[:, None]) + p  # lag l - j
    if weights is None:
        w2 = np.ones(freq_hz.size)
    else:
        w2 = np.asarray(weights, dtype=float) ** 2
    per_output = w2.ndim == 2
    w2o = w2 if per_output else w2[None, :]

    # S: lag sums of w^2 H_ob   -> (n_out, n_in, 2p+1); its real part is
    # taken before the Toeplitz gather (one pass over q^2 reals per channel
    # instead of three over q^2 complex numbers; the same numbers)
    s_neg = -lag_sums(freq_hz, w2o[:, None, :] * H, dt, p).real
    # T summed over outputs (the Toeplitz structure is linear): (n_in, n_in, 2p+1)
    HH = np.einsum("oak,obk->abk", np.conj(H) * w2o[:, None, :], H)
    t = lag_sums(freq_hz, HH, dt, p)
    T = t.real[:, :, idx]  # [a, b, j, l]
    T = T.transpose(2, 0, 3, 1).reshape(q * n_in, q * n_in)
    # R and the Schur complement
    r = lag_sums(freq_hz, w2o.astype(complex), dt, p)  # (n_out or 1, 2p+1)
    R = r.real[:, idx]  # (n_out or 1, q, q)
    if per_output:
        S = s_neg[:, :, idx].transpose(0, 2, 3, 1).reshape(n_out, q, q * n_in)  # [o, j, (l, b)]
        X = np.stack([linalg.solve_triangular(gram_cholesky(R[o]), S[o], lower=True)
                      for o in range(n_out)])
        Xs = X.reshape(n_out * q, q * n_in)
    else:
        Xs = whitened_numerators(gram_cholesky(R[0]), s_neg, idx)
    M = 2.0 * (T - Xs.T @ Xs)
    return 0.5 * (M + M.T)


def whitened_numerators(L: np.ndarray, s_neg: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The rows L^-1 S_o of every output o stacked, (n_out q, q n_in), for the
    Toeplitz S_o[j, (l, b)] = ``s_neg[o, b, idx[j, l]]`` and the lower
    Cholesky factor ``L`` (q, q) of the numerator basis' Gram matrix shared
    by all outputs: the X of ``M = 2 (T - X^T X)`` in
    :func:`plscf_normal_matrix`.

    One triangular solve with all outputs' columns, as
    ``scipy.linalg.solve_triangular(L, S, lower=True)`` makes it (LAPACK
    ``dtrtrs`` on L^T, transposed), with the right-hand sides gathered
    straight into the column-major layout LAPACK takes: no check for
    non-finite numbers (lag sums of finite FRFs), no transposed copies of
    them before and after the solve but one (30 outputs at order 255:
    the copies cost as much as the product X^T X; the same numbers).

    Examples
    --------
    >>> from scipy import linalg
    >>> rng = np.random.default_rng(0)
    >>> q, p = 3, 2
    >>> idx = (np.arange(q)[None, :] - np.arange(q)[:, None]) + p
    >>> s_neg = rng.standard_normal((2, 1, 2 * p + 1))
    >>> L = np.linalg.cholesky(np.eye(q) + 0.1)
    >>> S = np.concatenate([s_neg[o, 0][idx] for o in range(2)], axis=1)
    >>> X = linalg.solve_triangular(L, S, lower=True)
    >>> bool(np.array_equal(whitened_numerators(L, s_neg, idx),
    ...                     np.concatenate([X[:, :q], X[:, q:]])))
    True
    """
    n_out, n_in, _ = s_neg.shape
    q = L.shape[0]
    # B[j, (o, l, b)] = S_o[j, (l, b)], column-major: memory order [o, l, b, j]
    B = np.ascontiguousarray(s_neg[:, :, idx.T].transpose(0, 2, 1, 3)).reshape(-1, q).T
    X, info = linalg.lapack.dtrtrs(L.T, B, lower=0, trans=1, overwrite_b=1)
    if info != 0:  # pragma: no cover - gram_cholesky's factor has a positive diagonal
        raise DataError("pLSCF numerator basis is singular")
    # X[j, (o, c)] -> rows (o, j), columns c
    Xs = X.T.reshape(n_out, q * n_in, q).transpose(0, 2, 1)
    return np.ascontiguousarray(Xs).reshape(n_out * q, q * n_in)


def plscf_denominators(M: np.ndarray, n_in: int, orders: np.ndarray) -> list[np.ndarray]:
    """Denominator coefficients for every order from one Cholesky factorisation.

    Returns a list of arrays ``alpha`` of shape (n+1, n_in, n_in), alpha[n] = I,
    one per requested order n (1 <= n <= p).
    """
    d = np.sqrt(np.clip(np.diag(M), np.finfo(float).tiny, None))
    Ms = M / d[:, None] / d[None, :]
    jitter = 0.0
    for _ in range(8):
        try:
            L = np.linalg.cholesky(Ms + jitter * np.eye(Ms.shape[0]))
            break
        except np.linalg.LinAlgError:
            jitter = 1e-14 if jitter == 0 else jitter * 100
    else:  # pragma: no cover - M with NaN would fail earlier
        raise DataError("pLSCF normal equations are singular (constant or all-zero FRFs?)")
    U, info = linalg.lapack.dtrtri(L.T, lower=0)
    if info != 0:  # pragma: no cover
        raise DataError("pLSCF normal equations are singular")
    U = U / d[:, None]  # undo the diagonal scaling: U = L^-T of the unscaled M
    out = []
    for n in orders:
        blk = slice(n * n_in, (n + 1) * n_in)
        col = U[: (n + 1) * n_in, blk]
        alpha = col @ np.linalg.inv(col[blk])
        out.append(alpha.reshape(n + 1, n_in, n_in))
    return out


def companion_poles(alpha: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Discrete poles z and continuous poles ln(z)/dt of a monic matrix polynomial.

    alpha : (n+1, n_in, n_in) with alpha[n] = I. The block companion of alpha^T
    has the poles as eigenvalues
    (:func:`~ema_pipeline.identification.diagram.roots.companion_eigenvalues`).
    """
    z = companion_eigenvalues(alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.log(z.astype(complex)) / dt
    return z, lam


#: The companion eigenvalues of a diagram go to worker processes when the sum
#: of their sizes cubed reaches this (about 0.1 s of LAPACK; below it the
#: processes' round trips cost more than they save).
PARALLEL_MIN_SIZE3 = 2e7


def _order_poles(alpha: np.ndarray, dt: float, f_top: float) -> tuple[np.ndarray, np.ndarray]:
    """One order's poles below the band top ``f_top`` (Hz) and their participation vectors."""
    return _band_poles(alpha, companion_eigenvalues(alpha), dt, f_top)


def _band_poles(alpha: np.ndarray, z: np.ndarray, dt: float,
                f_top: float) -> tuple[np.ndarray, np.ndarray]:
    """Of one order's discrete poles ``z``: the continuous poles of positive
    frequency below the band top ``f_top`` (Hz), in ascending frequency, and
    their participation vectors."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.log(z.astype(complex)) / dt
    keep = np.isfinite(lam) & (lam.imag > 0) & (lam.imag < 2 * np.pi * f_top * 0.9999)
    keep = np.flatnonzero(keep)
    keep = keep[np.argsort(lam.imag[keep], kind="stable")]
    return lam[keep], participation_vectors(alpha, z[keep])


def participation_vectors(alpha: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Unit participation vectors l_r with l_r^T A(z_r) = 0 (null vector of A^T)."""
    n_in = alpha.shape[1]
    if n_in == 1:
        return np.ones((z.size, 1), dtype=complex)
    powers = z[:, None] ** np.arange(alpha.shape[0])[None, :]  # (n_poles, n+1)
    A = np.einsum("rj,jab->rab", powers, alpha)
    _, _, vh = np.linalg.svd(np.swapaxes(A, 1, 2))
    return vh[:, -1, :].conj()


def plscf(
    freq_hz: np.ndarray,
    H: np.ndarray,
    *,
    max_order: int,
    orders: np.ndarray | None = None,
    weights: np.ndarray | None = None,
    dt: float | None = None,
    map_: Mapper | None = None,
) -> PoleSet:
    """pLSCF poles of every model order from one normal-matrix build.

    Parameters
    ----------
    freq_hz : (n_freq,) band lines in Hz (already restricted to the band).
    H : (n_out, n_in, n_freq) complex FRFs in that band.
    max_order : highest denominator order p (the model has p * n_in poles).
    orders : orders to solve (default 1..p).
    weights : (n_freq,) or (n_out, n_freq) line weights, optional.
    dt : z-domain sampling time; default 1 / (2 * freq_hz[-1]) (band top).
    map_ : a :class:`~ema_pipeline.runner.Mapper` of worker processes: the
        companion eigenvalues of the orders, shared out among them when they
        are worth it (:data:`PARALLEL_MIN_SIZE3`); the same numbers.

    Returns
    -------
    PoleSet with the poles of positive frequency below the band top.
    """
    n_out, n_in, n_freq = H.shape
    p = int(max_order)
    if dt is None:
        dt = 1.0 / (2.0 * freq_hz[-1])
    orders = np.arange(1, p + 1) if orders is None else np.asarray(orders, dtype=int)
    M = plscf_normal_matrix(freq_hz, H, p, dt, weights)
    alphas = plscf_denominators(M, n_in, orders)
    solve = partial(_order_poles, dt=float(dt), f_top=float(freq_hz[-1]))
    work = sum(float(a.shape[0] * n_in) ** 3 for a in alphas)
    if n_in == 1:  # scalar denominators: each order's roots from the previous ones
        roots = diagram_roots([a[:, 0, 0] for a in alphas])
        per_order = [_band_poles(a, z, float(dt), float(freq_hz[-1]))
                     for a, z in zip(alphas, roots, strict=True)]
    elif map_ is None or map_.workers < 2 or work < PARALLEL_MIN_SIZE3:
        per_order = [solve(alpha) for alpha in alphas]
    else:  # one order per task, the largest first (fixed shares left one worker
        # 36 % more of an order-480 diagram than the other)
        per_order = map_costliest_first(map_, solve, alphas,
                                        [float(a.shape[0] * n_in) ** 3 for a in alphas])
    o_list, l_list, p_list = [], [], []
    for n, (lam, part) in zip(orders, per_order, strict=True):
        o_list.append(np.full(lam.size, n))
        l_list.append(lam)
        p_list.append(part)
    return PoleSet(
        order=np.concatenate(o_list),
        pole=np.concatenate(l_list),
        participation=np.concatenate(p_list, axis=0),
        orders=orders,
        dt=float(dt),
    )
