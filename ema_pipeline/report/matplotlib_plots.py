"""Diagrams of the identification stage drawn onto matplotlib axes, for
interactive use (a notebook, a script).

The report's pages draw their figures as SVG (:mod:`.figures`, :mod:`.svg`)
and do not use this module. matplotlib is optional: this module never imports
it (the functions draw on an ``Axes`` of the caller's own figure; no pyplot,
no global backend state), so only their callers need it, e.g. through the
``plots`` extra (``pip install ema-pipeline[plots]``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ema_pipeline.identification.result import StabilizationData
from ema_pipeline.report.stab_marks import STABILITY, stability_symbols

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

    from ema_pipeline.identification.result import IdentificationResult


def plot_stabilization(
    ax: Axes,
    stab: StabilizationData,
    *,
    freq_hz: np.ndarray | None = None,
    frf_sum: np.ndarray | None = None,
    selected_hz: np.ndarray | None = None,
) -> Axes:
    """Draw a stabilization diagram onto ``ax``.

    Each pole is drawn as its stability symbol in its colour, as the report's
    interactive diagram draws it (:data:`.stab_marks.STABILITY`): ``o`` new or
    unstable, ``f`` stable in frequency only, ``d`` in frequency and damping,
    ``v`` in frequency and vector, ``s`` in all three. With ``freq_hz`` and
    ``frf_sum`` (e.g. the sum of |H| over all FRFs) the FRF sum is drawn on a
    twin log axis; ``selected_hz`` draws vertical lines at the selected modes.
    """
    f, n = stab.freq_hz, stab.order
    symbols = stability_symbols(stab.flags)
    for key, (label, color) in STABILITY.items():
        mask = symbols == key
        if np.any(mask):
            ax.plot(f[mask], n[mask], marker=f"${key}$", color=color, ms=5, ls="none",
                    label=f"{key}: {label}")
    if selected_hz is not None:
        for fs in np.atleast_1d(selected_hz):
            ax.axvline(fs, color="tab:red", lw=0.8, alpha=0.7)
    ax.set_xlabel("frequency / Hz")
    ax.set_ylabel("model order")
    if freq_hz is not None and frf_sum is not None:
        ax2 = ax.twinx()
        ax2.semilogy(freq_hz, frf_sum, color="k", lw=0.8)
        ax2.set_ylabel("sum |H|")
    ax.legend(loc="upper left", fontsize="small")
    return ax


def plot_fit(
    ax: Axes,
    freq_hz: np.ndarray,
    H: np.ndarray,
    H_fit: np.ndarray,
    *,
    label: str = "",
    frac_value: float | None = None,
    error_value: float | None = None,
) -> Axes:
    """Draw one measured FRF and its synthesis (magnitude, log scale) onto ``ax``.

    The title carries the FRAC and the normalised error when given.
    """
    ax.semilogy(freq_hz, np.abs(H), color="0.5", lw=0.8, label="measured")
    ax.semilogy(freq_hz, np.abs(H_fit), color="tab:red", lw=0.9, ls="--", label="synthesised")
    ax.semilogy(freq_hz, np.abs(H - H_fit), color="tab:blue", lw=0.5, alpha=0.6,
                label="difference")
    parts = [label] if label else []
    if frac_value is not None:
        parts.append(f"FRAC {frac_value:.4f}")
    if error_value is not None:
        parts.append(f"error {100 * error_value:.2f} %")
    ax.set_title(", ".join(parts), fontsize="small")
    ax.set_xlabel("frequency / Hz")
    ax.set_ylabel("|H|")
    ax.legend(fontsize="x-small", loc="lower right")
    return ax


def plot_fit_quality(
    ax: Axes, result: IdentificationResult, H: np.ndarray, output: int, reference: int = 0
) -> Axes:
    """Draw measured vs synthesised FRF ``(output, reference)`` with its FRAC and
    normalised error onto ``ax``. ``H`` is the measured (n_out, n_in, n_freq)
    array on ``result.freq_hz`` (e.g. ``frf.band(*result.settings.band_hz).H``)."""
    label = f"{result.modes.dofs[output].label()}" if result.modes.dofs else f"out {output}"
    return plot_fit(
        ax,
        result.freq_hz,
        H[output, reference],
        result.H_fit[output, reference],
        label=label,
        frac_value=float(result.frac[output, reference]),
        error_value=float(result.error[output, reference]),
    )
