"""k-ary randomized response in closed form, against the general route on its explicit k x k matrix.

``fa.randomized_response`` returns a lazy mechanism whose ε, δ(ε), pairwise δ, keep probability, paper and tight
bounds, black-box certificate, worst model and calibration are closed forms (memory linear in k). Every expected
value here comes from an independent route: the k x k matrix built with numpy in this file and run through the
general code path (``fa.from_matrix``, which must not take the fast path), exact ``Fraction`` arithmetic for a hand
case (k = 3, e^ε = 4: p = 2/3, q = 1/6), the formulas of ``proofs/black_box.md`` §3 written out here, or the exact
vertex enumeration of ``proofs/_exact.py``. The large-k tests assert memory (tracemalloc), never wall-clock time.
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
import tracemalloc
from fractions import Fraction as F
from pathlib import Path

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fairaudit as fa
from fairaudit import UtilityClass
from fairaudit.cli import main
from fairaudit.laws.closed_forms import RandomizedResponse
from fairaudit.worstcase.black_box import black_box_bound
from fairaudit.worstcase.calibration import calibrate
from fairaudit.worstcase.known_utility import worst_model


def rr_family(k: int) -> fa.MechanismFamily:
    """k-ary randomized response on the groups 0 to k − 1: the family ``calibrate(groups=k)`` chose before issue 81."""
    return fa.randomized_response_family(range(k))


PROOFS = Path(__file__).resolve().parents[2] / "proofs"
KS = (2, 3, 5, 17)
EPSILONS = (0.0, 0.3, 1.7, 6.0)


# --------------------------------------------------------------------------- the independent route


def rr_matrix(k: int, eps: float) -> np.ndarray:
    """The k x k matrix of k-ary RR written out here: e^ε/(e^ε + k − 1) on the diagonal, 1/(e^ε + k − 1) off it."""
    t = math.exp(eps)
    m = np.full((k, k), 1.0 / (t + k - 1))
    np.fill_diagonal(m, t / (t + k - 1))
    return m


def pair(k: int, eps: float) -> tuple[fa.Mechanism, fa.Mechanism]:
    """(closed form, general route) on the same labels."""
    closed = fa.randomized_response(list(range(k)), eps)
    general = fa.from_matrix(rr_matrix(k, eps), list(range(k)))
    assert isinstance(closed, RandomizedResponse)
    assert not isinstance(general, RandomizedResponse)
    return closed, general


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err and "Error" not in err.replace("error:", "")
    return code, out, err


def run_json(capsys, *argv):
    code, out, err = run(capsys, *argv, "--format", "json")
    return code, json.loads(out), err


def spec_text(values, mechanism: str, utility: str = 'decision = "yes"', target: float | None = 0.5) -> str:
    return (
        '[sensitive]\nname = "group"\nvalues = ' + json.dumps(list(values)) + "\n"
        '[decision]\nname = "chosen"\nvalues = ["yes", "no"]\n'
        '[privacy.sensitive]\nmechanism = "randomized_response"\n' + mechanism + "\n"
        "[utility]\n" + utility + "\n" + ("" if target is None else f"[target]\nlocal = {target}\n")
    )


# --------------------------------------------------------------------------- the mechanism itself


def test_randomized_response_is_lazy_and_from_matrix_is_general():
    m = fa.randomized_response(list(range(5)), 1.0)
    assert isinstance(m, RandomizedResponse) and "matrix" not in m.__dict__
    assert m.epsilon == 1.0 and m.delta(0.5) > 0 and m.keep_probability > 0
    assert "matrix" not in m.__dict__  # ε, δ and the keep probability did not build the 5 x 5 matrix
    np.testing.assert_allclose(m.matrix, rr_matrix(5, 1.0), rtol=1e-14)
    assert isinstance(fa.randomized_response_family(list("abc"))(0.4), RandomizedResponse)
    assert not isinstance(fa.from_matrix(rr_matrix(3, 0.4), list("abc")), RandomizedResponse)


@pytest.mark.parametrize("k", KS)
@pytest.mark.parametrize("eps", EPSILONS)
def test_epsilon_delta_profile_and_keep_equal_the_general_route(k, eps):
    closed, general = pair(k, eps)
    assert closed.epsilon == pytest.approx(general.epsilon, rel=1e-12, abs=1e-12)
    assert closed.keep_probability == pytest.approx(general.keep_probability, rel=1e-12)
    grid = [0.0, 0.1, eps / 2, eps, eps + 0.5, 40.0]
    np.testing.assert_allclose(closed.delta(grid), general.delta(grid), rtol=1e-12, atol=1e-14)
    for e in grid + [math.inf]:
        np.testing.assert_allclose(closed.pairwise_delta(e), general.pairwise_delta(e), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(closed.profile().deltas, general.profile().deltas, rtol=1e-12, atol=1e-14)
    for d in (0.0, 0.01, 0.2, 1.0):
        assert closed.epsilon_for_delta(d) == pytest.approx(general.epsilon_for_delta(d), rel=1e-11, abs=1e-12)
    assert closed.is_identity == general.is_identity


def test_identity_and_huge_epsilon():
    ident = fa.randomized_response(list("abc"), math.inf)
    assert ident.is_identity and ident.keep_probability == 1.0
    assert ident.delta([0.0, 3.0, math.inf]).tolist() == [1.0, 1.0, 1.0]  # disjoint mass, as the identity matrix
    assert ident.epsilon_for_delta(0.5) == math.inf and ident.epsilon_for_delta(1.0) == 0.0
    for eps in (710.0, 1e5, 1e308):  # e^ε overflows a double: no OverflowError, the limit p → 1, q → e^-ε
        m = fa.randomized_response(list("abc"), eps)
        assert m.epsilon == eps and m.keep_probability == 1.0 and not m.is_identity
        assert m.delta(eps) == 0.0 and m.delta(math.inf) == 0.0 and m.delta(0.0) == pytest.approx(1.0, abs=1e-300)
        assert m.epsilon_for_delta(0.5) == pytest.approx(eps + math.log(0.5), rel=1e-15)
    assert fa.randomized_response(list("abc"), 720.0).rr.log_q == pytest.approx(-720.0, rel=1e-15)


def test_general_pairwise_delta_with_a_huge_epsilon_does_not_overflow():
    m = fa.from_matrix([[0.5, 0.5, 0.0], [0.25, 0.5, 0.25]], [0, 1], [0, 1, 2])
    for eps in (710.0, math.inf):  # upper ends, rounded up (proofs/outward.md §5)
        got = m.pairwise_delta(eps)
        assert got[0].tolist() == [0.0, 0.0] and got[1, 1] == 0.0
        assert 0.25 <= got[1, 0] <= 0.25 * (1 + 1e-14)


def test_hand_case_in_fractions_k3_e_eps_4():
    # k = 3, e^ε = 4: p = 4/6 = 2/3, q = 1/6 (Fractions); every pair's δ(t) = [p − t q]₊.
    p, q = F(2, 3), F(1, 6)
    m = fa.randomized_response(["a", "b", "c"], math.log(4))
    assert m.keep_probability == pytest.approx(float(p), rel=1e-15)
    assert m.rr.q == pytest.approx(float(q), rel=1e-15)
    assert m.delta(0.0) == pytest.approx(float(p - q), rel=1e-15)  # 1/2
    assert m.delta(math.log(2)) == pytest.approx(float(p - 2 * q), rel=1e-15)  # 1/3
    assert m.epsilon_for_delta(float(p - 3 * q)) == pytest.approx(math.log(3), rel=1e-14)  # δ = 1/6 at t = 3
    # paper and tight, γ = 1, τ = 1/2: min(log(1 + (p − q)/τ), ε) = min(log 2, log 4)
    tau = F(1, 2)
    assert fa.paper_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.5)).value == pytest.approx(
        math.log(1 + (p - q) / tau), rel=1e-15
    )
    assert fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.5)).value == pytest.approx(
        math.log(1 + (p - q) / tau), rel=1e-15
    )
    # L_A = 1/2 (discrete): paper min(log(1 + (1/2 + 1/2)/(1/2)), log 4 + log(1 + 1)) = log 3;
    # tight min(1 + (1/2 + 1/2)/(1/2), 4 + (1/2)/(1/2)) = 3
    assert fa.paper_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.5, lipschitz=0.5)).value == pytest.approx(
        math.log(3), rel=1e-15
    )
    assert fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.5, lipschitz=0.5)).value == pytest.approx(
        math.log(3), rel=1e-15
    )
    # black-box (proofs/black_box.md §3): lower 0: p/q = 4; lower 1/5: (1/5 + 4/5 p)/(1/5 + 4/5 q) = 11/5
    lo = F(1, 5)
    assert black_box_bound(m).ratio == pytest.approx(float(p / q), rel=1e-15)
    assert black_box_bound(m, utility_class=UtilityClass(lower=0.2)).ratio == pytest.approx(
        float((lo + (1 - lo) * p) / (lo + (1 - lo) * q)), rel=1e-15
    )
    # a binding floor τ = 1/4 (> q, ≤ 2q): a and part of the other value raised: 1 + (p − q)/τ = 3
    c = black_box_bound(m, utility_class=UtilityClass(tau=0.25))
    assert c.ratio == pytest.approx(float(1 + (p - q) / F(1, 4)), rel=1e-15)
    h = [F(1), F(0), F(1, 4) / q - 1]  # q·h = q + q·x = 1/4: x = 1/2 of the third value
    assert c.utility_by_release.tolist() == pytest.approx([float(v) for v in h], abs=1e-15)
    # τ = 1/2 (> 2q): a and the other value raised, a' by s = (1/2 − 2q)/p = 1/4: (p + q + q s)/τ = 7/4
    s = (tau - 2 * q) / p
    c = black_box_bound(m, utility_class=UtilityClass(tau=0.5))
    assert s == F(1, 4) and c.ratio == pytest.approx(float((p + q + q * s) / tau), rel=1e-15)
    assert c.utility_by_release.tolist() == pytest.approx([1.0, float(s), 1.0], abs=1e-15)
    # calibration back to ε = log 4 from the target log(11/5) with lower 1/5, keep probability 2/3
    cal = calibrate(
        math.log(11 / 5), family=fa.randomized_response_family(["a", "b", "c"]), utility_class=UtilityClass(lower=0.2)
    )
    assert cal.epsilon == pytest.approx(math.log(4), rel=1e-13) and cal.keep_probability == pytest.approx(2 / 3)


# --------------------------------------------------------------------------- paper and tight


@pytest.mark.parametrize("k", KS)
@pytest.mark.parametrize("eps", EPSILONS)
def test_paper_and_tight_equal_the_general_route(k, eps):
    closed, general = pair(k, eps)
    for tau, lip in ((0.5, 0.0), (0.05, 0.0), (0.3, 0.2), (1.0, 0.0)):
        for bound in (fa.paper_bound, fa.tight_bound):
            a = bound(closed, utility_class=fa.UtilityClass(tau=tau, gamma=1.0, lipschitz=lip))
            b = bound(general, utility_class=fa.UtilityClass(tau=tau, gamma=1.0, lipschitz=lip))
            # the general route widens its float value when many pairs tie (k = 17 at ε = 0: 272 pairs), by about 1e-14 times gamma/tau
            assert a.value == pytest.approx(b.value, rel=1e-12, abs=1e-10)
            assert a.epsilon == pytest.approx(b.epsilon, rel=1e-12, abs=1e-14)
            assert a.delta == pytest.approx(b.delta, rel=1e-12, abs=1e-14)
            assert (a.group, a.other_group) == (b.group, b.other_group)


def test_tight_with_a_metric_equals_the_general_route():
    closed, general = pair(5, 1.2)
    pts = np.array([0.0, 0.3, 1.0, 1.2, 2.5])
    d = np.abs(pts[:, None] - pts[None, :])
    for tau in (0.1, 0.6):
        a = fa.tight_bound(closed, utility_class=fa.UtilityClass(tau=tau, gamma=1.0, lipschitz=0.2, metric=d))
        b = fa.tight_bound(general, utility_class=fa.UtilityClass(tau=tau, gamma=1.0, lipschitz=0.2, metric=d))
        assert a.value == pytest.approx(b.value, rel=1e-12) and (a.group, a.other_group) == (b.group, b.other_group)


# --------------------------------------------------------------------------- black-box


@pytest.mark.parametrize("k", KS)
@pytest.mark.parametrize("eps", EPSILONS)
def test_black_box_without_lipschitz_equals_the_general_route(k, eps):
    closed, general = pair(k, eps)
    for lower, tau in ((0.0, None), (0.2, None), (0.0, 0.3), (0.1, 0.6), (0.0, 1.0), (0.3, 0.2)):
        a = black_box_bound(closed, utility_class=UtilityClass(lower=lower, gamma=1.0, tau=tau))
        b = black_box_bound(general, utility_class=UtilityClass(lower=lower, gamma=1.0, tau=tau))
        assert a.value == pytest.approx(b.value, rel=1e-12, abs=1e-14), (lower, tau)
        assert a.method == "threshold" and a.programs_solved == 0
        # the worst utility attains the value and meets every group's floor
        h = a.utility_by_release
        rows = rr_matrix(k, eps) @ h
        assert math.log(rows.max() / rows.min()) == pytest.approx(a.value, rel=1e-12, abs=1e-14)
        assert rows.min() >= (tau or 0.0) * (1 - 1e-12) and h.min() >= lower - 1e-15 and h.max() <= 1 + 1e-15


def test_black_box_gamma_scales():
    closed, general = pair(4, 0.9)
    a = black_box_bound(closed, utility_class=UtilityClass(lower=0.5, gamma=2.0, tau=1.2))
    b = black_box_bound(general, utility_class=UtilityClass(lower=0.5, gamma=2.0, tau=1.2))
    assert a.value == pytest.approx(b.value, rel=1e-12)
    np.testing.assert_allclose(np.sort(a.utility_by_release), np.sort(b.utility_by_release), rtol=1e-12)


def no_tau_lipschitz_closed_form(k: int, eps: float, lower: float, lam: float) -> float:
    """Without a binding τ the worst h[a'] takes lower or 1 − λ per value (threshold in the ratio; the other groups at
    min(h[a'] + λ, 1)): the largest of the four prefixes ∅, {a}, every value but a', every value."""
    t = math.exp(eps)
    p, q = t / (t + k - 1), 1 / (t + k - 1)
    lam = min(lam, 1 - lower)
    hi, fl = 1 - lam, lower + lam  # h[a'] at the top, h[a] at the bottom of the box

    def ratio(num_top: float, den_top: float) -> float:
        return (num_top + fl * (1 - num_top)) / (hi * den_top + lower * (1 - den_top))

    return max(ratio(0, 0), ratio(p, q), ratio(1 - q, 1 - p), ratio(1, 1))


@pytest.mark.slow
@pytest.mark.parametrize("k", (2, 3, 5))
@pytest.mark.parametrize("eps", (0.0, 0.4, 2.0))
def test_black_box_with_lipschitz_equals_the_general_route(k, eps):
    closed, general = pair(k, eps)
    for lower, tau, lip in ((0.1, None, 0.1), (0.3, None, 0.5), (0.0, 0.4, 0.1), (0.1, 0.7, 0.05), (0.2, 0.3, 0.2)):
        a = black_box_bound(closed, utility_class=UtilityClass(lower=lower, gamma=1.0, tau=tau, lipschitz=lip))
        b = black_box_bound(
            general, utility_class=UtilityClass(lower=lower, gamma=1.0, tau=tau, lipschitz=lip)
        )  # the Charnes–Cooper LP
        assert a.value == pytest.approx(b.value, rel=1e-8, abs=1e-10), (lower, tau, lip)
        assert a.programs_solved == 0 and a.status == "optimal"
        # its worst utility per group is in the class and attains the value exactly (an independent lower bound)
        h, M = a.utility_by_release, rr_matrix(k, eps)
        e = np.einsum("ba,ba->b", M, h)
        assert np.abs(h[:, None, :] - h[None, :, :]).max() <= lip * (1 + 1e-12) + 1e-15
        assert h.min() >= lower - 1e-15 and h.max() <= 1 + 1e-15 and e.min() >= (tau or 0) * (1 - 1e-12)
        assert math.log(e[0] / e[1]) == pytest.approx(a.value, rel=1e-12, abs=1e-14)
        if tau is None or tau <= lower:
            want = no_tau_lipschitz_closed_form(k, eps, lower, lip)
            assert a.ratio == pytest.approx(want, rel=1e-12)


def test_black_box_with_lipschitz_unbounded_without_a_floor():
    c = black_box_bound(fa.randomized_response(list(range(4)), 1.0), utility_class=UtilityClass(lipschitz=0.1))
    assert c.value == math.inf and c.status == "unbounded" and c.reason


def test_black_box_lipschitz_example_2_in_fractions(monkeypatch):
    # proofs/black_box.md, Example 2: binary RR keeping 0.7, L_A = 0.1, τ = 1/2: 58/35 by vertex enumeration
    monkeypatch.syspath_prepend(str(PROOFS))
    from _exact import box, vertex_max

    R = [[F(7, 10), F(3, 10)], [F(3, 10), F(7, 10)]]
    A, b = box([0] * 4, [1] * 4)
    for o in range(2):
        e = [F(0)] * 4
        e[o], e[2 + o] = F(1), F(-1)
        A += [e, [-v for v in e]]
        b += [F(1, 10)] * 2
    A += [[-R[0][0], -R[0][1], 0, 0], [0, 0, -R[1][0], -R[1][1]]]
    b += [-F(1, 2)] * 2
    exact = vertex_max(R[0] + [0, 0], [0, 0] + R[1], A, b)[0]
    c = black_box_bound(
        fa.randomized_response(["a", "b"], keep=0.7), utility_class=UtilityClass(tau=0.5, lipschitz=0.1)
    )
    assert exact == F(58, 35) and c.ratio == pytest.approx(float(exact), rel=1e-14)
    np.testing.assert_allclose(c.utility_by_release, [[1.0, 3 / 7], [0.9, 23 / 70]], atol=1e-14)


def rational_ends(k: int, eps: float, lower: float, tau: float, lip: float, metric: np.ndarray | None) -> tuple[F, F]:
    """The exact worst ratio over the class behind k-ary randomized response at e^epsilon's rational lower and upper
    ends (the rational simplex on the whole program, every group's h: the tests' exact route, verify's before its
    certificates recorded proofs), which enclose the exact one."""
    from fairaudit.verification.enclosures import RecordedMechanism

    path = Path(__file__).resolve().parents[1] / "verification" / "_exact_route.py"
    spec = importlib.util.spec_from_file_location("_exact_route_for_worstcase", path)
    assert spec is not None and spec.loader is not None
    route = sys.modules.setdefault(spec.name, importlib.util.module_from_spec(spec))
    spec.loader.exec_module(route)  # (registered first: its dataclasses look their module up)
    labels = [f"g{i}" for i in range(k)]
    record = {"inputs": labels, "outputs": labels, "kind": "randomized_response", "epsilon": eps}
    d = None if metric is None else [[F(float(v)) for v in row] for row in metric]  # the floats, exactly
    e = route.lipschitz_class_exact(RecordedMechanism.from_record(record, "m"), F(lower), F(1), F(tau), F(lip), d)
    assert not isinstance(e, str), e
    return e.lo, e.hi


# found by a random hunt: the programs were solved on randomized response's floats as if exact, 1e-17 to 4e-17
# below the exact value's upper end (with L_A = 0, the witness 1e-14 above it)
@pytest.mark.parametrize(
    "k, eps, points, tau, lip",
    [
        (4, 2.9624666878468804, [0.31871083848551673, 0.7885489358200289, 0.8698965116962161, 0.391084806539194],
         0.5065173111859591, 0.192646962513783),
        (4, 2.1663733039002375, [0.2808233280360034, 0.08272491799811632, 0.9697713192928598, 0.5639267453679521],
         0.6510246735058725, 0.29266701711627846),
        (4, 2.618404554563207, [0.21836189884262291, 0.23009715061195535, 0.49274309924545157, 0.7532229040143165],
         0.6929626982093107, 0.474072134822498),
    ],
)  # fmt: skip
@pytest.mark.slow
def test_black_box_lipschitz_with_a_metric_encloses_the_exact_programs(k, eps, points, tau, lip):
    # L_A > 0, a metric other than the discrete one and a binding floor: no closed form, so every pair's LP, on
    # randomized response's float matrix; the value must be at least the upper end, the witness at most it (the
    # groups on a line: three of them make a degenerate vertex, whose witness is pulled inside the polytope)
    metric = np.abs(np.subtract.outer(points, points))
    low, high = rational_ends(k, eps, 0.0, tau, lip, metric)
    c = black_box_bound(
        fa.randomized_response(list(range(k)), eps), utility_class=UtilityClass(tau=tau, lipschitz=lip, metric=metric)
    )
    assert c.method == "lp" and c.certified
    assert F(c.ratio) >= high and c.ratio <= float(low) * (1 + 1e-12)
    assert F(c.witness) <= high and c.witness >= float(low) * (1 - 1e-9)


@pytest.mark.parametrize(
    "k, eps, lower, tau",
    [
        (2, 1.0064460776696595, 0.0, 0.6346140062618605),
        (4, 3.4838759907482015, 0.10918094942131146, 0.314155874670315),
        (3, 2.993615483020565, 0.39034869216898616, 0.5658400701297708),
        (2, 2.077706488382951, 0.0, 0.22867852331392802),
    ],
)
def test_black_box_forced_lp_encloses_the_exact_programs(k, eps, lower, tau):
    # method="lp" skips the closed form: the LP on randomized response's floats, a single pair (every pair is alike)
    low, high = rational_ends(k, eps, lower, tau, 0.0, None)
    c = black_box_bound(fa.randomized_response(list(range(k)), eps), utility_class=UtilityClass(lower=lower, tau=tau),
                        method="lp")  # fmt: skip
    assert c.method == "lp" and c.certified and c.programs_solved == 1
    assert F(c.ratio) >= high and c.ratio <= float(low) * (1 + 1e-12)
    assert F(c.witness) <= high and c.witness >= float(low) * (1 - 1e-12)


@pytest.mark.parametrize(
    "eps, lower, tau, lip",
    [(math.log(7 / 3), 0.0, 0.5, 0.1), (1e-9, 0.1, 0.3, 0.05), (0.3, 0.0, 0.01, 0.5), (5.0, 0.2, 0.9, 0.2)],
)
def test_black_box_lipschitz_is_an_upper_end_of_the_vertex_enumeration(monkeypatch, eps, lower, tau, lip):
    # binary randomized response, L_A > 0: the certified value against vertex enumeration of the whole program
    # (h[b, o] for both groups, independent of the closed form's reduction) at e^epsilon's rational ends; the value is
    # non-decreasing in e^epsilon, so [value at t_down, value at t_up] encloses the exact one
    monkeypatch.syspath_prepend(str(PROOFS))
    from _exact import box, vertex_max

    from fairaudit.base.outward import exp_down, exp_up

    def enumerated(t: F) -> F:
        p, q = t / (t + 1), 1 / (t + 1)
        R = [[p, q], [q, p]]
        A, b = box([F(lower)] * 4, [1] * 4)
        for o in range(2):
            e = [F(0)] * 4
            e[o], e[2 + o] = F(1), F(-1)
            A += [e, [-v for v in e]]
            b += [F(lip)] * 2
        A += [[-R[0][0], -R[0][1], 0, 0], [0, 0, -R[1][0], -R[1][1]]]
        b += [-F(tau)] * 2
        return vertex_max(R[0] + [0, 0], [0, 0] + R[1], A, b)[0]

    low, high = enumerated(F(exp_down(eps))), enumerated(F(exp_up(eps)))
    c = black_box_bound(
        fa.randomized_response(["a", "b"], eps), utility_class=UtilityClass(lower=lower, tau=tau, lipschitz=lip)
    )
    assert F(c.ratio) >= high and c.ratio <= float(low) * (1 + 1e-13)
    mpmath.mp.dps = 50
    top = mpmath.log(mpmath.mpf(high.numerator) / high.denominator)
    assert c.value >= top and c.value - mpmath.log(mpmath.mpf(low.numerator) / low.denominator) < 1e-13


@pytest.mark.slow
def test_black_box_with_a_non_discrete_metric():
    closed, general = pair(4, 1.0)
    pts = np.array([0.0, 0.5, 0.8, 2.0])
    d = np.abs(pts[:, None] - pts[None, :])
    for tau in (None, 0.5):  # without τ: the closed form at L_A·diam; with a binding τ: the general LP
        a = black_box_bound(closed, utility_class=UtilityClass(lower=0.1, tau=tau, lipschitz=0.1, metric=d))
        b = black_box_bound(general, utility_class=UtilityClass(lower=0.1, tau=tau, lipschitz=0.1, metric=d))
        assert a.value == pytest.approx(b.value, rel=1e-8)


# --------------------------------------------------------------------------- worst model


@pytest.mark.slow
@pytest.mark.parametrize("k", (2, 3, 5))
@pytest.mark.parametrize("eps", (0.0, 0.7, 3.0))
def test_worst_model_equals_the_general_route(k, eps):
    closed, general = pair(k, eps)
    U = ["u0", "u1", "u2"]
    contexts = ["x0", "x1"]
    utilities = [
        fa.indicator("u0", U),
        fa.Utility([0.2, 1.0, 0.5], U),
        fa.from_table(np.repeat(np.array([[0.3, 1.0, 0.6], [0.1, 0.9, 0.4]])[:, None, :], k, 1), U, contexts, range(k)),
    ]
    mx = fa.randomized_response(contexts, 1.0)
    for g in utilities:
        for tau in (None, 0.25, 0.5):
            for cm in (None, mx):
                kw = {"tau": tau, "context_mechanism": cm}
                a = worst_model(closed, g, **kw)
                b = worst_model(general, g, **kw)
                for ca, cb in ((a.local_fairness, b.local_fairness), (a.global_fairness, b.global_fairness)):
                    assert ca.value == pytest.approx(cb.value, rel=1e-9, abs=1e-12), (g, tau, cm, ca.kind)
                    # the worst model, composed and audited, gives its value and meets τ
                    law = fa.compose(ca.kernel, closed, cm)
                    audited = fa.local_fairness(law, g) if ca.kind == "local" else fa.global_fairness(law, g)
                    # (the value is an upper bound, certified; the model is its witness, within the LP's 1e-9)
                    assert audited.value <= ca.value * (1 + 1e-14) + 1e-14
                    assert audited.value == pytest.approx(ca.value, rel=1e-9, abs=1e-12)
                    if tau is not None:  # (1e-9: where the general route's LP decides, its tolerance)
                        assert np.nanmin(fa.expected_utility(law, g)) >= tau * (1 - 1e-9)


def test_worst_model_infeasible_tau():
    w = worst_model(fa.randomized_response(list("abc"), 1.0), fa.Utility([0.2, 0.1], ["u0", "u1"]), tau=0.5)
    assert (
        math.isnan(w.local_fairness.value)
        and w.local_fairness.status == "infeasible"
        and "tau" in w.local_fairness.reason
    )


# --------------------------------------------------------------------------- calibration


def rr_black_box_epsilon(target: float, k: int, rho: float) -> float:
    """proofs/black_box.md §3, written out: t = (T ρ (k − 1) + T (1 − ρ) − ρ (k − 1)) / (1 − T ρ)."""
    big = math.exp(target)
    if big * rho >= 1:
        return math.inf
    return math.log((big * rho * (k - 1) + big * (1 - rho) - rho * (k - 1)) / (1 - big * rho))


def bisect_general(k: int, target: float, **cls) -> float:
    """The largest ε with black_box_bound(general route) ≤ target, by plain bisection (the value is monotone)."""
    lo, hi = 0.0, 1.0
    while black_box_bound(fa.from_matrix(rr_matrix(k, hi), list(range(k))), **cls).value <= target:
        lo, hi = hi, 2 * hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        value = black_box_bound(fa.from_matrix(rr_matrix(k, mid), list(range(k))), **cls).value
        lo, hi = (mid, hi) if value <= target else (lo, mid)
    return lo


@pytest.mark.slow
@pytest.mark.parametrize("k", (2, 3, 5))
def test_calibration_equals_the_general_route(k):
    for target, cls in (
        (0.4, {"utility_class": UtilityClass(lower=0.0)}),
        (0.4, {"utility_class": UtilityClass(lower=0.2)}),
        (0.4, {"utility_class": UtilityClass(lower=0.0, tau=0.3)}),
        (0.3, {"utility_class": UtilityClass(lower=0.1, tau=0.5, lipschitz=0.05)}),
    ):
        c = calibrate(target, family=rr_family(k), **cls)
        want = bisect_general(k, target, **cls)
        assert c.epsilon == pytest.approx(want, rel=1e-8), cls
        if cls["utility_class"].tau is None:
            lower = cls["utility_class"].lower
            assert c.epsilon == pytest.approx(rr_black_box_epsilon(target, k, lower), rel=1e-12)
        t = math.exp(c.epsilon)
        assert c.keep_probability == pytest.approx(t / (t + k - 1), rel=1e-12)


@pytest.mark.slow
def test_calibrate_a_million_groups_in_closed_form_and_little_memory():
    k = 10**6
    tracemalloc.start()
    try:
        c = calibrate(0.5, family=rr_family(k))  # lower = 0, no τ, L_A = 0: the black-box value of RR is ε itself
        c2 = calibrate(0.5, family=rr_family(k), utility_class=UtilityClass(lower=0.2))
        c3 = calibrate(0.5, family=rr_family(k), utility_class=UtilityClass(lower=0.1, tau=0.3, lipschitz=0.05))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 200e6  # the labels, not a (k, k) or (k, k, k) array
    assert c.epsilon == pytest.approx(0.5, rel=1e-12) and c.feasible and "closed form" in c.reason
    assert c.keep_probability == pytest.approx(math.exp(0.5) / (math.exp(0.5) + k - 1), rel=1e-12)
    assert c2.epsilon == pytest.approx(rr_black_box_epsilon(0.5, k, 0.2), rel=1e-12)
    t = math.exp(c2.epsilon)
    assert c2.keep_probability == pytest.approx(t / (t + k - 1), rel=1e-12)
    assert c3.feasible and c3.bound == pytest.approx(0.5, rel=1e-9)


# --------------------------------------------------------------------------- property tests


@pytest.mark.slow
@given(
    k=st.integers(2, 12),
    eps=st.one_of(st.just(0.0), st.floats(0.0, 8.0)),
    tau=st.floats(0.01, 1.0),
    lower=st.floats(0.0, 0.9),
    gamma=st.floats(0.5, 3.0),
    lip=st.one_of(st.just(0.0), st.floats(0.0, 0.5)),
)
def test_closed_forms_equal_the_general_route_property(k, eps, tau, lower, gamma, lip):
    closed, general = pair(k, eps)
    lower, tau = lower * gamma, tau * gamma
    for e in (0.0, eps / 3, eps, eps + 1):
        assert closed.delta(e) == pytest.approx(general.delta(e), rel=1e-12, abs=1e-14)
    for bound in (fa.paper_bound, fa.tight_bound):
        a = bound(closed, utility_class=fa.UtilityClass(tau=tau, gamma=gamma, lipschitz=lip))
        b = bound(general, utility_class=fa.UtilityClass(tau=tau, gamma=gamma, lipschitz=lip))
        assert a.value == pytest.approx(b.value, rel=1e-12, abs=1e-10)  # widened general route, as above
    for t in (None, tau):
        a = black_box_bound(closed, utility_class=UtilityClass(lower=lower, gamma=gamma, tau=t))
        b = black_box_bound(general, utility_class=UtilityClass(lower=lower, gamma=gamma, tau=t))
        # (the general route's LP value is certified from its dual: an upper bound within 1e-9)
        assert a.value == pytest.approx(b.value, rel=1e-12, abs=1e-9)


# (a subnormal floor leaves the threshold rule an absolute underflow term, proofs/linear_fractional.md §7: excluded)
@pytest.mark.slow
@given(k=st.integers(2, 40), target=st.floats(0.0, 5.0), rho=st.floats(0.0, 0.95, allow_subnormal=False))
def test_calibration_closed_form_meets_the_target_property(k, target, rho):
    c = calibrate(target, family=rr_family(k), utility_class=UtilityClass(lower=rho))
    want = rr_black_box_epsilon(target, k, rho)
    if math.isinf(want) or target >= -math.log(max(rho, 1e-300)):
        assert c.epsilon == math.inf
        return
    assert c.epsilon == pytest.approx(want, rel=1e-10, abs=1e-12)
    general = black_box_bound(
        fa.from_matrix(rr_matrix(k, c.epsilon), list(range(k))), utility_class=UtilityClass(lower=rho)
    )
    # the general route is certified (rounded up by its error bound): within the 1e-9·max(1, v) of the target
    assert target - 1e-12 <= general.value <= target + 1e-9 * max(1.0, target)


# --------------------------------------------------------------------------- certify with 1,000 groups


@pytest.mark.parametrize("tau", [None, 0.001])
def test_certify_a_thousand_groups_is_closed_form_and_small(tmp_path, capsys, tau):
    k, eps = 1000, 0.5
    utility = 'decision = "yes"' + ("" if tau is None else f"\ntau = {tau}")
    path = tmp_path / "many.toml"
    path.write_text(spec_text([f"g{i}" for i in range(k)], f"epsilon = {eps}", utility), encoding="utf-8")
    tracemalloc.start()
    try:
        code, d, _ = run_json(capsys, "certify", path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 200e6
    t = math.exp(eps)
    p, q = t / (t + k - 1), 1 / (t + k - 1)
    b = d["bounds"]
    assert b["corollary"] == pytest.approx(eps, rel=1e-12)
    if tau is None:  # L_A = 0, pure DP: no τ needed, paper = tight = ε; black-box (lower 0) = ε
        assert b["paper"] == pytest.approx(eps, rel=1e-12) and b["tight"] == pytest.approx(eps, rel=1e-12)
        assert b["black_box"] == pytest.approx(eps, rel=1e-12)
        assert any(a["status"] == "not applicable" and "no tau needed" in a["detail"] for a in d["assumptions"])
    else:
        assert b["paper"] == pytest.approx(min(math.log1p((p - q) / tau), eps), rel=1e-12)
        assert b["tight"] == pytest.approx(min(math.log(1 + (p - q) / tau), eps), rel=1e-12)
        # black-box with the floor: q < τ ≤ (k − 1) q, so a and part of the others are raised: 1 + (p − q)/τ
        assert q < tau <= (k - 1) * q
        assert b["black_box"] == pytest.approx(math.log(1 + (p - q) / tau), rel=1e-12)
        assert d["bound_details"]["black_box"]["global"]["value"] == pytest.approx(b["black_box"], rel=1e-12)
    assert code == 0 and d["certified"] is True  # every bound is ≤ the target 0.5
    cal = d["calibration"]
    assert cal["feasible"] and cal["keep_probability"] == pytest.approx(
        math.exp(cal["epsilon"]) / (math.exp(cal["epsilon"]) + k - 1), rel=1e-12
    )
    if tau is None:
        assert cal["epsilon"] == pytest.approx(0.5, rel=1e-12)
    else:  # the largest ε whose closed-form black-box value is the target
        te = math.exp(cal["epsilon"])
        pe, qe = te / (te + k - 1), 1 / (te + k - 1)
        value = math.log(1 + (pe - qe) / tau) if qe < tau <= (k - 1) * qe else math.log(pe / qe)
        assert value == pytest.approx(0.5, rel=1e-9)


# --------------------------------------------------------------------------- overflow: the right value, no traceback


def test_cli_spec_with_epsilon_710(tmp_path, capsys):
    path = tmp_path / "e710.toml"
    path.write_text(spec_text(["a", "b", "c"], "epsilon = 710", 'decision = "yes"\ntau = 0.2'), encoding="utf-8")
    code, d, _ = run_json(capsys, "certify", path)
    assert code == 1 and d["certified"] is False  # the target 0.5 is not met
    assert d["privacy"]["sensitive"]["epsilon"] == 710.0 and d["privacy"]["sensitive"]["keep_probability"] == 1.0
    assert d["bounds"]["corollary"] == 710.0
    # paper and tight at t = 1 (δ = p − q = 1 to rounding): log(1 + 1/0.2) = log 6; black-box (τ = 0.2 binding,
    # q = e^-710/(...) ≈ 0): a and the other value raised, a' by 0.2: (1 + 0·...)/0.2 → log 5
    assert d["bounds"]["paper"] == pytest.approx(math.log(6), rel=1e-12)
    assert d["bounds"]["tight"] == pytest.approx(math.log(6), rel=1e-12)
    assert d["bounds"]["black_box"] == pytest.approx(math.log(5), rel=1e-12)
    path.write_text(spec_text(["a", "b", "c"], "epsilon = 710", 'decision = "yes"'), encoding="utf-8")
    code, d, _ = run_json(capsys, "certify", path)  # no τ: every bound is ε = 710 (lower = 0), not inf
    assert code == 1 and d["bounds"]["paper"] == d["bounds"]["tight"] == d["bounds"]["black_box"] == 710.0
    code, out, err = run(capsys, "certify", path)
    assert code == 1 and "710 nats" in out and err == ""


def test_cli_spec_with_epsilon_inf(tmp_path, capsys):
    path = tmp_path / "inf.toml"
    path.write_text(spec_text(["a", "b"], "epsilon = inf", 'decision = "yes"'), encoding="utf-8")
    code, d, _ = run_json(capsys, "certify", path)
    assert code == 1 and d["privacy"]["sensitive"]["epsilon"] == "inf"
    assert d["bounds"]["paper"] is None and d["bounds"]["tight"] is None  # ε = inf: τ is needed
    assert d["bounds"]["black_box"] == "inf"


@pytest.mark.parametrize(
    "argv, epsilon",
    [
        (["--target", "710"], 710.0),
        (["--target", "1e308"], 1e308),
        (["--target", "800", "--groups", "1000"], 800.0),
        (["--target", "1e308", "--lower", "0.5"], "inf"),  # every ε: the identity's worst case is log 2
        (["--target", "710", "--method", "paper"], 710.0),  # no τ needed: ε = target
        (["--target", "1e308", "--method", "tight", "--tau", "0.5", "--lipschitz", "0.1"], 1e308),
        (["--target", "720", "--tau", "0.5"], "inf"),  # black-box with τ: at most log(1/0.5)
        # T·ρ < 1 (k = 2): t = T/(1 − Tρ), so ε = 720 − log(1 − ρ e^720), in logarithms (e^720 overflows)
        (["--target", "720", "--lower", "1e-320"], 720.0 - math.log1p(-math.exp(720.0 + math.log(1e-320)))),
    ],
)
def test_cli_calibrate_huge_targets(capsys, argv, epsilon):
    code, d, _ = run_json(capsys, "calibrate", *argv)
    assert code == 0 and d["feasible"] is True
    # the calibrated ε is a lower end, each term of the logarithmic form rounded down above 700 nats
    assert d["epsilon"] == epsilon if isinstance(epsilon, str) else d["epsilon"] == pytest.approx(epsilon, rel=1e-14)
    assert d["keep_probability"] == 1.0


@pytest.mark.parametrize(
    "target, k, lower",
    [(701.0, 3, 1e-310), (705.0, 2, 5e-308), (710.0, 5, 2e-310), (720.0, 4, 1e-320), (709.9, 7, 1e-309),
     (800.0, 3, 0.5), (708.5, 2, 3e-308), (1e4, 3, 0.0)],
)  # fmt: skip
def test_calibrated_epsilon_above_700_nats_is_a_lower_end_within_an_ulp(target, k, lower):
    # against 60 digits: t = (T r (k − 1) + T (1 − r) − r (k − 1))/(1 − T r), T = e^target, r = lower/γ exactly;
    # +inf when T r >= 1 (was 0.0 at (800, 3, 0.5): the widening of +inf gave NaN)
    from fairaudit.worstcase.calibration_methods import rr_black_box_epsilon as closed_form

    got = closed_form(target, k, lower, 1.0)
    with mpmath.workdps(60):
        r = mpmath.mpf(F(lower).numerator) / F(lower).denominator
        big = mpmath.exp(mpmath.mpf(target))
        if big * r >= 1:
            assert got == math.inf
            return
        exact = mpmath.log((big * r * (k - 1) + big * (1 - r) - r * (k - 1)) / (1 - big * r))
        assert got <= exact and (exact - got) / exact < 1e-15


def test_calibrate_huge_target_bound_is_the_target():
    c = calibrate(1e308)
    assert c.epsilon == 1e308 and c.bound == 1e308 and c.mechanism.keep_probability == 1.0
    # ε + ln(1 + x e^−ε) > ε exactly: the upper end is the next float
    assert fa.main_theorem_tight(1e308, 0.1, gamma=1.0, tau=0.5) == math.nextafter(1e308, math.inf)


# --------------------------------------------------------------------------- τ is not needed when the extra term is 0


def test_paper_and_tight_without_tau_are_epsilon():
    m = fa.from_matrix([[0.45, 0.40, 0.15], [0.65, 0.20, 0.15], [0.65, 0.30, 0.05]], ["a0", "a1", "a2"])
    eps = math.log(3)  # 0.45/0.15 (a0 over a2 on o2)
    for mech in (m, fa.randomized_response(list("abcd"), 1.3), fa.randomized_response(["x"], 2.0)):
        want = mech.epsilon if len(mech.inputs) > 1 else 0.0
        for bound in (fa.paper_bound, fa.tight_bound):
            b = bound(mech, utility_class=fa.UtilityClass(gamma=1.0))
            assert b.value == pytest.approx(want, rel=1e-12) and b.delta == 0.0 and math.isnan(b.tau)
            assert b.assumptions[-1].status == "not applicable" and "no tau needed" in b.assumptions[-1].detail
    assert fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0)).value == pytest.approx(eps, rel=1e-12)
    assert (
        fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0)).group,
        fa.tight_bound(m, utility_class=fa.UtilityClass(gamma=1.0)).other_group,
    ) == ("a0", "a2")
    # with τ the bound may be smaller (δ > 0 traded against τ), never larger than ε(M) when L_A = 0
    assert fa.paper_bound(m, utility_class=fa.UtilityClass(gamma=1.0, tau=0.1)).value <= eps + 1e-12


def test_paper_and_tight_still_need_tau_when_the_extra_term_is_not_zero():
    rr = fa.randomized_response(list("ab"), keep=0.7)
    table = fa.from_table([[[1.0, 0.0], [0.5, 0.5]]], ["yes", "no"], ["all"], ["a", "b"])
    cases = [
        ({"mechanism": rr}, 0.1, "L_A"),
        ({"mechanism": fa.identity(list("ab"))}, None, "epsilon(M) = inf"),
        ({"mechanism": fa.randomized_response(list("ab"), math.inf)}, None, "epsilon(M) = inf"),
        ({"mechanism": rr, "utility": table}, 0.0, "depends on the group"),
    ]
    for kw, lipschitz, why in cases:
        for bound in (fa.paper_bound, fa.tight_bound):
            with pytest.raises(fa.InputError, match=r"^tau: the (paper|tight) bound needs tau") as err:
                bound(utility_class=fa.UtilityClass(gamma=1.0, lipschitz=lipschitz), **kw)
            assert why in str(err.value)


def test_calibrate_paper_and_tight_without_tau():
    for method in ("paper", "tight"):
        c = calibrate(0.5, method=method, family=rr_family(3))
        assert c.feasible and c.epsilon == 0.5 and c.bound == 0.5 and "without tau" in c.reason
        assert c.keep_probability == pytest.approx(math.exp(0.5) / (math.exp(0.5) + 2), rel=1e-12)
        for kw in ({"utility_class": fa.UtilityClass(lipschitz=0.2)}, {"delta": 0.1}):
            with pytest.raises(fa.InputError, match=f"^tau: the {method} bound needs tau"):
                calibrate(0.5, method=method, family=rr_family(3), **kw)


def test_cli_calibrate_tight_without_tau(capsys):
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.5, "--method", "tight")
    assert code == 0 and d["epsilon"] == 0.5 and d["tau"] is None and "without tau" in d["reason"]
    code, out, err = run(capsys, "calibrate", "--target", 0.5, "--method", "paper", "--lipschitz", 0.2)
    assert code == 2 and out == "" and err.startswith("fairaudit: error: --tau: the paper bound needs tau")


def test_certify_without_tau_reports_epsilon_or_needs_tau(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(spec_text(["a", "b"], "keep = 0.7", 'decision = "yes"', target=None), encoding="utf-8")
    code, d, _ = run_json(capsys, "certify", path)
    eps = math.log(7 / 3)
    assert code == 0 and d["bounds"]["paper"] == pytest.approx(eps) and d["bounds"]["tight"] == pytest.approx(eps)
    code, out, _ = run(capsys, "certify", path)
    assert "needs utility.tau" not in out and "[not applicable] E[g | x, a] >= tau" in out
    # a utility that depends on the group (L_A > 0): τ is needed, paper and tight are n/a
    util = 'kind = "table"\nvalues = [[[1.0, 0.0], [0.5, 0.2]]]'
    path.write_text(spec_text(["a", "b"], "keep = 0.7", util, target=None), encoding="utf-8")
    code, d, _ = run_json(capsys, "certify", path)
    assert code == 0 and d["bounds"]["paper"] is None and d["bounds"]["tight"] is None


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))


@pytest.mark.parametrize("k", [2, 3])
def test_rr_law_agrees_with_compose_and_refuses_the_same_cells(k):
    # the closed form without the k x k matrix: the same law as the matrix product, and the same refusal where
    # q = 1/(e^epsilon + k - 1) is below the float range (800 nats); at 700 nats L = ln(p/q) = epsilon
    from fairaudit.laws.composition import compose
    from fairaudit.worstcase.randomized_response import rr_law

    groups = [f"g{i}" for i in range(k)]
    rows = [[1.0, 0.0]] + [[0.0, 1.0]] * (k - 1)
    kernel = fa.Kernel([rows], ["all"], groups, ["d0", "d1"])
    near = fa.randomized_response(groups, epsilon=700.0)
    law = rr_law(kernel, near.rr, near.inputs, fa.identity(["all"]))
    np.testing.assert_allclose(law.probabilities, compose(kernel, near).probabilities, rtol=1e-15, atol=0)
    value = fa.local_fairness(law, fa.indicator("d0", ["d0", "d1"])).value
    assert abs(value - 700.0) <= 1e-12 * 700
    far = fa.randomized_response(groups, epsilon=800.0)
    with pytest.raises(fa.UnderflowError, match=rf"^mechanism '{k}-ary randomized response': .*epsilon = 800 nats"):
        rr_law(kernel, far.rr, far.inputs, fa.identity(["all"]))
    with pytest.raises(fa.UnderflowError, match=rf"^mechanism '{k}-ary randomized response': "):
        compose(kernel, far)


@given(
    st.integers(2, 6),
    st.sampled_from([1e-17, 1e-9, 0.3, 1.0, 3.0, 30.0]),
    st.sampled_from([0.0, 0.1, 0.5]),
    st.sampled_from([0.6, 1.0, 2.0]),
    st.floats(0.0, 1.0),
)
def test_the_witness_point_meets_every_floor_at_both_ends_and_attains_the_closed_form(k, epsilon, lo, hi, share):
    # the exact maximiser recorded for verify: in the box, every group's floor met at the rational upper end of e^eps
    # and at the lower one (verify reads it at its own end, between them), and at the upper end its ratio is the
    # closed form's value there, computed by its own formula (_rr_box_ratio) and by the threshold rule where the
    # floor does not bind
    from fairaudit.worstcase.randomized_response import _rr_box_ratio, rr_exact_rows, rr_witness_point

    floor = lo + share * (hi - lo)
    h = rr_witness_point(k, epsilon, lo, hi, floor, 0, 1)
    if h is None:  # no floor point: a' cannot reach the floor even raised to hi
        p, q = rr_exact_rows(k, epsilon, 1)
        assert p <= q or F(lo) + (F(hi) - F(lo)) * (q * (k - 1) + p) < F(floor)
        return
    assert all(F(lo) <= v <= F(hi) for v in h)
    for end in (0, 1):
        p, q = rr_exact_rows(k, epsilon, end)
        rows = [[p if i == j else q for j in range(k)] for i in range(k)]
        released = [sum((m * v for m, v in zip(row, h)), F(0)) for row in rows]
        assert min(released) >= F(floor)
        if end == 1:
            assert released[0] / released[1] == _rr_box_ratio(k, epsilon, F(lo), F(hi), floor)
