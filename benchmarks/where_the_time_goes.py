"""Where an identification's CPU time goes: the table of the fifth look of
``benchmarks/issue52_speed.md``.

Run as ``python benchmarks/where_the_time_goes.py``. Each dataset is
identified twice in this process with one worker (``workers=1``, so every
piece runs here and is timed), the second run timed. For each function
below, the time of its outermost calls (a call inside another call of the
same function is not counted twice) is printed, in seconds and as a share of
the whole identification. The pieces nest into each other (a refinement
per mode holds its band, its local fit and its covariance; the screens hold
their own linear fits), so the shares do not add up to 100 %.

The datasets: the measured beam (``../shared/data/ufsc-beam-hammer.uff``),
the pyFRF recording (``../shared/data/pyfrf-impact.uff``, its FRF made by
``ema-pipeline frf`` first) and one simulated paper file (genuine, seed 0);
those absent are skipped with a note.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from ema_pipeline import io as frf_io
from ema_pipeline.identification import identify
from ema_pipeline.identification.diagram import plscf, roots
from ema_pipeline.identification.refinement import local_fits, lsfd, refine
from ema_pipeline.identification.selection import trajectories
from ema_pipeline.pipeline.simulate import simulate_paper_test

ROOT = Path(__file__).resolve().parent.parent
BEAM_UFF = ROOT.parent / "shared" / "data" / "ufsc-beam-hammer.uff"
PYFRF_UFF = ROOT.parent / "shared" / "data" / "pyfrf-impact.uff"

#: (label, module, function name): the pieces timed, where they are defined.
PIECES = [
    ("local fits (vp_fit, all callers)", refine, "vp_fit"),
    ("refinement per mode (LocalFits.fit)", refine.LocalFits, "fit"),
    ("diagram roots (diagram_roots)", roots, "diagram_roots"),
    ("  of which companion eigenvalues", roots, "companion_roots"),
    ("sandwich covariance (vp_covariance)", refine, "vp_covariance"),
    ("LSFDs (lsfd)", lsfd, "lsfd"),
    ("normal matrices (plscf_normal_matrix)", plscf, "plscf_normal_matrix"),
    ("denominators (plscf_denominators)", plscf, "plscf_denominators"),
    ("screens (quick_significance)", local_fits, "quick_significance"),
    ("pole tracking (track_poles)", trajectories, "track_poles"),
]


def timed(func: Callable, label: str, spent: dict[str, float],
          depth: dict[str, int]) -> Callable:
    """``func`` adding the time of its outermost calls to ``spent[label]``."""

    def wrapper(*args, **kwargs):
        depth[label] = depth.get(label, 0) + 1
        start = time.perf_counter()
        try:
            return func(*args, **kwargs)
        finally:
            depth[label] -= 1
            if depth[label] == 0:
                spent[label] = spent.get(label, 0.0) + time.perf_counter() - start

    return wrapper


def patch_all(spent: dict[str, float]) -> None:
    """Replace each piece of :data:`PIECES` by its timed wrapper, in its own
    module or class and in every package module that imported it."""
    depth: dict[str, int] = {}
    for label, owner, name in PIECES:
        original = getattr(owner, name)
        wrapped = timed(original, label, spent, depth)
        setattr(owner, name, wrapped)
        for module in list(sys.modules.values()):
            if (getattr(module, "__name__", "").startswith("ema_pipeline")
                    and getattr(module, name, None) is original):
                setattr(module, name, wrapped)


def datasets(tmp: Path) -> dict[str, object]:
    """The FRF sets to identify (those whose files exist)."""
    out: dict[str, object] = {}
    if BEAM_UFF.exists():
        out["beam"] = frf_io.read_frf(BEAM_UFF)
    else:
        print(f"measured beam: skipped, {BEAM_UFF} is absent")
    if PYFRF_UFF.exists():
        rec = tmp / "rec.h5"
        subprocess.run([sys.executable, "-m", "ema_pipeline", "frf", str(PYFRF_UFF), "--out",
                        str(rec), "--quiet"], check=True, capture_output=True)
        out["recording"] = frf_io.read_frf(rec)
    else:
        print(f"real recording: skipped, {PYFRF_UFF} is absent")
    out["paper file"] = simulate_paper_test("genuine", seed=0)
    return out


def main() -> None:
    warnings.simplefilter("ignore")
    spent: dict[str, float] = {}
    patch_all(spent)
    with tempfile.TemporaryDirectory() as tmp:
        frfs = datasets(Path(tmp))
    columns: dict[str, tuple[float, dict[str, float]]] = {}
    for name, frf in frfs.items():
        identify(frf, workers=1)  # the first run: caches, lazy imports
        spent.clear()
        start = time.perf_counter()
        identify(frf, workers=1)
        columns[name] = (time.perf_counter() - start, dict(spent))
    head = "".join(f"{f'{name} ({total:.2f} s)':>24s}" for name, (total, _) in columns.items())
    print(f"{'CPU of one identification, workers=1':44s}{head}")
    for label, _, _ in PIECES:
        cells = [f"{part.get(label, 0.0):.3f} s ({100 * part.get(label, 0.0) / total:.0f} %)"
                 for total, part in columns.values()]
        print(f"{label:44s}" + "".join(f"{cell:>24s}" for cell in cells))


if __name__ == "__main__":
    main()
