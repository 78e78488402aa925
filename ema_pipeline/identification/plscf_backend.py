"""The ``"plscf"`` backend of :func:`ema_pipeline.identification.identify`:
pLSCF stabilization, automatic (or ``expect_hz``-guided) pole selection,
refinement with covariance and LSFD."""

from __future__ import annotations

import numpy as np

from ema_pipeline.data import FRFSet
from ema_pipeline.identification.common import (
    default_max_order,
    finish_identification,
    resolve_band,
)
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.plscf import plscf
from ema_pipeline.identification.result import IdentificationResult, ResolvedSettings
from ema_pipeline.identification.selection import cluster_poles, select_poles
from ema_pipeline.identification.stabilization import StabilizationData, stabilization


def identify_plscf(frf: FRFSet, options: IdentificationOptions) -> IdentificationResult:
    """Identify with this package's pLSCF chain.

    Called by :func:`ema_pipeline.identification.identify`, which checks the
    FRF set and the options first (band, order, coherence, ``expect_hz``
    sorted and inside the band) and applies ``options.exp_window_tau_s``;
    call that, not this, with unchecked input.
    """
    lo, hi = resolve_band(frf, options.band_hz)
    sub = frf.band(lo, hi)
    n_out, n_in, n_freq = sub.H.shape
    p = (
        default_max_order(frf.n_in, sub.freq_hz.size)
        if options.max_order is None
        else int(options.max_order)
    )
    expect_hz = np.asarray(options.expect_hz, dtype=float) if options.expect_hz else None
    decay = float(frf.acquisition.window_decay_rate)
    freq = sub.freq_hz
    rms = np.sqrt(np.mean(np.abs(sub.H) ** 2, axis=(1, 2)))
    Hn = sub.H / rms[:, None, None]
    weights = None
    if options.weighting == "coherence":
        assert sub.coherence is not None  # identify() refuses coherence weighting without it
        weights = np.sqrt(np.clip(np.mean(sub.coherence, axis=1), 0.0, 1.0))
    orders = np.arange(2, p + 1, 2) if n_in == 1 else np.arange(1, p + 1)
    poles = plscf(freq, Hn, max_order=p, orders=orders, weights=weights)
    stab = stabilization(
        poles, decay, tol_freq=options.tol_freq, tol_zeta=options.tol_zeta,
        tol_mac=options.tol_mac,
    )
    labels = cluster_poles(stab, (lo, hi))
    stab = StabilizationData(**{**stab.__dict__, "cluster": labels})
    sel = select_poles(stab, labels, expect_hz=expect_hz, min_fraction=options.min_fraction)
    return finish_identification(
        sub,
        sel.pole,
        decay=decay,
        refine=options.refine,
        lower_residual=options.lower_residual,
        upper_residual=options.upper_residual,
        stab=stab,
        selected=sel,
        screen=expect_hz is None,
        settings=ResolvedSettings(
            method="plscf",
            band_hz=(lo, hi),
            max_order=p,
            orders=orders,
            dt_s=poles.dt,
            weighting=options.weighting,
            window_decay_rate=decay,
            tol_freq=options.tol_freq,
            tol_zeta=options.tol_zeta,
            tol_mac=options.tol_mac,
            min_fraction=options.min_fraction,
            refine=options.refine,
            lower_residual=options.lower_residual,
            upper_residual=options.upper_residual,
            expect_hz=expect_hz,
            uncertainty="least-squares covariance of the refined poles"
            if options.refine
            else "scatter of the cluster poles over model orders",
        ),
    )
