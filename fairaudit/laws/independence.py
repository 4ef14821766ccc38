"""X ⊥ A exactly, and the factor by which a population within rounding of it departs: what L̄ ≤ L costs there.

A population given as P(x)·P(a) in floating point is independent only within rounding: P(x | a) differs between
groups by an ulp, and a bound that uses independence (L̄ ≤ L, or a program with one weight per context) is then not
a bound for the population recorded. For any model, E[g | a] = Σ_x P(x | a) E[g | x, a], so with
r(x, a) = P(x | a)/P(x),

    E[g | a] / E[g | a'] ≤ (max r / min r) · (Σ_x P(x) E[g | x, a]) / (Σ_x P(x) E[g | x, a'])

and every bound derived under independence holds for the recorded population once multiplied by
F = max r / min r (its logarithm added), over the contexts with P(x) > 0 and the groups with P(a) > 0
(``proofs/black_box.md`` §6, "Independence within rounding"). F = 1 exactly when X ⊥ A exactly.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.outward import widen_up

__all__ = ["exactly_independent", "independence_factor"]


def exactly_independent(probabilities: npt.ArrayLike) -> bool:
    """Whether P(x, a) = P(x) P(a) exactly for the floats of a population table (its rank is at most 1).

    Parameters
    ----------
    probabilities : array_like, shape (n_contexts, n_groups)
        P(x, a), non-negative.

    Returns
    -------
    bool
        True when every 2 × 2 minor vanishes in exact arithmetic: P(x, a) P(r, c) = P(x, c) P(r, a) against the
        largest entry (r, c). Rounding to nearest is a function of the exact product, so a minor whose float
        products differ is non-zero; only a table whose float minors all vanish is checked in integers.

    Examples
    --------
    >>> exactly_independent([[0.125, 0.375], [0.125, 0.375]]), exactly_independent(np.outer([0.25, 0.75], [0.4, 0.6]))
    (True, False)
    """
    p = np.asarray(probabilities, dtype=float)
    r, c = np.unravel_index(int(np.argmax(p)), p.shape)
    if p[r, c] == 0:
        return True
    if not np.array_equal(p * p[r, c], np.outer(p[:, c], p[r, :])):
        return False
    exact = [[Fraction(v) for v in row] for row in p.tolist()]
    pivot = exact[r][c]
    return all(exact[x][a] * pivot == exact[x][c] * exact[r][a] for x in range(p.shape[0]) for a in range(p.shape[1]))


def independence_factor(probabilities: npt.ArrayLike) -> float:
    """F = max r / min r, r(x, a) = P(x, a)/(P(x) P(a)) over P(x) > 0 and P(a) > 0, rounded up; 1.0 when X ⊥ A.

    Parameters
    ----------
    probabilities : array_like, shape (n_contexts, n_groups)
        P(x, a), non-negative.

    Returns
    -------
    float
        An upper end of F (≥ 1): every bound derived under independence, times F, holds for the table (module
        docstring). Exactly 1.0 when :func:`exactly_independent`; +inf when a context of positive probability never
        meets a group that is present. Computed in floating point with its error bound: the marginals are sums of
        n_groups and n_contexts non-negative terms, then a product, a quotient and the ratio of two of them.

    Examples
    --------
    >>> independence_factor([[0.1, 0.3], [0.2, 0.4]])   # max r = 0.2/(0.6·0.3) = 10/9 over min r = 0.1/(0.4·0.3) = 5/6
    1.333333333333336
    >>> independence_factor(np.outer([0.25, 0.75], [0.4, 0.6])) - 1 < 1e-14
    True
    """
    p = np.asarray(probabilities, dtype=float)
    if exactly_independent(p):
        return 1.0
    p_x, p_a = p.sum(axis=1), p.sum(axis=0)
    block = p[np.ix_(p_x > 0, p_a > 0)] / np.outer(p_x[p_x > 0], p_a[p_a > 0])
    low, high = float(block.min()), float(block.max())
    if low == 0:
        return math.inf
    u = 2.0**-53
    return float(widen_up(high / low, (2 * (p.shape[0] + p.shape[1]) + 8) * u))
