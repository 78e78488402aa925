"""Local added mass by an exact (nonlinear) fit of the FE eigenvalues: method ``exact``.

The paper's local added mass (eq. 14-20) is a first-order expansion: it assumes
the genuine mode shapes and a linear change of the eigenvalues, and therefore
underestimates large added masses (0.3 on the tip element comes back as about
0.275 with the ``block`` method). Here the same unknowns are fitted so that
the FE model's *eigenvalues themselves* reproduce the measured frequency
ratios; nothing is linearised except the covariance.

Definitions (comparable with the paper's block method, eq. 15):

* ``delta_m[j]`` and ``delta_k[j]`` (ratios, not percent) scale the mass and
  stiffness matrices of the fine FE elements inside measurement element
  ``elements[j]`` (1-based, element 10 = tip) by ``1 + delta``:
  M(p) = M + sum_j delta_m_j M_j, K(p) = K + sum_j delta_k_j K_j (eq. 15 with
  the unreduced element matrices). The forward model, the beam so modified,
  is :mod:`ema_pipeline.added_mass.modified_beam`. This is the quantity the paper's block and the
  projected methods estimate to first order: on exact frequencies of a beam
  with delta_m = 0.05 / 0.3 / 0.6 / 1.0 on the tip they return 0.054 / 0.275 /
  0.473 / 0.671 (block) and 0.048 / 0.249 / 0.424 / 0.592 (projected); the
  first-order start below gives 0.049 / 0.263 / 0.471 / 0.689; ``exact`` the
  truth to 1e-7.
* Data: y_r = (f_wr / f_r)^2 with f_r, f_wr the measured *undamped* natural
  frequencies (eq. 4 applied by the caller, e.g. ``ModalParameters.fn_hz``)
  of the genuine and the modified configuration, mode r. The fit solves
  lambda_r(p) / lambda_r(0) = y_r, r = 1..n_modes (least squares), with
  lambda_r(0) the eigenvalues of the given (updated) beam. Using ratios cancels
  the updated model's remaining error in the absolute frequencies: for a
  uniform beam without point masses the ratio does not depend on E, rho, h or L
  at all (every eigenvalue scales with E h^2 / (rho L^4), see
  :mod:`ema_pipeline.fe`), so the update matters only through point masses.
  FE mode r is paired with measured mode r; a NaN modified frequency (mode not
  found) drops that mode.
* Solver: Levenberg-Marquardt (Marquardt's diagonal scaling) on the residuals
  r_r(p) = lambda_r(p) / lambda_r(0) - y_r, with the analytic eigenvalue
  derivatives d lambda_r / d p = phi_r^T (dK/dp - lambda_r dM/dp) phi_r
  (phi_r mass-normalised w.r.t. M(p)), i.e. d lambda_r / d delta_m_j =
  -lambda_r phi_r^T M_j phi_r and d lambda_r / d delta_k_j = phi_r^T K_j phi_r.
  Start: the first-order answer (one Gauss-Newton step from p = 0: eq. 14-20 on
  the full FE model, which is the ``projected`` method with
  Delta_lambda_r = lambda_r(0) (y_r - 1)), or zero, or a given vector (e.g. the
  ``block`` answer).
* Uncertainty (``delta_m_std``): linearised propagation of the frequencies'
  standard deviations through the fit at the solution,
  Cov_p = J^+ Cov_y J^+T with J the (weighted) sensitivity matrix,
  J^+ = (J^T W J)^-1 J^T W, Cov_y = diag(sigma_y^2),
  sigma_y_r = 2 y_r sqrt((sigma_r / f_r)^2 + (sigma_wr / f_wr)^2) (genuine and
  modified frequencies independent). Not sampled. ``delta_m_std_misfit`` is the
  a-posteriori alternative s^2 (J^T W J)^-1 from the fit residual (only when
  there are more modes than unknowns): it also covers model-form error.
* Identifiability: the sensitivity matrix S = d(lambda_r / lambda_r(0)) / d p
  (dimensionless, unweighted, all unknowns are fractions so columns share one
  scale) is checked at the start and at the solution. The fit is refused with
  :class:`DataError` when there are more unknowns than usable modes, when S is
  rank deficient (singular values below max(S.shape) * eps * s_max), or when
  cond(S) = s_max / s_min exceeds ``max_condition`` (default
  :data:`MAX_CONDITION` = 100). Rationale for 100: the weakest combination of
  unknowns then moves the frequency ratios 100 times less than the strongest;
  identified frequencies carry relative errors of 1e-4..1e-3 and the ratios
  twice that, so beyond 100 that combination is uncertain by 0.1 or more, the
  size of the effect sought. For the paper's beam (100 elements, 10
  measurement elements): mass of the tip element alone, cond 1; mass of
  elements 9 and 10, cond 4.5 (4 modes); mass and stiffness of the tip
  element, cond 717 / 108 / 34 / 15 / 8.5 with 2 / 3 / 4 / 5 / 6 modes (the
  tip's curvature is small, so its stiffness hardly moves the frequencies);
  mass and stiffness of elements 9 and 10, cond 407 / 83 / 27 with 4 / 5 / 6
  modes. ``delta_m_std`` remains the honest measure for a given noise level.

Why written here: the fit needs one eigen-solution per iteration that gives
both the residuals and the analytic Jacobian, and steps that would make
1 + delta <= 0 (negative mass) must be rejected; scipy's MINPACK
Levenberg-Marquardt cannot bound the parameters and its trust-region variant
evaluates residuals and Jacobian separately. The loop is twenty lines (its
damped step and damping schedule are :mod:`ema_pipeline.numerics`, shared with
the pole refinement of the identification); the
eigen-solver is the project's :func:`ema_pipeline.fe.lowest_modes` (banded
subspace iteration). Measured (200 DOF, 2 shared cores, single-thread BLAS,
best of 20): one solve of 4 modes 3.8 ms banded against 2.7 ms for dense
``scipy.linalg.eigh``; the dense solver is off by about 6e-7 relative on
lambda_1 (the banded one reproduces ratios to 1e-9..1e-8), so the banded one
is kept. A fit takes 3-5 solves: about 50 ms (one element) to 80 ms (two
elements, or mass and stiffness), the block matrices of the modified
elements being updated in place (no dense 200 x 200 sums per iteration).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Literal

import numpy as np

from ema_pipeline import fe
from ema_pipeline.added_mass.exact_result import (
    EXACT_METHOD,
    MAX_CONDITION,
    ExactAddedMassResult,
    ExactOutcome,
    UnidentifiableError,
)
from ema_pipeline.added_mass.modal import (
    AddedMassResult,
    modal_added_mass_all,
    replace_configuration,
)
from ema_pipeline.added_mass.modified_beam import ElementModification
from ema_pipeline.data import Beam, DataError, ModalParameters
from ema_pipeline.numerics import MarquardtDamping, marquardt_step

__all__ = [
    "EXACT_METHOD",
    "MAX_CONDITION",
    "ExactAddedMassResult",
    "ExactOutcome",
    "UnidentifiableError",
    "exact_added_mass_all",
    "exact_added_mass",
]


Start = Literal["first_order", "zero"]
Weighting = Literal["equal", "inverse_variance"]


# ---------------------------------------------------------------------------
# the exact fit
# ---------------------------------------------------------------------------
def _as_1d(name: str, value: Sequence[float] | np.ndarray, n: int) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1 or arr.size < n:
        raise DataError(f"{name} must be a 1-D array with at least {n} entries, got {arr.shape}")
    return arr[:n]


def _sensitivity(
    mod: ElementModification, omega2: np.ndarray, shapes: np.ndarray, lam0: np.ndarray, stiff: bool
) -> np.ndarray:
    """d(lambda_r / lambda_r(0)) / d[delta_m, delta_k]: (p, n_p), mass-normalised shapes."""
    mass = mod.element_quadratic(shapes, "M")
    cols = [-(omega2 / lam0)[:, None] * mass]
    if stiff:
        cols.append(mod.element_quadratic(shapes, "K") / lam0[:, None])
    return np.hstack(cols)


def _svd_check(s_mat: np.ndarray, max_condition: float, where: str, names: list[str]) -> tuple[
    float, int, np.ndarray
]:
    sv = np.linalg.svd(s_mat, compute_uv=False)
    tol = max(s_mat.shape) * np.finfo(float).eps * sv[0] if sv.size else 0.0
    rank = int(np.sum(sv > tol))
    cond = float(sv[0] / sv[-1]) if rank == sv.size and sv.size else np.inf
    if rank < s_mat.shape[1] or cond > max_condition:
        raise UnidentifiableError(
            f"exact local added mass: the {s_mat.shape[0]} mode(s) used cannot determine the "
            f"{s_mat.shape[1]} unknowns {', '.join(names)} ({where}: sensitivity matrix rank "
            f"{rank}, condition number {cond:.3g} > {max_condition:g}); use more modes, fewer "
            "immersed elements, or fit_stiffness=False",
            cond,
            rank,
        )
    return cond, rank, sv


def exact_added_mass(
    beam: Beam,
    fn_genuine_hz: Sequence[float] | np.ndarray,
    fn_modified_hz: Sequence[float] | np.ndarray,
    *,
    fn_genuine_std_hz: Sequence[float] | np.ndarray | None = None,
    fn_modified_std_hz: Sequence[float] | np.ndarray | None = None,
    immersed_elements: Sequence[int] = (10,),
    n_modes: int | None = None,
    fit_stiffness: bool = False,
    start: Start | Sequence[float] = "first_order",
    weighting: Weighting = "equal",
    max_condition: float = MAX_CONDITION,
    max_iter: int = 50,
    xtol: float = 1e-9,
    ratio_tol: float = 1e-8,
    configuration: str = "",
) -> ExactAddedMassResult:
    """Added mass (and stiffness change) of immersed elements by an exact eigenvalue fit.

    Fits p = [delta_m_j, (delta_k_j)] so that lambda_r(p) / lambda_r(0) =
    (f_wr / f_r)^2 for the modes r = 1..n_modes (least squares,
    Levenberg-Marquardt with analytic eigenvalue derivatives); see the module
    docstring for the definitions, the start, the uncertainty and the refusal
    rule.

    Parameters
    ----------
    beam : the updated FE beam of the genuine structure.
    fn_genuine_hz, fn_modified_hz : measured undamped natural frequencies (Hz,
        eq. 4 applied) per mode, genuine and modified configuration, mode r
        paired with FE mode r. NaN in the modified ones drops the mode.
    fn_genuine_std_hz, fn_modified_std_hz : their standard deviations (Hz);
        None or NaN gives NaN ``delta_m_std``.
    immersed_elements : measurement element numbers (1-based, tip = n).
    n_modes : modes to use (default: all given).
    fit_stiffness : also fit delta_k per element (two unknowns per element).
    start : ``"first_order"`` (default), ``"zero"`` or an initial vector
        [delta_m..., delta_k...] (e.g. the block method's answer).
    weighting : ``"equal"`` (default, every mode's ratio residual counts
        alike) or ``"inverse_variance"`` (residuals divided by sigma_y; needs
        positive std for every mode used).
    max_condition : refuse above this condition number (module docstring).
    max_iter, xtol, ratio_tol : limit on trial steps; converged when the
        undamped Gauss-Newton step changes no unknown by more than ``xtol``, or
        when the cost decrease it promises is below what eigenvalue-ratio noise
        of size ``ratio_tol`` can hide (the banded eigen-solver reproduces the
        ratios to about 1e-9..1e-8 on mode 1); that last step is then taken.
    configuration : label copied to the result.

    Returns
    -------
    ExactAddedMassResult

    Raises
    ------
    DataError : bad input, unknowns not determined by the modes, or no convergence.

    Examples
    --------
    >>> from ema_pipeline.added_mass.modified_beam import beam_modes_with_added_mass
    >>> from ema_pipeline.data import Beam
    >>> beam = Beam()
    >>> dry = beam_modes_with_added_mass(beam, {}, 4).fn_hz
    >>> wet = beam_modes_with_added_mass(beam, {10: 0.3}, 4).fn_hz
    >>> res = exact_added_mass(beam, dry, wet, immersed_elements=[10])
    >>> round(float(res.delta_m[0]), 6), res.condition_number
    (0.3, 1.0)
    """
    elements = tuple(int(e) for e in immersed_elements)
    if not elements or len(set(elements)) != len(elements):
        raise DataError(f"immersed_elements must be distinct element numbers, got {elements}")
    for el in elements:
        fe.fe_elements_of_measurement_element(beam, el)
    fg_all = np.atleast_1d(np.asarray(fn_genuine_hz, dtype=float))
    p_all = fg_all.size if n_modes is None else int(n_modes)
    if p_all < 1:
        raise DataError(f"n_modes must be >= 1, got {p_all}")
    fg = _as_1d("fn_genuine_hz", fg_all, p_all)
    fw = _as_1d("fn_modified_hz", fn_modified_hz, p_all)
    nan_std = np.full(p_all, np.nan)
    sg = nan_std if fn_genuine_std_hz is None else _as_1d("fn_genuine_std_hz", fn_genuine_std_hz,
                                                           p_all)
    sw = nan_std if fn_modified_std_hz is None else _as_1d("fn_modified_std_hz",
                                                            fn_modified_std_hz, p_all)
    if not (np.all(np.isfinite(fg)) and np.all(fg > 0)):
        raise DataError(f"genuine natural frequencies must be finite and > 0, got {fg.tolist()}")
    use = np.flatnonzero(np.isfinite(fw))
    if np.any(fw[use] <= 0):
        raise DataError(f"modified natural frequencies must be > 0, got {fw.tolist()}")
    n_el = len(elements)
    n_p = 2 * n_el if fit_stiffness else n_el
    names = [f"delta_m[{e}]" for e in elements] + (
        [f"delta_k[{e}]" for e in elements] if fit_stiffness else []
    )
    if n_p > use.size:
        raise UnidentifiableError(
            f"exact local added mass: {n_p} unknowns ({', '.join(names)}) need at least {n_p} "
            f"modes measured in both configurations, got {use.size}",
            np.inf,
            int(use.size),
        )
    if weighting not in ("equal", "inverse_variance"):
        raise DataError(f"unknown weighting {weighting!r}; use 'equal' or 'inverse_variance'")

    y = (fw[use] / fg[use]) ** 2
    sigma_y = 2 * y * np.sqrt((sg[use] / fg[use]) ** 2 + (sw[use] / fw[use]) ** 2)
    if weighting == "inverse_variance":
        if not (np.all(np.isfinite(sigma_y)) and np.all(sigma_y > 0)):
            raise DataError("weighting='inverse_variance' needs positive frequency std for every "
                            "mode used")
        w = 1.0 / sigma_y
    else:
        w = np.ones(use.size)

    mod = ElementModification.build(beam, elements)
    n_fe = int(use.max()) + 1

    def solve(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k, m = mod.matrices(x[:n_el], x[n_el:] if fit_stiffness else np.zeros(n_el))
        omega2, shapes = fe.lowest_modes(k, m, n_fe)
        return omega2[use], shapes[:, use]

    lam0, phi0 = solve(np.zeros(n_p))
    s0 = _sensitivity(mod, lam0, phi0, lam0, fit_stiffness)
    _svd_check(s0, max_condition, "at zero added mass", names)
    r0 = 1.0 - y
    x_fo = np.linalg.lstsq(w[:, None] * s0, -w * r0, rcond=None)[0]

    if isinstance(start, str):
        if start not in ("first_order", "zero"):
            raise DataError(f"unknown start {start!r}; use 'first_order', 'zero' or a vector")
        x = x_fo.copy() if start == "first_order" else np.zeros(n_p)
    else:
        x = np.asarray(start, dtype=float).ravel()
        if x.size != n_p or not np.all(np.isfinite(x)):
            raise DataError(f"start needs {n_p} finite values ({', '.join(names)}), got {start!r}")
    if np.any(1 + x <= 0):
        x = np.zeros(n_p)  # a first-order answer of <= -1 is no start

    def evaluate(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        omega2, shapes = solve(x)
        res = w * (omega2 / lam0 - y)
        jac = w[:, None] * _sensitivity(mod, omega2, shapes, lam0, fit_stiffness)
        return res, jac, omega2, shapes

    res, jac, omega2, shapes = evaluate(x)
    cost = float(res @ res)
    damping = MarquardtDamping(mu=1e-3, mu_min=1e-12, mu_max=1e10)
    converged = False
    it = 0
    noise = ratio_tol * float(np.linalg.norm(w))  # eigen-solver noise in the weighted residual
    while it < max_iter:  # Levenberg-Marquardt with Marquardt's diagonal scaling
        gauss_newton = np.linalg.lstsq(jac, -res, rcond=None)[0]
        gain = float(np.sum((jac @ gauss_newton) ** 2))  # cost decrease it promises
        if np.max(np.abs(gauss_newton)) < xtol:
            converged = True
            break
        if gain <= 2 * noise * np.sqrt(cost) + noise**2 and np.all(1 + x + gauss_newton > 1e-6):
            # at the minimum within eigen-solver noise: cost values can no longer rank
            # steps, the (exact) gradient still can; take the last Gauss-Newton step
            x = x + gauss_newton
            res, jac, omega2, shapes = evaluate(x)
            cost = float(res @ res)
            converged = True
            break
        it += 1
        step = marquardt_step(jac.T @ jac, -(jac.T @ res), damping.mu)
        x_new = x + step
        if np.all(1 + x_new > 1e-6):  # else: negative mass or stiffness, no trial
            trial = evaluate(x_new)
            cost_new = float(trial[0] @ trial[0])
            if cost_new < cost:
                x, (res, jac, omega2, shapes), cost = x_new, trial, cost_new
                damping.accepted()
                continue
        if not damping.rejected():  # no downhill step left although Gauss-Newton promises one
            break
    if not converged:
        raise DataError(f"exact local added mass did not converge in {it} iterations "
                        f"(last unknowns {dict(zip(names, np.round(x, 6), strict=True))})")

    s_sol = jac / w[:, None]
    cond, rank, sv = _svd_check(s_sol, max_condition, "at the solution", names)
    # linearised covariance, J^+ Cov_y J^+T with J^+ = (J^T W J)^-1 J^T W
    pinv = np.linalg.pinv(jac) * w[None, :]
    cov = pinv @ np.diag(sigma_y**2) @ pinv.T
    std = np.sqrt(np.diag(cov))
    dof = use.size - n_p
    if dof > 0:
        s2 = cost / dof
        std_mis = np.sqrt(np.diag(s2 * np.linalg.inv(jac.T @ jac)))
    else:
        std_mis = np.full(n_p, np.nan)

    ratio_model = omega2 / lam0
    mismatch = np.sqrt(ratio_model / y) - 1
    dm = x[:n_el]
    dk = x[n_el:] if fit_stiffness else np.full(n_el, np.nan)
    # modal added mass phi^T dM phi, dM = sum_j delta_m_j M_j (genuine / modified shapes)
    ma_genuine = mod.element_quadratic(phi0, "M") @ dm
    ma_modified = mod.element_quadratic(shapes, "M") @ dm
    nan_el = np.full(n_el, np.nan)
    return ExactAddedMassResult(
        configuration=configuration,
        elements=elements,
        delta_m=dm.copy(),
        delta_m_std=std[:n_el],
        delta_k=dk.copy(),
        delta_k_std=std[n_el:] if fit_stiffness else nan_el,
        delta_m_std_misfit=std_mis[:n_el],
        delta_k_std_misfit=std_mis[n_el:] if fit_stiffness else nan_el,
        delta_m_first_order=x_fo[:n_el],
        delta_k_first_order=x_fo[n_el:] if fit_stiffness else nan_el,
        covariance=cov,
        mode=use + 1,
        ratio_measured=y,
        ratio_model=ratio_model,
        freq_ratio_mismatch=mismatch,
        residual=float(np.sqrt(np.mean(mismatch**2))),
        condition_number=cond,
        rank=rank,
        singular_values=sv,
        fn_genuine_model_hz=np.sqrt(lam0) / (2 * np.pi),
        fn_modified_model_hz=np.sqrt(omega2) / (2 * np.pi),
        modal_added_mass=ma_genuine,
        modal_added_mass_modified_shape=ma_modified / np.einsum("ir,ik,kr->r", shapes, mod.M,
                                                                 shapes),
        modal_added_mass_eq10=lam0 / omega2 - 1,
        iterations=it,
        weighting=weighting,
        fit_stiffness=fit_stiffness,
    )


# ---------------------------------------------------------------------------
# every modified configuration of a study
# ---------------------------------------------------------------------------
def exact_added_mass_all(
    beam: Beam,
    measured: Mapping[str, ModalParameters],
    genuine: str = "genuine",
    *,
    immersed_elements: Sequence[int] = (10,),
    pairing: Mapping[str, AddedMassResult] | None = None,
    fit_stiffness: bool = False,
    max_condition: float = MAX_CONDITION,
) -> dict[str, ExactOutcome]:
    """:func:`exact_added_mass` for every modified configuration, never raising per configuration.

    Genuine mode r (all genuine modes, in order) is FE mode r; the modified
    configuration's partner comes from the eq. (10) pairing (``pairing``,
    default :func:`ema_pipeline.added_mass.modal_added_mass_all`), so a mode
    missing there is dropped, never paired with a wrong one. Frequencies and
    their ``fn_std_hz`` are the undamped ones (eq. 4). A configuration whose
    modes cannot determine the unknowns, or whose fit fails, becomes an
    :class:`ExactOutcome` with the reason instead of an exception.

    Examples
    --------
    >>> from ema_pipeline.added_mass.modified_beam import beam_modes_with_added_mass
    >>> from ema_pipeline.data import Beam, ModalParameters
    >>> beam = Beam()
    >>> fn = {k: beam_modes_with_added_mass(beam, a, 4).fn_hz
    ...       for k, a in (("genuine", {}), ("wet", {10: 0.3}))}
    >>> measured = {k: ModalParameters(fn_hz=f, zeta=np.zeros(4)) for k, f in fn.items()}
    >>> out = exact_added_mass_all(beam, measured)
    >>> round(float(out["wet"].result.delta_m[0]), 4), out["wet"].status
    (0.3, 'ok')
    >>> exact_added_mass_all(beam, measured, immersed_elements=range(1, 11))["wet"].status
    'refused'
    """
    elements = tuple(int(e) for e in immersed_elements)
    pairs = modal_added_mass_all(measured, genuine) if pairing is None else pairing
    gen = replace_configuration(measured[genuine], genuine)
    out: dict[str, ExactOutcome] = {}
    for name, pair in pairs.items():
        mod = measured[name]
        paired = pair.partner >= 0
        idx = np.where(paired, pair.partner, 0)
        fw = np.where(paired, mod.fn_hz[idx], np.nan)
        sw = np.where(paired, np.asarray(mod.fn_std_hz)[idx], np.nan)
        try:
            res = exact_added_mass(
                beam, gen.fn_hz, fw, fn_genuine_std_hz=gen.fn_std_hz, fn_modified_std_hz=sw,
                immersed_elements=elements, fit_stiffness=fit_stiffness,
                max_condition=max_condition, configuration=name,
            )
        except UnidentifiableError as exc:
            out[name] = ExactOutcome(name, elements, None, "refused", str(exc),
                                     exc.condition_number, exc.rank)
            continue
        except DataError as exc:
            out[name] = ExactOutcome(name, elements, None, "failed", str(exc))
            continue
        out[name] = ExactOutcome(name, elements, res, "ok", "", res.condition_number, res.rank)
    return out
