"""TDMS files (npTDMS) as the raw channels of a recording, for
:func:`ema_pipeline.io.recording.read_recording` (the rules: its module docstring).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ema_pipeline.acquisition.channels import (
    ChannelData,
    check_sample_rate,
    nice_rate,
    rate_from_time,
)
from ema_pipeline.data import DataError
from ema_pipeline.io.recording_csv import is_time_unit
from ema_pipeline.io.uff_units import parse_unit_label

__all__ = ["read_tdms_channels"]

log = logging.getLogger("ema_pipeline.io.recording")


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


def read_tdms_channels(path: Path, skipped: list[str] | None = None
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
            if unit is not None and is_time_unit(unit):
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
