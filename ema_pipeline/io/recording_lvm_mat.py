"""LabVIEW (``.lvm``, lvm_read) and MATLAB (``.mat`` v5, scipy) recordings as the raw
channels of a recording, for :func:`ema_pipeline.io.recording.read_recording` (the
rules: its module docstring).
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from ema_pipeline.acquisition.channels import (
    ChannelData,
    check_sample_rate,
    nice_rate,
    rate_from_time,
)
from ema_pipeline.data import DataError

__all__ = ["read_lvm_channels", "read_mat_channels"]

def read_lvm_channels(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    """LabVIEW measurement files (lvm_read): every segment's channels, names and
    units from the header (``Channel names``, ``Y_Unit_Label``), the sample rate from
    ``Delta_X``; several segments are pre-cut records (``segment_starts``)."""
    try:
        import lvm_read  # type: ignore[import-untyped]
    except ImportError:
        raise DataError(f"{path}: reading LabVIEW .lvm files needs lvm_read "
                        "(pip install lvm-read)") from None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            doc = lvm_read.read(str(path), read_from_pickle=False, dump_file=False)
    except Exception as exc:  # lvm_read raises anything on a damaged file
        raise DataError(f"{path}: not a readable LabVIEW LVM file ({type(exc).__name__}: "
                        f"{exc})") from None
    segments = [doc[k] for k in sorted(k for k in doc if isinstance(k, int))]
    if not segments:
        raise DataError(f"{path}: LVM file without data segments")
    x_columns = str(doc.get("X_Columns", "No"))
    if x_columns not in ("No", "One"):
        raise DataError(f"{path}: LVM with X_Columns = {x_columns!r} (a time column per "
                        "channel) is not read; save it with one or no X column")
    parts: list[list[ChannelData]] = []
    for seg in segments:
        n_ch = int(seg.get("Channels", 0))
        data = np.asarray(seg.get("data"), dtype=float)
        if data.ndim != 2 or data.shape[1] < n_ch or n_ch < 1:
            raise DataError(f"{path}: LVM segment of shape {data.shape} for {n_ch} channels")
        data = data[:, data.shape[1] - n_ch:]  # after the X column, if any
        names = [str(n) for n in seg.get("Channel names", [])][:n_ch]
        labels = [str(u) for u in seg.get("Y_Unit_Label", [])][:n_ch]
        steps = list(seg.get("Delta_X", []))[:n_ch]
        if len(names) < n_ch or len(steps) < n_ch:
            raise DataError(f"{path}: LVM header lists fewer channel names or Delta_X than "
                            f"its {n_ch} channels")
        part = []
        for k in range(n_ch):
            step = float(steps[k])
            rate = check_sample_rate(1.0 / step if step > 0 else float("nan"), str(path),
                                     f"channel {names[k]!r} Delta_X", step_s=step)
            part.append(ChannelData(name=names[k], data=data[:, k], sample_rate_hz=nice_rate(rate),
                                    unit_label=labels[k] if k < len(labels) else ""))
        parts.append(part)
    return _join_segments(path, parts)


def _join_segments(path: Path, parts: list[list[ChannelData]]
                   ) -> tuple[list[ChannelData], tuple[int, ...]]:
    """Segments with the same channels as one list of channels and their starts."""
    first = parts[0]
    starts, offset = [], 0
    for part in parts:
        if [c.name for c in part] != [c.name for c in first]:
            raise DataError(f"{path}: segments hold different channels")
        starts.append(offset)
        offset += part[0].data.size
    if len(parts) == 1:
        return first, (0,)
    joined = [replace(c, data=np.concatenate([p[k].data for p in parts]))
              for k, c in enumerate(first)]
    return joined, tuple(starts)


_MAT_TIME_NAMES = ("time", "t", "time_s", "timestamps")
_MAT_RATE_NAMES = ("fs", "sample_rate", "sample_rate_hz", "samplerate", "sr")


def read_mat_channels(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    """MATLAB v5 ``.mat`` files (scipy.io.loadmat): the numeric vectors of equal
    length among the top-level variables and the fields of structs; a vector named
    ``time`` / ``t`` gives the sample rate (else a scalar ``fs``); a text ``units``
    beside them gives the units (``"s, m/s^2"``: the time's, then one for every
    channel or one each)."""
    from scipy.io import loadmat

    try:
        doc = loadmat(str(path), squeeze_me=True, struct_as_record=False)
    except NotImplementedError:
        raise DataError(f"{path}: a MATLAB v7.3 file (HDF5); save it with -v7 or read it "
                        "as HDF5") from None
    except Exception as exc:  # scipy raises anything on a damaged file
        raise DataError(f"{path}: not a readable MATLAB .mat file ({type(exc).__name__}: "
                        f"{exc})") from None
    tables: list[tuple[str, dict]] = [("", {k: v for k, v in doc.items()
                                            if not k.startswith("__")})]
    for name, value in list(tables[0][1].items()):
        if hasattr(value, "_fieldnames"):
            tables.append((name, {f: getattr(value, f) for f in value._fieldnames}))
    best: tuple[str, dict] | None = None
    for name, table in tables:
        found = {k: np.asarray(v) for k, v in table.items()
                   if isinstance(v, np.ndarray) and v.ndim == 1 and v.size >= 2
                   and np.issubdtype(v.dtype, np.number)}
        if found and (best is None or len(found) > len(best[1]["__vectors__"])):
            best = (name, {**table, "__vectors__": found})
    if best is None:
        raise DataError(f"{path}: no numeric vectors (channels) in the .mat file")
    table = best[1]
    vectors: dict[str, np.ndarray] = table["__vectors__"]
    time_key = next((k for k in vectors if k.lower() in _MAT_TIME_NAMES), None)
    lengths = {v.size for k, v in vectors.items() if k != time_key}
    if len(lengths) != 1:
        raise DataError(f"{path}: the .mat vectors have different lengths "
                        f"({', '.join(f'{k} {v.size}' for k, v in vectors.items())})")
    if time_key is not None:
        rate = rate_from_time(vectors[time_key], str(path), f"time vector {time_key!r}")
    else:
        fs = next((table[k] for k in table if str(k).lower() in _MAT_RATE_NAMES), None)
        if fs is None or np.ndim(fs) != 0:
            raise DataError(f"{path}: no time vector (time, t) nor sample rate (fs) in the "
                            ".mat file")
        rate = check_sample_rate(float(fs), str(path), "fs")
    names = [k for k in vectors if k != time_key]
    units_text = next((str(v) for k, v in table.items() if str(k).lower() == "units"
                       and isinstance(v, str)), "")
    units = [u.strip() for u in units_text.split(",")] if units_text else []
    if time_key is not None and units:
        units = units[1:]  # the time's first
    if len(units) == 1:
        units = units * len(names)
    labels = units if len(units) == len(names) else [""] * len(names)
    channels = [ChannelData(name=n, data=vectors[n].astype(float), sample_rate_hz=rate,
                            unit_label=u) for n, u in zip(names, labels, strict=True)]
    return channels, (0,)
