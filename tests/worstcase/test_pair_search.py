"""Many groups: the pruned pair routes (proofs/black_box.md §7) against the all-pairs computations.

Every general route (``black_box_bound``, ``worst_model`` through ``pairwise_box``, ``tight_bound``, ``paper_bound``)
solves exactly only the pairs that can reach the maximum, after exact upper bounds set the others aside. Here the
result is compared with (1) the same route with every pair solved (``box_pairs`` replaced by its all-pairs version,
which is the code before the pruning), bit for bit, with the same pair and the same number of LPs, and (2) routes
written here from scratch (the whole n x n tables of threshold values, brute force over each pair's candidate t), on
mechanisms of many shapes: k != m, k = 2, ties, zero entries, the identity, randomized response given as a matrix
(against its closed form). Tiny block sizes force many tiles; bad first candidates force the pass to find the best
pair itself. Memory: ``black_box_bound`` at 400 groups stays within 16 times the matrix (tracemalloc).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
import time
import tracemalloc

import numpy as np
import pytest
from _terminal import lines_drawn, on_terminal

import fairaudit as fa
import fairaudit.base.pairs as pairs_module
import fairaudit.metrics.privacy_profile as profile_module
import fairaudit.worstcase.black_box as black_box_module
import fairaudit.worstcase.pair_search as search_module
from fairaudit import UtilityClass
from fairaudit.base.progress import progress_shown
from fairaudit.base.threshold_rule import floor_max_many, threshold_max_many
from fairaudit.metrics.privacy_profile import _profile_candidates
from fairaudit.worstcase.black_box import black_box_bound
from fairaudit.worstcase.known_utility import worst_model


def _all_pairs(matrix, lower, upper, floor=None):
    """The route before the pruning: every ordered pair solved exactly."""
    return search_module._all_pairs(matrix, float(lower), float(upper), floor)


@pytest.fixture(autouse=True)
def _no_caches(monkeypatch):
    """Each test (and each patched block size) computes afresh: empty caches of results and candidates."""
    monkeypatch.setattr(search_module, "_CACHE", {})
    monkeypatch.setattr(pairs_module, "_CANDIDATES_CACHE", {})


@pytest.fixture
def all_pairs(monkeypatch):
    """Within the fixture's ``with``: every pair solved, as before the pruning."""

    class Switch:
        def __enter__(self):
            self.patch = pytest.MonkeyPatch()
            self.patch.setattr(black_box_module, "box_pairs", _all_pairs)
            self.patch.setattr(search_module, "box_pairs", _all_pairs)
            return self

        def __exit__(self, *exc):
            self.patch.undo()

    return Switch()


def _tiny_blocks(monkeypatch, block=7):
    """A few pairs per tile, so that every pass runs over many tiles, bands and chunks (caches emptied)."""
    for module in (pairs_module, search_module, profile_module):
        if hasattr(module, "PAIR_BLOCK"):
            monkeypatch.setattr(module, "PAIR_BLOCK", block)
    monkeypatch.setattr(search_module, "_CACHE", {})
    monkeypatch.setattr(pairs_module, "_CANDIDATES_CACHE", {})


def _bad_candidates(monkeypatch):
    """Start every pruned pass from the pair (0, 1) only: the pass must find the best pair itself."""

    def first(matrix, count=0):
        return np.array([0]), np.array([1])

    monkeypatch.setattr(search_module, "pair_candidates", first)
    monkeypatch.setattr(profile_module, "pair_candidates", first)


def _mechanisms():
    """(name, matrix) of many shapes: k != m, k = 2, ties, zeros, the identity, near-equal rows."""
    rng = np.random.default_rng(2024)
    out = []
    for n, m, alpha in [(2, 2, 1.0), (2, 7, 0.5), (3, 3, 1.0), (5, 2, 1.0), (7, 11, 0.3), (12, 4, 2.0), (25, 25, 1.0)]:
        out.append((f"dirichlet {n}x{m}", rng.dirichlet(np.full(m, alpha), size=n)))
    zeros = rng.dirichlet(np.ones(6), size=9)
    zeros[rng.random(zeros.shape) < 0.3] = 0.0
    zeros[:, 0] += 1e-3  # (no row of zeros)
    out.append(("zeros 9x6", zeros / zeros.sum(1, keepdims=True)))
    ties = rng.dirichlet(np.ones(5), size=4)
    out.append(("duplicate rows 8x5", np.repeat(ties, 2, axis=0)))
    out.append(("identity 6", np.eye(6)))
    out.append(("randomized response 9", fa.randomized_response(range(9), epsilon=1.3).matrix))
    near = np.full((5, 4), 0.25)
    near[0] = [0.25 + 3e-10, 0.25 - 3e-10, 0.25, 0.25]
    out.append(("near-equal rows 5x4", near))
    return out


MECHANISMS = _mechanisms()


def _mech(matrix):
    n, m = matrix.shape
    return fa.from_matrix(matrix, list(range(n)), [f"o{j}" for j in range(m)])


def _same_certificate(c, d):
    assert c.value == d.value or (math.isnan(c.value) and math.isnan(d.value))
    assert (c.group, c.other_group, c.released, c.method, c.status) == (
        d.group,
        d.other_group,
        d.released,
        d.method,
        d.status,
    )
    assert c.programs_solved == d.programs_solved
    np.testing.assert_array_equal(c.utility_by_release, d.utility_by_release)


# ------------------------------------------------------------------------------------------------ tables
def _full_tables(M, lo, hi, floor=None):
    """The n x n box values (and floor relaxations), computed for every pair at once (diagonal -inf)."""
    p, q = M[:, None, :], M[None, :, :]
    box = threshold_max_many(p, q, lo, hi)[0]
    rel = None if floor is None else floor_max_many(p, q, lo, hi, floor)[0]
    for t in (box, rel):
        if t is not None:
            np.fill_diagonal(t, -np.inf)
    return box, rel


@pytest.mark.parametrize("name, M", MECHANISMS, ids=[x[0] for x in MECHANISMS])
@pytest.mark.parametrize("lo", [0.0, 0.1, 0.6])
def test_box_pairs_keep_the_maximum_and_its_first_pair(name, M, lo, monkeypatch):
    box, _ = _full_tables(M, lo, 1.0)
    want = np.unravel_index(int(np.argmax(box)), box.shape)
    for tiny in (False, True):
        if tiny:
            _tiny_blocks(monkeypatch)
            _bad_candidates(monkeypatch)
        found = search_module.box_pairs(M, lo, 1.0)
        i = int(np.argmax(found.box))
        assert (found.a[i], found.b[i]) == want and found.box[i] == box.max()
        np.testing.assert_array_equal(found.box, box[found.a, found.b])  # solved pairs: bit for bit
        assert np.all(np.diff(found.a * len(M) + found.b) > 0)  # row-major, no duplicates
        dense, _ = search_module.pairwise_box(M, lo, 1.0, None)
        np.fill_diagonal(dense, -np.inf)
        off = ~np.eye(len(M), dtype=bool)
        assert np.all(dense[off] >= box[off] * (1 - 1e-12))  # valid upper bounds
        assert np.unravel_index(int(np.argmax(dense)), dense.shape) == want and dense.max() == box.max()


@pytest.mark.slow
@pytest.mark.parametrize("name, M", MECHANISMS, ids=[x[0] for x in MECHANISMS])
@pytest.mark.parametrize("lo, floor", [(0.0, 0.3), (0.1, 0.5), (0.2, 0.9)])
def test_relaxation_bounds_are_valid_and_exact_where_kept(name, M, lo, floor, monkeypatch):
    box, rel = _full_tables(M, lo, 1.0, floor)
    for tiny in (False, True):
        if tiny:
            _tiny_blocks(monkeypatch)
        found = search_module.box_pairs(M, lo, 1.0, floor)
        np.testing.assert_array_equal(found.relaxed, rel[found.a, found.b])
        np.testing.assert_array_equal(found.box, box[found.a, found.b])
        dense_box, dense_rel = search_module.pairwise_box(M, lo, 1.0, floor)
        off = ~np.eye(len(M), dtype=bool)
        ok = ~np.isnan(rel[off])
        assert np.all(dense_rel[off][ok] >= rel[off][ok] * (1 - 1e-12))
        assert np.all(dense_box[off] >= box[off] * (1 - 1e-12))


# ------------------------------------------------------------------------------------------------ black box
@pytest.mark.parametrize("name, M", MECHANISMS, ids=[x[0] for x in MECHANISMS])
@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"utility_class": UtilityClass(lower=0.1)},
        {"utility_class": UtilityClass(lower=0.5, gamma=2.0)},
        {"utility_class": UtilityClass(tau=0.3)},
        {"utility_class": UtilityClass(lower=0.05, tau=0.6)},
    ],
    ids=["lower0", "lower", "lower-gamma", "tau", "lower-tau"],
)
def test_black_box_equals_the_all_pairs_route(name, M, kw, all_pairs, monkeypatch):
    mech = _mech(M)
    with all_pairs:
        want = black_box_bound(mech, **kw)
    _same_certificate(black_box_bound(mech, **kw), want)
    _tiny_blocks(monkeypatch)
    _bad_candidates(monkeypatch)
    _same_certificate(black_box_bound(mech, **kw), want)
    # and against the whole table (threshold route)
    c = kw.get("utility_class", UtilityClass())
    if c.tau is None:
        lo = (c.lower or 0.0) / (c.gamma or 1.0)
        box, _ = _full_tables(M, lo, 1.0)
        assert want.ratio == box.max()
        assert (want.group, want.other_group) == np.unravel_index(int(np.argmax(box)), box.shape)


def test_black_box_forced_lp_and_population_equal_the_all_pairs_route(all_pairs):
    rng = np.random.default_rng(5)
    for n, m in [(4, 3), (6, 5)]:
        mech = _mech(rng.dirichlet(np.ones(m), size=n))
        pop = fa.Population(rng.dirichlet(np.ones(2 * n)).reshape(2, n), ["x0", "x1"], list(range(n)))
        for kw in (
            {"utility_class": UtilityClass(lower=0.1), "method": "lp"},
            {"utility_class": UtilityClass(tau=0.4), "method": "lp"},
            {"utility_class": UtilityClass(tau=0.4), "population": pop},
        ):
            with all_pairs:
                want = black_box_bound(mech, **kw)
            got = black_box_bound(mech, **kw)
            assert got.ratio == pytest.approx(want.ratio, rel=1e-9)
            assert (got.group, got.other_group, got.programs_solved) == (
                want.group,
                want.other_group,
                want.programs_solved,
            )
            assert got.assumptions == want.assumptions


def test_black_box_lipschitz_with_a_metric_is_unchanged(all_pairs):
    rng = np.random.default_rng(8)
    mech = _mech(rng.dirichlet(np.ones(3), size=3))
    d = np.array([[0.0, 1.0, 2.0], [1.0, 0.0, 1.0], [2.0, 1.0, 0.0]])
    for kw in (
        {"utility_class": UtilityClass(tau=0.4, lipschitz=0.1, metric=d)},
        {"utility_class": UtilityClass(lower=0.2, lipschitz=0.05, metric=d)},
    ):
        with all_pairs:
            want = black_box_bound(mech, **kw)
        got = black_box_bound(mech, **kw)
        assert got.ratio == pytest.approx(want.ratio, rel=1e-9)
        assert (got.group, got.other_group, got.programs_solved) == (want.group, want.other_group, want.programs_solved)


def test_randomized_response_as_a_matrix_equals_its_closed_form(monkeypatch, all_pairs):
    for k, eps in [(2, 0.7), (5, 1.3), (13, 2.0)]:
        rr = fa.randomized_response(range(k), epsilon=eps)
        general = _mech(rr.matrix)
        for kw in (
            {},
            {"utility_class": UtilityClass(lower=0.2)},
            {"utility_class": UtilityClass(tau=0.5)},
            {"utility_class": UtilityClass(lower=0.1, tau=0.3)},
        ):
            closed, route = black_box_bound(rr, **kw), black_box_bound(general, **kw)
            assert route.value == pytest.approx(closed.value, rel=1e-12, abs=1e-14)
            with all_pairs:  # every pair ties: rounding picks the pair, the same one as before
                _same_certificate(route, black_box_bound(general, **kw))
    _tiny_blocks(monkeypatch)
    rr = fa.randomized_response(range(7), epsilon=1.0)
    assert black_box_bound(_mech(rr.matrix), utility_class=UtilityClass(lower=0.3)).value == pytest.approx(
        black_box_bound(rr, utility_class=UtilityClass(lower=0.3)).value, rel=1e-12
    )


# ------------------------------------------------------------------------------------------------ worst model
@pytest.mark.slow
@pytest.mark.parametrize("name, M", MECHANISMS[:9], ids=[x[0] for x in MECHANISMS[:9]])
def test_worst_model_equals_the_all_pairs_route(name, M, all_pairs):
    mech = _mech(M)
    n = len(M)
    pop = fa.Population(np.full((2, n), 1 / (2 * n)), ["x0", "x1"], list(range(n)))
    g = fa.from_table([1.0, 0.3, 0.0], ["u0", "u1", "u2"])
    g_ctx = fa.from_table([[[1.0, 0.2]] * n, [[0.6, 0.1]] * n], ["u0", "u1"], ["x0", "x1"], list(range(n)))
    for util, tau in ((g, None), (g, 0.4), (g_ctx, None), (g_ctx, 0.3)):
        with all_pairs:
            want = worst_model(mech, util, population=pop, tau=tau)
        got = worst_model(mech, util, population=pop, tau=tau)
        for w, v in ((got.local_fairness, want.local_fairness), (got.global_fairness, want.global_fairness)):
            assert w.value == pytest.approx(v.value, rel=1e-9) or (math.isnan(w.value) and math.isnan(v.value))
            assert (w.context, w.group, w.other_group, w.method) == (v.context, v.group, v.other_group, v.method)


# ------------------------------------------------------------------------------------------------ tight, paper
def _tight_brute(M, d, gamma, tau, lip):
    """max over pairs of min over t in {1} ∪ ratios of t + (L_A d + γ Σ[p − tq]₊)/τ, every pair, directly."""
    best, pair = -math.inf, None
    for a, b in itertools.permutations(range(len(M)), 2):
        p, q = M[a], M[b]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(q > 0, p / np.where(q > 0, q, 1.0), np.inf)
        ts = np.concatenate([[1.0], r[np.isfinite(r) & (r >= 1)]])
        v = min(t + (lip * d[a, b] + gamma * np.clip(p - t * q, 0, None).sum()) / tau for t in ts)
        if v > best * (1 + 1e-12):
            best, pair = v, (a, b)
    return math.log(best), pair


@pytest.mark.slow
@pytest.mark.parametrize("name, M", MECHANISMS, ids=[x[0] for x in MECHANISMS])
def test_tight_and_paper_equal_the_all_pairs_computations(name, M, monkeypatch):
    mech = _mech(M)
    n = len(M)
    d = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :]) / max(1, n - 1)
    for tiny in (False, True):
        if tiny:
            _tiny_blocks(monkeypatch)
            _bad_candidates(monkeypatch)
        for tau, lip, metric in ((0.1, 0.0, None), (0.3, 0.0, None), (0.2, 0.1, d)):
            got = fa.tight_bound(mech, utility_class=fa.UtilityClass(gamma=1.0, tau=tau, lipschitz=lip, metric=metric))
            value, _ = _tight_brute(M, np.ones((n, n)) if metric is None else d, 1.0, tau, lip)
            assert got.value == pytest.approx(value, rel=1e-12, abs=1e-15)
            a, b = np.nonzero(~np.eye(n, dtype=bool))  # every pair's objective, as before the pruning
            dist = np.ones(a.size) if metric is None else d[a, b]
            obj = profile_module._tight_objective(M[a], M[b], dist, 1.0, tau, lip)[0]
            i = int(np.argmax(obj))
            assert (got.group, got.other_group) == (a[i], b[i])
            assert float(np.log(obj[i])) * (1 - 1e-12) - 1e-15 <= got.value  # rounded up, within its error bound
            assert got.value == pytest.approx(float(np.log(obj[i])), rel=1e-12, abs=1e-14)
            paper = fa.paper_bound(mech, utility_class=fa.UtilityClass(gamma=1.0, tau=tau, lipschitz=lip))
            t, deltas = _profile_candidates(mech)  # the envelope of every pair's lines
            c = lip * (1.0 if metric is None else d.max())
            values = np.log(t) + np.log1p((c + deltas) / tau)
            k = int(np.argmin(values))
            assert paper.value == pytest.approx(values[k], rel=1e-12, abs=1e-15)
            assert paper.epsilon == pytest.approx(math.log(t[k]), rel=1e-9, abs=1e-12)


def test_tight_and_paper_on_a_larger_mechanism(monkeypatch):
    rng = np.random.default_rng(3)
    M = rng.dirichlet(np.ones(30) * 0.7, size=60)
    mech = _mech(M)
    value, pair = _tight_brute(M, np.ones((60, 60)), 1.0, 0.1, 0.0)
    got = fa.tight_bound(mech, utility_class=fa.UtilityClass(gamma=1.0, tau=0.1))
    assert got.value == pytest.approx(value, rel=1e-12) and (got.group, got.other_group) == pair
    t, deltas = _profile_candidates(mech)
    assert fa.paper_bound(mech, utility_class=fa.UtilityClass(gamma=1.0, tau=0.1)).value == pytest.approx(
        float(np.min(np.log(t) + np.log1p(deltas / 0.1))), rel=1e-12
    )


# ------------------------------------------------------------------------------------------------ memory
@pytest.mark.slow
@pytest.mark.parametrize(
    "kw",
    [{}, {"utility_class": UtilityClass(lower=0.1)}, {"utility_class": UtilityClass(tau=0.1)}],
    ids=["lower0", "lower", "tau"],
)
def test_black_box_memory_is_linear_in_the_matrix(kw):
    M = np.random.default_rng(0).dirichlet(np.ones(400), size=400)
    mech = _mech(M)
    tracemalloc.start()
    try:
        black_box_bound(mech, **kw)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 * M.nbytes, peak / M.nbytes


def test_pair_pass_sums_and_candidates():
    rng = np.random.default_rng(1)
    M = rng.dirichlet(np.ones(5), size=7)
    passer = pairs_module.PairPass(M)
    got = np.full((7, 7), np.nan)

    def visit(rows, cols, sums, lam):
        got[rows, cols] = sums

    passer.run(lambda: 1.7, visit)
    want = np.maximum(M[:, None, :], 1.7 * M[None, :, :]).sum(-1)
    np.testing.assert_allclose(got, want, rtol=1e-15)
    a, b = pairs_module.pair_candidates(M, count=3)
    assert np.all(a != b) and np.all(np.diff(a * 7 + b) > 0)
    coef = np.sqrt(M) @ np.sqrt(M).T
    np.fill_diagonal(coef, np.inf)
    assert coef[a, b].min() == coef.min()


# ------------------------------------------------------------------------------------------------ worst utility
def test_worst_utility_threshold_route_equals_the_whole_table(monkeypatch):
    from fairaudit.worstcase.known_law import worst_utility

    rng = np.random.default_rng(11)
    for trial in range(8):
        nX, nA, nU = int(rng.integers(1, 4)), int(rng.integers(2, 30)), int(rng.integers(2, 5))
        Q = rng.dirichlet(np.ones(nU) * 0.6, size=(nX, nA))
        law = fa.Law(Q, [f"x{i}" for i in range(nX)], list(range(nA)), [f"u{j}" for j in range(nU)])
        if trial % 2:
            _tiny_blocks(monkeypatch)
        for lower in (0.0, 0.2):
            w = worst_utility(law, utility_class=UtilityClass(lower=lower))
            vals = threshold_max_many(Q[:, :, None, :], Q[:, None, :, :], lower, 1.0)[0]
            vals[:, np.arange(nA), np.arange(nA)] = -np.inf
            x, a, b = np.unravel_index(int(np.argmax(vals)), vals.shape)
            L = w.local_fairness
            assert (L.ratio, L.context, L.group, L.other_group) == (
                vals.max(),
                f"x{x}",
                a,
                b,
            )


def test_white_box_calibration_behind_randomized_response_without_its_matrix(monkeypatch):
    """Above RR_COMPOSE_LIMIT groups the law comes from the closed form: the same calibration, to the 1e-9 at which the refinement stops.

    The limit is lowered so that both routes run on the same 12-group kernel; the closed form never reads the
    mechanism's matrix (a guard raises if it does).
    """
    import fairaudit.worstcase.calibration_methods as methods
    from fairaudit.laws.closed_forms import RandomizedResponse
    from fairaudit.worstcase.calibration import calibrate

    rng = np.random.default_rng(5)
    k, contexts = 12, ("x0", "x1", "x2")
    kernel = fa.Kernel(rng.dirichlet(np.ones(3), size=(3, k)), contexts, tuple(range(k)), ("no", "maybe", "yes"))
    utility = fa.indicator("yes", kernel.decisions)
    family = fa.randomized_response_family(range(k))

    def run():
        return calibrate(0.4, method="white_box", family=family, kernel=kernel, utility=utility)

    with_matrix = run()
    monkeypatch.setattr(methods, "RR_COMPOSE_LIMIT", 0)
    monkeypatch.setattr(RandomizedResponse, "matrix", property(lambda self: pytest.fail("the matrix was built")))
    closed = run()
    assert closed.epsilon == pytest.approx(with_matrix.epsilon, rel=1e-9)  # the refinement stops within ~1e-12
    assert closed.bound == pytest.approx(with_matrix.bound, rel=1e-9)
    assert 0 < closed.epsilon < math.inf and closed.bound <= 0.4 * (1 + 1e-12)


def _fixed(value: float, certified: bool = True):
    from fairaudit.base.linear_fractional import FractionalResult

    return FractionalResult(
        value=value, argmax=None, status="optimal", method="lp", solver_status="optimal", reason="",
        certified=certified, witness=value, gap=0.0,
    )  # fmt: skip


def test_search_returns_an_upper_end_over_every_problem():
    values = [2.0, 2.0 * (1 + 5e-10), 1.0]
    # a near-tie (within the solver's 1e-9) keeps the earlier problem as the maximiser, but its value is the larger
    found = search_module.search(np.array([3.0, 2.5, 1.5]), lambda i: _fixed(values[i]))
    assert found.index == 0 and found.result.value == values[1] and found.solved == 2
    # a problem left unsolved because its bound is within STOP of the best: its bound is the value
    bound = 2.0 * (1 + 1e-13)
    found = search_module.search(np.array([3.0, bound, 1.0]), lambda i: _fixed(values[0]))
    assert found.index == 0 and found.result.value == bound and found.solved == 1
    # one uncertified value leaves the maximum uncertified, whichever problem attains it
    found = search_module.search(np.array([3.0, 2.5, 1.5]), lambda i: _fixed(values[i], certified=i != 1))
    assert found.index == 0 and not found.result.certified


class _Recorder:
    """A progress bar that records what the search shows."""

    disable = False

    def __init__(self):
        self.n, self.postfixes = 0, []

    def update(self, n=1):
        self.n += n

    def set_postfix_str(self, s="", refresh=True):
        self.postfixes.append(s)


PROGRESS_BOUNDS = np.array([4.0, 3.0, 2.5, 1.5, 1.2])
PROGRESS_VALUES = [2.0, 2.8, 2.2, 1.0, 1.0]


def test_search_progress_shows_the_best_value_and_the_bounds_it_closes_on():
    # after program 0: best ln 2, next bound ln 3, and two bounds (3, 2.5) above 2; after program 1 (2.8) none is:
    # the search stops there, having taken 2 of the 5 programs
    bar = _Recorder()
    found = search_module._search(PROGRESS_BOUNDS, lambda i: _fixed(PROGRESS_VALUES[i]), bar)
    assert found.index == 1 and found.solved == 2 and bar.n == 2
    assert bar.postfixes == [
        f"best {math.log(2.0):.4f} nats, next bound {math.log(3.0):.4f} nats (2 left above best)",
        f"best {math.log(2.8):.4f} nats",
    ]
    assert bar.postfixes[0] == "best 0.6931 nats, next bound 1.0986 nats (2 left above best)"


def test_search_draws_its_bar_on_stderr_inside_progress_shown_only(monkeypatch):
    terminal = on_terminal(monkeypatch)
    monkeypatch.setattr(search_module, "STEP_DELAY", 0.0)

    def slow(i):
        time.sleep(0.15)  # (longer than tqdm's 0.1 s between two draws)
        return _fixed(PROGRESS_VALUES[i])

    search_module.search(PROGRESS_BOUNDS, slow)
    assert terminal.getvalue() == ""
    with progress_shown():
        found = search_module.search(PROGRESS_BOUNDS, slow)
    assert found.index == 1
    drawn = [re.sub(r"\[\d\d:\d\d", "[T", line) for line in lines_drawn(terminal.getvalue())]
    assert drawn == [
        "worst case: 0/5 programs [T]",
        "worst case: 1/5 programs [T, best 0.6931 nats, next bound 1.0986 nats (2 left above best)]",
        "worst case: 2/5 programs [T, best 1.0296 nats]",
    ]
    assert terminal.getvalue().endswith("\r")  # (cleared when the search ends)


def test_the_witness_is_the_outer_basis_vertex_on_the_inner_rows():
    # outer floors 0.7 h1 + 0.3 h2 >= 1/2 and 0.3 h1 + 0.7 h2 >= 1/2 (the maximiser (1, 2/7), ratio 11/7); the inner
    # rows 0.69/0.29 and 0.29/0.69 are tighter, so the outer maximiser misses the second by 0.013 (no witness there);
    # the same basis on the inner rows is the vertex (1, 7/23), where the inner ratio (0.69 + 0.29·7/23)/(0.31 +
    # 0.71·7/23) = 179/121 is the inner program's maximum (h1 at its top, h2 at its least under the second row)
    from fractions import Fraction as F

    from fairaudit.base.linear_fractional import FractionalProgram

    outer = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=[[-0.7, -0.3], [-0.3, -0.7]], b_ub=[-0.5, -0.5])
    r = outer.solve([0.7, 0.3], [0.3, 0.7])
    rows = [(-np.array([[0.69, 0.29], [0.29, 0.69]]), np.full(2, -0.5), "le")]
    inner = search_module.InnerProgram(np.zeros(2), np.ones(2), rows)
    p, q = np.array([0.69, 0.29]), np.array([0.31, 0.71])
    best = (F(0.69) + F(0.29) * (F(0.5) - F(0.29)) / F(0.69)) / (F(0.31) + F(0.71) * (F(0.5) - F(0.29)) / F(0.69))
    assert abs(best - F(179, 121)) < F(1, 10**15)
    w = search_module.inner_witness(r, p, q, inner)
    assert F(w.witness) <= best < F(w.witness) + F(1, 10**15)
    no_basis = dataclasses.replace(r, basis=None)
    assert math.isnan(search_module.inner_witness(no_basis, p, q, inner).witness)  # (the float point alone: none)
