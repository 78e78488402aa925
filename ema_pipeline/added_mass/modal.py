"""Modal added mass, eq. (10), and the pairing of modes between configurations.

* :func:`modal_added_mass` - the ratio m_ar / m_r of every mode from the natural
  frequencies and damping ratios of the genuine and one modified configuration
  (eq. 10 with eq. 4), with the modes paired robustly (frequency, and MAC
  (:func:`ema_pipeline.modal.mac`) when both configurations carry mode shapes);
  a mode missing in one configuration is reported as missing, never paired
  with a wrong partner.
* :func:`pair_modes` - that pairing, by
  :func:`scipy.optimize.linear_sum_assignment`.

Why written here: eq. (10) is a line of numpy; the assignment is scipy's.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import DataError, ModalParameters, damped
from ema_pipeline.modal import mac as mac_of

__all__ = [
    "AddedMassResult",
    "modal_added_mass",
    "modal_added_mass_all",
    "pair_modes",
    "replace_configuration",
    "require_genuine",
]


def pair_modes(
    fn_a_hz: np.ndarray,
    fn_b_hz: np.ndarray,
    *,
    shapes_a: np.ndarray | None = None,
    shapes_b: np.ndarray | None = None,
    rel_tol: float = 0.2,
    mac_min: float = 0.6,
) -> tuple[np.ndarray, np.ndarray]:
    """Pair the modes of configuration b with those of a.

    A pair (i, j) is admissible when |f_b,j - f_a,i| / f_a,i <= ``rel_tol``
    (added mass lowers frequencies by up to ~10 %, adjacent bending modes are
    farther apart) and, when both shape sets are given, MAC >= ``mac_min``.
    Among admissible pairs the assignment minimising the total relative
    frequency distance (plus 1 - MAC with shapes) is taken
    (:func:`scipy.optimize.linear_sum_assignment`); a mode without admissible
    partner stays unpaired.

    Returns
    -------
    partner : (n_a,) int, index into b of each mode of a, -1 if missing in b.
    mac : (n_a,) MAC of the pair, NaN without shapes or partner.

    Examples
    --------
    >>> partner, mac = pair_modes([20.0, 100.0], [96.0, 19.0])
    >>> partner, mac
    (array([1, 0]), array([nan, nan]))
    >>> pair_modes([20.0, 100.0], [19.0])[0]  # the 100 Hz mode is missing
    array([ 0, -1])
    """
    fa = np.atleast_1d(np.asarray(fn_a_hz, dtype=float))
    fb = np.atleast_1d(np.asarray(fn_b_hz, dtype=float))
    if rel_tol <= 0:
        raise DataError(f"rel_tol must be > 0, got {rel_tol}")
    partner = np.full(fa.size, -1)
    mac_pair = np.full(fa.size, np.nan)
    if fa.size == 0 or fb.size == 0:
        return partner, mac_pair
    with np.errstate(invalid="ignore", divide="ignore"):
        dist = np.abs(fb[None, :] - fa[:, None]) / fa[:, None]
    ok = np.isfinite(dist) & (dist <= rel_tol)
    cost = dist / rel_tol
    mac = None
    if shapes_a is not None and shapes_b is not None:
        mac = mac_of(shapes_a, shapes_b)
        if mac.shape != dist.shape:
            raise DataError(
                f"{mac.shape[0]} / {mac.shape[1]} mode shapes for {fa.size} / {fb.size} frequencies"
            )
        ok &= mac >= mac_min
        cost = cost + (1.0 - mac)
    if not ok.any():
        return partner, mac_pair
    big = 1e6 + float(np.nanmax(np.where(ok, cost, 0.0)))
    from scipy.optimize import linear_sum_assignment  # here: scipy.optimize is 0.2 s of start-up

    rows, cols = linear_sum_assignment(np.where(ok, cost, big))
    good = ok[rows, cols]
    partner[rows[good]] = cols[good]
    if mac is not None:
        mac_pair[rows[good]] = mac[rows[good], cols[good]]
    return partner, mac_pair


@dataclass(frozen=True)
class AddedMassResult:
    """Modal added-mass ratios m_ar / m_r (ratios, not percent), eq. (10).

    One entry per genuine mode. ``partner`` is the index of the paired mode in
    the modified configuration (-1: missing there, ratio NaN); ``unpaired``
    lists modified modes with no genuine partner; ``messages`` explains both.
    ``ratio_std`` is propagated from ``fn_std_hz`` of both configurations (NaN
    when either is unknown).
    """

    configuration: str
    genuine_configuration: str
    mode: np.ndarray
    partner: np.ndarray
    fn_genuine_hz: np.ndarray
    fn_modified_hz: np.ndarray
    ratio: np.ndarray
    ratio_std: np.ndarray
    mac: np.ndarray
    unpaired: np.ndarray
    messages: tuple[str, ...]

    @property
    def missing(self) -> np.ndarray:
        """True for genuine modes not found in the modified configuration."""
        return self.partner < 0


def modal_added_mass(
    genuine: ModalParameters,
    modified: ModalParameters,
    *,
    rel_tol: float = 0.2,
    mac_min: float = 0.6,
) -> AddedMassResult:
    """Modal added-mass ratio of every genuine mode, eq. (10).

    m_ar / m_r = ((1 - zeta_wr^2) / (1 - zeta_r^2)) * omega_dr^2 / omega_dwr^2 - 1
    (eq. 10, k_ar = 0), which by eq. (4) equals (f_n,r / f_n,wr)^2 - 1 with the
    undamped natural frequencies stored in :class:`ModalParameters`.

    Modes are paired by :func:`pair_modes` (nearest frequency within
    ``rel_tol``, and MAC >= ``mac_min`` when both carry shapes at the same
    DOFs). The standard deviation follows from fn_std_hz by first-order
    propagation, sigma^2 = (2 f/f_w^2 sigma_f)^2 + (2 f^2/f_w^3 sigma_fw)^2;
    zeta_std does not enter because the ratio depends on the undamped
    frequencies only.

    Examples
    --------
    Undamped frequencies 20 and 100 Hz drop to 19 and 96 Hz:

    >>> genuine = ModalParameters(fn_hz=[20.0, 100.0], zeta=[0.01, 0.005])
    >>> modified = ModalParameters(fn_hz=[19.0, 96.0], zeta=[0.012, 0.005])
    >>> modal_added_mass(genuine, modified).ratio.round(5)  # (20/19)^2 - 1, (100/96)^2 - 1
    array([0.10803, 0.08507])
    """
    for mp, name in ((genuine, "genuine"), (modified, "modified")):
        if np.any(~np.isfinite(mp.fn_hz)) or np.any(mp.fn_hz <= 0):
            raise DataError(f"{name} configuration {mp.configuration!r}: natural frequencies "
                            "must be finite and positive")
        if np.any((mp.zeta < 0) | (mp.zeta >= 1)):
            raise DataError(f"{name} configuration {mp.configuration!r}: damping ratios must "
                            "lie in [0, 1) (ratios, not percent)")
    shapes_g = shapes_w = None
    if genuine.shapes is not None and modified.shapes is not None:
        if genuine.dofs and modified.dofs and tuple(genuine.dofs) != tuple(modified.dofs):
            raise DataError("genuine and modified mode shapes are given at different DOFs")
        shapes_g, shapes_w = genuine.shapes, modified.shapes
    partner, mac = pair_modes(genuine.fn_hz, modified.fn_hz, shapes_a=shapes_g,
                              shapes_b=shapes_w, rel_tol=rel_tol, mac_min=mac_min)
    have = partner >= 0
    fn_w = np.full(genuine.n_modes, np.nan)
    fn_w[have] = modified.fn_hz[partner[have]]
    std_w = np.full(genuine.n_modes, np.nan)
    std_w[have] = modified.fn_std_hz[partner[have]]
    zeta_w = np.full(genuine.n_modes, np.nan)
    zeta_w[have] = modified.zeta[partner[have]]
    fd_g = genuine.fd_hz
    fd_w = damped(fn_w, zeta_w)
    ratio = (1 - zeta_w**2) / (1 - genuine.zeta**2) * fd_g**2 / fd_w**2 - 1  # eq. (10)
    f, fw, sf = genuine.fn_hz, fn_w, genuine.fn_std_hz
    ratio_std = np.sqrt((2 * f / fw**2 * sf) ** 2 + (2 * f**2 / fw**3 * std_w) ** 2)
    modes = np.arange(1, genuine.n_modes + 1)
    unpaired = np.setdiff1d(np.arange(modified.n_modes), partner[have])
    cfg = modified.configuration or "modified"
    msgs = [
        f"{cfg}: genuine mode {m} ({f[m - 1]:.4g} Hz) not found (no mode within "
        f"{rel_tol:.0%}{' and MAC >= ' + str(mac_min) if shapes_g is not None else ''}); "
        "added mass not computed"
        for m in modes[~have]
    ]
    msgs += [f"{cfg}: mode at {modified.fn_hz[j]:.4g} Hz has no genuine partner"
             for j in unpaired]
    return AddedMassResult(
        configuration=cfg,
        genuine_configuration=genuine.configuration or "genuine",
        mode=modes,
        partner=partner,
        fn_genuine_hz=genuine.fn_hz.copy(),
        fn_modified_hz=fn_w,
        ratio=ratio,
        ratio_std=ratio_std,
        mac=mac,
        unpaired=unpaired,
        messages=tuple(msgs),
    )


def modal_added_mass_all(
    measured: Mapping[str, ModalParameters], genuine: str = "genuine", **kwargs: float
) -> dict[str, AddedMassResult]:
    """Eq. (10) for every configuration of ``measured`` against ``measured[genuine]``."""
    require_genuine(measured, genuine)
    return {
        name: modal_added_mass(replace_configuration(measured[genuine], genuine),
                               replace_configuration(mp, name), **kwargs)
        for name, mp in measured.items()
        if name != genuine
    }


def replace_configuration(mp: ModalParameters, name: str) -> ModalParameters:
    """``mp`` with its configuration name set (kept if already given)."""
    if mp.configuration:
        return mp
    return ModalParameters(fn_hz=mp.fn_hz, zeta=mp.zeta, fn_std_hz=mp.fn_std_hz,
                           zeta_std=mp.zeta_std, shapes=mp.shapes, dofs=mp.dofs,
                           configuration=name)


def require_genuine(measured: Mapping[str, ModalParameters], genuine: str) -> None:
    """Raise a DataError naming the found configurations when ``genuine`` is missing."""
    if genuine not in measured:
        raise DataError(
            f"configuration {genuine!r} (the genuine beam) is missing; found "
            f"{sorted(measured) or 'none'}"
        )
