"""Resource guard and plausibility of the identification settings, checked up front.

:func:`check_identification` is called by
:func:`~ema_pipeline.identification.identify` (and by ``run`` for every
configuration before the study starts) once the size of the FRF set is known
and *before* the identification allocates anything: it refuses orders the data
cannot support (more unknowns than equations, fewer than six diagram orders),
a band outside the frequency axis or with too few lines, and settings whose
estimated memory (:func:`estimate_memory_bytes`) exceeds
``options.memory_limit_gb`` (default
:data:`~ema_pipeline.identification.options.DEFAULT_MEMORY_LIMIT_GB` GiB; on
the command line ``--memory-limit-gb`` or the environment variable
:data:`MEMORY_LIMIT_ENV`, read by the command line only). Every refusal is a
:class:`~ema_pipeline.data.ConfigError` with the number and a hint.

The estimate is a plain operation count of the arrays the methods build (see
:func:`estimate_memory_bytes`), not a measurement: a measurement would need the
allocation it is meant to prevent.
"""

from __future__ import annotations

import math

import numpy as np

from ema_pipeline.data import ConfigError, FRFSet
from ema_pipeline.identification.options import DEFAULT_MEMORY_LIMIT_GB, IdentificationOptions

#: Environment variable the command line reads for its ``--memory-limit-gb``
#: default (GiB); the library never reads it.
MEMORY_LIMIT_ENV = "EMA_PIPELINE_MEMORY_LIMIT_GB"
#: Its former name (the one variable without the ``EMA_PIPELINE_`` prefix):
#: the command line still reads it, with a note to rename it.
OLD_MEMORY_LIMIT_ENV = "EMA_MEMORY_LIMIT_GB"
#: Fewest frequency lines in the band.
MIN_BAND_LINES = 16
_GIB = 1 << 30


def order_cap(n_lines: int, n_in: int, max_poles: int, *, window: bool = False) -> int:
    """Highest fixed ``max_order`` the lines in the band support.

    The model of order p has p n_in poles and (p + 1) n_in real numerator
    coefficients per output; the 2 n_lines real equations of each output must
    outnumber them about 4:1 (p <= (n_lines / 2 - 1) / n_in), and the
    companion matrix stays below ``max_poles`` rows (p <= max_poles / n_in;
    ``SelectionThresholds.max_poles``).
    For one reference a whole band is held to p <= n_lines / 4 (8:1): on the
    measured beam's 1000 lines and 30 outputs the 4:1 rule lets the order grow
    to 480, and poles of the model error come in (10 of the 14 published modes
    found, 4 others, instead of 12 and none). A ``window`` of a band (the
    searches of its lowest part and of windows of 10 candidates in a dense
    band) holds few lines and is held to the 4:1 rule only: 10 modes 3 lines
    wide in 86 lines need order 40, and n_lines / 4 allows 21.

    Examples
    --------
    >>> order_cap(8000, 1, 480), order_cap(8000, 3, 480), order_cap(400, 1, 480)
    (480, 160, 100)
    >>> order_cap(86, 1, 480, window=True)
    42
    """
    by_lines = (n_lines // 2 - 1) // max(n_in, 1) if n_in > 1 or window else n_lines // 4
    return int(max(2, min(by_lines, max_poles // max(n_in, 1))))


def memory_limit_bytes(limit_gb: float = DEFAULT_MEMORY_LIMIT_GB) -> int:
    """The memory limit ``limit_gb`` (GiB, finite and positive) in bytes.

    Examples
    --------
    >>> memory_limit_bytes(0.5)
    536870912
    """
    if not (math.isfinite(limit_gb) and limit_gb > 0):
        raise ConfigError(f"memory limit must be a positive number of GiB, got {limit_gb!r}")
    return int(limit_gb * _GIB)


def estimate_memory_bytes(n_lines: int, n_in: int, n_out: int, max_order: int,
                          method: str = "plscf") -> int:
    """Estimated peak memory (bytes) of one identification at ``max_order``.

    pLSCF (Peeters et al. 2004): the complex basis and the per-output
    regression blocks, ``n_lines * (p + 1) * n_in * n_out`` complex numbers
    (twice, for the normal equations' products), the reduced normal matrices
    ``(p + 1)^2 * n_in^2 * n_out`` reals (R, S, T per output), the companion
    matrix of the highest order ``(p n_in)^2`` complex with LAPACK's workspace
    (x4), and LSFD ``n_lines * n_out * n_in * 2 p n_in`` complex. sdypy-EMA's
    LSCF solves up to order ``2 p``.

    Examples
    --------
    >>> round(estimate_memory_bytes(3200, 1, 2, 40) / 2**20, 1)  # MiB
    16.0
    >>> estimate_memory_bytes(3200, 1, 2, 2000) > estimate_memory_bytes(3200, 1, 2, 500)
    True
    """
    p = 2 * max_order if method == "sdypy-lscf" else max_order
    c, r = 16, 8  # bytes of a complex128 and a float64
    regression = 2 * c * n_lines * (p + 1) * n_in * n_out
    normal = 3 * r * (p + 1) ** 2 * n_in**2 * n_out
    companion = 4 * c * (p * n_in) ** 2
    lsfd = c * n_lines * n_out * n_in * 2 * p * n_in
    return int(regression + normal + companion + lsfd)


def check_identification(frf: FRFSet, options: IdentificationOptions, *,
                         source: str = "") -> None:
    """Refuse settings that cannot work on ``frf`` before identifying it.

    ``frf`` is the set :func:`~ema_pipeline.identification.identify` works on
    (one reference for a roving-hammer test:
    :func:`~ema_pipeline.identification.common.single_reference`). Checks what
    depends on the data (the options themselves were checked when they were
    made, :class:`IdentificationOptions`): the band against the frequency axis
    (inside it, at least :data:`MIN_BAND_LINES` lines), ``max_order`` against
    :func:`order_cap` (pLSCF), ``expect_hz`` inside the band, and the memory
    estimate against ``options.memory_limit_gb`` (at ``max_order``, or with
    the adaptive order search at the highest order it may reach,
    :func:`order_cap`). Raises ConfigError naming ``source``.

    Examples
    --------
    >>> frf = FRFSet(freq_hz=np.arange(0.0, 100.0, 0.5), H=np.ones((1, 1, 200), complex))
    >>> check_identification(frf, IdentificationOptions(band_hz=(5.0, 1e9)),
    ...                      source="x.h5")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ema_pipeline.data.ConfigError: x.h5: band 5..1e+09 Hz reaches beyond the frequency axis ...
    >>> check_identification(frf, IdentificationOptions(memory_limit_gb=1e-6))
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ema_pipeline.data.ConfigError: the adaptive order search up to order 50 on 200 lines ...
    """
    where = f"{source}: " if source else ""
    f = np.asarray(frf.freq_hz, dtype=float)
    lo_axis, hi_axis = float(f[0]), float(f[-1])
    lo, hi = options.band_hz if options.band_hz is not None else (lo_axis, hi_axis)
    if options.band_hz is not None and (lo < lo_axis - frf.df_hz or hi > hi_axis + frf.df_hz):
        raise ConfigError(
            f"{where}band {lo:g}..{hi:g} Hz reaches beyond the frequency axis "
            f"{lo_axis:g}..{hi_axis:g} Hz"
        )
    n_lines = int(np.count_nonzero((f >= lo) & (f <= hi)))
    if n_lines < MIN_BAND_LINES:
        raise ConfigError(
            f"{where}band {lo:g}..{hi:g} Hz holds {n_lines} frequency lines; at least "
            f"{MIN_BAND_LINES} are needed"
        )
    for fx in options.expect_hz:
        if not (math.isfinite(fx) and lo <= fx <= hi):
            raise ConfigError(f"{where}expected frequency {fx:g} Hz is outside the band "
                              f"{lo:g}..{hi:g} Hz")
    method = str(options.method)
    n_in, n_out = frf.n_in, frf.n_out
    cap = order_cap(n_lines, n_in, options.thresholds.max_poles)
    p = options.max_order
    if p is not None:
        if method == "plscf" and p > cap:
            raise ConfigError(
                f"{where}max order {p} is more than the {n_lines} lines in the band support "
                f"(at most {cap} for {n_in} reference(s)); lower --max-order / max_order or "
                "widen the band"
            )
    else:
        # the adaptive order search may raise the order up to the cap: the memory
        # check holds for the highest order it can reach
        p = cap
    need = estimate_memory_bytes(n_lines, n_in, n_out, p, method)
    limit = memory_limit_bytes(options.memory_limit_gb)
    if need > limit:
        what = "max order" if options.max_order else "the adaptive order search up to order"
        raise ConfigError(
            f"{where}{what} {p} on {n_lines} lines x {n_out} outputs x {n_in} inputs needs "
            f"about {need / _GIB:.1f} GiB, more than the limit of {limit / _GIB:.3g} GiB; "
            f"lower the order or narrow the band, or raise the limit (memory_limit_gb; on the "
            f"command line --memory-limit-gb or {MEMORY_LIMIT_ENV})"
        )
