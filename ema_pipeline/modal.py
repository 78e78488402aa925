"""Small modal numerics shared by the stages: the one home of the MAC, of the
mean phase deviation of a shape (:func:`mpd`) and of a pole's frequencies in Hz.

Identification (auto-MAC of the identified shapes, stability of participation
vectors between model orders, FRAC of the synthesised FRFs) and the
added-mass stage (pairing of modes between configurations) call these instead
of writing the formula again. A pole lambda = -sigma + j omega_d (rad/s) has
the natural frequency |lambda| / 2 pi (:func:`pole_fn_hz`), the damped
frequency omega_d / 2 pi (:func:`pole_fd_hz`) and the half-power half-width
sigma / 2 pi (:func:`pole_half_width_hz`), all in Hz. The damped frequency of
a natural frequency and a damping ratio is :func:`ema_pipeline.data.damped`
(the data containers need it, and they are below this module).

Why written here: the MAC is one line of numpy; no library we depend on
exposes it for complex shapes.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.data import DataError

__all__ = ["mac", "mac_pairs", "mpd", "pole_fd_hz", "pole_fn_hz", "pole_half_width_hz",
           "poles_overlap"]


def mac(phi_a: np.ndarray, phi_b: np.ndarray | None = None) -> np.ndarray:
    """Modal assurance criterion of every pair of columns.

    MAC_ij = |a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j)); 0 where a shape is all zero.

    Parameters
    ----------
    phi_a : (n_dof, n_a) real or complex mode shapes (one per column).
    phi_b : (n_dof, n_b) shapes at the same DOFs; default ``phi_a`` (auto-MAC).

    Returns
    -------
    (n_a, n_b) array of values in [0, 1].

    Raises
    ------
    DataError
        If the shapes are not 2-D arrays with the same number of DOFs.

    Examples
    --------
    >>> phi = np.array([[1.0, 1.0], [2.0, -0.5]])  # two orthogonal shapes
    >>> mac(phi).round(6)
    array([[1., 0.],
           [0., 1.]])
    >>> float(mac(phi[:, :1], 2j * phi[:, :1])[0, 0])  # blind to complex scaling
    1.0
    """
    a = np.asarray(phi_a)
    b = a if phi_b is None else np.asarray(phi_b)
    if a.ndim != 2 or b.ndim != 2 or a.shape[0] != b.shape[0]:
        raise DataError(f"mode shapes {a.shape} and {b.shape} are not at the same DOFs")
    num = np.abs(a.conj().T @ b) ** 2
    # the norms as in mac_pairs (and in the selection's pole linking)
    den = np.sum(np.abs(a) ** 2, axis=0)[:, None] * np.sum(np.abs(b) ** 2, axis=0)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, 0.0)


def mac_pairs(phi_a: np.ndarray, phi_b: np.ndarray) -> np.ndarray:
    """MAC of corresponding columns only: the diagonal of ``mac(phi_a, phi_b)``.

    Parameters
    ----------
    phi_a, phi_b : (n_dof, n) shapes or vectors (one per column), same shape.

    Returns
    -------
    (n,) MAC of column k of ``phi_a`` with column k of ``phi_b``; 0 where a
    column is all zero.

    Examples
    --------
    >>> phi = np.array([[1.0, 1.0], [2.0, -0.5]])
    >>> mac_pairs(phi, -3.0 * phi)
    array([1., 1.])
    >>> mac_pairs(phi, phi[:, ::-1]).round(6)
    array([0., 0.])
    """
    a = np.asarray(phi_a)
    b = np.asarray(phi_b)
    if a.shape != b.shape or a.ndim != 2:
        raise DataError(f"vectors {a.shape} and {b.shape} do not pair column by column")
    num = np.abs(np.sum(a.conj() * b, axis=0)) ** 2
    den = np.sum(np.abs(a) ** 2, axis=0) * np.sum(np.abs(b) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, 0.0)


def pole_fn_hz(pole: np.ndarray | complex) -> np.ndarray:
    """Natural frequency |lambda| / 2 pi in Hz of poles ``pole`` (rad/s).

    Examples
    --------
    >>> float(pole_fn_hz(-3.0 + 4.0j) * 2 * np.pi)
    5.0
    """
    return np.abs(pole) / (2 * np.pi)


def pole_fd_hz(pole: np.ndarray | complex) -> np.ndarray:
    """Damped natural frequency Im(lambda) / 2 pi in Hz of poles ``pole`` (rad/s).

    Examples
    --------
    >>> float(pole_fd_hz(-3.0 + 2j * np.pi * 50.0))
    50.0
    """
    return np.asarray(np.imag(pole)) / (2 * np.pi)


def pole_half_width_hz(pole: np.ndarray | complex) -> np.ndarray:
    """Half-power half-width |Re(lambda)| / 2 pi = zeta f_n in Hz of poles
    ``pole`` (rad/s); the half-power bandwidth is twice it.

    Examples
    --------
    >>> float(pole_half_width_hz(-2 * np.pi * 0.5 + 2j * np.pi * 50.0))
    0.5
    """
    return np.abs(np.real(pole)) / (2 * np.pi)


def poles_overlap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(a.size, b.size) bool: pole ``a[i]`` and pole ``b[j]`` (rad/s) lie within
    the sum of their half-power half-widths of each other (one resonance:
    |Im a - Im b| < |Re a| + |Re b|).

    Examples
    --------
    >>> a = np.array([-1 + 100j, -1 + 150j])
    >>> poles_overlap(a, np.array([-1 + 101.5j, -1 + 103j])).tolist()
    [[True, False], [False, False]]
    """
    a, b = np.asarray(a), np.asarray(b)
    gap = np.abs(a[:, None].imag - b[None, :].imag)
    return np.asarray(gap < np.abs(a[:, None].real) + np.abs(b[None, :].real))


def mpd(phi: np.ndarray) -> np.ndarray:
    """Mean phase deviation per mode in degrees (0 = real/normal mode; 45 or more
    for scattered phases), NaN for an all-zero shape.

    The standard definition (Reynders, Houbrechts and De Roeck 2012, "Fully
    automated (operational) modal analysis", MSSP 29): the magnitude-weighted
    mean angle between each component phi_o and the straight line through the
    origin that best fits the shape in the complex plane (its principal axis,
    from the SVD of [Re phi, Im phi]),

        MPD = sum_o |phi_o| arccos(|Re(phi_o e^-j theta)| / |phi_o|) / sum_o |phi_o|,

    theta = 1/2 atan2(2 S_xy, S_xx - S_yy), the principal axis with the sums of
    :func:`ema_pipeline.identification.refinement.lsfd.mpc` (the same rotation as
    :func:`ema_pipeline.identification.refinement.lsfd.real_normalised`).

    Parameters
    ----------
    phi : (n_dof, n_modes) complex shapes.

    Examples
    --------
    >>> phi = np.array([[1.0 + 1.0j, 1.0, 1.0], [2.0 + 2.0j, 1.0j, 1.0 + 0.1j]])
    >>> mpd(phi).round(3)  # real mode (rotated), two components 90 deg apart, one 5.7 deg off
    array([ 0.   , 45.   ,  2.855])
    """
    phi = np.asarray(phi, dtype=complex)
    x, y = phi.real, phi.imag
    theta = 0.5 * np.arctan2(2 * np.sum(x * y, axis=0), np.sum(x * x - y * y, axis=0))
    mag = np.abs(phi)
    along = np.abs(np.real(phi * np.exp(-1j * theta)[None, :]))
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = np.clip(np.where(mag > 0, along / mag, 1.0), 0.0, 1.0)
        total = np.sum(mag, axis=0)
        return np.where(total > 0, np.sum(mag * np.degrees(np.arccos(cos)), axis=0) / total,
                        np.nan)
