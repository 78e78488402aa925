"""Issue 15: nothing a user gives ema-pipeline crashes it, hangs it, fools it or
costs them earlier results.

The corpus (``tests/fuzz_cases.py``: byte flips and truncations of HDF5 and UFF
files, malformed HDF5 structures, experiment-file mutations, hostile names,
special files, abusive options, a batch of bad files, a full disk) is generated
once per session in a temporary folder and run through ``python -m
ema_pipeline`` in subprocesses with timeouts, by a background process started
when these tests are collected (conftest.py), which stores each case's verdict.
Three tests per case group:

* ``test_no_crash``: no death by signal, no hang, no Python traceback;
* ``test_verdict``: garbage is never reported as success, stderr names the
  file, no temporary files left, earlier results byte-identical, nothing
  written outside the output folder, no unescaped markup, batch tables right;
* ``test_exit_status``: exit 2 for input errors, 1 for runtime failures.

No group is expected to fail any more (issue 15 phase 2). By default the
quick subset of the corpus runs (fewer flips, one or two ``run`` mutations per
group: most of them run the whole study until the experiment file is validated
up front); ``EMA_FUZZ_FULL=1`` runs all of it.
"""

from __future__ import annotations

import json

import pytest

import tests.fuzz_cases as fc
from tests.jobs import start_fuzz

#: group -> {test: reason} for checks still expected to fail (none since issue 15
#: phase 2: experiment schema, atomic results swap, exit codes, order/band/memory
#: guards, batch tables, name checks, UFF axis plausibility).
GROUPS = (
    "h5_flip_gcol", "h5_flip_vlen", "h5_flip_head", "h5_flip_tail", "h5_flip_any",
    "h5_trunc", "h5_malformed_dtype", "h5_malformed_shape", "h5_malformed_plausible",
    "h5_malformed_missing", "h5_malformed_object", "h5_malformed_external",
    "h5_malformed_size", "h5_malformed_attr", "uff_flip", "uff_trunc", "special",
    "uff_header", "experiment_type", "experiment_range", "experiment_unknown",
    "experiment_float_node", "experiment_late", "experiment_name", "experiment_syntax",
    "cli_option", "batch", "disk_full_identify", "disk_full_run", "disk_full_batch",
    "recording_bad", "recording_hostile",
)

CHECKS = {
    "no_crash": {"signal", "hang", "traceback"},
    "verdict": {"exit0", "message", "litter", "results", "escape", "html", "table"},
    "exit_status": {"exit_code"},
}


@pytest.fixture(scope="session")
def fuzz_verdicts(request: pytest.FixtureRequest) -> dict[str, dict]:
    """Case name -> {"group", "bad" (failed checks), "rc", "signal", "stderr"} of the
    whole fuzz corpus (tests/fuzz_cases.py), from its background run."""
    job = start_fuzz(request.config)
    assert job.wait() == 0, f"fuzz corpus run failed:\n{job.log_tail()}"
    return json.loads((job.dir / "verdicts.json").read_text())



@pytest.fixture(scope="session")
def fuzz(fuzz_verdicts):
    """The corpus' verdicts: generated and run in the background from the start of
    the session (``fc.save_verdicts``, see conftest.py), here waited for."""
    return fuzz_verdicts


def _failures(fuzz, group: str, test: str) -> list[str]:
    mine = {name: v for name, v in fuzz.items() if v["group"] == group}
    assert mine, f"no cases in group {group}"
    out = []
    for name, v in mine.items():
        bad = set(v["bad"]) & CHECKS[test]  # v["bad"] is fc.verdict(case, outcome)
        if bad:
            out.append(f"{name}: {','.join(sorted(bad))} (rc={v['rc']}, signal={v['signal']}, "
                       f"stderr={v['stderr'].strip()[-300:]!r})")
    return out


@pytest.mark.parametrize("group", GROUPS)
def test_no_crash(fuzz, group):
    bad = _failures(fuzz, group, "no_crash")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("group", GROUPS)
def test_verdict(fuzz, group):
    bad = _failures(fuzz, group, "verdict")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("group", GROUPS)
def test_exit_status(fuzz, group):
    bad = _failures(fuzz, group, "exit_status")
    assert not bad, "\n".join(bad)


def test_corpus_is_deterministic(tmp_path):
    """Same seeds, same bytes: two generations of the file cases are identical."""
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    for root in (a, b):
        fc.h5_flip_cases(root)
        fc.uff_cases(root)
    files_a = {p.name: p.read_bytes() for p in a.iterdir()}
    files_b = {p.name: p.read_bytes() for p in b.iterdir()}
    assert files_a == files_b and len(files_a) > 50


def testvlen_targets_found():
    """The structure-aware flips find the string attribute references and types."""
    refs, dtypes = fc.vlen_targets((fc.EXAMPLES / "larger_tank.h5").read_bytes())
    assert len(refs) >= 10 and len(dtypes) >= 5


def test_check_hdf5_refuses_a_looping_file_quickly(tmp_path):
    """A corrupted global heap makes libhdf5 loop forever: the child is killed and
    the file refused, within the timeout, naming the file."""
    import time

    from ema_pipeline.data import DataError
    from ema_pipeline.io import check_hdf5

    src = bytearray((fc.EXAMPLES / "larger_tank.h5").read_bytes())
    size_fields = [off for off, n in fc.gcol_fields(bytes(src)) if n == 8]
    src[size_fields[2]] ^= 0xFF  # the size of the second string in the global heap
    path = tmp_path / "loops.h5"
    path.write_bytes(bytes(src))
    start = time.perf_counter()
    with pytest.raises(DataError, match="loops.h5"):
        check_hdf5(path, timeout_s=2.0)
    # the loop is endless without the guard; the bound is generous because the
    # check may start a fresh interpreter (threads present) on a loaded machine
    assert time.perf_counter() - start < 60.0
    check_hdf5(fc.EXAMPLES / "larger_tank.h5")  # and a good file passes



def test_check_hdf5_gives_a_fresh_interpreter_time_to_start(monkeypatch):
    """A check that must start a fresh interpreter (threads present rule out a
    fork) gets CHILD_START_S more than the reading time: at load 8 the start-up
    alone took over 5 s and valid files of a batch failed as 'corrupt'. A fork
    gets the reading time only, and a timeout given by the caller is kept."""
    from ema_pipeline import runner
    from ema_pipeline.io import hdf5_check

    good = fc.EXAMPLES / "larger_tank.h5"
    reading = hdf5_check._child_timeout(good.stat().st_size)
    seen: list[tuple[str, float]] = []
    monkeypatch.setattr(hdf5_check, "_spawn_check",
                        lambda p, t: seen.append(("spawn", t)) or ("ok", ""))
    monkeypatch.setattr(runner, "fork_is_safe", lambda: False)  # asked at the fork
    hdf5_check.check_hdf5(good)
    hdf5_check.check_hdf5(good, timeout_s=2.0)
    monkeypatch.setattr(hdf5_check, "_fork_check",
                        lambda p, t: seen.append(("fork", t)) or ("ok", ""))
    hdf5_check.check_hdf5(good)
    assert seen == [("spawn", pytest.approx(reading + hdf5_check.CHILD_START_S)), ("spawn", 2.0),
                    ("fork", pytest.approx(reading))]
