"""Write ``examples/pyfrf-impact.uff``: a real impact recording, five pre-cut hits.

Provenance
----------
The numbers are the "real measurements" of pyFRF's showcase: ``data/measurements_1.npy``
... ``measurements_5.npy`` of https://github.com/ladisk/pyFRF, added in commit 55431fd
("added real measurements to showcase", Janko Slavič, 2016-09-15) and removed from the
repository in 9451dd5 (2019-04-18). (c) the pyFRF authors (Martin Česnik, Matjaž Mršnik,
Miha Pirnat, Janko Slavič, Blaž Starc). At that commit pyFRF was distributed under the
GNU LGPL v3 (its ``LICENSE`` file; the MIT licence of pyFRF dates from 2023, after the
data had left the repository), so this file is under the LGPL v3: see
``examples/README.md`` and ``examples/LICENSE-pyFRF-data.txt``.

Each ``.npy`` is one hit, a (3, 25600) float64 array: time in s (0 to 1 s at 25.6 kHz),
force in N and acceleration in m/s^2 (peaks 70-90 N and 440-550 m/s^2; pyFRF's showcase
treats the third row as an acceleration, the unit is not stated). The geometry is not
given either: here the force is DOF 1+Z and the acceleration 2+Z.

What this script changes: the five hits become UFF dataset 58 time records (function
type 1), binary, one load case per hit (1 to 5), force with ordinate data type 13 and
label ``N``, acceleration with data type 12 and label ``m/s^2``, stored as float32
(ordinate data type 2; a relative rounding of 6e-8, far below the resolution of the
24-bit DAQ that recorded them). Nothing else: no filtering, no offset removal.

Run once, from the repository root, with a checkout of pyFRF at 55431fd::

    python examples/make_pyfrf_example.py PATH/TO/pyFRF/data examples/pyfrf-impact.uff

Only numpy (``np.load(..., allow_pickle=False)``) and pyuff are used.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

SAMPLE_RATE_HZ = 25600.0
#: (row, name, UFF ordinate data type, unit label, length exp, force exp, node)
CHANNELS = ((1, "force", 13, "N", 0, 1, 1), (2, "acceleration", 12, "m/s^2", 1, 0, 2))


def load_hits(folder: Path) -> list[np.ndarray]:
    """The five (3, 25600) arrays, checked against the description above."""
    hits = []
    for k in range(1, 6):
        data = np.load(folder / f"measurements_{k}.npy", allow_pickle=False)
        if data.shape != (3, 25600) or not np.all(np.isfinite(data)):
            raise SystemExit(f"measurements_{k}.npy: unexpected content {data.shape}")
        step = np.diff(data[0])
        if not np.allclose(step, 1.0 / SAMPLE_RATE_HZ, rtol=1e-9, atol=0):
            raise SystemExit(f"measurements_{k}.npy: time row is not 25.6 kHz")
        hits.append(data)
    return hits


def write(hits: list[np.ndarray], out: Path) -> None:
    import pyuff

    sets = []
    for case, data in enumerate(hits, start=1):
        for row, name, dtype, unit, len_exp, force_exp, node in CHANNELS:
            sets.append(pyuff.prepare_58(
                binary=1, id1=f"pyFRF showcase hit {case}: {name}",
                id2="ladisk/pyFRF 55431fd data/measurements_*.npy (LGPL-3.0)",
                id3="NONE", id4=f"hit record {case}", id5="NONE",
                func_type=1, load_case_id=case,
                rsp_ent_name="NONE", rsp_node=node, rsp_dir=3,
                ref_ent_name="NONE", ref_node=1, ref_dir=3,
                ord_data_type=2, num_pts=data.shape[1], abscissa_spacing=1,
                abscissa_min=0.0, abscissa_inc=1.0 / SAMPLE_RATE_HZ,
                abscissa_spec_data_type=17, abscissa_len_unit_exp=0,
                abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
                abscissa_axis_units_lab="s",
                ordinate_spec_data_type=dtype, ordinate_len_unit_exp=len_exp,
                ordinate_force_unit_exp=force_exp, ordinate_temp_unit_exp=0,
                ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_len_unit_exp=0,
                orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
                orddenom_axis_units_lab="NONE",
                z_axis_spec_data_type=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0,
                z_axis_temp_unit_exp=0, z_axis_axis_units_lab="NONE",
                data=data[row].astype(np.float32).astype(float), x=data[0],
            ))
    tmp = out.with_name(out.name + ".tmp")
    if tmp.exists():
        tmp.unlink()  # pyuff appends to an existing file
    pyuff.UFF(str(tmp)).write_sets(sets, mode="add", force_double=False)
    tmp.write_bytes(as_single(tmp.read_bytes(), [s["num_pts"] for s in sets]))
    tmp.replace(out)


def as_single(raw: bytes, num_pts: list[int]) -> bytes:
    """pyuff 2.5 writes the binary data of every set in double precision even when
    the header says single (ordinate data type 2, ``n_bytes`` = 4 per value): store
    each set's values as little-endian float32, as its header says."""
    out, pos = [], 0
    for n in num_pts:
        head = raw.index(b"    58b", pos)
        for _ in range(12):  # the 58b line and records 1-11
            head = raw.index(b"\n", head) + 1
        out.append(raw[pos:head])
        values = np.frombuffer(raw[head:head + 8 * n], dtype="<f8")
        out.append(values.astype("<f4").tobytes())
        pos = head + 8 * n
    out.append(raw[pos:])
    return b"".join(out)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit("usage: python examples/make_pyfrf_example.py DATA_FOLDER OUT.uff")
    write(load_hits(Path(sys.argv[1])), Path(sys.argv[2]))
