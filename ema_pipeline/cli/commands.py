"""The subcommands' handlers: each takes the parsed options, checks what argparse
cannot, calls :mod:`ema_pipeline.pipeline` (and ``acquisition``, ``io``) and prints.

A handler returns an exit status of :mod:`ema_pipeline.cli.support`; bad input
or settings raise :class:`~ema_pipeline.data.EMAError`, which
:func:`ema_pipeline.cli.main` reports on one line. The library is imported inside
the handlers, so that ``--help`` and usage errors stay fast.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ema_pipeline.cli.startup import start_up_imports
from ema_pipeline.cli.support import EXIT_INPUT, EXIT_OK, EXIT_RUNTIME, command_workers
from ema_pipeline.data import ConfigError, DataError
from ema_pipeline.paths import DEFAULT_RAW_FOLDER

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np

    from ema_pipeline.acquisition import TestSetup
    from ema_pipeline.data import Geometry, ModalParameters
    from ema_pipeline.experiment import Experiment
    from ema_pipeline.identification.options import IdentificationOptions

__all__ = [
    "IDENTIFY_FLAGS",
    "check_output_dir",
    "check_output_file",
    "cmd_batch",
    "cmd_fe",
    "cmd_identify",
    "cmd_init",
    "cmd_run",
    "cmd_simulate",
]


def cmd_simulate(args: argparse.Namespace) -> int:
    """``simulate``: one simulated impact test of the paper's cantilever, written as FRFs."""
    from ema_pipeline import acquisition, paper
    from ema_pipeline.pipeline.simulate import paper_modes

    if args.added_mass is not None:
        return _simulate_added_mass(args)
    _simulate_outputs(args)
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
    _simulate_and_write(args, modes, setup)
    return EXIT_OK


def _simulate_outputs(args: argparse.Namespace) -> None:
    """``simulate``'s output files, checked before the simulation."""
    check_output_file(args.out, "--out")
    _simulate_format(args.out, args.format, args.binary)
    if args.time_records is not None:
        check_output_file(args.time_records, "--time-records")


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


def _simulate_and_write(
    args: argparse.Namespace,
    modes: ModalParameters,
    setup: TestSetup,
    shapes: tuple[np.ndarray, np.ndarray] | None = None,
) -> None:
    """Simulate the test of ``modes`` (time records, then H1 FRFs) with the noise
    and seed of the options, and write what ``simulate`` was asked to."""
    from ema_pipeline import acquisition, io

    snr = acquisition.noise_snr_db(args.snr_db)  # 0: noise-free; negative: noisier than the signal
    records = acquisition.simulate_time_records(
        modes, setup, snr_db=snr, seed=args.seed, configuration=args.configuration,
        shapes=shapes,
    )
    frf = acquisition.estimate_frf(
        records, force_window_s=setup.force_window_s, exp_window_tau_s=setup.exp_window_tau_s
    )
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
    from ema_pipeline.added_mass import parse_element_fractions
    from ema_pipeline.pipeline.simulate import added_mass_modes, experiment_setup

    _simulate_outputs(args)
    if args.fd_hz is not None:
        raise ConfigError("--added-mass takes its frequencies from the FE beam; drop --fd-hz")
    text = args.added_mass.strip()
    added = {} if text.lower() in ("", "none") else parse_element_fractions(text)
    setup = experiment_setup(_experiment_or_default(args.experiment))
    args.configuration = args.configuration or ("genuine" if not added else "added_mass")
    zeta = None if args.zeta_pct is None else [z / 100 for z in args.zeta_pct]
    modes, shapes = added_mass_modes(added, setup, zeta=zeta, configuration=args.configuration)
    _simulate_and_write(args, modes, setup, shapes)
    if not args.quiet:
        freqs = ", ".join(f"{f:.3f}" for f in modes.fn_hz[:4])
        print(f"FE beam with added mass {added or 'none'}: fn = {freqs}, ... Hz")
    return EXIT_OK


def check_output_dir(path: Path, option: str) -> None:
    """Refuse, before any work, an output folder that cannot be one: an existing
    file, below a file, or in a folder we may not write (:class:`ConfigError`,
    exit 2, naming the path and the problem).

    Examples
    --------
    >>> import tempfile
    >>> f = Path(tempfile.mkdtemp()) / "taken.txt"; _ = f.write_text("x")
    >>> try:
    ...     check_output_dir(f, "--out")
    ... except ConfigError as exc:
    ...     print(str(exc).split(": ", 1)[1])
    --out names an existing file, not a folder
    """
    if path.exists() and not path.is_dir():
        raise ConfigError(f"{path}: {option} names an existing file, not a folder")
    _check_creatable(path, option)


def check_output_file(path: Path, option: str) -> None:
    """Refuse, before any work, an output file that cannot be written: an existing
    folder, or a path whose folder cannot be made or written (:class:`ConfigError`)."""
    if path.is_dir():
        raise ConfigError(f"{path}: {option} names an existing folder, not a file")
    _check_creatable(path.parent if str(path.parent) else Path("."), option, of=path)


def _check_creatable(path: Path, option: str, of: Path | None = None) -> None:
    """``path`` is a folder or can be made as one, writable: not through a symbolic
    link loop, not on a read-only file system."""
    import errno

    what = of if of is not None else path
    try:
        os.stat(what)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise ConfigError(f"{what}: {option} goes through a symbolic link loop") from None
    ancestor = path.absolute()
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ConfigError(f"{what}: {option} cannot be created: {ancestor} is a file, "
                          "not a folder")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        why = ("read-only file system" if os.statvfs(ancestor).f_flag & os.ST_RDONLY
               else "permission denied")
        raise ConfigError(f"{what}: {option} is not writable ({ancestor}: {why})")


#: The option of ``identify`` / ``batch`` that sets each field of
#: :class:`~ema_pipeline.identification.IdentificationOptions`.
IDENTIFY_FLAGS = {
    "band_hz": "--band",
    "max_order": "--max-order",
    "method": "--method",
    "expect_hz": "--expect",
    "exp_window_tau_s": "--exp-window-tau",
    "window_searches": "--no-window-search",
    "accept": "--no-accept",
    "memory_limit_gb": "--memory-limit-gb",
}


def _identify_options(args: argparse.Namespace) -> IdentificationOptions:
    """The ``identify`` / ``batch`` arguments as one options object; the options
    check every value (:class:`~ema_pipeline.data.OptionError`), and an
    impossible one is a usage error naming the option (``--max-order must be
    ...``)."""
    from ema_pipeline.data import OptionError
    from ema_pipeline.identification.options import IdentificationOptions

    try:
        return IdentificationOptions(
            band_hz=None if args.band is None else (args.band[0], args.band[1]),
            max_order=args.max_order,
            method=args.method,
            expect_hz=tuple(args.expect or ()),
            exp_window_tau_s=args.exp_window_tau,
            window_searches=not args.no_window_search,
            accept=not args.no_accept,
            memory_limit_gb=_memory_limit(args),
        )
    except OptionError as exc:
        raise ConfigError(f"{IDENTIFY_FLAGS.get(exc.field, exc.field)} {exc.reason}") from None


def _geometry(args: argparse.Namespace) -> Geometry | None:
    """``--geometry FILE``: the geometry read now (a bad file exits with 2), or None.

    ``identify`` and ``batch`` draw it in the report pages only: without
    ``--report`` it is a usage error (their modes UFF of ``--uff`` has no
    geometry datasets; ``run`` writes the beam's nodes as 15/82)."""
    from ema_pipeline import io

    path = getattr(args, "geometry", None)
    if path is not None and not getattr(args, "report", True):  # run always reports
        raise ConfigError("--geometry draws the modes in the report pages: add --report "
                          "(the modes UFF of --uff holds no geometry)")
    return None if path is None else io.read_geometry(path)


def cmd_identify(args: argparse.Namespace) -> int:
    """``identify``: modal parameters of each FRF file, several files side by
    side in worker processes (:mod:`ema_pipeline.pipeline.many`), printed in
    their order, each with the warnings of its result
    (``IdentificationResult.warnings``).

    Inputs that are not readable files are reported before the readers and the
    identification chain are imported, so a mistyped name fails right away
    and two unreadable files of the same stem do not stop the others."""
    from ema_pipeline.paths import FRF_FILE_KIND, check_readable

    readable = []
    for path in args.files:
        try:
            check_readable(path, FRF_FILE_KIND)
            readable.append(path)
        except DataError as exc:
            print(f"ema-pipeline identify: error: {exc}", file=sys.stderr)
    if not readable:
        return EXIT_INPUT
    from ema_pipeline.pipeline.ahead import read_ahead
    from ema_pipeline.runner import WorkerCrashed, started_ahead

    workers = command_workers(args.workers)
    # the files are read in a process of their own while this one imports
    # the identification chain (a worker reads a file that was not)
    with started_ahead(read_ahead, tuple(readable), workers) as read:
        with start_up_imports():  # the identification chain (cli.startup)
            from ema_pipeline.pipeline.many import FileJob, identify_files
            from ema_pipeline.report.wording import plural

        options = _identify_options(args)
        check_output_dir(args.out, "--out")
        geometry = _geometry(args)
        picks = None
        if args.picks is not None:
            from ema_pipeline import io

            picks = io.read_picks(args.picks)
        job = FileJob(args.out, options, report=args.report, figures=not args.no_figures,
                      uff=args.uff, picks=picks, geometry=geometry, checked=True)
        try:
            frfs = read()
        except WorkerCrashed:  # the reader died: each worker reads its file
            frfs = None
    failed, runtime = len(args.files) - len(readable), 0
    for outcome, page in identify_files(readable, job, workers, frfs=frfs):
        if outcome.status == "failed":
            failed += 1
            runtime += outcome.runtime
            print(f"ema-pipeline identify: error: {outcome.reason}", file=sys.stderr)
            continue
        for warning in outcome.warnings:  # shown even with --quiet
            print(f"ema-pipeline identify: warning: {warning}", file=sys.stderr)
        if not args.quiet:
            freqs = ", ".join(f"{f:.3f}" for f in outcome.fn_hz)
            print(
                f"{outcome.path}: {plural(outcome.n_modes, 'mode')} [{freqs}] Hz -> "
                f"{outcome.modes_csv} " + (f"and {page} " if page else "")
                + f"({outcome.seconds:.1f} s)"
            )
            print(f"  model: {outcome.model}")
    return EXIT_RUNTIME if runtime else EXIT_INPUT if failed else EXIT_OK


def _memory_limit(args: argparse.Namespace) -> float:
    """The memory limit of ``identify``, ``batch`` and ``run`` (GiB, for
    ``IdentificationOptions.memory_limit_gb``): ``--memory-limit-gb``, else
    ``$EMA_PIPELINE_MEMORY_LIMIT_GB`` (read here, the one place that reads it;
    the former ``$EMA_MEMORY_LIMIT_GB`` with a note to rename it), else the
    default. A bad value is a usage error naming where it came from."""
    from ema_pipeline.data import OptionError
    from ema_pipeline.identification.diagram.resources import (
        MEMORY_LIMIT_ENV,
        OLD_MEMORY_LIMIT_ENV,
    )
    from ema_pipeline.identification.options import DEFAULT_MEMORY_LIMIT_GB, check_option

    limit = getattr(args, "memory_limit_gb", None)
    if limit is not None:
        return float(limit)  # checked with the options (an error names --memory-limit-gb)
    name = MEMORY_LIMIT_ENV
    text = os.environ.get(name, "").strip()
    if not text and os.environ.get(OLD_MEMORY_LIMIT_ENV, "").strip():
        name = OLD_MEMORY_LIMIT_ENV
        text = os.environ[name].strip()
        print(f"ema-pipeline: note: ${OLD_MEMORY_LIMIT_ENV} is read for now; rename it "
              f"${MEMORY_LIMIT_ENV} (every variable of the tool starts with EMA_PIPELINE_)",
              file=sys.stderr)
    if not text:
        return DEFAULT_MEMORY_LIMIT_GB
    try:
        return float(check_option("memory_limit_gb", float(text)))
    except (OptionError, ValueError):
        raise ConfigError(f"{name}={text!r} is not a positive number of GiB") from None


def cmd_batch(args: argparse.Namespace) -> int:
    """``batch``: every FRF file under a folder, in parallel and resumable."""
    from ema_pipeline.pipeline.batch import run_batch

    options = _identify_options(args)
    check_output_dir(args.out, "--out")
    workers = None if args.scheduler and args.workers is None else command_workers(args.workers)
    geometry = _geometry(args)  # read now: a bad file stops before the batch runs
    report = run_batch(
        args.folder,
        args.out,
        options=options,
        workers=workers,
        scheduler=args.scheduler,
        force=args.force,
        progress=not args.quiet,
        uff=args.uff,
    )
    if report.n_failed or not args.quiet:  # --quiet: print only errors
        print(report.summary_line(), file=sys.stderr if report.n_failed else sys.stdout)
    if args.report:
        from ema_pipeline.pipeline.reports import write_batch_report

        warnings: list[str] = []
        page = write_batch_report(
            report.out, report.folder, options, seconds=report.seconds,
            interrupted=report.interrupted, figures=not args.no_figures,
            geometry=geometry, warnings=warnings,
        )
        for warning in warnings:  # shown even with --quiet
            print(f"ema-pipeline batch: warning: {warning}", file=sys.stderr)
        if not args.quiet:
            print(f"report: {page}")
    return EXIT_RUNTIME if report.n_failed else EXIT_OK


def cmd_run(args: argparse.Namespace) -> int:
    """``run``: the whole study of an experiment file, Tables 1-6 and the report."""
    import json

    from ema_pipeline.pipeline import study
    from ema_pipeline.report.wording import plural

    experiment_path = args.experiment or args.raw / "experiment.toml"
    if args.experiment is None and not os.path.lexists(experiment_path):
        raise ConfigError(f"{experiment_path}: no such file; `ema-pipeline init DIR --example` "
                          "writes the example study (then `cd DIR && ema-pipeline run`), "
                          "`ema-pipeline init DIR` an experiment file for your test")
    check_output_dir(args.results, "--results")
    limit = _memory_limit(args)
    experiment = study.load_experiment(experiment_path)
    experiment = _with_memory_limit(experiment, limit)
    geometry = _geometry(args)  # --geometry: the report's wireframe instead of [geometry]
    if geometry is not None:
        import dataclasses

        experiment = dataclasses.replace(experiment, geometry=geometry)
    hits: dict = {}  # hit tables of configurations measured as raw recordings
    frfs = study.prepare_study(experiment, experiment_path, hits=hits)  # inputs checked: exit 2

    def say(message: str) -> None:
        if not args.quiet and not args.json:
            print(message, file=sys.stderr, flush=True)

    result = study.run_study(experiment, progress=say, progress_bars=not (args.quiet or args.json),
                             frfs=frfs, hits=hits, workers=command_workers(args.workers))
    if not result.ok and Path(args.results).exists():
        for problem in result.problems:
            print(f"ema-pipeline run: {problem}", file=sys.stderr)
        why = result.problems[0] if result.problems else "a stage failed"
        more = f" and {plural(len(result.problems) - 1, 'more problem')} above" if len(
            result.problems) > 1 else ""
        print(f"ema-pipeline run: error: the earlier results in {args.results} are kept "
              f"unchanged because {why}{more}; use a new --results folder to see the "
              "incomplete ones", file=sys.stderr)
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
    return EXIT_OK if result.ok else EXIT_RUNTIME


def _with_memory_limit(experiment: Experiment, limit_gb: float) -> Experiment:
    """``experiment`` whose identification options carry the memory limit
    ``limit_gb`` (GiB; :func:`_memory_limit`), refused when not positive."""
    import dataclasses

    from ema_pipeline.data import OptionError

    try:
        options = dataclasses.replace(experiment.identification, memory_limit_gb=limit_gb)
    except OptionError as exc:
        raise ConfigError(f"--memory-limit-gb {exc.reason}") from None
    return dataclasses.replace(experiment, identification=options)


def cmd_init(args: argparse.Namespace) -> int:
    """``init``: a commented experiment-file template in a folder, or the example study."""
    from ema_pipeline.io.template import write_channel_template, write_experiment_template

    check_output_dir(args.folder, "DIR")
    if args.example:
        from ema_pipeline.pipeline.simulate import write_example_study

        if args.recordings is not None:
            raise ConfigError("--example writes the example's own files; drop --recordings")
        written = write_example_study(args.folder, force=args.force)
        print(f"wrote {written[0].parent}: the example study ({', '.join(p.name for p in written)}"
              f"; simulated impact tests of a steel cantilever); run it with `cd {args.folder} "
              "&& ema-pipeline run` (results in results/)")
        return EXIT_OK
    if args.recordings is not None:
        exists = (args.folder / "experiment.toml").exists()
        if exists and not args.force:  # before the sheet is written
            raise ConfigError(f"{args.folder / 'experiment.toml'} exists; give --force to "
                              "overwrite it")
        sheet, n_files = write_channel_template(args.folder, args.recordings, force=args.force)
        path = write_experiment_template(args.folder, force=args.force, recordings=True)
        print(f"wrote {sheet} ({n_files} recordings): complete node and direction of every "
              f"row; and {path}: edit it, put the geometry beside it, then "
              f"`ema-pipeline run --raw {args.folder}`")
        return EXIT_OK
    path = write_experiment_template(args.folder, force=args.force)
    print(f"wrote {path}: edit it, put the FRF and geometry files beside it, then "
          f"`ema-pipeline run --raw {args.folder}`")
    return EXIT_OK


def cmd_fe(args: argparse.Namespace) -> int:
    """``fe``: Tables 2-6 from a measured modal table in the Table 1 form."""
    import numpy as np

    from ema_pipeline import added_mass, io
    from ema_pipeline.data import Beam
    from ema_pipeline.pipeline import fe_stage

    check_output_dir(args.out, "--out")
    experiment = _experiment_or_default(args.experiment)
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
        n_modes=experiment.n_modes if experiment else None,  # [fe] n_modes, as run uses it
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


def _experiment_or_default(path: Path | None) -> Experiment | None:
    """The experiment of ``--experiment``, else of ``raw_frf/experiment.toml`` if that
    file exists, else ``None`` (the paper's beam)."""
    from ema_pipeline.pipeline import study

    if path is None:
        default = Path(DEFAULT_RAW_FOLDER) / "experiment.toml"
        path = default if default.is_file() else None
    return None if path is None else study.load_experiment(path)
