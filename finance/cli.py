"""CLI verbs of the `finance` domain, registered through the `snapo_ode.plugins` entry point."""

from snapo_ode.cli import CommandLine

from .alm._cli import register_alm
from .gas_storage._cli import register_gas
from .gas_storage._report_cli import register_gas_report


def register(cli: CommandLine) -> None:
    """Add this domain's verbs, benchmarks and reports to the `snapo` command line."""
    register_gas(cli)
    register_gas_report(cli)
    register_alm(cli)
