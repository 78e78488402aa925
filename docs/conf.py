"""Sphinx configuration of the ema-pipeline documentation.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html``
(``pip install -e '.[docs]'``). The tutorials in ``tutorials_src/`` run during
the build (sphinx-gallery); ``tests/test_docs.py`` builds the site with ``-W``.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(DOCS))  # cli_parser.py
# one BLAS thread: the tutorials are small, and the build shares the machine
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import ema_pipeline  # noqa: E402

project = "ema-pipeline"
author = "ema-pipeline developers"
copyright = "ema-pipeline developers"
release = version = ema_pipeline.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx.ext.intersphinx",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
    "myst_parser",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "tutorials_src/README.rst", "tutorials/*.ipynb",
                    "tutorials/*.py", "tutorials/*.md5", "tutorials/*.codeobj.json",
                    "tutorials/*.zip", "sg_execution_times.rst"]
templates_path: list[str] = []
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
suppress_warnings = ["config.cache"]  # sphinx-gallery's config holds functions

# autodoc / napoleon (numpydoc-style docstrings)
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"
autosummary_generate = False
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
add_module_names = False

intersphinx_mapping: dict[str, tuple[str, None]] = {}

html_theme = "furo"
html_title = f"ema-pipeline {release}"
html_static_path = ["_static"]

sphinx_gallery_conf = {
    "examples_dirs": "tutorials_src",
    "gallery_dirs": "tutorials",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "show_memory": False,
    "abort_on_example_error": True,
    "reset_modules": ("matplotlib",),
    "write_computation_times": False,
    # tests/test_docs.py runs every tutorial, also those whose source has not changed
    "run_stale_examples": os.environ.get("EMA_DOCS_RUN_ALL") == "1",
}

# -- docstrings are written as plain text: |H|^2 is an absolute value, not a
# reStructuredText substitution, and rho_-d a subscript, not a link. Escape both
# outside literals, doctests and literal blocks (every other reST problem of a
# docstring still fails the build).
_LITERAL = re.compile(r"(``.*?``|`[^`]*`)")


_REFERENCE = re.compile(r"(?<=\w)_(?=[^\w]|$)")  # rho_-d: a subscript, not a link


def _escape_bars(line: str) -> str:
    parts = _LITERAL.split(line)
    return "".join(p if k % 2 else _REFERENCE.sub(r"\\_", p.replace("|", r"\|"))
                   for k, p in enumerate(parts))


def escape_absolute_values(app, what, name, obj, options, lines: list[str]) -> None:
    literal_indent: int | None = None
    in_doctest = False
    for k, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None:
            if not stripped or indent > literal_indent:
                continue
            literal_indent = None
        if stripped.startswith(">>>"):
            in_doctest = True
        if in_doctest:
            in_doctest = bool(stripped)
            continue
        if "|" in line or "_" in line:
            lines[k] = _escape_bars(line)
        if stripped.endswith("::"):
            literal_indent = indent


def setup(app) -> None:
    app.connect("autodoc-process-docstring", escape_absolute_values)
