"""Benchmark tables: one writer (CSV through the `csv` module, and JSON) and one text format for
every `snapo bench`."""

import csv
import io
import os
import pathlib
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

from ._io import atomic_write_json, atomic_write_text
from ._results import jsonable


class Column(NamedTuple):
    """A column of a printed table: its `header`, the row `key`, and `format` (a format spec such
    as ".2f", or a function of the value returning text)."""

    header: str
    key: str
    format: str | Callable = ""


def format_table(rows: Sequence[Mapping], columns: Sequence[Column]) -> str:
    """`rows` as a Markdown table (pasteable into the README)."""

    def cell(row, column):
        value = row.get(column.key)
        if value is None:
            return "-"
        return column.format(value) if callable(column.format) else format(value, column.format)

    lines = ["| " + " | ".join(c.header for c in columns) + " |",
             "|" + "|".join(" --- " for _ in columns) + "|"]
    lines += ["| " + " | ".join(cell(row, c) for c in columns) + " |" for row in rows]
    return "\n".join(lines)


def write_table(out: str | os.PathLike, name: str, rows: Sequence[Mapping], extra: Mapping | None = None
                ) -> tuple[pathlib.Path, pathlib.Path]:
    """Write `rows` as `out/name.csv` (the union of the rows' keys as columns, in first-seen
    order; values quoted by the `csv` module) and `{"rows": rows, **extra}` as `out/name.json`,
    each atomically. Returns both paths."""
    out = pathlib.Path(out)
    columns = list(dict.fromkeys(key for row in rows for key in row))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({key: jsonable(row.get(key)) for key in columns})
    csv_path = atomic_write_text(out / f"{name}.csv", buffer.getvalue())
    json_path = atomic_write_json(out / f"{name}.json", jsonable({"rows": list(rows), **(extra or {})}))
    return csv_path, json_path
