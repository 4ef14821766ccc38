"""Continuation scoring over HTTP: the replies' whole texts scored by the chain rule, on every route a server allows.

The stand-in server (tests/_chat_server.py, a real HTTP server) answers from a known law over multi-token replies:
per shown cell, a tree of tokens (``"Office"`` then ``" A"`` / ``" B"`` / ``" C"``; ``"2"``, ``","``, ``" 3"``, ...;
``"y"`` then ``"es"``) whose leaves' masses are the cell's law, fixed by a hash of the cell's prompt. The kernels it
must give are computed here from those masses (each option's reply is one leaf): by prompt log-probabilities (vLLM),
by top log-probabilities (llama-server: a server that ignores or rejects ``prompt_logprobs``), by the text
completions' echo of the messages rendered in ChatML (a server whose chat completions give no log-probabilities,
or that has none), and, with a list too short for the law's support, the lower bounds computed by hand.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import zlib
from pathlib import Path

import numpy as np
import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.endpoint import endpoint_kernel
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.run import run_experiment
from fairaudit.experiments.taskfile import load_task as load_task_file
from fairaudit.experiments.vlm.client import ChatClient
from fairaudit.experiments.vlm.logprobs import echo_token_logprobs, prompt_token_logprobs, reply_bounds, reply_logprob
from fairaudit.experiments.vlm.messages import CHATML
from fairaudit.experiments.vlm.models import SimulatedModel

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "tasks"


def load_task(path):
    """The task with each option's own text as its only reply: these tests count the requests per reply (the
    variants' sums: test_variants.py)."""
    return dataclasses.replace(load_task_file(path), variant_rule="exact")


OFFICE = """
title = "Which office handles the request"
[task]
candidates = 2
decision = "choose"
population = [[["Emily", "engineering"], ["Lakisha", "sales"]]]
[prompt]
system = "You route requests. Answer with the office only."
user = '''{{ c1.name }} ({{ c1.department }}) and {{ c2.name }} ({{ c2.department }}) ask for a {{ context }} day.
Which office handles it? Answer Office A or Office B.'''
[context]
name = "leave"
values = ["holiday"]
[[attribute]]
name = "name"
values = ["Emily", "Lakisha"]
[[attribute]]
name = "department"
values = ["engineering", "sales"]
[decision]
name = "office"
options = { "Office A" = 1, "Office B" = 2 }
[utility]
values = { chosen = 1.0, "not chosen" = 0.0 }
[filter]
attributes = ["name", "department"]
keep = [0.7]
"""


def _office_task(tmp_path):
    path = tmp_path / "office.toml"
    path.write_text(OFFICE)
    return path


def _one_context(tmp_path, name, old, new):
    path = tmp_path / name
    path.write_text((EXAMPLES / name).read_text().replace(old, new))
    return path


def _u(text, salt):
    """A number in [0, 1) fixed by the text (the cell's prompt)."""
    return (zlib.crc32(f"{salt}|{text}".encode()) % 10_000) / 10_000


def _tree(paths):
    """The next-token law after each prefix of a law over token paths {tokens: mass} (the rest of the mass ends)."""
    mass: dict[str, float] = {}
    for tokens, q in paths.items():
        for i in range(len(tokens) + 1):
            prefix = "".join(tokens[:i])
            mass[prefix] = mass.get(prefix, 0.0) + q
    law: dict[str, list] = {}
    for tokens, q in paths.items():
        for i, token in enumerate(tokens):
            prefix = "".join(tokens[:i])
            step = (token, mass[prefix + token] / (mass[prefix] if prefix else 1.0))
            if step not in law.setdefault(prefix, []):
                law[prefix].append(step)
    return law


def _user(body):
    return next(m["content"] for m in body["messages"] if m["role"] == "user")


def _office_paths(user):
    """A cell's law: Office A, Office B and Office C (not an option), "Sure" and the end of the reply."""
    a, b = 0.2 + 0.5 * _u(user, "a"), 0.05 + 0.2 * _u(user, "b")
    return {("Office", " A"): a, ("Office", " B"): b, ("Office", " C"): 0.05, ("Sure",): 0.1 * (1 - a - b)}


def _ranking_paths(user, task):
    """A cell's law over the orders written out, one token per number and per ", " part, and "Sure"."""
    weights = [1 + 3 * _u(user, "".join(map(str, o))) for o in task.orders]
    total = sum(weights) / 0.9  # 0.9 on the orders
    paths = {}
    for o, w in zip(task.orders, weights):
        text = ", ".join(task.options[i] for i in o)
        paths[tuple(t for part in text.split(", ") for t in (part, ",", " "))[:-2]] = w / total
    paths[("Sure",)] = 0.06  # and 0.04 ends the reply at once
    return paths


def _ranking_tokens(text):
    return tuple(t for part in text.split(", ") for t in (part, ",", " "))[:-2]


def _loan_paths(user):
    """yes in two tokens, no in one; "yeah" is not an option."""
    y = 0.3 + 0.4 * _u(user, "y")
    return {("y", "es"): y, ("no",): 0.8 * (1 - y), ("y", "eah"): 0.1 * (1 - y)}


def _replies(task):
    return [", ".join(task.options[i] for i in o) for o in task.orders] if task.kind == "order" else list(task.options)


def _expected(task, paths_of):
    """The kernel the law gives, cell by cell: each option's reply is one leaf; the rest is unparsed."""
    n = len(task.profiles)
    out = np.zeros((len(task.contexts), *([n] * task.slots), len(task.decisions)))
    replies = _replies(task)
    for x, c in enumerate(task.contexts):
        for slots in itertools.product(range(n), repeat=task.slots):
            paths = {"".join(t): q for t, q in paths_of(task.prompt(c, tuple(task.profiles[i] for i in slots))).items()}
            row = [paths.get(r, 0.0) for r in replies]
            out[(x, *slots)] = [*row, 1 - sum(row)]
    return out


LAWS = {
    "office": (lambda tmp: _office_task(tmp), lambda task: _office_paths),
    "ranking": (
        lambda tmp: _one_context(tmp, "ranking.toml", '"software engineer", "HR specialist"', '"software engineer"'),
        lambda task: lambda user: _ranking_paths(user, task),
    ),
    "loan": (lambda tmp: EXAMPLES / "loan.toml", lambda task: _loan_paths),
}


def _server(task, paths_of, **kwargs):
    return ChatServer(law=lambda body: _tree(paths_of(_user(body))), **kwargs)


# --- the pieces ---------------------------------------------------------------------------------------------------


def test_vllms_prompt_logprobs_are_read_from_the_end():
    """vLLM's shape: null first, {id: {logprob, rank, decoded_token}}, the prompt's token first (or by its id)."""
    reply = {
        "prompt_logprobs": [
            None,
            {"12": {"logprob": -1.5, "rank": 4, "decoded_token": "\n"}},
            {"7": {"logprob": -0.25, "rank": 1, "decoded_token": "Office"}, "9": {"logprob": -2.0, "rank": 2, "decoded_token": "Off"}},
            {"3": {"logprob": -9999.0, "rank": 80, "decoded_token": " B"}, "5": {"logprob": -0.1, "rank": 1, "decoded_token": " A"}},
        ]
    }  # fmt: skip
    tokens = prompt_token_logprobs(reply)
    assert tokens == (("\n", -1.5), ("Office", -0.25), (" B", -9999.0))
    assert reply_logprob(tokens, "Office B") == -9999.25 and math.exp(reply_logprob(tokens, "Office B")) == 0.0
    assert prompt_token_logprobs({**reply, "prompt_token_ids": [1, 12, 9, 5]})[1:] == (("Off", -2.0), (" A", -0.1))
    with pytest.raises(InputError, match=r"^endpoint: the server's token '\\nO'\.\.\. straddles the start of"):
        reply_logprob((("x", -1.0), ("\nOffice", -0.5), (" A", -0.5)), "Office A")
    with pytest.raises(InputError, match="did not continue the assistant's message"):
        reply_logprob((("Office", -0.5), (" A", -0.5), ("<|im_end|>", -0.1)), "Office A")
    for bad in ({"choices": []}, {"prompt_logprobs": [None, {"1": {"logprob": -1.0}}]}, {"prompt_logprobs": [None]}):
        assert prompt_token_logprobs(bad) is None


def test_an_echo_is_read_up_to_the_prompts_end():
    """OpenAI's legacy shape: null first; a generated token after the prompt is dropped, by offset or by length."""
    prompt = "<|im_start|>user\nHi<|im_end|>\nyes"
    tokens = ["<|im_start|>", "user", "\n", "Hi", "<|im_end|>", "\n", "y", "es", " please"]
    values = [None, -1.0, -1.0, -1.0, -1.0, -1.0, -0.25, -0.5, -2.0]
    offsets = [0, 12, 16, 17, 19, 29, 30, 31, 33]
    reply = {"choices": [{"text": prompt + " please", "logprobs": {"tokens": tokens, "token_logprobs": values}}]}
    assert echo_token_logprobs(reply, prompt)[-2:] == (("y", -0.25), ("es", -0.5))  # by length
    reply["choices"][0]["logprobs"]["text_offset"] = offsets
    got = echo_token_logprobs(reply, prompt)
    assert len(got) == 7 and reply_logprob(got, "yes") == -0.75  # by offset
    for bad in ({"choices": [{"text": prompt}]}, {"choices": [{"logprobs": {"tokens": ["a"], "token_logprobs": []}}]}):
        assert echo_token_logprobs(bad, prompt) is None
    reply["choices"][0]["logprobs"]["token_logprobs"] = [None, "x", *values[2:]]
    assert echo_token_logprobs(reply, prompt) is None


def test_a_reply_whose_token_is_not_listed_gets_its_lower_bound_and_the_bound_on_what_it_missed():
    """Hand computed: Office 0.6 then A 0.5, C 0.2, B (0.005) not among the 3 listed; p_min 0.1 at "Office"."""
    law = {"": [("Office", math.log(0.6)), ("Sure", math.log(0.3))],
           "Office": [(" A", math.log(0.5)), (" C", math.log(0.2)), (" D", math.log(0.1))]}  # fmt: skip
    p, missing = reply_bounds(law.__getitem__, ["Office A", "Office B"], listed=3)
    assert p.tolist() == pytest.approx([0.3, 0.0], abs=1e-15) and missing == pytest.approx(0.6 * 0.1, abs=1e-15)
    # a list shorter than asked is not known to be a top list: the bound is the mass outside it, 1 - 0.8
    assert reply_bounds(law.__getitem__, ["Office B"], listed=5)[1] == pytest.approx(0.6 * 0.2, abs=1e-15)
    assert reply_bounds(law.__getitem__, ["Office A"], listed=3)[1] == 0.0


# --- endpoint_kernel: the law to 1e-9 on every route -------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("which", sorted(LAWS))
@pytest.mark.parametrize("mode", ["serve", "ignore", "reject"])
def test_continuation_scoring_gives_the_law_on_every_route(which, mode, tmp_path):
    path, paths_of = LAWS[which]
    task = load_task(path(tmp_path))
    law = paths_of(task)
    with _server(task, law, prompt_logprobs_mode=mode) as server:
        client = ChatClient(server.url, "m", max_tokens=1, top_logprobs=20, max_concurrency=4)
        with client:
            made = endpoint_kernel(task, client)
        bodies = server.chat_requests
    assert made.route == ("prompt-logprobs" if mode == "serve" else "top-logprobs") and made.missing == 0.0
    np.testing.assert_allclose(made.probabilities, _expected(task, law), rtol=0, atol=1e-9)
    cells = len(task.contexts) * len(task.profiles) ** task.slots
    replies = len(_replies(task))
    assert bodies[0]["prompt_logprobs"] == 0 and bodies[0]["messages"][-1]["role"] == "user"  # the probe
    if mode == "serve":  # the probe, then one request per (cell, reply), the reply continued
        assert made.summary.requests == len(bodies) == 1 + cells * replies
        assert all(b["prompt_logprobs"] == 0 and b["continue_final_message"] is True for b in bodies[1:])
    else:  # the top lists after each prefix; a rejected probe is sent again without the field, once
        assert len(bodies) == made.summary.requests
        assert not any("prompt_logprobs" in b for b in bodies[1:])
        asked_first = [ChatServer.reply_so_far(b) for b in bodies].count("")  # the probe, then each cell's "" once
        assert asked_first == cells + (mode == "reject")


def test_the_probe_counts_as_the_first_prompts_first_request_on_the_top_route(tmp_path):
    """A server that ignores prompt_logprobs: no request more than the top route's own (2 per cell: "", "Office")."""
    task = load_task(_office_task(tmp_path))
    with _server(task, _office_paths, prompt_logprobs_mode="ignore") as server:
        with ChatClient(server.url, "m", max_tokens=1, top_logprobs=20) as client:
            made = endpoint_kernel(task, client)
        prefixes = [ChatServer.reply_so_far(b) for b in server.chat_requests]
    assert made.summary.requests == len(prefixes) == 16 * 2  # 16 cells: 4 profiles in each slot
    assert sorted(prefixes) == [""] * 16 + ["Office"] * 16


@pytest.mark.slow
def test_a_list_shorter_than_the_support_gives_the_hand_computed_lower_bounds(tmp_path, capsys):
    """Office 0.6, Sure 0.1 and 22 fillers of 0.01; after "Office": A 0.5, C 0.2, 20 fillers of 0.0125 and B 0.005.

    The 20 listed after "Office" are A, C and 18 fillers: P(Office A) = 0.3 exactly, P(Office B) = 0 (its law 0.003),
    unparsed 0.7; the bound 0.6 * min(0.0125, 1 - 0.925) = 0.0075 is recorded, and 0.003 is below it.
    """
    task_path, out = _office_task(tmp_path), tmp_path / "exact"
    task_path.write_text(OFFICE.replace("[decision]\n", '[decision]\nvariants = "exact"\n'))  # the options' texts only
    paths = {("Office", " A"): 0.3, ("Office", " C"): 0.12, ("Office", " B"): 0.003, ("Sure",): 0.1}
    paths |= {("Office", f" y{i}"): 0.6 * 0.0125 for i in range(20)}
    paths |= {(f"x{i}",): 0.01 for i in range(22)}
    with ChatServer(law=lambda body: _tree(paths), prompt_logprobs_mode="ignore") as server:
        code, _, err = run(
            capsys, "experiment", task_path, "--endpoint", server.url, "--model", "m", "--exact", "--no-progress",
            "--out", out,
        )  # fmt: skip
    assert code == 0, err
    scoring = json.loads((out / "certificate.json").read_text())["run"]["scoring"]
    assert scoring.pop("variants") == {"rule": "exact", "replies": {"Office A": ["Office A"], "Office B": ["Office B"]}}
    assert scoring.pop("coverage")["min"] == pytest.approx(0.3, abs=1e-9)
    assert scoring == {
        "method": "continuation",
        "route": "top-logprobs",
        "missing_bound": pytest.approx(0.0075),
        "rendering": "the server's chat template",
    }
    assert 0.6 * 0.005 <= scoring["missing_bound"]
    got = SimulatedModel.from_csv(load_task(task_path), out / "kernel.csv").probabilities
    assert got.shape == (1, 4, 4, 3)  # 2 names x 2 departments
    np.testing.assert_allclose(got.reshape(-1, 3), [[0.3, 0.0, 0.7]] * 16, rtol=0, atol=1e-12)
    assert "lower bound" in (out / "report.md").read_text()


@pytest.mark.parametrize("which", sorted(LAWS))
@pytest.mark.parametrize("chat", ["no-logprobs", "absent"])
def test_text_completions_echo_gives_the_law_when_chat_gives_no_logprobs(which, chat, tmp_path):
    """Chat completions without log-probabilities (or none at all): the text completions' echo of the ChatML prompt."""
    path, paths_of = LAWS[which]
    task = load_task(path(tmp_path))
    law = paths_of(task)
    with _server(task, law, chat_logprobs=False, chat=chat != "absent") as server:
        with ChatClient(server.url, "m", max_tokens=1, top_logprobs=20, max_concurrency=4) as client:
            made = endpoint_kernel(task, client)
        bodies, echoes = server.chat_requests, server.completion_requests
    assert made.route == "completions-echo" and made.rendering == CHATML and made.missing == 0.0
    np.testing.assert_allclose(made.probabilities, _expected(task, law), rtol=0, atol=1e-9)
    cells = len(task.contexts) * len(task.profiles) ** task.slots
    # the probe (once with prompt_logprobs; no chat: a 404), then one echo per (cell, reply), the probe's reused
    assert len(bodies) == 1 and bodies[0]["prompt_logprobs"] == 0
    assert made.summary.requests == 1 + len(echoes) == 1 + cells * len(_replies(task))
    assert all(e["echo"] is True and e["max_tokens"] == 0 and e["logprobs"] == 1 for e in echoes)
    first = echoes[0]["prompt"]
    system = task.messages(task.contexts[0], (task.profiles[0],) * task.slots)[0]["content"]
    assert first.startswith(f"<|im_start|>system\n{system}<|im_end|>\n<|im_start|>user\n")
    assert first.endswith("<|im_end|>\n<|im_start|>assistant\n" + _replies(task)[0])


@pytest.mark.parametrize(
    "server, error",
    [
        (
            {"completions": False},
            "--endpoint: the server gave no log-probabilities for model 'm': none on chat completions (logprobs, "
            "prompt_logprobs), and its text completions (echo) answered HTTP 404; run with --samples N instead",
        ),
        ({"straddle": True}, "--endpoint: the server's token '\\nO'... straddles the start of the reply"),
    ],
    ids=["no-logprobs-anywhere", "straddling-token"],
)
def test_the_text_completions_route_exits_2_with_one_line(server, error, tmp_path, capsys):
    task_path = _office_task(tmp_path)
    with _server(load_task(task_path), _office_paths, chat_logprobs=False, **server) as stand_in:
        code, _, err = run(
            capsys, "experiment", task_path, "--endpoint", stand_in.url, "--model", "m", "--exact", "--no-progress",
            "--out", tmp_path / "exact",
        )  # fmt: skip
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(f"fairaudit: error: {error}")
    assert sorted(p.name for p in (tmp_path / "exact").iterdir()) in ([], [".fairaudit.lock"])  # no kernel


# --- fairaudit experiment --exact, --scoring first-token, --sampled-twin ----------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("which", sorted(LAWS))
def test_the_command_gives_the_law_and_records_the_route(which, tmp_path, capsys):
    path, paths_of = LAWS[which]
    task_path = path(tmp_path)
    task = load_task(task_path)
    with _server(task, paths_of(task)) as server:
        code, _, err = run(
            capsys, "experiment", task_path, "--endpoint", server.url, "--model", "m", "--exact", "--no-progress",
            "--out", tmp_path / "exact", "--keep", "0.7",
        )  # fmt: skip
    assert code == 0, err
    got = SimulatedModel.from_csv(task, tmp_path / "exact" / "kernel.csv").probabilities
    np.testing.assert_allclose(got, _expected(task, paths_of(task)), rtol=0, atol=1e-9)
    scoring = json.loads((tmp_path / "exact" / "certificate.json").read_text())["run"]["scoring"]
    assert scoring.pop("variants")["rule"] == "case" and 0 <= scoring.pop("coverage")["min"] <= 1
    assert scoring == {
        "method": "continuation",
        "route": "prompt-logprobs",
        "missing_bound": 0.0,
        "rendering": "the server's chat template",
    }
    assert "read from the server's prompt log-probabilities" in (tmp_path / "exact" / "report.md").read_text()


@pytest.mark.slow
def test_the_command_records_the_text_completions_route_and_its_rendering(tmp_path, capsys):
    task_path = _office_task(tmp_path)
    task = load_task(task_path)
    with _server(task, _office_paths, chat_logprobs=False) as server:
        code, _, err = run(
            capsys, "experiment", task_path, "--endpoint", server.url, "--model", "m", "--exact", "--no-progress",
            "--out", tmp_path / "exact",
        )  # fmt: skip
    assert code == 0, err
    got = SimulatedModel.from_csv(task, tmp_path / "exact" / "kernel.csv").probabilities
    np.testing.assert_allclose(got, _expected(task, _office_paths), rtol=0, atol=1e-9)
    scoring = json.loads((tmp_path / "exact" / "certificate.json").read_text())["run"]["scoring"]
    assert scoring.pop("variants")["rule"] == "case" and 0 <= scoring.pop("coverage")["min"] <= 1
    assert scoring == {"method": "continuation", "route": "completions-echo", "missing_bound": 0.0, "rendering": CHATML}
    report = " ".join((tmp_path / "exact" / "report.md").read_text().split())
    assert "text completions echoed for the messages rendered as stated (ChatML: each message as" in report


def test_a_token_that_straddles_the_reply_exits_2_with_one_line(tmp_path, capsys):
    task_path = _office_task(tmp_path)
    with _server(load_task(task_path), _office_paths, straddle=True) as server:
        code, _, err = run(
            capsys, "experiment", task_path, "--endpoint", server.url, "--model", "m", "--exact", "--no-progress",
            "--out", tmp_path / "exact",
        )  # fmt: skip
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("fairaudit: error: --endpoint: the server's token '\\nO'... straddles the start of the reply")
    assert sorted(p.name for p in (tmp_path / "exact").iterdir()) in ([], [".fairaudit.lock"])  # no kernel


def test_first_token_scoring_on_options_that_share_their_first_token_exits_2(tmp_path, capsys):
    task_path = _office_task(tmp_path)
    with _server(load_task(task_path), _office_paths) as server:
        code, _, err = run(
            capsys, "experiment", task_path, "--endpoint", server.url, "--model", "m", "--exact", "--no-progress",
            "--scoring", "first-token", "--out", tmp_path / "exact",
        )  # fmt: skip
    assert code == 2 and err.count("\n") == 1, err
    assert "the first token 'Office' begins the replies of two options (Office A, Office B)" in err


@pytest.mark.slow
@pytest.mark.parametrize("which", ["office", "loan"])
@pytest.mark.parametrize("route", ["prompt-logprobs", "completions-echo"])
def test_the_sampled_twin_agrees_with_the_exact_route_within_its_intervals(which, route, tmp_path):
    """The same law sampled (--sampled-twin --samples N): the exact baselines lie in the twin's 99% intervals."""
    path, paths_of = LAWS[which]
    task_path = path(tmp_path)
    task = load_task(task_path)
    common = {"keeps": [0.7], "seed": 5, "targets": []}
    with _server(task, paths_of(task), chat_logprobs=route == "prompt-logprobs") as server:
        twin = run_experiment(
            str(task_path), tmp_path / "twin", ModelSource(endpoint=server.url, model="m", sampled_twin=True),
            RunOptions(samples=60, concurrency=8, **common), progress=False,
        )  # fmt: skip
        bodies = server.chat_requests
        run_experiment(
            str(task_path), tmp_path / "exact", ModelSource(endpoint=server.url, model="m", exact=True),
            RunOptions(**common), progress=False,
        )  # fmt: skip
    assert twin.summary is not None and twin.summary.failed == 0
    assert {b["max_tokens"] for b in bodies} == {max(len(r) for r in task.options)}
    exact = json.loads((tmp_path / "exact" / "certificate.json").read_text())
    sampled = json.loads((tmp_path / "twin" / "certificate.json").read_text())
    assert exact["run"]["scoring"]["route"] == route and sampled["run"]["sampling"]["scoring"] == "continuation"
    for kind in ("local", "global"):
        lo, hi = sampled["baseline"][kind]["interval"]
        assert lo <= exact["baseline"][kind]["value"] <= hi
    records = [json.loads(line) for line in (tmp_path / "twin" / "queries.jsonl").read_text().splitlines()[1:]]
    shares = np.mean([r.get("decision") == "unparsed" for r in records])
    law = _expected(task, paths_of(task))[..., -1].mean()
    assert abs(shares - law) < 4 * math.sqrt(law * (1 - law) / len(records))  # the unparsed share, sampled
