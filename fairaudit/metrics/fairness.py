"""Exact fairness metrics of a law P(U | X, A): local and global g-fairness, DP and EO gaps.

Definitions (paper SI A and B; docs/design.md):

* E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u], shape (n_contexts, n_groups).
* **Local g-fairness** L = log max over x, a, a' of E[g | x, a] / E[g | x, a'].
* **Global g-fairness** L̄ = log max over a, a' of E[g | a] / E[g | a'], with
  E[g | a] = Σ_x P(x | a) E[g | x, a].
* **Demographic parity gap** L_dp = max over a, a' of TV(P(U | a), P(U | a')).
* **Equalized-odds gap** L_eo = max over x, a, a' of TV(P(U | x, a), P(U | x, a')).
* **Sup over g** (Lemma 1): sup over g(u) ≥ 0 of L is log max Q[x, a, u] / Q[x, a', u];
  of L̄, the same with P(U | a).

Conventions: values are in nats; a ratio 0/0 counts as 1 (parity) and c/0
with c > 0 as +inf. Contexts with P(X = x) = 0, and empty cells of an
estimated law, are excluded and listed in ``excluded``, never silently.

The maximisations are vectorised: per context the largest ratio is
max_a E / min_a E, so no pair of groups is enumerated.

Proofs: ``proofs/lemma1_links.md`` (Lemma 1 and the links theorem),
``proofs/main_theorem.md`` Step 4 (L̄ ≤ L under X ⊥ A).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

import numpy as np

from fairaudit.base.arrays import (
    ROW_TOLERANCE,
    BoolArray,
    FloatArray,
    first_max,
    ratio_extremes,
    ratio_of_extremes,
    safe_log,
)
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number, pair_dict
from fairaudit.base.labels import format_label
from fairaudit.laws.tables import Law, Population, population_for
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.total_variation import max_tv_pair, tv_chunk

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    # results
    "AllMetrics",
    "Fairness",
    "SupFairness",
    "TotalVariation",
    # g-fairness and its sup over g
    "global_fairness",
    "local_fairness",
    "sup_global_fairness",
    "sup_local_fairness",
    # total-variation gaps
    "demographic_parity",
    "equalized_odds",
    # every metric at once
    "all_metrics",
    # the quantities behind them
    "expected_utility",
    "group_decision_law",
]


@dataclass(frozen=True, eq=False, kw_only=True)
class Fairness:
    """Local or global g-fairness of a law, with the cells that attain it.

    Attributes
    ----------
    kind : {"local", "global"}
    value : float
        L or L̄ in nats (≥ 0; +inf when a group's expected utility is 0 and
        another's is positive; NaN when no two groups can be compared).
    ratio : float
        exp(value): the largest ratio of expected utilities.
    context : hashable or None
        The maximising context (None for global).
    group, other_group : hashable or None
        The maximising pair: ``group`` has the larger expected utility.
    expected_utility : numpy.ndarray
        E[g | x, a], shape (n_contexts, n_groups), for local; E[g | a], shape
        (n_groups,), for global. NaN marks excluded cells.
    per_context : numpy.ndarray or None
        For local: log of the largest ratio in each context, shape (n_contexts,),
        in the law's context order; :attr:`by_context` is the same with its labels.
    excluded : tuple of str
        What was left out and why.
    law, utility, population
        The inputs.

    Examples
    --------
    >>> import fairaudit as fa
    >>> law = fa.Law([[[0.5, 0.5], [0.25, 0.75]]], ["x"], ["a", "b"], [0, 1])
    >>> fa.local_fairness(law, fa.Utility([1.0, 0.0], [0, 1]))
    Fairness(local, value=0.693147 nats, ratio=2, context='x', groups 'a' vs 'b')
    """

    kind: str
    value: float
    ratio: float
    context: Hashable | None
    group: Hashable | None
    other_group: Hashable | None
    expected_utility: FloatArray
    per_context: FloatArray | None
    excluded: tuple[str, ...]
    law: Law
    utility: Utility
    population: Population | None

    def __repr__(self) -> str:
        where, pair = _where_and_pair(self.context, self.group, self.other_group)
        return f"Fairness({self.kind}, value={self.value:.6g} nats, ratio={self.ratio:.6g}{where}, groups {pair})"

    @property
    def by_context(self) -> pd.Series | None:
        """For local: L within each context (nats) as a pandas Series indexed by the context labels; None for global.

        Examples
        --------
        >>> import fairaudit as fa
        >>> law = fa.Law([[[0.5, 0.5], [0.25, 0.75]], [[0.3, 0.7], [0.3, 0.7]]], ["day", "night"], ["a", "b"], [0, 1])
        >>> fa.local_fairness(law, fa.Utility([1.0, 0.0], [0, 1])).by_context.round(6).to_dict()
        {'day': 0.693147, 'night': 0.0}
        """
        if self.per_context is None:
            return None
        import pandas as pd

        return pd.Series(
            self.per_context, index=pd.Index(list(self.law.contexts), name="context"), name="local_fairness"
        )

    def to_dict(self, interval: Iterable[float] | None = None) -> Report:
        """The report dictionary: value, ratio, (context,) the pair of groups and the interval.

        Parameters
        ----------
        interval : Interval, pair of float, or None
            A confidence interval ``(lower, upper)`` for this value, such as a
            :class:`~fairaudit.statistics.intervals.Interval` (``[lower, upper]`` in the
            dictionary), or None.

        Examples
        --------
        >>> import fairaudit as fa
        >>> law = fa.Law([[[0.5, 0.5], [0.25, 0.75]]], contexts=["x"], groups=["a", "b"], decisions=[0, 1])
        >>> fa.local_fairness(law, fa.Utility([1.0, 0.0], [0, 1])).to_dict()
        {'value': 0.6931471805599453, 'ratio': 2.0, 'context': 'x', 'group': 'a', 'other_group': 'b', 'interval': None}
        """
        d = pair_dict(self.kind, self.value, self.ratio, self.context, self.group, self.other_group)
        d["interval"] = None if interval is None else [number(end) for end in interval]
        return d


def _where_and_pair(context: Hashable | None, group: Hashable | None, other: Hashable | None) -> tuple[str, str]:
    """The ``, context=...`` and ``'a' vs 'b'`` parts of a result's short repr (its inputs are left out)."""
    where = f", context={format_label(context)!r}" if context is not None else ""
    pair = f"{format_label(group)!r} vs {format_label(other)!r}" if group is not None else "none"
    return where, pair


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
    context: Hashable | None
    group: Hashable | None
    other_group: Hashable | None
    event: tuple
    excluded: tuple[str, ...]
    law: Law
    population: Population | None

    def __repr__(self) -> str:
        where, pair = _where_and_pair(self.context, self.group, self.other_group)
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
    context: Hashable | None
    group: Hashable | None
    other_group: Hashable | None
    decision: Hashable | None
    excluded: tuple[str, ...]
    law: Law
    population: Population | None

    def __repr__(self) -> str:
        where, pair = _where_and_pair(self.context, self.group, self.other_group)
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


def _check_law(law: object) -> Law:
    if not isinstance(law, Law):
        raise InputError("law", "must be a Law (use compose() to turn a kernel into a law)", type(law).__name__)
    return law


# --------------------------------------------------------------------------- the arrays behind the metrics
# Each metric is whole-array numpy over the law's [x, a, u] table; loops run over decisions, groups, pairs of
# groups or events, never over cells. What is computed per context (E[g | x, a], the extremes over groups, the
# largest TV) is computed over chunks of contexts of about _CHUNK_BYTES (:func:`_by_chunks`): no temporary grows
# with the table, and each chunk is read once from memory into a transposed copy that stays in cache, over whose
# contiguous rows the reductions over groups run several times faster than over the table's short group axis. A
# context's numbers do not depend on the chunks. E[g | x, a] adds the terms Q[x, a, u] g(u) in the order of the
# decisions, each product rounded once. The sums over contexts (E[g | a] and P(u | a)) are one ``einsum`` over
# the whole arrays: the contexts added one after the other.

_CHUNK_BYTES = 1 << 19


def _by_chunks(fn: Callable[..., FloatArray], *per_context: FloatArray) -> FloatArray:
    """``fn`` of the arrays ``per_context``, computed over chunks of contexts (axis 0) and put together."""
    n, step = len(per_context[0]), max(64, _CHUNK_BYTES // max(per_context[0][:1].nbytes, 1))
    first = fn(*(a[:step] for a in per_context))
    out = np.empty((n, *first.shape[1:]))
    out[:step] = first
    for i in range(step, n, step):
        out[i : i + step] = fn(*(a[i : i + step] for a in per_context))
    return out


def _transposed(chunk: FloatArray) -> FloatArray:
    """A chunk (contexts, groups[, decisions]) as a contiguous ([decisions,] groups, contexts) copy."""
    return np.ascontiguousarray(chunk.T)


def _extremes(t: FloatArray, complete: bool) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The max, the min and the ratio max / min over groups of a transposed chunk ``t`` (..., groups, contexts),
    each of shape (..., contexts); the ratio by :func:`~fairaudit.base.arrays.ratio_of_extremes`. Rows of NaN (empty
    cells) are left out."""
    present = t.shape[-2] if complete else np.count_nonzero(~np.isnan(t.reshape(-1, *t.shape[-2:])[0]), axis=0)
    top, bottom = np.fmax.reduce(t, axis=-2), np.fmin.reduce(t, axis=-2)
    return top, bottom, ratio_of_extremes(top, bottom, present)


def _law_extremes(law: Law) -> FloatArray:
    """Per context, from the max and min over groups of each Q[x, ·, u]: the largest ratio max / min over u (the
    sup of L in x), the largest range over u < K − 1 (a singleton event's, so at most the largest TV over pairs
    of groups in x) and Σ_u min (the largest TV in x is at most 1 + tolerance − this): shape (n_contexts, 3)."""

    def chunk(q: FloatArray) -> FloatArray:
        top, bottom, ratio = _extremes(_transposed(q), law.complete)  # (n_decisions, chunk) each
        low = np.max(top[:-1] - bottom[:-1], axis=0) if len(top) > 1 else np.zeros(len(q))
        return np.stack([np.fmax.reduce(ratio, axis=0), low, np.add.reduce(bottom, axis=0)], axis=1)

    return _by_chunks(chunk, law.probabilities)


def _utility_values(law: Law, utility: Utility) -> FloatArray:
    """g(u), shape (n_decisions,), or g[x, a, u] for a utility that depends on context or group (labels checked)."""
    if utility.values.ndim == 1:
        return np.asarray(utility.table((law.context_labels[0],), law.groups[:1], law.decisions)[0, 0], dtype=float)
    return np.asarray(utility.table(law.contexts, law.groups, law.decisions), dtype=float)


def _expected(q: FloatArray, g: FloatArray) -> FloatArray:
    """E of a chunk q (contexts, groups, decisions): Σ_u q[:, :, u] g[..., u] in the order of the decisions.

    ``g`` is g(u) or the chunk of g[x, a, u]. A term whose g is 0 everywhere adds nothing and is skipped.
    """
    terms = [u for u in range(q.shape[2]) if np.any(g[..., u])] or [0]  # (one kept: NaN rows stay NaN)
    e = q[:, :, terms[0]] * g[..., terms[0]]
    for u in terms[1:]:
        e += q[:, :, u] * g[..., u]
    return e


def _expected_utility(law: Law, utility: Utility) -> FloatArray:
    g = _utility_values(law, utility)
    if g.ndim == 1:
        return _by_chunks(lambda q: _expected(q, g), law.probabilities)
    return _by_chunks(_expected, law.probabilities, g)


def expected_utility(law: Law, utility: Utility) -> FloatArray:
    """E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u], shape (n_contexts, n_groups).

    Empty cells of an estimated law give NaN.

    Examples
    --------
    >>> from fairaudit.laws.utilities import indicator
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> expected_utility(law, indicator("yes", ["yes", "no"])).tolist()
    [[0.2, 0.6]]
    """
    return _expected_utility(_check_law(law), utility)


def _excluded_contexts(law: Law, population: Population | None, present: BoolArray) -> tuple[list[str], BoolArray]:
    notes = []
    if population is None:
        keep = np.ones(law.shape[0], dtype=bool)
    else:
        keep = population.p_context == 0
        for i in np.flatnonzero(keep):
            notes.append(f"context {format_label(law.context_labels[i])!r}: P(X = x) = 0")
        np.logical_not(keep, out=keep)  # in place: the contexts with P(X = x) > 0 (one new array, not three)
    for x, a in law.empty_cells:
        notes.append(f"cell (context {format_label(x)!r}, group {format_label(a)!r}): no records")
    if len(law.groups) >= 2 and not law.complete:  # (a complete law has every group in every context)
        for i in np.flatnonzero(keep & (present.sum(axis=1) < 2)):
            notes.append(f"context {format_label(law.context_labels[i])!r}: fewer than two groups with records")
    return notes, keep


def local_fairness(law: Law, utility: Utility, population: Population | None = None) -> Fairness:
    """Local g-fairness L = log max over x, a, a' of E[g | x, a] / E[g | x, a'].

    Proof: ``proofs/main_theorem.md`` (what bounds it), proofs/x_privacy.md (behind M_X).

    Parameters
    ----------
    law : Law
        P(U | X, A), shape (n_contexts, n_groups, n_decisions).
    utility : Utility
        g(u) or g[x, a, u] with the law's labels.
    population : Population, optional
        Used only to exclude contexts with P(X = x) = 0.

    Returns
    -------
    Fairness
        ``value`` in nats, the maximising context and pair, and E[g | x, a].

    Raises
    ------
    InputError
        If the labels of law, utility and population do not match.

    Notes
    -----
    Paper SI A, Definition (local g-fairness), eq. (Lg).

    Examples
    --------
    >>> from fairaudit.laws.utilities import indicator
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]], [[0.5, 0.5], [0.5, 0.5]]], ["x0", "x1"], ["a", "b"], ["yes", "no"])
    >>> r = local_fairness(law, indicator("yes", ["yes", "no"]))
    >>> round(r.ratio, 12), r.context, r.group, r.other_group
    (3.0, 'x0', 'b', 'a')
    """
    law = _check_law(law)
    if population is not None:
        population = population_for(law, population)
    return _local(law, utility, population, _expected_utility(law, utility))


def _local(law: Law, utility: Utility, population: Population | None, e: FloatArray) -> Fairness:
    notes, keep = _excluded_contexts(law, population, law.observed)
    ratio = _by_chunks(lambda e: _extremes(_transposed(e), law.complete)[2], e)
    ratio[~keep] = np.nan
    i = first_max(ratio) if len(law.groups) >= 2 else None
    best = float("nan") if i is None else float(ratio[i])
    # ratios are >= 1, inf or NaN: their logs are >= 0, inf or NaN
    per_context = np.log(ratio) if len(law.groups) >= 2 else np.zeros(law.shape[0])

    def result(value: float, ratio: float, context: Hashable, group: Hashable, other: Hashable) -> Fairness:
        return Fairness(
            kind="local",
            value=value,
            ratio=ratio,
            context=context,
            group=group,
            other_group=other,
            expected_utility=e,
            per_context=per_context,
            excluded=tuple(notes),
            law=law,
            utility=utility,
            population=population,
        )

    if len(law.groups) < 2:
        return result(0.0, 1.0, None, None, None)
    if i is None:
        return result(float("nan"), float("nan"), None, None, None)
    _, hi, lo = ratio_extremes(e[i][None, :], axis=1)  # the pair, in the maximising context
    return result(safe_log(best), best, law.context_labels[i], law.groups[hi[0]], law.groups[lo[0]])


def _group_weights(law: Law, population: Population) -> list[str]:
    """The notes on groups with P(A = a) = 0; raise if P(x | a) > 0 weights an empty cell (x, a) of the law.

    Group averages are Σ_x P(x | a) f(x, a) with the weights P(x | a) made first
    (:meth:`~fairaudit.laws.tables.Population.context_given_group`): a fair law (f equal across groups) gives exactly
    equal averages.
    """
    notes = [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]
    if not law.complete:
        empty = ~law.observed & (population.probabilities > 0)  # P(x | a) > 0 exactly where P(x, a) > 0
        if np.any(empty):
            i, j = np.argwhere(empty)[0]
            w = population.probabilities[i, j] / population.p_group[j]  # P(x | a)
            raise InputError(
                "population",
                f"gives weight {w:.6g} to the empty cell (context {format_label(law.context_labels[i])!r}, "
                f"group {format_label(law.groups[j])!r}) of the law",
            )
    return notes


def _per_group(total: FloatArray, population: Population) -> FloatArray:
    """NaN in the rows (axis 0, groups) of groups with P(A = a) = 0."""
    total[population.p_group == 0] = np.nan
    return total


def global_fairness(law: Law, utility: Utility, population: Population | None = None) -> Fairness:
    """Global g-fairness L̄ = log max over a, a' of E[g | a] / E[g | a'].

    Proof: ``proofs/main_theorem.md,`` Step 4 (L̄ ≤ L under X ⊥ A, and the counterexample without it).

    Parameters
    ----------
    law : Law
        P(U | X, A), shape (n_contexts, n_groups, n_decisions).
    utility : Utility
        g(u) or g[x, a, u].
    population : Population, optional
        P(X, A); default the records' own P(x, a) = n(x, a) / n when the law comes from counts,
        else uniform and independent (reported as assumed: :func:`~fairaudit.laws.tables.default_population`).
        E[g | a] = Σ_x P(x | a) E[g | x, a].

    Returns
    -------
    Fairness
        ``kind = "global"``, ``context = None``, E[g | a] of shape (n_groups,).

    Raises
    ------
    InputError
        If the population weights an empty cell of the law, or labels differ.

    Notes
    -----
    Paper SI A, Definition (global g-fairness), eq. (barLg).

    Examples
    --------
    The paper's X-privacy example (SI C): L̄ = log 4 behind its (log 3)-DP M_X.

    >>> from fairaudit.laws.utilities import indicator
    >>> law = Law([[[0.9, 0.1], [0.1, 0.9]], [[0.7, 0.3], [0.3, 0.7]]], [0, 1], [0, 1], [1, 0])
    >>> r = global_fairness(law, indicator(1, [1, 0]))
    >>> round(r.ratio, 12), r.group, r.other_group
    (4.0, 0, 1)
    """
    law = _check_law(law)
    population = population_for(law, population)
    notes = _group_weights(law, population)
    e, w = _expected_utility(law, utility), population.context_given_group()
    return _global(law, utility, population, notes, e, w)


def _global(
    law: Law, utility: Utility, population: Population, notes: list[str], e: FloatArray, w: FloatArray
) -> Fairness:
    """L̄ from E[g | x, a] and the weights ``w`` = P(x | a) (NaN for a group with P(a) = 0: its mean is NaN anyway)."""
    mean = np.einsum("xa,xa->a", w, e if law.complete else np.nan_to_num(e, nan=0.0))
    eg = _per_group(mean, population)

    def result(value: float, ratio: float, group: Hashable, other: Hashable) -> Fairness:
        return Fairness(
            kind="global",
            value=value,
            ratio=ratio,
            context=None,
            group=group,
            other_group=other,
            expected_utility=eg,
            per_context=None,
            excluded=tuple(notes),
            law=law,
            utility=utility,
            population=population,
        )

    if len(law.groups) < 2:
        return result(0.0, 1.0, None, None)
    ratio, hi, lo = ratio_extremes(eg[None, :], axis=1)
    best = float(ratio[0])
    if np.isnan(best):
        return result(float("nan"), float("nan"), None, None)
    return result(safe_log(best), best, law.groups[hi[0]], law.groups[lo[0]])


def group_decision_law(law: Law, population: Population | None = None) -> FloatArray:
    """P(U = u | A = a) = Σ_x P(x | a) Q[x, a, u], shape (n_groups, n_decisions).

    Rows of groups with P(A = a) = 0 are NaN.
    """
    law = _check_law(law)
    population = population_for(law, population)
    _group_weights(law, population)
    return _group_law(law, population, population.context_given_group())


def _group_law(law: Law, population: Population, w: FloatArray) -> FloatArray:
    """P(u | a) = Σ_x w[x, a] Q[x, a, u] with ``w`` = P(x | a); the empty cells (w = 0 there) read as 0, not NaN."""
    q = law.probabilities if law.complete else np.nan_to_num(law.probabilities, nan=0.0)
    return _per_group(np.einsum("xa,xau->au", w, q), population)


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
    law = _check_law(law)
    population = population_for(law, population)
    return _demographic_parity(law, population, group_decision_law(law, population))


def _demographic_parity(law: Law, population: Population, dist: FloatArray) -> TotalVariation:
    notes = [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]
    if len(law.groups) < 2:
        return _total_variation("demographic_parity", 0.0, notes, law, population)
    value, a, b = max_tv_pair(dist)
    if a is None or b is None:
        return _total_variation("demographic_parity", float("nan"), notes, law, population)
    event = tuple(law.decisions[u] for u in np.flatnonzero(dist[a] > dist[b]))
    return _total_variation(
        "demographic_parity", float(value), notes, law, population, pair=(law.groups[a], law.groups[b]), event=event
    )


def _total_variation(
    kind: str,
    value: float,
    notes: list[str],
    law: Law,
    population: Population | None,
    *,
    context: Hashable | None = None,
    pair: tuple[Hashable, Hashable] | tuple[None, None] = (None, None),
    event: tuple = (),
) -> TotalVariation:
    """A :class:`TotalVariation`; without a pair, the result when no two groups can be compared."""
    return TotalVariation(
        kind=kind,
        value=value,
        context=context,
        group=pair[0],
        other_group=pair[1],
        event=event,
        excluded=tuple(notes),
        law=law,
        population=population,
    )


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
    law = _check_law(law)
    if population is not None:
        population = population_for(law, population)
    return _equalized_odds(law, population, _law_extremes(law))


def _equalized_odds(law: Law, population: Population | None, extremes: FloatArray) -> TotalVariation:
    notes, keep = _excluded_contexts(law, population, law.observed)
    if len(law.groups) < 2:
        return _total_variation("equalized_odds", 0.0, notes, law, population)
    valid = keep & (law.observed.sum(axis=1) >= 2)  # the contexts where TV is defined
    if not valid.any():
        return _total_variation("equalized_odds", float("nan"), notes, law, population)
    i = _tv_argmax(law, valid, extremes)
    # the pair in the maximising context, in linear time; its value by the pairwise definition
    tv, ai, bi = max_tv_pair(law.probabilities[i])
    assert ai is not None and bi is not None  # (a valid context has two groups)
    row_a, row_b = law.probabilities[i, ai], law.probabilities[i, bi]
    event = tuple(law.decisions[u] for u in np.flatnonzero(row_a > row_b))
    return _total_variation(
        "equalized_odds",
        tv,
        notes,
        law,
        population,
        context=law.context_labels[i],
        pair=(law.groups[ai], law.groups[bi]),
        event=event,
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
            tv[where] = tv_chunk(_transposed(q[where]), not law.complete)
        return tv

    i = first_max(_by_chunks(chunk, law.probabilities, candidates))
    assert i is not None  # (the context of the best lower bound is a candidate)
    return i


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
    law = _check_law(law)
    if population is not None:
        population = population_for(law, population)
    return _sup_local(law, population, _law_extremes(law))


def _sup_local(law: Law, population: Population | None, extremes: FloatArray) -> SupFairness:
    notes, keep = _excluded_contexts(law, population, law.observed)
    if len(law.groups) < 2:
        return _sup_fairness("local", 0.0, 1.0, notes, law, population)
    # the first (x, u) in table order with the largest max_a Q[x, a, u] / min_a Q[x, a, u], NaN ignored:
    # each context's largest ratio, then the first decision attaining it in the context found
    ratio = extremes[:, 0].copy()
    ratio[~keep] = np.nan
    i = first_max(ratio)
    if i is None:
        return _sup_fairness("local", float("nan"), float("nan"), notes, law, population)
    row = law.probabilities[i]  # (n_groups, n_decisions)
    big, small = (np.maximum, np.minimum) if law.complete else (np.fmax, np.fmin)
    present = law.shape[1] if law.complete else int(law.observed[i].sum())
    u = first_max(ratio_of_extremes(big.reduce(row, axis=0), small.reduce(row, axis=0), present))
    assert u is not None
    best = float(ratio[i])
    _, hi, lo = ratio_extremes(law.probabilities[i, :, u][None, :], axis=1)
    return _sup_fairness(
        "local",
        safe_log(best),
        best,
        notes,
        law,
        population,
        context=law.context_labels[i],
        pair=(law.groups[hi[0]], law.groups[lo[0]]),
        decision=law.decisions[u],
    )


def _sup_fairness(
    kind: str,
    value: float,
    ratio: float,
    notes: list[str],
    law: Law,
    population: Population | None,
    *,
    context: Hashable | None = None,
    pair: tuple[Hashable, Hashable] | tuple[None, None] = (None, None),
    decision: Hashable | None = None,
) -> SupFairness:
    """A :class:`SupFairness`; without a pair, the result when no two groups can be compared."""
    return SupFairness(
        kind=kind,
        value=value,
        ratio=ratio,
        context=context,
        group=pair[0],
        other_group=pair[1],
        decision=decision,
        excluded=tuple(notes),
        law=law,
        population=population,
    )


def sup_global_fairness(law: Law, population: Population | None = None) -> SupFairness:
    """sup over g(u) ≥ 0 of L̄: log max over u, a, a' of P(u | a) / P(u | a') (Lemma 1).

    Proof: ``proofs/lemma1_links.md`` (Lemma 1).

    Default population: :func:`~fairaudit.laws.tables.default_population` (the records' own for a law from counts).
    """
    law = _check_law(law)
    population = population_for(law, population)
    return _sup_global(law, population, group_decision_law(law, population))


def _sup_global(law: Law, population: Population, dist: FloatArray) -> SupFairness:
    notes = [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]
    if len(law.groups) < 2:
        return _sup_fairness("global", 0.0, 1.0, notes, law, population)
    ratio, hi, lo = ratio_extremes(dist, axis=0)  # shape (n_decisions,)
    if np.all(np.isnan(ratio)):
        return _sup_fairness("global", float("nan"), float("nan"), notes, law, population)
    u = int(np.nanargmax(ratio))
    best = float(ratio[u])
    return _sup_fairness(
        "global",
        safe_log(best),
        best,
        notes,
        law,
        population,
        pair=(law.groups[hi[u]], law.groups[lo[u]]),
        decision=law.decisions[u],
    )


AllMetrics = TypedDict(
    "AllMetrics",
    {
        "local": Fairness,
        "global": Fairness,
        "demographic_parity": TotalVariation,
        "equalized_odds": TotalVariation,
        "sup_local": SupFairness,
        "sup_global": SupFairness,
    },
)
"""What :func:`all_metrics` returns: every exact metric by name (``"global"`` is a keyword, hence this form)."""


def all_metrics(law: Law, utility: Utility, population: Population | None = None) -> AllMetrics:
    """Every exact metric of ``law``: L, L̄, L_dp, L_eo and the sups over g.

    The same numbers as :func:`local_fairness`, :func:`global_fairness`, :func:`demographic_parity`,
    :func:`equalized_odds`, :func:`sup_local_fairness` and :func:`sup_global_fairness` called one by one
    (they share the code), with E[g | x, a] and P(U | A) computed once for the metrics that share them.

    Parameters
    ----------
    law : Law
        P(U | X, A), shape (n_contexts, n_groups, n_decisions), indexed [x, a, u].
    utility : Utility
        g(u) or g[x, a, u] with the law's labels.
    population : Population, optional
        P(X, A), shape (n_contexts, n_groups); default the records' own for a law from counts, else
        uniform and independent (:func:`~fairaudit.laws.tables.default_population`).

    Returns
    -------
    dict
        Keys ``"local"``, ``"global"``, ``"sup_local"``, ``"sup_global"`` (:class:`Fairness` or
        :class:`SupFairness`, values in nats) and ``"demographic_parity"``, ``"equalized_odds"``
        (:class:`TotalVariation`, probabilities), each naming its maximising context and groups.

    Raises
    ------
    InputError
        As the six functions.

    Notes
    -----
    Definitions: paper SI A (local and global g-fairness) and SI B (L_dp, L_eo, Lemma 1 for the sups).
    L_eo per context is the largest range over groups of P(S | x, a) over events S (TV = max over S of
    P(S) − P'(S)); the reported value and pair are recomputed pairwise in the maximising context.

    Examples
    --------
    >>> from fairaudit.laws.utilities import indicator
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> m = all_metrics(law, indicator("yes", ["yes", "no"]))
    >>> round(m["local"].ratio, 12), round(m["demographic_parity"].value, 12), round(m["sup_local"].ratio, 12)
    (3.0, 0.4, 3.0)
    """
    law = _check_law(law)
    population = population_for(law, population)
    notes = _group_weights(law, population)
    e, w = _expected_utility(law, utility), population.context_given_group()
    dist, extremes = _group_law(law, population, w), _law_extremes(law)
    return {
        "local": _local(law, utility, population, e),
        "global": _global(law, utility, population, notes, e, w),
        "demographic_parity": _demographic_parity(law, population, dist),
        "equalized_odds": _equalized_odds(law, population, extremes),
        "sup_local": _sup_local(law, population, extremes),
        "sup_global": _sup_global(law, population, dist),
    }
