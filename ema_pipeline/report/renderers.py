"""The report pages: a study (``run``), one FRF file (``identify --report``) and
a batch (``batch --report``), as self-contained HTML, and the study as Markdown.

Every string that comes from data (configuration and file names, problems,
settings) goes through :func:`.htmlparts.esc`; figures are inline SVG.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import PurePath
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ema_pipeline.added_mass.modal import pair_modes as pair_configurations
from ema_pipeline.data import FRFSet, Geometry
from ema_pipeline.identification.common import ends_at_usable_top
from ema_pipeline.identification.selection.edge_poles import edge_message
from ema_pipeline.identification.selection.not_kept import not_kept_message
from ema_pipeline.report import figures as figs
from ema_pipeline.report.fit_noise import noise_error
from ema_pipeline.report.htmlparts import (
    Page,
    esc,
    figure,
    item_list,
    kv_table,
    no_figures,
    provenance,
)
from ema_pipeline.report.inputs import BatchReportInput, ReportInput
from ema_pipeline.report.page_figures import identification_figures, safe_name
from ema_pipeline.report.result_tables import (
    COLUMN_TITLES,
    cross_mac_html,
    dof_labels,
    fit_table,
    mac_section,
    mode_table,
    mode_table_html,
    report_tables,
    setup_table,
)
from ema_pipeline.report.shape_views import (
    MIN_SHAPE_DOFS,
    ModeSet,
    paired_shape_views_html,
    shape_dof_count,
    shape_views_html,
)
from ema_pipeline.report.stab_diagram import stab_diagram_html
from ema_pipeline.report.tables import TABLE_TITLES, html_table, markdown_table
from ema_pipeline.report.trends import PAIRING, pair_modes
from ema_pipeline.report.wording import (
    fit_grade,
    fit_limits_text,
    fit_noise_text,
    fit_noise_verdict,
    fit_verdict,
    model_text,
    plural,
)

if TYPE_CHECKING:  # pragma: no cover
    from ema_pipeline.identification.result import IdentificationResult

__all__ = [
    "render_batch_html",
    "render_html",
    "render_identify_html",
    "render_markdown",
    "tables_heading",
]


# --------------------------------------------------------------------------
# The study: run
# --------------------------------------------------------------------------


def _summary_study(report: ReportInput) -> str:
    n_prob = len(report.problems)
    errors = {name: float(np.mean(r.error)) for name, r in report.identification.items()}
    not_good = [f"{name}: {fit_verdict(e)}" for name, e in errors.items()
                if fit_grade(e) != "good"]
    if n_prob:
        status = (f'<p class="status bad">{plural(n_prob, "problem")}: see the list below; '
                  "what could be computed is shown.</p>")
    elif not_good:
        status = ('<p class="status">Every configuration identified, no problems, but not '
                  f"every fit is good: {esc('; '.join(not_good))}.</p>")
    else:
        status = ('<p class="status ok">Complete: every configuration identified, no problems, '
                  "every fit good.</p>")
    status += _limits_note()

    what = []
    g = report.geometry
    if g is not None:
        what.append(
            f"Cantilever beam, L = {g.length_m:g} m, measured at nodes "
            f"{', '.join(str(n) for n in g.response_nodes)} (accelerometers, "
            f"{g.direction_label}) with the hammer at node {g.hammer_node}"
            + (f"; immersed element(s) {', '.join(map(str, g.immersed_elements))}"
               if g.immersed_elements else "")
            + "."
        )
    rows = []
    t2 = report.tables.get("table2_modal_added_mass")
    t6 = report.tables.get("table6_local_added_mass")
    for name in report.descriptions or report.identification:
        r = report.identification.get(name)
        desc = report.descriptions.get(name, "")
        if r is None:
            rows.append({"configuration": name, "description": desc,
                         "natural frequencies / Hz": "not identified"})
            continue
        row = {
            "configuration": name,
            "description": desc,
            "natural frequencies / Hz": ", ".join(f"{f:.2f}" for f in np.sort(r.modes.fn_hz)),
            "damping / %": ", ".join(f"{100 * z:.3f}" for z in r.modes.zeta[
                np.argsort(r.modes.fn_hz)]),
            "fit error / %": f"{100 * errors[name]:.2f} ({fit_grade(errors[name])})",
        }
        if t2 is not None and len(t2):
            sub = t2[t2["configuration"] == name]
            row["added mass m_ar/m_r"] = ", ".join(f"{v:.4f}" for v in sub["added_mass_ratio"])
        if t6 is not None and len(t6):
            sub = t6[(t6["configuration"] == name) & (t6["method"] == "block")]
            row["local delta_m (block, eq. 20)"] = ", ".join(f"{v:.4f}" for v in sub["delta_m"])
        rows.append(row)
    table = html_table(pd.DataFrame(rows).fillna(""), split=False) if rows else ""
    return (
        status + "".join(f"<p>{esc(w)}</p>" for w in what) + table
        + item_list(report.problems, "problems") + item_list(report.notes, "notes")
    )


def tables_heading(names: Sequence[str]) -> str:
    """The heading of the numbered tables present: ``Table 1``, ``Tables 1-3``,
    ``Tables 1, 2 and 5``.

    Examples
    --------
    >>> tables_heading(["table1_fn"]), tables_heading(["table1_a", "table2_b", "table3_c"])
    ('Table 1', 'Tables 1-3')
    >>> tables_heading(["table1_a", "table2_b", "table5_c"])
    'Tables 1, 2 and 5'
    """
    import re

    nums = sorted({int(m.group(1)) for n in names if (m := re.match(r"table(\d+)", n))})
    if not nums:
        return "Tables"
    if len(nums) == 1:
        return f"Table {nums[0]}"
    if nums == list(range(nums[0], nums[-1] + 1)):
        return f"Tables {nums[0]}-{nums[-1]}"
    return "Tables " + ", ".join(map(str, nums[:-1])) + f" and {nums[-1]}"


def _few_dofs_note(frf: FRFSet, n_dof: int) -> str:
    """Why a page with shapes of fewer than :data:`MIN_SHAPE_DOFS` points has
    no shapes and no AutoMAC."""
    why = ("every MAC between one-value shapes is 1" if n_dof == 1 else
           "two values hold at most two independent shapes, so the AutoMAC cannot "
           "tell more modes apart")
    return (f'<p class="muted">Each mode shape has {plural(n_dof, "measured point")} only '
            f'({plural(frf.n_out, "response")}, {plural(frf.n_in, "reference")}): a shape '
            f"needs at least {MIN_SHAPE_DOFS} points to be drawn or compared, so this report "
            f"has no shape views, no shape figure and no AutoMAC ({why}).</p>")


def _limits_note() -> str:
    """The fit verdict's limits, printed beside every verdict."""
    return f'<p class="muted">{esc(fit_limits_text())}</p>'


def _doubtful_note(results: Iterable[Any]) -> str:
    """Under the modes tables: where the doubtful rules are, unless the tables
    already name the rule that fired (``doubtful_reason``)."""
    if all("doubtful_reason" in mode_table(r) for r in results):
        return ""
    return ('<p class="muted">doubtful: marked for a second look by one of the rules '
            "of the identification (few stable orders, loose damping, complex shape, "
            "damping not resolved by the lines; README, Identification).</p>")


def _mode_set(report: ReportInput, result: Any) -> ModeSet:
    """The shapes to animate of one configuration: the pipeline's (expanded) set
    when given, else the identified shapes at the measured DOFs."""
    for name, r in report.identification.items():
        if r is result and name in report.shape_sets:
            return report.shape_sets[name]
    m = result.modes
    return ModeSet(m.fn_hz, m.zeta, m.shapes, m.dofs)


def _across(report: ReportInput, *, shapes: bool = True) -> str:
    """The MAC of every configuration against the reference one, and the animated
    shapes paired by frequency and MAC (``added_mass.modal.pair_modes``, as Table 2)."""
    ref = report.identification[report.genuine]
    out = [
        f'<p>Each configuration\'s modes against those of the reference configuration '
        f"<b>{esc(report.genuine)}</b>: MAC (modal assurance criterion; "
        "rows: reference modes) and, below, the shapes side by side, paired by frequency "
        "and MAC as in Table 2.</p>",
        cross_mac_html(report.identification, report.genuine),
    ]
    if report.test_geometry is None or not shapes:
        return "".join(out)
    order = [report.genuine, *[n for n in report.identification if n != report.genuine]]
    pairs: dict[str, list[int]] = {}
    for name in order[1:]:
        r = report.identification[name]
        same = r.modes.dofs == ref.modes.dofs
        partner, _ = pair_configurations(
            ref.modes.fn_hz, r.modes.fn_hz,
            shapes_a=ref.modes.shapes if same else None,
            shapes_b=r.modes.shapes if same else None,
        )
        pairs[name] = [int(j) for j in partner]
    sets = {name: _mode_set(report, report.identification[name]) for name in order}
    out.append(paired_shape_views_html(report.test_geometry, sets, pairs, report.genuine))
    return "".join(out)


def render_html(report: ReportInput, figures: Mapping[str, str] | None) -> str:
    """The self-contained HTML study report; ``figures`` from :func:`make_figures`
    (``None``: drawn without figures)."""
    fg = figures or {}
    page = Page(report.title)
    page.section("summary", "Summary").append(_summary_study(report))
    if report.frfs or report.test_info:
        sec = page.section("setup", "Test setup")
        if report.test_info:
            sec.append(kv_table(report.test_info, caption="The test"))
        if report.frfs:
            sec.append(html_table(setup_table(report.frfs, report.geometry), split=False))
    if report.hits:
        sec = page.section("hits", "Impact hits (configurations measured as recordings)")
        for name, table in report.hits.items():
            sec.append(html_table(table, caption=f"{name}: hits found and checked",
                                  split=False))
    if report.geometry is not None:
        g = report.geometry
        sec = page.section("geometry", "Geometry: sensors and hammer")
        sec.append(figure("geometry", fg, "Measurement mesh, accelerometers (squares), "
                           "hammer (arrow), immersed element(s) (blue)"))
        nodes = pd.DataFrame(
            [("accelerometer", n, g.node_x_m(n)) for n in g.response_nodes]
            + [("hammer", g.hammer_node, g.node_x_m(g.hammer_node))],
            columns=["role", "node", "x_m"],
        )
        sec.append(html_table(nodes))
    if report.frfs:
        sec = page.section("frf", "FRFs and coherence")
        sec.append(no_figures(figures))
        for name in report.frfs:
            sec.append(figure(f"frf_{safe_name(name)}", fg, f"|H| and coherence: {name}"))
        sec.append(figure("fig4_frf_overlay", fg, "FRF overlay of the configurations "
                           "(paper Fig. 4)"))
        sec.append(figure("fig5_zoom_mode2", fg, "Zoom on mode 2 (paper Fig. 5)"))
    if report.identification:
        sec = page.section("stabilization", "Stabilization diagrams")
        sec.append(no_figures(figures))
        drawn = 0  # the first diagram drawn holds the code the others call
        for k, (name, r) in enumerate(report.identification.items()):
            if name in report.frfs:  # interactive: pick poles, get a picks file
                sec.append(f"<h3>{esc(name)}</h3>" + stab_diagram_html(
                    report.frfs[name], r, picks_id="picks" if k == 0 else
                    f"picks-{safe_name(name)}", file_name=f"{safe_name(name)}_picks.toml",
                    geometry=report.test_geometry, mode_set=_mode_set(report, r),
                    with_code=drawn == 0))
                drawn += 1
            sec.append(figure(f"stabilization_{safe_name(name)}", fg,
                               f"Stabilization diagram: {name}"))
        sec = page.section("modes", "Modes (MPC, MPD, stable orders)")
        for name, r in report.identification.items():
            sec.append(f"<h3>{esc(name)}</h3>" + mode_table_html(r))
        sec.append(_doubtful_note(report.identification.values()))
        page.section("mac", "AutoMAC").append(
            mac_section(report.identification, report.genuine, cross=False)
        )
        if len(report.identification) > 1 and report.genuine in report.identification:
            page.section("across", "Modes across configurations").append(
                _across(report, shapes=figures is not None)
            )
        shapes: list[str] = []
        if (figures is not None and report.test_geometry is not None
                and len(report.identification) <= 1):
            for r in report.identification.values():
                shapes.append(shape_views_html(report.test_geometry, _mode_set(report, r)))
        if "mode_shapes" in fg:
            shapes.append(figure("mode_shapes", fg, "Measured mode shapes at the sensors vs "
                                 "the updated FE model"))
        if any(shapes):  # no empty section (no geometry, no figure)
            page.section("shapes", "Mode shapes").extend(shapes)
        sec = page.section("fit", "Measured vs synthesised FRFs")
        fits = fit_table(report.identification, report.frfs)
        if len(report.identification) == 1:  # the configuration named once, above
            sec.append(f'<p class="fit-of">The FRFs of {esc(next(iter(report.identification)))}'
                       ", each against its synthesis:</p>")
            fits = fits.drop(columns="configuration")
        sec.append(html_table(fits, titles=COLUMN_TITLES))
        sec.append(no_figures(figures))
        for name in report.identification:
            sec.append(figure(f"fit_{safe_name(name)}", fg, f"LSFD fit: {name}"))
    tables = report_tables(report)
    if tables:
        title = tables_heading(list(tables)) + (
            " beside the paper" if report.compare_with_paper else "")
        sec = page.section("tables", title)
        for name, table in tables.items():
            sec.append(f'<h3 id="{name}">{esc(TABLE_TITLES[name])}</h3>')
            sec.append(html_table(table))
            if name == "table2_modal_added_mass":
                sec.append(figure("modal_added_mass", fg, "Modal added mass per mode"))
    page.section("provenance", "Provenance").append(
        provenance(report.inputs, report.settings, report.version, report.generated)
    )
    return page.html()


def render_markdown(report: ReportInput, figures: Sequence[str]) -> str:
    """The Markdown report; figures are referenced as ``figures/<name>.svg``."""
    parts = [f"# {report.title}", ""]
    if report.problems:
        parts += ["## Problems", ""] + [f"- {p}" for p in report.problems] + [""]
    if report.notes:
        parts += ["## Notes", ""] + [f"- {n}" for n in report.notes] + [""]
    if report.frfs:
        parts += ["## Test setup", "", markdown_table(setup_table(report.frfs,
                                                                   report.geometry)), ""]
    for name, r in report.identification.items():
        parts += [f"## Modes: {name}", "", markdown_table(mode_table(r)), ""]
    if report.identification:
        parts += ["## Fit quality", "",
                  markdown_table(fit_table(report.identification, report.frfs)), ""]
        parts += [f"- {name}: {fit_verdict(float(np.mean(r.error)))}"
                  for name, r in report.identification.items()]
        parts += [f"- limits: {fit_limits_text()}", ""]
    for name, table in report_tables(report).items():
        parts += [f"## {TABLE_TITLES[name]}", "", markdown_table(table), ""]
    if figures:
        parts += ["## Figures", ""]
        parts += [f"![{name}](figures/{name}.svg)" for name in figures]
        parts.append("")
    if report.inputs:
        parts += ["## Provenance", "", "| input | path | sha256 |", "|---|---|---|"]
        parts += [f"| {r} | {p} | {s} |" for r, p, s in report.inputs]
        parts += ["", f"ema-pipeline {report.version}, generated {report.generated}", ""]
    return "\n".join(parts)


# --------------------------------------------------------------------------
# One file: identify --report
# --------------------------------------------------------------------------


def render_identify_html(
    frf: FRFSet,
    result: IdentificationResult,
    *,
    settings: Mapping[str, str] | None = None,
    version: str = "",
    generated: str = "",
    figures: bool = True,
    geometry: Geometry | None = None,
    batch_page: str = "",
    picks: tuple[str, str] | None = None,
) -> str:
    """The report of one identified FRF file: the study report's sections that
    apply to a single file (no FE or paper tables); with ``geometry`` the modes
    are animated on it (:mod:`.shape_views`); ``batch_page``: the link (URL) of
    the batch page this page belongs to (``batch --report``), shown on top;
    ``picks``: the picks file the modes were fitted from and its sha256, named
    in the summary and the provenance. The file's path is given once on top
    (summary, test setup, provenance); the figures, the AutoMAC and the fit
    table name the file by its configuration or its file name."""
    name = frf.configuration or frf.source.path or "FRF set"
    short = frf.configuration or (PurePath(frf.source.path).name if frf.source.path
                                  else "FRF set")
    fg: dict[str, str] = {}
    n_dof = shape_dof_count(frf)
    few = n_dof < MIN_SHAPE_DOFS
    if figures:
        identification_figures("one", frf, result, fg, short)
    if figures and not few:
        fg["shapes_one"] = figs.figure_shapes_by_dof(result, dof_labels(frf)[0])
    page = Page(f"Modal identification: {frf.source.path or name}")
    m, st = result.modes, result.settings
    error = float(np.mean(result.error))
    noise = noise_error(frf.band(*st.band_hz).H, np.asarray(result.H_fit))
    noise_mean = float(np.mean(noise)) if np.all(np.isfinite(noise)) else float("nan")
    summary = pd.DataFrame(
        {
            "": ["file", *(["configuration"] if frf.configuration else []), "modes",
                 "natural frequencies / Hz", "fit quality", "model",
                 *(["modes selected by"] if picks is not None else [])],
            "value": [frf.source.path or "(in memory)",
                      *([frf.configuration] if frf.configuration else []), str(m.n_modes),
                      ", ".join(f"{f:.3f}" for f in np.sort(m.fn_hz)),
                      fit_noise_verdict(error, noise_mean),
                      model_text(st.band_hz, st.orders, st.lower_residual, st.upper_residual,
                                 to_usable_top=ends_at_usable_top(frf, st.band_hz)),
                      *([f"hand, picks file {picks[0]} (sha256 {picks[1]})"]
                        if picks is not None else [])],
        }
    )
    up = (f'<p><a class="batch-page" href="{esc(batch_page)}">Back to the batch report</a>'
          "</p>" if batch_page else "")
    page.section("summary", "Summary").append(
        up + html_table(summary, split=False)
        + (f'<p class="muted">{esc(fit_noise_text())}.</p>' if np.isfinite(noise_mean)
           else _limits_note())
    )
    page.section("setup", "Test setup").append(
        html_table(setup_table({short: frf}, None), split=False)
    )
    no = no_figures(None if not figures else fg)
    page.section("frf", "FRFs and coherence").append(
        no + figure("frf_one", fg, f"|H| and coherence: {short}")
    )
    page.section("stabilization", "Stabilization diagram").append(
        stab_diagram_html(frf, result, geometry=geometry)
        + no + figure("stabilization_one", fg, "Stabilization diagram")
    )
    notes = [not_kept_message(result.not_kept_hz, result.not_kept_frfs, frf.n_out * frf.n_in),
             edge_message(result.edge_hz, result.settings.band_hz,
                          thresholds=result.settings.thresholds)]
    page.section("modes", "Modes (MPC, MPD, stable orders)").append(
        mode_table_html(result) + _doubtful_note([result])
        + item_list([note for note in notes if note], "notes")
        + (_few_dofs_note(frf, n_dof) if few else "")
    )
    if not few:
        page.section("mac", "AutoMAC").append(mac_section({short: result}, short))
        shapes = []
        if figures and geometry is not None and m.shapes is not None:
            shapes.append(shape_views_html(geometry,
                                           ModeSet(m.fn_hz, m.zeta, m.shapes, m.dofs)))
        shapes.append(figure("shapes_one", fg,
                             "Real-normalised mode shapes at the measured DOFs")
                      if figures else "")
        if any(shapes):
            page.section("shapes", "Mode shapes").extend(shapes)
    sec = page.section("fit", "Measured vs synthesised FRFs")
    sec.append(f'<p class="fit-of">The FRFs of {esc(short)}, each against its synthesis:</p>')
    sec.append(html_table(fit_table({name: result}, {name: frf}).drop(columns="configuration"),
                          titles=COLUMN_TITLES))
    sec.append(no + figure("fit_one", fg, "LSFD fit"))
    inputs = [("FRF file", frf.source.path, frf.source.sha256)]
    if picks is not None:
        inputs.append(("picks file", picks[0], picks[1]))
    page.section("provenance", "Provenance").append(
        provenance(inputs, dict(settings or {}), version, generated)
    )
    return page.html()


# --------------------------------------------------------------------------
# A batch: batch --report
# --------------------------------------------------------------------------


def _frequencies(cell: Any) -> list[float]:
    if cell is None or (isinstance(cell, float) and np.isnan(cell)) or str(cell) == "":
        return []
    return [float(v) for v in str(cell).split(";") if v]


def _usable_shapes(
    freqs: list[list[float]], shapes: list[np.ndarray | None] | None
) -> list[np.ndarray | None] | None:
    """The shapes that have one column per frequency of their row (else None)."""
    if shapes is None:
        return None
    return [
        sh if sh is not None and np.ndim(sh) == 2 and np.shape(sh)[1] == len(f) else None
        for f, sh in zip(freqs, shapes, strict=True)
    ]


def render_batch_html(batch: BatchReportInput, *, figures: bool = True) -> str:
    """One page over a batch: status per file (with the failure reason), modes
    per file, each mode's frequency across the files."""
    s = batch.summary.copy()
    reasons = dict(zip(batch.failures.get("file", []), batch.failures.get("reason", []),
                       strict=False))
    page = Page(batch.title)
    counts = s["status"].value_counts() if len(s) else pd.Series(dtype=int)
    n_failed = int(counts.get("failed", 0))
    state = "interrupted; " if batch.interrupted else ""
    cls = "bad" if n_failed or batch.interrupted else "ok"
    head = (
        f'<p class="status {cls}">{state}{plural(len(s), "file")}: {int(counts.get("ok", 0))} ok, '
        f'{int(counts.get("skipped", 0))} skipped, {n_failed} failed'
        + (f" in {batch.seconds:.1f} s" if np.isfinite(batch.seconds) else "") + "</p>"
        + f"<p>Input folder: <code>{esc(batch.folder)}</code></p>"
    )
    page.section("summary", "Summary").append(head)
    if n_failed:
        failed = s[s["status"] == "failed"]
        ft = pd.DataFrame({"file": failed["file"],
                           "reason": [reasons.get(f, "") for f in failed["file"]]})
        page.section("failures", "Failed files").append(html_table(ft))
    if "warnings" in s:  # what identify warned about a file (resonances not kept, ...)
        # an all-empty column reads back as NaN (float)
        warned = s[[isinstance(w, str) and bool(w) for w in s["warnings"]]]
        if len(warned):
            page.section("warnings", "Warnings").append(html_table(
                pd.DataFrame({"file": warned["file"], "warnings": warned["warnings"]})))
    freqs = [_frequencies(c) for c in s.get("frequencies_hz", [])]
    shapes = batch.shapes if batch.shapes is not None and len(batch.shapes) == len(s) else None
    paired = pair_modes(freqs, _usable_shapes(freqs, shapes))
    table = pd.DataFrame({"#": np.arange(1, len(s) + 1), "file": s["file"],
                          "status": s["status"], "configuration": s.get("configuration", "")})
    for k in range(paired.shape[1]):
        table[f"f{k + 1}_hz"] = paired[:, k]
    if "fit_error_pct" in s:
        table["fit_error_pct"] = pd.to_numeric(s["fit_error_pct"], errors="coerce")
    elif "fit_error" in s:  # a summary.csv of an earlier version: a ratio
        table["fit_error_pct"] = 100 * pd.to_numeric(s["fit_error"], errors="coerce")
    if "fit_error_pct" in table:
        table["fit"] = [fit_grade(v / 100) for v in table["fit_error_pct"]]
    table = table.fillna({"configuration": ""})
    page.section("files", "Status and modes per file").append(
        html_table(table)
        + f'<p class="muted">f1_hz, f2_hz, ...: each file\'s modes paired across the files by '
        f"frequency (within {100 * PAIRING.max_shift:g} %) and MAC (at least "
        f"{PAIRING.min_mac:g}{'' if shapes is not None else ', when the shapes are known'}), "
        "not by their index; an empty cell: the file lacks that mode. "
        f"{esc(fit_limits_text())}.</p>"
        + ('<p class="muted">Failed files and why: see above.</p>' if n_failed else "")
    )
    pages = batch.pages if batch.pages is not None and len(batch.pages) == len(s) else None
    if pages is not None and any(pages):
        links = "".join(
            f'<li value="{k + 1}"><a class="file-page" href="{esc(href)}">{esc(str(f))}</a></li>'
            for k, (f, href) in enumerate(zip(s["file"], pages, strict=True)) if href
        )
        page.section("pages", "Report page of each file").append(
            '<p class="muted">Each file\'s modes, animated mode shapes, interactive '
            "stabilization diagram (pick poles, get a picks file) and fit, as "
            "<code>identify --report</code> writes them, from its stored result; numbers "
            f"as in the table above.</p><ol class=\"file-pages\">{links}</ol>"
        )
    sec = page.section("trend", "Each mode's frequency across the files")
    if figures:
        sec.append(
            '<figure id="fig-batch_frequencies">'
            + figs.figure_batch_frequencies([str(f) for f in s["file"]], paired)
            + "<figcaption>Deviation of each file's natural frequency from the mode's median "
            "(red: outliers; modes paired as in the table above); file numbers as in the "
            "table above.</figcaption></figure>"
        )
    else:
        sec.append(no_figures(None))
    inputs = [("FRF file", str(f), str(h) if isinstance(h, str) else "")
              for f, h in zip(s["file"], s.get("sha256", [""] * len(s)), strict=False)]
    page.section("provenance", "Provenance").append(
        provenance(inputs, batch.settings, batch.version, batch.generated)
    )
    return page.html()
