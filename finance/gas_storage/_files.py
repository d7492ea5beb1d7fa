"""The storage contract's files: a facility JSON and a forward-curve CSV, and the built-in sample
of each. Plain Python and NumPy, so the CLI can list and read them without importing JAX."""

import csv
import json
import os
from importlib.resources import files

import numpy as np

from snapo_ode import InputError

def load_facility(path: str | os.PathLike) -> dict:
    """Read a facility JSON file."""
    try:
        with open(path) as handle:
            facility = json.load(handle)
    except json.JSONDecodeError as error:
        raise InputError(f"facility file {path}: not valid JSON ({error}).") from None
    if not isinstance(facility, dict):
        raise InputError(f"facility file {path}: expected a JSON object of fields.")
    return facility


def load_curve(path: str | os.PathLike) -> np.ndarray:
    """Read a forward-curve CSV with header `day,price` and days 0..T-1 in order; prices [$/MMBtu]."""
    with open(path, newline="") as handle:
        reader = csv.DictReader(handle)
        if reader.fieldnames is None or [f.strip() for f in reader.fieldnames] != ["day", "price"]:
            raise InputError(f"curve file {path}: the header must be 'day,price'; got {reader.fieldnames}.")
        rows = list(reader)
    try:
        days = np.array([float(row["day"]) for row in rows])
        prices = np.array([float(row["price"]) for row in rows])
    except (TypeError, ValueError) as error:
        raise InputError(f"curve file {path}: a day or price is not a number ({error}).") from None
    if not np.array_equal(days, np.arange(len(days))):
        raise InputError(f"curve file {path}: days must be 0, 1, ..., T-1 in order.")
    return prices


def sample_facility() -> dict:
    """The built-in sample facility (1 million MMBtu, concave ratchets)."""
    return load_facility(files("finance") / "data" / "sample_facility.json")


def sample_curve() -> np.ndarray:
    """The built-in sample 365-day seasonal forward curve [$/MMBtu], starting 1 April."""
    return load_curve(files("finance") / "data" / "sample_curve.csv")
