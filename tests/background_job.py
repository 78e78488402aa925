"""Identify test cases in a child process (a background job of the test run).

``python -m tests.background_job OUT_DIR KIND:NAME:SEED,SEED ...`` writes,
case by case in the order given, [{"seed", "fn_hz", "zeta", "fn_std_hz",
"zeta_std"}, ...] to OUT_DIR/KIND_NAME.json, each through a temporary file
and a rename (a test waits only for its own). Before a case it claims it
(:func:`claim`, an atomic ``mkdir``); a case that the test process claimed
first, because it needed it before the job got to it, is skipped, so that
neither process waits for work the other has not started. KIND is ``hard`` (a family
of ``tests/hardcases.py``, identified as ``test_identification_hard.identify_case``
does) or ``paper`` (a configuration of the paper's simulated impact test,
``pipeline.simulate.simulate_paper_test``, identified at the defaults).
``tests/conftest.py`` starts it at collection (:func:`tests.jobs.start_background`)
for the slow cases that the selected tests read (their modules' ``BACKGROUND``):
they then run on the second core while the rest of the suite runs on the first.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterable
from pathlib import Path

import numpy as np


def identify_one(kind: str, name: str, seed: int) -> dict[str, np.ndarray]:
    """fn_hz, zeta, fn_std_hz, zeta_std of one case."""
    if kind == "hard":
        from tests import hardcases
        from tests.test_identification_hard import identify_case

        return identify_case(hardcases.make_case(name, seed))
    if kind == "paper":
        from ema_pipeline.identification import identify
        from ema_pipeline.pipeline.simulate import simulate_paper_test

        m = identify(simulate_paper_test(name, seed=seed)).modes
        return {"fn_hz": m.fn_hz, "zeta": m.zeta, "fn_std_hz": m.fn_std_hz,
                "zeta_std": m.zeta_std}
    raise ValueError(f"unknown kind {kind!r} (hard or paper)")


def output_path(out_dir: Path, key: str) -> Path:
    """Where the outputs of ``key`` ("KIND:NAME") go."""
    return out_dir / (key.replace(":", "_") + ".json")


def claim(out_dir: Path, key: str) -> bool:
    """True when this process is the first to claim ``key`` (it then computes it)."""
    try:
        os.mkdir(out_dir / ("claim_" + key.replace(":", "_")))
    except FileExistsError:
        return False
    return True


def write_outputs(out_dir: Path, key: str, seeds: Iterable[int]) -> None:
    """Identify the cases ``seeds`` of ``key`` ("KIND:NAME") and write their
    outputs to :func:`output_path` (a temporary file renamed: a reader sees
    the whole file or none)."""
    kind, name = key.split(":")
    rows = [{"seed": seed, **{k: np.asarray(v).tolist() for k, v in
                              identify_one(kind, name, seed).items()}}
            for seed in seeds]
    path = output_path(out_dir, key)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(rows))
    os.replace(tmp, path)


def main(argv: list[str]) -> int:
    out_dir = Path(argv[0])
    for spec in argv[1:]:
        kind, name, seeds = spec.split(":")
        if claim(out_dir, f"{kind}:{name}"):
            write_outputs(out_dir, f"{kind}:{name}", [int(s) for s in seeds.split(",")])
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
