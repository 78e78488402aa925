"""Low-level Universal File reader: datasets 58 / 58b, 164 and 151; others skipped.

Our own parser, not pyuff's reader, because pyuff (2.5) fails on files that
real instruments and tools write:

* it reads a binary 58b record with uneven abscissa and double-precision
  ordinate as all-double, although the specification stores the abscissa as
  single precision (Addendum B: "the abscissa is always real single
  precision"), so the values come out wrong without an error;
* it keeps the padding values of the last data line (``1602 of 1600``);
* it decodes header text as UTF-8 with replacement, losing a Latin-1 ``²``;
* it raises bare ``Exception`` for text such as ``inf`` in unused header fields
  and drops a truncated last record silently.

What this parser accepts, as real files do: delimiter lines ``    -1`` padded
with blanks (to 80 columns or not), CRLF or LF line ends (also mixed), header
text in UTF-8 or any 8-bit code page (decoded as UTF-8, else CP-1252, else
Latin-1), Fortran ``D`` exponents and 3-digit exponents, text in header fields
the FRF does not need (function id, version, load case, Z-axis value, the
Z-axis record), value columns that drift from the fixed widths (values are
split at blanks; the fixed widths of the specification are the fallback when
values touch), padding values on the last data line, and in 58b: both byte
orders (field 3 of the header line: 1 little-endian, 2 big-endian), 4- and
8-byte values, and an extra CR or LF between the binary block and the
closing delimiter.

Every problem is a :class:`~ema_pipeline.data.DataError` naming the file, the
record (1-based position of the dataset in the file), its dataset number and
first line, and the reason.
"""

from __future__ import annotations

import logging
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ema_pipeline.data import DataError
from ema_pipeline.io.uff_units import SI, UNIT_SYSTEMS, UnitSystem

log = logging.getLogger("ema_pipeline.io.uff")

_DELIM = re.compile(rb"(?m)^[ \t]{0,6}-1[ \t]*\r?$")
#: the end of a delimiter line: the literal "-1" leads, which re finds fast
_DELIM_END = re.compile(rb"(?m)-1[ \t]*\r?$")
_BIN_CLOSE = re.compile(rb"[ \t\r\n\x00]*-1[ \t]*(?:\r?\n|\Z)")
_NUMBER_LINE = re.compile(rb"^[ \t]*(\d+)([bB]?)\b")


@dataclass(frozen=True)
class AxisInfo:
    """Record 8, 9, 10 or 11 of dataset 58: data characteristics of one axis."""

    data_type: int = 0
    length_exp: int = 0
    force_exp: int = 0
    label: str = ""
    units: str = ""


@dataclass
class Record58:
    """One dataset 58 (function at nodal DOF), values as stored in the file.

    ``record`` is the 1-based position of the dataset in the file, ``line``
    its first line; ``units`` the dataset 164 in force (the last one before it).
    """

    record: int
    line: int
    binary: bool
    ids: tuple[str, str, str, str, str]
    func_type: int
    load_case: int
    rsp_name: str
    rsp_node: int
    rsp_dir: int
    ref_name: str
    ref_node: int
    ref_dir: int
    ord_data_type: int
    n_values: int
    uniform: bool
    x0: float
    dx: float
    abscissa: AxisInfo
    numerator: AxisInfo
    denominator: AxisInfo
    x: np.ndarray
    data: np.ndarray
    units: UnitSystem = SI

    @property
    def at(self) -> str:
        """Where the record is: ``dataset 58 at line 1203``."""
        return f"dataset 58{'b' if self.binary else ''} at line {self.line}"


@dataclass
class UffContents:
    """What :func:`read_uff_file` found: the dataset-58 records, the dataset-151
    header (model name, description, program) and the skipped datasets."""

    path: Path
    records: list[Record58] = field(default_factory=list)
    header: dict[str, str] = field(default_factory=dict)
    dataset_numbers: list[int] = field(default_factory=list)
    unit_systems: list[UnitSystem] = field(default_factory=list)
    #: Geometry datasets (15, 2411 nodes; 82 trace lines) as ``(number, body,
    #: unit system in force, where)`` for :mod:`ema_pipeline.io.geometry`.
    geometry_blocks: list[tuple[int, bytes, UnitSystem, str]] = field(default_factory=list)

    @property
    def skipped(self) -> dict[int, int]:
        """{dataset number: count} of the datasets not read (not 58, 164, 151, geometry)."""
        return dict(Counter(n for n in self.dataset_numbers
                           if n not in (58, 151, 164, *GEOMETRY_DATASETS)))


#: Datasets whose text :func:`read_uff_file` keeps for the geometry reader.
GEOMETRY_DATASETS = (15, 82, 2411)


def _decode(raw: bytes) -> str:
    for enc in ("utf-8", "cp1252"):
        try:
            return raw.decode(enc)
        except UnicodeDecodeError:
            continue
    return raw.decode("latin-1")


def _int(text: str, default: int | None = None) -> int | None:
    try:
        return int(text.strip())
    except ValueError:
        try:
            value = float(text.strip().replace("D", "E").replace("d", "e"))
        except ValueError:
            return default
        return int(value) if np.isfinite(value) and value == int(value) else default


def _float(text: str, default: float | None = None) -> float | None:
    try:
        return float(text.strip().replace("D", "E").replace("d", "e"))
    except ValueError:
        return default


def read_uff_file(path: Path) -> UffContents:
    """Split a Universal File into datasets and parse 58/58b, 164 and 151.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    UffContents

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "u.uff"
    >>> _ = p.write_text("    -1\\n   164\\n         1SI\\n 1.0 1.0 1.0\\n 273.15\\n    -1\\n")
    >>> c = read_uff_file(p)
    >>> c.dataset_numbers, c.unit_systems[0].length_factor
    ([164], 1.0)
    """
    raw = path.read_bytes()
    contents = UffContents(path=path)
    units = SI
    pos = 0
    n_record = 0
    while True:
        m = find_delimiter(raw, pos)
        if m is None:
            rest = raw[pos:].strip(b" \t\r\n\x00\x1a")
            if rest and n_record == 0:
                break
            if rest:
                line = raw.count(b"\n", 0, pos) + 1
                raise DataError(
                    f"{path}: unexpected text after the last dataset (line {line}); "
                    "truncated or corrupt Universal File"
                )
            break
        if n_record == 0 and raw[: m.start()].strip():
            # text before the first delimiter: not a Universal File
            break
        head_start = _next_line(raw, m.end())
        if head_start >= len(raw):
            break  # a lone trailing delimiter
        head_end = _line_end(raw, head_start)
        head = raw[head_start:head_end]
        number = _NUMBER_LINE.match(head)
        n_record += 1
        line_no = raw.count(b"\n", 0, head_start) + 1
        if number is None:
            raise DataError(
                f"{path}: record {n_record} (at line {line_no}): no dataset number after the "
                f"-1 delimiter (found {_decode(head.strip()[:20])!r}); corrupt Universal File"
            )
        dataset = int(number.group(1))
        binary = bool(number.group(2))
        contents.dataset_numbers.append(dataset)
        where = (f"{path}: record {n_record} (dataset {dataset}{'b' if binary else ''} "
                 f"at line {line_no})")
        if binary:
            if dataset != 58:
                raise DataError(f"{where}: binary datasets other than 58b are not supported")
            record, pos = _read_58b(raw, head_start, head, where)
        else:
            close = find_delimiter(raw, _next_line(raw, head_start))
            if close is None:
                raise DataError(
                    f"{where}: truncated Universal File: the dataset has no closing -1 delimiter"
                )
            body = raw[_next_line(raw, head_start) : close.start()]
            pos = close.end()
            record = None
            if dataset == 58:
                record = _read_58_ascii(body, where)
            elif dataset == 164:
                units = _read_164(body, where)
                contents.unit_systems.append(units)
            elif dataset == 151:
                contents.header = _read_151(body)
            elif dataset in GEOMETRY_DATASETS:
                contents.geometry_blocks.append((dataset, body, units, where))
        if record is not None:
            record.record, record.line, record.units = n_record, line_no, units
            contents.records.append(record)
    if contents.skipped:
        text = ", ".join(f"{n} (x{c})" if c > 1 else str(n) for n, c in contents.skipped.items())
        log.info("%s: skipped datasets not needed for FRFs: %s", path, text)
    return contents


def find_delimiter(raw: bytes, pos: int) -> re.Match[bytes] | None:
    """The first ``-1`` delimiter line of a Universal File at or after ``pos``:
    ``_DELIM.search(raw, pos)``, found faster. That pattern begins at a line
    start, so ``re`` tries it at every byte of the file (3 ms for a paper
    file's 665 kB); here the lines that end in ``-1`` are found first (a
    pattern led by a literal) and each is matched by ``_DELIM`` at its start.

    Examples
    --------
    >>> raw = b"    -1\\n    58\\n  1.0E-1\\n    -1\\n"
    >>> [(m.start(), m.end()) for m in (find_delimiter(raw, 0), find_delimiter(raw, 7))]
    [(0, 6), (23, 29)]
    >>> [(m.start(), m.end()) for m in (_DELIM.search(raw, 0), _DELIM.search(raw, 7))]
    [(0, 6), (23, 29)]
    """
    at = pos
    while (end := _DELIM_END.search(raw, at)) is not None:
        start = raw.rfind(b"\n", 0, end.start()) + 1
        if start >= pos:
            m = _DELIM.match(raw, start)
            if m is not None:
                return m
        at = end.end()
    return None


def _next_line(raw: bytes, pos: int) -> int:
    nl = raw.find(b"\n", pos)
    return len(raw) if nl < 0 else nl + 1


def _line_end(raw: bytes, pos: int) -> int:
    nl = raw.find(b"\n", pos)
    return len(raw) if nl < 0 else nl


def _lines(body: bytes) -> list[str]:
    return [_decode(line.rstrip(b"\r")) for line in body.split(b"\n")]


def _read_164(body: bytes, where: str) -> UnitSystem:
    lines = _lines(body)
    code = _int(lines[0][:10], 0) if lines else 0
    description = lines[0][10:30].strip() if lines else ""
    values = " ".join(lines[1:]).replace("D", "E").replace("d", "e").split()
    try:
        length, force = float(values[0]), float(values[1])
    except (IndexError, ValueError):
        length = force = float("nan")
    if not (np.isfinite(length) and np.isfinite(force) and length > 0 and force > 0):
        if code in UNIT_SYSTEMS:
            _, length, force = UNIT_SYSTEMS[code]
        else:
            raise DataError(
                f"{where}: dataset 164 (units) has no positive length and force factors"
            )
    elif code in UNIT_SYSTEMS:
        _, std_len, std_force = UNIT_SYSTEMS[code]
        if not (np.isclose(length, std_len, rtol=1e-4) and np.isclose(force, std_force, rtol=1e-4)):
            log.warning(
                "%s: dataset 164 unit code %d (%s) but factors %g, %g; the factors are used",
                where, code, UNIT_SYSTEMS[code][0], length, force,
            )
    return UnitSystem(length, force, int(code or 0), description or f"code {code}")


def _read_151(body: bytes) -> dict[str, str]:
    lines = _lines(body)
    keys = ("model_name", "description", "program")
    return {k: lines[i].strip() for i, k in enumerate(keys) if i < len(lines)}


def _axis(line: str) -> AxisInfo:
    """Record 8-11: Format(I10,3I5,2(1X,20A1))."""
    data_type = _int(line[:10], None)
    if data_type is None:  # columns drifted: split at blanks
        parts = line.split()
        data_type = _int(parts[0], 0) if parts else 0
    return AxisInfo(
        data_type=int(data_type or 0),
        length_exp=_int(line[10:15], 0) or 0,
        force_exp=_int(line[15:20], 0) or 0,
        label=line[26:46].strip(),
        units=line[47:67].strip() if len(line) > 47 else "",
    )


def _dof_line(line: str, where: str) -> tuple[int, int, str, int, int, str, int, int]:
    """Record 6: Format(2(I5,I10),2(1X,10A1,I10,I4))."""
    fields = (line[0:5], line[20:30], line[31:41], line[41:51], line[51:55],
              line[56:66], line[66:76], line[76:80])
    ftype, lcase = _int(fields[0]), _int(fields[1], 0)
    rnode, rdir, fnode, fdir = (_int(f) for f in (fields[3], fields[4], fields[6], fields[7]))
    if None in (ftype, rnode, rdir, fnode, fdir):
        parts = line.split()  # columns drifted: plain names without blanks
        if len(parts) == 10 and all(_int(parts[k]) is not None for k in (0, 5, 6, 8, 9)):
            ftype, lcase = _int(parts[0]), _int(parts[3], 0)
            rnode, rdir, fnode, fdir = (_int(parts[k]) for k in (5, 6, 8, 9))
            fields = (*fields[:2], parts[4], *fields[3:5], parts[7], *fields[6:])
        else:
            raise DataError(
                f"{where}: record 6 (function type, node and direction numbers) is not "
                f"readable: {line.strip()[:80]!r}"
            )
    return (int(ftype), int(lcase or 0), fields[2].strip(), int(rnode), int(rdir),  # type: ignore[arg-type]
            fields[5].strip(), int(fnode), int(fdir))  # type: ignore[arg-type]


def _header(lines: list[str], where: str) -> dict[str, object]:
    """Records 1-11 of dataset 58 (the ASCII header of 58 and 58b)."""
    if len(lines) < 11:
        raise DataError(f"{where}: truncated header ({len(lines)} of 11 lines)")
    ftype, lcase, rname, rnode, rdir, fname, fnode, fdir = _dof_line(lines[5], where)
    r7 = lines[6]
    parts = r7.split()
    # split at blanks unless an I10 field touches its neighbour (an 11+ digit "integer"
    # is two fields, e.g. a 10-digit count after the data type)
    if len(parts) >= 5 and all(_int(p) is not None and len(p) <= 10 for p in parts[:3]):
        ord_type, n_values, spacing = (_int(p) for p in parts[:3])
        x0, dx = _float(parts[3]), _float(parts[4])
    else:  # values touching: fixed columns 3I10,3E13.5
        ord_type, n_values, spacing = (_int(r7[a : a + 10]) for a in (0, 10, 20))
        x0, dx = _float(r7[30:43]), _float(r7[43:56])
    if ord_type not in (2, 4, 5, 6):
        raise DataError(
            f"{where}: ordinate data type {ord_type} (record 7, field 1) is not one of "
            "2, 4 (real) or 5, 6 (complex)"
        )
    if n_values is None or n_values < 0:
        raise DataError(f"{where}: number of values (record 7, field 2) is not readable")
    if spacing not in (0, 1):
        raise DataError(f"{where}: abscissa spacing (record 7, field 3) is {spacing}, not 0 or 1")
    if spacing == 1 and not (x0 is not None and dx is not None and np.isfinite(x0)
                             and np.isfinite(dx) and dx > 0):
        raise DataError(
            f"{where}: even abscissa spacing needs a finite start and a positive increment "
            f"(record 7: {r7.strip()!r})"
        )
    ids = tuple(line.strip() for line in lines[:5])
    return dict(
        ids=ids, func_type=ftype, load_case=lcase, rsp_name=rname, rsp_node=rnode,
        rsp_dir=rdir, ref_name=fname, ref_node=fnode, ref_dir=fdir, ord_data_type=ord_type,
        n_values=n_values, uniform=spacing == 1, x0=float(x0 or 0.0), dx=float(dx or 0.0),
        abscissa=_axis(lines[7]), numerator=_axis(lines[8]), denominator=_axis(lines[9]),
    )


def _layout(ord_type: int, uniform: bool) -> tuple[int, int]:
    """(values per point, ASCII values per line) of a data case (Addendum B)."""
    complex_data = ord_type in (5, 6)
    per_point = (2 if complex_data else 1) + (0 if uniform else 1)
    if ord_type in (2, 5):
        return per_point, 6  # 6E13.5
    return per_point, 3 if complex_data and not uniform else 4  # E13.5,2E20.12 / 4E20.12


def _fixed_width(lines: list[bytes], ord_type: int, uniform: bool) -> np.ndarray:
    """Values by the fixed Fortran widths of the specification."""
    single = ord_type in (2, 5)
    if single:
        widths = [13] * 6
    elif uniform:
        widths = [20] * 4
    elif ord_type == 4:
        widths = [13, 20, 13, 20]
    else:
        widths = [13, 20, 20]
    values: list[float] = []
    for line in lines:
        text = line.rstrip(b"\r\n").replace(b"D", b"E").replace(b"d", b"e")
        a = 0
        for w in widths:
            chunk = text[a : a + w].strip()
            a += w
            if chunk:
                values.append(float(chunk))
    return np.array(values, dtype=float)


def _read_58_ascii(body: bytes, where: str) -> Record58:
    # the 11 header lines apart, the data as one block: its values are the
    # same whitespace-separated tokens as those of its non-blank lines
    lines = body.split(b"\n", 11)
    head = _header([_decode(x.rstrip(b"\r")) for x in lines[:11]], where)
    data = lines[11] if len(lines) > 11 else b""
    ord_type, uniform, n = head["ord_data_type"], head["uniform"], head["n_values"]
    per_point, per_line = _layout(ord_type, uniform)  # type: ignore[arg-type]
    blob = data.replace(b"D", b"E").replace(b"d", b"e")
    try:
        values = np.array(blob.split(), dtype=float)
    except ValueError:
        data_lines = [x for x in data.split(b"\n") if x.strip()]
        try:
            values = _fixed_width(data_lines, ord_type, uniform)  # type: ignore[arg-type]
        except ValueError:
            bad = next(t for t in blob.split() if _float(t.decode("latin-1")) is None)
            raise DataError(
                f"{where}: data value {bad.decode('latin-1')[:20]!r} is not a number"
            ) from None
    need = int(n) * per_point  # type: ignore[call-overload]
    values = _trim(values, need, per_line, where)
    return _record(head, values, where, binary=False)


def _trim(values: np.ndarray, need: int, per_line: int, where: str) -> np.ndarray:
    """Drop padding values of the last line; refuse missing values."""
    if values.size < need:
        raise DataError(
            f"{where}: truncated record: {values.size} of {need} data values "
            "(record 7 announces more values than the file holds)"
        )
    extra = values.size - need
    if extra >= per_line:
        raise DataError(
            f"{where}: {values.size} data values where record 7 announces {need}; "
            "corrupt record"
        )
    return values[:need]


def _record(head: dict[str, object], values: np.ndarray, where: str, *, binary: bool,
            x: np.ndarray | None = None) -> Record58:
    ord_type, uniform, n = head["ord_data_type"], head["uniform"], int(head["n_values"])  # type: ignore[call-overload]
    complex_data = ord_type in (5, 6)
    if uniform:
        xs = head["x0"] + np.arange(n) * head["dx"]  # type: ignore[operator]
        ys = values
    elif x is not None:
        xs, ys = x, values
    else:
        step = 3 if complex_data else 2
        xs, ys = values[0::step], np.delete(values, np.s_[0::step])
    data = ys[0::2] + 1j * ys[1::2] if complex_data else ys.astype(float)
    return Record58(record=0, line=0, binary=binary, x=np.asarray(xs, dtype=float), data=data,
                    **head)  # type: ignore[arg-type]


def _read_58b(raw: bytes, head_start: int, head: bytes, where: str) -> tuple[Record58, int]:
    """Binary 58b: header line fields byte order, float format, ASCII line count,
    byte count; then the ASCII header lines; then the values."""
    fields = _decode(head).split()
    order = _int(fields[1], 1) if len(fields) > 1 else 1
    n_ascii = _int(fields[3], 11) if len(fields) > 3 else 11
    n_bytes = _int(fields[4], None) if len(fields) > 4 else None
    if order not in (1, 2):
        raise DataError(f"{where}: byte order {order} is neither 1 (little) nor 2 (big endian)")
    pos = _next_line(raw, head_start)
    header_lines = []
    for _ in range(n_ascii or 11):
        end = _line_end(raw, pos)
        header_lines.append(_decode(raw[pos:end].rstrip(b"\r")))
        pos = _next_line(raw, pos)
    head_fields = _header(header_lines, where)
    ord_type = int(head_fields["ord_data_type"])  # type: ignore[call-overload]
    uniform = bool(head_fields["uniform"])
    n = int(head_fields["n_values"])  # type: ignore[call-overload]
    size = 4 if ord_type in (2, 5) else 8
    comps = 2 if ord_type in (5, 6) else 1
    endian = "<" if order == 1 else ">"
    # the abscissa of an uneven record is always single precision (Addendum B)
    point_bytes = size * comps + (0 if uniform else 4)
    need = n * point_bytes
    # n_bytes (header field 5) is not trusted: pyuff, for one, writes num_pts * 8
    # for complex double records; the number of values and the data type decide.
    block = raw[pos : pos + need]
    if len(block) < need:
        raise DataError(
            f"{where}: truncated Universal File: {len(block)} of {need} bytes of binary data"
        )
    if uniform:
        values = np.frombuffer(block, dtype=f"{endian}f{size}").astype(float)
        x = None
    else:
        dt = np.dtype([("x", f"{endian}f4"), ("y", f"{endian}f{size}", (comps,))])
        rec = np.frombuffer(block, dtype=dt)
        x = rec["x"].astype(float)
        values = rec["y"].astype(float).reshape(-1)
    # the closing delimiter follows the data, on a new line or (pyuff) directly;
    # some writers add a CR/LF or count the bytes differently (n_bytes)
    close = None
    for end in dict.fromkeys((pos + need, pos + (n_bytes or need))):
        close = _BIN_CLOSE.match(raw, end)
        if close:
            break
    if close is None:
        raise DataError(
            f"{where}: truncated or corrupt Universal File: no -1 delimiter after "
            f"the {need} bytes of binary data"
        )
    return _record(head_fields, values, where, binary=True, x=x), close.end()
