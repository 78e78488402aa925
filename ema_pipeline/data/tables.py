"""Plain tables: named columns (:class:`Table`) and their notebook HTML."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from html import escape
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pandas as pd


def std_column(column: str, columns: Iterable[str]) -> str | None:
    """Name of the standard-deviation column of ``column`` among ``columns``, if
    any: ``x_std``, or ``fn_std_hz`` for ``fn_hz`` (units ``_hz _pct _m _kg``),
    the naming of every table and of :class:`ModalParameters`.

    Examples
    --------
    >>> names = ["fn_hz", "fn_std_hz", "zeta_pct", "zeta_std_pct", "r", "r_std"]
    >>> [std_column(c, names) for c in ("fn_hz", "zeta_pct", "r", "fn_std_hz")]
    ['fn_std_hz', 'zeta_std_pct', 'r_std', None]
    """
    if "_std" in column:
        return None
    candidates = [f"{column}_std"]
    for unit in ("_hz", "_pct", "_m", "_kg"):
        if column.endswith(unit):
            candidates.append(column[: -len(unit)] + "_std" + unit)
    present = set(columns)
    return next((c for c in candidates if c in present), None)


def notebook_table_html(columns: Mapping[str, Sequence[Any] | np.ndarray],
                        caption: str = "") -> str:
    """A plain HTML table of equal-length ``columns`` for notebook display
    (``_repr_html_`` of the data objects): a value with a standard deviation
    column (:func:`std_column`) as ``value ± std`` in one cell, floats to 6
    significant digits (std to 2), NaN as an empty cell, every text escaped.
    The report's tables (decimals per column) are :func:`ema_pipeline.report.html_table`.

    Examples
    --------
    >>> html = notebook_table_html({"fn_hz": [18.1423456], "fn_std_hz": [0.00123], "x": ["<b>"]})
    >>> html[html.index("<tr><td>"):]
    '<tr><td>18.1423 ± 0.0012</td><td>&lt;b&gt;</td></tr></table>'
    """

    def cell(value: Any, digits: int = 6) -> str:
        if isinstance(value, float | np.floating):
            return "" if np.isnan(value) else f"{value:.{digits}g}"
        return escape(str(value))

    def merged(value: Any, std: Any) -> str:
        text = cell(value)
        return f"{text} ± {cell(std, 2)}" if text and cell(std) else text

    names = [str(name) for name in columns]
    stds = {name: std_column(name, names) for name in names}
    shown = [name for name in names if name not in set(stds.values())]
    values = {name: list(columns[name]) for name in names}
    rows = "".join(
        "<tr>" + "".join(
            f"<td>{merged(values[c][r], values[s][r]) if (s := stds[c]) else cell(values[c][r])}"
            "</td>" for c in shown) + "</tr>"
        for r in range(len(values[names[0]]) if names else 0)
    )
    head = "".join(f"<th>{escape(name)}</th>" for name in shown)
    title = f"<caption>{escape(caption)}</caption>" if caption else ""
    return f"<table>{title}<tr>{head}</tr>{rows}</table>"


@dataclass(frozen=True)
class Table:
    """A table as named 1-D columns of equal length, in order: what a
    ``pandas.DataFrame`` would hold, for the stages that write a table and
    have no other use for pandas (``ema-pipeline identify`` writes its modes
    table this way: importing pandas costs each command 0.4-0.5 s).
    :func:`ema_pipeline.io.write_csv` and
    :func:`ema_pipeline.io.write_results_h5` store it as they store a
    DataFrame of the same columns.

    Examples
    --------
    >>> t = Table({"mode": np.array([1, 2]), "fn_hz": np.array([18.1, 112.0])})
    >>> t.names, t.to_frame().shape
    (['mode', 'fn_hz'], (2, 2))
    >>> Table({"a": np.zeros(2), "b": np.zeros(3)})
    Traceback (most recent call last):
    ...
    ValueError: table columns must be 1-D and of equal length: a (2,), b (3,)
    """

    columns: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        arrays = {str(name): np.asarray(col) for name, col in self.columns.items()}
        shapes = {col.shape for col in arrays.values()}
        if len(shapes) > 1 or any(len(shape) != 1 for shape in shapes):
            raise ValueError("table columns must be 1-D and of equal length: "
                             + ", ".join(f"{name} {col.shape}" for name, col in arrays.items()))
        object.__setattr__(self, "columns", arrays)

    @property
    def names(self) -> list[str]:
        """The column names, in order."""
        return list(self.columns)

    def to_frame(self) -> pd.DataFrame:
        """The same columns as a ``pandas.DataFrame`` (pandas imported here)."""
        import pandas as pd

        return pd.DataFrame(self.columns)

    @classmethod
    def from_frame(cls, frame: pd.DataFrame) -> Table:
        """A ``pandas.DataFrame``'s columns, names as strings; a column of
        pandas' own string dtype as Python objects."""
        import pandas as pd  # imported already: frame is a DataFrame

        return cls({str(c): (frame[c].to_numpy(dtype=object)
                             if pd.api.types.is_string_dtype(frame[c]) else frame[c].to_numpy())
                    for c in frame.columns})
