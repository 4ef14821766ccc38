"""The LP's certified value: weak duality checked exactly, against vertex enumeration in Fractions; tampered duals fail;
an inaccurate solve is certified from its dual, never from its primal value."""

from __future__ import annotations

import math
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit.base.exact_duality import certify_ratio, dual_value, point_ratio, prepare_rows
from fairaudit.base.linear_fractional import FractionalProgram
from fairaudit.base.outward import fraction_up

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "proofs"))
from _exact import box, vertex_max  # noqa: E402


def _program(seed: int, n: int, m: int):
    rng = np.random.default_rng(seed)
    p, q = rng.dirichlet(np.ones(n)), rng.dirichlet(np.ones(n))
    lo = rng.uniform(0, 0.3, n) * rng.integers(0, 2)
    hi = lo + rng.uniform(0.05, 1.0, n)
    rows = rng.dirichlet(np.ones(n), size=m)
    tau = (rows @ lo) + rng.uniform(0.1, 0.9, m) * (rows @ (hi - lo))
    return p, q, lo, hi, -rows, -tau


def _exact_max(p, q, lo, hi, a_ub, b_ub) -> Fraction:
    A, b = box([Fraction(v) for v in lo], [Fraction(v) for v in hi])
    A += [[Fraction(v) for v in r] for r in a_ub]
    b += [Fraction(v) for v in b_ub]
    return vertex_max([Fraction(v) for v in p], [Fraction(v) for v in q], A, b)[0]


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 4), st.integers(1, 2))
def test_certified_value_is_above_the_exact_optimum_and_close(seed, n, m):
    p, q, lo, hi, a_ub, b_ub = _program(seed, n, m)
    r = FractionalProgram(n, lower=lo, upper=hi, A_ub=a_ub, b_ub=b_ub).solve(p, q)
    exact = _exact_max(p, q, lo, hi, a_ub, b_ub)
    assert r.certified and r.status == "optimal"
    assert Fraction(r.value) >= exact
    assert Fraction(r.value) <= exact + abs(exact) * Fraction(1, 10**12)  # verify's TOLERANCE
    if r.witness == r.witness:  # a witness, when there is one, is a lower end
        assert Fraction(r.witness) <= exact
    assert r.value == fraction_up(exact)  # the exact optimum rounded up
    if r.dual:  # the recorded dual, to nearest, proves the value again within 1e-13 (exactly, by weak duality)
        assert all(np.all(y >= 0) for y in r.dual)
        assert (
            dual_value(Fraction(r.value) * (1 + Fraction(1, 10**13)), p, q, lo, hi, [(a_ub, b_ub, "le")], list(r.dual))
            <= 0
        )


def test_a_tampered_dual_fails_the_exact_check():
    p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    lo, hi = np.zeros(2), np.ones(2)
    rows = [(np.array([[-0.7, -0.3], [-0.3, -0.7]]), np.array([-0.5, -0.5]), "le")]
    r = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=rows[0][0], b_ub=rows[0][1]).solve(p, q)
    assert r.certified and 11 / 7 <= r.value < 11 / 7 * (1 + 1e-12)
    lam = Fraction(r.value)
    assert all(np.all(y >= 0) for y in r.dual) and dual_value(lam, p, q, lo, hi, rows, list(r.dual)) <= 0
    # λ lowered below the optimum 11/7: no dual proves it
    assert dual_value(Fraction(11, 7) * (1 - Fraction(1, 10**6)), p, q, lo, hi, rows, list(r.dual)) > 0
    assert dual_value(Fraction(3, 2), p, q, lo, hi, rows, list(r.dual)) > 0
    # a negative ν is no dual at all, even where B(λ) is ≤ 0 (proofs/linear_fractional.md §6, the worked example)
    negative = [np.array([-1.0, 8 / 7])]
    assert dual_value(lam, p, q, lo, hi, rows, negative) <= 0  # (Proposition 8 needs ν ≥ 0: this proves nothing)
    # the exact optimum itself is proved by the exact dual ν = (0, 8/7)... in floats, up to one rounding
    assert certify_ratio(1.5, p, q, lo, hi, rows, [np.array([0.0, 8 / 7])]).value >= 11 / 7


def test_point_ratio_refuses_an_infeasible_point():
    p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    assert np.isnan(point_ratio(np.array([1.0, 2 / 7 - 1e-12]), p, q, np.zeros(2), np.ones(2), rows))
    assert point_ratio(np.array([1.0, 0.3]), p, q, np.zeros(2), np.ones(2), rows) == pytest.approx(0.79 / 0.51)


def test_a_degenerate_vertex_is_solved_exactly():
    # the L-bar program behind randomized response at epsilon 1e-12 with tau = 0.01 (three contexts, X and A
    # dependent): the two floor rows of the last context differ by 2.5e-13 and the solver stops at their crossing,
    # (0.01, 0.01), while the optimum is the vertex (0.02 / (1 - 5e-13), 0) along one of them. The crossing's duals have
    # mixed signs; the value certified from the solver's was 2.5e-11 relative above the exact optimum.
    p = [0.0, 0.0, 0.2500000000001253, 0.2499999999998752, 0.2500000000001253, 0.2499999999998752]
    q = [0.0, 0.0, 0.16666666666658314, 0.16666666666674984, 0.3333333333331663, 0.3333333333334997]
    a, b = [-0.50000000000025, -0.49999999999975], [-0.49999999999975, -0.50000000000025]
    a_ub = [[0, 0, *a, 0, 0], [0, 0, *b, 0, 0], [0, 0, 0, 0, *a], [0, 0, 0, 0, *b]]
    b_ub = [-0.01] * 4
    r = FractionalProgram(6, lower=0.0, upper=1.0, A_ub=a_ub, b_ub=b_ub).solve(p, q)
    exact = _exact_max(p, q, np.zeros(6), np.ones(6), a_ub, b_ub)
    assert r.certified and Fraction(r.witness) <= exact <= Fraction(r.value)
    assert r.value - r.witness <= 4 * math.ulp(r.value)
    assert r.argmax[4] > 0.02 and r.argmax[5] == 0.0  # the vertex along the first row, not the crossing
    assert exact > Fraction(101, 68)  # the crossing's ratio (h = (., ., 1, 1, 0.01, 0.01)), 1.2e-14 relative lower


def _b_by_hand(lam, p, q, lo, hi, rows, duals) -> Fraction:
    """B(λ) = ν·b + Σ_i max(r_i lo_i, r_i hi_i), r = p − λq − Aᵀν, every term a Fraction (a second route)."""
    F = Fraction
    r = [F(pi) - lam * F(qi) for pi, qi in zip(p.tolist(), q.tolist(), strict=True)]
    total = F(0)
    for (a, b, _), y in zip(rows, duals, strict=True):
        dense = a.toarray() if hasattr(a, "toarray") else a
        for i, yi in enumerate(y.tolist()):
            total += F(yi) * F(b[i])
            for j, aij in enumerate(dense[i].tolist()):
                r[j] -= F(yi) * F(aij)
    return total + sum(max(ri * F(lo_i), ri * F(hi_i)) for ri, lo_i, hi_i in zip(r, lo.tolist(), hi.tolist()))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 5), st.integers(1, 4), st.booleans())
def test_prepared_rows_give_the_dual_bound_computed_in_fractions(seed, n, m, sparse):
    # the rows read once (their nonzeros as integers, only the rows with ν ≠ 0 used) against B(λ) summed in Fractions;
    # duals with zeros (a floor that does not bind), tiny and negative entries on the equality rows, a sparse A
    import scipy.sparse as sp

    rng = np.random.default_rng(seed)
    p, q = rng.dirichlet(np.ones(n)), rng.dirichlet(np.ones(n))
    lo, hi = np.zeros(n), rng.uniform(0.5, 2.0, n)
    a_ub = rng.uniform(-1, 1, (m, n)) * (rng.random((m, n)) < 0.7)
    a_eq = rng.uniform(-1, 1, (2, n)) * 1e-20 ** rng.integers(0, 2)
    rows = [
        (sp.csr_matrix(a_ub) if sparse else a_ub, rng.uniform(-1, 1, m), "le"),
        (a_eq, rng.uniform(-1, 1, 2), "eq"),
    ]
    duals = [rng.uniform(0, 3, m) * (rng.random(m) < 0.5), rng.normal(size=2) * 1e-30 ** rng.integers(0, 2)]
    prepared = prepare_rows(rows, n)
    for lam in (Fraction(0), Fraction(rng.uniform(0, 3)), Fraction(7, 3)):
        expected = _b_by_hand(lam, p, q, lo, hi, rows, duals)
        assert dual_value(lam, p, q, lo, hi, prepared, duals) == expected
        assert dual_value(lam, p, q, lo, hi, rows, duals) == expected
    bound = certify_ratio(1.0, p, q, lo, hi, prepared, duals)
    assert repr(bound) == repr(certify_ratio(1.0, p, q, lo, hi, rows, duals))  # (NaN where not certified)
    if bound.certified:  # the value proves B ≤ 0 there, in Fractions too
        assert _b_by_hand(Fraction(bound.value), p, q, lo, hi, rows, duals) <= 0
