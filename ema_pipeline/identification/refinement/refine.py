"""Pole refinement: a local nonlinear least-squares fit of each selected pole.

:func:`refine_poles` is a variable-projection Gauss-Newton (Levenberg-Marquardt)
fit of the poles, with the linear terms eliminated, that minimises the
noise-weighted squared error sum_c sum_k |e_ck|^2 / (s_c v_k)^2. The noise level
is estimated from the residual of the initial fit
(:func:`ema_pipeline.identification.refinement.uncertainty.noise_model`); the covariance of
the pole parameters (sigma_r, omega_dr) is the sandwich covariance of that fit
with the line correlation of the noise (see
:mod:`ema_pipeline.identification.refinement.uncertainty`). :func:`vp_solve` is that fit on
one local problem (:mod:`ema_pipeline.identification.refinement.local_band`);
:func:`band_sensitivity` repeats the refinement on a narrower band for the
model-choice part of the covariance. The screens that solve the same local
problem once (:func:`~ema_pipeline.identification.refinement.local_fits.quick_significance`)
or with one pole more
(:func:`~ema_pipeline.identification.refinement.local_fits.split_fit`) live in
:mod:`ema_pipeline.identification.refinement.local_fits`.

Why written here: scipy's ``least_squares`` neither eliminates the linear terms
(variable projection) nor shares one projection between channels, which is what
makes the fit cheap enough to run on every mode. The damped step and the
damping schedule are the package's one Levenberg-Marquardt
(:mod:`ema_pipeline.numerics`), shared with the exact added-mass fit.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ema_pipeline.identification.refinement.local_band import (
    WeightedPoleDesign,
    background_columns,
    global_residues,
    local_problem,
    local_sizes,
    pole_jacobian_factors,
)
from ema_pipeline.identification.refinement.uncertainty import (
    ToeplitzKernel,
    correlated_information,
    correlated_leverage,
    exponential_window_correlation,
    noise_model,
    rect_window_correlation,
    residual_correlation,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.numerics import MarquardtDamping, marquardt_step
from ema_pipeline.runner import Mapper, map_each

#: A Levenberg-Marquardt round of :func:`vp_fit` has converged once an
#: accepted step moved no pole parameter (decay rate, damped frequency) by
#: more than this fraction of its own standard deviation (the inverse
#: Fisher matrix's, at the new point). Not looser (measured in the eleventh
#: look of benchmarks/issue52_speed.md): at 0.1 in the second round, fits
#: that creep along a flat valley (steps of 0.02-0.2 sigma that shrink by
#: 0.3 % a step) stopped at once, and a mode of a held-out case
#: (``damping`` seed 503, 1073 Hz) moved 3.9 sigma; at 0.1 in the first
#: round, a fit of FRFs without noise stopped with misfit left, which the
#: noise model took for noise, and a residual search found a pole in it.
STEP_TOL_SIGMA = 1e-3
#: A round also stops once an accepted step lowered its cost (the
#: noise-weighted squared error) by less than this fraction of it: 1e-6 in
#: the first round, whose fit only makes the residual of the second round's
#: noise model (the misfit it leaves is a fraction of that residual's
#: variance far below what its noise model resolves), 1e-8 in the second.
#: FRFs without noise are not stopped early: their cost falls by orders of
#: magnitude at each step until rounding. Split fits that creep along a flat
#: valley for their 20 iterations stop sooner. Measured against 1e-8 in
#: both rounds in the eleventh look of benchmarks/issue52_speed.md (with
#: the numbers of 1e-5 and 1e-4, which moved more: a second round that
#: ends unconverged at ``max_iter`` ends where its start puts it, and a
#: held-out mode, ``damping`` seed 503 at 1073 Hz, moved 0.28 sigma at 1e-5).
COST_REL_TOL = (1e-6, 1e-8)


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


@dataclass(frozen=True)
class VPFit:
    """A finished variable-projection fit of :func:`vp_fit`: what
    :func:`vp_covariance` needs to add the covariance.

    freq_hz : (n,) lines.   Y : (2n, n_ch) real-stacked data.
    bg_r : (2n, K_bg) real-stacked background columns.
    lam : (m,) fitted poles (rad/s).   F : (2m, 2m) Fisher matrix of the last
    accepted step.   u : (2n,) row weights.   inv_s2 : (n_ch,) channel weights.
    n_iter : Levenberg-Marquardt iterations taken.
    solved : the weighted projection (Q, weighted residual, coefficients) of
    ``scaled_solve`` at ``lam`` with the weights ``u``, as the last accepted
    step computed it (``vp_covariance`` takes it instead of solving again:
    the same numbers); None: solved again.
    finished : False where :func:`vp_fit`'s ``go_on`` stopped it before its
    second round's iterations: ``lam`` is then the first round's, ``F`` NaN,
    ``u`` and ``inv_s2`` the second round's weights (so :attr:`noise_std` is
    what the finished fit reports), and :func:`vp_covariance` refuses it;
    also where its ``away`` stopped it in the first round (``lam`` where it
    stopped, the first round's weights).
    """

    freq_hz: np.ndarray
    Y: np.ndarray
    bg_r: np.ndarray
    lam: np.ndarray
    F: np.ndarray
    u: np.ndarray
    inv_s2: np.ndarray
    n_iter: int
    solved: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    finished: bool = True

    @property
    def noise_std(self) -> np.ndarray:
        """(2n, n_ch) the separable noise std s_c / u_k of the fit's weights."""
        return np.sqrt(1.0 / self.inv_s2)[None, :] / self.u[:, None]


def vp_fit(
    freq_hz: np.ndarray,
    Y: np.ndarray,
    poles: np.ndarray,
    background: np.ndarray,
    max_iter: int,
    *,
    go_on: Callable[[VPFit], bool] | None = None,
    away: Callable[[np.ndarray], bool] | None = None,
) -> VPFit:
    """The iterations of :func:`vp_solve` without its covariance.

    Callers that use only the poles or the noise level (the narrower band of
    :func:`band_sensitivity`, the fit without the extra pole of
    :func:`~ema_pipeline.identification.refinement.local_fits.split_fit`, a refinement
    that wandered off) skip the sandwich covariance of :func:`vp_covariance`,
    about half of :func:`vp_solve`'s time with a window's line correlation;
    the poles are the same numbers.

    ``go_on``, when given, is asked once the second round's weights are
    known, with the fit so far (``VPFit.finished`` False: its
    :attr:`~VPFit.noise_std` already the finished fit's); False returns that
    fit without the second round's iterations. A split fit whose residual
    ratio fails its test needs no more
    (:func:`~ema_pipeline.identification.refinement.local_fits.split_fit`).
    ``away``, when given, is asked with the poles after each accepted step of
    the first round; True returns the fit there (``VPFit.finished`` False):
    a refinement that has wandered off needs no more (:func:`refine_poles`).

    Each of the two rounds (weights from the noise model of the start
    poles' residual, then of the first round's) stops after ``max_iter``
    trial steps, when the damping cannot grow any more, or once an accepted
    step moved every pole parameter by less than :data:`STEP_TOL_SIGMA` of
    its standard deviation or lowered the cost by less than a fraction of
    it (:data:`COST_REL_TOL`: 1e-6 in the first round, 1e-8 in the second).
    """
    n = freq_hz.size
    m = poles.size
    jw = 2j * np.pi * freq_hz[:, None]
    bg_r = background_columns(background)
    n_lin = 2 * m + bg_r.shape[1]

    def cost_of(Rw: np.ndarray, inv_s2: np.ndarray) -> float:
        return float((Rw**2 * inv_s2).sum())

    def normal(
        lam: np.ndarray, u: np.ndarray, inv_s2: np.ndarray, fitted: tuple,
        cost: float | None = None,
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """Fisher matrix, gradient and cost at ``lam`` (``fitted``: its fit,
        ``cost``: its cost, if known).

        With the Jacobian of channel c as B W_c (:func:`pole_jacobian_factors`),
        F = sum_c W_c^T (Bp^T Bp) W_c / s_c^2 and g = sum_c W_c^T Bp^T r_c / s_c^2,
        Bp the row-weighted B projected off the linear terms: one projection
        of 2m columns, not of 2m per channel."""
        Qm, Rw, X = fitted
        B, W = pole_jacobian_factors(jw, lam, X)
        Bw = B * u[:, None]
        Bp = Bw - Qm @ (Qm.T @ Bw)
        Ws = W * inv_s2[:, None, None]
        # sum over channels and rows as one product (np.tensordot's own
        # reshape and dot, without its per-call overhead)
        F = Ws.reshape(-1, Ws.shape[2]).T @ ((Bp.T @ Bp) @ W).reshape(-1, Ws.shape[2])
        g = np.einsum("cia,ic->a", Ws, Bp.T @ Rw)
        return 0.5 * (F + F.T), g, cost_of(Rw, inv_s2) if cost is None else cost

    def lam_of(th: np.ndarray) -> np.ndarray:
        return -th[0::2] + 1j * th[1::2]

    def stopped(n_iter: int) -> VPFit:
        """The fit so far, not finished (``go_on`` or ``away`` stopped it):
        the poles and weights as they are now, no Fisher matrix."""
        return VPFit(freq_hz=freq_hz, Y=Y, bg_r=bg_r, lam=lam,
                     F=np.full((2 * m, 2 * m), np.nan), u=u, inv_s2=inv_s2,
                     n_iter=n_iter, finished=False)

    theta = np.empty(2 * m)
    theta[0::2] = -poles.real
    theta[1::2] = poles.imag
    it_total = 0
    u = np.ones(2 * n)
    # the design with unit weights (the start of each round): the
    # pole-independent background formed once (WeightedPoleDesign)
    unweighted = WeightedPoleDesign(freq_hz, bg_r, u)
    tiny = np.finfo(float).tiny
    lam = lam_of(theta)
    for _round in range(2):
        _, R0, _ = unweighted.solve(lam, Y)
        std = np.asarray(noise_model(R0, Y, n_lin))
        # separable approximation std_ck ~ s_c u_k (one projection for all channels)
        std2 = std**2
        s2 = np.mean(std2, axis=0)
        inv_s2 = 1.0 / np.maximum(s2, tiny)
        u = 1.0 / np.sqrt(np.mean(std2 * inv_s2[None, :], axis=1))
        if _round == 1 and go_on is not None:
            so_far = stopped(it_total)
            if not go_on(so_far):
                return so_far
        Yw = Y * u[:, None]
        design = WeightedPoleDesign(freq_hz, bg_r, u)
        fit = design.solve
        solved = fit(lam, Yw)  # the fit at theta with the final weights
        F, g, cost = normal(lam, u, inv_s2, solved)
        damping = MarquardtDamping(mu=1e-3, mu_min=1e-9, mu_max=1e6)
        n_accepted = 0
        it_round = 0
        for _it in range(max_iter):
            it_round += 1
            try:
                step = marquardt_step(F, g, damping.mu, floor=tiny)
            except np.linalg.LinAlgError:
                break
            trial = theta + step
            # min > 0 is all(> 0), NaN included
            lam_t = lam_of(trial)
            fitted = fit(lam_t, Yw) if trial[0::2].min() > 0 else None
            cost_t = np.inf if fitted is None else cost_of(fitted[1], inv_s2)
            if fitted is not None and cost_t < cost:
                theta, solved, lam = trial, fitted, lam_t
                n_accepted += 1
                F, g, cost_new = normal(lam, u, inv_s2, fitted, cost_t)
                sd = np.sqrt(1.0 / np.maximum(F.diagonal(), 1e-300))
                done = ((cost - cost_new) < COST_REL_TOL[_round] * cost
                        or bool((np.abs(step) < STEP_TOL_SIGMA * sd).all()))
                cost = cost_new
                damping.accepted()
                if _round == 0 and away is not None and away(lam):
                    return stopped(it_total + it_round)
                if done:
                    break
            elif not damping.rejected():
                break
        it_total += it_round
        if n_accepted == 0:
            # the poles did not move: the second round would start from the
            # same residual, hence the same weights, and repeat this round
            # step by step (the fits of max_iter=0, a wandered-off refinement's
            # start pole): its iterations are counted, not taken
            it_total += it_round * (1 - _round)
            break
    return VPFit(freq_hz=freq_hz, Y=Y, bg_r=bg_r, lam=lam, F=F, u=u, inv_s2=inv_s2,
                 n_iter=it_total, solved=solved)


def decay_determined(pole: np.ndarray, cov: np.ndarray,
                     *, thresholds: SelectionThresholds) -> np.ndarray:
    """True where the decay rate sigma = -Re(pole) is determined:
    std(sigma) / sigma < ``thresholds.max_rel_decay_std``; ``cov`` (n, 2, 2)
    is the covariance of (Re, Im) of each pole, in (rad/s)^2.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> pole = np.array([-2.0 + 600j, -2.0 + 900j])
    >>> cov = np.array([np.diag([0.1, 0.1]), np.diag([2.5, 2.5])])  # std 0.32 and 1.6 rad/s
    >>> decay_determined(pole, cov, thresholds=th).tolist()
    [True, False]
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.sqrt(np.asarray(cov)[:, 0, 0]) / np.abs(np.real(pole))
    limit = thresholds.max_rel_decay_std
    return np.asarray(np.nan_to_num(rel, nan=np.inf) < limit)


def fisher_undetermined(pole: complex, var_decay: float, *,
                        thresholds: SelectionThresholds) -> bool:
    """Whether the decay rate of ``pole`` (rad/s) is undetermined
    (:func:`decay_determined` false) whatever the sandwich covariance of
    :func:`vp_covariance` says, from ``var_decay``, the inverse Fisher
    matrix's variance of it ((rad/s)^2): that sandwich's diagonal is raised
    to the inverse Fisher matrix's where it falls below, so a decay rate the
    inverse Fisher matrix leaves undetermined stays so. A margin of 1e-9 of
    the limit covers the rounding of that raise; a variance that is not
    positive and finite decides nothing (False).

    Examples
    --------
    >>> th = SelectionThresholds()  # max_rel_decay_std 0.2
    >>> [fisher_undetermined(-2.0 + 600j, v, thresholds=th) for v in (0.01, 0.25, np.nan)]
    [False, True, False]
    """
    if not (np.isfinite(var_decay) and var_decay > 0):
        return False
    limit = thresholds.max_rel_decay_std * (1 + 1e-9)
    return bool(np.sqrt(var_decay) >= limit * abs(pole.real))


def fisher_inverse(F: np.ndarray) -> np.ndarray:
    """The inverse of a Fisher matrix ``F`` (the pseudo-inverse where it is
    singular): the covariance of independent lines, and the bread of the
    sandwich of :func:`vp_covariance`.

    Examples
    --------
    >>> fisher_inverse(np.diag([4.0, 0.0])).tolist()
    [[0.25, 0.0], [0.0, 0.0]]
    """
    try:
        return np.linalg.inv(F)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(F)


def vp_covariance(
    fit: VPFit,
    window_tau_s: float | None = None,
    force_window_s: float | None = None,
) -> np.ndarray:
    """The sandwich covariance (2m, 2m) of (sigma_r, omega_dr) of a :func:`vp_fit`
    (see :func:`vp_solve`); a fit that is not finished
    (``VPFit.finished``) raises ValueError."""
    if not fit.finished:
        raise ValueError("vp_covariance: the fit was stopped before its last round")
    freq_hz, Y, lam, u, inv_s2 = fit.freq_hz, fit.Y, fit.lam, fit.u, fit.inv_s2
    n = freq_hz.size
    jw = 2j * np.pi * freq_hz[:, None]
    n_lin = 2 * lam.size + fit.bg_r.shape[1]
    Finv = fisher_inverse(fit.F)
    Qm, Rw, X = (WeightedPoleDesign(freq_hz, fit.bg_r, u).solve(lam, Y * u[:, None])
                 if fit.solved is None else fit.solved)
    sq = np.sqrt(inv_s2)
    # the projected, weighted Jacobian from its factors (pole_jacobian_factors):
    # 2m columns projected instead of 2m per channel
    B, W = pole_jacobian_factors(jw, lam, X)
    Bw = B * u[:, None]
    Bp = Bw - Qm @ (Qm.T @ Bw)
    Ws = W * sq[:, None, None]
    # Jp[:, :, c] = Bp Ws_c and its leverage diag(Jp_c Finv Jp_c^T) =
    # diag(Bp (Ws_c Finv Ws_c^T) Bp^T): matrix products, not einsum loops
    # (14x faster at 30 channels, the same numbers up to rounding)
    Jp = np.matmul(Bp, Ws).transpose(1, 2, 0)
    # the noise level of the covariance (the weights above stay as they are):
    # from this weighted fit's residual, each line's share corrected by its
    # leverage, that of the linear terms plus that of the poles
    M = np.matmul(np.matmul(Ws, Finv), Ws.transpose(0, 2, 1))
    lev = np.sum(Qm**2, axis=1)[:, None] + np.sum(np.matmul(Bp, M) * Bp, axis=2).T
    df = freq_hz[1] - freq_hz[0]
    # the exponential window's correlation of the additive noise, when known
    rho_w = (exponential_window_correlation(window_tau_s * df, n)
             if window_tau_s is not None and window_tau_s > 0 else None)
    if rho_w is not None:
        # it spans about 1/(pi tau df) lines, as wide as a resonance that the
        # window dominates: the fit takes up more of that noise than lev
        # says. The part proportional to |H| (with a force window) keeps lev.
        kernel_w = ToeplitzKernel(rho_w, n)  # one spectrum for the three products
        lev_w = correlated_leverage(Qm, Jp, Finv, rho_w, kernel_w)
        if force_window_s:
            _, frac_b = noise_model(Rw / u[:, None], Y, n_lin, with_fraction=True, leverage=lev)
            beta = np.concatenate([frac_b, frac_b], axis=0)
            lev = beta * lev + (1 - beta) * lev_w
        else:
            lev = lev_w
    std, frac_b = noise_model(Rw / u[:, None], Y, n_lin, with_fraction=True, leverage=lev)
    Rw = Rw * sq[None, :]
    # the weights are separable (std_ck ~ s_c u_k); the weighted noise keeps
    # the ratio w of the modelled std to that approximation as its std
    w = (std[:n] * np.sqrt(inv_s2)[None, :] * u[:n, None]).astype(float)
    Jc = (Jp[:n] + 1j * Jp[n:]) * w[:, None, :]  # (n, 2m, n_ch)
    if rho_w is not None:
        # the windows' own correlation, in full (an estimate from the residual
        # is truncated and tapered): the additive part of the noise is that of
        # the exponential window; the part proportional to |H| (force noise,
        # dH = -H dF/F) that of the force window
        beta = frac_b if force_window_s else np.zeros_like(frac_b)
        G = correlated_information(Jc * np.sqrt(1 - beta)[:, None, :], rho_w, kernel_w)
        if force_window_s:
            Hm = Y - Rw / sq[None, :] / u[:, None]  # the fitted model
            h = Hm[:n] + 1j * Hm[n:]
            ph = np.conj(h) / np.maximum(np.abs(h), 1e-300)
            V = Jc * (np.sqrt(beta) * ph)[:, None, :]
            G = G + correlated_information(V, rect_window_correlation(force_window_s * df, n))
    else:
        rho = residual_correlation((Rw[:n] + 1j * Rw[n:]) / w)
        G = correlated_information(Jc, rho)
    cov = Finv @ G @ Finv
    # a truncated correlation estimate must never make the fit look better
    # than independent lines would
    return np.asarray(cov + np.diag(np.maximum(np.diag(Finv) - np.diag(cov), 0.0)))


def vp_solve(
    freq_hz: np.ndarray,
    Y: np.ndarray,
    poles: np.ndarray,
    background: np.ndarray,
    max_iter: int,
    window_tau_s: float | None = None,
    force_window_s: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Variable-projection Levenberg-Marquardt fit of ``poles`` to Y (2n, n_ch).

    Model per channel: sum_r a_r/(jw - l_r) + conj + background @ c (complex c).
    Noise: independent per line with the variance model of :func:`noise_model`,
    estimated from the residual of the start poles and once more after a first
    weighted solve, approximated as separable, std_ck = s_c u_k, so that one
    projection serves all channels. The noise level of the covariance is
    estimated once more at the end, from the final weighted residual with the
    leverage of each line (:func:`noise_model`). Returns the poles, the inverse Fisher matrix of
    (sigma_r, omega_dr), the noise std (2n, n_ch) and the iterations: the fit
    of :func:`vp_fit` and the covariance of :func:`vp_covariance`.
    """
    fit = vp_fit(freq_hz, Y, poles, background, max_iter)
    cov = vp_covariance(fit, window_tau_s, force_window_s)
    return fit.lam, cov, fit.noise_std, fit.n_iter


def refine_poles(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    *,
    half_width: float | None = None,
    max_iter: int = 10,
    quantity: str | None = "accelerance",
    window_tau_s: float | None = None,
    force_window_s: float | None = None,
    thresholds: SelectionThresholds,
    map_: Mapper | None = None,
    modes: Sequence[int] | np.ndarray | None = None,
    memo: FitMemo | None = None,
    decay_screen: bool = False,
) -> RefinedPoles:
    """Local nonlinear least-squares refinement of each pole, with its covariance.

    For mode r the lines within f_r +- ``half_width`` half-power bandwidths
    (sigma_r / pi Hz; default ``thresholds.local_half_width``; at least
    ``thresholds.local_min_lines`` lines, at most 20 % of f_r) are
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
    gets the covariance evaluated there (``max_shift`` is
    ``thresholds.refine_max_shift``). A fit whose pole, at a step of the
    first of its two weighting rounds, lies further than
    ``thresholds.refine_stop_shift`` times that reach stops there, as
    wandered off (the residual peaks of the noise that the final tests
    screen).

    The modes outside a local problem reach into its band with tails that a
    quadratic does not follow (a heavily damped neighbour, dense modes): with
    ``quantity`` (not ``None``) one global LSFD of all poles (with the residual
    terms of that quantity) is computed first, and the terms of the modes that
    are not members of the local problem are subtracted from its data.

    Parameters
    ----------
    freq_hz : (n_freq,) Hz.   H : (n_ch, n_freq) complex FRFs (any quantity).
    poles : (n_modes,) identified poles (rad/s, Im > 0).
    map_ : a :class:`~ema_pipeline.runner.Mapper` of worker processes: the
        modes' local fits (independent of each other) shared out among them
        from :data:`PARALLEL_MIN_MODES` modes on; the same numbers.
    modes : the indices of the poles to refine (default all); the others keep
        their start pole with a NaN covariance. Each mode's local fit is its
        own (the other poles are its start values), so a refined mode has the
        numbers it has when all are refined.
    memo : the local fits of an earlier refinement of the same ``freq_hz`` and
        ``H`` (:class:`FitMemo`, one per data): where it holds the same
        poles and settings, its global LSFD and the modes it fitted are
        taken, not computed again (the same numbers); it then holds this
        refinement's.
    decay_screen : for a caller that asks only whether each decay rate is
        determined (:func:`decay_determined`; the final tests' screen of new
        candidates): a mode whose decay rate the inverse Fisher matrix alone
        leaves undetermined (:func:`fisher_undetermined`) gets that matrix's
        block as its covariance, and the sandwich of :func:`vp_covariance`,
        never below it on the diagonal, is not computed. The poles and every
        verdict of :func:`decay_determined` are those without it; such fits
        do not stay in ``memo``. On a simulated paper file the residual
        peaks of the noise are such modes (11 sandwiches of 4 ms in 12 files).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(80.0, 120.0, 401)
    >>> lam = np.array([-2.0 + 2j * np.pi * 95.0, -2.0 + 2j * np.pi * 105.0])
    >>> jw = 2j * np.pi * f
    >>> H = sum(1 / (jw - p) + 1 / (jw - p.conj()) for p in lam)[None]
    >>> H = H + 1e-6 * np.random.default_rng(0).standard_normal(H.shape)
    >>> start = lam * (1 + 1e-4)
    >>> memo = FitMemo()
    >>> one = refine_poles(f, H, start, quantity="receptance", thresholds=th, modes=[1], memo=memo)
    >>> both = refine_poles(f, H, start, quantity="receptance", thresholds=th, memo=memo)
    >>> memo.taken, bool(both.pole[1] == one.pole[1])
    (1, True)
    >>> (np.abs(both.pole - lam) / np.abs(lam.real) < 0.01).tolist()
    [True, True]
    """
    th = thresholds
    half_width = th.local_half_width if half_width is None else half_width
    return _refine(freq_hz, H, poles, half_width, max_iter, quantity, window_tau_s,
                   force_window_s, th, covariance=True, map_=map_, modes=modes, memo=memo,
                   decay_screen=decay_screen)


class FitMemo:
    """The global LSFD and the local fits of the last refinement
    (:func:`refine_poles` with ``memo``) of one data set, for the next
    refinement of the same poles with the same settings: the final tests
    ask first which new candidates can pass on their own local fits (the
    fits of ``modes``), then refine all the candidates together, and each
    mode's local fit is its own, so those fits are taken, not made again
    (the pyFRF recording: two fits of 35 ms and the global LSFD of 40 poles
    over 4487 lines). A refinement of other poles or settings starts it
    afresh. ``taken`` counts the fits taken (for tests and diagnostics).

    Examples
    --------
    >>> FitMemo().taken
    0
    """

    def __init__(self) -> None:
        self.key: tuple | None = None
        self.residues: np.ndarray | None = None
        self.fits: dict[int, tuple | None] = {}
        self.taken = 0

    def residues_for(self, key: tuple, compute: Callable[[], np.ndarray | None]
                     ) -> np.ndarray | None:
        """The global LSFD's residues of the refinement ``key`` (poles and
        settings): the memo's when it holds that key, else ``compute()``,
        and the memo then holds ``key`` with no fits."""
        if key != self.key:
            self.key, self.residues, self.fits = key, compute(), {}
        return self.residues


#: Refinements of this many modes or more share their local fits out among
#: worker processes (fewer: the round trips cost more than they save).
PARALLEL_MIN_MODES = 6


@dataclass(frozen=True)
class LocalFits:
    """What one local fit of :func:`_refine` needs besides the mode's index."""

    freq_hz: np.ndarray
    H: np.ndarray
    poles: np.ndarray
    a_all: np.ndarray | None
    half_width: float
    max_iter: int
    window_tau_s: float | None
    force_window_s: float | None
    thresholds: SelectionThresholds
    covariance: bool
    #: only whether each decay rate is determined is asked (:func:`refine_poles`'s
    #: ``decay_screen``)
    decay_screen: bool = False

    def fit(self, r: int) -> tuple[complex, np.ndarray, np.ndarray, np.ndarray, int, bool] | None:
        """Mode ``r``'s refined pole, covariance (2, 2), noise std (n_ch,),
        band (2,), iterations and whether the covariance is the sandwich of
        :func:`vp_covariance` (False: the inverse Fisher matrix's block of a
        ``decay_screen``, or NaN without ``covariance``); None when it has
        no local problem."""
        th = self.thresholds
        freq_hz, H, poles = self.freq_hz, self.H, self.poles
        df = freq_hz[1] - freq_hz[0]
        local = local_problem(freq_hz, H, poles, r, self.half_width, th.local_min_lines,
                              self.a_all, thresholds=th)
        if local is None:
            return None
        f, Y, members, background, k, band = local
        reach = th.refine_max_shift * abs(poles[r].real) + 2 * np.pi * df
        stop = th.refine_stop_shift * reach

        def far_off(lam: np.ndarray) -> bool:
            # wandered off in the first round: no more steps (a NaN reach,
            # refine_max_shift inf, never stops a fit)
            return bool(abs(lam[k] - poles[r]) > stop)

        fit = vp_fit(f, Y, poles[members], background, self.max_iter, away=far_off)
        lam_r = fit.lam[k]
        if abs(lam_r - poles[r]) > reach:
            # refinement wandered off: keep the start pole, covariance there
            fit = vp_fit(f, Y, poles[members], background, 0)
            lam_r = poles[r]
        cov = np.full((2, 2), np.nan)
        sandwich = False
        if self.covariance:
            block = slice(2 * k, 2 * k + 2)
            fisher = fisher_inverse(fit.F)[block, block] if self.decay_screen else None
            if fisher is not None and fisher_undetermined(complex(lam_r), fisher[0, 0],
                                                          thresholds=th):
                cov = fisher  # the sandwich cannot make this decay rate determined
            else:
                cov = vp_covariance(fit, self.window_tau_s, self.force_window_s)[block, block]
                sandwich = True
        noise = np.sqrt(np.mean(fit.noise_std**2, axis=0))
        return complex(lam_r), cov, noise, np.asarray(band, float), int(fit.n_iter), sandwich

    def fit_all(self, modes: list[int]) -> list[tuple | None]:
        """:meth:`fit` of each of ``modes`` (one worker's share)."""
        return [self.fit(r) for r in modes]


def _refine(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    half_width: float,
    max_iter: int,
    quantity: str | None,
    window_tau_s: float | None,
    force_window_s: float | None,
    th: SelectionThresholds,
    covariance: bool,
    map_: Mapper | None = None,
    modes: Sequence[int] | np.ndarray | None = None,
    memo: FitMemo | None = None,
    decay_screen: bool = False,
) -> RefinedPoles:
    """:func:`refine_poles`; without ``covariance`` the poles only (cov NaN):
    :func:`band_sensitivity` needs no covariance of its narrower fits, which
    saves the sandwich of :func:`vp_covariance` on every mode. A refinement
    that wanders off gets the covariance of its start pole only, not also
    that of the discarded fit."""
    freq_hz = np.asarray(freq_hz, dtype=float)
    H = np.asarray(H)
    n_ch = H.shape[0]
    m = poles.size
    out = poles.copy()
    cov = np.full((m, 2, 2), np.nan)
    noise = np.full((m, n_ch), np.nan)
    bands = np.zeros((m, 2))
    iters = np.zeros(m, dtype=int)
    def residues() -> np.ndarray | None:
        return global_residues(freq_hz, H, poles, quantity)

    known: dict[int, tuple | None] = {}
    if memo is None:
        a_all = residues()
    else:
        key = (poles.tobytes(), half_width, max_iter, quantity, window_tau_s, force_window_s,
               th, covariance)
        a_all = memo.residues_for(key, residues)
        known = memo.fits
    fits = LocalFits(freq_hz, H, poles, a_all, half_width, max_iter, window_tau_s,
                     force_window_s, th, covariance, decay_screen)
    todo = list(range(m)) if modes is None else [int(r) for r in modes]
    new = [r for r in todo if r not in known]
    cost = local_sizes(freq_hz, poles, half_width, th.local_min_lines, thresholds=th)[new].tolist()
    known.update(zip(new, map_each(map_, fits.fit_all, new, PARALLEL_MIN_MODES, cost),
                     strict=True))
    if memo is not None:
        memo.taken += len(todo) - len(new)
    for r in todo:
        res = known[r]
        if res is not None:
            out[r], cov[r], noise[r], bands[r], iters[r], sandwich = res
            if covariance and not sandwich:  # a screen's: not for a refinement to take
                del known[r]
    return RefinedPoles(pole=out, cov=cov, noise_std=noise, band_hz=bands, n_iter=iters)


def local_residues(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    a_all: np.ndarray,
    *,
    thresholds: SelectionThresholds,
) -> tuple[np.ndarray, np.ndarray]:
    """Each mode's residues from its own local band: a local LSFD.

    A global LSFD (:func:`~ema_pipeline.identification.refinement.lsfd.lsfd`)
    over a wide band fits every mode's residues to all the band's lines: a
    low mode's terms reach far beyond its resonance (their tail falls off as
    1/w only), so the misfit of lines far from it -- modes outside the
    band that two residual terms follow only roughly, the noise of lines
    where |H| is large -- goes partly into its residues, and its shape then
    depends on the band (the measured beam's first mode: MAC 0.89 between
    the whole band and 10-130 Hz, MPC 0.73 against 0.93). Here mode r's
    residues come from the local problem of the pole refinement
    (:func:`~ema_pipeline.identification.refinement.local_band.local_problem`:
    its lines within ``thresholds.local_half_width`` half-power bandwidths,
    its member poles, a quadratic background per channel, the other modes'
    terms of the global residues ``a_all`` subtracted), solved linearly at
    the given poles with the noise weights of :func:`vp_fit`: only the
    lines that carry the mode decide its residues.

    Parameters
    ----------
    freq_hz : (n_freq,) Hz.   H : (n_ch, n_freq) complex FRFs (any quantity).
    poles : (n_modes,) complex, Im > 0, rad/s.
    a_all : (n_modes, n_ch) complex  the global LSFD's residues (of the FRFs'
        quantity), kept for a mode without a local problem (fewer than 12
        lines in its band).

    Returns
    -------
    a : (n_modes, n_ch) complex residues of the FRFs' quantity.
    local : (n_modes,) bool  whether each came from its local band.

    Examples
    --------
    Modes at 20 and 150 Hz with real shapes on 6 channels, and a strong one
    at 300 Hz just above the band (1-280 Hz), which the residual terms follow
    only roughly: the global fit's shape of the 20 Hz mode has MAC 0.84 with
    the truth and MPC 0.49, the local one is exact.

    >>> th = SelectionThresholds()
    >>> from ema_pipeline.identification.refinement.lsfd import lsfd, mpc
    >>> from ema_pipeline.modal import mac_pairs
    >>> f = np.arange(1.0, 281.0)
    >>> lam = 2j * np.pi * np.array([20.0, 150.0, 300.0]) - np.array([0.6, 3.0, 3.0])
    >>> a = 1j * np.random.default_rng(0).standard_normal((3, 6)) * [[1], [30], [300]]
    >>> jw = 2j * np.pi * f[:, None]
    >>> H = (1 / (jw - lam) @ a + 1 / (jw - lam.conj()) @ a.conj()).T  # (6, 280)
    >>> a_all = lsfd(f, H, lam[:2], "receptance").a
    >>> a_loc, local = local_residues(f, H, lam[:2], a_all, thresholds=th)
    >>> mac_pairs(a_all.T, a[:2].T).round(2), mpc(a_all.T).round(2)
    (array([0.84, 1.  ]), array([0.49, 1.  ]))
    >>> mac_pairs(a_loc.T, a[:2].T).round(6), bool(local.all())
    (array([1., 1.]), True)
    """
    th = thresholds
    freq_hz = np.asarray(freq_hz, dtype=float)
    a = np.array(a_all, dtype=complex, copy=True)
    local = np.zeros(poles.size, dtype=bool)
    for r in range(poles.size):
        problem = local_problem(freq_hz, H, poles, r, th.local_half_width, th.local_min_lines,
                                a_all, thresholds=th)
        if problem is None:
            continue
        f, Y, members, background, k, _ = problem
        # the noise-weighted linear fit at the given poles (no iteration)
        solved = vp_fit(f, Y, poles[members], background, 0).solved
        if solved is None:  # pragma: no cover - vp_fit always solves once
            continue
        X = solved[2]
        a[r] = X[2 * k] + 1j * X[2 * k + 1]
        local[r] = True
    return a, local


def band_sensitivity(
    freq_hz: np.ndarray,
    H: np.ndarray,
    poles: np.ndarray,
    *,
    half_width: float | None = None,
    quantity: str | None = "accelerance",
    window_tau_s: float | None = None,
    force_window_s: float | None = None,
    thresholds: SelectionThresholds,
    map_: Mapper | None = None,
) -> np.ndarray:
    """Model-choice covariance of refined poles, (n_modes, 2, 2) in (sigma, omega_d).

    The local fit of :func:`refine_poles` (at +-``local_half_width`` half-power bandwidths)
    stands for everything outside its members by a quadratic background and
    the subtracted terms of a global LSFD; where that is not exact (modes just
    outside the band, heavily damped neighbours) the pole carries an error the
    residual does not show. It is estimated as the change d of (sigma,
    omega_d) when the fit is repeated on the narrower band of ``half_width``
    half-power bandwidths (default half of ``thresholds.local_half_width``;
    starting at ``poles``, the refined poles); half of
    it is taken as the standard deviation of the model choice (the two fits
    bracket the error, and d also holds the extra noise of the narrower fit),
    returned as d d^T / 4, to be added to the noise covariance. Modes whose
    local band is set by its minimum number of lines get 0. ``quantity``,
    ``window_tau_s``, ``force_window_s`` and ``map_`` as in :func:`refine_poles`.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(50.0, 150.0, 801)
    >>> lam = np.array([-3.0 + 2j * np.pi * 100.0])
    >>> jw = 2j * np.pi * f
    >>> H = (1 / (jw - lam) + 1 / (jw - lam.conj()))[None] + 1e-4 * jw[None] ** 0
    >>> shift = band_sensitivity(f, H, lam, quantity="receptance", thresholds=th)
    >>> float(np.abs(shift).max()) < 1e-6
    True
    """
    th = thresholds
    half_width = th.local_half_width / 2 if half_width is None else half_width
    # the poles only: the narrower fit's covariance is not used
    other = _refine(freq_hz, H, poles, half_width, 10, quantity, window_tau_s, force_window_s,
                    th, covariance=False, map_=map_)
    d = np.stack([other.pole.real - poles.real, poles.imag - other.pole.imag], axis=1)
    d = np.nan_to_num(d)
    return d[:, :, None] * d[:, None, :] / 4.0
