"""The synthesis of the picked poles in the interactive stabilization diagram.

The page refits the FRFs whenever a pole is picked or unpicked and draws the
sum of |H_synth| over all channels (``path[data-synthesis]``) over the sum of
|H| of the measurement (``path[data-frf-overlay]``), on the same log scale.
The model is LSFD's (:func:`ema_pipeline.identification.refinement.lsfd.design_matrix`):
for every picked pole lambda (from its frequency and damping, less the
window's decay rate; a kept mode's refined ones, as the tables give them and
as ``--picks`` refines the pick), a complex residue per channel with its
complex-conjugate term, plus the lower
and upper residual terms of the FRF's quantity when the identification used
them; the real coefficients of all channels are one linear least-squares
problem, solved in the page by its normal equations (columns scaled to a
unit diagonal, Cholesky). Untouched, the picks include the companions, as
the picks file does.

The page carries the measured FRFs for this (:func:`synthesis_data`): every
line of the band (every ``k``-th above :data:`FIT_LINES`), each complex value as
one character (3 bytes in UTF-8): its log10 magnitude in 256 levels over
the channel's top :data:`DECADES` decades (2.3 % at most) and its phase in
128 (1.4 degrees at most). The fit averages these errors over the lines; the
curve drawn is the model's, at every line of the overlay. Not base64: its
letters spell any short word or label somewhere in a long string, and a
search of the page for "3+Z" or "nan" would find them.

Above :data:`SYNTH_VALUES` values, the channels are replaced by the leading components of the real
SVD of their real and imaginary parts, ``H_c = sum_k U_ck Y_k`` with real
``U``; the real-coefficient fit is real-linear, so each channel's synthesis
is ``sum_k U_ck`` times the synthesis of ``Y_k``.
"""

from __future__ import annotations

import numpy as np

from ema_pipeline.data import FRFSet, quantity_power
from ema_pipeline.identification.result import ResolvedSettings
from ema_pipeline.report.scripts import page_script

__all__ = ["CODE_0", "DECADES", "FIT_LINES", "MAG_LEVELS", "PHASE_LEVELS", "SYNTHESIS_JS",
           "SYNTH_VALUES", "decode_levels", "synthesis_data"]

#: At most this many lines of the band are fitted in the page (all of them
#: below it, as the identification's LSFD).
FIT_LINES = 4096
#: At most this many complex values (lines x channels or components) in the page.
SYNTH_VALUES = 40_000
#: One character a value, ``CODE_0 + PHASE_LEVELS * m + p``: the magnitude's
#: level m (0 to MAG_LEVELS, log10 from the row's ``lmin`` to its ``lmax``,
#: at most DECADES below it) and the phase's p (0 to PHASE_LEVELS - 1 over
#: 2 pi). 15 bits: the characters run from U+3400 to U+B3FF (CJK and Hangul,
#: 3 bytes in UTF-8), far from the letters, digits and signs a page's text uses.
CODE_0, MAG_LEVELS, PHASE_LEVELS, DECADES = 0x3400, 255, 128, 5.0


def _quantize(Y: np.ndarray) -> tuple[str, list[float], list[float]]:
    """``Y`` (rows, n) complex as one character a value (see the constants);
    zeros, NaN and magnitudes more than DECADES below the row's largest at
    its lowest level."""
    mag = np.abs(np.nan_to_num(Y))
    with np.errstate(divide="ignore"):
        lg = np.where(mag > 0, np.log10(np.where(mag > 0, mag, 1.0)), np.nan)
    lmin, lmax = [], []
    codes = np.empty(Y.shape, dtype=np.int64)
    for k, row in enumerate(lg):
        ok = np.isfinite(row)
        b = float(row[ok].max()) if ok.any() else 0.0
        a = max(float(row[ok].min()), b - DECADES) if ok.any() else b - 1.0
        b = b if b > a else a + 1.0
        m = np.rint(np.clip((np.where(ok, row, a) - a) / (b - a), 0.0, 1.0) * MAG_LEVELS)
        p = np.rint((np.angle(np.nan_to_num(Y[k])) + np.pi) / (2 * np.pi) * PHASE_LEVELS)
        codes[k] = CODE_0 + PHASE_LEVELS * m.astype(np.int64) + p.astype(np.int64) % PHASE_LEVELS
        lmin.append(round(a, 6))
        lmax.append(round(b, 6))
    return "".join(map(chr, codes.ravel().tolist())), lmin, lmax


def decode_levels(data: dict[str, object]) -> np.ndarray:
    """The complex values (rows, n) of :func:`synthesis_data`'s ``levels``, as
    the page decodes them (for tests and checks).

    Examples
    --------
    >>> f = np.linspace(10.0, 20.0, 101)
    >>> Y = (1.0 / (f - 15.0 - 0.1j))[None]
    >>> levels, lmin, lmax = _quantize(Y)
    >>> back = decode_levels({"levels": levels, "rows": 1, "n": 101, "lmin": lmin,
    ...                       "lmax": lmax})
    >>> len(levels.encode()), bool(np.abs(back / Y - 1).max() < 0.035)
    (303, True)
    """
    q = np.array([ord(c) - CODE_0 for c in str(data["levels"])], dtype=float)
    q = q.reshape(int(data["rows"]), int(data["n"]))  # type: ignore[call-overload]
    lmin = np.asarray(data["lmin"], dtype=float)[:, None]
    lmax = np.asarray(data["lmax"], dtype=float)[:, None]
    m, p = np.divmod(q, PHASE_LEVELS)
    return 10 ** (lmin + m / MAG_LEVELS * (lmax - lmin)) * np.exp(
        1j * (p / PHASE_LEVELS * 2 * np.pi - np.pi))


def synthesis_data(sub: FRFSet, settings: ResolvedSettings) -> dict[str, object]:
    """What the page needs to synthesise the picks: the FRFs of ``sub`` (the
    band) as described in the module docstring, with the model's settings
    (``q``, the quantity's power; ``low``/``up``, the residual terms; ``wdr``,
    the window's decay rate in 1/s). Empty for an empty band.

    Examples
    --------
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.data import ModalParameters
    >>> from ema_pipeline.identification import identify
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> frf = FRFSet(freq_hz=f, H=H)
    >>> d = synthesis_data(frf.band(5.0, 95.0), identify(frf).settings)
    >>> d["n"], d["rows"], d["mix"], len(d["levels"])
    (361, 2, None, 722)
    """
    n = sub.freq_hz.size
    if n < 2:
        return {}
    step = max(1, -(-n // FIT_LINES))
    f = sub.freq_hz[::step]
    Y = sub.H.reshape(-1, n)[:, ::step]
    mix = None
    if Y.size > SYNTH_VALUES:
        r = max(1, SYNTH_VALUES // f.size)
        U, s, Vt = np.linalg.svd(np.concatenate([Y.real, Y.imag], axis=1),
                                 full_matrices=False)
        Y = s[:r, None] * (Vt[:r, : f.size] + 1j * Vt[:r, f.size:])
        mix = [[round(float(v), 6) for v in u] for u in U[:, :r]]
    levels, lmin, lmax = _quantize(Y)
    return {"f0": float(f[0]), "df": float(f[1] - f[0]), "n": int(f.size),
            "rows": int(Y.shape[0]), "lmin": lmin, "lmax": lmax, "levels": levels, "mix": mix,
            "q": quantity_power(sub.quantity), "low": bool(settings.lower_residual),
            "up": bool(settings.upper_residual), "wdr": float(settings.window_decay_rate)}


#: The page's synthesis (functions of the diagram's script, which calls
#: ``synthesis(poles)`` with the picked poles as ``[re, im]`` in rad/s before
#: the window correction and gets the log10 of the summed |H_synth| on the
#: overlay's lines ``d.f0 + k d.df``, or null): the file ``report/js/synthesis.js``.
SYNTHESIS_JS = page_script("synthesis.js", CODE_0=CODE_0, MAG_LEVELS=MAG_LEVELS,
                           PHASE_LEVELS=PHASE_LEVELS)
