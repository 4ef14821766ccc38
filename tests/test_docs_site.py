"""The generator of the documentation site's pages (scripts/gen_docs.py); CI builds the site with --strict."""

import argparse
import runpy
from pathlib import Path

import pytest

from fairaudit.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
gen = runpy.run_path(str(ROOT / "scripts" / "gen_docs.py"), run_name="gen_docs")  # main() does not run


@pytest.mark.parametrize(
    "text, page, expected",
    [
        ("[proofs](../proofs/README.md)", "concepts.md", "[proofs](proofs/README.md)"),
        ("[p](../proofs/black_box.md#section-6)", "certificates.md", "[p](proofs/black_box.md#section-6)"),
        ("[t](../../proofs/tight_bound.md)", "examples/compas.md", "[t](../proofs/tight_bound.md)"),
        ("[b](../benchmarks/README.md)", "performance.md", "[b](benchmarks/README.md)"),
        ("[c](../CHANGELOG.md)", "index.md", "[c](CHANGELOG.md)"),
        # inside docs/, outside the mirrored files, external or anchors only: unchanged
        ("[u](../uncertainty.md)", "examples/compas.md", "[u](../uncertainty.md)"),
        ("[s](../fairaudit/certification/spec.py)", "spec.md", "[s](../fairaudit/certification/spec.py)"),
        ("[w](https://example.org/../proofs/a.md)", "index.md", "[w](https://example.org/../proofs/a.md)"),
        ("[a](#notation)", "concepts.md", "[a](#notation)"),
    ],
)
def test_relink(text, page, expected):
    assert gen["relink"](text, page) == expected


def test_sphinx_roles_show_as_code():
    hooks = runpy.run_path(str(ROOT / "scripts" / "mkdocs_hooks.py"))
    html = ":func:<code>~fairaudit.data.counts.count_file</code> and :class:<code>Kernel</code>, :mod:<code>fairaudit.data.spark</code>"
    assert (
        hooks["strip_roles"](html)
        == "<code>count_file</code> and <code>Kernel</code>, <code>fairaudit.data.spark</code>"
    )


def _parsers(parser):
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                yield from _parsers(child)


def test_cli_reference_has_every_command_and_option(monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    page = gen["cli_reference"]()
    sections = {s.split("`", 1)[0]: s for s in page.split("\n## `")[1:]}
    parsers = list(_parsers(build_parser()))
    assert sorted(sections) == sorted(p.prog for p in parsers)
    assert {"fairaudit certify", "fairaudit audit", "fairaudit calibrate", "fairaudit plan"} <= set(sections)
    for p in parsers:
        section = sections[p.prog]
        assert p.format_usage().strip() in section
        for action in p._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help"):
                    assert f"`{option}`" in section, (p.prog, option)
            if action.choices is not None and not isinstance(action, argparse._SubParsersAction):
                assert all(f"`{c}`" in section for c in action.choices), (p.prog, action.dest)
    assert "| `--format` | `text` \\| `json` \\| `markdown` \\| `html` | `text` |" in sections["fairaudit certify"]
    one_of = "one of `--target`, `--target-impact-ratio`"
    assert f"| `--target` | `L` |  | {one_of} |" in sections["fairaudit calibrate"]
    assert f"| `--target-impact-ratio` | `R` |  | {one_of} |" in sections["fairaudit calibrate"]
    assert "| `--target` | `L` |  | yes |" in sections["fairaudit plan"]


def test_api_reference_covers_every_public_module():
    files = {
        ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for p in (ROOT / "fairaudit").rglob("*.py")
    }
    public = sorted(m for m in files if not any(part.startswith("_") for part in m.split(".")))
    assert gen["public_modules"]() == public
    assert "fairaudit.certification.certificate" in public and "fairaudit.experiments.vlm.client" in public


def test_package_page_lists_every_export():
    import fairaudit

    page = gen["_package_page"]()
    for name in fairaudit.__all__:
        assert f"[`{name}`]" in page, name
    assert (
        "| [`certify`][fairaudit.certification.certificate.certify] | function | "
        "[`fairaudit.certification.certificate`](certification/certificate.md) |" in page
    )
    assert (
        "| [`InputError`][fairaudit.base.errors.InputError] | class | [`fairaudit.base.errors`](base/errors.md) |"
        in page
    )


def test_every_docs_page_is_in_the_nav():
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in (ROOT / "docs").rglob("*.md"):
        assert page.relative_to(ROOT / "docs").as_posix() in nav, page
