"""Command-line interface of ema-pipeline (thin: parses, calls the library, prints).

Exit status: 0 success; 2 input or usage error (bad option, bad experiment
file, unreadable or implausible input file, settings the data cannot support);
1 runtime failure (disk full, out of memory, a study with problems, a batch with
failed files). Every error is one line on stderr; warnings of the libraries
(numpy, h5py, pyuff, sdypy) go to the ``py.warnings`` log (a file when
``EMA_PIPELINE_LOG`` names one), not to the terminal.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ema_pipeline.data import ConfigError, DataError, EMAError

if TYPE_CHECKING:  # pragma: no cover
    from ema_pipeline.data import FRFSet, TimeRecords
    from ema_pipeline.identification.options import IdentificationOptions

EXIT_OK, EXIT_INPUT, EXIT_USAGE = 0, 1, 2
EXIT_RUNTIME = EXIT_INPUT  # 1: runtime failure; input errors exit with EXIT_USAGE (2)
#: Environment variable naming a log file for library warnings (default: discarded).
LOG_ENV = "EMA_PIPELINE_LOG"


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on usage errors, which is our contract too; the
    error is one line (no usage block)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _capture_warnings() -> None:
    """Route ``warnings`` (numpy, h5py, pyuff, sdypy) into the ``py.warnings``
    logger: a file when ``$EMA_PIPELINE_LOG`` is set, else nowhere."""
    logging.captureWarnings(True)
    log = logging.getLogger("py.warnings")
    log.propagate = False
    if not log.handlers:
        target = os.environ.get(LOG_ENV)
        handler: logging.Handler = logging.NullHandler()
        if target:
            try:
                handler = logging.FileHandler(target, delay=True)
            except OSError:
                pass
        log.addHandler(handler)


def _verbose_logging() -> None:
    """``--verbose``: the package's INFO messages (skipped UFF datasets, ...) on stderr."""
    log = logging.getLogger("ema_pipeline")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("ema-pipeline: %(message)s"))
    log.addHandler(handler)
    log.setLevel(logging.INFO)


def _floats(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.replace(" ", "").split(",") if v)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    return values


def _cmd_simulate(args: argparse.Namespace) -> int:
    from ema_pipeline import acquisition, paper
    from ema_pipeline.pipeline.simulate import paper_modes

    if args.added_mass is not None:
        return _simulate_added_mass(args)
    setup = acquisition.TestSetup()
    if args.experiment is not None:
        raise ConfigError("--experiment goes with --added-mass (the experiment's FE beam)")
    args.configuration = args.configuration or "genuine"
    if args.fd_hz is None and args.configuration not in paper.CONFIGURATIONS:
        raise ConfigError(
            f"no Table 1 values for configuration {args.configuration!r} (known: "
            f"{', '.join(paper.CONFIGURATIONS)}); give --fd-hz and --zeta-pct for others"
        )
    if (args.fd_hz is None) != (args.zeta_pct is None) or (
        args.fd_hz is not None and len(args.fd_hz) != len(args.zeta_pct)
    ):
        raise ConfigError("--fd-hz and --zeta-pct go together, with one value per mode each")
    if args.fd_hz is None:
        modes = paper_modes(args.configuration, setup)
    else:
        modes = acquisition.configuration_modes(
            args.configuration,
            fd_hz=args.fd_hz,
            zeta=[z / 100 for z in args.zeta_pct],
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
    _write_simulated(args, records, frf, snr)
    return EXIT_OK


def _simulate_format(out: Path, fmt: str | None, binary: bool) -> str:
    """The format ``simulate`` writes: ``--format`` or the suffix of ``--out``; a
    contradiction between them (or ``--binary`` with HDF5) is a usage error."""
    from ema_pipeline import io

    try:
        by_suffix = io.frf_format_for_writing(out)
    except DataError:
        by_suffix = None
    if fmt is None and by_suffix is None:
        raise ConfigError(f"{out}: cannot tell the format from the suffix; use .uff or .h5, "
                          "or give --format")
    if fmt is not None and by_suffix is not None and fmt != by_suffix:
        raise ConfigError(f"--format {fmt} contradicts the suffix of {out} ({by_suffix})")
    chosen = fmt or by_suffix
    if binary and chosen != "uff":
        raise ConfigError("--binary is for UFF output, not HDF5")
    return "uff-binary" if binary else str(chosen)


def _write_simulated(
    args: argparse.Namespace, records: TimeRecords, frf: FRFSet, snr: float | None
) -> None:
    from ema_pipeline import io

    fmt = _simulate_format(args.out, args.format, args.binary)
    io.write_frf(frf, args.out, fmt, coherence=args.coherence)
    if args.time_records:
        io.write_time_uff(records, args.time_records, binary=args.binary)
    if not args.quiet:
        print(
            f"wrote {args.out}: {args.configuration}, {frf.n_out} FRFs x {frf.freq_hz.size} lines, "
            f"df = {frf.df_hz:.7g} Hz, {records.n_averages} averages, seed {args.seed}, "
            f"SNR {'none' if snr is None else f'{snr:g} dB'}"
        )


def _simulate_added_mass(args: argparse.Namespace) -> int:
    """``simulate --added-mass``: the experiment's FE beam with extra mass (frequencies
    and shapes from the FE model), damping from --zeta-pct or Table 1's genuine."""
    from ema_pipeline import acquisition
    from ema_pipeline.added_mass import parse_element_fractions
    from ema_pipeline.pipeline import study
    from ema_pipeline.pipeline.simulate import added_mass_modes, experiment_setup

    if args.fd_hz is not None:
        raise ConfigError("--added-mass takes its frequencies from the FE beam; drop --fd-hz")
    text = args.added_mass.strip()
    added = {} if text.lower() in ("", "none") else parse_element_fractions(text)
    experiment_path = args.experiment
    if experiment_path is None:
        default = Path("raw_frf") / "experiment.toml"
        experiment_path = default if default.is_file() else None
    experiment = None if experiment_path is None else study.load_experiment(experiment_path)
    setup = experiment_setup(experiment)
    args.configuration = args.configuration or ("genuine" if not added else "added_mass")
    zeta = None if args.zeta_pct is None else [z / 100 for z in args.zeta_pct]
    modes, shapes = added_mass_modes(added, setup, zeta=zeta, configuration=args.configuration)
    snr = None if args.snr_db is not None and args.snr_db <= 0 else args.snr_db
    records = acquisition.simulate_time_records(
        modes, setup, snr_db=snr, seed=args.seed, configuration=args.configuration,
        shapes=shapes,
    )
    frf = acquisition.estimate_frf(
        records, force_window_s=setup.force_window_s, exp_window_tau_s=setup.exp_window_tau_s
    )
    _write_simulated(args, records, frf, snr)
    if not args.quiet:
        freqs = ", ".join(f"{f:.3f}" for f in modes.fn_hz[:4])
        print(f"FE beam with added mass {added or 'none'}: fn = {freqs}, ... Hz")
    return EXIT_OK


def _identify_options(args: argparse.Namespace) -> IdentificationOptions:
    """The ``identify`` / ``batch`` arguments as one options object."""
    import math

    from ema_pipeline.identification.options import IdentificationOptions

    if args.band is not None and not (
        all(math.isfinite(b) for b in args.band) and 0 <= args.band[0] < args.band[1]
    ):
        raise ConfigError(f"--band needs finite 0 <= LO_HZ < HI_HZ, got {args.band[0]} "
                          f"{args.band[1]}")
    if args.expect is not None and not all(math.isfinite(f) and f > 0 for f in args.expect):
        raise ConfigError(f"--expect needs positive frequencies in Hz, got {list(args.expect)}")
    _memory_limit(args)
    if args.max_order is not None and args.max_order < 2:
        raise ConfigError(f"--max-order must be at least 2, got {args.max_order}")
    tau = args.exp_window_tau
    if tau is not None and not 0 < tau < float("inf"):
        raise ConfigError(f"--exp-window-tau needs the exponential window's time constant in "
                          f"seconds, finite and > 0; got {tau:g}")
    return IdentificationOptions(
        band_hz=None if args.band is None else (args.band[0], args.band[1]),
        max_order=args.max_order,
        method=args.method,
        expect_hz=tuple(args.expect or ()),
        exp_window_tau_s=args.exp_window_tau,
    )


def _cmd_identify(args: argparse.Namespace) -> int:
    from ema_pipeline.pipeline.single import identify_file

    options = _identify_options(args)
    failed = runtime = 0
    for path in args.files:
        outcome = identify_file(path, args.out, options, keep=args.report, uff=args.uff)
        if outcome.status == "failed":
            failed += 1
            runtime += outcome.runtime
            print(f"ema-pipeline identify: error: {outcome.reason}", file=sys.stderr)
            continue
        for warning in outcome.warnings:  # shown even with --quiet
            print(f"ema-pipeline identify: warning: {warning}", file=sys.stderr)
        page = None
        if args.report:
            from ema_pipeline.pipeline.reports import write_identify_report

            page = write_identify_report(outcome, args.out, options, figures=not args.no_figures)
        if not args.quiet:
            freqs = ", ".join(f"{f:.3f}" for f in outcome.fn_hz)
            print(
                f"{path}: {outcome.n_modes} modes [{freqs}] Hz -> {outcome.modes_csv} "
                + (f"and {page} " if page else "")
                + f"({outcome.seconds:.1f} s)"
            )
    return EXIT_RUNTIME if runtime else EXIT_USAGE if failed else EXIT_OK


def _memory_limit(args: argparse.Namespace) -> None:
    """``--memory-limit-gb``: checked, and passed on (also to batch workers) as
    ``$EMA_MEMORY_LIMIT_GB``."""
    from ema_pipeline.identification.resources import MEMORY_LIMIT_ENV, memory_limit_bytes

    limit = getattr(args, "memory_limit_gb", None)
    memory_limit_bytes(limit)  # refuse a bad value (or a bad environment variable) now
    if limit is not None:
        os.environ[MEMORY_LIMIT_ENV] = repr(float(limit))


def _cmd_batch(args: argparse.Namespace) -> int:
    from ema_pipeline.pipeline.batch import run_batch

    options = _identify_options(args)
    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {args.workers}")
    report = run_batch(
        args.folder,
        args.out,
        options=options,
        workers=args.workers,
        scheduler=args.scheduler,
        force=args.force,
        progress=not args.quiet,
        uff=args.uff,
    )
    print(report.summary_line(), file=sys.stderr if report.n_failed else sys.stdout)
    if args.report:
        from ema_pipeline.pipeline.reports import write_batch_report

        page = write_batch_report(
            report.out, report.folder, options, seconds=report.seconds,
            interrupted=report.interrupted, figures=not args.no_figures,
        )
        if not args.quiet:
            print(f"report: {page}")
    return EXIT_INPUT if report.n_failed else EXIT_OK


def _cmd_run(args: argparse.Namespace) -> int:
    import json

    from ema_pipeline.pipeline import study

    experiment_path = args.experiment or args.raw / "experiment.toml"
    _memory_limit(args)
    experiment = study.load_experiment(experiment_path)
    frfs = study.prepare_study(experiment, experiment_path)  # every input checked: exit 2

    def say(message: str) -> None:
        if not args.quiet and not args.json:
            print(message, file=sys.stderr, flush=True)

    result = study.run_study(experiment, progress=say, progress_bars=not (args.quiet or args.json),
                             frfs=frfs)
    if not result.ok and Path(args.results).exists():
        for problem in result.problems:
            print(f"ema-pipeline run: {problem}", file=sys.stderr)
        print(f"ema-pipeline run: error: the study has problems; the earlier results in "
              f"{args.results} are kept unchanged (use a new --results folder to see the "
              "incomplete ones)", file=sys.stderr)
        return EXIT_RUNTIME
    study.write_study(
        result, args.results, say, figures=not args.no_figures, experiment_file=experiment_path,
        uff=args.uff,
    )
    if args.json:
        payload = study.summary(result)
        payload["results"] = str(args.results)
        print(json.dumps(payload, indent=2))
    elif not args.quiet:
        print(study.summary_text(result, args.results))
    elif result.problems:
        for problem in result.problems:
            print(f"ema-pipeline run: {problem}", file=sys.stderr)
    return EXIT_OK if result.ok else EXIT_INPUT


def _cmd_fe(args: argparse.Namespace) -> int:
    import numpy as np

    from ema_pipeline import added_mass, io
    from ema_pipeline.data import Beam
    from ema_pipeline.pipeline import fe_stage, study

    experiment_path = args.experiment
    if experiment_path is None:
        default = Path("raw_frf") / "experiment.toml"
        experiment_path = default if default.is_file() else None
    experiment = None if experiment_path is None else study.load_experiment(experiment_path)
    table = io.read_csv(args.table1, required=("configuration", "mode", "fd_hz", "zeta_pct"))
    genuine = experiment.genuine_name if experiment else "genuine"
    measured = added_mass.modal_parameters_from_table(
        table, genuine=genuine, source=str(args.table1)
    )
    stds = [m.fn_std_hz for m in measured.values()]
    has_std = "fn_std_hz" in table.columns and all(np.all(np.isfinite(s)) for s in stds)
    stage = fe_stage.run_fe_stage(
        experiment.beam if experiment else Beam(),
        measured,
        genuine=genuine,
        immersed_elements=experiment.immersed_elements if experiment else (10,),
        n_repeats=experiment.update_repeats if experiment else 5,
        seed=experiment.seed if experiment else 0,
        progress=not args.quiet,
    )
    for name, frame in fe_stage.fe_stage_tables(stage).items():
        path = io.write_csv(frame, args.out / f"{name}.csv")
        if not args.quiet:
            print(f"wrote {path}")
    if not args.quiet:
        print(
            "note: Table 6 delta_m_std (method exact) is the frequencies' fn_std_hz propagated "
            "through the fit" if has_std else f"note: {args.table1} has no (complete) fn_std_hz "
            "column: Table 6 delta_m_std (method exact) is the misfit std, from the fit residual "
            "(delta_m_std_source)"
        )
        for message in stage.messages:
            print(f"note: {message}")
    return EXIT_OK


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
    p.set_defaults(func=_cmd_simulate)

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
    p.set_defaults(func=_cmd_identify)

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
    p.set_defaults(func=_cmd_batch)

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
    p.set_defaults(func=_cmd_run)

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
    p.set_defaults(func=_cmd_fe)
    return parser


def main(argv: list[str] | None = None) -> int:
    _capture_warnings()
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "verbose", False):
        _verbose_logging()
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except EMAError as exc:  # bad input or settings (DataError, ConfigError)
        print(f"ema-pipeline {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:  # unwritable output folder, disk full, ...
        where = f" {exc.filename}:" if getattr(exc, "filename", None) else ""
        print(f"ema-pipeline {args.command}: error:{where} {_one_line(exc.strerror or exc)}",
              file=sys.stderr)
        return EXIT_RUNTIME
    except MemoryError:
        print(f"ema-pipeline {args.command}: error: out of memory; lower the order or narrow "
              "the band (see --memory-limit-gb)", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt:
        print(f"ema-pipeline {args.command}: interrupted", file=sys.stderr)
        return 130


def _one_line(message: object) -> str:
    """An error message on one line."""
    return " ".join(str(message).split())


if __name__ == "__main__":
    sys.exit(main())
