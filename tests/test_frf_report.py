"""Issue 26, the hit page of ``frf --report``: one section per hit with the reason it
was kept or rejected (the truth: the generator's injected defects), the usable band,
a small self-contained page; and no page without ``--report``."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from ema_pipeline.cli import main
from ema_pipeline.pipeline.frf import frf_from_files
from ema_pipeline.report.hits_page import ACCEPTED_TEXT, REASON_TEXT
from tests.impact_recordings import make_recording, write_tdms


def sections(page: str) -> dict[int, str]:
    """Hit number -> the HTML of its section."""
    return {int(m.group(1)): m.group(2) for m in
            re.finditer(r'<section id="hit-(\d+)">(.*?)</section>', page, re.S)}


def test_hit_page_shows_every_hit_with_its_reason_and_the_band(tmp_path):
    rec = make_recording(3, n_double=1, n_overload=1, n_resp=2)
    path = write_tdms(rec, tmp_path / "test.tdms")
    out = tmp_path / "out" / "test.h5"
    out.parent.mkdir()
    result = frf_from_files([path], out, report=True)
    page = (tmp_path / "out" / "test_hits.html").read_text()
    found = sections(page)
    assert sorted(found) == list(range(1, rec.hit_times_s.size + 1))
    for hit, truth in zip(result.hits, rec.defects, strict=True):
        body = found[hit.index]
        for reason in truth:  # the injected defect is named and explained
            assert REASON_TEXT[reason] in body, (hit.index, reason)
        if not hit.reasons:
            assert ACCEPTED_TEXT in body and "no check objects" not in body
        else:
            assert "rejected: " in body
        assert body.count("<svg") == 1  # pulse, spectrum and response panels
    f10, f20 = result.force_band_hz
    assert f"-10 dB at {f10:.5g} Hz, -20 dB at {f20:.5g} Hz" in page
    assert 0 < f10 < f20 <= rec.sample_rate_hz / 2
    table = pd.read_csv(tmp_path / "out" / "test_hits.csv")
    assert page.count('class="hit"') == len(table)
    # self-contained and small: no external resources, curves reduced to envelopes
    assert not re.search(r'(src|href)="(?!#)', page)
    assert len(page.encode()) < 60_000 + 40_000 * len(table)


def test_no_page_without_report(tmp_path):
    rec = make_recording(1, n_hits=5, n_resp=1, last_hit_short=False)
    path = write_tdms(rec, tmp_path / "r.tdms")
    assert main(["frf", str(path), "--out", str(tmp_path / "a.h5"), "--quiet"]) == 0
    assert not (tmp_path / "a_hits.html").exists()
    assert main(["frf", str(path), "--out", str(tmp_path / "b.h5"), "--quiet",
                 "--report"]) == 0
    page = (tmp_path / "b_hits.html").read_text()
    assert len(sections(page)) == 5
    assert np.isfinite(float(re.search(r"-10 dB at ([0-9.e+]+) Hz", page).group(1)))


def test_single_recording_page_hits_left_out_by_hand_and_windows(tmp_path, capsys):
    """A plain recording is one point of the choice by hand; a hit left out with
    --hits says so (never an empty reason); the captions name the exponential window
    only when one was used."""
    from ema_pipeline.io.hit_choice import write_hit_choice
    from ema_pipeline.report.hits_page import LEFT_OUT_TEXT

    rec = make_recording(1, n_hits=5, n_resp=1, last_hit_short=False)
    path = write_tdms(rec, tmp_path / "r.tdms")
    write_hit_choice({"": [1, 3, 4, 5]}, tmp_path / "hits.toml")
    assert main(["frf", str(path), "--out", str(tmp_path / "a.h5"), "--report",
                 "--hits", str(tmp_path / "hits.toml"), "--exp-window-tau", "0.2"]) == 0
    said = capsys.readouterr().out
    assert re.search(r"hit 2 at [0-9.]+ s: rejected: left out by hand \(--hits\)\n", said)
    assert "5 hits found, 4 averaged" in said
    page = (tmp_path / "a_hits.html").read_text()
    assert re.findall(r'data-hit-choice-point="([^"]*)"', page) == [""]
    found = sections(page)
    assert f"rejected: {LEFT_OUT_TEXT}; it passed every check" in found[2]
    assert "rejected: <" not in page and "rejected: </" not in page
    assert [ACCEPTED_TEXT in found[k] for k in range(1, 6)] == [True, False, True, True, True]
    table = pd.read_csv(tmp_path / "a_hits.csv", keep_default_na=False)
    assert table["accepted"].tolist() == [True, False, True, True, True]
    assert "<th>averages</th><td>4</td>" in page and "(chosen by hand: --hits)" in page
    captions = re.findall(r"<figcaption>Force pulse.*?</figcaption>", page)
    assert len(captions) == 5
    assert all("the exponential window scaled to its peak" in c for c in captions)
    assert main(["frf", str(path), "--out", str(tmp_path / "b.h5"), "--quiet", "--report",
                 "--exp-window-tau", "none"]) == 0
    page = (tmp_path / "b_hits.html").read_text()
    captions = re.findall(r"<figcaption>Force pulse.*?</figcaption>", page)
    assert len(captions) == 5 and not any("exponential" in c for c in captions)
