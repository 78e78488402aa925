"""Band-to-band stability of the measured beam's mode shapes (issue 42, item 3).

Run from the repository root::

    python benchmarks/eval_band_shapes.py                  # defaults and three bands
    python benchmarks/eval_band_shapes.py --json out.json

The measured beam (``../shared/data/ufsc-beam-hammer.uff``, 30 FRFs of a
roving hammer) is identified at the defaults and in the narrower bands
10-130, 100-400 and 250-700 Hz, each with only the band given. Every mode of
the defaults within 1 Hz of a published frequency is paired with the mode of
each narrower band that holds it (at least 5 Hz inside the band) nearest in
frequency (within 1 Hz); for each pair the MAC of the two complex shapes
(``result.modes.shapes``, one row per hammer point, as the UFF 55 export
writes them), both MPCs and the change of f_n in standard deviations. The
first mode is also compared with a half sine along the beam: the hammer
points are two lines of points along it, numbers 2-16 and 19-33, and each
line gets sin(pi x), x = (node - 1) / 16 and (node - 18) / 16 (a value of
0.98 for the narrow band's shape).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout's package

from ema_pipeline import io  # noqa: E402
from ema_pipeline.modal import mac_pairs  # noqa: E402

REAL_UFF = ROOT.parent / "shared" / "data" / "ufsc-beam-hammer.uff"
PUBLISHED_HZ = np.array([17.212, 68.840, 118.878, 155.391, 226.395, 235.230, 265.219,
                         362.805, 414.118, 567.539, 602.292, 643.435, 707.200, 740.567])
BANDS_HZ = ((10.0, 130.0), (100.0, 400.0), (250.0, 700.0))


def identify_band(frf, band_hz: tuple[float, float] | None) -> dict:
    """f_n, its std, MPC, shapes and DOF numbers at ``band_hz`` (None: defaults)."""
    from ema_pipeline.identification import identify

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = identify(frf, band_hz=band_hz)
    return {"fn_hz": np.asarray(res.modes.fn_hz), "fn_std_hz": np.asarray(res.modes.fn_std_hz),
            "zeta": np.asarray(res.modes.zeta), "mpc": np.asarray(res.mpc),
            "shapes": np.asarray(res.modes.shapes),
            "nodes": np.array([d.node for d in res.modes.dofs]),
            "time_s": time.perf_counter() - t0}


def half_sine_mac(shape: np.ndarray, nodes: np.ndarray) -> float:
    """MAC of ``shape`` with a half sine along each of the two lines of points."""
    x = np.where(nodes <= 17, nodes - 1.0, nodes - 18.0) / 16.0
    ref = np.sin(np.pi * x)
    return float(mac_pairs(shape[:, None], ref[:, None].astype(complex))[0])


def compare(default: dict, bands: dict[tuple[float, float], dict]) -> list[dict]:
    """The pairs (a default mode near a published one, a narrower band's mode)."""
    rows = []
    for j, f in enumerate(default["fn_hz"]):
        if not np.any(np.abs(PUBLISHED_HZ - f) <= 1.0):
            continue
        for band, out in bands.items():
            if not band[0] + 5.0 <= f <= band[1] - 5.0 or out["fn_hz"].size == 0:
                continue
            k = int(np.argmin(np.abs(out["fn_hz"] - f)))
            if abs(out["fn_hz"][k] - f) > 1.0:
                rows.append({"fn_hz": float(f), "band_hz": band, "found": False})
                continue
            assert np.array_equal(out["nodes"], default["nodes"])
            m = float(mac_pairs(default["shapes"][:, [j]], out["shapes"][:, [k]])[0])
            s = np.hypot(default["fn_std_hz"][j], out["fn_std_hz"][k])
            rows.append({"fn_hz": float(f), "band_hz": band, "found": True,
                         "fn_band_hz": float(out["fn_hz"][k]), "mac": m,
                         "mpc_default": float(default["mpc"][j]), "mpc_band": float(out["mpc"][k]),
                         "df_sigma": float((out["fn_hz"][k] - f) / s) if s > 0 else np.inf,
                         "half_sine_default": half_sine_mac(default["shapes"][:, j],
                                                            default["nodes"]),
                         "half_sine_band": half_sine_mac(out["shapes"][:, k], out["nodes"])})
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write all numbers to this JSON file")
    args = ap.parse_args(argv)
    if not REAL_UFF.is_file():
        print(f"measured beam not available at {REAL_UFF}")
        return 1
    frf = io.read_frf(REAL_UFF)
    default = identify_band(frf, None)
    bands = {b: identify_band(frf, b) for b in BANDS_HZ}
    rows = compare(default, bands)
    print(f"defaults: {default['fn_hz'].size} modes ({default['time_s']:.1f} s): "
          f"{np.round(default['fn_hz'], 2).tolist()}")
    for b, out in bands.items():
        print(f"{b[0]:g}-{b[1]:g} Hz: {out['fn_hz'].size} modes: "
              f"{np.round(out['fn_hz'], 2).tolist()}")
    print(f"{'f default':>10}{'band':>10}{'f band':>9}{'MAC':>7}{'MPC def':>9}{'MPC band':>9}"
          f"{'df/sig':>8}")
    for r in rows:
        band = f"{r['band_hz'][0]:g}-{r['band_hz'][1]:g}"
        if not r["found"]:
            print(f"{r['fn_hz']:>10.2f}{band:>10}  not found")
            continue
        print(f"{r['fn_hz']:>10.2f}{band:>10}{r['fn_band_hz']:>9.2f}{r['mac']:>7.3f}"
              f"{r['mpc_default']:>9.2f}{r['mpc_band']:>9.2f}{r['df_sigma']:>8.2f}")
    found = [r for r in rows if r["found"]]
    low = [r for r in found if r["mac"] < 0.95]
    print(f"{len(low)} of {len(found)} pairs with MAC < 0.95; min MAC "
          f"{min((r['mac'] for r in found), default=np.nan):.3f}")
    first = [r for r in found if abs(r["fn_hz"] - PUBLISHED_HZ[0]) <= 1.0]
    for r in first:
        print(f"mode 1: MAC with a half sine {r['half_sine_default']:.3f} (defaults), "
              f"{r['half_sine_band']:.3f} ({r['band_hz'][0]:g}-{r['band_hz'][1]:g} Hz)")
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"default_fn_hz": default["fn_hz"].tolist(),
             "default_fn_std_hz": default["fn_std_hz"].tolist(),
             "default_zeta": default["zeta"].tolist(), "default_mpc": default["mpc"].tolist(),
             "bands": {f"{b[0]:g}-{b[1]:g}": out["fn_hz"].tolist() for b, out in bands.items()},
             "pairs": rows}, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
