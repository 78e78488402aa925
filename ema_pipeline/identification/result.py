"""What :func:`ema_pipeline.identification.identify` returns: the result, its
parts (the stabilization data, the selected poles) and the resolved record of
the settings it used, with the tables read from them.

A light module: it imports numpy, pandas, :mod:`ema_pipeline.data`,
:mod:`ema_pipeline.modal` and the thresholds, never the numerics (no scipy),
so that :mod:`ema_pipeline.io` can read and write results without loading
the identification (``tests/test_style.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ema_pipeline.data import ModalParameters, Table, notebook_table_html
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.modal import mpd

if TYPE_CHECKING:
    import pandas as pd

#: Bits of :attr:`StabilizationData.flags`.
STABLE_FREQ = 1
STABLE_DAMP = 2
STABLE_VECTOR = 4
STABLE_ALL = STABLE_FREQ | STABLE_DAMP | STABLE_VECTOR


@dataclass(frozen=True)
class StabilizationData:
    """Poles of all model orders with their stability flags (plain arrays for HDF5).

    Attributes
    ----------
    order : (n,) int          model (polynomial) order of each pole
    freq_hz : (n,) float      natural frequency f_n of the window-corrected pole, Hz
    zeta : (n,) float         damping ratio of the window-corrected pole
    flags : (n,) uint8        bit 1: frequency stable (< ``tol_freq`` relative change
                              against the nearest pole of the previous order),
                              bit 2: damping stable (< ``tol_zeta``),
                              bit 4: participation vector stable (MAC > 1 - ``tol_mac``)
    pole : (n,) complex       identified pole lambda (rad/s, before window correction)
    cluster : (n,) int        cluster of the automatic selection, -1 = none
    tol_freq, tol_zeta, tol_mac : the tolerances used (NaN: no diagram, e.g.
                              the sdypy backend).
    mode_pole : (n_modes,) complex  the start pole of each kept mode (result
                              order, before window correction): a trajectory's
                              median or a pole found outside the diagram; what
                              the report's diagram and ``--picks`` use
                              (:mod:`ema_pipeline.identification.selection.picks`).
    companion_pole : (n,) complex  the start poles of the candidates refined
                              together with the kept modes in their final
                              fit that the final tests then dropped (before
                              window correction): ``--picks`` refines them
                              with the picks and drops them again, so that
                              the untouched picks reproduce the kept modes.
    """

    order: np.ndarray
    freq_hz: np.ndarray
    zeta: np.ndarray
    flags: np.ndarray
    pole: np.ndarray
    cluster: np.ndarray
    tol_freq: float = float("nan")
    tol_zeta: float = float("nan")
    tol_mac: float = float("nan")
    mode_pole: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))
    companion_pole: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))

    @property
    def stable(self) -> np.ndarray:
        """Poles stable in frequency, damping and participation vector."""
        return (self.flags & STABLE_ALL) == STABLE_ALL


#: How a mode's candidate was found (``SelectedPoles.found_by`` indexes it, the
#: modes table's ``found_by`` column names it): a trajectory of the band's
#: stabilization diagram (``diagram``), of one of the band's diagrams at
#: another order than the one stored (``other_order``), a narrower search's diagram (the
#: band's lowest part or a dense band's window: ``window``), the narrower
#: search's candidate tried where the full band's failed (``alternate``), a
#: close mode hidden in a kept resonance (``partner``), a peak of the residual
#: of the kept modes' fit (``residual``), the answer to an expected frequency
#: (``expected``) or a pole picked by hand (``picked``). Modes found outside the
#: stored diagram have ``stable_from_order`` and ``n_stable_orders`` 0.
FOUND_BY = ("diagram", "other_order", "window", "alternate", "partner", "residual", "expected",
            "picked")


def found_by_code(name: str, n: int) -> np.ndarray:
    """``n`` rows of :data:`FOUND_BY` entry ``name`` (int codes).

    Examples
    --------
    >>> found_by_code("window", 2).tolist()
    [2, 2]
    """
    return np.full(n, FOUND_BY.index(name), dtype=int)


@dataclass(frozen=True)
class SelectedPoles:
    """Physical poles chosen from the stabilization data, ascending frequency.

    Attributes
    ----------
    pole : (n_modes,) complex   identified pole (trajectory median, before window correction)
    cluster : (n_modes,) int    trajectory label in :attr:`StabilizationData.cluster`
    n_members : (n_modes,) int  number of model orders the trajectory holds
    scatter_fn_hz, scatter_zeta : (n_modes,) std of f_n and zeta over the
        settled (last half) members
    first_order : (n_modes,) int  model order at which the trajectory starts
        (the mode is stable from there on); empty when unknown
    found_by : (n_modes,) int  how the candidate was found, an index into
        :data:`FOUND_BY` (the diagram, a narrower search's window, ...);
        empty when unknown (results stored before it)
    """

    pole: np.ndarray
    cluster: np.ndarray
    n_members: np.ndarray
    scatter_fn_hz: np.ndarray
    scatter_zeta: np.ndarray
    first_order: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    found_by: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    def subset(self, keep: np.ndarray) -> SelectedPoles:
        """The rows ``keep`` (boolean mask or indices) of every field."""
        return SelectedPoles(
            **{k: (v[keep] if v.size else v) for k, v in self.__dict__.items()}
        )

    def concatenate(self, other: SelectedPoles) -> SelectedPoles:
        """The rows of ``self`` followed by those of ``other``."""
        return SelectedPoles(**{k: np.concatenate([v, getattr(other, k)])
                                for k, v in self.__dict__.items()})




@dataclass(frozen=True)
class ResolvedSettings:
    """Everything :func:`identify` used, resolved (no ``None`` left but ``expect_hz``).

    The record stored with a result: the :class:`IdentificationOptions` after
    the defaults of the method and the data were applied (band, order, the
    orders computed, the z-domain sampling time, the window's decay rate).
    ``tol_freq``, ``tol_zeta``, ``tol_mac`` are the tolerances of the
    selection's pole linking (the diagram's are in ``result.stabilization``);
    ``thresholds`` the tuned thresholds used, which also define the
    ``doubtful`` rule (:func:`doubtful_reasons`); ``window_searches`` whether
    a dense band was searched again in windows (the option of that name;
    results stored before it had them); ``accept`` whether the final tests
    ran (the option of that name; ``False`` for picked modes, never tested).
    """

    method: str
    band_hz: tuple[float, float]
    max_order: int
    orders: np.ndarray
    dt_s: float
    weighting: str
    window_decay_rate: float
    tol_freq: float
    tol_zeta: float
    tol_mac: float
    min_fraction: float
    refine: bool
    lower_residual: bool
    upper_residual: bool
    expect_hz: np.ndarray | None
    uncertainty: str
    window_searches: bool = True
    accept: bool = True
    thresholds: SelectionThresholds = field(default_factory=SelectionThresholds)


@dataclass(frozen=True)
class IdentificationResult:
    """Modal parameters identified from one FRF set, with everything to judge them.

    Attributes
    ----------
    modes : ModalParameters
        f_n, zeta (window-corrected, structural), their standard deviations,
        complex mode shapes (modal constants 2j omega_d A_r at the response DOFs
        for the reference ``shape_reference``, from the rank-one part of A_r
        with several references:
        :func:`~ema_pipeline.identification.common.reference_column`), configuration.
    pole : (n_modes,) complex  window-corrected poles lambda_r (rad/s).
    residues : (n_modes, n_out, n_in) complex  receptance residues A_r, each
        mode's from its local band
        (:func:`~ema_pipeline.identification.refinement.refine.local_residues`).
    lower_residual, upper_residual : (n_out, n_in) complex residual terms of
        the global LSFD that gives ``H_fit`` (in the FRF's quantity; see
        :mod:`ema_pipeline.identification.refinement.lsfd`).
    shapes_real : (n_out, n_modes) real-normalised shapes (largest component +1).
    shape_reference : int  index of the reference used for ``modes.shapes``.
    mac : (n_modes, n_modes) auto-MAC of the shapes.
    mpc : (n_modes,) modal phase collinearity (1 = real mode).
    freq_hz : (n_freq,) the band's lines.   H_fit : (n_out, n_in, n_freq) synthesis
        of the global LSFD (all modes and the residual terms over the band).
    frac, error : (n_out, n_in) FRAC and normalised error ||H - H_fit|| / ||H|| per FRF.
    stabilization : StabilizationData (empty arrays for the sdypy backend).
    selected : SelectedPoles (cluster bookkeeping; ``None`` for the sdypy backend).
    settings : ResolvedSettings
    not_kept_hz : (n,) float  resonances the FRFs show that no mode was kept
        for (candidates that failed the final tests but stand out as a peak in
        ``not_kept_frfs`` of the FRFs; :mod:`ema_pipeline.identification.selection.not_kept`),
        Hz, ascending; empty when there is none and for the sdypy backend.
    not_kept_frfs : (n,) int  in how many FRFs each stands out.
    band_support : (n_modes, 2) int  per mode, how many of the narrower searches
        of the band (its lowest part, the windows of a dense band) hold it and
        how many of those found a candidate there
        (:func:`~ema_pipeline.identification.diagram.narrower_searches.band_support`); no rows
        when there were no such searches' records (picks, the sdypy backend).
    pair_flags : (n_modes,) int  per mode, with fewer than three channels the
        bits :data:`PAIR_UNDER_ONE_PEAK` (one of a close pair whose peaks do
        not show apart) and :data:`SECOND_POLE_DROPPED` (a second pole beside
        it was dropped: the data did not prefer two), with any number the bit
        :data:`TWIN_APART` (found twice, the twins apart); empty when not
        judged (picks, ``expect_hz``, the sdypy backend) or, with three or more
        channels, when no mode has a twin apart.
    edge_hz : (n,) float  natural frequencies (Hz, ascending) of resonances in
        the band's edge zones or just past them, fitted beside their
        neighbours on a widened band and not reported
        (:mod:`~ema_pipeline.identification.selection.edge_poles`); empty when
        there is none.
    warnings : tuple of str  what the user should know about this result, one
        line each, prefixed with the FRF file's path when the set has one:
        resonances no mode was kept for, a band past the hammer's usable band,
        narrower searches a fixed order turned off, expected modes not found
        (:func:`~ema_pipeline.identification.identify` makes them, issues each
        as a ``UserWarning`` too, and ``ema-pipeline identify`` prints them).
    """

    modes: ModalParameters
    pole: np.ndarray
    residues: np.ndarray
    lower_residual: np.ndarray
    upper_residual: np.ndarray
    shapes_real: np.ndarray
    shape_reference: int
    mac: np.ndarray
    mpc: np.ndarray
    freq_hz: np.ndarray
    H_fit: np.ndarray
    frac: np.ndarray
    error: np.ndarray
    stabilization: StabilizationData
    selected: SelectedPoles | None
    settings: ResolvedSettings
    extras: dict[str, float] = field(default_factory=dict)
    not_kept_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    not_kept_frfs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    band_support: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=int))
    pair_flags: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    edge_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    warnings: tuple[str, ...] = ()

    def __repr__(self) -> str:
        """Short: configuration, modes, band, method and order, mean fit error."""
        m = self.modes
        freqs = ", ".join(f"{f:.2f}" for f in np.sort(m.fn_hz)[:8]) + (
            ", ..." if m.n_modes > 8 else ""
        )
        lo, hi = self.settings.band_hz
        error = f"{100 * float(np.mean(self.error)):.2f} %" if self.error.size else "n/a"
        return (
            f"IdentificationResult({m.configuration or 'unnamed'}: {m.n_modes} modes "
            f"[{freqs}] Hz, band {lo:g}-{hi:g} Hz, {self.settings.method} max order "
            f"{self.settings.max_order}, fit error {error})"
        )

    def _repr_html_(self) -> str:
        """The modal table (notebooks): :func:`modes_table` as plain HTML (the
        report's formatted one is :func:`ema_pipeline.report.mode_table_html`)."""
        m = self.modes
        return notebook_table_html(modes_columns(self).columns,
                                   caption=f"{m.configuration or 'modes'}: {m.n_modes} modes")

    @property
    def fn_hz(self) -> np.ndarray:
        return self.modes.fn_hz

    @property
    def fd_hz(self) -> np.ndarray:
        return self.modes.fd_hz

    @property
    def zeta(self) -> np.ndarray:
        return self.modes.zeta


def stable_orders(result: IdentificationResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per mode (result order): the lowest and the highest model order at which
    its pole is stable and the number of orders that hold it (zeros without
    cluster data, e.g. for the sdypy backend).

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import FRFSet
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> res = identify(FRFSet(freq_hz=f, H=H))
    >>> first, last, count = stable_orders(res)
    >>> bool(first.min() > 0 and count.min() >= res.settings.thresholds.min_stable_orders)
    True
    """
    n = result.modes.n_modes
    first, last, count = (np.zeros(n, dtype=int) for _ in range(3))
    sel, stab = result.selected, result.stabilization
    if sel is None or stab.order.size == 0:
        return first, last, count
    for k in range(min(n, sel.cluster.size)):
        members = stab.order[stab.cluster == sel.cluster[k]]
        if members.size:
            first[k], last[k] = int(members.min()), int(members.max())
            count[k] = np.unique(members).size
    return first, last, count


def found_by_names(result: IdentificationResult) -> list[str]:
    """Per mode (result order), how its candidate was found (an entry of
    :data:`FOUND_BY`), ``""`` where the result does not say (the sdypy
    backend, results stored before it).

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import FRFSet
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> found_by_names(identify(FRFSet(freq_hz=f, H=H)))
    ['diagram', 'diagram']
    """
    n = result.modes.n_modes
    sel = result.selected
    codes = np.zeros(0, int) if sel is None else np.asarray(sel.found_by, dtype=int)
    if codes.size < n:
        return [""] * n
    return [FOUND_BY[int(c)] for c in codes[:n]]


def selection_names(result: IdentificationResult) -> list[str]:
    """Per mode (result order), who chose it: ``picked`` (a picks file),
    ``expected`` (it answers an expected frequency) or ``auto`` (the automatic
    selection, whichever search found it); read from :func:`found_by_names`.

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import FRFSet
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> selection_names(identify(FRFSet(freq_hz=f, H=H), expect_hz=(30.0,)))
    ['expected']
    """
    return [name if name in ("picked", "expected") else "auto"
            for name in found_by_names(result)]


#: Bits of :attr:`IdentificationResult.pair_flags` (fewer than three channels,
#: ``plscf_backend.with_pair_flags``): the mode is one of two close poles kept
#: under one peak (two poles fit the data better than one, but no FRF shows
#: two peaks, no shape tells them apart, and the F test is not calibrated on
#: the file or does not prefer them by ``pair_clear_significance``) ...
PAIR_UNDER_ONE_PEAK = 1
#: ... or a second pole beside it was dropped (the data did not prefer two).
SECOND_POLE_DROPPED = 2
#: Any number of channels: the final tests found the mode twice and the other
#: candidate refined more than ``twin_max_sigma`` of its f sigma away
#: (``plscf_backend.with_twin_flags``).
TWIN_APART = 4

#: The names of the rules of :func:`doubtful_reasons`, in the order they are listed.
DOUBTFUL_RULES = ("few_stable_orders", "loose_damping", "complex_shape", "unresolved_damping",
                  "found_only_in_some_bands", "pair_under_one_peak",
                  "second_pole_not_significant", "refinement_failed", "found_twice_apart")


def doubtful_flags(result: IdentificationResult) -> dict[str, np.ndarray]:
    """Per rule of :data:`DOUBTFUL_RULES`, the modes (result order) it marks,
    with the thresholds of ``result.settings.thresholds``:

    * ``few_stable_orders``: stable at fewer than ``min_stable_orders`` model
      orders (where cluster data exist);
    * ``loose_damping``: ``zeta_std > max_rel_zeta_std * zeta``;
    * ``complex_shape``: ``mpc < min_mpc`` with three or more responses;
    * ``unresolved_damping``: a half-power bandwidth 2 zeta f_n below
      ``min_bandwidth_lines`` line spacings;
    * ``found_only_in_some_bands``: at least ``min_band_searches`` of the
      band's narrower searches hold it and none found it
      (``result.band_support``);
    * ``pair_under_one_peak``: with fewer than three channels, one of two
      close poles kept under one peak: the fit prefers two poles, but one or
      two channels cannot tell them from one mode whose frequency varies
      (``result.pair_flags``, :data:`PAIR_UNDER_ONE_PEAK`; not marked where
      the F test is calibrated on the file and prefers two poles by
      ``pair_clear_significance``);
    * ``second_pole_not_significant``: with fewer than three channels, a
      second pole beside it was dropped, since the data did not prefer two
      (:data:`SECOND_POLE_DROPPED`): it may be two close modes;
    * ``refinement_failed``: with refinement on, the mode's local fit
      wandered off (further than ``refine_max_shift`` decay rates and a
      line from its start), so its start pole -- a diagram's trajectory
      or a residual peak -- is reported, with the standard deviations
      evaluated there (its selected pole is its start pole, bit for bit; a
      close partner whose local fit wanders is not kept).
      On the measured beam in 5-790 Hz a change of the FRFs in their last
      bits turns the 603.0 Hz mode into such a start pole at 601.2 Hz
      (``docs/validation.md``);
    * ``found_twice_apart``: the final tests found the mode twice (two
      candidates, one mode: ``acceptance.distinct_shapes`` kept one) and the
      other candidate's refined frequency lies more than ``twin_max_sigma``
      of its ``fn_std_hz`` from the mode's (``result.pair_flags``,
      :data:`TWIN_APART`): which start the tests kept moves the value by more
      than its sigma. On the measured beam in 100-400 Hz a change of the FRFs
      in their last bits keeps the other twin of the 155.5 Hz mode (155.50
      -> 155.48 Hz, 0.6 sigma).
    """
    th = result.settings.thresholds
    m = result.modes
    _, _, count = stable_orders(result)
    few = (count < th.min_stable_orders) & (result.selected is not None) & (count > 0)
    zeta_std = np.asarray(m.zeta_std, dtype=float)
    loose = np.isfinite(zeta_std) & (zeta_std > th.max_rel_zeta_std * np.abs(m.zeta))
    mpc = np.asarray(result.mpc, dtype=float)
    complex_shape = (mpc < th.min_mpc) if len(m.dofs) >= 3 else np.zeros(m.n_modes, bool)
    df = float(np.median(np.diff(result.freq_hz))) if result.freq_hz.size > 1 else 0.0
    unresolved = 2 * np.abs(m.zeta) * m.fn_hz < th.min_bandwidth_lines * df
    support = np.asarray(result.band_support).reshape(-1, 2)
    only_some = np.zeros(m.n_modes, bool)
    if support.shape[0] == m.n_modes:
        only_some = (support[:, 0] >= th.min_band_searches) & (support[:, 1] == 0)
    pair = np.asarray(result.pair_flags, dtype=int).reshape(-1)
    if pair.size != m.n_modes:
        pair = np.zeros(m.n_modes, dtype=int)
    not_refined = np.zeros(m.n_modes, bool)
    start = np.asarray(result.stabilization.mode_pole)
    if result.settings.refine and result.selected is not None and (
            start.size == result.selected.pole.size == m.n_modes):
        not_refined = result.selected.pole == start
    flags = (few, loose, complex_shape, unresolved, only_some,
             (pair & PAIR_UNDER_ONE_PEAK) > 0, (pair & SECOND_POLE_DROPPED) > 0, not_refined,
             (pair & TWIN_APART) > 0)
    return {name: np.asarray(f, dtype=bool) for name, f in zip(DOUBTFUL_RULES, flags, strict=True)}


def doubtful_modes(result: IdentificationResult) -> np.ndarray:
    """Modes to look at twice (result order): any rule of
    :func:`doubtful_flags` fires (:func:`doubtful_reasons` names which).
    Such modes are reported with ``doubtful = True``, not dropped.
    """
    flags = doubtful_flags(result)
    return np.asarray(np.logical_or.reduce(list(flags.values())), dtype=bool).reshape(-1)


def doubtful_reasons(result: IdentificationResult) -> list[str]:
    """Per mode (result order) the names of the doubtful rules that fire,
    joined by ``";"`` (``""`` for a mode that is not doubtful), e.g.
    ``"few_stable_orders;loose_damping"``; see :func:`doubtful_flags`.

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import FRFSet
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)  # 0.25 Hz lines
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.0005])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> res = identify(FRFSet(freq_hz=f, H=H), expect_hz=(30, 70))
    >>> doubtful_reasons(res)  # 70 Hz: 2 zeta f_n = 0.07 Hz < 0.5 line
    ['', 'unresolved_damping']
    """
    flags = doubtful_flags(result)
    n = result.modes.n_modes
    return [";".join(name for name in DOUBTFUL_RULES if flags[name][k]) for k in range(n)]


def modes_table(result: IdentificationResult) -> pd.DataFrame:
    """:func:`modes_columns` as a ``pandas.DataFrame``.

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import FRFSet
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> modes_table(identify(FRFSet(freq_hz=f, H=H)))[["mode", "fn_hz", "zeta_pct"]].round(4)
       mode  fn_hz  zeta_pct
    0     1   30.0       1.0
    1     2   70.0       2.0
    """
    return modes_columns(result).to_frame()


def modes_columns(result: IdentificationResult) -> Table:
    """One row per mode, ascending frequency: ``mode, fn_hz, fd_hz, zeta_pct,
    fn_std_hz, zeta_std_pct`` (zeta in percent) and the quality columns ``mpc``
    (modal phase collinearity, 1 = real), ``mpd_deg`` (mean phase deviation,
    degrees), ``stable_from_order``, ``n_stable_orders`` (see
    :func:`stable_orders`), ``found_by`` (how it was found,
    :func:`found_by_names`), ``selection`` (``auto``, ``picked`` or
    ``expected``, :func:`selection_names`), ``doubtful`` (see :func:`doubtful_modes`) and
    ``doubtful_reason`` (the rules that fire, :func:`doubtful_reasons`).
    :func:`modes_table` is the same as a ``pandas.DataFrame``.

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import FRFSet
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> table = modes_columns(identify(FRFSet(freq_hz=f, H=H)))
    >>> table.columns["fn_hz"].round(4).tolist(), table.columns["found_by"].tolist()
    ([30.0, 70.0], ['diagram', 'diagram'])
    """
    m = result.modes
    order = np.argsort(m.fn_hz)
    first, _, count = stable_orders(result)
    mpd_deg = mpd(m.shapes) if m.shapes is not None else np.full(m.n_modes, np.nan)
    return Table(
        {
            "mode": np.arange(1, m.n_modes + 1),
            "fn_hz": m.fn_hz[order],
            "fd_hz": m.fd_hz[order],
            "zeta_pct": 100 * m.zeta[order],
            "fn_std_hz": m.fn_std_hz[order],
            "zeta_std_pct": 100 * m.zeta_std[order],
            "mpc": np.asarray(result.mpc, dtype=float)[order],
            "mpd_deg": np.asarray(mpd_deg, dtype=float)[order],
            "stable_from_order": first[order],
            "n_stable_orders": count[order],
            "found_by": np.asarray(found_by_names(result), dtype=object)[order],
            "selection": np.asarray(selection_names(result), dtype=object)[order],
            "doubtful": doubtful_modes(result)[order],
            "doubtful_reason": np.asarray(doubtful_reasons(result), dtype=object)[order],
        }
    )
