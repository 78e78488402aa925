"""
Simulate, identify and report
=============================

The paper's impact test of the genuine (dry) beam, simulated with known modal
parameters, identified unattended, and written as a report. Everything on this
page was computed when the documentation was built.
"""

# %%
# Simulate the impact test: accelerometers at nodes 3 and 6, hammer at node 8,
# 4 averages, force and exponential windows, 40 dB noise (see
# :doc:`../guide/acquisition`).
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ema_pipeline import io, paper
from ema_pipeline.identification import IdentificationOptions, identify, modes_table
from ema_pipeline.pipeline.simulate import simulate_paper_test
from ema_pipeline.report.matplotlib_plots import plot_stabilization

frf = simulate_paper_test("genuine", seed=1)
print(frf)

# %%
# Identify at the defaults: no band, no model order, no picking.
result = identify(frf)
print(result)
print(modes_table(result)[["mode", "fn_hz", "zeta_pct", "fn_std_hz", "zeta_std_pct"]])

# %%
# Against the truth the simulation used (the paper's Table 1, damped
# frequencies):
truth_hz = np.asarray(paper.TABLE1_FD_HZ["genuine"], dtype=float)
error_pct = 100 * (result.modes.fd_hz - truth_hz) / truth_hz
print("frequency error in %:", np.round(error_pct, 4))

# %%
# The stabilization diagram over the FRF sum, with the selected modes:
fig, ax = plt.subplots(figsize=(6, 3.2), layout="constrained")
plot_stabilization(ax, result.stabilization, freq_hz=frf.freq_hz,
                   frf_sum=np.abs(frf.H).sum(axis=(0, 1)), selected_hz=result.modes.fn_hz)
ax.set_xlim(0, 1000)

# %%
# Write the FRFs and the report of ``ema-pipeline identify --report``:
from ema_pipeline.pipeline.reports import write_identify_report  # noqa: E402
from ema_pipeline.pipeline.single import identify_file  # noqa: E402

with tempfile.TemporaryDirectory() as tmp:
    path = io.write_frf(frf, Path(tmp) / "genuine.h5")
    options = IdentificationOptions()
    outcome = identify_file(path, Path(tmp) / "out", options, keep=True)
    page = write_identify_report(outcome, Path(tmp) / "out", options, figures=False)
    print(sorted(p.name for p in (Path(tmp) / "out").iterdir()))
    print(f"{page.name}: {page.stat().st_size // 1024} KiB")
