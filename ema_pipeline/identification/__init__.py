"""Identification stage: modal parameters from FRFs.

Poly-reference least-squares complex-frequency estimation (pLSCF, "PolyMAX")
builds stabilization data over model orders; stable poles are clustered and
selected automatically; each selected pole is refined by a local nonlinear
least-squares fit that also gives its covariance; LSFD gives residues, mode
shapes and the synthesised FRFs.

Why our own pLSCF rather than sdypy-EMA's LSCF (which we use as an independent
reference, ``method="sdypy-lscf"``, and test against):

* speed -- the normal equations are Toeplitz in the z-domain basis, so R, S, T
  come from a few inverse FFTs of the weighted data; the reduced matrix M is
  built once for the highest order and the denominators of every lower order
  come from one Cholesky factorisation of M (leading blocks), so the cost is
  essentially that of the companion eigenvalues;
* features sdypy-EMA lacks -- several references (matrix-fraction model with
  participation vectors), automatic pole selection without a GUI or typed-in
  frequencies, standard deviations of f and zeta, correction of the
  exponential window's added damping, and clear errors on bad input.

The package reads as the pipeline. At the top, the public entry:
``core`` (:func:`identify`, its checks :func:`check_input` and warnings,
and the method table :data:`METHODS`), ``options``
(:class:`IdentificationOptions`), ``thresholds``
(:class:`SelectionThresholds`), ``result`` (the result types), ``picked``
(the picks as data) -- these four light, no scipy -- ``common`` (band checks
and the shared finish) and the methods ``plscf_backend`` (its stages in
order) and ``sdypy_backend``. Then the three steps of ``plscf_backend``:

* ``diagram``: ``plscf`` (the poles of every order), ``stabilization``,
  ``order_search`` (the adaptive order search: diagrams of growing order and
  their candidates), ``narrower_searches`` (a wide band's lowest part, a
  dense band's windows), ``resources`` (the order cap, the memory estimate);
* ``selection``: ``trajectories`` (pole trajectories and the automatic
  choice), ``acceptance`` (the final tests), ``partners`` (close partners),
  ``pairs`` (close pairs with few channels),
  ``residual_search`` (modes the diagrams missed), ``expect`` (guesses),
  ``picks`` (modes picked by hand), ``not_kept`` (resonances the FRFs show
  that no mode was kept for);
* ``refinement``: ``refine`` (pole refinement with covariance),
  ``local_band`` (the local problem of one mode), ``local_fits`` (local
  screens and fits of single modes), ``lsfd`` (residues and fit
  indicators), ``uncertainty`` (noise and covariance model).

The MAC and the MPD live in :mod:`ema_pipeline.modal`, the matplotlib
diagrams in :mod:`ema_pipeline.report.matplotlib_plots`.

The package loads its modules on first use (a module ``__getattr__`` over
:data:`EXPORTS`): ``import ema_pipeline.identification`` (and so
:mod:`ema_pipeline.io`, which reads and writes results) loads neither scipy nor
the numerics; ``from ema_pipeline.identification import identify`` loads what
identifying needs. The functions ``plscf`` and ``stabilization`` are not
exported here (the names are their modules'): use
``identification.diagram.plscf.plscf`` and
``identification.diagram.stabilization.stabilization``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ema_pipeline.lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover  (what the lazy names are, for type checkers)
    from ema_pipeline.identification.common import default_max_order, single_reference
    from ema_pipeline.identification.core import METHODS, CheckedInput, check_input, identify
    from ema_pipeline.identification.diagram.plscf import PoleSet, plscf_normal_matrix
    from ema_pipeline.identification.diagram.stabilization import pole_to_modal
    from ema_pipeline.identification.options import IdentificationOptions
    from ema_pipeline.identification.refinement.lsfd import (
        frac,
        mpc,
        normalised_error,
        real_normalised,
    )
    from ema_pipeline.identification.refinement.refine import refine_poles
    from ema_pipeline.identification.refinement.uncertainty import modal_std
    from ema_pipeline.identification.result import (
        FOUND_BY,
        STABLE_DAMP,
        STABLE_FREQ,
        STABLE_VECTOR,
        IdentificationResult,
        ResolvedSettings,
        SelectedPoles,
        StabilizationData,
        doubtful_reasons,
        found_by_names,
        modes_columns,
        modes_table,
    )
    from ema_pipeline.identification.selection.trajectories import select_trajectories, track_poles
    from ema_pipeline.identification.thresholds import SelectionThresholds

__all__ = [
    "FOUND_BY",
    "METHODS",
    "STABLE_DAMP",
    "STABLE_FREQ",
    "STABLE_VECTOR",
    "CheckedInput",
    "IdentificationOptions",
    "IdentificationResult",
    "PoleSet",
    "ResolvedSettings",
    "SelectedPoles",
    "SelectionThresholds",
    "StabilizationData",
    "check_input",
    "default_max_order",
    "doubtful_reasons",
    "found_by_names",
    "frac",
    "identify",
    "modal_std",
    "modes_columns",
    "modes_table",
    "mpc",
    "normalised_error",
    "plscf_normal_matrix",
    "pole_to_modal",
    "real_normalised",
    "refine_poles",
    "select_trajectories",
    "single_reference",
    "track_poles",
]

#: The module of each name of :data:`__all__` (loaded on first use).
EXPORTS: dict[str, str] = {
    "METHODS": "core",
    "identify": "core",
    "CheckedInput": "core",
    "check_input": "core",
    "default_max_order": "common",
    "single_reference": "common",
    "frac": "refinement.lsfd",
    "mpc": "refinement.lsfd",
    "normalised_error": "refinement.lsfd",
    "real_normalised": "refinement.lsfd",
    "IdentificationOptions": "options",
    "PoleSet": "diagram.plscf",
    "plscf_normal_matrix": "diagram.plscf",
    "refine_poles": "refinement.refine",
    "STABLE_DAMP": "result",
    "STABLE_FREQ": "result",
    "STABLE_VECTOR": "result",
    "IdentificationResult": "result",
    "ResolvedSettings": "result",
    "SelectedPoles": "result",
    "StabilizationData": "result",
    "doubtful_reasons": "result",
    "found_by_names": "result",
    "FOUND_BY": "result",
    "modes_columns": "result",
    "modes_table": "result",
    "select_trajectories": "selection.trajectories",
    "track_poles": "selection.trajectories",
    "pole_to_modal": "diagram.stabilization",
    "SelectionThresholds": "thresholds",
    "modal_std": "refinement.uncertainty",
}


__getattr__, __dir__ = lazy_exports(__name__, EXPORTS)
