"""Smoke test of the benchmark scripts (benchmarks/): each runs with --quick and exits 0.

Performance is reported by the benchmarks themselves, as ratios between routes
timed in the same run; nothing here asserts a time. What is checked: the exit
status, the Markdown table headers, the agreement column (every value within
the scripts' own tolerance), the atomic --output file, the failure path of the
agreement check, and the bisection fallback used when ``calibrate`` is absent.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
AGREEMENT = "agreement (max rel. diff)"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"fairaudit_benchmark_{name}", BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _tables(text: str) -> list[list[list[str]]]:
    """The Markdown tables of a report: rows of cells, header first, rule lines dropped."""
    tables, current = [], []
    for line in text.splitlines():
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not all(re.fullmatch(r":?-{3,}:?", c) for c in cells):
                current.append(cells)
        elif current:
            tables.append(current)
            current = []
    if current:
        tables.append(current)
    return tables


def _check_agreement(table: list[list[str]], tol: float) -> None:
    header, rows = table[0], table[1:]
    assert header[-1] == AGREEMENT
    assert rows
    for row in rows:
        assert len(row) == len(header)
        cell = row[-1]
        if cell != "—":
            assert float(cell) <= tol, row


@pytest.mark.parametrize("name, headers", [
    ("bench_lfp", ["| m (cells) | programs | threshold_max |", "| n (groups) | m (outputs) |"]),
    ("bench_product64", ["| operation | result | median time |"]),
])
def test_quick_run_exits_zero_with_tables(name, headers, capsys, tmp_path):
    module = _load(name)
    output = tmp_path / "report.md"
    assert module.main(["--quick", "--output", str(output)]) == 0
    text = capsys.readouterr().out
    for header in headers:
        assert header in text
    tables = _tables(text)
    assert len(tables) == len(headers)
    for table in tables:
        _check_agreement(table, module.AGREEMENT_TOL)
    assert output.read_text(encoding="utf-8") == text          # --output holds exactly the printed report
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]   # no temporary file left behind


def test_lfp_quick_reports_sampled_pairs(capsys):
    module = _load("bench_lfp")
    assert module.main(["--quick"]) == 0
    text = capsys.readouterr().out
    assert "(sample)" in text and "extrapolated" in text


def test_agreement_failure_exits_one(capsys, monkeypatch):
    module = _load("bench_product64")
    monkeypatch.setattr(module, "AGREEMENT_TOL", -1.0)      # every comparison now "fails"
    assert module.main(["--quick"]) == 1
    captured = capsys.readouterr()
    assert "FAILURE" in captured.out and "FAIL:" in captured.err


def test_product64_bisection_fallback(capsys, monkeypatch):
    module = _load("bench_product64")
    monkeypatch.setattr(module, "calibrate", None)
    assert module.main(["--quick"]) == 0
    text = capsys.readouterr().out
    assert "bisection fallback" in text
    _check_agreement(_tables(text)[0], module.AGREEMENT_TOL)


def test_coverage_quick_run_exits_zero_with_tables(capsys, tmp_path):
    """bench_coverage reports coverage, not agreement: its tables have no agreement column."""
    module = _load("bench_coverage")
    output = tmp_path / "report.md"
    assert module.main(["--quick", "--output", str(output)]) == 0
    text = capsys.readouterr().out
    for level in ("0.90", "0.95"):
        assert f"## Confidence {level}" in text
    assert "| method | datasets | coverage L | coverage L̄ | coverage L_dp | coverage L_eo | simultaneous |" in text
    assert "| fairlearn bootstrap |" in text
    tables = _tables(text)
    assert len(tables) == 6                                    # per level: methods, bootstrap subset, scenarios
    assert [row[0] for row in tables[0][1:]] == ["clopper-pearson", "multinomial", "bayes"]
    assert output.read_text(encoding="utf-8") == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]
