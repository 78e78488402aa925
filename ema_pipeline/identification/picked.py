"""Modes picked by hand, as data: :class:`Pick` and :class:`Picks`.

The content of a picks file (``identify --picks``), the poles a user chose in
the report's stabilization diagram. The file's layout (keys, version, comments)
is :mod:`ema_pipeline.io.picks`, which reads and writes it; the report's
interactive diagram (:mod:`ema_pipeline.report.stab_diagram`) writes the same
layout from its script; the fit of the picks is
:func:`ema_pipeline.identification.selection.picks.identify_picks`. This module is light
(no numerics), so that :mod:`ema_pipeline.io` can import it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ema_pipeline.identification.options import IdentificationOptions

#: A diagram pick matches the pole of its order whose natural frequency is
#: within this relative distance (nearest first).
PICK_TOL_REL: float = 1e-3


@dataclass(frozen=True)
class Pick:
    """One picked pole.

    Attributes
    ----------
    freq_hz, zeta : float
        Natural frequency (Hz) and damping ratio of the pole (window-corrected,
        as the diagram shows them).
    order : int or None
        Model order of a diagram pole; ``None`` for a pole given by value.
    pole : complex or None
        The pole itself (rad/s, before the window correction) for the start
        pole of an automatically kept mode; ``None`` for a diagram pole.
    """

    freq_hz: float
    zeta: float = float("nan")
    order: int | None = None
    pole: complex | None = None

    def label(self) -> str:
        """``"274.6 Hz at order 40"`` / ``"18.1 Hz (mode pole)"`` for messages.

        Examples
        --------
        >>> Pick(274.6, order=40).label(), Pick(18.1, pole=-1 + 113.7j).label()
        ('274.6 Hz at order 40', '18.1 Hz (mode pole)')
        """
        where = f"at order {self.order}" if self.order is not None else "(mode pole)"
        return f"{self.freq_hz:.6g} Hz {where}"


@dataclass(frozen=True)
class Picks:
    """The content of a picks file: the diagram's settings and the picks.

    Attributes
    ----------
    band_hz : (float, float)
        The identification band (Hz).
    orders : tuple of int
        The model orders of the diagram (its highest is the pLSCF order p).
    picks : tuple of Pick
        One :class:`Pick` per mode.
    weighting : str
        "none" or "coherence".
    source : str
        The file (for messages).
    companions : tuple of complex
        Poles (rad/s, before the window correction) refined together with the
        picks and then dropped, not reported (see
        :mod:`ema_pipeline.identification.selection.picks`).
    """

    band_hz: tuple[float, float]
    orders: tuple[int, ...]
    picks: tuple[Pick, ...]
    weighting: str = "none"
    source: str = ""
    companions: tuple[complex, ...] = ()

    @property
    def max_order(self) -> int:
        return int(max(self.orders))

    def options(self, options: IdentificationOptions) -> IdentificationOptions:
        """``options`` with the picks file's band, order and weighting.

        Examples
        --------
        >>> picks = Picks((5.0, 100.0), (2, 4, 40), (Pick(30.0, order=40),))
        >>> picks.options(IdentificationOptions()).max_order
        40
        """
        return replace(options, band_hz=self.band_hz, max_order=self.max_order,
                       weighting=self.weighting)  # type: ignore[arg-type]
