"""The uncertainty model of the identified poles: standard deviations from the data.

Derivation (no empirical factor). The refined pole of mode r is the weighted
least-squares estimate of the local fit of
:mod:`ema_pipeline.identification.refinement.refine` (variable projection: the linear
terms -- residues and background -- eliminated). To first order its error is
d theta = F^-1 J^T u, with J the noise-weighted Jacobian projected off the
linear terms (rows: real and imaginary part of every line and channel) and u
the weighted noise, so

    Cov(theta) = F^-1 G F^-1,   F = J^T J,   G = J^T Cov(u) J.

* **Noise level** (:func:`noise_model`): per channel and line
  var = a_c + b_c |H_ck|^2, fitted to the residual of the local fit (additive
  response noise, and the part proportional to |H| that force noise gives an
  H1 estimate, dH = -H dF / F). The fit absorbs part of the noise, most
  where its columns concentrate: a resonance only a few lines wide. Each
  squared residual is therefore divided by 1 - h_k, h_k the leverage of line
  k (the diagonal of the hat matrix of the weighted fit: linear terms and
  poles), rather than by one global degrees-of-freedom factor; the weighted
  residual sees nearly homoscedastic noise, so 1 - h_k is its expected
  shrinkage. With the global factor the variance at the peak of a
  3-line-wide resonance comes out 17-23 % low (``tests/test_uncertainty.py``),
  and on the close-mode hard cases 88-90 % of the true damping ratios lay
  within 2 sigma (now 89-94 %). The fit's own weights keep the global factor:
  weighting with the leverage-corrected level moved poles of the measured
  beam by 1-7 Hz (a peak 1-2 lines wide then barely counts). The sandwich
  below takes the weights' mismatch into account.
* **Why not coherence**: where an FRF set carries its coherence g^2 and
  number of averages n_d, textbook H1 theory gives the random error
  var = (1 - g^2) / (g^2 n_d) |H|^2 (Bendat & Piersol). It was tried as a
  lower bound of the noise level and is not used: within 3 half-power
  widths of a mode the simulated impact tests of ``tests/hardcases.py``
  carry 3-35 times *less* error than it says (the exponential window and
  the hit-to-hit change of the force spectrum lower the coherence at a
  resonance without a random error in the averaged H1), away from the modes
  1.2-2 times more; as a floor it doubled the damping sigmas of those tests
  (docs/validation.md). On the paper's
  simulated test the residual is 3-300 times the coherence's variance
  (leakage, the windows' bias). The residual, which sees all of it, decides.
* **Line-to-line correlation**: windows correlate the noise of neighbouring
  lines (the FRF lines are no longer independent). For circular complex noise
  with correlation rho_l between lines l apart, G = Re(Jc^H P Jc) with P the
  Hermitian Toeplitz matrix of rho (:func:`correlated_information`, by FFT).
  When the FRF set records its windows, rho is the windows' own: the
  exponential window exp(-t/tau) gives rho_l = 1 / (1 - j pi l tau df) for the
  additive part (:func:`exponential_window_correlation`), a rectangular force
  window of length L gives exp(j pi l L df) sinc(l L df) for the part
  proportional to |H| (:func:`rect_window_correlation`, applied to the
  fraction b|H|^2 / var of the variance, with the phase of H). Otherwise rho
  is estimated from the residual (:func:`residual_correlation`, Bartlett
  taper). A correlation estimate never makes a variance smaller than that of
  independent lines.
* **Correlated leverage**: the window's correlation also changes how much
  noise the fit takes up. Noise correlated over 1/(pi tau df) lines looks
  like a small change of a resonance that is as narrow (one the window
  dominates, 1/tau above the structure's decay), and the residual there
  keeps only diag((I - P) S (I - P)) / diag(S) of it, P the fit's hat
  matrix, S the noise covariance (:func:`correlated_leverage`); one minus
  that share replaces the leverage diag(P) in the noise level when the
  exponential window is known (the part of the noise proportional to |H|
  keeps diag(P)). Without it the damping scatter of such modes was 1.3-2
  times the sigma (Monte Carlo of a windowed mode,
  ``tests/test_uncertainty.py``, and of the impact hard cases:
  docs/validation.md).
* **Local model** (:func:`ema_pipeline.identification.refinement.refine.band_sensitivity`):
  the local fit stands for the modes outside its band by a quadratic
  background and subtracted LSFD terms; where that is not exact the pole
  carries an error the residual cannot show. The change d of the pole when
  the fit is repeated on half the local band (6 instead of 12 half-power
  bandwidths), halved, is added as a standard deviation of the model choice,
  d d^T / 4 (the two fits bracket the error; d also holds the extra noise of
  the narrower fit).
* **Window correction**: the exponential window shifts every pole by the
  constant 1/tau, which leaves the covariance unchanged; it enters through the
  line correlation above.
* **Propagation** to f_n and zeta (:func:`modal_std`), first order.

``SelectionThresholds.max_rel_sigma_std`` is the threshold below which the
order search's screen counts a pole as determined by the data.

Neither ``scipy.optimize`` nor ``scipy.signal`` is imported here (together
about 0.8 s of start-up through ``scipy.stats``): the noise level's NNLS of two
coefficients is closed-form (:func:`nonnegative_line_fit`), and the Toeplitz
products use ``numpy.fft`` (the same pocketfft as ``scipy.fft``, bit for bit,
without the 60-75 ms of importing ``scipy.fft`` in every process) with the
transform lengths of :func:`fast_fft_len`.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

#: The smallest normal float, the floor of a variance or a maximum.
_TINY = float(np.finfo(float).tiny)


def noise_model(
    R: np.ndarray,
    Y: np.ndarray,
    n_lin: int,
    *,
    with_fraction: bool = False,
    leverage: np.ndarray | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Standard deviation per line and channel, var_k = a_c + b_c |H_ck|^2.

    Additive noise on the response gives the constant a, noise on the force
    (and leakage) gives an error proportional to |H| (H1 = X/F, dH = -H dF/F);
    a_c, b_c >= 0 are fitted to the squared residual |e_ck|^2 against the
    fitted |H_ck|^2 by non-negative least squares, scaled by the degrees of
    freedom 2n / (2n - n_lin), or, with ``leverage`` (2n,) or (2n, n_ch) (the
    diagonal of the hat matrix of the fit that left R), each squared residual
    divided by 1 - h of its line. R, Y: (2n, n_ch) real-stacked residual and data.
    With ``with_fraction`` also the fraction b |H|^2 / var of the variance that
    is proportional to |H|^2, (n, n_ch).
    """
    n = R.shape[0] // 2
    e2 = R[:n] ** 2 + R[n:] ** 2
    fit = Y - R
    h2 = fit[:n] ** 2 + fit[n:] ** 2
    dof = 2 * n / max(2 * n - n_lin, 1)
    if leverage is not None:
        # the fit absorbs the noise where its columns concentrate (a resonance
        # only a few lines wide): divide by 1 - h per line instead of a
        # global degrees-of-freedom factor
        lev = np.broadcast_to(np.reshape(leverage, (2 * n, -1)), R.shape)
        h = 0.5 * (lev[:n] + lev[n:])
        e2 = e2 / np.clip(1.0 - h, 0.05, 1.0)
        dof = 1.0
    # (methods, not numpy's functions: the same reductions without their
    # wrappers, in a helper called some 50 times per identification)
    x = h2 / np.maximum(h2.max(axis=0), _TINY)
    a, b = nonnegative_line_fit(x, e2)
    var = (a + b * x) * dof
    floor = np.maximum(e2.sum(axis=0) / n * dof * 1e-3, _TINY)
    std = np.sqrt(np.maximum(var, floor))
    # each of the real and imaginary parts carries half the complex variance
    half = std / np.sqrt(2)
    out = np.concatenate([half, half], axis=0)
    if not with_fraction:  # (the fraction costs as much again as the rest)
        return out
    frac_b = b * x * dof / std**2
    return out, np.clip(frac_b, 0.0, 1.0)


def nonnegative_line_fit(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Non-negative least squares of y ~ a + b x per column: a, b >= 0 (n_ch,) each.

    The two-coefficient NNLS in closed form for all columns at once: the
    unconstrained line (centred, as in simple regression) when both
    coefficients are >= 0, otherwise the better of a alone (mean of y) and
    b alone (x.y / x.x). A convex problem has one minimum, which is on one of
    these faces, so this is the NNLS solution; it replaces one
    ``scipy.optimize.nnls`` call per channel.

    Examples
    --------
    >>> x = np.array([[0.0, 0.0], [0.5, 0.5], [1.0, 1.0]])
    >>> y = np.array([[1.0, 2.0], [2.0, 1.0], [3.0, 0.0]])  # 1 + 2x; 2 - 2x: b clipped at 0
    >>> a, b = nonnegative_line_fit(x, y)
    >>> a.round(6).tolist(), b.round(6).tolist()
    ([1.0, 1.0], [2.0, 0.0])
    """
    # the means and sums as array methods (numpy's functions add a wrapper
    # each; the same reductions): this runs on every local fit's residual
    n = x.shape[0]
    x_mean, y_mean = x.sum(axis=0) / n, y.sum(axis=0) / n
    xc = x - x_mean
    sxx = (xc * xc).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        b_line = (xc * (y - y_mean)).sum(axis=0) / sxx
        b_only = (x * y).sum(axis=0) / (x * x).sum(axis=0)
    a_line = y_mean - b_line * x_mean
    line_ok = (sxx > 0) & np.isfinite(b_line) & (b_line >= 0) & (a_line >= 0)
    # the three faces: a alone, b alone, the line (where it is allowed)
    a_only = np.maximum(y_mean, 0.0)
    b_only = np.where(np.isfinite(b_only), np.maximum(b_only, 0.0), 0.0)
    a_line = np.where(line_ok, a_line, 0.0)
    b_line = np.where(line_ok, b_line, 0.0)
    # the squared error of each face, (a + b x - y)^2 summed over the lines:
    # a face with a zero coefficient drops its term (a + 0 x = a, 0 + b x =
    # b x: the same numbers with fewer passes over the lines)
    cost = np.empty((3, y.shape[1]))
    cost[0] = ((a_only - y) ** 2).sum(axis=0)
    cost[1] = ((b_only * x - y) ** 2).sum(axis=0)
    cost[2] = np.where(line_ok, ((a_line + b_line * x - y) ** 2).sum(axis=0), np.inf)
    pick = cost.argmin(axis=0)
    return (np.where(pick == 0, a_only, np.where(pick == 2, a_line, 0.0)),
            np.where(pick == 1, b_only, np.where(pick == 2, b_line, 0.0)))


def residual_correlation(e: np.ndarray, max_lag: int = 128) -> np.ndarray:
    """Complex correlation of the noise between lines l apart, from residuals.

    rho_l = sum_kc e_kc conj(e_(k+l)c) / sum_kc |e_kc|^2 for l = 0..L,
    L = min(``max_lag``, n/4), ``e`` (n, n_ch) the complex noise-weighted
    residual, times the Bartlett taper 1 - l/(L+1) (a consistent, positive
    estimate). Windows make it complex: the exponential window of time
    constant tau on a record of length T gives rho_l = 1 / (1 - j pi l tau/T)
    in this convention.

    Examples
    --------
    >>> e = np.random.default_rng(0).standard_normal((4000, 2)) * (1 + 0j)
    >>> rho = residual_correlation(e, 4)
    >>> float(rho[0].real), bool(np.all(np.abs(rho[1:]) < 0.1))
    (1.0, True)
    """
    n = e.shape[0]
    L = int(min(max_lag, n // 4))
    e = e - np.mean(e, axis=0)
    p0 = float(np.sum(np.abs(e) ** 2))
    rho = np.zeros(L + 1, dtype=complex)
    rho[0] = 1.0
    if p0 <= 0:
        return rho[:1]
    for lag in range(1, L + 1):
        rho[lag] = np.sum(e[:-lag] * np.conj(e[lag:])) / p0 * (1 - lag / (L + 1))
    return rho


def exponential_window_correlation(tau_df: float, n_lags: int) -> np.ndarray:
    """Correlation rho_l = 1 / (1 - j pi l tau df), l = 0..n_lags-1, between
    lines l apart of white noise under the exponential window exp(-t/tau)
    (E[X_k conj(X_(k+l))] / E|X_k|^2 of the windowed record's spectrum,
    df = 1/T, the record decayed at its end); ``tau_df`` = tau df.

    Examples
    --------
    >>> rho = exponential_window_correlation(0.2, 2)
    >>> rho.real.round(3).tolist(), rho.imag.round(3).tolist()
    ([1.0, 0.717], [0.0, 0.45])
    """
    lag = np.arange(int(n_lags))
    return np.asarray(1.0 / (1.0 - 1j * np.pi * lag * tau_df))


def rect_window_correlation(length_df: float, n_lags: int) -> np.ndarray:
    """Correlation rho_l = exp(j pi l L df) sinc(l L df), l = 0..n_lags-1,
    between lines l apart of white noise under a rectangular (force) window
    of length L (``length_df`` = L df).

    Examples
    --------
    >>> np.abs(rect_window_correlation(0.5, 3)).round(3).tolist()
    [1.0, 0.637, 0.0]
    """
    x = np.arange(int(n_lags)) * length_df
    return np.asarray(np.exp(1j * np.pi * x) * np.sinc(x))


@lru_cache(maxsize=512)
def fast_fft_len(target: int, real: bool) -> int:
    """Smallest length >= ``target`` whose prime factors are 2, 3 and 5 (a
    real transform) or 2, 3, 5, 7 and 11 (a complex one): pocketfft's fast
    lengths, those of ``scipy.fft.next_fast_len``, without importing
    ``scipy.fft``.

    Examples
    --------
    >>> fast_fft_len(97, True), fast_fft_len(97, False), fast_fft_len(1, False)
    (100, 98, 1)
    """
    primes = (2, 3, 5) if real else (2, 3, 5, 7, 11)
    m = max(int(target), 1)
    while True:
        rest = m
        for p in primes:
            while rest % p == 0:
                rest //= p
        if rest == 1:
            return m
        m += 1


def correlated_information(Jc: np.ndarray, rho: np.ndarray,
                           kernel: ToeplitzKernel | None = None) -> np.ndarray:
    """G = Re(Jc^H P Jc) summed over channels, P[k, k+l] = rho_l (Hermitian Toeplitz).

    ``Jc`` (n, n_par, n_ch) is the complex form (real part rows + 1j imaginary
    part rows) of the noise-weighted, projected Jacobian; the real-stacked
    least-squares estimate has the sandwich covariance F^-1 G F^-1 with
    F = Re(Jc^H Jc) when the complex noise is circular with line correlation
    ``rho`` (for rho = [1] G = F). G = F + sum_l (Re(rho_l S_l) + Re(rho_l S_l)^T),
    S_l = sum_k Jc_k^H Jc_(k+l). ``kernel``: the :class:`ToeplitzKernel` of
    ``rho`` for n lines, when the caller has it.

    Examples
    --------
    >>> J = np.ones((10, 1, 1), complex)
    >>> float(correlated_information(J, np.array([1.0, 0.5]))[0, 0])  # 10 + 2 * 0.5 * 9
    19.0
    """
    n, n_par, n_ch = Jc.shape
    X = Jc.reshape(n, n_par * n_ch)
    PX = toeplitz_apply(X, rho if kernel is None else kernel)
    G = np.real(np.conj(X).reshape(n, n_par, n_ch).transpose(1, 0, 2).reshape(n_par, -1)
                @ PX.reshape(n, n_par, n_ch).transpose(0, 2, 1).reshape(-1, n_par))
    return np.asarray(0.5 * (G + G.T))


def toeplitz_apply(X: np.ndarray, rho: np.ndarray | ToeplitzKernel) -> np.ndarray:
    """P X for the Hermitian Toeplitz P[k, k+l] = rho_l (conj(rho_l) below the
    diagonal; lags beyond ``rho`` are zero), X (n, p) complex, by FFT.
    ``rho`` may be a :class:`ToeplitzKernel` of it for n lines (its spectrum
    computed once for several products).

    Examples
    --------
    >>> toeplitz_apply(np.ones((3, 1), complex), np.array([1.0, 0.5j]))[:, 0].round(12).tolist()
    [(1+0.5j), (1+0j), (1-0.5j)]
    """
    kernel = rho if isinstance(rho, ToeplitzKernel) else ToeplitzKernel(rho, X.shape[0])
    return kernel.apply(X)


class ToeplitzKernel:
    """The FFT of the convolution kernel of :func:`toeplitz_apply` for ``n``
    lines, computed once for all the products with one correlation ``rho``.

    (P X)_k = sum_d h_d X_(k+d), h_d = rho_d (d >= 0), conj(rho_-d) (d < 0):
    a convolution with the reversed kernel, O(n log n) for any number of
    lags: a circular convolution just long enough that the n outputs kept
    are free of wrap-around (about 2n points for n lags, where
    ``scipy.signal.fftconvolve`` transforms the full linear convolution of
    3n; the same products to rounding) without importing ``scipy.signal``
    (0.7 s of start-up through ``scipy.stats``) and without transforming the
    kernel again for every product (the correlated leverage and information
    of one local fit apply one correlation three times).

    Examples
    --------
    >>> k = ToeplitzKernel(np.array([1.0, 0.5j]), 3)
    >>> k.apply(np.ones((3, 1), complex))[:, 0].round(12).tolist()
    [(1+0.5j), (1+0j), (1-0.5j)]
    """

    def __init__(self, rho: np.ndarray, n: int) -> None:
        self.n = int(n)
        self.lags = min(rho.size, self.n)
        L = self.lags
        self.g = np.concatenate([rho[L - 1 : 0 : -1], np.conj(rho[:L])])
        self._spectra: dict[bool, tuple[int, np.ndarray]] = {}

    def _spectrum(self, complex_result: bool) -> tuple[int, np.ndarray]:
        """FFT length and the kernel's spectrum for a complex or real product."""
        if complex_result not in self._spectra:
            # a circular convolution of n + L - 1 points or more leaves the n
            # outputs kept (from L - 1 on) free of wrap-around: 2n instead of
            # the 3n of the full linear convolution for a window's n lags
            size = fast_fft_len(self.n + self.lags - 1, not complex_result)
            spec = np.fft.fft(self.g, size) if complex_result else np.fft.rfft(self.g, size)
            self._spectra[complex_result] = (size, spec)
        return self._spectra[complex_result]

    def apply(self, X: np.ndarray) -> np.ndarray:
        """P X, X (n, p)."""
        if X.shape[0] != self.n:
            raise ValueError(f"ToeplitzKernel for {self.n} lines applied to {X.shape[0]}")
        complex_result = bool(np.iscomplexobj(self.g) or np.iscomplexobj(X))
        size, spec = self._spectrum(complex_result)
        out: np.ndarray
        if complex_result:
            out = np.fft.ifft(np.fft.fft(X, size, axis=0) * spec[:, None], size, axis=0)
        else:
            out = np.fft.irfft(np.fft.rfft(X, size, axis=0) * spec[:, None], size, axis=0)
        L = self.lags
        return np.asarray(out[L - 1 : L - 1 + self.n])


def correlated_leverage(Q: np.ndarray, J: np.ndarray, Finv: np.ndarray,
                        rho: np.ndarray, kernel: ToeplitzKernel | None = None) -> np.ndarray:
    """Share of the noise variance that a least-squares fit takes up at each
    line when the noise of lines l apart correlates as ``rho``.

    The real-stacked fit (2n rows: real parts, then imaginary parts) has per
    channel c linear terms with the orthonormal basis ``Q`` (2n, K) and poles
    shared by all channels, with the Jacobian ``J`` (2n, n_par, n_ch)
    projected off Q and the inverse Fisher matrix ``Finv`` = (sum_c J_c^T
    J_c)^-1. Its residual of channel c is e_c = (I - Q Q^T) u_c - J_c Finv
    sum_c' J_c'^T u_c'. For circular complex noise u_c of covariance S (the
    Hermitian Toeplitz matrix of ``rho``, halved onto the real and imaginary
    parts), independent between channels::

        diag Cov(e_c) = diag((I - QQ^T) S (I - QQ^T))
                        - 2 diag((I - QQ^T) S J_c Finv J_c^T)
                        + diag(J_c Finv (sum_c' J_c'^T S J_c') Finv J_c^T),

    and the returned (2n, n_ch) is 1 - diag Cov(e_c) / diag(S), which
    :func:`noise_model` takes as ``leverage``. For independent lines
    (rho = [1]) it is the leverage diag(Q Q^T + J_c Finv J_c^T). Noise that is
    correlated over a resonance's width looks like a change of that
    resonance, and the fit takes up more of it. ``kernel``: the
    :class:`ToeplitzKernel` of ``rho`` for n lines, when the caller has it;
    S Q and S J are one FFT product (one kernel spectrum, one transform of
    all their columns).

    Examples
    --------
    >>> Q = np.zeros((8, 1)); Q[:4, 0] = 0.5  # a constant real offset on 4 lines
    >>> J = np.zeros((8, 1, 1))
    >>> correlated_leverage(Q, J, np.eye(1), np.array([1.0]))[:4, 0].tolist()
    [0.25, 0.25, 0.25, 0.25]
    >>> correlated_leverage(Q, J, np.eye(1), np.ones(4))[:4, 0].round(6).tolist()  # all alike
    [1.0, 1.0, 1.0, 1.0]
    """
    n = Q.shape[0] // 2
    # S [Q, J] for real-stacked columns, in one product
    QJ = np.concatenate([Q, J.reshape(2 * n, -1)], axis=1)
    PX = 0.5 * toeplitz_apply(QJ[:n] + 1j * QJ[n:], rho if kernel is None else kernel)
    SX = np.concatenate([PX.real, PX.imag], axis=0)
    SQ = SX[:, : Q.shape[1]]
    SJ = SX[:, Q.shape[1] :]  # (2n, n_par n_ch), columns as J.reshape(2n, -1)
    # per channel c (leading axis): J_c Finv, S J_c off Q; matrix products
    # rather than einsum loops (the same numbers up to rounding)
    JF = np.matmul(J.transpose(2, 0, 1), Finv)  # (n_ch, 2n, n_par)
    d = 0.5 * float(np.real(rho[0]))
    linear = d - 2 * np.sum(Q * SQ, axis=1) + np.sum((Q @ (Q.T @ SQ)) * Q, axis=1)
    SJ_off = (SJ - Q @ (Q.T @ SJ)).reshape(J.shape).transpose(2, 0, 1)
    # sum over channels of J_c^T S J_c
    G = np.tensordot(J, SJ.reshape(J.shape), axes=([0, 2], [0, 2]))
    kept = (linear[:, None] - 2 * np.sum(SJ_off * JF, axis=2).T
            + np.sum(np.matmul(JF, G) * JF, axis=2).T)
    return np.asarray(1.0 - kept / d)


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
