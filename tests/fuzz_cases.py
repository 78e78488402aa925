"""Deterministic fuzz corpus for issue 15 and the runner that feeds it to the CLI.

Every case is generated at test time in a temporary folder from the example
files in ``raw_frf/`` (seeded ``random.Random``, no stored corpus):

* ``h5_flip``      one byte of ``larger_tank.h5`` XOR-ed: in the global heap that
                   holds the string attributes (object sizes and indices, the
                   collection size, the text), in the superblock / root object
                   headers, in the trailing object headers, anywhere;
* ``h5_trunc``     ``larger_tank.h5`` cut at seeded lengths;
* ``h5_malformed`` valid HDF5 files with the FRF layout broken: wrong dtypes and
                   shapes, missing objects, a group for a dataset, an external
                   link, an external / virtual dataset, a 64 GiB dataset declared
                   in a small file, soft-link loops, attributes of the wrong type,
                   a negative / zero / NaN window time constant;
* ``uff_flip`` / ``uff_trunc`` byte flips and truncations of ``genuine.uff``
                   (ASCII) and ``smaller_tank.uff`` (binary); ``uff_header``:
                   a plausible-looking header with an absurd increment;
* ``special``      FIFO, ``/dev/zero`` (directly and through a ``.h5`` symlink),
                   a directory named ``x.h5``, a symlink loop, a dangling
                   symlink, an empty file, an HDF5 signature alone;
* ``experiment``   ``experiment.toml`` mutations for ``run``: wrong types,
                   out-of-range values, unknown keys (typos), float node
                   numbers, missing / special files, hostile configuration names;
* ``cli_option``   ``identify`` with abusive options;
* ``batch``        a folder of bad files, its output folder inside it;
* ``disk_full``    ``identify`` / ``run`` / ``batch`` under a file-size limit
                   (``RLIMIT_FSIZE``: writes fail with EFBIG like on a full disk).

:func:`run_cases` runs them through ``python -m ema_pipeline`` in subprocesses
(forked from the runner with the package already imported where the runner
has one thread, as in the test suite's background run: :func:`run_cli`;
under ``RLIMIT_AS`` so that a runaway allocation fails instead of swapping),
many file cases per ``identify`` process; a process that crashes, hangs or
prints a traceback is re-run one case at a time to find the culprit.
:func:`save_verdicts` does both and stores the verdicts as JSON (the test
suite runs it in the background from the start of the session).
:func:`verdict` lists the checks a case fails: ``signal``, ``hang``,
``traceback``, ``exit0`` (garbage reported as success), ``exit_code``,
``message`` (stderr does not name the file), ``litter`` (temporary files
left), ``results`` (earlier results changed), ``escape`` (written outside the
output folder), ``html`` (unescaped markup), ``table`` (batch tables).

``python -m tests.fuzz_cases [-v] [CATEGORY ...]`` prints the failure counts by
category (``EMA_FUZZ_FULL=1``: the whole corpus, else the quick subset that the
test suite runs; ``EMA_FUZZ_CODE=DIR``: test the package in DIR).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "raw_frf"
#: The code under test (default: this repository; set EMA_FUZZ_CODE to measure another tree).
CODE = Path(os.environ.get("EMA_FUZZ_CODE", str(REPO)))
#: EMA_FUZZ_FULL=1: the whole corpus; else the quick subset (cases with quick=True).
FULL = os.environ.get("EMA_FUZZ_FULL") == "1"
#: Address-space limit of every CLI process (bytes): a 12 GB allocation fails at once.
MEMORY_LIMIT = 3 << 30
#: Seconds allowed per case when run alone, and per group (+ per file).
SOLO_TIMEOUT_S = 60.0
RUN_TIMEOUT_S = 150.0  # a whole study on a loaded 2-core machine
OPTION_TIMEOUT_S = 30.0
GUARD_TIMEOUT_S = 10.0  # --max-order 500/2000 must be refused up front, not computed
GROUP_TIMEOUT_S, PER_FILE_TIMEOUT_S = 30.0, 3.0
#: File-size limit of the disk-full cases (bytes).
DISK_LIMIT = 100_000
FAST_BAND = ("5", "395")  # three modes; keeps identification of benign mutations cheap


@dataclass
class Case:
    """One hostile input and what the CLI must do with it."""

    name: str  # unique, also the file stem
    category: str
    group: str  # the test's parameter: a finer grouping of the cases
    kind: str  # "file" (identify, groupable) | "solo" (own process)
    garbage: bool = True  # exit 0 / success for this input is wrong
    expect_exit: int | None = 2  # 2 input error, 1 runtime failure, None: any non-zero
    argv: list[str] = field(default_factory=list)  # solo cases: CLI arguments
    names: tuple[str, ...] = ()  # one of these must appear in stderr
    fsize_limit: int | None = None
    results_dir: str | None = None  # relative to cwd: must stay byte-identical
    check: Callable[[Path, Outcome], list[str]] | None = None  # extra checks
    path: Path | None = None  # file cases: the input
    timeout_s: float = SOLO_TIMEOUT_S
    quick: bool = True  # part of the default (quick) corpus


@dataclass
class Outcome:
    rc: int | None = None
    signal: int | None = None
    timed_out: bool = False
    stdout: str = ""
    stderr: str = ""
    file_status: str = ""  # file cases in a group: ok | error | silent
    solo: bool = True
    seconds: float = 0.0


# --------------------------------------------------------------------------
# HDF5 inputs
# --------------------------------------------------------------------------


def gcol_fields(data: bytes) -> list[tuple[int, int]]:
    """(offset, length) of the index, reference count and size fields of every
    object in the first global heap collection (the vlen string attributes)."""
    start = data.find(b"GCOL")
    if start < 0:
        return []
    size = int.from_bytes(data[start + 8 : start + 16], "little")
    out, pos = [(start + 8, 8)], start + 16
    while pos + 16 <= start + size:
        index = int.from_bytes(data[pos : pos + 2], "little")
        length = int.from_bytes(data[pos + 8 : pos + 16], "little")
        out += [(pos, 2), (pos + 2, 2), (pos + 8, 8), (pos + 16, min(length, 16))]
        if index == 0:
            break
        pos += 16 + (length + 7) // 8 * 8
    return out


def vlen_targets(data: bytes) -> tuple[list[int], list[int]]:
    """Offsets of the variable-length string references (4-byte length, 8-byte
    global-heap address, 4-byte index) and of the vlen-string datatype messages."""
    start = data.find(b"GCOL")
    refs = [m.start() - 4 for m in re.finditer(re.escape(start.to_bytes(8, "little")), data)
            if m.start() >= 4] if start >= 0 else []
    dtypes = [m.start() for m in re.finditer(rb"\x19[\x00\x01][\x00\x01]\x00\x10", data)]
    return refs, dtypes


def h5_flip_cases(root: Path, n_per_region: int = 8) -> list[Case]:
    """Single-byte XORs of larger_tank.h5, by region (seeded offsets and masks).

    ``gcol``: the global heap holding the string attributes (object index /
    size fields, text); ``vlen``: the references to it in attribute messages
    and the string datatype messages; ``head``/``tail``: superblock, object
    headers, B-trees, local heaps; ``any``: anywhere.
    """
    src = (EXAMPLES / "larger_tank.h5").read_bytes()
    fields = [f for f in gcol_fields(src) if f[1] > 0]
    refs, dtypes = vlen_targets(src)

    def gcol(r: random.Random) -> int:
        off, length = r.choice(fields)
        return off + (0 if length in (2, 8) and r.random() < 0.7 else r.randrange(length))

    def vlen(r: random.Random) -> int:
        if dtypes and r.random() < 0.4:
            return r.choice(dtypes) + r.randrange(1, 4)  # the class bit fields
        return r.choice(refs) + r.choice((0, 2, 3, 4, 5, 12))  # length, address, index

    regions = {
        "gcol": gcol,
        "vlen": vlen,
        "head": lambda r: r.randrange(0, 2048),
        "tail": lambda r: r.randrange(len(src) - 4096, len(src)),
        "any": lambda r: r.randrange(len(src)),
    }
    cases = []
    for region, pick in regions.items():
        rng = random.Random(f"h5flip-{region}")
        n = n_per_region if region != "any" else n_per_region // 2
        seen: set[int] = set()
        while len(seen) < n:
            off = pick(rng)
            mask = rng.choice((0xFF, 0x01, 0x80, rng.randrange(1, 256)))
            if off in seen:
                continue
            seen.add(off)
            data = bytearray(src)
            data[off] ^= mask
            name = f"h5flip_{region}_{off}_{mask:02x}"
            path = root / f"{name}.h5"
            path.write_bytes(bytes(data))
            cases.append(
                Case(name, "h5_flip", f"h5_flip_{region}", "file", garbage=False, path=path,
                     quick=len(seen) <= n_per_region // 2)
            )
    # And the first of each vlen structure, at the bytes libhdf5 is known to trust:
    # the string datatype's class bits and the high byte of a reference's length.
    for name, off in (("h5flip_vlen_dtype_first", dtypes[0] + 1),
                      ("h5flip_vlen_length_first", refs[0] + 3)):
        data = bytearray(src)
        data[off] ^= 0xFF
        path = root / f"{name}.h5"
        path.write_bytes(bytes(data))
        cases.append(Case(name, "h5_flip", "h5_flip_vlen", "file", garbage=False, path=path))
    return cases


def h5_trunc_cases(root: Path) -> list[Case]:
    src = (EXAMPLES / "larger_tank.h5").read_bytes()
    rng = random.Random("h5trunc")
    lengths = sorted({8, 100, 2047, 2100, 8192, len(src) - 1, len(src) // 2} | {
        rng.randrange(len(src)) for _ in range(4)
    })
    cases = []
    for n in lengths:
        name = f"h5trunc_{n}"
        path = root / f"{name}.h5"
        path.write_bytes(src[:n])
        cases.append(Case(name, "h5_trunc", "h5_trunc", "file", path=path))
    return cases


def _frf_arrays() -> dict:
    with h5py.File(EXAMPLES / "larger_tank.h5", "r") as h5:
        g = h5["frf"]
        return {
            "freq_hz": g["freq_hz"][()],
            "H": g["H"][()],
            "coherence": g["coherence"][()],
            "response_dofs": g["response_dofs"][()],
            "reference_dofs": g["reference_dofs"][()],
            "root_attrs": dict(h5.attrs),
            "frf_attrs": dict(g.attrs),
            "acq_attrs": dict(g["acquisition"].attrs),
        }


def _write_layout(path: Path, base: dict, mutate: Callable[[h5py.File, Path], None]) -> None:
    """The FRF layout of io.hdf5 written by hand, then ``mutate``-d."""
    with h5py.File(path, "w") as h5:
        h5.attrs.update(base["root_attrs"])
        g = h5.create_group("frf")
        g.attrs.update(base["frf_attrs"])
        for key in ("freq_hz", "H", "coherence", "response_dofs", "reference_dofs"):
            g.create_dataset(key, data=base[key])
        g.create_group("acquisition").attrs.update(base["acq_attrs"])
        mutate(h5, path)


def _replace(name: str, **kwargs) -> Callable[[h5py.File, Path], None]:
    def mutate(h5: h5py.File, path: Path) -> None:
        del h5[name]
        h5.create_dataset(name, **kwargs)

    return mutate


def _set_attr(obj: str, key: str, value) -> Callable[[h5py.File, Path], None]:
    def mutate(h5: h5py.File, path: Path) -> None:
        h5[obj].attrs[key] = value

    return mutate


def _delete(name: str) -> Callable[[h5py.File, Path], None]:
    def mutate(h5: h5py.File, path: Path) -> None:
        del h5[name]

    return mutate


def _external_link(h5: h5py.File, path: Path) -> None:
    other = path.with_name(path.stem + "_target.hdf")
    with h5py.File(other, "w") as o:
        o["H"] = h5["frf/H"][()]
    del h5["frf/H"]
    h5["frf/H"] = h5py.ExternalLink(other.name, "/H")


def _external_dataset(h5: h5py.File, path: Path) -> None:
    H = h5["frf/H"][()]
    raw = path.with_name(path.stem + "_raw.bin")
    raw.write_bytes(H.tobytes())
    del h5["frf/H"]
    h5.create_dataset("frf/H", shape=H.shape, dtype=H.dtype, external=[(raw.name, 0, H.nbytes)])


def _external_dataset_passwd(h5: h5py.File, path: Path) -> None:
    del h5["frf/response_dofs"]
    h5.create_dataset(
        "frf/response_dofs", shape=(2, 2), dtype="<i8", external=[("/etc/passwd", 0, 32)]
    )


def _virtual_dataset(h5: h5py.File, path: Path) -> None:
    other = path.with_name(path.stem + "_src.hdf")
    H = h5["frf/H"][()]
    with h5py.File(other, "w") as o:
        o["H"] = H
    layout = h5py.VirtualLayout(shape=H.shape, dtype=H.dtype)
    layout[...] = h5py.VirtualSource(other.name, "H", shape=H.shape)
    del h5["frf/H"]
    h5["frf"].create_virtual_dataset("H", layout)


def _huge(h5: h5py.File, path: Path) -> None:
    n = 2**31  # 64 GiB of complex128 (x2 outputs), 16 GiB of float64 frequencies
    for key in ("freq_hz", "H", "coherence"):
        del h5[f"frf/{key}"]
    h5.create_dataset("frf/freq_hz", shape=(n,), dtype="<f8", chunks=(1 << 16,))
    h5.create_dataset("frf/H", shape=(2, 1, n), dtype="<c16", chunks=(1, 1, 1 << 16),
                      compression="gzip")


def _soft_loop(h5: h5py.File, path: Path) -> None:
    del h5["frf/H"]
    h5["frf/H"] = h5py.SoftLink("/frf/H2")
    h5["frf/H2"] = h5py.SoftLink("/frf/H")


def _frf_is_dataset(h5: h5py.File, path: Path) -> None:
    del h5["frf"]
    h5["frf"] = np.zeros(4)


def _scaled_freq(h5: h5py.File, path: Path) -> None:
    f = h5["frf/freq_hz"][()]
    f[100], f[101] = f[101], f[100]
    h5["frf/freq_hz"][...] = f


def h5_malformed_cases(root: Path) -> list[Case]:
    base = _frf_arrays()
    H, f = base["H"], base["freq_hz"]
    s = h5py.string_dtype()
    mutations: dict[str, tuple[str, Callable[[h5py.File, Path], None]]] = {
        "H_int": ("dtype", _replace("frf/H", data=np.zeros(H.shape, dtype=np.int32))),
        "H_text": ("dtype", _replace("frf/H", data=np.full(H.shape[:2], "x", dtype=object),
                                    dtype=s)),
        "H_bool": ("dtype", _replace("frf/H", data=np.ones(H.shape, dtype=bool))),
        "H_compound": ("dtype", _replace("frf/H", data=np.zeros(
            H.shape, dtype=[("a", "<f8"), ("b", "<i4"), ("c", "<f8")]))),
        "freq_text": ("dtype", _replace("frf/freq_hz", data=np.array(["1"] * f.size,
                                                                    dtype=object), dtype=s)),
        "dofs_float": ("dtype", _replace("frf/response_dofs", data=np.array(
            [[3.7, 3.0], [6.0, 3.0]]))),
        "H_2d": ("shape", _replace("frf/H", data=H[:, 0, :])),
        "H_scalar": ("shape", _replace("frf/H", data=1.0 + 0j)),
        "H_short": ("shape", _replace("frf/H", data=H[..., :-7])),
        "H_empty": ("shape", _replace("frf/H", data=H[:, :, :0])),
        "freq_2d": ("shape", _replace("frf/freq_hz", data=np.stack([f, f]))),
        "freq_one": ("shape", _replace("frf/freq_hz", data=f[:1])),
        "dofs_shape": ("shape", _replace("frf/response_dofs", data=np.ones((2, 3), dtype=int))),
        "dofs_count": ("shape", _replace("frf/reference_dofs", data=np.ones((3, 2), dtype=int))),
        "coherence_shape": ("shape", _replace("frf/coherence", data=np.ones(7))),
        "freq_unsorted": ("plausible", _scaled_freq),
        "freq_nan": ("plausible", _replace("frf/freq_hz", data=np.where(
            np.arange(f.size) == 5, np.nan, f))),
        "no_H": ("missing", _delete("frf/H")),
        "no_freq": ("missing", _delete("frf/freq_hz")),
        "no_acquisition": ("missing", _delete("frf/acquisition")),
        "no_frf": ("missing", _delete("frf")),
        "no_schema": ("missing", lambda h5, p: h5.attrs.__delitem__("schema")),
        "H_group": ("object", lambda h5, p: (h5.__delitem__("frf/H"),
                                             h5.create_group("frf/H"))),
        "frf_dataset": ("object", _frf_is_dataset),
        "acquisition_dataset": ("object", lambda h5, p: (
            h5.__delitem__("frf/acquisition"), h5.create_dataset("frf/acquisition", data=1))),
        "soft_loop": ("object", _soft_loop),
        "external_link": ("external", _external_link),
        "external_dataset": ("external", _external_dataset),
        "external_passwd": ("external", _external_dataset_passwd),
        "virtual_dataset": ("external", _virtual_dataset),
        "huge_declared": ("size", _huge),
        "tau_text": ("attr", _set_attr("frf/acquisition", "exp_window_tau_s", "abc")),
        "tau_negative": ("attr", _set_attr("frf/acquisition", "exp_window_tau_s", -1.0)),
        "tau_zero": ("attr", _set_attr("frf/acquisition", "exp_window_tau_s", 0.0)),
        "tau_nan": ("attr", _set_attr("frf/acquisition", "exp_window_tau_s", np.nan)),
        "tau_array": ("attr", _set_attr("frf/acquisition", "exp_window_tau_s", np.ones(3))),
        "fs_negative": ("attr", _set_attr("frf/acquisition", "sample_rate_hz", -2000.0)),
        "navg_float": ("attr", _set_attr("frf/acquisition", "n_averages", 1.5)),
        "nsamples_text": ("attr", _set_attr("frf/acquisition", "n_samples", "many")),
        "quantity_int": ("attr", _set_attr("frf", "quantity", 5)),
        "quantity_bogus": ("attr", _set_attr("frf", "quantity", "bogus")),
        "configuration_int": ("attr", _set_attr("frf", "configuration", 12345)),
        "version_text": ("attr", _set_attr("/", "schema_version", "1")),
        "version_2": ("attr", _set_attr("/", "schema_version", 2)),
        "schema_array": ("attr", _set_attr("/", "schema", np.array(
            ["ema-pipeline/frf"] * 2, dtype=object))),
    }
    cases = []
    for key, (group, mutate) in mutations.items():
        name = f"h5bad_{key}"
        path = root / f"{name}.h5"
        _write_layout(path, base, mutate)
        cases.append(Case(name, "h5_malformed", f"h5_malformed_{group}", "file", path=path))
    return cases


# --------------------------------------------------------------------------
# UFF inputs
# --------------------------------------------------------------------------


def uff_cases(root: Path, n_flips: int = 8) -> list[Case]:
    cases = []
    for stem in ("genuine", "smaller_tank"):
        src = (EXAMPLES / f"{stem}.uff").read_bytes()
        rng = random.Random(f"uff-{stem}")
        headers = [m.start() for m in re.finditer(rb"(?m)^\s*-1\s*\r?\n\s*58", src)]
        for k in range(n_flips):
            if k % 2 == 0:  # in a record header (the 11 lines after the delimiter)
                off = rng.choice(headers) + rng.randrange(0, 11 * 81)
            else:
                off = rng.randrange(len(src))
            mask = rng.randrange(1, 256)
            data = bytearray(src)
            data[off] ^= mask
            name = f"uffflip_{stem}_{off}_{mask:02x}"
            path = root / f"{name}.uff"
            path.write_bytes(bytes(data))
            cases.append(Case(name, "uff_flip", "uff_flip", "file", garbage=False, path=path,
                              quick=k < n_flips // 2))
        for n in sorted({rng.randrange(len(src)) for _ in range(4)} | {len(src) - 3, 200}):
            name = f"ufftrunc_{stem}_{n}"
            path = root / f"{name}.uff"
            path.write_bytes(src[:n])
            cases.append(Case(name, "uff_trunc", "uff_trunc", "file", path=path))
    # A header with an absurd abscissa increment (record line 7, field 5).
    text = (EXAMPLES / "genuine.uff").read_text()
    lines = text.split("\n")
    for k, line in enumerate(lines):
        if re.match(r"^\s+\d+\s+\d+\s+\d+\s+[-+.\deE]+\s+[-+.\deE]+\s+[-+.\deE]+\s*$", line):
            parts = line.split()
            if len(parts) == 6 and parts[2] == "1":  # ord type, n, even spacing, x0, dx, z
                lines[k] = line.replace(parts[4], "1.00000E-30", 1)
    path = root / "uffhdr_df_tiny.uff"
    path.write_text("\n".join(lines).replace("ema-pipeline fs=", "ema-pipeline xx="))
    cases.append(Case("uffhdr_df_tiny", "uff_header", "uff_header", "file", path=path))
    return cases


# --------------------------------------------------------------------------
# Special files
# --------------------------------------------------------------------------


def special_cases(root: Path) -> list[Case]:
    sp = root / "special"
    sp.mkdir()
    made: dict[str, Path] = {}
    os.mkfifo(sp / "fifo.h5")
    made["fifo_h5"] = sp / "fifo.h5"
    os.mkfifo(sp / "fifo.uff")
    made["fifo_uff"] = sp / "fifo.uff"
    os.mkfifo(sp / "fifo_nosuffix")
    made["fifo_nosuffix"] = sp / "fifo_nosuffix"
    (sp / "zero.h5").symlink_to("/dev/zero")
    made["devzero_h5"] = sp / "zero.h5"
    (sp / "zero.uff").symlink_to("/dev/zero")
    made["devzero_uff"] = sp / "zero.uff"
    made["devzero"] = Path("/dev/zero")
    (sp / "folder.h5").mkdir()
    made["directory_h5"] = sp / "folder.h5"
    (sp / "loop_a.h5").symlink_to(sp / "loop_b.h5")
    (sp / "loop_b.h5").symlink_to(sp / "loop_a.h5")
    made["symlink_loop"] = sp / "loop_a.h5"
    (sp / "dangling.uff").symlink_to(sp / "nowhere.uff")
    made["dangling"] = sp / "dangling.uff"
    (sp / "empty.h5").write_bytes(b"")
    made["empty_h5"] = sp / "empty.h5"
    (sp / "signature.h5").write_bytes(b"\x89HDF\r\n\x1a\n")
    made["signature_only"] = sp / "signature.h5"
    (sp / "text.h5").write_text("not hdf5 at all\n")
    made["text_as_h5"] = sp / "text.h5"
    (sp / "uff_as_h5.h5").write_bytes((EXAMPLES / "smaller_tank.uff").read_bytes())
    made["uff_named_h5"] = sp / "uff_as_h5.h5"
    cases = []
    for key, path in made.items():
        cases.append(Case(f"special_{key}", "special", "special", "file", path=path))
    return cases


# --------------------------------------------------------------------------
# experiment.toml mutations (run)
# --------------------------------------------------------------------------

_EXPERIMENT_MUTATIONS: dict[str, tuple[str, str, str]] = {
    # name: (group, old text, new text) applied to raw_frf/experiment.toml
    "length_text": ("type", "length_m = 0.65", 'length_m = "abc"'),
    "n_elements_float": ("type", "n_elements = 100", "n_elements = 100.5"),
    "nodes_text": ("type", "response_nodes = [3, 6]", 'response_nodes = "3,6"'),
    "nodes_nested": ("type", "response_nodes = [3, 6]", "response_nodes = [[3], 6]"),
    "band_text": ("type", "band_hz = [5.0, 395.0]", 'band_hz = "5-395"'),
    "band_three": ("type", "band_hz = [5.0, 395.0]", "band_hz = [5.0, 100.0, 395.0]"),
    "method_int": ("type", 'method = "plscf"', "method = 5"),
    "max_order_text": ("type", "# max_order = 40", 'max_order = "forty"'),
    "expect_text": ("type", "# expect_hz = [18, 112, 327, 629]", 'expect_hz = ["a"]'),
    "hammer_text": ("type", "hammer_node = 8", 'hammer_node = "eight"'),
    "immersed_int": ("type", "immersed_elements = [10]", 'immersed_elements = "tip"'),
    "seed_float": ("type", "seed = 0", "seed = 0.5"),
    "name_int": ("type", 'name = "genuine"', "name = 3"),
    "configurations_table": ("type", "[[configurations]]\nname = \"genuine\"",
                             "[configurations.x]\nname = \"genuine\""),
    "description_table": ("type", 'description = "beam in air"', "description = {a = 1}"),
    "beam_not_table": ("type", "[beam]                       # initial FE model; Table 3 of "
                       "the paper\nlength_m = 0.65", "beam = 5\n[beamx]\nlength_m = 0.65"),
    "length_negative": ("range", "length_m = 0.65", "length_m = -0.65"),
    "n_elements_zero": ("range", "n_elements = 100 ", "n_elements = 0 "),
    "nodes_out": ("range", "response_nodes = [3, 6]", "response_nodes = [0, 99]"),
    "hammer_out": ("range", "hammer_node = 8", "hammer_node = 50"),
    "direction_7": ("range", "direction = 3", "direction = 7"),
    "band_reversed": ("range", "band_hz = [5.0, 395.0]", "band_hz = [395.0, 5.0]"),
    "band_beyond": ("range", "band_hz = [5.0, 395.0]", "band_hz = [5.0, 1e9]"),
    "band_nan": ("range", "band_hz = [5.0, 395.0]", "band_hz = [nan, 395.0]"),
    "max_order_0": ("range", "# max_order = 40", "max_order = 0"),
    "max_order_huge": ("range", "# max_order = 40", "max_order = 2000"),
    "n_modes_0": ("range", "n_modes = 3", "n_modes = 0"),
    "n_modes_100": ("range", "n_modes = 3", "n_modes = 100"),
    "repeats_negative": ("range", "update_repeats = 1", "update_repeats = -1"),
    "n_modes_text": ("type", "n_modes = 3", 'n_modes = "3"'),
    "immersed_0": ("range", "immersed_elements = [10]", "immersed_elements = [0]"),
    "tau_negative": ("range", 'file = "larger_tank.h5"',
                     'file = "larger_tank.h5"\nexp_window_tau_s = -1.0'),
    "tau_zero": ("range", 'file = "larger_tank.h5"',
                 'file = "larger_tank.h5"\nexp_window_tau_s = 0'),
    "typo_bandhz": ("unknown", "band_hz = [5.0, 395.0]", "bandhz = [5.0, 395.0]"),
    "typo_methd": ("unknown", 'method = "plscf"', 'methd = "plscf"'),
    "typo_table": ("unknown", "[sensors]", "[sensor]"),
    "typo_config_key": ("unknown", 'file = "genuine.uff"', 'file = "genuine.uff"\nfiel = "x"'),
    "nodes_float": ("float_node", "response_nodes = [3, 6]", "response_nodes = [3.7, 6]"),
    "hammer_float": ("float_node", "hammer_node = 8", "hammer_node = 8.5"),
    "method_magic": ("late", 'method = "plscf"', 'method = "magic"'),
    "file_missing": ("late", 'file = "larger_tank.h5"', 'file = "nothere.h5"'),
    "file_directory": ("late", 'file = "larger_tank.h5"', 'file = "."'),
    "file_fifo": ("late", 'file = "larger_tank.h5"', 'file = "fifo.h5"'),
    "file_devzero": ("late", 'file = "larger_tank.h5"', 'file = "/dev/zero"'),
    "file_corrupt": ("late", 'file = "genuine.uff"', 'file = "corrupt.h5"'),
    "name_dotdot": ("name", 'name = "larger_tank"', 'name = "../../x"'),
    "name_dotdot4": ("name", 'name = "larger_tank"', 'name = "../../../../x"'),
    "name_script": ("name", 'name = "larger_tank"', 'name = "<script>alert(1)</script>"'),
    "name_slash": ("name", 'name = "larger_tank"', 'name = "a/b"'),
    "name_empty": ("name", 'name = "larger_tank"', 'name = ""'),
    "duplicate_names": ("name", 'name = "larger_tank"', 'name = "genuine"'),
    "toml_syntax": ("syntax", "[beam]", "[beam"),
    "toml_binary": ("syntax", "", ""),  # replaced below by binary garbage
    "toml_empty": ("syntax", "", ""),  # replaced below by an empty file
}


_FILE_NAMES = {
    "file_missing": ("nothere.h5",),
    "file_directory": ("raw",),
    "file_fifo": ("fifo.h5",),
    "file_devzero": ("/dev/zero",),
    "file_corrupt": ("corrupt.h5",),
}


def _old_results(folder: Path) -> None:
    (folder / "tables").mkdir(parents=True)
    (folder / "report.md").write_text("# earlier results\n")
    (folder / "tables" / "table1_modal_parameters.csv").write_text("configuration,mode\nx,1\n")
    (folder / "ema_results.h5").write_bytes(b"\x89HDF earlier bytes")


#: ``run`` mutations in the quick corpus (at least one per group; most others run
#: the whole study until the experiment file is validated up front).
QUICK_EXPERIMENTS = {
    "nodes_text", "name_int", "band_reversed", "max_order_0", "typo_bandhz", "nodes_float",
    "method_magic", "file_corrupt", "name_script", "toml_syntax", "toml_binary",
}


def fast_inputs(folder: Path) -> Path:
    """The three example configurations cut to 2-400 Hz (three modes; a whole study
    then takes a few seconds) and an experiment file for them, in ``folder``."""
    from ema_pipeline import io  # the writer of the code under test is fine for inputs

    folder.mkdir(parents=True, exist_ok=True)
    for name, fmt in (("genuine.uff", "uff"), ("larger_tank.h5", "h5"),
                      ("smaller_tank.uff", "uff-binary")):
        io.write_frf(io.read_frf(EXAMPLES / name).band(2.0, 400.0), folder / name, fmt)
    text = (EXAMPLES / "experiment.toml").read_text()
    for old, new in (("update_repeats = 5", "update_repeats = 1"),
                     ("band_hz = [5.0, 1000.0]", "band_hz = [5.0, 395.0]"),
                     ("n_modes = 4", "n_modes = 3")):
        assert old in text, old
        text = text.replace(old, new)
    (folder / "experiment.toml").write_text(text)
    return folder


def experiment_cases(root: Path) -> list[Case]:
    inputs = fast_inputs(root / "inputs")
    base = (inputs / "experiment.toml").read_text()
    cases = []
    for key, (group, old, new) in _EXPERIMENT_MUTATIONS.items():
        case_dir = root / f"exp_{key}"
        raw = case_dir / "raw"
        raw.mkdir(parents=True)
        for f in ("genuine.uff", "larger_tank.h5", "smaller_tank.uff"):
            (raw / f).symlink_to(inputs / f)
        os.mkfifo(raw / "fifo.h5")
        corrupt = bytearray((EXAMPLES / "larger_tank.h5").read_bytes())
        corrupt[2104] ^= 0xFF  # a global heap object size: libhdf5 loops
        (raw / "corrupt.h5").write_bytes(bytes(corrupt))
        if key == "toml_binary":
            text = None
            (raw / "experiment.toml").write_bytes(bytes(random.Random(key).randbytes(300)))
        elif key == "toml_empty":
            text = ""
        else:
            if old not in base:
                raise AssertionError(f"mutation {key}: {old!r} not in experiment.toml")
            text = base.replace(old, new, 1)
        if text is not None:
            (raw / "experiment.toml").write_text(text)
        work = case_dir / "work"
        _old_results(work / "results")
        cases.append(
            Case(
                f"exp_{key}",
                "experiment",
                f"experiment_{group}",
                "solo",
                argv=["run", "--raw", str(raw), "--results", "results", "--quiet"],
                names=("experiment.toml", *_FILE_NAMES.get(key, ())),
                garbage=group != "name" or key in ("name_empty", "duplicate_names"),
                results_dir="results",
                path=case_dir,
                check=_check_html,
                timeout_s=RUN_TIMEOUT_S,
                quick=key in QUICK_EXPERIMENTS,
            )
        )
    return cases


def _check_html(cwd: Path, out: Outcome) -> list[str]:
    bad = []
    for html in cwd.parent.rglob("*.html"):
        if "<script>alert" in html.read_text(errors="replace"):
            bad.append("html")
    return bad


# --------------------------------------------------------------------------
# CLI options, batch, disk full
# --------------------------------------------------------------------------


QUICK_OPTIONS = {"max_order_0", "max_order_500", "sdypy_order_2", "band_reversed",
                 "band_beyond", "band_nan", "method_magic", "expect_text"}


def option_cases(root: Path) -> list[Case]:
    good = str(EXAMPLES / "larger_tank.h5")
    abuse = {
        "max_order_0": ("--max-order", "0"),
        "max_order_1": ("--max-order", "1"),
        "max_order_negative": ("--max-order", "-5"),
        "max_order_500": ("--max-order", "500"),
        "max_order_2000": ("--max-order", "2000"),
        "sdypy_order_2": ("--method", "sdypy-lscf", "--max-order", "2"),
        "band_reversed": ("--band", "1000", "5"),
        "band_empty": ("--band", "5", "5"),
        "band_negative": ("--band", "-10", "5"),
        "band_beyond": ("--band", "5", "1e9"),
        "band_nan": ("--band", "nan", "500"),
        "band_inf": ("--band", "5", "inf"),
        "method_magic": ("--method", "magic"),
        "expect_text": ("--expect", "abc"),
        "expect_negative": ("--expect", "-5,20"),
        "expect_nan": ("--expect", "nan"),
    }
    cases = []
    for key, opts in abuse.items():
        out = root / f"opt_{key}"
        cases.append(
            Case(
                f"opt_{key}", "cli_option", "cli_option", "solo",
                argv=["identify", good, "--out", str(out), *opts],
                names=(opts[0], "order", "band", "method", "expect"),
                path=out,
                timeout_s=GUARD_TIMEOUT_S if key.startswith("max_order_") else OPTION_TIMEOUT_S,
                quick=key in QUICK_OPTIONS,
            )
        )
    cases.append(
        Case("opt_workers_0", "cli_option", "cli_option", "solo",
             argv=["batch", str(EXAMPLES), "--out", str(root / "w0"), "--workers", "0"],
             names=("--workers",), path=root / "w0", quick=False)
    )
    return cases


def batch_cases(root: Path, bad_files: list[Case]) -> list[Case]:
    folder = root / "batch_in"
    folder.mkdir()
    for c in bad_files:
        shutil.copyfile(c.path, folder / c.path.name)
    os.mkfifo(folder / "fifo.h5")
    (folder / "loop.h5").symlink_to(folder / "loop.h5")
    out = folder / "out"  # inside the input folder
    return [
        Case("batch_bad_folder", "batch", "batch", "solo", expect_exit=1,
             argv=["batch", str(folder), "--out", str(out), "--workers", "1", "--quiet",
                   "--band", *FAST_BAND],
             names=("failed",), path=folder, check=_check_batch_tables)
    ]


def _check_batch_tables(cwd: Path, out: Outcome) -> list[str]:
    import csv

    folder = cwd.parent / "batch_in"
    failures = folder / "out" / "failures.csv"
    summary = folder / "out" / "summary.csv"
    if not failures.is_file() or not summary.is_file():
        return ["table"]
    rows = list(csv.DictReader(failures.open()))
    names = {Path(r.get("path", r.get("file", ""))).name for r in rows}
    expected = {p.name for p in folder.glob("*") if p.suffix in (".h5", ".uff") and p.is_file()}
    problems = []
    if not expected <= names or any(not r.get("sha256") for r in rows):
        problems.append("table")
    if any("_result" in r.get("path", "") for r in csv.DictReader(summary.open())):
        problems.append("table")
    return problems


def disk_full_cases(root: Path) -> list[Case]:
    cases = []
    out = root / "df_identify"
    cases.append(Case("diskfull_identify", "disk_full", "disk_full_identify", "solo",
                      expect_exit=1, argv=["identify", str(EXAMPLES / "larger_tank.h5"),
                                           "--out", str(out), "--quiet"],
                      names=("larger_tank",), fsize_limit=DISK_LIMIT, path=out))
    case_dir = root / "df_run"
    work = case_dir / "work"
    _old_results(work / "results")
    raw = fast_inputs(case_dir / "raw")
    cases.append(Case("diskfull_run", "disk_full", "disk_full_run", "solo", expect_exit=1,
                      argv=["run", "--raw", str(raw), "--results", "results", "--quiet"],
                      names=("results", "space", "large"), fsize_limit=DISK_LIMIT,
                      results_dir="results", path=case_dir, timeout_s=RUN_TIMEOUT_S))
    folder = root / "df_batch_in"
    folder.mkdir()
    for f in ("larger_tank.h5", "genuine.uff"):
        shutil.copyfile(EXAMPLES / f, folder / f)
    cases.append(Case("diskfull_batch", "disk_full", "disk_full_batch", "solo", expect_exit=1,
                      argv=["batch", str(folder), "--out", str(root / "df_batch_out"),
                            "--workers", "1", "--quiet", "--band", *FAST_BAND],
                      names=("df_batch_out", "space", "large"), fsize_limit=DISK_LIMIT,
                      path=root / "df_batch_out"))
    return cases


def _nothing_written(folder: Path, out: Outcome) -> list[str]:
    """Bad input: the output folder stays empty (no FRF, no hit table, no temporary)."""
    return ["litter"] if folder.exists() and any(folder.iterdir()) else []


def recording_cases(root: Path) -> list[Case]:
    """Issue 26: bad raw recordings for ``frf`` (NaN, truncated UFF / TDMS / WAV,
    different sample rates, no force channel, unknown unit, no hit, every hit rejected),
    made from generated recordings; ``--report`` too, so that no page is written either."""
    from nptdms import ChannelObject, TdmsWriter

    from tests.impact_recordings import make_recording, write_tdms, write_uff

    root.mkdir(parents=True)
    rec = make_recording(5, n_hits=5, n_resp=1, last_hit_short=False)
    n = 4 * int(rec.sample_rate_hz)  # the first hits, to keep the files small
    t = rec.time_s[:n]
    files: dict[str, Path] = {}

    def csv(name: str, header: str, force: np.ndarray, acc: np.ndarray) -> None:
        rows = "\n".join(f"{a:.7f},{b:.6e},{c:.6e}" for a, b, c in zip(t, force, acc,
                                                                      strict=True))
        (root / name).write_text(f"{header}\n{rows}\n")
        files[name] = root / name

    acc_nan = rec.response[0, :n].copy()
    acc_nan[n // 3] = np.nan
    csv("rec_nan.csv", "time_s,force [N],acc [m/s^2]", rec.force_n[:n], acc_nan)
    csv("rec_noforce.csv", "time_s,acc0 [m/s^2],acc [m/s^2]", rec.force_n[:n],
        rec.response[0, :n])
    csv("rec_unit.csv", "time_s,force [N],acc [furlong/s^2]", rec.force_n[:n],
        rec.response[0, :n])
    raw = write_uff(rec, root / "full.uff").read_bytes()
    (root / "rec_truncated.uff").write_bytes(raw[: len(raw) * 3 // 4])
    files["rec_truncated.uff"] = root / "rec_truncated.uff"
    raw = write_tdms(rec, root / "full.tdms").read_bytes()
    (root / "rec_truncated.tdms").write_bytes(raw[: len(raw) // 2])
    files["rec_truncated.tdms"] = root / "rec_truncated.tdms"
    with TdmsWriter(str(root / "rec_rates.tdms")) as writer:
        writer.write_segment([
            ChannelObject("g", "Hammer force", rec.force_n[:n],
                          properties={"unit_string": "N", "wf_increment": 1 / 2048}),
            ChannelObject("g", "Acc", rec.response[0, :n],
                          properties={"unit_string": "m/s^2", "wf_increment": 1 / 1024}),
        ])
    files["rec_rates.tdms"] = root / "rec_rates.tdms"
    # no hit: the force channel holds only its noise
    quiet = rec.noise_std[0] * np.random.default_rng(1).standard_normal(n)
    with TdmsWriter(str(root / "rec_nohit.tdms")) as writer:
        writer.write_segment([
            ChannelObject("g", "Hammer force", quiet,
                          properties={"unit_string": "N", "wf_increment": 1 / 2048}),
            ChannelObject("g", "Acc", rec.response[0, :n],
                          properties={"unit_string": "m/s^2", "wf_increment": 1 / 2048}),
        ])
    files["rec_nohit.tdms"] = root / "rec_nohit.tdms"
    # every hit rejected: all of them double hits
    doubles = make_recording(7, n_hits=5, n_double=5, n_resp=1, last_hit_short=False)
    files["rec_alldouble.tdms"] = write_tdms(doubles, root / "rec_alldouble.tdms")
    # a truncated WAV (int16, 2 channels): the data chunk says more than the file holds
    from scipy.io import wavfile

    pcm = np.vstack([rec.force_n[:n] / rec.full_scale[0], rec.response[0, :n]
                     / rec.full_scale[1]]).T
    wavfile.write(root / "full.wav", 2048, np.round(pcm * 32000).astype(np.int16))
    raw = (root / "full.wav").read_bytes()
    (root / "rec_truncated.wav").write_bytes(raw[: len(raw) * 3 // 5 + 1])
    files["rec_truncated.wav"] = root / "rec_truncated.wav"
    (root / "full.wav").unlink()
    (root / "full.uff").unlink()
    (root / "full.tdms").unlink()
    cases = []
    for path in files.values():
        stem = f"{path.stem}_{path.suffix[1:]}"
        out = root / f"out_{stem}"
        extra = (["--unit", "0=N", "--unit", "1=m/s^2", "--scale", f"0={rec.full_scale[0]}",
                  "--scale", f"1={rec.full_scale[1]}"] if path.suffix == ".wav" else [])
        cases.append(Case(stem, "recording", "recording_bad", "solo",
                          argv=["frf", str(path), "--out", str(out / "frf.h5"), "--quiet",
                                "--report", *extra],
                          names=(path.name,), path=out, check=_nothing_written))
    return cases


def _folder_hashes(folder: Path) -> dict[str, str]:
    return {str(q.relative_to(folder)): hashlib.sha256(q.read_bytes()).hexdigest()
            for q in sorted(folder.rglob("*")) if q.is_file() and not q.is_symlink()}


def _left_as_it_was(expected: dict[str, str]) -> Callable[[Path, Outcome], list[str]]:
    """The case's folder after the run: every input byte-identical (else ``results``)
    and nothing new (else ``litter``)."""
    def check(folder: Path, out: Outcome) -> list[str]:
        now = _folder_hashes(folder)
        bad = ["results"] if any(now.get(k) != v for k, v in expected.items()) else []
        return bad + (["litter"] if set(now) - set(expected) else [])

    return check


def hostile_recording_cases(root: Path) -> list[Case]:
    """Issue 39: ``frf`` on hostile recordings, options and outputs: an output that is
    an input, a hit page that is a folder, WAV headers cut or damaged, absurd time
    steps, options out of range, a square-wave force, a time-record UFF cut at a
    record boundary, a complex TDMS channel. Each must exit 2 naming the file or
    option, write nothing and change no input."""
    import struct

    from nptdms import ChannelObject, TdmsWriter
    from scipy.io import wavfile

    from ema_pipeline import acquisition
    from ema_pipeline import io as ema_io
    from tests.impact_recordings import make_recording

    root.mkdir(parents=True)
    rec = make_recording(5, n_hits=5, n_resp=1, last_hit_short=False)
    n = 4 * int(rec.sample_rate_hz)
    t = rec.time_s[:n]

    def csv_text(force: np.ndarray, step: float | None = None) -> str:
        times = t if step is None else np.arange(n) * step
        rows = "\n".join(f"{float(a)!r},{b:.6e},{c:.6e}" for a, b, c in
                         zip(times, force, rec.response[0, :n], strict=True))
        return f"time_s,force [N],acc [m/s^2]\n{rows}\n"

    pcm = np.vstack([rec.force_n[:n] / rec.full_scale[0],
                     rec.response[0, :n] / rec.full_scale[1]]).T
    wav_path = root / "full.wav"
    wavfile.write(wav_path, 2048, np.round(pcm * 32000).astype(np.int16))
    wav = wav_path.read_bytes()
    wav_path.unlink()
    wav_opts = ["--unit", "0=N", "--unit", "1=m/s^2", "--scale", f"0={rec.full_scale[0]}",
                "--scale", f"1={rec.full_scale[1]}"]

    def patched(offset: int, fmt: str, value: int) -> bytes:
        raw = bytearray(wav)
        raw[offset:offset + struct.calcsize(fmt)] = struct.pack(fmt, value)
        return bytes(raw)

    setup = acquisition.TestSetup(n_samples=2048)
    from ema_pipeline.pipeline.simulate import paper_modes

    records = acquisition.simulate_time_records(paper_modes("genuine", setup), setup,
                                                snr_db=50, seed=3)
    uff_path = ema_io.write_time_uff(records, root / "sim.uff")
    uff = uff_path.read_bytes()
    uff_path.unlink()
    starts = [m.start() for m in re.finditer(rb"(?m)^    -1\r?\n    58", uff)]
    square = np.where((t // 0.25) % 2 == 0, 1000.0, -1000.0)
    edges = np.zeros(n)  # issue 49: hits at the first and the last sample, no room for either
    edges[[0, -1]] = 1000.0

    # name: (files {name: bytes or text}, argv after "frf", names in stderr, quick)
    specs: dict[str, tuple[dict[str, bytes | str], list[str], tuple[str, ...], bool]] = {
        "h39_out_is_input": ({"rec.uff": uff}, ["rec.uff", "--out", "rec.uff"],
                             ("rec.uff: --out would overwrite the input",), True),
        "h39_hits_is_input": ({"rec_hits.csv": csv_text(rec.force_n[:n])},
                              ["rec_hits.csv", "--out", "rec.h5"],
                              ("rec_hits.csv: the hit table of --out",), True),
        "h39_page_is_folder": ({"rec.csv": csv_text(rec.force_n[:n]), "o_hits.html/x": "x"},
                               ["rec.csv", "--out", "o.h5", "--report"],
                               ("o_hits.html: is a folder",), True),
        "h39_wav_cut30": ({"rec.wav": wav[:30]}, ["rec.wav", *wav_opts],
                          ("rec.wav: truncated WAV header",), True),
        "h39_wav_0ch": ({"rec.wav": patched(22, "<H", 0)}, ["rec.wav", *wav_opts],
                        ("rec.wav: WAV header declares 0 channels",), True),
        "h39_wav_65535ch": ({"rec.wav": patched(22, "<H", 65535)}, ["rec.wav", *wav_opts],
                            ("rec.wav: WAV header declares 65535 channels",), False),
        "h39_wav_frames": ({"rec.wav": wav[:44 + 4 * 3000]}, ["rec.wav", *wav_opts],
                           ("rec.wav: truncated WAV file",), True),
        "h39_wav_4gb": ({"rec.wav": patched(40, "<I", 0xFFFFFFFF)}, ["rec.wav", *wav_opts],
                        ("rec.wav: truncated WAV file",), False),
        "h39_dt_tiny": ({"rec.csv": csv_text(rec.force_n[:n], 1e-300)}, ["rec.csv"],
                        ("rec.csv: time column 'time_s': time step 1e-300 s",), True),
        "h39_dt_huge": ({"rec.csv": csv_text(rec.force_n[:n], 1e296)}, ["rec.csv"],
                        ("rec.csv: time column 'time_s': time step 1e+296 s",), True),
        "h39_record_1e16": ({"rec.csv": csv_text(rec.force_n[:n])},
                            ["rec.csv", "--record-length-s", "1e16"],
                            ("--record-length-s",), False),
        "h39_pretrigger_1e300": ({"rec.csv": csv_text(rec.force_n[:n])},
                                 ["rec.csv", "--pretrigger-s", "1e300"], ("--pretrigger-s",),
                                 False),
        "h39_pretrigger_3": ({"rec.csv": csv_text(rec.force_n[:n])},
                             ["rec.csv", "--pretrigger-s", "3"],
                             ("rec.csv: the pretrigger (--pretrigger-s) 3 s",), True),
        "h39_force_window": ({"rec.csv": csv_text(rec.force_n[:n])},
                             ["rec.csv", "--force-window-s", "0.005"],
                             ("rec.csv: --force-window-s 0.005 s ends before",), True),
        "h39_tau": ({"rec.csv": csv_text(rec.force_n[:n])},
                    ["rec.csv", "--exp-window-tau", "1e-5"],
                    ("rec.csv: exponential window time constant",), False),
        "h39_scale": ({"rec.csv": csv_text(rec.force_n[:n])},
                      ["rec.csv", "--scale", "force=1e308"],
                      ("rec.csv: channel 'force': scale 1e+308",), False),
        "h39_square": ({"rec.csv": csv_text(square)}, ["rec.csv"],
                       ("rec.csv: every hit rejected (hit 1 at 0.500 s: overload ('force')",),
                       True),
        "h39_uff_records": ({"rec.uff": uff[:starts[6]]}, ["rec.uff"],
                            ("rec.uff: truncated Universal File: 6 of 12",), True),
        "h49_edge_hits": ({"rec.csv": csv_text(edges)}, ["rec.csv"],
                          ("rec.csv: no room for a record: the data end 1 sample(s) after",),
                          True),
    }
    cases = []
    for name, (files, args, names, quick) in specs.items():
        folder = root / name
        folder.mkdir()
        for rel, content in files.items():
            target = folder / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            if isinstance(content, bytes):
                target.write_bytes(content)
            else:
                target.write_text(content)
        argv = ["frf", *(str(folder / a) if a in files or (k and args[k - 1] == "--out")
                         else a for k, a in enumerate(args))]
        if "--out" not in argv:
            argv += ["--out", str(folder / "frf.h5")]
        argv.append("--quiet")
        cases.append(Case(name, "recording", "recording_hostile", "solo", argv=argv,
                          names=names, path=folder, quick=quick,
                          check=_left_as_it_was(_folder_hashes(folder))))
    tdms = root / "h39_tdms_complex"
    tdms.mkdir()
    with TdmsWriter(str(tdms / "rec.tdms")) as writer:
        writer.write_segment([
            ChannelObject("g", "Hammer force", rec.force_n[:n],
                          properties={"unit_string": "N", "wf_increment": 1 / 2048}),
            ChannelObject("g", "Acc", rec.response[0, :n] * (1 + 1j),
                          properties={"unit_string": "m/s^2", "wf_increment": 1 / 2048})])
    cases.append(Case("h39_tdms_complex", "recording", "recording_hostile", "solo",
                      argv=["frf", str(tdms / "rec.tdms"), "--out", str(tdms / "frf.h5"),
                            "--quiet"],
                      names=("rec.tdms: channel 'g/Acc' holds complex",), path=tdms,
                      check=_left_as_it_was(_folder_hashes(tdms))))
    for name, inp, out, said in (  # issue 49: symbolic link loops as input and output
            ("h49_loop_input", "loop.uff", "frf.h5", "loop.uff: symbolic link loop"),
            ("h49_loop_output", "rec.csv", "loop/frf.h5",
             "loop/frf.h5: --out goes through a symbolic link loop")):
        folder = root / name
        folder.mkdir()
        (folder / "rec.csv").write_text(csv_text(rec.force_n[:n]))
        for link in ("loop", "loop.uff"):
            (folder / link).symlink_to(link)  # each names itself
        cases.append(Case(name, "recording", "recording_hostile", "solo",
                          argv=["frf", str(folder / inp), "--out", str(folder / out), "--quiet"],
                          names=(said,), path=folder,
                          check=_left_as_it_was(_folder_hashes(folder))))
    return cases


def build_cases(root: Path) -> list[Case]:
    """The whole corpus, generated in ``root`` (deterministic)."""
    files = root / "files"
    files.mkdir(parents=True)
    h5 = h5_flip_cases(files) + h5_trunc_cases(files) + h5_malformed_cases(files)
    uff = uff_cases(files)
    special = special_cases(files)
    (root / "bt").mkdir()
    bad_for_batch = [c for c in h5_trunc_cases(root / "bt") if c.name.endswith(("_8", "_2100"))]
    bad_for_batch += [c for c in h5 if c.name in ("h5bad_huge_declared", "h5bad_external_link",
                                                   "h5bad_tau_negative")]
    cases = h5 + uff + special + experiment_cases(root / "exp") + option_cases(root / "opt")
    cases += batch_cases(root, bad_for_batch) + disk_full_cases(root)
    cases += recording_cases(root / "rec")
    cases += hostile_recording_cases(root / "rec39")
    names = [c.name for c in cases]
    assert len(names) == len(set(names)), "case names repeat"
    return cases if FULL else [c for c in cases if c.quick]


# --------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------


def _limits(fsize: int | None) -> Callable[[], None]:
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        if fsize is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

    return apply


#: The package's modules the commands import, loaded once by :func:`_preload`
#: in the process that forks the cases (:func:`run_cli`).
PRELOAD = ("ema_pipeline.cli", "ema_pipeline.pipeline.frf", "ema_pipeline.pipeline.study",
           "ema_pipeline.pipeline.many", "ema_pipeline.pipeline.batch",
           "ema_pipeline.pipeline.reports")


def _cli_env() -> dict[str, str]:
    """The environment of a CLI run: PYTHONPATH the code under test, one BLAS
    thread, no faulthandler."""
    env = dict(os.environ, PYTHONPATH=str(CODE), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    env.pop("PYTHONFAULTHANDLER", None)
    return env


_PRELOADED: list[bool] = []


def _preload() -> bool:
    """Import :data:`PRELOAD` from the code under test into this process (once);
    False where it cannot (another tree of the package already imported)."""
    if not _PRELOADED:
        import importlib

        sys.path.insert(0, str(CODE))
        ok = True
        for name in PRELOAD:
            module = importlib.import_module(name)
            ok = ok and Path(module.__file__).resolve().is_relative_to(CODE.resolve())
        _PRELOADED.append(ok)
    return _PRELOADED[0]


def run_cli(argv: list[str], cwd: Path, timeout: float, fsize: int | None = None) -> Outcome:
    """``python -m ema_pipeline ARGV`` in ``cwd`` (PYTHONPATH = this repository):
    forked from this process with the package already imported
    (:func:`_forked_cli`, what ``python -m ema_pipeline`` does without paying
    the imports again, about 1 s a case) where this process runs one thread,
    else a fresh interpreter."""
    cwd.mkdir(parents=True, exist_ok=True)
    if threading.active_count() == 1 and _preload():
        return _forked_cli(argv, cwd, timeout, fsize)
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "ema_pipeline", *argv], cwd=cwd,
                            env=_cli_env(), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, errors="replace",
                            preexec_fn=_limits(fsize), start_new_session=True)
    out = Outcome()
    try:
        out.stdout, out.stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out.stdout, out.stderr = proc.communicate()
        out.timed_out = True
    else:  # reap a batch's workers that outlived their parent
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    out.seconds = time.perf_counter() - start
    if not out.timed_out:
        if proc.returncode < 0:
            out.signal = -proc.returncode
        else:
            out.rc = proc.returncode
    return out


def _forked_cli(argv: list[str], cwd: Path, timeout: float, fsize: int | None) -> Outcome:
    """:func:`run_cli` in a child forked from this process (which has imported
    the package, :func:`_preload`): the child starts a session of its own, takes
    the limits, the environment, ``cwd``, stdin from /dev/null and stdout and
    stderr to files, and runs ``sys.exit(ema_pipeline.cli.main(ARGV))`` as
    ``python -m ema_pipeline`` does (an exception escaping it printed as a
    traceback, exit status 1)."""
    import tempfile

    sys.stdout.flush()
    sys.stderr.flush()
    files = [tempfile.TemporaryFile() for _ in range(2)]
    start = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        code = 1
        try:
            os.setsid()
            _limits(fsize)()
            os.environ.clear()
            os.environ.update(_cli_env())
            os.chdir(cwd)
            null = os.open(os.devnull, os.O_RDONLY)
            os.dup2(null, 0)
            os.dup2(files[0].fileno(), 1)
            os.dup2(files[1].fileno(), 2)
            sys.argv = [str(CODE / "ema_pipeline" / "__main__.py"), *argv]
            # __main__ as under ``python -m ema_pipeline``: worker processes
            # started by spawn or forkserver (batch) do not import it again
            import importlib.util
            import types

            main_module = types.ModuleType("__main__")
            main_module.__file__ = sys.argv[0]
            main_module.__spec__ = importlib.util.find_spec("ema_pipeline.__main__")
            sys.modules["__main__"] = main_module
            from ema_pipeline.cli import main

            code = main(argv)
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
            if not isinstance(stop.code, int | None):
                print(stop.code, file=sys.stderr)
        except BaseException:
            import traceback

            traceback.print_exc()
            code = 1
        finally:
            # the interpreter's own end: wait for the threads, run the atexit
            # functions (temporary files, worker pools), flush
            import atexit

            with contextlib.suppress(BaseException):
                threading._shutdown()  # type: ignore[attr-defined]
            with contextlib.suppress(BaseException):
                atexit._run_exitfuncs()
            with contextlib.suppress(BaseException):
                sys.stdout.flush()
                sys.stderr.flush()
            os._exit(code if isinstance(code, int) else 1)
    out = Outcome()
    deadline = start + timeout
    status = None
    while status is None:
        done, status_code = os.waitpid(pid, os.WNOHANG)
        if done:
            status = status_code
        elif time.perf_counter() > deadline:
            os.killpg(pid, signal.SIGKILL)
            _, status = os.waitpid(pid, 0)
            out.timed_out = True
        else:
            time.sleep(0.02)
    with contextlib.suppress(ProcessLookupError):  # a batch's workers that outlived it
        os.killpg(pid, signal.SIGKILL)
    out.seconds = time.perf_counter() - start
    for f, attr in zip(files, ("stdout", "stderr"), strict=True):
        f.seek(0)
        setattr(out, attr, f.read().decode(errors="replace"))
        f.close()
    if not out.timed_out:
        if os.WIFSIGNALED(status):
            out.signal = os.WTERMSIG(status)
        else:
            out.rc = os.WEXITSTATUS(status)
    return out


def _troubled(out: Outcome) -> bool:
    return out.timed_out or out.signal is not None or "Traceback" in out.stderr


def _file_status(case: Case, out: Outcome) -> str:
    p = str(case.path)
    if any(line.startswith(f"{p}: ") and (" modes [" in line or " mode [" in line)
           for line in out.stdout.splitlines()):
        return "ok"
    if any(case.path.name in line for line in out.stderr.splitlines()):
        return "error"
    return "silent"


def _run_file_group(cases: list[Case], work: Path, tag: str) -> dict[str, Outcome]:
    out_dir = work / f"out_{tag}"
    argv = ["identify", *(str(c.path) for c in cases), "--out", str(out_dir), "--quiet",
            "--band", *FAST_BAND]
    # --quiet prints nothing on success: ask for the success lines instead.
    argv.remove("--quiet")
    group = run_cli(argv, work, GROUP_TIMEOUT_S + PER_FILE_TIMEOUT_S * len(cases))
    if len(cases) > 1 and _troubled(group):
        results = {}
        for k, c in enumerate(cases):
            results.update(_run_file_group([c], work, f"{tag}_{k}"))
        return results
    results = {}
    for c in cases:
        o = Outcome(group.rc, group.signal, group.timed_out, group.stdout, group.stderr,
                    solo=len(cases) == 1, seconds=group.seconds)
        o.file_status = _file_status(c, group)
        results[c.name] = o
    return results


def run_cases(cases: list[Case], work: Path, workers: int = 2,
              group_size: int = 20) -> dict[str, Outcome]:
    """Run every case; returns outcomes by case name."""
    jobs: list[Callable[[], dict[str, Outcome]]] = []
    file_cases = [c for c in cases if c.kind == "file"]
    by_group: dict[str, list[Case]] = defaultdict(list)
    for c in file_cases:
        by_group["files"].append(c)
    for key, group in by_group.items():
        size = group_size
        for k in range(0, len(group), size):
            chunk = group[k : k + size]
            jobs.append(lambda chunk=chunk, tag=f"{key}{k}": _run_file_group(chunk, work, tag))
    solos = sorted((c for c in cases if c.kind == "solo"), key=lambda c: -c.timeout_s)
    # Long jobs (whole studies, batches) first, so that the two workers end together.
    jobs = [lambda c=c: {c.name: _run_solo(c, work)} for c in solos] + jobs
    results: dict[str, Outcome] = {}
    if workers == 1:  # in this thread (run_cli forks from a one-thread process)
        for job in jobs:
            results.update(job())
        return results
    with ThreadPoolExecutor(workers) as pool:
        for part in pool.map(lambda j: j(), jobs):
            results.update(part)
    return results


def _run_solo(case: Case, work: Path) -> Outcome:
    cwd = (case.path / "work") if case.results_dir else (work / f"cwd_{case.name}")
    root = case.path if case.results_dir else cwd
    before = _tree(root)
    out = run_cli(case.argv, cwd, case.timeout_s, case.fsize_limit)
    out.file_status = "ok" if out.rc == 0 else "error"
    out.tree_before, out.tree_after = before, _tree(root)  # type: ignore[attr-defined]
    return out


def _tree(folder: Path) -> dict[str, str]:
    """Relative path -> sha256 of every regular file below ``folder`` (symlinks skipped)."""
    out = {}
    if not folder.exists():
        return out
    for p in sorted(folder.rglob("*")):
        if p.is_symlink() or not p.is_file():
            continue
        out[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


# --------------------------------------------------------------------------
# Judging
# --------------------------------------------------------------------------


def verdict(case: Case, out: Outcome) -> list[str]:
    """The checks ``case`` fails (empty: it passed)."""
    bad = []
    if out.signal is not None:
        bad.append("signal")
    if out.timed_out:
        bad.append("hang")
    if "Traceback" in out.stderr:
        bad.append("traceback")
    if bad:
        return bad
    if case.kind == "file":
        if out.file_status == "ok":
            if case.garbage:
                bad.append("exit0")
        elif out.file_status != "error":
            bad.append("message")
        if out.file_status != "ok" and out.rc != case.expect_exit:
            bad.append("exit_code")  # one input error in an identify run: exit 2
        return bad
    if out.rc == 0:
        if case.garbage:
            bad.append("exit0")
    else:
        if case.expect_exit is not None and out.rc != case.expect_exit:
            bad.append("exit_code")
        if not any(n in out.stderr for n in case.names):
            bad.append("message")
        if len([ln for ln in out.stderr.splitlines() if ln.strip()]) > 3:
            bad.append("message")  # one line per error, no warnings around it
    before, after = out.tree_before, out.tree_after  # type: ignore[attr-defined]
    if case.results_dir and out.rc != 0:
        old = {k: v for k, v in before.items() if k.startswith(f"work/{case.results_dir}/")}
        new = {k: v for k, v in after.items() if k.startswith(f"work/{case.results_dir}/")}
        if old != new:
            bad.append("results")
    if case.results_dir:
        extra = [k for k in set(after) - set(before)
                 if not k.startswith(f"work/{case.results_dir}/")]
        temporary = [k for k in extra if re.search(r"\.partial-|\.old-|\.tmp$", k)]
        if temporary:
            bad.append("litter")
        if len(temporary) < len(extra):
            bad.append("escape")
    elif any(Path(k).name.endswith(".tmp") or ".partial-" in k for k in after):
        bad.append("litter")
    if case.check is not None:
        cwd = (case.path / "work") if case.results_dir else case.path
        bad += case.check(cwd, out)
    return sorted(set(bad))


def summarize(cases: list[Case], outcomes: dict[str, Outcome]) -> str:
    per_cat: dict[str, Counter] = defaultdict(Counter)
    failing: dict[str, list[str]] = defaultdict(list)
    for c in cases:
        bad = verdict(c, outcomes[c.name])
        per_cat[c.category]["cases"] += 1
        if bad:
            per_cat[c.category]["failed"] += 1
            failing[c.group].append(f"{c.name}: {','.join(bad)}")
        for b in bad:
            per_cat[c.category][b] += 1
    lines = []
    total = Counter()
    for cat, cnt in per_cat.items():
        total.update(cnt)
        detail = ", ".join(f"{k} {v}" for k, v in sorted(cnt.items())
                           if k not in ("cases", "failed"))
        lines.append(f"{cat:14s} {cnt['failed']:3d}/{cnt['cases']:3d} failed  {detail}")
    detail = ", ".join(f"{k} {v}" for k, v in sorted(total.items())
                       if k not in ("cases", "failed"))
    lines.append(f"{'TOTAL':14s} {total['failed']:3d}/{total['cases']:3d} failed  {detail}")
    for group, items in failing.items():
        lines.append(f"\n[{group}]")
        lines += [f"  {i}" for i in items]
    return "\n".join(lines)


def save_verdicts(root: Path, workers: int = 2) -> Path:
    """Generate the corpus in ``root``, run it and write every case's group,
    failed checks (:func:`verdict`) and outcome to ``root/verdicts.json``."""
    import json

    cases = build_cases(root)
    outcomes = run_cases(cases, root / "work", workers=workers)
    table = {c.name: {"group": c.group, "bad": verdict(c, outcomes[c.name]),
                      "rc": outcomes[c.name].rc, "signal": outcomes[c.name].signal,
                      "stderr": outcomes[c.name].stderr[-2000:]} for c in cases}
    path = root / "verdicts.json"
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(table))
    tmp.rename(path)
    return path


if __name__ == "__main__" and sys.argv[1:2] == ["--save"]:
    # python -m tests.fuzz_cases --save ROOT WORKERS (the test suite's background run)
    save_verdicts(Path(sys.argv[2]), workers=int(sys.argv[3]))
elif __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory(prefix="ema-fuzz-") as tmp:
        t0 = time.perf_counter()
        wanted = [a for a in sys.argv[1:] if not a.startswith("-")]
        all_cases = [c for c in build_cases(Path(tmp))
                     if not wanted or c.category in wanted or c.group in wanted]
        t1 = time.perf_counter()
        outcomes = run_cases(all_cases, Path(tmp) / "work")
        t2 = time.perf_counter()
        print(summarize(all_cases, outcomes))
        print(f"\n{len(all_cases)} cases: generated in {t1 - t0:.1f} s, run in {t2 - t1:.1f} s")
        if "-v" in sys.argv:
            for c in all_cases:
                o = outcomes[c.name]
                if verdict(c, o):
                    print(f"--- {c.name} rc={o.rc} sig={o.signal} hang={o.timed_out}")
                    print(o.stderr[-600:])
