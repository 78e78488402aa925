"""``ema-pipeline run``'s options and the experiment file's keys change the
study as they say (a simulated three-configuration study; FRF files on a
geometry), checked against the values given and the paper's tables (every
option's test: test_option_inventory.py)."""

from __future__ import annotations

import contextlib
import html
import json
import logging
import re
import shutil
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io, paper
from tests.cli_runs import TWO_MODES, count_calls, run_cli, shape_data, write_experiment

#: A study simulated on the paper's FE beam, band 5-200 Hz (its first two modes,
#: Table 3's 19.84 and 124.33 Hz), two simulated configurations and one given as
#: the raw hammer records of the paper's genuine beam (Table 1: 18.14, 112.07 Hz).
STUDY_A = """
[experiment]
name = "Option effects: two masses"
[test]
object = "steel cantilever"
date = 2024-05-06
operator = "A. Tester"
equipment = ["PCB 086C03 hammer", "PCB 352C23 accelerometer"]
description = "a three-configuration check"
[identification]
band_hz = [5.0, 200.0]
[fe]
n_modes = 2
update_repeats = 1
[[configurations]]
name = "as_built"
added_mass = {}
description = "the beam as built"
zeta_pct = [1.0, 0.8]
snr_db = 0
[[configurations]]
name = "tip_mass"
added_mass = {10 = 0.3}
description = "thirty per cent at the tip"
[[configurations]]
name = "recorded"
recording = "hits.uff"
description = "hammer records of the paper's beam"
"""


#: RAW/experiment.toml beside it: no name (the file's stem), one noise-free
#: configuration, the FE stage on the first mode only.
STUDY_B = """
[identification]
band_hz = [5.0, 200.0]
[fe]
n_modes = 1
update_repeats = 1
[[configurations]]
name = "as_built"
added_mass = {}
snr_db = 0
"""


@pytest.fixture(scope="module")
def study_raw(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """RAW with experiment.toml (:data:`STUDY_B`), a.toml (:data:`STUDY_A`) and the
    paper genuine beam's hammer records ``hits.uff`` (UFF-58 time records)."""
    from ema_pipeline import acquisition
    from ema_pipeline.pipeline.simulate import paper_modes

    raw = tmp_path_factory.mktemp("study")
    setup = acquisition.TestSetup()
    records = acquisition.simulate_time_records(paper_modes("genuine", setup), setup,
                                                snr_db=50, seed=3, configuration="genuine")
    io.write_time_uff(records, raw / "hits.uff", binary=True)
    write_experiment(raw / "a.toml", STUDY_A)
    write_experiment(raw / "experiment.toml", STUDY_B)
    return raw


def _cells(page: str) -> dict[str, str]:
    """The report's two-cell rows ``<tr><th>key</th><td>value</td></tr>`` as a dict."""
    return {html.unescape(m.group(1)): html.unescape(m.group(2)) for m in re.finditer(
        r"<tr><th>([^<]*)</th><td>([^<]*)</td></tr>", page)}


def test_run_options_and_experiment_keys(study_raw: Path, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    """run --experiment a.toml replaces RAW/experiment.toml; --json prints the
    summary as JSON only; --quiet prints nothing; the default prints the progress
    (stderr) and the summary (stdout).

    The keys, against the values given and the paper: [experiment] name is the
    report's title and the summary's name (default: the file's stem); the
    configurations' names are Table 1's; zeta_pct is the identified damping
    (noise-free, 1e-3), the paper's genuine damping where not given; [fe] n_modes
    is the number of modes of Tables 3 and 5 (Table 3 = the paper's, 1e-3);
    descriptions and [test] appear in the report as given; the recorded
    configuration's frequencies are the paper's Table 1 (1e-3)."""
    code, said, err = run_cli(["run", "--raw", study_raw, "--experiment", study_raw / "a.toml",
                            "--results", tmp_path / "a", "--no-figures", "--json"], capsys)
    assert code == 0, err
    payload = json.loads(said)  # nothing but the JSON on stdout
    assert payload["experiment"] == "Option effects: two masses"
    assert payload["results"] == str(tmp_path / "a")
    modes = payload["modes"]
    assert list(modes) == ["as_built", "tip_mass", "recorded"]
    np.testing.assert_allclose(modes["as_built"]["fn_hz"], paper.TABLE3_FN_HZ[:2], rtol=1e-3)
    np.testing.assert_allclose(modes["as_built"]["zeta_pct"], [1.0, 0.8], rtol=1e-3)
    np.testing.assert_allclose(modes["tip_mass"]["zeta_pct"],
                               100 * paper.TABLE1_ZETA["genuine"][:2], rtol=0.01)
    np.testing.assert_allclose(modes["recorded"]["fd_hz"], paper.TABLE1_FD_HZ["genuine"][:2],
                               rtol=1e-3)
    tables = tmp_path / "a" / "tables"
    np.testing.assert_allclose(pd.read_csv(tables / "table3_fe_initial.csv")["fn_hz"],
                               paper.TABLE3_FN_HZ[:2], rtol=1e-3)
    assert len(pd.read_csv(tables / "table5_fe_updated.csv")) == 2
    page = (tmp_path / "a" / "report.html").read_text()
    assert "<title>Option effects: two masses" in page
    cells = _cells(page)
    for key, value in (("object", "steel cantilever"), ("date", "2024-05-06"),
                       ("operator", "A. Tester"),
                       ("equipment", "PCB 086C03 hammer; PCB 352C23 accelerometer"),
                       ("description", "a three-configuration check")):
        assert cells[key] == value, key
    for name, text in (("as_built", "the beam as built"),
                       ("tip_mass", "thirty per cent at the tip"),
                       ("recorded", "hammer records of the paper&#x27;s beam")):
        assert f"<tr><td>{name}</td><td>{text}</td>" in page, name

    # RAW/experiment.toml (no --experiment), --quiet: nothing printed
    code, said, err = run_cli(["run", "--raw", study_raw, "--results", tmp_path / "b",
                            "--no-figures", "--quiet"], capsys)
    assert (code, said, err) == (0, "", "")
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert summary["experiment"] == "experiment" and list(summary["modes"]) == ["as_built"]
    np.testing.assert_allclose(pd.read_csv(tmp_path / "b" / "tables" / "table3_fe_initial.csv")
                               ["fn_hz"], paper.TABLE3_FN_HZ[:1], rtol=1e-3)
    # neither: progress on stderr, the summary on stdout
    code, said, err = run_cli(["run", "--raw", study_raw, "--results", tmp_path / "c",
                            "--no-figures"], capsys)
    assert code == 0
    assert said.startswith("ema-pipeline run: experiment") and "[identify 1/1] as_built" in err


#: Any structure (a [geometry], no [beam]: identification only): the noise-free
#: two-mode FRF twice, once said to carry a 10 s exponential window; its DOFs
#: 1+Z and 2+Z (hammer at 1+Z) are put on nodes 1 and 3 of the geometry.
STUDY_FILES = """
[experiment]
name = "Two modes"
[geometry]
nodes = [[1, 0.0, 0.0, 0.0], [2, 0.3, 0.0, 0.0], [3, 0.3, 0.2, 0.0]]
lines = [[1, 2]]
surfaces = [[1, 2, 3]]
[dofs]
roving = "sensor"
fixed = ["1+Z"]
map = {"2+Z" = "3+Z"}
[identification]
band_hz = [5.0, 95.0]
[[configurations]]
name = "windowed"
file = "two.uff"
description = "said to be windowed, tau 10 s"
exp_window_tau_s = 10.0
[[configurations]]
name = "plain"
file = "two.uff"
"""


@contextlib.contextmanager
def _logging_restored() -> Iterator[None]:
    """--verbose adds a handler to the package's logger (for the process): removed
    again on leaving."""
    log = logging.getLogger("ema_pipeline")
    handlers, level = list(log.handlers), log.level
    try:
        yield
    finally:
        log.handlers[:] = handlers
        log.setLevel(level)


def test_run_file_configurations_geometry_and_verbose(
        two_mode_folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Configurations read from a file: name and description as given;
    exp_window_tau_s = 10 s removes 1/tau from the decay rate of the file's
    30 Hz / 1 % and 70 Hz / 2 % modes (zeta = (sigma - 1/tau) / |lambda|), the
    other stays at 1 % / 2 % (1e-4). [geometry] nodes, lines and surfaces are
    the report's animated model; [geometry] file reads the nodes and trace lines
    of a UFF file, lines and surfaces add to them; run --geometry FILE replaces
    [geometry]. [dofs] map puts the file's 2+Z on node 3 (measured nodes 1, 3;
    without it 1, 2), roving and fixed are the report's description of the test.
    --verbose prints the reader's INFO message about the UFF dataset it skips
    (2420), without it nothing."""
    raw = tmp_path / "raw"
    raw.mkdir()
    text = (two_mode_folder / "two.uff").read_text()
    (raw / "two.uff").write_text(text + "    -1\n  2420\n         1\nSI\n    -1\n")
    write_experiment(raw / "experiment.toml", STUDY_FILES)
    with _logging_restored():
        code, said, err = run_cli(["run", "--raw", raw, "--results", tmp_path / "a", "--quiet",
                                "--verbose"], capsys)
    assert code == 0 and said == ""
    assert "skipped datasets not needed for FRFs: 2420" in err
    t1 = pd.read_csv(tmp_path / "a" / "tables" / "table1_modal_parameters.csv")
    assert t1["configuration"].tolist() == ["windowed"] * 2 + ["plain"] * 2
    plain = t1[t1["configuration"] == "plain"]
    np.testing.assert_allclose(plain["fn_hz"], TWO_MODES.fn_hz, rtol=1e-4)
    np.testing.assert_allclose(plain["zeta_pct"], 100 * TWO_MODES.zeta, rtol=1e-4)
    wd = 2 * np.pi * TWO_MODES.fn_hz * np.sqrt(1 - TWO_MODES.zeta**2)
    sigma = TWO_MODES.zeta * 2 * np.pi * TWO_MODES.fn_hz - 1 / 10.0
    np.testing.assert_allclose(t1.loc[t1["configuration"] == "windowed", "zeta_pct"],
                               100 * sigma / np.hypot(wd, sigma), rtol=1e-4)  # 0.947, 1.977
    page = (tmp_path / "a" / "report.html").read_text()
    assert "<tr><td>windowed</td><td>said to be windowed, tau 10 s</td>" in page
    cells = _cells(page)
    assert cells["test"] == "roving accelerometer(s), fixed hammer at 1+Z"
    assert cells["DOF map (file -> geometry)"] == "2+Z -> 3+Z"
    data = shape_data(page)
    assert data["ids"] == [1, 2, 3]
    np.testing.assert_allclose(data["nodes"], [[0, 0, 0], [0.3, 0, 0], [0.3, 0.2, 0]])
    assert data["lines"] == [[0, 1]] and data["surfaces"] == [[0, 1, 2]]
    assert data["modes"][0]["m"] == [0, 2]  # measured: nodes 1 and 3 (the map)

    # a UFF geometry (nodes 1-3 elsewhere, one trace line 1-2-3)
    from ema_pipeline.data import Geometry
    xyz = np.array([[0.0, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.5, 0.25]])
    io.write_geometry_uff(Geometry(node_ids=np.array([1, 2, 3]), xyz_m=xyz, lines=((1, 2, 3),)),
                          raw / "geometry.uff")
    code, said, err = run_cli(["run", "--raw", raw, "--results", tmp_path / "b", "--quiet",
                            "--geometry", raw / "geometry.uff"], capsys)
    assert (code, said, err) == (0, "", "")  # no --verbose: no INFO message
    data = shape_data((tmp_path / "b" / "report.html").read_text())
    np.testing.assert_allclose(data["nodes"], xyz)
    assert data["lines"] == [[0, 1, 2]] and data["surfaces"] == []
    write_experiment(raw / "experiment.toml", STUDY_FILES.replace(
        "nodes = [[1, 0.0, 0.0, 0.0], [2, 0.3, 0.0, 0.0], [3, 0.3, 0.2, 0.0]]",
        'file = "geometry.uff"').replace("lines = [[1, 2]]", "lines = [[3, 1]]").replace(
        'map = {"2+Z" = "3+Z"}\n', "").replace('roving = "sensor"\n', ""))
    assert run_cli(["run", "--raw", raw, "--results", tmp_path / "c", "--quiet"], capsys)[0] == 0
    page = (tmp_path / "c" / "report.html").read_text()
    data = shape_data(page)
    np.testing.assert_allclose(data["nodes"], xyz)
    assert data["lines"] == [[0, 1, 2], [2, 0]] and data["surfaces"] == [[0, 1, 2]]
    assert data["modes"][0]["m"] == [0, 1]  # no map: the file's nodes 1 and 2
    cells = _cells(page)  # fixed without roving: said as such
    assert cells["fixed DOFs"] == "1+Z" and "test" not in cells


def test_a_fixed_order_in_the_experiment_file_is_a_note_of_run(
        example_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``[identification] max_order`` in the study: ``run`` says once, in its notes
    (console and report), for which configurations it turned the
    narrower searches off (the warning of ``identify`` went to the log only)."""
    raw = tmp_path / "raw"
    shutil.copytree(example_dir, raw)
    toml = raw / "experiment.toml"
    toml.write_text(toml.read_text().replace("# max_order = 40", "max_order = 40"))
    with pytest.warns(UserWarning, match="turned off the narrower searches"):
        code, out, _ = run_cli(["run", "--raw", raw, "--results", tmp_path / "results",
                             "--no-figures"], capsys)
    assert code == 0
    note = ("genuine, larger_tank, smaller_tank: max_order (--max-order) turned off the "
            "narrower searches that run with the adaptive order only (the band's lowest 1/8 "
            "and the windows of a dense band)")
    assert [line for line in out.splitlines() if "narrower searches" in line] == [
        f"note: {note}: the modes found make no dense band, but those of the adaptive order may"]


def test_run_checks_each_configuration_once(two_mode_folder: Path, tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """``run`` of two configurations read from a file checks each once, before
    anything is computed (``prepare_study``), and identifies the checked input
    as it is: one ``check_input`` each, hence one window, one single reference
    and one order / memory check per configuration (the report's count of a
    shape's points, ``report.shape_views.shape_dof_count``, is no check and
    not counted); the identified modes are the file's 30 Hz / 1 % and 70 Hz /
    2 % (1e-4)."""
    import ema_pipeline.pipeline.study  # noqa: F401  (every holder of the checks loaded)
    from ema_pipeline.identification import IdentificationOptions, common, core
    from ema_pipeline.identification.diagram import resources

    raw = tmp_path / "raw"
    raw.mkdir()
    shutil.copy(two_mode_folder / "two.uff", raw / "two.uff")
    write_experiment(raw / "experiment.toml", STUDY_FILES)
    checks = count_calls(monkeypatch, core, "check_input")
    window = count_calls(monkeypatch, IdentificationOptions, "apply_window")
    single = count_calls(monkeypatch, common, "single_reference")
    limits = count_calls(monkeypatch, resources, "check_identification")
    code, said, err = run_cli(["run", "--raw", raw, "--results", tmp_path / "out",
                               "--no-figures", "--quiet"], capsys)
    assert (code, said) == (0, ""), err
    single = [call for call in single if not call[0].startswith("ema_pipeline.report")]
    assert [len(c) for c in (checks, window, single, limits)] == [2, 2, 2, 2]
    t1 = pd.read_csv(tmp_path / "out" / "tables" / "table1_modal_parameters.csv")
    plain = t1[t1["configuration"] == "plain"]
    np.testing.assert_allclose(plain["fn_hz"], TWO_MODES.fn_hz, rtol=1e-4)
    np.testing.assert_allclose(plain["zeta_pct"], 100 * TWO_MODES.zeta, rtol=1e-4)


def test_run_refuses_a_configuration_it_cannot_identify_before_any_work(
        two_mode_folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A configuration whose FRFs ``identify`` refuses (a channel all zero in the
    band) stops ``run`` with exit 2 before the first identification, the
    message naming the file and the configuration; no results are written."""
    raw = tmp_path / "raw"
    raw.mkdir()
    shutil.copy(two_mode_folder / "two.uff", raw / "two.uff")
    frf = io.read_frf(raw / "two.uff")
    H = frf.H.copy()
    H[1] = 0.0
    io.write_frf(replace(frf, H=H), raw / "zero.uff", "uff")
    write_experiment(raw / "experiment.toml", STUDY_FILES.replace(
        'name = "plain"\nfile = "two.uff"', 'name = "plain"\nfile = "zero.uff"'))
    code, said, err = run_cli(["run", "--raw", raw, "--results", tmp_path / "out",
                               "--no-figures"], capsys)
    assert (code, said) == (2, "")
    assert f"{raw / 'zero.uff'} (plain): " in err and "all zero in the band" in err
    assert "[identify" not in err and not (tmp_path / "out").exists()
