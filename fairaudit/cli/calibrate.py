"""``fairaudit calibrate``: the largest privacy budget meeting a fairness target (fairaudit.calibrate)."""

from __future__ import annotations

import argparse
import dataclasses
from typing import TYPE_CHECKING, Any

from fairaudit.base.errors import InputError
from fairaudit.reports.formats import render

from ._common import COMMANDS, Subparsers, add_global, add_output, emit

if TYPE_CHECKING:
    from fairaudit.laws.families import MechanismFamily


def add_parser(sub: Subparsers) -> None:
    """Add the ``calibrate`` subcommand to ``sub``."""
    k = sub.add_parser(
        "calibrate",
        help=COMMANDS["calibrate"],
        description="Largest epsilon of a mechanism family on the sensitive attribute (k-ary "
        "randomized response, or the spec's) whose certificate on local g-fairness (or global, "
        "--global) meets --target, and its keep probability. Exit 1 when no epsilon meets it.",
    )
    t = k.add_mutually_exclusive_group(required=True)
    t.add_argument("--target", type=float, metavar="L", help="target on L (or L-bar), in nats")
    t.add_argument(
        "--target-impact-ratio",
        type=float,
        metavar="R",
        help="target as the worst impact ratio R in (0, 1] of a 0/1 selection indicator g: L <= -ln R nats "
        "(0.8, the four-fifths rule: ln 1.25 = 0.223 nats)",
    )
    k.add_argument("--groups", type=int, metavar="K", help="number of groups k (default 2, or the spec's)")
    k.add_argument("--gamma", type=float, metavar="G", help="upper end of the utility (default 1, or the spec's)")
    k.add_argument("--lower", type=float, metavar="B", help="lower end of the utility (default 0, or the spec's)")
    k.add_argument(
        "--tau",
        type=float,
        metavar="T",
        help="lower bound on E[g | x, a] (needed by paper and tight; optional for black_box)",
    )
    k.add_argument(
        "--delta",
        type=float,
        metavar="D",
        help="delta of an arbitrary (epsilon, delta)-DP mechanism (paper and tight; the default method becomes tight)",
    )
    k.add_argument(
        "--lipschitz",
        type=float,
        metavar="LA",
        help="L_A, how much g may change with the group (default 0, or the spec's)",
    )
    k.add_argument(
        "--method",
        choices=("paper", "tight", "black_box", "white_box"),
        help="certificate to calibrate (default: white_box with a model in --spec, tight with --delta, else black_box)",
    )
    add_global(k)
    k.add_argument(
        "--spec",
        metavar="SPEC.toml",
        help="take groups, utility, tau, L_A, metric, population, "
        "mechanism family, context mechanism and model from a spec; flags override",
    )
    add_output(k)
    # calibrate's decision model and utility come from the spec: errors about them name --spec
    k.set_defaults(func=run, flags={"kernel": "--spec", "utility": "--spec", "unparsed_decision": "--spec"})


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit calibrate``; returns the exit status (1 when no epsilon meets the target)."""
    from fairaudit.laws.utilities import UtilityClass
    from fairaudit.worstcase.calibration import calibrate

    opts: dict[str, Any] = _spec_options(args) if args.spec else {"family": _groups_family(args.groups)}
    flags = {f: getattr(args, f) for f in ("gamma", "lower", "tau", "lipschitz") if getattr(args, f) is not None}
    opts["utility_class"] = dataclasses.replace(opts.get("utility_class", UtilityClass()), **flags)
    if args.delta is not None:
        opts["delta"] = args.delta
    cal = calibrate(
        args.target, target_impact_ratio=args.target_impact_ratio, kind=args.kind, method=args.method, **opts
    )
    data = cal.to_dict()
    summary = f"epsilon = {data['epsilon']}" if cal.feasible else f"no epsilon meets the target: {cal.reason}"
    emit(args, render(data, "calibrate", args.format), summary)
    return 0 if cal.feasible else 1


def _groups_family(groups: int | None) -> MechanismFamily:
    """Without ``--spec``: k-ary randomized response on ``--groups`` groups (default 2), labelled 0 to k − 1."""
    from fairaudit.laws.families import randomized_response_family

    k = 2 if groups is None else groups
    if k < 2:
        raise InputError("groups", "randomized response needs at least 2 groups", k)
    return randomized_response_family(range(k))


def _spec_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keywords of calibrate taken from ``--spec`` (:meth:`fairaudit.certification.spec.Spec.calibration_options`)."""
    from fairaudit.certification.spec import load_spec

    try:
        spec = load_spec(args.spec)
    except InputError as exc:
        if exc.field != "SPEC":
            raise
        raise exc.under("--spec", keep_own=False) from None
    return spec.calibration_options(groups=args.groups, method=args.method)
