"""SEREP reduction, eq. (21)-(25), onto the translational DOFs of the measurement
nodes, with a check that the retained eigenvalues are preserved."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse

from ema_pipeline.data import Beam, DataError
from ema_pipeline.fe.beam import FEModes, beam_modes


# ---------------------------------------------------------------------------
# SEREP, eq. (21)-(25)
# ---------------------------------------------------------------------------
def fe_elements_of_measurement_element(beam: Beam, element: int) -> np.ndarray:
    """0-based FE element indices inside measurement element ``element`` (1-based).

    Examples
    --------
    >>> fe_elements_of_measurement_element(Beam(), 2)  # 100 FE elements, 10 measured
    array([10, 11, 12, 13, 14, 15, 16, 17, 18, 19])
    """
    n_meas = beam.n_measurement_elements
    if not 1 <= element <= n_meas:
        raise DataError(f"measurement element {element} does not exist (1..{n_meas})")
    r = beam.n_elements // n_meas
    return np.arange((element - 1) * r, element * r)


def measurement_master_dofs(beam: Beam) -> tuple[np.ndarray, tuple[int, ...]]:
    """Translational FE DOFs at the free measurement nodes (default SEREP masters).

    Measurement node k (1-based, node 1 clamped) sits at FE node
    (k - 1) * n_elements / n_measurement_elements. Returns the DOF indices and
    the measurement node numbers 2..n_measurement_elements + 1.

    Examples
    --------
    >>> dofs, nodes = measurement_master_dofs(Beam())
    >>> dofs[:3], nodes[:3], len(nodes)
    (array([18, 38, 58]), (2, 3, 4), 10)
    """
    r = beam.n_elements // beam.n_measurement_elements
    nodes = tuple(range(2, beam.n_measurement_elements + 2))
    fe_nodes = (np.asarray(nodes) - 1) * r
    return 2 * (fe_nodes - 1), nodes


@dataclass(frozen=True)
class SerepModel:
    """SEREP-reduced model, eq. (23)-(25).

    Attributes
    ----------
    T : (n_dof, n_master) transformation x = T x_m, eq. (24).
    K_R, M_R : (n_master, n_master) reduced stiffness (N/m) and mass (kg), eq. (25).
    masters : (n_master,) indices of the master DOFs in the full DOF vector.
    master_nodes : measurement node numbers of the masters (empty if not known).
    shapes : (n_master, n_modes) Psi_m, mass-normalised w.r.t. M_R.
    omega2 : (n_modes,) retained FE eigenvalues, (rad/s)^2.
    eigenvalue_rel_error : max |lambda(K_R, M_R) - omega2| / omega2 over the
        retained modes: SEREP must preserve them (about 1e-12 in practice).
    """

    T: np.ndarray
    K_R: np.ndarray
    M_R: np.ndarray
    masters: np.ndarray
    shapes: np.ndarray
    omega2: np.ndarray
    eigenvalue_rel_error: float
    master_nodes: tuple[int, ...] = ()

    def master_position(self, node: int) -> int:
        """Position of measurement node ``node`` in the reduced DOF vector."""
        if node not in self.master_nodes:
            raise DataError(
                f"measurement node {node} is not a master DOF of the reduced model "
                f"(masters: nodes {list(self.master_nodes)}; node 1 is clamped)"
            )
        return self.master_nodes.index(node)


def serep(
    K: np.ndarray,
    M: np.ndarray,
    shapes: np.ndarray,
    omega2: np.ndarray,
    masters: Sequence[int] | np.ndarray,
    *,
    master_nodes: tuple[int, ...] = (),
    check_rtol: float = 1e-6,
) -> SerepModel:
    """System equivalent reduction-expansion process (SEREP), eq. (21)-(25).

    T = Psi (Psi_m^T Psi_m)^-1 Psi_m^T (eq. 24), K_R = T^T K T, M_R = T^T M T
    (eq. 25), with Psi the retained full-model modes and Psi_m their rows at the
    master DOFs. Use at most as many modes as masters (the paper: as many).
    The eigenvalues of (K_R, M_R) are checked against ``omega2``; a relative
    deviation above ``check_rtol`` raises DataError (ill-chosen masters).

    Parameters
    ----------
    K, M : (n, n) full stiffness (N/m) and mass (kg).
    shapes : (n, n_modes) mass-normalised full mode shapes Psi.
    omega2 : (n_modes,) their eigenvalues (rad/s)^2.
    masters : master DOF indices into the full DOF vector.
    """
    masters = np.asarray(masters, dtype=int)
    shapes = np.asarray(shapes, dtype=float)
    omega2 = np.asarray(omega2, dtype=float)
    n, n_modes = shapes.shape
    if masters.ndim != 1 or np.unique(masters).size != masters.size:
        raise DataError("SEREP masters must be distinct DOF indices")
    if masters.size and (masters.min() < 0 or masters.max() >= n):
        raise DataError(f"SEREP master DOFs must lie in 0..{n - 1}")
    if n_modes > masters.size:
        raise DataError(
            f"SEREP with {n_modes} modes needs at least as many masters, got {masters.size}"
        )
    psi_m = shapes[masters]
    gram = psi_m.T @ psi_m
    if np.linalg.cond(gram) > 1e12:
        raise DataError("SEREP: the master DOFs cannot distinguish the retained modes")
    t = shapes @ np.linalg.solve(gram, psi_m.T)  # eq. (24)
    k_r = t.T @ K @ t  # eq. (25)
    m_r = t.T @ M @ t
    k_r = 0.5 * (k_r + k_r.T)
    m_r = 0.5 * (m_r + m_r.T)
    # check: the reduced model keeps the retained eigenvalues. With as many
    # modes as masters the pencil is regular; otherwise it has extra zero
    # eigenvalues (M_R singular) and the check uses the retained subspace.
    if n_modes == masters.size:
        lam = scipy.linalg.eigh(k_r, m_r, eigvals_only=True)
    else:
        lam = np.sort(np.diag(psi_m.T @ k_r @ psi_m) / np.diag(psi_m.T @ m_r @ psi_m))
    rel = float(np.max(np.abs(lam - np.sort(omega2)) / np.abs(omega2)))
    if rel > check_rtol:
        raise DataError(f"SEREP reduction lost the retained eigenvalues (rel. error {rel:.2g})")
    return SerepModel(
        T=t,
        K_R=k_r,
        M_R=m_r,
        masters=masters,
        shapes=psi_m,
        omega2=omega2,
        eigenvalue_rel_error=rel,
        master_nodes=tuple(master_nodes),
    )


def reduce_beam(beam: Beam, n_modes: int | None = None) -> tuple[FEModes, SerepModel]:
    """FE modes of ``beam`` and its SEREP reduction to the measurement mesh.

    Masters are the translational DOFs of the free measurement nodes
    (:func:`measurement_master_dofs`, 10 for the paper); ``n_modes`` defaults to
    the number of masters, as in the paper.
    """
    masters, nodes = measurement_master_dofs(beam)
    n_modes = masters.size if n_modes is None else n_modes
    modes = beam_modes(beam, n_modes)
    red = serep(
        modes.model.K, modes.model.M, modes.shapes, modes.omega2, masters, master_nodes=nodes
    )
    return modes, red
