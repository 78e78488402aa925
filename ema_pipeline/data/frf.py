"""Measured FRFs: the DOFs, how they were measured, where they came from, the FRF set."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ema_pipeline.data.errors import DataError
from ema_pipeline.data.quantities import QUANTITY_UNITS, Quantity, quantity_factor


@dataclass(frozen=True)
class DOF:
    """A measurement degree of freedom: node number and direction.

    ``direction`` follows UFF: 1..3 = +X,+Y,+Z; -1..-3 = -X,-Y,-Z; 0 = scalar.
    """

    node: int
    direction: int = 3

    def label(self) -> str:
        """Node, sign and axis as written in tables and plots, e.g. ``3+Z``.

        Examples
        --------
        >>> DOF(3).label(), DOF(12, -1).label()
        ('3+Z', '12-X')
        """
        axis = "SXYZ"[abs(self.direction)] if abs(self.direction) <= 3 else "?"
        sign = "-" if self.direction < 0 else "+"
        return f"{self.node}{sign}{axis}"


@dataclass(frozen=True)
class AcquisitionInfo:
    """How the FRFs were measured (or simulated).

    ``exp_window_tau_s`` is the time constant of the exponential window
    exp(-t/tau) applied to the records; it adds ``1/tau`` (1/s) to the decay
    rate sigma_r = zeta_r * omega_r of every mode, which identification undoes.
    ``None`` means no exponential window.
    """

    sample_rate_hz: float | None = None
    n_samples: int | None = None
    n_averages: int | None = None
    #: The most averages of any FRF where they differ between FRFs (a roving
    #: test's points; ``n_averages`` is then the fewest); ``None``: every FRF
    #: has ``n_averages``.
    n_averages_max: int | None = None
    force_window: str = "none"
    response_window: str = "none"
    exp_window_tau_s: float | None = None
    estimator: str = "H1"
    #: Usable band from the force spectrum (Hz): where it falls 10 dB and 20 dB
    #: below its low-frequency level (the Nyquist frequency when it never does);
    #: ``None`` when unknown (FRFs not estimated from hits).
    force_band_hz: tuple[float, float] | None = None
    #: ``""``: the FRF matrix is laid out as measured; ``"reciprocal"``:
    #: :meth:`FRFSet.reciprocal` swapped responses and references (a roving-hammer
    #: set), so the response DOFs are the hammer points and the references the sensors.
    layout: str = ""
    #: Labels (space-separated, e.g. ``"3-Z"``) of the response / reference DOFs the
    #: file stores with a negative direction: the values are read flipped to +X, +Y,
    #: +Z, these keep the direction as tested (for the report's test setup).
    response_negative: str = ""
    reference_negative: str = ""

    @property
    def duration_s(self) -> float | None:
        if self.sample_rate_hz is None or self.n_samples is None:
            return None
        return self.n_samples / self.sample_rate_hz

    @property
    def force_window_s(self) -> float | None:
        """Length (s) of a rectangular force window ``"rect <L> s"``, else ``None``.

        Examples
        --------
        >>> AcquisitionInfo(force_window="rect 0.1 s").force_window_s
        0.1
        """
        parts = self.force_window.split()
        if len(parts) == 3 and parts[0] == "rect" and parts[2] == "s":
            try:
                length = float(parts[1])
            except ValueError:
                return None
            return length if length > 0 else None
        return None

    @property
    def window_decay_rate(self) -> float:
        """Decay rate (1/s) the exponential window adds to every mode."""
        return 0.0 if not self.exp_window_tau_s else 1.0 / self.exp_window_tau_s


@dataclass(frozen=True)
class Provenance:
    """Where a data set came from: file path and its sha256 (hex)."""

    path: str = ""
    sha256: str = ""


@dataclass
class FRFSet:
    """Frequency response functions of one test configuration.

    Attributes
    ----------
    freq_hz : (n_freq,) float
        Frequency axis in Hz, strictly increasing.
    H : (n_out, n_in, n_freq) complex
        FRF matrix, ``H[o, i, k]`` = response o / force at reference i.
    coherence : (n_out, n_in, n_freq) float or None
        Ordinary coherence (0..1) per FRF.
    response_dofs, reference_dofs : tuple of DOF
        Labels of the n_out responses and n_in references.
    quantity : "accelerance" (default), "mobility" or "receptance".
    acquisition : AcquisitionInfo
    configuration : str
        Test configuration name (``genuine``, ``larger_tank``, ...).
    source : Provenance
    """

    freq_hz: np.ndarray
    H: np.ndarray
    response_dofs: tuple[DOF, ...] = ()
    reference_dofs: tuple[DOF, ...] = ()
    coherence: np.ndarray | None = None
    quantity: Quantity = "accelerance"
    acquisition: AcquisitionInfo = field(default_factory=AcquisitionInfo)
    configuration: str = ""
    source: Provenance = field(default_factory=Provenance)

    def __post_init__(self) -> None:
        where = f"{self.source.path}: " if self.source.path else ""
        self.freq_hz = np.asarray(self.freq_hz, dtype=float)
        H = np.asarray(self.H)
        if H.ndim == 1:
            H = H[None, None, :]
        elif H.ndim == 2:
            H = H[:, None, :]
        if H.ndim != 3:
            raise DataError(f"{where}H must have shape (n_out, n_in, n_freq), got {H.shape}")
        self.H = H.astype(complex, copy=False)
        if self.freq_hz.ndim != 1 or self.freq_hz.size != self.H.shape[-1]:
            raise DataError(
                f"{where}frequency axis has {self.freq_hz.size} lines but H has {self.H.shape[-1]}"
            )
        if self.freq_hz.size < 2:
            raise DataError(f"{where}an FRF needs at least 2 frequency lines")
        if not np.all(np.isfinite(self.freq_hz)) or np.any(np.diff(self.freq_hz) <= 0):
            raise DataError(f"{where}frequency axis must be finite and strictly increasing")
        if self.quantity not in QUANTITY_UNITS:
            raise DataError(
                f"{where}unknown FRF quantity {self.quantity!r}; "
                f"expected one of {sorted(QUANTITY_UNITS)}"
            )
        n_out, n_in, _ = self.H.shape
        if not self.response_dofs:
            self.response_dofs = tuple(DOF(k + 1) for k in range(n_out))
        if not self.reference_dofs:
            self.reference_dofs = tuple(DOF(0) for _ in range(n_in))
        self.response_dofs = tuple(self.response_dofs)
        self.reference_dofs = tuple(self.reference_dofs)
        if len(self.response_dofs) != n_out or len(self.reference_dofs) != n_in:
            raise DataError(
                f"{where}{len(self.response_dofs)} response / {len(self.reference_dofs)} "
                f"reference labels for an H of shape {self.H.shape}"
            )
        if self.coherence is not None:
            coh = np.asarray(self.coherence, dtype=float)
            if coh.shape != self.H.shape:
                raise DataError(f"{where}coherence shape {coh.shape} != H shape {self.H.shape}")
            self.coherence = coh
        self.check_finite()

    def check_finite(self) -> None:
        """Raise DataError naming the source, the DOFs and the frequency of the first
        NaN/inf value in H or the coherence (the arrays can change after construction)."""
        where = f"{self.source.path}: " if self.source.path else ""
        bad = ~np.isfinite(self.H)
        if bad.any():
            o, i, k = np.argwhere(bad)[0]
            raise DataError(
                f"{where}FRF contains {int(bad.sum())} NaN/inf values (first: response "
                f"{self.response_dofs[o].label()}, reference {self.reference_dofs[i].label()}, "
                f"{self.freq_hz[k]:.4g} Hz)"
            )
        if self.coherence is not None and not np.all(np.isfinite(self.coherence)):
            raise DataError(f"{where}coherence contains NaN/inf values")

    def __repr__(self) -> str:
        """Short: configuration, shape, band, quantity, coherence, source (no arrays)."""
        f = self.freq_hz
        return (
            f"FRFSet({self.configuration or 'unnamed'}: {self.n_out} out x {self.n_in} in x "
            f"{f.size} lines, {f[0]:.4g}-{f[-1]:.5g} Hz (df {self.df_hz:.4g} Hz), "
            f"{self.quantity} {self.units}, "
            f"coherence {'yes' if self.coherence is not None else 'no'}, "
            f"source {self.source.path or 'memory'})"
        )

    # -- convenience -------------------------------------------------------
    @property
    def units(self) -> str:
        return QUANTITY_UNITS[self.quantity]

    @property
    def n_out(self) -> int:
        return self.H.shape[0]

    @property
    def n_in(self) -> int:
        return self.H.shape[1]

    @property
    def df_hz(self) -> float:
        return float(self.freq_hz[1] - self.freq_hz[0])

    def as_quantity(self, quantity: Quantity) -> FRFSet:
        """Return the FRFs converted to another quantity.

        Accelerance = j*omega * mobility = (j*omega)^2 * receptance. Lines at
        0 Hz, where the conversion divides by zero, are set to 0.
        """
        if quantity not in QUANTITY_UNITS:
            raise DataError(f"unknown FRF quantity {quantity!r}")
        if quantity == self.quantity:
            return replace(self)
        factor = quantity_factor(self.quantity, quantity, self.freq_hz)
        return replace(self, H=self.H * factor, quantity=quantity)

    def reciprocal(self) -> FRFSet:
        """The same FRFs with responses and references swapped (Maxwell reciprocity).

        A roving-hammer test (many references, one response) becomes one
        reference and many responses, which keeps a poly-reference model small.

        Examples
        --------
        >>> roving = FRFSet(freq_hz=np.arange(1.0, 6.0), H=np.ones((1, 3, 5), complex),
        ...                 response_dofs=(DOF(1),), reference_dofs=(DOF(2), DOF(3), DOF(4)))
        >>> single = roving.reciprocal()
        >>> single.H.shape, [d.label() for d in single.response_dofs]
        ((3, 1, 5), ['2+Z', '3+Z', '4+Z'])
        """
        coh = None if self.coherence is None else self.coherence.transpose(1, 0, 2)
        a = self.acquisition
        info = replace(a, layout="" if a.layout == "reciprocal" else "reciprocal",
                       response_negative=a.reference_negative,
                       reference_negative=a.response_negative)
        return replace(
            self,
            H=self.H.transpose(1, 0, 2),
            coherence=coh,
            response_dofs=self.reference_dofs,
            reference_dofs=self.response_dofs,
            acquisition=info,
        )

    def band(self, lo_hz: float, hi_hz: float) -> FRFSet:
        """The lines with lo_hz <= f <= hi_hz (a copy).

        Examples
        --------
        >>> frf = FRFSet(freq_hz=np.arange(0.0, 100.0), H=np.ones(100, complex))
        >>> sub = frf.band(10.0, 20.0)
        >>> sub.freq_hz[[0, -1]], sub.H.shape
        (array([10., 20.]), (1, 1, 11))
        """
        if not lo_hz < hi_hz:
            raise DataError(f"band [{lo_hz}, {hi_hz}] Hz is empty")
        if lo_hz < self.freq_hz[0] - 1e-9 or hi_hz > self.freq_hz[-1] + 1e-9:
            raise DataError(
                f"band [{lo_hz}, {hi_hz}] Hz lies outside the frequency axis "
                f"[{self.freq_hz[0]:.4g}, {self.freq_hz[-1]:.4g}] Hz"
            )
        sel = (self.freq_hz >= lo_hz) & (self.freq_hz <= hi_hz)
        coh = None if self.coherence is None else self.coherence[..., sel]
        return replace(self, freq_hz=self.freq_hz[sel], H=self.H[..., sel], coherence=coh)
