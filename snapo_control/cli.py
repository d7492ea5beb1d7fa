"""CLI verbs of the control domain (`snapo_control`), registered through the `snapo_ode.plugins` entry point."""

from snapo_ode.cli import CommandLine

from .pendulum._cli import register_pendulum


def register(cli: CommandLine) -> None:
    """Add this domain's verbs to the `snapo` command line."""
    register_pendulum(cli)
