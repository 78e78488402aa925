"""Local added mass, eq. (14)-(20): proportional modification factors of the
immersed element(s).

* :func:`local_added_mass_factors` - delta_k, delta_m by least squares (eq. 16-20).
* :func:`local_added_mass` - the same on the SEREP-reduced updated FE model
  (:mod:`ema_pipeline.fe`), two ways: ``"block"`` (the paper's: the "element
  matrices" are the 2 x 2 blocks of K_R, M_R at the element's two measurement
  nodes) and ``"projected"`` (the fine FE elements of the immersed part
  projected with SEREP, T^T K_e T).

Sign convention (DESIGN.md): Delta_lambda_r = omega_wr^2 - omega_r^2 (modified
minus genuine, undamped by eq. 4) and, with mass-normalised Psi_r, the
first-order relation Psi_r^T K_a Psi_r - omega_r^2 Psi_r^T M_a Psi_r =
Delta_lambda_r (eq. 14 with consistent signs), so added mass gives delta_m > 0.
omega_r and Psi_r are the updated FE model's (eq. 16 needs the genuine
structure's modal model; the FE model supplies the shapes at all masters).

Why written here: these are the paper's formulas (a few lines of numpy each);
the least squares is numpy's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ema_pipeline import fe
from ema_pipeline.added_mass.modal import AddedMassResult, modal_added_mass
from ema_pipeline.data import Beam, DataError, ModalParameters

__all__ = [
    "METHODS",
    "LocalAddedMassResult",
    "Method",
    "local_added_mass",
    "local_added_mass_factors",
]

Method = Literal["block", "projected"]
#: The local added mass methods (:func:`local_added_mass`).
METHODS: tuple[str, ...] = ("block", "projected")


def local_added_mass_factors(
    shapes: np.ndarray,
    omega2: np.ndarray,
    element_stiffness: np.ndarray,
    element_mass: np.ndarray,
    delta_lambda: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Proportional modification factors by least squares, eq. (16)-(20).

    A_rj = Psi_r^T K_j Psi_r, B_rj = -omega_r^2 Psi_r^T M_j Psi_r (eq. 16),
    [A, B] [dk; dm] = Delta_lambda (eq. 19), solved in the least-squares sense
    (eq. 20, via a QR/SVD solver instead of the normal equations).

    Parameters
    ----------
    shapes : (n_dof, p) mass-normalised mode shapes Psi_r of the genuine model.
    omega2 : (p,) its eigenvalues omega_r^2, (rad/s)^2.
    element_stiffness, element_mass : (n, n_dof, n_dof) K_j^e, M_j^e of the n
        modified elements (zero outside the element's DOFs).
    delta_lambda : (p,) omega_wr^2 - omega_r^2 in (rad/s)^2 (modified minus genuine).

    Returns
    -------
    delta_k, delta_m : (n,) factors (ratios). residual : (p,) [A,B] x - Delta_lambda.
    A, B : (p, n).

    Examples
    --------
    A 2-DOF toy (M = I, K = diag(1, 4)) whose one "element" holds the stiffness of
    DOF 1 and the mass of DOF 2; both grow by 10 %:

    >>> psi, omega2 = np.eye(2), np.array([1.0, 4.0])
    >>> k_e = np.array([[[1.0, 0.0], [0.0, 0.0]]])
    >>> m_e = np.array([[[0.0, 0.0], [0.0, 1.0]]])
    >>> dk, dm, residual, A, B = local_added_mass_factors(psi, omega2, k_e, m_e,
    ...                                                   np.array([0.1, -0.4]))
    >>> dk.round(6), dm.round(6)
    (array([0.1]), array([0.1]))
    """
    psi = np.asarray(shapes, dtype=float)
    w2 = np.asarray(omega2, dtype=float)
    kj = np.asarray(element_stiffness, dtype=float)
    mj = np.asarray(element_mass, dtype=float)
    dl = np.asarray(delta_lambda, dtype=float)
    p = w2.size
    n = kj.shape[0]
    if psi.shape[1] != p or dl.shape != (p,) or kj.shape != mj.shape or kj.shape[1:] != (
        psi.shape[0], psi.shape[0]
    ):
        raise DataError(
            f"inconsistent shapes: Psi {psi.shape}, omega2 {w2.shape}, K_e {kj.shape}, "
            f"M_e {mj.shape}, Delta_lambda {dl.shape}"
        )
    if 2 * n > p:
        raise DataError(
            f"{n} modified element(s) need at least {2 * n} modes (two unknowns per element, "
            f"eq. 19), but only {p} are available: the number of modified elements must not "
            "exceed half the number of measured modes"
        )
    if not (np.all(np.isfinite(dl)) and np.all(np.isfinite(psi))):
        raise DataError("Delta_lambda or mode shapes contain NaN/inf")
    a = np.einsum("ir,jik,kr->rj", psi, kj, psi)  # eq. (16)
    b = -w2[:, None] * np.einsum("ir,jik,kr->rj", psi, mj, psi)
    ab = np.hstack([a, b])
    sol, _, rank, sv = np.linalg.lstsq(ab, dl, rcond=None)  # eq. (20)
    if rank < 2 * n:
        raise DataError(
            "[A, B] of eq. (19) is rank deficient: the modes used cannot separate stiffness "
            "and mass changes of these elements"
        )
    return sol[:n], sol[n:], ab @ sol - dl, a, b


@dataclass(frozen=True)
class LocalAddedMassResult:
    """Local added mass of the modified elements (paper Table 6), eq. (14)-(20).

    ``elements`` are measurement element numbers (1 = at the clamp);
    ``delta_k``, ``delta_m`` the proportional factors (ratios, not percent);
    ``mode`` the genuine mode numbers used, ``delta_lambda`` their
    omega_wr^2 - omega_r^2 in (rad/s)^2, ``omega2`` the FE eigenvalues that went
    into B (eq. 16), ``A``, ``B`` the matrices of eq. (19), ``residual`` of the fit.
    """

    configuration: str
    method: str
    elements: tuple[int, ...]
    delta_k: np.ndarray
    delta_m: np.ndarray
    mode: np.ndarray
    delta_lambda: np.ndarray
    omega2: np.ndarray
    A: np.ndarray
    B: np.ndarray
    residual: np.ndarray


def _element_matrices(
    beam: Beam, red: fe.SerepModel, elements: Sequence[int], method: str
) -> tuple[np.ndarray, np.ndarray]:
    n_m = red.K_R.shape[0]
    kj = np.zeros((len(elements), n_m, n_m))
    mj = np.zeros_like(kj)
    for i, el in enumerate(elements):  # a handful of elements, not the FE hot path
        fe.fe_elements_of_measurement_element(beam, el)  # validates the number
        if method == "block":
            pos = [red.master_position(node) for node in (el, el + 1) if node != 1]
            sel = np.ix_(pos, pos)
            kj[i][sel] = red.K_R[sel]
            mj[i][sel] = red.M_R[sel]
        elif method == "projected":
            sub = fe.assemble_beam(beam, elements=fe.fe_elements_of_measurement_element(beam, el))
            kj[i] = red.T.T @ sub.K @ red.T
            mj[i] = red.T.T @ sub.M @ red.T
        else:
            raise DataError(f"unknown local added mass method {method!r}; use {METHODS}")
    return kj, mj


def local_added_mass(
    beam: Beam,
    genuine: ModalParameters,
    modified: ModalParameters,
    *,
    immersed_elements: Sequence[int] = (10,),
    method: Method = "block",
    reduced: fe.SerepModel | None = None,
    pairing: AddedMassResult | None = None,
) -> LocalAddedMassResult:
    """Local added mass of the immersed element(s), eq. (14)-(20).

    Parameters
    ----------
    beam : the (updated) FE beam of the genuine structure; it is reduced by
        SEREP to the free measurement nodes with as many modes as masters
        (:func:`ema_pipeline.fe.reduce_beam`) unless ``reduced`` is given.
    genuine, modified : measured modal parameters (undamped fn via eq. 4).
        Genuine measured mode r is FE mode r; modified modes are paired with
        :func:`modal_added_mass` (or ``pairing``), unpaired modes are left out.
    immersed_elements : measurement element numbers (1..n, n = tip element).
    method : ``"block"`` (paper): K_j, M_j are the 2 x 2 blocks of K_R, M_R at
        the element's two nodes (node 1 is clamped); ``"projected"``: the fine FE
        elements of the measurement element, projected T^T K_e T.

    omega_r and Psi_r are the updated FE model's (SEREP-reduced, mass-normalised
    w.r.t. M_R); Delta_lambda_r = (2 pi)^2 (f_wr^2 - f_r^2) from the measured
    undamped frequencies.
    """
    elements = tuple(int(e) for e in immersed_elements)
    if not elements or len(set(elements)) != len(elements):
        raise DataError(f"immersed_elements must be distinct element numbers, got {elements}")
    if method not in METHODS:
        raise DataError(f"unknown local added mass method {method!r}; use {METHODS}")
    for el in elements:
        fe.fe_elements_of_measurement_element(beam, el)
    pair = pairing if pairing is not None else modal_added_mass(genuine, modified)
    use = np.flatnonzero(pair.partner >= 0)
    if 2 * len(elements) > use.size:
        raise DataError(
            f"{len(elements)} immersed element(s) need at least {2 * len(elements)} modes "
            f"measured in both configurations, got {use.size}: the number of modified "
            "elements must not exceed half the number of measured modes"
        )
    if reduced is None:
        _, reduced = fe.reduce_beam(beam)
    if use.max() >= reduced.shapes.shape[1]:
        raise DataError(
            f"genuine mode {use.max() + 1} exceeds the {reduced.shapes.shape[1]} modes of the "
            "reduced model"
        )
    dl = (2 * np.pi) ** 2 * (pair.fn_modified_hz[use] ** 2 - pair.fn_genuine_hz[use] ** 2)
    kj, mj = _element_matrices(beam, reduced, elements, method)
    w2 = reduced.omega2[use]
    dk, dm, res, a, b = local_added_mass_factors(reduced.shapes[:, use], w2, kj, mj, dl)
    return LocalAddedMassResult(
        configuration=modified.configuration or pair.configuration,
        method=method,
        elements=elements,
        delta_k=dk,
        delta_m=dm,
        mode=use + 1,
        delta_lambda=dl,
        omega2=w2,
        A=a,
        B=b,
        residual=res,
    )
