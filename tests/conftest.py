"""Shared fixtures and the run's hooks: the measured data set beside the project,
the shipped example's study, simulated FRFs, and the background jobs started
at collection (:mod:`tests.jobs`)."""

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
import shutil  # noqa: E402
import signal  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402
import tqdm  # noqa: E402

from ema_pipeline.cli import main  # noqa: E402
from tests.cli_runs import write_two_mode_uff  # noqa: E402
from tests.jobs import (  # noqa: E402
    BG_JOBS_KEY,
    JOBS_ENV,
    OWNER_KEY,
    README_INDICES_KEY,
    ROOT_KEY,
    Background,
    background_needed,
    readme_needed,
    shared_folder,
    start_background,
    start_beam_report,
    start_docs,
    start_fuzz,
    start_mypy,
    start_readme,
    suite_job,
    uses_fixture,
)
from tests.paths import (  # noqa: E402
    BEAM_GEOMETRY,
    PYFRF_UFF,
    PYUFF_DIR,
    REAL_UFF,
    REPO,
    THREE_SENSORS,
)

# tqdm starts a monitor thread with its first bar, even a disabled one (batch
# --quiet), and keeps it for the life of the process. Any second thread makes
# every later io.check_hdf5 in the test process start a fresh interpreter
# (about 2 s on the loaded 2-core machine) instead of forking (about 0.1 s),
# for every test that runs after the first batch. Bars refresh without it.
tqdm.tqdm.monitor_interval = 0


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
    session for test_identification_real.py and test_library_cli.py (about 10 s)."""
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


@pytest.fixture(scope="module")
def two_mode_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with one noise-free two-mode FRF file, ``two.uff``
    (:func:`tests.cli_runs.write_two_mode_uff`)."""
    folder = tmp_path_factory.mktemp("two") / "in"
    folder.mkdir()
    write_two_mode_uff(folder / "two.uff")
    return folder


def _is_worker(config: pytest.Config) -> bool:
    """Whether this process is a pytest-xdist worker."""
    return hasattr(config, "workerinput")


def pytest_configure(config: pytest.Config) -> None:
    """The run's jobs folder: made by the process that owns the run (the xdist
    controller, or the one process without xdist), read by the workers from
    :data:`JOBS_ENV`."""
    if _is_worker(config) and os.environ.get(JOBS_ENV):
        config.stash[ROOT_KEY] = Path(os.environ[JOBS_ENV])
        config.stash[OWNER_KEY] = False
        return
    root = Path(tempfile.mkdtemp(prefix="ema-suite-"))
    (root / "owner").write_text(str(os.getpid()))
    os.environ[JOBS_ENV] = str(root)  # inherited by the xdist workers
    config.stash[ROOT_KEY] = root
    config.stash[OWNER_KEY] = True


#: Test modules that run on the xdist worker of another module (``--dist
#: loadscope``, :func:`pytest_xdist_make_scheduler`): those that share an
#: in-memory session fixture (``beam_identified``), computed once then.
SAME_WORKER = {"tests/test_library_cli.py": "tests/test_identification_real.py"}


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


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start the background jobs whose tests were collected (and not deselected),
    once per run (with xdist every worker collects the same tests; the first
    to claim a job starts it)."""
    config = session.config
    if importlib.util.find_spec("mypy") is not None and any(
        item.name == "test_mypy_clean" for item in session.items
    ):
        start_mypy(config)
    if uses_fixture(session.items, "fuzz"):
        start_fuzz(config)
    needed = background_needed(session.items)
    if needed:
        config.stash[BG_JOBS_KEY] = needed
        start_background(config)
    if REAL_UFF.is_file() and BEAM_GEOMETRY.is_file() and uses_fixture(session.items,
                                                                          "beam_report"):
        start_beam_report(config)
    if uses_fixture(session.items, "docs_site"):
        start_docs(config)
    readme = readme_needed(session.items)
    if readme:
        config.stash[README_INDICES_KEY] = readme
        start_readme(config)


def pytest_unconfigure(config: pytest.Config) -> None:
    """The run's owner stops the jobs the run did not wait for (stopped early:
    each job's whole process group) and removes the jobs folder."""
    root = config.stash.get(ROOT_KEY, None)
    if root is None or not config.stash.get(OWNER_KEY, False):
        return
    for pid_file in root.glob("*/pid"):
        if not (pid_file.parent / "rc").exists():
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.killpg(int(pid_file.read_text()), signal.SIGKILL)
    shutil.rmtree(root, ignore_errors=True)
    if os.environ.get(JOBS_ENV) == str(root):
        del os.environ[JOBS_ENV]


@pytest.fixture(scope="session")
def beam_report(request: pytest.FixtureRequest, real_uff: Path) -> Path:
    """The results folder of ``ema-pipeline identify`` on the measured beam
    with ``--report --no-figures --geometry examples/ufsc-beam-geometry.uff
    --quiet`` (:func:`tests.jobs.beam_report_args`): modes CSV, result and report page.
    It runs once per run, in a child process started at collection (about
    10 s on the second core); the tests only read it (test_library_cli,
    test_picks, test_picks_browser, test_report)."""
    if not BEAM_GEOMETRY.is_file():
        pytest.skip(f"the beam's geometry {BEAM_GEOMETRY} is not there")
    job = start_beam_report(request.config)
    assert job.wait() == 0, f"the measured beam's run failed:\n{job.log_tail()}"
    return job.dir / "out"


@pytest.fixture(scope="session")
def background(request: pytest.FixtureRequest) -> Background:
    """Cases identified in the background (:class:`Background`)."""
    jobs = request.config.stash.get(BG_JOBS_KEY, {})
    job = suite_job(request.config, "bg")
    return Background(job if jobs and job.started else None, jobs)
