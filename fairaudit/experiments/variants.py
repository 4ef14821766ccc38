"""Every way a model says an option: each decision's reply variants, and the mass they cover (issue 82).

An option's **variants** are the replies that say it. By default (``[decision] variants = "case"``) they are its
text's case variants, each also after a space (:func:`case_variants`: ``yes``, ``Yes``, ``YES``, `` yes``, ...),
and those of the further texts the task file lists for it (``variants = ["Approve"]``); with ``variants =
"exact"``, its text and the listed ones as written. The exact routes' continuation scoring gives a decision the sum
of its variants' probabilities (:func:`prompt_variants`): distinct token sequences are disjoint continuations, so
their probabilities add.

**The prefix rule.** Continuation scoring gives a reply r P(the reply begins with r)
(:func:`~fairaudit.experiments.exact.decision_replies`; lm-evaluation-harness's ``loglikelihood``: no end of reply
is required after r). A variant whose text begins with another variant of the same decision (``"Yes, approve"``
after ``"Yes"``) is then not scored: the replies that begin with it begin with the shorter one too, whose
probability already counts them (when the tokenizer writes the shorter one's tokens first; when it merges across
the boundary, those replies are left to ``unparsed``, never counted twice). Variants of two decisions must not
share a text, nor may one begin the other: that reply would count for both (an error naming both).

The **coverage** of a prompt is the mass on its decisions' variants, 1 − its unparsed mass
(:func:`coverage`); below ``min_coverage`` (default :data:`DEFAULT_MIN_COVERAGE`, lm-evaluation-harness's
``discrim_eval`` threshold) the experiment warns, naming the most likely replies no variant begins
(:func:`coverage_warning`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from fairaudit import InputError

from .exact import ExactPrompt, prompt_replies

if TYPE_CHECKING:
    import numpy.typing as npt

    from .vlm.tasks import DeliveryTask

__all__ = [
    "DEFAULT_MIN_COVERAGE",
    "VARIANT_RULES",
    "case_variants",
    "coverage",
    "coverage_warning",
    "decision_row",
    "decision_variants",
    "option_variants",
    "prompt_variants",
    "reply_decision",
    "variants_record",
]

VARIANT_RULES = ("case", "exact")
"""Which replies say an option (``[decision] variants``): ``"case"`` (the default), its texts' case variants, each
also after a space (:func:`case_variants`); ``"exact"``, its texts as written."""

DEFAULT_MIN_COVERAGE = 0.99
"""The coverage below which an exact run warns (``min_coverage``): lm-evaluation-harness's ``discrim_eval`` requires
99% of the mass on the answers."""


def case_variants(text: str) -> tuple[str, ...]:
    """``text``, lower case, first letter upper (the rest as written), upper case, then each after a space.

    Deduplicated, in that order, ``text`` first.

    Examples
    --------
    >>> case_variants("yes")
    ('yes', 'Yes', 'YES', ' yes', ' Yes', ' YES')
    >>> case_variants("1")
    ('1', ' 1')
    """
    return option_variants("case", text)


def option_variants(rule: str, reply: str, listed: Sequence[str] = ()) -> tuple[str, ...]:
    """The variants of one decision whose reply is ``reply``, the task file listing ``listed`` for it, under ``rule``.

    ``"exact"``: ``reply`` and ``listed`` as written; ``"case"``: the case forms of each (:func:`case_variants`),
    then each of them after a space. Deduplicated, in that order, ``reply`` first, before the prefix rule.

    Examples
    --------
    >>> option_variants("case", "yes", ["Approve"])
    ('yes', 'Yes', 'YES', 'Approve', 'approve', 'APPROVE', ' yes', ' Yes', ' YES', ' Approve', ' approve', ' APPROVE')
    >>> option_variants("exact", "yes", ["Approve"])
    ('yes', 'Approve')
    """
    texts = (reply, *listed)
    if rule == "exact":
        return tuple(dict.fromkeys(texts))
    cased = [v for t in texts for v in (t, t.lower(), t[:1].upper() + t[1:], t.upper())]  # repeats go below
    return tuple(dict.fromkeys((*cased, *(" " + v for v in cased))))


def decision_variants(task: DeliveryTask, replies: Sequence[str]) -> tuple[tuple[str, ...], ...]:
    """Each decision's variants, given its reply, checked across decisions; the prefix rule applied within one.

    Parameters
    ----------
    task : DeliveryTask
    replies : sequence of str
        One reply per decision before ``"unparsed"`` (:func:`~fairaudit.experiments.exact.decision_replies`). A
        reply that is an option's own text (a task file's prompt) adds the variants the task file lists for it.

    Returns
    -------
    tuple of tuple of str
        Per decision, its variants in order (its reply first), without those that begin with an earlier-kept,
        shorter variant of the same decision (the module's prefix rule).

    Raises
    ------
    InputError
        Naming ``scoring`` when a variant of one decision is, or begins, a variant of another (both quoted).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> decision_variants(HR_DELIVERY, ("1", "2"))
    (('1', ' 1'), ('2', ' 2'))
    """
    listed = dict(zip(task.options, task.variants)) if task.variants else {}
    out = []
    for reply in replies:
        every = option_variants(task.variant_rule, reply, listed.get(reply, ()))
        kept: list[str] = []
        for v in sorted(every, key=len):
            if not any(v.startswith(k) for k in kept):
                kept.append(v)
        out.append(tuple(v for v in every if v in kept))
    owner = sorted((v, d) for d, vs in enumerate(out) for v in vs)
    for (a, da), (b, db) in zip(owner, owner[1:]):  # a prefix sorts right before some string it begins
        if da != db and b.startswith(a):
            raise InputError(
                "scoring",
                f"the reply {a!r} says the decision {replies[da]!r} and {'is' if a == b else 'begins'} {b!r}, which "
                f"says {replies[db]!r}: it would count for both; give the options distinct variants, or set "
                '[decision] variants = "exact"',
            )
    return tuple(out)


def prompt_variants(task: DeliveryTask, answers: Sequence[str], prompt: ExactPrompt) -> tuple[tuple[str, ...], ...]:
    """The variants a sequence route scores for one prompt, per decision before ``"unparsed"``.

    :func:`~fairaudit.experiments.exact.prompt_replies` (checked as it checks them), then
    :func:`decision_variants`.
    """
    return decision_variants(task, prompt_replies(task, answers, prompt))


def decision_row(groups: Sequence[Sequence[Any]], probabilities: Any) -> npt.NDArray[np.float64]:
    """P(decision) of one prompt from its variants' probabilities (flat, in the order of ``groups``, the variants of
    each decision): a decision gets the sum of its variants' (distinct replies are disjoint continuations), and
    ``"unparsed"``, last, the rest, 1 − their sum clipped at 0.

    Examples
    --------
    >>> decision_row([["yes", " yes"], ["no"]], [0.5, 0.25, 0.2]).tolist()
    [0.75, 0.2, 0.05]
    """
    sums = np.add.reduceat(np.asarray(probabilities, dtype=float), np.cumsum([0] + [len(g) for g in groups[:-1]]))
    return np.append(sums, max(0.0, 1.0 - float(sums.sum())))


def reply_decision(task: DeliveryTask, text: str, replies: Sequence[str] | None = None) -> int | None:
    """The decision a sampled reply says by one of its variants, or None.

    Parameters
    ----------
    task : DeliveryTask
    text : str
        The reply.
    replies : sequence of str, optional
        The decisions' replies (default the options' texts).

    Returns
    -------
    int or None
        The index of the decision one of whose variants is the reply, after stripping white space (up to case
        under the ``"case"`` rule); None when none is.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> reply_decision(HR_DELIVERY, " hr2 "), reply_decision(HR_DELIVERY, "HR3")
    (1, None)
    """
    listed = dict(zip(task.options, task.variants)) if task.variants else {}
    norm = (lambda s: s.strip()) if task.variant_rule == "exact" else (lambda s: s.strip().casefold())
    said = norm(text)
    for d, reply in enumerate(task.options if replies is None else replies):
        if any(norm(v) == said for v in (reply, *listed.get(reply, ()))):
            return d
    return None


def coverage(probabilities: Any) -> tuple[float, float]:
    """The least and the mean mass on the decisions' variants over the shown cells: 1 − each cell's unparsed mass.

    Parameters
    ----------
    probabilities : array_like, shape (..., n_decisions)
        An exact kernel (the last decision ``"unparsed"``); rows of zeros (cells not asked) are left out.

    Returns
    -------
    (float, float)
        (min, mean); (1.0, 1.0) when no row was asked.

    Examples
    --------
    >>> coverage([[0.5, 0.4, 0.1], [0.7, 0.3, 0.0], [0.0, 0.0, 0.0]])
    (0.9, 0.95)
    """
    p = np.asarray(probabilities, dtype=float).reshape(-1, np.shape(probabilities)[-1])
    asked = p[p.sum(axis=1) > 0]
    if not len(asked):
        return 1.0, 1.0
    covered: npt.NDArray[np.float64] = 1.0 - asked[:, -1]
    return float(covered.min()), float(covered.mean())


def variants_record(task: DeliveryTask, replies: Sequence[str]) -> dict[str, list[str]]:
    """Each decision's reply -> its variants (:func:`decision_variants`), for ``run.scoring.variants``."""
    return {r: list(v) for r, v in zip(replies, decision_variants(task, replies))}


def coverage_warning(
    least: float, mean: float, threshold: float, unparsed: Sequence[tuple[str, float]] = ()
) -> str | None:
    """One line when the least coverage is below ``threshold``, naming it and the most likely unparsed replies.

    Examples
    --------
    >>> coverage_warning(0.07, 0.2, 0.99, [("Sure", 0.6), ("I", 0.1)])
    "coverage 0.07 (mean 0.2) is below 0.99: the rest of the mass is on replies that say no option's variant (most likely 'Sure' 0.6, 'I' 0.1); L can be anywhere in its unparsed range: list the model's replies as variants ([decision] options) or ask for the option alone"
    >>> coverage_warning(0.995, 0.998, 0.99) is None
    True
    """
    if least >= threshold:
        return None
    likely = ", ".join(f"{t!r} {p:.3g}" for t, p in unparsed)
    return (
        f"coverage {least:.3g} (mean {mean:.3g}) is below {threshold:g}: the rest of the mass is on replies that say "
        f"no option's variant{f' (most likely {likely})' if likely else ''}; L can be anywhere in its unparsed "
        "range: list the model's replies as variants ([decision] options) or ask for the option alone"
    )
