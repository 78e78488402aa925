"""``ema-pipeline simulate``'s options and a simulated configuration's keys
change the FRFs as they say, checked against closed-form scaling laws and the
paper's tables (every option's test: test_option_inventory.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ema_pipeline import io, paper
from ema_pipeline.cli import main
from ema_pipeline.data import DOF, FRFSet
from tests.cli_runs import run_cli, write_experiment


def _peak_hz(frf: FRFSet, lo: float, hi: float, row: int = 0) -> float:
    """The line of largest |H| of response ``row`` between lo and hi Hz."""
    band = (frf.freq_hz > lo) & (frf.freq_hz < hi)
    return float(frf.freq_hz[band][np.argmax(np.abs(frf.H[row, 0, band]))])


def _cantilever_shape(x_rel: np.ndarray) -> np.ndarray:
    """First bending mode of a clamped-free Euler-Bernoulli beam at x/L (closed form)."""
    bl, sigma = 1.8751040687, 0.7340955137
    z = bl * np.asarray(x_rel)
    return np.cosh(z) - np.cos(z) - sigma * (np.sinh(z) - np.sin(z))


def test_simulate_seed_snr_and_quiet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Same --seed: identical FRFs; another seed: other noise. --snr-db 20 has 10x the
    noise amplitude of 40 dB (20 dB = a factor 10), so about 10x the FRF error
    against the noise-free (--snr-db 0) simulation. --quiet prints nothing."""
    def sim(name: str, *options: str) -> tuple[np.ndarray, str]:
        code, out, _ = run_cli(["simulate", "--out", tmp_path / f"{name}.h5", *options], capsys)
        assert code == 0
        return io.read_frf(tmp_path / f"{name}.h5").H, out

    truth, _ = sim("free", "--snr-db", "0", "--quiet")
    a, said = sim("a", "--seed", "1")
    again, quiet = sim("again", "--seed", "1", "--quiet")
    b, _ = sim("b", "--seed", "2", "--quiet")
    low, _ = sim("low", "--seed", "1", "--snr-db", "20", "--quiet")
    assert "wrote" in said and "seed 1" in said and quiet == ""
    np.testing.assert_array_equal(a, again)
    # the median over lines of the relative error (robust to the antiresonances)
    err = {name: np.median(np.abs(x / truth - 1)) for name, x in (("a", a), ("b", b),
                                                                ("low", low))}
    assert np.median(np.abs(a / b - 1)) > 0.5 * err["a"]  # other noise, of the same size
    assert 0.7 < err["b"] / err["a"] < 1.4
    assert 7.0 < err["low"] / err["a"] < 13.0, err


def test_simulate_configuration_and_zeta_pct(tmp_path: Path) -> None:
    """--configuration larger_tank puts the first peak at Table 1's 16.93 Hz (genuine
    18.14 Hz). --zeta-pct: doubling the damping of an isolated mode lowers its peak
    |H| by (sigma_2 + 1/tau) / (sigma_1 + 1/tau), sigma = 2 pi fn zeta, the
    exponential window's 1/tau = 5/8.192 s adding to both."""
    out = tmp_path / "lt.h5"
    assert main(["simulate", "--configuration", "larger_tank", "--snr-db", "0", "--out",
                 str(out), "--quiet"]) == 0
    fd = paper.TABLE1_FD_HZ["larger_tank"][0]
    assert _peak_hz(io.read_frf(out), 10, 40) == pytest.approx(fd, abs=0.13)  # one line
    assert abs(fd - paper.TABLE1_FD_HZ["genuine"][0]) > 1.0
    peaks = []
    for zeta in ("1", "2"):
        path = tmp_path / f"z{zeta}.h5"
        assert main(["simulate", "--configuration", "custom", "--fd-hz", "20,120",
                     "--zeta-pct", f"{zeta},0.5", "--snr-db", "0", "--out", str(path),
                     "--quiet"]) == 0
        frf = io.read_frf(path)
        peaks.append(np.abs(frf.H[0, 0, (frf.freq_hz > 15) & (frf.freq_hz < 25)]).max())
    rate = 5 / 8.192
    sigma = 2 * np.pi * 20 * np.array([0.01, 0.02])
    assert peaks[0] / peaks[1] == pytest.approx((sigma[1] + rate) / (sigma[0] + rate), rel=0.08)


def test_simulate_binary_and_coherence(tmp_path: Path) -> None:
    """--binary writes binary UFF (not text) with the same FRFs; --coherence adds the
    coherence records to a UFF file, near 1 at the first resonance (40 dB SNR)."""
    paths = {k: tmp_path / f"{k}.uff" for k in ("plain", "binary", "coherence")}
    for name, options in (("plain", []), ("binary", ["--binary"]),
                          ("coherence", ["--coherence"])):
        assert main(["simulate", "--seed", "3", "--out", str(paths[name]), "--quiet",
                     *options]) == 0
    plain, binary, coh = (io.read_frf(paths[k]) for k in ("plain", "binary", "coherence"))
    assert b"\x00" in paths["binary"].read_bytes()
    assert b"\x00" not in paths["plain"].read_bytes()
    np.testing.assert_allclose(binary.H, plain.H, rtol=0, atol=1e-6 * np.abs(plain.H).max())
    assert plain.coherence is None and coh.coherence is not None
    k = np.argmin(np.abs(coh.freq_hz - paper.TABLE1_FD_HZ["genuine"][0]))
    assert np.all(coh.coherence[:, 0, k] > 0.99) and np.all(coh.coherence <= 1 + 1e-9)


def test_simulate_experiment_beam_and_sensors(tmp_path: Path) -> None:
    """simulate --experiment: the experiment's beam and sensors. A beam 1.1 times
    longer has its first mode at 1/1.1^2 of the paper beam's 19.84 Hz (Table 3);
    with 5 measurement elements node 3 is at 0.4 L and node 6 at the tip, so the
    ratio of the two responses at the first peak is the cantilever's first mode
    shape phi(0.4)/phi(1.0); the FRF's DOFs are the given nodes and direction."""
    exp = write_experiment(tmp_path / "exp.toml", """
[beam]
length_m = 0.715
n_elements = 50
n_measurement_elements = 5
[sensors]
response_nodes = [3, 6]
hammer_node = 6
direction = -3
[[configurations]]
name = "genuine"
added_mass = {}
""")
    out = tmp_path / "g.h5"
    assert main(["simulate", "--added-mass", "none", "--experiment", str(exp), "--snr-db", "0",
                 "--out", str(out), "--quiet"]) == 0
    frf = io.read_frf(out)
    assert frf.response_dofs == (DOF(3, -3), DOF(6, -3)) and frf.reference_dofs == (DOF(6, -3),)
    f1 = _peak_hz(frf, 5, 40)
    assert f1 == pytest.approx(paper.TABLE3_FN_HZ[0] / 1.1**2, abs=0.13)  # one line
    k = np.argmin(np.abs(frf.freq_hz - f1))
    ratio = np.abs(frf.H[0, 0, k] / frf.H[1, 0, k])
    expected = _cantilever_shape(0.4) / _cantilever_shape(1.0)  # 0.19
    assert ratio == pytest.approx(expected, rel=0.03)


def test_simulated_configuration_snr_and_seed(tmp_path: Path) -> None:
    """A simulated configuration's FRFs (what run identifies,
    :func:`ema_pipeline.pipeline.simulate.simulate_configuration`): the same seed
    gives the same noise, another seed other noise of the same size, the default
    seed is the entry's position (entry 5 without a seed = seed 5); snr_db = 20 has
    10x the noise amplitude of 40 dB, so about 10x the FRF error against the
    noise-free snr_db = 0; a negative snr_db is noise stronger than the signal
    (as ``simulate --snr-db``), not noise-free."""
    from ema_pipeline.pipeline.simulate import simulate_configuration

    entries = (("free", "snr_db = 0"), ("a", "seed = 5"), ("again", "seed = 5"),
               ("other", "seed = 6"), ("fifth", ""), ("low", "seed = 5\nsnr_db = 20"),
               ("loud", "snr_db = -10"))
    exp = io.read_experiment(write_experiment(tmp_path / "exp.toml", "".join(
        f'[[configurations]]\nname = "{name}"\nadded_mass = {{}}\n{keys}\n'
        for name, keys in entries)))
    snr = {spec.name: spec.snr_db for spec in exp.configurations}
    assert snr["free"] is None and snr["loud"] == -10.0 and snr["a"] == 40.0
    H = {spec.name: simulate_configuration(exp, spec).H for spec in exp.configurations
         if spec.name != "loud"}
    np.testing.assert_array_equal(H["a"], H["again"])
    np.testing.assert_array_equal(H["a"], H["fifth"])
    err = {k: np.median(np.abs(H[k] / H["free"] - 1)) for k in ("a", "other", "low")}
    assert np.median(np.abs(H["a"] / H["other"] - 1)) > 0.5 * err["a"]
    assert 0.7 < err["other"] / err["a"] < 1.4
    assert 7.0 < err["low"] / err["a"] < 13.0, err
