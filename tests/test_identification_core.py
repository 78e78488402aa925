"""``identify()`` owns its checks and its warnings (:mod:`ema_pipeline.identification.core`).

The library call ``identify(io.read_frf(path), ...)`` and ``ema-pipeline
identify path`` give the same warnings (``IdentificationResult.warnings``,
also issued as ``UserWarning``) and the same refusals, the memory limit
among them; ``identify FILE`` reads, checks and hashes the file once.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any

import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.data import ConfigError
from ema_pipeline.identification import IdentificationOptions, check_input, identify
from tests.cli_runs import count_calls

#: The warnings of the genuine beam (modes 18.1, 112.1, 327.6, 629.6 Hz) with a
#: fixed order (the narrower searches off) and a guess at 60 Hz no mode answers.
WARNED = {"max_order": 40, "band_hz": (5.0, 700.0), "expect_hz": (18.0, 60.0, 112.0),
          "refine": False}
WARNED_ARGS = ["--max-order", "40", "--band", "5", "700", "--expect", "18,60,112"]


def _cli(argv: list[Any], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    """``ema-pipeline ARGV`` in this process: exit status and the lines on stderr."""
    capsys.readouterr()
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err.splitlines()


def test_library_warnings_are_the_ones_the_cli_prints(example_dir: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    """A case that warns twice: ``identify()`` returns the lines the command line
    prints (``warning: ...``), issues each as a UserWarning, and the result
    file keeps them with the result."""
    path = example_dir / "genuine.uff"
    code, err = _cli(["identify", path, "--out", tmp_path, "--quiet", *WARNED_ARGS], capsys)
    assert code == 0
    printed = [line.split("warning: ", 1)[1] for line in err if " warning: " in line]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = identify(io.read_frf(path), **WARNED)  # type: ignore[arg-type]
    assert len(result.warnings) == 2
    assert result.warnings[0].startswith(f"{path}: max_order (--max-order) turned off the "
                                         "narrower searches")
    assert result.warnings[1] == (f"{path}: expected mode(s) not found within 15 % of 60 Hz "
                                  "(reported with empty values)")
    assert list(result.warnings) == printed
    assert [str(w.message) for w in caught if w.category is UserWarning] == printed
    stored = io.read_identification_result(tmp_path / "genuine_result.h5")[1]
    assert stored.warnings == result.warnings
    quiet = identify(io.read_frf(path), band_hz=(5.0, 700.0))
    assert quiet.warnings == ()  # and a case that does not warn says nothing
    stored = io.read_identification_result(_identified(path, tmp_path / "q", capsys))[1]
    assert stored.warnings == ()


def _identified(path: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    assert _cli(["identify", path, "--out", out, "--quiet", "--band", "5", "700"], capsys)[0] == 0
    return out / f"{path.stem}_result.h5"


@pytest.mark.parametrize("name", ["genuine.uff", "larger_tank.h5"])
def test_identify_file_runs_each_check_once(name: str, example_dir: Path, tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """``identify FILE`` (UFF and HDF5): the window override and the
    reciprocity rule are applied once, the data checks (order cap, memory) run
    once, the file is hashed once (the hash reaches the result file from the
    reader's provenance), and the file's readability (a stat) is checked
    once, by the command line before anything is imported (the readers take
    its word, ``read_frf(checked=True)``; the HDF5 check looks at the open
    file's descriptor). One worker, so that every call is this process's
    (with more, the process that reads the file ahead hashes it:
    ``tests/test_read_ahead.py``)."""
    from ema_pipeline import paths
    from ema_pipeline.identification import common
    from ema_pipeline.identification.diagram import resources
    from ema_pipeline.io import files
    from ema_pipeline.pipeline import single  # noqa: F401  (loaded: its names are counted too)

    calls = {name: count_calls(monkeypatch, owner, name) for owner, name in (
        (common, "single_reference"), (resources, "check_identification"),
        (files, "sha256_file"), (paths, "check_readable"),
        (IdentificationOptions, "apply_window"))}
    path = example_dir / name
    code, err = _cli(["identify", path, "--out", tmp_path, "--quiet", "--band", "5", "400",
                      "--exp-window-tau", "2.0", "--workers", "1"], capsys)
    assert code == 0, err
    assert {name: len(c) for name, c in calls.items()} == {
        "apply_window": 1, "single_reference": 1, "check_identification": 1,
        "sha256_file": 1, "check_readable": 1}, calls
    assert [Path(args[0]) for _, args in calls["check_readable"]] == [path]
    stored = io.completed_result_sha256(tmp_path / f"{path.stem}_result.h5")
    assert stored == io.sha256_file(path)


def test_library_refuses_a_diagram_over_the_memory_limit(example_dir: Path, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    """``memory_limit_gb`` below the estimate: the library refuses before any
    work with the command line's message (fixed order and adaptive search);
    the command line passes ``--memory-limit-gb`` in the options and writes no
    environment variable; the library never reads ``$EMA_PIPELINE_MEMORY_LIMIT_GB``."""
    path = example_dir / "genuine.uff"
    frf = io.read_frf(path)
    monkeypatch.delenv("EMA_PIPELINE_MEMORY_LIMIT_GB", raising=False)
    for order in (["--max-order", "40"], []):
        with pytest.raises(ConfigError, match="more than the limit of 9.99e-07 GiB") as refused:
            identify(frf, memory_limit_gb=1e-6,
                     max_order=int(order[1]) if order else None)
        assert str(refused.value).startswith(f"{path}: ")
        code, err = _cli(["identify", path, "--out", tmp_path / "cli", *order,
                          "--memory-limit-gb", "1e-6"], capsys)
        assert code == 2 and err == [f"ema-pipeline identify: error: {refused.value}"]
        assert "EMA_PIPELINE_MEMORY_LIMIT_GB" not in os.environ
    assert not (tmp_path / "cli").exists()  # refused before any output
    with pytest.raises(ConfigError, match="more than the limit"):
        check_input(frf, IdentificationOptions(memory_limit_gb=1e-6))
    monkeypatch.setenv("EMA_PIPELINE_MEMORY_LIMIT_GB", "1e-6")  # read by the command line only
    assert check_input(frf, max_order=40).options.memory_limit_gb == 4.0
    code, err = _cli(["identify", path, "--out", tmp_path / "env", "--max-order", "40"], capsys)
    assert code == 2 and "more than the limit of 9.99e-07 GiB" in err[0]
    monkeypatch.setenv("EMA_PIPELINE_MEMORY_LIMIT_GB", "lots")
    code, err = _cli(["identify", path, "--out", tmp_path / "bad"], capsys)
    assert code == 2 and err == ["ema-pipeline identify: error: "
                                 "EMA_PIPELINE_MEMORY_LIMIT_GB='lots' "
                                 "is not a positive number of GiB"], err
    # the former name: still read, with a note to rename it
    monkeypatch.delenv("EMA_PIPELINE_MEMORY_LIMIT_GB")
    monkeypatch.setenv("EMA_MEMORY_LIMIT_GB", "1e-6")
    code, err = _cli(["identify", path, "--out", tmp_path / "old", "--max-order", "40"], capsys)
    assert code == 2 and "rename it $EMA_PIPELINE_MEMORY_LIMIT_GB" in err[0]
    assert "more than the limit of 9.99e-07 GiB" in err[1]
