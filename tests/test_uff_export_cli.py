"""UFF export of identified modes from the command line (issue 12, item 6).

``identify --uff``, ``batch --uff`` and ``run --uff`` write the modes as a
Universal File; plain pyuff reads them back and the numbers agree with the
modal table written beside them. ``--verbose`` names the skipped datasets.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import pyuff

from ema_pipeline import io
from ema_pipeline.cli import main

REPO = Path(__file__).resolve().parents[1]


def _modes_55(path: Path) -> list[dict]:
    return [s for s in pyuff.UFF(str(path)).read_sets() if s["type"] == 55]


def test_identify_uff_round_trips_through_pyuff(tmp_path: Path) -> None:
    assert main(["identify", str(REPO / "raw_frf" / "genuine.uff"), "--out", str(tmp_path),
                 "--uff", "--quiet"]) == 0
    table = pd.read_csv(tmp_path / "genuine_modes.csv")
    uff = tmp_path / "genuine_modes.uff"
    assert set(pyuff.UFF(str(uff)).get_set_types()) == {164, 55, 58}
    modes = _modes_55(uff)
    assert len(modes) == len(table) == 4
    # dataset 55 stores E13.5: 6 significant digits
    np.testing.assert_allclose([m["freq"] for m in modes], table["fn_hz"], rtol=1e-5)
    np.testing.assert_allclose([m["modal_damp_vis"] for m in modes], table["zeta_pct"] / 100,
                               rtol=1e-4)
    # the synthesised FRFs (dataset 58) read back with our own reader
    fit = io.read_frf(uff)
    assert fit.H.shape[0] == 2 and fit.freq_hz.size > 1000
    assert fit.quantity == "accelerance"


def test_batch_uff_writes_one_file_per_input(tmp_path: Path) -> None:
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(REPO / "raw_frf" / "larger_tank.h5", src / "a.h5")
    out = tmp_path / "out"
    assert main(["batch", str(src), "--out", str(out), "--workers", "1", "--uff",
                 "--quiet"]) == 0
    modes = _modes_55(out / "a_modes.uff")
    table = pd.read_csv(out / "a_modes.csv")
    np.testing.assert_allclose([m["freq"] for m in modes], table["fn_hz"], rtol=1e-5)


def test_run_uff_carries_the_beam_geometry(example_study_uff_no_figures: Path) -> None:
    results = example_study_uff_no_figures  # run --no-figures --uff on raw_frf/
    table1 = pd.read_csv(results / "tables" / "table1_modal_parameters.csv")
    for name in ("genuine", "larger_tank", "smaller_tank"):
        path = results / "modes" / f"{name}.uff"
        sets = pyuff.UFF(str(path)).read_sets()
        nodes = next(s for s in sets if s["type"] == 15)
        # sensors at measurement nodes 3 and 6 of the 0.65 m beam (10 elements)
        x = dict(zip(np.asarray(nodes["node_nums"]).astype(int), nodes["x"], strict=True))
        assert x[3] == pytest.approx(0.13) and x[6] == pytest.approx(0.325)
        assert any(s["type"] == 82 for s in sets)
        fd = table1.loc[table1["configuration"] == name, "fn_hz"].to_numpy()
        np.testing.assert_allclose(sorted(m["freq"] for m in sets if m["type"] == 55), fd,
                                   rtol=1e-5)


def test_verbose_names_skipped_datasets(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        pyuff_dir: Path) -> None:
    """On pyuff's Testlab export (``../shared/data/pyuff``; skipped where absent)."""
    path = pyuff_dir / "testlab_164_18_15_82.uff"
    assert main(["identify", str(path), "--out", str(tmp_path), "--verbose", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "skipped datasets not needed for FRFs: 18\n" in err  # 15, 82: the geometry reader's
    assert "no dataset 58" in err and str(path) in err
