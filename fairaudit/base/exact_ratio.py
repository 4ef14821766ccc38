"""Exact maxima of ratios over polytopes with rational data: max (p·h)/(q·h) over a polytope or a product of
polytopes, every number exact, by Dinkelbach's method over :class:`~fairaudit.base.exact_lp.ExactProgram` (HiGHS's
basis, solved and finished exactly). What the certifier's exact proofs are solved with: the Lipschitz class's in
:mod:`fairaudit.worstcase.lipschitz_proofs` and the known-utility programs on exact coefficients. The same method over
float data, with its outward rounding, is :class:`~fairaudit.base.linear_fractional.FractionalProgram`; proofs:
``proofs/linear_fractional.md`` §6 and ``proofs/exact_lp.md``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fairaudit.base.exact_lp import ExactProgram

__all__ = ["Polytope", "RatioOptimum", "dot", "maximize_ratio_over_product"]


def dot(a: Sequence[Fraction], b: Sequence[Fraction]) -> Fraction:
    """The exact dot product of two sequences of rationals (the zero terms skipped).

    Examples
    --------
    >>> dot([Fraction(1, 2), 0], [Fraction(2, 3), 5])
    Fraction(1, 3)
    """
    return sum((x * y for x, y in zip(a, b, strict=True) if x and y), Fraction(0))


@dataclass(frozen=True)
class RatioOptimum:
    """The outcome of :func:`maximize_ratio_over_product` (and :meth:`Polytope.maximize_ratio`), every number exact.

    Attributes
    ----------
    status : {"optimal", "infeasible", "zero_denominator"}
        "infeasible" when a polytope is empty; "zero_denominator" when the ratio has no finite maximum over the points
        with q·h > 0: q·h < 0 somewhere, q·h = 0 everywhere, or q·h = 0 < p·h somewhere (unbounded near it).
    value : Fraction or None
        max (p·h)/(q·h), exactly; None unless optimal.
    point : tuple of Fraction or None
        When optimal, a vertex h with q·h > 0 and (p·h)/(q·h) = value; for "zero_denominator", a vertex with q·h < 0,
        or with q·h = 0 < p·h, or, where q·h = 0 everywhere, one maximising p·h; None when infeasible.
    multipliers : tuple of Fraction or None
        When optimal, the last step's duals on the rows of A_ub, y ≥ 0 (over a product, the blocks' rows one after
        the other), from its exact basis: max over the box of (p − value·q − yᵀA_ub)·h, plus y·b_ub, is 0, which
        proves p·h ≤ value·q·h on the polytope; None unless optimal.
    """

    status: str
    value: Fraction | None
    point: tuple[Fraction, ...] | None
    multipliers: tuple[Fraction, ...] | None = None


class Polytope:
    """The polytope {lower ≤ h ≤ upper, A_ub h ≤ b_ub} with rational data (floats at their binary value), for exact
    maxima of ratios over it: each linear program an :class:`~fairaudit.base.exact_lp.ExactProgram` (HiGHS's basis,
    solved and finished exactly), warm-started from the basis the last one ended at.

    Parameters
    ----------
    lower, upper : sequences of Fraction or int, length n
        The box, finite, lower ≤ upper.
    A_ub : sequence of m rows of length n (m ≥ 0)
    b_ub : sequence of length m
    n : int
        The number of variables (≥ 1).

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> box = Polytope([0, 0], [1, 1], [[-1, -1]], [F(-1, 2)], 2)
    >>> box.feasible, box.maximize_ratio([F(7, 10), F(3, 10)], [F(3, 10), F(7, 10)]).value
    (True, Fraction(7, 3))
    """

    def __init__(
        self,
        lower: Sequence[Fraction | int],
        upper: Sequence[Fraction | int],
        A_ub: Sequence[Sequence[Fraction | int]],
        b_ub: Sequence[Fraction | int],
        n: int,
    ) -> None:
        matrix = [list(row) for row in A_ub] if len(A_ub) else np.zeros((0, n))
        self.n = n
        self._program = ExactProgram(matrix, [-math.inf] * len(b_ub), list(b_ub), list(lower), list(upper))

    @functools.cached_property
    def feasible(self) -> bool:
        """False when the polytope is empty (proved exactly)."""
        return self._program.minimize([0] * self.n).status == "optimal"

    def maximize(self, cost: Sequence[Fraction | int]) -> tuple[Fraction, tuple[Fraction, ...], tuple[Fraction, ...]]:
        """max c·h over the (feasible) polytope, exactly: the maximum, a vertex attaining it, and its row duals y ≥ 0."""
        found = self._program.minimize([-c for c in cost])
        assert found.value is not None and found.point is not None and found.duals is not None  # (a bounded polytope)
        return -found.value, found.point, tuple(-y for y in found.duals)

    def maximize_ratio(
        self, p: Sequence[Fraction | int], q: Sequence[Fraction | int], *, start: Fraction | None = None
    ) -> RatioOptimum:
        """Exact max (p·h)/(q·h) over the polytope's points with q·h > 0, as :func:`maximize_ratio_over_product`."""
        return maximize_ratio_over_product([self], [p], [q], start=start)


def maximize_ratio_over_product(
    polytopes: Sequence[Polytope],
    p: Sequence[Sequence[Fraction | int]],
    q: Sequence[Sequence[Fraction | int]],
    *,
    start: Fraction | None = None,
) -> RatioOptimum:
    """Exact max (Σ_i p_i·h_i)/(Σ_i q_i·h_i) over the product of polytopes, h_i in the i-th, by Dinkelbach's method.

    The ratio must have a finite maximum: q·h ≥ 0 on the product, q·h > 0 somewhere and no h with q·h = 0 < p·h
    (points with p·h = q·h = 0 are left out: 0/0 is not a ratio); otherwise the status is "zero_denominator". Without
    ``start``, min q·h (< 0: "zero_denominator") and max q·h (= 0: "zero_denominator") come first and λ₀ is the ratio
    at the maximiser of q·h; with it, λ₀ is the ratio at the maximiser of (p − start·q)·h where q·h > 0 there (a guess
    near the maximum: one step or two). Each step maximises Σ_i (p_i − λ_k q_i)·h_i block by block (a sum over
    separate blocks is maximised by each block's maximum), exactly, at a vertex h_k. When that maximum is 0, λ_k,
    attained, is the maximum; when it is positive and q·h_k = 0, the ratio is unbounded; otherwise λ_{k+1} =
    (p·h_k)/(q·h_k) > λ_k. λ rises strictly over vertices' ratios, so the steps end (Dinkelbach 1967).

    Parameters
    ----------
    polytopes : sequence of Polytope, length b ≥ 1
    p, q : sequences of b sequences of Fraction
        The numerator's and the denominator's coefficients on each block, the i-th of the i-th polytope's length.
    start : Fraction, optional
        A guess at the maximum; the answer is as exact. Where q·h < 0 somewhere but no step meets such a point, the
        status is "optimal" (the maximum over the points with q·h > 0, which the last step proves).

    Returns
    -------
    RatioOptimum
        Its point the blocks' points one after the other; "infeasible" when a block is empty.

    Examples
    --------
    Two blocks, each a box with the floor h_0 + h_1 ≥ 1/2: the second puts its utility where the denominator has
    none, and the first carries the whole denominator at its floor, (7/20 + 1)/(3/20) = 9.

    >>> from fractions import Fraction as F
    >>> one = Polytope([0, 0], [1, 1], [[-1, -1]], [F(-1, 2)], 2)
    >>> two = Polytope([0, 0], [1, 1], [[-1, -1]], [F(-1, 2)], 2)
    >>> best = maximize_ratio_over_product([one, two], [[F(7, 10), F(3, 10)], [1, 0]], [[F(3, 10), F(7, 10)], [0, 1]])
    >>> best.value, [str(h) for h in best.point], best.multipliers
    (Fraction(9, 1), ['1/2', '0', '1', '0'], (Fraction(2, 1), Fraction(0, 1)))
    """
    if not all(poly.feasible for poly in polytopes):
        return RatioOptimum("infeasible", None, None)
    numerator = [Fraction(x) for block in p for x in block]
    denominator = [Fraction(x) for block in q for x in block]
    duals: tuple[Fraction, ...] = ()

    def step(ratio: Fraction, top: int = 1) -> tuple[Fraction, tuple[Fraction, ...]]:
        """max Σ_i (top·p_i − ratio·q_i)·h_i over the product, block by block (the duals kept in ``duals``)."""
        nonlocal duals
        total, duals = Fraction(0), ()
        point: tuple[Fraction, ...] = ()
        for poly, a, b in zip(polytopes, p, q, strict=True):
            value, vertex, y = poly.maximize([top * x - ratio * z for x, z in zip(a, b, strict=True)])
            total, point, duals = total + value, point + vertex, duals + y
        return total, point

    point: tuple[Fraction, ...] | None = None  # a point attaining ``ratio`` (None: not attained yet)
    if start is not None:  # one step at the guess, whose vertex's ratio, when q·h > 0 there, starts the steps
        gap, vertex = step(Fraction(start))
        scale = dot(denominator, vertex)
        if scale < 0 or (scale == 0 and gap > 0):
            return RatioOptimum("zero_denominator", None, vertex)  # q·h < 0 here, or q·h = 0 < p·h: unbounded
        if scale > 0:
            point, ratio = vertex, dot(numerator, vertex) / scale
    if point is None:  # (no guess, or its vertex has p·h ≤ 0 = q·h: the denominator's minimum and maximum first)
        negative_min, point = step(Fraction(1), top=0)
        if negative_min > 0:
            return RatioOptimum("zero_denominator", None, point)  # q·h < 0 at this point
        largest, point = step(Fraction(-1), top=0)
        if largest == 0:  # q·h = 0 on the whole polytope: the maximiser of p·h shows whether c/0 (p·h > 0) is met
            return RatioOptimum("zero_denominator", None, step(Fraction(0))[1])
        ratio = dot(numerator, point) / largest
    while True:
        gap, vertex = step(ratio)
        if gap == 0:
            return RatioOptimum("optimal", ratio, point, duals)
        scale = dot(denominator, vertex)
        if scale == 0:
            return RatioOptimum("zero_denominator", None, vertex)  # q·h = 0 < p·h here: the ratio is unbounded
        point, ratio = vertex, dot(numerator, vertex) / scale
