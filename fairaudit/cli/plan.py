"""``fairaudit plan``: queries per cell needed to certify a fairness target from counts (fairaudit.plan)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import TYPE_CHECKING

from fairaudit.base.json_values import Report
from fairaudit.reports.formats import render

from ._common import COMMANDS, Subparsers, add_global, add_output, emit

if TYPE_CHECKING:
    from fairaudit.statistics.sample_size import SamplePlan


_PLAN_KEYWORDS = (
    "groups contexts base_rate disparity confidence power epsilon kind datasets seed max_n max_memory".split()
)
"""The keywords of :func:`fairaudit.plan` that the flags of their names give (``--global`` gives ``kind``)."""


def add_parser(sub: Subparsers) -> None:
    """Add the ``plan`` subcommand (sample sizes) to ``sub``."""
    p = sub.add_parser(
        "plan",
        help=COMMANDS["plan"],
        description="Smallest number of queries per cell (context x group) such that the "
        "simultaneous interval on L (or L-bar, --global) of a binary decision has its upper end <= "
        "--target with probability >= --power, by simulation, when the model has the given "
        "disparity. Exit 1 when some method finds no such number.",
    )
    p.add_argument("--target", required=True, type=float, metavar="L", help="target on L (or L-bar), in nats")
    p.add_argument("--groups", type=int, default=2, metavar="K", help="number of groups (default 2)")
    p.add_argument("--contexts", type=int, default=1, metavar="X", help="number of contexts (default 1)")
    p.add_argument(
        "--base-rate", type=float, default=0.5, metavar="P", help="E[g | x, a] of every group but group 0 (default 0.5)"
    )
    p.add_argument(
        "--disparity",
        type=float,
        default=0.0,
        metavar="D",
        help="group 0's rate is base rate x exp(D); the true L is |D| nats (default 0: a fair model)",
    )
    p.add_argument("--confidence", type=float, default=0.95, metavar="C", help="1 - alpha (default 0.95)")
    p.add_argument(
        "--method",
        choices=("clopper-pearson", "multinomial", "bayes", "all"),
        default="clopper-pearson",
        metavar="NAME|all",
        help="interval method: clopper-pearson (default), multinomial, bayes, or all three",
    )
    p.add_argument(
        "--power",
        type=float,
        default=0.8,
        metavar="P",
        help="required probability of certifying the target (default 0.8)",
    )
    p.add_argument(
        "--epsilon",
        type=float,
        metavar="E",
        help="query the model behind k-ary randomized response at E nats and certify the filtered law",
    )
    add_global(p)
    p.add_argument(
        "--datasets", type=int, metavar="N", help="simulated tables per sample size (default 200; 40 for bayes)"
    )
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument(
        "--max-n", type=int, default=1_000_000, metavar="N", help="largest n per cell tried (default 1000000)"
    )
    p.add_argument(  # plan's max_memory, over $FAIRAUDIT_MAX_MEMORY (fairaudit.base.resources.parse_size)
        "--max-memory",
        metavar="SIZE",
        help="memory the computation may take, e.g. 4G, 512M, 2.5GiB (default: $FAIRAUDIT_MAX_MEMORY, "
        "else half the memory available); refused with exit 2 when it needs more",
    )
    p.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    add_output(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit plan``; returns the exit status (1 when some method finds no sample size)."""
    from fairaudit.base.progress import progress_shown
    from fairaudit.statistics.sample_size import plan

    methods = ("clopper-pearson", "multinomial", "bayes") if args.method == "all" else (args.method,)
    keywords = {name: getattr(args, name) for name in _PLAN_KEYWORDS}
    with progress_shown(args.progress):  # a bar per sample size tried (minutes on a million cells)
        plans = [plan(args.target, method=method, **keywords) for method in methods]  # errors name keywords
    data = _plans_dict(plans)
    summary = "; ".join(f"{p.method}: {p.n_per_cell if p.feasible else 'no n'}" for p in plans)
    emit(args, render(data, "plan", args.format), f"queries per cell: {summary}")
    return 0 if data["feasible"] else 1


def _plans_dict(plans: Sequence[SamplePlan]) -> Report:
    """One ``plan`` JSON for plans of several methods (same inputs): the first's, every method's entry in ``plans``.

    Keys: ``target``, ``confidence``, ``power``, ``kind``, ``groups``,
    ``contexts``, ``base_rate``, ``disparity``, ``epsilon`` (``null`` without
    a filter), ``seed``, ``max_n``, ``true_value`` (L or L̄ of the assumed law),
    ``feasible`` (every plan found an n) and ``plans``: one entry per method
    with ``method``, ``n_per_cell``, ``n_total`` (``null`` when infeasible),
    ``achieved_power``, ``expected_upper`` (median upper end, nats),
    ``datasets``, ``reason`` (``""`` when feasible), as in
    :meth:`~fairaudit.statistics.sample_size.SamplePlan.to_dict`.
    """
    out = plans[0].to_dict()
    out["feasible"] = all(p.feasible for p in plans)
    out["plans"] = [entry for p in plans for entry in p.to_dict()["plans"]]
    return out
