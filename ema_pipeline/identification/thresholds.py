"""Every tuned threshold of the ``"plscf"`` identification, in one place.

:class:`SelectionThresholds` is one frozen record of the tuned numbers of
the identification: the diagram's tolerances and those that link poles into
trajectories, the tolerance of an expected frequency, the screens of the
adaptive order search and its order cap, the local band of the pole
refinement, the final tests of a refined pole, the residual check, the list
of resonances not kept and the rule that marks a mode ``doubtful``. Each
field says what it was chosen on (the measured beam of ``../shared/data`` and
the hard families of ``tests/hardcases.py``).

It is a field of :class:`~ema_pipeline.identification.IdentificationOptions`
(``options.thresholds``) and is passed down the chain from there as a
required keyword (no function inside the package has a default record of
its own), never imported as module constants: a study of one threshold is
``identify(frf, thresholds=replace(SelectionThresholds(), max_rel_decay_std=0.3))``.
The result keeps the record it was made with
(``result.settings.thresholds``). Every field is checked when the record is
made (:meth:`SelectionThresholds.__post_init__`: numbers, not NaN, not
negative; tolerances and widths above zero; the refinement's stop shift at
least 1; MAC and MPC levels and shares at most 1): an impossible value is an
:class:`~ema_pipeline.data.OptionError` naming the field (the rules of
:mod:`ema_pipeline.validation`, the only module of the package this one
imports).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import partial

from ema_pipeline.validation import integer, number, sequence

#: Fields that must be above zero (tolerances, widths and divisors; counts of at least one).
_ABOVE_ZERO = frozenset({
    "diagram_tol_freq", "diagram_tol_zeta", "diagram_tol_mac", "link_tol_freq",
    "link_tol_zeta", "link_tol_mac", "max_zeta", "fragment_tol_zeta", "expect_tol",
    "mature_fraction", "zoom_ratio", "local_half_width", "split_half_width", "split_max_iter",
    "peak_lines",
    "min_members", "expect_min_members", "young_min_members", "diagram_orders",
    "window_modes", "window_step", "window_min_lines", "local_min_lines", "min_frfs",
    "alternate_min_frfs", "alternate_peak_lines", "pair_significance_level", "pair_max_gap",
    "max_poles", "local_max_fraction", "local_cap_min_lines", "local_band_min_lines",
    "residual_contrast_widths",
})
#: Fields that are fractions, levels of the MAC or the MPC, or damping ratios: at most 1.
_AT_MOST_ONE = frozenset({
    "max_zeta", "mature_fraction", "min_frf_share", "weak_min_mpc", "partner_min_mpc",
    "duplicate_min_mac", "split_max_mpc", "split_mpc_gap", "split_max_gap", "min_mpc",
    "pair_significance_level", "pair_min_dip",
})
#: Fields that are multiples of a limit they extend: at least 1 (a local fit
#: stopped by ``refine_stop_shift`` must lie beyond ``refine_max_shift``).
_AT_LEAST_ONE = frozenset({"refine_stop_shift"})
#: The rule of each of the two fractions of ``band_edge``.
_BAND_EDGE = partial(number, at_least=0.0, below=0.5)


@dataclass(frozen=True)
class SelectionThresholds:
    """The tuned thresholds of the identification (defaults: the tuned values).

    Examples
    --------
    >>> from dataclasses import replace
    >>> th = SelectionThresholds()
    >>> th.max_rel_decay_std, th.link_tol_zeta, th.diagram_tol_zeta
    (0.2, 0.3, 0.05)
    >>> replace(th, max_rel_decay_std=0.3) == th
    False
    >>> str(th), str(replace(th, max_rel_decay_std=0.3))  # what reports show
    ('tuned defaults', 'max_rel_decay_std=0.3 (others tuned defaults)')
    """

    def __post_init__(self) -> None:
        """Refuse an impossible value (:class:`~ema_pipeline.data.OptionError`
        naming the field): every number real and not NaN, not negative (inf is
        allowed: no limit); integer fields integers; the fields of
        ``_ABOVE_ZERO`` above zero, of ``_AT_LEAST_ONE`` at least 1, of
        ``_AT_MOST_ONE`` at most 1;
        ``band_edge`` two fractions in [0, 0.5)."""
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "band_edge":
                value = sequence(f.name, value, item=_BAND_EDGE, min_len=2, max_len=2)
            else:
                above, at_least = ((0, None) if f.name in _ABOVE_ZERO
                                   else (None, 1) if f.name in _AT_LEAST_ONE else (None, 0))
                value = (integer(f.name, value, above=above, at_least=at_least)
                         if f.type == "int" else
                         number(f.name, value, above=above, at_least=at_least,
                                at_most=1.0 if f.name in _AT_MOST_ONE else None, finite=False))
            object.__setattr__(self, f.name, value)

    def __str__(self) -> str:
        """The fields that differ from the tuned defaults, or ``"tuned defaults"``."""
        default = SelectionThresholds()
        changed = [f"{f.name}={getattr(self, f.name)!r}" for f in fields(self)
                   if getattr(self, f.name) != getattr(default, f.name)]
        return f"{', '.join(changed)} (others tuned defaults)" if changed else "tuned defaults"

    # ------------------------------------------------ stabilization diagram
    #: Diagram flags (:func:`~ema_pipeline.identification.diagram.stabilization.stabilization`,
    #: drawn by ``report.matplotlib_plots.plot_stabilization``, not used by the
    #: selection): a pole is
    #: stable in frequency when it moved by less than this fraction against the
    #: nearest pole of the previous order (the textbook 1 %) ...
    diagram_tol_freq: float = 0.01
    #: ... in damping by less than this fraction (the textbook 5 %) ...
    diagram_tol_zeta: float = 0.05
    #: ... and in participation vector when 1 - MAC is below this (MAC > 0.98).
    diagram_tol_mac: float = 0.02

    # ------------------------------------------------ trajectories (selection)
    #: Pole linking of :func:`~ema_pipeline.identification.selection.trajectories.track_poles`:
    #: d = |df| / (tol_freq f) + |dzeta| / (tol_zeta max(zeta)) + (1 - MAC) / tol_mac < 1.
    #: 1 % in frequency keeps two close modes (hard cases ``close_*``, 0.5-2 %
    #: apart) in two trajectories ...
    link_tol_freq: float = 0.01
    #: ... 30 % in damping: the damping of a true mode drifts by 10-30 % between
    #: low orders, far more than its frequency ...
    link_tol_zeta: float = 0.3
    #: ... 0.05 in 1 - MAC of the participation vectors (several references).
    link_tol_mac: float = 0.05
    #: A trajectory stays open for poles of up to this many later computed orders
    #: (a mode that a diagram misses at one order stays one trajectory).
    link_max_gap: int = 2
    #: A pole with a damping ratio at or above this is not a physical mode of the
    #: structures this tool is for (the selection, the search's young
    #: trajectories and the residual check's start poles all use it).
    max_zeta: float = 0.2
    #: A trajectory is a candidate when it holds at least this many poles (and
    #: ``min_fraction`` of the orders; ``IdentificationOptions.min_fraction``) ...
    min_members: int = 6
    #: ... or this many when it answers an expected frequency (``expect_hz``).
    expect_min_members: int = 4
    #: Its pole must lie inside the band less these fractions of its width at the
    #: bottom and the top (poles at a band edge model the truncation).
    band_edge: tuple[float, float] = (0.005, 0.02)
    #: It has settled when, over its last half, f_n and zeta scatter by less than
    #: this fraction of the half-power half-width zeta f_n and of zeta.
    max_scatter: float = 0.15
    #: Two trajectories whose poles are within this fraction of a decay rate are
    #: one pole (a trajectory broken by a gap); close modes differ by more.
    coincident_rel: float = 0.2
    #: Fragments of a heavily damped mode (``selection.link_fragments``): pieces
    #: with a structural damping of at least this are joined ...
    fragment_min_zeta: float = 0.02
    #: ... when their damping differs by less than this fraction of the larger ...
    fragment_tol_zeta: float = 0.3
    #: ... and one starts within this many computed orders of the other's end.
    fragment_max_gap: int = 3
    #: An expected frequency (``expect_hz``) is answered by the candidate
    #: nearest to it within this relative distance
    #: (:func:`~ema_pipeline.identification.selection.trajectories.select_expected`),
    #: and a guess that no kept mode answers within it is reported not found
    #: (:func:`~ema_pipeline.identification.selection.expect.match_expected`: the
    #: warning and the empty row of the modes table; the sdypy-lscf backend
    #: keeps only the poles that answer a guess within it). One tolerance for
    #: both: a guess whose kept mode lies within it is never also "not found".
    expect_tol: float = 0.15

    # ------------------------------------------------ adaptive order search
    #: The cheap screen counts a pole as determined when its decay rate has a
    #: relative standard deviation below this: it models noise, not a mode, above.
    #: Physical modes of the simulated tests sit below 0.01, noise poles near 1.
    max_rel_sigma_std: float = 0.5
    #: A young trajectory asks for a higher order only when the screen determines
    #: its decay rate this well (stricter than ``max_rel_sigma_std``: the screen
    #: ignores line correlation and the noise model) ...
    young_max_rel_sigma_std: float = 0.1
    #: ... and when its own peak is at least this fraction of the local RMS of the
    #: data (noise-free data determine every pole; a mode must also show) ...
    young_min_peak_ratio: float = 0.3
    #: ... and it holds at least this many poles.
    young_min_members: int = 3
    #: A selected mode whose own peak is below this fraction of the local RMS of
    #: the data models background, not a resonance (dropped) ...
    min_peak_ratio: float = 0.05
    #: ... or below this one with 3 or more channels, where the shape test of
    #: :func:`~ema_pipeline.identification.selection.acceptance.resonant` (MPC) judges the
    #: weak candidates that remain.
    min_peak_ratio_shapes: float = 0.02
    #: In the adaptive search a trajectory counts (and is kept) only when it starts
    #: below this fraction of the diagram's highest order, unless that is the cap.
    mature_fraction: float = 0.75
    #: The order is doubled while the diagram has fewer than this many pole pairs
    #: per determined mode ...
    room_pairs_per_mode: int = 4
    #: ... plus this many to spare (noise and the modes outside the band take poles).
    room_spare_pairs: int = 16
    #: A diagram holds at most this many orders, evenly spaced (the companion
    #: eigenvalues, O(sum n^3), dominate the cost at high order).
    diagram_orders: int = 40
    #: The companion matrix of a pLSCF diagram has at most this many rows
    #: (poles): the order is held to max_poles / n_in
    #: (:func:`~ema_pipeline.identification.diagram.resources.order_cap`, which
    #: also bounds the adaptive search and the memory check).
    max_poles: int = 480
    #: A band whose top is more than this times its bottom is searched once more
    #: in its lowest 1/zoom_ratio (pLSCF's time step follows the band top, so
    #: the poles of low modes in a wide band crowd near z = 1 and are poorly
    #: resolved: impact tests of 2-900 Hz lose their modes below 50 Hz).
    zoom_ratio: float = 8.0
    #: A band where the full search selects at least this many candidates is
    #: searched again in windows of ``window_modes`` consecutive candidates, each
    #: shifted by ``window_step`` candidates (so that they overlap): one common
    #: denominator for 20-40 modes lets the strong ones take the poles, and weak
    #: modes between them (a few per cent of the local response) never form a
    #: trajectory. In a window of 10 modes they do.
    window_min_modes: int = 10
    window_modes: int = 10
    window_step: int = 4
    #: A zoom or window search needs at least this many lines.
    window_min_lines: int = 64
    #: An alternate (a narrower search's candidate whose cover failed the final
    #: tests) is tried only where at least this many FRFs show a peak of their
    #: own ... (the measured beam: the alternate at 602.9 Hz in the band 250-700
    #: Hz stands out in 18 of 30 FRFs, one at 989.8 Hz in none) ...
    alternate_min_frfs: int = 2
    #: ... within this many lines of its natural frequency
    #: (``narrower_searches.shown_by_the_frfs``; the same values as the listing
    #: of resonances not kept, ``min_frfs`` and ``peak_lines``, but a rule of
    #: its own).
    alternate_peak_lines: float = 1.5

    # ------------------------------------------------ local band, refinement
    #: Local band of one mode: +-local_half_width half-power bandwidths around
    #: it, widened to at least ``local_min_lines`` lines (the pole refinement and
    #: the local screens use the same one; the model-choice covariance repeats
    #: the refinement on half of it).
    local_half_width: float = 12.0
    local_min_lines: int = 40
    #: ... but at most this fraction of the mode's frequency on each side (a
    #: low mode's band stays clear of 0 Hz) ...
    local_max_fraction: float = 0.2
    #: ... where that cap still leaves more than this many lines (else the
    #: band of ``local_half_width`` and ``local_min_lines`` stands) ...
    local_cap_min_lines: int = 13
    #: ... and a local band of fewer than this many lines is not fitted (the
    #: mode has no local problem:
    #: :func:`~ema_pipeline.identification.refinement.local_band.local_problem`).
    local_band_min_lines: int = 12
    #: The split fit of a close partner uses +-this many half-power bandwidths ...
    split_half_width: float = 6.0
    #: ... and at most this many Levenberg-Marquardt iterations per weighting
    #: round. On noise the extra pole wanders and uses them all (a third of a
    #: simulated paper file's time when each split had two starts), but
    #: fewer lose modes: with 10 the split of a wide candidate in the low cluster of
    #: ``dense_log`` seed 803 no longer gives five of its modes
    #: (``test_low_cluster_of_a_wide_band_is_found``), with 6 a close pair of
    #: ``impact_close`` seed 100 is lost (docs/validation.md).
    split_max_iter: int = 20
    #: A refined pole that moves by more than this many decay rates (plus one
    #: line) keeps its start value (the refinement wandered off).
    refine_max_shift: float = 0.5
    #: A local fit whose pole, at a step of the first of its two weighting
    #: rounds, lies further from its start than this many times that reach
    #: (``refine_max_shift`` decay rates plus one line) stops there: it has
    #: wandered off, and it keeps its start pole as it would at the end
    #: (inf: every fit runs to its end). Of 763 local fits (the 12 paper
    #: files, the pyFRF recording, 16 family cases), the 13 that went beyond
    #: 3 times the reach in their first round (the residual peaks of the
    #: noise, mostly at their first or second step) all ended beyond the
    #: reach; those that came back within it had been within 1.09 of it.
    refine_stop_shift: float = 3.0

    # ------------------------------------------------ final tests (acceptance)
    #: Final test of a refined pole (``acceptance.resonant``): a mode whose own
    #: peak is below weak_peak_ratio of the local RMS of the data (it explains
    #: less of the response than the modes and background around it) is kept
    #: only when that peak exceeds the standard deviation of the local fit's
    #: residual by at least min_weak_peak_snr, or (with at least 3 channels) its
    #: shape in its own local fit is nearly real (MPC >= weak_min_mpc, a normal
    #: mode; one global LSFD bends a weak mode's shape, down to MPC 0.2 for real
    #: modes of the hard families, where the local fit gives 0.93-1.0 and the
    #: measured beam's other poles 0.89 at most). On synthetic data the residual
    #: is the noise and weak true modes stand far above it or have MPC ~ 1; on
    #: measured data the residual also holds model error, and poles that fit it
    #: have a small peak ratio, a modest SNR and a complex shape. Chosen on the
    #: measured beam (its published modes have peak ratios of 0.69 and more, the
    #: poles between them 0.63 and less) and on the hard families.
    weak_peak_ratio: float = 0.65
    min_weak_peak_snr: float = 150.0
    weak_min_mpc: float = 0.95
    #: ... or, whatever its shape (complex modes: localized damping, joints,
    #: dampers), when its peak SNR is at least complex_min_snr and its own term
    #: explains most of its local residual: the local problem's residual
    #: without it is at least complex_min_residual_drop times the residual
    #: with it (``acceptance.residual_drop``; noise alone gives about 1).
    #: Chosen on the measured beam in bands 5-400, 5-790, 100-400, 250-700 and
    #: without a band (its poles that are neither published modes nor
    #: resonances the FRFs show have a peak SNR of 41 at most, with a residual
    #: drop of 5.7 at most; 42.1 and 325.1 Hz, resonances the FRFs show, have
    #: SNR 58-72 and drops of 6-10 and now pass) and on ``complex_chain``
    #: (the strongly complex modes that failed the MPC test: SNR 77-135,
    #: drops 14-150; a spurious pole beside a mode of zeta 7 %: SNR 20).
    complex_min_snr: float = 50.0
    complex_min_residual_drop: float = 4.0
    #: A close mode hidden in a kept mode's resonance (``partners.close_partners``):
    #: one pole more in that mode's local fit must leave at most
    #: partner_max_residual_ratio of the residual variance, both poles must be
    #: determined, apart by more than half the sum of their decay rates, and
    #: both shapes nearly real (MPC >= partner_min_mpc, two normal modes) in
    #: one global LSFD or in their own local fits. On synthetic close pairs the
    #: missed partner leaves 0.002-0.64 of the residual and reaches MPC 0.9 in
    #: one of the two fits; on the measured beam a second pole also removes
    #: much of the residual beside most modes (model error: the roving channels
    #: do not agree exactly), but one of the two shapes is then complex (MPC
    #: 0.84 at most in the global LSFD, 0.75 in the local fits).
    partner_max_residual_ratio: float = 0.75
    partner_min_mpc: float = 0.9
    #: Shapes are judged (the MPC and residual-drop tests of a weak pole, the
    #: split of a resonance into two close modes) only with at least this many
    #: channels: with two, the residues of any extra pole fit both channels, so
    #: a shape tells nothing of realness and a split always fits better.
    min_shape_channels: int = 3
    #: With fewer channels (impact tests with one or two accelerometers, issue
    #: 42) a pole is a second mode beside a close partner only on evidence one
    #: channel can give: two poles fit the pair's local problem better than
    #: one beyond what the noise explains (``pairs.pair_significance``:
    #: an F test at this significance level), or its peak shows apart from the
    #: partner's (``pairs.peaks_apart``). Otherwise the weaker pole is
    #: dropped and the mode marked (``second_pole_not_significant``); the
    #: pairs of the diagrams are judged as if the noise were white (both
    #: poles passed the diagrams' and the final tests), a close partner of
    #: the split fit with the critical value raised by the exponential
    #: window's line correlation (sum |rho|^2, about 1/(tau df): what a free
    #: second pole takes up of windowed noise beside one mode, measured 5.6
    #: and 20 times the white noise's at tau = T/5 and T/16). True close pairs
    #: of the impact families give 2.3-1e5, the measured pyFRF recording's
    #: pairs 20-1e4 (model error, not noise: hence the mark below) ...
    pair_significance_level: float = 1e-3
    #: ... a close partner of the split fit is added with fewer channels
    #: (``partners.close_partners``) only where the F test is calibrated:
    #: the median significance of every kept mode's split fit (with or
    #: without a partner) below this. In the impact families the noise is
    #: all the split fits see (medians 0.2-1.0, a missed partner 2.7-1.2e4);
    #: on the measured pyFRF recording model error (leakage of its 0.64 s
    #: records) makes a second pole significant beside most modes (median
    #: 5.8, its would-be partners 6-166) ...
    partner_max_split_median: float = 1.0
    #: ... a valley between the two maxima of at most this fraction of the
    #: lower one (2 dB); two poles under one peak with fewer channels are
    #: marked ``pair_under_one_peak`` (kept, doubtful: one channel cannot tell
    #: them from one mode whose frequency varies, e.g. between hits; not
    #: where the data show two modes clearly, ``pair_clear_significance``) ...
    pair_min_dip: float = 0.8
    #: ... and two kept poles are a close pair when they lie within this many
    #: times the sum of their half-power half-widths of each other (the
    #: measured gaps: docs/validation.md, impact tests with one to three
    #: channels).
    pair_max_gap: float = 4.0
    #: A pair under one peak is not marked (``plscf_backend.with_pair_flags``)
    #: when the F test that adds close partners (``pair_significance``, the
    #: window's correction applied) is calibrated on the file
    #: (``pairs.f_test_calibrated``) and prefers the two poles by at
    #: least this: above what a second pole beside a lone mode gives, below
    #: what true pairs under one peak give (measured: docs/validation.md).
    #: A file whose F test is not calibrated keeps its pairs marked, as do
    #: the pairs of a mode whose frequency varies between hits.
    pair_clear_significance: float = 5.0
    #: The kept candidates are refined again without those that failed
    #: (``acceptance.refit_kept``) while some fail, at most this many times.
    refit_rounds: int = 3
    #: A refined pole is kept only when its decay rate has a relative standard
    #: deviation below this (5 sigma from zero; where true modes and the poles
    #: that are not modes lie: docs/validation.md). The decay rate itself, not
    #: the structure's share
    #: of it: a lightly damped low mode under a strong window (12.6 Hz, zeta
    #: 0.27 %, 1/tau 2.6 1/s) has its total decay determined to 2 % and the
    #: structure's only to 50 %.
    max_rel_decay_std: float = 0.2
    #: Two kept poles within each other's half-power bands with LSFD shapes of
    #: MAC above this are one mode found twice (one of them stays).
    duplicate_min_mac: float = 0.95
    #: Of two kept poles within each other's half-power bands, one with a markedly
    #: complex shape (MPC below split_max_mpc and split_mpc_gap below its
    #: partner's) is the split of the other -- one mode whose frequency differs a
    #: little between the channels (a roving-hammer test measures them one after
    #: the other) -- and is dropped. On the measured beam 363.9 and 415.1 Hz,
    #: beside 363.0 and 414.6 Hz, have MPC 0.67 and 0.39 against 0.83 and 0.88
    #: (the synthetic families, with real shapes, are unaffected).
    split_max_mpc: float = 0.7
    split_mpc_gap: float = 0.15
    #: ... and only when their damped frequencies are less than this fraction
    #: apart: a split is a shift between channels, the beam's are 0.13-0.29 %
    #: at the defaults and 1.1 % (69.04 and 69.81 Hz) in 5-790 Hz. Physical
    #: modes of a chain with strong discrete dashpots (``complex_dashpots`` of
    #: the hard cases: modes 3 % or more apart, half-power bands overlapping)
    #: that the rule dropped without this were 3.0-11.4 % from the neighbour
    #: kept, MPC 0.06-0.62 (docs/validation.md).
    split_max_gap: float = 0.02

    # ------------------------------------------------ residual check
    #: A residual peak is a candidate when its squared residual (mean over the
    #: channels of each channel's |e|^2 over its median, over 3 lines) exceeds
    #: this. White noise gives 1/ln 2 = 1.44 on average and 3-7 at the highest
    #: peaks of a few thousand lines; missed modes of the hard cases 10-60.
    residual_peak_ratio: float = 8.0
    #: ... and at least this many times the median of its surroundings (the
    #: lines 1 to ``residual_contrast_widths`` peak widths plus
    #: ``residual_contrast_lines`` lines away): missed modes of the hard cases
    #: stand 5-30 times above theirs, the spikes of a noisy stretch (the top of
    #: the paper's simulated axis, at the anti-alias filter) 1.3-1.8 times.
    residual_peak_contrast: float = 3.0
    residual_contrast_widths: int = 4
    residual_contrast_lines: int = 20
    #: At most this many residual peaks (the highest) are tried per band.
    max_residual_peaks: int = 6
    #: Where the residual of the kept modes' fit rises into an edge zone of the
    #: band (``band_edge``) and the FRFs go on past it, the band is widened there
    #: by this fraction of its width to find the resonance at the edge, which is
    #: kept in its neighbours' fits and not reported
    #: (:mod:`~ema_pipeline.identification.selection.edge_poles`).
    edge_margin: float = 0.05
    #: ... again while the residual of the kept and edge poles' fit rises into
    #: the widened end (a resonance past it), at most this many widenings.
    edge_steps: int = 2

    # ------------------------------------------------ resonances not kept
    #: A peak of |H| stands out when its prominence in log|H| exceeds this: a
    #: factor e^0.5 = 1.65 over the valleys beside it. On the measured beam the
    #: rejected candidates that are not resonances have such a peak in at most 3
    #: of the 30 FRFs, the three resonances (42.0, 274.7, 325.1 Hz) in 9-16.
    min_log_prominence: float = 0.5
    #: A rejected candidate is listed when it stands out in at least this share of
    #: the FRFs, and in at least ``min_frfs`` of them, ...
    min_frf_share: float = 0.2
    min_frfs: int = 2
    #: ... with a peak within this many lines of its natural frequency. With the
    #: candidate's half-power band as the window instead, the random peaks of
    #: FRFs that are mostly noise counted for broad poles of the noise (hard cases
    #: baseline-9 at 176 Hz and close_1ref-9 at 1269 and 1302 Hz, 2 of 3 and 2 of
    #: 6 FRFs).
    peak_lines: float = 1.5

    # ------------------------------------------------ doubtful modes (result)
    #: A mode is marked ``doubtful`` (kept, never dropped) when its pole is stable
    #: at fewer model orders than this (``few_stable_orders``) ...
    min_stable_orders: int = 5
    #: ... or its damping is poorly determined, zeta_std above this fraction of
    #: zeta (``loose_damping``) ...
    max_rel_zeta_std: float = 0.5
    #: ... or its shape is strongly complex, MPC below this with 3 or more
    #: responses (``complex_shape``) ...
    min_mpc: float = 0.5
    #: ... or its half-power bandwidth 2 zeta f_n is below this fraction of the
    #: line spacing: the lines do not resolve its damping (``unresolved_damping``) ...
    min_bandwidth_lines: float = 0.5
    #: ... or at least this many of the narrower searches of the band (its lowest
    #: part, the windows of a dense band) hold it and none of them has a
    #: candidate that covers it (``found_only_in_some_bands``: the band's own
    #: diagram, a close-partner or residual search found it, no narrower band
    #: did). Two searches that miss a true mode are common: a close partner
    #: hidden in its neighbour's resonance or a weak mode of a dense band,
    #: held by two searches and found by neither; 3 marks no true mode of the
    #: hard families (docs/validation.md) ...
    min_band_searches: int = 3
    #: ... a search holds a mode when the mode lies inside its band by this
    #: fraction of its frequency ...
    band_support_margin: float = 0.03
    #: ... or the final tests found it twice (two candidates within each
    #: other's half-power bands, one mode: ``acceptance.distinct_shapes``) and
    #: the other candidate's refined frequency lies more than this many of the
    #: mode's f standard deviations from its own (``found_twice_apart``): the
    #: reported value depends on which start the tests kept, by more than its
    #: sigma says. Only the measured beam has such modes (twins 9-45 sigma
    #: apart; on the hard families of seeds 100-101 and 200-201 no candidate
    #: is dropped as a twin), where a change of the FRFs in their last bits
    #: can keep the other twin: 155.50 -> 155.48 Hz in 100-400 Hz
    #: (docs/validation.md).
    twin_max_sigma: float = 1.0

