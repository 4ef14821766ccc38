"""Issue 38, defect 4: a task's prompts must show every attribute of every candidate, and the context.

A Python-style ``{age}`` in a Jinja2 template is text to Jinja2: the attribute never reaches the prompt, every
profile of a context gets the same prompt, and before this check a full certificate was written. The task file is
now refused at load time, naming the attribute, the slot, the line and the Jinja2 to write.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from _cli import run

from fairaudit import InputError
from fairaudit.experiments import taskfile
from fairaudit.experiments.taskfile import load_task, parse_task

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "fairaudit" / "experiments" / "tasks").glob("*.toml")) + sorted(
    (ROOT / "examples" / "tasks").glob("*.toml")
)

LOAN = '''
[task]
candidates = 1
population = "all"
[prompt]
system = "You review loan applications. Answer yes or no."
user = """Applicant: {{ c1.name }}, aged {{ c1.age }}.
Loan requested: {{ context }}.
Do you approve the loan?"""
[context]
name = "loan"
values = ["10,000 dollars", "50,000 dollars"]
[[attribute]]
name = "name"
values = ["Emily", "Lakisha"]
[[attribute]]
name = "age"
values = ["25-34", "55-64"]
[decision]
options = { yes = "approved", no = "denied" }
[utility]
values = { approved = 1.0, denied = 0.0 }
'''

THREE = '''
[task]
candidates = 3
population = "all"
[prompt]
user = """Role: {{ context }}.
1: {{ c1.name }}, {{ c1.department }}.
2: {{ c2.name }}, {{ c2.department }}.
3: {{ c3.name }}, {{ c3.department }}.
Answer 1, 2 or 3."""
[context]
name = "role"
values = ["analyst", "lead"]
[[attribute]]
name = "name"
values = ["Emily", "Lakisha"]
[[attribute]]
name = "department"
values = ["engineering", "sales"]
[decision]
options = { "1" = 1, "2" = 2, "3" = 3 }
[utility]
values = { chosen = 1.0, "not chosen" = 0.0 }
'''


def _error(text: str) -> str:
    with pytest.raises(InputError) as info:
        parse_task(text, "t.toml")
    return str(info.value)


def test_the_valid_tasks_of_this_file_load():
    assert parse_task(LOAN).slots == 1 and parse_task(THREE).slots == 3


@pytest.mark.parametrize("placeholder", ["{age}", "{ age }", "{c1.age}", "{c1[age]}", "{Age}"])
def test_a_python_style_placeholder_is_refused_with_its_line_and_the_hint(placeholder):
    line = f"Applicant: {{{{ c1.name }}}}, aged {placeholder}."
    message = _error(LOAN.replace("Applicant: {{ c1.name }}, aged {{ c1.age }}.", line))
    assert message == (
        "t.toml: prompt.user: the attribute 'age' of candidate 1 never reaches the prompt: two cells that differ "
        "only in it render the same; the line looks like a Python-style placeholder, which Jinja2 leaves as text: "
        f"write {{{{ c1.age }}}} (got {line!r})"
    )


def test_the_cli_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys):
    path = tmp_path / "loan.toml"
    path.write_text(LOAN.replace("{{ c1.age }}", "{age}"))
    code, out, err = run(capsys, "experiment", path, "--out", tmp_path / "run", "--samples", "1", "--no-progress")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"fairaudit: error: {path}: prompt.user: the attribute 'age'")
    assert "write {{ c1.age }} (got 'Applicant: {{ c1.name }}, aged {age}.')" in err
    assert not (tmp_path / "run").exists()


def test_a_placeholder_in_the_system_message_names_prompt_system():
    text = LOAN.replace(", aged {{ c1.age }}", "").replace("Answer yes or no.", "The applicant is {age} years old.")
    message = _error(text)
    assert message.startswith("t.toml: prompt.system: the attribute 'age' of candidate 1 never reaches the prompt")
    assert message.endswith(
        "write {{ c1.age }} (got 'You review loan applications. The applicant is {age} years old.')"
    )


def test_an_attribute_shown_in_the_system_message_only_reaches_the_prompt():
    text = LOAN.replace(", aged {{ c1.age }}", "").replace("Answer yes or no.", "Age: {{ c1.age }}.")
    assert parse_task(text).prompt("10,000 dollars", [("Emily", "55-64")]).startswith("Applicant: Emily.\n")


def test_an_attribute_of_slot_2_left_out_is_named_with_its_slot():
    message = _error(THREE.replace("2: {{ c2.name }}, {{ c2.department }}.", "2: {{ c2.name }}."))
    assert message == (
        "t.toml: prompt.user: the attribute 'department' of candidate 2 never reaches the prompt: two cells that "
        "differ only in it render the same; show it with {{ c2.department }}"
    )


def test_the_slot_of_a_placeholder_is_found_among_several():
    text = THREE.replace("2: {{ c2.name }}, {{ c2.department }}.", "2: {{ c2.name }}, {c2.department}.")
    message = _error(text.replace("1: {{ c1.name }}, {{ c1.department }}.", "1: {{ c1.name }}, {c1.department}."))
    assert "the attribute 'department' of candidate 1 never reaches the prompt (nor that of candidate 2)" in message
    assert message.endswith("write {{ c1.department }} (got '1: {{ c1.name }}, {c1.department}.')")


def test_every_failure_after_the_first_is_counted_in_the_message():
    text = THREE.replace("{{ c1.name }}, {{ c1.department }}", "{name}, {department}")
    message = _error(text)
    assert "the attribute 'name' of candidate 1 never reaches the prompt (nor 'department' of candidate 1)" in message
    assert message.endswith("write {{ c1.name }} (got '1: {name}, {department}.')")


def test_an_attribute_name_that_is_no_identifier_gets_the_subscript_hint():
    text = THREE.replace('name = "department"', 'name = "complaint rate"').replace(
        "{{ c3.department }}", '{c3["complaint rate"]}'
    )
    text = text.replace("c1.department", 'c1["complaint rate"]').replace("c2.department", 'c2["complaint rate"]')
    message = _error(text)
    assert "the attribute 'complaint rate' of candidate 3 never reaches the prompt" in message
    assert message.endswith("""write {{ c3["complaint rate"] }} (got '3: {{ c3.name }}, {c3["complaint rate"]}.')""")


def test_the_context_must_reach_the_prompt():
    message = _error(THREE.replace("Role: {{ context }}.", "Role: {role}."))
    assert message == (
        "t.toml: prompt.user: the role never reaches the prompt: two cells that differ only in it ('analyst' and "
        "'lead') render the same; the line looks like a Python-style placeholder, which Jinja2 leaves as text: write "
        "{{ context }} (got 'Role: {role}.')"
    )
    plain = _error(THREE.replace("Role: {{ context }}.\n", ""))
    assert plain.endswith("('analyst' and 'lead') render the same; show it with {{ context }}")


def test_one_context_needs_no_context_in_the_prompt():
    assert parse_task(THREE.replace("Role: {{ context }}.\n", "").replace('["analyst", "lead"]', '["analyst"]'))


def test_two_contexts_of_three_rendered_alike_are_named():
    text = THREE.replace('["analyst", "lead"]', '["analyst", "lead", "chief"]').replace(
        "Role: {{ context }}.", 'Role: {% if context == "lead" %}lead{% else %}other{% endif %}.'
    )
    assert "two cells that differ only in it ('analyst' and 'chief') render the same" in _error(text)


def test_an_attribute_shown_in_some_contexts_only_names_a_context_where_it_is_not():
    text = THREE.replace("1: {{ c1.name }},", '1: {% if context == "lead" %}{{ c1.name }}{% endif %},')
    assert _error(text).startswith(
        "t.toml: prompt.user: the attribute 'name' of candidate 1 does not reach the prompt when the role is 'analyst':"
    )


def test_values_whose_texts_are_equal_do_not_reach_the_prompt():
    text = THREE.replace(
        'values = ["engineering", "sales"]',
        'values = ["engineering", "sales"]\ntext = { engineering = "staff", sales = "staff" }',
    )
    assert "the attribute 'department' of candidate 1 never reaches the prompt" in _error(text)
    several = text.replace('sales = "staff"', 'sales = ["field sales", "staff"]')
    assert parse_task(several).texts("department", "sales") == ("field sales", "staff")


NAMED = '''
[task]
candidates = 2
decision = "rank"
population = "distinct"
[prompt]
user = """Rank {{ c1.name }} and {{ c2.name }}."""
[[attribute]]
name = "name"
values = ["A", "B"]
text = { A = ["Ann", "Amy"], B = ["Bo", "Ben"] }
[decision]
named_by = "name"
[utility]
values = "rank"
'''


def test_a_task_whose_reply_names_the_candidates_must_show_each_name():
    assert parse_task(NAMED).named_by == "name"
    message = _error(NAMED.replace("and {{ c2.name }}", "and {name}"))
    assert "the attribute 'name' of candidate 2 never reaches the prompt" in message
    assert message.endswith("write {{ c2.name }} (got 'Rank {{ c1.name }} and {name}.')")


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_task_loads_and_its_prompts_differ_per_profile(path):
    task = load_task(path)
    # the independent route: hash the prompts of one context over every profile of slot 1 (the others fixed at the
    # first profile) and over every context; all distinct
    first = task.profiles[0]
    shown = [(p, *[first] * (task.slots - 1)) for p in task.profiles]
    for context in task.contexts:
        digests = {hashlib.sha256(task.prompt(context, s).encode()).hexdigest() for s in shown}
        assert len(digests) == len(task.profiles)
    cell = (first,) * task.slots
    rendered = {(task.system_prompt(c, cell), task.prompt(c, cell)) for c in task.contexts}
    assert len(rendered) == len(task.contexts)


def test_the_check_renders_a_handful_per_slot_and_attribute_not_the_table(monkeypatch):
    calls = []
    real = taskfile.DeliveryTask._render

    def counting(self, *args, **kwargs):
        calls.append(args[1])
        return real(self, *args, **kwargs)

    monkeypatch.setattr(taskfile.DeliveryTask, "_render", counting)
    task = load_task(ROOT / "examples" / "tasks" / "resume-ranking.toml")
    n_x, k, n_a = len(task.contexts), task.slots, len(task.attributes)
    # two messages per render; one render to check the templates, then per context the first cell and one per
    # (slot, attribute): 2 x (1 + 4 x (1 + 8 x 1)) = 74, where the table has 4 x 8^8 cells
    assert (n_x, k, n_a) == (4, 8, 1)
    assert len(calls) == 2 * (1 + n_x * (1 + k * n_a)) == 74
