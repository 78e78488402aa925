"""Animated mode shapes on the test geometry: presentation only.

A *shape view* is one mode drawn on the wireframe of a
:class:`~ema_pipeline.data.Geometry`: the undeformed lines in grey and the
deformed ones over them, animated over one cycle by a little inline
JavaScript, displacement(t) = Re(phi exp(i w t)) = Re(phi) cos(wt) -
Im(phi) sin(wt), so complex shapes move with their phases. The page carries the
data, not frames: the geometry and, per mode, the complex displacement of every
node as JSON (``<script type="application/json">``). Each view is a
``<figure data-mode-shape="<mode number>">`` holding an inline SVG already drawn
at t = 0 (the static frame that prints, and what a reader without JavaScript
sees); the script redraws it. Controls above the views set the amplitude
scale, the speed (cycles per second on screen), the projection (a fixed
isometric view or the XY, XZ, YZ planes) and pause. Nothing is loaded from
outside the page.

Nodes without a measured DOF: **interpolated linearly along the trace lines**
(by distance along the line) between the nearest measured nodes on either side,
axis by axis; a node with a measured node on one side only (the end of a line,
e.g. a support) or on no line **stays at rest**. Measured nodes are drawn as
filled dots, the others hollow.

The group functions: :func:`shape_views_html` (the modes of one result),
:func:`paired_shape_views_html` (the modes of several configurations, one row
per mode of the reference, its paired mode of every configuration beside it)
and :func:`shape_preview_html` (one view whose mode the page sets: the
stabilization diagram's preview). Each group's script animates its own views
(a page may hold several groups), and only while the group is shown.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ema_pipeline.data import DOF, FRFSet, Geometry
from ema_pipeline.identification import single_reference
from ema_pipeline.report.htmlparts import esc
from ema_pipeline.report.scripts import page_script

__all__ = [
    "MIN_SHAPE_DOFS",
    "ModeSet",
    "interpolated_displacements",
    "missing_dofs",
    "paired_shape_views_html",
    "shape_data",
    "shape_dof_count",
    "shape_preview_html",
    "shape_views_html",
]

#: Fewer measured points in a mode shape than this: a page shows no shape
#: (views, bars by DOF, the diagram's preview) and no AutoMAC. One value says
#: nothing and every MAC between one-value shapes is 1; two values hold at
#: most two independent shapes, so the AutoMAC cannot tell more modes apart.
MIN_SHAPE_DOFS = 3

#: Size of each view's SVG (px, its viewBox) and the share of the model's size
#: that the largest displacement takes at amplitude scale 1.
VIEW_W, VIEW_H, AMPLITUDE_SHARE = 300, 170, 0.15
#: Decimals of the shapes in the JSON (normalised to a largest component of 1).
DECIMALS = 4


def shape_dof_count(frf: FRFSet) -> int:
    """The number of measured points (DOFs) of a mode shape identified from
    ``frf``: its responses, or its references for a roving-hammer test (one
    response, several references: the shapes are over the hammer points by
    reciprocity, :func:`ema_pipeline.identification.single_reference`).

    Examples
    --------
    >>> f = np.linspace(0.0, 10.0, 11)
    >>> shape_dof_count(FRFSet(freq_hz=f, H=np.ones((1, 12, 11), complex)))  # roving hammer
    12
    >>> shape_dof_count(FRFSet(freq_hz=f, H=np.ones((2, 1, 11), complex)))   # two sensors
    2
    """
    return single_reference(frf).n_out


@dataclass(frozen=True)
class ModeSet:
    """Modes to draw: ``fn_hz``, ``zeta`` (ratio), ``shapes`` (n_dof, n_modes)
    complex at ``dofs``; ``measured`` the DOFs actually measured (default: all
    of ``dofs``; others, e.g. expanded by a model, are drawn hollow)."""

    fn_hz: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray
    dofs: tuple[DOF, ...]
    measured: tuple[DOF, ...] | None = None


def interpolated_displacements(
    geometry: Geometry, shapes: np.ndarray, dofs: Sequence[DOF]
) -> tuple[np.ndarray, np.ndarray]:
    """Complex displacement ``(n_nodes, 3, n_modes)`` of every node and the
    ``(n_nodes, 3)`` mask of the measured node axes: measured values placed by
    :meth:`~ema_pipeline.data.Geometry.map_dofs` (a DOF without node is left
    out), unmeasured nodes interpolated along the trace lines between measured
    nodes, else at rest (module docstring).

    Examples
    --------
    >>> g = Geometry(node_ids=[1, 2, 3, 4], xyz_m=[[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]],
    ...              lines=((1, 2, 3, 4),))
    >>> d, known = interpolated_displacements(g, np.array([[1.0], [3.0]]), [DOF(1), DOF(3)])
    >>> d[:, 2, 0].real.tolist(), known[:, 2].tolist()
    ([1.0, 2.0, 3.0, 0.0], [True, False, True, False])
    """
    phi = np.asarray(shapes, dtype=complex)
    if phi.ndim == 1:
        phi = phi[:, None]
    where = geometry.map_dofs(dofs)
    n_modes = phi.shape[1]
    disp = np.zeros((geometry.n_nodes, 3, n_modes), dtype=complex)
    known = np.zeros((geometry.n_nodes, 3), dtype=bool)
    ok = where.node_index >= 0
    disp[where.node_index[ok], where.axis[ok]] = phi[ok] * where.sign[ok, None]
    known[where.node_index[ok], where.axis[ok]] = True
    index = {int(n): k for k, n in enumerate(geometry.node_ids)}
    total = np.zeros_like(disp)
    count = np.zeros((geometry.n_nodes, 3))
    for line in geometry.lines:
        idx = np.array([index[n] for n in line])
        steps = np.linalg.norm(np.diff(geometry.xyz_m[idx], axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(steps)])
        for axis in range(3):
            have = known[idx, axis]
            if have.sum() < 2:
                continue
            inside = ~have & (s > s[have].min()) & (s < s[have].max())
            for j in np.flatnonzero(inside):
                lo = np.flatnonzero(have & (s <= s[j]))[-1]
                hi = np.flatnonzero(have & (s >= s[j]))[0]
                w = 0.0 if s[hi] == s[lo] else (s[j] - s[lo]) / (s[hi] - s[lo])
                total[idx[j], axis] += (1 - w) * disp[idx[lo], axis] + w * disp[idx[hi], axis]
                count[idx[j], axis] += 1
    fill = (count > 0) & ~known
    disp[fill] = total[fill] / count[fill][:, None]
    return disp, known


def _normalised(disp: np.ndarray) -> np.ndarray:
    """Each mode scaled so that its largest node component is 1 (real, positive):
    relative amplitudes and phases unchanged."""
    flat = disp.reshape(-1, disp.shape[-1])
    peak = flat[np.argmax(np.abs(flat), axis=0), np.arange(flat.shape[1])]
    peak = np.where(np.abs(peak) > 0, peak, 1.0)
    return disp / peak


def _project(xyz: np.ndarray, view: str = "iso") -> np.ndarray:
    """2-D screen coordinates (y down) of 3-D points; the same formulas as the script."""
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    if view == "xy":
        return np.stack([x, -y], axis=-1)
    if view == "xz":
        return np.stack([x, -z], axis=-1)
    if view == "yz":
        return np.stack([y, -z], axis=-1)
    c = np.cos(np.pi / 6)
    return np.stack([(x - y) * c, (x + y) * 0.5 - z], axis=-1)


def _size(geometry: Geometry) -> float:
    extent = np.ptp(geometry.xyz_m, axis=0).max()
    return float(extent) if extent > 0 else 1.0


def shape_data(geometry: Geometry, modes: Mapping[str, ModeSet]) -> dict:
    """The JSON the script animates: nodes (m), lines and surfaces (node
    indices), the model size, and per mode of each set its number, frequency,
    damping, the complex displacement of every node (``d``: per node Re x, y, z
    then Im x, y, z, normalised to a largest component of 1) and the indices of
    the measured nodes (``m``)."""
    index = {int(n): k for k, n in enumerate(geometry.node_ids)}
    out: dict = {
        "nodes": np.round(geometry.xyz_m, 6).tolist(),
        "ids": geometry.node_ids.tolist(),
        "lines": [[index[n] for n in line] for line in geometry.lines],
        "surfaces": [[index[n] for n in s] for s in geometry.surfaces],
        "size": _size(geometry),
        # a model in the XZ plane (a beam along x, bending in z) is seen from the front
        "view": "xz" if np.ptp(geometry.xyz_m[:, 1]) == 0 else "iso",
        "share": AMPLITUDE_SHARE,
        "modes": [],
    }
    for label, ms in modes.items():
        disp, _ = interpolated_displacements(geometry, ms.shapes, ms.dofs)
        disp = _normalised(disp)
        measured_map = geometry.map_dofs(ms.dofs if ms.measured is None else ms.measured)
        measured = sorted({int(i) for i in measured_map.node_index if i >= 0})
        for k in range(disp.shape[-1]):
            d = np.concatenate([disp[:, :, k].real, disp[:, :, k].imag], axis=1)
            out["modes"].append({
                "set": label, "n": k + 1, "fn": round(float(ms.fn_hz[k]), 6),
                "zeta": round(float(ms.zeta[k]), 8),
                "d": np.round(d, DECIMALS).ravel().tolist(), "m": measured,
            })
    return out


def _fit(points: np.ndarray, pad: float) -> tuple[float, float, float]:
    """Scale and offsets that fit projected points (padded by ``pad``) in a view."""
    lo, hi = points.min(axis=0) - pad, points.max(axis=0) + pad
    span = np.maximum(hi - lo, 1e-12)
    scale = min((VIEW_W - 8) / span[0], (VIEW_H - 8) / span[1])
    ox = (VIEW_W - scale * (lo[0] + hi[0])) / 2
    oy = (VIEW_H - scale * (lo[1] + hi[1])) / 2
    return float(scale), float(ox), float(oy)


def _points(xy: np.ndarray, idx: Sequence[int]) -> str:
    return " ".join(f"{xy[i, 0]:.1f},{xy[i, 1]:.1f}" for i in idx)


def _view_svg(data: dict, mode: dict) -> str:
    """One mode's SVG at t = 0 (the static frame), default projection and scale."""
    xyz = np.asarray(data["nodes"], dtype=float)
    d = np.asarray(mode["d"], dtype=float).reshape(-1, 6)
    amp = data["share"] * data["size"]
    base = _project(xyz, data["view"])
    scale, ox, oy = _fit(base, amp)
    to_px = np.array([scale, scale])
    shift = np.array([ox, oy])
    rest = base * to_px + shift
    moved = _project(xyz + amp * d[:, :3], data["view"]) * to_px + shift
    measured = set(mode["m"])
    parts = ['<g class="rest">']
    parts += [f'<polygon points="{_points(rest, s)}"/>' for s in data["surfaces"]]
    parts += [f'<polyline points="{_points(rest, ln)}"/>' for ln in data["lines"]]
    parts.append('</g><g class="moved">')
    parts += [f'<polygon points="{_points(moved, s)}"/>' for s in data["surfaces"]]
    parts += [f'<polyline points="{_points(moved, ln)}"/>' for ln in data["lines"]]
    parts += [
        f'<circle cx="{moved[i, 0]:.1f}" cy="{moved[i, 1]:.1f}" r="2.2"'
        + ("" if i in measured else ' class="open"') + "/>"
        for i in range(len(xyz))
    ]
    parts.append("</g>")
    return (f'<svg class="shape" viewBox="0 0 {VIEW_W} {VIEW_H}" role="img" '
            f'aria-label="mode {mode["n"]} shape">' + "".join(parts) + "</svg>")


_CSS = """
.shape-views .shape-controls{font-size:.85em;margin:.3em 0;display:flex;flex-wrap:wrap;gap:.3em 1em;
align-items:center}
.shape-grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(230px,1fr));gap:.4em}
.shape-grid.paired{grid-template-columns:repeat(var(--cols),minmax(0,1fr))}
.shape-grid .head{font-weight:600;font-size:.85em;align-self:end}
figure.shape-view{margin:0;border:1px solid #dde5ee;border-radius:3px;padding:2px}
figure.shape-view figcaption{font-size:.8em}
svg.shape{display:block;width:100%;height:auto}
svg.shape .rest polyline{fill:none;stroke:#bbb;stroke-width:1}
svg.shape .rest polygon{fill:#f2f2f2;stroke:none}
svg.shape .moved polyline{fill:none;stroke:#1f4e79;stroke-width:1.6}
svg.shape .moved polygon{fill:#1f4e79;fill-opacity:.12;stroke:none}
svg.shape circle{fill:#1f4e79;stroke:#1f4e79;stroke-width:1}
svg.shape circle.open{fill:#fff}
@media print{.shape-views .shape-controls{display:none}figure.shape-view{break-inside:avoid}}
"""

# The animation (report/js/shape_views.js): every .shape-views group reads its JSON
# and redraws its views (W, H: the view size; the projections are those of _project).
_SCRIPT = page_script("shape_views.js", VIEW_W=VIEW_W, VIEW_H=VIEW_H)


def _controls() -> str:
    return (
        '<div class="shape-controls">'
        '<label>amplitude <input class="sv-scale" type="range" min="0" max="3" step="0.1" '
        'value="1"></label>'
        '<label>speed <input class="sv-speed" type="range" min="0.05" max="2" step="0.05" '
        'value="0.5"></label>'
        '<label>view <select class="sv-view"><option value="iso">isometric</option>'
        '<option value="xy">top (XY)</option><option value="xz">front (XZ)</option>'
        '<option value="yz">side (YZ)</option></select></label>'
        '<button type="button" class="sv-pause">pause</button></div>'
    )


def _json_script(data: dict) -> str:
    text = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return f'<script type="application/json" class="shape-data">{text}</script>'


def _note(geometry: Geometry, missing: Sequence[DOF]) -> str:
    text = (f"Geometry: {geometry.n_nodes} nodes, {len(geometry.lines)} trace lines"
            + (f", {len(geometry.surfaces)} surfaces" if geometry.surfaces else "")
            + (f" ({geometry.source})" if geometry.source else "")
            + ". Grey: undeformed; blue: the mode over one cycle, Re(phi exp(i w t)) "
            "(complex shapes move with their phases). Filled dots: measured nodes; hollow: "
            "not measured, interpolated along the trace lines between measured nodes, or at "
            "rest at the end of a line.")
    out = f'<p class="muted">{esc(text)}</p>'
    if missing:
        out += ('<div class="problems"><p>Measured DOFs with no node in the geometry '
                "(not drawn): " + esc(", ".join(d.label() for d in missing)) + "</p></div>")
    return out


def _group(data: dict, body: str, note: str) -> str:
    return (f'<div class="shape-views"><style>{_CSS}</style>{note}{_controls()}{body}'
            f"{_json_script(data)}<script>{_SCRIPT}</script></div>")


def _figure(data: dict, key: int, caption: str) -> str:
    mode = data["modes"][key]
    return (f'<figure class="shape-view" data-mode-shape="{mode["n"]}" data-key="{key}">'
            f"{_view_svg(data, mode)}<figcaption>{esc(caption)}</figcaption></figure>")


def missing_dofs(geometry: Geometry, dofs: Sequence[DOF]) -> tuple[DOF, ...]:
    """The DOFs that :meth:`~ema_pipeline.data.Geometry.map_dofs` cannot place."""
    return geometry.map_dofs(dofs).missing


def shape_views_html(geometry: Geometry, modes: ModeSet) -> str:
    """The animated shapes of one result: one view per mode, numbered from 1 in
    the order of ``modes``, with the controls, the JSON and the script."""
    data = shape_data(geometry, {"": modes})
    body = "".join(
        _figure(data, k, f"Mode {m['n']}: {m['fn']:.2f} Hz, zeta {100 * m['zeta']:.3g} %")
        for k, m in enumerate(data["modes"])
    )
    return _group(data, f'<div class="shape-grid">{body}</div>',
                  _note(geometry, missing_dofs(geometry, modes.dofs)))


def shape_preview_html(geometry: Geometry, modes: ModeSet) -> str:
    """One animated view for a preview (``figure.shape-view[data-preview-shape]``,
    drawn at first with the first mode of ``modes``), with the controls, the
    JSON of every mode and the script. A page shows another mode in it by
    setting the figure's ``data-key`` (the mode's index in ``modes``) and
    sending the group (``.shape-views``) a ``shape-key`` event.

    Examples
    --------
    >>> g = Geometry(node_ids=[1, 2, 3], xyz_m=[[0, 0, 0], [1, 0, 0], [2, 0, 0]],
    ...              lines=((1, 2, 3),))
    >>> phi = np.array([[1.0, 1.0], [0.0, -1.0], [-1.0, 1.0]])
    >>> page = shape_preview_html(g, ModeSet(np.array([10.0, 20.0]), np.array([0.01, 0.01]),
    ...                                      phi, (DOF(1), DOF(2), DOF(3))))
    >>> page.count("data-preview-shape"), page.count('class="shape-view"')
    (1, 1)
    """
    data = shape_data(geometry, {"": modes})
    missing = missing_dofs(geometry, modes.dofs)
    note = ('<div class="problems"><p>Measured DOFs with no node in the geometry (not drawn): '
            + esc(", ".join(d.label() for d in missing)) + "</p></div>" if missing else "")
    figure = (f'<figure class="shape-view" data-preview-shape="" data-key="0">'
              f"{_view_svg(data, data['modes'][0])}<figcaption></figcaption></figure>")
    return _group(data, figure, note)


def paired_shape_views_html(
    geometry: Geometry,
    sets: Mapping[str, ModeSet],
    pairs: Mapping[str, Sequence[int]],
    reference: str,
) -> str:
    """Modes of several configurations side by side: one row per mode of
    ``reference``, one column per configuration; ``pairs[name][r]`` is the index
    (0-based) of the mode of ``name`` paired with the reference's mode ``r``
    (-1: none, an empty cell). Each view carries its own mode number."""
    data = shape_data(geometry, sets)
    keys = {(m["set"], m["n"] - 1): k for k, m in enumerate(data["modes"])}
    names = list(sets)
    cells = [f'<div class="head">{esc(n)}</div>' for n in names]
    n_ref = sets[reference].fn_hz.size
    for r in range(n_ref):
        for name in names:
            j = r if name == reference else int(pairs.get(name, [-1] * n_ref)[r])
            if j < 0 or (name, j) not in keys:
                cells.append('<div class="muted">no paired mode</div>')
                continue
            m = data["modes"][keys[(name, j)]]
            cap = f"{name}: mode {m['n']}, {m['fn']:.2f} Hz"
            if name != reference:
                cap += f" (pairs {reference} mode {r + 1})"
            cells.append(_figure(data, keys[(name, j)], cap))
    missing = sorted({d for s in sets.values() for d in missing_dofs(geometry, s.dofs)},
                     key=lambda d: (d.node, d.direction))
    body = (f'<div class="shape-grid paired" style="--cols:{len(names)}">'
            + "".join(cells) + "</div>")
    return _group(data, body, _note(geometry, missing))
