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
def pyfrf_identified(tmp_path_factory: pytest.TempPathFactory, pyfrf_uff: Path) -> Path:
    """pyFRF's recording through ``ema-pipeline frf --out real.h5`` and
    ``identify real.h5 --out id --report`` at the defaults, once per session
    (about 20 s): the folder holding ``real.h5`` and ``id/`` (``real_modes.csv``,
    ``real_report.html``, ``real_result.h5``); tests only read it."""
    root = tmp_path_factory.mktemp("pyfrf")
    h5 = root / "real.h5"
    assert main(["frf", str(pyfrf_uff), "--out", str(h5), "--quiet"]) == 0
    assert main(["identify", str(h5), "--out", str(root / "id"), "--report", "--quiet"]) == 0
    return root


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
def example_study(tmp_path_factory: pytest.TempPathFactory, example_dir: Path) -> Path:
    """The results folder of ``ema-pipeline run`` on the shipped example (default
    options), run once per session: the study, report and browser tests only read
    it (a test that changes results works on a copy)."""
    results = tmp_path_factory.mktemp("study") / "results"
    assert main(["run", "--raw", str(example_dir), "--results", str(results), "--quiet"]) == 0
    return results


#: The sensor nodes of :func:`three_sensor_h5` (the shipped example has two).
THREE_SENSORS = (3, 6, 9)


@pytest.fixture(scope="session")
def three_sensor_h5(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shipped example's larger_tank test simulated with a third accelerometer
    (nodes 3, 6 and 9 of the beam, hammer at 8, seed 4141): the smallest test
    whose identify report has shapes and an AutoMAC (renderers need 3 points)."""
    from ema_pipeline import acquisition, io
    from ema_pipeline.pipeline.simulate import simulate_paper_test

    frf = simulate_paper_test("larger_tank", acquisition.TestSetup(response_nodes=THREE_SENSORS),
                              seed=4141)
    return io.write_frf(frf, tmp_path_factory.mktemp("three") / "three_sensors.h5", "h5")


@pytest.fixture(scope="session")
def example_study_uff_no_figures(tmp_path_factory: pytest.TempPathFactory,
                                 example_dir: Path) -> Path:
    """The results folder of ``ema-pipeline run --no-figures --uff`` on the shipped
    example, run once per session for the tests that read it (no figures in
    test_report.py, the modes' UFF files in test_uff_export_cli.py, and its console
    output, stdout then stderr, kept in ``../console.txt`` for test_cli_first_hour.py)."""
    import io as text_io

    results = tmp_path_factory.mktemp("study_uff") / "results"
    out, err = text_io.StringIO(), text_io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["run", "--raw", str(example_dir), "--results", str(results),
                     "--no-figures", "--uff"])
    (results.parent / "console.txt").write_text(out.getvalue() + err.getvalue())
    assert code == 0, err.getvalue()
    return results


# Background jobs: two checks that run whole programs (mypy, the fuzz corpus of
# issue 15 through the CLI) and the identification of the slow dense hard cases
# (tests/background_job.py) start in child processes as soon as their tests are
# collected. The rest of the suite mostly runs on one core meanwhile, so on the
# 2-core machine they cost little wall time; their tests then wait for them and
# assert on their output exactly as before.

#: ``python -m mypy ema_pipeline`` (settings in pyproject.toml), for test_mypy_clean.
MYPY_COMMAND = [sys.executable, "-m", "mypy", "ema_pipeline"]
#: Worker threads of the background fuzz run (one: it shares the machine with the suite).
FUZZ_WORKERS = 1
_BG_KEY = pytest.StashKey[tuple[subprocess.Popen[bytes], Path, dict[str, tuple[int, ...]]]]()
_MYPY_KEY = pytest.StashKey[subprocess.Popen[str]]()
_FUZZ_KEY = pytest.StashKey[tuple[subprocess.Popen[bytes], Path]]()
_BEAM_KEY = pytest.StashKey[tuple[subprocess.Popen[bytes], Path]]()
_DOCS_KEY = pytest.StashKey[tuple[subprocess.Popen[bytes], Path]]()
_README_KEY = pytest.StashKey[tuple[subprocess.Popen[bytes], Path, list[int]]]()


def beam_report_args(out: Path) -> list[str]:
    """The arguments of the shared run of the measured beam (:func:`beam_report`)."""
    return ["identify", str(REAL_UFF), "--out", str(out), "--report", "--no-figures",
            "--geometry", str(BEAM_GEOMETRY), "--quiet"]


def _start_mypy() -> subprocess.Popen[str]:
    return subprocess.Popen(MYPY_COMMAND, cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True)


def _start_script(prefix: str, script: str, args: Callable[[Path], list[str]],
                  one_worker: bool = True,
                  new_session: bool = False) -> tuple[subprocess.Popen[bytes], Path]:
    """``python tests/SCRIPT ARGS`` in a child process with the repository on
    its path, output to ROOT/runner.log, ROOT a fresh folder (``args(ROOT)``);
    ``one_worker``: with ``EMA_PIPELINE_WORKERS=1``; ``new_session``: in a
    process group of its own (:func:`pytest_unconfigure` stops the whole group)."""
    root = Path(tempfile.mkdtemp(prefix=prefix))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    if one_worker:
        # one process each: the jobs run beside the suite on 2 cores (no worker
        # processes of their own, ema_pipeline.threads)
        env["EMA_PIPELINE_WORKERS"] = "1"
    with open(root / "runner.log", "wb") as log:
        proc = subprocess.Popen(
            [sys.executable, str(REPO / "tests" / script), *args(root)],
            cwd=REPO, env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
            start_new_session=new_session,
        )
    return proc, root


def _start_beam_report() -> tuple[subprocess.Popen[bytes], Path]:
    """``python -m ema_pipeline.cli`` with :func:`beam_report_args` (ROOT/out)."""
    root = Path(tempfile.mkdtemp(prefix="ema-beam-"))
    env = dict(os.environ, EMA_PIPELINE_WORKERS="1", PYTHONPATH=os.pathsep.join(
        filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    with open(root / "runner.log", "wb") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "ema_pipeline.cli", *beam_report_args(root / "out")],
            cwd=REPO, env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
        )
    return proc, root


def _start_docs() -> tuple[subprocess.Popen[bytes], Path]:
    """The documentation site built with ``sphinx -W`` into ROOT/html, its
    stdout and stderr in ROOT/stdout.txt and ROOT/stderr.txt (for test_docs.py;
    sphinx-gallery runs every tutorial and writes their pages to
    ``docs/tutorials/``, which git ignores)."""
    root = Path(tempfile.mkdtemp(prefix="ema-docs-"))
    env = dict(os.environ, MPLBACKEND="Agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=str(REPO), EMA_DOCS_RUN_ALL="1")
    with open(root / "stdout.txt", "wb") as out, open(root / "stderr.txt", "wb") as err:
        proc = subprocess.Popen(
            [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-j", "1", "-q",
             "-b", "html", str(REPO / "docs"), str(root / "html")],
            cwd=REPO, env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
        )
    return proc, root


def _log_tail(root: Path) -> str:
    """The end of a background job's runner.log (for a failure message)."""
    return (root / "runner.log").read_text(errors="replace")[-3000:]


def _start_fuzz() -> tuple[subprocess.Popen[bytes], Path]:
    """``python tests/fuzz_cases.py --save ROOT``: corpus and verdicts in a fresh ROOT."""
    return _start_script("ema-fuzz-", "fuzz_cases.py",
                         lambda root: ["--save", str(root), str(FUZZ_WORKERS)])


def _start_background(jobs: dict[str, tuple[int, ...]]) -> tuple[subprocess.Popen[bytes], Path]:
    """``python tests/background_job.py ROOT KIND:NAME:SEEDS ...``: the cases
    ``jobs`` ("KIND:NAME" -> seeds, in the order the tests read them)
    identified in the background, one file per key in ROOT (one BLAS thread,
    as set at the top of this file)."""
    specs = [f"{key}:{','.join(str(s) for s in seeds)}" for key, seeds in jobs.items()]
    return _start_script("ema-bg-", "background_job.py", lambda root: [str(root), *specs])


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


def _start_readme(indices: list[int]) -> tuple[subprocess.Popen[bytes], Path]:
    """``python tests/readme_blocks.py ROOT INDEX ...``: the bash blocks run in
    the background, one outcome file each in ROOT. The blocks run in the
    suite's environment (as their tests did), so without the jobs'
    ``EMA_PIPELINE_WORKERS=1``; in a process group of its own, so that a run
    stopped early stops the block's commands too."""
    return _start_script("ema-readme-", "readme_blocks.py",
                         lambda root: [str(root), *map(str, indices)], one_worker=False,
                         new_session=True)


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


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start the background jobs whose tests were collected (and not deselected)."""
    if importlib.util.find_spec("mypy") is not None and any(
        item.name == "test_mypy_clean" for item in session.items
    ):
        session.config.stash[_MYPY_KEY] = _start_mypy()
    if any("fuzz" in getattr(item, "fixturenames", ()) for item in session.items):
        session.config.stash[_FUZZ_KEY] = _start_fuzz()
    needed = _background_needed(session.items)
    if needed:
        session.config.stash[_BG_KEY] = (*_start_background(needed), needed)
    if REAL_UFF.is_file() and BEAM_GEOMETRY.is_file() and any(
        "beam_report" in getattr(item, "fixturenames", ()) for item in session.items
    ):
        session.config.stash[_BEAM_KEY] = _start_beam_report()
    if any("docs_site" in getattr(item, "fixturenames", ()) for item in session.items):
        session.config.stash[_DOCS_KEY] = _start_docs()
    readme = _readme_needed(session.items)
    if readme:
        session.config.stash[_README_KEY] = (*_start_readme(readme), readme)


def pytest_unconfigure(config: pytest.Config) -> None:
    """Stop jobs the run did not wait for (stopped early); remove the fuzz folder."""
    mypy = config.stash.get(_MYPY_KEY, None)
    fuzz = config.stash.get(_FUZZ_KEY, None)
    bg = config.stash.get(_BG_KEY, None)
    beam = config.stash.get(_BEAM_KEY, None)
    docs = config.stash.get(_DOCS_KEY, None)
    readme = config.stash.get(_README_KEY, None)
    if readme is not None and readme[0].poll() is None:  # the job and the block it runs
        with contextlib.suppress(ProcessLookupError):
            os.killpg(readme[0].pid, signal.SIGKILL)
    for proc in (mypy, *(job[0] for job in (fuzz, bg, beam, docs, readme) if job)):
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
    for job in (fuzz, bg, beam, docs, readme):
        if job is not None:
            shutil.rmtree(job[1], ignore_errors=True)


@pytest.fixture
def mypy_outcome(request: pytest.FixtureRequest) -> tuple[int, str]:
    """(exit status, output) of :data:`MYPY_COMMAND`, started at collection (or now)."""
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy not installed (it is in the [test] extra)")
    proc = request.config.stash.get(_MYPY_KEY, None)
    if proc is None:
        proc = request.config.stash[_MYPY_KEY] = _start_mypy()
    output, _ = proc.communicate()
    return proc.returncode, output


@pytest.fixture(scope="session")
def fuzz_verdicts(request: pytest.FixtureRequest) -> dict[str, dict]:
    """Case name -> {"group", "bad" (failed checks), "rc", "signal", "stderr"} of the
    whole fuzz corpus (tests/fuzz_cases.py), from its background run."""
    job = request.config.stash.get(_FUZZ_KEY, None)
    if job is None:
        job = request.config.stash[_FUZZ_KEY] = _start_fuzz()
    proc, root = job
    proc.wait()
    assert proc.returncode == 0, f"fuzz corpus run failed:\n{_log_tail(root)}"
    return json.loads((root / "verdicts.json").read_text())


@pytest.fixture(scope="session")
def beam_report(request: pytest.FixtureRequest, real_uff: Path) -> Path:
    """The results folder of ``ema-pipeline identify`` on the measured beam
    with ``--report --no-figures --geometry examples/ufsc-beam-geometry.uff
    --quiet`` (:func:`beam_report_args`): modes CSV, result and report page.
    It runs once per session, in a child process started at collection (about
    10 s on the second core); the tests only read it (test_library_cli,
    test_picks, test_picks_browser, test_report)."""
    if not BEAM_GEOMETRY.is_file():
        pytest.skip(f"the beam's geometry {BEAM_GEOMETRY} is not there")
    job = request.config.stash.get(_BEAM_KEY, None)
    if job is None:
        job = request.config.stash[_BEAM_KEY] = _start_beam_report()
    proc, root = job
    proc.wait()
    assert proc.returncode == 0, f"the measured beam's run failed:\n{_log_tail(root)}"
    return root / "out"


@pytest.fixture(scope="session")
def docs_site(request: pytest.FixtureRequest) -> Path:
    """The folder of the documentation site built with ``sphinx -W`` (about
    45 s, in a child process started at collection): the build must succeed
    with no warning and no error."""
    job = request.config.stash.get(_DOCS_KEY, None)
    if job is None:
        job = request.config.stash[_DOCS_KEY] = _start_docs()
    proc, root = job
    start = time.perf_counter()
    proc.wait(timeout=600)
    waited = time.perf_counter() - start
    stderr = (root / "stderr.txt").read_text(errors="replace")
    assert proc.returncode == 0, (
        f"sphinx -W failed ({waited:.0f} s after its test asked for it):\n{stderr[-6000:]}")
    assert "WARNING" not in stderr and "ERROR" not in stderr, stderr[-6000:]
    return root / "html"


class Background:
    """The cases identified by the background job (``tests/background_job.py``):
    :meth:`outputs` reads the job's file of a case. A case the job has not
    started, the test process claims and identifies itself (all its seeds,
    written like the job's); while the job computes the case a test waits
    for, the test process identifies cases the job has not started (the
    last first), so neither core idles while work is left."""

    def __init__(
        self, job: tuple[subprocess.Popen[bytes], Path, dict[str, tuple[int, ...]]] | None
    ) -> None:
        self.job = job

    def outputs(self, key: str) -> dict[int, dict[str, np.ndarray]]:
        """seed -> {"fn_hz", "zeta", "fn_std_hz", "zeta_std", ...} of ``key``
        ("hard:FAMILY" or "paper:CONFIGURATION"); empty when the job does not
        run it (the test then identifies the case itself)."""
        if self.job is None or key not in self.job[2]:
            return {}
        proc, root, jobs = self.job
        path = output_path(root, key)
        if not path.exists() and claim(root, key):
            write_outputs(root, key, jobs[key])
        while not path.exists():
            if proc.poll() is not None:
                raise AssertionError(
                    f"background identification failed ({key}):\n{_log_tail(root)}")
            if not self._take_one():
                time.sleep(0.1)
        return {d["seed"]: {k: np.asarray(v) for k, v in d.items() if k != "seed"}
                for d in json.loads(path.read_text())}

    def _take_one(self) -> bool:
        """Identify one case that nobody has claimed yet (the job's last
        first); False when there is none."""
        assert self.job is not None
        _, root, jobs = self.job
        for key in reversed(list(jobs)):
            if not output_path(root, key).exists() and claim(root, key):
                write_outputs(root, key, jobs[key])
                return True
        return False


@pytest.fixture(scope="session")
def background(request: pytest.FixtureRequest) -> Background:
    """Cases identified in the background (:class:`Background`)."""
    return Background(request.config.stash.get(_BG_KEY, None))


class ReadmeOutcomes:
    """The bash blocks of README.md and the docs run by the background job
    (``tests/readme_blocks.py``): :meth:`outcome` reads a block's. A block the
    job has not started, the test process claims and runs itself (written
    like the job's); while the job runs the block a test waits for, the test
    process runs blocks the job has not started (the last first)."""

    def __init__(self, job: tuple[subprocess.Popen[bytes], Path, list[int]] | None) -> None:
        self.job = job

    def outcome(self, index: int) -> dict[str, object] | None:
        """{"returncode", "stdout", "stderr", "script"} of block ``index``; None
        when the job does not run it (the test then runs it itself)."""
        if self.job is None or index not in self.job[2]:
            return None
        proc, root, _ = self.job
        path = output_path(root, readme_key(index))
        if not path.exists() and claim(root, readme_key(index)):
            write_outcome(root, index)
        while not path.exists():
            if proc.poll() is not None and not path.exists():
                raise AssertionError(f"readme block job failed (block {index}):\n"
                                     f"{_log_tail(root)}")
            if not self._take_one():
                time.sleep(0.1)
        return json.loads(path.read_text())

    def _take_one(self) -> bool:
        """Run one block that nobody has claimed yet (the job's last first);
        False when there is none."""
        assert self.job is not None
        _, root, indices = self.job
        for index in reversed(indices):
            key = readme_key(index)
            if not output_path(root, key).exists() and claim(root, key):
                write_outcome(root, index)
                return True
        return False


@pytest.fixture(scope="session")
def readme_outcomes(request: pytest.FixtureRequest) -> ReadmeOutcomes:
    """The readme bash blocks run in the background (:class:`ReadmeOutcomes`)."""
    return ReadmeOutcomes(request.config.stash.get(_README_KEY, None))
