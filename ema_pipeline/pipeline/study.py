"""The whole study of an experiment: ``ema-pipeline run``.

Driven entirely by the experiment file (``raw_frf/experiment.toml``): read each
configuration's FRFs, identify its modes (Table 1), compute the modal added mass
(Table 2), run the FE stage (Tables 3-6) and write tables, the HDF5 store, the
Markdown/HTML report and its figures.

Failures are collected, not raised: a missing FRF file, an unknown
configuration or too few identified modes becomes a *problem* that is printed
and written into the report, and everything that can still be computed is.
Inputs are validated before anything is computed or written
(:func:`prepare_study`): the experiment file against its schema, every FRF
file read and checked (sensor DOFs, band, orders, window, memory estimate); any
problem there is an input error (exit 2) and nothing is written.

Results are never lost. The results folder is written into a fresh sibling
folder ``.NAME.partial-PID-XXXX`` and swapped in only when complete
(:func:`ema_pipeline.io.swap_in`): with Linux ``renameat2(RENAME_EXCHANGE)`` the old and the new
folder trade places in one atomic step, then the old one is removed; where
that call is unavailable, two renames (old -> ``.NAME.old-PID``, new -> NAME)
and a killed run's backup is put back by the next run. A failure anywhere
(settings, inputs, a full disk) leaves an existing results folder
byte-identical; a run whose study has *problems* (exit 1) writes its incomplete
results only when there is no earlier results folder to lose. Partial folders
of killed runs (their process is gone) are removed by the next run
(:func:`ema_pipeline.io.remove_stale_partials`). The numbers are reproducible (fixed seeds, no
time stamps in the outputs).

The code, one concern a module (every name is imported from here):
:mod:`.study_inputs` (the experiment file and the FRFs read and checked,
:func:`prepare_study`), :mod:`.study_run` (the computation, :func:`run_study`
and its :class:`StudyResult`) and :mod:`.study_output` (the results folder,
:func:`write_study`, and the summary of a run).
"""

from ema_pipeline.pipeline.study_inputs import (
    load_experiment,
    map_dofs,
    prepare_study,
    recorded_frf,
)
from ema_pipeline.pipeline.study_output import (
    report_input,
    summary,
    summary_text,
    write_modes_uff_files,
    write_study,
)
from ema_pipeline.pipeline.study_run import Progress, StudyResult, run_study, table1

__all__ = ["Progress", "StudyResult", "load_experiment", "table1", "recorded_frf", "map_dofs",
           "prepare_study", "run_study", "report_input", "summary", "write_modes_uff_files",
           "write_study", "summary_text"]
