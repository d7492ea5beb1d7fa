"""The `snapo` command line. Domains plug in their verbs through the `snapo_ode.plugins` entry points.

A plugin is a function `register(cli: CommandLine) -> None` that adds its verbs with
`cli.command(name, help)`, `cli.bench(name, help)` and `cli.report(name, help)`; each returns an
`argparse.ArgumentParser` whose `handler` default (`parser.set_defaults(handler=fn)`) is called
with the parsed arguments. The core itself never imports a domain.
"""

import argparse
import sys
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points

from ._validation import InputError

PLUGIN_GROUP = "snapo_ode.plugins"


class CommandLine:
    """The parser tree handed to each plugin."""

    def __init__(self) -> None:
        self.parser = argparse.ArgumentParser(
            prog="snapo",
            description="Smooth Neural Adjoint Policy Optimization on differentiable simulators.",
        )
        self._verbs = self.parser.add_subparsers(dest="verb", metavar="VERB")
        bench = self._verbs.add_parser("bench", help="run a benchmark and print its table")
        self._benches = bench.add_subparsers(dest="bench", metavar="NAME")
        report = self._verbs.add_parser("report", help="write a report to a directory")
        self._reports = report.add_subparsers(dest="report", metavar="NAME")

    def command(self, name: str, help: str) -> argparse.ArgumentParser:
        """A top-level verb: `snapo NAME ...`."""
        return self._verbs.add_parser(name, help=help, description=help)

    def bench(self, name: str, help: str) -> argparse.ArgumentParser:
        """A benchmark: `snapo bench NAME ...`."""
        return self._benches.add_parser(name, help=help, description=help)

    def report(self, name: str, help: str) -> argparse.ArgumentParser:
        """A report: `snapo report NAME --out DIR ...`."""
        return self._reports.add_parser(name, help=help, description=help)


def build(plugins: Sequence[Callable[[CommandLine], None]] | None = None) -> CommandLine:
    """The command line with every installed plugin (or the given ones) registered."""
    cli = CommandLine()
    if plugins is None:
        plugins = [entry.load() for entry in entry_points(group=PLUGIN_GROUP)]
    for register in plugins:
        register(cli)
    return cli


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `snapo` console script."""
    cli = build()
    args = cli.parser.parse_args(argv)
    handler = getattr(args, "handler", None)
    if handler is None:
        cli.parser.print_help()
        return 2
    try:
        return int(handler(args) or 0)
    except InputError as error:
        print(f"snapo: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
