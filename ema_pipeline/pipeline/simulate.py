"""The paper's simulated impact test by configuration name.

:mod:`ema_pipeline.acquisition` simulates whatever modal parameters it is
given; this module looks up the paper's Table 1 (:mod:`ema_pipeline.paper`) for
a named configuration (``genuine``, ``larger_tank``, ``smaller_tank``) and
passes it in. Used by ``ema-pipeline simulate``, the tests and the benchmarks.
"""

from __future__ import annotations

from ema_pipeline import acquisition, paper
from ema_pipeline.data import DataError, FRFSet, ModalParameters

__all__ = ["paper_modes", "simulate_paper_test"]


def paper_modes(
    configuration: str = "genuine", setup: acquisition.TestSetup | None = None
) -> ModalParameters:
    """The modes to simulate for a configuration of the paper's Table 1.

    Table 1's damped frequencies and damping ratios, completed with modes above
    1 kHz up to ``setup.n_modes_total`` (:func:`ema_pipeline.acquisition.configuration_modes`;
    ``setup`` defaults to :class:`~ema_pipeline.acquisition.TestSetup`).

    Raises
    ------
    DataError : ``configuration`` is not one of :data:`ema_pipeline.paper.CONFIGURATIONS`.
    """
    setup = acquisition.TestSetup() if setup is None else setup
    if configuration not in paper.TABLE1_FD_HZ:
        raise DataError(
            f"no default modal parameters for configuration {configuration!r}; "
            f"known: {', '.join(paper.CONFIGURATIONS)} (or give fd_hz and zeta)"
        )
    return acquisition.configuration_modes(
        configuration,
        fd_hz=paper.TABLE1_FD_HZ[configuration],
        zeta=paper.TABLE1_ZETA[configuration],
        n_modes_total=setup.n_modes_total,
        high_mode_zeta=setup.high_mode_zeta,
    )


def simulate_paper_test(
    configuration: str = "genuine",
    setup: acquisition.TestSetup | None = None,
    *,
    snr_db: float | None = 40.0,
    seed: int | None = 0,
) -> FRFSet:
    """A simulated impact test of a configuration of the paper's Table 1.

    :func:`paper_modes` then :func:`ema_pipeline.acquisition.simulate_impact_test`.
    """
    setup = acquisition.TestSetup() if setup is None else setup
    modes = paper_modes(configuration, setup)
    return acquisition.simulate_impact_test(modes, setup, snr_db=snr_db, seed=seed)
