"""Replies that name the candidates (``[decision] named_by``): the Bloomberg study's format, "1. Cara Kramer\\n2. ..."."""

from __future__ import annotations

import itertools
import json
import math
import re

import numpy as np
import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.exact import exact_prompts, prompt_replies
from fairaudit.experiments.harness import plan_queries
from fairaudit.experiments.taskfile import parse_task
from fairaudit.experiments.vlm.models import reply_text, simulated_model
from fairaudit.experiments.vlm.parse import parse_reply

NAMED = """
title = "Rank three applicants whose names signal their group"
[task]
candidates = 3
decision = "rank"
positions = "balanced"
population = "distinct"
[prompt]
user = '''Rank the applicants for the {{ context }} role, best first; write their names in order.
{% for c in candidates %}{{ c.group }}
{% endfor %}'''
[context]
name = "job"
values = ["retail"]
[[attribute]]
name = "group"
values = ["A", "B", "C"]
text = { A = ["ANN LEE", "AMY LEE", "ADA LEE"], B = ["BO KIM", "BEA KIM", "BEN KIM"], C = ["CY DAY", "CAL DAY", "CAS DAY"] }
[decision]
name = "rank"
named_by = "group"
[utility]
values = [1.0, 0.0, 0.0]
unparsed = 0.0
"""


def test_an_order_is_read_from_the_first_mention_of_each_name():
    names = ("CARA KRAMER", "PAUL WU", "AKEEM MOSLEY")
    reply = "Ranking the candidates:\n\n1. Paul Wu\n2. Akeem Mosley\n3. Cara Kramer (strong retail experience)"
    assert parse_reply(reply, names, "order", named=True).order == (1, 2, 0)
    again = "1. Paul Wu\n2. Cara Kramer\n3. Akeem Mosley\n\nPaul Wu has the most experience."
    assert parse_reply(again, names, "order", named=True).order == (1, 0, 2)  # first mentions only
    short = parse_reply("1. Paul Wu\n2. Hakeem Mosley\n3. Cara Kramer", names, "order", named=True)
    assert not short.ok and short.error == "names 2 of the 3 candidates"  # AKEEM is not inside HAKEEM
    assert not parse_reply("2, 3, 1", names, "order", named=True).ok  # no bare numbers when replies name people
    assert parse_reply("I would choose Paul Wu.", names, "choice", named=True).choice == 1
    both = parse_reply("Paul Wu or Cara Kramer", names, "choice", named=True)
    assert not both.ok and both.error.startswith("ambiguous: the reply names several candidates")


def test_every_decision_written_with_names_reads_back_as_itself():
    task = parse_task(NAMED, name="named")
    rng = np.random.default_rng(1)
    for q in plan_queries(task, "table", 1, seed=4)[:40]:
        names = task.reply_names(q.profiles, q.texts)
        assert len(set(names)) == 3  # two candidates of one group are shown different names
        for d in range(len(task.orders)):
            text = reply_text(task, d, rng, names)
            parsed = parse_reply(text, names, task.kind, named=True)
            assert parsed.ok and task.orders.index(parsed.order) == d, text


@pytest.mark.slow
def test_a_named_ranking_runs_end_to_end_on_the_simulated_model(tmp_path, capsys):
    path = tmp_path / "named.toml"
    path.write_text(NAMED)
    out = tmp_path / "run"
    code, _, err = run(
        capsys, "experiment", str(path), "--samples", "4", "--keep", "0.8", "--out", out, "--no-progress"
    )
    assert code == 0, err
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["queries"]["unparsed"] == 0 and cert["queries"]["table"] == 27 * 4
    records = [json.loads(line) for line in (out / "queries.jsonl").read_text().splitlines()[1:]]
    shown = records[0]["shown"]
    assert [list(s) for s in shown] == [["group"]] * 3
    assert all(s["group"] in records[0]["reply"].upper() for s in shown)


TWO = (
    NAMED.replace("candidates = 3", "candidates = 2")
    .replace('values = ["A", "B", "C"]', 'values = ["A", "B"]')
    .replace(', C = ["CY DAY", "CAL DAY", "CAS DAY"]', "")
    .replace('"ANN LEE", "AMY LEE", "ADA LEE"', '"ANN LEE", "AMY LEE"')
    .replace('"BO KIM", "BEA KIM", "BEN KIM"', '"BO KIM", "BEA KIM"')
    .replace("values = [1.0, 0.0, 0.0]", "values = [1.0, 0.0]")
)


@pytest.mark.slow
def test_the_exact_route_scores_the_name_of_the_one_ranked_first(tmp_path):
    """Two candidates. A stand-in whose reply is the names in slot order with probability 1/2, reversed 1/4, anything
    else 1/4 (one token per name or separator): the kernel is 1/2, 1/4, 1/4 in every cell, averaged over 12 prompts.
    An order of two decides who comes first, so each decision's reply is that name alone (the reply written out
    begins with it)."""
    task = parse_task(TWO, name="two")
    prompts = exact_prompts(task)
    assert len(prompts) == 2 * 2 + 2 * 4  # A,A and B,B: two orders of two names; A,B and B,A: 2 x 2 names
    names = task.reply_names(prompts[0].profiles, prompts[0].texts)
    assert prompt_replies(task, task.options, prompts[0]) == names and len(set(names)) == 2

    def logprobs(body):
        messages = body["messages"]
        prefix = messages[-1]["content"] if messages[-1]["role"] == "assistant" else ""
        shown = [line for line in messages[-2 if prefix else -1]["content"].splitlines()[1:] if line]
        law = {", ".join(shown): 0.5, ", ".join(reversed(shown)): 0.25}
        mass = sum(q for r, q in law.items() if r.startswith(prefix)) if prefix else 1.0
        nxt: dict[str, float] = {}
        for r, q in law.items():
            if r.startswith(prefix) and len(r) > len(prefix):
                rest = r[len(prefix) :]
                token = ", " if rest.startswith(", ") else rest.split(", ")[0]
                nxt[token] = nxt.get(token, 0.0) + q / mass
        return [(t, math.log(q)) for t, q in nxt.items()] + ([("Sure", math.log(0.25))] if not prefix else [])

    from fairaudit.experiments.options import ModelSource, RunOptions
    from fairaudit.experiments.run import run_experiment

    path = tmp_path / "two.toml"
    path.write_text(TWO)
    with ChatServer(lambda body: "x", logprobs=logprobs) as server:
        done = run_experiment(
            str(path), tmp_path / "r", ModelSource(endpoint=server.url, model="m", exact=True),
            RunOptions(targets=[], keeps=[0.8]), progress=False,
        )  # fmt: skip
    assert done.analysis is not None and done.summary is not None
    assert done.summary.requests == 12  # "" alone: each name is one token
    k = done.analysis.kernel.probabilities[0]  # (shown cell, decision): slot 1 first 1/2, slot 2 first 1/4
    np.testing.assert_allclose(k, np.tile([0.5, 0.25, 0.25], (4, 1)), atol=1e-12)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (('named_by = "group"', 'named_by = "colour"'), "decision.named_by: is not an attribute (group)"),
        (('"ADA LEE"]', '"ADA LEE", "BO KIM"]'), "attribute[0].text.B: 'BO KIM' also names the value 'A'"),
        (('"CY DAY", "CAL DAY", "CAS DAY"', '"CY DAY", "CAL DAY"'), "every value of 'group' needs at least 3 texts"),
        (('named_by = "group"', 'named_by = "group"\noptions = { "1" = 1, "2" = 2, "3" = 3 }'),
         "decision.options: not with named_by"),
    ],
)  # fmt: skip
def test_named_by_is_checked_in_one_line(change, message):
    with pytest.raises(InputError, match=re.escape(message)):
        parse_task(NAMED.replace(*change), name="bad")


def test_the_first_token_twin_refuses_named_replies(tmp_path, capsys):
    path = tmp_path / "named.toml"
    path.write_text(NAMED)
    code, out, err = run(
        capsys, "experiment", str(path), "--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--sampled-twin",
        "--samples", "2", "--out", tmp_path / "r",
    )  # fmt: skip
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--sampled-twin" in err


def test_simulated_named_models_exist():
    task = parse_task(NAMED, name="named")
    assert simulated_model(task, "prefers-first").probabilities.shape == (1, 3, 3, 3, 7)
    assert list(itertools.islice(task.text_choices((("A",), ("A",), ("B",))), 2)) == [(0, 1, 0), (0, 1, 1)]
