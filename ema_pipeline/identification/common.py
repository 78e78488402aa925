"""Steps every identification backend shares: band and input checks, and the
common finish (standard deviations, LSFD, window correction,
indicators). The backends (:mod:`~ema_pipeline.identification.plscf_backend`,
:mod:`~ema_pipeline.identification.sdypy_backend`) import from here and never
from :mod:`~ema_pipeline.identification.core`, which dispatches to them."""

from __future__ import annotations

import numpy as np

from ema_pipeline.data import (
    MIN_FRF_LINES,
    DataError,
    FRFSet,
    ModalParameters,
    axis_is_uniform,
    quantity_power,
)
from ema_pipeline.identification.diagram.stabilization import pole_to_modal
from ema_pipeline.identification.refinement.lsfd import (
    frac,
    lsfd,
    mpc,
    normalised_error,
    real_normalised,
)
from ema_pipeline.identification.refinement.refine import local_residues
from ema_pipeline.identification.refinement.uncertainty import modal_std
from ema_pipeline.identification.result import (
    IdentificationResult,
    ResolvedSettings,
    SelectedPoles,
    StabilizationData,
)
from ema_pipeline.modal import mac


def single_reference(frf: FRFSet) -> FRFSet:
    """The FRF set the identification works on: a roving-hammer set (one
    response, several references) made single-reference by reciprocity
    (:meth:`ema_pipeline.data.FRFSet.reciprocal`), which keeps the pLSCF model
    small; any other set unchanged. :func:`~ema_pipeline.identification.identify`
    applies it, so the library and ``ema-pipeline identify`` see the same set.

    Examples
    --------
    >>> from ema_pipeline.data import DOF
    >>> roving = FRFSet(freq_hz=np.arange(1.0, 6.0), H=np.ones((1, 3, 5), complex),
    ...                 response_dofs=(DOF(1),), reference_dofs=(DOF(2), DOF(3), DOF(4)))
    >>> single_reference(roving).H.shape, single_reference(roving.reciprocal()).H.shape
    ((3, 1, 5), (3, 1, 5))
    """
    return frf.reciprocal() if frf.n_out == 1 and frf.n_in > 1 else frf


def source_prefix(frf: FRFSet) -> str:
    """``"<path>: "`` for error messages, or ``""`` when the FRF set has no source file.

    Examples
    --------
    >>> from dataclasses import replace
    >>> from ema_pipeline.data import Provenance
    >>> frf = FRFSet(freq_hz=np.arange(3.0), H=np.ones(3, complex))
    >>> source_prefix(frf), source_prefix(replace(frf, source=Provenance(path="a.uff")))
    ('', 'a.uff: ')
    """
    return f"{frf.source.path}: " if frf.source.path else ""


def usable_top_hz(frf: FRFSet) -> float | None:
    """The top of the hammer's usable band: the last line at or below the
    force spectrum's -20 dB point (``frf.acquisition.force_band_hz[1]``, FRFs
    made by ``ema-pipeline frf``), where that lies inside the axis and leaves
    :data:`~ema_pipeline.data.MIN_FRF_LINES` lines above the default band's
    start; else ``None`` (the whole axis is used).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from ema_pipeline.data import AcquisitionInfo
    >>> frf = FRFSet(freq_hz=np.arange(0.0, 100.0), H=np.ones(100, complex))
    >>> usable_top_hz(frf) is None
    True
    >>> usable_top_hz(replace(frf, acquisition=AcquisitionInfo(force_band_hz=(30.0, 60.5))))
    60.0
    """
    band = frf.acquisition.force_band_hz
    f = frf.freq_hz
    if band is None or not np.isfinite(band[1]) or band[1] >= f[-1]:
        return None
    below = np.flatnonzero(f <= band[1] * (1 + 1e-12))
    if below.size == 0 or below[-1] - min(5, f.size - 2) + 1 < MIN_FRF_LINES:
        return None
    return float(f[below[-1]])


def resolve_band(frf: FRFSet, band_hz: tuple[float, float] | None) -> tuple[float, float]:
    """The band (lo, hi) in Hz: ``band_hz`` checked against the axis, or by default
    from the 6th line (skipping 0 Hz and the first lines) to the last line, or
    to the hammer's usable band (:func:`usable_top_hz`) for FRFs that carry one:
    past the force's -20 dB point the FRFs are mostly noise.

    Examples
    --------
    >>> frf = FRFSet(freq_hz=np.arange(0.0, 100.0), H=np.ones(100, complex))
    >>> resolve_band(frf, None), resolve_band(frf, (10, 50))
    ((5.0, 99.0), (10.0, 50.0))
    """
    f = frf.freq_hz
    if band_hz is None:
        top = usable_top_hz(frf)
        return float(f[min(5, f.size - 2)]), float(f[-1]) if top is None else top
    lo, hi = (float(b) for b in band_hz)
    if not (np.isfinite(lo) and np.isfinite(hi)) or not lo < hi:
        raise DataError(f"band {band_hz} Hz is not an interval lo < hi")
    if lo < f[0] - 1e-9 or hi > f[-1] + 1e-9:
        raise DataError(
            f"band [{lo:g}, {hi:g}] Hz lies outside the frequency axis [{f[0]:g}, {f[-1]:g}] Hz"
        )
    return lo, hi


def ends_at_usable_top(frf: FRFSet, band_hz: tuple[float, float]) -> bool:
    """Whether the identified band ``band_hz`` ends at the hammer's usable band
    (:func:`usable_top_hz`), as the default band of FRFs from ``frf`` does.

    Examples
    --------
    >>> frf = FRFSet(freq_hz=np.arange(0.0, 100.0), H=np.ones(100, complex))
    >>> ends_at_usable_top(frf, (5.0, 99.0))
    False
    """
    top = usable_top_hz(frf)
    return top is not None and abs(band_hz[1] - top) <= 1e-9 * top


def check_band_data(sub: FRFSet, max_order: int, where: str) -> None:
    """Refuse, before any numerics, a band that identification cannot use.

    Parameters
    ----------
    sub : the FRF set cut to the band.
    max_order : the highest model order that will be computed.
    where : prefix of the messages (the source file, see :func:`source_prefix`).

    Raises
    ------
    DataError
        fewer than :data:`ema_pipeline.data.MIN_FRF_LINES` lines in the band,
        unequally spaced lines, too few lines for ``max_order`` (pLSCF needs
        2 (p + 1)), or a channel that is all zero in the band.

    Examples
    --------
    >>> from ema_pipeline.data import FRFSet
    >>> f = np.linspace(10.0, 100.0, 40)
    >>> frf = FRFSet(freq_hz=f, H=np.ones((1, 1, 40), complex))
    >>> check_band_data(frf, 10, "")
    >>> check_band_data(frf, 30, "a.uff: ")
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: a.uff: the band has 40 frequency lines, too few ...
    """
    n_lines = sub.freq_hz.size
    if n_lines < MIN_FRF_LINES:
        raise DataError(
            f"{where}the band has {n_lines} frequency lines; identification needs at least "
            f"{MIN_FRF_LINES}: widen the band or measure with a finer frequency resolution"
        )
    if not axis_is_uniform(sub.freq_hz):
        raise DataError(
            f"{where}frequency lines are not equally spaced (UFF abscissa spacing 0); "
            "pLSCF needs a uniform axis: resample the FRFs first"
        )
    if max_order < 1:
        raise DataError(f"max_order must be >= 1, got {max_order}")
    need = 2 * (max_order + 1)
    if n_lines < need:
        raise DataError(
            f"{where}the band has {n_lines} frequency lines, too few for model order "
            f"{max_order} (need at least {need}); lower max_order or widen the band"
        )
    zero = ~np.any(sub.H != 0, axis=-1)
    if zero.any():
        o, i = np.argwhere(zero)[0]
        raise DataError(
            f"{where}FRF channel response {sub.response_dofs[o].label()} / reference "
            f"{sub.reference_dofs[i].label()} is all zero in the band; remove the channel"
        )


def default_max_order(n_in: int, n_lines: int) -> int:
    """Default highest polynomial order, the adaptive order search's start: 64
    for one reference, 40 for two, 30 for three, 24 for more references,
    never more than the lines allow (``n_lines // 2 - 1``).

    Examples
    --------
    >>> default_max_order(1, 4000), default_max_order(2, 4000), default_max_order(1, 50)
    (64, 40, 24)
    """
    p = {1: 64, 2: 40, 3: 30}.get(n_in, 24)
    return int(min(p, n_lines // 2 - 1))


def reference_column(residues: np.ndarray, i_ref: int) -> np.ndarray:
    """Column ``i_ref`` of each mode's residue matrix, (n_modes, n_out), from
    its rank-one part.

    A mode's residues over the responses o and references i are
    phi_o phi_i / (2j omega_d m): a rank-one matrix. With several references
    its shape is read from all of them: the column of reference ``i_ref`` of
    the best rank-one approximation s_1 u_1 v_1^H of the fitted matrix
    (its largest singular triple), i.e. the direction u_1 that all
    references agree on, scaled as reference ``i_ref`` sees it. A mode that
    reference ``i_ref`` barely excites then keeps the direction the other
    references give (its own column there holds mostly noise: a close_2ref
    case's mode at MAC 0.80 with the truth, 0.999 from the rank-one part).
    One reference: the column itself.

    Examples
    --------
    >>> phi = np.array([1.0, -2.0, 0.5])
    >>> A = (phi[:, None] * np.array([1e-3, 1.0])[None, :])[None]  # reference 0 barely excited
    >>> A[0, :, 0] += np.array([0.0, 0.0, 1e-3])  # and noise there
    >>> col = reference_column(A, 0)[0]
    >>> (col / col[0]).real.round(6).tolist(), float(abs(col[0])) < 1.1e-3
    ([1.0, -2.0, 0.5], True)
    """
    if residues.shape[2] == 1 or residues.shape[0] == 0:
        return residues[:, :, i_ref]
    U, s, Vh = np.linalg.svd(residues, full_matrices=False)
    return s[:, :1] * U[:, :, 0] * Vh[:, 0, i_ref][:, None]


def finish_identification(
    sub: FRFSet,
    pole_id: np.ndarray,
    *,
    decay: float,
    lower_residual: bool,
    upper_residual: bool,
    stab: StabilizationData,
    selected: SelectedPoles | None,
    settings: ResolvedSettings,
    pole_cov: np.ndarray | None = None,
    edge: tuple[FRFSet, np.ndarray] | None = None,
) -> IdentificationResult:
    """LSFD, window correction, standard deviations, indicators.

    One global LSFD of all poles over the band gives the synthesis ``H_fit``
    (FRAC, error) and the residual terms; each mode's residues, shape, MPC and
    MAC come from its own local band (:func:`local_residues`, the global
    residues of the other modes subtracted there), so that a mode's shape
    does not depend on how wide the band is; the shape of a mode with
    several references is read from the rank-one part of its residues
    (:func:`reference_column`).

    ``sub`` is the FRF set cut to the band, ``pole_id`` the identified poles
    (before window correction), ``decay`` the window's decay rate 1/tau (1/s).
    ``pole_cov`` (n_modes, 2, 2), the covariance of (sigma, omega_d) of refined
    poles, gives their standard deviations; without it the scatter of the
    selected trajectories over the model orders does (NaN without ``selected``).
    ``edge``, the FRF set cut to a widened band and poles at the band's edges
    (:mod:`~ema_pipeline.identification.selection.edge_poles`): both fits run
    on the widened band with those poles among the poles, which are not
    reported; ``H_fit`` is cut back to the band's lines.
    """
    freq = sub.freq_hz
    n_out, n_in, n_freq = sub.H.shape
    Hc = sub.H.reshape(n_out * n_in, n_freq)
    m = pole_id.size
    fn_std = np.full(m, np.nan)
    zeta_std = np.full(m, np.nan)
    if m and pole_cov is not None:
        fn_std, zeta_std = modal_std(pole_id + decay, pole_cov)
    elif m and selected is not None:
        fn_std, zeta_std = selected.scatter_fn_hz, selected.scatter_zeta
    pole = pole_id + decay
    fn, fd, zeta = pole_to_modal(pole)
    if m:
        fit_freq, fit_H, fit_pole, lines = freq, Hc, pole_id, slice(None)
        if edge is not None:  # the widened band, the edge poles among the poles
            wide, edge_pole = edge
            fit_freq, fit_pole = wide.freq_hz, np.concatenate([pole_id, edge_pole])
            fit_H = wide.H.reshape(n_out * n_in, fit_freq.size)
            i0 = int(np.argmin(np.abs(fit_freq - freq[0])))
            lines = slice(i0, i0 + n_freq)
        fit = lsfd(fit_freq, fit_H, fit_pole, sub.quantity, lower=lower_residual,
                   upper=upper_residual)
        # the residues (and shapes) from each mode's local band, the global
        # fit's terms of the other modes subtracted; the synthesis stays the
        # global fit's
        a_local, _ = local_residues(fit_freq, fit_H, fit_pole, fit.a,
                                    thresholds=settings.thresholds)
        q = quantity_power(sub.quantity)
        residues = (a_local[:m] / pole[:, None] ** q).reshape(m, n_out, n_in)
        H_fit = fit.H_fit[:, lines].reshape(n_out, n_in, n_freq)
        low = fit.lower.reshape(n_out, n_in)
        up = fit.upper.reshape(n_out, n_in)
    else:
        residues = np.zeros((0, n_out, n_in), dtype=complex)
        H_fit = np.zeros_like(sub.H)
        low = np.zeros((n_out, n_in), dtype=complex)
        up = np.zeros((n_out, n_in), dtype=complex)
    i_ref = int(np.argmax(np.sum(np.abs(residues) ** 2, axis=(0, 1)))) if m else 0
    shapes = (2j * pole.imag)[None, :] * reference_column(residues, i_ref).T  # (n_out, m)
    modes = ModalParameters(
        fn_hz=fn,
        zeta=zeta,
        fn_std_hz=fn_std,
        zeta_std=zeta_std,
        shapes=shapes,
        dofs=sub.response_dofs,
        configuration=sub.configuration,
    )
    return IdentificationResult(
        modes=modes,
        pole=pole,
        residues=residues,
        lower_residual=low,
        upper_residual=up,
        shapes_real=real_normalised(shapes),
        shape_reference=i_ref,
        mac=mac(shapes),
        mpc=mpc(shapes),
        freq_hz=freq,
        H_fit=H_fit,
        frac=frac(sub.H, H_fit),
        error=normalised_error(sub.H, H_fit),
        stabilization=stab,
        selected=selected,
        settings=settings,
    )
