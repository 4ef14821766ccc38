"""Which prompts an exact route scores, and which replies: the shared part of the local and the endpoint routes.

An exact route computes the kernel P(decision | shown cell) from a model's token probabilities instead of sampling
replies: each shown cell once per choice of its candidates' texts (:func:`exact_prompts`), and for a ranking of
k ≥ 3, each order written out (:func:`ranking_replies`), whose probability is a product over its tokens.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

from .._errors import InputError
from .vlm.tasks import DeliveryTask

__all__ = [
    "MAX_EXACT_PROMPTS",
    "ExactPrompt",
    "by_sequence",
    "count_prompts",
    "exact_prompts",
    "prompt_replies",
    "ranking_replies",
]

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
        for texts in choices:
            out.append(ExactPrompt(index, context, profiles, tuple(texts), 1.0 / len(choices)))
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


def by_sequence(task: DeliveryTask) -> bool:
    """True when an exact route scores whole replies, not the first token.

    A ranking of k ≥ 3 (the first token gives only who comes first) or a task whose reply names the candidates
    (names may share their first token): P(reply begins with r) = Π_t P(r_t | prompt, r_<t), the chain rule.
    """
    return (task.kind == "order" and task.slots > 2) or task.named_by is not None


def prompt_replies(task: DeliveryTask, answers: Sequence[str], prompt: ExactPrompt) -> tuple[str, ...]:
    """The replies a sequence route scores for one prompt, one per decision before ``"unparsed"``.

    Parameters
    ----------
    task : DeliveryTask
    answers : sequence of str
        The reply naming each slot (the options' keys, :func:`fairaudit.experiments.local_model.exact_prompt`);
        not used when the reply names the candidates.
    prompt : ExactPrompt

    Returns
    -------
    tuple of str
        n_decisions − 1 texts in the order of :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.decisions`. A
        ranking: each order written out (:func:`ranking_replies`); a choice: each candidate's reply alone. A task
        whose reply names the candidates writes the names its prompt shows
        (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.reply_names`; the Bloomberg study's replies), else
        ``answers``.
    """
    names = task.reply_names(prompt.profiles, prompt.texts) if task.named_by is not None else tuple(answers)
    return ranking_replies(task, names) if task.kind == "order" else names
