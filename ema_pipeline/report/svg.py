"""A small SVG chart writer for the report's figures.

Why written here instead of drawing with matplotlib: importing matplotlib and
saving the report's PNG figures (8193-point lines, constrained layout, tight
bounding boxes) took most of a study's run time and made a large report
(measured: docs/validation.md). The report needs only lines and markers on
linear or logarithmic axes, which this module writes as SVG text directly:

* every line is reduced to a per-pixel min/max envelope (:func:`envelope`), so
  a long FRF costs two points per horizontal pixel and looks the same;
* coordinates are integers on a grid of :data:`SCALE` units per CSS pixel,
  written as relative path commands (a few bytes per point);
* text stays text: searchable, selectable and sharp in print at any size.

:mod:`ema_pipeline.report.matplotlib_plots` keeps matplotlib versions of two of
them (the stabilization diagram, the fit) for interactive use.
Nothing here knows about modal analysis; :mod:`ema_pipeline.report.figures`
draws the report's figures with it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from html import escape

import numpy as np
import numpy.typing as npt

__all__ = [
    "SCALE",
    "Axes",
    "Canvas",
    "envelope",
    "NICE_MANTISSAS",
    "legend_size",
    "log_ticks",
    "nice_step",
    "nice_steps",
    "nice_ticks",
    "path_data",
    "standalone",
]

#: Canvas units per CSS pixel (integer coordinates on this grid are exact enough).
SCALE = 2
_FONT = 11 * SCALE  # base font size, canvas units
_SMALL = 9 * SCALE


def envelope(px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel min/max envelope of a line already in pixel coordinates.

    Points are grouped by ``floor(px)`` (``px`` increasing); a group of more
    than two points is replaced by its minimum and maximum, in the order the
    line passes them (the minimum first when the line rises through the
    column). Drawn at that pixel size the envelope covers exactly the pixels
    the full line covers.

    Parameters
    ----------
    px, py : (n,) float pixel coordinates, ``px`` non-decreasing.

    Returns
    -------
    (x, y) : float arrays of at most ``2 * n_columns`` points.

    Examples
    --------
    >>> x = np.linspace(0, 9.99, 1000)
    >>> y = np.sin(40 * x)
    >>> ex, ey = envelope(x, y)
    >>> ex.size, float(ey.min()) == float(y.min()), float(ey.max()) == float(y.max())
    (20, True, True)
    """
    px = np.asarray(px, dtype=float)
    py = np.asarray(py, dtype=float)
    col = np.floor(px)
    starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])
    if px.size <= 2 * starts.size:
        return px, py
    ends = np.r_[starts[1:], px.size] - 1
    lo = np.minimum.reduceat(py, starts)
    hi = np.maximum.reduceat(py, starts)
    rising = py[starts] <= py[ends]
    ey = np.empty(2 * starts.size)
    ey[0::2] = np.where(rising, lo, hi)
    ey[1::2] = np.where(rising, hi, lo)
    ex = np.repeat(col[starts] + 0.5, 2)
    return ex, ey


#: The leading digits of a round step between ticks: 1, 2 or 5 times a power of ten.
NICE_MANTISSAS = (1.0, 2.0, 5.0)


def nice_step(span: float, parts: float) -> float:
    """The smallest round step (:data:`NICE_MANTISSAS` times a power of ten)
    that cuts ``span`` into at most ``parts`` parts: the one home of the
    choice, for the figures' axes and the interactive diagram's.

    Examples
    --------
    >>> nice_step(1019.0, 7), nice_step(1.0, 5), nice_step(252.0, 7), nice_step(24.0, 8)
    (200.0, 0.2, 50.0, 5.0)
    """
    raw = span / parts
    mag = 10.0 ** math.floor(math.log10(raw))
    return next(m * mag for m in (*NICE_MANTISSAS, 10.0) if m * mag >= raw * 0.999)


def nice_steps(smallest: float, largest: float, parts: float) -> list[float]:
    """Every :func:`nice_step` of a span from ``smallest`` to ``largest``, in
    increasing order: the steps a page's script chooses from as its axis is
    zoomed (the first at least span / parts, which is :func:`nice_step`'s).

    Examples
    --------
    >>> nice_steps(1.0, 1019.0, 7)
    [0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0]
    """
    lo, hi = nice_step(smallest, parts), nice_step(largest, parts)
    ladder = [m * 10.0 ** k for k in range(math.floor(math.log10(lo)) - 1,
                                            math.floor(math.log10(hi)) + 2)
              for m in NICE_MANTISSAS]
    return [float(f"{v:.12g}") for v in ladder if lo * 0.999 <= v <= hi * 1.001]


def nice_ticks(lo: float, hi: float, n: int = 6) -> np.ndarray:
    """Round tick values (1, 2 or 5 times a power of ten apart,
    :func:`nice_step` for ``n - 1`` parts) within [lo, hi].

    Examples
    --------
    >>> nice_ticks(0.0, 1.0).tolist()
    [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    """
    if not hi > lo:
        return np.array([lo])
    step = nice_step(hi - lo, max(n - 1, 1))
    first = math.ceil(lo / step - 1e-9)
    ticks = (first + np.arange(math.floor(hi / step + 1e-6) - first + 1)) * step
    return np.round(ticks, max(0, 2 - math.floor(math.log10(step))))


def log_ticks(lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Major (labelled) and minor ticks of a log axis over [lo, hi] (lo > 0).

    Decades are major; with less than two decades 2 and 5 times them are too.

    Examples
    --------
    >>> [float(t) for t in log_ticks(0.5, 200.0)[0]]
    [1.0, 10.0, 100.0]
    >>> [float(t) for t in log_ticks(3.0, 20.0)[0]]
    [5.0, 10.0, 20.0]
    """
    d0, d1 = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    decades = 10.0 ** np.arange(d0, d1 + 1)
    all_minor = (decades[:, None] * np.arange(1, 10)[None, :]).ravel()
    inside = all_minor[(all_minor >= lo * (1 - 1e-9)) & (all_minor <= hi * (1 + 1e-9))]
    major = decades[(decades >= lo * (1 - 1e-9)) & (decades <= hi * (1 + 1e-9))]
    if major.size < 3:
        lead = np.round(inside / 10.0 ** np.floor(np.log10(inside)), 6)
        major = inside[np.isin(lead, (1.0, 2.0, 5.0))]
    minor = inside[~np.isin(inside, major)]
    return major, minor


def standalone(svg: str) -> str:
    """An inline ``<svg>`` element as the text of a ``.svg`` file (namespace and
    XML declaration added).

    Examples
    --------
    >>> standalone('<svg viewBox="0 0 2 2"></svg>').splitlines()[1]
    '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 2 2"></svg>'
    """
    if "xmlns=" not in svg.split(">", 1)[0]:
        svg = svg.replace("<svg", '<svg xmlns="http://www.w3.org/2000/svg"', 1)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + svg + "\n"


def _label(value: float, log: bool) -> str:
    """Tick label: plain numbers, powers of ten as 10 with a superscript."""
    if value == 0:
        return "0"
    if log and not 1e-2 <= abs(value) < 1e4:
        exponent = int(round(math.log10(abs(value))))
        if math.isclose(abs(value), 10.0**exponent, rel_tol=1e-9):
            return f'10<tspan dy="{-_SMALL // 2}" font-size="{_SMALL}">{exponent}</tspan>'
        return f"{value:.0e}"
    return f"{value:.6g}"


def _ints(values: np.ndarray) -> str:
    return " ".join(map(str, values.tolist())).replace(" -", "-")


def path_data(x: np.ndarray, y: np.ndarray) -> str:
    """SVG path data through integer points: ``M`` then relative ``l`` steps,
    repeated points dropped.

    Examples
    --------
    >>> path_data(np.array([0, 2, 2, 5]), np.array([10, 8, 8, 9]))
    'M0 10l2-2 3 1'
    """
    xi = np.rint(np.asarray(x, dtype=float)).astype(np.int64)
    yi = np.rint(np.asarray(y, dtype=float)).astype(np.int64)
    if xi.size == 0:
        return ""
    keep = np.r_[True, (np.diff(xi) != 0) | (np.diff(yi) != 0)]
    xi, yi = xi[keep], yi[keep]
    d = np.empty(2 * (xi.size - 1), dtype=np.int64)
    d[0::2] = np.diff(xi)
    d[1::2] = np.diff(yi)
    head = f"M{xi[0]} {yi[0]}"
    return head + ("l" + _ints(d) if d.size else "")


def legend_size(labels: Sequence[str], columns: int = 1) -> tuple[float, float]:
    """Width and height (CSS px) of a legend of ``labels`` in ``columns``
    columns, as :meth:`Axes.legend` draws it (0, 0 without labels).

    Examples
    --------
    >>> legend_size(["measured", "synthesised"], columns=2)
    (210.4, 21)
    """
    if not labels:
        return 0.0, 0.0
    rows = math.ceil(len(labels) / columns)
    return (max(len(x) for x in labels) * 6.2 + 34) * columns + 6, rows * 15 + 6


@dataclass
class Canvas:
    """An SVG drawing of ``width`` x ``height`` CSS pixels (coordinates in canvas
    units, :data:`SCALE` per pixel). ``title`` becomes the accessible name."""

    width: int
    height: int
    title: str = ""
    parts: list[str] = field(default_factory=list)

    def axes(
        self,
        box: tuple[float, float, float, float],
        xlim: tuple[float, float],
        ylim: tuple[float, float],
        *,
        xlog: bool = False,
        ylog: bool = False,
    ) -> Axes:
        """Axes in the pixel box ``(left, top, width, height)`` of the canvas."""
        return Axes(self, box, xlim, ylim, xlog, ylog)

    def add(self, element: str) -> None:
        self.parts.append(element)

    def text(
        self, x_px: float, y_px: float, text: str, *, anchor: str = "middle", size: int = _FONT,
        weight: str = "", color: str = "", rotate: bool = False,
    ) -> None:
        """Escaped text at pixel position (x, y) (baseline)."""
        x, y = round(x_px * SCALE), round(y_px * SCALE)
        attrs = f'x="{x}" y="{y}" text-anchor="{anchor}"'
        if size != _FONT:
            attrs += f' font-size="{size}"'
        if weight:
            attrs += f' font-weight="{weight}"'
        if color:
            attrs += f' fill="{color}"'
        if rotate:
            attrs += f' transform="rotate(-90 {x} {y})"'
        self.add(f"<text {attrs}>{escape(text)}</text>")

    def to_svg(self, standalone: bool = False) -> str:
        """The SVG element; ``standalone`` adds the XML namespace and declaration
        for a ``.svg`` file."""
        w, h = self.width * SCALE, self.height * SCALE
        ns = ' xmlns="http://www.w3.org/2000/svg"' if standalone else ""
        head = (
            f'<svg{ns} viewBox="0 0 {w} {h}" width="{self.width}" height="{self.height}" '
            f'class="fig" role="img" aria-label="{escape(self.title)}" '
            f'font-family="system-ui,Segoe UI,Helvetica,Arial,sans-serif" font-size="{_FONT}" '
            'stroke-linejoin="round">'
        )
        title = f"<title>{escape(self.title)}</title>" if self.title else ""
        body = head + title + "".join(self.parts) + "</svg>"
        return ('<?xml version="1.0" encoding="utf-8"?>\n' + body + "\n") if standalone else body


@dataclass
class Axes:
    """Linear or logarithmic axes in a pixel box of a :class:`Canvas`."""

    canvas: Canvas
    box: tuple[float, float, float, float]
    xlim: tuple[float, float]
    ylim: tuple[float, float]
    xlog: bool = False
    ylog: bool = False
    legend_items: list[tuple[str, str]] = field(default_factory=list)
    #: The (x, y) CSS-pixel points of the lines drawn so far, for a legend
    #: placed where they are fewest (``legend("best")``).
    drawn: list[np.ndarray] = field(default_factory=list)

    def __post_init__(self) -> None:
        for lim, log, name in ((self.xlim, self.xlog, "x"), (self.ylim, self.ylog, "y")):
            if not (np.all(np.isfinite(lim)) and lim[1] > lim[0]) or (log and lim[0] <= 0):
                raise ValueError(f"bad {name} limits {lim} for a {'log' if log else 'linear'} axis")

    # -- coordinates -------------------------------------------------------
    def _t(self, v: npt.ArrayLike, lim: tuple[float, float], log: bool) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        if log:
            with np.errstate(divide="ignore", invalid="ignore"):
                return (np.log10(v) - math.log10(lim[0])) / (
                    math.log10(lim[1]) - math.log10(lim[0])
                )
        return (v - lim[0]) / (lim[1] - lim[0])

    def px(self, x: npt.ArrayLike) -> np.ndarray:
        """x data -> canvas pixels (CSS px)."""
        return self.box[0] + self._t(x, self.xlim, self.xlog) * self.box[2]

    def py(self, y: npt.ArrayLike) -> np.ndarray:
        """y data -> canvas pixels (CSS px, downwards)."""
        return self.box[1] + (1 - self._t(y, self.ylim, self.ylog)) * self.box[3]

    # -- drawing -----------------------------------------------------------
    def line(
        self, x: np.ndarray, y: np.ndarray, color: str, *, width: float = 1.0,
        dash: str = "", label: str = "", opacity: float = 1.0,
    ) -> None:
        """A line through (x, y), drawn as its per-pixel envelope, clipped to the box."""
        px, py = self.px(x), self.py(y)
        ok = np.isfinite(px) & np.isfinite(py)
        x0, x1 = self.box[0], self.box[0] + self.box[2]
        ok &= (px >= x0 - 0.5) & (px <= x1 + 0.5)
        px, py = px[ok], np.clip(py[ok], self.box[1], self.box[1] + self.box[3])
        if px.size == 0:
            return
        ex, ey = envelope(px * SCALE / 2, py)  # columns of 2 CSS px: half the points
        self.drawn.append(np.c_[ex * 2 / SCALE, ey])
        d = path_data(ex * 2, ey * SCALE)
        attrs = f'd="{d}" fill="none" stroke="{color}" stroke-width="{width * SCALE:g}"'
        if dash:
            attrs += f' stroke-dasharray="{dash}"'
        if opacity < 1:
            attrs += f' stroke-opacity="{opacity:g}"'
        self.canvas.add(f"<path {attrs}/>")
        if label:
            self.legend_items.append((label, f'stroke="{color}" stroke-width="{width * SCALE:g}"'
                                      + (f' stroke-dasharray="{dash}"' if dash else "")))

    def markers(
        self, x: np.ndarray, y: np.ndarray, color: str, *, shape: str = "o", size: float = 4.0,
        label: str = "",
    ) -> None:
        """Markers ``o`` (dot), ``s`` (square), ``x`` (cross) or ``+`` at (x, y), one path,
        points on the same canvas unit drawn once."""
        px, py = self.px(x) * SCALE, self.py(y) * SCALE
        left, top, w, h = (v * SCALE for v in self.box)
        ok = np.isfinite(px) & np.isfinite(py)
        ok &= (px >= left - 1) & (px <= left + w + 1) & (py >= top - 1) & (py <= top + h + 1)
        pts = np.unique(np.rint(np.c_[px[ok], py[ok]]).astype(np.int64), axis=0)
        if pts.size == 0:
            return
        s = size * SCALE
        r = int(round(s / 2))
        if shape in ("o", "s"):
            cap = "round" if shape == "o" else "square"
            body = "".join(f"M{a} {b}h0" for a, b in pts.tolist())
            style = f'stroke="{color}" stroke-width="{s:g}" stroke-linecap="{cap}"'
        elif shape == "x":
            d = 2 * r
            body = "".join(f"M{a - r} {b - r}l{d} {d}m0-{d}l-{d} {d}" for a, b in pts.tolist())
            style = f'stroke="{color}" stroke-width="{SCALE}"'
        else:
            body = "".join(f"M{a - r} {b}h{2 * r}m-{r}-{r}v{2 * r}" for a, b in pts.tolist())
            style = f'stroke="{color}" stroke-width="{SCALE}"'
        self.canvas.add(f'<path d="{body}" fill="none" {style}/>')
        if label:
            if shape in ("o", "s"):
                style = style.replace(f'stroke-width="{s:g}"', f'stroke-width="{min(s, 12):g}"')
                self.legend_items.append((label, f"{style} marker"))
            else:
                glyph = "M12 -6l12 12m0-12l-12 12" if shape == "x" else "M10 0h16m-8-8v16"
                self.legend_items.append((label, f'{style} glyph="{glyph}"'))

    def vline(self, x: float, color: str, *, width: float = 1.0, dash: str = "") -> None:
        px = round(float(self.px(x)) * SCALE)
        y0, y1 = round(self.box[1] * SCALE), round((self.box[1] + self.box[3]) * SCALE)
        extra = f' stroke-dasharray="{dash}"' if dash else ""
        self.canvas.add(
            f'<path d="M{px} {y0}V{y1}" stroke="{color}" stroke-width="{width * SCALE:g}"{extra}/>'
        )

    def hline(self, y: float, color: str, *, width: float = 1.0, dash: str = "") -> None:
        py = round(float(self.py(y)) * SCALE)
        x0, x1 = round(self.box[0] * SCALE), round((self.box[0] + self.box[2]) * SCALE)
        extra = f' stroke-dasharray="{dash}"' if dash else ""
        self.canvas.add(
            f'<path d="M{x0} {py}H{x1}" stroke="{color}" stroke-width="{width * SCALE:g}"{extra}/>'
        )

    def bars(
        self, x: np.ndarray, height: np.ndarray, width: float, color: str, *,
        err: np.ndarray | None = None, label: str = "",
    ) -> None:
        """Vertical bars from 0 (data units), optional +-err whiskers."""
        x = np.asarray(x, dtype=float)
        h = np.asarray(height, dtype=float)
        left = np.rint(self.px(x - width / 2) * SCALE).astype(int)
        right = np.rint(self.px(x + width / 2) * SCALE).astype(int)
        top = np.rint(self.py(np.maximum(h, 0)) * SCALE).astype(int)
        bottom = np.rint(self.py(np.minimum(h, 0)) * SCALE).astype(int)
        d = "".join(
            f"M{a} {t}H{b}V{u}H{a}z" for a, b, t, u in zip(left, right, top, bottom, strict=True)
        )
        self.canvas.add(f'<path d="{d}" fill="{color}"/>')
        if err is not None:
            e = np.asarray(err, dtype=float)
            ok = np.isfinite(e)
            lo = np.rint(self.py(h - e) * SCALE).astype(int)
            hi = np.rint(self.py(h + e) * SCALE).astype(int)
            cx = np.rint(self.px(x) * SCALE).astype(int)
            d = "".join(
                f"M{c} {a}V{b}M{c - 5} {a}h10M{c - 5} {b}h10"
                for c, a, b, k in zip(cx, lo, hi, ok, strict=True)
                if k
            )
            if d:
                self.canvas.add(f'<path d="{d}" stroke="#222" stroke-width="{SCALE}"/>')
        if label:
            self.legend_items.append((label, f'fill="{color}" bar'))

    def text(self, x: float, y: float, text: str, **kwargs: object) -> None:
        """Text at data coordinates (x, y)."""
        self.canvas.text(float(self.px(x)), float(self.py(y)), text, **kwargs)  # type: ignore[arg-type]

    # -- frame, ticks, labels, legend ----------------------------------------
    def frame(
        self, *, xlabel: str = "", ylabel: str = "", title: str = "", yside: str = "left",
        xticks: Sequence[float] | None = None, xticklabels: Sequence[str] | None = None,
        show_x: bool = True, grid: bool = True, draw_box: bool = True,
    ) -> None:
        """Box, ticks with labels, grid lines, axis labels and title."""
        c = self.canvas
        left, top, w, h = self.box
        S = SCALE
        if draw_box:
            c.add(
                f'<rect x="{round(left * S)}" y="{round(top * S)}" width="{round(w * S)}" '
                f'height="{round(h * S)}" fill="none" stroke="#444" stroke-width="{S}"/>'
            )
        grid_d: list[str] = []
        tick_d: list[str] = []
        # x axis
        if show_x or xticks is not None:
            if xticks is not None:
                xmaj, xmin = np.asarray(xticks, dtype=float), np.zeros(0)
            elif self.xlog:
                xmaj, xmin = log_ticks(*self.xlim)
            else:
                xmaj, xmin = nice_ticks(*self.xlim, n=8), np.zeros(0)
            yb = round((top + h) * S)
            for k, t in enumerate(xmaj):
                p = round(float(self.px(t)) * S)
                if grid:
                    grid_d.append(f"M{p} {round(top * S)}V{yb}")
                tick_d.append(f"M{p} {yb}v8")
                if show_x:
                    lab = xticklabels[k] if xticklabels is not None else _label(t, self.xlog)
                    c.add(f'<text x="{p}" y="{yb + 26}" text-anchor="middle">{lab}</text>')
            for t in xmin:
                p = round(float(self.px(t)) * S)
                tick_d.append(f"M{p} {yb}v4")
            if xlabel and show_x:
                c.text(left + w / 2, top + h + 28, xlabel)
        # y axis
        if self.ylog:
            ymaj, ymin = log_ticks(*self.ylim)
        else:
            ymaj, ymin = nice_ticks(*self.ylim, n=5), np.zeros(0)
        xa = round((left if yside == "left" else left + w) * S)
        sign = -1 if yside == "left" else 1
        for t in ymaj:
            p = round(float(self.py(t)) * S)
            if grid:
                grid_d.append(f"M{round(left * S)} {p}H{round((left + w) * S)}")
            tick_d.append(f"M{xa} {p}h{8 * sign}")
            anchor = "end" if yside == "left" else "start"
            c.add(
                f'<text x="{xa + 12 * sign}" y="{p + 7}" text-anchor="{anchor}">'
                f"{_label(t, self.ylog)}</text>"
            )
        for t in ymin:
            p = round(float(self.py(t)) * S)
            tick_d.append(f"M{xa} {p}h{4 * sign}")
        if grid and grid_d:
            c.parts.insert(0, f'<path d="{"".join(grid_d)}" stroke="#e4e4e4" stroke-width="2"/>')
        c.add(f'<path d="{"".join(tick_d)}" stroke="#444" stroke-width="{S}"/>')
        if ylabel:
            xl = left - 52 if yside == "left" else left + w + 56
            c.text(xl, top + h / 2, ylabel, rotate=True)
        if title:
            c.text(left + w / 2, top - 7, title, weight="600")

    def legend_size(self, columns: int = 1) -> tuple[float, float]:
        """Width and height (CSS px) of the legend of the labelled items drawn
        so far in ``columns`` columns (:func:`legend_size`)."""
        return legend_size([label for label, _ in self.legend_items], columns)

    def emptiest_corner(self, w: float, h: float) -> str:
        """The corner of the box (``"upper right"``, ``"upper left"``, ``"lower
        right"``, ``"lower left"``) where a ``w`` x ``h`` legend covers the
        fewest points of the lines drawn so far (the first of a tie).

        Examples
        --------
        >>> ax = Canvas(200, 100).axes((0, 0, 200, 100), (0.0, 1.0), (0.0, 1.0))
        >>> ax.line(np.linspace(0, 1, 50), np.linspace(0, 1, 50), "#000")  # rising
        >>> ax.emptiest_corner(60, 30)
        'upper left'
        """
        left, top, bw, bh = self.box
        pts = np.concatenate(self.drawn) if self.drawn else np.zeros((0, 2))
        best, fewest = "upper right", None
        for where in ("upper right", "upper left", "lower right", "lower left"):
            x0 = left + 6 if "left" in where else left + bw - w - 6
            y0 = top + 6 if "upper" in where else top + bh - h - 6
            n = int(np.count_nonzero((pts[:, 0] >= x0 - 3) & (pts[:, 0] <= x0 + w + 3)
                                     & (pts[:, 1] >= y0 - 3) & (pts[:, 1] <= y0 + h + 3)))
            if fewest is None or n < fewest:
                best, fewest = where, n
        return best

    def legend(self, where: str = "best", columns: int = 1) -> None:
        """Legend of the labelled lines, markers and bars drawn so far: in a
        corner of the box (``"best"``: :meth:`emptiest_corner`) or ``"below"``
        the x axis's label, outside the box."""
        if not self.legend_items:
            return
        c = self.canvas
        S = SCALE
        n = len(self.legend_items)
        rows = math.ceil(n / columns)
        w, h = self.legend_size(columns)
        col_w = (w - 6) / columns
        left, top, bw, bh = self.box
        if where == "best":
            where = self.emptiest_corner(w, h)
        x0 = left + 6 if "left" in where else left + bw - w - 6
        y0 = top + 6 if "upper" in where else top + bh - h - 6
        if where == "below":  # under the x axis label, outside the box
            x0, y0 = left, top + bh + 36
        c.add(
            f'<rect x="{round(x0 * S)}" y="{round(y0 * S)}" width="{round(w * S)}" '
            f'height="{round(h * S)}" fill="#fff" fill-opacity="0.85" stroke="#bbb"/>'
        )
        for k, (label, style) in enumerate(self.legend_items):
            cx = x0 + 5 + (k // rows) * col_w
            cy = y0 + 11 + (k % rows) * 15
            sx, sy = round(cx * S), round((cy - 4) * S)
            if style.endswith(" marker"):
                c.add(f'<path d="M{sx + 18} {sy}h0" {style[:-7]}/>')
            elif ' glyph="' in style:
                style, glyph = style.split(' glyph="')
                rel = glyph[:-1].replace("M", "m", 1)
                c.add(f'<path d="M{sx} {sy}{rel}" fill="none" {style}/>')
            elif style.endswith(" bar"):
                c.add(f'<rect x="{sx + 6}" y="{sy - 9}" width="24" height="18" {style[:-4]}/>')
            else:
                c.add(f'<path d="M{sx} {sy}h36" fill="none" {style}/>')
            c.text(cx + 24, cy, label, anchor="start", size=_SMALL + 2)
