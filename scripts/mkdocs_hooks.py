"""MkDocs hooks (registered in ``mkdocs.yml``): Sphinx roles shown as code, and the TeX rendered as MathML at build time.

* Docstrings are numpydoc, written for Sphinx: ``:func:`~fairaudit.data.counts.count_file``` is rendered by mkdocstrings
  as ``:func:<code>~fairaudit...</code>``; :func:`strip_roles` drops the role and, as Sphinx does for a leading ``~``,
  keeps only the last dotted name.
* The TeX in the pages (``$...$`` and ``$$...$$``, which ``pymdownx.arithmatex`` in generic mode wraps as
  ``<span class="arithmatex">\\(...\\)</span>`` and ``<div class="arithmatex">\\[...\\]</div>``) is converted to
  MathML by ``latex2mathml`` (in the ``docs`` extra), which browsers render natively (MathML Core): the built site
  needs no JavaScript and no network to show its math. The headings' entries in the table of contents, which
  arithmatex leaves as plain ``\\(...\\)`` text, are converted too. A formula that does not convert is a warning,
  so ``mkdocs build --strict`` fails on it rather than publishing raw TeX.
"""

from __future__ import annotations

import html as _html
import re
import unicodedata

from latex2mathml.converter import convert
from mkdocs.plugins import get_plugin_logger

log = get_plugin_logger("math")

_ROLE = re.compile(r":(?:class|func|meth|attr|mod|data|exc|obj):<code>(~?)([^<]*)</code>")


def strip_roles(html: str) -> str:
    return _ROLE.sub(lambda m: f"<code>{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}</code>", html)


# --------------------------------------------------------------------------- TeX -> MathML
# what arithmatex (generic mode) makes of $...$, $$...$$ and a bare \begin{env}...\end{env} block
_ARITHMATEX = re.compile(r'<(span|div) class="arithmatex">(.*?)</\1>', re.S)
# inline math left as text by arithmatex in the table of contents (a heading's entry is its text, tags stripped)
_TOC_MATH = re.compile(r"\\\((.+?)\\\)", re.S)
# before converting, fixes for what latex2mathml reads differently from TeX:
_TEX_FIXES = [
    (re.compile(r"\\(\\|\s)"), lambda m: m.group(0) if m.group(1) == "\\" else "\\ "),  # "\<newline>" is a space
    (re.compile(r"\\arg(?![A-Za-z])"), lambda m: r"\operatorname{arg}"),  # no \arg in latex2mathml
    (re.compile(r"\\!"), lambda m: ""),  # a negative space, which MathML Core cannot show
    (re.compile(r"\\mathrm\{(\w)\}"), lambda m: rf"\mathrm {m.group(1)}"),  # \mathrm{d} would come out italic
]
# after converting: escaped characters that latex2mathml leaves escaped in a token
_MATHML_FIXES = [
    (re.compile(r"(<mtext[^>]*>)([^<]*)"), lambda m: m.group(1) + re.sub(r"\\([_%&#$])", r"\1", m.group(2))),
    (re.compile(r"(<mo[^>]*>)\\(?:\{|lbrace)<"), lambda m: m.group(1) + "{<"),
    (re.compile(r"(<mo[^>]*>)\\(?:\}|rbrace)<"), lambda m: m.group(1) + "}<"),
]
# MathML Core (what Chromium, Firefox and Safari render) knows no mathvariant but "normal": a token in another
# alphabet (\mathcal A, \mathbb R, \mathbf 1) is written with its Unicode mathematical letters instead, and a text's
# style (\texttt) with CSS
_VARIANT = re.compile(r'<(mi|mn|mo|mtext)([^>]*?) mathvariant="(?!normal")([a-z-]+)"([^>]*)>([^<]*)</\1>')
_ALPHABET = {  # mathvariant: its name in Unicode's, as in MATHEMATICAL BOLD SCRIPT CAPITAL A
    "bold": "BOLD",
    "italic": "ITALIC",
    "bold-italic": "BOLD ITALIC",
    "script": "SCRIPT",
    "bold-script": "BOLD SCRIPT",
    "fraktur": "FRAKTUR",
    "bold-fraktur": "BOLD FRAKTUR",
    "double-struck": "DOUBLE-STRUCK",
    "sans-serif": "SANS-SERIF",
    "bold-sans-serif": "SANS-SERIF BOLD",
    "sans-serif-italic": "SANS-SERIF ITALIC",
    "sans-serif-bold-italic": "SANS-SERIF BOLD ITALIC",
    "monospace": "MONOSPACE",
}
# the letters of these alphabets that Unicode had before, as SCRIPT CAPITAL B (a hole in the mathematical block)
_LETTERLIKE = {"SCRIPT": "SCRIPT", "DOUBLE-STRUCK": "DOUBLE-STRUCK", "FRAKTUR": "BLACK-LETTER"}
_TEXT_STYLE = {
    "monospace": "font-family: monospace",
    "bold": "font-weight: bold",
    "italic": "font-style: italic",
    "bold-italic": "font-weight: bold; font-style: italic",
    "sans-serif": "font-family: sans-serif",
}
# a TeX command left in a token's text: latex2mathml did not know it
_LEFTOVER = re.compile(r">[^<]*\\[^<]*<")


def _math_letter(char: str, variant: str) -> str | None:
    """``char`` (a Latin or Greek letter, or a digit) in the mathematical alphabet ``variant`` (a mathvariant)."""
    try:
        name = unicodedata.name(char)
    except ValueError:
        return None
    name = re.sub(r"^(?:LATIN|GREEK) (CAPITAL|SMALL) LETTER ", r"\1 ", name)
    alphabet = _ALPHABET.get(variant)
    if alphabet is None:
        return None
    names = [f"MATHEMATICAL {alphabet} {name}"]
    if alphabet in _LETTERLIKE:
        names.append(f"{_LETTERLIKE[alphabet]} {name}")
    if alphabet == "ITALIC" and name == "SMALL H":
        names.append("PLANCK CONSTANT")
    for candidate in names:
        try:
            return unicodedata.lookup(candidate)
        except KeyError:
            pass
    return None


def _variant(m: re.Match[str]) -> str:
    tag, before, variant, after, text = m.groups()
    if tag == "mtext":
        if variant not in _TEXT_STYLE:
            return m.group(0)
        return f'<mtext{before} style="{_TEXT_STYLE[variant]}"{after}>{text}</mtext>'
    letters = [_math_letter(c, variant) for c in _html.unescape(text)]
    if any(letter is None for letter in letters):
        return m.group(0)  # not a letter of that alphabet: left to the browser
    return f"<{tag}{before}{after}>{_html.escape(''.join(filter(None, letters)), quote=False)}</{tag}>"


class MathError(ValueError):
    """A formula that latex2mathml does not convert (or converts leaving TeX in the MathML)."""


def tex_to_mathml(tex: str, display: bool = False) -> str:
    """The MathML ``<math>`` element for a TeX formula (without its ``\\(``/``\\[`` delimiters)."""
    for pattern, repl in _TEX_FIXES:
        tex = pattern.sub(repl, tex)
    try:
        mathml = convert(tex, display="block" if display else "inline")
    except Exception as e:  # latex2mathml raises its own exceptions, and IndexError/KeyError on some input
        raise MathError(f"{tex!r}: {type(e).__name__}: {e}") from e
    for pattern, repl in _MATHML_FIXES:
        mathml = pattern.sub(repl, mathml)
    mathml = _VARIANT.sub(_variant, mathml)
    if (left := _LEFTOVER.search(mathml)) or "<merror" in mathml:
        raise MathError(f"{tex!r}: not converted: {left.group(0) if left else '<merror>'}")
    return mathml


def _strip_delimiters(tex: str) -> tuple[str, bool]:
    """The formula of an arithmatex block's text, and whether it is displayed."""
    tex = tex.strip()
    if tex.startswith("\\(") and tex.endswith("\\)"):
        return tex[2:-2], False
    if tex.startswith("\\[") and tex.endswith("\\]"):
        return tex[2:-2], True
    return tex, True  # a bare \begin{env}...\end{env} block


def render_math(html: str, where: str = "") -> str:
    """``html`` with every arithmatex span and div holding MathML instead of TeX (kept as TeX, with a warning, where
    the TeX does not convert)."""

    def one(m: re.Match[str]) -> str:
        tex, display = _strip_delimiters(_html.unescape(m.group(2)))
        try:
            return f'<{m.group(1)} class="arithmatex">{tex_to_mathml(tex, display)}</{m.group(1)}>'
        except MathError as e:
            log.warning("%s: TeX not rendered: %s", where, e)
            return m.group(0)

    return _ARITHMATEX.sub(one, html)


def render_toc_math(title: str, where: str = "") -> str:
    """A table-of-contents entry (escaped text) with its ``\\(...\\)`` formulas as MathML."""

    def one(m: re.Match[str]) -> str:
        try:
            return tex_to_mathml(_html.unescape(m.group(1)))
        except MathError as e:
            log.warning("%s: TeX not rendered in the table of contents: %s", where, e)
            return m.group(0)

    return _TOC_MATH.sub(one, title)


def _toc_items(items):
    for item in items:
        yield item
        yield from _toc_items(item.children)


def on_page_content(html, page, **kwargs):
    where = page.file.src_uri
    for item in _toc_items(page.toc):
        item.title = render_toc_math(item.title, where)
    return render_math(strip_roles(html), where)
