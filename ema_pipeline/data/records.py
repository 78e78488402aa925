"""Time records of hits and raw recordings with their channels."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ema_pipeline.data.errors import DataError
from ema_pipeline.data.frf import DOF, Provenance


@dataclass
class TimeRecords:
    """Raw impact-test time records: one force channel and n_out responses.

    ``force`` (n_averages, n_samples) in N; ``response`` (n_averages, n_out,
    n_samples) in m/s^2; one row per impact. ``trigger_s`` is the impact time
    within each record (the exponential window starts there).
    """

    force: np.ndarray
    response: np.ndarray
    sample_rate_hz: float
    trigger_s: float = 0.0
    response_dofs: tuple[DOF, ...] = ()
    reference_dof: DOF = DOF(0)
    configuration: str = ""
    source: Provenance = field(default_factory=Provenance)

    def __post_init__(self) -> None:
        where = f"{self.source.path}: " if self.source.path else ""
        force = np.asarray(self.force, dtype=float)
        response = np.asarray(self.response, dtype=float)
        if force.ndim == 1:
            force = force[None, :]
        if response.ndim == 2:
            response = response[:, None, :]
        if force.ndim != 2 or response.ndim != 3:
            raise DataError(
                f"{where}time records must be force (n_averages, n_samples) and response "
                f"(n_averages, n_out, n_samples); got {force.shape} and {response.shape}"
            )
        if response.shape[0] != force.shape[0] or response.shape[-1] != force.shape[-1]:
            raise DataError(
                f"{where}force records {force.shape} and response records {response.shape} "
                "differ in number of averages or samples"
            )
        if not (np.all(np.isfinite(force)) and np.all(np.isfinite(response))):
            raise DataError(f"{where}time records contain NaN/inf values")
        if not np.any(force):
            raise DataError(f"{where}force records are all zero: no impact recorded")
        if not (np.isfinite(self.sample_rate_hz) and self.sample_rate_hz > 0):
            raise DataError(f"{where}sample rate must be positive, got {self.sample_rate_hz}")
        self.force, self.response = force, response
        if not self.response_dofs:
            self.response_dofs = tuple(DOF(k + 1) for k in range(response.shape[1]))
        if len(self.response_dofs) != response.shape[1]:
            raise DataError(
                f"{where}{len(self.response_dofs)} labels for {response.shape[1]} responses"
            )

    def __repr__(self) -> str:
        """Short: configuration, averages x responses x samples, sample rate, source."""
        return (
            f"TimeRecords({self.configuration or 'unnamed'}: {self.n_averages} averages x "
            f"{self.response.shape[1]} responses x {self.n_samples} samples at "
            f"{self.sample_rate_hz:g} Hz ({self.n_samples / self.sample_rate_hz:.4g} s), "
            f"reference {self.reference_dof.label()}, source {self.source.path or 'memory'})"
        )

    @property
    def n_averages(self) -> int:
        return self.force.shape[0]

    @property
    def n_samples(self) -> int:
        return self.force.shape[1]


#: Physical quantities a recorded channel may carry, and their SI units.
CHANNEL_SI_UNITS: dict[str, str] = {
    "force": "N",
    "acceleration": "m/s^2",
    "velocity": "m/s",
    "displacement": "m",
}


@dataclass(frozen=True)
class Channel:
    """One recorded channel: its name, physical quantity, measurement DOF and full scale.

    ``quantity`` is a key of :data:`CHANNEL_SI_UNITS`; the samples of a
    :class:`Recording` are always in that quantity's SI unit. ``full_scale`` is the
    input range of the channel in the same SI unit (``None`` when the file does not
    say; overload detection then looks for flat tops only).
    """

    name: str
    quantity: str
    dof: DOF | None = None
    full_scale: float | None = None

    @property
    def unit(self) -> str:
        return CHANNEL_SI_UNITS[self.quantity]


@dataclass
class Recording:
    """A raw time recording of an impact test: force and responses, in SI units.

    ``signals`` (n_channels, n_samples) holds one row per channel, sampled at
    ``sample_rate_hz`` from time 0 (the start of the recording). A continuous
    recording has ``segment_starts == (0,)``; pre-cut records (one hit each) are
    concatenated, and ``segment_starts`` gives the first sample of each, so that
    no record found later spans two of them.
    """

    signals: np.ndarray
    sample_rate_hz: float
    channels: tuple[Channel, ...]
    segment_starts: tuple[int, ...] = (0,)
    source: Provenance = field(default_factory=Provenance)
    #: The file's channels left out as no signal (a TDMS channel of text), each a
    #: sentence naming the file and the channel, for the warnings.
    skipped: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        where = f"{self.source.path}: " if self.source.path else ""
        signals = np.asarray(self.signals, dtype=float)
        if signals.ndim != 2 or signals.shape[0] != len(self.channels):
            raise DataError(f"{where}signals must be (n_channels={len(self.channels)}, "
                            f"n_samples); got {signals.shape}")
        if not np.all(np.isfinite(signals)):
            raise DataError(f"{where}recording contains NaN/inf samples")
        if not (np.isfinite(self.sample_rate_hz) and self.sample_rate_hz > 0):
            raise DataError(f"{where}sample rate must be positive, got {self.sample_rate_hz}")
        for ch in self.channels:
            if ch.quantity not in CHANNEL_SI_UNITS:
                raise DataError(f"{where}channel {ch.name!r}: unknown quantity {ch.quantity!r}; "
                                f"known: {', '.join(CHANNEL_SI_UNITS)}")
        starts = tuple(int(s) for s in self.segment_starts)
        n = signals.shape[1]
        if not starts or starts[0] != 0 or any(np.diff(starts) <= 0) or starts[-1] >= n:
            raise DataError(f"{where}segment starts {starts} must rise from 0 within "
                            f"{n} samples")
        self.signals, self.segment_starts = signals, starts

    @property
    def n_samples(self) -> int:
        return self.signals.shape[1]

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sample_rate_hz

    def channel_index(self, quantity: str) -> list[int]:
        """Indices of the channels carrying ``quantity`` (e.g. ``"force"``)."""
        return [k for k, ch in enumerate(self.channels) if ch.quantity == quantity]
