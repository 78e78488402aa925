"""The study report in a real browser (headless Chromium through Selenium):
no table wider than the page at 800 px and in print layout, every image loads.

Needs the system's ``chromium`` and ``chromium-driver`` (Debian packages; a
browser downloaded at install time cannot be fetched here) and ``selenium``
(the ``test`` extra); skipped with the reason where they are missing.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from ema_pipeline.cli import main

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
from tests.browser import chromium, needs_browser  # noqa: E402

#: A4 (210 mm) less the print style sheet's 14 mm margins, in CSS px (96 per inch).
PRINT_WIDTH_PX = round((210 - 2 * 14) / 25.4 * 96)

pytestmark = needs_browser

# Per table: its width against the page's content width and whether its
# scrolling wrapper would have to scroll. Per image and figure: loaded and drawn.
LAYOUT_JS = """
const page = document.documentElement.clientWidth;
const tables = [...document.querySelectorAll('table')].map((t, k) => {
  const r = t.getBoundingClientRect();
  const wrap = t.closest('.tablewrap');
  return {k: k, caption: (t.caption || t.querySelector('th') || {}).textContent || '',
          right: r.right, width: r.width,
          scrolls: wrap ? wrap.scrollWidth > wrap.clientWidth + 1 : false};
});
const images = [...document.images].map(i => ({src: i.src.slice(0, 60),
  ok: i.complete && i.naturalWidth > 0}));
const figures = [...document.querySelectorAll('svg.fig')].map(s => {
  const r = s.getBoundingClientRect();
  return {label: s.getAttribute('aria-label'), width: r.width, right: r.right,
          drawn: s.querySelectorAll('path').length};
});
return {page: page, scroll: document.documentElement.scrollWidth, tables: tables,
        images: images, figures: figures, print: window.matchMedia('print').matches};
"""


@pytest.fixture(scope="module")
def report(example_study: Path) -> Path:
    """The report of ``ema-pipeline run`` on the shipped example (shared, read only)."""
    return example_study / "report.html"


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    with chromium(tmp_path_factory.mktemp("chromium-profile"), width=800) as driver:
        yield driver


def _layout(driver, url: str, width: int, media: str) -> dict:
    driver.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": media})
    driver.execute_cdp_cmd(
        "Emulation.setDeviceMetricsOverride",
        {"width": width, "height": 1000, "deviceScaleFactor": 1, "mobile": False},
    )
    driver.get(url)
    return driver.execute_script(LAYOUT_JS)


def _check(layout: dict, width: int) -> None:
    assert layout["page"] <= width
    assert layout["scroll"] <= layout["page"], "the page scrolls sideways"
    assert len(layout["tables"]) >= 20
    too_wide = [t for t in layout["tables"] if t["right"] > layout["page"] + 1 or t["scrolls"]]
    assert too_wide == [], too_wide
    assert all(i["ok"] for i in layout["images"]), layout["images"]
    assert len(layout["figures"]) >= 14
    for fig in layout["figures"]:
        assert 100 < fig["width"] and fig["right"] <= layout["page"] + 1, fig
        assert fig["drawn"] >= 2, fig  # frame and data


def test_report_fits_an_800_px_window(browser, report):
    layout = _layout(browser, report.as_uri(), 800, "screen")
    assert not layout["print"]
    _check(layout, 800)


def test_report_fits_the_printed_page(browser, report):
    layout = _layout(browser, report.as_uri(), PRINT_WIDTH_PX, "print")
    assert layout["print"]  # the print style sheet is in force
    _check(layout, PRINT_WIDTH_PX)


@pytest.fixture(scope="module")
def other_pages(tmp_path_factory, example_dir) -> list[Path]:
    """``identify --report`` of one file, ``batch --report`` with a broken file and
    the batch's page of one file."""
    tmp = tmp_path_factory.mktemp("pages")
    h5 = example_dir / "larger_tank.h5"
    assert main(["identify", str(h5), "--out", str(tmp / "id"), "--report", "--quiet"]) == 0
    src = tmp / "in"
    src.mkdir()
    for name in ("genuine.uff", "larger_tank.h5"):
        shutil.copy(example_dir / name, src / name)
    (src / "broken.h5").write_bytes(b"not an HDF5 file")
    assert main(["batch", str(src), "--out", str(tmp / "b"), "--workers", "1", "--report",
                 "--quiet"]) == 1
    return [tmp / "id" / "larger_tank_report.html", tmp / "b" / "report.html",
            tmp / "b" / "genuine_report.html"]


@pytest.mark.parametrize(("width", "media"), [(800, "screen"), (PRINT_WIDTH_PX, "print")])
def test_identify_and_batch_pages_fit(browser, other_pages, width, media):
    # the identify pages: FRF, stabilization, fit (two sensors: no shape figure)
    for page, n_figures in zip(other_pages, (3, 1, 3), strict=True):
        layout = _layout(browser, page.as_uri(), width, media)
        assert layout["scroll"] <= layout["page"], page
        too_wide = [t for t in layout["tables"]
                    if t["right"] > layout["page"] + 1 or t["scrolls"]]
        assert too_wide == [], (page, too_wide)
        assert len(layout["figures"]) == n_figures
        assert all(f["width"] > 100 and f["drawn"] >= 2 for f in layout["figures"])


def test_batch_links_each_file_page_whose_diagram_draws_and_picks(browser, other_pages):
    """From the batch page to each file's page (broken.h5 has none) and back; on the
    page the script draws one ``text.pole`` per pole of the diagram's JSON and
    opens with one selected pole per mode of the file's ``_modes.csv``, all in
    ``#picks``."""
    import json

    import pandas as pd
    from selenium.webdriver.common.by import By

    batch_page = other_pages[1]
    browser.get(batch_page.as_uri())
    links = {a.text: a.get_attribute("href")
             for a in browser.find_elements(By.CSS_SELECTOR, "a.file-page")}
    assert sorted(links) == ["genuine.uff", "larger_tank.h5"]
    for name, href in links.items():
        browser.get(href)
        n_modes = len(pd.read_csv(batch_page.parent / f"{Path(name).stem}_modes.csv"))
        poles = json.loads(browser.find_element(By.CSS_SELECTOR, "script.stab-poles")
                           .get_attribute("textContent"))
        drawn = browser.find_elements(By.CSS_SELECTOR, "g.diagram-poles text.pole")
        assert len(drawn) == len(poles["f"]) > 100
        assert len(browser.find_elements(By.CSS_SELECTOR, ".pole.selected")) == n_modes
        picks = browser.find_element(By.ID, "picks").get_attribute("textContent")
        assert picks.count("[[pick]]") == n_modes  # (hidden in print media: textContent)
        back = browser.find_element(By.CSS_SELECTOR, "a.batch-page").get_attribute("href")
        assert back == batch_page.as_uri()


#: Every element of ``#mac`` and ``#picks`` whose content is wider than its
#: box (hidden behind a scroll bar or cut), and how the AutoMAC's last column
#: and the picks' longest line sit in their boxes.
HIDDEN_JS = """
const out = {hidden: [], mac: null, picks: null};
for (const sel of ['#mac', '#picks']) {
  const root = document.querySelector(sel);
  for (const e of [root, ...root.querySelectorAll('*')]) {
    if (e.clientWidth > 0 && e.scrollWidth > e.clientWidth)
      out.hidden.push(sel + ' ' + e.tagName + '.' + e.className + ' ' + e.scrollWidth + '>'
                      + e.clientWidth);
  }
}
const mac = document.querySelector('#mac table.mac'), box = document.querySelector('#mac');
const cells = mac.querySelectorAll('thead th');
out.mac = {columns: cells.length, right: cells[cells.length - 1].getBoundingClientRect().right,
           box: box.getBoundingClientRect().right};
const picks = document.querySelector('#picks');
out.picks = {wrap: getComputedStyle(picks).whiteSpace,
             orders: picks.textContent.split('\\n').some(l => l.startsWith('orders = ['))};
return out;
"""


def test_beam_page_hides_nothing_at_1400_px(browser, beam_report, real_uff):
    """The measured beam's 19 x 19 AutoMAC fits its box (its last column in
    view, no scroll bar) and the picks text wraps its long ``orders = [...]``
    line, in a 1400 px window."""
    _layout(browser, (beam_report / f"{real_uff.stem}_report.html").as_uri(), 1400, "screen")
    got = browser.execute_script(HIDDEN_JS)
    assert got["hidden"] == []
    assert got["mac"]["columns"] == 20  # the row labels' column and 19 modes
    assert got["mac"]["right"] <= got["mac"]["box"] + 0.5, got["mac"]
    assert got["picks"] == {"wrap": "pre-wrap", "orders": True}
