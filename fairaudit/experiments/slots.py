"""k candidates per prompt: the true prompts, the per-candidate view and the filter that protects a candidate.

The mathematics is docs/design.md, "k candidates behind a filter": the record of slot i has context (x, i), group
t_i and outcome o_i(u); what the model sees about it is its *view*, the shown cell rotated to start at its own slot,
and the mechanism that protects it is M_cand (:func:`candidate_mechanism`). Arrays index profiles by
:attr:`DeliveryTask.profiles` and shown cells row-major over the k slots (slot 1 the slowest axis); true prompts are
``(n_prompts, k)`` integer arrays of profile indices.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit import InputError, Kernel, Mechanism, Population, choice

from .vlm.tasks import DeliveryTask

__all__ = [
    "MAX_KERNEL_ENTRIES",
    "MAX_SHOWN_CELLS",
    "PositionSplit",
    "candidate_context_name",
    "candidate_contexts",
    "candidate_epsilon",
    "candidate_kernel",
    "candidate_mechanism",
    "candidate_mechanism_epsilon",
    "candidate_population",
    "check_size",
    "epsilon_factor",
    "epsilon_from_keep",
    "expected_utility",
    "outcome_index",
    "position_split",
    "slot_names",
    "true_prompts",
    "view_label",
    "view_mixtures",
]

MAX_SHOWN_CELLS = 2_000_000
"""The largest n_contexts · n_profiles^k the table design and the exact route enumerate."""

MAX_KERNEL_ENTRIES = 20_000_000
"""The largest kernel (shown cells × decisions) the table design holds: 160 MB of float64."""

POSITIONS = ("balanced", "latin", "fixed")


def check_size(task: DeliveryTask) -> int:
    """The number of shown cells n_contexts · n_profiles^k, or an error naming ``task.candidates`` when too many.

    Too many: beyond :data:`MAX_SHOWN_CELLS` cells, or :data:`MAX_KERNEL_ENTRIES` entries of the kernel (cells ×
    decisions: a ranking of k has k! + 1, and more with partial rankings).

    Raises
    ------
    InputError
        Beyond :data:`MAX_SHOWN_CELLS`.
    """
    n = len(task.contexts) * len(task.profiles) ** task.slots
    if n > MAX_SHOWN_CELLS:
        raise InputError(
            "task.candidates",
            f"{len(task.contexts)} contexts x {len(task.profiles)}^{task.slots} shown cells = {n:,} are more than "
            f'the table design enumerates ({MAX_SHOWN_CELLS:,}): run the paper\'s design alone (design "paper")',
            task.slots,
        )
    k = task.slots
    orders = sum(math.perm(k, j) for j in range(1, k + 1)) if task.partial else math.factorial(k)
    decisions = orders + 1 if task.kind == "order" and k > 2 else k + 1
    if n * decisions > MAX_KERNEL_ENTRIES:
        raise InputError(
            "task.candidates",
            f"{n:,} shown cells x {decisions:,} decisions (every order of {task.slots}) are more kernel entries than "
            f'the table design holds ({MAX_KERNEL_ENTRIES:,}): run the paper\'s design alone (design "paper")',
            task.slots,
        )
    return n


def true_prompts(task: DeliveryTask, positions: str) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.float64]]:
    """The true prompts and their probabilities.

    Parameters
    ----------
    task : DeliveryTask
    positions : {"balanced", "latin", "fixed"}
        The orders each listed combination is shown in: all k! of them, the
        k cyclic shifts of the listed order, or the listed order only.
        Ignored for ``population = "all"`` (every ordered k-tuple, uniformly).

    Returns
    -------
    prompts : numpy.ndarray of int, shape (n_prompts, k)
        Profile indices in slot order, each distinct prompt once, in the order
        the combinations and their orders are listed.
    weights : numpy.ndarray, shape (n_prompts,)
        P(prompt): uniform over the combinations, then over each one's orders.

    Raises
    ------
    InputError
        On another ``positions``.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> p, w = true_prompts(HR_DELIVERY, "balanced")
    >>> p.tolist(), w.tolist()            # Tom (profile 0) and Mary (7) in both orders
    ([[0, 7], [7, 0]], [0.5, 0.5])
    """
    choice(positions, "positions", POSITIONS)
    k, n = task.slots, len(task.profiles)
    if task.population == "all":
        grid = np.array(list(itertools.product(range(n), repeat=k)), dtype=np.int64).reshape(-1, k)
        return grid, np.full(len(grid), 1.0 / len(grid))
    index = {p: i for i, p in enumerate(task.profiles)}
    weights: dict[tuple[int, ...], float] = {}
    for combo in task.combinations:
        listed = tuple(index[tuple(p)] for p in combo)
        if positions == "balanced":
            orders = list(itertools.permutations(listed))
        elif positions == "latin":
            orders = [listed[i:] + listed[:i] for i in range(k)]
        else:
            orders = [listed]
        for order in orders:
            weights[order] = weights.get(order, 0.0) + 1.0 / (len(task.combinations) * len(orders))
    prompts = np.array(list(weights), dtype=np.int64).reshape(-1, k)
    return prompts, np.array(list(weights.values()))


def _rotation(k: int, i: int) -> list[int]:
    """Slot order of the view of slot i: i, i + 1, ..., i − 1."""
    return [(i + j) % k for j in range(k)]


def view_label(task: DeliveryTask, shown: tuple) -> str:
    """Label of a view: the shown profiles from the candidate's own slot on, joined by ``" | "``.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> view_label(HR_DELIVERY, (("Tom", 25, "Asian"), ("Mary", 55, "American")))
    'Tom & 25 & Asian | Mary & 55 & American'
    """
    return " | ".join(task.profile_label(p) for p in shown)


@functools.lru_cache(maxsize=16)
def _views(task: DeliveryTask) -> tuple[str, ...]:
    return tuple(view_label(task, s) for s in itertools.product(task.profiles, repeat=task.slots))


def slot_names(task: DeliveryTask) -> tuple:
    """The names of the k slots, as tables and messages write them: the options (k ≥ 2), or ``("candidate",)``."""
    return tuple(task.options) if task.slots > 1 else ("candidate",)


def candidate_contexts(task: DeliveryTask) -> tuple:
    """Per-candidate contexts: ``"<context> @ <slot>"`` for every context and slot (context-major); k = 1: the contexts."""
    if task.slots == 1:
        return tuple(task.contexts)
    return tuple(f"{c} @ {o}" for c in task.contexts for o in task.options)


def candidate_context_name(task: DeliveryTask) -> str:
    """The name of the per-candidate contexts: the task's context, or ``"context @ position"`` (k ≥ 2)."""
    return task.context_name if task.slots == 1 else "context @ position"


def outcome_index(task: DeliveryTask) -> npt.NDArray[np.intp]:
    """o_i(u): the outcome index of the candidate in slot i under decision u, shape (k, n_decisions).

    A choice: 0 (chosen) for u = i, else 1; a ranking: the rank of slot i in
    order u (0 = first), k (``"unranked"``) for a slot a partial order leaves
    out (:attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.partial`);
    k = 1: the decision itself; the last decision, ``"unparsed"``, gives the
    last outcome.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> outcome_index(HR_DELIVERY).tolist()       # decisions HR1, HR2, unparsed
    [[0, 1, 2], [1, 0, 2]]
    """
    k, n_d = task.slots, len(task.decisions)
    last = len(task.outcomes) - 1
    out = np.full((k, n_d), last, dtype=np.int64)
    if k == 1:
        out[0, :-1] = np.arange(n_d - 1)
    elif task.kind == "choice":
        out[:, :-1] = np.where(np.eye(k, dtype=bool), 0, 1)
    else:
        orders = np.array(task.orders, dtype=np.int64)  # [u, rank] -> slot
        ranks = np.argsort(orders, axis=1)  # [u, slot] -> rank
        if k == 2:  # a ranking of two is named by the option served first
            ranks = np.array([[0, 1], [1, 0]])
        out[:, : len(orders)] = ranks.T
        at = len(orders)
        for j, of_j in itertools.groupby(task.partial_orders, len):  # orders of j slots: the others unranked (k)
            some = np.array(list(of_j), dtype=np.int64)  # [u, rank] -> slot
            part = np.full((len(some), k), k, dtype=np.int64)
            np.put_along_axis(part, some, np.arange(j), axis=1)
            out[:, at : at + len(some)] = part.T
            at += len(some)
    return out


def candidate_kernel(task: DeliveryTask, kernel: Kernel) -> Kernel:
    """The per-candidate kernel from the model's kernel on shown cells.

    Parameters
    ----------
    task : DeliveryTask
    kernel : Kernel
        Shape (n_contexts, n_profiles^k, n_decisions): shown cells row-major
        over the slots (:func:`fairaudit.experiments.kernel.table_kernel`),
        with or without counts.

    Returns
    -------
    Kernel
        Shape (n_contexts · k, n_profiles^k, n_outcomes): contexts
        :func:`candidate_contexts`; groups the views (the shown cell rotated
        to start at the candidate's slot, :func:`view_label`); decisions
        :attr:`DeliveryTask.outcomes`. Counts are kept: each query counts once
        in each slot.
    """
    k, n_p = task.slots, len(task.profiles)
    n_ctx = len(task.contexts)
    raw = kernel.counts if kernel.counts is not None else kernel.probabilities
    c = np.asarray(raw, dtype=float).reshape(n_ctx, *([n_p] * k), -1)
    o = outcome_index(task)
    views = (c.transpose(0, *(1 + j for j in _rotation(k, i)), k + 1).reshape(n_ctx, n_p**k, -1) for i in range(k))
    per_slot = [view @ np.eye(len(task.outcomes))[o[i]] for i, view in enumerate(views)]
    out = np.stack(per_slot, axis=1).reshape(n_ctx * k, n_p**k, len(task.outcomes))
    args = (candidate_contexts(task), _views(task), task.outcomes)
    if kernel.counts is not None:
        return Kernel.from_counts(out, *args, name="per-candidate kernel")
    return Kernel(out, *args, name="per-candidate kernel")


@functools.lru_cache(maxsize=32)
def _slot_group(
    task: DeliveryTask, positions: str
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.float64], npt.NDArray[np.float64], list[int]]:
    """(prompts, weights, P(slot i, group), group profile indices) with P of shape (k, n_groups); cached per task."""
    prompts, w = true_prompts(task, positions)
    index = {p: i for i, p in enumerate(task.profiles)}
    groups = [index[tuple(c)] for c in task.candidates]
    col = {g: j for j, g in enumerate(groups)}
    p = np.zeros((task.slots, len(groups)))
    for i in range(task.slots):
        np.add.at(p[i], [col[g] for g in prompts[:, i]], w)
    return prompts, w, p, groups


def candidate_population(task: DeliveryTask, positions: str = "balanced") -> Population:
    """P(X, A) of the per-candidate records: P((x, slot i), a) = P(x) P(t_i = a) / k.

    Contexts are uniform; groups are :attr:`DeliveryTask.candidates`. With
    ``balanced`` or ``latin`` every candidate takes every slot equally often,
    so X ⊥ A; with ``fixed`` the slot can reveal the group (the paper's order).

    Raises
    ------
    InputError
        On another value of ``positions``.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> candidate_population(HR_DELIVERY, "fixed").probabilities[:2].tolist()     # 3 documents
    [[0.16666666666666666, 0.0], [0.0, 0.16666666666666666]]
    """
    _, _, p, _ = _slot_group(task, positions)
    n = len(task.contexts)
    table = np.tile(p / (n * task.slots), (n, 1))
    return Population(table, candidate_contexts(task), [task.profile_label(c) for c in task.candidates])


def _candidate_rows(task: DeliveryTask, m: npt.NDArray[np.float64], positions: str) -> npt.NDArray[np.float64]:
    """The rows of :func:`candidate_mechanism` from M_P's matrix ``m``, shape (n_groups, n_profiles^k)."""
    k, n_p = task.slots, len(task.profiles)
    if len(task.candidates) * n_p**k > MAX_KERNEL_ENTRIES:  # before enumerating the true prompts
        raise InputError(
            "task.candidates",
            f"a candidate's view has {n_p}^{k} = {n_p**k:,} values: its mechanism is too large to build "
            f"({len(task.candidates)} rows; at most {MAX_KERNEL_ENTRIES:,} entries); a point-mass design needs no "
            "matrix: positions = 'latin' with population = 'distinct', or population = 'all'",
            k,
        )
    prompts, w, p, groups = _slot_group(task, positions)
    rows = np.full((len(groups), n_p**k), np.nan)
    for i in range(k):
        rotated = prompts[:, _rotation(k, i)]
        joint = np.zeros((n_p,) * k)  # P(t_i, t_{i+1}, ..., t_{i-1}) as a dense tensor
        np.add.at(joint, tuple(rotated.T), w)
        for j in range(1, k):  # the rivals' profiles through M_P, axis by axis
            joint = np.moveaxis(np.tensordot(joint, m, axes=([j], [0])), -1, j)
        rest = joint.reshape(n_p, -1)[groups]  # [group, rivals shown]
        with np.errstate(invalid="ignore", divide="ignore"):
            slot_rows = (m[groups][:, :, None] * rest[:, None, :]).reshape(len(groups), -1) / p[i][:, None]
        for r in np.flatnonzero(p[i] > 0):
            if np.isnan(rows[r, 0]):
                rows[r] = slot_rows[r]
            elif not np.allclose(rows[r], slot_rows[r], rtol=1e-9, atol=1e-15):
                raise InputError(
                    "task.positions",
                    f"with these combinations what is shown about {task.profile_label(task.profiles[groups[r]])!r} "
                    "depends on its slot (use positions = 'balanced'; not supported yet)",
                    positions,
                )
    return rows


def candidate_mechanism_epsilon(
    task: DeliveryTask, profile_matrix: npt.NDArray[np.float64], positions: str = "balanced"
) -> float:
    """ε(M_cand) from M_P's matrix, nats, without building the labelled mechanism (the family's root finding).

    Parameters
    ----------
    task : DeliveryTask
    profile_matrix : array_like, shape (n_profiles, n_profiles)
        M_P, rows the true profile, columns the shown one.
    positions : {"balanced", "latin", "fixed"}

    Returns
    -------
    float
        max over shown views of the spread of ln M_cand between candidates (pure ε, docs/design.md), the
        value :attr:`fairaudit.laws.mechanisms.Mechanism.epsilon` gives for :func:`candidate_mechanism`.

    Raises
    ------
    InputError
        As :func:`candidate_mechanism` (a view that depends on the slot, a view too large to enumerate).
    """
    rows = _candidate_rows(task, np.asarray(profile_matrix, dtype=float), positions)
    with np.errstate(divide="ignore", invalid="ignore"):
        ln = np.log(rows)
        spread = ln.max(axis=0) - ln.min(axis=0)
    spread = spread[np.isfinite(ln.max(axis=0))]  # columns no candidate reaches carry no evidence
    return float(spread.max()) if spread.size else 0.0


def candidate_mechanism(task: DeliveryTask, profile: Mechanism, positions: str = "balanced") -> Mechanism:
    """M_cand: what a candidate's view shows about its true profile, shape (n_groups, n_profiles^k).

    Parameters
    ----------
    task : DeliveryTask
    profile : Mechanism
        M_P on one profile, square on :attr:`DeliveryTask.profiles`.
    positions : {"balanced", "latin", "fixed"}

    Returns
    -------
    Mechanism
        Inputs the candidates' profile labels; outputs the views
        (:func:`view_label`, row-major). Row a is
        Σ_T P(T | t_i = a) Π_j M_P[T_{i+j}, ·]: the candidate's own profile
        filtered, and its rivals', as the population draws them.

    Raises
    ------
    InputError
        When the row of a candidate differs between the slots it takes (the
        view would depend on the slot: not supported yet), or the design is
        too large (:func:`check_size`).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> from fairaudit.experiments.vlm.filter import TaskFilter
    >>> m = candidate_mechanism(HR_DELIVERY, TaskFilter.from_epsilon(HR_DELIVERY, 1.0).profile_mechanism)
    >>> m.matrix.shape, round(m.epsilon, 12)             # both profiles are shown: twice the profile's ε
    ((2, 64), 2.0)
    """
    check_size(task)
    rows = _candidate_rows(task, np.asarray(profile.matrix, dtype=float), positions)
    groups = _slot_group(task, positions)[3]
    return Mechanism(
        rows,
        [task.profile_label(task.profiles[g]) for g in groups],
        _views(task),
        name=f"per-candidate view of {profile.name}",
    )


def view_mixtures(task: DeliveryTask, positions: str = "balanced") -> dict[int, dict[tuple[int, ...], float]]:
    """The true views each candidate is shown with, and their probabilities.

    A view is a true prompt rotated to start at the candidate's slot; its
    probability is pooled over the slots the candidate takes. The row of
    :func:`candidate_mechanism` of a candidate is the mixture, with these
    weights, of what the filter releases from its views. A *point-mass*
    design has one view per candidate: it always faces the same rivals in
    the same places from its own slot on, as the paper's Tom and Mary.

    Parameters
    ----------
    task : DeliveryTask
    positions : {"balanced", "latin", "fixed"}

    Returns
    -------
    dict
        Profile index of each candidate -> {view (tuple of k profile indices, its own first): P(view | candidate)}.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> view_mixtures(HR_DELIVERY)                      # Tom (0) always with Mary (7), and Mary with Tom
    {0: {(0, 7): 1.0}, 7: {(7, 0): 1.0}}
    """
    k = task.slots
    prompts, w, _, groups = _slot_group(task, positions)
    views: dict[int, dict[tuple[int, ...], float]] = {g: {} for g in groups}
    for i in range(k):
        for t, p in zip(prompts[:, _rotation(k, i)].tolist(), w.tolist()):
            views[t[0]][tuple(t)] = views[t[0]].get(tuple(t), 0.0) + p
    return {g: {v: p / sum(d.values()) for v, p in d.items()} for g, d in views.items()}


def candidate_epsilon(task: DeliveryTask, attribute_epsilons: tuple, positions: str = "balanced") -> float | None:
    """ε(M_cand) in closed form when attribute i is released at ε_i (nats); None for mixtures (compute the matrix).

    ``"all"``: Σ ε_i (the rivals carry nothing about the candidate). A
    point-mass design (:func:`view_mixtures`): the largest, over two
    candidates, of Σ ε_i over the attribute values in which their views
    differ (each differing value multiplies the likelihood ratio by at most
    e^{ε_i}, attained together at one shown cell).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> candidate_epsilon(HR_DELIVERY, (1.0, 1.0, 1.0))      # Tom and Mary differ in all 3, own and rival
    6.0
    """
    if task.population == "all":
        return float(sum(attribute_epsilons))
    d = _view_differences(task, positions)
    if d is None:
        return None
    return float(np.max(d @ np.asarray(attribute_epsilons, dtype=float), initial=0.0))


def _view_differences(task: DeliveryTask, positions: str) -> npt.NDArray[np.intp] | None:
    """For every two candidates of a point-mass design, in how many slots their views differ in each attribute.

    Shape (n_pairs, n_attributes); None for ``"all"`` and for mixtures (:func:`view_mixtures`).
    """
    if task.population == "all":
        return None
    views = view_mixtures(task, positions)
    if any(len(v) != 1 for v in views.values()):
        return None
    profiles = np.asarray([[task.attributes[j].values.index(v) for j, v in enumerate(p)] for p in task.profiles])
    cells = np.asarray([next(iter(v)) for v in views.values()], dtype=np.int64)  # (candidates, k): each one's view
    a, b = np.triu_indices(len(cells), k=1)
    shown_a, shown_b = profiles[cells[a]], profiles[cells[b]]  # (pairs, k, attributes)
    return np.sum(shown_a != shown_b, axis=1)


def epsilon_factor(task: DeliveryTask, positions: str = "balanced") -> Fraction | None:
    """ε(M_cand) / ε(M_P) when it is the same constant for every split of ε_P over the attributes; None otherwise.

    1 for ``"all"`` (ε(M_cand) = Σ ε_i). For a point-mass design
    (:func:`candidate_epsilon`: the largest, over two candidates, of Σ_i d_i
    ε_i with d_i the slots in which their views differ in attribute i) the
    ratio is a constant c for every ε ≥ 0 exactly when some two candidates
    differ in c slots in every attribute and no two in more: 2 for the
    paper's pair, which differ in every attribute, own and rival. When every
    attribute has the same number of values the filter splits ε_P evenly
    (:func:`fairaudit.laws.closed_forms.split_by_keep`), and the ratio is then the most
    attribute values in which two views differ over the number of attributes.
    Mixtures (``"distinct"`` with several combinations, several listed ones)
    and other point masses have no constant ratio: ε_P is then found by root
    finding (:func:`fairaudit.experiments.vlm.filter.profile_budget`).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> epsilon_factor(HR_DELIVERY)
    Fraction(2, 1)
    """
    n = len(task.attributes)
    if task.population == "all":
        return Fraction(1)
    d = _view_differences(task, positions)
    if d is None:
        return None
    if len(d) == 0:
        return Fraction(0)
    if len({len(a.values) for a in task.attributes}) == 1:  # an even split: ε_i = ε_P / n
        return Fraction(int(d.sum(axis=1).max()), n)
    top = d.max(axis=0)
    if np.all(top == top[0]) and np.any(np.all(d == top, axis=1)):
        return Fraction(int(top[0]))
    return None


def expected_utility(
    task: DeliveryTask, probabilities: npt.NDArray[np.float64], utility_values: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """m[x, c, i]: E[g] of candidate c in slot i without a filter, over the rivals all orders give it.

    Parameters
    ----------
    task : DeliveryTask
    probabilities : numpy.ndarray, shape (n_contexts, n_profiles^k, n_decisions)
        The model's kernel on shown cells.
    utility_values : numpy.ndarray, shape (n_outcomes,)
        g of each outcome.

    Returns
    -------
    numpy.ndarray, shape (n_contexts, n_groups, k)
        Groups :attr:`DeliveryTask.candidates`; the rivals of c in slot i are
        drawn as the ``balanced`` population draws them (NaN where c never
        takes slot i).
    """
    k, n_p = task.slots, len(task.profiles)
    prompts, w, p, groups = _slot_group(task, "balanced")
    cells = np.ravel_multi_index(tuple(prompts.T), (n_p,) * k) if k else np.zeros(0, dtype=np.int64)
    g_of = np.asarray(utility_values, dtype=float)[outcome_index(task)]  # [slot, decision]
    e = np.einsum("xtu,iu->xti", np.asarray(probabilities, dtype=float)[:, cells], g_of)  # [x, prompt, slot]
    col = {g: j for j, g in enumerate(groups)}
    member = np.zeros((len(prompts), k, len(groups)))  # [prompt, slot, group] = P(prompt) 1{t_i = group}
    for i in range(k):
        member[np.arange(len(prompts)), i, [col[g] for g in prompts[:, i]]] = w
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.einsum("xti,tic->xci", e, member) / p.T[None]


@dataclass(frozen=True, eq=False, kw_only=True)
class PositionSplit:
    """The raw disparity of the listed order split into a position part, a group part and a remainder (nats).

    With m(c, i) the expected utility of candidate c shown in slot i (its
    rivals drawn as all orders draw them), write ln m(c, i) = μ + α_c + β_i +
    γ_ci, the two-way additive decomposition with equal weights (Σ α = Σ β =
    0, γ summing to 0 along each axis). The listed order shows candidate c₁
    in slot 1 and c₂ in slot 2, and its raw log ratio splits exactly:

    ``raw = ln m(c₁, 1) − ln m(c₂, 2) = group + position + interaction``, with
    ``group = α_c₁ − α_c₂`` (the candidates over the same slots),
    ``position = β₁ − β₂`` (the slots over the same candidates) and
    ``interaction = γ_c₁1 − γ_c₂2``. For two candidates in two slots γ's
    difference is 0 and ``group = ½ [ln m(1, 1) − ln m(2, 1) + ln m(1, 2) − ln m(2, 2)]``,
    ``position = ½ [ln m(1, 1) − ln m(1, 2) + ln m(2, 1) − ln m(2, 2)]``.

    A single order cannot tell the parts apart; all orders (``--positions
    balanced``, the slot as a context) can.

    Attributes
    ----------
    contexts : tuple of str
        The task's contexts; the arrays below are indexed by them.
    pair : tuple of str
        c₁ and c₂: the first two candidates of the first listed combination.
    raw, position, group, interaction : numpy.ndarray, shape (n_contexts,)
        Per context, from that context's m (nats; ±inf or NaN where an m is 0).
    overall_raw, overall_position, overall_group, overall_interaction : float
        The same with m averaged over the contexts (equal weights), as L̄ averages them (nats).
    expected_utility : numpy.ndarray, shape (n_contexts, n_groups, k)
        m[x, candidate, slot] (candidates :attr:`DeliveryTask.candidates`).
    """

    contexts: tuple
    pair: tuple
    raw: npt.NDArray[np.float64]
    position: npt.NDArray[np.float64]
    group: npt.NDArray[np.float64]
    interaction: npt.NDArray[np.float64]
    overall_raw: float
    overall_position: float
    overall_group: float
    overall_interaction: float
    expected_utility: npt.NDArray[np.float64]

    def explained(self) -> tuple[float, float]:
        """The overall shares (position, group) of the raw disparity: position / raw and group / raw (NaN at raw 0)."""
        r = self.overall_raw
        if r == 0 or not math.isfinite(r):
            return math.nan, math.nan
        return self.overall_position / r + 0.0, self.overall_group / r + 0.0  # (+ 0.0: no -0)


def position_split(task: DeliveryTask, m: npt.ArrayLike) -> PositionSplit | None:
    """Split the listed order's disparity into position, group and interaction (:class:`PositionSplit`).

    Parameters
    ----------
    task : DeliveryTask
    m : array_like, shape (n_contexts, n_groups, k)
        Expected utility of each candidate in each slot without a filter
        (:func:`fairaudit.experiments.slots.expected_utility`).

    Returns
    -------
    PositionSplit or None
        Values in nats; None for one candidate per prompt (no slots to split).

    Notes
    -----
    The split is an identity of logarithms (the parts add up to ``raw``
    term by term), on the per-candidate framing of docs/design.md (context =
    item @ slot, group = the candidate's profile, g of its own outcome).

    Examples
    --------
    Pure position bias: the first-listed is chosen 0.8 of the time, whoever it is.

    >>> from fairaudit.experiments.taskfile import HR_DELIVERY as t
    >>> s = position_split(t, [[[0.8, 0.2], [0.8, 0.2]]] * 3)
    >>> round(s.overall_raw, 6), round(s.overall_position, 6), s.overall_group, s.explained()
    (1.386294, 1.386294, 0.0, (1.0, 0.0))
    """
    mm = np.asarray(m, dtype=float)
    if task.slots < 2:
        return None
    first = task.combinations[0] if task.combinations else task.profiles[: task.slots]
    groups = [tuple(c) for c in task.candidates]
    c1, c2 = groups.index(tuple(first[0])), groups.index(tuple(first[1]))

    def parts(x: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float64], ...]:
        with np.errstate(divide="ignore", invalid="ignore"):
            ln = np.log(x)
            raw = ln[..., c1, 0] - ln[..., c2, 1]
            group = np.mean(ln[..., c1, :] - ln[..., c2, :], axis=-1)  # α_c₁ − α_c₂
            position = np.mean(ln[..., :, 0] - ln[..., :, 1], axis=-1)  # β₁ − β₂
            if x.shape[-2:] == (2, 2):  # γ_c₁1 − γ_c₂2 = 0 for two candidates in two slots
                interaction = np.zeros_like(raw)
            else:
                interaction = raw - group - position
        return raw, position, group, interaction

    raw, position, group, interaction = parts(mm)
    o_raw, o_pos, o_group, o_int = parts(mm.mean(axis=0))
    return PositionSplit(
        contexts=tuple(task.contexts),
        pair=(task.profile_label(groups[c1]), task.profile_label(groups[c2])),
        raw=raw,
        position=position,
        group=group,
        interaction=interaction,
        overall_raw=float(o_raw),
        overall_position=float(o_pos),
        overall_group=float(o_group),
        overall_interaction=float(o_int),
        expected_utility=mm,
    )


def epsilon_from_keep(task: DeliveryTask, keep: float, positions: str = "balanced") -> float:
    """The candidate's ε when every attribute of every profile is kept with probability ``keep`` (nats).

    ε(M_cand) with attribute i, of k_i values, at ln(keep (k_i − 1) / (1 − keep)), exactly, whatever the other
    attributes' sizes (the split of :meth:`fairaudit.experiments.vlm.filter.TaskFilter.from_epsilon`): for the
    paper's pair Σ over the 2 n attributes shown
    (:func:`candidate_epsilon`); for mixtures
    from the mechanism's matrix.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> round(epsilon_from_keep(HR_DELIVERY, 0.7), 6)      # 6 ln(7/3), not 0.7/0.3
    5.083787
    """
    from fairaudit import epsilon_from_keep_probability, product, randomized_response

    eps = []
    for a in task.attributes:
        try:
            eps.append(epsilon_from_keep_probability(float(keep), len(a.values)))
        except InputError:
            raise InputError(
                "keep",
                f"must be in [1/k, 1] for every attribute; {a.name!r} has k = {len(a.values)} values, so at least "
                f"{1 / len(a.values):.6g} (below 1/k randomized response would show the true value less often than "
                "any other)",
                keep,
            ) from None
    closed = candidate_epsilon(task, tuple(eps), positions)
    if closed is not None:
        return closed
    mechs = [randomized_response(a.values, e) for a, e in zip(task.attributes, eps)]
    return candidate_mechanism(task, product(*mechs), positions).epsilon
