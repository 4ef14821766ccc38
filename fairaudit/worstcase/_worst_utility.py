"""The worst-case utility of a known law: the utility g(u) ∈ [lower, γ] that shows the largest disparity.

:func:`worst_utility` and its result :class:`WorstUtility` (``proofs/worst_case_utility.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable
from dataclasses import dataclass

import numpy as np

from .._arrays import BoolArray, FloatArray, format_label
from .._errors import InputError
from ..laws import Law, Population
from ..lfp import FractionalProgram, FractionalResult, threshold_max_many
from ..utility import Utility
from ._search import _check_class, _check_method, _log, _search
from ._worst_model import WorstCase


@dataclass(frozen=True, eq=False)
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
    from ..metrics import _check_population, group_decision_law

    if not isinstance(law, Law):
        raise InputError("law", "must be a Law", type(law).__name__)
    method = _check_method(method)
    lower, gamma, tau = _check_class(lower, gamma, tau)
    population = _check_population(population, law)
    binding = tau is not None and tau > lower
    if method == "threshold" and binding:
        raise InputError("method", "the threshold solution needs tau <= lower", method)
    Q = law.probabilities
    nX, nA, nU = Q.shape
    live_x = population.p_context > 0
    cell = law.observed & live_x[:, None]
    excluded = tuple(
        f"context {format_label(law.contexts[i])!r}: P(X = x) = 0" for i in np.flatnonzero(~live_x)
    ) + tuple(f"cell (context {format_label(x)!r}, group {format_label(a)!r}): no records" for x, a in law.empty_cells)
    decisions = law.decisions

    def util(h: FloatArray) -> Utility:
        return Utility(np.clip(h, lower, gamma), decisions, name="worst utility")

    Qz = np.nan_to_num(Q, nan=0.0)
    a_ub = -Qz[cell] if binding else None
    b_ub = None if a_ub is None or tau is None else np.full(a_ub.shape[0], -tau)
    prog: FractionalProgram | None = None

    def program() -> FractionalProgram:
        nonlocal prog
        if prog is None:
            prog = FractionalProgram(nU, lower=lower, upper=gamma, A_ub=a_ub, b_ub=b_ub)
        return prog

    def case(kind: str, P: FloatArray, valid: BoolArray, label_x: Callable[[int | None], Hashable]) -> WorstCase:
        """P: (..., nA, nU) numerators per leading index; valid: (..., nA, nA) pairs to consider."""
        vals, k, order = threshold_max_many(P[..., :, None, :], P[..., None, :, :], lower, gamma)
        vals = np.where(valid, vals, -np.inf)
        if not valid.any():
            return WorstCase(
                kind,
                math.nan,
                math.nan,
                None,
                None,
                None,
                None,
                None,
                None,
                "threshold",
                "trivial",
                "threshold",
                "no two groups can be compared",
                0,
            )
        if not binding and method != "lp":
            idx = np.unravel_index(int(vals.argmax()), vals.shape)
            top = order[idx][: int(k[idx])]
            h = np.full(nU, lower)
            h[top] = gamma
            ratio = float(vals[idx])
            x = int(idx[0]) if kind == "local" else None
            return WorstCase(
                kind,
                _log(ratio),
                ratio,
                label_x(x),
                law.groups[idx[-2]],
                law.groups[idx[-1]],
                None,
                util(h),
                None,
                "threshold",
                "unbounded" if math.isinf(ratio) else "optimal",
                "threshold",
                "a decision is possible for one group and impossible for another" if math.isinf(ratio) else "",
                0,
            )
        flat = np.argwhere(valid)
        upper = vals[tuple(flat.T)]
        if tau is not None and tau > 0:
            upper = np.minimum(upper, gamma / tau)

        def solve(i: int) -> FractionalResult:
            *lead, a, b = flat[i]
            return program().solve(P[tuple(lead) + (a,)], P[tuple(lead) + (b,)])

        found = _search(upper, solve)
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
        x = lead[0] if kind == "local" else None
        return WorstCase(
            kind,
            _log(r.value),
            r.value,
            label_x(x),
            law.groups[a],
            law.groups[b],
            None,
            util(r.argmax) if r.argmax is not None else None,
            None,
            "lp" if found.solved else "threshold",
            r.status,
            r.solver_status,
            r.reason,
            found.solved,
        )

    valid_local = cell[:, :, None] & cell[:, None, :] & ~np.eye(nA, dtype=bool)[None]
    local = case("local", Qz, valid_local, lambda x: None if x is None else law.contexts[x])
    pu = np.nan_to_num(group_decision_law(law, population), nan=0.0)
    has = population.p_group > 0
    valid_global = has[:, None] & has[None, :] & ~np.eye(nA, dtype=bool)
    global_ = case("global", pu, valid_global, lambda x: None)
    return WorstUtility(local, global_, law, lower, gamma, tau, population, excluded)
