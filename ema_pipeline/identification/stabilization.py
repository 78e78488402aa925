"""Stabilization data: pole stability between model orders.

The diagram is drawn by :func:`ema_pipeline.plots.plot_stabilization`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ema_pipeline.identification.plscf import PoleSet
from ema_pipeline.modal import mac_pairs, pole_fd_hz, pole_fn_hz

#: Bits of :attr:`StabilizationData.flags`.
STABLE_FREQ = 1
STABLE_DAMP = 2
STABLE_VECTOR = 4
STABLE_ALL = STABLE_FREQ | STABLE_DAMP | STABLE_VECTOR


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


@dataclass(frozen=True)
class StabilizationData:
    """Poles of all model orders with their stability flags (plain arrays for HDF5).

    Attributes
    ----------
    order : (n,) int          model (polynomial) order of each pole
    freq_hz : (n,) float      natural frequency f_n of the window-corrected pole, Hz
    zeta : (n,) float         damping ratio of the window-corrected pole
    flags : (n,) uint8        bit 1: frequency stable (< ``tol_freq`` relative change
                              against the nearest pole of the previous order),
                              bit 2: damping stable (< ``tol_zeta``),
                              bit 4: participation vector stable (MAC > 1 - ``tol_mac``)
    pole : (n,) complex       identified pole lambda (rad/s, before window correction)
    cluster : (n,) int        cluster of the automatic selection, -1 = none
    tol_freq, tol_zeta, tol_mac : the tolerances used (NaN: no diagram, e.g.
                              the sdypy backend).
    mode_pole : (n_modes,) complex  the start pole of each kept mode (result
                              order, before window correction): a trajectory's
                              median or a pole found outside the diagram; what
                              the report's diagram and ``--picks`` use
                              (:mod:`ema_pipeline.identification.picks`).
    companion_pole : (n,) complex  the start poles of the candidates refined
                              together with the kept modes in their final
                              fit that the final tests then dropped (before
                              window correction): ``--picks`` refines them
                              with the picks and drops them again, so that
                              the untouched picks reproduce the kept modes.
    """

    order: np.ndarray
    freq_hz: np.ndarray
    zeta: np.ndarray
    flags: np.ndarray
    pole: np.ndarray
    cluster: np.ndarray
    tol_freq: float = float("nan")
    tol_zeta: float = float("nan")
    tol_mac: float = float("nan")
    mode_pole: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))
    companion_pole: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))

    @property
    def stable(self) -> np.ndarray:
        """Poles stable in frequency, damping and participation vector."""
        return (self.flags & STABLE_ALL) == STABLE_ALL


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
