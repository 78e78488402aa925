"""Model update, eq. (26), by differential evolution, with the exact frequency
scaling of a uniform beam (see the package docstring)."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
import scipy.sparse

from ema_pipeline.data import Beam, DataError
from ema_pipeline.fe.beam import (
    banded_cholesky,
    batch_operator,
    check_point_masses,
    frequency_scale,
    hat_element_matrices,
    point_mass_vectors,
    scatter_elements,
    start_vectors,
    subspace_iteration,
)

#: Update parameters in the order of the paper's Table 4 rows (names as in :class:`Beam`).
PARAMETER_NAMES: tuple[str, ...] = (
    "thickness_m",
    "width_m",
    "length_m",
    "youngs_modulus_pa",
    "density_kg_m3",
)
PARAMETER_UNITS: dict[str, str] = {
    "thickness_m": "m",
    "width_m": "m",
    "length_m": "m",
    "youngs_modulus_pa": "Pa",
    "density_kg_m3": "kg/m^3",
}
#: Default update bounds, relative: geometry +-5 %, material +-8 % (section 4.2.1).
DEFAULT_BOUNDS_REL: dict[str, float] = {
    "thickness_m": 0.05,
    "width_m": 0.05,
    "length_m": 0.05,
    "youngs_modulus_pa": 0.08,
    "density_kg_m3": 0.08,
}
IDENTIFIABLE_NAME = "h*sqrt(E/rho)/L^2"


# ---------------------------------------------------------------------------
# model update, eq. (26)
# ---------------------------------------------------------------------------
def beam_parameters(beam: Beam) -> np.ndarray:
    """The five update parameters of ``beam`` in :data:`PARAMETER_NAMES` order (SI).

    Examples
    --------
    >>> beam_parameters(Beam())  # h, b, L, E, rho
    array([1.0e-02, 5.0e-02, 6.5e-01, 2.1e+11, 7.8e+03])
    """
    return np.array([getattr(beam, name) for name in PARAMETER_NAMES], dtype=float)


def beam_with_parameters(beam: Beam, params: np.ndarray) -> Beam:
    """``beam`` with the five parameters replaced (PARAMETER_NAMES order, SI).

    Point masses keep their position relative to the length (a sensor at a
    measurement node stays at that node when L changes).

    Examples
    --------
    >>> beam = Beam(point_masses=((0.65, 0.1),))
    >>> longer = beam_with_parameters(beam, [0.01, 0.05, 1.3, 210e9, 7800.0])
    >>> longer.length_m, longer.point_masses  # the tip mass stays at the tip
    (1.3, ((1.3, 0.1),))
    """
    params = np.asarray(params, dtype=float)
    values = dict(zip(PARAMETER_NAMES, params.tolist(), strict=True))
    scale = values["length_m"] / beam.length_m
    pms = tuple((x * scale, m) for x, m in beam.point_masses)
    return replace(beam, point_masses=pms, **values)


def identifiable_combination(params: np.ndarray) -> np.ndarray:
    """h * sqrt(E / rho) / L^2 in 1/s for parameter vector(s) (..., 5), PARAMETER_NAMES order.

    For a uniform beam without point masses every natural frequency is
    proportional to it, and b cancels: it is all that frequencies can identify.

    Examples
    --------
    >>> p = beam_parameters(Beam())
    >>> float(identifiable_combination(p).round(3))  # 0.01 * sqrt(210e9 / 7800) / 0.65^2
    122.811
    >>> float(identifiable_combination(p * [2, 1, 1, 4, 1]) / identifiable_combination(p))
    4.0
    """
    p = np.asarray(params, dtype=float)
    h, e, rho, length = (p[..., PARAMETER_NAMES.index(name)] for name in
                         ("thickness_m", "youngs_modulus_pa", "density_kg_m3", "length_m"))
    return frequency_scale(h, e, rho, length)


def update_objective(fn_model_hz: np.ndarray, fn_measured_hz: np.ndarray) -> np.ndarray:
    """Eq. (26): sum_r |f_A,r - f_X,r| / f_X,r over the last axis.

    ``fn_measured_hz`` are undamped natural frequencies (eq. 4).

    Examples
    --------
    >>> round(float(update_objective(np.array([20.0, 125.0]), np.array([19.84, 124.33]))), 5)
    0.01345
    """
    fa = np.asarray(fn_model_hz, dtype=float)
    fx = np.asarray(fn_measured_hz, dtype=float)
    return np.sum(np.abs(fa - fx) / fx, axis=-1)


class FrequencyEvaluator:
    """Natural frequencies (Hz) of the FE beam for many parameter sets at once.

    Uses the exact scaling of the module docstring: K^, M^ (dimensionless, rotations
    as le*theta) are assembled once; for parameters (h, b, L, E, rho)
    lambda_r = E I / (rho A le^4) * mu_r(t), t = 1 / (rho A le). Without point
    masses mu_r is computed once (one reference solve) and every evaluation is a
    scalar scaling - exact, not an approximation. With point masses every
    parameter set gets a full eigen-solve, batched over the population.

    Parameters
    ----------
    beam : the reference beam (mesh, point masses; positions kept relative to L).
    mode_numbers : 1-based FE mode numbers to return.
    """

    def __init__(self, beam: Beam, mode_numbers: Sequence[int] | np.ndarray) -> None:
        self.beam = beam
        self.mode_numbers = np.asarray(mode_numbers, dtype=int)
        if self.mode_numbers.size == 0 or self.mode_numbers.min() < 1:
            raise DataError("mode numbers must be >= 1")
        n = beam.n_elements
        self._n_modes = int(self.mode_numbers.max())
        if self._n_modes > 2 * n:
            raise DataError(f"the FE model with {n} elements has only {2 * n} modes")
        k_hat, m_hat = hat_element_matrices()
        all_el = np.arange(n)
        self._k = scatter_elements(n, all_el, np.broadcast_to(k_hat, (n, 4, 4)))
        self._m = scatter_elements(n, all_el, np.broadcast_to(m_hat, (n, 4, 4)))
        frac, mass = check_point_masses(beam)
        keep = mass > 0
        self._g = point_mass_vectors(n, frac[keep], mass[keep])
        self.has_point_masses = bool(self._g.shape[1])
        self._q = max(2 * self._n_modes, self._n_modes + 8)
        self._small = 2 * n <= 2 * self._q
        if not self._small:
            self._chol = banded_cholesky(self._k)
            self._k_apply = batch_operator(self._k)
            self._m_apply = batch_operator(self._m)
        self.n_solves = 0
        self._x_warm: np.ndarray | None = None
        if self.has_point_masses:
            # eigenvectors of the reference beam: a warm start for every later solve
            b0 = beam
            t_ref = np.array([1.0 / (b0.density_kg_m3 * b0.area_m2 * b0.length_m / n)])
            self._mu0 = None
            self._mu(t_ref, keep_vectors=True)
        else:
            self._mu0 = self._mu(np.zeros(1))[0]
        self.n_solves = 0

    def _mu(self, t: np.ndarray, keep_vectors: bool = False) -> np.ndarray:
        """Eigenvalues (S, n_modes) of (K^, M^ + t_s P^), batched over t."""
        self.n_solves += t.size
        if self._small:
            out = []
            for ts in t:
                m = self._m + ts * self._g @ self._g.T
                out.append(
                    scipy.linalg.eigh(
                        self._k, m, eigvals_only=True, subset_by_index=[0, self._n_modes - 1]
                    )
                )
            return np.array(out)
        g = self._g
        m_hat = self._m_apply

        def mass_apply(x: np.ndarray) -> np.ndarray:
            mx = m_hat(x)
            if g.shape[1]:
                mx += t[:, None, None] * (g @ (g.T @ x))
            return mx

        if self._x_warm is None:
            x0 = start_vectors(self._k.shape[0], self._q, t.size)
        else:  # point masses change the modes only a little: start from the reference
            x0 = np.repeat(self._x_warm, t.size, axis=0)
        n_keep = self._n_modes + 4 if keep_vectors else self._n_modes
        # eigenvalues only: their error is ~ residual^2, so 1e-7 gives ~1e-14
        w, x, err = subspace_iteration(
            self._chol, self._k_apply, mass_apply, x0, n_keep, 1e-9 if keep_vectors else 1e-7, 100
        )
        if err > 1e-5:
            raise DataError(f"subspace iteration did not converge (relative residual {err:.2g})")
        if keep_vectors:
            self._x_warm = x[:1]
        return w[:, : self._n_modes]

    def __call__(self, params: np.ndarray) -> np.ndarray:
        """Frequencies (S, n_sel) in Hz for params (S, 5) in PARAMETER_NAMES order (SI)."""
        p = np.atleast_2d(np.asarray(params, dtype=float))
        h, b, length, e, rho = p.T
        le = length / self.beam.n_elements
        ei = e * b * h**3 / 12.0
        rho_a = rho * b * h
        factor = ei / (rho_a * le**4)
        mu = (
            np.broadcast_to(self._mu0, (p.shape[0], self._n_modes))
            if self._mu0 is not None
            else self._mu(1.0 / (rho_a * le))
        )
        lam = factor[:, None] * mu[:, self.mode_numbers - 1]
        return np.sqrt(lam) / (2 * np.pi)


@dataclass(frozen=True)
class UpdateRun:
    """One differential-evolution run: seed, best parameters (SI), eq. (26) value.

    ``n_evaluations`` counts parameter sets evaluated (population members), not
    calls of the vectorised objective.
    """

    seed: int
    parameters: np.ndarray
    objective: float
    fn_hz: np.ndarray
    n_evaluations: int
    n_generations: int
    success: bool
    message: str


@dataclass(frozen=True)
class UpdateResult:
    """Result of :func:`update_beam` (paper Table 4 and 5).

    Attributes
    ----------
    parameter_names, units : the five parameters (PARAMETER_NAMES order) and units.
    initial, updated, lower, upper : (5,) SI values; ``updated`` from the best run.
    objective, objective_initial : eq. (26) of the updated and initial model.
    fn_measured_hz : (p,) undamped measured frequencies used (eq. 4).
    mode_numbers : (p,) FE mode numbers matched to them.
    fn_initial_hz, fn_updated_hz : (p,) FE frequencies before / after.
    runs : every run; ``best_run`` the index of the kept one.
    identifiable_name, identifiable_initial, identifiable_updated : the only
        combination of the parameters that frequencies determine (no point
        masses), h*sqrt(E/rho)/L^2 in 1/s, and its value before / after.
    identifiable_runs : (n_runs,) its value in every run.
    identifiable_exact : True without point masses (frequencies depend on the
        parameters only through the combination); with point masses it is only
        the leading combination.
    method : "scaling" (exact scaling, one reference solve) or "full solve".
    beam : the updated Beam.
    wall_time_s : time of all runs.
    """

    parameter_names: tuple[str, ...]
    units: tuple[str, ...]
    initial: np.ndarray
    updated: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    objective: float
    objective_initial: float
    fn_measured_hz: np.ndarray
    mode_numbers: np.ndarray
    fn_initial_hz: np.ndarray
    fn_updated_hz: np.ndarray
    runs: tuple[UpdateRun, ...]
    best_run: int
    identifiable_initial: float
    identifiable_updated: float
    identifiable_runs: np.ndarray
    identifiable_exact: bool
    method: str
    beam: Beam
    wall_time_s: float
    identifiable_name: str = IDENTIFIABLE_NAME
    objectives: np.ndarray = field(default_factory=lambda: np.empty(0))

    @property
    def run_parameters(self) -> np.ndarray:
        """(n_runs, 5) best parameters of every run."""
        return np.array([r.parameters for r in self.runs])

    @property
    def run_min(self) -> np.ndarray:
        return self.run_parameters.min(axis=0)

    @property
    def run_max(self) -> np.ndarray:
        return self.run_parameters.max(axis=0)

    @property
    def run_std(self) -> np.ndarray:
        return (
            self.run_parameters.std(axis=0, ddof=1)
            if len(self.runs) > 1
            else np.full(len(self.parameter_names), np.nan)
        )


def update_beam(
    beam: Beam,
    fn_measured_hz: np.ndarray,
    *,
    mode_numbers: Sequence[int] | np.ndarray | None = None,
    bounds_rel: Mapping[str, float] | None = None,
    n_repeats: int = 5,
    seed: int = 0,
    progress: Callable[[int, int], None] | None = None,
    popsize: int = 15,
    maxiter: int = 1000,
    tol: float = 1e-6,
    polish: bool = True,
) -> UpdateResult:
    """Update b, h, L, E, rho so that FE frequencies match measured ones, eq. (26).

    Minimises f = sum_r |f_A,r - f_X,r| / f_X,r (eq. 26) by differential
    evolution (:func:`scipy.optimize.differential_evolution`, strategy best1bin;
    the paper's "genetic algorithm"), repeated ``n_repeats`` times with seeds
    ``seed, seed + 1, ...``; the run with the lowest objective is kept and all
    runs are reported. Bounds: geometry +-5 %, E and rho +-8 % of the initial
    values (section 4.2.1), or ``bounds_rel`` (relative half-widths per name).

    Without point masses the frequencies are computed by the exact scaling
    lambda ~ E h^2 / (rho L^4) of one reference solve (see
    :class:`FrequencyEvaluator`); the five parameters are then not separately
    identifiable, only h*sqrt(E/rho)/L^2 is - the result reports it and the
    spread of the parameters over the runs. With point masses each candidate
    gets a full eigen-solve (batched over the population).

    Parameters
    ----------
    beam : initial beam (Table 3 model).
    fn_measured_hz : (p,) measured UNDAMPED natural frequencies, fn = fd/sqrt(1-zeta^2)
        (eq. 4); NaN entries (modes not measured) are left out.
    mode_numbers : FE mode numbers matching them (default 1..p).
    progress : called as ``progress(done, n_repeats)`` before the first run
        (done = 0) and after every run, e.g. to advance a progress bar
        (:func:`ema_pipeline.pipeline.fe_stage.update_progress_bar`); None: silent.
    """
    fx = np.atleast_1d(np.asarray(fn_measured_hz, dtype=float))
    if fx.ndim != 1 or fx.size == 0:
        raise DataError("fn_measured_hz must be a non-empty 1-D array of frequencies in Hz")
    modes = np.arange(1, fx.size + 1) if mode_numbers is None else np.asarray(mode_numbers, int)
    if modes.shape != fx.shape:
        raise DataError(f"{modes.size} mode numbers for {fx.size} measured frequencies")
    ok = np.isfinite(fx)
    if np.any(fx[ok] <= 0):
        raise DataError("measured natural frequencies must be positive")
    if not ok.any():
        raise DataError("no finite measured frequency to update against")
    if n_repeats < 1:
        raise DataError(f"n_repeats must be >= 1, got {n_repeats}")
    rel = dict(DEFAULT_BOUNDS_REL)
    if bounds_rel:
        unknown = set(bounds_rel) - set(PARAMETER_NAMES)
        if unknown:
            raise DataError(f"unknown update parameter(s) {sorted(unknown)}; use {PARAMETER_NAMES}")
        rel.update(bounds_rel)
    if any(not 0 <= v < 1 for v in rel.values()):
        raise DataError(f"relative bounds must lie in [0, 1), got {rel}")
    x_init = beam_parameters(beam)
    half = np.array([rel[n] for n in PARAMETER_NAMES])
    lower, upper = x_init * (1 - half), x_init * (1 + half)

    evaluator = FrequencyEvaluator(beam, modes[ok])
    fx_ok = fx[ok]

    counter = [0]

    def objective(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        pop = x.T if x.ndim == 2 else x[None, :]
        counter[0] += pop.shape[0]
        val = update_objective(evaluator(pop), fx_ok)
        return val if x.ndim == 2 else val[0]

    t0 = time.perf_counter()
    runs: list[UpdateRun] = []
    if progress is not None:
        progress(0, n_repeats)
    from scipy.optimize import differential_evolution  # here: 0.2 s of start-up

    for k in range(n_repeats):
        counter[0] = 0
        res = differential_evolution(
            objective,
            list(zip(lower, upper, strict=True)),
            popsize=popsize,
            maxiter=maxiter,
            tol=tol,
            rng=np.random.default_rng(seed + k),
            polish=polish,
            vectorized=True,
            updating="deferred",
        )
        xb = np.clip(res.x, lower, upper)
        n_eval = counter[0]
        runs.append(
            UpdateRun(
                seed=seed + k,
                parameters=xb,
                objective=float(objective(xb)),
                fn_hz=evaluator(xb[None, :])[0],
                n_evaluations=int(n_eval),
                n_generations=int(res.nit),
                success=bool(res.success),
                message=str(res.message),
            )
        )
        if progress is not None:
            progress(k + 1, n_repeats)
    wall = time.perf_counter() - t0
    objectives = np.array([r.objective for r in runs])
    best = int(np.argmin(objectives))
    x_best = runs[best].parameters
    full_eval = FrequencyEvaluator(beam, modes)
    fn_init = full_eval(x_init[None, :])[0]
    fn_upd = full_eval(x_best[None, :])[0]
    comb = identifiable_combination(np.array([r.parameters for r in runs]))
    return UpdateResult(
        parameter_names=PARAMETER_NAMES,
        units=tuple(PARAMETER_UNITS[n] for n in PARAMETER_NAMES),
        initial=x_init,
        updated=x_best,
        lower=lower,
        upper=upper,
        objective=float(objectives[best]),
        objective_initial=float(update_objective(fn_init[ok], fx_ok)),
        fn_measured_hz=fx,
        mode_numbers=modes,
        fn_initial_hz=fn_init,
        fn_updated_hz=fn_upd,
        runs=tuple(runs),
        best_run=best,
        identifiable_initial=float(identifiable_combination(x_init)),
        identifiable_updated=float(comb[best]),
        identifiable_runs=comb,
        identifiable_exact=not evaluator.has_point_masses,
        method="full solve" if evaluator.has_point_masses else "scaling",
        beam=beam_with_parameters(beam, x_best),
        wall_time_s=wall,
        objectives=objectives,
    )
