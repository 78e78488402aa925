"""What the report pages are drawn from: the plain inputs of the study page
(:class:`ReportInput`, with the beam's :class:`BeamSetup` and the test
:class:`~ema_pipeline.data.Geometry`) and of the batch page
(:class:`BatchReportInput`). The pipeline fills them; nothing here computes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ema_pipeline.data import FRFSet, Geometry

__all__ = ["BatchReportInput", "BeamSetup", "ReportInput"]


@dataclass(frozen=True)
class BeamSetup:
    """Where the sensors and the hammer are: a cantilever of ``length_m``
    divided into ``n_elements`` measurement elements (node 1 clamped)."""

    length_m: float
    n_elements: int
    response_nodes: tuple[int, ...]
    hammer_node: int
    immersed_elements: tuple[int, ...] = ()
    direction: int = 3

    @property
    def direction_label(self) -> str:
        axis = "SXYZ"[abs(self.direction)] if abs(self.direction) <= 3 else "?"
        return ("-" if self.direction < 0 else "+") + axis

    def node_x_m(self, node: int) -> float:
        return (node - 1) * self.length_m / self.n_elements


@dataclass
class ReportInput:
    """What the study report shows.

    ``tables`` are the six result tables in DESIGN.md form (any may be missing);
    ``frfs`` and ``identification`` are keyed by configuration name;
    ``fe_node_x``/``fe_shapes`` (n_points, n_modes) the updated FE mode shapes
    along the beam and ``sensor_x`` the accelerometer positions, both as x/L;
    ``compare_with_paper`` adds the paper's values and deviations to the tables.
    ``descriptions`` maps configuration names to what was tested; ``inputs``
    are ``(role, path, sha256)`` of every input file; ``settings`` the
    settings as text; ``version`` the package version; ``generated`` the date;
    ``hits`` the hit tables (``hit,time_s,force_peak_n,accepted,reasons``) of the
    configurations measured as raw recordings.
    """

    title: str
    tables: dict[str, pd.DataFrame]
    frfs: dict[str, FRFSet] = field(default_factory=dict)
    identification: dict[str, Any] = field(default_factory=dict)
    genuine: str = "genuine"
    fe_node_x: np.ndarray | None = None
    fe_shapes: np.ndarray | None = None
    sensor_x: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    compare_with_paper: bool = True
    descriptions: dict[str, str] = field(default_factory=dict)
    geometry: BeamSetup | None = None
    inputs: list[tuple[str, str, str]] = field(default_factory=list)
    settings: dict[str, str] = field(default_factory=dict)
    version: str = ""
    generated: str = ""
    hits: dict[str, pd.DataFrame] = field(default_factory=dict)
    #: The wireframe the modes are animated on, and per configuration the shapes
    #: to animate (:class:`~ema_pipeline.report.shape_views.ModeSet`; default: the
    #: identified shapes at the measured DOFs).
    test_geometry: Geometry | None = None
    shape_sets: dict[str, Any] = field(default_factory=dict)
    #: What the experiment file says of the test (object, date, operator,
    #: equipment, roving and fixed DOFs), shown first in the setup section.
    test_info: dict[str, str] = field(default_factory=dict)


@dataclass
class BatchReportInput:
    """What the batch page shows: ``summary`` and ``failures`` are the rows of
    ``summary.csv`` and ``failures.csv`` (:mod:`ema_pipeline.pipeline.batch`);
    ``shapes`` (optional) one ``(n_dofs, n_modes)`` array per summary row, in the
    order of its ``frequencies_hz`` (None where unknown), to pair modes by MAC;
    ``pages`` (optional) per summary row the link (URL relative to the batch
    page) of the file's own report page, "" where it has none."""

    title: str
    folder: str
    summary: pd.DataFrame
    failures: pd.DataFrame
    shapes: list[np.ndarray | None] | None = None
    pages: list[str] | None = None
    settings: dict[str, str] = field(default_factory=dict)
    seconds: float = float("nan")
    interrupted: bool = False
    version: str = ""
    generated: str = ""
