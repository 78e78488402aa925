"""LSFD on near-coincident poles and many modes/outputs, and the MPD indicator."""

from __future__ import annotations

import os
from functools import lru_cache

import numpy as np
import pytest

from ema_pipeline.data import DOF, FRFSet
from ema_pipeline.identification import identify
from ema_pipeline.identification.refinement.lsfd import (
    batched_qr,
    design_matrix,
    householder_qr,
    lsfd,
    mpc,
    real_stack,
    solve_r,
)
from ema_pipeline.modal import mpd


@lru_cache(maxsize=2)
def pole_residue_set(n_out: int, n_modes: int = 60, seed: int = 0, n_lines: int = 4097,
                     snr_db: float = 40.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Accelerance of ``n_modes`` real modes log-spaced in 20-950 Hz at ``n_out``
    outputs, one reference, complex noise ``snr_db`` below each FRF's RMS.

    Returns freq_hz (n_freq,), H (n_out, n_freq), poles (n_modes,) rad/s and the
    accelerance residues a (n_modes, n_out) of the LSFD model."""
    rng = np.random.default_rng(seed)
    f = np.linspace(0.0, 1000.0, n_lines)
    fn = np.sort(np.exp(rng.uniform(np.log(20.0), np.log(950.0), n_modes)))
    zeta = rng.uniform(0.003, 0.02, n_modes)
    wn = 2 * np.pi * fn
    lam = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    A = rng.standard_normal((n_out, n_modes)) * rng.standard_normal(n_modes) / (2j * lam.imag)
    jw = 2j * np.pi * f
    g, gc = 1.0 / (jw[:, None] - lam), 1.0 / (jw[:, None] - lam.conj())
    H = np.sum(A[:, None, :] * g + A.conj()[:, None, :] * gc, axis=-1) * jw**2
    rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=-1, keepdims=True))
    H = H + rms * 10 ** (-snr_db / 20) * (rng.standard_normal(H.shape)
                                          + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    return f, H, lam, (A * lam**2).T


@pytest.mark.parametrize("n_out", [32, 128])
@pytest.mark.parametrize("eps", [0.0, 1e-12, 1e-7])
def test_lsfd_near_coincident_poles_many_modes(n_out: int, eps: float) -> None:
    """60 modes + a copy of mode 30 moved by ``eps`` (relative): no exception,
    the fit stays at the noise level, the two copies share the true residue
    (within 10 %: the pair also fits a pole shift to the noise), and the
    coefficients are the least-squares ones where those are unique."""
    f, H, lam, a_true = pole_residue_set(n_out)
    sel = f > 5.0
    poles = np.concatenate([lam, [lam[30] * (1 + eps)]])
    fit = lsfd(f[sel], H[:, sel], poles, "accelerance")
    assert np.all(np.isfinite(fit.a)) and np.all(np.isfinite(fit.H_fit))
    err = np.linalg.norm(fit.H_fit - H[:, sel]) / np.linalg.norm(H[:, sel])
    assert err < 2 * 10 ** (-40 / 20)  # the noise is 1 % of the RMS
    shared = fit.a[30] + fit.a[-1]
    np.testing.assert_allclose(shared, a_true[30], rtol=0.1, atol=0.1 * np.abs(a_true[30]).max())
    others = np.delete(np.arange(60), 30)
    rel = np.abs(fit.a[others] - a_true[others]) / np.abs(a_true[others]).max(axis=1,
                                                                               keepdims=True)
    assert np.median(rel) < 0.01
    if eps >= 1e-7:  # full column rank: compare with LAPACK's least squares
        B = real_stack(design_matrix(f[sel], poles, "accelerance"))
        scale = np.max(np.abs(B), axis=0)
        X = np.linalg.lstsq(B / scale, real_stack(H[:, sel].T), rcond=None)[0] / scale[:, None]
        a = X[0:122:2] + 1j * X[1:122:2]
        np.testing.assert_allclose(fit.a, a, rtol=1e-5, atol=1e-7 * np.abs(a).max())


def test_batched_qr_rank_deficient_stack() -> None:
    """A stack with one full-rank and one rank-deficient matrix: the full-rank
    solution is the least-squares solution, the deficient one the minimum-norm one."""
    rng = np.random.default_rng(1)
    full = rng.standard_normal((50, 4))
    deficient = full.copy()
    deficient[:, 3] = deficient[:, 2]  # two equal columns
    A = np.stack([full, deficient])
    y = rng.standard_normal((2, 50, 1))
    Q, R = batched_qr(A)
    x = np.linalg.solve(R, np.swapaxes(Q, -1, -2) @ y)
    np.testing.assert_allclose(x[0], np.linalg.lstsq(full, y[0], rcond=None)[0], rtol=1e-9)
    np.testing.assert_allclose(x[1], np.linalg.pinv(deficient) @ y[1], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("shape", [(12, 8), (600, 38), (16376, 14)])
def test_householder_qr_and_solve_r_against_numpy(shape: tuple[int, int]) -> None:
    """The direct LAPACK calls give numpy's numbers: Q and R of
    ``numpy.linalg.qr`` to 1e-13 (the same routines: in practice equal), the
    solution of ``numpy.linalg.solve`` to 1e-12 relative (back substitution
    against LU of a triangular matrix), with a column-scaled design of
    condition ~1e4 as in the local fits; the SVD fallback's dense R goes to
    numpy.linalg.solve."""
    rng = np.random.default_rng(shape[0])
    A = rng.standard_normal(shape) * np.logspace(0, -4, shape[1])
    Y = rng.standard_normal((shape[0], 3))
    Q, R = householder_qr(np.asfortranarray(A))
    Qn, Rn = np.linalg.qr(A)
    np.testing.assert_allclose(Q, Qn, rtol=0, atol=1e-13)
    np.testing.assert_allclose(R, Rn, rtol=0, atol=1e-13)
    assert np.all(np.tril(R, -1) == 0.0)
    X = solve_r(R, Q.T @ Y)
    np.testing.assert_allclose(X, np.linalg.solve(Rn, Qn.T @ Y), rtol=1e-12)
    dense = rng.standard_normal((4, 4)) + 4 * np.eye(4)  # not triangular: numpy's solve
    np.testing.assert_allclose(solve_r(dense, Y[:4]), np.linalg.solve(dense, Y[:4]), rtol=1e-13)


@pytest.mark.parametrize("shape", [(8972, 74), (2050, 16), (600, 15)])
def test_least_squares_blocked_qr_gives_the_unblocked_solution(shape, monkeypatch) -> None:
    """From ``BLOCKED_QR_MIN_COLUMNS`` columns on, ``least_squares`` takes
    LAPACK's blocked Householder QR (``dgeqrt``): the solution of the
    unblocked ``dgeqrf`` path and of numpy's ``lstsq`` to 1e-12 relative, on
    a column-scaled design of condition ~1e4 (a whole band's LSFD of 35
    poles over 4487 lines is 8972 x 74); fewer columns stay on ``dgeqrf``.
    A numerically singular design still gets the minimum-norm solution."""
    from scipy.linalg import lapack

    from ema_pipeline.identification.refinement import lsfd as lsfd_module

    rng = np.random.default_rng(shape[1])
    A = np.asfortranarray(rng.standard_normal(shape) * np.logspace(0, -4, shape[1]))
    Y = rng.standard_normal((shape[0], 2))
    calls: list[str] = []

    class Counted:
        def __getattr__(self, name):
            calls.append(name)
            return getattr(lapack, name)

    monkeypatch.setattr(lsfd_module, "lapack", Counted())
    X = lsfd_module.least_squares(A, Y)
    blocked = shape[1] >= lsfd_module.BLOCKED_QR_MIN_COLUMNS
    assert ("dgeqrt" in calls) == blocked and ("dgeqrf" in calls) != blocked
    monkeypatch.setattr(lsfd_module, "BLOCKED_QR_MIN_COLUMNS", 10**9)
    X0 = lsfd_module.least_squares(A, Y)
    scale = np.abs(X0).max()
    assert np.abs(X - X0).max() <= 1e-12 * scale
    assert np.abs(X - np.linalg.lstsq(A, Y, rcond=None)[0]).max() <= 1e-12 * scale
    monkeypatch.setattr(lsfd_module, "BLOCKED_QR_MIN_COLUMNS", 16)
    singular = A.copy()
    singular[:, -1] = singular[:, 0]  # two equal columns: the minimum-norm fit
    Xs = lsfd_module.least_squares(singular, Y)
    np.testing.assert_allclose(singular @ Xs, singular @ np.linalg.pinv(singular) @ Y,
                               rtol=0, atol=1e-9 * np.abs(Y).max())
    assert abs(Xs[0, 0] - Xs[-1, 0]) <= 1e-8 * np.abs(Xs).max()


def mpd_by_svd(phi: np.ndarray) -> np.ndarray:
    """Reynders et al. (2012) literally: SVD of [Re phi, Im phi] per mode."""
    out = []
    for col in phi.T:
        _, _, vt = np.linalg.svd(np.stack([col.real, col.imag], axis=1), full_matrices=False)
        v12, v22 = vt[1, 0], vt[1, 1]  # V = vt.T; (V12, V22) = second column of V
        num = np.abs(col.real * v22 - col.imag * v12)
        dev = np.degrees(np.arccos(np.clip(num / (np.sqrt(v12**2 + v22**2) * np.abs(col)),
                                           0, 1)))
        out.append(np.sum(np.abs(col) * dev) / np.sum(np.abs(col)))
    return np.array(out)


def test_mpd_known_values_and_svd_definition() -> None:
    rng = np.random.default_rng(2)
    real = rng.standard_normal((12, 3)) * np.exp(1j * np.array([0.0, 0.7, -2.0]))
    np.testing.assert_allclose(mpd(real), 0.0, atol=1e-6)  # rotated real modes
    np.testing.assert_allclose(mpc(real), 1.0, atol=1e-12)
    # components at +-alpha around a common axis, equal weight: MPD = alpha
    alpha = np.array([3.0, 10.0, 30.0])
    mag = rng.uniform(0.5, 2.0, 6)
    sym = np.concatenate([mag[:, None] * np.exp(1j * np.radians(alpha)),
                          mag[:, None] * np.exp(-1j * np.radians(alpha))]) * np.exp(0.4j)
    np.testing.assert_allclose(mpd(sym), alpha, rtol=1e-9)
    noisy = real + 0.3 * (rng.standard_normal(real.shape) + 1j * rng.standard_normal(real.shape))
    np.testing.assert_allclose(mpd(noisy), mpd_by_svd(noisy), rtol=1e-9)
    assert np.all(mpd(noisy) > 1.0)
    assert np.isnan(mpd(np.zeros((3, 1), complex)))[0]


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("EMA_SLOW_TESTS"),
                    reason="about 70 s; run with EMA_SLOW_TESTS=1 (the LSFD part of this case "
                    "runs always, in test_lsfd_near_coincident_poles_many_modes)")
def test_identify_60_modes_128_outputs_runs_to_the_end() -> None:
    """No raw numpy exception for a dense MIMO-size case (issue 11)."""
    f, H, lam, _ = pole_residue_set(128)
    frf = FRFSet(freq_hz=f, H=H[:, None, :], response_dofs=tuple(DOF(i + 1) for i in range(128)),
                 reference_dofs=(DOF(200),), quantity="accelerance")
    res = identify(frf, band_hz=(10.0, 990.0))
    fn_true = np.abs(lam) / (2 * np.pi)
    assert res.modes.n_modes >= 10
    dist = np.min(np.abs(res.fn_hz[:, None] - fn_true[None, :]) / fn_true[None, :], axis=1)
    assert np.median(dist) < 0.005
