"""Stage 1 of the ``"plscf"`` backend
(:mod:`~ema_pipeline.identification.plscf_backend`): the band's FRFs as every
stage sees them (:class:`BandData`, made by :func:`band_data`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import FRFSet, Quantity
from ema_pipeline.identification.common import resolve_band
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.thresholds import SelectionThresholds

__all__ = ["BandData", "band_data"]


@dataclass(frozen=True)
class BandData:
    """The band's FRFs as every stage sees them (:func:`band_data`).

    Attributes
    ----------
    sub : the FRF set cut to the band.   band_hz : (lo, hi) in Hz.
    Hn : (n_out, n_in, n_freq) each output scaled by its RMS in the band.
    Hc, Hn_c : ``sub.H`` and ``Hn`` with one row per channel (n_out * n_in).
    weights : the lines' weights of the pLSCF equations (coherence
        weighting), or None.
    min_peak : the peak ratio a candidate must reach in the search's screen.
    window_decay_rate : 1/tau of the exponential window (1/s; 0 without).
    window_tau_s, force_window_s : the windows of the FRFs (s, or None).
    expect_hz : the expected frequencies (Hz), None for the automatic selection.
    thresholds : the selection's thresholds.
    """

    sub: FRFSet
    band_hz: tuple[float, float]
    Hn: np.ndarray
    Hc: np.ndarray
    Hn_c: np.ndarray
    weights: np.ndarray | None
    min_peak: float
    window_decay_rate: float
    window_tau_s: float | None
    force_window_s: float | None
    expect_hz: np.ndarray | None
    thresholds: SelectionThresholds

    @property
    def freq_hz(self) -> np.ndarray:
        return self.sub.freq_hz

    @property
    def quantity(self) -> Quantity:
        return self.sub.quantity


def band_data(frf: FRFSet, options: IdentificationOptions) -> BandData:
    """Stage 1: the FRFs of the options' band (:func:`resolve_band`), each
    output scaled by its RMS in the band, the coherence weights and the
    windows."""
    lo, hi = resolve_band(frf, options.band_hz)
    sub = frf.band(lo, hi)
    n_out, n_in, n_freq = sub.H.shape
    th = options.thresholds
    rms = np.sqrt(np.mean(np.abs(sub.H) ** 2, axis=(1, 2)))
    Hn = sub.H / rms[:, None, None]
    weights = None
    if options.weighting == "coherence":
        assert sub.coherence is not None  # identify() refuses coherence weighting without it
        weights = np.sqrt(np.clip(np.mean(sub.coherence, axis=1), 0.0, 1.0))
    return BandData(
        sub=sub, band_hz=(lo, hi), Hn=Hn, Hc=sub.H.reshape(n_out * n_in, n_freq),
        Hn_c=Hn.reshape(n_out * n_in, n_freq), weights=weights,
        min_peak=th.min_peak_ratio_shapes if n_out * n_in >= 3 else th.min_peak_ratio,
        window_decay_rate=float(frf.acquisition.window_decay_rate),
        window_tau_s=frf.acquisition.exp_window_tau_s,
        force_window_s=frf.acquisition.force_window_s,
        expect_hz=np.asarray(options.expect_hz, dtype=float) if options.expect_hz else None,
        thresholds=th,
    )
