"""Expected natural frequencies (``expect_hz``, ``--expect``): which mode answers which guess.

A guess g is *found* by a mode of frequency f when |f - g| <= tol_pct / 100 * g
(default :data:`EXPECT_TOL_PCT` = 5 %: more than the spread of a mode's frequency
over the model orders and than the shift of a mode between the paper's
configurations, far less than the spacing of the modes of a beam). A guess
with no mode inside its tolerance is *not found*: it is reported (a warning
and a row with empty values in the modes table), never answered by a distant
mode. Each mode answers at most one guess; guesses and modes are paired
nearest first.

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

#: Default tolerance of a guess, percent of the guessed frequency.
EXPECT_TOL_PCT: float = 5.0


def match_expected(
    fn_hz: Sequence[float] | np.ndarray,
    expect_hz: Sequence[float] | np.ndarray,
    tol_pct: float = EXPECT_TOL_PCT,
    *,
    priority: Sequence[float] | np.ndarray | None = None,
) -> np.ndarray:
    """For each guess the index of the mode that answers it, or -1 (not found).

    Parameters
    ----------
    fn_hz : (n_modes,) candidate natural frequencies in Hz.
    expect_hz : (n_guesses,) guessed natural frequencies in Hz.
    tol_pct : a mode answers a guess g only within ``tol_pct`` percent of g.
    priority : (n_modes,) optional; among modes equally near a guess (relative
        distances within 1e-4) the one of higher priority (e.g. more stable
        model orders) is taken.

    Returns
    -------
    (n_guesses,) int  index into ``fn_hz``, -1 for a guess not found. Pairs are
    formed nearest first (relative distance), each mode and guess used once.

    Examples
    --------
    >>> match_expected([18.1, 112.0, 327.5], [18.0, 115.0, 500.0, 330.0])
    array([ 0,  1, -1,  2])
    >>> match_expected([18.1, 112.0], [18.0, 115.0], tol_pct=1.0)  # 112 is 2.6 % off
    array([ 0, -1])
    >>> match_expected([100.0], [99.0, 101.5])  # one mode answers one guess
    array([ 0, -1])
    """
    fn = np.asarray(fn_hz, dtype=float).ravel()
    guess = np.asarray(expect_hz, dtype=float).ravel()
    if not tol_pct > 0:
        raise ValueError(f"tol_pct must be > 0, got {tol_pct}")
    prio = np.zeros(fn.size) if priority is None else np.asarray(priority, dtype=float).ravel()
    match = np.full(guess.size, -1, dtype=int)
    if fn.size == 0 or guess.size == 0:
        return match
    rel = np.abs(fn[None, :] - guess[:, None]) / guess[:, None]  # (n_guesses, n_modes)
    ok = rel <= tol_pct / 100.0
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
                      tol_pct: float = EXPECT_TOL_PCT) -> str:
    """One line naming the guesses that no mode answers ("" when all are found).

    Examples
    --------
    >>> not_found_message([18.0, 500.0], np.array([0, -1]))
    'expected mode(s) not found within 5 % of 500 Hz (reported with empty values)'
    """
    missing = np.asarray(expect_hz, dtype=float)[np.asarray(match) < 0]
    if missing.size == 0:
        return ""
    return (f"expected mode(s) not found within {tol_pct:g} % of "
            f"{', '.join(f'{f:g}' for f in missing)} Hz (reported with empty values)")


def with_expected_rows(
    table: pd.DataFrame,
    expect_hz: Sequence[float] | np.ndarray,
    tol_pct: float = EXPECT_TOL_PCT,
) -> pd.DataFrame:
    """The modes table with an ``expect_hz`` column and one row per guess that
    no mode answers (every other column empty), ordered by frequency.

    ``table`` has one row per mode with columns ``mode`` and ``fn_hz`` (the
    table of :func:`ema_pipeline.identification.modes_table`); modes that
    answer no guess keep an empty ``expect_hz``. ``mode`` stays the number of
    the identified mode (empty on a not-found row).

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({"mode": [1, 2], "fn_hz": [18.1, 112.0], "zeta_pct": [0.5, 0.7]})
    >>> with_expected_rows(table, [18.0, 60.0, 112.5])
       mode  fn_hz  zeta_pct  expect_hz
    0     1   18.1       0.5       18.0
    1  <NA>    NaN       NaN       60.0
    2     2  112.0       0.7      112.5
    """
    import pandas as pd  # here: only --expect needs it (pandas costs 0.4-0.5 s to import)

    guess = np.asarray(expect_hz, dtype=float).ravel()
    out = table.copy()
    match = match_expected(out["fn_hz"].to_numpy(), guess, tol_pct)
    answered = np.full(len(out), np.nan)
    answered[match[match >= 0]] = guess[match >= 0]
    out["expect_hz"] = answered
    missing = pd.DataFrame({"expect_hz": guess[match < 0]})
    out = pd.concat([out, missing], ignore_index=True) if len(missing) else out
    out["mode"] = out["mode"].astype("Int64")
    sort_key = out["fn_hz"].fillna(out["expect_hz"])
    return out.iloc[np.argsort(sort_key.to_numpy(), kind="stable")].reset_index(drop=True)
