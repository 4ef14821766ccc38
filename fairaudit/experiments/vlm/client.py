"""A client for any OpenAI-compatible chat-completions endpoint.

:class:`ChatClient` sends one chat completion per :meth:`ChatClient.complete`
call to ``{endpoint}/chat/completions`` (OpenAI, vLLM, llama.cpp, Ollama,
LM Studio, ...), with

* retries with exponential backoff (``backoff * 2**k`` seconds, capped at
  ``max_backoff``, plus up to 10 % jitter; a ``Retry-After`` header is honoured
  instead, also capped) on HTTP 429, 500, 502, 503 and 504, on timeouts and on
  connection errors; never on other statuses (400, 401, 403, 404, 422, ...)
  nor on a malformed 200 reply;
* at most ``max_concurrency`` requests in flight across all threads that share
  the client;
* the API key sent only as ``Authorization: Bearer ...``: it never appears in
  an error message, a ``repr``, a log record or a returned object.

It needs the extra ``fairness-certify[vlm]`` (httpx and tenacity), imported when a
client is built, so this module imports without them.
"""

from __future__ import annotations

import json
import logging
import math
import random
import re
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from email.utils import parsedate_to_datetime
from numbers import Integral
from typing import Any
from urllib.parse import urlsplit, urlunsplit

from fairaudit import FairauditError, InputError, choice, optional_modules, real, whole

from .logprobs import echo_token_logprobs, first_token_logprobs, prompt_token_logprobs

__all__ = [
    "CONSTRAINTS",
    "RETRY_STATUSES",
    "ChatClient",
    "ChatError",
    "ChatReply",
    "constraint_body",
    "gbnf_choice",
]

CONSTRAINTS = ("none", "json-schema", "guided-choice", "grammar")
"""How a request may ask the server to reply with one of a set of texts only (:func:`constraint_body`)."""

RETRY_STATUSES = frozenset({429, 500, 502, 503, 504})
"""HTTP statuses that are retried; every other non-2xx status fails at once."""

_log = logging.getLogger(__name__)
_MESSAGE_CHARS = 200


class ChatError(FairauditError):
    """A chat completion that failed after its retries, or at once on a non-retryable error.

    Parameters
    ----------
    message : str
        One line naming the endpoint URL and the problem (never the API key).
    kind : {"http", "timeout", "connection", "protocol"}
        ``"http"``: a non-2xx status (``status`` holds it); ``"timeout"``: no
        reply within the timeout; ``"connection"``: the connection failed or
        was dropped; ``"protocol"``: a 2xx reply that is not a chat completion
        (not JSON, or no ``choices[0].message.content``).
    status : int or None
        The HTTP status of the last attempt, None when there was no reply.
    attempts : int
        How many requests were sent (1 = no retry).
    url : str
        The chat-completions URL (without query string).
    """

    def __init__(self, message: str, kind: str, status: int | None = None, attempts: int = 1, url: str = "") -> None:
        super().__init__(message)
        self.kind = kind
        self.status = status
        self.attempts = attempts
        self.url = url

    def __reduce__(self) -> tuple[type[ChatError], tuple[str, str, int | None, int, str]]:
        return (type(self), (str(self), self.kind, self.status, self.attempts, self.url))


@dataclass(frozen=True, kw_only=True)
class ChatReply:
    """One successful chat completion.

    Attributes
    ----------
    text : str
        ``choices[0].message.content`` (text parts joined by newlines; null gives ``""``), or a text
        completion's ``choices[0].text`` (:meth:`ChatClient.echo`).
    model : str
        The model named in the reply, else the requested one.
    finish_reason : str or None
        ``choices[0].finish_reason`` (``"stop"``, ``"length"``, ...).
    usage : dict or None
        The reply's ``usage`` object (token counts), when present.
    attempts : int
        How many requests were sent, 1 when the first succeeded.
    latency : float
        Seconds taken by the successful attempt.
    status : int
        The HTTP status of the successful attempt (200).
    top_logprobs : tuple of (str, float), optional
        With a client made with ``top_logprobs``: the first token's most likely tokens and their
        log-probabilities (nats) (:func:`fairaudit.experiments.vlm.logprobs.first_token_logprobs`), else None.
    prompt_logprobs : tuple of (str, float), optional
        The prompt's tokens and their log-probabilities (nats) when the server returned them
        (:func:`~fairaudit.experiments.vlm.logprobs.prompt_token_logprobs`, :meth:`ChatClient.echo`), else None.
    """

    text: str
    model: str
    finish_reason: str | None
    usage: dict | None
    attempts: int
    latency: float
    status: int = 200
    top_logprobs: tuple[tuple[str, float], ...] | None = None
    prompt_logprobs: tuple[tuple[str, float], ...] | None = None


class _Failure(Exception):
    """One failed attempt (internal): becomes a :class:`ChatError` when it is the last."""

    def __init__(self, kind: str, problem: str, status: int | None = None, retry_after: float | None = None) -> None:
        super().__init__(problem)
        self.kind = kind
        self.problem = problem
        self.status = status
        self.retry_after = retry_after

    @property
    def retryable(self) -> bool:
        return self.kind in ("timeout", "connection") or (self.kind == "http" and self.status in RETRY_STATUSES)


class ChatClient:
    """A thread-safe client for an OpenAI-compatible chat-completions endpoint.

    Parameters
    ----------
    endpoint : str
        The API's base URL, for example ``http://127.0.0.1:8000/v1`` or
        ``https://api.openai.com/v1`` (a trailing slash is fine); requests go
        to ``{endpoint}/chat/completions``. A URL that already ends in
        ``/chat/completions`` is used as it is; a query string is kept.
        Scheme http or https, no user name or password in the URL.
    model : str
        The model name sent in every request; non-empty.
    api_key : str, optional
        The API key; default: the environment variable ``api_key_env``. When
        neither is set no ``Authorization`` header is sent (local servers).
        Printable ASCII without spaces.
    api_key_env : str
        The environment variable read when ``api_key`` is None.
    timeout : float
        Seconds allowed for connecting, sending and for the reply; > 0.
    max_retries : int
        Retries after the first attempt; >= 0.
    backoff, max_backoff : float
        The wait before retry k (k = 0, 1, ...) is ``min(max_backoff,
        backoff * 2**k)`` plus up to 10 % jitter (never above ``max_backoff``);
        a ``Retry-After`` header (seconds or an HTTP date) replaces it, capped
        at ``max_backoff``. Both >= 0.
    max_concurrency : int
        Requests in flight at once across all threads; >= 1.
    temperature : float, optional
        Sent as ``temperature`` when given; finite and >= 0.
    top_p : float, optional
        Sent as ``top_p`` when given; in (0, 1].
    max_tokens : int, optional
        Sent as ``max_tokens`` when given; >= 1.
    top_logprobs : int, optional
        When given (>= 1), every request asks for log-probabilities
        (``logprobs: true``, ``top_logprobs``: this many most likely tokens per
        position) and every reply carries its first token's in
        :attr:`ChatReply.top_logprobs`.
    extra_body : dict, optional
        More JSON fields for every request body (``top_p``,
        ``response_format``, ...); may not set ``model`` or ``messages``.

    Raises
    ------
    InputError
        Naming an invalid argument, or ``vlm`` when httpx or tenacity is missing.

    Notes
    -----
    One ``httpx.Client`` per ChatClient, shared by all threads; close it with
    :meth:`close` or use the client as a context manager.
    """

    def __init__(
        self,
        endpoint: str,
        model: str,
        *,
        api_key: str | None = None,
        api_key_env: str = "OPENAI_API_KEY",
        timeout: float = 60.0,
        max_retries: int = 5,
        backoff: float = 1.0,
        max_backoff: float = 60.0,
        max_concurrency: int = 4,
        temperature: float | None = None,
        top_p: float | None = None,
        max_tokens: int | None = None,
        top_logprobs: int | None = None,
        extra_body: dict | None = None,
    ) -> None:
        self._url, self.endpoint = _chat_url(endpoint)
        if not isinstance(model, str) or not model.strip():
            raise InputError("model", "must be a non-empty model name", model)
        self.model = model.strip()
        self.timeout = real(timeout, "timeout", low=0.0, low_open=True)
        self.max_retries = whole(max_retries, "max_retries")
        self.backoff = real(backoff, "backoff", low=0.0)
        self.max_backoff = real(max_backoff, "max_backoff", low=0.0)
        self.max_concurrency = whole(max_concurrency, "max_concurrency", low=1)
        self.temperature = None if temperature is None else real(temperature, "temperature", low=0.0)
        self.top_p = None if top_p is None else real(top_p, "top_p", low=0.0, low_open=True, high=1.0)
        self.max_tokens = None if max_tokens is None else whole(max_tokens, "max_tokens", low=1)
        self.top_logprobs = None if top_logprobs is None else whole(top_logprobs, "top_logprobs", low=1)
        self.extra_body = _extra_body(extra_body)
        self._key = _api_key(api_key, api_key_env)
        self._headers = {"Content-Type": "application/json", "Accept": "application/json"}
        if self._key is not None:
            self._headers["Authorization"] = f"Bearer {self._key}"

        httpx, tenacity = optional_modules("vlm", "needs pip install 'fairness-certify[vlm]'", "httpx", "tenacity")
        self._httpx = httpx
        self._tenacity = tenacity
        self._slots = threading.BoundedSemaphore(self.max_concurrency)
        self._http = httpx.Client(
            timeout=httpx.Timeout(self.timeout),
            limits=httpx.Limits(max_connections=self.max_concurrency, max_keepalive_connections=self.max_concurrency),
            follow_redirects=False,
            trust_env=True,
        )
        self._closed = False

    def __repr__(self) -> str:
        return f"ChatClient(endpoint={self.endpoint!r}, model={self.model!r})"

    def __enter__(self) -> ChatClient:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection pool; later :meth:`complete` calls raise InputError. Idempotent."""
        if not self._closed:
            self._closed = True
            self._http.close()

    def complete(self, messages: list[dict], *, seed: int | None = None, extra: dict | None = None) -> ChatReply:
        """One chat completion, with retries.

        Parameters
        ----------
        messages : list of dict
            OpenAI chat messages, each with a ``role`` (:mod:`fairaudit.experiments.vlm.messages`).
        seed : int, optional
            Sent as ``seed`` (servers that support it sample reproducibly).
        extra : dict, optional
            More request fields for this request only, after the client's ``extra_body``.

        Returns
        -------
        ChatReply

        Raises
        ------
        ChatError
            After the last attempt, or at once on a non-retryable error (:class:`ChatError`'s ``kind``).
        InputError
            When ``messages`` or ``seed`` is invalid, or the client is closed.
        """
        if self._closed:
            raise InputError("client", "is closed")
        return self._send(self._url, self._body(messages, seed, _extra_body(extra)), None)

    def echo(self, prompt: str) -> ChatReply:
        """The log-probabilities of ``prompt``'s own tokens from the server's text completions, with retries.

        Sends ``{"model", "prompt", "echo": true, "logprobs": 1, "max_tokens": 0, "temperature": 0}`` to
        ``{endpoint}/completions`` (the OpenAI-compatible text completions that vLLM serves, and OpenAI's legacy
        ones), which score the prompt and generate nothing; the client's sampling settings and ``extra_body``
        belong to chat requests and are not sent.

        Parameters
        ----------
        prompt : str
            The text to score, non-empty.

        Returns
        -------
        ChatReply
            ``text`` is ``choices[0].text`` (the echoed prompt); :attr:`ChatReply.prompt_logprobs` the prompt's
            tokens and their log-probabilities (:func:`~fairaudit.experiments.vlm.logprobs.echo_token_logprobs`).

        Raises
        ------
        ChatError, InputError
            As :meth:`complete` (a server without text completions answers 404); an empty ``prompt``.
        """
        if self._closed:
            raise InputError("client", "is closed")
        if not isinstance(prompt, str) or not prompt:
            raise InputError("prompt", "must be a non-empty string", prompt)
        body = {"model": self.model, "prompt": prompt, "echo": True, "logprobs": 1, "max_tokens": 0, "temperature": 0}
        content = json.dumps(body, ensure_ascii=False).encode("utf-8")
        return self._send(_completions_url(self._url), content, prompt)

    def _send(self, url: str, content: bytes, prompt: str | None) -> ChatReply:
        """POST ``content`` to ``url`` with retries: a chat completion, or a text completion of ``prompt``."""
        tenacity = self._tenacity
        retrying = tenacity.Retrying(
            stop=tenacity.stop_after_attempt(self.max_retries + 1),
            wait=self._wait,
            retry=tenacity.retry_if_exception(lambda exc: isinstance(exc, _Failure) and exc.retryable),
            before_sleep=self._log_retry,
            reraise=True,
        )
        attempts = 0
        try:
            for attempt in retrying:
                with attempt:
                    attempts = attempt.retry_state.attempt_number
                    return self._attempt(url, content, attempts, prompt)
        except _Failure as exc:
            failure = exc
        # raised outside the except block: no chained exception (which could carry the request) is kept
        raise self._error(failure, attempts)

    # ------------------------------------------------------------------------------------------

    def is_llama_server(self) -> bool:
        """True when the server answers llama.cpp's ``GET /props`` (its default generation settings), else False.

        llama-server reuses a cached prompt prefix, and its log-probabilities then depend on what it computed before
        (a quantized model: up to 0.04 in a probability, measured); an exact route sends ``cache_prompt: false``
        to it.
        """
        parts = urlsplit(self._url)
        try:
            response = self._http.get(urlunsplit((parts.scheme, parts.netloc, "/props", "", "")), timeout=5.0)
            data = response.json() if response.status_code == 200 else None
        except Exception:  # noqa: BLE001 - any failure means: not a llama-server we can recognise
            return False
        return isinstance(data, dict) and "default_generation_settings" in data

    def _body(self, messages: Any, seed: Any, extra: dict | None = None) -> bytes:
        if not isinstance(messages, (list, tuple)) or not messages:
            raise InputError("messages", "must be a non-empty list of chat messages", messages)
        for i, message in enumerate(messages):
            if not isinstance(message, dict) or not isinstance(message.get("role"), str):
                raise InputError(f"messages[{i}]", "must be a dict with a 'role'", message)
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, Integral)):
            raise InputError("seed", "must be an integer or None", seed)
        seed = None if seed is None else int(seed)
        sampling = {"seed": seed, "temperature": self.temperature, "top_p": self.top_p, "max_tokens": self.max_tokens}
        if self.top_logprobs is not None:
            sampling |= {"logprobs": True, "top_logprobs": self.top_logprobs}
        body = {"model": self.model, "messages": list(messages)} | {k: v for k, v in sampling.items() if v is not None}
        body |= self.extra_body | (extra or {})  # the request's own fields last
        try:
            return json.dumps(body, ensure_ascii=False, allow_nan=False).encode("utf-8")
        except (TypeError, ValueError):
            raise InputError("messages", "must be JSON-serialisable (bytes? use user_message for images)") from None

    def _attempt(self, url: str, content: bytes, attempt: int, prompt: str | None) -> ChatReply:
        httpx = self._httpx
        problem: _Failure | None = None
        with self._slots:
            start = time.perf_counter()
            try:
                response = self._http.post(url, content=content, headers=self._headers)
            except httpx.TimeoutException:
                problem = _Failure("timeout", f"no reply within {self.timeout:g} s")
            except httpx.DecodingError as exc:
                problem = _Failure("protocol", f"undecodable reply ({self._clean(str(exc))})")
            except httpx.HTTPError as exc:
                problem = _Failure("connection", f"connection failed ({type(exc).__name__}: {self._clean(str(exc))})")
            latency = time.perf_counter() - start
        if problem is not None:
            raise problem
        status = response.status_code
        if not 200 <= status < 300:
            retry_after = _retry_after(response.headers.get("retry-after")) if status in RETRY_STATUSES else None
            reason = response.reason_phrase or ""
            message = self._server_message(response)
            text = f"HTTP {status}" + (f" {reason}" if reason else "") + (f": {message}" if message else "")
            raise _Failure("http", text, status, retry_after)
        return self._reply(response, attempt, latency, prompt)

    def _reply(self, response: Any, attempt: int, latency: float, prompt: str | None = None) -> ChatReply:
        status = response.status_code
        try:
            data = json.loads(response.content)
        except (ValueError, RecursionError):
            snippet = self._clean(response.content[:80].decode("utf-8", "replace"))
            raise _Failure("protocol", f"HTTP {status} reply is not JSON (starts {snippet!r})", status) from None
        choices = data.get("choices") if isinstance(data, dict) else None
        if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
            raise _Failure("protocol", f"HTTP {status} reply has no choices[0]", status)
        choice = choices[0]
        if prompt is not None:  # a text completion: the echoed prompt and its tokens' log-probabilities
            text = choice.get("text")
            if not isinstance(text, str):
                raise _Failure("protocol", f"HTTP {status} reply has no choices[0].text", status)
        else:
            message = choice.get("message")
            if not isinstance(message, dict) or "content" not in message:
                raise _Failure("protocol", f"HTTP {status} reply has no choices[0].message.content", status)
            text = _content_text(message["content"])
            if text is None:
                kind = type(message["content"]).__name__
                raise _Failure(
                    "protocol", f"HTTP {status} reply's choices[0].message.content is a {kind}, not text", status
                )
        model, finish, usage = data.get("model"), choice.get("finish_reason"), data.get("usage")
        return ChatReply(
            text=text,
            model=model if isinstance(model, str) and model else self.model,
            finish_reason=finish if isinstance(finish, str) and prompt is None else None,
            usage=usage if isinstance(usage, dict) else None,
            attempts=attempt,
            latency=latency,
            status=status,
            top_logprobs=first_token_logprobs(data) if self.top_logprobs is not None and prompt is None else None,
            prompt_logprobs=prompt_token_logprobs(data) if prompt is None else echo_token_logprobs(data, prompt),
        )

    def _server_message(self, response: Any) -> str:
        """The server's error message (OpenAI ``{"error": {"message": ...}}`` and common variants), one line, clipped."""
        message = None
        try:
            data = json.loads(response.content)
        except (ValueError, RecursionError):
            data = None
        if isinstance(data, dict):
            error = data.get("error")
            said = (error.get("message") if isinstance(error, dict) else error, data.get("message"), data.get("detail"))
            message = next((m for m in said if isinstance(m, str)), None)
        if message is None:
            message = response.content[: 4 * _MESSAGE_CHARS].decode("utf-8", "replace")
        message = self._clean(message)
        return message if len(message) <= _MESSAGE_CHARS else message[: _MESSAGE_CHARS - 3] + "..."

    def _clean(self, text: str) -> str:
        """``text`` on one line, with the API key masked (servers may echo it)."""
        if self._key:
            text = text.replace(self._key, "***")
        return " ".join(text.split())

    def _error(self, failure: _Failure, attempts: int) -> ChatError:
        tries = f"{attempts} attempt" + ("s" if attempts != 1 else "")
        message = self._clean(f"{self.endpoint}: {failure.problem} ({tries})")
        return ChatError(message, failure.kind, failure.status, attempts, self.endpoint)

    def _wait(self, retry_state: Any) -> float:
        failure = retry_state.outcome.exception() if retry_state.outcome is not None else None
        if isinstance(failure, _Failure) and failure.retry_after is not None:
            return min(failure.retry_after, self.max_backoff)
        base = self.backoff * 2.0 ** (retry_state.attempt_number - 1)
        return min(self.max_backoff, base * (1.0 + 0.1 * random.random()))

    def _log_retry(self, retry_state: Any) -> None:
        failure = retry_state.outcome.exception() if retry_state.outcome is not None else None
        wait = retry_state.next_action.sleep if retry_state.next_action is not None else 0.0
        problem = self._clean(failure.problem) if isinstance(failure, _Failure) else "error"
        _log.info("%s: %s (attempt %d); retrying in %.2f s", self.endpoint, problem, retry_state.attempt_number, wait)


def constraint_body(mode: str, replies: Sequence[str], name: str = "decision") -> dict:
    """The request fields that ask a server to reply with one of ``replies`` only.

    Parameters
    ----------
    mode : {"none", "json-schema", "guided-choice", "grammar"}
        ``"json-schema"``: OpenAI's structured outputs, ``response_format`` with a strict JSON schema whose one
        field ``answer`` is one of ``replies`` (the reply is ``{"answer": "..."}``; OpenAI, vLLM, llama-server);
        ``"guided-choice"``: vLLM's ``guided_choice`` (the reply is one of ``replies``); ``"grammar"``:
        llama.cpp's ``grammar``, a GBNF grammar whose root is one of ``replies`` (:func:`gbnf_choice`);
        ``"none"``: no field.
    replies : sequence of str
        The allowed replies, non-empty, distinct (not read for ``"none"``).
    name : str
        The schema's name (``json-schema`` only): letters, digits, ``_`` and ``-``.

    Returns
    -------
    dict
        Fields to merge into the request body (``ChatClient(extra_body=...)``); empty for ``"none"``.

    Raises
    ------
    InputError
        An unknown ``mode`` (naming ``constrain``), or ``replies`` empty, repeated or not strings.

    Examples
    --------
    >>> constraint_body("guided-choice", ["yes", "no"])
    {'guided_choice': ['yes', 'no']}
    >>> constraint_body("grammar", ["yes", "no"])
    {'grammar': 'root ::= "yes" | "no"'}
    """
    choice(mode, "constrain", CONSTRAINTS)
    if mode == "none":
        return {}
    texts = list(replies)
    if not texts or not all(isinstance(t, str) and t for t in texts) or len(set(texts)) != len(texts):
        raise InputError("replies", "must be distinct non-empty strings", texts)
    if mode == "guided-choice":
        return {"guided_choice": texts}
    if mode == "grammar":
        return {"grammar": gbnf_choice(texts)}
    schema = {
        "type": "object",
        "properties": {"answer": {"type": "string", "enum": texts}},
        "required": ["answer"],
        "additionalProperties": False,
    }
    return {"response_format": {"type": "json_schema", "json_schema": {"name": name, "strict": True, "schema": schema}}}


_GBNF_ESCAPES = {"\\": "\\\\", '"': '\\"', "\n": "\\n", "\r": "\\r", "\t": "\\t"}


def gbnf_choice(replies: Sequence[str]) -> str:
    """A llama.cpp GBNF grammar whose only sentences are ``replies``: ``root ::= "a" | "b"``.

    Each reply is a GBNF string literal: a backslash, a double quote, a newline, a carriage return and a tab are
    escaped (``\\\\``, ``\\"``, ``\\n``, ``\\r``, ``\\t``), other control characters as ``\\xHH``; the rest is
    written as it is (GBNF literals are UTF-8).

    Examples
    --------
    >>> print(gbnf_choice(['say "no"', "a\\\\b"]))
    root ::= "say \\"no\\"" | "a\\\\b"
    """

    def char(ch: str) -> str:
        return _GBNF_ESCAPES.get(ch) or (f"\\x{ord(ch):02X}" if ord(ch) < 0x20 or ord(ch) == 0x7F else ch)

    return "root ::= " + " | ".join('"' + "".join(map(char, t)) + '"' for t in replies)


# ----------------------------------------------------------------------------------------------
# validation and helpers


def _chat_url(endpoint: Any) -> tuple[str, str]:
    """The request URL and its display form (no query) for ``endpoint``."""
    hint = "must be an http(s) URL such as http://127.0.0.1:8000/v1"
    if not isinstance(endpoint, str) or not endpoint.strip():
        raise InputError("endpoint", hint, endpoint)
    try:
        parts = urlsplit(endpoint.strip())
        parts.port  # noqa: B018 - raises ValueError on a bad port
    except ValueError:
        raise InputError("endpoint", hint) from None
    if parts.username is not None or parts.password is not None:
        raise InputError(
            "endpoint", "must not contain a user name or password (pass the key with api_key or the environment)"
        )
    if parts.scheme.lower() not in ("http", "https") or not parts.hostname:
        raise InputError("endpoint", hint, urlunsplit((parts.scheme, parts.netloc, parts.path, "", "")))
    path = parts.path.rstrip("/").removesuffix("/chat/completions") + "/chat/completions"
    scheme = parts.scheme.lower()
    return urlunsplit((scheme, parts.netloc, path, parts.query, "")), urlunsplit((scheme, parts.netloc, path, "", ""))


def _completions_url(chat_url: str) -> str:
    """The text completions' URL beside a chat completions' URL: ``.../chat/completions`` becomes ``.../completions``.

    >>> _completions_url("http://127.0.0.1:8000/v1/chat/completions?x=1")
    'http://127.0.0.1:8000/v1/completions?x=1'
    """
    parts = urlsplit(chat_url)
    path = parts.path.removesuffix("/chat/completions") + "/completions"
    return urlunsplit((parts.scheme, parts.netloc, path, parts.query, ""))


def _extra_body(extra: Any) -> dict:
    if extra is None:
        return {}
    if not isinstance(extra, dict) or not all(isinstance(k, str) for k in extra):
        raise InputError("extra_body", "must be a dict with string keys", extra)
    reserved = sorted({"model", "messages"} & set(extra))
    if reserved:
        raise InputError("extra_body", f"must not set {', '.join(reserved)}", extra)
    try:
        json.dumps(extra, allow_nan=False)
    except (TypeError, ValueError):
        raise InputError("extra_body", "must be JSON-serialisable", extra) from None
    return dict(extra)


def _api_key(api_key: Any, env: Any) -> str | None:
    import os

    if api_key is not None:
        if not isinstance(api_key, str) or not re.fullmatch(r"[\x21-\x7e]+", api_key):
            raise InputError("api_key", "must be a non-empty string of printable ASCII without spaces")
        return api_key
    if not isinstance(env, str) or not env:
        raise InputError("api_key_env", "must be the name of an environment variable", env)
    value = os.environ.get(env, "").strip()
    if value and not re.fullmatch(r"[\x21-\x7e]+", value):
        raise InputError(f"environment variable {env}", "must be printable ASCII without spaces")
    return value or None  # unset or blank: no Authorization header


def _retry_after(value: str | None) -> float | None:
    """Seconds to wait from a ``Retry-After`` header (seconds or an HTTP date); None when absent or invalid."""
    if value is None:
        return None
    try:
        seconds = float(value)
    except ValueError:
        try:
            when = parsedate_to_datetime(value)
        except (TypeError, ValueError, IndexError):
            return None
        if when.tzinfo is None:
            return None
        seconds = when.timestamp() - time.time()
    return max(0.0, seconds) if math.isfinite(seconds) else None


def _content_text(content: Any) -> str | None:
    """A message content as text: a string, null (``""``) or a list of parts (text parts joined); else None."""
    if content is None:
        return ""
    if isinstance(content, str):
        return content
    if isinstance(content, list):
        parts = [{"text": part} if isinstance(part, str) else part for part in content]  # a string is a text part
        return "\n".join(
            part["text"]
            for part in parts
            if isinstance(part, dict)
            and isinstance(part.get("text"), str)
            and part.get("type", "text") in ("text", "output_text")
        )
    return None
