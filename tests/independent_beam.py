"""The paper's beam as an independent FE truth for the added-mass tests.

100 Euler-Bernoulli elements (Hermite cubic, consistent mass), clamped at x = 0,
assembled here with a few lines of numpy, independently of ``ema_pipeline.fe``;
extra mass (stiffness) delta on measurement element j scales the mass
(stiffness) matrices of its ten fine elements by 1 + delta.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

LENGTH_M, WIDTH_M, THICK_M, E_PA, RHO = 0.65, 0.05, 0.01, 210e9, 7800.0
N_EL, N_MEAS = 100, 10
def truth(
    added: dict[int, float], n_modes: int = 6, stiffness: dict[int, float] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Independent FE truth: (fn_hz, mass-normalised shapes, K, M), clamped node removed."""
    stiffness = stiffness or {}
    le = LENGTH_M / N_EL
    ei = E_PA * WIDTH_M * THICK_M**3 / 12
    ra = RHO * WIDTH_M * THICK_M
    ke = ei / le**3 * np.array([[12, 6 * le, -12, 6 * le],
                                [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                                [-12, -6 * le, 12, -6 * le],
                                [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    me = ra * le / 420 * np.array([[156, 22 * le, 54, -13 * le],
                                   [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                                   [54, 13 * le, 156, -22 * le],
                                   [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
    n = 2 * (N_EL + 1)
    k, m = np.zeros((n, n)), np.zeros((n, n))
    for e in range(N_EL):
        meas = e // (N_EL // N_MEAS) + 1  # fine elements 91-100 (e = 90..99) -> element 10
        s = slice(2 * e, 2 * e + 4)
        k[s, s] += (1 + stiffness.get(meas, 0.0)) * ke
        m[s, s] += (1 + added.get(meas, 0.0)) * me
    k, m = k[2:, 2:], m[2:, 2:]  # clamp at x = 0
    w, v = scipy.linalg.eigh(k, m, subset_by_index=[0, n_modes - 1])
    return np.sqrt(w) / (2 * np.pi), v, k, m
