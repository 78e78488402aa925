"""The interactive stabilization diagram's marks and axes in Python
(report.stab_marks, report.svg.nice_step): the round step, the steps the
page's script chooses from, the stability symbols from the diagram's flags,
the ticks of the order and amplitude axes."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from ema_pipeline.identification.result import STABLE_DAMP, STABLE_FREQ, STABLE_VECTOR
from ema_pipeline.report.stab_marks import (
    FREQUENCY_PARTS,
    STABILITY,
    amplitude_axis,
    frequency_steps,
    legend_html,
    order_axis,
    stability_symbols,
)
from ema_pipeline.report.svg import nice_step, nice_steps, nice_ticks

SPANS = np.geomspace(1e-3, 1e5, 2001)


def _series(lo: float, hi: float) -> np.ndarray:
    """Every 1, 2 or 5 x 10^k in [lo, hi]."""
    k = np.arange(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 2)
    v = np.sort((np.array([1.0, 2.0, 5.0])[:, None] * 10.0 ** k[None, :]).ravel())
    return v[(v >= lo) & (v <= hi)]


@pytest.mark.parametrize("parts", [4, 5, 7])
def test_nice_step_is_the_smallest_round_step_that_fits(parts):
    """For spans over eight decades: the step is 1, 2 or 5 x 10^k, cuts the
    span into at most ``parts`` parts (0.1 % slack) and the round step below
    it would cut it into more."""
    steps = np.array([nice_step(s, parts) for s in SPANS])
    lead = steps / 10.0 ** np.floor(np.log10(steps) + 1e-9)
    assert np.all(np.min(np.abs(lead[:, None] - [1.0, 2.0, 5.0]), axis=1) < 1e-9)
    assert np.all(SPANS / steps <= parts * 1.001)
    series = _series(1e-6, 1e6)
    below = series[np.searchsorted(series, steps * (1 - 1e-9)) - 1]
    assert np.all(SPANS / below > parts * 0.999)


def test_the_page_steps_give_nice_step_at_every_zoom():
    """The page's script takes the first of ``frequency_steps`` at least the
    range over FREQUENCY_PARTS: that is nice_step's choice for every range the
    page allows (the band down to a thousandth of it)."""
    lo, hi = 5.0, 1024.0
    ladder = np.array(frequency_steps(lo, hi, (hi - lo) * 1e-3))
    assert np.array_equal(ladder, np.unique(ladder)) and ladder[-1] == 200.0
    for span in np.geomspace((hi - lo) * 1e-3, hi - lo, 500):
        raw = span / FREQUENCY_PARTS
        chosen = ladder[np.argmax(ladder >= raw * 0.999)]
        assert chosen == pytest.approx(nice_step(span, FREQUENCY_PARTS), rel=1e-12)
    assert nice_steps(0.7, 0.7, 7) == [0.1]


def test_ticks_are_multiples_of_the_step_inside_the_range():
    rng = np.random.default_rng(50)
    for a, w in zip(rng.uniform(-500, 500, 300), 10 ** rng.uniform(-2, 4, 300), strict=True):
        t = nice_ticks(a, a + w, FREQUENCY_PARTS + 1)
        step = nice_step(w, FREQUENCY_PARTS)
        assert t[0] >= a - 1e-9 * w and t[-1] <= a + w + 1e-9 * w
        assert t[0] - step < a and t[-1] + step > a + w  # none left out
        assert np.allclose(np.diff(t), step, rtol=1e-6)


def test_stability_symbols_follow_the_flags():
    """Every combination the diagram writes (damping and vector only with a
    stable frequency): o, f, d, v, s; and what each symbol means."""
    flags = np.array([0, STABLE_FREQ, STABLE_FREQ | STABLE_DAMP, STABLE_FREQ | STABLE_VECTOR,
                      STABLE_FREQ | STABLE_DAMP | STABLE_VECTOR], dtype=np.uint8)
    assert stability_symbols(flags).tolist() == ["o", "f", "d", "v", "s"]
    assert [STABILITY[k][0] for k in "fds"] == [
        "stable frequency", "stable frequency and damping",
        "stable frequency, damping and vector"]
    assert STABILITY["v"][0] == "stable frequency and vector"


def _values(axis_svg: str) -> list[float]:
    return [float(v) for v in re.findall(r'data-value="([^"]+)"', axis_svg)]


def test_order_ticks_round_and_between_their_rows():
    """The measured beam's orders (2, 8, 14, 22, 28, ..., 254: steps of 6 and
    8): ticks 50 ... 250, each at the height of the rows around it."""
    orders = np.unique(np.r_[np.arange(2, 255, 14), np.arange(8, 255, 14)])
    rows = 400.0 - 9.0 * np.arange(orders.size)

    def y_of(o: float) -> float:
        return float(np.interp(o, orders, rows))

    axis = order_axis(orders, y_of, 48.0)
    assert _values(axis) == [50.0, 100.0, 150.0, 200.0, 250.0]
    ys = [float(y) for y in re.findall(r'<text x="[^"]+" y="([^"]+)"', axis)]
    assert np.allclose(ys, [y_of(v) for v in _values(axis)], atol=0.05)
    assert re.findall(r">(\d+)</text>", axis) == ["50", "100", "150", "200", "250"]


def test_amplitude_ticks_are_decades_or_1_2_5():
    assert _values(amplitude_axis(0.9, 3.8, lambda v: v, 800.0)) == [10.0, 100.0, 1000.0]
    assert _values(amplitude_axis(-0.4, 0.9, lambda v: v, 800.0)) == [0.5, 1.0, 2.0, 5.0]
    assert "10<tspan" in amplitude_axis(-6.5, -3.5, lambda v: v, 800.0)  # 10^-6 ... 10^-4
    assert amplitude_axis(1.0, 1.0, lambda v: v, 800.0) == ""


def test_legend_lists_the_symbols_drawn_and_every_other_mark():
    legend = legend_html(np.array(["o", "s", "s", "v"]), 3)
    keys = re.findall(r'data-legend="([^"]+)"', legend)
    assert keys == ["o", "v", "s", "picked", "mode", "mode-unpicked", "previewed", "frf",
                    "synthesis"]
    # the kept modes: diamonds, as drawn
    assert legend.count('<polygon class="mode selected"') == 1
    assert legend.count('<polygon class="mode"') == 1
    assert "mode" not in re.findall(r'data-legend="([^"]+)"', legend_html(["o"], 0))
