"""The worst-case utility of a known law: the utility g(u) ∈ [lower, γ] that shows the largest disparity.

:func:`worst_utility` and its result :class:`WorstUtility` (``proofs/worst_case_utility.md``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np

from fairaudit.base.arrays import BoolArray, FloatArray
from fairaudit.base.errors import InputError
from fairaudit.base.exact_duality import Rows
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.base.linear_fractional import FractionalProgram, FractionalResult
from fairaudit.base.outward import product_ends, rounding_error, sum_ends, widen_up
from fairaudit.base.threshold_rule import box_point, threshold_max_many
from fairaudit.laws.tables import Law, Population
from fairaudit.laws.utilities import Utility, UtilityClass
from fairaudit.worstcase.pair_search import (
    InnerProgram,
    box_pairs,
    check_class,
    implied_floor,
    inner_witness,
    pair_values,
    ratio_ceiling,
    search,
)
from fairaudit.worstcase.worst_cases import WorstCase, check_method, nats_up


@dataclass(frozen=True, eq=False, kw_only=True)
class WorstUtility:
    """The utilities g(u) ∈ [lower, γ] that maximise L and L̄ for a known law (:func:`worst_utility`).

    Attributes
    ----------
    local_fairness, global_fairness : WorstCase
        The maxima of L and L̄, each with its maximising utility
        (``.utility``, a vector over the law's decisions) and pair (and context).
    law : Law
    lower, gamma : float
    tau : float or None
    population : Population
    excluded : tuple of str
    """

    local_fairness: WorstCase
    global_fairness: WorstCase
    law: Law
    lower: float
    gamma: float
    tau: float | None
    population: Population
    excluded: tuple[str, ...]

    def to_dict(self) -> Report:
        """The report dictionary: the class, the law's decisions, and the worst utility of L (``local``) and of L̄.

        ``local`` and ``global`` are each worst case's dictionary (value, ratio, the context for ``local``, the
        pair, method, status, programs solved) with ``utility``: the maximising g, one value per decision in the
        order of ``decisions`` (``null`` when no utility of the class meets τ). Then ``lower``, ``gamma``, ``tau``
        (``null`` when not given), ``population`` and ``excluded``.

        Examples
        --------
        >>> law = Law([[[0.5, 0.3, 0.2], [0.2, 0.3, 0.5]]], ["x"], ["a", "b"], ["hire", "wait", "reject"])
        >>> d = worst_utility(law).to_dict()
        >>> d["decisions"], d["local"]["utility"], d["local"]["ratio"], d["local"]["group"]
        (['hire', 'wait', 'reject'], [1.0, 0.0, 0.0], 2.5, 'a')
        """

        def case(w: WorstCase) -> Report:
            d = w.to_dict()
            d["utility"] = None if w.utility is None else [number(v) for v in np.asarray(w.utility.values).tolist()]
            return d

        return {
            "decisions": [label(d) for d in self.law.decisions],
            "lower": number(self.lower),
            "gamma": number(self.gamma),
            "tau": number(self.tau),
            "local": case(self.local_fairness),
            "global": case(self.global_fairness),
            "population": self.population.to_dict(),
            "excluded": list(self.excluded),
        }


def worst_utility(
    law: Law,
    *,
    utility_class: UtilityClass | None = None,
    population: Population | None = None,
    method: str = "auto",
) -> WorstUtility:
    """The utility g(u) ∈ [lower, γ] that shows the largest disparity of a known law.

    Per context x and ordered pair (a, a'), maximise (Q[x, a]·g) / (Q[x, a']·g)
    (local) or (P(U | a)·g) / (P(U | a')·g) (global) over g ∈ [lower, γ]^{n_decisions},
    with E[g | x, b] = Q[x, b]·g ≥ τ in every observed cell of a context of
    positive probability (τ couples the contexts, as g is shared).

    Parameters
    ----------
    law : Law
        Q[x, a, u], shape (n_contexts, n_groups, n_decisions); empty cells are skipped.
    utility_class : UtilityClass, optional
        ``lower`` and ``gamma``: the range of g, 0 ≤ lower ≤ γ (by default 0
        and 1); ``tau``: lower bound on E[g | x, a], ≤ γ (by default none).
        ``lipschitz``, ``metric`` and ``diameter`` are not used: g(u) does not
        depend on the group.
    population : Population, optional
        P(X, A) for L̄ and to skip contexts with P(X = x) = 0; default uniform.
    method : {"auto", "threshold", "lp"}
        ``auto``: the threshold solution when τ ≤ lower, the LP otherwise.

    Returns
    -------
    WorstUtility
        ``local_fairness`` and ``global_fairness`` with the maximising utility, context and pair.

    Raises
    ------
    InputError
        On a bad range, τ > γ, mismatched population labels, or an unknown method.

    Notes
    -----
    With lower = 0 and no τ the value is Lemma 1's sup over g
    (:func:`fairaudit.metrics.sup_fairness.sup_local_fairness`): the threshold keeps the
    single decision of largest likelihood ratio. ``proofs/worst_case_utility.md``.

    Examples
    --------
    >>> law = Law([[[0.5, 0.3, 0.2], [0.2, 0.3, 0.5]]], ["x"], ["a", "b"], ["hire", "wait", "reject"])
    >>> w = worst_utility(law)
    >>> round(w.local_fairness.ratio, 12), w.local_fairness.group, w.local_fairness.utility.values.tolist()   # Lemma 1: 0.5 / 0.2
    (2.5, 'a', [1.0, 0.0, 0.0])
    >>> from fairaudit.laws.utilities import UtilityClass
    >>> w = worst_utility(law, utility_class=UtilityClass(lower=0.5))   # (0.5 + 0.5·0.5) / (0.5 + 0.5·0.2)
    >>> round(w.local_fairness.ratio, 12)
    1.25
    """
    from fairaudit.laws.tables import population_for
    from fairaudit.metrics.reductions import group_decision_law

    if not isinstance(law, Law):
        raise InputError("law", "must be a Law", type(law).__name__)
    method = check_method(method)
    lower, gamma, tau = check_class(utility_class)
    population = population_for(law, population)
    Q = law.probabilities
    live_x = population.p_context > 0
    cell = law.observed & live_x[:, None]
    # τ > lower binds; else E[g | x, a] = Q[x, a]·g ≥ lower Σ_u Q[x, a, u] may still fall below τ, a law's rows
    # summing to 1 only within 1e-9 (their exact sums, a row at a time, only then)
    binding = tau is not None and tau > lower
    if tau is not None and 0 < tau <= lower:
        binding = tau > implied_floor(lower, float(sum_ends(np.nan_to_num(Q, nan=1.0)[cell])[1].min(initial=1.0)))
    if method == "threshold" and binding:
        raise InputError("method", "the threshold solution needs tau <= lower (times the law's least row sum)", method)
    excluded = tuple(
        f"context {format_label(law.contexts[i])!r}: P(X = x) = 0" for i in np.flatnonzero(~live_x)
    ) + tuple(f"cell (context {format_label(x)!r}, group {format_label(a)!r}): no records" for x, a in law.empty_cells)
    Qz = np.nan_to_num(Q, nan=0.0)
    a_ub = -Qz[cell] if binding else None
    problem = _UtilityProblem(
        law=law,
        lower=lower,
        gamma=gamma,
        tau=tau,
        binding=binding,
        method=method,
        a_ub=a_ub,
        b_ub=None if a_ub is None or tau is None else np.full(a_ub.shape[0], -tau),
    )
    # (a pair (a, b), a != b, is compared where both rows are: no (n, n) masks, no (n, n, n_decisions) tables)
    local = _utility_case(problem, "local", Qz, cell)
    pu = np.nan_to_num(group_decision_law(law, population), nan=0.0)
    has = population.p_group > 0
    # P(u | a) = Σ_x P(x | a) Q[x, a, u]: P(x | a) carries n_x roundings, the product one, the sum n_x − 1; exact
    # when one context has P(x, a) > 0 (its weight is 1)
    weights = population.probabilities > 0
    roundings = 2 * law.shape[0] + 1 if np.any(weights.sum(axis=0) > 1) else 0
    ends = product_ends(pu, roundings, np.any(weights[:, :, None] & (Qz > 0), axis=0))
    global_ = _utility_case(problem, "global", pu[None], has[None], (ends[0][None], ends[1][None]), roundings)
    return WorstUtility(
        local_fairness=local,
        global_fairness=global_,
        law=law,
        lower=lower,
        gamma=gamma,
        tau=tau,
        population=population,
        excluded=excluded,
    )


@dataclass(eq=False, kw_only=True)
class _UtilityProblem:
    """A checked class [lower, γ] (with τ) for a law, and its program, built on first use and shared by both cases."""

    law: Law
    lower: float
    gamma: float
    tau: float | None
    binding: bool  # τ > lower
    method: str
    a_ub: FloatArray | None  # the τ rows: a_ub @ g <= b_ub
    b_ub: FloatArray | None

    @functools.cached_property
    def program(self) -> FractionalProgram:
        """The program over g, built at the first use."""
        n_decisions = len(self.law.decisions)
        return FractionalProgram(n_decisions, lower=self.lower, upper=self.gamma, A_ub=self.a_ub, b_ub=self.b_ub)

    def utility(self, h: FloatArray) -> Utility:
        return Utility(np.clip(h, self.lower, self.gamma), self.law.decisions, name="worst utility")


def _utility_case(
    problem: _UtilityProblem,
    kind: str,
    P: FloatArray,
    rows: BoolArray,
    ends: tuple[FloatArray, FloatArray] | None = None,
    roundings: int = 0,
) -> WorstCase:
    """The worst utility of one kind; P: (n_lead, nA, nU) numerators (n_lead: contexts, or 1 for L̄); rows:
    (n_lead, nA), the groups that take part (pairs of two of them, a != b).

    ``ends``, when P was computed with at most ``roundings`` roundings an entry: its lower and upper ends. The values are then certified on the
    outer program (numerator's upper end over the denominator's lower end, which contains the exact one), the
    threshold's widened by the ratio's error (1 + γ)/(1 − γ) ≤ 1 + 3γ, and the witness is the inner ratio.
    """
    lower, gamma, tau, groups = problem.lower, problem.gamma, problem.tau, problem.law.groups
    widen = 3 * float(rounding_error(roundings))
    if not np.any(rows.sum(axis=-1) >= 2):  # undefined, not fair: NaN rather than trivial's 0
        trivial = WorstCase.trivial(kind, kernel=None, reason="no two groups can be compared")
        return dataclasses.replace(trivial, value=math.nan, ratio=math.nan)
    if not problem.binding and problem.method != "lp":
        # per leading index, the pairs that can be the largest (box_pairs: exact, O(nA·nU) memory); the first
        # maximiser in (x, a, b) order, as over the whole table (max keeps the first of equal values)
        def best(x: int) -> tuple[float, int, int, int]:
            at = np.flatnonzero(rows[x])
            found = box_pairs(P[x, at], lower, gamma)
            i = int(np.argmax(found.box))
            return float(found.box[i]), x, int(at[found.a[i]]), int(at[found.b[i]])

        leading = (best(x) for x in range(P.shape[0]) if np.count_nonzero(rows[x]) >= 2)  # (some has two rows)
        ratio, x, a, b = max(leading, key=lambda found: found[0])
        ratio = float(widen_up(ratio, widen)) if widen else ratio
        _, k, order = threshold_max_many(P[x, a], P[x, b], lower, gamma)
        h = box_point(lower, gamma, order, int(k))
        return WorstCase.threshold(
            kind,
            ratio,
            nats_up(ratio),
            context=problem.law.contexts[x] if kind == "local" else None,
            group=groups[a],
            other_group=groups[b],
            utility=problem.utility(h),
            reason="a decision is possible for one group and impossible for another" if math.isinf(ratio) else "",
        )
    flat = np.argwhere(rows[:, :, None] & rows[:, None, :] & ~np.eye(rows.shape[1], dtype=bool))  # (x, a, b), row-major
    rows_of = flat[:, 0] * P.shape[1]  # (P's rows of context x, one per group)
    upper = pair_values(P.reshape(-1, P.shape[-1]), rows_of + flat[:, 1], rows_of + flat[:, 2], lower, gamma, None)[0]
    upper = np.asarray(widen_up(upper, widen)) if widen else upper
    if tau is not None and tau > 0:  # E[g | x, a] ≤ γ Σ_u P[x, a, u]: a law's rows sum to 1 within 1e-9
        upper = np.minimum(upper, ratio_ceiling(gamma, float(sum_ends(P if ends is None else ends[1])[0].max()), tau))
    low, high = (P, P) if ends is None else ends
    floors: Rows = [] if problem.a_ub is None or problem.b_ub is None else [(problem.a_ub, problem.b_ub, "le")]
    inner = InnerProgram(np.full(P.shape[-1], lower), np.full(P.shape[-1], gamma), floors)

    def solve(i: int) -> FractionalResult:
        x, a, b = flat[i]
        r = problem.program.solve(high[x, a], low[x, b])
        return r if ends is None else inner_witness(r, low[x, a], high[x, b], inner)

    searched = search(upper, solve)
    if searched.index < 0:
        return WorstCase.unmet(
            kind, searched, "no utility in the class meets E[g | x, a] >= tau: " + (searched.reason or "")
        )
    r = searched.result
    assert r is not None  # a maximising pair was found
    x, a, b = flat[searched.index]
    return WorstCase.searched(
        kind,
        searched,
        context=problem.law.contexts[x] if kind == "local" else None,
        group=groups[a],
        other_group=groups[b],
        utility=problem.utility(r.argmax) if r.argmax is not None else None,
    )
