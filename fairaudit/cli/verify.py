"""``fairaudit verify``: a certificate's numbers re-derived from its recorded inputs; exit 0 when all hold, 1 if not.

Reads the JSON of ``fairaudit certify --format json`` (:func:`fairaudit.verification.rederive.verify`), prints each
number with ``holds`` or ``fails by X`` (text) or the checks as JSON, and with ``--filter`` also checks that a deployed
filter's parameters (``fairaudit filter --parameters``) are the certified mechanism. Exit status: 0 when every
number holds, 1 when one fails, 2 on bad input (one line).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

from fairaudit.base.errors import InputError
from fairaudit.verification.schema import MAX_DEPTH, CertificateError

from ._common import COMMANDS, Subparsers


def add_parser(sub: Subparsers) -> None:
    """Add the ``verify`` subcommand to ``sub``."""
    v = sub.add_parser(
        "verify",
        help=COMMANDS["verify"],
        description="Re-derives every number of a certificate that it can from the inputs the certificate records, "
        "in exact rational arithmetic, and prints each with 'holds' or 'fails by X'. Exit 0 when all hold, 1 when "
        "one fails, 2 on bad input.",
    )
    v.add_argument("certificate", metavar="CERT.json", help="a certificate: the JSON of fairaudit certify")
    v.add_argument(
        "--filter",
        metavar="FILTER.json",
        help="a deployed filter's parameters (fairaudit filter --parameters): check it is the certified mechanism",
    )
    v.add_argument("--format", choices=("text", "json"), default="text", help="the report's format (default text)")
    v.set_defaults(func=run)


_TOKENS = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|[\[\]{}]')
"""A JSON string (skipped whole: brackets inside it do not nest) or a bracket."""


def _depth_at(text: str, limit: int) -> int | None:
    """The offset of the first bracket nested deeper than ``limit``, or None: one pass, no recursion.

    Examples
    --------
    >>> _depth_at('[[["]]]]]"]]]', 2), _depth_at("[" * 5, 4), _depth_at('{"a": [1, {"b": "[[[["}]}', 3)
    (2, 4, None)
    """
    depth = 0
    for token in _TOKENS.finditer(text):
        c = token.group()
        if c in "[{":
            depth += 1
            if depth > limit:
                return token.start()
        elif c in "]}":
            depth -= 1
    return None


def _parse_float(text: str) -> float:
    """A JSON number with a fraction or exponent, refused (ValueError) beyond the floats' range (1e400)."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"holds the number {text[:40]}, beyond the largest float (1.8e308)")
    return value


def _parse_int(text: str) -> int:
    """A JSON integer, refused (ValueError) beyond the floats' range, before Python converts its digits."""
    digits = len(text.lstrip("-"))
    if digits > 309 or abs(value := int(text)) > sys.float_info.max:
        raise ValueError(f"holds an integer of {digits} digits, beyond the largest float (1.8e308)")
    return value


def _parse_constant(text: str) -> Any:
    """NaN, Infinity and -Infinity, which Python's ``json`` reads and JSON does not allow: refused (ValueError)."""
    raise ValueError(f'holds {text}, which JSON does not allow (a certificate writes an infinity as "inf")')


def _read_json(path: str, field: str) -> Any:
    """A JSON file, or an InputError naming ``field``: unreadable, not JSON, nested deeper than ``MAX_DEPTH`` (Python's
    ``json`` recurses once per level: the text is scanned first), or holding NaN, an infinity or a number beyond the
    floats."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(field, f"cannot be read: {exc.strerror}", path) from None
    except UnicodeDecodeError as exc:
        raise InputError(field, f"is not JSON: {exc}", path) from None
    at = _depth_at(text, MAX_DEPTH)
    if at is not None:
        raise InputError(field, f"is nested deeper than {MAX_DEPTH} arrays and objects (at character {at})", path)
    try:
        return json.loads(text, parse_float=_parse_float, parse_int=_parse_int, parse_constant=_parse_constant)
    except json.JSONDecodeError as exc:
        raise InputError(field, f"is not JSON: {exc}", path) from None
    except ValueError as exc:  # a hook's, or Python's own limit on an integer's digits
        raise InputError(field, str(exc), path) from None
    except RecursionError:  # (not reached below MAX_DEPTH; kept so that no input ends in a traceback)
        raise InputError(field, "is nested too deeply to read", path) from None


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit verify``; returns the exit status (0 all hold, 1 one fails)."""
    from fairaudit.verification.rederive import verify

    cert = _read_json(args.certificate, "CERT.json")
    parameters = None
    if args.filter is not None:
        from fairaudit.filter.filters import PrivacyFilter

        parameters = _read_json(args.filter, "--filter")
        try:  # its fields checked and named here; verify reads the parameters itself
            PrivacyFilter.from_dict(parameters)
        except InputError as exc:
            raise exc.under(f"--filter {exc.field}", keep_own=False) from None
    try:
        result = verify(cert, privacy_filter=parameters, source=args.certificate)
    except CertificateError as exc:  # (verification's own error: the package imports nothing else of fairaudit)
        if exc.field == "certificate":  # the whole document: named by its path
            raise InputError("CERT.json", exc.problem, args.certificate) from None
        field = exc.field.replace("privacy_filter", "--filter", 1) if exc.field.startswith("privacy_filter") else ""
        given = () if exc.value is CertificateError.NO_VALUE else (exc.value,)
        raise InputError(field or f"CERT.json {exc.field}", exc.problem, *given) from None
    if args.format == "json":
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print("\n".join(result.lines()))
    return 0 if result.holds else 1
