"""Families ε ↦ M_ε: k-ary randomized response and products of randomized responses with a fixed split of ε."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import brentq

import fairaudit as fa
from fairaudit import InputError, from_matrix
from fairaudit.laws.closed_forms import keep_probability
from fairaudit.laws.families import product_family, product_rows_family, randomized_response_family


@given(st.floats(0.0, 60.0), st.integers(2, 12))
def test_family_keep_is_the_checked_keep_probability(eps, k):
    # A family's keep skips the checks (a calibration scan calls it thousands of times) but gives the same double,
    # and the member's own diagonal: P(a | a) of the matrix.
    fam = fa.randomized_response_family(list(range(k)))
    assert fam.keep(eps) == keep_probability(eps, k) == fam.keep_probability(eps)
    assert fam.keep(eps) == pytest.approx(float(np.min(np.diag(fam(eps).matrix))), rel=1e-12)
    assert fam.keep(math.inf) == 1.0


def test_product_family_keep_is_the_product_of_its_components():
    # Equal split of 2 ln(7/3): k = 2 keeps with 7/10, k = 3 with 1 / (1 + 2 · 3/7) = 7/13.
    fam = fa.product_family(["a", "b"], [1, 2, 3], weights=[1, 1])
    assert fam.keep(2 * math.log(7 / 3)) == pytest.approx(float(Fraction(49, 130)), rel=1e-14)
    assert fam.keep(2 * math.log(7 / 3)) == fam.keep_probability(2 * math.log(7 / 3))
    # Split as ln(7/3) : ln(14/3): k = 2 at ln(7/3) and k = 3 at ln(14/3) both keep with 7/10.
    eps = math.log(7 / 3) + math.log(14 / 3)
    fam2 = fa.product_family(["a", "b"], [1, 2, 3], weights=[math.log(7 / 3), math.log(14 / 3)])
    assert fam2.keep(eps) == pytest.approx(float(Fraction(49, 100)), rel=1e-14)


def test_randomized_response_family_members_have_the_requested_epsilon():
    fam = randomized_response_family(list("abcd"))
    for eps in (0.0, 0.3, 2.0):
        m = fam(eps)
        assert m.epsilon == pytest.approx(eps, abs=1e-12)
        # keep probability by hand: e^eps / (e^eps + 3)
        assert fam.keep_probability(eps) == pytest.approx(math.exp(eps) / (math.exp(eps) + 3), rel=1e-15)
    assert np.array_equal(fam(math.inf).matrix, np.eye(4))


def test_product_family_splits_epsilon_by_weight():
    fam = product_family(["x", "y"], [1, 2, 3], weights=[1, 3])
    m = fam(2.0)
    assert m.epsilon == pytest.approx(2.0, abs=1e-12)
    # component budgets 0.5 and 1.5: keep = e^.5/(e^.5+1) * e^1.5/(e^1.5+2)
    want = math.exp(0.5) / (math.exp(0.5) + 1) * math.exp(1.5) / (math.exp(1.5) + 2)
    assert fam.keep_probability(2.0) == pytest.approx(want, rel=1e-14)
    assert fam.keep_probability(math.inf) == 1.0
    with pytest.raises(fa.InputError, match="weights"):
        product_family(["x", "y"], [1, 2], weights=[1])
    with pytest.raises(fa.InputError, match=r"values\[1\]"):
        product_family(["x", "y"], [1])


def test_randomized_response_on_a_range_keeps_the_range_whatever_k():
    """10^12 groups: their labels stay the range (O(1) memory), not 10^12 int objects; keep e^ε / (e^ε + k − 1)."""
    fam = randomized_response_family(range(10**12))
    assert fam.inputs == range(10**12) and fam(1.0).inputs is fam.inputs
    assert fam.keep_probability(30.0) == pytest.approx(math.exp(30) / (math.exp(30) + 10**12 - 1), rel=1e-15)


@given(st.floats(0.0, 30.0))
def test_product_rows_family_is_the_products_rows_at_its_rescaled_epsilon(eps):
    # Shares 1 : 2 : 1 over (a, b), (1, 2, 3), (x, y); the kept rows differ in the first two components only, so
    # c = 3/4 and the member at eps is the full product's at 4 eps / 3 on those rows.
    values = (["a", "b"], [1, 2, 3], ["x", "y"])
    rows = [("a", 1, "x"), ("b", 3, "x")]
    fam = product_rows_family(*values, rows=rows, inputs=["r", "s"], weights=[1, 2, 1])
    full = product_family(*values, weights=[1, 2, 1])(4 * eps / 3)
    member = fam(eps)
    np.testing.assert_allclose(
        member.matrix, full.matrix[[full.inputs.index(r) for r in rows]], rtol=1e-12, atol=1e-300
    )
    assert member.inputs == ("r", "s") and member.outputs == full.outputs
    assert member.epsilon == pytest.approx(eps, rel=1e-12, abs=1e-12)
    assert fam.keep(eps) == pytest.approx(product_family(*values, weights=[1, 2, 1]).keep(4 * eps / 3), rel=1e-12)


@given(st.floats(0.05, 20.0))
def test_product_rows_family_of_mixtures_mixes_the_products_rows(eps):
    # r is (a, 1, x) or (a, 2, x), s is (b, 3, x): the member at eps is W times the full product's rows at the t where
    # that mixture's epsilon is eps (found here by the product family and brentq, not by the family).
    values = (["a", "b"], [1, 2, 3], ["x", "y"])
    rows = [("a", 1, "x"), ("a", 2, "x"), ("b", 3, "x")]
    mixture = [[0.25, 0.75, 0.0], [0.0, 0.0, 1.0]]
    fam = product_rows_family(*values, rows=rows, inputs=["r", "s"], weights=[1, 2, 1], mixture=mixture)
    full = product_family(*values, weights=[1, 2, 1])

    def at(t):
        return np.asarray(mixture) @ full(t).matrix[[full.inputs.index(r) for r in rows]]

    t = brentq(lambda t: from_matrix(at(t), ["r", "s"], full.inputs).epsilon - eps, eps, 10 * eps, xtol=1e-14)
    np.testing.assert_allclose(fam(eps).matrix, at(t), rtol=1e-10, atol=1e-300)
    assert fam(eps).epsilon == pytest.approx(eps, rel=1e-10)


def test_product_rows_family_checks_its_mixture():
    values, rows = (["a", "b"], ["x", "y"]), [("a", "x"), ("b", "y")]
    for mixture, problem in (
        ([[1.0, 0.0]], r"mixture: needs shape \(inputs, rows\) = \(2, 2\) \(got \(1, 2\)\)"),
        ([[1.5, -0.5], [0.0, 1.0]], "mixture: each row must be non-negative and sum to 1"),
        ([[0.5, 0.4], [0.0, 1.0]], "mixture: each row must be non-negative and sum to 1"),
        ([[0.5, 0.5], [0.5, 0.5]], "mixture: the inputs' mixtures stay within epsilon 0 at every scale"),
    ):
        with pytest.raises(InputError, match=problem):
            product_rows_family(*values, rows=rows, inputs=["r", "s"], mixture=mixture)
