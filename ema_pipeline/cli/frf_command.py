"""``ema-pipeline frf``: raw impact recordings to checked, averaged FRFs.

:func:`add_frf_parser` declares the subcommand (called by
:func:`ema_pipeline.cli.parser.build_parser`); :func:`cmd_frf` runs
:func:`ema_pipeline.pipeline.frf.frf_from_files` and prints the hits, the
record length, the windows and the usable band.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ema_pipeline.cli.commands import check_output_file
from ema_pipeline.cli.support import EXIT_OK
from ema_pipeline.data import ConfigError
from ema_pipeline.validation import nonzero

__all__ = ["add_frf_parser", "cmd_frf"]


def _pairs(values: list[str] | None, option: str, number: bool) -> dict:
    """``CHANNEL=VALUE`` options as a dict (a bad item is a ConfigError)."""
    out: dict = {}
    for item in values or []:
        name, sep, value = item.rpartition("=")
        if not sep or not name or not value:
            raise ConfigError(f"{option} expects CHANNEL=VALUE, got {item!r}")
        if number:
            try:
                factor = float(value)
            except ValueError:
                raise ConfigError(f"{option} {item!r}: {value!r} is not a number") from None
            out[name] = nonzero(f"{option} {item!r}: the factor", factor)
        else:
            out[name] = value
    return out


def _tau(text: str) -> str | float:
    """The argparse type of ``--exp-window-tau``: a number of seconds as a float,
    else the word in lower case (``auto``, ``none``); FRFSettings checks the
    value (:func:`ema_pipeline.acquisition.frf_settings.exp_window_tau`)."""
    try:
        return float(text)
    except ValueError:
        return text.strip().lower()


def _estimator(text: str) -> str:
    """The argparse type of ``--estimator``: H1, H2 or Hv in any letter case."""
    return {"h1": "H1", "h2": "H2", "hv": "Hv"}.get(text.strip().lower(), text)


def add_frf_parser(sub: Any) -> None:
    """Declare ``ema-pipeline frf`` on ``sub``, the subcommands' action of the
    ``ema-pipeline`` parser (``parser.add_subparsers()``)."""
    p = sub.add_parser(
        "frf",
        help="raw impact recordings to checked, averaged FRFs (hits found and checked)",
        description="Read impact recordings (UFF-58 time records, TDMS, WAV, CSV, LabVIEW "
        ".lvm, MATLAB v5 .mat; several files are segments of one test), find the hits on "
        "the force channel, check them "
        "(double_hit, overload, not_decayed, low_force, outlier, past_end), average the "
        "accepted ones into FRFs with coherence and write FILE (.h5 or .uff) and "
        "<stem>_hits.csv beside it.",
    )
    p.add_argument("inputs", nargs="*", type=Path, metavar="INPUT",
                   help="recordings (.uff/.unv, .tdms, .wav, .csv, .lvm, .mat; segments of "
                   "one test); or give --channels")
    p.add_argument("--channels", type=Path, default=None, metavar="SHEET.csv",
                   help="channel sheet (file,channel,role,node,direction,scale,unit; one "
                   "row per channel per file): every file it names is one point of a "
                   "roving test, assembled into one FRF set with the sheet's DOFs (a "
                   "roving-hammer test over the hammer points, by reciprocity)")
    p.add_argument("--out", required=True, type=Path, metavar="FILE",
                   help="FRF file to write (.h5 or .uff)")
    p.add_argument("--pretrigger-s", type=float, default=None, metavar="S",
                   help="time kept before each trigger crossing (default 0.01 s)")
    p.add_argument("--record-length-s", type=float, default=None, metavar="S",
                   help="record length (default: the longest power-of-two record that fits "
                   "between hits)")
    p.add_argument("--force-window-s", type=float, default=None, metavar="S",
                   help="force window length from the record start, then a 10 ms taper "
                   "(0 = none; default the pretrigger + 0.05 s)")
    p.add_argument("--exp-window-tau", type=_tau, default="auto", metavar="auto|none|SECONDS",
                   help="exponential window on force and responses: auto (the response "
                   "decays to about 1 %% at the record end), none (records that have not "
                   "decayed are rejected), or a time constant in s; stored with the FRFs")
    p.add_argument("--estimator", type=_estimator, choices=("H1", "H2", "Hv"), default="H1",
                   help="FRF estimator (default H1)")
    p.add_argument("--keep-all", action="store_true",
                   help="average every hit that has a record, even rejected ones")
    p.add_argument("--force-channel", default=None, metavar="NAME",
                   help="name or position of the force channel (default: the one channel "
                        "in a force unit; of several, the one named force)")
    p.add_argument("--scale", action="append", default=None, metavar="CHANNEL=FACTOR",
                   help="multiply a channel by FACTOR (e.g. WAV counts to units; repeatable)")
    p.add_argument("--unit", action="append", default=None, metavar="CHANNEL=UNIT",
                   help="unit of a channel after scaling (e.g. N, g, m/s^2; repeatable)")
    p.add_argument("--report", action="store_true",
                   help="also write the hit page <stem>_hits.html: every hit with its force "
                   "pulse, force spectrum, response and windows, and why it was kept or not; "
                   "the hits to choose by hand per point (file), each point's average and "
                   "coherence, and a hits.toml for --hits; the averaged FRF with coherence "
                   "and the usable band")
    p.add_argument("--hits", type=Path, default=None, metavar="HITS.toml",
                   help="average exactly the hits chosen by hand ([[recording]] tables "
                   "with file and accepted hit numbers), whatever the checks say")
    p.add_argument("--quiet", action="store_true", help="print only errors")
    p.set_defaults(func=cmd_frf)


def cmd_frf(args: argparse.Namespace) -> int:
    """``frf``: find, check and average the hits; write the FRFs and the hit table."""
    from ema_pipeline.pipeline.frf import (
        DEFAULT_PRETRIGGER_S,
        FRFSettings,
        check_output,
        frf_from_files,
        hits_csv_path,
        hits_report_path,
    )

    if (args.channels is None) == (not args.inputs):
        raise ConfigError("give the recordings (INPUT ...) or a channel sheet (--channels "
                          "SHEET.csv), not both" if args.inputs else
                          "give the recordings (INPUT ...) or a channel sheet (--channels "
                          "SHEET.csv)")
    if args.channels is not None:
        given = [o for o, v in (("--force-channel", args.force_channel), ("--scale", args.scale),
                                ("--unit", args.unit)) if v]
        if given:
            raise ConfigError(f"{', '.join(given)}: not with --channels (the sheet gives the "
                              "force channel, scales and units)")
    else:
        check_output(args.out, list(args.inputs), report=args.report)  # before any work
    check_output_file(args.out, "--out")  # a loop, a read-only folder: before any work
    settings = FRFSettings(  # ranges checked here, before any work
        pretrigger_s=DEFAULT_PRETRIGGER_S if args.pretrigger_s is None else args.pretrigger_s,
        record_length_s=args.record_length_s,
        force_window_s=args.force_window_s,
        exp_window_tau=args.exp_window_tau,
        estimator=args.estimator,
        keep_all=args.keep_all,
    )
    scale = _pairs(args.scale, "--scale", number=True) or None
    units = _pairs(args.unit, "--unit", number=False) or None
    choice = None
    if args.hits is not None:
        from ema_pipeline.io.hit_choice import read_hit_choice

        choice = read_hit_choice(args.hits)
    if args.channels is not None:
        return _frf_from_sheet(args, settings, choice)
    chosen = None
    if choice is not None:
        if len(choice) != 1:
            raise ConfigError(f"{args.hits}: names {len(choice)} recordings; a plain frf "
                              "takes one [[recording]] (several: a channel sheet, --channels)")
        chosen = next(iter(choice.values()))
    result = frf_from_files(list(args.inputs), args.out, settings,
                            force_channel=args.force_channel, scale=scale, units=units,
                            report=args.report, chosen=chosen)
    for warning in result.warnings:  # also with --quiet: they question the data
        print(f"warning: {warning}", file=sys.stderr)
    if not args.quiet:
        rejected = [h for h in result.hits if not h.accepted or h.reasons]
        print(f"{len(result.hits)} hits found, {result.n_accepted} averaged; records of "
              f"{result.n_samples} samples ({result.record_length_s:.4g} s)")
        kept = "kept by hand (--hits)" if result.chosen_by_hand else "kept (--keep-all)"
        for h in rejected:
            state = kept if h.accepted else "rejected"
            print(f"  hit {h.index} at {h.time_s:.3f} s: {state}: {h.reasons_text()}")
        tau = result.exp_window_tau_s
        fw = result.force_window_s
        f10, f20 = result.force_band_hz
        print(f"windows: force {'none' if not fw else f'{fw:g} s'}, exponential "
              f"{'none' if tau is None else f'tau = {tau:.4g} s'}; estimator {args.estimator}")
        print(f"usable band (force spectrum): -10 dB at {f10:.5g} Hz, -20 dB at {f20:.5g} Hz")
        extra = f" and {hits_report_path(args.out)}" if args.report else ""
        print(f"wrote {args.out}, {hits_csv_path(args.out)}{extra}")
    return EXIT_OK


def _frf_from_sheet(args: argparse.Namespace, settings: Any, choice: Any = None) -> int:
    """``frf --channels SHEET``: one FRF set from every file the sheet names."""
    from ema_pipeline.pipeline.frf import hits_csv_path, hits_report_path
    from ema_pipeline.pipeline.roving import frf_from_sheet

    result = frf_from_sheet(args.channels, args.out, settings, report=args.report,
                            chosen=choice)
    for name, point in zip(result.files, result.points, strict=True):
        for warning in point.warnings:
            print(f"warning: {name}: {warning}", file=sys.stderr)
    if not args.quiet:
        frf = result.frf
        counts = sorted({p.n_accepted for p in result.points})
        each = f"{counts[0]}" + (f"-{counts[-1]}" if len(counts) > 1 else "")
        print(f"{len(result.points)} files, {result.n_accepted} hits averaged ({each} per "
              f"point); records of {result.n_samples} samples ({result.record_length_s:.4g} s)")
        for name, point in zip(result.files, result.points, strict=True):
            kept = "kept by hand (--hits)" if point.chosen_by_hand else "kept (--keep-all)"
            for h in point.hits:
                if not h.accepted or h.reasons:
                    state = kept if h.accepted else "rejected"
                    print(f"  {name} hit {h.index} at {h.time_s:.3f} s: {state}: "
                          f"{h.reasons_text()}")
        tau, fw = result.exp_window_tau_s, result.force_window_s
        print(f"windows: force {'none' if not fw else f'{fw:g} s'}, exponential "
              f"{'none' if tau is None else f'tau = {tau:.4g} s'} (common to every file)")
        if result.layout == "roving hammer":
            print(f"roving hammer: {frf.n_out} hammer points x {frf.n_in} fixed response(s), "
                  "stored by reciprocity (responses = hammer points: shapes over them)")
        else:
            print(f"roving sensor: {frf.n_out} responses x {frf.n_in} hammer point(s)")
        f10, f20 = result.force_band_hz
        print(f"usable band (force spectrum): -10 dB at {f10:.5g} Hz, -20 dB at {f20:.5g} Hz")
        extra = f" and {hits_report_path(args.out)}" if args.report else ""
        print(f"wrote {args.out}, {hits_csv_path(args.out)}{extra}")
    return EXIT_OK
