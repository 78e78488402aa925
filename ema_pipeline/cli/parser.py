"""The argparse declarations of ``ema-pipeline``: :func:`build_parser`.

One sub-parser per subcommand (``simulate``, ``identify``, ``batch``, ``run``,
``fe``), each bound to its handler in :mod:`ema_pipeline.cli.commands`; the
options several subcommands share are added by the ``_add_*`` helpers. A usage
error is one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ema_pipeline.cli.commands import cmd_batch, cmd_fe, cmd_identify, cmd_run, cmd_simulate
from ema_pipeline.cli.support import EXIT_USAGE

__all__ = ["build_parser"]


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on usage errors, which is our contract too; the
    error is one line (no usage block)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _floats(text: str) -> tuple[float, ...]:
    """The argparse type of ``--expect``, ``--fd-hz``, ``--zeta-pct``: ``"1,2.5,3"``."""
    try:
        values = tuple(float(v) for v in text.replace(" ", "").split(",") if v)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    return values


def _add_identify_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--band",
        nargs=2,
        type=float,
        metavar=("LO_HZ", "HI_HZ"),
        default=None,
        help="frequency band in Hz (default: the whole axis above the first lines)",
    )
    p.add_argument(
        "--max-order",
        type=int,
        default=None,
        help="highest polynomial order of the stabilization diagram",
    )
    p.add_argument(
        "--method",
        choices=("plscf", "sdypy-lscf"),
        default="plscf",
        help="plscf (ours, default) or sdypy-lscf (sdypy-EMA's LSCF)",
    )
    p.add_argument(
        "--expect",
        type=_floats,
        default=None,
        metavar="F1,F2,...",
        help="approximate natural frequencies in Hz: pick the nearest stable modes",
    )
    p.add_argument(
        "--exp-window-tau",
        type=float,
        default=None,
        metavar="SECONDS",
        help="time constant of the exponential window applied to the responses, for "
        "files that do not record it (UFF has no field for it); the identified damping "
        "is corrected by 1/tau (default: the value stored in the file, else none)",
    )
    p.add_argument("--quiet", action="store_true", help="print only errors")
    _add_memory_limit(p)


def _add_memory_limit(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--memory-limit-gb",
        type=float,
        default=None,
        metavar="GB",
        help="refuse settings whose estimated memory exceeds this (GiB; default "
        "$EMA_MEMORY_LIMIT_GB or 4)",
    )


def _add_uff_and_verbose(p: argparse.ArgumentParser, where: str) -> None:
    p.add_argument(
        "--uff",
        action="store_true",
        help=f"also write the identified modes as Universal File {where} (datasets 164, "
        "15/82 where the geometry is known, 55 per mode, 58 with the synthesised FRFs)",
    )
    p.add_argument(
        "--verbose",
        action="store_true",
        help="say what the readers skip (e.g. UFF datasets other than 58/151/164)",
    )


def _add_no_figures(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--no-figures",
        action="store_true",
        help="write reports without figures (faster; for batch jobs and CI)",
    )


def build_parser() -> argparse.ArgumentParser:
    """The ``ema-pipeline`` parser; a subcommand's namespace has its handler as ``func``."""
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
        default=None,
        help="Table 1 configuration: genuine, larger_tank, smaller_tank "
        "(or any name with --fd-hz/--zeta-pct or --added-mass); default genuine "
        "(added_mass with a non-empty --added-mass)",
    )
    p.add_argument(
        "--added-mass",
        default=None,
        metavar="ELEMENT=FRACTION[,ELEMENT=FRACTION]",
        help="simulate the experiment's FE beam whose measurement elements (1-based, 10 = tip) "
        "carry extra mass, as a fraction of the element's mass, e.g. 10=0.3; frequencies and "
        "shapes from the FE model, damping from --zeta-pct or Table 1's genuine; 'none' is "
        "the genuine FE beam",
    )
    p.add_argument(
        "--experiment",
        type=Path,
        default=None,
        help="with --added-mass: experiment file giving the FE beam and sensor nodes "
        "(default raw_frf/experiment.toml if present, else the paper's beam)",
    )
    p.add_argument(
        "--format",
        choices=("uff", "h5"),
        default=None,
        help="file format (default: from the suffix of --out, .uff/.unv or .h5; "
        "a format that contradicts the suffix is an error)",
    )
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
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser(
        "identify",
        help="identify modal parameters of FRF files (pLSCF + LSFD)",
        description="Identify natural frequencies, damping ratios and mode shapes of each "
        "FRF file (UFF-58 or HDF5) with poly-reference LSCF, automatic pole selection and "
        "LSFD. Writes DIR/<stem>_modes.csv (mode,fn_hz,fd_hz,zeta_pct,fn_std_hz,"
        "zeta_std_pct) and DIR/<stem>_result.h5 (full result with stabilization data).",
    )
    p.add_argument("files", nargs="+", type=Path, metavar="FILE", help="FRF files")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="output folder")
    p.add_argument(
        "--report",
        action="store_true",
        help="also write DIR/<stem>_report.html per file (setup, FRFs and coherence, "
        "stabilization, modes with MPC, AutoMAC, shapes, fit, provenance)",
    )
    _add_no_figures(p)
    _add_identify_options(p)
    _add_uff_and_verbose(p, "DIR/<stem>_modes.uff")
    p.set_defaults(func=cmd_identify)

    p = sub.add_parser(
        "batch",
        help="identify every FRF file under a folder (parallel, resumable)",
        description="Run acquisition checks and identification on every UFF-58 and HDF5 "
        "file under FOLDER (recursively), in parallel; skip files whose content already "
        "has a complete result; record bad files in OUT/failures.csv and go on; write "
        "OUT/summary.csv. Exit status 1 if any file failed.",
    )
    p.add_argument("folder", type=Path, metavar="DIR", help="folder with FRF files")
    p.add_argument("--out", required=True, type=Path, metavar="OUT", help="output folder")
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local worker processes (default: number of cores)",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on an existing dask.distributed cluster, e.g. tcp://host:8786 "
        "(needs the [distributed] extra)",
    )
    p.add_argument("--force", action="store_true", help="recompute files with complete results")
    p.add_argument(
        "--report",
        action="store_true",
        help="also write OUT/report.html: status per file with failure reasons, modes per "
        "file, each mode's frequency across the files",
    )
    _add_no_figures(p)
    _add_identify_options(p)
    _add_uff_and_verbose(p, "OUT/.../<stem>_modes.uff")
    p.set_defaults(func=cmd_batch)

    p = sub.add_parser(
        "run",
        help="the whole study: identification, added mass, FE update, Tables 1-6, report",
        description="Run the study described by RAW/experiment.toml: identify every "
        "configuration (Table 1), modal added mass (Table 2), FE model, update and local "
        "added mass (Tables 3-6); write RESULTS/tables/*.csv, RESULTS/ema_results.h5, "
        "RESULTS/report.md, RESULTS/report.html and RESULTS/figures/*.svg (not with "
        "--no-figures). Every input is checked first: a bad experiment file, FRF file or "
        "setting exits with 2 and writes nothing. Exit status 1 when the study has problems "
        "(the incomplete results are written only if RESULTS does not exist yet) or on a "
        "runtime failure such as a full disk; RESULTS is replaced atomically and only by a "
        "complete run.",
    )
    p.add_argument(
        "--raw",
        type=Path,
        default=Path("raw_frf"),
        help="folder with experiment.toml and the FRF files (default raw_frf)",
    )
    p.add_argument(
        "--results",
        type=Path,
        default=Path("results"),
        help="output folder, replaced as a whole when the run ends (default results)",
    )
    p.add_argument(
        "--experiment",
        type=Path,
        default=None,
        help="experiment file (default RAW/experiment.toml)",
    )
    p.add_argument("--quiet", action="store_true", help="print only problems")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    _add_no_figures(p)
    _add_memory_limit(p)
    _add_uff_and_verbose(p, "RESULTS/modes/<configuration>.uff (with the beam's node coordinates)")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser(
        "fe",
        help="Tables 2-6 from a measured modal table (Table 1 form)",
        description="Take measured modal parameters in the Table 1 form (CSV with columns "
        "configuration,mode,fd_hz,zeta_pct; configuration 'genuine' plus modified ones) and "
        "write Tables 2-6 as CSV into DIR. The beam comes from the default experiment "
        "(raw_frf/experiment.toml) unless --experiment is given.",
    )
    p.add_argument("table1", type=Path, metavar="TABLE1.csv", help="measured modal table")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="output folder")
    p.add_argument("--experiment", type=Path, default=None, help="experiment file (TOML)")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=cmd_fe)
    return parser

