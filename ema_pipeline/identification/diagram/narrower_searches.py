"""What the narrower searches of the order search add after the final tests:
the alternates of failed candidates, and each kept mode's band support.

:func:`~ema_pipeline.identification.diagram.order_search.add_zoom_modes` and
:func:`~ema_pipeline.identification.diagram.order_search.add_window_modes` record each
narrower search (its band, its candidates, and those a full-band candidate
covered: :data:`~ema_pipeline.identification.diagram.order_search.SearchedBand`).
After the final tests of :mod:`ema_pipeline.identification.selection.acceptance`:

* where a full-band candidate failed, the narrower search's candidate it
  covered is tried (:func:`uncovered_alternates`), only where the FRFs show
  a peak (:func:`shown_by_the_frfs`);
* :func:`band_support` counts the narrower searches that hold and find each
  kept mode, which the doubtful rule ``found_only_in_some_bands`` reads
  (:func:`~ema_pipeline.identification.result.doubtful_flags`).

Thresholds (``alternate_min_frfs``, ``alternate_peak_lines``, ``band_support_margin``) are fields
of :class:`~ema_pipeline.identification.thresholds.SelectionThresholds`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ema_pipeline.identification.diagram.order_search import SearchedBand, mode_windows
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.selection.not_kept import visible_peaks
from ema_pipeline.identification.selection.trajectories import SelectedPoles
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fd_hz, pole_fn_hz, poles_overlap

__all__ = ["band_support", "searches_turned_off", "shown_by_the_frfs", "uncovered_alternates"]


def uncovered_alternates(kept: np.ndarray, alternates: list[SelectedPoles | None]) -> np.ndarray:
    """The poles of ``alternates`` (candidates of narrower searches that a
    candidate of the full band covered,
    :func:`~ema_pipeline.identification.diagram.order_search.covered_candidates`) that
    no ``kept`` pole covers (within the sum of their half-power half-widths):
    their cover failed the final tests, so they have not been judged. One per
    resonance: an alternate covered by one of more orders is left out.

    Examples
    --------
    >>> alt = SelectedPoles(np.array([-1 + 100j, -1 + 100.5j, -1 + 200j]), np.zeros(3, int),
    ...                     np.array([20, 30, 20]), np.zeros(3), np.zeros(3), np.zeros(3, int))
    >>> uncovered_alternates(np.array([-1 + 200.2j]), [alt, None]).tolist()
    [(-1+100.5j)]
    """
    found = [a for a in alternates if a is not None and a.pole.size]
    if not found:
        return np.zeros(0, dtype=complex)
    pole = np.concatenate([a.pole for a in found])
    members = np.concatenate([a.n_members for a in found])
    chosen: list[complex] = []
    for k in np.argsort(-members, kind="stable"):
        others = np.concatenate([kept, np.array(chosen, dtype=complex)])
        if np.any(poles_overlap(pole[k : k + 1], others)):
            continue
        chosen.append(complex(pole[k]))
    return np.sort_complex(np.array(chosen, dtype=complex)) if chosen else np.zeros(0, complex)


def shown_by_the_frfs(freq_hz: np.ndarray, H: np.ndarray, pole: np.ndarray,
                      *, thresholds: SelectionThresholds) -> np.ndarray:
    """Per pole: at least ``alternate_min_frfs`` of the FRFs ``H`` (n_ch, n_freq)
    show a peak of their own within ``alternate_peak_lines`` lines of its natural frequency
    (:func:`~ema_pipeline.identification.selection.not_kept.visible_peaks`). An
    alternate (:func:`uncovered_alternates`) is a second chance for a
    resonance whose cover failed, so it is tried only where the data show one:
    on the measured beam the alternate at 602.9 Hz (band 250-700 Hz) stands
    out in 18 of 30 FRFs, one at 989.8 Hz, which no FRF shows, in none.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> jw = 2j * np.pi * f
    >>> lam = -0.5 + 2j * np.pi * 40.0
    >>> H = np.tile(1 / (jw - lam) + 1 / (jw - np.conj(lam)), (2, 1))
    >>> shown_by_the_frfs(f, H, np.array([lam, -0.5 + 2j * np.pi * 70.0]), thresholds=th).tolist()
    [True, False]
    """
    th = thresholds
    pole = np.asarray(pole, dtype=complex)
    if pole.size == 0:
        return np.zeros(0, dtype=bool)
    df = float(np.median(np.diff(freq_hz)))
    n_frfs = visible_peaks(freq_hz, H, pole_fn_hz(pole), th.alternate_peak_lines * df,
                           thresholds=th)
    return np.asarray(n_frfs >= th.alternate_min_frfs)


def band_support(pole: np.ndarray, searched: Sequence[SearchedBand],
                 *, thresholds: SelectionThresholds) -> np.ndarray:
    """Per pole (n, 2) int: how many of the narrower searches ``searched``
    (their bands in Hz and candidates: the first two entries of each
    :data:`~ema_pipeline.identification.diagram.order_search.SearchedBand`) hold it
    (its damped frequency inside their band by ``band_support_margin`` of
    itself) and how many of those have a candidate that covers it (within the
    sum of their half-power half-widths); the doubtful rule
    ``found_only_in_some_bands`` reads it
    (:func:`~ema_pipeline.identification.result.doubtful_flags`).

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> cand = SelectedPoles(np.array([-1 + 2j * np.pi * 100.2]), np.zeros(1, int),
    ...                      np.ones(1, int), np.zeros(1), np.zeros(1), np.zeros(1, int))
    >>> lam = np.array([-2 + 2j * np.pi * 100.0, -2 + 2j * np.pi * 150.0])
    >>> searched = [((50.0, 200.0), cand, None), ((90.0, 160.0), None, None)]
    >>> band_support(lam, searched, thresholds=th).tolist()
    [[2, 1], [2, 0]]
    """
    margin = thresholds.band_support_margin
    fd = pole_fd_hz(np.asarray(pole))
    out = np.zeros((fd.size, 2), dtype=int)
    for entry in searched:
        (lo, hi), cand = entry[0], entry[1]
        holds = (fd > lo * (1 + margin)) & (fd < hi / (1 + margin))
        out[:, 0] += holds
        if cand is not None and cand.pole.size:
            out[:, 1] += holds & np.any(poles_overlap(pole, cand.pole), axis=1)
    return out


def searches_turned_off(options: IdentificationOptions, band_hz: tuple[float, float],
                        fn_hz: np.ndarray) -> str:
    """The note that ``options`` turned off narrower searches, else ``""``.
    They run with the adaptive order only: a fixed ``max_order`` turns them
    off, and so do ``expect_hz`` without refinement (with it, the expected
    modes come from the automatic selection, which ran them). The searches:
    that of the band's lowest part where the top is ``zoom_ratio`` times the
    bottom or more, and the windows of a dense band when
    ``options.window_searches`` is on. A fixed order always gets the note
    when they are on, since the modes it finds need not be those that make a
    band dense (:func:`~ema_pipeline.identification.diagram.order_search.mode_windows`),
    saying whether the modes ``fn_hz`` (Hz) do; ``expect_hz`` gets it only
    where a search would have run on ``fn_hz``.

    Examples
    --------
    >>> note = searches_turned_off(IdentificationOptions(max_order=40), (5.0, 790.0),
    ...                            np.array([17.0]))
    >>> note.split(" (")[0], note.split("only ")[1].split(":")[0]
    ('max_order', "(the band's lowest 1/8 and the windows of a dense band)")
    >>> note.split(": ")[1]
    'the modes found make no dense band, but those of the adaptive order may'
    >>> searches_turned_off(IdentificationOptions(), (5.0, 790.0), np.array([17.0]))
    ''
    """
    if options.max_order is not None:
        why = "max_order (--max-order)"
    elif options.expect_hz and not options.refine:
        why = "expect_hz (--expect) without refinement"
    else:
        return ""
    th = options.thresholds
    lo, hi = (float(b) for b in band_hz)
    what = []
    if hi >= th.zoom_ratio * lo:
        what.append(f"the band's lowest 1/{th.zoom_ratio:g}")
    dense = bool(mode_windows(np.asarray(fn_hz, float), (lo, hi), thresholds=th))
    fixed = options.max_order is not None
    if options.window_searches and (dense or fixed):
        what.append("the windows of a dense band")
    if not what:
        return ""
    why_missing = ("the modes found make no dense band, but those of the adaptive order may"
                   if fixed and options.window_searches and not dense
                   else "modes only they find may be missing")
    return (f"{why} turned off the narrower searches that run with the adaptive order only "
            f"({' and '.join(what)}): {why_missing}")
