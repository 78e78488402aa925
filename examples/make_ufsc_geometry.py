"""Write ``examples/ufsc-beam-geometry.uff``: the geometry of the measured beam of
``../shared/data/ufsc-beam-hammer.uff`` (see ``../shared/data/README.md``).

The steel beam (0.8 m x 50 mm x 5 mm, simply supported at both ends) was measured
at 34 points on its two long edges, 0.05 m apart: points 1-17 on the edge y = 0
and points 18-34 on the edge y = -0.05 m, both numbered from x = 0 to x = 0.8 m
(points 1, 17, 18 and 34 at the supports), all at z = 0. The hammer roved over
2-16 and 19-33 in -Z, the accelerometer stayed at point 3 (-Z).

Trace lines (dataset 82): one along each edge and one across the beam at every
station (1-18, 2-19, ..., 17-34). Nodes as dataset 15, coordinates in metres
(dataset 164: SI).

Run from the repository root::

    python examples/make_ufsc_geometry.py [OUT]   # default examples/ufsc-beam-geometry.uff
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ema_pipeline.data import Geometry
from ema_pipeline.io.geometry import write_geometry_uff

#: Points per edge, their pitch (m) and the two edges' y (m).
N_PER_EDGE, PITCH_M, EDGES_Y_M = 17, 0.05, (0.0, -0.05)


def ufsc_beam_geometry() -> Geometry:
    """The 34 points, the two edge lines and the 17 cross lines."""
    x = PITCH_M * np.arange(N_PER_EDGE)
    xyz = np.vstack([np.column_stack([x, np.full_like(x, y), np.zeros_like(x)])
                     for y in EDGES_Y_M])
    ids = np.arange(1, 2 * N_PER_EDGE + 1)
    edges = [tuple(range(1, N_PER_EDGE + 1)), tuple(range(N_PER_EDGE + 1, 2 * N_PER_EDGE + 1))]
    across = [(k, k + N_PER_EDGE) for k in range(1, N_PER_EDGE + 1)]
    return Geometry(node_ids=ids, xyz_m=xyz, lines=tuple(edges + across),
                    source="UFSC beam, ../shared/data/README.md")


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(__file__).with_name("ufsc-beam-geometry.uff")
    write_geometry_uff(ufsc_beam_geometry(), out)
    print(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
