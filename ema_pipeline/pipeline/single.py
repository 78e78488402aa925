"""One FRF file through acquisition checks and identification, with its outputs.

Used by ``ema-pipeline identify`` and by the batch runner. Outputs per input
file ``<stem>``: ``<stem>_modes.csv`` (one row per mode: ``mode, fn_hz, fd_hz,
zeta_pct`` and their standard deviations, ..., ``selection``: ``auto``,
``picked`` (``--picks``) or ``expected`` (a mode answering an ``--expect``
guess)) and ``<stem>_result.h5`` (the FRFs,
the full identification result with stabilization data, and the modal table;
its root attributes ``input_sha256`` and ``complete`` make it a resumable
record). Both are written atomically; the HDF5 file last, so a complete HDF5
result implies the CSV is there too.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ema_pipeline import io
from ema_pipeline.data import MIN_FRF_LINES, DataError, EMAError, FRFSet
from ema_pipeline.identification import (
    IdentificationOptions,
    IdentificationResult,
    check_input,
    identify,
    modes_columns,
)
from ema_pipeline.identification.common import ends_at_usable_top
from ema_pipeline.identification.picked import Picks
from ema_pipeline.identification.selection.expect import with_expected_rows
from ema_pipeline.report.wording import model_text


@dataclass
class FileOutcome:
    """What happened to one input file."""

    path: Path
    sha256: str = ""
    configuration: str = ""
    status: str = "ok"  # ok | skipped | failed
    reason: str = ""
    warnings: list[str] = field(default_factory=list)  # the result's (IdentificationResult)
    runtime: bool = False  # failed for a runtime reason (disk full, ...), not the input
    n_modes: int = 0
    fn_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    zeta: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fit_frac: float = float("nan")
    fit_error: float = float("nan")
    model: str = ""  # the fitted model in words (report.wording.model_text)
    seconds: float = 0.0
    modes_csv: Path | None = None
    result_h5: Path | None = None
    frf: FRFSet | None = None  # with identify_file(..., keep=True): what the report draws
    picks_path: str = ""  # with --picks: the picks file and its content hash
    picks_sha256: str = ""
    result: IdentificationResult | None = None


def write_result_uff(
    result: IdentificationResult,
    frf: FRFSet,
    path: str | Path,
    node_coordinates: dict[int, tuple[float, float, float]] | None = None,
) -> Path:
    """Write identified modes as a Universal File.

    Dataset 164 (SI), 15 and 82 when ``node_coordinates`` (m) are known, one
    55 per mode (fn, zeta, complex shape at the response DOFs) and 58 with the
    synthesised FRFs of the band; see :func:`ema_pipeline.io.write_modes_uff`.
    """
    if result.modes.shapes is None:
        raise DataError(f"{path}: the result has no mode shapes to export")
    fit = FRFSet(
        freq_hz=result.freq_hz,
        H=result.H_fit,
        response_dofs=frf.response_dofs,
        reference_dofs=frf.reference_dofs,
        quantity=frf.quantity,
        configuration=frf.configuration,
    )
    return io.write_modes_uff(
        path,
        result.modes.fn_hz,
        result.modes.zeta,
        result.modes.shapes,
        result.modes.dofs,
        node_coordinates=node_coordinates,
        frf_fit=fit,
        description=f"ema-pipeline modes {frf.configuration}".strip(),
    )


def output_paths(path: Path, out_dir: Path) -> tuple[Path, Path]:
    """``(<out>/<stem>_modes.csv, <out>/<stem>_result.h5)`` for an input file.

    Examples
    --------
    >>> [p.as_posix() for p in output_paths(Path("raw/test_01.uff"), Path("out"))]
    ['out/test_01_modes.csv', 'out/test_01_result.h5']
    """
    stem = Path(path).stem
    return out_dir / f"{stem}_modes.csv", out_dir / f"{stem}_result.h5"


def identify_file(
    path: str | Path,
    out_dir: str | Path,
    options: IdentificationOptions | None = None,
    *,
    force: bool = True,
    sha256: str | None = None,
    keep: bool = False,
    uff: bool = False,
    picks: Picks | None = None,
    workers: int = 1,
    checked: bool = False,
    frf: FRFSet | None = None,
) -> FileOutcome:
    """Identify the modes of one FRF file and write its outputs.

    The file is read once (:func:`ema_pipeline.io.read_frf`, which checks it
    and records its content hash in ``frf.source.sha256``, the hash the
    outputs carry; ``sha256`` given: that one); every other check is
    :func:`~ema_pipeline.identification.check_input`'s, and the warnings are
    the result's (``IdentificationResult.warnings``). With ``force=False`` the
    file is hashed first, and a file whose content hash already has a
    complete result in ``out_dir`` is skipped. With ``keep=True`` the outcome keeps the FRFs and
    the identification result (for a report). Problems with the file (unreadable, NaN, no modes)
    are returned as ``status="failed"`` with the reason, never raised. With
    ``picks`` (a picks file, :func:`ema_pipeline.io.read_picks`) exactly those
    poles are fitted (:func:`ema_pipeline.identification.selection.picks.identify_picks`).
    ``workers``: worker processes of the identification (``identify(workers=)``).
    ``checked``: the caller has checked that ``path`` is a readable file
    (:func:`ema_pipeline.paths.check_readable`, as the command line does before
    it imports the readers), so :func:`ema_pipeline.io.read_frf` does not again.
    ``frf``: the file's FRFs as that read gives them, read ahead
    (:func:`ema_pipeline.pipeline.ahead.read_ahead`); None: read here.
    """
    options = IdentificationOptions() if options is None else options
    path, out_dir = Path(path), Path(out_dir)
    start = time.perf_counter()
    outcome = FileOutcome(path=path)
    modes_csv, result_h5 = output_paths(path, out_dir)
    try:
        if not force:  # the content hash decides before the file is read
            outcome.sha256 = sha256 or io.sha256_file(path)
            if io.completed_result_sha256(result_h5) == outcome.sha256:
                outcome.status = "skipped"
                outcome.reason = "complete result with the same content hash exists"
                outcome.modes_csv, outcome.result_h5 = modes_csv, result_h5
                return outcome
        # checks the file (unless the caller did), hashes it once
        if frf is None:
            frf = io.read_frf(path, min_lines=MIN_FRF_LINES, checked=checked)
        outcome.sha256 = outcome.sha256 or sha256 or frf.source.sha256
        outcome.configuration = frf.configuration
        ready = check_input(frf, options, picks=picks)  # every other check, once
        frf = ready.frf  # as identified: the FRFs kept with the result match its shapes
        out_dir.mkdir(parents=True, exist_ok=True)  # an unusable output folder fails now
        result = identify(ready, workers=workers)
        if result.modes.n_modes == 0:
            raise DataError(f"{path}: no physical modes found in the band")
        table = modes_columns(result)  # its found_by column: diagram, ..., expected, picked
        if picks is not None and picks.source:
            outcome.picks_path = picks.source
            outcome.picks_sha256 = io.sha256_file(picks.source)
        outcome.warnings = list(result.warnings)
        if options.expect_hz:  # one row per guess; guesses not found with empty values
            tol = result.settings.thresholds.expect_tol  # the selection's tolerance
            table = with_expected_rows(table.to_frame(), options.expect_hz, tol)
            for column in ("found_by", "selection"):  # a guess not found: empty
                table[column] = table[column].fillna("")
        io.write_csv(table, modes_csv)
        if uff:  # <stem>_modes.uff beside <stem>_modes.csv
            write_result_uff(result, frf, modes_csv.with_suffix(".uff"))
        io.write_results_h5(
            {
                "frf": frf,
                "identification": result,
                "modes": table,
                "input": {"path": str(path), "sha256": outcome.sha256,
                          "warnings": tuple(outcome.warnings) or None,
                          "picks_path": outcome.picks_path or None,
                          "picks_sha256": outcome.picks_sha256 or None},
            },
            result_h5,
            attrs={"input_sha256": outcome.sha256},
        )
        outcome.n_modes = result.modes.n_modes
        outcome.fn_hz, outcome.zeta = result.modes.fn_hz, result.modes.zeta
        outcome.fit_frac = float(np.mean(result.frac))
        outcome.fit_error = float(np.mean(result.error))
        st = result.settings
        outcome.model = model_text(st.band_hz, st.orders, st.lower_residual, st.upper_residual,
                                   to_usable_top=ends_at_usable_top(frf, st.band_hz))
        outcome.modes_csv, outcome.result_h5 = modes_csv, result_h5
        if keep:
            outcome.frf, outcome.result = frf, result
    except EMAError as exc:
        outcome.status, outcome.reason = "failed", str(exc)
    except OSError as exc:  # the file it names (an output, say), else the input's
        where = getattr(exc, "filename", None)
        outcome.status, outcome.reason = "failed", (
            f"{where}: {exc.strerror or exc}" if where
            else f"{path}: {type(exc).__name__}: {exc}")
        outcome.runtime = True
    except (ValueError, MemoryError, np.linalg.LinAlgError) as exc:
        outcome.status, outcome.reason = "failed", f"{path}: {type(exc).__name__}: {exc}"
        outcome.runtime = isinstance(exc, MemoryError)  # else: the input's fault
    finally:
        outcome.seconds = time.perf_counter() - start
    if outcome.status == "failed" and not outcome.sha256:  # not read: its hash for the record
        try:
            outcome.sha256 = io.sha256_file(path)
        except (EMAError, OSError):
            pass
    return outcome
