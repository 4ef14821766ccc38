"""Every exact metric of one law, in one pass: :class:`Observed` and :func:`observe`.

Shared by :mod:`fairaudit.certify` (which re-exports both: they are its public
API), :mod:`fairaudit.audit` and the plug-in estimates of
:mod:`fairaudit.intervals`.
"""

from __future__ import annotations

from dataclasses import dataclass

from .laws import Law, Population
from .metrics import Fairness, SupFairness, TotalVariation, all_metrics
from .utility import Utility

__all__ = ["Observed", "observe"]


@dataclass(frozen=True, eq=False, kw_only=True)
class Observed:
    """Every exact metric of one law (see :mod:`fairaudit.metrics`)."""

    law: Law
    local: Fairness
    global_: Fairness
    demographic_parity: TotalVariation
    equalized_odds: TotalVariation
    sup_local: SupFairness
    sup_global: SupFairness


def observe(law: Law, utility: Utility, population: Population | None) -> Observed:
    """All exact metrics of ``law`` for ``utility`` under ``population`` (one pass: :func:`~fairaudit.metrics.all_metrics`)."""
    m = all_metrics(law, utility, population)
    return Observed(
        law=law,
        local=m["local"],
        global_=m["global"],
        demographic_parity=m["demographic_parity"],
        equalized_odds=m["equalized_odds"],
        sup_local=m["sup_local"],
        sup_global=m["sup_global"],
    )
