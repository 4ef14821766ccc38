"""Weak duality over the model's table: :class:`TableProgram`, max (P·K)/(Q·K) over tables K whose rows are
distributions over the decisions, bounded without solving (:mod:`~fairaudit.verification.black_box_check`).

A program is max (P·K)/(Q·K) over tables K with floors F_f·K ≥ τ. For λ ≥ 0 and multipliers
ν ≥ 0 on the floors, each row's simplex kept in the inner maximum,

    B(λ, ν) = Σ_rows max_u (P − λQ + Σ_f ν_f F_f)[row, u] − τ Σ_f ν_f  ≥  max over the tables of (P − λQ)·K,

so B(λ, ν) ≤ 0 proves P·K ≤ λ Q·K on every table meeting the floors: the ratio is at most λ where Q·K > 0, and no
table has Q·K = 0 < P·K. A certificate records, per program, one of

* ν (``floors``, ``bound_details.black_box.duals``): the bound is the least λ ≥ 0 with B(λ, ν) ≤ 0
  (:meth:`TableProgram.dual_bound`), the program's value where the table of the rows' maximisers there meets the
  floors and attains it (complementary slackness);
* θ (``theta``, ``bound_details.black_box.screens``), the one-floor proof: the multiplier λ − θ on a floor that keeps
  Q·K ≥ t, whose bound is θ + max(R(θ), 0)/t with R(θ) = Σ_rows max_u (P − θQ)[row, u]
  (:meth:`TableProgram.theta_bound`), in closed form;
* nothing: ν = 0, the bound of the table without its floors.

The smaller of the two is taken where both are. Nothing is searched for: the least λ is the root of a convex,
piecewise-linear, non-increasing function, reached by Newton's steps from the left (each lands on the next linear
piece, never beyond the root). Every number is exact: the rows are integers over one denominator. The ratio
conventions are the tool's: c/0 = +inf for c > 0, 0/0 = 1. A program whose recorded proof does not reach the
certified value shows as an upper end above it, and that check fails.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fairaudit.verification.enclosures import integers

__all__ = ["Number", "Table", "TableProgram"]

Number = Fraction | float
Table = Sequence[Sequence[Fraction]]


@dataclass(frozen=True)
class TableProgram:
    """max (P·K)/(Q·K) over tables K with floors F_f·K ≥ τ, all as integers over the one denominator ``d``.

    Attributes
    ----------
    top, bottom : object array of int, shape (n_rows, n_decisions)
        P and Q times d, ≥ 0.
    floors : object array of int, shape (n_floors, n_rows, n_decisions)
        The floors' rows F_f times d.
    d : int
    tau : Fraction or None
        τ; None without floors.
    """

    top: np.ndarray
    bottom: np.ndarray
    floors: np.ndarray
    d: int
    tau: Fraction | None

    def dual_bound(self, nu: Sequence[Fraction] | None = None) -> tuple[Number, Number | None]:
        """The least λ ≥ 0 with B(λ, ν) ≤ 0, exactly (ν = 0 when None): an upper bound on the program's value; and
        the value it proves attained: λ itself without floors (``tau`` None: the least root is the supremum); with
        floors, λ where the table of each row's maximiser at that λ (the largest q among ties) meets every floor and
        its ratio is λ (complementary slackness: then λ is the program's value), else None.

        Returns
        -------
        (Fraction or float, Fraction or None)
            The bound: +inf where some ν < 0 or no λ has B(λ, ν) ≤ 0; at least 1 where every row has a decision with
            q = 0. Then the value attained, or None.

        Examples
        --------
        P(yes | ã) over two released groups, p = (3/4, 1/4), q = (1/8, 3/8) on "yes", 0 on "no", floor q·K ≥ 1/4:
        without it the ratio reaches 6 (K = (1, 0)); ν = 8/3 on it proves 10/3, the value, which the table
        K = (1, 1) of the maximisers at 10/3 (the largest q among ties) does not attain (its ratio is 2); θ = 2/3
        proves it too.

        >>> F = Fraction
        >>> rows, d = integers([[[F(3, 4), F(0)], [F(1, 4), F(0)]], [[F(1, 8), F(0)], [F(3, 8), F(0)]]])
        >>> t = TableProgram(rows[0], rows[1], rows[1:], d, None)
        >>> t.dual_bound()
        (Fraction(6, 1), Fraction(6, 1))
        >>> t = TableProgram(rows[0], rows[1], rows[1:], d, F(1, 4))
        >>> t.dual_bound([F(8, 3)]), t.theta_bound(F(2, 3), F(1, 4))
        ((Fraction(10, 3), None), Fraction(10, 3))
        """
        top, d, constant = self.top, self.d, Fraction(0)
        if nu is not None and self.tau is not None and any(nu):
            if len(nu) != len(self.floors) or any(v < 0 for v in nu):
                return math.inf, None
            n = math.lcm(*(v.denominator for v in nu))
            weights = np.array([v.numerator * (n // v.denominator) for v in nu], dtype=object)
            top = self.top * n + np.tensordot(weights, self.floors, axes=1)
            d, constant = d * n, -self.tau * sum(nu, Fraction(0))
        lam, choice = _least_root(top, self.bottom * (d // self.d), d, constant)
        if lam != math.inf and all(any(v == 0 for v in row) for row in self.bottom.tolist()):
            lam = max(lam, Fraction(1))  # (a table with q·K = 0 = p·K is there: 0/0 = 1)
        if self.tau is None or lam == math.inf:  # (no floors: the least root is the supremum itself, +inf included)
            return lam, lam if self.tau is None else None
        n_u = self.top.shape[1]
        table = [[Fraction(int(u == c)) for u in range(n_u)] for c in choice.tolist()]
        return lam, lam if isinstance(lam, Fraction) and self.point_ratio(table) == lam else None

    def theta_bound(self, theta: Fraction, kept: Fraction) -> Number:
        """θ + max(R(θ), 0)/t, t = ``kept`` > 0: the bound the multiplier λ − θ on a floor Q·K ≥ t proves, exactly.

        R(θ) = Σ_rows max_u (P − θQ)[row, u]; the bound holds for any θ, a poor one is only loose.
        """
        r = _row_maxima(self.top * theta.denominator - theta.numerator * self.bottom, self.bottom)[0].sum()
        return theta + Fraction(max(int(r), 0), self.d * theta.denominator) / kept

    def point_ratio(self, table: Table) -> Fraction | None:
        """(P·K)/(Q·K) at a table whose rows are distributions and which meets every floor, exactly; None where it
        does not (a row with a negative entry or not summing to 1, a floor below τ)."""
        if any(v < 0 for row in table for v in row) or any(sum(row, Fraction(0)) != 1 for row in table):
            return None
        k, e = integers([table])
        k = k[0]
        for f in self.floors:
            if self.tau is not None and Fraction(int((f * k).sum()), self.d * e) < self.tau:
                return None
        num, den = int((self.top * k).sum()), int((self.bottom * k).sum())
        return Fraction(num, den) if den else (Fraction(1) if num == 0 else None)


def _row_maxima(
    values: np.ndarray, bottom: np.ndarray, left: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each row's largest value, the least q among the decisions attaining it (the slope to the right; the largest,
    the slope to the left, with ``left``), and that decision (the first such)."""
    best = values.max(axis=1)
    ties = values == best[:, None]
    keyed = np.where(ties, bottom, np.max(bottom, initial=0) + 1) if not left else np.where(ties, -bottom, 1)
    at = np.argmin(keyed, axis=1)
    return best, bottom[np.arange(len(at)), at], at


def _least_root(top: np.ndarray, bottom: np.ndarray, d: int, constant: Fraction) -> tuple[Number, np.ndarray]:
    """The least λ ≥ 0 with f(λ) = Σ_rows max_u (top − λ·bottom)/d + constant ≤ 0, by Newton's steps from the left
    along the right slopes (f is convex and non-increasing: each step lands on the root of the piece it starts on,
    never beyond f's); +inf where f stays positive (a right slope of 0). With it, each row's maximiser there with the
    largest q (the table on the piece to the left of the root, which attains it where the floors allow)."""
    lam = Fraction(0)
    while True:
        values = top * lam.denominator - lam.numerator * bottom
        best, slope, _ = _row_maxima(values, bottom)
        value = Fraction(int(best.sum()), d * lam.denominator) + constant
        if value <= 0:
            return lam, _row_maxima(values, bottom, left=True)[2]
        falls = Fraction(int(slope.sum()), d)
        if falls == 0:
            return math.inf, _
        lam += value / falls
