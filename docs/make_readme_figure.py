"""Write ``docs/_static/readme_fit.svg``, the picture of the README and of the
documentation's front page: the example's measured FRF (``raw_frf/genuine.uff``)
and its synthesis from the identified modes.

Run from the repository root: ``python docs/make_readme_figure.py [PREVIEW.png]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ema_pipeline import io  # noqa: E402
from ema_pipeline.identification import identify  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "_static" / "readme_fit.svg"


def main(png: str | None = None) -> Path:
    """Write the SVG (and a PNG preview to ``png`` when given)."""
    frf = io.read_frf(REPO / "raw_frf" / "genuine.uff")
    result = identify(frf)
    f = frf.freq_hz
    keep = (f >= 5) & (f <= 900)
    # about 700 lines, denser at the resonances: every line near a mode, every 8th elsewhere
    near = np.zeros_like(f, dtype=bool)
    for fn, z in zip(result.modes.fn_hz, result.modes.zeta, strict=True):
        near |= np.abs(f - fn) < max(6 * z * fn, 1.0)
    lines = np.flatnonzero(keep & (near | (np.arange(f.size) % 8 == 0)))
    matplotlib.rcParams.update(
        {"svg.hashsalt": "ema-pipeline", "svg.fonttype": "none", "font.size": 8})
    fig, ax = plt.subplots(figsize=(6.4, 2.4), layout="constrained")
    ax.semilogy(f[lines], np.abs(frf.H[1, 0, lines]), color="0.55", lw=1.6,
                label="measured H1 (node 6 / hammer at node 8)")
    fit = np.clip(np.searchsorted(result.freq_hz, f[lines]), 0, result.freq_hz.size - 1)
    ax.semilogy(result.freq_hz[fit], np.abs(result.H_fit[1, 0, fit]), color="C3", lw=0.8, ls="--",
                label="synthesised from the identified modes")
    for fn in result.modes.fn_hz:
        ax.axvline(fn, color="C0", lw=0.5, alpha=0.6)
        ax.annotate(f"{fn:.2f} Hz", (fn, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(2, -10), textcoords="offset points", fontsize=7, color="C0")
    ax.set(xlim=(0, 900), xlabel="frequency (Hz)", ylabel="|H| (m/s$^2$/N)")
    ax.legend(loc="upper left", bbox_to_anchor=(0.3, 0.88), fontsize=7, frameon=False)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, format="svg", metadata={"Date": None})
    if png:
        fig.savefig(png, dpi=100)
    plt.close(fig)
    return OUT


if __name__ == "__main__":
    print(main(*sys.argv[1:2]))
