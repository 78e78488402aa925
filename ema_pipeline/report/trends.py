"""Which mode of one file is which mode of another: the batch report's trends
pair modes across files by frequency and MAC, not by their index (a file that
lacks a mode would shift every mode above it by one).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ema_pipeline.modal import mac

__all__ = ["PAIRING", "Pairing", "pair_modes"]


@dataclass(frozen=True)
class Pairing:
    """Limits of :func:`pair_modes`.

    ``max_shift``: a file's mode joins a group only if its frequency is within
    this fraction of the group's (0.25: the paper's immersed beam shifts its
    modes by 1-7 %, and neighbouring bending modes are a factor 2.8 or more
    apart, so a quarter is loose for the one and tight for the other).
    ``min_mac``: with shapes at the same DOFs, the MAC with the group's shape
    must reach this (0.6: the same bending mode at two sensors gives 0.9 or more
    in air and in water; two different ones mostly below 0.5).
    """

    max_shift: float = 0.25
    min_mac: float = 0.6


#: The limits the batch report uses.
PAIRING = Pairing()


def pair_modes(
    fn_hz: Sequence[Sequence[float]],
    shapes: Sequence[np.ndarray | None] | None = None,
    limits: Pairing = PAIRING,
) -> np.ndarray:
    """Group the modes of several files: ``(n_files, n_groups)`` frequencies, NaN
    where a file has no mode of that group; groups in ascending frequency.

    The file with the most modes seeds the groups; every other file's modes are
    assigned to groups one-to-one (Hungarian assignment on the log frequency
    ratio plus ``1 - MAC``) within ``limits``; a mode that fits no group opens
    a new one. ``shapes[i]`` is ``(n_dofs, n_modes_i)`` in the order of
    ``fn_hz[i]`` (None: frequency alone); the MAC is used between files with
    the same number of DOFs.

    Examples
    --------
    >>> pair_modes([[18.1, 112.0, 327.6], [18.2, 330.1]])
    array([[ 18.1, 112. , 327.6],
           [ 18.2,   nan, 330.1]])
    """
    n_files = len(fn_hz)
    freqs = [np.asarray(f, dtype=float) for f in fn_hz]
    shp: list[np.ndarray | None] = list(shapes) if shapes is not None else [None] * n_files
    ref_f: list[float] = []
    ref_s: list[np.ndarray | None] = []
    members: list[dict[int, float]] = []
    max_log = np.log1p(limits.max_shift)
    for i in sorted(range(n_files), key=lambda k: -freqs[k].size):
        f, s = freqs[i], shp[i]
        if f.size == 0:
            continue
        taken: dict[int, int] = {}  # mode of this file -> group
        if ref_f:
            dist = np.abs(np.log(f[:, None] / np.asarray(ref_f)[None, :]))
            allowed = dist <= max_log
            cost = dist.copy()
            for j, rs in enumerate(ref_s):
                if s is not None and rs is not None and rs.shape[0] == s.shape[0]:
                    m = mac(s, rs[:, None])[:, 0]
                    allowed[:, j] &= m >= limits.min_mac
                    cost[:, j] += 1 - m
            cost[~allowed] = 1e6
            from scipy.optimize import linear_sum_assignment  # here: 0.2 s of start-up

            rows, cols = linear_sum_assignment(cost)
            taken = {int(r): int(c) for r, c in zip(rows, cols, strict=True) if allowed[r, c]}
        for k in range(f.size):
            if k in taken:
                members[taken[k]][i] = float(f[k])
            else:
                ref_f.append(float(f[k]))
                ref_s.append(None if s is None else s[:, k])
                members.append({i: float(f[k])})
    order = np.argsort(ref_f, kind="stable")
    table = np.full((n_files, len(ref_f)), np.nan)
    for col, g in enumerate(order):
        for i, v in members[g].items():
            table[i, col] = v
    return table
