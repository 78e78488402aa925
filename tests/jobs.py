"""The suite's background jobs and the folders its processes share.

Two checks that run whole programs (mypy, the fuzz corpus through the CLI),
the documentation build, the measured beam's report, the README's bash blocks
and the identification of the slow cases (``tests/background_job.py``) start
in child processes as soon as their tests are collected, once per run
(``tests/conftest.py``, ``pytest_collection_finish``): with pytest-xdist
(``-n``), the worker that claims a job first starts it and every worker reads
its output (the jobs' folder is made by the controller and handed to the
workers in ``$EMA_SUITE_JOBS``; :class:`Job`). Their tests wait for them and
assert on their output. :func:`shared_folder` fills a folder once per run for
the session fixtures that the xdist workers share.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from tests.background_job import claim, output_path, write_outputs
from tests.paths import BEAM_GEOMETRY, REAL_UFF, REPO
from tests.readme_blocks import INDEX, readme_key, runs_in_background, write_outcome

#: ``python -m mypy ema_pipeline`` (settings in pyproject.toml), for test_mypy_clean.
MYPY_COMMAND = [sys.executable, "-m", "mypy", "ema_pipeline"]
#: Worker threads of the background fuzz run (one: it shares the machine with the suite).
FUZZ_WORKERS = 1
#: The environment variable that hands the run's jobs folder to the xdist workers.
JOBS_ENV = "EMA_SUITE_JOBS"
ROOT_KEY = pytest.StashKey[Path]()
OWNER_KEY = pytest.StashKey[bool]()
BG_JOBS_KEY = pytest.StashKey[dict[str, tuple[int, ...]]]()
README_INDICES_KEY = pytest.StashKey[list[int]]()

#: The runner of a job (``python -c RUNNER RC_FILE OWNER_PID COMMAND...``): it runs
#: the command, writes its exit status to RC_FILE (a temporary file renamed)
#: and stops it when the process OWNER_PID (the test run) is gone.
_RUNNER = """
import os, subprocess, sys
rc_path, owner = sys.argv[1], int(sys.argv[2])
proc = subprocess.Popen(sys.argv[3:])
while True:
    try:
        rc = proc.wait(timeout=1.0)
        break
    except subprocess.TimeoutExpired:
        try:
            os.kill(owner, 0)
        except ProcessLookupError:
            proc.kill()
            sys.exit(1)
with open(rc_path + ".tmp", "w") as f:
    f.write(str(rc))
os.replace(rc_path + ".tmp", rc_path)
"""


def _owner_pid(root: Path) -> int:
    return int((root / "owner").read_text())


class Job:
    """A background job of the run, in the folder ROOT/NAME: :meth:`start` runs
    it once per run (the first process to claim it), :meth:`wait` waits for its
    exit status from any process of the run."""

    def __init__(self, root: Path, name: str) -> None:
        self.root = root
        self.dir = root / name

    def start(self, command: list[str], env: dict[str, str] | None = None,
              stdout: str = "runner.log", stderr: str | None = None) -> Job:
        """Start ``command`` (cwd the repository, output to DIR/``stdout`` and
        DIR/``stderr``, stderr to stdout if None) unless a process of the run
        claimed the job first; in a process group of its own, which the run's
        owner stops at its end (``pytest_unconfigure`` in conftest.py)."""
        try:
            self.dir.mkdir()
        except FileExistsError:
            return self
        with contextlib.ExitStack() as stack:
            out = stack.enter_context(open(self.dir / stdout, "wb"))
            err = (subprocess.STDOUT if stderr is None
                   else stack.enter_context(open(self.dir / stderr, "wb")))
            proc = subprocess.Popen(
                [sys.executable, "-c", _RUNNER, str(self.dir / "rc"),
                 str(_owner_pid(self.root)), *command],
                cwd=REPO, env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                start_new_session=True,
            )
        (self.dir / "pid").write_text(str(proc.pid))
        return self

    @property
    def started(self) -> bool:
        return self.dir.is_dir()

    def done(self) -> bool:
        return (self.dir / "rc").exists()

    def wait(self, timeout_s: float | None = None) -> int:
        """The job's exit status, once it has ended."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while not self.done():
            if deadline is not None and time.monotonic() > deadline:
                raise TimeoutError(f"background job {self.dir.name} still running")
            time.sleep(0.1)
        return int((self.dir / "rc").read_text())

    def log_tail(self) -> str:
        """The end of the job's runner.log (for a failure message)."""
        return (self.dir / "runner.log").read_text(errors="replace")[-3000:]


def suite_job(config: pytest.Config, name: str) -> Job:
    """The job ``name`` of the run (in the run's jobs folder, :data:`ROOT_KEY`)."""
    return Job(config.stash[ROOT_KEY], name)


def shared_folder(config: pytest.Config, name: str, build: Callable[[Path], None]) -> Path:
    """ROOT/fixtures/NAME, filled by ``build(folder)`` once per run: the first
    process of the run to ask builds it (the others wait on a lock) and every
    process reads it (a session fixture that the xdist workers share)."""
    base = config.stash[ROOT_KEY] / "fixtures"
    base.mkdir(exist_ok=True)
    folder, done = base / name, base / f"{name}.done"
    with open(base / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            build(folder)
            done.touch()
    return folder


def job_env(one_worker: bool) -> dict[str, str]:
    """The environment of a job: the repository on its path; ``one_worker``: with
    ``EMA_PIPELINE_WORKERS=1`` (one process each: the jobs run beside the suite
    on 2 cores, no worker processes of their own, ema_pipeline.threads)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    if one_worker:
        env["EMA_PIPELINE_WORKERS"] = "1"
    return env


def beam_report_args(out: Path) -> list[str]:
    """The arguments of the shared run of the measured beam (the fixture
    ``beam_report`` of conftest.py)."""
    return ["identify", str(REAL_UFF), "--out", str(out), "--report", "--no-figures",
            "--geometry", str(BEAM_GEOMETRY), "--quiet"]


def start_mypy(config: pytest.Config) -> Job:
    """:data:`MYPY_COMMAND`, its output in DIR/runner.log."""
    return suite_job(config, "mypy").start(MYPY_COMMAND)


def start_beam_report(config: pytest.Config) -> Job:
    """``python -m ema_pipeline.cli`` with :func:`beam_report_args` (DIR/out)."""
    job = suite_job(config, "beam")
    return job.start([sys.executable, "-m", "ema_pipeline.cli", *beam_report_args(job.dir / "out")],
                     env=job_env(one_worker=True))


def start_docs(config: pytest.Config) -> Job:
    """The documentation site built with ``sphinx -W`` into DIR/html, its
    stdout and stderr in DIR/stdout.txt and DIR/stderr.txt (for test_docs.py;
    sphinx-gallery runs every tutorial and writes their pages to
    ``docs/tutorials/``, which git ignores)."""
    job = suite_job(config, "docs")
    env = dict(os.environ, MPLBACKEND="Agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=str(REPO), EMA_DOCS_RUN_ALL="1")
    return job.start([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-j", "1",
                      "-q", "-b", "html", str(REPO / "docs"), str(job.dir / "html")],
                     env=env, stdout="stdout.txt", stderr="stderr.txt")


def start_fuzz(config: pytest.Config) -> Job:
    """``python -m tests.fuzz_cases --save DIR``: corpus and verdicts in DIR."""
    job = suite_job(config, "fuzz")
    return job.start([sys.executable, "-m", "tests.fuzz_cases", "--save",
                      str(job.dir), str(FUZZ_WORKERS)], env=job_env(one_worker=True))


def start_background(config: pytest.Config) -> Job:
    """``python -m tests.background_job DIR KIND:NAME:SEEDS ...``: the cases
    of :func:`background_needed` ("KIND:NAME" -> seeds, in the order the
    tests read them) identified in the background, one file per key in DIR
    (one BLAS thread, as set at the top of ``tests/conftest.py``)."""
    job = suite_job(config, "bg")
    jobs = config.stash.get(BG_JOBS_KEY, {})
    specs = [f"{key}:{','.join(str(s) for s in seeds)}" for key, seeds in jobs.items()]
    return job.start([sys.executable, "-m", "tests.background_job", str(job.dir), *specs],
                     env=job_env(one_worker=True))


def readme_needed(items: list[pytest.Item]) -> list[int]:
    """The indices (readme_blocks.BLOCKS) of the selected readme blocks that
    may run in the background job (readme_blocks.runs_in_background), in
    test order."""
    needed = []
    for item in items:
        if getattr(item, "originalname", None) != "test_readme_block_runs":
            continue
        params = item.callspec.params  # type: ignore[attr-defined]
        if runs_in_background(params["lang"], params["body"], params["directive"]):
            needed.append(INDEX[params["line"]])
    return needed


def start_readme(config: pytest.Config) -> Job:
    """``python -m tests.readme_blocks DIR INDEX ...``: the bash blocks run in
    the background, one outcome file each in DIR. The blocks run in the
    suite's environment (as their tests did), so without the jobs'
    ``EMA_PIPELINE_WORKERS=1``."""
    job = suite_job(config, "readme")
    indices = config.stash.get(README_INDICES_KEY, [])
    return job.start([sys.executable, "-m", "tests.readme_blocks", str(job.dir),
                      *map(str, indices)], env=job_env(one_worker=False))


def background_needed(items: list[pytest.Item]) -> dict[str, tuple[int, ...]]:
    """The entries of the test modules' ``BACKGROUND`` ("KIND:NAME" -> seeds) that
    the selected tests using the ``background`` fixture may read: for a test
    parametrized by ``family`` or ``configuration`` only that NAME's entry, else
    all of its module's."""
    needed: dict[str, tuple[int, ...]] = {}
    for item in items:
        if "background" not in getattr(item, "fixturenames", ()):
            continue
        jobs = getattr(getattr(item, "module", None), "BACKGROUND", {})
        params = getattr(getattr(item, "callspec", None), "params", {})
        name = params.get("family", params.get("configuration"))
        needed.update({k: v for k, v in jobs.items()
                       if name is None or k.split(":", 1)[1] == name})
    return needed


def uses_fixture(items: list[pytest.Item], name: str) -> bool:
    """Whether a collected test uses the fixture ``name``."""
    return any(name in getattr(item, "fixturenames", ()) for item in items)


class Background:
    """The cases identified by the background job (``tests/background_job.py``):
    :meth:`outputs` reads the job's file of a case. A case the job has not
    started, the test process claims and identifies itself (all its seeds,
    written like the job's); while the job computes the case a test waits
    for, the test process identifies cases the job has not started (the
    last first), so neither core idles while work is left."""

    def __init__(self, job: Job | None, jobs: dict[str, tuple[int, ...]]) -> None:
        self.job = job
        self.jobs = jobs

    def outputs(self, key: str) -> dict[int, dict[str, np.ndarray]]:
        """seed -> {"fn_hz", "zeta", "fn_std_hz", "zeta_std", ...} of ``key``
        ("hard:FAMILY" or "paper:CONFIGURATION"); empty when the job does not
        run it (the test then identifies the case itself)."""
        if self.job is None or key not in self.jobs:
            return {}
        root = self.job.dir
        path = output_path(root, key)
        if not path.exists() and claim(root, key):
            write_outputs(root, key, self.jobs[key])
        while not path.exists():
            if self.job.done() and not path.exists():
                raise AssertionError(
                    f"background identification failed ({key}):\n{self.job.log_tail()}")
            if not self._take_one():
                time.sleep(0.1)
        return {d["seed"]: {k: np.asarray(v) for k, v in d.items() if k != "seed"}
                for d in json.loads(path.read_text())}

    def _take_one(self) -> bool:
        """Identify one case that nobody has claimed yet (the job's last
        first); False when there is none."""
        assert self.job is not None
        root = self.job.dir
        for key in reversed(list(self.jobs)):
            if not output_path(root, key).exists() and claim(root, key):
                write_outputs(root, key, self.jobs[key])
                return True
        return False


class ReadmeOutcomes:
    """The bash blocks of README.md and the docs run by the background job
    (``tests/readme_blocks.py``): :meth:`outcome` reads a block's. A block the
    job has not started, the test process claims and runs itself (written
    like the job's); while the job runs the block a test waits for, the test
    process runs blocks the job has not started (the last first)."""

    def __init__(self, job: Job | None, indices: list[int]) -> None:
        self.job = job
        self.indices = indices

    def outcome(self, index: int) -> dict[str, object] | None:
        """{"returncode", "stdout", "stderr", "script"} of block ``index``; None
        when the job does not run it (the test then runs it itself)."""
        if self.job is None or index not in self.indices:
            return None
        root = self.job.dir
        path = output_path(root, readme_key(index))
        if not path.exists() and claim(root, readme_key(index)):
            write_outcome(root, index)
        while not path.exists():
            if self.job.done() and not path.exists():
                raise AssertionError(f"readme block job failed (block {index}):\n"
                                     f"{self.job.log_tail()}")
            if not self._take_one():
                time.sleep(0.1)
        return json.loads(path.read_text())

    def _take_one(self) -> bool:
        """Run one block that nobody has claimed yet (the job's last first);
        False when there is none."""
        assert self.job is not None
        root = self.job.dir
        for index in reversed(self.indices):
            key = readme_key(index)
            if not output_path(root, key).exists() and claim(root, key):
                write_outcome(root, index)
                return True
        return False

