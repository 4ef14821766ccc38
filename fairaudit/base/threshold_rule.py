"""The threshold rule: max (p·h)/(q·h) over boxes lower ≤ h ≤ upper, in closed form, vectorised.

At the optimum λ*, h maximises Σ_i (p_i − λ* q_i) h_i over the box, so h_i = upper_i where p_i / q_i > λ* and
lower_i elsewhere: a threshold in likelihood-ratio order. Sorting once and scanning the n + 1 prefixes finds it
exactly (Dinkelbach 1967; Charnes and Cooper 1962). With one more constraint q·h ≥ floor the best point is a
fractional knapsack (:func:`floor_max_many`). These are the inner loops of the worst-case searches of
:mod:`fairaudit.worstcase`: numpy arrays in, numpy arrays out, nothing validated (the callers pass 0 ≤ lower ≤ upper
and p, q ≥ 0); any other polytope is Dinkelbach's method of :class:`fairaudit.base.linear_fractional.FractionalProgram`.

Conventions as elsewhere: c/0 = +inf for c > 0, 0/0 = 1. Proofs: ``proofs/linear_fractional.md`` (the threshold
solution; the box plus one floor).
"""

from __future__ import annotations

from typing import TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.outward import down, up, widen_up

ThresholdSolution: TypeAlias = tuple[FloatArray, IntArray, IntArray]
"""What :func:`threshold_max_many` returns: (values, k, order)."""

UNIT = 2.0**-53
"""The unit roundoff u of binary64, round to nearest."""

_TINY_PRODUCT = 2.0**-1022
"""The smallest normal float: a nonzero product below it may have lost its relative accuracy (gradual underflow)."""


def sum_error(n: int) -> float:
    """γ_{n+3} = (n + 3)u / (1 − (n + 3)u), rounded up: the relative error of the threshold rule's sums over n cells.

    Each term p_i·lower_i or p_i·(upper_i − lower_i) carries at most two roundings and each sum of prefix at most
    n + 1 additions of non-negative terms (``proofs/linear_fractional.md`` §7).

    Examples
    --------
    >>> sum_error(1) > 4 * 2.0**-53
    True
    """
    k = float(n + 3) * UNIT
    if k >= 0.5:
        return float("inf")
    return float(up(up(k) / down(1.0 - k)))


__all__ = [
    "UNIT",
    "box_point",
    "floor_max_many",
    "sum_error",
    "threshold_max_many",
]


def _broadcast(
    p: npt.ArrayLike, q: npt.ArrayLike, lower: npt.ArrayLike, upper: npt.ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(p, q, lower, upper) as float arrays broadcast to one shape (..., n)."""
    p, q, lo, hi = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (p, q, lower, upper)))
    return p, q, lo, hi


def _prefix_sums(x: FloatArray, order: IntArray) -> tuple[FloatArray, FloatArray]:
    """``x`` in ``order`` along the last axis, and its n + 1 prefix sums (0 first)."""
    ordered = np.take_along_axis(x, order, -1)
    zeros = np.zeros(ordered.shape[:-1] + (1,))
    return ordered, np.concatenate([zeros, np.cumsum(ordered, -1)], -1)


def threshold_max_many(
    p: npt.ArrayLike, q: npt.ArrayLike, lower: npt.ArrayLike, upper: npt.ArrayLike
) -> ThresholdSolution:
    """The threshold solution for a batch of box programs, vectorised over leading axes.

    Proof: ``proofs/linear_fractional.md`` (the threshold solution).

    Parameters
    ----------
    p, q : numpy.ndarray, shape (..., n)
        Non-negative numerator and denominator weights (not validated: this
        is the inner loop of the worst-case searches).
    lower, upper : numpy.ndarray, broadcastable to (..., n)
        Box bounds, 0 ≤ lower ≤ upper.

    Returns
    -------
    values : numpy.ndarray, shape (...)
        The optimal ratios (c/0 = +inf, 0/0 = 1), each rounded up by the rule's error bound: ≥ the exact
        maximum and within about (2n + 10)u of it (``proofs/linear_fractional.md`` §7).
    k : numpy.ndarray of int, shape (...)
        How many cells take their upper bound at the optimum (the longest
        optimal prefix when ratios tie).
    order : numpy.ndarray of int, shape (..., n)
        Cells by decreasing likelihood ratio p/q: the optimum sets
        ``order[..., :k]`` to ``upper`` and the rest to ``lower``.

    Raises
    ------
    ValueError
        From numpy when the shapes do not broadcast. Nothing else is checked: a negative lower bound, p or q
        gives a meaningless value (``proofs/linear_fractional.md`` §3).

    Examples
    --------
    >>> v, k, order = threshold_max_many(np.array([[0.7, 0.3], [0.3, 0.7]]),
    ...                                  np.array([[0.3, 0.7], [0.7, 0.3]]), 0.5, 1.0)
    >>> v.round(12).tolist(), k.tolist(), order[:, 0].tolist()
    ([1.307692307692, 1.307692307692], [1, 1], [0, 1])
    >>> bool(np.all(v >= 17 / 13))                                  # (0.5·0.3 + 0.7) / (0.5·0.7 + 0.3), upward
    True
    """
    p, q, lo, hi = _broadcast(p, q, lower, upper)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r = np.where(q > 0, p / np.where(q > 0, q, 1.0), np.where(p > 0, np.inf, 0.0))
    order = np.argsort(-r, axis=-1, kind="stable")
    span = hi - lo
    # the programs where some product underflowed (proofs/linear_fractional.md §7)
    under = np.zeros(p.shape[:-1], dtype=bool)
    num = _terms(p, lo, span, order, under)
    den = _terms(q, lo, span, order, under)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        values = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 1.0))
    best = values.max(axis=-1)
    # Among optimal prefixes (ties in the ratio, up to rounding) take the longest: the same value with h as high as
    # possible, which helps every extra constraint E ≥ τ of the callers' relaxations.
    tied = values >= (best * (1 - 1e-12))[..., None]
    k = values.shape[-1] - 1 - np.argmax(tied[..., ::-1], axis=-1)
    del values, tied
    certified = _certified_max(num, den, under)
    # p = q: every ratio is exactly 1 (0/0 = 1 too), with no rounding to bound (randomized response at ε = 0)
    return np.where(np.all(p == q, axis=-1), 1.0, certified)[()], k, order


def _terms(
    w: FloatArray, lo: FloatArray, span: FloatArray, order: IntArray, under: npt.NDArray[np.bool_]
) -> FloatArray:
    """w·h at the n + 1 prefixes of ``order``, computed; marks in ``under`` the programs where a product underflowed."""
    base = w * lo
    under |= np.any((base > 0) & (base < _TINY_PRODUCT), axis=-1)
    total = base.sum(-1, keepdims=True)
    del base
    raised = w * span
    under |= np.any((raised > 0) & (raised < _TINY_PRODUCT), axis=-1)
    return total + _prefix_sums(raised, order)[1]


def _certified_max(num: FloatArray, den: FloatArray, under: npt.NDArray[np.bool_]) -> FloatArray:
    """max over prefixes of the exact ratio, bounded above (proofs/linear_fractional.md §7), shape (...).

    Per prefix: its numerator rounded up and denominator down by γ_{n+3} (and by an absolute 2n·2^-1074 where a
    product underflowed), their quotient rounded up; then the largest, widened by 3u for near-ties that the sort of
    the floating-point ratios may have ordered wrongly. ``num`` and ``den`` are overwritten.
    """
    n = num.shape[-1] - 1
    g = sum_error(n)
    absolute = np.where(under, 2.0 * n * 2.0**-1074, 0.0)[..., None]
    exact_zero = (absolute == 0) & (den == 0)  # no underflow: den is 0 exactly when its float is
    zero_inf = np.any(exact_zero & (num > 0), axis=-1)  # c/0 = +inf, decided exactly
    zero_one = np.any(exact_zero & (num == 0), axis=-1)  # 0/0 = 1, exactly
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        np.multiply(num, up(1.0 + g), out=num)
        np.nextafter(num, np.inf, out=num)
        np.add(num, absolute, out=num)
        np.nextafter(num, np.inf, out=num)
        np.multiply(den, down(1.0 - g), out=den)
        np.nextafter(den, -np.inf, out=den)
        np.subtract(den, absolute, out=den)
        np.nextafter(den, -np.inf, out=den)
        bad = den <= 0
        den[bad] = 1.0
        np.divide(num, den, out=num)
        np.nextafter(num, np.inf, out=num)
        num[bad] = -np.inf
    largest = num.max(axis=-1)
    with np.errstate(invalid="ignore"):
        finite = np.where(np.isneginf(largest), -np.inf, widen_up(largest, 3 * UNIT))
    infinite = zero_inf | np.any(bad & ~exact_zero, axis=-1)  # (a denominator bound ≤ 0 after underflow: +inf)
    out = np.where(infinite, np.inf, np.where(zero_one, np.maximum(finite, 1.0), finite))  # conventions not widened
    return np.asarray(out, dtype=float)[()]


def floor_max_many(
    p: npt.ArrayLike,
    q: npt.ArrayLike,
    lower: npt.ArrayLike,
    upper: npt.ArrayLike,
    floor: float,
    threshold: ThresholdSolution | None = None,
) -> tuple[FloatArray, IntArray, FloatArray, IntArray]:
    """Box programs with one more constraint, q·h ≥ floor, solved in closed form, vectorised.

    max (p·h)/(q·h) over lower ≤ h ≤ upper with q·h ≥ floor > 0. Let h* be the
    threshold solution without the floor. If q·h* ≥ floor it is optimal.
    Otherwise the ratio, a quasi-concave function of D = q·h (the best
    numerator N(D) is concave in D), is largest at D = floor, where the best
    numerator is the fractional knapsack: raise cells to ``upper`` in
    decreasing order of p/q until q·h = floor, the last one partly.
    ``proofs/linear_fractional.md`` (the box plus one floor). This is the relaxation
    of the τ-constrained programs that keeps only the denominator group's
    constraint: an upper bound, and the optimum whenever its point meets the
    other constraints.

    Parameters
    ----------
    p, q : numpy.ndarray, shape (..., n)
        Non-negative weights.
    lower, upper : numpy.ndarray, broadcastable to (..., n)
        0 ≤ lower ≤ upper.
    floor : float
        > 0.
    threshold : tuple, optional
        The result of :func:`threshold_max_many` on the same arrays, when the
        caller has it already (saves recomputing it).

    Returns
    -------
    values : numpy.ndarray, shape (...)
        Optimal ratios (NaN where q·upper < floor: infeasible), rounded up by the rule's error bound: ≥ the exact
        maximum and within about (4n + 24)u of it (``proofs/linear_fractional.md`` §7).
    k : numpy.ndarray of int, shape (...)
        Cells at ``upper`` (the first k in ``order``).
    frac : numpy.ndarray, shape (...)
        Fraction of the span of cell ``order[k]`` that is raised (0 when none).
    order : numpy.ndarray of int, shape (..., n)

    Raises
    ------
    ValueError
        From numpy when the shapes do not broadcast; the inputs are not
        otherwise validated (the inner loop of the worst-case searches).

    Examples
    --------
    >>> v, k, frac, order = floor_max_many(np.array([0.7, 0.3]), np.array([0.3, 0.7]), 0.0, 1.0, 0.5)
    >>> round(float(v), 12), int(k), round(float(frac), 12)      # h = (1, 2/7): (0.7 + 0.6/7) / 0.5 = 11/7
    (1.571428571429, 1, 0.285714285714)
    >>> bool(v >= 11 / 7)
    True
    """
    p, q, lo, hi = _broadcast(p, q, lower, upper)
    shape = p.shape
    values, k, order = threshold_max_many(p, q, lo, hi) if threshold is None else threshold
    span = hi - lo
    ps, cp = _prefix_sums(p * span, order)
    qs, cq = _prefix_sums(q * span, order)
    d0 = (q * lo).sum(-1)
    n0 = (p * lo).sum(-1)
    # q·h at the shortest optimal prefix: the threshold's k is the longest prefix tied to 1e-12, whose q·h may meet
    # the floor where the maximiser's does not (a value 1e-12 relative above the optimum with the floor)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        num, den = n0[..., None] + cp, d0[..., None] + cq
        ratios = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 1.0))
    shortest = np.argmax(ratios, axis=-1)
    del num, den, ratios
    d_star = d0 + np.take_along_axis(cq, shortest[..., None], -1)[..., 0]
    g = sum_error(shape[-1])
    # low only where the unconstrained optimum's q·h is surely below the floor (else its value, an upper bound)
    low = (up(d_star * up(1.0 + g)) < floor) & ~np.all(p == q, axis=-1)  # (p = q: every ratio is exactly 1)
    need = floor - d0
    j = np.clip((cq >= need[..., None] - 1e-15 * floor).argmax(-1) - 1, 0, shape[-1] - 1)
    qj, pj, cqj, cpj = (np.take_along_axis(v, j[..., None], -1)[..., 0] for v in (qs, ps, cq, cp))
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.clip(np.where(qj > 0, (need - cqj) / np.where(qj > 0, qj, 1.0), 0.0), 0.0, 1.0)
    # the relative error bound of the knapsack value at the floor (proofs/linear_fractional.md §7)
    filled = widen_up((n0 + cpj + frac * pj) / floor, float(up(4.0 * g + 12.0 * UNIT + 2e-15)))
    feasible = d0 + cq[..., -1] >= floor * (1 - 1e-12)
    values = np.where(low, np.where(feasible, filled, np.nan), values)
    k_out = np.where(low, j, k)
    frac_out = np.where(low, frac, 0.0)
    return values, k_out, frac_out, order


def box_point(lower: npt.ArrayLike, upper: npt.ArrayLike, order: IntArray, k: int, frac: float = 0.0) -> FloatArray:
    """The point of a threshold or floor solution: ``upper`` on ``order[:k]``, partly raised ``order[k]``.

    Parameters
    ----------
    lower, upper : array_like, broadcastable to (n,)
    order : numpy.ndarray of int, shape (n,)
    k : int
    frac : float
        Fraction of cell ``order[k]``'s span that is raised.

    Returns
    -------
    numpy.ndarray, shape (n,)

    Raises
    ------
    IndexError
        When ``order`` holds an index outside [0, n).

    Examples
    --------
    >>> box_point(0.0, 1.0, np.array([1, 0, 2]), 1, 0.25).tolist()    # cell 1 up, cell 0 a quarter up
    [0.25, 1.0, 0.0]
    """
    lo, hi = (np.broadcast_to(np.asarray(v, dtype=float), order.shape) for v in (lower, upper))
    h = lo.copy()
    h[order[:k]] = hi[order[:k]]
    if frac > 0 and k < len(order):
        o = order[k]
        h[o] = lo[o] + frac * (hi[o] - lo[o])
    return h
