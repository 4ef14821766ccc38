"""Start-up budget: ``import fairaudit`` and ``fairaudit --help`` import no heavy module.

Each check runs a fresh interpreter with ``-X importtime`` and reads the modules it imported from stderr (one line
per module, ``import time: self | cumulative | name``), so a module imported by any path at start-up is caught,
however deep. Times are not asserted (benchmarks/bench_startup.py measures them as ratios); what is imported is.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import fairaudit

ROOT = Path(__file__).resolve().parents[1]

# Heavy at start-up: each takes from a tenth of a second to most of one to import.
HEAVY = (
    "pandas",
    "pyarrow",
    "scipy.stats",
    "cvxpy",
    "matplotlib",
    "httpx",
    "duckdb",
    "pyspark",
    "torch",
    "jinja2",
)
COMMANDS = ("certify", "audit", "calibrate", "plan", "experiment", "prepare-model")


def _imported(*args: str) -> set[str]:
    """The modules a fresh ``python -X importtime ARGS`` imports (the command must exit 0)."""
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", *args], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    names = set()
    for line in proc.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            names.add(line.rsplit("|", 1)[1].strip())
    assert names, "no -X importtime lines: the interpreter did not report its imports"
    return names


def _heavy(names: set[str]) -> list[str]:
    return sorted(n for n in names if any(n == h or n.startswith(h + ".") for h in HEAVY))


def test_import_fairaudit_imports_no_heavy_module_not_even_numpy():
    names = _imported("-c", "import fairaudit")
    assert "fairaudit" in names
    assert _heavy(names) == []
    assert not {"numpy", "scipy", "pydantic"} & names  # every public name is imported on first use


@pytest.mark.parametrize("command", [(), *((c,) for c in COMMANDS)], ids=lambda c: " ".join(c) or "fairaudit")
def test_help_imports_no_heavy_module(command):
    names = _imported("-m", "fairaudit.cli", *command, "--help")
    assert "fairaudit.cli" in names
    assert _heavy(names) == []


def test_the_check_catches_a_heavy_import():
    """The test above can fail: an interpreter that imports scipy.stats is caught."""
    assert _heavy(_imported("-c", "import fairaudit, scipy.stats")) == ["scipy.stats"] + sorted(
        n for n in _imported("-c", "import scipy.stats") if n.startswith("scipy.stats.")
    )


def _type_checking_names() -> dict[str, set[str]]:
    """The names ``fairaudit/__init__.py`` imports for type checkers, by module (read from its source)."""
    tree = ast.parse((ROOT / "fairaudit" / "__init__.py").read_text(encoding="utf-8"))
    block = next(n for n in tree.body if isinstance(n, ast.If) and getattr(n.test, "id", "") == "TYPE_CHECKING")
    found: dict[str, set[str]] = {}
    for node in block.body:
        assert isinstance(node, ast.ImportFrom) and node.level == 1 and node.module
        found.setdefault(node.module, set()).update(a.name for a in node.names)
    return found


def test_lazy_names_match_the_type_checking_imports_and_all():
    lazy = {module: set(names) for module, names in fairaudit._SOURCES.items()}
    assert lazy == _type_checking_names()
    eager = {"FairauditError", "InputError"}
    assert set(fairaudit.__all__) == set(fairaudit._MODULE_OF) | eager
    assert len(fairaudit.__all__) == len(set(fairaudit.__all__))
    for name in fairaudit.__all__:
        value = getattr(fairaudit, name)
        module = fairaudit._MODULE_OF.get(name, "_errors")
        assert value is getattr(sys.modules[f"fairaudit.{module}"], name), name
        assert name in dir(fairaudit)


def test_unknown_attribute_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        fairaudit.no_such_name  # noqa: B018


@pytest.mark.parametrize("name", ["audit", "calibrate", "certify", "plan"])
def test_a_function_named_like_its_module_stays_the_function(name):
    """``fairaudit.audit`` is the function whether the module ``fairaudit.audit`` was imported first or not."""
    code = (
        f"import fairaudit.{name}, fairaudit, types\n"
        f"from fairaudit import {name} as f\n"
        f"assert callable(f) and not isinstance(f, types.ModuleType), f\n"
        f"assert fairaudit.{name} is f and f.__module__ == 'fairaudit.{name}'\n"
        f"import sys; assert sys.modules['fairaudit.{name}'].{name} is f\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
