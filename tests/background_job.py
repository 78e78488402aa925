"""Identify test cases in a child process (a background job of the test run).

``python tests/background_job.py OUT.json KIND:NAME:SEED,SEED ...`` writes
{"KIND:NAME": [{"seed", "fn_hz", "zeta", "fn_std_hz", "zeta_std"}, ...]}
to OUT.json, through a temporary file and a rename. KIND is ``hard`` (a family
of ``tests/hardcases.py``, identified as ``test_identification_hard.identify_case``
does) or ``paper`` (a configuration of the paper's simulated impact test,
``pipeline.simulate.simulate_paper_test``, identified at the defaults).
``tests/conftest.py`` starts it at collection for the slow cases that the
selected tests read (their modules' ``BACKGROUND``): they then run on the
second core while the rest of the suite runs on the first.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def identify_one(kind: str, name: str, seed: int) -> dict[str, np.ndarray]:
    """fn_hz, zeta, fn_std_hz, zeta_std of one case."""
    if kind == "hard":
        import hardcases
        from test_identification_hard import identify_case

        return identify_case(hardcases.make_case(name, seed))
    if kind == "paper":
        from ema_pipeline.identification import identify
        from ema_pipeline.pipeline.simulate import simulate_paper_test

        m = identify(simulate_paper_test(name, seed=seed)).modes
        return {"fn_hz": m.fn_hz, "zeta": m.zeta, "fn_std_hz": m.fn_std_hz,
                "zeta_std": m.zeta_std}
    raise ValueError(f"unknown kind {kind!r} (hard or paper)")


def main(argv: list[str]) -> int:
    out = Path(argv[0])
    result: dict[str, list[dict]] = {}
    for spec in argv[1:]:
        kind, name, seeds = spec.split(":")
        result[f"{kind}:{name}"] = [
            {"seed": seed, **{k: np.asarray(v).tolist() for k, v in
                              identify_one(kind, name, seed).items()}}
            for seed in (int(s) for s in seeds.split(","))
        ]
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result))
    os.replace(tmp, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
