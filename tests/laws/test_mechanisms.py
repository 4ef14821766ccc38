"""Finite privacy mechanisms: ε, δ(ε), post-processing, products.

Every expected value comes from an independent route: a hand calculation in a
comment, exact ``Fraction`` arithmetic, brute force over output sets, or a peer
library (Google's dp-accounting for the hockey-stick divergence δ(ε)).
"""

from __future__ import annotations

import itertools
import math
import warnings
from fractions import Fraction

import mpmath
import numpy as np
import pytest

import fairaudit as fa
from fairaudit.laws.mechanisms import log_ratio_up

# --------------------------------------------------------------------------- helpers


def brute_delta(matrix, epsilon: float) -> float:
    """δ(ε) by brute force: max over ordered pairs and over every output set S of P(S) − e^ε Q(S)."""
    m = np.asarray(matrix, dtype=float)
    n, k = m.shape
    best = 0.0
    for a, b in itertools.permutations(range(n), 2):
        for r in range(k + 1):
            for s in itertools.combinations(range(k), r):
                idx = list(s)
                best = max(best, m[a, idx].sum() - math.exp(epsilon) * m[b, idx].sum())
    return best


def fraction_epsilon(rows) -> float:
    """ε = log max M[a, o] / M[a', o] with exact Fraction ratios (all entries > 0)."""
    worst = max(
        rows[a][o] / rows[b][o] for a in range(len(rows)) for b in range(len(rows)) for o in range(len(rows[0]))
    )
    return math.log(worst)


# --------------------------------------------------------------------------- general matrices


def test_kary_rr_epsilon_matches_its_matrix_by_brute_force():
    # ε cached from the argument must equal the ε read off the matrix (Fractions of the entries).
    for k, eps in [(2, 0.3), (3, 1.0), (5, 2.5), (8, 0.01)]:
        m = fa.randomized_response(list(range(k)), epsilon=eps)
        rows = [[Fraction(v) for v in row] for row in m.matrix]
        assert m.epsilon == pytest.approx(eps, rel=1e-12)
        assert fraction_epsilon(rows) == pytest.approx(eps, rel=1e-12)


def test_keep_probability_of_a_general_mechanism():
    # Smallest diagonal entry, matched by label (outputs in a different order).
    m = fa.from_matrix([[0.3, 0.7], [0.6, 0.4]], ["a", "b"], ["b", "a"])
    assert m.keep_probability == pytest.approx(0.6, rel=1e-12)  # P(a|a) = 0.7, P(b|b) = 0.6
    assert fa.from_matrix([[0.5, 0.5]], ["a"], ["x", "y"]).keep_probability is None


def test_epsilon_of_x_privacy_mechanism_is_log3():
    # Paper SI C example: ratios 0.9/0.7, 0.3/0.1 = 3, 0.7/0.9, 0.1/0.3; max = 3.
    m = fa.from_matrix([[0.9, 0.1], [0.7, 0.3]], [0, 1])
    rows = [[Fraction(9, 10), Fraction(1, 10)], [Fraction(7, 10), Fraction(3, 10)]]
    assert fraction_epsilon(rows) == pytest.approx(math.log(3), rel=1e-15)
    assert m.epsilon == pytest.approx(math.log(3), rel=1e-12)


def test_epsilon_with_zero_entries():
    # Output 2 is reachable from row 0 only: ratio c/0 = inf. Zero in both rows (0/0) is parity.
    assert math.isinf(fa.from_matrix([[0.5, 0.25, 0.25, 0.0], [0.5, 0.5, 0.0, 0.0]], [0, 1], [0, 1, 2, 3]).epsilon)
    m = fa.from_matrix([[0.5, 0.5, 0.0], [0.25, 0.75, 0.0]], [0, 1], [0, 1, 2])
    assert m.epsilon == pytest.approx(math.log(2), rel=1e-12)  # 0.5 / 0.25
    # Equal rows: ε = 0.
    assert fa.from_matrix([[0.2, 0.8], [0.2, 0.8]], [0, 1]).epsilon == 0.0


def test_delta_equals_brute_force_over_output_sets():
    rng = np.random.default_rng(20240611)
    for _ in range(40):
        n, k = int(rng.integers(2, 5)), int(rng.integers(2, 6))
        matrix = rng.dirichlet(np.ones(k), size=n)
        m = fa.from_matrix(matrix, list(range(n)), list(range(k)))
        for eps in (0.0, 0.1, 0.5, 1.3, 4.0):
            assert m.delta(eps) == pytest.approx(brute_delta(matrix, eps), rel=1e-12, abs=1e-15)


def test_delta_at_infinity_is_disjoint_mass():
    # Row 0 puts 0.25 on output 2, which row 1 never produces: δ(∞) = 0.25.
    m = fa.from_matrix([[0.5, 0.25, 0.25], [0.5, 0.5, 0.0]], [0, 1], [0, 1, 2])
    assert m.pairwise_delta(math.inf)[0, 1] == pytest.approx(0.25, rel=1e-12)
    assert m.pairwise_delta(math.inf)[1, 0] == 0.0
    assert m.epsilon_for_delta(0.2) == math.inf
    assert math.isfinite(m.epsilon_for_delta(0.3))


def test_profile_default_grid():
    m = fa.randomized_response([0, 1], keep=0.7)
    prof = m.profile()
    assert prof.epsilons[0] == 0.0 and prof.epsilons[-1] == pytest.approx(math.log(7 / 3), rel=1e-12)
    assert len(prof.epsilons) == 101
    assert prof.deltas.tolist() == pytest.approx(
        [max(0.0, 0.7 - math.exp(e) * 0.3) for e in prof.epsilons], rel=1e-12, abs=1e-15
    )


def test_then_is_post_processing():
    # Two binary RRs with keep 0.7 in a row: keep 0.7² + 0.3² = 0.58, flip 0.42.
    rr = fa.randomized_response([0, 1], keep=0.7)
    both = rr.then(rr)
    assert both.matrix.tolist() == [pytest.approx([0.58, 0.42], rel=1e-12), pytest.approx([0.42, 0.58], rel=1e-12)]
    assert both.epsilon == pytest.approx(math.log(58 / 42), rel=1e-12)
    with pytest.raises(fa.InputError, match="inputs"):
        rr.then(fa.randomized_response(["x", "y"], keep=0.7))


# --------------------------------------------------------------------------- products


def test_product_of_three_binary_rr():
    rr = [fa.randomized_response(v, keep=0.7) for v in (["Tom", "Mary"], [25, 55], ["Asian", "American"])]
    m = fa.product(*rr)
    # ε adds up: 3 ln(7/3) = 2.541894 (the seed paper's error 2).
    assert m.epsilon == pytest.approx(3 * math.log(7 / 3), rel=1e-12)
    assert m.epsilon == pytest.approx(2.5419, abs=5e-5)
    # Labels are tuples in itertools.product order.
    expected_labels = tuple(itertools.product(["Tom", "Mary"], [25, 55], ["Asian", "American"]))
    assert m.inputs == expected_labels and m.outputs == expected_labels
    # Hand: (Tom, 25, Asian) -> (Mary, 25, Asian) flips the name only: 0.3 · 0.7 · 0.7 = 0.147.
    i = m.inputs.index(("Tom", 25, "Asian"))
    j = m.outputs.index(("Mary", 25, "Asian"))
    assert m.matrix[i, j] == pytest.approx(0.3 * 0.7 * 0.7, rel=1e-12)
    # Every entry is the product of the components' entries, looked up by label.
    for a in m.inputs:
        for o in m.outputs:
            want = 1.0
            for comp, ai, oi in zip(rr, a, o):
                want *= comp.matrix[comp.inputs.index(ai), comp.outputs.index(oi)]
            assert m.matrix[m.inputs.index(a), m.outputs.index(o)] == pytest.approx(want, rel=1e-12)


def test_product_epsilon_is_sum_by_fractions():
    # Product of 3-ary RR (ε = log 4, entries 2/3, 1/6) and a 2x2 matrix with ratio 3: ε = log 4 + log 3 = log 12.
    a = fa.randomized_response([0, 1, 2], epsilon=math.log(4))
    b = fa.from_matrix([[0.9, 0.1], [0.7, 0.3]], ["x", "y"])
    m = fa.product(a, b)
    fa_rows = [[Fraction(2, 3) if i == j else Fraction(1, 6) for j in range(3)] for i in range(3)]
    fb_rows = [[Fraction(9, 10), Fraction(1, 10)], [Fraction(7, 10), Fraction(3, 10)]]
    rows = [[ra[oa] * rb[ob] for oa in range(3) for ob in range(2)] for ra in fa_rows for rb in fb_rows]
    assert fraction_epsilon(rows) == pytest.approx(math.log(12), rel=1e-15)
    assert m.epsilon == pytest.approx(math.log(12), rel=1e-12)


# --------------------------------------------------------------------------- peers: dp-accounting


@pytest.fixture(scope="module")
def pld_module():
    return pytest.importorskip("dp_accounting.pld.privacy_loss_distribution")


# dp-accounting's δ(ε) is an upper estimate of the exact value, off by at most about 1e-6 · e^ε on these mechanisms
# (see tests/laws/test_closed_forms.py).
PLD_INTERVAL = 1e-6
PLD_TOL = 5e-6


def test_dp_accounting_general_mechanism_delta(pld_module):
    # privacy_loss_distribution.from_two_probability_mass_functions(log_pmf_lower, log_pmf_upper,
    # symmetric=False) for one pair of rows; get_delta_for_epsilon returns the larger hockey-stick divergence
    # of the two directions, so the max over unordered pairs is our δ(M, ε).
    rng = np.random.default_rng(7)
    for _ in range(4):
        n, k = int(rng.integers(2, 5)), int(rng.integers(2, 5))
        matrix = rng.dirichlet(np.full(k, 2.0), size=n)
        m = fa.from_matrix(matrix, list(range(n)), list(range(k)))
        plds = []
        for a, b in itertools.combinations(range(n), 2):
            plds.append(
                pld_module.from_two_probability_mass_functions(
                    {o: math.log(matrix[b, o]) for o in range(k)},
                    {o: math.log(matrix[a, o]) for o in range(k)},
                    value_discretization_interval=PLD_INTERVAL,
                    symmetric=False,
                )
            )
        for eps in (0.0, 0.1, 0.4, 0.8):
            peer = max(p.get_delta_for_epsilon(eps) for p in plds)
            ours = m.delta(eps)
            assert peer >= ours - 1e-12
            assert peer == pytest.approx(ours, abs=PLD_TOL)


# --------------------------------------------------------------------------- errors


def test_mechanism_row_not_summing_to_one():
    with pytest.raises(fa.InputError) as err:
        fa.from_matrix([[0.5, 0.5], [0.6, 0.3]], ["a", "b"], name="M_A")
    text = str(err.value)
    assert "mechanism 'M_A'" in text and "input='b'" in text and "0.9" in text and "not 1" in text


def test_mechanism_negative_and_nan_entries():
    with pytest.raises(fa.InputError, match=r"negative.*-0\.1"):
        fa.from_matrix([[1.1, -0.1], [0.5, 0.5]], ["a", "b"])
    with pytest.raises(fa.InputError, match="not finite"):
        fa.from_matrix([[float("nan"), 1.0], [0.5, 0.5]], ["a", "b"])
    with pytest.raises(fa.InputError, match="shape"):
        fa.from_matrix([[1.0, 0.0], [0.5, 0.5]], ["a", "b", "c"])
    with pytest.raises(fa.InputError, match="distinct"):
        fa.from_matrix([[1.0, 0.0], [0.5, 0.5]], ["a", "a"])


def test_product_needs_a_mechanism():
    with pytest.raises(fa.InputError, match="product"):
        fa.product()


def test_product_refuses_an_entry_below_the_float_range():
    # q = 1/(e^400 + 1) ~ 1.9e-174 is a normal float, but q * q ~ 3.6e-348 is not: the product's epsilon would read
    # +inf from a zero entry, where it is 800 exactly
    rr = fa.randomized_response(["a", "b"], epsilon=400.0)
    assert fa.product(rr, fa.randomized_response([0, 1], epsilon=300.0)).epsilon == pytest.approx(700.0, rel=1e-12)
    with pytest.raises(fa.InputError, match=r"^product: .*smallest normal float"):
        fa.product(rr, fa.randomized_response([0, 1], epsilon=400.0))


def test_a_log_ratio_above_the_float_range_is_finite_and_an_upper_end():
    """0.5 / 1e-310 overflows a float; ln of it is about 712.5 nats, read exactly (it was +inf, with a warning)."""
    with mpmath.workdps(50), warnings.catch_warnings():
        warnings.simplefilter("error")
        got = log_ratio_up([0.5, 0.25], [1e-310, 0.25])
        exact = mpmath.log(mpmath.mpf(0.5) / mpmath.mpf(1e-310))
        assert mpmath.mpf(got) >= exact and mpmath.mpf(got) - exact <= 1e-12 * exact
