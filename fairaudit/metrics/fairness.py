"""Exact local and global g-fairness of a law P(U | X, A), and every exact metric of a law at once.

Definitions (paper SI A and B; docs/design.md):

* E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u], shape (n_contexts, n_groups).
* **Local g-fairness** L = log max over x, a, a' of E[g | x, a] / E[g | x, a'].
* **Global g-fairness** L̄ = log max over a, a' of E[g | a] / E[g | a'], with
  E[g | a] = Σ_x P(x | a) E[g | x, a].

The gaps L_dp and L_eo are in :mod:`fairaudit.metrics.parity`, the sups over g (Lemma 1) in
:mod:`fairaudit.metrics.sup_fairness`, and what they share with L and L̄ (E[g | x, a], P(u | a), the
per-context reductions) in :mod:`fairaudit.metrics.reductions`; :func:`all_metrics` computes them all,
sharing those arrays.

Conventions: values are in nats; a ratio 0/0 counts as 1 (parity) and c/0
with c > 0 as +inf. Contexts with P(X = x) = 0, and empty cells of an
estimated law, are excluded and listed in ``excluded``, never silently.

The maximisations are vectorised: per context the largest ratio is
max_a E / min_a E, so no pair of groups is enumerated.

Proofs: ``proofs/lemma1_links.md`` (Lemma 1 and the links theorem),
``proofs/main_theorem.md`` Step 4 (L̄ ≤ L under X ⊥ A).
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

import numpy as np

from fairaudit.base.arrays import FloatArray, first_max, ratio_extremes, safe_log
from fairaudit.base.json_values import Report, number, pair_dict
from fairaudit.laws.tables import Law, Population, population_for
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.parity import TotalVariation, demographic_parity_of, equalized_odds_of
from fairaudit.metrics.reductions import (
    by_chunks,
    check_law,
    excluded_contexts,
    expected_utility,
    extremes,
    group_law,
    group_weights,
    law_extremes,
    per_group,
    transposed,
    where_and_pair,
)
from fairaudit.metrics.sup_fairness import SupFairness, sup_global_of, sup_local_of

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    # results
    "AllMetrics",
    "Fairness",
    # g-fairness
    "global_fairness",
    "local_fairness",
    # every metric at once
    "all_metrics",
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
        where, pair = where_and_pair(self.context, self.group, self.other_group)
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
    law = check_law(law)
    if population is not None:
        population = population_for(law, population)
    return _local(law, utility, population, expected_utility(law, utility))


def _local(law: Law, utility: Utility, population: Population | None, e: FloatArray) -> Fairness:
    """L from E[g | x, a]: the largest ratio over groups in each context, and the first context attaining it."""
    notes, keep = excluded_contexts(law, population, law.observed)
    ratio = by_chunks(lambda e: extremes(transposed(e), law.complete)[2], e)
    ratio[~keep] = np.nan
    i = first_max(ratio) if len(law.groups) >= 2 else None
    best = float("nan") if i is None else float(ratio[i])
    # ratios are >= 1, inf or NaN: their logs are >= 0, inf or NaN
    per_context = np.log(ratio) if len(law.groups) >= 2 else np.zeros(law.shape[0])
    cells: tuple[Hashable | None, Hashable | None, Hashable | None] = (None, None, None)
    if len(law.groups) < 2:
        value, best = 0.0, 1.0
    elif i is None:
        value = float("nan")
    else:
        _, hi, lo = ratio_extremes(e[i][None, :], axis=1)  # the pair, in the maximising context
        value, cells = safe_log(best), (law.context_labels[i], law.groups[hi[0]], law.groups[lo[0]])
    return Fairness(
        kind="local",
        value=value,
        ratio=best,
        context=cells[0],
        group=cells[1],
        other_group=cells[2],
        expected_utility=e,
        per_context=per_context,
        excluded=tuple(notes),
        law=law,
        utility=utility,
        population=population,
    )


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
    law = check_law(law)
    population = population_for(law, population)
    notes = group_weights(law, population)
    e, w = expected_utility(law, utility), population.context_given_group()
    return _global(law, utility, population, notes, e, w)


def _global(
    law: Law, utility: Utility, population: Population, notes: list[str], e: FloatArray, w: FloatArray
) -> Fairness:
    """L̄ from E[g | x, a] and the weights ``w`` = P(x | a) (NaN for a group with P(a) = 0: its mean is NaN anyway)."""
    mean = np.einsum("xa,xa->a", w, e if law.complete else np.nan_to_num(e, nan=0.0))
    eg = per_group(mean, population)
    cells: tuple[None, Hashable | None, Hashable | None] = (None, None, None)
    if len(law.groups) < 2:
        value, best = 0.0, 1.0
    else:
        ratio, hi, lo = ratio_extremes(eg[None, :], axis=1)
        best = float(ratio[0])
        if np.isnan(best):
            value, best = float("nan"), float("nan")
        else:
            value, cells = safe_log(best), (None, law.groups[hi[0]], law.groups[lo[0]])
    return Fairness(
        kind="global",
        value=value,
        ratio=best,
        context=cells[0],
        group=cells[1],
        other_group=cells[2],
        expected_utility=eg,
        per_context=None,
        excluded=tuple(notes),
        law=law,
        utility=utility,
        population=population,
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

    The same numbers as :func:`local_fairness`, :func:`global_fairness`,
    :func:`~fairaudit.metrics.parity.demographic_parity`, :func:`~fairaudit.metrics.parity.equalized_odds`,
    :func:`~fairaudit.metrics.sup_fairness.sup_local_fairness` and
    :func:`~fairaudit.metrics.sup_fairness.sup_global_fairness` called one by one (they share the code), with
    E[g | x, a] and P(U | A) computed once for the metrics that share them.

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
        :class:`~fairaudit.metrics.sup_fairness.SupFairness`, values in nats) and ``"demographic_parity"``,
        ``"equalized_odds"`` (:class:`~fairaudit.metrics.parity.TotalVariation`, probabilities), each naming its
        maximising context and groups.

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
    law = check_law(law)
    population = population_for(law, population)
    notes = group_weights(law, population)
    e, w = expected_utility(law, utility), population.context_given_group()
    dist, context_extremes = group_law(law, population, w), law_extremes(law)
    return {
        "local": _local(law, utility, population, e),
        "global": _global(law, utility, population, notes, e, w),
        "demographic_parity": demographic_parity_of(law, population, dist),
        "equalized_odds": equalized_odds_of(law, population, context_extremes),
        "sup_local": sup_local_of(law, population, context_extremes),
        "sup_global": sup_global_of(law, population, dist),
    }
