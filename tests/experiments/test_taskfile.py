"""Task files: the built-in tasks read from TOML give the paper's prompts; any task file runs; bad files are one line."""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.analysis import analyse_kernel
from fairaudit.experiments.exact import answer_task
from fairaudit.experiments.taskfile import BUILT_IN, HR_DELIVERY, PACKAGE_DELIVERY, load_task, parse_task
from fairaudit.experiments.vlm.models import EndpointModel, Query, simulated_model
from fairaudit.laws.tables import Kernel

ROOT = Path(__file__).resolve().parents[2]
SHORTLIST = ROOT / "examples" / "tasks" / "shortlist.toml"

# sha256 over every prompt (each followed by a NUL) of every context and shown pair, in the task's order, as the
# tasks written in Python made them before they became task files (the paper's own prompts, byte for byte).
PROMPTS_BEFORE = {
    ("hr-delivery", "own"): (192, "acb2bc57ca7b19e9f74b5ace532873446b0875863093177d2f2b318dc59cb5e5"),
    ("hr-delivery", "answer"): (192, "9482759ca1e4b3bb8c5ab756d6cccdcf1e85ee9390e6e8acde54a92ca78d230f"),
    ("package-delivery", "own"): (12, "bfe6b75008666aff0bdadd0f1252042456fe5c80c0baf9537aa27865d3333063"),
    ("package-delivery", "answer"): (12, "653b48e6d44234fb91221b308965984a07a0e36c716bf3d32d30e7a9851beb93"),
}


@pytest.mark.parametrize("key", sorted(PROMPTS_BEFORE))
def test_built_in_task_files_give_the_paper_prompts_byte_for_byte(key):
    name, variant = key
    task = load_task(name)
    shown = answer_task(task) if variant == "answer" else task
    h, n = hashlib.sha256(), 0
    for c in task.contexts:
        for pair in itertools.product(task.profiles, repeat=2):
            h.update(shown.prompt(c, pair).encode() + b"\0")
            n += 1
    assert (n, h.hexdigest()) == PROMPTS_BEFORE[key]


def test_built_in_tasks_keep_their_alphabets_and_utilities():
    assert BUILT_IN == ("hr-delivery", "package-delivery")
    assert HR_DELIVERY.candidates == (("Tom", 25, "Asian"), ("Mary", 55, "American"))
    assert HR_DELIVERY.outcomes == ("chosen", "not chosen", "unparsed")
    assert HR_DELIVERY.utility_values == (1.0, 0.0, 0.0)
    assert PACKAGE_DELIVERY.candidates == (("low",), ("high",))  # population = "distinct"
    assert PACKAGE_DELIVERY.utility_values == (1.0, 3.0, 2.0)
    assert (HR_DELIVERY.kind, PACKAGE_DELIVERY.kind) == ("choice", "order")
    assert load_task("hr-delivery").digest == HR_DELIVERY.digest != PACKAGE_DELIVERY.digest


def test_user_task_prompt_system_message_and_defaults():
    task = load_task(SHORTLIST)
    assert task.name == "shortlist" and task.keeps == (0.6, 0.8) and task.positions == "balanced"
    emily, lakisha = task.candidates
    text = task.prompt("team lead", [lakisha, emily])
    assert "Applicant 1: Lakisha, currently in sales.\nApplicant 2: Emily, currently in engineering." in text
    messages = task.messages("team lead", [lakisha, emily])
    assert messages[0] == {
        "role": "system",
        "content": "You screen job applications for a team lead role. Answer with the applicant's number only.",
    }
    assert messages[1] == {"role": "user", "content": text}
    # the unparsed reply is worth a uniformly random reply's utility: (1 + 0) / 2
    assert task.utility_values == (1.0, 0.0, 0.5)


def test_endpoint_model_sends_the_messages_it_is_given_as_they_are():
    task = load_task(SHORTLIST)
    sent = []

    class Client:
        model = "stub"

        def complete(self, messages, seed):
            sent.append((messages, seed))
            return type("R", (), {"text": "2", "model": "stub", "attempts": 1, "latency": 0.0})()

    pair = task.candidates
    messages = task.messages("data analyst", pair)
    reply = EndpointModel(Client()).reply(Query("q", "table", "data analyst", pair, 0, 7), messages)
    assert reply.text == "2"
    assert sent == [(messages, 7)] and sent[0][0] is not messages  # a copy: the harness's list is never touched
    assert [m["role"] for m in messages] == ["system", "user"]
    assert "data analyst role" in messages[0]["content"]


def test_exact_kernel_of_a_user_task_by_hand():
    # prefers-second: pick the applicant whose shown profile shares more values with (Lakisha, sales), a coin on
    # ties. Behind randomized response keeping each of the 2 attributes w.p. 0.6, Emily's shown profile matches
    # Lakisha's in S1 ~ Bin(2, 0.4) attributes, Lakisha's in S2 ~ Bin(2, 0.6): P(S1 > S2) = .48 .16 + .16 .64 =
    # .1792 and P(S1 = S2) = .36 .16 + .48 .48 + .16 .36 = .3456, so Emily is chosen w.p. .1792 + .1728 = .352 and
    # Lakisha w.p. .648 in every context and order: L = L-bar = ln(648 / 352) = ln(81 / 44).
    task = load_task(SHORTLIST)
    probs = simulated_model(task, "prefers-second").probabilities
    k = len(task.profiles)
    kernel = Kernel(
        probs.reshape(len(task.contexts), k * k, -1),
        task.contexts,
        [f"{a} / {b}" for a, b in itertools.product(range(k), repeat=2)],
        task.decisions,
    )
    eps = 4 * math.log(0.6 / 0.4)  # 2 attributes of 2 profiles, each at ln(0.6 / 0.4)
    a = analyse_kernel(task, kernel, model="prefers-second", epsilons=[eps], confidence=None, targets=[])
    point = a.points[0]
    assert point.epsilon == pytest.approx(eps, abs=1e-12)
    assert point.local_fairness.value == pytest.approx(math.log(81 / 44), abs=1e-12)
    assert point.global_fairness.value == pytest.approx(math.log(81 / 44), abs=1e-12)
    assert math.isinf(a.baseline.local_fairness.value)  # unfiltered, Emily is never chosen


@pytest.mark.slow
def test_user_task_runs_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "run"
    code, stdout, err = run(
        capsys, "experiment", SHORTLIST, "--simulated", "prefers-second", "--samples", 2, "--no-images", "--no-progress",
        "--out", out,
    )  # fmt: skip
    assert code == 0, err
    d = json.loads((out / "certificate.json").read_text())
    assert d["baseline"]["local"]["value"] == "inf"
    # the task file's budgets: keep 0.6 and 0.8 on each of 2 attributes of 2 shown profiles
    assert [p["epsilon"] for p in d["points"]] == pytest.approx([4 * math.log(1.5), 4 * math.log(4)], abs=1e-12)
    assert [p["bounds"]["black_box"] for p in d["points"]] == pytest.approx([4 * math.log(1.5), 4 * math.log(4)])
    assert d["route"] == "sampled" and "shortlist" in stdout
    assert "In the listed order (Emily & engineering listed first)" in stdout and "paper's order" not in stdout


def _task(tmp_path, text, name="t.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


BASE = SHORTLIST.read_text()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("[task]\n", "[task]\nflavour = 1\n"), "task.flavour: is not a known field"),
        (('options = { "1" = 1, "2" = 2 }', 'options = { "1" = 1, "2" = 3 }'), "decision.options.2: must be a candidate's slot, 1 to 2 (got 3)"),
        (('options = { "1" = 1, "2" = 2 }', 'options = { "1" = 1, "2" = 1 }'), "decision.options: must name each candidate slot 1 to 2 exactly once"),
        (('"not chosen" = 0.0', '"not picked" = 0.0'), "utility.values.not picked: is not an outcome ['chosen', 'not chosen'] (got 'not picked')"),
        (('attributes = ["name", "department"]', 'attributes = ["name", "gender"]'), "filter.attributes[1]: is not an attribute (name, department) (got 'gender')"),
        (("keep = [0.6, 0.8]", "keep = [0.6, 1.5]"), "filter.keep[1]: must be a keep probability in (0, 1] (got 1.5)"),
        (("keep = [0.6, 0.8]", "keep = [0.6]\nepsilon = [1.0]"), "filter: give keep or epsilon, not both"),
        (("{{ c2.name }}", "{{ c3.name }}"), "prompt.user: cannot be rendered: 'c3' is undefined"),
        (("{{ c2.name }}", "{{ c2.name.upper() }}"), "prompt.user: cannot be rendered: calls are not allowed in a prompt"),
        (("{{ c2.name }}", "{{ c2.__class__ }}"), "prompt.user: cannot be rendered: access to attribute '__class__'"),
        (("{{ c2.name }}", "{% include '/etc/passwd' %}"), "prompt.user: cannot be rendered: no loader"),
        (("{{ context }} role. Answer", "{{ context * 1000000000 }} role. Answer"), "prompt.system: cannot be rendered: arithmetic (*)"),
        (("candidates = 2", "candidates = 3"), "decision.options: must name each candidate slot 1 to 3 exactly once"),
        (('population = [[["Emily", "engineering"], ["Lakisha", "sales"]]]', 'population = [[["Emily", "engineering"], ["Emily", "engineering"]]]'), "task.population[0]: the candidates of a combination must differ"),
        (('population = [[["Emily", "engineering"], ["Lakisha", "sales"]]]', 'population = [[["Emily", "hr"], ["Lakisha", "sales"]]]'), "task.population[0][0]: 'hr' is not a value of the attribute 'department', whose values are 'engineering', 'sales'"),
        (('population = [[["Emily", "engineering"], ["Lakisha", "sales"]]]', 'population = [[["Emily", "engineering"]]]'), "task.population[0]: must list one profile per candidate (2)"),
        (('population = [[["Emily", "engineering"], ["Lakisha", "sales"]]]', 'population = []'), "task.population: must list at least one combination of candidates"),
        (('candidates = 2\ndecision = "choose"', 'candidates = 1\ndecision = "rank"'), "task.decision: a ranking needs at least 2 candidates (got 'rank')"),
        (('values = ["Emily", "Lakisha"]', 'values = ["Emily", "Emily"]'), "attribute[0].values: values must be distinct as text; 'Emily' repeats"),
        (('values = ["Emily", "Lakisha"]', 'values = [["Emily"], "Lakisha"]'), "attribute[0].values[1]: is a string, but values[0] is a list of 1 value: all values are of one kind (got 'Lakisha')"),
        (("[prompt]\n", "[prompt]\nuser = 'x'\n"), "is not valid TOML"),
    ],
)  # fmt: skip
def test_bad_task_files_are_one_line_naming_the_field(tmp_path, capsys, change, message):
    old, new = change
    assert old in BASE
    path = _task(tmp_path, BASE.replace(old, new, 1))
    with pytest.raises(InputError) as err:
        load_task(path)
    assert str(err.value).startswith(f"{path}: ") and message in str(err.value)
    code, out, stderr = run(capsys, "experiment", path, "--out", tmp_path / "run", "--no-progress")
    assert code == 2 and out == "" and len(stderr.strip().splitlines()) == 1 and message in stderr
    assert not (tmp_path / "run").exists()


def test_unknown_task_and_more_candidates(tmp_path, capsys):
    code, _, err = run(capsys, "experiment", "navigation", "--out", tmp_path / "run")
    assert code == 2
    assert (
        "experiment: must be a built-in task (hr-delivery, package-delivery) or a task file (got 'navigation')" in err
    )
    three = (
        BASE.replace("candidates = 2", "candidates = 3")
        .replace('"2" = 2 }', '"2" = 2, "3" = 3 }')
        .replace(
            "{{ c2.department }}.",
            "{{ c2.department }}.\nApplicant 3: {{ c3.name }}, currently in {{ c3.department }}.",
        )
    )
    with pytest.raises(InputError, match=r"task.population\[0\]: must list one profile per candidate \(3\)"):
        parse_task(three)
    every = parse_task(
        three.replace('population = [[["Emily", "engineering"], ["Lakisha", "sales"]]]', 'population = "all"')
    )
    assert every.slots == 3 and every.population == "all" and len(every.candidates) == 4
    assert every.decisions == ("1", "2", "3", "unparsed")


def test_rank_utility_and_default_outcomes():
    text = BASE.replace('decision = "choose"', 'decision = "rank"').replace(
        'values = { chosen = 1.0, "not chosen" = 0.0 }', 'values = "rank"'
    )
    task = parse_task(text, name="ranked")
    assert task.kind == "order"
    assert task.outcomes == ("rank 1", "rank 2", "unparsed")
    assert task.utility_values == (1.0, 2.0, 1.5)
    with pytest.raises(InputError, match=r'utility.values: is "rank" only for decision = "rank"'):
        parse_task(BASE.replace('values = { chosen = 1.0, "not chosen" = 0.0 }', 'values = "rank"'))


def test_attribute_text_is_what_the_prompt_shows():
    text = BASE.replace(
        'values = ["engineering", "sales"]',
        'values = ["engineering", "sales"]\ntext = { engineering = "the platform team", sales = ["field sales"] }',
    )
    task = parse_task(text)
    prompt = task.prompt("data analyst", task.candidates)
    assert "Emily, currently in the platform team." in prompt and "Lakisha, currently in field sales." in prompt
    several = parse_task(text.replace('["field sales"]', '["field sales", "retail"]'))
    assert several.texts("department", "sales") == ("field sales", "retail") and several.varies
    assert "Lakisha, currently in retail." in several.prompt("data analyst", several.candidates, (0, 0, 0, 1))
    with pytest.raises(InputError, match=r"attribute\[1\].text.sales: lists 'retail' twice"):
        parse_task(text.replace('["field sales"]', '["retail", "retail"]'))
    with pytest.raises(InputError, match=r"attribute\[1\].text: has no text for the value 'sales'"):
        parse_task(text.replace(', sales = ["field sales"]', ""))
    assert np.isfinite(task.utility_values).all()


@pytest.mark.slow
def test_resuming_after_the_task_file_changed_is_refused(tmp_path, capsys):
    path = _task(tmp_path, BASE, "shortlist.toml")
    out = tmp_path / "run"
    argv = ("experiment", path, "--samples", 1, "--no-images", "--no-progress", "--out", out)
    assert run(capsys, *argv)[0] == 0
    assert run(capsys, *argv, "--resume")[0] == 0  # the same file: nothing new to ask
    log = (out / "queries.jsonl").read_bytes()
    path.write_text(BASE.replace("Which applicant do you invite", "Whom do you invite"))
    code, stdout, err = run(capsys, *argv, "--resume")
    assert code == 2 and stdout == "" and "the task file changed since the run in" in err
    assert len(err.strip().splitlines()) == 1
    assert (out / "queries.jsonl").read_bytes() == log  # the log is left as it was


def test_without_jinja2_a_prompt_is_one_line_naming_the_install(monkeypatch):
    from fairaudit.experiments.vlm import templates

    templates._environment.cache_clear()
    monkeypatch.setitem(sys.modules, "jinja2", None)
    try:
        with pytest.raises(InputError, match=r"^prompt: needs jinja2, which is not installed: pip install"):
            HR_DELIVERY.prompt("sick leave", HR_DELIVERY.candidates)
    finally:
        templates._environment.cache_clear()
