"""Least-squares frequency-domain (LSFD) residues and the fit indicators (MPC, MPD,
FRAC, error).

Pole-residue model of every FRF channel c = (output, reference), in the FRF's
own quantity (receptance, mobility or accelerance)::

    H_c(w) = sum_r [ a_cr / (jw - lambda_r) + conj(a_cr) / (jw - conj(lambda_r)) ]
             + LR_c * b_low(w) + UR_c * b_up(w)

with complex lower and upper residual terms b_low, b_up = (jw)^-2, 1 (receptance),
(jw)^-1, jw (mobility), 1, (jw)^2 (accelerance) (:func:`ema_pipeline.data.quantity_factor`).
The residue of the receptance is A_cr = a_cr / lambda_r^q with q = 0, 1, 2 for
the three quantities (:func:`ema_pipeline.data.quantity_power`), and the modal
constant 2j omega_dr A_cr equals phi_o phi_i for mass-normalised real modes.

Pole refinement lives in :mod:`ema_pipeline.identification.refinement.refine`, the noise
and covariance model in :mod:`ema_pipeline.identification.refinement.uncertainty`, the MAC
in :mod:`ema_pipeline.modal`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.linalg import lapack

from ema_pipeline.data import quantity_factor
from ema_pipeline.modal import mac_pairs


def residual_basis(freq_hz: np.ndarray, quantity: str) -> np.ndarray:
    """(n_freq, 2) lower and upper residual basis functions of the quantity:
    (jw)^(q-2) and (jw)^q, 0 where not finite (0 Hz)."""
    low = quantity_factor("accelerance", quantity, freq_hz)
    up = quantity_factor("receptance", quantity, freq_hz)
    return np.stack([low, up], axis=1)


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
    n_res = int(lower) + int(upper)
    m2 = 2 * poles.size
    # all columns written into one array (no concatenation of the two blocks)
    cols = np.empty((jw.shape[0], m2 + 2 * n_res), dtype=complex)
    cols[:, 0:m2:2] = g + gc
    cols[:, 1:m2:2] = 1j * (g - gc)
    if not n_res:  # the local fits' modal columns: no residual basis to build
        return cols
    res = residual_basis(freq_hz, quantity)[:, [k for k, on in enumerate((lower, upper)) if on]]
    cols[:, m2::2] = res
    cols[:, m2 + 1 :: 2] = 1j * res
    return cols


def column_scale(A: np.ndarray) -> np.ndarray:
    """Per column of the real (n, K) ``A``, max |A| (1 for a zero column): the
    scale that divides each column before a least-squares factorisation.
    Formed from the column maxima and minima, without the copy ``np.abs``
    would make (these reductions run on thousands of small local designs).

    Examples
    --------
    >>> column_scale(np.array([[1.0, -3.0, 0.0], [-2.0, 1.0, 0.0]])).tolist()
    [2.0, 3.0, 1.0]
    """
    scale = np.maximum(A.max(axis=0), -A.min(axis=0))
    scale[scale == 0] = 1.0
    return scale


def real_stack(B: np.ndarray) -> np.ndarray:
    """Real and imaginary parts stacked along the first axis, (2n, ...)."""
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


#: The LSFDs of one identification (:func:`reused_lsfds`), None outside one.
_REUSED: ContextVar[list | None] = ContextVar("ema_pipeline_reused_lsfds", default=None)

#: How many of an identification's latest LSFDs :func:`reused_lsfds` keeps,
#: and the most memory their synthesised FRFs and FRFs may take.
REUSED_LSFDS = 8
REUSED_BYTES = 64 * 2**20


@contextlib.contextmanager
def reused_lsfds() -> Iterator[None]:
    """Inside the block, :func:`lsfd` of the same lines, FRFs, poles and
    terms, bit for bit (:func:`same_bits`), as one of the block's
    :data:`REUSED_LSFDS` latest fits (within :data:`REUSED_BYTES`) gives that
    fit again (its arrays read-only) instead of solving again: the stages
    of one identification fit the same kept poles to the whole band
    several times (the close partners, the residual peaks, the band
    sensitivity, the final residues). The same numbers; a
    block inside a block shares its fits. Each fit is kept with copies of
    its lines, FRFs and poles, which a later call is compared with (a
    caller that changes its arrays in place gets a new fit).

    Examples
    --------
    >>> f = np.linspace(10.0, 30.0, 201)
    >>> pole = np.array([-1.0 + 2j * np.pi * 20.0])
    >>> H = (1 / (2j * np.pi * f - pole[0]))[None]
    >>> with reused_lsfds():
    ...     first, again = lsfd(f, H, pole, "receptance"), lsfd(f, H, pole, "receptance")
    >>> again is first, bool(np.allclose(first.a, lsfd(f, H, pole, "receptance").a))
    (True, True)
    """
    if _REUSED.get() is not None:
        yield
        return
    token = _REUSED.set([])
    try:
        yield
    finally:
        _REUSED.reset(token)


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether ``a`` and ``b`` hold the same numbers bit for bit: shape, type
    and every element's bytes (a NaN equals the same NaN; -0.0 is not 0.0).
    Views and copies of equal numbers are the same; the comparison reads
    each array once (about 14 us for a paper file's FRFs, where a hash of
    them took 290 us).

    Examples
    --------
    >>> x = np.arange(6.0).reshape(2, 3)
    >>> same_bits(x, x.copy()), same_bits(x, x + 1), same_bits(np.zeros(1), -np.zeros(1))
    (True, False, False)
    """
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    return bool(np.array_equal(np.ascontiguousarray(a).reshape(-1).view(np.uint8),
                               np.ascontiguousarray(b).reshape(-1).view(np.uint8)))


@dataclass(frozen=True)
class _Reused:
    """One fit of :func:`reused_lsfds`, with copies of what it was fitted to."""

    freq_hz: np.ndarray
    H: np.ndarray
    poles: np.ndarray
    terms: tuple[str, bool, bool]
    fit: LSFDFit

    def fits(self, freq_hz: np.ndarray, H: np.ndarray, poles: np.ndarray,
             terms: tuple[str, bool, bool]) -> bool:
        """Whether this is the fit of those arrays and terms (the cheapest
        comparisons first: most fits asked for differ in their poles)."""
        return (terms == self.terms and same_bits(poles, self.poles)
                and same_bits(freq_hz, self.freq_hz) and same_bits(H, self.H))

    @property
    def nbytes(self) -> int:
        return self.H.nbytes + self.fit.H_fit.nbytes


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

    Inside :func:`reused_lsfds` a fit of the same problem is given again.
    """
    reused = _REUSED.get()
    if reused is not None and weights is None:
        freq_hz, H = np.asarray(freq_hz, dtype=float), np.asarray(H)
        poles, terms = np.asarray(poles, dtype=complex), (quantity, lower, upper)
        for entry in reused:
            if entry.fits(freq_hz, H, poles, terms):
                return entry.fit
        fit = _solve(freq_hz, H, poles, quantity, lower, upper, None)
        for array in (fit.a, fit.lower, fit.upper, fit.H_fit):
            array.flags.writeable = False
        reused.append(_Reused(freq_hz.copy(), H.copy(), poles.copy(), terms, fit))
        del reused[:-REUSED_LSFDS]
        while reused and sum(entry.nbytes for entry in reused) > REUSED_BYTES:
            del reused[0]  # the oldest first: large FRF sets keep fewer
        return fit
    return _solve(freq_hz, H, poles, quantity, lower, upper, weights)


def lsfd_residual(freq_hz: np.ndarray, H: np.ndarray, poles: np.ndarray,
                  quantity: str) -> np.ndarray:
    """``H`` less the global LSFD of ``poles`` (with the residual terms of
    ``quantity``), (n_ch, n_freq).

    Examples
    --------
    >>> f = np.linspace(50.0, 150.0, 201)
    >>> lam = np.array([-2.0 + 2j * np.pi * 100.0])
    >>> H = (1 / (2j * np.pi * f - lam[0]) + 1 / (2j * np.pi * f - lam[0].conj()))[None]
    >>> bool(np.max(np.abs(lsfd_residual(f, H, lam, "receptance"))) < 1e-10)
    True
    """
    return np.asarray(H - lsfd(freq_hz, H, poles, quantity).H_fit)


#: A QR factor whose diagonal's smallest magnitude is below this fraction of
#: its largest is numerically singular: the least-squares solutions then
#: take the SVD's minimum-norm path (:func:`least_squares`, :func:`qr_factor`,
#: :class:`GrowingResidual`).
MIN_R_RATIO = 1e-6


def r_determined(qr: np.ndarray) -> bool:
    """Whether the R of a Householder factor ``qr`` (LAPACK ``dgeqrf``'s
    array: R on and above the diagonal) is finite and not numerically
    singular (:data:`MIN_R_RATIO`).

    Examples
    --------
    >>> r_determined(np.array([[2.0, 1.0], [0.5, 1.0]])), r_determined(np.diag([1.0, 1e-9]))
    (True, False)
    """
    d = np.abs(qr.diagonal())
    return bool(np.all(np.isfinite(d)) and d.min() >= MIN_R_RATIO * d.max())


def reflected(qr: np.ndarray, tau: np.ndarray, Y: np.ndarray,
              trans: str) -> tuple[np.ndarray, int]:
    """``Q^T Y`` (``trans`` "T") or ``Q Y`` ("N") from the reflectors of a
    Householder factor (``qr``, ``tau``: LAPACK ``dgeqrf``'s), without
    forming Q (``dormqr``); and LAPACK's ``info``."""
    out, _, info = lapack.dormqr("L", trans, qr, tau, Y, max(1, Y.shape[1] * 64))
    return out, info


def scaled_design(freq_hz: np.ndarray, poles: np.ndarray, quantity: str, lower: bool = True,
                  upper: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The design matrix B (:func:`design_matrix`), its real stack A in
    column-major order with each column divided by its scale
    (:func:`column_scale`) and the scales."""
    B = design_matrix(freq_hz, poles, quantity, lower, upper)
    # real_stack(B) in column-major order: LAPACK's QR takes it without a
    # copy, and the column maxima run down contiguous columns
    n = B.shape[0]
    A = np.empty((2 * n, B.shape[1]), order="F")
    A[:n], A[n:] = B.real, B.imag
    scale = column_scale(A)
    A /= scale
    return B, A, scale


def _solve(freq_hz: np.ndarray, H: np.ndarray, poles: np.ndarray, quantity: str, lower: bool,
           upper: bool, weights: np.ndarray | None) -> LSFDFit:
    """:func:`lsfd` solved."""
    B, A, scale = scaled_design(freq_hz, poles, quantity, lower, upper)
    Y = real_stack(np.asarray(H).T)
    if weights is not None:  # (unit weights would multiply by 1.0: nothing)
        w = np.asarray(weights, dtype=float)
        w2 = np.concatenate([w, w])[:, None]
        A *= w2
        Y = Y * w2
    X = least_squares(A, Y) / scale[:, None]
    m = poles.size
    a = X[0 : 2 * m : 2] + 1j * X[1 : 2 * m : 2]
    rest = X[2 * m :]
    res = rest[0::2] + 1j * rest[1::2]
    zeros = np.zeros(H.shape[0], dtype=complex)
    low = res[0] if lower else zeros
    up = res[int(lower)] if upper else zeros
    H_fit = (B @ X).T
    return LSFDFit(a=a, lower=low, upper=up, H_fit=H_fit)


def least_squares(A: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Least-squares solution X of A X = Y for one tall real matrix A (n, K)
    and Y (n, n_rhs): Householder QR (LAPACK ``dgeqrf``), Q^T Y applied from
    its reflectors (``dormqr``) and back substitution, without forming Q
    (half the cost of :func:`householder_qr` for the few right-hand sides of
    an LSFD). A numerically singular A (:func:`r_determined` false) goes to
    :func:`qr_factor`, whose SVD gives the minimum-norm solution.

    Examples
    --------
    >>> A = np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 2.0]])
    >>> least_squares(A, A @ np.array([[1.0], [2.0]])).ravel().round(12).tolist()
    [1.0, 2.0]
    """
    n, k = A.shape
    if A.dtype == np.float64 and Y.dtype == np.float64 and n >= k > 0:
        QtY = None
        if k >= BLOCKED_QR_MIN_COLUMNS:
            # the blocked Householder QR (compact WY, dgeqrt) and its Q^T Y
            # (dgemqrt): matrix products where dgeqrf's unblocked code for
            # fewer than 128 columns updates one column at a time
            qr, T, info = lapack.dgeqrt(QR_BLOCK, A)
            if info == 0 and r_determined(qr):
                QtY, info = lapack.dgemqrt(qr, T, Y, side="L", trans="T")
        else:
            qr, tau, _, info = lapack.dgeqrf(A)
            if info == 0 and r_determined(qr):
                QtY, info = reflected(qr, tau, Y, "T")
        if QtY is not None and info == 0 and np.all(np.isfinite(QtY[:k])):
            X, info = lapack.dtrtrs(qr[:k], QtY[:k], lower=0)
            if info == 0:
                return np.asarray(X)
    Q, R, triangular = qr_factor(A)
    return solve_r(R, Q.T @ Y, triangular)


#: Columns from which :func:`least_squares` factorises with LAPACK's blocked
#: Householder QR (``dgeqrt``, blocks of :data:`QR_BLOCK` columns) instead of
#: ``dgeqrf``, whose blocked code starts only at 128 columns: a whole band's
#: LSFD of 35 poles over 4487 lines (8972 x 74) 14.4 -> 4.9 ms, 8972 x 40
#: 3.0 -> 1.7 ms, 16386 x 20 1.6 -> 1.1 ms; below 16 columns no faster. The
#: same factorisation to rounding (both are Householder's).
BLOCKED_QR_MIN_COLUMNS = 16
QR_BLOCK = 16


class GrowingResidual:
    """The residual ``H - H_fit`` of the global LSFD (:func:`lsfd`, lower and
    upper residual terms) of a pole set that grows one pole at a time: the
    residual search adds each start pole to the LSFD before it seeks the
    next peak (:func:`~ema_pipeline.identification.selection.residual_search.residual_peaks`).

    The first residual is :func:`lsfd`'s (reused where a stage fitted the
    same poles). A pole added extends the Householder QR of the scaled
    design (LAPACK ``dgeqrf``, as :func:`least_squares` has it): its two
    columns are brought to the factor by the reflectors (``dormqr``) and
    factorised below them, and Q^T Y follows. That is O(n k) per pole where
    a new LSFD is O(n k^2): on the pyFRF recording (4487 lines, 36-42 poles)
    about 3 ms against 25 ms. The residual is the LSFD's to rounding (the
    columns' order and scaling differ; the least-squares residual does not
    depend on them). Where the design becomes numerically singular
    (:func:`r_determined`, as in :func:`least_squares`), a new :func:`lsfd`
    gives it (its minimum-norm fit).

    Examples
    --------
    >>> f = np.linspace(50.0, 150.0, 401)
    >>> jw = 2j * np.pi * f
    >>> lam = np.array([-2.0 + 2j * np.pi * 80.0, -1.5 + 2j * np.pi * 120.0])
    >>> H = sum(1 / (jw - p) + 1 / (jw - p.conj()) for p in lam)[None]
    >>> grow = GrowingResidual(f, H, lam[:1], "receptance")
    >>> bool(np.abs(grow.residual()).max() > 0.1)
    True
    >>> grow.add(lam[1])
    >>> bool(np.abs(grow.residual()).max() < 1e-10)
    True
    """

    def __init__(self, freq_hz: np.ndarray, H: np.ndarray, poles: np.ndarray,
                 quantity: str) -> None:
        self.freq_hz = np.asarray(freq_hz, dtype=float)
        self.H = np.asarray(H)
        self.poles = np.asarray(poles, dtype=complex)
        self.quantity = quantity
        self.factor: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # qr, tau, Q^T Y
        self.fresh = True  # the residual is lsfd()'s: no factor yet

    def residual(self) -> np.ndarray:
        """(n_ch, n_freq) complex  ``H`` less the LSFD of the poles so far."""
        if self.factor is None:
            return lsfd_residual(self.freq_hz, self.H, self.poles, self.quantity)
        qr, tau, qty = self.factor
        k = qr.shape[1]
        rest = qty.copy()
        rest[:k] = 0.0  # (I - Q1 Q1^T) Y = Q [0; Q2^T Y]
        r, info = reflected(qr, tau, rest, "N")
        if info != 0:  # pragma: no cover - LAPACK argument errors only
            raise np.linalg.LinAlgError(f"dormqr failed (info {info})")
        n = self.freq_hz.size
        return np.asarray(r[:n] + 1j * r[n:]).T

    def add(self, pole: complex) -> None:
        """Add ``pole`` (Im > 0, rad/s) to the LSFD."""
        if self.fresh:  # the first pole added: factorise the design so far
            self.fresh = False
            self.factor = self.factorised()
        self.poles = np.append(self.poles, complex(pole))
        if self.factor is None:
            return
        qr, tau, qty = self.factor
        k = qr.shape[1]
        C = scaled_design(self.freq_hz, np.array([pole]), self.quantity,
                          lower=False, upper=False)[1]
        W, info = reflected(qr, tau, C, "T")
        low, tau2, _, info2 = lapack.dgeqrf(np.asfortranarray(W[k:]))
        qty_low, info3 = reflected(low, tau2, np.asfortranarray(qty[k:]), "T")
        grown = np.empty((qr.shape[0], k + 2), order="F")
        grown[:, :k] = qr
        grown[:k, k:] = W[:k]
        grown[k:, k:] = low
        if info or info2 or info3 or not r_determined(grown):
            self.factor = None  # numerically singular: lsfd()'s minimum-norm fit from now on
            return
        qty = qty.copy()
        qty[k:] = qty_low
        self.factor = (grown, np.concatenate([tau, tau2]), qty)

    def factorised(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The Householder QR of the scaled design of the poles so far and
        Q^T Y; None where it is numerically singular."""
        A = scaled_design(self.freq_hz, self.poles, self.quantity)[1]
        qr, tau, _, info = lapack.dgeqrf(A)
        if info != 0 or not r_determined(qr):
            return None
        qty, info = reflected(qr, tau, np.asfortranarray(real_stack(self.H.T)), "T")
        return (qr, tau, qty) if info == 0 else None


def batched_qr(A: np.ndarray, rcond: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """Thin factorisation A = Q R of a stack of tall matrices (..., n, K), for
    least squares: X = solve(R, Q^T Y) and the projector Q Q^T.

    A single matrix: Householder QR (LAPACK, :func:`householder_qr`).
    Stacks: CholeskyQR2 (two rounds of Q = A R^-1 with
    R^T R = A^T A): as accurate as Householder for the moderately conditioned,
    column-scaled design matrices here, and all matrix products (numpy's
    batched Householder QR is ~20x slower). When the matrix is numerically
    singular -- near-coincident poles give nearly equal columns -- the
    Cholesky factorisation fails or the diagonal of R spans more than 1e6;
    then it is factorised by SVD instead,
    A = U S V^T: Q = U with the columns of singular values below ``rcond``
    times the largest set to zero, R = max(S, rcond S_max) V^T. ``solve(R, Q^T Y)``
    is then the minimum-norm (truncated-SVD) least-squares solution and Q Q^T
    the projector on the numerical range of A, so callers need no special case.

    Examples
    --------
    Two equal columns (a coincident pole): no exception, and the fit is exact.

    >>> A = np.array([[[1.0, 1.0], [2.0, 2.0], [0.0, 0.0]]])
    >>> Q, R = batched_qr(A)
    >>> y = np.array([[2.0], [4.0], [0.0]])
    >>> x = np.linalg.solve(R[0], Q[0].T @ y)
    >>> x.ravel().round(6), (A[0] @ x).ravel().round(6)
    (array([1., 1.]), array([2., 4., 0.]))
    """
    return qr_factor(A, rcond)[:2]


def qr_factor(A: np.ndarray, rcond: float = 1e-12) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`batched_qr` and whether its R is the upper triangular factor of
    the Householder path (one matrix, not singular): then ``solve_r(R, B,
    triangular=True)`` skips its checks of R. The local fits factorise
    thousands of small matrices per file, where these checks and numpy's
    wrappers cost more than LAPACK's factorisation.

    Examples
    --------
    >>> A = np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 2.0]])
    >>> qr_factor(A)[2], qr_factor(np.ones((3, 2)))[2]  # independent columns; equal ones
    (True, False)
    """
    if A.ndim == 2 and A.dtype == np.float64 and A.shape[0] >= A.shape[1] > 0:
        # one matrix (the local fits, a whole band's LSFD): LAPACK's
        # Householder QR called directly, faster than CholeskyQR2 at every
        # size here (1.4x at 4700 x 10, 2.2x at 16000 x 14; numpy's own qr
        # was 3x slower than CholeskyQR2 on the tall ones). LAPACK sets no
        # numpy error state: no errstate needed around it.
        try:
            Q, R = householder_qr(A)
        except np.linalg.LinAlgError:  # pragma: no cover - invalid arguments only
            pass
        else:
            d = np.abs(R.diagonal())
            # Householder's Q has entries of at most 1: its sum is finite
            # exactly when all of them are (one reduction, no boolean copy of
            # Q); min(d) >= c max(d) is all(d >= c max(d)), NaN included
            if np.isfinite(Q.sum()) and d.min() >= MIN_R_RATIO * d.max():
                return Q, R, True
    else:
        try:
            with np.errstate(all="ignore"):
                # a stack: CholeskyQR2, all matrix products
                Q, R = householder_qr(A) if A.ndim == 2 else _cholesky_qr2(A)
            d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
            if np.all(np.isfinite(Q)) and np.all(
                    d >= MIN_R_RATIO * np.max(d, axis=-1, keepdims=True)):
                return Q, R, False
        except np.linalg.LinAlgError:
            pass
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    floor = rcond * s[..., :1]
    Q = U * (s > floor)[..., None, :]
    R = np.maximum(s, floor)[..., :, None] * Vt
    return Q, R, False


@lru_cache(maxsize=64)
def strictly_lower(k: int) -> np.ndarray:
    """Read-only (k, k) mask of the entries below the diagonal, built once per
    size (``np.tri`` costs more than the small solves it serves).

    Examples
    --------
    >>> strictly_lower(2).tolist()
    [[False, False], [True, False]]
    """
    mask = np.tri(k, k, -1, dtype=bool)
    mask.flags.writeable = False
    return mask


def solve_r(R: np.ndarray, B: np.ndarray, triangular: bool = False) -> np.ndarray:
    """``numpy.linalg.solve(R, B)`` for the R of :func:`batched_qr`: by back
    substitution (LAPACK ``dtrtrs``) when R is one upper triangular real
    matrix (the QR paths; LU of a triangular matrix does not pivot, so the
    same arithmetic), else ``numpy.linalg.solve`` (a stack, or the dense R of
    the SVD fallback). The local fits solve thousands of these small systems
    per file: numpy's wrapper costs more than the substitution.
    ``triangular``: R is known to be one upper triangular float64 matrix (the
    third value of :func:`qr_factor`), its checks are skipped.

    Examples
    --------
    >>> R = np.array([[2.0, 1.0], [0.0, 4.0]])
    >>> solve_r(R, np.array([[4.0], [8.0]])).ravel().tolist()
    [1.0, 2.0]
    """
    if triangular and B.ndim == 2 and B.dtype == np.float64:
        pass  # R as the checks below would find it: straight to dtrtrs
    elif (R.ndim != 2 or B.ndim != 2 or R.dtype != np.float64 or B.dtype != np.float64
            or R.shape[0] != R.shape[1] or np.any(R[strictly_lower(R.shape[0])])):
        return np.linalg.solve(R, B)
    X, info = lapack.dtrtrs(R, B, lower=0)
    if info != 0:  # a zero on the diagonal: singular, as numpy.linalg.solve says
        raise np.linalg.LinAlgError("Singular matrix")
    return np.asarray(X)


def householder_qr(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Thin Householder QR of one tall real matrix (n, K), n >= K: LAPACK's
    ``dgeqrf`` and ``dorgqr``, the routines of ``numpy.linalg.qr``, called
    directly (the same numbers, at half the cost for the small matrices of
    the local fits, thousands of them per file: numpy's wrapper costs as much
    as the factorisation there). Other matrices go to ``numpy.linalg.qr``.

    Examples
    --------
    >>> A = np.random.default_rng(0).standard_normal((6, 3))
    >>> Q, R = householder_qr(A)
    >>> bool(np.allclose(Q @ R, A)), bool(np.allclose(Q.T @ Q, np.eye(3)))
    (True, True)
    """
    n, k = A.shape
    if A.dtype != np.float64 or n < k or k == 0:
        return np.linalg.qr(A)
    qr, tau, _, info = lapack.dgeqrf(A)
    if info != 0:  # pragma: no cover - only for invalid arguments
        raise np.linalg.LinAlgError("dgeqrf failed")
    R = qr[:k].copy()
    R[strictly_lower(k)] = 0.0  # np.triu, without its masked copy
    Q, _, info = lapack.dorgqr(qr, tau, overwrite_a=1)
    if info != 0:  # pragma: no cover
        raise np.linalg.LinAlgError("dorgqr failed")
    return Q, R


def _cholesky_qr2(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CholeskyQR2 of :func:`batched_qr` (raises ``LinAlgError`` when A^T A is
    not numerically positive definite)."""
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
    assert R is not None  # set in the first of the two rounds
    return Q, R


def mpc(phi: np.ndarray) -> np.ndarray:
    """Modal phase collinearity per mode (1 = real/normal mode, 0 = fully complex).

    MPC = ((S_xx - S_yy)^2 + 4 S_xy^2) / (S_xx + S_yy)^2 with S_xx = Re^T Re,
    S_yy = Im^T Im, S_xy = Re^T Im of each shape (n_dof, n_modes).

    Examples
    --------
    >>> mpc(np.array([[1.0 + 1.0j, 1.0], [2.0 + 2.0j, 1.0j]])).round(6)  # real mode, complex mode
    array([1., 0.])
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
    largest component of +1.

    Examples
    --------
    >>> real_normalised(np.array([[1.0j], [-2.0j]]))
    array([[-0.5],
           [ 1. ]])
    """
    x, y = phi.real, phi.imag
    theta = 0.5 * np.arctan2(2 * np.sum(x * y, axis=0), np.sum(x * x - y * y, axis=0))
    rot = np.real(phi * np.exp(-1j * theta)[None, :])
    k = np.argmax(np.abs(rot), axis=0)
    peak = rot[k, np.arange(rot.shape[1])]
    peak = np.where(peak == 0, 1.0, peak)
    return rot / peak[None, :]


def frac(H: np.ndarray, H_fit: np.ndarray) -> np.ndarray:
    """Frequency response assurance criterion per FRF (last axis = frequency).

    Examples
    --------
    >>> H = np.array([[[1.0 + 1.0j, 2.0, 3.0j]]])
    >>> frac(H, H), frac(H, 2 * H).round(3)
    (array([[1.]]), array([[1.]]))
    """
    H, H_fit = np.asarray(H), np.asarray(H_fit)
    lead = H.shape[:-1]
    n = H.shape[-1]
    # the MAC of each FRF with its synthesis, lines as the "DOFs"
    return mac_pairs(H.reshape(-1, n).T, H_fit.reshape(-1, n).T).reshape(lead)


def normalised_error(H: np.ndarray, H_fit: np.ndarray) -> np.ndarray:
    """||H - H_fit|| / ||H|| per FRF (last axis = frequency).

    Examples
    --------
    >>> H = np.array([[[1.0 + 1.0j, 2.0, 3.0j]]])
    >>> normalised_error(H, H), normalised_error(H, 1.1 * H).round(3)
    (array([[0.]]), array([[0.1]]))
    """
    num = np.sqrt(np.sum(np.abs(H - H_fit) ** 2, axis=-1))
    den = np.sqrt(np.sum(np.abs(H) ** 2, axis=-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, np.inf)
