"""Reading Universal Files: datasets 58 and 58b (FRFs, coherences, time
records) into :class:`~ema_pipeline.data.FRFSet` and
:class:`~ema_pipeline.data.TimeRecords`, by the reading rules of :mod:`.uff`
(the DOFs and their signs, the units, the axis, the record count of our own
files).
"""

from __future__ import annotations

import logging
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline.data import DOF, AcquisitionInfo, DataError, FRFSet, Provenance, TimeRecords
from ema_pipeline.io.files import check_readable, sha256_file
from ema_pipeline.io.uff_format import Record58, UffContents, read_uff_file
from ema_pipeline.io.uff_units import (
    FORCE_TYPES,
    TYPE_QUANTITY,
    Unit,
    is_blank_label,
    parse_unit_label,
    type_unit,
)

log = logging.getLogger("ema_pipeline.io.uff")

#: File name suffixes read as Universal Files (compared in lower case).
UFF_SUFFIXES = {".uff", ".unv", ".ufb", ".58", ".bunv", ".buf", ".uf"}

#: Function types of dataset 58 (record 6, field 1): time response, FRF, coherence.
UFF_FUNC_TIME, UFF_FUNC_FRF, UFF_FUNC_COHERENCE = 1, 4, 6
_FUNCTION_NAMES = {
    0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum",
    4: "FRF", 5: "transmissibility", 6: "coherence", 7: "auto correlation",
    8: "cross correlation", 9: "PSD", 10: "ESD", 12: "spectrum",
    18: "mode indicator function",
}
_FORCE_DIMS = Unit(1.0, (0, 0, -1), "1/N")  # dividing by it multiplies by N
_ENTITY_DOF = re.compile(r"^\W*(\d+)\W*?([+-]?)([XYZ])([+-]?)\W*$", re.IGNORECASE)


def read_uff(path: str | os.PathLike[str], *, checked: bool = False) -> UffContents:
    """All dataset-58 records of a Universal File, as stored, with the unit system
    in force for each, the dataset-151 header and the datasets skipped.

    Raises DataError (naming the file, record and reason) for any unreadable
    file; nothing else escapes. Anything but a non-empty regular file is
    refused before it is opened (:func:`~ema_pipeline.io.files.check_readable`),
    unless ``checked``: the caller has checked it already.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "nodes.unv"
    >>> node = "         1         0         0         0 0.0 0.0 0.0"
    >>> _ = p.write_text(f"    -1\\n    15\\n{node}\\n    -1\\n    -1\\n    18\\n    -1\\n")
    >>> read_uff(p).skipped  # 15 (nodes) is kept for the geometry reader
    {18: 1}
    """
    path = Path(path)
    if not checked:
        check_readable(path, "a Universal File (dataset 58)")
    try:
        return read_uff_file(path)
    except DataError:
        raise
    except (ValueError, IndexError, TypeError, OverflowError, KeyError) as exc:
        raise DataError(f"{path}: not a readable Universal File ({exc})") from exc


def _read_58(path: Path, checked: bool = False) -> tuple[UffContents, list[Record58]]:
    contents = read_uff(path, checked=checked)
    if not contents.dataset_numbers:
        raise DataError(f"{path}: no UFF datasets found (not a Universal File, or empty)")
    if not contents.records:
        found = ", ".join(str(n) for n in sorted(set(contents.dataset_numbers)))
        raise DataError(f"{path}: no dataset 58 (function at nodal DOF) in file; found {found}")
    return contents, contents.records


def _metadata_from_id(rec: Record58) -> dict[str, str]:
    """key=value pairs our writer puts in ID lines 4 and 5 (and 3 when they need it;
    :func:`_id_lines`), empty for foreign files."""
    meta: dict[str, str] = {}
    for k, text in enumerate(rec.ids[2:5], start=3):
        if text.startswith("ema-pipeline " if k == 3 else "ema-pipeline"):
            meta.update(re.findall(r"(\w+)=(\S+)", text))
    # "none" means not known, as an absent key; unreadable numbers are dropped
    meta = {k: v for k, v in meta.items() if v != "none"}
    for key in ("fs", "ns", "navg", "tau", "trig", "nrec"):
        if key in meta:
            try:
                value = (float if key in ("fs", "tau", "trig") else int)(meta[key])
            except ValueError:
                value = None
            if value is None or not (math.isfinite(value) and (value >= 0 if key == "trig"
                                                                else value > 0)):
                log.warning("record %d: ID-line value %s=%r ignored", rec.record, key, meta[key])
                del meta[key]
    return meta


def _dof(node: int, direction: int, name: str) -> tuple[DOF, int]:
    """(DOF with a non-negative direction, sign of the stored direction)."""
    if node == 0 and direction == 0:
        m = _ENTITY_DOF.match(name)
        if m:
            sign = -1 if "-" in (m.group(2) + m.group(4)) else 1
            return DOF(int(m.group(1)), "XYZ".index(m.group(3).upper()) + 1), sign
    return DOF(node, abs(direction)), (-1 if direction < 0 else 1)


def response_dof(rec: Record58) -> tuple[DOF, int]:
    """Response DOF of a record, with a non-negative direction (taken from the
    entity name, e.g. ``1+Z``, when node and direction are 0), and the sign of the
    stored direction (-1 for -X, -Y, -Z: the values are flipped to +X, +Y, +Z)."""
    return _dof(rec.rsp_node, rec.rsp_dir, rec.rsp_name)


def _record_dofs(rec: Record58) -> tuple[DOF, DOF, int]:
    rsp, s1 = _dof(rec.rsp_node, rec.rsp_dir, rec.rsp_name)
    ref, s2 = _dof(rec.ref_node, rec.ref_dir, rec.ref_name)
    return rsp, ref, s1 * s2


def _negative_directions(records: Sequence[Record58]) -> tuple[str, str]:
    """``response_negative``, ``reference_negative`` of the AcquisitionInfo: the
    labels (``3-Z``) of the DOFs the records store with a negative direction."""
    out = []
    for role in ("rsp", "ref"):
        labels: dict[str, None] = {}
        for rec in records:
            dof, sign = _dof(getattr(rec, f"{role}_node"), getattr(rec, f"{role}_dir"),
                             getattr(rec, f"{role}_name"))
            if sign < 0:
                labels[DOF(dof.node, -dof.direction).label()] = None
        out.append(" ".join(labels))
    return out[0], out[1]


def _label_unit(path: Path, rec: Record58, label: str, what: str) -> Unit:
    try:
        return parse_unit_label(label)
    except ValueError as exc:
        raise DataError(
            f"{path}: record {rec.record} has unknown units {label!r} ({what}, {rec.at}: "
            f"{exc}); known: m, mm, in, ft, g, s, N, kN, lbf and combinations such as "
            "m/s^2/N, g/N, (m/s)/N, in/s^2/lbf"
        ) from None


def ordinate_unit(path: Path, rec: Record58) -> Unit:
    """Unit of the ordinate (numerator / denominator) of a record, SI factor
    included, by the rules of the module docstring."""
    num_ax, den_ax = rec.numerator, rec.denominator
    from_type = None
    if num_ax.data_type in TYPE_QUANTITY or num_ax.data_type in FORCE_TYPES:
        from_type = type_unit(num_ax.data_type, num_ax.length_exp, num_ax.force_exp,
                              rec.units, rec.rsp_dir)
    num = (from_type if is_blank_label(num_ax.units)
           else _label_unit(path, rec, num_ax.units, "ordinate, record 9"))
    if num is None:
        num = type_unit(num_ax.data_type, num_ax.length_exp, num_ax.force_exp, rec.units,
                        rec.rsp_dir)
    if num is None:
        raise DataError(
            f"{path}: record {rec.record}: cannot tell the quantity ({rec.at}: ordinate data "
            f"type {num_ax.data_type}, units {num_ax.units!r}); expected acceleration, "
            "velocity or displacement (per force)"
        )
    if num.quantity is not None:
        # a combined label (g/N, (m/s)/N) already holds the denominator
        unit = num
        if not is_blank_label(den_ax.units):
            log.info("%s: record %d: combined units label %r; denominator label %r ignored",
                     path, rec.record, num_ax.units, den_ax.units)
    else:
        den: Unit | None
        if not is_blank_label(den_ax.units):
            den = _label_unit(path, rec, den_ax.units, "ordinate denominator, record 10")
        else:
            den = type_unit(den_ax.data_type, den_ax.length_exp, den_ax.force_exp, rec.units,
                            rec.ref_dir)
        if den is None:
            den = type_unit(0, 0, 0, rec.units)  # dimensionless
        unit = num / den  # type: ignore[operator]
        if unit.quantity is None and den_ax.data_type == 0 and is_blank_label(den_ax.units):
            per_force = num / type_unit(13, 0, 1, rec.units)  # type: ignore[operator]
            if rec.func_type == UFF_FUNC_FRF and per_force.quantity is not None:
                log.info("%s: record %d: no denominator unit; force in %s assumed",
                         path, rec.record, rec.units.description)
                unit = per_force
    if from_type is not None and not is_blank_label(num_ax.units):
        label_dims = num.dims if num.quantity is None else (num / _FORCE_DIMS).dims
        if from_type.dims != label_dims:
            log.warning(
                "%s: record %d: units label %r disagrees with ordinate data type %d; "
                "the label is used", path, rec.record, num_ax.units, num_ax.data_type)
        elif not rec.units.is_si:
            factor = num.factor if num.quantity is None else (num / _FORCE_DIMS).factor
            if not np.isclose(from_type.factor, factor, rtol=1e-6):
                log.warning(
                    "%s: record %d: units label %r disagrees with dataset 164 (%s); "
                    "the label is used", path, rec.record, num_ax.units,
                    rec.units.description)
    return unit


def _frf_quantity_and_factor(path: Path, rec: Record58) -> tuple[str, float]:
    unit = ordinate_unit(path, rec)
    if unit.quantity is None:
        raise DataError(
            f"{path}: record {rec.record}: units {rec.numerator.units!r} / "
            f"{rec.denominator.units!r} ({rec.at}) are not acceleration, velocity or "
            "displacement per force"
        )
    return unit.quantity, unit.factor


def _function_summary(records: Sequence[Record58]) -> str:
    types = sorted({r.func_type for r in records})
    return ", ".join(f"{t} ({_FUNCTION_NAMES.get(t, 'other')})" for t in types)


def read_frf_uff(path: str | os.PathLike[str], *, min_lines: int = 2,
                 checked: bool = False) -> FRFSet:
    """Read FRFs (dataset 58 / 58b, function type 4) from a Universal File.

    Parameters
    ----------
    path : file name (.uff, .unv, .ufb, any case).
    min_lines : refuse FRFs with fewer frequency lines (pass
        :data:`ema_pipeline.data.MIN_FRF_LINES` before identification).
    checked : the caller has checked that ``path`` is a non-empty regular file
        (:func:`~ema_pipeline.io.files.check_readable`, as
        :func:`ema_pipeline.io.read_frf` does); else it is checked here.

    Returns
    -------
    FRFSet
        SI units, +direction DOFs (see the module docstring for the rules).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from ema_pipeline.io.uff_write import write_frf_uff
    >>> tmp = tempfile.TemporaryDirectory()
    >>> f = np.linspace(0.0, 100.0, 41)
    >>> frf = FRFSet(freq_hz=f, H=np.ones((2, 1, 41)) / (1 + 1j * f), response_dofs=(DOF(3),
    ...              DOF(6)), reference_dofs=(DOF(8),))
    >>> back = read_frf_uff(write_frf_uff(frf, pathlib.Path(tmp.name) / "g.uff"))
    >>> back.H.shape, [d.label() for d in back.response_dofs]
    ((2, 1, 41), ['3+Z', '6+Z'])
    >>> bool(np.allclose(back.H, frf.H, rtol=1e-10))  # 12 significant digits in ASCII
    True
    >>> tmp.cleanup()
    """
    path = Path(path)
    contents, sets = _read_58(path, checked)
    frf_recs = [r for r in sets if r.func_type == UFF_FUNC_FRF]
    if not frf_recs:
        hint = ""
        if any(r.func_type == UFF_FUNC_TIME for r in sets):
            hint = ("; this is a file of time records: read it with read_time_uff and "
                    "estimate FRFs (ema_pipeline.acquisition.estimate_frf) first")
        raise DataError(
            f"{path}: dataset 58 records hold no FRFs (function type 4); function types "
            f"found: {_function_summary(sets)}{hint}"
        )
    coh_recs = [r for r in sets if r.func_type == UFF_FUNC_COHERENCE]
    meta = _metadata_from_id(frf_recs[0])
    _check_record_count(path, meta, len(sets))
    freq = _uff_axis(path, frf_recs, meta)
    if freq.size < min_lines:
        rec = frf_recs[0]
        raise DataError(
            f"{path}: record {rec.record} ({rec.at}) has {freq.size} frequency lines; "
            f"at least {min_lines} are needed for identification (measure a longer record "
            "or a finer frequency resolution)"
        )

    responses: list[DOF] = []
    references: list[DOF] = []
    keyed = []
    for rec in frf_recs:
        rsp, ref, sign = _record_dofs(rec)
        keyed.append((rec, rsp, ref, sign))
        if rsp not in responses:
            responses.append(rsp)
        if ref not in references:
            references.append(ref)
    H = np.full((len(responses), len(references), freq.size), np.nan + 0j)
    filled = np.zeros(H.shape[:2], dtype=int)
    quantities = set()
    for rec, rsp, ref, sign in keyed:
        o, i = responses.index(rsp), references.index(ref)
        if filled[o, i]:
            other = frf_recs[filled[o, i] - 1].record
            raise DataError(
                f"{path}: records {other} and {rec.record} are both FRFs of response "
                f"{rsp.label()} / reference {ref.label()} (+ and - directions of a node are "
                "one DOF)"
            )
        quantity, factor = _frf_quantity_and_factor(path, rec)
        quantities.add(quantity)
        data = np.asarray(rec.data)
        if not np.all(np.isfinite(data)):
            raise DataError(
                f"{path}: record {rec.record} contains NaN/inf values ({rec.at}; response "
                f"{rsp.label()}, reference {ref.label()})"
            )
        H[o, i] = data * (sign * factor)
        filled[o, i] = frf_recs.index(rec) + 1
    if len(quantities) > 1:
        raise DataError(f"{path}: records mix FRF quantities {sorted(quantities)}")
    if not filled.all():
        o, i = np.argwhere(filled == 0)[0]
        raise DataError(
            f"{path}: incomplete FRF matrix: no record for response "
            f"{responses[o].label()} / reference {references[i].label()}"
        )
    coherence = None
    if coh_recs:
        coherence = np.zeros(H.shape)
        have = np.zeros(H.shape[:2], dtype=bool)
        for rec in coh_recs:
            rsp, ref, _ = _record_dofs(rec)
            if rsp in responses and ref in references and rec.data.size == freq.size:
                o, i = responses.index(rsp), references.index(ref)
                coherence[o, i] = np.real(rec.data)
                have[o, i] = True
        coherence = coherence if have.all() and np.all(np.isfinite(coherence)) else None
    info = AcquisitionInfo()
    if meta:
        info = AcquisitionInfo(
            sample_rate_hz=float(meta["fs"]) if "fs" in meta else None,
            n_samples=int(meta["ns"]) if "ns" in meta else None,
            n_averages=int(meta["navg"]) if "navg" in meta else None,
            exp_window_tau_s=float(meta["tau"]) if meta.get("tau", "none") != "none" else None,
            force_window=meta.get("fwin", "none").replace("_", " "),
            response_window="exponential" if meta.get("tau", "none") != "none" else "none",
            estimator=meta.get("est", "H1"),
        )
    response_negative, reference_negative = _negative_directions(frf_recs)
    info = replace(info, response_negative=response_negative,
                   reference_negative=reference_negative)
    return FRFSet(
        freq_hz=freq,
        H=H,
        coherence=coherence,
        response_dofs=tuple(responses),
        reference_dofs=tuple(references),
        quantity=quantities.pop(),  # type: ignore[arg-type]
        acquisition=info,
        configuration="" if meta.get("cfg", "none") == "none" else meta["cfg"],
        source=Provenance(path=str(path), sha256=sha256_file(path)),
    )


def _uff_axis(path: Path, records: list[Record58], meta: Mapping[str, str]) -> np.ndarray:
    x0 = records[0].x
    for rec in records[1:]:
        x = rec.x
        if x.shape != x0.shape or not np.allclose(x, x0, rtol=1e-6, atol=1e-9):
            raise DataError(
                f"{path}: records have different frequency axes (record {records[0].record}: "
                f"{x0.size} lines {x0[0]:.6g}-{x0[-1]:.6g} Hz; record {rec.record}: {x.size} "
                f"lines {x[0]:.6g}-{x[-1]:.6g} Hz)"
            )
    if x0.size > 1 and not np.all(np.diff(x0) > 0):
        raise DataError(
            f"{path}: record {records[0].record} ({records[0].at}): the abscissa values are "
            "not strictly increasing"
        )
    if "fs" in meta and "ns" in meta and x0.size > 1:
        # the lines k0 .. k0 + size - 1 of rfftfreq(ns, 1 / fs) = k fs / ns, computed
        # for those lines only (an absurd ns in a damaged ID line allocates nothing)
        fs, ns = float(meta["fs"]), int(meta["ns"])
        df = fs / ns
        with np.errstate(all="ignore"):
            k0f = x0[0] / df if df > 0 else np.nan
        if np.isfinite(k0f) and 0 <= k0f and round(k0f) + x0.size <= ns // 2 + 1:
            exact = (round(k0f) + np.arange(x0.size)) * fs / ns
            if np.allclose(exact, x0, rtol=1e-4, atol=1e-3):
                return exact
    return x0


def _check_record_count(path: Path, meta: Mapping[str, str], n_found: int) -> None:
    """Compare with the record count our writer stores (absent in foreign files)."""
    if "nrec" in meta and int(meta["nrec"]) != n_found:
        raise DataError(
            f"{path}: truncated Universal File: {n_found} of {meta['nrec']} dataset-58 records"
        )


def check_record_count(path: str | os.PathLike[str], records: Sequence[Record58]) -> None:
    """DataError naming ``path`` (``truncated``, with the numbers) when a file of ours
    holds another number of ``records`` than the count ID line 4 or 5 of the first
    one states (a file cut exactly at a record boundary); foreign files state none.
    ``records``: those the count is of (time records: the time records)."""
    if records:
        _check_record_count(Path(path), _metadata_from_id(records[0]), len(records))


def read_time_uff(path: str | os.PathLike[str]) -> TimeRecords:
    """Read raw impact records (dataset 58 / 58b, function type 1) from a UFF file.

    Force records are those whose ordinate is a force (data type 13 or 9, or a
    force unit label); the others are responses, which must be accelerations.
    Records are grouped into impacts by load case number (or, when all are 0,
    by order: one force record followed by its responses). Units are converted
    to SI and a negative direction flips the sign, as for FRFs.

    Examples
    --------
    Two impacts of 64 samples at 1 kHz, one response:

    >>> import tempfile, pathlib
    >>> from ema_pipeline.io.uff_write import write_time_uff
    >>> tmp = tempfile.TemporaryDirectory()
    >>> t = np.arange(64) / 1000.0
    >>> rec = TimeRecords(force=np.ones((2, 64)), response=np.sin(t)[None, None, :].repeat(2, 0),
    ...                   sample_rate_hz=1000.0, response_dofs=(DOF(3),), reference_dof=DOF(8))
    >>> back = read_time_uff(write_time_uff(rec, pathlib.Path(tmp.name) / "t.uff"))
    >>> back.response.shape, back.sample_rate_hz
    ((2, 1, 64), 1000.0)
    >>> tmp.cleanup()
    """
    path = Path(path)
    _, all_sets = _read_58(path)
    sets = [s for s in all_sets if s.func_type == UFF_FUNC_TIME]
    if not sets:
        raise DataError(
            f"{path}: no time-response records (dataset 58, function type 1); function "
            f"types found: {_function_summary(all_sets)}"
        )
    meta = _metadata_from_id(sets[0])
    _check_record_count(path, meta, len(sets))
    impacts: dict[int, dict[str, Any]] = {}
    current = 0
    for rec in sets:
        unit = ordinate_unit(path, rec)
        is_force = unit.signal == "force"
        case = rec.load_case
        if case == 0 or not any(r.load_case for r in sets):
            current += int(is_force)
            case = current
        impact = impacts.setdefault(case, {"force": None, "responses": {}})
        dof, sign = _dof(rec.rsp_node, rec.rsp_dir, rec.rsp_name)
        data = np.real(rec.data).astype(float) * (sign * unit.factor)
        if not np.all(np.isfinite(data)):
            raise DataError(f"{path}: record {rec.record} contains NaN/inf values ({rec.at})")
        if is_force:
            if impact["force"] is not None:
                raise DataError(f"{path}: impact {case} has two force records")
            impact["force"] = data
            impact["ref"] = dof
        else:
            if unit.signal != "acceleration":
                raise DataError(
                    f"{path}: record {rec.record} ({rec.at}): time responses must be "
                    f"accelerations (with one force record per impact); units "
                    f"{rec.numerator.units!r}, data type {rec.numerator.data_type}"
                )
            impact["responses"][dof] = data
    dofs = None
    force, response = [], []
    for case in sorted(impacts):
        impact = impacts[case]
        if impact["force"] is None:
            raise DataError(
                f"{path}: impact {case} has no force record (ordinate data type 13 or a "
                "force unit); ema-pipeline needs the hammer force with the responses"
            )
        these = tuple(impact["responses"])
        if dofs is None:
            dofs = these
        if these != dofs:
            raise DataError(f"{path}: impact {case} has responses {these}, expected {dofs}")
        force.append(impact["force"])
        response.append([impact["responses"][d] for d in dofs])
    lengths = {f.size for f in force} | {r.size for rs in response for r in rs}
    if len(lengths) != 1:
        raise DataError(f"{path}: time records have different lengths {sorted(lengths)}")
    x = sets[0].x
    fs = float(meta["fs"]) if "fs" in meta else 1.0 / float(x[1] - x[0])
    return TimeRecords(
        force=np.array(force),
        response=np.array(response),
        sample_rate_hz=fs,
        trigger_s=float(meta.get("trig", 0.0)),
        response_dofs=dofs or (),
        reference_dof=impacts[min(impacts)]["ref"],
        configuration=meta.get("cfg", "") if meta.get("cfg") != "none" else "",
        source=Provenance(path=str(path), sha256=sha256_file(path)),
    )
