"""Finite-sample intervals: one simultaneous confidence set for a law estimated from counts, every metric over it.

A table of counts ``n[x, a, u]`` (decision records per context, group and
decision) estimates each cell's decision distribution P(U | x, a). Every
method here builds **one** confidence set C for all of those distributions at
once, with P(C contains the true law) ≥ 1 − α, and reports for each metric
the interval [min over C, max over C] (the projection of C). All the
intervals of one result therefore hold *simultaneously*: the maximum over
cells is never treated as a single cell.

Methods (``method=``):

``"clopper-pearson"``
    For an indicator utility g ∈ {0, 1}: each cell's probability of g = 1 gets
    an exact binomial (Clopper–Pearson 1934) interval at level 1 − α/m, with m
    the number of non-empty cells (plus groups, see below): Bonferroni. Exact
    coverage ≥ 1 − α whatever the counts. L_dp, L_eo and the sups over g are
    about U's whole distribution, so they are given only when U is binary.
``"multinomial"``
    For any bounded utility: each cell's distribution lies in the polytope
    {p in the simplex : lo_u ≤ p_u ≤ hi_u}, with Clopper–Pearson bounds at
    level 1 − α/(m K) per decision (K decisions; K = 2 needs one interval per
    cell since the two coincide). Coverage ≥ 1 − α by Bonferroni, whatever
    the counts. E[g | x, a] ranges over an interval found in closed form (a
    fractional knapsack, checked against the LP in the tests); ratios of
    groups are extremised by the linear-fractional engine
    (:mod:`fairaudit.lfp`; cvxpy + Clarabel where the groups share cells).
``"bayes"``
    Each cell's distribution has the posterior Dirichlet(n[x, a, :] + c/K)
    (``concentration`` c; c = 1 gives the posterior mean that AIF360's
    ``smoothed_empirical_differential_fairness`` uses). ``draws`` samples with
    ``seed``; the simultaneous credible set is the rank-based band of Besag
    et al. (1995) over every cell probability: a box per cell, projected onto
    the metrics like the polytopes above. A credible set, not a confidence
    set: its frequentist coverage is measured (``benchmarks/bench_coverage.py``),
    not guaranteed.

Global metrics (L̄, L_dp, sup over g of L̄): without a population, records
are taken to be i.i.d. draws of (X, A, U), so within group a the records are
i.i.d. with law P(U | a) (or P(X, U | a) when g depends on the context);
those pooled per-group distributions get their own sets, counted in m. With
a population P(X, A) (as in a spec), E[g | a] = Σ_x P(x | a) E[g | x, a] is
a fixed linear map of the cells.

Behind a privacy filter (``sensitive_mechanism`` M_A, ``context_mechanism``
M_X): the counts are those of the decision model's kernel K[x̃, ã, u] (its
decisions on released values), and the audited law is
Q[x, a, u] = Σ M_X[x, x̃] M_A[a, ã] K[x̃, ã, u]. Groups then share kernel
cells, and the extremes of each ratio over C are linear-fractional programs:
the upper end by the threshold solution over the box of kernel cells
(:func:`fairaudit.lfp.threshold_max_many`), the lower end by the
Charnes–Cooper LP of min over the box of max_a E_a / min_a E_a. The upper end
of L is the white-box certificate at level 1 − α; a lower end above 0 is
evidence of unfairness.

Zero counts give a finite lower end and an honest upper end (+inf where the
data cannot exclude a zero expected utility). An empty cell constrains
nothing: its distribution may be anything.

Proof of the projection argument and the LP: ``proofs/intervals.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass, field
from typing import NotRequired, TypeAlias, TypedDict

import numpy as np
import numpy.typing as npt

from ._arrays import BoolArray, FloatArray, IntArray, format_label
from ._errors import InputError
from .estimate import CountTable
from .laws import Kernel, Law, Population, compose
from .privacy import Mechanism
from .utility import Utility

__all__ = [
    "METHODS",
    "Interval",
    "FairnessIntervals",
    "fairness_intervals",
    "clopper_pearson",
    "category_bounds",
    "linear_extremes",
]

METHODS = ("clopper-pearson", "multinomial", "bayes")
_MAX_EVENT_DECISIONS = 10  # up to 2^10 - 2 events for the total-variation gaps; beyond, a valid coarser bound

CellSets: TypeAlias = tuple[FloatArray, FloatArray, FloatArray | None, FloatArray | None, int]
"""Simultaneous sets: (cell lower, cell upper, group lower, group upper, m), group bounds None when not asked."""
SetMaker: TypeAlias = Callable[[FloatArray, FloatArray, bool, float], CellSets]
"""(cell counts (X, A, K), group counts (A, C), use_groups, alpha) -> :data:`CellSets`."""
_Extremes: TypeAlias = tuple[FloatArray, FloatArray, IntArray, IntArray]
"""Per map: (lower, upper, favoured group, other group)."""


@dataclass(frozen=True)
class Interval:
    """An interval for one metric, with how it was made.

    Attributes
    ----------
    lower, upper : float
        The ends, in the metric's units (nats for L, L̄ and the sups; a
        probability for L_dp and L_eo). ``upper`` may be +inf.
    estimate : float
        The point estimate (plug-in of the empirical law; for ``"bayes"``,
        of the posterior mean).
    confidence : float
        1 − α, shared by every interval of one :class:`FairnessIntervals`.
    method : str
        One of :data:`METHODS`.
    context, group, other_group : hashable or None
        Where the upper end is attained: the context (None for global
        metrics) and the pair of groups, ``group`` the favoured one.

    Examples
    --------
    >>> iv = Interval(0.1, 0.7, 0.3, 0.95, "multinomial")
    >>> lo, hi = iv
    >>> (lo, hi), iv.width, 0.5 in iv
    ((0.1, 0.7), 0.6, True)
    """

    lower: float
    upper: float
    estimate: float
    confidence: float
    method: str
    context: Hashable | None = None
    group: Hashable | None = None
    other_group: Hashable | None = None

    def __iter__(self) -> Iterator[float]:
        return iter((self.lower, self.upper))

    def __contains__(self, value: float) -> bool:
        return bool(self.lower <= value <= self.upper)

    @property
    def width(self) -> float:
        """upper − lower (+inf when the upper end is)."""
        return self.upper - self.lower


@dataclass(frozen=True, eq=False)
class FairnessIntervals:
    """Simultaneous intervals for every metric of a law estimated from counts.

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    confidence : float
        1 − α: all intervals hold together with probability ≥ 1 − α (for
        ``"bayes"``, posterior probability).
    local, global_ : Interval
        L and L̄ in nats.
    sup_local, sup_global : Interval or None
        Sups over g of L and L̄ (Lemma 1), nats; None with
        ``"clopper-pearson"`` when U is not binary.
    demographic_parity, equalized_odds : Interval or None
        L_dp and L_eo (total variation, in [0, 1]); None as above.
    cell_lower, cell_upper : numpy.ndarray, shape (n_contexts, n_groups)
        Simultaneous bounds on E[g | x, a] of the audited law (the filtered
        law behind a privacy filter).
    group_lower, group_upper : numpy.ndarray, shape (n_groups,)
        Bounds on E[g | a].
    kernel_lower, kernel_upper : numpy.ndarray or None, shape (n_released_contexts, n_released_groups)
        Behind a filter: bounds on E[g | x̃, ã] of the counted kernel.
    n_sets : int
        How many per-cell (and per-group) sets share α (Bonferroni's m);
        0 for ``"bayes"``.
    table, utility, sensitive_mechanism, context_mechanism, population
        The inputs (mechanisms None when not filtered; population None when
        the records' own, pooled, was used).
    concentration, draws, seed : float, int, int or None
        The Bayesian settings (None for the other methods).
    notes : tuple of str
        What was not computed or is conservative, and why.
    """

    method: str
    confidence: float
    local: Interval
    global_: Interval
    sup_local: Interval | None
    sup_global: Interval | None
    demographic_parity: Interval | None
    equalized_odds: Interval | None
    cell_lower: FloatArray
    cell_upper: FloatArray
    group_lower: FloatArray
    group_upper: FloatArray
    kernel_lower: FloatArray | None
    kernel_upper: FloatArray | None
    n_sets: int
    table: CountTable
    utility: Utility
    sensitive_mechanism: Mechanism | None
    context_mechanism: Mechanism | None
    population: Population | None
    concentration: float | None = None
    draws: int | None = None
    seed: int | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    def intervals(self) -> dict[str, Interval | None]:
        """The metric intervals by name (None where not computed)."""
        return {
            "local": self.local,
            "global": self.global_,
            "sup_local": self.sup_local,
            "sup_global": self.sup_global,
            "demographic_parity": self.demographic_parity,
            "equalized_odds": self.equalized_odds,
        }


# ---------------------------------------------------------------- per-cell sets


class _Inputs(TypedDict):
    """The fields of a :class:`FairnessIntervals` that repeat its inputs."""

    table: CountTable
    utility: Utility
    sensitive_mechanism: Mechanism | None
    context_mechanism: Mechanism | None
    population: Population | None
    concentration: NotRequired[float]
    draws: NotRequired[int]
    seed: NotRequired[int]


def _sum_last(x: npt.ArrayLike, keepdims: bool = False) -> FloatArray:
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
        checked: :func:`fairness_intervals` validates the counts).

    Examples
    --------
    >>> lo, hi = clopper_pearson(0, 10, 0.05)      # (0, 1 - 0.025**(1/10))
    >>> float(lo), round(float(hi), 6)
    (0.0, 0.308497)
    """
    from scipy import stats  # imported here: scipy.stats adds ~1 s to every start of the command

    k, n = np.broadcast_arrays(np.asarray(k, dtype=float), np.asarray(n, dtype=float))
    codes = None
    if (
        k.size > 256
        and np.all(np.isfinite(n))
        and n.max(initial=0) < 2**31
        and k.min(initial=0) >= 0
        and np.array_equal(k, np.floor(k))
        and np.array_equal(n, np.floor(n))
    ):
        # a big table repeats few (k, n): the beta quantiles (most of the cost) once per distinct pair
        import pandas as pd

        codes, uniques = pd.factorize(n.astype(np.int64).ravel() * 2**31 + k.astype(np.int64).ravel())
        shape = k.shape
        n, k = (uniques // 2**31).astype(float), (uniques % 2**31).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        lo = np.where(k > 0, stats.beta.ppf(alpha / 2, k, n - k + 1), 0.0)
        hi = np.where(k < n, stats.beta.isf(alpha / 2, k + 1, n - k), 1.0)
    lo = np.where(n > 0, lo, np.nan)
    hi = np.where(n > 0, hi, np.nan)
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
    n = np.broadcast_to(_sum_last(counts, keepdims=True), counts.shape)
    lo, hi = clopper_pearson(counts, n, alpha / K if K > 2 else alpha)
    lo = np.where(n > 0, lo, 0.0)
    hi = np.where(n > 0, hi, 1.0)
    lo2 = np.maximum(lo, 1.0 - (_sum_last(hi, keepdims=True) - hi))
    hi2 = np.minimum(hi, 1.0 - (_sum_last(lo, keepdims=True) - lo))
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
    base = _sum_last(f * lo)
    room = np.clip(1.0 - _sum_last(lo), 0.0, None)[..., None]
    cap = hi - lo
    out = []
    for key in (f, -f):
        order = np.argsort(key, axis=-1, kind="stable")
        c = np.take_along_axis(cap, order, -1)
        before = np.cumsum(c, -1) - c
        left = room - before
        alloc = np.where(left > 1e-12, np.clip(left, 0.0, c), 0.0)  # no rounding crumbs: 0 must stay 0 (c/0 = inf)
        out.append(base + _sum_last(alloc * np.take_along_axis(f, order, -1)))
    return out[0], out[1]


def _event_extremes(events: FloatArray, lower: FloatArray, upper: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`linear_extremes` for 0/1 functionals (events S, rows of ``events``, shape (S, K)), by matrix products.

    For f = 1_S the knapsack gives max P(S) = min(Σ_S upper, 1 − Σ_{not S} lower)
    and min P(S) = max(Σ_S lower, 1 − Σ_{not S} upper). ``lower``, ``upper``:
    shape (..., K). Returns arrays of shape (S, ...).
    """
    s_lo, s_hi = lower @ events.T, upper @ events.T  # (..., S)
    t_lo, t_hi = _sum_last(lower, keepdims=True), _sum_last(upper, keepdims=True)
    mn = np.maximum(s_lo, 1.0 - (t_hi - s_hi))
    mx = np.minimum(s_hi, 1.0 - (t_lo - s_lo))
    return np.moveaxis(mn, -1, 0), np.moveaxis(mx, -1, 0)


def _events(K: int) -> FloatArray:
    """0/1 matrix of decision events S (rows) for the total-variation gaps.

    All nonempty proper subsets when K ≤ 10 (TV = max over S of P(S) − P'(S)
    exactly); singletons otherwise (the callers then bound the upper end by
    ½ Σ_u max |ΔP(u)|, still valid).
    """
    if K < 2:
        return np.zeros((0, K))
    if K > _MAX_EVENT_DECISIONS:
        return np.eye(K)
    codes = np.arange(1, 2**K - 1)
    return ((codes[:, None] >> np.arange(K)) & 1).astype(float)


# ---------------------------------------------------------------- ratio and gap extremes


def _div(num: npt.ArrayLike, den: npt.ArrayLike) -> FloatArray:
    """num / den with c/0 = +inf (c > 0) and 0/0 = 1."""
    num, den = np.broadcast_arrays(np.asarray(num, dtype=float), np.asarray(den, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 1.0))


def _log(x: float) -> float:
    if math.isnan(x):
        return math.nan
    return math.inf if x == math.inf else math.log(max(x, 1.0))


def _disjoint_ratio(lo: FloatArray, hi: FloatArray) -> _Extremes:
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
    best_a = np.where(valid & np.isfinite(den), _div(hi0, np.where(np.isfinite(den), den, 1.0)), -np.inf)
    a = best_a.argmax(-1)  # the first a of the first maximal pair
    row = np.where(valid & (cols[None, :] != a[:, None]), _div(hi0[rows, a][:, None], np.nan_to_num(lo)), -np.inf)
    b = row.argmax(-1)  # its first b
    upper = row[rows, b]
    idx = a * A + b
    enough = valid.sum(-1) >= 2
    lower = np.maximum(1.0, _div(np.where(valid, lo, -np.inf).max(-1), np.where(valid, hi, np.inf).min(-1)))
    upper = np.where(enough, upper, np.nan)
    lower = np.where(enough, lower, np.nan)
    return lower, upper, idx // A, idx % A


def _pair_gap(big: FloatArray, small: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
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


def _disjoint_tv(
    lo: FloatArray, hi: FloatArray, events: FloatArray, cat_lo: FloatArray, cat_hi: FloatArray
) -> _Extremes:
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
    if events.shape[0] == events.shape[1] and events.shape[1] > _MAX_EVENT_DECISIONS:
        off = ~np.eye(A, dtype=bool)
        d = np.maximum(cat_hi[:, :, None, :] - cat_lo[:, None, :, :], cat_hi[:, None, :, :] - cat_lo[:, :, None, :])
        up_pairs = np.where(off, np.clip(0.5 * np.clip(d, 0.0, None).sum(-1), 0.0, 1.0), -np.inf).reshape(M, -1)
        idx = up_pairs.argmax(-1)
        upper, fav, oth = up_pairs[rows, idx], idx // A, idx % A
    else:
        val, f, o = _pair_gap(hi.transpose(0, 2, 1), lo.transpose(0, 2, 1))  # (M, S)
        s = val.argmax(-1)
        upper, fav, oth = np.clip(val[rows, s], 0.0, 1.0), f[rows, s], o[rows, s]
    low, _, _ = _pair_gap(lo.transpose(0, 2, 1), hi.transpose(0, 2, 1))
    lower = np.clip(low.max(-1), 0.0, 1.0)
    return lower, upper, fav, oth


class _MinMaxRatio:
    """min over lower ≤ e ≤ upper of max_a (W_a·e) / min_a (W_a·e), by the Charnes–Cooper LP.

    With y = t e and t = 1 / min_a W_a·e: minimise σ subject to W y ≤ σ,
    W y ≥ 1, t·lower ≤ y ≤ t·upper, t ≥ 0 (``proofs/intervals.md``). Built
    once per shape with cvxpy parameters and solved with Clarabel.
    """

    def __init__(self, A: int, n: int) -> None:
        import cvxpy as cp

        self.W = cp.Parameter((A, n), nonneg=True)
        self.lo = cp.Parameter(n, nonneg=True)
        self.hi = cp.Parameter(n, nonneg=True)
        y, t, sigma = cp.Variable(n), cp.Variable(nonneg=True), cp.Variable()
        self.problem = cp.Problem(
            cp.Minimize(sigma),
            [self.W @ y <= sigma, self.W @ y >= 1, y >= cp.multiply(self.lo, t), y <= cp.multiply(self.hi, t)],
        )

    def solve(self, W: FloatArray, lo: FloatArray, hi: FloatArray) -> float:
        import cvxpy as cp

        from .lfp import _solve

        if np.all(W @ lo <= 0):  # every group can be at 0 together: 0/0, parity
            return 1.0
        if np.any(W @ hi <= 0):  # some group is always 0 while another can be positive
            return math.inf
        pairwise = _pairwise_floor(W, lo, hi)
        self.W.value, self.lo.value, self.hi.value = W, lo, hi
        _solve(self.problem)
        if self.problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return pairwise  # badly scaled boxes (upper ends near 1e-12) defeat the solver: keep the valid floor
        # The solver stops within ~1e-9 of the optimum; shade by that much so the lower end stays a lower end.
        value = float(self.problem.value) * (1.0 - 1e-9)
        return max(pairwise, value if value > 1.0 + 1e-9 else 1.0)


def _pairwise_floor(W: FloatArray, lo: FloatArray, hi: FloatArray) -> float:
    """max over pairs of min over the box of (W_a·e)/(W_a'·e): a valid floor of the min-max ratio, in closed form.

    min of a max ≥ max of the mins; each min is 1 / the threshold maximum of
    the inverse ratio. Exact when the groups use disjoint cells.
    """
    from .lfp import threshold_max_many

    A = W.shape[0]
    inv, _, _ = threshold_max_many(W[None, :, :], W[:, None, :], lo, hi)  # [a, a'] = max (W_a'·e)/(W_a·e)
    with np.errstate(divide="ignore"):
        mins = np.where(inv > 0, 1.0 / inv, np.inf)
    mins = np.where(np.eye(A, dtype=bool), 1.0, mins)
    return max(1.0, float(mins.max()))


def _mixed_ratio(
    W: FloatArray, lo: FloatArray, hi: FloatArray, solver: dict[tuple[int, int], _MinMaxRatio]
) -> _Extremes:
    """Extremes of max_{a≠a'} (W_a·e)/(W_a'·e) over the box lo ≤ e ≤ hi, for each map W[m] (shape (M, A, n)).

    Upper: the threshold solution of each pair's linear-fractional program.
    Lower: :class:`_MinMaxRatio` (one LP per map).
    """
    from .lfp import threshold_max_many

    M, A, n = W.shape
    vals, _, _ = threshold_max_many(W[:, :, None, :], W[:, None, :, :], lo, hi)
    vals = np.where(~np.eye(A, dtype=bool), vals, -np.inf).reshape(M, -1)
    idx = vals.argmax(-1)
    upper = vals[np.arange(M), idx]
    key = (A, n)
    if key not in solver:
        solver[key] = _MinMaxRatio(A, n)
    lower = np.array([solver[key].solve(W[m], lo, hi) for m in range(M)])
    if A < 2:
        upper = lower = np.full(M, np.nan)
    return lower, upper, idx // A, idx % A


def _mixed_tv(
    W: FloatArray, ev_lo: FloatArray, ev_hi: FloatArray, events: FloatArray, cat_lo: FloatArray, cat_hi: FloatArray
) -> _Extremes:
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
    if events.shape[0] == events.shape[1] and events.shape[1] > _MAX_EVENT_DECISIONS:
        hi_u = np.einsum("mabn,nk->mabk", cp_, cat_hi) - np.einsum("mabn,nk->mabk", cn, cat_lo)
        lo_u = np.einsum("mabn,nk->mabk", cp_, cat_lo) - np.einsum("mabn,nk->mabk", cn, cat_hi)
        up_pairs = 0.5 * np.maximum(hi_u, -lo_u).sum(-1)
    up_pairs = np.where(off, np.clip(up_pairs, 0.0, 1.0), -np.inf).reshape(M, -1)
    idx = up_pairs.argmax(-1)
    upper = up_pairs[np.arange(M), idx]
    lower = np.clip(np.where(off, low.max(-1), -np.inf).reshape(M, -1).max(-1), 0.0, 1.0)
    return lower, upper, idx // A, idx % A


# ---------------------------------------------------------------- the entry point


def _check(table: object, utility: object, confidence: float, method: str, concentration: float, draws: int) -> None:
    if not isinstance(table, CountTable):
        raise InputError("table", "must be a CountTable (fairaudit.count_records or count_table)", type(table).__name__)
    if not isinstance(utility, Utility):
        raise InputError("utility", "must be a Utility", type(utility).__name__)
    try:
        ok = 0.0 < float(confidence) < 1.0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError("--confidence", "must lie strictly between 0 and 1", confidence)
    if method not in METHODS + ("auto",):
        raise InputError("--method", f"must be one of {', '.join(METHODS)}", method)
    counts = np.asarray(table.counts, dtype=float)
    if np.any(counts != np.round(counts)):
        bad = counts[counts != np.round(counts)].flat[0]
        raise InputError(
            "counts", "intervals need whole numbers of records (the table holds probabilities or weights)", float(bad)
        )
    if method == "bayes":
        if not (isinstance(concentration, (int, float)) and math.isfinite(concentration) and concentration > 0):
            raise InputError("--concentration", "must be a finite number > 0", concentration)
        if not (isinstance(draws, (int, np.integer)) and draws >= 100):
            raise InputError("--draws", "must be a whole number >= 100", draws)


def _is_indicator(g: FloatArray) -> bool:
    return bool(np.all((g == 0.0) | (g == 1.0)))


def fairness_intervals(
    table: CountTable,
    utility: Utility,
    confidence: float = 0.95,
    method: str = "auto",
    *,
    sensitive_mechanism: Mechanism | None = None,
    context_mechanism: Mechanism | None = None,
    population: Population | None = None,
    concentration: float = 1.0,
    draws: int = 4000,
    seed: int = 0,
) -> FairnessIntervals:
    """Simultaneous (1 − α) intervals for E[g | x, a], E[g | a], L, L̄, the sups over g, L_dp and L_eo.

    Parameters
    ----------
    table : CountTable
        Counts, shape (n_contexts, n_groups, n_decisions): of the law itself,
        or, with a mechanism, of the decision model's kernel on released
        values (n_released_contexts, n_released_groups, n_decisions).
    utility : Utility
        g ≥ 0 over the table's decisions (and contexts and groups). Behind a
        filter it must depend on the decision only.
    confidence : float
        1 − α in (0, 1).
    method : {"auto", "clopper-pearson", "multinomial", "bayes"}
        "auto" is "clopper-pearson" for a 0/1 utility, "multinomial" otherwise.
    sensitive_mechanism, context_mechanism : Mechanism, optional
        M_A (n_groups × n_released_groups) and M_X; their outputs must be the
        table's groups and contexts.
    population : Population, optional
        P(X, A) for global metrics (and to leave out contexts with P(x) = 0).
        Default: the records' own groups, pooled (unfiltered); uniform and
        independent behind a filter.
    concentration, draws, seed
        The Bayesian prior Dirichlet(c/K, ..., c/K), the number of posterior
        samples and the random seed (``method="bayes"`` only).

    Returns
    -------
    FairnessIntervals

    Raises
    ------
    InputError
        On a confidence outside (0, 1), an unknown method, a non-indicator
        utility with "clopper-pearson", counts that are not whole numbers,
        mechanisms that do not match the table, a utility that depends on the
        context or group behind a filter, or bad Bayesian settings.

    Notes
    -----
    Sources: the projection argument, the sets and the programs are proved in
    ``proofs/intervals.md``; exact binomial intervals from Clopper and
    Pearson (1934, Biometrika 26); the Bayesian band from Besag, Green,
    Higdon and Mengersen (1995, Statist. Sci. 10, sec. 4.3); the metrics are
    those of the paper's SI A and B (:mod:`fairaudit.metrics`). Lower ends of
    the sups over g and of L_dp, L_eo are valid but may be below the exact
    minimum over the set (a max of minima); every upper end is exact.

    Examples
    --------
    Two groups, 30/50 and 20/50 selected: L = log 1.5 lies inside.

    >>> import pandas as pd
    >>> from fairaudit import count_records, indicator
    >>> t = count_records(pd.DataFrame({"g": ["a"] * 50 + ["b"] * 50,
    ...                                 "y": [1] * 30 + [0] * 20 + [1] * 20 + [0] * 30}), sensitive=["g"], outcome="y")
    >>> iv = fairness_intervals(t, indicator(1, t.decisions), 0.95)
    >>> iv.method, round(iv.local.estimate, 6), iv.local.lower < iv.local.estimate < iv.local.upper
    ('clopper-pearson', 0.405465, True)
    >>> iv.local.group, iv.local.other_group
    ('a', 'b')
    """
    _check(table, utility, confidence, method, concentration, draws)
    confidence = float(confidence)
    alpha = 1.0 - confidence
    counts = np.asarray(table.counts, dtype=float)
    X, A, K = counts.shape
    g = np.asarray(utility.table(table.contexts, table.groups, table.decisions), dtype=float)
    if method == "auto":
        method = "clopper-pearson" if _is_indicator(g) else "multinomial"
    if method == "clopper-pearson" and not _is_indicator(g):
        raise InputError(
            "--method", "clopper-pearson needs a 0/1 utility; use multinomial or bayes for this utility", utility.name
        )
    filtered = not (_identity(sensitive_mechanism, table.groups) and _identity(context_mechanism, table.contexts))
    m_a: Mechanism | None
    m_x: Mechanism | None
    if filtered:
        m_a = sensitive_mechanism if sensitive_mechanism is not None else _eye(table.groups)
        m_x = context_mechanism if context_mechanism is not None else _eye(table.contexts)
        if tuple(m_a.outputs) != tuple(table.groups):
            raise InputError(
                "sensitive mechanism",
                f"outputs must be the table's groups {list(map(format_label, table.groups))}",
                list(map(format_label, m_a.outputs)),
            )
        if tuple(m_x.outputs) != tuple(table.contexts):
            raise InputError(
                "context mechanism",
                f"outputs must be the table's contexts {list(map(format_label, table.contexts))}",
                list(map(format_label, m_x.outputs)),
            )
        if utility.depends_on_context or utility.depends_on_group:
            raise InputError(
                "utility", "behind a privacy filter intervals need a utility of the decision only", utility.name
            )
        if population is None:
            population = Population.uniform(m_x.inputs, m_a.inputs, source="assumed")
        law_groups, law_contexts = tuple(m_a.inputs), tuple(m_x.inputs)
    else:
        m_a, m_x = None, None
        law_groups, law_contexts = table.groups, table.contexts
    if population is not None and (
        tuple(population.groups) != law_groups or tuple(population.contexts) != law_contexts
    ):
        raise InputError(
            "population",
            "labels must be the audited law's contexts and groups",
            (list(map(format_label, population.contexts)), list(map(format_label, population.groups))),
        )

    prior = concentration / K if method == "bayes" else 0.0  # bayes: the plug-in of the posterior mean
    estimate = _estimates(table, counts + prior, utility, filtered, m_a, m_x, population)
    common = _Inputs(
        table=table, utility=utility, sensitive_mechanism=m_a, context_mechanism=m_x, population=population
    )
    ctx_keep = np.ones(len(law_contexts), bool) if population is None else population.p_context > 0
    sets: SetMaker = _binomial_sets
    if method == "bayes":
        from ._bayes import band_sets

        sets = band_sets(concentration, int(draws), int(seed))
        common["concentration"], common["draws"], common["seed"] = float(concentration), int(draws), int(seed)
    return _frequentist(
        counts,
        g,
        alpha,
        method,
        estimate,
        law_contexts,
        law_groups,
        ctx_keep,
        filtered,
        m_a,
        m_x,
        population,
        common,
        sets,
    )


def _identity(mech: Mechanism | None, labels: tuple) -> bool:
    if mech is None:
        return True
    return tuple(mech.inputs) == tuple(labels) and mech.is_identity


def _eye(labels: tuple) -> Mechanism:
    from .privacy import identity

    return identity(labels)


def _estimates(
    table: CountTable,
    counts: FloatArray,
    utility: Utility,
    filtered: bool,
    m_a: Mechanism | None,
    m_x: Mechanism | None,
    population: Population | None,
) -> dict[str, float]:
    """Plug-in values of every metric for the law ``counts`` / their row sums (NaN where empty cells matter).

    ``counts`` are the table's, plus the prior's pseudo-counts c/K for the posterior mean of ``"bayes"``
    ((n + c/K) / (N + c), AIF360's smoothing). The population defaults to the records' own.
    """
    from .certify import observe

    if filtered:
        if np.any(_sum_last(counts) == 0):
            return {}
        law = compose(Kernel.from_counts(counts, table.contexts, table.groups, table.decisions), m_a, m_x)
    else:
        law = Law.from_counts(counts, table.contexts, table.groups, table.decisions)
    pop = population if population is not None else table.population()
    o = observe(law, utility, pop)
    return {
        "local": o.local.value,
        "global": o.global_.value,
        "sup_local": o.sup_local.value,
        "sup_global": o.sup_global.value,
        "demographic_parity": o.demographic_parity.value,
        "equalized_odds": o.equalized_odds.value,
    }


def _make(
    name: str,
    lower: npt.ArrayLike,
    upper: npt.ArrayLike,
    idx: tuple[IntArray, IntArray],
    keys: list[int],
    contexts: tuple,
    groups: tuple,
    estimate: dict[str, float],
    confidence: float,
    method: str,
    local: bool,
) -> Interval:
    """One Interval from per-map ends (maps are contexts for local metrics, one map for global)."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    fav, oth = idx
    if np.all(np.isnan(upper)):
        return Interval(math.nan, math.nan, estimate.get(name, math.nan), confidence, method)
    m = int(np.nanargmax(upper))
    lo, hi = float(np.nanmax(lower)), float(upper[m])
    ratio = name not in ("demographic_parity", "equalized_odds")
    if ratio:
        lo, hi = _log(lo), _log(hi)
    return Interval(
        lo,
        hi,
        float(estimate.get(name, math.nan)),
        confidence,
        method,
        contexts[keys[m]] if local else None,
        groups[int(fav[m])],
        groups[int(oth[m])],
    )


def _binomial_sets(cell_counts: FloatArray, group_counts: FloatArray, use_groups: bool, alpha: float) -> CellSets:
    """The exact sets: per-decision Clopper–Pearson bounds, Bonferroni over the non-empty cells (and groups).

    Returns (cell lower, cell upper, group lower, group upper, m); the group bounds are None without ``use_groups``.
    """
    m = int((_sum_last(cell_counts) > 0).sum()) + (int((_sum_last(group_counts) > 0).sum()) if use_groups else 0)
    a_cell = alpha / max(m, 1)
    c_lo, c_hi = category_bounds(cell_counts, a_cell)
    g_lo, g_hi = category_bounds(group_counts, a_cell) if use_groups else (None, None)
    return c_lo, c_hi, g_lo, g_hi, m


def _frequentist(
    counts: FloatArray,
    g: FloatArray,
    alpha: float,
    method: str,
    estimate: dict[str, float],
    contexts: tuple,
    groups: tuple,
    ctx_keep: BoolArray,
    filtered: bool,
    m_a: Mechanism | None,
    m_x: Mechanism | None,
    population: Population | None,
    common: _Inputs,
    sets: SetMaker = _binomial_sets,
) -> FairnessIntervals:
    X, A, K = counts.shape
    depends_on_context = bool(g.ndim == 3 and X > 1 and not np.all(g == g[:1]))
    pooled = population is None  # unfiltered, records' own groups
    if method == "clopper-pearson":
        k = _sum_last(counts * g)
        cell_counts = np.stack([_sum_last(counts) - k, k], -1)
        gf = np.broadcast_to(np.array([0.0, 1.0]), (X, A, 2))
        binary_u = K == 2 and not np.all(g == g[..., :1])
        group_counts = cell_counts.sum(0)
        g_group = np.array([0.0, 1.0])
    else:
        cell_counts, gf, binary_u = counts, np.broadcast_to(g, (X, A, K)), True
        if depends_on_context:
            group_counts = counts.transpose(1, 0, 2).reshape(A, X * K)  # joint (x, u) per group
            g_group = g.transpose(1, 0, 2).reshape(A, X * K) if g.ndim == 3 else np.tile(g, X)
        else:
            group_counts = counts.sum(0)
            g_group = gf[0]  # (A, K)
    shared = pooled and X == 1 and group_counts.shape[-1] == cell_counts.shape[-1]  # one context: groups are cells
    c_lo, c_hi, gc_lo, gc_hi, m = sets(cell_counts, group_counts, pooled and not shared, alpha)  # (X, A, K'), (A, C)
    if shared:
        gc_lo, gc_hi = c_lo[0], c_hi[0]
    e_lo, e_hi = linear_extremes(gf, c_lo, c_hi)  # (X, A)
    notes: list[str] = []
    solver: dict[tuple[int, int], _MinMaxRatio] = {}
    kc = cell_counts.shape[-1]
    events = _events(kc)
    ev_lo, ev_hi = (
        _event_extremes(events, c_lo, c_hi) if len(events) else (np.zeros((0, X, A)), np.zeros((0, X, A)))
    )  # (S, X, A)
    with_u = method != "clopper-pearson" or binary_u
    if not with_u:
        notes.append(
            "clopper-pearson bounds the event g = 1 only: the sups over g, L_dp and L_eo need U's whole "
            "distribution (use multinomial or bayes)"
        )
    if kc > _MAX_EVENT_DECISIONS:
        notes.append(f"{kc} decisions: the upper ends of L_dp and L_eo use the coarser bound ½ Σ_u max |ΔP(u)|")
    res: dict[str, tuple[_Extremes, IntArray | list[int]]] = {}  # metric -> (ends per map, the maps' context indices)
    local_keys = np.flatnonzero(ctx_keep)
    if not filtered:
        sl = local_keys
        res["local"] = (_disjoint_ratio(e_lo[sl], e_hi[sl]), sl)
        if with_u:
            sup = [_disjoint_ratio(c_lo[sl, :, u], c_hi[sl, :, u]) for u in range(kc)]
            res["sup_local"] = (_max_over(sup), sl)
            res["equalized_odds"] = (
                _disjoint_tv(
                    ev_lo[:, sl].transpose(1, 2, 0), ev_hi[:, sl].transpose(1, 2, 0), events, c_lo[sl], c_hi[sl]
                ),
                sl,
            )
        if population is None:  # pooled
            assert gc_lo is not None and gc_hi is not None  # the group sets were asked for, or are the cells'
            ge_lo, ge_hi = linear_extremes(g_group, gc_lo, gc_hi)
            if with_u:
                fold = _fold(depends_on_context and method != "clopper-pearson", X, kc)  # categories -> decisions
                gev = events @ fold if fold is not None else events  # (S, C)
                gev_lo, gev_hi = _event_extremes(gev, gc_lo, gc_hi)  # (S, A)
                gu = fold if fold is not None else np.eye(kc)  # (K, C)
                gu_lo, gu_hi = _event_extremes(gu, gc_lo, gc_hi)  # (K, A)
        else:
            w = population.context_given_group()  # (X, A)
            w = np.where(np.isnan(w), 0.0, w)
            absent = population.p_group <= 0
            ge_lo, ge_hi = (w * e_lo).sum(0), (w * e_hi).sum(0)
            if with_u:
                gev_lo, gev_hi = np.einsum("xa,sxa->sa", w, ev_lo), np.einsum("xa,sxa->sa", w, ev_hi)
                gu_lo, gu_hi = np.einsum("xa,xak->ka", w, c_lo), np.einsum("xa,xak->ka", w, c_hi)
            ge_lo, ge_hi = np.where(absent, np.nan, ge_lo), np.where(absent, np.nan, ge_hi)
        res["global"] = (_disjoint_ratio(ge_lo[None], ge_hi[None]), [0])
        if with_u:
            res["sup_global"] = (_max_over([_disjoint_ratio(gu_lo[u][None], gu_hi[u][None]) for u in range(kc)]), [0])
            res["demographic_parity"] = (
                _disjoint_tv(gev_lo.T[None], gev_hi.T[None], events, gu_lo.T[None], gu_hi.T[None]),
                [0],
            )
        cell_lo, cell_hi = e_lo, e_hi
        kernel_lo = kernel_hi = None
    else:
        assert m_a is not None and m_x is not None and population is not None  # behind a filter all are set
        Wl = np.einsum("xy,ab->xayb", m_x.matrix, m_a.matrix).reshape(len(contexts), len(groups), X * A)
        w = population.context_given_group()
        w = np.where(np.isnan(w), 0.0, w)
        Wg = np.einsum("xa,xayb->ayb", w, np.einsum("xy,ab->xayb", m_x.matrix, m_a.matrix)).reshape(len(groups), X * A)
        flat_lo, flat_hi = e_lo.reshape(-1), e_hi.reshape(-1)
        Wsel = Wl[local_keys]
        res["local"] = (_mixed_ratio(Wsel, flat_lo, flat_hi, solver), local_keys)
        res["global"] = (_mixed_ratio(Wg[None], flat_lo, flat_hi, solver), [0])
        if with_u:
            cl, ch = c_lo.reshape(X * A, kc), c_hi.reshape(X * A, kc)
            res["sup_local"] = (
                _max_over([_mixed_ratio(Wsel, cl[:, u], ch[:, u], solver) for u in range(kc)]),
                local_keys,
            )
            res["sup_global"] = (
                _max_over([_mixed_ratio(Wg[None], cl[:, u], ch[:, u], solver) for u in range(kc)]),
                [0],
            )
            el, eh = ev_lo.reshape(len(events), X * A), ev_hi.reshape(len(events), X * A)
            res["equalized_odds"] = (_mixed_tv(Wsel, el, eh, events, cl, ch), local_keys)
            res["demographic_parity"] = (_mixed_tv(Wg[None], el, eh, events, cl, ch), [0])
        cell_lo = np.einsum("xan,n->xa", Wl, flat_lo)
        cell_hi = np.einsum("xan,n->xa", Wl, flat_hi)
        ge_lo, ge_hi = Wg @ flat_lo, Wg @ flat_hi
        kernel_lo, kernel_hi = e_lo, e_hi
    conf = 1.0 - alpha
    made: dict[str, Interval | None] = {}
    for name in ("local", "global", "sup_local", "sup_global", "demographic_parity", "equalized_odds"):
        if name not in res:
            made[name] = None
            continue
        (lower, upper, fav, oth), keys = res[name]
        made[name] = _make(
            name,
            lower,
            upper,
            (fav, oth),
            list(keys),
            contexts,
            groups,
            estimate,
            conf,
            method,
            local=name in ("local", "sup_local", "equalized_odds"),
        )
    local, global_ = made["local"], made["global"]
    assert local is not None and global_ is not None  # always computed
    return FairnessIntervals(
        method,
        conf,
        local,
        global_,
        made["sup_local"],
        made["sup_global"],
        made["demographic_parity"],
        made["equalized_odds"],
        cell_lo,
        cell_hi,
        np.asarray(ge_lo, float),
        np.asarray(ge_hi, float),
        kernel_lo,
        kernel_hi,
        m,
        notes=tuple(notes),
        **common,
    )


def _fold(joint: bool, X: int, K: int) -> FloatArray | None:
    """(K, X·K) matrix summing the joint (x, u) categories of a group into decisions u; None when not joint."""
    if not joint:
        return None
    return np.tile(np.eye(K), (1, X))


def _max_over(results: list[_Extremes]) -> _Extremes:
    """The max over decisions u of per-u (lower, upper, fav, other) results (valid for both ends)."""
    lowers = np.stack([r[0] for r in results])
    uppers = np.stack([r[1] for r in results])
    best = np.where(np.isnan(uppers), -np.inf, uppers).argmax(0)
    cols = np.arange(uppers.shape[1])
    fav = np.stack([r[2] for r in results])[best, cols]
    oth = np.stack([r[3] for r in results])[best, cols]
    low = np.where(np.isnan(lowers), -np.inf, lowers).max(0)
    return np.where(np.isinf(low) & (low < 0), np.nan, low), uppers[best, cols], fav, oth
