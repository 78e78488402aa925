"""The test geometry (nodes, trace lines, surfaces) and where the DOFs lie on it."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ema_pipeline.data.errors import DataError
from ema_pipeline.data.frf import DOF


@dataclass(frozen=True)
class DofMap:
    """Where measurement DOFs lie on a :class:`Geometry`: per DOF the index of its
    node (-1: no such node), the axis (0, 1, 2 for X, Y, Z; -1: not a
    translation) and the sign of its direction; ``missing`` the DOFs that could
    not be placed (no node, or a rotation / scalar direction)."""

    node_index: np.ndarray
    axis: np.ndarray
    sign: np.ndarray
    missing: tuple[DOF, ...] = ()


@dataclass(frozen=True)
class Geometry:
    """The test object's wireframe: nodes, trace lines and optional surfaces.

    Attributes
    ----------
    node_ids : (n,) int
        Node numbers (as in the DOF labels of the FRFs).
    xyz_m : (n, 3) float
        Node coordinates in metres (global Cartesian system).
    lines : tuple of node-id tuples
        Trace lines: polylines through the given nodes (a pair is one segment).
    surfaces : tuple of node-id tuples
        Optional triangles or quads drawn filled.
    source : str
        Where the geometry came from (file path or a description).

    Examples
    --------
    >>> g = Geometry(node_ids=[1, 2, 3], xyz_m=[[0, 0, 0], [0.5, 0, 0], [1, 0, 0]],
    ...              lines=((1, 2, 3),))
    >>> m = g.map_dofs([DOF(2, 3), DOF(3, -1), DOF(9, 3)])
    >>> m.node_index.tolist(), m.axis.tolist(), m.sign.tolist(), [d.label() for d in m.missing]
    ([1, 2, -1], [2, 0, -1], [1, -1, 1], ['9+Z'])
    """

    node_ids: np.ndarray
    xyz_m: np.ndarray
    lines: tuple[tuple[int, ...], ...] = ()
    surfaces: tuple[tuple[int, ...], ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        where = f"{self.source}: " if self.source else ""
        ids = np.asarray(self.node_ids)
        xyz = np.asarray(self.xyz_m, dtype=float)
        if ids.ndim != 1 or ids.size == 0 or not np.issubdtype(ids.dtype, np.integer):
            raise DataError(f"{where}geometry node ids must be a non-empty list of integers")
        if xyz.shape != (ids.size, 3) or not np.all(np.isfinite(xyz)):
            raise DataError(f"{where}geometry needs finite (x, y, z) in m for each of its "
                            f"{ids.size} nodes, got an array of shape {xyz.shape}")
        if np.unique(ids).size != ids.size:
            dup = sorted({int(n) for n in ids if np.count_nonzero(ids == n) > 1})
            raise DataError(f"{where}geometry node(s) {dup} defined twice")
        object.__setattr__(self, "node_ids", ids.astype(int))
        object.__setattr__(self, "xyz_m", xyz)
        lines = tuple(tuple(int(n) for n in line) for line in self.lines)
        surfaces = tuple(tuple(int(n) for n in s) for s in self.surfaces)
        known = set(ids.tolist())
        for kind, items in (("trace line", lines), ("surface", surfaces)):
            for k, item in enumerate(items, start=1):
                unknown = sorted(set(item) - known)
                if unknown:
                    raise DataError(f"{where}{kind} {k} uses node(s) {unknown} that the "
                                    "geometry does not define")
                if kind == "trace line" and len(item) < 2:
                    raise DataError(f"{where}trace line {k} needs at least 2 nodes")
                if kind == "surface" and len(item) not in (3, 4):
                    raise DataError(f"{where}surface {k} needs 3 or 4 nodes, got {len(item)}")
        object.__setattr__(self, "lines", lines)
        object.__setattr__(self, "surfaces", surfaces)

    @property
    def n_nodes(self) -> int:
        return int(self.node_ids.size)

    def __repr__(self) -> str:
        return (f"Geometry({self.n_nodes} nodes, {len(self.lines)} trace lines, "
                f"{len(self.surfaces)} surfaces, source {self.source or 'memory'})")

    def map_dofs(self, dofs: Iterable[DOF]) -> DofMap:
        """Place measurement DOFs on the nodes by node number and direction
        (1..3 = X, Y, Z; a negative direction has sign -1). A DOF whose node is
        not in the geometry, or whose direction is not a translation, is listed
        in ``missing`` (index and axis -1), never dropped silently."""
        dofs = tuple(dofs)
        where = {int(n): k for k, n in enumerate(self.node_ids)}
        index = np.array([where.get(d.node, -1) for d in dofs], dtype=int)
        axis = np.array([abs(d.direction) - 1 if 1 <= abs(d.direction) <= 3 else -1
                         for d in dofs], dtype=int)
        bad = (index < 0) | (axis < 0)
        index[bad], axis[bad] = -1, -1
        sign = np.array([-1 if d.direction < 0 else 1 for d in dofs], dtype=int)
        missing = tuple(d for d, b in zip(dofs, bad, strict=True) if b)
        return DofMap(node_index=index, axis=axis, sign=sign, missing=missing)
