"""The core's report builder on a toy report: the HTML shows the JSON's values and no other
number, the PDF (printed from the HTML by headless Chromium) shows the same values in the same
order under the same headings with page numbers, the CSV holds the tables' full-precision values,
the set is published whole, and without Chromium the rest is written with a warning naming the
Debian package (or, with --require-pdf, nothing is computed)."""

import json
import shutil

import matplotlib
import pytest

import snapo_ode
from snapo_ode import Figure, Heading, Highlights, Paragraph, Report, Section, Table, Value, write_report
from snapo_ode.cli import CommandLine, main, publish_report

from report_checks import Page, check_html, check_pdf, check_reader

matplotlib.use("Agg")
HAS_CHROMIUM = snapo_ode.find_chromium() is not None
needs_chromium = pytest.mark.skipif(not HAS_CHROMIUM, reason="no headless Chromium (Debian package chromium)")


def toy_report(rows: int = 3) -> Report:
    import matplotlib.pyplot as plt

    data = {"value": 1234.5678, "ratio": 0.987654, "label": "ok", "missing": None, "flag": True,
            "ladder": [{"tenor": f"{t}y", "delta": 0.1 * t - 0.05} for t in range(1, rows + 1)]}
    figure, axis = plt.subplots(figsize=(4, 2))
    axis.plot([0, 1], [0, 1])
    ladder = tuple((Value(("ladder", i, "tenor")), Value(("ladder", i, "delta"), ".3e")) for i in range(rows))
    return Report(
        name="toy", title="Toy report", data=data, provenance=snapo_ode.provenance({"data": data}),
        subtitle=("A report of ", Value(("label",)), " things"),
        warnings=("a warning from the domain",),
        sections=(
            Section("Summary", (Highlights((("value", Value(("value",), ",.2f"), ("dollars",)),)),
                                Paragraph(("The ratio is ", Value(("ratio",), ".1%"), "; flag ", Value(("flag",)),
                                           ", missing ", Value(("missing",)), "."), "finding"))),
            Section("Ladder", (Heading("By tenor"), Table(("tenor", "delta"), ladder, ("The ladder",), csv="ladder.csv"),
                               Figure.from_matplotlib(figure, ("A line",), "a line"))),
        ),
        csv={"extra.csv": [["a", "b"], [1, 0.1]]})


@needs_chromium
def test_html_pdf_csv_and_json_agree(tmp_path):
    out = tmp_path / "report"
    written = write_report(out, toy_report(rows=60))  # long enough for a second page
    assert sorted(p.name for p in written.paths) == ["extra.csv", "ladder.csv", "report.html", "report.json",
                                                    "report.pdf"]
    doc, page = check_html(out)
    assert len(page.values) >= 120 and doc["report"]["pdf"]["written"] and doc["report"]["pdf"]["pages"] >= 2
    text = check_pdf(out, doc, page)
    assert "1,234.57" in text and "98.8%" in text
    assert page.headings == ["Toy report", "Summary", "Ladder", "By tenor", "Provenance"]
    rows = (out / "ladder.csv").read_text().splitlines()
    assert rows[0] == "tenor,delta" and rows[1] == f"1y,{repr(0.1 - 0.05)}" and len(rows) == 61
    assert doc["warnings"] == ["a warning from the domain"]
    assert doc["provenance"]["input_sha256"]["data"] == snapo_ode.input_digest(toy_report(60).data)


def test_a_value_missing_from_the_data_is_refused(tmp_path):
    report = toy_report()
    broken = Report(name="toy", title="t", data=report.data, provenance={},
                    sections=(Section("s", (Paragraph((Value(("nowhere",)),)),)),))
    with pytest.raises(KeyError, match="nowhere"):
        write_report(tmp_path / "r", broken, pdf="skip")
    assert not (tmp_path / "r").exists()
    with pytest.raises(ValueError, match="core's keys"):
        Report(name="toy", title="t", data={"warnings": []}, provenance={}, sections=())


def test_without_chromium_the_rest_is_written_with_a_warning(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SNAPO_CHROMIUM", "")
    out = tmp_path / "report"
    written = write_report(out, toy_report())
    assert not (out / "report.pdf").exists() and (out / "report.html").exists()
    doc, _ = check_html(out)
    assert doc["report"]["pdf"]["written"] is False
    assert "Debian package `chromium`" in doc["warnings"][-1] and doc["warnings"] == written.warnings

    def register(cli: CommandLine):
        parser = cli.report("toy", "a toy report")
        parser.set_defaults(handler=lambda args: publish_report(args, toy_report()))

    assert main(["report", "toy", "--out", str(tmp_path / "cli")], plugins=[register]) == 0
    err = capsys.readouterr().err
    assert "apt-get install chromium" in err and (tmp_path / "cli" / "report.html").exists()
    calls = []

    def register_counting(cli: CommandLine):
        parser = cli.report("toy", "a toy report")
        parser.set_defaults(handler=lambda args: calls.append(args) or 0)

    assert main(["report", "toy", "--require-pdf", "--out", str(tmp_path / "req")], plugins=[register_counting]) == 2
    assert calls == [] and "chromium" in capsys.readouterr().err
    assert main(["report", "toy", "--no-pdf", "--out", str(tmp_path / "skip")], plugins=[register]) == 0
    assert json.loads((tmp_path / "skip" / "report.json").read_text())["report"]["pdf"]["reason"] == "not requested"


@needs_chromium
def test_a_failed_print_leaves_the_old_report(tmp_path, monkeypatch):
    out = tmp_path / "report"
    write_report(out, toy_report(), pdf="skip")
    before = (out / "report.html").read_bytes()
    fake = tmp_path / "false-chromium"
    fake.write_text("#!/bin/sh\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("SNAPO_CHROMIUM", str(fake))
    with pytest.raises(snapo_ode.PdfUnavailable, match="without a PDF"):
        write_report(out, toy_report(rows=5), pdf="require")
    assert (out / "report.html").read_bytes() == before
    assert shutil.which(str(fake))


def _page(html: str) -> Page:
    page = Page()
    page.feed(html)
    page.close()
    return page


@pytest.mark.parametrize("body, defect", [
    ("<p>a step of 1.2e-05 m</p>", "scientific"),
    ("<p>a duration of -0.000 years</p>", "negative zero"),
    ("<p>written by /work/x/snapo_ode/cli.py</p>", "paths"),
    ("<p>installed in lib/python3/site-packages</p>", "paths"),
    ("<p>see finance/alm/_report.py</p>", "paths"),
    ('<div class="card"><div class="label">value</div><div class="big"><span>1,234.5</span></div></div>', "unit"),
])
def test_the_reader_check_fails_on_each_defect(body, defect):
    card = '<div class="card"><div class="label">v</div><div class="big"><span>3.5</span>\u2009kg</div></div>'
    clean = _page(f"<h1>T</h1>{card}<h2>Summary</h2><p>a rate of 5%</p><h2>Provenance</h2><p>/work/x.py 1e-05</p>")
    assert "5%" in check_reader(clean)  # the provenance may name files and raw numbers
    with pytest.raises(AssertionError, match=defect):
        check_reader(_page(f"<h1>T</h1>{card}<h2>Summary</h2>{body}<h2>Provenance</h2>"))


def test_a_number_rounded_to_zero_reads_without_a_minus_sign():
    from snapo_ode._runtime.report_model import format_value

    assert [format_value(v, f) for v, f in ((-0.0004, ".3f"), (-1e-9, ".1%"), (-0.0, "+.2f"), (-0.004, ".2f"),
                                            (-0.006, ".2f"), (-12.0, ",.0f"))] == ["0.000", "0.0%", "0.00",
                                                                                   "0.00", "-0.01", "-12"]
