"""FRF quantities (accelerance, mobility, receptance) and plausible frequency axes."""

from __future__ import annotations

from typing import Literal

import numpy as np

from ema_pipeline.data.errors import DataError

Quantity = Literal["accelerance", "mobility", "receptance"]

#: SI units of each FRF quantity (response per newton of force).
QUANTITY_UNITS: dict[str, str] = {
    "accelerance": "m/s^2/N",
    "mobility": "m/s/N",
    "receptance": "m/N",
}
#: Power of (j*omega) that turns receptance into the quantity.
QUANTITY_POWER: dict[str, int] = {"receptance": 0, "mobility": 1, "accelerance": 2}


#: Fewest frequency lines an FRF must have for identification: the default band
#: skips the first 5 lines, and pLSCF needs 2 (p + 1) lines for model order p;
#: below about 32 lines the stabilization diagram has too few orders to find a
#: mode (measured: a single-mode FRF is found from 32 lines, not from 24).
MIN_FRF_LINES: int = 32

#: Plausible frequency axes: line spacing at least this (Hz; a 11.6-day record) ...
MIN_DF_HZ = 1e-6
#: ... and no line above this (Hz). :func:`ema_pipeline.io.check_frequency_axis`
#: refuses other axes; the acquisition keeps recordings within them.
MAX_AXIS_HZ = 1e7


def quantity_power(quantity: str) -> int:
    """Power q of (j*omega) that turns receptance into ``quantity``: 0 receptance,
    1 mobility, 2 accelerance (H_quantity = (j omega)^q H_receptance).

    In pole-residue form the same power multiplies the residue: the residue of
    the quantity is lambda_r^q times that of the receptance.

    Examples
    --------
    >>> quantity_power("receptance"), quantity_power("mobility"), quantity_power("accelerance")
    (0, 1, 2)
    """
    try:
        return QUANTITY_POWER[quantity]
    except KeyError:
        raise DataError(
            f"unknown FRF quantity {quantity!r}; expected one of {sorted(QUANTITY_POWER)}"
        ) from None


def quantity_factor(quantity_from: str, quantity_to: str, freq_hz: np.ndarray) -> np.ndarray:
    """Factor (j omega)^(q_to - q_from) per line that converts an FRF of
    ``quantity_from`` into ``quantity_to`` (omega = 2 pi ``freq_hz``).

    Accelerance = j omega mobility = (j omega)^2 receptance. Where the factor is
    not finite (negative powers at 0 Hz) it is 0.

    Examples
    --------
    >>> quantity_factor("receptance", "accelerance", np.array([0.0, 1.0])).real  # -(2 pi f)^2
    array([  0.        , -39.4784176])
    >>> quantity_factor("accelerance", "receptance", np.array([0.0, 1.0])).real  # 0 where infinite
    array([ 0.        , -0.02533030])
    """
    power = quantity_power(quantity_to) - quantity_power(quantity_from)
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = jw**power
    return np.where(np.isfinite(factor), factor, 0.0)


def axis_is_uniform(freq_hz: np.ndarray, rtol: float = 1e-6) -> bool:
    """True when the lines of ``freq_hz`` are equally spaced (within ``rtol`` of the
    mean step); identification needs a uniform axis.

    Parameters
    ----------
    freq_hz : (n_freq,) frequency axis in Hz.
    rtol : tolerance on each step relative to the mean step.

    Returns
    -------
    bool (True for fewer than 3 lines).

    Examples
    --------
    >>> axis_is_uniform(np.arange(5.0)), axis_is_uniform(np.array([1.0, 2.0, 4.0]))
    (True, False)
    """
    f = np.asarray(freq_hz, dtype=float)
    if f.size < 3:
        return True
    step = np.diff(f)
    return bool(np.all(np.abs(step - step.mean()) <= rtol * abs(step.mean())))
