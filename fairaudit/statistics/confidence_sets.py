"""The simultaneous sets behind :func:`fairaudit.statistics.intervals.fairness_intervals`, one box per cell.

Each cell's decision distribution gets a box {lower ≤ p ≤ upper} intersected
with the simplex: exact binomial (Clopper–Pearson 1934) bounds per decision,
Bonferroni over the decisions (:func:`category_bounds`) and over the non-empty
cells and pooled groups (:func:`binomial_sets`). Linear functionals of a cell
(E[g | x, a], the probability of a decision event) range over an interval
found in closed form (:func:`linear_extremes`, :func:`event_extremes`). The
Bayesian set maker lives in :mod:`fairaudit.statistics.bayes`; both return
:class:`CellSets`. Proofs: ``proofs/intervals.md`` §2 and §3.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray
from fairaudit.metrics.box_extremes import MAX_EVENT_DECISIONS

__all__ = [
    "CellSets",
    "SetMaker",
    "binomial_sets",
    "category_bounds",
    "clopper_pearson",
    "decision_events",
    "event_extremes",
    "linear_extremes",
    "sum_last",
]


class CellSets(NamedTuple):
    """One simultaneous set: a box per cell (and per pooled group), and how many sets share α.

    Attributes
    ----------
    cell_lower, cell_upper : numpy.ndarray, shape (X, A, K)
        Bounds on each cell's probability of each decision (or category).
    group_lower, group_upper : numpy.ndarray or None, shape (A, C)
        Bounds on each pooled group's distribution; None when not asked for.
    n_sets : int
        Bonferroni's m (0 for the Bayesian band).
    """

    cell_lower: FloatArray
    cell_upper: FloatArray
    group_lower: FloatArray | None
    group_upper: FloatArray | None
    n_sets: int


SetMaker: TypeAlias = Callable[[FloatArray, FloatArray, bool, float], CellSets]
"""(cell counts (X, A, K), group counts (A, C), use_groups, alpha) -> :class:`CellSets`."""


def sum_last(x: npt.ArrayLike, keepdims: bool = False) -> FloatArray:
    """Sum over the last (short: decisions) axis; ``einsum`` is several times faster than ``sum`` there."""
    out = np.einsum("...k->...", np.asarray(x, dtype=float))
    return out[..., None] if keepdims else out


def clopper_pearson(k: npt.ArrayLike, n: npt.ArrayLike, alpha: float) -> tuple[FloatArray, FloatArray]:
    """Exact two-sided binomial interval (Clopper and Pearson 1934), vectorised.

    Parameters
    ----------
    k, n : array_like of int, broadcastable
        Successes and trials, 0 ≤ k ≤ n.
    alpha : float
        1 − level, in (0, 1).

    Returns
    -------
    lower, upper : numpy.ndarray
        Beta quantiles B(α/2; k, n − k + 1) and B(1 − α/2; k + 1, n − k),
        with lower = 0 at k = 0 and upper = 1 at k = n; NaN where n = 0.

    Raises
    ------
    ValueError
        From numpy when ``k`` and ``n`` do not broadcast (values are not
        checked: :func:`fairaudit.statistics.intervals.fairness_intervals` validates the counts).

    Examples
    --------
    >>> lo, hi = clopper_pearson(0, 10, 0.05)      # (0, 1 - 0.025**(1/10))
    >>> float(lo), round(float(hi), 6)
    (0.0, 0.308497)
    """
    # The Beta quantiles from scipy.special, what scipy.stats.beta.ppf and .isf evaluate (the same numbers,
    # tested): scipy.stats alone takes most of a second to import. Imported here, on first use.
    from scipy.special import betainccinv, betaincinv

    kf, nf = np.broadcast_arrays(np.asarray(k, dtype=float), np.asarray(n, dtype=float))
    codes = None
    if (
        kf.size > 256
        and np.all(np.isfinite(nf))
        and nf.max(initial=0) < 2**31
        and kf.min(initial=0) >= 0
        and np.array_equal(kf, np.floor(kf))
        and np.array_equal(nf, np.floor(nf))
    ):
        # a big table repeats few (k, n): the beta quantiles (most of the cost) once per distinct pair
        uniques, codes = np.unique(
            nf.astype(np.int64).ravel() * 2**31 + kf.astype(np.int64).ravel(), return_inverse=True
        )
        shape = kf.shape
        nf, kf = (uniques // 2**31).astype(float), (uniques % 2**31).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        lo = np.where(kf > 0, betaincinv(kf, nf - kf + 1, alpha / 2), 0.0)
        hi = np.where(kf < nf, betainccinv(kf + 1, nf - kf, alpha / 2), 1.0)
    lo, hi = (np.where(nf > 0, v, np.nan) for v in (lo, hi))
    if codes is not None:
        lo, hi = lo[codes].reshape(shape), hi[codes].reshape(shape)
    return lo, hi


def category_bounds(counts: npt.ArrayLike, alpha: float) -> tuple[FloatArray, FloatArray]:
    """A simultaneous multinomial set for each cell: Clopper–Pearson per decision, intersected with the simplex.

    Parameters
    ----------
    counts : array_like of int, shape (..., K)
        Counts of the K decisions in each cell.
    alpha : float
        The error allowed to each cell: the K per-decision intervals are at
        level 1 − α/K (1 − α when K ≤ 2: for two decisions they coincide).

    Returns
    -------
    lower, upper : numpy.ndarray, shape (..., K)
        Bounds (probabilities) with P(lower ≤ p ≤ upper for every decision) ≥ 1 − α per cell
        (Bonferroni over the decisions; ``proofs/intervals.md`` §2),
        tightened by Σ_u p_u = 1. An empty cell gives [0, 1].

    Raises
    ------
    ValueError
        From numpy/scipy on a malformed array (counts are not checked here).

    Examples
    --------
    >>> lo, hi = category_bounds([[0, 10]], 0.05)
    >>> print(lo.round(6).tolist(), hi.round(6).tolist())
    [[0.0, 0.691503]] [[0.308497, 1.0]]
    """
    counts = np.asarray(counts, dtype=float)
    K = counts.shape[-1]
    n = np.broadcast_to(sum_last(counts, keepdims=True), counts.shape)
    lo, hi = clopper_pearson(counts, n, alpha / K if K > 2 else alpha)
    lo = np.where(n > 0, lo, 0.0)
    hi = np.where(n > 0, hi, 1.0)
    lo2 = np.maximum(lo, 1.0 - (sum_last(hi, keepdims=True) - hi))
    hi2 = np.minimum(hi, 1.0 - (sum_last(lo, keepdims=True) - lo))
    lo2 = np.where(lo2 > 1e-12, lo2, 0.0)  # rounding crumbs of the tightening must not turn c/0 = inf into 1e16
    return np.clip(lo2, 0.0, 1.0), np.clip(hi2, 0.0, 1.0)


def linear_extremes(f: npt.ArrayLike, lower: npt.ArrayLike, upper: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """min and max of f·p over {p : lower ≤ p ≤ upper, Σ p = 1}, in closed form, vectorised.

    The LP's solution is a fractional knapsack: start at ``lower`` and give
    the remaining mass 1 − Σ lower to the decisions in decreasing (for the
    max; increasing for the min) order of f, each up to its upper bound.

    Parameters
    ----------
    f, lower, upper : array_like, broadcastable to (..., K)
        Σ lower ≤ 1 ≤ Σ upper (the set is not empty).

    Returns
    -------
    minimum, maximum : numpy.ndarray, shape (...)
        In the units of f. Proof of the greedy solution: ``proofs/intervals.md`` §3.

    Raises
    ------
    ValueError
        From numpy when the shapes do not broadcast (nothing else is checked).

    Examples
    --------
    >>> mn, mx = linear_extremes([0.0, 0.5, 1.0], [0.1, 0.1, 0.1], [0.5, 0.5, 0.5])
    >>> float(mn), float(mx)
    (0.3, 0.7)
    """
    f, lo, hi = np.broadcast_arrays(
        np.asarray(f, dtype=float), np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    )
    base = sum_last(f * lo)
    room = np.clip(1.0 - sum_last(lo), 0.0, None)[..., None]
    cap = hi - lo
    out = []
    for key in (f, -f):
        order = np.argsort(key, axis=-1, kind="stable")
        c = np.take_along_axis(cap, order, -1)
        before = np.cumsum(c, -1) - c
        left = room - before
        alloc = np.where(left > 1e-12, np.clip(left, 0.0, c), 0.0)  # no rounding crumbs: 0 must stay 0 (c/0 = inf)
        out.append(base + sum_last(alloc * np.take_along_axis(f, order, -1)))
    return out[0], out[1]


def event_extremes(events: FloatArray, lower: FloatArray, upper: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`linear_extremes` for 0/1 functionals (events S, rows of ``events``, shape (S, K)), by matrix products.

    For f = 1_S the knapsack gives max P(S) = min(Σ_S upper, 1 − Σ_{not S} lower)
    and min P(S) = max(Σ_S lower, 1 − Σ_{not S} upper). ``lower``, ``upper``:
    shape (..., K). Returns arrays of shape (S, ...).
    """
    s_lo, s_hi = lower @ events.T, upper @ events.T  # (..., S)
    t_lo, t_hi = sum_last(lower, keepdims=True), sum_last(upper, keepdims=True)
    mn = np.maximum(s_lo, 1.0 - (t_hi - s_hi))
    mx = np.minimum(s_hi, 1.0 - (t_lo - s_lo))
    return np.moveaxis(mn, -1, 0), np.moveaxis(mx, -1, 0)


def decision_events(K: int) -> FloatArray:
    """0/1 matrix of decision events S (rows) for the total-variation gaps.

    All nonempty proper subsets when K ≤ 10 (TV = max over S of P(S) − P'(S)
    exactly); singletons otherwise (the callers then bound the upper end by
    ½ Σ_u max |ΔP(u)|, still valid).
    """
    if K < 2:
        return np.zeros((0, K))
    if K > MAX_EVENT_DECISIONS:
        return np.eye(K)
    codes = np.arange(1, 2**K - 1)
    return ((codes[:, None] >> np.arange(K)) & 1).astype(float)


def binomial_sets(cell_counts: FloatArray, group_counts: FloatArray, use_groups: bool, alpha: float) -> CellSets:
    """The exact sets: per-decision Clopper–Pearson bounds, Bonferroni over the non-empty cells (and groups).

    A :data:`SetMaker`; the group bounds are None without ``use_groups``.
    """
    m = int((sum_last(cell_counts) > 0).sum()) + (int((sum_last(group_counts) > 0).sum()) if use_groups else 0)
    a_cell = alpha / max(m, 1)
    c_lo, c_hi = category_bounds(cell_counts, a_cell)
    g_lo, g_hi = category_bounds(group_counts, a_cell) if use_groups else (None, None)
    return CellSets(c_lo, c_hi, g_lo, g_hi, m)
