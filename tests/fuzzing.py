"""Helpers shared by the fuzz tests of the file loaders."""

from hypothesis import strategies as st

import snapo_ode


def loads_or_input_error(load):
    """`load()`, or None where it raises `InputError` (any other exception fails the test)."""
    try:
        return load()
    except snapo_ode.InputError:
        return None


def mutated_yaml_lines(data, lines: list[str], odd_values: list[str]) -> list[str]:
    """A copy of the YAML `lines` with one line, drawn by hypothesis's `data`, truncated, deleted,
    or given one of `odd_values` in place of its value."""
    lines = list(lines)
    kind = data.draw(st.sampled_from(["truncate", "swap", "delete"]))
    where = data.draw(st.integers(0, len(lines) - 1))
    if kind == "truncate":
        lines = lines[:where] + [lines[where][: data.draw(st.integers(0, len(lines[where])))]]
    elif kind == "delete":
        del lines[where]
    elif ":" in lines[where]:
        key = lines[where].split(":", 1)[0]
        lines[where] = f"{key}: {data.draw(st.sampled_from(odd_values))}\n"
    return lines
