"""griffe extension for the API pages: the docstrings' lists render as lists.

The docstrings write a list right under its label, diffrax's way ("**Arguments:**" and then "- `fn`:
..."), with sub-lists indented by two spaces. Python-Markdown, which renders the site, needs a blank
line before a list and four spaces for a sub-list; without them an argument list is one paragraph
of "- " text. The docstrings stay as they are (they read well in `help()`); the site's copy gets the
blank line and the indent.
"""

import re

import griffe

_ITEM = re.compile(r"^( *)([-*]|\d+\.) +\S")


def as_markdown_lists(text: str) -> str:
    """`text` with a blank line before each list that starts under other text, and sub-list items
    indented by four spaces per level instead of two."""
    lines, previous, fenced = [], "", False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        item = None if fenced else _ITEM.match(line)
        if item:
            depth = len(item.group(1)) // 2
            line = "    " * depth + line.lstrip()
            if previous.strip() and not _ITEM.match(previous) and not previous.startswith(" ") and depth == 0:
                lines.append("")
        lines.append(line)
        previous = line
    return "\n".join(lines)


class DocstringLists(griffe.Extension):
    """Rewrite each loaded object's docstring with `as_markdown_lists`."""

    def on_object(self, *, obj, loader, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = as_markdown_lists(obj.docstring.value)
