"""Stabilization data (pole stability between model orders) and its diagram."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ema_pipeline.identification.plscf import PoleSet

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

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
    wn = np.abs(lam)
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = -lam.real / wn
    return wn / (2 * np.pi), lam.imag / (2 * np.pi), zeta


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
    tol_freq, tol_zeta, tol_mac : the tolerances used.
    """

    order: np.ndarray
    freq_hz: np.ndarray
    zeta: np.ndarray
    flags: np.ndarray
    pole: np.ndarray
    cluster: np.ndarray
    tol_freq: float = 0.01
    tol_zeta: float = 0.05
    tol_mac: float = 0.02

    @property
    def stable(self) -> np.ndarray:
        """Poles stable in frequency, damping and participation vector."""
        return (self.flags & STABLE_ALL) == STABLE_ALL


def stabilization(
    poles: PoleSet,
    window_decay_rate: float = 0.0,
    *,
    tol_freq: float = 0.01,
    tol_zeta: float = 0.05,
    tol_mac: float = 0.02,
) -> StabilizationData:
    """Flag each pole against the closest pole (in frequency) of the previous order.

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
        mac = np.abs(np.sum(l1.conj() * l0, axis=1)) ** 2 / (
            np.sum(np.abs(l1) ** 2, axis=1) * np.sum(np.abs(l0) ** 2, axis=1)
        )
        ok_v = 1 - mac < tol_mac
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


def plot_stabilization(
    ax: Axes,
    stab: StabilizationData,
    *,
    freq_hz: np.ndarray | None = None,
    frf_sum: np.ndarray | None = None,
    selected_hz: np.ndarray | None = None,
) -> Axes:
    """Draw a stabilization diagram onto ``ax``.

    Markers: ``o`` stable in frequency, damping and vector; ``v`` stable in
    frequency and damping; ``.`` frequency only; ``x`` unstable (grey).
    Cluster members are drawn in colour. With ``freq_hz`` and ``frf_sum`` (e.g.
    the sum of |H| over all FRFs) the FRF sum is drawn on a twin log axis;
    ``selected_hz`` draws vertical lines at the selected modes.
    """
    f, n, fl = stab.freq_hz, stab.order, stab.flags
    groups = [
        (fl & STABLE_ALL == STABLE_ALL, "o", "tab:green", "stable f, zeta, vector"),
        ((fl & STABLE_DAMP > 0) & (fl & STABLE_ALL != STABLE_ALL), "v", "tab:blue",
         "stable f, zeta"),
        ((fl & STABLE_FREQ > 0) & (fl & STABLE_DAMP == 0), ".", "tab:orange", "stable f"),
        (fl & STABLE_FREQ == 0, "x", "0.7", "new / unstable"),
    ]
    for mask, marker, color, label in groups:
        if np.any(mask):
            ax.plot(f[mask], n[mask], marker, color=color, ms=3, ls="none", label=label)
    if selected_hz is not None:
        for fs in np.atleast_1d(selected_hz):
            ax.axvline(fs, color="tab:red", lw=0.8, alpha=0.7)
    ax.set_xlabel("frequency / Hz")
    ax.set_ylabel("model order")
    if freq_hz is not None and frf_sum is not None:
        ax2 = ax.twinx()
        ax2.semilogy(freq_hz, frf_sum, color="k", lw=0.8)
        ax2.set_ylabel("sum |H|")
    ax.legend(loc="upper left", fontsize="small")
    return ax
