"""Benchmark of ``ema-pipeline live``'s processing: the replay device at maximum
speed through the live test (every block journaled with fsync, hits judged as
their records complete, the running FRF after each hit; no server, no
identification).

A roving test of ``--points`` points (default 4), each a float32 WAV of
``--seconds`` s (default 10) with 4 channels (a force, three accelerations: two
decaying modes) at 51.2 kHz, four hits 2.2 s apart. The row: the multiple of
real time the processing reaches (seconds of data per second of wall time and
per second of CPU time of the process).

Usage: ``python benchmarks/bench_live.py [--points 4] [--seconds 10] [--keep DIR]``
"""

from __future__ import annotations

import argparse
import math
import resource
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

FS_HZ = 51200.0
N_CHANNELS = 4


def write_test(folder: Path, points: int, seconds: float) -> Path:
    """The recordings and their channel sheet; returns the sheet's path."""
    from scipy.io import wavfile

    n = int(seconds * FS_HZ)
    t = np.arange(n) / FS_HZ
    rng = np.random.default_rng(0)
    rows = ["file,channel,role,node,direction,scale,unit"]
    for k in range(1, points + 1):
        data = np.zeros((n, N_CHANNELS))
        for t0 in (0.5, 2.7, 4.9, 7.1):
            if t0 + 2.2 > seconds:
                break
            on = (t >= t0) & (t <= t0 + 1e-3)
            data[on, 0] += 200.0 * np.sin(np.pi * (t[on] - t0) / 1e-3)
            after = t >= t0
            tau = t[after] - t0
            for j in range(1, N_CHANNELS):
                data[after, j] += (np.exp(-2 * np.pi * 0.01 * 80 * tau) * np.sin(
                    2 * np.pi * 80 * tau) * j + 0.5 * np.exp(-2 * np.pi * 0.01 * 300 * tau)
                    * np.sin(2 * np.pi * 300 * tau))
        data += 1e-4 * rng.standard_normal(data.shape) * np.array([200.0, 1, 1, 1])
        wavfile.write(folder / f"p{k}.wav", int(FS_HZ), data.astype(np.float32))
        rows.append(f"p{k}.wav,0,force,{k},-Z,,N")
        rows += [f"p{k}.wav,{j},response,{100 + j},+Z,,m/s^2" for j in range(1, N_CHANNELS)]
    (folder / "channels.csv").write_text("\n".join(rows) + "\n")
    return folder / "channels.csv"


def run(sheet: Path, session: Path) -> tuple[float, float, float, int]:
    """Replay the whole test at maximum speed; (data s, wall s, CPU s, hits)."""
    from ema_pipeline.io.channel_sheet import read_channel_sheet
    from ema_pipeline.io.live_session import SessionFolder
    from ema_pipeline.live.device import ReplayDevice
    from ema_pipeline.live.engine import LiveTest

    device = ReplayDevice(read_channel_sheet(sheet), speed=math.inf)
    test = LiveTest(device, SessionFolder(session), identify_points=False)
    data_s = sum(r.signals.shape[1] for r in device.recordings) / device.sample_rate_hz
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    wall0 = time.perf_counter()
    test.start()
    hits = 0
    for k in range(len(device.plan)):
        while test.snapshot()["streaming"]:
            time.sleep(0.002)
        hits += len(test.points[k].hits)
        if k + 1 < len(device.plan):
            test.next_point()
    wall = time.perf_counter() - wall0
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    test.close()
    cpu = (cpu1.ru_utime + cpu1.ru_stime) - (cpu0.ru_utime + cpu0.ru_stime)
    return data_s, wall, cpu, hits


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--keep", type=Path, default=None, help="keep the files here")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench_live_")) if args.keep is None else args.keep
    folder.mkdir(parents=True, exist_ok=True)
    try:
        sheet = write_test(folder, args.points, args.seconds)
        data_s, wall, cpu, hits = run(sheet, folder / "session")
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)
    print("| test | data | wall | CPU | multiple of real time (wall) | (CPU) | hits |")
    print("|---|---|---|---|---|---|---|")
    print(f"| {args.points} points x {N_CHANNELS} channels at {FS_HZ / 1e3:g} kHz | "
          f"{data_s:.1f} s | {wall:.2f} s | {cpu:.2f} s | {data_s / wall:.1f} x | "
          f"{data_s / cpu:.1f} x | {hits} |")


if __name__ == "__main__":
    main()
