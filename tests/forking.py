"""Tests that fork worker processes: run them where no other thread runs.

A fork is refused while another thread runs in the process
(:func:`ema_pipeline.runner.fork_is_safe`), and the suite's process may hold
threads another test left behind (a dask client's, a server's). Such a test
starts with ``if not here_or_fresh(request): return``: its body runs here
when this process may fork, else the same test runs in a fresh pytest
process, which has no other thread, and must pass there.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading

import pytest

from ema_pipeline import runner
from tests.paths import REPO

#: Set in the fresh pytest process that :func:`here_or_fresh` starts.
FRESH_ENV = "EMA_TEST_RUNNER_FRESH"


def here_or_fresh(request: pytest.FixtureRequest) -> bool:
    """Whether the test's body runs in this process (True), or ran and passed
    in a fresh pytest process (False: the caller returns)."""
    if runner.fork_is_safe():
        return True
    names = [t.name for t in threading.enumerate()]
    if os.environ.get(FRESH_ENV):
        pytest.fail(f"a fresh process cannot fork workers: threads {names}")
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_XDIST")}
    env[FRESH_ENV] = "1"
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "-n", "0", request.node.nodeid], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, (names, proc.stdout[-4000:], proc.stderr[-2000:])
    assert re.search(r"\b1 passed\b", proc.stdout), proc.stdout[-2000:]
    return False
