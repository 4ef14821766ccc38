"""Demographic parity and equalized odds of the utility g: differences of E[g] between groups.

The gaps of :mod:`fairaudit.metrics.parity` (``demographic_parity``,
``equalized_odds``) are total-variation distances between groups'
distributions of the whole outcome U. Users of fairlearn mean something
else by the same names: the difference of selection rates between groups,
``demographic_parity_difference`` (pooled) and ``equalized_odds_difference``
(within each value of the true label, the larger of the two). For a 0/1
utility g those are the gaps of E[g] computed here, with the context in the
true label's place; for another bounded g they are the same differences of
expected utilities. ``fairaudit audit --gap-on g`` reports them beside the
distribution gaps, each labelled.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from fairaudit.base.arrays import FloatArray, first_max
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.metrics.fairness import Fairness

__all__ = ["UtilityGap", "UtilityGaps", "utility_gaps"]


@dataclass(frozen=True)
class UtilityGap:
    """The largest difference of E[g] between two groups (in the context ``context`` for equalized odds).

    Attributes
    ----------
    kind : {"demographic_parity", "equalized_odds"}
    value : float
        max E[g | a] − min E[g | a] (pooled over contexts, under the audit's
        population), or its largest value within one context (E[g | x, a]);
        in g's units (a probability for a 0/1 g). NaN when no two groups compare.
    context : hashable or None
        The maximising context (equalized odds only).
    group, other_group : hashable or None
        The groups with the largest and the smallest E[g] there.
    utility : str
        g's name.
    """

    kind: str
    value: float
    context: Hashable | None
    group: Hashable | None
    other_group: Hashable | None
    utility: str

    def to_dict(self) -> Report:
        """``value``, ``context`` (equalized odds), ``group``, ``other_group``."""
        out: Report = {"value": number(self.value)}
        if self.kind == "equalized_odds":
            out["context"] = label(self.context)
        out.update(group=label(self.group), other_group=label(self.other_group))
        return out

    def __str__(self) -> str:
        where = f" in context {format_label(self.context)}" if self.context is not None else ""
        return f"{self.value:.6g} ({format_label(self.group)} vs {format_label(self.other_group)}{where})"


@dataclass(frozen=True)
class UtilityGaps:
    """Both gaps of E[g]: :attr:`demographic_parity` (pooled) and :attr:`equalized_odds` (within contexts)."""

    demographic_parity: UtilityGap
    equalized_odds: UtilityGap

    def to_dict(self) -> Report:
        """The ``gaps_on_g`` object of ``fairaudit audit --gap-on g``'s JSON."""
        return {
            "utility": self.demographic_parity.utility,
            "demographic_parity": self.demographic_parity.to_dict(),
            "equalized_odds": self.equalized_odds.to_dict(),
        }


def utility_gaps(local: Fairness, global_: Fairness) -> UtilityGaps:
    """The gaps of E[g] from the local and global g-fairness results of one law (their ``expected_utility``).

    Parameters
    ----------
    local : Fairness
        Local g-fairness: E[g | x, a], shape (n_contexts, n_groups), NaN for left-out cells.
    global_ : Fairness
        Global g-fairness: E[g | a], shape (n_groups,), under its population.

    Returns
    -------
    UtilityGaps

    Examples
    --------
    >>> import pandas as pd, fairaudit as fa
    >>> df = pd.DataFrame({"g": list("aaaabbbb"), "y": [1, 1, 1, 0, 1, 0, 0, 0], "x": list("pqpqpqpq")})
    >>> r = fa.audit(df, sensitive=["g"], outcome="y", context=["x"])
    >>> gaps = utility_gaps(r.observed.local_fairness, r.observed.global_fairness)
    >>> gaps.demographic_parity.value, str(gaps.equalized_odds)
    (0.5, '0.5 (a vs b in context p)')
    """
    name = local.utility.name
    pooled = np.asarray(global_.expected_utility, dtype=float)
    groups = local.law.groups
    dp = _range(pooled[None, :], groups, (None,), "demographic_parity", name)
    contexts = local.law.contexts
    eo = _range(np.asarray(local.expected_utility, dtype=float), groups, tuple(contexts), "equalized_odds", name)
    return UtilityGaps(dp, eo)


def _range(e: FloatArray, groups: tuple, contexts: tuple, kind: str, name: str) -> UtilityGap:
    """The largest max − min over groups of the rows of ``e`` (contexts × groups), NaN ignored, the first one kept."""
    present = (~np.isnan(e)).sum(axis=1) >= 2
    with np.errstate(invalid="ignore"):
        spread = np.where(present, np.nanmax(np.where(np.isnan(e), -np.inf, e), axis=1), np.nan)
        spread = spread - np.where(present, np.nanmin(np.where(np.isnan(e), np.inf, e), axis=1), np.nan)
    i = first_max(spread)
    if i is None:
        return UtilityGap(kind, float("nan"), None, None, None, name)
    hi, lo = int(np.nanargmax(e[i])), int(np.nanargmin(e[i]))
    return UtilityGap(kind, float(spread[i]), contexts[i], groups[hi], groups[lo], name)
