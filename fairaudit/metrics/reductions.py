"""The reductions behind the metrics of a law, shared by L and L̄, the gaps and the sups over g.

* E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u] (:func:`expected_utility`) and P(u | a) = Σ_x P(x | a) Q[x, a, u]
  (:func:`group_decision_law`);
* per context, the extremes over groups (:func:`extremes`, :func:`law_extremes`), by chunks of contexts
  (:func:`by_chunks`);
* what is left out, and said (:func:`excluded_contexts`, :func:`group_weights`), and the cells a result names.

Each metric is whole-array numpy over the law's [x, a, u] table; loops run over decisions, groups, pairs of
groups or events, never over cells. What is computed per context (E[g | x, a], the extremes over groups, the
largest TV) is computed over chunks of contexts of about ``_CHUNK_BYTES`` (:func:`by_chunks`): no temporary grows
with the table, and each chunk is read once from memory into a transposed copy that stays in cache, over whose
contiguous rows the reductions over groups run several times faster than over the table's short group axis. A
context's numbers do not depend on the chunks. E[g | x, a] adds the terms Q[x, a, u] g(u) in the order of the
decisions, each product rounded once. The sums over contexts (E[g | a] and P(u | a)) are one ``einsum`` over
the whole arrays: the contexts added one after the other.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable

import numpy as np

from fairaudit.base.arrays import BoolArray, FloatArray, ratio_of_extremes
from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label
from fairaudit.laws.tables import Law, Population, population_for
from fairaudit.laws.utilities import Utility

__all__ = [
    # the quantities behind the metrics
    "expected_utility",
    "group_decision_law",
    # per context, by chunks of contexts
    "by_chunks",
    "extremes",
    "law_extremes",
    "transposed",
    # over contexts, per group
    "group_law",
    "per_group",
    # what is left out, and the cells a result names
    "check_law",
    "excluded_contexts",
    "group_weights",
    "where_and_pair",
    "zero_groups",
]

_CHUNK_BYTES = 1 << 19


def check_law(law: object) -> Law:
    """``law`` itself, once it is checked to be a :class:`~fairaudit.laws.tables.Law`."""
    if not isinstance(law, Law):
        raise InputError("law", "must be a Law (use compose() to turn a kernel into a law)", type(law).__name__)
    return law


def where_and_pair(context: Hashable | None, group: Hashable | None, other: Hashable | None) -> tuple[str, str]:
    """The ``, context=...`` and ``'a' vs 'b'`` parts of a result's short repr (its inputs are left out)."""
    where = f", context={format_label(context)!r}" if context is not None else ""
    pair = f"{format_label(group)!r} vs {format_label(other)!r}" if group is not None else "none"
    return where, pair


# --------------------------------------------------------------------------- per context, by chunks of contexts


def by_chunks(fn: Callable[..., FloatArray], *per_context: FloatArray) -> FloatArray:
    """``fn`` of the arrays ``per_context``, computed over chunks of contexts (axis 0) and put together."""
    n, step = len(per_context[0]), max(64, _CHUNK_BYTES // max(per_context[0][:1].nbytes, 1))
    first = fn(*(a[:step] for a in per_context))
    out = np.empty((n, *first.shape[1:]))
    out[:step] = first
    for i in range(step, n, step):
        out[i : i + step] = fn(*(a[i : i + step] for a in per_context))
    return out


def transposed(chunk: FloatArray) -> FloatArray:
    """A chunk (contexts, groups[, decisions]) as a contiguous ([decisions,] groups, contexts) copy."""
    return np.ascontiguousarray(chunk.T)


def extremes(t: FloatArray, complete: bool) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The max, the min and the ratio max / min over groups of a transposed chunk ``t`` (..., groups, contexts),
    each of shape (..., contexts); the ratio by :func:`~fairaudit.base.arrays.ratio_of_extremes`. Rows of NaN (empty
    cells) are left out."""
    present = t.shape[-2] if complete else np.count_nonzero(~np.isnan(t.reshape(-1, *t.shape[-2:])[0]), axis=0)
    top, bottom = np.fmax.reduce(t, axis=-2), np.fmin.reduce(t, axis=-2)
    return top, bottom, ratio_of_extremes(top, bottom, present)


def law_extremes(law: Law) -> FloatArray:
    """Per context, from the max and min over groups of each Q[x, ·, u]: the largest ratio max / min over u (the
    sup of L in x), the largest range over u < K − 1 (a singleton event's, so at most the largest TV over pairs
    of groups in x) and Σ_u min (the largest TV in x is at most 1 + tolerance − this): shape (n_contexts, 3)."""

    def chunk(q: FloatArray) -> FloatArray:
        top, bottom, ratio = extremes(transposed(q), law.complete)  # (n_decisions, chunk) each
        low = np.max(top[:-1] - bottom[:-1], axis=0) if len(top) > 1 else np.zeros(len(q))
        return np.stack([np.fmax.reduce(ratio, axis=0), low, np.add.reduce(bottom, axis=0)], axis=1)

    return by_chunks(chunk, law.probabilities)


# --------------------------------------------------------------------------- E[g | x, a]


def _utility_values(law: Law, utility: Utility) -> FloatArray:
    """g(u), shape (n_decisions,), or g[x, a, u] for a utility that depends on context or group (labels checked)."""
    if utility.values.ndim == 1:
        return np.asarray(utility.table((law.context_labels[0],), law.groups[:1], law.decisions)[0, 0], dtype=float)
    return np.asarray(utility.table(law.contexts, law.groups, law.decisions), dtype=float)


def _expected(q: FloatArray, g: FloatArray) -> FloatArray:
    """E of a chunk q (contexts, groups, decisions): Σ_u q[:, :, u] g[..., u] in the order of the decisions.

    ``g`` is g(u) or the chunk of g[x, a, u]. A term whose g is 0 everywhere adds nothing and is skipped.
    """
    terms = [u for u in range(q.shape[2]) if np.any(g[..., u])] or [0]  # (one kept: NaN rows stay NaN)
    e = q[:, :, terms[0]] * g[..., terms[0]]
    for u in terms[1:]:
        e += q[:, :, u] * g[..., u]
    return e


def expected_utility(law: Law, utility: Utility) -> FloatArray:
    """E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u], shape (n_contexts, n_groups).

    Empty cells of an estimated law give NaN.

    Examples
    --------
    >>> from fairaudit.laws.utilities import indicator
    >>> law = Law([[[0.2, 0.8], [0.6, 0.4]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> expected_utility(law, indicator("yes", ["yes", "no"])).tolist()
    [[0.2, 0.6]]
    """
    law = check_law(law)
    g = _utility_values(law, utility)
    if g.ndim == 1:
        return by_chunks(lambda q: _expected(q, g), law.probabilities)
    return by_chunks(_expected, law.probabilities, g)


# --------------------------------------------------------------------------- what is left out


def excluded_contexts(law: Law, population: Population | None, present: BoolArray) -> tuple[list[str], BoolArray]:
    """The notes on the contexts and cells left out of a per-context metric, and the contexts kept.

    Left out: contexts with P(X = x) = 0 (when a population is given), the empty cells of the law, and
    contexts where fewer than two groups are ``present``.
    """
    if population is None:
        notes, keep = [], np.ones(law.shape[0], dtype=bool)
    else:
        keep = population.p_context == 0
        notes = [f"context {format_label(law.context_labels[i])!r}: P(X = x) = 0" for i in np.flatnonzero(keep)]
        np.logical_not(keep, out=keep)  # in place: the contexts with P(X = x) > 0 (one new array, not three)
    notes += [f"cell (context {format_label(x)!r}, group {format_label(a)!r}): no records" for x, a in law.empty_cells]
    if len(law.groups) >= 2 and not law.complete:  # (a complete law has every group in every context)
        for i in np.flatnonzero(keep & (present.sum(axis=1) < 2)):
            notes.append(f"context {format_label(law.context_labels[i])!r}: fewer than two groups with records")
    return notes, keep


def zero_groups(law: Law, population: Population) -> list[str]:
    """The notes on the groups with P(A = a) = 0, left out of every metric over groups."""
    return [f"group {format_label(law.groups[j])!r}: P(A = a) = 0" for j in np.flatnonzero(population.p_group == 0)]


def group_weights(law: Law, population: Population) -> list[str]:
    """The notes on groups with P(A = a) = 0; raise if P(x | a) > 0 weights an empty cell (x, a) of the law.

    Group averages are Σ_x P(x | a) f(x, a) with the weights P(x | a) made first
    (:meth:`~fairaudit.laws.tables.Population.context_given_group`): a fair law (f equal across groups) gives exactly
    equal averages.
    """
    notes = zero_groups(law, population)
    if not law.complete:
        empty = ~law.observed & (population.probabilities > 0)  # P(x | a) > 0 exactly where P(x, a) > 0
        if np.any(empty):
            i, j = np.argwhere(empty)[0]
            w = population.probabilities[i, j] / population.p_group[j]  # P(x | a)
            raise InputError(
                "population",
                f"gives weight {w:.6g} to the empty cell (context {format_label(law.context_labels[i])!r}, "
                f"group {format_label(law.groups[j])!r}) of the law",
            )
    return notes


# --------------------------------------------------------------------------- over contexts, per group


def per_group(total: FloatArray, population: Population) -> FloatArray:
    """NaN in the rows (axis 0, groups) of groups with P(A = a) = 0."""
    total[population.p_group == 0] = np.nan
    return total


def group_decision_law(law: Law, population: Population | None = None) -> FloatArray:
    """P(U = u | A = a) = Σ_x P(x | a) Q[x, a, u], shape (n_groups, n_decisions).

    Rows of groups with P(A = a) = 0 are NaN.
    """
    law = check_law(law)
    population = population_for(law, population)
    group_weights(law, population)
    return group_law(law, population, population.context_given_group())


def group_law(law: Law, population: Population, w: FloatArray) -> FloatArray:
    """P(u | a) = Σ_x w[x, a] Q[x, a, u] with ``w`` = P(x | a); the empty cells (w = 0 there) read as 0, not NaN."""
    q = law.probabilities if law.complete else np.nan_to_num(law.probabilities, nan=0.0)
    return per_group(np.einsum("xa,xau->au", w, q), population)
