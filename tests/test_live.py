"""The live test without a browser: the session lock, the replay device's lost
blocks, the hits judged on the stream against ``frf``'s own checks, the
session folder (WAV, channels.csv, hits.toml) and the resume.

A two-point plate test (tests/impact_recordings.py, seeds 7401-7402, its own:
no other test uses them): point 1 in CSV, point 2 in WAV with a bounce 50 ms
after its second hit.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ema_pipeline.cli import main
from ema_pipeline.data import ConfigError
from ema_pipeline.io import read_recording
from ema_pipeline.io.channel_sheet import read_channel_sheet
from ema_pipeline.io.hit_choice import read_hit_choice
from ema_pipeline.io.live_session import SessionFolder
from ema_pipeline.live.device import ReplayDevice
from ema_pipeline.live.engine import LiveTest
from ema_pipeline.pipeline.frf import frf_from_recording
from tests.impact_recordings import PLATE_HIT_TIMES_S, PlateTest, write_plate_test
from tests.test_plate_holdout import PLATE, POINTS, SENSOR

REPO = Path(__file__).resolve().parents[1]
TWO = PlateTest(PLATE, tuple(POINTS[:2]), SENSOR, ("csv", "wav"), peak_n=150.0,
                seed_base=7400, jitter=True, double_hit=(2, PLATE_HIT_TIMES_S[1] + 0.05, 80.0))


def _strike(test: LiveTest, n_samples: int, timeout_s: float = 10.0) -> None:
    """Strike the current point and wait until ``n_samples`` more samples of it
    have streamed."""
    test.strike()
    assert test.stream is not None
    n0, end = test.stream.n, time.monotonic() + timeout_s
    while test.stream.n < n0 + n_samples:
        assert time.monotonic() < end
        time.sleep(0.002)


def _wait_judged(test: LiveTest, timeout_s: float = 20.0) -> None:
    end = time.monotonic() + timeout_s
    while test.snapshot()["streaming"]:
        assert time.monotonic() < end, "the point's stream never ended"
        time.sleep(0.01)


def test_session_lock_refuses_a_second_session_and_takes_over_a_dead_ones(tmp_path):
    first = SessionFolder(tmp_path / "s")
    first.lock()
    with pytest.raises(ConfigError, match=r"a live session \(process \d+\) is running"):
        other = SessionFolder(tmp_path / "s")
        other.folder.joinpath("live.lock").write_text("1\n")  # pid 1 lives: refused
        other.lock()
    first.unlock()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (tmp_path / "s" / "live.lock").write_text(f"{dead}\n")
    again = SessionFolder(tmp_path / "s")
    again.lock()  # the lock of a process gone is taken over
    assert (tmp_path / "s" / "live.lock").read_text().strip() == str(os.getpid())
    again.unlock()
    assert not (tmp_path / "s" / "live.lock").exists()


def test_replay_judges_hits_as_frf_does_rejects_lost_data_and_resumes(tmp_path):
    write_plate_test(tmp_path, TWO)
    sheet = read_channel_sheet(tmp_path / "channels.csv")
    # block 100 of point 1 (50 ms blocks of 102 samples: 4.98-5.03 s) never arrives:
    # inside hit 3's record (4.7 s + 2 s)
    device = ReplayDevice(sheet, speed=math.inf, lose_blocks={(1, 100)})
    test = LiveTest(device, SessionFolder(tmp_path / "session"), identify_points=False)
    test.start()
    try:
        _wait_judged(test)
        one = [(h.number, h.accepted, h.reasons) for h in test.points[0].hits]
        assert one == [(1, True, ()), (2, True, ()), (3, False, ("data_lost",)), (4, True, ())]
        assert [round(h.time_s, 2) for h in test.points[0].hits] == list(PLATE_HIT_TIMES_S)
        assert "102 samples lost" in test.snapshot()["messages"][-1]
        test.next_point()
        _wait_judged(test)
        live = [(h.accepted, h.reasons) for h in test.points[1].hits]
        # frf's own checks on the same file: the same verdicts and reasons
        offline = frf_from_recording(read_recording(
            tmp_path / "p2.wav", scale={"0": 1000.0}, units={"0": "N", "1": "g"})).hits
        assert live == [(h.accepted, h.reasons) for h in offline]
        assert live[1] == (False, ("double_hit",))
        assert all(abs(a.time_s - b.time_s) < 1 / 2048 for a, b in
                   zip(test.points[1].hits, offline, strict=True))
        test.decide("reject", 4)  # by hand, then undone: the average rolled back
        assert not test.points[1].hits[3].accepted
        test.decide("undo")
        assert test.points[1].hits[3].accepted
        test.decide("reject", 1)
    finally:
        test.close()  # point 2 not done: its journal holds its hits and the choice

    session = tmp_path / "session"
    assert read_hit_choice(session / "hits.toml") == {"p1.wav": (1, 2, 4)}
    assert (session / "p1.wav").is_file() and not (session / "p2.wav").exists()
    rec = read_recording(session / "p1.wav", units={"0": "N", "1": "m/s^2"})
    assert rec.signals.shape == (2, 9 * 2048)

    again = LiveTest(ReplayDevice(sheet, speed=math.inf), SessionFolder(session),
                     identify_points=False)
    again.start()  # resumes: point 1 done, point 2 where its journal ends
    try:
        state = again.snapshot()
        assert [p["state"] for p in state["points"]] == ["done", "current"]
        assert [p["accepted"] for p in state["points"]] == [3, 2]
        assert [h["status"] for h in state["hits"]] == ["rejected", "rejected", "accepted",
                                                       "accepted"]
        again.next_point()
    finally:
        again.close()
    assert read_hit_choice(session / "hits.toml") == {"p1.wav": (1, 2, 4), "p2.wav": (3, 4)}
    assert main(["frf", "--channels", str(session / "channels.csv"), "--hits",
                 str(session / "hits.toml"), "--out", str(tmp_path / "t.h5"), "--quiet"]) == 0


def test_live_command_errors_are_one_line(tmp_path, capsys):
    pytest.importorskip("starlette", reason="ema-pipeline live needs the live extra")
    pytest.importorskip("uvicorn", reason="ema-pipeline live needs the live extra")
    assert main(["live", "--session", str(tmp_path / "s"), "--replay", "--no-browser"]) == 2
    assert "--replay streams the recordings of a channel sheet" in capsys.readouterr().err
    assert main(["live", "--session", str(tmp_path / "s"), "--simulate", "plate", "--speed",
                 "0", "--no-browser"]) == 2
    assert "--speed must be > 0" in capsys.readouterr().err


def test_simulated_strikes_are_judged_with_the_double_hit_rejected(tmp_path):
    from ema_pipeline.live.simulate import SimulateDevice, builtin_model

    device = SimulateDevice(builtin_model("plate"), speed=20.0, seed=1, double_hits={2})
    test = LiveTest(device, SessionFolder(tmp_path / "s"), identify_points=False)
    test.start()
    try:
        for _ in range(3):
            _strike(test, 3000)
        end = time.monotonic() + 10
        while len(test.points[0].hits) < 2:
            assert time.monotonic() < end, test.points[0].hits
            time.sleep(0.01)
        hits = test.points[0].hits
        assert [(h.accepted, h.reasons) for h in hits[:2]] == [(True, ()), (False, ("double_hit",))]
        assert np.all(np.diff([h.time_s for h in hits]) > 1.0)
    finally:
        test.close()


def _strikes(args: list[str], n: int = 3) -> list:
    """``live ARGS`` parsed as the command does, its device struck ``n`` times
    1.5 to 1.6 s apart (at 20 x real time: records of 1 s, never reaching the
    next hit); the hits judged but the last."""
    from ema_pipeline.cli.live_command import hammer_options
    from ema_pipeline.cli.parser import build_parser
    from ema_pipeline.live.app import make_device

    ns = build_parser().parse_args(["live", *args, "--speed", "20", "--no-browser"])
    device, _ = make_device(None, replay=False, speed=ns.speed, simulate=ns.simulate,
                            seed=ns.seed, hammer=hammer_options(ns))
    test = LiveTest(device, SessionFolder(ns.session), identify_points=False)
    test.start()
    try:
        for _ in range(n):
            _strike(test, 3072)
        end = time.monotonic() + 10
        while len(test.points[0].hits) < n - 1:
            assert time.monotonic() < end
            time.sleep(0.01)
        return list(test.points[0].hits)[:n - 1]  # the last may be judged or not yet
    finally:
        test.close()


def test_simulate_options_clip_scatter_noise_seed_double_hit(tmp_path):
    base = ["--simulate", "plate", "--seed", "4"]
    plain = _strikes([*base, "--session", str(tmp_path / "a")])
    again = _strikes([*base, "--session", str(tmp_path / "b")])
    # --seed: the same hits (peaks within the noise, 1e-4 of 150 N, where the strike lands)
    np.testing.assert_allclose([h.peak_n for h in plain], [h.peak_n for h in again], rtol=1e-3)
    peaks = np.array([h.peak_n for h in plain])
    assert np.all(np.abs(peaks / 150 - 1) <= 0.1 + 1e-3) and np.ptp(peaks) > 1.0  # U(0.9, 1.1)
    flat = _strikes([*base, "--force-scatter", "0", "--session", str(tmp_path / "c")])
    np.testing.assert_allclose([h.peak_n for h in flat], 150.0, rtol=2e-3)
    other = _strikes([*base[:-1], "5", "--session", str(tmp_path / "d")])
    assert np.max(np.abs(np.array([h.peak_n for h in other]) / peaks - 1)) > 0.01
    clipped = _strikes([*base, "--clip-n", "60", "--session", str(tmp_path / "e")])
    assert all(h.reasons == ("overload",) and abs(h.peak_n - 60) < 0.1 for h in clipped), [
        (h.reasons, h.peak_n, h.time_s) for h in clipped]
    double = _strikes([*base, "--double-hit", "1", "--session", str(tmp_path / "f")])
    assert [h.reasons for h in double] == [("double_hit",), (), ()][:len(double)]
    # --noise: the force's noise between the hits (robust std) as a share of 150 N
    quiet = SessionFolder(tmp_path / "a").read_raw(1, 2)[0]
    loud_hits = _strikes([*base, "--noise", "1e-2", "--session", str(tmp_path / "g")])
    loud = SessionFolder(tmp_path / "g").read_raw(1, 2)[0]
    assert len(loud_hits) >= 2
    for data, share in ((quiet, 1e-4), (loud, 1e-2)):
        d = np.diff(data[:500].astype(float))
        assert abs(1.4826 * np.median(np.abs(d)) / np.sqrt(2) / (share * 150) - 1) < 0.15


def test_live_host_option_listens_there_only(tmp_path):
    pytest.importorskip("starlette", reason="ema-pipeline live needs the live extra")
    pytest.importorskip("uvicorn", reason="ema-pipeline live needs the live extra")
    import urllib.error
    import urllib.request

    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen([sys.executable, "-m", "ema_pipeline", "live", "--simulate",
                             "plate", "--session", str(tmp_path / "s"), "--host", "127.0.0.2",
                             "--port", "0", "--no-browser"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        url = line.split("open ", 1)[1].strip()
        assert url.startswith("http://127.0.0.2:"), line
        with urllib.request.urlopen(url, timeout=10) as page:
            assert b"data-live" in page.read()
        with pytest.raises(urllib.error.URLError):  # not on 127.0.0.1
            urllib.request.urlopen(url.replace("127.0.0.2", "127.0.0.1"), timeout=10)
    finally:
        proc.kill()
        proc.wait()


class _FakeSoundDevice:
    """A stand-in for the ``sounddevice`` module: its InputStream calls back with
    blocks of a hit every 1.5 s on input 1 (0.5 of full scale) and a decaying
    40 Hz response on input 0, the third block with an input overflow."""

    class InputStream:
        def __init__(self, *, device, channels, samplerate, blocksize, dtype, callback):
            self.args = (device, channels, samplerate, blocksize, dtype)
            self.callback, self.n = callback, 0
            _FakeSoundDevice.streams.append(self)

        def start(self):
            fs, n = self.args[2], self.args[3]
            t = np.arange(int(4.5 * fs)) / fs
            data = np.zeros((t.size, self.args[1]), dtype=np.float32)
            for t0 in (0.5, 2.0, 3.5):
                on = (t >= t0) & (t < t0 + 2e-3)
                data[on, 1] += 0.5 * np.sin(np.pi * (t[on] - t0) / 2e-3)
                after = t >= t0
                data[after, 0] += 0.2 * np.exp(-3 * (t[after] - t0)) * np.sin(
                    2 * np.pi * 40 * (t[after] - t0))
            status = type("Status", (), {"input_overflow": False})
            for k in range(0, t.size - n + 1, n):
                flag = type("Status", (), {"input_overflow": k // n == 2})
                self.callback(data[k:k + n], n, None, flag if k // n == 2 else status)

        def stop(self):
            pass

        def close(self):
            pass

    streams: list = []


def test_sounddevice_backend_at_its_interface(tmp_path, monkeypatch):
    """``--device sounddevice:CARD`` with a stand-in module: the sheet's inputs,
    scales and units, the blocks judged as hits, an overflow reported as lost."""
    from ema_pipeline.cli.parser import build_parser
    from ema_pipeline.live.app import make_device

    monkeypatch.setitem(sys.modules, "sounddevice", _FakeSoundDevice)
    (tmp_path / "sheet.csv").write_text("file,channel,role,node,direction,scale,unit\n"
                                        "p1,1,force,1,-Z,500,N\np1,0,response,100,+Z,2,g\n"
                                        "p2,1,force,2,-Z,500,N\np2,0,response,100,+Z,2,g\n")
    ns = build_parser().parse_args(["live", "--channels", str(tmp_path / "sheet.csv"),
                                    "--session", str(tmp_path / "s"), "--device",
                                    "sounddevice:Scarlett", "--sample-rate", "4096",
                                    "--no-browser"])
    device, title = make_device(ns.channels, replay=False, daq=ns.device,
                                sample_rate_hz=ns.sample_rate)
    assert title == "sound card Scarlett"
    assert [p.label for p in device.plan] == ["1-Z", "2-Z"]
    assert [c.quantity for c in device.plan[0].channels] == ["force", "acceleration"]
    test = LiveTest(device, SessionFolder(ns.session), identify_points=False)
    test.start()
    try:
        end = time.monotonic() + 10
        while len(test.points[0].hits) < 2:
            assert time.monotonic() < end, test.points[0].hits
            time.sleep(0.01)
        stream = _FakeSoundDevice.streams[-1]
        assert stream.args == ("Scarlett", 2, 4096.0, 205, "float32")
        hits = test.points[0].hits
        # 205 samples (0.05 s) counted lost before block 3 (0.1 s): the hits after it later
        assert [round(h.time_s, 2) for h in hits] == [0.55, 2.05]
        np.testing.assert_allclose([h.peak_n for h in hits], 250.0, rtol=1e-3)  # 0.5 x 500 N
        assert "205 samples lost" in test.snapshot()["messages"][-1]
        assert test.stream is not None
        peak = np.abs(test.stream.data[1]).max()  # 0.2 x 2 g, in m/s^2
        assert abs(peak / (0.4 * 9.80665) - 1) < 0.05
    finally:
        test.close()


def test_simulate_a_universal_file_of_modes(tmp_path):
    """``--simulate FILE.uff``: the modes ``identify --uff`` writes, struck at their
    DOFs; the running FRF's peaks at the file's frequencies."""
    from ema_pipeline.data import DOF
    from ema_pipeline.io import write_modes_uff
    from ema_pipeline.live.app import make_device

    x = np.linspace(0.05, 0.95, 6)
    fn, zeta = np.array([30.0, 75.0, 140.0]), np.array([0.01, 0.015, 0.01])
    shapes = np.sin(np.pi * np.outer(x, [1, 2, 3]))  # a pinned beam's first three
    nodes = list(range(1, 7))
    write_modes_uff(tmp_path / "beam.uff", fn, zeta, shapes, [DOF(n, 3) for n in nodes],
                    node_coordinates={n: (float(v), 0.0, 0.0)
                                      for n, v in zip(nodes, x, strict=True)},
                    trace_lines=[nodes])
    device, title = make_device(None, replay=False, simulate=str(tmp_path / "beam.uff"),
                                speed=20.0, seed=2)
    assert title == "simulated beam.uff" and device.sample_rate_hz == 1024.0
    assert [p.label for p in device.plan] == [f"{n}-Z" for n in nodes]
    assert device.model.geometry.n_nodes == 6  # the file's own geometry
    test = LiveTest(device, SessionFolder(tmp_path / "s"), identify_points=False)
    test.start()
    try:
        test.next_point()  # point 2
        for _ in range(3):
            _strike(test, 1536)
        end = time.monotonic() + 10
        while test.stream.frf is None:
            assert time.monotonic() < end
            time.sleep(0.01)
        frf = test.stream.frf
        mag = np.abs(frf.H[0, 0])
        for f in fn:  # a peak within 2 lines of each mode
            band = (frf.freq_hz > 0.8 * f) & (frf.freq_hz < 1.2 * f)
            assert abs(frf.freq_hz[band][np.argmax(mag[band])] - f) <= 2 * frf.freq_hz[1]
    finally:
        test.close()


def test_simulate_the_result_file_of_identify(tmp_path, example_dir):
    """``--simulate RESULT.h5``: the modes ``identify`` identified (the example's
    genuine beam, four modes), struck at their DOFs; the model is those modes."""
    from ema_pipeline import io
    from ema_pipeline.cli import main
    from ema_pipeline.live.app import make_device

    assert main(["identify", str(example_dir / "genuine.uff"), "--out", str(tmp_path),
                 "--quiet"]) == 0
    _, result = io.read_identification_result(tmp_path / "genuine_result.h5")
    device, title = make_device(None, replay=False, speed=20.0, seed=2,
                                simulate=str(tmp_path / "genuine_result.h5"))
    assert title == "simulated genuine_result.h5"
    np.testing.assert_array_equal(device.model.fn_hz, result.modes.fn_hz)
    np.testing.assert_array_equal(device.model.zeta, result.modes.zeta)
    assert len(device.plan) == len(result.modes.dofs)
