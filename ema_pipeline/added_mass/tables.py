"""Paper Tables 1-6 of the added-mass study as pandas DataFrames (the CSV forms
of DESIGN.md).

* :func:`modal_parameters_from_table` - measured modal parameters from the
  Table 1 form (configuration, mode, fd_hz, zeta_pct).
* :func:`modal_added_mass_table` (Table 2), :func:`fe_frequency_table`
  (Tables 3 and 5), :func:`updated_parameters_table` (Table 4) and
  :func:`local_added_mass_table` (Table 6) from the stage results; the names
  and required leading columns of the tables are :data:`TABLE_COLUMNS`.

The whole set from one FE stage run is
:func:`ema_pipeline.pipeline.fe_stage.fe_stage_tables`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np
import pandas as pd

from ema_pipeline import fe
from ema_pipeline.added_mass.local import LocalAddedMassResult
from ema_pipeline.added_mass.modal import AddedMassResult, require_genuine
from ema_pipeline.data import DataError, ModalParameters

__all__ = [
    "TABLE4_PARAMETER_NAMES",
    "TABLE_COLUMNS",
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
    "table6_local_added_mass": ("configuration", "method", "delta_k", "delta_m"),
}

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


def modal_added_mass_table(results: Mapping[str, AddedMassResult]) -> pd.DataFrame:
    """Table 2 in the DESIGN.md form: configuration, mode, added_mass_ratio (+ extras)."""
    rows = []
    for name, res in results.items():
        for i, m in enumerate(res.mode):
            rows.append(
                {
                    "configuration": name,
                    "mode": int(m),
                    "added_mass_ratio": res.ratio[i],
                    "added_mass_ratio_std": res.ratio_std[i],
                    "fn_genuine_hz": res.fn_genuine_hz[i],
                    "fn_modified_hz": res.fn_modified_hz[i],
                    "paired": bool(res.partner[i] >= 0),
                }
            )
    cols = [*TABLE_COLUMNS["table2_modal_added_mass"], "added_mass_ratio_std",
            "fn_genuine_hz", "fn_modified_hz", "paired"]
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


def local_added_mass_table(results: Iterable[LocalAddedMassResult]) -> pd.DataFrame:
    """Table 6: delta_k, delta_m per configuration, method and immersed element.

    Extra columns: the element number and the number of modes used.
    """
    return pd.DataFrame(
        [
            {
                "configuration": r.configuration,
                "method": r.method,
                "delta_k": r.delta_k[i],
                "delta_m": r.delta_m[i],
                "element": el,
                "n_modes": int(r.mode.size),
            }
            for r in results
            for i, el in enumerate(r.elements)
        ],
        columns=[*TABLE_COLUMNS["table6_local_added_mass"], "element", "n_modes"],
    )
