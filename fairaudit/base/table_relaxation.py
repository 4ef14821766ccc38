"""Exact upper bounds on many ratio programs over the model's table at once: the one-floor relaxation's value,
found exactly by Newton's and Kelley's steps on a convex piecewise-linear function, and its weak-duality proof.

A program of the pair (a, b) is max (P_a·K)/(Q_b·K) over tables K whose rows are distributions over the decisions
(and which meet some floors). Where every table meeting them keeps Q_b·K ≥ t > 0, for every θ

    P_a·K − θ Q_b·K ≤ R(θ) = Σ_rows max_u (P_a − θQ_b)[row, u],

so the ratio is at most θ where R(θ) ≤ 0, else at most θ + R(θ)/(Q_b·K) ≤ θ + R(θ)/t: f(θ) = θ + max(R(θ), 0)/t
bounds the program at every θ, negative ones included, and its least value is the relaxation's (the program with
Q_b·K ≥ t its only floor). Without a floor, θ bounds it where R(θ) ≤ 0.

Which θ. Every table K gives a line A − θB ≤ R(θ) (A = P_a·K, B = Q_b·K), equal to R at the θ where each row of K is
on a maximiser of p − θq; R is convex, piecewise linear and non-increasing (Q_b ≥ 0), and so f is convex. The least
f is found exactly, in finitely many steps, each computing the rows' maximisers at one rational θ (the largest q
among ties: B is then f's left slope's S; floats decide a row where their error bounds separate it, integers the
rest) and the line of that table in integers:

* Newton's steps on R from the left, θ ← A/B (the line's root: Dinkelbach's ratio at the table), from the leftmost
  line (each row on its largest q) while B ≥ t, where f does not rise before θ, up to R's root, the least f where
  B ≥ t still holds there;
* once B < t (f rises before θ), Kelley's steps on φ(θ) = R(θ) + tθ between the last two lines: θ ← their crossing
  (f is φ/t there, R ≥ 0), whose table replaces the line on its side of t, until R at the crossing is the lines'
  value: their maximum, below φ everywhere, is φ at its own least point, so θ minimises φ, and f ≥ φ/t with
  equality there.

Without a floor, Newton's steps from θ = 0 reach R's least root ≥ 0, or a table with B = 0 shows there is none.
Every step lands on a new piece of R (or of the pair of lines), so the steps end; :func:`_thresholds` stops after
three times the pieces R can have, which only a wrong maximiser could reach. The bound is then computed at that θ
exactly, in integers over one denominator, every row's maximum taken over all its decisions (a cell that repeats an
earlier one in every group once): θ only decides how tight the bound is, never whether it holds; where no table meets
the floor (Σ_rows max q < t, f unbounded below), θ is the least float.

Certify's pair search orders its linear programs by it (``proofs/black_box.md`` §6), and the certificate records each
θ, which ``fairaudit verify`` checks with its own arithmetic (``proofs/verification.md`` §4f, §4h).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.exact_duality import on_one_denominator
from fairaudit.base.outward import quotient_nearest

__all__ = ["relaxation_bounds"]

Table = Sequence[Sequence[Fraction]]


def relaxation_bounds(
    tops: Mapping[int, Table], kept: Mapping[int, Fraction | None], bottoms: Mapping[int, Table] | None = None
) -> dict[tuple[int, int], tuple[Fraction | float, Fraction | None]]:
    """Exact upper bounds on max (P_a·K)/(Q_b·K) over tables K whose rows are distributions over the decisions and
    which keep Q_b·K ≥ ``kept[b]``, for every ordered pair (a, b) of the groups of ``tops``; without that floor, over
    the tables alone (c/0 = +inf, 0/0 = 1).

    Parameters
    ----------
    tops : mapping of int to sequences of sequences of Fraction, each of shape (n_rows, n_decisions)
        P_a per group a: the numerator's coefficients on the cells of the model's table K, indexed [row, decision],
        ≥ 0 (E[g | a]'s, or E[g | x, a]'s).
    kept : mapping of int to Fraction or None
        t per group as the denominator: every table meeting the program's floors has Q_b·K ≥ t (None or 0: no such
        floor is used).
    bottoms : mapping of int to sequences of sequences of Fraction, optional
        Q_b per group, as ``tops``, ≥ 0 (default: ``tops``, the same form as numerator and denominator).

    Returns
    -------
    dict
        {(a, b): (U, θ)} for a ≠ b groups of ``tops``, each U ≥ the value of the pair's program (any program whose
        tables all keep Q_b·K ≥ t). U is a ratio (its log is in nats), a Fraction, or +inf where no finite bound
        exists. With a floor U is the one-floor relaxation's value (min over θ of f(θ) = θ + max(R(θ), 0)/t) and θ
        the threshold that attains it, U = f(θ): the weak-duality bound with the multiplier U − θ ≥ 0 on the floor
        Q_b·K ≥ t (what a certificate records for the program); where no table meets the floor, f has no least
        value and θ is the least float. Without a floor U is R's least root θ ≥ 0 (max(θ, 1) where every row has a
        decision with q = 0: 0/0 = 1), +inf where there is none, proved with no multiplier (R(U) ≤ 0), and θ is None.

    Raises
    ------
    KeyError
        When a group of ``tops`` has no entry in ``kept`` or ``bottoms``.

    Notes
    -----
    Weak duality on the one-floor relaxation: ``proofs/verification.md`` §4g (its value, the rows' upper hulls) and
    §4h (this bound, and how θ is found).

    Examples
    --------
    §4g's example: the pair (a, b) at t = 1/4 is 10/3 (the hull edge of slope 2/3); without the floor, 6.

    >>> F = Fraction
    >>> forms = {0: [[F(3, 4), F(0)], [F(1, 4), F(0)]], 1: [[F(1, 8), F(0)], [F(3, 8), F(0)]]}
    >>> relaxation_bounds(forms, {0: F(1, 4), 1: F(1, 4)})[(0, 1)], relaxation_bounds(forms, {0: None, 1: None})[(0, 1)]
    ((Fraction(10, 3), Fraction(2, 3)), (Fraction(6, 1), None))
    """
    groups = list(tops)
    below = tops if bottoms is None else bottoms
    if len(groups) < 2:
        return {}
    n_rows = len(tops[groups[0]])
    flat = [[v for row in form[a] for v in row] for form in (tops, below) for a in groups]
    ints, d = on_one_denominator(flat)
    exact = np.array(ints, dtype=object).reshape(2, len(groups), n_rows, -1)
    floats = np.array([[n / d for n in row] for row in ints]).reshape(2, len(groups), n_rows, -1)  # (to nearest)
    cells = _distinct_cells(exact)[None, None]
    exact, floats = (np.take_along_axis(v, cells, axis=-1) for v in (exact, floats))
    equal = cells[0, 0, :, :, None] == cells[0, 0, :, None, :]  # (a row's padding: its first cell again)
    zero = (exact[1] == 0).any(axis=-1).all(axis=-1)  # (every row of Q_b has a decision with q = 0)
    out: dict[tuple[int, int], tuple[Fraction | float, Fraction | None]] = {}
    for a in range(len(groups)):  # (one numerator's programs at a time: memory in proportion to the input)
        others = np.array([b for b in range(len(groups)) if b != a], dtype=np.intp)
        forms = _Forms(exact[0], exact[1], floats[0], floats[1], np.full(len(others), a), others, d, equal)
        t = [kept[groups[b]] or None for b in others.tolist()]
        num, den = _thresholds(forms, t)
        bounds = _bounds(forms, num, den, t, zero[others].tolist())
        for b, u, n, m, v in zip(others.tolist(), bounds, num.tolist(), den.tolist(), t, strict=True):
            out[groups[a], groups[b]] = (u, None if v is None else Fraction(n, m))
    return out


def _distinct_cells(exact: np.ndarray) -> IntArray:
    """Each row's decisions but those that are the same cell as an earlier one (equal p and q in every group's P and
    Q, exactly: ``exact``, shape (2, groups, rows, decisions)), in order, padded with the row's first decision: shape
    (rows, k), k the most any row keeps. A decision left out ties with an earlier one at every θ, so R, the rows'
    maximisers' p and q, and the relaxation are the same without it (a utility that takes a few values over many
    decisions leaves out many)."""
    columns = exact.transpose(2, 3, 0, 1).reshape(exact.shape[2], exact.shape[3], -1).tolist()
    kept = [[u for u, cell in enumerate(row) if row.index(cell) == u] for row in columns]  # (== on ints: exact)
    k = max(map(len, kept))
    return np.array([row + [0] * (k - len(row)) for row in kept], dtype=np.intp)


@dataclass(frozen=True)
class _Forms:
    """The groups' coefficients, exactly (integers over ``d``, object arrays) and in floats, each of shape (groups,
    rows, decisions), the decisions each row's distinct ones (:func:`_distinct_cells`), the programs' groups (program
    i is max (P_{first[i]}·K)/(Q_{second[i]}·K)) and which of a row's decisions are the same cell (a row's padding)."""

    tops: np.ndarray
    bottoms: np.ndarray
    float_tops: FloatArray
    float_bottoms: FloatArray
    first: IntArray
    second: IntArray
    d: int
    equal: npt.NDArray[np.bool_]

    def lines(self, programs: IntArray, num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A, B)·d = (P·K, Q·K)·d of each of ``programs`` at the table K of its rows' maximisers of p − θq, θ =
        num/den (the largest q among ties, the first among equal ones: floats decide, :func:`_float_maximisers`, integers
        the rows they leave), exactly: R(θ) = (A − θB)/d."""
        a, b = self.first[programs], self.second[programs]
        at, undecided = _float_maximisers(self.float_tops[a], self.float_bottoms[b], num, den, self.equal)
        m, rows = np.nonzero(undecided)
        if m.size:
            tops, bottoms = self.tops[a[m], rows], self.bottoms[b[m], rows]
            at[m, rows] = _exact_maximisers(tops, bottoms, num[m], den[m])
        return self._sums(programs, at)

    def leftmost(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, B)·d of every program at the table of each row's largest q, the largest p among those in floats: its
        line is R's for every θ below R's least breakpoint, where the largest p is the exact one (else it is below R,
        still a line under R, as every table's)."""
        steepest = (self.bottoms == self.bottoms.max(axis=-1, keepdims=True)).astype(bool)[self.second]
        p = np.where(steepest, self.float_tops[self.first], -np.inf)
        return self._sums(np.arange(len(self.first)), np.argmax(p, axis=-1))

    def _sums(self, programs: IntArray, at: IntArray) -> tuple[np.ndarray, np.ndarray]:
        rows = np.arange(at.shape[-1])[None, :]
        tops = self.tops[self.first[programs][:, None], rows, at]
        bottoms = self.bottoms[self.second[programs][:, None], rows, at]
        return tops.sum(axis=1), bottoms.sum(axis=1)


def _thresholds(forms: _Forms, t: Sequence[Fraction | None]) -> tuple[np.ndarray, np.ndarray]:
    """θ = num/den per program (integer object arrays, den > 0) at which f is least, or, without a floor (t None),
    R's least root θ ≥ 0 (where there is none, a θ with R(θ) > 0): the module's Newton and Kelley steps, the
    programs stepped together."""
    n = len(t)
    floored = np.array([v is not None for v in t])
    t_num = np.array([0 if v is None else v.numerator for v in t], dtype=object)
    t_den = np.array([1 if v is None else v.denominator for v in t], dtype=object)
    # the line θ is stepped from (Newton: its root), or the lines on either side (Kelley: their crossing)
    low_a, low_b = forms.leftmost()
    reach = (low_b * t_den >= t_num * forms.d).astype(bool)  # (Σ_rows max q ≥ t: a table meets the floor)
    low_a, low_b = np.where(floored, low_a, 0), np.where(floored, low_b, 1)  # (without a floor: θ = 0/1 first)
    high_a, high_b = np.zeros(n, dtype=object), np.zeros(n, dtype=object)
    crossing = np.zeros(n, dtype=bool)
    num, den = np.zeros(n, dtype=object), np.ones(n, dtype=object)
    num[floored & ~reach] = -int(sys.float_info.max)  # (f unbounded below: the least float)
    active = ~floored | reach
    rows, decisions = forms.tops.shape[1:]
    for _ in range(3 * (rows * max(decisions - 1, 0) + 1)):  # (R's pieces, three times: never reached)
        p = np.flatnonzero(active)
        if not p.size:
            break
        k = crossing[p]
        num[p] = np.where(k, low_a[p] - high_a[p], low_a[p])
        den[p] = np.where(k, low_b[p] - high_b[p], low_b[p])
        a, b = forms.lines(p, num[p], den[p])
        r = a * den[p] - num[p] * b  # R(θ)·d·den
        above = (b * t_den[p] >= t_num[p] * forms.d).astype(bool)  # B ≥ t (always without a floor)
        met = (r == low_a[p] * den[p] - num[p] * low_b[p]).astype(bool)  # R(θ) on the lower line (at its crossing)
        positive = (r > 0).astype(bool)
        kelley = k | (floored[p] & ~above)
        done = np.where(k, met, ~kelley & (~positive | (b == 0).astype(bool)))
        active[p[done]] = False
        step = ~done & (~kelley | above)
        high = ~done & kelley & ~above
        low_a[p[step]], low_b[p[step]] = a[step], b[step]
        high_a[p[high]], high_b[p[high]] = a[high], b[high]
        crossing[p] = kelley
    return num, den


def _best(values: np.ndarray, bottoms: np.ndarray) -> tuple[np.ndarray, IntArray, np.ndarray]:
    """Each row's largest value over the decisions (the last axis), the decision attaining it with the largest q (the
    first among equal ones) and that q, shape (programs, rows): one pass over the decisions, which are few (floats or
    integer object arrays alike)."""
    best, q, at = values[..., 0], bottoms[..., 0], np.zeros(values.shape[:-1], dtype=np.intp)
    for u in range(1, values.shape[-1]):
        v, qu = values[..., u], bottoms[..., u]
        take = (v > best) | ((v == best) & (qu > q))
        best, q, at = np.where(take, v, best), np.where(take, qu, q), np.where(take, u, at)
    return best, at, q


def _float_maximisers(
    top: FloatArray, bottoms: FloatArray, num: np.ndarray, den: np.ndarray, equal: npt.NDArray[np.bool_] | None
) -> tuple[IntArray, npt.NDArray[np.bool_]]:
    """Each row's maximiser of p − θq in floats, θ = num/den per program (``top`` shape (rows, decisions) or shaped
    as ``bottoms``, (programs, rows, decisions)), and the rows it is not known to be exact for, both shape (programs,
    rows). A row is decided where its float maximum beats every other decision by more than both values' error
    bounds (:func:`_float_errors`), but the decisions that are the same cell exactly (``equal``, shape (rows,
    decisions, decisions), or None: they tie at every θ, and the first of them, which floats take, is the first
    among ties); the others (near-ties, ties, overflow) are left to the integers."""
    with np.errstate(all="ignore"):
        theta = np.array([quotient_nearest(n, m) for n, m in zip(num.tolist(), den.tolist(), strict=True)])
        values = top - theta[:, None, None] * bottoms
        errors = _float_errors(top, bottoms, theta, values)
        at = np.argmax(values, axis=-1)
        lowest = np.take_along_axis(values - errors, at[..., None], -1)[..., 0]
        same = np.arange(values.shape[-1]) == at[..., None]
        same = same if equal is None else equal[np.arange(values.shape[1]), at]  # (at's row, at's decision)
        others = np.where(same, -np.inf, values + errors).max(axis=-1)
    return at, ~(lowest > others)  # (NaN, inf: undecided)


def _exact_maximisers(tops: np.ndarray, bottoms: np.ndarray, num: np.ndarray, den: np.ndarray) -> IntArray:
    """The maximiser of p − θq of each row of ``tops`` and ``bottoms`` (integer object arrays, shape (rows,
    decisions)), θ = num/den per row, the largest q among ties (the first among equal ones), in integers."""
    return _best(tops * den[:, None] - num[:, None] * bottoms, bottoms)[1]


def _float_errors(top: FloatArray, bottoms: FloatArray, theta: FloatArray, values: FloatArray) -> FloatArray:
    """A bound on |fl(p − θ̂q) − (p − θq)| per cell, p and q rounded to floats from exact rationals and θ̂ = θ to
    nearest: 8u(|p| + |θ||q|) + 2u|fl(p − θ̂q)| plus the smallest normal (each of the five roundings is within u of
    its exact value, relatively, or within half the smallest subnormal absolutely), doubled to cover the rounding of
    this bound itself."""
    u = 2.0**-53
    return 2 * (8 * u * (np.abs(top) + np.abs(theta)[:, None, None] * bottoms) + 2 * u * np.abs(values)) + (
        np.finfo(np.float64).tiny
    )


def _bounds(
    forms: _Forms, num: np.ndarray, den: np.ndarray, t: Sequence[Fraction | None], zero: Sequence[bool]
) -> list[Fraction | float]:
    """f(θ) per program, θ = num/den, exactly, each row's maximum of p − θq taken over all its (distinct) decisions in
    integers; without a floor, θ where R(θ) ≤ 0 (max(θ, 1) where every row has a decision with q = 0: 0/0 = 1), else
    +inf."""
    values = forms.tops[forms.first] * den[:, None, None] - num[:, None, None] * forms.bottoms[forms.second]
    r = values.max(axis=-1).sum(axis=-1)  # R·d·den
    out: list[Fraction | float] = []
    for rb, cn, cd, tb, z in zip(r.tolist(), num.tolist(), den.tolist(), t, zero, strict=True):
        theta = Fraction(cn, cd)
        if tb is None:
            out.append(math.inf if rb > 0 else max(theta, Fraction(1)) if z else theta)
        else:
            out.append(theta + Fraction(max(rb, 0), forms.d * cd) / tb)
    return out
