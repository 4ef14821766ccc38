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
from typing import TypedDict

import numpy as np

from ._arrays import BoolArray, FloatArray, IntArray, format_label, ratio_extremes, ratio_of_extremes, safe_log
from ._errors import InputError
from ._json import Report, label, number, pair_dict
from .laws import Law, Population, population_for
from .utility import Utility

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
        (n_groups,), for global. NaN marks excluded cells.
    per_context : numpy.ndarray or None
        For local: log of the largest ratio in each context, shape (n_contexts,).
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
    expected_utility: FloatArray
    per_context: FloatArray | None
    excluded: tuple[str, ...]
    law: Law
    utility: Utility
    population: Population | None

    def __repr__(self) -> str:
        where, pair = _where_and_pair(self.context, self.group, self.other_group)
        return f"Fairness({self.kind}, value={self.value:.6g} nats, ratio={self.ratio:.6g}{where}, groups {pair})"

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
# are few. Reductions along the short axes are slow in numpy when done in place, so the law is read once, in
# chunks of contexts of about _CHUNK_BYTES, each transposed to (n_decisions, n_groups, chunk): every reduction
# is then over contiguous rows. Loops run over chunks, groups or events, never over cells.

_CHUNK_BYTES = 1 << 19


def _chunks(n: int, row_bytes: int) -> Iterator[slice]:
    step = max(64, _CHUNK_BYTES // max(int(row_bytes), 1))
    for start in range(0, n, step):
        yield slice(start, min(n, start + step))


def _use_events(n_groups: int, n_decisions: int) -> bool:
    """TV by events (2^(K-1) - 1 sums per group) when cheaper than by pairs of groups."""
    events = (1 << max(n_decisions - 1, 0)) - 1
    return n_decisions <= 12 and events * n_groups <= n_groups * (n_groups - 1) // 2 * n_decisions


def _tv_chunk(ct: FloatArray, nan: bool) -> FloatArray:
    """Largest TV over pairs of groups per context of a chunk ``ct`` (n_decisions, n_groups, chunk).

    TV(P, P') = max over events S of P(S) − P'(S), so the largest TV over pairs is the largest range
    over groups of P(S); S runs over the non-empty subsets of the first K − 1 decisions (a subset and its
    complement give the same range), each built from a smaller one by adding one decision. Otherwise
    (many decisions) :func:`_max_tv`'s loop over pairs of groups. NaN where fewer than two groups are present.
    """
    K, A, C = ct.shape
    big, small = (np.fmax, np.fmin) if nan else (np.maximum, np.minimum)
    if _use_events(A, K):
        best = np.zeros(C)
        sums: dict[int, FloatArray] = {}  # bit mask m of decisions -> P(S_m), shape (n_groups, chunk)
        for m in range(1, 1 << max(K - 1, 0)):
            low = m & -m
            u = low.bit_length() - 1
            sums[m] = ct[u] if m == low else sums[m ^ low] + ct[u]
            np.maximum(best, big.reduce(sums[m], axis=0) - small.reduce(sums[m], axis=0), out=best)
        if nan:
            best[(~np.isnan(ct[0])).sum(axis=0) < 2] = np.nan
        return best
    return _max_tv(ct.transpose(2, 1, 0))[0]


@dataclass
class _Pass:
    """What one pass over the law found: E[g | x, a], extremes over groups, TV per context, P(U | a)."""

    e: FloatArray | None = None  # (n_contexts, n_groups)
    e_max: FloatArray | None = None  # (n_contexts,): max over groups of E[g | x, a], NaN ignored
    e_min: FloatArray | None = None
    top: FloatArray | None = None  # (n_contexts, n_decisions): max over groups of Q[x, a, u]
    bottom: FloatArray | None = None  # (n_contexts, n_decisions): min over groups
    tv: FloatArray | None = None  # (n_contexts,): max over pairs of TV(Q[x, a], Q[x, a'])
    group_law: FloatArray | None = None  # (n_groups, n_decisions): Σ_x w[x, a] Q[x, a, u]


def _asked(result: FloatArray | None) -> FloatArray:
    """A result of :func:`_scan` that the caller asked for, so it was computed (None only when not asked)."""
    assert result is not None, "_scan was not asked for this result"
    return result


def _scan(
    law: Law,
    utility: Utility | None = None,
    *,
    extremes: bool = False,
    tv: bool = False,
    weights: FloatArray | None = None,
) -> _Pass:
    """Read the law once, in chunks of contexts, computing only what is asked.

    ``utility`` gives E[g | x, a]; ``extremes`` the max and min over groups per (x, u); ``tv`` the largest
    TV per context; ``weights`` (n_contexts, n_groups), P(x | a), the group law Σ_x w[x, a] Q[x, a, u]. Empty cells (NaN rows) give NaN in E and are ignored by the extremes and TV.
    """
    q = law.probabilities
    X, A, K = q.shape
    nan = not law.complete
    big, small = (np.fmax, np.fmin) if nan else (np.maximum, np.minimum)
    out = _Pass()
    g: FloatArray | None = None  # g(u), shape (n_decisions,), or g[x, a, u]
    if utility is not None:
        if utility.values.ndim == 1:
            g = np.asarray(utility.table(law.contexts[:1], law.groups[:1], law.decisions)[0, 0], dtype=float)
        else:
            g = np.asarray(utility.table(law.contexts, law.groups, law.decisions), dtype=float)
        out.e, out.e_max, out.e_min = np.empty((X, A)), np.empty(X), np.empty(X)
    if extremes:
        out.top, out.bottom = np.empty((X, K)), np.empty((X, K))
    if tv:
        out.tv = np.empty(X)
    if weights is not None:
        out.group_law = np.zeros((A, K))
    for sl in _chunks(X, A * K * q.itemsize):
        ct = np.ascontiguousarray(q[sl].transpose(2, 1, 0))  # (K, A, chunk)
        if g is not None:
            assert out.e is not None and out.e_max is not None and out.e_min is not None  # allocated with g
            e = np.tensordot(g, ct, axes=1) if g.ndim == 1 else np.einsum("xau,xau->ax", q[sl], g[sl])
            out.e[sl] = e.T
            out.e_max[sl], out.e_min[sl] = big.reduce(e, axis=0), small.reduce(e, axis=0)
        if extremes:
            assert out.top is not None and out.bottom is not None
            out.top[sl] = big.reduce(ct, axis=1).T
            out.bottom[sl] = small.reduce(ct, axis=1).T
        if tv:
            assert out.tv is not None
            out.tv[sl] = _tv_chunk(ct, nan)
        if weights is not None:
            assert out.group_law is not None
            c = np.nan_to_num(ct, nan=0.0, copy=not ct.flags.writeable) if nan else ct
            out.group_law += np.einsum("uac,ca->au", c, weights[sl])
    return out


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
    return _asked(_scan(law, utility).e)


def _excluded_contexts(law: Law, population: Population | None, present: BoolArray) -> tuple[list[str], BoolArray]:
    notes = []
    keep = np.ones(len(law.contexts), dtype=bool)
    if population is not None:
        zero = population.p_context == 0
        for i in np.flatnonzero(zero):
            notes.append(f"context {format_label(law.contexts[i])!r}: P(X = x) = 0")
        keep &= ~zero
    for x, a in law.empty_cells:
        notes.append(f"cell (context {format_label(x)!r}, group {format_label(a)!r}): no records")
    few = keep & (present.sum(axis=1) < 2) if not law.complete else np.zeros(len(keep), dtype=bool)
    if len(law.groups) >= 2:
        for i in np.flatnonzero(few):
            notes.append(f"context {format_label(law.contexts[i])!r}: fewer than two groups with records")
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
    return _local(law, utility, population, _scan(law, utility))


def _present(law: Law) -> int | IntArray:
    """Groups with records per context: (n_contexts,) counts, or the number of groups when no cell is empty."""
    return len(law.groups) if law.complete else law.observed.sum(axis=1)


def _local(law: Law, utility: Utility, population: Population | None, scan: _Pass) -> Fairness:
    e = _asked(scan.e)
    notes, keep = _excluded_contexts(law, population, law.observed)
    ratio = ratio_of_extremes(_asked(scan.e_max), _asked(scan.e_min), _present(law))
    if not keep.all():
        ratio[~keep] = np.nan
    per_context = np.log(ratio, where=~np.isnan(ratio), out=np.full(ratio.shape, np.nan))

    def result(
        value: float, ratio: float, context: Hashable, group: Hashable, other: Hashable, per: FloatArray = per_context
    ) -> Fairness:
        return Fairness(
            kind="local",
            value=value,
            ratio=ratio,
            context=context,
            group=group,
            other_group=other,
            expected_utility=e,
            per_context=per,
            excluded=tuple(notes),
            law=law,
            utility=utility,
            population=population,
        )

    if len(law.groups) < 2:
        return result(0.0, 1.0, None, None, None, np.zeros(len(law.contexts)))
    if np.all(np.isnan(ratio)):
        return result(float("nan"), float("nan"), None, None, None)
    i = int(np.nanargmax(ratio))
    best = float(ratio[i])
    _, hi, lo = ratio_extremes(e[i : i + 1], axis=1)  # the pair, in the maximising context only
    return result(safe_log(best), best, law.contexts[i], law.groups[hi[0]], law.groups[lo[0]])


def _group_weights(law: Law, population: Population) -> tuple[FloatArray, list[str]]:
    """P(x | a), shape (n_contexts, n_groups), zero for groups with P(A = a) = 0; no weighted cell may be empty.

    Group averages are Σ_x P(x | a) f(x, a): with the weights made first, a fair law (f equal across groups)
    gives exactly equal averages.
    """
    w = np.nan_to_num(population.context_given_group(), nan=0.0, copy=False)
    notes = [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]
    if not law.complete:
        empty = ~law.observed & (w > 0)
        if np.any(empty):
            i, j = np.argwhere(empty)[0]
            raise InputError(
                "population",
                f"gives weight {w[i, j]:.6g} to the empty cell (context {format_label(law.contexts[i])!r}, "
                f"group {format_label(law.groups[j])!r}) of the law",
            )
    return w, notes


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
    w, notes = _group_weights(law, population)
    return _global(law, utility, population, w, notes, _asked(_scan(law, utility).e))


def _global(
    law: Law, utility: Utility, population: Population, w: FloatArray, notes: list[str], e: FloatArray
) -> Fairness:
    eg = _per_group(np.einsum("xa,xa->a", w, e if law.complete else np.nan_to_num(e, nan=0.0)), population)

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
    w, _ = _group_weights(law, population)
    return _per_group(_asked(_scan(law, weights=w).group_law), population)


def _max_tv(dist: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
    """Largest TV over pairs of rows along axis -2 of ``dist`` (..., n_groups, n_decisions).

    Loops over pairs of groups (not over cells); each step is vectorised over
    the leading axes. Returns (value, argmax-of-leading, a, a') where value has
    the leading shape.
    """
    n = dist.shape[-2]
    lead = dist.shape[:-2]
    best = np.full(lead, np.nan)
    arg_a = np.zeros(lead, dtype=int)
    arg_b = np.zeros(lead, dtype=int)
    for a in range(n):
        for b in range(a + 1, n):  # TV is symmetric: each unordered pair once, reported in label order
            tv = np.clip(dist[..., a, :] - dist[..., b, :], 0.0, None).sum(axis=-1)
            tv = np.where(np.isnan(dist[..., a, 0]) | np.isnan(dist[..., b, 0]), np.nan, tv)
            better = ~np.isnan(tv) & (np.isnan(best) | (tv > best))
            best = np.where(better, tv, best)
            arg_a = np.where(better, a, arg_a)
            arg_b = np.where(better, b, arg_b)
    return best, arg_a, arg_b


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
    value, arg_a, arg_b = _max_tv(dist)
    if np.isnan(value):
        return _total_variation("demographic_parity", float("nan"), notes, law, population)
    a, b = int(arg_a), int(arg_b)
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
    return _equalized_odds(law, population, _scan(law, tv=len(law.groups) >= 2).tv)


def _equalized_odds(law: Law, population: Population | None, per_context: FloatArray | None) -> TotalVariation:
    notes, keep = _excluded_contexts(law, population, law.observed)
    if len(law.groups) < 2:
        return _total_variation("equalized_odds", 0.0, notes, law, population)
    value = np.where(keep, _asked(per_context), np.nan)  # computed for two groups or more
    if np.all(np.isnan(value)):
        return _total_variation("equalized_odds", float("nan"), notes, law, population)
    i = int(np.nanargmax(value))
    # the value and pair in the maximising context by the pairwise definition (each unordered pair once)
    tv, a, b = _max_tv(law.probabilities[i : i + 1])
    ai, bi = int(a[0]), int(b[0])
    row_a, row_b = law.probabilities[i, ai], law.probabilities[i, bi]
    event = tuple(law.decisions[u] for u in np.flatnonzero(row_a > row_b))
    return _total_variation(
        "equalized_odds",
        float(tv[0]),
        notes,
        law,
        population,
        context=law.contexts[i],
        pair=(law.groups[ai], law.groups[bi]),
        event=event,
    )


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
    scan = _scan(law, extremes=True)
    return _sup_local(law, population, _asked(scan.top), _asked(scan.bottom))


def _sup_local(law: Law, population: Population | None, top: FloatArray, bottom: FloatArray) -> SupFairness:
    notes, keep = _excluded_contexts(law, population, law.observed)
    if len(law.groups) < 2:
        return _sup_fairness("local", 0.0, 1.0, notes, law, population)
    present = _present(law)
    ratio = ratio_of_extremes(
        top, bottom, present if isinstance(present, int) else present[:, None]
    )  # shape (n_contexts, n_decisions)
    if not keep.all():
        ratio[~keep] = np.nan
    if np.all(np.isnan(ratio)):
        return _sup_fairness("local", float("nan"), float("nan"), notes, law, population)
    i, u = np.unravel_index(int(np.nanargmax(ratio)), ratio.shape)
    best = float(ratio[i, u])
    _, hi, lo = ratio_extremes(law.probabilities[i, :, u][None, :], axis=1)
    return _sup_fairness(
        "local",
        safe_log(best),
        best,
        notes,
        law,
        population,
        context=law.contexts[i],
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
    w, notes = _group_weights(law, population)
    scan = _scan(law, utility, extremes=True, tv=len(law.groups) >= 2, weights=w)
    dist = _per_group(_asked(scan.group_law), population)
    return {
        "local": _local(law, utility, population, scan),
        "global": _global(law, utility, population, w, notes, _asked(scan.e)),
        "demographic_parity": _demographic_parity(law, population, dist),
        "equalized_odds": _equalized_odds(law, population, scan.tv),
        "sup_local": _sup_local(law, population, _asked(scan.top), _asked(scan.bottom)),
        "sup_global": _sup_global(law, population, dist),
    }
