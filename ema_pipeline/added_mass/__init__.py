"""Added mass stage: modal added mass, eq. (10), and local added mass, eq. (14)-(20).

Modules:

* :mod:`.modal` - eq. (10) per mode (:func:`modal_added_mass`) and the pairing
  of modes between configurations (:func:`pair_modes`).
* :mod:`.local` - the local added mass of the immersed element(s) by least
  squares on the SEREP-reduced FE model (:func:`local_added_mass`, methods
  ``"block"`` and ``"projected"``).
* :mod:`.modified_beam` - the FE beam with extra mass (and stiffness) on some
  measurement elements, the forward model (:func:`beam_modes_with_added_mass`,
  :func:`modified_beam_matrices`), used by the simulator and by ``exact``.
* :mod:`.exact` - the local added mass by an exact (nonlinear) fit of the FE
  eigenvalues to the measured frequency ratios (method ``"exact"``,
  :func:`exact_added_mass`, :func:`exact_added_mass_all`), with its linearised
  std and identifiability check.
* :mod:`.exact_result` - the results of ``exact``
  (:class:`ExactAddedMassResult`, :class:`ExactOutcome`, :class:`UnidentifiableError`).
* :mod:`.tables` - Tables 1-6 as DataFrames (:func:`modal_parameters_from_table`
  reads the Table 1 form; :data:`TABLE_COLUMNS`).

The whole FE stage (model update, SEREP, Tables 2-6) is orchestrated by
:mod:`ema_pipeline.pipeline.fe_stage`.
"""

from ema_pipeline.added_mass.exact import (
    EXACT_METHOD,
    MAX_CONDITION,
    ExactAddedMassResult,
    ExactOutcome,
    UnidentifiableError,
    exact_added_mass,
    exact_added_mass_all,
)
from ema_pipeline.added_mass.local import (
    METHODS,
    LocalAddedMassResult,
    Method,
    local_added_mass,
    local_added_mass_factors,
)
from ema_pipeline.added_mass.modal import (
    AddedMassResult,
    modal_added_mass,
    modal_added_mass_all,
    pair_modes,
    replace_configuration,
    require_genuine,
)
from ema_pipeline.added_mass.modified_beam import (
    AddedMassModes,
    beam_modes_with_added_mass,
    modified_beam_matrices,
    parse_element_fractions,
)
from ema_pipeline.added_mass.tables import (
    TABLE4_PARAMETER_NAMES,
    TABLE6_EXTRA_COLUMNS,
    TABLE_COLUMNS,
    exact_method_notes,
    fe_frequency_table,
    local_added_mass_table,
    modal_added_mass_table,
    modal_parameters_from_table,
    updated_parameters_table,
)

__all__ = [
    "EXACT_METHOD",
    "MAX_CONDITION",
    "METHODS",
    "TABLE4_PARAMETER_NAMES",
    "TABLE6_EXTRA_COLUMNS",
    "TABLE_COLUMNS",
    "AddedMassModes",
    "AddedMassResult",
    "ExactAddedMassResult",
    "ExactOutcome",
    "LocalAddedMassResult",
    "Method",
    "UnidentifiableError",
    "beam_modes_with_added_mass",
    "exact_added_mass",
    "exact_added_mass_all",
    "exact_method_notes",
    "fe_frequency_table",
    "local_added_mass",
    "local_added_mass_factors",
    "local_added_mass_table",
    "modal_added_mass",
    "modal_added_mass_all",
    "modal_added_mass_table",
    "modal_parameters_from_table",
    "modified_beam_matrices",
    "pair_modes",
    "parse_element_fractions",
    "replace_configuration",
    "require_genuine",
    "updated_parameters_table",
]
