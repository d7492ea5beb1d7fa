"""Benchmark tables: one writer (CSV through the `csv` module, and JSON) and one text format for
every `snapo bench`."""

import csv
import io
import os
import pathlib
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

from .._platform.files import json_bytes, publish
from .results import jsonable


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


def records_csv(rows: Sequence[Mapping]) -> bytes:
    """`rows` (mappings) as CSV: the union of their keys as columns, in first-seen order; values
    quoted by the `csv` module."""
    columns = list(dict.fromkeys(key for row in rows for key in row))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({key: jsonable(row.get(key)) for key in columns})
    return buffer.getvalue().encode("utf-8")


def write_table(out: str | os.PathLike, name: str, rows: Sequence[Mapping], extra: Mapping | None = None,
                files: Mapping[str, bytes] | None = None, also_as: Sequence[str] = ()) -> list[pathlib.Path]:
    """Write `rows` as `out/name.csv` (`records_csv`), any other `files` (name -> bytes, e.g. a
    plot) and `{"rows": rows, **extra}` as `out/name.json`, as one set (`snapo_ode.publish`, the
    JSON last); the same table also under each name of `also_as` (a bench's earlier names).
    Returns the paths, the CSV first and the JSON last."""
    out = pathlib.Path(out)
    table, payload = records_csv(rows), json_bytes(jsonable({"rows": list(rows), **(extra or {})}))
    names = (name, *also_as)
    return publish({**{out / f"{each}.csv": table for each in names},
                    **{out / file: data for file, data in (files or {}).items()},
                    **{out / f"{each}.json": payload for each in reversed(names)}})
