"""Issue 26 in the pipeline: ``batch`` takes raw recordings beside FRF files, and an
experiment-file configuration may name a recording instead of an FRF file.

Truth: the generator's modes (tests/impact_recordings.py, written without the
package) and the paper's Table 1 (the simulated cantilever's recording)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import acquisition, io, paper
from ema_pipeline.cli import main
from ema_pipeline.data import DataError
from ema_pipeline.io.recording import is_recording
from ema_pipeline.pipeline.simulate import paper_modes
from tests.fuzz_cases import fast_inputs
from tests.impact_recordings import make_recording, write_tdms
from tests.paths import REPO


def test_batch_takes_a_recording_beside_an_frf_file(tmp_path):
    rec = make_recording(1, n_resp=2, n_hits=6, last_hit_short=False, n_double=1)
    src = tmp_path / "in"
    src.mkdir()
    write_tdms(rec, src / "hammer.tdms")
    (src / "genuine.uff").write_bytes((REPO / "raw_frf" / "genuine.uff").read_bytes())
    (src / "notes.csv").write_text("name,value\na,1\n")  # not a recording: not an input
    out = tmp_path / "out"
    assert main(["batch", str(src), "--out", str(out), "--band", "5", str(rec.band_hz[1]),
                 "--quiet"]) == 0
    summary = pd.read_csv(out / "summary.csv").set_index("file")
    assert sorted(summary.index) == ["genuine.uff", "hammer.tdms"]
    assert (summary["status"] == "ok").all()
    # the recording: FRF file, hit table (the double hit rejected) and modes
    hits = pd.read_csv(out / "hammer_hits.csv")
    assert len(hits) == 6 and hits["accepted"].sum() == 5
    assert hits.loc[~hits["accepted"], "reasons"].tolist() == ["double_hit"]
    assert io.read_frf(out / "hammer.h5").acquisition.n_averages == 5
    modes = pd.read_csv(out / "hammer_modes.csv")
    found = np.sort(modes["fn_hz"].to_numpy())
    for fn, zeta in zip(rec.fn_hz, rec.zeta, strict=True):  # every mode within 0.5 %
        k = np.argmin(np.abs(found - fn))
        assert abs(found[k] / fn - 1) < 5e-3, (fn, found)
        assert abs(modes["zeta_pct"].to_numpy()[np.argsort(modes["fn_hz"])][k]
                   / (100 * zeta) - 1) < 0.10  # the stored tau undone
    # the FRF file: the paper's genuine modes inside the band
    genuine = np.sort(pd.read_csv(out / "genuine_modes.csv")["fn_hz"].to_numpy())
    np.testing.assert_allclose(genuine[:2], paper.TABLE1_FD_HZ["genuine"][:2], rtol=2e-3)


@pytest.fixture(scope="module")
def recorded_study(tmp_path_factory):
    """The fast example study (three configurations, 2-400 Hz) with the genuine beam's
    configuration given as its raw impact records (simulated, UFF-58 time records)."""
    folder = fast_inputs(tmp_path_factory.mktemp("recorded") / "inputs")
    setup = acquisition.TestSetup()
    records = acquisition.simulate_time_records(paper_modes("genuine", setup), setup,
                                                snr_db=50, seed=3, configuration="genuine")
    io.write_time_uff(records, folder / "genuine_hits.uff", binary=True)
    text = (folder / "experiment.toml").read_text()
    text = text.replace('file = "genuine.uff"', 'recording = "genuine_hits.uff"\n'
                        'frf = { exp_window_tau = "auto", pretrigger_s = 0.02 }')
    (folder / "experiment.toml").write_text(text)
    return folder


def test_experiment_with_a_recorded_configuration_runs(recorded_study, tmp_path):
    results = tmp_path / "results"
    assert main(["run", "--experiment", str(recorded_study / "experiment.toml"),
                 "--results", str(results), "--quiet", "--no-figures"]) == 0
    hits = pd.read_csv(results / "hits" / "genuine_hits.csv")
    assert len(hits) == 4 and hits["accepted"].all()  # the simulator's four impacts
    table1 = pd.read_csv(results / "tables" / "table1_modal_parameters.csv")
    genuine = table1[table1["configuration"] == "genuine"]
    np.testing.assert_allclose(genuine["fd_hz"], paper.TABLE1_FD_HZ["genuine"][:3], rtol=1e-3)
    np.testing.assert_allclose(genuine["zeta_pct"], 100 * paper.TABLE1_ZETA["genuine"][:3],
                               rtol=0.05)
    page = (results / "report.html").read_text()
    assert "Impact hits" in page and "genuine: hits found and checked" in page


def test_experiment_frf_settings_are_checked(recorded_study, tmp_path):
    bad = recorded_study / "bad.toml"
    text = (recorded_study / "experiment.toml").read_text()
    bad.write_text(text.replace('exp_window_tau = "auto"', 'exp_window_tua = "auto"'))
    with pytest.raises(DataError, match=r"frf: exp_window_tua: unknown key \(did you mean "
                                        r"'exp_window_tau'\?\)"):
        io.read_experiment(bad)
    bad.write_text(text.replace('recording = "genuine_hits.uff"', 'recording = "gone.tdms"'))
    with pytest.raises(DataError, match="recording .genuine.*gone.tdms"):
        io.read_experiment(bad)
    assert main(["run", "--experiment", str(bad), "--results", str(tmp_path / "r"),
                 "--quiet"]) == 2
    assert not (tmp_path / "r").exists()


def test_is_recording_tells_recordings_from_frf_files(recorded_study):
    assert is_recording(recorded_study / "genuine_hits.uff")
    assert not is_recording(recorded_study / "smaller_tank.uff")
    assert not is_recording(recorded_study / "larger_tank.h5")
