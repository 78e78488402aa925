"""Raw channels (as a file or a SEP-005 structure holds them) into a checked
:class:`~ema_pipeline.data.Recording` in SI units.

The one place of the rules every recording reader shares (:func:`ema_pipeline.io.
read_recording` for UFF, TDMS, WAV and CSV, :func:`ema_pipeline.acquisition.from_sep005`):

* **Overrides.** ``units={CHANNEL: LABEL}`` replaces the unit a file gives (or
  supplies a missing one); ``scale={CHANNEL: FACTOR}`` multiplies the stored
  numbers first (e.g. a sensitivity: volts to newtons). ``CHANNEL`` is a channel
  name (any letter case) or its position, ``"0"`` or ``"ch0"``; a key naming no
  channel is an error.
* **Units.** A label is parsed by :func:`ema_pipeline.units.parse_unit_label`
  (``N``, ``kN``, ``lbf``, ``m/s^2``, ``g``, ``mm/s^2``, ``in/s^2``, ``m/s``,
  ``mm``, ...) and converted to SI. A missing or unknown unit, or one that is not
  a force, acceleration, velocity or displacement, is an error naming the channel:
  never silently SI.
* **Force channel.** :func:`force_channel_index`, the one rule of every path:
  ``force_channel=NAME`` chooses it (its unit must be a force); otherwise the one
  channel in a force unit; when several are, the one whose name contains
  ``force``. No force channel, or several without a way to choose, is an error.
  Other channels in force units are left out (logged). The force comes first in
  the recording, then the responses in their order.
* **Checks.** Every channel has the same sample rate (within 1e-9), between
  :data:`MIN_SAMPLE_RATE_HZ` (1 Hz) and :data:`MAX_SAMPLE_RATE_HZ` (2e7 Hz, so that
  the FRFs' lines stay within :data:`ema_pipeline.data.MAX_AXIS_HZ`): a time step of
  1e-300 s or 1e296 s is a damaged header or a time column in the wrong unit. Every
  channel has the same length, at least 2 samples, no NaN or inf; a ``scale`` that
  overflows the samples to inf is named as such.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import DOF, MAX_AXIS_HZ, Channel, DataError, Provenance, Recording
from ema_pipeline.units import Unit, is_blank_label, parse_unit_label

log = logging.getLogger("ema_pipeline.acquisition")

#: Lowest sample rate (Hz) of a recording: impact tests sample at hundreds of Hz at
#: least; below 1 Hz the time column is in the wrong unit or the header damaged.
MIN_SAMPLE_RATE_HZ = 1.0
#: Highest sample rate (Hz): twice the highest frequency line an FRF file may hold.
MAX_SAMPLE_RATE_HZ = 2 * MAX_AXIS_HZ


def check_sample_rate(rate_hz: float, where: str = "", what: str = "",
                      step_s: float | None = None) -> float:
    """``rate_hz`` when it lies between :data:`MIN_SAMPLE_RATE_HZ` and
    :data:`MAX_SAMPLE_RATE_HZ`, else a DataError naming ``where`` (the file) and
    ``what`` (the channel or header field) with the rate and its time step
    (``step_s`` when the rate came from one, else 1 / ``rate_hz``).

    Examples
    --------
    >>> check_sample_rate(1e300, "rec.csv", "time column")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: rec.csv: time column: time step 1e-300 s (sample rate 1e+300
    Hz) outside 1-2e+07 Hz: a damaged header or a time in the wrong unit?
    """
    rate = float(rate_hz)
    if not MIN_SAMPLE_RATE_HZ <= rate <= MAX_SAMPLE_RATE_HZ:  # NaN too
        if step_s is None:
            with np.errstate(divide="ignore"):
                step_s = float(np.divide(1.0, rate))
        label = f"{what}: " if what else ""
        raise DataError(f"{_prefix(where)}{label}time step {step_s:g} s (sample rate {rate:g} "
                        f"Hz) outside {MIN_SAMPLE_RATE_HZ:g}-{MAX_SAMPLE_RATE_HZ:g} Hz: a "
                        "damaged header or a time in the wrong unit?")
    return rate


@dataclass
class ChannelData:
    """One channel as read, before conversion: the stored numbers and what the
    source says about them.

    ``unit_label`` is the label the source gives (blank: none); ``unit``, when
    not ``None``, is the unit already resolved by the reader (e.g. from a UFF
    dataset 164) and wins over the label. ``full_scale`` is the input range in the
    stored numbers (``None``: unknown). ``force_hint`` marks a channel the source
    declares as a force (UFF data type 13) for the messages.
    """

    name: str
    data: np.ndarray
    sample_rate_hz: float
    unit_label: str = ""
    unit: Unit | None = None
    dof: DOF | None = None
    full_scale: float | None = None
    force_hint: bool = False


def rate_from_time(time_s: np.ndarray, where: str = "", what: str = "time vector") -> float:
    """Sample rate (Hz) of an equally spaced time vector; DataError when it is not
    (a sample deviating by more than a quarter step from the straight line), has
    fewer than 2 values or a step out of range (:func:`check_sample_rate`; ``what``
    names the vector there). Rounded to whole Hz when within 1e-4 of it (times
    printed with few digits).

    Examples
    --------
    >>> rate_from_time(np.round(np.arange(25600) / 25600.0, 6))  # 1 s, times in µs
    25600.0
    """
    t = np.asarray(time_s, dtype=float).ravel()
    prefix = f"{where}: " if where else ""
    if t.size < 2 or not np.all(np.isfinite(t)):
        raise DataError(f"{prefix}time vector needs at least 2 finite values")
    step = (t[-1] - t[0]) / (t.size - 1)
    if not step > 0:
        raise DataError(f"{prefix}time vector does not increase")
    with np.errstate(all="ignore"):
        check_sample_rate(1.0 / step, where, what, step_s=step)
        if np.max(np.abs(t - t[0] - step * np.arange(t.size))) > 0.25 * step:
            raise DataError(f"{prefix}time vector is not equally spaced (missing samples?)")
    return nice_rate(1.0 / step)


def nice_rate(rate_hz: float, rtol: float = 1e-4) -> float:
    """``rate_hz`` rounded to whole Hz when within ``rtol`` of it, else unchanged
    (a sample rate read back from a rounded time step).

    Examples
    --------
    >>> nice_rate(1 / 4.88281e-04), nice_rate(1000.5)
    (2048.0, 1000.5)
    """
    whole = float(np.round(rate_hz))
    return whole if whole > 0 and abs(whole - rate_hz) <= rtol * rate_hz else float(rate_hz)


def _prefix(where: str) -> str:
    return f"{where}: " if where else ""


def match_channel(key: str, names: Sequence[str], where: str = "", what: str = "channel") -> int:
    """Index of the channel ``key`` names: a name (any letter case) or a position
    ``"0"`` / ``"ch0"``. DataError naming ``where`` when none matches.

    Examples
    --------
    >>> match_channel("ch1", ["Force", "Acc"]), match_channel("force", ["Force", "Acc"])
    (1, 0)
    """
    wanted = str(key).strip()
    lowered = [n.strip().lower() for n in names]
    if wanted.lower() in lowered:
        return lowered.index(wanted.lower())
    digits = wanted[2:] if wanted.lower().startswith("ch") else wanted
    if digits.isdigit() and int(digits) < len(names):
        return int(digits)
    raise DataError(f"{_prefix(where)}{what} {wanted!r} names no channel; channels: "
                    f"{', '.join(repr(n) for n in names)} (or 0..{len(names) - 1}, ch0..)")


def _by_index(mapping: Mapping[str, object] | None, names: Sequence[str], where: str,
              what: str) -> dict[int, object]:
    out: dict[int, object] = {}
    for key, value in (mapping or {}).items():
        out[match_channel(key, names, where, what)] = value
    return out


def _unit(ch: ChannelData, label: str | None, where: str) -> Unit:
    if label is None and ch.unit is not None:
        return ch.unit
    text = ch.unit_label if label is None else str(label)
    if is_blank_label(text):
        raise DataError(f"{_prefix(where)}channel {ch.name!r} has no unit; give it "
                        "(units CHANNEL=UNIT, e.g. N, g, m/s^2)")
    try:
        unit = parse_unit_label(text)
    except ValueError as exc:
        raise DataError(f"{_prefix(where)}channel {ch.name!r}: unknown unit {text!r} ({exc}); "
                        "known: N, kN, lbf, m/s^2, g, mm/s^2, in/s^2, m/s, mm/s, m, mm, ...") \
            from None
    if unit.signal is None:
        raise DataError(f"{_prefix(where)}channel {ch.name!r}: unit {text!r} is not a force, "
                        "acceleration, velocity or displacement")
    return unit


def force_channel_index(names: Sequence[str], quantities: Sequence[str],
                        force_channel: str | None = None, where: str = "") -> int:
    """Index of the force channel among channels ``names`` of ``quantities``: the one
    rule of every path (a recording read from a file, a channel sheet's file, a
    :class:`~ema_pipeline.data.Recording` made in Python).

    1. ``force_channel`` (``--force-channel``, the experiment file's
       ``force_channel``, a channel sheet's force row) chooses it: a name (any
       letter case) or a position (``"0"``, ``"ch0"``); it must be a force.
    2. Otherwise the one channel that is a force (in a force unit: N, kN, lbf).
    3. When several are, the one whose name contains ``force``.

    No force channel, a named channel that is no force, or several force channels
    without a way to choose, is a DataError naming ``where``.

    Examples
    --------
    >>> force_channel_index(["acc", "hammer"], ["acceleration", "force"])
    1
    >>> force_channel_index(["Force", "reaction"], ["force", "force"])
    0
    >>> force_channel_index(["f1", "f2"], ["force", "force"], where="rec.csv")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: rec.csv: several force channels ('f1', 'f2'); choose one
    (force_channel / --force-channel, or the role column of a channel sheet)
    """
    names = list(names)
    if force_channel is not None:
        k = match_channel(force_channel, names, where, "force channel")
        if quantities[k] != "force":
            raise DataError(f"{_prefix(where)}force channel {names[k]!r} is in {quantities[k]} "
                            "units, not a force (N, kN, lbf)")
        return k
    forces = [k for k, kind in enumerate(quantities) if kind == "force"]
    if len(forces) > 1:
        named = [k for k in forces if "force" in names[k].lower()]
        if len(named) == 1:
            return named[0]
        raise DataError(f"{_prefix(where)}several force channels "
                        f"({', '.join(repr(names[k]) for k in forces)}); choose one "
                        "(force_channel / --force-channel, or the role column of a channel "
                        "sheet)")
    if not forces:
        listed = ", ".join(f"{n!r} ({kind})" for n, kind in zip(names, quantities, strict=True))
        raise DataError(f"{_prefix(where)}no force channel: none is in a force unit (N, kN, "
                        f"lbf); channels: {listed}. Without the hammer's force there are no "
                        "FRFs; if one of them is the hammer, give its unit (--unit NAME=N)")
    return forces[0]


def assemble_recording(
    channels: Sequence[ChannelData],
    *,
    where: str = "",
    force_channel: str | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
    segment_starts: Sequence[int] = (0,),
    source: Provenance | None = None,
) -> Recording:
    """A checked :class:`~ema_pipeline.data.Recording` in SI units from raw channels,
    by the rules of the module docstring.

    Parameters
    ----------
    channels : the channels as read (stored numbers, units, sample rates).
    where : the source (file path) for the messages.
    force_channel : name or position of the force channel (default: found by unit).
    scale : {CHANNEL: FACTOR} multiplying the stored numbers before unit conversion.
    units : {CHANNEL: LABEL} replacing the source's units.
    segment_starts : first sample of each pre-cut record (``(0,)``: continuous).
    source : provenance of the recording (default: ``where`` without hash).

    Returns
    -------
    Recording with the force first.

    Raises
    ------
    DataError
        One line naming ``where`` and the channel: missing or unknown unit, no
        force channel, different sample rates or lengths, NaN, no samples.

    Examples
    --------
    >>> ch = [ChannelData("acc", np.zeros(4), 100.0, "g"),
    ...       ChannelData("hammer", np.ones(4), 100.0, "kN")]
    >>> rec = assemble_recording(ch)
    >>> [c.name for c in rec.channels], float(rec.signals[0, 0])
    (['hammer', 'acc'], 1000.0)
    """
    if not channels:
        raise DataError(f"{_prefix(where)}no channels")
    names = [c.name for c in channels]
    factors = _by_index(scale, names, where, "scale")
    labels = _by_index(units, names, where, "units")
    si_units = [_unit(c, labels.get(k), where) for k, c in enumerate(channels)]  # type: ignore[arg-type]
    kinds = [u.signal or "" for u in si_units]
    rates = [float(c.sample_rate_hz) for c in channels]
    for c, fs in zip(channels, rates, strict=True):
        check_sample_rate(fs, where, f"channel {c.name!r}")
    if max(rates) - min(rates) > 1e-9 * max(rates):
        listed = ", ".join(f"{c.name!r} {fs:g} Hz" for c, fs in zip(channels, rates, strict=True))
        raise DataError(f"{_prefix(where)}channels have different sample rates ({listed}); "
                        "resample them to one rate first")
    lengths = [np.asarray(c.data).size for c in channels]
    if len(set(lengths)) != 1:
        listed = ", ".join(f"{c.name!r} {n}" for c, n in zip(channels, lengths, strict=True))
        raise DataError(f"{_prefix(where)}channels have different lengths ({listed} samples): "
                        "truncated file?")
    if lengths[0] < 2:
        raise DataError(f"{_prefix(where)}no samples (a recording needs at least 2)")
    force = force_channel_index(names, kinds, force_channel, where)
    order = [force] + [k for k in range(len(channels)) if k != force and kinds[k] != "force"]
    dropped = [names[k] for k in range(len(channels)) if k != force and kinds[k] == "force"]
    if dropped:
        log.warning("%sforce channels %s not used (the force is %r)", _prefix(where),
                    ", ".join(dropped), names[force])
    rows, out_channels = [], []
    for k in order:
        c, unit = channels[k], si_units[k]
        given = float(factors.get(k, 1.0))  # type: ignore[arg-type]
        factor = given * unit.factor
        stored = np.asarray(c.data).ravel()
        if not np.issubdtype(stored.dtype, np.number) or np.iscomplexobj(stored):
            kind = "complex" if np.iscomplexobj(stored) else f"non-numeric ({stored.dtype})"
            raise DataError(f"{_prefix(where)}channel {c.name!r} holds {kind} samples; a "
                            "recording needs real numbers")
        with np.errstate(all="ignore"):
            raw = stored.astype(float)
            data = raw * factor
        bad = ~np.isfinite(data)
        if bad.any():
            first = int(np.argmax(bad))
            at = f"first at sample {first}, t = {first / rates[k]:g} s"
            if np.isfinite(raw[first]) and np.isfinite(factor):
                raise DataError(
                    f"{_prefix(where)}channel {c.name!r}: scale {given:g} (x {unit.factor:g} "
                    f"to SI) overflows its samples to inf ({at}: {raw[first]:g} stored); "
                    "check the scale (--scale)")
            raise DataError(f"{_prefix(where)}channel {c.name!r} has NaN/inf samples ({at})")
        full = None if c.full_scale is None else abs(float(c.full_scale) * factor)
        rows.append(data)
        out_channels.append(Channel(c.name, kinds[k], c.dof, full))
    return Recording(
        signals=np.vstack(rows),
        sample_rate_hz=rates[0],
        channels=tuple(out_channels),
        segment_starts=tuple(segment_starts),
        source=source or Provenance(path=where),
    )
