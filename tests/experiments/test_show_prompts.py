"""Issue 38, defect 4: ``fairaudit experiment TASK --show-prompts N`` prints the messages of N cells, asks nothing.

Independent routes: the expected text is written out by hand for a small task file; the messages of a cell with
drawn texts are those the run's log records for the same query (the run draws them, the test reads them back);
a stand-in chat server counts the requests (none).
"""

from __future__ import annotations

import json

import pytest
from _chat_server import ChatServer
from _cli import run

TASK = '''
[task]
candidates = 2
population = "all"
[prompt]
system = "Pick for the {{ context }} shift."
user = """1: {{ c1.name }} ({{ c1.age }})
2: {{ c2.name }} ({{ c2.age }})
Answer 1 or 2."""
[context]
name = "shift"
values = ["night", "day"]
[[attribute]]
name = "name"
values = ["A", "B"]
text = { A = "Ann", B = "Bo" }
[[attribute]]
name = "age"
values = [30, 60]
[decision]
options = { "1" = 1, "2" = 2 }
[utility]
values = { chosen = 1.0, "not chosen" = 0.0 }
'''

EXPECTED = """t: the first 3 of 32 shown cells of the table design (contexts in order; within one, the profiles of slots 1 to 2, the last slot fastest), each with the messages the run sends for it; nothing is asked

== cell 1 of 32: table|night|A & 30|A & 30|0
shift: night
candidate 1: name = A (shown as 'Ann'), age = 30
candidate 2: name = A (shown as 'Ann'), age = 30
--- system message ---
Pick for the night shift.
--- user message ---
1: Ann (30)
2: Ann (30)
Answer 1 or 2.
--- end of cell 1 ---

== cell 2 of 32: table|night|A & 30|A & 60|0
shift: night
candidate 1: name = A (shown as 'Ann'), age = 30
candidate 2: name = A (shown as 'Ann'), age = 60
--- system message ---
Pick for the night shift.
--- user message ---
1: Ann (30)
2: Ann (60)
Answer 1 or 2.
--- end of cell 2 ---

== cell 3 of 32: table|night|A & 30|B & 30|0
shift: night
candidate 1: name = A (shown as 'Ann'), age = 30
candidate 2: name = B (shown as 'Bo'), age = 30
--- system message ---
Pick for the night shift.
--- user message ---
1: Ann (30)
2: Bo (30)
Answer 1 or 2.
--- end of cell 3 ---
"""


def test_show_prompts_prints_the_cells_and_their_messages_and_writes_nothing(tmp_path, capsys):
    path = tmp_path / "t.toml"
    path.write_text(TASK)
    out = tmp_path / "run"
    with ChatServer(lambda body: "1") as server:
        code, stdout, err = run(
            capsys, "experiment", path, "--show-prompts", "3", "--endpoint", server.url, "--model", "m", "--out", out
        )
        asked = server.n_chat
    assert (code, err) == (0, "")
    assert stdout == EXPECTED
    assert asked == 0 and not out.exists()
    assert list(tmp_path.iterdir()) == [path]


def test_show_prompts_needs_no_model_nor_out(tmp_path, capsys):
    path = tmp_path / "t.toml"
    path.write_text(TASK)
    code, stdout, err = run(capsys, "experiment", path, "--show-prompts", "1")
    assert (code, err) == (0, "")
    assert stdout == EXPECTED[: EXPECTED.index("\n== cell 2")].replace("first 3 of", "first 1 of")


def test_more_cells_than_the_table_has_prints_them_all(tmp_path, capsys):
    path = tmp_path / "t.toml"
    path.write_text(TASK.replace('values = ["night", "day"]', 'values = ["night"]'))
    code, stdout, _ = run(capsys, "experiment", path, "--show-prompts", "100")
    assert code == 0
    assert stdout.startswith("t: the first 16 of 16 shown cells") and stdout.count("--- end of cell") == 16
    assert stdout.endswith("--- end of cell 16 ---\n")


def test_a_count_below_1_and_a_missing_out_are_errors_naming_the_flag(tmp_path, capsys):
    path = tmp_path / "t.toml"
    path.write_text(TASK)
    for n in ("0", "-2", "x"):
        with pytest.raises(SystemExit) as exc:
            run(capsys, "experiment", path, "--show-prompts", n)
        out, err = capsys.readouterr()
        assert exc.value.code == 2 and out == ""
        assert f"argument --show-prompts: expected a whole number >= 1, got '{n}'" in err
    code, _, err = run(capsys, "experiment", path, "--samples", "1")
    assert code == 2
    assert (
        err == "fairaudit: error: --out: is required: the folder of the run (or print prompts only: --show-prompts N)\n"
    )


NAMED = TASK.replace('text = { A = "Ann", B = "Bo" }', 'text = { A = ["Ann", "Amy", "Ada"], B = ["Bo", "Ben"] }')


@pytest.mark.slow
def test_drawn_texts_are_those_the_run_sends(tmp_path, capsys):
    path = tmp_path / "t.toml"
    path.write_text(NAMED)
    code, stdout, _ = run(capsys, "experiment", path, "--show-prompts", "32", "--seed", "3")
    assert code == 0
    code, _, err = run(
        capsys, "experiment", path, "--simulated", "fair", "--samples", "1", "--keep", "0.7", "--seed", "3",
        "--out", tmp_path / "run", "--no-progress",
    )  # fmt: skip
    assert code == 0, err
    logged = {}
    for line in (tmp_path / "run" / "queries.jsonl").read_text().splitlines()[1:]:
        r = json.loads(line)
        logged[r["id"]] = r["messages"]
    cells = stdout.split("\n== cell ")[1:]
    assert len(cells) == 32 == len(logged)
    for cell in cells:
        key = cell.split("\n", 1)[0].split(": ", 1)[1]
        system = cell.split("--- system message ---\n", 1)[1].split("\n--- user message ---\n", 1)[0]
        user = cell.split("\n--- user message ---\n", 1)[1].split("\n--- end of cell", 1)[0]
        assert logged[key] == [{"role": "system", "content": system}, {"role": "user", "content": user}]
    # two candidates who share a name are shown two of its texts, as the run shows them
    first = cells[0].split("\n")
    assert first[2].startswith("candidate 1: name = A (shown as '") and first[2] != first[3].replace("2", "1", 1)


def test_the_exact_route_shows_its_own_prompt(capsys):
    code, own, _ = run(capsys, "experiment", "hr-delivery", "--show-prompts", "1")
    assert code == 0
    assert own.count('"HR2": "1.0",') == 1 and "--- then 2 route images" in own
    code, exact, _ = run(
        capsys, "experiment", "hr-delivery", "--show-prompts", "1", "--endpoint", "http://127.0.0.1:9/v1", "--model",
        "m", "--exact",
    )  # fmt: skip
    assert code == 0
    assert "Answer with a single digit: 1 to choose HR1, 2 to choose HR2.\nAnswer:\n--- end of cell 1 ---" in exact
    assert '"HR2": "1.0",' not in exact and "route images" not in exact
    code, plain, _ = run(capsys, "experiment", "hr-delivery", "--show-prompts", "1", "--no-images")
    assert plain == own.replace(
        "--- then 2 route images (route-1.png, ...: made by the run, hashed in its log) ---\n", ""
    )
