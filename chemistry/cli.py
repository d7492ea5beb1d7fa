"""CLI verbs of the `chemistry` domain, registered through the `snapo_ode.plugins` entry point."""

from snapo_ode.cli import CommandLine


def register(cli: CommandLine) -> None:
    """Add this domain's verbs, benchmarks and reports to the `snapo` command line."""
