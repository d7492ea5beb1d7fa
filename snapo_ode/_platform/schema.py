"""Reading user files strictly: text of bounded size, JSON without duplicate keys or non-standard
numbers, and records checked by a pydantic schema, every failure one `InputError` line naming the
file, the line, the field, the value and what is allowed.

JSON as RFC 8259 defines it: `NaN`, `Infinity` and a key given twice are refused (Python's `json`
accepts the first two and keeps the last of the duplicates). Types are the schema's, strictly:
`true` is not a number and `"1e6"` is a string (pydantic's strict mode).
"""

import datetime
import json
import os
import pathlib
import re
from collections.abc import Sequence
from typing import Annotated

import pydantic

from .reading import MAX_DEPTH, MAX_NUMBER_CHARS, read_yaml
from .validation import InputError, _shorten

MAX_FILE_BYTES = 64 * 2**20  # a user file larger than this is refused before it is parsed
STRICT_SCHEMA = pydantic.ConfigDict(strict=True, extra="forbid", frozen=True)


def read_text(path: str | os.PathLike, what: str, max_bytes: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of the `what` file `path` (e.g. "facility"), at most `max_bytes` long.

    **Raises:** `InputError` naming the file for a missing, oversized or unreadable one."""
    path = pathlib.Path(path)
    try:
        with open(path, "rb") as handle:
            data = handle.read(max_bytes + 1)
    except FileNotFoundError:
        raise InputError(f"{what} file {str(path)!r} does not exist.") from None
    except IsADirectoryError:
        raise InputError(f"{what} file {str(path)!r} is a directory.") from None
    except OSError as error:
        raise InputError(f"{what} file {str(path)!r} cannot be read: {error.strerror or error}.") from None
    if len(data) > max_bytes:
        raise InputError(f"{what} file {str(path)!r} is larger than {max_bytes:,} bytes, the most a {what} file "
                         "may be.")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise InputError(f"{what} file {str(path)!r} is not UTF-8 text ({error.reason} at byte {error.start}).") from None


def _unique(pairs):
    seen = {}
    for key, value in pairs:
        if key in seen:
            raise InputError(f"the key {key!r} is given twice")
        seen[key] = value
    return seen


def _json_number(kind):
    def parse(text: str):
        if len(text) > MAX_NUMBER_CHARS:
            raise InputError(f"a number written with {len(text):,} characters; allowed: at most {MAX_NUMBER_CHARS}")
        return kind(text)
    return parse


def _depth(value) -> int:
    """How deeply `value` (parsed JSON) nests lists and dicts, counted without recursion."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, (dict, list)):
            deepest = max(deepest, depth + 1)
            stack.extend((child, depth + 1) for child in (node.values() if isinstance(node, dict) else node))
    return deepest


def _refuse_constant(name):
    raise InputError(f"{name} is not a JSON number (JSON numbers are finite)")


def strict_json(text: str, where: str):
    """Parse `text` as strict JSON (see the module docstring); `where` names it in errors.

    **Raises:** `InputError` with the line for invalid JSON, a duplicate key, NaN or Infinity,
    or nesting too deep to read."""
    try:
        value = json.loads(text, object_pairs_hook=_unique, parse_constant=_refuse_constant,
                           parse_int=_json_number(int), parse_float=_json_number(float))
    except json.JSONDecodeError as error:
        raise InputError(f"{where}, line {error.lineno}: not valid JSON ({error.msg}).") from None
    except InputError as error:
        raise InputError(f"{where}: {error}.") from None
    except RecursionError:
        raise InputError(f"{where}: nested too deeply to read.") from None
    if _depth(value) > MAX_DEPTH:
        raise InputError(f"{where}: nested more than {MAX_DEPTH} levels deep; allowed: at most {MAX_DEPTH}.")
    return value


def line_of(text: str | None, location: Sequence) -> str:
    """', line N' of the last key of `location` (a field's path, e.g. ["market", "key_rates"])
    that occurs in `text` as a JSON or YAML key (its first occurrence), or "" where none does:
    for errors found after a file's schema, so that they name the line too."""
    names = [str(part) for part in location if isinstance(part, str)]
    if text is None or not names:
        return ""
    match = re.search(rf"""["']?{re.escape(names[-1])}["']?\s*:""", text)
    return "" if match is None else f", line {text.count(chr(10), 0, match.start()) + 1}"


def validate(model: type[pydantic.BaseModel], data, where: str, text: str | None = None):
    """`model.model_validate(data)`, or `InputError` naming `where` (the file), the line (found
    in `text`), the field, its value and what the schema allows; the count of further errors."""
    try:
        return model.model_validate(data)
    except pydantic.ValidationError as error:
        errors = error.errors(include_url=False)
        first = errors[0]
        field = ".".join(str(part) for part in first["loc"]) or "the file"
        more = f" ({len(errors) - 1} more error{'s' * (len(errors) > 2)})" if len(errors) > 1 else ""
        value = "" if first["type"] == "missing" else f" = {_shorten(first.get('input'))}"
        raise InputError(f"{where}{line_of(text, first['loc'])}: {field}{value}: {first['msg']}{more}.") from None


def strict_yaml(text: str, where: str):
    """Parse `text` as YAML into plain data (dicts, lists, str, int, float, bool, None) by YAML
    1.2's core schema, restricted and bounded (`reading.read_yaml`: no aliases, no tags beyond the
    core ones, no dates, a key given twice refused); `where` names it in errors. NaN and
    infinities parse and are left to the schema (`FiniteNumber` refuses them).

    **Raises:** `InputError` with the line for invalid YAML or anything `read_yaml` refuses."""
    return read_yaml(text, where)


def _iso_date(value):
    if isinstance(value, str):
        try:
            return datetime.date.fromisoformat(value) if re.fullmatch(r"\d{4}-\d{2}-\d{2}", value) else value
        except ValueError:
            raise ValueError(f"{value!r} is not a date of the calendar") from None
    return value


IsoDate = Annotated[datetime.date, pydantic.BeforeValidator(_iso_date)]
"""A date in a user file: the text YYYY-MM-DD of a day of the calendar (YAML dates are text)."""

FiniteNumber = pydantic.confloat(strict=True, allow_inf_nan=False)
"""A number in a user file: an integer or a decimal, finite (never NaN, an infinity, a string or a
boolean)."""
