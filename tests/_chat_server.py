"""A real OpenAI-compatible chat-completions server for the tests (not a mock).

``ChatServer`` is an ``http.server.ThreadingHTTPServer`` on 127.0.0.1 (a free
port) served from a daemon thread; use it as a context manager::

    with ChatServer(responder=lambda body: '{"HR1": "0.0", "HR2": "1.0"}') as server:
        client = ChatClient(server.url, "test-model")

Routes: ``POST /v1/chat/completions`` (the OpenAI response shape) and
``GET /v1/models``; anything else is a 404 with an OpenAI-style error body.

Faults, consumed one per chat-completion request (a scripted list first, then
``fault_fn(n_request, request_json)`` where ``n_request`` counts chat requests
from 1; None means no fault):

* ``("status", code)``, ``("status", code, headers)``,
  ``("status", code, headers, message)``: that status with
  ``{"error": {"message": ...}}`` and the headers (e.g. ``{"Retry-After": "0"}``);
* ``("sleep", seconds)``: reply normally after sleeping (to trigger timeouts);
* ``("malformed",)``: a 200 whose body is not JSON;
* ``("json", obj)``: a 200 whose body is ``obj`` (to test reply shapes);
* ``("reply", text)``: a normal reply with this text instead of the responder's;
* ``("drop",)``: close the connection without any response.

``logprobs(request_json)``, optional: the first token's distribution, a list of
``(token, logprob)``; a request with ``"logprobs": true`` then gets
``choices[0].logprobs.content[0]`` as OpenAI sends it, with the
``top_logprobs`` most likely of them (sorted, most likely first; none past
the request's ``top_logprobs``). Without it no reply has ``logprobs``, as
from a server that does not support them.

``law(request_json)``, optional: a law over multi-token replies, a mapping from the assistant's reply so far
(a prefix, ``""`` first) to the next token's law, a list of ``(token, probability)``; the mass left over ends the
reply (as the end-of-turn token, never listed). It tokenizes a text by walking the mapping from ``""`` (at each
prefix, the one listed token the rest of the text begins with). With it the server answers as vLLM and
llama-server do:

* the reply so far is the last message's content when it is the assistant's and the request says
  ``"continue_final_message": true`` (else ``""``);
* ``"logprobs": true`` lists the next token's law after the reply so far, most likely first, cut to the request's
  ``top_logprobs`` (``("<|im_end|>", 0.0)`` after a prefix the law does not continue);
* ``"prompt_logprobs": k`` (``prompt_logprobs_mode="serve"``, the default) adds vLLM's top-level
  ``prompt_logprobs``: ``null`` for the first token, then per prompt token ``{"<id>": {"logprob", "rank",
  "decoded_token"}}``, the prompt's own token first and, for k > 0, the k most likely others. The prompt is the
  ChatML rendering ``<|im_start|>system\n...<|im_end|>\n<|im_start|>user\n...<|im_end|>\n<|im_start|>assistant\n``
  (the last turn left open when continued), split into runs of non-space characters and single white-space
  characters, each of log-probability -1, then the reply so far in the law's tokens with the law's
  log-probabilities; ``straddle=True`` joins the template's last token to the reply's first (``"\nOffice"``), as a
  tokenizer that merges across the boundary does. ``prompt_logprobs_mode="reject"`` answers such a request with a
  400 (a server that refuses unknown fields); ``"ignore"`` leaves the field out (llama-server);
* without a ``responder``, a reply is sampled from the law (one token at a time, at most ``max_tokens``, seeded by
  the request's ``seed`` and messages);
* ``POST /v1/completions`` with ``"echo": true`` (text completions, as vLLM serves them; ``completion_fault_fn(
  request_json)``, where it returns an HTTP status, answers that status instead) reads the prompt as the
  ChatML rendering above, its messages then the reply so far after the open assistant turn, and answers
  ``choices[0].text`` = the prompt with OpenAI's legacy ``logprobs`` (``tokens``, ``token_logprobs`` with
  ``null`` first, ``top_logprobs``, ``text_offset``) of the same tokens as ``prompt_logprobs``; ``max_tokens``
  > 0 appends one generated token (``"<gen>"``) to the text and the lists. A prompt without ChatML (raw text, as
  lm-eval sends discrim-eval's) that holds ``raw_reply_after`` (default ``\u201c``, the opening quote that ends
  lm-eval's discrim-eval prompt) is read as the user's text up to its last such mark, in runs at -1 each, then the
  reply so far in the law's tokens; ``law`` gets that user message and the reply as the continued assistant's.

``chat_logprobs=False`` makes the chat completions answer without any log-probabilities (a server that does not
give them), ``chat=False`` takes the chat completions away (404) and ``completions=False`` the text completions.
``completion_requests`` are the text completions' JSON bodies.

``required_key``: requests without ``Authorization: Bearer <key>`` get a 401
(checked before the faults; a body without ``messages`` gets a 400). Every
request is recorded in ``server.requests`` (method, path, JSON body, headers
with the Authorization value redacted); ``chat_requests`` are the chat
requests' JSON bodies and ``messages`` their ``messages``, each as the
``json.dumps`` text of the list (to compare what routes send byte for byte); ``n_chat`` counts the POSTs to
``/v1/chat/completions`` and ``max_in_flight`` is the largest number of
chat requests handled at once (from the body read until the reply starts).
"""

from __future__ import annotations

import json
import math
import random
import re
import threading
import time
import zlib
from collections import deque
from collections.abc import Callable, Iterable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

DEFAULT_REPLY = '{"HR1": "0.0", "HR2": "1.0", "reason": "HR2 is closer to the robot."}'

Fault = tuple


class ChatServer:
    """An OpenAI-compatible chat-completions server on 127.0.0.1 with fault injection (see the module docstring)."""

    def __init__(
        self,
        responder: Callable[[dict], str] | None = None,
        *,
        faults: Iterable[Fault] = (),
        fault_fn: Callable[[int, dict], Fault | None] | None = None,
        required_key: str | None = None,
        model: str | None = None,
        logprobs: Callable[[dict], list[tuple[str, float]]] | None = None,
        props: dict | None = None,
        law: Callable[[dict], dict[str, list[tuple[str, float]]]] | None = None,
        prompt_logprobs_mode: str = "serve",
        straddle: bool = False,
        chat_logprobs: bool = True,
        chat: bool = True,
        completions: bool = True,
        raw_reply_after: str = "\u201c",
        completion_fault_fn: Callable[[dict], int | None] | None = None,
    ) -> None:
        self.completion_fault_fn = completion_fault_fn
        self.chat = chat
        self.raw_reply_after = raw_reply_after
        self.law = law
        self.chat_logprobs = chat_logprobs
        self.completions = completions and law is not None
        self.prompt_logprobs_mode = prompt_logprobs_mode
        self.straddle = straddle
        if responder is None and law is not None:
            responder = self._sample
        if logprobs is None and law is not None:
            logprobs = self._next_tokens
        self.responder = responder or (lambda body: DEFAULT_REPLY)
        self.logprobs = logprobs
        self.props = props  # llama-server's GET /props, when given
        self.fault_fn = fault_fn
        self.required_key = required_key
        self.model = model  # None: echo the requested model
        self.requests: list[dict] = []
        self.n_chat = 0
        self.in_flight = 0
        self.max_in_flight = 0
        self._faults: deque = deque(faults)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._httpd: ThreadingHTTPServer | None = None
        self._thread: threading.Thread | None = None

    # --- lifecycle -------------------------------------------------------------------------

    def __enter__(self) -> ChatServer:
        self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def start(self) -> None:
        handler = type("Handler", (_Handler,), {"server_state": self})
        self._httpd = _Server(("127.0.0.1", 0), handler)
        self._thread = threading.Thread(target=self._httpd.serve_forever, kwargs={"poll_interval": 0.01}, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()  # wakes sleeping handlers
        if self._httpd is not None:
            self._httpd.shutdown()
            self._httpd.server_close()
            self._thread.join(timeout=5)
            self._httpd = None

    @property
    def port(self) -> int:
        return self._httpd.server_address[1]

    @property
    def url(self) -> str:
        """The API base URL, ``http://127.0.0.1:PORT/v1``."""
        return f"http://127.0.0.1:{self.port}/v1"

    def add_faults(self, *faults: Fault) -> None:
        """Append scripted faults (consumed one per chat request)."""
        with self._lock:
            self._faults.extend(faults)

    @property
    def chat_requests(self) -> list[dict]:
        """The recorded chat-completion requests (their JSON bodies), in arrival order."""
        with self._lock:
            return [r["json"] for r in self.requests if r["path"] == "/v1/chat/completions" and r["method"] == "POST"]

    @property
    def completion_requests(self) -> list[dict]:
        """The recorded text-completion requests (their JSON bodies), in arrival order."""
        with self._lock:
            return [r["json"] for r in self.requests if r["path"] == "/v1/completions" and r["method"] == "POST"]

    @property
    def messages(self) -> list[str]:
        """The ``messages`` of each recorded chat request, as ``json.dumps`` of the list, in arrival order."""
        return [json.dumps(body["messages"]) for body in self.chat_requests]

    # --- the law over multi-token replies ------------------------------------------------------

    @staticmethod
    def reply_so_far(body: dict) -> str:
        """The assistant's reply so far: the continued last message's content, else ``""``."""
        last = body["messages"][-1]
        if last.get("role") == "assistant" and body.get("continue_final_message"):
            return str(last.get("content", ""))
        return ""

    def _next_tokens(self, body: dict) -> list[tuple[str, float]]:
        assert self.law is not None
        nxt = self.law(body).get(self.reply_so_far(body))
        return [(t, math.log(q)) for t, q in nxt if q > 0] if nxt else [("<|im_end|>", 0.0)]

    def _sample(self, body: dict) -> str:
        assert self.law is not None
        law = self.law(body)
        rng = random.Random(f"{body.get('seed')}|{json.dumps(body['messages'])}")
        text = prefix = self.reply_so_far(body)
        for _ in range(int(body.get("max_tokens") or 16)):
            u, step = rng.random(), None
            for token, q in law.get(prefix, []):
                u -= q
                if u < 0:
                    step = token
                    break
            if step is None:  # the rest of the mass: the reply ends
                break
            prefix += step
        return prefix[len(text) :]

    def law_tokens(self, law: dict, text: str) -> list[tuple[str, float]]:
        """``text`` in the law's tokens with their log-probabilities (characters at ln 1e-9 where it leaves the law)."""
        out, prefix = [], ""
        while prefix != text:
            rest = text[len(prefix) :]
            steps = [(t, q) for t, q in law.get(prefix, []) if t and rest.startswith(t)]
            token, q = steps[0] if steps else (rest[0], 1e-9)
            out.append((token, math.log(q) if q > 0 else -9999.0))
            prefix += token
        return out

    def prompt_tokens(self, body: dict) -> list[tuple[str, float]]:
        """The tokens of the request's ChatML-rendered prompt and their log-probabilities (the module docstring)."""
        assert self.law is not None
        messages, continued = body["messages"], bool(self.reply_so_far(body))
        turns = messages[:-1] if continued else messages
        template = "".join(f"<|im_start|>{m['role']}\n{m.get('content', '')}<|im_end|>\n" for m in turns)
        template += "<|im_start|>assistant\n"
        tokens = [(t, -1.0) for t in re.findall(r"\S+|\s", template)]
        reply = self.law_tokens(self.law(body), self.reply_so_far(body))
        if self.straddle and reply:
            (last, lp), (first, lq) = tokens.pop(), reply.pop(0)
            tokens.append((last + first, lp + lq))
        return tokens + reply

    def echo(self, body: dict) -> dict:
        """A text completion echoing the request's prompt with its tokens' log-probabilities (the module docstring)."""
        prompt = str(body["prompt"])
        if "<|im_start|>" not in prompt and self.raw_reply_after in prompt:  # raw text, as lm-eval sends it
            head, sep, reply = prompt.rpartition(self.raw_reply_after)
            messages = [{"role": "user", "content": head + sep}, {"role": "assistant", "content": reply}]
            law = self.law(dict(body, messages=messages, continue_final_message=True))
            tokens = [(t, -1.0) for t in re.findall(r"\S+|\s", head + sep)] + self.law_tokens(law, reply)
        else:
            head, sep, reply = prompt.rpartition("<|im_start|>assistant\n")
            turns = re.findall(r"<\|im_start\|>(\w+)\n(.*?)<\|im_end\|>\n", head, re.S)
            messages = [{"role": r, "content": c} for r, c in turns] + [{"role": "assistant", "content": reply}]
            tokens = self.prompt_tokens({"messages": messages, "continue_final_message": True})
        assert "".join(t for t, _ in tokens) == prompt, "the stand-in reads ChatML only"
        if int(body.get("max_tokens") or 0) > 0:
            tokens.append(("<gen>", -0.5))
        offsets = [0]
        for token, _ in tokens[:-1]:
            offsets.append(offsets[-1] + len(token))
        values = [None] + [lp for _, lp in tokens[1:]]
        return {
            "id": f"cmpl-{time.monotonic_ns()}",
            "object": "text_completion",
            "model": self.model or body.get("model") or "test-model",
            "choices": [
                {
                    "index": 0,
                    "text": "".join(t for t, _ in tokens),
                    "finish_reason": "length",
                    "logprobs": {
                        "tokens": [t for t, _ in tokens],
                        "token_logprobs": values,
                        "top_logprobs": [None] + [{t: lp} for t, lp in tokens[1:]],
                        "text_offset": offsets,
                    },
                }
            ],
        }

    def prompt_logprobs(self, body: dict) -> list:
        """vLLM's ``prompt_logprobs`` of the request's rendered prompt (the module docstring)."""
        tokens = self.prompt_tokens(body)
        k = int(body.get("prompt_logprobs") or 0)
        out: list = [None]
        for token, lp in tokens[1:]:
            entry = {str(_token_id(token)): {"logprob": lp, "rank": 1 + (lp < -1e-12), "decoded_token": token}}
            for r, other in enumerate(("<alt-a>", "<alt-b>", "<alt-c>")[:k], start=2):
                entry[str(_token_id(other))] = {"logprob": -20.0 - r, "rank": r, "decoded_token": other}
            out.append(entry)
        return out

    # --- per request -----------------------------------------------------------------------

    def _record(self, method: str, path: str, headers: dict, body: Any) -> None:
        with self._lock:
            self.requests.append({"method": method, "path": path, "headers": headers, "json": body})

    def _count_chat(self) -> int:
        with self._lock:
            self.n_chat += 1
            return self.n_chat

    def _next_fault(self, n: int, body: Any) -> Fault | None:
        with self._lock:
            if self._faults:
                return self._faults.popleft()
        return self.fault_fn(n, body) if self.fault_fn is not None else None

    def _enter(self) -> None:
        with self._lock:
            self.in_flight += 1
            self.max_in_flight = max(self.max_in_flight, self.in_flight)

    def _leave(self) -> None:
        with self._lock:
            self.in_flight -= 1


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    request_queue_size = 64

    def handle_error(self, request, client_address) -> None:  # a client that hung up is not an error here
        pass


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    timeout = 10  # idle keep-alive connections end after this
    disable_nagle_algorithm = True  # no 40 ms delayed-ACK stalls on keep-alive connections
    wbufsize = -1  # buffered: headers and body leave in one write at flush
    server_state: ChatServer

    def log_message(self, format: str, *args: Any) -> None:  # quiet
        pass

    # --- routes ----------------------------------------------------------------------------

    def do_GET(self) -> None:
        state = self.server_state
        state._record("GET", self.path, self._headers(), None)
        if self.path.split("?")[0] == "/v1/models":
            model = state.model or "test-model"
            self._send_json(
                200, {"object": "list", "data": [{"id": model, "object": "model", "owned_by": "fairaudit-tests"}]}
            )
        elif self.path.split("?")[0] == "/props" and state.props is not None:
            self._send_json(200, state.props)
        else:
            self._send_error(404, f"Unknown path {self.path}", "not_found")

    def do_POST(self) -> None:
        state = self.server_state
        length = int(self.headers.get("Content-Length") or 0)
        raw = self.rfile.read(length) if length else b""
        try:
            body = json.loads(raw) if raw else None
        except ValueError:
            body = None
        state._record("POST", self.path, self._headers(), body)
        if self.path.split("?")[0] == "/v1/completions" and state.completions:
            if not isinstance(body, dict) or not isinstance(body.get("prompt"), str) or not body.get("echo"):
                self._send_error(400, "this stand-in answers echo requests with a prompt only", "invalid_request_error")
                return
            code = state.completion_fault_fn(body) if state.completion_fault_fn is not None else None
            if code is not None:
                self._send_error(code, f"Injected HTTP {code}", "server_error")
                return
            self._send_json(200, state.echo(body))
            return
        if self.path.split("?")[0] != "/v1/chat/completions" or not state.chat:
            self._send_error(404, f"Unknown path {self.path}", "not_found")
            return
        n = state._count_chat()
        if state.required_key is not None and self.headers.get("Authorization") != f"Bearer {state.required_key}":
            self._send_error(401, "Incorrect API key provided.", "invalid_api_key")
            return
        if not isinstance(body, dict) or not isinstance(body.get("messages"), list):
            self._send_error(400, "'messages' is a required property", "invalid_request_error")
            return
        asks_prompt = body.get("prompt_logprobs") is not None and state.law is not None
        if asks_prompt and state.prompt_logprobs_mode == "reject":
            self._send_error(400, "Unrecognized request argument supplied: prompt_logprobs", "invalid_request_error")
            return
        fault = state._next_fault(n, body)
        state._enter()
        try:
            response = self._respond(fault, body)
        finally:
            state._leave()  # before the reply is written: the client still holds its slot
        if response is None:  # ("drop",): close without a response
            self.close_connection = True
            return
        self._send_raw(*response)

    def _respond(self, fault: Fault | None, body: dict) -> tuple | None:
        """(status, payload, content type, headers) for this request, or None to drop the connection."""
        state = self.server_state
        if fault is not None and fault[0] == "sleep":
            state._stop.wait(fault[1])
            fault = None
        if fault is None or fault[0] == "reply":
            try:
                text = fault[1] if fault is not None else state.responder(body)
                asks = body.get("logprobs") and state.chat_logprobs
                top = state.logprobs(body) if state.logprobs is not None and asks else None
            except Exception as exc:  # a broken responder is a 500, visible to the client
                return _error(500, f"responder failed: {exc!r}", "server_error")
            completion = _completion(body, text, state.model, top)
            if (
                body.get("prompt_logprobs") is not None
                and state.law is not None
                and state.prompt_logprobs_mode == "serve"
                and state.chat_logprobs
            ):
                completion["prompt_logprobs"] = state.prompt_logprobs(body)
            return 200, json.dumps(completion).encode(), "application/json", {}
        if fault[0] == "drop":
            return None
        if fault[0] == "status":
            code = fault[1]
            headers = fault[2] if len(fault) > 2 else {}
            message = fault[3] if len(fault) > 3 else f"Injected HTTP {code}"
            return _error(code, message, "injected", headers)
        if fault[0] == "malformed":
            return 200, b'{"choices": [ this is not json', "application/json", {}
        if fault[0] == "json":
            return 200, json.dumps(fault[1]).encode(), "application/json", {}
        return _error(500, f"unknown test fault {fault!r}", "server_error")

    # --- helpers ---------------------------------------------------------------------------

    def _headers(self) -> dict:
        return {k: ("<redacted>" if k.lower() == "authorization" else v) for k, v in self.headers.items()}

    def _send_error(self, code: int, message: str, kind: str, headers: dict | None = None) -> None:
        self._send_raw(*_error(code, message, kind, headers))

    def _send_json(self, code: int, obj: Any, headers: dict | None = None) -> None:
        self._send_raw(code, json.dumps(obj).encode("utf-8"), "application/json", headers)

    def _send_raw(self, code: int, payload: bytes, content_type: str, headers: dict | None = None) -> None:
        try:
            self.send_response(code)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(payload)))
            for name, value in (headers or {}).items():
                self.send_header(name, value)
            self.end_headers()
            self.wfile.write(payload)
            self.wfile.flush()
        except OSError:  # the client gave up (e.g. after its timeout)
            self.close_connection = True


def _token_id(token: str) -> int:
    """A token's id in the stand-in's vocabulary (a hash of its text)."""
    return zlib.crc32(token.encode()) % 150_000


def _error(code: int, message: str, kind: str, headers: dict | None = None) -> tuple:
    """An OpenAI-style error response: (status, payload, content type, headers)."""
    body = {"error": {"message": message, "type": kind, "param": None, "code": code}}
    return code, json.dumps(body).encode(), "application/json", headers or {}


def _completion(request: dict, text: str, model: str | None, top: list[tuple[str, float]] | None = None) -> dict:
    """An OpenAI chat.completion object with ``text`` as the assistant's reply (and ``top`` as its logprobs)."""
    prompt_tokens = sum(len(str(m.get("content", "")).split()) for m in request["messages"] if isinstance(m, dict))
    completion_tokens = len(text.split())
    return {
        "id": f"chatcmpl-{time.monotonic_ns()}",
        "object": "chat.completion",
        "created": int(time.time()),
        "model": model or request.get("model") or "test-model",
        "choices": [
            {
                "index": 0,
                "message": {"role": "assistant", "content": text},
                "finish_reason": "stop",
                **({} if top is None else {"logprobs": _logprobs(request, top)}),
            }
        ],
        "usage": {
            "prompt_tokens": prompt_tokens,
            "completion_tokens": completion_tokens,
            "total_tokens": prompt_tokens + completion_tokens,
        },
    }


def _logprobs(request: dict, top: list[tuple[str, float]]) -> dict:
    """``choices[0].logprobs`` as OpenAI sends it: the first token, with the request's ``top_logprobs`` most likely."""
    ranked = sorted(top, key=lambda entry: -entry[1])[: max(0, int(request.get("top_logprobs") or 0))]
    entries = [{"token": t, "logprob": lp, "bytes": list(t.encode())} for t, lp in ranked]
    first = entries[0] if entries else {"token": "", "logprob": 0.0, "bytes": []}
    return {"content": [{**first, "top_logprobs": entries}], "refusal": None}
