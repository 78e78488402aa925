"""The options of the identification stage, defined once.

:class:`IdentificationOptions` is what the experiment file's
``[identification]`` table (:func:`ema_pipeline.io.read_experiment`), the
command line (``ema-pipeline identify`` / ``batch``) and library callers build,
and what :func:`ema_pipeline.identification.identify` takes whole. This module
imports only from :mod:`ema_pipeline.data` and
:mod:`~ema_pipeline.identification.thresholds`, so the data containers can refer
to it without an import cycle.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from ema_pipeline.data import FRFSet
from ema_pipeline.identification.thresholds import SelectionThresholds

Method = Literal["plscf", "sdypy-lscf"]
Weighting = Literal["none", "coherence"]


@dataclass(frozen=True)
class IdentificationOptions:
    """Options of :func:`ema_pipeline.identification.identify` (``None`` = the method's default).

    Attributes
    ----------
    band_hz : (lo, hi) band in Hz; default: from the 6th line (skipping 0 Hz
        and the first lines) to the last line.
    max_order : highest pLSCF denominator order p (p * n_in poles), fixed;
        default adaptive: from :func:`ema_pipeline.identification.default_max_order`
        doubled while the diagram gains modes, up to
        :func:`ema_pipeline.identification.resources.order_cap`. For
        ``"sdypy-lscf"`` sdypy-EMA's ``pol_order_high`` (default 100).
    method : a name in :data:`ema_pipeline.identification.METHODS`:
        ``"plscf"`` (this package) or ``"sdypy-lscf"`` (sdypy-EMA).
    expect_hz : approximate natural frequencies in Hz; the nearest stable pole
        cluster is taken for each (one mode per entry) instead of the automatic
        choice. Empty: automatic selection.
    exp_window_tau_s : time constant (s) of the exponential window, overriding
        the one stored with the FRFs (foreign UFF files lack it); ``None`` keeps
        the FRF set's.
    weighting : "none" (each output scaled by its RMS in the band) or
        "coherence" (additionally every line weighted by the coherence).
    tol_freq, tol_zeta, tol_mac : stabilization tolerances (relative frequency,
        relative damping, 1 - MAC of participation vectors). A value given is
        used by both the pole linking of the selection
        (:func:`~ema_pipeline.identification.selection.track_poles`: looser
        tolerances join more poles into a trajectory) and the stabilization
        diagram's flags. ``None`` (default): each uses its tuned default,
        ``thresholds.link_tol_*`` (1 %, 30 %, 0.05) and
        ``thresholds.diagram_tol_*`` (1 %, 5 %, 0.02).
    min_fraction : a pole trajectory must hold poles of at least this fraction
        of the computed orders (and at least 6) to count as a physical mode;
        where in the diagram it starts does not matter (a mode that
        stabilises late is kept once it holds them).
    refine : refine the selected poles by variable-projection nonlinear least
        squares (:func:`ema_pipeline.identification.refine.refine_poles`), which
        also gives their covariance.
    lower_residual, upper_residual : residual terms in LSFD.
    window_searches : search a dense band again in windows of consecutive
        candidates (:func:`~ema_pipeline.identification.order_search.add_window_modes`:
        a weak mode between strong ones forms a trajectory there, and a
        window's candidate stands in for a full-band pole that fails the
        final tests); ``False`` skips them: much faster on a band of many
        modes, at the risk of missing such modes. Measured beam without a
        band: the same 19 modes within 0.01 Hz in 1.8 s instead of 3.9 s;
        bands 5-790 and 250-700 Hz: 603.0 Hz missed (its full-band pole
        fails, the window's is the mode); the dense hard cases, seeds
        400-403: 14 of 259 modes missed without the windows, 4 with them.
        The doubtful rule ``found_only_in_some_bands`` then rests on the
        low-band search alone.
    thresholds : the tuned thresholds of the selection and the final tests
        (:class:`~ema_pipeline.identification.thresholds.SelectionThresholds`);
        for studies of the method, not for everyday use.

    Examples
    --------
    >>> options = IdentificationOptions(band_hz=[5, 395], expect_hz=[18.1, 112.0])
    >>> options.band_hz, options.expect_hz
    ((5.0, 395.0), (18.1, 112.0))
    >>> options == IdentificationOptions(band_hz=(5.0, 395.0), expect_hz=(18.1, 112.0))
    True
    """

    band_hz: tuple[float, float] | None = None
    max_order: int | None = None
    method: Method = "plscf"
    expect_hz: tuple[float, ...] = ()
    exp_window_tau_s: float | None = None
    weighting: Weighting = "none"
    tol_freq: float | None = None
    tol_zeta: float | None = None
    tol_mac: float | None = None
    min_fraction: float = 0.3
    refine: bool = True
    lower_residual: bool = True
    upper_residual: bool = True
    window_searches: bool = True
    thresholds: SelectionThresholds = field(default_factory=SelectionThresholds)

    def __post_init__(self) -> None:
        # normalise sequences so that options compare and hash by value
        if self.band_hz is not None:
            object.__setattr__(self, "band_hz", tuple(float(b) for b in self.band_hz))
        expect = () if self.expect_hz is None else np.atleast_1d(self.expect_hz)
        object.__setattr__(self, "expect_hz", tuple(float(f) for f in expect))

    def link_tolerances(self) -> tuple[float, float, float]:
        """(tol_freq, tol_zeta, tol_mac) of the selection's pole linking: the
        options given, else ``thresholds.link_tol_*``.

        Examples
        --------
        >>> IdentificationOptions().link_tolerances()
        (0.01, 0.3, 0.05)
        >>> IdentificationOptions(tol_zeta=0.1).link_tolerances()
        (0.01, 0.1, 0.05)
        """
        th = self.thresholds
        return _given_or(self, th.link_tol_freq, th.link_tol_zeta, th.link_tol_mac)

    def diagram_tolerances(self) -> tuple[float, float, float]:
        """(tol_freq, tol_zeta, tol_mac) of the stabilization diagram's flags:
        the options given, else ``thresholds.diagram_tol_*``.

        Examples
        --------
        >>> IdentificationOptions().diagram_tolerances()
        (0.01, 0.05, 0.02)
        >>> IdentificationOptions(tol_zeta=0.1).diagram_tolerances()
        (0.01, 0.1, 0.02)
        """
        th = self.thresholds
        return _given_or(self, th.diagram_tol_freq, th.diagram_tol_zeta, th.diagram_tol_mac)

    def apply_window(self, frf: FRFSet) -> FRFSet:
        """``frf`` with ``exp_window_tau_s`` recorded in its acquisition info
        (unchanged when the option is ``None``).

        Examples
        --------
        >>> frf = FRFSet(freq_hz=np.arange(3.0), H=np.ones(3, complex))
        >>> windowed = IdentificationOptions(exp_window_tau_s=2.0).apply_window(frf)
        >>> windowed.acquisition.window_decay_rate  # 1 / tau
        0.5
        """
        if self.exp_window_tau_s is None:
            return frf
        return replace(
            frf, acquisition=replace(frf.acquisition, exp_window_tau_s=self.exp_window_tau_s)
        )


def _given_or(
    options: IdentificationOptions, freq: float, zeta: float, mac: float
) -> tuple[float, float, float]:
    """The options' tolerances where given, else ``freq``, ``zeta``, ``mac``."""
    given = (options.tol_freq, options.tol_zeta, options.tol_mac)
    return tuple(  # type: ignore[return-value]
        float(d) if g is None else float(g) for g, d in zip(given, (freq, zeta, mac), strict=True)
    )
