"""``ema-pipeline frf``'s options and a recorded configuration's ``frf`` table
change the FRFs as they say, on the generator's hits of
``tests/impact_recordings.py`` (every option's test: test_option_inventory.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.data import FRFSet
from tests.cli_runs import run_cli, write_experiment


@pytest.fixture(scope="module")
def hammer_csv(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """Six hits (the second a double hit) from tests/impact_recordings.py as CSV:
    the hammer force (N), the acceleration (m/s^2) and a "load cell" in N that reads
    twice the hammer's force."""
    from tests.impact_recordings import make_recording

    rec = make_recording(5, n_resp=1, n_hits=6, n_double=1, last_hit_short=False)
    time_s = np.arange(rec.force_n.size) / rec.sample_rate_hz
    path = tmp_path_factory.mktemp("hammer") / "hits.csv"
    np.savetxt(path, np.c_[time_s, rec.force_n, rec.response[0], 2 * rec.force_n],
               delimiter=",", header="time [s],hammer force [N],acc [m/s^2],load cell [N]",
               comments="", fmt="%.17g")  # 17 digits: read back exactly
    return path, rec


def _ratio(a: FRFSet, b: FRFSet) -> np.ndarray:
    """a.H / b.H on the lines where b is not zero."""
    assert a.H.shape == b.H.shape
    keep = np.abs(b.H) > 1e-12 * np.abs(b.H).max()
    return a.H[keep] / b.H[keep]


def test_frf_reader_options_and_quiet(hammer_csv: tuple[Path, object], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    """frf --force-channel "load cell" (twice the force) halves H; --scale acc=2
    doubles it; --unit acc=g (the header says m/s^2) multiplies it by g =
    9.80665 m/s^2 (H1 is linear in the response, inverse in the force; 1e-9).
    Without --quiet the console counts the generator's 6 hits, 5 averaged (one
    double hit); --quiet prints nothing."""
    src, rec = hammer_csv

    def frf(name: str, *options: str) -> tuple[FRFSet, str]:
        code, said, _ = run_cli(["frf", src, "--out", tmp_path / f"{name}.h5", *options], capsys)
        assert code == 0
        return io.read_frf(tmp_path / f"{name}.h5"), said

    base, said = frf("base")
    assert rec.hit_times_s.size == 6
    assert "6 hits found, 5 averaged" in said and "rejected: double_hit" in said
    load, quiet = frf("load", "--force-channel", "load cell", "--quiet")
    assert quiet == ""
    np.testing.assert_allclose(_ratio(load, base), 0.5, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf("scale", "--scale", "acc=2", "--quiet")[0], base),
                               2.0, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf("unit", "--unit", "acc=g", "--quiet")[0], base),
                               9.80665, rtol=1e-9)


def test_recorded_configuration_frf_keys(hammer_csv: tuple[Path, object], tmp_path: Path) -> None:
    """Each key of a recorded configuration's ``frf`` table changes the FRFs that
    run uses (:func:`ema_pipeline.pipeline.study.recorded_frf`), as its name says:
    record_length_s = 0.5 gives lines 1 / 0.5 s = 2 Hz apart (default the
    generator's 1 s record: 1 Hz); pretrigger_s = 0.03 moves the default force
    window, the pretrigger + 0.05 s, from 0.06 to 0.08 s (one sample); force_window_s
    and exp_window_tau are stored as given; estimator H2 gives H1 / H2 = the
    coherence (single reference, 1e-9); keep_all averages the double hit too (6
    averages, else 5); force_channel, scale and units as the frf options (0.5, 2,
    g). The same table without a key gives the default result."""
    from ema_pipeline.pipeline.study import recorded_frf

    src, rec = hammer_csv

    def frf(table: str) -> FRFSet:
        path = write_experiment(tmp_path / "exp.toml", f"""
[sensors]
response_nodes = [6]
[[configurations]]
name = "hammer"
recording = "{src}"
frf = {{{table}}}
""")
        exp = io.read_experiment(path)
        return recorded_frf(exp, exp.configurations[0])[0]

    base = frf("")
    acq = base.acquisition
    assert base.df_hz == pytest.approx(1 / rec.record_s) and acq.n_averages == 5
    dt = 1 / rec.sample_rate_hz
    assert acq.force_window_s == pytest.approx(0.01 + 0.05, abs=dt)
    assert frf("record_length_s = 0.5").df_hz == pytest.approx(2.0, rel=1e-12)
    assert frf("pretrigger_s = 0.03").acquisition.force_window_s == pytest.approx(0.08, abs=dt)
    assert frf("force_window_s = 0.1").acquisition.force_window_s == pytest.approx(0.1, abs=dt)
    assert acq.exp_window_tau_s != 0.2
    assert frf("exp_window_tau = 0.2").acquisition.exp_window_tau_s == 0.2
    h2 = frf('estimator = "H2"')
    assert h2.acquisition.estimator == "H2" and acq.estimator == "H1"
    keep = base.coherence[0, 0] > 1e-3
    np.testing.assert_allclose((base.H / h2.H)[0, 0, keep].real, base.coherence[0, 0, keep],
                               rtol=1e-9)
    assert frf("keep_all = true").acquisition.n_averages == 6
    np.testing.assert_allclose(_ratio(frf('force_channel = "load cell"'), base), 0.5, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf("scale = {acc = 2.0}"), base), 2.0, rtol=1e-9)
    np.testing.assert_allclose(_ratio(frf('units = {acc = "g"}'), base), 9.80665, rtol=1e-9)
