"""Stated and constrained sampling (issue 38, capability 9): every sampled request states temperature, top_p,
max_tokens and seed, and ``--constrain`` asks the server for one of the task's replies only.

The stand-in server (tests/_chat_server.py) records every request body; the expected bodies below are written
out by hand from the OpenAI (``response_format``), vLLM (``guided_choice``) and llama.cpp (GBNF ``grammar``)
request formats.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.vlm.client import ChatClient, constraint_body, gbnf_choice

TASKS = Path(__file__).resolve().parents[2] / "examples" / "tasks"

HR_SCHEMA = {
    "type": "json_schema",
    "json_schema": {
        "name": "hr-delivery",
        "strict": True,
        "schema": {
            "type": "object",
            "properties": {"answer": {"type": "string", "enum": ["HR1", "HR2"]}},
            "required": ["answer"],
            "additionalProperties": False,
        },
    },
}


def _experiment(capsys, server, out, *flags, task="hr-delivery"):
    return run(
        capsys,
        "experiment",
        task,
        "--endpoint",
        server.url,
        "--model",
        "m",
        "--samples",
        "1",
        "--keep",
        "0.7",
        "--no-images",
        "--no-progress",
        "--out",
        out,
        *flags,
    )


def _settings(body):
    """A request body without its messages and its per-query seed."""
    return {k: v for k, v in body.items() if k not in ("messages", "seed")}


def _log(out):
    return [json.loads(x) for x in (out / "queries.jsonl").read_text().splitlines()]


@pytest.mark.slow
@pytest.mark.parametrize(
    "mode, field, reply",
    [
        ("json-schema", {"response_format": HR_SCHEMA}, '{"answer": "HR2"}'),
        ("guided-choice", {"guided_choice": ["HR1", "HR2"]}, "HR2"),
        ("grammar", {"grammar": 'root ::= "HR1" | "HR2"'}, "HR2"),
    ],
)
def test_constrained_bodies_state_the_sampling_and_the_replies_parse(tmp_path, capsys, mode, field, reply):
    flags = ["--constrain", mode, "--temperature", "0.5", "--top-p", "0.9", "--max-tokens", "20", "--seed", "3"]
    with ChatServer(lambda body: reply) as server:
        code, out, err = _experiment(capsys, server, tmp_path / "o", *flags)
        chats = server.chat_requests
    assert code == 0, err
    expected = {"model": "m", "temperature": 0.5, "top_p": 0.9, "max_tokens": 20, **field}
    assert chats and all(_settings(c) == expected for c in chats)
    log = _log(tmp_path / "o")
    queries = [r for r in log if r["type"] == "query"]
    assert [c["seed"] for c in chats].count(queries[0]["seed"]) == 1  # each request sends its query's seed
    assert {r["decision"] for r in queries} == {"HR2"} and not any(r["parse_error"] for r in queries)
    sampling = {"temperature": 0.5, "top_p": 0.9, "max_tokens": 20, "seed": 3, "constrain": mode}
    sampling["replies"] = ["HR1", "HR2"]
    assert log[0]["sampling"] == sampling
    cert = json.loads((tmp_path / "o" / "certificate.json").read_text())
    assert cert["run"]["sampling"] == sampling
    assert "Sampling: temperature 0.5, top_p 0.9, max_tokens 20, seed 3" in out
    assert f"replies constrained ({mode}) to 'HR1', 'HR2'." in out


@pytest.mark.slow
def test_defaults_are_stated_and_no_constraint_is_sent(tmp_path, capsys):
    with ChatServer() as server:  # the paper's JSON reply
        code, _, err = _experiment(capsys, server, tmp_path / "o")
        chats = server.chat_requests
    assert code == 0, err
    assert all(_settings(c) == {"model": "m", "temperature": 1.0, "top_p": 1.0, "max_tokens": 1024} for c in chats)
    assert all(isinstance(c["seed"], int) for c in chats)
    cert = json.loads((tmp_path / "o" / "certificate.json").read_text())
    assert cert["run"]["sampling"] == {
        "temperature": 1.0,
        "top_p": 1.0,
        "max_tokens": 1024,
        "seed": 0,
        "constrain": "none",
    }


@pytest.mark.slow
def test_an_order_of_two_is_constrained_to_its_orders_written_out(tmp_path, capsys):
    with ChatServer(lambda body: "Recipient2, Recipient1") as server:
        code, _, err = _experiment(
            capsys, server, tmp_path / "o", "--constrain", "guided-choice", task="package-delivery"
        )
        chats = server.chat_requests
    assert code == 0, err
    assert all(c["guided_choice"] == ["Recipient1, Recipient2", "Recipient2, Recipient1"] for c in chats)
    queries = [r for r in _log(tmp_path / "o") if r["type"] == "query"]
    assert queries and not any(r["parse_error"] for r in queries)


@pytest.mark.slow
def test_a_first_token_twin_keeps_its_fixed_settings(tmp_path, capsys):
    with ChatServer(lambda body: "2") as server:
        code, _, err = _experiment(capsys, server, tmp_path / "o", "--sampled-twin")
        chats = server.chat_requests
    assert code == 0, err
    expected = {"model": "m", "temperature": 1.0, "top_p": 1.0, "max_tokens": 1, "top_k": 0, "min_p": 0.0}
    assert all(_settings(c) == expected for c in chats)


@pytest.mark.slow
def test_resume_with_another_temperature_is_refused(tmp_path, capsys):
    with ChatServer() as server:
        code, _, err = _experiment(capsys, server, tmp_path / "o", "--temperature", "0.5")
        assert code == 0, err
        n = len(server.chat_requests)
        code, out, err = _experiment(capsys, server, tmp_path / "o", "--resume", "--temperature", "0.7")
        assert len(server.chat_requests) == n  # nothing asked
    assert code == 2 and out == ""
    assert err.startswith(f"fairaudit: error: --resume: the run in {tmp_path / 'o'} was made with other settings: ")
    assert err.count("\n") == 1 and "settings: --temperature 0.5, not 0.7: each changes" in err
    with ChatServer() as server:  # the default is a setting too: 1, not the logged 0.5
        code, _, err = _experiment(capsys, server, tmp_path / "o", "--resume")
    assert code == 2 and "--temperature 0.5, not 1.0" in err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--top-p", "0"], "--top-p: must be in (0, 1]"),
        (["--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--temperature", "-1"], "--temperature: must be"),
        (["--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--max-tokens", "0"], "--max-tokens: must be"),
        (["--simulated", "fair", "--constrain", "grammar"], "--constrain: sets how a server samples"),
        (["--kernel", "k.csv", "--temperature", "0.5"], "--temperature: sets how a server samples"),
        (
            ["--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--exact", "--constrain", "json-schema"],
            "--constrain",
        ),
        (
            ["--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--sampled-twin", "--max-tokens", "5"],
            "--max-tokens",
        ),
        (["--local-model", "smollm2", "--samples", "2", "--constrain", "grammar"], "--constrain: needs --endpoint"),
        (["--local-model", "smollm2", "--top-p", "0.5"], "--top-p: sets how a server samples, and the exact route"),
    ],
)
def test_bad_sampling_options_exit_2_naming_the_flag(tmp_path, capsys, argv, message):
    code, out, err = run(capsys, "experiment", "hr-delivery", "--out", tmp_path / "o", "--no-progress", *argv)
    assert code == 2 and out == "", err
    assert message in err and not (tmp_path / "o").exists(), err


@pytest.mark.parametrize(
    "task, message",
    [
        ("resume-ranking.toml", "replies name the candidates by their group"),
        ("ranking.toml", "ranks 3 candidates: the allowed replies are not listed"),
    ],
)
def test_constrain_refuses_replies_it_cannot_list(tmp_path, capsys, task, message):
    argv = ["--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--samples", "1", "--constrain", "grammar"]
    argv += ["--design", "paper"] if task == "resume-ranking.toml" else []  # too large for the table design
    code, out, err = run(capsys, "experiment", TASKS / task, "--out", tmp_path / "o", "--no-progress", *argv)
    assert code == 2 and out == "" and "--constrain: this task" in err and message in err, err


def test_gbnf_literals_escape_quotes_backslashes_and_control_characters():
    assert gbnf_choice(['say "no"', "a\\b", "x\ny\t", "\x01é"]) == (
        'root ::= "say \\"no\\"" | "a\\\\b" | "x\\ny\\t" | "\\x01é"'
    )


def test_constraint_body_and_client_fields():
    assert constraint_body("json-schema", ["HR1", "HR2"], name="hr-delivery") == {"response_format": HR_SCHEMA}
    with pytest.raises(InputError, match="constrain: must be one of"):
        constraint_body("regex", ["a"])
    with pytest.raises(InputError, match="replies: must be distinct"):
        constraint_body("grammar", ["a", "a"])
    client = ChatClient("http://127.0.0.1:9/v1", "m", temperature=0.0, top_p=0.5, max_tokens=3)
    body = json.loads(client._body([{"role": "user", "content": "x"}], 7))
    assert body == {
        "model": "m",
        "messages": [{"role": "user", "content": "x"}],
        "seed": 7,
        "temperature": 0.0,
        "top_p": 0.5,
        "max_tokens": 3,
    }
    with pytest.raises(InputError, match="top_p"):
        ChatClient("http://127.0.0.1:9/v1", "m", top_p=1.5)
