"""Issue 26 part A: raw recordings (UFF-58 time records, TDMS, WAV, CSV, SEP-005) are
read back in SI with the right channel roles, from files written by the independent
generator ``tests/impact_recordings.py`` (pyuff / npTDMS directly, not our writers)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import wavfile

from ema_pipeline.acquisition import from_sep005
from ema_pipeline.data import DataError
from ema_pipeline.io import read_recording
from ema_pipeline.io.channel_sheet import read_channel_sheet
from tests.impact_recordings import STANDARD_GRAVITY, make_recording, write_tdms, write_uff

LBF_N = 4.4482216152605  # hand value: 1 lbf = 0.45359237 kg * 9.80665 m/s^2
INCH_M = 0.0254


@pytest.fixture(scope="module")
def rec():
    return make_recording(7, n_double=1, n_overload=1, n_resp=2)


def _check_same(read, truth, rtol):
    """Signals (force first), sample rate, roles and units of ``read`` match ``truth``."""
    assert read.sample_rate_hz == truth.sample_rate_hz
    assert [c.quantity for c in read.channels] == ["force"] + ["acceleration"] * truth.n_resp
    assert [c.unit for c in read.channels] == ["N"] + ["m/s^2"] * truth.n_resp
    assert read.segment_starts == (0,)
    scale = np.abs(truth.signals).max(axis=1, keepdims=True)
    np.testing.assert_allclose(read.signals / scale, truth.signals / scale, rtol=0, atol=rtol)


@pytest.mark.parametrize("binary", [False, True], ids=["ascii", "binary"])
def test_uff_round_trip(rec, tmp_path, binary):
    read = read_recording(write_uff(rec, tmp_path / "r.uff", binary=binary))
    # ASCII keeps 12 significant digits (pyuff's E20.12), binary is exact
    _check_same(read, rec, 1e-10 if not binary else 0.0)
    assert [c.dof.label() for c in read.channels] == ["1+Z", "1+Z", "2+Z"]
    assert read.channels[0].name == "1+Z force"


def test_tdms_round_trip_and_agrees_with_uff(rec, tmp_path):
    tdms = read_recording(write_tdms(rec, tmp_path / "r.tdms", accel_unit="g"))
    _check_same(tdms, rec, 1e-13)
    assert tdms.channels[0].name == "Hammer force"
    uff = read_recording(write_uff(rec, tmp_path / "r.uff", binary=True))
    np.testing.assert_allclose(tdms.signals, uff.signals, rtol=1e-13, atol=0)


def test_uff_units_from_labels_and_precut_records(rec, tmp_path):
    """Accelerations written in g and force in lbf come back in SI; one record per
    hit and channel gives pre-cut records with their segment starts."""
    path = write_uff(rec, tmp_path / "cut.uff", precut_s=0.5, pretrigger_s=0.01,
                     accel_unit="g", force_unit="lbf")
    read = read_recording(path)
    n = int(0.5 * rec.sample_rate_hz)
    firsts = [int(np.floor((t - 0.01) * rec.sample_rate_hz)) for t in rec.hit_times_s]
    firsts = [k for k in firsts if k + n <= rec.n_samples]
    assert read.segment_starts == tuple(range(0, n * len(firsts), n))
    expected = np.hstack([rec.signals[:, k:k + n] for k in firsts])
    np.testing.assert_allclose(read.signals, expected, rtol=1e-10,
                               atol=1e-10 * np.abs(expected).max())


def test_force_channel_override_and_named_force(tmp_path):
    r = make_recording(3, n_resp=1)
    path = write_tdms(r, tmp_path / "f.tdms", force_name="Kraft")
    assert read_recording(path).channels[0].name == "Kraft"  # found by its unit N
    with pytest.raises(DataError, match=r"f\.tdms.*'Acc 1\+Z' is in acceleration"):
        read_recording(path, force_channel="Acc 1+Z")
    # a second channel in N: the one named *force* is the force, the other left out
    t = np.arange(64) / 1000.0
    csv = tmp_path / "two.csv"
    rows = "\n".join(f"{x},{np.sin(x)},{2 * np.sin(x)},{x}" for x in t)
    csv.write_text(f"time_s,reaction [N],hammer force [N],acc [m/s^2]\n{rows}\n")
    read = read_recording(csv)
    assert [c.name for c in read.channels] == ["hammer force", "acc"]
    read = read_recording(csv, force_channel="ch0")  # positions after the time column
    assert [c.name for c in read.channels] == ["reaction", "acc"]


def test_wav_round_trip_with_scale_and_units(tmp_path):
    fs = 4096
    t = np.arange(2048) / fs
    force = 0.5 * np.sin(2 * np.pi * 30 * t)  # fractions of full scale
    acc = 0.25 * np.cos(2 * np.pi * 70 * t)
    pcm = np.round(np.c_[force, acc] * 32767).astype(np.int16)
    path = tmp_path / "hit.wav"
    wavfile.write(path, fs, pcm)
    read = read_recording(path, scale={"0": 200.0, "ch1": 50.0}, units={"0": "N", "1": "g"})
    assert read.sample_rate_hz == fs
    np.testing.assert_allclose(read.signals[0], pcm[:, 0] / 32768 * 200.0, rtol=1e-15)
    np.testing.assert_allclose(read.signals[1], pcm[:, 1] / 32768 * 50.0 * STANDARD_GRAVITY,
                               rtol=1e-15)
    assert read.channels[0].full_scale == 200.0  # int16 full scale times the factor
    assert read.channels[1].full_scale == pytest.approx(50.0 * STANDARD_GRAVITY)
    # scale changes the result by its factor
    other = read_recording(path, scale={"0": 100.0, "1": 50.0}, units={"0": "N", "1": "g"})
    np.testing.assert_allclose(other.signals[0], read.signals[0] / 2)
    with pytest.raises(DataError, match=r"hit\.wav.*units for channel\(s\) 0, 1"):
        read_recording(path, scale={"0": 1.0, "1": 1.0})
    with pytest.raises(DataError, match=r"hit\.wav.*scale for channel\(s\) 1"):
        read_recording(path, scale={"0": 1.0}, units={"0": "N", "1": "g"})


def test_csv_round_trip_header_units(tmp_path):
    r = make_recording(11, n_resp=2)
    k = slice(0, 3000)
    t = r.time_s[k]
    path = tmp_path / "r.csv"
    header = "# exported by a DAQ\ntime [ms];force [lbf];acc1 [g];acc2 (in/s^2)"
    data = np.c_[t * 1e3, r.force_n[k] / LBF_N, r.response[0, k] / STANDARD_GRAVITY,
                 r.response[1, k] / INCH_M]
    np.savetxt(path, data, delimiter=";", header=header, comments="", fmt="%.10e")
    read = read_recording(path)
    assert read.sample_rate_hz == r.sample_rate_hz
    assert [c.name for c in read.channels] == ["force", "acc1", "acc2"]
    np.testing.assert_allclose(read.signals, r.signals[:, k], rtol=1e-9,
                               atol=1e-9 * np.abs(r.signals).max())


def test_unit_conversion_hand_values(tmp_path):
    """g, mm/s^2, in/s^2, lbf, kN against hand values; unknown units refused."""
    t = np.arange(4) / 100.0
    path = tmp_path / "u.csv"
    path.write_text("time_s,f [kN],a [g],b [mm/s^2],c [in/s^2],d [lbf]\n"
                    + "\n".join(f"{x},1,1,1,1,1" for x in t) + "\n")
    read = read_recording(path, force_channel="f")
    np.testing.assert_allclose(read.signals[:, 0], [1000.0, 9.80665, 1e-3, 0.0254])
    assert [c.name for c in read.channels] == ["f", "a", "b", "c"]  # d (lbf) left out
    read = read_recording(path, force_channel="d")
    assert read.signals[0, 0] == pytest.approx(LBF_N, rel=1e-12)
    # a units override replaces the header's unit
    read = read_recording(path, force_channel="f", units={"a": "m/s^2"})
    assert read.signals[1, 0] == 1.0


def test_sep005_with_the_sdypy_package(rec):
    sep005 = pytest.importorskip("sdypy_sep005.sep005",
                                 reason="sdypy-sep005 not installed (test extra)")
    signals = [{"name": "hammer", "data": rec.force_n / 1000.0, "unit_str": "kN",
                "fs": rec.sample_rate_hz, "quantity": "f"}]
    for c in range(rec.n_resp):
        signals.append({"name": f"acc{c}", "data": rec.response[c] / STANDARD_GRAVITY,
                        "unit_str": "g", "time": list(rec.time_s), "quantity": "a"})
    sep005.assert_sep005(signals)  # the structure is valid SEP-005
    read = from_sep005(signals)
    _check_same(read, rec, 1e-14)
    bad = [dict(signals[0], quantity="a")] + signals[1:]
    with pytest.raises(DataError, match="quantity 'a'"):
        from_sep005(bad)
    with pytest.raises(DataError, match="unknown unit 'furlong'"):
        from_sep005([dict(signals[0], unit_str="furlong")] + signals[1:])


# ------------------------------------------------------------------ bad input
def _csv(path, header, rows):
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _rows(n=32, nan_at=None):
    out = []
    for k in range(n):
        v = "nan" if k == nan_at else f"{np.sin(k / 3):.6f}"
        out.append(f"{k / 1000:.6f},{np.cos(k / 5):.6f},{v}")
    return out


def test_bad_inputs_name_the_file(rec, tmp_path):
    cases = {
        "nan.csv": lambda p: _csv(p, "time_s,force [N],acc [g]", _rows(nan_at=7)),
        "noforce.csv": lambda p: _csv(p, "time_s,acc0 [g],acc [g]", _rows()),
        "unit.csv": lambda p: _csv(p, "time_s,force [N],acc [furlong]", _rows()),
        "nounit.csv": lambda p: _csv(p, "time_s,force [N],acc", _rows()),
        "notime.csv": lambda p: _csv(p, "time,force [N],acc [g]", _rows()),
        "ragged.csv": lambda p: _csv(p, "time_s,force [N],acc [g]", _rows()[:-1] + ["0.031,1"]),
        "gap.csv": lambda p: _csv(p, "time_s,force [N],acc [g]", _rows()[:10] + _rows()[12:]),
        "empty.csv": lambda p: p.write_text(""),
        "header.csv": lambda p: p.write_text("time_s,force [N],acc [g]\n"),
    }
    expected = {"nan.csv": "'acc' has NaN", "noforce.csv": "no force channel",
                "unit.csv": "unknown unit 'furlong'", "nounit.csv": "'acc' has no unit",
                "notime.csv": "time column 'time' has no unit",
                "ragged.csv": "truncated CSV file: its last row has 2 of the header.s 3 columns",
                "gap.csv": "not equally spaced", "empty.csv": "empty file",
                "header.csv": "fewer than 2 data rows"}
    for name, make in cases.items():
        path = tmp_path / name
        make(path)
        with pytest.raises(DataError, match=rf"{path}.*{expected[name]}"):
            read_recording(path)

    uff = write_uff(rec, tmp_path / "full.uff")
    raw = uff.read_bytes()
    cut = tmp_path / "cut.uff"
    cut.write_bytes(raw[: len(raw) * 3 // 4])  # inside the acceleration record's data
    with pytest.raises(DataError, match=r"cut\.uff"):
        read_recording(cut)
    tdms = write_tdms(rec, tmp_path / "full.tdms").read_bytes()
    for frac in (0.5, 0.999, 0.01):
        path = tmp_path / f"cut{frac}.tdms"
        path.write_bytes(tdms[: int(len(tdms) * frac)])
        with pytest.raises(DataError, match=rf"cut{frac}\.tdms"):
            read_recording(path)
    wav = tmp_path / "w.wav"
    wavfile.write(wav, 1000, np.zeros((100, 2), np.int16))
    short = tmp_path / "short.wav"
    short.write_bytes(wav.read_bytes()[:-51])
    with pytest.raises(DataError, match=r"short\.wav"):
        read_recording(short, scale={"0": 1, "1": 1}, units={"0": "N", "1": "g"})
    with pytest.raises(DataError, match=r"x\.xyz.*unknown recording format"):
        read_recording(tmp_path / "x.xyz")


def test_different_sample_rates_refused(rec, tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    path = tmp_path / "rates.tdms"
    with TdmsWriter(str(path)) as w:
        w.write_segment([
            ChannelObject("g", "force", rec.force_n[:100],
                          properties={"unit_string": "N", "wf_increment": 1 / 2048}),
            ChannelObject("g", "acc", rec.response[0, :100],
                          properties={"unit_string": "m/s^2", "wf_increment": 1 / 1024}),
        ])
    with pytest.raises(DataError, match=r"rates\.tdms.*different sample rates"):
        read_recording(path)
    with pytest.raises(DataError, match="different sample rates"):
        from_sep005([{"name": "f", "data": [0.0, 1.0], "unit_str": "N", "fs": 10.0},
                     {"name": "a", "data": [0.0, 1.0], "unit_str": "g", "fs": 20.0}])


def test_one_force_channel_rule_for_files_sheets_and_recordings(tmp_path):
    """The force channel is chosen by one rule
    (:func:`ema_pipeline.acquisition.channels.force_channel_index`) whether the
    channels come from a file, a channel sheet or a Recording made in Python: the
    same choice and the same words (after the name of the source)."""
    from ema_pipeline.data import Channel, Recording
    from ema_pipeline.pipeline.frf import frf_from_recording, impact_channels
    from ema_pipeline.pipeline.roving import read_sheet_recordings

    t = np.arange(64) / 1000.0
    signals = np.vstack([np.sin(t), np.cos(t), t])

    def both(names: tuple[str, str, str], units: tuple[str, str, str]):
        path = tmp_path / f"{'_'.join(names)}.csv"
        header = ",".join(f"{n} [{u}]" for n, u in zip(names, units, strict=True))
        rows = "\n".join(",".join(f"{v:.9g}" for v in (t[k], *signals[:, k]))
                         for k in range(t.size))
        path.write_text(f"time [s],{header}\n{rows}\n")
        quantity = {"N": "force", "m/s^2": "acceleration"}
        rec = Recording(signals, 1000.0, tuple(Channel(n, quantity[u])
                                               for n, u in zip(names, units, strict=True)))
        return path, rec

    def words(exc: pytest.ExceptionInfo) -> str:
        return str(exc.value).split(": ", 1)[1]

    # several force channels: the one named force, first in both
    path, rec = both(("reaction", "Force", "acc"), ("N", "N", "m/s^2"))
    assert read_recording(path).channels[0].name == "Force"
    chosen, _ = impact_channels(rec)
    assert [c.name for c in chosen.channels] == ["Force", "acc"]
    np.testing.assert_array_equal(chosen.signals[0], signals[1])
    # named explicitly (--force-channel, a sheet's force row): that one
    assert read_recording(path, force_channel="reaction").channels[0].name == "reaction"
    assert impact_channels(rec, "REACTION")[0].channels[0].name == "reaction"
    sheet = tmp_path / "channels.csv"
    sheet.write_text("file,channel,role,node,direction,scale,unit\n"
                     f"{path.name},reaction,force,1,-Z,,\n{path.name},acc,response,2,+Z,,\n")
    (read,) = read_sheet_recordings(read_channel_sheet(sheet))
    assert [c.name for c in read.channels] == ["reaction", "acc"]

    # the same words for the same fault
    for names, units, force, expected in (
        (("f1", "f2", "acc"), ("N", "N", "m/s^2"), None,
         "several force channels ('f1', 'f2'); choose one (force_channel / "
         "--force-channel, or the role column of a channel sheet)"),
        (("hammer", "a1", "a2"), ("m/s^2", "m/s^2", "m/s^2"), None,
         "no force channel: none is in a force unit (N, kN, lbf); channels: 'hammer' "
         "(acceleration), 'a1' (acceleration), 'a2' (acceleration)."),
        (("hammer", "acc", "acc2"), ("N", "m/s^2", "m/s^2"), "acc",
         "force channel 'acc' is in acceleration units, not a force (N, kN, lbf)"),
        (("hammer", "acc", "acc2"), ("N", "m/s^2", "m/s^2"), "gauge",
         "force channel 'gauge' names no channel; channels: 'hammer', 'acc', 'acc2'"),
    ):
        path, rec = both(names, units)
        with pytest.raises(DataError) as from_file:
            read_recording(path, force_channel=force)
        with pytest.raises(DataError) as from_python:
            frf_from_recording(rec, force_channel=force)
        assert str(from_file.value).startswith(f"{path}: ")
        assert words(from_file).startswith(expected) and words(from_python) == words(from_file)
        if force is not None:  # a channel sheet whose force row names it
            sheet.write_text("file,channel,role,node,direction,scale,unit\n"
                             f"{path.name},{force},force,1,-Z,,\n"
                             f"{path.name},acc2,response,2,+Z,,\n")
            with pytest.raises(DataError) as from_sheet:
                read_sheet_recordings(read_channel_sheet(sheet))
            assert words(from_sheet) == words(from_file)
