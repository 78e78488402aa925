"""UFF export of identified modes (datasets 164, 15, 82, 55, 58): pyuff reads the
file back and frequencies, damping ratios and shapes round-trip."""

from __future__ import annotations

import numpy as np
import pytest
import pyuff

from ema_pipeline import io
from ema_pipeline.data import DOF, DataError
from ema_pipeline.pipeline.simulate import simulate_paper_test

FN = np.array([17.212, 68.84, 118.878])
ZETA = np.array([0.0123, 0.0045, 0.00321])


def _shapes(n_dof: int) -> np.ndarray:
    rng = np.random.default_rng(5)
    return rng.normal(size=(n_dof, FN.size)) + 1j * rng.normal(size=(n_dof, FN.size)) * 0.1


def test_modes_round_trip_through_pyuff(tmp_path):
    dofs = [DOF(1, 3), DOF(2, 3), DOF(3, -3), DOF(3, 1)]
    shapes = _shapes(len(dofs))
    coords = {1: (0.0, 0.0, 0.0), 2: (0.05, 0.0, 0.0), 3: (0.10, 0.0, 0.0)}
    fit = simulate_paper_test("genuine", seed=2).band(0, 200)
    path = io.write_modes_uff(tmp_path / "modes.uff", FN, ZETA, shapes, dofs,
                              node_coordinates=coords, frf_fit=fit)
    assert not list(tmp_path.glob(".*.tmp"))
    sets = pyuff.UFF(str(path)).read_sets()
    types = [int(s["type"]) for s in sets]
    assert types == [164, 15, 82, 55, 55, 55, 58, 58]
    units = sets[0]
    assert units["units_code"] == 1 and units["length"] == 1.0 and units["force"] == 1.0
    np.testing.assert_allclose(sets[1]["x"], [0.0, 0.05, 0.10], atol=1e-9)
    np.testing.assert_array_equal(sets[2]["nodes"], [1, 2, 3])
    modes = [s for s in sets if s["type"] == 55]
    # dataset 55 stores E13.5: 6 significant digits
    np.testing.assert_allclose([m["freq"] for m in modes], FN, rtol=5e-6)
    np.testing.assert_allclose([m["modal_damp_vis"] for m in modes], ZETA, rtol=5e-6)
    for k, m in enumerate(modes):
        assert list(m["node_nums"]) == [1, 2, 3]
        scale = np.abs(shapes[:, k]).max()
        np.testing.assert_allclose(m["r3"][:2], shapes[:2, k], rtol=0, atol=1e-5 * scale)
        # node 3 was measured in -Z: stored as +Z with the sign flipped
        np.testing.assert_allclose(m["r3"][2], -shapes[2, k], rtol=0, atol=1e-5 * scale)
        np.testing.assert_allclose(m["r1"][2], shapes[3, k], rtol=0, atol=1e-5 * scale)
        assert m["r1"][0] == 0 and m["r2"][1] == 0  # not measured
    # our reader skips 164/15/82/55 and reads the synthesised FRFs back
    back = io.read_frf(path)
    np.testing.assert_allclose(back.freq_hz, fit.freq_hz)
    np.testing.assert_allclose(back.H, fit.H, rtol=1e-10, atol=1e-12 * np.abs(fit.H).max())
    assert io.read_uff(path).skipped == {55: 3}  # 15 and 82 are kept for the geometry reader


def test_modes_without_geometry_and_exact_id_line(tmp_path):
    dofs = [DOF(4, 3), DOF(7, 3)]
    path = io.write_modes_uff(tmp_path / "m.unv", FN, ZETA, _shapes(2), dofs)
    sets = pyuff.UFF(str(path)).read_sets()
    assert [int(s["type"]) for s in sets] == [164, 55, 55, 55]
    fn = [float(s["id4"].split("fn=")[1].split()[0]) for s in sets[1:]]
    np.testing.assert_array_equal(fn, FN)  # full precision in ID line 4


def test_modes_bad_input(tmp_path):
    with pytest.raises(DataError, match=r"x.uff: shapes have shape \(2, 3\), expected"):
        io.write_modes_uff(tmp_path / "x.uff", FN, ZETA, _shapes(2), [DOF(1, 3)])
    with pytest.raises(DataError, match="appears twice"):
        io.write_modes_uff(tmp_path / "x.uff", FN, ZETA, _shapes(2), [DOF(1, 3), DOF(1, -3)])
    with pytest.raises(DataError, match="NaN"):
        io.write_modes_uff(tmp_path / "x.uff", FN * np.nan, ZETA, _shapes(1), [DOF(1, 3)])
    assert not (tmp_path / "x.uff").exists()
