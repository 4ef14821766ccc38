"""The Markdown format: headings, sentences and tables (``--format markdown``).

Every text that comes from the data (labels, names, titles, notes) goes
through :func:`escape`, so that a label such as ``a|b``, ``*x*`` or
``<script>`` is shown as written and never breaks a table, starts emphasis or
becomes HTML: in table cells and in sentences alike.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from fairaudit.base.json_values import Report
from fairaudit.reports.formats import sections
from fairaudit.reports.formats.base import Format
from fairaudit.reports.formats.text import calibration_text, worst_case_text

__all__ = ["MarkdownFormat", "code_block", "code_span", "escape"]

# Markdown's inline syntax that a text could trigger, each made literal (CommonMark/GFM and Python-Markdown alike):
# the backslash escapes, "_" only at a word's edge (inside a word it is no emphasis), "<" before what could open a
# tag or an autolink, "&" before what could be an entity, "~~" (GFM's strikethrough; "\~" is no escape everywhere).
_SPECIAL = re.compile(
    r"""(?P<bs>[\\`*\[\]|#])"""
    r"""|(?P<us>(?<![A-Za-z0-9])_|_(?![A-Za-z0-9]))"""
    r"""|(?P<lt><(?=[A-Za-z/!?]))"""
    r"""|(?P<amp>&(?=#?[A-Za-z0-9]+;))"""
    r"""|(?P<tilde>~(?=~)|(?<=~)~)"""
)


#: The groups of :data:`_SPECIAL` written as an entity; the others are backslash-escaped.
_ENTITIES = {"lt": "&lt;", "amp": "&amp;", "tilde": "&#126;"}


def escape(text: object) -> str:
    """``text`` as Markdown that shows it literally, on one line (table cells included).

    Backslash-escapes ``\\ ` * [ ] | #`` and ``_`` at a word's edge; writes
    ``<`` before a letter, ``/``, ``!`` or ``?`` as ``&lt;``, ``&`` before an
    entity as ``&amp;`` and ``~~`` as ``&#126;&#126;``; a line break becomes
    ``<br>``. Other characters stay as they are, so that ordinary labels
    read the same in the Markdown source.

    Parameters
    ----------
    text : object
        Anything; ``str(text)`` is escaped.

    Returns
    -------
    str

    Examples
    --------
    >>> print(escape("a|b"), escape("*x* A_M _y_"), escape("<script>"), escape("<=50K & >50K"), escape("a\\nb"))
    a\\|b \\*x\\* A_M \\_y\\_ &lt;script> <=50K & >50K a<br>b
    """
    s = str(text).replace("\r\n", "\n").replace("\r", "\n")
    return _SPECIAL.sub(lambda m: _ENTITIES.get(m.lastgroup or "", "\\" + m.group(0)), s).replace("\n", "<br>")


def code_span(text: object) -> str:
    """``text`` as an inline code span: fenced by more backticks than it contains, on one line.

    Examples
    --------
    >>> code_span("u >= 5"), code_span("a`b")
    ('`u >= 5`', '`` a`b ``')
    """
    s = " ".join(str(text).splitlines())
    fence = "`" * (max((len(r) for r in re.findall("`+", s)), default=0) + 1)
    pad = " " if s.startswith("`") or s.endswith("`") or fence != "`" else ""
    return f"{fence}{pad}{s}{pad}{fence}"


def code_block(text: str) -> str:
    """``text`` in a fenced code block whose fence is longer than any run of backticks in it."""
    fence = "`" * max(3, max((len(r) for r in re.findall("`+", text)), default=0) + 1)
    return f"{fence}\n{text if text.endswith(chr(10)) else text + chr(10)}{fence}\n"


class MarkdownFormat(Format):
    """GitHub-flavoured Markdown: one heading per report, tables for bounds, metrics, targets and assumptions."""

    name = "markdown"

    def certificate(self, d: Report) -> str:
        """Privacy, utility, population, the bounds, what was observed, targets, calibration and assumptions."""
        lines = [f"# fairaudit certificate: {escape(d['title'] or d['spec'])}", ""]
        lines += _facts(sections.certificate_facts(d))
        lines += ["", "## Bounds on L for any decision model behind the filter", ""]
        lines += _table(sections.bound_rows(d), sections.BOUND_HEAD)
        lines += [
            "",
            f"Best valid bound: **{sections.nats(d['bounds']['best'])}** ({escape(d['bounds']['best_form'])}).",
        ]
        for key, head in sections.OBSERVED_PARTS:
            if key in d:
                lines += ["", f"## {head}", ""] + _observed(d[key], counts=key == "observed")
            elif key == "observed" and "observed_omitted" in d:
                lines += ["", f"## {head}", "", f"Left out: {escape(d['observed_omitted'])}"]
        if "targets" in d:
            lines += ["", "## Targets", ""]
            lines += _table(sections.target_rows(d["targets"]), sections.TARGET_HEAD)
        if "calibration" in d:
            lines += ["", "## Calibration"]
            for sentence in sections.calibration_sentences(d["calibration"]):
                lines += ["", escape(sentence)]
        lines += ["", "## Assumptions", ""]
        lines += _table(sections.assumption_rows(d), sections.ASSUMPTION_HEAD)
        lines += ["", f"**Certified: {'yes' if d['certified'] else 'no'}**", ""]
        return "\n".join(lines)

    def audit(self, d: Report) -> str:
        """The audit's columns, records per group and per context, the population, the metrics and the notes."""
        if "published" in d:  # fairaudit audit --published: the checked table alone
            lines = ["# A published bias audit, checked", ""]
            for title, head, rows in sections.published_tables(d):
                lines += [f"## {escape(title)}", ""] + _table(rows, head) + [""]
            return "\n".join(lines + [f"* {escape(n)}" for n in sections.published_notes(d)] + [""])
        lines = []
        if "impact_ratios" in d:  # the report asked for first, the headline metrics after
            lines += [f"# {escape(sections.impact_title(d))}", ""]
            for name, head, rows in sections.impact_tables(d):
                lines += [f"## By {escape(name)}", ""] + _table(rows, head) + [""]
            lines += [f"* {escape(n)}" for n in sections.impact_notes(d)] + [""]
        lines += [f"# fairaudit audit: {escape(sections.records(d))}", ""]
        lines += _facts(sections.audit_facts(d), code=("utility",))
        lines += ["", "## Records per group", ""]
        lines += _table(sections.record_rows(d["groups"]), ("group", "records"))
        if "outcome_values" in d:
            lines += ["", "## Records per outcome value", ""]
            lines += _table(sections.outcome_rows(d), sections.OUTCOME_HEAD)
            lines += ["", escape(sections.outcomes_more(d) or "") + "."] if sections.outcomes_more(d) else []
        if len(d["contexts"]) > 1:
            lines += ["", "## Records per context", ""]
            shown = d["contexts"][: sections.CONTEXTS_SHOWN]
            lines += _table(sections.record_rows(shown), ("context", "records"))
            if len(d["contexts"]) > len(shown):
                lines += ["", f"... and {len(d['contexts']) - len(shown)} more contexts (all in `--format json`)."]
        lines += ["", "## Metrics", ""] + _observed(d) + [""]
        lines += [f"**Note**: {escape(n)}." for n in sections.audit_notes(d)] + (
            [""] if sections.audit_notes(d) else []
        )
        if "by_context" in d:
            lines += ["## L by context", ""] + _table(sections.by_context_table(d), sections.BY_CONTEXT_HEAD) + [""]
        if "gaps_on_g" in d:
            lines += (
                ["## Gaps of g", ""]
                + _table(sections.gap_rows(d), sections.GAP_HEAD)
                + ["", escape(sections.GAP_NOTE) + ".", ""]
            )
        return "\n".join(lines)

    def calibration(self, d: Report) -> str:
        """The text report in a code block under a heading."""
        return "# fairaudit calibration\n\n" + code_block(calibration_text(d))

    def worst_case(self, d: Report) -> str:
        """The text report in a code block under a heading."""
        return "# fairaudit worst case\n\n" + code_block(worst_case_text(d))

    def plan(self, d: Report) -> str:
        """The question and the assumed model as sentences, then a table of the methods."""
        head = sections.plan_head(d)
        lines = ["# fairaudit plan", "", escape(head[0]) + ".", "", escape(head[1]) + ".", ""]
        lines += _table(sections.plan_rows(d), sections.PLAN_HEAD)
        lines += [""] + [f"* {escape(p['method'])}: {escape(p['reason'])}" for p in d["plans"] if p["reason"]]
        return "\n".join(lines).rstrip("\n") + "\n"


def _table(rows: Sequence[Sequence[object]], head: Sequence[str]) -> list[str]:
    """A table whose every cell is escaped (:func:`escape`): a cell never splits nor spans lines."""
    out = ["| " + " | ".join(escape(h) for h in head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(escape(c) for c in r) + " |" for r in rows]
    return out


def _facts(facts: Sequence[tuple[str, str]], code: tuple[str, ...] = ()) -> list[str]:
    """A bulleted list ``name: description``; the descriptions of the names in ``code`` as code spans."""
    return [f"* **{escape(k)}**: {code_span(v) if k in code else escape(v)}" for k, v in facts]


def _observed(o: Report, counts: bool = False) -> list[str]:
    """The observed metrics (value, ratio or decision, where, interval), then the intervals' notes and exclusions.

    With ``counts``, the white-box certificate and evidence that the intervals give (:func:`counts_sentence`).
    """
    head, rows = sections.metric_table(o)
    lines = _table(rows, head)
    found = sections.counts_sentence(o) if counts else None
    if found is not None:
        lines += ["", escape(sections.sentence(found))]
    notes, excluded, more = sections.observed_notes(o)
    if notes:
        lines += ["", "Notes on the intervals:", ""] + [f"* {escape(n)}" for n in notes]
    if excluded:
        lines += ["", "Excluded:", ""] + [f"* {escape(e)}" for e in excluded]
        if more:
            lines.append(f"* ... and {more} more exclusions (all in `--format json`)")
    return lines
