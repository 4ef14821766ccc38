"""Smoke test of the benchmark scripts (benchmarks/): each runs with --quick and exits 0.

Performance is reported by the benchmarks themselves, as ratios between routes
timed in the same run; nothing here asserts a time. What is checked: the exit
status, the Markdown table headers, the agreement column (every value within
the scripts' own tolerance), the atomic --output file, the failure path of the
agreement check, and the bisection fallback used when ``calibrate`` is absent.
"""

from __future__ import annotations

import importlib.util
import os
import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.benchmarks  # a slow group of its own (pyproject.toml, .ci/run)

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


@pytest.mark.parametrize(
    "name, headers",
    [
        ("bench_lfp", ["| m (cells) | programs | threshold_max |", "| n (groups) | m (outputs) |"]),
        ("bench_product64", ["| operation | result | median time |"]),
        ("bench_impact_ratio", ["| n per category | level | interval or test |"]),
        ("bench_plan_memory", ["| groups x contexts | epsilon | method | tables |"]),
        ("bench_audit_memory", ["| groups | records | audit peak (MiB) | pandas groupby peak (MiB) |"]),
    ],
)
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
    assert output.read_text(encoding="utf-8") == text  # --output holds exactly the printed report
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]  # no temporary file left behind


def test_certify_quick_run_verifies_every_family(capsys):
    # issue 80: each family's small spec certifies, and its certificate verifies (the agreement of this benchmark)
    assert _load("bench_certify").main(["--quick"]) == 0
    (table,) = _tables(capsys.readouterr().out)
    assert table[0][:3] == ["family", "seed", "certify s"] and [row[0] for row in table[1:]] == [
        "intersectional",
        "near_tie",
        "counts",
    ]
    assert all(row[7] == "True" for row in table[1:])


def test_lfp_quick_reports_sampled_pairs(capsys):
    module = _load("bench_lfp")
    assert module.main(["--quick"]) == 0
    text = capsys.readouterr().out
    assert "(sample)" in text and "extrapolated" in text


def test_agreement_failure_exits_one(capsys, monkeypatch):
    module = _load("bench_product64")
    monkeypatch.setattr(module, "AGREEMENT_TOL", -1.0)  # every comparison now "fails"
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
    assert len(tables) == 6  # per level: methods, bootstrap subset, scenarios
    assert [row[0] for row in tables[0][1:]] == ["clopper-pearson", "multinomial", "bayes"]
    assert output.read_text(encoding="utf-8") == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]


def test_scale_quick_run_exits_zero_with_tables(capsys, tmp_path):
    """bench_scale --quick: five tables, each with the agreement column within tolerance, every step run."""
    module = _load("bench_scale")
    output, plot = tmp_path / "report.md", tmp_path / "curves.svg"
    work = tmp_path / "work"
    work.mkdir()
    assert module.main(["--quick", "--output", str(output), "--plot", str(plot), "--workdir", str(work)]) == 0
    text = capsys.readouterr().out
    for header in (
        "| step | median time | repeats | peak memory |",
        "| route | median time | repeats | peak RSS |",
        "| step | contexts | median time |",
        "| records | Parquet file | median time |",
        "| contexts | table | build Law |",
    ):
        assert header in text
    tables = _tables(text)
    assert len(tables) == 5
    for table in tables:
        _check_agreement(table, module.AGREEMENT_TOL)
        assert all(row[-1] != "—" for row in table[1:] if "did not run" not in " ".join(row))
    assert "did not run" not in text and "skipped:" not in text  # quick sizes always fit
    assert "same context and groups" in text  # pandas found the same maximiser
    assert [row[0] for row in tables[3][1:]] == ["10^3", "10^4"]  # the records curve
    assert [row[0] for row in tables[4][1:]] == ["100", "10^3", "10^4"]
    assert "slope" in text and "Every agreement is within tolerance." in text
    assert output.read_text(encoding="utf-8") == text
    assert plot.read_text(encoding="utf-8").lstrip().startswith("<?xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["curves.svg", "report.md", "work"]
    assert list(work.iterdir()) == []  # the Parquet files are deleted


def test_scale_guard_reports_failure_and_timeout():
    """A step that raises, runs out of its address space or its time is reported as an error dict, not raised."""
    module = _load("bench_scale")
    assert module.run_guarded(lambda: {"ok": 1}, timeout=30) == {"ok": 1}
    failed = module.run_guarded(lambda: 1 / 0, timeout=30)
    assert failed["error"].startswith("failed (ZeroDivisionError")
    huge = module.run_guarded(lambda: {"n": module.np.eye(10**6).shape}, timeout=30)  # 8 TB
    assert huge["error"].startswith("needs more memory than available (MemoryError")
    slow = module.run_guarded(lambda: module.time.sleep(30), timeout=0.5)
    assert slow == {"error": "stopped at the time limit of 0.5 s"}


def test_scale_pandas_route_matches_hand_count():
    """The pandas baseline on a 2-context law computed by hand: E[g | x, a] = P(u = 1 | x, a)."""
    module = _load("bench_scale")
    import numpy as np
    import pandas as pd

    q = np.full((2, 8, 4), 0.25)
    q[1, 3] = [0.1, 0.6, 0.2, 0.1]  # context 1, group 3: E = 0.6 against 0.25 elsewhere
    q[1, 5] = [0.7, 0.1, 0.1, 0.1]  # context 1, group 5: E = 0.1
    idx = pd.MultiIndex.from_product([np.arange(2), np.arange(8)], names=["context", "group"])
    r = module.pandas_route(
        module._long_frame(q), pd.Series([0.0, 1.0, 0.0, 0.0]), pd.Series(np.full(16, 1 / 16), index=idx)
    )
    assert (r["context"], r["group"], r["other_group"]) == (1, 3, 5)
    assert r["local"] == pytest.approx(np.log(6.0))
    # E[g | a] = mean over the two contexts: group 3 (0.25 + 0.6) / 2, group 5 (0.25 + 0.1) / 2
    assert (r["global_group"], r["global_other_group"]) == (3, 5)
    assert r["global"] == pytest.approx(np.log(0.85 / 0.35))


def test_scale_command_rss_is_the_commands_own():
    """The peak RSS of a command is its own, not the benchmark's: 400 MB held here do not show in it."""
    module = _load("bench_scale")
    import sys

    import numpy as np

    held = np.ones(50_000_000)  # 400 MB resident in this process
    small = module.run_command([sys.executable, "-c", "pass"], timeout=60)
    big = module.run_command([sys.executable, "-c", "import numpy; a = numpy.ones(40_000_000)"], timeout=60)
    assert small["returncode"] == 0 and big["returncode"] == 0
    assert small["rss"] < 100e6 < 320e6 < big["rss"] < 400e6 + 100e6  # a bare interpreter; 320 MB of ones
    failed = module.run_command([sys.executable, "-c", "import sys; sys.exit('no such column')"], timeout=60)
    assert failed["returncode"] == 1 and "no such column" in failed["stderr"]
    del held


@pytest.mark.local_model
def test_local_model_quick_run_exits_zero_with_tables(capsys, tmp_path):
    """bench_local_model --quick: SmolLM2 exact and through a real server, package-delivery, N = 3, one repetition."""
    from _model import need_local_model

    need_local_model("fastapi", "uvicorn")  # skips, or fails under FAIRAUDIT_REQUIRE_LOCAL_MODEL=1
    module = _load("bench_local_model")
    output = tmp_path / "report.md"
    assert module.main(["--quick", "--output", str(output)]) == 0
    text = capsys.readouterr().out
    for header in (
        "| task | route | cells | samples per cell | forward passes / queries | time |",
        "| task | cells × decisions | α per entry | max half-width in this run |",
        "| task | rep | samples per cell | entries covered (per-cell 95%) |",
        "| task | rep | ε (nats) | metric | exact | sampled estimate |",
    ):
        assert header in text
    tables = _tables(text)
    assert len(tables) == 4
    assert [row[1] for row in tables[0][1:]] == ["exact", "sampled, rep 1"]
    assert {row[0] for table in tables for row in table[1:]} == {"package-delivery", "**package-delivery**"}
    agreement = tables[3]
    assert agreement[0][-1] == "agreement"
    assert [row[3] for row in agreement[1:]] == ["L", "L̄", "L", "L̄"]  # no filter, then the finite ε
    assert all(row[-1] == "inside" for row in agreement[1:])
    assert "Every check passed." in text
    assert output.read_text(encoding="utf-8") == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]


@pytest.mark.local_model
def test_lm_eval_quick_run_exits_zero_with_agreement(capsys, tmp_path):
    """bench_lm_eval --quick: lm-eval's ``loglikelihood`` and fairaudit's on the same model and requests, equal to
    1e-4 nats, with the throughput ratio; without lm_eval or the model it prints that it skipped and exits 0."""
    module = _load("bench_lm_eval")
    output = tmp_path / "report.md"
    assert module.main(["--quick", "--output", str(output)]) == 0
    text = capsys.readouterr().out
    if module.missing_requirements():
        assert text.startswith("bench_lm_eval: skipped: ") and not output.exists()
        if os.environ.get("FAIRAUDIT_REQUIRE_LOCAL_MODEL") == "1":  # (.ci/run installs lm_eval with the model)
            pytest.fail(text.strip())
        pytest.skip(text.strip())
    (table,) = _tables(text)
    assert table[0] == [
        "route",
        "requests",
        "median time",
        "requests/s",
        "throughput ÷ lm-eval batch 1",
        "agreement (max abs. diff, nats)",
    ]
    assert [row[0].split(",")[0] for row in table[1:]] == ["lm-eval `HFLM.loglikelihood`"] * 2 + [
        "fairaudit `loglikelihoods`"
    ] * 2
    assert all(row[1] == "32" for row in table[1:])  # 4 prompts × 8 continuations
    assert table[1][-1] == "—" and all(float(row[-1]) <= module.AGREEMENT_TOL for row in table[2:])
    assert "Every agreement is within tolerance." in text
    assert output.read_text(encoding="utf-8") == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]


@pytest.mark.parametrize(
    "name, header",
    [
        ("bench_groups", "| route | groups k | time | ÷ one pass | peak ÷ matrix | value (nats) | agreement |"),
        ("bench_law", None),
        ("bench_counting", None),
    ],
)
def test_issue22_quick_runs_exit_zero_with_agreement(name, header, capsys, tmp_path):
    """The benchmarks of issue 22: --quick exits 0, prints tables whose agreement column is within tolerance."""
    module = _load(name)
    output = tmp_path / "report.md"
    assert module.main(["--quick", "--output", str(output)]) == 0
    text = capsys.readouterr().out
    if header is not None:
        assert header in text
    if name == "bench_groups":  # part (d): plan at 10^4, 10^6 and 10^9 groups refused in one line naming groups
        assert text.count("| refused: groups: must be a whole number >= 2 and <= 1000 (got 1000") == 3
    tables = _tables(text)
    assert tables
    for table in tables:
        if table[0][-1].startswith("agreement"):
            for row in table[1:]:
                cell = row[-1]
                assert cell in ("", "—") or cell.startswith("—") or float(cell) <= module.AGREEMENT_TOL, row
    assert output.read_text(encoding="utf-8") == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]


def test_startup_quick_run_reports_no_heavy_module_for_help(capsys):
    """bench_startup --quick: every command runs, --help and import fairaudit import no heavy module."""
    module = _load("bench_startup")
    assert module.main(["--quick"]) == 0
    text = capsys.readouterr().out
    rows = {row[0]: row for row in _tables(text)[0][1:]}
    for command in ('python -c "import fairaudit"', "fairaudit --help", "fairaudit certify --help"):
        assert rows[command][4] == "none", rows[command]
    certify = rows["fairaudit certify examples/llm_hiring/gpt35.toml --format json"]
    assert certify[-1] == "0"  # the command's certificate equals the API's
    assert "pandas" not in certify[4] and "cvxpy" not in certify[4] and "scipy.stats" not in certify[4]


def test_limits_runs_every_issue22_script(capsys):
    """bench_limits --quick: the one command runs the four scripts, each exiting 0, and prints their reports."""
    module = _load("bench_limits")
    assert module.main(["--quick"]) == 0
    text = capsys.readouterr().out
    for script in module.SCRIPTS:
        assert f"<!-- {script}: exit 0," in text
    assert text.count("Machine:") >= 5


def test_weights_quick_run_reports_coverage(capsys, tmp_path):
    """bench_weights --quick: per level, the weighted and unweighted rows; the weighted intervals cover the truth."""
    module = _load("bench_weights")
    output = tmp_path / "weights.md"
    assert module.main(["--quick", "--output", str(output)]) == 0
    text = capsys.readouterr().out
    tables = _tables(text)
    assert len(tables) == 2
    for t in tables:
        assert t[0] == ["intervals", "samples", "coverage E[g ∣ a], both groups", "coverage L̄", "simultaneous"]
        weighted, unweighted = t[1], t[2]
        assert weighted[0] == "weighted (Kish n_eff)" and float(weighted[4]) >= 0.85
        assert unweighted[0] == "unweighted" and float(unweighted[2]) < 0.5  # the biased truth is missed
    assert output.read_text(encoding="utf-8") == text


def test_navigation_quick_run_reports_every_stage(capsys, tmp_path):
    """bench_navigation --quick: every stage of the pipeline runs; the streamed maps equal the in-memory ones."""
    pytest.importorskip("networkx")
    pytest.importorskip("PIL")
    module = _load("bench_navigation")
    output = tmp_path / "navigation.md"
    assert module.main(["--quick", "--no-profile", "--output", str(output)]) == 0
    text = capsys.readouterr().out
    rows = {row[0]: row for row in _tables(text)[0][1:]}
    assert rows["maps, in memory (`build_maps(read_area(folder))`)"][-1].endswith("identical")
    assert "equal: True" in rows["equal-distance check"][-1]
    for stage in ("write the area (`write_building`)", "maps, streamed (`build_maps(folder)`)"):
        assert rows[stage][2].endswith("GB"), rows[stage]  # a peak RSS was measured
    assert output.read_text(encoding="utf-8") == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["navigation.md"]


def test_published_aclu_runs_on_a_table_in_their_format(capsys, tmp_path):
    """bench_published_aclu on a two-category table in the ACLU's columns, their bounds computed by hand: every value
    equal (exit 0); one bound moved: it differs (exit 1). Their data is not shipped."""
    module = _load("bench_published_aclu")
    # Female 30/100, Male 48/120 (the comparator, 0.40, flagged), 10 unknown: theirs 30/110/0.4 to 40/110/0.4, and
    # in proportion (m = 10·100/220) 30/(100 + m)/0.4 to (30 + m)/(100 + m)/0.4
    m = 10 * 100 / 220
    head = ("audit_id,selection_or_scoring_rate,protected_char_group,sex,race_ethnicity,number_of_applications,"
            "n_selected_or_n_above_median,result,impact_ratio,comparator_group,impact_ratio_lower_bound,"
            "impact_ratio_upper_bound,impact_ratio_lower_bound2,impact_ratio_upper_bound2")  # fmt: skip
    female = f"a,Selection,sex,Female,Total,100,30,0.30,0.75,FALSE,{30 / 110 / 0.4!r},{40 / 110 / 0.4!r},"
    female += f"{30 / (100 + m) / 0.4!r},{(30 + m) / (100 + m) / 0.4!r}"
    m_male = 10 * 120 / 220
    male = f"a,Selection,sex,Male,Total,120,48,0.40,1,TRUE,{48 / 130 / 0.4!r},{58 / 130 / 0.4!r},"
    male += f"{48 / (120 + m_male) / 0.4!r},{(48 + m_male) / (120 + m_male) / 0.4!r}"
    unknown = "a,Selection,sex,Missing/Unknown,Total,10,NA,NA,NA,NA,NA,NA,NA,NA"
    path = tmp_path / "audits_full.csv"
    path.write_text("\n".join([head, female, male, unknown]) + "\n")
    assert module.main([str(path)]) == 0
    (table,) = _tables(capsys.readouterr().out)
    _check_agreement(table, 1e-15)
    assert ["`impact_ratio_lower_bound`", "2 equal, 0 differ, 0 only theirs, 0 only ours", "0"] in table
    path.write_text("\n".join([head, female.replace("0.75,FALSE,0.6", "0.75,FALSE,0.5"), male, unknown]) + "\n")
    assert module.main([str(path)]) == 1
