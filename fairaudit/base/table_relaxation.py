"""Exact upper bounds on many ratio programs over the model's table at once: the one-floor relaxation's weak-duality
bound at a threshold floating point proposes, computed in integers.

A program of the pair (a, b) is max (P_a·K)/(Q_b·K) over tables K whose rows are distributions over the decisions
(and which meet some floors). Where every table meeting them keeps Q_b·K ≥ t > 0, for every θ

    P_a·K − θ Q_b·K ≤ R(θ) = Σ_rows max_u (P_a − θQ_b)[row, u],

so the ratio is at most θ where R(θ) ≤ 0, else at most θ + R(θ)/(Q_b·K) ≤ θ + R(θ)/t: f(θ) = θ + max(R(θ), 0)/t
bounds the program at every θ, negative ones included, and its least value is the relaxation's (the program with
Q_b·K ≥ t its only floor). Without a floor, θ bounds it where R(θ) ≤ 0. Floating point only proposes θ: bisection
over the floats' bit patterns on the sign of f's slope, the bracket read as rationals, each row's maximisers at its
ends found exactly (floats decide the rows their error bounds separate, integers the rest), the hull edge where they
move and two Newton steps toward R's root; f is computed in floats at each, then exactly at the least of them and, where
floats do not put them well above it, at the first Newton step and at the bracket's upper end, and the least exact
value kept. A poor θ only makes the bound loose, never wrong.

``fairaudit verify`` screens the pairs with it before relaxing any (``proofs/verification.md`` §4h), and certify's
pair search orders its linear programs by it (``proofs/black_box.md`` §6).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
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
        Q_b per group, as ``tops`` (default: ``tops``, the same form as numerator and denominator).

    Returns
    -------
    dict
        {(a, b): (U, θ)} for a ≠ b groups of ``tops``, each U ≥ the value of the pair's program (any program whose
        tables all keep Q_b·K ≥ t). U is a ratio (its log is in nats), a Fraction, or +inf where no finite bound was
        found. θ is the threshold that proves it: U = θ + max(R(θ), 0)/t, the weak-duality bound with the multiplier
        U − θ ≥ 0 on the floor Q_b·K ≥ t (what a certificate records for the program); None without a floor, where
        U is proved with no multiplier (R(U) ≤ 0).

    Raises
    ------
    KeyError
        When a group of ``tops`` has no entry in ``kept`` or ``bottoms``.

    Notes
    -----
    Weak duality on the one-floor relaxation: ``proofs/verification.md`` §4g (its value, the rows' upper hulls) and
    §4h (this bound, and the threshold proposed).

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
    n_rows = len(tops[groups[0]]) if groups else 0
    flat = [[v for row in form[a] for v in row] for form in (tops, below) for a in groups]
    ints, d = on_one_denominator(flat)
    exact = np.array(ints, dtype=object).reshape(2, len(groups), n_rows, -1)
    floats = np.array([[float(v) for v in row] for row in flat]).reshape(2, len(groups), n_rows, -1)
    out: dict[tuple[int, int], tuple[Fraction | float, Fraction | None]] = {}
    for a in range(len(groups)):
        others = [b for b in range(len(groups)) if b != a]
        if not others:
            continue
        t = [kept[groups[b]] or None for b in others]
        floor = np.array([np.inf if v is None else float(v) for v in t])  # (S > +inf never: no floor)
        top, float_top, bottom = exact[0, a], floats[0, a], exact[1, others]
        low, high = _bisect(float_top, floats[1, others], floor, np.array([v is not None for v in t]))
        spread = (4 * n_rows + 32) * 2.0**-53 * np.maximum(np.abs(low), np.abs(high))  # (beyond the floats' errors)
        largest = np.finfo(np.float64).max
        with np.errstate(over="ignore"):
            at_low, at_high = (_as_rationals(np.clip(v, -largest, largest)) for v in (low - spread, high + spread))
        pair = (top, bottom, float_top, floats[1, others])
        first, then = (_maximisers(*pair, *theta) for theta in (at_low, at_high))
        root = _or(_root_of(top, bottom, first), at_high)
        again = _or(_root_of(top, bottom, _maximisers(*pair, *root)), at_high)  # (Newton's steps)
        candidates = [root, again, *(_or(edge, at_high) for edge in _edges(top, bottom, first, then)), at_high]
        in_floats = _float_bounds(float_top, floats[1, others], candidates, floor)
        pick = np.argmin(in_floats, axis=0)  # (the first least)
        m = np.arange(len(others))
        best = (np.stack([c[0] for c in candidates])[pick, m], np.stack([c[1] for c in candidates])[pick, m])
        zero = (bottom == 0).any(axis=-1).all(axis=-1)  # (every row has a decision with q = 0)
        bounds = _bounds(top, bottom, *best, d, t, zero.tolist())
        thetas = [Fraction(n, m) if v is not None else None for n, m, v in zip(*best, t, strict=True)]
        # exactly too, where floats do not show them well above it: R's root from θ_low (floats miss ties and
        # subnormal θ) and θ_high
        least = in_floats[pick, m]
        for k, (num, den) in ((0, root), (len(candidates) - 1, at_high)):
            with np.errstate(over="ignore"):  # (+inf: R > 0 in floats, which may miss R's root by an ulp)
                above = (in_floats[k] > least * (1 + NEAR) + NEAR) & np.isfinite(in_floats[k])
            near = np.flatnonzero(~above | ~np.isfinite(least)).tolist()
            checked = _bounds(top, bottom[near], num[near], den[near], d, [t[i] for i in near], zero[near].tolist())
            for i, u in zip(near, checked, strict=True):
                if u < bounds[i]:
                    bounds[i], thetas[i] = u, None if t[i] is None else Fraction(num[i], den[i])
        out.update(((groups[a], groups[b]), (u, theta)) for b, u, theta in zip(others, bounds, thetas, strict=True))
    return out


NEAR = 2.0**-20
"""How far above the least candidate's f in floats (relative, and absolute) another candidate is still computed
exactly: floats err by far less, so one further above cannot be smaller exactly (and if it were, the bound kept is
still a bound, only looser)."""


def _float_bounds(
    top: FloatArray, bottoms: FloatArray, candidates: Sequence[tuple[np.ndarray, np.ndarray]], floor: FloatArray
) -> FloatArray:
    """f(θ) in floats at each candidate θ = num/den, shape (candidates, programs): which one to compute exactly (inf
    where it overflows, or where R(θ) > 0 without a floor)."""
    out = []
    with np.errstate(all="ignore"):
        for num, den in candidates:
            theta = np.array([quotient_nearest(n, m) for n, m in zip(num.tolist(), den.tolist(), strict=True)])
            r = _best(top[None] - theta[:, None, None] * bottoms, bottoms)[0].sum(axis=-1)
            f = np.where(np.isinf(floor), np.where(r > 0, np.inf, theta), theta + np.maximum(r, 0) / floor)
            out.append(np.where(np.isnan(f), np.inf, f))
    return np.array(out)


def _goes_right(top: FloatArray, bottoms: FloatArray, theta: FloatArray, floor: FloatArray) -> npt.NDArray[np.bool_]:
    """Whether f (or, without a floor, the root of R) lies beyond θ, in floats: R(θ) > 0 and the rows' maximisers
    (the largest q among ties) keep q·K above the floor."""
    best, _, reach = _best(top[None] - theta[:, None, None] * bottoms, bottoms)
    return (best.sum(axis=-1) > 0) & ~(reach.sum(axis=-1) <= floor)


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


def _bisect(
    top: FloatArray, bottoms: FloatArray, floor: FloatArray, floored: npt.NDArray[np.bool_]
) -> tuple[FloatArray, FloatArray]:
    """Adjacent floats θ_low < θ_high per program (row of ``bottoms``) with the least f (the root of R without a
    floor, θ ≥ 0) between them, by bisection over the floats' bit patterns (signed keys, order-preserving): with a
    floor θ may be negative (f bounds at every θ)."""
    largest = np.float64(np.finfo(np.float64).max).view(np.int64)
    low = np.where(floored, -largest, 0)
    high = np.full(len(bottoms), largest)
    with np.errstate(all="ignore"):
        while np.any(high - 1 > low):  # (high − low overflows)
            middle = low // 2 + high // 2 + (low % 2 + high % 2) // 2
            right = _goes_right(top, bottoms, _float_of(middle), np.where(floored, floor, -np.inf))
            low, high = np.where(right, middle, low), np.where(right, high, middle)
    return _float_of(low), _float_of(high)


def _float_of(key: IntArray) -> FloatArray:
    """The float whose bit pattern is |key|, negated for key < 0: increasing in key."""
    return np.where(key < 0, -np.abs(key).view(np.float64), key.view(np.float64))


def _maximisers(
    top: np.ndarray,
    bottoms: np.ndarray,
    float_top: FloatArray,
    float_bottoms: FloatArray,
    num: np.ndarray,
    den: np.ndarray,
) -> IntArray:
    """Each row's maximiser of p − θq, θ = num/den per program, the largest q among ties, exactly: shape (programs,
    rows). Floats decide a row where their maximum beats every other decision by more than both values' error bounds
    (:func:`_float_errors`); the other rows (near-ties, ties, overflow) are compared exactly, in the integer object
    arrays ``top`` and ``bottoms``."""
    with np.errstate(all="ignore"):
        theta = np.array([quotient_nearest(n, m) for n, m in zip(num.tolist(), den.tolist(), strict=True)])
        values = float_top[None] - theta[:, None, None] * float_bottoms
        errors = _float_errors(float_top, float_bottoms, theta, values)
        at = np.argmax(values, axis=-1)
        lowest = np.take_along_axis(values - errors, at[..., None], -1)[..., 0]
        others = np.where(np.arange(values.shape[-1]) == at[..., None], -np.inf, values + errors).max(axis=-1)
    programs, rows = np.nonzero(~(lowest > others))  # (NaN, inf: exactly)
    if programs.size:
        exact = top[rows] * den[programs, None] - num[programs, None] * bottoms[programs, rows]
        at[programs, rows] = _best(exact, bottoms[programs, rows])[1]
    return at


def _float_errors(top: FloatArray, bottoms: FloatArray, theta: FloatArray, values: FloatArray) -> FloatArray:
    """A bound on |fl(p − θ̂q) − (p − θq)| per cell, p and q rounded to floats from exact rationals and θ̂ = θ to
    nearest: 8u(|p| + |θ||q|) + 2u|fl(p − θ̂q)| plus the smallest normal (each of the five roundings is within u of
    its exact value, relatively, or within half the smallest subnormal absolutely), doubled to cover the rounding of
    this bound itself."""
    u = 2.0**-53
    return 2 * (8 * u * (np.abs(top)[None] + np.abs(theta)[:, None, None] * bottoms) + 2 * u * np.abs(values)) + (
        np.finfo(np.float64).tiny
    )


def _or(theta: tuple[np.ndarray, np.ndarray], other: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """θ = num/den where den > 0, else ``other``'s."""
    good = theta[1] > 0
    return np.where(good, theta[0], other[0]), np.where(good, theta[1], other[1])


def _as_rationals(theta: FloatArray) -> tuple[np.ndarray, np.ndarray]:
    ratios = [v.as_integer_ratio() for v in theta.tolist()]
    return np.array([n for n, _ in ratios], dtype=object), np.array([m for _, m in ratios], dtype=object)


def _root_of(top: np.ndarray, bottoms: np.ndarray, rows_on: IntArray) -> tuple[np.ndarray, np.ndarray]:
    """The ratio (p·K)/(q·K) at the table of each row on its decision ``rows_on`` (a Newton step from θ_low, R's
    root where no breakpoint lies between), exactly: numerators and denominators (den 0 where q·K = 0)."""
    m, rows = np.arange(len(bottoms))[:, None], np.arange(bottoms.shape[1])[None, :]
    return top[rows, rows_on].sum(axis=1), bottoms[m, rows, rows_on].sum(axis=1)


def _edges(
    top: np.ndarray, bottoms: np.ndarray, first: IntArray, then: IntArray
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The slopes (p_u − p_v)/(q_u − q_v) of the first and the last row whose maximiser moves from u (``first``, at
    θ_low) to v (``then``, at θ_high): the hull edges where the rows' q·K may cross the floor, exactly; den 0 where
    no row moves."""
    m = np.arange(len(bottoms))
    moved = first != then
    out = []
    for row in np.argmax(moved, axis=-1), moved.shape[-1] - 1 - np.argmax(moved[:, ::-1], axis=-1):
        u, v = first[m, row], then[m, row]
        num, den = top[row, u] - top[row, v], bottoms[m, row, u] - bottoms[m, row, v]
        good = (den > 0) & moved.any(axis=-1)
        out.append((np.where(good, num, 0), np.where(good, den, 0)))
    return out


def _bounds(
    top: np.ndarray,
    bottoms: np.ndarray,
    num: np.ndarray,
    den: np.ndarray,
    d: int,
    t: Sequence[Fraction | None],
    zero: Sequence[bool],
) -> list[Fraction | float]:
    """f(θ) per program, θ = num/den, exactly (``top``, ``bottoms`` integers over ``d``); without a floor, θ where
    R(θ) ≤ 0 (max(θ, 1) where every row has a decision with q = 0: 0/0 = 1), else +inf."""
    r = _best(top[None] * den[:, None, None] - num[:, None, None] * bottoms, bottoms)[0].sum(axis=-1)  # R·d·den
    out: list[Fraction | float] = []
    for rb, cn, cd, tb, z in zip(r.tolist(), num.tolist(), den.tolist(), t, zero, strict=True):
        theta = Fraction(cn, cd)
        if tb is None:
            out.append(math.inf if rb > 0 else max(theta, Fraction(1)) if z else theta)
        else:
            out.append(theta + Fraction(max(rb, 0), d * cd) / tb)
    return out
