"""Issue 39: ``ema-pipeline frf`` survives hostile and broken input. Every case ends
with exit 1 or 2 and one line naming the file or option and the problem, or with a
correct FRF; no input changed, no earlier result destroyed or half replaced.

The files are built here (tmp_path) from the independent generator
``tests/impact_recordings.py``."""

from __future__ import annotations

import errno
import hashlib
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from tests.impact_recordings import make_recording, write_uff


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def snapshot(folder: Path) -> dict[str, str]:
    """Every file of ``folder`` (hidden ones too) and its hash."""
    return {p.name: digest(p) for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.fixture(scope="module")
def rec():
    return make_recording(5, n_hits=5, n_resp=1, last_hit_short=False)


def csv_text(rec) -> str:
    rows = "\n".join(f"{a:.9g},{b:.9g},{c:.9g}" for a, b, c in
                     zip(rec.time_s, rec.force_n, rec.response[0], strict=True))
    return f"time_s,force [N],acc [m/s^2]\n{rows}\n"


def run(capsys, *argv: str) -> tuple[int, str]:
    """``ema-pipeline frf ARGV --quiet``: (exit status, stderr)."""
    code = main(["frf", *argv, "--quiet"])
    return code, capsys.readouterr().err.strip()


def one_line(err: str, *names: str) -> None:
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    for name in names:
        assert name in err, (name, err)


# ---------------------------------------------------------------- 1. nothing is lost
@pytest.mark.parametrize("case", ["out_is_input", "hits_table_is_input", "hit_page_is_input",
                                  "through_dotdot", "hard_link", "symlink"])
def test_an_output_that_is_an_input_is_refused_before_any_work(rec, tmp_path, capsys, case):
    uff = write_uff(rec, tmp_path / "rec.uff")
    (tmp_path / "rec_hits.csv").write_text(csv_text(rec))
    (tmp_path / "page_hits.html").write_text(csv_text(rec))
    inputs, out, names = [str(uff)], uff, ("rec.uff",)
    if case == "hits_table_is_input":  # the hit table of rec.h5 is rec_hits.csv
        inputs, out, names = [str(tmp_path / "rec_hits.csv")], tmp_path / "rec.h5", (
            "rec_hits.csv", "hit table")
    elif case == "hit_page_is_input":
        (tmp_path / "page_hits.html").unlink()  # the recording under a second name
        os.link(tmp_path / "rec_hits.csv", tmp_path / "page_hits.html")
        inputs, out, names = [str(tmp_path / "rec_hits.csv")], tmp_path / "page.uff", (
            "page_hits.html", "rec_hits.csv", "hit page")
    elif case == "through_dotdot":
        (tmp_path / "sub").mkdir()
        out = tmp_path / "sub" / ".." / "rec.uff"
    elif case == "hard_link":
        out = tmp_path / "other.uff"
        os.link(uff, out)
        names = ("other.uff", "rec.uff")
    elif case == "symlink":
        out = tmp_path / "link.uff"
        out.symlink_to(uff)
        names = ("link.uff", "rec.uff")
    before = snapshot(tmp_path)
    extra = ["--report"] if case == "hit_page_is_input" else []
    code, err = run(capsys, *inputs, "--out", str(out), *extra)
    assert code == 2
    one_line(err, *names, "would overwrite the input")
    assert snapshot(tmp_path) == before  # nothing written, nothing changed


def test_a_target_that_is_a_folder_is_refused_by_name(rec, tmp_path, capsys):
    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    assert run(capsys, str(src), "--out", str(tmp_path / "o.h5"))[0] == 0
    (tmp_path / "o_hits.html").mkdir()
    before = snapshot(tmp_path)
    code, err = run(capsys, str(src), "--out", str(tmp_path / "o.h5"), "--report",
                    "--estimator", "H2")
    assert code == 2
    one_line(err, "o_hits.html", "is a folder")
    assert snapshot(tmp_path) == before
    (tmp_path / "o_hits.html").rmdir()
    (tmp_path / "o_hits.csv").unlink()
    (tmp_path / "o_hits.csv").mkdir()
    code, err = run(capsys, str(src), "--out", str(tmp_path / "o.h5"))
    assert code == 2
    one_line(err, "o_hits.csv", "is a folder")


def test_io_refuses_a_folder_target_by_name(tmp_path):
    (tmp_path / "t.csv").mkdir()
    with pytest.raises(IsADirectoryError) as caught:
        io.write_text("x", tmp_path / "t.csv")
    assert caught.value.filename == str(tmp_path / "t.csv")
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


@pytest.fixture
def earlier(rec, tmp_path, capsys):
    """An earlier run's three outputs (o.h5, o_hits.csv, o_hits.html) and their hashes."""
    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    assert run(capsys, str(src), "--out", str(tmp_path / "o.h5"), "--report")[0] == 0
    return src, snapshot(tmp_path)


@pytest.mark.parametrize("which", ["o_hits.csv", "o.h5", "o_hits.html"])
def test_a_write_failing_on_a_full_disk_leaves_the_earlier_results(
        earlier, tmp_path, capsys, monkeypatch, which):
    """The disk fills up while one of the three outputs is written: none is replaced
    (a different estimator would change all three), no temporary left, the
    message names the target, not the hidden temporary."""
    src, before = earlier
    real_write = Path.write_bytes if which == "o.h5" else Path.write_text
    name = "write_bytes" if which == "o.h5" else "write_text"

    def full(self, *args, **kwargs):
        if self.name.startswith(f".{which}."):
            raise OSError(errno.ENOSPC, "No space left on device", str(self))
        return real_write(self, *args, **kwargs)

    monkeypatch.setattr(Path, name, full)  # the hit table too (io.csv_text, then write_text)
    code, err = run(capsys, str(src), "--out", str(tmp_path / "o.h5"), "--report",
                    "--estimator", "H2", "--pretrigger-s", "0.02")
    assert code == 1
    one_line(err, f"{tmp_path / which}: cannot write: no space left on device")
    assert ".tmp" not in err
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("links", [True, False], ids=["hard_links", "no_hard_links"])
def test_a_failed_rename_puts_back_the_targets_already_replaced(
        earlier, tmp_path, capsys, monkeypatch, links):
    """The last of the three renames fails: the two replaced before it are put back
    (the old targets kept as hard links, or renamed where the file system has none)."""
    src, before = earlier
    real_replace = os.replace
    if not links:
        def no_link(*args, **kwargs):
            raise PermissionError(errno.EPERM, "Operation not permitted")

        monkeypatch.setattr(os, "link", no_link)

    def failing(a, b, *args, **kwargs):
        if Path(b).name == "o_hits.html" and Path(a).name.endswith(".tmp"):
            raise PermissionError(errno.EACCES, "Permission denied", str(a))
        return real_replace(a, b, *args, **kwargs)

    monkeypatch.setattr(os, "replace", failing)
    code, err = run(capsys, str(src), "--out", str(tmp_path / "o.h5"), "--report",
                    "--estimator", "H2")
    assert code == 1
    one_line(err, f"{tmp_path / 'o_hits.html'}: Permission denied")
    assert snapshot(tmp_path) == before


def test_the_three_outputs_are_replaced_together_when_all_succeed(earlier, tmp_path, capsys):
    src, before = earlier
    assert run(capsys, str(src), "--out", str(tmp_path / "o.h5"), "--report",
               "--estimator", "H2")[0] == 0
    after = snapshot(tmp_path)
    assert sorted(after) == sorted(before)  # no temporary, no backup left
    assert all(after[n] != before[n] for n in ("o.h5", "o_hits.html"))
    h2 = io.read_frf(tmp_path / "o.h5")
    assert h2.acquisition.estimator == "H2"


def test_replace_together_nothing_replaced_when_the_block_fails(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old a")
    with pytest.raises(RuntimeError), io.replace_together():
        io.write_text("new a", a)
        io.write_text("new b", b)
        raise RuntimeError("stop")
    assert a.read_text() == "old a" and not b.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_a_linked_input_is_not_changed_by_the_swap(tmp_path):
    """The old target kept during the swap is a hard link: the file another name
    points to keeps its bytes (the target gets a new inode)."""
    a = tmp_path / "a.txt"
    a.write_text("old")
    os.link(a, tmp_path / "other_name.txt")
    with io.replace_together():
        io.write_text("new", a)
    assert a.read_text() == "new" and (tmp_path / "other_name.txt").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "other_name.txt"]


def test_valid_recording_gives_the_same_frf_as_frf_from_recording(rec, tmp_path, capsys):
    """The grouped writes change nothing in what is written."""
    from ema_pipeline.io.recording import read_recording
    from ema_pipeline.pipeline.frf import frf_from_recording

    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    assert run(capsys, str(src), "--out", str(tmp_path / "o.uff"))[0] == 0
    written = io.read_frf(tmp_path / "o.uff")
    direct = frf_from_recording(read_recording(src)).frf
    np.testing.assert_allclose(written.H, direct.H, rtol=1e-11)


# ---------------------------------------------------------------- 2. UFF ID lines
def id_lines(path: Path) -> list[str]:
    """ID lines 1-5 of every dataset 58 of an ASCII UFF file."""
    lines = path.read_text().splitlines()
    return [ln for k, ln in enumerate(lines) if k >= 2 and lines[k - 2].strip() == "-1"
            and lines[k - 1].strip() == "58" for ln in lines[k:k + 5]]


@pytest.mark.parametrize("cfg_chars", [0, 40, 63])
def test_uff_id_lines_hold_every_field_at_its_longest(tmp_path, cfg_chars):
    """Every field at its longest (17-digit floats in both forms, large counts, the
    longest force window text, a 63-character configuration) stays within 80
    characters and reads back (floats to 10 significant digits)."""
    from ema_pipeline.data import DOF, AcquisitionInfo, FRFSet

    fs = 1.0 / 3.0 * 1e5  # 33333.333333333336: 18 characters as repr
    info = AcquisitionInfo(sample_rate_hz=fs, n_samples=2**40, n_averages=999_999_999,
                           exp_window_tau_s=1.2345678901234567e-05,
                           force_window="rect 1.23457e-05 s", estimator="Hv",
                           response_window="exponential")
    f = np.arange(40) * fs / 2**40
    H = np.ones((12, 1, 40), complex) * (1 + 2j)
    cfg = ("c" * cfg_chars)
    frf = FRFSet(freq_hz=f, H=H, coherence=np.full(H.shape, 0.5),
                 response_dofs=tuple(DOF(100000 + k) for k in range(12)),
                 reference_dofs=(DOF(999999),), acquisition=info, configuration=cfg)
    out = io.write_frf_uff(frf, tmp_path / "long.uff", coherence=True)
    ids = id_lines(out)
    assert len(ids) == 5 * 24
    assert max(len(x.rstrip()) for x in ids) <= 80, max(ids, key=len)
    back = io.read_frf_uff(out)
    a = back.acquisition
    assert a.sample_rate_hz == pytest.approx(fs, rel=1e-9)
    assert a.n_samples == 2**40 and a.n_averages == 999_999_999
    assert a.exp_window_tau_s == pytest.approx(1.2345678901234567e-05, rel=1e-9)
    assert a.force_window == "rect 1.23457e-05 s" and a.estimator == "Hv"
    assert back.configuration == cfg
    np.testing.assert_allclose(back.H, H, rtol=1e-12)


def test_uff_id_lines_short_numbers_are_exact_and_a_too_long_name_is_named(tmp_path):
    from ema_pipeline.data import AcquisitionInfo, DataError, FRFSet

    info = AcquisitionInfo(sample_rate_hz=2048.0, n_samples=4096, n_averages=5,
                           exp_window_tau_s=0.5405591056902891, force_window="rect 0.06 s")
    frf = FRFSet(freq_hz=np.arange(2049) * 0.5, H=np.ones((1, 1, 2049), complex),
                 acquisition=info, configuration="x" * 64)
    with pytest.raises(DataError, match=r"too\.long\.uff: configuration name of 64 characters "
                                        r"is too long for a UFF ID line \(at most 63\)"):
        io.write_frf_uff(frf, tmp_path / "too.long.uff")
    assert not list(tmp_path.iterdir())
    out = io.write_frf_uff(replace_cfg(frf, "genuine"), tmp_path / "ok.uff")
    back = io.read_frf_uff(out).acquisition
    assert back.sample_rate_hz == 2048.0 and back.exp_window_tau_s == 0.5405591057


def replace_cfg(frf, name):
    from dataclasses import replace
    return replace(frf, configuration=name)


def test_uff_output_with_the_automatic_window(tmp_path, capsys):
    """The issue's case: a lightly damped recording, short records, auto tau, .uff out:
    exit 0, and the file holds the same FRF as the .h5 (tau to 10 digits)."""
    rec = make_recording(2, n_double=1, n_overload=1)
    src = write_uff(rec, tmp_path / "rec.uff")
    for out in ("o.uff", "o.h5"):
        assert run(capsys, str(src), "--record-length-s", "0.25", "--out",
                   str(tmp_path / out))[0] == 0
    u, h = io.read_frf(tmp_path / "o.uff"), io.read_frf(tmp_path / "o.h5")
    assert h.acquisition.exp_window_tau_s is not None
    assert u.acquisition.exp_window_tau_s == pytest.approx(h.acquisition.exp_window_tau_s,
                                                           rel=1e-9)
    np.testing.assert_allclose(u.H, h.H, rtol=1e-11, atol=1e-12 * np.abs(h.H).max())
    np.testing.assert_array_equal(u.freq_hz, h.freq_hz)
    assert all(len(x.rstrip()) <= 80 for x in id_lines(tmp_path / "o.uff"))


def test_time_records_keep_their_configuration_within_80_characters(tmp_path):
    from ema_pipeline.data import TimeRecords

    name = "c" * 63
    records = TimeRecords(force=np.eye(2, 64), response=np.ones((2, 1, 64)),
                          sample_rate_hz=1 / 3 * 1e4, trigger_s=0.0123456789012345,
                          configuration=name)
    out = io.write_time_uff(records, tmp_path / "t.uff")
    assert max(len(x.rstrip()) for x in id_lines(out)) <= 80
    back = io.read_time_uff(out)
    assert back.configuration == name
    assert back.trigger_s == pytest.approx(0.0123456789012345, rel=1e-9)
    assert back.sample_rate_hz == pytest.approx(1 / 3 * 1e4, rel=1e-9)


# ---------------------------------------------------------------- 3. ranges
def write_tdms_step(rec, path: Path, step_s: float) -> Path:
    from nptdms import ChannelObject, TdmsWriter

    with TdmsWriter(str(path)) as writer:
        writer.write_segment([
            ChannelObject("g", "Hammer force", rec.force_n,
                          properties={"unit_string": "N", "wf_increment": step_s}),
            ChannelObject("g", "Acc", rec.response[0],
                          properties={"unit_string": "m/s^2", "wf_increment": step_s}),
        ])
    return path


def write_uff_step(rec, path: Path, step_s: float) -> Path:
    import pyuff

    sets = []
    for data, dtype, unit, node in ((rec.force_n, 13, "N", 1), (rec.response[0], 12, "m/s^2", 2)):
        sets.append(pyuff.prepare_58(
            binary=0, id1="x", func_type=1, rsp_node=node, rsp_dir=3, ref_node=1, ref_dir=3,
            ord_data_type=4, num_pts=data.size, abscissa_spacing=1, abscissa_min=0.0,
            abscissa_inc=step_s, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=dtype, ordinate_axis_units_lab=unit,
            orddenom_spec_data_type=0, data=data, x=np.arange(data.size) * step_s))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


@pytest.mark.parametrize("step_s", [1e-300, 1e296, 1e-310, 1e-9, 10.0])
@pytest.mark.parametrize("fmt", ["csv", "tdms", "uff"])
def test_absurd_time_steps_are_refused_naming_file_and_field(rec, tmp_path, capsys, fmt,
                                                            step_s):
    """Time steps whose sample rate is outside 1 Hz - 20 MHz (an FRF file could not
    hold the lines): exit 2 naming the file, the field and the step; no traceback,
    no FRF file that read_frf would then refuse."""
    path = tmp_path / f"rec.{fmt}"
    if fmt == "csv":
        rows = "\n".join(f"{k * step_s!r},{b:.9g},{c:.9g}" for k, (b, c) in
                         enumerate(zip(rec.force_n, rec.response[0], strict=True)))
        path.write_text(f"time_s,force [N],acc [m/s^2]\n{rows}\n")
        field = "time column"
    elif fmt == "tdms":
        write_tdms_step(rec, path, step_s)
        field = "wf_increment"
    else:
        write_uff_step(rec, path, step_s)
        field = "abscissa increment"
    out = tmp_path / "out" / "o.h5"
    code, err = run(capsys, str(path), "--out", str(out))
    assert code == 2
    one_line(err, f"rec.{fmt}", field, f"time step {step_s:g} s")
    assert not out.parent.exists()


def test_sample_rate_limits_hold_at_the_boundary(tmp_path):
    """1 Hz and 20 MHz are accepted (by the reader's check); just outside is not."""
    from ema_pipeline.acquisition.channels import (
        MAX_SAMPLE_RATE_HZ,
        MIN_SAMPLE_RATE_HZ,
        check_sample_rate,
    )
    from ema_pipeline.data import DataError

    assert check_sample_rate(MIN_SAMPLE_RATE_HZ) == 1.0
    assert check_sample_rate(MAX_SAMPLE_RATE_HZ) == 2e7
    for bad in (np.nextafter(1.0, 0.0), np.nextafter(2e7, np.inf), np.nan, np.inf, 0.0, -1.0):
        with pytest.raises(DataError, match="outside 1-2e\\+07 Hz"):
            check_sample_rate(bad, "f.wav", "header")
    # an FRF at the highest rate stays readable: Nyquist = MAX_AXIS_HZ
    assert MAX_SAMPLE_RATE_HZ / 2 == io.MAX_AXIS_HZ


@pytest.mark.parametrize("option, value, expected", [
    ("--record-length-s", "1e16", "record_length_s (--record-length-s) must be a number of "
                                  "seconds in (0, 10000], got 1e+16"),
    ("--record-length-s", "100", "rec.csv: record length (record_length_s / "
                                 "--record-length-s) 100 s is longer than the recording"),
    ("--record-length-s", "0.005", "leaves no samples after the pretrigger (--pretrigger-s)"),
    ("--pretrigger-s", "1e300", "pretrigger_s (--pretrigger-s) must be a number of seconds "
                                "in [0, 1000], got 1e+300"),
    ("--pretrigger-s", "3", "rec.csv: the pretrigger (--pretrigger-s) 3 s is not shorter than "
                            "the records, 1 s (2048 samples"),
    ("--pretrigger-s", "9", "rec.csv: pretrigger (pretrigger_s / --pretrigger-s) 9 s is not "
                            "shorter than the recording"),
    ("--pretrigger-s", "nan", "pretrigger_s (--pretrigger-s) must be a number of seconds in "
                              "[0, 1000], got nan"),
    ("--force-window-s", "0.005", "rec.csv: --force-window-s 0.005 s ends before the force "
                                  "pulse does"),
    ("--force-window-s", "1e-9", "rec.csv: --force-window-s 1e-09 s ends before the force "
                                 "pulse does"),
    ("--force-window-s", "1e300", "force_window_s (--force-window-s) must be a number of "
                                  "seconds in [0, 10000]"),
    ("--exp-window-tau", "1e-5", "rec.csv: exponential window time constant (exp_window_tau "
                                 "/ --exp-window-tau) 1e-05 s is too short for records of 1 s"),
    ("--exp-window-tau", "1e302", "exp_window_tau (--exp-window-tau) must be 'auto', 'none' "
                                  "or a number of seconds in (0, 10000], got 1e+302"),
    ("--exp-window-tau", "-1", "exp_window_tau (--exp-window-tau) must be 'auto', 'none' "
                               "or a number of seconds in (0, 10000], got -1.0"),
    ("--exp-window-tau", "Auto3", "exp_window_tau (--exp-window-tau) must be 'auto', 'none' "
                                  "or a number of seconds in (0, 10000], got 'auto3'"),
    ("--scale", "force=1e308", "rec.csv: channel 'force': scale 1e+308 (x 1 to SI) overflows "
                               "its samples to inf"),
    ("--scale", "acc=-1e307", "rec.csv: channel 'acc': scale -1e+307"),
])
def test_numeric_options_out_of_range_name_the_option(rec, tmp_path, capsys, option, value,
                                                     expected):
    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    out = tmp_path / "out" / "o.h5"
    code, err = run(capsys, str(src), "--out", str(out), option, value)
    assert code == 2
    one_line(err, expected)
    assert not out.parent.exists()


def test_the_force_window_may_end_where_the_pulse_ends(rec, tmp_path, capsys):
    """The limit is the pulse's end: a window that long keeps the FRF of a longer one
    (|H| within 1 % near the modes), one sample shorter is refused."""
    from ema_pipeline.io.recording import read_recording
    from ema_pipeline.pipeline.frf import FRFSettings, frf_from_recording

    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    recording = read_recording(src)
    base = frf_from_recording(recording, FRFSettings(force_window_s=0.05))
    from ema_pipeline.acquisition import hits as hitlib

    found = hitlib.find_hits(recording, 0, pretrigger_s=0.01)
    accepted = [h.index - 1 for h in base.hits if h.accepted]
    end_s = hitlib.pulse_end_s(recording, 0, found, accepted)
    assert 0.01 < end_s < 0.01 + 0.005  # the pretrigger + a pulse of 0.5-2 ms
    tight = frf_from_recording(recording, FRFSettings(force_window_s=end_s))
    f = base.frf.freq_hz
    near = np.zeros(f.size, bool)
    for fn in rec.fn_hz:
        near |= np.abs(f - fn) < 2.0
    ratio = np.abs(tight.frf.H[0, 0, near]) / np.abs(base.frf.H[0, 0, near])
    assert np.all(np.abs(ratio - 1) < 0.01), ratio
    code, err = run(capsys, str(src), "--out", str(tmp_path / "o.h5"), "--force-window-s",
                    f"{end_s - 1 / rec.sample_rate_hz!r}")
    assert code == 2 and "ends before the force pulse does" in err


def test_the_shortest_exponential_window_is_accepted(rec, tmp_path):
    """tau at its lower limit gives a finite FRF; the limit spans the float range."""
    from ema_pipeline import acquisition
    from ema_pipeline.io.recording import read_recording
    from ema_pipeline.pipeline.frf import FRFSettings, frf_from_recording

    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    recording = read_recording(src)
    shortest = acquisition.shortest_exp_window_tau(2048, rec.sample_rate_hz, 20 / 2048)
    out = frf_from_recording(recording, FRFSettings(exp_window_tau=shortest * (1 + 1e-12)))
    assert out.n_samples == 2048 and out.records.trigger_s == 20 / 2048
    assert np.all(np.isfinite(out.frf.H))
    w = acquisition.exponential_window(2048, rec.sample_rate_hz, shortest, 20 / 2048)
    assert w[-1] == pytest.approx(np.finfo(float).eps, rel=1e-9)


# ---------------------------------------------------------------- 4. read whole or refuse
WAV_SETTINGS = {"units": {"0": "N", "1": "m/s^2"}, "scale": {"0": 100.0, "1": 10.0}}


@pytest.fixture(scope="module")
def wav_bytes(rec) -> bytes:
    """A valid int16 WAV of 2 channels (44-byte header, 4-byte frames) and a LIST
    chunk after the data, as recorders write."""
    import io as bytes_io

    from scipy.io import wavfile

    buf = bytes_io.BytesIO()
    pcm = np.vstack([rec.force_n / rec.full_scale[0], rec.response[0] / rec.full_scale[1]]).T
    wavfile.write(buf, 2048, np.round(pcm[:6000] * 32000).astype(np.int16))
    raw = buf.getvalue()
    assert raw[36:40] == b"data" and len(raw) == 44 + 4 * 6000
    return raw + b"LIST\x04\x00\x00\x00INFO"


def test_wav_cut_anywhere_is_refused_as_truncated(wav_bytes, tmp_path):
    """Every cut of the header (0-44 bytes) and cuts in the data, on and off frame
    boundaries: a DataError naming the file and saying truncated (or empty); the
    whole file, and the file without its trailing LIST chunk, read as 6000 frames."""
    from ema_pipeline.data import DataError
    from ema_pipeline.io.recording import read_recording

    path = tmp_path / "cut.wav"
    for n in [*range(0, 45), 46, 44 + 4 * 3000, 44 + 4 * 3000 + 1, 44 + 4 * 6000 - 2]:
        path.write_bytes(wav_bytes[:n])
        with pytest.raises(DataError) as caught:
            read_recording(path, **WAV_SETTINGS)
        msg = str(caught.value)
        assert msg.startswith(f"{path}: "), msg
        assert ("truncated" in msg or "empty file" in msg or "not a WAV" in msg), (n, msg)
        if n >= 44:
            held = n - 44
            assert (f"declares 24000 bytes (6000 frames of 2 channels) but the file holds "
                    f"{held} ({held // 4} frames)") in msg
    for n in (44 + 4 * 6000, len(wav_bytes)):
        path.write_bytes(wav_bytes[:n])
        assert read_recording(path, **WAV_SETTINGS).n_samples == 6000


@pytest.mark.parametrize("offset, fmt, value, expected", [
    (22, "<H", 0, "declares 0 channels (1 to 1024 expected)"),
    (22, "<H", 65535, "declares 65535 channels"),
    (22, "<H", 3, "frames of 4 bytes for 3 channels"),
    (24, "<I", 0, "WAV header: time step inf s (sample rate 0 Hz)"),
    (24, "<I", 4_000_000_000, "sample rate 4e+09 Hz"),
    (32, "<H", 0, "frames of 0 bytes"),
    (40, "<I", 0xFFFFFFFF, "declares 4294967295 bytes (1073741823 frames of 2 channels) but "
                           "the file holds 24012 (6003 frames)"),
    (40, "<I", 24001, "data chunk of 24001 bytes is not a whole number of 4-byte frames"),
    (40, "<I", 0, "holds no samples"),
    (0, "<4s", b"RIFX", "truncated WAV"),  # big-endian sizes: absurd
    (36, "<4s", b"junk", "truncated WAV header: the file ends at byte 24056 before its data"),
])
def test_wav_header_damage_is_refused(wav_bytes, tmp_path, capsys, offset, fmt, value,
                                      expected):
    import struct

    raw = bytearray(wav_bytes)
    raw[offset:offset + struct.calcsize(fmt)] = struct.pack(fmt, value)
    path = tmp_path / "bad.wav"
    path.write_bytes(bytes(raw))
    out = tmp_path / "out" / "o.h5"
    code, err = run(capsys, str(path), "--out", str(out), "--unit", "0=N", "--unit",
                    "1=m/s^2", "--scale", "0=100", "--scale", "1=10")
    assert code == 2
    one_line(err, "bad.wav", expected)
    assert not out.parent.exists()


def time_uff(tmp_path: Path) -> tuple[Path, list[int]]:
    """Simulated impact records (4 hits, force + 2 responses) written by our writer,
    and the offset of each of its 12 dataset-58 records."""
    import re

    from ema_pipeline import acquisition
    from ema_pipeline.pipeline.simulate import paper_modes

    setup = acquisition.TestSetup(n_samples=2048)
    records = acquisition.simulate_time_records(paper_modes("genuine", setup), setup,
                                                snr_db=50, seed=3)
    path = io.write_time_uff(records, tmp_path / "sim.uff")
    starts = [m.start() for m in re.finditer(rb"(?m)^    -1\r?\n    58", path.read_bytes())]
    assert len(starts) == 12
    return path, starts


def test_uff_cut_at_every_record_boundary_is_truncated(tmp_path, capsys):
    """Our time-record file says how many records it holds: cut at any record
    boundary it is refused (before: 2 of 4 hits averaged), also by read_time_uff."""
    from ema_pipeline.data import DataError
    from ema_pipeline.io.recording import read_recording

    path, starts = time_uff(tmp_path)
    raw = path.read_bytes()
    full = read_recording(path)
    assert full.segment_starts == (0, 2048, 4096, 6144)
    cut = tmp_path / "cut.uff"
    for k in range(1, 12):
        cut.write_bytes(raw[:starts[k]])
        with pytest.raises(DataError, match=f"cut.uff: truncated Universal File: {k} of 12 "
                                            "dataset-58 records"):
            read_recording(cut)
        with pytest.raises(DataError, match="truncated"):
            io.read_time_uff(cut)
    cut.write_bytes(raw[:starts[6]])
    code, err = run(capsys, str(cut), "--out", str(tmp_path / "o.h5"))
    assert code == 2
    one_line(err, "cut.uff: truncated Universal File: 6 of 12")


def test_uff_cut_inside_a_record_names_the_file(tmp_path):
    from ema_pipeline.data import DataError
    from ema_pipeline.io.recording import read_recording

    path, starts = time_uff(tmp_path)
    raw = path.read_bytes()
    cut = tmp_path / "mid.uff"
    for n in (starts[3] + 40, starts[3] + 700, (starts[3] + starts[4]) // 2, len(raw) - 9):
        cut.write_bytes(raw[:n])
        with pytest.raises(DataError, match="mid.uff: "):
            read_recording(cut)


def test_complex_time_records_are_refused(tmp_path):
    import pyuff

    from ema_pipeline.data import DataError
    from ema_pipeline.io.recording import read_recording

    sets = [pyuff.prepare_58(
        binary=0, func_type=1, rsp_node=node, rsp_dir=3, ref_node=1, ref_dir=3,
        ord_data_type=6, num_pts=64, abscissa_spacing=1, abscissa_min=0.0,
        abscissa_inc=1e-3, abscissa_spec_data_type=17, ordinate_spec_data_type=dtype,
        ordinate_axis_units_lab=unit, orddenom_spec_data_type=0, data=np.ones(64) * (1 + 1j),
        x=np.arange(64) * 1e-3)
        for node, dtype, unit in ((1, 13, "N"), (2, 12, "m/s^2"))]
    path = tmp_path / "cplx.uff"
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    with pytest.raises(DataError, match=r"cplx.uff: record 1 .* holds complex values "
                                        r"\(ordinate data type 6\)"):
        read_recording(path)


def tdms_with(rec, path: Path, *more) -> Path:
    """A TDMS file of the hammer force and one response, then the channels ``more``."""
    from nptdms import ChannelObject, TdmsWriter

    with TdmsWriter(str(path)) as writer:
        writer.write_segment([
            ChannelObject("g", "Hammer force", rec.force_n,
                          properties={"unit_string": "N", "wf_increment": 1 / 2048}),
            ChannelObject("g", "Acc", rec.response[0],
                          properties={"unit_string": "m/s^2", "wf_increment": 1 / 2048}),
            *more])
    return path


@pytest.mark.parametrize("extra, expected", [
    ("complex", "channel 'g/Z' holds complex numbers (complex128)"),
    ("empty", "channel 'g/Nothing' is empty (no samples)"),
])
def test_tdms_channels_that_are_not_samples_are_refused_by_name(rec, tmp_path, capsys, extra,
                                                               expected):
    from nptdms import ChannelObject

    more = {
        "complex": ChannelObject("g", "Z", rec.response[0] * (1 + 1j),
                                 properties={"unit_string": "m/s^2", "wf_increment": 1 / 2048}),
        "empty": ChannelObject("g", "Nothing", np.array([], dtype=float),
                               properties={"unit_string": "m/s^2"}),
    }[extra]
    path = tdms_with(rec, tmp_path / "x.tdms", more)
    code, err = run(capsys, str(path), "--out", str(tmp_path / "o.h5"))
    assert code == 2
    one_line(err, "x.tdms", expected)


def test_tdms_text_and_boolean_channels_are_skipped_by_name(rec, tmp_path, capsys):
    """A channel of text (a comment) and one of booleans (a digital line) beside the
    numeric ones: the numeric ones are read, the FRF is the one of the file without
    them (equal arrays), and ``frf`` warns once per skipped channel, naming it; a
    file of text alone has no numeric channel and says why."""
    from nptdms import ChannelObject

    from ema_pipeline.data import DataError
    from ema_pipeline.io.recording import read_recording

    note = ChannelObject("g", "Note", np.array(["a", "b"]), properties={})
    flag = ChannelObject("g", "Flag", np.ones(8, dtype=bool), properties={})
    mixed = tdms_with(rec, tmp_path / "x.tdms", note, flag)
    plain = tdms_with(rec, tmp_path / "plain.tdms")
    recording = read_recording(mixed)
    assert [c.name for c in recording.channels] == ["Hammer force", "Acc"]
    assert recording.skipped == (
        f"{mixed}: channel 'g/Note' holds text or objects (object): skipped, not a signal",
        f"{mixed}: channel 'g/Flag' holds booleans (bool): skipped, not a signal")
    code, err = run(capsys, str(mixed), "--out", str(tmp_path / "x.h5"))
    assert code == 0
    assert err.splitlines() == [f"warning: {m}" for m in recording.skipped]
    assert run(capsys, str(plain), "--out", str(tmp_path / "plain.h5")) == (0, "")
    ours, without = io.read_frf(tmp_path / "x.h5"), io.read_frf(tmp_path / "plain.h5")
    np.testing.assert_array_equal(ours.H, without.H)
    assert read_recording(plain).skipped == ()
    folder = tmp_path / "batch"  # batch's summary says it too
    folder.mkdir()
    tdms_with(rec, folder / "x.tdms", note)
    assert main(["batch", str(folder), "--out", str(tmp_path / "out"), "--workers", "1",
                 "--quiet"]) == 0
    summary = (tmp_path / "out" / "summary.csv").read_text()
    assert f"{folder / 'x.tdms'}: channel 'g/Note' holds text or objects (object): skipped" \
        in summary
    text_only = tmp_path / "note.tdms"
    from nptdms import TdmsWriter

    with TdmsWriter(str(text_only)) as writer:
        writer.write_segment([note])
    with pytest.raises(DataError, match=r"note.tdms: no numeric channels in the TDMS file; "
                                        r"channel 'g/Note' holds text"):
        read_recording(text_only)


def test_tdms_time_stamps_are_not_a_signal(rec, tmp_path):
    """A channel of absolute time stamps is left out: the same recording as without."""
    from nptdms import ChannelObject, TdmsWriter

    from ema_pipeline.io.recording import read_recording

    def write(path: Path, stamps: bool) -> Path:
        objs = [ChannelObject("g", "Hammer force", rec.force_n,
                              properties={"unit_string": "N", "wf_increment": 1 / 2048}),
                ChannelObject("g", "Acc", rec.response[0],
                              properties={"unit_string": "m/s^2", "wf_increment": 1 / 2048})]
        if stamps:
            objs.append(ChannelObject("g", "Stamp", np.array(["2024-01-01T00:00"] * 3,
                                                             dtype="datetime64[us]")))
        with TdmsWriter(str(path)) as writer:
            writer.write_segment(objs)
        return path

    a = read_recording(write(tmp_path / "a.tdms", True))
    b = read_recording(write(tmp_path / "b.tdms", False))
    assert [c.name for c in a.channels] == ["Hammer force", "Acc"]
    np.testing.assert_array_equal(a.signals, b.signals)


def test_uff_record_7_with_touching_fields_is_read_by_columns():
    """A 10-digit count fills its I10 field and touches the data type before it: read
    by the fixed columns, not split at blanks (which gave data type 41234567890)."""
    from ema_pipeline.io.uff_format import _header

    dof = ("    1         0    0         0       NONE         1   3       NONE         1"
           "   3")
    axis = "        17    0    0    0                 NONE                 s"
    lines = ["NONE"] * 5 + [dof, "         41234567890         1  0.00000E+00  1.00000E-03"
                            "  0.00000E+00"] + [axis] * 4
    head = _header(lines, "x.uff")
    assert (head["ord_data_type"], head["n_values"], head["dx"]) == (4, 1234567890, 1e-3)


# ---------------------------------------------------------------- 5. two-level clipping
def test_a_square_wave_force_is_an_overload_of_the_force_channel(rec, tmp_path, capsys):
    """A force at +-1000 N (its quantization step is its whole swing, so the flat-top
    rule saw no flat top): every transition is an overload of 'force', none averaged."""
    from ema_pipeline.io.recording import read_recording
    from ema_pipeline.pipeline.frf import FRFSettings, frf_from_recording

    fs = rec.sample_rate_hz
    t = rec.time_s
    square = np.where((t // 0.25) % 2 == 0, 1000.0, -1000.0)
    rows = "\n".join(f"{a:.9g},{b:.9g},{c:.9g}" for a, b, c in
                     zip(t, square, rec.response[0], strict=True))
    src = tmp_path / "square.csv"
    src.write_text(f"time_s,force [N],acc [m/s^2]\n{rows}\n")
    code, err = run(capsys, str(src), "--out", str(tmp_path / "o.h5"))
    assert code == 2
    one_line(err, "square.csv: every hit rejected", "overload ('force')")
    recording = read_recording(src)
    from ema_pipeline.acquisition import hits as hitlib

    found = hitlib.find_hits(recording, 0, pretrigger_s=0.01)
    hits = hitlib.check_hits(recording, 0, found, exp_window=True)
    assert found.n_hits == int(t[-1] // 0.5)  # one per upward step
    assert all("overload" in h.reasons and h.overloaded[:1] == ("force",) for h in hits)
    assert not any(h.accepted for h in hits)
    assert fs == 2048.0
    with pytest.raises(Exception, match="every hit rejected"):
        frf_from_recording(recording, FRFSettings())


def test_two_level_clipping_of_a_response_names_the_channel(rec, tmp_path):
    """One hit whose response sits at +-its peak (a clipped amplifier): that hit is an
    overload of 'acc' and is named so on the hit page; the others are kept."""
    from ema_pipeline.acquisition import hits as hitlib
    from ema_pipeline.io.recording import read_recording
    from ema_pipeline.pipeline.frf import frf_from_recording
    from ema_pipeline.report.hits_page import verdict_text

    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    recording = read_recording(src)
    found = hitlib.find_hits(recording, 0, pretrigger_s=0.01)
    a = int(found.start[2])
    b = a + found.n_samples
    peak = np.abs(recording.signals[1]).max()
    signals = recording.signals.copy()
    signals[1, a:b] = np.where(signals[1, a:b] >= 0, peak, -peak)
    from dataclasses import replace

    clipped = replace(recording, signals=signals)
    out = frf_from_recording(clipped)
    assert [h.accepted for h in out.hits] == [True, True, False, True, True]
    assert out.hits[2].reasons == ("overload",) and out.hits[2].overloaded == ("acc",)
    assert "overload: a channel reaches its full scale or has flat tops (clipped) " \
           "(channel acc)" in verdict_text(out.hits[2])
    assert out.hits[2].reasons_text() == "overload ('acc')"


def test_a_quiet_record_toggling_between_two_codes_is_no_overload(rec):
    """A response that saw nothing of one hit toggles between +-half a quantization
    step in its record (a mid-rise converter, little noise): two values of opposite
    sign too, but far below the channel's peak (the other hits), so not clipping."""
    from ema_pipeline.acquisition import hits as hitlib
    from ema_pipeline.data import Channel, Recording

    lsb = np.abs(rec.response[0]).max() / 2**12
    resp = (np.floor(rec.response[0] / lsb) + 0.5) * lsb  # mid-rise: no zero code
    recording = Recording(np.vstack([rec.force_n, resp]), rec.sample_rate_hz,
                          (Channel("force", "force"), Channel("acc", "acceleration")))
    found = hitlib.find_hits(recording, 0, pretrigger_s=0.01)
    a = int(found.start[2])
    b = a + found.n_samples
    resp[a:b] = np.where(np.arange(b - a) % 3 == 0, 0.5, -0.5) * lsb
    recording = Recording(np.vstack([rec.force_n, resp]), rec.sample_rate_hz,
                          recording.channels)
    hits = hitlib.check_hits(recording, 0, found, exp_window=True)
    assert "overload" not in hits[2].reasons
    assert [h.reasons for k, h in enumerate(hits) if k != 2] == [()] * 4


KILLED_SWAP = """
import os, sys
from pathlib import Path
from ema_pipeline import io
folder = Path(sys.argv[1])
real = os.replace
renames = []
def replace_then_die(a, b, *args, **kwargs):
    real(a, b, *args, **kwargs)
    renames.append(b)
    if len(renames) == 2:  # killed after the second of three renames
        os._exit(9)
os.replace = replace_then_die
with io.replace_together():
    for name in ("a.txt", "b.txt", "c.txt"):
        io.write_text("new " + name, folder / name)
"""


def test_a_swap_killed_between_its_renames_is_put_back_by_the_next(tmp_path):
    """A process killed between the renames of replace_together (a real
    os._exit in a child, after two of three) leaves a mixed set and its journal;
    the next replace_together into that folder puts the old set back first,
    with a warning naming the files, and then writes its own; nothing hidden
    is left."""
    import subprocess
    import sys

    (tmp_path / "a.txt").write_text("old a.txt")
    (tmp_path / "c.txt").write_text("old c.txt")  # b.txt did not exist
    child = subprocess.run([sys.executable, "-c", KILLED_SWAP, str(tmp_path)],
                           capture_output=True, text=True)
    assert child.returncode == 9, child.stderr
    assert (tmp_path / "a.txt").read_text() == "new a.txt"  # mixed: a and b new, c old
    assert (tmp_path / "b.txt").read_text() == "new b.txt"
    assert (tmp_path / "c.txt").read_text() == "old c.txt"
    assert len(list(tmp_path.glob(".ema-replace-*.journal"))) == 1
    with pytest.warns(UserWarning, match=r"interrupted between its renames; put back a\.txt, "
                                         r"b\.txt as they were"):  # c was not reached
        with io.replace_together():
            io.write_text("third d", tmp_path / "d.txt")
    assert (tmp_path / "a.txt").read_text() == "old a.txt"
    assert not (tmp_path / "b.txt").exists()
    assert (tmp_path / "c.txt").read_text() == "old c.txt"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "c.txt", "d.txt"]
    assert io.recover_interrupted(tmp_path) == []  # nothing left to put back


# ---------------------------------------------------------------- 6. loops, read-only, edges
@pytest.mark.parametrize("argv, said", [
    (["frf", "loop.uff", "--out", "o.h5"], "loop.uff: symbolic link loop, expected a recording"),
    (["frf", "rec.csv", "--out", "loop/o.h5"], "loop/o.h5: --out goes through a symbolic link "
                                                "loop"),
    (["identify", "rec.csv", "--out", "loop"], "loop: --out goes through a symbolic link loop"),
    (["run", "--results", "loop"], "loop: --results goes through a symbolic link loop"),
    (["batch", "sub", "--out", "loop/sub"], "loop/sub: --out goes through a symbolic link loop"),
    (["init", "loop", "--example"], "loop: DIR goes through a symbolic link loop"),
], ids=["frf_input", "frf_out", "identify_out", "run_results", "batch_out", "init"])
def test_a_symbolic_link_loop_is_one_line_naming_it(rec, tmp_path, capsys, monkeypatch,
                                                    example_dir, argv, said):
    """A path that loops (``loop -> loop``) as input or output: exit 2 and one line
    naming it, before any work (Path.resolve raised RuntimeError on it)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rec.csv").write_text(csv_text(rec))
    (tmp_path / "sub").mkdir()
    for link in ("loop", "loop.uff"):
        (tmp_path / link).symlink_to(link)
    if argv[0] == "run":
        argv = [*argv, "--raw", str(example_dir)]
    before = snapshot(tmp_path)
    code = main([*argv, "--quiet"] if argv[0] != "init" else argv)
    err = capsys.readouterr().err.strip()
    assert code == 2
    one_line(err, said)
    assert snapshot(tmp_path) == before


def test_an_unwritable_folder_names_the_output_not_its_temporary(rec, tmp_path, capsys,
                                                                 monkeypatch):
    """A folder where no file can be made although it looks writable (sysfs: EACCES
    even for root; a file system turned read-only): the error names the output
    file, not the hidden temporary it failed to make; exit 1, nothing left."""
    import tempfile

    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    real = tempfile.mkstemp

    def refused(suffix=None, prefix=None, dir=None, text=False):
        if Path(dir) == out_dir:
            raise PermissionError(errno.EACCES, "Permission denied",
                                  os.path.join(dir, f"{prefix}x1y2z3{suffix}"))
        return real(suffix, prefix, dir, text)

    monkeypatch.setattr(tempfile, "mkstemp", refused)
    code, err = run(capsys, str(src), "--out", str(out_dir / "o.h5"))
    assert code == 1
    one_line(err, f"{out_dir / 'o_hits.csv'}: Permission denied")
    assert ".tmp" not in err
    assert list(out_dir.iterdir()) == []
    with pytest.raises(PermissionError) as caught:
        io.write_text("x", out_dir / "t.csv")
    assert caught.value.filename == str(out_dir / "t.csv")


def test_a_read_only_file_system_is_refused_before_any_work(rec, tmp_path, capsys,
                                                            monkeypatch):
    """``--out`` on a read-only file system (``os.access`` says no and ``statvfs``
    flags it): exit 2 before any work, naming the output and why."""
    from types import SimpleNamespace

    src = tmp_path / "rec.csv"
    src.write_text(csv_text(rec))
    ro = tmp_path / "ro"
    ro.mkdir()
    real_access, real_statvfs = os.access, os.statvfs
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: (
        False if Path(p) == ro else real_access(p, mode, **kw)))
    monkeypatch.setattr(os, "statvfs", lambda p: (
        SimpleNamespace(f_flag=os.ST_RDONLY) if Path(p) == ro else real_statvfs(p)))
    code, err = run(capsys, str(src), "--out", str(ro / "o.h5"))
    assert code == 2
    one_line(err, f"{ro / 'o.h5'}: --out is not writable ({ro}: read-only file system)")


def test_hits_at_the_first_and_last_samples_have_no_room(rec, tmp_path, capsys):
    """Two hits, at the very first and the very last sample: the first is a pulse cut
    off by the start of the data (no upward crossing), the last has one sample after
    it. The message says that the hits have no room, not that the pretrigger is too
    long; one hit at the end alone says the same, and a pulse at the start alone
    says it is cut off."""
    n = rec.force_n.size
    force = np.zeros(n)
    force[[0, -1]] = 1000.0
    edges = tmp_path / "edges.csv"
    edges.write_text(csv_text(replace(rec, force_n=force)))
    code, err = run(capsys, str(edges), "--out", str(tmp_path / "o.h5"))
    assert code == 2
    one_line(err, f"{edges}: no room for a record: the data end 1 sample(s) after the hit at "
                  f"{(n - 2) / rec.sample_rate_hz:.3g}", "; the force is above the trigger from "
                  "the first sample on (a hit cut off by the start of the data)")
    assert "pretrigger" not in err
    force[0] = 0.0
    edges.write_text(csv_text(replace(rec, force_n=force)))
    code, err = run(capsys, str(edges), "--out", str(tmp_path / "o.h5"))
    assert code == 2
    one_line(err, "edges.csv: no room for a record: the data end 1 sample(s) after the hit")
    assert "first sample" not in err
    force[[0, -1]] = [1000.0, 0.0]
    edges.write_text(csv_text(replace(rec, force_n=force)))
    code, err = run(capsys, str(edges), "--out", str(tmp_path / "o.h5"))
    assert code == 2
    one_line(err, "edges.csv: no hit found: the force never crosses the trigger",
              "above the trigger from the first sample on")
    assert not (tmp_path / "o.h5").exists()
