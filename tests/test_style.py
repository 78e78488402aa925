"""The code base stays ruff-clean and free of pickle (users open files from others)."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest
from conftest import REPO


def test_ruff_clean():
    ruff = shutil.which("ruff")
    if ruff is None:
        pytest.skip("ruff not installed (it is in the [test] extra)")
    done = subprocess.run([ruff, "check", "ema_pipeline", "tests", "benchmarks"], cwd=REPO,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_no_pickle_anywhere():
    pattern = re.compile(r"^\s*(import (pickle|dill|cloudpickle)|from (pickle|dill|cloudpickle) )",
                         re.MULTILINE)
    offenders = [str(p) for p in (REPO / "ema_pipeline").rglob("*.py")
                 if pattern.search(p.read_text())]
    assert offenders == []
