"""Picking modes by hand in a real browser (headless Chromium through Selenium, as
tests/test_report_browser.py) on the measured beam with its geometry: deselect
one kept mode, add the stable pole nearest 274.6 Hz, copy ``#picks`` into a
file, ``identify --picks`` it. Skipped without chromium / chromium-driver /
selenium or without the measured data (../shared/data)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline.cli import main

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
from browser import chromium, needs_browser  # noqa: E402

GEOMETRY = Path(__file__).resolve().parents[1] / "examples" / "ufsc-beam-geometry.uff"

pytestmark = needs_browser


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    with chromium(tmp_path_factory.mktemp("chromium-profile"), width=1100) as driver:
        yield driver


@pytest.fixture(scope="module")
def automatic(tmp_path_factory, real_uff) -> Path:
    """``identify --report --geometry`` of the measured beam, once per module (~10 s)."""
    if not GEOMETRY.is_file():
        pytest.skip(f"the beam's geometry {GEOMETRY} is not there")
    out = tmp_path_factory.mktemp("auto")
    assert main(["identify", str(real_uff), "--out", str(out), "--report", "--no-figures",
                 "--geometry", str(GEOMETRY), "--quiet"]) == 0
    return out


def _click(driver, element) -> None:
    # a click as the user makes it, on the element itself (SVG elements are tiny)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", element)
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(driver).move_to_element(element).click().perform()


def test_pick_by_hand_in_the_browser(browser, automatic, real_uff, tmp_path):
    from selenium.webdriver.common.by import By

    auto = pd.read_csv(automatic / f"{real_uff.stem}_modes.csv")["fn_hz"].to_numpy()
    page = automatic / f"{real_uff.stem}_report.html"
    browser.get(page.as_uri())
    selected = browser.find_elements(By.CSS_SELECTOR, ".pole.selected")
    f_sel = np.array([float(p.get_attribute("data-freq-hz")) for p in selected])
    # the page opens with every kept mode picked
    assert f_sel.size == auto.size
    assert np.allclose(np.sort(f_sel), auto, rtol=1e-2)  # start poles, before refinement
    # hover shows f, zeta and MPC
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", selected[0])
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(browser).move_to_element(selected[0]).perform()
    info = browser.find_element(By.CSS_SELECTOR, ".stabd .info").text
    assert "Hz" in info and "zeta" in info and "MPC" in info
    # deselect the kept mode nearest 155 Hz (isolated: far from 274.6 Hz)
    drop = selected[int(np.argmin(np.abs(f_sel - 155.0)))]
    f_drop = float(drop.get_attribute("data-freq-hz"))
    _click(browser, drop)
    assert "selected" not in drop.get_attribute("class")
    # add the stable pole nearest 274.6 Hz
    stable = browser.find_elements(By.CSS_SELECTOR, '.pole[data-stable="1"]:not(.mode)')
    f_st = np.array([float(p.get_attribute("data-freq-hz")) for p in stable])
    add = stable[int(np.argmin(np.abs(f_st - 274.6)))]
    f_add = float(add.get_attribute("data-freq-hz"))
    assert abs(f_add - 274.6) < 1.5
    _click(browser, add)
    assert "selected" in add.get_attribute("class")
    # copy #picks into a file (the copy button must not fail; the text is the element's)
    browser.find_element(By.CSS_SELECTOR, ".stabd .copy-picks").click()
    text = browser.find_element(By.ID, "picks").get_attribute("textContent")
    assert text.count("[[pick]]") == auto.size
    picks = tmp_path / "picks.toml"
    picks.write_text(text, encoding="utf-8")
    out = tmp_path / "picked"
    assert main(["identify", str(real_uff), "--out", str(out), "--picks", str(picks),
                 "--report", "--no-figures", "--quiet"]) == 0
    got = pd.read_csv(out / f"{real_uff.stem}_modes.csv")["fn_hz"].to_numpy()
    assert got.size == auto.size
    # a mode within 1.5 Hz of 274.6 Hz, none at the deselected one
    assert np.min(np.abs(got - 274.6)) < 1.5
    assert np.min(np.abs(got - f_drop)) > 0.01 * f_drop
    # the other kept modes unchanged within 0.1 %
    others = auto[np.abs(auto - f_drop) > 0.01 * f_drop]
    nearest = got[np.argmin(np.abs(got[None, :] - others[:, None]), axis=1)]
    assert np.max(np.abs(nearest / others - 1)) < 1e-3
    # the report marks the picked modes
    picked_page = (out / f"{real_uff.stem}_report.html").read_text(encoding="utf-8")
    assert picked_page.count(">picked<") == got.size
