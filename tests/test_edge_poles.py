"""Resonances at the band's edges (identification.selection.edge_poles): a mode
just past the band's top is kept in its in-band neighbour's fits and not
reported; one in the band's edge zone is named in a warning. Known truth: exact
FRFs of seven modes on eight responses, with noise."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from ema_pipeline.acquisition import modal_frf
from ema_pipeline.data import FRFSet, ModalParameters
from ema_pipeline.identification import IdentificationResult, SelectionThresholds, identify
from ema_pipeline.modal import mac_pairs

FN = np.array([42.0, 97.0, 151.0, 208.0, 250.0, 258.2, 272.0])
ZETA = np.array([0.008, 0.01, 0.009, 0.012, 0.0135, 0.0135, 0.01])
TOP = 4  # the band's top mode (250 Hz); 258.2 Hz lies just past the band's top


@pytest.fixture(scope="module")
def case() -> tuple[FRFSet, np.ndarray]:
    rng = np.random.default_rng(3)
    f = np.arange(0.0, 400.5, 0.25)
    phi = rng.standard_normal((8, FN.size))
    phi[:, 5] *= 2.5  # the mode past the band is strong at the responses
    H = modal_frf(f, ModalParameters(fn_hz=FN, zeta=ZETA), phi, phi[:1])
    H = H + 2e-3 * np.sqrt(np.mean(np.abs(H) ** 2)) * (
        rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    return FRFSet(freq_hz=f, H=H), phi


def run(frf: FRFSet, band: tuple[float, float], **th) -> IdentificationResult:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return identify(frf, band_hz=band, thresholds=replace(SelectionThresholds(), **th))


def shape_mac(result: IdentificationResult, phi: np.ndarray, j: int) -> float:
    i = int(np.argmin(np.abs(result.fn_hz - FN[j])))
    assert abs(result.fn_hz[i] / FN[j] - 1) < 0.01
    return float(mac_pairs(result.modes.shapes[:, [i]], phi[:, [j]])[0])


def test_mode_just_past_the_band_top_kept_in_the_fit_not_reported(case):
    frf, phi = case
    band = (20.0, 256.0)  # 258.2 Hz lies 0.9 % above the top, its half-power band reaches in
    result = run(frf, band)
    # every band mode found, within 0.05 %, the top one's shape within MAC 0.999 of the truth
    assert result.fn_hz.size == 5
    np.testing.assert_allclose(result.fn_hz, FN[:5], rtol=5e-4)
    np.testing.assert_allclose(result.zeta, ZETA[:5], rtol=0.02)
    assert shape_mac(result, phi, TOP) >= 0.999
    # the mode past the top is fitted (edge_hz) but not reported
    assert not np.any(np.abs(result.fn_hz / FN[5] - 1) < 0.01)
    assert np.min(np.abs(result.edge_hz / FN[5] - 1)) < 1e-3
    assert not result.warnings  # it lies past the band: nothing to warn of
    # without it (no widening) the top mode takes up its resonance: 0.3 % off, shape bent
    bare = run(frf, band, edge_margin=0.0)
    assert bare.edge_hz.size == 0
    assert abs(bare.fn_hz[TOP] / FN[TOP] - 1) > 2e-3
    assert shape_mac(bare, phi, TOP) < 0.8


def test_mode_in_the_band_edge_zone_named_in_a_warning(case):
    frf, phi = case
    band = (20.0, 260.0)  # 258.2 Hz within 2 % of the width of the top: taken as truncation
    with pytest.warns(UserWarning, match=r"a resonance at 258\.\d+ Hz lies at the top edge of "
                      r"the band \[20, 260\] Hz .* widen the band past it"):
        result = identify(frf, band_hz=band)
    assert not np.any(np.abs(result.fn_hz / FN[5] - 1) < 0.01)
    assert shape_mac(result, phi, TOP) >= 0.99


def test_band_without_a_resonance_at_its_edges_unchanged(case):
    frf, _ = case
    band = (20.0, 230.0)  # the nearest modes 22 Hz inside and 20 Hz past the top
    result = run(frf, band)
    bare = run(frf, band, edge_margin=0.0)
    assert result.edge_hz.size == 0
    np.testing.assert_array_equal(result.fn_hz, bare.fn_hz)
    np.testing.assert_array_equal(result.modes.shapes, bare.modes.shapes)


def test_band_is_not_widened_past_the_hammer_usable_top(case):
    """Above the force spectrum's -20 dB point the FRFs hold noise: a band
    that ends there is not widened, whatever lies past it."""
    from ema_pipeline.data import AcquisitionInfo

    frf, _ = case
    band = (20.0, 256.0)
    driven = replace(frf, acquisition=AcquisitionInfo(force_band_hz=(0.0, 256.0)))
    result = run(driven, band)
    bare = run(frf, band, edge_margin=0.0)
    assert result.edge_hz.size == 0
    np.testing.assert_array_equal(result.fn_hz, bare.fn_hz)
    # with the hammer driving past it, the same band is widened (the first test)
    edge = run(replace(frf, acquisition=AcquisitionInfo(force_band_hz=(0.0, 300.0))),
               band).edge_hz
    assert np.min(np.abs(edge / FN[5] - 1)) < 1e-3
