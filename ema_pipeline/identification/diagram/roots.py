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
of the previous order plus new points on the unit circle.

* **Half the points.** The coefficients are real, so the roots are real or
  conjugate pairs: the iteration runs on the upper half plane and the real
  axis only (:func:`real_aberth_roots`), each upper point standing for its
  pair.
* **The last few at once.** Where the number of real roots changes from one
  order to the next (a pair of real roots becomes a complex pair, or the
  other way), the points concerned cannot converge in that form; and the
  last few points of any order take several sweeps of fixed cost. Both are
  replaced by the roots the converged ones leave (:func:`remaining_roots`,
  Newton's identities), which one or two sweeps of the general iteration
  polish.
* **Powers by blocks.** Each sweep evaluates the polynomial and its
  derivative at every point from powers built by blocks
  (:class:`BlockedPolynomial`).

A root has converged when its residual is within the polynomial's
rounding error (backward error below ``4 n eps``) or its last correction
was below :data:`CUBIC_STOP` of it (the iteration converges cubically: the
error left is at the rounding level), the accuracy the companion
eigenvalues give. An order whose iteration does not converge, or gives two
coincident roots (:func:`distinct`), falls back to the companion
eigenvalues; below :data:`ABERTH_MIN_ORDER` the eigenvalues are cheaper and
are used directly. ``tests/test_diagram_roots.py`` checks the roots
against ``numpy.roots`` on the diagrams of simulated and measured FRFs.
An order-480 diagram of the pyFRF recording: 1.5 s by the eigenvalues,
0.35 s by the general iteration, 0.12 s by this one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Below this polynomial order the companion eigenvalues cost less than the
#: iteration (its sweeps are numpy calls of fixed overhead): measured on the
#: diagrams of the measured beam and the pyFRF recording.
ABERTH_MIN_ORDER = 80

#: Sweeps after which an order still not converged falls back to the eigenvalues.
ABERTH_MAX_SWEEPS = 80

#: :func:`real_aberth_roots` replaces the points left by the roots the
#: converged ones leave (:func:`remaining_roots`) once their number has not
#: fallen for this many sweeps (a changed number of real roots stalls for
#: good) ...
STALL_SWEEPS = 3

#: ... or once no more than this many are left (of an order's 8-12 sweeps
#: on the diagrams of the measured beam and the pyFRF recording, the last
#: three or four move these few points; 2, 4 and 8 measured: 4 the fastest).
FEW_POINTS = 4

#: A root within this of its magnitude from the real axis is real, as the
#: eigenvalue solver returns real eigenvalues (:func:`on_real_axis`).
REAL_AXIS_REL = 1e-10

_EPS = float(np.finfo(float).eps)

#: A root whose last step was below this (relative) is converged: the
#: Aberth iteration converges cubically near a simple root, so the error
#: left is of the order of the step cubed.
CUBIC_STOP = 1e-7


def companion_eigenvalues(alpha: np.ndarray) -> np.ndarray:
    """Roots of the monic matrix polynomial ``sum_j alpha[j] z^j`` (``alpha``
    (n+1, n_in, n_in), ``alpha[n]`` = I): the eigenvalues of the block
    companion matrix of alpha^T (LAPACK, balanced), formed transposed: its
    identity blocks below the diagonal and the coefficients in its last
    block column, so that with one reference it is upper Hessenberg, as
    ``numpy.roots`` forms it, and LAPACK's reduction to Hessenberg form has
    nothing to do (a paper file's 64 orders up to 64: 13.8 -> 11.4 ms; the
    eigenvalues agree to rounding, 6e-14 relative).

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
        C[n_in:, : N - n_in] = np.eye(N - n_in)
    C[:, N - n_in :] = -alpha[:n].reshape(N, n_in)
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


@dataclass(frozen=True)
class BlockedPolynomial:
    """A polynomial ``p(x) = sum_k c_k x^k`` of degree ``n``, its reversal
    ``q(x) = x^n p(1/x)`` and both derivatives, laid out for evaluation at
    many points by blocks of ``block`` powers: ``p(x) = sum_m (x^b)^m
    P_m(x)`` with ``P_m(x) = sum_(r<b) c_(bm+r) x^r``. With b about sqrt(n)
    the powers of each point are two cumulative products of b and n/b
    terms, not one of n, and the sums are one real matrix product (the
    coefficients are real): a third of the time of the n powers at order
    480 (:func:`newton_corrections`).

    Attributes
    ----------
    n : the degree.
    block : b, the powers per block.
    coeffs : (b, 4 * n_blocks) real  ``coeffs[r, j * n_blocks + m]`` is
        coefficient ``bm + r`` of p, q, p' and q' (j = 0..3), zero past the
        degree.
    magnitudes : (b, 2 * n_blocks) real  the magnitudes of those of p and q
        (the backward error's bound).
    """

    n: int
    block: int
    coeffs: np.ndarray
    magnitudes: np.ndarray

    @classmethod
    def of(cls, coeffs: np.ndarray) -> BlockedPolynomial:
        """The layout of the real polynomial ``coeffs`` (ascending powers).

        Examples
        --------
        >>> BlockedPolynomial.of(np.arange(1.0, 11.0)).coeffs.shape  # b = 3, 4 blocks
        (3, 16)
        """
        c = np.asarray(coeffs, dtype=float)
        n = c.size - 1
        b = max(int(np.sqrt(n + 1)), 1)
        m = -(-(n + 1) // b)
        both = np.stack([c, c[::-1]], axis=1)  # p and q
        padded = np.zeros((m * b, 4))
        padded[: n + 1, :2] = both
        padded[:n, 2:] = both[1:] * np.arange(1, n + 1)[:, None]  # p', q' (power k: (k+1) c_(k+1))
        blocks = padded.reshape(m, b, 4).transpose(1, 2, 0)  # (b, 4, m)
        return cls(n=n, block=b, coeffs=blocks.reshape(b, 4 * m).copy(),
                   magnitudes=np.abs(blocks[:, :2]).reshape(b, 2 * m).copy())


def blocked_powers(x: np.ndarray, block: int, n_blocks: int) -> tuple[np.ndarray, np.ndarray]:
    """The powers ``x^0 .. x^(block-1)`` (m, block) and ``(x^block)^0 ..
    (x^block)^(n_blocks-1)`` (m, n_blocks) of the points ``x`` (m,), by
    cumulative products."""
    low = np.empty((x.size, block), dtype=x.dtype)
    low[:, 0] = 1.0
    low[:, 1:] = x[:, None]
    np.cumprod(low[:, 1:], axis=1, out=low[:, 1:])
    high = np.empty((x.size, n_blocks), dtype=x.dtype)
    high[:, 0] = 1.0
    high[:, 1:] = (low[:, -1] * x)[:, None]
    np.cumprod(high[:, 1:], axis=1, out=high[:, 1:])
    return low, high


def newton_corrections(poly: BlockedPolynomial, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton corrections p(z)/p'(z) of the polynomial ``poly`` at the points
    ``z``, and the backward error of p(z), |p(z)| / sum_j |c_j| |z|^j.

    The polynomial is evaluated in x = z where |z| <= 1 and in x = 1/z (the
    reversed polynomial) elsewhere, so no power overflows; by blocks of
    powers (:class:`BlockedPolynomial`).

    Examples
    --------
    >>> poly = BlockedPolynomial.of(np.array([-4.0, 0.0, 1.0]))
    >>> N, err = newton_corrections(poly, np.array([1.0 + 0j, 3.0 + 0j]))
    >>> N.real.round(6).tolist()  # (z^2 - 4) / 2z
    [-1.5, 0.833333]
    """
    n, b = poly.n, poly.block
    m = poly.magnitudes.shape[1] // 2
    az = np.abs(z)
    outside = az > 1.0
    x = np.where(outside, 1.0 / np.where(outside, z, 1.0), z)
    low, high = blocked_powers(x, b, m)
    # the block sums of p, q, p', q' at every point: real and imaginary
    # parts of the low powers in one real product
    k = z.size
    sums = np.concatenate([low.real, low.imag]) @ poly.coeffs  # (2k, 4m)
    blocks = (sums[:k] + 1j * sums[k:]).reshape(k, 4, m)
    value = np.einsum("ijm,im->ij", blocks, high)
    # the bound's powers |x|^j: the magnitudes of the powers of x
    bound = np.einsum("ijm,im->ij", (np.abs(low) @ poly.magnitudes).reshape(k, 2, m),
                      np.abs(high))
    rows, col = np.arange(k), outside.astype(int)
    p, dp, e = value[rows, col], value[rows, col + 2], bound[rows, col]
    with np.errstate(divide="ignore", invalid="ignore"):
        # outside: p(z) = z^n q(1/z), so p/p' = z q / (n q - x q')
        correction = np.where(outside, z * p / (n * p - x * dp), p / dp)
    return correction, np.abs(p) / np.maximum(e, np.finfo(float).tiny)


def aberth_sweeps(poly: BlockedPolynomial, z: np.ndarray, active: np.ndarray, *,
                  n_upper: int = 0, max_sweeps: int = ABERTH_MAX_SWEEPS,
                  stall: int = 0, few: int = 0) -> tuple[np.ndarray, np.ndarray, int, bool]:
    """Aberth-Ehrlich sweeps of the points ``z`` (updated in place) whose
    ``active`` flag is set, until none is (a converged point is frozen).

    With ``n_upper`` 0 the points are all the roots' approximations.
    Otherwise ``z[:n_upper]`` stand for themselves and their conjugates and
    ``z[n_upper:]`` are real and stay real: the approximations of a real
    polynomial's roots as a conjugate-symmetric set, of which half is
    iterated. ``stall`` > 0 stops once the number of active points has not
    fallen for that many sweeps.

    Returns the points, the active flags, the sweeps made and whether every
    step was finite.

    Examples
    --------
    >>> poly = BlockedPolynomial.of(np.array([5.0, -2.0, 1.0]))  # z^2 - 2 z + 5: 1 +- 2j
    >>> z, active, _, ok = aberth_sweeps(poly, np.array([0.5 + 1.5j]), np.ones(1, bool),
    ...                                  n_upper=1)
    >>> np.round(z, 12).tolist(), bool(active.any()), ok
    ([(1+2j)], False, True)
    """
    n = poly.n
    counts: list[int] = []
    for sweep in range(max_sweeps):
        idx = np.flatnonzero(active)
        counts.append(idx.size)
        if idx.size <= few or (stall and sweep >= stall and counts[-1] == counts[-1 - stall]):
            return z, active, sweep, True
        zi = z[idx]
        newton, backward = newton_corrections(poly, zi)
        others = np.concatenate([z, np.conj(z[:n_upper])]) if n_upper else z
        inverse = np.subtract.outer(zi, others)  # 1 / (z_i - z_j), in place
        inverse[np.arange(idx.size), idx] = np.inf  # z is the head of others
        with np.errstate(divide="ignore", invalid="ignore"):
            np.reciprocal(inverse, out=inverse)
            step = newton / (1.0 - newton * inverse.sum(axis=1))
        if not np.all(np.isfinite(step)):
            return z, active, sweep + 1, False
        if n_upper:  # a real point's step is real (its imaginary part: rounding)
            real = idx >= n_upper
            step[real] = step[real].real
        zi -= step
        z[idx] = zi
        # converged: the residual within the rounding error of p, or a step
        # below CUBIC_STOP: the iteration converges cubically, the root is
        # then at the rounding level (a cluster's roots take smaller steps)
        done = (backward <= 4 * n * _EPS) | (np.abs(step) <= CUBIC_STOP * np.abs(zi))
        active[idx[done]] = False
    return z, active, max_sweeps, True


def distinct(z: np.ndarray, rel: float = 1e-8) -> bool:
    """Whether no two of the points ``z`` lie within ``rel`` of their
    magnitude of each other (two approximations that converged to one root).
    The points are sorted by real part and each compared with those whose
    real part is that close: O(n log n), not the n^2 distances.

    Examples
    --------
    >>> distinct(np.array([1 + 1j, 1 - 1j, 2.0])), distinct(np.array([1 + 1j, 2.0, 1 + 1j]))
    (True, False)
    """
    zs = z[np.argsort(z.real, kind="stable")]
    tol = rel * np.maximum(np.abs(zs), 1e-300)
    # |z_j| <= |z_i| (1 + rel): twice the tolerance holds every close pair's
    span = np.searchsorted(zs.real, zs.real + 2 * tol, side="right") - np.arange(zs.size)
    for k in range(1, int(span.max(initial=1))):
        i = np.flatnonzero(span > k)
        if np.any(np.abs(zs[i + k] - zs[i]) <= np.maximum(tol[i], tol[i + k])):
            return False
    return True


def remaining_roots(coeffs: np.ndarray, known: np.ndarray) -> np.ndarray:
    """The roots of the monic polynomial ``coeffs`` (ascending powers, degree
    n) other than the n - k roots ``known``: the k roots whose power sums
    are those of all roots (Newton's identities on the top k coefficients)
    less those of ``known``. Accurate to about n eps over the roots' gaps;
    a start for a few sweeps, not an answer.

    Examples
    --------
    >>> c = np.polynomial.polynomial.polyfromroots([2.0, -1.0, 1 + 1j, 1 - 1j]).real
    >>> np.sort(remaining_roots(c, np.array([1 + 1j, 1 - 1j])).real).round(9).tolist()
    [-1.0, 2.0]
    """
    n, k = coeffs.size - 1, coeffs.size - 1 - known.size
    a = coeffs / coeffs[-1]
    total = np.zeros(k + 1, dtype=complex)  # power sums of all roots (Newton's identities)
    for j in range(1, k + 1):
        total[j] = -(j * a[n - j] + np.dot(a[n - j + 1 : n], total[1:j]))
    own = total[1:] - np.sum(known[:, None] ** np.arange(1, k + 1), axis=0)
    e = np.zeros(k + 1, dtype=complex)  # their elementary symmetric functions
    e[0] = 1.0
    for j in range(1, k + 1):
        e[j] = np.dot(e[j - 1 :: -1][:j] * (-1.0) ** np.arange(j), own[:j]) / j
    return np.roots(e * (-1.0) ** np.arange(k + 1))


def real_aberth_roots(coeffs: np.ndarray, upper: np.ndarray, real: np.ndarray,
                      max_sweeps: int = ABERTH_MAX_SWEEPS) -> tuple[np.ndarray, bool]:
    """Roots of the real polynomial ``coeffs`` (degree n) from the
    conjugate-symmetric start of the points ``upper`` and their conjugates
    and the real points ``real`` (2 upper.size + real.size = n); and whether
    every root converged (no two of them coincident).

    A real polynomial's roots are real or conjugate pairs, so the iteration
    runs on the upper half plane and the real axis only
    (:func:`aberth_sweeps` with ``n_upper``): half the points to evaluate
    and half the pair sums of the general iteration. Where the number of
    real roots differs from that of the start (from one order to the next
    two real roots become a pair, or a pair two real roots), some points
    cannot converge in that form: once the points left stop converging for
    :data:`STALL_SWEEPS` sweeps, or once no more than :data:`FEW_POINTS`
    are left, they are replaced by the roots the converged ones leave
    (:func:`remaining_roots`) and go on by the general iteration.

    Examples
    --------
    >>> c = np.polynomial.polynomial.polyfromroots([1 + 2j, 1 - 2j, 0.5, -0.5]).real
    >>> z, ok = real_aberth_roots(c, np.array([0.8 + 1.5j]), np.array([0.3, -0.9]))
    >>> np.sort_complex(np.round(z, 12)).tolist(), ok
    ([(-0.5+0j), (0.5+0j), (1-2j), (1+2j)], True)
    """
    poly = BlockedPolynomial.of(coeffs)
    n_upper = upper.size
    z = np.concatenate([upper, real]).astype(complex)
    z, active, used, finite = aberth_sweeps(poly, z, np.ones(z.size, bool), n_upper=n_upper,
                                            max_sweeps=max_sweeps, stall=STALL_SWEEPS,
                                            few=FEW_POINTS)
    roots = np.concatenate([z[:n_upper], np.conj(z[:n_upper]), z[n_upper:]])
    if finite and active.any():
        left = np.concatenate([active[:n_upper], active[:n_upper], active[n_upper:]])
        roots[left] = remaining_roots(coeffs, roots[~left])
        roots, left, _, finite = aberth_sweeps(poly, roots, left, max_sweeps=max_sweeps - used)
        active = left
    return roots, bool(finite and not active.any() and distinct(roots))


def on_real_axis(z: np.ndarray) -> np.ndarray:
    """Which of the points ``z`` lie within :data:`REAL_AXIS_REL` of their
    magnitude from the real axis.

    Examples
    --------
    >>> on_real_axis(np.array([1.0 + 1e-12j, 1.0 + 1e-3j])).tolist()
    [True, False]
    """
    return np.abs(z.imag) <= REAL_AXIS_REL * np.abs(z)


def conjugate_start(previous: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Conjugate-symmetric start points for a real polynomial of degree ``n``
    (:func:`real_aberth_roots`): the roots ``previous`` of a lower order in
    the upper half plane and on the real axis (:func:`on_real_axis`), new
    points spread over the upper unit circle and, for an odd number of new
    points, one real point; None where ``previous`` holds
    more than n roots so counted.

    Examples
    --------
    >>> upper, real = conjugate_start(np.array([0.5 + 0.5j, 0.5 - 0.5j, 0.2]), 6)
    >>> upper.size, real.tolist()
    (2, [0.2, 0.31])
    """
    real_axis = on_real_axis(previous)
    upper = previous[~real_axis & (previous.imag > 0)]
    real = previous[real_axis].real
    k = n - 2 * upper.size - real.size
    if k < 0:
        return None
    angle = (np.arange(k // 2) + 0.5) * (0.98 * np.pi / max(k // 2, 1)) + 0.01
    return (np.concatenate([upper, np.exp(1j * angle)]),
            np.concatenate([real, np.full(k % 2, 0.31)]))


def diagram_roots(coeffs: list[np.ndarray]) -> list[np.ndarray]:
    """Roots of each polynomial of ``coeffs`` (ascending powers, leading
    coefficient 1, ascending degree: the denominators of one diagram).

    Degrees below :data:`ABERTH_MIN_ORDER` by the companion eigenvalues, the
    others by :func:`real_aberth_roots` started from the previous order's
    roots (:func:`conjugate_start`), with the eigenvalues as the fallback.
    Roots on the real axis (:func:`on_real_axis`) are made real, as the
    eigenvalue solver returns real eigenvalues.

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
        start = conjugate_start(previous, n) if n >= ABERTH_MIN_ORDER else None
        if start is not None:
            z, ok = real_aberth_roots(c, *start)
            if ok:
                z = np.where(on_real_axis(z), z.real + 0j, z)
        if not ok:
            z = companion_roots(c)
        out.append(z)
        previous = z
    return out
