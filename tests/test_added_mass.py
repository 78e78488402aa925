"""Modal (eq. 10) and local (eq. 14-20) added mass against the paper and known truth."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.linalg

from ema_pipeline import added_mass as am
from ema_pipeline import fe, paper
from ema_pipeline.data import Beam, DataError, ModalParameters
from ema_pipeline.modal import mac
from ema_pipeline.pipeline import fe_stage


def _table1() -> pd.DataFrame:
    rows = [
        {"configuration": c, "mode": i + 1, "fd_hz": f, "zeta_pct": z * 100}
        for c in paper.CONFIGURATIONS
        for i, (f, z) in enumerate(zip(paper.TABLE1_FD_HZ[c], paper.TABLE1_ZETA[c], strict=True))
    ]
    return pd.DataFrame(rows)


def _measured() -> dict[str, ModalParameters]:
    return am.modal_parameters_from_table(_table1())


@pytest.fixture(scope="module")
def stage() -> fe_stage.FEStageResult:
    return fe_stage.run_fe_stage(Beam(), _measured(), progress=False)


# --- Table 1 input ------------------------------------------------------------
def test_table1_reader_applies_eq4_and_percent():
    meas = _measured()
    assert set(meas) == set(paper.CONFIGURATIONS)
    g = meas["genuine"]
    np.testing.assert_allclose(g.zeta, paper.TABLE1_ZETA["genuine"])
    np.testing.assert_allclose(g.fd_hz, paper.TABLE1_FD_HZ["genuine"])
    np.testing.assert_allclose(g.fn_hz, g.fd_hz / np.sqrt(1 - g.zeta**2))


def test_table1_reader_errors():
    with pytest.raises(DataError, match="missing column"):
        am.modal_parameters_from_table(_table1().drop(columns="zeta_pct"))
    no_genuine = _table1().query("configuration != 'genuine'")
    with pytest.raises(DataError, match="'genuine'.*missing"):
        am.modal_parameters_from_table(no_genuine)
    bad = _table1()
    bad.loc[0, "zeta_pct"] = 150.0
    with pytest.raises(DataError, match="percent"):
        am.modal_parameters_from_table(bad)
    dup = pd.concat([_table1(), _table1().iloc[:1]])
    with pytest.raises(DataError, match="twice"):
        am.modal_parameters_from_table(dup)


def test_table1_reader_drops_empty_modes():
    t = _table1()
    t.loc[(t.configuration == "larger_tank") & (t["mode"] == 2), "fd_hz"] = np.nan
    meas = am.modal_parameters_from_table(t)
    assert meas["larger_tank"].n_modes == 3
    res = am.modal_added_mass(meas["genuine"], meas["larger_tank"])
    np.testing.assert_array_equal(res.partner, [0, -1, 1, 2])


# --- modal added mass, eq. (10) -----------------------------------------------
@pytest.mark.parametrize("cfg", ["larger_tank", "smaller_tank"])
def test_table2_from_table1(cfg):
    meas = _measured()
    res = am.modal_added_mass(meas["genuine"], meas[cfg])
    assert not res.missing.any() and not res.messages
    np.testing.assert_allclose(res.ratio, paper.TABLE2_RATIO[cfg], atol=6e-4)
    # eq. (10) is (fn / fn_w)^2 - 1 by eq. (4)
    np.testing.assert_allclose(res.ratio, (meas["genuine"].fn_hz / meas[cfg].fn_hz) ** 2 - 1)
    assert np.all(np.isnan(res.ratio_std))  # no std given -> NaN


def test_ratio_std_propagation():
    g = ModalParameters(fn_hz=[20.0, 100.0], zeta=[0.01, 0.01], fn_std_hz=[0.02, 0.1])
    w = ModalParameters(fn_hz=[18.0, 95.0], zeta=[0.02, 0.02], fn_std_hz=[0.03, np.nan])
    res = am.modal_added_mass(g, w)
    rng = np.random.default_rng(0)
    fg = 20.0 + 0.02 * rng.standard_normal(200_000)
    fw = 18.0 + 0.03 * rng.standard_normal(200_000)
    assert res.ratio_std[0] == pytest.approx(np.std((fg / fw) ** 2 - 1), rel=0.02)
    assert np.isnan(res.ratio_std[1])


def test_pairing_with_missing_mode():
    g = ModalParameters.from_damped(paper.TABLE1_FD_HZ["genuine"], paper.TABLE1_ZETA["genuine"])
    fd_w = paper.TABLE1_FD_HZ["larger_tank"][[0, 2, 3]]
    z_w = paper.TABLE1_ZETA["larger_tank"][[0, 2, 3]]
    w = ModalParameters.from_damped(fd_w, z_w, configuration="larger_tank")
    res = am.modal_added_mass(g, w)
    np.testing.assert_array_equal(res.partner, [0, -1, 1, 2])
    np.testing.assert_array_equal(res.missing, [False, True, False, False])
    assert np.isnan(res.ratio[1])
    np.testing.assert_allclose(res.ratio[[0, 2, 3]], paper.TABLE2_RATIO["larger_tank"][[0, 2, 3]],
                               atol=6e-4)
    assert len(res.messages) == 1 and "mode 2" in res.messages[0]


def test_pairing_extra_modified_mode_is_reported():
    g = ModalParameters(fn_hz=[20.0, 120.0], zeta=[0.01, 0.01])
    w = ModalParameters(fn_hz=[19.0, 60.0, 115.0], zeta=[0.01, 0.01, 0.01])
    res = am.modal_added_mass(g, w)
    np.testing.assert_array_equal(res.partner, [0, 2])
    np.testing.assert_array_equal(res.unpaired, [1])


def test_pairing_uses_mac_when_shapes_exist():
    # close modes: by frequency alone the single modified mode (99 Hz) would pair
    # with genuine mode 1 (100 Hz); its shape is mode 2's, so MAC pairs it there
    shapes_g = np.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]])
    g = ModalParameters(fn_hz=[100.0, 104.0], zeta=[0.01, 0.01], shapes=shapes_g)
    w = ModalParameters(fn_hz=[99.0], zeta=[0.01], shapes=shapes_g[:, [1]] * 1.1)
    res = am.modal_added_mass(g, w)
    np.testing.assert_array_equal(res.partner, [-1, 0])
    assert res.mac[1] == pytest.approx(1.0)
    w_freq_only = ModalParameters(fn_hz=[99.0], zeta=[0.01])
    np.testing.assert_array_equal(am.modal_added_mass(g, w_freq_only).partner, [0, -1])


def test_mac_matrix_complex():
    a = np.array([[1.0 + 1j, 0], [2.0, 1.0]])
    m = mac(a, a * (0.3 - 2j))
    np.testing.assert_allclose(np.diag(m), 1.0)


# --- local added mass, eq. (14)-(20) ------------------------------------------
def test_local_added_mass_factors_recover_known_modification():
    """Projected element matrices recover a known mass change of the tip tenth."""
    beam = fe.beam_with_parameters(
        Beam(), np.array([paper.TABLE4_UPDATED[n] for n in fe.PARAMETER_NAMES])
    )
    modes, red = fe.reduce_beam(beam)
    tip = fe.assemble_beam(beam, elements=fe.fe_elements_of_measurement_element(beam, 10))
    true_dk, true_dm = 0.002, 0.01
    k_w = modes.model.K + true_dk * tip.K
    m_w = modes.model.M + true_dm * tip.M
    lam_w = scipy.linalg.eigh(k_w, m_w, subset_by_index=[0, 3], eigvals_only=True)
    dl = lam_w - modes.omega2[:4]
    kj = (red.T.T @ tip.K @ red.T)[None]
    mj = (red.T.T @ tip.M @ red.T)[None]
    dk, dm, res, a, b = am.local_added_mass_factors(red.shapes[:, :4], red.omega2[:4], kj, mj, dl)
    assert dm[0] == pytest.approx(true_dm, rel=0.02)
    assert dk[0] == pytest.approx(true_dk, rel=0.05)
    assert np.all(b < 0) and np.all(a > 0)


def test_table6_block_method(stage):
    res = {(r.configuration, r.method): r for r in stage.local_added_mass}
    large, small = res["larger_tank", "block"], res["smaller_tank", "block"]
    assert large.delta_m[0] == pytest.approx(paper.TABLE6["larger_tank"]["delta_m"], rel=0.05)
    assert small.delta_m[0] == pytest.approx(paper.TABLE6["smaller_tank"]["delta_m"], rel=0.05)
    assert abs(large.delta_k[0]) <= 0.005 and abs(small.delta_k[0]) <= 0.005
    assert large.delta_m[0] > small.delta_m[0]
    np.testing.assert_array_equal(large.mode, [1, 2, 3, 4])
    # omega_r in B (eq. 16) is the updated FE model's, Delta_lambda the measured one
    np.testing.assert_allclose(large.omega2, stage.reduced.omega2[:4])
    meas = _measured()
    np.testing.assert_allclose(
        large.delta_lambda,
        (2 * np.pi) ** 2 * (meas["larger_tank"].fn_hz ** 2 - meas["genuine"].fn_hz ** 2),
    )
    assert np.all(large.delta_lambda < 0)


def test_table6_projected_method_is_reported(stage):
    res = {(r.configuration, r.method): r for r in stage.local_added_mass}
    for cfg in ("larger_tank", "smaller_tank"):
        r = res[cfg, "projected"]
        assert 0.15 < r.delta_m[0] < 0.35  # same order as block, a different value
        assert r.delta_m[0] != pytest.approx(res[cfg, "block"].delta_m[0], rel=0.05)


def test_too_many_modified_elements_is_an_error():
    meas = _measured()
    with pytest.raises(DataError, match="half the number of measured modes"):
        am.local_added_mass(Beam(), meas["genuine"], meas["larger_tank"],
                            immersed_elements=(8, 9, 10))
    with pytest.raises(DataError, match="half the number of measured modes"):
        fe_stage.run_fe_stage(Beam(), meas, immersed_elements=(8, 9, 10), progress=False)
    # two elements with four modes is allowed (2 * 2 <= 4)
    r = am.local_added_mass(Beam(), meas["genuine"], meas["larger_tank"],
                            immersed_elements=(9, 10))
    assert r.delta_m.shape == (2,)


def test_missing_modified_mode_reduces_usable_modes():
    meas = _measured()
    w = meas["larger_tank"]
    w3 = ModalParameters(fn_hz=w.fn_hz[[0, 2, 3]], zeta=w.zeta[[0, 2, 3]],
                         configuration="larger_tank")
    r = am.local_added_mass(Beam(), meas["genuine"], w3)
    np.testing.assert_array_equal(r.mode, [1, 3, 4])
    with pytest.raises(DataError, match="half"):
        am.local_added_mass(Beam(), meas["genuine"], w3, immersed_elements=(9, 10))


def test_unknown_element_or_method():
    meas = _measured()
    with pytest.raises(DataError, match="element 11"):
        am.local_added_mass(Beam(), meas["genuine"], meas["larger_tank"], immersed_elements=(11,))
    with pytest.raises(DataError, match="method"):
        am.local_added_mass(Beam(), meas["genuine"], meas["larger_tank"], method="lumped")


# --- the whole stage and its tables -----------------------------------------
def test_fe_stage_tables_forms(stage):
    tables = fe_stage.fe_stage_tables(stage)
    assert set(tables) == set(am.TABLE_COLUMNS)
    for name, cols in am.TABLE_COLUMNS.items():
        assert tuple(tables[name].columns[: len(cols)]) == cols, name
    t2 = tables["table2_modal_added_mass"]
    assert len(t2) == 8 and t2["added_mass_ratio"].max() < 1  # ratios, not percent
    for cfg in ("larger_tank", "smaller_tank"):
        got = t2.query("configuration == @cfg").sort_values("mode")["added_mass_ratio"]
        np.testing.assert_allclose(got, paper.TABLE2_RATIO[cfg], atol=6e-4)
    np.testing.assert_allclose(tables["table3_fe_initial"]["fn_hz"], paper.TABLE3_FN_HZ,
                               atol=0.005)
    t4 = tables["table4_updated_parameters"]
    assert list(t4["parameter"][:5]) == ["thickness", "width", "length", "youngs_modulus",
                                         "density"]
    ident = t4[t4["identifiable"]].iloc[0]
    assert ident["parameter"] == fe.IDENTIFIABLE_NAME
    assert ident["lower"] < ident["updated"] < ident["upper"]
    t5 = tables["table5_fe_updated"]
    assert abs(t5["fn_hz"].iloc[0] - 18.14) < 0.02
    assert fe.update_objective(t5["fn_hz"].to_numpy(), t5["fn_measured_hz"].to_numpy()) <= 0.052
    t6 = tables["table6_local_added_mass"]
    # one row per configuration, method and element, methods in the order block, projected, exact
    assert t6["method"].tolist() == ["block", "projected", "exact"] * 2
    assert (t6["element"] == 10).all() and (t6["status"] == "ok").all()
    exact = t6[t6["method"] == "exact"].set_index("configuration")["delta_m"]
    assert 0.40 < exact["larger_tank"] < 0.43 and 0.34 < exact["smaller_tank"] < 0.38
    assert t2["added_mass_ratio_fe"].notna().all()


def test_fe_stage_requires_genuine():
    meas = _measured()
    del meas["genuine"]
    with pytest.raises(DataError, match="genuine"):
        fe_stage.run_fe_stage(Beam(), meas, progress=False)
