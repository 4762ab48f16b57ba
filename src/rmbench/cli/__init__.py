"""Command-line interface: ``rmbench COMMAND ...`` (see ``rmbench --help``)."""

from rmbench.cli.main import main

__all__ = ["main"]
