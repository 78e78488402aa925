"""The animated mode shapes move in a real browser (headless Chromium through
Selenium, as tests/test_report_browser.py): two screenshots of a shape view
0.3 s apart differ, in the identify report and in the run report. Skipped
without chromium / chromium-driver / selenium."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.data import Beam

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
from tests.browser import chromium, needs_browser  # noqa: E402

pytestmark = needs_browser


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    with chromium(tmp_path_factory.mktemp("chromium-profile"), width=1000) as driver:
        yield driver


def _frames(driver, page: Path) -> tuple[int, bytes, bytes, list[str]]:
    """Open ``page``: its number of shape views, two screenshots of the first one
    0.3 s apart, and the URLs it requested from outside the file."""
    from selenium.webdriver.common.by import By

    driver.get(page.as_uri())
    views = driver.find_elements(By.CSS_SELECTOR, "[data-mode-shape]")
    if not views:
        return 0, b"", b"", []
    view = views[0]
    driver.execute_script("arguments[0].scrollIntoView()", view)
    time.sleep(0.2)
    first = view.screenshot_as_png
    time.sleep(0.3)
    later = view.screenshot_as_png
    urls = driver.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name)")
    return len(views), first, later, [u for u in urls if not u.startswith("file:")]


def test_shapes_move_in_the_identify_report(browser, tmp_path, three_sensor_h5):
    # three sensors: the shipped example's two make shapes of two points, not drawn
    geometry = io.write_geometry_uff(Beam().measurement_geometry(), tmp_path / "beam.uff")
    assert main(["identify", str(three_sensor_h5), "--out", str(tmp_path),
                 "--report", "--quiet", "--geometry", str(geometry)]) == 0
    n_views, first, later, external = _frames(
        browser, tmp_path / f"{three_sensor_h5.stem}_report.html")
    assert n_views > 0 and later != first, "the shape does not move"
    assert external == []  # nothing was requested from outside the file


def test_shapes_move_in_the_run_report(browser, example_study):
    n_views, first, later, external = _frames(browser, example_study / "report.html")
    assert n_views > 0 and later != first, "the shape does not move"
    assert external == []  # nothing was requested from outside the file


def test_pole_preview_brings_the_mode_view_into_sight(browser, tmp_path, three_sensor_h5):
    """Clicking a kept mode's diamond in the stabilization diagram: its preview
    holds a button that scrolls that mode's animated view on the geometry into
    the window."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    geometry = io.write_geometry_uff(Beam().measurement_geometry(), tmp_path / "beam.uff")
    assert main(["identify", str(three_sensor_h5), "--out", str(tmp_path),
                 "--report", "--quiet", "--geometry", str(geometry)]) == 0
    browser.get((tmp_path / f"{three_sensor_h5.stem}_report.html").as_uri())
    diamond = browser.find_elements(By.CSS_SELECTOR, 'polygon.pole.mode[data-mode="2"]')[0]
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", diamond)
    ActionChains(browser).move_to_element(diamond).click().perform()
    view = browser.find_element(By.CSS_SELECTOR, '[data-mode-shape="2"]')
    inside = ("var r=arguments[0].getBoundingClientRect();"
              "return r.top >= 0 && r.bottom <= window.innerHeight;")
    assert not browser.execute_script(inside, view)  # the diagram is far above the views
    browser.find_element(By.CSS_SELECTOR, '[data-pole-preview] [data-show-shape="2"]').click()
    assert browser.execute_script(inside, view)


def test_two_sensor_preview_draws_no_shape(browser, tmp_path, example_dir):
    """The shipped example (two sensors): a diamond's preview gives its values
    and says why no shape is drawn, with no shape bars (issue 41)."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    assert main(["identify", str(example_dir / "genuine.uff"), "--out", str(tmp_path),
                 "--report", "--quiet", "--no-figures"]) == 0
    browser.get((tmp_path / "genuine_report.html").as_uri())
    diamond = browser.find_elements(By.CSS_SELECTOR, 'polygon.pole.mode[data-mode="2"]')[0]
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", diamond)
    ActionChains(browser).move_to_element(diamond).click().perform()
    preview = browser.find_element(By.CSS_SELECTOR, "[data-pole-preview]")
    assert "MPC" in preview.text
    assert "2 measured points only: no shape is drawn" in preview.text
    assert not preview.find_elements(By.CSS_SELECTOR, "svg[data-shape]")


def test_pole_preview_animates_the_mode_on_the_geometry(browser, tmp_path, three_sensor_h5):
    """Clicking a kept mode's diamond previews its shape, animated on the test
    geometry, in the preview itself (two frames 0.3 s apart differ), and picks
    nothing; the views of the mode shapes section still move."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    geometry = io.write_geometry_uff(Beam().measurement_geometry(), tmp_path / "beam.uff")
    assert main(["identify", str(three_sensor_h5), "--out", str(tmp_path),
                 "--report", "--quiet", "--geometry", str(geometry)]) == 0
    page = tmp_path / f"{three_sensor_h5.stem}_report.html"
    browser.get(page.as_uri())
    count = browser.find_element(By.CSS_SELECTOR, ".stabd .npicks").text
    view = browser.find_element(By.CSS_SELECTOR, "[data-pole-preview] [data-preview-shape]")
    assert not view.is_displayed()  # nothing previewed yet
    diamond = browser.find_elements(By.CSS_SELECTOR, 'polygon.pole.mode[data-mode="2"]')[0]
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", diamond)
    ActionChains(browser).move_to_element(diamond).click().perform()
    assert browser.find_element(By.CSS_SELECTOR, ".stabd .npicks").text == count
    assert view.is_displayed() and view.get_attribute("data-key") == "1"
    f_hz = float(diamond.get_attribute("data-x-hz"))
    assert view.text.startswith(f"Mode 2: {f_hz:.2f} Hz")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", view)
    time.sleep(0.2)
    first = view.screenshot_as_png
    time.sleep(0.3)
    assert view.screenshot_as_png != first, "the previewed shape does not move"
    n_views, first, later, _ = _frames(browser, page)
    assert n_views > 0 and later != first, "the section's shape does not move"
