"""The roots of a diagram's denominators (identification.diagram.roots) against
the companion eigenvalues (numpy.roots), on random polynomials, on the
denominators of a simulated impact test and of the measured beam, where
the number of real roots changes and where the iteration must fall back;
its parts (the blocked evaluation, the remaining roots, the coincidence
test) against the plain computation; and the speed-ups that keep every number
(lsfd.least_squares, lsfd.reused_lsfds, the shared residues of the pair
significance) against the plain computation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.data import FRFSet
from ema_pipeline.identification import SelectionThresholds
from ema_pipeline.identification.diagram.order_search import diagram_orders
from ema_pipeline.identification.diagram.plscf import plscf_denominators, plscf_normal_matrix
from ema_pipeline.identification.diagram.roots import (
    ABERTH_MIN_ORDER,
    BlockedPolynomial,
    companion_eigenvalues,
    companion_roots,
    conjugate_start,
    diagram_roots,
    distinct,
    newton_corrections,
    real_aberth_roots,
    remaining_roots,
)
from ema_pipeline.identification.refinement.local_band import global_residues
from ema_pipeline.identification.refinement.lsfd import least_squares, lsfd, reused_lsfds
from ema_pipeline.identification.selection.pairs import pair_significance
from tests.paths import REAL_UFF


@pytest.fixture(scope="module")
def paper_frf(example_dir: Path) -> FRFSet:
    """The shipped example's simulated impact test (2 responses, 8193 lines)."""
    return io.read_frf(example_dir / "genuine.uff")


def matched(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance from a root of either set to the nearest of the
    other, relative to its magnitude (at least 1e-3)."""
    d = np.abs(a[:, None] - b[None, :])
    return float(max((d.min(axis=1) / np.maximum(np.abs(a), 1e-3)).max(),
                     (d.min(axis=0) / np.maximum(np.abs(b), 1e-3)).max()))


def denominators(freq_hz: np.ndarray, H: np.ndarray, p: int) -> list[np.ndarray]:
    """The scalar denominators of a one-reference diagram of order p."""
    Hn = H / np.sqrt(np.mean(np.abs(H) ** 2))
    dt = 1 / (2 * freq_hz[-1])
    orders = diagram_orders(p, 1, SelectionThresholds().diagram_orders)
    M = plscf_normal_matrix(freq_hz, Hn, p, dt)
    return [a[:, 0, 0] for a in plscf_denominators(M, 1, orders)]


def test_random_polynomials_match_the_companion_eigenvalues():
    rng = np.random.default_rng(5)
    polys = [np.append(rng.standard_normal(n) * np.exp(rng.standard_normal(n)), 1.0)
             for n in range(60, 200, 14)]
    got = diagram_roots(polys)
    for c, z in zip(polys, got, strict=True):
        assert z.size == c.size - 1
        assert matched(z, np.roots(c[::-1])) < 1e-8


def test_the_transposed_companion_has_the_block_companion_eigenvalues():
    """``companion_eigenvalues`` forms the block companion of alpha^T
    transposed (upper Hessenberg with one reference): its eigenvalues are
    those of the untransposed form, to rounding, for 1-3 references (the
    roots of det A(z)), and with one reference the roots of the scalar
    polynomial (``numpy.roots``)."""
    rng = np.random.default_rng(11)
    for n_in in (1, 2, 3):
        for n in (1, 2, 7, 30):
            alpha = rng.standard_normal((n + 1, n_in, n_in))
            alpha[n] = np.eye(n_in)
            N = n * n_in
            C = np.zeros((N, N))
            C[: N - n_in, n_in:] = np.eye(N - n_in)
            C[N - n_in :, :] = -np.concatenate([alpha[j].T for j in range(n)], axis=1)
            got = companion_eigenvalues(alpha)
            assert got.size == N
            assert matched(got, np.linalg.eigvals(C)) < 1e-9
            if n_in == 1:
                assert matched(got, np.roots(alpha[::-1, 0, 0])) < 1e-9


def test_diagram_of_a_simulated_impact_test(paper_frf):
    """Order 200 (the iteration runs from order 80 on): every order's roots
    are numpy's, the number of poles of positive frequency the same."""
    frf = paper_frf
    keep = frf.freq_hz >= frf.freq_hz[5]
    polys = denominators(frf.freq_hz[keep], frf.H[:, :, keep], 200)
    assert polys[-1].size - 1 >= 2 * ABERTH_MIN_ORDER
    for c, z in zip(polys, diagram_roots(polys), strict=True):
        ref = companion_roots(c)
        assert matched(z, ref) < 1e-8
        assert np.sum(z.imag > 0) == np.sum(ref.imag > 0)


def test_diagram_of_the_measured_beam():
    if not REAL_UFF.exists():
        pytest.skip(f"{REAL_UFF} not present (../shared/data)")
    frf = io.read_frf(REAL_UFF).reciprocal()  # roving hammer: 30 responses, 1 reference
    assert frf.H.shape[1] == 1
    keep = frf.freq_hz >= frf.freq_hz[5]
    polys = denominators(frf.freq_hz[keep], frf.H[:, :, keep], 255)
    for c, z in zip(polys, diagram_roots(polys), strict=True):
        ref = companion_roots(c)
        assert matched(z, ref) < 1e-8
        assert np.sum(z.imag > 0) == np.sum(ref.imag > 0)


def test_multiple_roots_and_a_failed_iteration_fall_back():
    """A triple root makes the iteration converge slowly; whatever path it
    takes, the roots are the eigenvalues'. A single sweep does not converge
    and says so."""
    rng = np.random.default_rng(8)
    z = 0.95 * np.exp(2j * np.pi * rng.random(43))
    c = np.polynomial.polynomial.polyfromroots(
        np.concatenate([[0.5, 0.5, 0.5, -0.3], z, np.conj(z)])).real
    assert c.size - 1 == 90
    c = c / c[-1]
    assert matched(diagram_roots([c])[0], companion_roots(c)) < 1e-4  # a triple root: eps^(1/3)
    _, ok = real_aberth_roots(c, *conjugate_start(np.zeros(0, complex), 90), max_sweeps=1)
    assert not ok


def test_newton_corrections_by_blocks_are_the_direct_ones():
    """p/p' and the backward error from the blocked powers against
    numpy's polynomial evaluation, inside and outside the unit circle."""
    rng = np.random.default_rng(3)
    for n in (2, 7, 90, 481):
        c = rng.standard_normal(n + 1)
        z = (0.3 + 1.4 * rng.random(50)) * np.exp(2j * np.pi * rng.random(50))
        got, backward = newton_corrections(BlockedPolynomial.of(c), z)
        P = np.polynomial.Polynomial(c)
        want = P(z) / P.deriv()(z)
        np.testing.assert_allclose(got, want, rtol=1e-9)
        bound = np.polynomial.Polynomial(np.abs(c))(np.abs(z))
        np.testing.assert_allclose(backward, np.abs(P(z)) / bound, rtol=1e-9)


def test_remaining_roots_are_those_the_known_ones_leave():
    rng = np.random.default_rng(4)
    roots = np.concatenate([0.9 * np.exp(1j * np.linspace(0.1, 3.0, 40)), [0.95, -0.5]])
    roots = np.concatenate([roots, np.conj(roots[:40])])
    c = np.polynomial.polynomial.polyfromroots(roots).real
    for k in (1, 2, 4, 6):
        left = rng.choice(roots.size, k, replace=False)
        known = np.delete(roots, left)
        assert matched(remaining_roots(c, known), roots[left]) < 1e-8


def test_a_changed_number_of_real_roots_converges():
    """From a start with two real points where the roots are a complex
    pair, and with a pair where they are two real roots: the roots are the
    true ones (within 1e-8; numpy's eigenvalues are within 2e-8 here), as
    many of them real."""
    rng = np.random.default_rng(6)
    pairs = 0.97 * np.exp(1j * np.sort(rng.uniform(0.05, 3.1, 60)))
    # roots: the pairs and two real roots, or the pairs and one more pair;
    # start: the pairs and one more pair, or the pairs and two real points
    for real_roots, start_real in (([0.4, -0.7], []), ([], [0.1, 0.5])):
        extra = np.array([] if real_roots else [0.2 + 0.5j])
        roots = np.concatenate([pairs, np.conj(pairs), real_roots, extra, np.conj(extra)])
        c = np.polynomial.polynomial.polyfromroots(roots).real
        start_upper = np.concatenate([pairs * (1 + 1e-3), [0.5 + 0.3j] * (len(start_real) == 0)])
        start_real = np.array(start_real)
        z, ok = real_aberth_roots(c, start_upper, start_real)
        assert ok
        assert matched(z, roots) < 1e-8
        real = np.abs(z.imag) <= 1e-10 * np.abs(z)
        assert real.sum() == len(real_roots) != start_real.size


def test_distinct_finds_two_points_on_one_root():
    z = np.exp(1j * np.linspace(0.1, 3.0, 200))
    z = np.concatenate([z, np.conj(z), [0.5, -0.5]])  # conjugates share their real part
    assert distinct(z)
    assert not distinct(np.append(z, z[17] * (1 + 1e-10)))
    assert not distinct(np.append(z, 0.5 + 1e-12j))


def test_least_squares_is_numpys():
    rng = np.random.default_rng(2)
    A = rng.standard_normal((400, 12)) * np.logspace(0, 3, 12)
    Y = rng.standard_normal((400, 3))
    np.testing.assert_allclose(least_squares(A, Y), np.linalg.lstsq(A, Y, rcond=None)[0],
                               rtol=1e-10, atol=0)
    # numerically singular: the minimum-norm answer, no error
    A[:, 1] = A[:, 0]
    x = least_squares(A, Y)
    np.testing.assert_allclose(A @ x, A @ np.linalg.lstsq(A, Y, rcond=None)[0], atol=1e-8)


def test_reused_lsfds_give_the_same_fit(paper_frf):
    f = paper_frf.freq_hz[5:]
    H = paper_frf.H[:, 0, 5:]
    pole = np.array([-0.9 + 2j * np.pi * 18.1, -3.0 + 2j * np.pi * 113.0])
    plain = lsfd(f, H, pole, "accelerance")
    with reused_lsfds():
        first = lsfd(f, H, pole, "accelerance")
        again = lsfd(f, H.copy(), pole.copy(), "accelerance")  # equal copies: reused
        other = lsfd(f, H, pole[:1], "accelerance")
        assert again is first and other is not first
        with pytest.raises(ValueError):
            first.a[0, 0] = 0.0  # read-only: no stage changes another's fit
    np.testing.assert_array_equal(first.a, plain.a)
    np.testing.assert_array_equal(first.H_fit, plain.H_fit)


def test_a_reused_lsfd_of_frfs_changed_in_place_is_solved_again(paper_frf):
    """The reuse compares the numbers of the lines, FRFs and poles with the
    copies kept beside each fit: FRFs changed in place after a fit (the same
    array object) are fitted again, and a pole set equal in value but -0.0
    for 0.0 is not taken for the same."""
    f = paper_frf.freq_hz[5:]
    H = paper_frf.H[:, 0, 5:].copy()
    pole = np.array([-0.9 + 2j * np.pi * 18.1, -3.0 + 2j * np.pi * 113.0])
    with reused_lsfds():
        first = lsfd(f, H, pole, "accelerance")
        H[0, 100:140] *= 1.5
        changed = lsfd(f, H, pole, "accelerance")
        plus = np.array([complex(0.0, 2 * np.pi * 18.1)])
        minus = np.array([complex(-0.0, 2 * np.pi * 18.1)])
        assert lsfd(f, H, plus, "accelerance") is not lsfd(f, H, minus, "accelerance")
    assert changed is not first
    np.testing.assert_array_equal(changed.a, lsfd(f, H, pole, "accelerance").a)
    assert not np.array_equal(changed.a, first.a)


def test_pair_significance_with_given_residues_is_the_same():
    th = SelectionThresholds()
    f = np.linspace(80.0, 160.0, 801)
    lam = np.array([-3.0 + 2j * np.pi * 99.0, -3.0 + 2j * np.pi * 101.0,
                    -4.0 + 2j * np.pi * 140.0])
    jw = 2j * np.pi * f
    rng = np.random.default_rng(1)
    H = sum(a / (jw - p) + np.conj(a) / (jw - np.conj(p))
            for a, p in zip((1, 0.7, 2), lam, strict=True))
    H = H[None] + 1e-3 * (rng.standard_normal((1, f.size))
                          + 1j * rng.standard_normal((1, f.size)))
    residues = global_residues(f, H, lam, "receptance")
    plain = pair_significance(f, H, lam, 0, 1, "receptance", thresholds=th)
    given = pair_significance(f, H, lam, 0, 1, "receptance", residues=residues, thresholds=th)
    assert plain == given and plain > 1
