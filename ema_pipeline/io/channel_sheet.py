"""The channel sheet: which channel of which recording is the force or a response,
at which DOF, with which scale and unit (``ema-pipeline frf --channels``).

A CSV table with the header ``file,channel,role,node,direction,scale,unit`` and
one row per channel per recording file:

* ``file``: the recording (CSV, WAV, TDMS, UFF-58 time records), relative to the
  sheet's folder;
* ``channel``: the channel's name as in the file (any letter case; a CSV column
  without its unit, ``acc1`` for ``acc1 [g]``) or its **0-based** position
  (``0``, ``1``, ... or ``ch0``, as for ``--scale 0=500``);
* ``role``: ``force`` or ``response`` (exactly one force row per file);
* ``node``: the node number (an integer >= 1), ``direction``: ``+X`` ... ``-Z``;
* ``scale``: multiplies the stored numbers (blank: 1);
* ``unit``: the physical unit after scaling (``N``, ``g``, ``m/s^2``, ...;
  blank: the unit the file gives).

Channels of a file that no row names are not read. Lines starting with ``#`` are
comments. Every problem is one :class:`~ema_pipeline.data.DataError` naming the
sheet, the row (its line number) and the problem. The same rows may be given
inline in an experiment file (:func:`channel_sheet_from_rows`).
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ema_pipeline.data import DOF, DataError
from ema_pipeline.io.files import check_readable, open_regular, write_text
from ema_pipeline.validation import integer, nonzero

__all__ = ["SHEET_COLUMNS", "ChannelRow", "ChannelSheet", "channel_sheet_from_rows",
           "is_channel_sheet", "read_channel_sheet", "write_channel_sheet"]

#: The columns of a channel sheet, in this order.
SHEET_COLUMNS = ("file", "channel", "role", "node", "direction", "scale", "unit")
_ROLES = ("force", "response")
_AXES = {"X": 1, "Y": 2, "Z": 3}


@dataclass(frozen=True)
class ChannelRow:
    """One row of a channel sheet: ``file`` (resolved against the sheet's folder),
    ``channel`` (a name or 0-based position), ``role`` (force or response), ``dof``,
    ``scale`` (1.0: none), ``unit`` (``""``: the file's) and ``line`` (the row's line
    number in the sheet, 0 when given inline)."""

    file: Path
    channel: str
    role: str
    dof: DOF
    scale: float = 1.0
    unit: str = ""
    line: int = 0


@dataclass(frozen=True)
class ChannelSheet:
    """The rows of a channel sheet and where it came from (``source``: the sheet's
    path, or the experiment file for inline rows)."""

    rows: tuple[ChannelRow, ...]
    source: str = ""

    def files(self) -> list[Path]:
        """The recording files in the order the sheet first names them."""
        return list(dict.fromkeys(r.file for r in self.rows))

    def rows_of(self, file: Path) -> list[ChannelRow]:
        return [r for r in self.rows if r.file == file]

    def where(self, row: ChannelRow) -> str:
        """``SHEET, row N`` for messages."""
        return f"{self.source}, row {row.line}" if row.line else f"{self.source}, {row.file.name}"


def _direction(text: str) -> int:
    t = text.strip().upper()
    if len(t) == 1:
        t = "+" + t
    if len(t) != 2 or t[0] not in "+-" or t[1] not in _AXES:
        raise ValueError(f"direction must be +X, +Y, +Z, -X, -Y or -Z, got {text!r}")
    return (-1 if t[0] == "-" else 1) * _AXES[t[1]]


def _row(values: Mapping[str, object], folder: Path, line: int, where: str) -> ChannelRow:
    def text(key: str) -> str:
        v = values.get(key)
        return "" if v is None or (isinstance(v, float) and math.isnan(v)) else str(v).strip()

    try:
        file, channel, role = text("file"), text("channel"), text("role").lower()
        if not file:
            raise ValueError("file is blank")
        if not channel:
            raise ValueError("channel is blank (a name or a 0-based position)")
        if role not in _ROLES:
            raise ValueError(f"role must be force or response, got {text('role')!r}")
        node_text = text("node")
        for key in ("node", "direction"):
            if not text(key):
                raise ValueError(f"{key} is blank: give each channel's node and direction "
                                 "(e.g. 3 and -Z)")
        try:
            node = int(float(node_text))
            if node != float(node_text):
                raise ValueError
        except (ValueError, OverflowError):
            raise ValueError(f"node must be a whole number, got {node_text!r}") from None
        integer("node", node, at_least=1)
        direction = _direction(text("direction"))
        scale_text = text("scale")
        try:
            scale = float(scale_text) if scale_text else 1.0
        except ValueError:
            raise ValueError(f"scale must be a number, got {scale_text!r}") from None
        nonzero("scale", scale)
    except ValueError as exc:
        raise DataError(f"{where}: {exc}") from None
    return ChannelRow(file=folder / file, channel=channel, role=role,
                      dof=DOF(node, direction), scale=scale, unit=text("unit"), line=line)


def _checked(rows: list[ChannelRow], source: str) -> ChannelSheet:
    sheet = ChannelSheet(tuple(rows), source)
    if not rows:
        raise DataError(f"{source}: the channel sheet has no rows")
    for file in sheet.files():
        mine = sheet.rows_of(file)
        forces = [r for r in mine if r.role == "force"]
        if len(forces) != 1:
            what = "no force row" if not forces else \
                f"{len(forces)} force rows ({', '.join(sheet.where(r) for r in forces)})"
            raise DataError(f"{source}: {file.name} has {what}; each file needs exactly one")
        if len(mine) < 2:
            raise DataError(f"{sheet.where(mine[0])}: {file.name} has no response row")
        seen: dict[str, ChannelRow] = {}
        for r in mine:
            for key, what in ((r.channel.lower(), f"channel {r.channel!r}"),
                              (r.dof.label(), f"DOF {r.dof.label()}")):
                first = seen.get(key + what[:3])
                if first is not None:
                    raise DataError(f"{sheet.where(r)}: {what} of {file.name} is named twice "
                                    f"(also {sheet.where(first)})")
                seen[key + what[:3]] = r
    return sheet


def is_channel_sheet(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a ``.csv`` whose first line that is not a comment holds
    the columns of a channel sheet (any order, any letter case); read from its first
    64 KiB only.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "channels.csv"
    >>> _ = p.write_text("# my test\\nfile,channel,role,node,direction,scale,unit\\n")
    >>> is_channel_sheet(p), is_channel_sheet(p.with_name("other.csv"))
    (True, False)
    """
    path = Path(path)
    if path.suffix.lower() != ".csv":
        return False
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16).decode("utf-8-sig", errors="replace")
    except OSError:
        return False
    first = next((ln for ln in head.splitlines()
                  if ln.strip() and not ln.lstrip().startswith("#")), "")
    return {c.strip().lower() for c in first.split(",")} == set(SHEET_COLUMNS)


def read_channel_sheet(path: str | os.PathLike[str]) -> ChannelSheet:
    """Read and check a channel sheet (module docstring); ``file`` entries are
    resolved against the sheet's folder.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "channels.csv"
    >>> _ = p.write_text("file,channel,role,node,direction,scale,unit\\n"
    ...                  "p1.csv,force,force,1,-Z,,N\\np1.csv,acc,response,5,+Z,0.5,g\\n")
    >>> sheet = read_channel_sheet(p)
    >>> [(r.file.name, r.role, r.dof.label(), r.scale) for r in sheet.rows]
    [('p1.csv', 'force', '1-Z', 1.0), ('p1.csv', 'response', '5+Z', 0.5)]
    """
    path = Path(path)
    check_readable(path, "a channel sheet (CSV)")
    try:
        with open_regular(path, "a channel sheet (CSV)") as fh:
            text = fh.read().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(f"{path}: not a text CSV channel sheet ({exc.reason})") from None
    lines = [(k + 1, ln) for k, ln in enumerate(text.splitlines())
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise DataError(f"{path}: empty channel sheet; expected the header "
                        f"{','.join(SHEET_COLUMNS)}")
    reader = csv.reader([ln for _, ln in lines])
    header = [h.strip().lower() for h in next(reader)]
    missing = [c for c in SHEET_COLUMNS if c not in header]
    if missing:
        raise DataError(f"{path}: row {lines[0][0]}: missing column(s) {', '.join(missing)}; "
                        f"the header must be {','.join(SHEET_COLUMNS)}")
    rows = []
    for (number, _), cells in zip(lines[1:], reader, strict=True):
        where = f"{path}, row {number}"
        if len(cells) != len(header):
            raise DataError(f"{where}: {len(cells)} cells for {len(header)} columns")
        rows.append(_row(dict(zip(header, cells, strict=True)), path.parent, number, where))
    return _checked(rows, str(path))


def channel_sheet_from_rows(rows: Sequence[Mapping[str, object]], folder: str | os.PathLike[str],
                            source: str) -> ChannelSheet:
    """A channel sheet from rows given inline (e.g. the experiment file's
    ``[[recordings.channels]]`` tables), files relative to ``folder``; messages
    name ``source`` and the row's position (1-based).

    Examples
    --------
    >>> sheet = channel_sheet_from_rows(
    ...     [{"file": "a.csv", "channel": "0", "role": "force", "node": 1, "direction": "+Z"},
    ...      {"file": "a.csv", "channel": "1", "role": "response", "node": 2,
    ...       "direction": "+Z", "unit": "g"}], ".", "experiment.toml")
    >>> [r.dof.label() for r in sheet.rows]
    ['1+Z', '2+Z']
    """
    out = []
    for k, values in enumerate(rows, start=1):
        where = f"{source}: channel row {k}"
        if not isinstance(values, Mapping):
            raise DataError(f"{where}: must be a table with keys {', '.join(SHEET_COLUMNS)}")
        unknown = sorted(set(values) - set(SHEET_COLUMNS))
        if unknown:
            raise DataError(f"{where}: unknown key(s) {', '.join(unknown)}; known: "
                            f"{', '.join(SHEET_COLUMNS)}")
        out.append(_row(values, Path(folder), k, where))
    return _checked(out, source)


def write_channel_sheet(rows: Sequence[Mapping[str, object]], path: str | os.PathLike[str],
                        comment: str = "") -> Path:
    """Write a channel sheet (e.g. the template of ``init --recordings``): the rows'
    values in :data:`SHEET_COLUMNS` order after ``#`` comment lines ``comment``."""
    lines = [f"# {ln}" if ln else "#" for ln in comment.splitlines()]
    lines.append(",".join(SHEET_COLUMNS))
    for values in rows:
        cells = ["" if values.get(c) is None else str(values.get(c)) for c in SHEET_COLUMNS]
        lines.append(",".join(f'"{c}"' if ("," in c or '"' in c) else c for c in cells))
    return write_text("\n".join(lines) + "\n", path)
