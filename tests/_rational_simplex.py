"""The tests' second route: exact maxima of small linear and linear-fractional programs with rational data by a
cold-start rational simplex, an algorithm independent of the package's one route (HiGHS's basis solved and finished
exactly, :mod:`fairaudit.base.exact_lp`), which the tests check the certifier's exact numbers against.

Over the polytope P = {h : lower ≤ h ≤ upper, A_ub h ≤ b_ub} (finite bounds, lower ≤ upper, rational data),
:func:`maximize_linear` gives max c·h and :func:`maximize_ratio` gives max (p·h)/(q·h) over the h of P with q·h > 0
(when q·h ≥ 0 on P and no h has q·h = 0 < p·h: the maximum is finite), both exactly, with a vertex of P attaining
them. No floating point: the data are :class:`fractions.Fraction` (or ints), the answers are fractions.

The method is the primal simplex with bounded variables over w, h = lower + (upper − lower)·w, 0 ≤ w ≤ 1, one slack
per row of A_ub (Chvátal 1983, ch. 8), in integer-pivoting form (Edmonds 1967; Bareiss 1968): every row is scaled to
integers and the tableau D·B⁻¹N of the nonbasic columns, D·(the basic values) and D·(the reduced costs) are kept in
GMP integers (gmpy2), D = det B, each pivot an exact integer division; fractions appear only in the answer, with the
rows' multipliers (an optimal dual) read off the last basis's reduced costs of the slacks. Phase 1 adds one
auxiliary column −t on the rows that h = lower (or a vertex of the box given as the start) violates and maximises −t
(Chvátal 1983, ch. 3); phase 2 starts from its basis. The entering variable is the one of largest reduced cost
(Dantzig's rule) until a step is degenerate, then the lowest-indexed improving one (Bland 1977) until a step is not;
the leaving one is the lowest-indexed among the ties of the ratio test. A run of degenerate steps is thus all
Bland's after its first and cannot cycle, every other step raises the objective, so the simplex ends. The ratio is
maximised by Dinkelbach's method (Dinkelbach 1967) on the same tableau: each step is a phase 2 from the previous
basis. A guess at the maximum (a bound from a solver's dual) may start the steps in place of the denominator's
minimum and maximum: the guess need not be right, only near, for the steps to be few.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Literal

from fairaudit.base.errors import InputError

__all__ = [
    "LinearOptimum",
    "Polytope",
    "RatioOptimum",
    "maximize_linear",
    "maximize_ratio",
    "maximize_ratio_over_product",
]

Rational = Fraction | int
"""An exact rational: a fraction or an integer (any :class:`numbers.Rational` is accepted; a float is not)."""


@dataclass(frozen=True)
class LinearOptimum:
    """The outcome of :func:`maximize_linear`.

    Attributes
    ----------
    status : {"optimal", "infeasible"}
        "infeasible" when the polytope is empty.
    value : Fraction or None
        max c·h over the polytope, exactly; None when infeasible.
    point : tuple of Fraction or None
        A vertex h of the polytope with c·h = value (length n); None when infeasible.
    multipliers : tuple of Fraction or None
        An optimal dual on the rows of A_ub, y ≥ 0 (length m), from the simplex's last basis: max over the box of
        (c − yᵀA_ub)·h, plus y·b_ub, is the value (so y proves it, by weak duality); None when infeasible.
    """

    status: Literal["optimal", "infeasible"]
    value: Fraction | None
    point: tuple[Fraction, ...] | None
    multipliers: tuple[Fraction, ...] | None = None


@dataclass(frozen=True)
class RatioOptimum:
    """The outcome of :func:`maximize_ratio`.

    Attributes
    ----------
    status : {"optimal", "infeasible", "zero_denominator"}
        "infeasible" when the polytope is empty; "zero_denominator" when the ratio has no finite maximum over the
        points with q·h > 0 as :func:`maximize_ratio` requires it: q·h < 0 somewhere, q·h = 0 everywhere, or
        q·h = 0 < p·h somewhere (the ratio is unbounded near that point).
    value : Fraction or None
        max (p·h)/(q·h) over the polytope, exactly; None unless optimal.
    point : tuple of Fraction or None
        When optimal, a vertex h with q·h > 0 and (p·h)/(q·h) = value; for "zero_denominator", a vertex with
        q·h < 0, or with q·h = 0 (everywhere, or with p·h > 0); None when infeasible.
    multipliers : tuple of Fraction or None
        When optimal, a dual of the last step on the rows of A_ub, y ≥ 0 (length m; over a product, the blocks' rows
        one after the other), from the simplex's last basis: max over the box of (p − value·q − yᵀA_ub)·h, plus
        y·b_ub, is 0, which proves p·h ≤ value·q·h on the polytope; None unless optimal.
    """

    status: Literal["optimal", "infeasible", "zero_denominator"]
    value: Fraction | None
    point: tuple[Fraction, ...] | None
    multipliers: tuple[Fraction, ...] | None = None


def _vector(name: str, values: Sequence[Rational], length: int | None = None) -> list[Fraction]:
    """``values`` as fractions, checked: a sequence of exact rationals, of ``length`` when given."""
    if isinstance(values, (str, bytes)):
        raise InputError(name, "must be a sequence of exact rationals", values)
    try:
        items = list(values)
    except TypeError:
        raise InputError(name, "must be a sequence of exact rationals", values) from None
    if length is not None and len(items) != length:
        raise InputError(name, f"must have length {length}, the number of variables", len(items))
    for item in items:
        if not isinstance(item, numbers.Rational):
            raise InputError(name, "must hold exact rationals (int or fractions.Fraction), not floats", item)
    return [Fraction(item) for item in items]


def _polytope(
    lower: Sequence[Rational],
    upper: Sequence[Rational],
    A_ub: Sequence[Sequence[Rational]],
    b_ub: Sequence[Rational],
    n: int,
) -> tuple[list[Fraction], list[Fraction], list[list[Fraction]], list[Fraction]]:
    """The polytope's data as fractions, checked (n variables, lower ≤ upper, one bound of b_ub per row of A_ub)."""
    low = _vector("lower", lower, n)
    high = _vector("upper", upper, n)
    for i, (a, b) in enumerate(zip(low, high, strict=True)):
        if a > b:
            raise InputError("upper", f"must be >= lower at every index (index {i}, lower {a})", b)
    if isinstance(A_ub, (str, bytes)):
        raise InputError("A_ub", "must be a sequence of rows", A_ub)
    try:
        rows = [_vector("A_ub", row, n) for row in A_ub]
    except TypeError:
        raise InputError("A_ub", "must be a sequence of rows", A_ub) from None
    rhs = _vector("b_ub", b_ub)
    if len(rhs) != len(rows):
        raise InputError("b_ub", f"must have one entry per row of A_ub ({len(rows)})", len(rhs))
    return low, high, rows, rhs


def _integers(row: Sequence[Fraction]) -> tuple[list[int], int]:
    """A row of fractions times the positive lcm of their denominators: (integers, as GMP's, that multiplier)."""
    from gmpy2 import mpz  # (imported where used: ``import fairaudit`` does not load GMP)

    scale = mpz(math.lcm(1, *(x.denominator for x in row)))
    return [x.numerator * (scale // x.denominator) for x in row], scale


def _dot(a: Sequence[Fraction], b: Sequence[Fraction]) -> Fraction:
    """a·b, exactly."""
    return sum((x * y for x, y in zip(a, b, strict=True)), Fraction(0))


class _Simplex:
    """The bounded-variable primal simplex over w, h = lower + (upper − lower)·w, all in integers.

    Variables, in Bland's order: w_0..w_{n-1} (bounds [0, 1]), the slacks of the rows (bounds [0, ∞)), and the
    auxiliary t of phase 1 (bounds [0, ∞) in phase 1, [0, 0] after); ``cap`` holds the upper bounds (None: ∞). Each
    row, A_ub's row times the widths and its bound minus A_ub·lower, is scaled to integers. The tableau keeps only
    the nonbasic columns (a basic one is D times a unit vector), as in integer pivoting (Edmonds 1967; Bareiss
    1968): ``matrix`` (m × (n + 1)) is D·B⁻¹ times the columns of the variables ``nonbasic``, ``rhs`` is D times the
    basic variables' values, ``reduced`` is D times the nonbasic ones' reduced costs for the current objective, all
    GMP integers, ``det`` = D = det B with its sign. A nonbasic variable sits at 0, or at its cap when
    ``at_upper``.
    """

    def __init__(
        self, lower: list[Fraction], upper: list[Fraction], rows: list[list[Fraction]], rhs: list[Fraction]
    ) -> None:
        n, m = len(lower), len(rows)
        self.n, self.m, self.aux, self.lower = n, m, n + m, lower
        self.width = [b - a for a, b in zip(lower, upper, strict=True)]
        self.matrix: list[list[int]] = []
        self.rhs: list[int] = []
        self.scales: list[int] = []  # (what each row was multiplied by, and the objective, for the multipliers)
        for row, bound in zip(rows, rhs, strict=True):
            ints, scale = _integers([*(a * w for a, w in zip(row, self.width, strict=True)), bound - _dot(row, lower)])
            self.matrix.append([*ints[:-1], 0])  # (t's column: set by phase 1)
            self.rhs.append(ints[-1])
            self.scales.append(scale)
        self.cost_scale = 1
        self.cap: list[int | None] = [1] * n + [None] * (m + 1)
        self.basis = list(range(n, n + m))
        self.nonbasic = [*range(n), n + m]
        self.at_upper = [False] * (n + m + 1)
        self.det = 1
        self.reduced: list[int] = [0] * (n + 1)
        self.degenerate = False

    def feasible(self, at_upper: Sequence[int] = ()) -> bool:
        """Phase 1: a feasible basis, or False when the polytope is empty. Called once, before :meth:`maximize`, the
        variables ``at_upper`` (w's indices, each once) first moved to their cap: the basis of the slacks at that
        vertex of the box, where phase 1 takes no step if it meets every row."""
        for j in at_upper:  # (D = 1 and w_j's column is column j here: each row's slack loses its coefficient)
            self.rhs = [b - row[j] for b, row in zip(self.rhs, self.matrix, strict=True)]
            self.at_upper[j] = True
        negative = [i for i, b in enumerate(self.rhs) if b < 0]
        for i, row in enumerate(self.matrix):  # (t's column: −1 on the rows that start violated, its value their slack)
            row[self.n] = -1 if self.rhs[i] < 0 else 0
        if negative:
            # t enters at the most violated row, at its value −(that slack): every violated row's slack rises to ≥ 0
            self._exchange(min(negative, key=lambda i: (self.rhs[i], i)), self.n)
            self._install([0] * self.aux + [-1])
            self._run()
            if any(j == self.aux and b != 0 for j, b in zip(self.basis, self.rhs, strict=True)):
                return False
        self.cap[self.aux] = 0  # t stays at 0 from now on (basic or not)
        return True

    def maximize(self, cost: Sequence[Fraction]) -> tuple[Fraction, tuple[Fraction, ...]]:
        """Phase 2 for the objective cost·h (length n) from the current feasible basis: (max, a vertex attaining it)."""
        ints, self.cost_scale = _integers([c * w for c, w in zip(cost, self.width, strict=True)])
        self._install(ints + [0] * (self.m + 1))
        self._run()
        w = [Fraction(1 if self.at_upper[j] else 0) for j in range(self.n)]
        for j, b in zip(self.basis, self.rhs, strict=True):
            if j < self.n:
                w[j] = Fraction(int(b), int(self.det))
        point = tuple(a + d * x for a, d, x in zip(self.lower, self.width, w, strict=True))
        return _dot(cost, point), point

    def multipliers(self) -> tuple[Fraction, ...]:
        """The dual on the rows after :meth:`maximize`: y_i = −(the reduced cost of row i's slack) where the slack is
        nonbasic, else 0 (≥ 0 at the optimum), back in the row's and the objective's own units (times the row's
        scale, over the objective's). The reduced costs of the w's then have the signs of their bounds, so y proves
        the maximum (complementary slackness)."""
        y = [Fraction(0)] * self.m
        for j, d in zip(self.nonbasic, self.reduced, strict=True):
            if self.n <= j < self.aux:
                i = j - self.n
                y[i] = Fraction(-int(d) * int(self.scales[i]), int(self.det) * int(self.cost_scale))
        return tuple(y)

    def _install(self, cost: list[int]) -> None:
        """The reduced costs of the objective ``cost`` (integers, one per variable) for the current basis, times D."""
        reduced = [self.det * cost[j] for j in self.nonbasic]
        for r, j in enumerate(self.basis):
            if cost[j]:
                reduced = [x - cost[j] * y for x, y in zip(reduced, self.matrix[r], strict=True)]
        self.reduced = reduced
        self.degenerate = False

    def _run(self) -> None:
        """Simplex steps until no variable improves the objective."""
        while (column := self._entering()) is not None:
            self._step(column)

    def _entering(self) -> int | None:
        """The column of the entering variable, or None at the optimum: among the non-fixed nonbasic variables whose
        move off their bound raises the objective, the one of largest |reduced cost| (Dantzig's rule), or after a
        degenerate step the lowest-indexed one (Bland's rule), ties to the lowest index."""
        sign = 1 if self.det > 0 else -1
        best, best_key = None, (0, 0)
        for k, (j, d) in enumerate(zip(self.nonbasic, self.reduced, strict=True)):
            if d == 0 or self.cap[j] == 0 or (d * sign > 0) == self.at_upper[j]:
                continue
            key = (0 if self.degenerate else abs(d), -j)
            if best is None or key > best_key:
                best, best_key = k, key
        return best

    def _step(self, column: int) -> None:
        """One step of the variable of ``column``: the ratio test (ties to the lowest index), then a flip or a pivot.

        A step's length is a fraction (numerator, positive denominator), compared by cross-multiplication."""
        entering = self.nonbasic[column]
        direction = -1 if self.at_upper[entering] else 1
        sign, size = (1, self.det) if self.det > 0 else (-1, -self.det)
        cap = self.cap[entering]
        best = None if cap is None else (cap, 1)  # the entering variable's own other bound
        leaving, hits_upper, index = -1, False, entering
        for i, j in enumerate(self.basis):
            a = direction * sign * self.matrix[i][column]  # > 0: the basic variable falls towards 0
            bound = self.cap[j]
            if a > 0:
                limit, upper_hit = (sign * self.rhs[i], a), False
            elif a < 0 and bound is not None:
                limit, upper_hit = (bound * size - sign * self.rhs[i], -a), True
            else:
                continue
            if best is not None:
                order = limit[0] * best[1] - best[0] * limit[1]
                if order > 0 or (order == 0 and j > index):
                    continue
            best, leaving, hits_upper, index = limit, i, upper_hit, j
        if best is None:
            raise AssertionError("unbounded step: impossible, every objective is bounded on the box")
        self.degenerate = best[0] == 0
        # the entering variable is some w (t is fixed once it could sit at a cap), so a cap it leaves or reaches is 1
        if leaving < 0:  # a flip: the entering variable goes to its other bound, D·B⁻¹(its column) off the values
            self.rhs = [b - direction * row[column] for b, row in zip(self.rhs, self.matrix, strict=True)]
            self.at_upper[entering] = not self.at_upper[entering]
            return
        if direction < 0:  # it leaves its cap: its column back into the values, as if it sat at 0
            self.rhs = [b + row[column] for b, row in zip(self.rhs, self.matrix, strict=True)]
        out = self.basis[leaving]
        out_cap = self.cap[out]
        if hits_upper and out_cap:  # the leaving variable goes to its cap: its cap off its value
            self.rhs[leaving] -= out_cap * self.det
        self.at_upper[entering], self.at_upper[out] = False, hits_upper
        self._exchange(leaving, column)

    def _exchange(self, r: int, column: int) -> None:
        """The pivot: the variable of ``column`` enters at row ``r``, the one of row ``r`` takes its column. Every
        new entry is an exact integer division by the old D (Bareiss 1968); the new D is the pivot; the leaving
        variable's column is −(the old column), the old D at row r; row r and its value stay."""
        from gmpy2 import divexact  # (GMP's exact division: faster than // where the remainder is known to be 0)

        old, pivot_row, lead = self.det, self.matrix[r], self.rhs[r]
        pivot = pivot_row[column]
        for i, row in enumerate(self.matrix):
            if i == r:
                continue
            f = row[column]
            if f == 0:
                if pivot != old:
                    self.matrix[i] = [divexact(x * pivot, old) for x in row]
                    self.rhs[i] = divexact(self.rhs[i] * pivot, old)
                continue
            new = [divexact(x * pivot - f * y, old) for x, y in zip(row, pivot_row, strict=True)]
            new[column] = -f
            self.matrix[i] = new
            self.rhs[i] = divexact(self.rhs[i] * pivot - f * lead, old)
        f = self.reduced[column]
        self.reduced = [divexact(x * pivot - f * y, old) for x, y in zip(self.reduced, pivot_row, strict=True)]
        self.reduced[column] = -f
        pivot_row[column] = old
        self.det = pivot
        self.basis[r], self.nonbasic[column] = self.nonbasic[column], self.basis[r]


def maximize_linear(
    c: Sequence[Rational],
    lower: Sequence[Rational],
    upper: Sequence[Rational],
    A_ub: Sequence[Sequence[Rational]],
    b_ub: Sequence[Rational],
) -> LinearOptimum:
    """Exact max c·h over the polytope {lower ≤ h ≤ upper, A_ub h ≤ b_ub}, by the rational simplex.

    Parameters
    ----------
    c : sequence of Fraction or int, length n ≥ 1
        The objective.
    lower, upper : sequences of Fraction or int, length n
        The box, lower ≤ upper at every index (finite: every rational is).
    A_ub : sequence of m rows, each a sequence of Fraction or int of length n (m ≥ 0)
        The rows of the inequalities A_ub h ≤ b_ub, dense.
    b_ub : sequence of Fraction or int, length m
        Their bounds.

    Returns
    -------
    LinearOptimum
        Status "optimal" with the exact maximum and a vertex attaining it, or "infeasible" (the polytope is empty).

    Raises
    ------
    InputError
        Naming the argument: not a sequence, a wrong length, an entry that is not an exact rational (floats are
        refused: pass ``Fraction(x)`` to mean a float's exact value), or lower > upper somewhere.

    Notes
    -----
    Primal simplex with bounded variables (Chvátal 1983, *Linear Programming*, ch. 8) in integer-pivoting form
    (Bareiss 1968, *Math. Comp.* 22: 565–578), phase 1 by one auxiliary variable (Chvátal 1983, ch. 3), Dantzig's rule
    and, from a degenerate step on until a step that is not, Bland's rule against cycling (Bland 1977, *Math. Oper.
    Res.* 2: 103–107). Sized for n up to about 100 and m up to about 200.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> maximize_linear([1, 1], [0, 0], [1, 1], [[1, 2]], [F(3, 2)])  # doctest: +NORMALIZE_WHITESPACE
    LinearOptimum(status='optimal', value=Fraction(5, 4), point=(Fraction(1, 1), Fraction(1, 4)),
                  multipliers=(Fraction(1, 2),))

    The multiplier proves it: 1/2 · 3/2 + max over the box of (1 − 1/2, 1 − 2 · 1/2)·h = 3/4 + 1/2 = 5/4.
    >>> maximize_linear([1], [0], [1], [[-1]], [-2]).status
    'infeasible'
    """
    cost = _vector("c", c)
    if not cost:
        raise InputError("c", "must have at least one variable", c)
    simplex = _Simplex(*_polytope(lower, upper, A_ub, b_ub, len(cost)))
    if not simplex.feasible():
        return LinearOptimum("infeasible", None, None)
    value, point = simplex.maximize(cost)
    return LinearOptimum("optimal", value, point, simplex.multipliers())


def maximize_ratio(
    p: Sequence[Rational],
    q: Sequence[Rational],
    lower: Sequence[Rational],
    upper: Sequence[Rational],
    A_ub: Sequence[Sequence[Rational]],
    b_ub: Sequence[Rational],
    *,
    start: Rational | None = None,
) -> RatioOptimum:
    """Exact max (p·h)/(q·h) over the points of {lower ≤ h ≤ upper, A_ub h ≤ b_ub} with q·h > 0, by Dinkelbach.

    The ratio must have a finite maximum, which holds when q·h ≥ 0 on the polytope, q·h > 0 somewhere and no h has
    q·h = 0 < p·h (points with p·h = q·h = 0, such as h = 0 in a box from 0, are allowed and left out: 0/0 is not a
    ratio); otherwise the status is "zero_denominator". First min q·h (< 0: "zero_denominator") and max q·h (= 0:
    "zero_denominator") are found exactly; λ₀ is the ratio at the maximiser of q·h. Each step then maximises
    (p − λ_k q)·h exactly (a phase 2 of the simplex from the previous basis, as :func:`maximize_linear` does) at a
    vertex h_k. That maximum is ≥ 0 (the point of λ_k gives 0). When it is exactly 0, p·h ≤ λ_k q·h on the whole
    polytope and λ_k, attained, is the maximum. When it is positive and q·h_k = 0, then p·h_k > 0: the ratio is
    unbounded ("zero_denominator"). Otherwise λ_{k+1} = (p·h_k)/(q·h_k) > λ_k. λ rises strictly and is always a
    vertex's ratio, so the steps are finitely many (usually a handful: the convergence is superlinear).

    Parameters
    ----------
    p, q : sequences of Fraction or int, length n ≥ 1
        The numerator and the denominator.
    lower, upper : sequences of Fraction or int, length n
        The box, lower ≤ upper at every index.
    A_ub : sequence of m rows, each a sequence of Fraction or int of length n (m ≥ 0)
        The rows of the inequalities A_ub h ≤ b_ub, dense.
    b_ub : sequence of Fraction or int, length m
        Their bounds.
    start : Fraction or int, optional
        A guess at the maximum (a bound a solver's dual gives, say). The steps then start from the ratio at the
        vertex maximising (p − start·q)·h, where q·h > 0 there, instead of from the maximiser of q·h: near the
        maximum, one step or two, and the denominator's minimum and maximum are not computed. The answer is as
        exact; only where the vertex has p·h ≤ 0 = q·h does the search start as without a guess. Where q·h < 0
        somewhere but no step meets such a point, the status is "optimal" (the maximum over the points with
        q·h > 0, which the last step proves) where without a guess it is "zero_denominator".

    Returns
    -------
    RatioOptimum
        Status "optimal" with the exact maximum and a vertex attaining it; "zero_denominator" with a vertex that
        shows why (q·h < 0 there, or q·h = 0 there and everywhere, or q·h = 0 < p·h there); or "infeasible" (the
        polytope is empty).

    Raises
    ------
    InputError
        Naming the argument, as :func:`maximize_linear` does (``q`` of the wrong length and a ``start`` that is not
        an exact rational included).

    Notes
    -----
    Dinkelbach 1967, "On nonlinear fractional programming", *Management Science* 13: 492–498; the problem is
    equivalent to one LP by the Charnes–Cooper transformation (Charnes & Cooper 1962, "Programming with linear
    fractional functionals", *Naval Research Logistics Quarterly* 9: 181–186), which the certifying route solves in
    floating point (:mod:`fairaudit.base.linear_fractional`); here each step is exact.

    Examples
    --------
    The threshold rule's box case: the ratio is largest where p is large relative to q.

    >>> from fractions import Fraction as F
    >>> p, q = [F(7, 10), F(3, 10)], [F(3, 10), F(7, 10)]
    >>> maximize_ratio(p, q, [0, 0], [1, 1], [], [])  # doctest: +NORMALIZE_WHITESPACE
    RatioOptimum(status='optimal', value=Fraction(7, 3), point=(Fraction(1, 1), Fraction(0, 1)),
                 multipliers=())
    >>> maximize_ratio(p, q, [0, 0], [1, 1], [[-q[0], -q[1]]], [F(-1, 2)]).value
    Fraction(11, 7)

    From a guess a hair above the maximum, as a dual bound gives: the same answer.

    >>> maximize_ratio(p, q, [0, 0], [1, 1], [[-q[0], -q[1]]], [F(-1, 2)], start=F(11, 7) + F(1, 10**9)).value
    Fraction(11, 7)
    """
    numerator = _vector("p", p)
    if not numerator:
        raise InputError("p", "must have at least one variable", p)
    return Polytope(lower, upper, A_ub, b_ub, len(numerator)).maximize_ratio(numerator, q, start=start)


class Polytope:
    """The polytope {lower ≤ h ≤ upper, A_ub h ≤ b_ub} with a feasible basis found once, to maximise several ratios
    over it: each :meth:`maximize_ratio` starts from the basis the previous one ended at (phase 1 runs once).

    Parameters
    ----------
    lower, upper, A_ub, b_ub
        As :func:`maximize_ratio`'s.
    n : int
        The number of variables (≥ 1).
    at_upper : sequence of int, optional
        The variables (indices in [0, n), each once) phase 1 starts at their upper bound, the others at their lower:
        a vertex of the box. Where it meets every row of A_ub, phase 1 takes no step; elsewhere it starts there. The
        polytope and every answer are the same from any start (default: every variable at its lower bound).

    Attributes
    ----------
    feasible : bool
        False when the polytope is empty.

    Raises
    ------
    InputError
        Where ``at_upper`` holds an index outside [0, n) or one twice; on the other parameters, as
        :func:`maximize_ratio`.

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> box = Polytope([0, 0], [1, 1], [[-1, -1]], [F(-1, 2)], 2)
    >>> box.maximize_ratio([F(7, 10), F(3, 10)], [F(3, 10), F(7, 10)]).value
    Fraction(7, 3)
    >>> box.maximize_ratio([F(3, 10), F(7, 10)], [F(7, 10), F(3, 10)]).value
    Fraction(7, 3)

    From the vertex (1, 0), which meets h₀ + h₁ ≥ 1/2, phase 1 has nothing to do; the answer is the same.

    >>> Polytope([0, 0], [1, 1], [[-1, -1]], [F(-1, 2)], 2, at_upper=[0]).maximize_ratio([F(3, 10), F(7, 10)],
    ...     [F(7, 10), F(3, 10)]).value
    Fraction(7, 3)
    """

    def __init__(
        self,
        lower: Sequence[Rational],
        upper: Sequence[Rational],
        A_ub: Sequence[Sequence[Rational]],
        b_ub: Sequence[Rational],
        n: int,
        *,
        at_upper: Sequence[int] = (),
    ) -> None:
        self._n = n
        self._simplex = _Simplex(*_polytope(lower, upper, A_ub, b_ub, n))
        starts = list(at_upper)
        for j in starts:
            if isinstance(j, bool) or not isinstance(j, numbers.Integral) or not 0 <= j < n:
                raise InputError("at_upper", f"must hold variables' indices in [0, {n})", j)
        if len(set(starts)) != len(starts):
            raise InputError("at_upper", "must name each variable once", starts)
        self.feasible = self._simplex.feasible([int(j) for j in starts])

    def maximize_ratio(
        self, p: Sequence[Rational], q: Sequence[Rational], *, start: Rational | None = None
    ) -> RatioOptimum:
        """Exact max (p·h)/(q·h) over the polytope's points with q·h > 0, as :func:`maximize_ratio` (p and q of
        length n, ``start`` a guess at the maximum)."""
        return maximize_ratio_over_product([self], [p], [q], start=start)


def maximize_ratio_over_product(
    polytopes: Sequence[Polytope],
    p: Sequence[Sequence[Rational]],
    q: Sequence[Sequence[Rational]],
    *,
    start: Rational | None = None,
) -> RatioOptimum:
    """Exact max (Σ_i p_i·h_i)/(Σ_i q_i·h_i) over the product of polytopes, h_i in the i-th, by Dinkelbach.

    Each step maximises Σ_i (p_i − λ q_i)·h_i, and over a product a sum of terms in separate blocks is maximised block
    by block: the blocks are solved apart, each from the basis its last step ended at, so the cost grows with the
    number of blocks, not with the size of one program over all of them. Otherwise as :func:`maximize_ratio`
    (min and max of the denominator first unless ``start`` is given, then the steps; the same statuses and
    conventions).

    Parameters
    ----------
    polytopes : sequence of Polytope, length b ≥ 1
        The blocks (each keeps its basis between calls).
    p, q : sequences of b sequences of Fraction or int
        The numerator's and the denominator's coefficients on each block, the i-th of the i-th polytope's length.
    start : Fraction or int, optional
        A guess at the maximum, as :func:`maximize_ratio`'s.

    Returns
    -------
    RatioOptimum
        As :func:`maximize_ratio`'s, its point the blocks' points one after the other; "infeasible" when a block is
        empty.

    Raises
    ------
    InputError
        Naming ``p`` or ``q``: not one entry per polytope, or a block of the wrong length or not exact rationals.

    Notes
    -----
    Dinkelbach 1967; the separable step is exact because max over h_1 × … × h_b of Σ_i c_i·h_i = Σ_i max c_i·h_i.
    ``proofs/verification.md`` §4 (L̄ over many contexts).

    Examples
    --------
    Two blocks, each a box with the floor h_0 + h_1 ≥ 1/2: the second puts its utility where the denominator has
    none, and the first carries the whole denominator at its floor, (7/20 + 1)/(3/20) = 9.

    >>> from fractions import Fraction as F
    >>> one = Polytope([0, 0], [1, 1], [[-1, -1]], [F(-1, 2)], 2)
    >>> two = Polytope([0, 0], [1, 1], [[-1, -1]], [F(-1, 2)], 2)
    >>> best = maximize_ratio_over_product([one, two], [[F(7, 10), F(3, 10)], [1, 0]], [[F(3, 10), F(7, 10)], [0, 1]])
    >>> best.value, [str(h) for h in best.point]
    (Fraction(9, 1), ['1/2', '0', '1', '0'])
    """
    for name, blocks in (("p", p), ("q", q)):
        if isinstance(blocks, (str, bytes)) or len(blocks) != len(polytopes):
            raise InputError(name, f"must hold one block per polytope ({len(polytopes)})", blocks)
    numerators = [_vector("p", block, poly._n) for block, poly in zip(p, polytopes, strict=True)]
    denominators = [_vector("q", block, poly._n) for block, poly in zip(q, polytopes, strict=True)]
    guess = None if start is None else _vector("start", [start])[0]
    if not all(poly.feasible for poly in polytopes):
        return RatioOptimum("infeasible", None, None)
    numerator = [x for block in numerators for x in block]
    denominator = [x for block in denominators for x in block]

    def maximize(costs: list[list[Fraction]]) -> tuple[Fraction, tuple[Fraction, ...]]:
        """max Σ_i costs_i·h_i over the product, block by block: (the maximum, a vertex attaining it)."""
        total = Fraction(0)
        point: tuple[Fraction, ...] = ()
        for poly, cost in zip(polytopes, costs, strict=True):
            value, vertex = poly._simplex.maximize(cost)
            total, point = total + value, point + vertex
        return total, point

    def step(ratio: Fraction) -> tuple[Fraction, tuple[Fraction, ...]]:
        """max Σ_i (p_i − ratio·q_i)·h_i over the product."""
        return maximize(
            [[a - ratio * b for a, b in zip(top, bottom, strict=True)] for top, bottom in zip(numerators, denominators)]
        )

    point: tuple[Fraction, ...] | None = None  # a point attaining ``ratio`` (None: not attained yet)
    if guess is not None:  # one step at the guess, whose vertex's ratio, when q·h > 0 there, starts the steps
        gap, vertex = step(guess)
        scale = _dot(denominator, vertex)
        if scale < 0 or (scale == 0 and gap > 0):
            return RatioOptimum("zero_denominator", None, vertex)  # q·h < 0 here, or q·h = 0 < p·h: unbounded
        if scale > 0:
            point, ratio = vertex, _dot(numerator, vertex) / scale
    if point is None:  # (no guess, or its vertex has p·h ≤ 0 = q·h: the denominator's minimum and maximum first)
        negative_min, point = maximize([[-x for x in block] for block in denominators])
        if negative_min > 0:
            return RatioOptimum("zero_denominator", None, point)  # q·h < 0 at this point
        largest, point = maximize(denominators)
        if largest == 0:
            return RatioOptimum("zero_denominator", None, point)  # q·h = 0 on the whole polytope
        ratio = _dot(numerator, point) / largest
    while True:
        gap, vertex = step(ratio)
        if gap == 0:
            duals = tuple(y for poly in polytopes for y in poly._simplex.multipliers())
            return RatioOptimum("optimal", ratio, point, duals)
        scale = _dot(denominator, vertex)
        if scale == 0:
            return RatioOptimum("zero_denominator", None, vertex)  # q·h = 0 < p·h here: the ratio is unbounded
        point, ratio = vertex, _dot(numerator, vertex) / scale
