"""Check a change that may move identified numbers against the rules of a speed change.

The rules (README "Speed", ``docs/validation.md``): detection unchanged over
the hard-case families at three seed ranges, the paper files, the measured
beam (no band and the four bands of the band-consistency test) and the pyFRF
recording; every f and zeta moved by at most 0.25 of its own sigma, with a
median of at most 0.05 sigma; the sigma coverage of every family within its
goals (90-98 % within 2 sigma, p68 0.75-1.35). And under a last-bit change of
the input (FRFs times 1 + 1e-12 e): every mode not marked doubtful within
0.1 sigma (or 0.01 Hz), every mode that changes more doubtful in both answers.

Run from the repository root::

    # the old code (a worktree of the old commit) and the new, same cases
    python benchmarks/speed_rules.py take before.json --package-root ../old
    python benchmarks/speed_rules.py take after.json
    python benchmarks/speed_rules.py compare before.json after.json
    # the 1e-12 rule: the same code, the input changed (three draws)
    python benchmarks/speed_rules.py take draw1.json --perturb 1
    python benchmarks/speed_rules.py compare after.json draw1.json --last-bits

``take`` identifies every case at the defaults and stores each mode's f, zeta,
their sigmas and whether it is doubtful, with the families' errors against
the truth (as ``eval_identification.score_case`` computes them). ``compare``
prints the table of detection, shifts in sigma and coverage before and after.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from seed_ranges import seed_list

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SHARED = ROOT.parent / "shared" / "data"
BEAM_BANDS = (None, (5.0, 400.0), (5.0, 790.0), (100.0, 400.0), (250.0, 700.0))
SEED_RANGES = "100-101,200-201,300-301"


def take(out_path: Path, seeds: list[int], perturb: int | None, package_root: Path,
         families: list[str] | None) -> None:
    sys.path.insert(0, str(package_root))
    import ema_pipeline  # first: the helpers below put this checkout on the path

    if Path(ema_pipeline.__file__).resolve().parents[1] != package_root:
        raise SystemExit(f"ema_pipeline imported from {ema_pipeline.__file__}, "
                         f"not {package_root}")
    sys.path.insert(1, str(ROOT))  # the tests package (after the package under test)
    sys.path.insert(0, str(HERE))
    import eval_identification as ev
    from bench_identification import simulate_paper_test

    from ema_pipeline import io
    from ema_pipeline.identification import identify
    from ema_pipeline.identification.result import doubtful_modes
    from tests import hardcases

    rng = np.random.default_rng(perturb) if perturb is not None else None

    def one(frf, band_hz=None) -> dict:
        if rng is not None:
            frf = replace(frf, H=frf.H * (1 + 1e-12 * rng.standard_normal(frf.H.shape)))
        if frf.n_out == 1 and frf.n_in > 1:
            frf = frf.reciprocal()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = identify(frf, band_hz=band_hz)
        m = res.modes
        return {"fn_hz": np.asarray(m.fn_hz, float).tolist(),
                "zeta": np.asarray(m.zeta, float).tolist(),
                "fn_std_hz": np.asarray(m.fn_std_hz, float).tolist(),
                "zeta_std": np.asarray(m.zeta_std, float).tolist(),
                "doubtful": np.asarray(doubtful_modes(res), bool).tolist()}

    snap: dict[str, dict] = {}
    for family in families or list(hardcases.ALL_FAMILIES):
        for seed in seeds:
            case = hardcases.make_case(family, seed)
            row = one(case.frf, case.band_hz)
            score = ev.score_case(case, {k: np.asarray(v) for k, v in row.items()})
            row.update(family=family, rf=score["rf"], rz=score["rz"],
                       missed=score["missed"], spurious=score["spurious"])
            snap[f"{family}/{seed}"] = row
            print(f"{family}/{seed}: {len(row['fn_hz'])} modes", flush=True)
    for config in ("genuine", "smaller_tank", "larger_tank"):
        for seed in range(4):
            snap[f"paper/{config}_{seed}"] = one(simulate_paper_test(config, seed=seed))
    for name in ("genuine.uff", "smaller_tank.uff", "larger_tank.h5"):
        snap[f"paper/raw_frf/{name}"] = one(io.read_frf(ROOT / "raw_frf" / name))
    beam = SHARED / "ufsc-beam-hammer.uff"
    if beam.exists():
        frf = io.read_frf(beam)
        for band in BEAM_BANDS:
            snap[f"beam/{band}"] = one(frf, band)
    recording = SHARED / "pyfrf-impact.uff"
    if recording.exists():
        with tempfile.TemporaryDirectory() as tmp:
            h5 = Path(tmp) / "pyfrf.h5"
            env_path = str(package_root)
            subprocess.run([sys.executable, "-m", "ema_pipeline", "frf", str(recording),
                            "--out", str(h5), "--quiet"], check=True,
                           env={**__import__("os").environ, "PYTHONPATH": env_path})
            snap["recording/pyfrf"] = one(io.read_frf(h5))
    print(f"package: {ema_pipeline.__file__}", flush=True)
    out_path.write_text(json.dumps(snap, indent=1))


def pair_modes(fa: np.ndarray, fb: np.ndarray, sa: np.ndarray) -> list[tuple[int, int]]:
    """One-to-one pairs of the modes of two answers: nearest frequencies within
    5 sigma of the first answer or 1e-4 relative, whichever is larger."""
    from scipy.optimize import linear_sum_assignment

    if fa.size == 0 or fb.size == 0:
        return []
    tol = np.maximum(5 * np.nan_to_num(sa, nan=0.0), 1e-4 * fa)
    d = np.abs(fb[None, :] - fa[:, None]) / tol[:, None]
    rows, cols = linear_sum_assignment(np.where(d <= 1, d, 1e6))
    return [(int(i), int(j)) for i, j in zip(rows, cols, strict=True) if d[i, j] <= 1]


def coverage(rows: list[dict], key: str) -> tuple[float, float]:
    x = np.array([v for r in rows for v in r[key]], dtype=float)
    if x.size == 0:
        return float("nan"), float("nan")
    return float(np.mean(x <= 2)), float(np.percentile(x, 68))


def compare(a_path: Path, b_path: Path, last_bits: bool) -> int:
    a, b = json.loads(a_path.read_text()), json.loads(b_path.read_text())
    shifts: list[float] = []
    steady: list[tuple[float, float]] = []  # modes not doubtful: (shift in sigma, |df| Hz)
    detection: list[str] = []
    flips: list[str] = []
    large: list[str] = []
    n_modes = 0
    for key in sorted(set(a) & set(b)):
        x, y = a[key], b[key]
        fa, fb = np.asarray(x["fn_hz"]), np.asarray(y["fn_hz"])
        sa = np.asarray(x["fn_std_hz"])
        pairs = pair_modes(fa, fb, sa)
        n_modes += fa.size
        da = np.asarray(x["doubtful"], bool)
        db = np.asarray(y["doubtful"], bool)
        matched_a = {i for i, _ in pairs}
        matched_b = {j for _, j in pairs}
        lost = [i for i in range(fa.size) if i not in matched_a]
        new = [j for j in range(fb.size) if j not in matched_b]
        if lost or new:
            detection.append(f"{key}: lost {np.round(fa[lost], 2).tolist()} "
                             f"new {np.round(fb[new], 2).tolist()}")
            for i in lost:  # a changed answer of a doubtful mode (the 1e-12 rule)
                flips.append(f"{key} {fa[i]:.2f} Hz lost, doubtful before: {bool(da[i])}")
            for j in new:
                flips.append(f"{key} {fb[j]:.2f} Hz new, doubtful after: {bool(db[j])}")
        for i, j in pairs:
            sf = abs(fb[j] - fa[i]) / x["fn_std_hz"][i]
            sz = abs(y["zeta"][j] - x["zeta"][i]) / x["zeta_std"][i]
            s = float(np.nanmax([sf, sz]))
            shifts.extend([sf, sz])
            if not (da[i] or db[j]):
                steady.append((s, abs(fb[j] - fa[i])))
            if last_bits and s > 0.1 and abs(fb[j] - fa[i]) > 0.01:
                entry = (f"{key} {fa[i]:.2f} Hz moved {s:.2f} sigma, doubtful "
                         f"{bool(da[i])}/{bool(db[j])}")
                (flips if da[i] and db[j] else large).append(entry)
            elif not last_bits and s > 0.25:
                large.append(f"{key} {fa[i]:.2f} Hz moved {s:.2f} sigma")
    sh = np.asarray(shifts, dtype=float)
    sh = sh[np.isfinite(sh)]
    print(f"{len(set(a) & set(b))} cases, {n_modes} modes before")
    print(f"detection changes: {len(detection)}")
    for d in detection:
        print(f"  {d}")
    print(f"shift in sigma (f and zeta): max {sh.max(initial=0):.3g}, "
          f"median {np.median(sh) if sh.size else 0:.3g}, "
          f"above {'0.1' if last_bits else '0.25'}: {len(large)}")
    for d in large:
        print(f"  {d}")
    if last_bits:
        st = np.array(steady, dtype=float).reshape(-1, 2)
        over = st[st[:, 0] > 0.1]
        largest = np.max(over[:, 1], initial=0)
        print(f"modes not doubtful: {st.shape[0]}, max shift {np.nanmax(st[:, 0], initial=0):.3g} "
              f"sigma; {over.shape[0]} above 0.1 sigma, all within 0.01 Hz: "
              f"{bool(largest <= 0.01)} (largest {largest:.4f} Hz)")
        print(f"changes of doubtful modes (allowed when doubtful in both answers): {len(flips)}")
        for d in flips:
            print(f"  {d}")
    families = sorted({v["family"] for v in a.values() if "family" in v})
    if families:
        print(f"{'family':<18}{'modes':>6}{'missed':>8}{'spur':>6}{'f<=2s':>14}{'p68 f':>14}"
              f"{'z<=2s':>14}{'p68 z':>14}")
        for fam in families:
            ra = [v for v in a.values() if v.get("family") == fam]
            rb = [v for v in b.values() if v.get("family") == fam]
            cells = []
            for key in ("rf", "rz"):
                (ca, pa), (cb, pb) = coverage(ra, key), coverage(rb, key)
                cells += [f"{100 * ca:.0f}->{100 * cb:.0f}%", f"{pa:.2f}->{pb:.2f}"]
            miss = f"{sum(r['missed'] for r in ra)}->{sum(r['missed'] for r in rb)}"
            spur = f"{sum(r['spurious'] for r in ra)}->{sum(r['spurious'] for r in rb)}"
            print(f"{fam:<18}{sum(len(r['fn_hz']) for r in ra):>6}{miss:>8}{spur:>6}"
                  + "".join(f"{c:>14}" for c in cells))
    bad = bool(detection and not last_bits) or bool(large)
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("take")
    t.add_argument("out", type=Path)
    t.add_argument("--seeds", default=SEED_RANGES, help=f"default {SEED_RANGES}")
    t.add_argument("--families", default=None, help="comma-separated; default all")
    t.add_argument("--perturb", type=int, default=None, metavar="DRAW",
                   help="FRFs times 1 + 1e-12 e, e standard normal of this seed")
    t.add_argument("--package-root", type=Path, default=ROOT)
    c = sub.add_parser("compare")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    c.add_argument("--last-bits", action="store_true",
                   help="the 1e-12 rule: 0.1 sigma, changes only of doubtful modes")
    args = ap.parse_args(argv)
    if args.cmd == "take":
        fams = args.families.split(",") if args.families else None
        take(args.out, seed_list(args.seeds), args.perturb, args.package_root.resolve(), fams)
        return 0
    return compare(args.before, args.after, args.last_bits)


if __name__ == "__main__":
    raise SystemExit(main())
