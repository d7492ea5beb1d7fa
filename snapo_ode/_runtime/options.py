"""Command-line option types that check their range as the command line is parsed, before
anything is imported or computed: `count(low, high)` for whole numbers, `number(low, high)` for
reals, `numbers(low, high)` and `counts(low, high)` for comma-separated lists of them, `seed`
for a random seed. A number is written as the files write one: ASCII decimal digits (`1_000`,
`0x10`, `nan` and other scripts' digits are refused), at most 100 characters. A value out of range is the usual one-line `snapo: error:` (exit 2) naming the option,
the value and the range (`OneLineParser`)."""

import argparse
import math
import re
import sys

from .._platform.reading import DECIMAL, MAX_NUMBER_CHARS

_WHOLE = re.compile(r"[+-]?[0-9]+")
MAX_SEED = 2**63 - 1  # a seed is a signed 64-bit integer (JAX, NumPy)


class OneLineParser(argparse.ArgumentParser):
    """An `ArgumentParser` whose errors are one line, `snapo: error: ...`, exit 2 (as every other
    user mistake), with the usage left to `--help`."""

    def error(self, message: str):
        print(f"snapo: error: {self.prog.removeprefix('snapo ')}: {' '.join(message.split())} (see --help).",
              file=sys.stderr)
        sys.exit(2)


def count(low: int = 1, high: int | None = None):
    """An option type: a whole number in [low, high]."""
    def parse(text: str) -> int:
        if _WHOLE.fullmatch(text.strip()) is None or len(text) > MAX_NUMBER_CHARS:
            raise argparse.ArgumentTypeError(f"{_shown(text)} is not a whole number")
        value = int(text)
        if value < low or (high is not None and value > high):
            allowed = f">= {low}" if high is None else f"from {low} to {high}"
            raise argparse.ArgumentTypeError(f"{value} is out of range: allowed {allowed}")
        return value
    parse.__name__ = "count"
    return parse


def number(low: float = -math.inf, high: float = math.inf, *, low_open: bool = False, high_open: bool = False):
    """An option type: a finite real number in the interval from `low` to `high` (each end
    excluded when `*_open`)."""
    def parse(text: str) -> float:
        if DECIMAL.fullmatch(text.strip()) is None or len(text) > MAX_NUMBER_CHARS:
            raise argparse.ArgumentTypeError(f"{_shown(text)} is not a number")
        value = float(text)
        if not math.isfinite(value) or value < low or value > high or (low_open and value == low) \
                or (high_open and value == high):
            interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
            raise argparse.ArgumentTypeError(f"{value:g} is out of range: allowed {interval}")
        return value
    parse.__name__ = "number"
    return parse


def _shown(text: str) -> str:
    return repr(text) if len(text) <= 40 else repr(text[:37]) + "..."


def _list_of(kind, name: str):
    """An option type: a comma-separated list of `kind`'s values, at least one."""
    def parse(text: str) -> list:
        items = text.split(",")
        if not text.strip() or any(not item.strip() for item in items):
            raise argparse.ArgumentTypeError(f"{_shown(text)} is not a comma-separated list (such as 1,2,4)")
        values = []
        for i, item in enumerate(items):
            try:
                values.append(kind(item.strip()))
            except argparse.ArgumentTypeError as error:
                raise argparse.ArgumentTypeError(f"entry {i + 1}: {error}") from None
        return values
    parse.__name__ = name
    return parse


def counts(low: int = 1, high: int | None = None):
    """An option type: comma-separated whole numbers, each in [low, high]."""
    return _list_of(count(low, high), "counts")


def numbers(low: float = -math.inf, high: float = math.inf, *, low_open: bool = False, high_open: bool = False):
    """An option type: comma-separated finite reals, each in the interval from `low` to `high`."""
    return _list_of(number(low, high, low_open=low_open, high_open=high_open), "numbers")


seed = count(0, MAX_SEED)
"""An option type: a random seed, a whole number in [0, 2^63)."""


def positive(high: float = math.inf):
    """An option type: a number > 0 (and <= `high`)."""
    return number(0.0, high, low_open=True)


class VersionAction(argparse.Action):
    """`snapo --version`: this package's version, then the stack's, read without importing JAX."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, help="show the versions and exit")

    def __call__(self, parser, namespace, values, option_string=None):
        from .._platform.versions import in_words

        snapo, stack = in_words().split(", ", 1)
        print(f"{snapo.replace('snapo-ode', 'snapo')}\n{stack}")
        parser.exit()
