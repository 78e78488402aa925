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

Each format's reader is a module of its own (:mod:`.recording_uff`,
:mod:`.recording_tdms`, :mod:`.recording_wav`, :mod:`.recording_csv`,
:mod:`.recording_lvm_mat`); each returns the raw channels
(:class:`~ema_pipeline.acquisition.channels.ChannelData`), read once
(:func:`read_raw_recording`), which :func:`recording_from_raw` turns into the
recording and :func:`recording_channels` lists.

Errors are one-line :class:`~ema_pipeline.data.DataError` naming the file: empty,
truncated or unparsable file, no force channel, different sample rates, NaN,
missing or unknown unit.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

from ema_pipeline.acquisition.channels import ChannelData, assemble_recording, match_channel
from ema_pipeline.data import DOF, DataError, Provenance, Recording
from ema_pipeline.io.files import check_readable, sha256_file
from ema_pipeline.io.recording_csv import has_time_column, read_csv_channels
from ema_pipeline.io.recording_lvm_mat import read_lvm_channels, read_mat_channels
from ema_pipeline.io.recording_tdms import read_tdms_channels
from ema_pipeline.io.recording_uff import UFF_FUNC_TIME, read_uff_channels
from ema_pipeline.io.recording_wav import (  # re-exported: their public home was here
    MAX_WAV_CHANNELS,
    read_wav_channels,
    require_wav_settings,
    wav_layout,
)
from ema_pipeline.io.uff import UFF_SUFFIXES

__all__ = [
    "MAX_WAV_CHANNELS",
    "RECORDING_ONLY_SUFFIXES",
    "RECORDING_SUFFIXES",
    "RawRecording",
    "is_recording",
    "read_raw_recording",
    "read_recording",
    "recording_channels",
    "recording_from_raw",
    "wav_layout",
]

#: Suffixes :func:`read_recording` reads (compared in lower case).
RECORDING_SUFFIXES = UFF_SUFFIXES | {".tdms", ".wav", ".csv", ".lvm", ".mat"}

_Reader = Callable[[Path], tuple[list[ChannelData], tuple[int, ...]]]
_READERS: dict[str, _Reader] = {".tdms": read_tdms_channels, ".wav": read_wav_channels,
                                ".csv": read_csv_channels, ".lvm": read_lvm_channels,
                                ".mat": read_mat_channels}


@dataclass(frozen=True)
class RawRecording:
    """A recording's channels as its file holds them, before any unit conversion or
    choice (:func:`read_raw_recording`): the ``path``, the ``channels``, the first
    sample of each segment (``segment_starts``) and the channels the reader
    ``skipped`` (a TDMS channel of text: not a signal)."""

    path: Path
    channels: list[ChannelData]
    segment_starts: tuple[int, ...]
    skipped: tuple[str, ...] = ()

    def unit_labels(self) -> dict[str, str]:
        """{channel name: the unit label the file gives} (``""``: none).

        Examples
        --------
        >>> import numpy as np
        >>> raw = RawRecording(Path("a.csv"), [ChannelData("f", np.zeros(2), 10.0, "kN")], (0,))
        >>> raw.unit_labels()
        {'f': 'kN'}
        """
        return {c.name: c.unit.label if c.unit is not None and c.unit.label else c.unit_label
                for c in self.channels}


def read_raw_recording(path: str | os.PathLike[str]) -> RawRecording:
    """Read the channels of a recording file once, as it holds them (the format by
    suffix: module docstring). Unknown suffix, unreadable or damaged file: a
    DataError naming the file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "hit.csv"
    >>> _ = p.write_text("time_s,force [N],acc\\n0,0,0\\n0.001,1,0\\n")
    >>> raw = read_raw_recording(p)
    >>> [c.name for c in raw.channels], raw.unit_labels()["force"], raw.segment_starts
    (['force', 'acc'], 'N', (0,))
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in UFF_SUFFIXES and suffix not in _READERS:
        raise DataError(f"{path}: unknown recording format {suffix or '(no suffix)'!r}; "
                        f"expected one of {', '.join(sorted(RECORDING_SUFFIXES))}")
    check_readable(path, "a recording (UFF, TDMS, WAV, CSV, LVM or MAT)")
    skipped: list[str] = []
    if suffix in UFF_SUFFIXES:
        found, starts = read_uff_channels(path)
    elif suffix == ".tdms":
        found, starts = read_tdms_channels(path, skipped)
    else:
        found, starts = _READERS[suffix](path)
    return RawRecording(path, found, starts, tuple(skipped))


def recording_from_raw(
    raw: RawRecording,
    *,
    force_channel: str | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
    channels: Mapping[str, DOF] | None = None,
) -> Recording:
    """The checked recording of the channels ``raw`` (arguments:
    :func:`read_recording`), in SI units, force first; its provenance has the
    file's sha256."""
    path, found = raw.path, raw.channels
    if channels is not None:
        names = [c.name for c in found]
        def name(key: str) -> str:  # positions refer to the file's channels
            return names[match_channel(key, names, str(path))]

        if force_channel is not None:  # named as the force rule names it
            force_channel = names[match_channel(force_channel, names, str(path),
                                                "force channel")]
        chosen = {match_channel(key, names, str(path)): dof for key, dof in channels.items()}
        found = [replace(found[k], dof=dof) for k, dof in chosen.items()]
        scale = None if scale is None else {name(k): v for k, v in scale.items()}
        units = None if units is None else {name(k): v for k, v in units.items()}
    if path.suffix.lower() == ".wav":
        require_wav_settings(path, found, scale, units)
    source = Provenance(path=str(path), sha256=sha256_file(path))
    recording = assemble_recording(found, where=str(path), force_channel=force_channel,
                                   scale=scale, units=units, segment_starts=raw.segment_starts,
                                   source=source)
    if raw.skipped and channels is None:  # a channel sheet reads the channels it names only
        recording = replace(recording, skipped=raw.skipped)
    return recording


def read_recording(
    path: str | os.PathLike[str],
    *,
    force_channel: str | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
    channels: Mapping[str, DOF] | None = None,
) -> Recording:
    """Read a raw impact recording (UFF-58 time records, TDMS, WAV, CSV, LVM or MAT) in
    SI units: :func:`read_raw_recording`, then :func:`recording_from_raw`.

    Parameters
    ----------
    path : the file; the format comes from its suffix (see the module docstring).
    force_channel : name or position (``"0"``, ``"ch0"``) of the force channel;
        default: the rule of
        :func:`~ema_pipeline.acquisition.channels.force_channel_index` (the one
        channel in a force unit: N, kN, lbf).
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
    return recording_from_raw(read_raw_recording(path), force_channel=force_channel,
                              scale=scale, units=units, channels=channels)


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
    raw = read_raw_recording(path)
    labels = raw.unit_labels()
    return [(c.name, labels[c.name], c.dof.label() if c.dof is not None else "")
            for c in raw.channels]


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
        return has_time_column(first)
    for k in range(1, len(lines) - 7):
        if lines[k - 1].strip() == "-1" and lines[k].split()[:1] in (["58"], ["58b"]):
            fields = lines[k + 6].split()
            return bool(fields) and fields[0] == str(UFF_FUNC_TIME)
    return False
