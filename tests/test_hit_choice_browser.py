"""Choosing hits by hand on the hit page in a real browser (headless Chromium through
Selenium, as tests/test_picks_browser.py), on a roving-hammer plate of 12 points
(tests/impact_recordings.py; test_channel_sheet's plate, point 5 with a double hit,
point 7's file starting 3 ms before its first hit): one group of hits per point,
each with the point's own H1 average and coherence; untick a hit and only its point
is redrawn; the downloaded hits.toml run through `frf --hits` reproduces the choice.
Skipped without chromium / chromium-driver / selenium."""

from __future__ import annotations

import json
import re
import time
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.io.hit_choice import read_hit_choice
from tests.impact_recordings import write_plate_test
from tests.test_channel_sheet import plate_test

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
from tests.browser import chromium, needs_browser  # noqa: E402

pytestmark = needs_browser

DOUBLE, LATE = 5, 7  # p5.wav's hit 2 bounces; p7.wav starts 3 ms before its first hit
FILES = [f"rec/p{k}.csv" if k <= 4 else f"p{k}.wav" if k <= 8 else f"p{k}.tdms"
         for k in range(1, 13)]


def _page_data(page: str) -> dict:
    """The spectra the page carries for the choice by hand (its JSON)."""
    blob = re.search(r'<script type="application/json" class="hit-data">(.*?)</script>', page,
                     re.S)
    return json.loads(blob.group(1).replace("<\\/", "</"))


def _h1(point: dict, numbers: set[int]) -> tuple[np.ndarray, np.ndarray]:
    """H1 and coherence of ``point``'s hits ``numbers`` from the page's spectra."""
    hits = [h for h in point["hits"] if h["number"] in numbers]
    sff = np.sum([h["sff"] for h in hits], axis=0)
    sfx = np.sum([np.asarray(h["sfr"]) + 1j * np.asarray(h["sfi"]) for h in hits], axis=0)
    sxx = np.sum([h["sxx"] for h in hits], axis=0)
    return sfx / sff, np.abs(sfx) ** 2 / (sff * sxx)


def _averages(browser, by) -> list[str]:
    """The black average curve of every point, as drawn."""
    return [p.find_element(by.CSS_SELECTOR, ".hit-plot polyline[stroke='#000']")
            .get_attribute("points")
            for p in browser.find_elements(by.CSS_SELECTOR, "[data-hit-choice-point]")]


def test_choose_hits_per_point_on_a_roving_plate(tmp_path):
    from selenium.webdriver.common.by import By

    plate = tmp_path / "plate"
    plate.mkdir()
    write_plate_test(plate, replace(plate_test(double_hit_point=DOUBLE),
                                    late_start=(LATE, 0.003)))
    sheet = plate / "channels.csv"
    out = tmp_path / "t.h5"
    assert main(["frf", "--channels", str(sheet), "--out", str(out), "--report",
                 "--quiet"]) == 0
    page = (tmp_path / "t_hits.html").read_text(encoding="utf-8")
    frf = io.read_frf(out)  # reciprocal: responses = the hammer points 1..12
    data = _page_data(page)
    assert [p["file"] for p in data["points"]] == FILES
    band = np.asarray(data["freq"]) < frf.acquisition.force_band_hz[0]
    lines = np.searchsorted(frf.freq_hz, data["freq"])
    np.testing.assert_allclose(frf.freq_hz[lines], data["freq"], rtol=1e-6)
    rows = [d.node for d in frf.response_dofs]
    for k, point in enumerate(data["points"]):
        # each point's average is that point's FRF (the page's spectra rounded to 6 digits)
        numbers = {4: {1, 3, 4}}.get(k, {1, 2, 3, 4})
        h1, coh = _h1(point, numbers)
        truth = np.abs(frf.H[rows.index(k + 1), 0, lines])
        assert np.abs(np.abs(h1) - truth)[band].max() < 1e-4 * truth[band].max(), point["file"]
        assert np.median(coh[band]) > 0.99, point["file"]
    # the 47 accepted hits of 12 points pooled into one average (the page's old plot)
    pooled = [{"hits": [h for p in data["points"] for h in p["hits"]]}]
    _, coh_all = _h1(pooled[0], {1, 2, 3, 4})
    assert np.median(coh_all[band]) < 0.5

    # the padded hit: its note, on the page and in the hit table
    late = re.search(rf'<section id="hit-\d+"><h2>p{LATE}\.wav, hit 1 at .*?</section>', page,
                     re.S).group(0)
    assert "passed every check" in late
    assert re.search(r"note: near the data start: its record padded with \d+ samples", late)

    with chromium(tmp_path / "profile", width=1100) as browser:
        downloads = tmp_path / "downloads"
        downloads.mkdir()
        browser.execute_cdp_cmd("Page.setDownloadBehavior",
                                {"behavior": "allow", "downloadPath": str(downloads)})
        browser.get((tmp_path / "t_hits.html").as_uri())
        points = browser.find_elements(By.CSS_SELECTOR, "[data-hit-choice-point]")
        assert [p.get_attribute("data-hit-choice-point") for p in points] == FILES
        ticked = [[b.is_selected() for b in p.find_elements(By.CSS_SELECTOR, "input.hit-pick")]
                  for p in points]
        assert ticked == [[True, False, True, True] if k == DOUBLE else [True] * 4
                          for k in range(1, 13)]
        for p in points:  # per point: its hits (grey), its average and its coherence
            drawn = len(p.find_elements(By.CSS_SELECTOR, ".hit-plot polyline"))
            assert drawn == (3 if p.get_attribute("data-hit-choice-point") == "p5.wav"
                             else 4) + 2
        start = browser.find_element(By.CSS_SELECTOR, ".hit-toml").get_attribute("textContent")
        before = _averages(browser, By)
        box = points[2].find_elements(By.CSS_SELECTOR, "input.hit-pick")[1]  # rec/p3.csv hit 2
        browser.execute_script("arguments[0].click()", box)
        after = _averages(browser, By)
        counts = [p.find_element(By.CSS_SELECTOR, ".hit-count").text for p in points]
        browser.find_element(By.CSS_SELECTOR, ".hit-download").click()
        target = downloads / "hits.toml"
        for _ in range(50):
            if target.is_file():
                break
            time.sleep(0.1)
    assert [a != b for a, b in zip(before, after, strict=True)] == [k == 2 for k in range(12)]
    assert counts[2] == "3 of 4 hits averaged." and counts[4] == "3 of 4 hits averaged."
    assert counts[0] == "4 of 4 hits averaged."

    (tmp_path / "start.toml").write_text(start)
    auto = {f: (1, 3, 4) if f == "p5.wav" else (1, 2, 3, 4) for f in FILES}
    assert read_hit_choice(tmp_path / "start.toml") == auto
    assert read_hit_choice(target) == {**auto, "rec/p3.csv": (1, 3, 4)}
    again = tmp_path / "again.h5"
    assert main(["frf", "--channels", str(sheet), "--out", str(again), "--hits",
                 str(tmp_path / "start.toml"), "--quiet"]) == 0
    assert (io.read_frf(again).H == frf.H).all()  # the page's start: the checks' choice
    chosen = tmp_path / "chosen.h5"
    assert main(["frf", "--channels", str(sheet), "--out", str(chosen), "--hits",
                 str(target), "--quiet"]) == 0
    hits = pd.read_csv(tmp_path / "chosen_hits.csv")
    assert hits[hits["file"] == "rec/p3.csv"]["accepted"].tolist() == [True, False, True, True]
    assert int(hits["accepted"].sum()) == 12 * 4 - 2
    new = io.read_frf(chosen)
    changed = [not np.array_equal(new.H[rows.index(k + 1)], frf.H[rows.index(k + 1)])
               for k in range(12)]
    assert changed == [k == 2 for k in range(12)]  # only p3's FRF
    h1, _ = _h1(data["points"][2], {1, 3, 4})  # = the average the page drew after the click
    truth = np.abs(new.H[rows.index(3), 0, lines])
    assert np.abs(np.abs(h1) - truth)[band].max() < 1e-4 * truth[band].max()
