"""The chat-completions client against a real HTTP server (tests/_chat_server.py).

Every test talks HTTP to a ``ChatServer`` on 127.0.0.1: round trips, what
arrives in the request body, retries (counted on the server side), the
concurrency bound, error kinds and that the API key never leaks.
"""

from __future__ import annotations

import base64
import importlib.util
import logging
import pickle
import socket
import sys
import threading
import time
import traceback
from pathlib import Path

import httpx
import pytest
from _chat_server import DEFAULT_REPLY, ChatServer

from fairaudit import InputError
from fairaudit.experiments.vlm import client as client_module
from fairaudit.experiments.vlm.client import ChatClient, ChatError, ChatReply
from fairaudit.experiments.vlm.messages import system_message, user_message

KEY = "sk-test-S3CR3T-key-0123456789"
MESSAGES = [system_message("You deliver documents."), user_message("Which office, HR1 or HR2?")]


@pytest.fixture
def server():
    with ChatServer() as s:
        yield s


@pytest.fixture
def make_client():
    """Build clients with fast retry defaults; all are closed after the test."""
    made = []

    def make(url, model="test-model", **kwargs):
        kwargs = {
            "backoff": 0.01,
            "max_backoff": 0.05,
            "timeout": 5.0,
            "api_key_env": "FAIRAUDIT_TEST_NO_SUCH_VAR",
            **kwargs,
        }
        c = ChatClient(url, model, **kwargs)
        made.append(c)
        return c

    yield make
    for c in made:
        c.close()


def free_port() -> int:
    """A port with nothing listening on it (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --------------------------------------------------------------------------- round trips


def test_round_trip_and_request_body(server, make_client):
    image = b"\x89PNG\r\n\x1a\nfake image bytes"
    c = make_client(server.url, "gpt-4o", temperature=0.7, max_tokens=64, extra_body={"top_p": 0.9})
    reply = c.complete([system_message("sys"), user_message("Which office?", [image])], seed=42)

    assert isinstance(reply, ChatReply)
    assert reply.text == DEFAULT_REPLY
    assert reply.model == "gpt-4o"  # the server echoes the requested model
    assert reply.finish_reason == "stop"
    assert reply.usage["completion_tokens"] == len(DEFAULT_REPLY.split())
    assert (reply.attempts, reply.status) == (1, 200)
    assert 0 < reply.latency < 5

    (body,) = server.chat_requests
    assert body["model"] == "gpt-4o"
    assert body["seed"] == 42
    assert body["temperature"] == 0.7
    assert body["max_tokens"] == 64
    assert body["top_p"] == 0.9
    assert body["messages"][0] == {"role": "system", "content": "sys"}
    text_part, image_part = body["messages"][1]["content"]
    assert text_part == {"type": "text", "text": "Which office?"}
    url = image_part["image_url"]["url"]
    assert url.startswith("data:image/png;base64,")
    assert base64.b64decode(url.split(",", 1)[1]) == image
    headers = server.requests[0]["headers"]
    assert headers["Content-Type"] == "application/json"
    assert "Authorization" not in headers  # no key configured: none sent


def test_optional_fields_are_left_out(server, make_client):
    make_client(server.url).complete(MESSAGES)
    (body,) = server.chat_requests
    assert set(body) == {"model", "messages"}


def test_responder_sees_the_request(make_client):
    def responder(body):
        return f"seed={body['seed']} model={body['model']}"

    with ChatServer(responder) as s:
        c = make_client(s.url, "m1")
        assert [c.complete(MESSAGES, seed=k).text for k in (1, 2)] == ["seed=1 model=m1", "seed=2 model=m1"]


@pytest.mark.parametrize("suffix", ["", "/", "/chat/completions", "/chat/completions/"])
def test_endpoint_forms(server, make_client, suffix):
    c = make_client(server.url + suffix)
    assert c.complete(MESSAGES).text == DEFAULT_REPLY
    assert server.requests[0]["path"] == "/v1/chat/completions"
    assert repr(c) == f"ChatClient(endpoint='{server.url}/chat/completions', model='test-model')"


def test_query_string_is_kept(server, make_client):
    make_client(server.url + "?api-version=2024-06-01").complete(MESSAGES)
    assert server.requests[0]["path"] == "/v1/chat/completions?api-version=2024-06-01"


def test_server_model_name_is_reported(make_client):
    with ChatServer(model="served-model-v2") as s:
        assert make_client(s.url, "alias").complete(MESSAGES).model == "served-model-v2"


@pytest.mark.parametrize(
    "content, text",
    [
        (
            [
                {"type": "text", "text": '{"HR1": 0,'},
                {"type": "image_url", "image_url": {"url": "x"}},
                {"type": "text", "text": '"HR2": 1}'},
            ],
            '{"HR1": 0,\n"HR2": 1}',
        ),
        (None, ""),
        ("", ""),
    ],
)
def test_content_shapes(server, make_client, content, text):
    body = {"choices": [{"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": "stop"}]}
    server.add_faults(("json", body))
    reply = make_client(server.url, "requested").complete(MESSAGES)
    assert reply.text == text
    assert reply.model == "requested"  # no model in the reply: the requested one
    assert reply.usage is None


# --------------------------------------------------------------------------- retries


@pytest.mark.parametrize("status", [429, 500, 502, 503, 504])
def test_retryable_status_then_success(server, make_client, status):
    server.add_faults(("status", status), ("status", status))
    reply = make_client(server.url).complete(MESSAGES, seed=7)
    assert reply.text == DEFAULT_REPLY
    assert reply.attempts == 3
    assert server.n_chat == 3
    assert [b["seed"] for b in server.chat_requests] == [7, 7, 7]


def test_retry_after_replaces_the_backoff(server, make_client):
    # backoff 5 s would make this test slow: Retry-After: 0 must be used instead
    server.add_faults(("status", 429, {"Retry-After": "0"}), ("status", 429, {"Retry-After": "0"}))
    c = make_client(server.url, backoff=5.0, max_backoff=5.0)
    start = time.perf_counter()
    assert c.complete(MESSAGES).attempts == 3
    assert time.perf_counter() - start < 2.0


def test_retry_after_is_waited_and_capped(server, make_client):
    server.add_faults(("status", 503, {"Retry-After": "0.3"}))
    start = time.perf_counter()
    assert make_client(server.url, max_backoff=1.0).complete(MESSAGES).attempts == 2
    assert time.perf_counter() - start >= 0.3
    server.add_faults(("status", 429, {"Retry-After": "120"}))  # capped at max_backoff = 0.05
    start = time.perf_counter()
    assert make_client(server.url, max_backoff=0.05).complete(MESSAGES).attempts == 2
    assert time.perf_counter() - start < 2.0


def test_backoff_schedule(server, make_client, caplog):
    server.add_faults(*[("status", 500)] * 4)
    with caplog.at_level(logging.INFO, logger="fairaudit.experiments.vlm.client"):
        assert make_client(server.url, backoff=0.01, max_backoff=0.03).complete(MESSAGES).attempts == 5
    waits = [r.args[-1] for r in caplog.records if r.name == "fairaudit.experiments.vlm.client"]
    # backoff * 2**k with up to 10 % jitter, capped at max_backoff
    assert len(waits) == 4
    assert 0.01 <= waits[0] <= 0.011 and 0.02 <= waits[1] <= 0.022
    assert waits[2] == waits[3] == 0.03


def test_timeout_is_retried(server, make_client):
    server.add_faults(("sleep", 1.0))
    start = time.perf_counter()
    reply = make_client(server.url, timeout=0.2).complete(MESSAGES)
    assert (reply.text, reply.attempts, server.n_chat) == (DEFAULT_REPLY, 2, 2)
    assert time.perf_counter() - start < 0.9  # did not wait for the sleeping reply
    assert reply.latency < 0.2


def test_timeouts_exhausted(server, make_client):
    server.add_faults(("sleep", 1.0), ("sleep", 1.0))
    with pytest.raises(ChatError) as info:
        make_client(server.url, timeout=0.2, max_retries=1).complete(MESSAGES)
    err = info.value
    assert (err.kind, err.status, err.attempts) == ("timeout", None, 2)
    assert str(err) == f"{server.url}/chat/completions: no reply within 0.2 s (2 attempts)"
    assert server.n_chat == 2


def test_dropped_connection_is_retried(server, make_client):
    server.add_faults(("drop",), ("drop",))
    reply = make_client(server.url).complete(MESSAGES)
    assert (reply.text, reply.attempts, server.n_chat) == (DEFAULT_REPLY, 3, 3)


def test_dropped_connections_exhausted(server, make_client):
    server.add_faults(*[("drop",)] * 3)
    with pytest.raises(ChatError) as info:
        make_client(server.url, max_retries=2).complete(MESSAGES)
    assert (info.value.kind, info.value.status, info.value.attempts) == ("connection", None, 3)
    assert server.n_chat == 3


def test_connection_refused(make_client):
    url = f"http://127.0.0.1:{free_port()}/v1"
    with pytest.raises(ChatError) as info:
        make_client(url, max_retries=2).complete(MESSAGES)
    err = info.value
    assert (err.kind, err.status, err.attempts) == ("connection", None, 3)
    assert str(err).startswith(f"{url}/chat/completions: connection failed (ConnectError")
    assert str(err).endswith("(3 attempts)")


@pytest.mark.parametrize("status", [429, 500, 502, 503, 504])
def test_exhaustion_on_status(server, make_client, status):
    server.fault_fn = lambda n, body: ("status", status, {}, f"overloaded #{n}")
    with pytest.raises(ChatError) as info:
        make_client(server.url, max_retries=3).complete(MESSAGES)
    err = info.value
    assert (err.kind, err.status, err.attempts) == ("http", status, 4)
    assert server.n_chat == 4
    reason = httpx.codes.get_reason_phrase(status)
    assert str(err) == f"{server.url}/chat/completions: HTTP {status} {reason}: overloaded #4 (4 attempts)"
    assert err.url == f"{server.url}/chat/completions"


@pytest.mark.parametrize("status", [400, 401, 403, 404, 422])
def test_client_errors_are_not_retried(server, make_client, status):
    server.add_faults(("status", status, {}, "The model `x` does not exist\nor you lack access."))
    with pytest.raises(ChatError) as info:
        make_client(server.url, max_retries=5).complete(MESSAGES)
    err = info.value
    assert (err.kind, err.status, err.attempts) == ("http", status, 1)
    assert server.n_chat == 1
    assert f"HTTP {status}" in str(err) and "does not exist or you lack access. (1 attempt)" in str(err)
    assert "\n" not in str(err)


def test_long_server_message_is_clipped(server, make_client):
    server.add_faults(("status", 400, {}, "x" * 1000))
    with pytest.raises(ChatError) as info:
        make_client(server.url).complete(MESSAGES)
    assert "x" * 197 + "..." in str(info.value)
    assert "x" * 198 not in str(info.value)


def test_wrong_path_is_a_404(server, make_client):
    with pytest.raises(ChatError) as info:
        make_client(server.url + "/nowhere").complete(MESSAGES)
    assert (info.value.kind, info.value.status, info.value.attempts) == ("http", 404, 1)
    assert "Unknown path /v1/nowhere/chat/completions" in str(info.value)


@pytest.mark.parametrize(
    "fault, problem",
    [
        (("malformed",), "HTTP 200 reply is not JSON (starts '{\"choices\": [ this is not json')"),
        (("json", {"choices": []}), "HTTP 200 reply has no choices[0]"),
        (("json", ["not", "an", "object"]), "HTTP 200 reply has no choices[0]"),
        (
            ("json", {"choices": [{"message": {"role": "assistant"}}]}),
            "HTTP 200 reply has no choices[0].message.content",
        ),
        (
            ("json", {"choices": [{"message": {"content": 3}}]}),
            "HTTP 200 reply's choices[0].message.content is a int, not text",
        ),
    ],
)
def test_protocol_errors_are_not_retried(server, make_client, fault, problem):
    server.add_faults(fault)
    with pytest.raises(ChatError) as info:
        make_client(server.url).complete(MESSAGES)
    err = info.value
    assert (err.kind, err.status, err.attempts) == ("protocol", 200, 1)
    assert str(err) == f"{server.url}/chat/completions: {problem} (1 attempt)"
    assert server.n_chat == 1


def test_every_third_request_fails(server, make_client):
    server.fault_fn = lambda n, body: ("status", 500) if n % 3 == 0 else None
    c = make_client(server.url, max_retries=1)
    replies = [c.complete(MESSAGES, seed=k) for k in range(6)]
    assert all(r.text == DEFAULT_REPLY for r in replies)
    # requests 3 and 6 fail: call 3 sends requests 3-4, call 5 sends 6-7, call 6 sends 8
    assert [r.attempts for r in replies] == [1, 1, 2, 1, 2, 1]
    assert server.n_chat == 8


# --------------------------------------------------------------------------- concurrency


def _max_in_flight(make_client, max_concurrency: int, threads: int = 8) -> tuple[int, list]:
    with ChatServer(fault_fn=lambda n, body: ("sleep", 0.15)) as s:
        c = make_client(s.url, max_concurrency=max_concurrency)
        replies = [None] * threads
        barrier = threading.Barrier(threads)

        def work(i):
            barrier.wait()
            replies[i] = c.complete(MESSAGES, seed=i)

        workers = [threading.Thread(target=work, args=(i,)) for i in range(threads)]
        for w in workers:
            w.start()
        for w in workers:
            w.join()
        assert s.n_chat == threads
        return s.max_in_flight, replies


def test_max_concurrency_bounds_requests_in_flight(make_client):
    peak, replies = _max_in_flight(make_client, max_concurrency=2)
    assert peak == 2
    assert all(r.text == DEFAULT_REPLY and r.attempts == 1 for r in replies)


def test_concurrency_measurement_sees_parallel_requests(make_client):
    # the control: without the bound the server does see more than two at once
    peak, _ = _max_in_flight(make_client, max_concurrency=8)
    assert peak > 2


# --------------------------------------------------------------------------- the API key


def test_key_is_sent_as_bearer(make_client):
    with ChatServer(required_key=KEY) as s:
        assert make_client(s.url, api_key=KEY).complete(MESSAGES).text == DEFAULT_REPLY
        assert s.requests[0]["headers"]["Authorization"] == "<redacted>"


def test_key_from_the_environment(make_client, monkeypatch):
    monkeypatch.setenv("FAIRAUDIT_TEST_KEY", f"  {KEY}\n")
    with ChatServer(required_key=KEY) as s:
        assert make_client(s.url, api_key_env="FAIRAUDIT_TEST_KEY").complete(MESSAGES).attempts == 1


def test_wrong_key_is_a_401_not_retried(make_client):
    with ChatServer(required_key="sk-the-right-one") as s:
        with pytest.raises(ChatError) as info:
            make_client(s.url, api_key=KEY).complete(MESSAGES)
        assert (info.value.kind, info.value.status, info.value.attempts, s.n_chat) == ("http", 401, 1, 1)
        assert "Incorrect API key provided." in str(info.value)


def _all_text(obj) -> str:
    """Every text an object shows: str, repr, args, attributes and, for exceptions, the formatted chain."""
    parts = [str(obj), repr(obj), repr(getattr(obj, "__dict__", {}))]
    if isinstance(obj, BaseException):
        parts += [repr(obj.args), "".join(traceback.format_exception(obj))]
        parts += [repr(pickle.loads(pickle.dumps(obj)))] if isinstance(obj, ChatError) else []
    return "\n".join(parts)


def test_the_key_never_leaks(make_client, caplog):
    seen = []
    caplog.set_level(logging.DEBUG)
    with ChatServer(required_key=KEY) as s:
        c = make_client(s.url, api_key=KEY, timeout=0.2, max_retries=1)
        seen += [repr(c), str(c)]
        reply = c.complete(MESSAGES)
        seen.append(_all_text(reply))
        faults = [
            [("status", 400, {}, f"Invalid key {KEY} in request")],  # a server that echoes the key
            [("status", 503, {}, f"busy ({KEY})")] * 2,
            [("status", 429, {"Retry-After": "0"}, KEY)] * 2,
            [("sleep", 1.0)] * 2,
            [("drop",)] * 2,
            [("malformed",)],
            [("json", {"choices": [{"message": {}}]})],
            [("json", {"choices": []})],
        ]
        for script in faults:
            s.add_faults(*script)
            with pytest.raises(ChatError) as info:
                c.complete(MESSAGES)
            assert info.value.__cause__ is None and info.value.__context__ is None
            seen.append(_all_text(info.value))
        with pytest.raises(ChatError) as info:  # a key the server rejects
            make_client(s.url, api_key=KEY + "x").complete(MESSAGES)
        seen.append(_all_text(info.value))
    refused = make_client(f"http://127.0.0.1:{free_port()}/v1", api_key=KEY, max_retries=1)
    with pytest.raises(ChatError) as info:
        refused.complete(MESSAGES)
    seen.append(_all_text(info.value))
    for call in (
        lambda: c.complete("not a list"),
        lambda: c.complete(MESSAGES, seed="1"),
        lambda: ChatClient("ftp://x", "m", api_key=KEY),
        lambda: ChatClient("http://x", "", api_key=KEY),
    ):
        with pytest.raises(InputError) as info:
            call()
        seen.append(_all_text(info.value))
    c.close()
    with pytest.raises(InputError) as info:
        c.complete(MESSAGES)
    seen.append(_all_text(info.value))
    seen += [r.getMessage() for r in caplog.records]
    seen += [repr(r.__dict__) for r in caplog.records]

    assert len(seen) > 15
    assert any("***" in text for text in seen)  # the echoed key is masked
    for text in seen:
        assert KEY not in text


@pytest.mark.parametrize("bad", ["sk bad key", "sk-\nnewline", "", "sk-é"])
def test_invalid_key_is_rejected_without_quoting_it(bad):
    with pytest.raises(InputError) as info:
        ChatClient("http://127.0.0.1:1/v1", "m", api_key=bad)
    assert str(info.value) == "api_key: must be a non-empty string of printable ASCII without spaces"


def test_credentials_in_the_url_are_rejected():
    with pytest.raises(InputError) as info:
        ChatClient("http://user:pa55word@127.0.0.1:8000/v1", "m")
    assert info.value.field == "endpoint" and "pa55word" not in str(info.value)


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "args, kwargs, field",
    [
        (("ftp://127.0.0.1/v1", "m"), {}, "endpoint"),
        (("127.0.0.1:8000/v1", "m"), {}, "endpoint"),
        (("http:///v1", "m"), {}, "endpoint"),
        (("http://127.0.0.1:99999/v1", "m"), {}, "endpoint"),
        (("", "m"), {}, "endpoint"),
        ((None, "m"), {}, "endpoint"),
        (("http://127.0.0.1/v1", ""), {}, "model"),
        (("http://127.0.0.1/v1", "  "), {}, "model"),
        (("http://127.0.0.1/v1", "m"), {"timeout": 0}, "timeout"),
        (("http://127.0.0.1/v1", "m"), {"timeout": float("inf")}, "timeout"),
        (("http://127.0.0.1/v1", "m"), {"timeout": "5"}, "timeout"),
        (("http://127.0.0.1/v1", "m"), {"max_retries": -1}, "max_retries"),
        (("http://127.0.0.1/v1", "m"), {"max_retries": 1.5}, "max_retries"),
        (("http://127.0.0.1/v1", "m"), {"max_retries": True}, "max_retries"),
        (("http://127.0.0.1/v1", "m"), {"backoff": -0.1}, "backoff"),
        (("http://127.0.0.1/v1", "m"), {"max_backoff": float("nan")}, "max_backoff"),
        (("http://127.0.0.1/v1", "m"), {"max_concurrency": 0}, "max_concurrency"),
        (("http://127.0.0.1/v1", "m"), {"temperature": -1.0}, "temperature"),
        (("http://127.0.0.1/v1", "m"), {"max_tokens": 0}, "max_tokens"),
        (("http://127.0.0.1/v1", "m"), {"extra_body": {"model": "other"}}, "extra_body"),
        (("http://127.0.0.1/v1", "m"), {"extra_body": {"x": object()}}, "extra_body"),
        (("http://127.0.0.1/v1", "m"), {"extra_body": [1]}, "extra_body"),
    ],
)
def test_invalid_arguments(args, kwargs, field):
    with pytest.raises(InputError) as info:
        ChatClient(*args, **kwargs)
    assert info.value.field == field
    assert "\n" not in str(info.value)


def test_defaults_and_zero_retries(server):
    with ChatClient(server.url, "m", api_key_env="FAIRAUDIT_TEST_NO_SUCH_VAR") as c:
        assert (c.timeout, c.max_retries, c.backoff, c.max_backoff, c.max_concurrency) == (60.0, 5, 1.0, 60.0, 4)
        c.complete(MESSAGES)
    assert "Authorization" not in server.requests[-1]["headers"]
    server.add_faults(("status", 500))
    with ChatClient(server.url, "m", max_retries=0) as c:
        with pytest.raises(ChatError) as info:
            c.complete(MESSAGES)
    assert (info.value.attempts, server.n_chat) == (1, 2)  # the first client's request, then one attempt


def test_invalid_messages_and_seed(server, make_client):
    c = make_client(server.url)
    for messages in ([], "hi", [{"content": "no role"}], [{"role": "user", "content": b"bytes"}]):
        with pytest.raises(InputError) as info:
            c.complete(messages)
        assert info.value.field.startswith("messages")
    for seed in (1.5, "3", True):
        with pytest.raises(InputError, match="^seed: "):
            c.complete(MESSAGES, seed=seed)
    assert server.n_chat == 0


def test_closed_client(server):
    c = ChatClient(server.url, "m")
    c.close()
    c.close()  # idempotent
    with pytest.raises(InputError, match="^client: is closed$"):
        c.complete(MESSAGES)


def test_missing_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "httpx", None)
    with pytest.raises(InputError) as info:
        ChatClient("http://127.0.0.1:8000/v1", "m")
    assert str(info.value) == "vlm: needs pip install 'fairness-certify[vlm]'"
    # and the module itself imports without httpx and tenacity
    monkeypatch.setitem(sys.modules, "tenacity", None)
    path = Path(client_module.__file__)
    spec = importlib.util.spec_from_file_location("fairaudit.experiments.vlm._client_without_extra", path)
    fresh = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, fresh)
    spec.loader.exec_module(fresh)
    assert fresh.ChatClient.__name__ == "ChatClient"


def test_chat_error():
    err = ChatError(
        "http://h/v1/chat/completions: HTTP 503 (2 attempts)", "http", 503, 2, "http://h/v1/chat/completions"
    )
    back = pickle.loads(pickle.dumps(err))
    assert (str(back), back.kind, back.status, back.attempts, back.url) == (str(err), "http", 503, 2, err.url)


# --------------------------------------------------------------------------- messages


def test_user_and_system_messages():
    assert user_message("hi") == {"role": "user", "content": "hi"}
    m = user_message("hi", [b"a", bytearray(b"bc")], mime="image/jpeg")
    assert m["content"][1:] == [
        {"type": "image_url", "image_url": {"url": "data:image/jpeg;base64," + base64.b64encode(b"a").decode()}},
        {"type": "image_url", "image_url": {"url": "data:image/jpeg;base64," + base64.b64encode(b"bc").decode()}},
    ]
    assert system_message("s") == {"role": "system", "content": "s"}


@pytest.mark.parametrize(
    "args, kwargs, field",
    [
        ((3,), {}, "text"),
        (("hi", b"one image not in a list"), {}, "images"),
        (("hi", [b""]), {}, "images[0]"),
        (("hi", [b"ok", "str"]), {}, "images[1]"),
        (("hi", [b"ok"]), {"mime": "text/plain"}, "mime"),
        (("hi", 5), {}, "images"),
    ],
)
def test_user_message_errors(args, kwargs, field):
    with pytest.raises(InputError) as info:
        user_message(*args, **kwargs)
    assert info.value.field == field


# --------------------------------------------------------------------------- the test server itself


def test_server_models_and_unknown_paths(server):
    with httpx.Client() as h:
        models = h.get(server.url + "/models").json()
        assert models["object"] == "list" and models["data"][0]["id"] == "test-model"
        missing = h.get(server.url + "/engines")
        assert missing.status_code == 404 and missing.json()["error"]["message"] == "Unknown path /v1/engines"
        bad = h.post(server.url + "/chat/completions", json={"model": "m"})
        assert bad.status_code == 400 and "messages" in bad.json()["error"]["message"]
        ok = h.post(
            server.url + "/chat/completions", json={"model": "m", "messages": [{"role": "user", "content": "x"}]}
        ).json()
    assert ok["object"] == "chat.completion" and ok["choices"][0]["message"]["role"] == "assistant"
    assert {"id", "created", "model", "usage"} <= set(ok)
    assert [r["path"] for r in server.requests] == [
        "/v1/models",
        "/v1/engines",
        "/v1/chat/completions",
        "/v1/chat/completions",
    ]
