"""`snapo report pharma`: the HTML's numbers are the JSON's, every figure is inline, the HTML is
well formed, the PDF has the sections, and (where Chromium is installed) a screenshot renders."""

import json
import pathlib
import shutil
import subprocess
from html.parser import HTMLParser

import pytest

from snapo_ode.cli import main

VOID = {"meta", "img", "br", "hr", "link", "input"}


class _Checker(HTMLParser):
    def __init__(self):
        super().__init__()
        self.stack, self.images, self.numbers, self.errors = [], [], [], []
        self._key = None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "img":
            self.images.append(attrs.get("src", ""))
        if tag not in VOID:
            self.stack.append(tag)
        self._key = attrs.get("data-key") if tag == "td" else None

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1] if self.stack else 'nothing'}")
        else:
            self.stack.pop()

    def handle_data(self, data):
        if self._key is not None:
            self.numbers.append((self._key, float(data)))
            self._key = None


def _lookup(report, key):
    node = report
    for part in key.split("."):
        if isinstance(node, list):
            node = next(item for item in node if item.get("name") == part) if not part.isdigit() else node[int(part)]
        else:
            node = node[part]
    return node


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    # The tolerances and batch shapes of the other pharma tests: one process compiles once.
    assert main(["report", "pharma", "--out", str(out), "--rtol", "1e-10", "--atol", "1e-12", "--points", "2",
                 "--samples", "47", "--repeats", "1"]) == 0
    return out


def test_report_files_numbers_and_figures(report_dir):
    report = json.loads((report_dir / "report.json").read_text())
    checker = _Checker()
    checker.feed((report_dir / "report.html").read_text())
    checker.close()
    assert checker.errors == [] and checker.stack == []
    assert len(checker.images) == 2 and all(src.startswith("data:image/png;base64,") for src in checker.images)
    assert len(checker.numbers) >= 60
    for key, shown in checker.numbers:
        value = _lookup(report, key.replace("sensitivities.", "sensitivities.", 1))
        assert shown == pytest.approx(value, rel=1e-5, abs=1e-300), key
    assert report["verification"]["max_rel_diff_fd"] <= 1e-5
    assert report["verification"]["cantera_r1_amounts"] <= 1e-8
    assert report["verification"]["r1_stiffness_ratio"] >= 1e6
    provenance = report["provenance"]
    assert provenance["packages"]["jax"] and len(provenance["git_commit"] or "") == 40
    assert set(provenance["input_sha256"]) == {"mechanism", "cpps", "physical_parameters", "solver", "effects"}
    rows = (report_dir / "sensitivities.csv").read_text().splitlines()
    assert len(rows) == 1 + 5 * (4 + 43)
    pdf = (report_dir / "report.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and pdf.count(b"/Type /Page\n") + pdf.count(b"/Type /Page ") >= 3


@pytest.mark.skipif(not any(shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome")),
                    reason="no Chromium binary on this machine")
def test_headless_chromium_renders_the_report(report_dir, tmp_path):
    binary = next(shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome") if shutil.which(b))
    shot = tmp_path / "report.png"
    subprocess.run([binary, "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
                    "--window-size=1200,2400", (report_dir / "report.html").as_uri()],
                   check=True, capture_output=True, timeout=120)
    from PIL import Image

    image = Image.open(shot).convert("L")
    assert image.size == (1200, 2400)
    # Tables and figures make the page far from blank.
    histogram = image.histogram()
    assert sum(histogram[:200]) > 0.05 * image.size[0] * image.size[1]
    assert pathlib.Path(shot).stat().st_size > 50_000
