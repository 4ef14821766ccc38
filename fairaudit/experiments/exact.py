"""Which prompts an exact route scores, and which replies: the shared part of the local and the endpoint routes.

An exact route computes the kernel P(decision | shown cell) from a model's token probabilities instead of sampling
replies: each shown cell once per choice of its candidates' texts (:func:`exact_prompts`), and for a ranking of
k ≥ 3, each order written out (:func:`ranking_replies`), whose probability is a product over its tokens. Its
prompt is :func:`exact_prompt`'s: the built-in tasks' JSON answer format replaced by a request for the option's
number alone (:func:`answer_task`), a task file's own prompt otherwise.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from dataclasses import dataclass

from fairaudit import InputError, choice

from .vlm.tasks import DeliveryTask

__all__ = [
    "MAX_EXACT_PROMPTS",
    "SCORINGS",
    "ExactPrompt",
    "answer_task",
    "by_sequence",
    "check_replies",
    "check_scoring",
    "count_prompts",
    "decision_replies",
    "exact_prompt",
    "exact_prompts",
    "prompt_replies",
    "ranking_replies",
]

SCORINGS = ("continuation", "first-token")
"""How an exact route scores a decision (``scoring``): the likelihood of its whole reply text by the chain rule
(``"continuation"``, the default: lm-evaluation-harness's ``loglikelihood`` convention), or the mass of the first
tokens that read as it (``"first-token"``: a choice, or an order of two, whose options begin with distinct tokens)."""

MAX_EXACT_PROMPTS = 200_000
"""Prompts an exact route scores at most (every text of every shown cell); beyond, run with samples."""


@dataclass(frozen=True)
class ExactPrompt:
    """One prompt of an exact route: its shown cell, its candidates' texts and its weight in the cell's average.

    Attributes
    ----------
    index : tuple of int
        (context, profile in slot 1, ..., slot k): the kernel row the prompt adds to.
    context : str
    profiles : tuple of tuple
        The k profiles shown.
    texts : tuple of int
        The choice of texts (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.text_choices`); ``()``: the only ones.
    weight : float
        1 / the cell's number of text choices: the kernel of a shown cell is the mean over them (docs/design.md,
        "Exact kernels of replies longer than a token").
    """

    index: tuple[int, ...]
    context: str
    profiles: tuple
    texts: tuple[int, ...]
    weight: float


_ANSWER_FORMAT = "\n\nRespond by"  # where both tasks' templates start the JSON answer format


def answer_task(task: DeliveryTask) -> DeliveryTask:
    """The task with its JSON answer format replaced by a request for the option's number alone.

    The scene, the context and the profiles read as in the task's own prompt;
    the reply is to be ``1`` or ``2`` (the option chosen, or served first),
    which :func:`fairaudit.experiments.vlm.parse.parse_reply` reads as that option.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> answer_task(HR_DELIVERY).prompt("sick leave", HR_DELIVERY.candidates).splitlines()[-2:]
    ['Answer with a single digit: 1 to choose HR1, 2 to choose HR2.', 'Answer:']
    """
    head, sep, _ = task.template.partition(_ANSWER_FORMAT)
    if not sep:
        raise InputError("task", "has no answer-format paragraph to replace", task.name)
    o1, o2 = task.options
    verb, then = ("choose", "") if task.kind == "choice" else ("serve", " first")
    ask = f"Answer with a single digit: 1 to {verb} {o1}{then}, 2 to {verb} {o2}{then}.\nAnswer:"
    return dataclasses.replace(task, template=head + "\n\n" + ask)


def exact_prompt(task: DeliveryTask) -> tuple[DeliveryTask, tuple[str, ...]]:
    """The task whose prompt an exact route sends (a local model's or an endpoint's), and the reply naming each option.

    The built-in tasks' prompts end with a JSON answer format, which
    :func:`answer_task` replaces with a request for the option's number (replies ``"1"``, ``"2"``). A task file whose prompt has no such paragraph
    is sent as it is: its prompt must then ask for the option alone, and the options' keys are the replies.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> exact_prompt(HR_DELIVERY)[1]
    ('1', '2')
    """
    try:
        return answer_task(task), tuple(str(i) for i in range(1, len(task.options) + 1))
    except InputError:  # no answer-format paragraph to replace: the task's own prompt
        return task, tuple(task.options)


def exact_prompts(task: DeliveryTask, cells: Sequence[tuple] | None = None) -> list[ExactPrompt]:
    """The prompts an exact route scores: each shown cell once per choice of its candidates' texts.

    Parameters
    ----------
    task : DeliveryTask
    cells : list of (context, profile 1, ..., profile k), optional
        Default every shown cell of the table design, contexts first, then slots in ``itertools.product`` order.

    Returns
    -------
    list of ExactPrompt
        The kernel of a cell is the weighted sum of its prompts' (weights 1 / the cell's text choices,
        :meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.text_choices`).

    Raises
    ------
    InputError
        ``attribute.text`` when there would be more than :data:`MAX_EXACT_PROMPTS` prompts.
    """
    cells = _shown_cells(task) if cells is None else cells
    count_prompts(task, cells)
    out: list[ExactPrompt] = []
    for cell in cells:
        context, profiles = cell[0], tuple(cell[1:])
        index = (task.contexts.index(context), *(task.profiles.index(p) for p in profiles))
        choices = list(task.text_choices(profiles)) if task.varies else [()]
        out.extend(ExactPrompt(index, context, profiles, tuple(texts), 1.0 / len(choices)) for texts in choices)
    return out


def count_prompts(task: DeliveryTask, cells: Sequence[tuple] | None = None) -> int:
    """How many prompts :func:`exact_prompts` lists, counted without listing them; an error beyond the limit.

    Parameters
    ----------
    task : DeliveryTask
    cells : list of (context, profile 1, ..., profile k), optional
        Default every shown cell of the table design.

    Returns
    -------
    int
        Σ over the cells of their choices of texts
        (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.text_choice_count`); the number of cells when no value
        has several texts.

    Raises
    ------
    InputError
        ``attribute.text`` beyond :data:`MAX_EXACT_PROMPTS` (100 names in each of 8 slots are 100!/92! choices
        per cell), before any prompt is made.
    """
    if not task.varies:
        return len(cells) if cells is not None else len(task.contexts) * len(task.profiles) ** task.slots
    total = 0
    for cell in _shown_cells(task) if cells is None else cells:
        total += task.text_choice_count(tuple(cell[1:]))
        if total > MAX_EXACT_PROMPTS:
            raise InputError(
                "attribute.text",
                f"the exact route would score more than {MAX_EXACT_PROMPTS:,} prompts (every choice of the "
                "candidates' texts in every shown cell); run with `samples` N, which draws the texts",
                total,
            )
    return total


def _shown_cells(task: DeliveryTask) -> list[tuple]:
    """Every shown cell of the table design, (context, profile 1, ..., profile k), contexts first."""
    return [(c, *shown) for c in task.contexts for shown in itertools.product(task.profiles, repeat=task.slots)]


def ranking_replies(task: DeliveryTask, answers: Sequence[str]) -> tuple[str, ...]:
    """The reply that gives each order of :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.orders`.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> ranking_replies(HR_DELIVERY, ("1", "2"))
    ('1, 2', '2, 1')
    """
    return tuple(task.order_reply(o, answers) for o in task.orders)


def by_sequence(task: DeliveryTask, scoring: str = "continuation") -> bool:
    """True when an exact route scores whole replies, not the first token.

    Continuation scoring (the default), a ranking of k ≥ 3 (the first token gives only who comes first) or a task
    whose reply names the candidates (names may share their first token): P(reply begins with r) =
    Π_t P(r_t | prompt, r_<t), the chain rule. ``"first-token"`` scoring on a choice or an order of two: the mass
    of the first tokens that read as each option.

    Parameters
    ----------
    task : DeliveryTask
    scoring : {"continuation", "first-token"}
        :data:`SCORINGS` (checked by :func:`check_scoring`, not here).

    Returns
    -------
    bool

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> by_sequence(HR_DELIVERY), by_sequence(HR_DELIVERY, "first-token")
    (True, False)
    """
    return scoring == "continuation" or (task.kind == "order" and task.slots > 2) or task.named_by is not None


def check_scoring(task: DeliveryTask, scoring: str) -> str:
    """``scoring`` checked against :data:`SCORINGS` and the task: first-token scoring needs a decision its first token gives.

    Returns
    -------
    str
        ``scoring``.

    Raises
    ------
    InputError
        Naming ``scoring``: a value not in :data:`SCORINGS`; ``"first-token"`` on a ranking of k ≥ 3 (the first
        token gives who comes first, not the order) or on a task whose reply names the candidates (names may share
        their first token).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> check_scoring(HR_DELIVERY, "first-token")
    'first-token'
    >>> check_scoring(HR_DELIVERY, "first")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: scoring: must be one of continuation, first-token (got 'first')
    """
    choice(scoring, "scoring", SCORINGS)
    if scoring == "first-token" and by_sequence(task, scoring):
        what = (
            f"ranks {task.slots} candidates: its first token gives who comes first, not the order"
            if task.kind == "order" and task.slots > 2
            else f"names the candidates by their {task.named_by} in its reply: names may share their first token"
        )
        raise InputError("scoring", f"first-token scoring reads one token, and this task {what}; use continuation")
    return scoring


def check_replies(replies: Sequence[str]) -> tuple[str, ...]:
    """``replies`` checked for continuation scoring: non-empty, and none begins another.

    The exact routes score P(the reply begins with r) for each r, and the sampled twin reads a reply as the
    decision whose text it begins with; the events are disjoint, and their probabilities add up to at most 1, only
    when no reply is a prefix of another (``"1"`` begins ``"10"``, ``"Ann"`` begins ``"Anna"``).

    Returns
    -------
    tuple of str
        ``replies``.

    Raises
    ------
    InputError
        Naming ``scoring``: an empty reply, or two replies one of which begins the other (both quoted).

    Examples
    --------
    >>> check_replies(("HR1", "HR2"))
    ('HR1', 'HR2')
    >>> check_replies(("Ann", "Anna"))
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: scoring: continuation scoring needs replies none of which begins another, and 'Ann' begins 'Anna': the reply 'Anna...' would count for both; give the options distinct beginnings, or use first-token
    """
    texts = tuple(replies)
    if any(not t for t in texts):
        raise InputError("scoring", "continuation scoring needs non-empty replies", list(texts))
    ordered = sorted(texts)
    for a, b in zip(ordered, ordered[1:]):  # a prefix sorts right before some string it begins
        if b.startswith(a):
            raise InputError(
                "scoring",
                f"continuation scoring needs replies none of which begins another, and {a!r} begins {b!r}: the "
                f"reply {b + '...'!r} would count for both; give the options distinct beginnings, or use first-token",
            )
    return texts


def prompt_replies(task: DeliveryTask, answers: Sequence[str], prompt: ExactPrompt) -> tuple[str, ...]:
    """The replies a sequence route scores for one prompt, one per decision before ``"unparsed"``.

    Parameters
    ----------
    task : DeliveryTask
    answers : sequence of str
        The reply naming each slot (the options' keys, :func:`exact_prompt`);
        not used when the reply names the candidates.
    prompt : ExactPrompt

    Returns
    -------
    tuple of str
        n_decisions − 1 texts in the order of :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.decisions`
        (:func:`decision_replies`): a ranking of k ≥ 3, each order written out (:func:`ranking_replies`); a choice
        or an order of two, the reply naming the option chosen or served first. A task whose reply names the
        candidates writes the names its prompt shows
        (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.reply_names`; the Bloomberg study's replies), else
        ``answers``.

    Raises
    ------
    InputError
        Naming ``scoring`` when one reply begins another (:func:`check_replies`).
    """
    names = task.reply_names(prompt.profiles, prompt.texts) if task.named_by is not None else tuple(answers)
    return decision_replies(task, names)


def decision_replies(task: DeliveryTask, names: Sequence[str]) -> tuple[str, ...]:
    """The reply text of each decision before ``"unparsed"``, given the text that names each slot.

    A ranking of k ≥ 3 decides an order, and its reply is that order written out (:func:`ranking_replies`). A
    choice, and an order of two, decide one option (the one chosen, the one served first:
    :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.decisions`), and its reply is that option's name alone:
    the built-in tasks' answer prompt asks for that digit alone, and a reply that writes the order out (``"2, 1"``)
    begins with it too. Continuation scoring gives each decision P(the reply begins with its text).

    Parameters
    ----------
    task : DeliveryTask
    names : sequence of str
        The text naming each slot in the reply, in slot order (the answers of
        :func:`exact_prompt`, or the names one prompt shows).

    Returns
    -------
    tuple of str
        n_decisions − 1 texts, in the order of :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.decisions`.

    Raises
    ------
    InputError
        Naming ``scoring`` when a text is empty or one begins another (:func:`check_replies`).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY
    >>> decision_replies(HR_DELIVERY, ("1", "2")), decision_replies(PACKAGE_DELIVERY, ("1", "2"))
    (('1', '2'), ('1', '2'))
    """
    ranking = task.kind == "order" and task.slots > 2
    return check_replies(ranking_replies(task, names) if ranking else tuple(names))
