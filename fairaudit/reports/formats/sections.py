"""Pieces shared by the formats (text, Markdown, HTML): numbers in words, pairs of groups, the rows of common tables.

The row builders return plain text, unescaped: each format escapes what it
writes (Markdown's table cells, HTML's text).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from fairaudit.base.json_values import Report, number

__all__ = [
    "ASSUMPTION_HEAD",
    "BOUNDS",
    "BOUND_HEAD",
    "BY_CONTEXT_HEAD",
    "CONTEXTS_SHOWN",
    "GAP_HEAD",
    "GAP_NOTE",
    "METRICS",
    "OBSERVED_PARTS",
    "OUTCOME_HEAD",
    "PLAN_HEAD",
    "TARGET_HEAD",
    "assumption_rows",
    "audit_facts",
    "audit_notes",
    "bound_detail",
    "bound_rows",
    "by_context_table",
    "calibration_sentences",
    "certificate_facts",
    "count",
    "counts_sentence",
    "fmt",
    "gap_rows",
    "impact_notes",
    "impact_tables",
    "impact_title",
    "measure",
    "metric_rows",
    "metric_table",
    "nats",
    "observed_notes",
    "outcome_rows",
    "outcomes_more",
    "pair",
    "plan_head",
    "plan_rows",
    "population_line",
    "published_notes",
    "published_tables",
    "record_rows",
    "records",
    "sentence",
    "target_rows",
    "where",
]


def fmt(v: object, digits: int = 6) -> str:
    """A JSON value for reading: ``n/a`` for None, ``yes``/``no``, integers as they are, floats to ``digits``.

    Examples
    --------
    >>> fmt(None), fmt(True), fmt(3), fmt(0.123456789), fmt("inf"), fmt(0.123456789, 3)
    ('n/a', 'yes', '3', '0.123457', 'inf', '0.123')
    """
    if v is None:
        return "n/a"
    if isinstance(v, str):
        return v
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    return f"{v:.{digits}g}"


def nats(v: object, digits: int = 6) -> str:
    """A value in nats (to ``digits`` significant digits): ``0.5 nats``, ``inf`` or ``n/a``."""
    return "n/a" if v is None else ("inf" if v == "inf" else f"{fmt(v, digits)} nats")


def where(d: Report) -> str:
    """``a vs b in context x`` of a measure's dictionary (where it is attained); empty without a group.

    Examples
    --------
    >>> where({"group": "f", "other_group": "m (40+)", "context": "x"}), where({"group": None})
    ('f vs m (40+) in context x', '')
    """
    if d.get("group") is None:
        return ""
    ctx = f" in context {d['context']!s}" if d.get("context") is not None else ""
    return f"{d['group']!s} vs {d['other_group']!s}{ctx}"


def pair(d: Report) -> str:
    """`` (a vs b in context x)`` of a measure's dictionary; empty without a group."""
    w = where(d)
    return f" ({w})" if w else ""


def population_line(d: Report) -> str:
    """The reports' population line."""
    p = d["population"]
    if p["independent"] == "assumed":
        return f"population P(X, A): {p['description']}"
    state = "independent" if p["independent"] else "dependent"
    return (
        f"population P(X, A): {p['description']}; X and A {state} in it (max |P(x,a) - P(x)P(a)| = "
        f"{fmt(p['max_deviation'], 3)} at context {fmt(p['context'])}, group {fmt(p['group'])})"
    )


def goal(kind: str, target: object) -> str:
    """'the local target 0.5 nats on L' (or on L-bar for the global one)."""
    return f"the {kind} target {nats(target)} on {'L' if kind == 'local' else 'L-bar'}"


def measure(d: Report) -> str:
    """``L-bar`` for a calibration of the global measure, else ``L``."""
    return "L-bar" if d.get("kind") == "global" else "L"


def plan_head(d: Report) -> list[str]:
    """The two lines that state a plan's question and its assumed model."""
    name = "L-bar" if d["kind"] == "global" else "L"
    ctx = f"{d['contexts']} context{'s' if d['contexts'] != 1 else ''}"
    filt = (
        f"queried behind {d['groups']}-ary randomized response at epsilon = {nats(d['epsilon'])}"
        if d["epsilon"] is not None
        else "no privacy filter"
    )
    return [
        f"queries per cell to certify {name} <= {nats(d['target'])} at confidence {fmt(d['confidence'])} "
        f"with power {fmt(d['power'])}",
        f"model: {d['groups']} groups x {ctx}, E[g] = {fmt(d['base_rate'])}, group 0 times "
        f"exp({fmt(d['disparity'])}); {filt}; true {name} = {nats(d['true_value'])}",
    ]


#: Columns of a plan's table, one row per method.
PLAN_HEAD = ("method", "n per cell", "n total", "power", "median upper end", "datasets")


def plan_rows(d: Report) -> list[tuple[str, ...]]:
    """A plan's table rows, one per method (columns :data:`PLAN_HEAD`)."""
    return [
        (
            p["method"],
            fmt(p["n_per_cell"]),
            fmt(p["n_total"]),
            fmt(p["achieved_power"], 3),
            nats(p["expected_upper"], 4),
            "exact" if p["datasets"] is None else str(p["datasets"]),
        )
        for p in d["plans"]
    ]


#: The certificate's bounds on L, in the order shown, with their names.
BOUNDS = (
    ("paper", "paper (main theorem)"),
    ("tight", "tight (its proof, per pair)"),
    ("black_box", "black-box (exact worst case)"),
    ("corollary", "corollary (epsilon)"),
)

#: The observed metrics, in the order shown, with their names.
METRICS = (
    ("local", "local g-fairness L"),
    ("global", "global g-fairness L-bar"),
    ("demographic_parity", "demographic parity gap"),
    ("equalized_odds", "equalized odds gap"),
    ("sup_local", "sup over g of L"),
    ("sup_global", "sup over g of L-bar"),
)

#: The headings of the observed parts of a certificate, in the order shown (Markdown and HTML).
OBSERVED_PARTS = (("observed", "Observed behind the filter"), ("unfiltered", "Observed without the filter"))

#: The columns of the tables of :func:`bound_rows`, :func:`target_rows` and :func:`assumption_rows`.
BOUND_HEAD = ("bound", "value", "details")
TARGET_HEAD = ("target", "value", "bound", "result", "observed", "reason")
ASSUMPTION_HEAD = ("assumption", "status", "detail", "for")

#: How many exclusions the reports list (the JSON has them all).
EXCLUDED_SHOWN = 10

#: How many contexts the text and Markdown reports list with their records (the JSON has them all).
CONTEXTS_SHOWN = 30


def certificate_facts(d: Report) -> list[tuple[str, str]]:
    """What a certificate is about, as (name, description): the privacy of A and of X, the utility, the population."""
    ps, pc, u = d["privacy"]["sensitive"], d["privacy"]["context"], d["utility"]
    return [
        (
            f"privacy of {d['sensitive']['name']!s}",
            f"{ps['mechanism']}, epsilon = {nats(ps['epsilon'])}, delta = {fmt(ps['delta'])}, "
            f"keep probability {fmt(ps['keep_probability'])}",
        ),
        (f"privacy of {d['context']['name']!s}", f"{pc['mechanism']}, epsilon = {nats(pc['epsilon'])}"),
        (
            "utility",
            f"{u['name']}, range [{fmt(u['lower'])}, {fmt(u['gamma'])}], tau = {fmt(u['tau'])}, "
            f"L_A = {fmt(u['lipschitz'])}",
        ),
        ("population P(X, A)", population_line(d).removeprefix("population P(X, A): ")),
    ]


def audit_facts(d: Report) -> list[tuple[str, str]]:
    """What an audit is about, as (name, description): columns, utility, population and the intervals' level."""
    facts = [
        ("sensitive", ", ".join(str(s) for s in d["sensitive"])),
        ("outcome", str(d["outcome"])),
        ("context", ", ".join(str(c) for c in d["context_columns"]) or "none"),
        ("utility", str(d["utility"]["name"])),
        ("population P(X, A)", population_line(d).removeprefix("population P(X, A): ")),
    ]
    if d["confidence"] is not None:
        facts.append(("intervals", f"simultaneous {fmt(d['confidence'])} ({d['interval_method']})"))
    return facts


def bound_rows(d: Report) -> list[tuple[str, str, str]]:
    """The certificate's bounds on L (:data:`BOUNDS`, in order): (name, value, :func:`bound_detail`)."""
    return [(name, nats(d["bounds"][key]), bound_detail(d, key)) for key, name in BOUNDS]


def bound_detail(d: Report, key: str) -> str:
    """How a certificate's bound ``key`` (of :data:`BOUNDS`) was found, or why it is missing or does not apply."""
    det, v = d["bound_details"], d["bounds"][key]
    extra = ""
    if key in ("paper", "tight") and key in det:
        extra = f"at epsilon = {fmt(det[key]['epsilon'])}, delta = {fmt(det[key]['delta'])}"
    if key == "black_box":
        bb = det["black_box"]
        extra = (
            f"({bb['reason']})"
            if bb.get("value") is None
            else f"({fmt(bb['group'])} over {fmt(bb['other_group'])}; on L-bar {nats(bb['global']['value'])})"
        )
    if key in ("paper", "tight") and v is None:
        extra = "(needs utility.tau)"
    if key in det and det[key].get("holds") is False:
        extra += " (does not apply: an assumption is violated)"
    return extra.strip()


def interval(o: Report, key: str) -> str | None:
    """``[lower, upper]`` of metric ``key`` in an observed dictionary, None without one."""
    iv = (o.get("intervals") or {}).get(key)
    return f"[{fmt(iv['lower'])}, {fmt(iv['upper'])}]" if iv else None


def without_label(d: Report) -> bool:
    """An audit of records without a context column: no true label, so no equalized-odds line in the reports.

    Its one context (``all``) would make the equalized-odds gap the demographic-parity gap again; the JSON keeps
    the key. A certificate's dictionaries have no ``context_columns``: their every metric is shown.
    """
    return d.get("context_columns") == []


def metric_rows(o: Report) -> list[tuple[str, str, str, str, str | None]]:
    """The observed metrics (:data:`METRICS`): (name, value, ratio or decision, where, interval or None).

    An audit without a context column has no equalized-odds row (:func:`without_label`).
    """
    det = o["details"]
    rows: list[tuple[str, str, str, str, str | None]] = []
    for key, name in METRICS:
        if key == "equalized_odds" and without_label(o):
            continue
        if key in ("local", "global"):
            value, detail, at = nats(o[key]["value"]), f"ratio {fmt(o[key]['ratio'])}", o[key]
        elif key in ("sup_local", "sup_global"):
            value, detail, at = nats(o[key]), f"decision {det[key]['decision']!s}", det[key]
        else:
            value, detail, at = fmt(o[key]), "", det[key]
        rows.append((name, value, detail, where(at), interval(o, key)))
    return rows


def metric_table(o: Report) -> tuple[tuple[str, ...], list[tuple[str, ...]]]:
    """The observed metrics as a table: its head and its rows (:func:`metric_rows`).

    With intervals the last column is the interval, headed by their level and method, ``n/a`` where a metric has
    none; without, the rows have no interval column.
    """
    rows = metric_rows(o)
    head: tuple[str, ...] = ("metric", "value", "ratio or decision", "where")
    iv = o.get("intervals")
    if not iv:
        return head, [r[:4] for r in rows]
    head += (f"simultaneous {fmt(iv['confidence'])} interval ({iv['method']})",)
    return head, [r[:4] + (r[4] or "n/a",) for r in rows]


def sentence(text: str) -> str:
    """``text`` as a sentence: its first letter capitalised and a full stop at its end."""
    return text[0].upper() + text[1:] + "."


def counts_sentence(o: Report) -> str | None:
    """The white-box certificate and the evidence of unfairness that the intervals on L give, None without them."""
    iv = o.get("intervals")
    if not iv or not iv.get("local"):
        return None
    return (
        f"from counts, simultaneous {fmt(iv['confidence'])} ({iv['method']}): white-box certificate "
        f"L <= {nats(iv['local']['upper'])}; evidence of unfairness L >= {nats(iv['local']['lower'])}"
    )


def observed_notes(o: Report) -> tuple[list[str], list[str], int]:
    """The intervals' notes, the first :data:`EXCLUDED_SHOWN` exclusions and how many more there are."""
    notes = [str(n) for n in (o.get("intervals") or {}).get("notes", [])]
    excluded = [str(e) for e in o.get("excluded", [])]
    return notes, excluded[:EXCLUDED_SHOWN], max(0, len(excluded) - EXCLUDED_SHOWN)


def target_rows(targets: Report) -> list[tuple[str, str, str, str, str, str]]:
    """One row per target: (target, value, bound, met or NOT met, observed, reason)."""
    return [
        (
            str(k),
            nats(t["target"]),
            nats(t["bound"]),
            "met" if t["met"] else "NOT met",
            nats(t["observed"]),
            str(t["reason"]),
        )
        for k, t in targets.items()
    ]


def assumption_rows(d: Report) -> list[tuple[str, str, str, str]]:
    """One row per assumption of a certificate: (name, status, detail, the bounds it is needed for)."""
    return [(str(a["name"]), str(a["status"]), str(a["detail"]), ", ".join(a["for"])) for a in d["assumptions"]]


def calibration_sentences(c: Report, plain: bool = False) -> list[str]:
    """A certificate's calibration as sentences: the black-box ε for any model (or why none), the white-box one.

    ``plain``: as the text report writes them (``epsilon <=``, lower case, no final period).
    """
    eps, le, head, end = ("epsilon", "<=", "calibration", "") if plain else ("ε", "≤", "Calibration", ".")
    lines: list[str] = []
    if c["method"] is None:
        lines.append(f"{head}: skipped ({c['reason']}){end}")
    elif c["feasible"]:
        goals = " and ".join(goal(k, v) for k, v in c.get("targets", {}).items()) or goal(c["kind"], c["target"])
        lines.append(
            f"{head}: {c.get('family') or 'randomized response'} with {eps} {le} {nats(c['epsilon'])} "
            f"(keep probability {fmt(c['keep_probability'])}) would meet {goals} for any model ({c['method']}){end}"
        )
        if "left_out" in c:
            lines.append(f"{head} leaves out a target: {c['left_out']}{end}")
    else:
        lines.append(
            f"{head}: no {eps} meets {goal(c['kind'], c['target'])} for any model ({c['method']}): {c['reason']}{end}"
        )
    w = c.get("white_box")
    if w is not None and w["feasible"]:
        lines.append(
            f"{head} for this model: {eps} {le} {nats(w['epsilon'])} (keep probability "
            f"{fmt(w['keep_probability'])}) keeps its {measure(w)} {le} {nats(w['target'])} (white_box){end}"
        )
    elif w is not None:
        lines.append(f"{head} for this model: no {eps} (white_box): {w['reason']}{end}")
    return lines


IMPACT_HEAD = (
    "category",
    "number of applicants",
    "{rate} rate",
    "impact ratio",
    "interval ({level})",
    "p-value",
    "threshold {threshold}",
)


def impact_title(d: Report) -> str:
    """The impact-ratio report's title: its applicants (of known category), sensitive columns and outcome."""
    details = d["impact_ratio_details"]
    applicants = sum(r["n"] for r in d["impact_ratios"] if r["type"] == details["intersection"])
    weighted = " (total weight)" if d.get("weight_column") else ""
    return (
        f"impact ratios (NYC Local Law 144 bias audit): {fmt(applicants)} applicants{weighted}; sensitive "
        f"{', '.join(d['sensitive'])}; outcome {d['outcome']}"
    )


def impact_tables(d: Report) -> list[tuple[str, tuple[str, ...], list[tuple[str, ...]]]]:
    """The impact-ratio report (``--report impact-ratio``) as one table per category type: (type, head, rows).

    The layout of published bias audits (NYC Local Law 144): category, number of applicants, selection (or
    scoring) rate, impact ratio; then the interval on the ratio, the p-value of equal rates with the highest, and the
    category's verdict against the threshold (below, significant; below, inconclusive; not below); with records of
    unknown category, the ratio's range over every way they could belong to the categories. An excluded category
    (under 2% of the data) keeps its number and rate, its ratio reads "excluded (< 2%)".
    """
    details = d["impact_ratio_details"]
    head = tuple(
        h.format(rate=details["rate"], level=fmt(details["confidence"]), threshold=fmt(details["threshold"]))
        for h in IMPACT_HEAD
    )
    ranges = any(r["unknown_range"] is not None for r in d["impact_ratios"])
    head = (*head[:-1], "with the unknowns", head[-1]) if ranges else head
    number = _impact_number(details.get("digits"))
    tables: dict[str, list[tuple[str, ...]]] = {}
    for r in d["impact_ratios"]:
        ratio = "excluded (< 2%)" if r["excluded"] else number(r["impact_ratio"], "half up")
        iv = r["interval"]
        interval = "" if iv is None else f"[{number(iv[0], 'down')}, {number(iv[1], 'up')}]"
        p = "" if r["p_value"] is None else fmt(r["p_value"], 2)
        row: tuple[str, ...] = (
            str(r["category"]), fmt(r["n"]), number(r["rate"], "half up"), ratio, interval, p, r["verdict"] or ""
        )  # fmt: skip
        if ranges:
            u = r["unknown_range"]
            row = (*row[:-1], "" if u is None else f"[{number(u[0], 'down')}, {number(u[1], 'up')}]", row[-1])
        tables.setdefault(r["type"], []).append(row)
    return [(name, head, rows) for name, rows in tables.items()]


def _impact_number(digits: int | None) -> Callable[[object, str], str]:
    """How the impact tables print a rate, ratio or interval end: 4 significant digits, or ``digits`` decimals
    rounded as published audits round (half up; an interval's ends outwards)."""
    if digits is None:
        return lambda v, how: fmt(v, 4)
    from fairaudit.statistics.ll144 import round_half_up

    return lambda v, how: fmt(v) if not isinstance(v, float) else f"{round_half_up(v, digits, how):.{digits}f}"


def impact_notes(d: Report) -> list[str]:
    """The sentences under the impact-ratio tables: the rate, the marks, nats, exclusions, unknown categories."""
    details = d["impact_ratio_details"]
    if details["rate"] == "scoring":
        rate = (
            f"scoring rate: the share of the category scoring above the whole sample's median, {fmt(details['median'])}"
        )
    else:
        rate = "selection rate: the share of the category selected"
    t = fmt(details["threshold"])
    alpha = fmt(1 - details["confidence"], 2)
    test = "Fisher's exact test (twice its smaller tail)" if details["test"] == "fisher" else "the pooled z test"
    adjusted = {
        "holm": f"Holm-adjusted over the {details['tested']} tested ratios; intervals at Bonferroni's level, so they "
        "hold at once",
        "none": "not adjusted: each test and interval alone",
        "simultaneous": "Bonferroni-adjusted; intervals: each ratio's range over simultaneous Clopper-Pearson "
        "intervals on every rate",
    }[details["adjustment"]]
    notes = [
        f"{rate}; impact ratio: the category's rate over the highest rate of its type (6 RCNY 5-301); interval: on "
        f"that ratio at {fmt(details['confidence'])}; p-value: {test} of equal rates with the highest, two-sided, "
        f"{adjusted}",
        f"threshold {t}{' (the four-fifths rule of thumb)' if details['threshold'] == 0.8 else ''}: below, "
        f"significant, the ratio under {t} and the p-value under {alpha}; below, inconclusive, the ratio under {t} "
        f"and the p-value at or above {alpha}; not below, the ratio at or above {t} (29 CFR 1607.4(D))",
    ]
    ratios = [
        r["impact_ratio"] for r in d["impact_ratios"] if r["type"] == details["intersection"] and not r["excluded"]
    ]
    if ratios:
        lowest = min(ratios)
        value = math.inf if lowest == 0 else -math.log(lowest)
        notes.append(
            f"in nats: the lowest impact ratio by {details['intersection']}, {fmt(lowest, 4)}, is L-bar = "
            f"-ln {fmt(lowest, 4)} = {nats(number(value))} over its categories; every impact ratio >= {t} is "
            f"L-bar <= ln(1/{t}) = {nats(-math.log(details['threshold']))}"
        )
    total = sum(r["n"] for r in d["impact_ratios"] if r["type"] == details["intersection"])
    excluded = [
        f"{r['type']} {r['category']} ({fmt(r['n'])} applicants, {fmt(100 * r['n'] / total, 2)}% of {fmt(total)}; "
        f"rate {fmt(r['rate'], 4)})"
        for r in d["impact_ratios"]
        if r["excluded"]
    ]
    if excluded:
        notes.append(
            "under 2% of the data, left out of the impact ratios (6 RCNY 5-301 allows it): " + ", ".join(excluded)
        )
    source = {"historical": "historical data", "test": "test data"}.get(details.get("data_source") or "")
    facts = [f"data: {source}"] if source else []
    dates = (("audit_date", "audit date"), ("distribution_date", "distribution date (the tool's first use)"))
    facts += [f"{name} {details[key]}" for key, name in dates if details.get(key)]
    if facts:
        notes.append("; ".join(facts))
    unknown = [f"{k} {fmt(v)}" for k, v in details["unknown"].items() if v]
    notes.append("records of unknown category: " + (", ".join(unknown) if unknown else "none"))
    ranged = [r for r in d["impact_ratios"] if r["unknown_range"] is not None]
    if ranged:
        threshold = details["threshold"]
        flips = [
            f"{r['type']} {r['category']}" for r in ranged if r["unknown_range"][0] < threshold <= r["unknown_range"][1]
        ]
        notes.append(
            "with the unknowns: the least and greatest impact ratio over every way the records of unknown category "
            "could belong to the categories of the type (the highest rate moves with them; for the intersection, to any "
            "of its categories, even where part of theirs is known: a range that holds, not the sharp one); the "
            "unknowns can move across the threshold: " + (", ".join(flips) if flips else "none")
        )
    return notes


def headline_note(d: Report) -> str | None:
    """With ``--report impact-ratio``: which categories the metrics cover, when the intersection leaves some out."""
    headline = d.get("impact_ratio_details", {}).get("headline")
    if not headline:
        return None
    if headline["left_out"]:
        cells = ", ".join(f"{c['category']} ({fmt(c['n'])} records)" for c in headline["left_out"])
        return (
            f"the metrics are over the categories of the impact ratios by {headline['type']}; left out, under 2% "
            f"of the data: {cells}"
        )
    if headline["includes_small"]:
        return (
            f"the metrics include the categories under 2% of the data that the impact ratios by {headline['type']} "
            "leave out (fewer than two of its categories hold 2% of the data)"
        )
    return None


GAP_HEAD = ("metric", "value", "where")
"""The columns of :func:`gap_rows`."""


def gap_rows(d: Report) -> list[tuple[str, str, str]]:
    """The gaps of E[g] (``--gap-on g``): (label, value, the pair and where), labelled apart from U's gaps.

    Without a context column, no equalized-odds row (:func:`without_label`).
    """
    gaps = d["gaps_on_g"]
    rows = [("demographic parity gap of g", gaps["demographic_parity"], "")]
    if not without_label(d):
        eo = gaps["equalized_odds"]
        rows.append(("equalized odds gap of g", eo, f" in context {eo['context']}"))
    return [(name, fmt(gap["value"]), f"{gap['group']} vs {gap['other_group']}{at}") for name, gap, at in rows]


GAP_NOTE = (
    "gaps of g: differences of E[g] between groups (fairlearn's selection-rate differences for a 0/1 g); the gaps "
    "above are total-variation distances of the outcome's whole distribution"
)


def audit_notes(d: Report) -> list[str]:
    """The audit's notes on small cells: the cell that drives L when it cannot support it, the cells left out."""
    from fairaudit.statistics.small_cells import small_cell_sentence

    headline = headline_note(d)
    notes = [] if headline is None else [headline]
    if d.get("small_cell"):
        notes.append(small_cell_sentence(d["small_cell"]))
    if d.get("left_out"):
        cells = [f"(context {c['context']}, group {c['group']}): {fmt(c['n'])}" for c in d["left_out"]]
        shown = cells[:EXCLUDED_SHOWN] + (
            [f"... and {len(cells) - EXCLUDED_SHOWN} more"] if len(cells) > EXCLUDED_SHOWN else []
        )
        many = f"{len(cells)} cells" if len(cells) > 1 else "1 cell"
        notes.append(f"left out, fewer than {d['min_count']} records (--min-count): {many}: " + "; ".join(shown))
    return notes


BY_CONTEXT_HEAD = ("context", "records", "L (nats)", "ratio", "pair")


def by_context_table(d: Report) -> list[tuple[str, str, str, str, str]]:
    """``--by context``: one row per context, L within it and its pair of groups."""
    return [
        (str(r["context"]), fmt(r["n"]), nats(r["value"]), fmt(r["ratio"]), f"{r['group']} vs {r['other_group']}")
        for r in d["by_context"]
    ]


def records(d: Report) -> str:
    """The audit's size: ``N records``, or with weights ``total weight W (weights COL)``."""
    if d.get("weight_column"):
        return f"total weight {fmt(d['n'])} (weights {d['weight_column']})"
    return f"{d['n']} records"


OUTCOMES_SHOWN = 30
"""How many outcome values the text, Markdown and HTML reports list (all are in the JSON)."""

OUTCOME_HEAD = ("outcome value", "records", "g(u)")
"""The columns of :func:`outcome_rows`."""


def record_rows(parts: list[Report]) -> list[tuple[object, str]]:
    """(label, records) of each group or context dictionary of an audit (``d["groups"]``, ``d["contexts"]``)."""
    return [(p["label"], count(p["n"])) for p in parts]


def outcome_rows(d: Report) -> list[tuple[str, str, str]]:
    """The first :data:`OUTCOMES_SHOWN` outcome values of an audit: (value, records, g(u) or ``-``).

    Examples
    --------
    >>> outcome_rows({"outcome_values": [{"label": 0, "n": 98, "g": 0.0}, {"label": "yes", "n": 3, "g": None}]})
    [('0', '98', '0'), ('yes', '3', '-')]
    """
    return [
        (str(v["label"]), count(v["n"]), "-" if v["g"] is None else fmt(v["g"]))
        for v in d.get("outcome_values", [])[:OUTCOMES_SHOWN]
    ]


def outcomes_more(d: Report) -> str | None:
    """``... and N more outcome values (all in --format json)``, when the reports list only some."""
    more = len(d.get("outcome_values", [])) - OUTCOMES_SHOWN
    return f"... and {more} more outcome values (all in --format json)" if more > 0 else None


def count(v: object) -> str:
    """A number of records, or a sum of weights (six significant digits)."""
    return fmt(v) if isinstance(v, float) else str(v)


PUBLISHED_HEAD = (
    "category",
    "applicants",
    "selected",
    "rate",
    "from counts",
    "impact ratio",
    "recomputed",
    "with the unknowns",
    "ACLU's",
    "p-value",
    "verdict",
    "findings",
)
"""The columns of a checked published table (``fairaudit audit --published``)."""


def published_tables(d: Report) -> list[tuple[str, tuple[str, ...], list[tuple[str, ...]]]]:
    """A checked published table (:meth:`~fairaudit.statistics.published_audit.PublishedAudit.to_dict`), one table
    per audit and category type: (title, head, rows). Figures as read; the recomputed ones to 4 significant
    digits; "with the unknowns" the sharp range of the ratio over every allocation of the unknown applicants,
    "ACLU's" their range with every unknown in the row's category and the comparator held."""

    def pair(lo: object, hi: object) -> str:
        return "" if lo is None or hi is None else f"[{fmt(lo, 4)}, {fmt(hi, 4)}]"

    tables: dict[str, list[tuple[str, ...]]] = {}
    for r in d["published"]:
        title = " / ".join(str(v) for v in (r["audit"], r.get("rate_kind"), r["type"]) if v) or "the table"
        row = (
            str(r["category"]), *("" if r[k] is None else fmt(r[k]) for k in ("applicants", "selected", "rate")),
            "" if r["recomputed_rate"] is None else fmt(r["recomputed_rate"], 4),
            "" if r["impact_ratio"] is None else fmt(r["impact_ratio"]),
            "" if r["recomputed_ratio"] is None or r["unknown"] else fmt(r["recomputed_ratio"], 4),
            pair(r["ratio_lower"], r["ratio_upper"]), pair(r["aclu_lower"], r["aclu_upper"]),
            "" if r["p_value"] is None else fmt(r["p_value"], 2), r["verdict"] or "",
            "; ".join(r["findings"]) or ("unknown category" if r["unknown"] else "consistent"),
        )  # fmt: skip
        tables.setdefault(title, []).append(row)
    return [(title, PUBLISHED_HEAD, rows) for title, rows in tables.items()]


def published_notes(d: Report) -> list[str]:
    """The sentences under a checked published table: what matches means, the comparators found, the verdict."""
    details = d["published_details"]
    bad = sum(1 for r in d["published"] if r["findings"])
    comparators = details["comparators"].items()
    return [
        "a printed figure matches when it is within half a unit of its last printed decimal of the exact value; a "
        "ratio is recomputed over the highest rate of its type (from the printed rates' rounding where the table "
        "has no counts)",
        "p-value: Fisher's exact test of equal rates with the type's highest rate, from the counts, Holm-adjusted over "
        "the audit's tests; verdict: the recomputed ratio against 0.8 and the p-value against 0.05",
        *(f"{where}: every printed ratio is the rate over {c}'s, not over the highest" for where, c in comparators),
        f"{details['rows']} rows checked: consistent"
        if details["consistent"]
        else f"{details['rows']} rows checked: {bad} with a finding (exit status 1)",
    ]
