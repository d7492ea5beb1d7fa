"""mkdocs hook: the built site is checked as a reader meets it, and the build fails on what strict
mode lets through.

- Markdown that renders as something else (`markdown_problems`): a line right under a table
  (Python-Markdown makes it a row of the table), a list that starts right under a paragraph
  (rendered as "- " text), a link target that is not a page, a file or an address.
- Links in the built HTML (`link_problems`): every relative `href` and `src` leads to a file of the
  site, and every `#anchor` to an id on its page; notebooks and generated pages included.
- Notebook pages (`notebook_problems`): at least one image each, and no output written to stderr
  (a warning box at the top of a page).

`make docs` also runs a Markdown linter over the sources (`.pymarkdown.json`).
"""

import html.parser
import pathlib
import re
import urllib.parse


_TABLE_ROW = re.compile(r"^\s*\|")
_LIST_ITEM = re.compile(r"^(?:[-*+]|\d+[.)])\s+\S")
_FENCE = re.compile(r"^\s*(```|~~~)")
_LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")


def markdown_problems(text: str) -> list[str]:
    """Lines of `text` (Markdown) that render as something their author did not mean, each as
    "line N: what"."""
    problems, fenced, previous = [], False, ""
    for number, line in enumerate(text.splitlines(), start=1):
        if _FENCE.match(line):
            fenced = not fenced
        if fenced or _FENCE.match(line):
            previous = "" if not fenced else previous
            continue
        if line.strip() and _TABLE_ROW.match(previous) and not _TABLE_ROW.match(line):
            problems.append(f"line {number}: text right under a table becomes one of its rows; leave a blank line")
        if (_LIST_ITEM.match(line) and previous.strip() and not _LIST_ITEM.match(previous.strip())
                and not previous.startswith((" ", "\t")) and not _TABLE_ROW.match(previous)
                and not previous.lstrip().startswith("#")):
            problems.append(f"line {number}: a list right under a paragraph renders as text; leave a blank line")
        for target in _LINK.findall(re.sub(r"`[^`]*`", "", line)):
            if not re.match(r"^(?:[a-z]+:|#|(?:\.{0,2}/)?(?:[\w.-]+/)*(?:[\w.-]+\.\w+)?(?:#[\w-]+)?$)", target):
                problems.append(f"line {number}: link target {target!r} is neither a page, a file nor an address")
        previous = line
    return problems


class _Collector(html.parser.HTMLParser):
    """The ids, links, images and stderr outputs of one HTML page."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.ids, self.links, self.images, self.stderr = set(), [], 0, 0

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if "id" in attrs:
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("name"):
            self.ids.add(attrs["name"])
        for key in ("href", "src"):
            if tag in ("a", "img") and attrs.get(key):
                self.links.append(attrs[key])
        if tag == "img":
            self.images += 1
        if attrs.get("data-mime-type") == "application/vnd.jupyter.stderr" or "output_stderr" in (attrs.get("class") or ""):
            self.stderr += 1


def _collect(page: pathlib.Path) -> _Collector:
    collector = _Collector()
    collector.feed(page.read_text(encoding="utf-8"))
    return collector


def link_problems(site: pathlib.Path) -> list[str]:
    """Relative links and anchors of the pages under `site` that lead nowhere."""
    # 404.html links from the site's root, which only a server knows
    pages = {page: _collect(page) for page in site.rglob("*.html") if page.name != "404.html" or page.parent != site}
    problems = []
    for page, found in pages.items():
        for link in found.links:
            parts = urllib.parse.urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "javascript:")):
                continue
            target = (page.parent / urllib.parse.unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            name = page.relative_to(site)
            if not target.exists():
                problems.append(f"{name}: link {link!r} leads to no file of the site")
            elif parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _collect(target).ids
                if urllib.parse.unquote(parts.fragment) not in ids:
                    problems.append(f"{name}: link {link!r} names no anchor of its page")
    return problems


def notebook_problems(site: pathlib.Path, notebooks) -> list[str]:
    """Notebook pages (their paths under `site`) without an image or with output on stderr."""
    problems = []
    for page in notebooks:
        found = _collect(site / page)
        if not found.images:
            problems.append(f"{page}: no image (is the kernel's matplotlib backend the inline one?)")
        if found.stderr:
            problems.append(f"{page}: {found.stderr} output(s) written to stderr")
    return problems


# Pages where measurements carry their dates and issue numbers; every other page is read by users.
DEVELOPMENT_NOTES = ("decisions.md", "results.md", "tests.md", "dev/")
_LAB_NOTES = re.compile(r"issue [0-9]+|/tmp/")
_NOTEBOOK_PAGES: list[str] = []
_PROBLEMS: list[str] = []


def lab_note_problems(text: str) -> list[str]:
    """Issue numbers and temporary paths in a user page, each as "line N: what"."""
    return [f"line {number}: {match.group(0)!r} belongs in the development notes"
            for number, line in enumerate(text.splitlines(), start=1) for match in _LAB_NOTES.finditer(line)]


def on_files(files, config):
    """Note the notebook pages, to check them once built."""
    _NOTEBOOK_PAGES[:] = [file.dest_uri for file in files if file.src_uri.endswith(".ipynb")]
    _PROBLEMS.clear()
    return files


def on_page_markdown(markdown, page, config, files):
    """Note Markdown that renders as something else, and lab notes on a user page (source
    pages only, not notebooks); the build fails at its end, naming every one."""
    name = page.file.src_uri
    if name.endswith(".md"):
        problems = markdown_problems(markdown)
        if not name.startswith(DEVELOPMENT_NOTES):
            problems += lab_note_problems(markdown)
        _PROBLEMS.extend(f"{name}: {problem}" for problem in problems)
    return markdown


def on_post_build(config):
    """Fail on the pages' problems, links that lead nowhere and notebook pages without figures."""
    site = pathlib.Path(config.site_dir)
    problems = _PROBLEMS + link_problems(site) + notebook_problems(site, _NOTEBOOK_PAGES)
    if problems:
        from mkdocs.exceptions import PluginError  # here, so the checks import without mkdocs (tests)

        raise PluginError("the built site has problems:\n  " + "\n  ".join(problems))
