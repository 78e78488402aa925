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

Modules: ``options`` (:class:`IdentificationOptions`), ``core`` (:func:`identify`
and the method table :data:`METHODS`), ``plscf_backend`` / ``sdypy_backend``
(the methods), ``common`` (band checks and the shared finish), ``plscf``,
``stabilization``, ``selection``, ``order_search`` (the adaptive order search
of ``plscf_backend``: diagrams of growing order and their candidates),
``refine`` (pole refinement), ``local_band``
(the local problem of one mode, shared by ``refine`` and ``local_fits``),
``local_fits`` (local screens and fits of single modes), ``acceptance``
(the final tests: which refined candidates are modes), ``residual_search``
(modes the diagrams missed), ``not_kept`` (resonances the FRFs show that no
mode was kept for), ``uncertainty`` (noise and covariance model),
``lsfd`` (residues and fit indicators), ``result``. The MAC lives in :mod:`ema_pipeline.modal`, the
diagrams in :mod:`ema_pipeline.plots`.
"""

from ema_pipeline.identification.common import default_max_order, single_reference
from ema_pipeline.identification.core import METHODS, identify
from ema_pipeline.identification.lsfd import (  # the module stays ``identification.lsfd``
    frac,
    mpc,
    normalised_error,
    real_normalised,
)
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.plscf import PoleSet, plscf, plscf_normal_matrix
from ema_pipeline.identification.refine import refine_poles
from ema_pipeline.identification.result import (
    IdentificationResult,
    ResolvedSettings,
    doubtful_reasons,
    modes_table,
)
from ema_pipeline.identification.selection import (
    SelectedPoles,
    select_trajectories,
    track_poles,
)
from ema_pipeline.identification.stabilization import (
    STABLE_DAMP,
    STABLE_FREQ,
    STABLE_VECTOR,
    StabilizationData,
    pole_to_modal,
    stabilization,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.identification.uncertainty import modal_std

__all__ = [
    "METHODS",
    "STABLE_DAMP",
    "STABLE_FREQ",
    "STABLE_VECTOR",
    "IdentificationOptions",
    "IdentificationResult",
    "PoleSet",
    "ResolvedSettings",
    "SelectedPoles",
    "SelectionThresholds",
    "StabilizationData",
    "default_max_order",
    "doubtful_reasons",
    "frac",
    "identify",
    "modal_std",
    "modes_table",
    "mpc",
    "normalised_error",
    "plscf",
    "plscf_normal_matrix",
    "pole_to_modal",
    "real_normalised",
    "refine_poles",
    "select_trajectories",
    "single_reference",
    "stabilization",
    "track_poles",
]
