"""The project's HDF5 files: FRF files and results stores.

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

Reading hostile files
---------------------
Every HDF5 file is read as if it came from an adversary (issue 15):

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

Corrupt files: a child process first
    libhdf5 itself is not safe on corrupt input. Flipping single bytes of
    ``raw_frf/larger_tank.h5`` (all 11,792 offsets of its metadata regions,
    XOR 0xFF) made the library loop forever on 18 offsets and segfault on 7 --
    mostly in the global heap that holds variable-length string attributes,
    which has no checksum in any HDF5 format version. Checksums therefore
    cannot help (files written by other tools, or with ``libver="earliest"``
    like ours, have none on any metadata), and a structure validator of our
    own would have to re-implement the file format. So before the parent
    process touches a file, a child process opens it and walks everything
    reachable (:func:`walk_hdf5`: the same link, type, dtype and size checks,
    then every attribute and every dataset read in full). The parent reads the
    file only when the child finished cleanly within
    ``CHILD_TIMEOUT_S + size / CHILD_READ_RATE`` seconds; a child killed by a
    signal or by the timeout makes the file a :class:`DataError` ("corrupt
    HDF5 file"), and a DataError found by the child is re-raised with its
    message. The child is a ``fork`` of the caller when the caller runs a
    single thread (cheap: nothing is imported again), else a fresh interpreter
    (``python -c``), because forking a multi-threaded process can deadlock
    the child on a lock held by another thread. Measured on the 2-core
    development machine under a load average of about 7 (other jobs running;
    ``larger_tank.h5``, 396 kB, medians of 30): reading the FRF group alone
    27 ms, the walk in-process 27 ms, the forked check 93 ms, the
    fresh-interpreter check 1980 ms (interpreter, numpy and h5py start-up);
    ``read_frf_h5`` as a whole (check, read, SHA-256) 108 ms, against about
    500 ms for identifying the file. The fork costs ~65 ms per file, paid
    once per input, which is why the fresh interpreter is only the fallback.
    A file on which libhdf5 hangs costs the child timeout (5 s + 0.1 s per MB)
    before it is refused. Every reader pays the check: ``read_frf_h5``,
    ``read_results_h5``, ``read_frf_from_results``, ``results_complete``,
    ``completed_result_sha256`` and ``result_details``.

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
import math
import os
import select
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import MISSING, fields, is_dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, overload

import h5py
import numpy as np

from ema_pipeline import __version__
from ema_pipeline.data import (
    DOF,
    QUANTITY_UNITS,
    AcquisitionInfo,
    DataError,
    FRFSet,
    ModalParameters,
    Provenance,
    Table,
)
from ema_pipeline.identification.result import (
    IdentificationResult,
    ResolvedSettings,
    SelectedPoles,
    StabilizationData,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.io.files import atomic_path, check_readable, open_regular, sha256_file

if TYPE_CHECKING:
    import pandas as pd

SCHEMA_FRF = "ema-pipeline/frf"
SCHEMA_RESULTS = "ema-pipeline/results"
SCHEMA_VERSION = 1
# Compressed, and without creation times so that a rerun writes identical bytes.
_DATASET_OPTIONS: dict[str, Any] = {"compression": "gzip", "shuffle": True, "track_times": False}
HDF5_SUFFIXES = {".h5", ".hdf5", ".hdf"}

#: Largest dataset or attribute (declared bytes) read from an HDF5 file.
MAX_DATASET_BYTES = 1 << 30
#: Deepest group nesting and most objects walked in one file.
MAX_DEPTH, MAX_OBJECTS = 64, 200_000
#: The child check of a file may take CHILD_TIMEOUT_S + size / CHILD_READ_RATE seconds,
#: and CHILD_START_S more when it is a fresh interpreter (threads in this process rule
#: out a fork): its start-up alone took more than 5 s on a 2-core machine at load 8,
#: and a valid file must not fail on a busy machine.
CHILD_TIMEOUT_S, CHILD_READ_RATE, CHILD_START_S = 5.0, 10e6, 30.0
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_ALLOWED_KINDS = frozenset("biufcSUO")  # bool, ints, floats, complex, strings
_EXIT_OK, _EXIT_DATA, _EXIT_OTHER = 0, 3, 4


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


# --------------------------------------------------------------------------
# Checked access to members and attributes
# --------------------------------------------------------------------------


def _member(group: h5py.Group, name: str, path: Path, kind: type, required: bool = True):
    """``group[name]`` reached through a hard link and of type ``kind`` (Group or
    Dataset; datasets pass :func:`_check_dataset`), else DataError. None when
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
        _check_dataset(obj, path)
    return obj


def _size_text(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} TiB"  # pragma: no cover


def _check_dataset(ds: h5py.Dataset, path: Path, max_bytes: int = MAX_DATASET_BYTES) -> None:
    """Storage, dtype and declared size of a dataset, before it is read."""
    if ds.is_virtual:
        raise DataError(f"{path}: {ds.name} is a virtual dataset (data in other files)")
    if ds.id.get_create_plist().get_external_count() > 0:
        raise DataError(
            f"{path}: {ds.name} keeps its data in external files; they are not read"
        )
    _check_type(ds.dtype, ds.shape, f"{ds.name}", path, max_bytes)


def _check_type(dtype: np.dtype, shape: tuple[int, ...] | None, where: str, path: Path,
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


def _attr(obj: h5py.HLObject, key: str, default: Any = None, path: Path | None = None) -> Any:
    """An attribute as a Python value (str for strings), size-checked before reading."""
    if key not in obj.attrs:
        return default
    aid = obj.attrs.get_id(key)
    _check_type(aid.dtype, aid.shape, f"attribute {key!r} of {obj.name}", path or Path(""))
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


def _typed_attr(obj: h5py.HLObject, key: str, kind: str, path: Path, default: Any = None) -> Any:
    """A scalar attribute of ``kind`` "str", "int" (> 0) or "float" (> 0, finite);
    for numbers the empty string (how None is written) gives None."""
    value = _attr(obj, key, default, path)
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


def _pair_attr(obj: h5py.HLObject, key: str, path: Path) -> tuple[float, float] | None:
    """A (lo, hi) pair attribute of positive finite numbers, lo <= hi ("" is None)."""
    value = _attr(obj, key, None, path)
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
def _dataset(group: h5py.Group, name: str, path: Path, ndim: int, kinds: str,
             required: Literal[True] = ...) -> np.ndarray: ...


@overload
def _dataset(group: h5py.Group, name: str, path: Path, ndim: int, kinds: str,
             required: bool) -> np.ndarray | None: ...


def _dataset(group: h5py.Group, name: str, path: Path, ndim: int, kinds: str,
             required: bool = True) -> np.ndarray | None:
    ds = _member(group, name, path, h5py.Dataset, required)
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


def read_frf_group(group: h5py.Group, path: str = "") -> FRFSet:
    """Read an FRFSet from an (open) HDF5 group written by :func:`write_frf_group`.

    Every member is checked (hard link, type, dtype, shape, size) before it is
    read; problems are DataErrors naming ``path``.
    """
    where = Path(path)
    acq = _member(group, "acquisition", where, h5py.Group)
    info_kwargs: dict[str, Any] = {}
    for f in fields(AcquisitionInfo):
        kind = _ACQUISITION_KINDS.get(f.name, "str")
        value = (_pair_attr(acq, f.name, where) if kind == "pair"
                 else _typed_attr(acq, f.name, kind, where))
        if value is not None and value != "":
            info_kwargs[f.name] = value
    h_ds = _member(group, "H", where, h5py.Dataset)
    f_ds = _member(group, "freq_hz", where, h5py.Dataset)
    if h_ds.ndim == 3 and f_ds.ndim == 1 and h_ds.shape[2] != f_ds.shape[0]:
        raise DataError(
            f"{path}: {h_ds.name} has {h_ds.shape[2]} frequency lines, "
            f"{f_ds.name} has {f_ds.shape[0]}"
        )
    freq = _dataset(group, "freq_hz", where, 1, "fiu")
    H = _dataset(group, "H", where, 3, "cf")
    coherence = _dataset(group, "coherence", where, 3, "fiu", required=False)
    dofs = {}
    for name, n in (("response_dofs", H.shape[0]), ("reference_dofs", H.shape[1])):
        array = _dataset(group, name, where, 2, "iu")
        if array.shape != (n, 2):
            raise DataError(
                f"{path}: {group.name}/{name} must have shape ({n}, 2) (node, direction), "
                f"got {array.shape}"
            )
        dofs[name] = _dofs_from(array)
    quantity = _typed_attr(group, "quantity", "str", where, "accelerance")
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
        configuration=_typed_attr(group, "configuration", "str", where, ""),
        source=Provenance(
            path=path or _typed_attr(group, "source_path", "str", where, ""),
            sha256=_typed_attr(group, "source_sha256", "str", where, ""),
        ),
    )


# --------------------------------------------------------------------------
# Writing: in memory, then one atomic write
# --------------------------------------------------------------------------


def _write_h5(path: str | os.PathLike[str], fill: Callable[[h5py.File], None]) -> Path:
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
        _put_attrs(
            h5,
            {"schema": SCHEMA_FRF, "schema_version": SCHEMA_VERSION, "software": _software()},
        )
        write_frf_group(h5.create_group("frf"), frf)

    return _write_h5(path, fill)


# --------------------------------------------------------------------------
# Opening: signature, child-process check, then h5py
# --------------------------------------------------------------------------


def _check_signature(path: Path, size: int) -> None:
    """An HDF5 superblock starts at 0, 512, 1024, 2048, ... bytes."""
    with open_regular(path, "an HDF5 file") as fh:
        offset = 0
        while offset + 8 <= size:
            fh.seek(offset)
            if fh.read(8) == _HDF5_SIGNATURE:
                return
            offset = 512 if offset == 0 else 2 * offset
    raise DataError(f"{path}: not an HDF5 file (no HDF5 signature)")


def walk_hdf5(path: str | os.PathLike[str], max_bytes: int = MAX_DATASET_BYTES) -> int:
    """Open an HDF5 file and read everything reachable through hard links.

    Links, object types, dtypes and declared sizes are checked before each
    read (as the readers do). Returns the number of objects. Meant to run in a
    child process (:func:`check_hdf5`): on a corrupt file libhdf5 may crash or
    never return.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "a.h5")
    >>> with h5py.File(path, "w") as h5:
    ...     h5["g/x"] = [1.0, 2.0]
    >>> walk_hdf5(path)  # the group g and the dataset x
    2
    """
    path = Path(path)
    count = 0

    def visit(group: h5py.Group, depth: int) -> None:
        nonlocal count
        if depth > MAX_DEPTH:
            raise DataError(f"{path}: groups nested deeper than {MAX_DEPTH} (a cycle?)")
        for key in group.attrs:
            _attr(group, key, path=path)
        for name in group:
            count += 1
            if count > MAX_OBJECTS:
                raise DataError(f"{path}: more than {MAX_OBJECTS} objects")
            link = group.get(name, getlink=True)
            if not isinstance(link, h5py.HardLink):
                _member(group, name, path, object)  # raises the link message
            obj = group[name]
            if isinstance(obj, h5py.Group):
                visit(obj, depth + 1)
            elif isinstance(obj, h5py.Dataset):
                _check_dataset(obj, path, max_bytes)
                for key in obj.attrs:
                    _attr(obj, key, path=path)
                obj[()]
            else:
                raise DataError(f"{path}: {obj.name} is neither a group nor a dataset")

    try:
        with h5py.File(path, "r") as h5:
            visit(h5, 0)
    except DataError:
        raise
    except Exception as exc:  # h5py raises OSError, KeyError, ValueError, RuntimeError ...
        raise DataError(f"{path}: corrupt HDF5 file ({type(exc).__name__}: {exc})") from exc
    return count


def _child_timeout(size: int) -> float:
    return CHILD_TIMEOUT_S + size / CHILD_READ_RATE


def _fork_check(path: Path, timeout_s: float) -> tuple[str, str]:
    """Run :func:`walk_hdf5` in a forked child; ``(status, message)`` with status
    "ok", "data" (a DataError), "other", "signal" or "timeout"."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: never return into the caller's code
        code = _EXIT_OTHER
        try:
            os.close(read_end)
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                walk_hdf5(path)
                code, message = _EXIT_OK, ""
            except DataError as exc:
                code, message = _EXIT_DATA, str(exc)
            except BaseException as exc:
                code, message = _EXIT_OTHER, f"{type(exc).__name__}: {exc}"
            os.write(write_end, message.encode("utf-8", "replace")[:8000])
        finally:
            os._exit(code)
    os.close(write_end)
    chunks, deadline = [], time.monotonic() + timeout_s
    try:
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not select.select([read_end], [], [], remaining)[0]:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                return "timeout", ""
            chunk = os.read(read_end, 65536)
            if not chunk:  # the child closed the pipe: it exited
                break
            chunks.append(chunk)
    finally:
        os.close(read_end)
    _, status = os.waitpid(pid, 0)
    message = b"".join(chunks).decode("utf-8", "replace")
    return _child_status(status, message)


def _child_status(status: int, message: str) -> tuple[str, str]:
    if os.WIFSIGNALED(status):
        return "signal", signal.Signals(os.WTERMSIG(status)).name
    code = os.WEXITSTATUS(status)
    return {_EXIT_OK: "ok", _EXIT_DATA: "data"}.get(code, "other"), message


_CHILD_CODE = (
    "import sys\n"
    "from ema_pipeline.data import DataError\n"
    "from ema_pipeline.io.hdf5 import walk_hdf5\n"
    "try:\n"
    "    walk_hdf5(sys.argv[1])\n"
    "except DataError as exc:\n"
    "    sys.stdout.write(str(exc)); sys.exit(3)\n"
)


def _spawn_check(path: Path, timeout_s: float) -> tuple[str, str]:
    """:func:`walk_hdf5` in a fresh interpreter (safe from a multi-threaded caller)."""
    package_root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [package_root, env.get("PYTHONPATH")]))
    try:
        done = subprocess.run(
            [sys.executable, "-c", _CHILD_CODE, str(path)],
            stdin=subprocess.DEVNULL,
            capture_output=True,
            timeout=timeout_s + 10.0,  # + interpreter start-up
            env=env,
        )
    except subprocess.TimeoutExpired:
        return "timeout", ""
    message = done.stdout.decode("utf-8", "replace")
    if done.returncode < 0:
        return "signal", signal.Signals(-done.returncode).name
    if done.returncode == 0:
        return "ok", ""
    if done.returncode == _EXIT_DATA:
        return "data", message
    lines = done.stderr.decode("utf-8", "replace").strip().splitlines()
    return "other", lines[-1] if lines else f"exit status {done.returncode}"


#: Threads with this name hold no lock (they only sleep and poll, e.g. a batch
#: worker's parent watcher), so :func:`check_hdf5` may still fork beside them.
FORK_SAFE_THREAD_NAME = "ema-fork-safe"


def only_fork_safe_threads() -> bool:
    """True when this is the only thread, apart from threads named
    :data:`FORK_SAFE_THREAD_NAME` (forking with other threads can deadlock the
    child on a lock one of them held).

    Examples
    --------
    >>> only_fork_safe_threads()
    True
    """
    me = threading.current_thread()
    return all(t is me or t.name == FORK_SAFE_THREAD_NAME for t in threading.enumerate())


def check_hdf5(path: str | os.PathLike[str], timeout_s: float | None = None) -> None:
    """Check that libhdf5 can read ``path`` safely, in a child process.

    Raises DataError naming the file when it is not a non-empty regular HDF5
    file, when the child finds a structural problem (links, types, sizes), or
    when libhdf5 crashed or hung in the child (killed after ``timeout_s``,
    default ``CHILD_TIMEOUT_S + size / CHILD_READ_RATE``, plus ``CHILD_START_S``
    for a fresh interpreter). See the module
    docstring for why and what it costs.

    Examples
    --------
    >>> check_hdf5("/dev/zero")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: /dev/zero: is a device, expected an HDF5 file
    """
    path = Path(path)
    size = check_readable(path, "an HDF5 file").st_size
    _check_signature(path, size)
    default = timeout_s is None
    timeout_s = _child_timeout(size) if timeout_s is None else timeout_s
    if hasattr(os, "fork") and only_fork_safe_threads():
        status, message = _fork_check(path, timeout_s)
    else:
        timeout_s += CHILD_START_S if default else 0.0
        status, message = _spawn_check(path, timeout_s)
    if status == "ok":
        return
    if status == "data":
        raise DataError(message)
    if status == "signal":
        raise DataError(f"{path}: corrupt HDF5 file (the HDF5 library crashed reading it: "
                        f"{message})")
    if status == "timeout":
        raise DataError(f"{path}: corrupt HDF5 file (the HDF5 library did not finish reading "
                        f"it within {timeout_s:.0f} s)")
    raise DataError(f"{path}: corrupt HDF5 file ({message})")


def _open_h5(path: Path) -> h5py.File:
    """Open an input HDF5 file read-only, after :func:`check_hdf5`."""
    check_hdf5(path)
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise DataError(f"{path}: not a readable HDF5 file (truncated or corrupt: {exc})") from exc


def _schema_checked(h5: h5py.File, path: Path, schema: str, what: str) -> None:
    found = _attr(h5, "schema", path=path)
    if found != schema:
        raise DataError(
            f"{path}: not an ema-pipeline {what} (schema attribute {found!r}, expected {schema!r})"
        )
    version = _attr(h5, "schema_version", path=path)
    if isinstance(version, bool) or not isinstance(version, int) or version != SCHEMA_VERSION:
        raise DataError(
            f"{path}: {what} schema version {version!r} is not supported "
            f"(this is {SCHEMA_VERSION})"
        )


def _results_checked(h5: h5py.File, path: Path, schema: str) -> None:
    """A results file of ``schema`` whose write finished, else DataError."""
    found = _attr(h5, "schema", path=path)
    if found != schema:
        raise DataError(f"{path}: schema {found!r}, expected {schema!r}")
    if not _attr(h5, "complete", False, path):
        raise DataError(f"{path}: incomplete results file (interrupted write)")


def read_frf_h5(path: str | os.PathLike[str]) -> FRFSet:
    """Read an FRFSet from the project's HDF5 FRF file (checked as described above)."""
    path = Path(path)
    with _open_h5(path) as h5:
        _schema_checked(h5, path, SCHEMA_FRF, "FRF file")
        frf = read_frf_group(_member(h5, "frf", path, h5py.Group), str(path))
    return _with_provenance(frf, path)


def _software() -> str:
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
        write_frf_group(group.create_group(name), value)
    elif isinstance(value, Table) or _is_dataframe(value):
        table = value if isinstance(value, Table) else Table.from_frame(value)
        sub = group.create_group(name)
        sub.attrs["kind"] = "table"
        sub.attrs["columns"] = np.array(table.names, dtype=object)
        for col, data in table.columns.items():
            if data.dtype == object or data.dtype.kind in "US":
                data = np.array([str(v) for v in data], dtype=h5py.string_dtype())
            sub.create_dataset(col, data=data, track_times=False)
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
    that has it; the file appears under its name only once complete).
    """

    def fill(h5: h5py.File) -> None:
        _put_attrs(
            h5, {"schema": schema, "schema_version": SCHEMA_VERSION, "software": _software()}
        )
        _put_attrs(h5, attrs or {})
        for name, value in sections.items():
            _store(h5, name, value)
        h5.attrs["complete"] = True

    return _write_h5(path, fill)


def _load(obj: h5py.HLObject, path: Path, depth: int = 0) -> Any:
    if depth > MAX_DEPTH:
        raise DataError(f"{path}: groups nested deeper than {MAX_DEPTH} (a cycle?)")
    if isinstance(obj, h5py.Dataset):
        _check_dataset(obj, path)
        if obj.dtype.kind == "O" or h5py.check_string_dtype(obj.dtype):
            return obj.asstr()[()]
        return obj[()]
    if not isinstance(obj, h5py.Group):
        raise DataError(f"{path}: {obj.name} is neither a group nor a dataset")
    out: dict[str, Any] = {k: _attr(obj, k, path=path) for k in obj.attrs}
    for key in obj:
        out[key] = _load(_member(obj, key, path, h5py.HLObject), path, depth + 1)
    return out


def read_results_h5(path: str | os.PathLike[str], *, schema: str = SCHEMA_RESULTS) -> dict:
    """Read a results file back as nested dicts of arrays and attributes."""
    path = Path(path)
    with _open_h5(path) as h5:
        _results_checked(h5, path, schema)
        return _load(h5, path)


def read_frf_from_results(path: str | os.PathLike[str], section: str) -> FRFSet:
    """The FRFSet stored in ``section`` of a results file."""
    path = Path(path)
    with _open_h5(path) as h5:
        if h5.get(section, getlink=True) is None:
            raise DataError(f"{path}: no section {section!r}")
        return read_frf_group(_member(h5, section, path, h5py.Group), str(path))


def results_complete(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a results file whose write finished (False for a
    missing, unreadable, corrupt or incomplete one)."""
    try:
        with _open_h5(Path(path)) as h5:
            return bool(_attr(h5, "complete", False, Path(path)))
    except (DataError, OSError, KeyError):
        return False


def completed_result_sha256(path: str | os.PathLike[str]) -> str | None:
    """The input hash (root attribute ``input_sha256``) of a complete results file.

    None when ``path`` is missing, unreadable, not complete (an interrupted
    write) or has no recorded hash. Used to skip inputs whose result exists.
    """
    path = Path(path)
    try:
        with _open_h5(path) as h5:
            if not _attr(h5, "complete", False, path):
                return None
            value = _attr(h5, "input_sha256", None, path)
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
        with _open_h5(path) as h5:
            frf = _member(h5, "frf", path, h5py.Group, required=False)
            details["configuration"] = (
                "" if frf is None else str(_attr(frf, "configuration", "", path))
            )
            modes = _member(h5, "modes", path, h5py.Group, required=False)
            if modes is not None and modes.get("fn_hz", getlink=True) is not None:
                details["fn_hz"] = np.asarray(
                    _member(modes, "fn_hz", path, h5py.Dataset)[()], dtype=float
                )
            inp = _member(h5, "input", path, h5py.Group, required=False)
            if inp is not None and "warnings" in inp.attrs:
                found = np.atleast_1d(_attr(inp, "warnings", path=path))
                details["warnings"] = [
                    w.decode() if isinstance(w, bytes) else str(w) for w in found
                ]
            ident = _member(h5, "identification", path, h5py.Group, required=False)
            if ident is not None and all(
                ident.get(k, getlink=True) is not None for k in ("frac", "error")
            ):
                details["frac"] = np.asarray(_member(ident, "frac", path, h5py.Dataset)[()])
                details["error"] = np.asarray(_member(ident, "error", path, h5py.Dataset)[()])
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


# --------------------------------------------------------------------------
# A one-file identification result read back as objects
# --------------------------------------------------------------------------

#: The dataclasses an identification result stores, by the ``kind`` attribute
#: :func:`write_results_h5` gives their groups.
_RESULT_KINDS: dict[str, type] = {
    cls.__name__: cls
    for cls in (IdentificationResult, ModalParameters, StabilizationData, SelectedPoles,
                ResolvedSettings, SelectionThresholds)
}


def _rebuilt(tree: Any, annotation: str, path: Path) -> Any:
    """A stored value as the field annotated ``annotation`` holds it: a group of a
    known ``kind`` as its dataclass, DOF arrays as DOFs, arrays as tuples."""
    if isinstance(tree, dict):
        cls = _RESULT_KINDS.get(str(tree.get("kind", "")))
        if cls is None:  # a plain mapping (extras)
            return {str(k): v for k, v in tree.items()}
        kwargs: dict[str, Any] = {}
        for f in fields(cls):
            if f.name in tree:
                kwargs[f.name] = value = _rebuilt(tree[f.name], str(f.type), path)
                wanted = _RESULT_KINDS.get(str(f.type).split(" ")[0])
                if wanted is not None and not isinstance(value, wanted):
                    raise DataError(f"{path}: {cls.__name__}.{f.name} is not a stored "
                                    f"{wanted.__name__}")
            elif f.default is MISSING and f.default_factory is MISSING:
                kwargs[f.name] = None  # stored as nothing: was None
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:
            raise DataError(f"{path}: the stored {cls.__name__} is malformed ({exc})") from exc
    if "DOF" in annotation:
        return _dofs_from(np.asarray(tree, dtype=np.int64))
    if annotation.startswith("tuple"):
        return tuple(np.asarray(tree).tolist())
    return tree


def read_identification_result(
    path: str | os.PathLike[str],
) -> tuple[FRFSet, IdentificationResult]:
    """The FRF set and the identification result of a one-file result
    (``<stem>_result.h5`` of ``identify`` and ``batch``), as identify returned
    them: everything a report page of the file draws (modes, shapes,
    stabilization diagram with the kept modes' start poles, fit) without
    identifying again. The FRF set's source is the input file the result was
    identified from. Sections: ``frf`` (:func:`write_frf_group`) and
    ``identification`` (the :class:`IdentificationResult` tree).

    Raises
    ------
    DataError : the file cannot be read, is incomplete, or lacks either section.

    Examples
    --------
    >>> import tempfile
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> frf = FRFSet(freq_hz=f, H=H)
    >>> result = identify(frf)
    >>> p = Path(tempfile.mkdtemp()) / "a_result.h5"
    >>> _ = write_results_h5({"frf": frf, "identification": result}, p)
    >>> frf2, back = read_identification_result(p)
    >>> np.allclose(back.fn_hz, result.fn_hz), back.modes.dofs == result.modes.dofs
    (True, True)
    >>> np.array_equal(back.stabilization.mode_pole, result.stabilization.mode_pole)
    True
    """
    path = Path(path)
    with _open_h5(path) as h5:
        _results_checked(h5, path, SCHEMA_RESULTS)
        group = _member(h5, "frf", path, h5py.Group)
        frf = read_frf_group(group, str(path))
        source = Provenance(path=_typed_attr(group, "source_path", "str", path, ""),
                            sha256=_typed_attr(group, "source_sha256", "str", path, ""))
        tree = _load(_member(h5, "identification", path, h5py.Group), path)
    result = _rebuilt(tree, "", path)
    if not isinstance(result, IdentificationResult):
        raise DataError(f"{path}: /identification is not an identification result "
                        f"(kind {tree.get('kind')!r})")
    return replace(frf, source=source), result
