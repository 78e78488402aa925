"""CSV recordings (a time column, then one column per channel ``NAME [UNIT]``) as the
raw channels of a recording, for :func:`ema_pipeline.io.recording.read_recording`
(the rules: its module docstring); the time column's unit.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ema_pipeline.acquisition.channels import ChannelData, rate_from_time
from ema_pipeline.data import DataError
from ema_pipeline.io.uff_units import Unit, parse_unit_label

__all__ = ["has_time_column", "is_time_unit", "read_csv_channels", "split_header",
           "time_label"]

_TIME_DIMS = (0, 1, 0)
_HEADER_UNIT = re.compile(r"^(?P<name>.*?)\s*(?:\[(?P<u1>[^\]]*)\]|\((?P<u2>[^)]*)\))\s*$")
_TIME_SUFFIX = re.compile(r"^(?P<name>.*?)_(?P<unit>s|ms|us)$", re.IGNORECASE)


def time_label(name: str) -> str | None:
    """The unit label of a time column's header ``name`` (``time [s]``, ``t (ms)``,
    ``time_s``), None when it gives none.

    Examples
    --------
    >>> time_label("t (ms)"), time_label("time_s"), time_label("time")
    ('ms', 's', None)
    """
    m = _HEADER_UNIT.match(name)
    label = (m.group("u1") if m.group("u1") is not None else m.group("u2")) if m else None
    if label is None:
        ms = _TIME_SUFFIX.match(name)
        label = ms.group("unit") if ms else None
    return label


def is_time_unit(unit: Unit) -> bool:
    """Whether ``unit`` is a time (s, ms, us).

    Examples
    --------
    >>> is_time_unit(parse_unit_label("ms")), is_time_unit(parse_unit_label("N"))
    (True, False)
    """
    return unit.dims == _TIME_DIMS


def has_time_column(header: str) -> bool:
    """Whether the CSV header row ``header`` starts with a time column in a time unit
    (a recording's CSV rather than a table).

    Examples
    --------
    >>> has_time_column("time_s,force [N]"), has_time_column("mode,fn_hz")
    (True, False)
    """
    label = time_label(split_header(header)[1][0])
    try:
        unit = parse_unit_label(label) if label else None
    except ValueError:
        unit = None
    return unit is not None and is_time_unit(unit)


def split_header(line: str) -> tuple[str | None, list[str]]:
    """The delimiter (``;``, tab or ``,``; None: one field) and the fields of a CSV
    header row, stripped of blanks and quotes.

    Examples
    --------
    >>> split_header('"time_s";"force [N]"')
    (';', ['time_s', 'force [N]'])
    """
    for delim in (";", "\t", ","):
        if delim in line:
            return delim, [f.strip().strip('"').strip("'").strip() for f in line.split(delim)]
    return None, [line.strip()]


def read_csv_channels(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    """The channels of a CSV recording: a time column first, then one column per
    channel ``NAME [UNIT]``."""
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
    delim, fields = split_header(lines[first])
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
    t_label = time_label(time_name)
    if t_label is None:
        raise DataError(f"{path}: time column {time_name!r} has no unit; write "
                        "'time [s]' or 'time_s' (first column)")
    try:
        t_unit = parse_unit_label(t_label)
    except ValueError:
        t_unit = None
    if t_unit is None or not is_time_unit(t_unit):
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
