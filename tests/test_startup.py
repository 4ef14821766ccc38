"""Start-up budget: ``import fairaudit`` and ``fairaudit --help`` import no heavy module, with a plain ``__init__``.

Each check runs a fresh interpreter that prints ``sys.modules`` on stderr when it exits, so a module imported by any
path at start-up is caught, however deep. Times are not asserted (benchmarks/bench_startup.py measures them as
ratios); what is imported is.
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
CORE = ("certify", "audit", "calibrate", "plan", "worst-case", "filter", "verify")


MODULES_AT_EXIT = "import atexit, sys; atexit.register(lambda: print(*sys.modules, sep='\\n', file=sys.stderr))"
"""Python that prints every module in ``sys.modules`` when the interpreter exits: ``-X importtime`` misses modules
imported by ``importlib.import_module`` (lazy_loader's and the command line's), ``sys.modules`` holds them all."""


def _imported(*args: str) -> set[str]:
    """The modules a fresh ``python -c CODE`` or ``python -m MODULE ARGS`` has imported when it exits (it must exit
    0)."""
    if args[0] == "-c":
        code = f"{MODULES_AT_EXIT}; {args[1]}"
    else:
        code = f"{MODULES_AT_EXIT}; import runpy; sys.argv = {[args[1], *args[2:]]!r}; "
        code += f"runpy.run_module({args[1]!r}, run_name='__main__')"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    names = set(proc.stderr.split())
    assert "sys" in names, "no module list: the interpreter did not print its modules"
    return names


def _heavy(names: set[str]) -> list[str]:
    return sorted(n for n in names if any(n == h or n.startswith(h + ".") for h in HEAVY))


def test_import_fairaudit_imports_no_module_of_the_package_until_a_name_is_used():
    """SPEC 1: ``import fairaudit`` imports none of its modules; using every public name imports numpy, never a heavy
    module."""
    names = _imported("-c", "import fairaudit")
    assert {n for n in names if n.startswith("fairaudit")} == {"fairaudit"}
    assert "numpy" not in names
    names = _imported("-c", "import fairaudit; [getattr(fairaudit, name) for name in fairaudit.__all__]")
    assert "fairaudit.certification.certificate" in names and "numpy" in names
    assert _heavy(names) == []


@pytest.mark.slow
@pytest.mark.parametrize("command", [(), *((c,) for c in COMMANDS)], ids=lambda c: " ".join(c) or "fairaudit")
def test_help_imports_no_heavy_module(command):
    names = _imported("-m", "fairaudit.cli", *command, "--help")
    assert "fairaudit.cli" in names
    assert _heavy(names) == []


@pytest.mark.parametrize("words", [("--help",), ("--version",), ("certify", "--help"), ("experiment", "--help")])
def test_the_command_line_imports_only_the_command_it_names(words):
    """``fairaudit --help`` and ``--version`` import no command's module; a core command imports its own alone."""
    names = _imported("-m", "fairaudit.cli", *words)
    modules = {f"fairaudit.cli.{c.replace('-', '_')}" for c in CORE}
    assert names & modules == ({f"fairaudit.cli.{words[0]}"} if words[0] in CORE else set())


SEARCH = (
    "fairaudit.worstcase.black_box",
    "fairaudit.worstcase.pair_search",
    "fairaudit.worstcase.known_utility_search",
    "fairaudit.worstcase.known_utility_exact",
    "fairaudit.worstcase.lipschitz_proofs",
    "fairaudit.base.linear_fractional",
    "fairaudit.base.exact_duality",
    "fairaudit.base.table_relaxation",
)
"""The worst-case searches' modules: certify loads them only where no closed form answers."""


def test_certify_behind_randomized_response_loads_no_search_module():
    """The shipped example (8-ary randomized response, a known utility): the closed forms answer every worst case
    and the calibrations, so none of the searches' modules is loaded (a tenth of certify's own start-up). The
    black-box bound's module loads them, which shows the check can fail."""
    names = _imported("-m", "fairaudit.cli", "certify", "examples/llm_hiring/gpt35.toml", "--no-progress")
    assert "fairaudit.certification.certificate" in names
    assert sorted(names & set(SEARCH)) == []
    assert "fairaudit.base.exact_lp" not in names  # (no LP at all: every interval's lower end is a closed form)
    names = _imported("-c", "import fairaudit as fa; fa.black_box_bound(fa.randomized_response([0, 1], 1.0))")
    assert {"fairaudit.worstcase.black_box", "fairaudit.base.linear_fractional"} <= names


@pytest.mark.slow
def test_the_check_catches_a_heavy_import():
    """The test above can fail: an interpreter that imports scipy.stats is caught."""
    caught = _heavy(_imported("-c", "import fairaudit, scipy.stats"))
    assert "scipy.stats" in caught and caught == sorted(n for n in _imported("-c", "import scipy.stats") if _heavy({n}))


def test_the_public_names_are_one_plain_list_of_imports_and_all():
    """``fairaudit/__init__.pyi``: relative imports of the public names from their modules (what
    ``lazy_loader.attach_stub`` reads), ``__version__`` and ``__all__``; every name imported is in ``__all__`` and
    every name of ``__all__`` is imported; ``__init__.py`` holds no import of its own."""
    tree = ast.parse((ROOT / "fairaudit" / "__init__.pyi").read_text(encoding="utf-8"))
    imported: list[str] = []
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            assert node.level == 1 and node.module, ast.unparse(node)
            imported += [a.asname or a.name for a in node.names]
        elif isinstance(node, ast.Assign):
            assert [t.id for t in node.targets if isinstance(t, ast.Name)] == ["__all__"], ast.unparse(node)
            listed = ast.literal_eval(node.value)
        else:
            assert isinstance(node, ast.AnnAssign) and ast.unparse(node.target) == "__version__", ast.unparse(node)
    assert sorted(imported) == sorted(listed) == sorted(fairaudit.__all__)
    assert len(listed) == len(set(listed))
    init = ast.parse((ROOT / "fairaudit" / "__init__.py").read_text(encoding="utf-8"))
    assert [ast.unparse(n) for n in init.body if isinstance(n, (ast.Import, ast.ImportFrom))] == ["import lazy_loader"]
    assert fairaudit.__version__ and set(dir(fairaudit)) >= set(fairaudit.__all__)


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
