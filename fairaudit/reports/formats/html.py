"""The HTML format: one self-contained HTML5 document per report (``--format html``).

Each report is one file that needs nothing else: the style sheet is in the
page, the figures are inline ``<svg>`` drawn by matplotlib, there is no
script and no address of anything outside the file (it opens offline, and
mailing or archiving it keeps it whole). The content is that of the text and
Markdown reports (headings, the tables of bounds, metrics, records, targets
and assumptions, the notes), with figures: for ``audit`` E[g | a] per group
and, with several contexts, E[g | x, a] per context and group, each with its
interval when there is one; for ``certify`` the bounds on L against the
observed L and the target.

The page is made by the Jinja2 template ``page.html.jinja`` (package data
beside this module) with autoescaping on, so that every text from the data (a label ``<script>``, a title with ``&``) is shown as written;
the only markup not escaped is the SVG that matplotlib writes (which escapes
its own text). Jinja2 and matplotlib are the extra ``html`` (``pip install
'fairness-certify[html]'``); they are imported only when a page is made, and without
them :class:`HtmlFormat` raises an :class:`~fairaudit.InputError` naming
``format``.
"""

from __future__ import annotations

import io
import json
import math
import re
from collections.abc import Callable, Sequence
from importlib import resources
from typing import TYPE_CHECKING, Any

from fairaudit.base.errors import optional_modules
from fairaudit.base.json_values import Report
from fairaudit.reports.formats import sections
from fairaudit.reports.formats.base import Format
from fairaudit.reports.formats.text import calibration_text, worst_case_text

if TYPE_CHECKING:
    import jinja2
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["HtmlFormat", "svg_of"]

#: How many contexts (and groups) the figure of E[g | x, a] draws; the table of cells lists more.
CONTEXTS_DRAWN, GROUPS_DRAWN = 30, 40
#: How many cells (context, group) the table of cells lists (the JSON has them all).
CELLS_SHOWN = 2000
#: How many contexts the table of records per context lists.
CONTEXTS_LISTED = 2000

#: matplotlib's colours of the bounds in :func:`fairaudit.reports.plots.plot_curve`, reused here.
_BOUND_COLOURS = {"paper": "tab:red", "tight": "tab:orange", "black_box": "tab:blue", "corollary": "0.55"}


class _Page:
    """A report being built: its title and its blocks (headings, sentences, tables, lists, figures).

    Every text is kept as plain text; the template escapes it.
    """

    def __init__(self, title: str) -> None:
        problem = "html needs jinja2 and matplotlib, which are not installed: pip install 'fairness-certify[html]'"
        self.jinja2 = optional_modules("format", problem, "jinja2", "matplotlib")[0]  # before any work
        self.title = title
        self.blocks: list[dict[str, Any]] = []

    def h2(self, text: str) -> None:
        """A section's heading."""
        self.blocks.append({"kind": "h2", "text": text})

    def p(self, text: str) -> None:
        """A paragraph."""
        self.blocks.append({"kind": "p", "text": text})

    def verdict(self, ok: bool, text: str) -> None:
        """The report's verdict, green when ``ok``, else red."""
        self.blocks.append({"kind": "verdict", "css": "yes" if ok else "no", "text": text})

    def facts(self, facts: Sequence[tuple[str, str]], code: tuple[str, ...] = ()) -> None:
        """A list of (name, description); the descriptions of the names in ``code`` as code."""
        self.blocks.append({"kind": "facts", "items": [(k, v, k in code) for k, v in facts]})

    def bullets(self, items: Sequence[str]) -> None:
        """A bulleted list (nothing when empty)."""
        if items:
            self.blocks.append({"kind": "list", "items": list(items)})

    def table(self, head: Sequence[str], rows: Sequence[Sequence[object]], numeric: Sequence[int] = ()) -> None:
        """A table (None shown as ``n/a``); the columns ``numeric`` (indices) are aligned right."""
        cells = [["n/a" if c is None else str(c) for c in r] for r in rows]
        self.blocks.append({"kind": "table", "head": list(head), "rows": cells, "numeric": set(numeric)})

    def figure(self, draw: Callable[[], Figure], caption: str) -> None:
        """A figure drawn by ``draw``, inline as SVG (ids prefixed by its number in the page), with its caption."""
        n = sum(b["kind"] == "figure" for b in self.blocks) + 1
        self.blocks.append({"kind": "figure", "svg": svg_of(draw, f"fig{n}-"), "text": caption})

    def render(self) -> str:
        """The whole document: the template with autoescaping (SVG blocks marked safe)."""
        env: jinja2.Environment = self.jinja2.Environment(
            autoescape=True, trim_blocks=True, lstrip_blocks=True, undefined=self.jinja2.StrictUndefined
        )
        from markupsafe import Markup

        blocks = [{**b, "svg": Markup(b["svg"])} if b["kind"] == "figure" else b for b in self.blocks]
        template = resources.files(__package__).joinpath("page.html.jinja").read_text(encoding="utf-8")
        text: str = env.from_string(template).render(title=self.title, blocks=blocks)
        return text


class HtmlFormat(Format):
    """One self-contained HTML5 page per report: inline CSS, tables, inline SVG figures, no script, no network."""

    name = "html"

    def certificate(self, d: Report) -> str:
        """The certificate's content (as the text report) with a figure of the bounds against the observed L."""
        page = _Page(f"fairaudit certificate: {d['title'] or d['spec']}")
        page.verdict(bool(d["certified"]), f"Certified: {'yes' if d['certified'] else 'no'}")
        page.facts(sections.certificate_facts(d))
        page.h2("Bounds on L for any decision model behind the filter")
        page.table(sections.BOUND_HEAD, sections.bound_rows(d), numeric=(1,))
        page.p(f"Best valid bound: {sections.nats(d['bounds']['best'])} ({d['bounds']['best_form']}).")
        page.figure(lambda: _bounds_figure(d), _bounds_caption(d))
        for key, head in sections.OBSERVED_PARTS:
            if key in d:
                page.h2(head)
                _observed(page, d[key], counts=key == "observed")
            elif key == "observed" and "observed_omitted" in d:
                page.h2(head)
                page.p(f"Left out: {d['observed_omitted']}")
        if "targets" in d:
            page.h2("Targets")
            page.table(sections.TARGET_HEAD, sections.target_rows(d["targets"]), numeric=(1, 2, 4))
        if "calibration" in d:
            page.h2("Calibration")
            for sentence in sections.calibration_sentences(d["calibration"]):
                page.p(sentence)
        page.h2("Assumptions")
        page.table(sections.ASSUMPTION_HEAD, sections.assumption_rows(d))
        return page.render()

    def audit(self, d: Report) -> str:
        """The audit's content (as the text report), the cells' table and figures of E[g | a] and E[g | x, a]."""
        if "published" in d:  # fairaudit audit --published: the checked table alone
            page = _Page("A published bias audit, checked")
            for title, head, published_rows in sections.published_tables(d):
                page.h2(title)
                page.table(head, published_rows, numeric=(1, 2, 3, 4, 5, 6))
            page.bullets(sections.published_notes(d))
            return page.render()
        if "impact_ratios" in d:  # the report asked for first, the headline metrics after
            page = _Page(sections.impact_title(d))
            for name, head, impact_rows in sections.impact_tables(d):
                page.h2(f"Impact ratios by {name}")
                page.table(head, impact_rows, numeric=(1, 2, 3, head.index("p-value")))
            page.bullets(sections.impact_notes(d))
            page.h2(f"The audit: {sections.records(d)}")
        else:
            page = _Page(f"fairaudit audit: {sections.records(d)}")
        page.facts(sections.audit_facts(d), code=("utility",))
        page.h2("Metrics")
        _observed(page, d)
        page.h2("Records and E[g | a] per group")
        means = group_means(d)
        rows = [
            (label, n, sections.fmt(m), None if iv is None else f"[{sections.fmt(iv[0])}, {sections.fmt(iv[1])}]")
            for label, n, m, iv in means
        ]
        width = 4 if any(iv is not None for *_, iv in means) else 3  # the interval's column where there is one
        page.table(("group", "records", "E[g | a]", "interval")[:width], [r[:width] for r in rows], numeric=(1, 2))
        page.figure(lambda: _groups_figure(d, means), _groups_caption(d))
        if "outcome_values" in d:
            page.h2("Records per outcome value")
            page.table(sections.OUTCOME_HEAD, sections.outcome_rows(d), numeric=(1, 2))
            if sections.outcomes_more(d):
                page.p(f"{sections.outcomes_more(d)}.")
        if len(d["contexts"]) > 1:
            page.h2("Records per context")
            shown = d["contexts"][:CONTEXTS_LISTED]
            page.table(("context", "records"), sections.record_rows(shown), numeric=(1,))
            if len(d["contexts"]) > len(shown):
                page.p(f"... and {len(d['contexts']) - len(shown)} more contexts (all in --format json).")
            page.h2("E[g | x, a] per context and group")
            page.figure(lambda: _cells_figure(d), _cells_caption(d))
        page.bullets(sections.audit_notes(d))
        if "by_context" in d:
            page.h2("L by context")
            page.table(sections.BY_CONTEXT_HEAD, sections.by_context_table(d), numeric=(1, 2, 3))
        if "gaps_on_g" in d:
            page.h2("Gaps of g")
            page.table(sections.GAP_HEAD, sections.gap_rows(d), numeric=(1,))
            page.p(sections.GAP_NOTE + ".")
        _cells_table(page, d)
        return page.render()

    def calibration(self, d: Report) -> str:
        """The calibration's lines (as the text report), one sentence each."""
        page = _Page("fairaudit calibration")
        for line in calibration_text(d).splitlines():
            page.p(line)
        return page.render()

    def worst_case(self, d: Report) -> str:
        """The worst-case lines (as the text report), one paragraph each."""
        page = _Page("fairaudit worst case")
        for line in worst_case_text(d).splitlines():
            page.p(line.strip())
        return page.render()

    def plan(self, d: Report) -> str:
        """The question and the assumed model, a table of the methods and why a method found no n."""
        page = _Page("fairaudit plan")
        for line in sections.plan_head(d):
            page.p(sections.sentence(line))
        page.table(sections.PLAN_HEAD, sections.plan_rows(d), numeric=(1, 2, 3, 4, 5))
        page.bullets([f"{p['method']}: {p['reason']}" for p in d["plans"] if p["reason"]])
        return page.render()


def _observed(page: _Page, o: Report, counts: bool = False) -> None:
    """The observed metrics' table, then (with ``counts``) what the intervals certify, the notes and exclusions."""
    head, rows = sections.metric_table(o)
    page.table(head, rows, numeric=(1,))
    found = sections.counts_sentence(o) if counts else None
    if found is not None:
        page.p(sections.sentence(found))
    notes, excluded, more = sections.observed_notes(o)
    if notes:
        page.p("Notes on the intervals:")
        page.bullets(notes)
    if excluded:
        page.p("Excluded:")
        page.bullets(excluded + ([f"... and {more} more exclusions (all in --format json)"] if more else []))


def _cells_table(page: _Page, d: Report) -> None:
    """Records and E[g | x, a] (with its interval) of every cell (context, group), up to :data:`CELLS_SHOWN`."""
    cells = d["cells"]
    with_iv = any("interval" in c for c in cells)
    page.h2("Cells")
    head = ["context", "group", "records", "E[g | x, a]"] + (["interval"] if with_iv else [])
    rows = []
    for c in cells[:CELLS_SHOWN]:
        row: list[object] = [c["context"], c["group"], sections.count(c["n"]), sections.fmt(c["expected_utility"])]
        if with_iv:
            iv = c.get("interval")
            row.append(None if iv is None or iv[0] is None else f"[{sections.fmt(iv[0])}, {sections.fmt(iv[1])}]")
        rows.append(row)
    page.table(head, rows, numeric=(2, 3))
    if len(cells) > CELLS_SHOWN:
        page.p(f"... and {len(cells) - CELLS_SHOWN} more cells (all in --format json).")


def group_means(d: Report) -> list[tuple[object, int, float | None, tuple[float, float] | None]]:
    """E[g | a] per group of an audit's dictionary: (label, records, E[g | a], interval or None).

    E[g | a] is the mean over the group's records, pooled over contexts (the
    cells' E[g | x, a] weighted by their records); None for a group without
    records. The interval is the cell's when there is a single context (it is
    then E[g | a]'s), else None: the audit's intervals are per cell.

    Examples
    --------
    >>> d = {"groups": [{"label": "a", "n": 3}, {"label": "b", "n": 0}], "contexts": [{"label": "x", "n": 1}, {"label": "y", "n": 2}],
    ...      "cells": [{"context": "x", "group": "a", "n": 1, "expected_utility": 1.0},
    ...                {"context": "y", "group": "a", "n": 2, "expected_utility": 0.25},
    ...                {"context": "x", "group": "b", "n": 0, "expected_utility": None}]}
    >>> group_means(d)
    [('a', 3, 0.5, None), ('b', 0, None, None)]
    """
    out: list[tuple[object, int, float | None, tuple[float, float] | None]] = []
    single = len(d["contexts"]) == 1
    by_group: dict[str, list[Report]] = {}  # one pass over the cells (labels as JSON: lists are not hashable)
    for c in d["cells"]:
        by_group.setdefault(json.dumps(c["group"]), []).append(c)
    for g in d["groups"]:
        cells = by_group.get(json.dumps(g["label"]), [])
        used = [c for c in cells if c["n"] and isinstance(c["expected_utility"], (int, float))]
        total = sum(c["n"] for c in used)
        mean = sum(c["n"] * c["expected_utility"] for c in used) / total if total else None
        iv = cells[0].get("interval") if single and cells else None
        interval = (float(iv[0]), float(iv[1])) if iv is not None and None not in iv else None
        out.append((g["label"], g["n"], mean, interval))
    return out


def svg_of(draw: Callable[[], Figure], prefix: str = "fig-") -> str:
    """The figure that ``draw`` makes, as an ``<svg>`` element to put inline in an HTML page.

    ``draw`` runs with matplotlib's math text off (a ``$`` in a label is a
    dollar sign); the SVG is written with text as text (``svg.fonttype``
    none), no date and reproducible ids. The XML prolog, DOCTYPE and namespace
    declarations are dropped (HTML needs none) and every id gets ``prefix``,
    so that several figures in one page never share one.

    Parameters
    ----------
    draw : callable
        Makes and returns a :class:`matplotlib.figure.Figure`.
    prefix : str
        Put before each id of the SVG (and each reference to one).

    Returns
    -------
    str
    """
    import matplotlib

    buf = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": "fairaudit", "svg.fonttype": "none", "text.parse_math": False}):
        draw().savefig(buf, format="svg", metadata={"Date": None, "Creator": None, "Format": None, "Type": None})
    svg = buf.getvalue()
    svg = svg[svg.index("<svg") :]

    # only inside tags: matplotlib escapes "<" and ">" in text, so a tag never holds text from the data
    def tag(m: re.Match[str]) -> str:
        t = re.sub(r'\s+xmlns(:\w+)?="[^"]*"', "", m.group(0))
        t = t.replace(' id="', f' id="{prefix}').replace('href="#', f'href="#{prefix}')
        return t.replace("url(#", f"url(#{prefix}")

    svg = re.sub(r"<[^<>]*>", tag, svg).strip()
    return svg.replace("<svg ", '<svg role="img" ', 1)


def _new_figure(width: float, height: float) -> Figure:
    """A figure of ``width`` by ``height`` inches (at most 40 high), constrained layout, made without pyplot."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width, min(height, 40.0)), layout="constrained")


def _short(text: object, width: int = 40) -> str:
    """A label for an axis: at most ``width`` characters, on one line."""
    s = " ".join(str(text).split())
    return s if len(s) <= width else s[: width - 1] + "…"


def _num(v: object) -> float:
    """A report's number as a float: ``"inf"`` as inf, None (n/a) as NaN."""
    return math.nan if v is None else math.inf if v == "inf" else float(v)  # type: ignore[arg-type]


def _style(i: int) -> tuple[Any, str]:
    """Colour and marker of the i-th group: tab10 (tab20 past ten groups), markers changing every 20."""
    from matplotlib import colormaps

    return colormaps["tab20" if i >= 10 else "tab10"](i % 20 if i >= 10 else i), "osD^v"[(i // 20) % 5]


def _bounds_figure(d: Report) -> Figure:
    """Bars of the bounds on L (paper, tight, black-box, corollary); lines of the observed L and the local target."""
    from fairaudit.reports.figures import mark_infinite, on_scale

    fig = _new_figure(7.0, 5.0)
    ax = fig.add_subplot()
    values = on_scale([_num(d["bounds"][k]) for k, _ in sections.BOUNDS]).tolist()  # beyond 1e300: at the top, as +inf
    lines = [(label, float(on_scale([v])[0]), style) for label, v, style in _bound_lines(d)]
    ends = [v for v in values if math.isfinite(v)] + [v for _, v, _ in lines if math.isfinite(v)]
    ends += [v for v in on_scale(_observed_interval(d)) if math.isfinite(v)]
    top = max(1.15 * max(ends, default=0.0), 0.1)
    for i, ((key, _), v) in enumerate(zip(sections.BOUNDS, values)):
        if math.isnan(v):
            ax.text(i, 0.02 * top, "n/a", ha="center", va="bottom", fontsize=9, color="0.35")
            continue
        holds = d["bound_details"].get(key, {}).get("holds") is not False
        best = key == d["bounds"].get("best_form")
        ax.bar(
            i,
            top if math.isinf(v) else v,
            width=0.6,
            color=_BOUND_COLOURS[key],
            alpha=0.75 if holds else 0.3,
            hatch=None if holds else "//",
            edgecolor="black" if best else "none",
            linewidth=1.8 if best else 0.0,
            zorder=2,
        )
        if math.isinf(v):
            mark_infinite(ax, [i], _BOUND_COLOURS[key])
        else:
            ax.text(i, v, sections.fmt(v, 4), ha="center", va="bottom", fontsize=8, zorder=5)
    for label, v, style in lines:
        where = " (+∞, drawn at the top)" if math.isinf(v) else ""
        ax.axhline(min(v, 0.98 * top), label=label + where, zorder=4, **style)
    lo, hi = _observed_interval(d)
    if math.isfinite(lo) and math.isfinite(hi):
        ax.axhspan(
            lo,
            hi,
            color="0.55",
            alpha=0.25,
            lw=0,
            zorder=1,
            label=f"its interval [{sections.fmt(lo)}, {sections.fmt(hi)}]",
        )
    names = ["paper\n(main theorem)", "tight\n(its proof)", "black-box\n(exact)", "corollary\n(ε)"]
    names = [n + ("\n[best]" if k == d["bounds"].get("best_form") else "") for n, (k, _) in zip(names, sections.BOUNDS)]
    ax.set_xticks(range(len(sections.BOUNDS)), labels=names, fontsize=9)
    ax.set_xlim(-0.6, len(sections.BOUNDS) - 0.4)
    ax.set_ylim(0.0, top)
    ax.set_ylabel("local g-fairness L (nats)")
    ax.grid(True, axis="y", color="0.9", lw=0.6, zorder=0)
    ax.set_axisbelow(True)
    ax.set_title("Bounds on L for any decision model behind the filter", fontsize=10)
    if ax.get_legend_handles_labels()[0]:
        fig.legend(loc="outside lower center", ncols=2, fontsize=8, frameon=False)
    return fig


def _bound_lines(d: Report) -> list[tuple[str, float, dict[str, Any]]]:
    """The horizontal lines of the bounds' figure: (label, value, style) of the observed L's and the local target."""
    out: list[tuple[str, float, dict[str, Any]]] = []
    for key, what, ls in (("observed", "behind the filter", "-"), ("unfiltered", "without the filter", "--")):
        if key in d and not math.isnan(v := _num(d[key]["local"]["value"])):
            label = f"observed L {what}: {sections.nats(v if math.isfinite(v) else 'inf')}"
            out.append((label, v, {"color": "black", "ls": ls, "lw": 1.4}))
    t = (d.get("targets") or {}).get("local")
    if t is not None and not math.isnan(v := _num(t["target"])):
        out.append((f"local target: {sections.nats(t['target'])}", v, {"color": "tab:purple", "ls": ":", "lw": 2.0}))
    return out


def _observed_interval(d: Report) -> tuple[float, float]:
    """The interval on the observed L (behind the filter), NaNs without one."""
    iv = d.get("observed", {}).get("local", {}).get("interval")
    return (math.nan, math.nan) if not iv or None in iv else (_num(iv[0]), _num(iv[1]))


def _bounds_caption(d: Report) -> str:
    """The caption of :func:`_bounds_figure`: what each bar and line is."""
    parts = [
        "The bounds on L for any decision model behind the filter (bars; the best valid bound outlined; "
        "hatched: an assumption it needs is violated; ▲ at the top edge: +∞; n/a: not computed)"
    ]
    if "observed" in d:
        parts.append("the observed L of the model behind the filter (solid line")
        parts[-1] += "; grey band: its interval)" if math.isfinite(_observed_interval(d)[0]) else ")"
    if "unfiltered" in d:
        parts.append("the observed L of the model without the filter (dashed)")
    if (d.get("targets") or {}).get("local") is not None:
        parts.append("the local target (dotted)")
    return parts[0] + (", against " + ", ".join(parts[1:]) if len(parts) > 1 else "") + ". In nats."


def _groups_figure(d: Report, means: Sequence[tuple[object, int, float | None, tuple[float, float] | None]]) -> Figure:
    """E[g | a] per group (a point each, with its interval when there is one), first group on top."""
    shown = list(means[:GROUPS_DRAWN])
    fig = _new_figure(7.0, 1.3 + 0.3 * len(shown))
    ax = fig.add_subplot()
    for i, (label, _, mean, iv) in enumerate(shown):
        if mean is None:
            ax.text(0.0, i, " no records", va="center", fontsize=8, color="0.35")
            continue
        err = None if iv is None else [[max(0.0, mean - iv[0])], [max(0.0, iv[1] - mean)]]
        ax.errorbar([mean], [i], xerr=err, fmt="o", color="black", ecolor="0.35", ms=5, capsize=3, lw=1.2)
    ends = [v for _, _, m, iv in shown for v in ((m,) if m is not None else ()) + (iv or ())]
    _category_axis(ax, [label for label, *_ in shown])
    _value_axis(ax, d, "E[g | a]", ends)
    ax.set_title("E[g | a] per group", fontsize=10)
    return fig


def _category_axis(ax: Axes, labels: Sequence[object]) -> None:
    """The y axis of a dot plot: one row per label, the first on top."""
    ax.set_yticks(range(len(labels)), labels=[_short(x) for x in labels], fontsize=8)
    ax.set_ylim(len(labels) - 0.5, -0.5)


def _value_axis(ax: Axes, d: Report, name: str, ends: Sequence[float]) -> None:
    """The x axis of E[g | ...]: from the utility's lower end (0 at most) to the largest of ``ends``, grid, label."""
    lower = _num(d["utility"].get("lower"))
    finite = [float(v) for v in ends if math.isfinite(v)]
    lo = min([0.0, *finite] + ([lower] if math.isfinite(lower) else []))
    hi = max([lo, *finite])
    pad = 0.04 * (hi - lo) if hi > lo else 0.05
    ax.set_xlim(lo - pad, hi + pad)
    ax.set_xlabel(f"{name} (utility {_short(d['utility']['name'], 60)})")
    ax.grid(True, axis="x", color="0.9", lw=0.6)
    ax.set_axisbelow(True)


def _groups_caption(d: Report) -> str:
    """The caption of :func:`_groups_figure`: how E[g | a] is computed, which intervals, what is left out."""
    n = len(d["groups"])
    text = "E[g | a] per group: the mean of g over the group's records"
    if len(d["contexts"]) > 1:
        text += ", pooled over the contexts (the cells' E[g | x, a] weighted by their records)"
    if d.get("confidence") is not None and len(d["contexts"]) == 1:
        text += f", with its simultaneous {sections.fmt(d['confidence'])} interval ({d['interval_method']})"
    elif d.get("confidence") is not None:
        text += "; the intervals are per cell (the figure of E[g | x, a])"
    if n > GROUPS_DRAWN:
        text += f"; the first {GROUPS_DRAWN} of {n} groups (all in the table)"
    return text + "."


def _cells_figure(d: Report) -> Figure:
    """E[g | x, a] per context (a row each, first on top) and group (a colour each), with the cells' intervals."""
    contexts = [c["label"] for c in d["contexts"][:CONTEXTS_DRAWN]]
    groups = [g["label"] for g in d["groups"][:GROUPS_DRAWN]]
    cells = {(c["context"], c["group"]): c for c in d["cells"]}
    fig = _new_figure(8.5, 1.5 + len(contexts) * max(0.35, 0.07 * len(groups)))
    ax = fig.add_subplot()
    ends: list[float] = []
    offsets = [0.0] if len(groups) == 1 else [0.7 * (j / (len(groups) - 1) - 0.5) for j in range(len(groups))]
    for j, g in enumerate(groups):
        xs, ys, lo, hi = [], [], [], []
        for i, x in enumerate(contexts):
            c = cells.get((x, g))
            if c is None or not c["n"] or not isinstance(c["expected_utility"], (int, float)):
                continue
            e = float(c["expected_utility"])
            iv = c.get("interval")
            ok = iv is not None and None not in iv
            xs.append(e)
            ys.append(i + offsets[j])
            lo.append(max(0.0, e - float(iv[0])) if ok else 0.0)
            hi.append(max(0.0, float(iv[1]) - e) if ok else 0.0)
        colour, marker = _style(j)
        ax.errorbar(xs, ys, xerr=[lo, hi], fmt=marker, color=colour, ms=4, capsize=2, lw=1.0, label=_short(g, 30))
        ends += [e - a for e, a in zip(xs, lo)] + [e + b for e, b in zip(xs, hi)]
    for i in range(len(contexts) - 1):
        ax.axhline(i + 0.5, color="0.85", lw=0.6)
    _category_axis(ax, contexts)
    _value_axis(ax, d, "E[g | x, a]", ends)
    ax.set_title("E[g | x, a] per context and group", fontsize=10)
    ax.legend(
        title="group",
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
        frameon=False,
        ncols=1 + len(groups) // 21,
    )
    return fig


def _cells_caption(d: Report) -> str:
    """The caption of :func:`_cells_figure`: which intervals, what is left out."""
    text = "E[g | x, a] per context (rows) and group (colours)"
    if d.get("confidence") is not None:
        text += f", with the simultaneous {sections.fmt(d['confidence'])} intervals ({d['interval_method']})"
    text += "; cells without records are not drawn"
    if len(d["contexts"]) > CONTEXTS_DRAWN:
        text += f"; the first {CONTEXTS_DRAWN} of {len(d['contexts'])} contexts"
    if len(d["groups"]) > GROUPS_DRAWN:
        text += f"; the first {GROUPS_DRAWN} of {len(d['groups'])} groups"
    return text + " (every cell is in the table of cells)."
