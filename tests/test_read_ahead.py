"""FRF files read ahead while ``identify`` imports the identification chain
(``pipeline.ahead.read_ahead``): the same FRFs, the same outputs and the same
errors as files read by their workers, and a reader that dies costs nothing
but the time."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.data import MIN_FRF_LINES
from ema_pipeline.pipeline import ahead
from ema_pipeline.pipeline.single import identify_file
from tests.forking import here_or_fresh


def _files(example_dir: Path, folder: Path) -> list[Path]:
    """Two FRF files of the example (UFF and HDF5) and one that is not an FRF
    file, in ``folder``."""
    folder.mkdir()
    paths = [folder / "genuine.uff", folder / "larger_tank.h5", folder / "notes.uff"]
    shutil.copy(example_dir / "genuine.uff", paths[0])
    shutil.copy(example_dir / "larger_tank.h5", paths[1])
    paths[2].write_text("these are not FRFs\n")
    return paths


def _given_frfs(monkeypatch) -> list:
    """The ``frfs`` that ``identify`` gives ``identify_files``, one entry a call."""
    from ema_pipeline.pipeline import many

    given = []
    real = many.identify_files

    def spied(paths, job, workers=1, *, frfs=None):
        given.append(frfs)
        return real(paths, job, workers, frfs=frfs)

    monkeypatch.setattr(many, "identify_files", spied)
    return given


def test_read_ahead_gives_the_frfs_identification_reads(example_dir: Path, tmp_path: Path,
                                                        monkeypatch) -> None:
    """Each file's FRFs as ``io.read_frf`` with ``MIN_FRF_LINES`` gives them
    (arrays, content hash); None for a file that fails to read and for the
    files past ``READ_AHEAD_BYTES``."""
    paths = _files(example_dir, tmp_path / "in")
    got = ahead.read_ahead(paths)
    assert got[2] is None
    for path, frf in zip(paths[:2], got[:2], strict=True):
        want = io.read_frf(path, min_lines=MIN_FRF_LINES)
        assert np.array_equal(frf.H, want.H) and np.array_equal(frf.freq_hz, want.freq_hz)
        assert frf.source.sha256 == want.source.sha256 and frf.quantity == want.quantity
    # a budget of the first file's size: the second waits for its worker
    monkeypatch.setattr(ahead, "READ_AHEAD_BYTES", paths[0].stat().st_size)
    got = ahead.read_ahead(paths)
    assert got[0] is not None and got[1] is None and got[2] is None


def test_identify_reads_ahead_with_the_same_outputs_and_errors(request, example_dir: Path,
                                                               tmp_path: Path, capsys,
                                                               monkeypatch) -> None:
    """``identify`` of two FRF files and a bad one in two workers: the two
    read ahead (the bad one left to its worker), each modes table byte for
    byte that of the file identified alone (read by itself), the bad file's
    error the one it gives when read by its worker."""
    if not here_or_fresh(request):
        return
    paths = _files(example_dir, tmp_path / "in")
    given = _given_frfs(monkeypatch)
    code = main(["identify", *map(str, paths), "--out", str(tmp_path / "out"), "--quiet",
                 "--workers", "2"])
    err = capsys.readouterr().err
    assert code == 2  # an input error: the bad file
    assert [frf is not None for frf in given[0]] == [True, True, False]
    for path in paths[:2]:
        alone = identify_file(path, tmp_path / "alone")
        assert alone.status == "ok"
        assert (tmp_path / "out" / alone.modes_csv.name).read_bytes() == \
            alone.modes_csv.read_bytes()
    bad = identify_file(paths[2], tmp_path / "alone")
    assert bad.status == "failed"
    assert f"ema-pipeline identify: error: {bad.reason}" in err


def _die(paths: tuple[str, ...]) -> tuple[None, ...]:
    """A reader that dies (as one killed, or out of memory)."""
    os._exit(3)


def test_a_reader_that_dies_leaves_the_files_to_their_workers(request, example_dir: Path,
                                                              tmp_path: Path,
                                                              monkeypatch) -> None:
    """The process reading ahead dies: every file is read by its worker,
    and the outputs are those of the files identified alone."""
    if not here_or_fresh(request):
        return
    paths = _files(example_dir, tmp_path / "in")[:2]
    monkeypatch.setattr(ahead, "read_ahead", _die)
    given = _given_frfs(monkeypatch)
    assert main(["identify", *map(str, paths), "--out", str(tmp_path / "out"), "--quiet",
                 "--workers", "2"]) == 0
    assert given == [None]  # nothing read ahead
    for path in paths:
        alone = identify_file(path, tmp_path / "alone")
        assert (tmp_path / "out" / alone.modes_csv.name).read_bytes() == \
            alone.modes_csv.read_bytes()


@pytest.mark.parametrize("n_frfs", [1, 3])
def test_identify_files_refuses_a_count_of_frfs_read_ahead_that_is_not_the_files(
        n_frfs: int, tmp_path: Path) -> None:
    from ema_pipeline.identification import IdentificationOptions
    from ema_pipeline.pipeline.many import FileJob, identify_files

    with pytest.raises(ValueError, match="read ahead for 2 files"):
        list(identify_files([Path("a.uff"), Path("b.uff")],
                            FileJob(tmp_path, IdentificationOptions()), frfs=[None] * n_frfs))
