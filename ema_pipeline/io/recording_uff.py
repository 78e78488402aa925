"""UFF-58 time records (function type 1) as the raw channels of a recording, for
:func:`ema_pipeline.io.recording.read_recording` (the rules: its module docstring).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ema_pipeline.acquisition.channels import (
    ChannelData,
    check_sample_rate,
    nice_rate,
    rate_from_time,
)
from ema_pipeline.data import DOF, DataError
from ema_pipeline.io.uff import check_record_count, ordinate_unit, read_uff, response_dof
from ema_pipeline.io.uff_format import Record58
from ema_pipeline.io.uff_units import FORCE_TYPES, Unit

__all__ = ["UFF_FUNC_TIME", "read_uff_channels"]

#: The UFF function type of a time record (dataset 58).
UFF_FUNC_TIME = 1


def _uff_rate(path: Path, rec: Record58) -> float:
    if rec.uniform:
        if not (np.isfinite(rec.dx) and rec.dx > 0):
            raise DataError(f"{path}: record {rec.record} ({rec.at}): abscissa increment "
                            f"{rec.dx} is not a time step")
        with np.errstate(all="ignore"):
            check_sample_rate(1.0 / rec.dx, str(path), f"record {rec.record} abscissa "
                              "increment", step_s=rec.dx)
        return nice_rate(1.0 / rec.dx)
    return rate_from_time(rec.x, f"{path}: record {rec.record}")


def read_uff_channels(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    """The channels of a UFF file's time records (one per DOF and signal kind, the
    records of each concatenated by load case) and the segments' first samples."""
    contents = read_uff(path)
    if not contents.dataset_numbers:
        raise DataError(f"{path}: no UFF datasets found (not a Universal File, or empty)")
    records = [r for r in contents.records if r.func_type == UFF_FUNC_TIME]
    if not records:
        found = sorted({r.func_type for r in contents.records})
        raise DataError(f"{path}: no time records (dataset 58, function type 1); function "
                        f"types found: {found or 'none (no dataset 58)'}")
    check_record_count(path, records)
    for rec in records:
        if np.iscomplexobj(rec.data):
            raise DataError(f"{path}: record {rec.record} ({rec.at}) holds complex values "
                            f"(ordinate data type {rec.ord_data_type}); time records are real")
    groups: dict[tuple[DOF, str], list[tuple[Record58, Unit | None, int]]] = {}
    for rec in records:
        dof, sign = response_dof(rec)
        try:
            unit: Unit | None = ordinate_unit(path, rec)
            kind = unit.signal or rec.numerator.units  # type: ignore[union-attr]
        except DataError:
            unit, kind = None, rec.numerator.units.strip() or "unknown"  # reported by channel
        groups.setdefault((dof, kind), []).append((rec, unit, sign))
    n_records = {len(v) for v in groups.values()}
    if len(n_records) != 1:
        listed = ", ".join(f"{d.label()} {k}: {len(v)}" for (d, k), v in groups.items())
        raise DataError(f"{path}: channels have different numbers of records ({listed}); "
                        "truncated file?")
    channels = []
    seg_lengths: list[int] | None = None
    for (dof, kind), recs in groups.items():
        if any(r.load_case for r, _, _ in recs):
            recs = sorted(recs, key=lambda item: item[0].load_case)
        rates = {_uff_rate(path, r) for r, _, _ in recs}
        if len(rates) != 1:
            raise DataError(f"{path}: channel {dof.label()} {kind} has records at different "
                            f"sample rates ({', '.join(f'{r:g}' for r in sorted(rates))} Hz)")
        lengths = [r.data.size for r, _, _ in recs]
        if seg_lengths is None:
            seg_lengths = lengths
        elif lengths != seg_lengths:
            raise DataError(f"{path}: records of channel {dof.label()} {kind} have "
                            f"{lengths} samples, others {seg_lengths}: truncated file?")
        data = np.concatenate([np.real(r.data).astype(float) * s for r, _, s in recs])
        first = recs[0][0]
        channels.append(ChannelData(
            name=f"{dof.label()} {kind}",
            data=data,
            sample_rate_hz=rates.pop(),
            unit_label=first.numerator.units,
            unit=recs[0][1],
            dof=dof,
            force_hint=first.numerator.data_type in FORCE_TYPES,
        ))
    starts = tuple(int(s) for s in np.cumsum([0] + (seg_lengths or [0])[:-1]))
    return channels, starts
