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
from dataclasses import dataclass, replace
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
from ema_pipeline.identification.diagram.resources import check_identification
from ema_pipeline.identification.options import IdentificationOptions
from ema_pipeline.identification.picked import Picks
from ema_pipeline.identification.plscf_backend import identify_plscf
from ema_pipeline.identification.result import IdentificationResult
from ema_pipeline.identification.sdypy_backend import identify_sdypy
from ema_pipeline.identification.selection.edge_poles import edge_message
from ema_pipeline.identification.selection.expect import match_expected, not_found_message
from ema_pipeline.identification.selection.not_kept import not_kept_message
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


@dataclass(frozen=True)
class CheckedInput:
    """What :func:`identify` identifies, every check passed (:func:`check_input`).

    Attributes
    ----------
    frf : the FRF set as identified: one reference for a roving-hammer test
        (:func:`~ema_pipeline.identification.common.single_reference`), the
        window override of ``options.exp_window_tau_s`` applied. A caller that
        keeps the FRFs beside the result (``ema-pipeline identify``) keeps
        these: the result's shapes and fitted FRFs are of this set.
    options : the options, with the picks file's band, orders and weighting
        when picks are given, the band resolved
        (:func:`~ema_pipeline.identification.common.resolve_band`) and
        ``expect_hz`` sorted.
    picks : the poles to fit (None: the automatic selection).
    """

    frf: FRFSet
    options: IdentificationOptions
    picks: Picks | None = None


def check_input(
    frf: FRFSet, options: IdentificationOptions | None = None, *, picks: Picks | None = None,
    source: str | None = None, **overrides: Any,
) -> CheckedInput:
    """The FRF set and options :func:`identify` works on, each check run once.

    The arguments are those of :func:`identify`. The checks, in order: picks
    go with the ``"plscf"`` method and no expected frequencies; the FRFs are
    finite; the band lies on the frequency axis and its data can be
    identified (:func:`~ema_pipeline.identification.common.check_band_data`);
    coherence weighting has coherence; ``expect_hz`` lies inside the band;
    and the order cap, the band's lines and the memory estimate against
    ``options.memory_limit_gb``
    (:func:`~ema_pipeline.identification.diagram.resources.check_identification`),
    all before anything is computed. Errors name ``source``, by default the
    FRF file (``frf.source.path``) when the set has one.

    Raises
    ------
    DataError, ConfigError
        The data cannot be identified with these options.

    Examples
    --------
    A roving-hammer set (one response, two hammer points) is identified in
    its reciprocal form; a memory limit below the estimate refuses it:

    >>> from ema_pipeline.data import DOF
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> frf = FRFSet(freq_hz=f, H=np.ones((1, 2, 401), complex), response_dofs=(DOF(1),),
    ...              reference_dofs=(DOF(1), DOF(2)))
    >>> checked = check_input(frf, band_hz=(10.0, 90.0))
    >>> checked.frf.H.shape, checked.options.band_hz
    ((2, 1, 401), (10.0, 90.0))
    >>> check_input(frf, memory_limit_gb=1e-6)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ema_pipeline.data.ConfigError: the adaptive order search up to order 100 ... more than ...
    """
    options = IdentificationOptions() if options is None else options
    if overrides:
        options = replace(options, **overrides)
    frf = single_reference(frf)
    where = f"{source}: " if source else source_prefix(frf)
    if picks is not None:
        if options.method != "plscf" or options.expect_hz:
            raise DataError(f"{where}picks are poles of the 'plscf' diagram; they go with "
                            "neither another method nor expected frequencies")
        options = picks.options(options)
    frf = options.apply_window(frf)
    frf.check_finite()
    try:
        lo, hi = resolve_band(frf, options.band_hz)
    except DataError as exc:
        raise DataError(f"{where}{exc}") from None
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
    check_identification(frf, options, source=source or frf.source.path)  # order cap, memory
    checked = replace(options, band_hz=(lo, hi), expect_hz=tuple(expect_hz))
    return CheckedInput(frf=frf, options=checked, picks=picks)


def result_warnings(checked: CheckedInput, result: IdentificationResult) -> tuple[str, ...]:
    """The warnings of ``result``, one line each, prefixed with the FRF file:
    resonances the FRFs show that no mode was kept for
    (:func:`~ema_pipeline.identification.selection.not_kept.not_kept_message`),
    a band that ends past the hammer's usable band (FRFs from ``ema-pipeline
    frf``), narrower searches a fixed order or ``expect_hz`` turned off
    (:func:`~ema_pipeline.identification.diagram.narrower_searches.searches_turned_off`,
    the ``"plscf"`` method without picks), and expected modes that no mode
    answers (:func:`~ema_pipeline.identification.selection.expect.not_found_message`).

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import ModalParameters
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> frf = FRFSet(freq_hz=f, H=modal_frf(f, truth, np.eye(2), np.array([[1.0, -0.8]])))
    >>> checked = check_input(frf, expect_hz=(30.0, 50.0))
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     result = identify(checked)
    >>> result_warnings(checked, result) == result.warnings
    True
    >>> for line in result.warnings:
    ...     print(line)
    expected mode(s) not found within 15 % of 50 Hz (reported with empty values)
    """
    frf, options = checked.frf, checked.options
    where = source_prefix(frf)
    band_hz = result.settings.band_hz
    out = []
    message = not_kept_message(result.not_kept_hz, result.not_kept_frfs, frf.n_out * frf.n_in)
    if message:
        out.append(message)
    out.append(edge_message(result.edge_hz, band_hz, thresholds=result.settings.thresholds))
    force_band = frf.acquisition.force_band_hz  # FRFs from `ema-pipeline frf`
    if force_band is not None and band_hz[1] > force_band[1] * (1 + 1e-9):
        out.append(f"the identification band ends at {band_hz[1]:.5g} Hz, past the usable "
                   f"band of the hammer: the force spectrum is 20 dB below its "
                   f"low-frequency level from {force_band[1]:.5g} Hz")
    if checked.picks is None and options.method == "plscf":
        out.append(searches_turned_off(options, band_hz, result.fn_hz))
    if options.expect_hz:  # the selection's tolerance
        tol = result.settings.thresholds.expect_tol
        out.append(not_found_message(options.expect_hz,
                                     match_expected(result.fn_hz, options.expect_hz, tol), tol))
    return tuple(f"{where}{line}" for line in out if line)


def identify(
    frf: FRFSet | CheckedInput, options: IdentificationOptions | None = None, *,
    picks: Picks | None = None, workers: int = 1, **overrides: Any,
) -> IdentificationResult:
    """Identify modal parameters from an FRF set (pLSCF + automatic selection + LSFD).

    Parameters
    ----------
    frf : FRFSet, (n_out, n_in, n_freq) FRFs. A roving-hammer set (one
        response, several references) is identified in its reciprocal form
        (:func:`~ema_pipeline.identification.common.single_reference`), as
        ``ema-pipeline identify`` does: ``result.modes.shapes`` then has one
        row per hammer point. Or the :class:`CheckedInput` of
        :func:`check_input` (then without ``options``, ``picks`` or
        ``overrides``: they are in it).
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
        With its ``warnings`` (:func:`result_warnings`), each also issued as
        a ``UserWarning``.

    Raises
    ------
    DataError, ConfigError
        Input that cannot be identified with these options, found before
        anything is computed (:func:`check_input`): among others settings
        whose estimated memory exceeds ``options.memory_limit_gb``.

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
    if isinstance(frf, CheckedInput):
        if options is not None or picks is not None or overrides:
            raise TypeError("identify(CheckedInput) takes no options, picks or overrides: "
                            "they are in the CheckedInput")
        checked = frf
    else:
        checked = check_input(frf, options, picks=picks, **overrides)
    backend = METHODS[checked.options.method]  # a name the options checked (METHOD_NAMES)
    with owned_blas_threads():  # small linear algebra: one BLAS thread (ema_pipeline.threads)
        result = (identify_picks(checked.frf, checked.options, checked.picks)
                  if checked.picks is not None
                  else backend(checked.frf, checked.options, workers=workers))
    result = replace(result, warnings=result_warnings(checked, result))
    for message in result.warnings:
        warnings.warn(message, UserWarning, stacklevel=2)
    return result
