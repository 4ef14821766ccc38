"""The worst-case utility of a known law: the utility g(u) ∈ [lower, γ] that shows the largest disparity.

:func:`worst_utility` and its result :class:`WorstUtility` (``proofs/worst_case_utility.md``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Hashable
from dataclasses import dataclass

import numpy as np

from .._arrays import BoolArray, FloatArray, IntArray, format_label, safe_log
from .._errors import InputError
from ..laws import Law, Population
from ..lfp import FractionalProgram, FractionalResult, threshold_max_many
from ..utility import Utility
from ._search import SearchResult, check_class, check_method, search
from ._worst_model import WorstCase


@dataclass(frozen=True, eq=False, kw_only=True)
class WorstUtility:
    """The utilities g(u) ∈ [lower, γ] that maximise L and L̄ for a known law (:func:`worst_utility`).

    Attributes
    ----------
    local, global_ : WorstCase
        Each with its maximising utility (``.utility``, a vector over the
        law's decisions) and pair (and context).
    law : Law
    lower, gamma : float
    tau : float or None
    population : Population
    excluded : tuple of str
    """

    local: WorstCase
    global_: WorstCase
    law: Law
    lower: float
    gamma: float
    tau: float | None
    population: Population
    excluded: tuple[str, ...]


def worst_utility(
    law: Law,
    *,
    lower: float = 0.0,
    gamma: float = 1.0,
    tau: float | None = None,
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
    lower, gamma : float
        The range of g, 0 ≤ lower ≤ γ.
    tau : float, optional
        Lower bound on E[g | x, a], ≤ γ.
    population : Population, optional
        P(X, A) for L̄ and to skip contexts with P(X = x) = 0; default uniform.
    method : {"auto", "threshold", "lp"}
        ``auto``: the threshold solution when τ ≤ lower, the LP otherwise.

    Returns
    -------
    WorstUtility
        ``local`` and ``global_`` with the maximising utility, context and pair.

    Raises
    ------
    InputError
        On a bad range, τ > γ, mismatched population labels, or an unknown method.

    Notes
    -----
    With lower = 0 and no τ the value is Lemma 1's sup over g
    (:func:`fairaudit.metrics.sup_local_fairness`): the threshold keeps the
    single decision of largest likelihood ratio. ``proofs/worst_case_utility.md``.

    Examples
    --------
    >>> law = Law([[[0.5, 0.3, 0.2], [0.2, 0.3, 0.5]]], ["x"], ["a", "b"], ["hire", "wait", "reject"])
    >>> w = worst_utility(law)
    >>> round(w.local.ratio, 12), w.local.group, w.local.utility.values.tolist()   # Lemma 1: 0.5 / 0.2
    (2.5, 'a', [1.0, 0.0, 0.0])
    >>> w = worst_utility(law, lower=0.5)                  # (0.5 + 0.5·0.5) / (0.5 + 0.5·0.2)
    >>> round(w.local.ratio, 12)
    1.25
    """
    from ..laws import population_for
    from ..metrics import group_decision_law

    if not isinstance(law, Law):
        raise InputError("law", "must be a Law", type(law).__name__)
    method = check_method(method)
    lower, gamma, tau = check_class(lower, gamma, tau)
    population = population_for(law, population)
    binding = tau is not None and tau > lower
    if method == "threshold" and binding:
        raise InputError("method", "the threshold solution needs tau <= lower", method)
    Q = law.probabilities
    nA = Q.shape[1]
    live_x = population.p_context > 0
    cell = law.observed & live_x[:, None]
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
    valid_local = cell[:, :, None] & cell[:, None, :] & ~np.eye(nA, dtype=bool)[None]
    local = _utility_case(problem, "local", Qz, valid_local, lambda x: None if x is None else law.contexts[x])
    pu = np.nan_to_num(group_decision_law(law, population), nan=0.0)
    has = population.p_group > 0
    valid_global = has[:, None] & has[None, :] & ~np.eye(nA, dtype=bool)
    global_ = _utility_case(problem, "global", pu, valid_global, lambda x: None)
    return WorstUtility(
        local=local,
        global_=global_,
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
    built: FractionalProgram | None = None

    def program(self) -> FractionalProgram:
        if self.built is None:
            n_decisions = len(self.law.decisions)
            self.built = FractionalProgram(
                n_decisions, lower=self.lower, upper=self.gamma, A_ub=self.a_ub, b_ub=self.b_ub
            )
        return self.built

    def utility(self, h: FloatArray) -> Utility:
        return Utility(np.clip(h, self.lower, self.gamma), self.law.decisions, name="worst utility")


def _utility_case(
    problem: _UtilityProblem,
    kind: str,
    P: FloatArray,
    valid: BoolArray,
    label_x: Callable[[int | None], Hashable],
) -> WorstCase:
    """The worst utility of one kind; P: (..., nA, nU) numerators per leading index; valid: (..., nA, nA) pairs."""
    lower, gamma, tau, groups = problem.lower, problem.gamma, problem.tau, problem.law.groups
    vals, k, order = threshold_max_many(P[..., :, None, :], P[..., None, :, :], lower, gamma)
    vals = np.where(valid, vals, -np.inf)
    if not valid.any():  # undefined, not fair: NaN rather than trivial's 0
        trivial = WorstCase.trivial(kind, kernel=None, reason="no two groups can be compared")
        return dataclasses.replace(trivial, value=math.nan, ratio=math.nan)
    if not problem.binding and problem.method != "lp":
        idx = np.unravel_index(int(vals.argmax()), vals.shape)
        top = order[idx][: int(k[idx])]
        h = np.full(P.shape[-1], lower)
        h[top] = gamma
        ratio = float(vals[idx])
        return WorstCase(
            kind=kind,
            value=safe_log(ratio),
            ratio=ratio,
            context=label_x(int(idx[0]) if kind == "local" else None),
            group=groups[idx[-2]],
            other_group=groups[idx[-1]],
            kernel=None,
            utility=problem.utility(h),
            expected_utility=None,
            method="threshold",
            status="unbounded" if math.isinf(ratio) else "optimal",
            solver_status="threshold",
            reason="a decision is possible for one group and impossible for another" if math.isinf(ratio) else "",
            programs_solved=0,
        )
    flat = np.argwhere(valid)
    upper = vals[tuple(flat.T)]
    if tau is not None and tau > 0:
        upper = np.minimum(upper, gamma / tau)

    def solve(i: int) -> FractionalResult:
        *lead, a, b = flat[i]
        return problem.program().solve(P[tuple(lead) + (a,)], P[tuple(lead) + (b,)])

    return _searched_case(problem, kind, search(upper, solve), flat, label_x)


def _searched_case(
    problem: _UtilityProblem,
    kind: str,
    found: SearchResult,
    flat: IntArray,
    label_x: Callable[[int | None], Hashable],
) -> WorstCase:
    """The worst case of the search over programs; ``flat[i]`` = (x, a, b) (local) or (a, b) (global) of program i."""
    r = found.result
    if found.index < 0:
        return WorstCase.infeasible(
            kind,
            r.solver_status if r else "",
            "no utility in the class meets E[g | x, a] >= tau: " + (found.reason or ""),
            found.solved,
        )
    assert r is not None  # a maximising pair was found
    *lead, a, b = flat[found.index]
    return WorstCase(
        kind=kind,
        value=safe_log(r.value),
        ratio=r.value,
        context=label_x(lead[0] if kind == "local" else None),
        group=problem.law.groups[a],
        other_group=problem.law.groups[b],
        kernel=None,
        utility=problem.utility(r.argmax) if r.argmax is not None else None,
        expected_utility=None,
        method="lp" if found.solved else "threshold",
        status=r.status,
        solver_status=r.solver_status,
        reason=r.reason,
        programs_solved=found.solved,
    )
