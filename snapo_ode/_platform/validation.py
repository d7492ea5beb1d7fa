"""Input checks that run in Python, before anything is traced or compiled.

Every failure is an `InputError` that names the field, the value it had and what is allowed.
Value-dependent checks inside jitted code use `equinox.error_if` instead.
"""

import math
from collections.abc import Sequence

import numpy as np


class InputError(ValueError):
    """Bad user input: the message names the field, its value and the allowed range; always one
    line (its whitespace, such as the line breaks of a printed array, is collapsed)."""

    def __init__(self, message: object = "", *args):
        super().__init__(" ".join(str(message).split()), *args)


def _show(value) -> str:
    array = np.asarray(value)
    if array.ndim == 0:
        return f"{array.item()!r}"
    return np.array2string(array, threshold=8, precision=6)


def _shorten(value) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def check_finite(field: str, value) -> np.ndarray:
    """Raise unless every entry of `value` is a finite number; returns it as a float64 array."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{field} = {_shorten(value)} is not a number (or a regular array of numbers).") from None
    bad = ~np.isfinite(array)
    if bad.any():
        where = np.argwhere(bad)[0]
        index = f"[{', '.join(map(str, where))}]" if array.ndim else ""
        raise InputError(
            f"{field}{index} = {_show(array[tuple(where)])} is not a finite number; "
            f"every entry of {field} must be finite."
        )
    return array


def check_range(
    field: str,
    value,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
) -> np.ndarray:
    """Raise unless every entry of `value` is finite and in the interval from `low` to `high`.

    `low_open`/`high_open` exclude the end points. Returns the value as a float64 array.
    """
    array = check_finite(field, value)
    below = array <= low if low_open else array < low
    above = array >= high if high_open else array > high
    bad = below | above
    if bad.any():
        where = np.argwhere(bad)[0]
        index = f"[{', '.join(map(str, where))}]" if array.ndim else ""
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        raise InputError(
            f"{field}{index} = {_show(array[tuple(where)])} is outside the allowed range {interval}."
        )
    return array


def check_scalar(field: str, value, low: float = -math.inf, high: float = math.inf, *, low_open: bool = False,
                 high_open: bool = False) -> float:
    """`check_range` for one number: also raise when `value` is an array of several; returns a float."""
    array = check_range(field, value, low, high, low_open=low_open, high_open=high_open)
    if array.ndim != 0:
        raise InputError(f"{field} = {_shorten(value)} must be a single number; got shape {array.shape}.")
    return float(array)


def check_choice(field: str, value: str, allowed: Sequence[str]) -> str:
    """Raise unless `value` is one of `allowed`, listing the valid choices."""
    if value not in allowed:
        raise InputError(f"{field} = {value!r} is not one of: {', '.join(map(repr, allowed))}.")
    return value


def check_increasing(field: str, value, *, strict: bool = True) -> np.ndarray:
    """Raise unless the 1-D `value` is (strictly) increasing."""
    array = check_finite(field, value)
    steps = np.diff(array)
    bad = steps <= 0 if strict else steps < 0
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{field} must be {'strictly ' if strict else ''}increasing, but entry {i + 1} "
            f"({array[i + 1]:g}) follows {array[i]:g}."
        )
    return array


def check_count(field: str, value, low: int = 1, high: int | None = None) -> int:
    """Raise unless `value` is a whole number in [low, high] (bools refused); returns it as an int."""
    whole = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    if not whole or value < low or (high is not None and value > high):
        allowed = f"a whole number >= {low}" if high is None else f"a whole number in [{low}, {high}]"
        raise InputError(f"{field} = {value!r}; allowed: {allowed}.")
    return int(value)
