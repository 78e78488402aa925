"""The options of the identification stage, defined and checked once.

:class:`IdentificationOptions` is what the experiment file's
``[identification]`` table (:func:`ema_pipeline.io.read_experiment`), the
command line (``ema-pipeline identify`` / ``batch``) and library callers build,
and what :func:`ema_pipeline.identification.identify` takes whole. Its
``__post_init__`` refuses every impossible value with an
:class:`~ema_pipeline.data.OptionError` naming the field
(:func:`check_option`, one rule per field); the command line and the
experiment file call the same rules and take their choices from here
(:data:`METHOD_NAMES`, :data:`WEIGHTING_NAMES`, from the ``Literal`` types).
The rules are those of :mod:`ema_pipeline.validation`. This module imports
only from :mod:`ema_pipeline.data`, :mod:`ema_pipeline.validation` and
:mod:`~ema_pipeline.identification.thresholds`, so the data containers can refer
to it without an import cycle, and importing it loads no numerics.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from functools import partial
from typing import Any, Literal, get_args

import numpy as np

from ema_pipeline.data import FRFSet, OptionError
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.validation import (
    Rule,
    choice,
    flag,
    integer,
    number,
    optional,
    pair,
    refusal,
    seconds,
    sequence,
)

Method = Literal["plscf", "sdypy-lscf"]
Weighting = Literal["none", "coherence"]
#: The identification methods by name (the keys of
#: :data:`ema_pipeline.identification.METHODS`), from :data:`Method`.
METHOD_NAMES: tuple[str, ...] = get_args(Method)
#: The weightings by name, from :data:`Weighting`.
WEIGHTING_NAMES: tuple[str, ...] = get_args(Weighting)
#: Lowest ``max_order`` per method (one key per name of :data:`METHOD_NAMES`): a
#: stabilization diagram needs at least six orders (pLSCF with one reference
#: computes every second order).
MIN_ORDER: dict[str, int] = {"plscf": 12, "sdypy-lscf": 10}
#: Highest ``max_order`` (the data may support less:
#: :func:`ema_pipeline.identification.diagram.resources.order_cap`).
MAX_ORDER = 1000
#: Default ``memory_limit_gb``: the largest estimated memory of one
#: identification, GiB.
DEFAULT_MEMORY_LIMIT_GB = 4.0


def _frequencies(name: str, value: Any) -> tuple[float, ...]:
    # one frequency or a sequence of them (any array-like); None: none
    if value is None:
        return ()
    items = np.atleast_1d(np.asarray(value, dtype=object)).tolist()
    return sequence(name, items, item=partial(number, above=0.0))


def _thresholds(name: str, value: Any) -> SelectionThresholds:
    if not isinstance(value, SelectionThresholds):
        raise refusal(name, "a SelectionThresholds", value)
    return value


#: The rule of each field of :class:`IdentificationOptions` (see its attributes).
_RULES: dict[str, Rule] = {
    "band_hz": optional(partial(pair, at_least=0.0, unit="Hz")),
    # the lower bound depends on the method: IdentificationOptions.__post_init__
    "max_order": optional(partial(integer, at_most=MAX_ORDER)),
    "method": partial(choice, names=METHOD_NAMES),
    "expect_hz": _frequencies,
    "exp_window_tau_s": optional(seconds),
    "weighting": partial(choice, names=WEIGHTING_NAMES),
    "tol_freq": optional(partial(number, above=0.0, at_most=1.0)),
    "tol_zeta": optional(partial(number, above=0.0, at_most=10.0)),
    "tol_mac": optional(partial(number, above=0.0, at_most=1.0)),
    "min_fraction": partial(number, above=0.0, at_most=1.0),
    "refine": flag,
    "accept": flag,
    "lower_residual": flag,
    "upper_residual": flag,
    "window_searches": flag,
    "thresholds": _thresholds,
    "memory_limit_gb": partial(number, above=0.0, noun="number of GiB"),
}


def check_option(name: str, value: Any) -> Any:
    """``value`` checked and normalised for the field ``name`` of
    :class:`IdentificationOptions` (sequences become tuples of floats); an
    impossible value raises :class:`~ema_pipeline.data.OptionError` naming the
    field. The rule of ``max_order`` that depends on the method
    (:data:`MIN_ORDER`) is checked by the options as a whole.

    Examples
    --------
    >>> check_option("band_hz", [5, 395])
    (5.0, 395.0)
    >>> check_option("min_fraction", 5)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.OptionError: min_fraction must be a number in (0, 1], got 5
    """
    rule = _RULES.get(name)
    if rule is None:
        raise OptionError(name, f"is not an option (known: {', '.join(_RULES)})")
    return rule(name, value)


@dataclass(frozen=True)
class IdentificationOptions:
    """Options of :func:`ema_pipeline.identification.identify` (``None`` = the method's default).

    Every field is checked when the options are made: an impossible value
    raises :class:`~ema_pipeline.data.OptionError` (a ``ValueError``) naming
    the field. The rules are given with each field below.

    Attributes
    ----------
    band_hz : (lo, hi) band in Hz, finite, 0 <= lo < hi; default: from the 6th
        line (skipping 0 Hz and the first lines) to the last line.
    max_order : highest pLSCF denominator order p (p * n_in poles), fixed, an
        integer from :data:`MIN_ORDER` of the method (12 for ``"plscf"``, 10
        for ``"sdypy-lscf"``) to :data:`MAX_ORDER`; default adaptive: from
        :func:`ema_pipeline.identification.default_max_order`
        doubled while the diagram gains modes, up to
        :func:`ema_pipeline.identification.diagram.resources.order_cap`. For
        ``"sdypy-lscf"`` sdypy-EMA's ``pol_order_high`` (default 100).
    method : a name in :data:`ema_pipeline.identification.METHODS`:
        ``"plscf"`` (this package) or ``"sdypy-lscf"`` (sdypy-EMA).
    expect_hz : approximate natural frequencies in Hz (finite, > 0); the nearest stable pole
        cluster is taken for each (one mode per entry) instead of the automatic
        choice. Empty: automatic selection.
    exp_window_tau_s : time constant (s, finite, > 0) of the exponential window, overriding
        the one stored with the FRFs (foreign UFF files lack it); ``None`` keeps
        the FRF set's.
    weighting : the weights of the pLSCF equations of the stabilization
        diagrams (the band's, its lowest part's and the dense band's windows):
        "none" (each output scaled by its RMS in the band) or "coherence"
        (additionally every line weighted by the square root of the mean
        coherence). The pole refinement and the LSFD weight the lines by their
        own noise model (:mod:`~ema_pipeline.identification.refinement.uncertainty`),
        whatever this says.
    tol_freq, tol_zeta, tol_mac : stabilization tolerances (relative frequency,
        relative damping, 1 - MAC of participation vectors; in (0, 1], (0, 10]
        and (0, 1]). Each sets two numbers at once: ``tol_freq`` replaces
        ``thresholds.link_tol_freq`` and ``thresholds.diagram_tol_freq``,
        ``tol_zeta`` ``link_tol_zeta`` and ``diagram_tol_zeta``, ``tol_mac``
        ``link_tol_mac`` and ``diagram_tol_mac``: the pole linking of the
        selection
        (:func:`~ema_pipeline.identification.selection.trajectories.track_poles`: looser
        tolerances join more poles into a trajectory; :meth:`link_tolerances`)
        and the stabilization diagram's flags (:meth:`diagram_tolerances`).
        ``None`` (default): each uses its tuned default,
        ``thresholds.link_tol_*`` (1 %, 30 %, 0.05) and
        ``thresholds.diagram_tol_*`` (1 %, 5 %, 0.02). To change one of the
        two alone, change that field of ``thresholds`` and leave these unset.
    min_fraction : (0, 1]; a pole trajectory must hold poles of at least this fraction
        of the computed orders (and at least 6) to count as a physical mode;
        where in the diagram it starts does not matter (a mode that
        stabilises late is kept once it holds them).
    refine : report refined poles: each kept pole refined by
        variable-projection nonlinear least squares
        (:func:`ema_pipeline.identification.refinement.refine.refine_poles`), which also
        gives its covariance (the standard deviations). ``False`` reports the
        start poles instead (the trajectories' medians; the poles found outside
        the diagrams as found), with the trajectories' scatter as their
        uncertainty (NaN for a pole found outside the diagrams). It changes the
        reported poles only: which modes are kept is ``accept``'s, and the
        final tests judge refined poles either way (with ``accept``, the
        candidates are refined to be judged).
    accept : run the final tests over all FRFs: the acceptance tests of every
        candidate (decay rate determined, a resonance of the data, not the
        same mode twice: :mod:`~ema_pipeline.identification.selection.acceptance`), the
        close partners, the residual search, the narrower searches'
        alternates and the list of resonances not kept. ``False`` keeps every
        candidate the diagrams select, untested (many more than the modes),
        with an empty not-kept list; for a look at the raw selection, not
        for results.
        Expected modes (``expect_hz``) and picked ones are never tested; with
        ``expect_hz`` the switch reaches the automatic selection they are
        answered from.
    lower_residual, upper_residual : residual terms in LSFD.
    window_searches : search a dense band again in windows of consecutive
        candidates (:func:`~ema_pipeline.identification.diagram.order_search.add_window_modes`:
        a weak mode between strong ones forms a trajectory there, and a
        window's candidate stands in for a full-band pole that fails the
        final tests); ``False`` skips them: faster on a band of many
        modes, at the risk of missing such modes (what it costs and saves on
        the measured beam and the hard cases: :doc:`/validation`). The
        doubtful rule ``found_only_in_some_bands`` then rests on the
        low-band search alone.
    thresholds : the tuned thresholds of the selection and the final tests
        (:class:`~ema_pipeline.identification.thresholds.SelectionThresholds`);
        for studies of the method, not for everyday use.
    memory_limit_gb : the largest estimated memory (GiB, > 0) of the
        identification: settings that need more are refused before anything
        is computed
        (:func:`~ema_pipeline.identification.diagram.resources.check_identification`);
        default :data:`DEFAULT_MEMORY_LIMIT_GB`. It changes no result.

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
    accept: bool = True
    lower_residual: bool = True
    upper_residual: bool = True
    window_searches: bool = True
    thresholds: SelectionThresholds = field(default_factory=SelectionThresholds)
    memory_limit_gb: float = DEFAULT_MEMORY_LIMIT_GB

    def __post_init__(self) -> None:
        # every field checked, sequences normalised (options compare and hash by value)
        for f in fields(self):
            object.__setattr__(self, f.name, check_option(f.name, getattr(self, f.name)))
        low = MIN_ORDER[self.method]
        if self.max_order is not None and self.max_order < low:
            raise OptionError("max_order", f"must be at least {low} for method "
                                           f"{self.method!r} (a stabilization diagram needs "
                                           f"six model orders), got {self.max_order}")

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
