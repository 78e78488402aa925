"""``ema-pipeline init DIR`` then ``ema-pipeline run`` on a structure that is not
the beam: a simply supported plate on a 4 x 3 grid of points, tested with a
roving hammer and a fixed accelerometer, in two configurations (as built, and
with a modification that lowers every frequency by a few per cent).

The test's own generator (pyuff and numpy, none of the package's code) writes
the FRFs (UFF-58, accelerance, modal superposition of four plate modes) and
the geometry (UFF 15 and 82). The report must show the geometry's animated
shapes and the cross-configuration MAC, and no FE or added-mass stage runs.
"""

from __future__ import annotations

import html
import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline.cli import main
from tests.cli_runs import run_cli

pyuff = pytest.importorskip("pyuff")

A_M, B_M = 0.4, 0.3  # plate size
MN = [(1, 1), (2, 1), (1, 2), (2, 2)]  # plate modes (half waves in x, y)
K_HZ = 40.0 / ((1 / A_M) ** 2 + (1 / B_M) ** 2)  # f_mn = K ((m/a)^2 + (n/b)^2); f_11 = 40 Hz
FN_HZ = np.array([K_HZ * ((m / A_M) ** 2 + (n / B_M) ** 2) for m, n in MN])
ZETA = np.array([0.010, 0.008, 0.009, 0.007])
SHIFT = np.array([0.97, 0.975, 0.96, 0.98])  # the modification's frequency ratios
X = np.array([0.08, 0.16, 0.24, 0.32])
Y = np.array([0.075, 0.15, 0.225])
NODES = np.arange(1, 13)  # node k at (X[(k-1) % 4], Y[(k-1) // 4])
FIXED = 1  # the accelerometer (off every nodal line)


def node_xy(k: int) -> tuple[float, float]:
    return float(X[(k - 1) % 4]), float(Y[(k - 1) // 4])


def shape(k: int, r: int) -> float:
    m, n = MN[r]
    x, y = node_xy(k)
    return float(np.sin(m * np.pi * x / A_M) * np.sin(n * np.pi * y / B_M))


def write_plate(folder: Path, offset: int = 0) -> None:
    """geometry.uff, reference.uff and modified.uff (the FRF files number the
    points ``offset + k``, the geometry ``k``)."""
    xyz = np.array([(*node_xy(k), 0.0) for k in NODES])
    lines = [list(range(1 + 4 * j, 5 + 4 * j)) for j in range(3)]
    lines += [[i, i + 4, i + 8] for i in range(1, 5)]
    records = [pyuff.prepare_15(node_nums=NODES.tolist(), def_cs=[0] * 12, disp_cs=[0] * 12,
                                color=[1] * 12, x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2])]
    records += [pyuff.prepare_82(trace_num=k + 1, n_nodes=len(line), color=1,
                                 id=f"line {k + 1}", nodes=np.array(line)) for k, line in
                enumerate(lines)]
    pyuff.UFF(str(folder / "geometry.uff")).write_sets(records, mode="add")
    f = np.arange(0.0, 250.0 + 1e-9, 0.25)
    w = 2 * np.pi * f
    rng = np.random.default_rng(7)
    for name, ratio in (("reference", np.ones(4)), ("modified", SHIFT)):
        fn = FN_HZ * ratio
        lam = -ZETA * 2 * np.pi * fn + 2j * np.pi * fn * np.sqrt(1 - ZETA**2)
        sets = []
        for k in NODES:  # hammer at k, accelerometer at FIXED: accelerance
            h = np.zeros(f.size, complex)
            for r in range(4):
                a = shape(FIXED, r) * shape(k, r) / (2j * lam[r].imag)  # unit modal mass
                h += a / (1j * w - lam[r]) + np.conj(a) / (1j * w - np.conj(lam[r]))
            h = -(w**2) * h
            h += 2e-4 * np.abs(h).max() * (rng.standard_normal(f.size)
                                           + 1j * rng.standard_normal(f.size))
            sets.append(pyuff.prepare_58(
                binary=0, func_type=4, rsp_node=offset + FIXED, rsp_dir=3,
                ref_node=offset + int(k), ref_dir=3,
                data=h, x=f, id1=f"plate {name} H {FIXED}+Z/{k}+Z", abscissa_spacing=1,
                abscissa_spec_data_type=18, ordinate_spec_data_type=12,
                orddenom_spec_data_type=13, ordinate_axis_units_lab="m/s^2",
                orddenom_axis_units_lab="N"))
        pyuff.UFF(str(folder / f"{name}.uff")).write_sets(sets, mode="add")


@pytest.fixture(scope="module")
def plate_study(tmp_path_factory) -> tuple[Path, Path]:
    raw = tmp_path_factory.mktemp("plate")
    assert main(["init", str(raw)]) == 0
    path = raw / "experiment.toml"
    text = path.read_text(encoding="utf-8")
    # the user's edits: name, object, the fixed accelerometer, the band
    text = text.replace('name = "My structure"', 'name = "Plate, roving hammer"')
    text = text.replace('object = "the test object: material, size, boundary conditions"',
                        'object = "steel plate 400 x 300 mm, simply supported"')
    text = text.replace('# fixed = ["1+Z"]', f'fixed = ["{FIXED}+Z"]')
    text = text.replace("# band_hz = [5.0, 1000.0]", "band_hz = [10.0, 240.0]")
    path.write_text(text, encoding="utf-8")
    write_plate(raw)
    out = raw.parent / (raw.name + "_results")
    assert main(["run", "--raw", str(raw), "--results", str(out), "--quiet"]) == 0
    return raw, out


def test_init_refuses_to_overwrite(tmp_path, capsys):
    assert main(["init", str(tmp_path)]) == 0
    doc = tomllib.loads((tmp_path / "experiment.toml").read_text(encoding="utf-8"))
    assert {"test", "geometry", "dofs", "configurations"} <= set(doc)
    assert "beam" not in doc  # any structure; the beam's tables are commented out
    assert main(["init", str(tmp_path)]) == 2
    assert "exists; give --force" in capsys.readouterr().err
    assert main(["init", str(tmp_path), "--force"]) == 0


def test_run_on_a_plate_identifies_both_configurations(plate_study):
    _, out = plate_study
    t1 = pd.read_csv(out / "tables" / "table1_modal_parameters.csv")
    for name, ratio in (("reference", np.ones(4)), ("modified", SHIFT)):
        fn = t1.loc[t1.configuration == name, "fn_hz"].to_numpy()
        np.testing.assert_allclose(np.sort(fn), FN_HZ * ratio, rtol=2e-3)
    # no beam: no FE model, no update, no added mass
    assert sorted(p.name for p in (out / "tables").glob("*.csv")) == [
        "table1_modal_parameters.csv"]


def test_plate_report_has_animated_shapes_and_cross_mac(plate_study):
    _, out = plate_study
    page = (out / "report.html").read_text(encoding="utf-8")
    views = re.findall(r'data-mode-shape="(\d+)"', page)
    assert len(views) >= 8  # 4 modes in each of the two configurations
    assert 'id="across"' in page  # modes across configurations: the MAC matrix
    across = page[page.index('id="across"'):]
    across = across[: across.index("</section>")]
    # the MAC of mode k with mode k is near 1: the diagonal cells print 0.99 or more
    cells = [float(v) for v in re.findall(r">(0\.\d+|1\.0+)<", across)]
    assert sum(v >= 0.99 for v in cells) >= 4
    # the test as the file describes it
    assert "steel plate 400 x 300 mm" in page
    assert html.escape("roving hammer, fixed accelerometer(s) at 1+Z") in page
    # no beam: no FE tables, and the report says why
    assert 'id="table1_modal_parameters"' in page
    assert not re.search(r'id="table[2-6]_', page)
    assert "describes no beam" in page
    # the interactive diagram of each configuration
    assert page.count('class="stabd"') == 2 and 'id="picks"' in page


def test_dofs_map_puts_the_file_points_on_the_geometry(tmp_path, capsys):
    """The FRF file numbers the points 101-112, the geometry 1-12: ``[dofs] map``
    puts every measured point on its node (all 12 drawn as measured); a
    ``[dofs] fixed`` DOF the file does not hold is an error naming the file."""
    raw = tmp_path / "raw"
    assert main(["init", str(raw)]) == 0
    write_plate(raw, offset=100)
    path = raw / "experiment.toml"
    mapping = ", ".join(f'"{100 + k}+Z" = "{k}+Z"' for k in NODES)
    text = path.read_text(encoding="utf-8").replace(
        '# map = {"101+Z" = "1+Z"}', f"map = {{{mapping}}}")
    path.write_text(text.replace('# fixed = ["1+Z"]', 'fixed = ["1+Z"]'), encoding="utf-8")
    assert main(["run", "--raw", str(raw), "--results", str(tmp_path / "out"), "--quiet"]) == 0
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert "with no node in the geometry" not in page  # said without the map
    assert "101+Z -&gt; 1+Z" in page  # the report states the map
    capsys.readouterr()
    path.write_text(text.replace('# fixed = ["1+Z"]', 'fixed = ["13+Z"]'), encoding="utf-8")
    assert main(["run", "--raw", str(raw), "--results", str(tmp_path / "out2"),
                 "--quiet"]) == 2
    assert "reference.uff: [dofs] fixed 13+Z: not among the file's DOFs" in capsys.readouterr().err


def test_init_writes_the_template_and_force_overwrites(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """init DIR creates DIR (nested) with experiment.toml, a TOML template with the
    [test], [geometry], [dofs] and [[configurations]] tables; an existing file is
    kept (exit 2) unless --force, which replaces it with the template."""
    folder = tmp_path / "new" / "test"
    assert run_cli(["init", folder], capsys)[0] == 0
    template = (folder / "experiment.toml").read_text()
    assert {"test", "geometry", "dofs", "configurations"} <= set(tomllib.loads(template))
    (folder / "experiment.toml").write_text("# mine\n")
    code, _, err = run_cli(["init", folder], capsys)
    assert code == 2 and "--force" in err
    assert (folder / "experiment.toml").read_text() == "# mine\n"
    assert run_cli(["init", folder, "--force"], capsys)[0] == 0
    assert (folder / "experiment.toml").read_text() == template
