"""Hostile documents for every user-file loader, generated from the loader's own schema: a field
of the document (any field its schema or its shipped sample has, at any depth) given a value of
the wrong type, an edge number, a YAML tag, deep nesting or a huge size; for tables, a cell or a
column; for archives, their headers. Used by tests/test_reading_hostile.py."""

import io
import json
import math
import zipfile

import numpy as np
import pydantic
from hypothesis import strategies as st

# Values written as YAML text: each is one class of what a careless or hostile user gives.
WRONG_TYPES = ["abc", "''", "[]", "{}", "{a: 1}", "null", "~", "true", "[1, 2]", "[[1, 2], [3]]", "'0.5'", "-"]
EDGE_NUMBERS = ["0", "-0.0", "-1", "1e308", "-1e308", "1e-320", "1e400", "-1e400", ".nan", ".inf", "-.inf", "0x10",
                "0o17", "0xFFFFFFFFFFFFFFFFFFFFFFFF", "0.02_5", "6_0", "0.4_5", "1_000", "+.5", "0b11", "1:30",
                "9" * 101, "9" * 5000, "1" + "0" * 400 + ".5", "1e99999999", "2026-02-30", "2026-13-01",
                "2026-01-01T00:00:00Z", "12:30:00", "yes", "off", "NaN", "Infinity", "0.1.2", "１２"]
YAML_TAGS = ["!!omap [a: 1, b: 2]", "!!set {a, b}", "!!binary aGVsbG8=", "!!timestamp 2026-01-01", "!!pairs [a: 1]",
             "!!python/object/apply:os.system ['true']", "!!python/name:os.system", "!local 1", "!!float abc",
             "!!int 0.5", "!!int 0x10", "!!bool maybe", "!!null 0", "!!str 1", "!!float 1", "&a 1", "*a",
             "&r [1, *r]", "{<<: {a: 1}}", "!!map {a: 1}", "!!seq [1]", "? [1]\n  : 2", "|\n  block text"]


def nested(depth: int) -> str:
    return "[" * depth + "1" + "]" * depth


@st.composite
def hostile_yaml_value(draw) -> str:
    """One hostile value as YAML flow text."""
    kind = draw(st.sampled_from(["type", "number", "tag", "nesting", "size", "text"]))
    if kind == "type":
        return draw(st.sampled_from(WRONG_TYPES))
    if kind == "number":
        return draw(st.sampled_from(EDGE_NUMBERS))
    if kind == "tag":
        return draw(st.sampled_from(YAML_TAGS))
    if kind == "nesting":
        return nested(draw(st.sampled_from([10, 63, 64, 65, 200, 3000])))
    if kind == "size":  # strings past the scalar bound and the settings-file bound; a long list (the pure-Python
        # parser reads some 10,000 values a second, so longer lists only cost time)
        return draw(st.sampled_from(["x" * 1_000, "x" * 100_001, "x" * 300_000, "[" + ", ".join(["0.5"] * 2_000) + "]"]))
    return json.dumps(draw(st.text(max_size=20)))  # any short string, quoted


def schema_paths(model: type[pydantic.BaseModel], prefix=()) -> list[tuple]:
    """Every field path of `model`, descending into nested models (also inside lists and
    optionals; a list's entries are addressed by 0)."""
    paths = []
    for name, field in model.model_fields.items():
        paths.append((*prefix, name))
        for inner in _models_in(field.annotation):
            paths.extend(schema_paths(inner, (*prefix, name, *([0] if _is_list(field.annotation) else []))))
    return paths


def _models_in(annotation) -> list:
    if isinstance(annotation, type) and issubclass(annotation, pydantic.BaseModel):
        return [annotation]
    return [m for arg in getattr(annotation, "__args__", ()) for m in _models_in(arg)]


def _is_list(annotation) -> bool:
    return getattr(annotation, "__origin__", None) is list or any(_is_list(a) for a in getattr(annotation, "__args__", ()))


def data_paths(data, prefix=()) -> list[tuple]:
    """Every path into `data` (a parsed document): keys of mappings and indices of lists."""
    paths = []
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        paths.append((*prefix, key))
        paths.extend(data_paths(value, (*prefix, key)))
    return paths


class _Raw(str):
    """YAML text put into a document as written (not quoted)."""


def yaml_text(data, indent: int = 0) -> str:
    """`data` (with `_Raw` leaves) as block YAML."""
    pad = " " * indent
    if isinstance(data, dict):
        return "".join(f"{pad}{json.dumps(str(k)) if not isinstance(k, _Raw) else k}:{_child(v, indent)}"
                       for k, v in data.items()) or f"{pad}{{}}\n"
    if isinstance(data, list):
        return "".join(f"{pad}-{_child(v, indent)}" for v in data) or f"{pad}[]\n"
    return f"{pad}{_scalar(data)}\n"


def _child(value, indent: int) -> str:
    if isinstance(value, (dict, list)) and value:
        return "\n" + yaml_text(value, indent + 2)
    text = _scalar(value) if not isinstance(value, (dict, list)) else ("{}" if isinstance(value, dict) else "[]")
    if "\n" in text:  # a multi-line raw value (a block scalar, a complex key): indented under its key
        return " " + text.replace("\n", "\n" + " " * (indent + 2)) + "\n"
    return f" {text}\n"


def _scalar(value) -> str:
    if isinstance(value, _Raw):
        return str(value)
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else (".nan" if math.isnan(value) else f"{'-' * (value < 0)}.inf")
    return json.dumps(value) if isinstance(value, str) else str(value)


def with_value(data, path: tuple, value):
    """A copy of `data` with the node at `path` set to `value` (created where the path's last key
    is missing from a mapping; the list entry 0 where the list is empty)."""
    if not path:
        return value
    head, rest = path[0], path[1:]
    if isinstance(data, dict):
        return {**data, head: with_value(data.get(head), rest, value)}
    if isinstance(data, list) and isinstance(head, int):
        copy = list(data) or [None]
        copy[min(head, len(copy) - 1)] = with_value(copy[min(head, len(copy) - 1)], rest, value)
        return copy
    return {head: with_value(None, rest, value)}


def without(data, path: tuple):
    """A copy of `data` without the node at `path` (unchanged where there is none)."""
    if not path or not isinstance(data, (dict, list)):
        return data
    head, rest = path[0], path[1:]
    if isinstance(data, dict):
        if head not in data:
            return data
        return {k: v for k, v in data.items() if k != head} if not rest else {**data, head: without(data[head], rest)}
    if not isinstance(head, int) or head >= len(data):
        return data
    return [x for i, x in enumerate(data) if i != head] if not rest else [
        without(x, rest) if i == head else x for i, x in enumerate(data)]


@st.composite
def hostile_document(draw, sample: dict, model: type[pydantic.BaseModel]) -> str:
    """The YAML text of `sample` with one field (from `model`'s schema or the sample itself) given
    a hostile value, dropped, or given twice; or a hostile whole document."""
    paths = sorted(set(schema_paths(model)) | set(data_paths(sample)), key=repr)
    path = draw(st.sampled_from(paths))
    kind = draw(st.sampled_from(["value", "value", "value", "drop", "twice", "whole"]))
    if kind == "drop":
        return yaml_text(without(sample, path))
    if kind == "twice":
        return yaml_text(sample) + yaml_text({path[0]: sample.get(path[0])})
    if kind == "whole":
        return draw(st.sampled_from([_Raw(v) for v in WRONG_TYPES + YAML_TAGS] + [nested(3000), "", "--- 1\n--- 2\n"]))
    return yaml_text(with_value(sample, path, _Raw(draw(hostile_yaml_value()))))


# Cells of a CSV or JSON number field: edge numbers as the text of the cell.
HOSTILE_CELLS = ["", " ", "nan", "NaN", "inf", "-inf", "1e400", "-1e400", "0x10", "1_000", "6_0", "+-1", "1e", ".",
                 "9" * 101, "9" * 5000, "1" + "0" * 400, "١٢", "１２", "1,5", '"7"', "true", "null", "2026-02-30",
                 "\x00", "1e-320", "-0", "1e308", "x" * 10_000]


@st.composite
def hostile_json_value(draw):
    """One hostile JSON value as text."""
    kind = draw(st.sampled_from(["type", "number", "nesting", "size"]))
    if kind == "type":
        return draw(st.sampled_from(['"abc"', '""', "[]", "{}", '{"a": 1}', "null", "true", "[1, 2]", "[[1]]",
                                     '"0.5"', "[[0.0, 1.0], [0.5]]", "[[1.0, 1.0], [0.0, 1.0]]"]))
    if kind == "number":
        return draw(st.sampled_from(["0", "-0.0", "-1", "1e308", "-1e308", "1e-320", "1e400", "NaN", "Infinity",
                                     "-Infinity", "9" * 101, "9" * 5000, "1" + "0" * 400 + ".5", "0x10", "1_000",
                                     "01", "+1", ".5", "1.", "1e99999999"]))
    if kind == "nesting":
        depth = draw(st.sampled_from([63, 64, 65, 3000, 100_000]))
        return "[" * depth + "]" * depth
    return draw(st.sampled_from(['"' + "x" * 100_000 + '"', "[" + ", ".join(["1.0"] * 50_000) + "]"]))


@st.composite
def hostile_json_document(draw, sample: dict) -> str:
    """The JSON text of `sample` with one field given a hostile value, dropped or given twice."""
    paths = sorted(data_paths(sample), key=repr)
    path = draw(st.sampled_from(paths))
    kind = draw(st.sampled_from(["value", "value", "value", "drop", "twice", "cut"]))
    if kind == "drop":
        return json.dumps(without(sample, path))
    if kind == "twice":
        return json.dumps(sample)[:-1] + f', "{path[0]}": 1}}'
    if kind == "cut":
        text = json.dumps(sample)
        return text[:draw(st.integers(0, len(text)))]
    marker = "\x00HOSTILE\x00"
    return json.dumps(with_value(sample, path, marker)).replace(json.dumps(marker), draw(hostile_json_value()))


@st.composite
def hostile_csv(draw, text: str) -> str:
    """`text` (a CSV with a header) with one cell hostile, a row cut or widened, the header
    changed, or a huge row."""
    lines = text.splitlines()
    kind = draw(st.sampled_from(["cell", "cell", "cell", "row", "header", "huge"]))
    row = draw(st.integers(1, len(lines) - 1))
    cells = lines[row].split(",")
    if kind == "cell":
        cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(HOSTILE_CELLS))
    elif kind == "row":
        cells = draw(st.sampled_from([cells[:-1], cells + ["1"], ["x"], [], cells * 50]))
    elif kind == "header":
        lines[0] = draw(st.sampled_from(["", lines[0].upper(), lines[0] + ",extra", ",".join(reversed(lines[0].split(","))),
                                         lines[0].replace(",", ";"), "\ufeff" + lines[0]]))
    else:
        cells = cells + ["1"] * draw(st.sampled_from([1_000, 100_000]))
    lines[row] = ",".join(cells)
    return "\n".join(lines) + "\n"


def npy_bytes(shape, dtype="<f8", data: bytes = b"", version=(1, 0)) -> bytes:
    """A .npy file whose header declares `shape` and `dtype`, followed by `data` (which may be
    much shorter than the header says)."""
    from numpy.lib import format as npy

    buffer = io.BytesIO()
    header = {"descr": dtype, "fortran_order": False, "shape": tuple(shape)}
    (npy.write_array_header_1_0 if version == (1, 0) else npy.write_array_header_2_0)(buffer, header)
    return buffer.getvalue() + data


@st.composite
def hostile_npz(draw, arrays: dict[str, np.ndarray]) -> bytes:
    """An NPZ archive of `arrays` with one hostile member: a header declaring a huge shape, an
    object (pickled) array, a wrong dtype or shape, an extra or missing member, a cut file."""
    members = {name: _npy(value) for name, value in arrays.items()}
    name = draw(st.sampled_from(sorted(arrays)))
    kind = draw(st.sampled_from(["huge", "pickle", "dtype", "shape", "extra", "missing", "cut", "value"]))
    if kind == "huge":
        members[name] = npy_bytes(draw(st.sampled_from([(2**40,), (10**6, 10**6, 1), (1_500_000_000,), (2**62, 2)])))
    elif kind == "pickle":
        members[name] = _npy(np.array([{"a": 1}, None], dtype=object), allow_pickle=True)
    elif kind == "dtype":
        dtype = draw(st.sampled_from(["complex128", "bool", "U3", "S3", "int8", "float16", "datetime64[s]"]))
        try:
            members[name] = _npy(arrays[name].astype(dtype))
        except (TypeError, ValueError):  # text that is no number: an array of that type and shape
            members[name] = _npy(np.zeros(arrays[name].shape, dtype))
    elif kind == "shape":
        members[name] = _npy(draw(st.sampled_from([np.zeros(()), np.zeros((0,)), np.zeros((1, 1, 1, 1)), np.zeros(7)])))
    elif kind == "extra":
        members[draw(st.sampled_from(["other", "../escape", "values.npy/x"]))] = _npy(np.zeros(3))
    elif kind == "missing":
        del members[name]
    elif kind == "value":
        values = np.array(arrays["values"], float)
        index = tuple(draw(st.integers(0, s - 1)) for s in values.shape)
        values[index] = draw(st.sampled_from([np.nan, np.inf, -1.0, 0.0, 1e-300, 1e300, 1e6, -1e6]))
        members["values"] = _npy(values)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for member, data in members.items():
            archive.writestr(f"{member}.npy", data)
    content = buffer.getvalue()
    return content[:draw(st.integers(0, len(content)))] if kind == "cut" else content


def _npy(array: np.ndarray, allow_pickle: bool = False) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=allow_pickle)
    return buffer.getvalue()
