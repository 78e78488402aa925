"""The channel sheet and ``frf --channels``: a simulated roving-hammer plate.

A simply supported rectangular plate (Kirchhoff) has the modes
``phi_mn(x, y) = sin(m pi x / Lx) sin(n pi y / Ly)`` with
``f_mn proportional to (m / Lx)^2 + (n / Ly)^2``. It is hit at 12 points (a 4 x 3 grid)
with one fixed accelerometer; each point is one recording (CSV, float WAV or TDMS,
written with numpy, scipy and npTDMS only by tests/impact_recordings.py), four clean
half-sine hits each, the responses computed exactly in the frequency domain. Truth: the analytic
frequencies, damping and shapes at the hammer points.
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.data import DataError
from ema_pipeline.io.channel_sheet import read_channel_sheet
from ema_pipeline.modal import mac_pairs
from ema_pipeline.pipeline.roving import sheet_frf
from tests import impact_recordings
from tests.impact_recordings import (
    PLATE_FS_HZ,
    PLATE_HIT_TIMES_S,
    Plate,
    PlateTest,
    plate_hammer_signals,
)

LX, LY = 0.6, 0.4
MODES = ((1, 1), (2, 1), (1, 2), (3, 1), (2, 2))  # by frequency
FN_HZ = np.array([4.43 * ((m / LX) ** 2 + (n / LY) ** 2) for m, n in MODES])
ZETA = np.array([0.010, 0.008, 0.010, 0.012, 0.009])
PLATE = Plate(LX, LY, MODES, FN_HZ, ZETA)
POINTS = [(x, y) for y in (0.1, 0.2, 0.3) for x in (0.12, 0.24, 0.36, 0.48)]
SENSOR = (0.1, 0.07)  # on no nodal line of the five modes
FS = PLATE_FS_HZ
HIT_TIMES_S = PLATE_HIT_TIMES_S
#: points 1-4 CSV, 5-8 float WAV in g (force in kN), 9-12 TDMS
FORMATS = ("csv",) * 4 + ("wav",) * 4 + ("tdms",) * 4
PEAK_N = 200.0


def _signals(point: tuple[float, float], seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Force (N) and acceleration (m/s^2) at the sensor for four hits at ``point``."""
    return plate_hammer_signals(PLATE, point, SENSOR, seed, peak_n=PEAK_N)


def plate_test(double_hit_point: int | None = None, plate: Plate = PLATE,
               points: list[tuple[float, float]] = POINTS) -> PlateTest:
    """This module's roving-hammer test (seeds 1-12; a bounce of 100 N at 2.65 s
    at ``double_hit_point``)."""
    return PlateTest(plate, tuple(points), SENSOR, FORMATS, PEAK_N, double_hit=(
        None if double_hit_point is None else (double_hit_point, 2.65, 100.0)))


def write_plate_test(folder: Path, double_hit_point: int | None = None) -> None:
    """One recording per hammer point (1-4 CSV, 5-8 float WAV in g, 9-12 TDMS) and
    ``channels.csv``; the sensor is node 100, +Z; the hammer hits in -Z."""
    impact_recordings.write_plate_test(folder, plate_test(double_hit_point))


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plate")
    write_plate_test(folder, double_hit_point=6)
    return folder


def test_sheet_rows_and_errors(tmp_path):
    sheet = tmp_path / "channels.csv"
    head = "file,channel,role,node,direction,scale,unit\n"
    sheet.write_text(head + "a.csv,0,force,3,-z,2.5,kN\na.csv,acc,response,7,Y,,\n")
    rows = read_channel_sheet(sheet).rows
    assert [(r.dof.label(), r.scale, r.unit, r.line) for r in rows] == [
        ("3-Z", 2.5, "kN", 2), ("7+Y", 1.0, "", 3)]
    assert rows[0].file == tmp_path / "a.csv"
    cases = {
        "a.csv,0,force,3,+W,,\na.csv,1,response,4,+Z,,\n": "row 2: direction must be",
        "a.csv,0,hammer,3,+Z,,\n": "row 2: role must be force or response",
        "a.csv,0,force,0,+Z,,\n": "row 2: node must be an integer >= 1, got 0",
        "a.csv,0,force,1,+Z,0,\na.csv,1,response,4,+Z,,\n": "row 2: scale must be a finite "
                                                           "non-zero number, got 0.0",
        "a.csv,0,force,1,+Z,,\na.csv,1,response,1,+Z,,\n": "row 3: DOF 1+Z of a.csv is named "
                                                           "twice (also",
        "a.csv,0,response,1,+Z,,\na.csv,1,response,2,+Z,,\n": "a.csv has no force row",
        "a.csv,0,force,1,+Z,,\n": "a.csv has no response row",
    }
    for body, message in cases.items():
        sheet.write_text(head + body)
        with pytest.raises(DataError, match=re.escape(message)) as err:
            read_channel_sheet(sheet)
        assert str(sheet) in str(err.value) and "\n" not in str(err.value)
    sheet.write_text("file,channel,role\n")
    with pytest.raises(DataError, match="missing column.*node, direction, scale, unit"):
        read_channel_sheet(sheet)


def test_roving_hammer_plate_frf_and_modes(plate, tmp_path):
    """frf --channels, then identify: every mode within 0.5 %, damping within 15 %,
    shapes over the 12 hammer points with MAC > 0.99 against the analytic ones."""
    out = tmp_path / "test.h5"
    assert main(["frf", "--channels", str(plate / "channels.csv"), "--out", str(out),
                 "--quiet"]) == 0
    frf = io.read_frf(out)
    assert frf.acquisition.layout == "reciprocal"
    assert [d.label() for d in frf.response_dofs] == [f"{k}-Z" for k in range(1, 13)]
    assert [d.label() for d in frf.reference_dofs] == ["100+Z"]
    hits = pd.read_csv(tmp_path / "test_hits.csv")
    assert list(hits.columns[:2]) == ["file", "hit"]
    assert sorted(set(hits["file"])) == sorted(
        [f"rec/p{k}.csv" for k in range(1, 5)] + [f"p{k}.wav" for k in range(5, 9)]
        + [f"p{k}.tdms" for k in range(9, 13)])
    p6 = hits[hits["file"] == "p6.wav"]
    assert p6["reasons"].fillna("").str.contains("double_hit").sum() == 1
    assert int(hits["accepted"].sum()) == 12 * 4 - 1

    from ema_pipeline.identification import identify
    result = identify(frf, band_hz=(20.0, 200.0))
    found = result.modes
    assert found.fn_hz.size == FN_HZ.size
    np.testing.assert_allclose(np.sort(found.fn_hz), FN_HZ, rtol=0.005)
    order = np.argsort(found.fn_hz)
    np.testing.assert_allclose(found.zeta[order], ZETA, rtol=0.15)
    truth = np.array([PLATE.shape(x, y) for x, y in POINTS])  # (12, n_modes)
    measured = np.real(result.shapes_real)[:, order]
    assert mac_pairs(measured, truth).min() > 0.99


def test_roving_sensor_layout_and_mismatches(plate, tmp_path):
    """One hammer point, the sensor roving: laid out as measured (responses = the
    sensor DOFs); a different sample rate, force unit, a point with every hit rejected
    and a DOF pair named twice are errors naming the file."""
    import shutil

    for k in (1, 2):
        shutil.copy(plate / f"rec/p{k}.csv", tmp_path / f"s{k}.csv")
    head = "file,channel,role,node,direction,scale,unit\n"
    sheet = tmp_path / "channels.csv"
    sheet.write_text(head + "s1.csv,Hammer,force,1,-Z,,\ns1.csv,acc,response,100,+Z,,\n"
                     "s2.csv,Hammer,force,1,-Z,,\ns2.csv,acc,response,101,+Z,,\n")
    result = sheet_frf(sheet)
    assert result.layout == "roving sensor"
    assert [d.label() for d in result.frf.response_dofs] == ["100+Z", "101+Z"]
    assert result.frf.acquisition.layout == ""
    # the same file as the sheet with the force in kN: one test, one force unit
    sheet.write_text(head + "s1.csv,Hammer,force,1,-Z,,\ns1.csv,acc,response,100,+Z,,\n"
                     "s2.csv,Hammer,force,2,-Z,,kN\ns2.csv,acc,response,100,+Z,,\n")
    with pytest.raises(DataError, match=r"force of .*s2.csv is in kN.*s1.csv in N"):
        sheet_frf(sheet)
    sheet.write_text(head + "s1.csv,Hammer,force,1,-Z,,\ns1.csv,acc,response,100,+Z,,\n"
                     "s2.csv,Hammer,force,1,-Z,,\ns2.csv,acc,response,100,+Z,,\n")
    with pytest.raises(DataError, match=r"response 100\+Z to a hit at 1-Z is named twice"):
        sheet_frf(sheet)
    table = pd.read_csv(tmp_path / "s2.csv")
    table["time_s"] = np.arange(len(table)) / 1024.0
    table.to_csv(tmp_path / "s2.csv", index=False)
    sheet.write_text(head + "s1.csv,Hammer,force,1,-Z,,\ns1.csv,acc,response,100,+Z,,\n"
                     "s2.csv,Hammer,force,2,-Z,,\ns2.csv,acc,response,100,+Z,,\n")
    with pytest.raises(DataError, match=r"s2.csv is sampled at 1024 Hz, .*s1.csv at 2048 Hz"):
        sheet_frf(sheet)
    table = pd.read_csv(tmp_path / "s1.csv")
    table["Hammer [N]"] = 0.0  # no hit at all at point 2
    table.to_csv(tmp_path / "s2.csv", index=False)
    with pytest.raises(DataError, match=r"point 2-Z \(hammer at 2-Z, s2.csv\)"):
        sheet_frf(sheet)


def test_frf_command_needs_inputs_or_sheet(plate, tmp_path, capsys):
    assert main(["frf", "--out", str(tmp_path / "a.h5")]) == 2
    assert "--channels" in capsys.readouterr().err
    assert main(["frf", str(plate / "p5.wav"), "--channels", str(plate / "channels.csv"),
                 "--out", str(tmp_path / "a.h5")]) == 2
    assert "not both" in capsys.readouterr().err


def test_estimator_in_any_case(plate, tmp_path):
    """--estimator h1 is H1: the same FRFs as --estimator H1."""
    outs = []
    for name in ("h1", "H1", "h2"):
        out = tmp_path / f"{name}.h5"
        assert main(["frf", str(plate / "rec/p1.csv"), "--out", str(out), "--estimator", name,
                     "--quiet"]) == 0
        outs.append(io.read_frf(out))
    np.testing.assert_array_equal(outs[0].H, outs[1].H)
    assert outs[0].acquisition.estimator == "H1" and outs[2].acquisition.estimator == "H2"


def _complete(template: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """What the engineer does with the template: node, direction, scale and the
    units the files lack, from the test's own sheet."""
    key = truth.assign(name=truth["file"].map(lambda f: f.split("/")[-1]),
                       ch=truth["channel"].astype(str).str.lower()).set_index(["name", "ch"])
    out = template.copy()
    for k, row in template.iterrows():
        t = key.loc[(row["file"].split("/")[-1], str(row["channel"]).lower())]
        out.loc[k, ["node", "direction"]] = [str(int(t["node"])), str(t["direction"])]
        out.loc[k, "scale"] = "" if pd.isna(t["scale"]) else f"{t['scale']:g}"
        if not pd.isna(t["unit"]):
            out.loc[k, "unit"] = str(t["unit"])
    return out


def test_init_recordings_then_run_has_shapes_over_the_hammer_points(plate, tmp_path, capsys):
    """init --recordings writes the sheet template (channels, roles, the units the
    files give); completed, `run` identifies the plate with its geometry: every mode
    within 0.5 %, shapes animated over the 12 hammer points, reciprocity stated."""
    raw = tmp_path / "raw"
    assert main(["init", str(raw), "--recordings", str(plate)]) == 0
    assert "12 recordings" in capsys.readouterr().out
    template = pd.read_csv(raw / "channels.csv", comment="#", dtype=str, keep_default_na=False)
    assert list(template.columns) == ["file", "channel", "role", "node", "direction", "scale",
                                      "unit"]
    assert len(template) == 24 and (template["role"] == "force").sum() == 12
    by_file = template.groupby("file")["unit"].apply(list).to_dict()
    rel = Path(os.path.relpath(plate, raw)).as_posix()
    assert by_file[f"{rel}/rec/p1.csv"] == ["N", "m/s^2"]
    assert by_file[f"{rel}/p5.wav"] == ["", ""]  # a WAV holds no units
    assert by_file[f"{rel}/p9.tdms"] == ["N", "m/s^2"]
    assert (template["node"] == "").all()
    text = (raw / "experiment.toml").read_text(encoding="utf-8")
    assert tomllib.loads(text)["recordings"]["channels"] == "channels.csv"
    nodes = [[k, x, y, 0.0] for k, (x, y) in enumerate(POINTS, start=1)] + [[100, *SENSOR, 0.0]]
    lines = [[1, 2], [2, 3], [3, 4], [5, 6], [6, 7], [7, 8], [9, 10], [10, 11], [11, 12],
             [1, 5], [5, 9], [4, 8], [8, 12]]
    text = text.replace('file = "geometry.uff"', f"nodes = {nodes}\nlines = {lines}")
    text = text.replace("# band_hz = [5.0, 1000.0]", "band_hz = [20.0, 200.0]")
    (raw / "experiment.toml").write_text(text, encoding="utf-8")
    assert main(["run", "--raw", str(raw), "--results", str(tmp_path / "o0"), "--quiet"]) == 2
    assert "node is blank" in capsys.readouterr().err  # not completed yet
    _complete(template, pd.read_csv(plate / "channels.csv")).to_csv(raw / "channels.csv",
                                                                   index=False)
    out = tmp_path / "out"
    assert main(["run", "--raw", str(raw), "--results", str(out), "--quiet"]) == 0
    t1 = pd.read_csv(out / "tables" / "table1_modal_parameters.csv")
    np.testing.assert_allclose(np.sort(t1["fn_hz"].to_numpy()), FN_HZ, rtol=0.005)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert len(re.findall(r'data-mode-shape="(\d+)"', page)) >= FN_HZ.size
    assert "identified by reciprocity" in page and "roving hammer (12 points)" in page
    assert "p6.wav" in page  # the hit table with its file column


def test_batch_takes_a_sheet_as_one_test(plate, tmp_path):
    """batch on the plate's folder: the sheet is one input (its 12 recordings are not
    inputs of their own); its FRFs are over the hammer points and its modes right."""
    out = tmp_path / "out"
    assert main(["batch", str(plate), "--out", str(out), "--band", "20", "200",
                 "--quiet"]) == 0
    summary = pd.read_csv(out / "summary.csv")
    assert summary["file"].tolist() == ["channels.csv"]
    assert (summary["status"] == "ok").all()
    frf = io.read_frf(out / "channels.h5")
    assert frf.n_out == 12 and frf.acquisition.layout == "reciprocal"
    assert set(pd.read_csv(out / "channels_hits.csv")["file"]) >= {"rec/p1.csv", "p12.tdms"}
    found = np.sort(pd.read_csv(out / "channels_modes.csv")["fn_hz"].to_numpy())
    np.testing.assert_allclose(found, FN_HZ, rtol=0.005)


def test_experiment_file_takes_the_sheet_inline_or_per_configuration(plate, tmp_path):
    """[[configurations]] channels: a sheet file or its rows inline give the same
    sheet; frf settings the sheet gives itself are refused; [sensors] without [beam]
    is accepted (it places channels without DOFs)."""
    from ema_pipeline.io.experiment import experiment_channel_sheet

    rows = pd.read_csv(plate / "channels.csv", dtype=str, keep_default_na=False)
    inline = ",\n  ".join(
        "{" + ", ".join(f'{k} = "{v}"' for k, v in r.items() if v) + "}"
        for r in rows.to_dict("records"))
    path = plate / "experiment_inline.toml"
    path.write_text('[geometry]\nnodes = [[1, 0.0, 0.0, 0.0]]\n[sensors]\nresponse_nodes = [100]\n'
                    '[[configurations]]\nname = "by_file"\nchannels = "channels.csv"\n'
                    f'[[configurations]]\nname = "inline"\nchannels = [\n  {inline}]\n')
    exp = io.read_experiment(path)
    by_file, inline_sheet = (experiment_channel_sheet(exp, spec) for spec in exp.configurations)
    assert [(r.file, r.channel, r.dof, r.scale, r.unit) for r in by_file.rows] == [
        (r.file, r.channel, r.dof, r.scale, r.unit) for r in inline_sheet.rows]
    assert len(by_file.rows) == 24 and by_file.rows[10].scale == 1000.0
    path.write_text('[recordings]\nchannels = "channels.csv"\n[recordings.frf]\n'
                    'force_channel = "hammer"\n')
    with pytest.raises(DataError, match=r"\[recordings\] frf: force_channel: the channel "
                                        "sheet gives"):
        io.read_experiment(path)
    path.write_text('[[configurations]]\nname = "x"\nchannels = [{file = "p1.csv"}]\n')
    with pytest.raises(DataError, match=r"\[\[configurations\]\] 1 channels: channel row 1: "
                                        "channel is blank"):
        io.read_experiment(path)
    path.unlink()


def test_a_hit_3_ms_into_a_file_is_kept(tmp_path):
    """A file that starts 3 ms before its first hit (pretrigger 10 ms): the hit is
    kept, its record padded at the front and its row says so; the FRF equals that of
    the whole recording within 0.5 % over the modes' band."""
    force, acc = _signals(POINTS[0], seed=1)
    k0 = int(round((HIT_TIMES_S[0] - 0.003) * FS))
    paths = []
    for name, lo in (("whole.csv", 0), ("cut.csv", k0)):
        table = pd.DataFrame({"time_s": np.arange(force.size - lo) / FS,
                              "Hammer [N]": force[lo:], "acc [m/s^2]": acc[lo:]})
        table.to_csv(tmp_path / name, index=False)
        paths.append(tmp_path / name)
    results = []
    for path in paths:
        out = path.with_suffix(".h5")
        assert main(["frf", str(path), "--out", str(out), "--quiet"]) == 0
        results.append((io.read_frf(out), pd.read_csv(path.with_name(f"{out.stem}_hits.csv"),
                                                      keep_default_na=False)))
    (whole, whole_hits), (cut, cut_hits) = results
    assert cut_hits["accepted"].tolist() == [True] * 4
    # pretrigger round(0.01 * 2048) = 20 samples; the pulse starts 3 ms = 6.1 samples in
    # and crosses the 5 % trigger at sample 7: 20 - 7 = 13 samples padded
    assert cut_hits["note"].iloc[0] == ("near the data start: its record padded with 13 "
                                        "samples before the data")
    assert (cut_hits["note"].iloc[1:] == "").all() and (whole_hits["note"] == "").all()
    band = (whole.freq_hz > 20) & (whole.freq_hz < 200)
    h_whole, h_cut = whole.H[0, 0, band], cut.H[0, 0, band]
    assert np.abs(h_cut - h_whole).max() < 0.005 * np.abs(h_whole).max()


def test_truncated_csv_and_identify_on_a_recording_have_our_own_messages(plate, tmp_path,
                                                                        capsys):
    """A CSV cut mid-row: one line of ours (no pandas/numpy hint); `identify` on a
    recording points to `ema-pipeline frf`."""
    text = (plate / "rec" / "p1.csv").read_text()
    cut = tmp_path / "cut.csv"
    lines = text.splitlines()[:5000]
    cut.write_text("\n".join(lines + [",".join(lines[-1].split(",")[:2])]) + "\n")
    assert main(["frf", str(cut), "--out", str(tmp_path / "a.h5")]) == 2
    err = capsys.readouterr().err
    assert "cut.csv: truncated CSV file: its last row has 2 of the header's 3 columns" in err
    assert "usecols" not in err and err.count("\n") == 1
    assert main(["identify", str(plate / "p9.tdms"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "p9.tdms: a raw recording (time data), not FRFs; make the FRFs first: " \
           "ema-pipeline frf" in err


def test_force_channel_warnings(plate, tmp_path, capsys):
    """Peaks of about 200 N read as kN (200 kN) warn that the unit is implausible for
    a hammer; the acceleration given as the force (it rings: every hit a double hit)
    gets the hint to check the force channel. The peaks as recorded warn of nothing."""
    table = pd.read_csv(plate / "rec" / "p1.csv")
    assert main(["frf", str(plate / "rec" / "p1.csv"), "--out", str(tmp_path / "a.h5"),
                 "--quiet"]) == 0
    assert capsys.readouterr().err == ""
    table.rename(columns={"Hammer [N]": "Hammer [kN]"}).to_csv(tmp_path / "kn.csv", index=False)
    assert main(["frf", str(tmp_path / "kn.csv"), "--out", str(tmp_path / "b.h5"),
                 "--quiet"]) == 0
    err = capsys.readouterr().err
    peak_kn = np.median(pd.read_csv(tmp_path / "b_hits.csv")["force_peak_n"]) / 1e3
    assert 150 < peak_kn < 250
    assert (f"warning: force channel 'Hammer': hit peaks of {peak_kn:.3g} kN (median) are "
            "implausible for an impact hammer") in err
    swapped = table.rename(columns={"Hammer [N]": "Hammer [m/s^2]", "acc [m/s^2]": "acc [N]"})
    swapped.to_csv(tmp_path / "swapped.csv", index=False)
    assert main(["frf", str(tmp_path / "swapped.csv"), "--out", str(tmp_path / "c.h5")]) == 2
    assert "is it a response? check the force channel" in capsys.readouterr().err


def test_sheet_hit_page(plate, tmp_path):
    """frf --channels --report: one hit page for the test, every file's hits with the
    file and their number in it, the double hit of p6.wav rejected."""
    head = "file,channel,role,node,direction,scale,unit\n"
    sheet = tmp_path / "channels.csv"
    sheet.write_text(head + "".join(
        f"{plate}/p{k}.wav,0,force,{k},-Z,1000,N\n{plate}/p{k}.wav,1,response,100,+Z,,g\n"
        for k in (5, 6)))
    out = tmp_path / "t.h5"
    assert main(["frf", "--channels", str(sheet), "--out", str(out), "--quiet"]) == 0
    assert not (tmp_path / "t_hits.html").exists()
    assert main(["frf", "--channels", str(sheet), "--out", str(out), "--report",
                 "--quiet"]) == 0
    page = (tmp_path / "t_hits.html").read_text(encoding="utf-8")
    rel = os.path.relpath(plate, tmp_path)
    titles = re.findall(r"<h2[^>]*>([^<]*) at \d", page)
    assert len(titles) == 8  # 4 hits in each file (p6.wav's hit 2 bounces 50 ms later)
    assert titles[0] == f"{rel}/p5.wav, hit 1" and titles[-1] == f"{rel}/p6.wav, hit 4"
    assert "2 files" in page and "double hit" in page
    # hits chosen per point: one group per file, each headed with its hammer point
    assert re.findall(r'data-hit-choice-point="([^"]*)"', page) == [
        f"{rel}/p5.wav", f"{rel}/p6.wav"]
    assert f"{rel}/p5.wav, hammer at 5-Z" in page and f"{rel}/p6.wav, hammer at 6-Z" in page
    # channels named by the sheet's DOFs (the WAV's channel 1 is the sensor 100+Z), in SI
    assert page.count(">100+Z [m/s^2]<") == 8 and "1 [m/s^2]" not in page
    assert "<th>averages</th><td>3-4 per point</td>" in page  # p6.wav: 3 of 4
    # the FRF file keeps the range, and the identify report's setup says it
    from ema_pipeline.report.result_tables import setup_table

    acq = io.read_frf(out).acquisition
    assert (acq.n_averages, acq.n_averages_max) == (3, 4)
    setup = setup_table({"t": io.read_frf(out)}, None).set_index("")
    assert setup.loc["averages", "t"] == "3-4 per point"
    # the sheet and every recording hashed
    for name in ("p5.wav", "p6.wav"):
        assert (f'<td class="path">{rel}/{name}</td><td class="hash">'
                f"{io.sha256_file(plate / name)}</td>") in page
    assert f'<td class="hash">{io.sha256_file(sheet)}</td>' in page
    # no exponential window was used (the records decay): no caption draws one
    tau = io.read_frf(out).acquisition.exp_window_tau_s
    captions = re.findall(r"<figcaption>Force pulse.*?</figcaption>", page)
    assert tau is None and len(captions) == 8
    assert not any("exponential" in c for c in captions)
    assert all("the force window (green dotted)" in c for c in captions)


CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus" / "impact2"


def _corpus_file(relative: str) -> Path:
    path = CORPUS / relative
    if not path.is_file():
        pytest.skip(f"{path} is absent (third-party recordings, not in the repository)")
    return path


def test_mat_recording_written_here(tmp_path):
    """A .mat written with scipy.io.savemat (a struct with time, force, acc and a
    units string) reads as the data stored: the force in N first, the acceleration
    in m/s^2, the sample rate from the time vector."""
    from scipy.io import savemat

    force, acc = _signals(POINTS[0], seed=3)
    t = np.arange(force.size) / FS - 0.01
    savemat(tmp_path / "hit.mat", {"rec": {"time": t, "hammer": force / 1e3, "acc": acc,
                                           "units": "s, kN, m/s^2"}})
    rec = io.read_recording(tmp_path / "hit.mat")
    assert rec.sample_rate_hz == FS
    assert [(c.name, c.quantity) for c in rec.channels] == [("hammer", "force"),
                                                           ("acc", "acceleration")]
    np.testing.assert_allclose(rec.signals[0], force, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(rec.signals[1], acc, rtol=1e-12)


def test_real_lvm_and_mat_recordings(tmp_path, capsys):
    """The real files of ../shared/corpus/impact2: the LVM (hammer F, labelled g, and
    two accelerations, 2 hits at 0.083 and 8.086 s) gives FRFs once F is given in N;
    the .mat with three accelerations and no force gets a clear error."""
    lvm = _corpus_file("ladisk-lvm_read/long_single_header_multi_ch.lvm")
    mat = _corpus_file("brb-hammer/HammerImpact.mat")
    from ema_pipeline.io.recording import recording_channels

    assert recording_channels(lvm) == [("F", "g", ""), ("m_1", "m/s^2", ""),
                                       ("m_2", "m/s^2", "")]
    out = tmp_path / "lvm.h5"
    assert main(["frf", str(lvm), "--out", str(out), "--unit", "F=N", "--quiet"]) == 0
    hits = pd.read_csv(tmp_path / "lvm_hits.csv")
    # SOURCES.txt times the pulses at 50 % of the peak, our trigger at 5 %: at most 3
    # samples (2.9 ms) earlier on these 1-2 sample pulses
    assert np.all(hits["time_s"].to_numpy() <= [0.083, 8.086])
    np.testing.assert_allclose(hits["time_s"], [0.083, 8.086], atol=3e-3)
    frf = io.read_frf(out)
    assert frf.n_out == 2 and frf.acquisition.sample_rate_hz == pytest.approx(1023.5, abs=0.1)
    assert main(["frf", str(mat), "--out", str(tmp_path / "mat.h5")]) == 2
    err = capsys.readouterr().err
    assert ("HammerImpact.mat: no force channel: none is in a force unit (N, kN, lbf); "
            "channels: 'acc1' (acceleration), 'acc2' (acceleration), 'acc3' (acceleration)."
            " Without the hammer's force there are no FRFs") in err


def test_hits_chosen_by_hand(plate, tmp_path, capsys):
    """frf --hits HITS.toml averages exactly the hits it names: the automatic choice
    written out gives the same FRFs bit for bit; dropping hit 2 averages 3 hits and
    changes them; in a sheet's test, p6.wav's double hit is averaged when chosen."""
    from ema_pipeline.io.hit_choice import write_hit_choice

    rec = plate / "rec" / "p1.csv"
    auto, same, fewer = (tmp_path / f"{n}.h5" for n in ("auto", "same", "fewer"))
    assert main(["frf", str(rec), "--out", str(auto), "--quiet"]) == 0
    write_hit_choice({"": [1, 2, 3, 4]}, tmp_path / "all.toml")
    write_hit_choice({"": [1, 3, 4]}, tmp_path / "three.toml")
    assert main(["frf", str(rec), "--out", str(same), "--hits", str(tmp_path / "all.toml"),
                 "--quiet"]) == 0
    assert main(["frf", str(rec), "--out", str(fewer), "--hits", str(tmp_path / "three.toml"),
                 "--quiet"]) == 0
    a, b, c = (io.read_frf(p) for p in (auto, same, fewer))
    np.testing.assert_array_equal(a.H, b.H)
    assert c.acquisition.n_averages == 3 and not np.array_equal(a.H, c.H)
    assert pd.read_csv(tmp_path / "fewer_hits.csv")["accepted"].tolist() == [True, False,
                                                                            True, True]
    write_hit_choice({"": [1, 9]}, tmp_path / "bad.toml")
    assert main(["frf", str(rec), "--out", str(fewer), "--hits", str(tmp_path / "bad.toml"),
                 "--quiet"]) == 2
    assert "the hit choice (--hits) names hit(s) 9; the recording has 4" in \
        capsys.readouterr().err
    write_hit_choice({"p6.wav": [1, 2, 3, 4]}, tmp_path / "p6.toml")
    out = tmp_path / "sheet.h5"
    assert main(["frf", "--channels", str(plate / "channels.csv"), "--out", str(out),
                 "--hits", str(tmp_path / "p6.toml"), "--quiet", "--report"]) == 0
    hits = pd.read_csv(tmp_path / "sheet_hits.csv")
    assert hits[hits["file"] == "p6.wav"]["accepted"].all()
    assert int(hits["accepted"].sum()) == 48
    page = (tmp_path / "sheet_hits.html").read_text(encoding="utf-8")
    assert page.count("kept by hand (--hits) despite: double hit") == 1  # p6.wav's hit 2
    assert "kept (--keep-all)" not in page


def test_close_pair_1_2_percent_apart(tmp_path):
    """A nearly square plate (Ly = 0.594 m for Lx = 0.6 m): modes (2,1) and (1,2) lie
    1.2 % apart (61.78 and 62.53 Hz). Recorded and assembled as the plate above, both
    are found within 0.1 %, damping within 15 %, shapes MAC > 0.99 over the hammer
    points; nothing spurious."""
    from ema_pipeline.identification import identify

    modes = ((1, 1), (2, 1), (1, 2), (2, 2), (3, 1))
    fn = np.array([4.43 * ((m / LX) ** 2 + (n / 0.594) ** 2) for m, n in modes])
    square = Plate(LX, 0.594, modes, fn, ZETA)
    points = [(x, y) for y in (0.15, 0.29, 0.43) for x in (0.12, 0.24, 0.36, 0.48)]
    assert 0.011 < fn[2] / fn[1] - 1 < 0.013
    impact_recordings.write_plate_test(tmp_path, plate_test(plate=square, points=points))
    result = identify(sheet_frf(tmp_path / "channels.csv").frf, band_hz=(15.0, 150.0))
    found = result.modes
    assert found.fn_hz.size == fn.size
    order = np.argsort(found.fn_hz)
    np.testing.assert_allclose(found.fn_hz[order], fn, rtol=1e-3)
    np.testing.assert_allclose(found.zeta[order], ZETA, rtol=0.15)
    truth = np.array([square.shape(x, y) for x, y in points])
    assert mac_pairs(np.real(result.shapes_real)[:, order], truth).min() > 0.99


def test_hit_page_plots_every_response_with_units(tmp_path):
    """Two accelerometers: each hit's figure has a panel for each, labelled with its
    unit (was: only the response that decayed least)."""
    force, acc = _signals(POINTS[0], seed=4)
    _, acc2 = _signals(POINTS[5], seed=4)
    pd.DataFrame({"time_s": np.arange(force.size) / FS, "Hammer [N]": force,
                  "acc [m/s^2]": acc, "other [g]": acc2 / 9.80665}).to_csv(
        tmp_path / "two.csv", index=False)
    assert main(["frf", str(tmp_path / "two.csv"), "--out", str(tmp_path / "two.h5"),
                 "--report", "--quiet"]) == 0
    page = (tmp_path / "two_hits.html").read_text(encoding="utf-8")
    assert page.count("acc [m/s^2]") >= 4 and page.count("other [m/s^2]") >= 4


def _uneven_plate(folder: Path, monkeypatch) -> list[Path]:
    """A roving-hammer test of three points on a lightly damped plate (the records
    need an exponential window, of a time constant that differs per point); point 3
    is hit every 1.2 s instead of 2.1 s, so its own records are half as long."""
    lightly = Plate(LX, LY, MODES, FN_HZ, np.full(FN_HZ.size, 0.002))
    rows = [impact_recordings.SHEET_HEADER]
    for k, point in enumerate(POINTS[:3], start=1):
        if k == 3:
            monkeypatch.setattr(impact_recordings, "PLATE_HIT_TIMES_S", (0.5, 1.7, 2.9, 4.1))
        force, acc = plate_hammer_signals(lightly, point, SENSOR, k, peak_n=PEAK_N)
        rows += impact_recordings.write_plate_recording(folder, k, force, acc, "csv")
    monkeypatch.undo()
    (folder / "channels.csv").write_text("\n".join(rows) + "\n")
    return [folder / "rec" / f"p{k}.csv" for k in (1, 2, 3)]


def test_sheet_reads_each_file_once_and_estimates_each_point_once(tmp_path, monkeypatch):
    """frf --channels on points whose own record lengths (4096, 4096, 2048 samples)
    and automatic windows differ: the record length and the window are settled over
    the files first (the shortest of each), then every file is read once and every
    point estimated once; the FRFs are those of each file estimated alone with the
    settled length and window."""
    from ema_pipeline import acquisition
    from ema_pipeline.io import recording as recording_io
    from ema_pipeline.pipeline.frf import FRFSettings, frf_from_recording

    files = _uneven_plate(tmp_path, monkeypatch)
    alone = [frf_from_recording(io.read_recording(f, force_channel="Hammer")) for f in files]
    assert [p.n_samples for p in alone] == [4096, 4096, 2048]
    settled_length = FRFSettings(record_length_s=2048 / FS)
    taus = [frf_from_recording(io.read_recording(f, force_channel="Hammer"),
                               settled_length).exp_window_tau_s for f in files]
    assert None not in taus and len(set(taus)) == 3  # each point its own window

    reads, estimates = [], []
    real_read, real_estimate = recording_io.read_raw_recording, acquisition.estimate_frf_windows

    def read(path):
        reads.append(Path(path).name)
        return real_read(path)

    def estimate(records, **kwargs):
        estimates.append(records.source.path)
        return real_estimate(records, **kwargs)

    monkeypatch.setattr(io, "read_raw_recording", read)
    monkeypatch.setattr(recording_io, "read_raw_recording", read)
    monkeypatch.setattr(acquisition, "estimate_frf_windows", estimate)
    out = tmp_path / "t.h5"
    assert main(["frf", "--channels", str(tmp_path / "channels.csv"), "--out", str(out),
                 "--report", "--quiet"]) == 0
    assert sorted(reads) == ["p1.csv", "p2.csv", "p3.csv"]
    assert sorted(Path(p).name for p in estimates) == ["p1.csv", "p2.csv", "p3.csv"]

    frf = io.read_frf(out)
    assert frf.acquisition.n_samples == 2048
    assert frf.acquisition.exp_window_tau_s == min(taus)
    settled = FRFSettings(record_length_s=2048 / FS, exp_window_tau=min(taus))
    for k, f in enumerate(files):  # as if each file were estimated with the settled ones
        one = frf_from_recording(io.read_recording(f, force_channel="Hammer"), settled)
        np.testing.assert_array_equal(frf.H[k, 0], one.frf.H[0, 0])
    page = (tmp_path / "t_hits.html").read_text(encoding="utf-8")
    assert page.count("<figcaption>Force pulse") == 12
    reads.clear()
    estimates.clear()  # a single recording too: read once, estimated once
    assert main(["frf", str(files[2]), "--force-channel", "Hammer", "--out",
                 str(tmp_path / "p3.h5"), "--report", "--quiet"]) == 0
    assert reads == ["p3.csv"] and len(estimates) == 1

