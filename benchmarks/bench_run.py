"""Benchmark: ``ema-pipeline run`` against ``ema-pipeline identify`` on the same files.

Issue 14's target: the whole study with its report (identification of the three
example configurations, modal added mass, FE update, tables, HDF5 store,
``report.html`` with its figures) takes at most twice the time of identifying
the same three FRF files with ``ema-pipeline identify``.

Each command runs ``--repeat`` times (default 3) in a fresh Python process,
alternating; the best wall time and the best CPU time (user + system of the
child process, which load from other processes on the machine does not
inflate) of each are compared; the exit status is 0 when the CPU-time ratio is
within the target and the report below 400 KB. Also runs ``run --no-figures`` to show what the
report's figures cost, and prints the size of ``report.html``.

Usage: ``python benchmarks/bench_run.py [--raw raw_frf] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def timed(args: list[str]) -> tuple[float, float]:
    """(wall s, CPU s) of ``python -m ema_pipeline.cli ARGS`` in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "ema_pipeline.cli", *args], check=True, cwd=REPO,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=dict(os.environ, PYTHONPATH=str(REPO)))
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--raw", type=Path, default=REPO / "raw_frf")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    files = [str(args.raw / n) for n in ("genuine.uff", "larger_tank.h5", "smaller_tank.uff")]
    with tempfile.TemporaryDirectory(prefix="bench_run-") as tmp:
        commands = {
            "identify (3 files)": ["identify", *files, "--out", f"{tmp}/identify", "--quiet"],
            "run": ["run", "--raw", str(args.raw), "--results", f"{tmp}/results", "--quiet"],
            "run --no-figures": ["run", "--raw", str(args.raw), "--results", f"{tmp}/plain",
                                 "--quiet", "--no-figures"],
        }
        best = {name: [float("inf"), float("inf")] for name in commands}
        for _ in range(args.repeat):
            for name, cmd in commands.items():
                wall, cpu = timed(cmd)
                best[name] = [min(best[name][0], wall), min(best[name][1], cpu)]
        size = (Path(tmp) / "results" / "report.html").stat().st_size
    print(f"{'command':<22} {'wall s':>8} {'CPU s':>8}   (best of {args.repeat})")
    for name, (wall, cpu) in best.items():
        print(f"{name:<22} {wall:8.2f} {cpu:8.2f}")
    ident, run = best["identify (3 files)"], best["run"]
    ratio_wall, ratio_cpu = run[0] / ident[0], run[1] / ident[1]
    print(f"run / identify: {ratio_wall:.2f} (wall), {ratio_cpu:.2f} (CPU); target <= 2")
    print(f"report.html: {size / 1024:.0f} KiB (target < 400 KB)")
    return 0 if ratio_cpu <= 2 and size < 400_000 else 1


if __name__ == "__main__":
    sys.exit(main())
