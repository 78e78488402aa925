"""UFF reading: the variants real writers produce (files in tests/data/uff, made by
tests/data/make_uff_test_files.py) and a few of pyuff's public test files
(``../shared/data/pyuff`` beside the repository, MIT licence there; those tests are
skipped, naming the folder, where it is absent). Every test checks values read."""

from __future__ import annotations

import importlib.util
import logging
import shutil
from pathlib import Path

import numpy as np
import pytest
import pyuff

from ema_pipeline import io
from ema_pipeline.data import DOF, DataError, EMAError

DATA = Path(__file__).parent / "data"
UFF = DATA / "uff"
IN_LBF = 0.0254 / 4.4482216152605  # (in/s^2)/lbf in (m/s^2)/N

_spec = importlib.util.spec_from_file_location("make_uff", DATA / "make_uff_test_files.py")
make = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(make)  # type: ignore[union-attr]
F = np.arange(make.N_LINES) * make.DF_HZ


def truth(k: int, freq: np.ndarray = F) -> np.ndarray:
    return make.truth(k, freq)


# single precision (E13.5 or float32) keeps 6-7 significant digits
RTOL_SINGLE = 5e-6  # half a unit in the 6th digit


def test_testlab_style_crlf_padded_delimiters_padding_values_and_skipped_datasets(caplog):
    path = UFF / "testlab_crlf_padded.uff"
    with caplog.at_level(logging.INFO, logger="ema_pipeline.io.uff"):
        frf = io.read_frf(path)
    assert frf.H.shape == (2, 1, 40)  # 40 lines, not 41: padding values dropped
    assert frf.response_dofs == (DOF(3, 3), DOF(6, 3)) and frf.reference_dofs == (DOF(8, 3),)
    np.testing.assert_allclose(frf.freq_hz, F)
    for k in range(2):
        np.testing.assert_allclose(frf.H[k, 0], truth(k), rtol=RTOL_SINGLE)
    contents = io.read_uff(path)
    assert contents.skipped == {18: 1, 2412: 1, 55: 1}  # 15, 82, 2411: the geometry reader's
    assert sorted(n for n, *_ in contents.geometry_blocks) == [15, 82, 2411]
    assert contents.header["model_name"] == "beam model"
    assert "skipped datasets not needed for FRFs: 18, 2412, 55" in caplog.text
    # pyuff keeps the two padding values of the last line (42 values for 40)
    sets = pyuff.UFF(str(path)).read_sets([7, 8])
    assert [len(s["data"]) for s in sets] == [42, 42]
    np.testing.assert_allclose(frf.H[1, 0], sets[1]["data"][:40], rtol=1e-12)


def test_dataset_164_inch_pound_force_is_converted_to_si():
    frf = io.read_frf(UFF / "units_164_inch_lbf.unv")
    assert frf.quantity == "accelerance"
    ratio = frf.H[0, 0] / truth(0)
    np.testing.assert_allclose(ratio, 0.005710, rtol=2e-4)  # 0.0254 / 4.4482
    np.testing.assert_allclose(ratio, IN_LBF, rtol=RTOL_SINGLE)
    assert io.read_uff(UFF / "units_164_inch_lbf.unv").records[0].units.code == 7


def test_labels_win_over_dataset_164(caplog):
    with caplog.at_level(logging.WARNING, logger="ema_pipeline.io.uff"):
        frf = io.read_frf(UFF / "units_164_vs_label.unv")
    np.testing.assert_allclose(frf.H[0, 0], truth(0), rtol=RTOL_SINGLE)  # m/s^2 / N as labelled
    assert "disagrees with dataset 164" in caplog.text


@pytest.mark.parametrize(
    "name, quantity, factors",
    [
        ("labels_accelerance.uff", "accelerance",
         [9.80665, 1.0, 1.0, 1.0, 1.0, IN_LBF, 1e-6, 1.0]),
        ("labels_mobility.uff", "mobility", [1.0, 1e-3, IN_LBF, 1.0]),
        ("labels_receptance.uff", "receptance", [1.0, 1e-3, 1e-6]),
    ],
)
def test_combined_unit_labels(name, quantity, factors):
    """g/N, (1/N)*(m/s^2), m/s^2/N, m/s2/N, 'm / s^2 / N', in/s^2/lbf, mm/s^2/kN,
    m/s²/N; numerator and denominator labels apart (m/s with N, in/s with lbf)."""
    frf = io.read_frf(UFF / name)
    assert frf.quantity == quantity
    assert frf.response_dofs == tuple(DOF(k + 1, 3) for k in range(len(factors)))
    expected = np.outer(factors, np.ones(F.size)) + 0j
    np.testing.assert_allclose(frf.H[:, 0] / truth(0), expected, rtol=RTOL_SINGLE)


def test_unit_label_parser():
    cases = {
        "g/N": (9.80665, "accelerance"),
        "(m/s)/N": (1.0, "mobility"),
        "(1/N)*(m/s^2)": (1.0, "accelerance"),
        "m s^-2 N^-1": (1.0, "accelerance"),
        "m/s⁻¹/N": (1.0, None),
        "in/s^2/lbf": (IN_LBF, "accelerance"),
        "mm/s/N": (1e-3, "mobility"),
        "m/sÂ²/N": (1.0, "accelerance"),  # UTF-8 read as Latin-1
        "(m/s≤)/N": (1.0, "accelerance"),  # Latin-1 ² read as Mac Roman
        "µm/N": (1e-6, "receptance"),
        "mm/N": (1e-3, "receptance"),
    }
    for label, (factor, quantity) in cases.items():
        unit = io.parse_unit_label(label)
        assert unit.factor == pytest.approx(factor, rel=1e-12), label
        assert unit.quantity == quantity, label
    for bad in ("furlong/N", "m/s^/N", "(m/s", "2 m/N"):
        with pytest.raises(ValueError):
            io.parse_unit_label(bad)


def test_plus_and_minus_direction_of_a_node_are_one_dof():
    frf = io.read_frf(UFF / "directions.uff")
    # records: 3-Z/2+Z: h0, 3+Z/5-Z: h1, 4-X/2+Z: h2, 4+X/5-Z: h0
    assert frf.response_dofs == (DOF(3, 3), DOF(4, 1))
    assert frf.reference_dofs == (DOF(2, 3), DOF(5, 3))
    np.testing.assert_allclose(frf.H[0, 0], -truth(0), rtol=RTOL_SINGLE)
    np.testing.assert_allclose(frf.H[0, 1], -truth(1), rtol=RTOL_SINGLE)
    np.testing.assert_allclose(frf.H[1, 0], -truth(2), rtol=RTOL_SINGLE)
    np.testing.assert_allclose(frf.H[1, 1], -truth(0), rtol=RTOL_SINGLE)
    raw = pyuff.UFF(str(UFF / "directions.uff")).read_sets(0)
    np.testing.assert_allclose(frf.H[0, 0], -raw["data"], rtol=1e-12)


def test_non_uniform_axis_is_read_as_stored():
    frf = io.read_frf(UFF / "nonuniform.uff")
    fu = np.geomspace(1.0, 200.0, make.N_LINES)
    np.testing.assert_allclose(frf.freq_hz, fu, rtol=RTOL_SINGLE)
    np.testing.assert_allclose(frf.H[0, 0], truth(0, fu), rtol=1e-5)
    assert not io.axis_is_uniform(frf.freq_hz) and io.axis_is_uniform(F)
    raw = pyuff.UFF(str(UFF / "nonuniform.uff")).read_sets(0)
    np.testing.assert_allclose(frf.freq_hz, raw["x"], rtol=1e-12)


@pytest.mark.parametrize("name, rtol", [("binary_le_single.ufb", RTOL_SINGLE),
                                        ("binary_be_double.uff", 1e-14)])
def test_binary_58b_both_byte_orders(name, rtol):
    frf = io.read_frf(UFF / name)
    assert frf.H.shape == (2, 1, 40)
    np.testing.assert_allclose(frf.freq_hz, F)
    for k in range(2):
        np.testing.assert_allclose(frf.H[k, 0], truth(k), rtol=rtol)
    rec = io.read_uff(UFF / name).records[0]
    assert rec.binary and rec.ord_data_type == (5 if "single" in name else 6)
    sets = pyuff.UFF(str(UFF / name)).read_sets([1, 2])  # pyuff agrees on these
    np.testing.assert_allclose(frf.H[1, 0], sets[1]["data"], rtol=1e-12)


def test_too_few_lines_for_identification():
    path = UFF / "short_10_lines.uff"
    assert io.read_frf(path).freq_hz.size == 10  # a valid file: it reads
    with pytest.raises(DataError, match=r"short_10_lines.uff: record 1 .*has 10 frequency "
                                        r"lines; at least 32 are needed"):
        io.read_frf(path, min_lines=io.MIN_FRF_LINES)


def test_time_records_give_a_clear_message():
    path = UFF / "time_only.uff"
    with pytest.raises(DataError, match=r"time_only.uff: a raw recording \(time data\), not "
                                        r"FRFs; make the FRFs first: ema-pipeline frf"):
        io.read_frf(path)
    with pytest.raises(DataError, match=r"time_only.uff: impact \d has no force record"):
        io.read_time_uff(path)


def test_any_suffix_case(tmp_path):
    names = ["a.UFF", "b.Unv", "c.UFB", "d.FRF", "e.frf", "f.H5", "notes.txt"]
    for name in names:
        shutil.copy(UFF / "units_164_inch_lbf.unv", tmp_path / name)
    found = [p.name for p in io.find_frf_files(tmp_path)]
    assert found == ["a.UFF", "b.Unv", "c.UFB", "d.FRF", "e.frf", "f.H5"]
    assert {io.frf_format(tmp_path / n) for n in names[:5]} == {"uff"}
    np.testing.assert_allclose(io.read_frf(tmp_path / "d.FRF").H[0, 0], truth(0) * IN_LBF,
                               rtol=RTOL_SINGLE)


def test_damaged_files_give_only_data_errors(tmp_path):
    """Cut every test file at many places and overwrite bytes: each read either
    works or raises the project's DataError naming the file; nothing else leaks."""
    rng = np.random.default_rng(3)
    n_errors = 0
    for src in sorted(UFF.iterdir()):
        raw = src.read_bytes()
        variants = [raw[: int(len(raw) * q)] for q in np.linspace(0.05, 0.98, 12)]
        for _ in range(12):
            b = bytearray(raw)
            at = rng.integers(0, len(b), 3)
            for a in at:
                b[a] = int(rng.choice(list(b"-1 9Ee.\n\x00xNa")))
            variants.append(bytes(b))
        for k, data in enumerate(variants):
            path = tmp_path / f"{src.stem}_{k}{src.suffix}"
            path.write_bytes(data)
            try:
                io.read_frf(path)
            except DataError as exc:
                assert str(path) in str(exc)
                n_errors += 1
            except EMAError as exc:  # pragma: no cover - would be a wrong class
                pytest.fail(f"{path}: {type(exc).__name__}: {exc}")
    assert n_errors > 100  # the cuts are caught (truncated / corrupt)


def test_truncated_binary_record(tmp_path):
    raw = (UFF / "binary_be_double.uff").read_bytes()
    cut = tmp_path / "cut.uff"
    cut.write_bytes(raw[: len(raw) - 200])
    with pytest.raises(DataError, match=r"cut.uff: record 3 \(dataset 58b at line \d+\): "
                                        r"truncated Universal File: \d+ of 640 bytes"):
        io.read_frf(cut)


# ---------------------------------------------------------------- pyuff's test data


def test_pyuff_non_ascii_header_latin1_units(pyuff_dir: Path):
    """'(1/N)*(m/s²)' with a Latin-1 superscript two; pyuff reads the same values."""
    path = pyuff_dir / "non_ascii_header.uff"
    frf = io.read_frf(path)
    ref = pyuff.UFF(str(path)).read_sets(0)
    assert frf.quantity == "accelerance" and frf.H.shape == (1, 1, 6)
    np.testing.assert_allclose(frf.H[0, 0], ref["data"], rtol=1e-12)
    np.testing.assert_allclose(frf.freq_hz, ref["x"], rtol=1e-12)


def test_pyuff_binary_8_byte_time_record(pyuff_dir: Path):
    path = pyuff_dir / "binary8byte.uff"
    rec = io.read_uff(path).records[0]
    ref = pyuff.UFF(str(path)).read_sets(0)
    assert rec.binary and rec.func_type == 1 and rec.n_values == 250
    np.testing.assert_allclose(rec.data, ref["data"], rtol=1e-15)
    with pytest.raises(DataError, match="binary8byte.uff: a raw recording .*ema-pipeline frf"):
        io.read_frf(path)


def test_pyuff_testlab_project_without_functions(pyuff_dir: Path):
    path = pyuff_dir / "testlab_164_18_15_82.uff"
    contents = io.read_uff(path)
    assert contents.records == [] and contents.skipped == {18: 1}  # 15, 82: geometry
    assert contents.unit_systems[0].code == 9  # user defined, factors 1
    with pytest.raises(DataError, match=r"testlab_164_18_15_82.uff: no dataset 58 .*found "
                                        r"15, 18, 82, 151, 164"):
        io.read_frf(path)
