"""Evaluate automatic identification on the hard cases of ``tests/hardcases.py``
and on the measured beam (issue 11).

Run from the repository root::

    python benchmarks/eval_identification.py                 # all families, 8 seeds
    python benchmarks/eval_identification.py --seeds 100-119 --families dense_log,impact
    python benchmarks/eval_identification.py --real --paper  # measured beam, paper timing
    python benchmarks/eval_identification.py --impl no-window-search  # that option's cost

For every family: true modes, missed and spurious (a match is
|f_id - f_true| <= (zeta_true + 0.005) f_true, one-to-one by minimum total
distance), and for the matched modes the fraction with |err| <= 2 sigma and the
68th percentile of |err| / sigma, for f_n and zeta separately (a missing sigma
counts as infinitely wrong), plus the mean time per file. The shapes of the
matched modes are compared with the true shapes at the identified response
DOFs (cases with at least 3 of them): the 10th percentile of the MAC and the fraction of
matched modes with a MAC below 0.95 (columns "MAC p10", "<.95"). With one or
two responses the column "1pk T/S" counts the modes marked doubtful
``pair_under_one_peak`` (close poles kept under one peak), true and spurious.

The single place that calls the identification is :func:`identify_case`; adapt
it when the signature changes (``identify(frf, options)``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment
from seed_ranges import seed_list

ROOT = Path(__file__).resolve().parents[1]
# this checkout's package, not whichever ema_pipeline is installed
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from ema_pipeline.data import FRFSet  # noqa: E402
from tests import hardcases  # noqa: E402

PUBLISHED_HZ = np.array([17.212, 68.840, 118.878, 155.391, 226.395, 235.230, 265.219,
                         362.805, 414.118, 567.539, 602.292, 643.435, 707.200, 740.567])
REAL_UFF = ROOT.parent / "shared" / "data" / "ufsc-beam-hammer.uff"


# --------------------------------------------------------------------------- the one call
def identify_case(frf: FRFSet, band_hz: tuple[float, float] | None,
                  impl: str = "current") -> dict[str, np.ndarray]:
    """Identify at DEFAULTS (only the band) and return fn_hz, zeta, fn_std_hz,
    zeta_std, the shapes and their nodes, and ``pair_marked`` (bool, each mode:
    doubtful ``pair_under_one_peak``).

    A roving set (1 response, several references) is transposed by reciprocity
    first, as the CLI does.
    """
    if frf.n_out == 1 and frf.n_in > 1:
        frf = frf.reciprocal()
    from ema_pipeline.identification import doubtful_reasons, identify

    # "no-window-search": the option that skips a dense band's window searches
    res = identify(frf, band_hz=band_hz, window_searches=impl != "no-window-search")
    m = res.modes
    return {"fn_hz": np.asarray(m.fn_hz), "zeta": np.asarray(m.zeta),
            "fn_std_hz": np.asarray(m.fn_std_hz), "zeta_std": np.asarray(m.zeta_std),
            "shapes": np.asarray(m.shapes),
            "nodes": np.array([d.node for d in m.dofs], dtype=int),
            "pair_marked": np.array(["pair_under_one_peak" in r.split(";")
                                     for r in doubtful_reasons(res)], dtype=bool)}


def shape_macs(case: hardcases.HardCase, out: dict[str, np.ndarray],
               pairs: list[tuple[int, int]]) -> list[float]:
    """MAC of each matched mode's identified shape with the true shape at the
    identified response DOFs (the hard cases number their points node k + 1
    for row k of ``case.shapes``); empty below 3 response DOFs, where a MAC
    says little."""
    nodes = out.get("nodes", np.zeros(0, dtype=int))
    if nodes.size < 3 or "shapes" not in out:
        return []
    from ema_pipeline.modal import mac_pairs

    rows = nodes - 1
    true = case.shapes[rows][:, [i for i, _ in pairs]]
    ident = out["shapes"][:, [j for _, j in pairs]]
    return [float(x) for x in mac_pairs(ident, true)]


# --------------------------------------------------------------------------- scoring
def match_modes(f_true: np.ndarray, z_true: np.ndarray, f_id: np.ndarray) -> list[tuple[int, int]]:
    """One-to-one pairs (i_true, j_id) with |f_id - f_true| <= (zeta_true + 0.005) f_true,
    minimising the total normalised distance."""
    if f_true.size == 0 or f_id.size == 0:
        return []
    tol = (z_true + 0.005) * f_true
    d = np.abs(f_id[None, :] - f_true[:, None]) / tol[:, None]
    cost = np.where(d <= 1, d, 1e6)
    rows, cols = linear_sum_assignment(cost)
    return [(int(i), int(j)) for i, j in zip(rows, cols, strict=True) if d[i, j] <= 1]


def score_case(case: hardcases.HardCase, out: dict[str, np.ndarray]) -> dict:
    pairs = match_modes(case.fn_hz, case.zeta, out["fn_hz"])
    rf, rz = [], []
    for i, j in pairs:
        ef = out["fn_hz"][j] - case.fn_hz[i]
        ez = out["zeta"][j] - case.zeta[i]
        sf, sz = out["fn_std_hz"][j], out["zeta_std"][j]
        rf.append(abs(ef) / sf if np.isfinite(sf) and sf > 0 else np.inf)
        rz.append(abs(ez) / sz if np.isfinite(sz) and sz > 0 else np.inf)
    macs = shape_macs(case, out, pairs) if pairs else []
    matched_true = {i for i, _ in pairs}
    matched_id = {j for _, j in pairs}
    marked = np.asarray(out.get("pair_marked", np.zeros(out["fn_hz"].size, bool)), bool)
    return {
        "n_true": int(case.fn_hz.size),
        "missed": int(case.fn_hz.size - len(pairs)),
        "spurious": int(out["fn_hz"].size - len(pairs)),
        "missed_hz": [float(case.fn_hz[i]) for i in range(case.fn_hz.size)
                      if i not in matched_true],
        "spurious_hz": [float(out["fn_hz"][j]) for j in range(out["fn_hz"].size)
                        if j not in matched_id],
        "marked_true_hz": [float(out["fn_hz"][j]) for j in sorted(matched_id) if marked[j]],
        "marked_spurious_hz": [float(out["fn_hz"][j]) for j in range(out["fn_hz"].size)
                               if j not in matched_id and marked[j]],
        "rf": rf,
        "rz": rz,
        "mac": macs,
    }


def run_family(family: str, seeds: list[int], impl: str, verbose: bool = False,
               complex_phase_deg: float = 0.0) -> dict:
    rows, times, errors = [], [], []
    for s in seeds:
        case = hardcases.make_case(family, s, complex_phase_deg)
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = identify_case(case.frf, case.band_hz, impl)
        except Exception as exc:  # a crash counts as all modes missed
            errors.append(f"{case.name}: {type(exc).__name__}: {exc}")
            out = {k: np.zeros(0) for k in ("fn_hz", "zeta", "fn_std_hz", "zeta_std")}
        times.append(time.perf_counter() - t0)
        sc = score_case(case, out)
        sc["seed"] = s
        rows.append(sc)
        if verbose and (sc["missed"] or sc["spurious"]):
            print(f"  {case.name}: missed {np.round(sc['missed_hz'], 2)} "
                  f"spurious {np.round(sc['spurious_hz'], 2)}", flush=True)
    rf = np.array([x for r in rows for x in r["rf"]])
    rz = np.array([x for r in rows for x in r["rz"]])

    def stats(x: np.ndarray) -> tuple[float, float]:
        if x.size == 0:
            return np.nan, np.nan
        return float(np.mean(x <= 2)), float(np.percentile(x, 68))

    cf, pf = stats(rf)
    cz, pz = stats(rz)
    macs = np.array([x for r in rows for x in r["mac"]])
    return {
        "family": family, "files": len(seeds),
        "true": sum(r["n_true"] for r in rows),
        "missed": sum(r["missed"] for r in rows),
        "spurious": sum(r["spurious"] for r in rows),
        "marked_true": sum(len(r["marked_true_hz"]) for r in rows),
        "marked_spurious": sum(len(r["marked_spurious_hz"]) for r in rows),
        "cov_f": cf, "p68_f": pf, "cov_z": cz, "p68_z": pz,
        "mac_p10": float(np.percentile(macs, 10)) if macs.size else np.nan,
        "mac_below_095": float(np.mean(macs < 0.95)) if macs.size else np.nan,
        "time_s": float(np.mean(times)), "errors": errors, "rows": rows,
    }


def print_table(results: list[dict]) -> None:
    head = (f"{'family':<14}{'files':>6}{'true':>6}{'missed':>8}{'spur':>6}"
            f"{'f<=2s':>8}{'p68 f':>8}{'z<=2s':>8}{'p68 z':>8}{'MAC p10':>8}{'<.95':>6}"
            f"{'1pk T/S':>9}{'s/file':>8}")
    print(head)
    print("-" * len(head))
    tot = {"true": 0, "missed": 0, "spurious": 0}
    for r in results:
        for k in tot:
            tot[k] += r[k]
        print(f"{r['family']:<14}{r['files']:>6}{r['true']:>6}{r['missed']:>8}{r['spurious']:>6}"
              f"{100 * r['cov_f']:>7.0f}%{r['p68_f']:>8.2f}{100 * r['cov_z']:>7.0f}%"
              f"{r['p68_z']:>8.2f}{r['mac_p10']:>8.3f}{100 * r['mac_below_095']:>5.0f}%"
              f"{str(r['marked_true']) + '/' + str(r['marked_spurious']):>9}"
              f"{r['time_s']:>8.2f}")
        for e in r["errors"]:
            print(f"    ERROR {e}")
    print(f"{'total':<14}{'':>6}{tot['true']:>6}{tot['missed']:>8}{tot['spurious']:>6}")


# --------------------------------------------------------------------------- real data
def run_real(impl: str) -> dict:
    from ema_pipeline import io

    frf = io.read_frf(REAL_UFF)
    t0 = time.perf_counter()
    out = identify_case(frf, None, impl)
    dt = time.perf_counter() - t0
    f = out["fn_hz"]
    found = [float(p) for p in PUBLISHED_HZ if np.any(np.abs(f - p) <= 1.0)]
    other = [float(x) for x in f if x < 800 and not np.any(np.abs(PUBLISHED_HZ - x) <= 1.0)]
    print(f"measured beam ({impl}): {len(found)} of {PUBLISHED_HZ.size} published modes "
          f"within 1 Hz, {len(other)} other below 800 Hz, {dt:.1f} s")
    print(f"  identified: {np.round(f, 1).tolist()}")
    print(f"  missing published: {sorted(set(PUBLISHED_HZ.tolist()) - set(found))}")
    print(f"  other: {np.round(other, 1).tolist()}")
    return {"found": found, "other": other, "time_s": dt, "fn_hz": f.tolist()}


def run_paper(impl: str, repeats: int = 3) -> dict:
    """Time at defaults on the paper's 2 FRFs, and peak memory at max-order 400."""
    import tracemalloc

    from ema_pipeline import io

    frf = io.read_frf(ROOT / "raw_frf" / "genuine.uff")
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = identify_case(frf, None, impl)
        times.append(time.perf_counter() - t0)
    print(f"paper genuine.uff ({impl}): {min(times):.2f} s (best of {repeats}), "
          f"f = {np.round(out['fn_hz'], 3).tolist()}")
    res = {"time_s": min(times)}
    import ema_pipeline

    print(f"  (package: {ema_pipeline.__file__})")
    tracemalloc.start()
    from ema_pipeline.identification import identify

    identify(frf, max_order=400)
    peak = tracemalloc.get_traced_memory()[1] / 2**30
    tracemalloc.stop()
    print(f"  peak traced memory at max-order 400: {peak:.2f} GiB")
    res["peak_gib_400"] = peak
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--families", default=",".join(hardcases.FAMILIES))
    ap.add_argument("--seeds", default="100-107", help="e.g. 100-107 or 1,5,9")
    ap.add_argument("--impl", choices=["current", "no-window-search"], default="current",
                    help="no-window-search: identify with window_searches=False")
    ap.add_argument("--real", action="store_true", help="also the measured beam")
    ap.add_argument("--paper", action="store_true", help="also timing/memory on raw_frf")
    ap.add_argument("--no-families", action="store_true")
    ap.add_argument("--complex-phase", type=float, default=0.0, metavar="DEG",
                    help="complex modes: each shape entry turned by a random phase within "
                         "+-DEG degrees (hardcases.complex_shapes); default 0, real modes")
    ap.add_argument("--json", help="write all numbers to this JSON file")
    ap.add_argument("-v", "--verbose", action="store_true", help="list missed/spurious modes")
    args = ap.parse_args(argv)
    report: dict = {"impl": args.impl, "seeds": args.seeds}
    if not args.no_families:
        results = []
        for fam in args.families.split(","):
            if args.verbose:
                print(f"[{fam}]", flush=True)
            results.append(run_family(fam, seed_list(args.seeds), args.impl, args.verbose,
                                      args.complex_phase))
        print_table(results)
        report["families"] = results
    if args.real:
        report["real"] = run_real(args.impl)
    if args.paper:
        report["paper"] = run_paper(args.impl)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
