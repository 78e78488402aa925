"""The public entry point :func:`identify` and its table of methods.

A new identification method is a function ``(frf, options) ->
IdentificationResult`` in its own module (see
:mod:`~ema_pipeline.identification.plscf_backend`), registered in
:data:`METHODS`; it may use :mod:`~ema_pipeline.identification.common` but never
imports this module.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ema_pipeline.data import DataError, FRFSet
from ema_pipeline.identification.common import (
    check_band_data,
    default_max_order,
    resolve_band,
    single_reference,
    source_prefix,
)
from ema_pipeline.identification.diagram.narrower_searches import searches_turned_off
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.picked import Picks
from ema_pipeline.identification.plscf_backend import identify_plscf
from ema_pipeline.identification.result import IdentificationResult
from ema_pipeline.identification.sdypy_backend import identify_sdypy
from ema_pipeline.identification.selection.expect import match_expected, not_found_message
from ema_pipeline.identification.selection.picks import identify_picks
from ema_pipeline.threads import owned_blas_threads

Backend = Callable[..., IdentificationResult]  # (frf, options, *, workers)

#: Identification methods by name: one backend per name of
#: :data:`~ema_pipeline.identification.options.METHOD_NAMES` (the ``Method``
#: literal of ``IdentificationOptions.method``, which checks the name).
METHODS: dict[str, Backend] = {
    "plscf": identify_plscf,
    "sdypy-lscf": identify_sdypy,
}


def identify(
    frf: FRFSet, options: IdentificationOptions | None = None, *, picks: Picks | None = None,
    workers: int = 1, **overrides: Any,
) -> IdentificationResult:
    """Identify modal parameters from an FRF set (pLSCF + automatic selection + LSFD).

    Parameters
    ----------
    frf : FRFSet, (n_out, n_in, n_freq) FRFs. A roving-hammer set (one
        response, several references) is identified in its reciprocal form
        (:func:`~ema_pipeline.identification.common.single_reference`), as
        ``ema-pipeline identify`` does: ``result.modes.shapes`` then has one
        row per hammer point.
    options : IdentificationOptions (default: all defaults); see its
        attributes for band, order, method, expected frequencies, window,
        weighting, tolerances, refinement, final tests and residual terms.
    picks : :class:`~ema_pipeline.identification.picked.Picks` (a picks file,
        :func:`ema_pipeline.io.read_picks`): fit exactly these poles, with the
        file's band, orders and weighting, and run no automatic selection
        (:func:`~ema_pipeline.identification.selection.picks.identify_picks`).
    workers : worker processes for the independent pieces of work (a large
        diagram's eigenvalues, a dense band's windows, the modes' local fits;
        :func:`ema_pipeline.runner.process_map`). The default 1 starts no
        process, as scipy's ``workers``; ``ema-pipeline`` passes the cores.
        The numbers are the same for every count.
    **overrides : fields of :class:`IdentificationOptions` replacing those of
        ``options``, e.g. ``identify(frf, band_hz=(5, 790), max_order=40)``.

    Returns
    -------
    IdentificationResult

    Notes
    -----
    z-domain sampling time: dt = 1 / (2 f_hi), f_hi the band top.
    Exponential window: the identified pole is lambda' = lambda - 1/tau with
    1/tau = ``frf.acquisition.window_decay_rate`` (or ``options.exp_window_tau_s``);
    reported values use lambda = lambda' + 1/tau: sigma = sigma' - 1/tau,
    omega_d unchanged, f_n = |lambda| / 2 pi, zeta = sigma / |lambda|.
    Uncertainty (``refine=True``): standard deviations of f_n and zeta by
    first-order propagation of the least-squares covariance of the refined
    poles (sandwich covariance of the noise-weighted local pole-residue fit:
    the noise level from the fit residual, its line-to-line correlation from
    the recorded windows or the residual; no empirical factor, see
    :mod:`ema_pipeline.identification.refinement.uncertainty`); with ``refine=False`` the
    scatter of the trajectory's poles over the model orders (an underestimate).

    Examples
    --------
    Two modes (30 Hz, 1 %; 70 Hz, 2 %), accelerance at two responses, noise-free:

    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import FRFSet, ModalParameters
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> result = identify(FRFSet(freq_hz=f, H=H))
    >>> result.fn_hz.round(4), result.zeta.round(5)
    (array([30., 70.]), array([0.01, 0.02]))
    """
    options = IdentificationOptions() if options is None else options
    if overrides:
        options = replace(options, **overrides)
    frf = single_reference(frf)
    where = source_prefix(frf)
    if picks is not None:
        if options.method != "plscf" or options.expect_hz:
            raise DataError(f"{where}picks are poles of the 'plscf' diagram; they go with "
                            "neither another method nor expected frequencies")
        options = picks.options(options)
    backend = METHODS[options.method]  # a name the options checked (METHOD_NAMES)
    frf = options.apply_window(frf)
    frf.check_finite()
    lo, hi = resolve_band(frf, options.band_hz)
    sub = frf.band(lo, hi)
    p = (
        default_max_order(frf.n_in, sub.freq_hz.size)
        if options.max_order is None
        else int(options.max_order)
    )
    check_band_data(sub, p, where)
    if options.weighting == "coherence" and frf.coherence is None:
        raise DataError(f"{where}coherence weighting asked for but the FRF set has no coherence")
    expect_hz = np.sort(np.asarray(options.expect_hz, dtype=float))
    if expect_hz.size and (np.any(expect_hz <= lo) or np.any(expect_hz >= hi)):
        raise DataError(
            f"expected frequencies {expect_hz} must lie inside the band [{lo:g}, {hi:g}] Hz"
        )
    checked = replace(options, band_hz=(lo, hi), expect_hz=tuple(expect_hz))
    with owned_blas_threads():  # small linear algebra: one BLAS thread (ema_pipeline.threads)
        result = (identify_picks(frf, checked, picks) if picks is not None
                  else backend(frf, checked, workers=workers))
    if picks is not None:
        return result
    if options.method == "plscf":  # a fixed order or --expect turned searches off: say so
        note = searches_turned_off(checked, (lo, hi), result.fn_hz)
        if note:
            warnings.warn(f"{where}{note}", stacklevel=2)
    if expect_hz.size:  # a guess no mode answers: say so (UserWarning)
        message = not_found_message(expect_hz, match_expected(result.fn_hz, expect_hz))
        if message:
            warnings.warn(f"{where}{message}", stacklevel=2)
    return result
