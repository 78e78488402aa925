"""The command's start-up in its own process (:mod:`ema_pipeline.cli.startup`):
its imports run with the garbage collector paused and their objects frozen;
a program that calls the command line itself keeps its objects as they are."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from ema_pipeline import io
from ema_pipeline.pipeline.simulate import simulate_paper_test
from tests.paths import REPO

#: Allocates 200 000 tracked objects inside the block and reports: the
#: collections during it, the frozen objects after it, the collector's state.
_BLOCK = textwrap.dedent("""
    import gc, sys
    from ema_pipeline.cli.startup import mark_own_process, start_up_imports
    if sys.argv[1] == "own":
        mark_own_process()
    runs = []
    gc.callbacks.append(lambda phase, info: runs.append(1) if phase == "start" else None)
    with start_up_imports():
        made = [[i] for i in range(200_000)]
        during = len(runs)
    print(during, gc.get_freeze_count() > 100_000, gc.isenabled())
""")


def _block(kind: str) -> list[str]:
    done = subprocess.run([sys.executable, "-c", _BLOCK, kind], capture_output=True, text=True,
                          timeout=120, check=True, cwd=REPO)
    return done.stdout.split()


def test_the_start_up_block_pauses_the_collector_and_freezes_only_in_the_command_process():
    """In the command's own process the block runs no collection and freezes
    what it made; elsewhere (a program calling the command line) the
    collector runs as always (hundreds of collections for the same objects)
    and nothing is frozen."""
    during, frozen, enabled = _block("own")
    assert (int(during), frozen, enabled) == (0, "True", "True")
    during, frozen, enabled = _block("program")
    assert int(during) > 100 and (frozen, enabled) == ("False", "True")


#: Runs ``ema-pipeline identify`` as the script does (cli.run) and prints the
#: frozen objects at the moment the command first submits to its workers.
_IDENTIFY = textwrap.dedent("""
    import gc, json, sys
    import ema_pipeline.runner as runner
    submit = runner.ProcessPool.submit
    seen = []
    def first(self, func, item):
        if not seen and self.workers > 1:
            seen.append(gc.get_freeze_count())
        return submit(self, func, item)
    runner.ProcessPool.submit = first
    from ema_pipeline.cli import run
    sys.argv = ["ema-pipeline", "identify", "--quiet", "--workers", "2", "--out"] + sys.argv[1:]
    status = run()
    print(status, json.dumps(seen))
""")


def test_identify_forks_its_workers_with_the_imports_frozen(tmp_path: Path):
    """``identify`` of two files in its own process: when it forks its
    workers, the objects of its imports (numpy's, scipy's, h5py's, the
    package's) are frozen, by the start-up rather than by the fork (before,
    none: the collector had walked them all as they were made)."""
    if sys.platform == "win32":  # pragma: no cover
        pytest.skip("no fork on Windows")
    files = []
    for seed in (0, 1):
        path = tmp_path / f"genuine_{seed}.uff"
        io.write_frf(simulate_paper_test("genuine", seed=seed), path)
        files.append(str(path))
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_XDIST")}
    done = subprocess.run([sys.executable, "-c", _IDENTIFY, str(tmp_path / "out"), *files],
                          capture_output=True, text=True, timeout=300, cwd=REPO, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    status, seen = done.stdout.strip().split(" ", 1)
    assert status == "0"
    frozen = json.loads(seen)
    if not frozen:
        pytest.skip("the workers were not forked (one core, or forking refused)")
    assert frozen[0] > 10_000
