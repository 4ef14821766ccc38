"""The documentation site's math renders offline (scripts/mkdocs_hooks.py: TeX to MathML at build time).

The fast tests check the converter on every formula of the pages. The ``browser`` test (left out of the default run;
``FAIRAUDIT_REQUIRE_BROWSER=1 python -m pytest -m browser -n 0``) builds the site, serves it on 127.0.0.1 and opens a
proof page in headless Chromium with every other host unresolvable, then checks, in the page, that each formula is
drawn as math and that no TeX is left in the visible text. Without Chromium (``/usr/bin/chromium``) it skips, or
fails under ``FAIRAUDIT_REQUIRE_BROWSER=1`` (set by ``.ci/run``, which installs Chromium from Debian).
"""

from __future__ import annotations

import functools
import html
import http.server
import json
import logging
import os
import re
import runpy
import subprocess
import sys
import threading
from pathlib import Path

import markdown
import pytest
import yaml

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = Path("/usr/bin/chromium")
REQUIRE_BROWSER = os.environ.get("FAIRAUDIT_REQUIRE_BROWSER") == "1"
PAGE = ROOT / "proofs" / "privacy.md"  # served at proofs/privacy/
hooks = runpy.run_path(str(ROOT / "scripts" / "mkdocs_hooks.py"))

# every Markdown file the site renders: docs/, and what scripts/gen_docs.py adds from the repository
SOURCES = sorted(
    [*ROOT.glob("docs/**/*.md"), *ROOT.glob("proofs/*.md"), ROOT / "benchmarks" / "README.md", ROOT / "CHANGELOG.md"]
)


@functools.cache
def _markdown() -> markdown.Markdown:
    """Python-Markdown with the site's extensions and their settings, read from mkdocs.yml."""
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    names, settings = [], {}
    for item in config["markdown_extensions"]:
        name, options = next(iter(item.items())) if isinstance(item, dict) else (item, {})
        names.append(name)
        settings[name] = options or {}
    settings["pymdownx.highlight"] = {**settings.get("pymdownx.highlight", {}), "use_pygments": False}  # faster
    return markdown.Markdown(extensions=names, extension_configs=settings)


def _formulas(text: str) -> list[tuple[str, str]]:
    """The arithmatex blocks of a page's Markdown: (span or div, their escaped text)."""
    md = _markdown().reset()
    return re.findall(r'<(span|div) class="arithmatex">(.*?)</\1>', md.convert(text), re.S)


@pytest.mark.slow
def test_every_formula_of_the_site_converts():
    failures, count = [], 0
    for path in SOURCES:
        for tag, text in _formulas(path.read_text()):
            count += 1
            tex, display = hooks["_strip_delimiters"](html.unescape(text))
            try:
                mathml = hooks["tex_to_mathml"](tex, display)
            except hooks["MathError"] as e:
                failures.append(f"{path.relative_to(ROOT)}: {e}")
                continue
            assert mathml.startswith("<math") and f'display="{"block" if tag == "div" else "inline"}"' in mathml
            assert not re.search(r'mathvariant="(?!normal")', mathml), (path, tex)  # what MathML Core ignores
    assert count > 3000  # the proofs' formulas are all found
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize(
    "tex, expected",
    [
        (r"\arg\max_u g", "<mo>arg</mo>"),  # latex2mathml has no \arg
        ("a,\\\nb", "<mtext>&#x000A0;</mtext>"),  # a backslash before a line break is a space
        (r"\texttt{tight\_bound}", ">tight_bound</mtext>"),
        (r"\big\{h\big\}", ">{</mo>"),
        (r"\log\!\Big(t\Big)", "<mi>log</mi><mo"),
        (r"\begin{pmatrix}0.9&0.1\\0.7&0.3\end{pmatrix}", "<mtable>"),
        # alphabets as Unicode's mathematical letters: MathML Core ignores mathvariant (but "normal")
        (r"\mathcal A\subseteq\mathcal{O}", "<mi>\N{MATHEMATICAL SCRIPT CAPITAL A}</mi>"),
        (r"\mathcal B", "<mi>\N{SCRIPT CAPITAL B}</mi>"),
        (r"\mathbb R^{n}", "<mi>\N{DOUBLE-STRUCK CAPITAL R}</mi>"),
        (r"\mathbf 1_{x}", "<mn>\N{MATHEMATICAL BOLD DIGIT ONE}</mn>"),
        (r"\mathit{hi}", "<mi>\N{PLANCK CONSTANT}</mi><mi>\N{MATHEMATICAL ITALIC SMALL I}</mi>"),
        (r"\mathrm{d}x", '<mi mathvariant="normal">d</mi>'),
        (r"\mathrm{TV}", '<mi mathvariant="normal">T</mi>'),
    ],
)
def test_tex_fixes(tex, expected):
    mathml = hooks["tex_to_mathml"](tex)
    assert expected in mathml
    assert "\\" not in re.sub(r"<[^>]*>", "", mathml)


def test_render_math_and_the_table_of_contents(caplog):
    page = '<p>For <span class="arithmatex">\\(c &gt; 0\\)</span>:</p>\n<div class="arithmatex">\\[x^2\\]</div>'
    out = hooks["render_math"](page)
    assert out.count("<math") == 2 and "\\(" not in out and "\\[" not in out
    assert '<span class="arithmatex"><math' in out and '<div class="arithmatex"><math' in out
    assert 'display="block"' in out and "<mo>&#x0003E;</mo>" in out  # the unescaped ">" is an operator
    toc = hooks["render_toc_math"]("Remark: \\(t &lt; 1\\) and the trivial bound")
    assert toc.startswith("Remark: <math") and toc.endswith("</math> and the trivial bound")
    # TeX that does not convert stays as it was, with a warning (an error under mkdocs build --strict)
    bad = '<span class="arithmatex">\\(\\unknowncommand x\\)</span>'
    with caplog.at_level(logging.WARNING):
        assert hooks["render_math"](bad, "p.md") == bad
    assert "p.md: TeX not rendered" in caplog.text and "unknowncommand" in caplog.text


# --------------------------------------------------------------------------- in headless Chromium
# Run in the page after it loaded (and after whatever script typesets math): for each formula of the article, whether
# it is drawn as math (a MathML element, or MathJax's output, with a box of its own), and the visible text outside
# code that still looks like TeX. The result is written into the page, where --dump-dom shows it.
CHECK = """<script>
setTimeout(() => {
  const blocks = [...document.querySelectorAll("article .arithmatex")];
  const drawn = (e) => { const r = e.getBoundingClientRect(); return r.width > 0 && r.height > 0; };
  const rendered = blocks.filter((b) =>
    [...b.querySelectorAll("math")].some((m) => m instanceof MathMLElement && drawn(m)) ||
    [...b.querySelectorAll("mjx-container")].some(drawn));
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  const tex = [];
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    const p = n.parentElement;
    if (!p || p.closest("pre, code, script, style, #math-check") || !p.checkVisibility()) continue;
    const m = n.data.match(/\\\\[()\\[\\]]|\\$\\$|\\\\[A-Za-z]+/);
    if (m) tex.push(n.data.trim().slice(0, 80));
  }
  const out = document.createElement("pre");
  out.id = "math-check";
  out.textContent = JSON.stringify({
    blocks: blocks.length,
    rendered: rendered.length,
    math: document.querySelectorAll("math").length,
    mathml: [...document.querySelectorAll("math")].filter((m) => m instanceof MathMLElement).length,
    tex: tex,
  });
  document.body.appendChild(out);
}, 2000);
</script>"""


@pytest.fixture(scope="module")
def chromium():
    """Chromium's path; a skip (a failure under FAIRAUDIT_REQUIRE_BROWSER=1) without it, before the site is built."""
    if not CHROMIUM.exists():
        why = f"{CHROMIUM} is absent (Debian: apt-get install chromium)"
        if REQUIRE_BROWSER:
            pytest.fail(f"FAIRAUDIT_REQUIRE_BROWSER=1 but {why}")
        pytest.skip(why)
    return CHROMIUM


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site, built once for this module as CI builds it (--strict)."""
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "DISABLE_MKDOCS_2_WARNING": "true"}
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    return out


@pytest.fixture(scope="module")
def server(site):
    """An HTTP server on 127.0.0.1 for the built site that adds CHECK to the page under test."""

    class Handler(http.server.SimpleHTTPRequestHandler):
        def do_GET(self):
            if self.path == "/proofs/privacy/":
                body = (site / "proofs" / "privacy" / "index.html").read_bytes()
                body = body.replace(b"</body>", CHECK.encode() + b"</body>")
                self.send_response(200)
                self.send_header("Content-Type", "text/html; charset=utf-8")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)
            else:
                super().do_GET()

        def log_message(self, *args):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=str(site)))
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


def _chromium_dom(chromium: Path, url: str, profile: Path) -> str:
    args = [
        str(chromium),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        # no network: every host name but the local server's fails to resolve (a CDN, a font service)
        "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
        "--window-size=1400,1000",  # wide enough for Material's table of contents to show
        "--virtual-time-budget=10000",
        "--dump-dom",
        url,
    ]
    done = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-4000:]
    return done.stdout


@pytest.mark.browser
def test_proof_page_math_renders_offline_in_chromium(chromium, server, tmp_path):
    expected = len(_formulas(PAGE.read_text()))
    assert expected > 50
    dom = _chromium_dom(chromium, f"{server}/proofs/privacy/", tmp_path / "profile")
    found = re.search(r'<pre id="math-check">(.*?)</pre>', dom, re.S)
    assert found, "the check did not run in the page"
    check = json.loads(html.unescape(found.group(1)))
    assert check["blocks"] == expected, check  # every formula of proofs/privacy.md is in the page ...
    assert check["rendered"] == expected, check  # ... and drawn as math, in a box of its own
    assert check["math"] == check["mathml"] >= expected, check  # the browser took the <math> elements as MathML
    assert check["tex"] == [], check  # no TeX left in the visible text (outside code), the table of contents included
