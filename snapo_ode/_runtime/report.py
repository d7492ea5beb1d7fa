"""Reports: a domain supplies the content, the core writes the files.

A `Report` is the JSON document (`data`: every number the report shows) and its content: sections
of paragraphs, tables, figures and highlighted key figures, whose numbers are `Value`s, paths into
`data` rather than numbers, so the HTML and the PDF cannot show a figure the JSON does not hold.
`write_report` renders the HTML (`_report_html`), prints the PDF from that HTML with headless
Chromium (`_pdf`), writes the CSV tables and the JSON, and publishes them with a MANIFEST as one
directory (`publish_directory`: the old report or the new one, never a mix). No domain writes
HTML.

The JSON is `data` with three keys added by the core: `report` (title, the section titles in
order, the files), `warnings` (the domain's and the core's, shown first in the HTML) and
`provenance` (`snapo_ode.provenance`).
"""

import csv
import dataclasses
import io
import os
import pathlib
from collections.abc import Mapping, Sequence
from typing import Any, Literal

from .._platform.files import atomic_write_bytes, json_bytes, publish_directory
from .report_html import render_html
from .report_model import Report, Table, Value, format_value, lookup
from .results import jsonable

PdfMode = Literal["auto", "require", "skip"]


def document(report: Report, warnings: Sequence[str], files: Sequence[str], pdf: Mapping[str, Any]) -> dict:
    """The JSON document: the domain's data and the core's `report`, `warnings`, `provenance`."""
    sections = [section.title for section in report.sections] + ["Provenance"]
    return {"report": {"name": report.name, "title": report.title, "sections": sections, "files": list(files),
                       "pdf": dict(pdf)},
            "warnings": list(warnings), **jsonable(dict(report.data)), "provenance": jsonable(report.provenance)}


def csv_bytes(rows: Sequence[Sequence[Any]]) -> bytes:
    """Rows as CSV (floats in full precision, `repr`; None as empty)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    for row in rows:
        writer.writerow(["" if v is None else repr(v) if isinstance(v, float) else v for v in row])
    return buffer.getvalue().encode("utf-8")


def _table_csv(table: Table, doc: Mapping) -> list[list[Any]]:
    def raw(cell):
        if isinstance(cell, Value):
            return lookup(doc, cell.path)
        if isinstance(cell, tuple):
            return "".join(format_value(lookup(doc, c.path), c.fmt) + c.unit if isinstance(c, Value) else c
                           for c in cell)
        return cell

    return [list(table.header)] + [[raw(cell) for cell in row] for row in table.rows]


@dataclasses.dataclass(frozen=True)
class WrittenReport:
    """The files written (`paths`), the JSON `document`, and the `warnings` (the PDF's among them)."""

    paths: list[pathlib.Path]
    document: dict
    warnings: list[str]


def write_report(out: str | os.PathLike, report: Report, *, json_path: str | os.PathLike | None = None,
                 pdf: PdfMode = "auto") -> WrittenReport:
    """Render and publish `report` as the directory `out`: report.html, report.pdf (printed from
    the HTML), the CSV files, report.json and MANIFEST.json, one set; the JSON also to `json_path`
    when that lies elsewhere.

    `pdf`: "auto" prints with Chromium when it is installed and otherwise writes the rest with a
    warning (in the JSON and the HTML) naming the Debian package; "require" raises
    `PdfUnavailable` instead; "skip" writes no PDF (and says so in the JSON).

    **Raises:** `KeyError` for a `Value` whose path is not in the data; `PdfUnavailable`."""
    from .pdf import PdfUnavailable, chromium_version, count_pages, print_pdf

    csv_files = {name: csv_bytes(rows) for name, rows in report.csv.items()}
    names = ["report.html", *(["report.pdf"] if pdf != "skip" else []),
             *csv_files, *(t.csv for t in _tables(report)), "report.json"]
    warnings = list(report.warnings)
    pdf_meta: dict[str, Any] = {"written": False, "engine": None, "pages": None}
    if pdf == "skip":
        pdf_meta["reason"] = "not requested"
    # The HTML shows the data and the warnings, never the file list or the PDF's details, so the
    # HTML published is the one the PDF was printed from.
    doc = document(report, warnings, names, pdf_meta)
    html_text = render_html(report, doc)
    pdf_bytes = None
    if pdf != "skip":
        try:
            pdf_bytes = print_pdf(html_text)
            pdf_meta.update(written=True, engine=chromium_version(), pages=count_pages(pdf_bytes))
        except PdfUnavailable as error:
            if pdf == "require":
                raise
            warnings.append(f"report.pdf was not written: {error}")
            pdf_meta["reason"] = str(error)
            names.remove("report.pdf")
            html_text = render_html(report, document(report, warnings, names, pdf_meta))
    doc = document(report, warnings, names, pdf_meta)
    for table in _tables(report):
        csv_files[table.csv] = csv_bytes(_table_csv(table, doc))
    report_json = json_bytes(doc)
    files = {"report.html": html_text.encode("utf-8"), **({"report.pdf": pdf_bytes} if pdf_bytes else {}),
             **csv_files, "report.json": report_json}
    paths = publish_directory(out, files)
    if json_path is not None and pathlib.Path(json_path).resolve() != (pathlib.Path(out) / "report.json").resolve():
        paths.append(atomic_write_bytes(json_path, report_json))
    return WrittenReport(paths, doc, warnings)


def _tables(report: Report) -> list[Table]:
    return [block for section in report.sections for block in section.blocks
            if isinstance(block, Table) and block.csv]
