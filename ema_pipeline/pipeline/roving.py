"""A whole roving test from the recordings a channel sheet names: what
``ema-pipeline frf --channels SHEET.csv`` runs.

Each file of the sheet (:mod:`ema_pipeline.io.channel_sheet`) is one point of the
test, read once: its hits are found, checked and averaged by the steps of
:func:`ema_pipeline.pipeline.frf.frf_from_recording`, with the record length and
the exponential window common to every file (the shortest record and the
shortest automatic time constant over the files, so that the FRFs share one
frequency axis and one window the identification undoes). Both are settled
before any FRF is estimated, so each point is estimated once. The FRFs of all files
are assembled into one :class:`~ema_pipeline.data.FRFSet` with the DOFs of the
sheet: responses x references.

* **Roving hammer** (one file per hammer point, fixed accelerometer(s): more
  references than responses): the set is stored in its reciprocal form
  (:meth:`~ema_pipeline.data.FRFSet.reciprocal`, ``acquisition.layout =
  "reciprocal"``), so that the responses, and the mode shapes, are over the
  hammer points (Maxwell reciprocity, H_ij = H_ji); the report says so.
* **Roving sensor** (one hammer point): laid out as measured, the shapes over the
  sensor points.

Errors name the sheet and the file: a file whose sample rate or force unit
differs from the first file's; a point with no accepted hit; a response/reference
pair measured twice (a DOF named twice); an incomplete FRF matrix.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ema_pipeline import io
from ema_pipeline.acquisition.channels import check_sample_rate
from ema_pipeline.data import DOF, DataError, FRFSet, Provenance, Recording
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.io.channel_sheet import ChannelSheet, read_channel_sheet
from ema_pipeline.pipeline.frf import (
    CutHits,
    FRFSettings,
    ImpactFRF,
    check_output,
    cut_impact_hits,
    estimate_impact_frf,
    find_impact_hits,
    identify_recording,
    impact_channels,
    write_frf_outputs,
)
from ema_pipeline.pipeline.single import FileOutcome

__all__ = ["SheetFRF", "frf_from_sheet", "identify_sheet", "read_sheet_recordings",
           "sheet_frf", "sheet_hits_page"]


@dataclass
class SheetFRF:
    """What :func:`sheet_frf` made: the assembled ``frf``, each file's
    :class:`~ema_pipeline.pipeline.frf.ImpactFRF` (``points``, in the sheet's order,
    with the file names relative to the sheet's folder in ``files``) and the
    ``layout``: ``"roving hammer"`` (reciprocal form) or ``"roving sensor"``."""

    frf: FRFSet
    points: list[ImpactFRF]
    files: list[str]
    layout: str

    @property
    def n_samples(self) -> int:
        return self.points[0].n_samples

    @property
    def record_length_s(self) -> float:
        return self.points[0].record_length_s

    @property
    def exp_window_tau_s(self) -> float | None:
        return self.points[0].exp_window_tau_s

    @property
    def force_window_s(self) -> float | None:
        return self.points[0].force_window_s

    @property
    def force_band_hz(self) -> tuple[float, float]:
        band = self.frf.acquisition.force_band_hz
        assert band is not None
        return band

    @property
    def n_accepted(self) -> int:
        return sum(p.n_accepted for p in self.points)

    def hits_table(self) -> pd.DataFrame:
        """Every file's hit table, with a first column ``file`` (relative to the
        sheet's folder)."""
        frames = []
        for name, point in zip(self.files, self.points, strict=True):
            table = point.hits_table()
            table.insert(0, "file", name)
            frames.append(table)
        return pd.concat(frames, ignore_index=True)


def _unit_factor(label: str, where: str) -> float:
    try:
        return io.parse_unit_label(label).factor
    except ValueError as exc:
        raise DataError(f"{where}: unknown unit {label!r} ({exc})") from None


def read_sheet_recordings(sheet: ChannelSheet) -> list[Recording]:
    """Read every file of ``sheet`` (only its channels, at their DOFs, scaled and in
    the sheet's units; the force first) and check that the files agree: the same
    sample rate and force unit as the first file, and every response row read as a
    response. Errors name the sheet and the file that differs."""
    recordings: list[Recording] = []
    force_units: list[tuple[str, float]] = []
    for file in sheet.files():
        rows = sheet.rows_of(file)
        force_row = next(r for r in rows if r.role == "force")
        raw = io.read_raw_recording(file)  # each file read once
        rec = io.recording_from_raw(
            raw, force_channel=force_row.channel,
            scale={r.channel: r.scale for r in rows if r.scale != 1.0} or None,
            units={r.channel: r.unit for r in rows if r.unit} or None,
            channels={r.channel: r.dof for r in rows},
        )
        read_dofs = {c.dof for c in rec.channels[1:]}
        for r in rows:
            if r.role == "response" and r.dof not in read_dofs:
                raise DataError(f"{sheet.where(r)}: channel {r.channel!r} of {file.name} has "
                                "a force unit but the role response; check its unit or role")
        label = force_row.unit or raw.unit_labels().get(rec.channels[0].name, "") or "N"
        force_units.append((label, _unit_factor(label, sheet.where(force_row))))
        first = recordings[0] if recordings else rec
        if rec.sample_rate_hz != first.sample_rate_hz:
            raise DataError(f"{sheet.source}: {file} is sampled at {rec.sample_rate_hz:g} Hz, "
                            f"{first.source.path} at {first.sample_rate_hz:g} Hz; one test "
                            "needs one sample rate")
        if force_units[-1][1] != force_units[0][1]:
            raise DataError(f"{sheet.source}: the force of {file} is in {label}, that of "
                            f"{first.source.path} in {force_units[0][0]}; one test needs "
                            "one force unit (check the unit column)")
        recordings.append(rec)
    return recordings


@contextmanager
def _at_point(sheet: ChannelSheet, rec: Recording) -> Iterator[None]:
    """A DataError of one point's work, named by the sheet, the point and its file."""
    try:
        yield
    except DataError as exc:
        force = rec.channels[0]
        point = force.dof.label() if force.dof is not None else "?"
        raise DataError(f"{sheet.source}: point {point} (hammer at {point}, "
                        f"{Path(rec.source.path).name}): {exc}") from None


def _sheet_points(sheet: ChannelSheet, recordings: list[Recording], settings: FRFSettings,
                  configuration: str, picks: list[Sequence[int] | None]) -> list[ImpactFRF]:
    """Every file's FRFs, in one direction: the hits of every file, then the record
    length (the shortest over the files), the records and their windows, then the
    exponential window (the shortest automatic time constant over the files), and
    only then the FRFs, once per file."""
    points = []
    for rec in recordings:
        with _at_point(sheet, rec):
            check_sample_rate(rec.sample_rate_hz, rec.source.path)
            channels, quantity = impact_channels(rec, rec.channels[0].name)
            points.append((rec, channels, quantity, find_impact_hits(channels, settings)))
    n = min(found.n_samples for *_, found in points)
    cut_settings = settings
    if any(found.n_samples != n for *_, found in points):  # one axis: the shortest record
        cut_settings = replace(settings, record_length_s=n / recordings[0].sample_rate_hz)
        for k, (rec, channels, quantity, found) in enumerate(points):
            if found.n_samples != n:
                with _at_point(sheet, rec):
                    points[k] = (rec, channels, quantity,
                                 find_impact_hits(channels, cut_settings))
    cuts: list[CutHits] = []
    for (rec, channels, quantity, found), pick in zip(points, picks, strict=True):
        with _at_point(sheet, rec):
            cuts.append(cut_impact_hits(channels, found, cut_settings, quantity,
                                        skipped=rec.skipped, configuration=configuration,
                                        chosen=pick))
    taus = [c.tau_s for c in cuts if c.tau_s is not None]
    out = []
    for rec, cut in zip(recordings, cuts, strict=True):
        # one window: the shortest automatic time constant (a given one is common)
        tau = (min(taus) if taus else None) if settings.exp_window_tau == "auto" else cut.tau_s
        with _at_point(sheet, rec):
            out.append(estimate_impact_frf(cut, settings, tau))
    return out


def _assemble(sheet: ChannelSheet, points: list[ImpactFRF]) -> FRFSet:
    responses: list[DOF] = []
    references: list[DOF] = []
    where: dict[tuple[DOF, DOF], str] = {}
    for p in points:
        rec = p.recording
        assert rec is not None
        ref = rec.channels[0].dof
        assert ref is not None
        references += [ref] if ref not in references else []
        for ch in rec.channels[1:]:
            assert ch.dof is not None
            responses += [ch.dof] if ch.dof not in responses else []
            pair = (ch.dof, ref)
            if pair in where:
                raise DataError(f"{sheet.source}: response {ch.dof.label()} to a hit at "
                                f"{ref.label()} is named twice ({where[pair]} and "
                                f"{rec.source.path}); each DOF pair once")
            where[pair] = rec.source.path
    quantities = {p.frf.quantity for p in points}
    if len(quantities) > 1:
        raise DataError(f"{sheet.source}: the files' responses mix quantities "
                        f"{sorted(quantities)}; one FRF set needs one")
    first = points[0].frf
    n_f = first.freq_hz.size
    H = np.full((len(responses), len(references), n_f), np.nan, dtype=complex)
    coh = np.full(H.shape, np.nan)
    for p in points:
        rec = p.recording
        assert rec is not None
        i = references.index(rec.channels[0].dof)  # type: ignore[arg-type]
        for k, ch in enumerate(rec.channels[1:]):
            o = responses.index(ch.dof)  # type: ignore[arg-type]
            H[o, i] = p.frf.H[k, 0]
            if p.frf.coherence is not None:
                coh[o, i] = p.frf.coherence[k, 0]
    missing = np.argwhere(np.isnan(H[..., 0].real))
    if missing.size:
        o, i = missing[0]
        raise DataError(f"{sheet.source}: no FRF from a hit at {references[i].label()} to "
                        f"response {responses[o].label()}: a roving test needs the same "
                        "responses in every file (roving hammer) or the same hammer point "
                        "(roving sensor)")
    bands = [p.force_band_hz for p in points]
    info = replace(first.acquisition,
                   n_averages=min(p.n_accepted for p in points),
                   n_averages_max=(max(p.n_accepted for p in points)
                                   if len({p.n_accepted for p in points}) > 1 else None),
                   force_band_hz=(min(b[0] for b in bands), min(b[1] for b in bands)))
    sha = ""
    if Path(sheet.source).is_file():
        sha = io.sha256_file(sheet.source)
    if any(p.frf.coherence is None for p in points):
        coh = None  # type: ignore[assignment]
    return FRFSet(freq_hz=first.freq_hz, H=H, coherence=coh, response_dofs=tuple(responses),
                  reference_dofs=tuple(references), quantity=first.quantity,
                  acquisition=info, configuration=first.configuration,
                  source=Provenance(path=sheet.source, sha256=sha))


def sheet_frf(sheet: ChannelSheet | str | os.PathLike[str], settings: FRFSettings | None = None,
              *, configuration: str = "",
              chosen: Mapping[str, Sequence[int]] | None = None) -> SheetFRF:
    """FRFs of the whole test a channel sheet describes (module docstring); nothing
    is written. ``sheet``: a :class:`ChannelSheet` or the path of its CSV.
    ``chosen``: {file (relative to the sheet's folder, as the hit table's ``file``
    column): the hit numbers to average}, a choice by hand (files not named: the
    checks decide)."""
    if not isinstance(sheet, ChannelSheet):
        sheet = read_channel_sheet(sheet)
    settings = FRFSettings() if settings is None else settings
    recordings = read_sheet_recordings(sheet)
    folder = Path(sheet.source).parent
    files = [Path(os.path.relpath(rec.source.path, folder)).as_posix() for rec in recordings]
    choice = dict(chosen or {})
    unknown = sorted(set(choice) - set(files))
    if unknown:
        raise DataError(f"{sheet.source}: the hit choice (--hits) names file(s) "
                        f"{', '.join(unknown)}, which the sheet does not")
    picks = [choice.get(f) for f in files]
    points = _sheet_points(sheet, recordings, settings, configuration, picks)
    frf = _assemble(sheet, points)
    layout = "roving sensor"
    if frf.n_in > frf.n_out:
        frf, layout = frf.reciprocal(), "roving hammer"
    return SheetFRF(frf=frf, points=points, files=files, layout=layout)


def sheet_hits_page(result: SheetFRF) -> str:
    """The hit page of a channel sheet's test: every file's hits (numbered through
    the test, each with its file and its number in the file, its channels named by
    the sheet's DOFs), the hits chosen per point (file), the assembled FRFs, and the
    sheet and every recording with its sha256 in the provenance
    (:func:`ema_pipeline.report.hits_page.render_hits_html`)."""
    from ema_pipeline.pipeline.hit_page import hits_page_input
    from ema_pipeline.report.hits_page import HitView, render_hits_html

    views: list[HitView] = []
    recordings = []
    for name, point in zip(result.files, result.points, strict=True):
        rec = point.recording
        assert rec is not None
        force = rec.channels[0].dof
        where = f"hammer at {force.label()}" if force is not None else ""
        recordings.append(("recording", name, rec.source.sha256))
        for view in hits_page_input(point, by_dof=True).hits:
            views.append(replace(view, hit=replace(view.hit, index=len(views) + 1),
                                 file=name, number=view.hit.index, point=where))
    page = hits_page_input(result.points[0], by_dof=True)
    page = replace(page, title=f"Impact hits: {result.frf.source.path} ({result.layout}, "
                   f"{len(result.points)} files)", source=result.frf.source.path,
                   sha256=result.frf.source.sha256, frf=result.frf, hits=views,
                   force_band_hz=result.force_band_hz, source_role="channel sheet",
                   inputs=tuple(recordings))
    return render_hits_html(page)


def frf_from_sheet(
    sheet: str | os.PathLike[str],
    out: str | os.PathLike[str],
    settings: FRFSettings | None = None,
    *,
    configuration: str = "",
    report: bool = False,
    chosen: Mapping[str, Sequence[int]] | None = None,
) -> SheetFRF:
    """:func:`sheet_frf` on the channel sheet ``sheet``, then write the FRFs to
    ``out`` (``.h5`` or ``.uff``) and the hit table (with its ``file`` column) to
    ``<stem>_hits.csv`` beside it, together (none replaced on an error); ``report``:
    also the hit page ``<stem>_hits.html`` (:func:`sheet_hits_page`). An output that
    is the sheet or one of its recordings is refused before any work."""
    parsed = read_channel_sheet(sheet)
    fmt = check_output(out, [Path(sheet), *parsed.files()], report=report)
    result = sheet_frf(parsed, settings, configuration=configuration, chosen=chosen)
    page = sheet_hits_page(result) if report else None
    write_frf_outputs(result.frf, result.hits_table(), page, out, fmt)
    return result


def identify_sheet(
    path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    options: IdentificationOptions | None = None,
    *,
    force: bool = True,
    uff: bool = False,
) -> FileOutcome:
    """What ``batch`` does with a channel sheet: :func:`sheet_frf` with the default
    settings, then ``identify``; the outputs and the skip rule (on the sheet's sha256)
    of :func:`ema_pipeline.pipeline.frf.identify_recording`."""
    return identify_recording(path, out_dir, options, force=force, uff=uff,
                              make_frf=lambda p: sheet_frf(p, configuration=p.stem))
