"""The hypotheses of the main theorem and its corollary, and how each stands on the data given.

:class:`Assumption` is one hypothesis with its status (checked, violated, vouched, assumed, not applicable);
:func:`check_assumptions` checks the main theorem's on the mechanism, utility, population and law given
(``proofs/main_theorem.md``, the hypotheses (A1)–(A6)). Every :class:`~fairaudit.metrics.bounds.Bound` and
black-box certificate carries them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Law, Population
from fairaudit.laws.utilities import Utility, UtilityClass

__all__ = [
    "Assumption",
    "assumptions_for",
    "check_assumptions",
]


@dataclass(frozen=True)
class Assumption:
    """One hypothesis of a theorem and how it stands.

    Attributes
    ----------
    name : str
        The hypothesis, for example ``"X independent of A"``.
    status : {"checked", "violated", "vouched", "assumed", "not applicable"}
        ``checked``: verified on the data given; ``violated``: the data
        contradict it (the bound does not apply); ``vouched``: taken on the
        caller's word; ``assumed``: holds by a default nobody stated (X ⊥ A
        of the uniform population used when none is given); ``not
        applicable``: not needed here.
    detail : str
        The numbers behind the status.
    scope : {"all", "global"}
        ``"global"``: needed only for the bound on L̄ (X ⊥ A), so a violation
        does not void the bound on L.
    """

    name: str
    status: str
    detail: str = ""
    scope: str = "all"

    def __post_init__(self) -> None:
        if self.status not in {"checked", "violated", "vouched", "assumed", "not applicable"}:
            raise InputError(
                "assumption status", "must be checked, violated, vouched, assumed or not applicable", self.status
            )


def check_assumptions(
    mechanism: Mechanism,
    *,
    utility_class: UtilityClass | None = None,
    utility: Utility | None = None,
    population: Population | None = None,
    law: Law | None = None,
) -> tuple[Assumption, ...]:
    """The main theorem's hypotheses, each checked on the data given or vouched for.

    Proof: ``proofs/main_theorem.md`` (the hypotheses (A1)–(A6)).

    Parameters
    ----------
    mechanism : Mechanism
        M_A; its (ε, δ) profile is always computed exactly ("checked").
    utility_class : UtilityClass, optional
        The constants claimed, ``tau`` and ``gamma`` (the others are not
        checked here); a field None when the bound does not use it.
    utility : Utility, optional
        Checks g ≤ γ and g ≥ 0.
    population : Population, optional
        Checks X ⊥ A (tolerance 1e-9).
    law : Law, optional
        The observed law behind the filter: checks E[g | x, a] ≥ τ on it (this
        law only, not every model; the bound for *any* model still relies on
        the caller's τ).

    Returns
    -------
    tuple of Assumption

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> from fairaudit.laws.utilities import UtilityClass
    >>> m = randomized_response(["a", "b"], keep=0.7)
    >>> [a.status for a in check_assumptions(m, utility_class=UtilityClass(gamma=1.0, tau=0.2))]
    ['checked', 'vouched', 'vouched', 'vouched']
    """
    c = UtilityClass() if utility_class is None else utility_class
    return assumptions_for(mechanism, c.tau, c.gamma, utility, population, law)


def assumptions_for(
    mechanism: Mechanism,
    tau: float | None,
    gamma: float | None,
    utility: Utility | None,
    population: Population | None,
    law: Law | None,
) -> tuple[Assumption, ...]:
    """:func:`check_assumptions` of the constants τ and γ themselves (None: a constant the bound does not use)."""
    # (:.6g writes an infinite epsilon as "inf")
    profile = f"exact privacy profile of {mechanism.name}; pure epsilon = {mechanism.epsilon:.6g} nats"
    out = [Assumption("M_A is differentially private", "checked", profile)]
    if population is None:
        out.append(Assumption("X independent of A", "vouched", "no population given; needed for L-bar only", "global"))
    else:
        ind = population.independence()
        where = f"at (context {format_label(ind.context)!r}, group {format_label(ind.group)!r})"
        if not ind.independent:
            status, detail = "violated", f"max |P(x,a) - P(x)P(a)| = {ind.max_deviation:.3g} {where}"
        elif population.source == "assumed":
            status, detail = "assumed", "the population is " + population.describe()
        else:
            status, detail = "checked", f"max |P(x,a) - P(x)P(a)| = {ind.max_deviation:.3g} {where}"
        source = "" if population.source == "assumed" else f" in {population.describe()}"
        out.append(Assumption("X independent of A", status, f"{detail}{source}; needed for L-bar only", "global"))
    if gamma is not None:
        if utility is None:
            out.append(Assumption("g <= gamma", "vouched", f"gamma = {gamma:g}; no utility table given"))
        else:
            status = "checked" if utility.gamma <= gamma + 1e-12 else "violated"
            out.append(Assumption("g <= gamma", status, f"max g = {utility.gamma:g}, gamma = {gamma:g}"))
    if tau is not None:
        if law is None or utility is None:
            out.append(Assumption("E[g | x, a] >= tau for every model", "vouched", f"tau = {tau:g}"))
        else:
            from fairaudit.metrics.reductions import expected_utility

            e = expected_utility(law, utility)
            low = float(np.nanmin(e)) if np.any(~np.isnan(e)) else math.nan
            status = "vouched" if low >= tau - 1e-12 else "violated"
            detail = f"tau = {tau:g}; the observed model has min E[g | x, a] = {low:.6g}"
            out.append(Assumption("E[g | x, a] >= tau for every model", status, detail))
    return tuple(out)
