"""``fairaudit verify``: a certificate's numbers re-derived from its recorded inputs; exit 0 when all hold, 1 if not.

Reads the JSON of ``fairaudit certify --format json`` (:func:`fairaudit.verification.rederive.verify`), prints each
number with ``holds`` or ``fails by X`` (text) or the checks as JSON, and with ``--filter`` also checks that a deployed
filter's parameters (``fairaudit filter --parameters``) are the certified mechanism. Exit status: 0 when every
number holds, 1 when one fails, 2 on bad input (one line).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from fairaudit.base.errors import InputError

from ._common import Subparsers


def add_parser(sub: Subparsers) -> None:
    """Add the ``verify`` subcommand to ``sub``."""
    v = sub.add_parser(
        "verify",
        help="re-derive a certificate's numbers from its recorded inputs (exit 0: all hold, 1: one fails)",
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


def _read_json(path: str, field: str) -> Any:
    """A JSON file, or an InputError naming ``field``."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(field, f"cannot be read: {exc.strerror}", path) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(field, f"is not JSON: {exc}", path) from None


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit verify``; returns the exit status (0 all hold, 1 one fails)."""
    from fairaudit.verification.rederive import verify

    cert = _read_json(args.certificate, "CERT.json")
    privacy_filter = None
    if args.filter is not None:
        from fairaudit.filter.filters import PrivacyFilter

        try:
            privacy_filter = PrivacyFilter.from_dict(_read_json(args.filter, "--filter"))
        except InputError as exc:
            raise exc.under(f"--filter {exc.field}", keep_own=False) from None
    try:
        result = verify(cert, privacy_filter=privacy_filter, source=args.certificate)
    except InputError as exc:
        raise exc.under(f"CERT.json {exc.field}", keep_own=False) from None
    if args.format == "json":
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print("\n".join(result.lines()))
    return 0 if result.holds else 1
