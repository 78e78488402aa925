"""Tables computed from the results, as ``pandas.DataFrame`` (or HTML built from
them): the six paper tables as printed, the mode table of one identification,
the fit quality, the test setup and the AutoMAC matrices.

Formatting and the paper's values live in :mod:`.tables`; this module only
decides what the rows and columns are.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ema_pipeline.data import DOF, FRFSet
from ema_pipeline.modal import mac
from ema_pipeline.report.htmlparts import esc
from ema_pipeline.report.inputs import BeamSetup, ReportInput
from ema_pipeline.report.tables import (
    TABLE_TITLES,
    compare_with_paper,
    html_matrix,
    html_table,
)

#: What the test setup table says of a field the FRF file does not hold.
NOT_IN_FILE = "not in the file"

if TYPE_CHECKING:  # pragma: no cover
    from ema_pipeline.identification.result import IdentificationResult

__all__ = [
    "COLUMN_TITLES",
    "cross_mac_html",
    "dof_labels",
    "fit_table",
    "mac_section",
    "mode_table",
    "mode_table_html",
    "report_tables",
    "setup_table",
    "stable_order_range",
    "label_as_tested",
]


def report_tables(report: ReportInput) -> dict[str, pd.DataFrame]:
    """The tables as printed: with the paper's values and deviations when comparing."""
    out = {}
    for name in TABLE_TITLES:
        if name in report.tables:
            t = report.tables[name]
            out[name] = compare_with_paper(name, t) if report.compare_with_paper else t
    return out


def stable_order_range(result: IdentificationResult) -> list[str]:
    """Per selected mode (ascending frequency) the model orders at which its pole
    cluster is stable, ``"lo-hi (n of N)"``; empty strings without cluster data."""
    from ema_pipeline.identification.result import stable_orders

    if result.selected is None or result.stabilization.order.size == 0:
        return [""] * result.modes.n_modes
    first, last, count = stable_orders(result)
    n_orders = np.unique(result.stabilization.order).size
    return [
        f"{first[k]}-{last[k]} ({count[k]} of {n_orders})" if count[k] else ""
        for k in np.argsort(result.modes.fn_hz)
    ]


def mode_table(result: IdentificationResult) -> pd.DataFrame:
    """The modal table of one identification, ascending frequency: ``mode,
    fn_hz, fn_std_hz, fd_hz, zeta_pct, zeta_std_pct, sigma_1_s`` (decay rate
    -Re(lambda), 1/s), ``mpc``, ``mpd_deg``, ``doubtful`` and ``stable_orders``
    (first-last order, count), and ``doubtful_reason`` (the rule that fired) when the
    identification names it."""
    from ema_pipeline.identification.result import modes_table

    table = modes_table(result)
    order = np.argsort(result.modes.fn_hz)
    table["sigma_1_s"] = -np.real(np.asarray(result.pole))[order]
    table["stable_orders"] = stable_order_range(result)
    columns = ["mode", "fn_hz", "fn_std_hz", "fd_hz", "zeta_pct", "zeta_std_pct", "sigma_1_s",
               "mpc", "stable_orders", "mpd_deg", "found_by", "doubtful"]
    if "doubtful_reason" in table:  # which rule fired
        columns.append("doubtful_reason")
    return table[columns]


def mode_table_html(result: IdentificationResult) -> str:
    """The modal table as HTML (``value ± std`` cells, consistent decimals; the
    doubtful rules in words: ``loose damping``, not ``loose_damping``)."""
    table = mode_table(result)
    for words in ("doubtful_reason", "found_by"):  # other_order: "other order"
        if words in table:
            table[words] = [str(v).replace("_", " ") for v in table[words]]
    return html_table(table, titles=COLUMN_TITLES)


#: Tooltips of the mode and fit table columns (HTML ``title`` of the header).
COLUMN_TITLES = {
    "fn_hz": "undamped natural frequency, Hz, ± one standard deviation",
    "fd_hz": "damped natural frequency, Hz (eq. 4)",
    "zeta_pct": "damping ratio in per cent, ± one standard deviation",
    "sigma_1_s": "decay rate sigma = zeta omega_n = -Re(lambda), 1/s",
    "mpc": "modal phase collinearity (1 = real mode)",
    "mpd_deg": "mean phase deviation, degrees (0 = real mode)",
    "doubtful": "marked for a second look: few stable orders, loose damping, complex shape, "
    "damping not resolved by the lines, found only in some bands, or (one or two channels) "
    "one of two poles under one peak or beside a second pole the data did not support, a "
    "refinement that wandered off, or found twice with the two answers apart",
    "doubtful_reason": "the rule that marked the mode doubtful",
    "found_by": "how the mode was found: in the band's stabilization diagram, in it at "
    "another order, in a narrower search's window, as the alternate of a failed candidate, "
    "as a close partner, in the fit's residual, as the answer to an expected frequency, or "
    "picked by hand (identify --picks)",
    "stable_orders": "model orders at which the pole is stable (count of orders computed)",
    "frac": "FRF assurance criterion of the synthesis",
    "error_pct": "normalised fit error ||H - H_fit|| / ||H||, per cent",
}


def label_as_tested(dof: DOF, negative: str) -> str:
    """The DOF's label with the direction as tested (the file's sign): ``3-Z``
    when the file gave ``3-Z`` (listed in ``negative``, the acquisition's
    ``response_negative`` or ``reference_negative``) and the reader flipped it
    to ``3+Z``; one sign convention for every table of the report.

    Examples
    --------
    >>> label_as_tested(DOF(3, 3), "3-Z"), label_as_tested(DOF(3, 3), "")
    ('3-Z', '3+Z')
    """
    tested = DOF(dof.node, -dof.direction)
    return tested.label() if tested.label() in set(negative.split()) else dof.label()


def dof_labels(frf: FRFSet) -> tuple[list[str], list[str]]:
    """The labels of ``frf``'s response and reference DOFs with the sign as
    tested (:func:`label_as_tested`): the one labelling of the FRFs for every
    table, legend and title of the report.

    Examples
    --------
    >>> from ema_pipeline.data import AcquisitionInfo
    >>> frf = FRFSet(freq_hz=np.arange(3.0), H=np.ones((2, 1, 3), dtype=complex),
    ...              response_dofs=(DOF(2), DOF(4)), reference_dofs=(DOF(3),),
    ...              acquisition=AcquisitionInfo(response_negative="2-Z",
    ...                                          reference_negative="3-Z"))
    >>> dof_labels(frf)
    (['2-Z', '4+Z'], ['3-Z'])
    """
    a = frf.acquisition
    return ([label_as_tested(d, a.response_negative) for d in frf.response_dofs],
            [label_as_tested(d, a.reference_negative) for d in frf.reference_dofs])


def fit_table(identification: Mapping[str, Any], frfs: Mapping[str, FRFSet]) -> pd.DataFrame:
    """Fit quality per configuration and FRF: FRAC and normalised error (per cent)
    of the synthesis, rows labelled with the DOFs of ``frfs`` when present."""
    rows = []
    for name, r in identification.items():
        frf = frfs.get(name)
        for o in range(r.frac.shape[0]):
            for i in range(r.frac.shape[1]):
                rows.append(
                    {
                        "configuration": name,
                        "response": label_as_tested(frf.response_dofs[o],
                                                 frf.acquisition.response_negative)
                        if frf else str(o + 1),
                        "reference": label_as_tested(frf.reference_dofs[i],
                                                  frf.acquisition.reference_negative)
                        if frf else str(i + 1),
                        "frac": float(r.frac[o, i]),
                        "error_pct": 100 * float(r.error[o, i]),
                    }
                )
    return pd.DataFrame(rows, columns=["configuration", "response", "reference", "frac",
                                       "error_pct"])


def setup_table(frfs: Mapping[str, FRFSet], geometry: BeamSetup | None) -> pd.DataFrame:
    """Test setup, one column per configuration (rows: what an engineer checks)."""

    def fmt(v: Any, unit: str = "", spec: str = "g") -> str:
        return NOT_IN_FILE if v is None else f"{v:{spec}}{unit}"

    def positions(dofs: Sequence[Any], negative: str) -> str:
        labels = []
        for d in dofs:  # the direction as tested (the file's sign), not as read
            label = label_as_tested(d, negative)
            if geometry is not None and 1 <= d.node <= geometry.n_elements + 1:
                label += f" (x = {geometry.node_x_m(d.node):.4g} m)"
            labels.append(label)
        return ", ".join(labels)

    columns: list[dict[str, str]] = []
    for frf in frfs.values():
        a = frf.acquisition
        responses = positions(frf.response_dofs, a.response_negative)
        references = positions(frf.reference_dofs, a.reference_negative)
        if a.layout == "reciprocal":  # a roving-hammer set, identified by reciprocity
            roles = {
                "test": f"roving hammer ({len(frf.response_dofs)} points), "
                f"{len(frf.reference_dofs)} fixed sensor(s); identified by reciprocity "
                "(hammer points as responses, so the shapes are at the hammer points)",
                "sensors (fixed)": references,
                "hammer (roving points)": responses,
            }
        else:
            roles = {"hammer (reference)": references, "sensors (responses)": responses}
        col = {
            "file": frf.source.path or "(in memory)",
            "sample rate": fmt(a.sample_rate_hz, " Hz"),
            "record length": (
                f"{a.duration_s:.4g} s ({a.n_samples} samples)" if a.duration_s
                else NOT_IN_FILE
            ),
            "frequency lines": f"{frf.freq_hz.size}, df = {frf.df_hz:.5g} Hz, "
            f"{frf.freq_hz[0]:.4g}-{frf.freq_hz[-1]:.5g} Hz",
            "averages": (fmt(a.n_averages) if a.n_averages_max is None
                         else f"{a.n_averages}-{a.n_averages_max} per point"),
            "estimator": a.estimator,
            "force window": a.force_window,
            "response window": a.response_window,
            "exponential window tau": (
                f"{a.exp_window_tau_s:.5g} s (adds {a.window_decay_rate:.4g} 1/s to sigma)"
                if a.exp_window_tau_s else "none"
            ),
            "quantity": f"{frf.quantity} ({frf.units})",
            **roles,
            "coherence": "in the file" if frf.coherence is not None else NOT_IN_FILE,
        }
        columns.append(col)
    keys = list(dict.fromkeys(k for col in columns for k in col))  # roles may differ
    return pd.DataFrame(
        [[k, *(col.get(k, "") for col in columns)] for k in keys],
        columns=["", *[str(n) for n in frfs]],
    )


def mac_section(identification: Mapping[str, Any], genuine: str, *, cross: bool = True) -> str:
    """The AutoMAC of each identification as HTML matrices, then (``cross``) the
    MAC of the ``genuine`` configuration against each other one
    (:func:`cross_mac_html`)."""
    parts = []
    for name, r in identification.items():
        labels = [f"{f:.2f} Hz" for f in r.modes.fn_hz]
        parts.append(html_matrix(r.mac, labels, labels, caption=f"AutoMAC - {name}"))
    if cross:
        parts.append(cross_mac_html(identification, genuine))
    note = (
        '<p class="muted">With few sensors the AutoMAC cannot separate all modes: '
        "off-diagonal values near 1 say the sensors do not tell those shapes apart, "
        "not that the modes are the same.</p>"
    )
    return "".join(parts) + note


def cross_mac_html(identification: Mapping[str, Any], genuine: str) -> str:
    """The MAC (:func:`ema_pipeline.modal.mac`) of the ``genuine`` (reference)
    configuration's modes (rows) against each other configuration's (columns),
    where both have shapes at the same DOFs."""
    parts = []
    ref = identification.get(genuine)
    if ref is not None and ref.modes.shapes is not None:
        for name, r in identification.items():
            if name == genuine or r.modes.shapes is None:
                continue
            if r.modes.dofs != ref.modes.dofs:
                parts.append(f'<p class="muted">{esc(name)}: not measured at the DOFs of '
                             f"{esc(genuine)}, no MAC.</p>")
                continue
            m = mac(ref.modes.shapes, r.modes.shapes)
            parts.append(html_matrix(
                m, [f"{k + 1}: {f:.2f} Hz" for k, f in enumerate(ref.modes.fn_hz)],
                [f"{k + 1}: {f:.2f} Hz" for k, f in enumerate(r.modes.fn_hz)],
                caption=f"MAC {genuine} (rows) vs {name} (columns)",
            ))
    return "".join(parts)
