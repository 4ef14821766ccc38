"""The certified bounds' range over every utility of the unparsed reply (``proofs/unparsed.md`` §6).

The corollary's bound is ε of the filter and does not depend on the utility; the black-box bounds depend on g only
through [min g, max g] and τ, so their range over the unparsed reply's utility has closed ends: the bound as stated,
and the bound for an unparsed utility within the other outcomes' range (:func:`bound_ranges_from`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from fairaudit import Mechanism, Population, Utility, number, worst_model

__all__ = ["BoundRange", "bound_ranges", "bound_ranges_from"]


@dataclass(frozen=True, eq=False, kw_only=True)
class BoundRange:
    """A certified bound's exact range over every utility of the unparsed reply in [min g, max g] (per cell).

    Attributes
    ----------
    lower, upper : float
        The ends (nats); ``upper`` is the bound as stated, equal to ``lower`` when the bound does not depend on
        the unparsed reply's utility.
    reason : str
        Why the range is what it is, in words.
    """

    lower: float
    upper: float
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """``{"range": [lower, upper], "reason": ...}``."""
        return {"range": [number(self.lower), number(self.upper)], "reason": self.reason}


def bound_ranges(
    mechanism: Mechanism,
    utility: Utility,
    bounds: tuple[float, float],
    *,
    context_mechanism: Mechanism,
    population: Population,
    tau: float | None,
) -> dict[str, BoundRange]:
    """The corollary's and the black-box bounds' ranges over every utility of the unparsed reply (the last decision).

    The corollary is ε of ``mechanism``: no utility enters it. The black-box bounds (``bounds``: on L and L̄, as
    :func:`fairaudit.worst_model` gives them for ``utility``) are maxima over every decision model whose
    cell expectations lie in [min g, max g] (g of the decision only) with E ≥ τ, τ held as stated. With the
    unparsed utility v_c of a cell in [min g, max g], that cell's expectations span [min(g_known ∪ v_c),
    max(g_known ∪ v_c)], g_known the other outcomes' utilities: between [min g_known, max g_known] and
    [min g, max g], and the bound is non-decreasing in each cell's interval (a maximum over a larger set). So the
    upper end is the bound as stated (v at the end of [min g, max g] beyond g_known, when there is one) and the
    lower end is the bound for the utility whose unparsed value lies within g_known's range: equal ends when the
    stated unparsed value lies within it (``proofs/unparsed.md`` §6).

    Parameters
    ----------
    mechanism : Mechanism
        The filter's mechanism on a candidate (its ε is the corollary's bound, nats).
    utility : Utility
        g of the candidate's outcome, shape (n_outcomes,), the unparsed reply last, at its stated value.
    bounds : tuple of float
        The black-box bounds on L and L̄ (nats) for ``utility`` as stated.
    context_mechanism : Mechanism
        The filter on the context, as the bounds were computed with it.
    population : Population
        P(X, A) of the candidates, shape (n_contexts, n_groups).
    tau : float or None
        The floor on E[g | x, a] the bounds used (None: none).

    Returns
    -------
    dict of str to BoundRange
        ``"corollary"``, ``"black_box"`` (on L) and ``"black_box_global"`` (on L̄): each bound's range (nats).
    """

    def inside(u: Utility) -> tuple[float, float]:
        wm = worst_model(mechanism, u, context_mechanism=context_mechanism, population=population, tau=tau)
        return wm.local_fairness.value, wm.global_fairness.value

    return bound_ranges_from(mechanism.epsilon, utility, bounds, inside)


def bound_ranges_from(
    corollary: float,
    utility: Utility,
    bounds: tuple[float, float],
    inside: Callable[[Utility], tuple[float, float]],
) -> dict[str, BoundRange]:
    """:func:`bound_ranges` from the corollary's value and a function giving the black-box bounds for a utility.

    For a design whose mechanism is given by its bounds alone (the paper's design, where M_cand may be too large
    to build: :func:`fairaudit.experiments.paper_design.paper_design_bounds`).

    Parameters
    ----------
    corollary : float
        ε of the filter on a candidate (nats).
    utility : Utility
        g of the candidate's outcome, shape (n_outcomes,), the unparsed reply last, at its stated value.
    bounds : tuple of float
        The black-box bounds on L and L̄ (nats) for ``utility`` as stated.
    inside : callable
        The black-box bounds on L and L̄ (nats) for another utility over the same outcomes, with the same
        mechanisms, population and τ; called only when the stated unparsed utility lies outside the other
        outcomes' range.

    Returns
    -------
    dict of str to BoundRange
        As :func:`bound_ranges`.

    Examples
    --------
    g = 1 (chosen), 0 (not chosen) and 2 for an unparsed reply: above the others' [0, 1], so the lower ends are
    the bounds for an unparsed utility of 0 (here given by ``inside``).

    >>> from fairaudit import Utility
    >>> g = Utility([1.0, 0.0, 2.0], ["chosen", "not chosen", "unparsed"])
    >>> r = bound_ranges_from(0.5, g, (0.9, 0.7), lambda u: (0.4, 0.3))
    >>> r["corollary"].lower, r["corollary"].upper, r["black_box"].lower, r["black_box"].upper
    (0.5, 0.5, 0.4, 0.9)
    >>> r["black_box_global"].to_dict()["range"]
    [0.3, 0.7]
    """
    g = np.asarray(utility.values, dtype=float)
    known, stated = g[:-1], float(g[-1])
    k_lo, k_hi = float(known.min()), float(known.max())
    fixed = BoundRange(
        lower=corollary, upper=corollary, reason="the corollary is epsilon of the filter: no utility enters it"
    )
    head = (
        f"the black-box bounds depend on g only through [min g, max g] = [{utility.lower:g}, {utility.gamma:g}] and "
        f"tau, and the stated unparsed utility {stated:g} lies"
    )
    if (k_lo, k_hi) == (utility.lower, utility.gamma):
        why = (
            f"{head} within the other outcomes' [{k_lo:g}, {k_hi:g}], so no utility of an unparsed reply in "
            "[min g, max g] changes them: each range is one value"
        )
        low = bounds
    else:
        why = (
            f"{head} outside the other outcomes' [{k_lo:g}, {k_hi:g}]: each range runs from the bound for g in "
            f"[{k_lo:g}, {k_hi:g}] (an unparsed utility within it) to the bound as stated"
        )
        low = inside(Utility(np.append(known, k_lo), utility.decisions, name=f"{utility.name}, unparsed at {k_lo:g}"))
    return {"corollary": fixed} | {
        name: BoundRange(lower=lo, upper=up, reason=why)
        for name, lo, up in zip(("black_box", "black_box_global"), low, bounds)
    }
