"""The error the noise alone gives a fit: what the fit verdict of the identify
page compares the fit error with.

The residual ``R = H - H_fit`` of a fit with every mode holds the noise of
the data; a mode missing (or wrong) adds a smooth resonance to it, spread over
the lines of its half-power band. Noise varies from line to line: its second
differences ``R[k-1] - 2 R[k] + R[k+1]`` have the mean square ``6 sigma**2``
for white noise of variance ``sigma**2`` per line, while a smooth resonance
resolved by several lines hardly has any. So ``sigma**2 = mean(|d2 R|**2) / 6``
is the noise level the data show, and ``sqrt(N sigma**2) / ||H||`` the
normalised error ``||H - H_fit|| / ||H||`` the noise alone would give a
perfect model. A resonance narrower than the line spacing varies from line
to line too: what the lines cannot resolve counts as noise, as it must (no
model can fit it better).
"""

from __future__ import annotations

import numpy as np

__all__ = ["noise_error"]


def noise_error(H: np.ndarray, H_fit: np.ndarray) -> np.ndarray:
    """The normalised error the noise alone gives, per channel (ratio).

    Parameters
    ----------
    H, H_fit : (n_out, n_in, n_lines) complex
        The measured FRFs of the band and their synthesis.

    Returns
    -------
    (n_out, n_in) float; NaN where there are fewer than 8 lines or the
    shapes differ.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> f = np.linspace(0.0, 100.0, 4001)
    >>> H_fit = (1.0 / (50.0**2 - f**2 + 1j * f))[None, None, :]
    >>> noise = 1e-5 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    >>> H = H_fit + noise
    >>> truth = np.linalg.norm(noise) / np.linalg.norm(H)
    >>> bool(abs(noise_error(H, H_fit)[0, 0] / truth - 1) < 0.05)
    True
    """
    H, H_fit = np.asarray(H), np.asarray(H_fit)
    if H.shape != H_fit.shape or H.ndim != 3 or H.shape[-1] < 8:
        return np.full(H.shape[:2] if H.ndim == 3 else (1, 1), np.nan)
    R = H - H_fit
    d2 = R[..., :-2] - 2 * R[..., 1:-1] + R[..., 2:]
    sigma2 = np.mean(np.abs(d2) ** 2, axis=-1) / 6
    total = np.sum(np.abs(H) ** 2, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(total > 0, np.sqrt(sigma2 * H.shape[-1] / total), np.nan)
