"""`ema-pipeline simulate`: the documented commands regenerate the example data."""

from __future__ import annotations

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main

# The exact commands of README "Example data" (arguments after `ema-pipeline`).
EXAMPLE_COMMANDS = {
    "genuine.uff": "simulate --configuration genuine --format uff --seed 1",
    "larger_tank.h5": "simulate --configuration larger_tank --format h5 --seed 2",
    "smaller_tank.uff": "simulate --configuration smaller_tank --format uff --binary --seed 3",
}


@pytest.mark.parametrize("name", sorted(EXAMPLE_COMMANDS))
def test_regenerating_the_example_data_gives_equal_arrays(name, example_dir, tmp_path):
    out = tmp_path / name
    assert main([*EXAMPLE_COMMANDS[name].split(), "--out", str(out), "--quiet"]) == 0
    shipped, again = io.read_frf(example_dir / name), io.read_frf(out)
    # The arrays are recomputed (FFTs, averaging, H1 estimate): another CPU or BLAS
    # changes the last bits (differences of 2e-10 seen on another machine), and
    # the ASCII UFF keeps 12 significant digits, so a changed last bit can also
    # change the stored rounding. Equal within 1e-9 of the largest |H| (absolute,
    # since lines near an antiresonance have no meaningful relative error); the
    # frequency axis within 1e-12 relative.
    np.testing.assert_allclose(again.freq_hz, shipped.freq_hz, rtol=1e-12, atol=0)
    np.testing.assert_allclose(again.H, shipped.H, rtol=0,
                               atol=1e-9 * np.max(np.abs(shipped.H)))
    assert again.H.shape == shipped.H.shape
    assert again.acquisition == shipped.acquisition


def test_simulate_usage_errors_exit_2(tmp_path, capsys):
    assert main(["simulate", "--configuration", "pond", "--out", str(tmp_path / "x.uff")]) == 2
    assert "pond" in capsys.readouterr().err
    assert main(["simulate", "--configuration", "pond", "--fd-hz", "10,20",
                 "--out", str(tmp_path / "x.uff")]) == 2
    assert not (tmp_path / "x.uff").exists()
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--format", "xls", "--out", "x"])
    assert exc.value.code == 2


def test_simulate_custom_modes_and_time_records(tmp_path):
    out, times = tmp_path / "c.h5", tmp_path / "c_time.uff"
    assert main(["simulate", "--configuration", "custom", "--fd-hz", "20,120",
                 "--zeta-pct", "1,0.5", "--format", "h5", "--snr-db", "0",
                 "--out", str(out), "--time-records", str(times), "--quiet"]) == 0
    frf = io.read_frf(out)
    k = np.argmax(np.abs(frf.H[0, 0, frf.freq_hz < 60]))
    assert frf.freq_hz[k] == pytest.approx(20.0, abs=0.2)  # the asked first mode
    rec = io.read_time_uff(times)
    assert rec.force.shape == (4, 16384) and rec.response.shape == (4, 2, 16384)


def test_unwritable_output_is_a_clear_error_not_a_traceback(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    code = main(["simulate", "--out", str(blocker / "sub" / "g.uff"), "--quiet"])
    assert code == 2  # found before the simulation: a usage error (issue 30)
    err = capsys.readouterr().err
    assert "error:" in err and f"{blocker} is a file, not a folder" in err
    assert "Traceback" not in err and err.count("\n") == 1


@pytest.mark.parametrize("snr_db", [-10.0, 20.0])
def test_snr_db_sets_the_noise_level_negative_too(snr_db, tmp_path, capsys):
    """``--snr-db`` sets the noise of every channel to RMS(channel) x
    10^(-snr/20), negative values included (-10 dB: noise 3.16 times the
    signal; it used to write the noise-free file); 0 is noise-free. Measured
    on the time records of the same seed with and without noise (4 impacts x
    16384 samples per channel: the sample RMS is within 2 %)."""
    def records(name: str, snr: str):
        out, times = tmp_path / f"{name}.uff", tmp_path / f"{name}_time.uff"
        assert main(["simulate", "--out", str(out), "--time-records", str(times), "--binary",
                     f"--snr-db={snr}", "--seed", "4"]) == 0
        return io.read_time_uff(times), capsys.readouterr().out

    clean, said_clean = records("free", "0")
    noisy, said = records("noisy", repr(snr_db))
    assert "SNR none" in said_clean and f"SNR {snr_db:g} dB" in said
    for signal, with_noise in ((clean.force, noisy.force), (clean.response, noisy.response)):
        rms = np.sqrt(np.mean(signal**2, axis=-1))
        noise_rms = np.sqrt(np.mean((with_noise - signal) ** 2, axis=-1))
        np.testing.assert_allclose(noise_rms / rms, 10 ** (-snr_db / 20), rtol=0.02)
    assert main(["simulate", "--out", str(tmp_path / "nan.uff"), "--snr-db=nan"]) == 2
    assert "snr_db must be a number of dB" in capsys.readouterr().err
    assert not (tmp_path / "nan.uff").exists()
