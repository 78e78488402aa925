"""Added mass: modal added mass, eq. (10), and local added mass, eq. (14)-(20).

* :func:`modal_added_mass` - the ratio m_ar / m_r of every mode from the natural
  frequencies and damping ratios of the genuine and one modified configuration
  (eq. 10 with eq. 4), with the modes paired robustly (frequency, and MAC when
  both configurations carry mode shapes); a mode missing in one configuration
  is reported as missing, never paired with a wrong partner.
* :func:`local_added_mass` - the proportional modification factors delta_k,
  delta_m of the immersed element(s) by least squares (eq. 16-20) on the
  SEREP-reduced updated FE model (:mod:`ema_pipeline.fe`), two ways:
  ``"block"`` (the paper's: the "element matrices" are the 2 x 2 blocks of K_R,
  M_R at the element's two measurement nodes) and ``"projected"`` (the fine FE
  elements of the immersed part projected with SEREP, T^T K_e T).
* :func:`run_fe_stage` - the whole FE stage (paper Tables 2-6) from measured
  modal parameters, and :func:`fe_stage_tables` - those tables as DataFrames in
  the CSV forms of DESIGN.md; :func:`modal_parameters_from_table` reads the
  Table 1 form.

Sign convention (DESIGN.md): Delta_lambda_r = omega_wr^2 - omega_r^2 (modified
minus genuine, undamped by eq. 4) and, with mass-normalised Psi_r, the
first-order relation Psi_r^T K_a Psi_r - omega_r^2 Psi_r^T M_a Psi_r =
Delta_lambda_r (eq. 14 with consistent signs), so added mass gives delta_m > 0.
omega_r and Psi_r are the updated FE model's (eq. 16 needs the genuine
structure's modal model; the FE model supplies the shapes at all masters).

Why written here: these are the paper's formulas (a few lines of numpy each);
the least squares is numpy's, mode pairing uses
:func:`scipy.optimize.linear_sum_assignment`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from ema_pipeline import fe
from ema_pipeline.data import Beam, DataError, ModalParameters

__all__ = [
    "AddedMassResult",
    "LocalAddedMassResult",
    "FEStageResult",
    "mac_matrix",
    "pair_modes",
    "modal_added_mass",
    "modal_added_mass_all",
    "modal_added_mass_table",
    "local_added_mass_factors",
    "local_added_mass",
    "modal_parameters_from_table",
    "run_fe_stage",
    "fe_stage_tables",
    "TABLE_COLUMNS",
]

Method = Literal["block", "projected"]
METHODS: tuple[str, ...] = ("block", "projected")

#: Required leading columns of each table (DESIGN.md); extra columns follow them.
TABLE_COLUMNS: dict[str, tuple[str, ...]] = {
    "table2_modal_added_mass": ("configuration", "mode", "added_mass_ratio"),
    "table3_fe_initial": ("mode", "fn_hz"),
    "table4_updated_parameters": ("parameter", "unit", "initial", "updated", "lower", "upper"),
    "table5_fe_updated": ("mode", "fn_hz"),
    "table6_local_added_mass": ("configuration", "method", "delta_k", "delta_m"),
}


# ---------------------------------------------------------------------------
# mode pairing
# ---------------------------------------------------------------------------
def mac_matrix(shapes_a: np.ndarray, shapes_b: np.ndarray) -> np.ndarray:
    """Modal assurance criterion |a^H b|^2 / ((a^H a)(b^H b)) for all column pairs.

    shapes_a (n_dof, n_a), shapes_b (n_dof, n_b), real or complex -> (n_a, n_b) in [0, 1].
    """
    a = np.asarray(shapes_a)
    b = np.asarray(shapes_b)
    if a.ndim != 2 or b.ndim != 2 or a.shape[0] != b.shape[0]:
        raise DataError(f"mode shapes {a.shape} and {b.shape} are not at the same DOFs")
    num = np.abs(a.conj().T @ b) ** 2
    den = np.real(np.sum(a.conj() * a, axis=0))[:, None] * np.real(np.sum(b.conj() * b, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / den, 0.0)


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
        mac = mac_matrix(shapes_a, shapes_b)
        if mac.shape != dist.shape:
            raise DataError(
                f"{mac.shape[0]} / {mac.shape[1]} mode shapes for {fa.size} / {fb.size} frequencies"
            )
        ok &= mac >= mac_min
        cost = cost + (1.0 - mac)
    if not ok.any():
        return partner, mac_pair
    big = 1e6 + float(np.nanmax(np.where(ok, cost, 0.0)))
    rows, cols = linear_sum_assignment(np.where(ok, cost, big))
    good = ok[rows, cols]
    partner[rows[good]] = cols[good]
    if mac is not None:
        mac_pair[rows[good]] = mac[rows[good], cols[good]]
    return partner, mac_pair


# ---------------------------------------------------------------------------
# modal added mass, eq. (10)
# ---------------------------------------------------------------------------
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
    fd_w = fn_w * np.sqrt(1 - zeta_w**2)
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
    _require_genuine(measured, genuine)
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


def modal_added_mass_table(results: Mapping[str, AddedMassResult]) -> pd.DataFrame:
    """Table 2 in the DESIGN.md form: configuration, mode, added_mass_ratio (+ extras)."""
    rows = []
    for name, res in results.items():
        for i, m in enumerate(res.mode):
            rows.append(
                {
                    "configuration": name,
                    "mode": int(m),
                    "added_mass_ratio": res.ratio[i],
                    "added_mass_ratio_std": res.ratio_std[i],
                    "fn_genuine_hz": res.fn_genuine_hz[i],
                    "fn_modified_hz": res.fn_modified_hz[i],
                    "paired": bool(res.partner[i] >= 0),
                }
            )
    cols = [*TABLE_COLUMNS["table2_modal_added_mass"], "added_mass_ratio_std",
            "fn_genuine_hz", "fn_modified_hz", "paired"]
    return pd.DataFrame(rows, columns=cols)


# ---------------------------------------------------------------------------
# local added mass, eq. (14)-(20)
# ---------------------------------------------------------------------------
def local_added_mass_factors(
    shapes: np.ndarray,
    omega2: np.ndarray,
    element_stiffness: np.ndarray,
    element_mass: np.ndarray,
    delta_lambda: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Proportional modification factors by least squares, eq. (16)-(20).

    A_rj = Psi_r^T K_j Psi_r, B_rj = -omega_r^2 Psi_r^T M_j Psi_r (eq. 16),
    [A, B] [dk; dm] = Delta_lambda (eq. 19), solved in the least-squares sense
    (eq. 20, via a QR/SVD solver instead of the normal equations).

    Parameters
    ----------
    shapes : (n_dof, p) mass-normalised mode shapes Psi_r of the genuine model.
    omega2 : (p,) its eigenvalues omega_r^2, (rad/s)^2.
    element_stiffness, element_mass : (n, n_dof, n_dof) K_j^e, M_j^e of the n
        modified elements (zero outside the element's DOFs).
    delta_lambda : (p,) omega_wr^2 - omega_r^2 in (rad/s)^2 (modified minus genuine).

    Returns
    -------
    delta_k, delta_m : (n,) factors (ratios). residual : (p,) [A,B] x - Delta_lambda.
    A, B : (p, n).
    """
    psi = np.asarray(shapes, dtype=float)
    w2 = np.asarray(omega2, dtype=float)
    kj = np.asarray(element_stiffness, dtype=float)
    mj = np.asarray(element_mass, dtype=float)
    dl = np.asarray(delta_lambda, dtype=float)
    p = w2.size
    n = kj.shape[0]
    if psi.shape[1] != p or dl.shape != (p,) or kj.shape != mj.shape or kj.shape[1:] != (
        psi.shape[0], psi.shape[0]
    ):
        raise DataError(
            f"inconsistent shapes: Psi {psi.shape}, omega2 {w2.shape}, K_e {kj.shape}, "
            f"M_e {mj.shape}, Delta_lambda {dl.shape}"
        )
    if 2 * n > p:
        raise DataError(
            f"{n} modified element(s) need at least {2 * n} modes (two unknowns per element, "
            f"eq. 19), but only {p} are available: the number of modified elements must not "
            "exceed half the number of measured modes"
        )
    if not (np.all(np.isfinite(dl)) and np.all(np.isfinite(psi))):
        raise DataError("Delta_lambda or mode shapes contain NaN/inf")
    a = np.einsum("ir,jik,kr->rj", psi, kj, psi)  # eq. (16)
    b = -w2[:, None] * np.einsum("ir,jik,kr->rj", psi, mj, psi)
    ab = np.hstack([a, b])
    sol, _, rank, sv = np.linalg.lstsq(ab, dl, rcond=None)  # eq. (20)
    if rank < 2 * n:
        raise DataError(
            "[A, B] of eq. (19) is rank deficient: the modes used cannot separate stiffness "
            "and mass changes of these elements"
        )
    return sol[:n], sol[n:], ab @ sol - dl, a, b


@dataclass(frozen=True)
class LocalAddedMassResult:
    """Local added mass of the modified elements (paper Table 6), eq. (14)-(20).

    ``elements`` are measurement element numbers (1 = at the clamp);
    ``delta_k``, ``delta_m`` the proportional factors (ratios, not percent);
    ``mode`` the genuine mode numbers used, ``delta_lambda`` their
    omega_wr^2 - omega_r^2 in (rad/s)^2, ``omega2`` the FE eigenvalues that went
    into B (eq. 16), ``A``, ``B`` the matrices of eq. (19), ``residual`` of the fit.
    """

    configuration: str
    method: str
    elements: tuple[int, ...]
    delta_k: np.ndarray
    delta_m: np.ndarray
    mode: np.ndarray
    delta_lambda: np.ndarray
    omega2: np.ndarray
    A: np.ndarray
    B: np.ndarray
    residual: np.ndarray


def _element_matrices(
    beam: Beam, red: fe.SerepModel, elements: Sequence[int], method: str
) -> tuple[np.ndarray, np.ndarray]:
    n_m = red.K_R.shape[0]
    kj = np.zeros((len(elements), n_m, n_m))
    mj = np.zeros_like(kj)
    for i, el in enumerate(elements):  # a handful of elements, not the FE hot path
        fe.fe_elements_of_measurement_element(beam, el)  # validates the number
        if method == "block":
            pos = [red.master_position(node) for node in (el, el + 1) if node != 1]
            sel = np.ix_(pos, pos)
            kj[i][sel] = red.K_R[sel]
            mj[i][sel] = red.M_R[sel]
        elif method == "projected":
            sub = fe.assemble_beam(beam, elements=fe.fe_elements_of_measurement_element(beam, el))
            kj[i] = red.T.T @ sub.K @ red.T
            mj[i] = red.T.T @ sub.M @ red.T
        else:
            raise DataError(f"unknown local added mass method {method!r}; use {METHODS}")
    return kj, mj


def local_added_mass(
    beam: Beam,
    genuine: ModalParameters,
    modified: ModalParameters,
    *,
    immersed_elements: Sequence[int] = (10,),
    method: Method = "block",
    reduced: fe.SerepModel | None = None,
    pairing: AddedMassResult | None = None,
) -> LocalAddedMassResult:
    """Local added mass of the immersed element(s), eq. (14)-(20).

    Parameters
    ----------
    beam : the (updated) FE beam of the genuine structure; it is reduced by
        SEREP to the free measurement nodes with as many modes as masters
        (:func:`ema_pipeline.fe.reduce_beam`) unless ``reduced`` is given.
    genuine, modified : measured modal parameters (undamped fn via eq. 4).
        Genuine measured mode r is FE mode r; modified modes are paired with
        :func:`modal_added_mass` (or ``pairing``), unpaired modes are left out.
    immersed_elements : measurement element numbers (1..n, n = tip element).
    method : ``"block"`` (paper): K_j, M_j are the 2 x 2 blocks of K_R, M_R at
        the element's two nodes (node 1 is clamped); ``"projected"``: the fine FE
        elements of the measurement element, projected T^T K_e T.

    omega_r and Psi_r are the updated FE model's (SEREP-reduced, mass-normalised
    w.r.t. M_R); Delta_lambda_r = (2 pi)^2 (f_wr^2 - f_r^2) from the measured
    undamped frequencies.
    """
    elements = tuple(int(e) for e in immersed_elements)
    if not elements or len(set(elements)) != len(elements):
        raise DataError(f"immersed_elements must be distinct element numbers, got {elements}")
    if method not in METHODS:
        raise DataError(f"unknown local added mass method {method!r}; use {METHODS}")
    for el in elements:
        fe.fe_elements_of_measurement_element(beam, el)
    pair = pairing if pairing is not None else modal_added_mass(genuine, modified)
    use = np.flatnonzero(pair.partner >= 0)
    if 2 * len(elements) > use.size:
        raise DataError(
            f"{len(elements)} immersed element(s) need at least {2 * len(elements)} modes "
            f"measured in both configurations, got {use.size}: the number of modified "
            "elements must not exceed half the number of measured modes"
        )
    if reduced is None:
        _, reduced = fe.reduce_beam(beam)
    if use.max() >= reduced.shapes.shape[1]:
        raise DataError(
            f"genuine mode {use.max() + 1} exceeds the {reduced.shapes.shape[1]} modes of the "
            "reduced model"
        )
    dl = (2 * np.pi) ** 2 * (pair.fn_modified_hz[use] ** 2 - pair.fn_genuine_hz[use] ** 2)
    kj, mj = _element_matrices(beam, reduced, elements, method)
    w2 = reduced.omega2[use]
    dk, dm, res, a, b = local_added_mass_factors(reduced.shapes[:, use], w2, kj, mj, dl)
    return LocalAddedMassResult(
        configuration=modified.configuration or pair.configuration,
        method=method,
        elements=elements,
        delta_k=dk,
        delta_m=dm,
        mode=use + 1,
        delta_lambda=dl,
        omega2=w2,
        A=a,
        B=b,
        residual=res,
    )


# ---------------------------------------------------------------------------
# Table 1 input
# ---------------------------------------------------------------------------
def _require_genuine(measured: Mapping[str, ModalParameters], genuine: str) -> None:
    if genuine not in measured:
        raise DataError(
            f"configuration {genuine!r} (the genuine beam) is missing; found "
            f"{sorted(measured) or 'none'}"
        )


def modal_parameters_from_table(
    table: pd.DataFrame, *, genuine: str | None = "genuine", source: str = ""
) -> dict[str, ModalParameters]:
    """Measured modal parameters from a Table 1 form DataFrame.

    Columns ``configuration, mode, fd_hz, zeta_pct`` (damped natural frequency in
    Hz, damping ratio in percent); optional ``fn_std_hz`` and ``zeta_std_pct``.
    Rows are sorted by mode; a row with an empty ``fd_hz`` is a mode not
    identified in that configuration and is left out. fn = fd / sqrt(1 - zeta^2)
    (eq. 4). ``genuine`` (if not None) must be one of the configurations.
    ``source`` (e.g. a file name) prefixes error messages.
    """
    where = f"{source}: " if source else ""
    if not isinstance(table, pd.DataFrame):
        raise DataError(f"{where}expected a pandas DataFrame, got {type(table).__name__}")
    required = ("configuration", "mode", "fd_hz", "zeta_pct")
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise DataError(
            f"{where}Table 1 is missing column(s) {missing}; expected at least {list(required)}, "
            f"got {list(table.columns)}"
        )
    if table.empty:
        raise DataError(f"{where}Table 1 has no rows")
    df = table.copy()
    df["configuration"] = df["configuration"].astype(str).str.strip()
    numeric = ["mode", "fd_hz", "zeta_pct"] + [
        c for c in ("fn_std_hz", "zeta_std_pct") if c in df.columns
    ]
    for col in numeric:
        conv = pd.to_numeric(df[col], errors="coerce")
        bad = conv.isna() & df[col].notna() & (df[col].astype(str).str.strip() != "")
        if bad.any():
            raise DataError(
                f"{where}column {col!r} has non-numeric value(s) "
                f"{df.loc[bad, col].astype(str).tolist()[:3]}"
            )
        df[col] = conv
    if df["mode"].isna().any() or (df["mode"] % 1 != 0).any() or (df["mode"] < 1).any():
        raise DataError(f"{where}column 'mode' must hold positive integers")
    dup = df.duplicated(["configuration", "mode"])
    if dup.any():
        r = df.loc[dup].iloc[0]
        raise DataError(f"{where}mode {int(r['mode'])} of {r['configuration']!r} appears twice")
    df = df[df["fd_hz"].notna()]
    if (df["fd_hz"] <= 0).any():
        raise DataError(f"{where}fd_hz must be positive")
    if df["zeta_pct"].isna().any() or ((df["zeta_pct"] < 0) | (df["zeta_pct"] >= 100)).any():
        raise DataError(f"{where}zeta_pct must be given in percent, 0 <= zeta_pct < 100")
    out: dict[str, ModalParameters] = {}
    for name, grp in df.sort_values(["configuration", "mode"]).groupby("configuration",
                                                                      sort=False):
        zeta = grp["zeta_pct"].to_numpy(float) / 100.0
        kwargs: dict[str, object] = {"configuration": str(name)}
        if "fn_std_hz" in grp:
            kwargs["fn_std_hz"] = grp["fn_std_hz"].to_numpy(float)
        if "zeta_std_pct" in grp:
            kwargs["zeta_std"] = grp["zeta_std_pct"].to_numpy(float) / 100.0
        out[str(name)] = ModalParameters.from_damped(grp["fd_hz"].to_numpy(float), zeta, **kwargs)
    if genuine is not None:
        try:
            _require_genuine(out, genuine)
        except DataError as exc:
            raise DataError(f"{where}{exc}") from None
    return out


# ---------------------------------------------------------------------------
# the whole FE stage
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class FEStageResult:
    """Everything the FE stage produces (paper Tables 2-6).

    Attributes
    ----------
    beam_initial, beam_updated : the Table 3 model and the updated one.
    genuine : name of the genuine configuration in ``measured``.
    measured : measured modal parameters per configuration.
    fn_initial_hz : Table 3, the initial FE frequencies (as many as genuine modes).
    update : Table 4 (:class:`ema_pipeline.fe.UpdateResult`, all runs,
        identifiable combination and its value, parameter spread).
    fn_updated_hz : Table 5.
    reduced : SEREP model of the updated beam (10 masters, 10 modes in the paper).
    modal_added_mass : Table 2, per modified configuration.
    local_added_mass : Table 6, one entry per configuration and method.
    """

    beam_initial: Beam
    beam_updated: Beam
    genuine: str
    measured: dict[str, ModalParameters]
    fn_initial_hz: np.ndarray
    update: fe.UpdateResult
    fn_updated_hz: np.ndarray
    reduced: fe.SerepModel
    modal_added_mass: dict[str, AddedMassResult]
    local_added_mass: tuple[LocalAddedMassResult, ...]
    messages: tuple[str, ...] = ()


def run_fe_stage(
    beam: Beam,
    measured: Mapping[str, ModalParameters],
    *,
    immersed_elements: Sequence[int] = (10,),
    genuine: str = "genuine",
    methods: Sequence[str] = METHODS,
    n_repeats: int = 5,
    seed: int = 0,
    progress: bool = True,
) -> FEStageResult:
    """Modal added mass, FE model, model update, SEREP and local added mass.

    1. Table 2: eq. (10) for every modified configuration.
    2. Table 3: FE frequencies of ``beam`` (as many modes as genuine measured).
    3. Table 4: :func:`ema_pipeline.fe.update_beam` on the genuine undamped
       frequencies, eq. (26), differential evolution repeated ``n_repeats`` times.
    4. Table 5: FE frequencies of the updated beam.
    5. Table 6: :func:`local_added_mass` per modified configuration and method,
       on the SEREP-reduced updated model.

    ``measured`` maps configuration names to modal parameters (see
    :func:`modal_parameters_from_table`); ``measured[genuine]`` must have every
    mode (it defines the FE mode numbers 1..p).
    """
    _require_genuine(measured, genuine)
    for m in methods:
        if m not in METHODS:
            raise DataError(f"unknown local added mass method {m!r}; use {METHODS}")
    gen = replace_configuration(measured[genuine], genuine)
    p = gen.n_modes
    if p < 1:
        raise DataError(f"configuration {genuine!r} has no modes")
    n_mod = len(measured) - 1
    if n_mod and 2 * len(tuple(immersed_elements)) > p:
        raise DataError(
            f"{len(tuple(immersed_elements))} immersed element(s) need at least "
            f"{2 * len(tuple(immersed_elements))} measured modes, got {p}: the number of "
            "modified elements must not exceed half the number of measured modes"
        )
    modal = modal_added_mass_all(measured, genuine)
    fn_init = fe.beam_frequencies(beam, p)
    upd = fe.update_beam(beam, gen.fn_hz, n_repeats=n_repeats, seed=seed, progress=progress)
    n_red = max(p, beam.n_measurement_elements)
    modes_upd, reduced = fe.reduce_beam(upd.beam, n_red)
    local: list[LocalAddedMassResult] = []
    for name, pair in modal.items():
        mod = replace_configuration(measured[name], name)
        for m in methods:
            local.append(
                local_added_mass(upd.beam, gen, mod, immersed_elements=immersed_elements,
                                 method=m, reduced=reduced, pairing=pair)  # type: ignore[arg-type]
            )
    msgs = tuple(msg for res in modal.values() for msg in res.messages)
    return FEStageResult(
        beam_initial=beam,
        beam_updated=upd.beam,
        genuine=genuine,
        measured=dict(measured),
        fn_initial_hz=fn_init,
        update=upd,
        fn_updated_hz=modes_upd.fn_hz[:p],
        reduced=reduced,
        modal_added_mass=modal,
        local_added_mass=tuple(local),
        messages=msgs,
    )


_TABLE4_NAMES = {
    "thickness_m": "thickness",
    "width_m": "width",
    "length_m": "length",
    "youngs_modulus_pa": "youngs_modulus",
    "density_kg_m3": "density",
}


def _table4(upd: fe.UpdateResult) -> pd.DataFrame:
    rows = []
    for i, name in enumerate(upd.parameter_names):
        rows.append(
            {
                "parameter": _TABLE4_NAMES[name],
                "unit": upd.units[i],
                "initial": upd.initial[i],
                "updated": upd.updated[i],
                "lower": upd.lower[i],
                "upper": upd.upper[i],
                "run_min": upd.run_min[i],
                "run_max": upd.run_max[i],
                "run_std": upd.run_std[i],
                "paper_label": fe.PAPER_PARAMETER_LABELS[name],
                "identifiable": False,
            }
        )
    comb = fe.identifiable_combination
    rows.append(
        {
            "parameter": fe.IDENTIFIABLE_NAME,
            "unit": "1/s",
            "initial": upd.identifiable_initial,
            "updated": upd.identifiable_updated,
            "lower": float(comb(np.array([upd.lower[0], 0, upd.upper[2], upd.lower[3],
                                          upd.upper[4]]))),
            "upper": float(comb(np.array([upd.upper[0], 0, upd.lower[2], upd.upper[3],
                                          upd.lower[4]]))),
            "run_min": float(np.min(upd.identifiable_runs)),
            "run_max": float(np.max(upd.identifiable_runs)),
            "run_std": float(np.std(upd.identifiable_runs, ddof=1))
            if upd.identifiable_runs.size > 1 else np.nan,
            "paper_label": "",
            "identifiable": True,
        }
    )
    return pd.DataFrame(rows)


def fe_stage_tables(result: FEStageResult) -> dict[str, pd.DataFrame]:
    """Tables 2-6 as DataFrames in the DESIGN.md CSV forms (ratios as ratios).

    Keys are the CSV file stems (``table2_modal_added_mass`` ...); the required
    columns come first (:data:`TABLE_COLUMNS`), extra columns after them:
    Table 2 std, frequencies, ``paired``; Table 4 the spread over the runs
    (``run_min, run_max, run_std``), the paper's row label and a last row with
    the identifiable combination h*sqrt(E/rho)/L^2 (``identifiable`` True);
    Table 5 the measured frequency and relative deviation; Table 6 the element
    number and the number of modes used.
    """
    upd = result.update
    p = result.fn_initial_hz.size
    modes = np.arange(1, p + 1)
    fx = result.measured[result.genuine].fn_hz
    t6 = pd.DataFrame(
        [
            {
                "configuration": r.configuration,
                "method": r.method,
                "delta_k": r.delta_k[i],
                "delta_m": r.delta_m[i],
                "element": el,
                "n_modes": int(r.mode.size),
            }
            for r in result.local_added_mass
            for i, el in enumerate(r.elements)
        ],
        columns=[*TABLE_COLUMNS["table6_local_added_mass"], "element", "n_modes"],
    )
    return {
        "table2_modal_added_mass": modal_added_mass_table(result.modal_added_mass),
        "table3_fe_initial": pd.DataFrame({"mode": modes, "fn_hz": result.fn_initial_hz}),
        "table4_updated_parameters": _table4(upd),
        "table5_fe_updated": pd.DataFrame(
            {
                "mode": modes,
                "fn_hz": result.fn_updated_hz,
                "fn_measured_hz": fx,
                "rel_deviation": (result.fn_updated_hz - fx) / fx,
            }
        ),
        "table6_local_added_mass": t6,
    }
