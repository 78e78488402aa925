"""Identify every FRF file under a folder: parallel, streaming, resumable.

``ema-pipeline batch DIR --out OUT`` runs :func:`~ema_pipeline.pipeline.single.identify_file`
(acquisition checks + identification + atomic outputs) on every UFF-58 and
HDF5 file under ``DIR`` and writes ``OUT/summary.csv`` (one row per file) and
``OUT/failures.csv`` (one row per bad file, with the reason).

Design
------
Output layout
    The outputs of ``DIR/sub/a.uff`` go to ``OUT/sub/`` (``a_modes.csv``,
    ``a_result.h5``), mirroring the input's sub-folder, so equal stems in
    different folders do not collide. Files that share a stem in one folder
    (``a.uff`` and ``a.h5``) each get a folder named after the whole file
    name instead: ``OUT/sub/a.uff/a_modes.csv``, ``OUT/sub/a.h5/a_modes.csv``
    (no input folder can have that name, because the file has it). The
    ``modes_csv`` and ``result_h5`` columns of the summary say where each
    file's outputs are. Input files inside ``OUT`` (``--out`` under ``DIR``)
    are not inputs.

Streaming window
    The parent never holds FRFs or results: it submits at most
    ``2 * concurrency`` tasks at a time (a sliding window refilled as results
    arrive) and a worker returns only a :class:`FileRecord` (a summary row:
    hash, configuration, frequencies, fit quality, status, reason). Rows are
    written as they arrive, in input order (a reorder buffer, bounded because
    no task is submitted more than ``_MAX_AHEAD`` positions past the first
    unwritten one), into temporary files beside ``summary.csv`` and
    ``failures.csv`` that are renamed into place at the end. Memory therefore
    stays flat; only the list of input paths grows with the number of files.

Atomic writes and resume by content hash
    Every output is written to a hidden temporary file in its folder and
    renamed when complete (:func:`ema_pipeline.io.atomic_path`); the result
    HDF5 file, written last, records the SHA-256 of the input and a
    ``complete`` flag. A batch killed at any moment (even SIGKILL) therefore
    leaves only complete results, and a rerun skips every file whose content
    hash already has a complete result (``force=True`` recomputes). Stray
    temporary files of a killed run (``.*.tmp``) are removed when the next run
    starts; a lock file (``OUT/.batch.lock``, ``flock``) keeps two batches from
    writing into one ``OUT`` at the same time.

Local processes
    Tasks run in ``workers`` local processes (:class:`ema_pipeline.runner.ProcessPool`;
    the library's default 1, ``ema-pipeline batch`` passes the cores), in a
    :class:`concurrent.futures.ProcessPoolExecutor` forked by a fork server
    that imported the worker code once (see :mod:`.local`: no fork of a parent
    that has h5py open and threads running, no import per worker). Workers run
    BLAS on one thread (unless ``$EMA_PIPELINE_BLAS_THREADS`` overrides):
    N processes with N BLAS threads each would oversubscribe the cores, and
    the results do not depend on the number of workers. Workers
    ignore SIGINT (the parent coordinates the stop) and exit when the parent
    dies. A worker that dies (crash, out of memory) breaks the pool: it is
    restarted, the files then in progress are retried once, and a file in
    progress at a second death is recorded as failed.

Interrupts
    The first SIGINT (Ctrl-C) or SIGTERM stops submitting, cancels the queued
    tasks and lets the running ones finish (their results are complete); the
    summary and failures of what was done are written and the report says
    ``interrupted`` and how many files were not run (they count as failed, so
    the exit status is 1; a rerun finishes them). A second signal aborts at
    once: workers are terminated, ``summary.csv`` and ``failures.csv`` are left
    as they were, and ``KeyboardInterrupt`` propagates.

dask.distributed
    With ``scheduler="tcp://host:port"`` the same tasks go to an existing
    dask.distributed cluster through ``Client(address).get_executor()`` (a
    :class:`concurrent.futures.Executor`), so the streaming window, ordering
    and interrupts are the same code. The workers must see ``DIR`` and ``OUT``
    under the same absolute paths (shared file system) and have ema-pipeline
    installed. ``distributed`` is imported only then (extra ``[distributed]``).

Modules
-------
:mod:`.scan` (inputs and output folders), :mod:`.tasks` (what a worker gets
and returns, :func:`process_file`), :mod:`.run` (:func:`run_batch` and the
streaming loop), :mod:`.local` and :mod:`.dask` (where tasks run),
:mod:`.resume` (complete results, stale temporaries, the lock) and
:mod:`.summary` (``summary.csv``/``failures.csv`` rows, :class:`BatchReport`).
"""

from ema_pipeline.pipeline.batch.dask import DaskBackend
from ema_pipeline.pipeline.batch.local import LocalBackend
from ema_pipeline.pipeline.batch.resume import (
    LOCK_NAME,
    batch_lock,
    completed_details,
    remove_stale_temporaries,
)
from ema_pipeline.pipeline.batch.run import Backend, StopRequest, run_batch, run_tasks
from ema_pipeline.pipeline.batch.scan import find_inputs, is_inside, output_dirs
from ema_pipeline.pipeline.batch.summary import (
    FAILURE_COLUMNS,
    SUMMARY_COLUMNS,
    BatchReport,
    count_record,
    csv_stream,
    summary_row,
)
from ema_pipeline.pipeline.batch.tasks import FileRecord, FileTask, naming, process_file

__all__ = [
    "FAILURE_COLUMNS",
    "LOCK_NAME",
    "SUMMARY_COLUMNS",
    "Backend",
    "BatchReport",
    "DaskBackend",
    "FileRecord",
    "FileTask",
    "LocalBackend",
    "StopRequest",
    "batch_lock",
    "completed_details",
    "count_record",
    "csv_stream",
    "find_inputs",
    "is_inside",
    "naming",
    "output_dirs",
    "process_file",
    "remove_stale_temporaries",
    "run_batch",
    "run_tasks",
    "summary_row",
]
