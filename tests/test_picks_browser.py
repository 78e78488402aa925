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

pytestmark = needs_browser


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    with chromium(tmp_path_factory.mktemp("chromium-profile"), width=1100) as driver:
        yield driver


@pytest.fixture(scope="module")
def automatic(beam_report) -> Path:
    """``identify --report --no-figures --geometry`` of the measured beam: the
    session's run (conftest.py, ``beam_report``)."""
    return beam_report


def _click(driver, element) -> None:
    # a click as the user makes it, on the element itself (SVG elements are tiny)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", element)
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(driver).move_to_element(element).click().perform()


def _attributes(driver, selector: str, name: str, root=None) -> list[str | None]:
    """The attribute ``name`` of every element matching ``selector`` (under
    ``root``, else in the page), in document order as ``find_elements`` lists
    them, in one WebDriver command: one ``get_attribute`` per element takes
    about 25 ms, and the beam's diagram has about 2500 poles."""
    return driver.execute_script(
        "return Array.from((arguments[2] || document).querySelectorAll(arguments[0]),"
        " e => e.getAttribute(arguments[1]))", selector, name, root)


def _texts(driver, selector: str) -> list[str]:
    """The text the browser shows of every element matching ``selector`` (as
    ``WebElement.text``: whitespace collapsed, empty when not rendered), in one
    WebDriver command (one per element takes about 20 ms)."""
    return driver.execute_script(
        "return Array.from(document.querySelectorAll(arguments[0]), e =>"
        " e.getClientRects().length ? e.innerText.replace(/\\s+/g, ' ').trim() : '')",
        selector)


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
    assert "Hz" in info and "ζ" in info and "MPC" in info
    # deselect the kept mode nearest 155 Hz (isolated: far from 274.6 Hz)
    drop = selected[int(np.argmin(np.abs(f_sel - 155.0)))]
    f_drop = float(drop.get_attribute("data-freq-hz"))
    _click(browser, drop)
    assert "selected" not in drop.get_attribute("class")
    # add the stable pole nearest 274.6 Hz
    stable_css = '.pole[data-stable="1"]:not(.mode)'
    stable = browser.find_elements(By.CSS_SELECTOR, stable_css)
    f_st = np.array([float(f) for f in _attributes(browser, stable_css, "data-freq-hz")])
    assert f_st.size == len(stable)
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


def _range(root) -> tuple[float, float]:
    return float(root.get_attribute("data-x-min-hz")), float(root.get_attribute("data-x-max-hz"))


def _tick_values(driver) -> list[str]:
    return _attributes(driver, "[data-axis-tick]", "data-axis-tick")


def _round_ticks(labels: list[str]) -> None:
    """Every label a plain decimal, the steps equal and 1, 2 or 5 times a power of ten."""
    import re

    assert len(labels) >= 3
    assert all(re.fullmatch(r"-?\d+(\.\d+)?", t) for t in labels), labels
    v = np.array([float(t) for t in labels])
    steps = np.diff(v)
    assert np.allclose(steps, steps[0], rtol=1e-9)
    lead = steps[0] / 10.0 ** np.floor(np.log10(steps[0]))
    assert min(abs(lead - m) for m in (1.0, 2.0, 5.0)) < 1e-9, steps[0]
    assert np.allclose(v / steps[0], np.round(v / steps[0]), atol=1e-9)


def test_diagram_zoom_overlay_preview_ticks_legend(browser, automatic, real_uff):
    """Zoom with the buttons, the wheel and a drag; the sum FRF under the poles;
    a diamond's preview gives the table's frequency and a 30-DOF shape; the
    ticks are round; the legend lists only the classes drawn; the diamonds sit
    at the refined frequencies of the modes table."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    modes = pd.read_csv(automatic / f"{real_uff.stem}_modes.csv")
    browser.get((automatic / f"{real_uff.stem}_report.html").as_uri())
    root = browser.find_element(By.CSS_SELECTOR, "[data-diagram]")
    lo, hi = _range(root)
    assert (lo, hi) == (5.0, 1024.0)  # the identification band of the beam
    _round_ticks(_tick_values(browser))
    # the sum FRF of the band is drawn: one point per line (>= 1000 in the band)
    overlay = root.find_element(By.CSS_SELECTOR, "svg [data-frf-overlay]")
    n_full = overlay.get_attribute("d").count("L")
    assert n_full > 1000
    # zoom in on the centre: half the width, the centre kept, the ticks round again
    root.find_element(By.CSS_SELECTOR, "[data-zoom-in]").click()
    a, b = _range(root)
    assert b - a == pytest.approx((hi - lo) / 2, rel=1e-9)
    assert a < (lo + hi) / 2 < b
    _round_ticks(_tick_values(browser))
    # the overlay is redrawn for the range: fewer lines
    assert 0.4 * n_full < overlay.get_attribute("d").count("L") < 0.6 * n_full
    poles = root.find_elements(By.CSS_SELECTOR, "circle.pole")
    f_poles = [float(f) for f in _attributes(browser, "circle.pole", "data-freq-hz", root)]
    assert len(f_poles) == len(poles)
    hidden = [p for p, f in zip(poles[:400], f_poles[:400], strict=True) if not a <= f <= b]
    assert hidden and not any(p.is_displayed() for p in hidden[:20])
    root.find_element(By.CSS_SELECTOR, "[data-zoom-out]").click()
    assert _range(root) == pytest.approx((lo, hi))
    # the wheel zooms around the pointer, a drag pans
    svg = root.find_element(By.CSS_SELECTOR, "svg.stab")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", svg)
    ActionChains(browser).scroll_from_origin(
        __import__("selenium.webdriver.common.actions.wheel_input",
                   fromlist=["ScrollOrigin"]).ScrollOrigin.from_element(svg), 0, -100).perform()
    a, b = _range(root)
    assert b - a == pytest.approx(0.8 * (hi - lo), rel=1e-6)
    ActionChains(browser).move_to_element(svg).click_and_hold().move_by_offset(
        -200, 0).release().perform()
    a2, b2 = _range(root)
    assert b2 - a2 == pytest.approx(b - a, rel=1e-6) and a2 > a + 50
    root.find_element(By.CSS_SELECTOR, "[data-zoom-reset]").click()
    assert _range(root) == (lo, hi)
    # the diamonds at the refined frequencies of the table (not the start poles)
    diamonds = root.find_elements(By.CSS_SELECTOR, "polygon.pole.mode")
    x_hz = np.sort([float(p.get_attribute("data-x-hz")) for p in diamonds])
    assert np.allclose(x_hz, np.sort(modes["fn_hz"].to_numpy()), atol=5e-4)
    # a click on the diamond of the mode nearest 155 Hz (isolated; 118.0 and
    # 119.4 Hz overlap at full width): its values and its shape
    k = int(np.argmin(np.abs(modes["fn_hz"].to_numpy() - 155.0)))
    target = next(p for p in diamonds
                  if abs(float(p.get_attribute("data-x-hz")) - modes["fn_hz"][k]) < 5e-4)
    _click(browser, target)
    preview = root.find_element(By.CSS_SELECTOR, "[data-pole-preview]")
    assert preview.is_displayed()
    shown = float(preview.find_element(By.CSS_SELECTOR, "[data-preview-freq-hz]")
                  .get_attribute("data-preview-freq-hz"))
    assert shown == pytest.approx(modes["fn_hz"][k], abs=5e-4)
    assert f"{modes['fn_hz'][k]:.3f} Hz" in preview.text and "MPC" in preview.text
    bars = preview.find_elements(By.CSS_SELECTOR, "svg[data-shape] rect")
    assert len(bars) == 30  # one bar per measured DOF of the beam
    # --no-figures: no animated views on the page, so no button to show one
    assert not preview.find_elements(By.CSS_SELECTOR, "[data-show-shape]")
    # the legend: only the stability classes that are drawn
    drawn = {int(c.split(" s")[1][0]) for c in _attributes(browser, "circle.pole", "class", root)}
    listed = {int(e.get_attribute("data-legend"))
              for e in root.find_elements(By.CSS_SELECTOR, "[data-legend]")
              if e.get_attribute("data-legend").isdigit()}
    assert listed == drawn


def test_beam_page_speaks_words(browser, automatic, real_uff):
    """The measured beam's identify page as the browser shows it: table headers in
    words (no snake_case), no code names in the text, the doubtful rules in words."""
    import re

    from selenium.webdriver.common.by import By

    browser.get((automatic / f"{real_uff.stem}_report.html").as_uri())
    headers = [h for h in _texts(browser, "th") if h]
    assert "f (Hz)" in headers and "ζ (%)" in headers and "fit error (%)" in headers
    assert not [h for h in headers if re.fullmatch(r"[a-z0-9]+(_[a-z0-9]+)+", h)], headers
    shown = browser.find_element(By.TAG_NAME, "body").text
    assert not re.search(r"ema_pipeline\.|report\.wording|FIT_LIMITS|modal\.mac|"
                         r"identification\.result", shown)
    cells = _texts(browser, "#modes td")
    assert not [c for c in cells if re.fullmatch(r"[a-z]+(_[a-z]+)+", c)], cells
