"""Modal parameters (eq. 4) and the beam of the FE model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ema_pipeline import paper
from ema_pipeline.data.errors import DataError
from ema_pipeline.data.frf import DOF
from ema_pipeline.data.geometry import Geometry
from ema_pipeline.data.tables import notebook_table_html


def damped(natural: npt.ArrayLike, zeta: npt.ArrayLike) -> np.ndarray:
    """Damped natural frequency natural * sqrt(1 - zeta^2) (eq. 4), in the unit
    of ``natural`` (Hz or rad/s): the one home of the formula.

    Examples
    --------
    >>> float(damped(10.0, 0.6))
    8.0
    """
    return np.asarray(natural) * np.sqrt(1.0 - np.asarray(zeta) ** 2)


@dataclass(frozen=True)
class ModalParameters:
    """Modal parameters of one configuration, one entry per mode (ascending f).

    ``fn_hz`` undamped natural frequency, ``fd_hz = fn_hz*sqrt(1-zeta^2)`` damped
    natural frequency (eq. 4), ``zeta`` damping ratio (a ratio, not percent).
    ``*_std`` are standard deviations (same units) or NaN when unknown.
    ``shapes`` (n_dof, n_modes) complex mode shapes at ``dofs``, optional.
    """

    fn_hz: np.ndarray
    zeta: np.ndarray
    # None (the default) becomes NaN per mode in __post_init__: always an array after
    fn_std_hz: np.ndarray = None  # type: ignore[assignment]
    zeta_std: np.ndarray = None  # type: ignore[assignment]
    shapes: np.ndarray | None = None
    dofs: tuple[DOF, ...] = ()
    configuration: str = ""

    def __post_init__(self) -> None:
        fn = np.atleast_1d(np.asarray(self.fn_hz, dtype=float))
        zeta = np.atleast_1d(np.asarray(self.zeta, dtype=float))
        if fn.shape != zeta.shape or fn.ndim != 1:
            raise DataError(f"fn_hz {fn.shape} and zeta {zeta.shape} must be equal 1-D arrays")
        object.__setattr__(self, "fn_hz", fn)
        object.__setattr__(self, "zeta", zeta)
        for name in ("fn_std_hz", "zeta_std"):
            val = getattr(self, name)
            val = np.full(fn.shape, np.nan) if val is None else np.asarray(val, dtype=float)
            object.__setattr__(self, name, val)

    def __repr__(self) -> str:
        """Short: configuration, number of modes, frequencies and damping (no arrays)."""
        more = ", ..." if self.n_modes > 8 else ""
        freqs = ", ".join(f"{f:.2f}" for f in self.fn_hz[:8]) + more
        zetas = ", ".join(f"{100 * z:.3f}" for z in self.zeta[:8]) + more
        shapes = "" if self.shapes is None else f", shapes at {self.shapes.shape[0]} DOFs"
        return (
            f"ModalParameters({self.configuration or 'unnamed'}: {self.n_modes} modes, "
            f"fn [{freqs}] Hz, zeta [{zetas}] %{shapes})"
        )

    def _repr_html_(self) -> str:
        """The modal table (notebooks): fn, fd, zeta with standard deviations.

        Plain HTML from :func:`notebook_table_html`; the report's formatted
        tables are :mod:`ema_pipeline.report` (a data object imports no layer
        above it)."""
        return notebook_table_html(
            {
                "mode": np.arange(1, self.n_modes + 1),
                "fn_hz": self.fn_hz,
                "fn_std_hz": self.fn_std_hz,
                "fd_hz": self.fd_hz,
                "zeta_pct": 100 * self.zeta,
                "zeta_std_pct": 100 * np.asarray(self.zeta_std),
            },
            caption=f"{self.configuration or 'modes'}: {self.n_modes} "
            f"mode{'' if self.n_modes == 1 else 's'}",
        )

    @classmethod
    def from_damped(
        cls, fd_hz: npt.ArrayLike, zeta: npt.ArrayLike, **kwargs: object
    ) -> ModalParameters:
        """Build from damped natural frequencies, fn = fd / sqrt(1 - zeta^2) (eq. 4).

        Examples
        --------
        >>> ModalParameters.from_damped([10.0], [0.1]).fn_hz  # 10 / sqrt(1 - 0.1^2)
        array([10.05037815])
        """
        fd = np.asarray(fd_hz, dtype=float)
        z = np.asarray(zeta, dtype=float)
        return cls(fn_hz=fd / damped(1.0, z), zeta=z, **kwargs)  # type: ignore[arg-type]

    @property
    def fd_hz(self) -> np.ndarray:
        """Damped natural frequencies, eq. (4)."""
        return damped(self.fn_hz, self.zeta)

    @property
    def n_modes(self) -> int:
        return int(self.fn_hz.size)


@dataclass(frozen=True)
class Beam:
    """A uniform clamped-free (cantilever) beam, clamped at x = 0.

    ``thickness_m`` (h) is the dimension in the bending direction, ``width_m``
    (b) the other one: I = b h^3 / 12. ``point_masses`` are (x_m, mass_kg)
    pairs, e.g. the 3.2 g accelerometers. ``n_elements`` is the FE mesh;
    ``n_measurement_elements`` divides the beam into the measurement mesh
    (node 1 at the clamp, node n+1 at the tip).
    """

    # the defaults are the paper's beam (Table 4, initial): one home, ema_pipeline.paper
    length_m: float = paper.TABLE4_INITIAL["length_m"]
    width_m: float = paper.TABLE4_INITIAL["width_m"]
    thickness_m: float = paper.TABLE4_INITIAL["thickness_m"]
    youngs_modulus_pa: float = paper.TABLE4_INITIAL["youngs_modulus_pa"]
    density_kg_m3: float = paper.TABLE4_INITIAL["density_kg_m3"]
    n_elements: int = 100
    n_measurement_elements: int = 10
    point_masses: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        for name in ("length_m", "width_m", "thickness_m", "youngs_modulus_pa", "density_kg_m3"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise DataError(f"beam {name} must be a positive number, got {value!r}")
        if self.n_elements < 1 or self.n_measurement_elements < 1:
            raise DataError("beam element counts must be positive")
        if self.n_elements % self.n_measurement_elements:
            raise DataError(
                f"n_elements ({self.n_elements}) must be a multiple of "
                f"n_measurement_elements ({self.n_measurement_elements})"
            )

    @property
    def area_m2(self) -> float:
        return self.width_m * self.thickness_m

    @property
    def second_moment_m4(self) -> float:
        return self.width_m * self.thickness_m**3 / 12.0

    def measurement_geometry(self) -> Geometry:
        """The measurement mesh as a :class:`Geometry`: nodes 1..n+1 along x (m),
        y = z = 0, one trace line from the clamp to the tip.

        Examples
        --------
        >>> g = Beam(length_m=1.0, n_elements=4, n_measurement_elements=2).measurement_geometry()
        >>> g.node_ids.tolist(), g.xyz_m[:, 0].tolist(), g.lines
        ([1, 2, 3], [0.0, 0.5, 1.0], ((1, 2, 3),))
        """
        ids = np.arange(1, self.n_measurement_elements + 2)
        xyz = np.zeros((ids.size, 3))
        xyz[:, 0] = (ids - 1) * self.length_m / self.n_measurement_elements
        return Geometry(node_ids=ids, xyz_m=xyz, lines=(tuple(ids.tolist()),),
                        source="the FE beam's measurement mesh")

    def node_x_m(self, node: int) -> float:
        """Position of measurement node ``node`` (1-based, node 1 at the clamp)."""
        n = self.n_measurement_elements
        if not 1 <= node <= n + 1:
            raise DataError(f"measurement node {node} does not exist (1..{n + 1})")
        return (node - 1) * self.length_m / n
