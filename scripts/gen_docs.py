"""Pages of the documentation site that are made at build time (mkdocs-gen-files).

Run by ``mkdocs build`` (see ``mkdocs.yml``); nothing here is committed as output.

* ``reference/cli.md``: the command-line reference, read from ``fairaudit.cli.build_parser()``, so it cannot drift
  from the command;
* ``reference/api/``: one page per public module of the package (mkdocstrings renders the docstrings), with the
  navigation in ``reference/api/SUMMARY.md`` (mkdocs-literate-nav);
* ``proofs/`` and ``benchmarks/README.md``: the repository's proofs and benchmark notes, rendered as they are;
* links from ``docs/`` to ``../proofs/...`` and ``../benchmarks/README.md`` point into the site instead.
"""

from __future__ import annotations

import argparse
import os
import pkgutil
import posixpath
import re
from pathlib import Path

import mkdocs_gen_files

import fairaudit
from fairaudit.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
# repository paths that the site also serves, at the same path
MIRRORED = ("proofs/", "benchmarks/README.md", "CHANGELOG.md")


# --------------------------------------------------------------------------- CLI reference
def _md(text: str) -> str:
    """Text for a Markdown table cell: one line, pipes and angle brackets escaped."""
    text = " ".join(str(text).split())
    return text.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")


def _value(action: argparse.Action) -> str:
    if action.nargs == 0:
        return ""
    if action.choices is not None:
        return " \\| ".join(f"`{c}`" for c in action.choices)
    if not action.option_strings:
        return ""
    return f"`{action.metavar or action.dest.upper()}`"


def _default(action: argparse.Action) -> str:
    d = action.default
    if action.nargs == 0 or d is None or d is argparse.SUPPRESS or action.required:
        return ""
    return f"`{d}`"


def _command_section(parser: argparse.ArgumentParser, level: int) -> list[str]:
    out = [f"{'#' * level} `{parser.prog}`", ""]
    if parser.description:
        out += [parser.description, ""]
    out += ["```text", parser.format_usage().strip(), "```", ""]
    rows = []
    one_of = {  # an option of a required mutually exclusive group: one of the group is required
        id(a): "one of " + ", ".join(f"`{max(b.option_strings, key=len)}`" for b in g._group_actions)
        for g in parser._mutually_exclusive_groups
        if g.required
        for a in g._group_actions
    }
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        name = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{action.metavar or action.dest.upper()}`"
        needed = "yes" if action.required or not action.option_strings else one_of.get(id(action), "")
        help_text = (action.help or "") % {"default": action.default, "prog": parser.prog}
        rows.append(f"| {name} | {_value(action)} | {_default(action)} | {needed} | {_md(help_text)} |")
    if rows:
        out += ["| argument | value | default | required | meaning |", "|---|---|---|---|---|", *rows, ""]
    for child in _subcommands(parser).values():
        out += _command_section(child, level)
    return out


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(subs[0].choices) if subs else {}


def cli_reference() -> str:
    os.environ["COLUMNS"] = "80"  # argparse wraps usage at the terminal width; fix it so the page is reproducible
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    lines = [
        "# Command-line reference",
        "",
        "Generated from `fairaudit.cli.build_parser()` when the site is built, so it lists exactly the options of",
        f"fairaudit {fairaudit.__version__}. The guide to the command, with examples, exit statuses and the JSON",
        "keys, is [The command line](../cli.md).",
        "",
        "| command | what it does |",
        "|---|---|",
    ]
    helps = {a.dest: a.help for a in sub._choices_actions}
    lines += [f"| [`{name}`](#fairaudit-{name}) | {_md(helps.get(name, ''))} |" for name in sub.choices]
    lines.append("")
    lines += _command_section(parser, 2)
    return "\n".join(lines)


# --------------------------------------------------------------------------- API reference
def public_modules() -> list[str]:
    """Dotted names of the package's public modules (no part starts with an underscore), sorted."""
    names = ["fairaudit"]
    for info in pkgutil.walk_packages(fairaudit.__path__, prefix="fairaudit."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return sorted(names)


def _documented_in(module: str) -> str:
    """The public module whose page documents what ``module`` defines: the dotted prefix before its first private part.

    ``fairaudit.worstcase.black_box`` -> ``fairaudit.worstcase`` (a package re-exports its private modules' names),
    ``fairaudit.base.errors`` -> ``fairaudit`` (documented on the package page).
    """
    parts = module.split(".")
    public = next((i for i, part in enumerate(parts) if part.startswith("_")), len(parts))
    return ".".join(parts[:public])


def _package_page() -> str:
    """The package's page: its docstring and what it exports, each linked to where it is documented."""
    lines = ["# `fairaudit`", "", "::: fairaudit", "    options:", "      members: false", ""]
    lines += ["## What `import fairaudit` gives", "", "| name | kind | defined in |", "|---|---|---|"]
    here = []  # defined in a private module: documented on this page
    for name in sorted(fairaudit.__all__, key=str.lower):
        obj = getattr(fairaudit, name)
        module = _documented_in(obj.__module__)
        kind = "class" if isinstance(obj, type) else "function"
        if module == "fairaudit":
            here.append(name)
            lines.append(f"| [`{name}`][fairaudit.{name}] | {kind} | this page |")
        else:
            page = "/".join(module.split(".")[1:]) + ".md"
            lines.append(f"| [`{name}`][{module}.{name}] | {kind} | [`{module}`]({page}) |")
    for name in here:
        lines += ["", f"::: fairaudit.{name}", "    options:", "      show_root_heading: true"]
    return "\n".join(lines) + "\n"


def api_reference() -> None:
    nav = mkdocs_gen_files.Nav()
    for name in public_modules():
        parts = tuple(name.split("."))
        doc_path = Path(*parts[1:] or ("index",)).with_suffix(".md") if len(parts) > 1 else Path("index.md")
        nav[parts] = doc_path.as_posix()
        with mkdocs_gen_files.open(Path("reference/api") / doc_path, "w") as fd:
            fd.write(_package_page() if name == "fairaudit" else f"# `{name}`\n\n::: {name}\n")
    with mkdocs_gen_files.open("reference/api/SUMMARY.md", "w") as fd:
        fd.writelines(nav.build_literate_nav())


# --------------------------------------------------------------------------- mirrored pages and links to them
_LINK = re.compile(r"\]\((?!https?:|#|mailto:)([^)\s]+?)(#[^)\s]*)?\)")


def _mirrored(repo_path: str) -> bool:
    return any(repo_path == m or (m.endswith("/") and repo_path.startswith(m)) for m in MIRRORED)


def relink(text: str, page: str) -> str:
    """Point links of docs/<page> that leave docs/ for a mirrored repository file at that file in the site."""
    here = posixpath.dirname(page)

    def fix(m: re.Match[str]) -> str:
        target, anchor = m.group(1), m.group(2) or ""
        repo_path = posixpath.normpath(posixpath.join("docs", here, target))
        if repo_path.startswith("docs/") or not _mirrored(repo_path):
            return m.group(0)
        return f"]({posixpath.relpath(repo_path, here or '.')}{anchor})"

    return _LINK.sub(fix, text)


def mirror() -> None:
    for src in [*sorted((ROOT / "proofs").glob("*.md")), ROOT / "benchmarks" / "README.md", ROOT / "CHANGELOG.md"]:
        rel = src.relative_to(ROOT).as_posix()
        with mkdocs_gen_files.open(rel, "w") as fd:
            fd.write(src.read_text(encoding="utf-8"))
        mkdocs_gen_files.set_edit_path(rel, Path("..") / rel)
    for page in sorted(DOCS.rglob("*.md")):
        rel = page.relative_to(DOCS).as_posix()
        text = page.read_text(encoding="utf-8")
        new = relink(text, rel)
        if new != text:
            with mkdocs_gen_files.open(rel, "w") as fd:
                fd.write(new)


def main() -> None:
    with mkdocs_gen_files.open("reference/cli.md", "w") as fd:
        fd.write(cli_reference())
    api_reference()
    mirror()


if __name__ in {"__main__", "<run_path>"}:  # mkdocs-gen-files runs this file with runpy.run_path
    main()
