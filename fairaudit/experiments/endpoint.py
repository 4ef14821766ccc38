"""An endpoint's exact kernel: P(decision | shown cell) from the log-probabilities of its replies' tokens.

First-token scoring (a choice, or an order of two): one request per prompt, its first token's top
log-probabilities read as P(decision) (:func:`~fairaudit.experiments.vlm.logprobs.decision_probabilities`).
Continuation scoring: P(the reply begins with r) = Π_t P(r_t | prompt, r_<t), the chain rule
(lm-evaluation-harness's ``loglikelihood``), for each variant r of each decision's text, summed per decision
(:func:`~fairaudit.experiments.variants.prompt_variants`, the prefix rule applied), by the first of these routes (:data:`SCORING_ROUTES`) the server serves:

1. ``"prompt-logprobs"`` (vLLM): one request per (prompt, reply), the reply sent as the assistant's message being
   continued (:data:`PREFILL`) with ``prompt_logprobs: 0``; the reply's tokens are the prompt's last. Exact.
2. ``"top-logprobs"`` (llama-server): one request per prefix of the replies, each prefix once
   (:func:`~fairaudit.experiments.vlm.logprobs.reply_bounds`). Lower bounds, exact when the lists hold every token
   of the replies; :attr:`ExactKernel.missing` bounds what they may lack.
3. ``"completions-echo"`` (text completions that echo the prompt's log-probabilities): one request per (prompt,
   reply) to ``/v1/completions``, the messages rendered in ChatML (:func:`~fairaudit.experiments.vlm.messages.chatml`)
   followed by the reply. Exact under that rendering, which ``run.scoring.rendering`` records.

The route is chosen once per run by a probe, the first prompt's first request, which asks for
``prompt_logprobs`` too (:func:`_probe`). The mass on no option, 1 − Σ P(r), is the cell's ``unparsed``. A cell
whose candidates have several texts averages over every choice of them
(:func:`fairaudit.experiments.exact.exact_prompts`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from fairaudit import InputError, progress_bar

from .exact import ExactPrompt, by_sequence, exact_prompt, exact_prompts, prompt_replies
from .harness import RunSummary
from .variants import decision_row, prompt_variants
from .vlm.client import ChatError
from .vlm.logprobs import decision_probabilities, reply_bounds, reply_logprob
from .vlm.messages import CHATML, chatml

if TYPE_CHECKING:
    import numpy.typing as npt

    from fairaudit import ProgressBar

    from .vlm.client import ChatClient, ChatReply
    from .vlm.tasks import DeliveryTask

__all__ = ["MODEL_TEMPLATE", "PREFILL", "SCORING_ROUTES", "SERVER_TEMPLATE", "ExactKernel", "endpoint_kernel"]

SERVER_TEMPLATE = "the server's chat template"
"""``run.scoring.rendering`` of the chat routes: the server renders the messages with its model's template."""

MODEL_TEMPLATE = "the model's chat template (its tokenizer's, in process)"
"""``run.scoring.rendering`` of a local model's exact route."""

SCORING_ROUTES = ("prompt-logprobs", "completions-echo", "top-logprobs", "first-token", "in-process")
"""How an exact route read its probabilities, recorded in ``certificate.json``'s ``run.scoring.route``
(``"in-process"``: a local model's own next-token probabilities)."""

PREFILL = {"continue_final_message": True, "add_generation_prompt": False}
"""Request fields that make a server continue the final assistant message (llama-server, vLLM): a reply's prefix."""

PROMPT_LOGPROBS = {"prompt_logprobs": 0}
"""The request field that asks vLLM for the prompt's own tokens' log-probabilities, the probe of route 1."""

REJECTED = (400, 422)
"""HTTP statuses of a server that rejects a request field it does not know (OpenAI 400, a FastAPI validation 422)."""

NO_ROUTE = (404, 405)
"""HTTP statuses of a server that does not serve a path (chat completions, text completions)."""


@dataclass(frozen=True)
class ExactKernel:
    """An exact route's kernel and how it was scored.

    Attributes
    ----------
    probabilities : numpy.ndarray, shape (n_contexts, n_profiles, ..., n_profiles, n_decisions), or None
        P(decision | shown cell); None when a request failed after its retries.
    summary : RunSummary or None
        The requests' summary; None in process (no requests).
    route : str
        Where the probabilities came from (:data:`SCORING_ROUTES`).
    missing : float
        An upper bound on the probability the options of any one cell may lack because the server did not list a
        token: 0 on the exact routes; on the top log-probabilities routes the largest over the prompts of
        :func:`~fairaudit.experiments.vlm.logprobs.reply_bounds`'s bound, or of the mass outside the first token's
        list.
    rendering : str
        How the messages became the text the model read: :data:`SERVER_TEMPLATE`, :data:`MODEL_TEMPLATE` or
        :data:`~fairaudit.experiments.vlm.messages.CHATML` (text completions).
    unparsed : tuple of (str, float)
        Where the route knows them, the likeliest replies that say no option at the prompt of least coverage (first
        tokens no variant begins with, and their probabilities); empty otherwise.
    """

    probabilities: npt.NDArray[np.float64] | None
    summary: RunSummary | None
    route: str
    missing: float = 0.0
    rendering: str = SERVER_TEMPLATE
    unparsed: tuple = ()

    def record(self, method: str | None) -> dict:
        """``run.scoring`` of ``certificate.json``: the method, the route, the bound on the mass not listed and the
        rendering of the messages."""
        return {
            "method": method,
            "route": self.route,
            "missing_bound": float(self.missing),
            "rendering": self.rendering,
        }


class _Scorer:
    """The requests of one run's exact kernel: the prompts, the route the probe chose, what was sent."""

    def __init__(self, task: DeliveryTask, client: ChatClient, scoring: str) -> None:
        self.task, self.client = task, client
        self.shown, self.answers = exact_prompt(task)
        self.prompts: list[ExactPrompt] = exact_prompts(task)
        self.sequences = by_sequence(task, scoring)
        self.uncached = {"cache_prompt": False} if client.is_llama_server() else {}  # the same numbers always
        self.sent: list[str] = []  # one entry per request (list.append is atomic)
        self.missing: dict[int, float] = {}  # per prompt: the bound on the mass its options lack
        self.route = "first-token"
        self.probe: tuple[tuple[str, float], ...] | None = None  # the first prompt's first-token list
        self.echoed: dict[str, float] = {}  # the text completions' probe: its reply's log-probability
        self.likely: dict[int, list[tuple[str, float]]] = {}  # per prompt: its likeliest first tokens no variant begins
        self.t0 = time.monotonic()

    def summary(self, answered: int, failure: str | None) -> RunSummary:
        return RunSummary(
            planned=len(self.prompts),
            already=0,
            asked=answered,
            failed=int(failure is not None),
            unparsed=0,
            seconds=time.monotonic() - self.t0,
            failures=(failure,) if failure is not None else (),
            requests=len(self.sent),
        )

    def messages(self, i: int) -> list[dict]:
        p = self.prompts[i]
        return self.shown.messages(p.context, p.profiles, p.texts)

    def choose_route(self) -> None:
        """The probe (continuation scoring): the route the server's first reply allows."""
        first = prompt_replies(self.task, self.answers, self.prompts[0])[0]
        reply = _probe(self.client, self.messages(0), self.uncached, self.sent)
        if reply is not None and reply.prompt_logprobs is not None:
            self.route = "prompt-logprobs"
        elif reply is not None and reply.top_logprobs is not None:
            self.route, self.probe = "top-logprobs", reply.top_logprobs
        else:  # no log-probabilities on chat, or no chat: the text completions' echo
            self.route = "completions-echo"
            self.echoed[first] = _probe_echo(self.client, chatml(self.messages(0)), first, self.sent)

    def top(self, i: int, prefix: str) -> Any:
        """The next token's top list after ``prefix`` in prompt ``i``."""
        if i == 0 and not prefix and self.probe is not None:
            return self.probe
        extra = {**self.uncached, **(PREFILL if prefix else {})}
        turn = [{"role": "assistant", "content": prefix}] if prefix else []
        reply = self.client.complete(self.messages(i) + turn, extra=extra)
        self.sent.append(prefix)
        if reply.top_logprobs is None:
            raise InputError(
                "endpoint",
                f"the server returned no log-probabilities for model {self.client.model!r} (it may not support "
                "logprobs); run with `samples` N instead",
            )
        return reply.top_logprobs

    def scored(self, i: int, text: str) -> float:
        """log P(``text`` | prompt ``i``) from the prompt's own log-probabilities (routes 1 and 3)."""
        if self.route == "completions-echo":
            if i == 0 and text in self.echoed:
                return self.echoed[text]
            reply, field = self.client.echo(chatml(self.messages(i)) + text), "echo"
        else:
            turn = [{"role": "assistant", "content": text}]
            extra = {**self.uncached, **PREFILL, **PROMPT_LOGPROBS}
            reply, field = self.client.complete(self.messages(i) + turn, extra=extra), "prompt_logprobs"
        self.sent.append(text)
        if reply.prompt_logprobs is None:
            raise InputError(
                "endpoint",
                f"the server returned no prompt log-probabilities for model {self.client.model!r} on a request after "
                f"its first had them ({field}); run the command again",
            )
        return reply_logprob(reply.prompt_logprobs, text)

    def row(self, i: int) -> npt.NDArray[np.float64]:
        """P(decision | prompt ``i``), the last entry the mass on no option."""
        if not self.sequences:
            first = self.top(i, "")
            self.missing[i] = max(0.0, 1.0 - math.fsum(math.exp(lp) for _, lp in first))  # mass outside the list
            return decision_probabilities(first, self.task, answers=self.answers)
        groups = prompt_variants(self.task, self.answers, self.prompts[i])
        flat = [v for g in groups for v in g]
        if self.route in ("prompt-logprobs", "completions-echo"):
            probs = np.array([math.exp(self.scored(i, r)) for r in flat])
        else:
            lists: dict[str, Any] = {}  # each prefix's top list (reply_bounds asks each prefix once)
            probs, self.missing[i] = reply_bounds(
                lambda prefix: lists.setdefault(prefix, self.top(i, prefix)), flat, listed=self.client.top_logprobs
            )
            first = lists.get("", ())
            likely = sorted((lp, t) for t, lp in first if t and not any(v.startswith(t) for v in flat))[::-1]
            self.likely[i] = [(t, math.exp(lp)) for lp, t in likely[:3]]
        return decision_row(groups, probs)


def endpoint_kernel(
    task: DeliveryTask, client: ChatClient, *, scoring: str = "continuation", progress: bool = False
) -> ExactKernel:
    """An endpoint's exact kernel from the log-probabilities of its replies' tokens (the module's routes).

    Parameters
    ----------
    task : DeliveryTask
    client : fairaudit.experiments.vlm.client.ChatClient
        Made with ``max_tokens=1`` and ``top_logprobs``; its ``max_concurrency`` prompts are in flight at once.
    scoring : {"continuation", "first-token"}
        :data:`fairaudit.experiments.exact.SCORINGS`.
    progress : bool
        A progress bar on stderr, by prompt.

    Returns
    -------
    ExactKernel
        The probabilities, shape (n_contexts, n_profiles, ..., n_profiles, n_decisions), or None when a request
        failed after its retries (the rest are then cancelled); the summary; the route; the bound on the mass not
        listed; the rendering of the messages.

    Raises
    ------
    InputError
        ``endpoint`` when no route gives log-probabilities, when the route chosen stops giving them, or when a
        prompt's scored tokens do not end with the reply; ``exact`` when a likely first token begins two options'
        replies (first-token scoring); ``attribute.text`` when the texts make too many prompts.
    """
    s = _Scorer(task, client, scoring)
    if s.sequences:
        try:
            s.choose_route()
        except ChatError as exc:
            return ExactKernel(None, s.summary(0, str(exc)), s.route)
    bar = progress_bar(len(s.prompts), f"{task.name}: exact kernel", progress, unit="query")
    try:
        answered, failure = _ask_cells(len(s.prompts), s.row, client.max_concurrency, bar)
    finally:
        bar.close()
    out = np.zeros((len(task.contexts), *([len(task.profiles)] * task.slots), len(task.decisions)))
    for i, row in answered.items():
        out[s.prompts[i].index] += s.prompts[i].weight * row
    return ExactKernel(
        out if failure is None else None,
        s.summary(len(answered), failure),
        s.route,
        max(s.missing.values(), default=0.0),
        rendering=CHATML if s.route == "completions-echo" else SERVER_TEMPLATE,
        unparsed=_likeliest(s.likely, answered),
    )


def _likeliest(likely: dict[int, list[tuple[str, float]]], rows: dict[int, npt.NDArray[np.float64]]) -> tuple:
    """The likeliest unparsed first tokens of the prompt whose unparsed mass is the largest, where they were read."""
    known = [i for i in likely if i in rows]
    return tuple(likely[max(known, key=lambda i: float(rows[i][-1]))]) if known else ()


def _probe(client: ChatClient, messages: list[dict], uncached: dict, sent: list[str]) -> ChatReply | None:
    """The probe's chat request, asking for ``prompt_logprobs`` too.

    A server that rejects the field (HTTP 400 or 422) gets the request again without it. None when the server has
    no chat completions (HTTP 404 or 405); any other failure raises.
    """
    for again, extra in enumerate(({**uncached, **PROMPT_LOGPROBS}, uncached)):
        try:
            return client.complete(messages, extra=extra)
        except ChatError as exc:
            if exc.kind != "http" or exc.status not in REJECTED + NO_ROUTE or (exc.status in REJECTED and again):
                raise
            if exc.status in NO_ROUTE:
                return None
        finally:
            sent.append("")
    raise AssertionError("unreachable: the second request returns or raises")


def _probe_echo(client: ChatClient, prompt: str, reply: str, sent: list[str]) -> float:
    """The text completions' probe: log P(``reply`` | ``prompt``) from the echo.

    Raises InputError (``endpoint``) when the server has no such route (HTTP 400, 404, 405 or 422) or its echo has
    no log-probabilities: then no route gives the exact kernel.
    """
    why = "echoed none"
    try:
        answer = client.echo(prompt + reply)
    except ChatError as exc:
        if exc.kind != "http" or exc.status not in REJECTED + NO_ROUTE:
            raise
        answer, why = None, f"answered HTTP {exc.status}"
    finally:
        sent.append(reply)
    if answer is None or answer.prompt_logprobs is None:
        raise InputError(
            "endpoint",
            f"the server gave no log-probabilities for model {client.model!r}: none on chat completions (logprobs, "
            f"prompt_logprobs), and its text completions (echo) {why}; run with `samples` N instead",
        )
    return reply_logprob(answer.prompt_logprobs, reply)


def _ask_cells(
    n: int, ask: Callable[[int], npt.NDArray[np.float64]], workers: int, bar: ProgressBar
) -> tuple[dict[int, npt.NDArray[np.float64]], str | None]:
    """``ask`` cells 0 to n − 1 on ``workers`` threads: the answers, and the first request that failed after retries.

    The first failure (a :class:`~fairaudit.experiments.vlm.client.ChatError`) cancels the cells not yet asked;
    any other exception (an :class:`InputError`, KeyboardInterrupt) does too, and propagates once the requests in
    flight have ended.
    """
    answered: dict[int, npt.NDArray[np.float64]] = {}
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        futures = {pool.submit(ask, cell): cell for cell in range(n)}
        for future in as_completed(futures):
            try:
                answered[futures[future]] = future.result()
            except ChatError as exc:  # after the client's retries: the kernel needs every cell
                return answered, str(exc)
            bar.update(1)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)  # no request left behind, however the loop ends
    return answered, None
