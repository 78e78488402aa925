"""Beam FE: Hermite cubic Euler-Bernoulli elements, consistent mass, point masses,
vectorised assembly, and the lowest modes by subspace iteration on the banded
Cholesky factor of K (see the package docstring for the measured speed)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg
import scipy.sparse
from scipy.linalg import lapack

from ema_pipeline.data import Beam, DataError

_HALF_BANDWIDTH = 3  # two DOFs per node, two nodes per element


# ---------------------------------------------------------------------------
# element matrices and assembly
# ---------------------------------------------------------------------------
def hermite_element_matrices(
    length_m: np.ndarray | float,
    ei_nm2: np.ndarray | float,
    rho_a_kg_m: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass matrices of Euler-Bernoulli beam elements.

    Hermite cubic shape functions, DOFs per element ``[w1, theta1, w2, theta2]``
    (m, rad).

    Parameters
    ----------
    length_m : element lengths in m, scalar or (n,).
    ei_nm2 : bending stiffness E*I in N m^2, scalar or (n,).
    rho_a_kg_m : mass per length rho*A in kg/m, scalar or (n,).

    Returns
    -------
    Ke, Me : (n, 4, 4) in N/m (N, N m for rotations) and kg (kg m, kg m^2).
    """
    le, ei, ra = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(v, dtype=float)) for v in (length_m, ei_nm2, rho_a_kg_m))
    )
    k_hat, m_hat = hat_element_matrices()
    # rotations as le*theta in the hat matrices: scale rows/cols 1 and 3 by le
    s = np.ones((le.size, 4))
    s[:, 1] = s[:, 3] = le
    outer = s[:, :, None] * s[:, None, :]
    ke = (ei / le**3)[:, None, None] * k_hat * outer
    me = (ra * le)[:, None, None] * m_hat * outer
    return ke, me


def hat_element_matrices() -> tuple[np.ndarray, np.ndarray]:
    """Dimensionless element matrices (element length 1, EI = 1, rho A = 1).

    Examples
    --------
    >>> k_hat, m_hat = hat_element_matrices()
    >>> u = np.array([1.0, 0.0, 1.0, 0.0])  # rigid translation of the element
    >>> k_hat @ u, float(u @ m_hat @ u)  # no strain energy; unit mass (rho A le = 1)
    (array([0., 0., 0., 0.]), 1.0)
    """
    k_hat = np.array(
        [
            [12.0, 6.0, -12.0, 6.0],
            [6.0, 4.0, -6.0, 2.0],
            [-12.0, -6.0, 12.0, -6.0],
            [6.0, 2.0, -6.0, 4.0],
        ]
    )
    m_hat = (
        np.array(
            [
                [156.0, 22.0, 54.0, -13.0],
                [22.0, 4.0, 13.0, -3.0],
                [54.0, 13.0, 156.0, -22.0],
                [-13.0, -3.0, -22.0, 4.0],
            ]
        )
        / 420.0
    )
    return k_hat, m_hat


def scatter_elements(n_elements: int, elements: np.ndarray, ke: np.ndarray) -> np.ndarray:
    """Assemble (n_sel, 4, 4) element matrices into the free-DOF matrix (clamp removed).

    Examples
    --------
    >>> k_hat, _ = hat_element_matrices()
    >>> K = scatter_elements(2, np.arange(2), np.broadcast_to(k_hat, (2, 4, 4)))
    >>> K.shape, bool(np.allclose(K, K.T))  # 2 free nodes x (w, le*theta)
    ((4, 4), True)
    """
    n_all = 2 * (n_elements + 1)
    idx = 2 * elements[:, None] + np.arange(4)[None, :]
    rows = np.broadcast_to(idx[:, :, None], ke.shape)
    cols = np.broadcast_to(idx[:, None, :], ke.shape)
    out = np.zeros((n_all, n_all))
    np.add.at(out, (rows, cols), ke)
    return out[2:, 2:]


def _hermite_shape(xi: np.ndarray) -> np.ndarray:
    """Dimensionless Hermite functions at xi in [0, 1], rotations as le*theta: (n, 4)."""
    xi = np.asarray(xi, dtype=float)
    return np.stack(
        [
            1 - 3 * xi**2 + 2 * xi**3,
            xi - 2 * xi**2 + xi**3,
            3 * xi**2 - 2 * xi**3,
            -(xi**2) + xi**3,
        ],
        axis=-1,
    )


def point_mass_vectors(n_elements: int, fraction: np.ndarray, mass_kg: np.ndarray) -> np.ndarray:
    """Columns sqrt(m_k) * N(x_k) in hat DOFs (rotations as le*theta): (n_dof, n_masses).

    The point-mass matrix is G G^T. ``fraction`` = x/L in [0, 1].

    Examples
    --------
    A 4 kg mass at the tip of a 2-element beam acts on the tip deflection only:

    >>> point_mass_vectors(2, np.array([1.0]), np.array([4.0])).ravel()  # sqrt(4) = 2
    array([0., 0., 2., 0.])
    """
    n_dof = 2 * n_elements
    fraction = np.asarray(fraction, dtype=float)
    g = np.zeros((2 * (n_elements + 1), fraction.size))
    if fraction.size:
        pos = fraction * n_elements
        elem = np.minimum(np.floor(pos).astype(int), n_elements - 1)
        xi = pos - elem
        shape = _hermite_shape(xi) * np.sqrt(np.asarray(mass_kg, dtype=float))[:, None]
        rows = 2 * elem[:, None] + np.arange(4)[None, :]
        cols = np.broadcast_to(np.arange(fraction.size)[:, None], rows.shape)
        g[rows, cols] = shape
    return g[2 : 2 + n_dof]


def check_point_masses(beam: Beam) -> tuple[np.ndarray, np.ndarray]:
    """Point masses of ``beam`` as (x / L, mass_kg) arrays; DataError when outside the beam
    or negative.

    Examples
    --------
    >>> check_point_masses(Beam(length_m=0.5, point_masses=((0.25, 0.1),)))
    (array([0.5]), array([0.1]))
    """
    pm = np.asarray(beam.point_masses, dtype=float).reshape(-1, 2)
    x, m = pm[:, 0], pm[:, 1]
    if not (np.all(np.isfinite(pm)) and np.all(m >= 0)):
        raise DataError(f"point masses must be finite (x_m, mass_kg >= 0) pairs, got {pm.tolist()}")
    if np.any((x < 0) | (x > beam.length_m * (1 + 1e-12))):
        raise DataError(
            f"point mass position(s) {x[(x < 0) | (x > beam.length_m)].tolist()} m lie outside "
            f"the beam [0, {beam.length_m}] m"
        )
    return np.clip(x / beam.length_m, 0.0, 1.0), m


@dataclass(frozen=True)
class FEModel:
    """Assembled cantilever FE model (clamped node 0 removed).

    DOF order ``[w_1, theta_1, w_2, theta_2, ..., w_n, theta_n]`` for FE nodes
    1..n (node 0 is the clamp at x = 0); w in m, theta in rad.
    ``K`` in N/m, ``M`` in kg (dense, symmetric, half-bandwidth 3).
    """

    K: np.ndarray
    M: np.ndarray
    node_x_m: np.ndarray
    beam: Beam

    @property
    def n_dof(self) -> int:
        return int(self.K.shape[0])

    def translational_dof(self, fe_node: int | np.ndarray) -> np.ndarray:
        """Index of the translational DOF of FE node(s) 1..n_elements."""
        node = np.asarray(fe_node, dtype=int)
        if np.any((node < 1) | (node > self.beam.n_elements)):
            raise DataError(f"FE node(s) {node} outside 1..{self.beam.n_elements} (0 is clamped)")
        return 2 * (node - 1)


def assemble_beam(beam: Beam, *, elements: Sequence[int] | np.ndarray | None = None) -> FEModel:
    """Assemble K and M of the clamped-free beam, vectorised.

    Parameters
    ----------
    beam : geometry, material, FE mesh (``beam.n_elements``) and point masses.
    elements : optional 0-based FE element indices; if given, only these
        elements contribute and point masses are left out (used for element
        matrices of a sub-domain, e.g. the immersed part).

    Returns
    -------
    FEModel with dense K, M of size 2*n_elements.
    """
    n = beam.n_elements
    le = beam.length_m / n
    ke, me = hermite_element_matrices(
        le, beam.youngs_modulus_pa * beam.second_moment_m4, beam.density_kg_m3 * beam.area_m2
    )
    if elements is None:
        sel = np.arange(n)
    else:
        sel = np.unique(np.asarray(elements, dtype=int))
        if sel.size and (sel.min() < 0 or sel.max() >= n):
            raise DataError(f"FE element indices must lie in 0..{n - 1}, got {sel.tolist()}")
    k_full = scatter_elements(n, sel, np.broadcast_to(ke, (sel.size, 4, 4)))
    m_full = scatter_elements(n, sel, np.broadcast_to(me, (sel.size, 4, 4)))
    if elements is None and beam.point_masses:
        frac, mass = check_point_masses(beam)
        g = point_mass_vectors(n, frac, mass)
        g[1::2] /= le  # hat rotation DOF le*theta -> theta (rad)
        m_full = m_full + g @ g.T
    return FEModel(K=k_full, M=m_full, node_x_m=np.linspace(0.0, beam.length_m, n + 1), beam=beam)


# ---------------------------------------------------------------------------
# eigen-solution
# ---------------------------------------------------------------------------
def _banded_upper(a: np.ndarray, half_bandwidth: int) -> np.ndarray:
    """Upper banded LAPACK storage ab[u + i - j, j] = a[i, j]."""
    n = a.shape[0]
    ab = np.zeros((half_bandwidth + 1, n))
    for k in range(half_bandwidth + 1):
        ab[half_bandwidth - k, k:] = np.diagonal(a, k)
    return ab


def _half_bandwidth(a: np.ndarray) -> int:
    """Largest j - i with a[i, j] != 0 (a symmetric)."""
    nz = a != 0
    last = a.shape[1] - 1 - np.argmax(nz[:, ::-1], axis=1)
    has = nz.any(axis=1)
    return int(np.max(np.where(has, last - np.arange(a.shape[0]), 0), initial=0))


def banded_cholesky(k: np.ndarray) -> np.ndarray:
    """Upper Cholesky factor of the banded stiffness ``k`` in LAPACK banded storage
    (``ab[u + i - j, j] = U[i, j]``); DataError when ``k`` is not positive definite.

    Examples
    --------
    >>> banded_cholesky(np.array([[4.0, 2.0], [2.0, 5.0]]))  # U = [[2, 1], [0, 2]]
    array([[0., 1.],
           [2., 2.]])
    """
    kb = _banded_upper(k, _half_bandwidth(k))
    chol, info = lapack.dpbtrf(kb, lower=0)
    if info != 0:
        raise DataError(
            "stiffness matrix is not positive definite (is the beam clamped and are all "
            "parameters positive?)"
        )
    return chol


def _ritz(kr: np.ndarray, mr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched generalized symmetric eigen-solution of small (S, q, q) pencils.

    Returns ascending eigenvalues (S, q) and M-orthonormal vectors (S, q, q).
    """
    kr = 0.5 * (kr + kr.swapaxes(-1, -2))
    mr = 0.5 * (mr + mr.swapaxes(-1, -2))
    low = np.linalg.cholesky(mr)
    y = np.linalg.solve(low, kr)  # L^-1 K
    c = np.linalg.solve(low, y.swapaxes(-1, -2))  # L^-1 K L^-T
    w, z = np.linalg.eigh(0.5 * (c + c.swapaxes(-1, -2)))
    v = np.linalg.solve(low.swapaxes(-1, -2), z)
    return w, v


def subspace_iteration(
    chol: np.ndarray,
    k_apply: Callable[[np.ndarray], np.ndarray],
    m_apply: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    n_modes: int,
    tol: float,
    max_iter: int,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Lowest eigenpairs of S pencils (K, M_s) sharing K, by inverse subspace iteration.

    Layout (S, n, q): S problems, n DOFs, q vectors each. ``chol`` is the
    banded upper Cholesky factor of K; ``k_apply(X)`` and ``m_apply(X)`` return
    K X_s and M_s X_s. Converged when every relative residual
    ||K x - lambda M x|| / (lambda ||M x||) of the wanted modes is < tol or stops
    decreasing (round-off floor); the caller judges the final residual.
    Returns eigenvalues (S, n_modes), M-normalised vectors (S, n, n_modes), and
    the largest relative residual.
    """
    x = x0
    n_batch, n, q = x.shape
    err = prev = np.inf
    for it in range(max_iter):
        x = x / np.linalg.norm(x, axis=1, keepdims=True)
        kx = k_apply(x)
        mx = m_apply(x)
        xt = x.swapaxes(1, 2)
        w, v = _ritz(xt @ kx, xt @ mx)
        x, mx = x @ v, mx @ v
        kx = kx @ v[..., :n_modes]
        res = kx - mx[..., :n_modes] * w[:, None, :n_modes]
        err = float(
            np.max(
                np.linalg.norm(res, axis=1)
                / (np.abs(w[:, :n_modes]) * np.linalg.norm(mx[..., :n_modes], axis=1))
            )
        )
        # stop when converged, or when the residual stagnates at its round-off
        # floor (about eps * cond(K, M): ~1e-8 for 100 elements)
        if err < tol or (it >= 3 and err > 0.5 * prev):
            break
        prev = err
        sol, info = lapack.dpbtrs(chol, _to_columns(mx), lower=0)
        if info != 0:  # pragma: no cover - dpbtrs only fails on bad arguments
            raise DataError(f"banded solve failed (LAPACK info {info})")
        x = _from_columns(sol, n_batch)
    return w[:, :n_modes], x[..., :n_modes], err


def _to_columns(x: np.ndarray) -> np.ndarray:
    """(S, n, q) -> (n, S*q)."""
    n_batch, n, q = x.shape
    return x.transpose(1, 0, 2).reshape(n, n_batch * q)


def _from_columns(x: np.ndarray, n_batch: int) -> np.ndarray:
    """(n, S*q) -> (S, n, q)."""
    n = x.shape[0]
    return x.reshape(n, n_batch, -1).transpose(1, 0, 2)


def start_vectors(n: int, q: int, n_batch: int = 1) -> np.ndarray:
    """Fixed pseudo-random start block (S, n, q): deterministic, no global state.

    Examples
    --------
    >>> x = start_vectors(5, 3, n_batch=2)
    >>> x.shape, bool(np.array_equal(x, start_vectors(5, 3, n_batch=2)))
    ((2, 5, 3), True)
    """
    rng = np.random.default_rng(20240611)
    return np.repeat(rng.standard_normal((1, n, q)), n_batch, axis=0)


def batch_operator(a: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """X (S, n, q) -> A X_s: dense BLAS for one problem, sparse (banded A) for a batch.

    Examples
    --------
    >>> apply = batch_operator(np.diag([1.0, 2.0, 3.0]))
    >>> apply(np.ones((2, 3, 1)))[:, :, 0]  # two problems at once
    array([[1., 2., 3.],
           [1., 2., 3.]])
    """
    a_sp: list[scipy.sparse.csr_array] = []

    def apply(x: np.ndarray) -> np.ndarray:
        if x.shape[0] == 1:
            return (a @ x[0])[None]
        if not a_sp:
            a_sp.append(scipy.sparse.csr_array(a))
        return _from_columns(a_sp[0] @ _to_columns(x), x.shape[0])

    return apply


def lowest_modes(
    K: np.ndarray,
    M: np.ndarray,
    n_modes: int,
    *,
    method: Literal["banded", "dense"] = "banded",
    tol: float = 1e-9,
    max_iter: int = 100,
) -> tuple[np.ndarray, np.ndarray]:
    """Lowest ``n_modes`` eigenpairs of K psi = omega^2 M psi, mass-normalised.

    Parameters
    ----------
    K, M : (n, n) symmetric positive definite stiffness (N/m) and mass (kg).
    n_modes : number of modes wanted.
    method : ``"banded"`` (default) subspace iteration on the banded Cholesky
        factor of K with Rayleigh-Ritz (block size max(2 n_modes, n_modes + 8));
        ``"dense"`` scipy.linalg.eigh with ``subset_by_index``. Small models
        (n <= 2 * block size) always use the dense solver.
    tol : relative residual at which the banded iteration stops (it also stops
        when the residual reaches its round-off floor; above 1e-5 it raises).

    Returns
    -------
    omega2 : (n_modes,) eigenvalues omega_r^2 in (rad/s)^2, ascending.
    shapes : (n, n_modes) mode shapes with shapes.T @ M @ shapes = I (eq. 14 needs
        mass normalisation); sign fixed so that the largest-magnitude entry is > 0.

    Examples
    --------
    >>> w2, psi = lowest_modes(np.diag([9.0, 1.0, 4.0]), 2 * np.eye(3), 2)
    >>> w2, np.abs(psi).round(4)  # omega^2 = k / m; psi^T M psi = 1
    (array([0.5, 2. ]), array([[0.    , 0.    ],
           [0.7071, 0.    ],
           [0.    , 0.7071]]))
    """
    K = np.asarray(K, dtype=float)
    M = np.asarray(M, dtype=float)
    n = K.shape[0]
    if K.shape != (n, n) or M.shape != (n, n):
        raise DataError(f"K {K.shape} and M {M.shape} must be equal square matrices")
    if not 1 <= n_modes <= n:
        raise DataError(f"n_modes must lie in 1..{n}, got {n_modes}")
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(M))):
        raise DataError("K or M contains NaN/inf")
    q = max(2 * n_modes, n_modes + 8)
    if method == "dense" or n <= 2 * q:
        try:
            w, v = scipy.linalg.eigh(K, M, subset_by_index=[0, n_modes - 1])
        except np.linalg.LinAlgError as exc:
            raise DataError(f"eigen-solution failed: {exc}") from exc
    elif method == "banded":
        chol = banded_cholesky(K)
        w, v, err = subspace_iteration(
            chol, batch_operator(K), batch_operator(M), start_vectors(n, q), n_modes, tol, max_iter
        )
        if err > 1e-5:
            raise DataError(f"subspace iteration did not converge (relative residual {err:.2g})")
        w, v = w[0], v[0]
    else:
        raise DataError(f"unknown eigen-solver method {method!r}; use 'banded' or 'dense'")
    # deterministic sign: the entry of largest magnitude is positive
    pick = np.argmax(np.abs(v), axis=0)
    v = v * np.sign(v[pick, np.arange(v.shape[1])])
    return w, v


@dataclass(frozen=True)
class FEModes:
    """Lowest modes of an FE model: fn in Hz, omega2 in (rad/s)^2, mass-normalised shapes."""

    fn_hz: np.ndarray
    omega2: np.ndarray
    shapes: np.ndarray
    model: FEModel


def beam_modes(
    beam: Beam, n_modes: int = 4, *, method: Literal["banded", "dense"] = "banded"
) -> FEModes:
    """Natural frequencies (Hz) and mass-normalised mode shapes of the FE beam.

    With ``Beam()`` (100 elements, b = 0.05 m, h = 0.01 m, L = 0.65 m,
    E = 210 GPa, rho = 7800 kg/m^3) this gives the paper's Table 3:
    19.84, 124.33, 348.12, 682.18 Hz.
    """
    model = assemble_beam(beam)
    omega2, shapes = lowest_modes(model.K, model.M, n_modes, method=method)
    return FEModes(fn_hz=np.sqrt(omega2) / (2 * np.pi), omega2=omega2, shapes=shapes, model=model)


def beam_frequencies(beam: Beam, n_modes: int = 4) -> np.ndarray:
    """Natural frequencies in Hz of the lowest ``n_modes`` FE modes of ``beam``.

    Examples
    --------
    The paper's steel beam (Table 3 initial model, 100 elements):

    >>> beam_frequencies(Beam(), 4).round(2)
    array([ 19.84, 124.33, 348.12, 682.18])
    """
    return beam_modes(beam, n_modes).fn_hz


def frequency_scale(
    thickness_m: np.ndarray | float,
    youngs_modulus_pa: np.ndarray | float,
    density_kg_m3: np.ndarray | float,
    length_m: np.ndarray | float,
) -> np.ndarray:
    """h sqrt(E / rho) / L^2 in 1/s: every natural frequency of a uniform
    clamped-free beam without point masses is proportional to it,
    f_r = (beta_r L)^2 / (2 pi sqrt(12)) * h sqrt(E / rho) / L^2 (I/A = h^2/12;
    the width b cancels). It is all that frequencies can identify of the five
    update parameters (:func:`ema_pipeline.fe.identifiable_combination`).

    Examples
    --------
    The paper's beam, and its first frequency with beta_1 L = 1.875104 (Table 3: 19.84 Hz):

    >>> scale = frequency_scale(0.01, 210e9, 7800.0, 0.65)  # 0.01 * sqrt(210e9/7800) / 0.65^2
    >>> float(scale.round(3)), float((1.875104**2 / (2 * np.pi * np.sqrt(12)) * scale).round(2))
    (122.811, 19.84)
    """
    h, e, rho, length = (np.asarray(v, dtype=float)
                         for v in (thickness_m, youngs_modulus_pa, density_kg_m3, length_m))
    return h * np.sqrt(e / rho) / length**2
