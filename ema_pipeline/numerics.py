"""The Levenberg-Marquardt step and damping schedule that the package's two
nonlinear fits share: the variable-projection pole refinement
(:func:`ema_pipeline.identification.refinement.refine.vp_solve`) and the exact local
added-mass fit (:func:`ema_pipeline.added_mass.exact.exact_added_mass`).

This module imports only numpy, so every stage can use it.

Why written here and not ``scipy.optimize.least_squares``: both fits need
what that function does not give. The pole refinement eliminates the linear
terms (variable projection), shares one projection between all channels and
re-estimates the noise weights between two rounds; the added-mass fit gets
its residuals and its analytic Jacobian from one eigen-solution, must refuse
steps to a negative mass (1 + delta <= 0), and stops on a Gauss-Newton step
that only eigen-solver noise can rank. The outer loops stay with them; the
step and the schedule of the damping factor, which they had written twice
with different limits, live here once, with each caller's limits explicit
(the limits are part of each fit's tuned behaviour: the refinement gives up
after mu > 1e6, where its start pole is kept, the added-mass fit only after
1e10).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MarquardtDamping", "marquardt_step"]


def marquardt_step(
    normal: np.ndarray, rhs: np.ndarray, mu: float, floor: float = 0.0
) -> np.ndarray:
    """The Levenberg-Marquardt step with Marquardt's diagonal scaling:
    the solution of (A + mu (diag(A) + floor)) step = rhs, A = J^T J the normal
    matrix, ``rhs`` = -J^T r for residuals r (``floor`` is added to every
    entry of the scaling matrix; a tiny one keeps a zero column solvable).

    Raises
    ------
    numpy.linalg.LinAlgError
        If the damped matrix is singular.

    Examples
    --------
    >>> J = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    >>> r = np.array([1.0, -2.0, 0.5])
    >>> gauss_newton = np.linalg.lstsq(J, -r, rcond=None)[0]
    >>> bool(np.allclose(marquardt_step(J.T @ J, -(J.T @ r), 0.0), gauss_newton))  # mu = 0
    True
    >>> bool(np.linalg.norm(marquardt_step(J.T @ J, -(J.T @ r), 100.0)) < 0.02)  # damped
    True
    """
    return np.linalg.solve(normal + mu * (np.diag(np.diag(normal)) + floor), rhs)


@dataclass
class MarquardtDamping:
    """The damping factor mu of a Levenberg-Marquardt loop: start ``mu``,
    divided by 10 after an accepted step (not below ``mu_min``), multiplied
    by 10 after a rejected one; past ``mu_max`` no downhill step is left.

    Examples
    --------
    >>> d = MarquardtDamping(mu=1e-3, mu_min=1e-4, mu_max=1e-1)
    >>> d.accepted(); d.accepted(); d.mu
    0.0001
    >>> d.rejected(), d.rejected(), d.rejected(), d.rejected()
    (True, True, True, False)
    """

    mu: float
    mu_min: float
    mu_max: float

    def accepted(self) -> None:
        """A step lowered the cost: trust the Gauss-Newton model more."""
        self.mu = max(self.mu / 10, self.mu_min)

    def rejected(self) -> bool:
        """A step did not lower the cost: damp more. False once ``mu`` passes
        ``mu_max`` (stop: no downhill step left)."""
        self.mu *= 10
        return self.mu <= self.mu_max
