"""sdypy-EMA (LSCF + LSFD) as an independent reference backend of :func:`identify`.

Only sdypy-EMA's public API is used: ``EMA.Model(...)``, ``get_poles``,
``select_closest_poles`` and ``get_constants``. sdypy-EMA picks poles near
given frequencies only, so the frequencies come from ``expect_hz`` or, without
it, from this package's automatic pLSCF selection (documented behaviour: the
two backends then agree on *which* modes, and sdypy-EMA estimates them
independently). No uncertainty: standard deviations are NaN.

Known trap handled here: ``select_closest_poles`` narrows a search window that
starts at ``f_window`` Hz wide; for a guess below ``f_window / 2`` the window
reaches 0 Hz, where its table of stable poles is zero-padded, and it silently
returns 0 Hz. The window is therefore at most 1.5 x the lowest guess.
It also returns, for a guess with no stable pole near it, whatever pole is
nearest -- the same pole for several guesses, or an unstable one. Here each
pole is kept once, only with positive (window-corrected) damping, and only when
it answers a guess within the tolerance of
:func:`ema_pipeline.identification.selection.expect.match_expected`; a guess left
unanswered is a warning (from :func:`identify`), never a distant mode. Orders
too low to hold the modes looked for (``max_order`` below
:func:`min_sdypy_order`) are refused.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from dataclasses import replace

import numpy as np

from ema_pipeline.data import DataError, FRFSet
from ema_pipeline.identification.common import (
    finish_identification,
    resolve_band,
    source_prefix,
)
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.plscf_backend import identify_plscf
from ema_pipeline.identification.refinement.lsfd import frac, normalised_error
from ema_pipeline.identification.result import (
    IdentificationResult,
    ResolvedSettings,
    StabilizationData,
)
from ema_pipeline.identification.selection.expect import match_expected
from ema_pipeline.modal import pole_fd_hz


def min_sdypy_order(n_modes: int) -> int:
    """Lowest ``pol_order_high`` accepted for ``n_modes`` modes looked for:
    max(10, 2 n_modes). sdypy-EMA's LSCF of order n gives n poles (n / 2
    conjugate pairs); every mode needs a pair at the top orders, with room for
    the computational poles, and its stability check needs the mode repeated
    over several orders.

    Examples
    --------
    >>> min_sdypy_order(4), min_sdypy_order(14)
    (10, 28)
    """
    return max(10, 2 * int(n_modes))


def identify_sdypy(frf: FRFSet, options: IdentificationOptions, *,
                   workers: int = 1) -> IdentificationResult:
    """Identify with sdypy-EMA (the ``"sdypy-lscf"`` backend).

    ``options.max_order`` is sdypy-EMA's ``pol_order_high`` (default 100, its
    own default; its LSCF then solves polynomial orders 2, 4, ..., 2 * max_order).
    Only ``band_hz``, ``max_order``, ``expect_hz``, the residual switches and
    (for the automatic selection that finds the modes to look for, without
    ``expect_hz``) ``window_searches`` apply; weighting, tolerances and
    refinement are pLSCF's. Poles are
    window-corrected like the pLSCF ones. The synthesised FRFs (and FRAC,
    error) are sdypy-EMA's LSFD reconstruction; residues, shapes, MAC and MPC
    come from this package's LSFD at sdypy-EMA's poles (each mode's local
    LSFD, as for pLSCF: :func:`~ema_pipeline.identification.common.finish_identification`).
    Called by :func:`ema_pipeline.identification.identify`, which checks the
    input first; ``workers`` worker processes serve the automatic selection.
    """
    from sdypy import EMA

    lower_residual, upper_residual = options.lower_residual, options.upper_residual
    lo, hi = resolve_band(frf, options.band_hz)
    decay = float(frf.acquisition.window_decay_rate)
    p = 100 if options.max_order is None else int(options.max_order)
    if not options.expect_hz:
        auto = identify_plscf(frf, IdentificationOptions(
            band_hz=(lo, hi), refine=False, accept=False,
            window_searches=options.window_searches,
            thresholds=options.thresholds), workers=workers)
        guesses = auto.modes.fd_hz
        if guesses.size == 0:
            raise DataError("sdypy-lscf: the automatic selection found no mode to look for")
    else:
        guesses = np.sort(np.asarray(options.expect_hz, dtype=float))
    where = source_prefix(frf)
    if p < min_sdypy_order(guesses.size):
        raise DataError(
            f"{where}sdypy-lscf: max_order {p} is too low for {guesses.size} mode(s) in the band "
            f"[{lo:g}, {hi:g}] Hz; sdypy-EMA's LSCF needs at least "
            f"{min_sdypy_order(guesses.size)} (default 100)"
        )
    n_out, n_in, n_freq = frf.H.shape
    # sdypy-EMA cuts the axis at the line nearest ``upper`` (exclusive): pass the
    # axis up to one line above the band top.
    top = min(int(np.searchsorted(frf.freq_hz, hi, side="right")) + 1, n_freq)
    H2 = frf.H[..., :top].reshape(n_out * n_in, top)
    upper = float(frf.freq_hz[top - 1]) if top < n_freq else float(frf.freq_hz[-1]) + 1e-9
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")  # and its progress bars
        model = EMA.Model(
            frf=H2, freq=frf.freq_hz[:top], lower=lo, upper=upper, pol_order_high=p,
            frf_form=frf.quantity,
        )
        model.get_poles(show_progress=False)
        f_window = float(min(50.0, 1.5 * np.min(guesses)))
        model.select_closest_poles(list(guesses), f_window=f_window)
        # several guesses can get the same pole: keep each (order, index) once
        pole_ind = np.unique(np.asarray(model.pole_ind, dtype=int).reshape(-1, 2), axis=0)
        poles = np.array([model.all_poles[i][j] for i, j in pole_ind], dtype=complex)
        H_sdypy, _ = model.get_constants(
            method="lsfd", whose_poles="own", lower_r=lower_residual, upper_r=upper_residual
        )
    poles = np.where(poles.imag < 0, poles.conj(), poles)
    poles = poles[(poles.real + decay < 0) & (poles.imag > 0)]  # structural damping > 0
    tol = options.thresholds.expect_tol
    match = match_expected(pole_fd_hz(poles), guesses, tol)
    poles = poles[np.unique(match[match >= 0])]
    if poles.size == 0:
        raise DataError(
            f"{where}sdypy-lscf found no stable pole within {100 * tol:g} % of "
            f"{', '.join(f'{g:g}' for g in guesses)} Hz; raise max_order or check the guesses"
        )
    if np.any(np.abs(poles.imag) < 2 * np.pi * lo):
        raise DataError(
            f"sdypy-lscf returned a pole below the band for guesses {guesses} Hz "
            "(its f_window trap); give better expected frequencies"
        )
    order = np.argsort(poles.imag)
    poles = poles[order]
    sub = frf.band(lo, hi)
    empty = np.zeros(0)
    stab = StabilizationData(
        order=empty.astype(int), freq_hz=empty, zeta=empty, flags=empty.astype(np.uint8),
        pole=empty.astype(complex), cluster=empty.astype(int),
    )
    settings = ResolvedSettings(
        method="sdypy-lscf", band_hz=(lo, hi), max_order=p,
        orders=np.arange(2, 2 * p + 1, 2), dt_s=float(model.sampling_time),
        weighting="none", window_decay_rate=decay, tol_freq=0.001, tol_zeta=0.05,
        tol_mac=float("nan"), min_fraction=float("nan"), refine=False,
        lower_residual=lower_residual, upper_residual=upper_residual,
        expect_hz=guesses if options.expect_hz else None, uncertainty="none (NaN)",
        window_searches=options.window_searches, accept=False,
        thresholds=options.thresholds,
    )
    result = finish_identification(
        sub, poles, decay=decay, lower_residual=lower_residual,
        upper_residual=upper_residual, stab=stab, selected=None, settings=settings,
    )
    # sdypy-EMA's own LSFD synthesis on the band lines
    f_sd = np.asarray(model.freq)
    idx = np.clip(np.searchsorted(f_sd, sub.freq_hz - 1e-9), 0, f_sd.size - 1)
    H_fit = np.asarray(H_sdypy)[:, idx].reshape(n_out, n_in, -1)
    return replace(
        result, H_fit=H_fit, frac=frac(sub.H, H_fit), error=normalised_error(sub.H, H_fit),
    )
