"""Choosing hits by hand on the hit page in a real browser (headless Chromium through
Selenium, as tests/test_picks_browser.py): the page opens with the checks' choice,
untick a hit, the plot and the TOML follow, and `frf --hits` on the downloaded text
reproduces that choice. Skipped without chromium / chromium-driver / selenium."""

from __future__ import annotations

import pandas as pd
import pytest
from test_channel_sheet import write_plate_test

from ema_pipeline import io
from ema_pipeline.cli import main
from ema_pipeline.io.hit_choice import read_hit_choice

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
from browser import chromium, needs_browser  # noqa: E402

pytestmark = needs_browser


def test_choose_hits_on_the_page(tmp_path):
    from selenium.webdriver.common.by import By

    plate = tmp_path / "plate"
    plate.mkdir()
    write_plate_test(plate, double_hit_point=6)
    sheet = tmp_path / "channels.csv"
    sheet.write_text("file,channel,role,node,direction,scale,unit\n" + "".join(
        f"plate/p{k}.wav,0,force,{k},-Z,1000,N\nplate/p{k}.wav,1,response,100,+Z,,g\n"
        for k in (5, 6)))
    out = tmp_path / "t.h5"
    assert main(["frf", "--channels", str(sheet), "--out", str(out), "--report",
                 "--quiet"]) == 0
    with chromium(tmp_path / "profile", width=1100) as browser:
        browser.get((tmp_path / "t_hits.html").as_uri())
        boxes = browser.find_elements(By.CSS_SELECTOR, "input.hit-pick")
        assert len(boxes) == 8
        assert [b.is_selected() for b in boxes] == [True] * 5 + [False] + [True] * 2
        plot = browser.find_element(By.CSS_SELECTOR, ".hit-plot")
        assert len(plot.find_elements(By.TAG_NAME, "polyline")) == 7 + 2  # hits, avg, coh
        start = browser.find_element(By.CSS_SELECTOR, ".hit-toml").get_attribute("textContent")
        browser.execute_script("arguments[0].click()", boxes[1])  # untick p5.wav hit 2
        assert len(plot.find_elements(By.TAG_NAME, "polyline")) == 6 + 2
        text = browser.find_element(By.CSS_SELECTOR, ".hit-toml").get_attribute("textContent")
        count = browser.find_element(By.CSS_SELECTOR, ".hit-count").text
    assert count == "6 of 8 hits averaged."
    (tmp_path / "start.toml").write_text(start)
    (tmp_path / "hits.toml").write_text(text)
    assert read_hit_choice(tmp_path / "start.toml") == {"plate/p5.wav": (1, 2, 3, 4),
                                                        "plate/p6.wav": (1, 3, 4)}
    assert read_hit_choice(tmp_path / "hits.toml")["plate/p5.wav"] == (1, 3, 4)
    again = tmp_path / "again.h5"
    assert main(["frf", "--channels", str(sheet), "--out", str(again), "--hits",
                 str(tmp_path / "start.toml"), "--quiet"]) == 0
    assert (io.read_frf(again).H == io.read_frf(out).H).all()  # the page's start: the checks'
    chosen = tmp_path / "chosen.h5"
    assert main(["frf", "--channels", str(sheet), "--out", str(chosen), "--hits",
                 str(tmp_path / "hits.toml"), "--quiet"]) == 0
    hits = pd.read_csv(tmp_path / "chosen_hits.csv")
    assert hits["accepted"].tolist() == [True, False, True, True, True, False, True, True]
