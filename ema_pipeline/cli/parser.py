"""The argparse declarations of ``ema-pipeline``: :func:`build_parser`.

One sub-parser per subcommand (``simulate``, ``identify``, ``batch``, ``run``,
``fe``), each bound to its handler in :mod:`ema_pipeline.cli.commands`; the
options several subcommands share are added by the ``_add_*`` helpers. A usage
error is one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import difflib
import sys
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from ema_pipeline.cli.commands import (
    cmd_batch,
    cmd_fe,
    cmd_identify,
    cmd_init,
    cmd_run,
    cmd_simulate,
)
from ema_pipeline.cli.frf_command import add_frf_parser
from ema_pipeline.cli.live_command import add_live_parser
from ema_pipeline.cli.support import EXIT_INPUT
from ema_pipeline.identification.options import MAX_ORDER, METHOD_NAMES, MIN_ORDER
from ema_pipeline.paths import DEFAULT_RAW_FOLDER

__all__ = ["MODES_CSV_HELP", "build_parser"]

#: The columns of ``<stem>_modes.csv`` as ``identify --help`` lists them (README
#: "Identification" documents the rules; tests check this against a real table).
MODES_CSV_HELP = """
  mode              1, 2, ... (ascending frequency)
  fn_hz, fd_hz      undamped and damped natural frequency, Hz
  zeta_pct          damping ratio, per cent
  fn_std_hz         standard deviation of fn_hz, Hz
  zeta_std_pct      standard deviation of zeta_pct, per cent
  mpc               modal phase collinearity (1 = real mode)
  mpd_deg           mean phase deviation, degrees (0 = real mode)
  stable_from_order lowest model order at which the pole is stable
  n_stable_orders   how many orders of the diagram hold it (0: found outside the
                    stored diagram, see found_by)
  found_by          how it was found: diagram, other_order (the band's diagram at
                    another order), window (a narrower search), alternate, partner,
                    residual, expected or picked
  selection         who chose it: auto, picked (--picks) or expected (it answers
                    an --expect guess)
  doubtful          True when a rule marks it for a second look (kept, never dropped)
  doubtful_reason   which rule fired (empty when not doubtful)
  expect_hz         with --expect: the guess the mode answers (a guess not found
                    gets a row of its own with the other columns empty)
"""


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on usage errors, which is our contract too; the
    error is one line (no usage block). An unknown option or subcommand gets the
    closest known one as a suggestion (``--bnad`` -> ``did you mean --band?``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.known_options: list[str] = []  # every option string, for suggestions
        self.commands: Mapping[str, argparse.ArgumentParser] = {}  # set by build_parser
        super().__init__(*args, **kwargs)

    def add_argument(self, *args: Any, **kwargs: Any) -> argparse.Action:
        action = super().add_argument(*args, **kwargs)
        self.known_options.extend(action.option_strings)
        return action

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        self.argv = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_INPUT, f"{self.prog}: error: {message}{self.suggestion(message)}\n")

    def suggestion(self, message: str) -> str:
        """``"; did you mean --band?"`` for an unknown option (or subcommand) close
        to a known one, among the options of the subcommand named on the line."""
        argv = getattr(self, "argv", [])
        if message.startswith("argument COMMAND: invalid choice"):
            unknown, known = [a for a in argv if not a.startswith("-")][:1], list(self.commands)
        elif message.startswith("unrecognized arguments"):
            command = next((self.commands[a] for a in argv if a in self.commands), self)
            known = getattr(command, "known_options", self.known_options)
            unknown = [a.split("=", 1)[0] for a in message.split(":", 1)[1].split()
                       if a.startswith("--")]
        else:
            return ""
        hints = []
        for word in unknown:
            close = difflib.get_close_matches(word, known, n=1, cutoff=0.6)
            if close:
                hints.append(f"{word} -> {close[0]}" if len(unknown) > 1 else close[0])
        return f"; did you mean {', '.join(hints)}?" if hints else ""


class _Numbers(argparse.Action):
    """A list option (``--expect``, ``--fd-hz``, ``--zeta-pct``): ``17,69`` or
    ``17 69`` (several arguments), stored as one flat tuple of floats."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        setattr(namespace, self.dest, tuple(v for group in values for v in group))


def _numbers(text: str) -> tuple[float, ...]:
    """The argparse type of one argument of a list option: ``"17"`` or ``"17,69"``.
    Anything else (``"17 69"`` in one argument, ``"1 7"``, ``"17,,69"``) is an
    error, never read as 1769 or 17.

    Examples
    --------
    >>> _numbers("18,112.5"), _numbers("20")
    ((18.0, 112.5), (20.0,))
    """
    parts = text.split(",")
    try:
        if any(not p or p != p.strip() for p in parts):
            raise ValueError
        return tuple(float(p) for p in parts)
    except ValueError:
        hint = " (give file names before this option)" if "/" in text or (
            "." in text and not any(c.isdigit() for c in text)) else ""
        raise argparse.ArgumentTypeError(
            f"expected numbers separated by commas or spaces (17,69 or 17 69), got {text!r}{hint}"
        ) from None


def _add_numbers(p: argparse.ArgumentParser, flag: str, help: str) -> None:
    p.add_argument(flag, type=_numbers, nargs="+", action=_Numbers, default=None,
                   metavar="X", help=help + "; give them as 17,69 or as 17 69")


def _add_workers(p: argparse.ArgumentParser, what: str) -> None:
    """``--workers N`` (default: ``$EMA_PIPELINE_WORKERS``, else the cores)."""
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help=f"{what} (default: $EMA_PIPELINE_WORKERS, else the cores this "
                   "process may use; 1 runs everything in this process)")


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
        help="highest polynomial order of the stabilization diagram (fixed; "
        + ", ".join(f"at least {low} for {name}" for name, low in MIN_ORDER.items())
        + f", at most {MAX_ORDER}; default: the adaptive order search). A fixed order "
        "also turns off the narrower searches (a wide band's lowest part, a dense band's "
        "windows), which run with the adaptive order only: identify warns where they would "
        "have run",
    )
    p.add_argument(
        "--method",
        choices=METHOD_NAMES,
        default=METHOD_NAMES[0],
        help="plscf (ours, default) or sdypy-lscf (sdypy-EMA's LSCF)",
    )
    _add_numbers(p, "--expect", "approximate natural frequencies in Hz: pick the nearest "
                 "stable modes (answered from the automatic selection, narrower searches "
                 "included; without refinement the narrower searches are off)")
    p.add_argument(
        "--exp-window-tau",
        type=float,
        default=None,
        metavar="SECONDS",
        help="time constant of the exponential window applied to the responses, for "
        "files that do not record it (UFF has no field for it); the identified damping "
        "is corrected by 1/tau (default: the value stored in the file, else none)",
    )
    p.add_argument(
        "--no-window-search",
        action="store_true",
        help="do not search a dense band again in windows of consecutive candidates: "
        "faster on a band of many modes, but a weak mode between strong ones, or one "
        "whose full-band pole fails the final tests, may be missed (what it saves and "
        "misses on the measured beam: the validation page of the documentation)",
    )
    p.add_argument(
        "--no-accept",
        action="store_true",
        help="keep every candidate the stabilization diagrams select, untested: skip the "
        "final tests (decay rate determined, a resonance of the data, not one mode twice), "
        "the close partners, the residual search and the list of resonances not kept; the "
        "poles are still refined. For a look at the raw selection, not for results",
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
        "$EMA_PIPELINE_MEMORY_LIMIT_GB or 4)",
    )


def _add_uff_and_verbose(p: argparse.ArgumentParser, where: str, geometry: str) -> None:
    p.add_argument(
        "--uff",
        action="store_true",
        help=f"also write the identified modes as Universal File {where} (datasets 164, "
        f"{geometry}55 per mode, 58 with the synthesised FRFs)",
    )
    p.add_argument(
        "--verbose",
        action="store_true",
        help="say what the readers skip (e.g. UFF datasets other than 58/151/164)",
    )


#: The default of ``--geometry`` of ``identify`` and ``batch``.
_GEOMETRY_FROM_FILE = "the geometry in the FRF file"


def _add_geometry(p: argparse.ArgumentParser, what: str, default: str = _GEOMETRY_FROM_FILE
                  ) -> None:
    p.add_argument(
        "--geometry",
        type=Path,
        default=None,
        metavar="FILE",
        help=f"test geometry (UFF datasets 15 or 2411 with nodes, 82 with trace lines) to "
        f"animate the mode shapes on in {what}; default: {default}",
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
    parser.commands = sub.choices

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
        help="signal-to-noise ratio in dB per channel (default 40; 0 = noise-free; a "
        "negative value adds noise stronger than the signal)",
    )
    _add_numbers(p, "--fd-hz", "damped natural frequencies in Hz, e.g. 18.1,112,327,629 "
                 "(default: Table 1)")
    _add_numbers(p, "--zeta-pct", "damping ratios in percent, e.g. 0.5,0.67,0.29,0.38 "
                 "(default: Table 1)")
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
        description=textwrap.fill(
            "Identify natural frequencies, damping ratios and mode shapes of each FRF file "
            "(UFF-58 or HDF5) with poly-reference LSCF, automatic pole selection and LSFD. "
            "Writes DIR/<stem>_result.h5 (full result with stabilization data) and "
            "DIR/<stem>_modes.csv, one row per mode with the columns:", 78,
        ) + MODES_CSV_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("files", nargs="+", type=Path, metavar="FILE", help="FRF files")
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="output folder")
    p.add_argument(
        "--report",
        action="store_true",
        help="also write DIR/<stem>_report.html per file (setup, FRFs and coherence, "
        "stabilization, modes with MPC, AutoMAC and shapes when a shape has 3 or more "
        "points, fit, provenance)",
    )
    _add_no_figures(p)
    _add_geometry(p, "the report (with --report)")
    p.add_argument(
        "--picks",
        type=Path,
        default=None,
        metavar="PICKS.toml",
        help="fit exactly the poles of this picks file (written by the report's interactive "
        "stabilization diagram; it sets the band and the orders) instead of the automatic "
        "selection; a pick that matches no pole is an error",
    )
    _add_identify_options(p)
    _add_workers(p, "worker processes: several files side by side, or one file's windows "
                 "and fits")
    _add_uff_and_verbose(p, "DIR/<stem>_modes.uff", "")
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
    _add_workers(p, "local worker processes, one file each")
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
        "file, each mode's frequency across the files; and per file its identify report "
        "page (OUT/.../<stem>_report.html, linked from it)",
    )
    _add_geometry(p, "the per-file report pages (with --report)")
    _add_no_figures(p)
    _add_identify_options(p)
    _add_uff_and_verbose(p, "OUT/.../<stem>_modes.uff", "")
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
        default=Path(DEFAULT_RAW_FOLDER),
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
    _add_geometry(p, "the report", "the experiment's [geometry], else its FE beam")
    _add_memory_limit(p)
    _add_workers(p, "worker processes of each configuration's identification")
    _add_uff_and_verbose(p, "RESULTS/modes/<configuration>.uff", "15 and 82 with the beam's "
                         "node coordinates, ")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser(
        "init",
        help="write a commented experiment-file template for your own test, or the example "
        "study (--example)",
        description="Write DIR/experiment.toml, a commented template of an experiment file "
        "for any structure: test metadata (object, date, operator, equipment), geometry, "
        "roving and fixed DOFs, identification settings and two configurations. Put the FRF "
        "and geometry files beside it (or edit the names), then `ema-pipeline run --raw DIR`. "
        "The FE, update and added-mass stages run only where the file has a [beam] table. "
        "With --example: the example study instead, ready to run.",
    )
    p.add_argument("folder", type=Path, metavar="DIR", help="folder for experiment.toml "
                   "(created if needed)")
    p.add_argument("--force", action="store_true", help="overwrite an existing experiment.toml "
                   "(with --example: the example's files)")
    p.add_argument("--example", action="store_true",
                   help="write the example study instead: DIR/raw_frf/ with its experiment.toml "
                   "and three simulated impact tests of a steel cantilever in air and partly "
                   "immersed (genuine.uff, larger_tank.h5, smaller_tank.uff); then `cd DIR && "
                   "ema-pipeline run` runs the whole study into DIR/results")
    p.add_argument("--recordings", type=Path, default=None, metavar="RECORDINGS",
                   help="also write DIR/channels.csv, a channel-sheet template with one row "
                   "per channel of every recording under RECORDINGS (names, roles and the "
                   "units the files give; complete node and direction), and make the "
                   "experiment file's test that sheet ([recordings] channels)")
    p.set_defaults(func=cmd_init)

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
    add_frf_parser(sub)  # ema-pipeline frf (cli/frf_command.py)
    add_live_parser(sub)  # ema-pipeline live (cli/live_command.py)
    return parser

