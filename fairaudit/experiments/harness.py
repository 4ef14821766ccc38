"""The sampling harness: query a decision model cell by cell, log every reply, resume after a crash.

Two designs (:func:`plan_queries`): the **table** design queries every shown cell N times, and its counts
estimate the model's kernel, to which any filter is applied exactly; the **paper** design draws what the model is
shown through the filter at each ε. Every query has a key and its own seed, a hash of the run's seed and the key,
so the replies do not depend on the order, the concurrency or interruptions. The log (:class:`QueryLog`) is an
append-only JSON-lines file, a header then one line per answered query, flushed as each reply arrives; on resume
the answered queries are skipped and a torn last line is cut off (docs/experiments.md, "The log, and resuming").
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from contextlib import suppress
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Self

import numpy as np

from fairaudit import FairauditError, InputError, ProgressBar, choice, progress_bar, whole

from .slots import check_size, true_prompts
from .vlm.filter import TaskFilter
from .vlm.models import DecisionModel, Query
from .vlm.tasks import UNPARSED, DeliveryTask

__all__ = [
    "QueryLog",
    "RunSummary",
    "decision_label",
    "logged_messages",
    "logged_settings",
    "paper_queries_needed",
    "plan_queries",
    "query_seed",
    "run_queries",
    "table_queries",
    "table_queries_needed",
]

LOG_VERSION = 1


def query_seed(run_seed: int, key: str) -> int:
    """The seed of one query: 63 bits of SHA-256 of the run's seed and the query's key.

    Examples
    --------
    >>> query_seed(0, "table|sick leave|a|b|0") == query_seed(0, "table|sick leave|a|b|0")
    True
    >>> query_seed(0, "x") != query_seed(1, "x")
    True
    """
    digest = hashlib.sha256(f"{int(run_seed)}|{key}".encode()).digest()
    return int.from_bytes(digest[:8], "big") >> 1


def eps_key(eps: float) -> str:
    """An ε as the logs write it in query keys (12 significant digits; ``inf`` for no filter)."""
    return f"{eps:.12g}"


def plan_queries(
    task: DeliveryTask,
    design: str,
    samples: int,
    seed: int,
    *,
    epsilons: Sequence[float] = (),
    positions: str = "balanced",
    context_epsilon: float | None = None,
) -> list[Query]:
    """Every query of a run, in a fixed order.

    Parameters
    ----------
    task : DeliveryTask
    design : {"table", "paper"}
    samples : int
        N ≥ 1: queries per shown cell (table) or per true cell and ε (paper).
    seed : int
        The run's seed.
    epsilons : sequence of float
        Paper design: the candidate's ε values (nats; :func:`fairaudit.experiments.vlm.filter.candidate_family`),
        each profile filtered at ε / 2.
    positions : {"balanced", "latin", "fixed"}
        Paper design: the true orders queried: both orders of the paper's
        candidates (``balanced``), or the paper's own only (``fixed``).
    context_epsilon : float, optional
        Paper design: ε of randomized response on the context (None: shown as is).

    Returns
    -------
    list of Query
        Table: n_contexts × n_profiles² × N queries. Paper: n_ε × n_contexts ×
        (2 or 1) × N queries, each with the cell drawn through the filter.

    Raises
    ------
    InputError
        On an unknown design or positions, N < 1, or no ε for the paper design.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> len(plan_queries(HR_DELIVERY, "table", 5, 0))              # 3 documents x 8 x 8 profiles x 5
    960
    >>> q = plan_queries(HR_DELIVERY, "paper", 2, 0, epsilons=[1.0])
    >>> len(q), q[0].id
    (12, 'paper|1|maternity leave|Tom & 25 & Asian|Mary & 55 & American|0')
    """
    choice(design, "design", ("table", "paper"))
    prompts, _ = true_prompts(task, positions)
    whole(samples, "samples", low=1)
    label = task.profile_label
    out: list[Query] = []
    if design == "table":
        check_size(task)
        return list(table_queries(task, samples, seed))
    if not len(epsilons):
        raise InputError("epsilons", "the paper design needs at least one epsilon")
    orders = [tuple(task.profiles[i] for i in p) for p in prompts]
    filters = [TaskFilter.for_candidates(task, float(e), positions, context_epsilon=context_epsilon) for e in epsilons]
    for (eps, filt), ctx, order, r in itertools.product(zip(epsilons, filters), task.contexts, orders, range(samples)):
        key = f"paper|{eps_key(float(eps))}|{ctx}|{'|'.join(label(p) for p in order)}|{r}"
        s = query_seed(seed, key)
        shown_ctx, shown = filt.release(ctx, order, np.random.default_rng([s, 1]).bytes)
        texts = task.draw_texts(shown, np.random.default_rng([s, 2]))
        out.append(Query(key, "paper", shown_ctx, shown, r, s, truth=(ctx, order), epsilon=float(eps), texts=texts))
    return out


def table_queries(task: DeliveryTask, samples: int, seed: int) -> Iterator[Query]:
    """The table design's queries, one at a time, in :func:`plan_queries`' order, without listing them all.

    The order: the contexts in the task's order; within one, every shown cell, the k-tuples of
    :attr:`~DeliveryTask.profiles` in ``itertools.product`` order (slot 1 slowest, slot k fastest); within one,
    repetitions 0 to ``samples`` − 1. Each query's texts are drawn from its own seed, as the run draws them.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> [q.id for q in itertools.islice(table_queries(HR_DELIVERY, 1, 0), 2)]
    ['table|maternity leave|Tom & 25 & Asian|Tom & 25 & Asian|0', 'table|maternity leave|Tom & 25 & Asian|Tom & 25 & American|0']
    """
    label = task.profile_label
    for ctx, shown in itertools.product(task.contexts, itertools.product(task.profiles, repeat=task.slots)):
        cell = "|".join(label(p) for p in shown)
        for r in range(samples):
            key = f"table|{ctx}|{cell}|{r}"
            s = query_seed(seed, key)
            texts = task.draw_texts(shown, np.random.default_rng([s, 2]))
            yield Query(key, "table", ctx, shown, r, s, texts=texts)


def table_queries_needed(task: DeliveryTask, samples: int) -> int:
    """Queries of the table design: n_contexts × n_profiles^k × N, for any number of ε."""
    return len(task.contexts) * len(task.profiles) ** task.slots * samples


def paper_queries_needed(task: DeliveryTask, samples: int, n_epsilons: int, positions: str = "balanced") -> int:
    """Queries of the paper's design: n_ε × n_contexts × n_true_prompts (both orders of the paper's pair, or 1) × N."""
    return n_epsilons * len(task.contexts) * len(true_prompts(task, positions)[0]) * samples


# -- the log --------------------------------------------------------------------------------------------------


class QueryLog:
    """The append-only JSON-lines log of a run.

    Parameters
    ----------
    path : str or Path
        The log file (``queries.jsonl`` in the run's folder).
    header : dict
        The run's identity: ``task``, ``model``, ``seed`` (and anything else
        to record). On resume these three must equal the log's.
    resume : bool
        Continue an existing log (its answered queries are kept and skipped);
        without it an existing log is an error, so nothing is overwritten.

    Attributes
    ----------
    records : dict
        The answered queries by key (the last answer of each; none is asked twice).
    errors : dict
        The queries whose last record is a transport failure, by key.
    extensions : list of dict
        The log's ``extend`` lines (:meth:`extend`), oldest first: ``{"from": n, "to": N, "time": ...}``.

    Raises
    ------
    InputError
        If the log exists and ``resume`` is False; if ``resume`` and the log
        was made by another task, model or seed; if a line other than the last
        is not valid JSON.
    """

    def __init__(self, path: str | Path, header: dict, *, resume: bool = False):
        self.path = Path(path)
        self.records: dict[str, dict] = {}
        self.errors: dict[str, dict] = {}
        self.extensions: list[dict] = []
        self._lock = threading.Lock()
        self._last_sync = time.monotonic()
        exists = self.path.exists() and self.path.stat().st_size > 0
        if exists and not resume:
            raise InputError(
                "out",
                f"holds a run already ({self.path.name}); pass `resume` to continue it, or choose another folder",
                str(self.path.parent),
            )
        if exists:
            self._read(header)
        self._fh = open(self.path, "ab")
        if not exists:
            self._append({"type": "header", "version": LOG_VERSION, "created": _now(), **header})

    def _read(self, header: dict) -> None:
        data = self.path.read_bytes()
        lines = data.split(b"\n")  # the last one has no newline after it: torn, or empty
        good = 0  # byte offset after the last complete, valid line
        first = None
        for i, raw in enumerate(lines[:-1]):
            try:
                rec = json.loads(raw)
            except ValueError:
                if all(not x.strip() for x in lines[i + 1 :]):
                    break  # a torn line left by a crash: cut it off below
                raise InputError(
                    "resume", f"line {i + 1} of {self.path} is not valid JSON; the log is damaged"
                ) from None
            good += len(raw) + 1
            if first is None:
                first = rec
                continue
            if rec.get("type") == "query":
                self._keep(rec)
            elif rec.get("type") == "extend":
                self.extensions.append(rec)
        if first is None or first.get("type") != "header":
            raise InputError("resume", "the log has no header line; it is not a fairaudit run log", str(self.path))
        for key, flag in (("task", "`experiment`"), ("model", "`model`/`simulated`/`kernel`"), ("seed", "`seed`")):
            if first.get(key) != header.get(key):
                raise InputError(
                    "resume",
                    f"the run in {self.path.parent} was made with {flag} {first.get(key)!r}, not {header.get(key)!r}",
                )
        before, now = first.get("task_sha256"), header.get("task_sha256")
        if before is not None and before != now:  # (logs from before task files have no digest)
            raise InputError(
                "resume",
                f"the task file changed since the run in {self.path.parent} began (sha256 {before[:12]}... then, "
                f"{str(now)[:12]}... now): its queries would mix two tasks; start a new run in another folder",
            )
        self.header = first
        if good < len(data):
            with open(self.path, "r+b") as fh:
                fh.truncate(good)

    def _append(self, record: dict) -> None:
        line = (json.dumps(record, ensure_ascii=False, separators=(",", ":")) + "\n").encode("utf-8")
        with self._lock:
            self._fh.write(line)
            self._fh.flush()
            now = time.monotonic()
            if now - self._last_sync > 1.0:
                os.fsync(self._fh.fileno())
                self._last_sync = now

    def add(self, record: dict) -> None:
        """Append one query's record (flushed at once; synced to disk at least every second)."""
        self._append(record)
        self._keep(record)

    def _keep(self, record: dict) -> None:
        """A query's record as the last of its key: answered (``records``) or failed (``errors``)."""
        if record.get("status") == "ok":
            self.records[record["id"]] = record
            self.errors.pop(record["id"], None)
        else:
            self.errors[record["id"]] = record

    def extend(self, samples: int, before: int) -> None:
        """Record that the run's ``samples`` grow from ``before`` to ``samples`` (a line ``{"type": "extend"}``).

        :func:`logged_settings` reads the run's samples as the last such line left them.
        """
        record = {"type": "extend", "time": _now(), "from": int(before), "to": int(samples)}
        self._append(record)
        self.extensions.append(record)

    def close(self) -> None:
        """Sync and close the file."""
        with self._lock:
            if not self._fh.closed:
                self._fh.flush()
                os.fsync(self._fh.fileno())
                self._fh.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def logged_settings(path: str | Path) -> dict | None:
    """The settings a run's log records: its header, with ``samples`` as its last ``extend`` line left them.

    Parameters
    ----------
    path : str or Path
        The log (``queries.jsonl``).

    Returns
    -------
    dict or None
        The header line's fields (``task``, ``model``, ``seed``, ``samples``, ``design``, ...), ``samples``
        replaced by the ``to`` of the last :meth:`QueryLog.extend` line; None when there is no log or its first
        line is not a header (which :class:`QueryLog` refuses in its own words).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     with QueryLog(Path(tmp) / "q.jsonl", {"task": "t", "model": "m", "seed": 0, "samples": 40}) as log:
    ...         log.extend(80, 40)
    ...     logged_settings(Path(tmp) / "q.jsonl")["samples"]
    80
    """
    try:
        with open(path, "rb") as fh:
            header = json.loads(fh.readline())
            if not isinstance(header, dict) or header.get("type") != "header":
                return None
            for line in fh:
                if line.startswith(b'{"type":"extend"'):
                    with suppress(ValueError, KeyError):  # a torn last line: the log cuts it off
                        header["samples"] = json.loads(line)["to"]
    except (OSError, ValueError):
        return None
    return header


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


# -- running --------------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class RunSummary:
    """What a call of :func:`run_queries` did.

    Attributes
    ----------
    planned : int
        Queries of the plan.
    already : int
        Answered in the log before this call (skipped).
    asked : int
        Answered in this call.
    failed : int
        Queries that failed after the client's retries (logged; asked again on resume).
    unparsed : int
        Answered queries, in the whole plan, whose reply could not be parsed.
    seconds : float
        Wall time of this call.
    failures : tuple of str
        The first few failure messages.
    requests : int
        Requests sent (an endpoint's exact route, where a ranking's prompt takes one per prefix; else 0).
    """

    planned: int
    already: int
    asked: int
    failed: int
    unparsed: int
    seconds: float
    failures: tuple = field(default=())
    requests: int = 0

    @property
    def complete(self) -> bool:
        """True when every planned query is answered."""
        return self.already + self.asked == self.planned


def logged_messages(messages: Sequence[dict], image_digests: Sequence[str]) -> list[dict]:
    """A query's chat messages as its log record keeps them: every text as sent, each image as its SHA-256.

    Parameters
    ----------
    messages : sequence of dict
        :meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.messages`' messages.
    image_digests : sequence of str
        The hex SHA-256 of each image, in the order the messages carry them.

    Returns
    -------
    list of dict
        ``{"role": ..., "content": ...}`` per message: a text content as it is; a content of parts with each
        ``image_url`` part replaced by ``{"type": "image_url", "sha256": digest}``.

    Examples
    --------
    >>> from fairaudit.experiments.vlm.messages import system_message, user_message
    >>> logged_messages([system_message("Be brief."), user_message("Which office?", [b"png"])], ["ab12"])
    [{'role': 'system', 'content': 'Be brief.'}, {'role': 'user', 'content': [{'type': 'text', 'text': 'Which office?'}, {'type': 'image_url', 'sha256': 'ab12'}]}]
    """
    digests = iter(image_digests)
    out = []
    for m in messages:
        content = m["content"]
        if not isinstance(content, str):
            content = [
                {"type": "image_url", "sha256": next(digests)} if part.get("type") == "image_url" else dict(part)
                for part in content
            ]
        out.append({"role": m["role"], "content": content})
    return out


def _text(message: dict) -> str:
    """The text of a chat message: its content, or its text parts joined."""
    content = message["content"]
    if isinstance(content, str):
        return content
    return "".join(part["text"] for part in content if part.get("type") == "text")


def run_queries(
    task: DeliveryTask,
    model: DecisionModel,
    queries: Sequence[Query],
    log: QueryLog,
    *,
    images: Sequence[bytes] = (),
    concurrency: int = 1,
    progress: bool = True,
) -> RunSummary:
    """Ask every query not yet in the log, logging each reply as it arrives.

    Parameters
    ----------
    task : DeliveryTask
    model : DecisionModel
        Given each query's messages (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.messages`); must be
        thread-safe when ``concurrency`` > 1.
    queries : sequence of Query
        From :func:`plan_queries`.
    log : QueryLog
    images : sequence of bytes
        PNG route images sent with every query, in its user message after the prompt (hashed into the prompt
        hash and logged as their hashes).
    concurrency : int
        Queries in flight at once (≥ 1).
    progress : bool
        Show a progress bar (tqdm, on stderr; off when stderr is not a terminal).

    Returns
    -------
    RunSummary

    Raises
    ------
    InputError
        On concurrency < 1. KeyboardInterrupt propagates after the answered
        queries are logged and pending ones cancelled.
    """
    whole(concurrency, "concurrency", low=1)
    digests = [hashlib.sha256(b).hexdigest() for b in images]
    images = tuple(images)
    already = sum(q.id in log.records for q in queries)
    todo = [q for q in queries if q.id not in log.records]
    start = time.monotonic()
    bar = progress_bar(len(todo), f"{task.name}: {model.name}", progress, unit="query")
    asked, failed, failures = _ask_all(
        todo, lambda q: _answer(task, model, q, digests, images), log, bar, int(concurrency)
    )
    ids = {q.id for q in queries}
    unparsed = sum(1 for k, r in log.records.items() if k in ids and r.get("decision") == UNPARSED)
    return RunSummary(
        planned=len(queries),
        already=already,
        asked=asked,
        failed=failed,
        unparsed=unparsed,
        seconds=time.monotonic() - start,
        failures=tuple(failures),
    )


def decision_label(task: DeliveryTask, choice: int | None, order: Sequence[int] | None) -> str:
    """The decision a parsed reply gives: the option chosen (or served first, of two), or the order of k ≥ 3.

    An order of some of the k ≥ 3 slots is its partial order's decision when the task reads partial rankings
    (:attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.partial`), else unparsed.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> decision_label(HR_DELIVERY, 1, (1, 0))
    'HR2'
    """
    if task.kind == "order" and task.slots > 2:
        index = None if order is None else task.order_decisions.get(tuple(order))
        return UNPARSED if index is None else str(task.decisions[index])
    return UNPARSED if choice is None else str(task.options[choice])


def _answer(
    task: DeliveryTask, model: DecisionModel, q: Query, digests: Sequence[str], images: tuple[bytes, ...]
) -> dict:
    """Ask one query and return its log record: the reply and its parsed decision, or the transport error."""
    from .variants import decision_variants, reply_decision
    from .vlm.parse import parse_reply

    messages = task.messages(q.context, q.profiles, q.texts, images)  # made once: what the model gets and the log keeps
    rec = {
        "type": "query",
        "id": q.id,
        "design": q.design,
        "context": q.context,
        "profiles": [list(p) for p in q.profiles],
        "rep": q.rep,
        "seed": q.seed,
        "epsilon": "inf" if q.epsilon == math.inf else q.epsilon,  # JSON has no infinity: read back with float()
        "truth": None if q.truth is None else {"context": q.truth[0], "profiles": [list(p) for p in q.truth[1]]},
        **({"shown": task.shown_names(q.profiles, q.texts)} if q.texts else {}),
        "prompt_sha256": hashlib.sha256((_text(messages[-1]) + "".join(digests)).encode("utf-8")).hexdigest(),
        "messages": logged_messages(messages, digests),
        "time": _now(),
    }
    t0 = time.monotonic()
    try:
        r = model.reply(q, messages)
    except FairauditError as exc:  # ChatError after the client's retries
        return {
            **rec,
            "model": model.name,
            "status": "error",
            "error": str(exc),
            "latency": round(time.monotonic() - t0, 6),
        }
    if task.replies:  # an exact route's sampled twin: the decision one of whose variants the reply begins with
        said = decision_variants(task, task.replies)
        begins = [i for i, variants in enumerate(said) if any(r.text.startswith(v) for v in variants)]
        decision = str(task.decisions[begins[0]]) if begins else UNPARSED
        error = "" if begins else "begins with no order written out"
    else:
        names = task.reply_names(q.profiles, q.texts)
        parsed = parse_reply(r.text, names, task.kind, named=task.named_by is not None, partial=task.partial)
        listed = reply_decision(task, r.text, names) if task.variants and not parsed.ok else None  # a listed variant
        decision = (
            decision_label(task, parsed.choice, parsed.order) if parsed.ok else decision_label(task, listed, None)
        )
        error = "" if parsed.ok or listed is not None else parsed.error
    return {
        **rec,
        "model": r.model,
        "status": "ok",
        "latency": round(r.latency or time.monotonic() - t0, 6),
        "attempts": r.attempts,
        "reply": r.text,
        "decision": decision,
        "parse_error": error,
    }


def _ask_all(
    todo: Sequence[Query], ask: Callable[[Query], dict], log: QueryLog, bar: ProgressBar, concurrency: int
) -> tuple[int, int, list[str]]:
    """Ask ``todo`` on ``concurrency`` threads, logging each record as it arrives: (answered, failed, first failures).

    At most 4 x ``concurrency`` queries are submitted at a time; on any exception (KeyboardInterrupt too) the
    pending ones are cancelled, the answered ones are in the log, the bar and log are closed, and it propagates.
    """
    failures: list[str] = []
    asked = failed = 0
    pool = ThreadPoolExecutor(max_workers=concurrency)
    try:
        it = iter(todo)
        window = 4 * concurrency
        pending = {pool.submit(ask, q) for q in itertools.islice(it, window)}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                rec = fut.result()
                log.add(rec)
                if rec["status"] == "ok":
                    asked += 1
                else:
                    failed += 1
                    if len(failures) < 5:
                        failures.append(rec["error"])
                bar.update(1)
            pending |= {pool.submit(ask, q) for q in itertools.islice(it, window - len(pending))}
    except BaseException:
        pool.shutdown(wait=True, cancel_futures=True)
        bar.close()
        log.close()
        raise
    pool.shutdown(wait=True)
    bar.close()
    return asked, failed, failures
