"""HiGHS's basis proved optimal in exact arithmetic, or finished by exact pivots: hand cases, every starting basis
against the rational simplex of the tests' ``_rational_simplex`` (a second algorithm), badly scaled programs where the solver's basis
is not optimal exactly, and weak duality recomputed here from the returned duals."""

from __future__ import annotations

import math
from fractions import Fraction as F

import numpy as np
import pytest
from _rational_simplex import maximize_linear
from hypothesis import given
from hypothesis import strategies as st

from fairaudit.base.errors import InputError
from fairaudit.base.exact_lp import ExactProgram

INF = math.inf


def weak_duality_bound(c, A, row_lower, row_upper, col_lower, col_upper, y):
    """min c·x ≥ Σ y_i·(row bound) + Σ d_j·(column bound), d = c − Aᵀy, each bound on the side of its multiplier's
    sign (−inf where that side is infinite); computed apart from the module."""
    n = len(c)
    d = [F(c[j]) - sum((F(y[i]) * F(A[i][j]) for i in range(len(A))), F(0)) for j in range(n)]
    total = F(0)
    for mult, lo, hi in [*zip(y, row_lower, row_upper, strict=True), *zip(d, col_lower, col_upper, strict=True)]:
        if mult == 0:
            continue
        side = lo if mult > 0 else hi
        if side in (INF, -INF):
            return -INF
        total += mult * F(side)
    return total


def feasible(x, A, row_lower, row_upper, col_lower, col_upper):
    rows = [sum((F(a) * v for a, v in zip(row, x, strict=True)), F(0)) for row in A]
    return all(lo <= v <= hi for v, lo, hi in zip(rows, row_lower, row_upper, strict=True)) and all(
        lo <= v <= hi for v, lo, hi in zip(x, col_lower, col_upper, strict=True)
    )


def test_the_vertex_and_duals_of_a_small_program_by_hand():
    # max x + y over the unit box with x + 2y <= 3/2: x = 1 (reduced cost 1 - 1/2 > 0), y = 1/4 basic, dual 1/2
    prog = ExactProgram([[1, 2]], [-INF], [1.5], [0, 0], [1, 1])
    r = prog.minimize([-1, -1])
    assert (r.status, r.value, r.point, r.duals) == ("optimal", F(-5, 4), (F(1), F(1, 4)), (F(-1, 2),))
    assert r.basis == ("upper", "basic", "upper") and r.start == "solver" and r.pivots == 0


def test_an_equality_row_and_free_variables():
    # min x - y with x + y = 1, x - y >= -3 (x, y free): x = -1, y = 2, value -3; duals from x - y's row alone
    prog = ExactProgram([[1, 1], [1, -1]], [1, -3], [1, INF], [-INF, -INF], [INF, INF])
    r = prog.minimize([1, -1])
    assert (r.status, r.value, r.point, r.duals) == ("optimal", F(-3), (F(-1), F(2)), (F(0), F(1)))


def test_a_float_array_is_read_at_its_exact_binary_values():
    # 0.1 and 0.2 as floats are not 1/10 and 1/5: max x + y over 0.1 x + 0.2 y <= 0.3, box [0, 1]^2, is at the
    # vertex (1, 1) only because 0.1 + 0.2 <= 0.3 fails in binary (0.30000000000000004 > 0.3): the vertex is
    # (1, (0.3 - 0.1) / 0.2) in exact binary arithmetic, the same from a list of floats and from an array
    from fractions import Fraction as F

    rows = [[0.1, 0.2]]
    for matrix in (rows, np.array(rows)):
        r = ExactProgram(matrix, [-INF], [0.3], [0, 0], [1, 1]).minimize([-1, -1])
        y = (F(0.3) - F(0.1)) / F(0.2)
        assert r.status == "optimal" and r.point == (F(1), y) and y < 1


def test_unbounded_and_infeasible_are_proved():
    unbounded = ExactProgram([[1, -1]], [-INF], [1], [0, 0], [INF, INF])  # x - y <= 1, min -x - y
    assert unbounded.minimize([-1, -1]).status == "unbounded"
    empty = ExactProgram([[1, 1]], [3], [INF], [0, 0], [1, 1])  # x + y >= 3 in the unit box
    r = empty.minimize([1, 0])
    assert (r.status, r.value, r.point, r.duals) == ("infeasible", None, None, None)


def test_bad_input_is_refused_by_name():
    with pytest.raises(InputError, match="col_upper"):
        ExactProgram([[1, 1]], [0], [1], [0, 0], [1])
    with pytest.raises(InputError, match="matrix"):
        ExactProgram([[1, math.nan]], [0], [1], [0, 0], [1, 1])
    with pytest.raises(InputError, match=r"matrix.*\(0, 1\)"):  # (a float array is read in bulk, checked alike)
        ExactProgram(np.array([[1.0, math.inf]]), [0], [1], [0, 0], [1, 1])
    with pytest.raises(InputError, match="col_lower"):
        ExactProgram([[1, 1]], [0], [1], [0, 2], [1, 1])
    prog = ExactProgram([[1, 1]], [0], [1], [0, 0], [1, 1])
    with pytest.raises(InputError, match="cost"):
        prog.minimize([1, INF])
    with pytest.raises(InputError, match="basis"):
        prog.minimize([1, 1], basis=["basic", "basic", "lower"])


@st.composite
def boxed_programs(draw):
    """max c·h over 0-ish boxes and rows A h <= b with small rational data, and a starting basis for the exact
    phase (None: HiGHS's)."""
    n, m = draw(st.integers(1, 5)), draw(st.integers(0, 5))
    small = st.fractions(min_value=-4, max_value=4, max_denominator=3)
    A = [[draw(small) for _ in range(n)] for _ in range(m)]
    b = [draw(st.fractions(min_value=-2, max_value=6, max_denominator=3)) for _ in range(m)]
    lower = [F(draw(st.integers(-2, 0))) for _ in range(n)]
    upper = [lo + draw(st.integers(0, 3)) for lo in lower]
    c = [draw(small) for _ in range(n)]
    basic = draw(st.none() | st.sets(st.integers(0, n + m - 1), min_size=m, max_size=m))
    basis = None
    if basic is not None:
        basis = ["basic" if v in basic else draw(st.sampled_from(["lower", "upper"])) for v in range(n + m)]
    return c, A, b, lower, upper, basis


@given(boxed_programs())
def test_from_any_basis_the_optimum_of_the_rational_simplex_with_its_proof(case):
    c, A, b, lower, upper, basis = case
    m = len(A)
    prog = ExactProgram(A, [-INF] * m, b, lower, upper)
    r = prog.minimize([-v for v in c], basis=basis)
    ref = maximize_linear(c, lower, upper, A, b)
    if ref.status == "infeasible":
        assert r.status == "infeasible"
        return
    assert r.status == "optimal" and -r.value == ref.value
    assert feasible(r.point, A, [-INF] * m, b, lower, upper)
    assert weak_duality_bound([-v for v in c], A, [-INF] * m, b, lower, upper, r.duals) == r.value


def test_a_singular_basis_starts_from_the_slack_basis():
    prog = ExactProgram([[1, 1], [2, 2]], [-INF, -INF], [1, 2], [0, 0], [1, 1])
    r = prog.minimize([-1, -1], basis=["basic", "basic", "lower", "lower"])  # x, y basic: K = [[1, 1], [2, 2]]
    assert (r.start, r.status, r.value) == ("slack", "optimal", F(-1))


def test_badly_scaled_programs_the_solver_leaves_unproved_are_finished_exactly():
    """Entries from e^-28 to e^10: HiGHS's optimal basis is off in exact arithmetic on some (13 of 120 with HiGHS 1.16;
    how many depends on the solver's version, so it is not asserted); exact pivots from it reach the rational simplex's
    optimum on every one."""
    rng = np.random.default_rng(0)
    for _ in range(120):
        n, m = int(rng.integers(3, 12)), int(rng.integers(2, 8))
        A = rng.normal(size=(m, n)) * np.exp(rng.uniform(-28, 10, size=(m, n)))
        A[rng.random((m, n)) < 0.3] = 0
        b = rng.normal(size=m) * np.exp(rng.uniform(-28, 5, size=m))
        c = rng.normal(size=n) * np.exp(rng.uniform(-28, 10, size=n))
        r = ExactProgram(A, [-INF] * m, b, [0.0] * n, [1.0] * n).minimize(c)
        exact = [[F(v) for v in row] for row in A]
        ref = maximize_linear([F(-v) for v in c], [0] * n, [1] * n, exact, [F(v) for v in b])
        assert (r.status == "infeasible") == (ref.status == "infeasible")
        if r.status == "optimal":
            assert -r.value == ref.value
            assert weak_duality_bound(c, A, [-INF] * m, b, [0] * n, [1] * n, r.duals) == r.value


def test_a_given_basis_puts_each_nonbasic_variable_at_a_bound_it_has_by_hand():
    # max x + y (min −x − y) over x free, 0 ≤ y ≤ 1, x + y ≤ 3/2 and x ≤ 1 (rows): a basis given with the free x at a
    # "lower" bound it lacks is read with x at 0 ("zero"), and y given "zero" though bounded is read at its lower
    # bound; from x basic, y at 0 and the second row at its bound 1, the optimum is the vertex (1, 1/2), value −3/2
    prog = ExactProgram([[1, 1], [1, 0]], [-INF, -INF], [1.5, 1], [-INF, 0], [INF, 1])
    assert prog._given(["lower", "zero", "basic", "basic"]) == ["zero", "lower", "basic", "basic"]
    r = prog.minimize([-1, -1], ["basic", "zero", "basic", "upper"])
    assert (r.status, r.value, r.point) == ("optimal", F(-3, 2), (F(1), F(1, 2)))


def test_no_basis_inverse_is_formed_from_the_vertex_to_the_pivots(monkeypatch):
    # the vertex, the duals and the pivots' directions and rates are exact solves with the basis matrix K; its inverse
    # (a k x k rational inverse: 847 ms where a solve takes 7 ms at k = 80, dense dyadic entries) is never formed
    import flint

    class NoInverse(flint.fmpq_mat):  # the basis matrices built here; their inverse refused
        def inv(self):  # type: ignore[no-untyped-def]
            pytest.fail("a basis inverse was formed")

    monkeypatch.setattr(flint, "fmpq_mat", NoInverse)
    r = ExactProgram([[1, 2]], [-math.inf], [1.5], [0, 0], [1, 1]).minimize([-1, -1])
    # max x + y with x + 2y <= 3/2 in the unit box: x = 1, y = 1/4, the row's dual -1/2 (by hand)
    assert (r.pivots, r.value, r.point, r.duals) == (0, F(-5, 4), (F(1), F(1, 4)), (F(-1, 2),))
    # from a basis that is not optimal (x basic in the row, y at 0): exact pivots to the same optimum
    r = ExactProgram([[1, 2]], [-math.inf], [1.5], [0, 0], [1, 1]).minimize([-1, -1], basis=["basic", "lower", "lower"])
    assert r.pivots > 0 and (r.value, r.point) == (F(-5, 4), (F(1), F(1, 4)))
