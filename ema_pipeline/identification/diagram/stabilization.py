"""Stabilization data: pole stability between model orders.

The record, :class:`~ema_pipeline.identification.result.StabilizationData`,
is one of the light result types of :mod:`~ema_pipeline.identification.result`.
The diagram is drawn by :func:`ema_pipeline.report.matplotlib_plots.plot_stabilization`.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.identification.diagram.plscf import PoleSet
from ema_pipeline.identification.result import (  # the result types live in result
    STABLE_DAMP,
    STABLE_FREQ,
    STABLE_VECTOR,
    StabilizationData,
)
from ema_pipeline.modal import mac_pairs, pole_fd_hz, pole_fn_hz


def pole_to_modal(pole: np.ndarray, window_decay_rate: float = 0.0) -> tuple[np.ndarray, ...]:
    """Natural frequency, damped frequency and damping ratio of poles.

    The exponential window moves every pole left by 1/tau:
    lambda_id = lambda - 1/tau, so lambda = lambda_id + ``window_decay_rate``.
    With lambda = -sigma + 1j*omega_d:

        f_n = |lambda| / (2 pi),   f_d = omega_d / (2 pi),   zeta = sigma / |lambda|

    Returns ``(fn_hz, fd_hz, zeta)``.
    """
    lam = np.asarray(pole, dtype=complex) + window_decay_rate
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = -lam.real / np.abs(lam)
    return pole_fn_hz(lam), pole_fd_hz(lam), zeta


def stabilization(
    poles: PoleSet,
    window_decay_rate: float = 0.0,
    *,
    tol_freq: float,
    tol_zeta: float,
    tol_mac: float,
) -> StabilizationData:
    """Flag each pole against the closest pole (in frequency) of the previous order.

    The tolerances are ``IdentificationOptions.diagram_tolerances()`` (their
    defaults are ``SelectionThresholds.diagram_tol_*``).

    Stable in frequency if |f - f_prev| / f_prev < ``tol_freq``; in damping if
    |zeta - zeta_prev| / zeta_prev < ``tol_zeta``; in participation vector if
    1 - MAC(l, l_prev) < ``tol_mac``, MAC = |l^H l_prev|^2 / (|l|^2 |l_prev|^2).
    Poles of the first order are never stable.
    """
    fn, _, zeta = pole_to_modal(poles.pole, window_decay_rate)
    flags = np.zeros(poles.pole.size, dtype=np.uint8)
    starts = np.searchsorted(poles.order, poles.orders)  # poles are sorted by order
    ends = np.append(starts[1:], poles.order.size)
    for k in range(1, poles.orders.size):
        cur = slice(starts[k], ends[k])
        prev = slice(starts[k - 1], ends[k - 1])
        if ends[k - 1] == starts[k - 1] or ends[k] == starts[k]:
            continue
        f1, f0 = fn[cur], fn[prev]
        j = np.argmin(np.abs(f1[:, None] - f0[None, :]), axis=1)
        ok_f = np.abs(f1 - f0[j]) < tol_freq * f0[j]
        z0 = zeta[prev][j]
        ok_z = np.abs(zeta[cur] - z0) < tol_zeta * np.abs(z0)
        l1 = poles.participation[cur]
        l0 = poles.participation[prev][j]
        ok_v = 1 - mac_pairs(l1.T, l0.T) < tol_mac
        flags[cur] = (
            ok_f * STABLE_FREQ + (ok_f & ok_z) * STABLE_DAMP + (ok_f & ok_v) * STABLE_VECTOR
        ).astype(np.uint8)
    return StabilizationData(
        order=poles.order.copy(),
        freq_hz=fn,
        zeta=zeta,
        flags=flags,
        pole=poles.pole.copy(),
        cluster=np.full(poles.pole.size, -1),
        tol_freq=tol_freq,
        tol_zeta=tol_zeta,
        tol_mac=tol_mac,
    )
