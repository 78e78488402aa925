"""The project's HDF5 files: FRF files and results stores.

The file is read through the checked access of :mod:`.hdf5_access`, after
the child-process check of :mod:`.hdf5_check`; a one-file identification
result is read back as objects by :mod:`.hdf5_result`.

FRF file layout (schema ``ema-pipeline/frf``, version 1)::

    /                 attrs: schema, schema_version, software
    /frf/freq_hz      (n_freq,) float64
    /frf/H            (n_out, n_in, n_freq) complex128 (native h5py compound)
    /frf/coherence    (n_out, n_in, n_freq) float64, optional
    /frf/response_dofs, /frf/reference_dofs   (n, 2) int: node, direction
    /frf              attrs: quantity, units, configuration, source_path, source_sha256
    /frf/acquisition  attrs: sample_rate_hz, n_samples, n_averages (n_averages_max where the
                      points differ), windows, tau, estimator,
                      force_band_hz (2 floats, optional: the force spectrum's -10/-20 dB points)

A results store (schema ``ema-pipeline/results``) holds any tree of dataclasses,
dicts, arrays, tables and FRF sets (:func:`write_results_h5`), one top-level
group per section, and the root attribute ``complete`` written last.

Writing
    HDF5 files are built in memory (h5py on a ``BytesIO``) and written to disk
    by :func:`~ema_pipeline.io.files.atomic_path` in one Python ``write``: a
    full disk then is one clean ``OSError`` (ENOSPC/EFBIG) and no partial file,
    where libhdf5 writing to a full disk itself segfaulted while closing the
    file. The cost is the file's size in memory for the time of the write
    (results files are a few MB).
"""

from __future__ import annotations

import io as _stdio
import os
import sys
from collections.abc import Callable, Mapping
from dataclasses import fields, is_dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

from ema_pipeline import __version__
from ema_pipeline.data import (
    DOF,
    QUANTITY_UNITS,
    AcquisitionInfo,
    DataError,
    FRFSet,
    Provenance,
    Table,
)
from ema_pipeline.io.files import atomic_path, sha256_file
from ema_pipeline.io.hdf5_access import (
    MAX_DEPTH,
    attr,
    check_dataset,
    dataset,
    dofs_array,
    dofs_from,
    member,
    pair_attr,
    put_attrs,
    typed_attr,
)
from ema_pipeline.io.hdf5_check import open_checked

if TYPE_CHECKING:
    import pandas as pd

SCHEMA_FRF = "ema-pipeline/frf"
SCHEMA_RESULTS = "ema-pipeline/results"
SCHEMA_VERSION = 1
# Without creation times, so that a rerun writes identical bytes. The FRF
# files (:func:`write_frf_h5`, a test's measurements, kept for long) are
# compressed; the results files are not: their arrays are mostly floats that
# gzip shrinks by 10-25 % (a paper file's result: 592 KB against 447 KB), for
# about a third of the write's time (a paper file: 10 of 28 ms; 12 paper files
# identified: 5 % of the command's wall time).
_STORED: dict[str, Any] = {"track_times": False}
_COMPRESSED: dict[str, Any] = {"compression": "gzip", "shuffle": True, **_STORED}
HDF5_SUFFIXES = {".h5", ".hdf5", ".hdf"}


def write_frf_group(group: h5py.Group, frf: FRFSet, *, compress: bool = True) -> None:
    """Store an FRFSet in an (open) HDF5 group (``H`` and ``coherence`` gzip
    compressed with ``compress``, as in the FRF files; a results file stores
    its FRFs uncompressed)."""
    options = _COMPRESSED if compress else _STORED
    group.create_dataset("freq_hz", data=frf.freq_hz, **_STORED)
    group.create_dataset("H", data=frf.H, **options)
    if frf.coherence is not None:
        group.create_dataset("coherence", data=frf.coherence, **options)
    group.create_dataset("response_dofs", data=dofs_array(frf.response_dofs), **_STORED)
    group.create_dataset("reference_dofs", data=dofs_array(frf.reference_dofs), **_STORED)
    put_attrs(
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
    put_attrs(acq, {f.name: getattr(info, f.name) for f in fields(info)})


_ACQUISITION_KINDS = {
    "sample_rate_hz": "float",
    "n_samples": "int",
    "n_averages": "int",
    "n_averages_max": "int",
    "force_window": "str",
    "response_window": "str",
    "exp_window_tau_s": "float",
    "estimator": "str",
    "force_band_hz": "pair",
}


def read_frf_group(group: h5py.Group, path: str = "") -> FRFSet:
    """Read an FRFSet from an (open) HDF5 group written by :func:`write_frf_group`.

    Every member is checked (hard link, type, dtype, shape, size) before it is
    read; problems are DataErrors naming ``path``.
    """
    where = Path(path)
    acq = member(group, "acquisition", where, h5py.Group)
    info_kwargs: dict[str, Any] = {}
    for f in fields(AcquisitionInfo):
        kind = _ACQUISITION_KINDS.get(f.name, "str")
        value = (pair_attr(acq, f.name, where) if kind == "pair"
                 else typed_attr(acq, f.name, kind, where))
        if value is not None and value != "":
            info_kwargs[f.name] = value
    h_ds = member(group, "H", where, h5py.Dataset)
    f_ds = member(group, "freq_hz", where, h5py.Dataset)
    if h_ds.ndim == 3 and f_ds.ndim == 1 and h_ds.shape[2] != f_ds.shape[0]:
        raise DataError(
            f"{path}: {h_ds.name} has {h_ds.shape[2]} frequency lines, "
            f"{f_ds.name} has {f_ds.shape[0]}"
        )
    freq = dataset(group, "freq_hz", where, 1, "fiu")
    H = dataset(group, "H", where, 3, "cf")
    coherence = dataset(group, "coherence", where, 3, "fiu", required=False)
    dofs = {}
    for name, n in (("response_dofs", H.shape[0]), ("reference_dofs", H.shape[1])):
        array = dataset(group, name, where, 2, "iu")
        if array.shape != (n, 2):
            raise DataError(
                f"{path}: {group.name}/{name} must have shape ({n}, 2) (node, direction), "
                f"got {array.shape}"
            )
        dofs[name] = dofs_from(array)
    quantity = typed_attr(group, "quantity", "str", where, "accelerance")
    if quantity not in QUANTITY_UNITS:
        raise DataError(
            f"{path}: unknown FRF quantity {quantity!r}; expected one of {sorted(QUANTITY_UNITS)}"
        )
    return FRFSet(
        freq_hz=freq,
        H=H,
        coherence=coherence,
        response_dofs=dofs["response_dofs"],
        reference_dofs=dofs["reference_dofs"],
        quantity=quantity,
        acquisition=AcquisitionInfo(**info_kwargs),
        configuration=typed_attr(group, "configuration", "str", where, ""),
        source=Provenance(
            path=path or typed_attr(group, "source_path", "str", where, ""),
            sha256=typed_attr(group, "source_sha256", "str", where, ""),
        ),
    )


# --------------------------------------------------------------------------
# Writing: in memory, then one atomic write
# --------------------------------------------------------------------------


def write_h5(path: str | os.PathLike[str], fill: Callable[[h5py.File], None]) -> Path:
    """Build an HDF5 file in memory with ``fill`` and write it atomically."""
    buffer = _stdio.BytesIO()
    with h5py.File(buffer, "w") as h5:
        fill(h5)
    with atomic_path(path) as tmp:
        tmp.write_bytes(buffer.getbuffer())
    return Path(path)


def write_frf_h5(frf: FRFSet, path: str | os.PathLike[str]) -> Path:
    """Write an FRFSet to the project's HDF5 FRF file (atomically)."""

    def fill(h5: h5py.File) -> None:
        put_attrs(
            h5,
            {"schema": SCHEMA_FRF, "schema_version": SCHEMA_VERSION, "software": software_name()},
        )
        write_frf_group(h5.create_group("frf"), frf)

    return write_h5(path, fill)


def _schema_checked(h5: h5py.File, path: Path, schema: str, what: str) -> None:
    found = attr(h5, "schema", path=path)
    if found != schema:
        raise DataError(
            f"{path}: not an ema-pipeline {what} (schema attribute {found!r}, expected {schema!r})"
        )
    version = attr(h5, "schema_version", path=path)
    if isinstance(version, bool) or not isinstance(version, int) or version != SCHEMA_VERSION:
        raise DataError(
            f"{path}: {what} schema version {version!r} is not supported "
            f"(this is {SCHEMA_VERSION})"
        )


def results_checked(h5: h5py.File, path: Path, schema: str) -> None:
    """A results file of ``schema`` whose write finished, else DataError."""
    found = attr(h5, "schema", path=path)
    if found != schema:
        raise DataError(f"{path}: schema {found!r}, expected {schema!r}")
    if not attr(h5, "complete", False, path):
        raise DataError(f"{path}: incomplete results file (interrupted write)")


def read_frf_h5(path: str | os.PathLike[str]) -> FRFSet:
    """Read an FRFSet from the project's HDF5 FRF file (checked as described above)."""
    path = Path(path)
    with open_checked(path) as h5:
        _schema_checked(h5, path, SCHEMA_FRF, "FRF file")
        frf = read_frf_group(member(h5, "frf", path, h5py.Group), str(path))
    return _with_provenance(frf, path)


def software_name() -> str:
    return f"ema-pipeline {__version__}"


def _with_provenance(frf: FRFSet, path: Path) -> FRFSet:
    return replace(frf, source=Provenance(path=str(path), sha256=sha256_file(path)))


# --------------------------------------------------------------------------
# Results files: any tree of dataclasses, dicts, arrays, tables and FRF sets
# --------------------------------------------------------------------------


def _is_dataframe(value: Any) -> bool:
    """Whether ``value`` is a ``pandas.DataFrame`` (pandas not imported: it is not)."""
    pd = sys.modules.get("pandas")
    return pd is not None and isinstance(value, pd.DataFrame)


def _store(group: h5py.Group, name: str, value: Any) -> None:
    """Store ``value`` under ``name``: arrays as datasets, scalars and strings as
    attributes, dataclasses and dicts as sub-groups, DataFrames column by column."""
    if value is None:
        return
    if not name or "/" in name or name in (".", ".."):
        raise DataError(
            f"cannot store {name!r} in HDF5: a member name must be non-empty, not '.' or "
            "'..', and contain no '/' (it would become a path)"
        )
    if isinstance(value, FRFSet):
        write_frf_group(group.create_group(name), value, compress=False)
    elif isinstance(value, Table) or _is_dataframe(value):
        table = value if isinstance(value, Table) else Table.from_frame(value)
        sub = group.create_group(name)
        sub.attrs["kind"] = "table"
        sub.attrs["columns"] = np.array(table.names, dtype=object)
        for col, data in table.columns.items():
            if data.dtype == object or data.dtype.kind in "US":
                data = np.array([str(v) for v in data], dtype=h5py.string_dtype())
            sub.create_dataset(col, data=data, **_STORED)
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
        group.create_dataset(name, data=dofs_array(tuple(value)), **_STORED)
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
        group.create_dataset(name, data=data, **_STORED)


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
    that has it; the file appears under its name only once complete).
    """

    def fill(h5: h5py.File) -> None:
        put_attrs(
            h5, {"schema": schema, "schema_version": SCHEMA_VERSION, "software": software_name()}
        )
        put_attrs(h5, attrs or {})
        for name, value in sections.items():
            _store(h5, name, value)
        h5.attrs["complete"] = True

    return write_h5(path, fill)


def load_tree(obj: h5py.HLObject, path: Path, depth: int = 0) -> Any:
    if depth > MAX_DEPTH:
        raise DataError(f"{path}: groups nested deeper than {MAX_DEPTH} (a cycle?)")
    if isinstance(obj, h5py.Dataset):
        check_dataset(obj, path)
        if obj.dtype.kind == "O" or h5py.check_string_dtype(obj.dtype):
            return obj.asstr()[()]
        return obj[()]
    if not isinstance(obj, h5py.Group):
        raise DataError(f"{path}: {obj.name} is neither a group nor a dataset")
    out: dict[str, Any] = {k: attr(obj, k, path=path) for k in obj.attrs}
    for key in obj:
        out[key] = load_tree(member(obj, key, path, h5py.HLObject), path, depth + 1)
    return out


def read_results_h5(path: str | os.PathLike[str], *, schema: str = SCHEMA_RESULTS) -> dict:
    """Read a results file back as nested dicts of arrays and attributes."""
    path = Path(path)
    with open_checked(path) as h5:
        results_checked(h5, path, schema)
        return load_tree(h5, path)


def read_frf_from_results(path: str | os.PathLike[str], section: str) -> FRFSet:
    """The FRFSet stored in ``section`` of a results file."""
    path = Path(path)
    with open_checked(path) as h5:
        if h5.get(section, getlink=True) is None:
            raise DataError(f"{path}: no section {section!r}")
        return read_frf_group(member(h5, section, path, h5py.Group), str(path))


def results_complete(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a results file whose write finished (False for a
    missing, unreadable, corrupt or incomplete one)."""
    try:
        with open_checked(Path(path)) as h5:
            return bool(attr(h5, "complete", False, Path(path)))
    except (DataError, OSError, KeyError):
        return False


def completed_result_sha256(path: str | os.PathLike[str]) -> str | None:
    """The input hash (root attribute ``input_sha256``) of a complete results file.

    None when ``path`` is missing, unreadable, not complete (an interrupted
    write) or has no recorded hash. Used to skip inputs whose result exists.
    """
    path = Path(path)
    try:
        with open_checked(path) as h5:
            if not attr(h5, "complete", False, path):
                return None
            value = attr(h5, "input_sha256", None, path)
    except (DataError, OSError):
        return None
    return None if value is None else str(value)


def result_details(path: str | os.PathLike[str]) -> dict[str, Any]:
    """What a one-file identification result (``<stem>_result.h5``) says about it.

    Returns
    -------
    dict with ``configuration`` (str, "" when not stored) and, when stored,
    ``fn_hz`` (natural frequencies, Hz, from the ``modes`` table), ``frac``,
    ``error`` (per-mode fit quality arrays of the ``identification`` section)
    and ``warnings`` (list of str: what ``identify`` warned about the file,
    from the ``input`` section).

    Raises
    ------
    DataError : the file cannot be read or its sections are malformed.
    """
    path = Path(path)
    details: dict[str, Any] = {}
    try:
        with open_checked(path) as h5:
            frf = member(h5, "frf", path, h5py.Group, required=False)
            details["configuration"] = (
                "" if frf is None else str(attr(frf, "configuration", "", path))
            )
            modes = member(h5, "modes", path, h5py.Group, required=False)
            if modes is not None and modes.get("fn_hz", getlink=True) is not None:
                details["fn_hz"] = np.asarray(
                    member(modes, "fn_hz", path, h5py.Dataset)[()], dtype=float
                )
            inp = member(h5, "input", path, h5py.Group, required=False)
            if inp is not None and "warnings" in inp.attrs:
                found = np.atleast_1d(attr(inp, "warnings", path=path))
                details["warnings"] = [
                    w.decode() if isinstance(w, bytes) else str(w) for w in found
                ]
            ident = member(h5, "identification", path, h5py.Group, required=False)
            if ident is not None and all(
                ident.get(k, getlink=True) is not None for k in ("frac", "error")
            ):
                details["frac"] = np.asarray(member(ident, "frac", path, h5py.Dataset)[()])
                details["error"] = np.asarray(member(ident, "error", path, h5py.Dataset)[()])
    except (OSError, KeyError, ValueError, TypeError) as exc:
        if isinstance(exc, DataError):
            raise
        raise DataError(f"{path}: cannot read the result details ({exc})") from exc
    return details


def table_from_results(tree: Mapping[str, Any]) -> pd.DataFrame:
    """A DataFrame stored by :func:`write_results_h5`, from the loaded tree."""
    import pandas as pd  # here: the commands that only write tables do without it

    columns = list(tree.get("columns", []))
    return pd.DataFrame({c: tree[c] for c in columns})
