"""A sound-card DAQ as a live test's device, through the optional ``sounddevice``
package (PortAudio): ``ema-pipeline live --channels SHEET.csv --device
sounddevice[:NAME]``. The package is imported only when this device is chosen.

The channel sheet gives the plan as for ``frf``: one point per ``file`` (the
name only labels the point; nothing is read), and per row the sound card's
input ``channel`` (0-based), its ``role`` and DOF, ``scale`` (the physical value
of a full-scale sample, 1.0) and ``unit`` (the unit of that value: ``N``,
``g``, ``m/s^2``, ...). A block the driver reports with an input overflow is
delivered with ``lost`` set (samples were dropped before it), so that the hits
it touches are rejected.

Tested at the interface only (the tests have no sound card): a stand-in
``sounddevice`` module feeds it blocks.
"""

from __future__ import annotations

import queue
import time
from typing import Any

import numpy as np

from ema_pipeline.data import Channel, ConfigError
from ema_pipeline.io.channel_sheet import ChannelSheet
from ema_pipeline.live.device import BLOCK_S, Block, PlanPoint
from ema_pipeline.units import parse_unit_label

__all__ = ["SoundDeviceDevice"]


class SoundDeviceDevice:
    """Blocks from a sound card's inputs (module docstring)."""

    def __init__(self, sheet: ChannelSheet, *, device: str | None = None,
                 sample_rate_hz: float = 48000.0, block_s: float = BLOCK_S) -> None:
        try:
            import sounddevice
        except (ImportError, OSError) as exc:
            raise ConfigError(f"--device sounddevice needs the sounddevice package and "
                              f"PortAudio (pip install sounddevice): {exc}") from None
        self._sd = sounddevice
        self.device = device
        self.sample_rate_hz = float(sample_rate_hz)
        self.block_n = max(1, int(round(block_s * self.sample_rate_hz)))
        points, self._inputs, self._factors = [], [], []
        for k, file in enumerate(sheet.files(), start=1):
            rows = sorted(sheet.rows_of(file), key=lambda r: r.role != "force")
            channels, inputs, factors = [], [], []
            for r in rows:
                where = sheet.where(r)
                if not r.channel.isdigit():
                    raise ConfigError(f"{where}: channel {r.channel!r}: a sound card's input "
                                      "is a number (0, 1, ...)")
                try:
                    unit = parse_unit_label(r.unit)
                except ValueError as exc:
                    raise ConfigError(f"{where}: unit {r.unit!r}: {exc}; give the unit of a "
                                      "full-scale sample (N, g, m/s^2, ...)") from None
                if unit.signal is None:
                    raise ConfigError(f"{where}: unit {r.unit!r} is not a force, acceleration, "
                                      "velocity or displacement")
                channels.append(Channel(f"in{r.channel}", unit.signal, r.dof,
                                        abs(r.scale * unit.factor)))
                inputs.append(int(r.channel))
                factors.append(r.scale * unit.factor)
            dof = channels[0].dof
            points.append(PlanPoint(k, dof.label() if dof is not None else str(k),
                                    tuple(channels)))
            self._inputs.append(inputs)
            self._factors.append(np.array(factors)[:, None])
        self.plan = tuple(points)
        self._queue: queue.Queue[tuple[np.ndarray, bool]] = queue.Queue()
        self._stream: Any = None
        self._point = 0
        self._pos = 0

    def _callback(self, indata: np.ndarray, frames: int, when: Any, status: Any) -> None:
        self._queue.put((indata.copy(), bool(getattr(status, "input_overflow", False))))

    def start(self, point: int, first_sample: int = 0) -> None:
        self.stop()
        self._point, self._pos = point, first_sample
        n_in = max(max(i) for i in self._inputs) + 1
        self._stream = self._sd.InputStream(
            device=self.device, channels=n_in, samplerate=self.sample_rate_hz,
            blocksize=self.block_n, dtype="float32", callback=self._callback)
        self._stream.start()

    def streaming(self) -> bool:
        return self._stream is not None

    def stop(self) -> None:
        if self._stream is not None:
            self._stream.stop()
            self._stream.close()
            self._stream = None
        self._point = 0
        while not self._queue.empty():
            self._queue.get_nowait()

    def read(self, timeout_s: float) -> Block | None:
        if not self._point:
            time.sleep(min(timeout_s, 0.01))
            return None
        try:
            data, overflow = self._queue.get(timeout=timeout_s)
        except queue.Empty:
            return None
        k = self._point - 1
        out = data[:, self._inputs[k]].T.astype(float) * self._factors[k]
        start = self._pos
        lost = self.block_n if overflow else 0  # the driver does not say how many
        self._pos += out.shape[1] + lost
        return Block(out, start + lost, lost, time.time())
