"""SDyPy SEP-005 time series (a list of channel dicts) into a :class:`~ema_pipeline.data.Recording`.

SEP-005 (SDyPy enhancement proposal 5, checked by the ``sdypy-sep005`` package)
describes a measurement as a list of dicts, one per channel, with the keys
``data`` (1-D values), ``name``, ``unit_str`` (e.g. ``N``, ``kN``, ``m/s²``, ``g``)
and ``fs`` (Hz) or ``time`` (s, equally spaced); ``quantity`` (``f`` force, ``a``
acceleration, ``v`` velocity, ``d`` displacement), ``group`` and time stamps are
optional. Units follow the rules of :mod:`ema_pipeline.acquisition.channels`
(converted to SI, unknown units refused); a channel whose ``quantity`` disagrees
with its unit is an error.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ema_pipeline.acquisition.channels import ChannelData, assemble_recording, rate_from_time
from ema_pipeline.data import DataError, Recording
from ema_pipeline.units import parse_unit_label

#: SEP-005 ``quantity`` codes and the signal kind each means.
SEP005_QUANTITIES = {"f": "force", "a": "acceleration", "v": "velocity", "d": "displacement"}


def from_sep005(
    signals: Sequence[Mapping[str, Any]] | Mapping[str, Any],
    *,
    force_channel: str | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
) -> Recording:
    """A :class:`~ema_pipeline.data.Recording` (SI, force first) from SEP-005 channels.

    Parameters
    ----------
    signals : list of SEP-005 channel dicts (or one dict).
    force_channel, scale, units : as for :func:`ema_pipeline.io.read_recording`
        (channel names or positions).

    Raises
    ------
    DataError
        Missing keys, no ``fs``/``time``, unknown units, ``quantity`` against the
        unit, no force channel, different sample rates or lengths, NaN.

    Examples
    --------
    >>> fs = 1000.0
    >>> signals = [{"name": "hammer", "data": np.r_[0.0, 1.0, 0.0, 0.0], "unit_str": "kN",
    ...             "fs": fs, "quantity": "f"},
    ...            {"name": "acc", "data": np.zeros(4), "unit_str": "m/s²", "fs": fs}]
    >>> rec = from_sep005(signals)
    >>> rec.signals[0], rec.channels[1].quantity
    (array([   0., 1000.,    0.,    0.]), 'acceleration')
    """
    items = [signals] if isinstance(signals, Mapping) else list(signals)
    if not items:
        raise DataError("SEP-005: no channels")
    channels = []
    for k, item in enumerate(items):
        if not isinstance(item, Mapping):
            raise DataError(f"SEP-005: channel {k} is a {type(item).__name__}, not a dict")
        name = str(item.get("name", f"ch{k}"))
        where = f"SEP-005 channel {name!r}"
        missing = [key for key in ("data", "unit_str") if key not in item]
        if missing:
            raise DataError(f"{where}: missing {', '.join(missing)}")
        try:
            data = np.asarray(item["data"], dtype=float)
        except (TypeError, ValueError) as exc:
            raise DataError(f"{where}: data are not numbers ({exc})") from None
        if data.ndim != 1:
            raise DataError(f"{where}: data must be 1-D, got shape {data.shape}")
        if item.get("fs") is not None:
            fs = float(item["fs"])
        elif item.get("time") is not None:
            time = np.asarray(item["time"], dtype=float)
            if time.size != data.size:
                raise DataError(f"{where}: time ({time.size}) and data ({data.size}) lengths "
                                "differ")
            fs = rate_from_time(time, where)
        else:
            raise DataError(f"{where}: neither fs nor time given")
        unit_str = str(item["unit_str"])
        quantity = item.get("quantity")
        if quantity is not None and str(quantity).lower() in SEP005_QUANTITIES:
            try:
                signal = parse_unit_label(unit_str).signal
            except ValueError:
                signal = None  # reported with the channel by assemble_recording
            expected = SEP005_QUANTITIES[str(quantity).lower()]
            if signal is not None and signal != expected:
                raise DataError(f"{where}: quantity {quantity!r} ({expected}) but unit "
                                f"{unit_str!r} is {signal}")
        channels.append(ChannelData(name=name, data=data, sample_rate_hz=fs,
                                    unit_label=unit_str))
    return assemble_recording(channels, where="SEP-005", force_channel=force_channel,
                              scale=scale, units=units)
