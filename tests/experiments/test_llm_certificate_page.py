"""docs/llm-certificate.md's worked example is what SmolLM2 gives now (marker ``local_model``).

The page quotes kernel rows of examples/tasks/loan.toml's exact route under both scorings, under
``<!-- report: examples/tasks/loan.toml SCORING -->``, and numbers in its text; each must be in that run's report.md
(the exact route has no sampling error, so the page cannot drift unnoticed). The observed L, a log-ratio of nearly
equal probabilities, is compared to 1e-3 relative: the model's fp32 arithmetic differs in that digit between machines
and library versions (0.005546 on one CI machine, 0.005549 on another, from the same code).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from _model import need_local_model
from test_local_model import _same_row

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "llm-certificate.md"

# the numbers the page's text states: (as each run's report.md prints them, as the page writes them)
STATED = {
    "continuation": [
        ("L = 0.00545 nats", "0.00545 nats under continuation"),
        ("L in [0, 1.385]", "[0, 1.385] under continuation"),
        ("| 0.8109 | 0.8109 | 0.6, 0.6 | 0.8109 |", "L ≤ 0.8109 nats"),
        ("| 2.773 | 2.773 | 0.8, 0.8 | 2.773 |", "L ≤ 2.773"),
        ("| 0.05 | L | 0.1195 | ∞ | 1.385 **not met** | 0.05 |", "ε ≤ 0.1195 nats under continuation"),
    ],
    "first-token": [
        ("L = 0.005546 nats", "0.005546 nats under first-token"),
        ("L in [0, 1.423]", "[0, 1.423] under first-token"),
        ("| 0.05 | L | 0.1161 | ∞ | 1.423 **not met** | 0.05 |", "≤ 0.1161 under first-token"),
        ("| 0.8109 | 0.8109 | 0.6, 0.6 | 0.8109 |", "L ≤ 0.8109 nats"),
    ],
}


def _quoted(page: str) -> dict[str, list[str]]:
    quoted: dict[str, list[str]] = {}
    for block in page.split("<!-- report: examples/tasks/loan.toml ")[1:]:
        scoring, _, rest = block.partition(" -->\n")
        quoted[scoring] = [line for line in rest.split("\n\n")[0].splitlines() if line.startswith("|")]
    return quoted


@pytest.mark.local_model
@pytest.mark.parametrize("scoring", ["continuation", "first-token"])
def test_the_worked_example_is_what_the_model_gives(scoring, tmp_path):
    need_local_model()
    from fairaudit.experiments.run import ModelSource, RunOptions, run_experiment

    page = PAGE.read_text()
    quoted = _quoted(page)
    assert sorted(quoted) == ["continuation", "first-token"] and all(len(rows) >= 3 for rows in quoted.values())
    run = run_experiment(
        str(ROOT / "examples" / "tasks" / "loan.toml"),
        tmp_path / "run",
        ModelSource(local_model="smollm2", scoring=scoring),
        RunOptions(),
    )
    report = (run.out / "report.md").read_text()
    lines = [line for line in report.splitlines() if line.startswith("|")]
    missing = [row for row in quoted[scoring] if not any(_same_row(row, line) for line in lines)]
    assert not missing, f"rows of docs/llm-certificate.md not in the {scoring} report: {missing}"
    for in_report, on_page in STATED[scoring]:
        assert " ".join(on_page.split()) in " ".join(page.split()), on_page
        if in_report.startswith("L = "):  # the observed L, a log-ratio of nearly equal fp32 probabilities: to 1e-3
            stated = float(in_report.split()[2])
            found = re.search(r"^L = (\S+) nats", report, re.M)
            assert found and float(found.group(1)) == pytest.approx(stated, rel=1e-3), (in_report, found)
        else:
            assert in_report in report, (in_report, on_page)


@pytest.mark.slow
def test_the_certificate_names_the_task_file_it_ran(tmp_path):
    """Conventions 3 and 5 recorded: ``run.task_sha256`` (the task file's bytes) and ``run.prompt``, on the sampled route."""
    import hashlib
    import json

    from fairaudit.experiments.run import ModelSource, RunOptions, run_experiment

    path = ROOT / "examples" / "tasks" / "loan.toml"
    run = run_experiment(str(path), tmp_path / "run", ModelSource(), RunOptions(samples=1))
    recorded = json.loads((run.out / "certificate.json").read_text())["run"]
    assert recorded["task_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert recorded["prompt"]["sent"] == "task's own"  # a simulated model reads the task's prompt as written
