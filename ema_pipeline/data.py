"""Small typed containers that the pipeline stages pass to each other.

Only plain numpy arrays and scalars live here; file layouts are the business of
:mod:`ema_pipeline.io`. Every container validates itself on construction so that
bad data is rejected at the border of the library, with a message that names the
problem (and the source file, when there is one), instead of failing later deep
inside numpy.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from html import escape
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from ema_pipeline import paper

if TYPE_CHECKING:
    import pandas as pd

Quantity = Literal["accelerance", "mobility", "receptance"]

#: SI units of each FRF quantity (response per newton of force).
QUANTITY_UNITS: dict[str, str] = {
    "accelerance": "m/s^2/N",
    "mobility": "m/s/N",
    "receptance": "m/N",
}
#: Power of (j*omega) that turns receptance into the quantity.
QUANTITY_POWER: dict[str, int] = {"receptance": 0, "mobility": 1, "accelerance": 2}


#: Fewest frequency lines an FRF must have for identification: the default band
#: skips the first 5 lines, and pLSCF needs 2 (p + 1) lines for model order p;
#: below about 32 lines the stabilization diagram has too few orders to find a
#: mode (measured: a single-mode FRF is found from 32 lines, not from 24).
MIN_FRF_LINES: int = 32

#: Plausible frequency axes: line spacing at least this (Hz; a 11.6-day record) ...
MIN_DF_HZ = 1e-6
#: ... and no line above this (Hz). :func:`ema_pipeline.io.check_frequency_axis`
#: refuses other axes; the acquisition keeps recordings within them.
MAX_AXIS_HZ = 1e7


class EMAError(Exception):
    """Base class of the errors ema-pipeline raises on bad input or settings."""


class ConfigError(EMAError, ValueError):
    """A usage or configuration problem (unknown name, unreadable experiment file)."""


class DataError(EMAError, ValueError):
    """Input data that cannot be used (wrong shape, NaN, unknown units, ...).

    The message names the source (file) when known.
    """


class OptionError(ConfigError):
    """An impossible value of a field of an option record
    (:class:`~ema_pipeline.identification.IdentificationOptions`,
    :class:`~ema_pipeline.identification.SelectionThresholds`): ``field`` names
    it, ``reason`` says what it must be and what it got. The command line and
    the experiment file put their own name of the field (``--max-order``,
    ``[identification] max_order``) before the reason.

    Examples
    --------
    >>> str(OptionError("min_fraction", "must be a number in (0, 1], got 5"))
    'min_fraction must be a number in (0, 1], got 5'
    """

    def __init__(self, field: str, reason: str) -> None:
        self.field, self.reason = field, reason
        super().__init__(f"{field} {reason}")


def quantity_power(quantity: str) -> int:
    """Power q of (j*omega) that turns receptance into ``quantity``: 0 receptance,
    1 mobility, 2 accelerance (H_quantity = (j omega)^q H_receptance).

    In pole-residue form the same power multiplies the residue: the residue of
    the quantity is lambda_r^q times that of the receptance.

    Examples
    --------
    >>> quantity_power("receptance"), quantity_power("mobility"), quantity_power("accelerance")
    (0, 1, 2)
    """
    try:
        return QUANTITY_POWER[quantity]
    except KeyError:
        raise DataError(
            f"unknown FRF quantity {quantity!r}; expected one of {sorted(QUANTITY_POWER)}"
        ) from None


def quantity_factor(quantity_from: str, quantity_to: str, freq_hz: np.ndarray) -> np.ndarray:
    """Factor (j omega)^(q_to - q_from) per line that converts an FRF of
    ``quantity_from`` into ``quantity_to`` (omega = 2 pi ``freq_hz``).

    Accelerance = j omega mobility = (j omega)^2 receptance. Where the factor is
    not finite (negative powers at 0 Hz) it is 0.

    Examples
    --------
    >>> quantity_factor("receptance", "accelerance", np.array([0.0, 1.0])).real  # -(2 pi f)^2
    array([  0.        , -39.4784176])
    >>> quantity_factor("accelerance", "receptance", np.array([0.0, 1.0])).real  # 0 where infinite
    array([ 0.        , -0.02533030])
    """
    power = quantity_power(quantity_to) - quantity_power(quantity_from)
    jw = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = jw**power
    return np.where(np.isfinite(factor), factor, 0.0)


def axis_is_uniform(freq_hz: np.ndarray, rtol: float = 1e-6) -> bool:
    """True when the lines of ``freq_hz`` are equally spaced (within ``rtol`` of the
    mean step); identification needs a uniform axis.

    Parameters
    ----------
    freq_hz : (n_freq,) frequency axis in Hz.
    rtol : tolerance on each step relative to the mean step.

    Returns
    -------
    bool (True for fewer than 3 lines).

    Examples
    --------
    >>> axis_is_uniform(np.arange(5.0)), axis_is_uniform(np.array([1.0, 2.0, 4.0]))
    (True, False)
    """
    f = np.asarray(freq_hz, dtype=float)
    if f.size < 3:
        return True
    step = np.diff(f)
    return bool(np.all(np.abs(step - step.mean()) <= rtol * abs(step.mean())))


def std_column(column: str, columns: Iterable[str]) -> str | None:
    """Name of the standard-deviation column of ``column`` among ``columns``, if
    any: ``x_std``, or ``fn_std_hz`` for ``fn_hz`` (units ``_hz _pct _m _kg``),
    the naming of every table and of :class:`ModalParameters`.

    Examples
    --------
    >>> names = ["fn_hz", "fn_std_hz", "zeta_pct", "zeta_std_pct", "r", "r_std"]
    >>> [std_column(c, names) for c in ("fn_hz", "zeta_pct", "r", "fn_std_hz")]
    ['fn_std_hz', 'zeta_std_pct', 'r_std', None]
    """
    if "_std" in column:
        return None
    candidates = [f"{column}_std"]
    for unit in ("_hz", "_pct", "_m", "_kg"):
        if column.endswith(unit):
            candidates.append(column[: -len(unit)] + "_std" + unit)
    present = set(columns)
    return next((c for c in candidates if c in present), None)


def notebook_table_html(columns: Mapping[str, Sequence[Any] | np.ndarray],
                        caption: str = "") -> str:
    """A plain HTML table of equal-length ``columns`` for notebook display
    (``_repr_html_`` of the data objects): a value with a standard deviation
    column (:func:`std_column`) as ``value ± std`` in one cell, floats to 6
    significant digits (std to 2), NaN as an empty cell, every text escaped.
    The report's tables (decimals per column) are :func:`ema_pipeline.report.html_table`.

    Examples
    --------
    >>> html = notebook_table_html({"fn_hz": [18.1423456], "fn_std_hz": [0.00123], "x": ["<b>"]})
    >>> html[html.index("<tr><td>"):]
    '<tr><td>18.1423 ± 0.0012</td><td>&lt;b&gt;</td></tr></table>'
    """

    def cell(value: Any, digits: int = 6) -> str:
        if isinstance(value, float | np.floating):
            return "" if np.isnan(value) else f"{value:.{digits}g}"
        return escape(str(value))

    def merged(value: Any, std: Any) -> str:
        text = cell(value)
        return f"{text} ± {cell(std, 2)}" if text and cell(std) else text

    names = [str(name) for name in columns]
    stds = {name: std_column(name, names) for name in names}
    shown = [name for name in names if name not in set(stds.values())]
    values = {name: list(columns[name]) for name in names}
    rows = "".join(
        "<tr>" + "".join(
            f"<td>{merged(values[c][r], values[s][r]) if (s := stds[c]) else cell(values[c][r])}"
            "</td>" for c in shown) + "</tr>"
        for r in range(len(values[names[0]]) if names else 0)
    )
    head = "".join(f"<th>{escape(name)}</th>" for name in shown)
    title = f"<caption>{escape(caption)}</caption>" if caption else ""
    return f"<table>{title}<tr>{head}</tr>{rows}</table>"


@dataclass(frozen=True)
class Table:
    """A table as named 1-D columns of equal length, in order: what a
    ``pandas.DataFrame`` would hold, for the stages that write a table and
    have no other use for pandas (``ema-pipeline identify`` writes its modes
    table this way: importing pandas costs each command 0.4-0.5 s).
    :func:`ema_pipeline.io.write_csv` and
    :func:`ema_pipeline.io.write_results_h5` store it as they store a
    DataFrame of the same columns.

    Examples
    --------
    >>> t = Table({"mode": np.array([1, 2]), "fn_hz": np.array([18.1, 112.0])})
    >>> t.names, t.to_frame().shape
    (['mode', 'fn_hz'], (2, 2))
    >>> Table({"a": np.zeros(2), "b": np.zeros(3)})
    Traceback (most recent call last):
    ...
    ValueError: table columns must be 1-D and of equal length: a (2,), b (3,)
    """

    columns: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        arrays = {str(name): np.asarray(col) for name, col in self.columns.items()}
        shapes = {col.shape for col in arrays.values()}
        if len(shapes) > 1 or any(len(shape) != 1 for shape in shapes):
            raise ValueError("table columns must be 1-D and of equal length: "
                             + ", ".join(f"{name} {col.shape}" for name, col in arrays.items()))
        object.__setattr__(self, "columns", arrays)

    @property
    def names(self) -> list[str]:
        """The column names, in order."""
        return list(self.columns)

    def to_frame(self) -> pd.DataFrame:
        """The same columns as a ``pandas.DataFrame`` (pandas imported here)."""
        import pandas as pd

        return pd.DataFrame(self.columns)

    @classmethod
    def from_frame(cls, frame: pd.DataFrame) -> Table:
        """A ``pandas.DataFrame``'s columns, names as strings; a column of
        pandas' own string dtype as Python objects."""
        import pandas as pd  # imported already: frame is a DataFrame

        return cls({str(c): (frame[c].to_numpy(dtype=object)
                             if pd.api.types.is_string_dtype(frame[c]) else frame[c].to_numpy())
                    for c in frame.columns})


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


@dataclass(frozen=True)
class DofMap:
    """Where measurement DOFs lie on a :class:`Geometry`: per DOF the index of its
    node (-1: no such node), the axis (0, 1, 2 for X, Y, Z; -1: not a
    translation) and the sign of its direction; ``missing`` the DOFs that could
    not be placed (no node, or a rotation / scalar direction)."""

    node_index: np.ndarray
    axis: np.ndarray
    sign: np.ndarray
    missing: tuple[DOF, ...] = ()


@dataclass(frozen=True)
class Geometry:
    """The test object's wireframe: nodes, trace lines and optional surfaces.

    Attributes
    ----------
    node_ids : (n,) int
        Node numbers (as in the DOF labels of the FRFs).
    xyz_m : (n, 3) float
        Node coordinates in metres (global Cartesian system).
    lines : tuple of node-id tuples
        Trace lines: polylines through the given nodes (a pair is one segment).
    surfaces : tuple of node-id tuples
        Optional triangles or quads drawn filled.
    source : str
        Where the geometry came from (file path or a description).

    Examples
    --------
    >>> g = Geometry(node_ids=[1, 2, 3], xyz_m=[[0, 0, 0], [0.5, 0, 0], [1, 0, 0]],
    ...              lines=((1, 2, 3),))
    >>> m = g.map_dofs([DOF(2, 3), DOF(3, -1), DOF(9, 3)])
    >>> m.node_index.tolist(), m.axis.tolist(), m.sign.tolist(), [d.label() for d in m.missing]
    ([1, 2, -1], [2, 0, -1], [1, -1, 1], ['9+Z'])
    """

    node_ids: np.ndarray
    xyz_m: np.ndarray
    lines: tuple[tuple[int, ...], ...] = ()
    surfaces: tuple[tuple[int, ...], ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        where = f"{self.source}: " if self.source else ""
        ids = np.asarray(self.node_ids)
        xyz = np.asarray(self.xyz_m, dtype=float)
        if ids.ndim != 1 or ids.size == 0 or not np.issubdtype(ids.dtype, np.integer):
            raise DataError(f"{where}geometry node ids must be a non-empty list of integers")
        if xyz.shape != (ids.size, 3) or not np.all(np.isfinite(xyz)):
            raise DataError(f"{where}geometry needs finite (x, y, z) in m for each of its "
                            f"{ids.size} nodes, got an array of shape {xyz.shape}")
        if np.unique(ids).size != ids.size:
            dup = sorted({int(n) for n in ids if np.count_nonzero(ids == n) > 1})
            raise DataError(f"{where}geometry node(s) {dup} defined twice")
        object.__setattr__(self, "node_ids", ids.astype(int))
        object.__setattr__(self, "xyz_m", xyz)
        lines = tuple(tuple(int(n) for n in line) for line in self.lines)
        surfaces = tuple(tuple(int(n) for n in s) for s in self.surfaces)
        known = set(ids.tolist())
        for kind, items in (("trace line", lines), ("surface", surfaces)):
            for k, item in enumerate(items, start=1):
                unknown = sorted(set(item) - known)
                if unknown:
                    raise DataError(f"{where}{kind} {k} uses node(s) {unknown} that the "
                                    "geometry does not define")
                if kind == "trace line" and len(item) < 2:
                    raise DataError(f"{where}trace line {k} needs at least 2 nodes")
                if kind == "surface" and len(item) not in (3, 4):
                    raise DataError(f"{where}surface {k} needs 3 or 4 nodes, got {len(item)}")
        object.__setattr__(self, "lines", lines)
        object.__setattr__(self, "surfaces", surfaces)

    @property
    def n_nodes(self) -> int:
        return int(self.node_ids.size)

    def __repr__(self) -> str:
        return (f"Geometry({self.n_nodes} nodes, {len(self.lines)} trace lines, "
                f"{len(self.surfaces)} surfaces, source {self.source or 'memory'})")

    def map_dofs(self, dofs: Iterable[DOF]) -> DofMap:
        """Place measurement DOFs on the nodes by node number and direction
        (1..3 = X, Y, Z; a negative direction has sign -1). A DOF whose node is
        not in the geometry, or whose direction is not a translation, is listed
        in ``missing`` (index and axis -1), never dropped silently."""
        dofs = tuple(dofs)
        where = {int(n): k for k, n in enumerate(self.node_ids)}
        index = np.array([where.get(d.node, -1) for d in dofs], dtype=int)
        axis = np.array([abs(d.direction) - 1 if 1 <= abs(d.direction) <= 3 else -1
                         for d in dofs], dtype=int)
        bad = (index < 0) | (axis < 0)
        index[bad], axis[bad] = -1, -1
        sign = np.array([-1 if d.direction < 0 else 1 for d in dofs], dtype=int)
        missing = tuple(d for d, b in zip(dofs, bad, strict=True) if b)
        return DofMap(node_index=index, axis=axis, sign=sign, missing=missing)
