"""``fairaudit experiment --endpoint URL --model NAME --exact``: the kernel from a server's first-token log-probabilities.

The stand-in model is a known kernel K (numbers below), served by a real chat-completions server on 127.0.0.1
(tests/_chat_server.py) both ways: as first-token log-probabilities (:func:`_first_tokens`: for a cell whose
P(option 1, option 2, unparsed) is (a, b, u), the tokens "1" 0.7a, " 1" 0.3a, " 2" 0.6b, "2" 0.4b, then unparsed
texts, "Sure" 0.25u, the option key's stem ("HR" or "Recipient") 0.05u, a blank " " 0.1u, "\\n" 0.1u and 25
fillers of 0.01u each, of which only the 20 most likely tokens are sent: 0.25u of the mass is never listed) and as
sampled JSON replies drawn from K with the request's seed. So the exact route must give K to rounding, its
certificate must equal :func:`analyse_kernel` on K, and the sampled route's intervals must cover K's values.
Every run here asks for ``--scoring first-token`` (continuation, the default, is tests/experiments/test_continuation_http.py's).
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.analysis import analyse_kernel
from fairaudit.experiments.exact import answer_task, exact_prompt
from fairaudit.experiments.local_model import exact_law
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.run import run_experiment
from fairaudit.experiments.slots import epsilon_from_keep
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY, load_task
from fairaudit.experiments.vlm.client import ChatClient
from fairaudit.experiments.vlm.logprobs import decision_probabilities, first_token_logprobs, shared_first_token
from fairaudit.experiments.vlm.models import Query, SimulatedModel, simulated_model

SHORTLIST = Path(__file__).resolve().parents[2] / "examples" / "tasks" / "shortlist.toml"
TARGETS = [0.05, 0.1, 0.25, 0.5]  # the command's default --target
ln = math.log


def _known_kernel(task, name, unparsed):
    """K: the named simulated model's choices, 0.8 of them kept and 0.2 split evenly, times 1 - u_c; u_c unparsed."""
    p = simulated_model(task, name).probabilities
    assert np.all(p[..., -1] == 0)
    u = np.asarray(unparsed, dtype=float)[:, None, None]
    out = np.empty_like(p)
    out[..., :-1] = (1 - u)[..., None] * (0.8 * p[..., :-1] + 0.1)
    out[..., -1] = u
    return out


def _first_tokens(task, row):
    """The first token's distribution of a cell with P = (a, b, u) (module docstring), as (token, logprob)."""
    a, b, u = row
    top = [("1", ln(0.7 * a)), (" 1", ln(0.3 * a)), (" 2", ln(0.6 * b)), ("2", ln(0.4 * b))]
    stem = task.options[0][:-1] or "Applicant"  # "HR", "Recipient": not a reply to answer_task's prompt
    top += [("Sure", ln(0.25 * u)), (stem, ln(0.05 * u)), (" ", ln(0.1 * u)), ("\n", ln(0.1 * u))]
    return top + [(f"x{i}", ln(0.01 * u)) for i in range(25)]


def _cells(task, shown):
    """The prompt of each shown cell -> its (context, profile 1, profile 2) indices."""
    k = range(len(task.profiles))
    return {
        shown.prompt(c, (task.profiles[i], task.profiles[j])): (x, i, j)
        for x, c in enumerate(task.contexts)
        for i, j in itertools.product(k, k)
    }


def _stand_in(task, kernel):
    """(responder, logprobs) of a server answering as the kernel: sampled JSON replies, first-token log-probabilities.

    Both read the cell from the prompt: the task's own (sampled route) or answer_task's (exact route).
    """
    cells = {**_cells(task, task), **_cells(task, exact_prompt(task)[0])}
    model = SimulatedModel(task, kernel, "stand-in")

    def cell(body):
        return cells[body["messages"][-1]["content"]]

    def responder(body):
        x, i, j = cell(body)
        shown = (task.profiles[i], task.profiles[j])
        return model.reply(Query("", "table", task.contexts[x], shown, 0, body.get("seed") or 0)).text

    return responder, lambda body: _first_tokens(task, kernel[cell(body)])


def _read_kernel(task, folder):
    return SimulatedModel.from_csv(task, folder / "kernel.csv").probabilities


def _files(folder):
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


# --- the log-probabilities of one reply -------------------------------------------------------------------------


def test_one_reply_by_hand():
    """0.6 + 0.3 on the options; 0.05 listed unparsed (a blank token counts as nothing) and 0.05 never listed."""
    top = [
        {"token": "1", "logprob": ln(0.6)},
        {"token": " 2", "logprob": ln(0.3)},
        {"token": "Sure", "logprob": ln(0.03)},
        {"token": " ", "logprob": ln(0.02)},
    ]
    reply = {"choices": [{"message": {"content": "1"}, "logprobs": {"content": [{"token": "1", "top_logprobs": top}]}}]}
    p = decision_probabilities(reply, HR_DELIVERY, answers=("1", "2"))
    assert p.tolist() == pytest.approx([0.6, 0.3, 0.1], abs=1e-15)
    assert first_token_logprobs(top) == first_token_logprobs(reply) == (
        ("1", ln(0.6)), (" 2", ln(0.3)), ("Sure", ln(0.03)), (" ", ln(0.02)),
    )  # fmt: skip
    # an option key reads as its option too (parse_reply); a log-probability rounded above 0 is 0, and options
    # whose mass rounding takes above 1 are scaled back to 1
    p = decision_probabilities([("HR1", 1e-9), ("2", ln(1e-7))], HR_DELIVERY, answers=("1", "2"))
    assert p.tolist() == pytest.approx([1 / (1 + 1e-7), 1e-7 / (1 + 1e-7), 0.0], abs=1e-15) and p[-1] == 0.0
    for bad in ({"choices": [{"message": {"content": "1"}}]}, [], [{"token": "1"}], [("1", 3.0)]):
        assert first_token_logprobs(bad) is None
        with pytest.raises(InputError, match="^reply: has no log-probabilities"):
            decision_probabilities(bad, HR_DELIVERY)
    with pytest.raises(InputError, match="summing to 1.5"):
        decision_probabilities([("1", ln(0.75)), ("2", ln(0.75))], HR_DELIVERY)


def test_a_first_token_shared_by_two_options_is_refused():
    top = [("HR", ln(0.9)), ("1", ln(0.05))]
    assert shared_first_token(top, ("HR1", "HR2")) == "HR"
    assert shared_first_token(top, ("1", "2")) is None  # answer_task's replies: "HR" is simply unparsed
    assert shared_first_token([(" hr", ln(0.5))], ("HR1", "HR2")) == " hr"  # spaces and case aside
    assert shared_first_token([("HR", ln(1e-7))], ("HR1", "HR2")) is None  # below 1e-6: ignored
    assert shared_first_token([("HR1", ln(0.9))], ("HR1", "HR2")) is None  # a whole reply, not a proper prefix
    with pytest.raises(
        InputError, match=r"^exact: the first token 'HR' begins the replies of two options \(HR1, HR2\)"
    ):
        decision_probabilities(top, HR_DELIVERY)
    assert decision_probabilities(top, HR_DELIVERY, answers=("1", "2")).tolist() == pytest.approx([0.05, 0, 0.95])


def test_the_client_asks_for_and_returns_the_top_logprobs():
    with ChatServer(lambda body: "1", logprobs=lambda body: [("x", ln(0.1)), ("1", ln(0.8)), ("2", ln(0.1))]) as s:
        with ChatClient(s.url, "m", max_tokens=1, top_logprobs=2) as client:
            r = client.complete([{"role": "user", "content": "?"}])
        with ChatClient(s.url, "m") as plain:
            assert plain.complete([{"role": "user", "content": "?"}]).top_logprobs is None
        body = s.chat_requests[0]
    assert (body["max_tokens"], body["logprobs"], body["top_logprobs"]) == (1, True, 2)
    assert "logprobs" not in s.chat_requests[1]
    assert r.text == "1" and r.top_logprobs == (("1", ln(0.8)), ("x", ln(0.1)))  # the two most likely, in order
    with pytest.raises(InputError, match="^top_logprobs: "):
        ChatClient("http://127.0.0.1:9/v1", "m", top_logprobs=0)


# --- whole runs -------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_hr_exact_run_equals_analyse_kernel_on_the_known_kernel(tmp_path, capsys):
    task, out = HR_DELIVERY, tmp_path / "exact"
    kernel = _known_kernel(task, "prefers-mary", [0.05, 0.1, 0.15])
    responder, logprobs = _stand_in(task, kernel)
    with ChatServer(responder, logprobs=logprobs) as server:
        code, report, err = run(
            capsys, "experiment", "hr-delivery", "--endpoint", server.url, "--model", "lp-model", "--exact", "--scoring", "first-token",
            "--out", out, "--no-progress", "--keep", "0.7", "0.9", "--concurrency", "3",
        )  # fmt: skip
        bodies = server.chat_requests
    assert code == 0, err
    first, warning = err.splitlines()  # the kernel puts 0.05 to 0.15 of each cell's mass on no option
    assert first.startswith("exact kernel of 192 shown cells (192 requests) in ")
    assert warning.startswith("fairaudit: warning: coverage 0.85") and "is below 0.99" in warning
    # one request per shown cell: one token, the top 20 log-probabilities, answer_task's text-only messages
    shown = answer_task(task)
    expected = [shown.messages(c, (p1, p2)) for c in task.contexts for p1 in task.profiles for p2 in task.profiles]
    assert sorted(map(json.dumps, (b["messages"] for b in bodies))) == sorted(map(json.dumps, expected))
    assert {(b["max_tokens"], b["logprobs"], b["top_logprobs"], b["model"]) for b in bodies} == {
        (1, True, 20, "lp-model")
    }
    assert server.max_in_flight <= 3
    np.testing.assert_allclose(_read_kernel(task, out), kernel, rtol=0, atol=1e-12)
    cert = json.loads((out / "certificate.json").read_text())
    eps = [epsilon_from_keep(task, k) for k in (0.7, 0.9)]
    law = exact_law(task, kernel)
    a = analyse_kernel(task, law, model="lp-model", epsilons=eps, positions=task.positions, targets=TARGETS)
    assert (cert["route"], cert["model"], cert["samples"], a.route) == ("exact", "lp-model", 0, "exact")
    assert cert["run"]["prompt"]["sent"] == "exact route's"  # the digit prompt, not the paper's JSON paragraph
    assert cert["queries"]["unparsed_share"] == pytest.approx(0.1, abs=1e-12)  # the mean of 0.05, 0.1, 0.15
    assert math.isfinite(a.baseline.local_fairness.value) and a.baseline.local_fairness.value > 0.1
    assert cert["baseline"]["local"]["value"] == pytest.approx(a.baseline.local_fairness.value, abs=1e-12)
    assert cert["baseline"]["global"]["value"] == pytest.approx(a.baseline.global_fairness.value, abs=1e-12)
    assert len(cert["points"]) == len(a.points) == 2
    for got, want in zip(cert["points"], a.points):
        assert got["epsilon"] == pytest.approx(want.epsilon, abs=1e-12)
        assert got["observed"]["local"]["value"] == pytest.approx(want.local_fairness.value, abs=1e-12)
        assert got["observed"]["global"]["value"] == pytest.approx(want.global_fairness.value, abs=1e-12)
        assert got["bounds"]["black_box"] == pytest.approx(want.black_box_local, abs=1e-12)
        assert got["observed"]["local"]["interval"] is None  # exact: no sampling error
    assert "probability" in (out / "kernel.csv").read_text().splitlines()[0]
    assert report == (out / "report.md").read_text() and "Exact route" in report
    assert not (out / "queries.jsonl").exists() and not (out / "route-1.png").exists()


@pytest.mark.slow
def test_exact_sampled_and_simulated_routes_agree(tmp_path, capsys):
    """The exact route gives K; 200 sampled replies per cell, over HTTP or in process from its kernel.csv, give
    the same counts (the same seeds draw the same replies) and 0.95 bands that cover K's values."""
    task = PACKAGE_DELIVERY
    kernel = _known_kernel(task, "low-complaint-first", [0.02, 0.05, 0.1])
    responder, logprobs = _stand_in(task, kernel)
    common = ["--no-images", "--no-progress", "--keep", "0.6", "0.8", "--seed", "11"]
    with ChatServer(responder, logprobs=logprobs) as server:
        code, _, err = run(
            capsys, "experiment", "package-delivery", "--endpoint", server.url, "--model", "m", "--exact", "--scoring", "first-token",
            "--out", tmp_path / "exact", *common,
        )  # fmt: skip
        assert code == 0, err
        code, _, err = run(
            capsys, "experiment", "package-delivery", "--endpoint", server.url, "--model", "m", "--samples", "200",
            "--concurrency", "8", "--out", tmp_path / "sampled", *common,
        )  # fmt: skip
        assert code == 0, err
    np.testing.assert_allclose(_read_kernel(task, tmp_path / "exact"), kernel, rtol=0, atol=1e-12)
    code, _, err = run(
        capsys, "experiment", "package-delivery", "--kernel", tmp_path / "exact" / "kernel.csv", "--samples", "200",
        "--out", tmp_path / "simulated", *common,
    )  # fmt: skip
    assert code == 0, err
    assert (tmp_path / "simulated" / "kernel.csv").read_text() == (tmp_path / "sampled" / "kernel.csv").read_text()
    exact = json.loads((tmp_path / "exact" / "certificate.json").read_text())
    sampled = json.loads((tmp_path / "sampled" / "certificate.json").read_text())
    assert (exact["route"], sampled["route"], sampled["queries"]["table"]) == ("exact", "sampled", 2400)
    pairs = [(exact["baseline"], sampled["baseline"])]
    pairs += [(e["observed"], s["observed"]) for e, s in zip(exact["points"], sampled["points"], strict=True)]
    for e, s in pairs:
        for kind in ("local", "global"):
            lo, hi = s[kind]["interval"]
            assert lo <= e[kind]["value"] <= hi, (kind, e[kind]["value"], lo, hi)
            assert abs(s[kind]["value"] - e[kind]["value"]) < 0.2


@pytest.mark.slow
def test_a_task_file_without_an_answer_paragraph_is_sent_as_it_is(tmp_path):
    """shortlist.toml asks for "1 or 2" itself: its own messages (with the system prompt) go out, its kernel back."""
    task = load_task(SHORTLIST)
    assert exact_prompt(task) == (task, ("1", "2"))
    kernel = _known_kernel(task, "prefers-second", [0.1, 0.3])
    responder, logprobs = _stand_in(task, kernel)
    with ChatServer(responder, logprobs=logprobs) as server:
        done = run_experiment(
            str(SHORTLIST), tmp_path / "r", ModelSource(endpoint=server.url, model="m", exact=True, scoring="first-token"),
            RunOptions(targets=[]), progress=False,
        )  # fmt: skip
        bodies = server.chat_requests
    assert done.route == "exact" and done.summary is not None and done.summary.asked == 32
    assert done.analysis is not None and done.analysis.unparsed_share == pytest.approx(0.2, abs=1e-12)
    np.testing.assert_allclose(done.analysis.kernel.probabilities, exact_law(task, kernel).probabilities, atol=1e-12)
    assert bodies[0]["messages"][0]["role"] == "system"
    assert bodies[0]["messages"] in [task.messages(c, pair) for c, pair in _pairs(task)]


def _pairs(task):
    return [(c, (p1, p2)) for c in task.contexts for p1 in task.profiles for p2 in task.profiles]


# --- errors -----------------------------------------------------------------------------------------------------


def test_a_server_without_logprobs_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "o"
    with ChatServer(lambda body: "1") as server:
        code, stdout, err = run(
            capsys, "experiment", "package-delivery", "--endpoint", server.url, "--model", "plain-model", "--exact", "--scoring", "first-token",
            "--out", out, "--no-images", "--no-progress",
        )  # fmt: skip
    assert code == 2 and stdout == "" and err.count("\n") == 1
    assert err.startswith(
        "fairaudit: error: --endpoint: the server returned no log-probabilities for model 'plain-model'"
    )
    assert "run with --samples N instead" in err
    assert _files(out) in ([], [".fairaudit.lock"])


def test_options_that_share_a_first_token_exit_2(tmp_path, capsys):
    """A task file whose replies are "HR1" and "HR2" (its own prompt: no paragraph for answer_task to replace)."""
    text = SHORTLIST.read_text().replace('options = { "1" = 1, "2" = 2 }', "options = { HR1 = 1, HR2 = 2 }")
    path = tmp_path / "keys.toml"
    path.write_text(text.replace("Answer 1 or 2.", "Answer HR1 or HR2."))
    task = load_task(path)
    assert task.options == ("HR1", "HR2") and exact_prompt(task) == (task, ("HR1", "HR2"))
    out = tmp_path / "o"
    with ChatServer(lambda body: "HR", logprobs=lambda body: [("HR", ln(0.97)), ("HR1", ln(0.02))]) as server:
        code, stdout, err = run(
            capsys, "experiment", path, "--endpoint", server.url, "--model", "m", "--exact", "--scoring", "first-token", "--out", out,
            "--no-progress",
        )  # fmt: skip
    assert code == 2 and stdout == "" and err.count("\n") == 1
    assert err.startswith(
        "fairaudit: error: --exact: the first token 'HR' begins the replies of two options (HR1, HR2)"
    )
    assert "run with --samples N instead" in err
    assert _files(out) in ([], [".fairaudit.lock"])


@pytest.mark.slow
def test_a_request_that_fails_after_retries_exits_1_with_nothing_written(tmp_path, capsys):
    task = PACKAGE_DELIVERY
    responder, logprobs = _stand_in(task, _known_kernel(task, "fair", [0.1, 0.1, 0.1]))
    out = tmp_path / "o"
    args = [
        "experiment",
        "package-delivery",
        "--model",
        "m",
        "--exact",
        "--scoring",
        "first-token",
        "--out",
        out,
        "--no-images",
        "--no-progress",
    ]
    with ChatServer(responder, logprobs=logprobs, fault_fn=lambda n, body: ("status", 500) if n == 5 else None) as s:
        code, stdout, err = run(capsys, *args, "--endpoint", s.url, "--max-retries", "0", "--concurrency", "1")
        assert code == 1 and stdout == "" and err.count("\n") == 1
        assert err.startswith("fairaudit: incomplete: 4 of 12 prompts answered before a request failed")
        assert "HTTP 500" in err and "nothing was written" in err
        assert _files(out) == [".fairaudit.lock"]
        code, stdout, err = run(capsys, *args, "--endpoint", s.url)  # again, without the fault: the whole run
    assert code == 0, err
    assert (out / "report.md").read_text() == stdout


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--exact"], "--exact: needs --endpoint (with --model) or --local-model"),
        (["--exact", "--simulated", "fair"], "--exact: needs --endpoint (with --model) or --local-model"),
        (["--exact", "--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--samples", "5"], "--samples: give --samples or --exact, not both"),
        (["--exact", "--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--design", "both"], "--design: the paper's design samples through the filter: run with --samples N, not --exact"),
        (["--exact", "--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--scene", "x"], "--scene: the exact route reads text only"),
    ],
)  # fmt: skip
def test_bad_exact_options_exit_2_with_one_line(tmp_path, capsys, argv, message):
    code, out, err = run(capsys, "experiment", "package-delivery", "--out", tmp_path / "o", "--no-progress", *argv)
    assert code == 2 and out == ""
    assert err.startswith("fairaudit: error: ") and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "o").exists()  # refused before --out is made


@pytest.mark.slow
def test_first_token_route_sends_the_exact_prompt_and_plain_sampling(tmp_path, capsys):
    """--sampled-twin: one-token replies to the exact route's prompt, drawn with temperature 1 and no truncation."""
    task = PACKAGE_DELIVERY
    kernel = _known_kernel(task, "low-complaint-first", [0.02, 0.05, 0.1])
    responder, logprobs = _stand_in(task, kernel)
    with ChatServer(responder, logprobs=logprobs) as server:
        code, _, err = run(
            capsys, "experiment", "package-delivery", "--endpoint", server.url, "--model", "m", "--sampled-twin", "--scoring", "first-token",
            "--samples", "2", "--no-images", "--no-progress", "--out", tmp_path / "run",
        )  # fmt: skip
        assert code == 0, err
        bodies = [r["json"] for r in server.requests if r["path"].endswith("/chat/completions")]
    assert len(bodies) == 24
    for body in bodies:
        assert (body["max_tokens"], body["temperature"], body["top_k"], body["top_p"], body["min_p"]) == (
            1,
            1.0,
            0,
            1.0,
            0.0,
        )
        assert "logprobs" not in body
    shown = exact_prompt(task)[0]
    prompts = {b["messages"][-1]["content"] for b in bodies}
    assert prompts == {
        shown.prompt(c, pair) for c in task.contexts for pair in itertools.product(task.profiles, repeat=2)
    }


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (("--sampled-twin", "--samples", "2"), "--sampled-twin: needs --endpoint (with --model): it samples a server's first token"),
        (("--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--sampled-twin", "--exact"), "--sampled-twin: is the sampled twin of --exact: give one of them"),
    ],
)  # fmt: skip
def test_first_token_needs_an_endpoint_and_not_exact(tmp_path, capsys, flags, message):
    code, out, err = run(capsys, "experiment", "package-delivery", *flags, "--out", tmp_path / "run")
    assert code == 2 and out == "" and err.strip() == f"fairaudit: error: {message}"
    assert not (tmp_path / "run").exists()


@pytest.mark.slow
def test_first_token_sends_no_images_and_refuses_a_scene(tmp_path, capsys):
    task = PACKAGE_DELIVERY
    responder, logprobs = _stand_in(task, _known_kernel(task, "fair", [0.0, 0.0, 0.0]))
    with ChatServer(responder, logprobs=logprobs) as server:
        code, _, err = run(
            capsys, "experiment", "package-delivery", "--endpoint", server.url, "--model", "m", "--sampled-twin", "--scoring", "first-token",
            "--samples", "1", "--no-progress", "--out", tmp_path / "run",
        )  # fmt: skip
        assert code == 0, err
        contents = [b["messages"][-1]["content"] for b in server.chat_requests]
    assert contents and all(isinstance(c, str) for c in contents)  # text only: no image parts
    assert not list((tmp_path / "run").glob("route-*.png"))
    code, _, err = run(
        capsys, "experiment", "package-delivery", "--endpoint", "http://127.0.0.1:9/v1", "--model", "m",
        "--sampled-twin", "--samples", "1", "--scene", tmp_path, "--out", tmp_path / "other",
    )  # fmt: skip
    assert code == 2 and "--scene: --sampled-twin samples the exact route's text-only prompt" in err
