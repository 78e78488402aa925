"""The acquisition interface of a live test, and the replay device.

A device delivers one hammer point at a time: :meth:`Device.start` begins
point ``k`` (1-based, the plan's order) at sample ``first_sample`` (a resumed
point continues where its journal ends), :meth:`Device.read` returns the next
:class:`Block` of samples (all channels of the point, force first, SI units) or
``None`` when none is ready within the timeout, :meth:`Device.streaming` says
whether more data will come for the point, :meth:`Device.stop` ends it.

To add a DAQ, write a class with these methods and attributes (a thread of the
live test calls :meth:`~Device.read` in a loop); report lost samples (a buffer
overflow) in :attr:`Block.lost`, so that the hits they touch are rejected.

:class:`ReplayDevice` streams each point's recording from a channel sheet
(every format ``frf`` reads), block by block on a clock at ``speed`` times real
time (``math.inf``: as fast as it is read), and can lose blocks on purpose
(``lose_blocks``) to test what a dropout does.
"""

from __future__ import annotations

import math
import time
from collections.abc import Collection
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from ema_pipeline.data import Channel, Recording
from ema_pipeline.io.channel_sheet import ChannelSheet
from ema_pipeline.pipeline.roving import read_sheet_recordings

__all__ = ["BLOCK_S", "Block", "Device", "PlanPoint", "ReplayDevice", "sheet_plan",
           "wait_until_due"]

#: Length (s of data) of the blocks the built-in devices deliver.
BLOCK_S = 0.05


@dataclass(frozen=True)
class Block:
    """Samples (n_channels, n) from sample ``first_sample`` of the point's stream;
    ``lost`` samples before them never arrived (a dropout or an overflow);
    ``wall_s``: when the block was delivered (``time.time()``)."""

    data: np.ndarray
    first_sample: int
    lost: int = 0
    wall_s: float = 0.0


@dataclass(frozen=True)
class PlanPoint:
    """One hammer point of the plan: its number (1-based), a label (the force
    DOF, e.g. ``5-Z``) and its channels (force first, at their DOFs)."""

    number: int
    label: str
    channels: tuple[Channel, ...]

    @property
    def node(self) -> int:
        dof = self.channels[0].dof
        return int(dof.node) if dof is not None else self.number


class Device(Protocol):
    """What a live test needs of an acquisition device (module docstring)."""

    sample_rate_hz: float
    plan: tuple[PlanPoint, ...]

    def start(self, point: int, first_sample: int = 0) -> None: ...

    def read(self, timeout_s: float) -> Block | None: ...

    def streaming(self) -> bool: ...

    def stop(self) -> None: ...


def sheet_plan(sheet: ChannelSheet, recordings: list[Recording]) -> tuple[PlanPoint, ...]:
    """The plan of a channel sheet's test: one point per file, its channels as read.

    Examples
    --------
    >>> from ema_pipeline.data import DOF
    >>> rec = Recording(np.zeros((2, 8)), 100.0, (Channel("hammer", "force", DOF(3, -3)),
    ...                                           Channel("acc", "acceleration", DOF(100, 3))))
    >>> [(p.number, p.label, p.node) for p in sheet_plan(ChannelSheet(()), [rec])]
    [(1, '3-Z', 3)]
    """
    out = []
    for k, rec in enumerate(recordings, start=1):
        dof = rec.channels[0].dof
        out.append(PlanPoint(k, dof.label() if dof is not None else str(k), rec.channels))
    return tuple(out)


def wait_until_due(due_s: float, speed: float, timeout_s: float) -> bool:
    """Sleep until the device's clock reaches ``due_s`` (``time.monotonic``
    seconds; at once when ``speed`` is infinite: as fast as it goes), or for
    ``timeout_s`` at most: whether the block is due now.

    Examples
    --------
    >>> wait_until_due(time.monotonic() - 1.0, 1.0, 0.1)
    True
    >>> wait_until_due(time.monotonic() + 60.0, 1.0, 0.01)
    False
    """
    wait = 0.0 if math.isinf(speed) else due_s - time.monotonic()
    if wait > timeout_s:
        time.sleep(timeout_s)
        return False
    if wait > 0:
        time.sleep(wait)
    return True


class ReplayDevice:
    """Streams each file of a channel sheet as a point (module docstring)."""

    def __init__(self, sheet: ChannelSheet, *, speed: float = 1.0, block_s: float = BLOCK_S,
                 lose_blocks: Collection[tuple[int, int]] = ()) -> None:
        self.recordings = read_sheet_recordings(sheet)
        self.sample_rate_hz = self.recordings[0].sample_rate_hz
        self.plan = sheet_plan(sheet, self.recordings)
        self.speed = float(speed)
        self.block_n = max(1, int(round(block_s * self.sample_rate_hz)))
        self.lose_blocks = set(lose_blocks)  # (point, block index) never delivered
        self._point = 0
        self._pos = self._first = 0
        self._t0 = 0.0

    def start(self, point: int, first_sample: int = 0) -> None:
        self._point, self._pos, self._first = point, first_sample, first_sample
        self._t0 = time.monotonic()

    def streaming(self) -> bool:
        return bool(self._point) and self._pos < self._signals().shape[1]

    def stop(self) -> None:
        self._point = 0

    def _signals(self) -> np.ndarray:
        return self.recordings[self._point - 1].signals

    def read(self, timeout_s: float) -> Block | None:
        if not self.streaming():
            time.sleep(min(timeout_s, 0.01))
            return None
        signals = self._signals()
        lost = 0
        while True:
            end = min(self._pos + self.block_n, signals.shape[1])
            due = self._t0 + (end - self._first) / self.sample_rate_hz / self.speed
            if not wait_until_due(due, self.speed, timeout_s):
                return None
            index = self._pos // self.block_n
            start, self._pos = self._pos, end
            if (self._point, index) in self.lose_blocks and end < signals.shape[1]:
                lost += end - start
                continue
            return Block(signals[:, start:end], start, lost, time.time())

    def point_recording(self, point: int) -> Recording:
        """The recording point ``point`` replays (for a test's truth)."""
        return replace(self.recordings[point - 1])
