"""Calibration of ε: each method against an independent route (hand algebra, Fractions, a second algorithm).

Proofs of what is checked here: proofs/calibration.md (closed forms, monotonicity along a family, the
white-box definition) and proofs/black_box.md §3 (the randomized-response closed form).
"""

from __future__ import annotations

import inspect
import itertools
import math
from fractions import Fraction
from pathlib import Path

import mpmath
import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

import fairaudit as fa
from fairaudit import UtilityClass
from fairaudit.laws.closed_forms import keep_probability, randomized_response
from fairaudit.laws.families import MechanismFamily
from fairaudit.worstcase.calibration import calibrate
from fairaudit.worstcase.calibration_result import Calibration


def rr_family(k: int) -> MechanismFamily:
    """k-ary randomized response on the groups 0 to k − 1: the family ``calibrate(groups=k)`` chose before issue 81."""
    return fa.randomized_response_family(range(k))


def disguised_rr(k: int) -> MechanismFamily:
    """k-ary randomized response with its outputs listed in reverse order.

    The same mechanism up to a relabelling of the released values (so the same black-box value), but not
    recognised by calibrate's closed-form fast path: calibrate must find ε by its root finder.
    """
    labels = tuple(range(k))
    return MechanismFamily(
        f"{k}-ary RR, outputs reversed",
        labels,
        lambda e: fa.from_matrix(randomized_response(labels, e).matrix[:, ::-1], labels, labels[::-1]),
        lambda e: keep_probability(e, k),
    )


def bisect_black_box(family, target, lower, gamma=1.0, hi=60.0):
    """Plain bisection, 200 halvings, on black_box_bound along the family (a second algorithm)."""
    lo = 0.0
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (
            (mid, hi)
            if fa.black_box_bound(family(mid), utility_class=fa.UtilityClass(lower=lower, gamma=gamma)).value <= target
            else (lo, mid)
        )
    return lo


# -- black-box ------------------------------------------------------------------------------------------


@pytest.mark.slow
@given(st.integers(2, 16), st.floats(0.0, 0.9), st.floats(0.01, 3.0))
def test_closed_form_equals_bisection_on_black_box(k, rho, target):
    # The RR closed form (fast path) against plain bisection on the exact threshold worst case.
    c = fa.calibrate_randomized_response(target, k, utility_class=fa.UtilityClass(lower=rho, gamma=1.0))
    if math.isinf(c.epsilon):
        assert rho > 0 and math.exp(target) * rho >= 1 - 1e-12
        return
    lo = bisect_black_box(fa.randomized_response_family(list(range(k))), target, rho)
    assert c.epsilon == pytest.approx(lo, rel=1e-9, abs=1e-12)
    assert c.bound == pytest.approx(target, rel=1e-9)


@pytest.mark.slow
@given(st.integers(2, 12), st.floats(0.0, 0.9), st.floats(0.01, 3.0))
def test_root_finder_agrees_with_rr_closed_form(k, rho, target):
    # calibrate's own root finder (on a relabelled RR it cannot recognise) against the closed form, to 1e-9.
    fast = calibrate(target, family=rr_family(k), utility_class=UtilityClass(lower=rho))
    slow = calibrate(target, family=disguised_rr(k), utility_class=UtilityClass(lower=rho))
    assert "closed form" in fast.reason and "bracketing" in slow.reason or math.isinf(fast.epsilon)
    if math.isinf(fast.epsilon):
        assert math.isinf(slow.epsilon)
        return
    assert slow.epsilon == pytest.approx(fast.epsilon, rel=1e-9, abs=1e-12)
    assert slow.bound <= target and slow.bound == pytest.approx(target, rel=1e-9)


def test_rr_hand_values():
    # proofs/black_box.md §3: k = 2, rho = 1/2, worst ratio (2t + 1)/(t + 2); target log(17/13) gives t = 7/3.
    c = calibrate(math.log(17 / 13), family=rr_family(2), utility_class=UtilityClass(lower=0.5))
    assert c.epsilon == pytest.approx(math.log(7 / 3), rel=1e-12)
    assert c.keep_probability == pytest.approx(0.7, rel=1e-12)
    assert (c.method, c.feasible, c.kind, c.groups, c.family) == (
        "black_box",
        True,
        "local",
        2,
        "2-ary randomized response",
    )
    assert np.allclose(c.mechanism.matrix, [[0.7, 0.3], [0.3, 0.7]], rtol=0, atol=1e-12)


def test_every_epsilon_meets_a_target_above_gamma_over_lower():
    # g in [0.2, 1]: no model can exceed a ratio of 5, so a target of log 5 is met even without privacy
    # (the float above ln 5: math.log(5) is below it, and a lower end of ε may not round it up).
    c = calibrate(math.nextafter(math.log(5), math.inf), family=rr_family(3), utility_class=UtilityClass(lower=0.2))
    assert math.isinf(c.epsilon) and c.keep_probability == 1.0 and c.feasible
    assert c.bound == pytest.approx(math.log(5), rel=1e-12)
    assert np.array_equal(c.mechanism.matrix, np.eye(3))  # the identity: no randomization needed
    assert "every epsilon" in c.reason


def test_product_family_64_groups():
    # Six binary attributes, ε split equally: black_box_bound at the returned ε is the target, above it just after.
    fam = fa.product_family(*[["0", "1"]] * 6)
    for lower, target in ((0.0, 0.5), (0.1, 0.5), (0.3, 1.0)):
        c = calibrate(target, family=fam, utility_class=UtilityClass(lower=lower))
        assert c.groups == 64 and c.feasible and "bracketing" in c.reason
        at = fa.black_box_bound(fam(c.epsilon), utility_class=fa.UtilityClass(lower=lower)).value
        after = fa.black_box_bound(fam(c.epsilon * (1 + 1e-6)), utility_class=fa.UtilityClass(lower=lower)).value
        assert at == pytest.approx(target, rel=1e-9) and at <= target
        assert after > target
        assert c.keep_probability == pytest.approx(keep_probability(c.epsilon / 6, 2) ** 6, rel=1e-12)
    # lower = 0: the worst case is ε(M) itself, so ε = target exactly (proofs/black_box.md).
    assert calibrate(0.5, family=fam).epsilon == pytest.approx(0.5, rel=1e-12)


def test_black_box_with_tau_and_lipschitz_is_non_decreasing_and_meets_the_target():
    # The general class (τ binds, g Lipschitz in the group): solved by the LP; the answer still brackets the target.
    c = calibrate(0.6, family=rr_family(3), utility_class=UtilityClass(tau=0.3, lipschitz=0.05))
    fam = fa.randomized_response_family([0, 1, 2])
    at = fa.black_box_bound(fam(c.epsilon), utility_class=fa.UtilityClass(tau=0.3, lipschitz=0.05)).value
    after = fa.black_box_bound(
        fam(c.epsilon * (1 + 1e-6)), utility_class=fa.UtilityClass(tau=0.3, lipschitz=0.05)
    ).value
    assert at == pytest.approx(0.6, rel=1e-8) and after > 0.6
    values = [
        fa.black_box_bound(fam(e), utility_class=fa.UtilityClass(tau=0.3, lipschitz=0.05)).value
        for e in np.linspace(0, 3, 13)
    ]
    assert all(b >= a - 1e-9 for a, b in zip(values, values[1:]))


def test_black_box_floor_with_lipschitz():
    # L_A > 0: even at ε = 0 a group-dependent g can differ between groups; a target below that is infeasible.
    fam = fa.randomized_response_family([0, 1])
    floor = fa.black_box_bound(fam(0.0), utility_class=fa.UtilityClass(tau=0.5, lipschitz=0.2)).value
    assert floor > 0
    c = calibrate(
        floor / 2, family=rr_family(2), utility_class=UtilityClass(tau=0.5, lipschitz=0.2), method="black_box"
    )
    assert not c.feasible and math.isnan(c.epsilon) and c.bound == pytest.approx(floor)
    assert f"{floor:.6g}" in c.reason


# -- paper and tight: closed forms ---------------------------------------------------------------------


def test_closed_forms_hand_values():
    # target log 3, L_A = 0.2, δ = 0.1, γ = 1, τ = 0.5: c/τ = (0.2 + 0.1)/0.5 = 3/5.
    # paper: ε = log 3 − log(8/5) = log(15/8); tight: ε = log(3 − 3/5) = log(12/5).
    p = calibrate(math.log(3), method="paper", utility_class=UtilityClass(tau=0.5, lipschitz=0.2), delta=0.1)
    t = calibrate(math.log(3), method="tight", utility_class=UtilityClass(tau=0.5, lipschitz=0.2), delta=0.1)
    assert p.epsilon == pytest.approx(math.log(Fraction(15, 8)), rel=1e-13)
    assert t.epsilon == pytest.approx(math.log(Fraction(12, 5)), rel=1e-13)
    # The bounds' definitions at the returned ε give the target back.
    assert p.epsilon + math.log(1 + 0.6) == pytest.approx(math.log(3), rel=1e-13)
    assert math.log(math.exp(t.epsilon) + 0.6) == pytest.approx(math.log(3), rel=1e-13)
    assert p.bound == pytest.approx(math.log(3), rel=1e-13) and t.bound == pytest.approx(math.log(3), rel=1e-13)
    assert p.delta == t.delta == 0.1 and p.keep_probability == pytest.approx(15 / 8 / (15 / 8 + 1), rel=1e-13)


@given(
    target=st.floats(0.0, 5.0),
    tau=st.floats(0.05, 1.0),
    lip=st.floats(0.0, 0.5),
    delta=st.floats(0.0, 0.2),
    gamma=st.sampled_from([1.0, 2.0]),
    k=st.integers(2, 5),
)
def test_closed_forms_reach_the_target_or_report_the_floor(target, tau, lip, delta, gamma, k):
    tau = min(tau, gamma)
    floor = math.log1p((lip + delta * gamma) / tau)
    for method, form in (("paper", fa.main_theorem), ("tight", fa.main_theorem_tight)):
        c = calibrate(
            target,
            method=method,
            family=rr_family(k),
            utility_class=UtilityClass(gamma=gamma, tau=tau, lipschitz=lip),
            delta=delta,
        )
        if target < floor * (1 - 1e-14):  # within a few ulps of the floor either answer is right (calibrate's rule)
            assert not c.feasible and math.isnan(c.epsilon) and math.isnan(c.keep_probability)
            assert c.mechanism is None and c.bound == pytest.approx(floor) and f"{floor:.6g}" in c.reason
            continue
        assert c.feasible and c.epsilon >= 0
        # the theorem's bound at (ε, δ) is the target (ε = 0 only at the floor itself)
        assert form(c.epsilon, delta, gamma=gamma, tau=tau, lipschitz=lip) == pytest.approx(target, rel=1e-9, abs=1e-12)
        # the family's member is pure ε-DP, so the profile-minimised bound on it is at most the target
        b = (fa.paper_bound if method == "paper" else fa.tight_bound)(
            c.mechanism, utility_class=fa.UtilityClass(gamma=gamma, tau=tau, lipschitz=lip)
        )
        assert b.value <= target + 1e-9
        assert c.mechanism.epsilon == pytest.approx(c.epsilon, rel=1e-9, abs=1e-12)


def test_floor_is_infeasible_with_the_value_in_the_reason():
    # L_A = 0.2, τ = 0.5: floor log(1.4) = 0.336472; a target of 0.1 cannot be met by any ε.
    for method in ("paper", "tight"):
        c = calibrate(0.1, method=method, utility_class=UtilityClass(tau=0.5, lipschitz=0.2))
        assert not c.feasible and math.isnan(c.epsilon)
        assert "0.336472" in c.reason and "floor" in c.reason
        assert c.bound == pytest.approx(math.log(1.4), rel=1e-12)
    # exactly at the floor: ε = 0
    assert calibrate(
        math.log(1.4), method="tight", utility_class=UtilityClass(tau=0.5, lipschitz=0.2)
    ).epsilon == pytest.approx(0.0, abs=1e-12)


def test_metric_sets_the_diameter_of_the_closed_forms():
    # d(a, a') = 2: c = L_A·diam = 0.2 · 2; tight ε = log(e − 0.4/0.5).
    c = calibrate(
        1.0,
        method="tight",
        family=rr_family(2),
        utility_class=UtilityClass(tau=0.5, lipschitz=0.2, metric=[[0, 2], [2, 0]]),
    )
    assert c.diameter == 2.0 and c.epsilon == pytest.approx(math.log(math.e - 0.8), rel=1e-13)


@given(target=st.floats(0.0, 4.0), tau=st.floats(0.05, 1.0), lower=st.floats(0.0, 0.9), k=st.integers(2, 6))
@example(target=1e-12, tau=0.5, lower=0.0, k=2)  # a rounding-sized target (found by hypothesis)
def test_black_box_at_least_tight_at_least_paper(target, tau, lower, k):
    # δ = 0, L_A = 0: black_box(ε) ≤ ε(M_ε) = ε = tight form at δ = 0, so the black-box ε is never smaller;
    # tight ≥ paper whenever feasible (e^T − c/τ ≥ e^T/(1 + c/τ) ⟺ e^T ≥ 1 + c/τ). Holds for any τ here.
    eps = {
        m: calibrate(target, method=m, family=rr_family(k), utility_class=UtilityClass(tau=tau, lower=lower)).epsilon
        for m in ("paper", "tight")
    }
    bb = calibrate(target, family=rr_family(k), utility_class=UtilityClass(lower=lower, tau=tau)).epsilon
    # (absolute slack 1e-10: near ε = 0 the RR matrix entries 1/k ± O(ε) carry rounding of order 1e-16 / ε)
    assert bb >= eps["tight"] * (1 - 1e-9) - 1e-10
    assert eps["tight"] >= eps["paper"] * (1 - 1e-12) - 1e-15


@settings(max_examples=8)  # the LP path: a second or so per example
@given(target=st.floats(0.35, 2.0), tau=st.sampled_from([0.2, 0.5]), lip=st.sampled_from([0.05, 0.1]))
def test_black_box_at_least_tight_with_lipschitz(target, tau, lip):
    # L_A > 0: black-box with the same τ and L_A is a maximum over a subclass of the theorem's class, so its
    # bound is at most the tight form at every ε, hence its ε is at least tight's.
    tight = calibrate(target, method="tight", family=rr_family(3), utility_class=UtilityClass(tau=tau, lipschitz=lip))
    assume(tight.feasible)
    bb = calibrate(target, method="black_box", family=rr_family(3), utility_class=UtilityClass(tau=tau, lipschitz=lip))
    assert bb.epsilon >= tight.epsilon * (1 - 1e-9)
    assert calibrate(
        target, method="paper", family=rr_family(3), utility_class=UtilityClass(tau=tau, lipschitz=lip)
    ).epsilon <= tight.epsilon * (1 + 1e-12)


# -- monotonicity along a family: post-processing ---------------------------------------------------------


@given(st.integers(2, 8), st.floats(1e-3, 6.0), st.floats(0.0, 1.0))
def test_smaller_epsilon_is_a_post_processing_of_a_larger_one(k, eps, frac):
    # proofs/calibration.md §3: RR(ε') = RR(ε) then RR(ε'') with e^ε'' = 1 + k a/(1 − a), a = α(ε')/α(ε),
    # α(ε) = (e^ε − 1)/(e^ε + k − 1).
    small = eps * frac
    labels = list(range(k))
    alpha = lambda e: math.expm1(e) / (math.exp(e) + k - 1)  # noqa: E731
    a = alpha(small) / alpha(eps)
    assert 0 <= a <= 1 + 1e-12
    r = fa.from_matrix(a * np.eye(k) + (1 - a) / k, labels) if a < 1 else fa.identity(labels)
    composed = randomized_response(labels, eps).then(r)
    assert np.allclose(composed.matrix, randomized_response(labels, small).matrix, rtol=0, atol=1e-12)
    if a < 1:
        assert r.epsilon == pytest.approx(math.log1p(k * a / (1 - a)), rel=1e-9, abs=1e-12)


def test_black_box_non_decreasing_along_product_family():
    fam = fa.product_family(["x", "y"], ["p", "q", "r"], weights=[2, 1])
    values = [fa.black_box_bound(fam(e), utility_class=fa.UtilityClass(lower=0.1)).value for e in np.linspace(0, 8, 81)]
    assert all(b >= a - 1e-12 for a, b in zip(values, values[1:]))


# -- white-box -------------------------------------------------------------------------------------------


def identity_model(labels):
    """A model that outputs the released group: K[ã, u] = 1{u = ã}, one context."""
    k = len(labels)
    return fa.Kernel(np.eye(k)[None], ["all"], labels, labels)


@pytest.mark.parametrize("k", [2, 3, 5])
@pytest.mark.parametrize("target", [0.0, 0.3, 1.0, 4.0])
def test_white_box_identity_model_has_L_equal_to_epsilon(k, target):
    # E[g | a0] = e^ε/(e^ε + k − 1) (keep); E[g | a] = 1/(e^ε + k − 1); ratio e^ε: L(ε) = ε and ε = target.
    labels = [f"g{i}" for i in range(k)]
    c = calibrate(target, kernel=identity_model(labels), utility=fa.indicator("g0", labels))
    assert c.method == "white_box" and c.feasible
    assert c.epsilon == pytest.approx(target, rel=1e-9, abs=1e-12)
    assert c.bound == pytest.approx(target, rel=1e-9, abs=1e-12) and c.bound <= target + 1e-12  # rounding slack
    g = calibrate(target, kind="global", kernel=identity_model(labels), utility=fa.indicator("g0", labels))
    assert g.epsilon == pytest.approx(target, rel=1e-9, abs=1e-12)


def test_white_box_model_that_never_reaches_the_target():
    # P(u0 | ã) = 0.8 or 0.6: even the unfiltered model has L = log(0.8/0.6) = 0.2877 < 0.5.
    k = fa.Kernel([[[0.8, 0.2], [0.6, 0.4]]], ["all"], ["a", "b"], ["a", "b"])
    c = calibrate(0.5, kernel=k, utility=fa.indicator("a", ["a", "b"]))
    assert math.isinf(c.epsilon) and c.keep_probability == 1.0 and c.bound == pytest.approx(math.log(4 / 3))
    # target 0.2: keep p with (0.6 + 0.2p)/(0.8 − 0.2p) = e^0.2 (by hand), ε = log(p/(1 − p))
    c = calibrate(0.2, kernel=k, utility=fa.indicator("a", ["a", "b"]))
    big_t = math.exp(0.2)
    p = (0.8 * big_t - 0.6) / (0.2 + 0.2 * big_t)
    assert c.epsilon == pytest.approx(math.log(p / (1 - p)), rel=1e-9)


def test_white_box_non_monotone_in_epsilon():
    # g depends on the group: g(·, a) = [1, 0], g(·, b) = [0.7, 0.5]; model outputs Ã. With keep p:
    # E_a = p, E_b = 0.7 − 0.2p, so L = |log(p/(0.7 − 0.2p))|: log 1.2 at ε = 0, 0 at p = 7/12, log 2 at p = 1.
    k = identity_model(["a", "b"])
    g = fa.from_table([[[1.0, 0.0], [0.7, 0.5]]], ["a", "b"], ["all"], ["a", "b"])
    c = calibrate(0.1, kernel=k, utility=g)  # below L(0) = 0.1823: no [0, ε] works ...
    assert not c.feasible and c.bound == pytest.approx(math.log(1.2)) and "depends on the group" in c.reason
    assert "not monotone" in c.reason  # ... although a middle range of ε meets it
    c = calibrate(0.2, kernel=k, utility=g)  # above L(0): the crossing on the rising side
    big_t = math.exp(0.2)
    p = 0.7 * big_t / (1 + 0.2 * big_t)
    assert c.epsilon == pytest.approx(math.log(p / (1 - p)), rel=1e-9)


@settings(max_examples=40)  # each example runs a white-box scan and a black-box calibration
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(2, 4), target=st.floats(0.05, 2.0))
def test_white_box_at_least_black_box(seed, k, target):
    # The black-box certificate bounds every model's L, and is non-decreasing in ε: on [0, ε_bb] any model meets
    # the target, so the white-box ε (largest with all of [0, ε] meeting it) is at least ε_bb.
    rng = np.random.default_rng(seed)
    labels, decisions = list(range(k)), ["u0", "u1", "u2"]
    kernel = fa.Kernel(rng.dirichlet(np.ones(3), size=(2, k)), ["x0", "x1"], labels, decisions)
    g = fa.from_table(rng.choice([0.0, 0.5, 1.0, 2.0], size=3), decisions)
    assume(g.gamma > 0)
    white = calibrate(target, kernel=kernel, utility=g, utility_class=UtilityClass(gamma=g.gamma, lower=g.lower))
    black = calibrate(
        target, family=fa.randomized_response_family(labels), utility_class=UtilityClass(gamma=g.gamma, lower=g.lower)
    )
    assert white.feasible
    assert white.epsilon >= black.epsilon * (1 - 1e-9)


@settings(max_examples=40)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(2, 5))
def test_white_box_non_decreasing_for_randomized_response(seed, k):
    # proofs/calibration.md §4: behind RR, E[g | x, a] is affine in α = (e^ε − 1)/(e^ε + k − 1), so for g
    # independent of the group L is non-decreasing in ε (and the scan's answer is exact).
    rng = np.random.default_rng(seed)
    labels = list(range(k))
    kernel = fa.Kernel(rng.dirichlet(np.ones(2) * 0.5, size=(3, k)), ["x0", "x1", "x2"], labels, ["y", "n"])
    g = fa.indicator("y", ["y", "n"])
    fam = fa.randomized_response_family(labels)
    values = [fa.local_fairness(fa.compose(kernel, fam(e)), g).value for e in np.linspace(0, 10, 41)]
    assert all(b >= a - 1e-12 for a, b in zip(values, values[1:]))


@pytest.mark.slow
@settings(max_examples=40)
@given(seed=st.integers(0, 2**32 - 1), sizes=st.sampled_from([(2, 2), (2, 3), (3, 2), (2, 2, 2)]))
def test_white_box_non_decreasing_for_products(seed, sizes):
    # proofs/calibration.md Proposition 5b: a product with a fixed split is a mixing family (a smaller epsilon is the
    # larger one behind a stochastic R on the true value), so for g free of the group L is non-decreasing in epsilon,
    # and so is L-bar over a population with X and A independent exactly; checked on a grid of random models
    rng = np.random.default_rng(seed)
    alphabets = [[f"v{i}{j}" for j in range(n)] for i, n in enumerate(sizes)]
    fam = fa.product_family(*alphabets, weights=rng.dirichlet(np.ones(len(sizes))))
    groups = fam.inputs
    kernel = fa.Kernel(rng.dirichlet(np.ones(3) * 0.5, size=(2, len(groups))), ["x0", "x1"], groups, ["u0", "u1", "u2"])
    g = fa.from_table(rng.uniform(0, 1, 3), ["u0", "u1", "u2"])
    pop = fa.Population(np.outer([0.25, 0.75], np.full(len(groups), 1 / len(groups))), ["x0", "x1"], groups)
    assert fam.mixing
    grid = np.linspace(0, 12, 25)
    local = [fa.local_fairness(fa.compose(kernel, fam(e)), g).value for e in grid]
    global_ = [fa.global_fairness(fa.compose(kernel, fam(e)), g, pop).value for e in grid]
    for values in (local, global_):
        assert all(b >= a - 1e-12 for a, b in zip(values, values[1:]))


def test_the_white_box_reason_says_what_the_answer_rests_on():
    # a utility free of the group behind a mixing family: the answer rests on Proposition 5b; a utility that depends
    # on the group: on the scan (here L falls, then rises: proofs/calibration.md's example, target 0.2)
    labels = ["a", "b"]
    kernel = fa.Kernel([[[1.0, 0.0], [0.0, 1.0]]], ["x"], labels, ["y", "n"])
    free = calibrate(0.2, kernel=kernel, utility=fa.indicator("y", ["y", "n"]))
    assert free.reason.endswith("(L is non-decreasing in epsilon along the family, for a utility free of the group)")
    depends = fa.Utility([[[1.0, 0.0], [0.7, 0.5]]], ["y", "n"], ["x"], labels)
    scanned = calibrate(0.2, kernel=kernel, utility=depends)
    assert scanned.reason.endswith("(first crossing of a 64-point scan, refined)")
    assert free.epsilon == pytest.approx(0.2, rel=1e-9)  # E[g | a] = p, E[g | b] = 1 - p: L = ln(p / (1 - p)) = epsilon
    p = 0.7 * math.exp(0.2) / (1 + 0.2 * math.exp(0.2))  # p / (0.7 - 0.2 p) = e^0.2, on the rising side
    assert scanned.epsilon == pytest.approx(math.log(p / (1 - p)), rel=1e-9)
    every = calibrate(50.0, kernel=fa.Kernel([[[0.5, 0.5], [0.25, 0.75]]], ["x"], labels, ["y", "n"]),
                      utility=fa.indicator("y", ["y", "n"]))  # fmt: skip
    assert every.epsilon == math.inf
    assert every.reason.endswith(
        "nats and L is non-decreasing in epsilon along the family, for a utility free of the group"
    )


def test_white_box_uses_the_context_mechanism_and_population():
    # Two contexts, population with X and A dependent: L-bar at ε = 0 is not 0, the white-box global result
    # starts there; the local one does not depend on the population's dependence.
    labels = ["a", "b"]
    kernel = fa.Kernel([[[0.9, 0.1], [0.5, 0.5]], [[0.2, 0.8], [0.1, 0.9]]], ["x0", "x1"], labels, ["y", "n"])
    pop = fa.Population([[0.4, 0.1], [0.1, 0.4]], ["x0", "x1"], labels)
    g = fa.indicator("y", ["y", "n"])
    c = calibrate(0.05, kind="global", kernel=kernel, utility=g, population=pop)
    law0 = fa.compose(kernel, fa.randomized_response(labels, 0.0))
    lbar0 = fa.global_fairness(law0, g, pop).value
    assert lbar0 > 0.05 and not c.feasible and c.bound == pytest.approx(lbar0)
    assert "dependent" in c.reason
    mx = fa.from_matrix([[0.8, 0.2], [0.2, 0.8]], ["x0", "x1"])
    c = calibrate(0.3, kernel=kernel, utility=g, population=pop, context_mechanism=mx)
    law = fa.compose(kernel, fa.randomized_response(labels, c.epsilon), mx)
    assert fa.local_fairness(law, g, pop).value == pytest.approx(0.3, rel=1e-9)


def _upper_by_vertices(k, g, m, pop, kind):
    """Upper end of L (L̄) over every utility of the last decision in [min g, max g] per kernel cell, by brute force.

    The ratio of two affine functions of the assignment v is quasilinear, so its maximum over the box is at a
    vertex: every v in {min g, max g}^cells is enumerated, E[g | x, a] formed with numpy (no fairaudit).
    """
    X, At, _ = k.shape
    rest, kd = k[..., :-1] @ g[:-1], k[..., -1]
    v = np.array(list(itertools.product([g.min(), g.max()], repeat=X * At))).reshape(-1, X, At)
    e = np.einsum("ab,vxb->vxa", m, rest + kd * v)  # (vertices, X, A)
    if kind == "global":
        e = np.einsum("xa,vxa->va", pop / pop.sum(0), e)[:, None, :]
    return float(np.log((e.max(-1) / e.min(-1)).max()))


def _rr(k, eps):
    keep = math.exp(eps) / (math.exp(eps) + k - 1)
    return np.where(np.eye(k, dtype=bool), keep, (1 - keep) / (k - 1))


@pytest.mark.parametrize("kind", ["local", "global"])
def test_white_box_on_the_upper_end_of_the_unparsed_range_by_a_grid(kind):
    # proofs/unparsed.md §5. Three groups behind 3-ary RR, two contexts, g = (1, 0.2, unparsed stated 0.5, known
    # within [0.2, 1]). Independent route: the upper end by brute force over the box's vertices on a dense grid of ε
    # (RR's matrix by hand), its first crossing of the target bisected by hand.
    rng = np.random.default_rng(7)
    k = rng.dirichlet(np.ones(3), size=(2, 3))
    pop = np.full((2, 3), 1 / 6)
    g = np.array([1.0, 0.2, 0.5])
    decisions, groups = ["y", "n", "unparsed"], ["a", "b", "c"]
    kernel = fa.Kernel(k, ["x0", "x1"], groups, decisions)
    util = fa.from_table(g, decisions)
    upper = lambda e: _upper_by_vertices(k, g, _rr(3, e), pop, kind)  # noqa: E731
    top = _upper_by_vertices(k, g, np.eye(3), pop, kind)
    for target in (0.3 * top, 0.7 * top):
        grid = np.linspace(0.0, 15.0, 601)
        values = [upper(e) for e in grid]
        first = next(i for i, v in enumerate(values) if v > target)
        lo, hi = grid[first - 1], grid[first]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if upper(mid) <= target else (lo, mid)
        c = calibrate(target, kind=kind, kernel=kernel, utility=util, unparsed_decision=-1)
        stated = calibrate(target, kind=kind, kernel=kernel, utility=util)
        assert c.feasible and c.epsilon == pytest.approx(lo, rel=1e-9)
        assert c.bound == pytest.approx(target, rel=1e-9) and "upper end of L" in c.reason
        assert stated.epsilon > c.epsilon * (1 + 1e-3)  # the stated utility allows more here
        measure = fa.local_fairness if kind == "local" else fa.global_fairness
        assert measure(fa.compose(kernel, fa.randomized_response(groups, c.epsilon)), util).value < target


def test_white_box_on_the_upper_end_without_unparsed_mass_is_the_old_answer():
    rng = np.random.default_rng(8)
    k = np.concatenate([rng.dirichlet(np.ones(2), size=(2, 3)), np.zeros((2, 3, 1))], axis=-1)
    kernel = fa.Kernel(k, ["x0", "x1"], ["a", "b", "c"], ["y", "n", "unparsed"])
    util = fa.from_table([1.0, 0.2, 0.5], ["y", "n", "unparsed"])
    for kind in ("local", "global"):
        for target in (0.05, 0.2):
            old = calibrate(target, kind=kind, kernel=kernel, utility=util)
            new = calibrate(target, kind=kind, kernel=kernel, utility=util, unparsed_decision=-1)
            assert old.feasible and math.isfinite(old.epsilon)
            assert {k: v for k, v in new.to_dict().items() if k != "unparsed"} == old.to_dict()
            assert new.to_dict()["unparsed"] == {"decision": "unparsed", "range": [0.2, 1.0]}  # [min g, max g]


def test_unparsed_decision_is_refused_where_it_means_nothing():
    kernel = fa.Kernel([[[0.5, 0.3, 0.2], [0.3, 0.5, 0.2]]], ["all"], ["a", "b"], ["a", "b", "unparsed"])
    util = fa.indicator("a", ["a", "b", "unparsed"])
    with pytest.raises(fa.InputError, match="unparsed_decision: is for the white_box method"):
        calibrate(0.5, method="black_box", unparsed_decision=-1)
    with pytest.raises(fa.InputError, match="unparsed_decision: must index one of the kernel's 3 decisions"):
        calibrate(0.5, kernel=kernel, utility=util, unparsed_decision=3)


def test_black_box_with_tau_assumes_it_behind_the_calibrated_mechanism():
    # proofs/calibration.md §4: examples/hr_office's model (always HR_2, RR on three binary attributes) meets
    # tau = 0.02 only up to ε = 3 log((1 − 0.02^(1/3)) / 0.02^(1/3)) = 2.96196; black-box with tau allows more than
    # its white-box ε (which is exactly the target: L(ε) = ε), because beyond 2.96 the model leaves the class.
    spec = fa.load_spec(Path(__file__).resolve().parents[2] / "examples" / "hr_office" / "hr_office.toml")
    fam, kernel = spec.sensitive_family, spec.kernel()
    b = calibrate(3.0, family=fam, utility_class=UtilityClass(tau=spec.tau))
    w = calibrate(3.0, family=fam, kernel=kernel, utility=spec.utility)
    assert w.epsilon == pytest.approx(3.0, rel=1e-9) and b.epsilon > w.epsilon
    assert "tau is vouched for" in b.reason
    edge = 3 * math.log((1 - 0.02 ** (1 / 3)) / 0.02 ** (1 / 3))
    min_e = lambda e: fa.expected_utility(fa.compose(kernel, fam(e)), spec.utility).min()  # noqa: E731
    assert min_e(edge) == pytest.approx(0.02, rel=1e-9) and min_e(b.epsilon) < 0.02
    # without tau the black-box class contains this model, and white >= black holds
    assert calibrate(3.0, family=fam).epsilon <= w.epsilon * (1 + 1e-9)


# -- global ----------------------------------------------------------------------------------------------


def test_global_needs_independence_for_certificates():
    dep = fa.Population([[0.4, 0.1], [0.1, 0.4]], ["x0", "x1"], [0, 1])
    ind = fa.Population.uniform(["x0", "x1"], [0, 1])
    for method, extra in (
        ("black_box", {}),
        ("tight", {"utility_class": UtilityClass(tau=0.2)}),
        ("paper", {"utility_class": UtilityClass(tau=0.2)}),
    ):
        c = calibrate(0.5, kind="global", method=method, family=rr_family(2), population=dep, **extra)
        assert not c.feasible and "not independent" in c.reason
        if method == "black_box":
            # exact on L-bar for any population; its floor at epsilon = 0, by hand: the model sees only x, and
            # P(x | a0) = (0.8, 0.2), P(x | a1) = (0.2, 0.8), so g = 1 on x0 only gives 0.8 / 0.2 = 4
            assert c.bound == pytest.approx(math.log(4), rel=1e-9) and "below the floor" in c.reason
        else:  # L-bar <= L needs X independent of A
            assert math.isinf(c.bound) and "use black_box" in c.reason
        ok = calibrate(0.5, kind="global", method=method, family=rr_family(2), population=ind, **extra)
        assert ok.feasible and ok.epsilon == pytest.approx(0.5) and ok.kind == "global"


def test_global_within_rounding_holds_l_to_the_target_less_ln_f():
    # P(x) P(a) in floats is independent only within rounding: L-bar <= L + ln F with F = max r / min r,
    # r = P(x, a) / (P(x) P(a)) (1 + 1.16e-16 here); every method below has L <= epsilon, so the largest epsilon
    # is 0.5 - ln F and the certificate on L-bar is epsilon + ln F, both checked at 50 digits
    table = np.outer([0.25, 0.75], [0.0, 0.4, 0.6])
    within = fa.Population(table, ["x0", "x1"], [0, 1, 2])
    exact = [[Fraction(v) for v in row] for row in table]
    p_x, p_a = [sum(row) for row in exact], [sum(col) for col in zip(*exact)]
    r = [exact[x][a] / (p_x[x] * p_a[a]) for x in range(2) for a in (1, 2)]
    mpmath.mp.dps = 50
    ln_f = mpmath.log(mpmath.mpf(max(r).numerator) / max(r).denominator * min(r).denominator / min(r).numerator)
    assert 1e-16 < ln_f < 2e-16
    for method, extra in (("black_box", {}), ("tight", {"utility_class": UtilityClass(tau=0.2)})):
        c = calibrate(0.5, kind="global", method=method, family=rr_family(3), population=within, **extra)
        assert c.feasible and c.target == 0.5 and "independent only within rounding" in c.reason
        # (F is rounded up as a float, 1 + 2.2e-15: epsilon loses about 20 ulps, a lower end all the same)
        assert mpmath.mpf(c.epsilon) + ln_f <= 0.5 < mpmath.mpf(c.epsilon) + ln_f + 1e-14
        assert mpmath.mpf(c.epsilon) + ln_f <= c.bound <= 0.5 + 2**-53  # (the sum rounded up: an ulp above)
        independent = calibrate(0.5, kind="global", method=method, family=rr_family(3), population=fa.Population.uniform(
            ["x0", "x1"], [0, 1, 2]), **extra)  # fmt: skip
        assert independent.epsilon == 0.5 and "within rounding" not in independent.reason


# -- defaults, wrapper and errors --------------------------------------------------------------------------


def test_default_method():
    k = identity_model(["a", "b"])
    assert calibrate(0.5).method == "black_box"
    assert calibrate(0.5, kernel=k, utility=fa.indicator("a", ["a", "b"])).method == "white_box"
    assert calibrate(0.5, utility_class=UtilityClass(tau=0.5), delta=0.01).method == "tight"
    assert calibrate(0.5, family=fa.randomized_response_family(["x", "y", "z"])).groups == 3


def test_calibrate_takes_at_most_12_parameters():
    """Issue 81, item 5: no ``groups``; the family says what it only chose (randomized response on k groups)."""
    parameters = inspect.signature(fa.calibrate).parameters
    assert len(parameters) <= 12 and "groups" not in parameters and "family" in parameters


@pytest.mark.parametrize("method", ["black_box", "tight", "paper"])
def test_a_randomized_response_family_is_the_wrapper_on_k_groups(method):
    cls = fa.UtilityClass(tau=0.5, lower=0.1) if method != "black_box" else fa.UtilityClass(lower=0.1)
    by_family = calibrate(0.8, method=method, family=fa.randomized_response_family([0, 1, 2]), utility_class=cls)
    by_wrapper = fa.calibrate_randomized_response(0.8, 3, method=method, utility_class=cls)
    assert by_family.epsilon == by_wrapper.epsilon and by_family.to_dict() == by_wrapper.to_dict()
    assert by_family.groups == 3 and by_family.family == "3-ary randomized response"
    # by hand, tight: ε = log(e^0.8 − δγ/τ − L_A·diam/τ) with δ = 0, L_A = 0: the target itself
    if method != "black_box":
        assert by_family.epsilon == pytest.approx(0.8, rel=1e-12)


def test_the_default_family_is_randomized_response_on_the_kernels_groups_else_on_two():
    assert calibrate(0.5).family == "2-ary randomized response" and calibrate(0.5).groups == 2
    kernel = identity_model(["a", "b", "c"])
    c = calibrate(0.5, kernel=kernel, utility=fa.indicator("a", ["a", "b", "c"]))
    assert (c.family, c.groups, c.mechanism.inputs) == ("3-ary randomized response", 3, ("a", "b", "c"))


def test_the_wrapper_checks_its_groups():
    for groups, problem in (
        (1, "randomized response needs at least 2 groups (got 1)"),
        (["only"], "randomized response needs at least 2 groups (got 1)"),
        ("ab", "must be a number of groups k >= 2 or a list of group labels (got 'ab')"),
        (True, "must be a number of groups k >= 2 or a list of group labels (got True)"),
    ):
        with pytest.raises(fa.InputError) as err:
            fa.calibrate_randomized_response(0.5, groups)
        assert str(err.value) == f"groups: {problem}"
    assert fa.calibrate_randomized_response(0.5, ["x", "y", "z"]).mechanism.inputs == ("x", "y", "z")


def test_wrapper_is_calibrate_and_raises_when_infeasible():
    c = fa.calibrate_randomized_response(0.7, 3, method="tight", utility_class=fa.UtilityClass(tau=0.05))
    assert isinstance(c, Calibration) and c.epsilon == pytest.approx(0.7, rel=1e-12)
    with pytest.raises(fa.InputError, match=r"^target: .*below the floor.*0\.336472"):
        fa.calibrate_randomized_response(0.1, 2, method="tight", utility_class=fa.UtilityClass(tau=0.5, lipschitz=0.2))


@pytest.mark.parametrize(
    "kwargs,flag",
    [
        ({"target": -0.1}, "target"),
        ({"target": math.inf}, "target"),
        ({"target": "x"}, "target"),
        ({"method": "exact"}, "method"),
        ({"family": 3}, "family"),
        ({"family": MechanismFamily("one group", (0,), lambda e: fa.identity([0]), lambda e: 1.0)}, "family"),
        ({"method": "paper", "lipschitz": 0.2}, "tau"),  # (without L_A or delta no tau is needed: epsilon = target)
        ({"method": "tight", "delta": 0.1}, "tau"),
        ({"tau": 0.0}, "tau"),
        ({"tau": 2.0}, "tau"),
        ({"lower": 2.0}, "lower"),
        ({"lower": -0.1}, "lower"),
        ({"gamma": 0.0}, "gamma"),
        ({"lipschitz": -1.0}, "lipschitz"),
        ({"delta": 1.5, "tau": 0.5}, "delta"),
        ({"delta": 0.1, "method": "black_box"}, "delta"),
        ({"method": "white_box"}, "kernel"),
        ({"kind": "both"}, "kind"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, flag):
    kwargs = {"target": 0.5, **kwargs}
    bundle = {k: kwargs.pop(k) for k in ("gamma", "lower", "tau", "lipschitz") if k in kwargs}
    with pytest.raises(fa.InputError) as err:  # (the class refuses a negative number, calibrate the rest)
        calibrate(kwargs.pop("target"), utility_class=fa.UtilityClass(**bundle), **kwargs)
    assert err.value.field == flag


@pytest.mark.parametrize(("target", "lower"), [(710.0, 1e-310), (710.0, 1e-320), (730.5, 1e-320), (740.0, 1e-300)])
def test_calibration_above_the_floats_e_epsilon_meets_its_target_to_1e_9(target, lower):
    # lower/gamma = r tiny: the black box of binary randomized response is ln((r + (1 - r) p)/(r + (1 - r) q)), by
    # mpmath at 80 digits. Above ln(max float) its closed form took p = 1, q = 0 (ln 1/r: 713.8 at r = 1e-310, above a
    # target of 710, which the calibrated epsilon then missed); now at the 50-digit end of e^epsilon
    from fairaudit.worstcase.calibration_methods import rr_black_box_epsilon
    from fairaudit.worstcase.randomized_response import rr_class_value

    eps = rr_black_box_epsilon(target, 2, lower, 1.0)
    value = rr_class_value(randomized_response(["a", "b"], eps).rr, lower, 1.0, None, 0.0, 1.0)
    with mpmath.workdps(80):
        r = mpmath.mpf(lower)
        if math.isinf(eps):  # the identity (p = 1, q = 0) meets it: ln(1/r) <= target
            assert r * mpmath.exp(target) >= 1 and value == pytest.approx(float(-mpmath.log(r)), rel=1e-15)
            return
        t = mpmath.exp(mpmath.mpf(eps))
        p, q = t / (t + 1), 1 / (t + 1)
        exact = mpmath.log((r + (1 - r) * p) / (r + (1 - r) * q))
        assert exact <= value <= target  # certified above the exact value, and meeting the target
        assert target - exact <= 1e-9 * target  # the largest epsilon, to 1e-9


@pytest.mark.parametrize("crossing", [0.0, 0.3, 2.5, 9.99])
def test_a_monotone_scan_finds_the_first_crossing_by_bisection(crossing):
    # a non-decreasing value with its first crossing anywhere on the 64-point grid: bisection over the grid's points
    # gives what the point-by-point scan gives (the second route), from about log2(64) = 6 points, not up to 64
    from fairaudit.worstcase.calibration_methods import _scan

    grid = np.linspace(0.0, 10.0, 64)
    calls: list[float] = []

    def value(eps: float) -> float:
        calls.append(eps)
        return 0.0 if eps <= crossing else 1.0 + eps

    scanned = _scan(0.5, 0.5, grid, value, 0.0, "L", monotone=False)
    scan_calls = len(calls)
    calls.clear()
    bisected = _scan(0.5, 0.5, grid, value, 0.0, "L", monotone=True)
    assert (bisected.epsilon, bisected.bound) == (scanned.epsilon, scanned.bound)
    first = int(np.argmax(grid > crossing))  # the grid's first point above the crossing
    refine = scan_calls - first  # the refinement's evaluations, the same after either route
    assert len(calls) - refine == 6 and abs(bisected.epsilon - crossing) <= 1e-9 * max(1.0, crossing)


def test_the_white_box_grid_is_made_once_per_family():
    # certify calibrates L and L-bar along one family: its grid (2,500 evaluations of the keep probability) is kept,
    # read-only, for the second; the grid itself is the one made afresh (a second route: the function uncached)
    from fairaudit.worstcase.calibration_search import keep_grid

    family = fa.randomized_response_family(["a", "b", "c"])
    grid = keep_grid(family)
    assert keep_grid(family) is grid and not grid.flags.writeable
    np.testing.assert_array_equal(grid, keep_grid.__wrapped__(family))
    assert len(grid) == 64 and grid[0] == 0.0 and np.all(np.diff(grid) > 0)
