"""The FE beam with extra mass (and stiffness) on some measurement elements: the
forward model of the local added mass.

``delta_m[j]`` (a ratio, not percent): every fine FE element inside measurement
element ``j`` (1-based, element 10 = tip) has its consistent mass matrix scaled
by ``1 + delta_m[j]``, i.e. the element carries an extra mass ``delta_m[j]``
times its own structural mass, distributed like the structural mass. Point
masses (accelerometers) are not scaled. ``delta_k[j]`` likewise scales the
elements' stiffness matrices:

    M(p) = M + sum_j delta_m_j M_j,   K(p) = K + sum_j delta_k_j K_j

with M_j, K_j the assembled fine elements of measurement element j (the
paper's eq. 15 with the unreduced element matrices).

Used by the simulator (a beam with its tip in water,
:mod:`ema_pipeline.pipeline.simulate`) and by the inverse problem, the exact
fit of :mod:`ema_pipeline.added_mass.exact`, which needs the element blocks
(:class:`ElementModification`) for its sensitivities.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ema_pipeline import fe
from ema_pipeline.data import Beam, ConfigError, DataError

__all__ = [
    "AddedMassModes",
    "ElementModification",
    "beam_modes_with_added_mass",
    "modified_beam_matrices",
    "parse_element_fractions",
]


def _check_fractions(values: Mapping[int, float] | None, what: str, beam: Beam) -> dict[int, float]:
    out: dict[int, float] = {}
    for el, frac in (values or {}).items():
        el_i = int(el)
        fe.fe_elements_of_measurement_element(beam, el_i)  # validates the number
        f = float(frac)
        if not (np.isfinite(f) and f > -1.0):
            raise DataError(
                f"{what} of measurement element {el_i} must be a finite fraction > -1 "
                f"(1 + fraction scales the element's matrices), got {frac!r}"
            )
        out[el_i] = f
    return out


@dataclass(frozen=True)
class ElementModification:
    """K, M of the beam and the fine elements of some measurement elements.

    ``K_el``, ``M_el`` (n_el, n_d, n_d) are the assembled fine elements of each
    measurement element restricted to ``dofs`` (the DOFs they touch), so that
    updates and sensitivities work on small blocks (the exact fit builds one
    per fit and calls :meth:`matrices` once per iteration).

    Examples
    --------
    >>> from ema_pipeline.data import Beam
    >>> mod = ElementModification.build(Beam(), (10,))
    >>> k, m = mod.matrices(np.array([0.5]), np.array([0.0]))
    >>> k2, m2 = modified_beam_matrices(Beam(), {10: 0.5})
    >>> bool(np.allclose(k, k2) and np.allclose(m, m2))
    True
    """

    K: np.ndarray
    M: np.ndarray
    elements: tuple[int, ...]
    dofs: np.ndarray
    K_el: np.ndarray
    M_el: np.ndarray

    @classmethod
    def build(cls, beam: Beam, elements: Sequence[int]) -> ElementModification:
        """Assemble ``beam`` and the fine elements of each measurement element of
        ``elements`` (1-based, tip = n)."""
        model = fe.assemble_beam(beam)
        subs = [
            fe.assemble_beam(beam, elements=fe.fe_elements_of_measurement_element(beam, el))
            for el in elements  # a handful of elements, assembled once per fit
        ]
        n = model.n_dof
        k_el = np.array([s.K for s in subs]).reshape(len(subs), n, n)
        m_el = np.array([s.M for s in subs]).reshape(len(subs), n, n)
        dofs = np.flatnonzero(np.any(k_el != 0, axis=(0, 2)) | np.any(m_el != 0, axis=(0, 2)))
        sel = np.ix_(np.arange(len(subs)), dofs, dofs)
        return cls(model.K, model.M, tuple(elements), dofs, k_el[sel], m_el[sel])

    def matrices(self, dm: np.ndarray, dk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """K(p), M(p) with mass fractions ``dm`` and stiffness fractions ``dk``
        (n_el,), one per element of :attr:`elements`."""
        k, m = self.K.copy(), self.M.copy()
        block = np.ix_(self.dofs, self.dofs)
        k[block] += np.tensordot(dk, self.K_el, axes=1)
        m[block] += np.tensordot(dm, self.M_el, axes=1)
        return k, m

    def element_quadratic(self, shapes: np.ndarray, which: str) -> np.ndarray:
        """phi_r^T M_j phi_r (``which="M"``) or phi_r^T K_j phi_r: (n_modes, n_el)."""
        phi = shapes[self.dofs]
        mats = self.M_el if which == "M" else self.K_el
        return np.einsum("ir,jik,kr->rj", phi, mats, phi)


def modified_beam_matrices(
    beam: Beam,
    added: Mapping[int, float],
    stiffness: Mapping[int, float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass matrices of ``beam`` with measurement elements modified.

    Parameters
    ----------
    beam : the FE beam (mesh, point masses).
    added : {measurement element (1-based): delta_m}; the fine FE elements
        inside the measurement element get their mass matrices scaled by
        ``1 + delta_m`` (eq. 15 with the unreduced element matrices).
    stiffness : {measurement element: delta_k}, likewise for the stiffness.

    Returns
    -------
    K (N/m), M (kg) : dense (2 n_elements, 2 n_elements), DOFs as
    :class:`ema_pipeline.fe.FEModel` (clamped node removed).

    Examples
    --------
    >>> from ema_pipeline.data import Beam
    >>> beam = Beam()
    >>> k, m = modified_beam_matrices(beam, {10: 0.5})
    >>> k0, m0 = modified_beam_matrices(beam, {})
    >>> bool(np.allclose(k, k0))
    True
    >>> # the translational inertia (sum over w DOFs) grows by half a tenth of the beam mass
    >>> ones = np.zeros(k.shape[0]); ones[0::2] = 1.0
    >>> mass = beam.density_kg_m3 * beam.area_m2 * beam.length_m
    >>> round(float(ones @ (m - m0) @ ones / mass), 6)
    0.05
    """
    dm = _check_fractions(added, "added mass", beam)
    dk = _check_fractions(stiffness, "stiffness change", beam)
    els = tuple(sorted(set(dm) | set(dk)))
    mod = ElementModification.build(beam, els)
    return mod.matrices(
        np.array([dm.get(e, 0.0) for e in els]), np.array([dk.get(e, 0.0) for e in els])
    )


@dataclass(frozen=True)
class AddedMassModes:
    """FE modes of a beam whose measurement elements carry extra mass (and stiffness).

    ``fn_hz`` (n_modes,) natural frequencies in Hz, ``omega2`` their
    eigenvalues in (rad/s)^2, ``shapes`` (n_nodes, n_modes) translational
    displacements (m per unit modal coordinate) at the measurement ``nodes``
    (1-based, node 1 is the clamp: zero row), mass-normalised w.r.t. the
    modified M (phi^T M phi = 1, so they enter FRF synthesis directly);
    ``full_shapes`` (n_dof, n_modes) the same at all FE DOFs.
    """

    fn_hz: np.ndarray
    omega2: np.ndarray
    shapes: np.ndarray
    nodes: tuple[int, ...]
    full_shapes: np.ndarray


def beam_modes_with_added_mass(
    beam: Beam,
    added: Mapping[int, float],
    n_modes: int = 4,
    nodes: Sequence[int] | None = None,
    *,
    stiffness: Mapping[int, float] | None = None,
) -> AddedMassModes:
    """Natural frequencies and mode shapes of ``beam`` with extra mass on some elements.

    Parameters
    ----------
    beam : FE beam (e.g. the experiment's updated beam).
    added : {measurement element (1-based, n = tip): delta_m}, extra mass as a
        fraction of the element's own mass (see :func:`modified_beam_matrices`).
        ``{}`` gives the genuine beam.
    n_modes : number of lowest modes.
    nodes : measurement node numbers (1..n_measurement_elements + 1) at which
        the shapes are returned; default all of them.
    stiffness : optional {element: delta_k}.

    Returns
    -------
    AddedMassModes

    Examples
    --------
    >>> from ema_pipeline.data import Beam
    >>> dry = beam_modes_with_added_mass(Beam(), {}, 4)
    >>> wet = beam_modes_with_added_mass(Beam(), {10: 0.3}, 4, nodes=(3, 6, 11))
    >>> np.round(dry.fn_hz, 2)
    array([ 19.84, 124.33, 348.12, 682.18])
    >>> bool(np.all(wet.fn_hz < dry.fn_hz)), wet.shapes.shape
    (True, (3, 4))
    """
    n_meas = beam.n_measurement_elements
    node_t = tuple(range(1, n_meas + 2)) if nodes is None else tuple(int(n) for n in nodes)
    bad = [n for n in node_t if not 1 <= n <= n_meas + 1]
    if bad:
        raise DataError(f"measurement node(s) {bad} do not exist (1..{n_meas + 1})")
    k, m = modified_beam_matrices(beam, added, stiffness)
    omega2, full = fe.lowest_modes(k, m, n_modes)
    r = beam.n_elements // n_meas
    fe_nodes = (np.asarray(node_t, dtype=int) - 1) * r
    shapes = np.zeros((len(node_t), n_modes))
    free = fe_nodes > 0
    shapes[free] = full[2 * (fe_nodes[free] - 1)]  # translational DOF of FE node i: 2 (i - 1)
    return AddedMassModes(
        fn_hz=np.sqrt(omega2) / (2 * np.pi),
        omega2=omega2,
        shapes=shapes,
        nodes=node_t,
        full_shapes=full,
    )


def parse_element_fractions(text: str) -> dict[int, float]:
    """Parse ``"ELEMENT=FRACTION[,ELEMENT=FRACTION]"`` (e.g. ``"10=0.3,9=0.2"``).

    For ``simulate --added-mass`` and experiment files. Raises ConfigError on
    malformed text or a repeated element.

    Examples
    --------
    >>> parse_element_fractions("10=0.3, 9=0.2")
    {10: 0.3, 9: 0.2}
    """
    out: dict[int, float] = {}
    for item in (s.strip() for s in text.split(",")):
        if not item:
            continue
        el, sep, frac = item.partition("=")
        try:
            if not sep:
                raise ValueError
            el_i, f = int(el), float(frac)
        except ValueError:
            raise ConfigError(
                f"bad added-mass item {item!r}: expected ELEMENT=FRACTION, e.g. 10=0.3"
            ) from None
        if el_i in out:
            raise ConfigError(f"added mass of element {el_i} given twice in {text!r}")
        out[el_i] = f
    if not out:
        raise ConfigError(f"no ELEMENT=FRACTION item in {text!r}")
    return out
