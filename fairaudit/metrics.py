"""Exact fairness metrics of a law P(U | X, A): local and global g-fairness, DP and EO gaps.

Definitions (paper SI A and B; DESIGN.md):

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

from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from ._arrays import format_label, ratio_extremes, safe_log
from ._errors import InputError
from .laws import Law, Population
from .utility import Utility

__all__ = [
    "Fairness",
    "TotalVariation",
    "SupFairness",
    "expected_utility",
    "local_fairness",
    "global_fairness",
    "demographic_parity",
    "equalized_odds",
    "sup_local_fairness",
    "sup_global_fairness",
    "group_decision_law",
]


@dataclass(frozen=True, eq=False)
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
    expected_utility: np.ndarray
    per_context: np.ndarray | None
    excluded: tuple
    law: Law
    utility: Utility
    population: Population | None

    def __repr__(self) -> str:
        where = f", context={format_label(self.context)!r}" if self.context is not None else ""
        pair = f"{format_label(self.group)!r} vs {format_label(self.other_group)!r}" if self.group is not None else "none"
        return f"Fairness({self.kind}, value={self.value:.6g} nats, ratio={self.ratio:.6g}{where}, groups {pair})"


@dataclass(frozen=True, eq=False)
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
    excluded: tuple
    law: Law
    population: Population | None


@dataclass(frozen=True, eq=False)
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
    excluded: tuple
    law: Law
    population: Population | None


def _check_law(law) -> Law:
    if not isinstance(law, Law):
        raise InputError("law", "must be a Law (use compose() to turn a kernel into a law)", type(law).__name__)
    return law


def _check_population(population, law: Law) -> Population:
    if population is None:
        return Population.uniform(law.contexts, law.groups)
    if not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    if population.contexts != law.contexts:
        raise InputError("population contexts", f"must match the law's contexts {list(map(format_label, law.contexts))}",
                         list(map(format_label, population.contexts)))
    if population.groups != law.groups:
        raise InputError("population groups", f"must match the law's groups {list(map(format_label, law.groups))}",
                         list(map(format_label, population.groups)))
    return population


def expected_utility(law: Law, utility: Utility) -> np.ndarray:
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
    g = utility.table(law.contexts, law.groups, law.decisions)
    return np.einsum("xau,xau->xa", law.probabilities, g)


def _excluded_contexts(law: Law, population: Population | None, present: np.ndarray) -> tuple[list[str], np.ndarray]:
    notes = []
    keep = np.ones(len(law.contexts), dtype=bool)
    if population is not None:
        zero = population.p_context == 0
        for i in np.flatnonzero(zero):
            notes.append(f"context {format_label(law.contexts[i])!r}: P(X = x) = 0")
        keep &= ~zero
    for x, a in law.empty_cells:
        notes.append(f"cell (context {format_label(x)!r}, group {format_label(a)!r}): no records")
    few = keep & (present.sum(axis=1) < 2)
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
        population = _check_population(population, law)
    e = expected_utility(law, utility)
    present = ~np.isnan(e)
    notes, keep = _excluded_contexts(law, population, present)
    ratio, hi, lo = ratio_extremes(e, axis=1)
    ratio = np.where(keep, ratio, np.nan)
    per_context = np.log(np.where(np.isnan(ratio), np.nan, ratio), where=~np.isnan(ratio), out=np.full(ratio.shape, np.nan))
    if len(law.groups) < 2:
        return Fairness("local", 0.0, 1.0, None, None, None, e, np.zeros(len(law.contexts)), tuple(notes), law, utility, population)
    if np.all(np.isnan(ratio)):
        return Fairness("local", float("nan"), float("nan"), None, None, None, e, per_context, tuple(notes), law, utility, population)
    i = int(np.nanargmax(ratio))
    best = float(ratio[i])
    return Fairness(
        "local", safe_log(best), best, law.contexts[i], law.groups[hi[i]], law.groups[lo[i]],
        e, per_context, tuple(notes), law, utility, population,
    )


def _group_weights(law: Law, population: Population) -> tuple[np.ndarray, list[str]]:
    """P(x | a), shape (n_contexts, n_groups), checking that no weighted cell is empty."""
    w = population.context_given_group()
    notes = []
    for j in np.flatnonzero(population.p_group == 0):
        notes.append(f"group {format_label(law.groups[j])!r}: P(A = a) = 0")
    empty = ~law.observed & (np.nan_to_num(w, nan=0.0) > 0)
    if np.any(empty):
        i, j = np.argwhere(empty)[0]
        raise InputError(
            "population",
            f"gives weight {w[i, j]:.6g} to the empty cell (context {format_label(law.contexts[i])!r}, "
            f"group {format_label(law.groups[j])!r}) of the law",
        )
    return w, notes


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
        P(X, A); default uniform and independent. E[g | a] = Σ_x P(x | a) E[g | x, a].

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
    population = _check_population(population, law)
    w, notes = _group_weights(law, population)
    e = expected_utility(law, utility)
    eg = np.nansum(np.nan_to_num(w, nan=0.0) * np.nan_to_num(e, nan=0.0), axis=0)
    eg = np.where(population.p_group > 0, eg, np.nan)
    if len(law.groups) < 2:
        return Fairness("global", 0.0, 1.0, None, None, None, eg, None, tuple(notes), law, utility, population)
    ratio, hi, lo = ratio_extremes(eg[None, :], axis=1)
    best = float(ratio[0])
    if np.isnan(best):
        return Fairness("global", float("nan"), float("nan"), None, None, None, eg, None, tuple(notes), law, utility, population)
    return Fairness("global", safe_log(best), best, None, law.groups[hi[0]], law.groups[lo[0]], eg, None,
                    tuple(notes), law, utility, population)


def group_decision_law(law: Law, population: Population | None = None) -> np.ndarray:
    """P(U = u | A = a) = Σ_x P(x | a) Q[x, a, u], shape (n_groups, n_decisions).

    Rows of groups with P(A = a) = 0 are NaN.
    """
    law = _check_law(law)
    population = _check_population(population, law)
    w, _ = _group_weights(law, population)
    q = np.nan_to_num(law.probabilities, nan=0.0)
    out = np.einsum("xa,xau->au", np.nan_to_num(w, nan=0.0), q)
    out[population.p_group == 0] = np.nan
    return out


def _max_tv(dist: np.ndarray):
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

    A probability in [0, 1], not nats. Default population: uniform and independent.

    Examples
    --------
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> r = demographic_parity(law)
    >>> round(r.value, 12), r.group, r.other_group, r.event
    (0.4, 'a', 'b', ('no',))
    """
    law = _check_law(law)
    population = _check_population(population, law)
    dist = group_decision_law(law, population)
    notes = [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]
    if len(law.groups) < 2:
        return TotalVariation("demographic_parity", 0.0, None, None, None, (), tuple(notes), law, population)
    value, a, b = _max_tv(dist)
    if np.isnan(value):
        return TotalVariation("demographic_parity", float("nan"), None, None, None, (), tuple(notes), law, population)
    a, b = int(a), int(b)
    event = tuple(law.decisions[u] for u in np.flatnonzero(dist[a] > dist[b]))
    return TotalVariation("demographic_parity", float(value), None, law.groups[a], law.groups[b], event,
                          tuple(notes), law, population)


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
        population = _check_population(population, law)
    present = law.observed
    notes, keep = _excluded_contexts(law, population, present)
    if len(law.groups) < 2:
        return TotalVariation("equalized_odds", 0.0, None, None, None, (), tuple(notes), law, population)
    value, a, b = _max_tv(law.probabilities)
    value = np.where(keep, value, np.nan)
    if np.all(np.isnan(value)):
        return TotalVariation("equalized_odds", float("nan"), None, None, None, (), tuple(notes), law, population)
    i = int(np.nanargmax(value))
    ai, bi = int(a[i]), int(b[i])
    row_a, row_b = law.probabilities[i, ai], law.probabilities[i, bi]
    event = tuple(law.decisions[u] for u in np.flatnonzero(row_a > row_b))
    return TotalVariation("equalized_odds", float(value[i]), law.contexts[i], law.groups[ai], law.groups[bi], event,
                          tuple(notes), law, population)


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
        population = _check_population(population, law)
    notes, keep = _excluded_contexts(law, population, law.observed)
    if len(law.groups) < 2:
        return SupFairness("local", 0.0, 1.0, None, None, None, None, tuple(notes), law, population)
    ratio, hi, lo = ratio_extremes(law.probabilities, axis=1)  # shape (n_contexts, n_decisions)
    ratio = np.where(keep[:, None], ratio, np.nan)
    if np.all(np.isnan(ratio)):
        return SupFairness("local", float("nan"), float("nan"), None, None, None, None, tuple(notes), law, population)
    i, u = np.unravel_index(int(np.nanargmax(ratio)), ratio.shape)
    best = float(ratio[i, u])
    return SupFairness("local", safe_log(best), best, law.contexts[i], law.groups[hi[i, u]], law.groups[lo[i, u]],
                       law.decisions[u], tuple(notes), law, population)


def sup_global_fairness(law: Law, population: Population | None = None) -> SupFairness:
    """sup over g(u) ≥ 0 of L̄: log max over u, a, a' of P(u | a) / P(u | a') (Lemma 1).

    Proof: ``proofs/lemma1_links.md`` (Lemma 1).

    Default population: uniform and independent.
    """
    law = _check_law(law)
    population = _check_population(population, law)
    dist = group_decision_law(law, population)
    notes = [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]
    if len(law.groups) < 2:
        return SupFairness("global", 0.0, 1.0, None, None, None, None, tuple(notes), law, population)
    ratio, hi, lo = ratio_extremes(dist, axis=0)  # shape (n_decisions,)
    if np.all(np.isnan(ratio)):
        return SupFairness("global", float("nan"), float("nan"), None, None, None, None, tuple(notes), law, population)
    u = int(np.nanargmax(ratio))
    best = float(ratio[u])
    return SupFairness("global", safe_log(best), best, None, law.groups[hi[u]], law.groups[lo[u]], law.decisions[u],
                       tuple(notes), law, population)
