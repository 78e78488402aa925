"""`ema-pipeline run`: the whole study on the shipped example and on a second
experiment, against the paper's tables and the simulated truth."""

from __future__ import annotations

import json
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

from ema_pipeline import acquisition, io, paper
from ema_pipeline.cli import main
from ema_pipeline.data import Beam
from tests.paths import REPO

TABLES = {
    "table1_modal_parameters": ["configuration", "mode", "fd_hz", "zeta_pct"],
    "table2_modal_added_mass": ["configuration", "mode", "added_mass_ratio"],
    "table3_fe_initial": ["mode", "fn_hz"],
    "table4_updated_parameters": ["parameter", "unit", "initial", "updated", "lower", "upper"],
    "table5_fe_updated": ["mode", "fn_hz"],
    "table6_local_added_mass": ["configuration", "method", "element", "delta_k", "delta_m"],
}


@pytest.fixture(scope="module")
def study(example_study: Path) -> Path:
    """``ema-pipeline run`` on the shipped example (shared with the report tests, read only)."""
    return example_study


def _table(results: Path, name: str) -> pd.DataFrame:
    table = pd.read_csv(results / "tables" / f"{name}.csv")
    assert list(table.columns[: len(TABLES[name])]) == TABLES[name]
    return table


def test_table1_reproduces_the_paper(study):
    t1 = _table(study, "table1_modal_parameters")
    for cfg in paper.CONFIGURATIONS:
        rows = t1[t1["configuration"] == cfg].sort_values("mode")
        assert len(rows) == 4
        np.testing.assert_allclose(rows["fd_hz"], paper.TABLE1_FD_HZ[cfg], atol=0.02)
        np.testing.assert_allclose(rows["zeta_pct"] / 100, paper.TABLE1_ZETA[cfg], rtol=0.05)


def test_table2_and_table6_reproduce_the_paper(study):
    t2 = _table(study, "table2_modal_added_mass")
    for cfg, ratios in paper.TABLE2_RATIO.items():
        got = t2[t2["configuration"] == cfg].sort_values("mode")["added_mass_ratio"]
        np.testing.assert_allclose(got, ratios, atol=0.002)
    t6 = _table(study, "table6_local_added_mass")
    block = t6[t6["method"] == "block"].set_index("configuration")
    for cfg, ref in paper.TABLE6.items():
        assert block.loc[cfg, "delta_m"] == pytest.approx(ref["delta_m"], rel=0.05)
        assert abs(block.loc[cfg, "delta_k"]) <= 0.005
    assert set(t6["method"]) == {"block", "projected", "exact"}


def test_the_first_readme_command_leaves_a_checkout_clean(study):
    """``ema-pipeline run`` (README, Quick start) writes ``results/`` by default,
    and every file of a run there is git-ignored, none tracked: a fresh clone
    stays clean (``git status --porcelain`` empty; Table 4's individual
    parameters are not identifiable and their digits differ between BLAS
    builds, so no example output is shipped). The run writes nothing beside its
    results folder."""
    from ema_pipeline.cli.parser import build_parser

    assert build_parser().parse_args(["run"]).results == Path("results")
    assert sorted(p.name for p in study.parent.iterdir()) == ["results"]
    git = shutil.which("git")
    if git is None or not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    written = sorted(f"results/{p.relative_to(study).as_posix()}"
                     for p in study.rglob("*") if p.is_file())
    assert "results/tables/table4_updated_parameters.csv" in written
    # with the folder itself and the run's temporary siblings (io.swap_in)
    paths = [*written, "results", ".results.partial-1-x/report.md", ".results.old-1"]
    ignored = subprocess.run([git, "check-ignore", "--no-index", "--stdin"], cwd=REPO,
                             input="\n".join(paths), capture_output=True, text=True,
                             check=True).stdout.split()
    assert sorted(ignored) == sorted(paths)
    tracked = subprocess.run([git, "ls-files", "results"], cwd=REPO, capture_output=True,
                             text=True, check=True).stdout
    assert tracked == ""


def test_fe_tables_reproduce_the_paper(study):
    np.testing.assert_allclose(_table(study, "table3_fe_initial")["fn_hz"], paper.TABLE3_FN_HZ,
                               atol=0.01)
    t5 = _table(study, "table5_fe_updated")
    np.testing.assert_allclose(t5["fn_hz"], paper.TABLE5_FN_HZ, rtol=0.02)
    t4 = _table(study, "table4_updated_parameters")
    params = t4.set_index("parameter")
    for name in ("length", "width", "thickness", "youngs_modulus", "density"):
        row = params.loc[name]
        assert row["lower"] <= row["updated"] <= row["upper"]
    # the individual parameters are not identifiable, their combination is: compare that
    p = paper.TABLE4_UPDATED
    paper_combination = (p["thickness_m"] * np.sqrt(p["youngs_modulus_pa"] / p["density_kg_m3"])
                         / p["length_m"] ** 2)
    ours = t4[t4["identifiable"].astype(bool)]["updated"].item()
    assert ours == pytest.approx(paper_combination, rel=0.002)


def test_report_states_the_identifiable_combination_and_the_parameter_spread(study):
    """The report's note on the model update quotes h*sqrt(E/rho)/L^2 with its
    spread over the runs and each parameter's range over the runs (4 digits),
    not the machine-dependent digits of the individual ``updated`` values."""
    t4 = _table(study, "table4_updated_parameters").set_index("parameter")
    md = (study / "report.md").read_text()
    note = next(line for line in md.splitlines() if "model update (Table 4)" in line)
    comb = t4.loc["h*sqrt(E/rho)/L^2"]
    assert f"h*sqrt(E/rho)/L^2 = {comb['updated']:.3f} 1/s" in note
    relative = float(note.split("differential-evolution runs to ")[1].split(" ")[0])
    assert relative == pytest.approx(comb["run_std"] / comb["updated"], rel=0.5)  # 1 digit
    assert relative < 1e-6  # the combination is determined, its spread is numerical
    for name, row in t4[~t4["identifiable"].astype(bool)].iterrows():
        assert f"{name} {row['run_min']:.4g} to {row['run_max']:.4g} {row['unit']}" in note
        assert f"{row['updated']:.6g}" not in note
    assert "not identifiable one by one" in note


class _Collector(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.ids: set[str] = set()
        self.external: list[str] = []
        self.tables = 0
        self.svgs = 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "img":
            self.images.append(a.get("src", ""))
        if tag == "table":
            self.tables += 1
        if tag == "svg" and a.get("class") not in ("shape", "stab", "mark"):  # figures, not the
            # shape views nor the interactive stabilization diagram
            self.svgs += 1
        for key in ("src", "href"):
            if key in a and not str(a[key]).startswith(("data:", "#")):
                self.external.append(a[key])
        if tag in ("link", "script") and (a.get("src") or a.get("href")):
            self.external.append(tag)


def test_html_report_is_self_contained_with_every_figure_and_table(study):
    parser = _Collector()
    parser.feed((study / "report.html").read_text())
    svgs = sorted(p.stem for p in (study / "figures").glob("*.svg"))
    assert {"fig4_frf_overlay", "fig5_zoom_mode2", "mode_shapes", "modal_added_mass",
            "stabilization_genuine", "stabilization_larger_tank",
            "stabilization_smaller_tank"} <= set(svgs)
    # figures are inline SVG (issue 14: SVG is smaller and faster than base64 PNG)
    assert parser.images == [] and parser.svgs == len(svgs)
    assert {f"fig-{p}" for p in svgs} <= parser.ids
    assert set(TABLES) <= parser.ids and parser.tables >= 6
    assert parser.external == []
    md = (study / "report.md").read_text()
    assert all(f"figures/{p}.svg" in md for p in svgs)
    # printed beside the paper's values
    assert "| paper fd (Hz) |" in md and "| deviation fd (Hz) |" in md


def test_markdown_tables_have_the_html_headers(study):
    """Issue 41: the Markdown report's table headers are the HTML's words with
    units (report.tables.header_text), not the CSV files' identifiers."""
    import re

    lines = (study / "report.md").read_text(encoding="utf-8").splitlines()
    headers = [[c.strip() for c in line.strip("|").split("|")]
               for line, below in zip(lines, lines[1:], strict=False)
               if below.startswith("|---")]
    assert len(headers) >= 8  # setup, 3 x modes, fit, the paper's tables, provenance
    cells = [c for row in headers for c in row]
    assert not [c for c in cells if re.fullmatch(r"[a-z0-9]+(_[a-z0-9]+)+", c)], cells
    for words in ("f (Hz)", "σ_f (Hz)", "ζ (%)", "damped f (Hz)", "fit error (%)", "MPD (°)"):
        assert words in cells, words
    assert "fn_hz" not in cells and "zeta_pct" not in cells and "error_pct" not in cells


def test_results_store_and_summary(study):
    with h5py.File(study / "ema_results.h5") as h5:
        assert h5.attrs["schema"] == "ema-pipeline/results" and h5.attrs["complete"]
        assert set(h5["frf"]) == set(paper.CONFIGURATIONS)
        assert h5["identification/genuine/stabilization/order"].size > 100
        assert "update" in h5["fe"] and "tables" in h5
    summary = json.loads((study / "summary.json").read_text())
    assert summary["ok"] and summary["problems"] == []
    assert summary["modes"]["genuine"]["fd_hz"][0] == pytest.approx(18.14, abs=0.02)


def test_rerun_is_reproducible_and_replaces_the_folder(study, tmp_path, example_dir):
    again = tmp_path / "results"
    shutil.copytree(study, again)
    (again / "stale.txt").write_text("from an older run")
    assert main(["run", "--raw", str(example_dir), "--results", str(again), "--quiet"]) == 0
    assert not (again / "stale.txt").exists()
    for name in TABLES:
        assert (again / "tables" / f"{name}.csv").read_bytes() == (
            study / "tables" / f"{name}.csv"
        ).read_bytes(), name
    assert not list(tmp_path.glob(".results.*"))  # no temporary folders left


# ----------------------------------------------------------- bad experiments


def _copy_example(example_dir: Path, dest: Path) -> Path:
    shutil.copytree(example_dir, dest)
    return dest / "experiment.toml"


def test_missing_frf_file_is_an_input_error_and_keeps_earlier_results(tmp_path, example_dir,
                                                                       capsys):
    """Every input is checked before anything runs: exit 2, one line naming the
    experiment file, the configuration and the missing file; earlier results untouched."""
    _copy_example(example_dir, tmp_path / "raw")
    (tmp_path / "raw" / "smaller_tank.uff").unlink()
    res = tmp_path / "res"
    (res / "tables").mkdir(parents=True)
    (res / "report.md").write_text("earlier")
    code = main(["run", "--raw", str(tmp_path / "raw"), "--results", str(res), "--quiet"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "experiment.toml" in err[0] and "smaller_tank.uff" in err[0]
    assert "no such file" in err[0]
    assert sorted(p.name for p in res.rglob("*")) == ["report.md", "tables"]
    assert (res / "report.md").read_text() == "earlier"
    assert not list(tmp_path.glob(".res.*"))


def test_unknown_configuration_name_is_a_usage_error(tmp_path, example_dir, capsys):
    toml = _copy_example(example_dir, tmp_path / "raw")
    toml.write_text(toml.read_text().replace('genuine = "genuine"', 'genuine = "in_air"'))
    assert main(["run", "--raw", str(tmp_path / "raw"), "--results", str(tmp_path / "r")]) == 2
    assert "genuine configuration 'in_air' is not among" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_too_few_modes_for_the_fe_stage(tmp_path, example_dir, capsys):
    toml = _copy_example(example_dir, tmp_path / "raw")
    toml.write_text(toml.read_text().replace("n_modes = 4", "n_modes = 6"))
    code = main(["run", "--raw", str(tmp_path / "raw"), "--results", str(tmp_path / "res"),
                 "--quiet"])
    assert code == 1
    err = capsys.readouterr().err
    assert "the FE stage needs 6" in err
    tables = {p.stem for p in (tmp_path / "res" / "tables").glob("*.csv")}
    assert {"table1_modal_parameters", "table3_fe_initial"} <= tables
    assert (tmp_path / "res" / "report.html").exists()


# ----------------------------------------------------- a second experiment

SECOND_RATIOS = np.array([0.20, 0.15, 0.10, 0.08, 0.06, 0.05])


@pytest.fixture(scope="module")
def second_experiment(tmp_path_factory) -> Path:
    """A 0.9 m beam, sensors at nodes 4 and 9, hammer at node 7, six modes in the
    band, two immersed elements; the modified state has known modal added mass."""
    raw = tmp_path_factory.mktemp("second")
    beam = Beam(length_m=0.9)
    setup = acquisition.TestSetup(beam=beam, response_nodes=(4, 9), hammer_node=7)
    fn_air, _ = acquisition.cantilever_modes(beam, np.array([0.0]), 6)
    fn_air = fn_air * 0.97
    zeta = np.array([0.005, 0.004, 0.003, 0.003, 0.0035, 0.004])
    truth = {"air": fn_air, "pond": fn_air / np.sqrt(1 + SECOND_RATIOS)}
    for k, (name, fn) in enumerate(truth.items()):
        fd = fn * np.sqrt(1 - zeta**2)
        modes = acquisition.configuration_modes(name, fd_hz=fd, zeta=zeta, n_modes_total=9)
        frf = acquisition.simulate_impact_test(modes, setup, seed=20 + k)
        frf.configuration = name
        io.write_frf(frf, raw / ("air.h5" if name == "air" else "pond.uff"))
    (raw / "experiment.toml").write_text(
        """
[experiment]
name = "Second beam: 0.9 m, two immersed elements"
genuine = "air"
[beam]
length_m = 0.9
[sensors]
response_nodes = [4, 9]
hammer_node = 7
[identification]
band_hz = [4.0, 950.0]
[fe]
immersed_elements = [9, 10]
n_modes = 6
update_repeats = 2
[[configurations]]
name = "air"
file = "air.h5"
[[configurations]]
name = "pond"
file = "pond.uff"
"""
    )
    return raw


def test_second_experiment_runs_without_code_change(second_experiment, tmp_path):
    res = tmp_path / "res"
    assert main(["run", "--raw", str(second_experiment), "--results", str(res), "--quiet"]) == 0
    t1 = pd.read_csv(res / "tables" / "table1_modal_parameters.csv")
    assert sorted(set(t1["configuration"])) == ["air", "pond"]
    assert (t1.groupby("configuration").size() == 6).all()
    t2 = pd.read_csv(res / "tables" / "table2_modal_added_mass.csv")
    np.testing.assert_allclose(t2.sort_values("mode")["added_mass_ratio"], SECOND_RATIOS,
                               atol=0.002)
    t6 = pd.read_csv(res / "tables" / "table6_local_added_mass.csv")
    assert sorted(set(t6["element"])) == [9, 10] and len(t6) == 6  # 2 elements x 3 methods
    html = (res / "report.html").read_text()
    assert "Second beam" in html and "paper_fd_hz" not in html  # no paper comparison here
