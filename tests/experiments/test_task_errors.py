"""A task file's mistakes are one line that names the task file's field and lists what is valid (issue 38).

Each case is a one-place change to a shipped example; the expected field, line and valid names are read off the
file by the test (the attributes' names and values, the template's line of the typo), not from the code.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.taskfile import load_task

ROOT = Path(__file__).resolve().parents[2]
LOAN = (ROOT / "examples" / "tasks" / "loan.toml").read_text()
SHORTLIST = (ROOT / "examples" / "tasks" / "shortlist.toml").read_text()


def _refused(tmp_path, capsys, text):
    """The message of ``load_task`` and of ``fairaudit experiment`` (exit 2, one line, nothing written)."""
    path = tmp_path / "task.toml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_task(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ")
    code, out, stderr = run(capsys, "experiment", path, "--out", tmp_path / "run", "--no-progress")
    assert code == 2 and out == "" and len(stderr.strip().splitlines()) == 1
    assert message in stderr
    assert not (tmp_path / "run").exists()
    return message


def _line_of(template, needle):
    """1-based line of ``template`` holding ``needle``."""
    return next(n for n, line in enumerate(template.splitlines(), start=1) if needle in line)


def test_a_misspelled_field_names_the_field_the_line_and_the_valid_fields(tmp_path, capsys):
    text = LOAN.replace("{{ c1.age }}", "{{ c1.agee }}")
    data = tomllib.loads(text)
    fields = [a["name"] for a in data["attribute"]]
    assert fields == ["name", "age"]
    line = _line_of(data["prompt"]["user"], "c1.agee")
    message = _refused(tmp_path, capsys, text)
    assert f"prompt.user: cannot be rendered: a candidate has no field 'agee' (template line {line})" in message
    assert f"a candidate's fields are {', '.join(fields)}" in message
    assert "the variables are context, candidates, c1," in message
    assert "_Candidate" not in message


def test_a_misspelled_field_on_a_later_line_and_in_a_loop(tmp_path, capsys):
    text = SHORTLIST.replace("{{ c2.department }}", "{% for c in candidates %}{{ c.departement }}{% endfor %}")
    data = tomllib.loads(text)
    line = _line_of(data["prompt"]["user"], "departement")
    assert line == 4
    message = _refused(tmp_path, capsys, text)
    assert f"prompt.user: cannot be rendered: a candidate has no field 'departement' (template line {line})" in message
    assert "the variables are context, candidates, c1, c2, and a candidate's fields are name, department" in message


def test_an_unknown_variable_names_the_variables(tmp_path, capsys):
    message = _refused(tmp_path, capsys, LOAN.replace("{{ c1.age }}", "{{ cc1.age }}"))
    assert "prompt.user: cannot be rendered: 'cc1' is undefined (template line 1)" in message
    assert "the variables are context, candidates, c1, and a candidate's fields are name, age" in message


def test_the_system_prompt_is_named_as_such(tmp_path, capsys):
    message = _refused(tmp_path, capsys, LOAN.replace("one word: yes or no", "one word: {{ answer }}"))
    assert "prompt.system: cannot be rendered: 'answer' is undefined (template line 1)" in message
    assert "the variables are context, candidates, c1" in message


def test_a_template_syntax_error_gives_its_line(tmp_path, capsys):
    text = SHORTLIST.replace("{{ c2.department }}.", "{{ c2.department }.")
    line = _line_of(tomllib.loads(text)["prompt"]["user"], "c2.department }.")
    message = _refused(tmp_path, capsys, text)
    assert re.search(rf"prompt\.user: cannot be rendered: .* \(template line {line}\)", message), message
    assert "the variables are" not in message  # a syntax error is not a name to correct


POPULATION = 'population = [[["Emily", "engineering"], ["Lakisha", "sales"]]]'


def test_a_misspelled_population_value_names_it_its_attribute_and_the_valid_values(tmp_path, capsys):
    text = SHORTLIST.replace(POPULATION, 'population = [[["Emily", "engineering"], ["Lakisha", "sale"]]]')
    department = tomllib.loads(text)["attribute"][1]
    assert department["name"] == "department"
    message = _refused(tmp_path, capsys, text)
    valid = ", ".join(repr(v) for v in department["values"])
    assert (
        f"task.population[0][1]: 'sale' is not a value of the attribute 'department', whose values are {valid} "
        "(got ['Lakisha', 'sale'])"
    ) in message


@pytest.mark.parametrize("values", [["Lakisha"], ["Lakisha", "sales", "remote"]])
def test_a_wrong_number_of_population_values_says_how_many(tmp_path, capsys, values):
    listed = ", ".join(f'"{v}"' for v in values)
    text = SHORTLIST.replace(POPULATION, f'population = [[["Emily", "engineering"], [{listed}]]]')
    n = len(tomllib.loads(text)["attribute"])
    message = _refused(tmp_path, capsys, text)
    assert (
        f"task.population[0][1]: must give {n} values, one of each attribute in order (name, department); "
        f"it gives {len(values)}"
    ) in message


def test_equal_candidates_of_a_combination_say_why(tmp_path, capsys):
    text = SHORTLIST.replace(POPULATION, 'population = [[["Emily", "engineering"], ["Emily", "engineering"]]]')
    message = _refused(tmp_path, capsys, text)
    assert (
        "task.population[0]: the candidates of a combination must differ: candidates 1 and 2 have the same profile "
        "['Emily', 'engineering'], so the prompt sets that group against itself"
    ) in message
    assert 'population = "all"' in message
