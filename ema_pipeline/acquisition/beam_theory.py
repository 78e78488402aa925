"""Beam theory: the analytic modes of a clamped-free Euler-Bernoulli beam.

The closed form (roots of cos(x) cosh(x) = -1, mass-normalised shapes) is
exact and cheap, which is why it is written here rather than taken from
:mod:`ema_pipeline.fe`; the FE model converges to it (tested). The simulated
impact test (:mod:`.simulation`) uses these modes for the paper's cantilever.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.data import Beam

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
