"""Test geometry files: nodes, trace lines and surfaces of the test object.

Read from a Universal File (datasets 15 or 2411 for the nodes, 82 for the trace
lines; the FRF file itself or a separate geometry file; coordinates converted
to metres with the dataset 164 in force) or from the ``[geometry]`` table of an
experiment file; written as a Universal File (164 SI, 15 or 2411, 82) with
pyuff. Coordinates are taken in the global Cartesian system (the definition
coordinate system numbers of 15/2411 are not applied).

Layouts (I-DEAS / SDRC Universal File specification):

* 15, one line per node: ``node, def. cs, disp. cs, color`` (4I10) and
  ``x, y, z`` (3E13.5).
* 2411, two lines per node: ``node, exp. cs, disp. cs, color`` (4I10), then
  ``x, y, z`` (3D25.16).
* 82: ``trace line number, number of nodes, color`` (3I10), an identification
  line, then the node numbers (8I10 per line); a node number 0 lifts the pen
  (the polyline is split there).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline.data import DataError, Geometry
from ema_pipeline.io.files import atomic_path, check_readable
from ema_pipeline.io.uff_format import read_uff_file

__all__ = [
    "geometry_from_table",
    "read_geometry",
    "read_geometry_uff",
    "write_geometry_uff",
]


def _number(text: str, where: str) -> float:
    try:
        return float(text.strip().replace("D", "E").replace("d", "e"))
    except ValueError:
        raise DataError(f"{where}: not a number: {text.strip()!r}") from None


def _node_line_15(line: str, where: str) -> tuple[int, tuple[float, float, float]]:
    parts = line.split()
    if len(parts) != 7:  # fixed width: 4I10, 3E13.5 (fields may touch)
        parts = [line[k:k + 10] for k in range(0, 40, 10)] + [
            line[40 + 13 * k:53 + 13 * k] for k in range(3)]
    x, y, z = (_number(p, where) for p in parts[4:7])
    return int(_number(parts[0], where)), (x, y, z)


def _nodes(number: int, text: str, where: str) -> list[tuple[int, tuple[float, float, float]]]:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if number == 15:
        return [_node_line_15(ln, where) for ln in lines]
    if len(lines) % 2:
        raise DataError(f"{where}: dataset 2411 needs two lines per node, found {len(lines)}")
    out = []
    for head, xyz in zip(lines[::2], lines[1::2], strict=True):
        values = xyz.split()
        if len(values) != 3:
            values = [xyz[k:k + 25] for k in range(0, 75, 25)]
        x, y, z = (_number(v, where) for v in values)
        out.append((int(_number(head.split()[0], where)), (x, y, z)))
    return out


def _trace_lines(text: str, where: str) -> list[tuple[int, ...]]:
    lines = text.splitlines()
    if len(lines) < 3:
        raise DataError(f"{where}: dataset 82 needs a header, an identification line and nodes")
    head = lines[0].split()
    if len(head) < 2:
        raise DataError(f"{where}: dataset 82 header needs the trace line and node count")
    n_nodes = int(_number(head[1], where))
    nodes = [int(_number(v, where)) for ln in lines[2:] for v in ln.split()]
    if len(nodes) != n_nodes:
        raise DataError(f"{where}: dataset 82 announces {n_nodes} nodes, holds {len(nodes)}")
    out: list[tuple[int, ...]] = []
    current: list[int] = []
    for n in [*nodes, 0]:  # 0 lifts the pen
        if n == 0:
            if len(current) >= 2:
                out.append(tuple(current))
            current = []
        else:
            current.append(n)
    return out


def read_geometry_uff(path: str | os.PathLike[str]) -> Geometry | None:
    """The geometry stored in a Universal File (datasets 15/2411 and 82), or
    ``None`` when the file holds no node dataset.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "g.uff"
    >>> g = Geometry(node_ids=[1, 2], xyz_m=[[0, 0, 0], [0.05, 0, 0]], lines=((1, 2),))
    >>> back = read_geometry_uff(write_geometry_uff(g, p))
    >>> back.node_ids.tolist(), back.xyz_m[1].tolist(), back.lines
    ([1, 2], [0.05, 0.0, 0.0], ((1, 2),))
    """
    path = Path(path)
    check_readable(path, "a geometry file (UFF)")
    contents = read_uff_file(path)
    ids: list[int] = []
    xyz: list[tuple[float, float, float]] = []
    lines: list[tuple[int, ...]] = []
    for number, body, units, where in contents.geometry_blocks:
        text = body.decode("latin-1")
        if number == 82:
            lines.extend(_trace_lines(text, where))
            continue
        for node, coords in _nodes(number, text, where):
            ids.append(node)
            f = units.length_factor
            xyz.append((coords[0] / f, coords[1] / f, coords[2] / f))
    if not ids:
        if lines:
            raise DataError(f"{path}: trace lines (dataset 82) without nodes (15 or 2411)")
        return None
    return Geometry(node_ids=np.array(ids, dtype=int), xyz_m=np.array(xyz, dtype=float),
                    lines=tuple(lines), source=str(path))


def read_geometry(path: str | os.PathLike[str]) -> Geometry:
    """Read a geometry file (a Universal File with dataset 15 or 2411 and 82);
    a file without nodes is a :class:`~ema_pipeline.data.DataError`."""
    geometry = read_geometry_uff(path)
    if geometry is None:
        raise DataError(f"{path}: no geometry in the file (no dataset 15 or 2411 with nodes)")
    return geometry


def write_geometry_uff(
    geometry: Geometry, path: str | os.PathLike[str], *, dataset: int = 15
) -> Path:
    """Write a geometry as a Universal File, atomically: 164 (SI), the nodes as
    dataset 15 (default) or 2411, one 82 per trace line. Surfaces are not written."""
    import pyuff

    if dataset not in (15, 2411):
        raise DataError(f"{path}: nodes are written as dataset 15 or 2411, not {dataset}")
    n = geometry.n_nodes
    zeros = [0] * n
    prepare = pyuff.prepare_15 if dataset == 15 else pyuff.prepare_2411
    x, y, z = geometry.xyz_m.T
    records: list[dict[str, Any]] = [
        pyuff.prepare_164(units_code=1, units_description="SI: Meter (newton)", temp_mode=2,
                          length=1.0, force=1.0, temp=1.0, temp_offset=273.15),
        prepare(node_nums=geometry.node_ids.tolist(), def_cs=zeros, disp_cs=zeros,
                color=[1] * n, x=x, y=y, z=z),
    ]
    for k, line in enumerate(geometry.lines, start=1):
        records.append(pyuff.prepare_82(trace_num=k, n_nodes=len(line), color=1,
                                        id=f"trace line {k}", nodes=np.asarray(line, dtype=int)))
    with atomic_path(path) as tmp:
        tmp.unlink()  # pyuff appends to an existing file
        pyuff.UFF(str(tmp)).write_sets(records, mode="add")
    return Path(path)


def _int_rows(value: Any, key: str, where: str) -> tuple[tuple[int, ...], ...]:
    if not isinstance(value, list) or not all(
        isinstance(row, list) and all(isinstance(v, int) and not isinstance(v, bool)
                                      for v in row) for row in value):
        raise DataError(f"{where}: [geometry] {key} must be a list of lists of node numbers")
    return tuple(tuple(row) for row in value)


def geometry_from_table(
    table: Mapping[str, Any], where: str, base_dir: str | os.PathLike[str] = "."
) -> Geometry:
    """The ``[geometry]`` table of an experiment file: either ``file`` (a UFF
    geometry file, relative to ``base_dir``) or ``nodes`` (``[[node, x_m, y_m,
    z_m], ...]``), with optional ``lines`` (polylines of node numbers) and
    ``surfaces`` (triangles or quads); with ``file``, ``lines`` and ``surfaces``
    are added to the file's.

    Examples
    --------
    >>> g = geometry_from_table({"nodes": [[1, 0, 0, 0], [2, 0.5, 0, 0], [3, 0.5, 0.1, 0]],
    ...                          "lines": [[1, 2]], "surfaces": [[1, 2, 3]]}, "exp.toml")
    >>> g.n_nodes, g.lines, g.surfaces
    (3, ((1, 2),), ((1, 2, 3),))
    """
    known = {"file", "nodes", "lines", "surfaces"}
    unknown = sorted(set(table) - known)
    if unknown:
        raise DataError(f"{where}: unknown key(s) {unknown} in [geometry]; "
                        f"expected {sorted(known)}")
    lines = _int_rows(table.get("lines", []), "lines", where)
    surfaces = _int_rows(table.get("surfaces", []), "surfaces", where)
    if ("file" in table) == ("nodes" in table):
        raise DataError(f"{where}: [geometry] needs either file or nodes")
    if "file" in table:
        if not isinstance(table["file"], str):
            raise DataError(f"{where}: [geometry] file must be a path (text)")
        base = read_geometry(Path(base_dir) / table["file"])
        return Geometry(node_ids=base.node_ids, xyz_m=base.xyz_m, lines=base.lines + lines,
                        surfaces=base.surfaces + surfaces, source=base.source)
    rows = table["nodes"]
    ok = isinstance(rows, list) and rows and all(
        isinstance(r, list) and len(r) == 4 and isinstance(r[0], int)
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in r)
        for r in rows)
    if not ok:
        raise DataError(f"{where}: [geometry] nodes must be a list of [node, x_m, y_m, z_m]")
    return Geometry(node_ids=np.array([r[0] for r in rows], dtype=int),
                    xyz_m=np.array([r[1:] for r in rows], dtype=float),
                    lines=lines, surfaces=surfaces, source=f"{where} [geometry]")
