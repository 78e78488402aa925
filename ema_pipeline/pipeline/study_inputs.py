"""The study's inputs: the experiment file and every configuration's FRFs, read
and checked before anything is computed (:func:`prepare_study`).
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import pandas as pd

from ema_pipeline import io
from ema_pipeline.data import DOF, MIN_FRF_LINES, ConfigError, DataError, FRFSet
from ema_pipeline.experiment import ConfigurationSpec, Experiment
from ema_pipeline.identification import CheckedInput, IdentificationOptions, check_input
from ema_pipeline.io.experiment import experiment_channel_sheet, experiment_recording_paths
from ema_pipeline.pipeline.frf import FRFSettings, configuration_frf
from ema_pipeline.pipeline.roving import sheet_frf


def load_experiment(path: str | os.PathLike[str]) -> Experiment:
    """Read the experiment file; an unreadable one is a configuration error (exit 2)."""
    try:
        return io.read_experiment(path)
    except DataError as exc:
        raise ConfigError(str(exc)) from exc


def _check_sensors(exp: Experiment, frf: FRFSet, path: Path, experiment_file: str) -> None:
    """The FRF file's DOFs must be the experiment's sensors (or, after reciprocity
    of a roving-hammer set, the other way round)."""
    resp = sorted({d.node for d in frf.response_dofs})
    ref = sorted({d.node for d in frf.reference_dofs})
    want_resp, want_ref = sorted(set(exp.response_nodes)), [exp.hammer_node]
    if (resp, ref) in ((want_resp, want_ref), (want_ref, want_resp)):
        return
    raise DataError(
        f"{path}: its FRFs are measured at response nodes {resp}, reference nodes {ref}; "
        f"{experiment_file} [sensors] says response_nodes {want_resp}, hammer_node "
        f"{exp.hammer_node}"
    )


def recorded_frf(exp: Experiment, spec: ConfigurationSpec) -> tuple[FRFSet, pd.DataFrame]:
    """The FRFs and the hit table of a configuration that names raw recordings
    (:func:`ema_pipeline.pipeline.frf.configuration_frf` with its ``frf`` settings).

    Channels without a DOF (TDMS, WAV, CSV) are placed on the experiment's sensors:
    the force at ``hammer_node``, the responses at ``response_nodes`` in channel
    order (their numbers must agree), in ``direction``. The FRFs are as
    measured: :func:`~ema_pipeline.identification.check_input` makes a
    roving-hammer set single-reference.
    """
    if spec.channels or spec.channel_rows:  # a channel sheet: a roving test
        sheet = experiment_channel_sheet(exp, spec)
        settings = FRFSettings(**dict(spec.frf))  # type: ignore[arg-type]
        roving = sheet_frf(sheet, settings, configuration=spec.name)
        return roving.frf, roving.hits_table()
    paths = experiment_recording_paths(exp, spec)
    result = configuration_frf(paths, spec.frf, configuration=spec.name)
    frf = result.frf
    rec = result.recording
    if rec is not None and all(ch.dof is None for ch in rec.channels):
        if frf.n_out != len(exp.response_nodes):
            raise DataError(
                f"{paths[0]}: {frf.n_out} response channel(s) without DOFs, but [sensors] "
                f"response_nodes has {len(exp.response_nodes)} (they are placed in channel "
                "order); give each channel its node and direction in a channel sheet "
                "([recordings] channels = \"channels.csv\"; `ema-pipeline init DIR "
                "--recordings RECORDINGS` writes one)"
            )
        frf = replace(frf, response_dofs=tuple(DOF(n, exp.direction) for n in exp.response_nodes),
                      reference_dofs=(DOF(exp.hammer_node, exp.direction),))
    return frf, result.hits_table()


def configuration_options(exp: Experiment, spec: ConfigurationSpec) -> IdentificationOptions:
    """The identification options of a configuration: the experiment's, with the
    configuration's ``exp_window_tau_s``."""
    return replace(exp.identification, exp_window_tau_s=spec.exp_window_tau_s)


def read_configuration(exp: Experiment, spec: ConfigurationSpec) -> FRFSet:
    """The FRFs of a configuration that names an FRF file: read (fewer than
    :data:`~ema_pipeline.data.MIN_FRF_LINES` lines is a :class:`DataError` naming
    the file), named after the configuration, the experiment's ``[dofs]``
    applied (:func:`map_dofs`)."""
    path = io.experiment_file_path(exp, spec)
    frf = replace(io.read_frf(path, min_lines=MIN_FRF_LINES), configuration=spec.name)
    return map_dofs(exp, frf, path)


def map_dofs(exp: Experiment, frf: FRFSet, path: Path | str = "") -> FRFSet:
    """``frf`` with the experiment's ``[dofs] map`` applied (file DOF -> geometry
    DOF) and its ``[dofs] fixed`` DOFs checked: each must be one of the FRFs'
    DOFs (a :class:`DataError` naming the file otherwise).

    Examples
    --------
    >>> import numpy as np
    >>> from ema_pipeline.data import Beam
    >>> from ema_pipeline.identification import IdentificationOptions
    >>> exp = Experiment(name="x", beam=Beam(), configurations=(),
    ...                  identification=IdentificationOptions(),
    ...                  dof_map=((DOF(101, 3), DOF(1, 3)),), fixed_dofs=(DOF(2, -3),))
    >>> frf = FRFSet(freq_hz=np.arange(3.0), H=np.ones((1, 1, 3), complex),
    ...              response_dofs=(DOF(101, 3),), reference_dofs=(DOF(2, -3),))
    >>> [d.label() for d in map_dofs(exp, frf).response_dofs]
    ['1+Z']
    """
    if exp.dof_map:
        table = dict(exp.dof_map)
        frf = replace(frf, response_dofs=tuple(table.get(d, d) for d in frf.response_dofs),
                      reference_dofs=tuple(table.get(d, d) for d in frf.reference_dofs))
    dofs = set(frf.response_dofs) | set(frf.reference_dofs)
    missing = [d.label() for d in exp.fixed_dofs if d not in dofs]
    if missing:
        where = f"{path}: " if path else ""
        raise DataError(f"{where}[dofs] fixed {', '.join(missing)}: not among the file's DOFs "
                        f"({', '.join(sorted({d.label() for d in dofs}))})")
    return frf


def prepare_study(
    experiment: Experiment, experiment_file: str | os.PathLike[str] = "experiment.toml",
    *, hits: dict[str, pd.DataFrame] | None = None,
) -> dict[str, CheckedInput]:
    """Read and check every configuration's FRF file before anything is computed.

    Each file is read (HDF5 checked in a child process first, see
    :func:`ema_pipeline.io.check_hdf5`), its sensors compared with the
    experiment's, and checked for identification with the configuration's
    options (:func:`~ema_pipeline.identification.check_input`: window,
    single reference, band, orders, expected frequencies, memory). Returns
    the checked inputs by configuration name, which
    :func:`~ema_pipeline.pipeline.study_run.run_study` identifies as they
    are; raises DataError / ConfigError (input errors) naming the file and
    the configuration. A configuration naming raw recordings gets its FRFs
    from them (:func:`recorded_frf`); its hit table goes into ``hits`` when
    given.
    """
    checked: dict[str, CheckedInput] = {}
    for spec in experiment.configurations:
        if spec.added_mass is not None:
            continue
        path = io.experiment_file_path(experiment, spec)
        if spec.recording:
            frf, table = recorded_frf(experiment, spec)
            frf = map_dofs(experiment, frf, path)
            if hits is not None:
                hits[spec.name] = table
        else:
            frf = read_configuration(experiment, spec)
        if experiment.has_beam:  # the beam's [sensors]; any other structure: its own DOFs
            _check_sensors(experiment, frf, path, str(experiment_file))
        checked[spec.name] = check_input(frf, configuration_options(experiment, spec),
                                         source=f"{path} ({spec.name})")
    return checked
