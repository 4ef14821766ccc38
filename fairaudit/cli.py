"""The ``fairaudit`` command: certify, audit, calibrate.

Exit status: 0 done and every target met; 1 a target is not met; 2 invalid
input, with one line on stderr that names the field or column and the value
(no traceback). Reports go to stdout or ``--output`` (written atomically);
with ``--output`` a one-line summary goes to stderr.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from . import __version__
from ._errors import InputError
from .report import FORMATS, audit_dict, calibration_dict, certificate_dict, render, write_atomic

__all__ = ["main", "build_parser"]


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2)."""

    def error(self, message: str):  # noqa: D401 - argparse API
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


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


def _add_output(p: argparse.ArgumentParser) -> None:
    p.add_argument("--format", choices=FORMATS, default="text", help="report format (default: text)")
    p.add_argument("--output", metavar="FILE", help="write the report to FILE (atomically) instead of stdout")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``fairaudit`` command (documented in docs/cli.md)."""
    parser = _Parser(prog="fairaudit", description="Certified fairness auditing: audit decisions, certify bounds that "
                     "hold for any model behind a privacy filter, calibrate the privacy budget.")
    parser.add_argument("--version", action="version", version=f"fairaudit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")

    c = sub.add_parser("certify", help="certify a bound on unfairness from a TOML spec",
                       description="Bounds on local g-fairness that hold for any decision model behind the spec's "
                       "privacy filter; observed metrics when the spec has a model; pass/fail against targets.")
    c.add_argument("spec", metavar="SPEC.toml", help="the spec (see docs/spec.md)")
    _add_output(c)

    a = sub.add_parser("audit", help="exact fairness metrics of decision records",
                       description="Count decision records (CSV or Parquet) by context, group and outcome and report "
                       "local and global g-fairness, demographic parity and equalized odds gaps, and sups over g.")
    a.add_argument("data", metavar="DATA", help="CSV or Parquet file, one record per decision (or candidate)")
    a.add_argument("--sensitive", required=True, type=_columns, metavar="COL[,COL...]",
                   help="sensitive column(s); several give intersectional groups")
    a.add_argument("--outcome", required=True, metavar="COL", help="outcome column U (all its values are kept)")
    a.add_argument("--context", type=_columns, default=[], metavar="COL[,COL...]", help="context column(s) X")
    g = a.add_mutually_exclusive_group()
    g.add_argument("--positive", metavar="VALUE", help="g = 1{U = VALUE}")
    g.add_argument("--utility", metavar="EXPR", help="g as an expression in u, e.g. 'u >= 5' or '11 - u'")
    a.add_argument("--confidence", type=_level, metavar="LEVEL",
                   help="simultaneous confidence level for intervals on L and L-bar (indicator utilities)")
    a.add_argument("--dropna", action="store_true", help="drop records with missing values in the used columns")
    _add_output(a)

    k = sub.add_parser("calibrate", help="the largest privacy budget epsilon meeting a fairness target",
                       description="Largest epsilon of k-ary randomized response on the sensitive attribute whose "
                       "certificate on local g-fairness meets --target, and its keep probability.")
    k.add_argument("--target", required=True, type=float, metavar="L", help="target on L, in nats")
    k.add_argument("--groups", type=int, default=2, metavar="K", help="number of groups k (default 2)")
    k.add_argument("--gamma", type=float, default=1.0, metavar="G", help="upper end of the utility (default 1)")
    k.add_argument("--lower", type=float, default=0.0, metavar="B", help="lower end of the utility (default 0)")
    k.add_argument("--tau", type=float, metavar="T", help="lower bound on E[g | x, a] (paper and tight methods)")
    k.add_argument("--method", choices=("black_box", "tight", "paper"), default="black_box",
                   help="certificate to calibrate (default black_box: exact, needs no tau)")
    _add_output(k)
    return parser


def _emit(args, text: str, summary: str) -> None:
    if args.output:
        write_atomic(args.output, text)
        print(f"{summary}; report written to {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(text)


def _run(args) -> int:
    if args.command == "certify":
        from .certify import certify

        cert = certify(args.spec)
        data = certificate_dict(cert)
        summary = f"certified: {'yes' if cert.certified else 'no'}; best bound {data['bounds']['best']} nats ({cert.best_form})"
        _emit(args, render(data, "certify", args.format), summary)
        return 0 if cert.certified else 1
    if args.command == "audit":
        from .audit import audit
        from .estimate import read_records

        frame = read_records(args.data)
        result = audit(frame, sensitive=args.sensitive, outcome=args.outcome, context=args.context,
                       positive=args.positive, utility=args.utility, confidence=args.confidence, dropna=args.dropna)
        data = audit_dict(result)
        _emit(args, render(data, "audit", args.format), f"audit: {data['n']} records, L = {data['local']['value']} nats")
        return 0
    from .calibrate import calibrate_randomized_response

    cal = calibrate_randomized_response(args.target, args.groups, method=args.method, gamma=args.gamma,
                                        lower=args.lower, tau=args.tau)
    data = calibration_dict(cal)
    _emit(args, render(data, "calibrate", args.format), f"epsilon = {data['epsilon']}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``fairaudit`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return _run(args)
    except InputError as exc:
        print(f"fairaudit: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"fairaudit: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fairaudit: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
