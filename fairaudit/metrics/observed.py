"""Every exact metric of one law: :class:`Observed` and :func:`observe`.

Shared by :mod:`fairaudit.certification.certificate` (which re-exports both: they are its public
API), :mod:`fairaudit.statistics.record_audit` and the plug-in estimates of
:mod:`fairaudit.statistics.intervals`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

from fairaudit.base.json_values import Report, number
from fairaudit.laws.tables import Law, Population
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.fairness import Fairness, all_metrics
from fairaudit.metrics.parity import TotalVariation
from fairaudit.metrics.sup_fairness import SupFairness

__all__ = ["Observed", "observe"]


class MetricIntervals(Protocol):
    """What :meth:`Observed.to_dict` reads of a :class:`~fairaudit.statistics.intervals.FairnessIntervals`."""

    @property
    def local_fairness(self) -> Iterable[float]: ...  # (lower, upper) of L

    @property
    def global_fairness(self) -> Iterable[float]: ...  # (lower, upper) of L-bar

    def to_dict(self) -> Report: ...


@dataclass(frozen=True, eq=False, kw_only=True)
class Observed:
    """Every exact metric of one law, each named as the function of :mod:`fairaudit.metrics` that computes it.

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
        others: dict[str, TotalVariation | SupFairness] = {
            "demographic_parity": self.demographic_parity,
            "equalized_odds": self.equalized_odds,
            "sup_local": self.sup_local_fairness,
            "sup_global": self.sup_global_fairness,
        }
        out: Report = {
            "local": self.local_fairness.to_dict(None if intervals is None else intervals.local_fairness),
            "global": self.global_fairness.to_dict(None if intervals is None else intervals.global_fairness),
            **{name: number(metric.value) for name, metric in others.items()},
            "details": {name: metric.to_dict() for name, metric in others.items()},
            "excluded": list(dict.fromkeys(self.local_fairness.excluded + self.global_fairness.excluded)),
        }
        if intervals is not None:
            out["intervals"] = intervals.to_dict()
        return out


def observe(law: Law, utility: Utility, population: Population | None) -> Observed:
    """All exact metrics of ``law`` for ``utility`` under ``population`` (:func:`~fairaudit.metrics.fairness.all_metrics`)."""
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
