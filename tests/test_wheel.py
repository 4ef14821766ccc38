"""Release hygiene: the wheel built by ``python -m build`` installs into a fresh environment and certifies.

The wheel is built from a copy of this checkout without what a clean clone
lacks (so that setuptools writes its ``build/`` and ``*.egg-info`` there, not
into the tree, where another build may be writing them), installed with pip
into a new virtual environment (its dependencies come from the package index, as for a user),
and its ``fairaudit`` command certifies a shipped example. The JSON it prints
must equal the in-tree package's certificate of the same spec, and the
version must be the one written in ``fairaudit/__init__.py`` (the only place
it is written: ``pyproject.toml`` reads it from there).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import fairaudit
from fairaudit.certification.certificate import certify
from fairaudit.reports.formats import render

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "llm_hiring" / "gpt35.toml"
# what a clean clone does not hold (.gitignore): build outputs, caches, virtual environments
NOT_IN_A_CLONE = (".git", "build", "dist", "*.egg-info", "__pycache__", ".*_cache", ".hypothesis", "*venv", "site")
# the distribution is fairness-certify on PyPI (fairaudit there is another project); the wheel's file and
# .dist-info names spell it normalized (PEP 427, PEP 503); the import package and the command stay fairaudit
DISTRIBUTION = "fairness-certify"
WHEEL_NAME = "fairness_certify"


def _run(args, **kw):
    done = subprocess.run(args, capture_output=True, text=True, **kw)
    assert done.returncode == 0, f"{args[:4]} exited {done.returncode}:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    return done


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    pytest.importorskip("build", reason="the release test needs 'build' (in the [test] extra)")
    out = tmp_path_factory.mktemp("dist")
    src = tmp_path_factory.mktemp("checkout") / "fairaudit"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(*NOT_IN_A_CLONE))
    _run([sys.executable, "-m", "build", "--wheel", "--outdir", str(out), str(src)])
    (found,) = out.glob(f"{WHEEL_NAME}-*.whl")
    return found


def test_version_is_written_once():
    assert re.fullmatch(r"\d+\.\d+\.\d+", fairaudit.__version__)
    assert "version =" not in (ROOT / "pyproject.toml").read_text().split("[project]")[1].split("\n[")[0]
    changelog = (ROOT / "CHANGELOG.md").read_text()
    assert f"## [{fairaudit.__version__}]" in changelog or "## [Unreleased]" in changelog


@pytest.mark.wheel  # slow: left out of the default run; `python -m pytest -m wheel` (.ci/run) runs it
def test_wheel_holds_the_package_and_nothing_else(wheel):
    assert wheel.name == f"{WHEEL_NAME}-{fairaudit.__version__}-py3-none-any.whl"
    names = zipfile.ZipFile(wheel).namelist()
    top = {n.split("/")[0] for n in names}
    info = f"{WHEEL_NAME}-{fairaudit.__version__}.dist-info"
    assert top == {"fairaudit", info}
    assert "fairaudit/cli/__init__.py" in names and "fairaudit/cli/certify.py" in names
    assert "fairaudit/worstcase/__init__.py" in names and "fairaudit/experiments/vlm/tasks.py" in names
    # the modules that became packages are gone (a stale ./build from an older checkout would bring them back)
    assert "fairaudit/cli.py" not in names and "fairaudit/worstcase.py" not in names
    assert "fairaudit/py.typed" in names  # PEP 561: type checkers use the shipped annotations
    assert "fairaudit/verification/certificate.schema.json" in names  # the certificate's JSON Schema (package data)
    assert "fairaudit/reports/formats/page.html.jinja" in names  # the HTML report's template (package data)
    entry = zipfile.ZipFile(wheel).read(f"{info}/entry_points.txt").decode()
    assert "fairaudit = fairaudit.cli:main" in entry
    # the experiments' commands, a plug-in registered in the group the fairaudit command reads
    plugin = (
        "experiment = fairaudit.experiments.cli.experiment\nprepare-model = fairaudit.experiments.cli.prepare_model"
    )
    assert f"[fairaudit.commands]\n{plugin}\n" in entry
    metadata = zipfile.ZipFile(wheel).read(f"{info}/METADATA").decode().splitlines()
    assert f"Name: {DISTRIBUTION}" in metadata and f"Version: {fairaudit.__version__}" in metadata
    # the extras name the distribution itself: [test] pulls [docs] from this wheel, not PyPI's other fairaudit
    assert f'Requires-Dist: {DISTRIBUTION}[docs]; extra == "test"' in metadata


@pytest.mark.wheel  # slow: left out of the default run; `python -m pytest -m wheel` (.ci/run) runs it
def test_wheel_installs_in_a_fresh_environment_and_certifies(wheel, tmp_path):
    env = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", str(env)])
    bindir = env / ("Scripts" if sys.platform == "win32" else "bin")
    _run([str(bindir / "python"), "-m", "pip", "install", "-q", str(wheel)])
    version = _run([str(bindir / "fairaudit"), "--version"]).stdout.strip()
    assert version == f"fairaudit {fairaudit.__version__}"
    # run outside the checkout, so the installed package (not the source tree) answers
    out = _run([str(bindir / "fairaudit"), "certify", str(EXAMPLE), "--format", "json"], cwd=tmp_path).stdout
    where = _run([str(bindir / "python"), "-c", "import fairaudit; print(fairaudit.__file__)"], cwd=tmp_path).stdout
    listed = _run([str(bindir / "fairaudit"), "--help"], cwd=tmp_path)
    assert "experiment " in listed.stdout and "prepare-model" in listed.stdout and listed.stderr == ""
    assert str(env) in where
    # installed under the distribution name, which provides the import package fairaudit
    names = (
        f"import importlib.metadata as m; print(m.version({DISTRIBUTION!r}), m.packages_distributions()['fairaudit'])"
    )
    installed = _run([str(bindir / "python"), "-c", names], cwd=tmp_path).stdout
    assert installed == f"{fairaudit.__version__} [{DISTRIBUTION!r}]\n"
    got, want = json.loads(out), json.loads(render(certify(EXAMPLE).to_dict(), "certify", "json"))
    assert got["certified"] is True
    assert got == want
