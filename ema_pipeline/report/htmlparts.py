"""The HTML building blocks of the report pages: the page with its style sheet
and table of contents (:class:`Page`), figures with captions, lists, key/value
tables and the provenance section. Every text goes through :func:`esc`.

Named ``htmlparts`` so as not to shadow the standard library's :mod:`html`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from html import escape

import pandas as pd

from ema_pipeline.report.wording import setting_text

__all__ = [
    "Page",
    "esc",
    "figure",
    "item_list",
    "kv_table",
    "no_figures",
    "provenance",
]

_CSS = """
*{box-sizing:border-box}
body{font:15px/1.45 system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:0 auto;
max-width:1000px;color:#222;padding:0 14px 3em}
h1{color:#1f4e79;border-bottom:2px solid #1f4e79;padding-bottom:.2em;font-size:1.6em}
h2{color:#1f4e79;margin-top:1.8em;border-bottom:1px solid #c9d6e3}
h3{margin:1.2em 0 .3em;font-size:1.05em}
nav.toc{font-size:.9em;background:#f4f8fb;padding:.4em .8em;border-radius:4px}
nav.toc a{margin-right:.9em;white-space:nowrap}
.tablewrap{max-width:100%;overflow-x:auto;margin:.4em 0 1.1em}
table{border-collapse:collapse;font-size:.86em}
caption{text-align:left;font-weight:600;padding:.2em 0}
th,td{border:1px solid #ccc;padding:.2em .45em;text-align:left;vertical-align:top}
th{background:#eef3f8;font-weight:600}
td{overflow-wrap:anywhere}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
td.pm{white-space:normal;overflow-wrap:normal}
td.hash,td.path{font-family:ui-monospace,Menlo,Consolas,monospace;font-size:.92em;
word-break:break-all}
table.mac th,table.mac td{padding:.15em .3em;overflow-wrap:normal}
.matwrap{container-type:inline-size}
table.mac{table-layout:fixed;font-size:min(.86em,calc(100cqw / var(--cols) / 4.5))}
pre{white-space:pre-wrap;overflow-wrap:anywhere}
figure{margin:.8em 0 1.6em;break-inside:avoid;page-break-inside:avoid}
svg.fig{display:block;width:100%;max-width:720px;height:auto}
figcaption{font-size:.88em;color:#555}
.status{padding:.5em .9em;border-radius:4px;font-weight:600}
.ok{background:#eaf6ec;border-left:5px solid #2e8b3a}
.bad{background:#fff3f3;border-left:5px solid #c0504d}
.problems{background:#fff3f3;border-left:4px solid #c0504d;padding:.3em 1em}
.notes{background:#f4f8fb;border-left:4px solid #1f4e79;padding:.3em 1em}
.muted{color:#777}
@media print{
 @page{size:A4;margin:14mm}
 body{font-size:10pt;max-width:none;padding:0}
 nav.toc{display:none}
 h2{break-after:avoid;page-break-after:avoid}
 h3{break-after:avoid}
 .tablewrap{overflow:visible}
 table{font-size:8pt;break-inside:auto}
 tr,figure,svg.fig{break-inside:avoid;page-break-inside:avoid}
 svg.fig{max-width:100%}
 a{color:inherit;text-decoration:none}
}
"""


def esc(text: str) -> str:
    """``text`` as HTML-escaped text (anything is first turned into ``str``)."""
    return escape(str(text))


class Page:
    """Sections collected in order, with a table of contents."""

    def __init__(self, title: str) -> None:
        self.title = title
        self.sections: list[tuple[str, str, list[str]]] = []

    def section(self, ident: str, title: str) -> list[str]:
        parts: list[str] = []
        self.sections.append((ident, title, parts))
        return parts

    def html(self) -> str:
        toc = " ".join(f'<a href="#{esc(i)}">{esc(t)}</a>' for i, t, _ in self.sections)
        body = "".join(
            f'<section id="{esc(i)}"><h2>{esc(t)}</h2>{"".join(parts)}</section>'
            for i, t, parts in self.sections
        )
        return (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            '<meta name="viewport" content="width=device-width,initial-scale=1">'
            f"<title>{esc(self.title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{esc(self.title)}</h1><nav class=\"toc\">{toc}</nav>{body}</body></html>\n"
        )


def figure(name: str, figures: Mapping[str, str], caption: str) -> str:
    """The figure ``name`` of ``figures`` with its caption; empty when not drawn."""
    svg = figures.get(name)
    if svg is None:
        return ""
    return f'<figure id="fig-{esc(name)}">{svg}<figcaption>{esc(caption)}</figcaption></figure>'


def no_figures(figures: Mapping[str, str] | None) -> str:
    """The note that figures were not drawn when ``figures`` is ``None``, else empty."""
    return '<p class="muted">Figures not drawn (--no-figures).</p>' if figures is None else ""


def item_list(items: Sequence[str], cls: str) -> str:
    """A bulleted list in a box of CSS class ``cls``; empty without items."""
    if not items:
        return ""
    return f'<div class="{cls}"><ul>' + "".join(f"<li>{esc(x)}</li>" for x in items) + "</ul></div>"


def kv_table(rows: Mapping[str, str], caption: str = "", cls: str = "") -> str:
    """A two-column key/value table; ``cls`` is the CSS class of the value cells."""
    attr = f' class="{cls}"' if cls else ""
    body = "".join(f"<tr><th>{esc(k)}</th><td{attr}>{esc(v)}</td></tr>" for k, v in rows.items())
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    return f'<div class="tablewrap"><table>{cap}<tbody>{body}</tbody></table></div>'


def provenance(
    inputs: Sequence[tuple[str, str, str]], settings: Mapping[str, str], version: str,
    generated: str,
) -> str:
    """The provenance section: input files ``(role, path, sha256)``, software
    versions and the settings (an unset one as what it means:
    :func:`~ema_pipeline.report.wording.setting_text`)."""
    settings = {k: setting_text(k, v) for k, v in settings.items()}
    rows = "".join(
        f'<tr><td>{esc(role)}</td><td class="path">{esc(path)}</td>'
        f'<td class="hash">{esc(sha)}</td></tr>'
        for role, path, sha in inputs
    )
    import platform

    import numpy
    import scipy

    software = {
        "ema-pipeline": version,
        "Python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "pandas": pd.__version__,
        "report generated": generated,
    }
    return (
        '<h3>Input files</h3><div class="tablewrap"><table class="inputs"><thead><tr>'
        "<th>input</th><th>path</th><th>sha256</th></tr></thead>"
        f"<tbody>{rows}</tbody></table></div>"
        + "<h3>Software</h3>" + kv_table(software)
        + ("<h3>Settings</h3>" + kv_table(settings) if settings else "")
    )
