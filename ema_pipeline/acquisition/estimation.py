"""FRF estimation from time records: H1, H2 and Hv with ordinary coherence
from repeated impacts (linear averaging), a force window and an exponential
window on both channels.

The exponential window exp(-t/tau) adds 1/tau to every mode's decay rate
sigma_r = zeta_r*omega_r; the time constant is recorded in
:class:`~ema_pipeline.data.AcquisitionInfo` so that identification can undo it.

Written by hand because no maintained library does it: scipy.signal has
windows and spectral densities (``csd``/``welch``) but estimates from
overlapped segments of one stream, not from separately triggered impacts with
a force window; sdypy-EMA identifies but does not acquire.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import AcquisitionInfo, DataError, FRFSet, TimeRecords


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


@dataclass(frozen=True)
class FRFEstimate:
    """What :func:`estimate_frf_windows` made: the FRFs ``frf``, the windows it
    applied, each one value per sample of the records (``exp_window``: the
    exponential window on force and responses; ``force_window``: the force window
    alone, which multiplies the force on top of it; ones where there is none),
    and ``force_autospectrum``, the windowed force's autospectrum averaged over
    the records (one value per frequency line)."""

    frf: FRFSet
    exp_window: np.ndarray
    force_window: np.ndarray
    force_autospectrum: np.ndarray


def estimate_frf(
    records: TimeRecords,
    *,
    force_window_s: float | None = None,
    exp_window_tau_s: float | None = None,
    estimator: str = "H1",
) -> FRFSet:
    """FRFs from repeated impacts by linear averaging of auto and cross spectra:
    the ``frf`` of :func:`estimate_frf_windows` (which also returns the windows
    applied and the force autospectrum).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> force = rng.standard_normal((4, 64))
    >>> records = TimeRecords(force=force, response=2.0 * force, sample_rate_hz=64.0)
    >>> [float(abs(estimate_frf(records, estimator=e).H[0, 0, 5])) for e in ("H1", "H2", "Hv")]
    [2.0, 2.0, 2.0]
    """
    return estimate_frf_windows(records, force_window_s=force_window_s,
                                exp_window_tau_s=exp_window_tau_s, estimator=estimator).frf


def estimate_frf_windows(
    records: TimeRecords,
    *,
    force_window_s: float | None = None,
    exp_window_tau_s: float | None = None,
    estimator: str = "H1",
) -> FRFEstimate:
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

    Returns
    -------
    FRFEstimate : the FRFs, with the windows applied and the force autospectrum.

    Examples
    --------
    >>> force = np.zeros((2, 64))
    >>> force[:, 1] = 1.0
    >>> records = TimeRecords(force=force, response=3.0 * force, sample_rate_hz=64.0)
    >>> out = estimate_frf_windows(records, force_window_s=0.5, exp_window_tau_s=0.25)
    >>> float(abs(out.frf.H[0, 0, 3])), out.force_window[[0, 40, 63]].tolist()
    (3.0, [1.0, 0.0, 0.0])
    >>> round(float(out.exp_window[16]), 4), out.force_autospectrum.shape  # exp(-1)
    (0.3679, (33,))
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
    w_force_alone = np.ones(n_samples)
    if force_window_s:
        w_force_alone = force_window(n_samples, fs, force_window_s)
        w_force *= w_force_alone
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
    frf = FRFSet(
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
    force_auto = np.mean(np.abs(F) ** 2, axis=0)
    return FRFEstimate(frf=frf, exp_window=w_exp, force_window=w_force_alone,
                       force_autospectrum=force_auto)
