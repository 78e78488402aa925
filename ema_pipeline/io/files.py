"""Generic file helpers: safe opening of inputs, content hashes, atomic writes, CSV.

Inputs
    Every input file is treated as hostile. :func:`check_readable` refuses
    anything but a non-empty regular file *before* it is opened, with a message
    naming the file and what it is instead: a missing file, a dangling symlink,
    a symlink loop, a folder, a FIFO (reading one blocks until someone writes),
    a device (``/dev/zero`` never ends), a socket. :func:`open_regular` opens
    with ``O_NONBLOCK`` and checks the *open* descriptor again with ``fstat``
    (no race between the check and the open), so :func:`sha256_file` never
    blocks on a FIFO or hashes a device forever.

Outputs
    Everything ema-pipeline writes goes through :func:`atomic_path`: a
    temporary file beside the target, renamed into place only when complete
    and removed on any failure. A full disk (``ENOSPC``), an exceeded quota
    (``EDQUOT``) or file-size limit (``EFBIG``) becomes one :class:`OSError`
    whose ``filename`` is the target and whose ``strerror`` says what happened;
    no partial file is left behind. Any other error names the target too, never
    the hidden temporary; a target that is a folder is refused by name.
    Inside :func:`replace_together` the temporaries of several
    :func:`atomic_path` blocks (the files of one command) are renamed onto
    their targets only at the end of the block, all of them or none.
    A process killed between those renames leaves a journal; the next
    :func:`replace_together` into the same folder puts that set back as it
    was (:func:`recover_interrupted`).
    :func:`same_file` and :func:`check_not_inputs` refuse an output that is an
    input before any work.
"""

from __future__ import annotations

import contextlib
import contextvars
import csv
import errno
import fcntl
import hashlib
import io as stdio
import os
import tempfile
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

from ema_pipeline.data import DataError, Table
from ema_pipeline.paths import check_readable, not_regular

if TYPE_CHECKING:
    import pandas as pd

#: errno values that mean "the disk (or the allowed file size) is full".
DISK_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT})


def open_regular(path: str | os.PathLike[str], kind: str = "a regular file") -> BinaryIO:
    """Open a regular file for binary reading, never blocking on a FIFO.

    The file is opened with ``O_NONBLOCK`` and its descriptor checked with
    ``fstat`` before anything is read; a non-regular file raises DataError.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.NamedTemporaryFile() as tmp:
    ...     _ = tmp.write(b"abc"); tmp.flush()
    ...     with open_regular(tmp.name) as fh:
    ...         fh.read()
    b'abc'
    """
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC)
    except OSError as exc:
        check_readable(path, kind)  # the precise message for a missing file, a loop, ...
        raise DataError(f"{path}: cannot open ({exc.strerror})") from exc
    try:
        what = not_regular(os.fstat(fd).st_mode)
        if what is not None:
            raise DataError(f"{path}: is {what}, expected {kind}")
        flags = fcntl.fcntl(fd, fcntl.F_GETFL)
        fcntl.fcntl(fd, fcntl.F_SETFL, flags & ~os.O_NONBLOCK)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def sha256_file(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a regular file's content, hex (DataError for FIFOs, devices, folders).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.NamedTemporaryFile() as tmp:
    ...     _ = tmp.write(b"abc"); tmp.flush()
    ...     sha256_file(tmp.name)[:16]
    'ba7816bf8f01cfea'
    """
    digest = hashlib.sha256()
    with open_regular(path, "an input file") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def disk_full_error(exc: OSError, target: str | os.PathLike[str]) -> OSError:
    """``exc`` as one clear OSError naming ``target`` when it means a full disk.

    Other errors are returned unchanged.

    Examples
    --------
    >>> import errno
    >>> e = disk_full_error(OSError(errno.ENOSPC, "No space left on device"), "out/a.csv")
    >>> e.filename, e.strerror
    ('out/a.csv', 'cannot write: no space left on device (disk full, quota or file-size limit)')
    """
    if exc.errno not in DISK_FULL_ERRNOS:
        return exc
    return OSError(
        exc.errno,
        "cannot write: no space left on device (disk full, quota or file-size limit)",
        str(target),
    )


def _named_error(exc: OSError, tmp: Path, target: Path) -> OSError:
    """``exc`` naming ``target`` where it named the temporary ``tmp`` (a full disk
    becomes :func:`disk_full_error`); other errors unchanged.

    Examples
    --------
    >>> import errno
    >>> tmp, target = Path("out/.a.csv.x1.tmp"), Path("out/a.csv")
    >>> _named_error(OSError(errno.EROFS, "Read-only file system", str(tmp)), tmp, target)
    OSError(30, 'Read-only file system')
    >>> _.filename
    'out/a.csv'
    """
    full = disk_full_error(exc, target)
    if full is not exc:
        return full
    if exc.filename is not None and str(exc.filename) == str(tmp):
        return OSError(exc.errno, exc.strerror or str(exc), str(target))
    return exc


def _refuse_folder(target: Path) -> None:
    """An existing folder (not a symlink to one) is never replaced by a file."""
    if target.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a folder, not a file: not replaced",
                                str(target))


#: The files staged by :func:`atomic_path` inside :func:`replace_together`:
#: (temporary, target) pairs, renamed together at the end of the block.
_STAGED: contextvars.ContextVar[list[tuple[Path, Path]] | None] = contextvars.ContextVar(
    "ema_pipeline_staged_writes", default=None)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On an exception the temporary file is removed and ``path`` is untouched; a
    full disk is re-raised as one clear OSError naming ``path``
    (:func:`disk_full_error`), and so is any error that named the temporary.
    An existing folder at ``path`` is refused (``IsADirectoryError`` naming it).
    Inside :func:`replace_together` the rename waits for the end of that block.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_path(target) as tmp:
    ...     _ = tmp.write_text("done")
    >>> target.read_text(), sorted(p.name for p in target.parent.iterdir())
    ('done', ['a.txt'])
    """
    target = Path(path)
    _refuse_folder(target)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        os.close(fd)
    except OSError as exc:  # a read-only folder or file system names the temporary
        culprit = Path(exc.filename) if exc.filename else target
        hidden = culprit if culprit.name.startswith(f".{target.name}.") else target
        raise _named_error(exc, hidden, target) from exc
    tmp_path = Path(tmp)
    staged = _STAGED.get()
    try:
        yield tmp_path
        if tmp_path.exists():  # mkstemp makes 0600 files; give the usual umask mode
            umask = os.umask(0)
            os.umask(umask)
            tmp_path.chmod(0o666 & ~umask)
        if staged is not None:
            staged.append((tmp_path, target))
        else:
            os.replace(tmp_path, target)
    except OSError as exc:
        tmp_path.unlink(missing_ok=True)
        named = _named_error(exc, tmp_path, target)
        if named is exc:
            raise
        raise named from exc
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def replace_together() -> Iterator[None]:
    """Write several files as one: every :func:`atomic_path` (so every writer of
    this package) inside the block writes its temporary only; at the end of the
    block all are renamed onto their targets, all or none.

    An exception inside the block removes every temporary and replaces nothing.
    The renames keep each old target under a hidden hard link (or, where the file
    system has none, a renamed copy) until all have succeeded; a rename that
    fails puts every target back as it was and raises an OSError naming its
    target.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "a.txt").write_text("old a")
    >>> try:
    ...     with replace_together():
    ...         _ = write_text("new a", d / "a.txt")
    ...         raise OSError(28, "No space left on device", str(d / "b.txt"))
    ... except OSError:
    ...     pass
    >>> (d / "a.txt").read_text(), sorted(p.name for p in d.iterdir())
    ('old a', ['a.txt'])
    >>> with replace_together():
    ...     _ = write_text("new a", d / "a.txt")
    ...     _ = write_text("new b", d / "b.txt")
    >>> (d / "a.txt").read_text(), (d / "b.txt").read_text()
    ('new a', 'new b')
    """
    if _STAGED.get() is not None:  # nested: the outer block swaps
        yield
        return
    staged: list[tuple[Path, Path]] = []
    token = _STAGED.set(staged)
    try:
        yield
    except BaseException:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
        raise
    finally:
        _STAGED.reset(token)
    _swap_all(staged)


def _keep_old(target: Path, backup: Path) -> bool:
    """Give the existing ``target`` the hidden second name ``backup``: a hard
    link where the file system has them, else the target renamed. False when
    there is no target."""
    if not os.path.lexists(target):
        return False
    try:
        os.link(target, backup, follow_symlinks=False)
    except OSError:
        os.replace(target, backup)
    return True


#: Name pattern of the journal of one :func:`replace_together` swap, in the
#: folder of its first target. Written before the first rename and removed
#: after the last, it lists each target, whether it existed, the hidden name
#: its old version gets during the swap and its temporary.
JOURNAL_GLOB = ".ema-replace-*.journal"


def _write_journal(folder: Path, staged: list[tuple[Path, Path]]) -> tuple[Path, list[dict]]:
    """The journal of one swap of ``staged`` (temporary, target) pairs
    (:data:`JOURNAL_GLOB`), on disk before it returns, and its entries."""
    import json

    fd, name = tempfile.mkstemp(prefix=".ema-replace-", suffix=".journal", dir=folder)
    tag = Path(name).name[len(".ema-replace-"):-len(".journal")]
    entries = [{"target": str(target.absolute()), "existed": os.path.lexists(target),
                "backup": str(target.absolute().with_name(f".{target.name}.{tag}.old")),
                "tmp": str(tmp.absolute())} for tmp, target in staged]
    with os.fdopen(fd, "w") as fh:
        json.dump(entries, fh)
        fh.flush()
        os.fsync(fh.fileno())
    return Path(name), entries


def _put_back(entry: dict) -> bool:
    """Undo one journal entry of an interrupted swap; True when its target changed."""
    target, backup, tmp = Path(entry["target"]), Path(entry["backup"]), Path(entry["tmp"])
    changed = False
    if entry["existed"]:
        if os.path.lexists(backup):
            if os.path.lexists(target) and os.path.samestat(os.lstat(backup), os.lstat(target)):
                backup.unlink()  # kept, not yet replaced: the second name only goes
            else:
                os.replace(backup, target)
                changed = True
    elif os.path.lexists(target) and not os.path.lexists(tmp):
        target.unlink()  # its temporary was renamed onto it: the new file goes
        changed = True
    tmp.unlink(missing_ok=True)
    return changed


def recover_interrupted(folder: str | os.PathLike[str]) -> list[Path]:
    """Put back the files of every swap of :func:`replace_together` in
    ``folder`` that was interrupted (the process killed between its renames):
    each target returns to what it was before that swap (its hidden old
    version renamed back, or removed where it did not exist), the temporaries
    and the journal go. Returns the targets that changed (empty when nothing
    was interrupted). :func:`replace_together` calls it on its targets'
    folders before it swaps, so the next command that writes there repairs
    them.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> a, b = d / "a.txt", d / "b.txt"
    >>> _ = a.write_text("old a")
    >>> journal, entries = _write_journal(d, [(d / ".a.tmp", a), (d / ".b.tmp", b)])
    >>> _ = _keep_old(a, pathlib.Path(entries[0]["backup"]))  # the swap kept the old a,
    >>> _ = (d / ".a.tmp").write_text("new a"); os.replace(d / ".a.tmp", a)  # replaced it,
    >>> _ = (d / ".b.tmp").write_text("new b"); os.replace(d / ".b.tmp", b)  # wrote b: killed
    >>> [p.name for p in recover_interrupted(d)], a.read_text()
    (['a.txt', 'b.txt'], 'old a')
    >>> sorted(p.name for p in d.iterdir())
    ['a.txt']
    """
    import json

    restored: list[Path] = []
    for journal in sorted(Path(folder).glob(JOURNAL_GLOB)):
        try:
            entries = json.loads(journal.read_text())
            for entry in reversed(entries):
                if _put_back(entry):
                    restored.append(Path(entry["target"]))
        except (OSError, ValueError, KeyError, TypeError):
            continue  # not ours, or unreadable: left for the user
        journal.unlink(missing_ok=True)
    return sorted(restored)


def _swap_all(staged: list[tuple[Path, Path]]) -> None:
    """Rename every (temporary, target) of ``staged``; on a failure put back the
    targets already replaced and remove the temporaries (:func:`replace_together`).

    A journal (:data:`JOURNAL_GLOB`) lists the swap before its first rename
    and goes after the last. A process killed in between leaves it, and the
    next swap into the same folder first puts the interrupted set back
    (:func:`recover_interrupted`), with a warning naming the files."""
    import warnings

    if not staged:
        return
    for folder in dict.fromkeys(target.parent for _, target in staged):
        put_back = recover_interrupted(folder)
        if put_back:
            warnings.warn(
                f"{folder}: an earlier write was interrupted between its renames; put back "
                f"{', '.join(p.name for p in put_back)} as they were before it", stacklevel=3)
    try:  # nothing replaced yet: on an error the temporaries go
        for _, target in staged:
            _refuse_folder(target)
        try:
            journal, entries = _write_journal(staged[0][1].parent, staged)
        except OSError as exc:  # named by the first target, not the hidden journal
            raise _named_error(exc, Path(str(exc.filename)), staged[0][1]) from exc
    except OSError:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
        raise
    try:
        for (tmp, target), entry in zip(staged, entries, strict=True):
            _keep_old(target, Path(entry["backup"]))
            try:
                os.replace(tmp, target)
            except OSError as exc:
                raise _named_error(exc, tmp, target) from exc
    except BaseException:
        for entry in reversed(entries):
            with contextlib.suppress(OSError):
                _put_back(entry)
        journal.unlink(missing_ok=True)
        raise
    for entry in entries:
        Path(entry["backup"]).unlink(missing_ok=True)
    journal.unlink(missing_ok=True)


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether paths ``a`` and ``b`` name one file: the same resolved path (through
    symbolic links and ``..``), or one file under two names (hard links).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> same_file(d / "x.uff", d / "sub" / ".." / "x.uff"), same_file(d / "x", d / "y")
    (True, False)
    """
    if os.path.realpath(a) == os.path.realpath(b):  # a symlink loop resolves to itself
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return False


def check_not_inputs(outputs: dict[str, Path], inputs: list[Path]) -> None:
    """Refuse (DataError naming both) an output that is one of the ``inputs``
    (:func:`same_file`), before any work. ``outputs``: {what it is: path}, e.g.
    ``{"--out": out, "the hit table of --out": hits}``.

    Examples
    --------
    >>> check_not_inputs({"--out": Path("a/rec.uff")}, [Path("a/rec.uff")])
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: a/rec.uff: --out would overwrite the input a/rec.uff; ...
    """
    for what, out in outputs.items():
        for inp in inputs:
            if same_file(out, inp):
                raise DataError(f"{out}: {what} would overwrite the input {inp}; choose another "
                                "output name")


def write_text(text: str, path: str | os.PathLike[str]) -> Path:
    """Write a text file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_bytes(data: bytes, path: str | os.PathLike[str]) -> Path:
    """Write a binary file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


#: How every table is written: floats to 10 significant digits (``%.10g``).
CSV_FLOAT_FORMAT = "%.10g"


def write_csv(table: pd.DataFrame | Table, path: str | os.PathLike[str]) -> Path:
    """Write a table as CSV (no index) atomically, floats to 10 significant
    digits (:data:`CSV_FLOAT_FORMAT`). A :class:`~ema_pipeline.data.Table`
    gives the same file as a DataFrame of its columns (:func:`csv_text`)."""
    with atomic_path(path) as tmp:
        if isinstance(table, Table):
            Path(tmp).write_text(csv_text(table), encoding="utf-8", newline="")
        else:
            table.to_csv(tmp, index=False, float_format=CSV_FLOAT_FORMAT)
    return Path(path)


def csv_text(table: Table) -> str:
    """``table`` as ``pandas.DataFrame(table.columns).to_csv(index=False,
    float_format="%.10g")`` writes it: a header line, then one line per row;
    float columns with ``%.10g``, NaN (and None) as an empty field, other
    values as ``str``; fields quoted only where they hold the separator, a
    quote or a line break; lines ended by ``os.linesep``. Written here so that
    ``ema-pipeline identify`` need not import pandas (0.4-0.5 s of every
    command); tests/test_io_tables.py compares it with pandas.

    Examples
    --------
    >>> csv_text(Table({"mode": np.array([1, 2]), "fn_hz": np.array([18.1, np.nan]),
    ...                 "found_by": np.array(["diagram", "a, b"], dtype=object)})).splitlines()
    ['mode,fn_hz,found_by', '1,18.1,diagram', '2,,"a, b"']
    """
    def cells(col: np.ndarray) -> list[str]:
        if col.dtype.kind == "f":
            return ["" if np.isnan(v) else CSV_FLOAT_FORMAT % v for v in col.tolist()]
        return ["" if v is None or (isinstance(v, float) and np.isnan(v)) else str(v)
                for v in col.tolist()]

    buffer = stdio.StringIO()
    writer = csv.writer(buffer, lineterminator=os.linesep)
    writer.writerow(table.names)
    writer.writerows(zip(*(cells(col) for col in table.columns.values()), strict=True))
    return buffer.getvalue()


def read_csv(path: str | os.PathLike[str], required: tuple[str, ...] = ()) -> pd.DataFrame:
    """Read a CSV table and check that it has the ``required`` columns."""
    import pandas as pd  # here: the commands that only write tables do without it

    path = Path(path)
    check_readable(path, "a CSV table")
    try:
        with open_regular(path, "a CSV table") as fh:
            table = pd.read_csv(fh)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a readable CSV table ({exc})") from exc
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise DataError(
            f"{path}: missing column(s) {', '.join(missing)}; "
            f"found {', '.join(map(str, table.columns))}"
        )
    return table


def read_toml(path: str | os.PathLike[str], kind: str) -> dict[str, Any]:
    """The table of a TOML file, or one DataError naming ``path`` (``kind`` says
    what the file should be: not a file, not valid TOML, unreadable).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.toml"
    >>> _ = p.write_text("x = 1")
    >>> read_toml(p, "a settings file (TOML)")
    {'x': 1}
    """
    path = Path(path)
    check_readable(path, kind)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not valid TOML ({exc})") from exc
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror or exc})") from exc
