"""A virtual structure struck with a virtual hammer: the ``simulate`` device of a
live test, whose truth is known (for a demo and for tests).

The structure is a modal model (:class:`ModalModel`): natural frequencies,
damping ratios and the unit-modal-mass shapes at the hammer points and the
sensors. The built-in ``plate`` (:func:`builtin_model`) is a simply supported
rectangular Kirchhoff plate, 0.5 x 0.35 m, hit at 12 points (a 4 x 3 grid,
nodes 1-12, in -Z), one accelerometer at node 100 (+Z); mode (m, n) has the
shape sin(m pi x / Lx) sin(n pi y / Ly) and the frequency 3.7 x ((m/Lx)^2 +
(n/Ly)^2) Hz, damping 1 %.

:meth:`SimulateDevice.strike` hits the current point: a 2 ms half-sine of
``peak_n`` times U(1 - scatter, 1 + scatter), with a bounce 40 ms later
(``double=True``, or the strikes numbered in ``double_hits``), and the
acceleration at the sensors exact in the frequency domain (zero-padded to
twice its length); white noise of ``noise`` times the hammer's peak on the
force and of the responses' typical peak on them. The force channel clips at
``clip_n`` (its input range: an overload). The stream runs at ``speed``
times real time while a point is current.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ema_pipeline.data import DOF, Channel, ConfigError, Geometry, ModalParameters
from ema_pipeline.live.device import BLOCK_S, Block, PlanPoint, wait_until_due

__all__ = ["ModalModel", "SimulateDevice", "builtin_model", "model_from_modes", "simulate_model"]

#: Length (s) of the response computed for one strike.
RESPONSE_S = 4.0


@dataclass(frozen=True)
class ModalModel:
    """A modal model to strike: ``fn_hz``, ``zeta``, the shapes (unit modal mass)
    at the hammer points ``point_shapes`` (n_points, n_modes) and at the sensors
    ``sensor_shapes`` (n_sensors, n_modes), their DOFs, the ``geometry``, the
    identification band ``band_hz`` and the ``sample_rate_hz``."""

    name: str
    fn_hz: np.ndarray
    zeta: np.ndarray
    point_shapes: np.ndarray
    sensor_shapes: np.ndarray
    point_dofs: tuple[DOF, ...]
    sensor_dofs: tuple[DOF, ...]
    geometry: Geometry
    band_hz: tuple[float, float]
    sample_rate_hz: float = 2048.0

    def accelerance(self, point: int, freq_hz: np.ndarray) -> np.ndarray:
        """(n_sensors, n_freq) accelerance of a hit at point ``point`` (0-based)."""
        w = 2 * np.pi * np.asarray(freq_hz)[None, None, :]
        wr = 2 * np.pi * self.fn_hz[None, :, None]
        res = (self.sensor_shapes * self.point_shapes[point][None, :])[:, :, None]
        z = self.zeta[None, :, None]
        return (-(w ** 2) * res / (wr ** 2 - w ** 2 + 2j * z * wr * w)).sum(axis=1)


def builtin_model(name: str) -> ModalModel:
    """The built-in virtual structure ``name`` (``plate``; module docstring).

    Examples
    --------
    >>> m = builtin_model("plate")
    >>> m.fn_hz[:3].round(1).tolist(), m.point_shapes.shape
    ([45.0, 89.4, 135.6], (12, 12))
    """
    if name != "plate":
        raise ConfigError(f"--simulate: unknown model {name!r}; the built-in one is 'plate'")
    lx, ly = 0.5, 0.35
    modes = [(m, n) for m in range(1, 5) for n in range(1, 4)]
    c = 45.0 / ((1 / lx) ** 2 + (1 / ly) ** 2)
    fn = np.array([c * ((m / lx) ** 2 + (n / ly) ** 2) for m, n in modes])
    order = np.argsort(fn)
    fn = fn[order]
    modes = [modes[k] for k in order]
    points = [(fx * lx, fy * ly) for fy in (0.2, 0.5, 0.8) for fx in (0.15, 0.38, 0.62, 0.85)]
    sensor = (0.23 * lx, 0.14 * ly)

    def shapes(xy: list[tuple[float, float]]) -> np.ndarray:
        return np.array([[np.sin(m * np.pi * x / lx) * np.sin(n * np.pi * y / ly)
                          for m, n in modes] for x, y in xy])

    xyz = np.array([[x, y, 0.0] for x, y in points] + [[*sensor, 0.0]])
    grid = np.arange(1, 13).reshape(3, 4)
    lines = tuple(tuple(int(v) for v in row) for row in grid) + tuple(
        tuple(int(v) for v in col) for col in grid.T)
    geometry = Geometry(node_ids=np.array([*range(1, 13), 100]), xyz_m=xyz, lines=lines)
    return ModalModel("plate", fn, np.full(fn.size, 0.01), shapes(points), shapes([sensor]),
                      tuple(DOF(k, -3) for k in range(1, 13)), (DOF(100, 3),), geometry,
                      (25.0, 210.0))


def model_from_modes(modes: ModalParameters, geometry: Geometry | None, name: str,
                     band_hz: tuple[float, float] | None = None) -> ModalModel:
    """A virtual structure from identified modes (e.g. ``identify --uff``'s
    datasets 55, :func:`ema_pipeline.io.read_modes_uff`): the hammer roves over
    the shapes' DOFs and one accelerometer sits at the DOF where the smallest of
    the modes' normalised amplitudes is largest (on no nodal line); each shape
    made real (turned to its largest component, the real part kept) and taken as
    unit modal mass. The sample rate: the power of two of Hz above 5 times the
    highest mode; the band: from 0.7 times the lowest to 1.15 times the highest.

    Examples
    --------
    >>> m = ModalParameters(np.array([10.0, 25.0]), np.array([0.01, 0.02]),
    ...                     shapes=np.array([[1.0, 1.0], [0.6, -0.5], [0.2, 0.9]]),
    ...                     dofs=(DOF(1, 3), DOF(2, 3), DOF(3, 3)))
    >>> model = model_from_modes(m, None, "beam")
    >>> model.sensor_dofs, model.sample_rate_hz, model.band_hz
    ((DOF(node=1, direction=3),), 128.0, (7.0, 28.75))
    """
    if modes.shapes is None or not modes.dofs:
        raise ConfigError(f"{name}: the modes have no shapes to strike")
    phi = np.asarray(modes.shapes, dtype=complex)
    top = phi[np.argmax(np.abs(phi), axis=0), np.arange(phi.shape[1])]
    real = (phi * np.exp(-1j * np.angle(top))[None, :]).real
    real = real / np.abs(real).max(axis=0, keepdims=True)
    sensor = int(np.argmax(np.abs(real).min(axis=1)))
    fn = np.asarray(modes.fn_hz, dtype=float)
    fs = float(2 ** math.ceil(math.log2(5 * fn.max())))
    if band_hz is None:
        band_hz = (0.7 * float(fn.min()), 1.15 * float(fn.max()))
    points = tuple(d if d.direction < 0 else DOF(d.node, -d.direction) for d in modes.dofs)
    if geometry is None:  # the DOFs on a line, for the plan and the shapes
        nodes = list(dict.fromkeys(d.node for d in modes.dofs))
        geometry = Geometry(node_ids=np.array(nodes), xyz_m=np.array(
            [[0.1 * k, 0.0, 0.0] for k in range(len(nodes))]), lines=(tuple(nodes),))
    return ModalModel(name, fn, np.asarray(modes.zeta, dtype=float), real,
                      real[sensor:sensor + 1], points, (modes.dofs[sensor],), geometry,
                      band_hz, fs)


def simulate_model(spec: str, geometry: Geometry | None = None) -> ModalModel:
    """The virtual structure of ``--simulate SPEC``: ``plate`` (:func:`builtin_model`),
    the result file of ``identify`` (``<stem>_result.h5``: its modes, on
    ``geometry``, else the DOFs on a line) or a Universal File with modes
    (datasets 55; :func:`model_from_modes`, on ``geometry``, else the file's
    own, else the DOFs on a line)."""
    if spec == "plate":
        return builtin_model(spec)
    path = Path(spec)
    if not path.is_file():
        raise ConfigError(f"--simulate {spec}: neither the built-in 'plate' nor a file")
    from ema_pipeline.io import read_geometry_uff, read_identification_result, read_modes_uff

    if path.suffix.lower() in (".h5", ".hdf5"):  # identify's result file
        _, result = read_identification_result(path)
        return model_from_modes(result.modes, geometry, path.name)
    modes = read_modes_uff(path)
    return model_from_modes(modes, geometry or read_geometry_uff(path), path.name)


class SimulateDevice:
    """The virtual hammer on a :class:`ModalModel` (module docstring)."""

    def __init__(self, model: ModalModel, *, speed: float = 1.0, seed: int | None = None,
                 peak_n: float = 150.0, scatter: float = 0.1, noise: float = 1e-4,
                 clip_n: float | None = None, double_hits: Collection[int] = (),
                 block_s: float = BLOCK_S) -> None:
        self.model = model
        self.clip_n = clip_n
        self.sample_rate_hz = model.sample_rate_hz
        self.plan = tuple(
            PlanPoint(k + 1, dof.label(), (Channel("hammer", "force", dof, clip_n),) + tuple(
                Channel(f"acc{j + 1}", "acceleration", s)
                for j, s in enumerate(model.sensor_dofs)))
            for k, dof in enumerate(model.point_dofs))
        self.speed, self.peak_n, self.scatter = float(speed), peak_n, scatter
        self.noise, self.clip_n, self.double_hits = noise, clip_n, set(double_hits)
        # the hammer's scatter and the noise drawn apart: a seed gives the same hits
        # whatever the timing of the strikes against the stream
        self.rng, self.noise_rng = (np.random.default_rng(s)
                                    for s in np.random.SeedSequence(seed).spawn(2))
        self.block_n = max(1, int(round(block_s * self.sample_rate_hz)))
        self.n_resp = int(2 ** math.ceil(math.log2(RESPONSE_S * self.sample_rate_hz)))
        n_ch = 1 + len(model.sensor_dofs)
        self._ahead = np.zeros((n_ch, self.n_resp + 4 * self.block_n))
        self._lock = threading.Lock()
        self._point = 0
        self._pos = self._first = 0
        self._t0 = 0.0
        self.strikes = 0
        freq = np.fft.rfftfreq(2 * self.n_resp, 1 / self.sample_rate_hz)
        typical = np.fft.irfft(model.accelerance(0, freq)[0] * np.fft.rfft(
            self._pulse(peak_n, False), 2 * self.n_resp), 2 * self.n_resp)
        self._resp_noise = noise * float(np.abs(typical).max())

    def _pulse(self, peak: float, double: bool) -> np.ndarray:
        fs = self.sample_rate_hz
        t = np.arange(self.n_resp) / fs
        force = np.zeros(self.n_resp)
        for t0, p in ((0.0, peak),) + (((0.04, 0.5 * peak),) if double else ()):
            on = (t >= t0) & (t <= t0 + 2e-3)
            force[on] += p * np.sin(np.pi * (t[on] - t0) / 2e-3)
        return force

    def start(self, point: int, first_sample: int = 0) -> None:
        with self._lock:
            self._point, self._pos, self._first = point, first_sample, first_sample
            self._ahead[:] = 0.0
            self._t0 = time.monotonic()

    def streaming(self) -> bool:
        return bool(self._point)

    def stop(self) -> None:
        with self._lock:
            self._point = 0

    def strike(self, double: bool | None = None, peak_n: float | None = None) -> None:
        """Hit the current point now (module docstring)."""
        with self._lock:
            if not self._point:
                return
            self.strikes += 1
            double = (self.strikes in self.double_hits) if double is None else double
            peak = (peak_n or self.peak_n) * self.rng.uniform(1 - self.scatter,
                                                             1 + self.scatter)
            force = self._pulse(peak, double)
            freq = np.fft.rfftfreq(2 * self.n_resp, 1 / self.sample_rate_hz)
            H = self.model.accelerance(self._point - 1, freq)
            acc = np.fft.irfft(H * np.fft.rfft(force, 2 * self.n_resp)[None, :],
                               2 * self.n_resp, axis=-1)[:, :self.n_resp]
            at = self.block_n  # in the block after the one being delivered
            self._ahead[0, at:at + self.n_resp] += force
            self._ahead[1:, at:at + self.n_resp] += acc

    def read(self, timeout_s: float) -> Block | None:
        if not self._point:
            time.sleep(min(timeout_s, 0.01))
            return None
        end = self._pos + self.block_n
        due = self._t0 + (end - self._first) / self.sample_rate_hz / self.speed
        if not wait_until_due(due, self.speed, timeout_s):
            return None
        with self._lock:
            n = self.block_n
            out = self._ahead[:, :n].copy()
            self._ahead = np.concatenate([self._ahead[:, n:], np.zeros((out.shape[0], n))],
                                         axis=1)
            start, self._pos = self._pos, end
        out[0] += self.noise * self.peak_n * self.noise_rng.standard_normal(n)
        out[1:] += self._resp_noise * self.noise_rng.standard_normal((out.shape[0] - 1, n))
        if self.clip_n is not None:  # the force channel's input range, as a DAQ clips
            np.clip(out[0], -self.clip_n, self.clip_n, out=out[0])
        return Block(out, start, 0, time.time())
