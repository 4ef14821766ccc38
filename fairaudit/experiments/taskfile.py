"""Task files: a decision task for ``fairaudit experiment`` written in TOML (docs/tasks.md).

A task file says what a decision model is shown (a prompt template, the
context, the candidates' sensitive attributes), what its reply means (the
options) and what each candidate's outcome is worth (the utility); the
privacy filter randomizes the attributes. :func:`load_task` reads one (or a
built-in task by name: the paper's ``hr-delivery`` and ``package-delivery``
ship as task files in ``fairaudit/experiments/tasks/``) into the
:class:`~fairaudit.experiments.vlm.tasks.DeliveryTask` the experiment runs.

The prompt is a Jinja2 template rendered in a sandbox (no attribute of
Python objects, no calls, no files): ``{{ context }}``, ``{{ candidates }}``
(the list) and ``{{ c1 }}``, ``{{ c2 }}``, ..., each candidate with one field
per attribute (``{{ c1.name }}``, ``{{ c1["complaint rate"] }}``); a
candidate written alone reads as its values joined by ``", "``, and the list
alone as its candidates joined by ``"; "``.

What runs today: any number of candidates per prompt whose table design has
at most :data:`fairaudit.experiments.slots.MAX_SHOWN_CELLS` shown cells, a
choice or a ranking, every ``positions`` and ``population``, one text per
attribute value. Files asking for more are read and checked, then refused
with a one-line error that says what is not supported yet.
"""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Hashable
from fractions import Fraction
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, Strict, ValidationError, field_validator, model_validator

from fairaudit import FieldProblem, InputError, distinct_labels, format_label, parse_toml, validation_error

from .prompt_reaches import check_prompt_reaches
from .vlm.tasks import UNPARSED, UNPARSED_DEFAULT, Attribute, DeliveryTask

__all__ = [
    "BUILT_IN",
    "HR_DELIVERY",
    "PACKAGE_DELIVERY",
    "TASKS",
    "TaskFile",
    "check_prompt_reaches",
    "get_task",
    "is_built_in",
    "load_task",
    "parse_task",
]

BUILT_IN = ("hr-delivery", "package-delivery")
"""The tasks shipped with fairaudit (``fairaudit/experiments/tasks/<name>.toml``)."""

_UNRANKED = ("unranked",)  # the outcome of a candidate that a partial ranking leaves out


class _Table(BaseModel):
    """A table of the task file: unknown keys are errors, the validated model is frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


_Number = Annotated[float, Strict()]
"""A TOML number: an integer or a float (as a float); a string or a boolean is an error (:func:`fairaudit.validation_error`
says which)."""


class TaskSection(_Table):
    """``[task]``: how many candidates a prompt shows, what the reply decides, their orders and the population."""

    candidates: int = Field(2, ge=1, le=64)
    decision: Literal["choose", "rank"] = "choose"
    positions: Literal["balanced", "latin", "fixed"] = "balanced"
    population: Literal["all", "distinct"] | list[list[list[Any]]] = "all"


class PromptSection(_Table):
    """``[prompt]``: the Jinja2 templates of the system (optional) and user messages."""

    system: str | None = None
    user: str = Field(min_length=1)


class ContextSection(_Table):
    """``[context]``: what varies between prompts besides the candidates (the item, the job)."""

    name: str = "context"
    values: list[Any]

    @field_validator("values")
    @classmethod
    def _distinct(cls, v: list[Any]) -> list[Any]:
        return distinct_labels(v) or []


class AttributeSection(_Table):
    """``[[attribute]]``: one sensitive attribute of a candidate, its values and what the prompt shows for each."""

    name: str = Field(min_length=1)
    values: list[Any]
    text: dict[str, str | list[str]] | None = None

    @field_validator("values")
    @classmethod
    def _distinct(cls, v: list[Any]) -> list[Any]:
        labels = distinct_labels(v) or []
        if len(labels) < 2:
            raise FieldProblem("", "an attribute needs at least 2 values", v)
        return labels

    @model_validator(mode="after")
    def _text_per_value(self) -> AttributeSection:
        if self.text is None:
            return self
        known = {format_label(v) for v in self.values}
        for key, shown in self.text.items():
            if key not in known:
                raise FieldProblem(f".text.{key}", f"is not one of the values {sorted(known)}", key)
            if isinstance(shown, list) and not shown:
                raise FieldProblem(f".text.{key}", "must list at least one text", shown)
            if isinstance(shown, list) and len(set(shown)) < len(shown):
                twice = next(t for t in shown if shown.count(t) > 1)
                raise FieldProblem(f".text.{key}", f"lists {twice!r} twice", shown)
        missing = sorted(known - set(self.text))
        if missing:
            raise FieldProblem(".text", f"has no text for the value {missing[0]!r}", sorted(self.text))
        return self


class OptionEntry(_Table):
    """One entry of ``[decision] options`` written as a list: the reply's text, its slot (or decision value) and the
    further replies that say it (:mod:`fairaudit.experiments.variants`)."""

    text: str = Field(min_length=1)
    slot: int | str
    variants: list[Annotated[str, Field(min_length=1)]] = Field(default_factory=list)


class DecisionSection(_Table):
    """``[decision]``: what the reply's options mean and the labels of a candidate's own outcome."""

    name: str = "decision"
    options: dict[str, int | str] | list[OptionEntry] | None = None
    variants: Literal["case", "exact"] = "case"
    named_by: str | None = None
    outcomes: list[str] | None = None
    separator: str = Field(", ", min_length=1)
    partial: bool = False

    @field_validator("options", mode="before")
    @classmethod
    def _entries(cls, v: Any) -> Any:
        """The list form's entries, each checked alone: its first error names the entry and its field."""
        for i, item in enumerate(v if isinstance(v, list) else ()):
            try:
                OptionEntry.model_validate(item)
            except ValidationError as exc:
                first = exc.errors()[0]
                where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in first["loc"])
                raise FieldProblem(f"[{i}]{where}", first["msg"].rstrip(".").lower(), first.get("input")) from None
        return v

    @field_validator("options")
    @classmethod
    def _some(cls, v: dict[str, int | str] | list[OptionEntry]) -> dict[str, int | str] | list[OptionEntry]:
        if not v:
            raise FieldProblem("", "must map at least one reply to a candidate or a decision", v)
        return v

    @property
    def table(self) -> dict[str, int | str] | None:
        """``options`` as the table reply -> slot (or decision value), whichever way the file wrote them."""
        if isinstance(self.options, list):
            return {o.text: o.slot for o in self.options}
        return self.options

    @property
    def listed(self) -> dict[str, tuple[str, ...]]:
        """The further replies the list of ``options`` gives each option (none in the table form)."""
        return {o.text: tuple(o.variants) for o in self.options} if isinstance(self.options, list) else {}

    @model_validator(mode="after")
    def _one_option_per_reply(self) -> DecisionSection:
        from .variants import option_variants

        if not isinstance(self.options, list):
            keys = list(self.options or ())
            where = [".options"] * len(keys)
        else:
            keys = [o.text for o in self.options]
            where = [f".options[{i}].variants" for i in range(len(keys))]
            twice = next((i for i, k in enumerate(keys) if k in keys[:i]), None)
            if twice is not None:
                raise FieldProblem(f".options[{twice}].text", "repeats an option's text", keys[twice])
        owner: dict[str, str] = {}
        for key, field in zip(keys, where):
            for v in option_variants(self.variants, key, self.listed.get(key, ())):
                if owner.setdefault(v, key) != key:
                    if v not in option_variants(self.variants, owner[v]):  # a variant the first one lists
                        field = where[keys.index(owner[v])]
                    raise FieldProblem(
                        field,
                        f"{v!r} would say both {owner[v]!r} and {key!r}: a reply may say one option only; drop it, or "
                        'set variants = "exact" when the options differ only in case',
                        v,
                    )
        return self


class UtilitySection(_Table):
    """``[utility]``: g of a candidate's own outcome; ``unparsed``: g when the reply cannot be read."""

    name: str | None = None
    values: dict[str, _Number] | list[_Number] | Literal["rank"]
    unparsed: _Number | None = None


class FilterSection(_Table):
    """``[filter]``: the attributes randomized response protects, and the budgets to run (``keep`` or ``epsilon``)."""

    attributes: list[str] | None = None
    keep: list[_Number] | None = None
    epsilon: list[_Number] | None = None

    @model_validator(mode="after")
    def _one_budget(self) -> FilterSection:
        if self.keep is not None and self.epsilon is not None:
            raise FieldProblem("", "give keep or epsilon, not both")
        for i, p in enumerate(self.keep or ()):
            if not 0 < p <= 1:
                raise FieldProblem(f".keep[{i}]", "must be a keep probability in (0, 1]", p)
        for i, e in enumerate(self.epsilon or ()):
            if not e >= 0:
                raise FieldProblem(f".epsilon[{i}]", "must be a number of nats >= 0", e)
        return self


class TaskFile(_Table):
    """A task file's fields, validated (docs/tasks.md)."""

    title: str | None = None
    task: TaskSection = Field(default_factory=lambda: TaskSection(candidates=2))
    prompt: PromptSection
    context: ContextSection | None = None
    attribute: list[AttributeSection] = Field(min_length=1)
    decision: DecisionSection
    utility: UtilitySection
    filter: FilterSection = Field(default_factory=FilterSection)

    @model_validator(mode="after")
    def _consistent(self) -> TaskFile:
        names = [a.name for a in self.attribute]
        if len(set(names)) < len(names):
            dup = next(n for n in names if names.count(n) > 1)
            raise FieldProblem(".attribute", f"names must be distinct; {dup!r} repeats", dup)
        for i, a in enumerate(self.filter.attributes or ()):
            if a not in names:
                raise FieldProblem(f".filter.attributes[{i}]", f"is not an attribute ({', '.join(names)})", a)
        narrowest = min(self.attribute, key=lambda a: len(a.values))  # the largest floor 1/k
        for i, p in enumerate(self.filter.keep or ()):
            if p < 1 / len(narrowest.values):  # applied to every attribute: randomized response keeps at least 1/k
                raise FieldProblem(
                    f".filter.keep[{i}]",
                    f"is applied to every attribute and must be at least 1/k for each; {narrowest.name!r} has "
                    f"k = {len(narrowest.values)} values, so at least {1 / len(narrowest.values):.6g} (below 1/k randomized "
                    "response would show the true value less often than any other)",
                    p,
                )
        if self.task.candidates == 1 and self.task.decision == "rank":
            raise FieldProblem(".task.decision", "a ranking needs at least 2 candidates", "rank")
        if self.decision.partial and (self.task.decision != "rank" or self.task.candidates < 3):
            raise FieldProblem(
                ".decision.partial", 'needs decision = "rank" of at least 3 candidates (a reply that ranks some)', True
            )
        _check_options(self)
        outcomes = _outcome_labels(self)
        _check_utility(self, outcomes)
        return self


def _check_options(f: TaskFile) -> None:
    k = f.task.candidates
    options = f.decision.table
    if f.decision.named_by is not None:
        _check_named_by(f)
        return
    if options is None:
        raise FieldProblem(".decision.options", "is required: reply -> candidate slot (or name them: named_by)", None)
    if k == 1:
        return  # reply -> decision value: any labels
    slots = list(options.values())
    for i, (key, slot) in enumerate(options.items()):
        if isinstance(slot, bool) or not isinstance(slot, int) or not 1 <= slot <= k:
            where = f"[{i}].slot" if isinstance(f.decision.options, list) else f".{key}"
            raise FieldProblem(f".decision.options{where}", f"must be a candidate's slot, 1 to {k}", slot)
    if sorted(slots) != list(range(1, k + 1)):
        raise FieldProblem(".decision.options", f"must name each candidate slot 1 to {k} exactly once", dict(options))


def _check_named_by(f: TaskFile) -> None:
    """``named_by``: an attribute whose texts tell the k candidates of any prompt apart, and no ``options``."""
    k, by = f.task.candidates, f.decision.named_by
    if f.decision.options is not None:
        raise FieldProblem(".decision.options", "not with named_by: the reply names the candidates", f.decision.options)
    if k < 2:
        raise FieldProblem(".decision.named_by", "needs at least 2 candidates to name", by)
    index = next((i for i, a in enumerate(f.attribute) if a.name == by), None)
    if index is None:
        raise FieldProblem(".decision.named_by", f"is not an attribute ({', '.join(a.name for a in f.attribute)})", by)
    attribute = f.attribute[index]
    texts = attribute.text or {}
    owner: dict[str, str] = {}
    for v in attribute.values:
        shown = texts.get(format_label(v), format_label(v))
        listed = [shown] if isinstance(shown, str) else list(shown)
        if len(listed) < k:
            raise FieldProblem(
                ".decision.named_by",
                f"every value of {by!r} needs at least {k} texts (names), so that the {k} candidates of any prompt "
                f"are told apart; {format_label(v)!r} has {len(listed)}",
                by,
            )
        for t in listed:
            key = " ".join(t.casefold().split())
            if key in owner:
                raise FieldProblem(
                    f".attribute[{index}].text.{format_label(v)}", f"{t!r} also names the value {owner[key]!r}", t
                )
            owner[key] = format_label(v)


def _outcome_labels(f: TaskFile) -> tuple[str, ...]:
    """A candidate's own outcomes, in order: ``[decision] outcomes``, else chosen/not chosen or rank 1..k; then
    ``"unranked"`` when a ranking may be partial."""
    k = f.task.candidates
    if f.decision.outcomes is not None:
        expected = 2 if f.task.decision == "choose" else k
        if k >= 2 and len(f.decision.outcomes) != expected:
            raise FieldProblem(".decision.outcomes", f"must list {expected} outcome labels", f.decision.outcomes)
        return (*f.decision.outcomes, *_UNRANKED[: f.decision.partial])
    if k == 1:
        return tuple(str(v) for v in (f.decision.table or {}).values())
    if f.task.decision == "choose":
        return ("chosen", "not chosen")
    return (*(f"rank {r}" for r in range(1, k + 1)), *_UNRANKED[: f.decision.partial])


def _check_utility(f: TaskFile, outcomes: tuple[str, ...]) -> None:
    values = f.utility.values
    if values == "rank":
        if f.task.decision != "rank":
            raise FieldProblem(".utility.values", 'is "rank" only for decision = "rank"', values)
        if f.decision.partial:
            raise FieldProblem(
                ".utility.values", f'"rank" gives "unranked" no number: list one per outcome {list(outcomes)}', values
            )
        return
    if isinstance(values, list):
        if len(values) != len(outcomes):
            raise FieldProblem(".utility.values", f"must give one number per outcome {list(outcomes)}", values)
        numbers = values
    else:
        unknown = sorted(set(values) - set(outcomes))
        if unknown:
            raise FieldProblem(f".utility.values.{unknown[0]}", f"is not an outcome {list(outcomes)}", unknown[0])
        missing = [o for o in outcomes if o not in values]
        if missing:
            raise FieldProblem(".utility.values", f"has no value for the outcome {missing[0]!r}", dict(values))
        numbers = list(values.values())
    for n in [*numbers, *([] if f.utility.unparsed is None else [f.utility.unparsed])]:
        if not (math.isfinite(n) and n >= 0):
            raise FieldProblem(".utility", "values must be finite and >= 0", n)


# -- reading -------------------------------------------------------------------------------------------


def parse_task(text: str, source: str = "<string>", name: str = "task") -> DeliveryTask:
    """Read a task file's text into the task the experiment runs.

    Parameters
    ----------
    text : str
        TOML (docs/tasks.md).
    source : str
        Where it came from, the head of every error.
    name : str
        The task's name in reports (a file's stem).

    Raises
    ------
    InputError
        One line, ``source: field: problem (got value)``: invalid TOML, an
        unknown or missing field, a wrong value, a template that does not
        render, or a design not supported yet.
    """
    raw = parse_toml(text, source)
    try:
        f = TaskFile.model_validate(raw)
    except ValidationError as exc:
        raise validation_error(exc, source, whole="task") from None
    except RecursionError:
        raise InputError(source, "is too deeply nested to validate") from None
    try:
        return _delivery_task(f, name, hashlib.sha256(text.encode()).hexdigest())
    except InputError as exc:
        raise exc.under(source) from None


def load_task(task: str | Path) -> DeliveryTask:
    """A built-in task by name, or a task file by path.

    Raises
    ------
    InputError
        Field ``experiment`` when ``task`` is neither a built-in name nor a
        file; the file's own errors as :func:`parse_task`.
    """
    name = str(task)
    if name in BUILT_IN:
        text = resources.files("fairaudit.experiments").joinpath("tasks", f"{name}.toml").read_text(encoding="utf-8")
        return parse_task(text, f"{name}.toml", name)
    path = Path(name)
    if not path.is_file():
        raise InputError("experiment", f"must be a built-in task ({', '.join(BUILT_IN)}) or a task file", name)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError("experiment", f"cannot be read ({exc})", name) from None
    return parse_task(text, str(path), path.stem)


def _unsupported(field: str, problem: str, value: object) -> InputError:
    return InputError(field, f"{problem} (not supported yet)", value)


def _delivery_task(f: TaskFile, name: str, digest: str) -> DeliveryTask:
    """The task file as the task the experiment runs (or a one-line refusal of what is not supported yet)."""
    k = f.task.candidates
    attributes = tuple(Attribute(a.name, tuple(a.values)) for a in f.attribute)
    if f.filter.attributes is not None and set(f.filter.attributes) != {a.name for a in f.attribute}:
        raise _unsupported("filter.attributes", "the filter randomizes every attribute", f.filter.attributes)
    text = {a.name: _shown_text(a) for a in f.attribute}
    population, combinations = _population(f, attributes)
    if f.decision.named_by is not None:  # the reply names the candidates: the slots' numbers label the decisions
        options = tuple(str(i) for i in range(1, k + 1))
    elif k == 1:
        options = tuple(f.decision.table or {})
    else:
        table = f.decision.table or {}
        options = tuple(sorted(table, key=lambda key: table[key]))
    outcomes = _outcome_labels(f)
    values = _utility_values(f, outcomes)
    if f.utility.unparsed is None:
        unparsed, unparsed_source = _random_reply_utility(f, values), UNPARSED_DEFAULT
    else:
        unparsed, unparsed_source = float(f.utility.unparsed), "given"
    context = f.context or ContextSection(values=["all"])
    task = DeliveryTask(
        name=name,
        title=f.title or name,
        kind="choice" if f.task.decision == "choose" else "order",
        options=options,
        context_name=context.name,
        contexts=tuple(context.values),
        attributes=attributes,
        slots=k,
        population=population,
        combinations=combinations,
        outcomes=(*outcomes, UNPARSED),
        utility_values=(*values, float(unparsed)),
        utility_name=f.utility.name or _utility_name(outcomes, values, unparsed),
        unparsed_source=unparsed_source,
        template=f.prompt.user,
        system=f.prompt.system,
        shown_text=text,
        separator=f.decision.separator,
        named_by=f.decision.named_by,
        partial=f.decision.partial,
        positions=f.task.positions,
        keeps=None if f.filter.keep is None else tuple(f.filter.keep),
        epsilons=None if f.filter.epsilon is None else tuple(f.filter.epsilon),
        digest=digest,
        variant_rule=f.decision.variants,
        variants=tuple(f.decision.listed.get(o, ()) for o in options) if f.decision.listed else (),
    )
    shown = combinations[0] if combinations else (task.profiles[0],) * k
    task.prompt(task.contexts[0], shown)  # the templates render (errors name prompt.user or system)
    task.system_prompt(task.contexts[0], shown)
    check_prompt_reaches(task)
    return task


def _shown_text(a: AttributeSection) -> dict[Hashable, tuple[str, ...]] | None:
    if a.text is None:
        return None
    texts = {key: (shown,) if isinstance(shown, str) else tuple(shown) for key, shown in a.text.items()}
    return {v: texts[format_label(v)] for v in a.values}


def _population(f: TaskFile, attributes: tuple[Attribute, ...]) -> tuple[Literal["listed", "distinct", "all"], tuple]:
    """``(kind, combinations)``: "all" (none listed), "distinct" (generated) or "listed" (as written)."""
    k, pop = f.task.candidates, f.task.population
    if pop == "all":
        return "all", ()
    if pop == "distinct":
        combos = _distinct(attributes, k)
        if not combos:
            raise InputError("task.population", f"no {k} profiles share no value of any attribute", pop)
        return "distinct", tuple(combos)
    out = []
    for n, combo in enumerate(pop):
        if len(combo) != k:
            raise InputError(f"task.population[{n}]", f"must list one profile per candidate ({k})", combo)
        profiles = [_listed_profile(p, attributes, f"task.population[{n}][{i}]") for i, p in enumerate(combo)]
        twice = next(((i, j) for j in range(k) for i in range(j) if profiles[i] == profiles[j]), None)
        if twice is not None:
            i, j = twice
            raise InputError(
                f"task.population[{n}]",
                f"the candidates of a combination must differ: candidates {i + 1} and {j + 1} have the same profile "
                f"{list(profiles[i])!r}, so the prompt sets that group against itself (their records differ only "
                'by slot); list different profiles, or population = "all", whose prompts include equal ones',
                combo,
            )
        out.append(tuple(profiles))
    if not out:
        raise InputError("task.population", "must list at least one combination of candidates", pop)
    return "listed", tuple(out)


def _listed_profile(p: list[Any], attributes: tuple[Attribute, ...], field: str) -> tuple:
    """One candidate of ``[task] population`` as a profile: a value of each attribute, in attribute order."""
    names = ", ".join(a.name for a in attributes)
    if len(p) != len(attributes):
        raise InputError(
            field, f"must give {len(attributes)} values, one of each attribute in order ({names}); it gives {len(p)}", p
        )
    for v, a in zip(p, attributes):
        if v not in a.values:
            valid = ", ".join(repr(x) for x in a.values)
            raise InputError(field, f"{v!r} is not a value of the attribute {a.name!r}, whose values are {valid}", p)
    return tuple(p)


def _distinct(attributes: tuple[Attribute, ...], k: int) -> list[tuple]:
    """Sets of k profiles, no two sharing a value of any attribute, in profile order."""
    if any(len(a.values) < k for a in attributes):
        return []
    profiles = list(itertools.product(*(a.values for a in attributes)))
    if math.comb(len(profiles), k) > 2_000_000:
        raise _unsupported("task.population", f"'distinct' over {len(profiles)} profiles, {k} at a time", "distinct")
    return [
        c
        for c in itertools.combinations(profiles, k)
        if all(len({p[j] for p in c}) == k for j in range(len(attributes)))
    ]


def _utility_values(f: TaskFile, outcomes: tuple[str, ...]) -> list[float]:
    values = f.utility.values
    if values == "rank":
        return [float(r) for r in range(1, len(outcomes) + 1)]
    if isinstance(values, list):
        return [float(v) for v in values]
    return [float(values[o]) for o in outcomes]


def _random_reply_utility(f: TaskFile, values: list[float]) -> float:
    """The default g of an unparsed reply: the expected g of a candidate under a uniformly random reply.

    One candidate (options -> decision values): each listed option with probability 1/n, so the mean of g over the
    options' outcomes (an outcome listed by two options counts twice). ``choose`` of k ≥ 2: each slot chosen with
    probability 1/k, so (1/k) g(chosen) + (1 − 1/k) g(not chosen). ``rank`` of k: a uniformly random complete order
    (a partial ranking's reply too is asked to order all k), which gives each rank with probability 1/k and never
    ``unranked``, so the mean of g over rank 1 to k. Summed in exact fractions of the values, rounded once.
    """
    k = f.task.candidates
    if k > 1 and f.task.decision == "choose":
        return float(Fraction(values[0]) / k + Fraction(values[1]) * (k - 1) / k)
    n = len(f.decision.table or {}) if k == 1 else k
    return float(sum((Fraction(v) for v in values[:n]), Fraction(0)) / n)


def _utility_name(outcomes: tuple[str, ...], values: list[float], unparsed: float) -> str:
    parts = ", ".join(f"{v:g} {o}" for o, v in zip(outcomes, values))
    return f"g of a candidate's outcome ({parts}, {unparsed:g} unparsed)"


HR_DELIVERY = load_task("hr-delivery")
"""The paper's HR-delivery task (``tasks/hr-delivery.toml``)."""

PACKAGE_DELIVERY = load_task("package-delivery")
"""The paper's package-delivery task (``tasks/package-delivery.toml``)."""

TASKS = {t.name: t for t in (HR_DELIVERY, PACKAGE_DELIVERY)}
"""The built-in tasks by name."""


def is_built_in(task: DeliveryTask) -> bool:
    """True for the paper's tasks as shipped (same name and same text), whose prompts speak of route images."""
    return task.name in TASKS and task.digest == TASKS[task.name].digest


def get_task(name: str | Path) -> DeliveryTask:
    """A built-in task by name, or a task file by path (as :func:`load_task`; the built-ins are read once)."""
    return TASKS[name] if isinstance(name, str) and name in TASKS else load_task(name)
