"""The picks file has one layout, ``ema_pipeline.io.picks``: the io writer and
reader agree with each other, refuse what the layout does not hold, and the
report page's script (the JavaScript writer of the interactive diagram)
writes the same layout: its constants are io's, and in headless Chromium the
text it writes reads back through the io reader field by field (the browser
part is skipped without chromium / chromium-driver / selenium)."""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import replace

import numpy as np
import pytest

from ema_pipeline import io
from ema_pipeline.data import DataError
from ema_pipeline.identification import identify
from ema_pipeline.identification.picked import Pick, Picks
from ema_pipeline.identification.selection.picks import picks_from_result
from ema_pipeline.io.picks import (
    COMPANIONS_COMMENT,
    DIAGRAM_KEYS,
    HEADER,
    PICK_KEYS,
    PICKS_VERSION,
    picks_from_mapping,
    picks_toml,
)
from ema_pipeline.report.stab_diagram import stab_diagram_html
from tests.browser import CHROMEDRIVER, CHROMIUM, chromium
from tests.test_picks import simulated

#: A companion put into the plate's result so that the page writes that line too.
COMPANION = complex(-3.0, 2 * np.pi * 120.0)


def _same(got: Picks, want: Picks) -> None:
    """``got`` holds ``want``'s settings and picks, float for float (NaN = NaN)."""
    assert got.band_hz == want.band_hz and got.orders == want.orders
    assert got.weighting == want.weighting and got.companions == want.companions
    assert len(got.picks) == len(want.picks)
    for a, b in zip(got.picks, want.picks, strict=True):
        assert a.freq_hz == b.freq_hz and a.order == b.order and a.pole == b.pole, (a, b)
        assert a.zeta == b.zeta or (math.isnan(a.zeta) and math.isnan(b.zeta)), (a, b)


def test_io_writer_and_reader_agree():
    """Every field survives ``picks_toml`` -> TOML -> ``picks_from_mapping``:
    diagram and mode picks, a NaN damping, companions, the coherence
    weighting; the text starts with the header and the version."""
    picks = Picks(band_hz=(5.0, 790.25), orders=(2, 4, 64),
                  picks=(Pick(18.123456789, 0.0049, order=64),
                         Pick(112.5, float("nan"), pole=complex(-1.234567, 706.8583))),
                  weighting="coherence", companions=(COMPANION, complex(-0.5, 3000.0)))
    text = picks_toml(picks)
    assert text.startswith("\n".join(HEADER) + f"\nversion = {PICKS_VERSION}\n\n[diagram]")
    _same(picks_from_mapping(tomllib.loads(text)), picks)


def test_a_file_without_version_is_version_1(tmp_path):
    """Files written before the ``version`` key read as version 1."""
    text = picks_toml(Picks((5.0, 100.0), (2, 4), (Pick(30.0, 0.01, order=4),)))
    old = tmp_path / "old.toml"
    old.write_text(text.replace(f"version = {PICKS_VERSION}\n", ""), encoding="utf-8")
    assert "version" not in old.read_text()
    assert io.read_picks(old).picks == (Pick(30.0, 0.01, order=4),)


@pytest.mark.parametrize(("change", "says"), [
    (("version = 1", "version = 2"), "picks file version 2 is newer than this ema-pipeline "
                                     "reads (1)"),
    (("version = 1", 'version = "1"'), "version must be a whole number >= 1, got '1'"),
    (("version = 1", "version = 1\nauthor = \"me\""), "unknown key author (known: version, "
                                                      "diagram, pick)"),
    (("weighting = \"none\"", "weighting = \"none\"\nsmooth = true"),
     "[diagram] unknown key smooth (known: band_hz, orders, weighting, companions)"),
    (("order = 4", "order = 4\nfreq = 30.0"),
     "pick 1: unknown key freq (known: freq_hz, zeta, order, pole)"),
    (("weighting = \"none\"", "weighting = \"snr\""),
     "[diagram] weighting must be one of 'none', 'coherence', got 'snr'"),
    (("order = 4", "order = 4\npole = [-1.0, 188.0]"), "give either order"),
])
def test_the_reader_refuses_what_the_layout_does_not_hold(tmp_path, change, says):
    """One line naming the file and the key, never a traceback."""
    text = picks_toml(Picks((5.0, 100.0), (2, 4), (Pick(30.0, 0.01, order=4),)))
    assert change[0] in text
    path = tmp_path / "picks.toml"
    path.write_text(text.replace(change[0], change[1], 1), encoding="utf-8")
    with pytest.raises(DataError) as info:
        io.read_picks(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and says in message and "\n" not in message


@pytest.fixture(scope="module")
def plate():
    """The simulated plate of tests/test_picks.py (3 modes, 4 responses), its
    automatic result with one companion added, and its diagram as a page."""
    frf = simulated()
    result = identify(frf)
    result = replace(result, stabilization=replace(
        result.stabilization, companion_pole=np.array([COMPANION])))
    page = ("<!DOCTYPE html><html><head><meta charset=\"utf-8\"></head><body>"
            + stab_diagram_html(frf, result) + "</body></html>")
    return frf, result, page


def _string_literals(script: str) -> set[str]:
    """The single-quoted string literals of a script (no escapes in these)."""
    return set(re.findall(r"'([^'\\\n]*)'", script))


def test_the_page_script_writes_the_io_constants(plate):
    """Without a browser: the script that writes ``#picks`` holds io's header,
    version, comments and keys as its literals, and the page's ``#picks`` is
    left for the script to fill (one writer of the text per language)."""
    _, _, page = plate
    script = page.split("<script>")[-1]
    literals = _string_literals(script)
    assert set(HEADER) <= literals
    assert set(COMPANIONS_COMMENT) <= literals
    assert f"version = {PICKS_VERSION}" in literals
    for key in (*DIAGRAM_KEYS, *PICK_KEYS):
        assert any(lit.startswith(f"{key} = ") for lit in literals), key
    assert '<pre class="picks" id="picks"></pre>' in page


@pytest.mark.skipif(CHROMIUM is None or CHROMEDRIVER is None,
                    reason="no headless browser: install the system packages chromium and "
                           "chromium-driver")
def test_the_page_script_writes_what_io_reads(plate, tmp_path):
    """In headless Chromium: the untouched page's ``#picks`` is the io
    writer's text of the automatic result's picks, character for character,
    and reads back field by field (the companion included). Moving the 97 Hz
    mode's pick to a pole of its trajectory in the diagram gives a pick by
    ``order`` with the pole's values, drops the companion, is again the io
    writer's text of what the io reader reads, and fits the 97 Hz mode."""
    pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
    from selenium.webdriver.common.by import By

    frf, result, page = plate
    path = tmp_path / "page.html"
    path.write_text(page, encoding="utf-8")
    automatic = picks_from_result(result)
    assert automatic.companions == (COMPANION,)
    with chromium(tmp_path / "profile") as driver:
        driver.get(path.as_uri())
        text = driver.find_element(By.ID, "picks").get_attribute("textContent")
        assert text == picks_toml(automatic)
        _same(picks_from_mapping(tomllib.loads(text)), automatic)
        # the 97 Hz mode's diamond and a pole of its trajectory at the highest order
        diamond = next(p for p in driver.find_elements(By.CSS_SELECTOR, "polygon.pole.mode")
                       if abs(float(p.get_attribute("data-freq-hz")) - 97.0) < 1.0)
        group = diamond.get_attribute("data-group")
        top = max(automatic.orders)
        pole = driver.find_element(
            By.CSS_SELECTOR, f'text.pole[data-group="{group}"][data-order="{top}"]')
        driver.execute_script(  # a click previews the pole, the preview's button picks it
            "arguments[0].dispatchEvent(new MouseEvent('click', {bubbles: true}))", pole)
        assert driver.find_element(By.ID, "picks").get_attribute("textContent") == text
        driver.find_element(By.CSS_SELECTOR, "[data-pole-preview] [data-pick-toggle]").click()
        assert "selected" not in diamond.get_attribute("class")
        moved = driver.find_element(By.ID, "picks").get_attribute("textContent")
        values = {k: pole.get_attribute(f"data-{k}") for k in ("freq-hz", "zeta", "order")}
    file = tmp_path / "moved.toml"
    file.write_text(moved, encoding="utf-8")
    read = io.read_picks(file)
    assert moved == picks_toml(read)
    assert read.companions == ()  # a diagram pole is picked: the page drops them
    by_order = [p for p in read.picks if p.order is not None]
    assert len(by_order) == 1 and by_order[0].pole is None
    assert by_order[0].order == int(values["order"]) == top
    assert by_order[0].freq_hz == float(values["freq-hz"])
    assert by_order[0].zeta == float(values["zeta"])
    kept = [p for p in automatic.picks if abs(p.freq_hz - 97.0) > 1.0]
    assert [p for p in read.picks if p.order is None] == kept
    fitted = identify(frf, picks=read)
    np.testing.assert_allclose(fitted.fn_hz, result.fn_hz, rtol=1e-3)
