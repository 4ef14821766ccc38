"""The vertex a solver's point stands for, solved exactly: a lower end never above the exact maximum (rational
simplex), the exact vertex where the point only misses its rows by rounding, and nothing where the reading is
wrong; the LP route then certifies tight values from it, and solves a failed solve exactly."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import fairaudit.base.exact_vertex as ev
from fairaudit.base.exact_programs import maximize_ratio
from fairaudit.base.exact_vertex import vertex_witness
from fairaudit.base.linear_fractional import FractionalProgram
from fairaudit.base.outward import fraction_down


def _exact(p, q, lo, hi, rows) -> Fraction:
    """max (p·h)/(q·h) by the rational simplex, an equality as two inequalities."""
    a_ub, b_ub = [], []
    for a, b, kind in rows:
        for sign in (1, -1) if kind == "eq" else (1,):
            a_ub += [[Fraction(float(sign * v)) for v in r] for r in np.atleast_2d(a)]
            b_ub += [Fraction(float(sign * v)) for v in b]
    frac = [[Fraction(float(v)) for v in x] for x in (p, q, lo, hi)]
    optimum = maximize_ratio(*frac, a_ub, b_ub)
    assert optimum.status == "optimal"
    return optimum.value


def test_a_table_whose_rows_sum_to_one_only_in_floats():
    # two rows of a decision table (cells 0-1 and 2-3), each summing to 1; the floor 0.3 h0 + 0.1 h2 >= 0.2 binds.
    # The vertex: h2 = 1, h0 = (0.2 - 0.1)/0.3 = 1/3 in the floats' rationals, h1 = 1 - h0, h3 = 0.
    p, q = np.array([0.9, 0.1, 0.3, 0.0]), np.array([0.3, 0.0, 0.1, 0.0])
    rows = [
        (np.array([[-0.3, 0.0, -0.1, 0.0]]), np.array([-0.2]), "le"),
        (np.array([[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0]]), np.ones(2), "eq"),
    ]
    lo, hi = np.zeros(4), np.ones(4)
    h = np.array([1 / 3 + 1e-13, 2 / 3 + 1e-13, 1.0 - 1e-12, 1e-12])  # a solver's point: off every row by rounding
    w = vertex_witness(h, p, q, lo, hi, rows)
    h0 = (Fraction(0.2) - Fraction(0.1)) / Fraction(0.3)
    at_vertex = (Fraction(0.9) * h0 + Fraction(0.1) * (1 - h0) + Fraction(0.3)) / (Fraction(0.3) * h0 + Fraction(0.1))
    assert w == fraction_down(at_vertex)
    assert Fraction(w) <= _exact(p, q, lo, hi, rows)


def test_a_wrong_reading_of_the_active_set_is_refused():
    # the floor read as active at a point far inside it: solved as an equality it puts h0 outside the box
    p, q = np.array([1.0, 0.0]), np.array([1.0, 1.0])
    rows = [(np.array([[-1.0, -1.0]]), np.array([-3.0]), "le")]
    assert np.isnan(vertex_witness(np.array([0.5, 0.5]), p, q, np.zeros(2), np.ones(2), rows, tolerance=10.0))


def test_an_inconsistent_equality_is_refused():
    # h0 at its bound 0 by the reading, yet the equality wants h0 + 0 = 1 with h1 at 0 too
    rows = [(np.array([[1.0, 1.0]]), np.array([1.0]), "eq")]
    h = np.array([1e-12, 1e-12])
    assert np.isnan(vertex_witness(h, np.ones(2), np.ones(2), np.zeros(2), np.ones(2), rows))


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 4), st.integers(1, 3))
def test_the_vertex_witness_is_a_lower_end_and_tight_at_the_solvers_point(seed, n_u, n_rows):
    # decision tables with n_rows rows over n_u decisions, a floor on each row's expected utility: the LP's point
    # stands for an optimal vertex, whose witness is within 1e-13 of the exact maximum (rational simplex) and below it
    rng = np.random.default_rng(seed)
    n = n_u * n_rows
    p, q = rng.choice([0.0, 0.2, 0.5, 1.0, 2.0], n), rng.choice([0.1, 0.2, 0.5, 1.0], n)
    g = rng.choice([0.0, 0.2, 0.5, 1.0], n)
    floors = np.kron(np.eye(n_rows), np.ones((1, n_u))) * g
    tau = 0.5 * floors.max(axis=1)
    simplex = np.kron(np.eye(n_rows), np.ones((1, n_u)))
    rows = [(-floors, -tau, "le"), (simplex, np.ones(n_rows), "eq")]
    lo, hi = np.zeros(n), np.ones(n)
    exact = _exact(p, q, lo, hi, rows)
    prog = FractionalProgram(n, lower=0.0, upper=1.0, A_ub=-floors, b_ub=-tau, A_eq=simplex, b_eq=np.ones(n_rows))
    r = prog.solve(p, q)
    assert r.certified and Fraction(r.value) >= exact
    assert Fraction(r.value) - exact <= Fraction(1, 10**12) * max(1, exact)
    assert Fraction(r.witness) <= exact  # every witness, the vertex's included, is a lower end
    assert exact - Fraction(r.witness) <= Fraction(1, 10**12) * max(1, exact)


@pytest.mark.parametrize("tolerance", [1e-9, 1e-7, 1e-5])
def test_the_docstring_program_at_each_tolerance(tolerance):
    p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    w = vertex_witness(np.array([1.0 - 1e-12, 2 / 7 - 1e-12]), p, q, np.zeros(2), np.ones(2), rows, tolerance)
    h1 = (Fraction(0.5) - Fraction(0.3)) / Fraction(0.7)
    assert w == fraction_down((Fraction(0.7) + Fraction(0.3) * h1) / (Fraction(0.3) + Fraction(0.7) * h1))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 6), st.integers(1, 12))
def test_the_cells_solved_for_are_the_pivots_exact_elimination_takes(seed, n_rows, extra):
    # rows of continuous random coefficients over n_rows + extra cells: no near-tie, so the float elimination picks,
    # row by row, the very cells gauss_jordan pivots on in rationals
    rng = np.random.default_rng(seed)
    n = n_rows + extra
    a = rng.uniform(-1.0, 1.0, (n_rows, n)) * (rng.random((n_rows, n)) < 0.7)
    interior = np.ones(n, dtype=bool)
    unknown = ev._pivot_cells([sp.csr_matrix(a)], interior)
    equations = [({c: Fraction(v) for c, v in enumerate(row) if v}, Fraction(0), True) for row in a.tolist()]
    pivots = ev.gauss_jordan(equations)
    assert pivots is not None and set(np.flatnonzero(unknown).tolist()) == set(pivots)


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 7), st.integers(0, 8))
def test_elimination_gives_back_a_point_every_row_passes_through(seed, n, m):
    # rows with small integer and dyadic coefficients, some the sums of others, all met at a random rational point
    # x0: the elimination pivots on exactly rank(rows) cells (numpy's rank of the small integer matrix, times 8), and
    # the pivot cells, solved from x0's free cells, are x0's own values (every solution of the rows agrees on them)
    rng = np.random.default_rng(seed)
    a = rng.integers(-4, 5, (m, n)) * (rng.random((m, n)) < 0.6) / rng.choice([1, 2, 8], (m, 1))
    if m >= 3:
        a[2] = a[0] - 2 * a[1]
    x0 = [Fraction(int(k), int(d)) for k, d in zip(rng.integers(-9, 10, n), rng.integers(1, 7, n), strict=True)]
    equations = [
        ({c: Fraction(v) for c, v in enumerate(row) if v}, sum((Fraction(v) * x for v, x in zip(row, x0)), Fraction(0)),
         bool(e))
        for row, e in zip(a.tolist(), rng.random(m) < 0.5, strict=True)
    ]  # fmt: skip
    pivots = ev.gauss_jordan(equations)
    assert pivots is not None
    assert len(pivots) == (np.linalg.matrix_rank(8 * a) if m else 0)
    for c, (terms, rhs) in pivots.items():
        assert c not in terms and not set(terms) & set(pivots)
        assert rhs - sum((v * x0[cc] for cc, v in terms.items()), Fraction(0)) == x0[c]
        assert all(type(x.numerator) is int for x in (rhs, *terms.values()))  # (GMP's integers stay inside)


def test_an_equality_the_others_contradict_is_inconsistent_and_an_inequality_is_dropped():
    # x + y = 1 and 2x + 2y = 3 cannot both hold; as an active inequality the second is decided by the first and
    # dropped (its point is checked against it after)
    F = Fraction
    first = ({0: F(1), 1: F(1)}, F(1), True)
    assert ev.gauss_jordan([first, ({0: F(2), 1: F(2)}, F(3), True)]) is None
    assert ev.gauss_jordan([first, ({0: F(2), 1: F(2)}, F(3), False)]) == {0: ({1: F(1)}, F(1))}


def test_a_row_the_others_decide_takes_no_cell_and_the_rest_keep_their_values():
    # the third row is the sum of the first two (exactly, in floats): two cells are solved for, one per independent
    # row, the largest coefficient of each (cell 0, then cell 2 once row 0 is eliminated from row 1); cell 3 keeps
    # the point's value
    a = np.array([[1.0, 0.5, 0.0, 0.25], [0.5, 0.0, 1.0, 0.25], [1.5, 0.5, 1.0, 0.5]])
    unknown = ev._pivot_cells([sp.csr_matrix(a)], np.ones(4, dtype=bool))
    assert np.flatnonzero(unknown).tolist() == [0, 2]
    h = np.array([0.25 + 1e-13, 0.5, 0.25 - 1e-13, 0.5])  # on the rows 0.625, 0.5 and 1.125 within rounding
    b = np.array([0.625, 0.5, 1.125])
    p, q = np.array([1.0, 0.0, 0.0, 0.0]), np.ones(4)
    w = vertex_witness(h, p, q, np.zeros(4), np.ones(4), [(a, b, "eq")])
    # h1 = 1/2 and h3 = 1/2 kept; h0 = 0.625 − h1/2 − h3/4 = 1/4, h2 = 0.5 − h0/2 − h3/4 = 1/4: the ratio 1/4 over 3/2
    assert w == fraction_down(Fraction(1, 6))


def test_one_row_sum_over_many_free_cells_solves_one_cell():
    # a solver's point over 200 cells whose row sums to 1 only within rounding: one cell (the first of the largest
    # coefficient) is solved for, the other 199 keep their values, so the point sums to 1 exactly
    rng = np.random.default_rng(7)
    h = rng.dirichlet(np.ones(200))
    h[0] += 1e-13
    p, q = rng.random(200), rng.random(200) + 0.1
    rows = [(np.ones((1, 200)), np.ones(1), "eq")]
    unknown = ev._pivot_cells([sp.csr_matrix(rows[0][0])], np.ones(200, dtype=bool))
    assert np.flatnonzero(unknown).tolist() == [0]
    x = [Fraction(float(v)) for v in h]
    x[0] = 1 - sum(x[1:], Fraction(0))
    expected = sum((Fraction(float(a)) * b for a, b in zip(p, x)), Fraction(0)) / sum(
        (Fraction(float(a)) * b for a, b in zip(q, x)), Fraction(0)
    )
    assert vertex_witness(h, p, q, np.zeros(200), np.ones(200), rows) == fraction_down(expected)


def test_a_second_improvement_at_the_same_point_solves_no_vertex_again(monkeypatch):
    # the LP route improves its witness before and after lowering its value: the vertices are solved once
    calls = []
    real = ev.vertex_witness
    monkeypatch.setattr(ev, "vertex_witness", lambda *args: calls.append(args[-1]) or real(*args))
    p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    h = np.array([1.0 - 1e-12, 2 / 7 - 1e-12])
    solved: dict[float, float] = {}
    first = ev.improve_witness(float("nan"), 2.0, 1e-13, h, p, q, np.zeros(2), np.ones(2), rows, solved)
    second = ev.improve_witness(float("nan"), 2.0, 1e-13, h, p, q, np.zeros(2), np.ones(2), rows, solved)
    assert first == second <= 11 / 7 and sorted(calls) == [1e-9, 1e-7, 1e-5]  # value 2: never close, every tolerance


def test_a_table_of_2000_rows_is_solved_row_by_row_however_large_the_whole_block():
    # 2,000 rows summing to 1 over 6,000 cells (12 million entries as one dense block, beyond DENSE_LIMIT): each row
    # is its own connected set, so each solves for its first cell, 1 − 1/4 − (1/4 + 1e-13), and the ratio p·h / q·h
    # (p on the first cells, q on every cell: each row sums to 1) is that cell's value
    n_rows = 2000
    h = np.tile([0.5, 0.25, 0.25 + 1e-13], n_rows)
    simplex = sp.kron(sp.identity(n_rows, format="csr"), np.ones((1, 3)), format="csr")
    p, q = np.tile([1.0, 0.0, 0.0], n_rows), np.ones(3 * n_rows)
    assert n_rows * 3 * n_rows > ev.DENSE_LIMIT
    w = vertex_witness(h, p, q, np.zeros(h.size), np.ones(h.size), [(simplex, np.ones(n_rows), "eq")])
    assert w == fraction_down(1 - Fraction(0.25) - Fraction(0.25 + 1e-13))


def test_a_row_over_12000_cells_is_solved_however_many_nonzeros():
    # a dense floor over every cell of a table (a matrix on the context spreads each floor over every group): the
    # vertex costs what the active rows touch, not the program's nonzeros (36,000 here, with the bounds), so a solver's
    # point whose row sums to 1 within rounding gets its witness: the first cell solved for, the others as they are
    rng = np.random.default_rng(11)
    n = 12_000
    h = rng.dirichlet(np.ones(n))
    h[0] += 1e-13
    p, q = rng.random(n), rng.random(n) + 0.1
    rows = [(np.ones((1, n)), np.ones(1), "eq")]
    x = [Fraction(float(v)) for v in h]
    x[0] = 1 - sum(x[1:], Fraction(0))
    expected = sum((Fraction(float(a)) * b for a, b in zip(p, x)), Fraction(0)) / sum(
        (Fraction(float(a)) * b for a, b in zip(q, x)), Fraction(0)
    )
    assert vertex_witness(h, p, q, np.zeros(n), np.ones(n), rows) == fraction_down(expected)


def test_one_connected_system_beyond_the_elimination_limit_gets_no_vertex(monkeypatch):
    # 46 equalities sum_{j <= i} h_j = b_i over 46 cells (1,081 nonzeros, one connected set): beyond
    # ELIMINATION_LIMIT no vertex is solved; within a raised limit the vertex is the forward substitution's exact
    # solution, x_i = b_i - (b_{i-1}), in the floats' rationals (2,000 rows of 3 cells, each its own set, pass above)
    n = 46
    rng = np.random.default_rng(5)
    h0 = rng.uniform(0.2, 0.8, n) / n
    a = np.tril(np.ones((n, n)))
    b = a @ h0
    assert np.count_nonzero(a) > ev.ELIMINATION_LIMIT
    p, q = rng.random(n), rng.random(n) + 0.1
    h = h0 * (1 + 1e-13)
    rows = [(a, b, "eq")]
    assert np.isnan(vertex_witness(h, p, q, np.zeros(n), np.ones(n), rows))
    monkeypatch.setattr(ev, "ELIMINATION_LIMIT", 2000)
    x = [Fraction(float(b[0]))] + [Fraction(float(b[i])) - Fraction(float(b[i - 1])) for i in range(1, n)]
    expected = sum((Fraction(float(u)) * v for u, v in zip(p, x)), Fraction(0)) / sum(
        (Fraction(float(u)) * v for u, v in zip(q, x)), Fraction(0)
    )
    assert vertex_witness(h, p, q, np.zeros(n), np.ones(n), rows) == fraction_down(expected)


def test_a_box_without_rows_is_read_at_its_bounds():
    # no rows at all (a box): the cells within the tolerance of a bound are put at it, the others keep their values,
    # and the ratio there is (0.7 * 1 + 0.3 * 0.25) / (0.3 * 1 + 0.7 * 0.25), in the floats' rationals
    p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    w = vertex_witness(np.array([1.0 - 1e-12, 0.25]), p, q, np.zeros(2), np.ones(2), [])
    F = Fraction
    assert w == fraction_down((F(0.7) + F(0.3) * F(0.25)) / (F(0.3) + F(0.7) * F(0.25)))
