"""Which hits the checks reject, on recordings whose hits span 40-160 N.

Run from the repository root::

    python benchmarks/eval_soft_hits.py                       # this checkout
    python benchmarks/eval_soft_hits.py --package ../other    # another checkout's package

The recordings come from ``tests/impact_recordings.py`` (written without the
package): 8 hits with peaks spread over 40-160 N (one clean hit within 5 % of
each end), Hertzian pulse widths, noise of 3e-4, 1e-3 or 3e-3 of each channel's
typical peak, one double hit and one overload, seeds 5300-5309. Printed:

* every verdict that differs from the truth (a clean hit rejected, a defect
  missed or given another reason);
* the same recordings with one clean hit corrupted (the softest, or the one
  with the median peak): ``wide`` (its pulse 3 times as long), ``gain`` (its
  responses 2.5 times as large), ``shifted`` (its responses stretched in time
  by 1.05: modes 5 % higher), ``dropout`` (its responses zero 30-130 ms after
  the hit), ``glitch`` (3 samples of half the response's peak added 0.3 s after
  the hit): how often the corrupt hit is rejected, and how many other hits get
  a verdict other than their truth.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SEEDS = range(5300, 5310)
NOISE = (3e-4, 1e-3, 3e-3)
CASES = ("wide", "gain", "shifted", "dropout", "glitch")


def family(make_recording, seed: int, **kwargs):
    return make_recording(seed, n_hits=8, n_double=1, n_overload=1,
                          force_range_n=(40.0, 160.0), noise_rel=NOISE[seed % 3], **kwargs)


def verdicts(rec):
    from ema_pipeline.acquisition import hits as hitlib
    from ema_pipeline.data import DOF, Channel, Recording

    channels = [Channel("force", "force", DOF(*rec.force_dof), rec.full_scale[0])]
    channels += [Channel(f"acc{c}", "acceleration", DOF(*dof), rec.full_scale[1 + c])
                 for c, dof in enumerate(rec.response_dofs)]
    recording = Recording(rec.signals, rec.sample_rate_hz, tuple(channels))
    found = hitlib.find_hits(recording, 0, pretrigger_s=0.01)
    return hitlib.check_hits(recording, 0, found, exp_window=True)


def corrupted(make_recording, corrupt_hit, clean_hits, seed: int, case: str, which: str):
    rec = family(make_recording, seed)
    ok = sorted(clean_hits(rec), key=lambda i: rec.force_peak_n[i])
    k = ok[0] if which == "soft" else ok[len(ok) // 2]
    if case == "wide":
        rec = family(make_recording, seed, odd_pulse=(k, 3.0))
    corrupt_hit(rec, k, case)
    return rec, k


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--package", type=Path, default=ROOT,
                        help="checkout whose ema_pipeline is imported (default this one)")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    import tests  # noqa: F401  (this checkout's test helpers, bound before --package)

    sys.path.insert(0, str(args.package.resolve()))
    import ema_pipeline
    from tests.impact_recordings import clean_hits, corrupt_hit, make_recording

    print(f"package: {Path(ema_pipeline.__file__).parent}")
    wrong, n_clean, n_defect = [], 0, 0
    for seed in SEEDS:
        rec = family(make_recording, seed)
        n_clean += len(clean_hits(rec))
        n_defect += sum(bool(d) for d in rec.defects)
        for h, truth in zip(verdicts(rec), rec.defects, strict=True):
            if set(h.reasons) - {"past_end"} != set(truth):
                peaks = rec.force_peak_n[clean_hits(rec)]
                wrong.append(f"  seed {seed} hit {h.index}: {rec.force_peak_n[h.index - 1]:.1f} N "
                             f"(clean hits {peaks.min():.0f}-{peaks.max():.0f} N, median "
                             f"{np.median(peaks):.0f} N), truth {sorted(truth) or 'clean'}, "
                             f"reasons {h.reasons}")
    print(f"40-160 N: {n_clean} clean hits with a record, {n_defect} defective; "
          f"{len(wrong)} verdicts not the truth")
    print("\n".join(wrong))
    print("corrupt hit: rejected of 10, other hits not as their truth")
    for which in ("soft", "median"):
        for case in CASES:
            caught = others = 0
            for seed in SEEDS:
                rec, k = corrupted(make_recording, corrupt_hit, clean_hits, seed, case, which)
                hits = verdicts(rec)
                caught += bool(set(hits[k].reasons) - {"past_end"})
                others += sum(set(h.reasons) - {"past_end"} != set(d)
                              for h, d in zip(hits, rec.defects, strict=True) if h.index - 1 != k)
            print(f"  {which:6s} {case:8s} {caught:2d} / 10   {others}")


if __name__ == "__main__":
    main()
