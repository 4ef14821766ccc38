"""The per-candidate fairness–privacy analysis of a run, exactly, at every ε (the fifth step of a run).

The table design's kernel on shown cells becomes the per-candidate kernel on views
(:func:`fairaudit.experiments.slots.candidate_kernel`); the filter that protects a candidate is M_cand
(:func:`fairaudit.experiments.vlm.filter.candidate_family`), whose ε is the ε of every curve and certificate here.
At each ε the law behind the filter is ``compose(K_cand, M_cand(ε), M_X ⊗ I)``, with its intervals and bounds from
the public functions of fairaudit (docs/design.md, "Handing the core a kernel" and "k candidates behind a filter").
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from fairaudit import (
    Calibration,
    CountTable,
    Fairness,
    FairnessIntervals,
    InputError,
    IntervalOptions,
    Kernel,
    Law,
    Mechanism,
    Population,
    PrivacyCurve,
    Utility,
    UtilityClass,
    UtilityRange,
    compose,
    fairness_intervals,
    fairness_range,
    from_matrix,
    from_table,
    global_fairness,
    identity,
    local_fairness,
    privacy_curve,
    randomized_response,
    real,
)

from .harness import eps_key
from .kernel import UnparsedMass, table_kernel, true_cell_counts, unparsed_mass
from .options import DEFAULT_TARGETS
from .slots import (
    PositionSplit,
    candidate_context_name,
    candidate_contexts,
    candidate_kernel,
    candidate_population,
    expected_utility,
    position_split,
    slot_names,
    true_prompts,
)
from .unparsed_bounds import BoundRange, bound_ranges
from .vlm.filter import TaskFilter, candidate_family
from .vlm.tasks import DeliveryTask

__all__ = [
    "ExperimentAnalysis",
    "Observed",
    "ObservedPoint",
    "PointResult",
    "RunAnalysis",
    "TargetBudget",
    "analyse",
    "analyse_kernel",
    "candidate_context_mechanism",
    "candidate_utility",
    "observed_point",
]


def candidate_utility(task: DeliveryTask) -> Utility:
    """g over a candidate's own outcome (:attr:`DeliveryTask.utility_values`); depends on u only."""
    return from_table(list(task.utility_values), task.outcomes, name=task.utility_name)


def candidate_context_mechanism(task: DeliveryTask, context_epsilon: float | None = None) -> Mechanism:
    """M_X ⊗ I on the per-candidate contexts: the context filtered, the position shown as is."""
    if context_epsilon is None:
        return identity(candidate_contexts(task), name=f"identity on {task.context_name}")
    m = randomized_response(task.contexts, context_epsilon).matrix
    return from_matrix(
        np.kron(m, np.eye(task.slots)), candidate_contexts(task), name=f"randomized response on {task.context_name}"
    )


@dataclass(frozen=True, eq=False)
class TargetBudget:
    """The candidate's privacy budget ε that meets one fairness target, for this model and for any model.

    Attributes
    ----------
    target : float
        On L (``kind="local"``) or L̄ (``"global"``), nats.
    kind : {"local", "global"}
    this_model : Calibration
        White-box on the upper end of this model's L (L̄) over every utility of the unparsed reply
        (:func:`fairaudit.calibrate` with ``unparsed_decision=-1``; ``proofs/unparsed.md`` §5). An estimate on the
        sampled route.
    any_model : Calibration
        Black-box: the largest ε whose exact worst case over every model is ≤ target.
    stated_default : Calibration
        White-box under the stated utility of the unparsed reply (at least ``this_model``'s ε).
    unparsed_upper : float
        The upper end of the unparsed range at ``stated_default``'s ε (nats; NaN when no ε meets the target).
    """

    target: float
    kind: str
    this_model: Calibration
    any_model: Calibration
    stated_default: Calibration
    unparsed_upper: float = math.nan

    @property
    def overturned(self) -> bool:
        """Whether some utility of the unparsed reply in [min g, max g] breaks the target at the stated default's ε."""
        return self.stated_default.feasible and self.unparsed_upper > self.target


@dataclass(frozen=True)
class _Setting:
    """What every ε of one analysis shares (:func:`_point`, :func:`_budgets`): the per-candidate kernel ``kc``, g,
    the population, M_X and the run's options."""

    task: DeliveryTask
    positions: str
    kc: Kernel
    utility: Utility
    pop: Population
    mx: Mechanism
    confidence: float | None
    method: str
    tau: float | None
    context_epsilon: float | None

    def mechanism(self, eps: float) -> tuple[TaskFilter, Mechanism]:
        """The filter that gives each candidate ``eps`` (nats), and M_cand, its mechanism on a candidate."""
        filt = TaskFilter.for_candidates(self.task, eps, self.positions, context_epsilon=self.context_epsilon)
        return filt, filt.candidate_mechanism(self.positions)

    def unparsed_range(self, mech: Mechanism) -> UtilityRange:
        """L and L̄ behind ``mech`` over every utility of the unparsed reply (:func:`fairaudit.fairness_range`)."""
        return fairness_range(
            self.kc, self.utility, -1, sensitive_mechanism=mech, context_mechanism=self.mx, population=self.pop
        )


def _budgets(s: _Setting, targets: Sequence[float], points: Sequence[PointResult]) -> tuple[TargetBudget, ...]:
    """Per target and kind the white-box ε (on the unparsed range's upper end, and under the stated default) and the
    black-box ε, with the unparsed range's upper end at the stated default's ε (the ``points``' ranges, or computed)."""
    from fairaudit import calibrate

    ranges = {p.epsilon: p.unparsed_range for p in points}

    def upper_at(e: float, kind: str) -> float:  # at the white-box ε of a target, with this run's M_X
        if e not in ranges:
            ranges[e] = s.unparsed_range(s.mechanism(e)[1])
        r = ranges[e]
        return (r.local_fairness if kind == "local" else r.global_fairness).upper

    family = candidate_family(s.task, s.positions)
    white_box: dict[str, Any] = {"family": family, "kernel": s.kc, "utility": s.utility, "population": s.pop}
    utility_class = UtilityClass(gamma=s.utility.gamma, lower=s.utility.lower, tau=s.tau)
    out = []
    for target, kind in itertools.product(sorted({float(t) for t in targets}), ("local", "global")):
        white = {
            d: calibrate(
                target, kind=kind, method="white_box", context_mechanism=s.mx, unparsed_decision=d, **white_box
            )
            for d in (-1, None)
        }
        black = calibrate(
            target, kind=kind, method="black_box", family=family, utility_class=utility_class, population=s.pop
        )
        stated = white[None]
        upper = upper_at(stated.epsilon, kind) if stated.feasible else math.nan
        out.append(TargetBudget(target, kind, white[-1], black, stated, upper))
    return tuple(out)


@dataclass(frozen=True, eq=False, kw_only=True)
class Observed:
    """What both designs observe at one ε (nats, the candidate's budget; +inf for the baseline, no filter).

    Attributes
    ----------
    epsilon : float
    law : Law
        The per-candidate law.
    local_fairness, global_fairness : Fairness
        Observed L and L̄ (nats), with the maximising context and groups.
    intervals : FairnessIntervals or None
    unparsed_range : UtilityRange
        L and L̄ over every utility of the unparsed reply in [min g, max g] (:func:`fairaudit.fairness_range`).
    """

    epsilon: float
    law: Law
    local_fairness: Fairness
    global_fairness: Fairness
    intervals: FairnessIntervals | None
    unparsed_range: UtilityRange


@dataclass(frozen=True, eq=False, kw_only=True)
class ObservedPoint(Observed):
    """What the paper's design observed at one ε: the per-candidate law from queries sampled through the filter.

    Attributes
    ----------
    epsilon : float
        The candidate's ε (nats; +inf for the baseline, no filter).
    queries : int
        Answered queries at this ε.
    law : Law
        The per-candidate law.
    local_fairness, global_fairness : Fairness
        Observed L and L̄ (nats), with the maximising context and groups.
    intervals : FairnessIntervals or None
    unparsed_range : UtilityRange
        L and L̄ over every utility of the unparsed reply in [min g, max g], chosen per cell (x, a) of ``law``
        (:func:`fairaudit.fairness_range` of the law itself: the filter is in the queries), next to
        the value under the stated default, which is ``local_fairness`` and ``global_fairness``.
    """

    queries: int


def observed_point(
    task: DeliveryTask,
    positions: str,
    records: Iterable[dict[str, Any]],
    eps: float,
    utility: Utility,
    pop: Population,
    confidence: float | None,
    method: str,
) -> ObservedPoint:
    """The paper's design at ``eps`` (nats; +inf: no filter): its records counted by true context, slot, profile, outcome.

    Records of ``design = "paper"`` whose ``epsilon`` is ``eps`` and whose true prompt is one of ``positions``
    (:func:`fairaudit.experiments.slots.true_prompts`) are counted by
    :func:`fairaudit.experiments.kernel.true_cell_counts`; L and L̄ (with ``confidence`` intervals) are those
    of their per-candidate law, with population ``pop``, and their range over the unparsed reply's utility is that
    of the law's cells (:func:`fairaudit.fairness_range` of the law: its value is L and L̄ as
    computed here, the same numbers).
    """
    prompts, _ = true_prompts(task, positions)
    orders = {tuple(task.profiles[i] for i in p) for p in prompts}
    key = eps_key(float(eps))
    truths = [
        {"context": r["truth"]["context"], "profiles": order, "decision": r["decision"]}
        for r in records
        if r.get("design") == "paper" and r.get("status") == "ok" and eps_key(float(r["epsilon"])) == key
        and (order := tuple(tuple(p) for p in r["truth"]["profiles"])) in orders
    ]  # fmt: skip
    counts = true_cell_counts(task, truths).reshape(-1, len(task.candidates), len(task.outcomes))
    groups = [task.profile_label(x) for x in task.candidates]
    law = Law.from_counts(counts, candidate_contexts(task), groups, task.outcomes)
    iv = None
    if confidence is not None and counts.sum() > 0:
        table = CountTable(
            counts, law.contexts, law.groups, law.decisions, (candidate_context_name(task),), ("candidate",), "outcome"
        )
        iv = fairness_intervals(table, utility, IntervalOptions(confidence=confidence, method=method), population=pop)
    return ObservedPoint(
        epsilon=eps,
        queries=len(truths),
        law=law,
        local_fairness=local_fairness(law, utility, pop),
        global_fairness=global_fairness(law, utility, pop),
        intervals=iv,
        unparsed_range=fairness_range(law, utility, -1, population=pop),
    )


@dataclass(frozen=True, eq=False, kw_only=True)
class PointResult(Observed):
    """The table design at one requested ε (nats, the candidate's budget).

    Attributes
    ----------
    epsilon : float
    filter : TaskFilter
    mechanism : Mechanism
        M_cand, the filter's mechanism on a candidate.
    law : Law
        The per-candidate kernel composed with ``mechanism`` and the context's mechanism.
    local_fairness, global_fairness : Fairness
        Observed L and L̄ (nats).
    intervals : FairnessIntervals or None
    black_box_local, black_box_global : float
        The black-box bounds on L and L̄ (any model behind this filter).
    corollary : float
        ε of ``mechanism``.
    unparsed_range : UtilityRange
        L and L̄ over every utility of the unparsed reply (:func:`fairaudit.fairness_range`).
    bound_ranges : dict of str to BoundRange
        Each certified bound's range over the same utilities
        (:func:`fairaudit.experiments.unparsed_bounds.bound_ranges`).
    """

    filter: TaskFilter
    mechanism: Mechanism
    black_box_local: float
    black_box_global: float
    corollary: float
    bound_ranges: dict[str, BoundRange] = field(default_factory=dict)


@dataclass(frozen=True, eq=False, kw_only=True)
class RunAnalysis:
    """What the analyses of both designs hold (:class:`ExperimentAnalysis`, and the paper's design alone:
    :class:`~fairaudit.experiments.paper_design.PaperDesignAnalysis`), which both certificates begin with.

    Attributes
    ----------
    task : DeliveryTask
    model : str
    samples : int
        Queries per shown cell (per true prompt and ε in the paper's design; 0 on the exact route).
    positions : {"balanced", "latin", "fixed"}
    population : Population
    utility : Utility
    confidence : float or None
    unparsed : int
        Replies that could not be parsed.
    context_epsilon, tau : float or None
    route : {"sampled", "exact"}
    """

    task: DeliveryTask
    model: str
    samples: int
    positions: str
    population: Population
    utility: Utility
    confidence: float | None
    unparsed: int
    context_epsilon: float | None = None
    tau: float | None = None
    route: str = "sampled"


@dataclass(frozen=True, eq=False, kw_only=True)
class ExperimentAnalysis(RunAnalysis):
    """Everything the report says about one run.

    Attributes
    ----------
    task : DeliveryTask
    model : str
    samples : int
        Queries per shown cell (0 on the exact route).
    positions : {"balanced", "latin", "fixed"}
    kernel : Kernel
        The model's kernel on shown cells (with counts on the sampled route).
    candidate_kernel : Kernel
        The per-candidate kernel on views.
    population : Population
    utility : Utility
    curve : PrivacyCurve
        Bounds and exact observed L, L̄ on a dense grid of the candidate's ε.
    points : tuple of PointResult
        At each requested ε.
    baseline : PointResult
        No filter (ε = +inf).
    shares : numpy.ndarray, shape (n_contexts, n_prompts, n_decisions)
        Baseline decision shares of each true prompt in all its orders
        (:func:`fairaudit.experiments.slots.true_prompts` with ``"balanced"``).
    paper : tuple of ObservedPoint
        The paper's design, when it was run.
    confidence : float or None
    unparsed : int
        Table-design replies that could not be parsed.
    table_queries, paper_queries : int
        Answered queries of each design (0 on the exact route).
    context_epsilon, tau : float or None
    route : {"sampled", "exact"}
        Estimated from queries (counts, intervals), or the model's own law.
    unparsed_share : float
        Mean over the shown cells of the share of unparsed replies (or of the probability mass).
    split : PositionSplit or None
    budgets : tuple of TargetBudget
    unparsed_mass : UnparsedMass or None
    """

    kernel: Kernel
    candidate_kernel: Kernel
    curve: PrivacyCurve
    points: tuple
    baseline: PointResult
    shares: np.ndarray
    paper: tuple
    table_queries: int
    paper_queries: int
    unparsed_share: float = 0.0
    split: PositionSplit | None = None
    budgets: tuple = ()
    unparsed_mass: UnparsedMass | None = None


def _point(s: _Setting, eps: float) -> PointResult:
    from fairaudit import worst_model

    filt, mech = s.mechanism(eps)
    kc, utility, pop, mx = s.kc, s.utility, s.pop, s.mx
    law = compose(kc, mech, mx)
    iv = None
    if s.confidence is not None and kc.counts is not None:
        table = CountTable(
            kc.counts, kc.contexts, kc.groups, kc.decisions, (candidate_context_name(s.task),), ("shown",), "outcome"
        )
        options = IntervalOptions(confidence=s.confidence, method=s.method)
        iv = fairness_intervals(table, utility, options, sensitive_mechanism=mech, context_mechanism=mx, population=pop)
    wm = worst_model(mech, utility, context_mechanism=mx, population=pop, tau=s.tau)
    bounds = (wm.local_fairness.value, wm.global_fairness.value)
    return PointResult(
        epsilon=eps,
        filter=filt,
        mechanism=mech,
        law=law,
        local_fairness=local_fairness(law, utility, pop),
        global_fairness=global_fairness(law, utility, pop),
        intervals=iv,
        black_box_local=wm.local_fairness.value,
        black_box_global=wm.global_fairness.value,
        corollary=mech.epsilon,
        unparsed_range=s.unparsed_range(mech),
        bound_ranges=bound_ranges(mech, utility, bounds, context_mechanism=mx, population=pop, tau=s.tau),
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
    positions : {"balanced", "latin", "fixed"}
        The population of true orders (see the module's docstring).
    confidence : float or None
        Level of the simultaneous intervals (None: none).
    method : str
        Interval method (:func:`fairaudit.fairness_intervals`).
    tau : float, optional
        τ for the paper and tight bounds; default the utility's smallest value
        when it is positive (the package task's waiting time ≥ 1), else none.
    context_epsilon : float, optional
        ε of randomized response on the context (None: shown as is).
    paper_epsilons : sequence of float
        ε values of the paper's design in the log, analysed beside.
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
        x, shown = kernel.empty_cells[0]
        cell = ", ".join(f"{o} {task.profile_label(p)!r}" for o, p in zip(slot_names(task), shown))
        raise InputError(
            "table design",
            f"shown cell ({task.context_name} {x!r}, {cell}) has "
            f"no answered query ({len(kernel.empty_cells)} such cells); run again with `resume`",
        )
    utility = candidate_utility(task)
    pop = candidate_population(task, positions)
    paper = tuple(
        observed_point(task, positions, records, e, utility, pop, confidence, method)
        for e in sorted(set(paper_epsilons))
    )
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
    paper: Sequence[ObservedPoint] = (),
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
        Shape (n_contexts, n_profiles^k, n_decisions), the layout of
        :func:`fairaudit.experiments.kernel.table_kernel`: contexts the task's,
        groups the shown pairs (row-major), decisions
        :attr:`DeliveryTask.decisions`. With counts: the sampled route
        (intervals at ``confidence``); without: the exact route.
    model : str
    epsilons : sequence of float
    samples : int
        Queries per shown cell (0 on the exact route).
    positions, confidence, method, tau, context_epsilon
        As in :func:`analyse`.
    grid : int
        Points of the dense ε grid of the curve (0 to the largest ε).
    paper : sequence of ObservedPoint
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
    n_shape = (len(task.contexts), len(task.profiles) ** task.slots, len(task.decisions))
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
        family=candidate_family(task, positions),
        epsilons=dense,
        kernel=kc,
        utility=utility,
        population=pop,
        context_mechanism=mx,
        utility_class=UtilityClass(tau=tau),
        title=f"{task.name}: {model}",
    )
    setting = _Setting(task, positions, kc, utility, pop, mx, confidence, method, tau, context_epsilon)
    points = tuple(_point(setting, e) for e in eps)
    no_filter = replace(setting, mx=identity(candidate_contexts(task)), context_epsilon=None)
    baseline = _point(no_filter, math.inf)
    probs = kernel.probabilities
    prompts, _ = true_prompts(task, "balanced")
    shares = probs[:, np.ravel_multi_index(tuple(prompts.T), (len(task.profiles),) * task.slots)]
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
        split=position_split(task, expected_utility(task, probs, np.asarray(task.utility_values))),
        budgets=_budgets(setting, targets, points),
        unparsed_mass=unparsed_mass(task, kernel),
    )
