"""The public entry point :func:`identify` and its result."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
import pandas as pd

from ema_pipeline.data import DataError, FRFSet, ModalParameters
from ema_pipeline.identification import lsfd as _lsfd
from ema_pipeline.identification.plscf import plscf
from ema_pipeline.identification.selection import SelectedPoles, cluster_poles, select_poles
from ema_pipeline.identification.stabilization import (
    StabilizationData,
    pole_to_modal,
    stabilization,
)

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

Method = Literal["plscf", "sdypy-lscf"]

#: Factor on the least-squares standard deviations. The covariance of the
#: refined poles assumes the noise model of the local fit; the noise of real
#: H1 estimates is correlated over many lines (force and exponential windows)
#: beyond what the residual autocorrelation correction recovers. Calibrated on
#: simulated impact tests (3 configurations x 20 seeds, 40 dB SNR, 4 averages):
#: with 2.0 the RMS of error/std is 0.7-1.1 per mode and parameter.
STD_CALIBRATION = 2.0

#: Automatic selection drops a pole whose decay rate has a (calibrated)
#: relative standard deviation above this: it models noise, not a mode.
#: Physical modes of the simulated tests sit below 0.01, noise poles near 1.
MAX_REL_SIGMA_STD = 0.5
Weighting = Literal["none", "coherence"]


@dataclass(frozen=True)
class IdentificationSettings:
    """Everything :func:`identify` used, resolved (no ``None`` left but ``expect_hz``)."""

    method: str
    band_hz: tuple[float, float]
    max_order: int
    orders: np.ndarray
    dt_s: float
    weighting: str
    window_decay_rate: float
    tol_freq: float
    tol_zeta: float
    tol_mac: float
    min_fraction: float
    refine: bool
    lower_residual: bool
    upper_residual: bool
    expect_hz: np.ndarray | None
    uncertainty: str


@dataclass(frozen=True)
class IdentificationResult:
    """Modal parameters identified from one FRF set, with everything to judge them.

    Attributes
    ----------
    modes : ModalParameters
        f_n, zeta (window-corrected, structural), their standard deviations,
        complex mode shapes (modal constants 2j omega_d A_r at the response DOFs
        for the reference ``shape_reference``), configuration.
    pole : (n_modes,) complex  window-corrected poles lambda_r (rad/s).
    residues : (n_modes, n_out, n_in) complex  receptance residues A_r.
    lower_residual, upper_residual : (n_out, n_in) complex residual terms (in the
        FRF's quantity; see :mod:`ema_pipeline.identification.lsfd`).
    shapes_real : (n_out, n_modes) real-normalised shapes (largest component +1).
    shape_reference : int  index of the reference used for ``modes.shapes``.
    mac : (n_modes, n_modes) auto-MAC of the shapes.
    mpc : (n_modes,) modal phase collinearity (1 = real mode).
    freq_hz : (n_freq,) the band's lines.   H_fit : (n_out, n_in, n_freq) synthesis.
    frac, error : (n_out, n_in) FRAC and normalised error ||H - H_fit|| / ||H|| per FRF.
    stabilization : StabilizationData (empty arrays for the sdypy backend).
    selected : SelectedPoles (cluster bookkeeping; ``None`` for the sdypy backend).
    settings : IdentificationSettings
    """

    modes: ModalParameters
    pole: np.ndarray
    residues: np.ndarray
    lower_residual: np.ndarray
    upper_residual: np.ndarray
    shapes_real: np.ndarray
    shape_reference: int
    mac: np.ndarray
    mpc: np.ndarray
    freq_hz: np.ndarray
    H_fit: np.ndarray
    frac: np.ndarray
    error: np.ndarray
    stabilization: StabilizationData
    selected: SelectedPoles | None
    settings: IdentificationSettings
    extras: dict[str, float] = field(default_factory=dict)

    @property
    def fn_hz(self) -> np.ndarray:
        return self.modes.fn_hz

    @property
    def fd_hz(self) -> np.ndarray:
        return self.modes.fd_hz

    @property
    def zeta(self) -> np.ndarray:
        return self.modes.zeta


def modes_table(result: IdentificationResult) -> pd.DataFrame:
    """One row per mode, ascending frequency:
    ``mode, fn_hz, fd_hz, zeta_pct, fn_std_hz, zeta_std_pct`` (zeta in percent)."""
    m = result.modes
    order = np.argsort(m.fn_hz)
    return pd.DataFrame(
        {
            "mode": np.arange(1, m.n_modes + 1),
            "fn_hz": m.fn_hz[order],
            "fd_hz": m.fd_hz[order],
            "zeta_pct": 100 * m.zeta[order],
            "fn_std_hz": m.fn_std_hz[order],
            "zeta_std_pct": 100 * m.zeta_std[order],
        }
    )


# --------------------------------------------------------------------------- checks
def _resolve_band(frf: FRFSet, band_hz: tuple[float, float] | None) -> tuple[float, float]:
    f = frf.freq_hz
    if band_hz is None:
        return float(f[min(5, f.size - 2)]), float(f[-1])
    lo, hi = (float(b) for b in band_hz)
    if not (np.isfinite(lo) and np.isfinite(hi)) or not lo < hi:
        raise DataError(f"band {band_hz} Hz is not an interval lo < hi")
    if lo < f[0] - 1e-9 or hi > f[-1] + 1e-9:
        raise DataError(
            f"band [{lo:g}, {hi:g}] Hz lies outside the frequency axis [{f[0]:g}, {f[-1]:g}] Hz"
        )
    return lo, hi


def _check_input(sub: FRFSet, max_order: int, where: str) -> None:
    n_lines = sub.freq_hz.size
    if max_order < 1:
        raise DataError(f"max_order must be >= 1, got {max_order}")
    need = 2 * (max_order + 1)
    if n_lines < need:
        raise DataError(
            f"{where}the band has {n_lines} frequency lines, too few for model order "
            f"{max_order} (need at least {need}); lower max_order or widen the band"
        )
    zero = ~np.any(sub.H != 0, axis=-1)
    if zero.any():
        o, i = np.argwhere(zero)[0]
        raise DataError(
            f"{where}FRF channel response {sub.response_dofs[o].label()} / reference "
            f"{sub.reference_dofs[i].label()} is all zero in the band; remove the channel"
        )


def default_max_order(n_in: int, n_lines: int) -> int:
    """Default highest polynomial order: 40 matrix coefficients for one reference
    (80 poles), fewer per extra reference, never more than the lines allow."""
    p = {1: 64, 2: 40, 3: 30}.get(n_in, 24)
    return int(min(p, n_lines // 2 - 1))


# --------------------------------------------------------------------------- main
def identify(
    frf: FRFSet,
    *,
    band_hz: tuple[float, float] | None = None,
    max_order: int | None = None,
    method: Method = "plscf",
    expect: list[float] | np.ndarray | None = None,
    weighting: Weighting = "none",
    tol_freq: float = 0.01,
    tol_zeta: float = 0.05,
    tol_mac: float = 0.02,
    min_fraction: float = 0.3,
    refine: bool = True,
    lower_residual: bool = True,
    upper_residual: bool = True,
) -> IdentificationResult:
    """Identify modal parameters from an FRF set (pLSCF + automatic selection + LSFD).

    Parameters
    ----------
    frf : FRFSet, (n_out, n_in, n_freq) FRFs. Roving-hammer sets (many
        references, one response) should be transposed by reciprocity first
        (:func:`ema_pipeline.identification.reciprocal`).
    band_hz : (lo, hi) band in Hz; default: from the 6th line (skipping 0 Hz
        and the first lines) to the last line.
    max_order : highest pLSCF denominator order p (p * n_in poles); default
        :func:`default_max_order`.
    method : "plscf" (this package) or "sdypy-lscf" (sdypy-EMA, see
        :func:`ema_pipeline.identification.sdypy_backend.identify_sdypy`).
    expect : approximate natural frequencies in Hz; the nearest stable pole
        cluster is taken for each (one mode per entry) instead of the automatic
        choice.
    weighting : "none" (each output scaled by its RMS in the band) or
        "coherence" (additionally every line weighted by the coherence).
    tol_freq, tol_zeta, tol_mac : stabilization tolerances (relative frequency,
        relative damping, 1 - MAC of participation vectors).
    min_fraction : a cluster must hold poles of at least this fraction of the
        computed orders to count as a physical mode.
    refine : refine the selected poles by variable-projection nonlinear least
        squares (see :func:`~ema_pipeline.identification.lsfd.refine_poles`).
    lower_residual, upper_residual : residual terms in LSFD.

    Returns
    -------
    IdentificationResult

    Notes
    -----
    z-domain sampling time: dt = 1 / (2 f_hi), f_hi the band top.
    Exponential window: the identified pole is lambda' = lambda - 1/tau with
    1/tau = ``frf.acquisition.window_decay_rate``; reported values use
    lambda = lambda' + 1/tau: sigma = sigma' - 1/tau, omega_d unchanged,
    f_n = |lambda| / 2 pi, zeta = sigma / |lambda|.
    Uncertainty (``refine=True``): standard deviations of f_n and zeta by
    first-order propagation of the least-squares covariance of the refined
    poles (inverse Fisher matrix of the noise-weighted local pole-residue fit,
    the noise level and its line-to-line correlation estimated from the fit
    residual), times ``STD_CALIBRATION``; with ``refine=False`` the
    scatter of the cluster's poles over the model orders (an underestimate).
    """
    where = f"{frf.source.path}: " if frf.source.path else ""
    if method not in ("plscf", "sdypy-lscf"):
        raise DataError(f"unknown identification method {method!r}; use 'plscf' or 'sdypy-lscf'")
    if weighting not in ("none", "coherence"):
        raise DataError(f"unknown weighting {weighting!r}; use 'none' or 'coherence'")
    frf.check_finite()
    lo, hi = _resolve_band(frf, band_hz)
    sub = frf.band(lo, hi)
    p = default_max_order(frf.n_in, sub.freq_hz.size) if max_order is None else int(max_order)
    _check_input(sub, p, where)
    if weighting == "coherence" and frf.coherence is None:
        raise DataError(f"{where}coherence weighting asked for but the FRF set has no coherence")
    expect_hz = None if expect is None else np.sort(np.atleast_1d(np.asarray(expect, float)))
    if expect_hz is not None and (
        expect_hz.size == 0 or np.any(expect_hz <= lo) or np.any(expect_hz >= hi)
    ):
        raise DataError(
            f"expected frequencies {expect_hz} must lie inside the band [{lo:g}, {hi:g}] Hz"
        )
    decay = float(frf.acquisition.window_decay_rate)
    if method == "sdypy-lscf":
        from ema_pipeline.identification.sdypy_backend import identify_sdypy

        return identify_sdypy(
            frf,
            band_hz=(lo, hi),
            max_order=max_order,
            expect=expect_hz,
            lower_residual=lower_residual,
            upper_residual=upper_residual,
        )

    freq = sub.freq_hz
    n_out, n_in, n_freq = sub.H.shape
    rms = np.sqrt(np.mean(np.abs(sub.H) ** 2, axis=(1, 2)))
    Hn = sub.H / rms[:, None, None]
    weights = None
    if weighting == "coherence":
        weights = np.sqrt(np.clip(np.mean(sub.coherence, axis=1), 0.0, 1.0))
    orders = np.arange(2, p + 1, 2) if n_in == 1 else np.arange(1, p + 1)
    poles = plscf(freq, Hn, max_order=p, orders=orders, weights=weights)
    stab = stabilization(poles, decay, tol_freq=tol_freq, tol_zeta=tol_zeta, tol_mac=tol_mac)
    labels = cluster_poles(stab, (lo, hi))
    stab = StabilizationData(**{**stab.__dict__, "cluster": labels})
    sel = select_poles(stab, labels, expect_hz=expect_hz, min_fraction=min_fraction)
    return finish_identification(
        sub,
        sel.pole,
        decay=decay,
        refine=refine,
        lower_residual=lower_residual,
        upper_residual=upper_residual,
        stab=stab,
        selected=sel,
        screen=expect_hz is None,
        settings=IdentificationSettings(
            method="plscf",
            band_hz=(lo, hi),
            max_order=p,
            orders=orders,
            dt_s=poles.dt,
            weighting=weighting,
            window_decay_rate=decay,
            tol_freq=tol_freq,
            tol_zeta=tol_zeta,
            tol_mac=tol_mac,
            min_fraction=min_fraction,
            refine=refine,
            lower_residual=lower_residual,
            upper_residual=upper_residual,
            expect_hz=expect_hz,
            uncertainty="least-squares covariance of the refined poles"
            if refine
            else "scatter of the cluster poles over model orders",
        ),
    )


def finish_identification(
    sub: FRFSet,
    pole_id: np.ndarray,
    *,
    decay: float,
    refine: bool,
    lower_residual: bool,
    upper_residual: bool,
    stab: StabilizationData,
    selected: SelectedPoles | None,
    settings: IdentificationSettings,
    screen: bool = False,
) -> IdentificationResult:
    """LSFD, optional refinement with covariance, window correction, indicators.

    With ``screen`` (automatic selection) poles whose decay rate the data do
    not determine (calibrated std(sigma)/sigma >= ``MAX_REL_SIGMA_STD``) are
    dropped as computational before refinement.
    """
    freq = sub.freq_hz
    n_out, n_in, n_freq = sub.H.shape
    Hc = sub.H.reshape(n_out * n_in, n_freq)
    m = pole_id.size
    fn_std = np.full(m, np.nan)
    zeta_std = np.full(m, np.nan)
    if m and refine and screen:
        rel = STD_CALIBRATION * _lsfd.pole_significance(freq, Hc, pole_id)
        keep = rel < MAX_REL_SIGMA_STD
        pole_id = pole_id[keep]
        if selected is not None:
            selected = SelectedPoles(**{k: v[keep] for k, v in selected.__dict__.items()})
        m = pole_id.size
        fn_std = fn_std[keep]
        zeta_std = zeta_std[keep]
    if m and refine:
        ref = _lsfd.refine_poles(freq, Hc, pole_id)
        pole_id = ref.pole
        fn_std, zeta_std = _lsfd.modal_std(pole_id + decay, ref.cov)
        fn_std, zeta_std = STD_CALIBRATION * fn_std, STD_CALIBRATION * zeta_std
    elif m and selected is not None:
        fn_std, zeta_std = selected.scatter_fn_hz, selected.scatter_zeta
    pole = pole_id + decay
    fn, fd, zeta = pole_to_modal(pole)
    if m:
        fit = _lsfd.lsfd(
            freq, Hc, pole_id, sub.quantity, lower=lower_residual, upper=upper_residual
        )
        q = {"receptance": 0, "mobility": 1, "accelerance": 2}[sub.quantity]
        residues = (fit.a / pole[:, None] ** q).reshape(m, n_out, n_in)
        H_fit = fit.H_fit.reshape(n_out, n_in, n_freq)
        low = fit.lower.reshape(n_out, n_in)
        up = fit.upper.reshape(n_out, n_in)
    else:
        residues = np.zeros((0, n_out, n_in), dtype=complex)
        H_fit = np.zeros_like(sub.H)
        low = np.zeros((n_out, n_in), dtype=complex)
        up = np.zeros((n_out, n_in), dtype=complex)
    i_ref = int(np.argmax(np.sum(np.abs(residues) ** 2, axis=(0, 1)))) if m else 0
    shapes = (2j * pole.imag)[None, :] * residues[:, :, i_ref].T  # (n_out, m)
    modes = ModalParameters(
        fn_hz=fn,
        zeta=zeta,
        fn_std_hz=fn_std,
        zeta_std=zeta_std,
        shapes=shapes,
        dofs=sub.response_dofs,
        configuration=sub.configuration,
    )
    return IdentificationResult(
        modes=modes,
        pole=pole,
        residues=residues,
        lower_residual=low,
        upper_residual=up,
        shapes_real=_lsfd.real_normalised(shapes),
        shape_reference=i_ref,
        mac=_lsfd.mac(shapes),
        mpc=_lsfd.mpc(shapes),
        freq_hz=freq,
        H_fit=H_fit,
        frac=_lsfd.frac(sub.H, H_fit),
        error=_lsfd.normalised_error(sub.H, H_fit),
        stabilization=stab,
        selected=selected,
        settings=settings,
    )


def reciprocal(frf: FRFSet) -> FRFSet:
    """The transposed FRF set H^T (Maxwell-Betti reciprocity): a roving-hammer
    test (n_ref hammer points, one response) becomes n_ref outputs x 1 reference."""
    from dataclasses import replace

    coh = None if frf.coherence is None else np.swapaxes(frf.coherence, 0, 1)
    return replace(
        frf,
        H=np.swapaxes(frf.H, 0, 1),
        coherence=coh,
        response_dofs=frf.reference_dofs,
        reference_dofs=frf.response_dofs,
    )


def plot_fit_quality(
    ax: Axes, result: IdentificationResult, H: np.ndarray, output: int, reference: int = 0
) -> Axes:
    """Draw measured vs synthesised FRF ``(output, reference)`` with its FRAC and
    normalised error onto ``ax``. ``H`` is the measured (n_out, n_in, n_freq)
    array on ``result.freq_hz`` (e.g. ``frf.band(*result.settings.band_hz).H``)."""
    label = f"{result.modes.dofs[output].label()}" if result.modes.dofs else f"out {output}"
    return _lsfd.plot_fit(
        ax,
        result.freq_hz,
        H[output, reference],
        result.H_fit[output, reference],
        label=label,
        frac_value=float(result.frac[output, reference]),
        error_value=float(result.error[output, reference]),
    )
