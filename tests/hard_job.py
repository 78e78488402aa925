"""Identify hard cases in a child process (a background job of the test run).

``python tests/hard_job.py OUT.json FAMILY:SEED,SEED ...`` writes
{family: [{"seed", "fn_hz", "zeta", "fn_std_hz", "zeta_std"}, ...]} (the
outputs of ``test_identification_hard.identify_case``) to OUT.json, through
a temporary file and a rename. ``tests/conftest.py`` starts it at collection
for the dense families, which take 5-11 s a file: they then run on the
second core while the rest of the suite runs on the first.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import hardcases  # noqa: E402
from test_identification_hard import identify_case  # noqa: E402


def main(argv: list[str]) -> int:
    out = Path(argv[0])
    result: dict[str, list[dict]] = {}
    for spec in argv[1:]:
        family, seeds = spec.split(":")
        result[family] = []
        for seed in (int(s) for s in seeds.split(",")):
            ident = identify_case(hardcases.make_case(family, seed))
            result[family].append({"seed": seed, **{k: v.tolist() for k, v in ident.items()}})
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result))
    os.replace(tmp, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
