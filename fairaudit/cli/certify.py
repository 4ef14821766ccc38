"""``fairaudit certify``: a certified bound on unfairness from a TOML spec (fairaudit.certify)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from fairaudit.base.errors import InputError
from fairaudit.base.progress import progress_shown
from fairaudit.reports.formats import render

from ._common import COMMANDS, Subparsers, add_output, emit, epsilons, level

if TYPE_CHECKING:
    from fairaudit.certification.certificate import Certificate


def add_parser(sub: Subparsers) -> None:
    """Add the ``certify`` subcommand to ``sub``."""
    c = sub.add_parser(
        "certify",
        help=COMMANDS["certify"],
        description="Bounds on local g-fairness that hold for any decision model behind the spec's "
        "privacy filter; observed metrics when the spec has a model; pass/fail against targets.",
    )
    c.add_argument("spec", metavar="SPEC.toml", help="the spec (see docs/spec.md)")
    add_output(c)
    c.add_argument(
        "--plot",
        metavar="FILE",
        help="draw the fairness-privacy curve (bounds and observed L against "
        "epsilon, in nats) to FILE, .png or .svg (needs pip install 'fairness-certify[plot]')",
    )
    c.add_argument("--plot-data", metavar="FILE.csv", help="write the data behind the curve to FILE.csv")
    c.add_argument(
        "--confidence",
        type=level,
        default=0.95,
        metavar="LEVEL",
        help="simultaneous level of intervals for the observed metrics when the model comes from counts (default 0.95)",
    )
    c.add_argument(
        "--method",
        choices=("auto", "clopper-pearson", "multinomial", "bayes"),
        default="auto",
        help="how those intervals are made (default auto: clopper-pearson for 0/1 utilities, else multinomial)",
    )
    c.add_argument(
        "--epsilons",
        type=epsilons,
        metavar="START:STOP:NUM",
        help="the curve's grid of epsilon in nats, NUM evenly spaced values (default 61 values from 0 to "
        "1.5 x the spec's epsilon, or 0 to 5); the spec's own epsilon is always added",
    )
    c.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    c.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit certify``; returns the exit status (1 when a target is not met)."""
    from fairaudit.certification.certificate import certify
    from fairaudit.statistics.intervals import IntervalOptions

    if args.epsilons is not None and not (args.plot or args.plot_data):
        raise InputError("--epsilons", "is the grid of the curve: give --plot FILE or --plot-data FILE.csv too")
    if args.plot:
        from fairaudit.reports.plots import check_plot_path

        check_plot_path(args.plot)  # before any work: a bad suffix or folder is exit 2 at once
    if args.plot_data:
        folder = Path(args.plot_data).parent
        if not folder.is_dir():
            raise InputError("--plot-data", "folder does not exist", str(folder))
    options = IntervalOptions(confidence=args.confidence, method=args.method)
    cert = certify(args.spec, intervals=options, progress=args.progress)
    if args.plot or args.plot_data:
        with progress_shown(args.progress):  # (a worst case per epsilon: minutes on large specs)
            _write_curve(args, cert)
    data = cert.to_dict()
    summary = (
        f"certified: {'yes' if cert.certified else 'no'}; best bound {data['bounds']['best']} nats ({cert.best_form})"
    )
    emit(args, render(data, "certify", args.format), summary)
    return 0 if cert.certified else 1


def _write_curve(args: argparse.Namespace, cert: Certificate) -> None:
    """The fairness-privacy curve of a certificate's spec: --plot and --plot-data (exit status unchanged)."""
    from fairaudit.certification.curves import privacy_curve

    curve = privacy_curve(cert.spec, epsilons=args.epsilons)
    written = []
    if args.plot:
        from fairaudit.reports.plots import plot_curve

        plot_curve(curve, args.plot)
        written.append(f"plot written to {args.plot}")
    if args.plot_data:
        try:
            curve.to_csv(args.plot_data)
        except InputError as exc:
            raise InputError("--plot-data", exc.problem, exc.value) from None
        written.append(f"curve data written to {args.plot_data}")
    print(f"fairness-privacy curve: {len(curve)} values of epsilon; {'; '.join(written)}", file=sys.stderr)
