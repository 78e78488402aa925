"""The rules of ``ema_pipeline.validation``: each refuses what it should, with
an OptionError naming the setting and the rule, and accepts its boundaries;
the FRF settings' table (``acquisition.frf_settings``) and the three doors
that use it (FRFSettings, the experiment file, ``ema-pipeline frf``) agree."""

from __future__ import annotations

import math
import re
from functools import partial

import numpy as np
import pytest

from ema_pipeline.data import OptionError
from ema_pipeline.validation import (
    choice,
    flag,
    integer,
    is_real,
    nonzero,
    number,
    optional,
    pair,
    refusal,
    seconds,
    sequence,
    shown,
    text,
)


def refused(rule, value, message: str) -> None:
    """``rule("x", value)`` raises an OptionError for field "x" whose text is ``message``."""
    with pytest.raises(OptionError) as info:
        rule("x", value)
    assert info.value.field == "x"
    assert str(info.value) == message
    assert isinstance(info.value, ValueError)  # callers that catch ValueError see it


def test_refusal_names_the_field_the_rule_and_the_value():
    error = refusal("tol_mac", "a number in (0, 1]", np.float64(2.0))
    assert (error.field, error.reason) == ("tol_mac", "must be a number in (0, 1], got 2.0")
    assert shown([1, np.float64(2.5)]) == "[1, 2.5]" and shown(np.arange(2.0)) == "[0.0, 1.0]"


def test_is_real():
    assert all(map(is_real, (0, -3, 2.5, np.int16(1), np.float32(1.5), math.inf, math.nan)))
    assert not any(map(is_real, (True, np.bool_(True), "1", 1j, None, [1.0])))


@pytest.mark.parametrize(("bounds", "inside", "outside", "rule"), [
    ({"above": 0, "at_most": 1}, [np.nextafter(0, 1), 1, 0.5], [0, 1.0000001, -1],
     "a number in (0, 1]"),
    ({"at_least": 0, "below": 0.5}, [0, np.nextafter(0.5, 0)], [0.5, -1e-300],
     "a number in [0, 0.5)"),
    ({"above": -1, "at_most": 1e3}, [-0.999, 1000], [-1, 1000.001], "a number in (-1, 1000]"),
    ({"above": 0}, [1e-300, 1e300], [0, -1, math.inf], "a finite number > 0"),
    ({"at_least": 0}, [0, 7], [-1e-9, math.inf], "a finite number >= 0"),
    ({"at_most": 400}, [400, -1e9], [400.5, -math.inf], "a finite number <= 400"),
    ({}, [-1e308, 0, 1e308], [math.inf], "a finite number"),
])
def test_number_keeps_its_range(bounds, inside, outside, rule):
    check = partial(number, **bounds)
    for value in inside:
        assert check("x", value) == float(value) and type(check("x", value)) is float
    for value in [*outside, math.nan, "1", True, None, [1.0], 1j]:
        refused(check, value, f"x must be {rule}, got {shown(value)}")


def test_number_lets_inf_pass_only_when_asked():
    assert number("x", math.inf, at_least=0, finite=False) == math.inf
    refused(partial(number, at_least=0, finite=False), math.nan, "x must be a number >= 0, got nan")
    refused(partial(number, at_least=0, finite=False), -math.inf,
            "x must be a number >= 0, got -inf")
    refused(number, 10**400, "x must be a finite number, got " + repr(10**400))  # no overflow


def test_seconds():
    assert seconds("x", 1e-300) == 1e-300 and seconds("x", 0, zero=True) == 0.0
    assert seconds("x", 1e3, at_most=1e3, zero=True) == 1e3
    refused(seconds, 0, "x must be a finite number of seconds > 0, got 0")
    refused(partial(seconds, at_most=1e3, zero=True), 1000.5,
            "x must be a number of seconds in [0, 1000], got 1000.5")
    refused(partial(seconds, at_most=1e4), 0.0,
            "x must be a number of seconds in (0, 10000], got 0.0")


def test_nonzero():
    assert nonzero("x", -1e-300) == -1e-300 and nonzero("x", 3) == 3.0
    for bad in (0, -0.0, math.inf, math.nan, "2", False):
        refused(nonzero, bad, f"x must be a finite non-zero number, got {shown(bad)}")


def test_integer():
    assert integer("x", np.int64(7)) == 7 and type(integer("x", np.int64(7))) is int
    check = partial(integer, at_least=1, at_most=2**32)
    assert check("x", 1) == 1 and check("x", 2**32) == 2**32
    for bad in (0, 2**32 + 1, 1.0, True, "1"):
        refused(check, bad, f"x must be an integer in [1, 4294967296], got {shown(bad)}")
    refused(partial(integer, above=0), 0, "x must be an integer > 0, got 0")
    assert integer("x", 1, above=0) == 1
    refused(partial(integer, at_most=1000), 1001, "x must be an integer <= 1000, got 1001")
    assert integer("x", -5, at_most=1000) == -5


def test_pair():
    check = partial(pair, at_least=0.0, unit="Hz")
    assert check("x", [0, 1e-9]) == (0.0, 1e-9) and check("x", np.array([5, 395])) == (5.0, 395.0)
    rule = "(low, high) in Hz with 0 <= low < high, both finite"
    for bad in ((5, 5), (300, 100), (-1e-9, 1), (1, math.inf), (math.nan, 1), (1, 2, 3), (1,),
                "5-395", 5.0, (True, 2)):
        refused(check, bad, f"x must be {rule}, got {shown(bad)}")
    assert pair("x", (-5, -1)) == (-5.0, -1.0)  # no lower bound
    refused(pair, (2, 1), "x must be (low, high) with low < high, both finite, got [2, 1]")


def test_choice_flag_text():
    names = ("H1", "H2", "Hv")
    assert [choice("x", n, names=names) for n in names] == list(names)
    for bad in ("h1", "", None, 1, ["H1"]):
        refused(partial(choice, names=names), bad,
                f"x must be one of 'H1', 'H2', 'Hv', got {shown(bad)}")
    assert flag("x", True) is True and flag("x", np.bool_(False)) is False
    for bad in (1, 0, "true", None):
        refused(flag, bad, f"x must be a boolean (true or false), got {shown(bad)}")
    assert text("x", "") == ""
    refused(text, b"a", "x must be a string, got b'a'")


def test_sequence():
    check = partial(sequence, item=partial(integer, at_least=1), min_len=1, max_len=3)
    assert check("x", [1, 2, 3]) == (1, 2, 3) and check("x", (4,)) == (4,)
    refused(check, [], "x must have 1 to 3 entries, got 0")
    refused(check, [1, 2, 3, 4], "x must have 1 to 3 entries, got 4")
    refused(check, [1, 0], "x entry 2 must be an integer >= 1, got 0")
    refused(check, "1,2", "x must be a list, got '1,2'")
    refused(partial(sequence, item=number, min_len=2, max_len=2), [1.0],
            "x must have 2 entries, got 1")
    refused(partial(sequence, item=number, min_len=2), [1.0],
            "x must have at least 2 entries, got 1")
    assert sequence("x", [], item=number) == ()


def test_optional():
    check = optional(partial(number, above=0))
    assert check("x", None) is None and check("x", 2) == 2.0
    refused(check, 0, "x must be a finite number > 0, got 0")


# --------------------------------------------------------------- the FRF settings
def test_frf_settings_rules():
    from ema_pipeline.acquisition.frf_settings import FRF_SETTING_RULES, exp_window_tau

    tau_rule = "'auto', 'none' or a number of seconds in (0, 10000]"
    assert [exp_window_tau("x", v) for v in ("auto", "none", None, 1e4, 1)] == [
        "auto", None, None, 1e4, 1.0]
    for bad in ("AUTO", "", 0, 1.0001e4, math.nan, True):
        refused(exp_window_tau, bad, f"x must be {tau_rule}, got {shown(bad)}")
    rules = FRF_SETTING_RULES
    assert rules["pretrigger_s"]("x", 0) == 0.0 and rules["pretrigger_s"]("x", 1e3) == 1e3
    assert rules["record_length_s"]("x", None) is None
    assert rules["force_window_s"]("x", 0) == 0.0
    refused(rules["record_length_s"], 0, "x must be a number of seconds in (0, 10000], got 0")
    refused(rules["estimator"], "H3", "x must be one of 'H1', 'H2', 'Hv', got 'H3'")
    refused(rules["keep_all"], "yes", "x must be a boolean (true or false), got 'yes'")


def test_frf_settings_name_their_option_and_normalise():
    from ema_pipeline.pipeline.frf import FRFSettings

    settings = FRFSettings(pretrigger_s=0, exp_window_tau="none", record_length_s=2)
    assert (settings.pretrigger_s, settings.exp_window_tau, settings.record_length_s) == (
        0.0, None, 2.0)
    assert type(settings.pretrigger_s) is float
    with pytest.raises(OptionError, match=re.escape(
            "force_window_s (--force-window-s) must be a number of seconds in [0, 10000], "
            "got -1")):
        FRFSettings(force_window_s=-1)


def test_the_experiment_files_frf_table_uses_the_same_rules(tmp_path):
    """``[[configurations]] frf`` gives the reason of the same rule, after the
    file, the entry and the key; ``scale`` the command line's rule too."""
    from ema_pipeline.data import DataError
    from ema_pipeline.io.experiment import read_experiment

    def message(frf: str) -> str:
        path = tmp_path / "experiment.toml"
        path.write_text(f'[[configurations]]\nname = "a"\nrecording = "r.csv"\nfrf = {{ {frf} }}\n')
        with pytest.raises(DataError) as info:
            read_experiment(path, check_files=False)
        return str(info.value).removeprefix(f"{path}: [[configurations]] 1 frf: ")

    assert message("pretrigger_s = -1") == (
        "pretrigger_s: must be a number of seconds in [0, 1000], got -1")
    assert message('exp_window_tau = "never"') == (
        "exp_window_tau: must be 'auto', 'none' or a number of seconds in (0, 10000], "
        "got 'never'")
    assert message("scale = { acc = 0 }") == (
        "scale: acc: must be a finite non-zero number, got 0")
    assert message("keep_all = 1") == "keep_all: must be a boolean (true or false), got 1"
