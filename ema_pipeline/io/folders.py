"""The atomic results folder: a whole folder of results written beside its
target and swapped in only when complete (``ema-pipeline run``).

:func:`atomic_folder` does it all, as :func:`~ema_pipeline.io.files.atomic_path`
does for one file. Its pieces: :func:`partial_folder` makes the fresh sibling
``.NAME.partial-PID-XXXX``; :func:`swap_in` replaces NAME by it in one step:
with Linux ``renameat2(RENAME_EXCHANGE)`` the two folders trade places
atomically and the old one is removed; where that call is unavailable, two
renames (old -> ``.NAME.old-PID``, new -> NAME). :func:`remove_stale_partials`
removes the partial folders of runs whose process is gone and puts back a
backup left by a run killed between the two renames.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from ema_pipeline.runner import pid_alive  # re-exported: the runner owns process facts

__all__ = ["atomic_folder", "partial_folder", "pid_alive", "remove_stale_partials", "swap_in"]


def partial_folder(results_dir: str | os.PathLike[str]) -> Path:
    """A fresh, empty folder ``.NAME.partial-PID-XXXX`` beside ``results_dir``
    (NAME its name, PID this process), to be filled and then :func:`swap_in`-ed.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     new = partial_folder(Path(tmp) / "results")
    ...     new.parent == Path(tmp), new.name.startswith(f".results.partial-{os.getpid()}-")
    (True, True)
    """
    results_dir = Path(results_dir)
    return Path(tempfile.mkdtemp(prefix=f".{results_dir.name}.partial-{os.getpid()}-",
                                 dir=results_dir.parent))


_RENAME_EXCHANGE, _AT_FDCWD = 2, -100


def _exchange(a: Path, b: Path) -> bool:
    """Atomically exchange two paths (Linux ``renameat2``); False if unsupported."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError, TypeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                          ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (22, 38, 95):  # EINVAL, ENOSYS, EOPNOTSUPP: this filesystem cannot
        return False
    raise OSError(err, os.strerror(err), str(b))


def swap_in(new_dir: Path, results_dir: Path) -> None:
    """Replace ``results_dir`` by the finished ``new_dir`` in one atomic step.

    With ``renameat2(RENAME_EXCHANGE)`` the two folders trade places atomically
    and the old one (now at ``new_dir``) is removed; otherwise old ->
    ``.NAME.old-PID``, new -> NAME, remove the backup (a run killed between the
    two renames leaves the backup, which :func:`remove_stale_partials` restores).
    """
    if not results_dir.exists():
        os.rename(new_dir, results_dir)
        return
    if _exchange(new_dir, results_dir):
        shutil.rmtree(new_dir, ignore_errors=True)
        return
    old = results_dir.with_name(f".{results_dir.name}.old-{os.getpid()}")
    os.rename(results_dir, old)
    try:
        os.rename(new_dir, results_dir)
    except BaseException:
        os.rename(old, results_dir)
        raise
    shutil.rmtree(old, ignore_errors=True)


def remove_stale_partials(results_dir: str | os.PathLike[str]) -> int:
    """Remove the ``.NAME.partial-PID-*`` folders of runs whose process is gone,
    and put back a ``.NAME.old-PID`` backup when NAME is missing (a run killed
    between the two renames of :func:`swap_in`). Returns how many were removed."""
    results_dir = Path(results_dir).absolute()
    parent, name = results_dir.parent, results_dir.name
    if not parent.is_dir():
        return 0
    removed = 0
    for p in parent.glob(f".{name}.old-*"):
        pid = p.name.rsplit("-", 1)[-1]
        if pid.isdigit() and not pid_alive(int(pid)):
            if not results_dir.exists():
                os.rename(p, results_dir)
            else:
                shutil.rmtree(p, ignore_errors=True)
                removed += 1
    for p in parent.glob(f".{name}.partial-*"):
        pid = p.name[len(f".{name}.partial-"):].split("-", 1)[0]
        if not pid.isdigit() or not pid_alive(int(pid)) or int(pid) == os.getpid():
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p, ignore_errors=True)
            else:
                p.unlink(missing_ok=True)
            removed += 1
    return removed


@contextlib.contextmanager
def atomic_folder(results_dir: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a fresh folder beside ``results_dir`` (:func:`partial_folder`, after
    :func:`remove_stale_partials`); on success make it readable by all (0755)
    and :func:`swap_in` it as ``results_dir``. On an exception it is removed
    and ``results_dir`` is untouched.

    Examples
    --------
    >>> import tempfile
    >>> target = Path(tempfile.mkdtemp()) / "results"
    >>> with atomic_folder(target) as tmp:
    ...     _ = (tmp / "report.md").write_text("done")
    >>> (target / "report.md").read_text(), [p.name for p in target.parent.iterdir()]
    ('done', ['results'])
    """
    results_dir = Path(results_dir)
    results_dir.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_partials(results_dir)
    tmp_dir = partial_folder(results_dir)
    try:
        yield tmp_dir
        tmp_dir.chmod(0o755)
        swap_in(tmp_dir, results_dir)
    except BaseException:
        shutil.rmtree(tmp_dir, ignore_errors=True)
        raise
