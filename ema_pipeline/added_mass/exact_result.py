"""The results of the exact local added mass (:mod:`.exact`): one configuration's
fit (:class:`ExactAddedMassResult`), one configuration's outcome in a study
(:class:`ExactOutcome`) and the refusal of unidentifiable unknowns.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import DataError

#: Largest condition number of the sensitivity matrix at which unknowns are reported.
MAX_CONDITION = 100.0
#: Name of the method in Table 6 (beside ``block`` and ``projected``).
EXACT_METHOD = "exact"


class UnidentifiableError(DataError):
    """The measured modes cannot determine the unknowns (rank or condition number).

    ``condition_number`` (inf when rank deficient or too few modes) and ``rank``
    of the sensitivity matrix travel with the message so that a table can
    report them beside the refusal.
    """

    def __init__(self, message: str, condition_number: float, rank: int) -> None:
        super().__init__(message)
        self.condition_number = condition_number
        self.rank = rank


# ---------------------------------------------------------------------------
# one configuration
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ExactAddedMassResult:
    """Local added mass by the exact eigenvalue fit (method ``exact``).

    Attributes
    ----------
    configuration : name of the modified configuration (may be empty).
    elements : measurement element numbers (1-based, tip = n).
    delta_m, delta_m_std : (n_el,) added mass as a fraction of each element's
        mass, and its linearised standard deviation from the frequencies' std
        (J^+ Cov_y J^+T; NaN when no std was given).
    delta_k, delta_k_std : (n_el,) stiffness factors and std; NaN when not fitted.
    delta_m_std_misfit, delta_k_std_misfit : a-posteriori std from the fit
        residual, s^2 (J^T W J)^-1, NaN without redundancy (modes = unknowns).
    delta_m_first_order, delta_k_first_order : the first-order (eq. 14-20,
        full FE model, ratio data) answer, for comparison.
    covariance : (n_p, n_p) covariance of [delta_m, delta_k (if fitted)].
    mode : (p,) 1-based mode numbers used.
    ratio_measured : (p,) y_r = (f_wr / f_r)^2.
    ratio_model : (p,) lambda_r(p) / lambda_r(0) at the solution.
    freq_ratio_mismatch : (p,) sqrt(ratio_model / ratio_measured) - 1.
    residual : rms of ``freq_ratio_mismatch`` (relative frequency mismatch).
    condition_number, rank : of the sensitivity matrix at the solution.
    singular_values : of that matrix.
    fn_genuine_model_hz, fn_modified_model_hz : (p,) FE frequencies of the
        given beam and of the fitted modified beam.
    modal_added_mass : (p,) m_ar / m_r = phi_r^T dM phi_r with the genuine FE
        mode shapes (mass-normalised, so m_r = 1): eq. (7)'s modal added mass
        as eq. (10) assumes it (unchanged shapes); sits beside Table 2.
    modal_added_mass_modified_shape : (p,) phi_wr^T dM phi_wr / phi_wr^T M phi_wr
        with the fitted modified model's shapes.
    modal_added_mass_eq10 : (p,) lambda_r(0) / lambda_r(p) - 1, what eq. (10)
        returns from the fitted model's frequencies (equals the measured
        eq. 10 ratio when the fit is exact).
    iterations : Levenberg-Marquardt trial steps (each one eigen-solution);
        ``weighting`` of the residuals; ``fit_stiffness`` as requested.
    """

    configuration: str
    elements: tuple[int, ...]
    delta_m: np.ndarray
    delta_m_std: np.ndarray
    delta_k: np.ndarray
    delta_k_std: np.ndarray
    delta_m_std_misfit: np.ndarray
    delta_k_std_misfit: np.ndarray
    delta_m_first_order: np.ndarray
    delta_k_first_order: np.ndarray
    covariance: np.ndarray
    mode: np.ndarray
    ratio_measured: np.ndarray
    ratio_model: np.ndarray
    freq_ratio_mismatch: np.ndarray
    residual: float
    condition_number: float
    rank: int
    singular_values: np.ndarray
    fn_genuine_model_hz: np.ndarray
    fn_modified_model_hz: np.ndarray
    modal_added_mass: np.ndarray
    modal_added_mass_modified_shape: np.ndarray
    modal_added_mass_eq10: np.ndarray
    iterations: int
    weighting: str
    fit_stiffness: bool

    @property
    def std_source(self) -> str:
        """Where the reported std comes from: ``"frequency_std"`` (the frequencies'
        std propagated, when known for every mode used), else ``"misfit"`` (the
        fit residual, when there are more modes than unknowns), else ``"none"``."""
        if np.all(np.isfinite(self.delta_m_std)):
            return "frequency_std"
        if np.all(np.isfinite(self.delta_m_std_misfit)):
            return "misfit"
        return "none"

    def rows(self) -> list[dict[str, object]]:
        """One Table 6 row per element: ``configuration, method, element, delta_k,
        delta_m`` (DESIGN.md) and ``delta_m_std`` (from :attr:`std_source`:
        the frequencies' std propagated, else the misfit std),
        ``delta_m_std_source, residual, condition_number, rank, n_modes, status``
        (``"ok"``), ``reason`` (empty), ``delta_k_std`` (same source),
        ``delta_m_std_misfit, delta_m_first_order``."""
        source = self.std_source
        m_std = self.delta_m_std_misfit if source == "misfit" else self.delta_m_std
        k_std = self.delta_k_std_misfit if source == "misfit" else self.delta_k_std
        return [
            {
                "configuration": self.configuration,
                "method": EXACT_METHOD,
                "element": el,
                "delta_k": float(self.delta_k[i]),
                "delta_m": float(self.delta_m[i]),
                "delta_m_std": float(m_std[i]),
                "delta_m_std_source": source,
                "residual": self.residual,
                "condition_number": self.condition_number,
                "rank": self.rank,
                "n_modes": int(self.mode.size),
                "status": "ok",
                "reason": "",
                "delta_k_std": float(k_std[i]),
                "delta_m_std_misfit": float(self.delta_m_std_misfit[i]),
                "delta_m_first_order": float(self.delta_m_first_order[i]),
            }
            for i, el in enumerate(self.elements)
        ]


# ---------------------------------------------------------------------------
# every modified configuration of a study
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ExactOutcome:
    """The ``exact`` local added mass of one modified configuration, or why not.

    ``result`` is None when the fit was refused (``status`` ``"refused"``: the
    modes cannot determine the unknowns, ``condition_number``/``rank`` say how
    badly) or failed (``"failed"``: bad data, no convergence); ``reason`` is
    the message. Table 6 gets one row per element either way (:meth:`rows`).
    """

    configuration: str
    elements: tuple[int, ...]
    result: ExactAddedMassResult | None
    status: str = "ok"
    reason: str = ""
    condition_number: float = float("nan")
    rank: int = -1

    def rows(self) -> list[dict[str, object]]:
        """Table 6 rows (:meth:`ExactAddedMassResult.rows`); NaN values and the
        reason when refused or failed."""
        if self.result is not None:
            return self.result.rows()
        nan = float("nan")
        return [
            {
                "configuration": self.configuration,
                "method": EXACT_METHOD,
                "element": el,
                "delta_k": nan,
                "delta_m": nan,
                "delta_m_std": nan,
                "delta_m_std_source": "none",
                "residual": nan,
                "condition_number": self.condition_number,
                "rank": self.rank,
                "n_modes": 0,
                "status": self.status,
                "reason": self.reason,
                "delta_k_std": nan,
                "delta_m_std_misfit": nan,
                "delta_m_first_order": nan,
            }
            for el in self.elements
        ]
