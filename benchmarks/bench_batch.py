"""Benchmark of ``ema-pipeline batch``: throughput and peak memory.

Generates simulated impact tests of the paper's cantilever into a temporary
folder, then runs the batch (each run in a fresh Python process, through
:func:`ema_pipeline.pipeline.batch.run_batch`):

* ``--files`` files (default 200) with ``--workers 1`` and ``--workers 2``:
  files/s (wall time of the batch including worker start-up) and the speed-up
  (target: at least 1.7x with 2 workers);
* ``--small`` files (default 20) with 2 workers: peak memory against the big
  run (target: within 20 %, memory does not grow with the number of files).

Peak memory is the high-water resident set of the batch's main process
(``getrusage(RUSAGE_SELF)``), of its largest worker process
(``getrusage(RUSAGE_CHILDREN)``), and, with psutil, the largest sum over the
whole process tree, sampled every 20 ms.

The files are the default simulated test (2 accelerances, 4 averages, H1,
exponential window) cropped to 2-400 Hz (3260 lines, three modes) so that the
benchmark takes a few minutes; a third each HDF5, ASCII UFF-58 and binary
UFF-58, in 10 sub-folders.

The speed-up means something only when the CPUs are free: before each run
the benchmark waits (``--wait-idle`` seconds at most) until enough CPUs are
idle, and the table shows how many were.

Usage: ``python benchmarks/bench_batch.py [--files 200] [--small 20]
[--workers 1 2] [--keep DIR] [--wait-idle SECONDS]``
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

FILE_BAND_HZ = (2.0, 400.0)
IDENT_BAND_HZ = (5.0, 395.0)
CONFIGURATIONS = ("genuine", "larger_tank", "smaller_tank")
FORMATS = (("h5", ".h5"), ("uff", ".uff"), ("uff-binary", ".uff"))


def generate(folder: Path, n: int) -> None:
    """``n`` simulated files (distinct seeds), spread over 10 sub-folders."""
    from ema_pipeline import io
    from ema_pipeline.pipeline.simulate import simulate_paper_test

    for k in range(n):
        configuration = CONFIGURATIONS[k % len(CONFIGURATIONS)]
        fmt, suffix = FORMATS[(k // len(CONFIGURATIONS)) % len(FORMATS)]
        frf = simulate_paper_test(configuration, seed=1000 + k)
        path = folder / f"day{k % 10:02d}" / f"test{k:04d}_{configuration}{suffix}"
        path.parent.mkdir(parents=True, exist_ok=True)
        io.write_frf(frf.band(*FILE_BAND_HZ), path, fmt)


def measure(folder: Path, out: Path, workers: int) -> dict[str, Any]:
    """Run the batch in this process; report timing and peak memory (used in
    the child process started by :func:`run_measured`)."""
    from ema_pipeline.identification.options import IdentificationOptions
    from ema_pipeline.pipeline.batch import run_batch

    report = run_batch(
        folder,
        out,
        options=IdentificationOptions(band_hz=IDENT_BAND_HZ),
        workers=workers,
        scheduler=None,
        force=False,
        progress=False,
    )
    kib = 1024 if sys.platform != "darwin" else 1  # ru_maxrss: KiB on Linux, bytes on macOS
    me = resource.getrusage(resource.RUSAGE_SELF)
    return {
        "parent_cpu_s": me.ru_utime + me.ru_stime,
        "files": report.n_files,
        "ok": report.n_ok,
        "failed": report.n_failed,
        "seconds": report.seconds,
        "parent_peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * kib / 2**20,
        "worker_peak_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * kib / 2**20,
        "summary": report.summary_line(),
    }


def _tree_rss_sampler(pid: int, peak: list[float], done: threading.Event) -> None:
    """Largest sum of RSS over the process ``pid`` and its descendants."""
    try:
        import psutil
    except ImportError:
        return
    try:
        root = psutil.Process(pid)
    except psutil.Error:
        return
    while not done.is_set():
        total = 0
        try:
            procs = [root, *root.children(recursive=True)]
        except psutil.Error:
            break
        for proc in procs:
            try:
                total += proc.memory_info().rss
            except psutil.Error:
                pass
        peak[0] = max(peak[0], total / 2**20)
        done.wait(0.02)


def idle_cpus(seconds: float = 1.0) -> float:
    """How many CPUs were idle over the last ``seconds`` (Linux /proc/stat; else nan)."""

    def sample() -> tuple[int, int]:
        fields = [int(v) for v in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
        return fields[3] + fields[4], sum(fields[:8])  # idle + iowait, total

    try:
        idle0, total0 = sample()
        time.sleep(seconds)
        idle1, total1 = sample()
    except (OSError, ValueError, IndexError):
        return float("nan")
    return (os.cpu_count() or 1) * (idle1 - idle0) / max(total1 - total0, 1)


def wait_until_idle(needed: float, limit_s: float) -> float:
    """Wait (up to ``limit_s``) until ``needed`` CPUs are idle; the idle CPUs."""
    deadline = time.monotonic() + limit_s
    idle = idle_cpus()
    while idle < needed and time.monotonic() < deadline:
        idle = idle_cpus(5.0)
    return idle


def run_measured(folder: Path, out: Path, workers: int) -> dict[str, Any]:
    """One batch run in a fresh Python process, with tree memory sampling."""
    cmd = [sys.executable, __file__, "--_measure", str(folder), str(out), str(workers)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    peak = [0.0]
    done = threading.Event()
    sampler = threading.Thread(target=_tree_rss_sampler, args=(proc.pid, peak, done))
    sampler.start()
    stdout, _ = proc.communicate()
    done.set()
    sampler.join()
    if proc.returncode != 0:
        raise SystemExit(f"batch run failed ({proc.returncode}): {stdout}")
    result = json.loads(stdout.strip().splitlines()[-1])
    result["tree_peak_mb"] = peak[0] if peak[0] > 0 else float("nan")
    result["workers"] = workers
    return result


def _percent(big: float, small: float) -> str:
    return f"{100 * (big - small) / small:+.1f} %"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--files", type=int, default=200, help="files in the big runs")
    parser.add_argument("--small", type=int, default=20, help="files in the small run")
    parser.add_argument(
        "--workers", type=int, nargs="+", default=[1, 2], help="worker counts to time"
    )
    parser.add_argument("--keep", type=Path, default=None, help="keep the files in this folder")
    parser.add_argument(
        "--wait-idle",
        type=float,
        default=600.0,
        metavar="SECONDS",
        help="before each run wait up to this long until the CPUs are idle (shared machines; "
        "0: do not wait)",
    )
    parser.add_argument("--_measure", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args._measure:
        folder, out, workers = args._measure
        print(json.dumps(measure(Path(folder), Path(out), int(workers))))
        return 0

    root = Path(tempfile.mkdtemp(prefix="bench_batch_")) if args.keep is None else args.keep
    root.mkdir(parents=True, exist_ok=True)
    try:
        big, small = root / "files_big", root / "files_small"
        t0 = time.perf_counter()
        if not big.is_dir():
            generate(big, args.files)
        if not small.is_dir():
            generate(small, args.small)
        n_lines = int(round((FILE_BAND_HZ[1] - FILE_BAND_HZ[0]) * 16384 / 2000)) + 1
        size_mb = sum(p.stat().st_size for p in big.rglob("*") if p.is_file()) / 2**20
        print(
            f"files: {args.files} (+{args.small}) simulated impact tests of the paper's cantilever "
            f"(genuine/larger_tank/smaller_tank, 2 accelerances, H1 of 4 averages), cropped to "
            f"{FILE_BAND_HZ[0]:g}-{FILE_BAND_HZ[1]:g} Hz (~{n_lines} lines, 3 modes); a third each "
            f"HDF5, ASCII and binary UFF-58; {size_mb:.1f} MB in all; identified in "
            f"{IDENT_BAND_HZ[0]:g}-{IDENT_BAND_HZ[1]:g} Hz; generated in "
            f"{time.perf_counter() - t0:.0f} s"
        )
        print(f"machine: {os.cpu_count()} CPUs")
        runs = []
        plan = [("big", big, w) for w in args.workers] + [("small", small, 2)]
        for kind, folder, workers in plan:
            out = root / f"out_{kind}_w{workers}"
            shutil.rmtree(out, ignore_errors=True)
            needed = min(workers + 1, os.cpu_count() or 1) - 0.2
            idle = wait_until_idle(needed, args.wait_idle) if args.wait_idle > 0 else idle_cpus()
            result = run_measured(folder, out, workers)
            result["idle_before"] = idle
            runs.append((kind, result))
        print()

        header = (
            "| files | workers | idle CPUs before | ok | failed | seconds | files/s "
            "| main process CPU s | main process peak MB | largest worker peak MB "
            "| process tree peak MB |"
        )
        print(header)
        print("|---" * 11 + "|")
        for _, r in runs:
            print(
                f"| {r['files']} | {r['workers']} | {r['idle_before']:.1f} | {r['ok']} "
                f"| {r['failed']} | {r['seconds']:.1f} | {r['files'] / r['seconds']:.2f} "
                f"| {r['parent_cpu_s']:.1f} | {r['parent_peak_mb']:.0f} "
                f"| {r['worker_peak_mb']:.0f} | {r['tree_peak_mb']:.0f} |"
            )
        print()
        by_workers = {r["workers"]: r for kind, r in runs if kind == "big"}
        if 1 in by_workers and 2 in by_workers:
            rate1 = by_workers[1]["files"] / by_workers[1]["seconds"]
            rate2 = by_workers[2]["files"] / by_workers[2]["seconds"]
            verdict = "ok" if rate2 >= 1.7 * rate1 else "BELOW TARGET"
            print(f"speed-up 2 workers vs 1: {rate2 / rate1:.2f}x (target >= 1.7x: {verdict})")
        small_run = runs[-1][1]
        if 2 in by_workers:
            b = by_workers[2]
            keys = ("parent_peak_mb", "worker_peak_mb", "tree_peak_mb")
            growth = {k: (b[k] - small_run[k]) / small_run[k] for k in keys}
            verdict = "ok" if all(abs(g) <= 0.2 for g in growth.values() if g == g) else "ABOVE"
            print(
                f"peak memory {b['files']} vs {small_run['files']} files (2 workers): "
                f"main process {_percent(b['parent_peak_mb'], small_run['parent_peak_mb'])}, "
                f"largest worker {_percent(b['worker_peak_mb'], small_run['worker_peak_mb'])}, "
                f"process tree {_percent(b['tree_peak_mb'], small_run['tree_peak_mb'])} "
                f"(target within 20 %: {verdict})"
            )
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
