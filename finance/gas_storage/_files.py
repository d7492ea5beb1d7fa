"""The storage contract's files: a facility JSON and a forward-curve CSV, and the built-in sample
of each. Plain Python and NumPy, so the CLI can list and read them without importing JAX."""

import csv
import io
import json
import os
import pathlib
from importlib.resources import files

import numpy as np

from snapo_ode import InputError

def _read_text(path, what: str) -> str:
    try:
        return pathlib.Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{what} file {str(path)!r} does not exist.") from None
    except IsADirectoryError:
        raise InputError(f"{what} file {str(path)!r} is a directory.") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{what} file {str(path)!r} cannot be read as text: {error}.") from None


def load_facility(path: str | os.PathLike) -> dict:
    """Read a facility JSON file (its fields are checked by `make_inputs`).

    **Raises:** `InputError` naming the file for a missing file, invalid JSON or not an object."""
    try:
        facility = json.loads(_read_text(path, "facility"))
    except json.JSONDecodeError as error:
        raise InputError(f"facility file {path}: not valid JSON ({error}).") from None
    if not isinstance(facility, dict):
        raise InputError(f"facility file {path}: expected a JSON object of fields.")
    return facility


def load_curve(path: str | os.PathLike) -> np.ndarray:
    """Read a forward-curve CSV with header `day,price` and days 0..T-1 in order; prices [$/MMBtu].

    **Raises:** `InputError` naming the file, and the line, for a missing file, a wrong header, a
    day or price that is not a number, or days out of order."""
    reader = csv.reader(io.StringIO(_read_text(path, "curve")))
    header = next(reader, None)
    if header is None or [f.strip() for f in header] != ["day", "price"]:
        raise InputError(f"curve file {path}: the header must be 'day,price'; got {header}.")
    days, prices = [], []
    for line, row in enumerate(reader, start=2):
        if not row:
            continue
        if len(row) != 2:
            raise InputError(f"curve file {path}, line {line}: expected 'day,price'; got {','.join(row)!r}.")
        try:
            days.append(float(row[0]))
            prices.append(float(row[1]))
        except ValueError:
            raise InputError(f"curve file {path}, line {line}: day = {row[0]!r} or price = {row[1]!r} is not a "
                             "number.") from None
        if days[-1] != len(days) - 1:
            raise InputError(f"curve file {path}, line {line}: day = {row[0]!r}; days must be 0, 1, ..., T-1 in "
                             f"order, so this one must be {len(days) - 1}.")
    return np.asarray(prices)


def sample_facility() -> dict:
    """The built-in sample facility (1 million MMBtu, concave ratchets)."""
    return load_facility(files("finance") / "data" / "sample_facility.json")


def sample_curve() -> np.ndarray:
    """The built-in sample 365-day seasonal forward curve [$/MMBtu], starting 1 April."""
    return load_curve(files("finance") / "data" / "sample_curve.csv")
