"""Whether libhdf5 can read a file safely: the check in a child process.

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

The child is forked through :func:`ema_pipeline.runner.checked_fork`, which
applies the package's one fork-safety rule at the moment of the fork.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py

from ema_pipeline.data import DataError
from ema_pipeline.io.files import open_regular
from ema_pipeline.io.hdf5_access import (
    MAX_DATASET_BYTES,
    MAX_DEPTH,
    MAX_OBJECTS,
    attr,
    check_dataset,
    member,
)
from ema_pipeline.paths import refuse_unusable
from ema_pipeline.runner import checked_fork

__all__ = ["CHILD_READ_RATE", "CHILD_START_S", "CHILD_TIMEOUT_S", "check_hdf5", "open_checked",
           "walk_hdf5"]

#: The child check of a file may take CHILD_TIMEOUT_S + size / CHILD_READ_RATE seconds,
#: and CHILD_START_S more when it is a fresh interpreter (threads in this process rule
#: out a fork): its start-up alone took more than 5 s on a 2-core machine at load 8,
#: and a valid file must not fail on a busy machine.
CHILD_TIMEOUT_S, CHILD_READ_RATE, CHILD_START_S = 5.0, 10e6, 30.0
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_EXIT_OK, _EXIT_DATA, _EXIT_OTHER = 0, 3, 4


def _checked_size(path: Path) -> int:
    """The size of ``path`` from its open descriptor, once it is a non-empty
    regular file with an HDF5 superblock (at 0, 512, 1024, 2048, ... bytes)."""
    kind = "an HDF5 file"
    with open_regular(path, kind) as fh:
        st = os.fstat(fh.fileno())
        refuse_unusable(path, st, kind)
        offset = 0
        while offset + 8 <= st.st_size:
            fh.seek(offset)
            if fh.read(8) == _HDF5_SIGNATURE:
                return st.st_size
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
            attr(group, key, path=path)
        for name in group:
            count += 1
            if count > MAX_OBJECTS:
                raise DataError(f"{path}: more than {MAX_OBJECTS} objects")
            link = group.get(name, getlink=True)
            if not isinstance(link, h5py.HardLink):
                member(group, name, path, object)  # raises the link message
            obj = group[name]
            if isinstance(obj, h5py.Group):
                visit(obj, depth + 1)
            elif isinstance(obj, h5py.Dataset):
                check_dataset(obj, path, max_bytes)
                for key in obj.attrs:
                    attr(obj, key, path=path)
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


def _fork_check(path: Path, timeout_s: float) -> tuple[str, str] | None:
    """Run :func:`walk_hdf5` in a forked child; ``(status, message)`` with status
    "ok", "data" (a DataError), "other", "signal" or "timeout"; None when the
    fork-safety rule refused the fork (:func:`ema_pipeline.runner.checked_fork`)."""
    read_end, write_end = os.pipe()
    pid = checked_fork()
    if pid is None:
        os.close(read_end)
        os.close(write_end)
        return None
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
    "from ema_pipeline.io.hdf5_check import walk_hdf5\n"
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
    size = _checked_size(path)
    default = timeout_s is None
    timeout_s = _child_timeout(size) if timeout_s is None else timeout_s
    found = _fork_check(path, timeout_s)
    if found is None:  # threads running: a fresh interpreter instead
        timeout_s += CHILD_START_S if default else 0.0
        found = _spawn_check(path, timeout_s)
    status, message = found
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


def open_checked(path: Path) -> h5py.File:
    """Open an input HDF5 file read-only, after :func:`check_hdf5`."""
    check_hdf5(path)
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise DataError(f"{path}: not a readable HDF5 file (truncated or corrupt: {exc})") from exc
