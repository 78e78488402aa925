"""``ema-pipeline frf``: hits found and checked on synthetic recordings with known truth
(tests/impact_recordings.py, written without the package), FRFs against the true FRF
and the textbook H1, identification of the written file, every option, bad input."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.acquisition import hits as hitlib
from ema_pipeline.cli import main
from ema_pipeline.data import DOF, Channel, DataError, Recording
from ema_pipeline.pipeline.frf import FRFSettings, frf_from_recording
from tests.impact_recordings import make_recording, write_tdms, write_uff

SEEDS = range(6)


def as_recording(rec, full_scale: bool = True) -> Recording:
    """The generator's arrays as a Recording (channel ranges known, as a DAQ file keeps)."""
    fs = rec.full_scale if full_scale else [None] * (1 + rec.n_resp)
    channels = [Channel("Hammer force", "force", DOF(*rec.force_dof), fs[0])]
    channels += [Channel(f"acc{c}", "acceleration", DOF(*dof), fs[1 + c])
                 for c, dof in enumerate(rec.response_dofs)]
    return Recording(rec.signals, rec.sample_rate_hz, tuple(channels))


def defective(seed: int):
    return make_recording(seed, n_double=1 + seed % 2, n_overload=1)


@pytest.mark.parametrize("seed", SEEDS)
def test_every_hit_found_within_5_ms_and_no_other(seed):
    rec = defective(seed)
    found = hitlib.find_hits(as_recording(rec), 0, pretrigger_s=0.01)
    assert found.n_hits == rec.hit_times_s.size
    assert np.max(np.abs(found.time_s - rec.hit_times_s)) < 5e-3


@pytest.mark.parametrize("seed", SEEDS)
def test_defective_hits_rejected_with_their_reason_good_hits_kept(seed):
    rec = defective(seed)
    recording = as_recording(rec)
    found = hitlib.find_hits(recording, 0, pretrigger_s=0.01)
    hits = hitlib.check_hits(recording, 0, found, exp_window=True)
    for hit, truth in zip(hits, rec.defects, strict=True):
        assert set(hit.reasons) - {"past_end"} == set(truth), (hit, truth)
        assert hit.accepted == (not hit.reasons)
    if rec.last_hit_short:  # the generator's last hit has no room for its record
        assert hits[-1].reasons == ("past_end",) and not hits[-1].accepted


@pytest.mark.parametrize("seed", range(12))
def test_flat_tops_found_without_the_full_scale(seed):
    """A channel clipped on 2 samples or more is an overload even when the file does
    not give the channel's range (UFF): the flat tops alone."""
    rec = make_recording(seed, n_overload=1)
    recording = as_recording(rec, full_scale=False)
    found = hitlib.find_hits(recording, 0, pretrigger_s=0.01)
    hits = hitlib.check_hits(recording, 0, found, exp_window=True)
    for hit, truth, clipped in zip(hits, rec.defects, rec.clipped_samples, strict=True):
        if "overload" in truth and clipped >= 2:
            assert "overload" in hit.reasons
        if not truth:
            assert set(hit.reasons) <= {"past_end"}


def windowed_truth(rec, freq_hz: np.ndarray, tau_s: float | None) -> np.ndarray:
    """The generator's accelerance seen through exp(-t/tau) on force and response:
    the accelerance at s + 1/tau (x e^{-t/tau} <-> X(s + 1/tau))."""
    shift = 0.0 if tau_s is None else 1.0 / tau_s
    s = 2j * np.pi * freq_hz + shift
    a = rec.residues[:, :, None]
    lam = rec.poles[None, :, None]
    h = (a / (s - lam) + np.conj(a) / (s - np.conj(lam))).sum(axis=1)
    return s**2 * h


@pytest.mark.parametrize("seed", [0, 3])
def test_averaged_h1_matches_the_true_frf_near_the_modes(seed):
    rec = defective(seed)
    out = frf_from_recording(as_recording(rec), FRFSettings(exp_window_tau=0.25))
    f = out.frf.freq_hz
    truth = windowed_truth(rec, f, out.exp_window_tau_s)
    for fn, zeta in zip(rec.fn_hz, rec.zeta, strict=True):
        half = zeta * fn + 1.0 / (2 * np.pi * 0.25)  # half-power half-width with the window
        near = np.abs(f - fn) <= half
        err = np.abs(out.frf.H[:, 0, near] - truth[:, near]) / np.abs(truth[:, near])
        assert err.max() < 0.02, (fn, err.max())


def test_our_h1_is_the_textbook_h1_on_the_same_records_and_hv_lies_between():
    rec = defective(1)
    recording = as_recording(rec)
    settings = FRFSettings(exp_window_tau=0.3, force_window_s=0.05)
    out = frf_from_recording(recording, settings)
    r, n, fs = out.records, out.n_samples, rec.sample_rate_hz
    t = np.arange(n) / fs
    w = np.exp(-(t - r.trigger_s) / 0.3)
    taper = np.clip((t - 0.05) / 0.01, 0, 1)
    wf = w * np.where(t <= 0.05, 1.0, np.where(t < 0.06, 0.5 * (1 + np.cos(np.pi * taper)), 0))
    F = np.fft.rfft(r.force * wf, axis=-1)
    X = np.fft.rfft(r.response * w, axis=-1)
    textbook = (np.conj(F)[:, None] * X).sum(0) / (np.abs(F) ** 2).sum(0)
    assert np.allclose(out.frf.H[:, 0], textbook, rtol=1e-10, atol=1e-12 * np.abs(textbook).max())
    h2 = frf_from_recording(recording, replace(settings, estimator="H2")).frf.H
    hv = frf_from_recording(recording, replace(settings, estimator="Hv")).frf.H
    h1 = np.abs(out.frf.H)
    assert np.all(h1 <= np.abs(hv) * (1 + 1e-9)) and np.all(np.abs(hv) <= np.abs(h2) * (1 + 1e-9))
    assert np.abs(hv - out.frf.H).max() > 0  # a different estimator, not H1 again


def test_uff_and_tdms_copies_give_the_same_frf_and_identify_recovers_the_damping(tmp_path):
    from ema_pipeline.identification import IdentificationOptions, identify

    rec = defective(2)
    write_uff(rec, tmp_path / "rec.uff")
    write_tdms(rec, tmp_path / "rec.tdms")
    for name in ("rec.uff", "rec.tdms"):
        code = main(["frf", str(tmp_path / name), "--out", str(tmp_path / f"{name}.h5"),
                     "--exp-window-tau", "0.25", "--quiet"])
        assert code == 0
    a, b = io.read_frf(tmp_path / "rec.uff.h5"), io.read_frf(tmp_path / "rec.tdms.h5")
    assert np.abs(a.H - b.H).max() <= 1e-9 * np.abs(a.H).max()
    assert a.acquisition.exp_window_tau_s == 0.25  # stored: identification corrects for it
    table = (tmp_path / "rec.uff_hits.csv").read_text().splitlines()
    assert table[0] == "hit,time_s,force_peak_n,accepted,reasons,note"
    assert len(table) == 1 + rec.hit_times_s.size
    result = identify(a, IdentificationOptions(band_hz=rec.band_hz))
    fn, zeta = result.modes.fn_hz, result.modes.zeta
    for f_true, z_true in zip(rec.fn_hz, rec.zeta, strict=True):
        k = np.argmin(np.abs(fn - f_true))
        assert abs(fn[k] - f_true) < 0.005 * f_true
        assert abs(zeta[k] - z_true) < 0.10 * z_true, (f_true, zeta[k], z_true)


def test_each_option_changes_the_result(tmp_path):
    rec = defective(4)
    write_uff(rec, tmp_path / "rec.uff")

    def run(*options: str) -> tuple[np.ndarray, str]:
        out = tmp_path / f"o{len(list(tmp_path.iterdir()))}.h5"
        assert main(["frf", str(tmp_path / "rec.uff"), "--out", str(out), "--quiet",
                     *options]) == 0
        frf = io.read_frf(out)
        return frf.H, (tmp_path / f"{out.stem}_hits.csv").read_text()

    base, base_hits = run()
    for option in (["--pretrigger-s", "0.03"], ["--record-length-s", "0.5"],
                   ["--force-window-s", "0"], ["--exp-window-tau", "0.2"],
                   ["--estimator", "H2"], ["--estimator", "Hv"]):
        H, _ = run(*option)
        assert H.shape != base.shape or np.abs(H - base).max() > 1e-6 * np.abs(base).max(), option
    # short records have not decayed: auto windows them, none rejects them instead
    short_auto, _ = run("--record-length-s", "0.25")
    short_none, hits = run("--record-length-s", "0.25", "--exp-window-tau", "none")
    assert "not_decayed" in hits and "not_decayed" not in base_hits
    assert np.abs(short_auto - short_none).max() > 1e-3 * np.abs(short_auto).max()
    H, hits = run("--keep-all")
    rows = [line.split(",") for line in hits.splitlines()[1:]]
    assert "False" in base_hits
    assert all(accepted == "True" or reasons == "past_end" for *_, accepted, reasons, _ in rows)
    assert np.abs(H - base).max() > 1e-6 * np.abs(base).max()


def write_csv_recording(path: Path, force: np.ndarray, response: np.ndarray, fs: float,
                        force_unit: str = "N") -> Path:
    t = np.arange(force.size) / fs
    rows = "\n".join(f"{a:.9g},{b:.9g},{c:.9g}" for a, b, c in zip(t, force, response,
                                                                    strict=True))
    path.write_text(f"time [s],hammer [{force_unit}],acc [m/s^2]\n{rows}\n")
    return path


@pytest.mark.parametrize("case", ["no hit", "every hit rejected", "no force channel"])
def test_bad_recordings_exit_2_naming_the_file_and_write_nothing(tmp_path, capsys, case):
    rec = make_recording(5, n_hits=5, n_double=5, last_hit_short=False, n_resp=1)
    force, resp = rec.force_n, rec.response[0]
    if case == "no hit":
        force = np.zeros_like(force)
    path = write_csv_recording(tmp_path / "rec.csv", force, resp, rec.sample_rate_hz,
                               "m/s^2" if case == "no force channel" else "N")
    out = tmp_path / "out" / "frf.h5"
    assert main(["frf", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "rec.csv" in err, err
    assert not out.exists() and not (tmp_path / "out" / "frf_hits.csv").exists()


def test_no_hit_and_every_hit_rejected_in_python():
    rec = make_recording(1, n_hits=5, n_double=5, last_hit_short=False)
    recording = as_recording(rec)
    with pytest.raises(DataError, match="every hit rejected"):
        frf_from_recording(recording)
    assert frf_from_recording(recording, FRFSettings(keep_all=True)).n_accepted == 5
    flat = replace(recording, signals=np.vstack([np.zeros(rec.n_samples), rec.response]))
    with pytest.raises(DataError, match="no hit found"):
        frf_from_recording(flat)


def test_usable_band_stored_and_identify_warns_past_it(tmp_path, capsys):
    rec = defective(0)
    write_uff(rec, tmp_path / "rec.uff")
    assert main(["frf", str(tmp_path / "rec.uff"), "--out", str(tmp_path / "f.h5")]) == 0
    printed = capsys.readouterr().out
    frf = io.read_frf(tmp_path / "f.h5")
    f10, f20 = frf.acquisition.force_band_hz
    assert f"-20 dB at {f20:.5g} Hz" in printed
    # half-sine pulse of width T: |F| = |cos(pi f T) / (1 - 4 (f T)^2)| (times its value
    # at 0) falls 10 / 20 dB at f T = 1.019 / 1.303 (first zero at 1.5); widths vary 8 %
    width = float(np.mean(rec.pulse_width_s))
    assert 1.303 / width < rec.sample_rate_hz / 2
    assert f10 == pytest.approx(1.019 / width, rel=0.08)
    assert f20 == pytest.approx(1.303 / width, rel=0.08)
    capped = replace(frf, acquisition=replace(frf.acquisition, force_band_hz=(40.0, 90.0)))
    io.write_frf(capped, tmp_path / "capped.h5")
    assert main(["identify", str(tmp_path / "capped.h5"), "--out", str(tmp_path / "id"),
                 "--band", str(rec.band_hz[0]), str(rec.band_hz[1]), "--quiet"]) == 0
    assert "past the usable band" in capsys.readouterr().err
