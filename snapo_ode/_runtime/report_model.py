"""The content of a report, free of any file format: `Value`s (paths into the report's JSON,
never numbers), blocks (paragraphs, lists, tables, figures, key figures, sub-headings), sections
and the `Report` a domain builds. `_report_html` renders it; `_report` writes the files."""

import dataclasses
import io
from collections.abc import Mapping, Sequence
from typing import Any

Path = tuple[str | int, ...]
CORE_KEYS = ("report", "warnings", "provenance")


@dataclasses.dataclass(frozen=True)
class Value:
    """A value shown in the report: the entry of the report's JSON at `path` (dict keys and list
    indices), numbers formatted with the format spec `fmt` (`format(value, fmt)`: ".4g", ",.0f",
    ".1%"), strings as they are, booleans as yes/no, None as n/a; `unit` follows as plain text."""

    path: Path
    fmt: str = ".4g"
    unit: str = ""


Inline = str | Value
"""A run of text: plain strings (no numbers in them, by convention: numbers are `Value`s) and values."""


def parts(*items: Inline) -> tuple[Inline, ...]:
    return tuple(items)


@dataclasses.dataclass(frozen=True)
class Paragraph:
    """Text; `kind` "text", "note" (smaller, grey) or "finding" (a highlighted conclusion)."""

    parts: tuple[Inline, ...]
    kind: str = "text"


@dataclasses.dataclass(frozen=True)
class Bullets:
    """A bulleted list, each item a run of text."""

    items: tuple[tuple[Inline, ...], ...]


@dataclasses.dataclass(frozen=True)
class Table:
    """A table: `header` strings, `rows` of cells (a string, a `Value`, or a run of text as a
    tuple), a `caption` above it; with `csv` (a file name) it is also written as CSV, each
    `Value` at full precision."""

    header: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]
    caption: tuple[Inline, ...] = ()
    csv: str | None = None


@dataclasses.dataclass(frozen=True)
class Figure:
    """An image (SVG or PNG bytes) with a caption; `width` as a CSS length."""

    image: bytes
    caption: tuple[Inline, ...]
    alt: str
    width: str = "100%"
    media_type: str = "image/svg+xml"

    @classmethod
    def from_matplotlib(cls, figure, caption: Sequence[Inline], alt: str, width: str = "100%") -> "Figure":
        """A matplotlib figure as SVG (text as paths, no timestamp: the same figure gives the same
        bytes); the figure is closed."""
        import matplotlib.pyplot as plt

        buffer = io.BytesIO()
        figure.savefig(buffer, format="svg", bbox_inches="tight", metadata={"Date": None})
        plt.close(figure)
        return cls(buffer.getvalue(), tuple(caption), alt, width)


@dataclasses.dataclass(frozen=True)
class Highlights:
    """Key figures shown as cards: (label, value, note) each."""

    items: tuple[tuple[str, Value, tuple[Inline, ...]], ...]


@dataclasses.dataclass(frozen=True)
class Heading:
    """A sub-heading inside a section (HTML h3, a PDF bookmark)."""

    title: str


Block = Paragraph | Bullets | Table | Figure | Highlights | Heading


@dataclasses.dataclass(frozen=True)
class Section:
    title: str
    blocks: tuple[Block, ...]


@dataclasses.dataclass(frozen=True)
class Report:
    """A report's content.

    **Arguments:**
    - `name`: short name ("pharma"), used in the page header.
    - `title`, `subtitle` (a run of text).
    - `data`: the JSON document (JSON-ready after `snapo_ode.jsonable`), without the core's keys.
    - `sections`: in reading order (the core appends Provenance).
    - `warnings`: strings shown first.
    - `provenance`: from `snapo_ode.provenance`.
    - `csv`: extra CSV files, name -> rows (the first row the header).
    """

    name: str
    title: str
    data: Mapping[str, Any]
    sections: tuple[Section, ...]
    provenance: Mapping[str, Any]
    subtitle: tuple[Inline, ...] = ()
    warnings: tuple[str, ...] = ()
    csv: Mapping[str, Sequence[Sequence[Any]]] = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        clash = [key for key in CORE_KEYS if key in self.data]
        if clash:
            raise ValueError(f"report data may not use the core's keys {clash}")


def lookup(document: Mapping, path: Path) -> Any:
    """The entry of `document` at `path`.

    **Raises:** `KeyError` naming the path when it does not resolve (a report that refers to a
    number its JSON does not hold is a programming error)."""
    node: Any = document
    for part in path:
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            raise KeyError(f"report value {list(path)!r}: {part!r} not found") from None
    return node


def format_value(value: Any, fmt: str) -> str:
    """How a value reads in the report (see `Value`); a number that rounds to zero reads without
    a minus sign ("0.000", not "-0.000": the sign of round-off means nothing to a reader)."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        text = format(value, fmt)
        return text[1:] if text.startswith("-") and not any(c in "123456789" for c in text.split("e")[0]) else text
    raise TypeError(f"cannot show a {type(value).__name__} as one value")


