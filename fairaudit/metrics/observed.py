"""Every exact metric of one law: :func:`all_metrics` (one pass over the table), :class:`Observed` and :func:`observe`.

Shared by :mod:`fairaudit.certification.certificate` (which re-exports both: they are its public
API), :mod:`fairaudit.statistics.record_audit` and the plug-in estimates of
:mod:`fairaudit.statistics.intervals`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol, TypedDict

from fairaudit.base.json_values import Report, number
from fairaudit.laws.tables import Law, Population, population_for
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.fairness import (
    Fairness,
    SupFairness,
    _check_law,
    _expected_utility,
    _global,
    _group_law,
    _group_weights,
    _law_extremes,
    _local,
    _sup_global,
    _sup_local,
)
from fairaudit.metrics.parity import TotalVariation, _demographic_parity, _equalized_odds

__all__ = ["AllMetrics", "Observed", "all_metrics", "observe"]


class MetricIntervals(Protocol):
    """What :meth:`Observed.to_dict` reads of a :class:`~fairaudit.statistics.intervals.FairnessIntervals`."""

    @property
    def local_fairness(self) -> Iterable[float]: ...  # (lower, upper) of L

    @property
    def global_fairness(self) -> Iterable[float]: ...  # (lower, upper) of L-bar

    def to_dict(self) -> Report: ...


@dataclass(frozen=True, eq=False, kw_only=True)
class Observed:
    """Every exact metric of one law, each named as the function of :mod:`fairaudit.metrics.fairness` that computes it.

    Attributes
    ----------
    law : Law
    local_fairness, global_fairness : Fairness
        L and L̄ in nats, with the maximising context and groups.
    demographic_parity, equalized_odds : TotalVariation
        L_dp and L_eo (total variation, in [0, 1]).
    sup_local_fairness, sup_global_fairness : SupFairness
        Sups over g of L and L̄ (Lemma 1), nats.
    """

    law: Law
    local_fairness: Fairness
    global_fairness: Fairness
    demographic_parity: TotalVariation
    equalized_odds: TotalVariation
    sup_local_fairness: SupFairness
    sup_global_fairness: SupFairness

    def to_dict(self, intervals: MetricIntervals | None = None) -> Report:
        """The report dictionary: each metric's value, its details, what was excluded and the intervals.

        Parameters
        ----------
        intervals : FairnessIntervals or None
            Intervals for these metrics: ``local`` and ``global`` carry theirs,
            and the whole set is under ``intervals``.
        """
        out: Report = {
            "local": self.local_fairness.to_dict(None if intervals is None else intervals.local_fairness),
            "global": self.global_fairness.to_dict(None if intervals is None else intervals.global_fairness),
            "demographic_parity": number(self.demographic_parity.value),
            "equalized_odds": number(self.equalized_odds.value),
            "sup_local": number(self.sup_local_fairness.value),
            "sup_global": number(self.sup_global_fairness.value),
            "details": {
                "demographic_parity": self.demographic_parity.to_dict(),
                "equalized_odds": self.equalized_odds.to_dict(),
                "sup_local": self.sup_local_fairness.to_dict(),
                "sup_global": self.sup_global_fairness.to_dict(),
            },
            "excluded": list(dict.fromkeys(self.local_fairness.excluded + self.global_fairness.excluded)),
        }
        if intervals is not None:
            out["intervals"] = intervals.to_dict()
        return out


def observe(law: Law, utility: Utility, population: Population | None) -> Observed:
    """All exact metrics of ``law`` for ``utility`` under ``population`` (:func:`~fairaudit.metrics.observed.all_metrics`)."""
    m = all_metrics(law, utility, population)
    return Observed(
        law=law,
        local_fairness=m["local"],
        global_fairness=m["global"],
        demographic_parity=m["demographic_parity"],
        equalized_odds=m["equalized_odds"],
        sup_local_fairness=m["sup_local"],
        sup_global_fairness=m["sup_global"],
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
