"""The argument parser of the ``fairaudit`` command: one module per subcommand, then the plug-ins' commands."""

from __future__ import annotations

import argparse
import importlib
import sys

from fairaudit import __version__

from ._common import COMMANDS, Parser, Subparsers, command_flags

COMMANDS_GROUP = "fairaudit.commands"
"""The entry point group of the plug-ins' commands (the experiments' ``experiment`` and ``prepare-model``)."""


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of the ``fairaudit`` command (documented in docs/cli.md).

    Parameters
    ----------
    command : str, optional
        The command line's first argument. When it names a core command, only that command's module is imported
        (the others are listed with their one-line help) and the plug-ins' commands are not loaded: a core command
        neither waits for them nor depends on them. Anything else (``--help``, ``--version``, a plug-in's command)
        lists every core command without importing its module, then loads the plug-ins. None (the default) builds
        every command's parser in full, as the CLI reference and the tests read them.
    """
    parser = Parser(
        prog="fairaudit",
        description="Certified fairness auditing: audit decisions, certify bounds that "
        "hold for any model behind a privacy filter, calibrate the privacy budget.",
    )
    parser.add_argument("--version", action="version", version=f"fairaudit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    for name, line in COMMANDS.items():
        if command in (None, name):
            importlib.import_module(f"{__package__}.{name.replace('-', '_')}").add_parser(sub)
        else:
            sub.add_parser(name, help=line)
    if command not in COMMANDS:
        add_plugin_commands(sub)
    for command_parser in sub.choices.values():
        own = command_parser.get_default("flags") or {}  # a command's parameters that come from another flag
        command_parser.set_defaults(flags={**command_flags(command_parser), **own})
    return parser


def add_plugin_commands(sub: Subparsers) -> None:
    """Add the command of every entry point of :data:`COMMANDS_GROUP`, in the order of their names.

    An entry point names an object (a module) with ``add_parser(subparsers)``, which adds its command as the core
    commands add theirs, with ``set_defaults(func=run)``. One that fails to load or to add its command is left out
    with one warning line on stderr naming it; the other commands work as before.
    """
    from importlib.metadata import entry_points  # (not at the top: a core command never reads the metadata)

    for point in sorted(entry_points(group=COMMANDS_GROUP), key=lambda p: p.name):
        known, helps = set(sub.choices), len(sub._choices_actions)
        try:
            point.load().add_parser(sub)
        except Exception as exc:  # a broken plug-in: whatever it raised, the core's commands still run
            for name in set(sub.choices) - known:  # what it added before failing
                del sub.choices[name]
            del sub._choices_actions[helps:]
            reason = f"{type(exc).__name__}: {exc}".splitlines()[0]
            print(
                f"fairaudit: warning: the plug-in command {point.name!r} ({point.value}) is left out: {reason}",
                file=sys.stderr,
            )
