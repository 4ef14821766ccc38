"""The verifier's worst case over a class of utilities Lipschitz in the group, from the proof certify records: equal
to the exact solve of a second route (``_exact_route``, the rational simplex) and to HiGHS (scipy, the Charnes–Cooper
LP written here), through certify's calibration, and failing wherever the proof is tampered with."""

from __future__ import annotations

import copy
import itertools
import json
import math
from fractions import Fraction as F

import numpy as np
import pytest
from _cli import run
from _exact_route import lipschitz_class_exact, lipschitz_worst, symmetric_worst
from _verified import certified_and_verified
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

import fairaudit
from fairaudit.base.outward import exp_up
from fairaudit.verification.class_check import UNPROVEN, lipschitz_class_enclosure
from fairaudit.verification.enclosures import INF, RecordedMechanism
from fairaudit.worstcase.lipschitz_proofs import lipschitz_proof


def _record(rows):
    k, m = len(rows), len(rows[0])
    return {"inputs": list(range(k)), "outputs": list(range(m)), "kind": "matrix", "matrix": rows}


def _rr_record(k: int, epsilon: float):
    labels = [f"g{i}" for i in range(k)]
    return {"inputs": labels, "outputs": labels, "kind": "randomized_response", "epsilon": epsilon}


def _verified(record, lower, gamma, tau, lip, d=None, proof=None):
    """Certify's proof for the class (floats, as a calibration records them), and verify's enclosure from it."""
    if proof is None:
        proof = lipschitz_proof(record, lower, gamma, tau, lip, d)
    metric = None if d is None else [[F(v) for v in row] for row in d]
    m = RecordedMechanism.from_record(record, "m")
    return proof, lipschitz_class_enclosure(
        m, F(lower), F(gamma), None if tau is None else F(tau), F(lip), metric, proof
    )


def _exact(record, lower, gamma, tau, lip, d=None):
    metric = None if d is None else [[F(v) for v in row] for row in d]
    m = RecordedMechanism.from_record(record, "m")
    return lipschitz_class_exact(m, F(lower), F(gamma), None if tau is None else F(tau), F(lip), metric)


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
    record = _record([[0.75, 0.25], [0.125, 0.875]])
    _, e = _verified(record, 0.2, 1.0, 0.25, 1.0)
    assert (e.lo, e.hi) == (F(4), F(4)) == (_exact(record, 0.2, 1.0, 0.25, 1.0).lo,) * 2


def test_no_floor_and_lower_zero_is_unbounded():
    # h[b] = min(γ, L_A d(b, a')) vanishes at a' only: E[g | a'] = 0 < E[g | a] (proofs/black_box.md §5, item 4)
    record = _record([[0.6, 0.4], [0.1, 0.9]])
    proof, e = _verified(record, 0.0, 1.0, None, 0.1)
    assert e.lo == e.hi == INF == _exact(record, 0.0, 1.0, None, 0.1).hi
    assert proof["programs"] == []  # no bound: the witness, q·h = 0 < p·h, shows it


def test_a_screen_sets_pairs_aside_and_verify_recomputes_it():
    # groups 0 and 1 released alike (t = 1.04): their pairs' screens t + L_A d/τ = 1.06 lie below the largest value,
    # 1.608 (group 0 against group 2); certify solves only the other four pairs
    rows = [[0.5, 0.3, 0.2], [0.48, 0.32, 0.2], [0.2, 0.3, 0.5]]
    d = [[0, 1, 1], [1, 0, 1], [1, 1, 0]]
    proof, e = _verified(_record(rows), 0.0, 1.0, 0.5, 0.01, d)
    assert {(p["group"], p["other_group"]) for p in proof["programs"]} == {(0, 2), (2, 0), (1, 2), (2, 1)}
    assert e.hi == F(proof["programs"][0]["bound"]) and float(e.hi) == pytest.approx(1.608)
    assert e.lo == e.hi == _exact(_record(rows), 0.0, 1.0, 0.5, 0.01, d).lo


def test_randomized_response_is_enclosed_between_its_ends():
    record = {"inputs": ["a", "b", "c"], "outputs": ["a", "b", "c"], "kind": "randomized_response", "epsilon": 1.0}
    proof, e = _verified(record, 0.5, 1.0, 0.3, 0.05)
    exact = _exact(record, 0.5, 1.0, 0.3, 0.05)
    assert e.lo <= exact.lo <= exact.hi <= e.hi and 0 < e.hi - e.lo < F(1, 10**15)
    # the bound is the exact value at the e^ε the proof records, exp_up(1) ≥ e
    t = F(exp_up(1.0))
    assert F(proof["at"]) == t and e.hi == symmetric_worst(t / (t + 2), 1 / (t + 2), 3, F(1, 2), F(1), F(0.3), F(0.05))
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


@settings(max_examples=40, deadline=None)  # (HiGHS on every pair, and the exact programs)
@given(drawn=classes())
def test_the_proofs_give_the_exact_value_and_highs_agrees(drawn):
    rows, lower, tau, lip, d = drawn
    _, e = _verified(_record(rows), lower, 1.0, tau, lip, d)
    exact = _exact(_record(rows), lower, 1.0, tau, lip, d)
    assert e.lo == e.hi == exact.lo == exact.hi  # the exact Fraction, from the recorded proof alone
    assert float(e.lo) == pytest.approx(_highs(np.array(rows), lower, 1.0, tau, lip, d), rel=1e-7)


def _tampered(proof, change):
    out = copy.deepcopy(proof)
    change(out)
    return out


def _lower_a_multiplier(proof):
    rows = proof["programs"][0]["rows"]
    i = next(i for i, v in enumerate(rows) if F(v) > 0)
    rows[i] = float(F(rows[i]) / 2)


@pytest.mark.parametrize(
    "change",
    [
        _lower_a_multiplier,
        lambda p: p["programs"][0].update(bound=float(F(p["programs"][0]["bound"])) * (1 - 1e-9)),  # λ lowered
        lambda p: p["witness_point"].__setitem__(0, 1.5),  # beyond γ: off the box
        lambda p: p["witness_point"].__setitem__(1, 1.0),  # a Lipschitz row broken (h[a, 1] − h[b, 1] > 1/10)
        lambda p: p["programs"][0]["rows"].pop(),  # a row's multiplier missing
        lambda p: p["programs"][0]["rows"].__setitem__(0, -1.0),  # a negative multiplier
    ],
)
def test_a_tampered_proof_proves_nothing(change):
    record = _record([[0.7, 0.3], [0.3, 0.7]])
    proof, e = _verified(record, 0.0, 1.0, 0.5, 0.1)
    assert e.lo == e.hi and float(e.lo) == pytest.approx(58 / 35)
    assert _verified(record, 0.0, 1.0, 0.5, 0.1, proof=_tampered(proof, change))[1] == UNPROVEN


def test_a_witness_that_misses_a_floor_is_moved_toward_gamma():
    # the witness scaled by 1 − 1e-12 misses its binding floor M[b]·h ≥ τ by about 5e-13 (as randomized response's
    # vertex may at the lower end of e^ε): verify moves it to (1 − δ) h + δγ, in the polytope, its ratio a lower end
    record = _record([[0.7, 0.3], [0.3, 0.7]])
    proof, exact = _verified(record, 0.0, 1.0, 0.5, 0.1)
    shrunk = [float(F(v) * (1 - F(1, 10**12))) for v in proof["witness_point"]]
    m = RecordedMechanism.from_record(record, "m")
    rows = [[F(v) for v in r] for r in record["matrix"]]
    assert min(sum(w * h for w, h in zip(r, shrunk[2 * b : 2 * b + 2])) for b, r in enumerate(rows)) < F(1, 2)
    e = lipschitz_class_enclosure(m, F(0), F(1), F(1, 2), F(0.1), None, {**proof, "witness_point": shrunk})
    assert e != UNPROVEN and e.hi == exact.hi and exact.hi * (1 - F(1, 10**11)) < e.lo < exact.lo


def test_randomized_response_at_an_e_epsilon_below_its_own_proves_nothing():
    record = _rr_record(4, 1.0)
    proof, _ = _verified(record, 0.0, 1.0, 0.3, 0.05)
    below = _tampered(proof, lambda p: p.update(at=math.e * (1 - 1e-12)))
    assert _verified(record, 0.0, 1.0, 0.3, 0.05, proof=below)[1] == UNPROVEN


def test_no_proof_recorded_is_not_re_derived():
    record = _record([[0.7, 0.3], [0.3, 0.7]])
    assert isinstance(_verified(record, 0.0, 1.0, 0.5, 0.1, proof={})[1], str)


SPEC = (
    '[sensitive]\nname = "group"\nvalues = [{values}]\n[decision]\nname = "d"\nvalues = ["yes", "no"]\n'
    '[privacy.sensitive]\nmechanism = "randomized_response"\nepsilon = 1.0\n'
    '[utility]\nkind = "table"\nvalues = [1.0, 0.5]\ntau = 0.3\nlipschitz = 0.05\n{metric}[target]\nlocal = 0.5\n'
)


@pytest.mark.parametrize(
    ("groups", "metric"),
    [
        (["a", "b", "c"], "metric = [[0, 1, 2], [1, 0, 1], [2, 1, 0]]\n"),
        ([f"g{i}" for i in range(8)], ""),  # 64 variables over H: the symmetric program of randomized response
    ],
)
def test_a_lipschitz_calibration_is_re_derived(tmp_path, groups, metric):
    values = ", ".join(f'"{g}"' for g in groups)
    cert, _, checked = certified_and_verified(SPEC.format(values=values, metric=metric), tmp_path)
    assert {"calibration.bound", "calibration.target", "calibration.epsilon is the largest"} <= checked
    assert set(cert["calibration"]["proofs"]) == {"black_box", "black_box_above"}
    moved = copy.deepcopy(cert)
    moved["calibration"]["bound"] -= 1e-9
    assert "calibration.bound" in {c.name for c in fairaudit.verify(moved).failures}


@pytest.mark.parametrize(
    ("member", "change", "fails"),
    [
        ("black_box", _lower_a_multiplier, "calibration.bound"),
        (
            "black_box",
            lambda p: p["programs"][0].update(bound=float(F(p["programs"][0]["bound"])) * 0.999),
            "calibration.bound",
        ),
        ("black_box_above", lambda p: p["witness_point"].__setitem__(0, 2.0), "calibration.epsilon is the largest"),
    ],
)
def test_a_tampered_calibration_proof_fails_verify_with_exit_1(capsys, tmp_path, member, change, fails):
    cert, _, _ = certified_and_verified(SPEC.format(values='"a", "b", "c"', metric=""), tmp_path)
    change(cert["calibration"]["proofs"][member])
    assert fails in {c.name for c in fairaudit.verify(cert).failures}
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert), encoding="utf-8")
    assert run(capsys, "verify", path)[0] == 1


def test_a_format_2_certificate_is_refused_with_one_line(capsys, tmp_path):
    cert, _, _ = certified_and_verified(SPEC.format(values='"a", "b"', metric=""), tmp_path)
    cert["format_version"] = 2
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert), encoding="utf-8")
    code, out, err = run(capsys, "verify", path)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "format version 2" in err and "re-certify" in err


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
    t = F(t_tenths, 10)
    p, q = t / (t + k - 1), 1 / (t + k - 1)
    rows = tuple(tuple(p if i == j else q for j in range(k)) for i in range(k))
    lower, tau, lip = F(lower_tenths, 10), None if tau_tenths is None else F(tau_tenths, 10), F(lip_hundredths, 100)
    d = [[F(0) if b == c else F(distance) for c in range(k)] for b in range(k)]
    assert symmetric_worst(p, q, k, lower, F(1), tau, lip * distance) == lipschitz_worst(rows, lower, F(1), tau, lip, d)


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(
    k=st.integers(2, 6),
    eps_tenths=st.integers(1, 30),
    lower_tenths=st.sampled_from([0, 1, 3]),
    tau_tenths=st.one_of(st.none(), st.integers(1, 9)),
    lip_hundredths=st.sampled_from([1, 5, 20, 60]),
)
def test_randomized_response_proofs_enclose_the_exact_route(k, eps_tenths, lower_tenths, tau_tenths, lip_hundredths):
    args = (lower_tenths / 10, 1.0, None if tau_tenths is None else tau_tenths / 10, lip_hundredths / 100)
    if args[0] == 0 and args[2] is None:
        return  # (unbounded: the test above)
    _, e = _verified(_rr_record(k, eps_tenths / 10), *args)
    exact = _exact(_rr_record(k, eps_tenths / 10), *args)
    assert e.lo <= exact.lo <= exact.hi <= e.hi <= exact.hi * (1 + F(1, 10**14))


def test_randomized_response_on_twelve_groups_is_re_derived():
    # 144 variables for the whole program: randomized response with one distance between groups is proved on the
    # symmetric program; the enclosure holds certify's closed form (proofs/black_box.md §5, 7b)
    k, eps, tau, lip = 12, 1.3, 0.4, 0.05
    proof, e = _verified(_rr_record(k, eps), 0.0, 1.0, tau, lip)
    exact = _exact(_rr_record(k, eps), 0.0, 1.0, tau, lip)
    assert e.lo <= exact.lo <= exact.hi <= e.hi <= e.lo * (1 + F(1, 10**14))
    c = fairaudit.black_box_bound(
        fairaudit.randomized_response(list(range(k)), eps), utility_class=fairaudit.UtilityClass(tau=tau, lipschitz=lip)
    )
    assert F(c.ratio) >= e.hi and c.ratio <= float(e.lo) * (1 + 1e-12)
    # a metric with two distances: the whole program, beyond the size certify proves
    d = [[0.0 if b == c else 1.0 + (b + c) % 2 for c in range(k)] for b in range(k)]
    assert lipschitz_proof(_rr_record(k, eps), 0.0, 1.0, tau, lip, d) is None
