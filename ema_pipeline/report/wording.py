"""Words the reports and the console share: counts with the right plural, the
fit-quality verdict with its limits (the one home of those limits), and the
model an identification fitted.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["FIT_LIMITS", "NOISE_LIMITS", "FitLimits", "NoiseLimits", "fit_grade",
           "fit_limits_text", "fit_noise_text", "fit_noise_verdict", "fit_verdict", "model_text",
           "plural", "setting_text"]


def plural(n: int, word: str, many: str | None = None) -> str:
    """``n`` and ``word``, plural unless ``n`` is 1.

    Examples
    --------
    >>> plural(1, "mode"), plural(4, "mode"), plural(0, "file"), plural(2, "analysis", "analyses")
    ('1 mode', '4 modes', '0 files', '2 analyses')
    """
    return f"{n} {word if n == 1 else many or word + 's'}"


@dataclass(frozen=True)
class FitLimits:
    """Limits of the fit-quality verdict on the mean normalised fit error
    ``||H - H_fit|| / ||H||`` of a configuration (or file), in per cent.

    ``good_pct``: at most this is a good fit. Chosen on the paper's simulated
    test (``ema-pipeline simulate``, genuine and larger tank, identified with
    the defaults): noise-free 2.1-4.7 % (leakage and windows, not noise),
    60 dB 2.6-4.7 %, 40 dB 5.6-7.0 %, 30 dB 8.8-9.7 %: a test with the right
    modes and a usable signal stays below 10 %.
    ``fair_pct``: above ``good_pct`` and at most this is fair (look at the fit
    figure: more noise, leakage or a weak mode not modelled); above it the
    synthesis misses a large part of the measured response (a mode missing or
    wrong, or the band holds mostly noise): poor.
    """

    good_pct: float = 10.0
    fair_pct: float = 20.0


#: The limits every report and the console use (:func:`fit_verdict`).
FIT_LIMITS = FitLimits()


@dataclass(frozen=True)
class NoiseLimits:
    """Limits of the fit verdict against the noise (:func:`fit_noise_verdict`):
    the fit error over the error the noise alone gives
    (:func:`ema_pipeline.report.fit_noise.noise_error`). At most ``at_noise``
    the fit leaves nothing but noise (a complete simulated fit: 1.0); above
    ``fair`` the residual holds a resonance of its own (a simulated test with
    one of three modes left out: 18)."""

    at_noise: float = 1.5
    fair: float = 3.0


#: The limits of the identify page's verdict.
NOISE_LIMITS = NoiseLimits()


def fit_noise_verdict(error: float, noise: float, limits: NoiseLimits = NOISE_LIMITS) -> str:
    """The verdict on a mean fit error against the error the noise alone gives
    (both ratios), with both numbers; the fixed limits (:func:`fit_verdict`)
    where the noise is not known.

    Examples
    --------
    >>> fit_noise_verdict(0.327, 0.301)
    'fit at the noise level (error 32.7 %, noise alone 30.1 %)'
    >>> fit_noise_verdict(0.05, 0.02)
    'fit error 2.5 times the noise (error 5.0 %, noise alone 2.0 %): check the fit figure'
    >>> fit_noise_verdict(0.56, 0.031).split(": ")[1]
    'a mode may be missing or wrong'
    >>> fit_noise_verdict(0.05, float("nan"))
    'good fit (error 5.0 % <= 10 %)'
    """
    if not (math.isfinite(error) and math.isfinite(noise) and noise > 0):
        return fit_verdict(error)
    ratio = error / noise
    both = f"(error {100 * error:.1f} %, noise alone {100 * noise:.1f} %)"
    if ratio <= limits.at_noise:
        return f"fit at the noise level {both}"
    tail = "check the fit figure" if ratio <= limits.fair else "a mode may be missing or wrong"
    return f"fit error {ratio:.1f} times the noise {both}: {tail}"


def fit_noise_text(limits: NoiseLimits = NOISE_LIMITS) -> str:
    """The noise verdict's rule in words, printed beside it.

    Examples
    --------
    >>> fit_noise_text()[:40]
    'fit: the mean error ||H - H_fit|| / ||H|'
    """
    return ("fit: the mean error ||H - H_fit|| / ||H|| against the error the noise alone "
            "gives (the residual's line-to-line scatter, as white noise would have it): "
            f"at the noise level up to {limits.at_noise:g} times it, a mode may be missing "
            f"above {limits.fair:g} times")


def fit_grade(error: float, limits: FitLimits = FIT_LIMITS) -> str:
    """``"good"``, ``"fair"`` or ``"poor"`` for a mean fit error (a ratio), ``""`` if NaN.

    Examples
    --------
    >>> fit_grade(0.059), fit_grade(0.117), fit_grade(0.3), fit_grade(float("nan"))
    ('good', 'fair', 'poor', '')
    """
    if not math.isfinite(error):
        return ""
    pct = 100 * error
    return "good" if pct <= limits.good_pct else "fair" if pct <= limits.fair_pct else "poor"


def fit_limits_text(limits: FitLimits = FIT_LIMITS) -> str:
    """The limits in words, printed beside every verdict.

    Examples
    --------
    >>> fit_limits_text()
    'fit: good if the mean error ||H - H_fit|| / ||H|| <= 10 %, fair <= 20 %, else poor'
    """
    return (f"fit: good if the mean error ||H - H_fit|| / ||H|| <= {limits.good_pct:g} %, "
            f"fair <= {limits.fair_pct:g} %, else poor")


def fit_verdict(error: float, limits: FitLimits = FIT_LIMITS) -> str:
    """The verdict on a mean fit error (a ratio, 0.117 = 11.7 %), with the limit
    it was judged against.

    Examples
    --------
    >>> fit_verdict(0.059)
    'good fit (error 5.9 % <= 10 %)'
    >>> fit_verdict(0.15)
    'fair fit (error 15.0 % > 10 %, <= 20 %): check the fit figure'
    >>> fit_verdict(0.4)
    'poor fit (error 40.0 % > 20 %): a mode may be missing or wrong'
    >>> fit_verdict(float("nan"))
    'fit not computed'
    """
    grade, pct = fit_grade(error, limits), 100 * error
    if grade == "good":
        return f"good fit (error {pct:.1f} % <= {limits.good_pct:g} %)"
    if grade == "fair":
        return (f"fair fit (error {pct:.1f} % > {limits.good_pct:g} %, <= {limits.fair_pct:g} %): "
                "check the fit figure")
    if grade == "poor":
        return (f"poor fit (error {pct:.1f} % > {limits.fair_pct:g} %): a mode may be missing "
                "or wrong")
    return "fit not computed"


def model_text(band_hz: tuple[float, float], orders: Sequence[int] | np.ndarray,
               lower_residual: bool, upper_residual: bool, *,
               to_usable_top: bool = False) -> str:
    """The model an identification fitted, in words: its band, the orders of its
    stabilization diagram and its residual terms
    (:class:`~ema_pipeline.identification.result.ResolvedSettings`). The band
    changes the model (the adaptive order search stops at another order in
    another band), and this says so beside the modes. ``to_usable_top``: the
    band ends where the force spectrum is 20 dB down (the default band of
    FRFs made from hammer recordings), and the text says so.

    Examples
    --------
    >>> model_text((5.0, 400.0), [2, 8, 98], True, True)
    'band 5-400 Hz, diagram orders 2-98, lower and upper residual terms'
    >>> model_text((0.6103515625, 1000.0), [40], False, True)
    'band 0.6104-1000 Hz, diagram order 40, upper residual term'
    >>> model_text((10.0, 7000.0), [2, 64], False, False, to_usable_top=True)
    "band 10-7000 Hz (up to the force's -20 dB point), diagram orders 2-64, no residual terms"
    """
    lo, hi = (float(x) for x in band_hz)
    o = [int(x) for x in orders]
    span = "" if not o else (f", diagram order {o[0]}" if len(o) == 1 or min(o) == max(o)
                             else f", diagram orders {min(o)}-{max(o)}")
    terms = [name for name, on in (("lower", lower_residual), ("upper", upper_residual)) if on]
    residual = (f", {' and '.join(terms)} residual term{'s' if len(terms) > 1 else ''}"
                if terms else ", no residual terms")
    usable = " (up to the force's -20 dB point)" if to_usable_top else ""
    return f"band {lo:.4g}-{hi:.4g} Hz{usable}{span}{residual}"


#: What an unset setting (``None`` or an empty list) means, by the last part of
#: its name; any other unset setting reads :data:`NOT_SET`.
UNSET_MEANS = {
    "band_hz": "automatic (the resolved band below)",
    "max_order": "automatic (the resolved order below)",
    "expect_hz": "none (automatic selection)",
    "exp_window_tau_s": "as stored with the FRFs",
    "tol_freq": "tuned default",
    "tol_zeta": "tuned default",
    "tol_mac": "tuned default",
}
NOT_SET = "not set"


def setting_text(name: str, value: str) -> str:
    """A setting's value as the report shows it: the text of ``value``, or what
    leaving the setting unset means (``None``, ``()``, ``[]`` or empty).

    Examples
    --------
    >>> setting_text("identification.max_order", "None")
    'automatic (the resolved order below)'
    >>> setting_text("identification.expect_hz", "()"), setting_text("frf.window", "None")
    ('none (automatic selection)', 'not set')
    >>> setting_text("identification.min_fraction", "0.3")
    '0.3'
    """
    if str(value).strip() not in ("None", "()", "[]", ""):
        return str(value)
    return UNSET_MEANS.get(name.rsplit(".", 1)[-1], NOT_SET)
