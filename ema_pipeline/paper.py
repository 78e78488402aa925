"""Values printed in the reference paper (added mass of a partially submerged
cantilever beam), used as simulation defaults and as the yardstick the report
and the tests compare against.

Tables 1, 2 and 6 print damping ratios and ratios under a "%" header; here every
ratio is a ratio (0.0049894, 0.1479), as ``../shared/DESIGN.md`` explains.
Table 4's row names are swapped against the geometry: its "width" is the bending
thickness h and its "height" the width b.
"""

from __future__ import annotations

import numpy as np

CONFIGURATIONS = ("genuine", "larger_tank", "smaller_tank")

#: Table 1: damped natural frequencies (Hz) and damping ratios per configuration.
TABLE1_FD_HZ: dict[str, np.ndarray] = {
    "genuine": np.array([18.14, 112.07, 327.57, 629.59]),
    "larger_tank": np.array([16.93, 106.99, 320.71, 618.94]),
    "smaller_tank": np.array([17.00, 108.34, 321.66, 621.00]),
}
TABLE1_ZETA: dict[str, np.ndarray] = {
    "genuine": np.array([0.49894, 0.67156, 0.29140, 0.38025]) / 100,
    "larger_tank": np.array([0.87303, 2.37840, 0.54096, 0.87303]) / 100,
    "smaller_tank": np.array([0.65432, 1.14640, 0.34052, 0.88930]) / 100,
}

#: Table 2: modal added-mass ratio m_ar/m_r per mode (eq. 10).
TABLE2_RATIO: dict[str, np.ndarray] = {
    "larger_tank": np.array([0.1479, 0.0971, 0.0432, 0.0347]),
    "smaller_tank": np.array([0.1388, 0.0700, 0.0371, 0.0279]),
}

#: Table 3: natural frequencies (Hz) of the initial FE model.
TABLE3_FN_HZ = np.array([19.84, 124.33, 348.12, 682.18])

#: Table 4: initial and updated design parameters, keyed by what they really are.
TABLE4_INITIAL = {
    "thickness_m": 0.01,
    "width_m": 0.05,
    "length_m": 0.65,
    "youngs_modulus_pa": 210e9,
    "density_kg_m3": 7800.0,
}
#: Table 4: the row names the paper prints, per update parameter (swapped
#: against the geometry for b and h).
TABLE4_LABELS = {
    "thickness_m": "Width",
    "width_m": "Height",
    "length_m": "Length",
    "youngs_modulus_pa": "Elastic modulus",
    "density_kg_m3": "Density",
}
TABLE4_UPDATED = {
    "thickness_m": 0.009497,
    "width_m": 0.049740,
    "length_m": 0.655755,
    "youngs_modulus_pa": 210.02799489e9,
    "density_kg_m3": 8106.7788,
}

#: Table 5: natural frequencies (Hz) of the updated FE model.
TABLE5_FN_HZ = np.array([18.14, 113.69, 318.39, 624.36])

#: Table 6: local added mass on the immersed element (proportional factors).
TABLE6 = {
    "larger_tank": {"delta_k": 0.0000, "delta_m": 0.3122},
    "smaller_tank": {"delta_k": 0.0002, "delta_m": 0.2547},
}
