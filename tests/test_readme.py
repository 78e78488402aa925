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
"""

from __future__ import annotations

import contextlib
import io as stdio
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
SOURCES = [README, *sorted(p for p in DOCS.rglob("*.md")
                           if not {"_build", "tutorials"} & set(p.relative_to(DOCS).parts))]
SHARED = REPO.parent / "shared"
FENCE = re.compile(
    r"(?:<!--\s*readme-test:\s*(?P<directive>.*?)\s*-->\s*\n)?```(?P<lang>\w*)\n(?P<body>.*?)```",
    re.S,
)


def _blocks() -> list[tuple[str, str, str, str]]:
    """(language, body, directive, ``file:line``) of every block of SOURCES."""
    out = []
    for source in SOURCES:
        text = source.read_text(encoding="utf-8")
        for m in FENCE.finditer(text):
            if m.group("lang") in ("python", "bash", "toml"):
                line = text[: m.start("body")].count("\n") + 1
                where = f"{source.relative_to(REPO)}:{line}"
                out.append((m.group("lang"), m.group("body"), m.group("directive") or "", where))
    return out


BLOCKS = _blocks()


@pytest.fixture
def sandbox(tmp_path, request) -> Path:
    """A scratch repository: raw_frf/ copied, ../shared linked, and for a block
    that reads results/ the tables of the suite's ``ema-pipeline run`` (results/
    is not in the repository: the README's first command writes it)."""
    repo = tmp_path / "repo"
    repo.mkdir()
    shutil.copytree(REPO / "raw_frf", repo / "raw_frf")
    shutil.copytree(REPO / "examples", repo / "examples")
    callspec = getattr(request.node, "callspec", None)
    if callspec is not None and "results/" in callspec.params.get("body", ""):
        tables = request.getfixturevalue("example_study") / "tables"
        shutil.copytree(tables, repo / "results" / "tables")
    shutil.copytree(REPO / "benchmarks", repo / "benchmarks")
    if SHARED.is_dir():
        (tmp_path / "shared").symlink_to(SHARED)
    (tmp_path / "scratch").mkdir()
    return repo


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
def test_readme_block_runs(lang, body, directive, line, sandbox, monkeypatch):
    if directive.startswith("skip"):
        pytest.skip(f"{line}: {directive}")
    if directive.startswith("reduce"):
        _, old, new, *_reason = shlex.split(directive)
        body = body.replace(old, new)
    needed = sorted({m.rstrip(".") for m in re.findall(r"\.\./shared[\w./-]*", body)})
    missing = [name for name in needed if not (REPO / name).exists()]
    if missing:
        pytest.skip(f"{line} needs {', '.join(missing)} beside the repository (absent here)")
    monkeypatch.chdir(sandbox)
    scratch = sandbox.parent / "scratch"
    if lang == "python":
        namespace: dict[str, object] = {"__name__": "__readme__"}
        with contextlib.redirect_stdout(stdio.StringIO()):
            exec(compile(body, line, "exec"), namespace)  # noqa: S102
    elif lang == "toml":
        doc = tomllib.loads(body)
        if "experiment" in doc:
            from ema_pipeline import io

            path = sandbox / "raw_frf" / "readme_experiment.toml"
            path.write_text(body, encoding="utf-8")
            experiment = io.read_experiment(path)
            assert experiment.name == doc["experiment"]["name"]
    else:
        cli = f'"{sys.executable}" -m ema_pipeline.cli'
        # /tmp/ first: the interpreter itself may live under /tmp (a venv there)
        script = body.replace("/tmp/", f"{scratch}/")
        script = re.sub(r"(?m)(^|\s|&&\s*)ema-pipeline(?=\s)", rf"\1{cli}", script)
        script = re.sub(r"(?m)(^|\s)python(?=\s)", rf'\1"{sys.executable}"', script)
        env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg")
        proc = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", script], cwd=sandbox,
                              env=env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, f"{line}\n{script}\n{proc.stdout}\n{proc.stderr}"
