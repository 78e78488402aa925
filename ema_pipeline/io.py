"""File formats: the project's HDF5 files, Universal File Format dataset 58, CSV
tables and the experiment description (TOML).

This is the only module that knows file layouts. Everything it writes goes to a
temporary file in the target folder first and is renamed into place when
complete (:func:`atomic_path`), so an interrupted run never leaves a
half-written result. Everything it reads is checked, and problems are raised as
:class:`~ema_pipeline.data.DataError` naming the file.

UFF dataset 58 is read and written through pyuff (ASCII and binary). The UFF
header stores the abscissa increment in an E13.5 field, which rounds
df = 2000/16384 Hz to 0.12207 Hz; our writer therefore also stores the exact
sample rate and record length in ID line 4 (``ema-pipeline fs=... ns=...``),
and our reader rebuilds the exact axis from it when present.

HDF5 layout of an FRF file (schema ``ema-pipeline/frf``, version 1)::

    /                 attrs: schema, schema_version, software
    /frf/freq_hz      (n_freq,) float64
    /frf/H            (n_out, n_in, n_freq) complex128 (native h5py compound)
    /frf/coherence    (n_out, n_in, n_freq) float64, optional
    /frf/response_dofs, /frf/reference_dofs   (n, 2) int: node, direction
    /frf              attrs: quantity, units, configuration, source_path, source_sha256
    /frf/acquisition  attrs: sample_rate_hz, n_samples, n_averages, windows, tau, estimator
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import tempfile
import tomllib
from collections.abc import Iterator, Mapping
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from ema_pipeline import __version__
from ema_pipeline.data import (
    DOF,
    AcquisitionInfo,
    Beam,
    ConfigurationSpec,
    DataError,
    Experiment,
    FRFSet,
    IdentificationSettings,
    Provenance,
    TimeRecords,
)

SCHEMA_FRF = "ema-pipeline/frf"
SCHEMA_RESULTS = "ema-pipeline/results"
SCHEMA_VERSION = 1
# Compressed, and without creation times so that a rerun writes identical bytes.
_DATASET_OPTIONS: dict[str, Any] = {"compression": "gzip", "shuffle": True, "track_times": False}

UFF_SUFFIXES = {".uff", ".unv", ".58"}
HDF5_SUFFIXES = {".h5", ".hdf5", ".hdf"}

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


# --------------------------------------------------------------------------
# Generic helpers
# --------------------------------------------------------------------------


def sha256_file(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a file's content, hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On an exception the temporary file is removed and ``path`` is untouched.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        if tmp_path.exists():  # mkstemp makes 0600 files; give the usual umask mode
            umask = os.umask(0)
            os.umask(umask)
            tmp_path.chmod(0o666 & ~umask)
        os.replace(tmp_path, target)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def write_text(text: str, path: str | os.PathLike[str]) -> Path:
    """Write a text file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_bytes(data: bytes, path: str | os.PathLike[str]) -> Path:
    """Write a binary file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_csv(table: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write a table as CSV (no index) atomically; floats keep full precision."""
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, float_format="%.10g")
    return Path(path)


def read_csv(path: str | os.PathLike[str], required: tuple[str, ...] = ()) -> pd.DataFrame:
    """Read a CSV table and check that it has the ``required`` columns."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    try:
        table = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a readable CSV table ({exc})") from exc
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise DataError(
            f"{path}: missing column(s) {', '.join(missing)}; "
            f"found {', '.join(map(str, table.columns))}"
        )
    return table


def _check_readable(path: Path, kind: str) -> None:
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    if path.stat().st_size == 0:
        raise DataError(f"{path}: empty file, expected {kind}")


# --------------------------------------------------------------------------
# HDF5 FRF files
# --------------------------------------------------------------------------


def _dofs_array(dofs: tuple[DOF, ...]) -> np.ndarray:
    return np.array([[d.node, d.direction] for d in dofs], dtype=np.int64).reshape(-1, 2)


def _dofs_from(array: np.ndarray) -> tuple[DOF, ...]:
    return tuple(DOF(int(n), int(d)) for n, d in np.asarray(array).reshape(-1, 2))


def _put_attrs(obj: h5py.HLObject, values: Mapping[str, Any]) -> None:
    for key, value in values.items():
        obj.attrs[key] = "" if value is None else value


def write_frf_group(group: h5py.Group, frf: FRFSet) -> None:
    """Store an FRFSet in an (open) HDF5 group."""
    group.create_dataset("freq_hz", data=frf.freq_hz, track_times=False)
    group.create_dataset("H", data=frf.H, **_DATASET_OPTIONS)
    if frf.coherence is not None:
        group.create_dataset("coherence", data=frf.coherence, **_DATASET_OPTIONS)
    group.create_dataset("response_dofs", data=_dofs_array(frf.response_dofs), track_times=False)
    group.create_dataset("reference_dofs", data=_dofs_array(frf.reference_dofs), track_times=False)
    _put_attrs(
        group,
        {
            "quantity": frf.quantity,
            "units": frf.units,
            "configuration": frf.configuration,
            "source_path": frf.source.path,
            "source_sha256": frf.source.sha256,
        },
    )
    acq = group.create_group("acquisition")
    info = frf.acquisition
    _put_attrs(acq, {f.name: getattr(info, f.name) for f in fields(info)})


def _attr(obj: h5py.HLObject, key: str, default: Any = None) -> Any:
    value = obj.attrs.get(key, default)
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, np.generic):
        value = value.item()
    return value


def read_frf_group(group: h5py.Group, path: str = "") -> FRFSet:
    """Read an FRFSet from an (open) HDF5 group written by :func:`write_frf_group`."""
    try:
        acq = group["acquisition"]
        info_kwargs: dict[str, Any] = {}
        for f in fields(AcquisitionInfo):
            value = _attr(acq, f.name)
            if value is not None and value != "":
                info_kwargs[f.name] = value
        return FRFSet(
            freq_hz=group["freq_hz"][()],
            H=group["H"][()],
            coherence=group["coherence"][()] if "coherence" in group else None,
            response_dofs=_dofs_from(group["response_dofs"][()]),
            reference_dofs=_dofs_from(group["reference_dofs"][()]),
            quantity=_attr(group, "quantity", "accelerance"),
            acquisition=AcquisitionInfo(**info_kwargs),
            configuration=_attr(group, "configuration", ""),
            source=Provenance(
                path=path or _attr(group, "source_path", ""),
                sha256=_attr(group, "source_sha256", ""),
            ),
        )
    except KeyError as exc:
        raise DataError(f"{path}: FRF group {group.name} is incomplete ({exc})") from exc


def write_frf_h5(frf: FRFSet, path: str | os.PathLike[str]) -> Path:
    """Write an FRFSet to the project's HDF5 FRF file (atomically)."""
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as h5:
        _put_attrs(
            h5,
            {"schema": SCHEMA_FRF, "schema_version": SCHEMA_VERSION, "software": _software()},
        )
        write_frf_group(h5.create_group("frf"), frf)
    return Path(path)


def _open_h5(path: Path) -> h5py.File:
    _check_readable(path, "an HDF5 file")
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise DataError(f"{path}: not a readable HDF5 file (truncated or corrupt: {exc})") from exc


def read_frf_h5(path: str | os.PathLike[str]) -> FRFSet:
    """Read an FRFSet from the project's HDF5 FRF file."""
    path = Path(path)
    with _open_h5(path) as h5:
        schema = _attr(h5, "schema")
        if schema != SCHEMA_FRF:
            raise DataError(
                f"{path}: not an ema-pipeline FRF file (schema attribute {schema!r}, "
                f"expected {SCHEMA_FRF!r})"
            )
        version = _attr(h5, "schema_version")
        if version != SCHEMA_VERSION:
            raise DataError(
                f"{path}: FRF schema version {version} is not supported (this is {SCHEMA_VERSION})"
            )
        if "frf" not in h5:
            raise DataError(f"{path}: no /frf group")
        frf = read_frf_group(h5["frf"], str(path))
    return _with_provenance(frf, path)


def _software() -> str:
    return f"ema-pipeline {__version__}"


def _with_provenance(frf: FRFSet, path: Path) -> FRFSet:
    from dataclasses import replace

    return replace(frf, source=Provenance(path=str(path), sha256=sha256_file(path)))


# --------------------------------------------------------------------------
# Results files: any tree of dataclasses, dicts, arrays, tables and FRF sets
# --------------------------------------------------------------------------


def _store(group: h5py.Group, name: str, value: Any) -> None:
    """Store ``value`` under ``name``: arrays as datasets, scalars and strings as
    attributes, dataclasses and dicts as sub-groups, DataFrames column by column."""
    if value is None:
        return
    if isinstance(value, FRFSet):
        write_frf_group(group.create_group(name), value)
    elif isinstance(value, pd.DataFrame):
        sub = group.create_group(name)
        sub.attrs["kind"] = "table"
        sub.attrs["columns"] = np.array([str(c) for c in value.columns], dtype=object)
        for col in value.columns:
            data = value[col].to_numpy()
            if data.dtype == object or pd.api.types.is_string_dtype(value[col]):
                data = np.array([str(v) for v in data], dtype=h5py.string_dtype())
            sub.create_dataset(str(col), data=data, track_times=False)
    elif is_dataclass(value) and not isinstance(value, type):
        sub = group.create_group(name)
        sub.attrs["kind"] = type(value).__name__
        for f in fields(value):
            _store(sub, f.name, getattr(value, f.name))
    elif isinstance(value, Mapping):
        sub = group.create_group(name)
        for key, item in value.items():
            _store(sub, str(key), item)
    elif isinstance(value, str | bool | int | float | np.generic):
        group.attrs[name] = value
    elif isinstance(value, tuple | list) and value and all(isinstance(v, DOF) for v in value):
        group.create_dataset(name, data=_dofs_array(tuple(value)), track_times=False)
    elif isinstance(value, tuple | list) and value and all(isinstance(v, str) for v in value):
        group.attrs[name] = np.array(value, dtype=object)
    elif (
        isinstance(value, tuple | list)
        and value
        and not all(isinstance(v, int | float | complex | np.generic) for v in value)
    ):
        sub = group.create_group(name)
        for k, item in enumerate(value):
            _store(sub, str(k), item)
    else:
        data = np.asarray(value)
        if data.dtype == object:
            raise DataError(f"cannot store {name!r} of type {type(value).__name__} in HDF5")
        options = _DATASET_OPTIONS if data.size > 4096 else {"track_times": False}
        group.create_dataset(name, data=data, **options)


def write_results_h5(
    sections: Mapping[str, Any],
    path: str | os.PathLike[str],
    *,
    schema: str = SCHEMA_RESULTS,
    attrs: Mapping[str, Any] | None = None,
) -> Path:
    """Write a results file atomically: one top-level group per section.

    The root carries ``schema``, ``schema_version``, ``software``, the given
    ``attrs`` and ``complete = True`` (set last, so a reader can trust a file
    that has it; the file appears under its name only once closed).
    """
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as h5:
        _put_attrs(
            h5, {"schema": schema, "schema_version": SCHEMA_VERSION, "software": _software()}
        )
        _put_attrs(h5, attrs or {})
        for name, value in sections.items():
            _store(h5, name, value)
        h5.attrs["complete"] = True
    return Path(path)


def _load(obj: h5py.HLObject) -> Any:
    if isinstance(obj, h5py.Dataset):
        data = obj[()]
        if obj.dtype.kind == "O" or h5py.check_string_dtype(obj.dtype):
            data = obj.asstr()[()]
        return data
    out: dict[str, Any] = {k: _attr(obj, k) for k in obj.attrs}
    for key, item in obj.items():
        out[key] = _load(item)
    return out


def read_results_h5(path: str | os.PathLike[str], *, schema: str = SCHEMA_RESULTS) -> dict:
    """Read a results file back as nested dicts of arrays and attributes."""
    path = Path(path)
    with _open_h5(path) as h5:
        found = _attr(h5, "schema")
        if found != schema:
            raise DataError(f"{path}: schema {found!r}, expected {schema!r}")
        if not _attr(h5, "complete", False):
            raise DataError(f"{path}: incomplete results file (interrupted write)")
        return _load(h5)


def read_frf_from_results(path: str | os.PathLike[str], section: str) -> FRFSet:
    """The FRFSet stored in ``section`` of a results file."""
    path = Path(path)
    with _open_h5(path) as h5:
        if section not in h5:
            raise DataError(f"{path}: no section {section!r}")
        return read_frf_group(h5[section], str(path))


def results_complete(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a results file whose write finished."""
    try:
        with h5py.File(path, "r") as h5:
            return bool(_attr(h5, "complete", False))
    except (OSError, KeyError):
        return False


def table_from_results(tree: Mapping[str, Any]) -> pd.DataFrame:
    """A DataFrame stored by :func:`write_results_h5`, from the loaded tree."""
    columns = list(tree.get("columns", []))
    return pd.DataFrame({c: tree[c] for c in columns})


# --------------------------------------------------------------------------
# Universal File Format, dataset 58
# --------------------------------------------------------------------------


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

    _check_readable(path, "a Universal File (dataset 58)")
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


def _id_lines(info: AcquisitionInfo, configuration: str) -> tuple[str, str]:
    """ID lines 4 and 5: acquisition metadata and configuration as key=value pairs."""

    def num(x: float | int | None) -> str:
        return "none" if x is None else repr(x)

    id4 = (
        f"ema-pipeline fs={num(info.sample_rate_hz)} ns={num(info.n_samples)} "
        f"navg={num(info.n_averages)} tau={num(info.exp_window_tau_s)} est={info.estimator} "
        f"fwin={info.force_window.replace(' ', '_')}"
    )
    id5 = f"ema-pipeline cfg={configuration.replace(' ', '_') or 'none'}"
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
    id4, id5 = _id_lines(frf.acquisition, frf.configuration)
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
        f"trig={records.trigger_s!r} cfg={records.configuration or 'none'}"
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


# --------------------------------------------------------------------------
# Dispatch by format
# --------------------------------------------------------------------------


def frf_format(path: str | os.PathLike[str]) -> str:
    """``"uff"`` or ``"h5"`` from the file name, else from the first bytes."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in UFF_SUFFIXES:
        return "uff"
    if suffix in HDF5_SUFFIXES:
        return "h5"
    _check_readable(path, "an FRF file")
    with open(path, "rb") as fh:
        head = fh.read(8)
    if head.startswith(b"\x89HDF"):
        return "h5"
    if head.strip().startswith(b"-1"):
        return "uff"
    raise DataError(f"{path}: unknown FRF file format (expected UFF dataset 58 or HDF5)")


def read_frf(path: str | os.PathLike[str]) -> FRFSet:
    """Read an FRF file: UFF dataset 58 (ASCII or binary) or the project's HDF5."""
    path = Path(path)
    if frf_format(path) == "uff":
        return read_frf_uff(path)
    return read_frf_h5(path)


def write_frf(
    frf: FRFSet, path: str | os.PathLike[str], fmt: str | None = None, *, coherence: bool = False
) -> Path:
    """Write an FRF file; ``fmt`` is "uff", "uff-binary" or "h5" (default: by suffix).

    HDF5 always keeps the coherence; UFF only with ``coherence=True``.
    """
    fmt = fmt or frf_format_for_writing(path)
    if fmt == "h5":
        return write_frf_h5(frf, path)
    if fmt in ("uff", "uff-binary"):
        return write_frf_uff(frf, path, binary=fmt == "uff-binary", coherence=coherence)
    raise DataError(f"unknown FRF format {fmt!r}; use uff, uff-binary or h5")


def frf_format_for_writing(path: str | os.PathLike[str]) -> str:
    suffix = Path(path).suffix.lower()
    if suffix in UFF_SUFFIXES:
        return "uff"
    if suffix in HDF5_SUFFIXES:
        return "h5"
    raise DataError(f"{path}: cannot tell the format from the suffix; use .uff or .h5")


def find_frf_files(folder: str | os.PathLike[str]) -> list[Path]:
    """Every UFF and HDF5 file under ``folder`` (recursively), sorted."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"{folder}: no such folder")
    suffixes = UFF_SUFFIXES | HDF5_SUFFIXES
    return sorted(
        p
        for p in folder.rglob("*")
        if p.is_file() and p.suffix.lower() in suffixes and not p.name.startswith(".")
    )


# --------------------------------------------------------------------------
# Experiment description (TOML)
# --------------------------------------------------------------------------


def _get(table: Mapping[str, Any], key: str, kind: type, path: Path, default: Any = ...) -> Any:
    if key not in table:
        if default is ...:
            raise DataError(f"{path}: missing required key {key!r}")
        return default
    value = table[key]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise DataError(f"{path}: {key!r} must be {kind.__name__}, got {value!r}")
    return value


def read_experiment(path: str | os.PathLike[str]) -> Experiment:
    """Read an experiment description (TOML). See ``raw_frf/experiment.toml``."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: experiment file not found")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not valid TOML ({exc})") from exc
    beam_t = doc.get("beam", {})
    try:
        beam = Beam(
            length_m=_get(beam_t, "length_m", float, path, 0.65),
            width_m=_get(beam_t, "width_m", float, path, 0.05),
            thickness_m=_get(beam_t, "thickness_m", float, path, 0.01),
            youngs_modulus_pa=_get(beam_t, "youngs_modulus_pa", float, path, 210e9),
            density_kg_m3=_get(beam_t, "density_kg_m3", float, path, 7800.0),
            n_elements=_get(beam_t, "n_elements", int, path, 100),
            n_measurement_elements=_get(beam_t, "n_measurement_elements", int, path, 10),
        )
    except DataError as exc:
        raise DataError(f"{path}: [beam] {exc}") from exc
    sensors = doc.get("sensors", {})
    ident = doc.get("identification", {})
    fe = doc.get("fe", {})
    configs = doc.get("configurations", [])
    if not isinstance(configs, list) or not configs:
        raise DataError(f"{path}: needs at least one [[configurations]] entry")
    specs = []
    for k, c in enumerate(configs, start=1):
        if not isinstance(c, dict) or "name" not in c or "file" not in c:
            raise DataError(f"{path}: configuration {k} needs 'name' and 'file'")
        tau = c.get("exp_window_tau_s")
        specs.append(
            ConfigurationSpec(
                name=str(c["name"]),
                file=str(c["file"]),
                description=str(c.get("description", "")),
                exp_window_tau_s=None if tau is None else float(tau),
            )
        )
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise DataError(f"{path}: configuration names repeat: {names}")
    genuine = str(doc.get("experiment", {}).get("genuine", names[0]))
    if genuine not in names:
        raise DataError(f"{path}: genuine configuration {genuine!r} is not among {names}")
    band = ident.get("band_hz")
    if band is not None and (len(band) != 2 or not float(band[0]) < float(band[1])):
        raise DataError(f"{path}: identification.band_hz must be [low, high], got {band}")
    n_nodes = beam.n_measurement_elements + 1
    immersed = tuple(int(e) for e in fe.get("immersed_elements", [beam.n_measurement_elements]))
    for e in immersed:
        if not 1 <= e <= beam.n_measurement_elements:
            raise DataError(
                f"{path}: immersed element {e} does not exist (1..{beam.n_measurement_elements})"
            )
    response_nodes = tuple(int(n) for n in sensors.get("response_nodes", [3, 6]))
    hammer = int(sensors.get("hammer_node", 8))
    for node in (*response_nodes, hammer):
        if not 1 <= node <= n_nodes:
            raise DataError(f"{path}: sensor node {node} does not exist (1..{n_nodes})")
    max_order = ident.get("max_order")
    return Experiment(
        name=str(doc.get("experiment", {}).get("name", path.stem)),
        beam=beam,
        configurations=tuple(specs),
        base_dir=str(path.parent),
        genuine=genuine,
        response_nodes=response_nodes,
        hammer_node=hammer,
        direction=int(sensors.get("direction", 3)),
        identification=IdentificationSettings(
            band_hz=None if band is None else (float(band[0]), float(band[1])),
            max_order=None if max_order is None else int(max_order),
            method=str(ident.get("method", "plscf")),
            expect_hz=tuple(float(f) for f in ident.get("expect_hz", [])),
        ),
        immersed_elements=immersed,
        n_modes=int(fe.get("n_modes", 4)),
        update_repeats=int(fe.get("update_repeats", 5)),
        seed=int(fe.get("seed", 0)),
    )


def experiment_file_path(experiment: Experiment, spec: ConfigurationSpec) -> Path:
    """Absolute path of a configuration's FRF file (relative to the experiment file)."""
    p = Path(spec.file)
    return p if p.is_absolute() else Path(experiment.base_dir) / p
