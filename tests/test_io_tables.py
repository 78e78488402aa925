"""Tables without pandas (issue 37): ``ema-pipeline identify`` and ``frf``
write their tables from :class:`ema_pipeline.data.Table` so that they need
not import pandas (0.4-0.5 s of every command). The files must be those
that pandas wrote: the CSV text, the HDF5 layout and what reads them back."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.data import Table
from ema_pipeline.io.files import CSV_FLOAT_FORMAT, csv_text

REPO = Path(__file__).resolve().parents[1]

#: every kind of column the tables hold, with the values that need care
COLUMNS = {
    "mode": np.array([1, 2, 3, 4]),
    "fn_hz": np.array([1.123456789012, np.nan, -0.0, np.inf]),
    "small": np.array([1e-300, 1e20, 3.0, -np.inf]),
    "doubtful": np.array([True, False, True, False]),
    "reason": np.array(["a,b", 'q"x', "", None], dtype=object),
    "text": np.array(["x", "line\nbreak", "\u00fc", " sp "]),
    "mixed": np.array([1.5, "t", np.nan, 2], dtype=object),
    "i32": np.array([1, -2, 3, 4], dtype=np.int32),
}


def test_csv_text_is_what_pandas_writes() -> None:
    """Floats to 10 digits, NaN and None empty, inf, -0, bools, quoting of
    commas, quotes and line breaks, unicode: the same text as pandas."""
    expected = pd.DataFrame(COLUMNS).to_csv(index=False, float_format=CSV_FLOAT_FORMAT)
    assert csv_text(Table(COLUMNS)) == expected
    empty = {"mode": np.zeros(0, int), "fn_hz": np.zeros(0)}
    assert csv_text(Table(empty)) == pd.DataFrame(empty).to_csv(
        index=False, float_format=CSV_FLOAT_FORMAT)


def test_write_csv_of_a_table_and_of_its_dataframe_are_the_same_file(tmp_path: Path) -> None:
    a = io.write_csv(Table(COLUMNS), tmp_path / "a.csv")
    b = io.write_csv(pd.DataFrame(COLUMNS), tmp_path / "b.csv")
    assert a.read_bytes() == b.read_bytes()
    back = io.read_csv(a)
    assert back["fn_hz"].iloc[0] == pytest.approx(1.123456789, abs=1e-12)
    assert back["reason"].iloc[1] == 'q"x'


def _tree(path: Path) -> dict[str, object]:
    out: dict[str, object] = {}

    def visit(name: str, obj: h5py.Group | h5py.Dataset) -> None:
        out.update({f"{name}@{k}": repr(v) for k, v in obj.attrs.items()})
        if isinstance(obj, h5py.Dataset):
            out[name] = (obj.dtype.kind, repr(obj[()]))

    with h5py.File(path) as h5:
        h5.visititems(visit)
    return out


def test_results_file_stores_a_table_as_its_dataframe(tmp_path: Path) -> None:
    """The same groups, datasets, dtypes and attributes; read back, the same frame."""
    # (no None: pandas makes it NaN in a frame, a Table keeps it)
    columns = {k: v for k, v in COLUMNS.items() if k != "mixed"}
    columns["reason"] = np.array(["a,b", 'q"x', "", "d"], dtype=object)
    a = io.write_results_h5({"modes": Table(columns)}, tmp_path / "a.h5")
    b = io.write_results_h5({"modes": pd.DataFrame(columns)}, tmp_path / "b.h5")
    tree_a, tree_b = _tree(a), _tree(b)
    assert tree_a == tree_b and "modes/fn_hz" in tree_a
    back = io.table_from_results(io.read_results_h5(a)["modes"])
    assert list(back.columns) == list(columns)
    np.testing.assert_array_equal(back["fn_hz"].to_numpy(), columns["fn_hz"])
    assert back["reason"].tolist() == ["a,b", 'q"x', "", "d"]


def _imports_pandas(args: list[str]) -> bool:
    """Whether ``ema-pipeline ARGS`` (exit status 0) imports pandas."""
    code = ("import sys\nfrom ema_pipeline.cli.entry import main\n"
            f"assert main({args!r}) == 0\nprint('pandas' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=REPO, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip().splitlines()[-1] == "True"


def test_identify_and_frf_write_their_tables_without_pandas(
        tmp_path: Path, pyfrf_uff: Path) -> None:
    """``frf`` of a recording, then ``identify`` of its FRFs: neither imports
    pandas; their tables are written. ``frf --report`` draws a page with
    pandas, so that the check can fail."""
    h5 = tmp_path / "rec.h5"
    assert not _imports_pandas(["frf", str(pyfrf_uff), "--out", str(h5), "--quiet"])
    assert io.read_csv(tmp_path / "rec_hits.csv")["accepted"].sum() == 5
    out = tmp_path / "out"
    assert not _imports_pandas(["identify", str(h5), "--out", str(out), "--quiet",
                                "--band", "10", "1000"])
    modes = io.read_csv(out / "rec_modes.csv")
    assert len(modes) >= 3 and np.all(np.diff(modes["fn_hz"]) > 0)
    assert _imports_pandas(["frf", str(pyfrf_uff), "--out", str(tmp_path / "rep.h5"),
                            "--quiet", "--report"])
