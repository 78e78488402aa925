"""A one-file identification result (``<stem>_result.h5``) read back as the
objects :func:`~ema_pipeline.identification.identify` returned."""

from __future__ import annotations

import os
from dataclasses import MISSING, fields, replace
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ema_pipeline.data import DataError, FRFSet, ModalParameters, Provenance
from ema_pipeline.identification.result import (
    IdentificationResult,
    ResolvedSettings,
    SelectedPoles,
    StabilizationData,
)
from ema_pipeline.identification.thresholds import SelectionThresholds
from ema_pipeline.io.hdf5 import (
    SCHEMA_RESULTS,
    load_tree,
    read_frf_group,
    results_checked,
)
from ema_pipeline.io.hdf5_access import dofs_from, member, typed_attr
from ema_pipeline.io.hdf5_check import open_checked

__all__ = ["read_identification_result"]


#: The dataclasses an identification result stores, by the ``kind`` attribute
#: :func:`~ema_pipeline.io.hdf5.write_results_h5` gives their groups.
_RESULT_KINDS: dict[str, type] = {
    cls.__name__: cls
    for cls in (IdentificationResult, ModalParameters, StabilizationData, SelectedPoles,
                ResolvedSettings, SelectionThresholds)
}


def _rebuilt(tree: Any, annotation: str, path: Path) -> Any:
    """A stored value as the field annotated ``annotation`` holds it: a group of a
    known ``kind`` as its dataclass, DOF arrays as DOFs, arrays as tuples."""
    if isinstance(tree, dict):
        cls = _RESULT_KINDS.get(str(tree.get("kind", "")))
        if cls is None:  # a plain mapping (extras)
            return {str(k): v for k, v in tree.items()}
        kwargs: dict[str, Any] = {}
        for f in fields(cls):
            if f.name in tree:
                kwargs[f.name] = value = _rebuilt(tree[f.name], str(f.type), path)
                wanted = _RESULT_KINDS.get(str(f.type).split(" ")[0])
                if wanted is not None and not isinstance(value, wanted):
                    raise DataError(f"{path}: {cls.__name__}.{f.name} is not a stored "
                                    f"{wanted.__name__}")
            elif f.default is MISSING and f.default_factory is MISSING:
                kwargs[f.name] = None  # stored as nothing: was None
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:
            raise DataError(f"{path}: the stored {cls.__name__} is malformed ({exc})") from exc
    if "DOF" in annotation:
        return dofs_from(np.asarray(tree, dtype=np.int64))
    if annotation.startswith("tuple"):
        return tuple(np.asarray(tree).tolist())
    return tree


def read_identification_result(
    path: str | os.PathLike[str],
) -> tuple[FRFSet, IdentificationResult]:
    """The FRF set and the identification result of a one-file result
    (``<stem>_result.h5`` of ``identify`` and ``batch``), as identify returned
    them: everything a report page of the file draws (modes, shapes,
    stabilization diagram with the kept modes' start poles, fit) without
    identifying again. The FRF set's source is the input file the result was
    identified from. Sections: ``frf`` (:func:`write_frf_group`) and
    ``identification`` (the :class:`IdentificationResult` tree).

    Raises
    ------
    DataError : the file cannot be read, is incomplete, or lacks either section.

    Examples
    --------
    >>> import tempfile
    >>> from ema_pipeline.acquisition import modal_frf
    >>> from ema_pipeline.identification import identify
    >>> from ema_pipeline.io import write_results_h5
    >>> f = np.linspace(0.0, 100.0, 401)
    >>> truth = ModalParameters(fn_hz=[30.0, 70.0], zeta=[0.01, 0.02])
    >>> H = modal_frf(f, truth, np.array([[1.0, 0.5], [0.3, -1.0]]), np.array([[1.0, -0.8]]))
    >>> frf = FRFSet(freq_hz=f, H=H)
    >>> result = identify(frf)
    >>> p = Path(tempfile.mkdtemp()) / "a_result.h5"
    >>> _ = write_results_h5({"frf": frf, "identification": result}, p)
    >>> frf2, back = read_identification_result(p)
    >>> np.allclose(back.fn_hz, result.fn_hz), back.modes.dofs == result.modes.dofs
    (True, True)
    >>> np.array_equal(back.stabilization.mode_pole, result.stabilization.mode_pole)
    True
    """
    path = Path(path)
    with open_checked(path) as h5:
        results_checked(h5, path, SCHEMA_RESULTS)
        group = member(h5, "frf", path, h5py.Group)
        frf = read_frf_group(group, str(path))
        source = Provenance(path=typed_attr(group, "source_path", "str", path, ""),
                            sha256=typed_attr(group, "source_sha256", "str", path, ""))
        tree = load_tree(member(h5, "identification", path, h5py.Group), path)
    result = _rebuilt(tree, "", path)
    if not isinstance(result, IdentificationResult):
        raise DataError(f"{path}: /identification is not an identification result "
                        f"(kind {tree.get('kind')!r})")
    return replace(frf, source=source), result
