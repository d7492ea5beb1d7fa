"""A `Report` as one self-contained HTML page (figures inline as data URIs), styled for the
screen and for print: the PDF is this page printed by Chromium (`_pdf`), so the CSS carries the
page layout: A4, the report's name in the header margin, "Page n of N" in the footer, headings
kept with what follows, figures, cards and short tables never split across pages.

Every value is a `<span class="v" data-key="[path as JSON]" data-fmt="spec">text</span>`: the
tests look each one up in the JSON and compare the text with the value formatted by `data-fmt`.
"""

import base64
import html
import json
from collections.abc import Mapping, Sequence

from .report_model import (
    Bullets, Figure, Heading, Highlights, Inline, Paragraph, Report, Table, Value, format_value, lookup)

SHORT_TABLE_ROWS = 24  # tables up to this many rows are kept on one page

CSS = """
:root{--ink:#1b1f24;--muted:#5b6570;--rule:#d0d7de;--accent:#1f4e79;--warn:#9a3412}
body{font-family:"DejaVu Sans","Liberation Sans",Arial,sans-serif;color:var(--ink);max-width:1060px;
margin:24px auto;padding:0 24px;font-size:14px;line-height:1.45;counter-reset:section;
font-variant-ligatures:none}
h1{font-size:25px;color:var(--accent);margin:0 0 4px}
.subtitle{color:var(--muted);margin:0 0 14px}
h2{counter-increment:section;color:var(--accent);font-size:19px;border-bottom:2px solid var(--accent);
margin:30px 0 10px;padding-bottom:2px;break-after:avoid}
h2::before{content:counter(section) "\\2003"}
h3{font-size:15px;margin:18px 0 6px;break-after:avoid}
p{margin:6px 0 8px}
nav.toc{border:1px solid var(--rule);border-radius:6px;padding:6px 14px;margin:10px 0 6px;font-size:13px;break-inside:avoid}
nav.toc ol{margin:4px 0;padding-left:20px;columns:2}
nav.toc a{color:var(--accent);text-decoration:none}
.warnings{border-left:5px solid var(--warn);background:#fff4e5;padding:6px 12px;margin:10px 0}
.warnings li{color:var(--warn)}
.finding{border-left:5px solid var(--accent);background:#f1f6fb;padding:6px 12px}
.note{font-size:12px;color:var(--muted)}
table{border-collapse:collapse;margin:4px 0 14px;font-size:12.5px}
caption{caption-side:top;text-align:left;font-weight:600;padding:0 0 4px;font-size:13px}
th{background:#eef2f6;text-align:left;border-bottom:1.5px solid #8a96a3;padding:3px 8px;vertical-align:bottom}
td{border-bottom:1px solid var(--rule);padding:3px 8px;vertical-align:top;overflow-wrap:break-word}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tbody tr:nth-child(even){background:#f8fafc}
figure{margin:8px 0 16px;break-inside:avoid}
figure img{max-width:100%;display:block}
figcaption{font-size:12px;color:var(--muted);margin-top:4px}
.cards{display:grid;grid-template-columns:repeat(auto-fill,minmax(220px,1fr));gap:10px;margin:8px 0 14px}
.card{border:1px solid var(--rule);border-radius:6px;padding:7px 10px;break-inside:avoid}
.card .label{font-size:12px;color:var(--muted)}
.card .big{font-size:20px;font-weight:600;color:var(--ink)}
.card .cardnote{font-size:11.5px;color:var(--muted)}
ul{margin:4px 0 10px}
@media print{
body{max-width:none;margin:0;padding:0;font-size:9.5pt}
table{font-size:8pt}
caption{font-size:8.5pt}
h1{font-size:18pt}
h2{font-size:13pt;margin-top:18px}
h3{font-size:10.5pt}
.note,figcaption{font-size:8pt}
.card .big{font-size:13pt}
.card .label,.card .cardnote{font-size:7.5pt}
table.short,tr,.finding,.warnings{break-inside:avoid}
thead{display:table-header-group}
a{color:inherit;text-decoration:none}
}
"""


def _css_string(text: str) -> str:
    """`text` as the inside of a CSS string: every character but letters, digits and spaces as a
    six-digit CSS escape, so no quote, backslash, newline or `</style>` in a user's name can end
    the string or the style sheet."""
    return "".join(c if c.isascii() and (c.isalnum() or c == " ") else f"\\{ord(c):06x}" for c in text)


def _page_css(report: Report) -> str:
    return ("@page{size:A4;margin:15mm 13mm 17mm 13mm;"
            f'@top-left{{content:"{_css_string(report.title)}";font:7.5pt "DejaVu Sans",sans-serif;color:#5b6570}}'
            '@bottom-center{content:"Page " counter(page) " of " counter(pages);'
            'font:7.5pt "DejaVu Sans",sans-serif;color:#5b6570}}')


def _value(value: Value, doc: Mapping) -> str:
    shown = format_value(lookup(doc, value.path), value.fmt)
    key = html.escape(json.dumps(list(value.path)), quote=True)
    span = f'<span class="v" data-key="{key}" data-fmt="{html.escape(value.fmt, quote=True)}">{html.escape(shown)}</span>'
    return span + (f"\u2009{html.escape(value.unit)}" if value.unit else "")


def _inline(run: Sequence[Inline] | Inline, doc: Mapping) -> str:
    if isinstance(run, (str, Value)):
        run = (run,)
    return "".join(_value(item, doc) if isinstance(item, Value) else html.escape(item) for item in run)


def _is_number(cell, doc: Mapping) -> bool:
    if not isinstance(cell, Value):
        return False
    value = lookup(doc, cell.path)
    return value is None or (isinstance(value, (int, float)) and not isinstance(value, bool))


def _table(table: Table, doc: Mapping) -> str:
    short = " short" if len(table.rows) <= SHORT_TABLE_ROWS else ""
    caption = f"<caption>{_inline(table.caption, doc)}</caption>" if table.caption else ""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in table.header)
    body = "".join(
        "<tr>" + "".join(f'<td{" class=num" if _is_number(cell, doc) else ""}>{_inline(cell, doc)}</td>'
                         for cell in row) + "</tr>" for row in table.rows)
    return f'<table class="data{short}">{caption}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _figure(figure: Figure, doc: Mapping) -> str:
    data = base64.b64encode(figure.image).decode()
    return (f'<figure><img alt="{html.escape(figure.alt, quote=True)}" style="width:{figure.width}" '
            f'src="data:{figure.media_type};base64,{data}"><figcaption>{_inline(figure.caption, doc)}</figcaption>'
            '</figure>')


def _block(block, doc: Mapping) -> str:
    if isinstance(block, Paragraph):
        css = {"text": "", "note": ' class="note"', "finding": ' class="finding"'}[block.kind]
        return f"<p{css}>{_inline(block.parts, doc)}</p>"
    if isinstance(block, Bullets):
        return "<ul>" + "".join(f"<li>{_inline(item, doc)}</li>" for item in block.items) + "</ul>"
    if isinstance(block, Table):
        return _table(block, doc)
    if isinstance(block, Figure):
        return _figure(block, doc)
    if isinstance(block, Highlights):
        cards = "".join(
            f'<div class="card"><div class="label">{html.escape(label)}</div><div class="big">{_value(value, doc)}'
            f'</div><div class="cardnote">{_inline(note, doc)}</div></div>' for label, value, note in block.items)
        return f'<div class="cards">{cards}</div>'
    if isinstance(block, Heading):
        return f"<h3>{html.escape(block.title)}</h3>"
    raise TypeError(f"not a report block: {type(block).__name__}")


def _provenance(doc: Mapping, anchor: str) -> list[str]:
    provenance = doc["provenance"]
    rows = [(name, Value(("provenance", "packages", name))) for name in provenance["packages"]]
    rows += [(name, Value(("provenance", name))) for name in provenance if not isinstance(provenance[name], dict)]
    rows += [(f"SHA-256 of {name}", Value(("provenance", "input_sha256", name)))
             for name in provenance.get("input_sha256", {})]
    table = Table(("item", "value"), tuple(rows), ("Package versions, the code's commit, inputs and time",))
    return [f'<h2 id="{anchor}">Provenance</h2>', _table(table, doc)]


def render_html(report: Report, doc: Mapping) -> str:
    """The report as one self-contained HTML page; `doc` is the JSON document the values come from."""
    titles = [section.title for section in report.sections] + ["Provenance"]
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             '<meta name="viewport" content="width=device-width, initial-scale=1">',
             f"<title>{html.escape(report.title)}</title>", f"<style>{CSS}{_page_css(report)}</style></head><body>",
             f"<h1>{html.escape(report.title)}</h1>"]
    if report.subtitle:
        parts.append(f'<p class="subtitle">{_inline(report.subtitle, doc)}</p>')
    if doc["warnings"]:
        items = "".join(f"<li>{_inline(Value(('warnings', i), '', ''), doc)}</li>"
                        for i in range(len(doc["warnings"])))
        parts.append(f'<div class="warnings"><strong>Warnings</strong><ul>{items}</ul></div>')
    parts.append('<nav class="toc"><strong>Contents</strong><ol>' + "".join(
        f'<li><a href="#s{i}">{html.escape(title)}</a></li>' for i, title in enumerate(titles)) + "</ol></nav>")
    for i, section in enumerate(report.sections):
        parts.append(f'<section><h2 id="s{i}">{html.escape(section.title)}</h2>')
        parts.extend(_block(block, doc) for block in section.blocks)
        parts.append("</section>")
    parts.append("<section>")
    parts.extend(_provenance(doc, f"s{len(report.sections)}"))
    parts.append("</section></body></html>")
    return "\n".join(parts)
