"""The fairness–privacy experiment of a decision task, end to end (the paper's HR and package delivery, any task file).

:func:`analyse` turns a run's log into the per-candidate analysis of the
paper's fairness–privacy experiment, exactly, at every ε:

1. The table design's counts estimate the model's kernel on *shown* cells,
   K[x̃, (ã₁, ..., ã_k), u] (:func:`fairaudit.experiments.harness.table_kernel`).
2. Per-candidate framing (docs/design.md): a query gives one record per candidate,
   with context (x, slot), group = the candidate's true profile and
   outcome = its own (chosen or not; its rank; unparsed). What the model
   sees about a candidate is every shown profile, from its own slot on (its
   *view*: ``"own | rival"`` for two), so the per-candidate kernel is indexed
   by views (:func:`fairaudit.experiments.slots.candidate_kernel`) and the
   filter that protects the candidate is M_cand
   (:func:`fairaudit.experiments.vlm.filter.candidate_family`): its ε is the
   candidate's privacy budget, the ε of every curve and certificate here.
3. At each ε the law of decisions behind the filter is the exact composition
   ``compose(K_cand, M_cand(ε), M_X ⊗ I)`` and its L and L̄ come with
   simultaneous confidence intervals from the counts
   (:func:`fairaudit.intervals.fairness_intervals`), beside the corollary,
   paper, tight and black-box bounds (:func:`fairaudit.curves.privacy_curve`).

Positions: ``balanced`` (default) weighs all orders of each combination of
candidates equally (``latin``: its k cyclic shifts), so X ⊥ A and position
bias cannot pass for group bias in L̄; ``fixed`` is the paper's own
population (the listed order only): there the slot can reveal the group,
and no filter on the profiles bounds L̄ (its black-box bound is +inf).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit import (
    Calibration,
    CountTable,
    Fairness,
    FairnessIntervals,
    InputError,
    Kernel,
    Law,
    Mechanism,
    Population,
    PrivacyCurve,
    Utility,
    UtilityRange,
    compose,
    fairness_intervals,
    fairness_range,
    from_matrix,
    from_table,
    global_fairness,
    identity,
    local_fairness,
    number,
    privacy_curve,
    randomized_response,
    real,
)

from .harness import eps_key, table_kernel, true_cell_counts
from .slots import (
    candidate_contexts,
    candidate_epsilon,
    candidate_kernel,
    candidate_mechanism,
    candidate_population,
    expected_utility,
    true_prompts,
)
from .vlm.filter import PrivacyFilter, candidate_family, profile_budget
from .vlm.tasks import DeliveryTask

if TYPE_CHECKING:
    from .cells import Cells
    from .kernel import Measured
    from .paper_design import PaperDesignAnalysis

__all__ = [
    "DEFAULT_TARGETS",
    "UNPARSED_WARNING",
    "BoundRange",
    "ExperimentAnalysis",
    "PaperDesignPoint",
    "PointResult",
    "PositionSplit",
    "TargetBudget",
    "UnparsedMass",
    "analyse",
    "analyse_kernel",
    "analyse_run",
    "bound_ranges",
    "bound_ranges_from",
    "candidate_context_mechanism",
    "candidate_utility",
    "epsilon_from_keep",
    "paper_design_point",
    "position_split",
]


def _context_name(task: DeliveryTask) -> str:
    return task.context_name if task.slots == 1 else "context @ position"


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


def epsilon_from_keep(task: DeliveryTask, keep: float, positions: str = "balanced") -> float:
    """The candidate's ε when every attribute of every profile is kept with probability ``keep`` (nats).

    ε(M_cand) with attribute i, of k_i values, at ln(keep (k_i − 1) / (1 − keep)), exactly, whatever the other
    attributes' sizes (the split of :meth:`fairaudit.experiments.vlm.filter.PrivacyFilter.from_epsilon`): for the
    paper's pair Σ over the 2 n attributes shown
    (:func:`fairaudit.experiments.slots.candidate_epsilon`); for mixtures
    from the mechanism's matrix.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> round(epsilon_from_keep(HR_DELIVERY, 0.7), 6)      # 6 ln(7/3), not 0.7/0.3
    5.083787
    """
    from fairaudit import epsilon_from_keep_probability, product

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


DEFAULT_TARGETS = (0.05, 0.1, 0.25, 0.5)
"""Fairness targets (nats) at which an experiment reports the privacy budget that meets them."""


@dataclass(frozen=True, eq=False)
class TargetBudget:
    """The candidate's privacy budget ε that meets one fairness target, for this model and for any model.

    A target is met by this model only when the upper end of its L (L̄) over every utility of the unparsed reply
    meets it: ``this_model`` is calibrated on that upper end, ``stated_default`` under the stated utility beside it.

    Attributes
    ----------
    target : float
        On L (``kind="local"``) or L̄ (``"global"``), nats.
    kind : {"local", "global"}
    this_model : Calibration
        White-box on the upper end: the largest ε at which the upper end of this model's L (L̄) behind the
        filter, over every utility of the unparsed reply in [min g, max g] chosen per cell
        (:func:`fairaudit.utility_range.fairness_range`), stays ≤ target at every smaller ε
        (:func:`fairaudit.calibrate.calibrate` with ``unparsed_decision=-1``): every such utility meets the
        target there (``proofs/unparsed.md`` §5). Without unparsed mass it is ``stated_default``'s answer.
        On the sampled route it is an estimate from the counts.
    any_model : Calibration
        Black-box: the largest ε whose exact worst case over every model is ≤ target.
    stated_default : Calibration
        White-box under the stated utility of the unparsed reply: the largest ε at which this model's L (L̄)
        stays ≤ target at every smaller ε (at least ``this_model``'s ε).
    unparsed_upper : float
        The upper end of the unparsed range at ``stated_default``'s ε (nats; NaN when no ε meets the target
        there). Above the target, ``stated_default``'s answer holds only under the stated unparsed utility.
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


def _budgets(
    task: DeliveryTask,
    positions: str,
    targets: Sequence[float],
    kc: Kernel,
    utility: Utility,
    pop: Population,
    mx: Mechanism,
    tau: float | None,
    upper_at: Any = None,
) -> tuple[TargetBudget, ...]:
    """Per target and kind the white-box ε (on the unparsed range's upper end, and under the stated default) and the
    black-box ε; ``upper_at(ε, kind)``: the unparsed range's upper end at the stated default's ε."""
    from fairaudit import calibrate

    family = candidate_family(task, positions)
    out = []
    for target in sorted({float(t) for t in targets}):
        for kind in ("local", "global"):
            white = {
                d: calibrate(
                    target,
                    kind=kind,
                    method="white_box",
                    family=family,
                    kernel=kc,
                    utility=utility,
                    population=pop,
                    context_mechanism=mx,
                    unparsed_decision=d,
                )
                for d in (-1, None)
            }
            black = calibrate(
                target, kind=kind, method="black_box", family=family, groups=list(pop.groups),
                gamma=utility.gamma, lower=utility.lower, tau=tau, population=pop,
            )  # fmt: skip
            stated = white[None]
            upper = upper_at(stated.epsilon, kind) if upper_at is not None and stated.feasible else math.nan
            out.append(TargetBudget(target, kind, white[-1], black, stated, upper))
    return tuple(out)


@dataclass(frozen=True, eq=False, kw_only=True)
class PaperDesignPoint:
    """The paper's design at one ε: the per-candidate law from queries sampled through the filter.

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
        (:func:`fairaudit.utility_range.fairness_range` of the law itself: the filter is in the queries), next to
        the value under the stated default, which is ``local_fairness`` and ``global_fairness``.
    """

    epsilon: float
    queries: int
    law: Law
    local_fairness: Fairness
    global_fairness: Fairness
    intervals: FairnessIntervals | None
    unparsed_range: UtilityRange


@dataclass(frozen=True, eq=False, kw_only=True)
class PointResult:
    """The table design at one requested ε (nats, the candidate's budget).

    Attributes
    ----------
    epsilon : float
    filter : PrivacyFilter
    mechanism : Mechanism
        The filter's mechanism on a candidate (:meth:`PrivacyFilter.candidate_mechanism`).
    law : Law
        The model's kernel composed with ``mechanism`` and the context's mechanism.
    local_fairness, global_fairness : Fairness
        Observed L and L̄ (nats), with the maximising context and groups.
    intervals : FairnessIntervals or None
    black_box_local, black_box_global : float
        The black-box bounds on L and L̄ (any model behind this filter).
    corollary : float
        The corollary's bound: ε of ``mechanism``.
    unparsed_range : UtilityRange
        L and L̄ over every utility of the unparsed reply in [min g, max g], chosen per cell of the
        per-candidate kernel (:func:`fairaudit.utility_range.fairness_range`), next to the value under the
        stated default.
    bound_ranges : dict of str to BoundRange
        ``"corollary"``, ``"black_box"`` and ``"black_box_global"``: each certified bound's exact range over the
        same utilities of the unparsed reply (:func:`bound_ranges`; its upper end is the bound as stated).
    """

    epsilon: float
    filter: PrivacyFilter
    mechanism: Mechanism
    law: Law
    local_fairness: Fairness
    global_fairness: Fairness
    intervals: FairnessIntervals | None
    black_box_local: float
    black_box_global: float
    corollary: float
    unparsed_range: UtilityRange
    bound_ranges: dict[str, BoundRange] = field(default_factory=dict)


@dataclass(frozen=True, eq=False, kw_only=True)
class BoundRange:
    """A certified bound's exact range over every utility of the unparsed reply in [min g, max g] (per cell).

    Attributes
    ----------
    lower, upper : float
        The ends (nats); ``upper`` is the bound as stated, equal to ``lower`` when the bound does not depend on
        the unparsed reply's utility.
    reason : str
        Why the range is what it is, in words.
    """

    lower: float
    upper: float
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """``{"range": [lower, upper], "reason": ...}``."""
        return {"range": [number(self.lower), number(self.upper)], "reason": self.reason}


def bound_ranges(
    mechanism: Mechanism,
    utility: Utility,
    bounds: tuple[float, float],
    *,
    context_mechanism: Mechanism,
    population: Population,
    tau: float | None,
) -> dict[str, BoundRange]:
    """The corollary's and the black-box bounds' ranges over every utility of the unparsed reply (the last decision).

    The corollary is ε of ``mechanism``: no utility enters it. The black-box bounds (``bounds``: on L and L̄, as
    :func:`fairaudit.worstcase.worst_model` gives them for ``utility``) are maxima over every decision model whose
    cell expectations lie in [min g, max g] (g of the decision only) with E ≥ τ, τ held as stated. With the
    unparsed utility v_c of a cell in [min g, max g], that cell's expectations span [min(g_known ∪ v_c),
    max(g_known ∪ v_c)], g_known the other outcomes' utilities: between [min g_known, max g_known] and
    [min g, max g], and the bound is non-decreasing in each cell's interval (a maximum over a larger set). So the
    upper end is the bound as stated (v at the end of [min g, max g] beyond g_known, when there is one) and the
    lower end is the bound for the utility whose unparsed value lies within g_known's range: equal ends when the
    stated unparsed value lies within it (``proofs/unparsed.md`` §6).

    Parameters
    ----------
    mechanism : Mechanism
        The filter's mechanism on a candidate (its ε is the corollary's bound, nats).
    utility : Utility
        g of the candidate's outcome, shape (n_outcomes,), the unparsed reply last, at its stated value.
    bounds : tuple of float
        The black-box bounds on L and L̄ (nats) for ``utility`` as stated.
    context_mechanism : Mechanism
        The filter on the context, as the bounds were computed with it.
    population : Population
        P(X, A) of the candidates, shape (n_contexts, n_groups).
    tau : float or None
        The floor on E[g | x, a] the bounds used (None: none).

    Returns
    -------
    dict of str to BoundRange
        ``"corollary"``, ``"black_box"`` (on L) and ``"black_box_global"`` (on L̄): each bound's range (nats).
    """
    from fairaudit import worst_model

    def inside(u: Utility) -> tuple[float, float]:
        wm = worst_model(mechanism, u, context_mechanism=context_mechanism, population=population, tau=tau)
        return wm.local_fairness.value, wm.global_fairness.value

    return bound_ranges_from(mechanism.epsilon, utility, bounds, inside)


def bound_ranges_from(
    corollary: float,
    utility: Utility,
    bounds: tuple[float, float],
    inside: Callable[[Utility], tuple[float, float]],
) -> dict[str, BoundRange]:
    """:func:`bound_ranges` from the corollary's value and a function giving the black-box bounds for a utility.

    For a design whose mechanism is given by its bounds alone (the paper's design, where M_cand may be too large
    to build: :func:`fairaudit.experiments.paper_design.paper_design_bounds`).

    Parameters
    ----------
    corollary : float
        ε of the filter on a candidate (nats).
    utility : Utility
        g of the candidate's outcome, shape (n_outcomes,), the unparsed reply last, at its stated value.
    bounds : tuple of float
        The black-box bounds on L and L̄ (nats) for ``utility`` as stated.
    inside : callable
        The black-box bounds on L and L̄ (nats) for another utility over the same outcomes, with the same
        mechanisms, population and τ; called only when the stated unparsed utility lies outside the other
        outcomes' range.

    Returns
    -------
    dict of str to BoundRange
        As :func:`bound_ranges`.

    Examples
    --------
    g = 1 (chosen), 0 (not chosen) and 2 for an unparsed reply: above the others' [0, 1], so the lower ends are
    the bounds for an unparsed utility of 0 (here given by ``inside``).

    >>> from fairaudit import Utility
    >>> g = Utility([1.0, 0.0, 2.0], ["chosen", "not chosen", "unparsed"])
    >>> r = bound_ranges_from(0.5, g, (0.9, 0.7), lambda u: (0.4, 0.3))
    >>> r["corollary"].lower, r["corollary"].upper, r["black_box"].lower, r["black_box"].upper
    (0.5, 0.5, 0.4, 0.9)
    >>> r["black_box_global"].to_dict()["range"]
    [0.3, 0.7]
    """
    g = np.asarray(utility.values, dtype=float)
    known, stated = g[:-1], float(g[-1])
    k_lo, k_hi = float(known.min()), float(known.max())
    fixed = BoundRange(
        lower=corollary, upper=corollary, reason="the corollary is epsilon of the filter: no utility enters it"
    )
    head = (
        f"the black-box bounds depend on g only through [min g, max g] = [{utility.lower:g}, {utility.gamma:g}] and "
        f"tau, and the stated unparsed utility {stated:g} lies"
    )
    if (k_lo, k_hi) == (utility.lower, utility.gamma):
        why = (
            f"{head} within the other outcomes' [{k_lo:g}, {k_hi:g}], so no utility of an unparsed reply in "
            "[min g, max g] changes them: each range is one value"
        )
        low = bounds
    else:
        why = (
            f"{head} outside the other outcomes' [{k_lo:g}, {k_hi:g}]: each range runs from the bound for g in "
            f"[{k_lo:g}, {k_hi:g}] (an unparsed utility within it) to the bound as stated"
        )
        low = inside(Utility(np.append(known, k_lo), utility.decisions, name=f"{utility.name}, unparsed at {k_lo:g}"))
    return {"corollary": fixed} | {
        name: BoundRange(lower=lo, upper=up, reason=why)
        for name, lo, up in zip(("black_box", "black_box_global"), low, bounds)
    }


UNPARSED_WARNING = 0.2
"""A shown cell whose unparsed mass exceeds this share makes the experiment warn (report.md and stderr)."""


@dataclass(frozen=True, eq=False, kw_only=True)
class UnparsedMass:
    """The shown cells whose unparsed mass exceeds a threshold: where the stated unparsed utility decides L.

    Attributes
    ----------
    threshold : float
        :data:`UNPARSED_WARNING`.
    share : float
        Share of the shown cells (context × shown profiles) whose unparsed mass exceeds ``threshold``.
    largest : float
        The largest unparsed mass of a shown cell.
    cells : tuple of (str, str, float)
        Up to five such cells, largest mass first: (context, the shown profiles by slot, mass).
    """

    threshold: float
    share: float
    largest: float
    cells: tuple

    @property
    def warning(self) -> str | None:
        """One line for report.md and stderr, or None when no cell exceeds the threshold."""
        if self.share == 0:
            return None
        named = "; ".join(f"{c} / {shown}: {m:.3g}" for c, shown, m in self.cells)
        return (
            f"{self.share:.1%} of the shown cells put more than {self.threshold:g} of their mass on unparsed replies "
            f"(largest {self.largest:.3g}; e.g. {named}): L and L̄ there depend on the utility given to an unparsed "
            "reply; see the unparsed ranges"
        )


def unparsed_mass(task: DeliveryTask, kernel: Kernel, threshold: float = UNPARSED_WARNING) -> UnparsedMass:
    """The shown cells of ``kernel`` (the table design's layout) whose unparsed mass exceeds ``threshold``."""
    mass = np.nan_to_num(kernel.probabilities[..., -1], nan=0.0)  # (n_contexts, n_shown)
    over = mass > threshold
    order = np.argsort(-mass, axis=None, kind="stable")[: min(5, int(over.sum()))]
    slots = task.options if task.slots > 1 else ("candidate",)
    cells = []
    for flat in order:
        x, j = np.unravel_index(flat, mass.shape)
        shown = np.unravel_index(j, (len(task.profiles),) * task.slots)
        who = ", ".join(f"{o} = {task.profile_label(task.profiles[i])}" for o, i in zip(slots, shown))
        cells.append((str(task.contexts[x]), who, float(mass[x, j])))
    return UnparsedMass(threshold=threshold, share=float(over.mean()), largest=float(mass.max()), cells=tuple(cells))


@dataclass(frozen=True, eq=False, kw_only=True)
class ExperimentAnalysis:
    """Everything the report says about one run.

    Attributes
    ----------
    task : DeliveryTask
    model : str
    samples : int
        Queries per shown cell (table design).
    positions : {"balanced", "latin", "fixed"}
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
    shares : numpy.ndarray, shape (n_contexts, n_prompts, n_decisions)
        Baseline decision shares for each true prompt in all its orders
        (:func:`fairaudit.experiments.slots.true_prompts` with ``"balanced"``):
        for the paper's pair, its order then swapped.
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
    split : PositionSplit or None
        How much of the raw disparity of the listed order is position and how
        much group (None for one candidate per prompt).
    budgets : tuple of TargetBudget
        Per target and kind (local, global): the ε that meets it for this model (on the upper end of the
        unparsed range, and under the stated default beside it) and for any model.
    unparsed_mass : UnparsedMass or None
        The shown cells whose unparsed mass exceeds :data:`UNPARSED_WARNING` (its ``warning``, when set, is
        written in report.md and on stderr).
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
    unparsed_mass: UnparsedMass | None = None


def _point(
    task: DeliveryTask,
    positions: str,
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
    from fairaudit import worst_model

    filt = PrivacyFilter.from_epsilon(task, profile_budget(task, positions)(eps), context_epsilon=context_epsilon)
    mech = filt.candidate_mechanism(positions)
    law = compose(kc, mech, mx)
    iv = None
    if confidence is not None and kc.counts is not None:
        table = CountTable(
            kc.counts, kc.contexts, kc.groups, kc.decisions, (_context_name(task),), ("shown",), "outcome"
        )
        iv = fairness_intervals(
            table, utility, confidence, method, sensitive_mechanism=mech, context_mechanism=mx, population=pop
        )
    wm = worst_model(mech, utility, context_mechanism=mx, population=pop, tau=tau)
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
        unparsed_range=fairness_range(kc, utility, -1, sensitive_mechanism=mech, context_mechanism=mx, population=pop),
        bound_ranges=bound_ranges(mech, utility, bounds, context_mechanism=mx, population=pop, tau=tau),
    )


def paper_design_point(
    task: DeliveryTask,
    positions: str,
    records: Iterable[dict[str, Any]],
    eps: float,
    utility: Utility,
    pop: Population,
    confidence: float | None,
    method: str,
) -> PaperDesignPoint:
    """The paper's design at ``eps`` (nats; +inf: no filter): its records counted by true context, slot, profile, outcome.

    Records of ``design = "paper"`` whose ``epsilon`` is ``eps`` and whose true prompt is one of ``positions``
    (:func:`fairaudit.experiments.slots.true_prompts`) are counted by
    :func:`fairaudit.experiments.harness.true_cell_counts`; L and L̄ (with ``confidence`` intervals) are those
    of their per-candidate law, with population ``pop``, and their range over the unparsed reply's utility is that
    of the law's cells (:func:`fairaudit.utility_range.fairness_range` of the law: its value is L and L̄ as
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
            counts, law.contexts, law.groups, law.decisions, (_context_name(task),), ("candidate",), "outcome"
        )
        iv = fairness_intervals(table, utility, confidence, method, population=pop)
    rng = fairness_range(law, utility, -1, population=pop)
    return PaperDesignPoint(
        epsilon=eps,
        queries=len(truths),
        law=law,
        local_fairness=local_fairness(law, utility, pop),
        global_fairness=global_fairness(law, utility, pop),
        intervals=iv,
        unparsed_range=rng,
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
    positions : {"balanced", "latin", "fixed"}
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
        x, shown = kernel.empty_cells[0]
        slots = task.options if task.slots > 1 else ("candidate",)
        cell = ", ".join(f"{o} {task.profile_label(p)!r}" for o, p in zip(slots, shown))
        raise InputError(
            "table design",
            f"shown cell ({task.context_name} {x!r}, {cell}) has "
            f"no answered query ({len(kernel.empty_cells)} such cells); run again with `resume`",
        )
    utility = candidate_utility(task)
    pop = candidate_population(task, positions)
    paper = tuple(
        paper_design_point(task, positions, records, e, utility, pop, confidence, method)
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
        tau=tau,
        title=f"{task.name}: {model}",
    )
    points = tuple(
        _point(task, positions, e, kc, utility, pop, mx, confidence, method, tau, context_epsilon) for e in eps
    )
    baseline = _point(
        task, positions, math.inf, kc, utility, pop, identity(candidate_contexts(task)), confidence, method, tau, None
    )
    ranges = {p.epsilon: p.unparsed_range for p in points}

    def upper_at(e: float, kind: str) -> float:  # at the white-box ε of a target, with this run's M_X
        if e not in ranges:
            filt = PrivacyFilter.from_epsilon(task, profile_budget(task, positions)(e), context_epsilon=context_epsilon)
            mech = filt.candidate_mechanism(positions)
            ranges[e] = fairness_range(kc, utility, -1, sensitive_mechanism=mech, context_mechanism=mx, population=pop)
        r = ranges[e]
        return (r.local_fairness if kind == "local" else r.global_fairness).upper

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
        budgets=_budgets(task, positions, targets, kc, utility, pop, mx, tau, upper_at),
        unparsed_mass=unparsed_mass(task, kernel),
    )


def analyse_run(cells: Cells, measured: Measured) -> ExperimentAnalysis | PaperDesignAnalysis:
    """The fifth step of a run: the analysis of what the model gave on ``cells``.

    The exact route's kernel (:func:`analyse_kernel`), the sampled route's answered queries (:func:`analyse`, with
    the paper's design beside when it ran), or the paper's design alone
    (:func:`fairaudit.experiments.paper_design.analyse_paper_design`).
    """
    common: dict[str, Any] = {
        "model": measured.model,
        "epsilons": cells.epsilons,
        "positions": cells.positions,
        "confidence": cells.confidence,
        "method": cells.method,
        "context_epsilon": cells.context_epsilon,
    }
    if measured.kernel is not None:
        return analyse_kernel(measured.task, measured.kernel, targets=cells.targets, **common)
    if cells.design == "paper":
        from .paper_design import analyse_paper_design

        return analyse_paper_design(measured.task, measured.records, samples=cells.samples, **common)
    paper = cells.epsilons if cells.design == "both" else ()
    return analyse(
        measured.task, measured.records, samples=cells.samples, paper_epsilons=paper, targets=cells.targets, **common
    )
