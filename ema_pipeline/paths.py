"""Checks on input paths before anything is opened, light enough for start-up.

:func:`check_readable` refuses anything but a non-empty regular file from its
``stat`` alone, with a message naming the file and what it is instead: a
missing file, a dangling symlink, a symlink loop, a folder, a FIFO, a device, a
socket. It lives here rather than in :mod:`ema_pipeline.io` so that the command
line can refuse a missing input right after start-up, before it imports the
readers (pandas, h5py and the identification chain).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from ema_pipeline.data import DataError

__all__ = ["DEFAULT_RAW_FOLDER", "FRF_FILE_KIND", "check_readable", "not_regular",
           "refuse_unusable"]

#: What an FRF input must be, as error messages say it.
FRF_FILE_KIND = "an FRF file (UFF or HDF5)"

#: The folder of the experiment file and its inputs that ``ema-pipeline run`` reads
#: by default (``--raw``), as the repository ships the example study and as
#: ``ema-pipeline init DIR --example`` writes it into DIR.
DEFAULT_RAW_FOLDER = "raw_frf"


def not_regular(mode: int) -> str | None:
    """What a non-regular file is, for messages (None for a regular file)."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def check_readable(path: str | os.PathLike[str], kind: str) -> os.stat_result:
    """Raise a DataError naming ``path`` unless it is a non-empty regular file.

    Nothing is opened: a FIFO, a device, a folder, a symlink loop or a dangling
    symlink is refused from its ``stat`` alone. ``kind`` says what the file
    should be, for the message. Returns the ``stat`` result.

    Examples
    --------
    >>> check_readable("/dev/zero", "an FRF file")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: /dev/zero: is a device, expected an FRF file
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            raise DataError(f"{path}: broken symbolic link (its target does not exist)") from None
        raise DataError(f"{path}: no such file") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise DataError(f"{path}: symbolic link loop, expected {kind}") from None
        raise DataError(f"{path}: cannot access ({exc.strerror})") from None
    refuse_unusable(path, st, kind)
    return st


def refuse_unusable(path: str | os.PathLike[str], st: os.stat_result, kind: str) -> None:
    """Raise a DataError naming ``path`` unless ``st`` (its ``stat`` or the
    ``fstat`` of its open descriptor) is that of a non-empty regular file;
    ``kind`` says what the file should be, for the message.

    Examples
    --------
    >>> refuse_unusable("x.h5", os.stat("/"), "an HDF5 file")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: x.h5: is a folder, expected an HDF5 file
    """
    what = not_regular(st.st_mode)
    if what is not None:
        raise DataError(f"{path}: is {what}, expected {kind}")
    if st.st_size == 0:
        raise DataError(f"{path}: empty file, expected {kind}")
