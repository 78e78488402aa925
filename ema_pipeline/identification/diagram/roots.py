"""Roots of the scalar denominators of one stabilization diagram, order after order.

With one reference the pLSCF denominator of order n is a real polynomial
``A(z) = sum_j c_j z^j`` and its poles are its roots. ``numpy.roots`` and
:func:`companion_eigenvalues` (the block companion of any number of
references) find them as the eigenvalues of the companion matrix: O(n^3) per order, the
largest cost of a high-order diagram (40 orders up to 480: about 1.5 s). The
denominators of one diagram share most of their roots (every physical pole
and many noise poles persist from one order to the next), which an
eigenvalue solver cannot use. Neither numpy nor scipy offers a root finder
that starts from given estimates, hence this module: the Aberth-Ehrlich
simultaneous iteration (Bini 1996), O(n^2) per sweep, started from the roots
of the previous order plus new points on the unit circle. A root has
converged when its residual is within the polynomial's rounding error
(backward error below ``4 n eps``) or its last correction was below
:data:`CUBIC_STOP` of it (the iteration converges cubically: the error left
is at the rounding level), the accuracy the companion eigenvalues give.
An order whose iteration does not converge, or gives two coincident roots,
falls back to the companion eigenvalues; below :data:`ABERTH_MIN_ORDER`
the eigenvalues are cheaper and are used directly.
``tests/test_diagram_roots.py`` checks the roots against ``numpy.roots`` on
the diagrams of simulated and measured FRFs.
"""

from __future__ import annotations

import numpy as np

#: Below this polynomial order the companion eigenvalues cost less than the
#: iteration (its sweeps are numpy calls of fixed overhead): measured on the
#: diagrams of the measured beam and the pyFRF recording.
ABERTH_MIN_ORDER = 80

#: Sweeps after which an order still not converged falls back to the eigenvalues.
ABERTH_MAX_SWEEPS = 80

_EPS = float(np.finfo(float).eps)

#: A root whose last step was below this (relative) is converged: the
#: Aberth iteration converges cubically near a simple root, so the error
#: left is of the order of the step cubed.
CUBIC_STOP = 1e-7


def companion_eigenvalues(alpha: np.ndarray) -> np.ndarray:
    """Roots of the monic matrix polynomial ``sum_j alpha[j] z^j`` (``alpha``
    (n+1, n_in, n_in), ``alpha[n]`` = I): the eigenvalues of the block
    companion matrix of alpha^T (LAPACK, balanced).

    Examples
    --------
    >>> alpha = np.array([2.0, -3.0, 1.0])[:, None, None]  # z^2 - 3 z + 2
    >>> np.sort(companion_eigenvalues(alpha).real).tolist()
    [1.0, 2.0]
    """
    n, n_in = alpha.shape[0] - 1, alpha.shape[1]
    N = n * n_in
    C = np.zeros((N, N))
    if N > n_in:
        C[: N - n_in, n_in:] = np.eye(N - n_in)
    C[N - n_in :, :] = -np.concatenate([alpha[j].T for j in range(n)], axis=1)
    return np.linalg.eigvals(C)


def companion_roots(coeffs: np.ndarray) -> np.ndarray:
    """Roots of ``sum_j coeffs[j] z^j`` as the eigenvalues of its companion
    matrix (:func:`companion_eigenvalues` of the monic polynomial), as
    complex numbers.

    Examples
    --------
    >>> np.sort_complex(companion_roots(np.array([2.0, -3.0, 1.0]))).real.tolist()
    [1.0, 2.0]
    """
    return companion_eigenvalues((coeffs / coeffs[-1])[:, None, None]).astype(complex)


def newton_corrections(coeffs: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton corrections p(z)/p'(z) of the polynomial ``coeffs`` (ascending
    powers) at the points ``z``, and the backward error of p(z),
    |p(z)| / sum_j |c_j| |z|^j.

    The polynomial is evaluated in x = z where |z| <= 1 and in x = 1/z (the
    reversed polynomial) elsewhere, so no power overflows; the powers of x
    for all points are one cumulative product and the sums matrix products.

    Examples
    --------
    >>> N, err = newton_corrections(np.array([-4.0, 0.0, 1.0]), np.array([1.0 + 0j, 3.0 + 0j]))
    >>> N.real.round(6).tolist()  # (z^2 - 4) / 2z
    [-1.5, 0.833333]
    """
    n = coeffs.size - 1
    az = np.abs(z)
    outside = az > 1.0
    x = np.where(outside, 1.0 / np.where(outside, z, 1.0), z)
    powers = np.empty((z.size, n + 1), dtype=complex)
    powers[:, 0] = 1.0
    powers[:, 1:] = x[:, None]
    np.cumprod(powers[:, 1:], axis=1, out=powers[:, 1:])
    magnitude = np.empty((z.size, n + 1))  # |x|^k, real: the bound's powers
    magnitude[:, 0] = 1.0
    magnitude[:, 1:] = np.where(outside, 1.0 / np.maximum(az, 1.0), az)[:, None]
    np.cumprod(magnitude[:, 1:], axis=1, out=magnitude[:, 1:])
    # column 0: p in x = z; column 1: the reversed polynomial q(x) = x^n p(1/x)
    # columns 2, 3: their derivatives (power k: (k + 1) c_(k+1)); one product
    both = np.stack([coeffs, coeffs[::-1]], axis=1)
    sums = np.zeros((n + 1, 4), dtype=complex)
    sums[:, :2] = both
    sums[:-1, 2:] = both[1:] * np.arange(1, n + 1)[:, None]
    value = powers @ sums
    bound = magnitude @ np.abs(both)
    rows, col = np.arange(z.size), outside.astype(int)
    p, dp, e = value[rows, col], value[rows, col + 2], bound[rows, col]
    with np.errstate(divide="ignore", invalid="ignore"):
        # outside: p(z) = z^n q(1/z), so p/p' = z q / (n q - x q')
        correction = np.where(outside, z * p / (n * p - x * dp), p / dp)
    return correction, np.abs(p) / np.maximum(e, np.finfo(float).tiny)


def aberth_roots(coeffs: np.ndarray, start: np.ndarray,
                 max_sweeps: int = ABERTH_MAX_SWEEPS) -> tuple[np.ndarray, bool]:
    """Roots of the polynomial ``coeffs`` (ascending powers, degree n) by the
    Aberth-Ehrlich iteration from the n points ``start``; and whether every
    root converged (no two of them coincident).

    Examples
    --------
    >>> roots, ok = aberth_roots(np.array([2.0, -3.0, 1.0]), np.array([0.5 + 0.5j, 3.0 - 0.2j]))
    >>> np.sort(roots.real).round(12).tolist(), ok
    ([1.0, 2.0], True)
    """
    n = coeffs.size - 1
    z = np.asarray(start, dtype=complex).copy()
    active = np.ones(n, dtype=bool)
    for _ in range(max_sweeps):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        newton, backward = newton_corrections(coeffs, z[idx])
        inverse = np.subtract.outer(z[idx], z)  # 1 / (z_i - z_j), in place
        inverse[np.arange(idx.size), idx] = np.inf
        with np.errstate(divide="ignore", invalid="ignore"):
            np.reciprocal(inverse, out=inverse)
            step = newton / (1.0 - newton * inverse.sum(axis=1))
        if not np.all(np.isfinite(step)):
            return z, False
        z[idx] -= step
        # converged: the residual within the rounding error of p, or a step
        # below CUBIC_STOP: the iteration converges cubically, the root is
        # then at the rounding level (a cluster's roots take smaller steps)
        done = (backward <= 4 * n * _EPS) | (np.abs(step) <= CUBIC_STOP * np.abs(z[idx]))
        active[idx[done]] = False
    if active.any():
        return z, False
    gap = np.abs(z[:, None] - z[None, :]) + np.diag(np.full(n, np.inf))
    return z, bool(np.all(gap.min(axis=1) > 1e-8 * np.maximum(np.abs(z), 1e-300)))


def next_start(previous: np.ndarray, n: int) -> np.ndarray:
    """Start points for a polynomial of degree ``n``: the roots ``previous``
    of a lower order and ``n - previous.size`` points spread over the unit
    circle (off the real axis, not conjugate to each other).

    Examples
    --------
    >>> next_start(np.array([0.5 + 0j]), 3).size
    3
    """
    k = n - previous.size
    angle = (np.arange(k) + 0.5) * (2 * np.pi / max(k, 1)) + 0.37
    return np.concatenate([previous, np.exp(1j * angle)])


def diagram_roots(coeffs: list[np.ndarray]) -> list[np.ndarray]:
    """Roots of each polynomial of ``coeffs`` (ascending powers, leading
    coefficient 1, ascending degree: the denominators of one diagram).

    Degrees below :data:`ABERTH_MIN_ORDER` by the companion eigenvalues, the
    others by :func:`aberth_roots` started from the previous order's roots
    (:func:`next_start`), with the eigenvalues as the fallback. Roots within
    1e-10 (relative) of the real axis are made real, as the eigenvalue
    solver returns real eigenvalues.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> polys = [np.append(rng.standard_normal(n), 1.0) for n in (90, 100)]
    >>> got = diagram_roots(polys)
    >>> ref = np.roots(polys[1][::-1])
    >>> distance = np.abs(got[1][:, None] - ref[None, :])
    >>> bool(distance.min(axis=0).max() < 1e-9 and distance.min(axis=1).max() < 1e-9)
    True
    """
    out: list[np.ndarray] = []
    previous = np.zeros(0, dtype=complex)
    for c in coeffs:
        n = c.size - 1
        ok = False
        if n >= ABERTH_MIN_ORDER and previous.size <= n:
            z, ok = aberth_roots(c, next_start(previous, n))
            if ok:
                z = np.where(np.abs(z.imag) <= 1e-10 * np.abs(z), z.real + 0j, z)
        if not ok:
            z = companion_roots(c)
        out.append(z)
        previous = z
    return out
