"""What ``ema-pipeline live`` runs: the device chosen, the test started on its
session folder, the server, the address printed (and the browser opened)."""

from __future__ import annotations

import os
import webbrowser
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ema_pipeline.data import ConfigError, Geometry
from ema_pipeline.io.live_session import SessionFolder
from ema_pipeline.live.device import Device
from ema_pipeline.live.engine import LiveTest

__all__ = ["make_device", "run_live"]


def make_device(channels: Path | None, *, replay: bool, speed: float = 1.0,
                simulate: str | None = None, seed: int | None = None,
                hammer: Mapping[str, Any] | None = None, daq: str | None = None,
                sample_rate_hz: float = 48000.0,
                geometry: Geometry | None = None) -> tuple[Device, str]:
    """The device and a title: the replay of a channel sheet's recordings, a
    virtual structure (``simulate``: ``plate`` or a Universal File of modes, on
    ``geometry``: :func:`~ema_pipeline.live.simulate.simulate_model`) struck with
    the virtual hammer's options ``hammer``
    (:class:`~ema_pipeline.live.simulate.SimulateDevice`), or a DAQ (``daq``:
    ``sounddevice`` or ``sounddevice:CARD``,
    :class:`~ema_pipeline.live.soundcard.SoundDeviceDevice`, imported only then).

    Examples
    --------
    >>> device, title = make_device(None, replay=False, simulate="plate", seed=1)
    >>> title, len(device.plan), device.plan[0].label
    ('simulated plate', 12, '1-Z')
    """
    if daq is not None:
        kind, _, card = daq.partition(":")
        if kind != "sounddevice":
            raise ConfigError(f"--device {daq!r}: the DAQ backend is sounddevice "
                              "(sounddevice or sounddevice:CARD)")
        if channels is None:
            raise ConfigError("--device needs the channel sheet of the test: give "
                              "--channels SHEET.csv")
        if not (sample_rate_hz > 0):
            raise ConfigError(f"--sample-rate must be > 0 Hz, got {sample_rate_hz:g}")
        from ema_pipeline.io.channel_sheet import read_channel_sheet
        from ema_pipeline.live.soundcard import SoundDeviceDevice

        return (SoundDeviceDevice(read_channel_sheet(channels), device=card or None,
                                  sample_rate_hz=sample_rate_hz),
                f"sound card {card or '(default)'}")
    if replay:
        from ema_pipeline.io.channel_sheet import read_channel_sheet
        from ema_pipeline.live.device import ReplayDevice

        if channels is None:
            raise ConfigError("--replay streams the recordings of a channel sheet: give "
                              "--channels SHEET.csv")
        if not (speed > 0):
            raise ConfigError(f"--speed must be > 0 (a multiple of real time), got {speed:g}")
        return ReplayDevice(read_channel_sheet(channels), speed=speed), f"replay of {channels}"
    if simulate is not None:
        from ema_pipeline.live.simulate import SimulateDevice, simulate_model

        model = simulate_model(simulate, geometry)
        if not (speed > 0):
            raise ConfigError(f"--speed must be > 0 (a multiple of real time), got {speed:g}")
        return (SimulateDevice(model, speed=speed, seed=seed, **dict(hammer or {})),
                f"simulated {model.name}")
    raise ConfigError("choose the device: --replay, --simulate MODEL or --device NAME")


def default_geometry(device: Device) -> Geometry | None:
    """The geometry a device brings (a virtual structure's), else None.

    Examples
    --------
    >>> device, _ = make_device(None, replay=False, simulate="plate")
    >>> default_geometry(device).n_nodes
    13
    """
    model = getattr(device, "model", None)
    return getattr(model, "geometry", None)


def run_live(device: Device, title: str, session: Path, *, geometry: Geometry | None = None,
             band_hz: tuple[float, float] | None = None, host: str = "127.0.0.1",
             port: int = 0, browser: bool = True,
             say: Callable[[str], None] = print) -> int:
    """Run the test until interrupted; prints the page's address first."""
    from ema_pipeline.live.server import LiveServer

    if geometry is None:
        geometry = default_geometry(device)
    if band_hz is None:
        band_hz = getattr(getattr(device, "model", None), "band_hz", None)
    test = LiveTest(device, SessionFolder(session), band_hz=band_hz, geometry=geometry)
    test.start()
    try:
        server = LiveServer(test, title, host=host, port=port)
        say(f"live test ({title}), session {session}: open {server.url}")
        say("stop with Ctrl-C; the same command resumes the session")
        if browser and not os.environ.get("EMA_PIPELINE_NO_BROWSER"):
            webbrowser.open(server.url)
        server.serve()
    finally:
        test.close()
    return 0
