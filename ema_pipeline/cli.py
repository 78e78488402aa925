"""Command-line interface of ema-pipeline (thin: parses, calls the library, prints).

Exit status: 0 success, 1 some input failed (the rest is still processed and
written), 2 usage error or unreadable configuration.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from ema_pipeline.data import ConfigError, DataError, EMAError

EXIT_OK, EXIT_INPUT, EXIT_USAGE = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on usage errors, which is our contract too."""


def _floats(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.replace(" ", "").split(",") if v)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    return values


def _cmd_simulate(args: argparse.Namespace) -> int:
    from ema_pipeline import acquisition, io, paper

    setup = acquisition.TestSetup()
    if args.fd_hz is None and args.configuration not in paper.CONFIGURATIONS:
        raise ConfigError(
            f"no Table 1 values for configuration {args.configuration!r} (known: "
            f"{', '.join(paper.CONFIGURATIONS)}); give --fd-hz and --zeta-pct for others"
        )
    if (args.fd_hz is None) != (args.zeta_pct is None) or (
        args.fd_hz is not None and len(args.fd_hz) != len(args.zeta_pct)
    ):
        raise ConfigError("--fd-hz and --zeta-pct go together, with one value per mode each")
    modes = acquisition.configuration_modes(
        args.configuration,
        fd_hz=args.fd_hz,
        zeta=None if args.zeta_pct is None else [z / 100 for z in args.zeta_pct],
        n_modes_total=setup.n_modes_total,
        high_mode_zeta=setup.high_mode_zeta,
    )
    snr = None if args.snr_db is not None and args.snr_db <= 0 else args.snr_db
    records = acquisition.simulate_time_records(
        modes, setup, snr_db=snr, seed=args.seed, configuration=args.configuration
    )
    frf = acquisition.estimate_frf(
        records, force_window_s=setup.force_window_s, exp_window_tau_s=setup.exp_window_tau_s
    )
    fmt = "h5" if args.format == "h5" else ("uff-binary" if args.binary else "uff")
    io.write_frf(frf, args.out, fmt, coherence=args.coherence)
    if args.time_records:
        io.write_time_uff(records, args.time_records, binary=args.binary)
    if not args.quiet:
        print(
            f"wrote {args.out}: {args.configuration}, {frf.n_out} FRFs x {frf.freq_hz.size} lines, "
            f"df = {frf.df_hz:.7g} Hz, {records.n_averages} averages, seed {args.seed}, "
            f"SNR {'none' if snr is None else f'{snr:g} dB'}"
        )
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="ema-pipeline",
        description="Experimental modal analysis: impact-test FRFs to modal parameters, "
        "modal and local added mass, and a report.",
    )
    from ema_pipeline import __version__

    parser.add_argument("--version", action="version", version=f"ema-pipeline {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser(
        "simulate",
        help="write one simulated impact test (FRFs) of the paper's cantilever",
        description="Simulate the paper's impact test (accelerometers at nodes 3 and 6, "
        "hammer at node 8, 16384 samples at 2000 Hz, 4 averages, force + exponential "
        "window, H1) and write the FRFs as UFF-58 or HDF5.",
    )
    p.add_argument(
        "--configuration",
        default="genuine",
        help="Table 1 configuration: genuine, larger_tank, smaller_tank "
        "(or any name with --fd-hz/--zeta-pct); default genuine",
    )
    p.add_argument("--format", choices=("uff", "h5"), default="uff", help="file format")
    p.add_argument("--binary", action="store_true", help="binary instead of ASCII UFF")
    p.add_argument("--out", required=True, type=Path, help="output file")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--snr-db",
        type=float,
        default=40.0,
        help="signal-to-noise ratio in dB per channel (default 40; 0 = noise-free)",
    )
    p.add_argument(
        "--fd-hz",
        type=_floats,
        default=None,
        help="damped natural frequencies, e.g. 18.1,112,327,629 (default: Table 1)",
    )
    p.add_argument(
        "--zeta-pct",
        type=_floats,
        default=None,
        help="damping ratios in percent, e.g. 0.5,0.67,0.29,0.38 (default: Table 1)",
    )
    p.add_argument(
        "--coherence",
        action="store_true",
        help="also write coherence records (function type 6) to a UFF file",
    )
    p.add_argument(
        "--time-records",
        type=Path,
        default=None,
        help="also write the raw time records to this UFF file",
    )
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=_cmd_simulate)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except DataError as exc:
        print(f"ema-pipeline {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except EMAError as exc:
        print(f"ema-pipeline {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"ema-pipeline {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
