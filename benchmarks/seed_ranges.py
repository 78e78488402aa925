"""The ``--seeds`` argument of the benchmark scripts: ranges and single seeds,
comma-separated (imports nothing, so a script can parse its arguments before
it chooses which checkout's package to import)."""

from __future__ import annotations


def seed_list(text: str) -> list[int]:
    """The seeds of ``text``: comma-separated ranges ``lo-hi`` (both ends
    included) and single seeds.

    Examples
    --------
    >>> seed_list("100-101,200-201"), seed_list("1,5,9"), seed_list("100-103")
    ([100, 101, 200, 201], [1, 5, 9], [100, 101, 102, 103])
    """
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out
