"""Checked access to the members and attributes of an HDF5 file read as if it
came from an adversary.

Every HDF5 file is read as if it came from an adversary:

* only a non-empty regular file with an HDF5 signature is handed to libhdf5
  (:func:`~ema_pipeline.io.files.check_readable`; FIFOs, devices, folders and
  symlink loops are refused before anything is opened or hashed);
* members are reached through hard links only: a soft or external link is
  refused, never followed (``group.get(name, getlink=True)`` inspects the link
  without traversing it), and so is a dataset whose raw data lives in another
  file (external storage) or in other datasets (virtual dataset);
* object types (group / dataset), dtypes, shapes and the declared size of
  every dataset and attribute are checked before it is read; a dataset may
  declare at most :data:`MAX_DATASET_BYTES` (a 64 GiB dataset declared in a
  400 kB file would otherwise be allocated, and filled with its fill value);
* attribute values are type-checked (``exp_window_tau_s`` must be a positive
  finite number, counts positive integers, names strings).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, overload

import h5py
import numpy as np

from ema_pipeline.data import DOF, DataError

__all__ = [
    "MAX_DATASET_BYTES",
    "MAX_DEPTH",
    "MAX_OBJECTS",
    "attr",
    "check_dataset",
    "check_type",
    "dataset",
    "dofs_array",
    "dofs_from",
    "member",
    "pair_attr",
    "put_attrs",
    "typed_attr",
]

#: Largest dataset or attribute (declared bytes) read from an HDF5 file.
MAX_DATASET_BYTES = 1 << 30
#: Deepest group nesting and most objects walked in one file.
MAX_DEPTH, MAX_OBJECTS = 64, 200_000
_ALLOWED_KINDS = frozenset("biufcSUO")  # bool, ints, floats, complex, strings


def dofs_array(dofs: tuple[DOF, ...]) -> np.ndarray:
    return np.array([[d.node, d.direction] for d in dofs], dtype=np.int64).reshape(-1, 2)


def dofs_from(array: np.ndarray) -> tuple[DOF, ...]:
    return tuple(DOF(int(n), int(d)) for n, d in np.asarray(array).reshape(-1, 2))


def put_attrs(obj: h5py.HLObject, values: Mapping[str, Any]) -> None:
    for key, value in values.items():
        obj.attrs[key] = "" if value is None else value


def member(group: h5py.Group, name: str, path: Path, kind: type, required: bool = True):
    """``group[name]`` reached through a hard link and of type ``kind`` (Group or
    Dataset; datasets pass :func:`check_dataset`), else DataError. None when
    absent and not ``required``."""
    where = f"{group.name.rstrip('/')}/{name}"
    link = group.get(name, getlink=True)
    if link is None:
        if required:
            raise DataError(f"{path}: {where} is missing")
        return None
    if isinstance(link, h5py.ExternalLink):
        raise DataError(
            f"{path}: {where} is an external link to {link.filename}:{link.path}; "
            "links to other files are not followed"
        )
    if not isinstance(link, h5py.HardLink):
        raise DataError(f"{path}: {where} is a soft link; links are not followed")
    obj = group[name]
    if not isinstance(obj, kind):
        found = "group" if isinstance(obj, h5py.Group) else "dataset"
        wanted = "group" if kind is h5py.Group else "dataset"
        raise DataError(f"{path}: {where} is a {found}, expected a {wanted}")
    if isinstance(obj, h5py.Dataset):
        check_dataset(obj, path)
    return obj


def _size_text(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} TiB"  # pragma: no cover


def check_dataset(ds: h5py.Dataset, path: Path, max_bytes: int = MAX_DATASET_BYTES) -> None:
    """Storage, dtype and declared size of a dataset, before it is read."""
    if ds.is_virtual:
        raise DataError(f"{path}: {ds.name} is a virtual dataset (data in other files)")
    if ds.id.get_create_plist().get_external_count() > 0:
        raise DataError(
            f"{path}: {ds.name} keeps its data in external files; they are not read"
        )
    check_type(ds.dtype, ds.shape, f"{ds.name}", path, max_bytes)


def check_type(dtype: np.dtype, shape: tuple[int, ...] | None, where: str, path: Path,
                max_bytes: int = MAX_DATASET_BYTES) -> None:
    if dtype.kind not in _ALLOWED_KINDS or (
        dtype.kind == "O" and h5py.check_string_dtype(dtype) is None
    ):
        raise DataError(f"{path}: {where} has an unsupported data type {dtype}")
    n = math.prod(shape or ())
    if n * dtype.itemsize > max_bytes:
        raise DataError(
            f"{path}: {where} declares {_size_text(n * dtype.itemsize)} (shape {shape}), more "
            f"than the limit of {_size_text(max_bytes)}"
        )


def attr(obj: h5py.HLObject, key: str, default: Any = None, path: Path | None = None) -> Any:
    """An attribute as a Python value (str for strings), size-checked before reading."""
    if key not in obj.attrs:
        return default
    aid = obj.attrs.get_id(key)
    check_type(aid.dtype, aid.shape, f"attribute {key!r} of {obj.name}", path or Path(""))
    try:
        value = obj.attrs[key]
    except (OSError, TypeError, ValueError) as exc:
        raise DataError(f"{path}: attribute {key!r} of {obj.name} is unreadable ({exc})") from exc
    if isinstance(value, bytes):
        try:
            value = value.decode()
        except UnicodeDecodeError as exc:
            raise DataError(f"{path}: attribute {key!r} of {obj.name} is not UTF-8") from exc
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, str):
        try:
            value.encode("utf-8")  # h5py keeps undecodable bytes as surrogates
        except UnicodeEncodeError as exc:
            raise DataError(
                f"{path}: attribute {key!r} of {obj.name} is not valid UTF-8 text"
            ) from exc
    return value


def typed_attr(obj: h5py.HLObject, key: str, kind: str, path: Path, default: Any = None) -> Any:
    """A scalar attribute of ``kind`` "str", "int" (> 0) or "float" (> 0, finite);
    for numbers the empty string (how None is written) gives None."""
    value = attr(obj, key, default, path)
    if value is default:
        return default
    where = f"{path}: attribute {key!r} of {obj.name}"
    if isinstance(value, np.ndarray):
        raise DataError(f"{where} must be a single value, got an array of shape {value.shape}")
    if kind == "str":
        if not isinstance(value, str):
            raise DataError(f"{where} must be text, got {value!r}")
        return value
    if value == "":
        return None
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
            raise DataError(f"{where} must be a positive integer, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
        math.isfinite(value) and value > 0
    ):
        raise DataError(f"{where} must be a positive finite number, got {value!r}")
    return float(value)


def pair_attr(obj: h5py.HLObject, key: str, path: Path) -> tuple[float, float] | None:
    """A (lo, hi) pair attribute of positive finite numbers, lo <= hi ("" is None)."""
    value = attr(obj, key, None, path)
    if value is None or (isinstance(value, str) and value == ""):
        return None
    pair = np.asarray(value)
    if pair.shape != (2,) or pair.dtype.kind not in "fiu" or not (
        np.all(np.isfinite(pair)) and 0 < pair[0] <= pair[1]
    ):
        raise DataError(f"{path}: attribute {key!r} of {obj.name} must be two positive "
                        f"numbers lo <= hi, got {value!r}")
    return float(pair[0]), float(pair[1])


@overload
def dataset(group: h5py.Group, name: str, path: Path, ndim: int, kinds: str,
             required: Literal[True] = ...) -> np.ndarray: ...


@overload
def dataset(group: h5py.Group, name: str, path: Path, ndim: int, kinds: str,
             required: bool) -> np.ndarray | None: ...


def dataset(group: h5py.Group, name: str, path: Path, ndim: int, kinds: str,
             required: bool = True) -> np.ndarray | None:
    ds = member(group, name, path, h5py.Dataset, required)
    if ds is None:
        return None
    if ds.ndim != ndim or ds.dtype.kind not in kinds:
        raise DataError(
            f"{path}: {ds.name} must be a {ndim}-D array of kind {kinds!r}, "
            f"got shape {ds.shape} dtype {ds.dtype}"
        )
    try:
        return ds[()]
    except (OSError, ValueError, TypeError) as exc:
        raise DataError(f"{path}: {ds.name} is unreadable (corrupt: {exc})") from exc
