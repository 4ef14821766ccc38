"""Populations, kernels, laws and their composition with privacy mechanisms.

Expected values: hand calculations (in comments), exact ``Fraction`` sums over
every (x̃, ã) written as explicit loops, and the paper's X-privacy example.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fairaudit as fa
from fairaudit.base.errors import UnderflowError
from fairaudit.laws.composition import compose

# --------------------------------------------------------------------------- the paper's X-privacy example (SI C)


def x_privacy_kernel() -> fa.Kernel:
    """P(U = 1 | x̃, a) = 1 iff x̃ = a; contexts and groups {0, 1}, decisions (1, 0)."""
    return fa.Kernel([[[1, 0], [0, 1]], [[0, 1], [1, 0]]], [0, 1], [0, 1], [1, 0])


def test_x_privacy_example_with_mechanism():
    m_x = fa.from_matrix([[0.9, 0.1], [0.7, 0.3]], [0, 1], name="M_X")
    assert m_x.epsilon == pytest.approx(math.log(3), rel=1e-12)  # 0.3 / 0.1
    law = compose(x_privacy_kernel(), context=m_x)
    # Hand: Q[x, a, U=1] = P(x̃ = a | x) = M_X[x, a].
    assert law.probabilities[:, :, 0] == pytest.approx(np.array([[0.9, 0.1], [0.7, 0.3]]), rel=1e-12)
    g = fa.indicator(1, [1, 0])
    pop = fa.Population.uniform([0, 1], [0, 1])
    # Global, uniform independent population: E[g | a=0] = (0.9 + 0.7)/2 = 0.8, E[g | a=1] = (0.1 + 0.3)/2 = 0.2,
    # so L̄ = log(0.8 / 0.2) = log 4.
    glob = fa.global_fairness(law, g, pop)
    assert glob.value == pytest.approx(math.log(4), rel=1e-12)
    assert (glob.group, glob.other_group) == (0, 1)
    assert glob.expected_utility == pytest.approx(np.array([0.8, 0.2]), rel=1e-12)
    # Local: context 0 has 0.9 / 0.1 = 9, context 1 has 0.7 / 0.3 = 7/3; L = log 9 at context 0.
    loc = fa.local_fairness(law, g, pop)
    assert loc.value == pytest.approx(math.log(9), rel=1e-12)
    assert (loc.context, loc.group, loc.other_group) == (0, 0, 1)
    assert loc.per_context == pytest.approx(np.array([math.log(9), math.log(7 / 3)]), rel=1e-12)


def test_x_privacy_example_without_mechanism():
    law = compose(x_privacy_kernel())
    g = fa.indicator(1, [1, 0])
    # Hand: Q[x, a, 1] = 1{x = a}: in each context one group gets 1 and the other 0, so L = log(1/0) = inf;
    # E[g | a] = (1 + 0)/2 = 1/2 for both groups, so L̄ = log 1 = 0.
    assert fa.local_fairness(law, g).value == math.inf
    assert fa.global_fairness(law, g).value == pytest.approx(0.0, abs=1e-15)


def test_x_privacy_equality_when_model_ignores_context():
    # The paper's error 4: a model that ignores x̃ keeps L exactly (here 0.6/0.2 = 3 in every context).
    k = fa.Kernel([[[0.6, 0.4], [0.2, 0.8]]] * 2, ["x0", "x1"], ["a", "b"], ["y", "n"])
    m_x = fa.from_matrix([[0.9, 0.1], [0.7, 0.3]], ["x0", "x1"])
    g = fa.indicator("y", ["y", "n"])
    before = fa.local_fairness(compose(k), g).value
    after = fa.local_fairness(compose(k, context=m_x), g).value
    assert before == pytest.approx(math.log(3), rel=1e-12)
    assert after == pytest.approx(math.log(3), rel=1e-12)


@st.composite
def kernels_and_context_mechanisms(draw):
    nx = draw(st.integers(1, 3))
    na = draw(st.integers(2, 3))
    nu = draw(st.integers(2, 3))
    weight = st.floats(0.01, 1.0)
    k = np.array(draw(st.lists(weight, min_size=nx * na * nu, max_size=nx * na * nu))).reshape(nx, na, nu)
    m = np.array(draw(st.lists(weight, min_size=nx * nx, max_size=nx * nx))).reshape(nx, nx)
    g = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=nu, max_size=nu)))
    return k / k.sum(-1, keepdims=True), m / m.sum(-1, keepdims=True), g


@given(kernels_and_context_mechanisms())
def test_x_privacy_cannot_increase_local_fairness(data):
    # Paper SI C, Theorem (privacy of X): for g = g(u), E[g | x, a] = Σ_x̃ M_X[x, x̃] E_K[g | x̃, a] is a mixture,
    # and a ratio of mixtures with the same weights is at most the largest ratio.
    k, m, gv = data
    nx, na, nu = k.shape
    kernel = fa.Kernel(k, list(range(nx)), list(range(na)), list(range(nu)))
    g = fa.from_table(gv, list(range(nu)))
    before = fa.local_fairness(compose(kernel), g).value
    after = fa.local_fairness(compose(kernel, context=fa.from_matrix(m, list(range(nx)))), g).value
    if math.isnan(before) or math.isnan(after):
        return
    assert after <= before + 1e-9


# --------------------------------------------------------------------------- composition by explicit Fraction sums


def test_compose_equals_fraction_sum():
    F = Fraction
    mx = [[F(3, 4), F(1, 4)], [F(1, 5), F(4, 5)]]
    ma = [[F(1, 2), F(1, 3), F(1, 6)], [F(1, 10), F(7, 10), F(1, 5)], [F(0), F(1, 4), F(3, 4)]]
    kern = [
        [[F(1, 3), F(2, 3)], [F(1, 2), F(1, 2)], [F(1), F(0)]],
        [[F(1, 8), F(7, 8)], [F(2, 5), F(3, 5)], [F(9, 10), F(1, 10)]],
    ]
    expected = [
        [
            [sum(mx[x][xt] * ma[a][at] * kern[xt][at][u] for xt in range(2) for at in range(3)) for u in range(2)]
            for a in range(3)
        ]
        for x in range(2)
    ]
    # One entry by hand: Q[0, 0, 0] = 3/4 (1/2·1/3 + 1/3·1/2 + 1/6·1) + 1/4 (1/2·1/8 + 1/3·2/5 + 1/6·9/10)
    #                            = 3/4 · 1/2 + 1/4 · (1/16 + 2/15 + 3/20) = 3/8 + 1/4 · 83/240 = 443/960.
    assert expected[0][0][0] == F(443, 960)
    law = compose(
        fa.Kernel(np.array(kern, dtype=float), ["x~0", "x~1"], ["a0", "a1", "a2"], ["yes", "no"]),
        sensitive=fa.from_matrix(np.array(ma, dtype=float), ["A0", "A1", "A2"], ["a0", "a1", "a2"]),
        context=fa.from_matrix(np.array(mx, dtype=float), ["X0", "X1"], ["x~0", "x~1"]),
    )
    assert law.contexts == ("X0", "X1") and law.groups == ("A0", "A1", "A2") and law.decisions == ("yes", "no")
    assert law.probabilities == pytest.approx(np.array(expected, dtype=float), rel=1e-12)


def test_compose_with_product_mechanism_has_tuple_labels():
    rr = [fa.randomized_response(v, keep=0.7) for v in (["Tom", "Mary"], [25, 55])]
    m = fa.product(*rr)
    # Kernel that outputs "yes" iff the released name is Mary.
    k = fa.Kernel(
        [[[1.0, 0.0] if g[0] == "Mary" else [0.0, 1.0] for g in m.outputs]], ["doc"], m.outputs, ["yes", "no"]
    )
    law = compose(k, sensitive=m)
    assert law.groups == (("Tom", 25), ("Tom", 55), ("Mary", 25), ("Mary", 55))
    # Hand: P(yes | Tom, ·) = P(name flipped) = 0.3; P(yes | Mary, ·) = 0.7.
    assert law.probabilities[0, :, 0] == pytest.approx(np.array([0.3, 0.3, 0.7, 0.7]), rel=1e-12)


def test_compose_label_mismatch():
    k = fa.Kernel([[[0.5, 0.5], [0.1, 0.9]]], ["doc"], ["a", "b"], ["y", "n"])
    with pytest.raises(fa.InputError) as err:
        compose(k, sensitive=fa.randomized_response(["b", "a"], keep=0.7, name="M_A"))
    assert "mechanism 'M_A' outputs" in str(err.value) and "kernel's groups" in str(err.value)
    with pytest.raises(fa.InputError, match="kernel's contexts"):
        compose(k, context=fa.randomized_response(["doc", "other"], keep=0.7))
    with pytest.raises(fa.InputError, match="must be a Kernel"):
        compose(fa.Law([[[0.5, 0.5]]], ["doc"], ["a"], ["y", "n"]))


def test_compose_reaching_an_empty_cell_of_an_estimated_kernel():
    counts = [[[3, 1], [0, 0]]]
    k = fa.Kernel.from_counts(counts, ["doc"], ["a", "b"], ["y", "n"])
    assert k.empty_cells == (("doc", "b"),)
    with pytest.raises(fa.InputError, match=r"empty cell \(context='doc', group='b'\)"):
        compose(k, sensitive=fa.randomized_response(["a", "b"], keep=0.7))
    # A filter that releases every group as a never reaches the empty cell: both groups get row (x, a) = (3/4, 1/4).
    law = compose(k, sensitive=fa.from_matrix([[1.0, 0.0], [1.0, 0.0]], ["a", "b"]))
    assert law.probabilities[0, 1] == pytest.approx(np.array([0.75, 0.25]), rel=1e-12)


# --------------------------------------------------------------------------- tables and their checks


def test_kernel_row_not_summing_to_one_names_table_labels_and_sum():
    with pytest.raises(fa.InputError) as err:
        fa.Kernel([[[0.2, 0.7]]], ["doc1"], ["HR_1"], ["go", "stay"])
    assert str(err.value) == "kernel: row (context='doc1', group='HR_1') sums to 0.9, not 1"
    with pytest.raises(fa.InputError) as err:
        fa.Law([[[0.5, 0.5], [0.5, 0.6]]], ["x"], ["a", "b"], ["y", "n"], name="observed law")
    assert "observed law" in str(err.value) and "group='b'" in str(err.value) and "1.1" in str(err.value)


def test_kernel_negative_and_nan_entries():
    with pytest.raises(fa.InputError) as err:
        fa.Kernel([[[1.2, -0.2]]], ["doc"], ["a"], ["go", "stay"])
    assert "kernel" in str(err.value) and "decision='stay'" in str(err.value) and "negative" in str(err.value)
    assert "-0.2" in str(err.value)
    with pytest.raises(
        fa.InputError, match=r"kernel: entry at \(context='doc', group='a', decision='go'\) is not finite"
    ):
        fa.Kernel([[[float("nan"), 1.0]]], ["doc"], ["a"], ["go", "stay"])
    with pytest.raises(fa.InputError, match="shape"):
        fa.Kernel([[[0.5, 0.5]]], ["doc"], ["a", "b"], ["go", "stay"])
    with pytest.raises(fa.InputError, match="3-dimensional"):
        fa.Kernel([[0.5, 0.5]], ["doc"], ["a"], ["go", "stay"])


def test_law_from_counts_marks_empty_cells():
    law = fa.Law.from_counts([[[3, 1], [0, 0]], [[0, 2], [5, 5]]], ["x0", "x1"], ["a", "b"], ["yes", "no"])
    # Hand: row (x0, a) = (3/4, 1/4); (x1, a) = (0, 1); (x1, b) = (1/2, 1/2); (x0, b) empty.
    assert law.probabilities[0, 0] == pytest.approx(np.array([0.75, 0.25]), rel=1e-12)
    assert law.probabilities[1, 1] == pytest.approx(np.array([0.5, 0.5]), rel=1e-12)
    assert np.all(np.isnan(law.probabilities[0, 1]))
    assert law.empty_cells == (("x0", "b"),)
    assert law.observed.tolist() == [[True, False], [True, True]]
    assert law.cell_counts.tolist() == [[4, 0], [2, 10]]
    with pytest.raises(fa.InputError, match="counts"):
        fa.Law.from_counts([[[3, -1]]], ["x"], ["a"], ["yes", "no"])


def test_population_constructors_and_independence():
    pop = fa.Population.independent([0.25, 0.75], [0.5, 0.3, 0.2], ["x0", "x1"], ["a", "b", "c"])
    assert pop.probabilities == pytest.approx(np.outer([0.25, 0.75], [0.5, 0.3, 0.2]), rel=1e-12)
    assert pop.independence().independent and pop.independence().max_deviation < 1e-15
    # Counts [[3, 1], [1, 3]]: P = [[3/8, 1/8], [1/8, 3/8]], P(x) = P(a) = 1/2, deviation |3/8 − 1/4| = 1/8.
    dep = fa.Population.from_counts([[3, 1], [1, 3]], ["x0", "x1"], ["a", "b"])
    check = dep.independence()
    assert not check.independent
    assert check.max_deviation == pytest.approx(0.125, rel=1e-12)
    assert (check.context, check.group) == ("x0", "a")
    assert dep.context_given_group() == pytest.approx(np.array([[0.75, 0.25], [0.25, 0.75]]), rel=1e-12)
    with pytest.raises(fa.InputError, match="sum to 0.9"):
        fa.Population([[0.5, 0.4]], ["x"], ["a", "b"])
    with pytest.raises(fa.InputError, match="negative"):
        fa.Population([[1.5, -0.5]], ["x"], ["a", "b"])
    with pytest.raises(fa.InputError, match="at least one record"):
        fa.Population.from_counts([[0, 0]], ["x"], ["a", "b"])


# --------------------------------------------------------------------------- cells floating point cannot hold


def _apart() -> fa.Kernel:
    """g0 always decides d0, g1 always d1: behind k-ary randomized response E[1{d0} | g0] = p, E[1{d0} | g1] = q."""
    return fa.Kernel([[[1.0, 0.0], [0.0, 1.0]]], ["all"], ["g0", "g1"], ["d0", "d1"])


def test_compose_behind_randomized_response_near_the_float_range_keeps_l_equal_to_epsilon():
    # at 700 nats q = 1/(e^700 + 1) ~ 1e-304 is a normal float: L = ln(p/q) = epsilon exactly (p/q = e^epsilon)
    law = compose(_apart(), fa.randomized_response(["g0", "g1"], epsilon=700.0))
    value = fa.local_fairness(law, fa.indicator("d0", ["d0", "d1"])).value
    assert abs(value - 700.0) <= 1e-12 * 700


@pytest.mark.parametrize("epsilon", [745.0, 800.0, 2e6])
def test_compose_refuses_a_cell_below_the_float_range(epsilon):
    # q = 1/(e^epsilon + 1) is positive but a subnormal (745) or 0 (800, 2e6) in floats: L would read +inf (or be
    # off), where the exact value is epsilon
    rr = fa.randomized_response(["g0", "g1"], epsilon=epsilon)
    with pytest.raises(fa.InputError, match=r"mechanism '2-ary randomized response'.*smallest normal float") as caught:
        compose(_apart(), rr)
    assert isinstance(caught.value, UnderflowError)
    assert "P(U = d1 | X = all, A = g0)" in str(caught.value)


def test_compose_behind_the_identity_keeps_its_zeros():
    # epsilon = +inf is the identity: its zeros are exact, and L = +inf is the exact value
    law = compose(_apart(), fa.randomized_response(["g0", "g1"], epsilon=math.inf))
    assert fa.local_fairness(law, fa.indicator("d0", ["d0", "d1"])).value == math.inf


def test_compose_refuses_a_product_of_kernel_and_mechanism_below_the_float_range():
    # every entry is a normal float, but 1e-200 * 1e-200 is not: the cell (g1, d0) is 1e-400 exactly (the rows
    # [1e-200, 1.0] sum to 1 within rounding)
    kernel = fa.Kernel([[[1e-200, 1.0], [0.0, 1.0]]], ["all"], ["g0", "g1"], ["d0", "d1"])
    m = fa.from_matrix([[1.0, 0.0], [1e-200, 1.0]], ["g0", "g1"], name="M")
    with pytest.raises(UnderflowError, match=r"^kernel: .*P\(U = d0 \| X = all, A = g1\)"):
        compose(kernel, m)
