"""The tests' exact rational simplex and Dinkelbach's method (``_rational_simplex``, their second route): hand cases,
degenerate ties, bad input, and random small programs against scipy's HiGHS (a test-only peer)."""

from __future__ import annotations

import subprocess
import sys
from fractions import Fraction as F

import numpy as np
import pytest
from _rational_simplex import (
    LinearOptimum,
    Polytope,
    RatioOptimum,
    maximize_linear,
    maximize_ratio,
    maximize_ratio_over_product,
)
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import linprog

from fairaudit.base.errors import InputError

P, Q = [F(7, 10), F(3, 10)], [F(3, 10), F(7, 10)]


def dot(a, b):
    return sum((F(x) * F(y) for x, y in zip(a, b, strict=True)), F(0))


def proves(multipliers, cost, lower, upper, A_ub, b_ub, value):
    """Weak duality, computed apart from the simplex: y >= 0 on the rows and y·b + max over the box of
    (cost - yᵀA)·h equal to ``value``."""
    if multipliers is None or len(multipliers) != len(A_ub) or any(y < 0 for y in multipliers):
        return False
    reduced = [
        F(c) - sum((y * F(row[j]) for y, row in zip(multipliers, A_ub, strict=True)), F(0)) for j, c in enumerate(cost)
    ]
    box = sum((d * F(hi if d > 0 else lo) for d, lo, hi in zip(reduced, lower, upper, strict=True)), F(0))
    return box + dot(multipliers, b_ub) == value


def feasible(point, lower, upper, A_ub, b_ub):
    """The point lies in the polytope, exactly."""
    return all(lo <= h <= hi for h, lo, hi in zip(point, lower, upper, strict=True)) and all(
        dot(row, point) <= b for row, b in zip(A_ub, b_ub, strict=True)
    )


# --- hand cases ---------------------------------------------------------------------------------------------------


def test_the_box_ratio_is_the_threshold_rules():
    """max (p·h)/(q·h) over [0, 1]² puts h = 1 where p/q is above the optimum: h = (1, 0), 7/3 (h = 0 is 0/0)."""
    result = maximize_ratio(P, Q, [0, 0], [1, 1], [], [])
    assert result == RatioOptimum("optimal", F(7, 3), (F(1), F(0)), ())


def test_a_floor_on_the_denominator():
    """With q·h ≥ 1/2 the threshold moves: h = (1, 2/7), ratio (7/10 + 3/35)/(3/10 + 1/5) = 11/7."""
    result = maximize_ratio(P, Q, [0, 0], [1, 1], [[-Q[0], -Q[1]]], [F(-1, 2)])
    assert result.status == "optimal" and result.value == F(11, 7)
    assert result.point == (F(1), F(2, 7))
    assert dot(P, result.point) / dot(Q, result.point) == F(11, 7)


def test_a_linear_program_by_hand():
    # max x + 2y over [0, 1]² with x + y ≤ 3/2: y = 1, x = 1/2; x between its bounds makes its reduced cost
    # 1 - y_row zero, so the row's multiplier is 1 (and 1·3/2 + max over the box of (0, 1)·h = 5/2)
    result = maximize_linear([1, 2], [0, 0], [1, 1], [[1, 1]], [F(3, 2)])
    assert result == LinearOptimum("optimal", F(5, 2), (F(1, 2), F(1)), (F(1),))


def test_the_answers_are_fractions_of_python_integers():
    # the simplex pivots in GMP's integers (gmpy2); its answers are Fractions of Python ints, which every caller may
    # hash, print or pickle. By hand, on the unit box with 2·h0 + h1 <= 3/2 (vertices (0, 0), (3/4, 0), (1/4, 1),
    # (0, 1)): max h0 + h1 = 5/4 at (1/4, 1); max (2·h0 + h1)/(h0 + h1) = 1 + h0/(h0 + h1) = 2 at (3/4, 0)
    linear = maximize_linear([F(1), F(1)], [F(0), F(0)], [F(1), F(1)], [[F(2), F(1)]], [F(3, 2)])
    ratio = maximize_ratio([F(2), F(1)], [F(1), F(1)], [F(0), F(0)], [F(1), F(1)], [[F(2), F(1)]], [F(3, 2)])
    assert (linear.value, linear.point) == (F(5, 4), (F(1, 4), F(1)))
    assert (ratio.value, ratio.point) == (F(2), (F(3, 4), F(0)))
    numbers = [linear.value, *linear.point, ratio.value, *ratio.point]
    assert {type(x.numerator) for x in numbers} == {type(x.denominator) for x in numbers} == {int}


def test_negative_lower_bounds_and_a_fixed_variable():
    # h_1 is fixed at -2; max h_0 - h_2 with h_0 + h_1 ≤ 0 over h_0 in [-3, 5], h_2 in [-1, 1]
    # (h_0 between its bounds: the row's multiplier is its cost, 1)
    result = maximize_linear([1, 7, -1], [-3, -2, -1], [5, -2, 1], [[1, 1, 0]], [0])
    assert result == LinearOptimum("optimal", F(2) - 14 + 1, (F(2), F(-2), F(-1)), (F(1),))


def test_an_infeasible_polytope():
    # x + y ≥ 3 over [0, 1]²
    assert maximize_linear([1, 1], [0, 0], [1, 1], [[-1, -1]], [-3]) == LinearOptimum("infeasible", None, None)
    assert maximize_ratio(P, Q, [0, 0], [1, 1], [[-1, -1]], [-3]) == RatioOptimum("infeasible", None, None)
    # two rows that contradict each other, each feasible alone: x ≤ 1/3 and x ≥ 1/2
    assert maximize_linear([1], [0], [1], [[1], [-1]], [F(1, 3), F(-1, 2)]).status == "infeasible"


def test_a_polytope_of_one_point():
    # x + y ≤ 0 over [0, 1]²: only h = 0; phase 1 is not needed, every step is degenerate
    result = maximize_linear([3, 5], [0, 0], [1, 1], [[1, 1]], [0])
    assert (result.status, result.value, result.point) == ("optimal", F(0), (F(0), F(0)))
    assert result.multipliers is not None and result.multipliers[0] >= 5  # (every y >= 5 proves 0; no smaller one)
    # x + y ≥ 2 over [0, 1]²: only h = (1, 1), reached by phase 1; every y >= 3 proves 2 (5 + y + max(y - 3, 0) - 2y)
    result = maximize_linear([-3, 5], [0, 0], [1, 1], [[-1, -1]], [-2])
    assert (result.status, result.value, result.point) == ("optimal", F(2), (F(1), F(1)))
    assert result.multipliers is not None and result.multipliers[0] >= 3


def test_degenerate_ties_do_not_cycle():
    """Beale's example, on which the simplex cycles with the largest-coefficient rule and naive ties; here inside a
    box that holds its optimum 5/4 at (1, 0, 1, 0)."""
    c = [F(3, 4), -20, F(1, 2), -6]
    A = [[F(1, 4), -8, -1, 9], [F(1, 2), -12, F(-1, 2), 3], [0, 0, 1, 0]]
    result = maximize_linear(c, [0] * 4, [10] * 4, A, [0, 0, 1])
    assert result.status == "optimal" and result.value == F(5, 4)
    assert feasible(result.point, [0] * 4, [10] * 4, A, [0, 0, 1]) and dot(c, result.point) == F(5, 4)


def test_redundant_rows_through_the_optimum():
    # max x + y over [0, 1]² with many rows tight at the optimal face x + y = 1 (and two copies of one)
    A = [[1, 1], [1, 1], [2, 2], [1, 0], [0, 1], [3, 1], [1, 3]]
    b = [1, 1, 2, 1, 1, 3, 3]
    result = maximize_linear([1, 1], [0, 0], [1, 1], A, b)
    assert result.value == 1 and feasible(result.point, [0, 0], [1, 1], A, b)
    ratio = maximize_ratio([1, 1], [1, 2], [0, 0], [1, 1], A, b)
    assert (ratio.status, ratio.value, ratio.point) == ("optimal", F(1), (F(1), F(0)))
    assert proves(ratio.multipliers, [0, -1], [0, 0], [1, 1], A, b, F(0))  # (p - 1·q = (0, -1))


def test_ties_in_the_ratio():
    # p = q: every point with q·h > 0 has ratio 1
    result = maximize_ratio([1, 2], [1, 2], [0, 0], [1, 1], [], [])
    assert result.status == "optimal" and result.value == 1
    assert dot([1, 2], result.point) > 0


@pytest.mark.parametrize(
    ("p", "q", "lower", "why"),
    [
        ([1, 0], [1, -1], [0, 0], "q·h < 0 at h = (0, 1)"),
        ([1, 1], [0, 0], [0, 0], "q·h = 0 everywhere"),
        ([1, 0], [0, 1], [0, 0], "q·h = 0 < p·h at h = (1, 0): the ratio is unbounded"),
    ],
)
def test_no_finite_maximum(p, q, lower, why):
    result = maximize_ratio(p, q, lower, [1, 1], [], [])
    assert result.status == "zero_denominator" and result.value is None, why
    assert result.point is not None and dot(q, result.point) <= 0


def test_a_positive_denominator_is_accepted_when_it_is_positive_everywhere():
    result = maximize_ratio([1, -1], [1, 1], [1, 1], [2, 2], [], [])
    assert result == RatioOptimum("optimal", F(1, 3), (F(2), F(1)), ())


# --- a guess at the maximum ---------------------------------------------------------------------------------------


def phase_twos(monkeypatch):
    """Count the simplex's phase-2 runs (one per objective maximised)."""
    import _rational_simplex as exact_programs

    calls = []
    original = exact_programs._Simplex.maximize

    def counted(self, cost):
        calls.append(1)
        return original(self, cost)

    monkeypatch.setattr(exact_programs._Simplex, "maximize", counted)
    return calls


@pytest.mark.parametrize("start", [F(11, 7) + F(1, 10**9), F(11, 7) - F(1, 10**9), F(11, 7)])
def test_a_guess_near_the_maximum_takes_two_steps(monkeypatch, start):
    """The floor case by hand, 11/7 at h = (1, 2/7): from a guess within 1e-9 of it, one step at the guess reaches
    the maximiser and a second proves it (gap 0), where without a guess the denominator's minimum and maximum come
    first (four phase-2 runs)."""
    rows, bounds = [[-Q[0], -Q[1]]], [F(-1, 2)]
    # the floor's multiplier by hand: at 11/7, p - 11/7·q = (8/35, -4/5), and h_1 between its bounds makes
    # -4/5 + y·7/10 zero: y = 8/7 (then 4/7 from h_0 at 1, less 8/7·1/2: 0)
    expected = RatioOptimum("optimal", F(11, 7), (F(1), F(2, 7)), (F(8, 7),))
    calls = phase_twos(monkeypatch)
    assert maximize_ratio(P, Q, [0, 0], [1, 1], rows, bounds) == expected
    assert len(calls) == 4
    calls.clear()
    result = maximize_ratio(P, Q, [0, 0], [1, 1], rows, bounds, start=start)
    assert result == expected and len(calls) == 2


def test_a_guess_whose_vertex_is_zero_over_zero_starts_as_without_one():
    """max (h1 − h2)/h1 over [0, 1]² is 1 (h2 = 0); at the guess 2 the step maximises −h1 − h2, whose vertex
    h = 0 has no ratio: the search starts from the denominator's maximiser instead, and still finds 1."""
    assert maximize_ratio([1, -1], [1, 0], [0, 0], [1, 1], [], [], start=2) == RatioOptimum(
        "optimal", F(1), (F(1), F(0)), ()
    )


@pytest.mark.parametrize(
    ("p", "q", "start", "why"),
    [
        ([1, 0], [0, 1], F(3), "q·h = 0 < p·h at h = (1, 0): unbounded"),
        ([1, 0], [1, -1], F(2), "q·h < 0 at h = (0, 1)"),
        ([1, 1], [0, 0], F(-1), "q·h = 0 everywhere: the guess's vertex has p·h > 0 = q·h"),
    ],
)
def test_a_guess_keeps_the_statuses_without_a_finite_maximum(p, q, start, why):
    result = maximize_ratio(p, q, [0, 0], [1, 1], [], [], start=start)
    assert result.status == "zero_denominator" and result.value is None, why
    assert result.point is not None and dot(q, result.point) <= 0


def test_a_float_guess_is_refused_by_name():
    with pytest.raises(InputError) as caught:
        maximize_ratio(P, Q, [0, 0], [1, 1], [], [], start=1.5)
    assert caught.value.field == "start"


# --- bad input ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (([1, 1], [0, 0], [1, -1], [], []), "upper"),
        (([1, 1], [0], [1, 1], [], []), "lower"),
        (([1, 1], [0, 0], [1, 1], [[1]], [1]), "A_ub"),
        (([1, 1], [0, 0], [1, 1], [[1, 1]], []), "b_ub"),
        (([1, 0.5], [0, 0], [1, 1], [], []), "c"),
        (([1, 1], [0, 0], [1, 1], [[1, 0.5]], [1]), "A_ub"),
        (([], [], [], [], []), "c"),
        (([1, 1], [0, 0], [1, 1], 3, [1]), "A_ub"),
        (("ab", [0, 0], [1, 1], [], []), "c"),
    ],
)
def test_bad_input_names_the_argument(args, field):
    with pytest.raises(InputError) as caught:
        maximize_linear(*args)
    assert caught.value.field == field


def test_bad_ratio_input_names_the_argument():
    with pytest.raises(InputError) as caught:
        maximize_ratio([1, 1], [1], [0, 0], [1, 1], [], [])
    assert caught.value.field == "q"
    with pytest.raises(InputError) as caught:
        maximize_ratio([1.0], [1], [0], [1], [], [])
    assert caught.value.field == "p"


@pytest.mark.parametrize(
    ("at_upper", "offending"), [([2], 2), ([-1], -1), ([0.0], 0.0), ([True], True), ([1, 1], [1, 1])]
)
def test_a_start_outside_the_variables_is_refused_by_name(at_upper, offending):
    with pytest.raises(InputError) as caught:
        Polytope([0, 0], [1, 1], [], [], 2, at_upper=at_upper)
    assert (caught.value.field, caught.value.value) == ("at_upper", offending)


def test_a_start_that_meets_every_row_takes_no_phase_1_step(monkeypatch):
    """h₀ + h₁ ≥ 3/2 over the unit box: from (0, 0) phase 1 pivots; from the vertex (1, 1) it takes no step, from
    (1, 0) (which misses the row) it does; the maximum of (h₀ − h₁)/(h₀ + h₁), 1/3 at (1, 1/2), is the same from
    each."""
    import _rational_simplex as exact_programs

    steps = []
    original = exact_programs._Simplex._exchange
    monkeypatch.setattr(
        exact_programs._Simplex, "_exchange", lambda self, r, c: steps.append(r) or original(self, r, c)
    )
    counts = []
    for start in ([], [0, 1], [0]):
        steps.clear()
        polytope = Polytope([0, 0], [1, 1], [[-1, -1]], [F(-3, 2)], 2, at_upper=start)
        counts.append(len(steps))
        assert polytope.feasible
        assert polytope.maximize_ratio([F(1), F(-1)], [F(1), F(1)]).value == F(1, 3)
    assert counts[1] == 0 and counts[0] > 0 and counts[2] > 0


def test_numpy_integers_are_exact_rationals():
    result = maximize_linear(list(np.array([1, 2])), [0, 0], [1, 1], [], [])
    assert result.value == 3


# --- random programs against HiGHS --------------------------------------------------------------------------------

small = st.builds(F, st.integers(-5, 5), st.integers(1, 4))


@st.composite
def polytopes(draw, positive=False):
    """(lower, upper, A_ub, b_ub): n ≤ 6 variables, m ≤ 6 rows, small rationals; usually but not always feasible
    (each bound is a drawn box point's value plus a slack that may be negative). ``positive``: lower ≥ 0."""
    n = draw(st.integers(1, 6))
    m = draw(st.integers(0, 6))
    lower = [F(draw(st.integers(0 if positive else -3, 2)), draw(st.integers(1, 2))) for _ in range(n)]
    upper = [lo + F(draw(st.integers(0, 3)), draw(st.integers(1, 2))) for lo in lower]
    inside = [lo + (hi - lo) * F(draw(st.integers(0, 4)), 4) for lo, hi in zip(lower, upper, strict=True)]
    A = [[draw(small) for _ in range(n)] for _ in range(m)]
    b = [dot(row, inside) + F(draw(st.integers(-2, 3)), 2) for row in A]
    return lower, upper, A, b


def highs(c, lower, upper, A, b):
    """max c·h by HiGHS's dual simplex: (status 0 optimal / 2 infeasible, value, vertex)."""
    A_ub = np.array(A, dtype=float).reshape(len(A), len(c)) if A else None
    res = linprog(
        -np.array(c, dtype=float),
        A_ub=A_ub,
        b_ub=np.array(b, dtype=float) if A else None,
        bounds=list(zip(map(float, lower), map(float, upper), strict=True)),
        method="highs-ds",
    )
    return res.status, (-res.fun if res.status == 0 else None), res.x


@pytest.mark.slow
@given(polytopes(), st.lists(small, min_size=6, max_size=6))
def test_linear_programs_agree_with_highs(polytope, costs):
    lower, upper, A, b = polytope
    c = costs[: len(lower)]
    result = maximize_linear(c, lower, upper, A, b)
    status, value, _ = highs(c, lower, upper, A, b)
    if result.status == "infeasible":
        assert status == 2
        return
    assert status == 0
    assert feasible(result.point, lower, upper, A, b) and dot(c, result.point) == result.value
    assert abs(float(result.value) - value) <= 1e-9 * max(1.0, abs(value))


def charnes_cooper(p, q, lower, upper, A, b):
    """max p·y subject to q·y = 1, A y ≤ b s, lower s ≤ y ≤ upper s, s ≥ 0 (Charnes & Cooper 1962), by HiGHS."""
    n = len(p)
    rows = [[*map(float, row), -float(bound)] for row, bound in zip(A, b, strict=True)]
    rows += [[-(i == j) * 1.0 for j in range(n)] + [float(lo)] for i, lo in enumerate(lower)]
    rows += [[(i == j) * 1.0 for j in range(n)] + [-float(hi)] for i, hi in enumerate(upper)]
    res = linprog(
        -np.array([*map(float, p), 0.0]),
        A_ub=np.array(rows),
        b_ub=np.zeros(len(rows)),
        A_eq=np.array([[*map(float, q), 0.0]]),
        b_eq=[1.0],
        bounds=[(None, None)] * n + [(0, None)],
        method="highs",
    )
    return res.status, (-res.fun if res.status == 0 else None)


@pytest.mark.slow
@given(
    polytopes(positive=True),
    st.lists(small, min_size=6, max_size=6),
    st.lists(st.builds(F, st.integers(0, 5), st.integers(1, 4)), min_size=6, max_size=6),
    st.lists(st.lists(st.integers(-3, 3), min_size=6, max_size=6), min_size=8, max_size=8),
)
def test_ratios_are_the_largest_at_every_vertex(polytope, numerator, denominator, directions):
    """The value is attained, exactly, at a feasible point; no vertex HiGHS finds (random objectives) has a larger
    ratio; and it is the Charnes–Cooper LP's value."""
    lower, upper, A, b = polytope
    n = len(lower)
    p, q = numerator[:n], denominator[:n]
    result = maximize_ratio(p, q, lower, upper, A, b)
    exact_linear = maximize_linear(q, lower, upper, A, b)
    if result.status == "infeasible":
        assert exact_linear.status == "infeasible"
        return
    if result.status == "zero_denominator":  # q ≥ 0 and h ≥ 0: q·h = 0 everywhere, or somewhere with p·h > 0
        h = result.point
        assert feasible(h, lower, upper, A, b) and dot(q, h) == 0
        assert exact_linear.value == 0 or dot(p, h) > 0
        return
    h = result.point
    assert feasible(h, lower, upper, A, b) and dot(q, h) > 0 and dot(p, h) / dot(q, h) == result.value
    value = float(result.value)
    for direction in directions:
        status, _, vertex = highs(direction[:n], lower, upper, A, b)
        assert status == 0
        qh = float(np.dot([float(x) for x in q], vertex))
        if qh > 1e-6:
            ratio = float(np.dot([float(x) for x in p], vertex)) / qh
            assert ratio <= value + 1e-7 * max(1.0, abs(value))
    status, cc = charnes_cooper(p, q, lower, upper, A, b)
    assert status == 0 and abs(cc - value) <= 1e-7 * max(1.0, abs(value))


@pytest.mark.slow
@given(
    polytopes(positive=True),
    st.lists(small, min_size=6, max_size=6),
    st.lists(st.builds(F, st.integers(0, 5), st.integers(1, 4)), min_size=6, max_size=6),
    st.builds(F, st.integers(-20, 20), st.integers(1, 8)),
)
def test_any_guess_gives_the_answer_without_one(polytope, numerator, denominator, guess):
    """With q ≥ 0 on the polytope (h ≥ 0, q ≥ 0), any guess, far or near, of either sign: the same status and the
    same exact maximum as without a guess, attained at a feasible point of that ratio."""
    lower, upper, A, b = polytope
    n = len(lower)
    p, q = numerator[:n], denominator[:n]
    plain = maximize_ratio(p, q, lower, upper, A, b)
    guessed = maximize_ratio(p, q, lower, upper, A, b, start=guess)
    assert (guessed.status, guessed.value) == (plain.status, plain.value)
    if guessed.status == "optimal":
        h = guessed.point
        assert feasible(h, lower, upper, A, b) and dot(q, h) > 0 and dot(p, h) / dot(q, h) == guessed.value


@given(
    polytopes(positive=True),
    st.lists(small, min_size=6, max_size=6),
    st.lists(st.builds(F, st.integers(0, 5), st.integers(1, 4)), min_size=6, max_size=6),
    st.sets(st.integers(0, 5)),
)
def test_any_starting_vertex_gives_the_answer_from_the_lower_one(polytope, numerator, denominator, starts):
    """Phase 1 from any vertex of the box: the same feasibility, status and exact maximum as from every variable at
    its lower bound, attained at a feasible point of that ratio."""
    lower, upper, A, b = polytope
    n = len(lower)
    p, q = numerator[:n], denominator[:n]
    plain = maximize_ratio(p, q, lower, upper, A, b)
    started = Polytope(lower, upper, A, b, n, at_upper=sorted(j for j in starts if j < n))
    assert started.feasible == (plain.status != "infeasible")
    found = started.maximize_ratio(p, q)
    assert (found.status, found.value) == (plain.status, plain.value)
    if found.status == "optimal":
        h = found.point
        assert feasible(h, lower, upper, A, b) and dot(q, h) > 0 and dot(p, h) / dot(q, h) == found.value


@given(
    polytopes(positive=True),
    st.lists(small, min_size=6, max_size=6),
    st.lists(st.builds(F, st.integers(0, 5), st.integers(1, 4)), min_size=6, max_size=6),
    st.one_of(st.none(), st.builds(F, st.integers(-20, 20), st.integers(1, 8))),
)
def test_the_multipliers_prove_the_optimum_by_weak_duality(polytope, numerator, denominator, guess):
    """The rows' multipliers, checked apart from the simplex: y >= 0 with y·b + max over the box of (c - yᵀA)·h
    the linear maximum exactly, and, for the ratio, 0 at c = p - value·q (so p·h <= value·q·h on the polytope),
    with or without a guess; as one program of two blocks, the blocks' multipliers one after the other."""
    lower, upper, A, b = polytope
    n = len(lower)
    p, q = numerator[:n], denominator[:n]
    linear = maximize_linear(p, lower, upper, A, b)
    if linear.status == "infeasible":
        assert linear.multipliers is None
    else:
        assert proves(linear.multipliers, p, lower, upper, A, b, linear.value)
    ratio = maximize_ratio(p, q, lower, upper, A, b, start=guess)
    if ratio.status != "optimal":
        assert ratio.multipliers is None
        return
    assert proves(ratio.multipliers, [x - ratio.value * y for x, y in zip(p, q)], lower, upper, A, b, F(0))
    both = maximize_ratio_over_product([Polytope(lower, upper, A, b, n) for _ in range(2)], [p, q], [q, p])
    if both.status == "optimal":
        lo, hi, rows, bounds = block_diagonal([polytope, polytope])
        cost = [x - both.value * y for x, y in zip([*p, *q], [*q, *p])]
        assert proves(both.multipliers, cost, lo, hi, rows, bounds, F(0))


def block_diagonal(blocks):
    """The product of polytopes as one polytope: the boxes side by side, each block's rows on its own columns."""
    widths = [len(lower) for lower, _, _, _ in blocks]
    lower = [x for block in blocks for x in block[0]]
    upper = [x for block in blocks for x in block[1]]
    rows, bounds, start = [], [], 0
    for (_, _, A, b), width in zip(blocks, widths, strict=True):
        rows += [[F(0)] * start + row + [F(0)] * (len(lower) - start - width) for row in A]
        bounds += b
        start += width
    return lower, upper, rows, bounds


@pytest.mark.slow
@given(
    st.lists(
        st.tuples(
            polytopes(positive=True),
            st.lists(small, min_size=6, max_size=6),
            st.lists(st.builds(F, st.integers(0, 5), st.integers(1, 4)), min_size=6, max_size=6),
        ),
        min_size=1,
        max_size=3,
    )
)
def test_a_product_is_solved_block_by_block_as_one_program(blocks):
    """maximize_ratio_over_product on blocks: the value of the Charnes–Cooper LP of the one block-diagonal program
    by HiGHS (the second route), attained exactly at a point of the product; empty and unbounded as that program."""
    polytopes_ = [Polytope(lo, hi, A, b, len(lo)) for (lo, hi, A, b), _, _ in blocks]
    p = [numerator[: len(poly[0])] for poly, numerator, _ in blocks]
    q = [denominator[: len(poly[0])] for poly, _, denominator in blocks]
    result = maximize_ratio_over_product(polytopes_, p, q)
    lower, upper, A, b = block_diagonal([poly for poly, _, _ in blocks])
    flat_p, flat_q = [x for block in p for x in block], [x for block in q for x in block]
    if result.status == "infeasible":
        assert maximize_linear(flat_q, lower, upper, A, b).status == "infeasible"
        return
    h = result.point
    assert feasible(h, lower, upper, A, b)
    if result.status == "zero_denominator":  # q ≥ 0 and h ≥ 0: q·h = 0 everywhere, or somewhere with p·h > 0
        assert dot(flat_q, h) == 0 and (maximize_linear(flat_q, lower, upper, A, b).value == 0 or dot(flat_p, h) > 0)
        return
    assert dot(flat_q, h) > 0 and dot(flat_p, h) / dot(flat_q, h) == result.value
    status, cc = charnes_cooper(flat_p, flat_q, lower, upper, A, b)
    value = float(result.value)
    assert status == 0 and abs(cc - value) <= 1e-7 * max(1.0, abs(value))


def test_a_product_refuses_blocks_that_do_not_match():
    box = Polytope([0], [1], [], [], 1)
    with pytest.raises(InputError, match="^q: must hold one block per polytope"):
        maximize_ratio_over_product([box], [[1]], [[1], [1]])
    with pytest.raises(InputError, match="^p: "):
        maximize_ratio_over_product([box], [[1, 2]], [[1]])


def test_a_larger_program_agrees_with_highs():
    """40 variables and 40 dense rows: the same optimum as HiGHS, at an exactly feasible point."""
    rng = np.random.default_rng(41)
    n = m = 40
    A = [[F(int(rng.integers(-9, 10)), int(rng.integers(1, 5))) for _ in range(n)] for _ in range(m)]
    inside = [F(int(rng.integers(0, 5)), 4) for _ in range(n)]
    b = [dot(row, inside) + F(int(rng.integers(0, 4)), 2) for row in A]
    c = [F(int(rng.integers(-9, 10)), int(rng.integers(1, 6))) for _ in range(n)]
    result = maximize_linear(c, [0] * n, [1] * n, A, b)
    status, value, _ = highs(c, [0] * n, [1] * n, A, b)
    assert result.status == "optimal" and status == 0
    assert feasible(result.point, [0] * n, [1] * n, A, b)
    assert abs(float(result.value) - value) <= 1e-9 * max(1.0, abs(value))
    q = [F(int(rng.integers(1, 10)), 10) for _ in range(n)]
    ratio = maximize_ratio(c, q, [F(1, 10)] * n, [1] * n, A, b)
    _, cc = charnes_cooper(c, q, [F(1, 10)] * n, [1] * n, A, b)
    assert ratio.status == "optimal" and abs(float(ratio.value) - cc) <= 1e-7 * max(1.0, abs(cc))


def test_the_exact_ratio_route_imports_no_scipy():
    code = "import sys, fairaudit.worstcase.lipschitz_proofs; print('scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
