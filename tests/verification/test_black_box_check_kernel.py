"""The verifier's worst case over the model's table (a utility that depends on the group, a context mechanism other
than the identity): by hand, against every deterministic table, and through certify and verify."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction as F

import pytest
from _exact_route import exact_enclosures, kernel_global, kernel_local
from _verified import certified_and_verified
from hypothesis import given, settings
from hypothesis import strategies as st

import fairaudit
from fairaudit.verification.black_box_check import KernelSetting, black_box_enclosures
from fairaudit.verification.enclosures import INF

IDENTITY_X = {"inputs": ["x"], "outputs": ["x"], "kind": "identity"}
KEEP_3_4 = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.75, 0.25], [0.25, 0.75]]}


def _inputs(values, tau=None, context=IDENTITY_X, probabilities=((0.5, 0.5),), sensitive=KEEP_3_4):
    contexts = context["inputs"]
    return {
        "sensitive_mechanism": sensitive,
        "context_mechanism": context,
        "utility": {"values": values, "tau": tau},
        "population": {"contexts": contexts, "groups": ["a", "b"], "probabilities": [list(r) for r in probabilities]},
    }


def test_a_utility_that_depends_on_the_group_by_hand():
    # keep 3/4; g(yes, a) = 1, g(yes, b) = 1/2, g(no, .) = 0. E[g | a] = 3/4 k_a + 1/4 k_b and
    # E[g | b] = (1/4 k_a + 3/4 k_b)/2 for k_ã = P(yes | ã): the ratio a over b is at most 2 * 3 = 6 (k = (1, 0)),
    # b over a at most 3/2. Not capped by ε = ln 3: the utility itself favours a.
    worst = black_box_enclosures(_inputs([[[1.0, 0.0], [0.5, 0.0]]]))
    assert (worst.local.lo, worst.local.hi) == (F(6), F(6))
    assert (worst.global_.lo, worst.global_.hi) == (F(6), F(6)) and not worst.group_free


def test_the_floors_bind_by_hand():
    # τ = 1/4: E[g | a] >= 1/4 and E[g | b] >= 1/4, i.e. k_a + 3 k_b >= 2. The ratio a over b is
    # 2 (3 k_a + k_b)/(k_a + 3 k_b), increasing in k_a and decreasing in k_b: k_a = 1, k_b = 1/3, the value 10/3.
    # The rational simplex finds it; verify solves nothing: without proofs each program is bounded without its
    # floors (6); with θ = 2/3 (R(θ) = 2/3 on the row of a: θ + R(θ)/τ = 2/3 + 8/3 = 10/3) and the maximiser's table
    # recorded it is 10/3 exactly, the pair (b, a) bounded by 3/2 < 10/3 without a proof
    inputs = _inputs([[[1.0, 0.0], [0.5, 0.0]]], tau=0.25)
    worst = exact_enclosures(inputs)
    assert (worst.local.lo, worst.local.hi) == (F(10, 3), F(10, 3))
    assert black_box_enclosures(inputs).local.hi == 6
    proof = {"context": "x", "group": "a", "other_group": "b", "witness_point": [[1.0, 0.0], ["1/3", "2/3"]],
             "screens": [{"context": "x", "group": "a", "other_group": "b", "theta": "2/3"}], "global": {}}  # fmt: skip
    proved = black_box_enclosures(inputs, proof)
    assert (proved.local.lo, proved.local.hi) == (F(10, 3), F(10, 3))


def test_floors_no_table_meets_are_found_by_the_exact_route_and_bound_nothing_in_verify():
    # E[g | b] <= 1/2 < τ = 0.6 for every table: no model meets the floors. The rational simplex says so; verify,
    # solving nothing, bounds each program without its floors (a bound over an empty set holds vacuously)
    inputs = _inputs([[[1.0, 0.0], [0.5, 0.0]]], tau=0.6)
    with pytest.raises(ValueError, match="no decision model meets the floors"):
        exact_enclosures(inputs)
    assert black_box_enclosures(inputs).local.hi == 6


def test_a_utility_that_vanishes_for_one_group_is_unbounded():
    # g(., b) = 0: E[g | b] = 0 < E[g | a] for k = (1, 1): the ratio a over b is +inf (c/0)
    worst = black_box_enclosures(_inputs([[[1.0, 0.0], [0.0, 0.0]]]))
    assert worst.local.hi == INF and worst.local.lo == INF


def _brute_force(s: KernelSetting) -> tuple[F | float, F | float | None]:
    """max L and L̄ over every deterministic table K[x̃, ã] -> u (the vertices of the tables' polytope: without floors
    the ratio's maximum is at one), with c/0 = +inf and 0/0 = 1."""
    n_x, k = len(s.g), s.k
    released_x = len(s.context[0]) if s.context is not None else n_x
    released_a, n_u = len(s.sensitive[0]), len(s.g[0][0])

    def mx(x, xr):
        return F(int(x == xr)) if s.context is None else s.context[x][xr]

    def ratio(top, bottom):
        return (INF if top > 0 else F(1)) if bottom == 0 else top / bottom

    best_l: F | float = F(0)
    best_g: F | float = F(1)
    for choice in itertools.product(range(n_u), repeat=released_x * released_a):
        e = [
            [
                sum(
                    mx(x, xr) * s.sensitive[a][ar] * s.g[x][a][choice[xr * released_a + ar]]
                    for xr in range(released_x)
                    for ar in range(released_a)
                )  # fmt: skip
                for a in range(k)
            ]
            for x in range(n_x)
        ]
        for x in s.live:
            for a in range(k):
                for b in range(k):
                    if a != b:
                        best_l = max(best_l, ratio(e[x][a], e[x][b]))
        by_group = [sum(s.weights[i][a] * e[x][a] for i, x in enumerate(s.live)) for a in range(k)]
        for a in s.present:
            for b in s.present:
                if a != b:
                    best_g = max(best_g, ratio(by_group[a], by_group[b]))
    return best_l, best_g


def _rows(draw, n_in, n_out):
    out = []
    for _ in range(n_in):
        ints = draw(st.lists(st.integers(0, 4), min_size=n_out, max_size=n_out).filter(lambda r: sum(r) > 0))
        out.append(tuple(F(i, sum(ints)) for i in ints))
    return tuple(out)


@st.composite
def kernel_settings(draw):
    k, n_x, n_u = draw(st.integers(2, 3)), draw(st.integers(1, 2)), draw(st.integers(2, 3))
    sensitive = _rows(draw, k, draw(st.integers(2, 3)))
    context = None if draw(st.booleans()) else _rows(draw, n_x, draw(st.integers(1, 2)))
    g = [[[F(draw(st.integers(0, 3)), 2) for _ in range(n_u)] for _ in range(k)] for _ in range(n_x)]
    pop = [[F(draw(st.integers(0, 3))) for _ in range(k)] for _ in range(n_x)]
    live = [x for x in range(n_x) if sum(pop[x])]
    if not live:
        pop[0][0], live = F(1), [0]
    mass = [sum(pop[x][a] for x in live) for a in range(k)]
    weights = [[pop[x][a] / mass[a] if mass[a] else F(0) for a in range(k)] for x in live]
    present = [a for a in range(k) if mass[a]]
    group_free = all(g[x][a] == g[x][0] for x in range(n_x) for a in range(k))
    return KernelSetting(sensitive, context, g, None, live, weights, present, group_free)


@pytest.mark.slow
@settings(max_examples=100)  # (each example solves up to 14 exact programs and walks up to 729 tables)
@given(s=kernel_settings())
def test_the_programs_agree_with_every_deterministic_table(s):
    # without floors the maximum of a linear-fractional function over the tables is at a vertex: a deterministic table
    local, global_ = _brute_force(s)
    assert kernel_local(s) == local
    assert kernel_global(s) == global_


def test_certify_and_verify_with_a_utility_that_depends_on_the_group(tmp_path):
    # the hand case behind randomized response on the context too: L = ln 6 (the context mechanism does not matter
    # here), re-derived exactly, and the black box moved down by 1e-9 fails
    cert, _, checked = certified_and_verified(
        '[sensitive]\nname = "group"\nvalues = ["a", "b"]\n[context]\nname = "job"\nvalues = ["x", "y"]\n'
        '[decision]\nname = "d"\nvalues = ["yes", "no"]\n'
        '[privacy.sensitive]\nmechanism = "matrix"\nrows = [[0.75, 0.25], [0.25, 0.75]]\n'
        '[privacy.context]\nmechanism = "randomized_response"\nepsilon = 1.0\n'
        '[utility]\nkind = "table"\nvalues = [[[1.0, 0.0], [0.5, 0.0]], [[1.0, 0.0], [1.0, 0.0]]]\n',
        tmp_path,
    )
    assert {"bounds.black_box", "bound_details.black_box.global.value", "bounds.global"} <= checked
    worst = black_box_enclosures(cert["inputs"])
    assert worst.local.lo == worst.local.hi == F(6)
    assert math.log(6) < cert["bounds"]["black_box"] <= math.log(6) * (1 + 1e-14)  # rounded up, within 1e-14
    cert["bounds"]["black_box"] -= 1e-9
    assert "bounds.black_box" in {c.name for c in fairaudit.verify(cert).failures}


def test_no_privacy_on_the_group_by_hand():
    # the identity on the groups: E[g | a] = k_a, free in [τ, 1] for each group: the ratio is 1/τ = 4 with τ = 1/4,
    # and +inf without a floor (k_a' = 0 < k_a); randomized response at ε = +inf is the identity too
    identity = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "identity"}
    rr_inf = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "randomized_response", "epsilon": "inf"}
    for sensitive in (identity, rr_inf):
        floor = exact_enclosures(_inputs([1.0, 0.0], tau=0.25, sensitive=sensitive))
        assert (floor.local.lo, floor.local.hi) == (F(4), F(4))
        assert black_box_enclosures(_inputs([1.0, 0.0], sensitive=sensitive)).local.hi == INF


def test_certify_and_verify_without_privacy_on_the_group(tmp_path):
    cert, _, checked = certified_and_verified(
        '[sensitive]\nname = "group"\nvalues = ["a", "b"]\n[decision]\nname = "d"\nvalues = ["yes", "no"]\n'
        '[utility]\nkind = "indicator"\ndecision = "yes"\ntau = 0.25\n',
        tmp_path,
    )
    # γ/τ = 4, certified from the LP's dual: rounded up, within 1e-14
    assert "bounds.black_box" in checked and math.log(4) < cert["bounds"]["black_box"] <= math.log(4) * (1 + 1e-14)


def test_contexts_with_one_utility_table_are_solved_once(monkeypatch):
    # four contexts, two tables (each twice): L is the largest of every (context, pair) solved on its own, and the
    # programs of two contexts only are built
    import _exact_route as kc

    table_1, table_2 = [[F(1), F(0)], [F(1, 2), F(0)]], [[F(1, 4), F(1)], [F(1), F(1, 8)]]
    g = [table_1, table_2, table_1, table_2]
    rows = ((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4)))
    s = KernelSetting(rows, None, g, F(1, 5), [0, 1, 2, 3], [[F(1, 4)] * 2] * 4, [0, 1], False)
    one_by_one = max(kernel_local(s, at=(i, a, b)) for i in range(4) for a, b in ((0, 1), (1, 0)))
    built = []
    make = kc._Polytope.of
    monkeypatch.setattr(kc._Polytope, "of", lambda s, contexts: built.append(contexts) or make(s, contexts))
    assert kernel_local(s) == one_by_one > 1
    assert sorted(built) == [[0], [1]]
