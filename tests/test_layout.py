"""The layout rules of docs/design.md that a reader checks by eye, checked here on every module.

* ``__all__`` is sorted within each of its groups (a ``# comment`` line starts a group);
* no module imports a private name (``_x``) from another module;
* no import cycle among the package's modules, counting imports inside functions (not ``TYPE_CHECKING`` ones).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "fairaudit"
MODULES = sorted(PACKAGE.rglob("*.py"))


def _name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _all_groups(path: Path) -> list[list[str]]:
    """The names of ``__all__`` in source order, split where a comment line starts a group."""
    lines = path.read_text().splitlines()
    tree = ast.parse(path.read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            elements = node.value.elts if isinstance(node.value, (ast.List, ast.Tuple)) else []
            groups: list[list[str]] = [[]]
            comment_lines = {i + 1 for i, line in enumerate(lines) if line.strip().startswith("#")}
            last = node.lineno
            for e in elements:
                if any(last < c < e.lineno for c in comment_lines):
                    groups.append([])
                assert isinstance(e, ast.Constant)
                groups[-1].append(e.value)
                last = e.lineno
            return [g for g in groups if g]
    return []


def _sort_key(name: str) -> tuple[int, str]:
    """isort's order: CONSTANTS, then Classes, then functions."""
    if name.isupper():
        return (0, name)
    if name[:1].isupper():
        return (1, name)
    return (2, name)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: _name(p))
def test_all_is_sorted_within_its_groups(path):
    for group in _all_groups(path):
        assert group == sorted(group, key=_sort_key), f"{_name(path)}: __all__ group {group}"


def _imports(path: Path) -> list[tuple[str, list[str], int]]:
    """(module imported, names imported, line) of each import, ``TYPE_CHECKING`` blocks left out."""
    tree = ast.parse(path.read_text())
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for child in node.body for n in ast.walk(child)}
    package = _name(path) if path.name == "__init__.py" else _name(path).rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out.append((target, [a.name for a in node.names], node.lineno))
        elif isinstance(node, ast.Import):
            out += [(a.name, [], node.lineno) for a in node.names]
    return out


@pytest.mark.slow
def test_no_private_name_is_imported_across_modules():
    known = {_name(p) for p in MODULES}
    found = [
        f"{_name(p)}:{line} imports {n} from {target}"
        for p in MODULES
        for target, names, line in _imports(p)
        if target.startswith("fairaudit")
        for n in names
        if n.startswith("_") and not n.startswith("__") and f"{target}.{n}" not in known
    ]
    assert found == []


@pytest.mark.slow
def test_no_import_cycle():
    names = {_name(p): p for p in MODULES}
    graph: dict[str, set[str]] = {}
    for name, path in names.items():
        edges = set()
        for target, imported, _ in _imports(path):
            if not target.startswith("fairaudit"):
                continue
            for t in [f"{target}.{n}" for n in imported] + [target]:
                if t in names and t != name:
                    edges.add(t)
                    break
        # a package's own submodules (re-exported by its __init__) are not a cycle
        graph[name] = {t for t in edges if not t.startswith(name + ".") and not name.startswith(t + ".")}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt) :] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            assert (cycle := visit(node)) is None, " -> ".join(cycle)
