"""What the subcommands share: the parser class, argparse value types, the report options and output."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, NoReturn, TypeAlias

from .._errors import InputError
from ..report import FORMATS, write_atomic

if TYPE_CHECKING:
    from .._arrays import FloatArray


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2)."""

    def error(self, message: str) -> NoReturn:  # noqa: D401 - argparse API
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


_Subparsers: TypeAlias = "argparse._SubParsersAction[_Parser]"


# Python parameters whose flag is not ``--`` + the parameter with ``-`` for ``_`` (the parser's own dest).
PARAMETER_FLAGS: dict[str, str] = {
    "kind": "--global",
}


def command_flags(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Python parameter -> flag for one subcommand: each option's dest, then :data:`PARAMETER_FLAGS`."""
    flags = {a.dest: max(a.option_strings, key=len) for a in parser._actions if a.option_strings}
    own = set(flags.values())
    flags.update({param: flag for param, flag in PARAMETER_FLAGS.items() if flag in own})
    return flags


def flag_error(exc: InputError, flags: dict[str, str]) -> InputError:
    """The library's error with its parameter named as the command's flag (``confidence`` -> ``--confidence``).

    Only the field's first word is mapped (``kernel column 'x'`` -> ``--kernel column 'x'``); spec fields, columns and
    anything that is not one of the command's parameters stay as they are.
    """
    head, sep, rest = exc.field.partition(" ")
    if head not in flags:
        return exc
    field = flags[head] + sep + rest
    if exc.value is InputError._missing:
        return InputError(field, exc.problem)
    return InputError(field, exc.problem, exc.value)


def _columns(text: str) -> list[str]:
    cols = [c.strip() for c in text.split(",") if c.strip()]
    if not cols:
        raise argparse.ArgumentTypeError(f"expected one or more comma-separated column names, got {text!r}")
    return cols


def _level(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), got {text!r}") from None
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), got {text!r}")
    return v


def _epsilons(text: str) -> FloatArray:
    parts = text.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP:NUM, e.g. 0:5:61, got {text!r}") from None
    if not (0 <= start <= stop < float("inf")) or not 1 <= num <= 100_000:
        raise argparse.ArgumentTypeError(f"expected 0 <= START <= STOP (nats) and 1 <= NUM <= 100000, got {text!r}")
    import numpy as np

    return np.linspace(start, stop, num)


def _nonneg(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not v >= 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return v


def _level_closed(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a probability in [1/k, 1), got {text!r}") from None
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"expected a probability in [1/k, 1), got {text!r}")
    return v


def _add_output(p: argparse.ArgumentParser) -> None:
    p.add_argument("--format", choices=FORMATS, default="text", help="report format (default: text)")
    p.add_argument("--output", metavar="FILE", help="write the report to FILE (atomically) instead of stdout")


def _emit(args: argparse.Namespace, text: str, summary: str) -> None:
    if args.output:
        write_atomic(args.output, text)
        print(f"{summary}; report written to {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(text)
