"""The decision's law from a chat completion's first-token log-probabilities (the exact route of an endpoint).

An OpenAI-compatible server asked for one token with ``logprobs: true`` and
``top_logprobs: 20`` (OpenAI, vLLM, llama.cpp's ``llama-server``, Ollama)
returns, beside the sampled token, the log-probabilities of the most likely
first tokens: ``choices[0].logprobs.content[0].top_logprobs``, a list of
``{"token": str, "logprob": float, ...}``. When the prompt asks for the
option alone, so that the first token decides, the probability of each option
is the mass of the top tokens that
:func:`~fairaudit.experiments.vlm.parse.parse_reply` reads as that option (the
rule of :func:`fairaudit.experiments.local_model.token_decisions`), and the
rest of the mass, the tokens outside the top list included, is
``"unparsed"`` (:func:`decision_probabilities`).

That reading needs the options' replies to start with distinct tokens: a
first token such as ``"HR"`` that begins both ``"HR1"`` and ``"HR2"`` leaves
the decision to later tokens, which the first token's probabilities do not
give (:func:`shared_first_token`); such a task is run by sampling instead.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from fairaudit import InputError

from .parse import parse_reply
from .tasks import DeliveryTask

__all__ = [
    "MIN_PROBABILITY",
    "TOP_LOGPROBS",
    "decision_probabilities",
    "echo_token_logprobs",
    "first_token_logprobs",
    "prompt_token_logprobs",
    "reply_bounds",
    "reply_logprob",
    "shared_first_token",
]

TOP_LOGPROBS = 20
"""First tokens requested (``top_logprobs``): OpenAI's largest."""

MIN_PROBABILITY = 1e-6
"""A top token below this probability is ignored by :func:`shared_first_token`."""

_SUM_TOLERANCE = 1e-6  # the options' mass may exceed 1 by this much (rounding of the server's log-probabilities)


def first_token_logprobs(reply: Any) -> tuple[tuple[str, float], ...] | None:
    """The first token's top log-probabilities in a chat completion, or None when it has none.

    Parameters
    ----------
    reply : dict
        The parsed JSON of a chat completion (``choices[0].logprobs.content[0].top_logprobs``
        is read), or such a ``top_logprobs`` list itself.

    Returns
    -------
    tuple of (str, float) or None
        ``(token text, log-probability in nats)`` per entry, in the server's
        order; None when the reply has no log-probabilities (the server does
        not support them or was not asked), when the list is empty, or when an
        entry lacks a string ``token`` or a ``logprob`` that is a number <= 0
        (a rounding error above 0 is taken as 0).

    Examples
    --------
    >>> reply = {"choices": [{"logprobs": {"content": [{"token": "1", "logprob": -0.1,
    ...     "top_logprobs": [{"token": "1", "logprob": -0.1}, {"token": " 2", "logprob": -2.5}]}]}}]}
    >>> first_token_logprobs(reply)
    (('1', -0.1), (' 2', -2.5))
    >>> first_token_logprobs({"choices": [{"message": {"content": "1"}}]}) is None
    True
    """
    if isinstance(reply, (list, tuple)):
        return _pairs(reply)
    try:
        entries = reply["choices"][0]["logprobs"]["content"][0]["top_logprobs"]
    except (KeyError, IndexError, TypeError):  # the path breaks: no log-probabilities
        return None
    return _pairs(entries) if isinstance(entries, list) else None


def _entry(entry: Any) -> tuple[str | None, float | None]:
    """(token, logprob) of one entry: a ``{"token", "logprob"}`` mapping or a pair; None where it is not one."""
    if isinstance(entry, Mapping):
        token, logprob = entry.get("token"), entry.get("logprob")
    elif isinstance(entry, (list, tuple)) and len(entry) == 2:
        token, logprob = entry
    else:
        return None, None
    if not isinstance(token, str) or isinstance(logprob, bool) or not isinstance(logprob, (int, float)):
        return None, None
    if math.isnan(logprob) or logprob > _SUM_TOLERANCE:  # a log-probability is <= 0, up to rounding
        return None, None
    return token, min(float(logprob), 0.0)


def shared_first_token(
    top: Sequence[tuple[str, float]], answers: Sequence[str], *, min_probability: float = MIN_PROBABILITY
) -> str | None:
    """A likely first token that begins the replies of two or more options, or None when there is none.

    Parameters
    ----------
    top : sequence of (str, float)
        First tokens and their log-probabilities (nats), as :func:`first_token_logprobs` gives them.
    answers : sequence of str
        The reply that names each option, in the options' order (``("1", "2")``
        for a prompt that asks for the option's number; the option keys, such
        as ``("HR1", "HR2")``, for one that asks for the key).
    min_probability : float
        Tokens at or below this probability are ignored.

    Returns
    -------
    str or None
        The first such token (its text as the server gave it): one whose text,
        stripped of white space, is a proper prefix (ignoring case) of two or
        more answers. Blank tokens are ignored (they read as unparsed).

    Examples
    --------
    >>> import math
    >>> shared_first_token([("HR", math.log(0.9)), ("1", math.log(0.05))], ("HR1", "HR2"))
    'HR'
    >>> shared_first_token([("HR", math.log(0.9))], ("1", "2")) is None
    True
    """
    keys = [a.strip().casefold() for a in answers]
    for token, logprob in top:
        text = token.strip().casefold()
        if not text or math.exp(logprob) <= min_probability:
            continue
        if sum(1 for k in keys if len(text) < len(k) and k.startswith(text)) >= 2:
            return token
    return None


def decision_probabilities(
    reply: Any, task: DeliveryTask, *, answers: Sequence[str] | None = None
) -> npt.NDArray[np.float64]:
    """P(decision) of one shown cell from its chat completion's first-token log-probabilities.

    Parameters
    ----------
    reply : dict or sequence
        The parsed JSON of a chat completion with log-probabilities, or its
        first token's top list (:func:`first_token_logprobs`'s input or output).
    task : DeliveryTask
        Its options and kind read each token (:func:`~fairaudit.experiments.vlm.parse.parse_reply`).
    answers : sequence of str, optional
        The reply that names each option (:func:`shared_first_token`); default
        the option keys, ``task.options``.

    Returns
    -------
    numpy.ndarray, shape (n_decisions,)
        Indexed by :attr:`DeliveryTask.decisions` (the options, then
        ``"unparsed"``); no unit (probabilities), summing to 1. Option i gets
        Σ exp(logprob) over the top tokens that ``parse_reply`` reads as option
        i (blank tokens read as nothing); ``"unparsed"`` gets the rest,
        ``1 − Σ_i P(option i)``, the tokens outside the top list included,
        clipped at 0 (the options are scaled to sum to 1 when rounding takes
        them just above it).

    Raises
    ------
    InputError
        ``reply`` when it has no first-token log-probabilities; ``exact`` when
        a token of probability above :data:`MIN_PROBABILITY` begins two or
        more options' replies (the first token does not decide), or when the
        options' mass exceeds 1 by more than rounding.

    Examples
    --------
    >>> import math
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> top = [("1", math.log(0.6)), (" 2", math.log(0.3)), ("Sure", math.log(0.05))]
    >>> decision_probabilities(top, HR_DELIVERY, answers=("1", "2")).round(12).tolist()
    [0.6, 0.3, 0.1]
    """
    top = first_token_logprobs(reply)
    if top is None:
        raise InputError("reply", "has no log-probabilities of its first token (choices[0].logprobs.content[0])")
    shared = shared_first_token(top, task.options if answers is None else answers)
    if shared is not None:
        raise InputError(
            "exact",
            f"the first token {shared.strip()!r} begins the replies of two options "
            f"({', '.join(task.options if answers is None else answers)}): the first token does not decide; "
            "run with `samples` N instead",
        )
    n = len(task.options)
    out = np.zeros(n + 1)
    for token, logprob in top:
        if not token.strip():
            continue
        r = parse_reply(token, task.options, task.kind)
        if r.ok and r.choice is not None:
            out[r.choice] += math.exp(logprob)
    total = float(out[:n].sum())
    if total > 1.0 + _SUM_TOLERANCE:
        raise InputError("exact", f"the options' first tokens have probabilities summing to {total:.6g}, above 1")
    if total > 1.0:  # rounding: the options take all the mass
        out[:n] /= total
        return out
    out[n] = max(0.0, 1.0 - total)
    return out


def reply_bounds(
    next_tokens: Callable[[str], Sequence[tuple[str, float]]], replies: Sequence[str], *, listed: int | None = None
) -> tuple[npt.NDArray[np.float64], float]:
    """Lower bounds on P(the reply begins with each of ``replies``) from top next-token lists, and what they may miss.

    The route of a server that gives only the next token's top log-probabilities (llama-server): one request per
    prefix of the replies, the prefix sent as the start of the assistant's message.

    Parameters
    ----------
    next_tokens : callable
        ``next_tokens(prefix)``: the top next tokens and their log-probabilities (nats) after the reply has begun
        with ``prefix`` (``""``: the first token), as :func:`first_token_logprobs` gives them. Each prefix is asked
        once, whatever the number of replies that share it.
    replies : sequence of str
        The replies scored (:func:`fairaudit.experiments.exact.ranking_replies`: ``"2, 3, 1"``, ...; the options'
        replies of a choice: ``"Office A"``, ...).
    listed : int, optional
        How many tokens each list was asked for (``top_logprobs``); a list that long is taken to be the true top of
        the next token's law. None: no list is known to be a top list.

    Returns
    -------
    probabilities : numpy.ndarray, shape (len(replies),)
        Π over the reply's tokens of P(token | prompt, the tokens before it), no unit. At each prefix the reply
        continues with the longest listed token that begins the rest of it (the tokenizer's own split of
        digits, commas and spaces); a reply whose next token is not listed gets 0. Other splits of the same text
        into tokens are not counted, as on the in-process route, which scores the tokenizer's own split.
    missing : float
        An upper bound on the probability the replies lost to unlisted tokens, summed over the replies, no unit:
        for each reply stopped at a prefix s whose next token is not listed, P(s) · m(s), where P(s) is the
        product of the listed probabilities up to s and m(s) = min(p_min(s), 1 − Σ listed) bounds the
        probability of one unlisted token (p_min(s), the smallest listed probability, only when the list holds
        ``listed`` tokens). 0 when every reply's tokens were listed.

    Notes
    -----
    Each probability is a lower bound on the reply's (the tokenizer's own split): it is a product of exact
    conditional probabilities along one path of tokens, and a reply whose path leaves the lists gets 0 ≤ its
    probability. The bound on what was missed: the reply's probability is P(s) · P(t | s) · P(rest | s, t) for
    its next token t after the last listed prefix s, and P(rest | s, t) ≤ 1. The token t is not listed, so
    P(t | s) ≤ 1 − Σ listed (the listed tokens are others); and when the list is the true top n of the law
    (it holds the ``listed`` tokens asked for), a token missing from it has probability at most the smallest
    listed one, p_min(s), or it would have been listed in that one's place. So each stopped reply lies in
    [0, P(s) · m(s)] and every other in its exact value: the options' total is low by at most ``missing``.

    Examples
    --------
    >>> import math
    >>> law = {"": [("Office", math.log(0.7)), ("Sure", math.log(0.2))], "Office": [(" A", math.log(0.6))]}
    >>> p, missing = reply_bounds(law.get, ["Office A", "Office B"], listed=1)
    >>> p.round(12).tolist(), round(missing, 12)
    ([0.42, 0.0], 0.28)

    Rankings, every token listed:

    >>> law = {"": [("2", math.log(0.5)), ("1", math.log(0.25))], "2": [(",", 0.0)], "2,": [(" 1", math.log(0.8))],
    ...        "1": [(",", math.log(0.5))], "1,": [(" 2", 0.0)]}
    >>> reply_bounds(law.get, ["2, 1", "1, 2"])[0].round(12).tolist()
    [0.4, 0.125]
    """
    asked: dict[str, Sequence[tuple[str, float]]] = {}
    out = np.zeros(len(replies))
    missing = 0.0
    for j, reply in enumerate(replies):
        prefix, logp = "", 0.0
        while prefix != reply:
            if prefix not in asked:
                asked[prefix] = next_tokens(prefix)
            top = asked[prefix]
            rest = reply[len(prefix) :]
            steps = [(t, lp) for t, lp in top if t and rest.startswith(t)]
            if not steps:
                probabilities = [math.exp(lp) for _, lp in top]
                bound = max(0.0, 1.0 - math.fsum(probabilities))
                if listed is not None and probabilities and len(probabilities) >= listed:
                    bound = min(bound, min(probabilities))
                missing += math.exp(logp) * bound
                logp = -math.inf
                break
            token, lp = max(steps, key=lambda step: len(step[0]))
            logp += lp
            prefix += token
        out[j] = math.exp(logp)
    return out, missing


def prompt_token_logprobs(reply: Any) -> tuple[tuple[str, float], ...] | None:
    """The prompt's tokens and their log-probabilities in a vLLM completion (``prompt_logprobs``), or None.

    vLLM answers a chat completion asked for ``prompt_logprobs: k`` with a top-level ``prompt_logprobs``: one entry
    per prompt token, ``null`` for the first (nothing precedes it), else a mapping from token id (a JSON string) to
    ``{"logprob": float, "rank": int, "decoded_token": str}`` that holds the prompt's own token and the k most
    likely ones (vLLM's ``PromptLogprobs``; a log-probability of −∞ is sent as −9999.0, ``clamp_prompt_logprobs``).

    Parameters
    ----------
    reply : dict
        The parsed JSON of the completion. The prompt's own token at each position is the entry keyed by
        ``prompt_token_ids[i]`` when the reply has those ids (``return_token_ids``), else the mapping's first entry
        (vLLM writes the prompt's token first, then the top k; with k = 0 it is the only entry).

    Returns
    -------
    tuple of (str, float) or None
        ``(decoded token, log-probability in nats)`` per prompt token after the leading ``null`` entries; None when
        the reply has no ``prompt_logprobs`` list or an entry is not of that form (no ``decoded_token`` string, a
        log-probability that is not a number <= 0 up to rounding).

    Examples
    --------
    >>> reply = {"prompt_logprobs": [None, {"791": {"logprob": -2.5, "rank": 3, "decoded_token": "Office"}},
    ...     {"362": {"logprob": -0.5, "rank": 1, "decoded_token": " A"}}]}
    >>> prompt_token_logprobs(reply)
    (('Office', -2.5), (' A', -0.5))
    >>> prompt_token_logprobs({"choices": []}) is None
    True
    """
    entries = reply.get("prompt_logprobs") if isinstance(reply, Mapping) else None
    if not isinstance(entries, list) or not entries:
        return None
    ids = reply.get("prompt_token_ids")
    ids = ids if isinstance(ids, list) and len(ids) == len(entries) else None

    def own(i: int, entry: Any) -> Any:
        """The prompt's own token at position ``i`` as a ``{"token", "logprob"}`` mapping; None stays None, () when
        the entry is not of the form."""
        if not isinstance(entry, Mapping) or not entry:
            return None if entry is None else ()
        chosen = entry.get(str(ids[i])) if ids is not None else None
        chosen = next(iter(entry.values())) if chosen is None else chosen
        if not isinstance(chosen, Mapping):
            return ()
        return {"token": chosen.get("decoded_token"), "logprob": chosen.get("logprob")}

    return _after_first(own(i, entry) for i, entry in enumerate(entries))


def echo_token_logprobs(reply: Any, prompt: str) -> tuple[tuple[str, float], ...] | None:
    """The prompt's tokens and their log-probabilities in a text completion that echoes it, or None.

    An OpenAI-compatible ``/v1/completions`` request with ``echo: true``, ``logprobs`` and ``max_tokens: 0`` (vLLM,
    and OpenAI's legacy completions) is answered with the prompt's own tokens in ``choices[0].logprobs``: parallel
    lists ``tokens`` (texts), ``token_logprobs`` (nats; ``null`` for the first token, which nothing precedes) and
    ``text_offset`` (each token's first character in ``choices[0].text``). Tokens the server generated after the
    prompt (a server that gives at least one) are dropped: those whose ``text_offset`` is at or past the prompt's
    end, or without offsets those past the prompt's length in characters.

    Parameters
    ----------
    reply : dict
        The parsed JSON of the text completion.
    prompt : str
        The prompt sent.

    Returns
    -------
    tuple of (str, float) or None
        ``(token, log-probability in nats)`` per prompt token after the leading ``null`` entries; None when the
        reply has no such lists (the server does not echo log-probabilities), when they differ in length, or when
        an entry is not a string token with a number <= 0 (up to rounding).

    Examples
    --------
    >>> reply = {"choices": [{"text": "Q: A or B? A: Office A", "logprobs": {
    ...     "tokens": ["Q", ":", " A", " or", " B", "?", " A", ":", " Office", " A"],
    ...     "token_logprobs": [None, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -0.5, -0.25],
    ...     "text_offset": [0, 1, 2, 4, 7, 9, 10, 12, 13, 20]}}]}
    >>> echo_token_logprobs(reply, "Q: A or B? A: Office A")[-2:]
    ((' Office', -0.5), (' A', -0.25))
    >>> echo_token_logprobs({"choices": [{"text": "Q", "logprobs": None}]}, "Q") is None
    True
    """
    node = reply.get("choices") if isinstance(reply, Mapping) else None
    choice = node[0] if isinstance(node, list) and node and isinstance(node[0], Mapping) else {}
    lists = choice.get("logprobs")
    if not isinstance(lists, Mapping):
        return None
    tokens, values, offsets = lists.get("tokens"), lists.get("token_logprobs"), lists.get("text_offset")
    if not isinstance(tokens, list) or not isinstance(values, list) or len(tokens) != len(values) or not tokens:
        return None
    if isinstance(offsets, list) and len(offsets) == len(tokens) and all(type(o) is int for o in offsets):
        kept = sum(1 for o in offsets if o < len(prompt))
    else:  # no offsets: the tokens whose texts make up the prompt's length
        kept, length = 0, 0
        while kept < len(tokens) and length < len(prompt) and isinstance(tokens[kept], str):
            length += len(tokens[kept])
            kept += 1
    return _after_first(None if value is None else (token, value) for token, value in zip(tokens[:kept], values[:kept]))


def _after_first(entries: Iterable[Any]) -> tuple[tuple[str, float], ...] | None:
    """:func:`_pairs` of the entries after the leading None ones (the first token: nothing precedes it)."""
    return _pairs(itertools.dropwhile(lambda entry: entry is None, entries))


def _pairs(entries: Iterable[Any]) -> tuple[tuple[str, float], ...] | None:
    """(token, log-probability) of each entry (:func:`_entry`); None when an entry is not one, or there is none."""
    out = []
    for token, logprob in map(_entry, entries):
        if token is None or logprob is None:
            return None
        out.append((token, logprob))
    return tuple(out) if out else None


def reply_logprob(tokens: Sequence[tuple[str, float]], reply: str) -> float:
    """log P(reply | prompt) from the log-probabilities of a prompt that ends with ``reply``: its last tokens' sum.

    The reply is sent as the assistant's message being continued (``continue_final_message``), so the prompt the
    server scored is the chat template's rendering of the messages, ending with the reply's text; its last tokens
    are the reply's, and their log-probabilities add up to log P(reply | the messages) (lm-evaluation-harness's
    ``loglikelihood`` of a continuation).

    Parameters
    ----------
    tokens : sequence of (str, float)
        The prompt's tokens and their log-probabilities (nats), :func:`prompt_token_logprobs`.
    reply : str
        The reply, non-empty.

    Returns
    -------
    float
        Σ of the log-probabilities (nats) of the last tokens, read from the end, whose texts join to ``reply``.

    Raises
    ------
    InputError
        ``endpoint``: when the prompt's text does not end with the reply (the server did not continue the
        assistant's message), or when a token straddles the reply's start (part template, part reply: the
        reply's own tokens cannot be told apart).

    Examples
    --------
    >>> reply_logprob([("<|assistant|>", -1.0), (":", -0.1), ("Office", -0.5), (" A", -0.25)], "Office A")
    -0.75
    """
    text, total = "", 0.0
    for token, logprob in reversed(tokens):
        if len(text) >= len(reply):
            break
        text = token + text
        total += logprob
    if not text.endswith(reply):
        raise InputError(
            "endpoint",
            f"the server's prompt log-probabilities end with {text[-len(reply) - 10 :]!r}, not with the reply "
            f"{reply!r}: it did not continue the assistant's message (or echo the prompt sent); run with `samples` N "
            "instead",
        )
    if len(text) > len(reply):
        raise InputError(
            "endpoint",
            f"the server's token {text[: len(text) - len(reply) + 1]!r}... straddles the start of the reply "
            f"{reply!r} (part chat template, part reply): the reply's own log-probability is not given; run with "
            "`samples` N instead",
        )
    return total
