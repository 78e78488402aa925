"""Raw impact recordings (time data) in: UFF-58 time records, TDMS, WAV, CSV, LVM, MAT.

:func:`read_recording` picks the format by suffix and returns a checked
:class:`~ema_pipeline.data.Recording` in SI units, force first. The rules shared
by every format (unit conversion, ``scale`` and ``units`` overrides, choice of the
force channel, checks) are those of :mod:`ema_pipeline.acquisition.channels`;
what each format adds:

* **UFF** (``.uff``, ``.unv``, ... ASCII or binary): dataset 58 time records
  (function type 1), other function types ignored. A channel is a response DOF
  and signal kind; it is named ``<DOF> <kind>``, e.g. ``1+Z force``, ``2+Z
  acceleration``. The kind comes from the units (label, else the ordinate data
  type: 13/9 force, 12 acceleration, 11 velocity, 8 displacement, with dataset
  164), as for FRFs in :mod:`ema_pipeline.io.uff`; -X/-Y/-Z records are flipped.
  One record per channel is a continuous recording; several (load cases, or
  repeated records) are pre-cut records, ordered by load case, concatenated with
  ``segment_starts``; every channel must have as many, of equal lengths. The
  sample rate is 1 / abscissa increment (rounded to whole Hz within 1e-4: the
  header keeps 6 digits). Complex time records are refused; a file of ours with
  fewer time records than its ID line says (cut at a record boundary) is
  ``truncated``.
* **TDMS** (npTDMS): every channel of every group with numeric data; name
  ``<channel>`` (``<group>/<channel>`` when names repeat); unit from the property
  ``unit_string``, sample rate from ``wf_increment``. A channel whose unit is a
  time (``s``) is a time track: it gives the sample rate when ``wf_increment`` is
  absent and is not a signal; so is a channel of time stamps. A channel of text or
  booleans (a comment, a digital line) is no signal either: it is skipped, and the
  recording says which (``Recording.skipped``; ``frf`` warns); channel positions
  count the channels read. A file npTDMS reads only partly (truncated) is refused,
  and so is a channel that is empty or holds complex numbers (named), and a file
  with no numeric channel.
* **WAV** (scipy): channels are named ``0``, ``1``, ...; ``units`` are required
  for every channel (``0=N``, ``ch1=g``) and ``scale`` for every channel of
  integer samples (``0=0.5``); float samples are taken as stored, in the unit. Integer samples
  are read as fractions of full scale (int16 / 32768, int32 / 2^31, uint8
  (x - 128) / 128), float samples as stored; ``scale`` turns them into the unit
  (for integers the channel's full scale is ``scale``). The RIFF header is read
  first (:func:`wav_layout`): a header cut short, 0 or more than
  :data:`MAX_WAV_CHANNELS` channels, an inconsistent frame size, or a data chunk
  that declares more bytes than the file holds (``truncated``, with the numbers)
  is refused before any sample is decoded.
* **CSV** (``,``, ``;`` or tab separated; ``#`` comment lines before the header
  skipped): a header row, then one row per sample. The first column is the time,
  ``time [s]``, ``t (ms)`` or ``time_s`` / ``time_ms``; every other column is a
  channel ``NAME [UNIT]`` or ``NAME (UNIT)``, e.g. ``force [N],acc1 [g]``. A
  column without a unit needs ``units``. The time must be equally spaced (within
  a quarter step).

* **LVM** (LabVIEW measurement files, with ``lvm_read``, the ``lvm`` extra): channel
  names and units from the header (``Channel names``, ``Y_Unit_Label``), the sample
  rate from ``Delta_X``; one X column or none; several segments are pre-cut records.
* **MAT** (MATLAB v5, ``scipy.io.loadmat``; v7.3 is refused with a hint): the numeric
  vectors of equal length among the top-level variables or a struct's fields are
  the channels, named as stored; a vector ``time`` / ``t`` gives the sample rate
  (else a scalar ``fs``); a text ``units`` (``"s, m/s^2"``: the time's unit, then one
  for every channel or one each) gives the units.

Errors are one-line :class:`~ema_pipeline.data.DataError` naming the file: empty,
truncated or unparsable file, no force channel, different sample rates, NaN,
missing or unknown unit.
"""

from __future__ import annotations

import logging
import os
import re
import struct
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from ema_pipeline.acquisition.channels import (
    ChannelData,
    assemble_recording,
    check_sample_rate,
    match_channel,
    nice_rate,
    rate_from_time,
)
from ema_pipeline.data import DOF, DataError, Provenance, Recording
from ema_pipeline.io.files import check_readable, open_regular, sha256_file
from ema_pipeline.io.uff import (
    UFF_SUFFIXES,
    check_record_count,
    ordinate_unit,
    read_uff,
    response_dof,
)
from ema_pipeline.io.uff_format import Record58
from ema_pipeline.io.uff_units import FORCE_TYPES, Unit, parse_unit_label

log = logging.getLogger("ema_pipeline.io.recording")

#: Suffixes :func:`read_recording` reads (compared in lower case).
RECORDING_SUFFIXES = UFF_SUFFIXES | {".tdms", ".wav", ".csv", ".lvm", ".mat"}

_UFF_FUNC_TIME = 1
_TIME_DIMS = (0, 1, 0)


def read_recording(
    path: str | os.PathLike[str],
    *,
    force_channel: str | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
    channels: Mapping[str, DOF] | None = None,
) -> Recording:
    """Read a raw impact recording (UFF-58 time records, TDMS, WAV or CSV) in SI units.

    Parameters
    ----------
    path : the file; the format comes from its suffix (see the module docstring).
    force_channel : name or position (``"0"``, ``"ch0"``) of the force channel;
        default: the one channel in a force unit (N, kN, lbf).
    scale : {CHANNEL: FACTOR} multiplying the stored numbers (before unit
        conversion); required for WAV.
    units : {CHANNEL: UNIT} replacing or supplying the file's units; required for WAV.
    channels : {CHANNEL: DOF}: read only these channels (a channel sheet's rows),
        each at its DOF; ``None``: every channel, DOFs as the file gives them.

    Returns
    -------
    Recording : force first, then the responses; ``segment_starts`` marks pre-cut
    records (UFF).

    Raises
    ------
    DataError
        One line naming the file: empty, truncated or unparsable file, no force
        channel, different sample rates, NaN, missing or unknown unit.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "hit.csv"
    >>> _ = p.write_text("time_s,force [kN],acc [g]\\n0,0,0\\n0.001,0.2,0\\n0.002,0,1\\n")
    >>> rec = read_recording(p)
    >>> rec.sample_rate_hz, [c.quantity for c in rec.channels], rec.signals[:, 1:].tolist()
    (1000.0, ['force', 'acceleration'], [[200.0, 0.0], [0.0, 9.80665]])
    """
    path = Path(path)
    suffix = path.suffix.lower()
    readers = {".tdms": _read_tdms, ".wav": _read_wav, ".csv": _read_csv, ".lvm": _read_lvm,
               ".mat": _read_mat}
    if suffix in UFF_SUFFIXES:
        reader = _read_uff
    elif suffix in readers:
        reader = readers[suffix]
    else:
        raise DataError(f"{path}: unknown recording format {suffix or '(no suffix)'!r}; "
                        f"expected one of {', '.join(sorted(RECORDING_SUFFIXES))}")
    check_readable(path, "a recording (UFF, TDMS, WAV, CSV, LVM or MAT)")
    skipped: list[str] = []
    found, starts = _read_tdms(path, skipped) if reader is _read_tdms else reader(path)
    if channels is not None:
        names = [c.name for c in found]
        def name(key: str) -> str:  # positions refer to the file's channels
            return names[match_channel(key, names, str(path))]

        chosen = {match_channel(key, names, str(path)): dof for key, dof in channels.items()}
        found = [replace(found[k], dof=dof) for k, dof in chosen.items()]
        scale = None if scale is None else {name(k): v for k, v in scale.items()}
        units = None if units is None else {name(k): v for k, v in units.items()}
        force_channel = None if force_channel is None else name(force_channel)
    if suffix == ".wav":
        _require_wav_settings(path, found, scale, units)
    source = Provenance(path=str(path), sha256=sha256_file(path))
    recording = assemble_recording(found, where=str(path), force_channel=force_channel,
                                   scale=scale, units=units, segment_starts=starts, source=source)
    if skipped and channels is None:  # a channel sheet reads the channels it names only
        recording = replace(recording, skipped=tuple(skipped))
    return recording


def recording_channels(path: str | os.PathLike[str]) -> list[tuple[str, str, str]]:
    """The channels of a recording as the file holds them: (name, unit label, DOF
    label), ``""`` where the file does not say (WAV units, CSV columns without one,
    DOFs of anything but UFF); for a channel-sheet template (``init --recordings``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "hit.csv"
    >>> _ = p.write_text("time_s,force [N],acc\\n0,0,0\\n0.001,1,0\\n")
    >>> recording_channels(p)
    [('force', 'N', ''), ('acc', '', '')]
    """
    path = Path(path)
    suffix = path.suffix.lower()
    readers = {".tdms": _read_tdms, ".wav": _read_wav, ".csv": _read_csv, ".lvm": _read_lvm,
               ".mat": _read_mat}
    reader = _read_uff if suffix in UFF_SUFFIXES else readers.get(suffix)
    if reader is None:
        raise DataError(f"{path}: unknown recording format {suffix or '(no suffix)'!r}; "
                        f"expected one of {', '.join(sorted(RECORDING_SUFFIXES))}")
    check_readable(path, "a recording (UFF, TDMS, WAV, CSV, LVM or MAT)")
    found, _ = reader(path)
    return [(c.name, c.unit.label if c.unit is not None and c.unit.label else c.unit_label,
             c.dof.label() if c.dof is not None else "") for c in found]


#: Suffixes that are recordings whatever their content (a CSV is one when its header
#: starts with a time column; a UFF when its first dataset 58 is a time record).
RECORDING_ONLY_SUFFIXES = {".tdms", ".wav", ".lvm", ".mat"}
_SNIFF_BYTES = 1 << 16


def is_recording(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a raw recording rather than an FRF file (or neither), told
    from its suffix and first bytes only: ``.tdms`` and ``.wav`` are; a ``.csv`` is
    when its first column is a time (``time [s]``, ``t (ms)``, ``time_s``); a UFF
    (:data:`ema_pipeline.io.uff.UFF_SUFFIXES`) when its first dataset 58 in the first
    64 KiB has function type 1 (time response). An unreadable file is not.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "hit.csv"
    >>> _ = p.write_text("time_s,force [N],acc [g]\\n0,0,0\\n")
    >>> is_recording(p), is_recording(p.with_name("modes.csv"))
    (True, False)
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in RECORDING_ONLY_SUFFIXES:
        return True
    if suffix not in UFF_SUFFIXES | {".csv"}:
        return False
    try:
        with open(path, "rb") as fh:
            head = fh.read(_SNIFF_BYTES).decode("latin-1")
    except OSError:
        return False
    lines = head.splitlines()
    if suffix == ".csv":
        first = next((ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")), "")
        name = _split_header(first)[1][0]
        m = _HEADER_UNIT.match(name)
        label = (m.group("u1") if m.group("u1") is not None else m.group("u2")) if m else None
        if label is None:
            ms = _TIME_SUFFIX.match(name)
            label = ms.group("unit") if ms else None
        try:
            unit = parse_unit_label(label) if label else None
        except ValueError:
            unit = None
        return unit is not None and unit.dims == _TIME_DIMS
    for k in range(1, len(lines) - 7):
        if lines[k - 1].strip() == "-1" and lines[k].split()[:1] in (["58"], ["58b"]):
            fields = lines[k + 6].split()
            return bool(fields) and fields[0] == str(_UFF_FUNC_TIME)
    return False


# ------------------------------------------------------------------------ UFF
def _uff_rate(path: Path, rec: Record58) -> float:
    if rec.uniform:
        if not (np.isfinite(rec.dx) and rec.dx > 0):
            raise DataError(f"{path}: record {rec.record} ({rec.at}): abscissa increment "
                            f"{rec.dx} is not a time step")
        with np.errstate(all="ignore"):
            check_sample_rate(1.0 / rec.dx, str(path), f"record {rec.record} abscissa "
                              "increment", step_s=rec.dx)
        return nice_rate(1.0 / rec.dx)
    return rate_from_time(rec.x, f"{path}: record {rec.record}")


def _read_uff(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    contents = read_uff(path)
    if not contents.dataset_numbers:
        raise DataError(f"{path}: no UFF datasets found (not a Universal File, or empty)")
    records = [r for r in contents.records if r.func_type == _UFF_FUNC_TIME]
    if not records:
        found = sorted({r.func_type for r in contents.records})
        raise DataError(f"{path}: no time records (dataset 58, function type 1); function "
                        f"types found: {found or 'none (no dataset 58)'}")
    check_record_count(path, records)
    for rec in records:
        if np.iscomplexobj(rec.data):
            raise DataError(f"{path}: record {rec.record} ({rec.at}) holds complex values "
                            f"(ordinate data type {rec.ord_data_type}); time records are real")
    groups: dict[tuple[DOF, str], list[tuple[Record58, Unit | None, int]]] = {}
    for rec in records:
        dof, sign = response_dof(rec)
        try:
            unit: Unit | None = ordinate_unit(path, rec)
            kind = unit.signal or rec.numerator.units  # type: ignore[union-attr]
        except DataError:
            unit, kind = None, rec.numerator.units.strip() or "unknown"  # reported by channel
        groups.setdefault((dof, kind), []).append((rec, unit, sign))
    n_records = {len(v) for v in groups.values()}
    if len(n_records) != 1:
        listed = ", ".join(f"{d.label()} {k}: {len(v)}" for (d, k), v in groups.items())
        raise DataError(f"{path}: channels have different numbers of records ({listed}); "
                        "truncated file?")
    channels = []
    seg_lengths: list[int] | None = None
    for (dof, kind), recs in groups.items():
        if any(r.load_case for r, _, _ in recs):
            recs = sorted(recs, key=lambda item: item[0].load_case)
        rates = {_uff_rate(path, r) for r, _, _ in recs}
        if len(rates) != 1:
            raise DataError(f"{path}: channel {dof.label()} {kind} has records at different "
                            f"sample rates ({', '.join(f'{r:g}' for r in sorted(rates))} Hz)")
        lengths = [r.data.size for r, _, _ in recs]
        if seg_lengths is None:
            seg_lengths = lengths
        elif lengths != seg_lengths:
            raise DataError(f"{path}: records of channel {dof.label()} {kind} have "
                            f"{lengths} samples, others {seg_lengths}: truncated file?")
        data = np.concatenate([np.real(r.data).astype(float) * s for r, _, s in recs])
        first = recs[0][0]
        channels.append(ChannelData(
            name=f"{dof.label()} {kind}",
            data=data,
            sample_rate_hz=rates.pop(),
            unit_label=first.numerator.units,
            unit=recs[0][1],
            dof=dof,
            force_hint=first.numerator.data_type in FORCE_TYPES,
        ))
    starts = tuple(int(s) for s in np.cumsum([0] + (seg_lengths or [0])[:-1]))
    return channels, starts


# ----------------------------------------------------------------------- TDMS
@contextmanager
def _nptdms_log() -> Iterator[list[str]]:
    """Collect npTDMS's warnings (it prints them to stderr itself) for the caller."""
    from nptdms.log import log_manager  # type: ignore[import-untyped]

    messages: list[str] = []

    class _Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if record.levelno >= logging.WARNING:
                messages.append(record.getMessage())

    collect = _Collect()
    saved = {name: (lg.handlers[:], lg.propagate) for name, lg in log_manager.loggers.items()}
    for lg in log_manager.loggers.values():
        lg.handlers, lg.propagate = [collect], False
    try:
        yield messages
    finally:
        for name, (handlers, propagate) in saved.items():
            lg = log_manager.loggers[name]
            lg.handlers, lg.propagate = handlers, propagate


def _read_tdms(path: Path, skipped: list[str] | None = None
               ) -> tuple[list[ChannelData], tuple[int, ...]]:
    """The numeric channels of a TDMS file; the channels of text or booleans are
    left out, each said in ``skipped``."""
    try:
        from nptdms import TdmsFile  # type: ignore[import-untyped]
    except ImportError:  # pragma: no cover - a runtime dependency
        raise DataError(f"{path}: reading TDMS needs npTDMS (pip install npTDMS)") from None
    try:
        with _nptdms_log() as problems:
            tdms = TdmsFile.read(str(path))
            raw = [(g.name, c.name, dict(c.properties), np.asarray(c[:]))
                   for g in tdms.groups() for c in g.channels()]
    except Exception as exc:  # npTDMS raises many kinds on damaged files
        raise DataError(f"{path}: not a readable TDMS file ({type(exc).__name__}: {exc})") \
            from None
    bad = [m for m in problems if re.search(r"less data|not a multiple|incomplete", m)]
    if bad:
        raise DataError(f"{path}: truncated TDMS file ({bad[0]})")
    kept, left_out = [], []
    for group, name, props, data in raw:
        what = _not_samples(data)
        if what == "time stamps":  # a time track of absolute times: not a signal
            log.info("%s: channel %s/%s holds time stamps; not a signal", path, group, name)
        elif what is not None and what.startswith(("holds text", "holds booleans")):
            left_out.append(f"channel {f'{group}/{name}'!r} {what}")
        elif what is not None:
            raise DataError(f"{path}: channel {f'{group}/{name}'!r} {what}; a recording's "
                            "channels hold real numbers")
        else:
            kept.append((group, name, props, data))
    raw = kept
    if not raw:
        raise DataError(f"{path}: no numeric channels in the TDMS file"
                        + "".join(f"; {m}" for m in left_out))
    if skipped is not None:
        skipped += [f"{path}: {m}: skipped, not a signal" for m in left_out]
    names = [c for _, c, _, _ in raw]
    time_rate = None
    channels: list[tuple[str, np.ndarray, float, str]] = []
    for group, name, props, data in raw:
        label = str(props.get("unit_string", ""))
        full_name = f"{group}/{name}" if names.count(name) > 1 else name
        if label.strip():
            try:
                unit = parse_unit_label(label)
            except ValueError:
                unit = None
            if unit is not None and unit.dims == _TIME_DIMS:
                time_rate = rate_from_time(data * unit.factor, f"{path}: time track {name!r}")
                continue
        rate = np.nan
        if "wf_increment" in props:
            try:
                step = float(props["wf_increment"])
            except (TypeError, ValueError):
                step = np.nan
            if np.isfinite(step) and step > 0:
                with np.errstate(all="ignore"):
                    check_sample_rate(1.0 / step, str(path),
                                      f"channel {full_name!r} wf_increment", step_s=step)
                rate = nice_rate(1.0 / step)
        channels.append((full_name, data, rate, label))
    out = []
    for full_name, data, rate, label in channels:
        if not np.isfinite(rate):
            if time_rate is None:
                raise DataError(f"{path}: channel {full_name!r} has no valid wf_increment "
                                "(sample interval) and the file no time track")
            rate = time_rate
        out.append(ChannelData(name=full_name, data=data, sample_rate_hz=rate,
                               unit_label=label))
    return out, (0,)


def _not_samples(data: np.ndarray) -> str | None:
    """What a TDMS channel holds when it is not real samples (None: it is)."""
    if data.size == 0:
        return "is empty (no samples)"
    if np.issubdtype(data.dtype, np.datetime64):
        return "time stamps"
    if np.iscomplexobj(data):
        return f"holds complex numbers ({data.dtype})"
    if data.dtype == np.bool_ or not np.issubdtype(data.dtype, np.number):
        return f"holds {'booleans' if data.dtype == np.bool_ else 'text or objects'} " \
            f"({data.dtype})"
    return None


# ------------------------------------------------------------------------ WAV
#: Most channels a WAV recording may declare (a DAQ's 1024 channels; 65535 is a
#: damaged header).
MAX_WAV_CHANNELS = 1024


def wav_layout(path: str | os.PathLike[str]) -> tuple[int, int, int, int]:
    """(channels, sample rate in Hz, bytes per frame, frames) from the RIFF header of
    a WAV file, checked against the file before any sample is decoded: a DataError
    naming the file for a header cut short (``truncated WAV header``), no fmt or data
    chunk, 0 or more than :data:`MAX_WAV_CHANNELS` channels, a frame size that is not
    a whole number of bytes per channel, or a data chunk that declares more bytes
    than the file holds or not a whole number of frames (``truncated``, with the
    numbers). RIFF (little-endian), RIFX (big-endian) and RF64 (sizes in ``ds64``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from scipy.io import wavfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.wav"
    >>> wavfile.write(p, 2048, np.zeros((100, 2), dtype=np.int16))
    >>> wav_layout(p)
    (2, 2048, 4, 100)
    >>> _ = p.write_bytes(p.read_bytes()[:-40])  # 10 frames cut off
    >>> wav_layout(p)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: ...a.wav: truncated WAV file: the data chunk declares 400
    bytes (100 frames of 2 channels) but the file holds 360 (90 frames)
    """
    path = Path(path)
    with open_regular(path, "a WAV file") as fh:
        raw = fh.read()
    if len(raw) < 12:
        raise DataError(f"{path}: truncated WAV header: {len(raw)} bytes, the RIFF header "
                        "alone has 12")
    kind = raw[:4]
    if kind not in (b"RIFF", b"RIFX", b"RF64") or raw[8:12] != b"WAVE":
        raise DataError(f"{path}: not a WAV file (no RIFF/WAVE header)")
    endian = ">" if kind == b"RIFX" else "<"
    pos, fmt, big_data = 12, None, None
    while True:
        if pos + 8 > len(raw):
            missing = "fmt" if fmt is None else "data"
            raise DataError(f"{path}: truncated WAV header: the file ends at byte {len(raw)} "
                            f"before its {missing} chunk")
        cid = raw[pos:pos + 4]
        (size,) = struct.unpack(endian + "I", raw[pos + 4:pos + 8])
        body = pos + 8
        if cid == b"ds64" and size >= 16:
            if body + 16 > len(raw):
                raise DataError(f"{path}: truncated WAV header: ds64 chunk cut at byte "
                                f"{len(raw)}")
            big_data = struct.unpack("<Q", raw[body + 8:body + 16])[0]
        elif cid == b"fmt ":
            if size < 16 or body + 16 > len(raw):
                raise DataError(f"{path}: truncated WAV header: fmt chunk of "
                                f"{min(size, len(raw) - body)} bytes, at least 16 expected")
            _, channels, rate, _, align, bits = struct.unpack(endian + "HHIIHH",
                                                             raw[body:body + 16])
            if not 1 <= channels <= MAX_WAV_CHANNELS:
                raise DataError(f"{path}: WAV header declares {channels} channels (1 to "
                                f"{MAX_WAV_CHANNELS} expected): a damaged header")
            if align == 0 or align % channels or bits == 0:
                raise DataError(f"{path}: WAV header: frames of {align} bytes for {channels} "
                                f"channels of {bits} bits are not whole samples: a damaged "
                                "header")
            fmt = (channels, rate, align)
        elif cid == b"data":
            if fmt is None:
                raise DataError(f"{path}: WAV data chunk before its fmt chunk")
            channels, rate, align = fmt
            if kind == b"RF64" and size == 0xFFFFFFFF and big_data is not None:
                size = big_data
            held = len(raw) - body
            if size > held:
                raise DataError(
                    f"{path}: truncated WAV file: the data chunk declares {size} bytes "
                    f"({size // align} frames of {channels} channels) but the file holds "
                    f"{held} ({held // align} frames)")
            if size % align:
                raise DataError(f"{path}: WAV data chunk of {size} bytes is not a whole "
                                f"number of {align}-byte frames: truncated or damaged")
            if size == 0:
                raise DataError(f"{path}: WAV file holds no samples (empty data chunk)")
            return channels, rate, align, size // align
        pos = body + size + (size & 1)  # chunks are padded to even sizes



def _require_wav_settings(path: Path, channels: list[ChannelData],
                          scale: Mapping[str, float] | None,
                          units: Mapping[str, str] | None) -> None:
    """Every WAV channel needs a unit, and an integer one a scale (keys: name or
    position); float samples are taken as stored, in the unit."""
    names = [c.name for c in channels]
    for what, given in (("units", units), ("scale", scale)):
        covered = {match_channel(key, names, str(path), what) for key in (given or {})}
        missing = [n for k, n in enumerate(names) if k not in covered
                   and not (what == "scale" and channels[k].full_scale is None)]
        if missing:
            raise DataError(f"{path}: a WAV file holds no units: give {what} for channel(s) "
                            f"{', '.join(missing)} (e.g. --unit 0=N --unit 1=g --scale 0=500 "
                            "--scale 1=50)")


def _read_wav(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    from scipy.io import wavfile

    n_channels, header_rate, _, n_frames = wav_layout(path)  # refused before decoding
    check_sample_rate(header_rate, str(path), "WAV header")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", wavfile.WavFileWarning)
            rate, data = wavfile.read(path)
    except wavfile.WavFileWarning as exc:
        raise DataError(f"{path}: truncated or damaged WAV file ({exc})") from None
    except (ValueError, OSError, EOFError, IndexError, TypeError, struct.error,
            ZeroDivisionError) as exc:
        raise DataError(f"{path}: not a readable WAV file ({type(exc).__name__}: {exc})") \
            from None
    data = np.asarray(data)
    if data.ndim == 1:
        data = data[:, None]
    if data.shape != (n_frames, n_channels):
        raise DataError(f"{path}: WAV file decoded as {data.shape[0]} frames of "
                        f"{data.shape[1]} channels, its header says {n_frames} of {n_channels}")
    full: float | None = 1.0
    if data.dtype == np.uint8:
        values = (data.astype(float) - 128.0) / 128.0
    elif np.issubdtype(data.dtype, np.integer):
        values = data.astype(float) / float(2 ** (8 * data.dtype.itemsize - 1))
    else:
        values, full = data.astype(float), None
    channels = [ChannelData(name=str(k), data=values[:, k], sample_rate_hz=float(rate),
                            full_scale=full) for k in range(values.shape[1])]
    return channels, (0,)


# ------------------------------------------------------------------------ CSV
_HEADER_UNIT = re.compile(r"^(?P<name>.*?)\s*(?:\[(?P<u1>[^\]]*)\]|\((?P<u2>[^)]*)\))\s*$")
_TIME_SUFFIX = re.compile(r"^(?P<name>.*?)_(?P<unit>s|ms|us)$", re.IGNORECASE)


def _split_header(line: str) -> tuple[str | None, list[str]]:
    for delim in (";", "\t", ","):
        if delim in line:
            return delim, [f.strip().strip('"').strip("'").strip() for f in line.split(delim)]
    return None, [line.strip()]


def _read_csv(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        text = path.read_text(encoding="latin-1")
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror})") from None
    lines = text.splitlines()
    first = next((k for k, ln in enumerate(lines) if ln.strip() and not ln.lstrip()
                  .startswith("#")), None)
    if first is None:
        raise DataError(f"{path}: empty CSV file (no header row)")
    delim, fields = _split_header(lines[first])
    if len(fields) < 2:
        raise DataError(f"{path}: CSV header {lines[first][:80]!r} has fewer than 2 columns; "
                        "expected 'time_s,force [N],acc [g]' (',', ';' or tab separated)")
    body = [ln for ln in lines[first + 1:] if ln.strip()]
    if len(body) < 2:
        raise DataError(f"{path}: CSV file has fewer than 2 data rows")
    n_cols = len(fields)
    for k, ln in enumerate(body):  # our own words for a short row (a file cut short)
        cells = ln.split(delim) if delim else ln.split()
        if len(cells) != n_cols:
            what = ("truncated CSV file: its last row" if k == len(body) - 1
                    else f"CSV data row {k + 1}")
            raise DataError(f"{path}: {what} has {len(cells)} of the header's {n_cols} "
                            f"columns ({ln[:60]!r}); was the file cut short?")
    try:
        values = np.loadtxt(body, delimiter=delim, ndmin=2, dtype=float)
    except ValueError as exc:
        raise DataError(f"{path}: unparsable CSV data ({exc})") from None
    if values.shape[1] != len(fields):
        raise DataError(f"{path}: {values.shape[1]} data columns but {len(fields)} in the "
                        "header")
    time_name = fields[0]
    m = _HEADER_UNIT.match(time_name)
    t_label = (m.group("u1") if m.group("u1") is not None else m.group("u2")) if m else None
    if t_label is None:
        ms = _TIME_SUFFIX.match(time_name)
        t_label = ms.group("unit") if ms else None
    if t_label is None:
        raise DataError(f"{path}: time column {time_name!r} has no unit; write "
                        "'time [s]' or 'time_s' (first column)")
    try:
        t_unit = parse_unit_label(t_label)
    except ValueError:
        t_unit = None
    if t_unit is None or t_unit.dims != _TIME_DIMS:
        raise DataError(f"{path}: first column {time_name!r} must be the time in s or ms, "
                        f"got unit {t_label!r}")
    if not np.all(np.isfinite(values[:, 0])):
        raise DataError(f"{path}: time column has NaN/inf values")
    rate = rate_from_time(values[:, 0] * t_unit.factor, str(path),
                          f"time column {time_name!r}")
    channels = []
    for k, field in enumerate(fields[1:], start=1):
        m = _HEADER_UNIT.match(field)
        if m:
            name, label = m.group("name"), m.group("u1") if m.group("u1") is not None \
                else m.group("u2")
        else:
            name, label = field, ""
        channels.append(ChannelData(name=name or f"column {k + 1}", data=values[:, k],
                                    sample_rate_hz=rate, unit_label=label or ""))
    return channels, (0,)


# ------------------------------------------------------------------- LVM, MAT
def _read_lvm(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
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


def _read_mat(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
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
