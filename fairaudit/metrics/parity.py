"""The total-variation gaps of a law P(U | X, A): demographic parity and equalized odds (paper SI B).

* **Demographic parity gap** L_dp = max over a, a' of TV(P(U | a), P(U | a')).
* **Equalized-odds gap** L_eo = max over x, a, a' of TV(P(U | x, a), P(U | x, a')).

Both are probabilities in [0, 1], not nats. Contexts with P(X = x) = 0, and empty cells of an estimated law,
are excluded and listed in ``excluded``, never silently. The largest TV per context comes from
:mod:`fairaudit.metrics.total_variation`, computed only in the contexts that can reach the largest.

Proof: ``proofs/lemma1_links.md`` (the links theorem: L_dp ≤ e^{sup L̄} − 1, L_eo ≤ e^{sup L} − 1).
"""

from __future__ import annotations

import functools
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from fairaudit.base.arrays import ROW_TOLERANCE, BoolArray, FloatArray, first_max
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.laws.tables import Law, Population, population_for
from fairaudit.metrics.reductions import (
    by_chunks,
    check_law,
    excluded_contexts,
    group_decision_law,
    law_extremes,
    transposed,
    where_and_pair,
    zero_groups,
)
from fairaudit.metrics.total_variation import max_tv_pair, tv_chunk

__all__ = [
    # the result
    "TotalVariation",
    # the gaps
    "demographic_parity",
    "equalized_odds",
    # the gaps from the arrays that all_metrics shares
    "demographic_parity_of",
    "equalized_odds_of",
]


@dataclass(frozen=True, eq=False, kw_only=True)
class TotalVariation:
    """A total-variation fairness gap (demographic parity or equalized odds).

    Attributes
    ----------
    kind : {"demographic_parity", "equalized_odds"}
    value : float
        The largest total-variation distance, in [0, 1] (a probability, not nats).
    context : hashable or None
        The maximising context (equalized odds only).
    group, other_group : hashable
        The maximising pair; ``group`` puts more mass on ``event``.
    event : tuple
        The decisions S with P(S | group) − P(S | other_group) = value.
    law, population
        The inputs.
    """

    kind: str
    value: float
    context: Hashable | None = None
    group: Hashable | None = None
    other_group: Hashable | None = None
    event: tuple = ()
    excluded: tuple[str, ...]
    law: Law
    population: Population | None

    def __repr__(self) -> str:
        where, pair = where_and_pair(self.context, self.group, self.other_group)
        event = tuple(format_label(u) for u in self.event)
        return f"TotalVariation({self.kind}, value={self.value:.6g}{where}, groups {pair}, event={event!r})"

    def to_dict(self) -> Report:
        """The report dictionary: value, context, the pair of groups and the event."""
        return {
            "value": number(self.value),
            "context": label(self.context),
            "group": label(self.group),
            "other_group": label(self.other_group),
            "event": [label(u) for u in self.event],
        }


def demographic_parity(law: Law, population: Population | None = None) -> TotalVariation:
    """L_dp = max over a, a' of TV(P(U | a), P(U | a')) (paper SI B, Definition 1).

    Proof: ``proofs/lemma1_links.md`` (L_dp ≤ e^{sup L̄} − 1, tightened to (R − 1)/(R + 1)).

    A probability in [0, 1], not nats. Default population: the records' own for a law from counts,
    else uniform and independent (:func:`~fairaudit.laws.tables.default_population`).

    Examples
    --------
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> r = demographic_parity(law)
    >>> round(r.value, 12), r.group, r.other_group, r.event
    (0.4, 'a', 'b', ('no',))
    """
    law = check_law(law)
    population = population_for(law, population)
    return demographic_parity_of(law, population, group_decision_law(law, population))


def demographic_parity_of(law: Law, population: Population, dist: FloatArray) -> TotalVariation:
    """:func:`demographic_parity` of a checked law and population, from ``dist`` = P(u | a), (n_groups, n_decisions)."""
    notes = zero_groups(law, population)
    result = functools.partial(
        TotalVariation, kind="demographic_parity", excluded=tuple(notes), law=law, population=population
    )
    if len(law.groups) < 2:
        return result(value=0.0)
    value, a, b = max_tv_pair(dist)
    if a is None or b is None:
        return result(value=float("nan"))
    event = tuple(law.decisions[u] for u in np.flatnonzero(dist[a] > dist[b]))
    return result(value=float(value), group=law.groups[a], other_group=law.groups[b], event=event)


def equalized_odds(law: Law, population: Population | None = None) -> TotalVariation:
    """L_eo = max over x, a, a' of TV(P(U | x, a), P(U | x, a')) (paper SI B, Definition 2).

    Proof: ``proofs/lemma1_links.md`` (L_eo ≤ e^{sup L} − 1, tightened to (R − 1)/(R + 1)).

    With X the true label this is the equalized-odds difference of a
    classifier. Empty cells and contexts with P(X = x) = 0 are excluded.

    Examples
    --------
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]], [[0.5, 0.5], [0.0, 1.0]]], ["y0", "y1"], ["a", "b"], ["yes", "no"])
    >>> r = equalized_odds(law)
    >>> round(r.value, 12), r.context, r.group, r.other_group
    (0.5, 'y1', 'a', 'b')
    """
    law = check_law(law)
    if population is not None:
        population = population_for(law, population)
    return equalized_odds_of(law, population, law_extremes(law))


def equalized_odds_of(law: Law, population: Population | None, extremes: FloatArray) -> TotalVariation:
    """:func:`equalized_odds` of a checked law and population, from its
    :func:`~fairaudit.metrics.reductions.law_extremes`."""
    notes, keep = excluded_contexts(law, population, law.observed)
    result = functools.partial(
        TotalVariation, kind="equalized_odds", excluded=tuple(notes), law=law, population=population
    )
    if len(law.groups) < 2:
        return result(value=0.0)
    valid = keep & (law.observed.sum(axis=1) >= 2)  # the contexts where TV is defined
    if not valid.any():
        return result(value=float("nan"))
    i = _tv_argmax(law, valid, extremes)
    # the pair in the maximising context, in linear time; its value by the pairwise definition
    tv, ai, bi = max_tv_pair(law.probabilities[i])
    assert ai is not None and bi is not None  # (a valid context has two groups)
    row_a, row_b = law.probabilities[i, ai], law.probabilities[i, bi]
    event = tuple(law.decisions[u] for u in np.flatnonzero(row_a > row_b))
    return result(
        value=tv, context=law.context_labels[i], group=law.groups[ai], other_group=law.groups[bi], event=event
    )


def _tv_argmax(law: Law, valid: BoolArray, extremes: FloatArray) -> int:
    """The first context among ``valid`` with the largest TV over pairs of groups, per :func:`~fairaudit.metrics.total_variation.tv_chunk`.

    It is computed only in the contexts that can reach the largest. In context x the largest TV is at least the
    range over groups of Q[x, a, u] for u < K − 1 (``extremes[:, 1]``, a singleton event), and
    TV(Q[x, a], Q[x, b]) = Σ_u Q[x, a, u] − Σ_u min(Q[x, a, u], Q[x, b, u]) is at most 1 + tolerance − Σ_u min
    over groups of Q[x, a, u] (``extremes[:, 2]``; rows are checked to sum to 1 within the tolerance). A context
    whose upper bound is below the best lower bound (less a margin for rounding and for the pairwise route's
    asymmetry) cannot be the first maximum; every other one is computed, so the value and the tie-breaking are
    those of every context computed.
    """
    threshold = np.max(extremes[valid, 1]) - 4 * ROW_TOLERANCE
    slack = 8 * law.shape[2] * float(np.finfo(float).eps)
    candidates = valid & ((1.0 + ROW_TOLERANCE) * (1.0 + slack) + slack - extremes[:, 2] >= threshold)

    def chunk(q: FloatArray, where: BoolArray) -> FloatArray:
        tv = np.full(len(q), np.nan)
        if where.any():
            tv[where] = tv_chunk(transposed(q[where]), not law.complete)
        return tv

    i = first_max(by_chunks(chunk, law.probabilities, candidates))
    assert i is not None  # (the context of the best lower bound is a candidate)
    return i
