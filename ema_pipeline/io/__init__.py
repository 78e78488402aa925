"""File formats: the project's HDF5 files, Universal File Format dataset 58, CSV
tables and the experiment description (TOML).

This is the only package that knows file layouts. Everything it writes goes to
a temporary file in the target folder first and is renamed into place when
complete (:func:`atomic_path`), so an interrupted run never leaves a
half-written result. Everything it reads is checked, and problems are raised as
:class:`~ema_pipeline.data.DataError` naming the file.

Modules: :mod:`.files` (hashes, atomic writes, several files replaced together,
outputs that are inputs refused, CSV), :mod:`.folders` (the
atomic results folder of ``run``), :mod:`.hdf5` (FRF files
and results stores), :mod:`.uff` (dataset 58 in and out, modes out as datasets
164/15/82/55), :mod:`.uff_format` (the dataset parser), :mod:`.uff_units` (unit
labels, dataset 164), :mod:`.experiment` (TOML), :mod:`.recording` (raw time
recordings: UFF-58 time records, TDMS, WAV, CSV, LVM, MAT), :mod:`.channel_sheet` (the
channel sheet of a roving test), :mod:`.hit_choice` (hits chosen by hand),
:mod:`.picks` (modes picked by hand: the picks file of ``identify --picks``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from ema_pipeline.data import (
    MAX_AXIS_HZ,
    MIN_DF_HZ,
    MIN_FRF_LINES,
    DataError,
    FRFSet,
    axis_is_uniform,
)
from ema_pipeline.io.files import (
    atomic_path,
    check_not_inputs,
    check_readable,
    disk_full_error,
    open_regular,
    read_csv,
    recover_interrupted,
    replace_together,
    same_file,
    sha256_file,
    write_bytes,
    write_csv,
    write_text,
)
from ema_pipeline.io.folders import (
    atomic_folder,
    partial_folder,
    pid_alive,
    remove_stale_partials,
    swap_in,
)
from ema_pipeline.io.hdf5 import (
    HDF5_SUFFIXES,
    SCHEMA_FRF,
    SCHEMA_RESULTS,
    SCHEMA_VERSION,
    completed_result_sha256,
    read_frf_from_results,
    read_frf_group,
    read_frf_h5,
    read_results_h5,
    result_details,
    results_complete,
    table_from_results,
    write_frf_group,
    write_frf_h5,
    write_results_h5,
)
from ema_pipeline.io.hdf5_access import MAX_DATASET_BYTES
from ema_pipeline.io.hdf5_check import check_hdf5
from ema_pipeline.io.hdf5_result import read_identification_result
from ema_pipeline.io.picks import picks_toml, read_picks, write_picks
from ema_pipeline.io.recording import (
    RECORDING_SUFFIXES,
    RawRecording,
    is_recording,
    read_raw_recording,
    read_recording,
    recording_from_raw,
)
from ema_pipeline.io.uff import (
    UFF_SUFFIXES,
    read_frf_uff,
    read_time_uff,
    read_uff,
    write_frf_uff,
    write_modes_uff,
    write_time_uff,
)
from ema_pipeline.io.uff_modes import read_modes_uff
from ema_pipeline.io.uff_units import parse_unit_label
from ema_pipeline.lazy import lazy_exports
from ema_pipeline.paths import FRF_FILE_KIND

if TYPE_CHECKING:
    from ema_pipeline.io.experiment import experiment_file_path, read_experiment
    from ema_pipeline.io.geometry import (
        geometry_from_table,
        read_geometry,
        read_geometry_uff,
        write_geometry_uff,
    )

#: Names of the experiment file's and the geometry's readers, imported on
#: first use (:func:`ema_pipeline.lazy.lazy_exports`): they load the channel sheet and the
#: acquisition stage, which identifying FRF files never needs (about 18 ms of
#: every ``identify`` command's start).
_LAZY = {"experiment_file_path": "experiment", "read_experiment": "experiment",
         "geometry_from_table": "geometry", "read_geometry": "geometry",
         "read_geometry_uff": "geometry", "write_geometry_uff": "geometry"}

#: Suffixes whose format is told by the file's first bytes (UFF or HDF5).
SNIFFED_SUFFIXES = {".frf"}
#: Every suffix ``batch`` takes as an FRF file (compared in lower case).
FRF_SUFFIXES = UFF_SUFFIXES | HDF5_SUFFIXES | SNIFFED_SUFFIXES


def frf_format(path: str | os.PathLike[str], *, checked: bool = False) -> str:
    """``"uff"`` or ``"h5"`` from the file name (any letter case), else from the
    first bytes (of a file checked first, :func:`check_readable`, unless
    ``checked``: the caller has checked it).

    Examples
    --------
    >>> frf_format("test.UFF"), frf_format("a.Unv"), frf_format("b.ufb"), frf_format("c.H5")
    ('uff', 'uff', 'uff', 'h5')
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in UFF_SUFFIXES:
        return "uff"
    if suffix in HDF5_SUFFIXES:
        return "h5"
    if not checked:
        check_readable(path, "an FRF file")
    with open_regular(path, "an FRF file") as fh:
        head = fh.read(8)
    if head.startswith(b"\x89HDF"):
        return "h5"
    if head.lstrip().startswith(b"-1"):
        return "uff"
    raise DataError(f"{path}: unknown FRF file format (expected UFF dataset 58 or HDF5)")


def read_frf(path: str | os.PathLike[str], *, min_lines: int = 2,
             checked: bool = False) -> FRFSet:
    """Read an FRF file: UFF dataset 58 (ASCII or binary) or the project's HDF5.

    ``min_lines``: refuse FRFs with fewer frequency lines; pass
    :data:`ema_pipeline.data.MIN_FRF_LINES` when the FRFs are to be identified.

    Anything but a non-empty regular file (a FIFO, a device, a folder, a
    symlink loop) is refused before it is opened, whatever its name
    (:func:`check_readable` with :data:`~ema_pipeline.paths.FRF_FILE_KIND`),
    once: ``checked`` says the caller has run that check already (the command
    line checks its inputs before it imports the readers).
    """
    path = Path(path)
    if not checked:
        check_readable(path, FRF_FILE_KIND)
    if is_recording(path):  # time data: the FRFs come from `ema-pipeline frf` first
        raise DataError(f"{path}: a raw recording (time data), not FRFs; make the FRFs "
                        f"first: ema-pipeline frf {path} --out {path.stem}.h5 (a roving "
                        "test of many files: ema-pipeline frf --channels SHEET.csv)")
    if frf_format(path, checked=True) == "uff":
        frf = read_frf_uff(path, min_lines=min_lines, checked=True)
    else:
        frf = read_frf_h5(path)
    if frf.freq_hz.size < min_lines:
        raise DataError(
            f"{path}: the FRFs have {frf.freq_hz.size} frequency lines; at least {min_lines} "
            "are needed for identification"
        )
    check_frequency_axis(frf.freq_hz, str(path))
    return frf



def check_frequency_axis(freq_hz: object, source: str = "") -> None:
    """Refuse an implausible frequency axis: not finite, negative, not strictly
    increasing, a spacing below :data:`MIN_DF_HZ` or lines above :data:`MAX_AXIS_HZ`.

    Examples
    --------
    >>> import numpy as np
    >>> check_frequency_axis(np.arange(8) * 1e-30, "x.uff")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: x.uff: implausible frequency axis: line spacing 1e-30 Hz ...
    """
    import numpy as np

    f = np.asarray(freq_hz, dtype=float)
    where = f"{source}: " if source else ""
    if f.size == 0 or not np.all(np.isfinite(f)) or f[0] < 0:
        raise DataError(f"{where}implausible frequency axis: values must be finite and >= 0")
    steps = np.diff(f)
    if steps.size and not np.all(steps > 0):
        raise DataError(f"{where}implausible frequency axis: not strictly increasing")
    if steps.size and steps.min() < MIN_DF_HZ:
        raise DataError(f"{where}implausible frequency axis: line spacing {steps.min():.3g} Hz "
                        f"(at least {MIN_DF_HZ:g} Hz expected)")
    if f[-1] > MAX_AXIS_HZ:
        raise DataError(f"{where}implausible frequency axis: lines up to {f[-1]:.3g} Hz "
                        f"(at most {MAX_AXIS_HZ:g} Hz expected)")


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
    """Every FRF file under ``folder`` (recursively), sorted.

    Suffixes, in any letter case (:data:`FRF_SUFFIXES`): .uff .unv .ufb .58
    .bunv .buf .uf (UFF), .h5 .hdf5 .hdf (HDF5) and .frf (either; told by
    content).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"{folder}: no such folder")
    return sorted(
        p
        for p in folder.rglob("*")
        if p.is_file() and p.suffix.lower() in FRF_SUFFIXES and not p.name.startswith(".")
    )


__all__ = [
    "FRF_SUFFIXES",
    "HDF5_SUFFIXES",
    "MIN_FRF_LINES",
    "MIN_DF_HZ",
    "MAX_AXIS_HZ",
    "SCHEMA_FRF",
    "SCHEMA_RESULTS",
    "SCHEMA_VERSION",
    "RECORDING_SUFFIXES",
    "RawRecording",
    "UFF_SUFFIXES",
    "MAX_DATASET_BYTES",
    "atomic_folder",
    "atomic_path",
    "axis_is_uniform",
    "check_hdf5",
    "check_not_inputs",
    "check_readable",
    "completed_result_sha256",
    "disk_full_error",
    "check_frequency_axis",
    "experiment_file_path",
    "find_frf_files",
    "frf_format",
    "frf_format_for_writing",
    "geometry_from_table",
    "open_regular",
    "parse_unit_label",
    "partial_folder",
    "picks_toml",
    "pid_alive",
    "read_csv",
    "read_experiment",
    "read_frf",
    "read_frf_from_results",
    "read_frf_group",
    "read_frf_h5",
    "read_frf_uff",
    "read_geometry",
    "read_geometry_uff",
    "read_modes_uff",
    "read_identification_result",
    "read_picks",
    "read_results_h5",
    "read_raw_recording",
    "read_recording",
    "recording_from_raw",
    "read_time_uff",
    "read_uff",
    "recover_interrupted",
    "remove_stale_partials",
    "replace_together",
    "result_details",
    "results_complete",
    "same_file",
    "sha256_file",
    "swap_in",
    "table_from_results",
    "write_bytes",
    "write_csv",
    "write_frf",
    "write_frf_group",
    "write_frf_h5",
    "write_frf_uff",
    "write_geometry_uff",
    "write_modes_uff",
    "write_picks",
    "write_results_h5",
    "write_text",
    "write_time_uff",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
