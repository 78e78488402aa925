"""What the hit page of ``ema-pipeline frf --report`` shows, gathered from the FRFs
made of a recording (:class:`~ema_pipeline.pipeline.frf.ImpactFRF`): every hit's
record with its windows, force spectrum, end level and the spectra for the choice
by hand. The page itself is :mod:`ema_pipeline.report.hits_page`; a channel
sheet's test gathers one of these per file
(:func:`ema_pipeline.pipeline.roving.sheet_hits_page`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ema_pipeline.acquisition import hits as hitlib
from ema_pipeline.data import Channel, DataError
from ema_pipeline.pipeline.frf import FRFSettings, ImpactFRF

if TYPE_CHECKING:
    from ema_pipeline.report.hits_page import HitsPageInput, HitView

__all__ = ["channel_label", "hits_page_input"]


def channel_label(channel: Channel, by_dof: bool = False) -> str:
    """How the hit page names a channel: its DOF (``by_dof``, when it has one: a
    channel sheet's test) or its name in the file.

    Examples
    --------
    >>> from ema_pipeline.data import DOF
    >>> ch = Channel("1", "acceleration", DOF(100, 3))
    >>> channel_label(ch), channel_label(ch, by_dof=True)
    ('1', '100+Z')
    """
    return channel.dof.label() if by_dof and channel.dof is not None else channel.name


def _hit_view(result: ImpactFRF, hit: hitlib.Hit, by_dof: bool) -> HitView:
    """The record of one hit (as far as the data go) with its windows, force spectrum
    and end levels, for the hit page; the response shown is the first response
    channel, for every hit alike."""
    from ema_pipeline.report.hits_page import HitView  # the page (pandas): --report

    rec = result.recording
    assert rec is not None
    fs, n = rec.sample_rate_hz, result.n_samples
    n_pre = int(round(result.records.trigger_s * fs))
    if hit.record_start >= 0:  # a padded front repeats the first sample of the data
        a, b = hit.record_start - hit.padded, hit.record_start + n - hit.padded
    else:  # past_end: what the data hold of the record, within the hit's segment
        cross = int(np.ceil(hit.time_s * fs))
        seg_starts = np.array(rec.segment_starts + (rec.n_samples,))
        k = int(np.searchsorted(seg_starts, cross, side="right")) - 1
        a = max(cross - n_pre, int(seg_starts[k]))
        b = min(cross - n_pre + n, int(seg_starts[k + 1]))
    m = b - a
    assert result.exp_window is not None and result.force_window is not None
    w_exp = result.exp_window[:m]  # the windows the estimate applied (past_end: cut short)
    w_force = result.force_window[:m]
    idx = np.maximum(np.arange(a, b), a + (hit.padded if hit.record_start >= 0 else 0))
    force = rec.signals[0, idx]
    responses = rec.signals[1:, idx]
    end, _ = hitlib.tail_level(responses[None], min(n_pre, m - 1))
    spectra = None
    if hit.record_start >= 0 and m == n:  # the averaged record: its spectra, to choose by hand
        f_spec = np.fft.rfft(force * w_force * w_exp, n)
        x_spec = np.fft.rfft(responses[0] * w_exp, n)
        spectra = (np.abs(f_spec) ** 2, np.conj(f_spec) * x_spec, np.abs(x_spec) ** 2)
    spec = np.abs(np.fft.rfft(force * w_force * w_exp, n))
    db = 20 * np.log10(np.maximum(spec, np.finfo(float).tiny) / max(spec.max(), 1e-300))
    names = [channel_label(ch, by_dof) for ch in rec.channels[1:]]
    units = [ch.unit for ch in rec.channels[1:]]
    return HitView(
        hit=hit, time_s=np.arange(a, b) / fs, force_n=force, response=responses[0],
        response_name=names[0], force_window=w_force, exp_window=w_exp,
        freq_hz=np.fft.rfftfreq(n, 1.0 / fs), force_db=db, end_level=float(end[0].max()),
        spectra=spectra,
        others=tuple((f"{names[i]} [{units[i]}]" if units[i] else names[i], responses[i])
                     for i in range(1, responses.shape[0])),
        response_unit=units[0],
        end_levels=tuple(zip(names, (float(v) for v in end[0]), strict=True)),
        by_hand=result.chosen_by_hand,
        note=hitlib.hit_note(hit),
    )


def hits_page_input(result: ImpactFRF, *, by_dof: bool = False) -> HitsPageInput:
    """What the hit page of ``frf --report`` shows, gathered from ``result`` (the
    recording must be kept: :func:`~ema_pipeline.pipeline.frf.frf_from_recording`
    does); ``by_dof``: name the channels by their DOFs (a channel sheet's test)."""
    from ema_pipeline import __version__
    from ema_pipeline.pipeline.reports import report_date
    from ema_pipeline.report.hits_page import HitsPageInput  # the page (pandas): --report

    if result.recording is None:
        raise DataError("no recording kept with the FRFs: cannot draw the hit page")
    settings = result.settings or FRFSettings()
    source = result.frf.source.path or result.recording.source.path
    return HitsPageInput(
        title=f"Impact hits: {source}",
        source=source,
        sha256=result.frf.source.sha256,
        frf=result.frf,
        hits=[_hit_view(result, h, by_dof) for h in result.hits],
        n_samples=result.n_samples,
        record_length_s=result.record_length_s,
        pretrigger_s=result.records.trigger_s,
        force_window_s=result.force_window_s,
        exp_window_tau_s=result.exp_window_tau_s,
        estimator=result.frf.acquisition.estimator,
        force_band_hz=result.force_band_hz,
        keep_all=settings.keep_all,
        settings={f"frf.{k}": str(v) for k, v in vars(settings).items()},
        version=__version__,
        generated=report_date(),
    )
