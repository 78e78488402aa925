"""Issue 39: ``ema-pipeline frf`` survives hostile and broken input. Every case ends
with exit 1 or 2 and one line naming the file or option and the problem, or with a
correct FRF; no input changed, no earlier result destroyed or half replaced.

The files are built here (tmp_path) from the independent generator
``tests/impact_recordings.py``."""

from __future__ import annotations

import errno
import hashlib
import os
from pathlib import Path

import numpy as np
import pytest
from impact_recordings import make_recording, write_uff

from ema_pipeline import io
from ema_pipeline.cli import main


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
    real_to_csv = None

    def full(self, *args, **kwargs):
        if self.name.startswith(f".{which}."):
            raise OSError(errno.ENOSPC, "No space left on device", str(self))
        return real_write(self, *args, **kwargs)

    monkeypatch.setattr(Path, name, full)
    if which == "o_hits.csv":  # pandas writes the table itself
        import pandas as pd
        real_to_csv = pd.DataFrame.to_csv

        def full_csv(self, path, *args, **kwargs):
            if Path(path).name.startswith(".o_hits.csv."):
                raise OSError(errno.ENOSPC, "No space left on device", str(path))
            return real_to_csv(self, path, *args, **kwargs)

        monkeypatch.setattr(pd.DataFrame, "to_csv", full_csv)
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
