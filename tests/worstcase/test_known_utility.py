"""General worst cases: τ-constrained and Lipschitz class certificates, the worst decision model for a known
utility, and the worst-case utility of a known law.

Expected values come from routes that share no code with fairaudit.worstcase: hand calculations with exact
fractions, Dinkelbach's method with each step a HiGHS LP (scipy), brute force over deterministic kernels (the
vertices of the kernel polytope), Lemma 1's sup, and audits of the returned worst models.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import linprog

import fairaudit as fa
from fairaudit import UtilityClass
from fairaudit.metrics.fairness import global_fairness, local_fairness
from fairaudit.metrics.sup_fairness import sup_global_fairness, sup_local_fairness
from fairaudit.worstcase.black_box import black_box_bound
from fairaudit.worstcase.known_law import worst_utility
from fairaudit.worstcase.known_utility import worst_model


def dinkelbach(p, q, bounds, a_ub=None, b_ub=None, a_eq=None, b_eq=None):
    """max p·h / q·h by Dinkelbach's iterations, each a HiGHS LP: an independent second algorithm."""
    lam = 0.0
    for _ in range(200):
        res = linprog(-(p - lam * q), A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method="highs")
        assert res.status == 0, res.message
        h = res.x
        new = (p @ h) / (q @ h)
        if abs(new - lam) <= 1e-12 * max(1.0, new):
            return new
        lam = new
    return lam


def class_value(matrix, lower, gamma, tau):
    """Exact max over pairs of the τ-constrained class program, L_A = 0 (Dinkelbach + HiGHS)."""
    n, m = matrix.shape
    best = 1.0
    for a, b in itertools.permutations(range(n), 2):
        best = max(best, dinkelbach(matrix[a], matrix[b], [(lower, gamma)] * m, -matrix, -tau * np.ones(n)))
    return best


def random_mechanism(rng, n=None, m=None):
    n = int(rng.integers(2, 5)) if n is None else n
    m = int(rng.integers(2, 6)) if m is None else m
    matrix = rng.dirichlet(np.full(m, float(rng.choice([0.5, 1.0, 3.0]))), size=n)
    return fa.from_matrix(matrix, list(range(n)), [f"o{j}" for j in range(m)])


# ------------------------------------------------------------------------------------------ class certificate
def test_tau_hand_example_in_fractions():
    # Binary RR keep 0.7, g in [0, 1], tau = 1/2. For (a, b): max (0.7 h1 + 0.3 h2)/(0.3 h1 + 0.7 h2) with
    # 0.3 h1 + 0.7 h2 >= 1/2: h1 = 1 and h2 = (1/2 - 3/10) / (7/10) = 2/7, ratio (7/10 + 3/10 * 2/7) / (1/2) = 11/7.
    h2 = (Fraction(1, 2) - Fraction(3, 10)) / Fraction(7, 10)
    ratio = (Fraction(7, 10) + Fraction(3, 10) * h2) / Fraction(1, 2)
    assert ratio == Fraction(11, 7)
    m = fa.randomized_response(["a", "b"], keep=0.7)
    c = black_box_bound(m, utility_class=UtilityClass(tau=0.5))
    assert c.ratio == pytest.approx(float(ratio), rel=1e-14)
    assert c.utility_by_release == pytest.approx([1.0, 2 / 7], rel=1e-14)
    # smaller than the box certificate (7/3) and than the tight bound min_t t + delta(t)/tau = 1 + 0.4/0.5 = 1.8
    assert c.ratio < 1.8 < 7 / 3
    assert fa.tight_bound(m, utility_class=fa.UtilityClass(tau=0.5, gamma=1.0)).value == pytest.approx(
        math.log(1.8), rel=1e-12
    )
    lp = black_box_bound(m, utility_class=UtilityClass(tau=0.5), method="lp")
    assert lp.method == "lp" and lp.ratio == pytest.approx(11 / 7, rel=1e-8)


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.1, 0.3]), st.floats(0.05, 1.0))
def test_tau_class_equals_dinkelbach_and_forced_lp(seed, lower, tau_share):
    rng = np.random.default_rng(seed)
    mech = random_mechanism(rng)
    tau = lower + tau_share * (1.0 - lower)
    want = class_value(mech.matrix, lower, 1.0, tau)
    auto = black_box_bound(mech, utility_class=UtilityClass(lower=lower, tau=tau))
    lp = black_box_bound(mech, utility_class=UtilityClass(lower=lower, tau=tau), method="lp")
    assert auto.ratio == pytest.approx(want, rel=1e-7)
    smallest = min(sum((Fraction(v) for v in row), Fraction(0)) for row in mech.matrix)
    if Fraction(tau) > smallest:  # τ = γ = 1 over rows whose floats sum below 1: no h <= 1 meets the floors exactly
        assert (lp.status, math.isnan(lp.ratio)) == ("infeasible", True) and "inconsistent" in lp.reason
        return
    assert lp.ratio == pytest.approx(want, rel=1e-7)
    # the point found is feasible and attains the value
    h = auto.utility_by_release
    assert np.all(mech.matrix @ h >= tau - 1e-9) and np.all((h >= lower - 1e-12) & (h <= 1 + 1e-12))
    a, b = mech.inputs.index(auto.group), mech.inputs.index(auto.other_group)
    assert (mech.matrix[a] @ h) / (mech.matrix[b] @ h) == pytest.approx(auto.ratio, rel=1e-9)


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.floats(0.05, 0.9), st.sampled_from([0.0, 0.2, 1.0]))
def test_ordering_observed_black_box_tight_paper(seed, tau_share, lip):
    # Any kernel behind M_A whose law meets E[g | x, a] >= tau: observed L <= black-box <= tight <= paper.
    rng = np.random.default_rng(seed)
    mech = random_mechanism(rng)
    n, m = mech.matrix.shape
    n_u = 3
    if lip > 0:  # a utility that depends on the group, within L_A = lip under the discrete metric
        base = rng.uniform(0, 1, n_u)
        g = np.clip(base[None, :] + rng.uniform(-lip / 2, lip / 2, (n, n_u)), 0, 1)[None]
        util = fa.Utility(g, list(range(n_u)), ["x"], mech.inputs)
    else:
        util = fa.Utility(rng.uniform(0, 1, n_u), list(range(n_u)))
    kernel = fa.Kernel(rng.dirichlet(np.ones(n_u), size=(1, m)), ["x"], mech.outputs, list(range(n_u)))
    law = fa.compose(kernel, mech)
    e = fa.expected_utility(law, util)
    tau = float(e.min()) * tau_share
    if tau <= 0:
        return
    lip_used = util.lipschitz() if lip > 0 else 0.0
    observed = local_fairness(law, util).value
    bb = black_box_bound(mech, utility_class=UtilityClass(lower=0.0, gamma=1.0, tau=tau, lipschitz=lip_used))
    tight = fa.tight_bound(mech, utility_class=fa.UtilityClass(tau=tau, gamma=1.0, lipschitz=lip_used))
    paper = fa.paper_bound(mech, utility_class=fa.UtilityClass(tau=tau, gamma=1.0, lipschitz=lip_used, diameter=1.0))
    assert observed <= bb.value + 1e-7
    assert bb.value <= tight.value + 1e-7
    assert tight.value <= paper.value + 1e-12


def test_lipschitz_class_equals_dinkelbach():
    rng = np.random.default_rng(7)
    for _ in range(8):
        mech = random_mechanism(rng, n=3, m=3)
        M = mech.matrix
        n, m = M.shape
        lip, tau = 0.2, 0.3
        # variables h[b, o], row-major; |h[b] - h[c]| <= lip (discrete metric); M[b]·h[b] >= tau
        rows, rhs = [], []
        for b, c in itertools.combinations(range(n), 2):
            for o in range(m):
                r = np.zeros(n * m)
                r[b * m + o], r[c * m + o] = 1, -1
                rows += [r, -r]
                rhs += [lip, lip]
        for b in range(n):
            r = np.zeros(n * m)
            r[b * m : (b + 1) * m] = -M[b]
            rows.append(r)
            rhs.append(-tau)
        best = 1.0
        for a, b in itertools.permutations(range(n), 2):
            p, q = np.zeros(n * m), np.zeros(n * m)
            p[a * m : (a + 1) * m], q[b * m : (b + 1) * m] = M[a], M[b]
            best = max(best, dinkelbach(p, q, [(0, 1)] * (n * m), np.array(rows), np.array(rhs)))
        got = black_box_bound(mech, utility_class=UtilityClass(tau=tau, lipschitz=lip))
        assert got.method == "lp" and got.utility_by_release.shape == (n, m)
        assert got.ratio == pytest.approx(best, rel=1e-7)


def test_lipschitz_without_tau_is_unbounded_with_a_reason():
    m = fa.randomized_response(["a", "b"], keep=0.7)
    c = black_box_bound(
        m, utility_class=UtilityClass(lipschitz=0.1)
    )  # g(u, b) = 0 and g(u, a) = 0.1: ratio 0.1 * ... / 0 = inf
    assert c.value == math.inf and c.status == "unbounded" and c.reason


def test_tau_above_gamma_is_an_error():
    m = fa.randomized_response(["a", "b"], keep=0.7)
    with pytest.raises(fa.InputError, match="^tau:.*exceeds gamma"):
        black_box_bound(m, utility_class=UtilityClass(tau=1.5))
    with pytest.raises(fa.InputError, match="^method:"):
        black_box_bound(m, utility_class=UtilityClass(tau=0.5), method="threshold")


def test_64_groups_with_tau_needs_few_programs():
    # Six binary attributes behind randomized response (a product): the relaxation decides all but a few pairs.
    fam = fa.product_family(*[[0, 1]] * 6)
    mech = fam(3.0)
    c = black_box_bound(mech, utility_class=UtilityClass(tau=0.3))
    assert c.programs_solved <= 5
    # cross-check against the LP on the maximising pair (Dinkelbach + HiGHS)
    a, b = mech.inputs.index(c.group), mech.inputs.index(c.other_group)
    M = mech.matrix
    want = dinkelbach(M[a], M[b], [(0, 1)] * 64, -M, -0.3 * np.ones(64))
    assert c.ratio == pytest.approx(want, rel=1e-7)
    assert c.value <= fa.tight_bound(mech, utility_class=fa.UtilityClass(tau=0.3, gamma=1.0)).value + 1e-9


def test_worst_model_of_class_certificate_attains_it():
    m = fa.randomized_response(list("abc"), epsilon=1.0)
    c = black_box_bound(m, utility_class=UtilityClass(lower=0.1, tau=0.4))
    kernel, util = c.worst_model()
    law = fa.compose(kernel, m)
    assert local_fairness(law, util).ratio == pytest.approx(c.ratio, rel=1e-9)
    assert fa.expected_utility(law, util).min() >= 0.4 - 1e-9


# ------------------------------------------------------------------------------------------ worst model
def deterministic_kernels(n_ctx, n_rel, n_u):
    for choice in itertools.product(range(n_u), repeat=n_ctx * n_rel):
        k = np.zeros((n_ctx, n_rel, n_u))
        for i, u in enumerate(choice):
            k[i // n_rel, i % n_rel, u] = 1.0
        yield k


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_worst_model_equals_brute_force_over_deterministic_kernels(seed):
    # Without τ the program's polytope is a product of simplices: its vertices are the deterministic kernels.
    rng = np.random.default_rng(seed)
    n_a, n_x, n_u = 2, 2, 2 + seed % 2
    ma = fa.from_matrix(rng.dirichlet(np.ones(3), size=n_a), ["A", "B"], ["r0", "r1", "r2"])
    mx = fa.from_matrix(rng.dirichlet(np.ones(n_x) * 2, size=n_x), ["x0", "x1"])
    g = rng.uniform(0, 1, (n_x, n_a, n_u)) if seed % 2 else np.repeat(rng.uniform(0, 1, (n_x, 1, n_u)), n_a, 1)
    util = fa.Utility(g, list(range(n_u)), ["x0", "x1"], ["A", "B"])
    pop = fa.Population(rng.dirichlet(np.ones(4)).reshape(2, 2), ["x0", "x1"], ["A", "B"])
    best_l = best_g = -math.inf
    for k in deterministic_kernels(n_x, 3, n_u):
        law = fa.compose(fa.Kernel(k, ["x0", "x1"], ["r0", "r1", "r2"], list(range(n_u))), ma, mx)
        best_l = max(best_l, local_fairness(law, util, pop).value)
        best_g = max(best_g, global_fairness(law, util, pop).value)
    w = worst_model(ma, util, context_mechanism=mx, population=pop)
    assert w.local_fairness.value == pytest.approx(best_l, rel=1e-7, abs=1e-9)
    assert w.global_fairness.value == pytest.approx(best_g, rel=1e-7, abs=1e-9)


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.sampled_from(["u", "ux", "uxa"]), st.floats(0.1, 0.6), st.booleans())
def test_worst_model_audits_to_its_value_and_meets_tau(seed, kind, tau, dependent):
    rng = np.random.default_rng(seed)
    n_a, n_r, n_x, n_u = int(rng.integers(2, 4)), int(rng.integers(2, 4)), int(rng.integers(1, 3)), 3
    ma = fa.from_matrix(rng.dirichlet(np.ones(n_r), size=n_a), list(range(n_a)), [f"r{i}" for i in range(n_r)])
    ctx = [f"x{i}" for i in range(n_x)]
    mx = fa.from_matrix(rng.dirichlet(np.ones(n_x) * 2, size=n_x), ctx)
    if kind == "u":
        util = fa.Utility(rng.uniform(0, 1, n_u), list(range(n_u)))
    elif kind == "ux":
        util = fa.Utility(np.repeat(rng.uniform(0, 1, (n_x, 1, n_u)), n_a, 1), list(range(n_u)), ctx, list(range(n_a)))
    else:
        util = fa.Utility(rng.uniform(0, 1, (n_x, n_a, n_u)), list(range(n_u)), ctx, list(range(n_a)))
    pop = (
        fa.Population(rng.dirichlet(np.ones(n_x * n_a)).reshape(n_x, n_a), ctx, list(range(n_a))) if dependent else None
    )
    auto = worst_model(ma, util, context_mechanism=mx, population=pop, tau=tau)
    lp = worst_model(ma, util, context_mechanism=mx, population=pop, tau=tau, method="lp")
    for a, b in ((auto.local_fairness, lp.local_fairness), (auto.global_fairness, lp.global_fairness)):
        if math.isnan(b.value):
            assert math.isnan(a.value) and a.status == "infeasible" and "tau" in a.reason
            continue
        assert a.value == pytest.approx(b.value, rel=1e-6, abs=1e-9)
        law = fa.compose(a.kernel, ma, mx)
        audited = (local_fairness if a.kind == "local" else global_fairness)(law, util, pop).value
        assert audited == pytest.approx(a.value, rel=1e-6, abs=1e-9)
        live = (pop.p_context > 0) if pop is not None else np.ones(n_x, bool)
        assert fa.expected_utility(law, util)[live].min() >= tau - 1e-7


def test_worst_model_infeasible_tau_says_why():
    m = fa.randomized_response(["a", "b"], keep=0.7)
    util = fa.Utility([0.2, 0.1], ["u0", "u1"])  # E[g | x, a] <= 0.2 < tau
    w = worst_model(m, util, tau=0.5)
    assert (
        math.isnan(w.local_fairness.value)
        and w.local_fairness.status == "infeasible"
        and "tau" in w.local_fairness.reason
    )


def test_worst_model_hr_office_hand_example():
    # Always-HR_2-like worst model behind binary RR keep 0.7: chosen iff released Mary, L = ln(7/3).
    m = fa.randomized_response(["Tom", "Mary"], keep=0.7)
    w = worst_model(m, fa.indicator("chosen", ["chosen", "not chosen"]))
    assert w.local_fairness.ratio == pytest.approx(7 / 3, rel=1e-12)
    assert w.global_fairness.ratio == pytest.approx(7 / 3, rel=1e-12)
    assert w.local_fairness.kernel.probabilities[0, :, 0].tolist() in ([1.0, 0.0], [0.0, 1.0])


# ------------------------------------------------------------------------------------------ worst utility
@pytest.mark.slow
@given(st.integers(0, 2**32 - 1))
def test_worst_utility_without_constraints_is_lemma_1(seed):
    rng = np.random.default_rng(seed)
    n_x, n_a, n_u = int(rng.integers(1, 4)), int(rng.integers(2, 5)), int(rng.integers(2, 6))
    law = fa.Law(
        rng.dirichlet(np.ones(n_u) * 0.7, size=(n_x, n_a)), list(range(n_x)), list(range(n_a)), list(range(n_u))
    )
    w = worst_utility(law)
    assert w.local_fairness.value == pytest.approx(sup_local_fairness(law).value, rel=1e-12)
    assert w.global_fairness.value == pytest.approx(sup_global_fairness(law).value, rel=1e-12)
    # the returned utility attains it
    assert local_fairness(law, w.local_fairness.utility).value == pytest.approx(w.local_fairness.value, rel=1e-12)


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.floats(0.05, 0.7), st.sampled_from([0.0, 0.1]))
def test_worst_utility_with_tau_equals_dinkelbach(seed, tau, lower):
    rng = np.random.default_rng(seed)
    n_x, n_a, n_u = int(rng.integers(1, 3)), int(rng.integers(2, 4)), int(rng.integers(2, 5))
    q = rng.dirichlet(np.ones(n_u), size=(n_x, n_a))
    law = fa.Law(q, list(range(n_x)), list(range(n_a)), list(range(n_u)))
    rows = q.reshape(-1, n_u)
    best = 1.0
    for x in range(n_x):
        for a, b in itertools.permutations(range(n_a), 2):
            best = max(best, dinkelbach(q[x, a], q[x, b], [(lower, 1.0)] * n_u, -rows, -tau * np.ones(len(rows))))
    w = worst_utility(law, utility_class=UtilityClass(lower=lower, tau=tau))
    assert w.local_fairness.ratio == pytest.approx(best, rel=1e-7)
    g = w.local_fairness.utility
    assert fa.expected_utility(law, g).min() >= tau - 1e-9
    assert local_fairness(law, g).ratio == pytest.approx(best, rel=1e-7)


def test_worst_utility_hand_example():
    law = fa.Law([[[0.5, 0.3, 0.2], [0.2, 0.3, 0.5]]], ["x"], ["a", "b"], ["hire", "wait", "reject"])
    w = worst_utility(law, utility_class=UtilityClass(lower=0.5))
    # threshold keeps "hire" only: (0.5 + 0.5*0.5) / (0.5 + 0.5*0.2) = 0.75 / 0.6 = 5/4
    assert w.local_fairness.ratio == pytest.approx(float(Fraction(3, 4) / Fraction(3, 5)), rel=1e-14)
    assert w.local_fairness.utility.values.tolist() == [1.0, 0.5, 0.5]
    assert (w.local_fairness.group, w.local_fairness.other_group, w.local_fairness.context) == ("a", "b", "x")


def test_worst_model_with_a_group_that_never_gains_is_infinite():
    # g(u, x, b) = 0 for every decision: E[g | x, b] = 0 for every model, E[g | x, a] > 0 for some: c/0 = +inf
    m = fa.randomized_response(["a", "b"], keep=0.7)
    util = fa.Utility([[[1.0, 0.0], [0.0, 0.0]]], ["u0", "u1"], ["x"], ["a", "b"])
    w = worst_model(m, util)
    assert w.local_fairness.value == math.inf and (w.local_fairness.group, w.local_fairness.other_group) == ("a", "b")
    assert w.global_fairness.value == math.inf


def test_class_certificate_is_scale_free():
    m = fa.randomized_response(["a", "b"], keep=0.7)
    big = black_box_bound(m, utility_class=UtilityClass(gamma=1e13, tau=5e12), method="lp")
    assert big.ratio == pytest.approx(11 / 7, rel=1e-8) and big.tau == 5e12 and big.gamma == 1e13
    assert big.utility_by_release == pytest.approx([1e13, 1e13 * 2 / 7], rel=1e-7)


@pytest.mark.parametrize(
    "mechanism",
    [
        fa.randomized_response(["a", "b"], epsilon=30.0),
        fa.randomized_response(["a", "b"], epsilon=720.0),  # e^epsilon beyond the floats: its 50-digit ends
        fa.from_matrix([[1 - 2.0**-40, 2.0**-40], [2.0**-40, 1 - 2.0**-40]], ["a", "b"]),  # exact rows, sum 1
    ],
    ids=["randomized response", "randomized response at 720 nats", "matrix"],
)
def test_a_floor_on_a_face_is_solved_on_exact_coefficients(mechanism):
    # g(·, a) = (0, 0.2) and tau = 0.2: E[g | a] >= 0.2 holds only where both released rows take "d1" (by hand), and
    # then E[g | b] = 0.2 too: the worst case is 0 exactly. The rounded coefficients made the face a slab q^-1 ulps
    # wide, and the value 0.0301 nats (randomized response) or 0.0022 (the matrix)
    util = fa.Utility(np.array([[[0.0, 0.2], [2.0, 0.2]]]), ["d0", "d1"], ["all"], ["a", "b"])
    w = worst_model(mechanism, util, tau=0.2)
    for case in (w.local_fairness, w.global_fairness):
        assert case.certified and 0.0 <= case.value <= 1e-15, case
        assert case.witness == 0.0
    assert w.local_fairness.kernel.probabilities[0, :, 1].tolist() == [1.0, 1.0]


def test_behind_the_identity_on_contexts_the_exact_program_is_a_product_of_the_contexts(monkeypatch):
    # the face of the test above in three contexts: 12 variables, beyond a crossover size shrunk to 8, but each
    # context's block (4 variables, 6 rows) within it: solved exactly over the product, 0 (by hand, as above)
    from fairaudit.worstcase import known_utility_exact

    monkeypatch.setattr(known_utility_exact, "CROSSOVER_SIZE", (8, 16))
    util = fa.Utility(np.array([[[0.0, 0.2], [2.0, 0.2]]] * 3), ["d0", "d1"], ["x0", "x1", "x2"], ["a", "b"])
    w = worst_model(fa.randomized_response(["a", "b"], epsilon=30.0), util, tau=0.2)
    for case in (w.local_fairness, w.global_fairness):
        assert case.certified and 0.0 <= case.value <= 1e-15 and case.witness == 0.0, case
    assert w.local_fairness.kernel.probabilities[:, :, 1].tolist() == [[1.0, 1.0]] * 3
    monkeypatch.setattr(known_utility_exact, "CROSSOVER_SIZE", (3, 16))  # a block beyond it: the slab's upper bound
    w = worst_model(fa.randomized_response(["a", "b"], epsilon=30.0), util, tau=0.2)
    assert w.local_fairness.value > 1e-3 and not w.local_fairness.settled


def test_over_the_model_s_table_the_search_orders_by_the_one_floor_relaxation():
    # two binary randomized responses keeping 0.7 (4 groups), g by group (g(chosen, a) from 0.6 to 1, 0 otherwise),
    # tau = 0.1: the programs over the model's table, ordered by their one-floor relaxations (exact bounds, rounded
    # up), need one LP each for L and L-bar; forcing the LP on every program gives the same values
    rng = np.random.default_rng(3)
    mech = fa.product_family(*[[0, 1]] * 2)(2 * math.log(7 / 3))
    g = np.zeros((1, 4, 2))
    g[0, :, 0] = np.round(rng.uniform(0.6, 1.0, 4), 2)
    util = fa.Utility(g, ["chosen", "not chosen"], ["all"], mech.inputs)
    found, every = worst_model(mech, util, tau=0.1), worst_model(mech, util, tau=0.1, method="lp")
    assert found.local_fairness.programs_solved == 1 and found.global_fairness.programs_solved == 1
    assert every.local_fairness.programs_solved > 4 * 3 // 2
    for ours, theirs in [(found.local_fairness, every.local_fairness), (found.global_fairness, every.global_fairness)]:
        assert ours.certified and ours.value == pytest.approx(theirs.value, rel=1e-9)


def test_the_table_relaxation_is_rounded_up_and_widened_for_the_coefficients_roundings():
    # proofs/verification.md §4g's example: rows (released a, released b) over (yes, no), E[g | a] = (3/4, 1/4) on yes,
    # E[g | b] = (1/8, 3/8), tau = 1/4: 10/3 exactly (the hull edge of slope 2/3), and b over a 3/2 (only the row of
    # released b on yes: 3/8 over 1/4, which meets the floor); with roundings, above 10/3, by about 3 gamma for the
    # widening and gamma (8/3 of the 10/3) for the floor kept, (1 - gamma) tau
    from fairaudit.base.outward import fraction_up, rounding_error
    from fairaudit.worstcase.known_utility_search import _table_relaxation

    P = np.array([[0.75, 0.0, 0.25, 0.0], [0.125, 0.0, 0.375, 0.0]])
    exact, theta = _table_relaxation(P, 2, 0.25, 0)
    assert exact[0, 1] == fraction_up(Fraction(10, 3)) and exact[1, 0] == 1.5
    assert theta[0, 1] == 2 / 3  # (the hull edge's slope: the multiplier 10/3 - 2/3 = 8/3 on b's floor, by hand)
    widened = _table_relaxation(P, 2, 0.25, 4)[0][0, 1]
    assert 10 / 3 < widened <= 10 / 3 * (1 + 6 * float(rounding_error(4)))
