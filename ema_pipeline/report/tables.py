"""The report's tables: the paper's values beside ours, the mode table, and
number formatting with consistent decimals per column.

Decimals per column: a column with a standard deviation beside it
(``fn_hz``/``fn_std_hz``, ``zeta_pct``/``zeta_std_pct``, ``x``/``x_std``) is
printed to the decimal of the second significant digit of its median standard
deviation; other columns to five significant digits of their largest value, or
in e-notation when they span more than that. Markdown tables keep the CSV
column names; HTML tables show ``value ± std`` in one cell.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from html import escape
from typing import Any

import numpy as np
import pandas as pd

from ema_pipeline import data, fe, paper

__all__ = [
    "TABLE_TITLES",
    "column_formatters",
    "compare_with_paper",
    "html_matrix",
    "html_table",
    "markdown_table",
    "std_column",
]

#: Titles of the six tables, as in the paper.
TABLE_TITLES = {
    "table1_modal_parameters": "Table 1 - Measured natural frequencies and damping ratios",
    "table2_modal_added_mass": "Table 2 - Modal added mass (ratio m_ar/m_r, eq. 10)",
    "table3_fe_initial": "Table 3 - Natural frequencies of the initial FE model",
    "table4_updated_parameters": "Table 4 - Updated design parameters",
    "table5_fe_updated": "Table 5 - Natural frequencies of the updated FE model",
    "table6_local_added_mass": "Table 6 - Local added mass on the immersed element(s)",
}

#: Table 4 parameter names (as the FE stage writes them) -> keys of paper.TABLE4_*.
TABLE4_PAPER_KEYS = {
    "thickness": "thickness_m",
    "width": "width_m",
    "length": "length_m",
    "youngs_modulus": "youngs_modulus_pa",
    "density": "density_kg_m3",
}

#: Fixed decimals of columns whose scale is known (ratios near 1, percentages of deviations).
FIXED_DECIMALS = {
    "mpc": 4,
    "mpd_deg": 2,
    "frac": 4,
    "fit_frac": 4,
    "error_pct": 2,
    "fit_error_pct": 2,
    "dev_fd_hz": 3,
    "dev_pct": 2,
    "dev_zeta_rel_pct": 1,
    "dev_delta_m_pct": 1,
    "dev_ratio": 4,
    "rel_deviation": 5,
}


# --------------------------------------------------------------------------
# Tables beside the paper
# --------------------------------------------------------------------------


def _paper_table1() -> pd.DataFrame:
    rows = [
        (cfg, k + 1, fd, 100 * z)
        for cfg in paper.CONFIGURATIONS
        for k, (fd, z) in enumerate(
            zip(paper.TABLE1_FD_HZ[cfg], paper.TABLE1_ZETA[cfg], strict=True)
        )
    ]
    return pd.DataFrame(rows, columns=["configuration", "mode", "paper_fd_hz", "paper_zeta_pct"])


def _paper_table2() -> pd.DataFrame:
    rows = [
        (cfg, k + 1, r) for cfg, ratios in paper.TABLE2_RATIO.items() for k, r in enumerate(ratios)
    ]
    return pd.DataFrame(rows, columns=["configuration", "mode", "paper_added_mass_ratio"])


def _paper_fn(values: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame({"mode": np.arange(1, values.size + 1), "paper_fn_hz": values})


def compare_with_paper(name: str, table: pd.DataFrame) -> pd.DataFrame:
    """The table with the paper's values and the deviations added as columns.

    Examples
    --------
    >>> t = pd.DataFrame({"mode": [1, 2], "fn_hz": [19.34, 121.2]})
    >>> compare_with_paper("table3_fe_initial", t).columns.tolist()
    ['mode', 'fn_hz', 'paper_fn_hz', 'dev_pct']
    """
    t = table.copy()
    if name == "table1_modal_parameters":
        t = t.merge(_paper_table1(), on=["configuration", "mode"], how="left")
        t["dev_fd_hz"] = t["fd_hz"] - t["paper_fd_hz"]
        t["dev_zeta_rel_pct"] = 100 * (t["zeta_pct"] / t["paper_zeta_pct"] - 1)
    elif name == "table2_modal_added_mass":
        t = t.merge(_paper_table2(), on=["configuration", "mode"], how="left")
        t["dev_ratio"] = t["added_mass_ratio"] - t["paper_added_mass_ratio"]
    elif name in ("table3_fe_initial", "table5_fe_updated"):
        ref = paper.TABLE3_FN_HZ if name == "table3_fe_initial" else paper.TABLE5_FN_HZ
        t = t.merge(_paper_fn(ref), on="mode", how="left")
        t["dev_pct"] = 100 * (t["fn_hz"] / t["paper_fn_hz"] - 1)
    elif name == "table4_updated_parameters":
        t["paper_updated"] = t["parameter"].map(TABLE4_PAPER_KEYS).map(paper.TABLE4_UPDATED)
        if "identifiable" in t:  # the only combination the frequencies determine
            p = paper.TABLE4_UPDATED
            combination = float(fe.frequency_scale(p["thickness_m"], p["youngs_modulus_pa"],
                                                   p["density_kg_m3"], p["length_m"]))
            t.loc[t["identifiable"].astype(bool), "paper_updated"] = combination
        t["dev_pct"] = 100 * (t["updated"] / t["paper_updated"] - 1)
    elif name == "table6_local_added_mass":
        t["paper_delta_k"] = t["configuration"].map(
            lambda c: paper.TABLE6.get(c, {}).get("delta_k")
        )
        t["paper_delta_m"] = t["configuration"].map(
            lambda c: paper.TABLE6.get(c, {}).get("delta_m")
        )
        t["dev_delta_m_pct"] = 100 * (
            t["delta_m"] / pd.to_numeric(t["paper_delta_m"], errors="coerce") - 1
        )
    return t


# --------------------------------------------------------------------------
# Number formatting
# --------------------------------------------------------------------------


def std_column(table: pd.DataFrame, column: str) -> str | None:
    """Name of the standard-deviation column of ``column`` in ``table``, if any
    (the naming rule is :func:`ema_pipeline.data.std_column`).

    Examples
    --------
    >>> t = pd.DataFrame(columns=["fn_hz", "fn_std_hz", "zeta_pct", "zeta_std_pct", "r", "r_std"])
    >>> [std_column(t, c) for c in ("fn_hz", "zeta_pct", "r", "fn_std_hz")]
    ['fn_std_hz', 'zeta_std_pct', 'r_std', None]
    """
    return data.std_column(column, [str(c) for c in table.columns])


def _is_float(series: pd.Series) -> bool:
    return pd.api.types.is_float_dtype(series) and not pd.api.types.is_bool_dtype(series)


def _decimals_from_std(std: pd.Series) -> int | None:
    s = pd.to_numeric(std, errors="coerce").to_numpy(dtype=float)
    s = s[np.isfinite(s) & (s > 0)]
    if s.size == 0 or s.max() / s.min() > 1e4:  # rows of different quantities
        return None
    return int(np.clip(1 - math.floor(math.log10(float(np.median(s)))), 0, 8))


def _fixed(decimals: int) -> Callable[[Any], str]:
    def fmt(v: Any) -> str:
        if v is None or pd.isna(v):
            return ""
        text = f"{float(v):.{decimals}f}"
        return text[1:] if text.startswith("-") and not text.strip("-0.") else text  # no -0.00

    return fmt


def _sci(v: Any) -> str:
    return "" if v is None or pd.isna(v) else f"{float(v):.4e}"


def _general(v: Any) -> str:
    return "" if v is None or pd.isna(v) else f"{float(v):.5g}"


def _plain(v: Any) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, bool | np.bool_):
        return "yes" if v else "no"
    return str(v)


def column_formatters(table: pd.DataFrame) -> dict[str, Callable[[Any], str]]:
    """One formatter per column, with the same number of decimals for every row.

    Examples
    --------
    >>> t = pd.DataFrame({"fn_hz": [18.13982, 629.4], "fn_std_hz": [0.0012, 0.03],
    ...                   "E": [2.1e11, 0.01], "dev": [-1e-6, 0.2]})
    >>> f = column_formatters(t)
    >>> f["fn_hz"](18.13982), f["fn_std_hz"](0.0012), f["E"](2.1e11), f["dev"](-1e-6)
    ('18.140', '0.001', '2.1e+11', '0.00000')
    """
    out: dict[str, Callable[[Any], str]] = {}
    for col in table.columns:
        series = table[col]
        name = str(col)
        if not _is_float(series):
            out[name] = _plain
            continue
        if name in FIXED_DECIMALS:
            out[name] = _fixed(FIXED_DECIMALS[name])
            continue
        std = std_column(table, name)
        if std is None and name.endswith("fd_hz") and "fn_std_hz" in table.columns:
            std = "fn_std_hz"  # damped frequencies: the decimals of the undamped ones
        own = name if "_std" in name else std
        decimals = None if own is None else _decimals_from_std(table[own])
        if decimals is not None:
            out[name] = _fixed(decimals)
            continue
        v = series.to_numpy(dtype=float)
        v = np.abs(v[np.isfinite(v)])
        if v.size == 0 or not np.any(v > 0):
            out[name] = _fixed(0 if v.size and np.all(v == 0) else 4)
            continue
        big, typical = float(v.max()), float(np.median(v))
        if np.all(v == np.round(v)) and big < 1e6:
            out[name] = _fixed(0)  # integers stored as floats (mode numbers after a merge)
        elif typical > 0 and big / typical > 1e4:
            out[name] = _general  # rows of different quantities (Table 4): 5 significant digits
        elif big >= 1e6 or big < 1e-3:
            out[name] = _sci
        else:
            out[name] = _fixed(int(np.clip(4 - math.floor(math.log10(big)), 0, 6)))
    # a std column takes the decimals of its value column
    for col in table.columns:
        std = std_column(table, str(col))
        if std is not None and std in out and _is_float(table[std]):
            out[std] = out[str(col)]
    return out


def markdown_table(table: pd.DataFrame) -> str:
    """A GitHub-flavoured Markdown table with consistent decimals per column,
    its headers in words with their units as the HTML tables' (:func:`header_text`).

    Examples
    --------
    >>> print(markdown_table(pd.DataFrame({"mode": [1, 2], "fn_hz": [18.1, 112.23]})))
    | mode | f (Hz) |
    |---|---|
    | 1 | 18.10 |
    | 2 | 112.23 |
    """
    cols = [str(c) for c in table.columns]
    fmts = column_formatters(table)
    head = (header_text(c).replace("|", "\\|") for c in cols)
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in table.itertuples(index=False):
        cells = (fmts[c](v).replace("|", "\\|") for c, v in zip(cols, row, strict=True))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


#: Column headers in words with symbols and units (the data's identifiers stay
#: in the CSV files); other identifiers are read by :func:`header_text`.
HEADERS = {
    "fn_hz": "f (Hz)", "fn_std_hz": "σ_f (Hz)", "fd_hz": "damped f (Hz)",
    "zeta_pct": "ζ (%)", "zeta_std_pct": "σ_ζ (%)", "sigma_1_s": "decay rate σ (1/s)",
    "mpc": "MPC", "mpd_deg": "MPD (°)", "frac": "FRAC", "error_pct": "fit error (%)",
    "doubtful_reason": "why doubtful", "stable_orders": "stable orders",
    "found_by": "found by",
    "expect_hz": "expected f (Hz)", "x_m": "x (m)",
    # the added mass of Table 6 (kg): "delta_m" is not a delta in metres
    "delta_m": "Δm (kg)", "paper_delta_m": "paper Δm (kg)", "dev_delta_m_pct": "deviation Δm (%)",
    "delta_m_std": "σ_Δm (kg)", "delta_m_std_source": "source of σ_Δm",
    "delta_m_std_misfit": "σ_Δm of the misfit (kg)", "delta_m_first_order": "Δm first order (kg)",
}
_UNITS = {"hz": "Hz", "pct": "%", "deg": "°", "m": "m", "s": "s", "kg": "kg", "n": "N",
          "db": "dB", "ms": "ms", "khz": "kHz"}
_WORDS = {"fn": "f", "zeta": "ζ", "std": "std", "dev": "deviation", "mac": "MAC",
          "frac": "FRAC", "fe": "FE", "ma": "m_a", "mr": "m_r"}


def header_text(name: str) -> str:
    """A column header in words with its unit: ``fn_hz`` -> ``f (Hz)``,
    ``mass_ratio_pct`` -> ``mass ratio (%)``; names that are not identifiers
    (with a space or a slash) stay as they are.

    Examples
    --------
    >>> header_text("fn_hz"), header_text("dev_fn_pct"), header_text("time / s")
    ('f (Hz)', 'deviation f (%)', 'time / s')
    >>> header_text("delta_m")
    'Δm (kg)'
    """
    if name in HEADERS:
        return HEADERS[name]
    if " " in name or "/" in name or "_" not in name:
        return name
    words = name.split("_")
    unit = ""
    if words[-1].lower() in _UNITS and len(words) > 1:
        unit = f" ({_UNITS[words.pop().lower()]})"
    elif len(words) > 2 and words[-2:] == ["1", "s"]:
        words, unit = words[:-2], " (1/s)"
    return " ".join(_WORDS.get(w, w) for w in words) + unit


def _breakable(name: str) -> str:
    """Escaped header text of a column, in words (:func:`header_text`)."""
    return escape(header_text(name))


#: Width budget of one HTML table, in characters of cell text (about 600 CSS px):
#: wider tables are split into parts that repeat the key columns.
TABLE_BUDGET_CHARS = 90


def _width_chars(header: str, cells: Sequence[str], numeric: bool) -> int:
    """Estimated rendered width of a column: its widest unbreakable part (numbers do
    not break; text breaks at spaces, and long words anywhere, past 24 characters)."""
    head = max((len(w) for w in header.split("_")), default=0)
    if numeric:
        words = [w for text in cells for w in text.split(" ± ")]
    else:
        words = [w[:24] for text in cells for w in text.split(" ")]
    return max(head, max((len(w) for w in words), default=0)) + 2


def _chunks(shown: list[str], widths: dict[str, int], keys: list[str]) -> list[list[str]]:
    """Columns split into parts within the width budget, each led by the key columns."""
    rest = [c for c in shown if c not in keys]
    key_width = sum(widths[k] for k in keys)
    parts: list[list[str]] = []
    current: list[str] = []
    for c in rest:
        if current and key_width + sum(widths[x] for x in current) + widths[c] > TABLE_BUDGET_CHARS:
            parts.append(current)
            current = []
        current.append(c)
    parts.append(current)
    return [keys + p for p in parts] if len(parts) > 1 else [shown]


def html_table(
    table: pd.DataFrame,
    *,
    caption: str = "",
    table_id: str = "",
    merge_std: bool = True,
    titles: Mapping[str, str] | None = None,
    split: bool = True,
) -> str:
    """An HTML table (every string escaped) in a horizontally scrolling wrapper.

    With ``merge_std`` a value column with a standard deviation column beside
    it is shown as ``value ± std`` and the std column is not shown.
    ``titles`` maps column names to header tooltips (units, meaning). A table
    wider than :data:`TABLE_BUDGET_CHARS` is split into parts of columns, each
    repeating the leading text/integer columns (configuration, mode, ...), so
    that it fits a narrow window and a printed page (unless ``split=False``);
    a one-row table is never split (it scrolls: a part of one row reads badly).

    Examples
    --------
    >>> t = pd.DataFrame({"configuration": ["<b>air</b>"], "fn_hz": [18.14], "fn_std_hz": [0.01]})
    >>> s = html_table(t)
    >>> "&lt;b&gt;air&lt;/b&gt;" in s, "18.140 ± 0.010" in s, "fn_std_hz" in s
    (True, True, False)
    >>> wide = pd.DataFrame({"mode": [1, 2], **{f"value_{k}": [1e-3 * k] * 2 for k in range(12)}})
    >>> html_table(wide).count("<table"), html_table(wide.head(1)).count("<table")
    (2, 1)
    """
    fmts = column_formatters(table)
    cols = [str(c) for c in table.columns]
    pairs = {c: std_column(table, c) for c in cols} if merge_std else {}
    hidden = {s for s in pairs.values() if s}
    shown = [c for c in cols if c not in hidden]
    titles = titles or {}
    numeric = {c for c in cols if pd.api.types.is_numeric_dtype(table[c])}
    texts: dict[str, list[str]] = {c: [] for c in shown}
    columns = {str(c): table[c].tolist() for c in table.columns}  # keeps each column's type
    for r in range(len(table)):
        for c in shown:
            text = fmts[c](columns[c][r])
            std = pairs.get(c)
            if std and text:
                sd = fmts[std](columns[std][r])
                if sd:
                    text = f"{text} ± {sd}"
            texts[c].append(text)
    widths = {c: _width_chars(c, texts[c], c in numeric) for c in shown}
    keys = []
    for c in shown[:2]:
        if _is_float(table[c]):
            break
        keys.append(c)
    parts = _chunks(shown, widths, keys) if split and len(table) > 1 else [shown]
    out = []
    for k, part in enumerate(parts):
        head = "".join(
            f'<th title="{escape(titles[c])}">{_breakable(c)}</th>' if c in titles
            else f"<th>{_breakable(c)}</th>"
            for c in part
        )
        body = []
        for r in range(len(table)):
            cells = []
            for c in part:
                text = texts[c][r]
                cls = ""
                if c in numeric:
                    cls = ' class="num pm"' if " ± " in text else ' class="num"'
                cells.append(f"<td{cls}>{escape(text)}</td>")
            body.append("<tr>" + "".join(cells) + "</tr>")
        ident = f' id="{escape(table_id)}"' if table_id and k == 0 else ""
        label = caption + (f" (part {k + 1} of {len(parts)})" if len(parts) > 1 else "")
        cap = f"<caption>{escape(label)}</caption>" if label else ""
        out.append(
            f'<div class="tablewrap"><table{ident}>{cap}<thead><tr>{head}</tr></thead>'
            f"<tbody>{''.join(body)}</tbody></table></div>"
        )
    return "".join(out)


def html_matrix(
    matrix: np.ndarray,
    row_labels: Sequence[str],
    col_labels: Sequence[str],
    *,
    caption: str = "",
    decimals: int = 3,
) -> str:
    """A matrix in [0, 1] (MAC) as an HTML table, cells shaded by value.

    The table takes the width its columns need (4.8 em each) up to its box's
    and its letters shrink with its columns beyond that (CSS ``.matwrap``,
    ``table.mac``): a large AutoMAC fits its box instead of scrolling.

    Examples
    --------
    >>> s = html_matrix(np.eye(2), ["1", "2"], ["1", "2"], caption="AutoMAC")
    >>> s.count("<td"), "1.000" in s
    (4, True)
    """
    m = np.asarray(matrix, dtype=float)
    head = "<th></th>" + "".join(f"<th>{escape(c)}</th>" for c in col_labels)
    rows = []
    for i, label in enumerate(row_labels):
        cells = []
        for j in range(m.shape[1]):
            v = m[i, j]
            shade = int(round(255 - 180 * float(np.clip(v, 0, 1)))) if np.isfinite(v) else 255
            ink = "#fff" if np.isfinite(v) and v > 0.6 else "#222"
            text = f"{v:.{decimals}f}" if np.isfinite(v) else ""
            cells.append(
                f'<td class="num" style="background:rgb({shade},{shade + (255 - shade) // 3},255);'
                f'color:{ink}">{text}</td>'
            )
        rows.append(f"<tr><th>{escape(label)}</th>{''.join(cells)}</tr>")
    cap = f"<caption>{escape(caption)}</caption>" if caption else ""
    return (
        f'<div class="tablewrap matwrap"><table class="mac" style="--cols:{m.shape[1] + 1};'
        f'width:min(100%,{4.8 * (m.shape[1] + 1):g}em)">{cap}<thead><tr>{head}</tr></thead>'
        f"<tbody>{''.join(rows)}</tbody></table></div>"
    )
