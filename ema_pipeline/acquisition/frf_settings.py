"""The rule of each setting of the FRFs from impact recordings, in one table.

:data:`FRF_SETTING_RULES` is what :class:`~ema_pipeline.pipeline.frf.FRFSettings`
(the settings of ``ema-pipeline frf``, whose options name the field) and the
``frf`` table of an experiment file (:data:`ema_pipeline.io.experiment.FRF_SETTINGS`)
check against; the rules are those of :mod:`ema_pipeline.validation` with the
limits of :mod:`ema_pipeline.acquisition.hits`.
"""

from __future__ import annotations

from functools import partial
from typing import Any

from ema_pipeline.acquisition.hits import (
    MAX_EXP_WINDOW_TAU_S,
    MAX_PRETRIGGER_S,
    MAX_RECORD_LENGTH_S,
)
from ema_pipeline.validation import Rule, choice, flag, optional, refusal, seconds

__all__ = ["ESTIMATORS", "FRF_SETTING_RULES", "exp_window_tau"]

#: The FRF estimators by name (:func:`ema_pipeline.acquisition.estimate_frf`).
ESTIMATORS: tuple[str, ...] = ("H1", "H2", "Hv")


def exp_window_tau(name: str, value: Any) -> str | float | None:
    """The exponential window's setting: ``"auto"`` (chosen from the records),
    ``None`` or ``"none"`` (no window: ``None``), or a time constant in s above
    0 and at most :data:`~ema_pipeline.acquisition.hits.MAX_EXP_WINDOW_TAU_S`.

    Examples
    --------
    >>> exp_window_tau("exp_window_tau", "none"), exp_window_tau("exp_window_tau", 0.5)
    (None, 0.5)
    >>> try:
    ...     exp_window_tau("tau", 0)
    ... except ValueError as exc:  # an OptionError
    ...     print(exc)
    tau must be 'auto', 'none' or a number of seconds in (0, 10000], got 0
    """
    if value is None or isinstance(value, str) and value in ("auto", "none"):
        return None if value in (None, "none") else "auto"
    try:
        return seconds(name, value, at_most=MAX_EXP_WINDOW_TAU_S)
    except ValueError:
        raise refusal(name, f"'auto', 'none' or a number of seconds in (0, "
                            f"{MAX_EXP_WINDOW_TAU_S:g}]", value) from None


#: The rule of each setting (``None``, where a setting allows it, is its default).
FRF_SETTING_RULES: dict[str, Rule] = {
    "pretrigger_s": partial(seconds, at_most=MAX_PRETRIGGER_S, zero=True),
    "record_length_s": optional(partial(seconds, at_most=MAX_RECORD_LENGTH_S)),
    "force_window_s": optional(partial(seconds, at_most=MAX_RECORD_LENGTH_S, zero=True)),
    "exp_window_tau": exp_window_tau,
    "estimator": partial(choice, names=ESTIMATORS),
    "keep_all": flag,
}
