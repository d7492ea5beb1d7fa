"""One reading path for user files: YAML read as YAML 1.2's core schema and nothing more, numbers
in CSV cells and JSON read by one rule, and tables and archives bounded from their metadata before
they are expanded. Every refusal is one `InputError` line naming the file, the line, the value's
text and what is allowed.

YAML (`read_yaml`): the document is built from the parser's events, so no constructor of a YAML
library ever runs on user input. A plain scalar is, as YAML 1.2's core schema says:
- null: `null`, `Null`, `NULL`, `~` or nothing; a boolean: `true`/`false` (also `True`, `TRUE`, ...);
- an integer: decimal digits with an optional sign, or `0x` hexadecimal or `0o` octal digits;
- a float: `[-+]?(.digits|digits(.digits?)?)([eE][-+]?digits)?`, `.inf`, `-.inf`, `.nan`;
- anything else text: `0.02_5`, `6_0`, `2026-02-30`, `yes`, `0b11` are strings (YAML 1.1's
  underscores, dates, sexagesimals and yes/no are gone), so a field that wants a number refuses them.
Quoted and block scalars are text. The explicit tags `!!str`, `!!int`, `!!float`, `!!bool`,
`!!null`, `!!map` and `!!seq` are honoured (a value that does not match its tag is refused); every
other tag (`!!timestamp`, `!!binary`, `!!omap`, `!!set`, `!!pairs`, `!!python/...`, `!local`) is
refused. Aliases (`*name`) are refused, so nothing is expanded; a key given twice, a key that is
not a scalar and a second document are refused. A settings file (a fund, a process) is at most `MAX_YAML_BYTES`
long: the pure-Python parser reads about 60 KB a second, so that bound keeps its work to seconds.
Bounds, checked as the events arrive (so a hostile
file stops at the first event past one, not after it is read): nesting depth `MAX_DEPTH`, nodes
`MAX_NODES`, a scalar's length `MAX_SCALAR_CHARS`, a number's text `MAX_NUMBER_CHARS` (which also
keeps integers far below Python's 4,300-digit conversion limit).

The same number rule everywhere: `number_text` (a CSV cell, a JSON number) accepts decimals only,
as JSON and CSV write them; YAML adds only its core schema's `0x`/`0o` integers and `.inf`/`.nan`
(which every schema then refuses as not finite).

Cantera's YAML (`check_cantera_yaml`): read through the same events before Cantera sees it, with
the same bounds on depth, nodes and scalars. Cantera expands aliases itself, so a mechanism's
aliases (a shared rate table, `&high {A: ...}` then `*high`) are counted in bytes as Cantera would
expand them, and the file is refused past `EXPANSION_LIMIT` times its own size (plus
`EXPANSION_SLACK`), or for an alias inside the node it names (`&r [1, *r]`, which Cantera expands
without end, into a crash) or naming no anchor.

Archives and tables (`check_npz`, `check_parquet`): the sizes are read from the zip directory
and each array's header, or the Parquet footer, and refused past a bound before anything is
decompressed or allocated; pickled arrays are refused.
"""

import math
import re
import zipfile

from .validation import InputError

MAX_YAML_BYTES = 256 * 2**10  # a settings file in YAML (a fund, a process): 64 times the largest shipped
MAX_DEPTH = 64  # nesting of mappings and sequences
MAX_NODES = 2_000_000  # scalars and collections in one YAML file (a large Cantera mechanism: ~3e5)
MAX_SCALAR_CHARS = 100_000  # the longest string a YAML file may hold
MAX_NUMBER_CHARS = 100  # the longest text of a number (an integer: at most 100 digits)
EXPANSION_LIMIT = 10  # a mechanism's aliases may expand it to 10 times its bytes (+ EXPANSION_SLACK)
EXPANSION_SLACK = 2**20

_CORE = "tag:yaml.org,2002:"
_NULL = re.compile(r"null|Null|NULL|~|")
_TRUE, _FALSE = re.compile(r"true|True|TRUE"), re.compile(r"false|False|FALSE")
_INTEGER = re.compile(r"[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+")
_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")
_INFINITY = re.compile(r"([-+]?)\.(inf|Inf|INF)")
_NAN = re.compile(r"\.(nan|NaN|NAN)")
_SURROGATE = re.compile("[\ud800-\udfff]")
DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)
"""A decimal number as JSON and CSV write one: no `_` separators, no `nan`, `inf` or hex."""


def _shown(text: str) -> str:
    return repr(text) if len(text) <= 60 else repr(text[:57]) + "..."


def _number(text: str, where: str):
    """The int or float of a plain YAML scalar matching the core schema's number forms."""
    if len(text) > MAX_NUMBER_CHARS:
        raise InputError(f"{where}: a number written with {len(text):,} characters ({_shown(text)}); allowed: at most "
                         f"{MAX_NUMBER_CHARS}.")
    if text.startswith("0x"):
        return int(text[2:], 16)
    if text.startswith("0o"):
        return int(text[2:], 8)
    return int(text) if _INTEGER.fullmatch(text) else float(text)


def resolve_plain(text: str, where: str):
    """A plain (unquoted, untagged) YAML scalar as YAML 1.2's core schema reads it: None, a bool,
    an int, a float or the text itself (see the module docstring)."""
    if _NULL.fullmatch(text):
        return None
    if _TRUE.fullmatch(text) or _FALSE.fullmatch(text):
        return _TRUE.fullmatch(text) is not None
    if _INTEGER.fullmatch(text) or _FLOAT.fullmatch(text):
        return _number(text, where)
    infinity = _INFINITY.fullmatch(text)
    if infinity:
        return -math.inf if infinity.group(1) == "-" else math.inf
    if _NAN.fullmatch(text):
        return math.nan
    return text


def _tagged(tag: str, text: str, where: str):
    """A scalar with an explicit core tag (`!!int 3`); any other tag is refused."""
    kind = tag.removeprefix(_CORE) if tag.startswith(_CORE) else None
    if kind == "str":
        return text
    value = resolve_plain(text, where)
    expected = {"int": int, "float": (int, float), "bool": bool, "null": type(None)}.get(kind)
    if expected is None:
        raise InputError(f"{where}: the YAML tag {_tag_name(tag)} on {_shown(text)} is not read; write the value "
                         "plainly (a number, true/false, null or text).")
    if not isinstance(value, expected) or (kind in ("int", "float") and isinstance(value, bool)):
        raise InputError(f"{where}: {_shown(text)} is not a YAML {kind}.")
    return float(value) if kind == "float" else value


def _tag_name(tag: str) -> str:
    return "!!" + tag.removeprefix(_CORE) if tag.startswith(_CORE) else tag


def _events(text: str, where: str, aliases: bool = False):
    """The parser's events of `text`, bounded (see the module docstring): a generator that raises
    `InputError` (file, line) at the first event past a bound, a parse error, or an alias unless
    `aliases` (then the caller bounds them)."""
    from ruamel.yaml import YAML, YAMLError
    from ruamel.yaml.events import AliasEvent, CollectionEndEvent, CollectionStartEvent, ScalarEvent

    depth = nodes = 0
    events = YAML(typ="safe", pure=True).parse(text)
    try:
        for event in events:
            line = f"{where}, line {event.start_mark.line + 1}"
            if isinstance(event, AliasEvent) and not aliases:
                raise InputError(f"{line}: a YAML alias (*{event.anchor}); write the value out instead (aliases are "
                                 "not expanded).")
            if isinstance(event, (ScalarEvent, CollectionStartEvent)):
                nodes += 1
                if nodes > MAX_NODES:
                    raise InputError(f"{line}: more than {MAX_NODES:,} YAML values; allowed: at most {MAX_NODES:,}.")
            if isinstance(event, CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    raise InputError(f"{line}: nested more than {MAX_DEPTH} levels deep; allowed: at most {MAX_DEPTH}.")
            elif isinstance(event, CollectionEndEvent):
                depth -= 1
            elif isinstance(event, ScalarEvent):
                if len(event.value) > MAX_SCALAR_CHARS:
                    raise InputError(f"{line}: a value of {len(event.value):,} characters; allowed: at most "
                                     f"{MAX_SCALAR_CHARS:,}.")
                if _SURROGATE.search(event.value):
                    raise InputError(f"{line}: an escape of half a UTF-16 pair (\\ud800-\\udfff) in "
                                     f"{_shown(event.value)}; write the character itself.")
            yield event, line
    except YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        at = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise InputError(f"{where}{at}: not valid YAML ({' '.join(str(problem).split())}).") from None


def check_cantera_yaml(text: str, where: str) -> None:
    """Raise `InputError` (file, line) unless `text` is YAML that Cantera can be handed: nesting,
    node count, scalar and number lengths within the bounds, aliases acyclic and their expansion
    bounded in bytes (module docstring). Tags and scalars are left to Cantera's own reader."""
    from ruamel.yaml.events import AliasEvent, CollectionEndEvent, CollectionStartEvent, ScalarEvent

    limit = EXPANSION_LIMIT * len(text.encode()) + EXPANSION_SLACK
    anchored: dict[str, int] = {}  # anchor -> the bytes its node expands to
    open_nodes = [[None, 0]]  # [anchor, bytes so far] of each collection being read
    total = 0
    for event, line in _events(text, where, aliases=True):
        if isinstance(event, CollectionStartEvent):
            open_nodes.append([event.anchor, 2])
            continue
        if isinstance(event, AliasEvent):
            if any(anchor == event.anchor for anchor, _ in open_nodes):
                raise InputError(f"{line}: the YAML alias *{event.anchor} lies inside the node it names, so it never "
                                 "ends; write the value out.")
            if event.anchor not in anchored:
                raise InputError(f"{line}: the YAML alias *{event.anchor} names no anchor before it.")
            size, anchor = anchored[event.anchor], None
        elif isinstance(event, ScalarEvent):
            if event.style is None and (_INTEGER.fullmatch(event.value) or _FLOAT.fullmatch(event.value)):
                _number(event.value, line)
            size, anchor = len(event.value) + 2, event.anchor
        elif isinstance(event, CollectionEndEvent):
            anchor, size = open_nodes.pop()
        else:
            continue
        if anchor is not None:
            anchored[anchor] = size
        open_nodes[-1][1] += size
        total += size if isinstance(event, AliasEvent) else 0
        if total > limit:
            raise InputError(f"{line}: its YAML aliases (*name) expand it past {EXPANSION_LIMIT} times its own size "
                             "(Cantera would expand them all in memory); write the aliased content out in full.")


def read_yaml(text: str, where: str):
    """`text` as plain data (dicts, lists, str, int, float, bool, None) by YAML 1.2's core schema,
    restricted and bounded as the module docstring says; `where` names the file in errors.

    **Raises:** `InputError` with the line for invalid YAML, a bound passed, an alias, a refused
    tag, a key given twice or not a scalar, or a second document."""
    from ruamel.yaml.events import (DocumentStartEvent, MappingEndEvent, MappingStartEvent, ScalarEvent,
                                    SequenceEndEvent, SequenceStartEvent)

    stack: list = []  # open collections: [container, pending key or _NO_KEY]
    documents, result = 0, None
    for event, line in _events(text, where):
        tag = None if getattr(event, "tag", None) is None else str(event.tag)
        if isinstance(event, DocumentStartEvent):
            documents += 1
            if documents > 1:
                raise InputError(f"{line}: a second YAML document; a file holds one.")
            continue
        if isinstance(event, ScalarEvent):
            if tag is None:
                value = resolve_plain(event.value, line) if event.style is None else event.value
            else:
                value = event.value if tag == "!" else _tagged(tag, event.value, line)
        elif isinstance(event, (MappingStartEvent, SequenceStartEvent)):
            kind = "map" if isinstance(event, MappingStartEvent) else "seq"
            if tag not in (None, "!", _CORE + kind):
                raise InputError(f"{line}: the YAML tag {_tag_name(tag)} is not read; write a plain "
                                 f"{'mapping' if kind == 'map' else 'list'}.")
            stack.append([{} if kind == "map" else [], _NO_KEY])
            continue
        elif isinstance(event, (MappingEndEvent, SequenceEndEvent)):
            value = stack.pop()[0]
        else:
            continue
        if not stack:
            result = value
            continue
        container, key = stack[-1]
        if isinstance(container, list):
            container.append(value)
        elif key is _NO_KEY:
            if isinstance(value, (dict, list)):
                raise InputError(f"{line}: a key that is a mapping or a list; keys are plain values.")
            if value in container:
                raise InputError(f"{line}: the key {value!r} is given twice.")
            stack[-1][1] = value
        else:
            container[key] = value
            stack[-1][1] = _NO_KEY
    return result


_NO_KEY = object()


def number_text(text: str, where: str, field: str) -> float:
    """The float of `text` (a CSV cell, stripped), a decimal number as JSON and CSV write one.

    **Raises:** `InputError` naming `where`, `field` and the text for anything else (`1_000`,
    `0x10`, `nan`, `inf`, words) or a number written with more than MAX_NUMBER_CHARS characters."""
    text = text.strip()
    if DECIMAL.fullmatch(text) is None:
        raise InputError(f"{where}: {field} = {_shown(text)} is not a decimal number (such as 3.25 or 1e-3).")
    if len(text) > MAX_NUMBER_CHARS:
        raise InputError(f"{where}: {field} is written with {len(text):,} characters; allowed: at most "
                         f"{MAX_NUMBER_CHARS}.")
    return float(text)


def whole_text(text: str, where: str, field: str, low: int = 0) -> int:
    """The int of `text` (stripped): ASCII digits only, at most MAX_NUMBER_CHARS of them, >= `low`.

    **Raises:** `InputError` naming `where`, `field`, the text and what is allowed."""
    text = text.strip()
    if not (text.isascii() and text.isdigit()) or len(text) > MAX_NUMBER_CHARS or int(text) < low:
        raise InputError(f"{where}: {field} = {_shown(text)}; allowed: a whole number >= {low} (digits only).")
    return int(text)


def check_npz(path, where: str, max_values: int, names: tuple[str, ...]) -> None:
    """Raise `InputError` unless the NPZ archive `path` holds only plain `.npy` arrays (no
    pickled objects) named `names`, whose headers declare at most `max_values` entries in all:
    read from the zip directory and each array's header, before anything is decompressed
    beyond those headers."""
    from numpy.lib import format as npy

    total = 0
    try:
        with zipfile.ZipFile(path) as archive:
            for member in archive.infolist():
                name = member.filename.removesuffix(".npy")
                if name not in names:
                    raise InputError(f"{where}: an entry {member.filename!r}; an NPZ scenario file holds only "
                                     f"{', '.join(names)}.")
                with archive.open(member) as handle:
                    version = npy.read_magic(handle)
                    shape, _, dtype = (npy.read_array_header_1_0 if version == (1, 0)
                                       else npy.read_array_header_2_0)(handle, max_header_size=10_000)
                if dtype.hasobject:
                    raise InputError(f"{where}: the array {name!r} holds Python objects (a pickle); allowed: numbers "
                                     "or text.")
                total += math.prod(shape) * max(1, dtype.itemsize // 8)
                if total > max_values:
                    raise InputError(f"{where}: its arrays declare more than {max_values:,} values (the array "
                                     f"{name!r} has shape {shape}); allowed: at most {max_values:,}.")
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as error:
        raise InputError(f"{where}: not a readable NPZ file ({type(error).__name__}: {error}).") from None


def check_parquet(path, where: str, max_rows: int, max_bytes: int) -> None:
    """Raise `InputError` unless the Parquet file `path` declares in its footer at most
    `max_rows` rows and `max_bytes` uncompressed bytes (read before any column is decoded)."""
    import pyarrow
    import pyarrow.parquet as pq

    try:
        metadata = pq.ParquetFile(path).metadata
    except (OSError, pyarrow.ArrowException) as error:
        raise InputError(f"{where}: not a readable Parquet file ({' '.join(str(error).split())[:200]}).") from None
    size = sum(metadata.row_group(i).total_byte_size for i in range(metadata.num_row_groups))
    if metadata.num_rows > max_rows or size > max_bytes:
        raise InputError(f"{where}: {metadata.num_rows:,} rows, {size:,} bytes uncompressed; allowed: at most "
                         f"{max_rows:,} rows and {max_bytes:,} bytes.")
