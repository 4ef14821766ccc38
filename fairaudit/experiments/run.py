"""``fairaudit experiment``: run a delivery experiment against a model and write its report.

:func:`run_experiment` is the whole pipeline: the scene and its route images
(:mod:`fairaudit.experiments.navigation`), the model (simulated, from a kernel
table, an OpenAI-compatible endpoint, or a real language model run locally),
the queries of the table design (and of the paper's design with
``RunOptions(design="both")``) through the resumable log, the analysis
(:func:`fairaudit.experiments.analysis.analyse`) and the files of
:mod:`fairaudit.experiments.report`; or, with ``RunOptions(design="paper")``,
the paper's design alone and its own analysis and files
(:mod:`fairaudit.experiments.paper_design`), for tasks too large for a table.

The model is a :class:`~fairaudit.experiments.options.ModelSource` and the rest of the run a
:class:`~fairaudit.experiments.options.RunOptions`. A local model (``ModelSource(local_model="smollm2")``,
:mod:`fairaudit.experiments.local_model`) takes one of two routes: without
``samples``, the exact route (its kernel from next-token probabilities, no
queries, no log); with ``samples=N``, the sampled route (N one-token replies per
cell from ``transformers serve`` on 127.0.0.1, through the same client, log and
parser as any endpoint). An endpoint takes the exact route with
``ModelSource(exact=True)``: one request per shown cell for its first token's
log-probabilities (:mod:`fairaudit.experiments.vlm.logprobs`), read as the
local model's next-token probabilities are, with no log either.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias, TypedDict

from fairaudit import InputError

from .analysis import ExperimentAnalysis, analyse, analyse_kernel, epsilon_from_keep
from .exact import SCORINGS, count_prompts
from .harness import QueryLog, RunSummary, plan_queries, run_queries
from .options import (
    DEFAULT_GOALS,
    DEFAULT_KEEPS,
    DEFAULT_MAX_TOKENS,
    DEFAULT_START,
    DEFAULT_TOLERANCE,
    PLAIN_SAMPLING,
    SAMPLING_FIELDS,
    ModelSource,
    RunOptions,
    exact_route,
)
from .paper_design import PaperDesignAnalysis, analyse_paper_design, paper_design_bounds, write_paper_design
from .slots import check_size
from .taskfile import get_task, is_built_in
from .vlm.filter import SPLIT_RULE
from .vlm.models import DecisionModel, EndpointModel, SimulatedModel, simulated_model, simulated_models
from .vlm.tasks import DeliveryTask

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from ._progress import Bar
    from .vlm.client import ChatClient, ChatReply

__all__ = [
    "DEFAULT_KEEPS",
    "SCORING_ROUTES",
    "ExactKernel",
    "ExperimentRun",
    "ModelSource",
    "RunOptions",
    "endpoint_kernel",
    "run_experiment",
    "show_prompts",
]


class _Common(TypedDict):
    """The analysis options both routes pass on (typed for ``**`` unpacking)."""

    epsilons: list[float]
    positions: str
    confidence: float | None
    method: str
    context_epsilon: float | None
    targets: list[float]


@dataclass(frozen=True, eq=False, kw_only=True)
class ExperimentRun:
    """What :func:`run_experiment` did: the query summary, the analysis (None when incomplete) and the files.

    ``route`` is ``"exact"`` on the exact route and ``"sampled"`` otherwise. ``summary`` is None on a local
    model's exact route, which asks no queries; on an endpoint's it counts the requests, one per shown cell
    (``analysis`` is None when one failed after retries: nothing is written then).
    """

    out: Path
    summary: RunSummary | None
    analysis: ExperimentAnalysis | PaperDesignAnalysis | None
    files: tuple
    route: str = "sampled"
    seconds: float = 0.0


@functools.cache
def fairaudit_version() -> str:
    """The installed fairaudit's version, recorded in every run (its log, ``certificate.json``).

    Read from the installed distribution's metadata (:mod:`importlib.metadata`): the distribution that provides the
    ``fairaudit`` package (``fairness-certify`` on PyPI); ``"unknown"`` when none does (the code run from a source
    tree that is not installed).
    """
    from importlib.metadata import packages_distributions, version

    names = packages_distributions().get("fairaudit", [])
    return version(names[0]) if names else "unknown"


def _model(task: DeliveryTask, source: ModelSource, concurrency: int, sampling: dict | None) -> DecisionModel:
    """The decision model of a source other than a local model (made by the run, which serves it)."""
    if source.endpoint:
        from .vlm.client import ChatClient, constraint_body

        assert source.model is not None and sampling is not None  # ModelSource and _prepare check it
        client = ChatClient(
            source.endpoint,
            source.model,
            timeout=source.timeout,
            max_retries=source.max_retries,
            max_concurrency=concurrency,
            temperature=sampling["temperature"],
            top_p=sampling["top_p"],
            max_tokens=sampling["max_tokens"],
            extra_body=dict(PLAIN_SAMPLING)
            if source.sampled_twin
            else constraint_body(sampling["constrain"], sampling.get("replies", ()), name=_schema_name(task)),
        )
        return EndpointModel(client)
    if source.kernel:
        return SimulatedModel.from_csv(task, source.kernel)
    return simulated_model(task, source.simulated or next(iter(simulated_models(task))))


def _schema_name(task: DeliveryTask) -> str:
    """The JSON schema's name of ``constrain="json-schema"``: the task's name in the characters OpenAI allows."""
    import re

    return re.sub(r"[^A-Za-z0-9_-]", "_", task.name)[:64] or "decision"


def _constrained_replies(task: DeliveryTask, constrain: str) -> tuple[str, ...]:
    """The replies a constrained server may give: each parses as one decision (:func:`~fairaudit.experiments.vlm.parse.parse_reply`).

    A choice: its options' keys (``{"answer": key}`` under ``json-schema``). An order of two: the key served first
    under ``json-schema`` (``{"answer": key}``), else both orders written out (``"Recipient2, Recipient1"``).
    Refused (naming ``constrain``): replies that name the candidates (``decision.named_by``: the names differ
    from prompt to prompt), rankings of three or more and partial rankings (too many replies to list, or replies
    of any length).
    """
    if task.named_by is not None:
        raise InputError(
            "constrain",
            f"this task's replies name the candidates by their {task.named_by} (decision.named_by), which differ "
            "from prompt to prompt: no one list of replies to allow; run without `constrain`",
            constrain,
        )
    if task.kind == "choice":
        return tuple(task.options)
    if task.slots != 2 or task.partial:
        raise InputError(
            "constrain",
            f"this task ranks {task.slots} candidates"
            + (" and reads partial rankings (decision.partial)" if task.partial else "")
            + ": the allowed replies are not listed for rankings of three or more; run without `constrain`",
            constrain,
        )
    if constrain == "json-schema":
        return tuple(task.options)
    return tuple(task.order_reply(o, task.options) for o in task.orders)


def _sampling(task: DeliveryTask, source: ModelSource, seed: int) -> dict:
    """The sampled route's stated settings, sent with every request and recorded in the log and the certificate.

    ``temperature``, ``top_p``, ``max_tokens`` (the source's, else 1, 1 and :data:`DEFAULT_MAX_TOKENS`, or for a
    local model room for the longest reply its exact route scores, one token under first-token scoring;
    ``sampled_twin``: 1, 1 and that room, with no top-k or min-p
    truncation), ``seed`` (the run's: each request sends its query's own seed, derived from it and logged with
    the query), ``constrain`` and, when constrained, the allowed ``replies``; ``scoring`` where the replies are read
    as the exact route scores them (``sampled_twin``, a local model: :func:`_twin`).
    """
    scoring = source.scoring or SCORINGS[0]
    if source.sampled_twin:
        return {
            "temperature": PLAIN_SAMPLING["temperature"],
            "top_p": PLAIN_SAMPLING["top_p"],
            "max_tokens": _twin_tokens(task, scoring),
            "seed": int(seed),
            "constrain": "none",
            "top_k": PLAIN_SAMPLING["top_k"],
            "min_p": PLAIN_SAMPLING["min_p"],
            "scoring": scoring,
        }
    default_tokens = _twin_tokens(task, scoring) if source.local_model is not None else DEFAULT_MAX_TOKENS
    out: dict[str, Any] = {
        "temperature": 1.0 if source.temperature is None else source.temperature,
        "top_p": 1.0 if source.top_p is None else source.top_p,
        "max_tokens": default_tokens if source.max_tokens is None else source.max_tokens,
        "seed": int(seed),
        "constrain": source.constrain,
    }
    if source.constrain != "none":
        out["replies"] = list(_constrained_replies(task, source.constrain))
    if source.local_model is not None:  # its replies are read as the exact route scores them
        out["scoring"] = scoring
    return out


def _twin_tokens(task: DeliveryTask, scoring: str) -> int:
    """``max_tokens`` of the exact route's sampled twin: 1 (first-token scoring), or room for the longest reply."""
    replies = _twin(task, scoring).replies
    return max(len(r) for r in replies) if replies else 1  # a token is one character or more


def _twin(task: DeliveryTask, scoring: str) -> DeliveryTask:
    """The task the exact route's sampled twins ask: the exact route's prompt; under continuation scoring a reply
    is read as the decision whose text it begins with (:func:`~fairaudit.experiments.exact.decision_replies`: each
    option's reply, each order of k ≥ 3 written out), the event the exact route scores."""
    import dataclasses

    from . import local_model as lm
    from .exact import by_sequence, decision_replies

    shown, answers = lm.exact_prompt(task)
    if by_sequence(task, scoring):
        return dataclasses.replace(shown, replies=decision_replies(task, answers))
    return shown


def show_prompts(
    experiment: str, count: int, source: ModelSource | None = None, options: RunOptions | None = None
) -> str:
    """The messages a run would send for the first ``count`` shown cells of the table design, as text; asks nothing.

    The cells are the table design's first, whatever ``options.design`` (:func:`~fairaudit.experiments.harness.table_queries`:
    the contexts in order; within one, the profiles of slots 1 to k in ``itertools.product`` order of
    :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.profiles`, the last slot fastest), each at repetition 0 with
    the texts the run draws for it (``options.seed``). Each cell gives its query key, its context and each
    candidate's shown profile (with the text shown where the task writes a value otherwise), then the system message
    and the user message as ``source``'s route sends them (the exact route's prompt for ``exact``,
    ``local_model`` and ``sampled_twin``), each between marker lines, its text verbatim and then one newline; a
    line says when the route images go with the user message (only their SHA-256 goes into the log).

    Parameters
    ----------
    experiment : str
        A built-in task or a task file (:func:`~fairaudit.experiments.taskfile.get_task`).
    count : int
        How many cells, ≥ 1 (fewer when the table has fewer).
    source : ModelSource, optional
        The route whose messages are shown; no model is made, loaded or asked.
    options : RunOptions, optional
        ``seed`` (the texts drawn), ``images`` and ``scene`` (whether route images go with the messages).

    Returns
    -------
    str
        Text for a person, ending with a newline.

    Raises
    ------
    InputError
        ``count`` below 1 (naming ``show_prompts``), or the task's own errors.

    Examples
    --------
    >>> text = show_prompts("package-delivery", 2)
    >>> cell = text[text.index("== cell 2") :]
    >>> print(cell[: cell.index("\\n", cell.index("You are"))])
    == cell 2 of 12: table|documents|low|high|0
    package: documents
    candidate 1: complaint rate = low
    candidate 2: complaint rate = high
    --- no system message ---
    --- user message ---
    You are an intelligent delivery agent tasked with delivering packages to two recipients.
    >>> cell.splitlines()[-2:]
    ['--- then 2 route images (route-1.png, ...: made by the run, hashed in its log) ---', '--- end of cell 2 ---']
    >>> text.endswith("--- end of cell 2 ---\\n")
    True
    """
    import itertools

    from fairaudit import format_label, whole

    from .harness import table_queries, table_queries_needed

    whole(count, "show_prompts", low=1)
    source = ModelSource() if source is None else source
    options = RunOptions() if options is None else options
    task = get_task(experiment)
    sent = task
    text_only = bool(source.exact or source.local_model is not None or source.sampled_twin)
    if text_only:
        from . import local_model as lm

        sent = lm.exact_prompt(task)[0]
    images = not text_only and options.images and (is_built_in(task) or options.scene is not None)
    total = table_queries_needed(task, 1)
    shown = min(int(count), total)
    order = "the profiles" if task.slots == 1 else f"the profiles of slots 1 to {task.slots}, the last slot fastest"
    lines = [
        f"{task.name}: the first {shown} of {total:,} shown cells of the table design (contexts in order; within one, "
        f"{order}), each with the messages the run sends for it; nothing is asked",
        "",
    ]
    for n, q in enumerate(itertools.islice(table_queries(task, 1, options.seed), shown), start=1):
        lines.append(f"== cell {n} of {total:,}: {q.id}")
        lines.append(f"{task.context_name}: {format_label(q.context)}")
        for i, (profile, texts) in enumerate(zip(q.profiles, task.shown_names(q.profiles, q.texts)), start=1):
            parts = []
            for a, v in zip(task.attributes, profile):
                text = texts[a.name]
                own = format_label(v)
                parts.append(f"{a.name} = {own}" + ("" if str(text) == own else f" (shown as {text!r})"))
            lines.append(f"candidate {i}: " + ", ".join(parts))
        system = sent.system_prompt(q.context, q.profiles, q.texts)
        if system is None:
            lines.append("--- no system message ---")
        else:
            lines += ["--- system message ---", system]
        lines += ["--- user message ---", sent.prompt(q.context, q.profiles, q.texts)]
        if images:
            lines.append(
                f"--- then {task.slots} route images (route-1.png, ...: made by the run, hashed in its log) ---"
            )
        lines += [f"--- end of cell {n} ---", ""]
    return "\n".join(lines)


_SCENE_FIELDS = ("scene", "start", "goals", "tolerance")
"""The options of the route images: refused, each naming itself, by a run that sends none."""


def _refuse_images(options: RunOptions, why: str, names: tuple[str, ...] = _SCENE_FIELDS) -> None:
    """Refuse the first of the image options ``names`` that ``options`` gives: this run sends no route images."""
    for name in names:
        if getattr(options, name) is not None:
            raise InputError(name, why)


def _images(task: DeliveryTask, options: RunOptions, images: bool) -> tuple[tuple[bytes, ...], dict | None]:
    """The route images of the scene and its record, checked for equal distances, before anything is written.

    The record (None without images) goes into the log's header and the certificate's ``run``: ``area`` (the
    ``scene`` folder, None for the generated floor), ``start``, ``goals``, ``lengths_m`` (the routes' lengths,
    metres, in the order of ``goals``), ``tolerance`` and ``max_relative_difference`` ((max - min) / max).
    """
    if not images:
        why = (
            "applies to the route images, and this run sends none (`images`)"
            if not options.images
            else "applies to the route images, which a task file gets only with `scene`"
        )
        _refuse_images(options, why)  # (--scene included: given with --no-images it would be ignored)
        return (), None
    from .navigation import delivery_scene

    start = DEFAULT_START if options.start is None else options.start
    goals = DEFAULT_GOALS if options.goals is None else tuple(options.goals)
    tolerance = DEFAULT_TOLERANCE if options.tolerance is None else float(options.tolerance)
    if len(goals) != task.slots:
        raise InputError(
            "goals",
            f"needs one room per candidate, in slot order: the task has {task.slots}, not {len(goals)}",
            ",".join(goals),
        )
    try:
        s = delivery_scene(options.scene, start=start, goals=goals, rtol=tolerance)
    except InputError as exc:  # the scene's own names of the options: the run's
        field = next((f for f in ("start", "goal", "rtol", "area_dir") if exc.field.startswith(f)), None)
        if field is None:
            raise
        field = {"goal": "goals", "rtol": "tolerance", "area_dir": "scene"}.get(field, field)
        if exc.value is InputError._missing:
            raise InputError(field, exc.problem) from None
        raise InputError(field, exc.problem, exc.value) from None
    record = {
        "area": None if options.scene is None else str(options.scene),
        "start": start,
        "goals": list(goals),
        "lengths_m": [float(x) for x in s.check.lengths],
        "tolerance": tolerance,
        "max_relative_difference": float(s.check.max_relative_difference),
    }
    if not s.check.equal:
        raise InputError(
            "scene",
            f"the routes from {start} to {', '.join(goals)} are not of equal length ({_lengths(record)}; "
            f"{s.check.max_relative_difference:.1%} apart, more than {_percent(tolerance)} (`tolerance`)): the "
            "paper's experiment needs equal distances",
            str(options.scene or "generated floor"),
        )
    return tuple(s.images), record


def _lengths(record: dict) -> str:
    return ", ".join(f"{x:.2f} m" for x in record["lengths_m"])


def _percent(fraction: float) -> str:
    """``0.05`` as ``5%``, ``0.025`` as ``2.5%``."""
    return f"{100 * fraction:.6g}%"


def _scene_line(record: dict) -> str:
    """The equal-distance check passed, in one line: the lengths, how far apart, the tolerance."""
    return (
        f"route lengths {_lengths(record)}: {record['max_relative_difference']:.1%} apart, within the tolerance "
        f"{_percent(record['tolerance'])}"
    )


def _settings(plan: _Plan, options: RunOptions) -> dict:
    """The settings of a sampled run that its log's header records and ``resume`` compares (:func:`_check_resumed`).

    ``seed``, ``samples``, ``design``, ``positions``, ``epsilons`` (the candidate's budgets, nats) and ``filter``
    (as asked: ``{"keep": [...]}`` or ``{"epsilon": [...]}``), ``context_epsilon``, ``images`` (route images per
    query), ``prompt`` (:func:`_prompt_record`), and where they apply ``scene`` (:func:`_images`) and ``sampling``
    (:func:`_sampling`).
    """
    out: dict[str, Any] = {
        "seed": int(options.seed),
        "samples": plan.samples,
        "design": options.design,
        "positions": plan.common["positions"],
        "epsilons": plan.common["epsilons"],
        "filter": {k: v for k, v in plan.asked.items() if k != "split"},
        "context_epsilon": options.context_epsilon,
        "images": len(plan.images),
        "prompt": plan.prompt,
    }
    if plan.scene is not None:
        out["scene"] = plan.scene
    if plan.sampling is not None:
        out["sampling"] = plan.sampling
    return out


RESUME_RULE = (
    "each changes which queries are asked or how their replies are counted; resume with the logged settings, or "
    "start a new run in another folder"
)
"""The end of :func:`_check_resumed`'s message: why, and what to do."""


def _shown(value: Any) -> str:
    """A setting's value in a message: text quoted, ``none`` for None, a list's numbers to 6 digits."""
    if value is None:
        return "none"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(f"{v:.6g}" if isinstance(v, float) else _shown(v) for v in value) + "]"
    return repr(value)


def _filter_change(before: dict, now: dict) -> str | None:
    """The privacy filter's change in a message (as each run asked it: keep or ε), or None when the ε are the same.

    The budgets are compared as the query keys write them (12 significant digits), so ``keeps`` and ``epsilons``
    that give the same budgets are the same filter.
    """
    from .harness import eps_key

    if "epsilons" not in before:
        return None
    then = [eps_key(float(e)) for e in before["epsilons"]]
    if then == [eps_key(float(e)) for e in now["epsilons"]]:
        return None
    asked_then, asked_now = before.get("filter") or {"epsilon": before["epsilons"]}, now["filter"]
    (kind_then, values_then), (kind_now, values_now) = next(iter(asked_then.items())), next(iter(asked_now.items()))
    name = {"keep": "keeps", "epsilon": "epsilons"}
    if kind_then == kind_now:
        return f"`{name[kind_now]}` {_shown(values_then)}, not {_shown(values_now)}"
    return f"`{name[kind_then]}` {_shown(values_then)}, not `{name[kind_now]}` {_shown(values_now)}"


def _changes(before: dict, now: dict, extend: bool) -> list[str]:
    """Each setting of ``now`` that differs from the log's ``before``, as ``"`name` logged, not new"``, in the order of
    :func:`_settings`. A setting the log does not record (a log from before it was recorded) is not compared;
    ``samples`` may grow with ``extend``."""
    parts: list[str] = []

    def compare(name: str, then: Any, new: Any, shown: Callable[[Any], str] = _shown) -> None:
        if then != new:
            parts.append(f"`{name}` {shown(then)}, not {shown(new)}")

    if "seed" in before:
        compare("seed", before["seed"], now["seed"])
    then, new = before.get("samples"), now["samples"]
    if then is not None and new != then and not (extend and new > then):
        hint = " (to add samples, give `extend`)" if new > then else ""
        parts.append(f"`samples` {then}, not {new}{hint}")
    for name in ("design", "positions"):
        if name in before:
            compare(name, before[name], now[name])
    filt = _filter_change(before, now)
    if filt is not None:
        parts.append(filt)
    if "context_epsilon" in before:
        compare("context_epsilon", before["context_epsilon"], now["context_epsilon"])
    if "images" in before and before["images"] != now["images"]:
        parts.append(f"route images {before['images']} per query, not {now['images']} (`images`)")
    scene_then, scene_now = before.get("scene"), now.get("scene")
    if isinstance(scene_then, dict) and scene_now is not None:
        for name in ("start", "goals", "tolerance"):
            if name in scene_then:
                goals = lambda v: repr(",".join(map(str, v or ())))  # noqa: E731 (as given: comma-separated)
                compare(name, scene_then[name], scene_now[name], goals if name == "goals" else _shown)
    prompt_then = before.get("prompt")
    if isinstance(prompt_then, dict) and prompt_then.get("sent") != now["prompt"]["sent"]:
        parts.append(f"the {prompt_then.get('sent')} prompt, not the {now['prompt']['sent']}")
    sampling_then, sampling_now = before.get("sampling"), now.get("sampling") or {}
    if isinstance(sampling_then, dict):
        for name in (*SAMPLING_FIELDS, "scoring"):  # the scoring says how the twins read a reply
            if name in sampling_then:
                compare(name, sampling_then[name], sampling_now.get(name))
    return parts


def _check_resumed(plan: _Plan, options: RunOptions) -> _Plan:
    """Refuse to resume a run with settings other than its log's, naming each (:func:`_changes`) in one line.

    Returns the plan, with ``extend_from`` set to the logged samples when ``extend`` lets them grow. A folder
    without a log passes (resuming it starts the run).
    """
    from .harness import logged_settings

    before = logged_settings(plan.log_path)
    if before is None:  # no log, or not a log (QueryLog refuses it in its own words)
        return plan
    parts = _changes(before, _settings(plan, options), options.extend)
    if parts:
        raise InputError(
            "resume", f"the run in {plan.out} was made with other settings: {'; '.join(parts)}: {RESUME_RULE}"
        )
    logged = before.get("samples")
    if options.extend and isinstance(logged, int) and plan.samples > logged:
        return dataclasses.replace(plan, extend_from=logged)
    return plan


LOCK_NAME = ".fairaudit.lock"
"""The lock file in a run's folder: held (an OS lock, ``filelock.FileLock``) while a run uses the folder."""


def _check_log(log_path: Path, resume: bool, exact: bool) -> None:
    """Refuse a folder whose log belongs to a run this one must not touch."""
    out = log_path.parent
    if log_path.exists() and log_path.stat().st_size > 0 and not resume:
        raise InputError(
            "out",
            "holds a run already (queries.jsonl); pass `resume` to continue it, or choose another folder",
            str(out),
        )
    if exact and log_path.exists():
        raise InputError("out", "holds a sampled run (queries.jsonl); the exact route needs another folder", str(out))


@contextmanager
def _claim(out: Path) -> Iterator[Path]:
    """Make ``out`` and hold its lock for a ``with`` block: one run per folder; a second is refused at once.

    The lock is the operating system's (``filelock.FileLock``: ``flock`` on Unix, a byte-range lock on Windows),
    so it is released when the block ends, however it ends, and by the system when the process dies (even by
    SIGKILL). The lock file stays in the folder, empty; a later run takes it again.
    """
    try:
        from filelock import FileLock, Timeout
    except ImportError:
        raise InputError(
            "out",
            "one run per folder needs filelock, which is not installed: pip install 'fairness-certify[experiment]'",
        ) from None
    out.mkdir(parents=True, exist_ok=True)  # with its missing parents, as `mkdir -p`
    path = out / LOCK_NAME
    lock = FileLock(path, timeout=0)
    try:
        lock.acquire()
    except Timeout:
        raise InputError(
            "out",
            f"is in use by another fairaudit run (lock {path}); wait for it to finish or choose another folder",
            str(out),
        ) from None
    try:
        yield path
    finally:
        lock.release()


def run_experiment(
    experiment: str,
    out: str | Path,
    source: ModelSource | None = None,
    options: RunOptions | None = None,
    *,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
) -> ExperimentRun:
    """Run one of the paper's delivery experiments and write its report to ``out``.

    Parameters
    ----------
    experiment : {"hr-delivery", "package-delivery"}
    out : str or Path
        Folder of the run (created, with its missing parent folders): the log, tables, certificate, figures,
        report.

        One run at a time per folder: the run holds the lock ``out/.fairaudit.lock``
        from before it writes anything until it returns, and a second run on the
        same folder is refused at once (an :class:`InputError` on ``out``).
    source : ModelSource, optional
        The decision model: a simulated model (the default: the task's first),
        a kernel table, an OpenAI-compatible endpoint, or a real language
        model run on this machine (text only: no route images are made or sent).
    options : RunOptions, optional
        The design, samples, privacy budgets, targets, seed, resuming,
        concurrency, bands and images (default :class:`RunOptions` ()).
    progress : bool
        A progress bar on stderr.
    log : callable, optional
        Called with one line per step of a local model (converting, loading,
        serving), and with the equal-distance check's line when route images
        are made ("route lengths 6.97 m, 6.93 m: 0.6% apart, within the
        tolerance 5%"); default none.

    Returns
    -------
    ExperimentRun

    Raises
    ------
    InputError
        On invalid options (naming the parameter), a log made by another run
        (or, resumed, with other settings: ``resume``, naming each changed
        setting with its logged and its new value: docs/experiments.md, "The
        log, and resuming"; ``samples`` may grow with ``extend``), ``extend`` on the exact route, a
        folder in use by another run (its lock held), an unreadable kernel, a
        scene whose routes differ in length by more than ``tolerance`` (naming
        ``scene``, with the lengths), an unknown room (naming ``start`` or
        ``goals`` and listing the scene's rooms), ``goals`` not one room per
        candidate, ``start``, ``goals`` or ``tolerance`` given for a run that
        sends no route images, or a local model that is not installed (naming
        the install command).

    Examples
    --------
    >>> from fairaudit.experiments.options import ModelSource, RunOptions
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     done = run_experiment(
    ...         "package-delivery",
    ...         Path(tmp) / "run",
    ...         ModelSource(simulated="fair"),
    ...         RunOptions(samples=1, keeps=[0.7], images=False, targets=[]),
    ...         progress=False,
    ...     )
    ...     done.summary.planned, done.analysis.model, (done.out / "report.md").is_file()
    (12, 'fair', True)
    """
    source = ModelSource() if source is None else source
    options = RunOptions() if options is None else options
    task = get_task(experiment)
    options = _task_defaults(task, options)
    plan = _prepare(task, Path(out), source, options)  # everything checked; nothing written yet
    with _claim(plan.out):  # makes out and locks it: a second run on it is refused here, before it writes anything
        _check_log(plan.log_path, options.resume, plan.exact)  # again under the lock: another run may have ended
        if options.resume and not plan.exact:  # every setting the log records, before a route image is written
            plan = _check_resumed(plan, options)
        if plan.scene is not None and log is not None:
            log(_scene_line(plan.scene))
        if plan.exact:
            name, make = _exact_route(task, source, plan, progress, log)
            return _run_exact(task, name, make, plan, options.seed)
        return _run_sampled(task, plan, source, options, progress, log)


def _task_defaults(task: DeliveryTask, options: RunOptions) -> RunOptions:
    """The options with what they leave out taken from the task file: positions and the budgets."""
    changes: dict[str, Any] = {}
    if options.positions is None:
        changes["positions"] = task.positions
    if options.keeps is None and options.epsilons is None:
        if task.epsilons is not None:
            changes["epsilons"] = task.epsilons
        else:
            changes["keeps"] = task.keeps if task.keeps is not None else DEFAULT_KEEPS
    return dataclasses.replace(options, **changes) if changes else options


@dataclass(frozen=True, eq=False)
class _Plan:
    """A run checked and ready: where it writes, its route, model, images and the analysis options."""

    out: Path
    log_path: Path
    exact: bool
    model: DecisionModel | None
    images: tuple[bytes, ...]
    samples: int
    concurrency: int
    common: _Common
    client: ChatClient | None = None  # the exact route of an endpoint: a client that asks for log-probabilities
    asked: dict = dataclasses.field(default_factory=dict)  # the filter asked for: {"keep": [...]} or {"epsilon": [...]}
    scene: dict | None = None  # the route images' scene: start, goals, lengths, tolerance (_images)
    sampling: dict | None = None  # a server's sampled route: the stated settings (_sampling)
    scoring: str | None = None  # how the exact route scores a decision and its twins read a reply (None: parsed)
    prompt: dict = dataclasses.field(default_factory=dict)  # which prompt the route sends (_prompt_record)
    extend_from: int | None = None  # resumed with `extend`: the logged samples, which grow to `samples`


def _prepare(task: DeliveryTask, out: Path, source: ModelSource, options: RunOptions) -> _Plan:
    """Check everything a run needs and make its model, before anything is written."""
    positions = options.positions or task.positions
    keeps = DEFAULT_KEEPS if options.keeps is None else options.keeps
    eps = [epsilon_from_keep(task, k, positions) for k in keeps] if options.epsilons is None else list(options.epsilons)
    asked = {"keep": [float(k) for k in keeps]} if options.epsilons is None else {"epsilon": [float(e) for e in eps]}
    if options.design == "paper":  # no kernel: the bounds are refused here when they need too large a matrix
        for e in eps:
            paper_design_bounds(task, e, positions, context_epsilon=options.context_epsilon)
    else:
        check_size(task)  # before any model or kernel of the table design is made
    if source.exact and options.samples is not None:
        raise InputError("samples", "give `samples` or `exact`, not both")
    exact = exact_route(source.exact, source.local_model, options.samples)
    if exact and options.extend:
        raise InputError("extend", "adds samples to a sampled run's log, and the exact route samples nothing")
    if exact:
        count_prompts(task)  # every choice of the texts is scored: refused here, before a model loads or a file is made
    if (exact or source.sampled_twin) and task.partial:
        raise InputError(
            "sampled_twin" if source.sampled_twin else "exact",
            "this task reads partial rankings (decision.partial), and the exact routes score complete orders only: "
            "run with `samples` N",
        )
    if source.sampled_twin and task.named_by is not None:
        raise InputError(
            "sampled_twin", "reads replies of options' keys; this task's replies name the candidates: run with `exact`"
        )
    scoring = _scoring(task, source, exact)
    # route images belong to the paper's navigation tasks; a task file gets them only with a scene asked for
    images = options.images and (is_built_in(task) or options.scene is not None)
    m: DecisionModel | None = None
    client: ChatClient | None = None
    sampling = None
    if (source.endpoint or source.local_model is not None) and not exact:
        sampling = _sampling(task, source, options.seed)
    elif exact:
        given = next((n for n in SAMPLING_FIELDS if getattr(source, n) not in (None, "none")), None)
        if given is not None:  # a local model without samples: its exact route samples nothing
            raise InputError(given, "sets how a server samples, and the exact route samples nothing: give `samples` N")
    if source.local_model is not None:
        _check_local(source.local_model, exact, options)
        images = False
    elif exact:
        _check_exact_endpoint(options)
        # one request at a time by default: a server that batches concurrent requests (llama-server) computes a
        # quantized model's logits differently per batch, so the exact kernel would depend on the timing
        client = _exact_client(source, options.concurrency or 1)
        images = False
    else:
        m = _model(task, source, options.concurrency or 4, sampling)
        if source.sampled_twin:  # the exact route's sampled twin: its text-only prompt
            _refuse_images(options, "`sampled_twin` samples the exact route's text-only prompt: no route images")
            images = False
    if out.exists() and not out.is_dir():
        raise InputError("out", "is a file, not a folder", str(out))
    above = next((p for p in out.parents if p.exists()), None)  # the missing folders are made by _claim
    if above is not None and not above.is_dir():
        raise InputError("out", f"cannot be made: {above} is a file, not a folder", str(out))
    log_path = out / "queries.jsonl"
    _check_log(log_path, options.resume, exact)
    pngs, scene = _images(task, options, images)  # a bad scene is refused before out is touched
    common: _Common = {
        "epsilons": eps,
        "positions": positions,
        "confidence": options.confidence,
        "method": options.method,
        "context_epsilon": options.context_epsilon,
        "targets": [float(t) for t in options.targets],
    }
    return _Plan(
        out=out,
        log_path=log_path,
        exact=exact,
        model=m,
        images=pngs,
        samples=20 if options.samples is None else int(options.samples),
        concurrency=options.concurrency or (4 if source.endpoint else 1),
        common=common,
        client=client,
        scene=scene,
        asked={**asked, "split": SPLIT_RULE},
        sampling=sampling,
        scoring=scoring,
        prompt=_prompt_record(task, scoring is not None),
    )


def _prompt_record(task: DeliveryTask, text_only: bool) -> dict:
    """``run.prompt`` of ``certificate.json``: whether the route sent the task's own prompt or the exact route's.

    A model with an exact route gets the exact route's prompt on every route (docs/experiments.md, "The messages of
    a query"): for the built-in tasks, their JSON answer paragraph replaced by a request for the option's number.
    """
    from . import local_model as lm

    if text_only and lm.exact_prompt(task)[0] is not task:
        return {
            "sent": "exact route's",
            "rule": "a model with an exact route gets the exact route's prompt on every route: the task's answer "
            "paragraph replaced by a request for the option's number alone",
        }
    return {"sent": "task's own", "rule": "the task's prompt as written"}


def _scoring(task: DeliveryTask, source: ModelSource, exact: bool) -> str | None:
    """The run's scoring (:data:`~fairaudit.experiments.exact.SCORINGS`), checked on the task and on every reply the
    exact route would score, before anything is made; None on a route that parses free replies."""
    if not (exact or source.local_model is not None or source.sampled_twin):
        return None
    from . import local_model as lm
    from .exact import by_sequence, check_scoring, exact_prompts, prompt_replies

    scoring = check_scoring(task, source.scoring or SCORINGS[0])
    if by_sequence(task, scoring):
        answers = lm.exact_prompt(task)[1]
        for p in exact_prompts(task) if task.named_by is not None else exact_prompts(task)[:1]:
            prompt_replies(task, answers, p)  # one reply beginning another is refused, naming both
    return scoring


def _check_local(name: str, exact: bool, options: RunOptions) -> None:
    """What a local model cannot do (route images; the paper's design without samples), and that it is installed."""
    from . import local_model as lm

    _refuse_images(options, f"the local model {name} reads text only: it takes no route images")
    if exact and options.design != "table":
        raise InputError("design", "the paper's design samples through the filter: give `samples` N too")
    lm.check(name)  # not installed: one line naming the install command, before anything is written


def _check_exact_endpoint(options: RunOptions) -> None:
    """What an endpoint's exact route cannot do: route images, the paper's design."""
    _refuse_images(options, "the exact route reads text only: it takes no route images")
    if options.design != "table":
        raise InputError("design", "the paper's design samples through the filter: run with `samples` N, not `exact`")


def _exact_client(source: ModelSource, concurrency: int) -> ChatClient:
    """The client of an endpoint's exact route: one-token replies with the first token's top log-probabilities."""
    from .vlm.client import ChatClient
    from .vlm.logprobs import TOP_LOGPROBS

    assert source.endpoint is not None and source.model is not None  # ModelSource checks it
    return ChatClient(
        source.endpoint,
        source.model,
        timeout=source.timeout,
        max_retries=source.max_retries,
        max_concurrency=concurrency,
        max_tokens=1,
        top_logprobs=TOP_LOGPROBS,
    )


def _run_sampled(
    task: DeliveryTask,
    plan: _Plan,
    source: ModelSource,
    options: RunOptions,
    progress: bool,
    log: Callable[[str], None] | None,
) -> ExperimentRun:
    """The sampled route: ask the queries through the log, then analyse and write the report when all are answered."""
    from fairaudit import write_atomic

    out, eps = plan.out, plan.common["epsilons"]
    for i, png in enumerate(plan.images, start=1):
        write_atomic(out / f"route-{i}.png", png, field="out")
    with ExitStack() as stack:
        m = plan.model
        if source.local_model is not None:
            assert plan.sampling is not None  # _prepare states a served model's sampling
            m = stack.enter_context(_served(source.local_model, out, source, plan.sampling, log))
        if plan.scoring is not None:  # a local model's or an endpoint's sampled twin: the exact route's replies
            task = _twin(task, plan.scoring)
        assert m is not None
        summary, records, logged = _ask(task, m, plan, options, progress)
    files = [plan.log_path] + [out / f"route-{i}.png" for i in range(1, len(plan.images) + 1)]
    if not summary.complete:
        return ExperimentRun(out=out, summary=summary, analysis=None, files=tuple(files), seconds=summary.seconds)
    run = {
        "seed": int(options.seed),
        "design": options.design,
        "fairaudit": fairaudit_version(),
        "task_sha256": task.digest,
        "prompt": plan.prompt,
        "filter": plan.asked,
    }
    run["seconds"] = round(summary.seconds, 3)
    run.update(logged)
    if plan.scene is not None:
        run["scene"] = plan.scene
    if plan.sampling is not None:
        run["sampling"] = plan.sampling
    analysis: ExperimentAnalysis | PaperDesignAnalysis
    if options.design == "paper":
        common = {k: v for k, v in plan.common.items() if k != "targets"}
        analysis = analyse_paper_design(task, records, model=m.name, samples=plan.samples, **common)  # type: ignore[arg-type]
        files += write_paper_design(analysis, out, run)
    else:
        paper_eps = eps if options.design == "both" else ()
        analysis = analyse(task, records, model=m.name, samples=plan.samples, paper_epsilons=paper_eps, **plan.common)
        files += _write(analysis, out, run)
    return ExperimentRun(out=out, summary=summary, analysis=analysis, files=tuple(files), seconds=summary.seconds)


def _ask(
    task: DeliveryTask, m: DecisionModel, plan: _Plan, options: RunOptions, progress: bool
) -> tuple[RunSummary, list[dict], dict]:
    """Plan the run's queries, ask those not yet in its log, and return the summary, the answered records of the
    plan, and what the certificate's ``run`` says of the log: ``replies`` (``used``, the plan's answered queries;
    ``logged``, every answered query in the log) and, when the run was extended, ``extended``."""
    n, eps = plan.samples, plan.common["epsilons"]
    header = {
        "task": task.name,
        "task_sha256": task.digest,
        "model": m.name,
        "fairaudit": fairaudit_version(),
        **_settings(plan, options),
    }
    positions = options.positions or task.positions
    if options.design == "paper":  # the true prompts without a filter, for the baseline
        queries = plan_queries(task, "paper", n, options.seed, epsilons=[math.inf], positions=positions)
    else:
        queries = plan_queries(task, "table", n, options.seed)
    if options.design != "table":
        queries += plan_queries(
            task,
            "paper",
            n,
            options.seed,
            epsilons=eps,
            positions=positions,
            context_epsilon=options.context_epsilon,
        )
    with QueryLog(plan.log_path, header, resume=options.resume) as qlog:
        if plan.extend_from is not None:
            qlog.extend(n, plan.extend_from)
        summary = run_queries(
            task, m, queries, qlog, images=plan.images, concurrency=plan.concurrency, progress=progress
        )
        records = [qlog.records[q.id] for q in queries if q.id in qlog.records]
        logged: dict[str, Any] = {"replies": {"used": len(records), "logged": len(qlog.records)}}
        if qlog.extensions:
            logged["extended"] = [{"from": e["from"], "to": e["to"], "time": e["time"]} for e in qlog.extensions]
    return summary, records, logged


@contextmanager
def _served(
    name: str, out: Path, source: ModelSource, sampling: dict, log: Callable[[str], None] | None
) -> Iterator[DecisionModel]:
    """The local model behind ``transformers serve`` (its output in ``out/server.log``), for a ``with`` block."""
    from . import local_model as lm
    from .vlm.client import ChatClient

    folder = lm.prepare(name, log=log)
    if log:
        log(f"serving {name} on 127.0.0.1 (output in {out / 'server.log'})")
    with lm.serve(folder, log=out / "server.log") as url:
        client = ChatClient(
            url,
            str(folder),
            temperature=sampling["temperature"],
            top_p=sampling["top_p"],
            max_tokens=sampling["max_tokens"],
            timeout=source.timeout,
            max_retries=source.max_retries,
        )
        with client:
            yield lm.ServedModel(client, name)


SERVER_TEMPLATE = "the server's chat template"
"""``run.scoring.rendering`` of the chat routes: the server renders the messages with its model's template."""

MODEL_TEMPLATE = "the model's chat template (its tokenizer's, in process)"
"""``run.scoring.rendering`` of a local model's exact route."""


@dataclass(frozen=True)
class ExactKernel:
    """An exact route's kernel and how it was scored (:func:`endpoint_kernel`; a local model's in process).

    Attributes
    ----------
    probabilities : numpy.ndarray, shape (n_contexts, n_profiles, ..., n_profiles, n_decisions), or None
        P(decision | shown cell), the layout of :func:`fairaudit.experiments.local_model.exact_kernel`; None when a
        request failed after its retries.
    summary : RunSummary or None
        The requests' summary; None in process (no requests).
    route : str
        Where the probabilities came from (:data:`SCORING_ROUTES`).
    missing : float
        An upper bound on the probability the options of any one cell may lack because the server did not list a
        token (no unit): 0 on the exact routes (prompt log-probabilities, in process); on the top log-probabilities
        routes, the largest over the prompts of :func:`~fairaudit.experiments.vlm.logprobs.reply_bounds`'s bound
        (continuation) or of the mass outside the first token's list (first-token).
    rendering : str
        How the messages became the text the model read: :data:`SERVER_TEMPLATE`, :data:`MODEL_TEMPLATE` (in
        process) or :data:`~fairaudit.experiments.vlm.messages.CHATML` (text completions).
    """

    probabilities: npt.NDArray[np.float64] | None
    summary: RunSummary | None
    route: str
    missing: float = 0.0
    rendering: str = SERVER_TEMPLATE

    def record(self, method: str | None) -> dict:
        """``run.scoring`` of ``certificate.json``: the method, the route, the bound on the mass not listed and the
        rendering of the messages."""
        return {
            "method": method,
            "route": self.route,
            "missing_bound": float(self.missing),
            "rendering": self.rendering,
        }


SCORING_ROUTES = ("prompt-logprobs", "completions-echo", "top-logprobs", "first-token", "in-process")
"""How an exact route read its probabilities, recorded in ``certificate.json``'s ``run.scoring.route``:
``"prompt-logprobs"``, the reply's tokens scored as the end of the prompt (vLLM's ``prompt_logprobs``; exact);
``"completions-echo"``, the same from the text completions' echo of the messages rendered in ChatML (exact under
that rendering); ``"top-logprobs"``, the next token's top list after each prefix of the replies (lower bounds,
:func:`endpoint_kernel`); ``"first-token"``, the first token's top list (first-token scoring); ``"in-process"``, a
local model's own next-token probabilities (exact)."""

_KernelMaker: TypeAlias = "Callable[[], ExactKernel]"
"""What makes an exact route's kernel (:class:`ExactKernel`)."""


def _exact_route(
    task: DeliveryTask, source: ModelSource, plan: _Plan, progress: bool, log: Callable[[str], None] | None
) -> tuple[str, _KernelMaker]:
    """The model's name and the function that makes its exact kernel: a local model's, or an endpoint's."""
    scoring = plan.scoring or SCORINGS[0]
    if source.local_model is not None:
        name = source.local_model

        def local() -> ExactKernel:
            from . import local_model as lm

            kernel = lm.exact_kernel(task, lm.load(name, log=log), scoring=scoring, progress=progress)
            return ExactKernel(kernel, None, "in-process", rendering=MODEL_TEMPLATE)

        return name, local
    client = plan.client
    assert client is not None and source.model is not None  # _prepare made it

    def endpoint() -> ExactKernel:
        with client:
            return endpoint_kernel(task, client, scoring=scoring, progress=progress)

    return source.model, endpoint


def _run_exact(task: DeliveryTask, name: str, make_kernel: _KernelMaker, plan: _Plan, seed: int) -> ExperimentRun:
    """The exact route: the kernel ``make_kernel`` gives, analysed and written (nothing when it gives none)."""
    from . import local_model as lm

    out = plan.out
    t0 = time.perf_counter()
    made = make_kernel()
    probabilities, summary = made.probabilities, made.summary
    if probabilities is None:  # a request failed: no kernel, nothing written
        seconds = time.perf_counter() - t0
        return ExperimentRun(out=out, summary=summary, analysis=None, files=(), route="exact", seconds=seconds)
    analysis = analyse_kernel(task, lm.exact_law(task, probabilities), model=name, **plan.common)
    seconds = time.perf_counter() - t0
    files = _write(
        analysis,
        out,
        {
            "seed": int(seed),
            "design": "table",
            "fairaudit": fairaudit_version(),
            "task_sha256": task.digest,
            "prompt": plan.prompt,
            "filter": plan.asked,
            "seconds": round(seconds, 3),
            "scoring": made.record(plan.scoring),
        },
    )
    return ExperimentRun(
        out=out, summary=summary, analysis=analysis, files=tuple(files), route="exact", seconds=seconds
    )


PREFILL = {"continue_final_message": True, "add_generation_prompt": False}
"""Request fields that make a server continue the final assistant message (llama-server, vLLM): a reply's prefix."""

PROMPT_LOGPROBS = {"prompt_logprobs": 0}
"""The request field that asks vLLM for the prompt's own tokens' log-probabilities (``prompt_logprobs``, 0: no
alternatives), the probe of the prompt log-probabilities route."""

REJECTED = (400, 422)
"""HTTP statuses of a server that rejects a request field it does not know (OpenAI 400, a FastAPI validation 422)."""

NO_ROUTE = (404, 405)
"""HTTP statuses of a server that does not serve a path (chat completions, text completions)."""


def endpoint_kernel(
    task: DeliveryTask, client: ChatClient, *, scoring: str = "continuation", progress: bool = False
) -> ExactKernel:
    """An endpoint's exact kernel from the log-probabilities of its replies' tokens.

    First-token scoring (a choice, or an order of two): one request per prompt, its first token's top
    log-probabilities read as P(decision) (:func:`~fairaudit.experiments.vlm.logprobs.decision_probabilities`).
    Continuation scoring: P(the reply begins with each decision's text r) = Π_t P(r_t | prompt, r_<t), the chain
    rule (lm-evaluation-harness's ``loglikelihood`` of r as the continuation of the prompt), by the first of these
    routes the server serves:

    1. ``"prompt-logprobs"`` (vLLM): one request per (prompt, reply), the reply sent as the assistant's message
       being continued (:data:`PREFILL`) with ``prompt_logprobs: 0``; the reply's tokens are the prompt's last,
       and their log-probabilities add up to log P(r | prompt)
       (:func:`~fairaudit.experiments.vlm.logprobs.reply_logprob`). Exact.
    2. ``"top-logprobs"`` (llama-server, any server that continues the assistant's message and lists the next
       token's top log-probabilities): one request per prefix of the replies, each prefix once
       (:func:`~fairaudit.experiments.vlm.logprobs.reply_bounds`). Each probability is a lower bound, exact when
       the lists hold every token of the replies; :attr:`ExactKernel.missing` bounds what it may lack.
    3. ``"completions-echo"`` (a server whose chat completions give no log-probabilities, or that has none, but
       whose text completions echo the prompt's: vLLM, OpenAI's legacy completions): one request per (prompt,
       reply) to ``/v1/completions`` with ``echo: true, logprobs: 1, max_tokens: 0``
       (:meth:`~fairaudit.experiments.vlm.client.ChatClient.echo`), the prompt being the messages rendered in
       ChatML (:func:`~fairaudit.experiments.vlm.messages.chatml`, the stated rendering: a text-completions
       server does not say its model's chat template) followed by the reply; the reply's tokens are the echo's
       last. Exact under that rendering, which ``run.scoring.rendering`` records.

    The route is chosen once per run by a probe: the first request (the first prompt's, no reply yet) asks for
    ``prompt_logprobs`` too. A reply that has them selects route 1; a reply with top log-probabilities only (the
    server ignores the field) is the first request of route 2; a server that rejects the field (HTTP 400 or 422)
    gets that request again without it. A chat reply with no log-probabilities at all, or a server without chat
    completions (HTTP 404 or 405), turns to route 3, whose first request (the first prompt's first reply) is its
    probe. No other request is sent twice but by the client's retries. The mass on no option, 1 − Σ P(r), is the
    cell's ``unparsed``. A cell whose candidates have several texts averages over every choice of them
    (:func:`fairaudit.experiments.exact.exact_prompts`).

    Parameters
    ----------
    task : DeliveryTask
    client : fairaudit.experiments.vlm.client.ChatClient
        Made with ``max_tokens=1`` and ``top_logprobs`` (the run's: 20); its ``max_concurrency`` prompts are in
        flight at once, each request with the client's retries.
    scoring : {"continuation", "first-token"}
        :data:`fairaudit.experiments.exact.SCORINGS`.
    progress : bool
        A progress bar on stderr, by prompt.

    Returns
    -------
    ExactKernel
        The probabilities, shape (n_contexts, n_profiles, ..., n_profiles, n_decisions), no unit, or None when a
        request failed after its retries (the rest are then cancelled); the summary (prompts planned, answered,
        failed with the first failure's message, requests sent); the route (``"prompt-logprobs"``,
        ``"completions-echo"``, ``"top-logprobs"`` or ``"first-token"``); the bound on the mass not listed; the
        rendering of the messages.

    Raises
    ------
    InputError
        ``endpoint`` when no route gives log-probabilities, when the route chosen stops giving them, or when a
        prompt's scored tokens do not end with the reply or a token straddles the reply's start; ``exact`` when a likely first token begins two options' replies (first-token scoring,
        :func:`fairaudit.experiments.vlm.logprobs.shared_first_token`); ``attribute.text`` when the texts make too
        many prompts.
    """

    import numpy as np

    from . import local_model as lm
    from ._progress import progress_bar
    from .exact import by_sequence, exact_prompts, prompt_replies
    from .vlm.client import ChatError
    from .vlm.logprobs import decision_probabilities, reply_bounds, reply_logprob
    from .vlm.messages import CHATML, chatml

    shown, answers = lm.exact_prompt(task)
    prompts = exact_prompts(task)
    n = len(task.profiles)
    out = np.zeros((len(task.contexts), *([n] * task.slots), len(task.decisions)))
    sequences = by_sequence(task, scoring)
    uncached = {"cache_prompt": False} if client.is_llama_server() else {}  # the same numbers whatever came before
    t0 = time.monotonic()

    sent: list[str] = []  # one entry per request (list.append is atomic)
    missing: dict[int, float] = {}  # per prompt: the bound on the mass its options lack

    def summary(answered: int, failure: str | None) -> RunSummary:
        return RunSummary(
            planned=len(prompts),
            already=0,
            asked=answered,
            failed=int(failure is not None),
            unparsed=0,
            seconds=time.monotonic() - t0,
            failures=(failure,) if failure is not None else (),
            requests=len(sent),
        )

    def no_logprobs() -> InputError:
        return InputError(
            "endpoint",
            f"the server returned no log-probabilities for model {client.model!r} (it may not support "
            "logprobs); run with `samples` N instead",
        )

    def cell_messages(i: int) -> list[dict]:
        p = prompts[i]
        return shown.messages(p.context, p.profiles, p.texts)

    route = "first-token"
    probe: tuple[tuple[str, float], ...] | None = None  # the first prompt's first-token list, from the probe
    echoed: dict[str, float] = {}  # the text completions' probe: its reply's log-probability
    if sequences:
        first = prompt_replies(task, answers, prompts[0])[0]
        try:
            reply = _probe_chat(client, cell_messages(0), uncached, sent)
            if reply is not None and reply.prompt_logprobs is not None:
                route = "prompt-logprobs"
            elif reply is not None and reply.top_logprobs is not None:
                route, probe = "top-logprobs", reply.top_logprobs
            else:  # no log-probabilities on chat, or no chat: the text completions' echo
                route = "completions-echo"
                echoed[first] = _probe_echo(client, chatml(cell_messages(0)), first, sent)
        except ChatError as exc:
            return ExactKernel(None, summary(0, str(exc)), route)

    def top(i: int, prefix: str) -> Any:
        if i == 0 and not prefix and probe is not None:
            return probe
        extra = {**uncached, **(PREFILL if prefix else {})}
        turn = [{"role": "assistant", "content": prefix}] if prefix else []
        reply = client.complete(cell_messages(i) + turn, extra=extra)
        sent.append(prefix)
        if reply.top_logprobs is None:
            raise no_logprobs()
        return reply.top_logprobs

    def scored(i: int, text: str) -> float:
        if route == "completions-echo":
            if i == 0 and text in echoed:
                return echoed[text]
            reply, field = client.echo(chatml(cell_messages(i)) + text), "echo"
        else:
            turn = [{"role": "assistant", "content": text}]
            extra = {**uncached, **PREFILL, **PROMPT_LOGPROBS}
            reply, field = client.complete(cell_messages(i) + turn, extra=extra), "prompt_logprobs"
        sent.append(text)
        if reply.prompt_logprobs is None:
            raise InputError(
                "endpoint",
                f"the server returned no prompt log-probabilities for model {client.model!r} on a request after "
                f"its first had them ({field}); run the command again",
            )
        return reply_logprob(reply.prompt_logprobs, text)

    def ask(i: int) -> npt.NDArray[np.float64]:
        if not sequences:
            first = top(i, "")
            missing[i] = max(0.0, 1.0 - math.fsum(math.exp(lp) for _, lp in first))  # mass outside the list
            return decision_probabilities(first, task, answers=answers)
        replies = prompt_replies(task, answers, prompts[i])
        row = np.zeros(len(task.decisions))
        if route in ("prompt-logprobs", "completions-echo"):
            row[:-1] = [math.exp(scored(i, r)) for r in replies]
        else:
            row[:-1], missing[i] = reply_bounds(lambda prefix: top(i, prefix), replies, listed=client.top_logprobs)
        row[-1] = max(0.0, 1.0 - float(row[:-1].sum()))
        return row

    bar = progress_bar(len(prompts), f"{task.name}: exact kernel", progress)
    try:
        answered, failure = _ask_cells(list(range(len(prompts))), ask, client.max_concurrency, bar)
    finally:
        bar.close()
    for i, row in answered.items():
        out[prompts[i].index] += prompts[i].weight * row
    return ExactKernel(
        out if failure is None else None,
        summary(len(answered), failure),
        route,
        max(missing.values(), default=0.0),
        rendering=CHATML if route == "completions-echo" else SERVER_TEMPLATE,
    )


def _probe_chat(client: ChatClient, messages: list[dict], uncached: dict, sent: list[str]) -> ChatReply | None:
    """The probe's chat request, asking for ``prompt_logprobs`` too (:func:`endpoint_kernel`).

    A server that rejects the field (HTTP 400 or 422) gets the request again without it. None when the server has
    no chat completions (HTTP 404 or 405). Raises :class:`~fairaudit.experiments.vlm.client.ChatError` on any other
    failure.
    """
    from .vlm.client import ChatError

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
    """The text completions' probe: log P(``reply`` | ``prompt``) from the echo (:func:`endpoint_kernel`).

    Raises InputError (``endpoint``) when the server has no such route (HTTP 400, 404, 405 or 422: the last
    failure is named) or its echo has no log-probabilities: then no route gives the exact kernel.
    """
    from .vlm.client import ChatError
    from .vlm.logprobs import reply_logprob

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
    cells: list[int], ask: Callable[[int], npt.NDArray[np.float64]], workers: int, bar: Bar
) -> tuple[dict[int, npt.NDArray[np.float64]], str | None]:
    """``ask`` every cell on ``workers`` threads: the answers, and the first request that failed after retries.

    The first failure (a :class:`~fairaudit.experiments.vlm.client.ChatError`) cancels the cells not yet asked;
    any other exception (an :class:`InputError`, KeyboardInterrupt) does too, and propagates once the requests in
    flight have ended.
    """
    from concurrent.futures import ThreadPoolExecutor, as_completed

    from .vlm.client import ChatError

    answered: dict[int, npt.NDArray[np.float64]] = {}
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        futures = {pool.submit(ask, cell): cell for cell in cells}
        for future in as_completed(futures):
            try:
                answered[futures[future]] = future.result()
            except ChatError as exc:  # after the client's retries: the kernel needs every cell
                return answered, str(exc)
            bar.update(1)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)  # no request left behind, however the loop ends
    return answered, None


def _write(analysis: ExperimentAnalysis, out: Path, run: dict) -> list:
    from fairaudit import write_atomic

    from .report import (
        candidate_frame,
        experiment_dict,
        experiment_markdown,
        experiment_spec,
        kernel_frame,
        plot_baseline,
        plot_experiment_curve,
        records_frame,
        write_frame,
        write_json,
    )

    data = experiment_dict(analysis, run)
    written = []
    steps: list[tuple[str, Callable[[Path], None]]] = [
        ("kernel.csv", lambda p: write_frame(p, kernel_frame(analysis))),
        ("candidates.csv", lambda p: write_frame(p, candidate_frame(analysis))),
        ("curve.csv", lambda p: analysis.curve.to_csv(p)),
        ("certificate.json", lambda p: write_json(p, data)),
        ("report.md", lambda p: write_atomic(p, experiment_markdown(data), field="out")),
    ]
    if analysis.route == "sampled":  # records are queries: the exact route has none
        steps.insert(2, ("records.csv", lambda p: write_frame(p, records_frame(analysis))))
    for name, write in steps:
        write(out / name)
        written.append(out / name)
    for p in analysis.points:
        path = out / f"spec-eps-{p.epsilon:.4g}.toml"
        write_atomic(path, experiment_spec(analysis, p), field="out")
        written.append(path)
    try:
        plot_baseline(analysis, out / "baseline.png")
        plot_experiment_curve(analysis, out / "curve.png")
        written += [out / "baseline.png", out / "curve.png"]
    except InputError as exc:  # matplotlib missing: the tables and report are written
        print(f"fairaudit: figures skipped: {exc}", file=sys.stderr)
    return written
