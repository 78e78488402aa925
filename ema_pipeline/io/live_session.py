"""The session folder of a live impact test (``ema-pipeline live --session DIR``):
its layout, the journal of every block acquired and the lock.

The layout::

    DIR/live.lock        the running session's process id (one session per folder)
    DIR/session.json     the plan: the sample rate and, per point, its node, file and channels
    DIR/raw/pK.f32       point K's samples as acquired: float32 frames of all its
                         channels, appended block by block (fsync after each block)
    DIR/raw/pK.json      point K's journal: the hits judged, the choices by hand, done or not
    DIR/pK.wav           point K's recording (float32 WAV, SI units) once the point is done
    DIR/channels.csv     the channel sheet of the points done (``frf --channels``)
    DIR/hits.toml        the hits accepted per point (``frf --hits``)

Every block is in ``raw/`` before it is used, so a crash or a kill loses at
most the block in flight; the summaries (journal, WAV, sheet, hit choice) are
written to a temporary file and renamed. A lock left by a process that is no
longer alive is taken over, so the same command resumes.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline.data import ConfigError, DataError
from ema_pipeline.io.channel_sheet import write_channel_sheet
from ema_pipeline.io.files import atomic_path, write_text
from ema_pipeline.io.folders import pid_alive
from ema_pipeline.io.hit_choice import write_hit_choice

__all__ = ["SessionFolder"]

#: Units of the session's WAV channels, by quantity (the samples are in SI units).
_SI_LABELS = {"force": "N", "acceleration": "m/s^2", "velocity": "m/s", "displacement": "m"}


class SessionFolder:
    """The files of one live session (module docstring). :meth:`lock` first.

    Examples
    --------
    >>> import tempfile
    >>> folder = SessionFolder(tempfile.mkdtemp())
    >>> folder.lock()
    >>> folder.append(1, np.array([[1.0, 2.0], [3.0, 4.0]]))  # a block of 2 channels
    >>> folder.append(1, np.array([[5.0], [6.0]]))
    >>> folder.read_raw(1, 2).tolist()
    [[1.0, 2.0, 5.0], [3.0, 4.0, 6.0]]
    >>> folder.unlock()
    """

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        self._raw: dict[int, Any] = {}
        self._locked = False

    # -- the lock -----------------------------------------------------------
    @property
    def lock_path(self) -> Path:
        return self.folder / "live.lock"

    def lock(self) -> None:
        """Take the folder's lock; a lock of a live process is a ConfigError naming
        the folder and the process, a stale one is taken over."""
        self.folder.mkdir(parents=True, exist_ok=True)
        for _ in range(2):
            try:
                fd = os.open(self.lock_path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    pid = int(self.lock_path.read_text().strip() or "0")
                except (OSError, ValueError):
                    pid = 0
                if pid and pid != os.getpid() and pid_alive(pid):
                    raise ConfigError(f"{self.folder}: a live session (process {pid}) is "
                                      "running on this folder; stop it first, or give "
                                      "another --session") from None
                self.lock_path.unlink(missing_ok=True)  # left by a process gone: take it
                continue
            with os.fdopen(fd, "w") as fh:
                fh.write(f"{os.getpid()}\n")
            self._locked = True
            return
        raise ConfigError(f"{self.folder}: cannot take the session lock {self.lock_path}")

    def unlock(self) -> None:
        """Close the journals and release the lock."""
        for fh in self._raw.values():
            fh.close()
        self._raw.clear()
        if self._locked:
            self.lock_path.unlink(missing_ok=True)
            self._locked = False

    # -- the plan -----------------------------------------------------------
    def write_plan(self, plan: Mapping[str, Any]) -> None:
        write_text(json.dumps(plan, indent=1) + "\n", self.folder / "session.json")

    def read_plan(self) -> dict[str, Any] | None:
        path = self.folder / "session.json"
        if not path.is_file():
            return None
        try:
            return dict(json.loads(path.read_text(encoding="utf-8")))
        except (ValueError, OSError) as exc:
            raise DataError(f"{path}: not a live session's plan ({exc})") from None

    # -- the raw journal ----------------------------------------------------
    def raw_path(self, point: int) -> Path:
        return self.folder / "raw" / f"p{point}.f32"

    def append(self, point: int, data: np.ndarray) -> None:
        """Append a block (n_channels, n) as float32 frames, and fsync it."""
        fh = self._raw.get(point)
        if fh is None:
            self.raw_path(point).parent.mkdir(parents=True, exist_ok=True)
            fh = self._raw[point] = open(self.raw_path(point), "ab")  # noqa: SIM115
        fh.write(np.ascontiguousarray(np.asarray(data, dtype=np.float32).T).tobytes())
        fh.flush()
        os.fsync(fh.fileno())

    def read_raw(self, point: int, n_channels: int) -> np.ndarray:
        """Point ``point``'s samples as acquired (n_channels, n): whole frames only
        (a frame cut by a crash is dropped)."""
        path = self.raw_path(point)
        if not path.is_file():
            return np.zeros((n_channels, 0), dtype=np.float32)
        raw = np.fromfile(path, dtype=np.float32)
        n = raw.size // n_channels
        return raw[:n * n_channels].reshape(n, n_channels).T.copy()

    def truncate_raw(self, point: int, n_samples: int, n_channels: int) -> None:
        """Cut point ``point``'s raw file to ``n_samples`` whole frames."""
        path = self.raw_path(point)
        if path.is_file():
            with open(path, "r+b") as fh:
                fh.truncate(4 * n_channels * n_samples)

    def close_raw(self, point: int) -> None:
        fh = self._raw.pop(point, None)
        if fh is not None:
            fh.close()

    # -- the journal of a point ---------------------------------------------
    def journal_path(self, point: int) -> Path:
        return self.folder / "raw" / f"p{point}.json"

    def write_journal(self, point: int, entry: Mapping[str, Any]) -> None:
        path = self.journal_path(point)
        with atomic_path(path) as tmp:
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(json.dumps(entry, indent=1) + "\n")
                fh.flush()
                os.fsync(fh.fileno())

    def read_journal(self, point: int) -> dict[str, Any] | None:
        path = self.journal_path(point)
        if not path.is_file():
            return None
        try:
            return dict(json.loads(path.read_text(encoding="utf-8")))
        except (ValueError, OSError) as exc:
            raise DataError(f"{path}: not a live session's point journal ({exc})") from None

    # -- what the offline commands read -------------------------------------
    def wav_name(self, point: int) -> str:
        return f"p{point}.wav"

    def write_wav(self, point: int, data: np.ndarray, sample_rate_hz: float) -> Path:
        """Point ``point``'s recording as a float32 WAV (one channel per row of
        ``data``, SI units)."""
        from scipy.io import wavfile

        path = self.folder / self.wav_name(point)
        with atomic_path(path) as tmp:
            wavfile.write(tmp, int(round(sample_rate_hz)),
                          np.ascontiguousarray(np.asarray(data, dtype=np.float32).T))
        return path

    def write_sheet(self, points: Sequence[tuple[int, Sequence[tuple[str, str, int, int]]]]
                    ) -> Path:
        """``channels.csv`` of the points done: per point its channels as
        (role, quantity, node, direction), in the WAV's order."""
        rows = []
        for point, channels in points:
            for k, (role, quantity, node, direction) in enumerate(channels):
                axis = "XYZ"[abs(direction) - 1] if direction else ""
                sign = "-" if direction < 0 else "+"
                rows.append({"file": self.wav_name(point), "channel": str(k), "role": role,
                             "node": node, "direction": f"{sign}{axis}" if axis else "",
                             "scale": "", "unit": _SI_LABELS.get(quantity, "")})
        return write_channel_sheet(rows, self.folder / "channels.csv",
                                   comment="the points done of a live session (ema-pipeline "
                                   "live): ema-pipeline frf --channels channels.csv --hits "
                                   "hits.toml")

    def write_hits(self, accepted: Mapping[int, Sequence[int]]) -> Path:
        """``hits.toml``: {point: accepted hit numbers of its WAV}."""
        return write_hit_choice({self.wav_name(k): tuple(v) for k, v in accepted.items()},
                                self.folder / "hits.toml")
