"""``identify --picks``: the untouched report's picks reproduce the automatic
result, a picked diagram pole gives the mode the data hold, and a pick that
matches no pole is an error naming it. The FRFs are simulated here by modal
superposition with known poles (independent of the package's simulator)."""

from __future__ import annotations

import html
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.data import DOF, DataError, FRFSet
from ema_pipeline.identification import IdentificationOptions, found_by_names, identify
from ema_pipeline.identification.picked import Pick
from ema_pipeline.identification.selection.picks import is_picked, picks_from_result

FN_HZ = np.array([42.0, 97.0, 161.0])
ZETA = np.array([0.012, 0.008, 0.01])
SHAPES = np.array([[1.0, 0.7, -0.4], [0.6, -0.9, 0.8], [0.3, -0.5, -1.0], [-0.8, 0.2, 0.6]])


def simulated(seed: int = 3) -> FRFSet:
    """Accelerance of 3 modes at 4 responses, one reference (DOF 1), 0.25 Hz
    lines to 200 Hz, 0.1 % complex noise of the largest value."""
    f = np.arange(0.0, 200.0 + 1e-9, 0.25)
    w = 2 * np.pi * f
    lam = -ZETA * 2 * np.pi * FN_HZ + 1j * 2 * np.pi * FN_HZ * np.sqrt(1 - ZETA**2)
    jw = 1j * w[None, :]
    H = np.zeros((4, f.size), complex)
    for r in range(FN_HZ.size):
        a = SHAPES[:, r] * SHAPES[0, r] / (2j * lam[r].imag)
        H += a[:, None] / (jw - lam[r]) + np.conj(a)[:, None] / (jw - np.conj(lam[r]))
    H = -(w**2)[None, :] * H
    rng = np.random.default_rng(seed)
    H += 1e-3 * np.abs(H).max() * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    return FRFSet(freq_hz=f, H=H[:, None, :], response_dofs=tuple(DOF(k + 1, 3) for k in range(4)),
                  reference_dofs=(DOF(1, 3),), configuration="plate")


@pytest.fixture(scope="module")
def case(tmp_path_factory) -> tuple[Path, Path]:
    """The simulated file and ``identify --report`` of it (once per module)."""
    tmp = tmp_path_factory.mktemp("picks")
    path = io.write_frf(simulated(), tmp / "plate.h5")
    assert main(["identify", str(path), "--out", str(tmp / "auto"), "--report",
                 "--no-figures", "--quiet"]) == 0
    return path, tmp / "auto"


def page_picks(report: Path) -> str:
    """The picks file of the page's ``#picks`` element as the page opens: the
    automatic result's picks (read from the ``_result.h5`` beside the page)
    in the layout of ``io.picks``, which the page's script writes
    (``tests/test_picks_format.py`` checks the two agree in a browser)."""
    assert '<pre class="picks" id="picks">' in report.read_text(encoding="utf-8")
    result_h5 = report.with_name(report.name.replace("_report.html", "_result.h5"))
    _, result = io.read_identification_result(result_h5)
    return io.picks_toml(picks_from_result(result))


def test_untouched_page_picks_reproduce_the_automatic_result(case, tmp_path):
    path, auto = case
    before = pd.read_csv(auto / "plate_modes.csv")
    assert np.allclose(before["fn_hz"], FN_HZ, rtol=1e-3)  # the case is identified right
    picks = tmp_path / "picks.toml"
    picks.write_text(page_picks(auto / "plate_report.html"), encoding="utf-8")
    assert main(["identify", str(path), "--out", str(tmp_path / "p"), "--picks", str(picks),
                 "--report", "--no-figures", "--quiet"]) == 0
    after = pd.read_csv(tmp_path / "p" / "plate_modes.csv")
    assert len(after) == len(before)
    np.testing.assert_allclose(after["fn_hz"], before["fn_hz"], rtol=1e-6)
    np.testing.assert_allclose(after["zeta_pct"], before["zeta_pct"], rtol=1e-4)
    # the report marks them as picked
    page = (tmp_path / "p" / "plate_report.html").read_text(encoding="utf-8")
    assert page.count(">picked<") == len(after)
    # the selection leaves a trace: a selection column, the picks file and its
    # sha256 in the report and in the HDF5 result (the automatic run says auto)
    assert list(after["found_by"]) == ["picked"] * len(after)
    assert list(after["selection"]) == ["picked"] * len(after)
    assert list(before["selection"]) == ["auto"] * len(before)
    assert set(before["found_by"]) <= {"diagram", "other_order", "window", "alternate",
                                       "partner", "residual"}
    digest = io.sha256_file(picks)
    assert len(digest) == 64 and digest in page and html.escape(str(picks)) in page
    stored = io.read_results_h5(tmp_path / "p" / "plate_result.h5")["input"]
    assert stored["picks_sha256"] == digest and stored["picks_path"] == str(picks)
    assert "picks_sha256" not in io.read_results_h5(auto / "plate_result.h5")["input"] or \
        io.read_results_h5(auto / "plate_result.h5")["input"]["picks_sha256"] == ""


def test_a_pick_that_matches_no_pole_is_an_error_naming_it(case, tmp_path, capsys):
    path, auto = case
    text = page_picks(auto / "plate_report.html")
    order = int(re.search(r"orders = \[([\d, ]+)\]", text).group(1).split(",")[-1])
    bad = text + f"\n[[pick]]\nfreq_hz = 130.0\nzeta = 0.01\norder = {order}\n"
    picks = tmp_path / "bad.toml"
    picks.write_text(bad, encoding="utf-8")
    capsys.readouterr()
    assert main(["identify", str(path), "--out", str(tmp_path / "p"), "--picks",
                 str(picks), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "bad.toml" in err and f"130 Hz at order {order} matches no pole" in err
    # a picks file that is not TOML: exit 2 naming it
    picks.write_text("[[pick]\n", encoding="utf-8")
    assert main(["identify", str(path), "--out", str(tmp_path / "p"), "--picks",
                 str(picks), "--quiet"]) == 2
    assert "bad.toml: not valid TOML" in capsys.readouterr().err


def test_a_picked_diagram_pole_gives_the_mode_and_a_dropped_one_is_gone():
    frf = simulated()
    auto = identify(frf)
    picks = picks_from_result(auto)
    # mode 2 (97 Hz) not picked; mode 3 (161 Hz) picked as a pole of the highest order
    top = max(picks.orders)
    stab = auto.stabilization
    at_top = stab.freq_hz[stab.order == top]
    f_pick = float(at_top[np.argmin(np.abs(at_top - FN_HZ[2]))])
    chosen = (picks.picks[0], Pick(freq_hz=round(f_pick, 4), order=top))
    result = identify(frf, picks=type(picks)(picks.band_hz, picks.orders, chosen))
    assert is_picked(result) and not is_picked(auto)
    assert found_by_names(result) == ["picked", "picked"]  # the modes table's found_by
    np.testing.assert_allclose(result.fn_hz, FN_HZ[[0, 2]], rtol=1e-3)  # the truth
    np.testing.assert_allclose(result.zeta, ZETA[[0, 2]], rtol=0.05)
    assert np.all(np.isfinite(result.modes.fn_std_hz))  # the same uncertainty chain
    # the first mode, picked by its start pole, is the automatic one
    np.testing.assert_allclose(result.fn_hz[0], auto.fn_hz[0], rtol=1e-5)


def test_picks_set_the_band_and_order_and_refuse_expect():
    frf = simulated()
    auto = identify(frf, band_hz=(20.0, 190.0))
    picks = picks_from_result(auto)
    result = identify(frf, IdentificationOptions(band_hz=(5.0, 199.0)), picks=picks)
    assert result.settings.band_hz == (20.0, 190.0)  # the picks file's, not the options'
    assert result.settings.max_order == max(picks.orders)
    np.testing.assert_allclose(result.fn_hz, auto.fn_hz, rtol=1e-6)
    with pytest.raises(DataError, match="expected frequencies"):
        identify(frf, expect_hz=(42.0,), picks=picks)


def test_untouched_page_picks_reproduce_the_measured_beam(real_uff, beam_report, tmp_path):
    """A candidate refined beside the kept modes and then dropped (a companion)
    bends their local fits; the page's picks carry it, so ``--picks`` gives
    the automatic modes again (before: 941.80 -> 941.22 Hz on the measured
    beam). Since issue 31 the kept modes are refined again without the
    candidates that failed (``acceptance.refit_kept``), and the beam's
    automatic fit has no companion left; the picks still reproduce it. The
    automatic run is the session's ``identify --report`` of the beam
    (conftest.py)."""
    auto = beam_report
    text = page_picks(auto / f"{real_uff.stem}_report.html")
    picks = tmp_path / "picks.toml"
    picks.write_text(text, encoding="utf-8")
    assert main(["identify", str(real_uff), "--out", str(tmp_path / "p"), "--picks",
                 str(picks), "--no-figures", "--quiet"]) == 0
    before = pd.read_csv(auto / f"{real_uff.stem}_modes.csv")
    after = pd.read_csv(tmp_path / "p" / f"{real_uff.stem}_modes.csv")
    assert len(after) == len(before)
    np.testing.assert_allclose(after["fn_hz"], before["fn_hz"], rtol=1e-6)
    np.testing.assert_allclose(after["zeta_pct"], before["zeta_pct"], rtol=1e-4)
