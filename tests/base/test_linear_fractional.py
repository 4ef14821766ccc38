"""Linear-fractional engine: the threshold rule vs Dinkelbach's method over the exact simplex vs HiGHS and vertices."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import linprog

from fairaudit.base.linear_fractional import FractionalProgram
from fairaudit.base.threshold_rule import threshold_max_many


def solve_lp(p, q, *, lower, upper, A_ub=None, b_ub=None):
    """Dinkelbach's method over the exact simplex, as the certifier runs it: the polytope built once, then solved."""
    return FractionalProgram(len(p), lower=lower, upper=upper, A_ub=A_ub, b_ub=b_ub).solve(p, q)


def threshold_value(p, q, lo, hi) -> float:
    """The threshold rule's value (rounded up by its error bound) for one box program, as the searches run it."""
    return float(threshold_max_many(np.asarray(p, dtype=float), np.asarray(q, dtype=float), lo, hi)[0])


def _instance(seed: int, n: int):
    rng = np.random.default_rng(seed)
    p, q = rng.dirichlet(np.ones(n)), rng.dirichlet(np.ones(n))
    lo = rng.uniform(0, 0.5, n) * rng.integers(0, 2)
    return p, q, lo, lo + rng.uniform(0.01, 1.0, n)


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.integers(1, 30))
def test_threshold_equals_lp(seed, n):
    p, q, lo, hi = _instance(seed, n)
    a, b = threshold_value(p, q, lo, hi), solve_lp(p, q, lower=lo, upper=hi)
    assert b.status == "optimal"
    assert b.value == pytest.approx(a, rel=1e-7)
    assert (p @ b.argmax) / (q @ b.argmax) == pytest.approx(a, rel=1e-7)


@given(st.integers(0, 2**32 - 1), st.integers(1, 8))
def test_threshold_equals_vertex_enumeration(seed, n):
    # Independent route: the optimum of a linear-fractional program over a box is at a vertex.
    p, q, lo, hi = _instance(seed, n)

    def ratio(v):  # the package's convention: 0/0 = 1 (h = 0 is a vertex when lower = 0)
        return 1.0 if q @ v == 0 and p @ v == 0 else (p @ v) / (q @ v)

    best = max(ratio(np.where(m, hi, lo)) for m in itertools.product([0, 1], repeat=n))
    assert threshold_value(p, q, lo, hi) == pytest.approx(best, rel=1e-12)


def _dinkelbach(p, q, a_ub, b_ub, lo, hi):
    """Second algorithm: Dinkelbach's parametric iterations, each a HiGHS LP (scipy)."""
    lam = 0.0
    for _ in range(100):
        res = linprog(-(p - lam * q), A_ub=a_ub, b_ub=b_ub, bounds=list(zip(lo, hi)), method="highs")
        h = res.x
        new = (p @ h) / (q @ h)
        if abs(new - lam) <= 1e-13 * max(1.0, new):
            return new
        lam = new
    return lam


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.integers(2, 12), st.integers(1, 4))
def test_lp_with_constraints_equals_dinkelbach(seed, n, m):
    # Polytope: box plus m constraints r_j . h >= tau_j (like lower bounds on E[g | x, b]).
    p, q, lo, hi = _instance(seed, n)
    rng = np.random.default_rng(seed + 1)
    rows = rng.dirichlet(np.ones(n), size=m)
    tau = 0.9 * (rows @ hi) * rng.uniform(0.2, 1.0, m) + 0.1 * (rows @ lo)
    a_ub, b_ub = -rows, -tau
    lp = solve_lp(p, q, lower=lo, upper=hi, A_ub=a_ub, b_ub=b_ub)
    assert lp.status == "optimal"
    assert lp.value == pytest.approx(_dinkelbach(p, q, a_ub, b_ub, lo, hi), rel=1e-7)
    assert np.all(a_ub @ lp.argmax <= b_ub + 1e-7)


def test_unbounded_and_infeasible_are_results_not_exceptions():
    r = solve_lp([1.0, 0.0], [0.0, 1.0], lower=0.0, upper=1.0)  # h = (1, 0) gives 1/0
    assert r.status == "unbounded" and r.value == math.inf and "q·h = 0" in r.reason
    assert threshold_value([1.0, 0.0], [0.0, 1.0], 0.0, 1.0) == math.inf
    r = solve_lp([1.0, 1.0], [1.0, 1.0], lower=0.0, upper=1.0, A_ub=[[1.0, 1.0]], b_ub=[-1.0])  # h1 + h2 <= -1
    assert r.status == "infeasible" and math.isnan(r.value) and r.reason


def test_dinkelbach_refuses_a_vertex_with_negative_denominator():
    # With h1 in [-1, 1] the ratio (0.5 h1 + 0.5 h2) / h1 is unbounded near h1 = 0+ (h = (0.01, 1) gives 50.5);
    # Dinkelbach's method needs q·h >= 0 and says so (status "error", NaN: nothing is claimed), where a vertex has
    # q·h < 0.
    r = solve_lp([0.5, 0.5], [1.0, 0.0], lower=-1.0, upper=1.0)
    assert r.status == "error" and math.isnan(r.value) and not r.certified and "q·h < 0" in r.reason


def test_the_bounds_must_be_finite():
    from fairaudit import InputError

    with pytest.raises(InputError, match="finite"):
        FractionalProgram(2, lower=0.0, upper=math.inf)
    with pytest.raises(InputError, match="finite"):
        FractionalProgram(2, lower=0.0)


def test_lp_statuses_zero_denominator_empty_polytope_and_scale():
    # q·h = 0 on the whole box and p·h > 0 somewhere: c/0 = +inf (not "infeasible")
    r = solve_lp([1.0, 0.0], [0.0, 0.0], lower=0.0, upper=1.0)
    assert r.value == math.inf and r.status == "unbounded" and "c/0" in r.reason
    # p·h = q·h = 0 everywhere: 0/0 counts as parity
    r = solve_lp([0.0, 0.0], [0.0, 0.0], lower=0.0, upper=1.0)
    assert r.value == 1.0 and r.status == "optimal"
    # an empty polytope: h_1 <= -1 and h_1 >= 1
    r = solve_lp([1.0, 1.0], [1.0, 1.0], lower=0.0, upper=1.0, A_ub=[[1.0, 0.0], [-1.0, 0.0]], b_ub=[-1.0, -1.0])
    assert math.isnan(r.value) and r.status == "infeasible"
    # a bounded polytope far from the origin: the ratio is 1 everywhere (s = 1/(q·h) ~ 3e-14 is not "unbounded")
    r = solve_lp([1.0, 1.0], [1.0, 1.0], lower=1e13, upper=2e13)
    assert r.status == "optimal" and r.value == pytest.approx(1.0, rel=1e-9)


def forced_zero_program(n: int = 70):
    """A program beyond the rational simplex's size (64 variables) whose rows h_i + (i + 1)/10 · h_{i+20} <= 0, i < 20,
    force h_0 … h_39 to 0 on the box [0, 1]^n (every term is >= 0): by hand, p·h = q·h = 0 on every feasible h when
    p and q live on those cells."""
    a = np.zeros((20, n))
    a[np.arange(20), np.arange(20)] = 1.0
    a[np.arange(20), np.arange(20) + 20] = (np.arange(20) + 1) / 10
    return FractionalProgram(n, lower=0.0, upper=1.0, A_ub=a, b_ub=np.zeros(20))


def test_zero_over_zero_beyond_the_exact_size_is_certified_by_a_checked_dual():
    # the solver calls the Charnes–Cooper LP infeasible (q·h = 0 on all of P); max p·h = 0 by hand, so 0/0: the value
    # 1 is certified from the duals of max p·h (B(1) <= 0 exactly), not from the solver's word
    prog = forced_zero_program()
    p, q = np.zeros(70), np.zeros(70)
    p[:10], q[5:40] = np.linspace(0.1, 1.0, 10), np.linspace(0.2, 0.9, 35)
    r = prog.solve(p, q)
    assert (r.value, r.status, r.certified) == (1.0, "optimal", True) and "0/0" in r.reason
    # a numerator on a free cell: q·h = 0 < p·h there, +inf (c/0), an upper bound of anything
    p[50] = 0.5
    r = prog.solve(p, q)
    assert (r.value, r.status, r.certified) == (math.inf, "unbounded", True) and "q·h = 0" in r.reason


def test_a_badly_scaled_box_program_is_solved_exactly():
    # cells of 2.3e-11 in the denominator (Clarabel called the Charnes–Cooper LP unbounded): q > 0 on the whole box
    # [0, 1]^3 but its corner 0, so the maximum is finite: max_i p_i / q_i = 0.7735231004548078 / 2.2667650723532528e-11
    p = [0.7735231004548078, 0.0579318426345534, 0.1685450569106387]
    q = [2.2667650723532528e-11, 0.9999999999546647, 2.2667650723532528e-11]
    r = solve_lp(p, q, lower=0.0, upper=1.0)
    assert r.status == "optimal" and r.certified and r.method == "lp"
    exact = Fraction(p[0]) / Fraction(q[0])
    assert Fraction(r.witness) <= exact <= Fraction(r.value) <= Fraction(threshold_value(p, q, 0.0, 1.0))
    assert r.value - r.witness <= 2 * math.ulp(r.value)  # exact: the threshold rule's error bound is wider


def _table_program(seed: int, rows: int = 7, decisions: int = 10):
    """max (p·K)/(q·K) over tables K (rows x decisions, each row a distribution) meeting three floors F·K ≥ 0.3, the
    shape of the known-utility search's programs: 70 variables, beyond the rational simplex's 64."""

    rng = np.random.default_rng(seed)
    n = rows * decisions
    floors = rng.choice([0.0, 0.1, 0.25, 0.5, 0.7, 1.0], size=(3, n)) / rows
    simplex = np.kron(np.eye(rows), np.ones(decisions))
    prog = FractionalProgram(n, lower=0.0, upper=1.0, A_ub=-floors, b_ub=np.full(3, -0.3), A_eq=simplex,
                             b_eq=np.ones(rows))  # fmt: skip
    p, q = rng.choice([0.0, 0.1, 0.5, 1.0], size=n) / rows, floors[0] + rng.uniform(0, 1e-3, n)
    return prog, p, q, floors, simplex


def test_below_a_value_held_the_method_starts_there_and_stops_at_once_when_it_is_proved():
    # a box with two floors: given below far above the maximum, max (p − below·q)·h < 0 at the first step, and below
    # comes back, certified by HiGHS's duals checked exactly, with no witness (no exact solve); given below under the
    # maximum, the method goes on from it to the exact maximum (Dinkelbach's iterations with HiGHS, a second
    # implementation)
    from fairaudit.base.linear_fractional import FractionalProgram

    p, q, lo, hi = _instance(3, 6)
    rows = np.random.default_rng(4).dirichlet(np.ones(6), size=2)
    a_ub, b_ub = -rows, -0.5 * (rows @ hi)
    exact = _dinkelbach(p, q, a_ub, b_ub, lo, hi)
    program = FractionalProgram(6, lower=lo, upper=hi, A_ub=a_ub, b_ub=b_ub)
    quick = program.solve(p, q, below=1e6)
    assert quick.certified and 1e6 <= quick.value <= 1e6 * (1 + 1e-13) and math.isnan(quick.witness)
    assert "(1 Dinkelbach steps" in quick.solver_status
    full = program.solve(p, q, below=exact / 2)
    assert full.certified and full.witness <= exact * (1 + 1e-12) <= full.value * (1 + 2e-12)
    assert full.value - full.witness <= 4 * math.ulp(full.value)


def _rational_program(seed: int, n: int, m: int, blocks: int):
    """Random small programs with rational data, a few blocks: p of either sign, q ≥ 0, floors and caps."""
    rng = np.random.default_rng(seed)

    def r(lo: int, hi: int) -> Fraction:
        return Fraction(int(rng.integers(lo, hi)), int(rng.integers(1, 8)))

    out = []
    for _ in range(blocks):
        lower = [Fraction(0) if rng.random() < 0.5 else r(0, 3) for _ in range(n)]
        upper = [lo + r(0, 6) for lo in lower]
        rows = [[r(-4, 5) for _ in range(n)] for _ in range(m)]
        rhs = [r(-3, 6) for _ in range(m)]
        p = [r(-3, 6) for _ in range(n)]
        q = [r(0, 5) for _ in range(n)]
        out.append((lower, upper, rows, rhs, p, q))
    return out


@given(st.integers(0, 2**32 - 1), st.integers(1, 4), st.integers(0, 4), st.integers(1, 3), st.booleans())
def test_polytope_ratios_equal_the_tests_rational_simplex(seed, n, m, blocks, guess):
    # The certifier's exact ratio route (HiGHS's basis proved exactly, Dinkelbach block by block) against the tests'
    # cold-start rational simplex: the same status and exact value; the multipliers prove the value by weak duality
    # (max over the box of (p − λq − yᵀA)·h + y·b = 0, y ≥ 0) and the point attains it.
    from _rational_simplex import Polytope as Second
    from _rational_simplex import maximize_ratio_over_product as second

    from fairaudit.base.exact_ratio import Polytope, maximize_ratio_over_product

    data = _rational_program(seed, n, m, blocks)
    ours = [Polytope(lo, hi, a, b, n) for lo, hi, a, b, _, _ in data]
    theirs = [Second(lo, hi, a, b, n) for lo, hi, a, b, _, _ in data]
    ps, qs = [d[4] for d in data], [d[5] for d in data]
    expected = second(theirs, ps, qs)
    start = expected.value + Fraction(1, 10**6) if guess and expected.value is not None else None
    found = maximize_ratio_over_product(ours, ps, qs, start=start)
    assert found.status == expected.status
    if found.status != "optimal":
        return
    assert found.value == expected.value
    lam, y, h = found.value, list(found.multipliers), list(found.point)
    top = [x for d in data for x in d[4]]
    bottom = [x for d in data for x in d[5]]
    assert sum(a * x for a, x in zip(top, h)) == lam * sum(b * x for b, x in zip(bottom, h))
    assert all(v >= 0 for v in y) and len(y) == m * blocks
    bound = Fraction(0)
    for i, (lo, hi, rows, rhs, p, q) in enumerate(data):
        yi = y[i * m : (i + 1) * m]
        for j in range(n):
            c = p[j] - lam * q[j] - sum(yi[k] * rows[k][j] for k in range(m))
            bound += c * (hi[j] if c > 0 else lo[j])
        bound += sum(v * b for v, b in zip(yi, rhs))
    assert bound == 0


def test_polytope_reports_an_empty_polytope_and_a_zero_denominator():
    from fairaudit.base.exact_ratio import Polytope

    F = Fraction
    assert not Polytope([0, 0], [1, 1], [[-1, -1]], [-3], 2).feasible
    assert Polytope([0, 0], [1, 1], [[-1, -1]], [-3], 2).maximize_ratio([1, 1], [1, 1]).status == "infeasible"
    box = Polytope([0, 0], [1, 1], [], [], 2)
    assert box.maximize_ratio([F(1), F(0)], [F(0), F(0)]).status == "zero_denominator"  # q·h = 0 everywhere
    unbounded = box.maximize_ratio([F(1), F(0)], [F(0), F(1)])  # h = (1, 0): q·h = 0 < p·h
    assert unbounded.status == "zero_denominator" and unbounded.point == (F(1), F(0))
    assert box.maximize_ratio([F(1), F(0)], [F(-1), F(1)]).status == "zero_denominator"  # q·h < 0 at (1, 0)


def test_polytope_where_the_denominator_vanishes_everywhere_shows_the_largest_numerator():
    # q·h = 0 on the whole polytope: the point maximises p·h, so c/0 (p·h > 0) shows wherever some h meets it
    from fairaudit.base.exact_ratio import Polytope

    F = Fraction
    box = Polytope([0, 0], [1, 1], [], [], 2)
    found = box.maximize_ratio([F(0), F(1)], [F(0), F(0)])
    assert found.status == "zero_denominator" and found.point == (F(0), F(1))
    assert box.maximize_ratio([F(0), F(-1)], [F(0), F(0)]).point[1] == 0  # (p·h ≤ 0 everywhere: 0 at best)
