"""Acquisition stage: FRFs from an impact test, measured or simulated.

Three things live here:

* **FRF estimation** from time records (:func:`estimate_frf`): H1 and H2 with
  ordinary coherence from repeated impacts (linear averaging), a force window and
  an exponential window on both channels. The exponential window exp(-t/tau)
  adds 1/tau to every mode's decay rate sigma_r = zeta_r*omega_r; the time
  constant is recorded in :class:`~ema_pipeline.data.AcquisitionInfo` so that
  identification can undo it.
* **Exact FRF synthesis** from modal parameters (:func:`modal_frf`), the
  pole-residue model used for fast unit tests and as the analytic reference.
* **A simulated impact test** of the paper's cantilever (:func:`simulate_impact_test`):
  half-sine hammer pulses, the exact modal response (closed-form convolution of
  each mode's impulse response with the pulse, no integration error), an
  anti-aliasing front end (simulation at 8x the sample rate, a linear-phase FIR
  low-pass applied to force and response alike, decimation), noise at a given
  SNR, windows, 4 linear averages, H1 and coherence.

The analytic cantilever modes (Euler-Bernoulli, clamped-free) are written here
rather than taken from :mod:`ema_pipeline.fe` because the closed form is exact
and cheap; the FE model converges to it (tested).

These are written by hand because no maintained library does them: scipy.signal
has windows and spectral densities (``csd``/``welch``) but estimates from
overlapped segments of one stream, not from separately triggered impacts with a
force window; sdypy-EMA identifies but does not acquire.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from ema_pipeline.data import (
    DOF,
    AcquisitionInfo,
    Beam,
    DataError,
    FRFSet,
    ModalParameters,
    Quantity,
)

# beta_n * L of a clamped-free Euler-Bernoulli beam: roots of cos(x)cosh(x) = -1.
_CANTILEVER_BETA_L = np.array(
    [1.8751040687119611, 4.6940911329741745, 7.8547574382376126, 10.995540734875467]
)


def cantilever_beta_l(n_modes: int) -> np.ndarray:
    """First ``n_modes`` roots beta_n*L of cos(x) cosh(x) = -1 (clamped-free beam)."""
    n = np.arange(1, n_modes + 1)
    roots = (2 * n - 1) * np.pi / 2  # asymptote, exact to 1e-15 from n = 5
    roots[: min(n_modes, 4)] = _CANTILEVER_BETA_L[: min(n_modes, 4)]
    return roots


def cantilever_modes(
    beam: Beam, x_m: np.ndarray, n_modes: int
) -> tuple[np.ndarray, np.ndarray]:
    """Analytic natural frequencies and mass-normalised mode shapes of a cantilever.

    Parameters
    ----------
    beam : Beam
        Uniform beam (point masses are ignored by the closed form).
    x_m : (n_points,) positions along the beam in m, 0 = clamp.
    n_modes : number of bending modes.

    Returns
    -------
    fn_hz : (n_modes,) natural frequencies in Hz.
    phi : (n_points, n_modes) mode shapes scaled so that int(rho*A*phi^2 dx) = 1.
    """
    bl = cantilever_beta_l(n_modes)
    length = beam.length_m
    ei = beam.youngs_modulus_pa * beam.second_moment_m4
    rho_a = beam.density_kg_m3 * beam.area_m2
    omega = bl**2 * np.sqrt(ei / (rho_a * length**4))
    s = np.asarray(x_m, dtype=float)[:, None] / length * bl[None, :]
    sigma = (np.cosh(bl) + np.cos(bl)) / (np.sinh(bl) + np.sin(bl))
    # Written to avoid cosh - sinh cancellation at high beta*x: cosh(s)-sigma*sinh(s)
    # = 0.5*((1-sigma) e^s + (1+sigma) e^-s); 1 - sigma is tiny but exact enough.
    hyper = 0.5 * ((1 - sigma) * np.exp(s) + (1 + sigma) * np.exp(-s))
    shape = hyper - np.cos(s) + sigma * np.sin(s)
    # int_0^L shape^2 dx = L for this normalisation (tip value 2 * (-1)^(n+1)).
    phi = shape / np.sqrt(rho_a * length)
    return omega / (2 * np.pi), phi


def modal_frf(
    freq_hz: np.ndarray,
    modes: ModalParameters,
    phi_out: np.ndarray,
    phi_in: np.ndarray,
    quantity: Quantity = "accelerance",
    extra_decay: float = 0.0,
) -> np.ndarray:
    """Exact FRF of a viscously damped system with real (normal) modes.

    The receptance is H_d = sum_r phi_o phi_i / (w_r^2 - w^2 + 2j zeta_r w_r w),
    written in pole-residue form H_d = sum_r A_r/(jw - l_r) + conj with
    l_r = -zeta_r w_r + j w_dr and A_r = phi_o phi_i / (2j w_dr). Mobility and
    accelerance multiply by (jw)^p, which in pole-residue form is
    sum_r A_r l_r^p / (jw - l_r) + conj + a direct term (sum 2 Re(A_r l_r) for
    accelerance, 0 otherwise).

    ``extra_decay`` (1/s) moves every pole left, l_r -> l_r - extra_decay, with
    the residues unchanged: that is what an exponential window exp(-t/tau) on
    force and response does to the measured FRF (extra_decay = 1/tau).

    Parameters
    ----------
    freq_hz : (n_freq,) frequency axis in Hz.
    modes : natural frequencies and damping ratios.
    phi_out : (n_out, n_modes) mass-normalised shapes at the response DOFs.
    phi_in : (n_in, n_modes) mass-normalised shapes at the reference DOFs.

    Returns
    -------
    H : (n_out, n_in, n_freq) complex.
    """
    power = {"receptance": 0, "mobility": 1, "accelerance": 2}[quantity]
    wn = 2 * np.pi * modes.fn_hz
    sigma = modes.zeta * wn
    wd = wn * np.sqrt(1 - modes.zeta**2)
    lam = -sigma + 1j * wd
    residue = (
        np.asarray(phi_out)[:, None, :] * np.asarray(phi_in)[None, :, :] / (2j * wd)
    )  # (n_out, n_in, n_modes)
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    shifted = lam - extra_decay
    num = residue * lam**power
    H = np.einsum("oim,mk->oik", num, 1.0 / (jw[None, :] - shifted[:, None]))
    H += np.einsum("oim,mk->oik", num.conj(), 1.0 / (jw[None, :] - shifted.conj()[:, None]))
    if power == 2:
        H += 2 * np.real(residue * lam).sum(axis=-1)[..., None]
    return H


def synthesize_frf_set(
    freq_hz: np.ndarray,
    modes: ModalParameters,
    phi_out: np.ndarray,
    phi_in: np.ndarray,
    *,
    quantity: Quantity = "accelerance",
    noise_rel: float = 0.0,
    seed: int | None = None,
    response_dofs: tuple[DOF, ...] = (),
    reference_dofs: tuple[DOF, ...] = (),
    configuration: str = "",
) -> FRFSet:
    """Direct frequency-domain synthesis of an FRF set, for fast tests.

    Optional complex Gaussian noise of standard deviation ``noise_rel`` times the
    RMS of each FRF is added (seeded by ``seed``).
    """
    H = modal_frf(freq_hz, modes, phi_out, phi_in, quantity=quantity)
    if noise_rel > 0:
        rng = np.random.default_rng(seed)
        rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=-1, keepdims=True))
        noise = rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)
        H = H + noise_rel * rms * noise / np.sqrt(2)
    return FRFSet(
        freq_hz=freq_hz,
        H=H,
        quantity=quantity,
        response_dofs=response_dofs,
        reference_dofs=reference_dofs,
        configuration=configuration,
    )


@dataclass(frozen=True)
class TestSetup:
    """The paper's impact test: beam, sensor and hammer nodes, acquisition settings.

    Accelerometers at measurement nodes 3 and 6 (as in the paper); the hammer at
    node 8 (x = 0.455 m), where none of the first four modes has a node and
    which stays above the water line when the last element is immersed.
    """

    beam: Beam = Beam()
    response_nodes: tuple[int, ...] = (3, 6)
    hammer_node: int = 8
    sample_rate_hz: float = 2000.0
    n_samples: int = 16384
    n_averages: int = 4
    pulse_s: float = 0.5e-3
    pretrigger_s: float = 0.05
    force_window_s: float = 0.1
    exp_window_tau_s: float = 8.192 / 5
    oversample: int = 8
    n_modes_total: int = 8

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sample_rate_hz

    @property
    def freq_hz(self) -> np.ndarray:
        return np.fft.rfftfreq(self.n_samples, 1.0 / self.sample_rate_hz)


def _check_time_records(force: np.ndarray, response: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    force = np.asarray(force, dtype=float)
    response = np.asarray(response, dtype=float)
    if force.ndim == 1:
        force = force[None, :]
    if response.ndim == 2:
        response = response[:, None, :]
    if force.ndim != 2 or response.ndim != 3:
        raise DataError(
            "time records must be force (n_averages, n_samples) and "
            f"response (n_averages, n_out, n_samples); got {force.shape} and {response.shape}"
        )
    if response.shape[0] != force.shape[0] or response.shape[-1] != force.shape[-1]:
        raise DataError(
            f"force records {force.shape} and response records {response.shape} "
            "differ in number of averages or samples"
        )
    if not (np.all(np.isfinite(force)) and np.all(np.isfinite(response))):
        raise DataError("time records contain NaN/inf values")
    if not np.any(force):
        raise DataError("force records are all zero: no impact recorded")
    return force, response


def force_window(n_samples: int, sample_rate_hz: float, width_s: float, taper_s: float = 0.01):
    """Rectangular force window of ``width_s`` seconds with a half-cosine taper."""
    t = np.arange(n_samples) / sample_rate_hz
    w = np.ones(n_samples)
    taper = (t > width_s) & (t < width_s + taper_s)
    w[taper] = 0.5 * (1 + np.cos(np.pi * (t[taper] - width_s) / taper_s))
    w[t >= width_s + taper_s] = 0.0
    return w


def exponential_window(n_samples: int, sample_rate_hz: float, tau_s: float, t0_s: float = 0.0):
    """Exponential window exp(-(t - t0)/tau); it adds 1/tau to every decay rate."""
    t = np.arange(n_samples) / sample_rate_hz
    return np.exp(-(t - t0_s) / tau_s)


def estimate_frf(
    force: np.ndarray,
    response: np.ndarray,
    sample_rate_hz: float,
    *,
    force_window_s: float | None = None,
    exp_window_tau_s: float | None = None,
    trigger_s: float = 0.0,
    estimator: str = "H1",
    response_dofs: tuple[DOF, ...] = (),
    reference_dofs: tuple[DOF, ...] = (),
    configuration: str = "",
) -> FRFSet:
    """FRFs from repeated impacts by linear averaging of auto and cross spectra.

    H1 = sum X F* / sum |F|^2 (noise on the response), H2 = sum |X|^2 / sum F X*
    (noise on the force); coherence = |sum X F*|^2 / (sum |F|^2 sum |X|^2).

    Parameters
    ----------
    force : (n_averages, n_samples) hammer force in N, one row per impact.
    response : (n_averages, n_out, n_samples) accelerations in m/s^2.
    sample_rate_hz : sampling rate in Hz.
    force_window_s : width of the force window (rectangular + 10 ms cosine taper),
        ``None`` for none.
    exp_window_tau_s : time constant tau (s) of the exponential window applied to
        force and response alike; it adds 1/tau to every mode's decay rate.
    trigger_s : time of the impact in the record; the exponential starts there.
    estimator : "H1" or "H2".
    """
    force, response = _check_time_records(force, response)
    if estimator not in ("H1", "H2"):
        raise DataError(f"unknown FRF estimator {estimator!r}; use 'H1' or 'H2'")
    n_samples = force.shape[-1]
    w_exp = np.ones(n_samples)
    if exp_window_tau_s:
        if exp_window_tau_s <= 0:
            raise DataError(f"exponential window time constant must be > 0, got {exp_window_tau_s}")
        w_exp = exponential_window(n_samples, sample_rate_hz, exp_window_tau_s, trigger_s)
    w_force = w_exp.copy()
    if force_window_s:
        w_force *= force_window(n_samples, sample_rate_hz, force_window_s)
    F = np.fft.rfft(force * w_force, axis=-1)  # (n_avg, n_freq)
    X = np.fft.rfft(response * w_exp, axis=-1)  # (n_avg, n_out, n_freq)
    Sff = np.sum(np.abs(F) ** 2, axis=0)
    Sxf = np.sum(X * F[:, None, :].conj(), axis=0)
    Sxx = np.sum(np.abs(X) ** 2, axis=0)
    tiny = np.finfo(float).tiny
    if estimator == "H1":
        H = Sxf / np.maximum(Sff, tiny)
    else:
        H = Sxx / np.where(np.abs(Sxf) > tiny, Sxf.conj(), tiny)
    coherence = np.abs(Sxf) ** 2 / np.maximum(Sff * Sxx, tiny)
    info = AcquisitionInfo(
        sample_rate_hz=float(sample_rate_hz),
        n_samples=int(n_samples),
        n_averages=int(force.shape[0]),
        force_window=f"rectangular {force_window_s} s + exponential" if force_window_s else "none",
        response_window="exponential" if exp_window_tau_s else "none",
        exp_window_tau_s=exp_window_tau_s,
        estimator=estimator,
    )
    return FRFSet(
        freq_hz=np.fft.rfftfreq(n_samples, 1.0 / sample_rate_hz),
        H=H[:, None, :],
        coherence=np.clip(coherence, 0.0, 1.0)[:, None, :],
        quantity="accelerance",
        acquisition=info,
        response_dofs=response_dofs,
        reference_dofs=reference_dofs,
        configuration=configuration,
    )
