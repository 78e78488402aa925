"""Acquisition stage: FRFs from an impact test, measured or simulated.

Modules:

* :mod:`.estimation`: **FRF estimation** from time records
  (:func:`estimate_frf`; :func:`estimate_frf_windows` also returns the windows
  it applied): H1, H2 and Hv with ordinary coherence from repeated
  impacts (linear averaging), a force window and an exponential window on both
  channels, whose time constant is recorded so that identification can undo it.
* :mod:`.simulation`: **exact FRF synthesis** from modal parameters
  (:func:`modal_frf`) and **a simulated impact test** of the paper's
  cantilever (:func:`simulate_impact_test`, :func:`simulate_time_records`).
* :mod:`.beam_theory`: the analytic modes of a clamped-free Euler-Bernoulli
  beam (:func:`cantilever_modes`), which the simulation uses.
* :mod:`.hit_search`, :mod:`.hit_checks`, :mod:`.hits`, :mod:`.channels`,
  :mod:`.sep005`: raw impact recordings (finding the hits and cutting their
  records, the checks, the automatic window and the hit table, the units and the
  one force-channel rule, SDyPy SEP-005 channels).

The names of the first three are re-exported here
(``from ema_pipeline.acquisition import modal_frf``), imported on first use:
reading FRF files needs only :mod:`.channels` (through the recording
readers), and importing the others cost every ``identify`` command's start
about 8 ms.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ema_pipeline.lazy import lazy_exports

if TYPE_CHECKING:
    from ema_pipeline.acquisition.beam_theory import cantilever_beta_l, cantilever_modes
    from ema_pipeline.acquisition.estimation import (
        EXP_WINDOW_MAX_EXPONENT,
        FRFEstimate,
        estimate_frf,
        estimate_frf_windows,
        exponential_window,
        force_window,
        shortest_exp_window_tau,
    )
    from ema_pipeline.acquisition.sep005 import from_sep005
    from ema_pipeline.acquisition.simulation import (
        TestSetup,
        anti_aliasing_filter,
        configuration_modes,
        half_sine_spectrum,
        modal_frf,
        noise_snr_db,
        simulate_impact_test,
        simulate_time_records,
        synthesize_frf_set,
    )

#: Each re-exported name's module.
_HOME = {
    "cantilever_beta_l": "beam_theory", "cantilever_modes": "beam_theory",
    "EXP_WINDOW_MAX_EXPONENT": "estimation", "FRFEstimate": "estimation",
    "estimate_frf": "estimation", "estimate_frf_windows": "estimation",
    "exponential_window": "estimation", "force_window": "estimation",
    "shortest_exp_window_tau": "estimation",
    "from_sep005": "sep005",
    "TestSetup": "simulation", "anti_aliasing_filter": "simulation",
    "configuration_modes": "simulation", "half_sine_spectrum": "simulation",
    "modal_frf": "simulation", "noise_snr_db": "simulation",
    "simulate_impact_test": "simulation", "simulate_time_records": "simulation",
    "synthesize_frf_set": "simulation",
}

__all__ = [
    "EXP_WINDOW_MAX_EXPONENT",
    "FRFEstimate",
    "TestSetup",
    "anti_aliasing_filter",
    "cantilever_beta_l",
    "cantilever_modes",
    "configuration_modes",
    "estimate_frf",
    "estimate_frf_windows",
    "exponential_window",
    "force_window",
    "from_sep005",
    "half_sine_spectrum",
    "modal_frf",
    "noise_snr_db",
    "shortest_exp_window_tau",
    "simulate_impact_test",
    "simulate_time_records",
    "synthesize_frf_set",
]


__getattr__, __dir__ = lazy_exports(__name__, _HOME)
