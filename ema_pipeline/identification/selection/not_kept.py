"""Resonances that the FRFs show but the identification did not keep as modes.

The final tests (:mod:`~ema_pipeline.identification.selection.acceptance`) judge a
candidate by what it adds to the fit of all FRFs together. A resonance that
stands out in some FRFs only, beside a much stronger mode, can fail them: on
the measured beam (``../shared/data``) 42.0, 274.7 and 325.1 Hz are clear
peaks in 9, 16 and 15 of the 30 FRFs (at 274.7 Hz a factor of up to 250
over the valleys beside it, at the nodal lines of the 265.6 Hz bending mode)
but explain less of the local response than that mode's skirt, and none of
them is in the published list of the test. They are not made modes, and they
are not dropped silently either: :func:`resonances_not_kept` lists every
rejected candidate at which enough FRFs have a clear peak of their own
(``min_log_prominence``, ``min_frf_share`` of
:class:`~ema_pipeline.identification.thresholds.SelectionThresholds`), the result
carries them
(``IdentificationResult.not_kept_hz``, ``not_kept_frfs``) and
``ema-pipeline identify`` prints them as a warning (``batch``: the
``warnings`` column of ``summary.csv``). On the beam, ``--band 240 300``
keeps 274.6 Hz as a mode beside 265.5 Hz.

A peak is a local maximum of |H| of one FRF (:func:`prominent_peaks`, the
peaks and the prominence of :func:`scipy.signal.find_peaks`: the height over
the higher of the two valleys that separate it from higher ground). Peaks
within a kept mode's half-power band (plus ``peak_lines`` lines) are that
mode's and never count for a candidate.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import pole_fd_hz, pole_fn_hz, pole_half_width_hz


def half_width_hz(freq_hz: np.ndarray, pole: np.ndarray,
                  *, thresholds: SelectionThresholds) -> np.ndarray:
    """The band (Hz, each side) that belongs to each pole (rad/s): its
    half-power half-width |Re lambda| / 2 pi plus ``thresholds.peak_lines`` lines.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.arange(0.0, 101.0)
    >>> half_width_hz(f, np.array([-2 * np.pi + 2j * np.pi * 50.0]), thresholds=th)
    array([2.5])
    """
    peak_lines = thresholds.peak_lines
    df = float(np.median(np.diff(freq_hz))) if freq_hz.size > 1 else 0.0
    return np.asarray(pole_half_width_hz(np.asarray(pole)) + peak_lines * df)


def prominent_peaks(x: np.ndarray, min_prominence: float) -> np.ndarray:
    """Indices of the peaks of ``x`` (1-D, finite) whose prominence is at least
    ``min_prominence``: what ``scipy.signal.find_peaks(x,
    prominence=min_prominence)[0]`` returns, the same indices.

    A peak is a sample (the middle one of a flat top, rounded down) higher
    than its neighbours on both sides, not at the ends; its prominence is its
    height over the higher of the lowest points on each side before higher
    ground (or the end). Written here, in numpy, because importing
    ``scipy.signal`` costs 0.7-1.2 s (it pulls in ``scipy.stats``), more than
    the identification of a paper file.

    Examples
    --------
    >>> prominent_peaks(np.array([0.0, 2.0, 1.0, 1.0, 3.0, 3.0, 0.5, 1.0, 0.0]), 0.8).tolist()
    [1, 4]
    """
    x = np.asarray(x, dtype=float)
    if x.size < 3:
        return np.zeros(0, dtype=np.intp)
    # runs of equal samples: a run higher than the runs on both sides is a peak
    start = np.flatnonzero(np.concatenate([[True], x[1:] != x[:-1]]))
    end = np.concatenate([start[1:], [x.size]]) - 1
    v = x[start]
    k = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] > v[2:])) + 1
    peaks = (start[k] + end[k]) // 2
    h = x[peaks]
    # the lowest point on each side before higher ground: first within
    # ``w`` samples for all peaks at once (noise peaks find higher ground
    # close by), the few others one by one
    w = 64
    pad = np.concatenate([np.full(w, np.inf), x, np.full(w, np.inf)])
    idx = peaks[:, None] + w + np.arange(-w, w + 1)[None, :]  # window pk-w .. pk+w
    win = pad[idx]
    higher = win > h[:, None]
    lo = w - np.argmax(higher[:, w::-1], axis=1)  # position of higher ground (left)
    hi = w + np.argmax(higher[:, w:], axis=1)  # (right)
    pos = np.arange(2 * w + 1)[None, :]
    inside = (pos > lo[:, None]) & (pos < hi[:, None])
    left_min = np.where(inside & (pos <= w), win, np.inf).min(axis=1)
    right_min = np.where(inside & (pos >= w), win, np.inf).min(axis=1)
    # higher ground not within w samples (the padding's inf counts as found)
    far = ~higher[:, : w + 1].any(axis=1) | ~higher[:, w:].any(axis=1)
    for i in np.flatnonzero(far):
        pk = peaks[i]
        left = np.flatnonzero(x[:pk] > h[i])
        right = np.flatnonzero(x[pk + 1 :] > h[i])
        lo_i = left[-1] + 1 if left.size else 0
        hi_i = pk + 1 + right[0] if right.size else x.size
        left_min[i], right_min[i] = x[lo_i : pk + 1].min(), x[pk:hi_i].min()
    return peaks[h - np.maximum(left_min, right_min) >= min_prominence]


def visible_peaks(
    freq_hz: np.ndarray,
    H: np.ndarray,
    center_hz: np.ndarray,
    within_hz: float,
    exclude_hz: np.ndarray | None = None,
    exclude_within_hz: np.ndarray | None = None,
    *,
    thresholds: SelectionThresholds,
) -> np.ndarray:
    """In how many FRFs a peak of |H| stands out (log-prominence above
    ``thresholds.min_log_prominence``) within ``within_hz`` of each ``center_hz``,
    not counting peaks within ``exclude_within_hz`` of an ``exclude_hz`` (the
    kept modes). ``H`` (n_ch, n_freq) on the lines ``freq_hz``.

    Examples
    --------
    >>> th = SelectionThresholds()
    >>> f = np.linspace(0.0, 100.0, 201)
    >>> jw = 2j * np.pi * f
    >>> lam = -1.0 + 2j * np.pi * 40.0
    >>> H = np.array([1 / (jw - lam) + 1 / (jw - np.conj(lam)), np.ones(f.size)])
    >>> visible_peaks(f, H, np.array([40.0, 70.0]), 1.0, thresholds=th).tolist()
    [1, 0]
    """
    min_log_prominence = thresholds.min_log_prominence
    center = np.asarray(center_hz, dtype=float)
    count = np.zeros(center.size, dtype=int)
    ex = np.zeros(0) if exclude_hz is None else np.asarray(exclude_hz, dtype=float)
    ex_w = np.zeros(0) if exclude_within_hz is None else np.asarray(exclude_within_hz, float)
    if center.size == 0:
        return count
    with np.errstate(divide="ignore"):
        log_mag = np.log(np.abs(np.asarray(H)))
    for row in log_mag:
        finite = np.isfinite(row)
        peaks = prominent_peaks(np.where(finite, row, row[finite].min(initial=0.0)),
                                min_log_prominence)
        f_pk = freq_hz[peaks]
        if ex.size:
            f_pk = f_pk[np.all(np.abs(f_pk[:, None] - ex[None, :]) > ex_w[None, :], axis=1)]
        count += np.any(np.abs(f_pk[:, None] - center[None, :]) <= within_hz, axis=0)
    return count


def resonances_not_kept(
    freq_hz: np.ndarray,
    H: np.ndarray,
    rejected: np.ndarray,
    kept: np.ndarray,
    *,
    thresholds: SelectionThresholds,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``rejected`` candidate poles (rad/s) at which the FRFs ``H``
    (n_ch, n_freq) show a resonance of their own: a peak that stands out in
    at least ``min_frf_share`` of the FRFs (and ``min_frfs``) within
    ``peak_lines`` lines of the candidate's natural frequency (fields of
    ``thresholds``), away from
    the ``kept`` poles' half-power bands. Pass only candidates whose decay
    rate is determined
    (:func:`~ema_pipeline.identification.refinement.refine.decay_determined`).
    Returns their natural frequencies (Hz, ascending, one per peak) and the
    number of FRFs in which each stands out.

    Examples
    --------
    A weak mode at 60 Hz seen by two FRFs that do not see the strong one at
    50 Hz, rejected by the fit:

    >>> th = SelectionThresholds()
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> jw = 2j * np.pi * f
    >>> def mode(fn):
    ...     lam = -0.5 + 2j * np.pi * fn
    ...     return 1 / (jw - lam) + 1 / (jw - np.conj(lam))
    >>> H = np.array([mode(50.0), mode(50.0), 0.01 * mode(60.0), 0.01 * mode(60.0)])
    >>> kept = np.array([-0.5 + 2j * np.pi * 50.0])
    >>> rejected = np.array([-0.5 + 2j * np.pi * 60.0, -3.0 + 2j * np.pi * 80.0])
    >>> resonances_not_kept(f, H, rejected, kept, thresholds=th)
    (array([60.]), array([2]))
    """
    th = thresholds
    rejected = np.asarray(rejected, dtype=complex)
    rejected = rejected[rejected.imag > 0]
    kept = np.asarray(kept, dtype=complex)
    if rejected.size == 0:
        return np.zeros(0), np.zeros(0, dtype=int)
    fn = pole_fn_hz(rejected)
    df = float(np.median(np.diff(freq_hz)))
    n_frfs = visible_peaks(freq_hz, H, fn, th.peak_lines * df, pole_fd_hz(kept),
                           half_width_hz(freq_hz, kept, thresholds=th), thresholds=th)
    listed = n_frfs >= max(th.min_frfs, int(np.ceil(th.min_frf_share * np.shape(H)[0])))
    fn, n_frfs = fn[listed], n_frfs[listed]
    width = half_width_hz(freq_hz, rejected[listed], thresholds=th)
    # one entry per resonance: of candidates within each other's bands, the
    # one seen in most FRFs
    out_f: list[float] = []
    out_n: list[int] = []
    for k in np.argsort(-n_frfs, kind="stable"):
        if all(abs(fn[k] - g) > width[k] for g in out_f):
            out_f.append(float(fn[k]))
            out_n.append(int(n_frfs[k]))
    order = np.argsort(out_f)
    return np.asarray(out_f)[order], np.asarray(out_n, dtype=int)[order]


def not_kept_message(not_kept_hz: np.ndarray, not_kept_frfs: np.ndarray, n_frfs: int) -> str:
    """The warning for :func:`resonances_not_kept`'s list ("" when empty).

    Examples
    --------
    >>> print(not_kept_message(np.array([274.69]), np.array([16]), 30))
    resonances in the FRFs with no mode kept: 274.7 Hz (a peak in 16 of 30 FRFs); ...
    """
    if len(not_kept_hz) == 0:
        return ""
    listed = ", ".join(f"{f:.1f} Hz (a peak in {n} of {n_frfs} FRFs)"
                       for f, n in zip(not_kept_hz, not_kept_frfs, strict=True))
    return (f"resonances in the FRFs with no mode kept: {listed}; they fail the final tests "
            "of the fit over all FRFs (too weak beside their neighbours)")
