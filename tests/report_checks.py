"""Checks of a written report directory, shared by the report tests and written apart from the
renderer: every value shown in the HTML equals its entry in the JSON, no number appears in the
HTML's text outside such a value, the PDF's text shows the HTML's values in the same order, its
bookmarks are the HTML's headings, and the files are the set the manifest names; and, for a reader,
that the body (every section before Provenance) shows no number in bare scientific notation, no
key figure without its unit and no path of the repository or the environment (`check_reader`)."""

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
        self.body = []  # the text of the sections before Provenance
        self.cards = []  # (label, the key figure as shown) of every card
        self._card = None  # [label, text] while inside a card's label or figure
        self._card_part = None
        self._in_provenance = False

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
        if tag == "div" and attrs.get("class") == "label":
            self._card, self._card_part = ["", ""], 0
        if tag == "div" and attrs.get("class") == "big" and self._card is not None:
            self._card_part = 1

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1] if self.stack else 'nothing'}")
            return
        self.stack.pop()
        if tag in ("style", "title", "script"):
            self._skip -= 1
        if tag == "div" and self._card_part is not None:
            if self._card_part == 1:
                self.cards.append((" ".join(self._card[0].split()), " ".join(self._card[1].split())))
                self._card = None
            self._card_part = None
        if tag == "span" and self._value is not None:
            self.values.append(tuple(self._value))
            self._value = None
        if tag in ("h1", "h2", "h3") and self._heading is not None:
            self.headings.append(" ".join(self._heading.split()))
            if tag == "h2":
                self.sections.append(self.headings[-1])
                self._in_provenance = self.headings[-1] == "Provenance"
            self._heading = None

    def handle_data(self, data):
        if self._skip:
            return
        if self._heading is not None:
            self._heading += data
        if not self._in_provenance:
            self.body.append(data)
        if self._card_part is not None:
            self._card[self._card_part] += data
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
    text = format(value, fmt)
    # Rounded to zero, a number shows no minus sign.
    return text.lstrip("-") if re.fullmatch(r"-[0.,]+(%|e[-+]\d+)?", text) else text


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


# A number in bare scientific notation ("1.2e-05"): a reader is owed a rounded figure with its unit.
SCIENTIFIC = re.compile(r"(?<![\w.])[-+\u2212]?\d+(?:\.\d+)?[eE][-+\u2212]?\d+\b")
# A number rounded to zero that keeps its minus sign ("-0.000").
NEGATIVE_ZERO = re.compile(r"(?<![\w.])[-\u2212]0(?:\.0+)?(?![\d.])")
# A path of the repository, the environment or a module: a reader's report names none.
REPOSITORY_PATH = re.compile(r"/work/|site-packages|/tmp/|\b[\w/]+\.py\b")
# A key figure reads with its unit: after the number (a word or a symbol), a percentage, or a value
# that is not a number (a name, yes/no, n/a).
NUMBER_ONLY = re.compile(r"[-+\u2212]?[\d,]+(?:\.\d+)?")


def check_reader(page: Page) -> str:
    """The body's text (every section before Provenance, headings and tables included), after
    checking what a reader is owed: no bare scientific notation, no repository or environment
    path, and every key figure with its unit."""
    text = " ".join(" ".join(page.body).split())
    assert SCIENTIFIC.findall(text) == [], f"bare scientific notation in the body: {SCIENTIFIC.findall(text)[:10]}"
    assert NEGATIVE_ZERO.findall(text) == [], f"a negative zero in the body: {NEGATIVE_ZERO.findall(text)[:5]}"
    paths = [text[max(m.start() - 30, 0):m.end() + 10] for m in REPOSITORY_PATH.finditer(text)]
    assert paths == [], f"repository paths in the body: {paths[:5]}"
    assert page.cards, "no key figures"
    bare = [(label, shown) for label, shown in page.cards if NUMBER_ONLY.fullmatch(shown)]
    assert bare == [], f"key figures without a unit: {bare}"
    return text


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
