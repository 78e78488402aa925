"""Paper Tables 1-6 of the added-mass study as pandas DataFrames (the CSV forms
of DESIGN.md).

* :func:`modal_parameters_from_table` - measured modal parameters from the
  Table 1 form (configuration, mode, fd_hz, zeta_pct).
* :func:`modal_added_mass_table` (Table 2), :func:`fe_frequency_table`
  (Tables 3 and 5), :func:`updated_parameters_table` (Table 4) and
  :func:`local_added_mass_table` (Table 6) from the stage results; the names
  and required leading columns of the tables are :data:`TABLE_COLUMNS`.
* :func:`exact_method_notes` - the sentences that put the ``exact`` local added
  mass beside the first-order (``block``) one, for the report.

The whole set from one FE stage run is
:func:`ema_pipeline.pipeline.fe_stage.fe_stage_tables`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np
import pandas as pd

from ema_pipeline import fe
from ema_pipeline.added_mass.exact import EXACT_METHOD, ExactOutcome
from ema_pipeline.added_mass.local import LocalAddedMassResult
from ema_pipeline.added_mass.modal import AddedMassResult, require_genuine
from ema_pipeline.data import DataError, ModalParameters

__all__ = [
    "TABLE4_PARAMETER_NAMES",
    "TABLE_COLUMNS",
    "TABLE6_EXTRA_COLUMNS",
    "exact_method_notes",
    "fe_frequency_table",
    "local_added_mass_table",
    "modal_added_mass_table",
    "modal_parameters_from_table",
    "updated_parameters_table",
]

#: Required leading columns of each table (DESIGN.md); extra columns follow them.
TABLE_COLUMNS: dict[str, tuple[str, ...]] = {
    "table2_modal_added_mass": ("configuration", "mode", "added_mass_ratio"),
    "table3_fe_initial": ("mode", "fn_hz"),
    "table4_updated_parameters": ("parameter", "unit", "initial", "updated", "lower", "upper"),
    "table5_fe_updated": ("mode", "fn_hz"),
    "table6_local_added_mass": ("configuration", "method", "element", "delta_k", "delta_m"),
}

#: Table 6 columns after :data:`TABLE_COLUMNS` (NaN where a method has no such value):
#: ``delta_m_std`` and its ``delta_m_std_source`` (``frequency_std``: the identified
#: frequencies' std propagated through the exact fit, linearised; ``misfit``: from the fit
#: residual, used when the frequencies carry no std; ``none``), ``residual`` (rms relative
#: mismatch of the fitted frequency ratios), ``condition_number`` and ``rank`` of the
#: exact fit's sensitivity matrix, ``n_modes`` used, ``status`` (``ok``, ``refused``: the
#: modes cannot determine the unknowns, ``failed``) and its ``reason``, then ``delta_k_std``,
#: ``delta_m_std_misfit`` and ``delta_m_first_order`` (the exact fit's first-order start).
TABLE6_EXTRA_COLUMNS: tuple[str, ...] = (
    "delta_m_std", "delta_m_std_source", "residual", "condition_number", "rank", "n_modes",
    "status", "reason", "delta_k_std", "delta_m_std_misfit", "delta_m_first_order",
)

#: Table 4 ``parameter`` column: update parameter (:data:`ema_pipeline.fe.PARAMETER_NAMES`)
#: -> the name written in the table.
TABLE4_PARAMETER_NAMES: dict[str, str] = {
    "thickness_m": "thickness",
    "width_m": "width",
    "length_m": "length",
    "youngs_modulus_pa": "youngs_modulus",
    "density_kg_m3": "density",
}


def modal_parameters_from_table(
    table: pd.DataFrame, *, genuine: str | None = "genuine", source: str = ""
) -> dict[str, ModalParameters]:
    """Measured modal parameters from a Table 1 form DataFrame.

    Columns ``configuration, mode, fd_hz, zeta_pct`` (damped natural frequency in
    Hz, damping ratio in percent); optional ``fn_std_hz`` and ``zeta_std_pct``.
    Rows are sorted by mode; a row with an empty ``fd_hz`` is a mode not
    identified in that configuration and is left out. fn = fd / sqrt(1 - zeta^2)
    (eq. 4). ``genuine`` (if not None) must be one of the configurations.
    ``source`` (e.g. a file name) prefixes error messages.
    """
    where = f"{source}: " if source else ""
    if not isinstance(table, pd.DataFrame):
        raise DataError(f"{where}expected a pandas DataFrame, got {type(table).__name__}")
    required = ("configuration", "mode", "fd_hz", "zeta_pct")
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise DataError(
            f"{where}Table 1 is missing column(s) {missing}; expected at least {list(required)}, "
            f"got {list(table.columns)}"
        )
    if table.empty:
        raise DataError(f"{where}Table 1 has no rows")
    df = table.copy()
    df["configuration"] = df["configuration"].astype(str).str.strip()
    numeric = ["mode", "fd_hz", "zeta_pct"] + [
        c for c in ("fn_std_hz", "zeta_std_pct") if c in df.columns
    ]
    for col in numeric:
        conv = pd.to_numeric(df[col], errors="coerce")
        bad = conv.isna() & df[col].notna() & (df[col].astype(str).str.strip() != "")
        if bad.any():
            raise DataError(
                f"{where}column {col!r} has non-numeric value(s) "
                f"{df.loc[bad, col].astype(str).tolist()[:3]}"
            )
        df[col] = conv
    if df["mode"].isna().any() or (df["mode"] % 1 != 0).any() or (df["mode"] < 1).any():
        raise DataError(f"{where}column 'mode' must hold positive integers")
    dup = df.duplicated(["configuration", "mode"])
    if dup.any():
        r = df.loc[dup].iloc[0]
        raise DataError(f"{where}mode {int(r['mode'])} of {r['configuration']!r} appears twice")
    df = df[df["fd_hz"].notna()]
    if (df["fd_hz"] <= 0).any():
        raise DataError(f"{where}fd_hz must be positive")
    if df["zeta_pct"].isna().any() or ((df["zeta_pct"] < 0) | (df["zeta_pct"] >= 100)).any():
        raise DataError(f"{where}zeta_pct must be given in percent, 0 <= zeta_pct < 100")
    out: dict[str, ModalParameters] = {}
    for name, grp in df.sort_values(["configuration", "mode"]).groupby("configuration",
                                                                      sort=False):
        zeta = grp["zeta_pct"].to_numpy(float) / 100.0
        kwargs: dict[str, object] = {"configuration": str(name)}
        if "fn_std_hz" in grp:
            kwargs["fn_std_hz"] = grp["fn_std_hz"].to_numpy(float)
        if "zeta_std_pct" in grp:
            kwargs["zeta_std"] = grp["zeta_std_pct"].to_numpy(float) / 100.0
        out[str(name)] = ModalParameters.from_damped(grp["fd_hz"].to_numpy(float), zeta, **kwargs)
    if genuine is not None:
        try:
            require_genuine(out, genuine)
        except DataError as exc:
            raise DataError(f"{where}{exc}") from None
    return out


def modal_added_mass_table(
    results: Mapping[str, AddedMassResult], exact: Mapping[str, ExactOutcome] | None = None
) -> pd.DataFrame:
    """Table 2 in the DESIGN.md form: configuration, mode, added_mass_ratio (+ extras).

    Extra columns: ``added_mass_ratio_std``, the paired frequencies, ``paired``
    and, from the ``exact`` fit of each configuration (``exact``, NaN where it
    was refused), the FE-based true modal added mass
    ``added_mass_ratio_fe`` = phi_r^T dM phi_r (genuine FE shapes,
    mass-normalised, dM the fitted added mass): what eq. (10) returns if the
    mode shapes do not change. Where ``added_mass_ratio`` (eq. 10 on the
    measured frequencies) departs from it, eq. (10)'s assumption of unchanged
    shapes breaks. ``added_mass_ratio_fe_modified_shape`` is the same with the
    fitted modified shapes, phi_wr^T dM phi_wr / phi_wr^T M phi_wr.

    Examples
    --------
    >>> from ema_pipeline.added_mass import modal_added_mass_all
    >>> from ema_pipeline.data import ModalParameters
    >>> z = np.zeros(2)
    >>> m = {"genuine": ModalParameters(fn_hz=[20.0, 120.0], zeta=z),
    ...      "wet": ModalParameters(fn_hz=[19.0, 117.0], zeta=z)}
    >>> t = modal_added_mass_table(modal_added_mass_all(m))
    >>> t[["configuration", "mode", "added_mass_ratio"]].round(4).values.tolist()
    [['wet', 1, 0.108], ['wet', 2, 0.0519]]
    """
    rows = []
    nan = float("nan")
    for name, res in results.items():
        fit = exact.get(name) if exact else None
        fit_res = fit.result if fit is not None else None
        fe_ratio: dict[int, tuple[float, float]] = {}
        if fit_res is not None:
            fe_ratio = {
                int(m): (float(a), float(b))
                for m, a, b in zip(fit_res.mode, fit_res.modal_added_mass,
                                   fit_res.modal_added_mass_modified_shape, strict=True)
            }
        for i, m in enumerate(res.mode):
            ratio_fe, ratio_fe_mod = fe_ratio.get(int(m), (nan, nan))
            rows.append(
                {
                    "configuration": name,
                    "mode": int(m),
                    "added_mass_ratio": res.ratio[i],
                    "added_mass_ratio_std": res.ratio_std[i],
                    "fn_genuine_hz": res.fn_genuine_hz[i],
                    "fn_modified_hz": res.fn_modified_hz[i],
                    "paired": bool(res.partner[i] >= 0),
                    "added_mass_ratio_fe": ratio_fe,
                    "added_mass_ratio_fe_modified_shape": ratio_fe_mod,
                }
            )
    cols = [*TABLE_COLUMNS["table2_modal_added_mass"], "added_mass_ratio_std",
            "fn_genuine_hz", "fn_modified_hz", "paired", "added_mass_ratio_fe",
            "added_mass_ratio_fe_modified_shape"]
    return pd.DataFrame(rows, columns=cols)


def updated_parameters_table(
    upd: fe.UpdateResult, labels: Mapping[str, str] | None = None
) -> pd.DataFrame:
    """Table 4: initial, updated and bound values of the five update parameters.

    Extra columns after :data:`TABLE_COLUMNS`: the spread over the runs
    (``run_min, run_max, run_std``), ``paper_label`` (``labels[name]``, e.g. the
    row names a publication prints; empty without ``labels``) and
    ``identifiable``; a last row holds the identifiable combination
    h*sqrt(E/rho)/L^2 in 1/s (``identifiable`` True).
    """
    labels = labels or {}
    rows = []
    for i, name in enumerate(upd.parameter_names):
        rows.append(
            {
                "parameter": TABLE4_PARAMETER_NAMES[name],
                "unit": upd.units[i],
                "initial": upd.initial[i],
                "updated": upd.updated[i],
                "lower": upd.lower[i],
                "upper": upd.upper[i],
                "run_min": upd.run_min[i],
                "run_max": upd.run_max[i],
                "run_std": upd.run_std[i],
                "paper_label": labels.get(name, ""),
                "identifiable": False,
            }
        )
    comb = fe.identifiable_combination
    rows.append(
        {
            "parameter": fe.IDENTIFIABLE_NAME,
            "unit": "1/s",
            "initial": upd.identifiable_initial,
            "updated": upd.identifiable_updated,
            "lower": float(comb(np.array([upd.lower[0], 0, upd.upper[2], upd.lower[3],
                                          upd.upper[4]]))),
            "upper": float(comb(np.array([upd.upper[0], 0, upd.lower[2], upd.upper[3],
                                          upd.lower[4]]))),
            "run_min": float(np.min(upd.identifiable_runs)),
            "run_max": float(np.max(upd.identifiable_runs)),
            "run_std": float(np.std(upd.identifiable_runs, ddof=1))
            if upd.identifiable_runs.size > 1 else np.nan,
            "paper_label": "",
            "identifiable": True,
        }
    )
    return pd.DataFrame(rows)


def fe_frequency_table(
    fn_hz: np.ndarray, fn_measured_hz: np.ndarray | None = None
) -> pd.DataFrame:
    """Table 3 (initial) or Table 5 (updated): FE natural frequencies per mode.

    With ``fn_measured_hz`` (Table 5) the measured undamped frequency and the
    relative deviation (fn_hz - fn_measured_hz) / fn_measured_hz follow.
    """
    fn = np.asarray(fn_hz, dtype=float)
    table = {"mode": np.arange(1, fn.size + 1), "fn_hz": fn}
    if fn_measured_hz is not None:
        fx = np.asarray(fn_measured_hz, dtype=float)
        table["fn_measured_hz"] = fx
        table["rel_deviation"] = (fn - fx) / fx
    return pd.DataFrame(table)


def local_added_mass_table(
    results: Iterable[LocalAddedMassResult], exact: Mapping[str, ExactOutcome] | None = None
) -> pd.DataFrame:
    """Table 6: delta_k, delta_m per configuration, method and immersed element.

    One row per configuration, method (``block``, ``projected`` from
    ``results``, then ``exact`` from ``exact``) and element, configurations in
    the order they first appear. Columns: :data:`TABLE_COLUMNS` then
    :data:`TABLE6_EXTRA_COLUMNS`; the first-order methods have no std,
    residual or condition number (NaN). A refused ``exact`` fit is a row with
    NaN values, ``status`` ``refused`` and the reason.

    Examples
    --------
    >>> list(local_added_mass_table([]).columns[:5])
    ['configuration', 'method', 'element', 'delta_k', 'delta_m']
    """
    nan = float("nan")
    by_config: dict[str, list[dict[str, object]]] = {}
    for r in results:
        by_config.setdefault(r.configuration, []).extend(
            {
                "configuration": r.configuration,
                "method": r.method,
                "element": el,
                "delta_k": float(r.delta_k[i]),
                "delta_m": float(r.delta_m[i]),
                "delta_m_std": nan,
                "delta_m_std_source": "none",
                "residual": nan,
                "condition_number": nan,
                "rank": -1,
                "n_modes": int(r.mode.size),
                "status": "ok",
                "reason": "",
            }
            for i, el in enumerate(r.elements)
        )
    for name, outcome in (exact or {}).items():
        by_config.setdefault(name, []).extend(outcome.rows())
    return pd.DataFrame(
        [row for rows in by_config.values() for row in rows],
        columns=[*TABLE_COLUMNS["table6_local_added_mass"], *TABLE6_EXTRA_COLUMNS],
    )


def exact_method_notes(table6: pd.DataFrame) -> list[str]:
    """Sentences that put the ``exact`` local added mass beside the ``block`` one.

    From a Table 6 (:func:`local_added_mass_table`): one sentence on why the
    two differ with the values per configuration and element, one on the
    standard deviations (from the frequencies' std and from the fit misfit,
    which also covers model error), and one per refused or failed exact fit.

    Examples
    --------
    >>> t = pd.DataFrame({"configuration": ["tank", "tank"], "method": ["block", "exact"],
    ...                   "element": [10, 10], "delta_k": [0.0, np.nan],
    ...                   "delta_m": [0.31, 0.42], "delta_m_std": [np.nan, 0.02],
    ...                   "delta_m_std_source": ["none", "misfit"], "residual": [np.nan, 0.004],
    ...                   "delta_m_std_misfit": [np.nan, 0.02],
    ...                   "status": ["ok", "ok"], "reason": ["", ""]})
    >>> for line in exact_method_notes(t):  # doctest: +NORMALIZE_WHITESPACE
    ...     print(line)
    local added mass: the paper's eq. (14)-(20) is first order in delta_m and assumes
    unchanged mode shapes; fitting the FE eigenvalues exactly (method exact) gives
    delta_m = 0.420 (tank, element 10) where the first-order block method gives 0.310.
    exact local added mass std: 0.02 from the fit misfit (frequency ratios matched to
    0.40 % rms) for tank, element 10.
    """
    if table6.empty or "method" not in table6:
        return []
    ex = table6[table6["method"] == EXACT_METHOD]
    block = table6[table6["method"] == "block"].set_index(["configuration", "element"])
    values, stds, refused = [], [], []
    for row in ex.itertuples(index=False):
        where = f"{row.configuration}, element {row.element}"
        if row.status != "ok":
            refused.append(f"exact local added mass of {where} not reported ({row.status}): "
                           f"{row.reason}")
            continue
        key = (row.configuration, row.element)
        first = (f" where the first-order block method gives {block.loc[key, 'delta_m']:.3f}"
                 if key in block.index else "")
        values.append(f"delta_m = {row.delta_m:.3f} ({where}){first}")
        misfit = float(getattr(row, "delta_m_std_misfit", np.nan))
        fit = f"fit misfit (frequency ratios matched to {100 * row.residual:.2f} % rms)"
        if row.delta_m_std_source == "frequency_std":
            extra = f", {misfit:.2g} from the {fit}" if np.isfinite(misfit) else ""
            stds.append(f"{row.delta_m_std:.2g} from the identified frequencies' std{extra} "
                        f"for {where}")
        elif row.delta_m_std_source == "misfit":
            stds.append(f"{row.delta_m_std:.2g} from the {fit} for {where}")
    notes = []
    if values:
        notes.append(
            "local added mass: the paper's eq. (14)-(20) is first order in delta_m and assumes "
            "unchanged mode shapes; fitting the FE eigenvalues exactly (method exact) gives "
            + "; ".join(values) + ".")
    if stds:
        notes.append("exact local added mass std: " + "; ".join(stds) + ".")
    return notes + refused
