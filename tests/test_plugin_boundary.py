"""The experiments are a plug-in on the public API (docs/design.md, "The plug-in interface").

* every module of ``fairaudit/experiments`` imports the core only as ``from fairaudit import NAME`` (or ``import
  fairaudit``, then ``fairaudit.NAME``) with NAME in ``fairaudit.__all__``: never a private module or name, never a
  submodule (relative imports that leave ``experiments/`` count the same);
* no module outside ``experiments/`` imports it, and at run time ``fairaudit --help`` (with no plug-in registered)
  and each core command's ``--help`` (with the plug-in registered, as installed) leave it out of ``sys.modules``;
* its commands come through the entry point group ``fairaudit.commands``; a plug-in that fails to load is left out
  with one warning line, and the core's commands run as before.
"""

from __future__ import annotations

import ast
import importlib.metadata
import subprocess
import sys
from pathlib import Path

import pytest

import fairaudit
from fairaudit.cli import _parser, main

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "fairaudit"
PLUGIN = PACKAGE / "experiments"
PUBLIC = frozenset(fairaudit.__all__)


def _module(path: Path) -> str:
    """The dotted name of the module at ``path`` (a package's ``__init__.py`` is the package)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _target(node: ast.ImportFrom, path: Path) -> str:
    """The absolute module a ``from ... import`` names, relative imports resolved from ``path``."""
    if not node.level:
        return node.module or ""
    package = _module(path) if path.name == "__init__.py" else _module(path).rpartition(".")[0]
    base = package.split(".")[: len(package.split(".")) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def _core(module: str) -> bool:
    """Whether ``module`` is the core: fairaudit or one of its modules outside the plug-in."""
    return (module == "fairaudit" or module.startswith("fairaudit.")) and not (
        module == "fairaudit.experiments" or module.startswith("fairaudit.experiments.")
    )


def boundary_violations(source: str, path: Path) -> list[str]:
    """``path:line: what`` for each use of the core in ``source`` (a module at ``path``) that is not public.

    Allowed: ``from fairaudit import NAME`` and ``import fairaudit`` (``as`` any alias), then ``fairaudit.NAME``,
    with NAME in ``fairaudit.__all__``. Everything else that reaches the core is a violation: ``fairaudit._x`` or
    ``fairaudit.submodule`` (imported, named after an alias, or passed to ``importlib.import_module``), and a name
    not in ``__all__``.
    """
    where = path.relative_to(ROOT) if path.is_absolute() else path
    tree = ast.parse(source)
    found: list[str] = []
    aliases: set[str] = set()  # local names bound to the package fairaudit itself
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            target = _target(node, path)
            if not _core(target):
                continue
            if target != "fairaudit":
                found.append(f"{where}:{node.lineno}: imports from {target}")
                continue
            found += [
                f"{where}:{node.lineno}: imports fairaudit.{a.name} (not in fairaudit.__all__)"
                for a in node.names
                if a.name not in PUBLIC
            ]
        elif isinstance(node, ast.Import):
            for a in node.names:
                if not _core(a.name):
                    continue
                if a.name != "fairaudit":
                    found.append(f"{where}:{node.lineno}: imports {a.name}")
                else:
                    aliases.add(a.asname or a.name)
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            name = ast.unparse(node.func)
            text = node.args[0].value
            if name.endswith(("import_module", "__import__")) and isinstance(text, str) and _core(text):
                if text != "fairaudit":
                    found.append(f"{where}:{node.lineno}: imports {text}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases:
            if node.attr not in PUBLIC:
                found.append(f"{where}:{node.lineno}: uses fairaudit.{node.attr} (not in fairaudit.__all__)")
    return sorted(set(found))


def test_the_plugin_imports_only_public_names():
    found = [v for p in sorted(PLUGIN.rglob("*.py")) for v in boundary_violations(p.read_text(), p)]
    assert found == []


@pytest.mark.parametrize(
    ("source", "at", "expected"),
    [
        ("from fairaudit.base.files import write_atomic", "experiments/run.py", ["imports from fairaudit.base.files"]),
        ("from ..laws.tables import Kernel", "experiments/analysis.py", ["imports from fairaudit.laws.tables"]),
        (
            "from ...base.toml_documents import parse_toml",
            "experiments/vlm/tasks.py",
            ["imports from fairaudit.base.toml_documents"],
        ),
        (
            "from ... import base",
            "experiments/vlm/tasks.py",
            ["imports fairaudit.base (not in fairaudit.__all__)"],
        ),
        ("from fairaudit import __version__", "experiments/run.py", ["imports fairaudit.__version__ (not in"]),
        ("from fairaudit import Kernel, StrictModel", "experiments/a.py", ["imports fairaudit.StrictModel (not in"]),
        ("import fairaudit.reports.plots", "experiments/figures.py", ["imports fairaudit.reports.plots"]),
        (
            "import fairaudit as fa\nfa.reports.plots.save_figure",
            "experiments/a.py",
            ["uses fairaudit.reports (not in"],
        ),
        (
            "import importlib\nimportlib.import_module('fairaudit.base.json_values')",
            "experiments/a.py",
            ["imports fairaudit.base.json_values"],
        ),
        (
            "if TYPE_CHECKING:\n    from fairaudit.laws.tables import Law",
            "experiments/a.py",
            ["imports from fairaudit.laws.tables"],
        ),
    ],
)
def test_the_boundary_check_catches_a_private_or_submodule_import(source, at, expected):
    """The check above can fail: each of these sources, as a module of the plug-in, is caught with its line."""
    found = boundary_violations(source, ROOT / "fairaudit" / at)
    assert len(found) == 1 and found[0].startswith(f"fairaudit/{at}:"), found
    assert expected[0] in found[0], found


def test_the_boundary_check_lets_public_and_plugin_imports_through():
    source = (
        "import fairaudit\nimport fairaudit as fa\nfrom fairaudit import Kernel, InputError, write_atomic\n"
        "from .harness import table_kernel\nfrom ..vlm.tasks import DeliveryTask\n"
        "from fairaudit.experiments.run import run_experiment\nimport numpy as np\n"
        "fa.compose\nfairaudit.privacy_curve\n"
    )
    assert boundary_violations(source, PLUGIN / "vlm" / "filter.py") == []


@pytest.mark.slow
def test_no_core_module_imports_the_plugin():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.is_relative_to(PLUGIN):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                target = _target(node, path)
                names = [f"{target}.{a.name}" for a in node.names] + [target]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.Call) and ast.unparse(node.func).endswith(("import_module", "__import__")):
                names = [ast.unparse(a).strip("'\"") for a in node.args[:1]]  # a module named in a string
            else:
                continue
            if any(n == "fairaudit.experiments" or n.startswith("fairaudit.experiments.") for n in names):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert found == []


def _modules_after(code: str) -> set[str]:
    """The ``fairaudit.experiments`` modules in ``sys.modules`` after ``code`` runs in a fresh interpreter."""
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            code + "\nimport sys\nprint(sorted(m for m in sys.modules if m.startswith('fairaudit')))",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return {m for m in eval(proc.stdout.splitlines()[-1]) if m.startswith("fairaudit.experiments")}


_HELP = "from fairaudit.cli import main\ntry:\n    main({argv!r})\nexcept SystemExit:\n    pass\n"
_NO_PLUGIN = "import importlib.metadata as m\nm.entry_points = lambda **kw: []\n"


@pytest.mark.parametrize("command", ["certify", "audit", "calibrate", "plan", "worst-case"])
def test_a_core_commands_help_leaves_the_plugin_out(command):
    """Registered or not, the plug-in is not loaded for a core command."""
    assert _modules_after(_HELP.format(argv=[command, "--help"])) == set()


@pytest.mark.slow
def test_the_commands_list_imports_nothing_of_the_plugin_but_what_it_registers():
    """``fairaudit --help``: without a plug-in, nothing of the experiments; with it, only its light command modules."""
    assert _modules_after(_NO_PLUGIN + _HELP.format(argv=["--help"])) == set()
    registered = {p.value for p in importlib.metadata.entry_points(group=_parser.COMMANDS_GROUP)}
    light = {"fairaudit.experiments", "fairaudit.experiments.cli", *registered}
    assert _modules_after(_HELP.format(argv=["--help"])) <= light


def test_the_experiments_commands_are_registered_entry_points():
    """What ``pip install`` registers (pyproject.toml): the two commands, each a module with add_parser and run."""
    points = {p.name: p.value for p in importlib.metadata.entry_points(group=_parser.COMMANDS_GROUP)}
    assert points == {
        "experiment": "fairaudit.experiments.cli.experiment",
        "prepare-model": "fairaudit.experiments.cli.prepare_model",
    }
    parser = _parser.build_parser()
    assert {"experiment", "prepare-model"} <= set(parser._subparsers._group_actions[0].choices)


class _Broken:
    name = "broken"
    value = "no_such_plugin.commands"

    def load(self) -> object:
        raise ModuleNotFoundError("No module named 'no_such_plugin'")


class _HalfDone:
    """A plug-in whose add_parser adds its command, then fails."""

    name = "half"
    value = "half_plugin.commands"

    def load(self) -> object:
        return self

    def add_parser(self, sub) -> None:
        sub.add_parser("half", help="never finished")
        raise RuntimeError("boom\nsecond line")


def test_a_broken_plugin_is_left_out_with_one_warning_and_the_core_runs(monkeypatch, capsys, tmp_path):
    real = importlib.metadata.entry_points
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: [_Broken(), _HalfDone(), *real(group=group)])
    assert main(["calibrate", "--target", "0.5", "--groups", "2"]) == 0  # a core command: no plug-in is loaded
    out, err = capsys.readouterr()
    assert "epsilon" in out and err == ""
    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    out, err = capsys.readouterr()
    assert exit_.value.code == 0
    assert err.splitlines() == [
        "fairaudit: warning: the plug-in command 'broken' (no_such_plugin.commands) is left out: "
        "ModuleNotFoundError: No module named 'no_such_plugin'",
        "fairaudit: warning: the plug-in command 'half' (half_plugin.commands) is left out: RuntimeError: boom",
    ]
    assert "half" not in out and "never finished" not in out and "experiment" in out
    with pytest.raises(SystemExit) as exit_:
        main(["half"])
    assert exit_.value.code == 2 and "invalid choice: 'half'" in capsys.readouterr().err
