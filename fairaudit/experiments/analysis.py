"""The paper's HR-delivery and package-delivery experiments, end to end.

:func:`analyse` turns a run's log into the per-candidate analysis of the
paper's fairness–privacy experiment, exactly, at every ε:

1. The table design's counts estimate the model's kernel on *shown* cells,
   K[x̃, (ã₁, ã₂), u] (:func:`fairaudit.experiments.harness.table_kernel`).
2. Per-candidate framing (docs/design.md): a query gives one record per candidate,
   with context (x, position), group = the candidate's true profile and
   outcome = its own (chosen or not; served first or second; unparsed). What
   the model sees about a candidate is its shown profile and its rival's, so
   the per-candidate kernel is indexed by ``"own | rival"``
   (:func:`candidate_kernel`) and the filter that protects the candidate is
   M_cand (:func:`fairaudit.experiments.vlm.filter.candidate_family`): its ε is
   the candidate's privacy budget, the ε of every curve and certificate here.
3. At each ε the law of decisions behind the filter is the exact composition
   ``compose(K_cand, M_cand(ε), M_X ⊗ I)`` and its L and L̄ come with
   simultaneous confidence intervals from the counts
   (:func:`fairaudit.intervals.fairness_intervals`), beside the corollary,
   paper, tight and black-box bounds (:func:`fairaudit.curves.privacy_curve`).

Positions: ``balanced`` (default) weighs both orders of the paper's two
candidates equally, so X ⊥ A and position bias cannot pass for group bias in
L̄; ``fixed`` is the paper's own population (candidate 1 always shown first):
there the position reveals the group, and no filter on the profiles bounds L̄
(its black-box bound is +inf).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .._arrays import FloatArray
from .._errors import InputError
from .._validation import real
from ..calibrate import Calibration
from ..curves import PrivacyCurve, privacy_curve
from ..estimate import CountTable
from ..intervals import FairnessIntervals, fairness_intervals
from ..laws import Kernel, Law, Population, compose
from ..metrics import Fairness, global_fairness, local_fairness
from ..privacy import Mechanism, from_matrix, identity, randomized_response
from ..utility import Utility, from_table
from .harness import paper_counts, table_kernel
from .vlm.filter import PrivacyFilter, candidate_family, released_pair_label
from .vlm.tasks import DeliveryTask

__all__ = [
    "DEFAULT_TARGETS",
    "ExperimentAnalysis",
    "PaperDesignPoint",
    "PointResult",
    "PositionSplit",
    "TargetBudget",
    "analyse",
    "analyse_kernel",
    "candidate_context_mechanism",
    "candidate_contexts",
    "candidate_kernel",
    "candidate_population",
    "candidate_utility",
    "epsilon_from_keep",
    "position_split",
]


def candidate_contexts(task: DeliveryTask) -> tuple:
    """Per-candidate contexts: ``"<context> @ <option>"`` for every context and position (context-major)."""
    return tuple(f"{c} @ {o}" for c in task.contexts for o in task.options)


def candidate_utility(task: DeliveryTask) -> Utility:
    """g over a candidate's own outcome (:attr:`DeliveryTask.utility_values`); depends on u only."""
    return from_table(list(task.utility_values), task.outcomes, name=task.utility_name)


def candidate_kernel(task: DeliveryTask, kernel: Kernel) -> Kernel:
    """The per-candidate kernel from the model's kernel on shown pairs.

    Parameters
    ----------
    task : DeliveryTask
    kernel : Kernel
        From :func:`fairaudit.experiments.harness.table_kernel`: shape
        (n_contexts, n_profiles², n_decisions), with counts.

    Returns
    -------
    Kernel
        Shape (2 n_contexts, n_profiles², 3): contexts
        :func:`candidate_contexts`; groups the shown ``"own | rival"`` labels
        (the outputs of M_cand); decisions :attr:`DeliveryTask.outcomes`. The
        candidate at position i is chosen (served first) when the decision is
        option i. Counts are kept: each query counts once at each position.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import PACKAGE_DELIVERY as t
    >>> from fairaudit.experiments.harness import table_kernel
    >>> recs = [{"design": "table", "status": "ok", "context": c, "profiles": [p1, p2], "decision": "Recipient1"}
    ...         for c in t.contexts for p1 in t.profiles for p2 in t.profiles]
    >>> kc = candidate_kernel(t, table_kernel(t, recs))
    >>> kc.contexts[:2], kc.groups[:2], kc.counts[0, :, 0].tolist(), kc.counts[1, :, 0].tolist()
    (('documents @ Recipient1', 'documents @ Recipient2'), ('low | low', 'low | high'), [1.0, 1.0, 1.0, 1.0], [0.0, 0.0, 0.0, 0.0])
    """
    k = len(task.profiles)
    n_ctx, n_opt = len(task.contexts), len(task.options)
    if n_opt != 2:
        raise InputError("task.options", "the per-candidate view is defined for two candidates", n_opt)
    counts = kernel.counts if kernel.counts is not None else kernel.probabilities
    c = np.asarray(counts, dtype=float).reshape(n_ctx, k, k, -1)  # [x, shown 1, shown 2, decision]
    out: FloatArray = np.zeros((n_ctx, n_opt, k, k, 3))  # [x, position, own, rival, outcome]
    for i in range(n_opt):
        view = c if i == 0 else c.transpose(0, 2, 1, 3)  # own = the profile shown at position i
        out[:, i, ..., 0] = view[..., i]
        out[:, i, ..., 1] = view[..., 1 - i]
        out[:, i, ..., 2] = view[..., n_opt]
    out = out.reshape(n_ctx * n_opt, k * k, 3)
    groups = [released_pair_label(task, s, o) for s in task.profiles for o in task.profiles]
    if kernel.counts is not None:
        return Kernel.from_counts(out, candidate_contexts(task), groups, task.outcomes, name="per-candidate kernel")
    return Kernel(out, candidate_contexts(task), groups, task.outcomes, name="per-candidate kernel")


def candidate_population(task: DeliveryTask, positions: str = "balanced") -> Population:
    """P(X, A) of the per-candidate records: contexts × positions × the two candidates.

    ``balanced``: both orders equally often, so P(x, position, a) =
    1 / (n_contexts · 2 · 2) and X ⊥ A. ``fixed``: the paper's order only
    (candidate 1 at position 1): P(x, position i, candidate i) = 1 / (2 n_contexts).

    Raises
    ------
    InputError
        On another value of ``positions``.
    """
    n = len(task.contexts)
    if positions == "balanced":
        p = np.full((2 * n, 2), 1.0 / (4 * n))
    elif positions == "fixed":
        p = np.tile(np.eye(2) / (2 * n), (n, 1))
    else:
        raise InputError("positions", "must be 'balanced' or 'fixed'", positions)
    return Population(p, candidate_contexts(task), [task.profile_label(c) for c in task.candidates])


def candidate_context_mechanism(task: DeliveryTask, context_epsilon: float | None = None) -> Mechanism:
    """M_X ⊗ I on the per-candidate contexts: the context filtered, the position shown as is."""
    if context_epsilon is None:
        return identity(candidate_contexts(task), name=f"identity on {task.context_name}")
    m = randomized_response(task.contexts, context_epsilon).matrix
    return from_matrix(
        np.kron(m, np.eye(2)), candidate_contexts(task), name=f"randomized response on {task.context_name}"
    )


def epsilon_from_keep(task: DeliveryTask, keep: float) -> float:
    """The candidate's ε when every attribute of both profiles is kept with probability ``keep``.

    Σ over the 2 n attributes shown of ln(keep (k_i − 1) / (1 − keep)), nats.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> round(epsilon_from_keep(HR_DELIVERY, 0.7), 6)      # 6 ln(7/3), not 0.7/0.3
    5.083787
    """
    from ..privacy import epsilon_from_keep_probability

    try:
        return 2 * sum(epsilon_from_keep_probability(float(keep), len(a.values)) for a in task.attributes)
    except InputError as exc:
        raise InputError("keep", exc.problem, keep) from None


@dataclass(frozen=True, eq=False, kw_only=True)
class PositionSplit:
    """The raw disparity of the paper's order split into a position part and a group part (nats).

    With m(c, i) the expected utility of candidate c shown at position i
    (rival: the other candidate), the paper's order shows candidate 1 first,
    and its raw log ratio splits exactly into two averages:

    ``raw = ln m(1, 1) − ln m(2, 2) = group + position``, with
    ``group = ½ [ln m(1, 1) − ln m(2, 1) + ln m(1, 2) − ln m(2, 2)]``
    (candidate 1 against 2 at the same position) and
    ``position = ½ [ln m(1, 1) − ln m(1, 2) + ln m(2, 1) − ln m(2, 2)]``
    (first against second for the same candidate).

    A single order cannot tell the two apart; both orders (``--positions
    balanced``, position as a context) can.

    Attributes
    ----------
    contexts : tuple of str
        The task's contexts; the arrays below are indexed by them.
    raw, position, group : numpy.ndarray, shape (n_contexts,)
        Per context, m from that context's decision shares (nats; ±inf or NaN
        where a share is 0).
    overall_raw, overall_position, overall_group : float
        The same with m averaged over the contexts (equal weights), as L̄ averages them (nats).
    expected_utility : numpy.ndarray, shape (n_contexts, 2, 2)
        m[x, candidate, position] (candidates in the task's order).
    """

    contexts: tuple
    raw: FloatArray
    position: FloatArray
    group: FloatArray
    overall_raw: float
    overall_position: float
    overall_group: float
    expected_utility: FloatArray

    def explained(self) -> tuple[float, float]:
        """The overall shares (position, group) of the raw disparity: position / raw and group / raw (NaN at raw 0)."""
        r = self.overall_raw
        if r == 0 or not math.isfinite(r):
            return math.nan, math.nan
        return self.overall_position / r + 0.0, self.overall_group / r + 0.0  # (+ 0.0: no -0)


def position_split(task: DeliveryTask, shares: npt.ArrayLike) -> PositionSplit:
    """Split the paper's-order disparity into position and group (:class:`PositionSplit`).

    Parameters
    ----------
    task : DeliveryTask
    shares : array_like, shape (n_contexts, 2, n_decisions)
        Decision shares of the true candidates, in the paper's order (axis 1 =
        0) and swapped (1): :attr:`ExperimentAnalysis.shares`.

    Returns
    -------
    PositionSplit
        Values in nats.

    Notes
    -----
    The split is an identity of logarithms (the two halves add up to
    ``raw`` term by term), on the per-candidate framing of docs/design.md
    (context = item @ position, group = the candidate's profile,
    g of its own outcome).

    Examples
    --------
    Pure position bias: the first-listed is chosen 0.8 of the time, whoever it is.

    >>> from fairaudit.experiments.taskfile import HR_DELIVERY as t
    >>> s = position_split(t, [[[0.8, 0.2, 0.0], [0.8, 0.2, 0.0]]] * 3)
    >>> round(s.overall_raw, 6), round(s.overall_position, 6), s.overall_group, s.explained()
    (1.386294, 1.386294, 0.0, (1.0, 0.0))
    """
    sh = np.asarray(shares, dtype=float)
    g = np.asarray(task.utility_values, dtype=float)  # over (own chosen/first, rival, unparsed)
    # outcome shares of the candidate at position i: (decision i, decision 1 - i, unparsed)
    own = [np.stack([sh[..., i], sh[..., 1 - i], sh[..., 2]], axis=-1) @ g for i in (0, 1)]  # [x, order]
    m = np.empty((sh.shape[0], 2, 2))  # [x, candidate, position]
    m[:, 0, 0], m[:, 1, 1] = own[0][:, 0], own[1][:, 0]  # paper's order: candidate 1 first
    m[:, 1, 0], m[:, 0, 1] = own[0][:, 1], own[1][:, 1]  # swapped: candidate 2 first

    def parts(mm: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        with np.errstate(divide="ignore", invalid="ignore"):
            ln = np.log(mm)
            raw = ln[..., 0, 0] - ln[..., 1, 1]
            group = 0.5 * (ln[..., 0, 0] - ln[..., 1, 0] + ln[..., 0, 1] - ln[..., 1, 1])
            position = 0.5 * (ln[..., 0, 0] - ln[..., 0, 1] + ln[..., 1, 0] - ln[..., 1, 1])
        return raw, position, group

    raw, position, group = parts(m)
    o_raw, o_pos, o_group = parts(m.mean(axis=0))
    return PositionSplit(
        contexts=tuple(task.contexts),
        raw=raw,
        position=position,
        group=group,
        overall_raw=float(o_raw),
        overall_position=float(o_pos),
        overall_group=float(o_group),
        expected_utility=m,
    )


DEFAULT_TARGETS = (0.05, 0.1, 0.25, 0.5)
"""Fairness targets (nats) at which an experiment reports the privacy budget that meets them."""


@dataclass(frozen=True, eq=False)
class TargetBudget:
    """The candidate's privacy budget ε that meets one fairness target, for this model and for any model.

    Attributes
    ----------
    target : float
        On L (``kind="local"``) or L̄ (``"global"``), nats.
    kind : {"local", "global"}
    this_model : Calibration
        White-box: the largest ε at which this model's own L (L̄) behind the
        filter stays ≤ target at every smaller ε (:func:`fairaudit.calibrate.calibrate`).
        On the sampled route it is an estimate from the counts.
    any_model : Calibration
        Black-box: the largest ε whose exact worst case over every model is ≤ target.
    """

    target: float
    kind: str
    this_model: Calibration
    any_model: Calibration


def _budgets(
    task: DeliveryTask,
    targets: Sequence[float],
    kc: Kernel,
    utility: Utility,
    pop: Population,
    mx: Mechanism,
    tau: float | None,
) -> tuple[TargetBudget, ...]:
    from ..calibrate import calibrate

    family = candidate_family(task)
    out = []
    for target in sorted({float(t) for t in targets}):
        for kind in ("local", "global"):
            white = calibrate(
                target, kind=kind, method="white_box", family=family, kernel=kc, utility=utility,
                population=pop, context_mechanism=mx,
            )  # fmt: skip
            black = calibrate(
                target, kind=kind, method="black_box", family=family, groups=list(pop.groups),
                gamma=utility.gamma, lower=utility.lower, tau=tau, population=pop,
            )  # fmt: skip
            out.append(TargetBudget(target, kind, white, black))
    return tuple(out)


@dataclass(frozen=True, eq=False, kw_only=True)
class PaperDesignPoint:
    """The paper's design at one ε: the per-candidate law from queries sampled through the filter."""

    epsilon: float
    queries: int
    law: Law
    local: Fairness
    global_: Fairness
    intervals: FairnessIntervals | None


@dataclass(frozen=True, eq=False, kw_only=True)
class PointResult:
    """The table design at one requested ε (nats, the candidate's budget)."""

    epsilon: float
    filter: PrivacyFilter
    mechanism: Mechanism
    law: Law
    local: Fairness
    global_: Fairness
    intervals: FairnessIntervals | None
    black_box_local: float
    black_box_global: float
    corollary: float


@dataclass(frozen=True, eq=False, kw_only=True)
class ExperimentAnalysis:
    """Everything the report says about one run.

    Attributes
    ----------
    task : DeliveryTask
    model : str
    samples : int
        Queries per shown cell (table design).
    positions : {"balanced", "fixed"}
    kernel : Kernel
        The model's kernel on shown pairs, with counts.
    candidate_kernel : Kernel
        The per-candidate kernel on ``"own | rival"``, with counts.
    population : Population
    utility : Utility
    curve : PrivacyCurve
        Bounds and exact observed L, L̄ on a dense grid of the candidate's ε.
    points : tuple of PointResult
        At each requested ε, with intervals.
    baseline : PointResult
        No filter (ε = +inf).
    shares : numpy.ndarray, shape (n_contexts, 2, n_decisions)
        Baseline decision shares for the true profiles, in the paper's order
        (axis 1 = 0) and swapped (1).
    paper : tuple of PaperDesignPoint
        The paper's design, when it was run.
    confidence : float or None
    unparsed : int
        Table-design replies that could not be parsed (counted as such; 0 on
        the exact route).
    table_queries, paper_queries : int
        Answered queries of each design (0 on the exact route).
    context_epsilon : float or None
    tau : float or None
    route : {"sampled", "exact"}
        ``"sampled"``: the kernel is estimated from queries (counts, with
        intervals); ``"exact"``: it is the model's own law (probabilities from
        its next-token distribution, no sampling error and no intervals).
    unparsed_share : float
        Mean over the shown cells of the share of replies that could not be
        parsed (of the counts, or of the probability mass on the exact route).
    split : PositionSplit
        How much of the raw disparity of the paper's order is position and how much group.
    budgets : tuple of TargetBudget
        Per target and kind (local, global): the ε that meets it for this model and for any model.
    """

    task: DeliveryTask
    model: str
    samples: int
    positions: str
    kernel: Kernel
    candidate_kernel: Kernel
    population: Population
    utility: Utility
    curve: PrivacyCurve
    points: tuple
    baseline: PointResult
    shares: np.ndarray
    paper: tuple
    confidence: float | None
    unparsed: int
    table_queries: int
    paper_queries: int
    context_epsilon: float | None = None
    tau: float | None = None
    route: str = "sampled"
    unparsed_share: float = 0.0
    split: PositionSplit | None = None
    budgets: tuple = ()


def _point(
    task: DeliveryTask,
    eps: float,
    kc: Kernel,
    utility: Utility,
    pop: Population,
    mx: Mechanism,
    confidence: float | None,
    method: str,
    tau: float | None,
    context_epsilon: float | None,
) -> PointResult:
    from ..worstcase import worst_model

    filt = PrivacyFilter.from_epsilon(task, eps / 2, context_epsilon=context_epsilon)
    mech = filt.candidate_mechanism()
    law = compose(kc, mech, mx)
    iv = None
    if confidence is not None and kc.counts is not None:
        table = CountTable(
            kc.counts, kc.contexts, kc.groups, kc.decisions, ("context @ position",), ("shown",), "outcome"
        )
        iv = fairness_intervals(
            table, utility, confidence, method, sensitive_mechanism=mech, context_mechanism=mx, population=pop
        )
    wm = worst_model(mech, utility, context_mechanism=mx, population=pop, tau=tau)
    return PointResult(
        epsilon=eps,
        filter=filt,
        mechanism=mech,
        law=law,
        local=local_fairness(law, utility, pop),
        global_=global_fairness(law, utility, pop),
        intervals=iv,
        black_box_local=wm.local.value,
        black_box_global=wm.global_.value,
        corollary=mech.epsilon,
    )


def _paper_point(
    task: DeliveryTask,
    records: Iterable[dict[str, Any]],
    eps: float,
    utility: Utility,
    pop: Population,
    confidence: float | None,
    method: str,
) -> PaperDesignPoint:
    c = paper_counts(task, records, eps)  # [x, order, decision]
    n_ctx = len(task.contexts)
    counts: FloatArray = np.zeros((n_ctx, 2, 2, 3))  # [x, position, true candidate, outcome]
    for order in range(2):
        for pos in range(2):
            cand = pos if order == 0 else 1 - pos
            counts[:, pos, cand, 0] = c[:, order, pos]
            counts[:, pos, cand, 1] = c[:, order, 1 - pos]
            counts[:, pos, cand, 2] = c[:, order, 2]
    counts = counts.reshape(2 * n_ctx, 2, 3)
    groups = [task.profile_label(x) for x in task.candidates]
    law = Law.from_counts(counts, candidate_contexts(task), groups, task.outcomes)
    iv = None
    if confidence is not None and counts.sum() > 0:
        table = CountTable(
            counts, law.contexts, law.groups, law.decisions, ("context @ position",), ("candidate",), "outcome"
        )
        iv = fairness_intervals(table, utility, confidence, method, population=pop)
    return PaperDesignPoint(
        epsilon=eps,
        queries=int(c.sum()),
        law=law,
        local=local_fairness(law, utility, pop),
        global_=global_fairness(law, utility, pop),
        intervals=iv,
    )


def analyse(
    task: DeliveryTask,
    records: Sequence[dict],
    *,
    model: str,
    samples: int,
    epsilons: Sequence[float],
    positions: str = "balanced",
    confidence: float | None = 0.95,
    method: str = "auto",
    tau: float | None = None,
    context_epsilon: float | None = None,
    paper_epsilons: Sequence[float] = (),
    grid: int = 61,
    targets: Sequence[float] = DEFAULT_TARGETS,
) -> ExperimentAnalysis:
    """The per-candidate fairness–privacy analysis of a run's answered queries.

    Parameters
    ----------
    task : DeliveryTask
    records : sequence of dict
        The log's answered queries (:attr:`fairaudit.experiments.harness.QueryLog.records`).
    model : str
        The model's name, for the report.
    samples : int
        N of the table design.
    epsilons : sequence of float
        The candidate's ε values (nats) at which to report intervals and
        certificates; finite, ≥ 0.
    positions : {"balanced", "fixed"}
        The population of true orders (see the module's docstring).
    confidence : float or None
        Level of the simultaneous intervals (None: none).
    method : str
        Interval method (:func:`fairaudit.intervals.fairness_intervals`).
    tau : float, optional
        τ for the paper and tight bounds; default the utility's smallest value
        when it is positive (the package task's waiting time ≥ 1), else none.
    context_epsilon : float, optional
        ε of randomized response on the context (None: shown as is).
    paper_epsilons : sequence of float
        ε values of the paper's design in the log, analysed beside.
    grid : int
        Points of the dense ε grid of the curve (0 to the largest ε).
    targets : sequence of float
        Fairness targets (nats) at which to report the ε that meets them
        (:attr:`ExperimentAnalysis.budgets`).

    Returns
    -------
    ExperimentAnalysis

    Raises
    ------
    InputError
        If a shown cell of the table design has no answered query (the
        composition needs every cell: naming the cell), or on a bad ε.
    """
    kernel = table_kernel(task, records)
    if kernel.empty_cells:
        x, pair = kernel.empty_cells[0]
        raise InputError(
            "table design",
            f"shown cell ({task.context_name} {x!r}, {task.options[0]} "
            f"{task.profile_label(pair[0])!r}, {task.options[1]} {task.profile_label(pair[1])!r}) has "
            f"no answered query ({len(kernel.empty_cells)} such cells); run again with `resume`",
        )
    utility = candidate_utility(task)
    pop = candidate_population(task, positions)
    paper = tuple(_paper_point(task, records, e, utility, pop, confidence, method) for e in sorted(set(paper_epsilons)))
    return analyse_kernel(
        task,
        kernel,
        model=model,
        samples=samples,
        epsilons=epsilons,
        positions=positions,
        confidence=confidence,
        method=method,
        tau=tau,
        context_epsilon=context_epsilon,
        paper=paper,
        grid=grid,
        targets=targets,
    )


def analyse_kernel(
    task: DeliveryTask,
    kernel: Kernel,
    *,
    model: str,
    epsilons: Sequence[float],
    samples: int = 0,
    positions: str = "balanced",
    confidence: float | None = 0.95,
    method: str = "auto",
    tau: float | None = None,
    context_epsilon: float | None = None,
    paper: Sequence[PaperDesignPoint] = (),
    grid: int = 61,
    targets: Sequence[float] = DEFAULT_TARGETS,
) -> ExperimentAnalysis:
    """The per-candidate analysis of the model's kernel on shown cells, with counts or exact.

    :func:`analyse` calls it with the kernel its records estimate; the exact
    route of a local model (:func:`fairaudit.experiments.local_model.exact_kernel`)
    calls it with the model's own probabilities, and then every L and L̄ is
    the model's exact value (no intervals: there is no sampling error).

    Parameters
    ----------
    task : DeliveryTask
    kernel : Kernel
        Shape (n_contexts, n_profiles², n_decisions), the layout of
        :func:`fairaudit.experiments.harness.table_kernel`: contexts the task's,
        groups the shown pairs (row-major), decisions
        :attr:`DeliveryTask.decisions`. With counts: the sampled route
        (intervals at ``confidence``); without: the exact route.
    model : str
    epsilons : sequence of float
    samples : int
        Queries per shown cell (0 on the exact route).
    positions, confidence, method, tau, context_epsilon, grid
        As in :func:`analyse`.
    paper : sequence of PaperDesignPoint
        The paper's design, analysed beside (sampled route only).
    targets : sequence of float
        Fairness targets (nats, ≥ 0) for :attr:`ExperimentAnalysis.budgets`.

    Returns
    -------
    ExperimentAnalysis

    Raises
    ------
    InputError
        On a kernel of another shape or a bad ε.
    """
    n_shape = (len(task.contexts), len(task.profiles) ** 2, len(task.decisions))
    if kernel.probabilities.shape != n_shape:
        raise InputError("kernel", f"must have shape {n_shape} for {task.name}", kernel.probabilities.shape)
    utility = candidate_utility(task)
    kc = candidate_kernel(task, kernel)
    pop = candidate_population(task, positions)
    mx = candidate_context_mechanism(task, context_epsilon)
    if tau is None and utility.lower > 0:
        tau = utility.lower
    eps = sorted({real(e, "epsilons", low=0.0, what="finite and >= 0 (nats)") for e in epsilons})
    top = max(eps + [1.0])
    dense = np.unique(np.concatenate([np.linspace(0.0, top, grid), eps]))
    curve = privacy_curve(
        family=candidate_family(task),
        epsilons=dense,
        kernel=kc,
        utility=utility,
        population=pop,
        context_mechanism=mx,
        tau=tau,
        title=f"{task.name}: {model}",
    )
    points = tuple(_point(task, e, kc, utility, pop, mx, confidence, method, tau, context_epsilon) for e in eps)
    baseline = _point(
        task, math.inf, kc, utility, pop, identity(candidate_contexts(task)), confidence, method, tau, None
    )
    k = len(task.profiles)
    i1, i2 = (task.profiles.index(tuple(c)) for c in task.candidates)
    probs = kernel.probabilities
    shares = np.stack([probs[:, i1 * k + i2], probs[:, i2 * k + i1]], axis=1)
    counts = kernel.counts
    return ExperimentAnalysis(
        task=task,
        model=model,
        samples=samples,
        positions=positions,
        kernel=kernel,
        candidate_kernel=kc,
        population=pop,
        utility=utility,
        curve=curve,
        points=points,
        baseline=baseline,
        shares=shares,
        paper=tuple(paper),
        confidence=confidence if counts is not None else None,
        unparsed=int(counts[..., -1].sum()) if counts is not None else 0,
        table_queries=int(counts.sum()) if counts is not None else 0,
        paper_queries=sum(p.queries for p in paper),
        context_epsilon=context_epsilon,
        tau=tau,
        route="sampled" if counts is not None else "exact",
        unparsed_share=float(probs[..., -1].mean()),
        split=position_split(task, shares),
        budgets=_budgets(task, targets, kc, utility, pop, mx, tau),
    )
