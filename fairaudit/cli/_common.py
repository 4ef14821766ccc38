"""What the subcommands share: the parser class, argparse value types, the report options and output.

Library errors name Python parameters; :func:`flag_error` names the command's flag instead, and
:func:`flag_mentions` does the same for the parameters a problem mentions in backticks (```endpoint```).
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import sys
import threading
from typing import TYPE_CHECKING, NoReturn, TypeAlias

from fairaudit.base.checks import number_type
from fairaudit.base.errors import InputError
from fairaudit.reports.formats import FORMATS

if TYPE_CHECKING:
    from fairaudit.base.arrays import FloatArray
    from fairaudit.data.csv_format import CsvFormat


COMMANDS = {
    "certify": "certify a bound on unfairness from a TOML spec",
    "audit": "exact fairness metrics of decision records",
    "calibrate": "the largest privacy budget epsilon meeting a fairness target",
    "plan": "queries per cell needed to certify a fairness target from counts",
    "worst-case": "the utility that shows the largest disparity of a spec's model",
    "filter": "release one column of a CSV or Parquet file through a privacy filter",
    "verify": "re-derive a certificate's numbers from its recorded inputs (exit 0: all hold, 1: one fails)",
}
"""The core commands and their one-line help, in the order ``fairaudit --help`` lists them. A command's module
(``fairaudit/cli/<command>.py``, ``-`` read as ``_``) is imported only when the command line names it (issue 83)."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2)."""

    def error(self, message: str) -> NoReturn:  # noqa: D401 - argparse API
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


Subparsers: TypeAlias = "argparse._SubParsersAction[Parser]"


# Python parameters whose flag is not ``--`` + the parameter with ``-`` for ``_`` (the parser's own dest).
PARAMETER_FLAGS: dict[str, str] = {
    "kind": "--global",
    "epsilons": "--epsilon",
    "keeps": "--keep",
    "targets": "--target",
    "max_concurrency": "--concurrency",
    "path": "--plot",
    "header": "--no-header",
}


def command_flags(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Python parameter -> flag for one subcommand: each option's dest, then :data:`PARAMETER_FLAGS`."""
    flags = {a.dest: max(a.option_strings, key=len) for a in parser._actions if a.option_strings}
    own = set(flags.values())
    flags.update({param: flag for param, flag in PARAMETER_FLAGS.items() if flag in own})
    return flags


def flag_error(exc: InputError, flags: dict[str, str]) -> InputError:
    """The library's error as the command says it: its parameters named as the command's flags.

    The field's first word is mapped (``confidence`` -> ``--confidence``, ``kernel column 'x'`` -> ``--kernel column
    'x'``); spec fields, columns and anything that is not one of the command's parameters stay as they are. The
    parameters the problem mentions in backticks are mapped by :func:`flag_mentions`.
    """
    exc = flag_mentions(exc, flags)
    head, sep, rest = exc.field.partition(" ")
    if head not in flags:
        return exc
    return InputError(flags[head] + sep + rest, exc.problem, exc.value)


_MENTION = re.compile(r"`([a-z_]+)`")


def flag_mentions(exc: InputError, flags: dict[str, str]) -> InputError:
    """The library's error with each parameter its problem mentions in backticks named as the command's flag.

    ```endpoint``` becomes ``--endpoint`` where the command has that flag, and ``endpoint`` (no backticks) where it
    has not; the field is left to :func:`flag_error`.

    Examples
    --------
    >>> str(flag_mentions(InputError("model", "is needed with `endpoint`"), {"endpoint": "--endpoint"}))
    'model: is needed with --endpoint'
    """
    problem = _MENTION.sub(lambda m: flags.get(m.group(1), m.group(1)), exc.problem)
    return exc if problem == exc.problem else InputError(exc.field, problem, exc.value)


level = number_type("a number in (0, 1)", low=0.0, high=1.0, low_open=True, high_open=True)
"""A confidence level: a number strictly between 0 and 1."""

nonneg = number_type("a finite number >= 0", low=0.0, unparsed="a number >= 0")
"""A finite number >= 0 (nats)."""

positive_int = number_type("a whole number >= 1", low=1, integer=True)
"""A whole number >= 1 (a count)."""


def columns(text: str) -> list[str]:
    """One or more comma-separated column names."""
    cols = [c.strip() for c in text.split(",") if c.strip()]
    if not cols:
        raise argparse.ArgumentTypeError(f"expected one or more comma-separated column names, got {text!r}")
    return cols


def separator(text: str) -> str:
    """A field separator: one character, or ``tab`` / ``\\t`` for a tab."""
    return "\t" if text in ("tab", "\\t") else text


def add_text_format(p: argparse.ArgumentParser) -> None:
    """The options of reading a text file of records (:class:`fairaudit.data.csv_format.CsvFormat`)."""
    p.add_argument(
        "--no-header", action="store_true", help="the file has no header line: name its columns with --names"
    )
    p.add_argument(
        "--names", type=columns, metavar="COL[,COL...]", help="the columns' names, one per field (replaces a header)"
    )
    p.add_argument(
        "--sep",
        type=separator,
        metavar="CHAR",
        help="field separator (default: tab for .tsv, else comma; 'tab' or '\\t')",
    )
    p.add_argument(
        "--na-values",
        type=columns,
        default=[],
        metavar="TEXT[,TEXT...]",
        help="fields read as missing besides the usual markers (empty, NA, nan, NULL, ...), e.g. '?' for UCI files",
    )
    p.add_argument(
        "--skip-initial-space",
        action="store_true",
        help="drop the spaces after each separator (UCI's '39, Male'); without it ' Male' keeps its space",
    )


def text_format(args: argparse.Namespace) -> CsvFormat:
    """The :class:`~fairaudit.data.csv_format.CsvFormat` of the options of :func:`add_text_format`."""
    from fairaudit.data.csv_format import CsvFormat

    return CsvFormat(
        header=not args.no_header,
        names=None if args.names is None else tuple(args.names),
        sep=args.sep,
        na_values=tuple(args.na_values),
        skip_initial_space=args.skip_initial_space,
    )


def epsilons(text: str) -> FloatArray:
    """A grid of privacy budgets START:STOP:NUM (nats), as ``numpy.linspace``."""
    try:
        first, last, count = text.split(":")  # (not three parts: a ValueError too)
        start, stop, num = float(first), float(last), int(count)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP:NUM, e.g. 0:5:61, got {text!r}") from None
    if not (0 <= start <= stop < float("inf")) or not 1 <= num <= 100_000:
        raise argparse.ArgumentTypeError(f"expected 0 <= START <= STOP (nats) and 1 <= NUM <= 100000, got {text!r}")
    import numpy as np

    return np.linspace(start, stop, num)


def add_output(p: argparse.ArgumentParser) -> None:
    """The report options: ``--format`` and ``--output``."""
    p.add_argument("--format", choices=FORMATS, default="text", help="report format (default: text)")
    p.add_argument("--output", metavar="FILE", help="write the report to FILE (atomically) instead of stdout")


def add_global(p: argparse.ArgumentParser) -> None:
    """``--global``: the target is on L-bar (the parameter ``kind``, ``"local"`` without it)."""
    p.add_argument(
        "--global",
        dest="kind",
        action="store_const",
        const="global",
        default="local",
        help="the target is on global g-fairness L-bar",
    )


INPUTS = ("data", "spec", "certificate", "published")
"""The arguments that name a command's input files (a file :func:`check_outputs` never lets a command write)."""

OUTPUTS = ("output", "parameters")
"""The arguments that name a file a command writes."""


def check_outputs(args: argparse.Namespace) -> None:
    """Before any work: every output names a file (not an empty path) and none is one of the command's inputs."""
    inputs = [(name, getattr(args, name)) for name in INPUTS if isinstance(getattr(args, name, None), str)]
    for out in OUTPUTS:
        path = getattr(args, out, None)
        if path is None:
            continue
        if not str(path).strip():
            raise InputError(f"--{out}", "names no file (an empty path): give a file, or leave it out", path)
        for name, given in inputs:
            if given == path or (os.path.exists(given) and os.path.exists(path) and os.path.samefile(given, path)):
                raise InputError(f"--{out}", f"is the input {name.upper()}: writing there would replace it", path)


def work_done() -> None:
    """From here on Ctrl-C is ignored (in the main thread; :func:`~fairaudit.cli.main` restores the handler when the
    command returns): what the command has done is being written, and a write is not parted or followed by
    ``interrupted`` and exit status 130."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def emit(args: argparse.Namespace, text: str, summary: str) -> None:
    """Write the report to ``--output`` (with ``summary`` on stderr) or to stdout.

    The command's work is done: from here on Ctrl-C is ignored (:func:`main` restores the handler when it
    returns), so that a report renamed into place is never followed by ``interrupted`` and exit status 130.
    """
    work_done()
    if args.output is not None:
        from fairaudit.base.files import write_atomic  # (and tempfile: only for --output)

        write_atomic(args.output, text)
        print(f"{summary}; report written to {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(text)
