"""Raw impact recordings to checked, averaged FRFs: what ``ema-pipeline frf`` runs.

:func:`frf_from_recording` does the numerics on one :class:`~ema_pipeline.data.Recording`
(find and check the hits, cut the accepted records, choose the exponential
window, estimate the FRFs, find the usable band of the force spectrum);
:func:`frf_from_files` reads the input files (several files are segments of one
recording: pre-cut records or recordings of the same test), runs it and writes
the FRF file (``.h5`` or ``.uff`` by suffix) and ``<stem>_hits.csv`` beside it.
Both return an :class:`ImpactFRF` (FRFs, hit table, record length, tau, band, the
windows applied), so that a report or a batch run can use them. The work runs in
one direction, each step once: the channels, the hits, the accepted records and
their window, the FRFs; a channel sheet's test
(:mod:`ema_pipeline.pipeline.roving`) settles the record length and the window
over its files between these steps. Where the outputs go:
:mod:`ema_pipeline.pipeline.frf_outputs` (its names are re-exported here).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ema_pipeline import acquisition, io
from ema_pipeline.acquisition import hits as hitlib
from ema_pipeline.acquisition.channels import check_sample_rate, force_channel_index
from ema_pipeline.acquisition.frf_settings import FRF_SETTING_RULES
from ema_pipeline.data import (
    ConfigError,
    DataError,
    EMAError,
    FRFSet,
    Provenance,
    Quantity,
    Recording,
    Table,
    TimeRecords,
)
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.pipeline.frf_outputs import (
    check_output,
    frf_output_paths,
    hits_csv_path,
    hits_report_path,
    write_frf_outputs,
)
from ema_pipeline.pipeline.single import FileOutcome, identify_file, output_paths

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "AUTO_FORCE_WINDOW_S",
    "DEFAULT_PRETRIGGER_S",
    "CutHits",
    "FRFSettings",
    "ImpactFRF",
    "check_output",
    "cut_impact_hits",
    "estimate_impact_frf",
    "find_impact_hits",
    "impact_channels",
    "concatenate_recordings",
    "frf_from_files",
    "frf_from_recording",
    "hits_csv_path",
    "configuration_frf",
    "hits_report_path",
    "frf_output_paths",
    "identify_recording",
    "impact_frf",
    "write_frf_outputs",
]

#: Default pretrigger (s) kept before each hit's trigger crossing.
DEFAULT_PRETRIGGER_S = 0.01
#: Default force window: the pretrigger plus this much (s) after the trigger.
AUTO_FORCE_WINDOW_S = 0.05

_QUANTITY_OF_RESPONSE: dict[str, Quantity] = {"acceleration": "accelerance", "velocity": "mobility",
                         "displacement": "receptance"}


@dataclass(frozen=True)
class FRFSettings:
    """Settings of ``ema-pipeline frf``.

    ``pretrigger_s``: time kept before each trigger crossing. ``record_length_s``:
    ``None`` = the longest power of two of samples that fits between hits.
    ``force_window_s``: length of the rectangular force window from the record
    start (then a 10 ms cosine taper); ``None`` = the pretrigger plus
    :data:`AUTO_FORCE_WINDOW_S`, 0 = none. ``exp_window_tau``: ``"auto"``
    (:func:`ema_pipeline.acquisition.hits.auto_exp_window_tau`), ``None`` (no
    exponential window: records that have not decayed are rejected) or a time
    constant in s. ``estimator``: H1, H2 or Hv. ``keep_all``: average every hit
    that has a record, whatever the checks say. Every field is checked when the
    settings are made (the rules of
    :data:`~ema_pipeline.acquisition.frf_settings.FRF_SETTING_RULES`): an
    impossible value is an :class:`~ema_pipeline.data.OptionError` naming the
    field and its option (``pretrigger_s (--pretrigger-s) must be ...``).
    """

    pretrigger_s: float = DEFAULT_PRETRIGGER_S
    record_length_s: float | None = None
    force_window_s: float | None = None
    exp_window_tau: str | float | None = "auto"
    estimator: str = "H1"
    keep_all: bool = False

    def __post_init__(self) -> None:
        # each field checked and normalised by its rule, named with its option
        for f in fields(self):
            label = f"{f.name} (--{f.name.replace('_', '-')})"
            value = FRF_SETTING_RULES[f.name](label, getattr(self, f.name))
            object.__setattr__(self, f.name, value)


@dataclass
class ImpactFRF:
    """What :func:`frf_from_recording` made: the averaged ``frf``, the hit table
    ``hits``, the record length (``n_samples``, ``record_length_s``), the
    exponential window's ``exp_window_tau_s`` (None: none), the force window
    (s, None: none), the usable band ``force_band_hz`` = (f_10dB, f_20dB) and
    the accepted ``records``, and for a report the ``recording`` (force first,
    the responses used), the ``settings`` and the force channel's ``warnings``."""

    frf: FRFSet
    hits: tuple[hitlib.Hit, ...]
    n_samples: int
    record_length_s: float
    exp_window_tau_s: float | None
    force_window_s: float | None
    force_band_hz: tuple[float, float]
    records: TimeRecords
    recording: Recording | None = None
    settings: FRFSettings | None = None
    #: Warnings: the file's channels skipped (``Recording.skipped``), then those about the
    #: force channel (:func:`ema_pipeline.acquisition.hits.force_warnings`).
    warnings: list[str] = field(default_factory=list)
    #: The hits averaged were chosen by hand (``chosen``, ``--hits``), not by the checks.
    chosen_by_hand: bool = False
    #: The windows the estimate applied, one value per record sample (ones: none): the
    #: exponential window (force and responses) and the force window alone
    #: (:class:`~ema_pipeline.acquisition.estimation.FRFEstimate`).
    exp_window: np.ndarray | None = None
    force_window: np.ndarray | None = None

    @property
    def n_accepted(self) -> int:
        return sum(h.accepted for h in self.hits)

    def hits_table(self) -> pd.DataFrame:
        """One row per hit (:meth:`hit_columns`) as a ``pandas.DataFrame``."""
        import pandas as pd  # here: the frf command writes its table without it

        return pd.DataFrame(hitlib.hits_columns(self.hits))

    def hit_columns(self) -> Table:
        """One row per hit: ``hit,time_s,force_peak_n,accepted,reasons,note``
        (:func:`ema_pipeline.acquisition.hits.hits_columns`)."""
        columns = hitlib.hits_columns(self.hits)
        return Table({name: np.asarray(col) for name, col in columns.items()})


def impact_channels(recording: Recording, force_channel: str | None = None
                    ) -> tuple[Recording, Quantity]:
    """``recording`` with the force first and the responses after it, and the FRFs'
    quantity (acceleration: accelerance, velocity: mobility, displacement:
    receptance). The force channel is chosen by the one rule
    (:func:`~ema_pipeline.acquisition.channels.force_channel_index`); other force
    channels are left out; the responses must be of one quantity. Errors name the
    source.

    Examples
    --------
    >>> from ema_pipeline.data import Channel
    >>> rec = Recording(np.zeros((2, 8)), 100.0, (Channel("acc", "velocity"),
    ...                                           Channel("hammer", "force")))
    >>> out, quantity = impact_channels(rec)
    >>> [c.name for c in out.channels], quantity
    (['hammer', 'acc'], 'mobility')
    """
    where = recording.source.path or "recording"
    names = [ch.name for ch in recording.channels]
    k_force = force_channel_index(names, [ch.quantity for ch in recording.channels],
                                  force_channel, where)
    keep = [k_force] + [k for k, ch in enumerate(recording.channels)
                        if k != k_force and ch.quantity != "force"]
    if len(keep) < 2:
        raise DataError(f"{where}: no response channel beside the force")
    quantities = {recording.channels[k].quantity for k in keep[1:]}
    if len(quantities) > 1:
        raise DataError(f"{where}: responses mix quantities {sorted(quantities)}; an FRF set "
                        "needs one")
    rec = replace(recording, signals=recording.signals[keep],
                  channels=tuple(recording.channels[k] for k in keep))
    return rec, _QUANTITY_OF_RESPONSE[quantities.pop()]


def find_impact_hits(recording: Recording, settings: FRFSettings) -> hitlib.HitSearch:
    """The hits of ``recording`` (force first: :func:`impact_channels`) and their
    records' place, with the pretrigger and record length of ``settings``
    (:func:`ema_pipeline.acquisition.hits.find_hits`)."""
    return hitlib.find_hits(recording, 0, pretrigger_s=settings.pretrigger_s,
                            record_length_s=settings.record_length_s)


@dataclass
class CutHits:
    """A recording's hits checked and the accepted ones cut, before the FRFs are
    estimated (:func:`cut_impact_hits`): the ``recording`` (force first), what
    :func:`find_impact_hits` ``found``, the checked ``hits``, the accepted
    ``records``, the exponential window's time constant these records call for
    (``tau_s``: the automatic one for ``"auto"``, the one given, or None), the FRFs'
    ``quantity`` and the ``warnings`` (channels skipped, force channel)."""

    recording: Recording
    found: hitlib.HitSearch
    hits: tuple[hitlib.Hit, ...]
    accepted: list[int]
    records: TimeRecords
    tau_s: float | None
    quantity: Quantity
    warnings: list[str]
    chosen_by_hand: bool = False


def cut_impact_hits(
    recording: Recording,
    found: hitlib.HitSearch,
    settings: FRFSettings,
    quantity: Quantity,
    *,
    skipped: Sequence[str] = (),
    configuration: str = "",
    chosen: Sequence[int] | None = None,
) -> CutHits:
    """Check the hits ``found`` on ``recording`` (force first), keep the accepted
    ones (``chosen``: exactly these hit numbers, 1-based, by hand), cut their records
    and find the exponential window they call for (``settings.exp_window_tau``
    ``"auto"``: :func:`ema_pipeline.acquisition.hits.auto_exp_window_tau`).
    ``skipped``: the channels the reader skipped, first of the warnings. Every hit
    rejected, or an automatic window that would overflow before the trigger: a
    DataError naming the source."""
    where = recording.source.path or "recording"
    hits = hitlib.check_hits(recording, 0, found,
                             exp_window=settings.exp_window_tau is not None,
                             keep_all=settings.keep_all)
    if chosen is not None:
        hits = choose_hits(hits, chosen, where)
    accepted = [h.index - 1 for h in hits if h.accepted]
    warnings = [*skipped, *hitlib.force_warnings(hits, recording.channels[0].name)]
    if not accepted:
        summary = "; ".join(f"hit {h.index} at {h.time_s:.3f} s: {h.reasons_text()}"
                            for h in hits)
        hint = "".join(f"; {w}" for w in warnings if "double hits" in w)
        raise DataError(f"{where}: every hit rejected ({summary}){hint}")
    records = hitlib.cut_records(recording, 0, found, accepted)
    records = replace(records, configuration=configuration)
    fs, n = recording.sample_rate_hz, found.n_samples
    tau: float | None
    if settings.exp_window_tau == "auto":
        tau = hitlib.auto_exp_window_tau(records, found.trigger_offsets(accepted),
                                         int(round(settings.pretrigger_s * fs)))
        shortest = acquisition.shortest_exp_window_tau(n, fs, records.trigger_s)
        if tau is not None and not tau >= shortest:
            raise DataError(f"{where}: the automatic exponential window (tau {tau:.4g} s) "
                            f"would overflow before the trigger: the pretrigger "
                            f"({records.trigger_s:g} s) takes most of the {n / fs:g} s records; "
                            "give a shorter --pretrigger-s or --exp-window-tau")
    else:
        tau = None if settings.exp_window_tau is None else float(settings.exp_window_tau)
    return CutHits(recording=recording, found=found, hits=hits, accepted=accepted,
                   records=records, tau_s=tau, quantity=quantity, warnings=warnings,
                   chosen_by_hand=chosen is not None)


def estimate_impact_frf(cut: CutHits, settings: FRFSettings,
                        tau_s: float | None) -> ImpactFRF:
    """The FRFs of the records ``cut``, estimated once with the exponential window
    ``tau_s`` (s, None: none) and the force window of ``settings`` (checked not to
    cut a force pulse), with the usable band of the force spectrum
    (:func:`ema_pipeline.acquisition.hits.force_band`) and the windows applied."""
    rec, found, records = cut.recording, cut.found, cut.records
    where = rec.source.path or "recording"
    force_window_s = settings.force_window_s
    if force_window_s is None:
        force_window_s = records.trigger_s + AUTO_FORCE_WINDOW_S  # the pretrigger used
    force_window_s = force_window_s or None
    if force_window_s is not None:
        pulse_end = hitlib.pulse_end_s(rec, 0, found, cut.accepted)
        if force_window_s < pulse_end:
            what = ("--force-window-s" if settings.force_window_s is not None else
                    f"the default force window (the pretrigger + {AUTO_FORCE_WINDOW_S:g} s)")
            raise DataError(f"{where}: {what} {force_window_s:g} s ends before the force pulse "
                            f"does ({pulse_end:.4g} s into the record, pretrigger "
                            f"{records.trigger_s:g} s): it would cut the pulse; give at least "
                            f"{pulse_end:.4g} s, or 0 for no force window")
    estimate = acquisition.estimate_frf_windows(records, force_window_s=force_window_s,
                                                exp_window_tau_s=tau_s,
                                                estimator=settings.estimator)
    frf = estimate.frf
    band = hitlib.force_band(frf.freq_hz, estimate.force_autospectrum)
    frf = replace(frf, quantity=cut.quantity,
                  acquisition=replace(frf.acquisition, force_band_hz=band))
    n, fs = found.n_samples, rec.sample_rate_hz
    return ImpactFRF(
        frf=frf,
        hits=cut.hits,
        n_samples=n,
        record_length_s=n / fs,
        exp_window_tau_s=tau_s,
        force_window_s=force_window_s,
        force_band_hz=band,
        records=records,
        recording=rec,
        settings=settings,
        warnings=cut.warnings,
        chosen_by_hand=cut.chosen_by_hand,
        exp_window=estimate.exp_window,
        force_window=estimate.force_window,
    )


def frf_from_recording(
    recording: Recording,
    settings: FRFSettings | None = None,
    *,
    force_channel: str | None = None,
    configuration: str = "",
    chosen: Sequence[int] | None = None,
) -> ImpactFRF:
    """Find and check the hits of ``recording``, and average the accepted ones
    (``chosen``: exactly these hit numbers, 1-based, as chosen by hand on the hit
    page: :mod:`ema_pipeline.io.hit_choice`), in one direction: the channels
    (:func:`impact_channels`), the hits (:func:`find_impact_hits`), the records
    (:func:`cut_impact_hits`), the FRFs estimated once (:func:`estimate_impact_frf`).

    The force channel is chosen by the one rule of
    :func:`~ema_pipeline.acquisition.channels.force_channel_index` (``force_channel``
    first); the responses are the channels of another quantity (all of one).
    Rules of the checks: :mod:`ema_pipeline.acquisition.hits`. No force channel, no
    hit, or every hit rejected: a DataError naming the source.

    Examples
    --------
    >>> from ema_pipeline.data import Channel
    >>> fs, n = 512.0, 5 * 1024
    >>> t = np.arange(n) / fs
    >>> force, resp = np.zeros(n), np.zeros(n)
    >>> for t0 in (0.5, 2.6, 4.7, 6.8):  # four clean hits, a 40 Hz mode
    ...     k = int(t0 * fs)
    ...     force[k:k + 3] = [50.0, 100.0, 50.0]
    ...     resp[k:] += np.exp(-8 * (t[k:] - t0)) * np.sin(2 * np.pi * 40 * (t[k:] - t0))
    >>> rec = Recording(np.vstack([force, resp]), fs,
    ...                 (Channel("hammer", "force"), Channel("acc", "acceleration")))
    >>> out = frf_from_recording(rec)
    >>> out.n_accepted, out.n_samples, out.frf.H.shape
    (4, 1024, (1, 1, 513))
    """
    settings = FRFSettings() if settings is None else settings
    check_sample_rate(recording.sample_rate_hz, recording.source.path)
    rec, quantity = impact_channels(recording, force_channel)
    found = find_impact_hits(rec, settings)
    cut = cut_impact_hits(rec, found, settings, quantity, skipped=recording.skipped,
                          configuration=configuration, chosen=chosen)
    return estimate_impact_frf(cut, settings, cut.tau_s)


def choose_hits(hits: tuple[hitlib.Hit, ...], chosen: Sequence[int],
                where: str) -> tuple[hitlib.Hit, ...]:
    """``hits`` with exactly the hit numbers ``chosen`` accepted (a choice by hand,
    whatever the checks said; their reasons stay); a number that is no hit, or a hit
    without a record (``past_end``), is a DataError naming ``where``.

    Examples
    --------
    >>> hits = (hitlib.Hit(1, 0.5, 90.0, True, (), 10), hitlib.Hit(2, 2.5, 95.0, False,
    ...         ("double_hit",), 2000))
    >>> [h.accepted for h in choose_hits(hits, [2], "rec.csv")]
    [False, True]
    """
    wanted = set(chosen)
    numbers = {h.index: h for h in hits}
    missing = sorted(wanted - set(numbers))
    if missing:
        raise DataError(f"{where}: the hit choice (--hits) names hit(s) "
                        f"{', '.join(map(str, missing))}; the recording has {len(hits)}")
    no_record = sorted(k for k in wanted if numbers[k].record_start < 0)
    if no_record:
        raise DataError(f"{where}: the hit choice (--hits) names hit(s) "
                        f"{', '.join(map(str, no_record))} without a record (past_end)")
    if not wanted:
        raise DataError(f"{where}: the hit choice (--hits) accepts no hit")
    return tuple(replace(h, accepted=h.index in wanted) for h in hits)


def concatenate_recordings(recordings: list[Recording]) -> Recording:
    """Recordings of one test (the same channels and sample rate) as the segments
    of one recording; the segments of each are kept.

    Examples
    --------
    >>> from ema_pipeline.data import Channel
    >>> one = Recording(np.ones((1, 10)), 100.0, (Channel("f", "force"),))
    >>> concatenate_recordings([one, one]).segment_starts
    (0, 10)
    """
    first = recordings[0]
    starts: list[int] = []
    offset = 0
    for rec in recordings:
        name = rec.source.path or "recording"
        if rec.sample_rate_hz != first.sample_rate_hz:
            raise DataError(f"{name}: sample rate {rec.sample_rate_hz:g} Hz differs from "
                            f"{first.sample_rate_hz:g} Hz of {first.source.path}")
        if [(c.name, c.quantity) for c in rec.channels] != [
            (c.name, c.quantity) for c in first.channels
        ]:
            raise DataError(f"{name}: channels differ from those of {first.source.path}")
        starts += [offset + s for s in rec.segment_starts]
        offset += rec.n_samples
    if len(recordings) == 1:
        return first
    return Recording(
        signals=np.concatenate([r.signals for r in recordings], axis=1),
        sample_rate_hz=first.sample_rate_hz,
        channels=first.channels,
        segment_starts=tuple(starts),
        source=Provenance(path=", ".join(r.source.path for r in recordings)),
        skipped=tuple(m for r in recordings for m in r.skipped),
    )


def impact_frf(
    paths: list[str | os.PathLike[str]] | list[Path],
    settings: FRFSettings | None = None,
    *,
    force_channel: str | None = None,
    scale: dict[str, float] | None = None,
    units: dict[str, str] | None = None,
    configuration: str = "",
    chosen: Sequence[int] | None = None,
) -> ImpactFRF:
    """Read the recordings ``paths`` (segments of one test) and run
    :func:`frf_from_recording` (``chosen``: the hits chosen by hand); nothing is
    written. The FRFs' source is the
    file list (with its sha256 for one file)."""
    from ema_pipeline.io.recording import read_recording

    if not paths:
        raise ConfigError("no input recording")
    recordings = [read_recording(Path(p), force_channel=force_channel, scale=scale,
                                 units=units) for p in paths]
    recording = concatenate_recordings(recordings)
    force = None if force_channel is None else recording.channels[0].name  # force first
    result = frf_from_recording(recording, settings, force_channel=force,
                                configuration=configuration, chosen=chosen)
    names = [str(p) for p in paths]
    result.frf = replace(result.frf, source=Provenance(
        path=", ".join(names),
        sha256=recordings[0].source.sha256 if len(names) == 1 else "",
    ))
    return result


#: Keys of an experiment file's ``frf`` table that go to the reader, not to FRFSettings.
READER_KEYS = ("force_channel", "scale", "units")


def configuration_frf(
    paths: list[Path], items: tuple[tuple[str, object], ...] | dict[str, object],
    configuration: str = "",
) -> ImpactFRF:
    """:func:`impact_frf` with the ``frf`` settings of an experiment-file configuration
    (:data:`ema_pipeline.io.experiment.FRF_SETTINGS`, already checked).

    Examples
    --------
    >>> configuration_frf([], {"estimator": "H9"})
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: estimator (--estimator) must be one of 'H1', 'H2', 'Hv', got 'H9'
    """
    values = dict(items)
    reader: dict = {k: values.pop(k) for k in READER_KEYS if k in values}
    for key in ("scale", "units"):
        if key in reader:
            reader[key] = dict(reader[key])
    settings = FRFSettings(**values)  # type: ignore[arg-type]
    return impact_frf(paths, settings, configuration=configuration, **reader)


def frf_from_files(
    paths: list[str | os.PathLike[str]] | list[Path],
    out: str | os.PathLike[str],
    settings: FRFSettings | None = None,
    *,
    force_channel: str | None = None,
    scale: dict[str, float] | None = None,
    units: dict[str, str] | None = None,
    configuration: str = "",
    report: bool = False,
    chosen: Sequence[int] | None = None,
) -> ImpactFRF:
    """Read the recordings ``paths`` (segments of one test), run
    :func:`frf_from_recording`, and write the FRFs to ``out`` (``.h5`` or ``.uff``)
    and the hit table to ``<stem>_hits.csv`` beside it. ``report``: also the hit
    page ``<stem>_hits.html``
    (:func:`ema_pipeline.report.hits_page.render_hits_html`). ``force_channel``,
    ``scale`` and ``units`` go to the reader
    (:func:`ema_pipeline.io.recording.read_recording`).

    An output that is an input, or a folder, is refused before any work
    (:func:`check_output`). The outputs are written to temporaries and replace
    their targets together (:func:`ema_pipeline.io.replace_together`): on any
    error none is replaced and no temporary is left."""
    fmt = check_output(out, paths, report=report)
    result = impact_frf(paths, settings, force_channel=force_channel, scale=scale,
                        units=units, configuration=configuration, chosen=chosen)
    page = None
    if report:  # the page (and pandas) imported only when drawn
        from ema_pipeline.pipeline.hit_page import hits_page_input
        from ema_pipeline.report.hits_page import render_hits_html

        page = render_hits_html(hits_page_input(result))
    write_frf_outputs(result.frf, result.hit_columns(), page, out, fmt)
    return result


def identify_recording(
    path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    options: IdentificationOptions | None = None,
    *,
    force: bool = True,
    uff: bool = False,
    make_frf: Callable[[Path], Any] | None = None,
) -> FileOutcome:
    """What ``batch`` does with a raw recording: ``frf`` with the default settings,
    then ``identify`` on its FRFs. ``make_frf(path)``: what makes the FRFs and the hit
    table instead of :func:`impact_frf` (a channel sheet's test:
    :func:`ema_pipeline.pipeline.roving.identify_sheet`). Writes ``<stem>.h5`` (the FRFs),
    ``<stem>_hits.csv``, ``<stem>_modes.csv`` and ``<stem>_result.h5`` in
    ``out_dir``; the result records the recording's sha256, so that with
    ``force=False`` a recording already done is skipped. Problems are returned as
    ``status="failed"`` with the reason, never raised (as
    :func:`ema_pipeline.pipeline.single.identify_file`)."""
    path, out_dir = Path(path), Path(out_dir)
    frf_path = out_dir / f"{path.stem}.h5"
    start = time.perf_counter()
    try:
        sha = io.sha256_file(path)
        _, result_h5 = output_paths(frf_path, out_dir)
        if not force and io.completed_result_sha256(result_h5) == sha:  # done: skipped
            return identify_file(frf_path, out_dir, options, force=False, sha256=sha)
        out_dir.mkdir(parents=True, exist_ok=True)
        check_output(frf_path, [path])
        result = (impact_frf([path], configuration=path.stem) if make_frf is None
                  else make_frf(path))
        with io.replace_together():
            io.write_csv(result.hits_table(), hits_csv_path(frf_path))
            io.write_frf(result.frf, frf_path, "h5")
    except EMAError as exc:
        return FileOutcome(path=path, status="failed", reason=str(exc),
                           seconds=time.perf_counter() - start)
    except OSError as exc:
        where = getattr(exc, "filename", None) or path
        return FileOutcome(path=path, status="failed", runtime=True,
                           reason=f"{where}: {exc.strerror or exc}",
                           seconds=time.perf_counter() - start)
    outcome = identify_file(frf_path, out_dir, options, force=True, sha256=sha, uff=uff)
    if isinstance(result, ImpactFRF) and result.recording is not None:  # channels skipped
        outcome.warnings[:0] = result.recording.skipped
    outcome.seconds = time.perf_counter() - start
    return outcome
