"""Every ```python, ```bash and ```toml block of README.md and of the Markdown
pages of the documentation (``docs/**/*.md``) runs (issues 14, 29; the
tutorials of ``docs/tutorials_src`` run in the docs build, tests/test_docs.py).

Each block runs on its own, as a reader would paste it, in a scratch copy of
the repository (``raw_frf/`` copied, ``results/tables`` from the suite's run of
the example, ``../shared`` linked when present): Python blocks with ``exec``,
bash blocks with ``bash -e`` (``ema-pipeline`` and ``python`` are this
interpreter, ``/tmp/`` is the scratch folder), TOML blocks are parsed (a
complete experiment file is also read with :func:`ema_pipeline.io.read_experiment`).

Convention, in README.md and the docs pages: an HTML comment on the line before the opening fence,

* ``<!-- readme-test: skip REASON -->`` skips the block with that reason (for
  installs, synopses with placeholders and minutes-long benchmarks);
* ``<!-- readme-test: reduce 'OLD' 'NEW' REASON -->`` runs the block with the
  text OLD replaced by NEW (smaller arguments for a block that runs long).

The reason must be given. Blocks that need files of ``../shared/data`` are
skipped, naming them, where they are absent.

The blocks and how a bash block runs are in tests/readme_blocks.py; the bash
blocks that need nothing of the suite's own results run there in a background
job started at collection (tests/conftest.py), and their tests assert on its
outcome.
"""

from __future__ import annotations

import contextlib
import io as stdio
import re
import shlex
import tomllib
from pathlib import Path

import pytest

from tests.jobs import README_INDICES_KEY, ReadmeOutcomes, suite_job
from tests.readme_blocks import (
    BLOCKS,
    INDEX,
    make_sandbox,
    missing_shared,
    needs_results,
    run_bash,
    runnable_body,
)


@pytest.fixture(scope="session")
def readme_outcomes(request: pytest.FixtureRequest) -> ReadmeOutcomes:
    """The readme bash blocks run in the background (:class:`ReadmeOutcomes`)."""
    indices = request.config.stash.get(README_INDICES_KEY, [])
    job = suite_job(request.config, "readme")
    return ReadmeOutcomes(job if indices and job.started else None, indices)


@pytest.fixture
def sandbox(tmp_path, request) -> Path:
    """A scratch repository (readme_blocks.make_sandbox): raw_frf/ copied,
    ../shared linked, and for a block that reads results/ the tables of the
    suite's ``ema-pipeline run`` (results/ is not in the repository: the
    README's first command writes it)."""
    callspec = getattr(request.node, "callspec", None)
    tables = None
    if callspec is not None and needs_results(callspec.params.get("body", "")):
        tables = request.getfixturevalue("example_study") / "tables"
    return make_sandbox(tmp_path, tables)


def test_readme_has_blocks_of_each_kind_and_skips_give_reasons():
    kinds = {lang for lang, *_ in BLOCKS}
    assert kinds == {"python", "bash", "toml"}
    assert any(where.startswith("README.md") for *_, where in BLOCKS)
    assert any(where.startswith("docs") for *_, where in BLOCKS)
    for _, body, directive, line in BLOCKS:
        if directive.startswith("reduce"):
            _, old, _new, *reason = shlex.split(directive)
            assert old in body and len(" ".join(reason)) > 8, f"{line}: {directive!r}"
        elif directive:
            assert re.fullmatch(r"skip \S.{8,}", directive), f"{line}: {directive!r}"


@pytest.mark.parametrize(
    ("lang", "body", "directive", "line"), BLOCKS,
    ids=[f"{b[3].removeprefix('docs/').replace('.md:', '-line')}-{b[0]}" for b in BLOCKS]
)
def test_readme_block_runs(lang, body, directive, line, request, monkeypatch):
    """The block runs without error. A bash block that needs nothing of the
    suite's results may have run in the background job started at collection
    (``readme_outcomes``, started by tests/conftest.py): its exit status and output are
    that run's."""
    if directive.startswith("skip"):
        pytest.skip(f"{line}: {directive}")
    body = runnable_body(body, directive)
    missing = missing_shared(body)
    if missing:
        pytest.skip(f"{line} needs {', '.join(missing)} beside the repository (absent here)")
    if lang == "bash":
        outcome = request.getfixturevalue("readme_outcomes").outcome(INDEX[line])
        if outcome is None:  # not a block of the background job: run it here
            outcome = run_bash(body, request.getfixturevalue("sandbox"))
        assert outcome["returncode"] == 0, (
            f"{line}\n{outcome['script']}\n{outcome['stdout']}\n{outcome['stderr']}")
        return
    sandbox = request.getfixturevalue("sandbox")
    monkeypatch.chdir(sandbox)
    if lang == "python":
        namespace: dict[str, object] = {"__name__": "__readme__"}
        with contextlib.redirect_stdout(stdio.StringIO()):
            exec(compile(body, line, "exec"), namespace)  # noqa: S102
    else:
        doc = tomllib.loads(body)
        if "experiment" in doc:
            from ema_pipeline import io

            path = sandbox / "raw_frf" / "readme_experiment.toml"
            path.write_text(body, encoding="utf-8")
            experiment = io.read_experiment(path)
            assert experiment.name == doc["experiment"]["name"]
