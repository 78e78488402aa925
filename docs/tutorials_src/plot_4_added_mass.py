"""
The added-mass study
====================

A beam whose tip element carries an extra 30 % of its mass (a known answer),
simulated on the FE beam, identified like a measurement, and the added mass
recovered: the modal added mass per mode (eq. 10) and the local added mass of
the tip element by the exact fit (see :doc:`../theory`).
"""

# %%
import numpy as np

from ema_pipeline import added_mass
from ema_pipeline.data import Beam
from ema_pipeline.identification import IdentificationOptions, identify
from ema_pipeline.pipeline.simulate import simulate_added_mass_test

options = IdentificationOptions()  # the defaults
genuine = identify(simulate_added_mass_test({}, seed=1, configuration="genuine"), options)
truth = identify(simulate_added_mass_test({10: 0.3}, seed=2, configuration="truth"), options)
print(genuine)
print(truth)

# %%
# Modal added mass, eq. (10): modes paired by frequency and MAC.
modal = added_mass.modal_added_mass(genuine.modes, truth.modes)
print(np.round(modal.ratio, 4))

# %%
# The exact local added mass of the tip element (element 10), with the standard
# deviation propagated from the identified frequencies:
n = min(4, genuine.modes.n_modes, truth.modes.n_modes)
exact = added_mass.exact_added_mass(
    Beam(), genuine.modes.fn_hz[:n], truth.modes.fn_hz[:n],
    fn_genuine_std_hz=genuine.modes.fn_std_hz[:n], fn_modified_std_hz=truth.modes.fn_std_hz[:n],
    immersed_elements=(10,))
print(f"delta_m = {exact.delta_m[0]:.4f} +- {exact.delta_m_std[0]:.1e} (truth 0.3000; "
      f"first order: {exact.delta_m_first_order[0]:.4f})")
