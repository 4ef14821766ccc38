"""The layers of docs/design.md, enforced: each subpackage imports only the layers its row of the table names.

The table is read from docs/design.md ("Layers"), so the page and the check cannot disagree. Every import of a
fairaudit module counts: at a module's top, inside a function, under ``TYPE_CHECKING``, relative or absolute.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "fairaudit"


def layer_table(text: str) -> dict[str, set[str]]:
    """Package -> the packages it may import (itself included), from the table of the "Layers" section."""
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    allowed: dict[str, set[str]] = {}
    for row in section.splitlines():
        cells = [c.strip() for c in row.strip().strip("|").split("|")]
        if len(cells) != 4 or not cells[1].startswith("`"):
            continue
        package = cells[1].strip("`")
        allowed[package] = {package} | {name.strip() for name in cells[3].split(",") if name.strip()}
    return allowed


def imported_modules(path: Path, source: str) -> set[str]:
    """The absolute names of the fairaudit modules (or packages) a module imports, anywhere in it."""
    package = list(path.relative_to(ROOT).parts[:-1])
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            if module == "fairaudit" or not node.module:  # names of a package: they may be modules
                found |= {f"{module}.{a.name}" for a in node.names}
            else:
                found.add(module)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module" and node.args:
            if isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
                found.add(node.args[0].value)
    return {m for m in found if m.split(".")[0] == "fairaudit"}


def layer_of(module: str, packages: set[str]) -> str | None:
    """The layer (first subpackage) of ``fairaudit.X...``; None for the package itself and its public names."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in packages else None


def violations(allowed: dict[str, set[str]], sources: dict[Path, str] | None = None) -> list[str]:
    """Each import that leaves the layers its module's row allows (``sources``: the package's modules by default)."""
    if sources is None:
        sources = {path: path.read_text(encoding="utf-8") for path in sorted(PACKAGE.rglob("*.py"))}
    found = []
    for path, source in sources.items():
        rel = path.relative_to(PACKAGE)
        if len(rel.parts) == 1:
            continue  # fairaudit/__init__.py: the package imports every layer
        mine = rel.parts[0]
        for module in sorted(imported_modules(path, source)):
            theirs = layer_of(module, set(allowed))
            if theirs is not None and theirs not in allowed[mine]:
                found.append(f"{rel.as_posix()} ({mine}) imports {module} ({theirs})")
    return found


ALLOWED = layer_table((ROOT / "docs" / "design.md").read_text(encoding="utf-8"))


def test_the_table_names_every_subpackage_and_only_known_layers():
    subpackages = {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    assert set(ALLOWED) == subpackages
    for package, names in ALLOWED.items():
        assert names <= set(ALLOWED) | {"the package `fairaudit`"}, package


def test_no_layer_imports_a_layer_its_row_does_not_name():
    assert violations(ALLOWED) == []


def test_the_layers_form_a_stack():
    """No two layers may import each other: the table is an order, lowest first."""
    for a, names in ALLOWED.items():
        for b in names - {a}:
            assert b not in ALLOWED or a not in ALLOWED[b], (a, b)


@pytest.mark.parametrize(
    ("package", "source", "caught"),
    [
        ("metrics", "from fairaudit.statistics.intervals import Interval", "fairaudit.statistics.intervals"),
        ("laws", "def f():\n    from ..metrics import fairness", "fairaudit.metrics"),
        ("base", "from ..laws.tables import Law", "fairaudit.laws.tables"),
        ("data", "import fairaudit.worstcase.calibration", "fairaudit.worstcase.calibration"),
        ("statistics", "importlib.import_module('fairaudit.reports.plots')", "fairaudit.reports.plots"),
        ("experiments", "from fairaudit.cli import main", "fairaudit.cli"),
    ],
)
def test_the_check_catches_an_import_up_the_stack(package, source, caught):
    """A module that reaches up is caught, however it imports."""
    found = violations(ALLOWED, {PACKAGE / package / "probe.py": source})
    assert len(found) == 1 and re.search(rf"imports {re.escape(caught)} \(", found[0]), found


def test_the_tests_mirror_the_package():
    """``tests/<layer>/test_<module>[_<topic>].py``: each core layer's tests name the module they test (the plug-in's
    tests, under ``tests/experiments/``, are named for what they run); the tests of the whole repository (docs,
    proofs, layers, start-up, the wheel) stay in ``tests/``."""
    tests = ROOT / "tests"
    assert {p.name for p in tests.iterdir() if p.is_dir() and not p.name.startswith("_")} == set(ALLOWED)
    for layer in set(ALLOWED) - {"experiments"}:
        modules = {p.stem.strip("_") or "main" for p in (PACKAGE / layer).rglob("*.py")} | {"main"}
        for test in (tests / layer).rglob("test_*.py"):
            name = test.stem.removeprefix("test_")
            assert any(name == m or name.startswith(m + "_") for m in modules), test.relative_to(ROOT).as_posix()
