"""Least-squares frequency-domain (LSFD) residues, pole refinement with covariance,
and the modal indicators (MAC, MPC, FRAC).

Pole-residue model of every FRF channel c = (output, reference), in the FRF's
own quantity (receptance, mobility or accelerance)::

    H_c(w) = sum_r [ a_cr / (jw - lambda_r) + conj(a_cr) / (jw - conj(lambda_r)) ]
             + LR_c * b_low(w) + UR_c * b_up(w)

with complex lower and upper residual terms b_low, b_up = (jw)^-2, 1 (receptance),
(jw)^-1, jw (mobility), 1, (jw)^2 (accelerance). The residue of the receptance
is A_cr = a_cr / lambda_r^q with q = 0, 1, 2 for the three quantities, and the
modal constant 2j omega_dr A_cr equals phi_o phi_i for mass-normalised real
modes.

Pole refinement (:func:`refine_poles`) is a variable-projection Gauss-Newton
(Levenberg-Marquardt) fit of the poles, with the linear terms eliminated, that
minimises the noise-weighted squared error sum_c sum_k |e_ck|^2 / (s_c v_k)^2.
The noise level is estimated from the residual of the initial fit: a scale
s_c per channel times a frequency profile v_k (running mean over a few lines).
The covariance of the pole parameters (sigma_r, omega_dr) is the inverse of
the Fisher matrix of that fit, F = sum_c Jp_c^T (I - P) Jp_c / s_c^2, where
Jp_c is the weighted Jacobian with respect to the poles and P the projection
onto the linear terms -- ordinary least-squares covariance propagation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

_Q = {"receptance": 0, "mobility": 1, "accelerance": 2}


def residual_basis(freq_hz: np.ndarray, quantity: str) -> np.ndarray:
    """(n_freq, 2) lower and upper residual basis functions of the quantity."""
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    q = _Q[quantity]
    with np.errstate(divide="ignore", invalid="ignore"):
        low = jw ** (q - 2)
        up = jw**q
    basis = np.stack([low, up], axis=1)
    return np.where(np.isfinite(basis), basis, 0.0)


def design_matrix(
    freq_hz: np.ndarray,
    poles: np.ndarray,
    quantity: str,
    lower: bool = True,
    upper: bool = True,
) -> np.ndarray:
    """Complex design matrix B (n_freq, K) whose columns take **real** coefficients.

    Columns 2r, 2r+1: g_r + conj-pole term and j(g_r - conj-pole term) with
    g_r = 1/(jw - lambda_r) (real and imaginary part of a_r); then j-pairs of the
    residual terms (real and imaginary part of LR and UR).
    """
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)[:, None]
    g = 1.0 / (jw - poles[None, :])
    gc = 1.0 / (jw - np.conj(poles)[None, :])
    cols = np.empty((jw.shape[0], 2 * poles.size), dtype=complex)
    cols[:, 0::2] = g + gc
    cols[:, 1::2] = 1j * (g - gc)
    res = residual_basis(freq_hz, quantity)[:, [k for k, on in enumerate((lower, upper)) if on]]
    res_cols = np.empty((jw.shape[0], 2 * res.shape[1]), dtype=complex)
    res_cols[:, 0::2] = res
    res_cols[:, 1::2] = 1j * res
    return np.concatenate([cols, res_cols], axis=1)


def _real_stack(B: np.ndarray) -> np.ndarray:
    return np.concatenate([B.real, B.imag], axis=0)


@dataclass(frozen=True)
class LSFDFit:
    """Result of :func:`lsfd`.

    a : (n_modes, n_ch) complex   residue a_cr of the quantity's modal term
    lower, upper : (n_ch,) complex residual terms (zero when not fitted)
    H_fit : (n_ch, n_freq) complex synthesised FRFs
    """

    a: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    H_fit: np.ndarray


def lsfd(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    quantity: str,
    *,
    lower: bool = True,
    upper: bool = True,
    weights: np.ndarray | None = None,
) -> LSFDFit:
    """Residues and residual terms of every channel for given poles (linear LS).

    Parameters
    ----------
    freq_hz : (n_freq,) Hz.   H : (n_ch, n_freq) complex FRFs.
    poles : (n_modes,) complex, Im > 0, rad/s.
    weights : (n_freq,) optional line weights (same for every channel).
    """
    B = design_matrix(freq_hz, poles, quantity, lower, upper)
    A = _real_stack(B)
    scale = np.max(np.abs(A), axis=0)
    scale[scale == 0] = 1.0
    Y = _real_stack(np.asarray(H).T)
    w = np.ones(H.shape[-1]) if weights is None else np.asarray(weights, dtype=float)
    w2 = np.concatenate([w, w])[:, None]
    Qm, Rm = _batched_qr(A / scale * w2)
    X = np.linalg.solve(Rm, Qm.T @ (Y * w2)) / scale[:, None]
    m = poles.size
    a = X[0 : 2 * m : 2] + 1j * X[1 : 2 * m : 2]
    rest = X[2 * m :]
    res = rest[0::2] + 1j * rest[1::2]
    zeros = np.zeros(H.shape[0], dtype=complex)
    low = res[0] if lower else zeros
    up = res[int(lower)] if upper else zeros
    H_fit = (B @ X).T
    return LSFDFit(a=a, lower=low, upper=up, H_fit=H_fit)


@dataclass(frozen=True)
class RefinedPoles:
    """Result of :func:`refine_poles`.

    pole : (n_modes,) complex refined poles (rad/s).
    cov : (n_modes, 2, 2) covariance of (sigma_r, omega_dr), (rad/s)^2.
    noise_std : (n_modes, n_ch) RMS standard deviation of the FRF noise in
        each mode's local band (per real/imaginary part).
    band_hz : (n_modes, 2) the local band of each mode.
    n_iter : (n_modes,) Levenberg-Marquardt iterations taken.
    """

    pole: np.ndarray
    cov: np.ndarray
    noise_std: np.ndarray
    band_hz: np.ndarray
    n_iter: np.ndarray


def _noise_model(R: np.ndarray, Y: np.ndarray, n_lin: int) -> np.ndarray:
    """Standard deviation per line and channel, var_k = a_c + b_c |H_ck|^2.

    Additive noise on the response gives the constant a, noise on the force
    (and leakage) gives an error proportional to |H| (H1 = X/F, dH = -H dF/F);
    a_c, b_c >= 0 are fitted to the squared residual |e_ck|^2 against the
    fitted |H_ck|^2 by non-negative least squares, scaled by the degrees of
    freedom 2n / (2n - n_lin). R, Y: (2n, n_ch) real-stacked residual and data.
    """
    n = R.shape[0] // 2
    e2 = R[:n] ** 2 + R[n:] ** 2
    fit = Y - R
    h2 = fit[:n] ** 2 + fit[n:] ** 2
    dof = 2 * n / max(2 * n - n_lin, 1)
    std = np.empty_like(e2)
    for c in range(e2.shape[1]):
        scale = max(np.max(h2[:, c]), np.finfo(float).tiny)
        coef, _ = optimize.nnls(np.stack([np.ones(n), h2[:, c] / scale], axis=1), e2[:, c])
        var = (coef[0] + coef[1] * h2[:, c] / scale) * dof
        floor = max(np.mean(e2[:, c]) * dof * 1e-3, np.finfo(float).tiny)
        std[:, c] = np.sqrt(np.maximum(var, floor))
    # each of the real and imaginary parts carries half the complex variance
    return np.concatenate([std, std], axis=0) / np.sqrt(2)


def _batched_qr(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Thin QR of a stack of tall matrices (..., n, K) by CholeskyQR2.

    Two rounds of Q = A R^-1 with R^T R = A^T A: as accurate as Householder
    for the moderately conditioned, column-scaled design matrices here, and
    all matrix products (numpy's batched Householder QR is ~20x slower).
    """
    Q = A
    R = None
    for _ in range(2):
        G = np.swapaxes(Q, -1, -2) @ Q
        k = G.shape[-1]
        G = G + np.eye(k) * (1e-15 * np.trace(G, axis1=-2, axis2=-1)[..., None, None] / k)
        Lc = np.linalg.cholesky(G)
        Linv = np.linalg.inv(Lc)
        Q = Q @ np.swapaxes(Linv, -1, -2)
        Rk = np.swapaxes(Lc, -1, -2)
        R = Rk if R is None else Rk @ R
    return Q, R


def _correlation_factor(Rw: np.ndarray, max_lag: int = 128) -> float:
    """Variance inflation for noise correlated between neighbouring lines.

    Windows (the exponential window and the force window above all) correlate
    the noise of neighbouring lines, so the lines carry less independent
    information than their number suggests. For a smooth estimator the
    variance grows by the factor 1 + 2 sum_l k_l rho_l, with rho_l the
    autocorrelation of the weighted complex residual at lag l lines and
    Bartlett weights k_l = 1 - l/(L+1), L = min(``max_lag``, n/8).
    """
    n = Rw.shape[0] // 2
    e = Rw[:n] + 1j * Rw[n:]
    e = e - np.mean(e, axis=0)
    p0 = np.sum(np.abs(e) ** 2)
    L = min(max_lag, n // 8)
    if p0 <= 0 or L < 1:
        return 1.0
    lags = np.arange(1, L + 1)
    rho = np.array([np.real(np.sum(e[lag:] * np.conj(e[:-lag]))) for lag in lags]) / p0
    return float(max(1.0, 1.0 + 2.0 * np.sum((1 - lags / (L + 1)) * rho)))


def _vp_solve(
    freq_hz: np.ndarray,
    Y: np.ndarray,
    poles: np.ndarray,
    background: np.ndarray,
    max_iter: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Variable-projection Levenberg-Marquardt fit of ``poles`` to Y (2n, n_ch).

    Model per channel: sum_r a_r/(jw - l_r) + conj + background @ c (complex c).
    Noise: independent per line with the variance model of :func:`_noise_model`,
    estimated from the residual of the start poles and once more after a first
    weighted solve, approximated as separable, std_ck = s_c u_k, so that one
    projection serves all channels. Returns the poles, the inverse Fisher matrix of
    (sigma_r, omega_dr), the noise std (2n, n_ch) and the iterations.
    """
    n = freq_hz.size
    m = poles.size
    jw = 2j * np.pi * freq_hz[:, None]
    bg = np.empty((n, 2 * background.shape[1]), dtype=complex)
    bg[:, 0::2] = background
    bg[:, 1::2] = 1j * background
    bg_r = _real_stack(bg)
    n_lin = 2 * m + bg.shape[1]

    def design(lam: np.ndarray) -> np.ndarray:
        g = 1.0 / (jw - lam[None, :])
        gc = 1.0 / (jw - np.conj(lam)[None, :])
        cols = np.empty((n, 2 * m), dtype=complex)
        cols[:, 0::2] = g + gc
        cols[:, 1::2] = 1j * (g - gc)
        return np.concatenate([_real_stack(cols), bg_r], axis=1)

    def fit(lam: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
        """Projection with row weights u (2n,) shared by all channels."""
        Aw = design(lam) * u[:, None]
        scale = np.max(np.abs(Aw), axis=0)
        scale[scale == 0] = 1.0
        Qm, Rm = _batched_qr(Aw / scale)
        Yw = Y * u[:, None]
        QtY = Qm.T @ Yw
        Rw = Yw - Qm @ QtY  # row-weighted residual (2n, n_ch)
        X = np.linalg.solve(Rm, QtY) / scale[:, None]  # (K, n_ch)
        return Qm, Rw, X

    def jac(lam: np.ndarray, X: np.ndarray) -> np.ndarray:
        a = X[0 : 2 * m : 2] + 1j * X[1 : 2 * m : 2]  # (m, n_ch)
        t1 = (1.0 / (jw - lam[None, :]) ** 2)[:, :, None] * a[None, :, :]
        t2 = (1.0 / (jw - np.conj(lam)[None, :]) ** 2)[:, :, None] * np.conj(a)[None, :, :]
        J = np.empty((n, 2 * m, a.shape[1]), dtype=complex)
        J[:, 0::2] = -(t1 + t2)  # d/d sigma
        J[:, 1::2] = 1j * (t1 - t2)  # d/d omega_d
        return np.concatenate([J.real, J.imag], axis=0)  # (2n, 2m, n_ch)

    def cost_of(Rw: np.ndarray, inv_s2: np.ndarray) -> float:
        return float(np.sum(Rw**2 * inv_s2[None, :]))

    def normal(lam: np.ndarray, u: np.ndarray, inv_s2: np.ndarray) -> tuple[np.ndarray, ...]:
        Qm, Rw, X = fit(lam, u)
        Jw = jac(lam, X) * u[:, None, None]
        Jf = Jw.reshape(Jw.shape[0], -1)
        Jp = (Jf - Qm @ (Qm.T @ Jf)).reshape(Jw.shape)
        sq = np.sqrt(inv_s2)
        Js = np.transpose(Jp * sq[None, None, :], (0, 2, 1)).reshape(-1, Jp.shape[1])
        F = Js.T @ Js
        g = Js.T @ (Rw * sq[None, :]).reshape(-1)
        return F, g, cost_of(Rw, inv_s2)

    def lam_of(th: np.ndarray) -> np.ndarray:
        return -th[0::2] + 1j * th[1::2]

    theta = np.empty(2 * m)
    theta[0::2] = -poles.real
    theta[1::2] = poles.imag
    it_total = 0
    u = np.ones(2 * n)
    for _round in range(2):
        _, R0, _ = fit(lam_of(theta), np.ones(2 * n))
        std = _noise_model(R0, Y, n_lin)
        # separable approximation std_ck ~ s_c u_k (one projection for all channels)
        s2 = np.mean(std**2, axis=0)
        inv_s2 = 1.0 / np.maximum(s2, np.finfo(float).tiny)
        u = 1.0 / np.sqrt(np.mean(std**2 * inv_s2[None, :], axis=1))
        F, g, cost = normal(lam_of(theta), u, inv_s2)
        mu = 1e-3
        for _it in range(max_iter):
            it_total += 1
            D = np.diag(np.diag(F)) + np.finfo(float).tiny
            try:
                step = np.linalg.solve(F + mu * D, g)
            except np.linalg.LinAlgError:
                break
            trial = theta + step
            if np.all(trial[0::2] > 0):
                cost_t = cost_of(fit(lam_of(trial), u)[1], inv_s2)
            else:
                cost_t = np.inf
            if cost_t < cost:
                theta = trial
                F, g, cost_new = normal(lam_of(theta), u, inv_s2)
                sd = np.sqrt(1.0 / np.maximum(np.diag(F), 1e-300))
                done = (cost - cost_new) < 1e-8 * cost or np.all(np.abs(step) < 1e-3 * sd)
                cost = cost_new
                mu = max(mu / 10, 1e-9)
                if done:
                    break
            else:
                mu *= 10
                if mu > 1e6:
                    break
    try:
        Finv = np.linalg.inv(F)
    except np.linalg.LinAlgError:
        Finv = np.linalg.pinv(F)
    _, Rw, _ = fit(lam_of(theta), u)
    Rw = Rw * np.sqrt(inv_s2)[None, :]
    std = np.sqrt(1.0 / inv_s2)[None, :] / u[:, None]
    return lam_of(theta), Finv * _correlation_factor(Rw), std, it_total


def refine_poles(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    *,
    half_width: float = 12.0,
    min_lines: int = 40,
    max_iter: int = 30,
    max_shift: float = 0.5,
) -> RefinedPoles:
    """Local nonlinear least-squares refinement of each pole, with its covariance.

    For mode r the lines within f_r +- ``half_width`` half-power bandwidths
    (sigma_r / pi Hz; at least ``min_lines`` lines, at most 20 % of f_r) are
    fitted with the poles of all modes whose half-power band reaches into that
    band plus a complex quadratic background c0 + c1 x + c2 x^2
    (x = (f - f_r)/width) per channel, which stands in for the modes outside
    the local band far better than global residual terms do. The fit is a
    variable-projection Levenberg-Marquardt on (sigma, omega_d) of those poles
    with white noise per channel, its variance estimated from the residual.
    The covariance of mode r is the (sigma_r, omega_dr) block of the inverse
    Fisher matrix F = sum_c Jp_c^T (I - P) Jp_c / s_c^2 (Jp the Jacobian with
    respect to the poles, P the projection onto the linear terms): least-squares
    covariance propagation. A pole that moves by more than ``max_shift`` times
    its decay rate plus one line keeps its start value (refinement failed) and
    gets the covariance evaluated there.

    Parameters
    ----------
    freq_hz : (n_freq,) Hz.   H : (n_ch, n_freq) complex FRFs (any quantity).
    poles : (n_modes,) identified poles (rad/s, Im > 0).
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    H = np.asarray(H)
    n_ch = H.shape[0]
    m = poles.size
    df = freq_hz[1] - freq_hz[0]
    out = poles.copy()
    cov = np.full((m, 2, 2), np.nan)
    noise = np.full((m, n_ch), np.nan)
    bands = np.zeros((m, 2))
    iters = np.zeros(m, dtype=int)
    for r in range(m):
        local = _local_problem(freq_hz, H, poles, r, half_width, min_lines)
        if local is None:
            continue
        f, Y, members, background, k, band = local
        bands[r] = band
        lam, Finv, s, it = _vp_solve(f, Y, poles[members], background, max_iter)
        lam_r = lam[k]
        if abs(lam_r - poles[r]) > max_shift * abs(poles[r].real) + 2 * np.pi * df:
            # refinement wandered off: keep the start pole, covariance there
            lam, Finv, s, it = _vp_solve(f, Y, poles[members], background, 0)
            lam_r = poles[r]
        out[r] = lam_r
        cov[r] = Finv[2 * k : 2 * k + 2, 2 * k : 2 * k + 2]
        noise[r] = np.sqrt(np.mean(s**2, axis=0))
        iters[r] = it
    return RefinedPoles(pole=out, cov=cov, noise_std=noise, band_hz=bands, n_iter=iters)


def _local_problem(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    r: int,
    half_width: float,
    min_lines: int,
) -> tuple | None:
    """Lines, data, member poles and background of mode r's local band."""
    df = freq_hz[1] - freq_hz[0]
    f_r = poles.imag / (2 * np.pi)
    hpb = np.abs(poles.real) / np.pi  # half-power bandwidth in Hz
    width = max(half_width * hpb[r], 0.5 * min_lines * df)
    width = min(width, 0.2 * f_r[r]) if 0.2 * f_r[r] > 5 * df else width
    lo, hi = f_r[r] - width, f_r[r] + width
    sel = (freq_hz >= lo) & (freq_hz <= hi)
    if sel.sum() < 12:
        return None
    f = freq_hz[sel]
    members = np.union1d(np.flatnonzero((f_r + hpb > lo) & (f_r - hpb < hi)), [r])
    x = (f - f_r[r]) / width
    background = np.stack([np.ones_like(x), x, x**2], axis=1).astype(complex)
    Y = _real_stack(H[:, sel].T)
    k = int(np.flatnonzero(members == r)[0])
    return f, Y, members, background, k, (lo, hi)


def pole_significance(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    *,
    half_width: float = 12.0,
    min_lines: int = 40,
) -> np.ndarray:
    """Relative standard deviation of each pole's decay rate, std(sigma_r)/sigma_r.

    The inverse Fisher matrix of the local fit of :func:`refine_poles`,
    evaluated at the given poles without iterating. A physical mode is
    determined to a small fraction of its damping; a computational pole that
    models noise is not (values near or above 1). Inf where the local band is
    too short.
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    H = np.asarray(H)
    rel = np.full(poles.size, np.inf)
    for r in range(poles.size):
        local = _local_problem(freq_hz, H, poles, r, half_width, min_lines)
        if local is None:
            continue
        f, Y, members, background, k, _ = local
        _, Finv, _, _ = _vp_solve(f, Y, poles[members], background, 0)
        rel[r] = np.sqrt(max(Finv[2 * k, 2 * k], 0.0)) / abs(poles[r].real)
    return rel


def modal_std(pole: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standard deviations of f_n (Hz) and zeta from the covariance of (sigma, omega_d).

    First-order propagation with |lambda| = sqrt(sigma^2 + omega_d^2), zeta = sigma/|lambda|:
    d|lambda| = (sigma dsigma + omega_d domega_d)/|lambda|,
    dzeta = (omega_d^2 dsigma - sigma omega_d domega_d)/|lambda|^3.
    ``pole`` is the window-corrected pole (the window shift is a constant).
    """
    s = -pole.real
    wd = pole.imag
    wn = np.abs(pole)
    Jf = np.stack([s / wn, wd / wn], axis=1) / (2 * np.pi)
    Jz = np.stack([wd**2, -s * wd], axis=1) / wn[:, None] ** 3
    var_f = np.einsum("ri,rij,rj->r", Jf, cov, Jf)
    var_z = np.einsum("ri,rij,rj->r", Jz, cov, Jz)
    return np.sqrt(np.maximum(var_f, 0)), np.sqrt(np.maximum(var_z, 0))


def mac(phi_a: np.ndarray, phi_b: np.ndarray | None = None) -> np.ndarray:
    """Modal assurance criterion MAC_ij = |a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j)).

    phi_a : (n_dof, n_a), phi_b : (n_dof, n_b) (default phi_a). Returns (n_a, n_b).
    """
    phi_b = phi_a if phi_b is None else phi_b
    num = np.abs(phi_a.conj().T @ phi_b) ** 2
    den = np.real(np.sum(phi_a.conj() * phi_a, axis=0))[:, None] * np.real(
        np.sum(phi_b.conj() * phi_b, axis=0)
    )[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, 0.0)


def mpc(phi: np.ndarray) -> np.ndarray:
    """Modal phase collinearity per mode (1 = real/normal mode, 0 = fully complex).

    MPC = ((S_xx - S_yy)^2 + 4 S_xy^2) / (S_xx + S_yy)^2 with S_xx = Re^T Re,
    S_yy = Im^T Im, S_xy = Re^T Im of each shape (n_dof, n_modes).
    """
    x, y = phi.real, phi.imag
    sxx = np.sum(x * x, axis=0)
    syy = np.sum(y * y, axis=0)
    sxy = np.sum(x * y, axis=0)
    den = (sxx + syy) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, ((sxx - syy) ** 2 + 4 * sxy**2) / den, 0.0)


def real_normalised(phi: np.ndarray) -> np.ndarray:
    """Real mode shapes: each complex shape rotated to its principal axis (the
    phase maximising the norm of the real part), real part taken, scaled to a
    largest component of +1."""
    x, y = phi.real, phi.imag
    theta = 0.5 * np.arctan2(2 * np.sum(x * y, axis=0), np.sum(x * x - y * y, axis=0))
    rot = np.real(phi * np.exp(-1j * theta)[None, :])
    k = np.argmax(np.abs(rot), axis=0)
    peak = rot[k, np.arange(rot.shape[1])]
    peak = np.where(peak == 0, 1.0, peak)
    return rot / peak[None, :]


def frac(H: np.ndarray, H_fit: np.ndarray) -> np.ndarray:
    """Frequency response assurance criterion per FRF (last axis = frequency)."""
    num = np.abs(np.sum(H.conj() * H_fit, axis=-1)) ** 2
    den = np.sum(np.abs(H) ** 2, axis=-1) * np.sum(np.abs(H_fit) ** 2, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, 0.0)


def normalised_error(H: np.ndarray, H_fit: np.ndarray) -> np.ndarray:
    """||H - H_fit|| / ||H|| per FRF (last axis = frequency)."""
    num = np.sqrt(np.sum(np.abs(H - H_fit) ** 2, axis=-1))
    den = np.sqrt(np.sum(np.abs(H) ** 2, axis=-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, np.inf)


def plot_fit(
    ax: Axes,
    freq_hz: np.ndarray,
    H: np.ndarray,
    H_fit: np.ndarray,
    *,
    label: str = "",
    frac_value: float | None = None,
    error_value: float | None = None,
) -> Axes:
    """Draw one measured FRF and its synthesis (magnitude, log scale) onto ``ax``.

    The title carries the FRAC and the normalised error when given.
    """
    ax.semilogy(freq_hz, np.abs(H), color="0.5", lw=0.8, label="measured")
    ax.semilogy(freq_hz, np.abs(H_fit), color="tab:red", lw=0.9, ls="--", label="synthesised")
    ax.semilogy(freq_hz, np.abs(H - H_fit), color="tab:blue", lw=0.5, alpha=0.6,
                label="difference")
    parts = [label] if label else []
    if frac_value is not None:
        parts.append(f"FRAC {frac_value:.4f}")
    if error_value is not None:
        parts.append(f"error {100 * error_value:.2f} %")
    ax.set_title(", ".join(parts), fontsize="small")
    ax.set_xlabel("frequency / Hz")
    ax.set_ylabel("|H|")
    ax.legend(fontsize="x-small", loc="lower right")
    return ax
