"""The Markdown reports are read by a real Markdown parser: every table keeps its shape and every label its text.

Each report (certify, audit, calibrate, plan) is made from the examples or from small tables whose labels hold
Markdown's syntax (``|``, ``*``, ``_``, ``<script>``, backslashes, backticks, ``&amp;``, brackets, a line break), then
converted to HTML by Python-Markdown (``extensions=["tables", "fenced_code"]``: GitHub's tables and code fences) and,
when it is installed, by markdown-it-py (CommonMark with GFM tables); the HTML is read back with the standard library's parser. The audit's
Markdown report must carry what the text report carries: context names, records per context, excluded cells, notes.
"""

from __future__ import annotations

from html.parser import HTMLParser
from pathlib import Path

import markdown
import pytest
from _reports import report_json

from fairaudit.reports.formats import render
from fairaudit.reports.formats.markdown import code_span, escape
from fairaudit.reports.formats.sections import BOUNDS, METRICS, bound_detail, certificate_facts, plan_rows, where

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"

# labels that are Markdown (or HTML) if written as they are
GROUPS = ["<script>alert(1)</script>", "a|b", "*bold* _x_", "back\\slash `tick`"]
CONTEXTS = ["c|1", "c*2*", "$x$ & &amp; <b>", "[link](#anchor) ~~s~~"]


class _Tables(HTMLParser):
    """The tables (rows of cell texts, ``<br>`` as a line break), the list items and the headings of a page."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[list[str]]] = []
        self.items: list[str] = []
        self.headings: list[str] = []
        self.paragraphs: list[str] = []
        self.code: list[str] = []
        self._cell: list[str] | None = None
        self._block: tuple[str, list[str]] | None = None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "br":
            for text in (self._cell, self._block[1] if self._block else None):
                if text is not None:
                    text.append("\n")
        elif tag in ("li", "h1", "h2", "p", "pre"):
            self._block = (tag, [])

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None
        elif self._block is not None and tag == self._block[0]:
            text = "".join(self._block[1])
            {"li": self.items, "h1": self.headings, "h2": self.headings, "p": self.paragraphs, "pre": self.code}[
                tag
            ].append(text if tag == "pre" else " ".join(text.split()))
            self._block = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)
        if self._block is not None:
            self._block[1].append(data)


def _python_markdown(text: str) -> str:
    return markdown.markdown(text, extensions=["tables", "fenced_code"])


def _markdown_it(text: str) -> str:
    markdown_it = pytest.importorskip("markdown_it")
    return markdown_it.MarkdownIt("commonmark").enable("table").render(text)


PARSERS = [pytest.param(_python_markdown, id="python-markdown"), pytest.param(_markdown_it, id="markdown-it")]


def _parse(text: str, parser) -> _Tables:
    page = _Tables()
    page.feed(parser(text))
    page.close()
    return page


@pytest.fixture(scope="module")
def weird_records(tmp_path_factory) -> Path:
    """Records whose groups, contexts and a column name are Markdown, with one empty cell; three outcomes."""
    path = tmp_path_factory.mktemp("weird") / "records.csv"
    lines = ['"ctx|col",grp,dec']
    for i, c in enumerate(CONTEXTS):
        for j, g in enumerate(GROUPS):
            if (i, j) == (1, 1):
                continue  # an empty cell: excluded, and said so
            dec = ["yes" if k < 4 + 2 * j + i else "maybe" if k % 3 else "no" for k in range(20)]
            lines += [f'"{c}","{g}",{x}' for x in dec]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def weird_audit(tmp_path_factory, weird_records) -> dict:
    args = ["--sensitive", "grp", "--context", "ctx|col", "--outcome", "dec", "--positive", "yes"]
    return report_json(tmp_path_factory, "weird", "audit", weird_records, *args, "--confidence", 0.9)


@pytest.fixture(scope="module")
def gpt_audit(tmp_path_factory) -> dict:
    csv = EXAMPLES / "llm_hiring" / "gpt_rank_counts.csv"
    args = ["--count", "count", "--sensitive", "demo", "--context", "model,job", "--outcome", "rank"]
    args += ["--mixed-outcome"]  # ranks 1 to 8 and "unranked"
    return report_json(tmp_path_factory, "gpt", "audit", csv, *args, "--positive", 1, "--confidence", 0.95)


@pytest.fixture(scope="module")
def weird_certificate(tmp_path_factory) -> dict:
    """A certificate whose title, attribute names and labels are Markdown."""
    folder = tmp_path_factory.mktemp("spec")
    rows = ["doc,office|name,chosen,probability"]
    for (c, a), p in {("c*1*", "a|b"): 0.3, ("c*1*", "<s>"): 0.6, ("back\\slash", "a|b"): 0.5}.items():
        rows += [f'"{c}","{a}",yes,{p}', f'"{c}","{a}",no,{1 - p}']
    rows += ['"back\\slash","<s>",yes,0.4', '"back\\slash","<s>",no,0.6']
    (folder / "model.csv").write_text("\n".join(rows) + "\n")
    (folder / "spec.toml").write_text(
        'title = "T | *x* <b>&amp; back\\\\slash"\n'
        '[sensitive]\nname = "office|name"\nvalues = ["a|b", "<s>"]\n'
        '[context]\nname = "doc"\nvalues = ["c*1*", "back\\\\slash"]\n'
        '[decision]\nname = "chosen"\nvalues = ["yes", "no"]\n'
        '[privacy.sensitive]\nmechanism = "randomized_response"\nkeep = 0.7\n'
        '[model]\ntable = "model.csv"\n'
        '[utility]\nkind = "indicator"\ndecision = "yes"\ntau = 0.1\n'
        "[target]\nlocal = 0.9\n"
    )
    return report_json(tmp_path_factory, "cert", "certify", folder / "spec.toml")


@pytest.fixture(scope="module")
def gpt_certificate(tmp_path_factory) -> dict:
    return report_json(tmp_path_factory, "gpt35", "certify", EXAMPLES / "llm_hiring" / "gpt35.toml")


@pytest.fixture(scope="module")
def plan(tmp_path_factory) -> dict:
    argv = ("plan", "--target", 1.5, "--datasets", 6, "--method", "all", "--epsilon", 1, "--global")
    return report_json(tmp_path_factory, "plan", *argv)


@pytest.fixture(scope="module")
def calibration(tmp_path_factory) -> dict:
    return report_json(tmp_path_factory, "calibration", "calibrate", "--target", 0.5, "--groups", 8, "--lower", 0.1)


def _column(table: list[list[str]], j: int) -> list[str]:
    return [row[j] for row in table[1:]]


def _check_metrics(table: list[list[str]], o: dict, intervals: bool) -> None:
    """The metrics' table: one row per metric, its columns, and where each is attained with the labels as written."""
    assert len(table) == 1 + len(METRICS) and {len(r) for r in table} == {5 if intervals else 4}
    assert _column(table, 0) == [name for _, name in METRICS]
    details = [o["local"], o["global"]] + [o["details"][k] for k, _ in METRICS[2:]]
    assert _column(table, 3) == [where(x) for x in details]
    assert o["local"]["group"] in table[1][3] and o["local"]["other_group"] in table[1][3]


# --------------------------------------------------------------------------- escaping


@pytest.mark.parametrize("parser", PARSERS)
@pytest.mark.parametrize(
    "text",
    [
        "a|b",
        "*bold* and **strong**",
        "_x_ A_M __init__",
        "<script>alert(1)</script>",
        "<b>bold</b> <!-- c --> <http://x.example>",
        "back\\slash \\| \\*",
        "`tick` ``two``",
        "[link](http://x.example) ![img](y.png)",
        "&amp; &#124; &lt; & <=50K >50K",
        "# not a heading #",
        "~~not struck~~",
        "line\nbreak",
        "$x$ {braces} (parens) 1. 2) - + !",
    ],
)
def test_escape_shows_the_text_as_written_in_a_table_cell_and_a_sentence(text, parser):
    page = _parse(f"| head |\n|---|\n| {escape(text)} |\n\n* {escape(text)}\n", parser)
    assert page.tables == [[["head"], [text]]]
    assert page.items == [" ".join(text.split())]


@pytest.mark.parametrize("parser", PARSERS)
def test_code_span_keeps_backticks(parser):
    for text in ("u >= 5", "a`b", "`x`", "a``b"):
        page = _parse(f"* {code_span(text)}\n", parser)
        assert page.items == [text]


# --------------------------------------------------------------------------- audit


@pytest.mark.parametrize("parser", PARSERS)
def test_audit_tables_keep_their_shape_and_labels(weird_audit, parser):
    d = weird_audit
    page = _parse(render(d, "audit", "markdown"), parser)
    groups, outcomes, contexts, metrics = page.tables
    assert groups[0] == ["group", "records"] and len(groups) == 1 + len(GROUPS)
    assert outcomes == [["outcome value", "records", "g(u)"]] + [
        [str(v["label"]), str(v["n"]), f"{v['g']:g}"] for v in d["outcome_values"]
    ]
    assert _column(groups, 0) == [str(g["label"]) for g in d["groups"]] and sorted(_column(groups, 0)) == sorted(GROUPS)
    assert _column(groups, 1) == [str(g["n"]) for g in d["groups"]]
    assert contexts[0] == ["context", "records"] and sorted(_column(contexts, 0)) == sorted(CONTEXTS)
    assert _column(contexts, 1) == [str(c["n"]) for c in d["contexts"]]
    _check_metrics(metrics, d, intervals=True)
    assert page.headings[0] == f"fairaudit audit: {d['n']} records"


def test_audit_markdown_carries_what_the_text_report_carries(weird_audit):
    d = weird_audit
    text = render(d, "audit", "text")
    page = _parse(render(d, "audit", "markdown"), _python_markdown)
    # the columns: sensitive, outcome, context names, the utility; the population and the intervals' level
    facts = dict(item.split(": ", 1) for item in page.items if ": " in item)
    assert facts["context"] == "ctx|col" and "context ctx|col" in text
    assert facts["sensitive"] == "grp" and facts["outcome"] == "dec" and facts["utility"] == d["utility"]["name"]
    assert facts["population P(X, A)"] in text and facts["intervals"] in text
    # records per group and per context, as the text lists them
    groups, contexts = page.tables[0], page.tables[2]
    records = {row[0]: row[1] for row in groups[1:] + contexts[1:]}
    outcomes = next(x for x in text.splitlines() if x.startswith("records per outcome value: "))
    assert outcomes.removeprefix("records per outcome value: ") == ", ".join(
        f"{u} {n} (g {g})" for u, n, g in page.tables[1][1:]
    )
    for line in ("records per group: ", "records per context: "):
        listed = next(x for x in text.splitlines() if x.startswith(line)).removeprefix(line)
        for entry in listed.split(", "):
            label, n = entry.rsplit(" ", 1)
            assert records[label] == n
    # every note on the intervals and every excluded cell of the text report
    notes = [x.strip().removeprefix("intervals: ") for x in text.splitlines() if x.startswith("  intervals: ")]
    excluded = [x.strip().removeprefix("excluded: ") for x in text.splitlines() if x.startswith("  excluded: ")]
    assert notes == d["intervals"]["notes"] and notes and all(n in page.items for n in notes)
    assert excluded == d["excluded"] and len(excluded) == 1 and excluded[0] in page.items
    assert "cell (context 'c*2*', group 'a|b'): no records" in page.items
    # the metrics' values, ratios, decisions and intervals of the text report
    metrics = page.tables[3]
    for row in metrics[1:]:
        line = next(x for x in text.splitlines() if x.strip().startswith(row[0] + " "))
        assert row[1] in line and (row[2] == "" or row[2] in line) and (row[4] == "n/a" or row[4] in line)


def test_audit_with_many_contexts_says_how_many_are_left_out(gpt_audit):
    d = dict(gpt_audit)
    d["contexts"] = [{"label": f"x{i}|y", "n": i} for i in range(45)]
    page = _parse(render(d, "audit", "markdown"), _python_markdown)
    assert len(page.tables[2]) == 1 + 30 and page.tables[2][-1] == ["x29|y", "29"]
    assert any("15 more contexts" in p for p in page.paragraphs)
    assert " ...\n" in render(d, "audit", "text")  # the text report cuts at the same place


def test_audit_labels_with_line_breaks_and_more(gpt_audit):
    d = dict(gpt_audit)
    labels = ["two\nlines", "~~s~~ &amp; &#124;", "| edge |", "trailing\\", "A_M", "`", "_", "**"]
    d["groups"] = [{"label": x, "n": i} for i, x in enumerate(labels)]
    for parser in (_python_markdown, _markdown_it):
        groups = _parse(render(d, "audit", "markdown"), parser).tables[0]
        assert [r[0] for r in groups[1:]] == labels


@pytest.mark.parametrize("parser", PARSERS)
def test_gpt_audit(gpt_audit, parser):
    page = _parse(render(gpt_audit, "audit", "markdown"), parser)
    assert [len(t) for t in page.tables] == [9, 10, 9, 7]  # groups, the 9 outcome values, contexts, metrics
    _check_metrics(page.tables[3], gpt_audit, intervals=True)
    assert "gpt-4 & software engineer" in _column(page.tables[2], 0)
    assert _column(page.tables[1], 0) == [str(r) for r in range(1, 9)] + ["unranked"]


# --------------------------------------------------------------------------- certify


@pytest.mark.parametrize("parser", PARSERS)
def test_certificate_tables_keep_their_shape_and_labels(weird_certificate, parser):
    d = weird_certificate
    page = _parse(render(d, "certify", "markdown"), parser)
    assert page.headings[0] == "fairaudit certificate: T | *x* <b>&amp; back\\slash"
    bounds, observed, unfiltered, targets, assumptions = page.tables
    assert [len(r) for r in bounds] == [3] * 5
    assert _column(bounds, 2) == [bound_detail(d, k) for k, _ in BOUNDS]
    assert bounds[3][2] == f"(a|b over <s>; on L-bar {bounds[3][1]})"
    _check_metrics(observed, d["observed"], intervals=False)
    _check_metrics(unfiltered, d["unfiltered"], intervals=False)
    assert observed[1][3] == "<s> vs a|b in context c*1*"
    assert targets[0] == ["target", "value", "bound", "result", "observed", "reason"] and len(targets) == 2
    assert len(assumptions) == 1 + len(d["assumptions"])
    assert _column(assumptions, 0) == [a["name"] for a in d["assumptions"]]
    assert _column(assumptions, 2) == [a["detail"] for a in d["assumptions"]]
    assert page.items[:4] == [f"{k}: {v}" for k, v in certificate_facts(d)]
    assert page.items[0].startswith("privacy of office|name: randomized_response on office|name, epsilon = ")


def test_certificate_markdown_carries_the_text_reports_lines(gpt_certificate):
    d = gpt_certificate
    text = render(d, "certify", "text")
    page = _parse(render(d, "certify", "markdown"), _python_markdown)
    for item in page.items[:4]:  # privacy of A and of X, utility, population: as the text says them
        assert item in text
    bounds = page.tables[0]
    for row in bounds[1:]:
        assert f"{row[1]} {row[2]}".strip() in text
    counts = next(p for p in page.paragraphs if p.startswith("From counts"))
    assert counts[0].lower() + counts[1:-1] in text
    assert page.items[4] == d["observed"]["intervals"]["notes"][0]
    assert page.paragraphs[-1] == "Certified: yes"


# --------------------------------------------------------------------------- calibrate and plan


@pytest.mark.parametrize("parser", PARSERS)
def test_calibration_is_the_text_report_in_a_code_block(calibration, parser):
    page = _parse(render(calibration, "calibrate", "markdown"), parser)
    assert page.headings == ["fairaudit calibration"]
    assert page.code == [render(calibration, "calibrate", "text")]
    odd = dict(calibration, reason="a ``` fence | and *stars*")
    assert _parse(render(odd, "calibrate", "markdown"), parser).code == [render(odd, "calibrate", "text")]


@pytest.mark.parametrize("parser", PARSERS)
def test_plan_table(plan, parser):
    page = _parse(render(plan, "plan", "markdown"), parser)
    (table,) = page.tables
    assert len(table) == 1 + len(plan["plans"]) == 4 and {len(r) for r in table} == {6}
    assert table[1:] == [list(r) for r in plan_rows(plan)]
    odd = dict(plan, plans=[dict(p, method="m|*x*", reason="why | <b>not</b>") for p in plan["plans"]])
    page = _parse(render(odd, "plan", "markdown"), parser)
    assert _column(page.tables[0], 0) == ["m|*x*"] * 3 and page.items == ["m|*x*: why | <b>not</b>"] * 3
