"""The description of a study: the beam, its test configurations and the
settings of every stage, as ``experiment.toml`` gives them.

It sits above the stages whose settings it holds (an
:class:`~ema_pipeline.identification.options.IdentificationOptions`, a
:class:`~ema_pipeline.data.Beam`) and below :mod:`ema_pipeline.io`, which reads
it from a file (:func:`ema_pipeline.io.read_experiment`), and
:mod:`ema_pipeline.pipeline`, which runs it (see the layer order in README.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ema_pipeline.data import DOF, Beam, DataError, Geometry

if TYPE_CHECKING:  # pragma: no cover
    # type only: reading the experiment file (io) must not import the
    # identification package and its scipy imports
    from ema_pipeline.identification.options import IdentificationOptions

__all__ = ["ConfigurationSpec", "Experiment"]


@dataclass(frozen=True)
class ConfigurationSpec:
    """One test configuration of an experiment and the file holding its FRFs.

    ``exp_window_tau_s`` overrides the exponential-window time constant stored
    in the file (foreign UFF files do not carry it); ``None`` keeps the file's.

    A *simulated* configuration has ``added_mass`` ((element, delta_m) pairs,
    ``()`` for the genuine beam) instead of a file: ``ema-pipeline run``
    simulates its impact test on the experiment's FE beam with damping
    ``zeta_pct`` (None: Table 1's genuine), noise ``snr_db`` (None: noise-free)
    and ``seed`` (:func:`ema_pipeline.pipeline.simulate.simulate_configuration`).

    A *recorded* configuration names raw impact recordings (``recording``: one
    or more files, segments of one test; ``file`` is the first) and the settings
    of ``ema-pipeline frf`` (``frf``: (key, value) pairs, e.g.
    ``(("pretrigger_s", 0.01), ("estimator", "H1"))``): ``run`` finds, checks and
    averages the hits (:mod:`ema_pipeline.pipeline.frf`) and identifies the FRFs.

    A recorded configuration may instead name a *channel sheet* (``channels``: its
    path, relative to the experiment file; or ``channel_rows``: its rows given
    inline, each as (column, value) pairs): every file of the sheet is one point of
    a roving test (:mod:`ema_pipeline.pipeline.roving`); ``recording`` then holds
    the sheet's path (or the experiment file's, for inline rows).
    """

    name: str
    file: str
    description: str = ""
    exp_window_tau_s: float | None = None
    added_mass: tuple[tuple[int, float], ...] | None = None
    zeta_pct: tuple[float, ...] | None = None
    snr_db: float | None = 40.0
    seed: int = 0
    recording: tuple[str, ...] = ()
    frf: tuple[tuple[str, object], ...] = ()
    channels: str = ""
    channel_rows: tuple[tuple[tuple[str, object], ...], ...] = ()


@dataclass(frozen=True)
class Experiment:
    """Everything ``ema-pipeline run`` needs, as described by ``experiment.toml``.

    ``configurations[0]`` is the genuine (reference) state unless ``genuine``
    names another one. ``immersed_elements`` are 1-based elements of the
    measurement mesh (element k joins nodes k and k+1; element 10 is the tip).
    ``n_modes`` is the number of modes the FE stage uses. ``identification``
    holds the options of the ``[identification]`` table
    (:class:`~ema_pipeline.identification.options.IdentificationOptions`, built
    by :func:`ema_pipeline.io.read_experiment`).
    """

    name: str
    beam: Beam
    configurations: tuple[ConfigurationSpec, ...]
    identification: IdentificationOptions
    base_dir: str = "."
    genuine: str = ""
    response_nodes: tuple[int, ...] = (3, 6)
    hammer_node: int = 8
    direction: int = 3
    immersed_elements: tuple[int, ...] = (10,)
    n_modes: int = 4
    update_repeats: int = 5
    seed: int = 0
    #: The test geometry of the ``[geometry]`` table (the report's animated shapes);
    #: None: the report draws the FE beam's measurement mesh.
    geometry: Geometry | None = None
    #: Whether the file describes a beam (a ``[beam]`` table, or no ``[geometry]``:
    #: the paper's cantilever by default): only then do the FE model, its update
    #: and the added-mass stages run; else ``run`` identifies every configuration
    #: and reports geometry, shapes and the cross-configuration MAC.
    has_beam: bool = True
    #: The ``[test]`` table: (key, text) pairs (object, date, operator, equipment, ...).
    test: tuple[tuple[str, str], ...] = ()
    #: ``[dofs] roving``: "hammer" (roving hammer, fixed sensors), "sensor" (roving
    #: sensors, fixed hammer), "none", or "" (not said).
    roving: str = ""
    #: ``[dofs] fixed``: the DOFs that stayed put during the test.
    fixed_dofs: tuple[DOF, ...] = ()
    #: ``[dofs] map``: (file DOF, geometry DOF) pairs, applied to the FRFs when read.
    dof_map: tuple[tuple[DOF, DOF], ...] = ()

    @property
    def genuine_name(self) -> str:
        return self.genuine or self.configurations[0].name

    def configuration(self, name: str) -> ConfigurationSpec:
        for spec in self.configurations:
            if spec.name == name:
                return spec
        known = ", ".join(c.name for c in self.configurations)
        raise DataError(f"unknown configuration {name!r}; the experiment has: {known}")
