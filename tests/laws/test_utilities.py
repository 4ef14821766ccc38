"""Utilities g(u, x, a): indicator, tables, functions; γ, lower, L_A, diam(A).

Expected values: hand calculations and brute-force loops over (u, x, a, a').
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fairaudit as fa
from fairaudit.laws.utilities import discrete_metric


def brute_lipschitz(values: np.ndarray, metric: np.ndarray) -> float:
    """max over u, x, a ≠ a' of |g[x, a, u] − g[x, a', u]| / d(a, a') by plain loops."""
    nx, na, nu = values.shape
    best = 0.0
    for x, u in itertools.product(range(nx), range(nu)):
        for a, b in itertools.permutations(range(na), 2):
            best = max(best, abs(values[x, a, u] - values[x, b, u]) / metric[a, b])
    return best


def test_indicator():
    g = fa.indicator("HR_2", ["HR_1", "HR_2", "HR_3"])
    assert g.values.tolist() == [0.0, 1.0, 0.0]
    assert (g.gamma, g.lower, g.lipschitz(), g.depends_on_group) == (1.0, 0.0, 0.0, False)
    assert g.table(["x0", "x1"], ["a", "b"], ["HR_1", "HR_2", "HR_3"]).shape == (2, 2, 3)


def test_indicator_value_not_in_decisions():
    with pytest.raises(fa.InputError) as err:
        fa.indicator("HR_9", ["HR_1", "HR_2"])
    text = str(err.value)
    assert text.startswith("utility.decision:") and "'HR_9'" in text and "HR_1" in text and "HR_2" in text


def test_from_function_uses_paper_argument_order():
    # g(u, x, a) = 100 u + 10 x + a: the table [x, a, u] must hold exactly these numbers.
    g = fa.from_function(lambda u, x, a: 100 * u + 10 * x + a, [1, 2, 3], [0, 4], [5, 6])
    for xi, x in enumerate([0, 4]):
        for ai, a in enumerate([5, 6]):
            for ui, u in enumerate([1, 2, 3]):
                assert g.values[xi, ai, ui] == 100 * u + 10 * x + a
    # Hand: γ = 300 + 40 + 6 = 346, lower = 100 + 0 + 5 = 105, L_A = |a − a'| = 1 under the discrete metric.
    assert (g.gamma, g.lower, g.lipschitz(), g.diameter()) == (346.0, 105.0, 1.0, 1.0)
    assert g.depends_on_group and g.depends_on_context


def test_lipschitz_with_metric_by_brute_force():
    rng = np.random.default_rng(3)
    for _ in range(30):
        nx, na, nu = rng.integers(1, 4), rng.integers(2, 5), rng.integers(1, 4)
        values = rng.uniform(0, 2, size=(nx, na, nu))
        pts = rng.uniform(0, 5, size=na)
        metric = np.abs(pts[:, None] - pts[None, :])
        g = fa.from_table(values, list(range(nu)), list(range(nx)), list(range(na)))
        assert g.lipschitz(metric) == pytest.approx(brute_lipschitz(values, metric), rel=1e-12)
        assert g.lipschitz() == pytest.approx(brute_lipschitz(values, discrete_metric(na)), rel=1e-12)
        assert g.diameter(metric) == pytest.approx(pts.max() - pts.min(), rel=1e-12)
        assert g.diameter() == 1.0


def test_lipschitz_hand_example():
    # One context, groups a, b, c on a line at 0, 1, 3; decisions y, n.
    # g(y) = (0.2, 0.5, 0.9), g(n) = 1 for all: differences 0.3/1, 0.7/3, 0.4/2 -> L_A = 0.3; discrete: 0.7.
    values = [[[0.2, 1.0], [0.5, 1.0], [0.9, 1.0]]]
    g = fa.from_table(values, ["y", "n"], ["x"], ["a", "b", "c"])
    metric = [[0, 1, 3], [1, 0, 2], [3, 2, 0]]
    assert g.lipschitz(metric) == pytest.approx(0.3, rel=1e-12)
    assert g.lipschitz() == pytest.approx(0.7, rel=1e-12)
    assert g.diameter(metric) == 3.0
    with pytest.raises(fa.InputError, match="metric"):
        g.lipschitz([[0, 1, 3], [1, 0, 2], [3, 1, 0]])  # not symmetric


@given(st.lists(st.floats(0.0, 10.0), min_size=1, max_size=6))
def test_vector_utility_range(vals):
    g = fa.from_table(vals, list(range(len(vals))))
    assert g.gamma == max(vals) and g.lower == min(vals)
    assert g.lipschitz() == 0.0 and not g.depends_on_group


def test_utility_errors():
    with pytest.raises(fa.InputError, match=r"non-negative; g at u='b' is \(got -1.0\)"):
        fa.from_table([1.0, -1.0], ["a", "b"])
    with pytest.raises(fa.InputError, match="finite"):
        fa.from_table([1.0, float("nan")], ["a", "b"])
    with pytest.raises(fa.InputError, match="shape"):
        fa.from_table([1.0, 2.0, 3.0], ["a", "b"])
    with pytest.raises(fa.InputError, match="needs contexts and groups"):
        fa.from_table([[[1.0, 2.0]]], ["a", "b"])
    with pytest.raises(fa.InputError, match="must return a number"):
        fa.from_function(lambda u, x, a: "high", ["a"], ["x"], ["g"])
    g = fa.from_table([[[1.0, 2.0]]], ["y", "n"], ["x"], ["a"])
    with pytest.raises(fa.InputError, match="utility decisions"):
        g.table(["x"], ["a"], ["n", "y"])
    with pytest.raises(fa.InputError, match="utility groups"):
        g.table(["x"], ["b"], ["y", "n"])
    with pytest.raises(fa.InputError, match="utility contexts"):
        g.table(["z"], ["a"], ["y", "n"])


# -- the class of utilities ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "field, value, problem",
    [
        ("lower", -0.1, "must be a finite non-negative number"),
        ("gamma", float("inf"), "must be a finite non-negative number"),
        ("tau", float("nan"), "must be a finite non-negative number"),
        ("lipschitz", -1, "must be a finite non-negative number"),
        ("diameter", "one", "must be a finite non-negative number"),
        ("metric", [[0.0, 1.0, 2.0]], "must be a square array"),
    ],
)
def test_utility_class_names_the_bad_field(field, value, problem):
    with pytest.raises(fa.InputError) as err:
        fa.UtilityClass(**{field: value})
    assert err.value.field == field and err.value.problem.startswith(problem)


def test_utility_class_diameter_is_not_below_the_metric():
    d = [[0.0, 2.0], [2.0, 0.0]]
    assert fa.UtilityClass(metric=d, diameter=3.0).diameter == 3.0  # a looser diameter is still a bound
    with pytest.raises(fa.InputError, match=r"^diameter: is below the metric's largest distance 2"):
        fa.UtilityClass(metric=d, diameter=1.0)


def test_utility_class_is_a_value():
    d = [[0.0, 0.5], [0.5, 0.0]]
    a = fa.UtilityClass(gamma=1, tau=0.2, metric=d)
    assert a == fa.UtilityClass(tau=0.2, gamma=1.0, metric=np.array(d)) and a != fa.UtilityClass(gamma=1, tau=0.2)
    assert a != fa.UtilityClass(gamma=1, tau=0.2, metric=[[0.0, 0.6], [0.6, 0.0]])
    assert isinstance(a.gamma, float) and not a.metric.flags.writeable  # (stored as floats, the metric read-only)
    with pytest.raises(TypeError):
        hash(a)


def test_utility_class_fields_left_out_are_the_function_defaults():
    rr = fa.randomized_response(["a", "b"], keep=0.7)
    # black_box_bound: lower 0, gamma 1, no tau, L_A 0: the corollary's eps = log(7/3)
    assert fa.black_box_bound(rr).value == fa.black_box_bound(rr, utility_class=fa.UtilityClass()).value
    assert fa.black_box_bound(rr).ratio == pytest.approx(7 / 3, rel=1e-15)
    # paper_bound takes gamma from the utility when the class leaves it out: t = 1 gives log(1 + 0.4/0.5) = log 1.8
    g = fa.indicator("a", ["a", "b"])
    by_utility = fa.paper_bound(rr, utility_class=fa.UtilityClass(tau=0.5), utility=g)
    assert by_utility.gamma == 1.0 and by_utility.value == pytest.approx(math.log(1.8), rel=1e-15)
    # and a metric's largest distance is the paper form's diameter: log(1 + (0.5 * 2 + 0.4) / 0.5) = log 3.8
    d = [[0.0, 2.0], [2.0, 0.0]]
    with_metric = fa.paper_bound(rr, utility_class=fa.UtilityClass(gamma=1.0, tau=0.5, lipschitz=0.5, metric=d))
    assert with_metric.diameter == 2.0 and with_metric.value == pytest.approx(math.log(3.8), rel=1e-15)
    with pytest.raises(fa.InputError, match=r"^utility_class: must be a UtilityClass \(got 'dict'\)$"):
        fa.paper_bound(rr, utility_class={"gamma": 1.0})


def test_a_metric_must_meet_the_triangle_inequality():
    # d(g2, g3) = 3 > d(g2, g0) + d(g0, g3) = 2: a utility 0.05-Lipschitz for this table is so for its shortest paths
    # (diameter 2), and the calibration's closed form at diameter 3 was 0.046 nats above the exact worst case
    from fairaudit.laws.utilities import check_metric

    d = [[0.0, 1.0, 1.0, 1.0], [1.0, 0.0, 1.0, 1.0], [1.0, 1.0, 0.0, 3.0], [1.0, 1.0, 3.0, 0.0]]
    with pytest.raises(fa.InputError, match=r"^metric: must meet the triangle inequality: d\(2, 3\) = 3 > d\(2, 0\)"):
        check_metric(d, 4)
    d[2][3] = d[3][2] = 2.0  # a tie is a metric
    assert check_metric(d, 4)[2, 3] == 2.0
    # 0.1 + 0.2 rounds above 0.3, and exactly too: a metric
    assert check_metric([[0, 0.1, 0.3], [0.1, 0, 0.2], [0.3, 0.2, 0]], 3)[0, 2] == 0.3
    # distances of points on a line computed in floats miss the inequality by an ulp: accepted (1e-13 slack)
    p = [0.326, 3.276, 4.568]
    line = [[abs(x - y) for y in p] for x in p]
    assert line[0][2] > line[0][1] + line[1][2]
    assert check_metric(line, 3)[0, 2] == line[0][2]
    # beyond the slack, refused: 1e-12 relative over
    over = 2.0 * (1 + 1e-12)
    with pytest.raises(fa.InputError, match=r"^metric: must meet the triangle inequality: d\(0, 2\)"):
        check_metric([[0, 1, over], [1, 0, 1], [over, 1, 0]], 3)
