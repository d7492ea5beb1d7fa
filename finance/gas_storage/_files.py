"""The storage contract's files: a facility JSON and a forward-curve CSV, and the built-in sample
of each. Plain Python, NumPy and pydantic, so the CLI can list and read them without importing JAX."""

import csv
import io
import os
from importlib.resources import files

import numpy as np
import pydantic

from snapo_ode import STRICT_SCHEMA, InputError, number_text, read_text, strict_json, validate

Number = float  # strict: an integer or a decimal, never a string or a boolean
RatchetTable = list[pydantic.conlist(Number, min_length=2, max_length=2)]  # rows [fill, rate]


class FacilityFile(pydantic.BaseModel):
    """A facility JSON file: every field of `FACILITY_FIELDS`, each a number (or a ratchet table
    of `[fill_fraction, rate_fraction]` rows) in the units of `StorageInputs`; no other field.
    Types are checked here, strictly; ranges by `make_inputs` (the same for Python callers)."""

    model_config = STRICT_SCHEMA
    capacity: Number
    initial_inventory: Number
    terminal_inventory_min: Number
    max_injection: Number
    max_withdrawal: Number
    injection_ratchet: RatchetTable
    withdrawal_ratchet: RatchetTable
    fuel_loss: Number
    injection_cost: Number
    withdrawal_cost: Number
    rate: Number


def load_facility(path: str | os.PathLike) -> dict:
    """Read a facility JSON file: strict JSON (`snapo_ode.strict_json`: no duplicate key, no NaN),
    the fields and types of `FacilityFile` (ranges are checked by `make_inputs`).

    **Raises:** `InputError` naming the file, the line, the field, its value and what is allowed."""
    where = f"facility file {path}"
    text = read_text(path, "facility")
    return validate(FacilityFile, strict_json(text, where), where, text).model_dump()


def load_curve(path: str | os.PathLike) -> np.ndarray:
    """Read a forward-curve CSV with header `day,price` and days 0..T-1 in order; prices [$/MMBtu]
    as decimal numbers (no `_` separators, `nan`, `inf` or words).

    **Raises:** `InputError` naming the file, and the line, for a missing file, a wrong header, a
    day or price that is not a number, or days out of order."""
    # Universal newlines: a lone carriage return (old spreadsheets) ends a line, as in any text reader.
    reader = csv.reader(io.StringIO(read_text(path, "curve"), newline=None))
    try:
        return _curve_rows(path, reader)
    except csv.Error as error:
        raise InputError(f"curve file {path}, line {reader.line_num}: not a CSV row ({error}).") from None


def _curve_rows(path, reader) -> np.ndarray:
    header = next(reader, None)
    if header is None or [f.strip() for f in header] != ["day", "price"]:
        raise InputError(f"curve file {path}: the header must be 'day,price'; got {header}.")
    prices = []
    for line, row in enumerate(reader, start=2):
        if not row:
            continue
        where = f"curve file {path}, line {line}"
        if len(row) != 2:
            raise InputError(f"{where}: expected 'day,price'; got {','.join(row)!r}.")
        day = number_text(row[0], where, "day")
        prices.append(number_text(row[1], where, "price"))
        if day != len(prices) - 1:
            raise InputError(f"{where}: day = {row[0]!r}; days must be 0, 1, ..., T-1 in order, so this one must be "
                             f"{len(prices) - 1}.")
    return np.asarray(prices)


def sample_facility() -> dict:
    """The built-in sample facility (1 million MMBtu, concave ratchets)."""
    return load_facility(files("finance") / "data" / "sample_facility.json")


def sample_curve() -> np.ndarray:
    """The built-in sample 365-day seasonal forward curve [$/MMBtu], starting 1 April."""
    return load_curve(files("finance") / "data" / "sample_curve.csv")
