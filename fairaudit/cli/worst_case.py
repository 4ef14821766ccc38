"""``fairaudit worst-case``: the utility that shows the largest disparity of a spec's model (fairaudit.certification.spec_worst_case)."""

from __future__ import annotations

import argparse

from fairaudit.reports.formats import render

from ._common import COMMANDS, Subparsers, add_output, emit, nonneg


def add_parser(sub: Subparsers) -> None:
    """Add the ``worst-case`` subcommand to ``sub``."""
    w = sub.add_parser(
        "worst-case",
        help=COMMANDS["worst-case"],
        description="For the decision model of a spec (its [model], behind the spec's privacy filter), the "
        "utility g(u) in [lower, gamma] (with E[g | x, a] >= tau) whose local and global g-fairness are largest, "
        "with their values in nats, beside the spec's own utility.",
    )
    w.add_argument("spec", metavar="SPEC.toml", help="the spec, with a [model] (see docs/spec.md)")
    w.add_argument("--lower", type=nonneg, metavar="B", help="lower end of the utilities (default: the spec's)")
    w.add_argument("--gamma", type=nonneg, metavar="G", help="upper end of the utilities (default: the spec's)")
    w.add_argument("--tau", type=nonneg, metavar="T", help="lower bound on every E[g | x, a] (default: the spec's)")
    w.add_argument(
        "--method",
        choices=("auto", "threshold", "lp"),
        default="auto",
        help="auto (default): the threshold solution when tau <= lower, else the linear-fractional LP",
    )
    add_output(w)
    w.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit worst-case``; returns the exit status."""
    from fairaudit import UtilityClass
    from fairaudit.certification.spec_worst_case import spec_worst_utility

    utility_class = UtilityClass(lower=args.lower, gamma=args.gamma, tau=args.tau)
    result = spec_worst_utility(args.spec, utility_class=utility_class, method=args.method)
    data = result.to_dict()
    summary = f"worst case: L = {data['local']['value']} nats, L-bar = {data['global']['value']} nats"
    emit(args, render(data, "worst-case", args.format), summary)
    return 0
