"""The worked numeric examples of proofs/*.md, checked against exact values.

Every expected value is recomputed here in exact arithmetic (``fractions.Fraction``), either by the proof's own
hand derivation or by exact vertex enumeration (a linear-fractional maximum over a bounded polytope with a positive
denominator is attained at a vertex: proofs/linear_fractional.md, Proposition 3). No fairaudit code is used for the
expected values. Tolerances: closed-form routes 1e-12 relative, LP routes 1e-7 relative.

Sections: proofs/linear_fractional.md (§5 worked example, Proposition 7 and ``floor_max_many`` edge cases, the
statuses of ``FractionalProgram.solve``), proofs/tight_bound.md (the t* rule of Proposition 3, the 3-group ordering of §4),
proofs/black_box.md (§5 Examples 1–3 and Consequence 3, §6 example), proofs/worst_case_utility.md (§2 examples).
"""

from __future__ import annotations

import itertools
import math
import sys
from fractions import Fraction as F
from pathlib import Path

import numpy as np
import pytest

import fairaudit as fa
from fairaudit import UtilityClass
from fairaudit.base.linear_fractional import FractionalProgram
from fairaudit.base.threshold_rule import box_point, floor_max_many, threshold_max_many
from fairaudit.metrics.fairness import global_fairness, local_fairness
from fairaudit.metrics.privacy_profile import _profile_candidates
from fairaudit.worstcase.black_box import black_box_bound
from fairaudit.worstcase.known_law import worst_utility
from fairaudit.worstcase.known_utility import worst_model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "proofs"))
from _exact import box, vertices  # noqa: E402  (exact Fractions, independent of fairaudit)
from _exact import dot as _dot  # noqa: E402

CLOSED = 1e-12  # closed-form routes (threshold, floor relaxation, audits)
LP = 1e-7  # LP routes


# ---------------------------------------------------------------------------------------------- exact helpers
def vertex_max(p, q, A, b):
    """(max over the vertices of (p·h)/(q·h), the maximising vertices); needs q·h > 0 at every vertex."""
    vals = [(_dot(p, h) / _dot(q, h), h) for h in vertices(A, b)]
    best = max(v for v, _ in vals)
    return best, [h for v, h in vals if v == best]


def floor_rows(rows, tau):
    """Rows (A, b) of r·h >= tau for each r in rows."""
    return [[-F(v) for v in r] for r in rows], [-F(tau)] * len(rows)


def fl(v):
    return np.array([float(x) for x in v])


def solve_lp(p, q, *, lower, upper, A_ub=None, b_ub=None):
    """Dinkelbach's method over the exact simplex, as the certifier runs it: the polytope built once, then solved."""
    return FractionalProgram(len(p), lower=lower, upper=upper, A_ub=A_ub, b_ub=b_ub).solve(p, q)


def rr(keep):
    """Binary randomized response keeping with probability ``keep``, exact rows."""
    return [[keep, 1 - keep], [1 - keep, keep]]


# ================================================================== proofs/linear_fractional.md
LF_P = [F(1, 10), F(4, 10), F(2, 10), F(3, 10)]
LF_Q = [F(3, 10), F(1, 10), F(4, 10), F(2, 10)]
LF_LO = [F(2, 10), F(0), F(1, 10), F(5, 10)]
LF_HI = [F(1), F(5, 10), F(9, 10), F(1)]


def test_lfp_worked_example_threshold_39_25():
    # §5: order of decreasing ratio 2, 4, 3, 1; prefix values 19/20, 39/25, 54/35, 70/67, 6/7; max 39/25 at
    # h* = (0.2, 0.5, 0.1, 0.5) (only cell 2 up, although cell 4 has ratio 3/2 > 1); Dinkelbach: p − λ*q > 0 on cell 2
    # only.
    order = sorted(range(4), key=lambda i: -LF_P[i] / LF_Q[i])
    assert order == [1, 3, 2, 0]
    prefixes = [[LF_HI[i] if i in order[:k] else LF_LO[i] for i in range(4)] for k in range(5)]
    values = [_dot(LF_P, h) / _dot(LF_Q, h) for h in prefixes]
    assert values == [F(19, 20), F(39, 25), F(54, 35), F(70, 67), F(6, 7)]
    lam = max(values)
    assert lam == F(39, 25) and [LF_P[i] - lam * LF_Q[i] > 0 for i in range(4)] == [False, True, False, False]
    assert vertex_max(LF_P, LF_Q, *box(LF_LO, LF_HI))[0] == lam  # Proposition 3 on all 16 vertices
    value, k, order = threshold_max_many(fl(LF_P), fl(LF_Q), fl(LF_LO), fl(LF_HI))
    assert float(value) == pytest.approx(float(lam), rel=CLOSED)
    assert box_point(fl(LF_LO), fl(LF_HI), order, int(k)) == pytest.approx(fl(prefixes[1]), rel=CLOSED)
    r = solve_lp(fl(LF_P), fl(LF_Q), lower=fl(LF_LO), upper=fl(LF_HI))
    assert r.status == "optimal" and r.value == pytest.approx(float(lam), rel=LP)
    assert r.argmax == pytest.approx(fl(prefixes[1]), rel=LP, abs=LP)  # unique maximiser: no ratio equals λ*


def test_floor_max_many_worked_example_113_80():
    # §5, Proposition 7(c): floor 0.4 > D* = 0.25: raise cell 2 (q-mass 0.05), cell 4 (0.1), then cell 3 by
    # θ = 0.05/0.32 = 5/32 (to 0.225); value (0.19 + 0.2 + 0.15 + 0.16·5/32)/0.4 = 113/80. The LP with −q·h <= −0.4
    # agrees.
    f = F(2, 5)
    d_star = _dot(LF_Q, [F(2, 10), F(5, 10), F(1, 10), F(5, 10)])
    assert d_star == F(1, 4) < f
    theta = (f - _dot(LF_Q, LF_LO) - F(5, 100) - F(1, 10)) / F(32, 100)
    assert theta == F(5, 32)
    h = [F(2, 10), F(5, 10), F(1, 10) + F(8, 10) * theta, F(1)]
    expected = _dot(LF_P, h) / f
    assert _dot(LF_Q, h) == f and expected == F(113, 80)
    A, b = box(LF_LO, LF_HI)
    A2, b2 = floor_rows([LF_Q], f)
    assert vertex_max(LF_P, LF_Q, A + A2, b + b2) == (expected, [h])  # independent: the unique maximising vertex

    p, q, lo, hi = fl(LF_P), fl(LF_Q), fl(LF_LO), fl(LF_HI)
    v, k, frac, order = floor_max_many(p, q, lo, hi, 0.4)
    assert float(v) == pytest.approx(float(expected), rel=CLOSED) and int(k) == 2
    assert float(frac) == pytest.approx(5 / 32, rel=CLOSED) and order.tolist() == [1, 3, 2, 0]
    assert box_point(lo, hi, order, int(k), float(frac)) == pytest.approx(fl(h), rel=CLOSED)
    r = solve_lp(p, q, lower=lo, upper=hi, A_ub=[-q], b_ub=[-0.4])
    assert r.status == "optimal" and r.value == pytest.approx(float(expected), rel=LP)
    assert r.argmax == pytest.approx(fl(h), rel=LP, abs=LP)


def _exact_floor(p, q, lo, hi, f):
    """max (p·h)/(q·h) over lo <= h <= hi, q·h >= f > 0 by exact vertex enumeration (None if infeasible)."""
    A, b = box(lo, hi)
    A2, b2 = floor_rows([q], f)
    if not vertices(A + A2, b + b2):
        return None
    return vertex_max(p, q, A + A2, b + b2)[0]


@pytest.mark.parametrize(
    "case, p, q, lo, hi, f, expected",
    [
        # Proposition 7(b): the floor does not bind (f <= D* = 1/4): the threshold value 39/25, no fraction
        ("floor below D*", LF_P, LF_Q, LF_LO, LF_HI, F(1, 5), F(39, 25)),
        ("floor equal to D*", LF_P, LF_Q, LF_LO, LF_HI, F(1, 4), F(39, 25)),
        # Proposition 7(a)/(c): f = q·hi is the last feasible floor: only h = hi, value p·hi/q·hi = 0.78/0.91 = 6/7
        ("floor equal to q·hi", LF_P, LF_Q, LF_LO, LF_HI, F(91, 100), F(6, 7)),
        # D* = 0 (the threshold point is c/0 = +inf): Step 1's case D* = 0; h = (1, 1/2), value 1/(1/2) = 2
        ("D* = 0", [F(1), F(0)], [F(0), F(1)], [F(0)] * 2, [F(1)] * 2, F(1, 2), F(2)),
        # an infinite ratio first and a 0/0 cell last: h = (1, 1/2, 0, 0), (1/2 + 1/4)/(3/10) = 5/2
        (
            "c/0 and 0/0 cells",
            [F(1, 2), F(1, 2), F(0), F(0)],
            [F(0), F(3, 5), F(2, 5), F(0)],
            [F(0)] * 4,
            [F(1)] * 4,
            F(3, 10),
            F(5, 2),
        ),
        # the top-ratio cell (8/5) has zero span and the threshold keeps the other (ratio 2/5) low, D* = q·lo = 1/2;
        # the floor binds inside cell 1's span: θ = (3/4 − 1/2)/(1/2) = 1/2, h = (1/2, 1), (1/10 + 4/5)/(3/4) = 6/5
        ("zero-span top cell", [F(1, 5), F(4, 5)], [F(1, 2), F(1, 2)], [F(0), F(1)], [F(1), F(1)], F(3, 4), F(6, 5)),
    ],
)
def test_floor_max_many_edge_cases(case, p, q, lo, hi, f, expected):
    # Proposition 7 on edge cases, each value checked by exact vertex enumeration here and against the LP.
    assert _exact_floor(p, q, lo, hi, f) == expected
    v, k, frac, order = floor_max_many(fl(p), fl(q), fl(lo), fl(hi), float(f))
    assert float(v) == pytest.approx(float(expected), rel=CLOSED)
    h = box_point(fl(lo), fl(hi), order, int(k), float(frac))
    assert fl(q) @ h >= float(f) * (1 - 1e-12)
    assert (fl(p) @ h) / (fl(q) @ h) == pytest.approx(float(expected), rel=CLOSED)
    if case.startswith("floor below") or case.startswith("floor equal to D"):
        assert float(frac) == 0.0 and int(k) == 1  # (b): h* itself, only cell 2 up
    if case == "zero-span top cell":
        assert (order.tolist(), int(k), float(frac)) == ([1, 0], 1, pytest.approx(0.5, rel=CLOSED))
    r = solve_lp(fl(p), fl(q), lower=fl(lo), upper=fl(hi), A_ub=[-fl(q)], b_ub=[-float(f)])
    assert r.status == "optimal" and r.value == pytest.approx(float(expected), rel=LP)


def test_floor_max_many_infeasible_floor_and_batch():
    # Proposition 7(a): q·hi = 0.91 < f = 0.92 is infeasible: NaN. Batched over the ordered pairs of binary RR 0.7
    # with floor 1/2 (the class certificate's relaxation): (a, b) and (b, a) give 11/7 at h = (1, 2/7); (a, a) gives 1.
    assert _exact_floor(LF_P, LF_Q, LF_LO, LF_HI, F(92, 100)) is None
    v = floor_max_many(fl(LF_P), fl(LF_Q), fl(LF_LO), fl(LF_HI), 0.92)[0]
    assert math.isnan(float(v))
    M = rr(F(7, 10))
    exact = _exact_floor(M[0], M[1], [F(0)] * 2, [F(1)] * 2, F(1, 2))
    assert exact == F(11, 7) and (M[0][0] + M[0][1] * F(2, 7)) / F(1, 2) == exact
    Mf = np.array([fl(r) for r in M])
    v, k, frac, order = floor_max_many(Mf[:, None, :], Mf[None, :, :], 0.0, 1.0, 0.5)
    assert v == pytest.approx(np.array([[1.0, 11 / 7], [11 / 7, 1.0]]), rel=CLOSED)
    assert box_point(0.0, 1.0, order[0, 1], int(k[0, 1]), float(frac[0, 1])) == pytest.approx([1.0, 2 / 7], rel=CLOSED)


def test_lp_statuses():
    # Proposition 2 and the package's conventions, as FractionalProgram.solve reports them, telling an empty polytope
    # from q·h = 0 on the whole polytope (the table "How the LP route reports them" in proofs/linear_fractional.md).
    r = solve_lp([1.0, 0.0], [0.0, 1.0], lower=0.0, upper=1.0)  # (b): h0 = (1, 0), q·h0 = 0 < p·h0
    assert r.status == "unbounded" and r.value == math.inf
    r = solve_lp([1.0, 1.0], [1.0, 1.0], lower=0.0, upper=1.0, A_ub=[[1.0, 1.0]], b_ub=[-1.0])  # empty, finite bounds
    assert r.status == "infeasible" and math.isnan(r.value) and "inconsistent" in r.reason
    r, t = solve_lp([1.0], [0.0], lower=0.0, upper=1.0), threshold_max_many(np.ones(1), np.zeros(1), 0.0, 1.0)[0]
    assert (r.status, r.value, t) == ("unbounded", math.inf, math.inf) and "c/0" in r.reason  # (a), c/0 = +inf
    r, t = solve_lp([0.0], [0.0], lower=0.0, upper=1.0), threshold_max_many(np.zeros(1), np.zeros(1), 0.0, 1.0)[0]
    assert (r.status, r.value, t) == ("optimal", 1.0, 1.0)  # (a), 0/0 = 1
    # a bounded polytope far from the origin: F = 1 everywhere, s = 1/(q·h) ~ 3e-14 is not "unbounded"
    r = solve_lp([1.0, 1.0], [1.0, 1.0], lower=1e13, upper=2e13)
    assert r.status == "optimal" and r.value == pytest.approx(1.0, rel=LP)
    big = black_box_bound(
        fa.randomized_response(["a", "b"], keep=0.7), utility_class=UtilityClass(gamma=1e13, tau=5e12), method="lp"
    )
    assert big.ratio == pytest.approx(float(F(11, 7)), rel=LP)


# ================================================================== proofs/tight_bound.md
def _delta(p, q, t):
    return sum((max(F(0), a - t * b) for a, b in zip(p, q)), F(0))


def _ratios(p, q):
    """Finite positive ratios p/q of the outputs with p, q > 0."""
    return sorted({a / b for a, b in zip(p, q) if a > 0 and b > 0})


def _pair_t_star(p, q, gamma, tau, c0):
    """Proposition 3, item 3: t* = the smallest t in {1} ∪ {finite ratios > 1} with Q_>(t) <= τ/γ, and h(t*)."""
    inf_mass = any(a > 0 and b == 0 for a, b in zip(p, q))
    cands = [F(1)] + [r for r in _ratios(p, q) if r > 1]
    q_gt = lambda t: sum((b for a, b in zip(p, q) if b > 0 and a / b > t), F(0))  # noqa: E731 (q = 0 adds 0)
    t_star = min(t for t in cands if q_gt(t) <= tau / gamma)
    h = lambda t: t + (c0 + gamma * _delta(p, q, t)) / tau  # noqa: E731
    # t* is a minimiser among the candidates and the smallest one (h strictly larger before it)
    assert all(h(t) >= h(t_star) for t in cands) and all(h(t) > h(t_star) for t in cands if t < t_star)
    assert not inf_mass or _delta(p, q, t_star) > 0
    return t_star, h(t_star)


def _tight_exact(M, gamma, tau, lip=F(0)):
    """max over ordered pairs of h_aa'(t*) (discrete metric), with the binding pair and t*."""
    best = None
    for a, b in itertools.permutations(range(len(M)), 2):
        t, v = _pair_t_star(M[a], M[b], gamma, tau, lip)
        if best is None or v > best[0]:
            best = (v, (a, b), t)
    return best


THREE = [
    [F(45, 100), F(40, 100), F(15, 100)],
    [F(65, 100), F(20, 100), F(15, 100)],
    [F(65, 100), F(30, 100), F(5, 100)],
]


@pytest.mark.parametrize(
    "tau, expected, t_star",
    [
        (F(1, 2), F(9, 5), F(1)),  # Q_>(1) = 0.3 <= τ: t* = 1, h(1) = 1 + 0.4/0.5 = 9/5
        (F(3, 10), F(7, 3), F(1)),  # the boundary τ = 0.3γ: t* = 1, h(1) = 1 + 0.4/0.3 = 7/3 = h(7/3)
        (F(1, 5), F(7, 3), F(7, 3)),
    ],  # Q_>(1) = 0.3 > τ: t* = 7/3, δ(7/3) = 0, h = 7/3
)
def test_tight_t_star_rule_binary_rr(tau, expected, t_star):
    # tight_bound.md, Proposition 3 item 3 on binary RR keeping 0.7 (γ = 1): t* = 1 iff τ >= 0.3γ.
    M = rr(F(7, 10))
    assert _pair_t_star(M[0], M[1], F(1), tau, F(0)) == (t_star, expected)
    b = fa.tight_bound(
        fa.randomized_response(["a", "b"], keep=0.7), utility_class=fa.UtilityClass(gamma=1.0, tau=float(tau))
    )
    assert math.exp(b.value) == pytest.approx(float(expected), rel=CLOSED)
    if tau != F(3, 10):  # at τ = 0.3 both t = 1 and t = 7/3 minimise
        assert math.exp(b.epsilon) == pytest.approx(float(t_star), rel=CLOSED)
        assert b.delta == pytest.approx(float(_delta(M[0], M[1], t_star)), abs=1e-12)


def test_tight_t_star_rule_three_groups_lipschitz_and_zero_entries():
    # The rule against tight_bound: the 3-group mechanism (e^T = 13/6, pair (a0, a2) at t* = 4/3: Q_>(1) = 0.35 > 0.1,
    # Q_>(4/3) = 0.05 <= 0.1, δ(4/3) = 0.15 − 0.05·4/3 = 1/12, 4/3 + 10/12 = 13/6); binary RR with L_A = 0.1 at
    # τ = 1/2 (1 + (0.1 + 0.4)/0.5 = 2); and a mechanism with zero entries (ratios c/0 and 0/0).
    v, pair, t = _tight_exact(THREE, F(1), F(1, 10))
    assert (v, pair, t) == (F(13, 6), (0, 2), F(4, 3)) and _delta(THREE[0], THREE[2], t) == F(1, 12)
    m = fa.from_matrix([[float(x) for x in r] for r in THREE], ["a0", "a1", "a2"], ["o0", "o1", "o2"])
    b = fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.1))
    assert math.exp(b.value) == pytest.approx(13 / 6, rel=CLOSED)
    assert (b.group, b.other_group) == ("a0", "a2") and math.exp(b.epsilon) == pytest.approx(4 / 3, rel=CLOSED)
    assert b.delta == pytest.approx(1 / 12, rel=CLOSED)

    M = rr(F(7, 10))
    assert _tight_exact(M, F(1), F(1, 2), F(1, 10))[0] == F(2)
    b = fa.tight_bound(
        fa.randomized_response(["a", "b"], keep=0.7), utility_class=fa.UtilityClass(gamma=1.0, tau=0.5, lipschitz=0.1)
    )
    assert math.exp(b.value) == pytest.approx(2.0, rel=CLOSED)

    Z = [[F(1, 2), F(1, 2), F(0)], [F(0), F(1, 2), F(1, 2)], [F(1, 4), F(3, 4), F(0)]]
    for gamma, tau in ((F(1), F(1, 5)), (F(2), F(1, 2)), (F(1), F(9, 10))):
        v = _tight_exact(Z, gamma, tau)[0]
        mz = fa.from_matrix([[float(x) for x in r] for r in Z], ["z0", "z1", "z2"], ["o0", "o1", "o2"])
        b = fa.tight_bound(mz, utility_class=fa.UtilityClass(gamma=float(gamma), tau=float(tau)))
        assert math.exp(b.value) == pytest.approx(float(v), rel=CLOSED)


def _envelope_candidates(M):
    """t = 1, every pair's ratio >= 1 and every crossing >= 1 of two pairs' affine pieces of δ_aa'(t) (exact).

    The envelope δ(t) = max over pairs of δ_aa'(t) is piecewise linear; its breakpoints are among these points, so a
    function of t and δ(t) that is concave on each piece is minimised over [1, ∞) at one of them.
    """
    pairs = [(M[a], M[b]) for a, b in itertools.permutations(range(len(M)), 2)]
    knots = sorted({F(1)} | {r for p, q in pairs for r in _ratios(p, q) if r >= 1})
    cands = set(knots)
    for lo_, hi_ in zip(knots, knots[1:]):
        lines = []
        for p, q in pairs:  # δ_aa' is affine on [lo_, hi_]: no ratio inside
            slope = (_delta(p, q, hi_) - _delta(p, q, lo_)) / (hi_ - lo_)
            lines.append((slope, _delta(p, q, lo_) - slope * lo_))
        for (s1, c1), (s2, c2) in itertools.combinations(lines, 2):
            if s1 != s2 and lo_ < (c2 - c1) / (s1 - s2) < hi_:
                cands.add((c2 - c1) / (s1 - s2))
    return sorted(cands)


def test_three_group_ordering_tight_mechanism_wide_ratios_paper():
    # tight_bound.md §4 (γ = 1, τ = 0.1, L_A = 0): e^T = 13/6 (per pair) < e^{T_M} = 7/3 (mechanism-wide δ, at the
    # crossing t = 5/3, not a ratio) < 5/2 (T_M evaluated only at t ∈ {1} ∪ ratios) < 25/9 (paper form).
    kappa = F(10)  # γ/τ
    pairs = [(THREE[a], THREE[b]) for a, b in itertools.permutations(range(3), 2)]
    env = lambda t: max(_delta(p, q, t) for p, q in pairs)  # noqa: E731
    ratios = sorted({F(1)} | {r for p, q in pairs for r in _ratios(p, q) if r >= 1})
    assert ratios == [1, F(4, 3), F(13, 9), F(3, 2), F(2), F(3)]
    cands = _envelope_candidates(THREE)
    whole = {t: t + kappa * env(t) for t in cands}
    t_m = min(whole.values())
    assert t_m == F(7, 3) and [t for t in cands if whole[t] == t_m] == [F(5, 3)] and F(5, 3) not in ratios
    # the proof's pieces: δ(t) = 0.4 − 0.2t on [1, 5/3], 0.15 − 0.05t on [5/3, 3]
    assert all(env(t) == F(2, 5) - t / 5 for t in (F(1), F(4, 3), F(3, 2), F(5, 3)))
    assert all(env(t) == F(3, 20) - t / 20 for t in (F(5, 3), F(2), F(3)))
    at_ratios = min(t + kappa * env(t) for t in ratios)
    paper = min(t * (1 + kappa * env(t)) for t in cands)  # concave on each piece of δ: minimum at a candidate
    tight = _tight_exact(THREE, F(1), F(1, 10))[0]
    assert (tight, t_m, at_ratios, paper) == (F(13, 6), F(7, 3), F(5, 2), F(25, 9))
    assert tight < t_m < at_ratios < paper

    m = fa.from_matrix([[float(x) for x in r] for r in THREE], ["a0", "a1", "a2"], ["o0", "o1", "o2"])
    assert math.exp(fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.1)).value) == pytest.approx(
        float(tight), rel=CLOSED
    )
    t, d = _profile_candidates(m)  # the package's envelope breakpoints and δ there
    assert (t + d / 0.1).min() == pytest.approx(float(t_m), rel=CLOSED)
    eps = math.log(5 / 3)
    assert m.delta(eps) == pytest.approx(float(env(F(5, 3))), rel=CLOSED)
    at_crossing = fa.main_theorem_tight(eps, m.delta(eps), gamma=1.0, tau=0.1)
    assert math.exp(at_crossing) == pytest.approx(float(t_m), rel=CLOSED)
    r = np.array([float(x) for x in ratios])
    assert (r + np.array([m.delta(math.log(x)) for x in r]) / 0.1).min() == pytest.approx(float(at_ratios), rel=CLOSED)
    assert math.exp(fa.paper_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.1)).value) == pytest.approx(
        float(paper), rel=CLOSED
    )


# ================================================================== proofs/black_box.md, §5
def _class_rows(M, tau):
    """H_0 = {h in [0, 1]^m : M h >= τ} (γ = 1, ℓ = 0, L_A = 0) as rows."""
    A, b = box([0] * len(M[0]), [1] * len(M[0]))
    A2, b2 = floor_rows(M, tau)
    return A + A2, b + b2


def test_black_box_example_1_binary_rr_tau_half_is_11_7():
    # black_box.md §5 Example 1: H_0 has vertices (1, 1), (1, 2/7), (1/2, 1/2), (2/7, 1) with ratios 1, 11/7, 1, 7/11;
    # black-box 11/7 at h = (1, 2/7) < tight 9/5 < box certificate 7/3.
    M = rr(F(7, 10))
    A, b = _class_rows(M, F(1, 2))
    V = vertices(A, b)
    assert sorted(V) == sorted([[F(1), F(1)], [F(1), F(2, 7)], [F(1, 2), F(1, 2)], [F(2, 7), F(1)]])
    assert {tuple(h): _dot(M[0], h) / _dot(M[1], h) for h in V}[(F(1), F(2, 7))] == F(11, 7)
    value = max(vertex_max(M[a], M[1 - a], A, b)[0] for a in range(2))
    assert value == F(11, 7)
    m = fa.randomized_response(["a", "b"], keep=0.7)
    c = black_box_bound(m, utility_class=UtilityClass(tau=0.5))
    assert c.method == "threshold" and c.ratio == pytest.approx(float(value), rel=CLOSED)
    assert c.utility_by_release == pytest.approx([1.0, 2 / 7], rel=CLOSED)
    c_lp = black_box_bound(m, utility_class=UtilityClass(tau=0.5), method="lp")
    assert c_lp.method == "lp" and c_lp.ratio == pytest.approx(float(value), rel=LP)
    assert math.exp(fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.5)).value) == pytest.approx(
        9 / 5, rel=CLOSED
    )
    assert black_box_bound(m).ratio == pytest.approx(7 / 3, rel=CLOSED)
    assert float(value) < 9 / 5 < 7 / 3


def test_black_box_example_2_lipschitz_is_58_35():
    # black_box.md §5 Example 2: L_A = 0.1 (discrete metric), τ = 1/2, h = (h[a,0], h[a,1], h[b,0], h[b,1]) in [0,1]^4
    # with |h[a,o] − h[b,o]| <= 0.1 and both floors: max 58/35 at h[a] = (1, 3/7), h[b] = (9/10, 23/70) (the only
    # maximising vertex, so the LP's point must be it); below tight = 2.
    M = rr(F(7, 10))
    A, b = box([0] * 4, [1] * 4)
    for o in range(2):
        e = [F(0)] * 4
        e[o], e[2 + o] = F(1), F(-1)
        A += [e, [-v for v in e]]
        b += [F(1, 10)] * 2
    A += [[-M[0][0], -M[0][1], 0, 0], [0, 0, -M[1][0], -M[1][1]]]
    b += [-F(1, 2)] * 2
    ab = vertex_max(M[0] + [0, 0], [0, 0] + M[1], A, b)
    ba = vertex_max([0, 0] + M[1], M[0] + [0, 0], A, b)
    h = [F(1), F(3, 7), F(9, 10), F(23, 70)]
    assert ab == (F(58, 35), [h]) and ba == (F(58, 35), [[F(23, 70), F(9, 10), F(3, 7), F(1)]])  # mirror image
    assert _dot(M[0], h[:2]) == F(29, 35) and _dot(M[1], h[2:]) == F(1, 2)  # the hand check of the proof
    m = fa.randomized_response(["a", "b"], keep=0.7)
    c = black_box_bound(m, utility_class=UtilityClass(tau=0.5, lipschitz=0.1))
    assert c.status == "optimal" and c.ratio == pytest.approx(58 / 35, rel=LP)
    table = np.array([fl(h[:2]), fl(h[2:])])  # rows h[a], h[b] for the pair (a, b)
    assert (c.group, c.other_group) in (("a", "b"), ("b", "a"))  # the two pairs tie
    expected = table if c.group == "a" else table[::-1, ::-1]
    assert c.utility_by_release == pytest.approx(expected, rel=LP, abs=LP)
    assert math.exp(
        fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.5, lipschitz=0.1)).value
    ) == pytest.approx(2.0, rel=CLOSED)


@pytest.mark.slow
@pytest.mark.parametrize(
    "tau, expected, point, tight",
    [
        (F(1, 2), F(9, 5), [F(1), F(1), F(20, 21), F(0)], F(9, 5)),  # Proposition 7 holds: black-box = tight
        (F(3, 5), F(227, 147), [F(1), F(1), F(1), F(9, 49)], F(5, 3)),
    ],  # 0.09 + 0.21 + 0.21 = 0.51 < 3/5: strictly below
)
def test_black_box_example_3_product_of_two_rr(tau, expected, point, tight):
    # black_box.md §5 Example 3: the product of two binary RRs keeping 0.7 (4 groups), L_A = 0, box certificate
    # 49/9 = (7/3)^2; the class value over H_0 = {[0,1]^4, M h >= τ} for every ordered pair by exact vertices.
    R = rr(F(7, 10))
    P = [[x * y for x in r1 for y in r2] for r1 in R for r2 in R]
    A, b = _class_rows(P, tau)
    best = max(vertex_max(P[i], P[j], A, b)[0] for i, j in itertools.permutations(range(4), 2))
    assert best == expected
    assert vertex_max(P[0], P[3], A, b)[0] == expected  # pair ((T, 25), (M, 55))
    assert _dot(P[0], point) / _dot(P[3], point) == expected and all(_dot(r, point) >= tau for r in P)
    assert _tight_exact(P, F(1), tau)[0] == tight
    mp = fa.product(fa.randomized_response(["T", "M"], keep=0.7), fa.randomized_response([25, 55], keep=0.7))
    assert mp.matrix == pytest.approx(np.array([fl(r) for r in P]), rel=CLOSED)
    c = black_box_bound(mp, utility_class=UtilityClass(tau=float(tau)))
    assert c.method == "threshold" and c.ratio == pytest.approx(float(expected), rel=CLOSED)
    assert (c.group, c.other_group) == (("T", 25), ("M", 55))
    assert c.utility_by_release == pytest.approx(fl(point), rel=CLOSED, abs=1e-15)
    c_lp = black_box_bound(mp, utility_class=UtilityClass(tau=float(tau)), method="lp")
    assert c_lp.ratio == pytest.approx(float(expected), rel=LP)
    hl = c_lp.utility_by_release  # the maximiser is not unique at τ = 1/2
    Pf = np.array([fl(r) for r in P])
    assert np.all(Pf @ hl >= float(tau) * (1 - LP))
    assert (Pf[0] @ hl) / (Pf[3] @ hl) == pytest.approx(float(expected), rel=LP)
    assert math.exp(
        fa.tight_bound(mp, utility_class=fa.UtilityClass(gamma=1.0, tau=float(tau))).value
    ) == pytest.approx(float(tight), rel=CLOSED)
    assert black_box_bound(mp).ratio == pytest.approx(49 / 9, rel=CLOSED)


def _independent_population(contexts, groups, px, pa):
    return fa.Population(np.outer(px, pa), contexts, groups)


def test_black_box_consequence_3_global_under_independence():
    # black_box.md §5 Consequence 3: under X ⊥ A the worst global L̄ is the same value. Theorem 5's members, put behind
    # a context filter M_X (binary RR 0.8) with an independent, non-uniform population, audit to L = L̄ = the value:
    # Example 1 (L_A = 0, two decisions, 11/7) and Example 2 (L_A = 0.1, U = released groups, g(u, x, b) = h[b, u],
    # 58/35).
    ma = fa.randomized_response(["a", "b"], keep=0.7)
    mx = fa.randomized_response(["x0", "x1"], keep=0.8)
    pop = _independent_population(["x0", "x1"], ["a", "b"], [0.3, 0.7], [0.4, 0.6])
    assert pop.independence().independent

    kernel, util = black_box_bound(ma, utility_class=UtilityClass(tau=0.5)).worst_model()
    table = np.repeat(kernel.probabilities, 2, axis=0)  # the same kernel in every released context
    law = fa.compose(fa.Kernel(table, ["x0", "x1"], kernel.groups, kernel.decisions), ma, mx)
    assert global_fairness(law, util, pop).ratio == pytest.approx(11 / 7, rel=CLOSED)
    assert local_fairness(law, util, pop).ratio == pytest.approx(11 / 7, rel=CLOSED)
    assert fa.expected_utility(law, util).min() >= 0.5 * (1 - CLOSED)

    h = np.array([[1.0, 3 / 7], [0.9, 23 / 70]])  # Example 2's exact maximiser, h[b, u]
    ident = np.repeat(np.eye(2)[None, :, :], 2, axis=0)  # K[x̃, ã, u] = 1{u = ã}
    law = fa.compose(fa.Kernel(ident, ["x0", "x1"], ["a", "b"], ["a", "b"]), ma, mx)
    g = fa.from_table(np.repeat(h[None, :, :], 2, axis=0), ["a", "b"], ["x0", "x1"], ["a", "b"])
    assert g.lipschitz() == pytest.approx(0.1, rel=CLOSED)
    assert global_fairness(law, g, pop).ratio == pytest.approx(58 / 35, rel=CLOSED)
    assert local_fairness(law, g, pop).ratio == pytest.approx(58 / 35, rel=CLOSED)
    assert fa.expected_utility(law, g).min() == pytest.approx(0.5, rel=CLOSED)

    # the value bounds L̄ for other members too: random kernels with P(high | x̃, ã) >= 1/2 meet τ = 1/2
    rng = np.random.default_rng(3)
    for _ in range(20):
        hi = rng.uniform(0.5, 1.0, size=(2, 2))
        law = fa.compose(fa.Kernel(np.stack([hi, 1 - hi], -1), ["x0", "x1"], ["a", "b"], ["high", "low"]), ma, mx)
        pr = _independent_population(["x0", "x1"], ["a", "b"], rng.dirichlet([1, 1]), rng.dirichlet([1, 1]))
        assert global_fairness(law, util, pr).ratio <= 11 / 7 * (1 + CLOSED)


# ================================================================== proofs/black_box.md, §6
def test_worst_model_known_utility_example_19_11_and_69_49():
    # black_box.md §6 Example: local 19/11 (context x0, box [0.2, 1], threshold releases {a}), 3/2 at x1; global:
    # w[x̃, u] = Σ_x P(x) M_X[x, x̃] g(u, x), lo_g = 17/50, hi_g = 21/25, (0.34 + 0.5·0.7)/(0.34 + 0.5·0.3) = 69/49.
    keep = F(7, 10)
    box_ratio = lambda lo, hi: (lo + (hi - lo) * keep) / (lo + (hi - lo) * (1 - keep))  # noqa: E731
    G = [[F(1), F(1, 2), F(1, 5)], [F(3, 5), F(3, 10), F(9, 10)]]
    PX = [[F(8, 10), F(2, 10)], [F(2, 10), F(8, 10)]]
    local = [box_ratio(min(r), max(r)) for r in G]
    assert local == [F(19, 11), F(3, 2)]
    w = [[sum(F(1, 2) * PX[x][xt] * G[x][u] for x in range(2)) for u in range(3)] for xt in range(2)]
    assert w == [[F(23, 50), F(23, 100), F(17, 100)], [F(17, 50), F(17, 100), F(19, 50)]]
    lo_g, hi_g = sum(min(r) for r in w), sum(max(r) for r in w)
    assert (lo_g, hi_g) == (F(17, 50), F(21, 25)) and box_ratio(lo_g, hi_g) == F(69, 49)

    ma, mx = fa.randomized_response(["a", "b"], keep=0.7), fa.randomized_response(["x0", "x1"], keep=0.8)
    g = fa.from_table([[fl(r), fl(r)] for r in G], ["u0", "u1", "u2"], ["x0", "x1"], ["a", "b"])
    pop = fa.Population([[0.25, 0.25], [0.25, 0.25]], ["x0", "x1"], ["a", "b"])
    auto = worst_model(ma, g, context_mechanism=mx, population=pop)
    assert auto.local_fairness.method == "threshold" and auto.local_fairness.context == "x0"
    assert auto.local_fairness.ratio == pytest.approx(19 / 11, rel=CLOSED)
    assert auto.global_fairness.ratio == pytest.approx(69 / 49, rel=CLOSED)
    # the worst global kernel: x̃0 answers u0 to released a and u2 to b; x̃1 answers u2 and u1
    assert auto.global_fairness.kernel.probabilities.tolist() == [
        [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]],
    ]
    law = fa.compose(auto.global_fairness.kernel, ma, mx)
    assert global_fairness(law, g, pop).ratio == pytest.approx(69 / 49, rel=CLOSED)
    law = fa.compose(auto.local_fairness.kernel, ma, mx)
    assert local_fairness(law, g, pop).ratio == pytest.approx(19 / 11, rel=CLOSED)
    lp = worst_model(ma, g, context_mechanism=mx, population=pop, method="lp")
    assert lp.local_fairness.method == "lp" and lp.local_fairness.ratio == pytest.approx(19 / 11, rel=LP)
    assert lp.global_fairness.ratio == pytest.approx(69 / 49, rel=LP)
    # Lemma 9: g = 1{u = u0} with τ = 1/2 is Example 1 of §5
    assert worst_model(ma, fa.indicator("u0", ["u0", "u1"]), tau=0.5).local_fairness.ratio == pytest.approx(
        11 / 7, rel=CLOSED
    )


# ================================================================== proofs/worst_case_utility.md
def test_worst_utility_one_context_tau_certificate_7_4():
    # worst_case_utility.md §2, one context: ℓ = 0, τ = 0.4: 7/4 at g = (1, 2/3, 0) (q·g = 0.4, p·g = 0.7);
    # Dinkelbach certificate (p − 7/4 q)·g <= 0 on W; (b, a) also 7/4 at (0, 2/3, 1); no constraint 5/2; ℓ = 0.5: 5/4.
    p, q = [F(5, 10), F(3, 10), F(2, 10)], [F(2, 10), F(3, 10), F(5, 10)]
    A, b = box([0] * 3, [1] * 3)
    A2, b2 = floor_rows([p, q], F(2, 5))
    g = [F(1), F(2, 3), F(0)]
    assert vertex_max(p, q, A + A2, b + b2) == (F(7, 4), [g]) and vertex_max(q, p, A + A2, b + b2)[0] == F(7, 4)
    assert _dot(q, g) == F(2, 5) and _dot(p, g) == F(7, 10)
    lam, mu = F(7, 4), F(3, 4)
    assert [pi - lam * qi for pi, qi in zip(p, q)] == [(pi - qi) - mu * qi for pi, qi in zip(p, q)]
    box_max = max(_dot([pi - qi for pi, qi in zip(p, q)], h) for h in vertices(*box([0] * 3, [1] * 3)))
    assert box_max == F(3, 10) and box_max - mu * F(2, 5) == 0  # max over [0,1]^3 of (0.3, 0, −0.3)·g
    assert all(_dot([pi - lam * qi for pi, qi in zip(p, q)], h) <= 0 for h in vertices(A + A2, b + b2))

    law = fa.Law([[fl(p), fl(q)]], ["x"], ["a", "b"], ["hire", "wait", "reject"])
    w = worst_utility(law, utility_class=UtilityClass(tau=0.4))
    assert w.local_fairness.method == "lp" and w.local_fairness.ratio == pytest.approx(7 / 4, rel=LP)
    expected_g = fl(g) if w.local_fairness.group == "a" else fl(g[::-1])
    assert w.local_fairness.utility.values == pytest.approx(expected_g, rel=LP, abs=LP)
    assert worst_utility(law).local_fairness.ratio == pytest.approx(5 / 2, rel=CLOSED)
    assert worst_utility(law, utility_class=UtilityClass(lower=0.5)).local_fairness.ratio == pytest.approx(
        float(F(3, 4) / F(3, 5)), rel=CLOSED
    )


def test_worst_utility_floors_couple_the_contexts_12_7_and_61_41():
    # worst_case_utility.md §2, two contexts, τ = 2/5, g in [0, 1]^3: (x0, a over b) is 7/4 at (0, 0, 1) with its own
    # context's floors, 12/7 at (1/5, 0, 1) with all four floors (the floor of (x1, b) is tight); global 61/41 (a over
    # b, same g); without constraints local 5/2 and global 7/3 (Lemma 1).
    Q = [
        [[F(1, 10), F(2, 10), F(7, 10)], [F(1, 10), F(5, 10), F(4, 10)]],
        [[F(5, 10), F(1, 10), F(4, 10)], [F(5, 10), F(2, 10), F(3, 10)]],
    ]
    tau = F(2, 5)
    A0, b0 = box([0] * 3, [1] * 3)

    def rows(cells):
        A, b = floor_rows([Q[x][c] for x, c in cells], tau)
        return A0 + A, b0 + b

    own, every = rows([(0, 0), (0, 1)]), rows([(x, c) for x in range(2) for c in range(2)])
    assert vertex_max(Q[0][0], Q[0][1], *own) == (F(7, 4), [[F(0), F(0), F(1)]])
    assert _dot(Q[1][1], [F(0), F(0), F(1)]) == F(3, 10) < tau  # that g breaks the floor of (x1, b)
    g = [F(1, 5), F(0), F(1)]
    assert vertex_max(Q[0][0], Q[0][1], *every) == (F(12, 7), [g]) and _dot(Q[1][1], g) == tau
    local = max(vertex_max(Q[x][a], Q[x][1 - a], *every)[0] for x in range(2) for a in range(2))
    own_x0 = max(vertex_max(Q[0][a], Q[0][1 - a], *own)[0] for a in range(2))
    Pa, Pb = ([(Q[0][c][u] + Q[1][c][u]) / 2 for u in range(3)] for c in range(2))
    assert (Pa, Pb) == ([F(3, 10), F(3, 20), F(11, 20)], [F(3, 10), F(7, 20), F(7, 20)])
    glob = max(vertex_max(Pa, Pb, *every)[0], vertex_max(Pb, Pa, *every)[0])
    assert (local, own_x0, glob) == (F(12, 7), F(7, 4), F(61, 41)) and vertex_max(Pa, Pb, *every)[1] == [g]
    sup_local = max(Q[x][a][u] / Q[x][1 - a][u] for x in range(2) for a in range(2) for u in range(3))
    sup_global = max(max(x / y for x, y in zip(Pa, Pb)), max(y / x for x, y in zip(Pa, Pb)))
    assert (sup_local, sup_global) == (F(5, 2), F(7, 3))

    law = fa.Law([[fl(r) for r in Qx] for Qx in Q], ["x0", "x1"], ["a", "b"], ["u1", "u2", "u3"])
    w = worst_utility(law, utility_class=UtilityClass(tau=0.4))
    assert w.local_fairness.ratio == pytest.approx(float(local), rel=LP)
    assert (w.local_fairness.context, w.local_fairness.group, w.local_fairness.other_group) == ("x0", "a", "b")
    assert w.local_fairness.utility.values == pytest.approx(fl(g), rel=LP, abs=LP)
    assert w.global_fairness.ratio == pytest.approx(float(glob), rel=LP)
    assert (w.global_fairness.group, w.global_fairness.other_group) == ("a", "b")
    only_x0 = fa.Law([[fl(r) for r in Q[0]]], ["x0"], ["a", "b"], ["u1", "u2", "u3"])  # only x0's floors
    w0 = worst_utility(only_x0, utility_class=UtilityClass(tau=0.4))
    assert w0.local_fairness.ratio == pytest.approx(float(own_x0), rel=LP)
    assert w0.local_fairness.utility.values == pytest.approx([0.0, 0.0, 1.0], rel=LP, abs=LP)
    free = worst_utility(law)
    assert free.local_fairness.ratio == pytest.approx(float(sup_local), rel=CLOSED)
    assert free.global_fairness.ratio == pytest.approx(float(sup_global), rel=CLOSED)
    assert fa.sup_local_fairness(law).ratio == pytest.approx(float(sup_local), rel=CLOSED)
