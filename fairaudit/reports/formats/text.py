"""The text format: the reports as aligned plain-text lines (the default of ``--format``)."""

from __future__ import annotations

from collections.abc import Sequence

from fairaudit.base.json_values import Report
from fairaudit.reports.formats import sections
from fairaudit.reports.formats.base import Format

__all__ = ["TextFormat", "calibration_text", "worst_case_text"]


class TextFormat(Format):
    """Plain text, one line per quantity; each report ends with a newline."""

    name = "text"

    def certificate(self, d: Report) -> str:
        """Privacy, utility, population, the bounds, what was observed, targets, calibration, assumptions."""
        lines = [f"fairaudit certificate: {d['title'] or d['spec']}"] + [
            f"{k}: {v}" for k, v in sections.certificate_facts(d)
        ]
        lines += _bound_lines(d)
        if "observed" in d:
            lines += _observed_lines(d["observed"], "observed, the model behind the filter:")
            counts = sections.counts_sentence(d["observed"])
            if counts is not None:
                lines.append(f"  {counts}")
        elif "observed_omitted" in d:
            lines += ["observed, the model behind the filter: left out", f"  {d['observed_omitted']}"]
        if "unfiltered" in d:
            lines += _observed_lines(d["unfiltered"], "observed, the model without the filter:")
        if "targets" in d:
            lines += _target_lines(d["targets"])
        if "calibration" in d:
            lines += sections.calibration_sentences(d["calibration"], plain=True)
        lines.append("assumptions:")
        lines += [f"  [{a['status']}] {a['name']}: {a['detail']} (for {', '.join(a['for'])})" for a in d["assumptions"]]
        lines.append(f"certified: {'yes' if d['certified'] else 'no'}")
        return "\n".join(lines) + "\n"

    def audit(self, d: Report) -> str:
        """Records per group (and context), the population, the intervals' level and the metrics."""
        if "published" in d:  # fairaudit audit --published: the checked table alone
            lines = []
            for title, head, rows in sections.published_tables(d):
                lines += [f"published {title}:", *_aligned([head, *rows]), ""]
            return "\n".join(lines + sections.published_notes(d)) + "\n"
        ctx = ", ".join(d["context_columns"]) or "none"
        lines = []
        if "impact_ratios" in d:  # the report asked for first, the headline metrics after
            lines += [sections.impact_title(d), *_impact_lines(d)[1:], ""]
        lines += [
            f"fairaudit audit: {sections.records(d)}; sensitive {', '.join(d['sensitive'])}; outcome {d['outcome']}; "
            f"context {ctx}",
            f"utility: {d['utility']['name']}",
        ]

        def listed(what: str, items: list[str], more: bool = False) -> str:
            return f"records per {what}: " + ", ".join(items) + (" ..." if more else "")

        lines.append(listed("group", [f"{label} {n}" for label, n in sections.record_rows(d["groups"])]))
        if "outcome_values" in d:
            values = [f"{u} {n} (g {g})" for u, n, g in sections.outcome_rows(d)]
            lines.append(listed("outcome value", values, sections.outcomes_more(d) is not None))
        if len(d["contexts"]) > 1:
            shown = [f"{label} {n}" for label, n in sections.record_rows(d["contexts"][: sections.CONTEXTS_SHOWN])]
            lines.append(listed("context", shown, len(d["contexts"]) > sections.CONTEXTS_SHOWN))
        lines.append(sections.population_line(d))
        if d["confidence"] is not None:
            lines.append(f"intervals: simultaneous {sections.fmt(d['confidence'])} ({d['interval_method']})")
        lines += _observed_lines(d, "metrics:")
        lines += [f"note: {n}" for n in sections.audit_notes(d)]
        if "by_context" in d:
            lines += ["L by context:", *_aligned([sections.BY_CONTEXT_HEAD, *sections.by_context_table(d)])]
        if "gaps_on_g" in d:
            lines += [f"  {name:<28} {value:<18} ({where})" for name, value, where in sections.gap_rows(d)]
            lines.append(f"  {sections.GAP_NOTE}")
        return "\n".join(lines) + "\n"

    def calibration(self, d: Report) -> str:
        """The largest ε that meets the target (or why none does), its keep probability and the method."""
        return calibration_text(d)

    def worst_case(self, d: Report) -> str:
        """The class of utilities, the worst utility of L and of L-bar with their values, the spec's own."""
        return worst_case_text(d)

    def plan(self, d: Report) -> str:
        """The question, the assumed model and an aligned table of the methods."""
        lines = sections.plan_head(d)
        lines += _aligned([sections.PLAN_HEAD, *sections.plan_rows(d)])
        lines += [f"{p['method']}: {p['reason']}" for p in d["plans"] if p["reason"]]
        return "\n".join(lines) + "\n"


def worst_case_text(d: Report) -> str:
    """The ``worst-case`` report as text (the Markdown and HTML formats quote it)."""
    tau = "" if d["tau"] is None else f", E[g | x, a] >= tau = {sections.fmt(d['tau'])}"
    lines = [
        f"fairaudit worst case: {d['title'] or d['spec']}",
        f"law: {d['law']}; sensitive {d['sensitive']}, context {d['context']}",
        f"utilities: every g({d['decision']}) in [{sections.fmt(d['lower'])}, {sections.fmt(d['gamma'])}]{tau}",
    ]
    for key, name in (("local", "L"), ("global", "L-bar")):
        w = d[key]
        lines.append(f"worst utility for {name}: {_utility_line(d, w['utility'])}")
        lines.append(
            f"  {name} = {sections.nats(w['value'])}, ratio {sections.fmt(w['ratio'])}{sections.pair(w)}; "
            f"method {w['method']}" + (f" ({w['reason']})" if w.get("reason") else "")
        )
    u = d["spec_utility"]
    lines.append(
        f"the spec's utility {u['name']}: L = {sections.nats(u['local'])}, L-bar = {sections.nats(u['global'])}"
    )
    lines += [f"excluded: {e}" for e in d["excluded"]]
    return "\n".join(lines) + "\n"


def _utility_line(d: Report, values: list[float] | None) -> str:
    """``g = 1 on a, b; 0 on c``: the decisions grouped by their utility, the largest first (20 shown each).

    A value within 1e-9 (relative to gamma) of the class's end is shown as that end: an LP's point may lie that
    close to a vertex without reaching it (an interior-point solver's did, before issue 80, and certificates made then
    hold such points), and the JSON keeps its values as they are.
    """
    if values is None:
        return "none (no utility of the class meets tau)"
    lower, gamma = float(d["lower"]), float(d["gamma"])
    tol = 1e-9 * max(gamma, 1.0)
    by_value: dict[float, list[str]] = {}
    for decision, v in zip(d["decisions"], values):
        x = float(v)  # (values in [lower, gamma]: finite, never null)
        x = lower if abs(x - lower) <= tol else gamma if abs(x - gamma) <= tol else x
        by_value.setdefault(x, []).append(str(decision))
    parts = []
    for x in sorted(by_value, reverse=True):
        names = by_value[x]
        parts.append(f"{sections.fmt(x)} on {', '.join(names[:20])}{', ...' if len(names) > 20 else ''}")
    return "g = " + "; ".join(parts)


def calibration_text(d: Report) -> str:
    """The ``calibrate`` report as text (the Markdown format quotes it in a code block)."""
    up = _unparsed_line(d)
    ratio = d.get("target_impact_ratio")
    goal = f"{sections.measure(d)} <= {sections.nats(d['target'])}"
    if ratio is not None:  # the target given as an impact ratio r: L <= -ln r
        goal += (
            f" (every impact ratio >= {sections.fmt(ratio)}: {sections.measure(d)} is -ln of the worst impact ratio)"
        )
    if not d["feasible"]:
        low = (
            f"the model's {sections.measure(d)} at epsilon = 0"
            if d["method"] == "white_box"
            else "smallest certified bound"
        )
        return (
            f"no epsilon of {d['family']} meets {goal}\n"
            f"method: {d['method']}; {low}: {sections.nats(d['bound'])}\n{up}"
            f"reason: {d['reason']}\n"
        )
    there = f"the model's {sections.measure(d)} there" if d["method"] == "white_box" else "certified bound there"
    return (
        f"largest epsilon of {d['family']} meeting {goal}: {sections.nats(d['epsilon'])}\n"
        f"keep probability (the price): {sections.fmt(d['keep_probability'])}\n"
        f"method: {d['method']}; {there}: {sections.nats(d['bound'])}\n{up}"
        f"reason: {d['reason']}\n"
    )


def _unparsed_line(d: Report) -> str:
    """With an unparsed decision: the line saying that ε and the bound are the upper end over its utility."""
    u = d.get("unparsed")
    if not u:
        return ""
    lo, hi = u["range"]
    return (
        f"unparsed decision {u['decision']!s}: calibrated on the upper end of {sections.measure(d)} over every "
        f"utility of it in [{sections.fmt(lo)}, {sections.fmt(hi)}], chosen per cell of the model, not on its stated "
        "utility\n"
    )


def _bound_lines(d: Report) -> list[str]:
    """The bounds on L for any model behind the filter, each with its details, then the best valid one."""
    return [
        "bounds on L for any decision model behind the filter:",
        *(f"  {name:<30} {value}{' ' + detail if detail else ''}" for name, value, detail in sections.bound_rows(d)),
        f"  best valid bound: {sections.nats(d['bounds']['best'])} ({d['bounds']['best_form']})",
    ]


def _observed_lines(o: Report, head: str) -> list[str]:
    """The observed metrics under ``head``: value, where it is attained and its interval; notes; exclusions."""
    lines = [head] + [
        f"  {name:<28} {value:<18}{' ' + detail if detail else ''}{f' ({at})' if at else ''}"
        f"{f'  interval {iv}' if iv else ''}"
        for name, value, detail, at, iv in sections.metric_rows(o)
    ]
    notes, excluded, more = sections.observed_notes(o)
    lines += [f"  intervals: {n}" for n in notes] + [f"  excluded: {e}" for e in excluded]
    return lines + ([f"  ... and {more} more exclusions"] if more else [])


def _target_lines(targets: Report) -> list[str]:
    """One line per target: met or not, the bound and the observed value."""
    lines = []
    for k, t in targets.items():
        obs = f"; observed {sections.nats(t['observed'])}" if t["observed"] is not None else ""
        lines.append(
            f"target {k}: {sections.nats(t['target'])} -> {'MET' if t['met'] else 'NOT MET'} "
            f"(bound {sections.nats(t['bound'])}{obs}; {t['reason']})"
        )
    return lines


def _impact_lines(d: Report) -> list[str]:
    """The impact-ratio tables, aligned, one per category type, and their notes."""
    lines = []
    for name, head, rows in sections.impact_tables(d):
        lines += ["", f"impact ratios by {name}:", *_aligned([head, *rows])]
    return lines + [""] + sections.impact_notes(d)


def _aligned(table: Sequence[Sequence[str]]) -> list[str]:
    """A table (its head first) as lines indented by two spaces, each column padded to its widest cell."""
    widths = [max(len(r[i]) for r in table) for i in range(len(table[0]))]
    return ["  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in table]
