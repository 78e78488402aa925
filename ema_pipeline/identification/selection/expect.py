"""Expected natural frequencies (``expect_hz``, ``--expect``): which mode answers which guess.

A guess g is *found* by a mode of frequency f when |f - g| < tol g
(:func:`within_tolerance`), ``tol`` the field ``expect_tol`` of
:class:`~ema_pipeline.identification.thresholds.SelectionThresholds` (15 %):
the same tolerance by which the selection picks the candidate that answers
a guess
(:func:`~ema_pipeline.identification.selection.trajectories.select_expected`),
so that a guess answered by a kept mode is never also reported not found. A
guess with no mode inside its tolerance is *not found*: it is reported (a
warning and a row with empty values in the modes table), never answered by
a distant mode. Each mode answers at most one guess; guesses and modes are
paired nearest first.

This module imports only numpy (pandas where a table is made), so that the
selection, the backends and the pipeline can all use it without an import
cycle.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

def within_tolerance(fn_hz: np.ndarray | float, guess_hz: np.ndarray | float,
                     tol: float) -> np.ndarray:
    """True where a mode of frequency ``fn_hz`` may answer the guess
    ``guess_hz``: |f - g| < ``tol`` g (broadcast).

    Examples
    --------
    >>> within_tolerance(np.array([90.0, 110.0, 120.0]), 100.0, 0.15).tolist()
    [True, True, False]
    """
    return np.asarray(np.abs(fn_hz - guess_hz) < tol * guess_hz)


def match_expected(
    fn_hz: Sequence[float] | np.ndarray,
    expect_hz: Sequence[float] | np.ndarray,
    tol: float,
    *,
    priority: Sequence[float] | np.ndarray | None = None,
) -> np.ndarray:
    """For each guess the index of the mode that answers it, or -1 (not found).

    Parameters
    ----------
    fn_hz : (n_modes,) candidate natural frequencies in Hz.
    expect_hz : (n_guesses,) guessed natural frequencies in Hz.
    tol : a mode answers a guess g only within ``tol`` g
        (:func:`within_tolerance`; ``SelectionThresholds.expect_tol``).
    priority : (n_modes,) optional; among modes equally near a guess (relative
        distances within 1e-4) the one of higher priority (e.g. more stable
        model orders) is taken.

    Returns
    -------
    (n_guesses,) int  index into ``fn_hz``, -1 for a guess not found. Pairs are
    formed nearest first (relative distance), each mode and guess used once.

    Examples
    --------
    >>> match_expected([18.1, 112.0, 327.5], [18.0, 115.0, 500.0, 330.0], 0.15)
    array([ 0,  1, -1,  2])
    >>> match_expected([18.1, 112.0], [18.0, 115.0], tol=0.01)  # 112 is 2.6 % off
    array([ 0, -1])
    >>> match_expected([100.0], [99.0, 101.5], 0.15)  # one mode answers one guess
    array([ 0, -1])
    """
    fn = np.asarray(fn_hz, dtype=float).ravel()
    guess = np.asarray(expect_hz, dtype=float).ravel()
    if not tol > 0:
        raise ValueError(f"tol must be > 0, got {tol}")
    prio = np.zeros(fn.size) if priority is None else np.asarray(priority, dtype=float).ravel()
    match = np.full(guess.size, -1, dtype=int)
    if fn.size == 0 or guess.size == 0:
        return match
    rel = np.abs(fn[None, :] - guess[:, None]) / guess[:, None]  # (n_guesses, n_modes)
    ok = within_tolerance(fn[None, :], guess[:, None], tol)
    span = max(float(np.ptp(prio)), 1.0)
    key = rel - 1e-4 * (prio - prio.min())[None, :] / span
    g_idx, m_idx = np.nonzero(ok)
    used = np.zeros(fn.size, dtype=bool)
    for k in np.argsort(key[g_idx, m_idx], kind="stable"):
        g, m = g_idx[k], m_idx[k]
        if match[g] < 0 and not used[m]:
            match[g], used[m] = m, True
    return match


def not_found_message(expect_hz: Sequence[float] | np.ndarray, match: np.ndarray,
                      tol: float) -> str:
    """One line naming the guesses that no mode answers ("" when all are
    found); ``tol`` the tolerance :func:`match_expected` used.

    Examples
    --------
    >>> not_found_message([18.0, 500.0], np.array([0, -1]), 0.15)
    'expected mode(s) not found within 15 % of 500 Hz (reported with empty values)'
    """
    missing = np.asarray(expect_hz, dtype=float)[np.asarray(match) < 0]
    if missing.size == 0:
        return ""
    return (f"expected mode(s) not found within {100 * tol:g} % of "
            f"{', '.join(f'{f:g}' for f in missing)} Hz (reported with empty values)")


def with_expected_rows(
    table: pd.DataFrame,
    expect_hz: Sequence[float] | np.ndarray,
    tol: float,
) -> pd.DataFrame:
    """The modes table with an ``expect_hz`` column and one row per guess that
    no mode answers (every other column empty), ordered by frequency.

    ``table`` has one row per mode with columns ``mode`` and ``fn_hz`` (the
    table of :func:`ema_pipeline.identification.modes_table`); modes that
    answer no guess keep an empty ``expect_hz``. ``mode`` stays the number of
    the identified mode (empty on a not-found row). A mode answers a guess
    within ``tol`` of it (:func:`match_expected`).

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({"mode": [1, 2], "fn_hz": [18.1, 112.0], "zeta_pct": [0.5, 0.7]})
    >>> with_expected_rows(table, [18.0, 60.0, 112.5], 0.15)
       mode  fn_hz  zeta_pct  expect_hz
    0     1   18.1       0.5       18.0
    1  <NA>    NaN       NaN       60.0
    2     2  112.0       0.7      112.5
    """
    import pandas as pd  # here: only --expect needs it (pandas costs 0.4-0.5 s to import)

    guess = np.asarray(expect_hz, dtype=float).ravel()
    out = table.copy()
    match = match_expected(out["fn_hz"].to_numpy(), guess, tol)
    answered = np.full(len(out), np.nan)
    answered[match[match >= 0]] = guess[match >= 0]
    out["expect_hz"] = answered
    missing = pd.DataFrame({"expect_hz": guess[match < 0]})
    out = pd.concat([out, missing], ignore_index=True) if len(missing) else out
    out["mode"] = out["mode"].astype("Int64")
    sort_key = out["fn_hz"].fillna(out["expect_hz"])
    return out.iloc[np.argsort(sort_key.to_numpy(), kind="stable")].reset_index(drop=True)
