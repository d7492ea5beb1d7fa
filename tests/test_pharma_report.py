"""`snapo report pharma`: every number in the HTML is the JSON's and so is every number in the PDF
(printed from the HTML by headless Chromium) with the same sections; the design-space map agrees
with full Monte Carlo at its verification points within their standard error; the verification
evidence holds; and (where Chromium is installed) a screenshot of the page renders."""

import csv
import shutil
import subprocess

import pytest

import snapo_ode
from snapo_ode.cli import main

from report_checks import check_html, check_pdf, check_reader

HAS_CHROMIUM = snapo_ode.find_chromium() is not None


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    # The tolerances and Monte Carlo batch shape (4 points x 47 draws = the central differences'
    # 188 rows) of the other pharma tests: one process compiles once. A small grid keeps it quick.
    assert main(["report", "pharma", "--out", str(out), "--rtol", "1e-10", "--atol", "1e-12", "--points", "5",
                 "--verify-points", "4", "--samples", "47", "--curvature-points", "2", "--surrogate-samples", "1024",
                 "--repeats", "1"]) == 0
    return out


def test_html_numbers_are_the_json_and_the_evidence_holds(report_dir):
    doc, page = check_html(report_dir)
    assert len(page.values) >= 250 and len(page.images) == 3
    assert doc["report"]["sections"] == ["Executive summary", "Process parameters and specifications", "Nominal CQAs",
                                         "Mass balances", "Sensitivities", "Design space", "Methods",
                                         "Document control and approval", "Appendix: solver settings and timings",
                                         "Provenance"]
    text = check_reader(page)
    assert "What was mapped" in text and doc["mapped"]["count"] == 2 and doc["mapped"]["of"] == 4
    assert doc["document"]["id"].startswith("SNAPO-Q8-") and "Approved by" in text
    verification = doc["verification"]
    assert verification["max_rel_diff_fd"] <= 1e-5 and verification["cantera_r1_amounts"] <= 1e-8
    # Every reactor against Cantera's own, the first one's also under its old name.
    assert list(verification["cantera_reactors"]) == ["r1", "r2"]
    assert verification["cantera_reactors"]["r1"]["amounts"] == verification["cantera_r1_amounts"]
    assert max(r["amounts"] for r in verification["cantera_reactors"].values()) <= 1e-8
    # Every unit's balance, stated in the report and its CSV, at round-off.
    balances = doc["mass_balances"]
    assert [row["unit"] for row in balances] == ["r1", "r2", "crystallizer", "filter", "dryer"]
    assert all(row["residual"] <= 1e-12 for row in balances)
    balance_rows = list(csv.reader((report_dir / "mass_balances.csv").open()))
    assert [row[0] for row in balance_rows[1:]] == [row["unit"] for row in balances]
    assert verification["r1_stiffness_ratio"] >= 1e6
    provenance = doc["provenance"]
    assert provenance["packages"]["jax"] and len(provenance["git_commit"] or "") == 40
    assert set(provenance["input_sha256"]) == {"process", "mechanism", "cpps", "physical_parameters", "solver", "effects"}
    assert provenance["command"].startswith("snapo report pharma --out")
    rows = list(csv.reader((report_dir / "sensitivities.csv").open()))
    assert len(rows) == 1 + 5 * (4 + 43)
    space = doc["design_space"]
    assert len(list(csv.reader((report_dir / "design_space.csv").open()))) == 1 + 5 * 5
    assert space["operating_probability"] >= space["level"] and space["verification"]["points"][0]["i"] == 2
    summary = doc["summary"]
    assert summary["all_specs_met"] and summary["impact"]["degradant"]["dryer_temperature"]["grade"] in ("medium", "high")
    # Criticality by the full model at the PAR's ends: residual solvent is strongly curved in the
    # dryer's temperature (its linearised grade understates it), and at least as critical as the
    # map shows it; each change is the full model's own CQA values at the ends.
    solvent = summary["impact"]["residual_solvent"]["dryer_temperature"]
    assert solvent["change_over_par_full_model"] > solvent["change_over_par"]
    assert solvent["grade_full_model"] in ("medium", "high")
    value = summary["cqas"]["residual_solvent"]["value"]
    assert solvent["change_over_par_full_model"] == max(abs(solvent["at_par_low"] - value),
                                                        abs(solvent["at_par_high"] - value))
    assert sum(summary["impact_counts_full_model"].values()) == 5 * 4


def test_design_space_agrees_with_full_monte_carlo_within_its_standard_error(report_dir):
    doc, _ = check_html(report_dir)
    check = doc["design_space"]["verification"]
    assert len(check["points"]) == 4 and check["samples"] == 47
    for point in check["points"]:
        assert abs(point["probability_surrogate"] - point["probability_mc"]) <= point["se_mc"], point
    assert check["all_within_se"]
    # The hot end of the dryer's PAR fails the degradant spec for most draws: the map has an edge.
    assert min(min(row) for row in doc["design_space"]["probability"]) < doc["design_space"]["level"]


@pytest.mark.skipif(not HAS_CHROMIUM, reason="no headless Chromium (Debian package chromium)")
def test_the_pdf_shows_the_html(report_dir):
    doc, page = check_html(report_dir)
    text = check_pdf(report_dir, doc, page)
    assert doc["report"]["pdf"]["written"] and doc["report"]["pdf"]["pages"] >= 5
    for title in doc["report"]["sections"]:
        assert title in text


@pytest.mark.skipif(not HAS_CHROMIUM, reason="no headless Chromium (Debian package chromium)")
def test_headless_chromium_renders_the_report(report_dir, tmp_path):
    binary = snapo_ode.find_chromium()
    shot = tmp_path / "report.png"
    subprocess.run([binary, "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
                    f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1200,2400",
                    (report_dir / "report.html").as_uri()], check=True, capture_output=True, timeout=120)
    from PIL import Image

    image = Image.open(shot).convert("L")
    assert image.size == (1200, 2400)
    histogram = image.histogram()  # tables, cards and text make the page far from blank
    assert sum(histogram[:200]) > 0.02 * image.size[0] * image.size[1]
    assert shot.stat().st_size > 50_000
    assert shutil.which(binary)
