"""k-ary randomized response in closed form: ε, δ(ε), keep probabilities, the split of a budget by keep.

Every expected value comes from an independent route: a hand calculation in a
comment, exact ``Fraction`` arithmetic, root finding, or a peer library (OpenDP
for ε of randomized response, Google's dp-accounting for the hockey-stick
divergence δ(ε)).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fairaudit as fa
from fairaudit.laws import closed_forms
from fairaudit.laws.closed_forms import epsilon_from_keep_probability, keep_probability

# --------------------------------------------------------------------------- binary randomized response


def test_binary_rr_keep_07_epsilon_is_log_7_over_3_not_paper_ratio():
    m = fa.randomized_response(["Tom", "Mary"], keep=0.7)
    # Hand: the largest likelihood ratio is P(Tom | Tom) / P(Tom | Mary) = 0.7 / 0.3 = 7/3.
    assert m.epsilon == pytest.approx(math.log(7 / 3), rel=1e-12)
    assert m.epsilon == pytest.approx(0.8472978603872037, rel=1e-12)
    # The seed paper's error 1: ε = p / (1 − p) = 2.333 is not the budget.
    assert m.epsilon != pytest.approx(0.7 / 0.3, rel=1e-3)


def test_binary_rr_keep_07_delta_at_half():
    m = fa.randomized_response(["Tom", "Mary"], keep=0.7)
    # Hand: Σ_o [M[0,o] − e^0.5 M[1,o]]₊ = [0.7 − 1.648721·0.3]₊ + [0.3 − 1.648721·0.7]₊
    #      = 0.7 − 0.494616 + 0 = 0.205384; the pair (Mary, Tom) is symmetric.
    expected = 0.7 - math.exp(0.5) * 0.3
    assert m.delta(0.5) == pytest.approx(expected, rel=1e-12)
    assert m.delta(0.5) == pytest.approx(0.20538, abs=5e-6)
    assert m.pairwise_delta(0.5) == pytest.approx(np.array([[0.0, expected], [expected, 0.0]]), rel=1e-12)
    # δ(0) is the total variation 0.7 − 0.3 = 0.4; δ(ε(M)) = 0.
    assert m.delta(0.0) == pytest.approx(0.4, rel=1e-12)
    assert m.delta(math.log(7 / 3)) == pytest.approx(0.0, abs=1e-15)


def test_delta_accepts_arrays_of_epsilon():
    m = fa.randomized_response([0, 1], keep=0.7)
    eps = np.array([[0.0, 0.5], [1.0, 2.0]])
    out = m.delta(eps)
    assert out.shape == (2, 2)
    # Hand: [0.7 − e^ε 0.3]₊ elementwise.
    assert out.ravel().tolist() == pytest.approx(
        [max(0.0, 0.7 - math.exp(e) * 0.3) for e in eps.ravel()], rel=1e-12, abs=1e-15
    )


# --------------------------------------------------------------------------- k-ary randomized response


def test_kary_rr_matrix_by_fractions_eps_log4_k3():
    m = fa.randomized_response(["a", "b", "c"], epsilon=math.log(4))
    # e^ε = 4: keep = 4 / (4 + 2) = 2/3, move = 1 / (4 + 2) = 1/6.
    e = Fraction(4)
    keep, move = e / (e + 2), 1 / (e + 2)
    assert keep == Fraction(2, 3) and move == Fraction(1, 6)
    expected = [[float(keep if i == j else move) for j in range(3)] for i in range(3)]
    assert m.matrix.tolist() == [pytest.approx(row, rel=1e-12) for row in expected]
    assert m.epsilon == pytest.approx(math.log(4), rel=1e-12)
    assert m.keep_probability == pytest.approx(2 / 3, rel=1e-12)
    assert keep_probability(math.log(4), 3) == pytest.approx(float(keep), rel=1e-12)
    # ε = log(p (k − 1) / (1 − p)) = log((2/3)·2 / (1/3)) = log 4.
    assert epsilon_from_keep_probability(2 / 3, 3) == pytest.approx(math.log(4), rel=1e-12)


@given(st.floats(0.0, 15.0), st.integers(2, 12))
def test_keep_probability_round_trip(eps, k):
    p = keep_probability(eps, k)
    # Closed form p = e^ε / (e^ε + k − 1), written independently.
    assert p == pytest.approx(math.exp(eps) / (math.exp(eps) + k - 1), rel=1e-12)
    # 1 − p loses ~e^-ε relative precision; abs 1e-8 covers ε ≤ 15.
    assert epsilon_from_keep_probability(p, k) == pytest.approx(eps, rel=1e-9, abs=1e-8)


@given(st.floats(0.0, 8.0), st.integers(2, 9))
def test_rr_from_keep_equals_rr_from_epsilon(eps, k):
    a = fa.randomized_response(list(range(k)), epsilon=eps)
    b = fa.randomized_response(list(range(k)), keep=keep_probability(eps, k))
    assert np.allclose(a.matrix, b.matrix, rtol=1e-12, atol=1e-15)
    assert b.epsilon == pytest.approx(eps, rel=1e-9, abs=1e-12)


def test_rr_edge_cases():
    # keep = 1/k: every row uniform, ε = 0; keep = 1: the identity, ε = inf.
    m = fa.randomized_response([0, 1, 2], keep=1 / 3)
    assert m.matrix.tolist() == [pytest.approx([1 / 3] * 3, rel=1e-12)] * 3
    assert m.epsilon == pytest.approx(0.0, abs=1e-12)
    ident = fa.randomized_response([0, 1, 2], keep=1.0)
    assert ident.matrix.tolist() == np.eye(3).tolist()
    assert math.isinf(ident.epsilon)
    assert math.isinf(fa.randomized_response([0, 1], epsilon=math.inf).epsilon)
    assert fa.identity(["x", "y"]).epsilon == math.inf
    assert fa.randomized_response(["only"], epsilon=3.0).epsilon == 0.0


def test_epsilon_for_delta_inverts_rr_closed_form():
    # k-ary RR: δ(ε') = p − e^ε' q for ε' ≤ ε, so ε'(δ) = log((p − δ)/q).
    k, eps = 4, 1.5
    m = fa.randomized_response(list(range(k)), epsilon=eps)
    p = math.exp(eps) / (math.exp(eps) + k - 1)
    q = 1 / (math.exp(eps) + k - 1)
    for d in (0.01, 0.1, 0.3):
        assert m.epsilon_for_delta(d) == pytest.approx(math.log((p - d) / q), rel=1e-11)
    assert m.epsilon_for_delta(0.0) == pytest.approx(eps, rel=1e-12)
    assert m.epsilon_for_delta(p - q) == 0.0  # δ(0) = TV = p − q
    with pytest.raises(fa.InputError, match="delta"):
        m.epsilon_for_delta(1.5)


# --------------------------------------------------------------------------- peers: OpenDP


@pytest.fixture(scope="module")
def opendp():
    dp = pytest.importorskip("opendp.prelude")
    dp.enable_features("contrib")
    return dp


def test_opendp_bool_rr_epsilon(opendp):
    # opendp.measurements.make_randomized_response_bool(prob): prob = P(return the true value); .map(1) = ε.
    for prob in (0.5, 0.55, 0.7, 0.9, 0.99):
        peer = opendp.m.make_randomized_response_bool(prob).map(1)
        ours = fa.randomized_response([True, False], keep=prob).epsilon
        assert ours == pytest.approx(peer, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("k,prob", [(3, 0.7), (3, 0.34), (4, 0.5), (5, 0.4), (8, 0.9), (10, 0.15)])
def test_opendp_kary_rr_epsilon(opendp, k, prob):
    # opendp.measurements.make_randomized_response(categories, prob): prob = P(return the true category),
    # in [1/k, 1] (help() docstring) -- the same parameter as our keep probability.
    cats = [f"c{i}" for i in range(k)]
    peer = opendp.m.make_randomized_response(cats, prob).map(1)
    ours = fa.randomized_response(cats, keep=prob)
    assert ours.epsilon == pytest.approx(peer, rel=1e-12)
    assert epsilon_from_keep_probability(prob, k) == pytest.approx(peer, rel=1e-12)


# --------------------------------------------------------------------------- peers: dp-accounting


@pytest.fixture(scope="module")
def pld_module():
    return pytest.importorskip("dp_accounting.pld.privacy_loss_distribution")


# dp-accounting discretises privacy losses to multiples of value_discretization_interval (1e-6 here) and,
# with pessimistic_estimate=True (default), rounds them up: its δ(ε) is an upper estimate of the exact value,
# off by at most about 1e-6 · e^ε on these mechanisms. Hence: peer ≥ ours − 1e-12 and peer − ours ≤ 5e-6.
PLD_INTERVAL = 1e-6
PLD_TOL = 5e-6


@pytest.mark.parametrize("k,keep", [(2, 0.7), (3, 0.7), (4, 0.55), (6, 0.8)])
def test_dp_accounting_randomized_response_delta(pld_module, k, keep):
    # privacy_loss_distribution.from_randomized_response(noise_parameter, num_buckets): with probability
    # 1 − noise it outputs the input, else a uniform bucket; so P(keep) = 1 − noise + noise/k and
    # noise = (1 − keep)·k/(k − 1). Neighbouring relation REPLACE_ONE = any two inputs (our adjacency).
    noise = (1 - keep) * k / (k - 1)
    pld = pld_module.from_randomized_response(noise, k, value_discretization_interval=PLD_INTERVAL)
    m = fa.randomized_response(list(range(k)), keep=keep)
    for eps in (0.0, 0.2, 0.5, 0.9, m.epsilon * 0.99):
        peer = pld.get_delta_for_epsilon(eps)
        ours = m.delta(eps)
        assert peer >= ours - 1e-12
        assert peer == pytest.approx(ours, abs=PLD_TOL)


# --------------------------------------------------------------------------- errors


def test_rr_argument_errors():
    with pytest.raises(fa.InputError, match="exactly one of epsilon and keep"):
        fa.randomized_response([0, 1])
    with pytest.raises(fa.InputError, match="exactly one of epsilon and keep"):
        fa.randomized_response([0, 1], 1.0, keep=0.7)
    with pytest.raises(fa.InputError, match=r"keep.*\[1/k, 1\]"):
        fa.randomized_response([0, 1, 2], keep=0.2)
    with pytest.raises(fa.InputError, match="epsilon"):
        fa.randomized_response([0, 1], epsilon=-0.1)
    with pytest.raises(fa.InputError, match="epsilon"):
        fa.randomized_response([0, 1], epsilon=float("nan"))
    with pytest.raises(fa.InputError, match="epsilon"):
        fa.randomized_response([0, 1], keep=0.7).delta(-1.0)
    with pytest.raises(fa.InputError, match="k"):
        closed_forms.epsilon_from_keep_probability(0.7, 1)


# -- a shared keep probability (proofs/closed_forms.md, Proposition 6) ------------------------------------------------


@pytest.mark.parametrize(
    "keep, sizes",
    [
        (Fraction(3, 5), [3, 2, 3]),
        (Fraction(7, 10), [2, 2, 2]),
        (Fraction(9, 10), [5, 2, 17, 3]),
        (Fraction(1, 2), [2, 4]),
    ],
)
def test_split_by_keep_matches_each_keep_by_fractions(keep, sizes):
    # each attribute's e^eps_i = p (k_i - 1) / (1 - p), in exact fractions; the profile's budget is their sum
    ratios = [keep * (k - 1) / (1 - keep) for k in sizes]
    total = sum(math.log(r) for r in ratios)
    eps = closed_forms.split_by_keep(total, sizes)
    for e, r, k in zip(eps, ratios, sizes):
        assert math.exp(e) == pytest.approx(float(r), rel=1e-14)
        assert keep_probability(float(e), k) == pytest.approx(float(keep), rel=1e-14)
    assert float(eps.sum()) == pytest.approx(total, rel=1e-14)


def test_split_by_keep_even_for_equal_sizes_and_the_ends():
    assert closed_forms.split_by_keep(3.0, [4, 4, 4]).tolist() == pytest.approx([1.0, 1.0, 1.0], rel=1e-15)
    assert closed_forms.split_by_keep(0.0, [3, 2]).tolist() == [0.0, 0.0]
    assert closed_forms.split_by_keep(math.inf, [3, 2]).tolist() == [math.inf, math.inf]
    # below the binary attribute's floor 1/2 it stays uniform; the 3-valued one takes the whole budget
    assert closed_forms.split_by_keep(0.5, [2, 3]).tolist() == [0.0, 0.5]
    with pytest.raises(fa.InputError, match=r"sizes\[1\]"):
        closed_forms.split_by_keep(1.0, [3, 1])
    with pytest.raises(fa.InputError, match="epsilon"):
        closed_forms.split_by_keep(-1.0, [3, 2])


@given(
    st.floats(1e-6, 60.0),
    st.lists(st.integers(2, 40), min_size=1, max_size=6),
)
def test_split_by_keep_against_root_finding(total, sizes):
    # a second algorithm: solve sum_i max(0, l + ln(k_i - 1)) = total for l by bisection, independent of the break points
    from scipy.optimize import brentq

    c = np.log(np.asarray(sizes, dtype=float) - 1.0)
    ell = brentq(lambda v: float(np.maximum(0.0, v + c).sum()) - total, -c.max(), total, xtol=1e-14, rtol=1e-15)
    want = np.maximum(0.0, ell + c)
    got = closed_forms.split_by_keep(total, sizes)
    assert got == pytest.approx(want, rel=1e-9, abs=1e-12)
    assert float(got.sum()) == pytest.approx(total, rel=1e-12)
    assert np.all(got >= 0)
    keeps = [keep_probability(float(e), k) for e, k in zip(got, sizes)]
    active = [q for q, e in zip(keeps, got) if e > 0]  # the attributes above their floor share one keep probability
    assert max(active) - min(active) < 1e-9
    assert all(q >= min(active) - 1e-12 for q in keeps)


# --------------------------------------------------------------------------- how far the float matrix is from the law


@given(
    epsilon=st.one_of(st.floats(0.0, 800.0), st.floats(1e-300, 1e-3)),
    k=st.integers(2, 1000),
)
def test_the_matrix_lies_within_its_counted_roundings_of_the_exact_law(epsilon, k):
    # the exact p = e^ε/(e^ε + k − 1) and q = 1/(e^ε + k − 1) by mpmath at 80 digits: each positive float entry is
    # within γ_R relative (a normal float) or R·2^-1074 absolute (a subnormal one), and R − 1 would not do
    import mpmath

    from fairaudit.base.outward import rounding_error

    m = fa.randomized_response([str(i) for i in range(k)], epsilon=epsilon)
    r = m.matrix_roundings
    with mpmath.workdps(80):
        t = mpmath.exp(mpmath.mpf(epsilon))
        exact = {"p": t / (t + k - 1), "q": 1 / (t + k - 1)}
        errors = []
        for name, computed in (("p", m.rr.p), ("q", m.rr.q)):
            if computed == 0:
                continue
            if computed >= 2.0**-1022:
                errors.append(abs(mpmath.mpf(computed) / exact[name] - 1) / mpmath.mpf(rounding_error(r)))
            else:
                errors.append(abs(mpmath.mpf(computed) - exact[name]) / (r * mpmath.mpf(2) ** -1074))
        assert max(errors) <= 1
        if r > 1:  # one fewer would miss an entry (rounding_error grows by about 2^-53 per rounding)
            assert max(errors) > (r - 1) / r - 1e-6
    assert m.matrix[0, 0] == m.rr.p and (k < 2 or m.matrix[0, 1] == m.rr.q)


def test_a_matrix_and_the_identity_carry_no_roundings():
    assert fa.from_matrix([[0.7, 0.3], [0.3, 0.7]], ["a", "b"]).matrix_roundings == 0
    assert fa.randomized_response(["a", "b"], epsilon=math.inf).matrix_roundings == 0
    assert fa.randomized_response(["a"], epsilon=1.0).matrix_roundings == 0
