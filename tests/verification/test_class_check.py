"""The verifier's worst case over a class of utilities Lipschitz in the group: by hand, against HiGHS (scipy, the
Charnes–Cooper LP written here), and through certify's calibration."""

from __future__ import annotations

import itertools
from fractions import Fraction as F

import numpy as np
import pytest
from _verified import certified_and_verified
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

import fairaudit
from fairaudit.verification.class_check import lipschitz_class_enclosure
from fairaudit.verification.enclosures import INF, RecordedMechanism


def _matrix(rows):
    k, m = len(rows), len(rows[0])
    record = {"inputs": list(range(k)), "outputs": list(range(m)), "kind": "matrix", "matrix": rows}
    return RecordedMechanism.from_record(record, "m")


def _highs(M, lower, gamma, tau, lip, d):
    """max over pairs of (M[a]·h[a])/(M[b]·h[b]) over H, by Charnes–Cooper (y = s h, M[b]·y[b] = 1) and HiGHS."""
    n, m = M.shape
    N = n * m + 1
    best = 0.0
    for a, b in itertools.permutations(range(n), 2):
        rows, rhs = [], []
        for i in range(n * m):
            for sign, bound in ((1, gamma), (-1, -lower)):  # sign·y_i − sign-bound·s ≤ 0
                r = np.zeros(N)
                r[i], r[-1] = sign, -bound
                rows.append(r)
                rhs.append(0.0)
        for g, c in itertools.combinations(range(n), 2):
            for o in range(m):
                for sign in (1, -1):
                    r = np.zeros(N)
                    r[g * m + o], r[c * m + o], r[-1] = sign, -sign, -lip * d[g][c]
                    rows.append(r)
                    rhs.append(0.0)
        for g in range(n):
            r = np.zeros(N)
            r[g * m : (g + 1) * m], r[-1] = -M[g], tau
            rows.append(r)
            rhs.append(0.0)
        obj, den = np.zeros(N), np.zeros(N)
        obj[a * m : (a + 1) * m], den[b * m : (b + 1) * m] = M[a], M[b]
        res = linprog(-obj, A_ub=np.array(rows), b_ub=rhs, A_eq=den[None], b_eq=[1.0],
                      bounds=[(0, None)] * N, method="highs")  # fmt: skip
        best = max(best, -res.fun)
    return best


def test_a_lipschitz_constant_the_box_implies_leaves_gamma_over_the_floor():
    # L_A d >= γ − lower: h[a] and h[a'] are free in the box; the ratio is γ over the smallest denominator
    # max(τ, lower) = 1/4: 4, whatever the mechanism (rows exact in binary: their sums are exactly 1)
    m = _matrix([[0.75, 0.25], [0.125, 0.875]])
    e = lipschitz_class_enclosure(m, F(1, 5), F(1), F(1, 4), F(1), None)
    assert (e.lo, e.hi) == (F(4), F(4))


def test_no_floor_and_lower_zero_is_unbounded():
    # h[b] = min(γ, L_A d(b, a')) vanishes at a' only: E[g | a'] = 0 < E[g | a] (proofs/black_box.md §5, item 4)
    m = _matrix([[0.6, 0.4], [0.1, 0.9]])
    assert lipschitz_class_enclosure(m, F(0), F(1), None, F(1, 10), None).hi == INF


def test_randomized_response_is_enclosed_between_its_ends():
    record = {"inputs": ["a", "b", "c"], "outputs": ["a", "b", "c"], "kind": "randomized_response", "epsilon": 1.0}
    e = lipschitz_class_enclosure(RecordedMechanism.from_record(record, "m"), F(1, 2), F(1), F(3, 10), F(1, 20), None)
    assert 0 < e.hi - e.lo < F(1, 10**40)
    t = np.e
    M = np.array([[t, 1, 1], [1, t, 1], [1, 1, t]]) / (t + 2)
    assert float(e.lo) == pytest.approx(_highs(M, 0.5, 1.0, 0.3, 0.05, 1 - np.eye(3)), rel=1e-7)


@st.composite
def classes(draw):
    n, m = draw(st.integers(2, 3)), draw(st.integers(2, 3))
    rows = []
    for _ in range(n):
        ints = draw(st.lists(st.integers(1, 5), min_size=m, max_size=m))
        rows.append([float(F(i, sum(ints))) for i in ints])
    lower = draw(st.sampled_from([0.0, 0.1, 0.5]))
    tau = draw(st.sampled_from([0.05, 0.2, 0.5])) + lower / 2
    lip = draw(st.sampled_from([0.02, 0.1, 0.3]))
    d = [[0.0 if b == c else float(1 + (b + c) % 2) for c in range(n)] for b in range(n)]
    return rows, lower, tau, lip, d


@settings(max_examples=40)  # (HiGHS on every pair, and the exact programs)
@given(drawn=classes())
def test_the_programs_agree_with_highs(drawn):
    rows, lower, tau, lip, d = drawn
    exact = lipschitz_class_enclosure(_matrix(rows), F(lower), F(1), F(tau), F(lip), [[F(v) for v in r] for r in d])
    assert exact.lo == exact.hi
    assert float(exact.lo) == pytest.approx(_highs(np.array(rows), lower, 1.0, tau, lip, d), rel=1e-7)


@pytest.mark.parametrize(
    ("groups", "metric"),
    [
        (["a", "b", "c"], "metric = [[0, 1, 2], [1, 0, 1], [2, 1, 0]]\n"),
        ([f"g{i}" for i in range(8)], ""),  # 64 variables over H: the symmetric program of randomized response
    ],
)
def test_a_lipschitz_calibration_is_re_derived(tmp_path, groups, metric):
    values = ", ".join(f'"{g}"' for g in groups)
    cert, _, checked = certified_and_verified(
        f'[sensitive]\nname = "group"\nvalues = [{values}]\n[decision]\nname = "d"\nvalues = ["yes", "no"]\n'
        '[privacy.sensitive]\nmechanism = "randomized_response"\nepsilon = 1.0\n'
        '[utility]\nkind = "table"\nvalues = [1.0, 0.5]\ntau = 0.3\nlipschitz = 0.05\n'
        f"{metric}[target]\nlocal = 0.5\n",
        tmp_path,
    )
    assert {"calibration.bound", "calibration.target", "calibration.epsilon is the largest"} <= checked
    cert["calibration"]["bound"] -= 1e-9
    assert "calibration.bound" in {c.name for c in fairaudit.verify(cert).failures}


def _rr(k: int, epsilon: float) -> RecordedMechanism:
    labels = [f"g{i}" for i in range(k)]
    record = {"inputs": labels, "outputs": labels, "kind": "randomized_response", "epsilon": epsilon}
    return RecordedMechanism.from_record(record, "m")


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(
    k=st.integers(2, 5),
    t_tenths=st.integers(1, 40),
    lower_tenths=st.sampled_from([0, 0, 1, 3]),
    tau_tenths=st.one_of(st.none(), st.integers(1, 9)),
    lip_hundredths=st.sampled_from([0, 1, 5, 20, 60]),
    distance=st.sampled_from([1, 2, 3]),
)
def test_randomized_response_with_one_distance_is_the_full_program(
    k, t_tenths, lower_tenths, tau_tenths, lip_hundredths, distance
):
    # the symmetric program (at most 10 variables, whatever k) against the whole program over H (k^2 variables),
    # both exact, on rational rows p = t/(t + k - 1), q = 1/(t + k - 1)
    from fairaudit.verification.class_check import _symmetric_worst, _worst

    t = F(t_tenths, 10)
    p, q = t / (t + k - 1), 1 / (t + k - 1)
    rows = tuple(tuple(p if i == j else q for j in range(k)) for i in range(k))
    lower, tau, lip = F(lower_tenths, 10), None if tau_tenths is None else F(tau_tenths, 10), F(lip_hundredths, 100)
    d = [[F(0) if b == c else F(distance) for c in range(k)] for b in range(k)]
    assert _symmetric_worst(p, q, k, lower, F(1), tau, lip * distance) == _worst(rows, lower, F(1), tau, lip, d)


def test_randomized_response_on_twelve_groups_is_re_derived():
    # 144 variables for the whole program, beyond its 36: randomized response with one distance between groups is
    # solved on the symmetric program; the enclosure holds certify's closed form (proofs/black_box.md §5, 7b)
    k, eps, tau, lip = 12, 1.3, 0.4, 0.05
    e = lipschitz_class_enclosure(_rr(k, eps), F(0), F(1), F(tau), F(lip), None)
    assert not isinstance(e, str) and e.lo <= e.hi <= e.lo * (1 + F(1, 10**14))
    c = fairaudit.black_box_bound(
        fairaudit.randomized_response(list(range(k)), eps), utility_class=fairaudit.UtilityClass(tau=tau, lipschitz=lip)
    )
    assert F(c.ratio) >= e.hi and c.ratio <= float(e.lo) * (1 + 1e-12)
    # a metric with two distances keeps the whole program, beyond its size
    d = [[F(0) if b == c else F(1 + (b + c) % 2) for c in range(k)] for b in range(k)]
    assert lipschitz_class_enclosure(_rr(k, eps), F(0), F(1), F(tau), F(lip), d) == "programs beyond 36 variables"
