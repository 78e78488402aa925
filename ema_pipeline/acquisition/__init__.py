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
import numpy.typing as npt

from ema_pipeline.acquisition.sep005 import from_sep005  # noqa: F401  (re-export)
from ema_pipeline.data import (
    DOF,
    AcquisitionInfo,
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

# beta_n * L of a clamped-free Euler-Bernoulli beam: roots of cos(x)cosh(x) = -1.
_CANTILEVER_BETA_L = np.array(
    [1.8751040687119611, 4.6940911329741745, 7.8547574382376126, 10.995540734875467]
)


def cantilever_beta_l(n_modes: int) -> np.ndarray:
    """First ``n_modes`` roots beta_n*L of cos(x) cosh(x) = -1 (clamped-free beam).

    Examples
    --------
    >>> cantilever_beta_l(3)  # roots of cos(x) cosh(x) = -1
    array([1.87510407, 4.69409113, 7.85475744])
    >>> x = cantilever_beta_l(4)
    >>> bool(np.allclose(np.cos(x) * np.cosh(x), -1.0))
    True
    """
    n = np.arange(1, n_modes + 1)
    roots = (2 * n - 1) * np.pi / 2  # asymptote, exact to 1e-15 from n = 5
    roots[: min(n_modes, 4)] = _CANTILEVER_BETA_L[: min(n_modes, 4)]
    return roots


def cantilever_modes(beam: Beam, x_m: np.ndarray, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
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


def force_window(
    n_samples: int, sample_rate_hz: float, width_s: float, taper_s: float = 0.01
) -> np.ndarray:
    """Rectangular force window of ``width_s`` seconds closed by a half-cosine taper.

    Examples
    --------
    >>> force_window(6, 1000.0, width_s=0.002, taper_s=0.002)  # ones, half-cosine, zeros
    array([1. , 1. , 1. , 0.5, 0. , 0. ])
    """
    t = np.arange(n_samples) / sample_rate_hz
    w = np.ones(n_samples)
    taper = (t > width_s) & (t < width_s + taper_s)
    w[taper] = 0.5 * (1 + np.cos(np.pi * (t[taper] - width_s) / taper_s))
    w[t >= width_s + taper_s] = 0.0
    return w


def exponential_window(
    n_samples: int, sample_rate_hz: float, tau_s: float, t0_s: float = 0.0
) -> np.ndarray:
    """Exponential window exp(-(t - t0)/tau); it adds 1/tau (1/s) to every decay rate.

    Examples
    --------
    >>> exponential_window(4, 1000.0, tau_s=0.002)  # exp(-t / 2 ms) at 1 kHz
    array([1.        , 0.60653066, 0.36787944, 0.22313016])
    """
    t = np.arange(n_samples) / sample_rate_hz
    return np.exp(-(t - t0_s) / tau_s)


#: Largest exponent exp(-(t - t0)/tau) may reach over a record, either side of the
#: trigger t0: the window stays between the float precision eps and 1/eps, so that it
#: neither loses the record's end (underflow to 0) nor overflows before the trigger.
EXP_WINDOW_MAX_EXPONENT = float(np.log(1.0 / np.finfo(float).eps))  # 36.04


def shortest_exp_window_tau(n_samples: int, sample_rate_hz: float, t0_s: float = 0.0) -> float:
    """Shortest time constant (s) of an exponential window over a record of
    ``n_samples`` with the trigger at ``t0_s``: the longer of the spans after and
    before the trigger over :data:`EXP_WINDOW_MAX_EXPONENT`.

    Examples
    --------
    >>> round(shortest_exp_window_tau(1025, 1024.0, 0.01), 5)  # 0.99 s / 36.04
    0.02747
    """
    after = (n_samples - 1) / sample_rate_hz - t0_s
    return max(after, t0_s) / EXP_WINDOW_MAX_EXPONENT


def estimate_frf(
    records: TimeRecords,
    *,
    force_window_s: float | None = None,
    exp_window_tau_s: float | None = None,
    estimator: str = "H1",
) -> FRFSet:
    """FRFs from repeated impacts by linear averaging of auto and cross spectra.

    H1 = sum X F* / sum |F|^2 (noise on the response), H2 = sum |X|^2 / sum F X*
    (noise on the force); coherence = |sum X F*|^2 / (sum |F|^2 sum |X|^2).
    Hv (total least squares, noise on both) is, per response and line, the
    eigenvector of the 2 x 2 spectral matrix [[Sff, Sfx], [Sxf, Sxx]] of the
    smallest eigenvalue: Hv = (Sxx - Sff + sqrt((Sxx - Sff)^2 + 4 |Sxf|^2)) / (2 Sfx),
    with Sxf = sum X F*, Sfx = conj(Sxf); it weighs force (N) and response noise
    equally in the units given, and |H1| <= |Hv| <= |H2|.

    The exponential window exp(-(t - trigger)/tau) is applied to force and
    response alike, so that for a noise-free test the windowed FRF equals the
    structure's FRF with every pole moved left by 1/tau and unchanged residues
    (exp(-t/tau) distributes over a convolution). The force window (rectangular
    over ``force_window_s`` seconds plus a 10 ms cosine taper) multiplies the
    force record on top of that.

    Parameters
    ----------
    records : force (N) and response (m/s^2) records, one row per impact.
    force_window_s : width of the force window in s, ``None`` for none.
    exp_window_tau_s : time constant tau (s) of the exponential window, ``None``
        for none. It adds 1/tau to every mode's decay rate; the value goes into
        ``FRFSet.acquisition`` so that identification can undo it.
    estimator : "H1", "H2" or "Hv".

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> force = rng.standard_normal((4, 64))
    >>> records = TimeRecords(force=force, response=2.0 * force, sample_rate_hz=64.0)
    >>> [float(abs(estimate_frf(records, estimator=e).H[0, 0, 5])) for e in ("H1", "H2", "Hv")]
    [2.0, 2.0, 2.0]
    """
    if estimator not in ("H1", "H2", "Hv"):
        raise DataError(f"unknown FRF estimator {estimator!r}; use 'H1', 'H2' or 'Hv'")
    fs, n_samples = records.sample_rate_hz, records.n_samples
    w_exp = np.ones(n_samples)
    if exp_window_tau_s is not None:
        shortest = shortest_exp_window_tau(n_samples, fs, records.trigger_s)
        if not (exp_window_tau_s > 0 and exp_window_tau_s >= shortest):
            where = f"{records.source.path}: " if records.source.path else ""
            raise DataError(
                f"{where}exponential window time constant (exp_window_tau / --exp-window-tau) "
                f"{exp_window_tau_s:g} s is too short for records of {n_samples / fs:g} s "
                f"(trigger at {records.trigger_s:g} s): the window would leave the float range "
                f"(1e-16 to 1e16); give at least {shortest:.4g} s, or none")
        w_exp = exponential_window(n_samples, fs, exp_window_tau_s, records.trigger_s)
    w_force = w_exp.copy()
    if force_window_s:
        w_force *= force_window(n_samples, fs, force_window_s)
    F = np.fft.rfft(records.force * w_force, axis=-1)  # (n_avg, n_freq)
    X = np.fft.rfft(records.response * w_exp, axis=-1)  # (n_avg, n_out, n_freq)
    Sff = np.sum(np.abs(F) ** 2, axis=0)
    Sxf = np.sum(X * F[:, None, :].conj(), axis=0)
    Sxx = np.sum(np.abs(X) ** 2, axis=0)
    tiny = np.finfo(float).tiny
    if estimator == "H1":
        H = Sxf / np.maximum(Sff, tiny)
    elif estimator == "H2":
        H = Sxx / np.where(np.abs(Sxf) > tiny, Sxf.conj(), tiny)
    else:  # Hv: smallest-eigenvalue eigenvector of [[Sff, Sfx], [Sxf, Sxx]]
        diff = Sxx - Sff[None, :]
        H = (diff + np.sqrt(diff**2 + 4 * np.abs(Sxf) ** 2)) / (
            2 * np.where(np.abs(Sxf) > tiny, Sxf.conj(), tiny))
    coherence = np.abs(Sxf) ** 2 / np.maximum(Sff * Sxx, tiny)
    info = AcquisitionInfo(
        sample_rate_hz=float(fs),
        n_samples=int(n_samples),
        n_averages=int(records.n_averages),
        force_window=f"rect {force_window_s:g} s" if force_window_s else "none",
        response_window="exponential" if exp_window_tau_s else "none",
        exp_window_tau_s=exp_window_tau_s,
        estimator=estimator,
    )
    return FRFSet(
        freq_hz=np.fft.rfftfreq(n_samples, 1.0 / fs),
        H=H[:, None, :],
        coherence=np.clip(coherence, 0.0, 1.0)[:, None, :],
        quantity="accelerance",
        acquisition=info,
        response_dofs=records.response_dofs,
        reference_dofs=(records.reference_dof,),
        configuration=records.configuration,
        source=records.source,
    )


# --------------------------------------------------------------------------
# Simulated impact test of the paper's cantilever
# --------------------------------------------------------------------------


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
