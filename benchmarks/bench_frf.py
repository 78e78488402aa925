"""Benchmark of ``ema-pipeline frf`` against pyFRF on the same hits.

Two recordings:

* **real**: ``../shared/data/pyfrf-impact.uff`` beside the repository, pyFRF's own
  showcase measurements (5 hits, 1 s records at 25.6 kHz, force + 1 acceleration;
  LGPL-3.0, provenance in ``../shared/data/README.md``; skipped, with a note, where
  absent);
* **generator**: a continuous recording of ``tests/impact_recordings.py`` (written
  without the package): 8 hits, 4 channels (force + 3 accelerations) at 25.6 kHz,
  8.5 s.

Timed in the same process, best of ``--repeat`` runs each:

* ``frf``: :func:`ema_pipeline.pipeline.frf.frf_from_recording` on the recording in
  memory: find the hits, check them (double_hit, overload, not_decayed, low_force,
  outlier), cut the records, choose tau, window, H1 with coherence, usable band;
* ``estimate``: :func:`ema_pipeline.acquisition.estimate_frf` alone on the cut records;
* ``pyFRF``: ``pyFRF.FRF`` on the same cut records with the same exponential window
  on force and response (no force window in either), then ``get_FRF('H1',
  'accelerance')`` and ``get_coherence()``; ``pyFRF+checks`` adds its own double-hit /
  overflow check (``FRF.is_data_ok``) per hit. pyFRF finds no hits: it is given the
  records.

The ratio is pyFRF's time / ours (> 1: ours is faster). The script also prints the
largest relative difference of the two H1 where the coherence exceeds 0.9 (DC
excluded: pyFRF removes each record's mean).

Usage: ``python benchmarks/bench_frf.py [--repeat 7]`` (needs ``pip install pyFRF``).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
PYFRF_UFF = REPO.parent / "shared" / "data" / "pyfrf-impact.uff"
sys.path.insert(0, str(REPO))  # this checkout's package and its tests package

from ema_pipeline import acquisition  # noqa: E402
from ema_pipeline.data import DOF, Channel, Recording  # noqa: E402
from ema_pipeline.io.recording import read_recording  # noqa: E402
from ema_pipeline.pipeline.frf import FRFSettings, frf_from_recording  # noqa: E402
from tests.impact_recordings import make_recording  # noqa: E402


def best(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def generator_recording() -> Recording:
    rec = make_recording(2, n_resp=3, n_hits=8, sample_rate_hz=25600.0, last_hit_short=False)
    channels = [Channel("Hammer force", "force", DOF(*rec.force_dof), rec.full_scale[0])]
    channels += [Channel(f"acc{c}", "acceleration", DOF(*dof), rec.full_scale[1 + c])
                 for c, dof in enumerate(rec.response_dofs)]
    return Recording(rec.signals, rec.sample_rate_hz, tuple(channels))


def compare(name: str, recording: Recording, repeat: int) -> dict[str, float]:
    import pyFRF

    settings = FRFSettings(force_window_s=0.0)  # pyFRF's force window has no taper
    t_frf, out = best(lambda: frf_from_recording(recording, settings), repeat)
    records, tau = out.records, out.exp_window_tau_s
    t_est, _ = best(lambda: acquisition.estimate_frf(records, exp_window_tau_s=tau), repeat)
    fs, n = records.sample_rate_hz, records.n_samples
    window = "none"
    if tau is not None:
        window = f"exponential:{float(np.exp(-(n - 1) / fs / tau))!r}"
    exc, resp = records.force[:, None, :], records.response

    def pyfrf(check: bool):
        frf = pyFRF.FRF(int(fs), exc=exc, resp=resp, exc_type="f", resp_type="a",
                        window=(window, window))
        if check:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ok = [frf.is_data_ok(exc[k], resp[k]) for k in range(exc.shape[0])]
        h = frf.get_FRF(frf_estimator="H1", frf_form="accelerance")
        return h, frf.get_coherence(), (ok if check else None)

    with np.errstate(divide="ignore", invalid="ignore"):
        t_py, (h_py, _, _) = best(lambda: pyfrf(False), repeat)
        t_pyc, _ = best(lambda: pyfrf(True), repeat)
    ours = out.frf.H[:, 0, :]
    good = out.frf.coherence[:, 0, :] > 0.9
    good[:, 0] = False
    diff = float(np.max(np.abs(ours[good] - h_py[:, 0, :][good]) / np.abs(ours[good])))
    print(f"{name:10s} {out.n_accepted} hits x {1 + records.response.shape[1]} ch, "
          f"{n} samples, tau {'none' if tau is None else f'{tau:.3g} s'}: "
          f"frf {1e3 * t_frf:7.1f} ms, estimate {1e3 * t_est:6.1f} ms, "
          f"pyFRF {1e3 * t_py:6.1f} ms, pyFRF+checks {1e3 * t_pyc:7.1f} ms; "
          f"ratio pyFRF/frf {t_py / t_frf:.2f}, pyFRF/estimate {t_py / t_est:.2f}, "
          f"pyFRF+checks/frf {t_pyc / t_frf:.2f}; max |dH1|/|H1| (coh > 0.9) {diff:.1e}")
    return {"frf": t_frf, "estimate": t_est, "pyfrf": t_py, "pyfrf_checks": t_pyc}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7, help="runs per timing (best of)")
    args = parser.parse_args()
    try:
        import pyFRF  # noqa: F401
    except ImportError:
        raise SystemExit("pyFRF is not installed: pip install pyFRF") from None
    if PYFRF_UFF.is_file():
        compare("real", read_recording(PYFRF_UFF), args.repeat)
    else:
        print(f"real: skipped, {PYFRF_UFF} is absent (see ../shared/data/README.md)")
    compare("generator", generator_recording(), args.repeat)


if __name__ == "__main__":
    main()
