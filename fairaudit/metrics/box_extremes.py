"""Extreme values of the fairness metrics over a box of expectations: ratios of groups and total-variation gaps.

Two settings. *Disjoint*: each group's expectation (or distribution) ranges
over its own box, independently of the others (no privacy filter): the
extremes of max_{a≠a'} E_a / E_a' and of the largest TV gap are in closed form
(:func:`disjoint_ratio`, :func:`disjoint_tv`). *Mixed*: behind a privacy
filter each group's expectation is a fixed mixture W_a·e of kernel cells e
that range over a box, so groups share cells: the upper end of each ratio is
the threshold solution of a linear-fractional program
(:func:`fairaudit.base.threshold_rule.threshold_max_many`) and the lower end a Charnes–Cooper
LP (:class:`MinMaxRatio`), in closed form behind randomized response
(:func:`randomized_response_min_max`); the TV gaps are linear per event (:func:`mixed_tv`).

Every function returns :data:`Extremes`: per map (a context for local
metrics, one map for global ones) the lower end, the upper end and the pair
of groups attaining the upper end. Ratios use c/0 = +inf (c > 0) and 0/0 = 1.
Proofs: ``proofs/intervals.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from fractions import Fraction
from typing import TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.outward import fraction_down

MAX_EVENT_DECISIONS = 10  # up to 2^10 - 2 events for the total-variation gaps; beyond, a valid coarser bound

__all__ = [
    "Extremes",
    "MinMaxRatio",
    "disjoint_ratio",
    "disjoint_tv",
    "div",
    "max_over",
    "mixed_ratio",
    "mixed_tv",
    "pair_floors",
    "pair_gap",
    "randomized_response_min_max",
]

Extremes: TypeAlias = tuple[FloatArray, FloatArray, IntArray, IntArray]
"""Per map: (lower, upper, favoured group, other group)."""


def div(num: npt.ArrayLike, den: npt.ArrayLike) -> FloatArray:
    """num / den with c/0 = +inf (c > 0) and 0/0 = 1."""
    num, den = np.broadcast_arrays(np.asarray(num, dtype=float), np.asarray(den, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 1.0))


def disjoint_ratio(lo: FloatArray, hi: FloatArray) -> Extremes:
    """Extremes of max_{a≠a'} E_a / E_a' when each E_a ranges over its own [lo_a, hi_a] independently.

    lo, hi: shape (M, A); NaN marks a group left out of a map. Returns
    (lower (M,), upper (M,), favoured (M,), other (M,)); NaN where a map has
    fewer than two groups. Upper: the pair with the largest hi_a / lo_a'.
    Lower: min over the box of max_a E_a / min_a E_a = max(1, max lo / min hi),
    since all E_a can be set into [min hi, max lo] when that is nonempty.
    """
    M, A = lo.shape
    valid = ~np.isnan(lo)
    rows, cols = np.arange(M), np.arange(A)
    hi0 = np.nan_to_num(hi)
    # hi_a / lo_b (with c/0 = inf, 0/0 = 1) rises with hi_a and falls with lo_b: for each a the best b ≠ a is
    # the smallest lo, or the second smallest when a holds the smallest. No (M, A, A) array of pairs is made.
    lo_v = np.where(valid, lo, np.inf)
    two = np.argsort(lo_v, axis=1, kind="stable")[:, :2] if A >= 2 else np.zeros((M, 2), dtype=int)
    den = np.where(cols[None, :] == two[:, :1], lo_v[rows, two[:, 1]][:, None], lo_v[rows, two[:, 0]][:, None])
    best_a = np.where(valid & np.isfinite(den), div(hi0, np.where(np.isfinite(den), den, 1.0)), -np.inf)
    a = best_a.argmax(-1)  # the first a of the first maximal pair
    row = np.where(valid & (cols[None, :] != a[:, None]), div(hi0[rows, a][:, None], np.nan_to_num(lo)), -np.inf)
    b = row.argmax(-1)  # its first b
    upper = row[rows, b]
    idx = a * A + b
    enough = valid.sum(-1) >= 2
    lower = np.maximum(1.0, div(np.where(valid, lo, -np.inf).max(-1), np.where(valid, hi, np.inf).min(-1)))
    upper = np.where(enough, upper, np.nan)
    lower = np.where(enough, lower, np.nan)
    return lower, upper, idx // A, idx % A


def pair_gap(big: FloatArray, small: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
    """max over a ≠ a' of big[..., a] − small[..., a'] (last axis, at least 2 groups) and the maximising pair.

    Only the two largest ``big`` and the two smallest ``small`` can attain it, so
    no (A, A) array of pairs is formed.
    """
    hb = np.argsort(-big, -1, kind="stable")[..., :2]
    ls = np.argsort(small, -1, kind="stable")[..., :2]
    b1, b2 = np.take_along_axis(big, hb[..., :1], -1)[..., 0], np.take_along_axis(big, hb[..., 1:], -1)[..., 0]
    s1, s2 = np.take_along_axis(small, ls[..., :1], -1)[..., 0], np.take_along_axis(small, ls[..., 1:], -1)[..., 0]
    same = hb[..., 0] == ls[..., 0]
    first = (b1 - s2) >= (b2 - s1)
    value = np.where(same, np.maximum(b1 - s2, b2 - s1), b1 - s1)
    fav = np.where(same & ~first, hb[..., 1], hb[..., 0])
    oth = np.where(same, np.where(first, ls[..., 1], ls[..., 0]), ls[..., 0])
    return value, fav, oth


def disjoint_tv(lo: FloatArray, hi: FloatArray, events: FloatArray, cat_lo: FloatArray, cat_hi: FloatArray) -> Extremes:
    """Extremes of max_{a≠a'} TV(P_a, P_a') when each P_a ranges over its own set independently.

    lo, hi: event bounds, shape (M, A, S); cat_lo, cat_hi: per-decision
    bounds, shape (M, A, K) (for K > 10, where the events are singletons).
    Returns (lower (M,), upper (M,), favoured (M,), other (M,)). Memory is
    O(M·A·S): pairs are found from the two extreme groups of each event.
    """
    M, A = lo.shape[:2]
    if lo.shape[-1] == 0 or A < 2:
        zero = np.zeros(M)
        return zero, zero, np.zeros(M, int), np.ones(M, int)
    rows = np.arange(M)
    if events.shape[0] == events.shape[1] and events.shape[1] > MAX_EVENT_DECISIONS:
        off = ~np.eye(A, dtype=bool)
        d = np.maximum(cat_hi[:, :, None, :] - cat_lo[:, None, :, :], cat_hi[:, None, :, :] - cat_lo[:, :, None, :])
        up_pairs = np.where(off, np.clip(0.5 * np.clip(d, 0.0, None).sum(-1), 0.0, 1.0), -np.inf).reshape(M, -1)
        idx = up_pairs.argmax(-1)
        upper, fav, oth = up_pairs[rows, idx], idx // A, idx % A
    else:
        val, f, o = pair_gap(hi.transpose(0, 2, 1), lo.transpose(0, 2, 1))  # (M, S)
        s = val.argmax(-1)
        upper, fav, oth = np.clip(val[rows, s], 0.0, 1.0), f[rows, s], o[rows, s]
    low, _, _ = pair_gap(lo.transpose(0, 2, 1), hi.transpose(0, 2, 1))
    lower = np.clip(low.max(-1), 0.0, 1.0)
    return lower, upper, fav, oth


class MinMaxRatio:
    """min over lower ≤ e ≤ upper of max_a (W_a·e) / min_a (W_a·e), by the Charnes–Cooper LP.

    With y = t e and t = 1 / min_a W_a·e: minimise σ subject to W y ≤ σ,
    W y ≥ 1, t·lower ≤ y ≤ t·upper, t ≥ 0 (``proofs/intervals.md``), over
    x = (σ, t, y). Solved as every linear program of fairaudit is: HiGHS's
    simplex, its basis proved optimal in exact arithmetic
    (:class:`~fairaudit.base.exact_lp.ExactProgram`); the exact optimum of the
    floats' program, rounded down, is the lower end. :meth:`solve` takes the
    same exact optimum in closed form where W is randomized response, scaled
    (:func:`randomized_response_min_max`), and solves no LP there.
    """

    def __init__(self, A: int, n: int) -> None:
        self.A, self.n = A, n

    def lp(self, W: FloatArray, lo: FloatArray, hi: FloatArray) -> float | None:
        """The LP's optimal σ rounded down, or None unless it was proved optimal."""
        from fairaudit.base.exact_lp import ExactProgram

        A, n, inf = self.A, self.n, math.inf
        rows = np.zeros((2 * A + 2 * n, n + 2))
        rows[:A, 0], rows[:A, 2:] = -1.0, W  # W y − σ ≤ 0
        rows[A : 2 * A, 2:] = W  # W y ≥ 1
        rows[2 * A : 2 * A + n, 1], rows[2 * A : 2 * A + n, 2:] = lo, -np.eye(n)  # t·lower − y ≤ 0
        rows[2 * A + n :, 1], rows[2 * A + n :, 2:] = -hi, np.eye(n)  # y − t·upper ≤ 0
        row_lower = [-inf] * A + [1.0] * A + [-inf] * (2 * n)
        row_upper = [0.0] * A + [inf] * A + [0.0] * (2 * n)
        program = ExactProgram(rows, row_lower, row_upper, [-inf, 0.0] + [-inf] * n, [inf] * (n + 2))
        found = program.minimize([1.0] + [0.0] * (n + 1))
        return fraction_down(found.value) if found.status == "optimal" and found.value is not None else None

    def solve(self, W: FloatArray, lo: FloatArray, hi: FloatArray) -> float:
        if np.all(W @ lo <= 0):  # every group can be at 0 together: 0/0, parity
            return 1.0
        if np.any(W @ hi <= 0):  # some group is always 0 while another can be positive
            return math.inf
        exact = randomized_response_min_max(W, lo, hi)
        if exact is not None:
            return max(1.0, fraction_down(exact))
        value = self.lp(W, lo, hi)  # the exact optimum, rounded down: at least every pair's floor
        if value is None:  # (not proved optimal: the pairs' floors, in closed form, are a valid lower end)
            return max(1.0, float(pair_floors(W, lo, hi).max()))
        return max(1.0, value)


def randomized_response_min_max(W: FloatArray, lo: FloatArray, hi: FloatArray) -> Fraction | None:
    """min over the box lo ≤ e ≤ hi of max_a (W_a·e) / min_a (W_a·e), exactly, where every cell a group weighs is
    randomized response up to a scale: s_c·p for the cell's own group, s_c·q < s_c·p for every other (None for any
    other W).

    Then W_a·e = Σ_b M[a, b] E_b with M randomized response and E_b = Σ s_c e_c over the cells of group b, which range
    over their own box; with d = p − q and S = Σ E, W_a·e = q S + d E_a, so the ratio is (q S + d max E) /
    (q S + d min E): it falls as S and min E rise, and every point is beaten by E(t) = min(hi, t) at t = its max E.
    Along t, from max lo to max hi, the ratio is linear-fractional between the hi values, so its minimum is at max lo
    or an hi above it (1 where the ranges meet). ``proofs/intervals.md`` §4; O(n_cells + A log A) exact operations,
    none of them an LP. A local map behind k-ary randomized response has one cell a group (s = 1); L̄'s map, cells
    weighted by P(x | a), has this form where those weights times p and q are exact floats (X and A independent).
    Call it where some group can be above 0 and none is 0 on the whole box (:meth:`MinMaxRatio.solve` checks both).

    Parameters
    ----------
    W : array of shape (n_groups, n_cells)
        Each group's weights on the cells.
    lo, hi : arrays of shape (n_cells,)
        The box, lo ≤ hi.

    Returns
    -------
    Fraction or None
        The exact minimum, a ratio (not a log), taking the floats at their exact values; None where W is not of this
        form with p > q on two or more groups, or an end of a weighed cell is not finite (the LP's case).

    Examples
    --------
    >>> W = np.array([[0.5, 0.25, 0.25], [0.25, 0.5, 0.25], [0.25, 0.25, 0.5]])
    >>> randomized_response_min_max(W, np.array([0.0, 0.5, 0.25]), np.array([0.125, 0.75, 0.375]))  # at e = (1/8, 1/2, 3/8)
    Fraction(4, 3)
    """
    A, cells = len(W), np.flatnonzero(W.any(0))
    if A < 2 or not np.isfinite(lo[cells]).all() or not np.isfinite(hi[cells]).all():
        return None
    V = W[:, cells]
    group = V.argmax(0)  # each cell's own group
    own, other = V[group, np.arange(len(cells))], V[(group + 1) % A, np.arange(len(cells))]
    if not (np.all((V == other) | (np.arange(A)[:, None] == group)) and np.all(own > other)):
        return None
    p, q = Fraction(own[0]), Fraction(other[0])
    scale = [Fraction(o) / p for o in own]
    if any(s * q != o for s, o in zip(scale, map(Fraction, other))):  # (not one randomized response, scaled)
        return None
    lower, upper = [Fraction(0)] * A, [Fraction(0)] * A
    for s, b, c in zip(scale, group.tolist(), cells.tolist()):
        lower[b], upper[b] = lower[b] + s * Fraction(lo[c]), upper[b] + s * Fraction(hi[c])
    d, ends, start = p - q, sorted(upper), max(lower)
    if start <= ends[0]:  # every group's E can take one value: parity
        return Fraction(1)
    best, below, i = None, Fraction(0), 0
    for t in [start] + [h for h in ends if h > start]:
        while ends[i] < t:  # (ends[-1] >= t: the loop stops at the largest hi)
            below, i = below + ends[i], i + 1
        total = q * (below + t * (A - i))
        ratio = (total + d * t) / (total + d * ends[0])
        best = ratio if best is None else min(best, ratio)
    return best


def pair_floors(W: FloatArray, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """[a, a'] = min over the box of (W_a·e)/(W_a'·e), in closed form: 1 / the threshold maximum of the inverse ratio
    (+inf where that is 0 or beyond the floats, -inf on the diagonal).

    The largest is a valid floor of the min-max ratio (min of a max ≥ max of the mins), exact when the groups use
    disjoint cells.

    Parameters
    ----------
    W : array of shape (n_groups, n_cells)
        Each group's nonnegative weights on the cells e.
    lo, hi : arrays of shape (n_cells,)
        The box lo ≤ e ≤ hi.

    Returns
    -------
    array of shape (n_groups, n_groups)
        The floor of each ordered pair's ratio (a ratio, not a log; -inf on the diagonal). Source: the threshold rule
        (:func:`~fairaudit.base.threshold_rule.threshold_max_many`).
    """
    from fairaudit.base.threshold_rule import threshold_max_many

    inv, _, _ = threshold_max_many(W[None, :, :], W[:, None, :], lo, hi)  # [a, a'] = max (W_a'·e)/(W_a·e)
    with np.errstate(divide="ignore", over="ignore"):  # (1/inv beyond the floats, inv subnormal: +inf, the largest)
        floor = np.where(inv > 0, 1.0 / inv, np.inf)
    return np.where(np.eye(len(W), dtype=bool), -np.inf, floor)


def mixed_ratio(
    W: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    solver: dict[tuple[int, int], MinMaxRatio],
    lower_end: bool = True,
    progress: Callable[[], object] | None = None,
) -> Extremes:
    """Extremes of max_{a≠a'} (W_a·e)/(W_a'·e) over the box lo ≤ e ≤ hi, for each map W[m] (shape (M, A, n)).

    Upper: the threshold solution of each pair's linear-fractional program, a map at a time (an (A, A, n) temporary).
    Lower: :class:`MinMaxRatio` (one LP per map); NaN without its LPs when ``lower_end`` is False. ``progress`` is
    called after each map's upper end and each map's lower end (M or 2M times).
    """
    from fairaudit.base.threshold_rule import threshold_max_many

    M, A, n = W.shape
    off = ~np.eye(A, dtype=bool)
    vals = np.empty((M, A * A))
    for m in range(M):
        vals[m] = np.where(off, threshold_max_many(W[m, :, None], W[m, None], lo, hi)[0], -np.inf).ravel()
        if progress is not None:
            progress()
    idx = vals.argmax(-1)
    upper = vals[np.arange(M), idx]
    if not lower_end:
        lower = np.full(M, np.nan)
    else:
        program = solver.setdefault((A, n), MinMaxRatio(A, n))
        lower = np.empty(M)
        for m in range(M):
            lower[m] = program.solve(W[m], lo, hi)
            if progress is not None:
                progress()
    if A < 2:
        upper = lower = np.full(M, np.nan)
    return lower, upper, idx // A, idx % A


def mixed_tv(
    W: FloatArray, ev_lo: FloatArray, ev_hi: FloatArray, events: FloatArray, cat_lo: FloatArray, cat_hi: FloatArray
) -> Extremes:
    """Extremes of max_{a≠a'} TV(Q_a, Q_a') with Q_a(S) = W_a·e_S over boxes ev_lo[S] ≤ e_S ≤ ev_hi[S].

    W: (M, A, n); ev_lo, ev_hi: (S, n); cat_lo, cat_hi: (n, K). For each S
    the extremes of the linear (W_a − W_a')·e_S over its box are exact; the
    lower end, a max over S of minima, is valid (it may be below the exact
    min over the set).
    """
    M, A, n = W.shape
    off = ~np.eye(A, dtype=bool)
    if ev_lo.shape[0] == 0:
        zero = np.zeros(M)
        return zero, zero, np.zeros(M, int), np.ones(M, int)
    c = W[:, :, None, :] - W[:, None, :, :]  # (M, A, A, n)
    cp_, cn = np.clip(c, 0, None), np.clip(-c, 0, None)
    up = np.einsum("mabn,sn->mabs", cp_, ev_hi) - np.einsum("mabn,sn->mabs", cn, ev_lo)
    low = np.einsum("mabn,sn->mabs", cp_, ev_lo) - np.einsum("mabn,sn->mabs", cn, ev_hi)
    up_pairs = up.max(-1)
    if events.shape[0] == events.shape[1] and events.shape[1] > MAX_EVENT_DECISIONS:
        hi_u = np.einsum("mabn,nk->mabk", cp_, cat_hi) - np.einsum("mabn,nk->mabk", cn, cat_lo)
        lo_u = np.einsum("mabn,nk->mabk", cp_, cat_lo) - np.einsum("mabn,nk->mabk", cn, cat_hi)
        up_pairs = 0.5 * np.maximum(hi_u, -lo_u).sum(-1)
    up_pairs = np.where(off, np.clip(up_pairs, 0.0, 1.0), -np.inf).reshape(M, -1)
    idx = up_pairs.argmax(-1)
    upper = up_pairs[np.arange(M), idx]
    lower = np.clip(np.where(off, low.max(-1), -np.inf).reshape(M, -1).max(-1), 0.0, 1.0)
    return lower, upper, idx // A, idx % A


def max_over(results: list[Extremes]) -> Extremes:
    """The max over decisions u of per-u (lower, upper, fav, other) results (valid for both ends)."""
    lowers = np.stack([r[0] for r in results])
    uppers = np.stack([r[1] for r in results])
    best = np.where(np.isnan(uppers), -np.inf, uppers).argmax(0)
    cols = np.arange(uppers.shape[1])
    fav = np.stack([r[2] for r in results])[best, cols]
    oth = np.stack([r[3] for r in results])[best, cols]
    low = np.where(np.isnan(lowers), -np.inf, lowers).max(0)
    return np.where(np.isinf(low) & (low < 0), np.nan, low), uppers[best, cols], fav, oth
