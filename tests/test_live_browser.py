"""``ema-pipeline live`` in headless Chromium: the held-out 12-point plate of
tests/test_plate_holdout.py (CSV, WAV and TDMS recordings, a double hit at
point 5, point 7's file starting 3 ms before its first hit) replayed at 20 x
real time, and the simulated plate struck with the virtual hammer.

The server runs as a subprocess (``--port 0 --no-browser``); its address, token
included, is read from its first line. The replay test kills it with SIGKILL
after 6 points and starts the same command again.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline.cli import main
from tests.browser import chromium, needs_browser
from tests.impact_recordings import PLATE_DURATION_S
from tests.test_plate_holdout import BAND_HZ, FN_ALL, IN_BAND, ZETA_ALL, write_test_folder

pytest.importorskip("starlette", reason="ema-pipeline live needs the live extra (starlette)")
pytest.importorskip("uvicorn", reason="ema-pipeline live needs the live extra (uvicorn)")
pytest.importorskip("selenium", reason="the browser tests drive Chromium with selenium")
pytestmark = needs_browser

REPO = Path(__file__).resolve().parents[1]
SPEED = 20.0


def _serve(args: list[str], cwd: Path) -> tuple[subprocess.Popen, str]:
    """Start ``ema-pipeline live ARGS`` and return it with the address it prints."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen([sys.executable, "-m", "ema_pipeline", "live", *args,
                             "--port", "0", "--no-browser"], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    match = re.search(r"http://127\.0\.0\.1:\d+/\S+/", line)
    if match is None:
        proc.kill()
        raise AssertionError(f"no address in {line!r}: {proc.communicate()[1]}")
    return proc, match.group(0)


def _stop(proc: subprocess.Popen) -> None:
    """Stop the server as Ctrl-C does; it must have logged no error."""
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    assert "Traceback" not in err, err[-3000:]


def _wait(cond, timeout_s: float, what):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = cond()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what() if callable(what) else what}")


def _attr(driver, css: str, name: str) -> list[str]:
    return driver.execute_script(
        "var name = arguments[1]; return [].slice.call(document.querySelectorAll(arguments[0]))"
        ".map(function(e){return e.getAttribute(name);});", css, name)


def _hits(driver) -> list[dict]:
    return driver.execute_script(
        "return [].slice.call(document.querySelectorAll('[data-hit]')).map(function(e){"
        "return {n: +e.dataset.hit, status: e.dataset.status, reasons: e.dataset.reasons,"
        "end: +e.dataset.recordEndMs, shown: +e.dataset.shownMs};});")


def _point_done_streaming(driver, point: int, n_hits: int) -> list[dict]:
    """Wait until ``point`` is current, its file streamed and its hits judged."""
    def ready():
        states = _attr(driver, "[data-point]", "data-state")
        root = driver.find_element("css selector", "[data-live]")
        if states[point - 1] != "current" or root.get_attribute("data-streaming") != "false":
            return None
        hits = _hits(driver)
        return hits if len(hits) == n_hits else None
    return _wait(ready, 30, f"point {point}'s hits")


def test_live_replay_of_the_plate_resumes_after_kill_and_matches_frf(tmp_path):
    start = time.monotonic()
    write_test_folder(tmp_path)
    args = ["--channels", "channels.csv", "--geometry", "plate.uff", "--session", "session",
            "--replay", "--speed", f"{SPEED:g}", "--band", *map(str, BAND_HZ)]
    proc, url = _serve(args, tmp_path)
    latencies: list[float] = []
    accepted: dict[int, str] = {}
    try:
        # the address without its token, or with another, is refused
        base = url.split("/", 3)
        for bad in (f"{base[0]}//{base[2]}/", f"{base[0]}//{base[2]}/x{base[3]}"):
            with pytest.raises(urllib.error.HTTPError) as err:
                urllib.request.urlopen(bad, timeout=10)
            assert err.value.code == 403
        # a WebSocket from another origin is refused
        from websockets.exceptions import InvalidStatus
        from websockets.sync.client import connect

        ws_url = url.replace("http://", "ws://") + "ws"
        with pytest.raises(InvalidStatus):
            connect(ws_url, origin="http://evil.example", open_timeout=10)
        with connect(ws_url, origin=f"http://{base[2]}", open_timeout=10) as ws:
            assert '"points"' in ws.recv(timeout=10)

        with chromium(tmp_path / "profile", 1300, 1100) as driver:
            driver.get(url)
            for point in range(1, 7):
                hits = _point_done_streaming(driver, point, 4)
                if point == 5:  # the bounce 50 ms after hit 2: a double hit
                    assert [h["status"] for h in hits] == ["accepted", "rejected", "accepted",
                                                           "accepted"]
                    assert "double_hit" in hits[1]["reasons"].split()
                else:
                    assert all(h["status"] == "accepted" for h in hits), hits
                if point > 1:  # the record length is known: each verdict when its record ends
                    latencies += [(h["shown"] - h["end"]) / 1000 for h in hits]
                driver.find_element("css selector", "[data-next-point]").click()
                _wait(lambda p=point: _attr(driver, "[data-point]", "data-state")[p - 1]
                      == "done", 10, f"point {point} done")
            accepted = dict(enumerate(_attr(driver, "[data-point]", "data-accepted")[:6], 1))
        assert accepted == {1: "4", 2: "4", 3: "4", 4: "4", 5: "3", 6: "4"}
        assert max(latencies) < 0.3, latencies
    finally:
        proc.send_signal(signal.SIGKILL)  # a crash: no clean-up at all
        proc.wait()
    assert (tmp_path / "session" / "live.lock").exists()
    from ema_pipeline.io.hit_choice import read_hit_choice

    chosen = read_hit_choice(tmp_path / "session" / "hits.toml")  # as the kill left it
    assert chosen == {f"p{k}.wav": (1, 3, 4) if k == 5 else (1, 2, 3, 4) for k in range(1, 7)}

    proc, url = _serve(args, tmp_path)  # the same command: resumes
    try:
        with chromium(tmp_path / "profile2", 1300, 1100) as driver:
            driver.get(url)
            _wait(lambda: _attr(driver, "[data-point]", "data-state")[:6] == ["done"] * 6,
                  10, "the 6 points done")
            assert dict(enumerate(_attr(driver, "[data-point]", "data-accepted")[:6], 1)
                        ) == accepted
            for point in range(7, 13):
                hits = _point_done_streaming(driver, point, 4)
                assert all(h["status"] == "accepted" for h in hits), (point, hits)
                if point < 12:
                    driver.find_element("css selector", "[data-next-point]").click()
            driver.find_element("css selector", "[data-finish]").click()
            _wait(lambda: driver.find_element("css selector", "[data-live]")
                  .get_attribute("data-final") == "true", 60, "the final identification")
            fn_page = np.array([float(v) for v in _attr(driver, "[data-live-mode]",
                                                         "data-fn-hz")])
            zeta_page = np.array([float(v) for v in _attr(driver, "[data-live-mode]",
                                                           "data-zeta")])
            n_shapes = len(driver.find_elements("css selector", "[data-mode-shape]"))
            driver.save_screenshot(str(tmp_path / "live_replay.png"))
    finally:
        _stop(proc)

    # every mode of the band within 1 %, none spurious, damping within 15 %, shapes drawn
    fn, zeta = FN_ALL[IN_BAND], ZETA_ALL[IN_BAND]
    order = np.argsort(fn_page)
    assert fn_page.size == fn.size
    np.testing.assert_allclose(fn_page[order], fn, rtol=0.01)
    np.testing.assert_allclose(zeta_page[order], zeta, rtol=0.15)
    assert n_shapes == fn.size

    # the session folder is a test the offline commands read: the same modes
    session = tmp_path / "session"
    assert main(["frf", "--channels", str(session / "channels.csv"), "--hits",
                 str(session / "hits.toml"), "--out", str(tmp_path / "t.h5"), "--quiet"]) == 0
    assert main(["identify", str(tmp_path / "t.h5"), "--out", str(tmp_path / "id"), "--band",
                 *map(str, BAND_HZ), "--quiet"]) == 0
    modes = pd.read_csv(tmp_path / "id" / "t_modes.csv")
    np.testing.assert_allclose(np.sort(modes["fn_hz"].to_numpy()), fn_page[order], rtol=1e-3)
    np.testing.assert_allclose(modes["zeta_pct"].to_numpy()[np.argsort(modes["fn_hz"])] / 100,
                               zeta_page[order], rtol=1e-3)
    final = read_hit_choice(session / "hits.toml")
    assert {k: final[k] for k in chosen} == chosen and len(final) == 12
    hits = pd.read_csv(tmp_path / "t_hits.csv", keep_default_na=False)
    assert int(hits["accepted"].sum()) == 47
    elapsed = time.monotonic() - start
    assert elapsed < 12 * PLATE_DURATION_S / SPEED + 120, elapsed


def test_live_simulated_plate_struck_with_the_virtual_hammer(tmp_path):
    """The built-in plate: strikes by button and by key, the second strike a double
    hit (rejected as one), a hit rejected and undone by keys, four points and the
    finish; every mode found is one of the plate's. With
    ``EMA_PIPELINE_DOCS_SCREENSHOT=1`` the page's picture goes to
    docs/_static/live_simulate.png (the tutorial's)."""
    from selenium.webdriver.common.keys import Keys

    from ema_pipeline.live.simulate import builtin_model

    proc, url = _serve(["--simulate", "plate", "--session", "session", "--speed", "5",
                        "--seed", "5", "--double-hit", "2"], tmp_path)
    try:
        with chromium(tmp_path / "profile", 1300, 1250) as driver:
            driver.get(url)
            button = _wait(lambda: [b for b in driver.find_elements(
                "css selector", "[data-virtual-hit]") if b.is_displayed()], 10,
                "the virtual hammer")[0]
            body = driver.find_element("css selector", "body")
            for point in range(1, 5):
                _wait(lambda p=point: _attr(driver, "[data-point]", "data-state")[p - 1]
                      == "current", 10, f"point {point}")
                for k in range(3):
                    if k == 2:
                        body.send_keys("h")  # the key strikes too
                    else:
                        button.click()
                    # 1.5 s of the plate's time at 5 x between the session's first two
                    # strikes (they set the record length, as frf does: the power of two
                    # of samples between them, 1 s; 2 s where a loaded machine delays
                    # the second strike), 4 s from then on: each record ends before
                    # the next hit whichever it is
                    time.sleep(0.3 if point == 1 and k == 0 else 0.8)
                hits = _wait(lambda: (h if len(h := _hits(driver)) == 3 else None), 30,
                             lambda p=point: f"point {p}'s three hits: {_hits(driver)}")
                if point == 1:  # strike 2 bounced: rejected as a double hit
                    assert [h["status"] for h in hits] == ["accepted", "rejected", "accepted"]
                    assert hits[1]["reasons"].split() == ["double_hit"]
                    body.send_keys("r")  # reject the last hit, then undo that
                    _wait(lambda: _hits(driver)[2]["status"] == "rejected", 5, "rejected")
                    body.send_keys("u")
                    _wait(lambda: _hits(driver)[2]["status"] == "accepted", 5, "undone")
                else:
                    assert all(h["status"] == "accepted" for h in hits), hits
                if point < 4:
                    body.send_keys(Keys.NULL, "n")
            driver.find_element("css selector", "[data-finish]").click()
            _wait(lambda: driver.find_element("css selector", "[data-live]")
                  .get_attribute("data-final") == "true", 60, "the final identification")
            assert _attr(driver, "[data-point]", "data-accepted")[:4] == ["2", "3", "3", "3"]
            fn_page = np.array([float(v) for v in _attr(driver, "[data-live-mode]",
                                                         "data-fn-hz")])
            n_shapes = len(driver.find_elements("css selector", "[data-mode-shape]"))
            shot = (REPO / "docs" / "_static" / "live_simulate.png"
                    if os.environ.get("EMA_PIPELINE_DOCS_SCREENSHOT") else
                    tmp_path / "live_simulate.png")
            driver.save_screenshot(str(shot))
    finally:
        _stop(proc)
    truth = builtin_model("plate").fn_hz
    assert fn_page.size >= 2 and n_shapes == fn_page.size
    nearest = np.min(np.abs(fn_page[:, None] / truth[None, :] - 1), axis=1)
    assert nearest.max() < 0.01, (fn_page, truth)
