"""Issue 27 part A: test geometry (UFF 15/2411/82, DOF mapping), animated mode
shapes in the reports, modes across configurations, the test as it was done."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.data import DOF, Beam, Geometry
from ema_pipeline.report.shape_views import (
    ModeSet,
    interpolated_displacements,
    shape_data,
    shape_views_html,
)

REPO = Path(__file__).resolve().parents[1]
EXAMPLE_GEOMETRY = REPO / "examples" / "ufsc-beam-geometry.uff"
MEASURED_BEAM = REPO.parent / "shared" / "data" / "ufsc-beam-hammer.uff"


def _plate() -> Geometry:
    """A 3 x 2 grid of nodes 11..16 in the z = 0.1 m plane, two lines and a quad."""
    xyz = [[x, y, 0.1] for y in (0.0, 0.2) for x in (0.0, 0.3, 0.6)]
    return Geometry(node_ids=[11, 12, 13, 14, 15, 16], xyz_m=xyz,
                    lines=((11, 12, 13), (14, 15, 16), (11, 14)), surfaces=((11, 12, 15, 14),))


@pytest.mark.parametrize(("dataset", "atol"), [(15, 5e-6), (2411, 1e-14)])
def test_geometry_round_trip_through_uff(tmp_path, dataset, atol):
    g = _plate()
    path = io.write_geometry_uff(g, tmp_path / "g.uff", dataset=dataset)
    text = path.read_text()
    assert re.search(rf"^\s*{dataset}\s*$", text, re.M) and re.search(r"^\s*82\s*$", text, re.M)
    back = io.read_geometry(path)
    assert back.node_ids.tolist() == [11, 12, 13, 14, 15, 16]
    np.testing.assert_allclose(back.xyz_m, g.xyz_m, rtol=0, atol=atol)  # E13.5 / D25.16
    assert back.lines == g.lines


def test_geometry_in_millimetres_is_read_in_metres(tmp_path):
    g = _plate()
    path = io.write_geometry_uff(g, tmp_path / "g.uff")
    # dataset 164 code 2 "mm": 1000 file units per metre; coordinates written in mm
    text = path.read_text().replace(
        "   1.0000000000000000D+00   1.0000000000000000D+00   1.0000000000000000D+00",
        "   1.0000000000000000D+03   1.0000000000000000D+00   1.0000000000000000D+00", 1)
    text = text.replace("3.00000E-01", "3.00000E+02").replace("6.00000E-01", "6.00000E+02")
    text = text.replace("2.00000E-01", "2.00000E+02").replace("1.00000E-01", "1.00000E+02")
    (tmp_path / "mm.uff").write_text(text)
    np.testing.assert_allclose(io.read_geometry(tmp_path / "mm.uff").xyz_m, g.xyz_m, atol=1e-9)


def test_geometry_table_and_bad_input():
    g = io.geometry_from_table({"nodes": [[1, 0, 0, 0], [2, 1.0, 0, 0]], "lines": [[1, 2]]},
                               "exp.toml")
    assert g.n_nodes == 2 and g.lines == ((1, 2),)
    with pytest.raises(io.DataError,
                       match=r"exp.toml \[geometry\]: trace line 1 uses node\(s\) \[3\]"):
        io.geometry_from_table({"nodes": [[1, 0, 0, 0], [2, 1, 0, 0]], "lines": [[1, 3]]},
                               "exp.toml")
    with pytest.raises(io.DataError, match="unknown key"):
        io.geometry_from_table({"node": []}, "exp.toml")


def test_dof_mapping_reports_a_missing_node():
    g = _plate()
    dofs = [DOF(11, 3), DOF(13, -3), DOF(99, 3), DOF(12, 0)]
    m = g.map_dofs(dofs)
    assert m.node_index.tolist() == [0, 2, -1, -1]
    assert m.axis.tolist() == [2, 2, -1, -1] and m.sign.tolist() == [1, -1, 1, 1]
    assert [d.label() for d in m.missing] == ["99+Z", "12+S"]
    html = shape_views_html(g, ModeSet(np.array([10.0]), np.array([0.01]),
                                       np.ones((4, 1), complex), tuple(dofs)))
    box = re.search(r'<div class="problems">(.*?)</div>', html).group(1)
    assert "99+Z" in box and "12+S" in box


def test_example_geometry_is_the_ufsc_beam():
    g = io.read_geometry(EXAMPLE_GEOMETRY)
    assert g.node_ids.tolist() == list(range(1, 35))
    for node, (x, y, z) in zip(g.node_ids, g.xyz_m, strict=True):
        k = (node - 1) % 17  # 0..16 along each edge, 0.05 m apart
        assert x == pytest.approx(0.05 * k, abs=1e-9)
        assert y == pytest.approx(0.0 if node <= 17 else -0.05, abs=1e-9) and z == 0
    assert tuple(range(1, 18)) in g.lines and tuple(range(18, 35)) in g.lines
    assert all((k, k + 17) in g.lines for k in range(1, 18))  # across, at every station


def test_interpolation_along_lines_and_rest_at_the_ends():
    g = _plate()
    # measured: 11 and 13 (z), 15 (z); 12 lies between 11 and 13 on line 1 (0.3 of 0.6 m)
    d, known = interpolated_displacements(
        g, np.array([[2.0 + 1j], [4.0 - 1j], [5.0]]), [DOF(11), DOF(13), DOF(15)])
    assert d[1, 2, 0] == pytest.approx(3.0 + 0j)  # the mean of 11 and 13
    assert d[3, 2, 0] == 0 and d[5, 2, 0] == 0  # line 2: one measured node only -> rest
    assert known[:, 2].tolist() == [True, False, True, False, True, False]
    assert not known[:, :2].any() and np.all(d[:, :2] == 0)


def test_complex_phase_is_kept_in_the_json():
    g = _plate()
    phi = np.array([[0.5 * np.exp(0.3j)], [-1.0 * np.exp(0.1j)], [0.25j]])
    data = shape_data(g, {"": ModeSet(np.array([12.0]), np.array([0.02]), phi,
                                      (DOF(11), DOF(13), DOF(16, -3)))})
    d = np.asarray(data["modes"][0]["d"]).reshape(-1, 6)
    z = d[:, 2] + 1j * d[:, 5]
    truth = np.array([phi[0, 0], 0, phi[1, 0], 0, 0, -phi[2, 0]]) / phi[1, 0]
    truth[1] = (truth[0] + truth[2]) / 2  # node 12: interpolated
    np.testing.assert_allclose(z, truth, atol=1e-4)  # 4 decimals in the page
    assert np.angle(z[0]) == pytest.approx(0.3 - 0.1 - np.pi, abs=1e-3)  # the relative phase


def _page_checks(html: str, n_modes: int) -> list[dict]:
    views = re.findall(r'data-mode-shape="(\d+)"', html)
    blobs = re.findall(r'<script type="application/json" class="shape-data">(.*?)</script>', html)
    assert blobs
    data = [json.loads(b) for b in blobs]
    assert len(views) == n_modes
    assert not re.search(r'(src|href)\s*=\s*["\']?\s*(https?:)?//', html, re.I)
    return data


def test_study_report_has_paired_shapes_mac_and_stays_small(example_study):
    html = (example_study / "report.html").read_text()
    # 452 kB, 3 x 24 kB of it the stabilization diagrams' FRFs for the
    # synthesis of the picks (every line of the band)
    assert (example_study / "report.html").stat().st_size < 470_000
    data = _page_checks(html, 12)  # 4 modes x 3 configurations, paired
    assert {m["set"] for m in data[0]["modes"]} == {"genuine", "larger_tank", "smaller_tank"}
    assert len(data[0]["nodes"]) == Beam().n_measurement_elements + 1
    assert "Modes across configurations" in html
    for name in ("larger_tank", "smaller_tank"):
        table = re.search(rf"<caption>MAC genuine \(rows\) vs {name} \(columns\)</caption>"
                          r"(.*?)</table>", html).group(1)
        rows = re.findall(r"<tr><th>[^<]*</th>(.*?)</tr>", table.split("<tbody>")[1])
        values = np.array([[float(v) for v in re.findall(r">([0-9.]+)</td>", r)] for r in rows])
        assert values.shape == (4, 4)
        assert np.all(np.diag(values) > 0.9), values
        # the view of each configuration's mode k says which genuine mode it pairs
        for k in range(1, 5):
            assert f"{name}: mode {k}, " in html and f"(pairs genuine mode {k})" in html


@pytest.fixture(scope="module")
def beam_geometry_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("geom") / "beam.uff"
    return io.write_geometry_uff(Beam().measurement_geometry(), path)


def test_identify_report_animates_the_modes_on_a_given_geometry(tmp_path, example_dir,
                                                                 beam_geometry_file,
                                                                 three_sensor_h5):
    """Three sensors (conftest.three_sensor_h5): the modes animated on the
    geometry. The shipped example's two sensors: no shape views even with a
    geometry (a shape of two points, issue 41)."""
    out = tmp_path / "id"
    stem = three_sensor_h5.stem
    assert main(["identify", str(three_sensor_h5), "--out", str(out),
                 "--report", "--quiet", "--geometry", str(beam_geometry_file)]) == 0
    html = (out / f"{stem}_report.html").read_text()
    n_modes = len(io.read_csv(out / f"{stem}_modes.csv", required=("mode",)))
    data = _page_checks(html, n_modes)
    assert [m["n"] for m in data[0]["modes"]] == list(range(1, n_modes + 1))
    # the measured nodes 3, 6 and 9 carry the shape (0-based 2, 5, 8)
    assert sorted(data[0]["modes"][0]["m"]) == [2, 5, 8]
    # without --geometry (an HDF5 file holds none) the page has no shape views, nor
    # with --no-figures
    for options in ([], ["--no-figures", "--geometry", str(beam_geometry_file)]):
        assert main(["identify", str(three_sensor_h5), "--out",
                     str(tmp_path / "b"), "--report", "--quiet", *options]) == 0
        assert "data-mode-shape" not in (tmp_path / "b" / f"{stem}_report.html").read_text()
    assert main(["identify", str(example_dir / "larger_tank.h5"), "--out", str(tmp_path / "c"),
                 "--report", "--quiet", "--geometry", str(beam_geometry_file)]) == 0
    two = (tmp_path / "c" / "larger_tank_report.html").read_text()
    assert "data-mode-shape" not in two and "has 2 measured points only" in two


@pytest.mark.skipif(not MEASURED_BEAM.is_file(), reason="../shared/data not present")
def test_measured_beam_report_states_the_roving_test(tmp_path, capsys):
    src = tmp_path / "beam.uff"
    shutil.copy(MEASURED_BEAM, src)
    assert main(["identify", str(src), "--out", str(tmp_path), "--report",
                 "--band", "10", "130", "--geometry", str(EXAMPLE_GEOMETRY)]) == 0
    html = (tmp_path / "beam_report.html").read_text()
    cell = {m.group(1): m.group(2) for m in re.finditer(
        r"<tr><td>([^<]*)</td><td>([^<]*)</td></tr>", html)}
    assert cell["sensors (fixed)"] == "3-Z"
    hammer = [f"{n}-Z" for n in [*range(2, 17), *range(19, 34)]]
    assert cell["hammer (roving points)"] == ", ".join(hammer)
    assert "roving hammer (30 points)" in cell["test"]
    for field in ("sample rate", "record length", "averages"):
        assert cell[field] == "not in the file"
    n_modes = len(io.read_csv(tmp_path / "beam_modes.csv", required=("mode",)))
    data = _page_checks(html, n_modes)
    assert len(data[0]["nodes"]) == 34
    assert sorted(data[0]["modes"][0]["m"]) == [k - 1 for k in [*range(2, 17), *range(19, 34)]]
