"""Universal File Format dataset 58, ASCII and binary, through pyuff.

FRF records (function type 4) are grouped into one FRF matrix by response and
reference node/direction; coherence records (type 6) are attached when present;
time records (type 1) hold raw impacts. Units are converted to SI.

pyuff is lenient where we must not be, so this module adds three checks: a
truncated file (pyuff silently drops a cut-off last record; every dataset ends
with a ``-1`` delimiter line), the text ``nan``/``inf`` in an ASCII file
(pyuff reads it as 0), and the abscissa increment, which the UFF header stores
in an E13.5 field (df = 2000/16384 Hz becomes 0.12207): our writer also stores
the exact sample rate and record length in ID line 4 (``ema-pipeline fs=...
ns=...``) and our reader rebuilds the exact axis from it when present.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline.data import DOF, AcquisitionInfo, DataError, FRFSet, Provenance, TimeRecords
from ema_pipeline.io.files import atomic_path, check_readable, sha256_file

UFF_SUFFIXES = {".uff", ".unv", ".58"}

# UFF "specific data type" codes (record 8-10 field 1).
_UFF_TYPE_QUANTITY = {8: "receptance", 11: "mobility", 12: "accelerance"}
_UFF_QUANTITY_TYPE = {v: k for k, v in _UFF_TYPE_QUANTITY.items()}
_UFF_FORCE = 13
_UFF_FUNC_TIME, _UFF_FUNC_FRF, _UFF_FUNC_COHERENCE = 1, 4, 6

# Unit labels understood for each quantity, with the factor to SI.
_G = 9.80665
_NUMERATOR_UNITS = {
    "accelerance": {
        "m/s^2": 1.0,
        "m/s2": 1.0,
        "m/s**2": 1.0,
        "m/s²": 1.0,
        "g": _G,
        "mm/s^2": 1e-3,
        "mm/s2": 1e-3,
    },
    "mobility": {"m/s": 1.0, "mm/s": 1e-3},
    "receptance": {"m": 1.0, "mm": 1e-3, "um": 1e-6},
}
_FORCE_UNITS = {"n": 1.0, "kn": 1e3, "lbf": 4.4482216152605}
_BLANK_UNITS = {"", "none"}


def _check_uff_complete(path: Path, n_sets: int) -> None:
    """Detect a truncated UFF file, which pyuff silently reads up to the last whole set.

    Every dataset ends with a ``-1`` delimiter line, so a complete file ends with
    one; in an ASCII file there are exactly two delimiter lines per dataset.
    """
    with open(path, "rb") as fh:
        fh.seek(max(0, path.stat().st_size - 64))
        tail = fh.read()
    if not tail.rstrip().endswith(b"-1"):
        raise DataError(
            f"{path}: truncated Universal File: the last dataset has no closing -1 delimiter"
        )
    raw = path.read_bytes()
    if b"\x00" not in raw[:4096] and not re.search(rb"(?m)^\s*-1\s*\r?\n\s*58b", raw):
        delims = [m.start() for m in re.finditer(rb"(?m)^\s*-1\s*$", raw)]
        if len(delims) != 2 * n_sets:
            raise DataError(
                f"{path}: truncated or corrupt Universal File: {len(delims)} delimiter lines "
                f"for {n_sets} complete datasets"
            )
        # pyuff reads the text 'nan'/'inf' of an ASCII file as 0: catch it here.
        bad = re.search(rb"(?i)[-+]?\b(nan|inf(inity)?)\b", raw)
        if bad:
            record = sum(1 for d in delims if d < bad.start()) // 2 + 1
            raise DataError(f"{path}: record {record} contains NaN/inf values")


def _read_uff_sets(path: Path) -> list[dict[str, Any]]:
    """All dataset-58 records of a UFF file, with clear errors."""
    import pyuff

    check_readable(path, "a Universal File (dataset 58)")
    try:
        uff = pyuff.UFF(str(path))
        types = list(uff.get_set_types())
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise DataError(f"{path}: not a readable Universal File ({exc})") from exc
    if not types:
        raise DataError(f"{path}: no UFF datasets found (not a Universal File, or empty)")
    _check_uff_complete(path, len(types))
    idx = [k for k, t in enumerate(types) if int(t) == 58]
    if not idx:
        found = ", ".join(sorted({str(int(t)) for t in types}))
        raise DataError(f"{path}: no dataset 58 (function at nodal DOF) in file; found {found}")
    try:
        sets = uff.read_sets(idx)
    except Exception as exc:
        raise DataError(f"{path}: dataset 58 records are truncated or corrupt ({exc})") from exc
    sets = [sets] if isinstance(sets, dict) else list(sets)
    for k, s in enumerate(sets):
        n_expected = int(s.get("num_pts", -1))
        data = np.asarray(s.get("data", ()))
        if n_expected >= 0 and data.size != n_expected:
            raise DataError(
                f"{path}: record {k + 1} is truncated: {data.size} of {n_expected} values"
            )
    return sets


def _metadata_from_id(record: Mapping[str, Any]) -> dict[str, str]:
    """key=value pairs our writer puts in ID lines 4 and 5 (empty for foreign files)."""
    meta: dict[str, str] = {}
    for key in ("id4", "id5"):
        text = str(record.get(key, ""))
        if text.startswith("ema-pipeline"):
            meta.update(re.findall(r"(\w+)=(\S+)", text))
    return meta


def _unit_factor(path: Path, quantity: str, record: Mapping[str, Any], k: int) -> float:
    num = str(record.get("ordinate_axis_units_lab", "")).strip().lower()
    den = str(record.get("orddenom_axis_units_lab", "")).strip().lower()
    table = {u.lower(): f for u, f in _NUMERATOR_UNITS[quantity].items()}
    if num in _BLANK_UNITS:
        f_num = 1.0  # SI assumed where the file names no unit
    elif num in table:
        f_num = table[num]
    else:
        raise DataError(
            f"{path}: record {k + 1} has unknown units {num!r} for {quantity}; "
            f"known: {', '.join(_NUMERATOR_UNITS[quantity])}"
        )
    if den in _BLANK_UNITS:
        f_den = 1.0
    elif den in _FORCE_UNITS:
        f_den = _FORCE_UNITS[den]
    else:
        raise DataError(
            f"{path}: record {k + 1} has unknown force units {den!r}; known: N, kN, lbf"
        )
    return f_num / f_den


def _uff_quantity(path: Path, record: Mapping[str, Any], k: int) -> str:
    code = int(record.get("ordinate_spec_data_type", 0) or 0)
    if code in _UFF_TYPE_QUANTITY:
        return _UFF_TYPE_QUANTITY[code]
    label = str(record.get("ordinate_axis_units_lab", "")).strip().lower()
    for quantity, units in _NUMERATOR_UNITS.items():
        if label in {u.lower() for u in units}:
            return quantity
    raise DataError(
        f"{path}: record {k + 1}: cannot tell the FRF quantity (ordinate data type {code}, "
        f"units {label!r}); expected acceleration, velocity or displacement per force"
    )


def _uff_axis(path: Path, records: list[dict[str, Any]], meta: dict[str, str]) -> np.ndarray:
    x0 = np.asarray(records[0]["x"], dtype=float)
    for k, rec in enumerate(records[1:], start=2):
        x = np.asarray(rec["x"], dtype=float)
        if x.shape != x0.shape or not np.allclose(x, x0, rtol=1e-9, atol=1e-12):
            raise DataError(
                f"{path}: records have different frequency axes (record 1: {x0.size} lines "
                f"{x0[0]:.6g}-{x0[-1]:.6g} Hz; record {k}: {x.size} lines "
                f"{x[0]:.6g}-{x[-1]:.6g} Hz)"
            )
    if "fs" in meta and "ns" in meta:
        exact = np.fft.rfftfreq(int(meta["ns"]), 1.0 / float(meta["fs"]))
        if exact.size == x0.size and np.allclose(exact, x0, rtol=1e-4, atol=1e-3):
            return exact
    return x0


def read_frf_uff(path: str | os.PathLike[str]) -> FRFSet:
    """Read FRFs (dataset 58, function type 4) from a UFF file, ASCII or binary.

    Records are grouped into one FRF matrix by response and reference
    node/direction; coherence records (function type 6) of the same DOFs are
    attached when present. Units are converted to SI.
    """
    path = Path(path)
    sets = _read_uff_sets(path)
    frf_recs = [s for s in sets if int(s.get("func_type", 0)) == _UFF_FUNC_FRF]
    if not frf_recs:
        found = sorted({int(s.get("func_type", 0)) for s in sets})
        raise DataError(
            f"{path}: dataset 58 records hold no FRFs (function type 4); function types "
            f"found: {found}"
        )
    coh_recs = [s for s in sets if int(s.get("func_type", 0)) == _UFF_FUNC_COHERENCE]
    meta = _metadata_from_id(frf_recs[0])
    _check_record_count(path, meta, len(sets))
    freq = _uff_axis(path, frf_recs, meta)

    def dofs(rec: Mapping[str, Any]) -> tuple[DOF, DOF]:
        return DOF(int(rec["rsp_node"]), int(rec["rsp_dir"])), DOF(
            int(rec["ref_node"]), int(rec["ref_dir"])
        )

    responses: list[DOF] = []
    references: list[DOF] = []
    for rec in frf_recs:
        rsp, ref = dofs(rec)
        if rsp not in responses:
            responses.append(rsp)
        if ref not in references:
            references.append(ref)
    H = np.full((len(responses), len(references), freq.size), np.nan + 0j)
    filled = np.zeros(H.shape[:2], dtype=bool)
    quantities = set()
    for k, rec in enumerate(frf_recs):
        rsp, ref = dofs(rec)
        o, i = responses.index(rsp), references.index(ref)
        if filled[o, i]:
            raise DataError(
                f"{path}: two FRF records for response {rsp.label()} / reference {ref.label()}"
            )
        quantity = _uff_quantity(path, rec, k)
        quantities.add(quantity)
        data = np.asarray(rec["data"])
        if not np.all(np.isfinite(data)):
            raise DataError(
                f"{path}: record {k + 1} (response {rsp.label()}, reference {ref.label()}) "
                "contains NaN/inf values"
            )
        H[o, i] = data * _unit_factor(path, quantity, rec, k)
        filled[o, i] = True
    if len(quantities) > 1:
        raise DataError(f"{path}: records mix FRF quantities {sorted(quantities)}")
    if not filled.all():
        o, i = np.argwhere(~filled)[0]
        raise DataError(
            f"{path}: incomplete FRF matrix: no record for response "
            f"{responses[o].label()} / reference {references[i].label()}"
        )
    coherence = None
    if coh_recs:
        coherence = np.zeros(H.shape)
        have = np.zeros(H.shape[:2], dtype=bool)
        for rec in coh_recs:
            rsp, ref = dofs(rec)
            if rsp in responses and ref in references:
                o, i = responses.index(rsp), references.index(ref)
                values = np.real(np.asarray(rec["data"]))
                if values.size == freq.size:
                    coherence[o, i] = values
                    have[o, i] = True
        coherence = coherence if have.all() else None
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


def _check_record_count(path: Path, meta: Mapping[str, str], n_found: int) -> None:
    """Compare with the record count our writer stores (absent in foreign files)."""
    if "nrec" in meta and int(meta["nrec"]) != n_found:
        raise DataError(
            f"{path}: truncated Universal File: {n_found} of {meta['nrec']} dataset-58 records"
        )


def _id_lines(info: AcquisitionInfo, configuration: str, n_records: int) -> tuple[str, str]:
    """ID lines 4 and 5: acquisition metadata, the number of records in the file
    (so that a file cut exactly at a record boundary is still seen as truncated)
    and the configuration, as key=value pairs."""

    def num(x: float | int | None) -> str:
        return "none" if x is None else repr(x)

    id4 = (
        f"ema-pipeline fs={num(info.sample_rate_hz)} ns={num(info.n_samples)} "
        f"navg={num(info.n_averages)} tau={num(info.exp_window_tau_s)} est={info.estimator} "
        f"fwin={info.force_window.replace(' ', '_')}"
    )
    id5 = f"ema-pipeline nrec={n_records} cfg={configuration.replace(' ', '_') or 'none'}"
    if len(id4) > 80 or len(id5) > 80:
        raise DataError(f"UFF ID lines longer than 80 characters: {id4!r} / {id5!r}")
    return id4, id5


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
    """
    numerator = {"accelerance": "m/s^2", "mobility": "m/s", "receptance": "m"}[frf.quantity]
    per_pair = 2 if coherence and frf.coherence is not None else 1
    id4, id5 = _id_lines(frf.acquisition, frf.configuration, per_pair * frf.n_out * frf.n_in)
    info = frf.acquisition
    id2 = f"{info.estimator}, {info.n_averages or '?'} linear averages"
    records = []
    for o, rsp in enumerate(frf.response_dofs):
        for i, ref in enumerate(frf.reference_dofs):
            ids = (
                f"{frf.configuration or 'FRF'} {rsp.label()}/{ref.label()}",
                id2,
                f"{frf.source.path}"[-80:],
                id4,
                id5,
            )
            records.append(
                _uff_record(
                    binary=binary,
                    func_type=_UFF_FUNC_FRF,
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
                        func_type=_UFF_FUNC_COHERENCE,
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
    return _write_uff(records, path)


def write_time_uff(
    records: TimeRecords, path: str | os.PathLike[str], *, binary: bool = False
) -> Path:
    """Write raw impact records as UFF dataset 58 time responses (function type 1).

    Impact k (1-based) is load case k; each has one force record (data type 13,
    N) and one acceleration record per response (data type 12, m/s^2).
    """
    t = np.arange(records.n_samples) / records.sample_rate_hz
    meta = (
        f"ema-pipeline fs={records.sample_rate_hz!r} ns={records.n_samples} "
        f"trig={records.trigger_s!r} nrec={records.n_averages * (1 + records.response.shape[1])} "
        f"cfg={records.configuration or 'none'}"
    )
    out = []
    ref = records.reference_dof
    for k in range(records.n_averages):
        ids = (f"impact {k + 1}", "time record", "NONE", meta, "NONE")
        out.append(
            _uff_record(
                binary=binary,
                func_type=_UFF_FUNC_TIME,
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
                    func_type=_UFF_FUNC_TIME,
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


def read_time_uff(path: str | os.PathLike[str]) -> TimeRecords:
    """Read raw impact records (dataset 58, function type 1) from a UFF file.

    Force records are those with ordinate data type 13; the others are
    responses. Records are grouped into impacts by load case number (or, when
    all are 0, by order: one force record followed by its responses).
    """
    path = Path(path)
    sets = [s for s in _read_uff_sets(path) if int(s.get("func_type", 0)) == _UFF_FUNC_TIME]
    if not sets:
        raise DataError(f"{path}: no time-response records (dataset 58, function type 1)")
    meta = _metadata_from_id(sets[0])
    _check_record_count(path, meta, len(sets))
    impacts: dict[int, dict[str, Any]] = {}
    current = 0
    for k, rec in enumerate(sets):
        is_force = int(rec.get("ordinate_spec_data_type", 0)) == _UFF_FORCE
        case = int(rec.get("load_case_id", 0) or 0)
        if case == 0:
            current += int(is_force)
            case = current
        impact = impacts.setdefault(case, {"force": None, "responses": {}})
        data = np.real(np.asarray(rec["data"], dtype=complex)).astype(float)
        if is_force:
            if impact["force"] is not None:
                raise DataError(f"{path}: impact {case} has two force records")
            impact["force"] = data
            impact["ref"] = DOF(int(rec["rsp_node"]), int(rec["rsp_dir"]))
        else:
            quantity = _uff_quantity(path, rec, k)
            if quantity != "accelerance":
                raise DataError(f"{path}: record {k + 1}: time responses must be accelerations")
            scale = _unit_factor(path, quantity, {**rec, "orddenom_axis_units_lab": ""}, k)
            impact["responses"][DOF(int(rec["rsp_node"]), int(rec["rsp_dir"]))] = data * scale
    dofs = None
    force, response = [], []
    for case in sorted(impacts):
        impact = impacts[case]
        if impact["force"] is None:
            raise DataError(f"{path}: impact {case} has no force record")
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
    x = np.asarray(sets[0]["x"], dtype=float)
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
