"""fairness_range: L and L̄ over every utility of the unparsed decision in [low, high], per kernel cell.

Independent routes: a hand case in exact fractions (no filter, two groups: the closed forms
max(1, max lo / min hi) and max hi / lo'), and LPs over the assignment v itself (cvxpy with Clarabel):
Charnes–Cooper per pair for the upper end, bisection on r with feasibility LPs for the lower end.
"""

from __future__ import annotations

import math
import warnings
from fractions import Fraction as F

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit import Kernel, Population, Utility, compose, global_fairness, local_fairness
from fairaudit.base.errors import InputError
from fairaudit.laws.mechanisms import from_matrix, identity
from fairaudit.metrics.utility_range import fairness_range

cp = pytest.importorskip("cvxpy")


def test_hand_case_in_fractions_without_a_filter():
    # Decisions yes (g = 1), no (g = 0), unparsed (default 1/2, known within [0, 1]).
    k = [[[F(1, 2), F(1, 5), F(3, 10)], [F(1, 5), F(3, 5), F(1, 5)]]]
    # Boxes: a: [1/2, 1/2 + 3/10] = [1/2, 4/5]; b: [1/5, 2/5].
    lo = {"a": F(1, 2), "b": F(1, 5)}
    hi = {"a": F(4, 5), "b": F(2, 5)}
    want_upper = max(hi["a"] / lo["b"], hi["b"] / lo["a"])  # 4
    want_lower = max(F(1), max(lo.values()) / min(hi.values()))  # 5/4
    stated = (F(1, 2) + F(3, 20)) / (F(1, 5) + F(1, 10))  # 13/6
    kern = Kernel(np.array(k, dtype=float), ["x"], ["a", "b"], ["yes", "no", "unparsed"])
    r = fairness_range(kern, Utility([1.0, 0.0, 0.5], ["yes", "no", "unparsed"]))
    for rng in (r.local_fairness, r.global_fairness):
        assert math.exp(rng.upper) == pytest.approx(float(want_upper), rel=1e-12)
        assert math.exp(rng.lower) == pytest.approx(float(want_lower), rel=1e-8)
        assert math.exp(rng.value) == pytest.approx(float(stated), rel=1e-12)
        assert (rng.upper_group, rng.upper_other_group) == ("a", "b")
        assert (rng.lower_group, rng.lower_other_group) == ("a", "b")
    assert r.local_fairness.upper_context == r.local_fairness.lower_context == "x"
    assert r.local_fairness.exact and (r.low, r.high, r.decision) == (0.0, 1.0, "unparsed")
    np.testing.assert_allclose(r.kernel_lower, [[0.5, 0.2]])
    np.testing.assert_allclose(r.kernel_upper, [[0.8, 0.4]])


def test_no_unparsed_mass_gives_a_point():
    kern = Kernel([[[0.7, 0.3, 0.0], [0.4, 0.6, 0.0]]], ["x"], ["a", "b"], ["yes", "no", "unparsed"])
    r = fairness_range(kern, Utility([1.0, 0.0, 0.5], ["yes", "no", "unparsed"]))
    assert r.local_fairness.lower == pytest.approx(math.log(7 / 4), rel=1e-8)
    assert r.local_fairness.upper == pytest.approx(math.log(7 / 4), rel=1e-12)


def test_no_unparsed_mass_behind_a_filter_gives_the_metrics_own_value_bit_for_bit():
    # the range is a point: both ends are L and L-bar as local_fairness and global_fairness compute them, not the
    # same number by another sum (which differs in the last bits, and then a target met by L reads as missed)
    rng = np.random.default_rng(7)
    p = rng.dirichlet(np.ones(2), size=(3, 4))
    kern = Kernel(np.concatenate([p, np.zeros((3, 4, 1))], -1), ["x", "y", "z"], list("abcd"), ["yes", "no", "?"])
    m_a = from_matrix(rng.dirichlet(np.ones(4) * 3, size=4), list("abcd"), list("abcd"))
    m_x = from_matrix(rng.dirichlet(np.ones(3) * 3, size=3), ["x", "y", "z"], ["x", "y", "z"])
    g = Utility([1.0, 0.0, 0.5], ["yes", "no", "?"])
    r = fairness_range(kern, g, sensitive_mechanism=m_a, context_mechanism=m_x)
    for got in (r.local_fairness, r.global_fairness):
        assert got.lower == got.upper == got.value
    assert r.local_fairness.value == local_fairness(compose(kern, m_a, m_x), g).value
    assert r.global_fairness.value == global_fairness(compose(kern, m_a, m_x), g, r.population).value


def test_bad_inputs_name_the_parameter():
    kern = Kernel([[[0.7, 0.3], [0.4, 0.6]]], ["x"], ["a", "b"], ["yes", "unparsed"])
    g = Utility([1.0, 0.5], ["yes", "unparsed"])
    with pytest.raises(InputError, match="decision"):
        fairness_range(kern, g, 2)
    with pytest.raises(InputError, match="low"):
        fairness_range(kern, g, low=1.0, high=0.0)


# --------------------------------------------------------------------------- an LP over the assignment v


def _upper_lp(Wa, Wb, rest, kd, lo, hi):
    """max over v ∈ [lo, hi]^n of (Wa·(rest + kd v)) / (Wb·(rest + kd v)), Charnes–Cooper (y = t v)."""
    n = len(rest)
    y, t = cp.Variable(n), cp.Variable(nonneg=True)
    num = Wa @ (rest * t) + Wa @ cp.multiply(kd, y)
    den = Wb @ (rest * t) + Wb @ cp.multiply(kd, y)
    prob = cp.Problem(cp.Maximize(num), [den == 1, y >= lo * t, y <= hi * t])
    prob.solve(solver=cp.CLARABEL)
    return prob.value


def _lower_lp(W, rest, kd, lo, hi, top):
    """min over v of max_a E_a / min_b E_b: bisection on r, each r a feasibility LP (E_a ≤ r E_b for all a, b)."""
    v = cp.Variable(len(rest))
    r = cp.Parameter(nonneg=True)
    e = W @ (rest + cp.multiply(kd, v))
    return _bisect(
        r, [v >= lo, v <= hi], [e[a] - r * e[b] for a in range(len(W)) for b in range(len(W)) if a != b], top
    )


def _bisect(r, box, gaps, top):
    """The smallest r at which some v in the box has every gap ≤ 0: min over v of the largest gap, by LP, per r."""
    s = cp.Variable()
    prob = cp.Problem(cp.Minimize(s), box + [gap <= s for gap in gaps])
    a, b = 1.0, top
    for _ in range(40):
        r.value = (a + b) / 2
        prob.solve(solver=cp.CLARABEL)
        a, b = (a, r.value) if prob.value <= 1e-12 else (r.value, b)
    return b


@st.composite
def _cases(draw):
    X = draw(st.integers(1, 2))
    At = draw(st.integers(2, 3))
    A = draw(st.integers(2, 3))
    seed = draw(st.integers(0, 2**31))
    rng = np.random.default_rng(seed)
    k = rng.dirichlet(np.ones(3), size=(X, At))
    m = rng.dirichlet(np.ones(At), size=A)
    p = rng.dirichlet(np.ones(X * A)).reshape(X, A)
    return k, m, p


@pytest.mark.slow
@settings(max_examples=12)
@given(_cases())
def test_against_an_lp_over_the_assignment(case):
    k, m, p = case
    X, At, _ = k.shape
    A = len(m)
    groups = [f"g{i}" for i in range(At)]
    contexts = [f"x{i}" for i in range(X)]
    kern = Kernel(k, contexts, groups, ["yes", "no", "unparsed"])
    mech = from_matrix(m, [f"a{i}" for i in range(A)], groups)
    pop = Population(p, contexts, mech.inputs)
    g = np.array([1.0, 0.0, 0.5])
    r = fairness_range(kern, Utility(g, kern.decisions), sensitive_mechanism=mech, population=pop)
    rest, kd = k[..., :2] @ g[:2], k[..., 2]
    # local: per context its own cells (M_X is the identity)
    ups, lows = [], []
    for x in range(X):
        ups.append(max(_upper_lp(m[a], m[b], rest[x], kd[x], 0.0, 1.0) for a in range(A) for b in range(A) if a != b))
        lows.append(_lower_lp(m, rest[x], kd[x], 0.0, 1.0, ups[-1] + 1.0))
    assert math.exp(r.local_fairness.upper) == pytest.approx(max(ups), rel=1e-6)
    assert math.exp(r.local_fairness.lower) == pytest.approx(max(lows), rel=1e-6, abs=1e-6)
    assert r.local_fairness.lower <= r.local_fairness.value <= r.local_fairness.upper
    # global: groups mix every cell by P(x | a)
    w = p / p.sum(0)
    Wg = np.einsum("xa,ab->axb", w, m).reshape(A, X * At)
    fr, fk = rest.reshape(-1), kd.reshape(-1)
    up = max(_upper_lp(Wg[a], Wg[b], fr, fk, 0.0, 1.0) for a in range(A) for b in range(A) if a != b)
    assert math.exp(r.global_fairness.upper) == pytest.approx(up, rel=1e-6)
    assert math.exp(r.global_fairness.lower) == pytest.approx(_lower_lp(Wg, fr, fk, 0.0, 1.0, up + 1.0), rel=1e-6)


def test_a_context_mechanism_gives_a_valid_outer_range():
    rng = np.random.default_rng(3)
    k = rng.dirichlet(np.ones(3), size=(2, 2))
    kern = Kernel(k, ["x0", "x1"], ["a", "b"], ["yes", "no", "unparsed"])
    mx = from_matrix([[0.8, 0.2], [0.3, 0.7]], ["x0", "x1"])
    r = fairness_range(kern, Utility([1.0, 0.0, 0.5], kern.decisions), context_mechanism=mx)
    assert not r.local_fairness.exact and r.global_fairness.exact
    W = np.einsum("xy,ab->xayb", mx.matrix, np.eye(2)).reshape(2, 2, 4)
    rest, kd = (k[..., :2] @ [1.0, 0.0]).reshape(-1), k[..., 2].reshape(-1)
    up = max(_upper_lp(W[x, a], W[x, 1 - a], rest, kd, 0.0, 1.0) for x in range(2) for a in range(2))
    assert math.exp(r.local_fairness.upper) == pytest.approx(up, rel=1e-6)
    exact_low = _lower_lp_contexts(W, rest, kd)
    assert math.exp(r.local_fairness.lower) <= exact_low * (1 + 1e-6)


def _lower_lp_contexts(W, rest, kd):
    """min over v of max over contexts and pairs of the ratio (contexts share cells): bisection."""
    v = cp.Variable(len(rest))
    r = cp.Parameter(nonneg=True)
    gaps = []
    for x in range(len(W)):
        e = W[x] @ (rest + cp.multiply(kd, v))
        gaps += [e[0] - r * e[1], e[1] - r * e[0]]
    return _bisect(r, [v >= 0.0, v <= 1.0], gaps, 100.0)


def test_identity_defaults_match_explicit_identities():
    k = np.random.default_rng(5).dirichlet(np.ones(3), size=(2, 3))
    kern = Kernel(k, ["x0", "x1"], ["a", "b", "c"], ["yes", "no", "unparsed"])
    g = Utility([1.0, 0.0, 0.5], kern.decisions)
    r1 = fairness_range(kern, g)
    r2 = fairness_range(kern, g, sensitive_mechanism=identity(kern.groups), context_mechanism=identity(kern.contexts))
    assert r1.local_fairness.to_dict() == r2.local_fairness.to_dict()


def test_upper_end_only_skips_the_lower_end_and_keeps_the_upper_end():
    # lower_end=False (what calibration on the upper end calls at every ε): the same upper ends, bit for bit,
    # and no lower end; with and without a context mechanism.
    rng = np.random.default_rng(11)
    k = rng.dirichlet(np.ones(3), size=(2, 3))
    kern = Kernel(k, ["x0", "x1"], ["a", "b", "c"], ["yes", "no", "unparsed"])
    g = Utility([1.0, 0.0, 0.5], kern.decisions)
    ma = from_matrix(rng.dirichlet(np.ones(3), size=3), ["a", "b", "c"], kern.groups)
    for mx in (None, from_matrix([[0.8, 0.2], [0.3, 0.7]], ["x0", "x1"])):
        both = fairness_range(kern, g, sensitive_mechanism=ma, context_mechanism=mx)
        upper = fairness_range(kern, g, sensitive_mechanism=ma, context_mechanism=mx, lower_end=False)
        for b, u in ((both.local_fairness, upper.local_fairness), (both.global_fairness, upper.global_fairness)):
            assert u.upper == b.upper and u.value == b.value and b.lower < b.upper
            assert (u.upper_context, u.upper_group, u.upper_other_group) == (
                b.upper_context, b.upper_group, b.upper_other_group,
            )  # fmt: skip
            assert math.isnan(u.lower) and u.lower_group is None and u.lower_context is None


def test_a_law_from_counts_leaves_its_empty_cells_out_as_the_metrics_do():
    # The law itself (the paper design's: the filter is in the queries), with an empty cell (y, b) and a group c
    # without records. x: a counts (5, 2, 3), b (2, 6, 2) with unparsed in [0, 1], the hand case's boxes
    # [1/2, 4/5] and [1/5, 2/5]; y has only a: fewer than two groups, no ratio. Closed forms without a filter
    # (proofs/unparsed.md §3): L in [max(1, (1/2)/(2/5)), (4/5)/(1/5)] = [5/4, 4]. L̄ with the records' P(x | a):
    # a = 10/12 x + 2/12 y, y's a at 1/2 (no unparsed): [1/2, 3/4]; b = x only: [1/5, 2/5]; c has P(A = c) = 0.
    # So L̄ in [max(1, (1/2)/(2/5)), (3/4)/(1/5)] = [5/4, 15/4].
    from fairaudit import Law
    from fairaudit.metrics.fairness import global_fairness, local_fairness

    law = Law.from_counts(
        [[[5, 2, 3], [2, 6, 2], [0, 0, 0]], [[1, 1, 0], [0, 0, 0], [0, 0, 0]]],
        ["x", "y"], ["a", "b", "c"], ["yes", "no", "unparsed"],
    )  # fmt: skip
    g = Utility([1.0, 0.0, 0.5], ["yes", "no", "unparsed"])
    r = fairness_range(law, g)
    assert r.local_fairness.value == local_fairness(law, g).value  # the law's own metrics, the same numbers
    assert r.global_fairness.value == global_fairness(law, g).value
    local, glob = r.local_fairness, r.global_fairness
    assert (math.exp(local.lower), math.exp(local.upper)) == (pytest.approx(1.25, rel=1e-8), pytest.approx(4.0))
    assert (math.exp(glob.lower), math.exp(glob.upper)) == (pytest.approx(1.25, rel=1e-8), pytest.approx(3.75))
    assert (local.upper_context, local.upper_group, local.upper_other_group) == ("x", "a", "b")
    assert (local.lower_context, local.lower_group, local.lower_other_group) == ("x", "a", "b")
    assert (glob.upper_group, glob.upper_other_group, glob.lower_group, glob.lower_other_group) == ("a", "b") * 2
    with pytest.raises(InputError, match="^sensitive_mechanism: must not be given with a Law"):
        fairness_range(law, g, sensitive_mechanism=identity(law.groups))


def test_the_lower_end_s_pair_is_found_without_a_warning_where_its_ratio_is_beyond_the_floats():
    # one group's weights 1e-310 times the other's: the ratio of the first over the second, 1e310, is beyond the
    # floats (its inverse is subnormal), so it is +inf, the largest: that pair, and no RuntimeWarning about it
    from fairaudit.metrics.utility_range import _lower_pair

    weights = np.array([[1.0, 1.0], [1e-310, 1e-310]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _lower_pair(weights, np.full(2, 0.5), np.ones(2)) == (0, 1)
