"""Simulated impact tests: the paper's configurations by name, or an FE beam with added mass.

:mod:`ema_pipeline.acquisition` simulates whatever modal parameters it is
given; this module supplies them:

* :func:`paper_modes` / :func:`simulate_paper_test` look up the paper's Table 1
  (:mod:`ema_pipeline.paper`) for a named configuration (``genuine``,
  ``larger_tank``, ``smaller_tank``); the shapes are the analytic cantilever's.
* :func:`added_mass_modes` / :func:`simulate_added_mass_test` take the
  frequencies *and* the shapes at the response and hammer nodes from the FE beam
  whose measurement elements carry extra mass
  (:func:`ema_pipeline.added_mass.modified_beam.beam_modes_with_added_mass`; ``{}`` is
  the genuine beam), with given damping (default: Table 1's genuine damping):
  a simulated immersed beam with a known answer, for ``simulate --added-mass``
  and for configurations declared with ``added_mass`` in an experiment file
  (:func:`simulate_configuration`).

:func:`write_example_study` writes the example study (``ema-pipeline init DIR
--example``): the repository's ``raw_frf`` folder, its three FRF files simulated
again.

Used by ``ema-pipeline simulate``, ``ema-pipeline run``, ``ema-pipeline init``,
the tests and the benchmarks.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ema_pipeline import acquisition, io, paper
from ema_pipeline.added_mass.modified_beam import beam_modes_with_added_mass
from ema_pipeline.data import ConfigError, DataError, FRFSet, ModalParameters
from ema_pipeline.experiment import ConfigurationSpec, Experiment
from ema_pipeline.io.template import EXPERIMENT_FILE, example_experiment
from ema_pipeline.paths import DEFAULT_RAW_FOLDER

__all__ = [
    "added_mass_modes",
    "experiment_setup",
    "paper_modes",
    "simulate_added_mass_test",
    "simulate_configuration",
    "simulate_paper_test",
    "write_example_study",
]

#: How the example study's FRF files are simulated: configuration -> (seed, binary
#: UFF); 40 dB SNR, the default test setup, the file format from the name.
EXAMPLE_SIMULATION = {"genuine": (1, False), "larger_tank": (2, False),
                      "smaller_tank": (3, True)}


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


def experiment_setup(experiment: Experiment | None = None) -> acquisition.TestSetup:
    """The simulated test setup of an experiment: its FE beam and sensor nodes.

    Acquisition settings (sampling, averages, windows) are
    :class:`~ema_pipeline.acquisition.TestSetup`'s; ``None`` gives the default setup.

    Examples
    --------
    >>> experiment_setup().response_nodes, experiment_setup().hammer_node
    ((3, 6), 8)
    """
    if experiment is None:
        return acquisition.TestSetup()
    return acquisition.TestSetup(
        beam=experiment.beam,
        response_nodes=tuple(experiment.response_nodes),
        hammer_node=experiment.hammer_node,
        direction=experiment.direction,
    )


def added_mass_modes(
    added: Mapping[int, float],
    setup: acquisition.TestSetup | None = None,
    *,
    zeta: Sequence[float] | np.ndarray | None = None,
    configuration: str = "",
) -> tuple[ModalParameters, tuple[np.ndarray, np.ndarray]]:
    """Modes of ``setup.beam`` with extra mass on measurement elements, for simulation.

    Parameters
    ----------
    added : {measurement element (1-based, tip = n): delta_m}, extra mass as a
        fraction of the element's own mass (``{}``: the genuine beam).
    setup : beam, sensor nodes, ``n_modes_total`` and ``high_mode_zeta``.
    zeta : damping ratios (not percent) of the lowest modes; the modes above
        them get ``setup.high_mode_zeta``. Default: the genuine configuration's
        of the paper's Table 1 (:data:`ema_pipeline.paper.TABLE1_ZETA`).
    configuration : name given to the modes.

    Returns
    -------
    modes : ModalParameters of the ``setup.n_modes_total`` lowest FE modes.
    shapes : (phi_out (n_responses, n), phi_in (1, n)) mass-normalised FE shapes
        at the response and hammer nodes (the ``shapes`` argument of
        :func:`ema_pipeline.acquisition.simulate_time_records`).

    Examples
    --------
    >>> modes, (phi_out, phi_in) = added_mass_modes({10: 0.3}, zeta=[0.005])
    >>> modes.n_modes, phi_out.shape, phi_in.shape, float(modes.zeta[1])
    (8, (2, 8), (1, 8), 0.004)
    >>> bool(modes.fn_hz[0] < 19.84)
    True
    """
    setup = acquisition.TestSetup() if setup is None else setup
    n = setup.n_modes_total
    z_low = np.asarray(paper.TABLE1_ZETA["genuine"] if zeta is None else zeta, dtype=float).ravel()
    if z_low.size > n or not (np.all(np.isfinite(z_low)) and np.all((z_low >= 0) & (z_low < 1))):
        raise DataError(
            f"damping ratios must be {n} or fewer values in [0, 1) (ratios, not percent), "
            f"got {z_low.tolist()}"
        )
    fe_modes = beam_modes_with_added_mass(
        setup.beam, added, n, nodes=(*setup.response_nodes, setup.hammer_node)
    )
    zeta_all = np.concatenate([z_low, np.full(n - z_low.size, setup.high_mode_zeta)])
    modes = ModalParameters(fn_hz=fe_modes.fn_hz, zeta=zeta_all, configuration=configuration)
    n_out = len(setup.response_nodes)
    return modes, (fe_modes.shapes[:n_out], fe_modes.shapes[n_out:])


def simulate_added_mass_test(
    added: Mapping[int, float],
    setup: acquisition.TestSetup | None = None,
    *,
    zeta: Sequence[float] | np.ndarray | None = None,
    snr_db: float | None = 40.0,
    seed: int | None = 0,
    configuration: str = "",
) -> FRFSet:
    """A simulated impact test of the FE beam with extra mass on measurement elements.

    :func:`added_mass_modes` (frequencies and shapes from the FE model) then
    :func:`ema_pipeline.acquisition.simulate_impact_test`. The answer is known:
    ``added`` is what the ``exact`` local added mass should return.

    Examples
    --------
    >>> frf = simulate_added_mass_test({10: 0.3}, snr_db=None, configuration="truth")
    >>> frf.H.shape, frf.configuration
    ((2, 1, 8193), 'truth')
    """
    setup = acquisition.TestSetup() if setup is None else setup
    modes, shapes = added_mass_modes(added, setup, zeta=zeta, configuration=configuration)
    frf = acquisition.simulate_impact_test(modes, setup, snr_db=snr_db, seed=seed, shapes=shapes)
    return frf


def simulate_configuration(experiment: Experiment, spec: ConfigurationSpec) -> FRFSet:
    """The FRFs of a configuration the experiment file declares as simulated.

    A ``[[configurations]]`` entry with ``added_mass = {ELEMENT = FRACTION, ...}``
    (``{}`` for the genuine beam) and no ``file``: the experiment's FE beam and
    sensors (:func:`experiment_setup`), damping ``zeta_pct`` of the entry
    (default Table 1's genuine damping), ``snr_db`` (default 40) and ``seed``
    (default: the entry's 1-based position in the file, so every configuration
    has its own fixed noise).

    Raises
    ------
    DataError : the configuration has no ``added_mass`` (it is read from a file).
    """
    if spec.added_mass is None:
        raise DataError(f"configuration {spec.name!r} is not simulated (it has no added_mass)")
    frf = simulate_added_mass_test(
        dict(spec.added_mass),
        experiment_setup(experiment),
        zeta=None if spec.zeta_pct is None else np.asarray(spec.zeta_pct) / 100.0,
        snr_db=spec.snr_db,
        seed=spec.seed,
        configuration=spec.name,
    )
    return frf


def write_example_study(folder: str | os.PathLike[str], *, force: bool = False) -> list[Path]:
    """Write the example study into ``folder``: ``folder/raw_frf`` with the example's
    experiment file (:func:`ema_pipeline.io.template.example_experiment`) and its
    three FRF files, simulated impact tests of the paper's configurations
    (:func:`simulate_paper_test` with the seeds of :data:`EXAMPLE_SIMULATION`), so
    that ``ema-pipeline run`` in ``folder`` runs the whole study. The files equal
    those of the repository's ``raw_frf`` (the arrays recomputed: within a
    rounding of the last bits).

    An existing file among them is kept (:class:`ConfigError` naming it) unless
    ``force``; the four files replace their targets together or not at all.
    Returns the paths written, the experiment file first.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     [p.name for p in write_example_study(tmp)]
    ['experiment.toml', 'genuine.uff', 'larger_tank.h5', 'smaller_tank.uff']
    """
    raw = Path(folder) / DEFAULT_RAW_FOLDER
    if raw.exists() and not raw.is_dir():
        raise ConfigError(f"{raw}: is a file; the example study needs a folder there")
    text, files = example_experiment()
    targets = [raw / EXPERIMENT_FILE, *(raw / name for name in files.values())]
    taken = [p for p in targets if os.path.lexists(p)]
    if taken and not force:
        raise ConfigError(f"{taken[0]} exists; give --force to overwrite the example study")
    frfs = [simulate_paper_test(name, seed=EXAMPLE_SIMULATION[name][0]) for name in files]
    with io.replace_together():
        io.write_text(text, targets[0])
        for name, frf, path in zip(files, frfs, targets[1:], strict=True):
            fmt = "uff-binary" if EXAMPLE_SIMULATION[name][1] else io.frf_format_for_writing(path)
            io.write_frf(frf, path, fmt)
    return targets
