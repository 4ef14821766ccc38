"""scripts/golden.py, the before-and-after check of what the docs and examples print: its comparison and its
normalisation (the runs themselves take minutes; the script is run by hand around a restructuring)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

import golden  # noqa: E402


def test_identical_records_compare_equal_and_a_changed_digit_does_not():
    old = {"a.md $ fairaudit x": {"stdout": "L = 0.1234 nats\n", "stderr": "", "status": 0}}
    assert golden.compare(old, old) == []
    new = {"a.md $ fairaudit x": {"stdout": "L = 0.1235 nats\n", "stderr": "", "status": 0}}
    (problem,) = golden.compare(old, new)
    assert problem.startswith("a.md $ fairaudit x [stdout]") and "-L = 0.1234 nats" in problem
    assert "+L = 0.1235 nats" in problem


def test_a_changed_status_and_a_command_of_one_version_are_named():
    old = {"k": {"stdout": "", "stderr": "", "status": 0}, "gone": {"content": "x"}}
    new = {"k": {"stdout": "", "stderr": "", "status": 2}, "added": {"content": "x"}}
    assert golden.compare(old, new) == [
        "only in the new version: added",
        "only in the old version: gone",
        "k [status]: 0 -> 2",
    ]
    assert golden._report(golden.compare(old, new), old, new) == 1
    assert golden._report(golden.compare(old, {**old}), old, old) == 0


def test_run_times_and_the_run_folder_are_normalised(tmp_path):
    folder = tmp_path / "clone"
    text = f"exact kernel of 8 shown cells in 6.9 s; report written to {folder}/runs/r.md\n"
    assert (
        golden._normal(text, folder)
        == "exact kernel of 8 shown cells in <time> s; report written to <run>/clone/runs/r.md\n"
    )
    assert golden._normal("in 6.9 ms", folder) == "in 6.9 ms"


def test_every_example_runs_through_each_command_that_reads_it():
    """Fixed by reading examples/: 3 specs x 6 commands, 4 task files x 1, 3 documented records files x 4 formats."""
    texts = [c.text for c in golden.examples(ROOT).commands]
    assert len(texts) == 3 * 6 + 4 + 3 * 4
    assert "fairaudit worst-case examples/llm_hiring/gpt4.toml --format json" in texts
    assert sum(t.startswith("fairaudit experiment examples/tasks/") for t in texts) == 4


def test_what_a_run_records_of_the_clock_is_normalised_and_nothing_else(tmp_path):
    line = '{"created": "2026-11-23T19:24:57.715Z", "time": "2026-11-23T19:24:57.735Z", "latency": 0.001513, "u": 0.25}'
    assert golden._normal(line, tmp_path) == '{"created": <time>, "time": <time>, "latency": <time>, "u": 0.25}'
    assert golden._normal('"seconds": 3.325, "epsilon": 3.325', tmp_path) == '"seconds": <time>, "epsilon": 3.325'
