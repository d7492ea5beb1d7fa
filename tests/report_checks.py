"""Checks of a written report directory, shared by the report tests and written apart from the
renderer: every value shown in the HTML equals its entry in the JSON, no number appears in the
HTML's text outside such a value, the PDF's text shows the HTML's values in the same order, its
bookmarks are the HTML's headings, and the files are the set the manifest names."""

import hashlib
import json
import re
import unicodedata
from html.parser import HTMLParser

VOID = {"meta", "img", "br", "hr", "link", "input"}
# A number standing alone in running text (not a part of a name such as R1, Q8, D[4,3] or m^3).
LOOSE_NUMBER = re.compile(r"(?<![\w\[\.\-/,^])[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w\]])")


class Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.images, self.values, self.loose = [], [], [], [], []
        self.headings, self.sections = [], []  # h1-h3 in order; the h2s
        self._value = None  # [key, fmt, text] while inside a value
        self._heading = None
        self._skip = 0

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "img":
            self.images.append(attrs.get("src", ""))
        if tag not in VOID:
            self.stack.append(tag)
        if tag in ("style", "title", "script"):
            self._skip += 1
        if tag == "span" and "data-key" in attrs:
            self._value = [json.loads(attrs["data-key"]), attrs["data-fmt"], ""]
        if tag in ("h1", "h2", "h3"):
            self._heading = ""

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1] if self.stack else 'nothing'}")
            return
        self.stack.pop()
        if tag in ("style", "title", "script"):
            self._skip -= 1
        if tag == "span" and self._value is not None:
            self.values.append(tuple(self._value))
            self._value = None
        if tag in ("h1", "h2", "h3") and self._heading is not None:
            self.headings.append(" ".join(self._heading.split()))
            if tag == "h2":
                self.sections.append(self.headings[-1])
            self._heading = None

    def handle_data(self, data):
        if self._skip:
            return
        if self._heading is not None:
            self._heading += data
        if self._value is not None:
            self._value[2] += data
        else:
            self.loose.extend(LOOSE_NUMBER.findall(data))


def expected_text(value, fmt: str) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, str):
        return value
    return format(value, fmt)


def lookup(doc, path):
    for part in path:
        doc = doc[part]
    return doc


def check_html(directory) -> tuple[dict, Page]:
    """The JSON document and the parsed page, after checking every value against the JSON."""
    doc = json.loads((directory / "report.json").read_text())
    page = Page()
    page.feed((directory / "report.html").read_text())
    page.close()
    assert page.errors == [] and page.stack == [], page.errors[:5]
    assert page.values, "no values in the HTML"
    for path, fmt, text in page.values:
        assert text == expected_text(lookup(doc, path), fmt), (path, fmt, text)
    assert page.loose == [], f"numbers in the HTML that are not values of the JSON: {page.loose[:20]}"
    assert page.sections == doc["report"]["sections"], (page.sections, doc["report"]["sections"])
    assert all(src.startswith("data:image/") for src in page.images)
    manifest = json.loads((directory / "MANIFEST.json").read_text())["files"]
    assert sorted(manifest) == sorted(doc["report"]["files"])
    for name, digest in manifest.items():
        assert hashlib.sha256((directory / name).read_bytes()).hexdigest() == digest, name
    return doc, page


def _outline_titles(reader) -> list[str]:
    titles = []

    def walk(items):
        for item in items:
            if isinstance(item, list):
                walk(item)
            else:
                titles.append(" ".join(str(item.title).split()))

    walk(reader.outline)
    return titles


def check_pdf(directory, doc: dict, page: Page) -> str:
    """The PDF's text, after checking that it shows every value of the HTML in order (whitespace
    aside: a long value may wrap), that its bookmarks are the HTML's headings, and its page
    count is the JSON's."""
    import pypdf

    reader = pypdf.PdfReader(directory / "report.pdf")
    assert len(reader.pages) == doc["report"]["pdf"]["pages"]
    # NFKC: a PDF may spell "fi" as one ligature glyph.
    text = unicodedata.normalize("NFKC", "\n".join(p.extract_text() for p in reader.pages))
    compact = re.sub(r"\s+", "", text)
    position = 0
    for path, _, shown in page.values:
        token = re.sub(r"\s+", "", unicodedata.normalize("NFKC", shown))
        found = compact.find(token, position)
        assert found >= 0, f"{path} = {shown!r} is not in the PDF's text after position {position}"
        position = found + len(token)
    # Compared without whitespace: Chromium joins the lines of a wrapped heading without a space.
    assert [re.sub(r"\s+", "", t) for t in _outline_titles(reader)] == [re.sub(r"\s+", "", t) for t in page.headings]
    assert f"Page 1 of {len(reader.pages)}" in text
    return text
