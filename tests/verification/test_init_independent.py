"""``verify`` is a small independent checker (issue 80): the package ``fairaudit.verification`` imports nothing else of
fairaudit, so that a third party reads one package (its certificate schema is its own file). Every import counts: at
a module's top, inside a function, under ``TYPE_CHECKING``, absolute, relative (one that leaves the package), or
by ``importlib.import_module``; and a fresh interpreter that verifies certificates loads nothing else of fairaudit."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

from test_rederive import MATRIX, OFFICE, TABLE

from fairaudit.certification.certificate import certify
from fairaudit.certification.spec import parse_spec
from fairaudit.filter.filters import PrivacyFilter

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "fairaudit" / "verification"

# verify solves nothing (issue 80): no module of fairaudit outside the package is allowed
ALLOWED: set[str] = set()


def imported(source: str, package: list[str]) -> set[str]:
    """The absolute names of every module a module in ``package`` (its dotted parts) imports, anywhere in it; for
    ``from P import a`` of a package P given by name only (``fairaudit``, or relative) also ``P.a``, which may be a
    module."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            found.add(module)
            if module == "fairaudit" or not node.module:
                found |= {f"{module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module" and node.args:
            if isinstance(node.args[0], ast.Constant):
                found.add(str(node.args[0].value))
    return found


def outside(modules: set[str]) -> set[str]:
    """The fairaudit modules among ``modules`` that are neither the verification package's nor allowed."""
    own = "fairaudit.verification"
    return {
        m
        for m in modules
        if (m == "fairaudit" or m.startswith("fairaudit.")) and m != own and not m.startswith(own + ".")
    } - ALLOWED


def test_the_detector_finds_every_kind_of_import():
    source = """
from typing import TYPE_CHECKING
import numpy
from . import checks
from .enclosures import exact
from ..base.errors import InputError
from .. import laws
import fairaudit.metrics.parity
from fairaudit import InputError
if TYPE_CHECKING:
    from fairaudit.filter.filters import PrivacyFilter
def f():
    from fairaudit.base.json_values import label
    importlib.import_module("fairaudit.data.counts")
"""
    found = outside(imported(source, ["fairaudit", "verification"]))
    assert found == {"fairaudit", "fairaudit.base.errors", "fairaudit.laws", "fairaudit.metrics.parity",
                     "fairaudit.InputError", "fairaudit.filter.filters", "fairaudit.base.json_values",
                     "fairaudit.data.counts"}  # fmt: skip


def test_verification_imports_nothing_else_of_fairaudit():
    modules = sorted(PACKAGE.rglob("*.py"))
    assert len(modules) >= 10  # (the package is found: its modules are merged as it shrinks)
    found = {}
    for path in modules:
        package = ["fairaudit", *path.relative_to(ROOT / "fairaudit").parts[:-1]]
        names = outside(imported(path.read_text(encoding="utf-8"), package))
        if names:
            found[path.name] = sorted(names)
    assert found == {}


# a fresh interpreter whose `fairaudit` is the package's folder without its __init__.py (which imports every layer, by
# design: docs/design.md "Start-up"), so that what loads is what verification itself imports, lazily too
_FRESH = """
import json, pathlib, sys, types
package = types.ModuleType("fairaudit")
package.__path__ = [sys.argv[1]]
sys.modules["fairaudit"] = package
import pkgutil, importlib
import fairaudit.verification
for info in pkgutil.iter_modules(fairaudit.verification.__path__):
    importlib.import_module(f"fairaudit.verification.{info.name}")
from fairaudit.verification.rederive import verify
for path in sys.argv[2:]:
    data = json.loads(pathlib.Path(path).read_text(encoding="utf-8"))
    result = verify(data["certificate"], privacy_filter=data["filter"])
    assert result.holds and len(result.checks) > 20, [c.line() for c in result.failures]
print(json.dumps(sorted(m for m in sys.modules if m.startswith("fairaudit.") and not m.startswith("fairaudit.verification"))))
"""


def test_a_fresh_interpreter_verifies_with_verification_alone(tmp_path):
    (tmp_path / "table.csv").write_text(TABLE, encoding="utf-8")
    (tmp_path / "spec.toml").write_text(MATRIX, encoding="utf-8")
    paths = []
    for name, spec in (("matrix", str(tmp_path / "spec.toml")), ("office", parse_spec(OFFICE))):
        cert = certify(spec).to_dict()
        mechanism = cert["inputs"]["sensitive_mechanism"]
        deployed = (
            PrivacyFilter.from_matrix(mechanism["matrix"], mechanism["inputs"])
            if mechanism["kind"] == "matrix"
            else PrivacyFilter.randomized_response(mechanism["inputs"], epsilon=mechanism["epsilon"])
        )
        paths.append(tmp_path / f"{name}.json")
        paths[-1].write_text(json.dumps({"certificate": cert, "filter": deployed.to_dict()}), encoding="utf-8")
    run = subprocess.run(
        [sys.executable, "-c", _FRESH, str(ROOT / "fairaudit"), *map(str, paths)],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    loaded = set(json.loads(run.stdout))
    assert loaded == set()
