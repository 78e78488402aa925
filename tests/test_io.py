"""io: HDF5 and UFF-58 round trips, plain-pyuff compatibility, and bad input."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyuff

from ema_pipeline import io
from ema_pipeline.acquisition import simulate_time_records
from ema_pipeline.data import DOF, DataError, FRFSet
from ema_pipeline.pipeline.simulate import paper_modes, simulate_paper_test


@pytest.fixture(scope="module")
def frf() -> FRFSet:
    return simulate_paper_test("larger_tank", seed=7)


def _assert_same(a: FRFSet, b: FRFSet, rtol: float) -> None:
    np.testing.assert_array_equal(a.freq_hz, b.freq_hz)
    scale = np.abs(a.H).max()
    assert np.abs(a.H - b.H).max() <= rtol * scale
    assert a.response_dofs == b.response_dofs and a.reference_dofs == b.reference_dofs
    assert a.quantity == b.quantity and a.configuration == b.configuration
    assert a.acquisition == b.acquisition


def test_hdf5_round_trip_is_exact_and_carries_schema(frf, tmp_path):
    path = io.write_frf_h5(frf, tmp_path / "x.h5")
    back = io.read_frf(path)
    _assert_same(frf, back, 0.0)
    np.testing.assert_array_equal(back.coherence, frf.coherence)
    assert back.source.sha256 == io.sha256_file(path) and back.source.path == str(path)
    with h5py.File(path) as h5:
        assert h5.attrs["schema"] == "ema-pipeline/frf" and h5.attrs["schema_version"] == 1
        assert h5["frf/H"].dtype == np.complex128  # complex stored natively
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary left behind


def test_frf_files_are_compressed_and_results_files_are_not(frf, tmp_path):
    """FRF files (kept measurements) are gzip compressed; a results file,
    written after every identification, stores its FRFs and arrays as they
    are (faster to write); both read back exactly."""
    frf_path = io.write_frf_h5(frf, tmp_path / "frf.h5")
    stab = np.linspace(0.0, 1.0, 5000)  # an array as large as a diagram's
    res_path = io.write_results_h5({"frf": frf, "extra": {"stab": stab}}, tmp_path / "res.h5")
    with h5py.File(frf_path) as a, h5py.File(res_path) as b:
        assert a["frf/H"].compression == "gzip" and a["frf/coherence"].compression == "gzip"
        assert b["frf/H"].compression is None and b["frf/coherence"].compression is None
        assert b["extra/stab"].compression is None
        np.testing.assert_array_equal(b["extra/stab"][()], stab)
    _assert_same(frf, io.read_frf(frf_path), 0.0)
    _assert_same(frf, io.read_frf_from_results(res_path, "frf"), 0.0)
    assert frf_path.stat().st_size < 0.95 * res_path.stat().st_size  # what gzip saves


@pytest.mark.parametrize("binary, rtol", [(False, 1e-11), (True, 0.0)])
def test_uff_round_trip(frf, tmp_path, binary, rtol):
    path = io.write_frf_uff(frf, tmp_path / "x.uff", binary=binary, coherence=True)
    back = io.read_frf(path)
    _assert_same(frf, back, rtol)  # ASCII keeps 12 significant digits, binary is exact
    assert np.abs(back.coherence - frf.coherence).max() <= max(rtol, 1e-11)


def test_plain_pyuff_reads_our_simulated_file(tmp_path):
    from ema_pipeline.cli import main

    out = tmp_path / "g.uff"
    assert main(["simulate", "--configuration", "genuine", "--format", "uff",
                 "--out", str(out), "--quiet"]) == 0
    sets = pyuff.UFF(str(out)).read_sets()
    assert len(sets) == 2
    for s in sets:
        assert s["type"] == 58 and s["func_type"] == 4
        assert s["num_pts"] == 8193 and len(s["data"]) == 8193
        assert s["x"][1] - s["x"][0] == pytest.approx(2000 / 16384, rel=1e-5)
        assert s["ordinate_spec_data_type"] == 12 and s["orddenom_spec_data_type"] == 13
        assert s["ordinate_axis_units_lab"].strip() == "m/s^2"
    assert {s["rsp_node"] for s in sets} == {3, 6} and {s["ref_node"] for s in sets} == {8}
    # our reader restores the exact axis from the ID-line metadata
    np.testing.assert_array_equal(io.read_frf(out).freq_hz, np.fft.rfftfreq(16384, 1 / 2000))


def test_time_records_round_trip_through_uff(tmp_path):
    rec = simulate_time_records(paper_modes("genuine"), seed=4, configuration="genuine")
    for binary in (False, True):
        path = io.write_time_uff(rec, tmp_path / f"t{binary}.uff", binary=binary)
        back = io.read_time_uff(path)
        scale = np.abs(rec.response).max()
        assert np.abs(back.response - rec.response).max() <= 1e-11 * scale
        assert np.abs(back.force - rec.force).max() <= 1e-11 * np.abs(rec.force).max()
        assert back.sample_rate_hz == rec.sample_rate_hz and back.trigger_s == rec.trigger_s
        assert back.response_dofs == rec.response_dofs and back.reference_dof == rec.reference_dof
        assert back.configuration == "genuine"
    # FRF estimation works on the recorded (read back) time data as on the original
    from ema_pipeline.acquisition import estimate_frf

    kwargs = {"force_window_s": 0.1, "exp_window_tau_s": 1.6384}
    h_orig, h_read = estimate_frf(rec, **kwargs), estimate_frf(back, **kwargs)
    band = (h_orig.freq_hz > 5) & (h_orig.freq_hz < 900)
    np.testing.assert_allclose(h_read.H[..., band], h_orig.H[..., band], rtol=1e-9)
    assert h_read.reference_dofs == (rec.reference_dof,)


def test_reads_the_measured_roving_hammer_file(real_uff):
    frf = io.read_frf(real_uff)
    assert frf.H.shape == (1, 30, 1025)
    assert frf.quantity == "accelerance" and frf.df_hz == 1.0
    # stored as -Z response / -Z references: one DOF per node, +Z, and the two sign
    # flips cancel, so the values are those pyuff reads
    assert frf.response_dofs == (DOF(3, 3),)
    assert len(set(frf.reference_dofs)) == 30
    assert all(d.direction == 3 for d in frf.reference_dofs)
    first = pyuff.UFF(str(real_uff)).read_sets(0)
    assert (first["rsp_dir"], first["ref_dir"]) == (-3, -3)
    k = frf.reference_dofs.index(DOF(int(first["ref_node"]), 3))
    np.testing.assert_allclose(frf.H[0, k], first["data"], rtol=1e-12)
    assert frf.reciprocal().H.shape == (30, 1, 1025)
    assert len(frf.source.sha256) == 64


# ---------------------------------------------------------------- bad input


def test_empty_file(tmp_path):
    for name in ("e.uff", "e.h5"):
        (tmp_path / name).write_bytes(b"")
        with pytest.raises(DataError, match=rf"{name}: empty file"):
            io.read_frf(tmp_path / name)


@pytest.mark.parametrize("name, fmt", [("t.uff", "uff"), ("tb.uff", "uff-binary"),
                                       ("t.h5", "h5")])
def test_truncated_file(frf, tmp_path, name, fmt):
    full = io.write_frf(frf, tmp_path / f"full_{name}", fmt)
    data = full.read_bytes()
    cut = tmp_path / name
    cut.write_bytes(data[: int(len(data) * 0.7)])
    with pytest.raises(DataError, match=rf"{name}: .*(truncated|corrupt)"):
        io.read_frf(cut)


def test_file_cut_exactly_at_a_record_boundary(frf, tmp_path):
    """Two equal records: half the file is a complete UFF of one record, which only
    the record count our writer stores can expose."""
    full = io.write_frf_uff(frf, tmp_path / "full.uff")
    data = full.read_bytes()
    half = tmp_path / "half.uff"
    half.write_bytes(data[: len(data) // 2])
    assert len(pyuff.UFF(str(half)).read_sets(0)["data"]) == 8193  # pyuff sees one record
    with pytest.raises(DataError, match=r"half.uff: truncated Universal File: 1 of 2"):
        io.read_frf(half)


def test_no_dataset_58(tmp_path):
    path = tmp_path / "geometry.uff"
    pyuff.UFF(str(path)).write_sets(
        pyuff.prepare_15(node_nums=[1, 2], def_cs=[0, 0], disp_cs=[0, 0],
                         color=[1, 1], x=[0.0, 1.0], y=[0.0, 0.0], z=[0.0, 0.0]),
        mode="add",
    )
    with pytest.raises(DataError, match=r"geometry.uff: no dataset 58.*found 15"):
        io.read_frf(path)


def test_not_a_universal_file(tmp_path):
    path = tmp_path / "notes.uff"
    path.write_text("hello\nthis is not a universal file\n")
    with pytest.raises(DataError, match="notes.uff: no UFF datasets"):
        io.read_frf(path)


def _record(x, data, rsp=3, units="m/s^2"):
    return pyuff.prepare_58(
        binary=0, func_type=4, rsp_node=rsp, rsp_dir=3, ref_node=8, ref_dir=3, data=data, x=x,
        id1="test", abscissa_spacing=1, abscissa_spec_data_type=18,
        ordinate_spec_data_type=12, orddenom_spec_data_type=13,
        ordinate_axis_units_lab=units, orddenom_axis_units_lab="N",
    )


def test_records_with_different_frequency_axes(tmp_path):
    path = tmp_path / "axes.uff"
    data = np.ones(101, dtype=complex)
    pyuff.UFF(str(path)).write_sets(
        [_record(np.arange(101.0), data), _record(np.arange(101.0) * 2, data, rsp=6)], mode="add"
    )
    with pytest.raises(DataError, match="axes.uff: records have different frequency axes"):
        io.read_frf(path)


def test_nan_and_inf_values(tmp_path, frf):
    # pyuff itself writes NaN as 0; other software writes the text NaN, as here
    path = tmp_path / "nan.uff"
    data = np.ones(101, dtype=complex)
    pyuff.UFF(str(path)).write_sets(
        [_record(np.arange(101.0), data), _record(np.arange(101.0), data, rsp=6)], mode="add"
    )
    text = path.read_text().splitlines()
    last_data_line = len(text) - 2
    text[last_data_line] = text[last_data_line].replace("1.00000000000e+00", "NaN", 1)
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(DataError, match="nan.uff: record 2 contains NaN"):
        io.read_frf(path)
    bad = tmp_path / "inf.h5"
    io.write_frf_h5(frf, bad)
    with h5py.File(bad, "r+") as h5:
        h5["frf/H"][0, 0, 100] = np.inf
    with pytest.raises(DataError, match="inf.h5: FRF contains 1 NaN/inf"):
        io.read_frf(bad)


def test_unknown_units(tmp_path):
    path = tmp_path / "units.uff"
    pyuff.UFF(str(path)).write_sets(
        [_record(np.arange(101.0), np.ones(101, dtype=complex), units="furlong/fortnight^2")],
        mode="add",
    )
    with pytest.raises(DataError, match="units.uff: record 1 has unknown units 'furlong"):
        io.read_frf(path)


def test_g_units_are_converted_to_si(tmp_path):
    path = tmp_path / "g.uff"
    pyuff.UFF(str(path)).write_sets(
        [_record(np.arange(101.0), np.full(101, 2.0 + 0j), units="g")], mode="add"
    )
    np.testing.assert_allclose(io.read_frf(path).H, 2.0 * 9.80665)


def test_hdf5_of_another_schema(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as h5:
        h5.attrs["schema"] = "somebody-else"
    with pytest.raises(DataError, match="other.h5: not an ema-pipeline FRF file"):
        io.read_frf(path)


def test_failed_write_leaves_target_untouched(frf, tmp_path):
    target = tmp_path / "keep.h5"
    io.write_frf_h5(frf, target)
    before = target.read_bytes()
    broken = replace(frf)
    broken.H = np.empty((2, 1, 3))  # wrong shape slips past validation: writing must not land
    with pytest.raises(ValueError):
        with io.atomic_path(target) as tmp:
            tmp.write_bytes(b"partial")
            raise ValueError("simulated crash in the middle of a write")
    assert target.read_bytes() == before
    assert not list(tmp_path.glob(".*.tmp"))


def test_frf_set_validation_messages():
    f = np.linspace(0, 10, 11)
    with pytest.raises(DataError, match="strictly increasing"):
        FRFSet(freq_hz=f[::-1], H=np.ones(11))
    with pytest.raises(DataError, match="11 lines but H has 5"):
        FRFSet(freq_hz=f, H=np.ones(5))
    with pytest.raises(DataError, match="unknown FRF quantity"):
        FRFSet(freq_hz=f, H=np.ones(11), quantity="inertance")


def test_quantity_conversion_round_trip(frf):
    rec = frf.as_quantity("receptance")
    back = rec.as_quantity("accelerance")
    k = frf.freq_hz > 0
    np.testing.assert_allclose(back.H[..., k], frf.H[..., k], rtol=1e-12)
    assert rec.units == "m/N" and frf.as_quantity("mobility").units == "m/s/N"


def test_shipped_experiment_file(example_dir: Path):
    exp = io.read_experiment(example_dir / "experiment.toml")
    assert [c.name for c in exp.configurations] == ["genuine", "larger_tank", "smaller_tank"]
    assert exp.genuine_name == "genuine" and exp.immersed_elements == (10,)
    for spec in exp.configurations:
        frf = io.read_frf(io.experiment_file_path(exp, spec))
        assert frf.configuration == spec.name and frf.H.shape == (2, 1, 8193)


def test_bad_experiment_files(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[beam\nlength_m = 1")
    with pytest.raises(DataError, match="bad.toml: not valid TOML"):
        io.read_experiment(bad)
    bad.write_text("[beam]\nlength_m = 0.65\n")
    with pytest.raises(DataError, match="at least one"):
        io.read_experiment(bad)
    bad.write_text('[beam]\nlength_m = -1.0\n[[configurations]]\nname="a"\nfile="a.uff"\n')
    with pytest.raises(DataError, match=r"\[beam\] length_m: must be a number in \(0, 1000\]"):
        io.read_experiment(bad)
    bad.write_text('[experiment]\ngenuine="air"\n[[configurations]]\nname="a"\nfile="a.uff"\n')
    with pytest.raises(DataError, match="genuine configuration 'air' is not among"):
        io.read_experiment(bad)
    bad.write_text('[fe]\nimmersed_elements=[12]\n[[configurations]]\nname="a"\nfile="a.uff"\n')
    with pytest.raises(DataError, match="immersed element 12 does not exist"):
        io.read_experiment(bad)
