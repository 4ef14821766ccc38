"""The exact route of a ranking (k = 3) over HTTP, its sampled twin, and candidates shown by one of several texts.

The stand-in server (tests/_chat_server.py) answers as a known kernel K over the orders of examples/tasks/ranking.toml:
a cell's reply is the order o written out ("2, 3, 1") with probability K[o], else "Sure, ..." (unparsed). Its
next-token law after any prefix of the reply is K's conditional law, one character per token, so the chain rule over
the prefixes must give K back to rounding, and the sampled twin's bands must cover it.
"""

from __future__ import annotations

import itertools
import json
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit.experiments.exact import exact_prompts, ranking_replies
from fairaudit.experiments.harness import QueryLog, plan_queries, run_queries
from fairaudit.experiments.kernel import table_kernel
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.run import run_experiment
from fairaudit.experiments.taskfile import load_task, parse_task
from fairaudit.experiments.vlm.logprobs import reply_bounds
from fairaudit.experiments.vlm.models import ModelReply, SimulatedModel, simulated_model
from fairaudit.experiments.vlm.parse import parse_reply

RANKING = Path(__file__).resolve().parents[2] / "examples" / "tasks" / "ranking.toml"
ln = math.log


def _known_kernel(task):
    """K: prefers-first mixed 0.7 : 0.3 with the uniform order, times 1 - u; u = 0.1 and 0.25 by context."""
    p = simulated_model(task, "prefers-first").probabilities
    out = np.empty_like(p)
    u = np.array([0.1, 0.25][: len(task.contexts)]).reshape(-1, *([1] * task.slots))
    out[..., :-1] = (1 - u)[..., None] * (0.7 * p[..., :-1] + 0.3 / len(task.orders))
    out[..., -1] = u
    return out


def _cells(task):
    """The user prompt of each shown cell -> its (context, slot 1, ..., slot k) indices."""
    n = range(len(task.profiles))
    return {
        task.prompt(c, tuple(task.profiles[i] for i in slots)): (x, *slots)
        for x, c in enumerate(task.contexts)
        for slots in itertools.product(n, repeat=task.slots)
    }


def _stand_in(task, kernel):
    """(responder, logprobs) of a server whose replies follow ``kernel``: the order written out, or "Sure, ..."."""
    cells = _cells(task)
    replies = ranking_replies(task, task.options)

    def split(body):
        messages = body["messages"]
        if messages[-1]["role"] == "assistant":
            return cells[messages[-2]["content"]], messages[-1]["content"]
        return cells[messages[-1]["content"]], ""

    def logprobs(body):
        cell, prefix = split(body)
        law = {r: kernel[cell][j] for j, r in enumerate(replies)}
        mass = sum(q for r, q in law.items() if r.startswith(prefix)) if prefix else 1.0
        nxt: dict[str, float] = {}
        for r, q in law.items():
            if r.startswith(prefix) and len(r) > len(prefix):
                nxt[r[len(prefix)]] = nxt.get(r[len(prefix)], 0.0) + q / mass
        top = [(t, ln(q)) for t, q in nxt.items()]
        if not prefix:
            top.append(("Sure", ln(kernel[cell][-1])))
        return top

    def responder(body):
        cell, _ = split(body)
        rng = np.random.default_rng(body.get("seed") or 0)
        j = rng.choice(len(task.decisions), p=kernel[cell])
        return "Sure, here is my ranking." if j == len(replies) else replies[j]

    return responder, logprobs


def test_the_chain_rule_is_the_product_of_the_conditionals_in_fractions():
    """Three orders, law 1/2, 1/3, 1/12 (1/12 unparsed): each prefix's conditional law, multiplied back, in Fractions."""
    law = {"1, 2, 3": Fraction(1, 2), "1, 3, 2": Fraction(1, 3), "2, 1, 3": Fraction(1, 12)}

    def conditional(prefix):
        mass = sum(q for r, q in law.items() if r.startswith(prefix)) if prefix else Fraction(1)
        nxt: dict[str, Fraction] = {}
        for r, q in law.items():
            if r.startswith(prefix) and len(r) > len(prefix):
                nxt[r[len(prefix)]] = nxt.get(r[len(prefix)], Fraction(0)) + q / mass
        return [(t, ln(q)) for t, q in nxt.items()]

    asked = []
    got = reply_bounds(lambda p: asked.append(p) or conditional(p), [*law, "3, 2, 1"])[0]
    np.testing.assert_allclose(got, [0.5, 1 / 3, 1 / 12, 0.0], rtol=1e-13, atol=0)
    assert len(asked) == len(set(asked)) == 1 + 2 * 3 + 3 * 3  # every prefix asked once; "3" is never listed


@pytest.mark.slow
def test_a_ranking_over_http_gives_the_known_kernel_one_request_per_prefix(tmp_path, capsys):
    task = load_task(RANKING)
    kernel = _known_kernel(task)
    responder, logprobs = _stand_in(task, kernel)
    with ChatServer(responder, logprobs=logprobs) as server:
        code, _, err = run(
            capsys, "experiment", str(RANKING), "--endpoint", server.url, "--model", "m", "--exact",
            "--out", tmp_path / "exact", "--no-progress", "--keep", "0.7",
        )  # fmt: skip
        bodies = server.chat_requests
    assert code == 0, err
    cells = 2 * 3**3
    assert err.startswith(f"exact kernel of {cells} shown cells ({cells * 28} requests) in ")
    assert len(bodies) == cells * (1 + 3 * 3 + 6 * 3)  # "", "2", "2,", "2, ", "2, 3", ... each prefix once per cell
    prefilled = [b for b in bodies if b["messages"][-1]["role"] == "assistant"]
    assert len(prefilled) == cells * 27
    assert all(b["continue_final_message"] is True and b["add_generation_prompt"] is False for b in prefilled)
    assert not any("cache_prompt" in b for b in bodies)  # not a llama-server (no GET /props)
    got = SimulatedModel.from_csv(task, tmp_path / "exact" / "kernel.csv").probabilities
    np.testing.assert_allclose(got, kernel, rtol=0, atol=1e-12)


@pytest.mark.slow
def test_the_sampled_twin_of_a_ranking_reads_the_order_the_reply_begins_with(tmp_path):
    """--sampled-twin on a ranking: replies of up to len("1, 2, 3") tokens, read by their beginning; bands cover K."""
    one_role = tmp_path / "ranking.toml"  # one context: 27 shown cells
    one_role.write_text(RANKING.read_text().replace('"software engineer", "HR specialist"', '"software engineer"'))
    task = load_task(one_role)
    kernel = _known_kernel(task)
    responder, logprobs = _stand_in(task, kernel)
    common = {"keeps": [0.7], "seed": 3, "targets": []}  # no targets: the budgets per target are not checked here
    with ChatServer(responder, logprobs=logprobs) as server:
        run_experiment(
            str(one_role), tmp_path / "twin", ModelSource(endpoint=server.url, model="m", sampled_twin=True),
            RunOptions(samples=40, concurrency=8, **common), progress=False,
        )  # fmt: skip
        bodies = server.chat_requests
        run_experiment(
            str(one_role), tmp_path / "exact", ModelSource(endpoint=server.url, model="m", exact=True),
            RunOptions(**common), progress=False,
        )  # fmt: skip
    assert {b["max_tokens"] for b in bodies[:5]} == {len("1, 2, 3")}
    records = [json.loads(line) for line in (tmp_path / "twin" / "queries.jsonl").read_text().splitlines()[1:]]
    unparsed = [r for r in records if r.get("decision") == "unparsed"]
    assert unparsed and all(r["parse_error"] == "begins with no order written out" for r in unparsed)
    exact = json.loads((tmp_path / "exact" / "certificate.json").read_text())
    twin = json.loads((tmp_path / "twin" / "certificate.json").read_text())
    for kind in ("local", "global"):
        lo, hi = twin["baseline"][kind]["interval"]
        assert lo <= exact["baseline"][kind]["value"] <= hi


def test_a_listed_order_parses_and_anything_else_in_the_text_does_not():
    assert parse_reply("2, 3, 1", ("1", "2", "3"), "order").order == (1, 2, 0)
    assert parse_reply("3 > 1 > 2", ("1", "2", "3"), "order").order == (2, 0, 1)
    for text in ("2, 3", "2, 2, 1", "Applicant 2, 3, 1", "12, 3"):
        assert not parse_reply(text, ("1", "2", "3"), "order").ok, text


# --- several texts per value ----------------------------------------------------------------------------------

NAMES = """
[task]
candidates = 1
decision = "choose"
population = "all"
[prompt]
user = "Applicant: {{ c1.name }}. Approve? Answer yes or no."
[[attribute]]
name = "name"
values = ["A", "B"]
text = { A = ["Ann", "Amy"], B = ["Bo"] }
[decision]
options = { yes = "approved", no = "denied" }
[utility]
values = { approved = 1.0, denied = 0.0 }
"""
P_YES = {"Ann": 0.9, "Amy": 0.5, "Bo": 0.2}  # the stand-in's P(yes) by the name it is shown


def _name(body):
    return body["messages"][-1]["content"].split(": ", 1)[1].split(".", 1)[0]


@pytest.mark.slow
def test_a_value_with_several_names_gets_the_average_over_its_names_on_the_exact_route(tmp_path):
    task = parse_task(NAMES, name="names")
    prompts = exact_prompts(task)
    assert [(p.profiles, p.texts, p.weight) for p in prompts] == [((("A",),), (0,), 0.5), ((("A",),), (1,), 0.5),
                                                                ((("B",),), (0,), 1.0)]  # fmt: skip
    path = tmp_path / "names.toml"
    path.write_text(NAMES)

    def logprobs(body):
        yes = P_YES[_name(body)]
        return [("yes", ln(0.9 * yes)), ("no", ln(0.9 * (1 - yes))), ("Well", ln(0.1))]

    props = {"default_generation_settings": {}, "build_info": "stand-in"}
    with ChatServer(lambda body: "yes", logprobs=logprobs, props=props) as server:
        done = run_experiment(
            str(path), tmp_path / "r", ModelSource(endpoint=server.url, model="m", exact=True),
            RunOptions(targets=[], keeps=[0.8]), progress=False,
        )  # fmt: skip
        bodies = server.chat_requests
    assert sorted(_name(b) for b in bodies) == ["Amy", "Ann", "Bo"]
    assert all(b["cache_prompt"] is False for b in bodies)  # a llama-server: no reuse of a cached prompt
    assert done.analysis is not None
    k = done.analysis.kernel.probabilities[0]  # (shown value, decision)
    np.testing.assert_allclose(k, [[0.9 * 0.7, 0.9 * 0.3, 0.1], [0.9 * 0.2, 0.9 * 0.8, 0.1]], atol=1e-12)


@pytest.mark.slow
def test_the_sampled_route_draws_one_name_per_query_and_logs_it(tmp_path):
    task = parse_task(NAMES, name="names")
    queries = plan_queries(task, "table", 2000, seed=5)
    drawn = [task.shown_names(q.profiles, q.texts)[0]["name"] for q in queries if q.profiles == (("A",),)]
    assert set(drawn) == {"Ann", "Amy"} and abs(drawn.count("Ann") / len(drawn) - 0.5) < 4 * 0.5 / math.sqrt(2000)

    class ByName:
        name = "by-name"

        def reply(self, query, messages):
            rng = np.random.default_rng(query.seed)
            prompt = messages[-1]["content"]
            return ModelReply("yes" if rng.random() < P_YES[prompt.split(": ", 1)[1].split(".")[0]] else "no", "m")

    with QueryLog(tmp_path / "q.jsonl", {"task": "names"}) as log:
        summary = run_queries(task, ByName(), queries, log, progress=False)
        records = list(log.records.values())
    assert summary.complete
    assert {r["shown"][0]["name"] for r in records if r["profiles"] == [["A"]]} == {"Ann", "Amy"}
    k = table_kernel(task, records).probabilities[0]
    for shown, p_yes in ((0, 0.7), (1, 0.2)):  # A: (0.9 + 0.5) / 2
        assert abs(k[shown, 0] - p_yes) < 4 * math.sqrt(p_yes * (1 - p_yes) / 2000)


def test_two_candidates_who_share_a_value_are_shown_different_names():
    task = parse_task(
        NAMES.replace("candidates = 1", "candidates = 2")
        .replace("{{ c1.name }}", "{{ c1.name }} and {{ c2.name }}")
        .replace('options = { yes = "approved", no = "denied" }', 'options = { "1" = 1, "2" = 2 }')
        .replace("values = { approved = 1.0, denied = 0.0 }", 'values = { chosen = 1.0, "not chosen" = 0.0 }'),
        name="two",
    )
    both_a = (("A",), ("A",))
    assert list(task.text_choices(both_a)) == [(0, 1), (1, 0)]
    rng = np.random.default_rng(0)
    draws = [task.draw_texts(both_a, rng) for _ in range(400)]
    assert set(draws) == {(0, 1), (1, 0)}
    assert list(task.text_choices((("B",), ("B",)))) == [(0, 0)]  # one name for B: shown twice


def test_the_exact_route_refuses_more_prompts_than_it_can_score():
    many = NAMES.replace('A = ["Ann", "Amy"]', "A = [" + ", ".join(f'"N{i}"' for i in range(500)) + "]")
    task = parse_task(many.replace("candidates = 1", "candidates = 2").replace("{{ c1.name }}", "{{ c1.name }} {{ c2.name }}")
                      .replace('options = { yes = "approved", no = "denied" }', 'options = { "1" = 1, "2" = 2 }')
                      .replace('values = { approved = 1.0, denied = 0.0 }', 'values = { chosen = 1.0, "not chosen" = 0.0 }'),
                      name="many")  # fmt: skip
    with pytest.raises(Exception, match=r"attribute.text: the exact route would score more than 200,000 prompts"):
        exact_prompts(task)


@pytest.mark.parametrize("sizes", [(1, 1), (2, 1), (3, 2), (1, 3)])
@pytest.mark.parametrize("k", [1, 2, 3])
def test_the_count_of_text_choices_is_the_length_of_their_list(sizes, k):
    """text_choice_count's closed form (n!/(n-m)! or n^m per shared value) against the listed choices, every cell."""
    a = ", ".join(f'"a{i}"' for i in range(sizes[0]))
    b = ", ".join(f'"b{i}"' for i in range(sizes[1]))
    user = " ".join(f"{{{{ c{i}.name }}}}" for i in range(1, k + 1))
    text = NAMES.replace('text = { A = ["Ann", "Amy"], B = ["Bo"] }', f"text = {{ A = [{a}], B = [{b}] }}")
    text = text.replace("Applicant: {{ c1.name }}. Approve? Answer yes or no.", user)
    if k > 1:
        slots = ", ".join(f'"{i}" = {i}' for i in range(1, k + 1))
        text = (
            text.replace("candidates = 1", f"candidates = {k}")
            .replace('options = { yes = "approved", no = "denied" }', f"options = {{ {slots} }}")
            .replace("values = { approved = 1.0, denied = 0.0 }", 'values = { chosen = 1.0, "not chosen" = 0.0 }')
        )
    task = parse_task(text, name="count")
    for shown in itertools.product(task.profiles, repeat=k):
        choices = list(task.text_choices(shown))
        assert task.text_choice_count(shown) == len(choices) == len(set(choices)), shown


def test_a_hundred_names_in_eight_slots_are_refused_before_any_is_listed():
    names = ", ".join(f'"N{i}"' for i in range(100))
    slots = ", ".join(f'"{i}" = {i}' for i in range(1, 9))
    text = (
        NAMES.replace("candidates = 1", "candidates = 8")
        .replace('A = ["Ann", "Amy"]', f"A = [{names}]")
        .replace("{{ c1.name }}", " ".join(f"{{{{ c{i}.name }}}}" for i in range(1, 9)))
        .replace('options = { yes = "approved", no = "denied" }', f"options = {{ {slots} }}")
        .replace("values = { approved = 1.0, denied = 0.0 }", 'values = { chosen = 1.0, "not chosen" = 0.0 }')
    )
    task = parse_task(text, name="eight")
    shown = (("A",),) * 8
    assert task.text_choice_count(shown) == math.perm(100, 8)
    with pytest.raises(Exception, match=r"attribute.text: the exact route would score more than 200,000"):
        exact_prompts(task, [("all", *shown)])


@pytest.mark.parametrize("route", [("--local-model", "smollm2"), ("--endpoint", "http://127.0.0.1:9/v1", "--model", "m",
                                   "--exact")], ids=["local", "endpoint"])  # fmt: skip
def test_too_many_prompts_are_refused_before_a_model_loads_or_a_folder_is_made(route, tmp_path, capsys):
    """500 names of A: the first cell (A, A) alone has 500 x 499 = 249,500 choices; no torch, server or folder needed."""
    path = tmp_path / "many.toml"
    path.write_text(NAMES.replace('A = ["Ann", "Amy"]', "A = [" + ", ".join(f'"N{i}"' for i in range(500)) + "]")
                    .replace("candidates = 1", "candidates = 2").replace("{{ c1.name }}", "{{ c1.name }} {{ c2.name }}")
                    .replace('options = { yes = "approved", no = "denied" }', 'options = { "1" = 1, "2" = 2 }')
                    .replace('values = { approved = 1.0, denied = 0.0 }', 'values = { chosen = 1.0, "not chosen" = 0.0 }'))  # fmt: skip
    code, out, err = run(capsys, "experiment", str(path), *route, "--out", tmp_path / "r")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "attribute.text: the exact route would score more than 200,000 prompts" in err and "(got 249500)" in err
    assert not (tmp_path / "r").exists()
