"""The code base stays ruff-clean and free of pickle (users open files from others),
its modules import downhill (no cycle, no private name from another module)."""

from __future__ import annotations

import ast
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.jobs import start_mypy
from tests.paths import REPO


@pytest.fixture
def mypy_outcome(request: pytest.FixtureRequest) -> tuple[int, str]:
    """(exit status, output) of :data:`MYPY_COMMAND`, started at collection (or now)."""
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy not installed (it is in the [test] extra)")
    job = start_mypy(request.config)
    code = job.wait()
    return code, (job.dir / "runner.log").read_text()



def test_ruff_clean():
    ruff = shutil.which("ruff")
    if ruff is None:
        pytest.skip("ruff not installed (it is in the [test] extra)")
    done = subprocess.run([ruff, "check", "ema_pipeline", "tests", "benchmarks"], cwd=REPO,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_mypy_clean(mypy_outcome):
    """``python -m mypy ema_pipeline`` with the settings in pyproject.toml: a type
    error introduced anywhere in the package fails here (about 15-50 s cold; it
    runs in the background from the start of the session, see conftest.py)."""
    returncode, output = mypy_outcome
    assert returncode == 0, output


def test_no_pickle_anywhere():
    pattern = re.compile(r"^\s*(import (pickle|dill|cloudpickle)|from (pickle|dill|cloudpickle) )",
                         re.MULTILINE)
    offenders = [str(p) for p in (REPO / "ema_pipeline").rglob("*.py")
                 if pattern.search(p.read_text())]
    assert offenders == []


# ------------------------------------------------------------------ imports
PACKAGE = "ema_pipeline"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def package_modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted((REPO / PACKAGE).rglob("*.py"))}


def is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def module_level_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """Imports that run when the module is imported: module body, class bodies,
    if/try/with blocks; not function bodies, not ``if TYPE_CHECKING:`` blocks."""
    found: list[ast.Import | ast.ImportFrom] = []

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, ast.Import | ast.ImportFrom):
                found.append(node)
            elif isinstance(node, ast.If):
                if not is_type_checking(node.test):
                    visit(node.body)
                visit(node.orelse)
            elif isinstance(node, ast.Try):
                for block in (node.body, node.orelse, node.finalbody):
                    visit(block)
                for handler in node.handlers:
                    visit(handler.body)
            elif isinstance(node, ast.With | ast.ClassDef):
                visit(node.body)

    visit(tree.body)
    return found


def absolute(node: ast.ImportFrom, importer: str, is_package: bool) -> str:
    if not node.level:
        return node.module or ""
    base = importer.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imported_modules(importer: str, path: Path, known: set[str]) -> set[str]:
    """The package's modules that importing ``importer`` executes first: each
    target, a submodule named in ``from X import name``, and every package
    ``__init__`` on the way that is not an ancestor of the importer itself."""
    tree = ast.parse(path.read_text(), str(path))
    is_package = path.name == "__init__.py"
    own_ancestors = {".".join(importer.split(".")[:k]) for k in range(1, importer.count(".") + 2)}
    targets: set[str] = set()
    for node in module_level_imports(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            base = absolute(node, importer, is_package)
            names = [base] + [f"{base}.{alias.name}" for alias in node.names]
        for name in names:
            parts = name.split(".")
            for k in range(1, len(parts) + 1):
                target = ".".join(parts[:k])
                if target in known and target not in own_ancestors:
                    targets.add(target)
    targets.discard(importer)
    return targets


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def test_find_cycle_finds_a_cycle_and_accepts_a_tree():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_no_import_cycle_among_package_modules():
    modules = package_modules()
    known = set(modules)
    graph = {name: imported_modules(name, path, known) for name, path in modules.items()}
    assert graph["ema_pipeline.pipeline.single"] >= {"ema_pipeline.io", "ema_pipeline.data"}
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph) or [])


# ------------------------------------------------------------------ layers
def readme_layers(text: str) -> dict[str, int]:
    """Package or module (second name of ``ema_pipeline.X``, ``ema_pipeline`` for
    the package itself) -> its layer, 0 the lowest, from docs/architecture.md's block after
    ``<!-- import layers ... -->`` (one line per layer, top to bottom)."""
    match = re.search(r"<!-- import layers[^>]*-->\s*```text\n(.*?)```", text, re.S)
    assert match, "docs/architecture.md: no '<!-- import layers -->' block"
    lines = [line for line in match.group(1).splitlines() if line.strip()]
    return {name.strip(): len(lines) - 1 - k
            for k, line in enumerate(lines) for name in line.split(",")}


def group(module: str) -> str:
    """``ema_pipeline.io.uff`` -> ``io``; the package itself -> ``ema_pipeline``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def all_imports(importer: str, path: Path, known: set[str]) -> list[tuple[int, str]]:
    """(line, module) of every package module ``importer`` names in an import:
    module level, function bodies and ``if TYPE_CHECKING:`` blocks alike. ``from
    ema_pipeline import io`` names ``ema_pipeline.io``; the package itself only
    when a name is not a module (``from ema_pipeline import __version__``)."""
    tree = ast.parse(path.read_text(), str(path))
    is_package = path.name == "__init__.py"
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = absolute(node, importer, is_package)
            subs = [f"{base}.{alias.name}" for alias in node.names]
            names = [sub for sub in subs if sub in known]
            if len(names) < len(subs):
                names.append(base)
        else:
            continue
        for name in names:
            parts = name.split(".")
            target = next((".".join(parts[:k]) for k in range(len(parts), 0, -1)
                           if ".".join(parts[:k]) in known), None)
            if target is not None and target != importer:
                found.append((node.lineno, target))
    return found


def layer_violations(modules: dict[str, Path], layers: dict[str, int]) -> list[str]:
    """Imports of a module of a higher layer or of another package of the same
    layer (``file:line: importer -> imported``)."""
    known = set(modules)
    bad = []
    for importer, path in modules.items():
        mine = group(importer)
        for line, target in all_imports(importer, path, known):
            theirs = group(target)
            if theirs != mine and layers[theirs] >= layers[mine]:
                bad.append(f"{importer}:{line} -> {target}")
    return bad


def test_layer_check_sees_an_upward_import_in_a_function(tmp_path):
    pkg = tmp_path / "ema_pipeline"
    (pkg / "report").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from ema_pipeline.data import X\n")
    (pkg / "data.py").write_text("def f():\n    from ema_pipeline.report import tables\n")
    (pkg / "modal.py").write_text("from ema_pipeline import data, __version__\n")
    (pkg / "report" / "__init__.py").write_text("from . import tables\n")
    (pkg / "report" / "tables.py").write_text("from ..data import X\n")
    modules = {"ema_pipeline": pkg / "__init__.py", "ema_pipeline.data": pkg / "data.py",
               "ema_pipeline.modal": pkg / "modal.py",
               "ema_pipeline.report": pkg / "report" / "__init__.py",
               "ema_pipeline.report.tables": pkg / "report" / "tables.py"}
    layers = {"report": 3, "modal": 2, "ema_pipeline": 1, "data": 0}
    assert layer_violations(modules, layers) == [
        "ema_pipeline.data:2 -> ema_pipeline.report.tables"]
    layers["modal"] = 1  # beside the package itself: an import of a neighbour
    assert layer_violations(modules, layers)[-1] == "ema_pipeline.modal:1 -> ema_pipeline"


def test_every_import_goes_down_the_readme_layers():
    """docs/architecture.md's layer order holds for every import of the package, function-level
    and type-only imports included; every package and module has a layer."""
    layers = readme_layers((REPO / "docs" / "architecture.md").read_text(encoding="utf-8"))
    modules = package_modules()
    assert {group(name) for name in modules} <= set(layers), "a package missing in README layers"
    assert layer_violations(modules, layers) == []


def test_io_loads_no_numerics():
    """``import ema_pipeline.io`` (which reads and writes identification results)
    loads neither scipy nor the identification's numerics: the result types live
    in the light ``identification.result`` and ``identification/__init__`` loads
    its modules on first use. Checked in a fresh interpreter."""
    code = ("import sys, ema_pipeline.io; "
            "print('scipy' in sys.modules, sorted(m for m in sys.modules "
            "if m.startswith('ema_pipeline.identification.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=REPO, check=True,
                         env={**os.environ, "PYTHONPATH": str(REPO)}).stdout
    assert out.split(" ", 1)[0] == "False", out
    loaded = set(ast.literal_eval(out.strip().split(" ", 1)[1]))
    light = {f"ema_pipeline.identification.{m}"
             for m in ("options", "picked", "result", "thresholds")}
    assert loaded <= light, loaded - light  # options, picks, result types: no numerics


def test_matplotlib_is_optional():
    """No module of the package imports matplotlib: not the report pages (SVG),
    not ``report.matplotlib_plots`` (its functions draw on the caller's Axes);
    matplotlib is the ``plots`` extra, not a dependency. Checked in a fresh
    interpreter that imports every module."""
    code = ("import importlib, pkgutil, sys, ema_pipeline; "
            "[importlib.import_module(m.name) for m in pkgutil.walk_packages("
            "ema_pipeline.__path__, 'ema_pipeline.') if not m.name.endswith('__main__')]; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=REPO, check=True,
                         env={**os.environ, "PYTHONPATH": str(REPO)}).stdout
    assert out.strip() == "[]", out
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert not [d for d in project["dependencies"] if d.startswith("matplotlib")]
    assert project["optional-dependencies"]["plots"] == ["matplotlib>=3.7"]


def test_identification_exports_are_lazy_and_complete():
    """Every name of ``identification.__all__`` resolves (through the lazy
    ``__getattr__``) to the object of its module, and an unknown name is an
    AttributeError."""
    import importlib

    import ema_pipeline.identification as ident

    assert sorted(ident.__all__) == sorted(ident.EXPORTS)
    for name, module in ident.EXPORTS.items():
        home = importlib.import_module(f"ema_pipeline.identification.{module}")
        assert getattr(ident, name) is getattr(home, name), name
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        _ = ident.no_such_name  # type: ignore[attr-defined]


def private_imports(path: Path) -> list[str]:
    """``from X import _name`` and imports of ``_module`` paths, anywhere in the file
    (function bodies too); dunder names (``__future__``, ``__version__``) are public."""
    def private(name: str) -> bool:
        return name.startswith("_") and not name.startswith("__")

    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            where = "." * node.level + (node.module or "")
            if any(private(part) for part in (node.module or "").split(".")):
                found.append(f"{path.name}:{node.lineno}: from {where}")
            found += [f"{path.name}:{node.lineno}: {alias.name} from {where}"
                      for alias in node.names if private(alias.name)]
        elif isinstance(node, ast.Import):
            found += [f"{path.name}:{node.lineno}: import {alias.name}" for alias in node.names
                      if any(private(part) for part in alias.name.split("."))]
    return found


def test_private_import_check_sees_one(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("from a.b import _hidden, public\nimport os\n"
                     "from __future__ import annotations\n")
    assert private_imports(probe) == ["probe.py:1: _hidden from a.b"]


def test_no_private_name_imported_from_another_module():
    offenders = [hit for path in sorted((REPO / PACKAGE).rglob("*.py"))
                 for hit in private_imports(path)]
    assert offenders == []


def test_scipy_pin_covers_the_api_we_call():
    """``fe/update.py`` passes ``rng=`` to ``scipy.optimize.differential_evolution``,
    which scipy has since 1.15.0 (SPEC 7): the pin in pyproject.toml says so."""
    import tomllib

    deps = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["dependencies"]
    pin = next(d for d in deps if re.match(r"scipy\b", d))
    version = tuple(int(x) for x in re.search(r">=\s*([\d.]+)", pin).group(1).split("."))
    assert version >= (1, 15), pin
    assert "rng=np.random.default_rng" in (REPO / "ema_pipeline" / "fe" / "update.py").read_text()


# ------------------------------------------------------------------ scripts
JS_MARKS = re.compile(r"function\s*\(|addEventListener|document\.\w|=>")


def javascript_strings(path: Path) -> list[str]:
    """``file:line`` of every string constant of ``path`` that reads as JavaScript."""
    return [f"{path.name}:{node.lineno}" for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and JS_MARKS.search(node.value)]


def test_javascript_check_sees_a_script(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('"""A docstring."""\nA = "x"\nB = """\n(function(){var a=1;})();\n"""\n')
    assert javascript_strings(probe) == ["probe.py:3"]


def test_no_javascript_inside_python_strings():
    """The pages' scripts live in ``report/js/*.js`` (package data, read by
    ``report.scripts.page_script``), never in a Python string."""
    offenders = [hit for path in sorted((REPO / PACKAGE).rglob("*.py"))
                 for hit in javascript_strings(path)]
    assert offenders == []
    data = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "report/js/*.js" in data["package-data"]["ema_pipeline"]
    assert {p.name for p in (REPO / PACKAGE / "report" / "js").glob("*.js")} == {
        "hit_choice.js", "live.js", "shape_views.js", "stab_call.js", "stab_diagram.js",
        "synthesis.js"}
