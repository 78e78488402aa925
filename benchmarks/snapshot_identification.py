"""Snapshot every identified number on the hard-case families, the paper files and
the measured beam, and compare two snapshots digit by digit.

A refactor or a speed-up must keep every identified number. Take a snapshot before
the change (from a clean checkout of the old commit) and one after, then compare::

    python benchmarks/snapshot_identification.py take before.json --seeds 100-103
    # ... change the code ...
    python benchmarks/snapshot_identification.py take after.json --seeds 100-103
    python benchmarks/snapshot_identification.py compare before.json after.json

``--package-root DIR`` snapshots the package found in another checkout (a
``git worktree`` of the old commit), so both snapshots can be taken at any time.

The comparison reports, per case, a changed mode count and the largest relative
change of fn, zeta, fn_std and zeta_std; the tolerances are the ones a refactor
must meet (fn 1e-6 relative, zeta 1e-4 relative, sigma 1 %). The resonances
listed as not kept (``not_kept_hz``) must be the same too, where both
snapshots hold them.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np
from seed_ranges import seed_list

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
REAL_UFF = ROOT.parent / "shared" / "data" / "ufsc-beam-hammer.uff"
TOLERANCES = {"fn_hz": 1e-6, "zeta": 1e-4, "fn_std_hz": 1e-2, "zeta_std": 1e-2}


def take(out: Path, seeds: list[int], families: list[str] | None, real: bool,
         package_root: Path) -> None:
    sys.path.insert(0, str(ROOT))
    import tests  # noqa: F401  (this checkout's test helpers, bound before package_root)

    sys.path.insert(0, str(package_root))
    from ema_pipeline import io
    from ema_pipeline.identification import identify
    from tests import hardcases

    def one(frf, band_hz=None) -> dict:
        if frf.n_out == 1 and frf.n_in > 1:
            frf = frf.reciprocal()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = identify(frf, band_hz=band_hz)
        out = {k: np.asarray(getattr(res.modes, k), dtype=float).tolist() for k in TOLERANCES}
        # the resonances the FRFs show with no mode kept (the warning's list)
        out["not_kept_hz"] = np.asarray(res.not_kept_hz, dtype=float).tolist()
        return out

    snap: dict[str, dict] = {}
    for family in families or list(hardcases.FAMILIES):
        for seed in seeds:
            case = hardcases.make_case(family, seed)
            snap[f"{family}/{seed}"] = one(case.frf, case.band_hz)
            print(f"{family}/{seed}: {len(snap[f'{family}/{seed}']['fn_hz'])} modes", flush=True)
    for name in ("genuine.uff", "smaller_tank.uff", "larger_tank.h5"):
        snap[f"paper/{name}"] = one(io.read_frf(ROOT / "raw_frf" / name))
    if real and REAL_UFF.exists():
        snap["real/no-band"] = one(io.read_frf(REAL_UFF))
    import ema_pipeline

    print(f"package: {ema_pipeline.__file__}")
    out.write_text(json.dumps(snap, indent=1))


def compare(a_path: Path, b_path: Path) -> int:
    a, b = json.loads(a_path.read_text()), json.loads(b_path.read_text())
    bad = 0
    for key in sorted(set(a) | set(b)):
        if key not in a or key not in b:
            print(f"{key}: only in {'after' if key in b else 'before'}")
            bad += 1
            continue
        if len(a[key]["fn_hz"]) != len(b[key]["fn_hz"]):
            print(f"{key}: {len(a[key]['fn_hz'])} -> {len(b[key]['fn_hz'])} modes "
                  f"{np.round(a[key]['fn_hz'], 3).tolist()} -> {np.round(b[key]['fn_hz'], 3)}")
            bad += 1
            continue
        worst = {}
        for col, tol in TOLERANCES.items():
            x, y = np.asarray(a[key][col], float), np.asarray(b[key][col], float)
            with np.errstate(invalid="ignore", divide="ignore"):
                rel = np.abs(y - x) / np.maximum(np.abs(x), 1e-300)
            rel = np.where(np.isnan(x) & np.isnan(y), 0.0, rel)
            worst[col] = float(np.nanmax(rel, initial=0.0))
            if worst[col] > tol:
                bad += 1
        flag = "CHANGED" if any(worst[c] > t for c, t in TOLERANCES.items()) else "ok"
        nk_a, nk_b = a[key].get("not_kept_hz"), b[key].get("not_kept_hz")
        if nk_a is not None and nk_b is not None and (
                len(nk_a) != len(nk_b) or not np.allclose(nk_a, nk_b, rtol=TOLERANCES["fn_hz"])):
            flag += f" not_kept {np.round(nk_a, 2).tolist()} -> {np.round(nk_b, 2).tolist()}"
            bad += 1
        print(f"{key}: {flag} " + " ".join(f"{c}={v:.1e}" for c, v in worst.items()))
    print(f"{len(set(a) | set(b))} cases, {bad} outside tolerance {TOLERANCES}")
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("take")
    t.add_argument("out", type=Path)
    t.add_argument("--seeds", default="100-101")
    t.add_argument("--families", default=None, help="comma-separated; default all")
    t.add_argument("--real", action="store_true", help="also the measured beam (no band)")
    t.add_argument("--package-root", type=Path, default=ROOT)
    c = sub.add_parser("compare")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    args = ap.parse_args(argv)
    if args.cmd == "take":
        fams = args.families.split(",") if args.families else None
        take(args.out, seed_list(args.seeds), fams, args.real, args.package_root.resolve())
        return 0
    return compare(args.before, args.after)


if __name__ == "__main__":
    raise SystemExit(main())
