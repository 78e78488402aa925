"""The runnable blocks of README.md and of the docs' Markdown pages, and how a
bash block runs (tests/test_readme.py).

Run as a script it is a background job of the test run:
``python -m tests.readme_blocks OUT_DIR INDEX ...`` runs the bash blocks
``BLOCKS[INDEX]``, in the order given, each in its own scratch repository
OUT_DIR/block_INDEX/repo (:func:`make_sandbox`), and writes its outcome
({"returncode", "stdout", "stderr", "script"}) to the file
:func:`background_job.output_path` gives for ``readme:INDEX``, through a
temporary file and a rename. Before a block it claims it
(:func:`background_job.claim`): a block that the test process claimed first,
because its test came before the job got to it, is skipped.
``tests/conftest.py`` starts it at collection for the selected bash blocks
that need nothing of the suite's own results (:func:`runs_in_background`).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from tests.background_job import claim, output_path

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
#: ``file:line`` -> index in :data:`BLOCKS`.
INDEX = {where: k for k, (*_, where) in enumerate(BLOCKS)}


def runnable_body(body: str, directive: str) -> str:
    """The block as it runs: with a ``reduce 'OLD' 'NEW' REASON`` directive, OLD
    replaced by NEW."""
    if directive.startswith("reduce"):
        _, old, new, *_reason = shlex.split(directive)
        return body.replace(old, new)
    return body


def missing_shared(body: str) -> list[str]:
    """The files of ``../shared`` the block names that are absent."""
    needed = sorted({m.rstrip(".") for m in re.findall(r"\.\./shared[\w./-]*", body)})
    return [name for name in needed if not (REPO / name).exists()]


def needs_results(body: str) -> bool:
    """Whether the block reads ``results/`` (the tables of the suite's run of the example)."""
    return "results/" in body


def runs_in_background(lang: str, body: str, directive: str) -> bool:
    """Whether the block's test may take its outcome from the background job: a
    bash block that runs (not skipped, its ../shared files present) and needs
    no results of the suite."""
    body = runnable_body(body, directive)
    return (lang == "bash" and not directive.startswith("skip") and not needs_results(body)
            and not missing_shared(body))


def make_sandbox(root: Path, tables: Path | None = None) -> Path:
    """A scratch repository ROOT/repo: raw_frf/, examples/ and benchmarks/
    copied, ``tables`` (if given) as results/tables, ../shared linked when
    present, and an empty ROOT/scratch (the blocks' /tmp/)."""
    repo = root / "repo"
    repo.mkdir(parents=True)
    shutil.copytree(REPO / "raw_frf", repo / "raw_frf")
    shutil.copytree(REPO / "examples", repo / "examples")
    if tables is not None:
        shutil.copytree(tables, repo / "results" / "tables")
    shutil.copytree(REPO / "benchmarks", repo / "benchmarks")
    if SHARED.is_dir():
        (root / "shared").symlink_to(SHARED)
    (root / "scratch").mkdir()
    return repo


def run_bash(body: str, sandbox: Path) -> dict[str, object]:
    """Run a bash block in ``sandbox`` with ``bash -e -o pipefail`` (``ema-pipeline``
    and ``python`` are this interpreter, ``/tmp/`` is the sandbox's scratch
    folder): {"returncode", "stdout", "stderr", "script"}."""
    scratch = sandbox.parent / "scratch"
    cli = f'"{sys.executable}" -m ema_pipeline.cli'
    # /tmp/ first: the interpreter itself may live under /tmp (a venv there)
    script = body.replace("/tmp/", f"{scratch}/")
    script = re.sub(r"(?m)(^|\s|&&\s*)ema-pipeline(?=\s)", rf"\1{cli}", script)
    script = re.sub(r"(?m)(^|\s)python(?=\s)", rf'\1"{sys.executable}"', script)
    env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg")
    proc = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", script], cwd=sandbox,
                          env=env, capture_output=True, text=True, timeout=600)
    return {"returncode": proc.returncode, "stdout": proc.stdout, "stderr": proc.stderr,
            "script": script}


def readme_key(index: int) -> str:
    """The job's key of block ``index`` (its output file: ``output_path(OUT_DIR, key)``)."""
    return f"readme:{index}"


def write_outcome(out_dir: Path, index: int) -> None:
    """Run bash block ``index`` in a fresh sandbox under ``out_dir`` and write its
    outcome (a temporary file renamed: a reader sees the whole file or none)."""
    lang, body, directive, _ = BLOCKS[index]
    assert lang == "bash", BLOCKS[index]
    sandbox = make_sandbox(out_dir / f"block_{index}")
    outcome = run_bash(runnable_body(body, directive), sandbox)
    path = output_path(out_dir, readme_key(index))
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(outcome))
    os.replace(tmp, path)


def main(argv: list[str]) -> int:
    out_dir = Path(argv[0])
    parent = os.getppid()
    for index in map(int, argv[1:]):
        if os.getppid() != parent:  # the test run is gone (killed): stop
            return 1
        if claim(out_dir, readme_key(index)):
            write_outcome(out_dir, index)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
