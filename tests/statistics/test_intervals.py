"""Simultaneous fairness intervals, checked against independent routes.

Every expected value here comes from somewhere other than the code under
test: scipy's exact binomial test, scipy's LP solver, brute force over the
vertices of a box, a bisection with LP feasibility, the true law of a
simulation, or AIF360.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog
from scipy.stats import binomtest

import fairaudit as fa
from fairaudit import IntervalOptions
from fairaudit.base.errors import InputError
from fairaudit.data.counts import CountTable, count_records, count_table
from fairaudit.laws.closed_forms import randomized_response
from fairaudit.laws.tables import Law, Population
from fairaudit.metrics.box_extremes import disjoint_ratio as _disjoint_ratio
from fairaudit.metrics.box_extremes import mixed_ratio as _mixed_ratio
from fairaudit.metrics.fairness import global_fairness, local_fairness
from fairaudit.metrics.parity import demographic_parity, equalized_odds
from fairaudit.metrics.sup_fairness import sup_global_fairness, sup_local_fairness
from fairaudit.statistics.confidence_sets import category_bounds, clopper_pearson, linear_extremes
from fairaudit.statistics.intervals import fairness_intervals, interval_options


def _cp(k: int, n: int, level: float) -> tuple[float, float]:
    """scipy's exact (Clopper-Pearson) interval at ``level``."""
    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=level, method="exact")
    return float(ci.low), float(ci.high)


def _table(counts, contexts=("all",), groups=("a", "b"), decisions=(0, 1)) -> CountTable:
    return CountTable(
        np.asarray(counts, dtype=np.int64),
        tuple(contexts),
        tuple(groups),
        tuple(decisions),
        ("x",) if contexts != ("all",) else (),
        ("g",),
        "y",
    )


def _binary_table(pos, tot, contexts=("all",), groups=("a", "b")) -> CountTable:
    """Counts [x, a, (0, 1)] from successes ``pos[x][a]`` out of ``tot[x][a]``."""
    pos, tot = np.asarray(pos), np.asarray(tot)
    return _table(np.stack([tot - pos, pos], -1), contexts, groups)


# ---------------------------------------------------------------- 1. clopper_pearson


@pytest.mark.parametrize("alpha", [0.05, 0.1, 0.01 / 3])
@pytest.mark.parametrize("n", [1, 2, 7, 30, 101])
def test_clopper_pearson_matches_scipy_exact(n, alpha):
    ks = sorted({0, 1, n // 3, n // 2, n - 1, n} & set(range(n + 1)))
    lo, hi = clopper_pearson(np.array(ks), n, alpha)
    for i, k in enumerate(ks):
        ref_lo, ref_hi = _cp(k, n, 1 - alpha)
        assert lo[i] == pytest.approx(ref_lo, rel=1e-7, abs=1e-14)
        assert hi[i] == pytest.approx(ref_hi, rel=1e-7, abs=1e-14)
    # the closed forms at the two ends, by hand
    assert lo[0] == 0.0 and hi[0] == pytest.approx(1 - (alpha / 2) ** (1 / n), rel=1e-12)
    assert hi[-1] == 1.0 and lo[-1] == pytest.approx((alpha / 2) ** (1 / n), rel=1e-12)


def test_clopper_pearson_equals_scipy_stats_beta_quantiles_bit_for_bit():
    """scipy.special's Beta quantiles are what scipy.stats.beta evaluates: the same doubles, small and big tables.

    Above 256 cells the quantiles are computed once per distinct (k, n) and scattered back; both paths are checked.
    """
    from scipy import stats

    rng = np.random.default_rng(7)
    n = rng.integers(1, 3000, size=(40, 9)).astype(float)
    k = np.minimum(np.floor(rng.random(n.shape) * (n + 1)), n)
    k[0, :3], k[1, :3] = 0.0, n[1, :3]  # both ends
    for alpha in (0.05, 0.01 / 7):
        ref_lo = np.where(k > 0, stats.beta.ppf(alpha / 2, k, n - k + 1), 0.0)
        ref_hi = np.where(k < n, stats.beta.isf(alpha / 2, k + 1, n - k), 1.0)
        for kk, nn, rl, rh in ((k, n, ref_lo, ref_hi), (k[:2], n[:2], ref_lo[:2], ref_hi[:2])):  # 360 and 18 cells
            lo, hi = clopper_pearson(kk, nn, alpha)
            np.testing.assert_array_equal(lo, rl)
            np.testing.assert_array_equal(hi, rh)


def test_clopper_pearson_hand_value_and_empty():
    lo, hi = clopper_pearson(0, 10, 0.05)
    assert float(lo) == 0.0 and float(hi) == pytest.approx(1 - 0.025**0.1, rel=1e-12)
    assert float(hi) == pytest.approx(0.3084971078187608, rel=1e-12)
    lo, hi = clopper_pearson(0, 0, 0.05)
    assert math.isnan(float(lo)) and math.isnan(float(hi))


# ---------------------------------------------------------------- 2. linear_extremes


@st.composite
def _boxes(draw):
    K = draw(st.integers(2, 5))
    w = np.array(draw(st.lists(st.floats(0.01, 1.0), min_size=K, max_size=K)))
    p = w / w.sum()
    down = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=K, max_size=K)))
    up = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=K, max_size=K)))
    lo = np.clip(p - down * p, 0.0, 1.0)  # lo <= p <= hi: the set contains p
    hi = np.clip(p + up * (1 - p), 0.0, 1.0)
    f = np.array(draw(st.lists(st.floats(-5.0, 5.0), min_size=K, max_size=K)))
    return f, lo, hi


@pytest.mark.slow
@given(_boxes())
def test_linear_extremes_equals_linprog(box):
    f, lo, hi = box
    K = len(f)
    bounds = list(zip(lo, hi))
    lp_min = linprog(f, A_eq=np.ones((1, K)), b_eq=[1.0], bounds=bounds, method="highs")
    lp_max = linprog(-f, A_eq=np.ones((1, K)), b_eq=[1.0], bounds=bounds, method="highs")
    assert lp_min.status == 0 and lp_max.status == 0
    mn, mx = linear_extremes(f, lo, hi)
    tol = 1e-6 * max(1.0, float(np.abs(f).max()))  # HiGHS meets bounds to its feasibility tolerance 1e-7
    assert float(mn) == pytest.approx(lp_min.fun, abs=tol)
    assert float(mx) == pytest.approx(-lp_max.fun, abs=tol)


def test_linear_extremes_vectorised_hand_example():
    mn, mx = linear_extremes([[0.0, 0.5, 1.0], [1.0, 0.0, 0.0]], [0.1, 0.1, 0.1], [0.5, 0.5, 0.5])
    # row 0: start at 0.1 each (0.15), 0.7 left: max puts 0.4 on f=1 then 0.3 on f=0.5 -> 0.15+0.4+0.15 = 0.7
    assert mn.tolist() == pytest.approx([0.3, 0.1]) and mx.tolist() == pytest.approx([0.7, 0.5])


# ---------------------------------------------------------------- 3. category_bounds


@pytest.mark.parametrize("counts", [[0, 3, 7], [5, 0, 0, 2], [1, 1, 1], [12, 30, 0, 4, 9], [0, 0, 20]])
@pytest.mark.parametrize("alpha", [0.05, 0.2])
def test_category_bounds_uses_alpha_over_K(counts, alpha):
    K, n = len(counts), sum(counts)
    lo, hi = category_bounds([counts], alpha)
    for u, k in enumerate(counts):
        ref_lo, ref_hi = _cp(k, n, 1 - alpha / K)
        assert lo[0, u] == pytest.approx(ref_lo, rel=1e-7, abs=1e-14)
        assert hi[0, u] == pytest.approx(ref_hi, rel=1e-7, abs=1e-14)


@pytest.mark.parametrize("k,n", [(0, 10), (3, 10), (10, 10), (17, 40), (1, 1)])
def test_category_bounds_two_decisions_use_alpha(k, n):
    alpha = 0.05
    lo, hi = category_bounds([[n - k, k]], alpha)
    ref_lo, ref_hi = _cp(k, n, 1 - alpha)  # level 1 - alpha, not 1 - alpha/2
    assert lo[0, 1] == pytest.approx(ref_lo, rel=1e-7, abs=1e-14)
    assert hi[0, 1] == pytest.approx(ref_hi, rel=1e-7, abs=1e-14)
    assert lo[0, 0] == pytest.approx(1 - hi[0, 1], abs=1e-12)  # complementary intervals
    assert hi[0, 0] == pytest.approx(1 - lo[0, 1], abs=1e-12)


def test_category_bounds_empty_cell_is_unconstrained():
    lo, hi = category_bounds([[0, 0, 0], [2, 1, 0]], 0.05)
    assert lo[0].tolist() == [0.0, 0.0, 0.0] and hi[0].tolist() == [1.0, 1.0, 1.0]
    assert np.all(hi[1] < 1.0) and np.all(np.isfinite(lo[1]))


def test_category_bounds_simplex_tightening_hand_example():
    # counts (0, 3, 7), alpha 0.05, K = 3: raw Clopper-Pearson at level 1 - 0.05/3 per decision, then
    # lo_u <- max(lo_u, 1 - sum_{v != u} hi_v), hi_u <- min(hi_u, 1 - sum_{v != u} lo_v), by hand.
    raw = [_cp(k, 10, 1 - 0.05 / 3) for k in (0, 3, 7)]
    rlo, rhi = np.array([r[0] for r in raw]), np.array([r[1] for r in raw])
    assert rlo[0] == 0.0 and rhi[0] == pytest.approx(1 - (0.05 / 6) ** 0.1, rel=1e-12)
    want_lo = [max(rlo[u], 1 - sum(rhi[v] for v in range(3) if v != u), 0.0) for u in range(3)]
    want_hi = [min(rhi[u], 1 - sum(rlo[v] for v in range(3) if v != u), 1.0) for u in range(3)]
    lo, hi = category_bounds([0, 3, 7], 0.05)
    assert lo.tolist() == pytest.approx(want_lo, abs=1e-12)
    assert hi.tolist() == pytest.approx(want_hi, abs=1e-12)
    # The set is a nonempty polytope: sum lo <= 1 <= sum hi.
    assert lo.sum() <= 1 <= hi.sum()


@given(st.lists(st.integers(0, 25), min_size=3, max_size=5).filter(lambda c: sum(c) > 0))
def test_category_bounds_tightening_keeps_consistent_clopper_pearson(counts):
    # Clopper-Pearson bounds at one level are already consistent with the simplex (sum of the others'
    # upper ends is at least the upper end of their total), so the tightening never moves them.
    K, n = len(counts), sum(counts)
    lo, hi = category_bounds(counts, 0.1)
    rlo, rhi = clopper_pearson(np.array(counts), n, 0.1 / K)
    assert np.allclose(lo, rlo, atol=1e-12) and np.allclose(hi, rhi, atol=1e-12)
    assert lo.sum() <= 1 + 1e-12 and hi.sum() >= 1 - 1e-12


# ---------------------------------------------------------------- 4. unfiltered, by hand


@pytest.mark.parametrize("method", ["clopper-pearson", "multinomial"])
def test_one_context_hand_example(method):
    pos, tot = [30, 20, 5], [50, 50, 40]
    t = _binary_table([pos], [tot], groups=("a", "b", "c"))
    conf = 0.95
    iv = fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=conf, method=method))
    m = 3  # one context: the groups are the cells, not counted twice
    assert iv.n_sets == m
    level = 1 - (1 - conf) / m
    ci = [_cp(k, n, level) for k, n in zip(pos, tot)]
    lo, hi = [c[0] for c in ci], [c[1] for c in ci]
    assert iv.cell_lower[0].tolist() == pytest.approx(lo, rel=1e-7)
    assert iv.cell_upper[0].tolist() == pytest.approx(hi, rel=1e-7)
    pairs = {(i, j): hi[i] / lo[j] for i in range(3) for j in range(3) if i != j}
    (fi, fj), best = max(pairs.items(), key=lambda kv: kv[1])
    assert (fi, fj) == (0, 2)  # a favoured over c
    assert iv.local_fairness.upper == pytest.approx(math.log(best), rel=1e-7)
    want_lower = math.log(max(1.0, max(lo) / min(hi)))
    assert want_lower > 0
    assert iv.local_fairness.lower == pytest.approx(want_lower, rel=1e-7)
    assert (iv.local_fairness.context, iv.local_fairness.group, iv.local_fairness.other_group) == ("all", "a", "c")
    assert iv.local_fairness.estimate == pytest.approx(math.log((30 / 50) / (5 / 40)), rel=1e-12)
    assert iv.local_fairness.confidence == conf and iv.local_fairness.method == method
    # one context, pooled: the global interval is the same set
    L, G = iv.local_fairness, iv.global_fairness
    assert (G.lower, G.upper) == pytest.approx((L.lower, L.upper), rel=1e-12)
    assert G.context is None and (G.group, G.other_group) == ("a", "c")


def test_two_contexts_hand_example_counts_groups_and_pools_them():
    pos = [[15, 5], [20, 18]]
    tot = [[30, 25], [40, 35]]
    t = _binary_table(pos, tot, contexts=("x0", "x1"))
    conf = 0.9
    iv = fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=conf, method="clopper-pearson"))
    m = 4 + 2  # 4 cells + 2 pooled groups
    assert iv.n_sets == m
    level = 1 - (1 - conf) / m
    uppers, lowers = [], []
    for x in range(2):
        (la, ha), (lb, hb) = (_cp(pos[x][a], tot[x][a], level) for a in range(2))
        uppers.append(max((ha / lb, ("a", "b")), (hb / la, ("b", "a"))))
        lowers.append(max(1.0, max(la, lb) / min(ha, hb)))
    x = int(np.argmax([u[0] for u in uppers]))
    assert x == 0
    assert iv.local_fairness.upper == pytest.approx(math.log(uppers[x][0]), rel=1e-7)
    assert iv.local_fairness.lower == pytest.approx(math.log(max(lowers)), rel=1e-7, abs=1e-12)
    assert (iv.local_fairness.context, iv.local_fairness.group, iv.local_fairness.other_group) == ("x0",) + uppers[x][1]
    # global: the pooled group counts a = 35/70, b = 23/60 at the same Bonferroni level
    (la, ha), (lb, hb) = _cp(35, 70, level), _cp(23, 60, level)
    assert iv.group_lower.tolist() == pytest.approx([la, lb], rel=1e-7)
    assert iv.group_upper.tolist() == pytest.approx([ha, hb], rel=1e-7)
    assert iv.global_fairness.upper == pytest.approx(math.log(max(ha / lb, hb / la)), rel=1e-7)
    assert iv.global_fairness.lower == pytest.approx(math.log(max(1.0, max(la, lb) / min(ha, hb))), rel=1e-7, abs=1e-12)
    assert (iv.global_fairness.group, iv.global_fairness.other_group) == ("a", "b")
    assert iv.global_fairness.estimate == pytest.approx(math.log((35 / 70) / (23 / 60)), rel=1e-12)


# ---------------------------------------------------------------- 5. behind a filter


def _rr_matrix(k: int, keep: float) -> np.ndarray:
    """Randomized response by hand: keep on the diagonal, the rest spread evenly."""
    return np.full((k, k), (1 - keep) / (k - 1)) + np.eye(k) * (keep - (1 - keep) / (k - 1))


def _max_ratio(q: np.ndarray) -> float:
    if q.min() <= 0:
        return math.inf if q.max() > 0 else 1.0
    return float(q.max() / q.min())


def _bisect_min_max_ratio(M: np.ndarray, lo: np.ndarray, hi: np.ndarray, t_hi: float) -> float:
    """min over lo <= e <= hi of max_{a,a'} (Me)_a / (Me)_a' by bisection on t with LP feasibility."""
    A = M.shape[0]
    bounds = list(zip(lo, hi))

    def feasible(t):
        rows = [M[a] - t * M[b] for a in range(A) for b in range(A) if a != b]
        res = linprog(np.zeros(len(lo)), A_ub=np.array(rows), b_ub=np.zeros(len(rows)), bounds=bounds, method="highs")
        return res.status == 0

    if feasible(1.0):
        return 1.0
    a, b = 1.0, t_hi
    assert feasible(b)
    for _ in range(60):
        mid = 0.5 * (a + b)
        a, b = (a, mid) if feasible(mid) else (mid, b)
    return b


FILTER_CASES = [
    # (successes [x][ã], totals [x][ã], keep)
    ([[40, 25]], [[50, 60]], 0.8),
    ([[400, 50]], [[500, 500]], 0.9),
    ([[90, 40, 10]], [[100, 100, 100]], 0.85),
    ([[30, 20], [5, 28]], [[40, 40], [30, 35]], 0.75),
    ([[300, 120, 60], [50, 200, 90]], [[400, 300, 300], [250, 260, 300]], 0.9),
    ([[12, 3, 7], [0, 9, 4]], [[20, 15, 25], [10, 30, 12]], 0.7),
]


@pytest.mark.parametrize("pos,tot,keep", FILTER_CASES)
def test_filtered_local_ends_by_brute_force_and_bisection(pos, tot, keep):
    pos, tot = np.array(pos), np.array(tot)
    X, A = pos.shape
    contexts = ("x0", "x1")[:X] if X > 1 else ("all",)
    groups = ("a", "b", "c")[:A]
    t = _binary_table(pos, tot, contexts=contexts, groups=groups)
    conf = 0.95
    iv = fairness_intervals(
        t,
        fa.indicator(1, t.decisions),
        IntervalOptions(confidence=conf, method="clopper-pearson"),
        sensitive_mechanism=randomized_response(groups, keep=keep),
    )
    # the box: Clopper-Pearson per kernel cell at 1 - alpha/m, m = kernel cells (no pooled groups behind a filter)
    assert iv.n_sets == X * A
    level = 1 - (1 - conf) / (X * A)
    box = np.array([[_cp(pos[x, a], tot[x, a], level) for a in range(A)] for x in range(X)])
    assert iv.kernel_lower == pytest.approx(box[..., 0], rel=1e-7)
    assert iv.kernel_upper == pytest.approx(box[..., 1], rel=1e-7)
    M = _rr_matrix(A, keep)
    # audited cells Q = M e: monotone in e, so their bounds are M applied to the box ends
    assert iv.cell_lower == pytest.approx(box[..., 0] @ M.T, rel=1e-7)
    assert iv.cell_upper == pytest.approx(box[..., 1] @ M.T, rel=1e-7)
    # (a) upper end: max over all vertices of the box (a ratio of linear functions peaks at a vertex)
    best, where = -1.0, None
    for x in range(X):
        for vertex in itertools.product(*[(box[x, a, 0], box[x, a, 1]) for a in range(A)]):
            q = M @ np.array(vertex)
            r = _max_ratio(q)
            if r > best:
                best, where = r, (x, contexts[x], groups[int(q.argmax())], groups[int(q.argmin())])
    assert iv.local_fairness.upper == pytest.approx(math.log(best), rel=1e-7)
    assert (iv.local_fairness.context, iv.local_fairness.group, iv.local_fairness.other_group) == where[1:]
    # (b) lower end: bisection on t with scipy LP feasibility, per context, then the max over contexts
    per_x = [_bisect_min_max_ratio(M, box[x, :, 0], box[x, :, 1], t_hi=best) for x in range(X)]
    want = math.log(max(per_x))
    assert iv.local_fairness.lower == pytest.approx(want, rel=1e-5, abs=1e-6)
    assert iv.local_fairness.lower <= iv.local_fairness.estimate <= iv.local_fairness.upper


def test_filtered_lower_end_is_positive_when_data_exclude_parity():
    # 400/500 against 50/500 released, keep 0.9: even after mixing, the groups cannot be made equal.
    t = _binary_table([[400, 50]], [[500, 500]])
    iv = fairness_intervals(
        t,
        fa.indicator(1, t.decisions),
        IntervalOptions(confidence=0.95, method="clopper-pearson"),
        sensitive_mechanism=randomized_response(t.groups, keep=0.9),
    )
    assert iv.local_fairness.lower > 0.5


_MIXED_SOLVERS: dict = {}  # cvxpy problems are built once per shape; share them across examples


@st.composite
def _identity_boxes(draw):
    M = draw(st.integers(1, 2))
    A = draw(st.integers(2, 3))
    n = M * A
    lo = np.array(draw(st.lists(st.one_of(st.just(0.0), st.floats(0.01, 0.9)), min_size=n, max_size=n)))
    width = np.array(draw(st.lists(st.one_of(st.just(0.0), st.floats(1e-3, 0.5)), min_size=n, max_size=n)))
    hi = np.minimum(lo + width, 1.0)
    hi = np.where(hi > 0, hi, 0.05)  # keep every upper end positive
    return M, A, lo, hi


@pytest.mark.slow
@given(_identity_boxes())
def test_mixed_ratio_with_identity_blocks_equals_disjoint_ratio(case):
    M, A, lo, hi = case
    n = M * A
    W = np.zeros((M, A, n))
    for m in range(M):
        W[m, np.arange(A), m * A + np.arange(A)] = 1.0
    d_lo, d_hi, d_fav, d_oth = _disjoint_ratio(lo.reshape(M, A), hi.reshape(M, A))
    m_lo, m_hi, m_fav, m_oth = _mixed_ratio(W, lo, hi, _MIXED_SOLVERS)
    assert np.allclose(m_hi, d_hi, rtol=1e-9) or np.array_equal(m_hi, d_hi)
    finite = np.isfinite(d_lo)
    assert np.array_equal(np.isinf(m_lo), np.isinf(d_lo))
    assert np.allclose(m_lo[finite], d_lo[finite], rtol=1e-6, atol=1e-7)
    # where the favoured pair is unique and the upper end finite, both name it
    for m in range(M):
        ratios = sorted(
            (hi[m * A + i] / lo[m * A + j] if lo[m * A + j] > 0 else math.inf)
            for i in range(A)
            for j in range(A)
            if i != j
        )
        if math.isfinite(ratios[-1]) and ratios[-1] > ratios[-2] * (1 + 1e-9):
            assert (m_fav[m], m_oth[m]) == (d_fav[m], d_oth[m])


@pytest.mark.parametrize("A, n", [(2, 3), (3, 6), (5, 9)])
def test_min_max_ratio_lp_equals_the_same_lp_in_cvxpy(A, n):
    """The Charnes–Cooper LP solved exactly from HiGHS's basis against the same program written in cvxpy and solved by
    Clarabel (a second route, to its tolerances): the same optimum within 1e-8, and a lower end: no point of the box
    has a smaller max-min ratio.

    As the intervals use it: one object per shape, solved again and again with new weights and ends (zeros included).
    """
    import cvxpy as cp

    from fairaudit.metrics.box_extremes import MinMaxRatio

    tolerances = {"tol_gap_abs": 1e-11, "tol_gap_rel": 1e-11, "tol_feas": 1e-11, "tol_ktratio": 1e-9}
    rng = np.random.default_rng(11 + A)
    y, t, sigma = cp.Variable(n), cp.Variable(nonneg=True), cp.Variable()
    Wp, lop, hip = cp.Parameter((A, n), nonneg=True), cp.Parameter(n, nonneg=True), cp.Parameter(n, nonneg=True)
    ref = cp.Problem(
        cp.Minimize(sigma), [Wp @ y <= sigma, Wp @ y >= 1, y >= cp.multiply(lop, t), y <= cp.multiply(hip, t)]
    )
    direct = MinMaxRatio(A, n)
    for _ in range(25):
        W = rng.dirichlet(np.ones(n), size=A)
        W[rng.random(W.shape) < 0.1] = 0.0
        W[np.arange(A), rng.integers(0, n, A)] += 0.1  # every group has some weight
        lo = rng.random(n) * 0.4
        lo[rng.random(n) < 0.2] = 0.0
        hi = np.minimum(lo + 0.05 + rng.random(n), 1.0)
        Wp.value, lop.value, hip.value = W, lo, hi
        ref.solve(solver=cp.CLARABEL, **tolerances)
        assert ref.status == cp.OPTIMAL
        value = direct.lp(W, lo, hi)
        assert value == pytest.approx(ref.value, rel=1e-8)
        e = lo + rng.random((200, n)) * (hi - lo)  # points of the box
        assert np.all((e @ W.T).max(1) / (e @ W.T).min(1) >= value)
    value = MinMaxRatio(A, n).solve(W, lo, hi)
    assert value == pytest.approx(max(ref.value, 1.0), rel=1e-8)


@st.composite
def _randomized_response_boxes(draw):
    """A randomized response on A groups, placed on the cells of one context among X (the others weigh 0, as a local
    map's W has them) or on every context's cells weighted by P(x) (L̄'s map with X and A independent; powers of 2,
    so that each weight times p and q is exact), and a box of cells: zeros, near-equal ends and ties with the
    largest lower end included."""
    A, X = draw(st.integers(2, 7)), draw(st.integers(1, 3))
    eps = draw(st.sampled_from([1e-9, 0.1, 0.5, 1.0, 3.0, 10.0, 40.0, 700.0, math.inf]))
    matrix = np.eye(A) if math.isinf(eps) else randomized_response(range(A), eps).matrix
    weights = np.zeros(X)
    if draw(st.booleans()):
        weights[draw(st.integers(0, X - 1))] = 1.0
    else:
        weights[:] = draw(st.lists(st.sampled_from([1.0, 0.5, 0.25, 0.125]), min_size=X, max_size=X))
    W = np.kron(weights[None, :], matrix)  # W[a, (x, b)] = P(x) M[a, b]
    unit = st.floats(0.0, 1.0)
    lo = np.array(draw(st.lists(unit | st.just(0.0), min_size=X * A, max_size=X * A)))
    width = draw(st.sampled_from([1e-6, 0.1, 1.0]))
    hi = np.minimum(lo + width * np.array(draw(st.lists(unit, min_size=X * A, max_size=X * A))), 1.0)
    if draw(st.booleans()):
        hi[draw(st.integers(0, X * A - 1))] = lo.max()
    assume(np.any(W @ lo > 0) and np.all(W @ hi > 0))  # (MinMaxRatio.solve answers the other cases first)
    return W, lo, hi


@given(_randomized_response_boxes())
def test_randomized_response_min_max_is_the_exact_lp_optimum(case):
    """The closed form behind randomized response against the Charnes–Cooper LP solved exactly from HiGHS's basis
    (a second route): the same exact optimum, so the same lower end to the last bit; no point of the box is below
    it."""
    from fairaudit.base.outward import fraction_down
    from fairaudit.metrics.box_extremes import MinMaxRatio, randomized_response_min_max

    W, lo, hi = case
    exact = randomized_response_min_max(W, lo, hi)
    by_lp = MinMaxRatio(*W.shape).lp(W, lo, hi)
    assert exact is not None and by_lp is not None
    assert fraction_down(exact) == by_lp
    e = lo + np.random.default_rng(0).random((200, len(lo))) * (hi - lo)  # points of the box
    assert np.all((e @ W.T).max(1) / (e @ W.T).min(1) >= float(exact) * (1 - 1e-12))


def test_randomized_response_min_max_leaves_other_matrices_to_the_lp():
    W = np.array([[0.5, 0.25, 0.25], [0.25, 0.5, 0.25], [0.25, 0.25, 0.5]])
    lo, hi = np.array([0.0, 0.5, 0.25]), np.array([0.125, 0.75, 0.375])
    from fairaudit.metrics.box_extremes import randomized_response_min_max

    # (4/3 by hand: at e = (1/8, 1/2, 3/8), S = 1 and W e = (9/32, 3/8, 11/32); at t = 3/4 the ratio is 16/11)
    assert randomized_response_min_max(W, lo, hi) == Fraction(4, 3)
    skewed = W.copy()
    skewed[0, 1] = 0.2  # one cell off: not randomized response
    assert randomized_response_min_max(skewed, lo, hi) is None
    assert randomized_response_min_max(W[:, ::-1], lo[::-1], hi[::-1]) == Fraction(4, 3)  # (the cells in any order)
    halves = np.hstack([W, W]) / 2  # two contexts at P(x | a) = 1/2: each group's E is the mean of its two cells
    assert randomized_response_min_max(halves, np.hstack([lo, lo]), np.hstack([hi, hi])) == Fraction(4, 3)
    rr = randomized_response(range(3), 1.0).matrix  # p/3, q/3 and p/5, q/5 rounded: two ratios p/q, not one
    mixed = np.hstack([rr / 3, rr / 5])  # (P(x | a) = 1/3 and 1/5 in floats): the LP's case
    assert Fraction(rr[0, 0] / 3) / Fraction(rr[0, 1] / 3) != Fraction(rr[0, 0] / 5) / Fraction(rr[0, 1] / 5)
    assert randomized_response_min_max(mixed, np.hstack([lo, lo]), np.hstack([hi, hi])) is None
    assert randomized_response_min_max(np.full((3, 3), 1 / 3), lo, hi) is None  # epsilon = 0: p = q


def test_mixed_ratio_tiny_positive_upper_end():
    # a badly scaled LP (Clarabel could not solve it): the exact LP and the closed-form pairwise floor (exact here:
    # disjoint cells) both give its value
    lo, hi = np.array([0.0, 0.5, 0.0]), np.array([0.05, 0.5, 1e-12])
    m_lo, _, _, _ = _mixed_ratio(np.eye(3)[None], lo, hi, {})
    assert m_lo[0] == pytest.approx(0.5 / 1e-12, rel=1e-3)


# ---------------------------------------------------------------- 6. zero and empty cells


@pytest.mark.parametrize("method", ["clopper-pearson", "multinomial"])
def test_zero_successes_give_infinite_upper_and_finite_lower(method):
    t = _binary_table([[0, 30]], [[100, 100]])
    iv = fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=0.95, method=method))
    assert iv.local_fairness.upper == math.inf
    (_, ha), (lb, _) = _cp(0, 100, 1 - 0.05 / 2), _cp(30, 100, 1 - 0.05 / 2)
    assert iv.local_fairness.lower == pytest.approx(math.log(lb / ha), rel=1e-7)
    assert 0 < iv.local_fairness.lower < math.inf
    assert (iv.local_fairness.group, iv.local_fairness.other_group) == ("b", "a")


@pytest.mark.parametrize("method", ["clopper-pearson", "multinomial"])
def test_all_zero_table_gives_lower_zero(method):
    t = _binary_table([[0, 0, 0], [0, 0, 0]], [[10, 20, 5], [7, 7, 7]], contexts=("x0", "x1"), groups=("a", "b", "c"))
    iv = fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=0.95, method=method))
    assert iv.local_fairness.lower == 0.0 and iv.local_fairness.upper == math.inf
    assert iv.global_fairness.lower == 0.0 and iv.global_fairness.upper == math.inf


@pytest.mark.parametrize("method", ["clopper-pearson", "multinomial", "bayes"])
def test_empty_cell_gives_finite_lower_and_infinite_upper(method):
    df = pd.DataFrame(
        {
            "x": ["p", "p", "p", "p", "q", "q"],
            "g": ["a", "a", "b", "b", "a", "a"],
            "y": [0, 1, 0, 1, 0, 1],
            "count": [10, 30, 25, 15, 12, 8],
        }
    )
    t = count_table(
        df, sensitive=["g"], outcome="y", context=["x"], contexts=["p", "q"], groups=["a", "b"], decisions=[0, 1]
    )
    assert t.counts[1, 1].tolist() == [0, 0]  # cell (q, b) is empty
    iv = fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=0.95, method=method, draws=200))
    assert math.isfinite(iv.local_fairness.lower) and iv.local_fairness.lower >= 0
    if method != "bayes":
        assert iv.local_fairness.upper == math.inf
        assert iv.n_sets == 3 + 2  # the empty cell is not counted
        assert iv.cell_lower[1, 1] == 0.0 and iv.cell_upper[1, 1] == 1.0


def test_empty_kernel_cell_behind_filter_does_not_crash():
    # Released group b has no records: its kernel cell may be anything in [0, 1]. Behind randomized
    # response with keep 0.8 both audited groups still see 0.8 or 0.2 of group a's positive kernel cell,
    # so the ratio is bounded: Q_a / Q_b <= 0.8 e_a / (0.2 e_a) = 4 at e_b = 0 (by hand); lower end 0.
    t = _binary_table([[30, 0]], [[50, 0]])
    iv = fairness_intervals(
        t,
        fa.indicator(1, t.decisions),
        IntervalOptions(confidence=0.95, method="clopper-pearson"),
        sensitive_mechanism=randomized_response(t.groups, keep=0.8),
    )
    assert iv.n_sets == 1
    assert iv.kernel_lower[0].tolist() == pytest.approx([_cp(30, 50, 1 - 0.05)[0], 0.0], rel=1e-7)
    assert iv.kernel_upper[0, 1] == 1.0
    assert iv.local_fairness.lower == pytest.approx(0.0, abs=1e-7)
    assert iv.local_fairness.upper == pytest.approx(math.log(4.0), rel=1e-9)
    assert (iv.local_fairness.group, iv.local_fairness.other_group) == ("a", "b")
    assert math.isnan(iv.local_fairness.estimate)  # no plug-in law with an empty kernel cell


# ---------------------------------------------------------------- 7. coverage


@pytest.mark.slow
def test_coverage_of_simultaneous_intervals_on_a_known_law():
    rng = np.random.default_rng(0)
    contexts, groups, decisions = ("x0", "x1"), ("a", "b", "c"), (0, 1)
    joint = np.array([[0.25, 0.15, 0.10], [0.10, 0.15, 0.25]])  # P(X, A), not independent
    p1 = np.array([[0.30, 0.50, 0.40], [0.60, 0.55, 0.25]])  # P(g = 1 | x, a)
    law = Law(np.stack([1 - p1, p1], -1), contexts, groups, decisions)
    pop = Population(joint, contexts, groups)
    u = fa.indicator(1, decisions)
    truth = {"local": local_fairness(law, u, pop).value, "global": global_fairness(law, u, pop).value}
    # the pooled truth is E[g | a] with the true P(x | a), by hand
    e_a = (joint * p1).sum(0) / joint.sum(0)
    assert truth["global"] == pytest.approx(math.log(e_a.max() / e_a.min()), rel=1e-12)
    truth_u = {
        "sup_local_fairness": sup_local_fairness(law, pop).value,
        "sup_global_fairness": sup_global_fairness(law, pop).value,
        "demographic_parity": demographic_parity(law, pop).value,
        "equalized_odds": equalized_odds(law, pop).value,
    }
    N = 40 * 6
    reps = 300
    hits = {"clopper-pearson": 0, "multinomial": 0}
    for _ in range(reps):
        cells = rng.multinomial(N, joint.ravel()).reshape(2, 3)
        k = rng.binomial(cells, p1)
        t = CountTable(np.stack([cells - k, k], -1).astype(np.int64), contexts, groups, decisions, ("x",), ("g",), "y")
        for method in hits:
            iv = fairness_intervals(t, u, IntervalOptions(confidence=0.95, method=method))
            ok = truth["local"] in iv.local_fairness and truth["global"] in iv.global_fairness
            if method == "multinomial":
                ok = ok and all(v in getattr(iv, name) for name, v in truth_u.items())
            hits[method] += ok
    for method, h in hits.items():
        assert h / reps >= 0.95, (method, h)


# ---------------------------------------------------------------- 8. Bayes


def _records(pos, tot):
    rows = []
    for a, (k, n) in enumerate(zip(pos, tot)):
        rows += [(a, 1)] * k + [(a, 0)] * (n - k)
    return pd.DataFrame(rows, columns=["g", "y"]).astype(float)


@pytest.mark.parametrize("pos,tot", [([30, 20], [50, 50]), ([12, 3, 40], [20, 25, 41]), ([0, 9, 5], [10, 9, 30])])
def test_bayes_estimate_matches_aif360_smoothed_edf(pos, tot):
    pytest.importorskip("aif360")
    import logging

    logging.getLogger().setLevel(logging.ERROR)
    from aif360.datasets import BinaryLabelDataset
    from aif360.metrics import BinaryLabelDatasetMetric

    df = _records(pos, tot)
    ds = BinaryLabelDataset(
        df=df, label_names=["y"], protected_attribute_names=["g"], favorable_label=1.0, unfavorable_label=0.0
    )
    ref = BinaryLabelDatasetMetric(ds).smoothed_empirical_differential_fairness(concentration=1.0)
    t = count_records(df, sensitive=["g"], outcome="y")
    iv = fairness_intervals(
        t,
        fa.indicator(1.0, t.decisions),
        IntervalOptions(confidence=0.95, method="bayes", concentration=1.0, draws=200, seed=1),
    )
    assert iv.sup_local_fairness.estimate == pytest.approx(ref, rel=1e-12)
    # and by hand: smoothed rates (k + 1/2) / (n + 1)
    r = (np.array(pos) + 0.5) / (np.array(tot) + 1.0)
    hand = max(
        max(abs(math.log(r[i] / r[j])), abs(math.log((1 - r[i]) / (1 - r[j]))))
        for i in range(len(r))
        for j in range(len(r))
        if i != j
    )
    assert iv.sup_local_fairness.estimate == pytest.approx(hand, rel=1e-12)
    assert iv.sup_local_fairness.lower <= iv.sup_local_fairness.upper


def test_bayes_seed_reproducible_and_sensitive():
    t = _binary_table([[12, 30], [7, 4]], [[40, 50], [20, 25]], contexts=("x0", "x1"))
    u = fa.indicator(1, t.decisions)
    a = fairness_intervals(t, u, IntervalOptions(confidence=0.9, method="bayes", draws=300, seed=5))
    b = fairness_intervals(t, u, IntervalOptions(confidence=0.9, method="bayes", draws=300, seed=5))
    c = fairness_intervals(t, u, IntervalOptions(confidence=0.9, method="bayes", draws=300, seed=6))
    for name in a.intervals():
        assert a.intervals()[name] == b.intervals()[name]
    assert np.array_equal(a.cell_lower, b.cell_lower) and np.array_equal(a.group_upper, b.group_upper)
    assert (a.local_fairness.lower, a.local_fairness.upper) != (c.local_fairness.lower, c.local_fairness.upper)
    assert a.n_sets == 0 and a.seed == 5 and a.draws == 300


@pytest.mark.parametrize(
    "kwargs,field",
    [
        ({"draws": 99}, "draws"),
        ({"draws": 50}, "draws"),
        ({"concentration": 0.0}, "concentration"),
        ({"concentration": -1.0}, "concentration"),
        ({"concentration": math.inf}, "concentration"),
    ],
)
def test_bayes_bad_settings_raise(kwargs, field):
    with pytest.raises(InputError, match=field) as err:
        IntervalOptions(confidence=0.95, method="bayes", **kwargs)
    assert err.value.field == field


# ---------------------------------------------------------------- 9. errors


@pytest.mark.parametrize("confidence", [0, 1, 0.0, 1.0, -0.1, 1.5, "high"])
def test_confidence_outside_open_unit_interval_raises(confidence):
    t = _binary_table([[3, 4]], [[10, 10]])
    with pytest.raises(InputError, match="confidence"):
        fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=confidence))


def test_unknown_method_raises():
    t = _binary_table([[3, 4]], [[10, 10]])
    with pytest.raises(InputError, match="method") as err:
        fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=0.95, method="wilson"))
    assert "wilson" in str(err.value)


def test_clopper_pearson_needs_indicator_utility():
    t = _binary_table([[3, 4]], [[10, 10]])
    g = fa.from_table([0.0, 0.5], t.decisions, name="half")
    with pytest.raises(InputError, match="method") as err:
        fairness_intervals(t, g, IntervalOptions(confidence=0.95, method="clopper-pearson"))
    assert "0/1" in str(err.value)
    # the same utility is fine with the multinomial set, and "auto" picks it
    assert fairness_intervals(t, g, IntervalOptions(confidence=0.95, method="auto")).method == "multinomial"


def test_fractional_counts_raise():
    df = pd.DataFrame({"g": ["a", "a", "b", "b"], "y": [0, 1, 0, 1], "count": [3.0, 2.5, 4.0, 1.0]})
    t = count_table(df, sensitive=["g"], outcome="y")
    with pytest.raises(InputError, match="counts") as err:
        fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=0.95, method="multinomial"))
    assert err.value.field == "counts" and "2.5" in str(err.value)


@settings(max_examples=100)
@given(st.integers(2, 6), st.integers(0, 2**31 - 1))
def test_pair_gap_equals_brute_force_over_pairs(A, seed):
    # _pair_gap finds max over a != a' of big[a] - small[a'] from the two extremes only; check against all pairs.
    from fairaudit.metrics.box_extremes import pair_gap as _pair_gap

    rng = np.random.default_rng(seed)
    big, small = rng.integers(0, 4, size=(5, A)) / 4, rng.integers(0, 4, size=(5, A)) / 4  # ties on purpose
    val, fav, oth = _pair_gap(big, small)
    for r in range(5):
        pairs = {(a, b): big[r, a] - small[r, b] for a in range(A) for b in range(A) if a != b}
        assert val[r] == max(pairs.values())
        assert fav[r] != oth[r] and pairs[(fav[r], oth[r])] == val[r]


@settings(max_examples=60)
@given(st.integers(2, 6), st.integers(0, 2**31 - 1))
def test_event_extremes_equal_the_knapsack(K, seed):
    # the matrix-product shortcut for 0/1 functionals against the general fractional knapsack
    from fairaudit.statistics.confidence_sets import decision_events as _events
    from fairaudit.statistics.confidence_sets import event_extremes as _event_extremes

    rng = np.random.default_rng(seed)
    p = rng.dirichlet(np.ones(K), size=(3, 2))
    lo, hi = np.clip(p - rng.uniform(0, 0.3, p.shape), 0, 1), np.clip(p + rng.uniform(0, 0.3, p.shape), 0, 1)
    ev = _events(K)
    mn, mx = _event_extremes(ev, lo, hi)
    ref_mn, ref_mx = linear_extremes(ev[:, None, None, :], lo[None], hi[None])
    np.testing.assert_allclose(mn, ref_mn, atol=1e-12)
    np.testing.assert_allclose(mx, ref_mx, atol=1e-12)


# -- the options object ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"confidence": 0.0}, "confidence"),
        ({"confidence": 1.0}, "confidence"),
        ({"method": "wald"}, "method"),
        ({"concentration": math.nan}, "concentration"),
        ({"draws": 99}, "draws"),
        ({"draws": 400.0}, "draws"),
        ({"seed": -1}, "seed"),
        ({"seed": True}, "seed"),
    ],
)
def test_interval_options_name_the_bad_field(kwargs, field):
    with pytest.raises(InputError) as err:
        IntervalOptions(**kwargs)
    assert err.value.field == field


def test_interval_options_are_values_and_their_settings_reach_the_result():
    assert IntervalOptions() == IntervalOptions(confidence=0.95, method="auto", concentration=1, draws=4000, seed=0)
    assert hash(IntervalOptions(seed=3)) == hash(IntervalOptions(seed=3))
    t = _binary_table([[3, 4]], [[10, 10]])
    g = fa.indicator(1, t.decisions)
    default = fairness_intervals(t, g)  # None: IntervalOptions(), 95% Clopper-Pearson for a 0/1 utility
    assert (default.method, default.confidence) == ("clopper-pearson", 0.95) and default.seed is None
    # 3/10 against 4/10 selected: the upper end of E[g | a] is Clopper-Pearson's at the Bonferroni level
    # alpha / n_sets for the set of each of the 2 cells (two-sided): scipy's beta quantile, an independent route
    lo = fairness_intervals(t, g, IntervalOptions(confidence=0.9))
    assert lo.n_sets == 2
    assert lo.cell_upper[0, 0] == pytest.approx(scipy.stats.beta.ppf(1 - 0.1 / 4, 4, 7), rel=1e-9)
    bayes = fairness_intervals(t, g, IntervalOptions(method="bayes", draws=300, seed=7, concentration=2.0))
    assert (bayes.method, bayes.draws, bayes.seed, bayes.concentration) == ("bayes", 300, 7, 2.0)
    again = fairness_intervals(t, g, IntervalOptions(method="bayes", draws=300, seed=7, concentration=2.0))
    assert again.local_fairness == bayes.local_fairness  # the seed fixes the draws
    with pytest.raises(InputError, match=r"^intervals: must be an IntervalOptions \(got 'float'\)$"):
        fairness_intervals(t, g, 0.95)
    # the one check that fairness_intervals, audit and certify make of the argument
    options = IntervalOptions(confidence=0.9)
    assert interval_options(options) is options and interval_options(None) is None
    with pytest.raises(InputError, match=r"^intervals: must be an IntervalOptions \(got 'float'\)$"):
        interval_options(0.95)


def test_min_max_ratio_falls_back_on_the_pairwise_floor_where_the_lp_is_not_proved(monkeypatch):
    # disjoint cells: the floor max(1, max_a lo_a / min_a hi_a) = 0.5 / 0.3 is the exact min-max ratio, by hand; the LP
    # gives it where it is proved optimal, the closed-form floor where it is not (its value None)
    import fairaudit.metrics.box_extremes as box
    from fairaudit.metrics.box_extremes import MinMaxRatio

    W, lo, hi = np.eye(3), np.array([0.2, 0.5, 0.1]), np.array([0.3, 0.6, 0.4])
    program = MinMaxRatio(3, 3)
    floors = box.pair_floors
    with monkeypatch.context() as m:  # the LP proved optimal: no pair's floor is computed (O(A^2 n log n) of work)
        m.setattr(box, "pair_floors", lambda *a: pytest.fail("the floors were computed beside an optimal LP"))
        assert program.solve(W, lo, hi) == pytest.approx(0.5 / 0.3, rel=1e-15)
    assert float(floors(W, lo, hi).max()) == pytest.approx(0.5 / 0.3, rel=1e-15)
    monkeypatch.setattr(MinMaxRatio, "lp", lambda self, W, lo, hi: None)
    assert program.solve(W, lo, hi) == pytest.approx(0.5 / 0.3, rel=1e-15)
    assert program.solve(W, lo, np.array([0.6, 0.6, 0.6])) == 1.0  # the boxes overlap: parity is reachable
