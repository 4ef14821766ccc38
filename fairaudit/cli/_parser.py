"""The argument parser of the ``fairaudit`` command, assembled from one module per subcommand."""

from __future__ import annotations

import argparse

from .. import __version__
from . import audit, calibrate, certify, experiment, plan, prepare_model, worst_case
from ._common import Parser, command_flags


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``fairaudit`` command (documented in docs/cli.md)."""
    parser = Parser(
        prog="fairaudit",
        description="Certified fairness auditing: audit decisions, certify bounds that "
        "hold for any model behind a privacy filter, calibrate the privacy budget.",
    )
    parser.add_argument("--version", action="version", version=f"fairaudit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    for command in (certify, audit, calibrate, plan, worst_case, experiment, prepare_model):
        command.add_parser(sub)
    for command_parser in sub.choices.values():
        own = command_parser.get_default("flags") or {}  # a command's parameters that come from another flag
        command_parser.set_defaults(flags={**command_flags(command_parser), **own})
    return parser
