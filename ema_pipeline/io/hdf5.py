"""The project's HDF5 files: FRF files and results stores.

FRF file layout (schema ``ema-pipeline/frf``, version 1)::

    /                 attrs: schema, schema_version, software
    /frf/freq_hz      (n_freq,) float64
    /frf/H            (n_out, n_in, n_freq) complex128 (native h5py compound)
    /frf/coherence    (n_out, n_in, n_freq) float64, optional
    /frf/response_dofs, /frf/reference_dofs   (n, 2) int: node, direction
    /frf              attrs: quantity, units, configuration, source_path, source_sha256
    /frf/acquisition  attrs: sample_rate_hz, n_samples, n_averages, windows, tau, estimator

A results store (schema ``ema-pipeline/results``) holds any tree of dataclasses,
dicts, arrays, tables and FRF sets (:func:`write_results_h5`), one top-level
group per section, and the root attribute ``complete`` written last.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import fields, is_dataclass, replace
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd

from ema_pipeline import __version__
from ema_pipeline.data import DOF, AcquisitionInfo, DataError, FRFSet, Provenance
from ema_pipeline.io.files import atomic_path, check_readable, sha256_file

SCHEMA_FRF = "ema-pipeline/frf"
SCHEMA_RESULTS = "ema-pipeline/results"
SCHEMA_VERSION = 1
# Compressed, and without creation times so that a rerun writes identical bytes.
_DATASET_OPTIONS: dict[str, Any] = {"compression": "gzip", "shuffle": True, "track_times": False}
HDF5_SUFFIXES = {".h5", ".hdf5", ".hdf"}


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
    check_readable(path, "an HDF5 file")
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


def completed_result_sha256(path: str | os.PathLike[str]) -> str | None:
    """The input hash (root attribute ``input_sha256``) of a complete results file.

    None when ``path`` is missing, unreadable, not complete (an interrupted
    write) or has no recorded hash. Used to skip inputs whose result exists.
    """
    if not results_complete(path):
        return None
    try:
        with h5py.File(path, "r") as h5:
            value = _attr(h5, "input_sha256")
    except OSError:
        return None
    return None if value is None else str(value)


def result_details(path: str | os.PathLike[str]) -> dict[str, Any]:
    """What a one-file identification result (``<stem>_result.h5``) says about it.

    Returns
    -------
    dict with ``configuration`` (str, "" when not stored) and, when stored,
    ``fn_hz`` (natural frequencies, Hz, from the ``modes`` table) and ``frac``,
    ``error`` (per-mode fit quality arrays of the ``identification`` section).

    Raises
    ------
    DataError : the file cannot be read or its sections are malformed.
    """
    path = Path(path)
    details: dict[str, Any] = {}
    try:
        with h5py.File(path, "r") as h5:
            details["configuration"] = (
                str(_attr(h5["frf"], "configuration", "")) if "frf" in h5 else ""
            )
            if "modes" in h5 and "fn_hz" in h5["modes"]:
                details["fn_hz"] = np.asarray(h5["modes"]["fn_hz"][()], dtype=float)
            ident = h5["identification"] if "identification" in h5 else None
            if ident is not None and "frac" in ident and "error" in ident:
                details["frac"] = np.asarray(ident["frac"][()])
                details["error"] = np.asarray(ident["error"][()])
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise DataError(f"{path}: cannot read the result details ({exc})") from exc
    return details


def table_from_results(tree: Mapping[str, Any]) -> pd.DataFrame:
    """A DataFrame stored by :func:`write_results_h5`, from the loaded tree."""
    columns = list(tree.get("columns", []))
    return pd.DataFrame({c: tree[c] for c in columns})
