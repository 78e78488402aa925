"""Shared fixtures: the measured data set beside the project, and simulated FRFs."""

from __future__ import annotations

import os

# One BLAS thread per process: the suite runs its background jobs (below) and
# the batch tests' workers beside the test process on 2 cores, and BLAS threads
# on top of them oversubscribe the machine (the measured beam's test took 25 s
# instead of 10). It takes effect for the child processes, and for this one
# when numpy is not yet imported (a plugin such as hypothesis may import it
# first); a value given by the caller wins.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import contextlib  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import shutil  # noqa: E402
import signal  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import tqdm  # noqa: E402
from background_job import claim, output_path, write_outputs  # noqa: E402
from readme_blocks import INDEX, readme_key, runs_in_background, write_outcome  # noqa: E402

from ema_pipeline.cli import main  # noqa: E402

# tqdm starts a monitor thread with its first bar, even a disabled one (batch
# --quiet), and keeps it for the life of the process. Any second thread makes
# every later io.check_hdf5 in the test process start a fresh interpreter
# (about 2 s on the loaded 2-core machine) instead of forking (about 0.1 s),
# for every test that runs after the first batch. Bars refresh without it.
tqdm.tqdm.monitor_interval = 0

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
REAL_UFF = SHARED_DATA / "ufsc-beam-hammer.uff"
#: pyFRF's showcase recording (five hits, LGPL-3.0; ../shared/data/README.md).
PYFRF_UFF = SHARED_DATA / "pyfrf-impact.uff"
#: Three of pyuff's public test files, with pyuff's MIT licence.
PYUFF_DIR = SHARED_DATA / "pyuff"
#: The measured beam's geometry (examples/make_ufsc_geometry.py).
BEAM_GEOMETRY = REPO / "examples" / "ufsc-beam-geometry.uff"


@pytest.fixture(scope="session")
def real_uff() -> Path:
    """The measured roving-hammer test in ../shared/data (skipped where absent)."""
    if not REAL_UFF.is_file():
        pytest.skip(f"measured data not available at {REAL_UFF}")
    return REAL_UFF


@pytest.fixture(scope="session")
def beam_identified(real_uff: Path):
    """``identify(io.read_frf(real_uff))``: the library on the measured beam at
    the defaults (the reciprocity rule inside ``identify``), run once per
    session for test_identification.py and test_library_cli.py (about 10 s)."""
    from ema_pipeline import io
    from ema_pipeline.identification import identify

    return identify(io.read_frf(real_uff))


@pytest.fixture(scope="session")
def pyfrf_uff() -> Path:
    """pyFRF's real five-hit recording in ../shared/data (skipped where absent)."""
    if not PYFRF_UFF.is_file():
        pytest.skip(f"pyFRF's recording not available at {PYFRF_UFF}")
    return PYFRF_UFF


@pytest.fixture(scope="session")
def pyfrf_identified(request: pytest.FixtureRequest, pyfrf_uff: Path) -> Path:
    """pyFRF's recording through ``ema-pipeline frf --out real.h5`` and
    ``identify real.h5 --out id --report`` at the defaults, once per run
    (about 20 s; :func:`shared_folder`): the folder holding ``real.h5`` and
    ``id/`` (``real_modes.csv``, ``real_report.html``, ``real_result.h5``);
    tests only read it."""

    def build(root: Path) -> None:
        h5 = root / "real.h5"
        assert main(["frf", str(pyfrf_uff), "--out", str(h5), "--quiet"]) == 0
        assert main(["identify", str(h5), "--out", str(root / "id"), "--report",
                     "--quiet"]) == 0

    return shared_folder(request.config, "pyfrf", build)


@pytest.fixture(scope="session")
def pyuff_dir() -> Path:
    """The folder of pyuff's test files in ../shared/data (skipped where absent)."""
    if not PYUFF_DIR.is_dir():
        pytest.skip(f"pyuff's test files not available at {PYUFF_DIR}")
    return PYUFF_DIR


@pytest.fixture(scope="session")
def example_dir() -> Path:
    return REPO / "raw_frf"


@pytest.fixture(scope="session")
def example_study(request: pytest.FixtureRequest, example_dir: Path) -> Path:
    """The results folder of ``ema-pipeline run`` on the shipped example (default
    options), run once per run (:func:`shared_folder`): the study, report and
    browser tests only read it (a test that changes results works on a copy)."""

    def build(root: Path) -> None:
        assert main(["run", "--raw", str(example_dir), "--results", str(root / "results"),
                     "--quiet"]) == 0

    return shared_folder(request.config, "study", build) / "results"


#: The sensor nodes of :func:`three_sensor_h5` (the shipped example has two).
THREE_SENSORS = (3, 6, 9)


@pytest.fixture(scope="session")
def three_sensor_h5(request: pytest.FixtureRequest) -> Path:
    """The shipped example's larger_tank test simulated with a third accelerometer
    (nodes 3, 6 and 9 of the beam, hammer at 8, seed 4141): the smallest test
    whose identify report has shapes and an AutoMAC (renderers need 3 points)."""

    def build(root: Path) -> None:
        from ema_pipeline import acquisition, io
        from ema_pipeline.pipeline.simulate import simulate_paper_test

        frf = simulate_paper_test("larger_tank",
                                  acquisition.TestSetup(response_nodes=THREE_SENSORS), seed=4141)
        io.write_frf(frf, root / "three_sensors.h5", "h5")

    return shared_folder(request.config, "three", build) / "three_sensors.h5"


@pytest.fixture(scope="session")
def example_study_uff_no_figures(request: pytest.FixtureRequest, example_dir: Path) -> Path:
    """The results folder of ``ema-pipeline run --no-figures --uff`` on the shipped
    example, run once per run (:func:`shared_folder`) for the tests that read it
    (no figures in test_report.py, the modes' UFF files in test_uff_export_cli.py,
    and its console output, stdout then stderr, kept in ``../console.txt`` for
    test_cli_first_hour.py)."""
    import io as text_io

    def build(root: Path) -> None:
        out, err = text_io.StringIO(), text_io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["run", "--raw", str(example_dir), "--results", str(root / "results"),
                         "--no-figures", "--uff"])
        (root / "console.txt").write_text(out.getvalue() + err.getvalue())
        assert code == 0, err.getvalue()

    return shared_folder(request.config, "study_uff", build) / "results"


# Background jobs: two checks that run whole programs (mypy, the fuzz corpus of
# issue 15 through the CLI), the documentation build, the measured beam's
# report, the README's bash blocks and the identification of the slow cases
# (tests/background_job.py) start in child processes as soon as their tests
# are collected, once per run: with pytest-xdist (``-n``), the worker that
# claims a job first starts it and every worker reads its output (the jobs'
# folder is made by the controller and handed to the workers in
# $EMA_SUITE_JOBS; :class:`Job`). Their tests wait for them and assert on
# their output exactly as before.

#: ``python -m mypy ema_pipeline`` (settings in pyproject.toml), for test_mypy_clean.
MYPY_COMMAND = [sys.executable, "-m", "mypy", "ema_pipeline"]
#: Worker threads of the background fuzz run (one: it shares the machine with the suite).
FUZZ_WORKERS = 1
#: The environment variable that hands the run's jobs folder to the xdist workers.
JOBS_ENV = "EMA_SUITE_JOBS"
_ROOT_KEY = pytest.StashKey[Path]()
_OWNER_KEY = pytest.StashKey[bool]()
_BG_JOBS_KEY = pytest.StashKey[dict[str, tuple[int, ...]]]()
_README_INDICES_KEY = pytest.StashKey[list[int]]()

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


def _is_worker(config: pytest.Config) -> bool:
    """Whether this process is a pytest-xdist worker."""
    return hasattr(config, "workerinput")


def pytest_configure(config: pytest.Config) -> None:
    """The run's jobs folder: made by the process that owns the run (the xdist
    controller, or the one process without xdist), read by the workers from
    :data:`JOBS_ENV`."""
    if _is_worker(config) and os.environ.get(JOBS_ENV):
        config.stash[_ROOT_KEY] = Path(os.environ[JOBS_ENV])
        config.stash[_OWNER_KEY] = False
        return
    root = Path(tempfile.mkdtemp(prefix="ema-suite-"))
    (root / "owner").write_text(str(os.getpid()))
    os.environ[JOBS_ENV] = str(root)  # inherited by the xdist workers
    config.stash[_ROOT_KEY] = root
    config.stash[_OWNER_KEY] = True


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
        owner stops at its end (:func:`pytest_unconfigure`)."""
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


def _job(config: pytest.Config, name: str) -> Job:
    return Job(config.stash[_ROOT_KEY], name)


def shared_folder(config: pytest.Config, name: str, build: Callable[[Path], None]) -> Path:
    """ROOT/fixtures/NAME, filled by ``build(folder)`` once per run: the first
    process of the run to ask builds it (the others wait on a lock) and every
    process reads it (a session fixture that the xdist workers share)."""
    import fcntl

    base = config.stash[_ROOT_KEY] / "fixtures"
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


def _env(one_worker: bool) -> dict[str, str]:
    """The environment of a job: the repository on its path; ``one_worker``: with
    ``EMA_PIPELINE_WORKERS=1`` (one process each: the jobs run beside the suite
    on 2 cores, no worker processes of their own, ema_pipeline.threads)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    if one_worker:
        env["EMA_PIPELINE_WORKERS"] = "1"
    return env


def beam_report_args(out: Path) -> list[str]:
    """The arguments of the shared run of the measured beam (:func:`beam_report`)."""
    return ["identify", str(REAL_UFF), "--out", str(out), "--report", "--no-figures",
            "--geometry", str(BEAM_GEOMETRY), "--quiet"]


def _start_mypy(config: pytest.Config) -> Job:
    """:data:`MYPY_COMMAND`, its output in DIR/runner.log."""
    return _job(config, "mypy").start(MYPY_COMMAND)


def _start_beam_report(config: pytest.Config) -> Job:
    """``python -m ema_pipeline.cli`` with :func:`beam_report_args` (DIR/out)."""
    job = _job(config, "beam")
    return job.start([sys.executable, "-m", "ema_pipeline.cli", *beam_report_args(job.dir / "out")],
                     env=_env(one_worker=True))


def _start_docs(config: pytest.Config) -> Job:
    """The documentation site built with ``sphinx -W`` into DIR/html, its
    stdout and stderr in DIR/stdout.txt and DIR/stderr.txt (for test_docs.py;
    sphinx-gallery runs every tutorial and writes their pages to
    ``docs/tutorials/``, which git ignores)."""
    job = _job(config, "docs")
    env = dict(os.environ, MPLBACKEND="Agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=str(REPO), EMA_DOCS_RUN_ALL="1")
    return job.start([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-j", "1",
                      "-q", "-b", "html", str(REPO / "docs"), str(job.dir / "html")],
                     env=env, stdout="stdout.txt", stderr="stderr.txt")


def _start_fuzz(config: pytest.Config) -> Job:
    """``python tests/fuzz_cases.py --save DIR``: corpus and verdicts in DIR."""
    job = _job(config, "fuzz")
    return job.start([sys.executable, str(REPO / "tests" / "fuzz_cases.py"), "--save",
                      str(job.dir), str(FUZZ_WORKERS)], env=_env(one_worker=True))


def _start_background(config: pytest.Config) -> Job:
    """``python tests/background_job.py DIR KIND:NAME:SEEDS ...``: the cases
    of :func:`_background_needed` ("KIND:NAME" -> seeds, in the order the
    tests read them) identified in the background, one file per key in DIR
    (one BLAS thread, as set at the top of this file)."""
    job = _job(config, "bg")
    jobs = config.stash.get(_BG_JOBS_KEY, {})
    specs = [f"{key}:{','.join(str(s) for s in seeds)}" for key, seeds in jobs.items()]
    return job.start([sys.executable, str(REPO / "tests" / "background_job.py"), str(job.dir),
                      *specs], env=_env(one_worker=True))


def _readme_needed(items: list[pytest.Item]) -> list[int]:
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


def _start_readme(config: pytest.Config) -> Job:
    """``python tests/readme_blocks.py DIR INDEX ...``: the bash blocks run in
    the background, one outcome file each in DIR. The blocks run in the
    suite's environment (as their tests did), so without the jobs'
    ``EMA_PIPELINE_WORKERS=1``."""
    job = _job(config, "readme")
    indices = config.stash.get(_README_INDICES_KEY, [])
    return job.start([sys.executable, str(REPO / "tests" / "readme_blocks.py"), str(job.dir),
                      *map(str, indices)], env=_env(one_worker=False))


def _background_needed(items: list[pytest.Item]) -> dict[str, tuple[int, ...]]:
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


#: Test modules that run on the xdist worker of another module (``--dist
#: loadscope``, :func:`pytest_xdist_make_scheduler`): those that share an
#: in-memory session fixture (``beam_identified``), computed once then.
SAME_WORKER = {"tests/test_library_cli.py": "tests/test_identification.py"}


@pytest.hookimpl(optionalhook=True, tryfirst=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    """With pytest-xdist's ``--dist loadscope`` (pyproject.toml): each test module
    on one worker, so that its module-scoped fixtures run once, and the
    modules of :data:`SAME_WORKER` with their partner."""
    if config.getoption("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class ModuleScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return SAME_WORKER.get(module, module)

    return ModuleScheduling(config, log)


def _uses_fixture(items: list[pytest.Item], name: str) -> bool:
    """Whether a collected test uses the fixture ``name``."""
    return any(name in getattr(item, "fixturenames", ()) for item in items)


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start the background jobs whose tests were collected (and not deselected),
    once per run (with xdist every worker collects the same tests; the first
    to claim a job starts it)."""
    config = session.config
    if importlib.util.find_spec("mypy") is not None and any(
        item.name == "test_mypy_clean" for item in session.items
    ):
        _start_mypy(config)
    if _uses_fixture(session.items, "fuzz"):
        _start_fuzz(config)
    needed = _background_needed(session.items)
    if needed:
        config.stash[_BG_JOBS_KEY] = needed
        _start_background(config)
    if REAL_UFF.is_file() and BEAM_GEOMETRY.is_file() and _uses_fixture(session.items,
                                                                          "beam_report"):
        _start_beam_report(config)
    if _uses_fixture(session.items, "docs_site"):
        _start_docs(config)
    readme = _readme_needed(session.items)
    if readme:
        config.stash[_README_INDICES_KEY] = readme
        _start_readme(config)


def pytest_unconfigure(config: pytest.Config) -> None:
    """The run's owner stops the jobs the run did not wait for (stopped early:
    each job's whole process group) and removes the jobs folder."""
    root = config.stash.get(_ROOT_KEY, None)
    if root is None or not config.stash.get(_OWNER_KEY, False):
        return
    for pid_file in root.glob("*/pid"):
        if not (pid_file.parent / "rc").exists():
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.killpg(int(pid_file.read_text()), signal.SIGKILL)
    shutil.rmtree(root, ignore_errors=True)
    if os.environ.get(JOBS_ENV) == str(root):
        del os.environ[JOBS_ENV]


@pytest.fixture
def mypy_outcome(request: pytest.FixtureRequest) -> tuple[int, str]:
    """(exit status, output) of :data:`MYPY_COMMAND`, started at collection (or now)."""
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy not installed (it is in the [test] extra)")
    job = _start_mypy(request.config)
    code = job.wait()
    return code, (job.dir / "runner.log").read_text()


@pytest.fixture(scope="session")
def fuzz_verdicts(request: pytest.FixtureRequest) -> dict[str, dict]:
    """Case name -> {"group", "bad" (failed checks), "rc", "signal", "stderr"} of the
    whole fuzz corpus (tests/fuzz_cases.py), from its background run."""
    job = _start_fuzz(request.config)
    assert job.wait() == 0, f"fuzz corpus run failed:\n{job.log_tail()}"
    return json.loads((job.dir / "verdicts.json").read_text())


@pytest.fixture(scope="session")
def beam_report(request: pytest.FixtureRequest, real_uff: Path) -> Path:
    """The results folder of ``ema-pipeline identify`` on the measured beam
    with ``--report --no-figures --geometry examples/ufsc-beam-geometry.uff
    --quiet`` (:func:`beam_report_args`): modes CSV, result and report page.
    It runs once per run, in a child process started at collection (about
    10 s on the second core); the tests only read it (test_library_cli,
    test_picks, test_picks_browser, test_report)."""
    if not BEAM_GEOMETRY.is_file():
        pytest.skip(f"the beam's geometry {BEAM_GEOMETRY} is not there")
    job = _start_beam_report(request.config)
    assert job.wait() == 0, f"the measured beam's run failed:\n{job.log_tail()}"
    return job.dir / "out"


@pytest.fixture(scope="session")
def docs_site(request: pytest.FixtureRequest) -> Path:
    """The folder of the documentation site built with ``sphinx -W`` (about
    45 s, in a child process started at collection): the build must succeed
    with no warning and no error."""
    job = _start_docs(request.config)
    start = time.perf_counter()
    code = job.wait(timeout_s=600)
    waited = time.perf_counter() - start
    stderr = (job.dir / "stderr.txt").read_text(errors="replace")
    assert code == 0, (
        f"sphinx -W failed ({waited:.0f} s after its test asked for it):\n{stderr[-6000:]}")
    assert "WARNING" not in stderr and "ERROR" not in stderr, stderr[-6000:]
    return job.dir / "html"


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


@pytest.fixture(scope="session")
def background(request: pytest.FixtureRequest) -> Background:
    """Cases identified in the background (:class:`Background`)."""
    jobs = request.config.stash.get(_BG_JOBS_KEY, {})
    job = _job(request.config, "bg")
    return Background(job if jobs and job.started else None, jobs)


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


@pytest.fixture(scope="session")
def readme_outcomes(request: pytest.FixtureRequest) -> ReadmeOutcomes:
    """The readme bash blocks run in the background (:class:`ReadmeOutcomes`)."""
    indices = request.config.stash.get(_README_INDICES_KEY, [])
    job = _job(request.config, "readme")
    return ReadmeOutcomes(job if indices and job.started else None, indices)
