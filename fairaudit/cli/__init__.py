"""The ``fairaudit`` command: certify, audit, calibrate, plan, worst-case, filter, and the plug-ins' commands.

One module per subcommand (``fairaudit/cli/<command>.py``) adds its arguments
(``add_parser``) and runs it (``run(args) -> int``, dispatched through
``set_defaults(func=run)``); :func:`build_parser` assembles them, then adds the
commands of every entry point of the group ``fairaudit.commands`` the same way
(the experiments' ``experiment`` and ``prepare-model``).

Exit status: 0 done and every target met; 1 a target is not met; 2 invalid
input, with one line on stderr that names the field or column and the value
(no traceback). Reports go to stdout or ``--output`` (written atomically);
with ``--output`` a one-line summary goes to stderr.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Sequence

from fairaudit.base.errors import InputError, echo

from ._common import check_outputs, flag_error
from ._parser import build_parser

__all__ = ["build_parser", "main"]

CLEAR_LINE = "\r\x1b[K"
"""Carriage return, then erase to the end of the line (ANSI): what a terminal shows before the interrupted line."""


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``fairaudit`` command; returns the exit status."""
    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(words[0] if words else "")  # "": no command named, so none is imported
    args = parser.parse_args(words)
    main_thread = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGINT) if main_thread else None  # (emit ignores Ctrl-C once work is done)
    try:
        check_outputs(args)
        status: int = args.func(args)  # each subcommand's run, set by its add_parser
        return status
    except InputError as exc:
        print(f"fairaudit: error: {flag_error(exc, args.flags)}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"fairaudit: error: {os_error_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # (a command that can say how to go on catches it itself)
        # on a terminal, from the start of a blank line: a progress bar interrupted while drawing is not cleared
        print(f"{CLEAR_LINE if sys.stderr.isatty() else ''}fairaudit: interrupted", file=sys.stderr)
        return 130
    finally:
        if argv is None:  # the command line itself: its work is done and said; Ctrl-C from now on is ignored
            try:  # (neither a traceback from the interpreter's shutdown nor another exit status)
                signal.signal(signal.SIGINT, signal.SIG_IGN)
            except KeyboardInterrupt:  # one pending since the last line, taken between two steps
                signal.signal(signal.SIGINT, signal.SIG_IGN)
        elif handler is not None:  # called in process: the caller's handler back
            signal.signal(signal.SIGINT, handler)


def os_error_line(exc: OSError) -> str:
    """The line of a system error that reached the command: the file it names, if any, and the reason.

    Never an empty name before the colon.

    Examples
    --------
    >>> os_error_line(OSError(27, "File too large"))
    'File too large'
    >>> os_error_line(FileNotFoundError(2, "No such file or directory", "runs/log.jsonl"))
    "'runs/log.jsonl': No such file or directory"
    """
    reason = exc.strerror or str(exc) or type(exc).__name__
    if exc.filename is None or exc.filename == "":
        return reason
    return f"{echo(os.fsdecode(exc.filename))}: {reason}"
