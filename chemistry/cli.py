"""CLI verbs of the `chemistry` domain, registered through the `snapo_ode.plugins` entry point."""

from snapo_ode.cli import CommandLine

from .kinetics._cli import register_kinetics
from .pharma._cli import register_pharma


def register(cli: CommandLine) -> None:
    """Add this domain's verbs, benchmarks and reports to the `snapo` command line."""
    register_kinetics(cli)
    register_pharma(cli)
