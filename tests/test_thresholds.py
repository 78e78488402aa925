"""The tuned thresholds of the identification
(:mod:`ema_pipeline.identification.thresholds`): one home for every tuned
number, passed down the package as a required keyword, and each field read
by the code it tunes."""

from __future__ import annotations

import ast
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

import ema_pipeline
from ema_pipeline.data import ConfigError, FRFSet
from ema_pipeline.identification import IdentificationOptions
from ema_pipeline.identification.diagram.resources import check_identification, order_cap
from ema_pipeline.identification.refinement.local_band import local_problem
from ema_pipeline.identification.selection.residual_search import residual_peaks
from ema_pipeline.identification.thresholds import SelectionThresholds

TH = SelectionThresholds()  # the tuned defaults
PACKAGE = Path(ema_pipeline.__file__).parent
#: The module of the record and the options that hold it (its one default).
HOMES = {PACKAGE / "identification" / "thresholds.py", PACKAGE / "identification" / "options.py"}


def _trees() -> dict[Path, ast.Module]:
    return {p: ast.parse(p.read_text(encoding="utf-8")) for p in sorted(PACKAGE.rglob("*.py"))}


def test_every_field_is_read_by_the_package() -> None:
    """Every field of the record is read (``.field``) by code outside its own
    module: none is a dead number, none is kept elsewhere instead."""
    own = PACKAGE / "identification" / "thresholds.py"
    read = {node.attr for path, tree in _trees().items() if path != own
            for node in ast.walk(tree) if isinstance(node, ast.Attribute)}
    unread = [f.name for f in fields(SelectionThresholds) if f.name not in read]
    assert not unread, unread


def test_the_guide_lists_every_field_with_its_default() -> None:
    """The table of ``docs/guide/identification.md`` names every field with
    its tuned default."""
    guide = (PACKAGE.parent / "docs" / "guide" / "identification.md").read_text(encoding="utf-8")
    missing = [f.name for f in fields(SelectionThresholds)
               if f"`{f.name}` {getattr(TH, f.name)!r}" not in guide]
    assert not missing, missing


def test_thresholds_are_required_inside_the_package() -> None:
    """No function of the package defaults its ``thresholds`` (no second
    home of the defaults: ``thresholds or SelectionThresholds()``), and only
    the options make the default record; no class attribute of the record
    stands in for a field either."""
    defaulted, made, class_read = [], [], []
    for path, tree in _trees().items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                args = node.args
                positional = args.posonlyargs + args.args
                with_default = positional[len(positional) - len(args.defaults):]
                with_default += [a for a, d in zip(args.kwonlyargs, args.kw_defaults,
                                                   strict=True) if d is not None]
                if any(a.arg == "thresholds" for a in with_default):
                    defaulted.append(f"{path.name}:{node.name}")
            if path in HOMES:
                continue
            if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "SelectionThresholds":
                made.append(f"{path.name}:{node.lineno}")
            if isinstance(node, ast.Attribute) and getattr(node.value, "id", "") == (
                    "SelectionThresholds"):
                class_read.append(f"{path.name}:{node.lineno}")
    assert (defaulted, made, class_read) == ([], [], [])


def test_max_poles_caps_the_order() -> None:
    """``max_poles`` bounds the order the data may take
    (``order_cap``): a fixed order the default cap (480 for one reference)
    allows is refused under a cap of 200."""
    assert order_cap(8000, 1, TH.max_poles) == 480
    assert order_cap(8000, 1, 200) == 200 and order_cap(8000, 2, 200) == 100
    frf = FRFSet(freq_hz=np.arange(8000) * 0.125, H=np.ones((1, 1, 8000), complex))
    check_identification(frf, IdentificationOptions(max_order=400), source="x.h5")
    low = IdentificationOptions(max_order=400, thresholds=replace(TH, max_poles=200))
    with pytest.raises(ConfigError, match="at most 200 for 1 reference"):
        check_identification(frf, low, source="x.h5")


def test_local_band_fields_set_the_band_of_a_low_mode() -> None:
    """A mode at 10 Hz, zeta 5 % (half-power band 1 Hz) on 0.05 Hz lines:
    +-12 bandwidths would reach 12 Hz away; ``local_max_fraction`` (0.2)
    holds it to +-2 Hz (0.1: +-1 Hz), unless that leaves no more than
    ``local_cap_min_lines`` lines; with fewer than ``local_band_min_lines``
    lines there is no local problem."""
    f = np.arange(0.0, 50.0, 0.05)
    zeta, fn = 0.05, 10.0
    pole = np.array([-zeta * 2 * np.pi * fn + 2j * np.pi * fn * np.sqrt(1 - zeta**2)])
    H = np.ones((1, f.size), complex)

    def band(th: SelectionThresholds) -> tuple[float, float] | None:
        local = local_problem(f, H, pole, 0, th.local_half_width, th.local_min_lines,
                              thresholds=th)
        return None if local is None else local[5]

    fd = fn * np.sqrt(1 - zeta**2)
    np.testing.assert_allclose(band(TH), (fd - 0.2 * fd, fd + 0.2 * fd), rtol=1e-12)
    np.testing.assert_allclose(band(replace(TH, local_max_fraction=0.1)),
                               (fd - 0.1 * fd, fd + 0.1 * fd), rtol=1e-12)
    uncapped = band(replace(TH, local_cap_min_lines=100))  # 2 Hz holds 80 lines, not 100
    np.testing.assert_allclose(uncapped, (fd - 12 * 2 * zeta * fn, fd + 12 * 2 * zeta * fn),
                               rtol=1e-3)
    assert band(replace(TH, local_band_min_lines=100)) is None  # +-2 Hz: 80 lines


def test_residual_contrast_fields_set_the_surroundings_of_a_peak() -> None:
    """A stretch of the data 10 times noisier (120-160 Hz) beside one kept
    mode: the residual check takes no peak inside it, each being no higher
    than its surroundings (1-``residual_contrast_widths`` peak widths plus
    ``residual_contrast_lines`` lines away); with those surroundings shrunk
    to nothing, the stretch's peaks become start poles."""
    f = np.linspace(10.0, 210.0, 2001)
    lam = np.array([-1.0 + 2j * np.pi * 30.0])
    jw = 2j * np.pi * f
    H = np.stack([s * (1 / (jw - lam[0]) + 1 / (jw - lam[0].conj())) for s in (1.0, 0.5, -0.7)])
    rng = np.random.default_rng(5)
    level = np.where((f > 120) & (f < 160), 10.0, 1.0) * 1e-5
    H = H + level * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))

    def inside(th: SelectionThresholds) -> int:
        start, _ = residual_peaks(f, H, lam, "receptance", thresholds=th)
        fd = start.imag / (2 * np.pi)
        return int(np.sum((fd > 125.0) & (fd < 155.0)))

    assert inside(TH) == 0
    assert inside(replace(TH, residual_contrast_widths=1, residual_contrast_lines=0)) >= 3
