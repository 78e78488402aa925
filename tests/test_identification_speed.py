"""The cheaper forms of issue 28's second round give the numbers of the forms
they replace (independent references: scipy's NNLS, the per-channel Jacobian,
LAPACK's least squares)."""

import numpy as np
from scipy.optimize import nnls

from ema_pipeline.identification.refinement.local_band import pole_jacobian, pole_jacobian_factors
from ema_pipeline.identification.refinement.lsfd import batched_qr
from ema_pipeline.identification.refinement.uncertainty import nonnegative_line_fit


def test_nonnegative_line_fit_is_scipy_nnls():
    """Closed-form NNLS of y ~ a + b x against scipy.optimize.nnls column by
    column, with data whose optimum is inside, on a = 0 and on b = 0."""
    rng = np.random.default_rng(3)
    faces = set()
    for _ in range(300):
        n = int(rng.integers(3, 40))
        x = rng.random((n, 4)) ** rng.uniform(0.3, 4.0)
        x /= x.max(axis=0)
        y = np.abs(rng.uniform(-1, 1) + rng.uniform(-2, 2) * x
                   + rng.uniform(0, 1) * rng.standard_normal((n, 4)))
        a, b = nonnegative_line_fit(x, y)
        for c in range(4):
            ref, _ = nnls(np.stack([np.ones(n), x[:, c]], axis=1), y[:, c])
            np.testing.assert_allclose(a[c] + b[c] * x[:, c], ref[0] + ref[1] * x[:, c],
                                       rtol=0, atol=1e-12 * np.max(np.abs(y[:, c])))
            faces.add((bool(ref[0] > 0), bool(ref[1] > 0)))
    assert {(True, True), (True, False), (False, True)} <= faces


def test_pole_jacobian_factors_give_the_fisher_matrix():
    """B W_c equals the per-channel Jacobian, and the Fisher matrix of the
    projected Jacobian formed from the factors equals the direct one."""
    rng = np.random.default_rng(5)
    f = np.linspace(80.0, 120.0, 60)
    jw = 2j * np.pi * f[:, None]
    lam = np.array([-3.0 + 2j * np.pi * 95.0, -2.0 + 2j * np.pi * 104.0])
    X = rng.standard_normal((2 * lam.size + 6, 7))
    J = pole_jacobian(jw, lam, X)
    B, W = pole_jacobian_factors(jw, lam, X)
    np.testing.assert_allclose(np.einsum("ki,cij->kjc", B, W), J, rtol=0,
                               atol=1e-12 * np.abs(J).max())
    Q, _ = np.linalg.qr(rng.standard_normal((2 * f.size, 10)))
    s = rng.uniform(0.5, 2.0, 7)
    Jf = J.reshape(J.shape[0], -1)
    Jp = (Jf - Q @ (Q.T @ Jf)).reshape(J.shape) / np.sqrt(s)[None, None, :]
    F_direct = np.einsum("kic,kjc->ij", Jp, Jp)
    Bp = B - Q @ (Q.T @ B)
    F = np.tensordot(W / s[:, None, None], (Bp.T @ Bp) @ W, axes=([0, 1], [0, 1]))
    np.testing.assert_allclose(F, F_direct, rtol=1e-10, atol=1e-12 * np.abs(F_direct).max())


def test_batched_qr_one_matrix_least_squares_and_rank_deficient():
    """One matrix (Householder path): the least-squares solution of LAPACK's
    lstsq; two equal columns: the minimum-norm solution, no exception."""
    rng = np.random.default_rng(7)
    A = rng.standard_normal((200, 6))
    Y = rng.standard_normal((200, 3))
    Q, R = batched_qr(A)
    np.testing.assert_allclose(np.linalg.solve(R, Q.T @ Y), np.linalg.lstsq(A, Y, rcond=None)[0],
                               rtol=1e-10, atol=1e-12)
    A2 = np.column_stack([A[:, 0], A[:, 0], A[:, 1]])
    Q2, R2 = batched_qr(A2)
    x = np.linalg.solve(R2, Q2.T @ Y[:, :1])
    np.testing.assert_allclose(x, np.linalg.pinv(A2) @ Y[:, :1], rtol=1e-8, atol=1e-10)


def test_correlated_leverage_products_are_the_einsum_sums():
    """correlated_leverage by matrix products (issue 28, third round) against
    its sums written out with einsum, for a window's correlation over all
    lines and three channels; and the pole leverage of vp_covariance,
    diag(Bp (W_c Finv W_c^T) Bp^T), against diag(J_c Finv J_c^T)."""
    from ema_pipeline.identification.refinement.uncertainty import (
        correlated_leverage,
        exponential_window_correlation,
        toeplitz_apply,
    )

    rng = np.random.default_rng(7)
    n, n_par, n_ch = 50, 4, 3
    Q, _ = np.linalg.qr(rng.standard_normal((2 * n, 5)))
    B = rng.standard_normal((2 * n, n_par))
    B = B - Q @ (Q.T @ B)
    W = rng.standard_normal((n_ch, n_par, n_par))
    J = np.einsum("ki,cij->kjc", B, W)
    Finv = np.linalg.inv(np.einsum("kic,kjc->ij", J, J))
    rho = exponential_window_correlation(0.1, n)
    # the sums of the einsum form
    QJ = np.concatenate([Q, J.reshape(2 * n, -1)], axis=1)
    PX = 0.5 * toeplitz_apply(QJ[:n] + 1j * QJ[n:], rho)
    SX = np.concatenate([PX.real, PX.imag], axis=0)
    SQ, SJ = SX[:, :5], SX[:, 5:].reshape(J.shape)
    JF = np.einsum("kic,ij->kjc", J, Finv)
    linear = 0.5 - 2 * np.sum(Q * SQ, axis=1) + np.sum((Q @ (Q.T @ SQ)) * Q, axis=1)
    SJ_off = SJ - np.einsum("ki,ijc->kjc", Q, np.einsum("ki,kjc->ijc", Q, SJ))
    G = np.einsum("kic,kjc->ij", J, SJ)
    kept = (linear[:, None] - 2 * np.einsum("kjc,kjc->kc", SJ_off, JF)
            + np.einsum("kic,ij,kjc->kc", JF, G, JF))
    np.testing.assert_allclose(correlated_leverage(Q, J, Finv, rho), 1.0 - kept / 0.5,
                               rtol=0, atol=1e-12)
    M = np.matmul(np.matmul(W, Finv), W.transpose(0, 2, 1))
    np.testing.assert_allclose(np.sum(np.matmul(B, M) * B, axis=2).T,
                               np.einsum("kjc,ji,kic->kc", J, Finv, J), rtol=1e-12)


def test_whitened_numerators_are_the_triangular_solve_of_all_outputs():
    """plscf's X = L^-1 S_o of every output (one LAPACK solve, gathered in
    its layout) to the last bit of ``scipy.linalg.solve_triangular`` on the
    outputs' Toeplitz numerator blocks side by side, with two references;
    and each block's solution against numpy's dense solve."""
    from scipy import linalg

    from ema_pipeline.identification.diagram.plscf import whitened_numerators

    rng = np.random.default_rng(11)
    n_out, n_in, p = 3, 2, 6
    q = p + 1
    idx = (np.arange(q)[None, :] - np.arange(q)[:, None]) + p
    s_neg = rng.standard_normal((n_out, n_in, 2 * p + 1))
    G = rng.standard_normal((q, q))
    L = np.linalg.cholesky(G @ G.T + q * np.eye(q))
    S = s_neg[:, :, idx].transpose(0, 2, 3, 1).reshape(n_out, q, q * n_in)  # [o, j, (l, b)]
    X = linalg.solve_triangular(L, S.transpose(1, 0, 2).reshape(q, -1), lower=True)
    ref = X.reshape(q, n_out, q * n_in).transpose(1, 0, 2).reshape(n_out * q, q * n_in)
    got = whitened_numerators(L, s_neg, idx)
    np.testing.assert_array_equal(got, ref)
    for o in range(n_out):
        np.testing.assert_allclose(got[o * q:(o + 1) * q], np.linalg.solve(L, S[o]),
                                   rtol=1e-12, atol=1e-12)


def test_distinct_shapes_solves_an_lsfd_only_for_neighbours_within_their_widths(monkeypatch):
    """Both duplicate tests of ``distinct_shapes`` judge neighbours closer
    than the sum of their decay rates; poles further apart keep their
    verdict without the LSFD of their shapes (none is solved), while a
    pair within that distance is still judged by it (one mode found twice:
    one of the two is dropped)."""
    from ema_pipeline.identification.selection import acceptance
    from ema_pipeline.identification.thresholds import SelectionThresholds

    th = SelectionThresholds()
    f = np.linspace(60.0, 160.0, 2001)
    jw = 2j * np.pi * f
    shape = np.array([1.0, 0.8, -0.6])
    solved = []
    real_lsfd = acceptance.lsfd

    def counted(*args, **kwargs):
        solved.append(args[2].size)
        return real_lsfd(*args, **kwargs)

    monkeypatch.setattr(acceptance, "lsfd", counted)
    for fd_hz, expect_solved, expect_kept in (((90.0, 130.0), [], 2), ((100.0, 100.02), [2], 1)):
        lam = -1.5 + 2j * np.pi * np.array(fd_hz)  # decay rates 1.5 1/s: 0.24 Hz half-widths
        H = sum(shape[:, None] / (jw - p) + shape[:, None] / (jw - np.conj(p)) for p in lam)
        solved.clear()
        kept = acceptance.distinct_shapes(f, H, lam, "receptance", np.ones(2, bool),
                                          thresholds=th)
        assert solved == expect_solved and int(kept.sum()) == expect_kept, (fd_hz, solved, kept)


def test_local_sizes_are_the_local_problems_lines_times_columns():
    """The cost estimate that deals the local fits to the workers
    (``local_sizes``) counts what :func:`local_problem` cuts: each mode's
    band lines times two columns per member pole and three of the
    background, at the refinement's and at the split fits' widths, close
    modes (several members) and isolated ones."""
    from ema_pipeline.identification.refinement.local_band import local_problem, local_sizes
    from ema_pipeline.identification.thresholds import SelectionThresholds

    th = SelectionThresholds()
    f = np.linspace(5.0, 400.0, 3951)
    fn = np.array([20.0, 100.0, 101.0, 102.5, 250.0, 390.0])
    lam = -np.array([0.02, 0.005, 0.005, 0.01, 0.001, 0.01]) * 2 * np.pi * fn + 2j * np.pi * fn
    H = np.ones((1, f.size), complex)
    for half_width in (th.local_half_width, th.split_half_width):
        sizes = local_sizes(f, lam, half_width, th.local_min_lines, thresholds=th)
        for r in range(lam.size):
            fl, Y, members, background, _, _ = local_problem(f, H, lam, r, half_width,
                                                             th.local_min_lines, thresholds=th)
            assert sizes[r] == fl.size * (2 * members.size + background.shape[1])
        assert sizes[1] > sizes[4]  # the close trio shares its bands
