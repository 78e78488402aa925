"""Simulation: exact FRFs from modal parameters and a simulated impact test.

* **Exact FRF synthesis** from modal parameters (:func:`modal_frf`), the
  pole-residue model used for fast unit tests and as the analytic reference.
* **A simulated impact test** of the paper's cantilever (:func:`simulate_impact_test`):
  half-sine hammer pulses, the exact modal response (closed-form convolution of
  each mode's impulse response with the pulse, no integration error), an
  anti-aliasing front end (simulation at 8x the sample rate, a linear-phase FIR
  low-pass applied to force and response alike, decimation), noise at a given
  SNR, windows, 4 linear averages, H1 and coherence (:mod:`.estimation`). The
  cantilever's modes are the closed form of :mod:`.beam_theory`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ema_pipeline.acquisition.beam_theory import cantilever_beta_l, cantilever_modes
from ema_pipeline.acquisition.estimation import estimate_frf
from ema_pipeline.data import (
    DOF,
    Beam,
    ConfigError,
    DataError,
    FRFSet,
    ModalParameters,
    Quantity,
    TimeRecords,
    damped,
    quantity_power,
)


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
    power = quantity_power(quantity)
    wn = 2 * np.pi * modes.fn_hz
    sigma = modes.zeta * wn
    wd = damped(wn, modes.zeta)
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
    """The paper's impact test: beam, sensors, hammer and acquisition settings.

    Accelerometers at measurement nodes 3 and 6 (as in the paper); the hammer at
    node 8 (x = 0.455 m), where none of the first four modes has a nodal line
    and which stays above the water when the last element is immersed.
    16384 samples at 2000 Hz (8.192 s, df = 0.1221 Hz, 8193 lines 0-1000 Hz),
    4 linear averages, a 0.5 ms half-sine hammer pulse (spectrum flat to within
    a few dB up to 1 kHz, first zero at 3 kHz), 50 ms pretrigger, force window
    0.1 s, exponential window with tau = record length / 5 (the first mode's
    apparent damping roughly doubles; identification corrects it).
    The anti-aliasing filter is linear phase with a flat passband to
    ``aa_pass_fraction`` of Nyquist and a raised-cosine roll-off to zero at
    Nyquist, so nothing aliases.
    """

    __test__ = False  # not a pytest test class despite the name

    beam: Beam = Beam()
    response_nodes: tuple[int, ...] = (3, 6)
    hammer_node: int = 8
    direction: int = 3
    sample_rate_hz: float = 2000.0
    n_samples: int = 16384
    n_averages: int = 4
    pulse_s: float = 0.5e-3
    force_amplitude_n: float = 100.0
    pretrigger_s: float = 0.05
    force_window_s: float = 0.1
    exp_window_tau_s: float = 16384 / 2000.0 / 5
    aa_pass_fraction: float = 0.9
    n_modes_total: int = 8
    high_mode_zeta: float = 0.004

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sample_rate_hz

    @property
    def freq_hz(self) -> np.ndarray:
        return np.fft.rfftfreq(self.n_samples, 1.0 / self.sample_rate_hz)

    def shapes(self, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
        """Mass-normalised shapes at the responses (n_out, m) and the hammer (1, m)."""
        x_out = [self.beam.node_x_m(n) for n in self.response_nodes]
        _, phi_out = cantilever_modes(self.beam, np.array(x_out), n_modes)
        _, phi_in = cantilever_modes(
            self.beam, np.array([self.beam.node_x_m(self.hammer_node)]), n_modes
        )
        return phi_out, phi_in


def configuration_modes(
    configuration: str = "",
    *,
    fd_hz: npt.ArrayLike,
    zeta: npt.ArrayLike,
    n_modes_total: int = 8,
    high_mode_zeta: float = 0.004,
) -> ModalParameters:
    """Modal parameters to simulate: the measured modes plus modes above them.

    The measured modes are ``fd_hz`` (damped natural frequencies, Hz) and
    ``zeta`` (damping ratios, not percent), e.g. a row of the paper's Table 1
    (:data:`ema_pipeline.paper.TABLE1_FD_HZ`, looked up by
    :func:`ema_pipeline.pipeline.simulate.paper_modes`); natural frequencies
    follow eq. (4). Higher modes, up to ``n_modes_total``, continue the last
    measured one with the Euler-Bernoulli ratios (beta_k / beta_n)^2 and damping
    ``high_mode_zeta``. ``configuration`` names the result.

    Examples
    --------
    >>> modes = configuration_modes("genuine", fd_hz=[18.0, 113.0], zeta=[0.01, 0.005],
    ...                             n_modes_total=3)
    >>> modes.fn_hz.round(3), modes.zeta
    (array([ 18.001, 113.001, 316.407]), array([0.01 , 0.005, 0.004]))
    """
    measured = ModalParameters.from_damped(fd_hz, zeta)
    n_meas = measured.n_modes
    if n_modes_total <= n_meas:
        return ModalParameters(measured.fn_hz, measured.zeta, configuration=configuration)
    bl = cantilever_beta_l(n_modes_total)
    high = measured.fn_hz[-1] * (bl[n_meas:] / bl[n_meas - 1]) ** 2
    return ModalParameters(
        fn_hz=np.concatenate([measured.fn_hz, high]),
        zeta=np.concatenate([measured.zeta, np.full(high.size, high_mode_zeta)]),
        configuration=configuration,
    )


def half_sine_spectrum(freq_hz: np.ndarray, duration_s: float, amplitude_n: float) -> np.ndarray:
    """Fourier transform (N/Hz) of a half-sine pulse a*sin(pi t/T), 0 <= t <= T.

    F(w) = a * W * (1 + exp(-j w T)) / (W^2 - w^2), W = pi/T; at w = W the limit
    is -j a T / 2.
    """
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    big_w = np.pi / duration_s
    den = big_w**2 - w**2
    at_pole = np.isclose(den, 0.0, atol=1e-9 * big_w**2)
    safe = np.where(at_pole, 1.0, den)
    F = amplitude_n * big_w * (1 + np.exp(-1j * w * duration_s)) / safe
    return np.where(at_pole, -0.5j * amplitude_n * duration_s, F)


def anti_aliasing_filter(freq_hz: np.ndarray, sample_rate_hz: float, pass_fraction: float):
    """Zero-phase (delay-compensated linear-phase) low-pass of the front end.

    1 up to ``pass_fraction`` * Nyquist, raised-cosine roll-off to 0 at Nyquist.
    """
    nyq = sample_rate_hz / 2
    f = np.abs(np.asarray(freq_hz, dtype=float))
    f_pass = pass_fraction * nyq
    g = np.where(f <= f_pass, 1.0, 0.0)
    roll = (f > f_pass) & (f < nyq)
    g[roll] = 0.5 * (1 + np.cos(np.pi * (f[roll] - f_pass) / (nyq - f_pass)))
    return g


def noise_snr_db(setting_db: float) -> float | None:
    """The ``snr_db`` of :func:`simulate_time_records` for a signal-to-noise
    setting of the command line (``simulate --snr-db``) or the experiment file
    (a simulated configuration's ``snr_db``): 0 (or +inf) means noise-free
    (``None``); any other value is the SNR in dB, negative ones included (noise
    stronger than the signal). NaN is a :class:`~ema_pipeline.data.ConfigError`.

    Examples
    --------
    >>> noise_snr_db(40.0), noise_snr_db(0.0), noise_snr_db(-10.0)
    (40.0, None, -10.0)
    """
    setting_db = float(setting_db)
    if np.isnan(setting_db):
        raise ConfigError("snr_db must be a number of dB (0: noise-free), got nan")
    return None if setting_db == 0 or setting_db == np.inf else setting_db


def simulate_time_records(
    modes: ModalParameters,
    setup: TestSetup = TestSetup(),
    *,
    snr_db: float | None = 40.0,
    seed: int | None = 0,
    configuration: str = "",
    period_factor: int = 8,
    shapes: tuple[np.ndarray, np.ndarray] | None = None,
) -> TimeRecords:
    """Time records of a simulated impact test (force and accelerations).

    ``shapes`` = (phi_out (n_out, n_modes), phi_in (1, n_modes)) are the
    mass-normalised mode shapes at the response and hammer nodes (e.g. of an FE
    beam with added mass,
    :func:`ema_pipeline.added_mass.modified_beam.beam_modes_with_added_mass`); ``None``
    uses the analytic cantilever's (:meth:`TestSetup.shapes`).

    For every impact the analogue signals are exact: the response is the
    convolution of each mode's impulse response with a half-sine hammer pulse
    (amplitude varying +-20 % between impacts), computed as the inverse
    transform of (pole-residue FRF per mode) x (analytic pulse spectrum) x (the
    front end's anti-aliasing filter) over a period ``period_factor`` times the
    record. Over that period the slowest mode decays by
    exp(-sigma_1 * 65 s) < 1e-15, so the wrap-around is below float precision and
    no numerical integration is involved. Force and responses pass through the
    same filter (as in a real front end), which therefore cancels in H1.

    Measurement noise is white Gaussian, added per channel after sampling, with
    standard deviation RMS(channel over the record) * 10^(-snr_db/20);
    ``snr_db=None`` gives noise-free records. Deterministic for a given seed.
    """
    rng = np.random.default_rng(seed)
    fs, n = setup.sample_rate_hz, setup.n_samples
    n_long = n * period_factor
    freq_long = np.fft.rfftfreq(n_long, 1.0 / fs)
    phi_out, phi_in = setup.shapes(modes.n_modes) if shapes is None else shapes
    n_out_expected = len(setup.response_nodes)
    if np.shape(phi_out) != (n_out_expected, modes.n_modes) or np.shape(phi_in) != (
        1, modes.n_modes
    ):
        raise DataError(
            f"simulation needs mode shapes ({n_out_expected}, {modes.n_modes}) at the responses "
            f"and (1, {modes.n_modes}) at the hammer, got {np.shape(phi_out)} and "
            f"{np.shape(phi_in)}"
        )
    H = modal_frf(freq_long, modes, phi_out, phi_in)[:, 0, :]  # (n_out, n_freq)
    G = anti_aliasing_filter(freq_long, fs, setup.aa_pass_fraction)
    delay = np.exp(-2j * np.pi * freq_long * setup.pretrigger_s)
    n_avg, n_out = setup.n_averages, phi_out.shape[0]
    force = np.empty((n_avg, n))
    response = np.empty((n_avg, n_out, n))
    amplitudes = setup.force_amplitude_n * rng.uniform(0.8, 1.2, n_avg)
    for k in range(n_avg):  # 4 impacts: the FFTs inside are the vectorised part
        F = half_sine_spectrum(freq_long, setup.pulse_s, amplitudes[k]) * G * delay
        force[k] = fs * np.fft.irfft(F, n=n_long)[:n]
        response[k] = fs * np.fft.irfft(H * F, n=n_long, axis=-1)[:, :n]
    if snr_db is not None:
        scale = 10.0 ** (-snr_db / 20.0)
        f_rms = np.sqrt(np.mean(force**2, axis=-1, keepdims=True))
        r_rms = np.sqrt(np.mean(response**2, axis=-1, keepdims=True))
        force = force + scale * f_rms * rng.standard_normal(force.shape)
        response = response + scale * r_rms * rng.standard_normal(response.shape)
    return TimeRecords(
        force=force,
        response=response,
        sample_rate_hz=fs,
        trigger_s=setup.pretrigger_s,
        response_dofs=tuple(DOF(node, setup.direction) for node in setup.response_nodes),
        reference_dof=DOF(setup.hammer_node, setup.direction),
        configuration=configuration or modes.configuration,
    )


def simulate_impact_test(
    modes: ModalParameters,
    setup: TestSetup = TestSetup(),
    *,
    snr_db: float | None = 40.0,
    seed: int | None = 0,
    shapes: tuple[np.ndarray, np.ndarray] | None = None,
) -> FRFSet:
    """A whole simulated impact test: time records, windows, H1 with coherence.

    ``modes`` are the modal parameters to simulate, e.g. from
    :func:`configuration_modes` (the paper's configurations by name:
    :func:`ema_pipeline.pipeline.simulate.simulate_paper_test`; an FE beam with
    added mass: :func:`ema_pipeline.pipeline.simulate.simulate_added_mass_test`).
    See :func:`simulate_time_records` (also for ``shapes``).
    """
    records = simulate_time_records(modes, setup, snr_db=snr_db, seed=seed, shapes=shapes)
    return estimate_frf(
        records,
        force_window_s=setup.force_window_s,
        exp_window_tau_s=setup.exp_window_tau_s,
    )
