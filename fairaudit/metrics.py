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

from collections.abc import Hashable, Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

import numpy as np

from ._arrays import (
    ROW_TOLERANCE,
    BoolArray,
    FloatArray,
    IntArray,
    TableScan,
    first_max,
    format_label,
    group_weights,
    max_tv_pair,
    ratio_extremes,
    ratio_of_extremes,
    safe_log,
    tv_chunk,
)
from ._errors import InputError
from ._json import Report, label, number, pair_dict
from ._lazy import Deferred, LazyField
from .laws import Law, Population, population_for
from .utility import Utility

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
    # every metric in one pass
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
        (n_groups,), for global. NaN marks excluded cells. For local it is made
        when first read (a pass over the law; the same numbers).
    per_context : numpy.ndarray or None
        For local: log of the largest ratio in each context, shape (n_contexts,),
        in the law's context order, made when first read; :attr:`by_context` is the
        same with its labels.
    excluded : tuple of str
        What was left out and why.
    law, utility, population
        The inputs.
    """

    kind: str
    value: float
    ratio: float
    context: Hashable | None
    group: Hashable | None
    other_group: Hashable | None
    expected_utility: LazyField[FloatArray] = LazyField()  # (for local, made on first read)
    per_context: LazyField[FloatArray | None] = LazyField()  # (the logs are made on first read)
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
            :class:`~fairaudit.intervals.Interval` (``[lower, upper]`` in the
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


# --------------------------------------------------------------------------- one pass over the law
# A law has n_contexts rows of n_groups x n_decisions cells; contexts can number millions, groups and decisions
# are few. The law is read once, in chunks of contexts of about _CHUNK_BYTES that stay in cache; loops run over
# chunks, groups, decisions or events, never over cells. E[g | x, a] is Σ_u Q[x, a, u] g(u) with the terms added
# in the order of the decisions (each product rounded, then added): the same number for the same cell in every
# route and every chunk. Reductions over groups (max, min, sums) run on a copy of the chunk transposed to
# (n_decisions, n_groups, chunk), or of E's chunk to (n_groups, chunk): over contiguous rows.

_CHUNK_BYTES = 1 << 19


def _chunks(n: int, row_bytes: int) -> Iterator[slice]:
    step = max(64, _CHUNK_BYTES // max(int(row_bytes), 1))
    for start in range(0, n, step):
        yield slice(start, min(n, start + step))


def _asked(result: FloatArray | None) -> FloatArray:
    """A result of :func:`_scan` that the caller asked for, so it was computed (None only when not asked)."""
    assert result is not None, "_scan was not asked for this result"
    return result


def _utility_values(law: Law, utility: Utility) -> FloatArray:
    """g(u), shape (n_decisions,), or g[x, a, u] for a utility that depends on context or group (labels checked)."""
    if utility.values.ndim == 1:
        return np.asarray(utility.table((law.context_labels[0],), law.groups[:1], law.decisions)[0, 0], dtype=float)
    return np.asarray(utility.table(law.contexts, law.groups, law.decisions), dtype=float)


def _scan(
    law: Law,
    utility: Utility | None = None,
    *,
    keep_e: bool = False,
    spread: bool = False,
    population: Population | None = None,
    extremes: bool = False,
    by_group: bool = False,
) -> TableScan:
    """Read the law once, in chunks of contexts (:func:`_chunks`), computing only what is asked.

    ``utility`` gives E[g | x, a] (kept whole with ``keep_e``), ``spread`` its ratio over groups per context,
    ``population`` its group means Σ_x P(x | a) E[g | x, a]; ``extremes`` the ratios and ranges over groups
    per (x, u); ``by_group`` (with ``population``) the group law (see :class:`~fairaudit._arrays.TableScan`).
    """
    X, A, K = law.shape
    row = A * K * law.probabilities.itemsize
    scan = TableScan(
        law.probabilities,
        None if law.complete else law.observed,
        None if utility is None else _utility_values(law, utility),
        step=next(_chunks(X, row)).stop,
        population=None if population is None else (population.probabilities, population.p_group),
        keep_e=keep_e,
        spread=spread,
        extremes=extremes,
        by_group=by_group,
    )
    for sl in _chunks(X, row):
        scan.chunk(sl)
    return scan


def expected_utility(law: Law, utility: Utility) -> FloatArray:
    """E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u], shape (n_contexts, n_groups).

    Empty cells of an estimated law give NaN.

    Examples
    --------
    >>> from fairaudit.utility import indicator
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> expected_utility(law, indicator("yes", ["yes", "no"])).tolist()
    [[0.2, 0.6]]
    """
    law = _check_law(law)
    return _asked(_scan(law, utility, keep_e=True).e)


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
    >>> from fairaudit.utility import indicator
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]], [[0.5, 0.5], [0.5, 0.5]]], ["x0", "x1"], ["a", "b"], ["yes", "no"])
    >>> r = local_fairness(law, indicator("yes", ["yes", "no"]))
    >>> round(r.ratio, 12), r.context, r.group, r.other_group
    (3.0, 'x0', 'b', 'a')
    """
    law = _check_law(law)
    if population is not None:
        population = population_for(law, population)
    return _local(law, utility, population, _scan(law, utility, spread=True))


def _present(law: Law) -> int | IntArray:
    """Groups with records per context: (n_contexts,) counts, or the number of groups when no cell is empty."""
    return law.shape[1] if law.complete else law.observed.sum(axis=1)


def _local(law: Law, utility: Utility, population: Population | None, scan: TableScan) -> Fairness:
    # E (n_contexts x n_groups) made on first read unless the pass kept it: the same numbers by the same operations
    e = Deferred(expected_utility, law, utility) if scan.e is None else scan.e
    notes, keep = _excluded_contexts(law, population, law.observed)
    ratio = _asked(scan.ratio)
    if not keep.all():
        ratio[~keep] = np.nan
    i = first_max(ratio) if len(law.groups) >= 2 else None
    best = float("nan") if i is None else float(ratio[i])
    # the logs, made on first read (a million take as long as the pass): ratios are >= 1, inf or NaN, the log is
    # NaN exactly where they are
    per_context = Deferred(_log_ratios, ratio) if len(law.groups) >= 2 else np.zeros(law.shape[0])

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
    _, hi, lo = ratio_extremes(scan.expected_row(i)[None, :], axis=1)  # the pair, in the maximising context only
    return result(safe_log(best), best, law.context_labels[i], law.groups[hi[0]], law.groups[lo[0]])


def _log_ratios(ratio: FloatArray) -> FloatArray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(ratio)


def _group_weights(law: Law, population: Population) -> list[str]:
    """The notes on groups with P(A = a) = 0; raise if P(x | a) > 0 weights an empty cell (x, a) of the law.

    Group averages are Σ_x P(x | a) f(x, a) with the weights P(x | a) made first (``group_weights``): a fair
    law (f equal across groups) gives exactly equal averages.
    """
    notes = [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]
    if not law.complete:
        empty = ~law.observed & (population.probabilities > 0)  # P(x | a) > 0 exactly where P(x, a) > 0
        if np.any(empty):
            i, j = np.argwhere(empty)[0]
            w = group_weights(population.probabilities, population.p_group, slice(i, i + 1))[0, j]  # P(x | a)
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
        else uniform and independent (reported as assumed: :func:`~fairaudit.laws.default_population`).
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

    >>> from fairaudit.utility import indicator
    >>> law = Law([[[0.9, 0.1], [0.1, 0.9]], [[0.7, 0.3], [0.3, 0.7]]], [0, 1], [0, 1], [1, 0])
    >>> r = global_fairness(law, indicator(1, [1, 0]))
    >>> round(r.ratio, 12), r.group, r.other_group
    (4.0, 0, 1)
    """
    law = _check_law(law)
    population = population_for(law, population)
    notes = _group_weights(law, population)
    one = law.shape[1] < 2
    return _global(law, utility, population, notes, _scan(law, utility, keep_e=one, population=population))


def _global(law: Law, utility: Utility, population: Population, notes: list[str], scan: TableScan) -> Fairness:
    if law.shape[1] >= 2:  # Σ_x P(x | a) E[g | x, a], added context after context by the pass
        mean = _asked(scan.group_mean)
    else:  # one group: the mean as before, by einsum (a pairwise sum)
        e = _asked(scan.e)
        w = group_weights(population.probabilities, population.p_group, slice(None))  # P(x | a)
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
    return _per_group(_asked(_scan(law, population=population, by_group=True).group_law), population)


def demographic_parity(law: Law, population: Population | None = None) -> TotalVariation:
    """L_dp = max over a, a' of TV(P(U | a), P(U | a')) (paper SI B, Definition 1).

    Proof: ``proofs/lemma1_links.md`` (L_dp ≤ e^{sup L̄} − 1, tightened to (R − 1)/(R + 1)).

    A probability in [0, 1], not nats. Default population: the records' own for a law from counts,
    else uniform and independent (:func:`~fairaudit.laws.default_population`).

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
    X, A, K = law.shape
    bounds = A >= 2 and next(_chunks(X, A * K * law.probabilities.itemsize)).stop < X  # (one chunk: no bound)
    return _equalized_odds(law, population, _scan(law, extremes=bounds))


def _equalized_odds(law: Law, population: Population | None, scan: TableScan) -> TotalVariation:
    notes, keep = _excluded_contexts(law, population, law.observed)
    if len(law.groups) < 2:
        return _total_variation("equalized_odds", 0.0, notes, law, population)
    valid = keep if law.complete else keep & (_present(law) >= 2)  # the contexts where TV is defined
    if not valid.any():
        return _total_variation("equalized_odds", float("nan"), notes, law, population)
    i = _tv_argmax(law, valid, scan)
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


def _tv_argmax(law: Law, valid: BoolArray, scan: TableScan) -> int:
    """The first context among ``valid`` with the largest TV over pairs of groups, per :func:`~fairaudit._arrays.tv_chunk`.

    Only the contexts that can reach the largest are computed. In context x, the range over groups of
    Q[x, a, u] (u < K − 1, a singleton event of :func:`~fairaudit._arrays.tv_chunk`) is at most its TV (``scan.tv_low``), and
    TV(Q[x, a], Q[x, b]) = Σ_u Q[x, a, u] − Σ_u min(Q[x, a, u], Q[x, b, u]) is at most 1 + tolerance −
    Σ_u min over groups of Q[x, a, u] (rows are checked to sum to 1 within the tolerance). A context whose
    upper bound is below the best lower bound (less a margin for rounding and for the pairwise route's
    asymmetry) cannot be the first maximum; every other one is computed exactly as before, so the value
    and the tie-breaking are unchanged.
    """
    q = law.probabilities
    X, A, K = q.shape
    if next(_chunks(X, A * K * q.itemsize)).stop == X:  # one chunk: every context, no bound needed
        rows = np.flatnonzero(valid)
    else:
        threshold = scan.low_max(valid) - 4 * ROW_TOLERANCE  # (only the chunks that can hold a candidate are read)
        slack = 8 * K * float(np.finfo(float).eps)
        rows = scan.candidates(valid, (1.0 + ROW_TOLERANCE) * (1.0 + slack) + slack, threshold)
    tv = np.empty(len(rows))
    for sl in _chunks(len(rows), A * K * q.itemsize):
        tv[sl] = tv_chunk(np.ascontiguousarray(q[rows[sl]].transpose(2, 1, 0)), not law.complete)
    return int(rows[np.nanargmax(tv)])


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
    return _sup_local(law, population, _scan(law, extremes=True))


def _sup_local(law: Law, population: Population | None, scan: TableScan) -> SupFairness:
    notes, keep = _excluded_contexts(law, population, law.observed)
    if len(law.groups) < 2:
        return _sup_fairness("local", 0.0, 1.0, notes, law, population)
    # the first (x, u) in table order with the largest max_a Q[x, a, u] / min_a Q[x, a, u], NaN ignored:
    # the pass gives each context's largest ratio; the first decision attaining it, in the context found
    ratio = _asked(scan.sup_ratio)
    if not keep.all():
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

    Default population: :func:`~fairaudit.laws.default_population` (the records' own for a law from counts).
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
    """Every exact metric of ``law`` in one pass over it: L, L̄, L_dp, L_eo and the sups over g.

    The same numbers as :func:`local_fairness`, :func:`global_fairness`, :func:`demographic_parity`,
    :func:`equalized_odds`, :func:`sup_local_fairness` and :func:`sup_global_fairness` called one by one
    (they share the code), with the law read once instead of five times: for a law of a million contexts
    this is most of the cost.

    Parameters
    ----------
    law : Law
        P(U | X, A), shape (n_contexts, n_groups, n_decisions), indexed [x, a, u].
    utility : Utility
        g(u) or g[x, a, u] with the law's labels.
    population : Population, optional
        P(X, A), shape (n_contexts, n_groups); default the records' own for a law from counts, else
        uniform and independent (:func:`~fairaudit.laws.default_population`).

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
    >>> from fairaudit.utility import indicator
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> m = all_metrics(law, indicator("yes", ["yes", "no"]))
    >>> round(m["local"].ratio, 12), round(m["demographic_parity"].value, 12), round(m["sup_local"].ratio, 12)
    (3.0, 0.4, 3.0)
    """
    law = _check_law(law)
    population = population_for(law, population)
    notes = _group_weights(law, population)
    one = law.shape[1] < 2  # (E for the mean of one group)
    scan = _scan(law, utility, keep_e=one, spread=True, population=population, extremes=True, by_group=True)
    dist = _per_group(_asked(scan.group_law), population)
    local, odds = _local(law, utility, population, scan), _equalized_odds(law, population, scan)
    sup_local = _sup_local(law, population, scan)
    return {
        "local": local,
        "global": _global(law, utility, population, notes, scan),
        "demographic_parity": _demographic_parity(law, population, dist),
        "equalized_odds": odds,
        "sup_local": sup_local,
        "sup_global": _sup_global(law, population, dist),
    }
