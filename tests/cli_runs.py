"""Helpers of the command-line tests: ``ema-pipeline`` run in this process, an
experiment file written, a report page's shape view read, and the noise-free
two-mode FRF the option tests identify."""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.acquisition import modal_frf
from ema_pipeline.cli import main
from ema_pipeline.data import DOF, FRFSet, ModalParameters

#: the two-mode test FRF: receptance of 30 Hz / 1 % and 70 Hz / 2 %, noise-free
TWO_MODES = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])


def run_cli(argv: list, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``ema-pipeline ARGV`` in this process: (exit status, stdout, stderr)."""
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def count_calls(monkeypatch: pytest.MonkeyPatch, owner: object,
                name: str) -> list[tuple[str, tuple]]:
    """Count the calls of ``owner.name`` (a function of a module, or a method of a
    class): it is wrapped in ``owner`` and wherever a loaded ``ema_pipeline``
    module holds it (``from X import name`` copies it), for the rest of the
    test. Returns the list each call appends (the calling module's name, the
    arguments) to."""
    func: Callable = getattr(owner, name)
    calls: list[tuple[str, tuple]] = []

    def counted(*args: object, **kwargs: object) -> object:
        calls.append((sys._getframe(1).f_globals.get("__name__", ""), args))
        return func(*args, **kwargs)

    monkeypatch.setattr(owner, name, counted)
    for module_name, module in list(sys.modules.items()):
        if module_name.startswith("ema_pipeline") and module is not None:
            for attr, value in list(vars(module).items()):
                if value is func:
                    monkeypatch.setattr(module, attr, counted)
    return calls


def write_experiment(path: Path, text: str) -> Path:
    """``text`` written to ``path`` (an experiment file); returns ``path``."""
    path.write_text(text)
    return path


def shape_data(page: str) -> dict:
    """The first animated shape view's JSON (nodes, ids, lines, surfaces, modes)."""
    blob = re.search(r'<script type="application/json" class="shape-data">(.*?)</script>', page)
    assert blob, "no shape view"
    return json.loads(blob.group(1))


def write_two_mode_uff(path: Path) -> Path:
    """:data:`TWO_MODES` as a noise-free UFF file at ``path`` (2 x 1 receptances,
    801 lines, 0-100 Hz, DOFs 1+Z and 2+Z, hammer at 1+Z)."""
    f = np.linspace(0.0, 100.0, 801)
    phi = np.array([[1.0, 0.6], [0.5, -1.0]])
    H = modal_frf(f, TWO_MODES, phi, phi[:1], quantity="receptance")
    frf = FRFSet(freq_hz=f, H=H, quantity="receptance", response_dofs=(DOF(1), DOF(2)),
                 reference_dofs=(DOF(1),))
    return io.write_frf(frf, path, "uff")
