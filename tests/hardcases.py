"""Hard identification cases with known truth, written independently of
:mod:`ema_pipeline.acquisition`.

Why our own synthesis: the issue (#11) asks for test data that our simulator
did not write, so that the identification is not tuned to one data source.
Everything here is plain numpy (and ``scipy.signal.decimate`` as the analyser's
anti-alias filter): a pole-residue model of real (proportionally damped) modes,

    receptance  H_oi(w) = sum_r A_r,oi / (jw - lambda_r) + conj(A_r,oi) / (jw - conj lambda_r)
    A_r,oi = phi_r(o) phi_r(i) / (2j omega_dr m_r),
    lambda_r = -zeta_r w_r + j w_r sqrt(1 - zeta_r^2)

times (jw)^q for mobility (q = 1) and accelerance (q = 2); complex Gaussian noise,
additive at a given SNR on each FRF plus a part proportional to |H|. The
impact family is simulated in the time domain (exact modal responses to a
half-sine force pulse, anti-alias filter, noise, force and exponential windows,
H1 averaging with the numpy FFT) and carries ``exp_window_tau_s``, the number of
averages and the coherence.

Every case is a :class:`HardCase` with the FRFs as :class:`ema_pipeline.data.FRFSet`,
the band to identify and the true f_n and zeta of every mode inside that band
(modes outside the band, present in the data, are not counted). A mode is only
generated if it is visible: its own peak over the noise, combined over all
channels, is at least 20 dB (weaker modes get a smaller modal mass; in the
time-domain impact families, :func:`impact_visibility`, all but ``impact``,
which keeps its cases of issue 11).

Two families of issue 31 (``COMPLEX_FAMILIES``) are built differently:
``complex_chain`` is a chain of masses and springs with light modal damping
and 1-3 strong discrete dashpots (non-proportional damping, strongly complex
modes); its FRFs are the exact inverse of the dynamic stiffness
K - w^2 M + jw C, and its truth the eigenvalues of the state-space matrix.
``impact_close`` is the impact family with one or two pairs of close modes
below 80 Hz, measured by 1-4 accelerometers (since issue 42 one accelerometer
too: its seeds that drew one, 2 before, are one-channel cases now).
``complex_dashpots`` (issue 53, in ``COMPLEX_FAMILIES`` too) is a chain with
springs to ground, one cross spring and 40-150 N s/m dashpots whose strongly
complex modes are only 3 % or more apart, measured at 3-5 masses.

Issue 42's ``FEW_CHANNEL_FAMILIES``: ``impact_1ch`` and ``impact_2ch`` are the
impact family with exactly one and two accelerometers, and in half of the
cases a close partner beside one of the modes.

Use ``make_case(family, seed)`` or ``cases(family, seeds)``; ``FAMILIES`` lists
the families of issue 11, ``ALL_FAMILIES`` those, ``COMPLEX_FAMILIES`` and
``FEW_CHANNEL_FAMILIES``. The same (family, seed) always gives the same case.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import DOF, AcquisitionInfo, FRFSet

FAMILIES: tuple[str, ...] = (
    "baseline",
    "dense_log",
    "dense_uniform",
    "close_1ref",
    "close_2ref",
    "damping",
    "snr",
    "mimo",
    "roving",
    "impact",
    "quantity",
)
#: Families of issue 31, kept apart from ``FAMILIES`` (whose acceptance tests
#: run every family): strongly complex modes of a physical chain with discrete
#: dashpots, and close low-frequency modes in time-domain impact tests.
COMPLEX_FAMILIES: tuple[str, ...] = ("complex_chain", "impact_close", "complex_dashpots")
#: Families of issue 42, kept apart as well: impact tests with one and with
#: two accelerometers (one hammer point), half of them with a close pair.
FEW_CHANNEL_FAMILIES: tuple[str, ...] = ("impact_1ch", "impact_2ch")
ALL_FAMILIES: tuple[str, ...] = FAMILIES + COMPLEX_FAMILIES + FEW_CHANNEL_FAMILIES
#: A family's number seeds its generator: the families in the order they were
#: added, so that a new one leaves every case of the others as it was.
_FAMILY_ID = {name: k for k, name in enumerate(
    (*FAMILIES, "complex_chain", "impact_close", *FEW_CHANNEL_FAMILIES, "complex_dashpots"))}
_Q = {"receptance": 0, "mobility": 1, "accelerance": 2}
#: Peak of a mode's own term over the noise std, combined over channels (20 dB).
MIN_VISIBILITY = 10.0


@dataclass
class HardCase:
    """One generated FRF set and its truth.

    ``fn_hz``, ``zeta``: true undamped natural frequencies and damping ratios of
    the modes inside ``band_hz`` (ascending). ``roving``: the FRFs are stored as
    1 response x n hammer points (identify their reciprocal).
    """

    family: str
    seed: int
    frf: FRFSet
    band_hz: tuple[float, float]
    fn_hz: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray
    roving: bool = False

    @property
    def name(self) -> str:
        return f"{self.family}-{self.seed}"


# --------------------------------------------------------------------------- building blocks
def modal_poles(fn_hz: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """Poles (rad/s, Im > 0) of modes with natural frequencies ``fn_hz`` and
    damping ratios ``zeta``."""
    wn = 2 * np.pi * fn_hz
    return -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)


def _residues(pole: np.ndarray, phi: np.ndarray, mass: np.ndarray, out: np.ndarray,
              ref: np.ndarray) -> np.ndarray:
    """Receptance residues A (n_modes, n_out, n_in) of modes phi (n_pts, n_modes),
    real or (:func:`complex_shapes`) complex."""
    scale = 1.0 / (2j * pole.imag * mass)
    return scale[:, None, None] * phi[out].T[:, :, None] * phi[ref].T[:, None, :]


def complex_shapes(phi: np.ndarray, phase_deg: float, family: str, seed: int) -> np.ndarray:
    """``phi`` (n_pts, n_modes) with each entry turned by a random phase, uniform
    in +-``phase_deg`` degrees: complex modes, MPC about 0.91 at 15 degrees,
    the pattern of non-proportional damping or of phase errors between
    channels. Not a damped mass-spring system: its residues no longer sum to
    zero real part (sum_r Re A_r = 0 keeps a receptance at 1/w^2 far above the
    modes), so accelerance grows like w far above the band; the families are
    identified in bands around their modes. ``phase_deg`` 0 returns ``phi``
    itself. The phases come from their own generator (family, seed), so the
    rest of the case is the same as without them."""
    if phase_deg == 0:
        return phi
    rng = np.random.default_rng([12, _FAMILY_ID[family], int(seed)])
    return phi * np.exp(1j * np.deg2rad(phase_deg) * rng.uniform(-1.0, 1.0, phi.shape))


def _synth(freq_hz: np.ndarray, pole: np.ndarray, A: np.ndarray, q: int) -> np.ndarray:
    """H (n_out, n_in, n_freq) of the pole-residue model in quantity power q."""
    jw = 2j * np.pi * freq_hz
    g = 1.0 / (jw[None, :] - pole[:, None])
    gc = 1.0 / (jw[None, :] - np.conj(pole)[:, None])
    H = np.einsum("roi,rk->oik", A, g) + np.einsum("roi,rk->oik", np.conj(A), gc)
    return H * (jw**q)[None, None, :]


def _shapes(rng: np.random.Generator, n_pts: int, n_modes: int, kind: str) -> np.ndarray:
    """(n_pts, n_modes) real shapes: random normal or beam-like sin(k pi x)."""
    if kind == "random":
        return rng.standard_normal((n_pts, n_modes))
    x = np.sort(rng.uniform(0.03, 0.97, n_pts))
    k = np.arange(1, n_modes + 1) + rng.uniform(-0.15, 0.15, n_modes)
    phi = np.sin(np.pi * np.outer(x, k) + rng.uniform(-0.2, 0.2, n_modes)[None, :])
    return phi + 0.1 * rng.standard_normal(phi.shape)


def _observable(phi: np.ndarray, ref: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Make every mode excited by at least one reference (|phi_ref| >= 0.3 RMS)."""
    phi = phi.copy()
    rms = np.sqrt(np.mean(phi**2, axis=0))
    best = np.max(np.abs(phi[ref]), axis=0)
    for r in np.flatnonzero(best < 0.3 * rms):
        i = ref[rng.integers(ref.size)]
        phi[i, r] = np.sign(phi[i, r] or 1.0) * rng.uniform(0.4, 1.0) * rms[r]
    return phi


def _noise_std(H: np.ndarray, snr_db: float, prop_db: float) -> np.ndarray:
    """Noise std per FRF and line: additive at ``snr_db`` below each FRF's RMS
    plus ``prop_db`` below |H| (force noise, leakage)."""
    rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=-1, keepdims=True))
    add = rms * 10 ** (-snr_db / 20)
    return np.sqrt(add**2 + (np.abs(H) * 10 ** (-prop_db / 20)) ** 2)


def _boost_weak(freq_hz: np.ndarray, pole: np.ndarray, A: np.ndarray, q: int,
                std: np.ndarray) -> np.ndarray:
    """Scale residues up so that every mode's own peak over the noise is >= MIN_VISIBILITY."""
    A = A.copy()
    for r in range(pole.size):
        k = int(np.argmin(np.abs(freq_hz - pole[r].imag / (2 * np.pi))))
        if not 0 < k < freq_hz.size - 1:
            continue
        peak = np.abs(A[r] / pole[r].real * (2j * np.pi * freq_hz[k]) ** q)
        vis = np.sqrt(np.sum((peak / std[..., k]) ** 2))
        if vis < MIN_VISIBILITY:
            A[r] *= MIN_VISIBILITY / max(vis, 1e-30)
    return A


def _cnoise(rng: np.random.Generator, std: np.ndarray) -> np.ndarray:
    return std * (rng.standard_normal(std.shape) + 1j * rng.standard_normal(std.shape)) / np.sqrt(2)


def _spaced_log(rng: np.random.Generator, n: int, lo: float, hi: float, r_min: float,
                r_max: float) -> np.ndarray:
    """n frequencies in [lo, hi] with ratios of neighbours in [r_min, r_max]
    (fewer if they do not fit)."""
    ratios = np.exp(rng.uniform(np.log(r_min), np.log(r_max), n - 1))
    span = np.log(hi / lo)
    while np.sum(np.log(ratios)) > span:
        if np.all(ratios <= r_min * 1.0001):
            ratios = ratios[:-1]
        ratios = np.maximum(ratios ** 0.95, r_min)
    total = np.sum(np.log(ratios))
    start = np.log(lo) + rng.uniform(0, span - total)
    return np.exp(start + np.concatenate([[0.0], np.cumsum(np.log(ratios))]))


# --------------------------------------------------------------------------- frequency domain
def _freq_case(family: str, seed: int, rng: np.random.Generator,
               complex_phase_deg: float = 0.0) -> HardCase:
    u = rng.uniform
    n_lines = int(rng.choice([1025, 2049, 4097, 8193])) if family not in (
        "dense_log", "dense_uniform") else int(rng.choice([4097, 8193]))
    f0 = float(u(1, 20)) if family == "quantity" else 0.0
    f_top = float(np.exp(u(np.log(150), np.log(3000))))
    df = (f_top - f0) / (n_lines - 1)
    freq = f0 + df * np.arange(n_lines)
    hi = f_top * u(0.85, 0.95)
    lo = max(f0 + 4 * df, freq[3], f_top * u(0.01, 0.05))
    W = hi - lo
    flo, fhi = lo + 0.03 * W, hi - 0.03 * W
    n_in, n_out, roving, shape_kind = 1, int(rng.integers(2, 7)), False, "beam"
    snr, prop = u(35, 55), u(40, 60)
    zlo, zhi = 0.003, 0.02
    quantity = "accelerance"
    pair_of: list[tuple[int, int]] = []
    if family in ("baseline", "damping", "snr", "quantity"):
        n = int(rng.integers(3, 7))
        rmin = 1.35 if family == "damping" else 1.15
        fn = _spaced_log(rng, n, flo, fhi, rmin, 2.5)
        if family == "damping":
            zlo, zhi = 0.03, 0.08
        if family == "snr":
            snr, prop = u(15, 25), u(25, 35)
        if family == "quantity":
            quantity = str(rng.choice(["mobility", "receptance"]))
            shape_kind = str(rng.choice(["random", "beam"]))
    elif family == "dense_log":
        n = int(rng.integers(20, 41))
        fn = _spaced_log(rng, n, flo, fhi, 1.02, 1.06)
        n_out = int(rng.integers(3, 7))
        zlo, zhi = 0.002, 0.008
        snr, prop = u(35, 50), u(40, 55)
        shape_kind = str(rng.choice(["random", "beam"]))
    elif family == "dense_uniform":
        n = int(rng.integers(20, 41))
        step = (fhi - flo) / (n - 1)
        fn = flo + step * (np.arange(n) + u(-0.2, 0.2, n))
        fn = np.clip(np.sort(fn), flo, fhi)
        n_out = int(rng.integers(3, 7))
        zlo, zhi = 0.002, 0.008
        snr, prop = u(35, 50), u(40, 55)
        shape_kind = str(rng.choice(["random", "beam"]))
    elif family in ("close_1ref", "close_2ref"):
        n_single = int(rng.integers(2, 5))
        base = _spaced_log(rng, n_single + 2, flo, fhi / 1.02, 1.2, 2.0)
        # pairs only where the lines resolve them: half-power band >= 3 lines
        # with a modal overlap <= 1, i.e. f >= 3 df / (sep - 1)
        seps = u(1.005, 1.02, 2)
        fn_list = list(base)
        order_hi = np.argsort(base)[::-1]
        for sep in seps:
            ok = [i for i in range(base.size) if base[i] >= 3 * df / (sep - 1)
                  and all(i != a for a, _ in pair_of)]
            i = int(rng.choice(ok)) if ok else int(next(
                k for k in order_hi if all(k != a for a, _ in pair_of)))
            sep = max(sep, 1 + 3 * df / base[i])
            fn_list.append(base[i] * sep)
            pair_of.append((i, len(fn_list) - 1))
        fn = np.array(fn_list)
        n_out = int(rng.integers(6, 11))
        n_in = 2 if family == "close_2ref" else 1
        zlo, zhi = 0.001, 0.004
        snr, prop = u(40, 50), u(45, 55)
        shape_kind = "random"
    elif family in ("mimo", "roving"):
        n = int(rng.integers(4, 11))
        fn = _spaced_log(rng, n, flo, fhi, 1.05, 1.6)
        if family == "mimo":
            n_in, n_out = int(rng.integers(2, 4)), int(rng.integers(6, 11))
        else:
            n_in, n_out, roving = int(rng.integers(8, 13)), 1, True
        shape_kind = str(rng.choice(["random", "beam"]))
        snr, prop = u(35, 50), u(40, 55)
    else:  # pragma: no cover
        raise ValueError(f"unknown family {family!r}")
    n = fn.size
    zeta = np.exp(u(np.log(zlo), np.log(zhi), n))
    zeta = np.maximum(zeta, 1.5 * df / fn)  # half-power band >= 3 lines
    for i, j in pair_of:  # a close pair: modal overlap <= 1
        sep = fn[j] / fn[i] - 1
        zeta[[i, j]] = np.minimum(zeta[[i, j]], np.maximum(sep / 2, 1.5 * df / fn[i]))
    # one or two modes above the band (in the data, not in the truth)
    n_above = int(rng.integers(0, 3))
    f_above = hi * u(1.08, 1.6, n_above)
    f_all = np.concatenate([fn, f_above])
    z_all = np.concatenate([zeta, np.full(n_above, 0.01)])
    n_modes = f_all.size
    pole = modal_poles(f_all, z_all)
    if roving:
        n_pts = n_in + 1
        out, ref = np.array([n_pts - 1]), np.arange(n_in)
    else:
        n_pts = n_out
        out = np.arange(n_out)
        ref = rng.choice(n_out, n_in, replace=False)
    phi = _shapes(rng, n_pts, n_modes, shape_kind)
    for _i, j in pair_of:  # different shapes in a pair
        phi[:, j] = rng.standard_normal(n_pts)
    phi = _observable(phi, ref if not roving else out, rng)
    if roving:  # the fixed response must see every mode, each hammer point is a "reference"
        phi = _observable(phi, out, rng)
    mass = np.exp(u(np.log(0.1), np.log(10.0), n_modes))
    q = _Q[quantity]
    A = _residues(pole, complex_shapes(phi, complex_phase_deg, family, seed), mass, out, ref)
    H0 = _synth(freq, pole, A, q)
    std = _noise_std(H0, snr, prop)
    A = _boost_weak(freq, pole, A, q, std)
    H0 = _synth(freq, pole, A, q)
    std = _noise_std(H0, snr, prop)
    H = H0 + _cnoise(rng, std)
    dofs = [DOF(int(k) + 1, 3) for k in range(n_pts)]
    frf = FRFSet(
        freq_hz=freq,
        H=H,
        response_dofs=tuple(dofs[k] for k in out),
        reference_dofs=tuple(dofs[k] for k in ref),
        quantity=quantity,  # type: ignore[arg-type]
        configuration=f"{family}-{seed}",
    )
    order = np.argsort(fn)
    return HardCase(family, seed, frf, (float(lo), float(hi)), fn[order], zeta[order],
                    phi[:, :n][:, order], roving)


# --------------------------------------------------------------------------- damped chain
def _chain_matrices(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                          np.ndarray]:
    """M, K, light modal damping C0 and the pattern D of 1-3 discrete dashpots
    (to ground or between neighbours, random strengths) of a random chain of
    4-9 masses (0.05-2 kg) and springs (0.3-3 MN/m, fixed at the first end,
    fixed or free at the other)."""
    u = rng.uniform
    n = int(rng.integers(4, 10))
    m = np.exp(u(np.log(0.05), np.log(2.0), n))
    k = np.exp(u(np.log(0.3), np.log(3.0), n + 1)) * 1e6
    if u() < 0.5:
        k[-1] = 0.0
    K = np.zeros((n, n))
    for i in range(n + 1):  # spring i joins mass i-1 and mass i (-1, n: ground)
        for a in (i - 1, i):
            if 0 <= a < n:
                K[a, a] += k[i]
        if 0 < i < n:
            K[i - 1, i] -= k[i]
            K[i, i - 1] -= k[i]
    M = np.diag(m)
    w2, U = np.linalg.eigh(K / np.sqrt(np.outer(m, m)))
    phi = U / np.sqrt(m)[:, None]  # mass-normalised undamped modes
    z0 = np.exp(u(np.log(0.003), np.log(0.01), n))
    C0 = M @ phi @ np.diag(2 * z0 * np.sqrt(w2)) @ phi.T @ M
    D = np.zeros((n, n))
    for _ in range(int(rng.integers(1, 4))):
        i, c = int(rng.integers(0, n)), float(np.exp(u(-1.0, 1.0)))
        D[i, i] += c
        if i < n - 1 and u() >= 0.3:  # between masses i and i+1, else to ground
            D[i + 1, i + 1] += c
            D[i, i + 1] -= c
            D[i + 1, i] -= c
    return M, K, C0, D


def _state_modes(M: np.ndarray, K: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poles (Im > 0, ascending) and complex displacement shapes of M x'' + C x' + K x = 0."""
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    lam, X = np.linalg.eig(A)
    up = lam.imag > 0
    lam, X = lam[up], X[:n, up]
    order = np.argsort(lam.imag)
    return lam[order], X[:, order]


def shape_mpc(psi: np.ndarray) -> np.ndarray:
    """Modal phase collinearity of each column of ``psi`` (1: a real shape),
    ((Sxx - Syy)^2 + 4 Sxy^2) / (Sxx + Syy)^2 of its real and imaginary parts."""
    x, y = psi.real, psi.imag
    sxx, syy, sxy = np.sum(x * x, 0), np.sum(y * y, 0), np.sum(x * y, 0)
    return ((sxx - syy) ** 2 + 4 * sxy**2) / (sxx + syy) ** 2


def _chain_case(seed: int, rng: np.random.Generator) -> HardCase:
    """``complex_chain``: a damped chain (:func:`_chain_matrices`) whose dashpots
    are scaled so that its least collinear mode has an MPC drawn in 0.3-0.65
    with no mode above zeta 8 %; drawn again until that holds with a modal
    overlap <= 1 (neighbours apart by at least the sum of their half-power
    half-widths, as the close families) and every mode visible. All masses
    are measured, the reference is the mass that sees the modes best. H is
    the accelerance -w^2 (K - w^2 M + jw C)^-1, exact, plus noise."""
    u = rng.uniform
    for _attempt in range(2000):
        M, K, C0, D = _chain_matrices(rng)
        n = M.shape[0]
        target = u(0.3, 0.65)

        def least_mpc(scale: float, M=M, K=K, C0=C0, D=D, n=n) -> float:
            lam, psi = _state_modes(M, K, C0 + scale * D)
            if lam.size < n or np.max(-lam.real / np.abs(lam)) > 0.08:
                return -1.0  # overdamped or too heavily damped: too strong
            return float(np.min(shape_mpc(psi)))

        lo, hi = 0.0, 1e7
        for _ in range(60):  # largest dashpot scale with least MPC >= target
            scale = np.sqrt(lo * hi) if lo > 0 else hi / 1e4
            if least_mpc(scale) < target:
                hi = scale
            else:
                lo = scale
            if lo > 0 and hi / lo < 1.002:
                break
        if lo == 0:
            continue
        C = C0 + lo * D
        lam, psi = _state_modes(M, K, C)
        fn = np.abs(lam) / (2 * np.pi)
        zeta = -lam.real / np.abs(lam)
        if lam.size < n or not 0.3 <= np.min(shape_mpc(psi)) <= 0.65 or zeta.max() > 0.08:
            continue
        hw = zeta * fn
        if np.any(hw[:-1] + hw[1:] > np.diff(fn)):
            continue
        # lines: half-power band >= 3 lines for every mode
        hi_hz = fn[-1] * u(1.15, 1.3)
        f_top = hi_hz / u(0.88, 0.95)
        lines = [nl for nl in (2049, 4097, 8193, 16385) if np.all(hw >= 1.5 * f_top / (nl - 1))]
        if not lines:
            continue
        n_lines = lines[0]
        freq = np.linspace(0.0, f_top, n_lines)
        lo_hz = max(float(freq[4]), fn[0] * u(0.4, 0.7))
        # residues of the state-space modes: A_r = psi psi^T / (psi^T (2 lam M + C) psi)
        a_r = np.array([psi[:, r] @ (2 * lam[r] * M + C) @ psi[:, r] for r in range(n)])
        jw_pk = 1j * np.abs(lam)
        snr, prop = u(35, 50), u(40, 55)
        jw = 2j * np.pi * freq
        Z = K[None] - (2 * np.pi * freq)[:, None, None] ** 2 * M[None] + jw[:, None, None] * C[None]
        R = np.linalg.inv(Z)  # receptance (n_freq, n, n)
        best, ref = -1.0, 0
        for i in range(n):  # the reference that sees every mode best
            H0 = np.moveaxis(R[:, :, i], 0, -1) * (jw**2)[None, :]
            std = _noise_std(H0[:, None, :], snr, prop)[:, 0, :]
            k_pk = np.argmin(np.abs(freq[:, None] - fn[None, :]), axis=0)
            peak = np.abs(psi * psi[i][None, :] / a_r[None, :] / lam.real[None, :]
                          * (jw_pk**2)[None, :])
            vis = np.sqrt(np.sum((peak / std[:, k_pk]) ** 2, axis=0))
            if vis.min() > best:
                best, ref = float(vis.min()), i
        if best < MIN_VISIBILITY:
            continue
        H0 = (np.moveaxis(R[:, :, ref], 0, -1) * (jw**2)[None, :])[:, None, :]
        H = H0 + _cnoise(rng, _noise_std(H0, snr, prop))
        dofs = [DOF(int(k) + 1, 3) for k in range(n)]
        frf = FRFSet(freq_hz=freq, H=H, response_dofs=tuple(dofs),
                     reference_dofs=(dofs[ref],), quantity="accelerance",
                     configuration=f"complex_chain-{seed}")
        return HardCase("complex_chain", seed, frf, (float(lo_hz), float(hi_hz)), fn, zeta, psi)
    raise RuntimeError(f"complex_chain-{seed}: no chain found")  # pragma: no cover


def _dashpot_matrices(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, K and C of a random chain of 6-10 masses (0.5-2 kg) with a spring
    to ground at every mass (0.1-1 x 4e5 N/m), springs between neighbours
    (0.5-2 x 4e5 N/m), one cross spring between two masses 2 or more apart
    (0.2-1 x 4e5 N/m), light Rayleigh damping (zeta 0.2-0.6 % at the middle
    of the chain's natural frequencies) and 1-3 discrete dashpots of
    40-150 N s/m, to ground or between neighbours."""
    u = rng.uniform
    n = int(rng.integers(6, 11))
    m = np.exp(u(np.log(0.5), np.log(2.0), n))
    K = np.diag(4e5 * np.exp(u(np.log(0.1), np.log(1.0), n)))

    def join(A: np.ndarray, i: int, j: int, value: float) -> None:
        A[i, i] += value
        A[j, j] += value
        A[i, j] -= value
        A[j, i] -= value

    for i in range(n - 1):
        join(K, i, i + 1, 4e5 * float(np.exp(u(np.log(0.5), np.log(2.0)))))
    i = int(rng.integers(0, n - 2))
    join(K, i, int(rng.integers(i + 2, n)), 4e5 * float(np.exp(u(np.log(0.2), np.log(1.0)))))
    M = np.diag(m)
    w = np.sqrt(np.linalg.eigvalsh(K / np.sqrt(np.outer(m, m))))
    wm, z0 = float(np.sqrt(w[0] * w[-1])), u(0.002, 0.006)
    C = z0 * wm * M + z0 / wm * K  # zeta z0 at wm, a little more either side
    for _ in range(int(rng.integers(1, 4))):
        i, c = int(rng.integers(0, n)), float(u(40.0, 150.0))
        if i < n - 1 and u() >= 0.4:
            join(C, i, i + 1, c)
        else:
            C[i, i] += c
    return M, K, C


def _dashpot_case(seed: int, rng: np.random.Generator) -> HardCase:
    """``complex_dashpots``: a chain of :func:`_dashpot_matrices`, drawn
    again until its least collinear mode has an MPC in 0.3-0.65, no mode is
    damped above zeta 8 %, neighbouring modes are at least 3 % apart (their
    half-power bands may overlap) and every mode is visible. 3-5 of the
    masses are measured, and the reference is the mass (measured or not)
    that sees every mode best; the noise is that of ``complex_chain``
    (additive 35-50 dB below each FRF's RMS plus 40-55 dB below |H|). H is
    the accelerance -w^2 (K - w^2 M + jw C)^-1, exact, plus noise."""
    u = rng.uniform
    for _attempt in range(5000):
        M, K, C = _dashpot_matrices(rng)
        n = M.shape[0]
        lam, psi = _state_modes(M, K, C)
        if lam.size < n:
            continue
        fn = np.abs(lam) / (2 * np.pi)
        zeta = -lam.real / np.abs(lam)
        mpc = shape_mpc(psi)
        if not 0.3 <= mpc.min() <= 0.65 or zeta.max() > 0.08 or np.any(fn[1:] < 1.03 * fn[:-1]):
            continue
        hw = zeta * fn
        hi_hz = fn[-1] * u(1.15, 1.3)
        f_top = hi_hz / u(0.88, 0.95)
        lines = [nl for nl in (2049, 4097, 8193, 16385) if np.all(hw >= 1.5 * f_top / (nl - 1))]
        if not lines:
            continue
        freq = np.linspace(0.0, f_top, lines[0])
        lo_hz = max(float(freq[4]), fn[0] * u(0.4, 0.7))
        out = np.sort(rng.choice(n, int(rng.integers(3, 6)), replace=False))
        a_r = np.array([psi[:, r] @ (2 * lam[r] * M + C) @ psi[:, r] for r in range(n)])
        jw_pk = 1j * np.abs(lam)
        snr, prop = u(35, 50), u(40, 55)
        jw = 2j * np.pi * freq
        Z = K[None] - (2 * np.pi * freq)[:, None, None] ** 2 * M[None] + jw[:, None, None] * C[None]
        R = np.linalg.inv(Z)  # receptance (n_freq, n, n)
        k_pk = np.argmin(np.abs(freq[:, None] - fn[None, :]), axis=0)
        best, ref = -1.0, 0
        for i in range(n):  # the reference that sees every mode best
            H0 = np.moveaxis(R[:, out, i], 0, -1) * (jw**2)[None, :]
            std = _noise_std(H0[:, None, :], snr, prop)[:, 0, :]
            peak = np.abs(psi[out] * psi[i][None, :] / a_r[None, :] / lam.real[None, :]
                          * (jw_pk**2)[None, :])
            vis = np.sqrt(np.sum((peak / std[:, k_pk]) ** 2, axis=0))
            if vis.min() > best:
                best, ref = float(vis.min()), i
        if best < MIN_VISIBILITY:
            continue
        H0 = (np.moveaxis(R[:, out, ref], 0, -1) * (jw**2)[None, :])[:, None, :]
        H = H0 + _cnoise(rng, _noise_std(H0, snr, prop))
        dofs = [DOF(int(k) + 1, 3) for k in range(n)]
        frf = FRFSet(freq_hz=freq, H=H, response_dofs=tuple(dofs[k] for k in out),
                     reference_dofs=(dofs[ref],), quantity="accelerance",
                     configuration=f"complex_dashpots-{seed}")
        return HardCase("complex_dashpots", seed, frf, (float(lo_hz), float(hi_hz)), fn, zeta,
                        psi)
    raise RuntimeError(f"complex_dashpots-{seed}: no chain found")  # pragma: no cover


# --------------------------------------------------------------------------- time domain
def _modal_pulse_response(t: np.ndarray, pole: np.ndarray, tp: float, f0: float) -> np.ndarray:
    """y_r(t) = int_0^t exp(lambda_r (t - s)) f(s) ds for the half-sine pulse
    f(s) = f0 sin(pi s / tp), 0 <= s <= tp (exact; t measured from the impact)."""
    wp = np.pi / tp
    lam = pole[:, None]
    tt = np.clip(t, 0.0, tp)[None, :]
    e = np.exp(lam * tt)
    y = f0 / 2j * ((np.exp(1j * wp * tt) - e) / (1j * wp - lam)
                   - (np.exp(-1j * wp * tt) - e) / (-1j * wp - lam))
    after = np.exp(lam * np.clip(t - tp, 0.0, None)[None, :])
    y = np.where(t[None, :] > tp, y * after, y)
    return np.where(t[None, :] >= 0, y, 0.0)


def _close_separation(rng: np.random.Generator, f1: float, z: np.ndarray, T: float) -> float:
    """Relative distance of a close pair at ``f1`` (Hz) with damping ratios
    ``z``: 2-8 %, but at least the sum of their half-power half-widths with
    the exponential window's decay of about 1/tau = 5.5/T, and 3 lines of 1/T."""
    hw = z * f1 + 5.5 / T / (2 * np.pi)  # half-power half-widths with the window, Hz
    return float(max(rng.uniform(0.02, 0.08), (hw[0] + hw[1]) / f1, 3.0 / T / f1))


def _close_low_modes(rng: np.random.Generator, T: float) -> tuple[np.ndarray, np.ndarray]:
    """fn, zeta of ``impact_close``: one or two pairs of close modes at 10-80 Hz
    (:func:`_close_separation`) and 2-6 other modes at 90-780 Hz."""
    u = rng.uniform
    n_pairs = int(rng.integers(1, 3))
    lows = _spaced_log(rng, n_pairs, 10.0, 70.0, 1.6, 3.0)
    fn_list, z_list = [], []
    for f1 in lows:
        z = np.exp(u(np.log(0.002), np.log(0.015), 2))
        sep = _close_separation(rng, f1, z, T)
        fn_list += [f1, f1 * (1 + sep)]
        z_list += list(z)
    n_hi = int(rng.integers(2, 7))
    fn_list += list(_spaced_log(rng, n_hi, 90.0, 780.0, 1.08, 2.5))
    z_list += list(np.exp(u(np.log(0.002), np.log(0.02), n_hi)))
    fn, zeta = np.array(fn_list), np.array(z_list)
    order = np.argsort(fn)
    return fn[order], zeta[order]


def _few_channel_modes(rng: np.random.Generator, T: float) -> tuple[np.ndarray, np.ndarray]:
    """fn, zeta of ``impact_1ch`` and ``impact_2ch``: 4-10 modes at 12-780 Hz
    as ``impact``, and in half of the cases a close partner beside one of
    them (:func:`_close_separation`, at most 40 % of the way to the next
    mode, zeta of both 0.2-1.5 %)."""
    u = rng.uniform
    n = int(rng.integers(4, 11))
    fn = _spaced_log(rng, n, 12.0, 780.0, 1.08, 2.5)
    zeta = np.exp(u(np.log(0.002), np.log(0.02), n))
    if u() < 0.5:
        i = int(rng.integers(0, n))
        z = np.exp(u(np.log(0.002), np.log(0.015), 2))
        sep = _close_separation(rng, fn[i], z, T)
        room = (fn[i + 1] / fn[i] - 1) * 0.4 if i < n - 1 else 0.1
        if sep <= room and fn[i] * (1 + sep) < 790.0:
            zeta[i] = z[0]
            fn, zeta = np.append(fn, fn[i] * (1 + sep)), np.append(zeta, z[1])
    order = np.argsort(fn)
    return fn[order], zeta[order]


def impact_visibility(freq_hz: np.ndarray, H1: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Each mode's own peak over the noise, combined over the channels, in an
    impact test's H1 estimates ``H1`` (n_out, n_lines): the modes' terms at
    their poles shifted by the window ``lam`` (and a constant) fitted by least
    squares on 5-900 Hz, each term's peak |c| / |Re lam| over the RMS of the
    fit's residual (the noise) within 20 lines or 10 half-power half-widths
    of the mode."""
    sel = (freq_hz > 5) & (freq_hz < 900)
    f = freq_hz[sel]
    jw = 2j * np.pi * f[:, None]
    B = np.concatenate([1 / (jw - lam), 1 / (jw - lam.conj()), np.ones_like(jw)], axis=1)
    vis2 = np.zeros(lam.size)
    df = f[1] - f[0]
    for h in H1[:, sel]:
        c = np.linalg.lstsq(B, h, rcond=None)[0]
        res = h - B @ c
        for r in range(lam.size):
            near = np.abs(f - lam[r].imag / (2 * np.pi)) <= max(
                20 * df, 10 * abs(lam[r].real) / (2 * np.pi))
            noise = np.sqrt(np.mean(np.abs(res[near]) ** 2))
            vis2[r] += (abs(c[r]) / abs(lam[r].real) / max(noise, 1e-300)) ** 2
    return np.sqrt(vis2)


def _impact_case(seed: int, rng: np.random.Generator,
                 complex_phase_deg: float = 0.0, family: str = "impact") -> HardCase:
    """Roving-free impact test: 1 hammer point, 1-4 accelerometers, 3-5 hits
    (``family`` "impact_close": close pairs at low frequency,
    :func:`_close_low_modes`; "impact_1ch", "impact_2ch": 1 or 2
    accelerometers, :func:`_few_channel_modes`)."""
    from scipy.signal import decimate

    u = rng.uniform
    fs = 2560.0
    T = float(rng.choice([2.0, 3.2, 4.0, 6.4]))
    N = int(round(fs * T))
    over = 4
    n_out = int(rng.integers(1, 5))
    n_avg = int(rng.integers(3, 6))
    if family == "impact_close":
        fn, zeta = _close_low_modes(rng, T)
        n = fn.size
    elif family in FEW_CHANNEL_FAMILIES:
        n_out = 1 if family == "impact_1ch" else 2
        fn, zeta = _few_channel_modes(rng, T)
        n = fn.size
    else:
        n = int(rng.integers(4, 11))
        fn = _spaced_log(rng, n, 12.0, 780.0, 1.08, 2.5)
        zeta = np.exp(u(np.log(0.002), np.log(0.02), n))
    pole = modal_poles(fn, zeta)
    n_pts = n_out + 1
    out, ref = np.arange(n_out), np.array([n_out])
    phi = _observable(_shapes(rng, n_pts, n, str(rng.choice(["random", "beam"]))), ref, rng)
    phi = _observable(phi, out, rng) if n_out == 1 else phi
    mass = np.exp(u(np.log(0.1), np.log(3.0), n))
    A = _residues(pole, complex_shapes(phi, complex_phase_deg, family, seed), mass, out,
                  ref)[:, :, 0]  # (n_modes, n_out)
    tp = u(0.5e-3, 1.0e-3)
    t0 = 0.01 * T
    tau = T / u(4.0, 7.0)
    t_sim = np.arange(N * over) / (fs * over) - t0
    t = np.arange(N) / fs - t0
    resp_snr, force_snr = u(50, 65), u(45, 60)
    w_exp = np.where(t >= 0, np.exp(-np.clip(t, 0, None) / tau), 1.0)
    w_force = ((t >= -0.002) & (t <= tp + 0.003)).astype(float) * w_exp
    state = rng.bit_generator.state  # the hits' draws, repeated for boosted modes

    def measure(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """H1 (n_out, n_lines) and coherence of the hits with residues ``A``."""
        rng.bit_generator.state = state
        D = np.sum(2 * np.real(A * pole[:, None]), axis=0)  # accelerance feed-through
        X = np.empty((n_avg, n_out, N // 2 + 1), dtype=complex)
        F = np.empty((n_avg, N // 2 + 1), dtype=complex)
        for k in range(n_avg):
            f_amp = u(50, 200)
            tpk = tp * u(0.9, 1.1)
            force = np.where((t_sim >= 0) & (t_sim <= tpk), f_amp * np.sin(np.pi * np.clip(
                t_sim, 0, tpk) / tpk), 0.0)
            y = _modal_pulse_response(t_sim, pole, tpk, f_amp)  # (n_modes, n_sim)
            acc = 2 * np.real((A * pole[:, None] ** 2).T @ y) + D[:, None] * force[None, :]
            fd = decimate(force, over, ftype="fir", zero_phase=True)
            ad = decimate(acc, over, ftype="fir", zero_phase=True, axis=-1)
            fd = fd + rng.standard_normal(N) * f_amp * 10 ** (-force_snr / 20)
            ad = ad + rng.standard_normal(ad.shape) * (
                np.max(np.abs(ad), axis=1, keepdims=True) * 10 ** (-resp_snr / 20))
            F[k] = np.fft.rfft(fd * w_force)
            X[k] = np.fft.rfft(ad * w_exp[None, :], axis=-1)
        Gff = np.mean(np.abs(F) ** 2, axis=0)
        Gxf = np.mean(X * np.conj(F)[:, None, :], axis=0)
        Gxx = np.mean(np.abs(X) ** 2, axis=0)
        return Gxf / Gff[None, :], np.abs(Gxf) ** 2 / (Gff[None, :] * Gxx)

    H1, coh = measure(A)
    for _round in range(4 if family != "impact" else 0):  # "impact" as it was
        # every mode visible (issue 42): the weak ones' residues scaled up; the
        # noise grows with them (it follows the largest response), so repeated
        vis = impact_visibility(np.fft.rfftfreq(N, 1 / fs), H1, pole - 1.0 / tau)
        if np.all(vis >= MIN_VISIBILITY):
            break
        boost = np.where(vis < MIN_VISIBILITY, 1.2 * MIN_VISIBILITY / np.maximum(vis, 1e-3),
                         1.0)
        A = A * boost[:, None]
        H1, coh = measure(A)
    freq = np.fft.rfftfreq(N, 1 / fs)
    keep = freq <= 1000.0
    dofs = [DOF(int(k) + 1, 3) for k in range(n_pts)]
    frf = FRFSet(
        freq_hz=freq[keep],
        H=H1[:, None, keep],
        coherence=np.clip(coh[:, None, keep], 0.0, 1.0),
        response_dofs=tuple(dofs[k] for k in out),
        reference_dofs=(dofs[n_out],),
        quantity="accelerance",
        acquisition=AcquisitionInfo(
            sample_rate_hz=fs, n_samples=N, n_averages=n_avg,
            force_window="rect + exponential", response_window="exponential",
            exp_window_tau_s=float(tau), estimator="H1"),
        configuration=f"{family}-{seed}",
    )
    band = (float(max(2.0, 4 * fs / N)), 900.0)
    return HardCase(family, seed, frf, band, fn, zeta, phi[:, :n])


# --------------------------------------------------------------------------- API
def make_case(family: str, seed: int, complex_phase_deg: float = 0.0) -> HardCase:
    """The hard case ``seed`` of ``family`` (deterministic); with
    ``complex_phase_deg`` > 0 its modes are complex (:func:`complex_shapes`)."""
    if family not in _FAMILY_ID:
        raise ValueError(f"unknown family {family!r}; known: {', '.join(FAMILIES)}")
    rng = np.random.default_rng([11, _FAMILY_ID[family], int(seed)])
    if family in ("impact", "impact_close", *FEW_CHANNEL_FAMILIES):
        return _impact_case(seed, rng, complex_phase_deg, family)
    if family == "complex_chain":
        return _chain_case(seed, rng)
    if family == "complex_dashpots":
        return _dashpot_case(seed, rng)
    return _freq_case(family, seed, rng, complex_phase_deg)


def cases(family: str, seeds: range | list[int]) -> list[HardCase]:
    """``make_case(family, s)`` for every seed."""
    return [make_case(family, int(s)) for s in seeds]


def noise_free_case(family: str, seed: int) -> tuple[HardCase, np.ndarray]:
    """The case ``make_case(family, seed)`` without its noise, and the noise's
    std per FRF and line (n_out, n_in, n_freq), for Monte Carlo runs that
    draw the noise again (``benchmarks/eval_complex_sigmas.py``). The
    frequency-domain families and ``complex_chain`` only: the impact
    families add their noise in the time domain."""
    global _cnoise
    if family in ("impact", "impact_close"):
        raise ValueError(f"{family}: the noise is added in the time domain")
    drawn: dict[str, np.ndarray] = {}
    real = _cnoise

    def no_noise(rng: np.random.Generator, std: np.ndarray) -> np.ndarray:
        drawn["std"] = std  # the last draw of the case: nothing after it changes
        return np.zeros(std.shape, dtype=complex)

    _cnoise = no_noise
    try:
        case = make_case(family, seed)
    finally:
        _cnoise = real
    return case, drawn["std"]
