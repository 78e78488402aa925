"""Modes from a Universal File: the datasets 55 (analysis type 2, normal modes:
frequency, viscous damping ratio and the shape at every node) that
``ema-pipeline identify --uff`` writes (:func:`ema_pipeline.io.write_modes_uff`),
read with pyuff. A DOF is (node, axis) for every axis (X, Y, Z) with a nonzero
value in some mode."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ema_pipeline.data import DOF, DataError, ModalParameters
from ema_pipeline.io.files import check_readable

__all__ = ["read_modes_uff"]


def read_modes_uff(path: str | os.PathLike[str]) -> ModalParameters:
    """The modes of the datasets 55 of ``path`` (module docstring); a file with
    none, or modes over different nodes, is a DataError naming it.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from ema_pipeline.io import write_modes_uff
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "modes.uff"
    >>> _ = write_modes_uff(p, np.array([10.0, 20.0]), np.array([0.01, 0.02]),
    ...                     np.array([[1.0, 0.5], [0.5, -1.0], [0.2, 1.0]]),
    ...                     [DOF(1, 3), DOF(2, 3), DOF(3, 3)])
    >>> m = read_modes_uff(p)
    >>> m.fn_hz.tolist(), m.zeta.tolist(), [d.label() for d in m.dofs], m.shapes[:, 1].real
    ([10.0, 20.0], [0.01, 0.02], ['1+Z', '2+Z', '3+Z'], array([ 0.5, -1. ,  1. ]))
    """
    import pyuff

    path = Path(path)
    check_readable(path, "a Universal File of modes (dataset 55)")
    try:
        sets = [s for s in pyuff.UFF(str(path)).read_sets() if int(s.get("type", 0)) == 55]
    except Exception as exc:  # noqa: BLE001 - pyuff's errors are of many kinds
        raise DataError(f"{path}: not a readable Universal File ({exc})") from None
    sets = [s for s in sets if int(s.get("analysis_type", 0)) == 2]
    if not sets:
        raise DataError(f"{path}: no mode (dataset 55, analysis type 2 'normal mode'); "
                        "ema-pipeline identify --uff writes them")
    nodes = np.asarray(sets[0]["node_nums"], dtype=int)
    values = []
    for s in sets:
        if not np.array_equal(np.asarray(s["node_nums"], dtype=int), nodes):
            raise DataError(f"{path}: the modes are given over different nodes")
        values.append(np.stack([np.asarray(s.get(f"r{c}", np.zeros(nodes.size)),
                                           dtype=complex) for c in (1, 2, 3)], axis=1))
    phi = np.stack(values, axis=-1)  # (n_nodes, 3, n_modes)
    used = np.any(np.abs(phi) > 0, axis=2)
    dofs = tuple(DOF(int(nodes[i]), int(c) + 1) for i, c in zip(*np.nonzero(used), strict=True))
    shapes = phi[used]  # (n_dof, n_modes), node by node
    return ModalParameters(fn_hz=np.array([float(s["freq"]) for s in sets]),
                           zeta=np.array([float(s["modal_damp_vis"]) for s in sets]),
                           shapes=shapes, dofs=dofs)
