"""Start-up budget: ``import fairaudit`` and ``fairaudit --help`` import no heavy module, with a plain ``__init__``.

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
    "scipy",
    "pydantic",
    "cvxpy",
    "matplotlib",
    "httpx",
    "duckdb",
    "pyspark",
    "torch",
    "jinja2",
    "jsonschema",  # about 0.05 s: imported when a certificate is checked
    "gmpy2",  # about 0.02 s (it loads importlib.metadata): imported where the exact arithmetic runs
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


def test_import_fairaudit_imports_no_heavy_module():
    names = _imported("-c", "import fairaudit")
    assert "fairaudit" in names and "numpy" in names  # every public name is imported, and numpy with them
    assert _heavy(names) == []


@pytest.mark.slow
@pytest.mark.parametrize("command", [(), *((c,) for c in COMMANDS)], ids=lambda c: " ".join(c) or "fairaudit")
def test_help_imports_no_heavy_module(command):
    names = _imported("-m", "fairaudit.cli", *command, "--help")
    assert "fairaudit.cli" in names
    assert _heavy(names) == []


@pytest.mark.slow
def test_the_check_catches_a_heavy_import():
    """The test above can fail: an interpreter that imports scipy.stats is caught."""
    caught = _heavy(_imported("-c", "import fairaudit, scipy.stats"))
    assert "scipy.stats" in caught and caught == sorted(n for n in _imported("-c", "import scipy.stats") if _heavy({n}))


def test_the_package_init_is_a_plain_list_of_imports_and_all():
    """``fairaudit/__init__.py``: a docstring, imports of the public names from their modules, ``__version__`` and
    ``__all__``; every name imported is in ``__all__`` and every name of ``__all__`` is imported."""
    tree = ast.parse((ROOT / "fairaudit" / "__init__.py").read_text(encoding="utf-8"))
    imported: list[str] = []
    assigned = []
    for node in tree.body[1:]:  # after the docstring
        if isinstance(node, ast.ImportFrom) and node.module == "__future__":
            continue
        if isinstance(node, ast.ImportFrom):
            assert node.level == 0 and node.module and node.module.startswith("fairaudit."), ast.unparse(node)
            imported += [a.asname or a.name for a in node.names]
        else:
            assert isinstance(node, ast.Assign), ast.unparse(node)
            assigned += [t.id for t in node.targets if isinstance(t, ast.Name)]
    assert assigned == ["__version__", "__all__"]
    assert sorted(imported) == sorted(fairaudit.__all__)
    assert len(fairaudit.__all__) == len(set(fairaudit.__all__))


def test_no_module_is_named_like_a_function_or_class_it_defines():
    """``fairaudit.audit`` is the function, never a module: no module shares its name with what it defines."""
    clashes = []
    for path in (ROOT / "fairaudit").rglob("*.py"):
        defined = {
            n.name
            for n in ast.parse(path.read_text(encoding="utf-8")).body
            if isinstance(n, (ast.FunctionDef, ast.ClassDef))
        }
        if path.stem in defined:
            clashes.append(path.relative_to(ROOT).as_posix())
    assert clashes == []
