"""``fairaudit audit``: exact fairness metrics of decision records (fairaudit.audit)."""

from __future__ import annotations

import argparse
import dataclasses

from fairaudit.base.checks import whole
from fairaudit.base.errors import InputError
from fairaudit.reports.formats import render
from fairaudit.reports.formats.sections import records

from ._common import COMMANDS, Subparsers, add_output, add_text_format, columns, emit, level, positive_int, text_format


def add_parser(sub: Subparsers) -> None:
    """Add the ``audit`` subcommand to ``sub``."""
    a = sub.add_parser(
        "audit",
        help=COMMANDS["audit"],
        description="Count decision records (CSV or Parquet) by context, group and outcome and report "
        "local and global g-fairness, demographic parity and equalized odds gaps, and sups over g. "
        "Parquet and CSV are counted out of core by DuckDB.",
    )
    a.add_argument(
        "data",
        metavar="DATA",
        nargs="?",
        help="Parquet file (or folder of Parquet files), or text: .csv, .tsv, .txt or .data, optionally "
        "compressed (.gz, .zst); one record per decision (or candidate); with --count, a count table",
    )
    a.add_argument(
        "--published",
        metavar="TABLE",
        help="instead of DATA: check a published bias audit's impact-ratio table (CSV or Parquet; the ACLU "
        "dataset's columns, or category, applicants, selected, rate, impact_ratio): every figure recomputed at its "
        "printed precision, ratios above 1, 2%% exclusions, the missing-data bounds; exit 1 when one is not "
        "consistent",
    )
    a.add_argument(
        "--sensitive",
        type=columns,
        metavar="COL[,COL...]",
        help="sensitive column(s); several give intersectional groups (required with DATA)",
    )
    a.add_argument("--outcome", metavar="COL", help="outcome column U (all its values are kept; required with DATA)")
    a.add_argument("--context", type=columns, default=[], metavar="COL[,COL...]", help="context column(s) X")
    g = a.add_mutually_exclusive_group()
    g.add_argument("--positive", metavar="VALUE", help="g = 1{U = VALUE}")
    g.add_argument("--utility", metavar="EXPR", help="g as an expression in u, e.g. 'u >= 5' or '11 - u'")
    a.add_argument(
        "--confidence",
        type=level,
        metavar="LEVEL",
        help="simultaneous confidence level of intervals for every metric (e.g. 0.95)",
    )
    a.add_argument(
        "--method",
        choices=("auto", "clopper-pearson", "multinomial", "bayes"),
        default="auto",
        help="how intervals are made: clopper-pearson (0/1 utilities), multinomial (bounded utilities), "
        "bayes (Dirichlet posterior); auto picks the first that applies (default)",
    )
    a.add_argument("--seed", type=int, default=0, metavar="S", help="random seed of --method bayes (default 0)")
    a.add_argument(
        "--draws", type=int, default=4000, metavar="N", help="posterior draws of --method bayes (default 4000)"
    )
    a.add_argument(
        "--concentration",
        type=float,
        default=1.0,
        metavar="C",
        help="Dirichlet prior mass of --method bayes (default 1, AIF360's smoothing)",
    )
    _add_report_options(a)
    add_text_format(a)
    a.add_argument("--dropna", action="store_true", help="drop records with missing values in the used columns")
    a.add_argument(
        "--mixed-outcome",
        action="store_true",
        help="the outcome mixes numbers and text on purpose (ranks and 'unranked'): count each value as an outcome "
        "of its own (else an error naming the rows; --utility accepts them too)",
    )
    a.add_argument(
        "--count",
        metavar="COL",
        help="DATA is a count table (one row per context, group and outcome, "
        "e.g. from SQL GROUP BY) whose column COL holds the number of records",
    )
    add_output(a)
    a.set_defaults(func=run)


def _add_report_options(a: argparse.ArgumentParser) -> None:
    """Weights, small cells, the per-context table, the gaps of g and the impact-ratio report."""
    a.add_argument(
        "--weights",
        metavar="COL",
        help="column of sample (survey) weights: weighted counts; intervals on Kish's effective sample size",
    )
    a.add_argument(
        "--min-count",
        type=positive_int,
        metavar="N",
        help="leave out (context, group) cells with fewer than N records, listed in the report",
    )
    a.add_argument(
        "--by",
        choices=("context",),
        help="context: add a table of L within each context (records, L, ratio, the pair of groups)",
    )
    a.add_argument(
        "--gap-on",
        choices=("u", "g"),
        default="u",
        help="u (default): the demographic parity and equalized odds gaps are total-variation distances of U's "
        "distribution; g: also the differences of E[g] between groups (fairlearn's selection-rate differences)",
    )
    a.add_argument(
        "--report",
        choices=("impact-ratio",),
        help="add a report: impact-ratio, the selection (or scoring) rate and impact ratio of each category of each "
        "sensitive column and of their intersection, as NYC Local Law 144 bias audits publish them; the metrics "
        "are then over the categories of the intersection's impact ratios (those under 2%% of the data left out)",
    )
    a.add_argument(
        "--threshold",
        type=float,
        metavar="T",
        help="with --report impact-ratio: each category's verdict: below T and significantly different from the "
        "highest rate, below and not significant (inconclusive), or not below (default 0.8, the four-fifths rule "
        "of thumb)",
    )
    a.add_argument(
        "--adjustment",
        choices=("holm", "none", "simultaneous"),
        help="with --report impact-ratio: how the tests and intervals of the report share alpha: holm (default; "
        "intervals at Bonferroni's level), none, or simultaneous (every ratio's range over simultaneous "
        "Clopper-Pearson intervals on every rate, Bonferroni's p-values)",
    )
    a.add_argument(
        "--test",
        choices=("fisher", "z"),
        help="with --report impact-ratio: the two-sided test of equal rates against the highest: fisher (default, "
        "Fisher's exact test) or z (the pooled two-proportion z test; always with weights or counts not whole)",
    )
    a.add_argument(
        "--data-source",
        choices=("historical", "test"),
        help="with --report impact-ratio: the data the audit uses, as the report states it (6 RCNY 5-303)",
    )
    a.add_argument("--no-progress", dest="progress", action="store_false", help="no bar while DuckDB reads DATA")
    a.add_argument("--audit-date", metavar="YYYY-MM-DD", help="with --report impact-ratio: the audit's date")
    a.add_argument(
        "--distribution-date",
        metavar="YYYY-MM-DD",
        help="with --report impact-ratio: the date the employer began using the tool",
    )
    a.add_argument(
        "--digits",
        type=int,
        metavar="N",
        help="with --report impact-ratio: print rates and ratios to N decimals, rounded half up as published "
        "audits print them (intervals outwards); default 4 significant digits",
    )


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit audit``; returns the exit status (with ``--published``, 1 when the table is not consistent)."""
    if args.published is not None:
        return _published(args)
    if args.data is None:
        raise InputError("DATA", "give the records to audit (or --published TABLE to check a published audit)")
    for name in ("sensitive", "outcome"):
        if getattr(args, name) is None:
            raise InputError(f"--{name}", "is required with DATA")
    from fairaudit.base.progress import progress_shown
    from fairaudit.data.counts import count_file
    from fairaudit.statistics.intervals import IntervalOptions
    from fairaudit.statistics.record_audit import audit
    from fairaudit.statistics.record_options import RecordOptions

    intervals = None
    if args.confidence is not None:
        intervals = IntervalOptions(**{f.name: getattr(args, f.name) for f in dataclasses.fields(IntervalOptions)})
    elif args.method != "auto":
        raise InputError("method", "chooses how intervals are made: give `confidence` too", args.method)
    # DuckDB counts the file (Parquet or CSV; fairaudit.data.counts.count_file); --count: DATA is a count table
    columns = {name: getattr(args, name) for name in ("sensitive", "outcome", "context", "dropna")}
    with progress_shown(args.progress):  # (DuckDB's progress through the file, after half a second)
        table = count_file(
            args.data,
            **columns,
            count=args.count,
            csv=text_format(args),
            weights=args.weights,
            mixed_outcome=args.mixed_outcome or args.utility is not None,  # --utility: what each value is worth
        )
    report = None
    if args.report == "impact-ratio":
        from fairaudit.statistics.ll144 import AuditFacts, FourFifths, impact_ratios

        digits = None if args.digits is None else whole(args.digits, "digits", high=15)
        given = {name: getattr(args, name) for name in ("threshold", "confidence", "adjustment", "test")}
        rule = FourFifths(**{name: value for name, value in given.items() if value is not None})
        facts = AuditFacts(args.data_source, args.audit_date, args.distribution_date)
        report = impact_ratios(table, args.utility, positive=args.positive, four_fifths=rule, facts=facts)
        table, _ = report.headline_table()  # the metrics over the categories of the impact ratios
    else:
        for name in ("threshold", "digits", "adjustment", "test", "data_source", "audit_date", "distribution_date"):
            if getattr(args, name) is not None:
                raise InputError(
                    name, "goes with the impact ratios: give --report impact-ratio too", getattr(args, name)
                )
    result = audit(
        table,
        sensitive=args.sensitive,
        outcome=args.outcome,
        context=args.context,
        positive=args.positive if report is None else None,
        utility=args.utility if report is None else report.utility,
        intervals=intervals,
        records=RecordOptions(min_count=args.min_count),  # (the table is counted: dropna and weights were used there)
    )
    data = result.to_dict()
    if args.by == "context":
        from fairaudit.statistics.small_cells import by_context_rows

        data["by_context"] = by_context_rows(result.observed.local_fairness, result.table, json=True)
    if args.gap_on == "g":
        data["gaps_on_g"] = result.gaps_on_g.to_dict()
    if report is not None:
        data.update(report.to_dict())
        data["impact_ratio_details"]["headline"] = report.headline_dict()
        if digits is not None:
            data["impact_ratio_details"]["digits"] = digits
    summary = f"audit: {records(data)}, L = {data['local']['value']} nats"
    emit(args, render(data, "audit", args.format), summary)
    return 0


def _published(args: argparse.Namespace) -> int:
    """``fairaudit audit --published TABLE``: the table checked, exit 0 when consistent, 1 when not."""
    from fairaudit.data.record_files import source
    from fairaudit.statistics.published_audit import check_published

    if args.data is not None:
        raise InputError("--published", "checks a published table alone: give it without DATA", args.published)
    table = source(args.published, text_format(args))
    checked = check_published(table.read(as_written=table.names))
    data = checked.to_dict()
    bad = sum(1 for r in checked.rows if r.findings)
    summary = f"published: {len(checked.rows)} rows, " + ("consistent" if not bad else f"{bad} with a finding")
    emit(args, render(data, "audit", args.format), summary)
    return 0 if checked.consistent else 1
