"""Writing Universal Files (with pyuff): FRFs and coherences (dataset 58 or
58b), identified modes (datasets 164, 15, 82 and 55) and time records, with
our key=value ID lines (:func:`id_number`), as :mod:`.uff` describes them.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline.data import DOF, DataError, FRFSet, TimeRecords
from ema_pipeline.io.files import atomic_path
from ema_pipeline.io.uff_read import UFF_FUNC_COHERENCE, UFF_FUNC_FRF, UFF_FUNC_TIME
from ema_pipeline.io.uff_units import QUANTITY_TYPE

_UFF_QUANTITY_TYPE = QUANTITY_TYPE
_UFF_FORCE = 13


#: Characters of an ID line (UFF dataset 58, records 1-5: format 80A1).
ID_LINE_CHARS = 80


def id_number(x: float | int | None) -> str:
    """A number as our ID lines write it: ``none`` for None, an integer in full, a
    float in its shortest exact form when that has at most 12 characters, else to
    10 significant digits (a relative error of at most 5e-10), so that every field fits.

    Examples
    --------
    >>> id_number(2048.0), id_number(0.5405591056902891), id_number(None), id_number(16384)
    ('2048.0', '0.5405591057', 'none', '16384')
    """
    if x is None:
        return "none"
    if isinstance(x, int | np.integer):
        return str(int(x))
    text = repr(float(x))
    return text if len(text) <= 12 else f"{float(x):.10g}"


def _id_lines(fields: Sequence[tuple[str, str]], configuration: str, id3: str,
              where: str = "") -> tuple[str, str, str]:
    """ID lines 3, 4 and 5 holding ``fields`` (key, text) and the configuration as
    ``key=value`` pairs after ``ema-pipeline``, each line within
    :data:`ID_LINE_CHARS`: the fields fill ID line 4 in order and go on in line 5;
    the configuration goes where it fits (5, 4, else line 3 in place of ``id3``, the
    source). A configuration too long for a line of its own is a DataError naming
    ``where`` (the file); so is a field that fits nowhere.

    Examples
    --------
    >>> _id_lines([("fs", "2048.0"), ("ns", "4096")], "genuine", "src.h5")
    ('src.h5', 'ema-pipeline fs=2048.0 ns=4096', 'ema-pipeline cfg=genuine')
    """
    prefix = f"{where}: " if where else ""
    lines = ["ema-pipeline", "ema-pipeline"]  # ID lines 4 and 5

    def place(token: str, order: tuple[int, ...]) -> bool:
        for k in order:
            if len(lines[k]) + len(token) <= ID_LINE_CHARS:
                lines[k] += token
                return True
        return False

    for key, text in fields:
        if not place(f" {key}={text}", (0, 1)):
            raise DataError(f"{prefix}UFF ID lines cannot hold {key}={text} (80 characters "
                            "each)")
    cfg = f" cfg={configuration.replace(' ', '_') or 'none'}"
    if not place(cfg, (1, 0)):
        room = ID_LINE_CHARS - len("ema-pipeline cfg=")
        if len("ema-pipeline") + len(cfg) > ID_LINE_CHARS:
            raise DataError(f"{prefix}configuration name of {len(configuration)} characters "
                            f"is too long for a UFF ID line (at most {room}); shorten it or "
                            "write HDF5 (.h5)")
        id3 = f"ema-pipeline{cfg}"
    return id3, lines[0], lines[1]


def _frf_id_lines(frf: FRFSet, n_records: int, where: str) -> tuple[str, str, str]:
    """ID lines 3-5 of an FRF file: the source, the acquisition metadata, the number
    of records in the file (so that a file cut exactly at a record boundary is still
    seen as truncated) and the configuration (:func:`_id_lines`)."""
    info = frf.acquisition
    fields = [
        ("fs", id_number(info.sample_rate_hz)), ("ns", id_number(info.n_samples)),
        ("navg", id_number(info.n_averages)), ("tau", id_number(info.exp_window_tau_s)),
        ("est", info.estimator), ("fwin", info.force_window.replace(" ", "_")),
        ("nrec", str(n_records)),
    ]
    return _id_lines(fields, frf.configuration, f"{frf.source.path}"[-ID_LINE_CHARS:], where)


def _uff_record(
    *,
    binary: bool,
    func_type: int,
    rsp: DOF,
    ref: DOF,
    x: np.ndarray,
    data: np.ndarray,
    ordinate_type: int,
    denominator_type: int,
    ordinate_units: str,
    denominator_units: str,
    abscissa_type: int,
    abscissa_units: str,
    ids: tuple[str, str, str, str, str],
    load_case: int = 0,
) -> dict[str, Any]:
    import pyuff

    return pyuff.prepare_58(
        binary=int(binary),
        id1=ids[0][:80] or "NONE",
        id2=ids[1][:80] or "NONE",
        id3=ids[2][:80] or "NONE",
        id4=ids[3][:80] or "NONE",
        id5=ids[4][:80] or "NONE",
        func_type=func_type,
        load_case_id=load_case,
        rsp_node=rsp.node,
        rsp_dir=rsp.direction,
        ref_node=ref.node,
        ref_dir=ref.direction,
        ord_data_type=6 if np.iscomplexobj(data) else 4,
        abscissa_spacing=1,
        abscissa_spec_data_type=abscissa_type,
        abscissa_axis_units_lab=abscissa_units,
        ordinate_spec_data_type=ordinate_type,
        ordinate_axis_units_lab=ordinate_units,
        orddenom_spec_data_type=denominator_type,
        orddenom_axis_units_lab=denominator_units,
        data=data,
        x=x,
    )


def _write_uff(records: list[dict[str, Any]], path: str | os.PathLike[str]) -> Path:
    import pyuff

    with atomic_path(path) as tmp:
        tmp.unlink()  # pyuff appends to an existing file
        pyuff.UFF(str(tmp)).write_sets(records, mode="add")
    return Path(path)


def write_frf_uff(
    frf: FRFSet, path: str | os.PathLike[str], *, binary: bool = False, coherence: bool = False
) -> Path:
    """Write an FRFSet as UFF dataset 58 records (ASCII or binary), atomically.

    One function-type-4 record per response/reference pair and, with
    ``coherence=True`` (and coherence in the set), a function-type-6 coherence
    record after each. ID line 4 carries the exact sample rate, record length,
    averages and window time constant; ID line 5 the configuration name.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> tmp = tempfile.TemporaryDirectory()
    >>> frf = FRFSet(freq_hz=np.arange(40.0), H=np.ones(40, complex), response_dofs=(DOF(3),),
    ...              reference_dofs=(DOF(8),))
    >>> write_frf_uff(frf, pathlib.Path(tmp.name) / "g.ufb", binary=True).name
    'g.ufb'
    >>> tmp.cleanup()
    """
    return _write_uff(_frf_records(frf, binary=binary, coherence=coherence,
                                   where=str(path)), path)


def _frf_records(frf: FRFSet, *, binary: bool, coherence: bool,
                 where: str = "") -> list[dict[str, Any]]:
    """pyuff dataset-58 dicts of an FRFSet (see :func:`write_frf_uff`)."""
    numerator = {"accelerance": "m/s^2", "mobility": "m/s", "receptance": "m"}[frf.quantity]
    per_pair = 2 if coherence and frf.coherence is not None else 1
    id3, id4, id5 = _frf_id_lines(frf, per_pair * frf.n_out * frf.n_in, where)
    info = frf.acquisition
    id2 = f"{info.estimator}, {info.n_averages or '?'} linear averages"
    records = []
    for o, rsp in enumerate(frf.response_dofs):
        for i, ref in enumerate(frf.reference_dofs):
            ids = (
                f"{frf.configuration or 'FRF'} {rsp.label()}/{ref.label()}",
                id2,
                id3,
                id4,
                id5,
            )
            records.append(
                _uff_record(
                    binary=binary,
                    func_type=UFF_FUNC_FRF,
                    rsp=rsp,
                    ref=ref,
                    x=frf.freq_hz,
                    data=frf.H[o, i],
                    ordinate_type=_UFF_QUANTITY_TYPE[frf.quantity],
                    denominator_type=_UFF_FORCE,
                    ordinate_units=numerator,
                    denominator_units="N",
                    abscissa_type=18,
                    abscissa_units="Hz",
                    ids=ids,
                )
            )
            if coherence and frf.coherence is not None:
                records.append(
                    _uff_record(
                        binary=binary,
                        func_type=UFF_FUNC_COHERENCE,
                        rsp=rsp,
                        ref=ref,
                        x=frf.freq_hz,
                        data=frf.coherence[o, i].astype(float),
                        ordinate_type=0,
                        denominator_type=0,
                        ordinate_units="NONE",
                        denominator_units="NONE",
                        abscissa_type=18,
                        abscissa_units="Hz",
                        ids=ids,
                    )
                )
    return records


def write_modes_uff(
    path: str | os.PathLike[str],
    fn_hz: np.ndarray,
    zeta: np.ndarray,
    shapes: np.ndarray,
    dofs: Sequence[DOF],
    *,
    node_coordinates: Mapping[int, Sequence[float]] | None = None,
    trace_lines: Sequence[Sequence[int]] | None = None,
    frf_fit: FRFSet | None = None,
    description: str = "",
) -> Path:
    """Write identified modes as a Universal File, atomically.

    Datasets, in this order: 164 (units: SI, metre and newton); 15 (node
    coordinates, m) and 82 (trace lines) when ``node_coordinates`` is given;
    one 55 per mode (analysis type 2 "normal mode": natural frequency in Hz,
    viscous damping ratio, modal mass 0 = not known, and the complex shape at
    every node, data type 5, X/Y/Z translations; rotations too when a DOF has
    direction 4-6); and with ``frf_fit`` the synthesised FRFs as dataset 58
    records, which :func:`read_frf_uff` reads back.

    Parameters
    ----------
    path : target file.
    fn_hz : (n_modes,) undamped natural frequencies, Hz.
    zeta : (n_modes,) damping ratios (not percent).
    shapes : (n_dof, n_modes) complex mode shapes at ``dofs``.
    dofs : n_dof DOFs; a negative direction stores the negated value in the
        positive direction.
    node_coordinates : {node: (x, y, z)} in metres (optional).
    trace_lines : node sequences drawn as lines (dataset 82); default: one line
        through the nodes of ``node_coordinates`` in their order.
    frf_fit : synthesised FRFs to add as dataset 58 (optional).
    description : text for ID line 1 of every mode.

    Returns
    -------
    Path of the file.

    Notes
    -----
    Dataset 55 stores numbers as E13.5 (6 significant digits); ID line 4 of
    each mode also holds ``fn=`` and ``zeta=`` at full precision.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "modes.uff"
    >>> shapes = np.array([[1.0 + 0j, 0.5], [0.4, -1.0]])
    >>> write_modes_uff(p, [10.0, 40.0], [0.01, 0.02], shapes, [DOF(1, 3), DOF(2, 3)]).name
    'modes.uff'
    """
    import pyuff

    fn = np.atleast_1d(np.asarray(fn_hz, dtype=float))
    z = np.atleast_1d(np.asarray(zeta, dtype=float))
    phi = np.asarray(shapes, dtype=complex)
    dofs = tuple(dofs)
    if phi.ndim == 1:
        phi = phi[:, None]
    if fn.shape != z.shape or fn.ndim != 1:
        raise DataError(f"{path}: fn_hz {fn.shape} and zeta {z.shape} must be equal 1-D arrays")
    if phi.shape != (len(dofs), fn.size):
        raise DataError(
            f"{path}: shapes have shape {phi.shape}, expected (n_dof, n_modes) = "
            f"({len(dofs)}, {fn.size})"
        )
    if not (np.all(np.isfinite(fn)) and np.all(np.isfinite(z)) and np.all(np.isfinite(phi))):
        raise DataError(f"{path}: modal parameters contain NaN/inf values")
    bad = [d.label() for d in dofs if not 1 <= abs(d.direction) <= 6]
    if bad:
        raise DataError(f"{path}: DOFs {bad} have no direction 1-6 (X, Y, Z, RX, RY, RZ)")
    nodes = list(dict.fromkeys(d.node for d in dofs))
    n_per_node = 6 if any(abs(d.direction) > 3 for d in dofs) else 3
    values = np.zeros((len(nodes), n_per_node, fn.size), dtype=complex)
    seen: set[tuple[int, int]] = set()
    for k, d in enumerate(dofs):
        key = (d.node, abs(d.direction))
        if key in seen:
            raise DataError(f"{path}: DOF {d.label()} appears twice (+ and - are one DOF)")
        seen.add(key)
        values[nodes.index(d.node), abs(d.direction) - 1] = phi[k] * np.sign(d.direction)
    records: list[dict[str, Any]] = [
        pyuff.prepare_164(
            units_code=1, units_description="SI: Meter (newton)", temp_mode=2,
            length=1.0, force=1.0, temp=1.0, temp_offset=273.15,
        )
    ]
    if node_coordinates:
        coord_nodes = list(node_coordinates)
        xyz = np.array([list(node_coordinates[n]) for n in coord_nodes], dtype=float)
        if xyz.ndim != 2 or xyz.shape[1] != 3 or not np.all(np.isfinite(xyz)):
            raise DataError(f"{path}: node coordinates must be finite (x, y, z) triples in m")
        ones = [0] * len(coord_nodes)
        records.append(
            pyuff.prepare_15(
                node_nums=coord_nodes, def_cs=ones, disp_cs=ones, color=[1] * len(coord_nodes),
                x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2],
            )
        )
        lines = [coord_nodes] if trace_lines is None else [list(t) for t in trace_lines]
        for k, line in enumerate(lines, start=1):
            if len(line) >= 2:
                records.append(
                    pyuff.prepare_82(trace_num=k, n_nodes=len(line), color=1,
                                     id=f"trace {k}", nodes=np.asarray(line, dtype=int))
                )
    for m in range(fn.size):
        r = {f"r{c + 1}": values[:, c, m] for c in range(n_per_node)}
        records.append(
            pyuff.prepare_55(
                id1=(description or "ema-pipeline identified modes")[:80],
                id2=f"mode {m + 1}: fn = {fn[m]:.6g} Hz, zeta = {z[m]:.6g}",
                id3="complex mode shape, SI units",
                id4=f"ema-pipeline fn={float(fn[m])!r} zeta={float(z[m])!r}"[:80],
                id5="NONE",
                model_type=1, analysis_type=2, data_ch=2 if n_per_node == 3 else 3,
                spec_data_type=8, data_type=5, n_data_per_node=n_per_node,
                load_case=1, mode_n=m + 1, freq=float(fn[m]), modal_m=0.0,
                modal_damp_vis=float(z[m]), modal_damp_his=0.0,
                node_nums=np.asarray(nodes, dtype=int), **r,
            )
        )
    if frf_fit is not None:
        records.extend(_frf_records(frf_fit, binary=False, coherence=False,
                                    where=str(path)))
    return _write_uff(records, path)


def write_time_uff(
    records: TimeRecords, path: str | os.PathLike[str], *, binary: bool = False
) -> Path:
    """Write raw impact records as UFF dataset 58 time responses (function type 1).

    Impact k (1-based) is load case k; each has one force record (data type 13,
    N) and one acceleration record per response (data type 12, m/s^2).
    """
    t = np.arange(records.n_samples) / records.sample_rate_hz
    fields = [("fs", id_number(records.sample_rate_hz)), ("ns", id_number(records.n_samples)),
              ("trig", id_number(records.trigger_s)),
              ("nrec", str(records.n_averages * (1 + records.response.shape[1])))]
    id3, id4, id5 = _id_lines(fields, records.configuration, "NONE", str(path))
    out = []
    ref = records.reference_dof
    for k in range(records.n_averages):
        ids = (f"impact {k + 1}", "time record", id3, id4, id5)
        out.append(
            _uff_record(
                binary=binary,
                func_type=UFF_FUNC_TIME,
                rsp=ref,
                ref=ref,
                x=t,
                data=records.force[k],
                ordinate_type=_UFF_FORCE,
                denominator_type=0,
                ordinate_units="N",
                denominator_units="NONE",
                abscissa_type=17,
                abscissa_units="s",
                ids=ids,
                load_case=k + 1,
            )
        )
        for o, rsp in enumerate(records.response_dofs):
            out.append(
                _uff_record(
                    binary=binary,
                    func_type=UFF_FUNC_TIME,
                    rsp=rsp,
                    ref=ref,
                    x=t,
                    data=records.response[k, o],
                    ordinate_type=12,
                    denominator_type=0,
                    ordinate_units="m/s^2",
                    denominator_units="NONE",
                    abscissa_type=17,
                    abscissa_units="s",
                    ids=ids,
                    load_case=k + 1,
                )
            )
    return _write_uff(out, path)
