"""``--format html``: one self-contained page per report, its tables and inline SVG figures, every label escaped.

The fast tests read the pages with the standard library's HTML parser: the tables and their rows, the ``<svg>``
figures, that nothing outside the file is referenced (no script, no link, no image, no address) and that a label
``<script>`` is text. The ``browser`` test (left out of the default run; ``FAIRAUDIT_REQUIRE_BROWSER=1 python -m
pytest -m browser -n 0``) opens an audit and a certificate in headless Chromium, offline, and checks in the page that
the tables and the figures are drawn. Without Chromium (``/usr/bin/chromium``) it skips, or fails under
``FAIRAUDIT_REQUIRE_BROWSER=1``.
"""

from __future__ import annotations

import html
import json
import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest
from _reports import report_json

from fairaudit import InputError
from fairaudit.cli import main
from fairaudit.reports.formats import FORMATS, render
from fairaudit.reports.formats.sections import METRICS, plan_rows

pytest.importorskip("jinja2")
pytest.importorskip("matplotlib")

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
CHROMIUM = Path("/usr/bin/chromium")
REQUIRE_BROWSER = os.environ.get("FAIRAUDIT_REQUIRE_BROWSER") == "1"

GROUPS = ["<script>alert(1)</script>", "a|b", "*bold* & &amp;", "back\\slash `tick`"]
CONTEXTS = ["c|1", "c*2*", "$x$ <b>", "[link](#anchor)"]

# what a self-contained page may not hold: elements that load or run something, and attributes that point outside
LOADING = {"script", "link", "img", "iframe", "object", "embed", "base", "audio", "video", "source", "track", "image"}
POINTING = {"src", "srcset", "action", "formaction", "poster", "data", "ping", "background", "manifest"}


class _Page(HTMLParser):
    """Elements, attributes, tables (rows of cell texts), headings and the text of a page."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[str] = []
        self.attrs: list[tuple[str, str, str | None]] = []
        self.tables: list[list[list[str]]] = []
        self.headings: list[str] = []
        self.svg_text: list[str] = []
        self.comments: list[str] = []
        self.doctype = ""
        self._cell: list[str] | None = None
        self._heading: list[str] | None = None
        self._svg = 0
        self._style = False
        self.style = ""

    def handle_decl(self, decl):
        self.doctype = decl

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.attrs += [(tag, k, v) for k, v in attrs]
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag in ("h1", "h2"):
            self._heading = []
        elif tag == "svg":
            self._svg += 1
        elif tag == "style":
            self._style = True

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell))
            self._cell = None
        elif tag in ("h1", "h2") and self._heading is not None:
            self.headings.append("".join(self._heading))
            self._heading = None
        elif tag == "svg":
            self._svg -= 1
        elif tag == "style":
            self._style = False

    def handle_data(self, data):
        for sink in (self._cell, self._heading):
            if sink is not None:
                sink.append(data)
        if self._svg:
            self.svg_text.append(data)
        if self._style:
            self.style += data

    def handle_comment(self, data):
        self.comments.append(data)


def _parse(text: str) -> _Page:
    page = _Page()
    page.feed(text)
    page.close()
    return page


@pytest.fixture(scope="module")
def weird_records(tmp_path_factory) -> Path:
    """Records whose labels are HTML and Markdown, with one empty cell (excluded) and three outcomes."""
    path = tmp_path_factory.mktemp("weird") / "records.csv"
    lines = ["ctx,grp,dec"]
    for i, c in enumerate(CONTEXTS):
        for j, g in enumerate(GROUPS):
            if (i, j) != (1, 1):
                lines += [
                    f'"{c}","{g}",{"yes" if k < 4 + 2 * j + i else "maybe" if k % 3 else "no"}' for k in range(20)
                ]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def weird_audit(tmp_path_factory, weird_records) -> dict:
    args = ["--sensitive", "grp", "--context", "ctx", "--outcome", "dec", "--positive", "yes", "--confidence", 0.9]
    return report_json(tmp_path_factory, "weird", "audit", weird_records, *args)


@pytest.fixture(scope="module")
def single_context_audit(tmp_path_factory, weird_records) -> dict:
    args = ["--sensitive", "grp", "--outcome", "dec", "--positive", "yes", "--confidence", 0.9]
    return report_json(tmp_path_factory, "single", "audit", weird_records, *args)


@pytest.fixture(scope="module")
def uci_audit(tmp_path_factory) -> dict:
    """The UCI layout example: an infinite L (a cell with E[g | x, a] = 0), no intervals."""
    args = ["--no-header", "--names", "age,workclass,education,sex,income", "--na-values", "?"]
    args += ["--skip-initial-space", "--dropna", "--sensitive", "sex", "--context", "education"]
    args += ["--outcome", "income", "--positive", ">50K"]
    return report_json(tmp_path_factory, "uci", "audit", EXAMPLES / "uci_layout" / "records.data", *args)


@pytest.fixture(scope="module")
def gpt_certificate(tmp_path_factory) -> dict:
    return report_json(tmp_path_factory, "gpt35", "certify", EXAMPLES / "llm_hiring" / "gpt35.toml")


@pytest.fixture(scope="module")
def office_certificate(tmp_path_factory) -> dict:
    """The HR-office example: the model without the filter has L = +inf."""
    return report_json(tmp_path_factory, "office", "certify", EXAMPLES / "hr_office" / "hr_office.toml")


def _check_self_contained(text: str, page: _Page, *, no_address: bool = True) -> None:
    """Nothing outside the file: no loading element, no attribute pointing out, no url() but to an id, no script."""
    assert text.startswith("<!DOCTYPE html>") and page.doctype.lower() == "doctype html"
    assert not LOADING & set(page.tags), LOADING & set(page.tags)
    assert not [a for a in page.attrs if a[1] in POINTING or a[1].startswith("on")]
    hrefs = [v for _, k, v in page.attrs if k in ("href", "xlink:href")]
    assert all(v and v.startswith("#") for v in hrefs), hrefs
    assert all(m == "#" for m in re.findall(r"url\(\s*['\"]?(.)", text, re.I))  # only clip paths, url(#id)
    assert "@import" not in page.style and "url(" not in page.style
    if no_address:  # the data hold no address either: none at all in the file (no namespace, no DTD)
        assert "http://" not in text and "https://" not in text and "//" not in page.style
    ids = [v for _, k, v in page.attrs if k == "id"]
    assert len(ids) == len(set(ids)), "duplicate ids"


# --------------------------------------------------------------------------- audit


def test_audit_page_tables_figures_and_escaping(weird_audit):
    d = weird_audit
    text = render(d, "audit", "html")
    page = _parse(text)
    _check_self_contained(text, page)
    assert page.headings[0] == f"fairaudit audit: {d['n']} records"
    metrics, groups, outcomes, contexts, cells = page.tables
    assert [r[:2] for r in outcomes[1:]] == [[str(v["label"]), str(v["n"])] for v in d["outcome_values"]]
    assert len(metrics) == 1 + len(METRICS) and [r[0] for r in metrics[1:]] == [n for _, n in METRICS]
    assert {len(r) for r in metrics} == {5}  # with the intervals
    assert [r[0] for r in groups[1:]] == [g["label"] for g in d["groups"]] and sorted(GROUPS) == sorted(
        r[0] for r in groups[1:]
    )
    assert [r[1] for r in groups[1:]] == [str(g["n"]) for g in d["groups"]]
    assert [r[:2] for r in contexts[1:]] == [[c["label"], str(c["n"])] for c in d["contexts"]]
    assert len(cells) == 1 + len(d["cells"]) == 1 + 16 and cells[0][:4] == [
        "context",
        "group",
        "records",
        "E[g | x, a]",
    ]
    assert ["c*2*", "a|b", "0", "n/a"] in [r[:4] for r in cells]  # the empty cell
    # two figures: E[g | a] per group and E[g | x, a] per context and group, with the labels as text
    assert page.tags.count("svg") == 2 and page.tags.count("figure") == 2
    svg_text = "".join(page.svg_text)
    assert "<script>alert(1)</script>" in svg_text and "E[g | a] per group" in svg_text
    # the labels are text, nowhere markup: the parser saw no script and the raw page has the label escaped
    assert "script" not in page.tags and "<script" not in text and "&lt;script&gt;alert(1)&lt;/script&gt;" in text
    assert "*bold* & &amp;" in [r[0] for r in groups[1:]]
    # the notes and the excluded cell, as the text report says them
    assert "<li>cell (context 'c*2*', group 'a|b'): no records</li>" in html.unescape(text)
    for note in d["intervals"]["notes"]:
        assert f"<li>{note}</li>" in html.unescape(text)


def test_single_context_audit_has_one_figure_with_the_intervals(single_context_audit):
    d = single_context_audit
    text = render(d, "audit", "html")
    page = _parse(text)
    _check_self_contained(text, page)
    assert page.tags.count("svg") == 1
    groups = page.tables[1]
    assert groups[0] == ["group", "records", "E[g | a]", "interval"]
    assert all(re.fullmatch(r"\[[0-9.e-]+, [0-9.e-]+\]", r[3]) for r in groups[1:])
    assert "Records per context" not in page.headings


def test_uci_audit_with_an_infinite_L(uci_audit):
    text = render(uci_audit, "audit", "html")
    page = _parse(text)
    _check_self_contained(text, page)
    metrics = page.tables[0]
    assert metrics[1][:2] == ["local g-fairness L", "inf"] and {len(r) for r in metrics} == {4}
    assert page.tags.count("svg") == 2
    assert ["Bachelors", "Female", "8", "0"] in [r[:4] for r in page.tables[-1]]


@pytest.mark.slow
def test_the_page_is_the_same_each_time(uci_audit, gpt_certificate):
    assert render(uci_audit, "audit", "html") == render(uci_audit, "audit", "html")
    assert render(gpt_certificate, "certify", "html") == render(gpt_certificate, "certify", "html")


def test_dollar_signs_are_no_math_and_many_contexts_are_cut(uci_audit):
    d = dict(uci_audit)
    d["contexts"] = [{"label": f"$x_{i}$", "n": 1} for i in range(45)]
    d["cells"] = [
        {"context": f"$x_{i}$", "group": g["label"], "n": 1, "expected_utility": (i % 5) / 5}
        for i in range(45)
        for g in d["groups"]
    ]
    page = _parse(render(d, "audit", "html"))
    assert "$x_44$" in [r[0] for r in page.tables[3]]  # every context in the table ...
    assert "$x_29$" in page.svg_text and "$x_30$" not in page.svg_text  # ... the first 30 in the figure


# --------------------------------------------------------------------------- certify


def test_certificate_page(gpt_certificate):
    d = gpt_certificate
    text = render(d, "certify", "html")
    page = _parse(text)
    _check_self_contained(text, page)
    assert page.headings[0] == f"fairaudit certificate: {d['title']}"
    bounds, observed, unfiltered, targets, assumptions = page.tables
    assert [r[0] for r in bounds] == [
        "bound",
        "paper (main theorem)",
        "tight (its proof, per pair)",
        "black-box (exact worst case)",
        "corollary (epsilon)",
    ]
    assert bounds[3][1] == "0.5 nats" and "A_M over A_W" in bounds[3][2]
    assert len(observed) == len(unfiltered) == 1 + len(METRICS)
    assert [r[0] for r in targets[1:]] == ["local", "global"] and targets[1][3] == "met"
    assert [r[0] for r in assumptions[1:]] == [a["name"] for a in d["assumptions"]]
    assert page.tags.count("svg") == 1
    svg_text = "".join(page.svg_text)
    for name in ("paper", "tight", "black-box", "corollary", "observed L behind the filter", "local target"):
        assert name in svg_text
    assert "Certified: yes" in text and "From counts, simultaneous 0.95 (clopper-pearson)" in text


def test_certificate_with_infinite_and_missing_bounds(office_certificate):
    d = json.loads(json.dumps(office_certificate))
    d["bounds"]["paper"] = None
    d["bounds"]["tight"] = "inf"
    d["bound_details"]["corollary"]["holds"] = False
    d["title"] = "<script>alert('t')</script> & co"
    text = render(d, "certify", "html")
    page = _parse(text)
    _check_self_contained(text, page)
    assert page.headings[0] == "fairaudit certificate: <script>alert('t')</script> & co" and "script" not in page.tags
    bounds = page.tables[0]
    assert bounds[1][1:] == ["n/a", "(needs utility.tau)"] and bounds[2][1] == "inf"
    assert "(does not apply: an assumption is violated)" in bounds[4][2]
    svg_text = "".join(page.svg_text)
    assert "n/a" in svg_text and "+∞" in svg_text and "without the filter: inf (+∞, drawn at the top)" in svg_text


# --------------------------------------------------------------------------- calibrate, plan, the command line


def test_calibration_and_plan_pages(tmp_path_factory):
    cal = report_json(tmp_path_factory, "cal", "calibrate", "--target", 0.5, "--groups", 8, "--lower", 0.1)
    text = render(cal, "calibrate", "html")
    page = _parse(text)
    _check_self_contained(text, page)
    for line in render(cal, "calibrate", "text").splitlines():
        assert f"<p>{html.escape(line)}</p>" in text
    plan = report_json(
        tmp_path_factory, "plan", "plan", "--target", 1.5, "--datasets", 6, "--method", "all", "--global"
    )
    text = render(plan, "plan", "html")
    page = _parse(text)
    _check_self_contained(text, page)
    (table,) = page.tables
    assert table[1:] == [list(r) for r in plan_rows(plan)] and page.tags.count("svg") == 0


def test_html_is_a_format_and_the_command_writes_the_file(tmp_path, capsys):
    assert "html" in FORMATS
    out = tmp_path / "report.html"
    spec = EXAMPLES / "llm_hiring" / "gpt35.toml"
    assert main(["certify", str(spec), "--format", "html", "--output", str(out)]) == 0
    assert "report written to" in capsys.readouterr().err
    text = out.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>") and "<svg" in text
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]  # no temporary file left


def test_without_jinja2_the_format_says_what_to_install(monkeypatch, uci_audit, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "jinja2", None)  # import jinja2 raises ImportError
    with pytest.raises(InputError) as e:
        render(uci_audit, "audit", "html")
    assert e.value.field == "format" and "pip install 'fairness-certify[html]'" in str(e.value)
    spec = EXAMPLES / "llm_hiring" / "gpt35.toml"
    assert main(["certify", str(spec), "--format", "html", "--output", str(tmp_path / "r.html")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("fairaudit: error: --format: html needs jinja2 and matplotlib")
    assert not (tmp_path / "r.html").exists()


def test_importing_the_format_imports_neither_jinja2_nor_matplotlib():
    code = "import sys, fairaudit.reports.formats; print(sorted({'jinja2', 'matplotlib'} & set(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert done.stdout.strip() == "[]"


# --------------------------------------------------------------------------- in headless Chromium
# Run in a copy of the page (the report itself has no script): whether each table and figure is drawn, with a box of
# its own, and what the figures hold. The result is written into the page, where --dump-dom shows it.
CHECK = """<script>
const box = (e) => { const r = e.getBoundingClientRect(); return [Math.round(r.width), Math.round(r.height)]; };
const out = document.createElement("pre");
out.id = "report-check";
out.textContent = JSON.stringify({
  tables: [...document.querySelectorAll("table")].map((t) => ({rows: t.rows.length, box: box(t)})),
  figures: [...document.querySelectorAll("figure svg")].map((s) => ({
    svg: s instanceof SVGSVGElement, box: box(s), drawn: s.querySelectorAll("path, use").length,
    text: [...s.querySelectorAll("text")].filter((t) => box(t)[0] > 0).length,
    bbox: (() => { const b = s.getBBox(); return [Math.round(b.width), Math.round(b.height)]; })(),
  })),
  scripts: document.querySelectorAll("script").length,
  title: document.title,
});
document.body.appendChild(out);
</script>"""


@pytest.fixture(scope="module")
def chromium():
    if not CHROMIUM.exists():
        why = f"{CHROMIUM} is absent (Debian: apt-get install chromium)"
        if REQUIRE_BROWSER:
            pytest.fail(f"FAIRAUDIT_REQUIRE_BROWSER=1 but {why}")
        pytest.skip(why)
    return CHROMIUM


def _chromium(chromium: Path, page: Path, profile: Path, *extra: str) -> subprocess.CompletedProcess:
    args = [
        str(chromium),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        "--host-resolver-rules=MAP * ~NOTFOUND",  # offline: no host resolves
        "--window-size=1280,1000",
        "--virtual-time-budget=5000",
        *extra,
        page.as_uri(),
    ]
    done = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-4000:]
    return done


@pytest.mark.browser
def test_pages_render_in_chromium(chromium, tmp_path, weird_audit, gpt_certificate):
    for kind, d, figures in (("audit", weird_audit, 2), ("certify", gpt_certificate, 1)):
        report = render(d, kind, "html")
        n_tables = report.count("<table>")
        (tmp_path / f"{kind}.html").write_text(report, encoding="utf-8")
        checked = tmp_path / f"{kind}-check.html"
        checked.write_text(report.replace("</body>", CHECK + "</body>"), encoding="utf-8")
        dom = _chromium(chromium, checked, tmp_path / "profile", "--dump-dom").stdout
        found = re.search(r'<pre id="report-check">(.*?)</pre>', dom, re.S)
        assert found, "the check did not run in the page"
        check = json.loads(html.unescape(found.group(1)))
        assert check["scripts"] == 1 and check["title"].startswith(
            f"fairaudit {'audit' if kind == 'audit' else 'cert'}"
        )
        assert len(check["tables"]) == n_tables >= 4
        assert all(t["rows"] >= 2 and t["box"][0] > 100 and t["box"][1] > 40 for t in check["tables"]), check
        assert len(check["figures"]) == figures, check
        for f in check["figures"]:  # an SVG element of the SVG namespace, laid out and drawn: paths and visible text
            assert f["svg"] and f["box"][0] > 300 and f["box"][1] > 100 and f["drawn"] > 10 and f["text"] > 5, f
            assert f["bbox"][0] > 300 and f["bbox"][1] > 100, f
        # the report itself, as written (no check script): a screenshot of a page that is not blank
        shot = tmp_path / f"{kind}.png"
        _chromium(chromium, tmp_path / f"{kind}.html", tmp_path / "profile", f"--screenshot={shot}")
        assert shot.stat().st_size > 20_000
