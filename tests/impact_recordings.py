"""Synthetic impact-test recordings with known truth, written WITHOUT the package's code.

Only numpy, scipy, pandas, pyuff and npTDMS are used here, so that tests of the
package's readers, hit detection, hit checks and FRF estimation compare against an
independent truth.

Two generators: :func:`make_recording` (the random structures below) and the
roving-hammer tests of a simply supported plate (:class:`Plate`,
:class:`PlateTest`, :func:`write_plate_test`: one recording per hammer point in
CSV, WAV or TDMS and their channel sheet), shared by tests/test_channel_sheet.py,
tests/test_plate_holdout.py and tests/test_hit_choice_browser.py.

The model
---------
A structure with 3-5 modes inside the analysed band ``band_hz`` and 1-2 modes above
it (viscous, proportional damping) is hit 5-8 times at its driving point. The
receptance from the force to response channel c is

    H_c(s) = sum_r  A_cr / (s - lambda_r) + conj(A_cr) / (s - conj(lambda_r)),
    lambda_r = -zeta_r omega_r + j omega_r sqrt(1 - zeta_r^2),
    A_cr = phi_c,r phi_d,r / (2 j m_r omega_d,r),

and the recorded responses are accelerations, accelerance ``s^2 H_c(s)``
(:meth:`SyntheticRecording.true_frf`). Channel 0 of ``response`` is the driving
point, channel 1 (when present) another DOF.

Each hit is a half-sine force pulse ``P sin(pi (t - t_i) / T)`` on ``[t_i, t_i + T]``
(``t_i`` anywhere between samples, ``T`` 0.5-2 ms but at least 4 samples), sampled
exactly. The response samples are the exact output of the sampled force through
the system band-limited to the Nyquist frequency (an ideal anti-alias filter, as
in a DAQ with a brick-wall FIR): on the DFT grid ``X(f) = H(f) F(f)`` holds exactly
for ``|f| < fs/2``, computed by FFT on a zero-padded grid long enough for every
mode to decay below 1e-4 before it wraps. So H1 from noise-free records equals
``true_frf`` up to leakage/windowing only, no aliasing error.

Defects per hit: ``double_hit`` (a second half-sine 3-30 ms after the first, at
20-70 % of its peak) and ``overload`` (one channel, the same for the whole
recording, saturates at its full scale; the overloaded hit is hit harder so that
the channel is clipped at 55-70 % of the peak it would have had: flat tops).
Normal hits stay below 1/1.05 of every full scale.

Hit gaps are random but at least ``max(1.3 record_s, 7 / sigma_min)`` (``sigma_min``
the slowest modal decay rate, so that a hit's ringing has decayed to < 0.1 % at the
next hit, e^-7), so a record of ``record_s`` (1 s, or the largest power of two of samples
not above it) plus a pretrigger fits between hits. The last hit is sometimes
(``last_hit_short``) less than ``record_s`` from the end, so its record must be
dropped; it never carries a defect.

Noise: white Gaussian, std ``noise_rel`` times the typical peak of each channel.
Generation takes a few ms.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.fft

STANDARD_GRAVITY = 9.80665

DEFECTS = ("double_hit", "overload")


@dataclass
class SyntheticRecording:
    """A continuous impact recording and its truth (see the module docstring)."""

    sample_rate_hz: float
    force_n: np.ndarray  # (n_samples,)
    response: np.ndarray  # (n_resp, n_samples) m/s^2
    hit_times_s: np.ndarray  # true start of each hit's (first) force pulse
    defects: list[frozenset[str]]  # per hit, subset of DEFECTS
    fn_hz: np.ndarray  # true modes inside band_hz
    zeta: np.ndarray
    band_hz: tuple[float, float]
    full_scale: np.ndarray  # (1 + n_resp,) input range [force N, resp m/s^2...]
    residues: np.ndarray  # (n_resp, n_modes_all) complex receptance residues A_cr (m/N/s)
    poles: np.ndarray  # (n_modes_all,) complex lambda_r (rad/s), upper half plane
    fn_all_hz: np.ndarray  # every mode, in band and above
    zeta_all: np.ndarray
    force_peak_n: np.ndarray  # per hit, P of the first pulse
    pulse_width_s: np.ndarray  # per hit, T
    bounce_delay_s: np.ndarray  # per hit, delay of the second pulse (NaN: none)
    bounce_ratio: np.ndarray  # per hit, its peak / P (NaN: none)
    clip_fraction: np.ndarray  # per hit, full scale / unclipped peak of the channel (NaN)
    overload_channel: int  # 0 force, 1.. response channel (c + 1); -1 none
    clipped_samples: np.ndarray  # per hit, samples of the overloaded channel at full scale
    noise_std: np.ndarray  # (1 + n_resp,) noise std per channel (SI)
    record_s: float  # record length the gaps leave room for (power of two of samples)
    last_hit_short: bool  # the last hit is less than record_s from the end
    force_dof: tuple[int, int] = (1, 3)  # (node, direction)
    response_dofs: tuple[tuple[int, int], ...] = field(default_factory=tuple)

    @property
    def n_samples(self) -> int:
        return self.force_n.size

    @property
    def n_resp(self) -> int:
        return self.response.shape[0]

    @property
    def time_s(self) -> np.ndarray:
        return np.arange(self.n_samples) / self.sample_rate_hz

    @property
    def signals(self) -> np.ndarray:
        """(1 + n_resp, n_samples): force first, then the responses."""
        return np.vstack([self.force_n[None, :], self.response])

    @property
    def channel_names(self) -> list[str]:
        return ["Hammer force"] + [f"Acc {n}{_AXES[d]}" for n, d in self.response_dofs]

    def true_frf(self, freq_hz: np.ndarray) -> np.ndarray:
        """(n_resp, n_freq) accelerance s^2 H(s) at s = 2 pi j f, in m/s^2/N."""
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
        return _accelerance(self.residues, self.poles, s)


_AXES = {1: "+X", 2: "+Y", 3: "+Z", -1: "-X", -2: "-Y", -3: "-Z"}


def _accelerance(residues: np.ndarray, poles: np.ndarray, s: np.ndarray) -> np.ndarray:
    s = np.asarray(s)[None, None, :]
    a = residues[:, :, None]
    lam = poles[None, :, None]
    h = (a / (s - lam) + np.conj(a) / (s - np.conj(lam))).sum(axis=1)
    return s[0] ** 2 * h


def _stratified(rng: np.random.Generator, lo: float, hi: float, n: int) -> np.ndarray:
    """n values in [lo, hi], one per log-spaced bin, adjacent ratios >= bin ratio^0.4."""
    edges = np.geomspace(lo, hi, n + 1)
    return edges[:-1] * (edges[1:] / edges[:-1]) ** rng.uniform(0.2, 0.8, n)


def _half_sines(n: int, fs: float, starts: np.ndarray, widths: np.ndarray,
                peaks: np.ndarray) -> np.ndarray:
    """Sum of sampled half-sine pulses (exact samples of the continuous pulse)."""
    out = np.zeros(n)
    for t0, width, peak in zip(starts, widths, peaks, strict=True):
        k = np.arange(int(np.ceil(t0 * fs)), int(np.floor((t0 + width) * fs)) + 1)
        k = k[(k >= 0) & (k < n)]
        out[k] += peak * np.sin(np.pi * (k / fs - t0) / width)
    return out


def make_recording(
    seed: int,
    *,
    n_hits: int | None = None,
    n_double: int = 0,
    n_overload: int = 0,
    sample_rate_hz: float = 2048.0,
    n_resp: int | None = None,
    n_modes: int | None = None,
    noise_rel: float = 5e-4,
    record_s: float = 1.0,
    last_hit_short: bool | None = None,
    overload_channel: int | None = None,
    force_range_n: tuple[float, float] | None = None,
    odd_pulse: tuple[int, float] | None = None,
) -> SyntheticRecording:
    """A random continuous impact recording with known truth.

    Parameters
    ----------
    seed : random seed (everything random derives from it).
    n_hits : number of hits (default random 5-8).
    n_double, n_overload : how many hits get a double hit / an overload (distinct
        hits, never the last one when it is short).
    sample_rate_hz : sampling rate.
    n_resp : response channels, 1 or 2 (default random).
    n_modes : modes inside the band, 3-5 (default random); 1-2 more lie above it.
    noise_rel : noise std relative to each channel's typical peak.
    record_s : record length the gaps must leave room for; the largest power of
        two of samples not above it is used.
    last_hit_short : the last hit is closer than ``record_s`` to the end (default
        random, probability 1/2).
    overload_channel : 0 force, c + 1 response c (default random).
    force_range_n : (lo, hi): the peaks of the hits spread over [lo, hi] (one hit
        without defect within 5 % of each end, the others uniform in between)
        instead of ``P`` x U(0.8, 1.2), and the
        pulse widths follow them as a Hertzian contact's do, ``T`` x (peak /
        median peak)^-0.2 x U(0.9, 1.1) (a soft hit lasts longer). Drawn from a
        second generator, so the other draws stay those of ``seed``.
    odd_pulse : (hit, factor): that hit's (0-based) pulse lasts ``factor`` times
        as long as it would (a hit with another tip, or on a bolt head).
    """
    rng = np.random.default_rng(seed)
    fs = float(sample_rate_hz)
    n_hits = int(rng.integers(5, 9)) if n_hits is None else int(n_hits)
    n_resp = int(rng.integers(1, 3)) if n_resp is None else int(n_resp)
    n_in = int(rng.integers(3, 6)) if n_modes is None else int(n_modes)
    n_above = int(rng.integers(1, 3))
    short = bool(rng.random() < 0.5) if last_hit_short is None else bool(last_hit_short)
    rec_n = 2 ** int(np.floor(np.log2(record_s * fs)))
    rec_s = rec_n / fs

    # pulse widths: 0.5-2 ms, at least 4 samples; band ends where the force is ~ -4 dB
    t_lo, t_hi = max(0.5e-3, 4 / fs), max(2e-3, 4 / fs)
    t_nom = rng.uniform(t_lo, t_hi)
    widths = t_nom * rng.uniform(0.92, 1.08, n_hits)
    band_hi = float(np.floor(min(0.6 / (1.08 * t_nom), 0.3 * fs)))

    fn_in = _stratified(rng, 0.15 * band_hi, 0.85 * band_hi, n_in)
    fn_above = _stratified(rng, 1.25 * band_hi, min(2.0 * band_hi, 0.45 * fs), n_above)
    zeta_lo = np.minimum(np.maximum(0.004, 3.0 / (2 * np.pi * fn_in)), 0.012)
    zeta_in = rng.uniform(zeta_lo, 0.02)
    zeta_above = rng.uniform(0.01, 0.03, n_above)
    fn_all = np.concatenate([fn_in, fn_above])
    zeta_all = np.concatenate([zeta_in, zeta_above])
    band = (float(np.floor(0.6 * fn_in[0])), band_hi)

    wn = 2 * np.pi * fn_all
    wd = wn * np.sqrt(1 - zeta_all**2)
    poles = -zeta_all * wn + 1j * wd
    n_all = fn_all.size
    phi_drive = rng.uniform(0.5, 1.0, n_all) * rng.choice([-1.0, 1.0], n_all)
    phis = [phi_drive]
    for _ in range(1, n_resp):
        phis.append(rng.uniform(0.3, 1.0, n_all) * rng.choice([-1.0, 1.0], n_all))
    modal_mass = rng.uniform(0.5, 3.0, n_all)
    residues = np.array([p * phi_drive / (2j * modal_mass * wd) for p in phis])
    sigma_min = float(np.min(zeta_all * wn))

    # hit times: random gaps with room for a record, decayed ringing at the next hit
    gap_min = max(1.3 * rec_s, 7.0 / sigma_min)
    starts = np.empty(n_hits)
    starts[0] = rng.uniform(0.3, 0.6) * rec_s
    for i in range(1, n_hits):
        starts[i] = starts[i - 1] + gap_min + rng.uniform(0.0, 0.8) * rec_s
    tail_s = rng.uniform(0.3, 0.8) * rec_s if short else rng.uniform(1.25, 1.6) * rec_s
    n = int(np.ceil((starts[-1] + tail_s) * fs))

    # defects on distinct hits (never a short last hit)
    eligible = np.arange(n_hits - 1 if short else n_hits)
    if n_double + n_overload > eligible.size:
        raise ValueError(f"{n_double} double hits + {n_overload} overloads > "
                         f"{eligible.size} eligible hits")
    chosen = rng.permutation(eligible)
    double_hits = set(chosen[:n_double].tolist())
    overload_hits = set(chosen[n_double:n_double + n_overload].tolist())
    scatter = None
    if force_range_n is not None:  # both ends of the range on hits without defect
        extra = np.random.default_rng([seed, 40160])
        lo, hi = force_range_n
        good = [i for i in eligible if i not in double_hits | overload_hits]
        ends = extra.choice(good, 2, replace=False)
        order = np.concatenate([ends, extra.permutation(np.setdiff1d(np.arange(n_hits), ends))])
        scatter = np.empty(n_hits)
        scatter[order] = np.concatenate([[lo * extra.uniform(1.0, 1.05),
                                          hi * extra.uniform(0.95, 1.0)],
                                         extra.uniform(lo, hi, n_hits - 2)])
        widths = (t_nom * (scatter / np.median(scatter)) ** -0.2
                  * extra.uniform(0.9, 1.1, n_hits))
    if odd_pulse is not None:
        widths[odd_pulse[0]] *= odd_pulse[1]
    delays = np.full(n_hits, np.nan)
    ratios = np.full(n_hits, np.nan)
    for i in double_hits:
        delays[i] = rng.uniform(max(3e-3, widths[i] + 2 / fs), 30e-3)
        ratios[i] = rng.uniform(0.2, 0.7)

    # unit-peak force of every hit (with its bounce) and its exact band-limited response
    unit_force = np.zeros((n_hits, n))
    for i in range(n_hits):
        unit_force[i] = _half_sines(n, fs, [starts[i]], [widths[i]], [1.0])
        if i in double_hits:
            unit_force[i] += _half_sines(n, fs, [starts[i] + delays[i]], [widths[i]], [ratios[i]])
    n_fft = scipy.fft.next_fast_len(n + int(np.ceil(10.0 / sigma_min * fs)), real=True)
    freq = np.fft.rfftfreq(n_fft, 1 / fs)
    h = _accelerance(residues, poles, 2j * np.pi * freq)  # (n_resp, n_f)
    spec = scipy.fft.rfft(unit_force, n_fft, axis=1)  # (n_hits, n_f)
    unit_resp = scipy.fft.irfft(spec[:, None, :] * h[None], n_fft, axis=2)[:, :, :n]
    unit = np.concatenate([unit_force[:, None, :], unit_resp], axis=1)  # (hits, ch, n)

    # per-hit peak of each channel per newton, within the hit's own span
    ends = np.append(starts[1:], n / fs)
    unit_peak = np.empty((n_hits, 1 + n_resp))
    for i in range(n_hits):
        k0, k1 = int(starts[i] * fs), int(ends[i] * fs)
        unit_peak[i] = np.abs(unit[i, :, k0:k1]).max(axis=1)

    p_nom = rng.uniform(50.0, 300.0)
    peaks = p_nom * rng.uniform(0.8, 1.2, n_hits)
    if scatter is not None:
        peaks = scatter.copy()
    ch_ov = -1
    clip = np.full(n_hits, np.nan)
    full_scale_ov = np.nan
    if overload_hits:
        ch_ov = int(rng.integers(0, 1 + n_resp)) if overload_channel is None \
            else int(overload_channel)
        normal = [i for i in range(n_hits) if i not in overload_hits]
        full_scale_ov = max(peaks[i] * unit_peak[i, ch_ov] for i in normal) * rng.uniform(1.05,
                                                                                         1.15)
        for i in overload_hits:
            clip[i] = rng.uniform(0.55, 0.70)
            peaks[i] = full_scale_ov / (clip[i] * unit_peak[i, ch_ov])
    clean = np.einsum("h,hcn->cn", peaks, unit)
    typical = np.median(peaks[:, None] * unit_peak, axis=0)
    noise_std = noise_rel * typical
    signals = clean + noise_std[:, None] * rng.standard_normal(clean.shape)
    full_scale = 1.25 * np.abs(signals).max(axis=1)
    clipped = np.zeros(n_hits, dtype=int)
    if overload_hits:
        full_scale[ch_ov] = full_scale_ov
        signals[ch_ov] = np.clip(signals[ch_ov], -full_scale_ov, full_scale_ov)
        at_fs = np.abs(signals[ch_ov]) >= full_scale_ov
        for i in range(n_hits):
            clipped[i] = int(at_fs[int(starts[i] * fs):int(ends[i] * fs)].sum())
        for i in overload_hits:  # the clip fraction actually reached (noise, tails)
            k0, k1 = int(starts[i] * fs), int(ends[i] * fs)
            clip[i] = full_scale_ov / np.abs(clean[ch_ov, k0:k1]).max()

    defects = [frozenset(({"double_hit"} if i in double_hits else set())
                         | ({"overload"} if i in overload_hits else set()))
               for i in range(n_hits)]
    resp_dofs = ((1, 3),) + tuple((2 + c, 3) for c in range(n_resp - 1))
    return SyntheticRecording(
        sample_rate_hz=fs,
        force_n=signals[0],
        response=signals[1:],
        hit_times_s=starts,
        defects=defects,
        fn_hz=fn_in,
        zeta=zeta_in,
        band_hz=band,
        full_scale=full_scale,
        residues=residues,
        poles=poles,
        fn_all_hz=fn_all,
        zeta_all=zeta_all,
        force_peak_n=peaks,
        pulse_width_s=widths,
        bounce_delay_s=delays,
        bounce_ratio=ratios,
        clip_fraction=clip,
        overload_channel=ch_ov,
        clipped_samples=clipped,
        noise_std=noise_std,
        record_s=rec_s,
        last_hit_short=short,
        force_dof=(1, 3),
        response_dofs=resp_dofs,
    )


# ----------------------------------------------------------------------------- writers

_ACCEL_UNITS = {"m/s^2": 1.0, "g": STANDARD_GRAVITY, "mm/s^2": 1e-3}
_FORCE_UNITS = {"N": 1.0, "kN": 1e3, "lbf": 4.4482216152605}


def clean_hits(rec: SyntheticRecording) -> list[int]:
    """0-based hits of ``rec`` without defect that have a record."""
    last = len(rec.defects) - 1
    return [i for i, d in enumerate(rec.defects) if not d
            and not (rec.last_hit_short and i == last)]


def corrupt_hit(rec: SyntheticRecording, k: int, case: str) -> None:
    """Corrupt hit ``k`` of ``rec`` in place: ``gain`` (its responses 2.5 times
    as large: another point or sensor gain), ``shifted`` (its responses
    stretched in time by 1.05: every mode 5 % higher, another structure
    state), ``dropout`` (its responses zero 30-130 ms after the hit: a loose
    cable) or ``glitch`` (a 3-sample spike 0.3 s after the hit). A pulse of
    another tip is a recording of its own (``make_recording(odd_pulse=)``)."""
    fs = rec.sample_rate_hz
    t0 = int(rec.hit_times_s[k] * fs) - int(0.01 * fs)
    t1 = (int(rec.hit_times_s[k + 1] * fs) - int(0.01 * fs) if k + 1 < len(rec.defects)
          else rec.n_samples)
    span = rec.response[:, t0:t1].copy()
    hit = int(rec.hit_times_s[k] * fs)
    if case == "gain":
        rec.response[:, t0:t1] = 2.5 * span
    elif case == "shifted":
        t = np.arange(t1 - t0)
        rec.response[:, t0:t1] = [np.interp(1.05 * t, t, y) for y in span]
    elif case == "dropout":
        j = hit + int(0.03 * fs)
        rec.response[:, j:j + int(0.1 * fs)] = 0.0
    elif case == "glitch":
        j = hit + int(0.3 * fs)
        rec.response[:, j:j + 3] += 0.5 * np.abs(span).max(axis=1)[:, None]
    elif case != "wide":
        raise ValueError(f"unknown corruption {case!r}")


def _segments(rec: SyntheticRecording, precut_s: float | None,
              pretrigger_s: float) -> list[tuple[int, int]]:
    """(first, stop) samples of each record to write: the whole recording, or one
    record of ``precut_s`` per hit starting ``pretrigger_s`` before it (hits whose
    record runs past the end are left out)."""
    if precut_s is None:
        return [(0, rec.n_samples)]
    fs = rec.sample_rate_hz
    length = int(round(precut_s * fs))
    out = []
    for t in rec.hit_times_s:
        k0 = int(np.floor((t - pretrigger_s) * fs))
        if k0 >= 0 and k0 + length <= rec.n_samples:
            out.append((k0, k0 + length))
    return out


def write_uff(
    rec: SyntheticRecording,
    path: str | Path,
    *,
    binary: bool = False,
    precut_s: float | None = None,
    pretrigger_s: float = 0.01,
    accel_unit: str = "m/s^2",
    force_unit: str = "N",
) -> Path:
    """Write ``rec`` as UFF-58 time records (function type 1) with pyuff.

    One record per channel (continuous), or with ``precut_s`` one record per
    channel and hit (load case = hit number, 1-based). The force record has
    ordinate data type 13 and label ``force_unit``, the accelerations data type 12
    and label ``accel_unit`` (data converted to those units); DOFs are
    ``rec.force_dof`` and ``rec.response_dofs``.
    """
    import pyuff

    path = Path(path)
    fs = rec.sample_rate_hz
    f_node, f_dir = rec.force_dof
    records = []
    for case, (k0, k1) in enumerate(_segments(rec, precut_s, pretrigger_s), start=1):
        channels = [(rec.force_n[k0:k1] / _FORCE_UNITS[force_unit], 13, force_unit, 0, 1,
                     (f_node, f_dir), rec.channel_names[0])]
        for c, dof in enumerate(rec.response_dofs):
            channels.append((rec.response[c, k0:k1] / _ACCEL_UNITS[accel_unit], 12, accel_unit,
                             1, 0, dof, rec.channel_names[1 + c]))
        for data, data_type, unit, len_exp, force_exp, (node, direction), name in channels:
            records.append(pyuff.prepare_58(
                binary=int(binary),
                id1=name,
                id2="synthetic impact recording",
                id3="NONE",
                id4=f"hit record {case}" if precut_s is not None else "continuous recording",
                id5="NONE",
                func_type=1,
                load_case_id=case if precut_s is not None else 0,
                rsp_ent_name="NONE",
                rsp_node=node,
                rsp_dir=direction,
                ref_ent_name="NONE",
                ref_node=f_node,
                ref_dir=f_dir,
                ord_data_type=4,
                num_pts=data.size,
                abscissa_spacing=1,
                abscissa_min=k0 / fs,
                abscissa_inc=1 / fs,
                abscissa_spec_data_type=17,
                abscissa_len_unit_exp=0,
                abscissa_force_unit_exp=0,
                abscissa_temp_unit_exp=0,
                abscissa_axis_units_lab="s",
                ordinate_spec_data_type=data_type,
                ordinate_len_unit_exp=len_exp,
                ordinate_force_unit_exp=force_exp,
                ordinate_temp_unit_exp=0,
                ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0,
                orddenom_len_unit_exp=0,
                orddenom_force_unit_exp=0,
                orddenom_temp_unit_exp=0,
                orddenom_axis_units_lab="NONE",
                z_axis_spec_data_type=0,
                z_axis_len_unit_exp=0,
                z_axis_force_unit_exp=0,
                z_axis_temp_unit_exp=0,
                z_axis_axis_units_lab="NONE",
                data=np.asarray(data, dtype=float),
                x=(k0 + np.arange(data.size)) / fs,
            ))
    if path.exists():
        path.unlink()  # pyuff appends to an existing file
    pyuff.UFF(str(path)).write_sets(records, mode="add")
    return path


def write_tdms(
    rec: SyntheticRecording,
    path: str | Path,
    *,
    group: str = "Impact test",
    accel_unit: str = "m/s^2",
    force_name: str | None = None,
) -> Path:
    """Write ``rec`` as a TDMS file with npTDMS: one group, one channel per signal,
    channel properties ``unit_string``, ``wf_increment`` (1/fs), ``wf_start_offset``
    (0), ``wf_samples`` and ``NI_ChannelName``. The force channel is named
    ``force_name`` (default ``"Hammer force"``) in N; the accelerations are in
    ``accel_unit`` (data converted).
    """
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    path = Path(path)
    names = rec.channel_names
    if force_name is not None:
        names[0] = force_name
    dt = 1.0 / rec.sample_rate_hz
    objects = [RootObject(properties={"name": "synthetic impact recording"}),
               GroupObject(group)]
    signals = [(rec.force_n, "N")] + [(rec.response[c] / _ACCEL_UNITS[accel_unit], accel_unit)
                                      for c in range(rec.n_resp)]
    for name, (data, unit) in zip(names, signals, strict=True):
        props = {"unit_string": unit, "wf_increment": dt, "wf_start_offset": 0.0,
                 "wf_samples": int(data.size), "NI_ChannelName": name}
        objects.append(ChannelObject(group, name, np.asarray(data, dtype=float),
                                     properties=props))
    with TdmsWriter(str(path)) as writer:
        writer.write_segment(objects)
    return path


# ----------------------------------------------------------- roving-hammer plate tests

#: The plate tests' sampling rate, hit times and recording length (each hammer
#: point one recording of four hits).
PLATE_FS_HZ = 2048.0
PLATE_HIT_TIMES_S = (0.5, 2.6, 4.7, 6.8)
PLATE_DURATION_S = 9.0
#: The header of a channel sheet (``frf --channels``).
SHEET_HEADER = "file,channel,role,node,direction,scale,unit"


@dataclass(frozen=True)
class Plate:
    """A simply supported rectangular Kirchhoff plate ``lx_m`` x ``ly_m``: mode
    ``(m, n)`` has the shape ``sin(m pi x / lx) sin(n pi y / ly)`` (unit modal
    mass), the natural frequency ``fn_hz`` and the damping ratio ``zeta``, in
    the order of ``modes``."""

    lx_m: float
    ly_m: float
    modes: tuple[tuple[int, int], ...]
    fn_hz: np.ndarray
    zeta: np.ndarray

    def shape(self, x_m: float, y_m: float) -> np.ndarray:
        """Every mode's displacement at (x, y)."""
        return np.array([np.sin(m * np.pi * x_m / self.lx_m) * np.sin(n * np.pi * y_m / self.ly_m)
                         for m, n in self.modes])


@dataclass(frozen=True)
class PlateTest:
    """A roving-hammer test of ``plate``: hammer points ``points`` (nodes 1, 2, ...
    in that order, hit in -Z), one accelerometer at ``sensor`` (node 100, +Z).
    Point k is recorded with seed ``seed_base + k`` in ``formats[k - 1]`` ("csv",
    "wav" or "tdms"): four half-sine hits of ``peak_n`` x U(0.8, 1.2) at
    :data:`PLATE_HIT_TIMES_S`, each ``jitter``: shifted by U(0, 1) samples;
    ``double_hit`` = (point, time s, peak N): a bounce of that point;
    ``late_start`` = (point, s): that point's file starts that long before its
    first hit; ``soft_hits`` = ((point, hit, peak N), ...): that hit (1-4) of
    that point has that peak instead."""

    plate: Plate
    points: tuple[tuple[float, float], ...]
    sensor: tuple[float, float]
    formats: tuple[str, ...]
    peak_n: float
    seed_base: int = 0
    jitter: bool = False
    double_hit: tuple[int, float, float] | None = None
    late_start: tuple[int, float] | None = None
    soft_hits: tuple[tuple[int, int, float], ...] = ()


def plate_hammer_signals(
    plate: Plate,
    point: tuple[float, float],
    sensor: tuple[float, float],
    seed: int,
    *,
    peak_n: float,
    jitter: bool = False,
    double_at: tuple[float, float] | None = None,
    peaks_n: dict[int, float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Force (N) and acceleration at ``sensor`` (m/s^2) of four half-sine hits
    (2 ms) at ``point``, :data:`PLATE_DURATION_S` at :data:`PLATE_FS_HZ`: peaks
    ``peak_n`` x U(0.8, 1.2), at :data:`PLATE_HIT_TIMES_S` (``jitter``: each
    shifted by U(0, 1) samples); ``double_at`` = (time s, peak N) adds a bounce;
    ``peaks_n`` {hit (1-4): peak N} replaces those hits' peaks.
    The response is exact in the frequency domain (zero-padded to twice the
    length); white noise of 1e-4 of the acceleration's peak and of ``peak_n``."""
    rng = np.random.default_rng(seed)
    fs = PLATE_FS_HZ
    n = int(PLATE_DURATION_S * fs)
    t = np.arange(n) / fs
    force = np.zeros(n)
    width = 2e-3
    pulses = [(t0 + (rng.uniform(0.0, 1.0) / fs if jitter else 0.0),
               peak_n * rng.uniform(0.8, 1.2)) for t0 in PLATE_HIT_TIMES_S]
    for hit, peak in (peaks_n or {}).items():
        pulses[hit - 1] = (pulses[hit - 1][0], peak)
    if double_at is not None:
        pulses.append(double_at)
    for t0, peak in pulses:
        on = (t >= t0) & (t <= t0 + width)
        force[on] += peak * np.sin(np.pi * (t[on] - t0) / width)
    n_pad = 2 * n
    w = 2 * np.pi * np.fft.rfftfreq(n_pad, 1 / fs)[:, None]
    wr = 2 * np.pi * plate.fn_hz
    residue = plate.shape(*sensor) * plate.shape(*point)
    H = (-(w**2) * residue / (wr**2 - w**2 + 2j * plate.zeta * wr * w)).sum(axis=1)
    acc = np.fft.irfft(H * np.fft.rfft(force, n_pad), n_pad)[:n]
    acc += 1e-4 * np.abs(acc).max() * rng.standard_normal(n)
    force += 1e-4 * peak_n * rng.standard_normal(n)
    return force, acc


def write_plate_recording(folder: Path, k: int, force: np.ndarray, acc: np.ndarray,
                          fmt: str) -> list[str]:
    """Hammer point ``k``'s recording in ``folder``: "csv" (``rec/pK.csv``, a time
    column, ``Hammer [N]`` and ``acc [m/s^2]``), "wav" (``pK.wav``, float32, the
    force in kN and the acceleration in g) or "tdms" (``pK.tdms``, channels
    ``hammer`` in N and ``acc`` in m/s^2); its two channel-sheet rows."""
    import pandas as pd

    if fmt == "csv":
        name = f"rec/p{k}.csv"
        (folder / "rec").mkdir(exist_ok=True)
        pd.DataFrame({"time_s": np.arange(force.size) / PLATE_FS_HZ, "Hammer [N]": force,
                      "acc [m/s^2]": acc}).to_csv(folder / name, index=False)
        return [f"{name},Hammer,force,{k},-Z,,", f"{name},acc,response,100,+Z,,"]
    if fmt == "wav":
        from scipy.io import wavfile

        name = f"p{k}.wav"
        data = np.column_stack([force / 1000.0, acc / STANDARD_GRAVITY]).astype(np.float32)
        wavfile.write(folder / name, int(PLATE_FS_HZ), data)
        return [f"{name},0,force,{k},-Z,1000,N", f"{name},1,response,100,+Z,,g"]
    if fmt == "tdms":
        from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

        name = f"p{k}.tdms"
        objects = [RootObject(), GroupObject("test")]
        for ch, data, unit in (("hammer", force, "N"), ("acc", acc, "m/s^2")):
            objects.append(ChannelObject("test", ch, data, properties={
                "unit_string": unit, "wf_increment": 1 / PLATE_FS_HZ}))
        with TdmsWriter(str(folder / name)) as writer:
            writer.write_segment(objects)
        return [f"{name},hammer,force,{k},-Z,,", f"{name},acc,response,100,+Z,,"]
    raise ValueError(f"format must be csv, wav or tdms, got {fmt!r}")


def write_plate_test(folder: Path, test: PlateTest) -> None:
    """Every hammer point's recording of ``test`` in ``folder``
    (:func:`write_plate_recording`) and their ``channels.csv``."""
    rows = [SHEET_HEADER]
    for k, point in enumerate(test.points, start=1):
        double = test.double_hit
        force, acc = plate_hammer_signals(
            test.plate, point, test.sensor, test.seed_base + k, peak_n=test.peak_n,
            jitter=test.jitter,
            double_at=double[1:] if double is not None and double[0] == k else None,
            peaks_n={hit: peak for point, hit, peak in test.soft_hits if point == k})
        if test.late_start is not None and test.late_start[0] == k:
            start = int(round((PLATE_HIT_TIMES_S[0] - test.late_start[1]) * PLATE_FS_HZ))
            force, acc = force[start:], acc[start:]
        rows += write_plate_recording(folder, k, force, acc, test.formats[k - 1])
    (folder / "channels.csv").write_text("\n".join(rows) + "\n")
