"""The Markdown format: headings, sentences and tables (``--format markdown``)."""

from __future__ import annotations

from collections.abc import Sequence

from .._json import Report
from ._base import Format
from ._common import PLAN_HEAD, fmt, goal, nats, pair, plan_head, plan_rows, population_line
from .text import calibration_text

__all__ = ["MarkdownFormat"]


class MarkdownFormat(Format):
    """GitHub-flavoured Markdown: one heading per report, tables for bounds, metrics, targets and assumptions."""

    name = "markdown"

    def certificate(self, d: Report) -> str:
        """Privacy, population, the bounds, what was observed, targets, calibration and assumptions."""
        lines = [f"# fairaudit certificate: {d['title'] or d['spec']}", ""]
        ps = d["privacy"]["sensitive"]
        lines.append(
            f"Privacy of **{d['sensitive']['name']}**: {ps['mechanism']}, ε = {nats(ps['epsilon'])}, "
            f"keep probability {fmt(ps['keep_probability'])}."
        )
        lines += ["", f"Population P(X, A): {population_line(d).removeprefix('population P(X, A): ')}."]
        lines += ["", "## Bounds on L for any decision model", ""]
        rows = [(k, nats(d["bounds"][k])) for k in ("paper", "tight", "black_box", "corollary")]
        lines += _table(rows, ("bound", "value"))
        lines += ["", f"Best valid bound: **{nats(d['bounds']['best'])}** ({d['bounds']['best_form']})."]
        for key, head in (("observed", "Observed behind the filter"), ("unfiltered", "Observed without the filter")):
            if key in d:
                lines += ["", f"## {head}", ""] + _observed_table(d[key])
        if "targets" in d:
            lines += ["", "## Targets", ""]
            lines += _table(
                [
                    (k, nats(t["target"]), nats(t["bound"]), "met" if t["met"] else "NOT met")
                    for k, t in d["targets"].items()
                ],
                ("target", "value", "bound", "result"),
            )
        if "calibration" in d:
            lines += _calibration_lines(d["calibration"])
        lines += ["", "## Assumptions", ""]
        lines += _table(
            [(a["name"], a["status"], a["detail"], ", ".join(a["for"])) for a in d["assumptions"]],
            ("assumption", "status", "detail", "for"),
        )
        lines += ["", f"**Certified: {'yes' if d['certified'] else 'no'}**", ""]
        return "\n".join(lines)

    def audit(self, d: Report) -> str:
        """Records per group, the population and the metrics' table."""
        lines = [
            f"# fairaudit audit: {d['n']} records",
            "",
            f"Sensitive: {', '.join(d['sensitive'])}; outcome: {d['outcome']}; utility: `{d['utility']['name']}`.",
            "",
        ]
        lines += _table([(g["label"], g["n"]) for g in d["groups"]], ("group", "records"))
        lines += ["", f"Population P(X, A): {population_line(d).removeprefix('population P(X, A): ')}.", ""]
        lines += _observed_table(d) + [""]
        return "\n".join(lines)

    def calibration(self, d: Report) -> str:
        """The text report in a code block under a heading."""
        return "# fairaudit calibration\n\n```\n" + calibration_text(d) + "```\n"

    def plan(self, d: Report) -> str:
        """The question and the assumed model as sentences, then a table of the methods."""
        head = plan_head(d)
        lines = ["# fairaudit plan", "", head[0] + ".", "", head[1] + ".", ""]
        lines += _table(plan_rows(d), PLAN_HEAD)
        lines += [""] + [f"* {p['method']}: {p['reason']}" for p in d["plans"] if p["reason"]]
        return "\n".join(lines).rstrip("\n") + "\n"


def _table(rows: Sequence[tuple[object, ...]], head: tuple[str, ...]) -> list[str]:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return out


def _observed_table(o: Report) -> list[str]:
    """The observed metrics: value, where it is attained and, with intervals, the interval."""
    rows: list[tuple[str, ...]] = [
        ("local g-fairness L", nats(o["local"]["value"]), pair(o["local"]).strip(" ()")),
        ("global g-fairness L-bar", nats(o["global"]["value"]), pair(o["global"]).strip(" ()")),
        (
            "demographic parity gap",
            fmt(o["demographic_parity"]),
            pair(o["details"]["demographic_parity"]).strip(" ()"),
        ),
        ("equalized odds gap", fmt(o["equalized_odds"]), pair(o["details"]["equalized_odds"]).strip(" ()")),
        ("sup over g of L", nats(o["sup_local"]), pair(o["details"]["sup_local"]).strip(" ()")),
        ("sup over g of L-bar", nats(o["sup_global"]), pair(o["details"]["sup_global"]).strip(" ()")),
    ]
    if o.get("intervals"):
        iv = o["intervals"]
        rows = [
            r + (f"[{fmt(iv[k]['lower'])}, {fmt(iv[k]['upper'])}]" if iv.get(k) else "n/a",)
            for r, k in zip(
                rows, ("local", "global", "demographic_parity", "equalized_odds", "sup_local", "sup_global")
            )
        ]
        head = ("metric", "value", "where", f"simultaneous {fmt(iv['confidence'])} interval ({iv['method']})")
        return _table(rows, head)
    return _table(rows, ("metric", "value", "where"))


def _calibration_lines(c: Report) -> list[str]:
    """A certificate's calibration as sentences: the black-box ε for any model (or why none), the white-box one."""
    lines: list[str] = []
    if c["method"] is None:
        lines += ["", f"Calibration: skipped ({c['reason']})."]
    elif c["feasible"]:
        goals = " and ".join(goal(k, v) for k, v in c.get("targets", {}).items()) or goal(c["kind"], c["target"])
        lines += [
            "",
            f"Calibration: ε ≤ {nats(c['epsilon'])} (keep probability {fmt(c['keep_probability'])}) "
            f"would meet {goals} for any model ({c['method']}).",
        ]
        if "left_out" in c:
            lines += ["", f"Calibration leaves out a target: {c['left_out']}."]
    else:
        lines += [
            "",
            f"Calibration: no ε meets {goal(c['kind'], c['target'])} for any model ({c['method']}): {c['reason']}.",
        ]
    w = c.get("white_box")
    if w is not None:
        lines += [
            "",
            f"Calibration for this model (white_box): ε ≤ {nats(w['epsilon'])} (keep probability "
            f"{fmt(w['keep_probability'])})."
            if w["feasible"]
            else f"Calibration for this model (white_box): no ε: {w['reason']}.",
        ]
    return lines
