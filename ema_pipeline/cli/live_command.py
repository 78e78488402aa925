"""``ema-pipeline live``: a live roving-hammer test in the browser (thin: parses,
calls :func:`ema_pipeline.live.app.run_live`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ema_pipeline.data import ConfigError

__all__ = ["add_live_parser", "cmd_live", "hammer_options"]


def add_live_parser(sub: Any) -> None:
    """Declare ``ema-pipeline live`` on ``sub`` (the subcommands' action)."""
    p = sub.add_parser(
        "live",
        help="a live roving-hammer impact test in the browser (replay or simulated device)",
        description="Run a roving-hammer impact test live in a local web page: every hit "
        "judged at once by the checks of frf, the running FRF and coherence of the point, "
        "the points so far identified after each point, the final identification at "
        "the finish. Everything is journaled in the session folder DIR "
        "(DIR/channels.csv and DIR/hits.toml for frf --channels ... --hits ...); the same "
        "command resumes it. Needs the live extra (pip install ema-pipeline[live]).",
    )
    p.add_argument("--channels", type=Path, default=None, metavar="SHEET.csv",
                   help="channel sheet of the test (the points and channels; --replay "
                   "streams its recordings)")
    p.add_argument("--geometry", type=Path, default=None, metavar="GEOM",
                   help="geometry (UFF 15/82 or CSV) for the point plan and the shapes")
    p.add_argument("--session", type=Path, required=True, metavar="DIR",
                   help="session folder: the journal, the recordings, channels.csv, hits.toml")
    dev = p.add_mutually_exclusive_group(required=True)
    dev.add_argument("--replay", action="store_true",
                     help="replay the sheet's recordings as if acquired")
    dev.add_argument("--simulate", default=None, metavar="MODEL",
                     help="a virtual structure struck with a virtual hammer: plate (built "
                     "in), the result file of identify (<stem>_result.h5) or a Universal "
                     "File of modes (datasets 55, identify --uff)")
    dev.add_argument("--device", default=None, metavar="NAME",
                     help="a DAQ: sounddevice or sounddevice:CARD (a sound card through the "
                     "optional sounddevice package; the sheet's channel column names its "
                     "inputs, scale and unit the value of a full-scale sample)")
    p.add_argument("--sample-rate", type=float, default=48000.0, metavar="HZ",
                   help="--device: the sample rate (default 48000)")
    p.add_argument("--speed", type=float, default=1.0, metavar="X",
                   help="multiple of real time of the device's clock (default 1; inf: "
                   "as fast as possible)")
    p.add_argument("--band", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="band of the identification in Hz (as identify --band)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this computer only)")
    p.add_argument("--port", type=int, default=8750, help="port (0: a free one; default 8750)")
    p.add_argument("--seed", type=int, default=None, help="seed of the simulated noise")
    p.add_argument("--double-hit", type=int, nargs="+", default=(), metavar="N",
                   help="--simulate: these strikes (numbered through the session from 1) "
                   "bounce: a double hit")
    p.add_argument("--force-scatter", type=float, default=0.1, metavar="S",
                   help="--simulate: hit peaks scattered by U(1 - S, 1 + S) (default 0.1)")
    p.add_argument("--clip-n", type=float, default=None, metavar="N",
                   help="--simulate: the force channel clips at this level (an overload)")
    p.add_argument("--noise", type=float, default=1e-4, metavar="R",
                   help="--simulate: white noise, this share of the peaks (default 1e-4)")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    p.set_defaults(func=cmd_live)


def hammer_options(args: argparse.Namespace) -> dict[str, Any]:
    """The virtual hammer's options (:class:`ema_pipeline.live.simulate.SimulateDevice`)
    from the command line."""
    if args.force_scatter < 0 or args.force_scatter >= 1:
        raise ConfigError(f"--force-scatter must be 0 to < 1, got {args.force_scatter:g}")
    if args.noise < 0:
        raise ConfigError(f"--noise must be >= 0, got {args.noise:g}")
    if args.clip_n is not None and not args.clip_n > 0:
        raise ConfigError(f"--clip-n must be > 0 (N), got {args.clip_n:g}")
    return {"double_hits": tuple(args.double_hit), "scatter": args.force_scatter,
            "clip_n": args.clip_n, "noise": args.noise}


def cmd_live(args: argparse.Namespace) -> int:
    """``live``: start the device, the session and the page; serve until Ctrl-C."""
    try:
        import starlette  # noqa: F401
        import uvicorn  # noqa: F401
    except ImportError:
        raise ConfigError("ema-pipeline live needs starlette and uvicorn: pip install "
                          "'ema-pipeline[live]'") from None
    from ema_pipeline.live.app import make_device, run_live

    geometry = None
    if args.geometry is not None:
        from ema_pipeline.io import read_geometry

        geometry = read_geometry(args.geometry)
    device, title = make_device(args.channels, replay=args.replay, speed=args.speed,
                                simulate=args.simulate, seed=args.seed,
                                hammer=hammer_options(args), daq=args.device,
                                sample_rate_hz=args.sample_rate, geometry=geometry)
    band = tuple(args.band) if args.band is not None else None
    return run_live(device, title, args.session, geometry=geometry, band_hz=band,
                    host=args.host, port=args.port, browser=not args.no_browser,
                    say=lambda line: print(line, flush=True))
