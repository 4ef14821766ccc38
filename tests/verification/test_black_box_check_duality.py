"""Weak duality over the model's table (``verification.table_program.TableProgram``), against second routes: every deterministic
table, B(λ, ν) recomputed cell by cell, the rational simplex (the tests' ``_rational_simplex.maximize_ratio``) and its
multipliers, and hand calculations."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from fractions import Fraction as F

from _rational_simplex import maximize_ratio
from hypothesis import assume, example, given
from hypothesis import strategies as st

from fairaudit.base.table_relaxation import relaxation_bounds
from fairaudit.verification.enclosures import INF, integers
from fairaudit.verification.table_program import TableProgram

Table = list[list[F]]


@dataclass(frozen=True)
class Drawn:
    """A program as rationals (the second routes read these), with a ν ≥ 0 per floor."""

    tops: Table
    bottoms: Table
    floors: list[Table]
    tau: F | None
    nu: list[F]

    def program(self, floors: bool = True) -> TableProgram:
        """The checker's program: the same rows as integers over one denominator (without its floors with
        ``floors`` false)."""
        kept = self.floors if floors else []
        rows, d = integers([self.tops, self.bottoms, *kept])
        return TableProgram(rows[0], rows[1], rows[2:], d, self.tau if kept else None)


@st.composite
def programs(draw):
    """1 to 3 rows of 2 or 3 decisions, up to 3 floors over them, small rationals, and a ν >= 0 per floor."""
    rows, n_u, m = draw(st.integers(1, 3)), draw(st.integers(2, 3)), draw(st.integers(0, 3))
    small = st.integers(0, 6).map(lambda v: F(v, 6))

    def table() -> Table:
        return [[draw(small) for _ in range(n_u)] for _ in range(rows)]

    tops, bottoms, floors = table(), table(), [table() for _ in range(m)]
    tau = draw(st.integers(0, 6).map(lambda v: F(v, 10))) if m else None
    nu = [draw(st.integers(0, 8).map(lambda v: F(v, 4))) for _ in range(m)]
    return Drawn(tops, bottoms, floors, tau, nu)


def _dot(rows: Table, table: Table) -> F:
    return sum((a * k for row, kr in zip(rows, table) for a, k in zip(row, kr)), F(0))


def _ratio(drawn: Drawn, table: Table) -> F | float:
    """The tool's ratio at a table: c/0 = +inf for c > 0, 0/0 = 1."""
    num, den = _dot(drawn.tops, table), _dot(drawn.bottoms, table)
    return num / den if den else (INF if num else F(1))


def _meets(drawn: Drawn, table: Table) -> bool:
    return all(_dot(f, table) >= drawn.tau for f in drawn.floors)


def _deterministic(drawn: Drawn) -> list[Table]:
    """Every table whose rows each put all their mass on one decision."""
    n_u = len(drawn.tops[0])
    one = [[F(int(i == u)) for i in range(n_u)] for u in range(n_u)]
    return [list(t) for t in itertools.product(one, repeat=len(drawn.tops))]


def _b(drawn: Drawn, nu: list[F], lam: F) -> F:
    """B(λ, ν) cell by cell (a second route): each row's largest p − λq + Σ_f ν_f F_f, less τ Σ ν."""
    total = -(drawn.tau or 0) * sum(nu, F(0))
    for r, (p, q) in enumerate(zip(drawn.tops, drawn.bottoms)):
        total += max(pi - lam * qi + sum((v * f[r][u] for v, f in zip(nu, drawn.floors)), F(0))
                     for u, (pi, qi) in enumerate(zip(p, q)))  # fmt: skip
    return total


def _simplex(tops: Table, bottoms: Table, floors: list[Table], tau: F | None):
    """The rational simplex's optimum of max (P·K)/(Q·K) over the tables meeting the floors: each row's sum = 1 as
    two inequalities (the 2·rows first rows of A_ub), then each floor −F·K ≤ −τ."""
    rows, n_u = len(tops), len(tops[0])
    n = rows * n_u
    a_ub, b_ub = [], []
    for r in range(rows):
        sums = [F(int(i // n_u == r)) for i in range(n)]
        a_ub += [sums, [-v for v in sums]]
        b_ub += [F(1), F(-1)]
    for floor in floors:
        a_ub.append([-v for row in floor for v in row])
        b_ub.append(-tau)
    flat = [v for row in tops for v in row], [v for row in bottoms for v in row]
    return maximize_ratio(*flat, [F(0)] * n, [F(1)] * n, a_ub, b_ub)


def _optimum(drawn: Drawn):
    return _simplex(drawn.tops, drawn.bottoms, drawn.floors, drawn.tau)


def _every_row_has_a_zero_q(drawn: Drawn) -> bool:
    """A table with Q·K = 0 exists: the bound is then at least 1 (0/0 = 1), whether or not it meets the floors."""
    return all(0 in row for row in drawn.bottoms)


@given(programs())
@example(Drawn([[F(0), F(0)]], [[F(0), F(1, 6)]], [], None, []))  # (only 0/0 = 1 reaches the bound)
def test_without_floors_the_bound_is_the_maximum_over_every_deterministic_table_and_attained(drawn):
    # the ratio is quasi-convex and the tables a product of simplices: its maximum is at a deterministic table;
    # ν = 0 on the floored program is the same bound (its floors only decide whether the bound is attained). Without
    # floors the bound is that maximum, so it is reported attained, also where only 0/0 = 1 reaches it (every finite
    # ratio below 1: p = (0, 0) and q = (0, 1/6) say) and where only c/0 = +inf does
    tables = _deterministic(drawn)
    best = max(_ratio(drawn, t) for t in tables)
    bound, attained = drawn.program(floors=False).dual_bound()
    assert bound == attained == best
    assert drawn.program().dual_bound()[0] == best


@given(programs())
def test_a_dual_bound_bounds_the_optimum_and_is_the_least_lambda_its_b_allows(drawn):
    bound, _ = drawn.program().dual_bound(drawn.nu)
    optimum = _optimum(drawn)
    if optimum.status == "optimal":
        assert bound >= optimum.value
    elif optimum.status == "zero_denominator":  # (q ≥ 0: a vertex with q·K = 0; p·K > 0 there is c/0 = +inf)
        point = optimum.point
        n_u = len(drawn.tops[0])
        table = [list(point[r * n_u : (r + 1) * n_u]) for r in range(len(drawn.tops))]
        assert _dot(drawn.bottoms, table) == 0
        assert bound >= _ratio(drawn, table)
    assume(bound != INF)
    assert _b(drawn, drawn.nu, bound) <= 0
    raised = _every_row_has_a_zero_q(drawn) and bound == 1  # (perhaps raised to 1 from a smaller root)
    if bound > 0 and not raised:
        assert _b(drawn, drawn.nu, bound - F(1, 10**9)) > 0


@given(programs())
def test_the_simplex_s_multipliers_prove_the_optimum_exactly(drawn):
    # y ≥ 0 on A_ub's rows: the 2·rows rows' sums, then the floors, whose y is ν*. With the rows' simplices kept B
    # is at most the simplex's Lagrangian over the box, 0 at the optimum: the least root at ν* is the optimum
    assume(drawn.floors)
    optimum = _optimum(drawn)
    assume(optimum.status == "optimal")
    nu = list(optimum.multipliers[2 * len(drawn.tops) :])
    assert len(nu) == len(drawn.floors) and min(nu) >= 0
    bound, _ = drawn.program().dual_bound(nu)
    assert bound == (max(optimum.value, F(1)) if _every_row_has_a_zero_q(drawn) else optimum.value)
    assert _b(drawn, nu, optimum.value) <= 0


@given(programs(), st.integers(1, 12).map(lambda v: F(v, 8)), st.integers(-8, 24).map(lambda v: F(v, 4)))
def test_the_one_floor_bound_holds_at_any_theta_and_is_the_relaxation_at_the_screen_s(drawn, kept, theta):
    # the program whose only floor is Q·K >= t, by the rational simplex: θ + max(R(θ), 0)/t is at least its optimum
    # at every θ, negative ones included; at the θ relaxation_bounds returns it is the screen's bound, within 1e-12
    # of the optimum (the screen's contract)
    program = drawn.program()
    optimum = _simplex(drawn.tops, drawn.bottoms, [drawn.bottoms], kept)
    assume(optimum.status == "optimal")
    assert program.theta_bound(theta, kept) >= optimum.value
    screen, at = relaxation_bounds({0: drawn.tops, 1: drawn.bottoms}, {0: None, 1: kept})[(0, 1)]
    assert at is not None and program.theta_bound(at, kept) == screen
    assert optimum.value <= screen <= optimum.value * (1 + F(1, 10**12))


@given(programs())
def test_an_attained_bound_is_a_feasible_deterministic_table_s_ratio(drawn):
    # attained is read off the table of the rows' maximisers (deterministic): some deterministic table meeting
    # every floor has that ratio, exactly, and it is the bound; at the drawn ν and at the simplex's multipliers alike
    program = drawn.program()
    optimum = _optimum(drawn)
    candidates = [drawn.nu]
    if optimum.status == "optimal" and drawn.floors:
        candidates.append(list(optimum.multipliers[2 * len(drawn.tops) :]))
    for nu in candidates:
        bound, attained = program.dual_bound(nu)
        if attained is None:
            continue
        assert attained == bound
        feasible = [t for t in _deterministic(drawn) if _meets(drawn, t)]
        assert attained in [_ratio(drawn, t) for t in feasible]
        if optimum.status == "optimal":
            assert attained >= optimum.value  # (a feasible table's ratio that a bound attains is the value)


# proofs/verification.md §4f's program: P(yes | released a, b), p = (3/4, 1/4) and q = (1/8, 3/8) on "yes", 0 on "no"
P = [[F(3, 4), F(0)], [F(1, 4), F(0)]]
Q = [[F(1, 8), F(0)], [F(3, 8), F(0)]]
CLASS = Drawn(P, Q, [P, Q], F(1, 4), [F(0), F(8, 3)])


def test_the_class_s_program_by_hand():
    # without floors 6 at K = (1, 0) (3/4 over 1/8); that table misses q·K >= 1/4, so on the floored program ν = 0
    # proves 6 and attains nothing. ν = 8/3 on the floor of q: at λ = 10/3 the rows' largest p − λq + νq are
    # 3/4 − (2/3)(1/8) = 2/3 and max(1/4 − (2/3)(3/8), 0) = 0, less τν = 2/3: B = 0, so 10/3, which K = (1, 1/3)
    # attains (q·K = 1/4, p·K = 3/4 + 1/12). θ = 2/3 proves it too: R = 2/3, over t = 1/4 is 8/3, plus 2/3
    program = CLASS.program()
    assert CLASS.program(floors=False).dual_bound() == (F(6), F(6))
    assert program.dual_bound() == (F(6), None)
    assert program.dual_bound(CLASS.nu)[0] == F(10, 3)
    assert program.point_ratio([[F(1), F(0)], [F(1, 3), F(2, 3)]]) == F(10, 3)
    assert program.theta_bound(F(2, 3), F(1, 4)) == F(10, 3)
    assert program.theta_bound(F(0), F(1, 4)) == 4  # (R(0) = 1, the largest numerator, over 1/4)


def test_a_negative_multiplier_proves_nothing():
    # one row, p = (1, 0), q = (1, 1), the floor P(first) >= 1/2: the value is 1 at K = (1, 0). At ν = -1, B would be
    # max(-λ, -λ) + 1/2, whose root 1/2 is below the value: a negative entry is no proof, +inf
    drawn = Drawn([[F(1), F(0)]], [[F(1), F(1)]], [[[F(1), F(0)]]], F(1, 2), [F(-1)])
    assert drawn.program().dual_bound([F(-1)]) == (INF, None)
    assert drawn.program().dual_bound([F(0)]) == (F(1), F(1))


def test_a_value_beyond_the_floats_is_bounded_and_attained_exactly():
    # q = (10^-400, 1), τ half its first cell: the maximum, at P(first) = 1, is 10^400, beyond the largest float
    tiny = F(1, 10**400)
    drawn = Drawn([[F(1), F(0)]], [[tiny, F(1)]], [[[tiny, F(1)]]], tiny / 2, [F(0)])
    assert drawn.program().dual_bound([F(0)]) == (F(10**400), F(10**400))
    assert drawn.program().theta_bound(F(0), tiny / 2) == 2 * F(10**400)


def test_point_ratio_refuses_a_table_that_is_not_one_and_one_that_misses_a_floor():
    program = CLASS.program()
    assert program.point_ratio([[F(1), F(0)], [F(1), F(0)]]) == 2  # (1 over 1/2, both floors met)
    assert program.point_ratio([[F(1), F(0)], [F(1, 3), F(1, 3)]]) is None  # (a row summing to 2/3)
    assert program.point_ratio([[F(1), F(0)], [F(4, 3), F(-1, 3)]]) is None  # (a negative entry)
    assert program.point_ratio([[F(1), F(0)], [F(0), F(1)]]) is None  # (q·K = 1/8 < 1/4)
    zero = Drawn([[F(0), F(1)]], [[F(0), F(1)]], [], None, [])
    assert zero.program().point_ratio([[F(1), F(0)]]) == 1  # (0/0 = 1)
    # c/0 is no finite ratio: None (the lower end is a table's Fraction; +inf is dual_bound's to prove: without floors
    # it is the supremum, attained by the convention c/0 = +inf)
    top = Drawn([[F(1), F(1)]], [[F(0), F(1)]], [], None, [])
    assert top.program().point_ratio([[F(1), F(0)]]) is None
    assert top.program().dual_bound() == (INF, INF)
