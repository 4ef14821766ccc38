"""The sups over g of local and global g-fairness of a law P(U | X, A) (paper SI B, Lemma 1).

* sup over g(u) ≥ 0 of L is log max over x, u, a, a' of Q[x, a, u] / Q[x, a', u];
* sup over g(u) ≥ 0 of L̄ is log max over u, a, a' of P(u | a) / P(u | a').

Values are in nats; a ratio 0/0 counts as 1 (parity) and c/0 with c > 0 as +inf. Per context the largest
ratio is max_a Q / min_a Q (:func:`~fairaudit.metrics.reductions.law_extremes`), so no pair of groups is
enumerated.

Proof: ``proofs/lemma1_links.md`` (Lemma 1).
"""

from __future__ import annotations

import functools
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from fairaudit.base.arrays import FloatArray, first_max, ratio_extremes, ratio_of_extremes, safe_log
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.laws.tables import Law, Population, population_for
from fairaudit.metrics.reductions import (
    check_law,
    excluded_contexts,
    group_decision_law,
    law_extremes,
    where_and_pair,
    zero_groups,
)

__all__ = [
    # the result
    "SupFairness",
    # the sups over g
    "sup_global_fairness",
    "sup_local_fairness",
    # the sups from the arrays that all_metrics shares
    "sup_global_of",
    "sup_local_of",
]


@dataclass(frozen=True, eq=False, kw_only=True)
class SupFairness:
    """The supremum of L (or L̄) over every utility g(u) ≥ 0 (paper SI B, Lemma 1).

    Attributes
    ----------
    kind : {"local", "global"}
    value : float
        log of the largest likelihood ratio, in nats (+inf when a decision has
        positive probability for one group and zero for another).
    ratio : float
        exp(value).
    context : hashable or None
        Maximising context (local only).
    group, other_group : hashable
        The pair with P(u | group) / P(u | other_group) = ratio.
    decision : hashable
        The decision u attaining the ratio; g = 1{u = decision} + η, η ↓ 0,
        approaches the supremum.
    """

    kind: str
    value: float
    ratio: float
    context: Hashable | None = None
    group: Hashable | None = None
    other_group: Hashable | None = None
    decision: Hashable | None = None
    excluded: tuple[str, ...]
    law: Law
    population: Population | None

    def __repr__(self) -> str:
        where, pair = where_and_pair(self.context, self.group, self.other_group)
        decision = format_label(self.decision) if self.decision is not None else None
        return (
            f"SupFairness({self.kind}, value={self.value:.6g} nats, ratio={self.ratio:.6g}{where}, groups {pair}, "
            f"decision={decision!r})"
        )

    def to_dict(self) -> Report:
        """The report dictionary: value, ratio, context, the pair of groups and the decision."""
        return {
            "value": number(self.value),
            "ratio": number(self.ratio),
            "context": label(self.context),
            "group": label(self.group),
            "other_group": label(self.other_group),
            "decision": label(self.decision),
        }


def sup_local_fairness(law: Law, population: Population | None = None) -> SupFairness:
    """sup over g(u) ≥ 0 of L: log max over x, u, a, a' of Q[x, a, u] / Q[x, a', u] (Lemma 1).

    Proof: ``proofs/lemma1_links.md`` (Lemma 1).

    A g that may depend on the group without a Lipschitz bound makes the sup
    +inf trivially; this is the sup over utilities of the decision alone, the
    "differential fairness" of Foulds et al. (2020) per context.

    Examples
    --------
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> r = sup_local_fairness(law)
    >>> round(r.ratio, 12), r.group, r.other_group, r.decision
    (3.0, 'b', 'a', 'yes')
    """
    law = check_law(law)
    if population is not None:
        population = population_for(law, population)
    return sup_local_of(law, population, law_extremes(law))


def sup_local_of(law: Law, population: Population | None, extremes: FloatArray) -> SupFairness:
    """:func:`sup_local_fairness` of a checked law and population, from its
    :func:`~fairaudit.metrics.reductions.law_extremes`."""
    notes, keep = excluded_contexts(law, population, law.observed)
    result = functools.partial(SupFairness, kind="local", excluded=tuple(notes), law=law, population=population)
    if len(law.groups) < 2:
        return result(value=0.0, ratio=1.0)
    # the first (x, u) in table order with the largest max_a Q[x, a, u] / min_a Q[x, a, u], NaN ignored:
    # each context's largest ratio, then the first decision attaining it in the context found
    ratio = extremes[:, 0].copy()
    ratio[~keep] = np.nan
    i = first_max(ratio)
    if i is None:
        return result(value=float("nan"), ratio=float("nan"))
    row = law.probabilities[i]  # (n_groups, n_decisions)
    big, small = (np.maximum, np.minimum) if law.complete else (np.fmax, np.fmin)
    present = law.shape[1] if law.complete else int(law.observed[i].sum())
    u = first_max(ratio_of_extremes(big.reduce(row, axis=0), small.reduce(row, axis=0), present))
    assert u is not None
    best = float(ratio[i])
    _, hi, lo = ratio_extremes(law.probabilities[i, :, u][None, :], axis=1)
    return result(
        value=safe_log(best),
        ratio=best,
        context=law.context_labels[i],
        group=law.groups[hi[0]],
        other_group=law.groups[lo[0]],
        decision=law.decisions[u],
    )


def sup_global_fairness(law: Law, population: Population | None = None) -> SupFairness:
    """sup over g(u) ≥ 0 of L̄: log max over u, a, a' of P(u | a) / P(u | a') (Lemma 1).

    Proof: ``proofs/lemma1_links.md`` (Lemma 1).

    Default population: :func:`~fairaudit.laws.tables.default_population` (the records' own for a law from counts).
    """
    law = check_law(law)
    population = population_for(law, population)
    return sup_global_of(law, population, group_decision_law(law, population))


def sup_global_of(law: Law, population: Population, dist: FloatArray) -> SupFairness:
    """:func:`sup_global_fairness` of a checked law and population, from ``dist`` = P(u | a), (n_groups, n_decisions)."""
    notes = zero_groups(law, population)
    result = functools.partial(SupFairness, kind="global", excluded=tuple(notes), law=law, population=population)
    if len(law.groups) < 2:
        return result(value=0.0, ratio=1.0)
    ratio, hi, lo = ratio_extremes(dist, axis=0)  # shape (n_decisions,)
    if np.all(np.isnan(ratio)):
        return result(value=float("nan"), ratio=float("nan"))
    u = int(np.nanargmax(ratio))
    best = float(ratio[u])
    return result(
        value=safe_log(best),
        ratio=best,
        group=law.groups[hi[u]],
        other_group=law.groups[lo[u]],
        decision=law.decisions[u],
    )
