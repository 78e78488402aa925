"""Headless Chromium through Selenium for the browser tests of the reports: one
home for finding the browser and starting it. The tests using it import
selenium with ``pytest.importorskip`` first and mark themselves with
:data:`needs_browser`, so they are skipped with the reason where chromium,
chromium-driver or selenium is missing."""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")

#: ``pytestmark = needs_browser`` skips a module without a headless browser.
needs_browser = pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None,
    reason="no headless browser: install the system packages chromium and chromium-driver",
)


@contextlib.contextmanager
def chromium(profile: Path, width: int = 1000, height: int = 1000) -> Iterator[object]:
    """A headless Chromium WebDriver with its own profile folder and window size."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run",
                f"--user-data-dir={profile}", f"--window-size={width},{height}"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    driver.set_page_load_timeout(60)
    try:
        yield driver
    finally:
        driver.quit()
