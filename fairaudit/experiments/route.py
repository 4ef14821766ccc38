"""The second step of a run: the decision model and how it is asked (:class:`Route`), checked before anything is
written.

A source (:class:`~fairaudit.experiments.options.ModelSource`) takes one of two routes. The sampled route asks
queries (a simulated model, a kernel table, an endpoint, or a local model served by ``transformers serve``),
with the stated sampling settings of a server (:func:`_sampling`). The exact route reads the kernel from token
probabilities: a local model in process, or an endpoint's log-probabilities (a client asking for one token and its
top log-probabilities). Route images (:func:`_scene`) go with the sampled route's queries of the paper's tasks, or
of a task file given a scene.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fairaudit import InputError

from .exact import SCORINGS, exact_prompt
from .options import (
    DEFAULT_GOALS,
    DEFAULT_MAX_TOKENS,
    DEFAULT_START,
    DEFAULT_TOLERANCE,
    PLAIN_SAMPLING,
    SAMPLING_FIELDS,
    ModelSource,
    RunOptions,
)
from .taskfile import is_built_in
from .vlm.tasks import DeliveryTask

if TYPE_CHECKING:
    from .cells import Cells
    from .vlm.client import ChatClient
    from .vlm.models import DecisionModel

__all__ = ["Route", "exact_route", "make_route", "scene_line", "sends_images", "sends_text_only"]


def exact_route(exact: bool, local_model: str | None, samples: int | None) -> bool:
    """Whether a run takes the exact route: ``exact`` asked for, or a local model without ``samples``.

    Examples
    --------
    >>> exact_route(False, "smollm2", None), exact_route(False, "smollm2", 20), exact_route(True, None, None)
    (True, False, True)
    """
    return bool(exact) or (local_model is not None and samples is None)


@dataclass(frozen=True, eq=False, kw_only=True)
class Route:
    """A decision model and how a run asks it.

    Attributes
    ----------
    exact : bool
        The exact route (the kernel from token probabilities); else the sampled route (queries).
    name : str
        The model's name in the log and the report.
    task : DeliveryTask
        The task as the route asks it: on a sampled twin, the exact route's prompt and replies (:func:`_twin`).
    source : ModelSource
    model : DecisionModel or None
        The sampled route's model, made here; None for a local model (served by the run) and on the exact route.
    client : ChatClient or None
        An endpoint's exact route: one-token replies with the first token's top log-probabilities.
    sampling : dict or None
        A server's sampled route: the stated settings (:func:`_sampling`).
    scoring : str or None
        How the exact route scores a decision and its twins read a reply (None: replies are parsed).
    prompt : dict
        Which prompt the route sends (``run.prompt`` of ``certificate.json``).
    images : tuple of bytes
        The route images sent with every query (PNG).
    scene : dict or None
        Their scene: start, goals, lengths, tolerance (``run.scene``).
    concurrency : int
        Queries (or prompts) in flight.
    """

    exact: bool
    name: str
    task: DeliveryTask
    source: ModelSource
    model: DecisionModel | None = None
    client: ChatClient | None = None
    sampling: dict | None = None
    scoring: str | None = None
    prompt: dict = dataclasses.field(default_factory=dict)
    images: tuple[bytes, ...] = ()
    scene: dict | None = None
    concurrency: int = 1

    def settings(self) -> dict:
        """The settings of the route that a sampled run's log records and ``resume`` compares."""
        given = {"scene": self.scene, "sampling": self.sampling}
        return {"images": len(self.images), "prompt": self.prompt, **{k: v for k, v in given.items() if v is not None}}


def make_route(cells: Cells, source: ModelSource, options: RunOptions) -> Route:
    """The route of ``source`` on ``cells``, its model made and its route images drawn, every option checked.

    Raises
    ------
    InputError
        ``samples`` with ``exact``; ``extend`` on the exact route; a task the route cannot ask (partial rankings on
        an exact route, named replies on a sampled twin, too many texts to score, a reply that begins another); a
        sampling setting on the exact route; route images, or the paper's design, on a text-only route; a local
        model that is not installed; the scene's errors (:func:`_scene`); an unreadable kernel table.
    """
    task = cells.task
    if source.exact and options.samples is not None:
        raise InputError("samples", "give `samples` or `exact`, not both")
    exact = exact_route(source.exact, source.local_model, options.samples)
    _check_task(task, source, exact, options)
    if source.local_model is not None:
        _check_local(source.local_model, exact, options)
    elif exact:
        _check_exact_endpoint(options)
    elif source.sampled_twin:  # the exact route's sampled twin: its text-only prompt
        _refuse_images(options, "`sampled_twin` samples the exact route's text-only prompt: no route images")
    images = sends_images(task, source, options)
    pngs, scene = _scene(task, options, images)  # a bad scene is refused before out is touched
    concurrency = options.concurrency or (1 if exact or not source.endpoint else 4)
    route = Route(exact=exact, name="", task=task, source=source, images=pngs, scene=scene, concurrency=concurrency)
    return _with_model(route, cells.seed)


def sends_text_only(source: ModelSource) -> bool:
    """Whether the model is sent the exact route's text-only prompt: the exact route, a local model, a sampled twin."""
    return bool(source.exact or source.local_model is not None or source.sampled_twin)


def sends_images(task: DeliveryTask, source: ModelSource, options: RunOptions) -> bool:
    """Whether the run sends route images: they belong to the paper's navigation tasks (a task file gets them only
    with a scene asked for), and a text-only prompt takes none."""
    return not sends_text_only(source) and options.images and (is_built_in(task) or options.scene is not None)


def _with_model(route: Route, seed: int) -> Route:
    """``route`` with its scoring, sampling, prompt and model (or exact client) made."""
    task, source = route.task, route.source
    scoring = _scoring(task, source, route.exact)
    prompt = _prompt_record(task, scoring is not None)
    if source.local_model is not None:
        sampling = None if route.exact else _sampling(task, source, seed)
        twin = task if route.exact else _twin(task, scoring or SCORINGS[0])
        changes: dict[str, Any] = {"name": source.local_model, "task": twin, "sampling": sampling}
    elif route.exact:
        from .vlm.logprobs import TOP_LOGPROBS

        assert source.model is not None  # ModelSource checks it
        # one request at a time by default: a server that batches concurrent requests (llama-server) computes a
        # quantized model's logits differently per batch, so the exact kernel would depend on the timing; one-token
        # replies with the first token's top log-probabilities
        client = _client(source, route.concurrency, max_tokens=1, top_logprobs=TOP_LOGPROBS)
        changes = {"name": source.model, "client": client}
    else:
        sampling = _sampling(task, source, seed) if source.endpoint else None
        m = _model(task, source, route.concurrency, sampling)
        changes = {"name": m.name, "model": m, "sampling": sampling}
        if source.sampled_twin:
            changes["task"] = _twin(task, scoring or SCORINGS[0])
    return dataclasses.replace(route, scoring=scoring, prompt=prompt, **changes)


def _check_task(task: DeliveryTask, source: ModelSource, exact: bool, options: RunOptions) -> None:
    """What the route cannot do with this task or these options."""
    from .exact import count_prompts

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
    given = next((n for n in SAMPLING_FIELDS if getattr(source, n) not in (None, "none")), None)
    if exact and given is not None:  # a local model without samples: its exact route samples nothing
        raise InputError(given, "sets how a server samples, and the exact route samples nothing: give `samples` N")


def _scoring(task: DeliveryTask, source: ModelSource, exact: bool) -> str | None:
    """The run's scoring (:data:`~fairaudit.experiments.exact.SCORINGS`), checked on the task and on every reply the
    exact route would score, before anything is made; None on a route that parses free replies."""
    if not (exact or source.local_model is not None or source.sampled_twin):
        return None
    from .exact import by_sequence, check_scoring, exact_prompts
    from .variants import prompt_variants

    scoring = check_scoring(task, source.scoring or SCORINGS[0])
    if by_sequence(task, scoring):
        answers = exact_prompt(task)[1]
        for p in exact_prompts(task) if task.named_by is not None else exact_prompts(task)[:1]:
            prompt_variants(task, answers, p)  # one reply (or variant) beginning another's is refused, naming both
    return scoring


def _prompt_record(task: DeliveryTask, text_only: bool) -> dict:
    """``run.prompt`` of ``certificate.json``: whether the route sent the task's own prompt or the exact route's.

    A model with an exact route gets the exact route's prompt on every route (docs/experiments.md, "The messages of
    a query").
    """
    if text_only and exact_prompt(task)[0] is not task:
        return {
            "sent": "exact route's",
            "rule": "a model with an exact route gets the exact route's prompt on every route: the task's answer "
            "paragraph replaced by a request for the option's number alone",
        }
    return {"sent": "task's own", "rule": "the task's prompt as written"}


def _check_local(name: str, exact: bool, options: RunOptions) -> None:
    """What a local model cannot do (route images; the paper's design without samples), and that it is installed."""
    from . import model_files

    _refuse_images(options, f"the local model {name} reads text only: it takes no route images")
    if exact and options.design != "table":
        raise InputError("design", "the paper's design samples through the filter: give `samples` N too")
    model_files.check(name)  # not installed: one line naming the install command, before anything is written


def _check_exact_endpoint(options: RunOptions) -> None:
    """What an endpoint's exact route cannot do: route images, the paper's design."""
    _refuse_images(options, "the exact route reads text only: it takes no route images")
    if options.design != "table":
        raise InputError("design", "the paper's design samples through the filter: run with `samples` N, not `exact`")


def _client(source: ModelSource, concurrency: int, **settings: Any) -> ChatClient:
    """A client of ``source``'s endpoint and model, with its timeout and retries and ``concurrency`` requests at once."""
    from .vlm.client import ChatClient

    assert source.endpoint is not None and source.model is not None  # ModelSource checks it
    return ChatClient(
        source.endpoint,
        source.model,
        timeout=source.timeout,
        max_retries=source.max_retries,
        max_concurrency=concurrency,
        **settings,
    )


def _model(task: DeliveryTask, source: ModelSource, concurrency: int, sampling: dict | None) -> DecisionModel:
    """The sampled route's model: an endpoint's client, a kernel table, or a simulated model."""
    from .vlm.models import EndpointModel, SimulatedModel, simulated_model, simulated_models

    if source.endpoint:
        from .vlm.client import constraint_body

        assert sampling is not None  # make_route checks it
        if source.sampled_twin:
            extra = dict(PLAIN_SAMPLING)
        else:
            extra = constraint_body(sampling["constrain"], sampling.get("replies", ()), name=_schema_name(task))
        fields = {name: sampling[name] for name in ("temperature", "top_p", "max_tokens")}
        return EndpointModel(_client(source, concurrency, extra_body=extra, **fields))
    if source.kernel:
        return SimulatedModel.from_csv(task, source.kernel)
    return simulated_model(task, source.simulated or next(iter(simulated_models(task))))


def _schema_name(task: DeliveryTask) -> str:
    """The JSON schema's name of ``constrain="json-schema"``: the task's name in the characters OpenAI allows."""
    import re

    return re.sub(r"[^A-Za-z0-9_-]", "_", task.name)[:64] or "decision"


def _constrained_replies(task: DeliveryTask, constrain: str) -> tuple[str, ...]:
    """The replies a constrained server may give: each parses as one decision.

    A choice: its options' keys. An order of two: the key served first under ``json-schema``, else both orders
    written out. Refused (naming ``constrain``): replies that name the candidates, rankings of three or more and
    partial rankings.
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
    local model room for the longest reply its exact route scores; ``sampled_twin``: 1, 1 and that room, with no
    top-k or min-p truncation), ``seed`` (the run's; each request sends its query's own), ``constrain`` and, when
    constrained, the allowed ``replies``; ``scoring`` where the replies are read as the exact route scores them.
    """
    scoring = source.scoring or SCORINGS[0]
    twin = source.sampled_twin  # ModelSource refuses other settings: PLAIN_SAMPLING's (1, 1, top_k 0, min_p 0)
    default_tokens = _twin_tokens(task, scoring) if twin or source.local_model is not None else DEFAULT_MAX_TOKENS
    out: dict[str, Any] = {
        "temperature": 1.0 if source.temperature is None else source.temperature,
        "top_p": 1.0 if source.top_p is None else source.top_p,
        "max_tokens": default_tokens if source.max_tokens is None else source.max_tokens,
        "seed": int(seed),
        "constrain": source.constrain,
    }
    if twin:
        out |= {"top_k": PLAIN_SAMPLING["top_k"], "min_p": PLAIN_SAMPLING["min_p"]}
    if source.constrain != "none":
        out["replies"] = list(_constrained_replies(task, source.constrain))
    if twin or source.local_model is not None:  # its replies are read as the exact route scores them
        out["scoring"] = scoring
    return out


def _twin_tokens(task: DeliveryTask, scoring: str) -> int:
    """``max_tokens`` of the exact route's sampled twin: 1 (first-token scoring), or room for the longest reply."""
    replies = _twin(task, scoring).replies
    return max(len(r) for r in replies) if replies else 1  # a token is one character or more


def _twin(task: DeliveryTask, scoring: str) -> DeliveryTask:
    """The task the exact route's sampled twins ask: the exact route's prompt; under continuation scoring a reply
    is read as the decision whose text it begins with (:func:`~fairaudit.experiments.exact.decision_replies`)."""
    from .exact import by_sequence, decision_replies

    shown, answers = exact_prompt(task)
    if by_sequence(task, scoring):
        return dataclasses.replace(shown, replies=decision_replies(task, answers))
    return shown


_SCENE_FIELDS = ("scene", "start", "goals", "tolerance")
"""The options of the route images: refused, each naming itself, by a run that sends none."""


def _refuse_images(options: RunOptions, why: str) -> None:
    """Refuse the first of the image options that ``options`` gives: this run sends no route images."""
    for name in _SCENE_FIELDS:
        if getattr(options, name) is not None:
            raise InputError(name, why)


def _scene(task: DeliveryTask, options: RunOptions, images: bool) -> tuple[tuple[bytes, ...], dict | None]:
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
        lengths = ", ".join(f"{x:.2f} m" for x in s.check.lengths)
        raise InputError(
            "scene",
            f"the routes from {start} to {', '.join(goals)} are not of equal length ({lengths}; "
            f"{s.check.max_relative_difference:.1%} apart, more than {100 * tolerance:.6g}% (`tolerance`)): the "
            "paper's experiment needs equal distances",
            str(options.scene or "generated floor"),
        )
    return tuple(s.images), record


def scene_line(record: dict) -> str:
    """The equal-distance check passed, in one line: the lengths, how far apart, the tolerance (``0.05`` as 5%)."""
    lengths = ", ".join(f"{x:.2f} m" for x in record["lengths_m"])
    return (
        f"route lengths {lengths}: {record['max_relative_difference']:.1%} apart, within the tolerance "
        f"{100 * record['tolerance']:.6g}%"
    )
