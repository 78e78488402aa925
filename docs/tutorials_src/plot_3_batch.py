"""
A batch of files
================

Every FRF file of a folder (recursively) identified in parallel, with a
``summary.csv`` and a ``failures.csv``; here the three example files and one
broken file. The same as ``ema-pipeline batch raw_frf --out OUT --workers 1``.
"""

# %%
import shutil
import tempfile
from pathlib import Path

import pandas as pd

from ema_pipeline.identification import IdentificationOptions
from ema_pipeline.pipeline.batch import run_batch

repo = Path.cwd()
while not (repo / "raw_frf").is_dir() and repo != repo.parent:
    repo = repo.parent


def batch_of_examples(tmp: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    folder = Path(tmp) / "tests"
    shutil.copytree(repo / "raw_frf", folder, ignore=shutil.ignore_patterns("*.toml"))
    (folder / "broken.uff").write_text("    -1\n    58\n", encoding="ascii")
    run_batch(folder, Path(tmp) / "out", workers=1, progress=False,
              options=IdentificationOptions())
    return (pd.read_csv(Path(tmp) / "out" / "summary.csv"),
            pd.read_csv(Path(tmp) / "out" / "failures.csv"))


# %%
# The worker processes start fresh interpreters, so a script runs the batch
# under ``if __name__ == "__main__"``:
if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        summary, failures = batch_of_examples(tmp)

    print(summary[["file", "status", "n_modes", "frequencies_hz", "fit_error_pct"]]
          .to_string(index=False))
    failures["reason"] = failures["reason"].str.replace(tmp, "TMP")
    print(failures[["file", "reason"]].to_string(index=False))
