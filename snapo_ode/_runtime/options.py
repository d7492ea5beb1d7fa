"""Command-line option types that check their range as the command line is parsed, before
anything is imported or computed: `count(low, high)` for whole numbers, `number(low, high)` for
reals. A value out of range is the usual one-line `snapo: error:` (exit 2) naming the option,
the value and the range (`OneLineParser`)."""

import argparse
import math
import sys


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
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
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
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not math.isfinite(value) or value < low or value > high or (low_open and value == low) \
                or (high_open and value == high):
            interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
            raise argparse.ArgumentTypeError(f"{value:g} is out of range: allowed {interval}")
        return value
    parse.__name__ = "number"
    return parse


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
