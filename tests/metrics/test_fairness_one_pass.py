"""The metrics of a law: compact labels, one checked copy of the table, the chunked metrics against plain loops.

Every fast route is checked against an independent straightforward one on the same input: the labels
against the tuples they stand for; the block-by-block check of a table against the exact check (same
errors, same culprit); E[g | x, a], L, L̄, the sups and L_eo against loops over contexts and pairs of
groups written here from the definitions (paper SI A and B), with 0/0, c/0, empty cells, excluded
contexts and groups, ties, and tables of many chunks (the chunk size made small: ``_CHUNK_BYTES`` and
``CHECK_BLOCK``). E is the sum over decisions of Q · g in the order of the decisions, so the loops give
the same numbers to the last bit; L̄'s group means and P(u | a) are the contexts added one after the other.
"""

from __future__ import annotations

import itertools
import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fairaudit as fa
from fairaudit.base import arrays as _arrays
from fairaudit.base.arrays import first_max, ratio_of_extremes
from fairaudit.base.errors import InputError
from fairaudit.base.labels import Labels, as_labels
from fairaudit.laws.tables import Kernel, Law, Population, default_population, population_for
from fairaudit.metrics import fairness as metrics
from fairaudit.metrics import reductions, total_variation
from fairaudit.metrics.observed import observe
from fairaudit.metrics.total_variation import tv_chunk

GROUPS = ("a", "b", "c")
DECISIONS = ("u0", "u1", "u2", "u3")


def dirichlet(n: int, groups: int = 3, decisions: int = 4, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).dirichlet(np.ones(decisions), size=(n, groups))


# --------------------------------------------------------------------------- labels


def test_range_contexts_stay_a_range_and_the_tuple_is_made_once():
    law = Law(dirichlet(5000), range(5000), GROUPS, DECISIONS)
    labels = law.context_labels
    assert isinstance(labels._compact, range) and labels._tuple is None  # no Python object per label yet
    assert len(labels) == 5000 and labels[4321] == 4321 and type(labels[4321]) is int
    assert law.context_labels._tuple is None  # indexing and len need no tuple
    assert law.contexts == tuple(range(5000)) and law.contexts is law.contexts
    assert as_labels(law.contexts, "x") is law.contexts  # the made tuple counts as checked
    assert Labels.of(law.contexts, "x") is labels


def test_array_labels_give_the_labels_a_list_gives():
    q = dirichlet(4)
    for given_, listed in (
        (np.array([7, 3, 5, 1]), [7, 3, 5, 1]),
        (np.array(["d", "a", "c", "b"]), ["d", "a", "c", "b"]),
        (np.arange(4, dtype=np.uint8), [0, 1, 2, 3]),
    ):
        by_array, by_list = Law(q, given_, GROUPS, DECISIONS), Law(q, listed, GROUPS, DECISIONS)
        assert by_array.contexts == by_list.contexts
        assert [type(v) for v in by_array.contexts] == [type(v) for v in by_list.contexts]
        assert by_array.context_labels[2] == listed[2] and type(by_array.context_labels[2]) is type(listed[2])
        assert by_array.context_labels.same(by_list.context_labels)
    given_ = np.array([5, 6, 7, 8])
    law = Law(q, given_, GROUPS, DECISIONS)
    given_[0] = 6  # the labels are the law's own copy
    assert law.contexts == (5, 6, 7, 8)


@pytest.mark.parametrize(
    "repeated",
    [np.array([3, 1, 2, 1, 3]), np.array(["x", "y", "x", "z", "w"]), np.r_[np.arange(3000), [17, 5]]],
)
def test_a_repeated_array_label_is_the_error_a_list_gives(repeated):
    q = dirichlet(len(repeated))
    with pytest.raises(InputError) as by_list:
        Law(q, repeated.tolist(), GROUPS, DECISIONS)
    with pytest.raises(InputError) as by_array:
        Law(q, repeated, GROUPS, DECISIONS)
    assert str(by_array.value) == str(by_list.value) and "repeated label" in str(by_array.value)


def test_labels_compare_as_their_tuples():
    def of(v):
        return Labels.of(v, "f")

    assert of(range(3)).same(of(np.arange(3))) and of(np.arange(3)).same(of([0, 1, 2]))
    assert of(np.arange(3)).same(of((0.0, 1.0, 2.0)))  # as (0, 1, 2) == (0.0, 1.0, 2.0)
    assert not of(np.arange(3)).same(of(np.array(["0", "1", "2"])))
    assert not of(np.array(["a"])).same(of(np.array([b"a"])))
    assert not of(range(3)).same(of(range(1, 4))) and not of(range(3)).same(of(range(4)))
    assert of(np.array([1, 2], dtype=np.uint64)).same(of(np.array([1, 2], dtype=np.int8)))
    big = range(2**63, 2**63 + 3)  # beyond int64: a tuple
    assert of(big)._compact is None and of(big).tuple == tuple(big)
    with pytest.raises(InputError, match="at least one"):
        of(range(0))


def test_a_population_built_on_the_law_shares_its_labels():
    law = Law(dirichlet(2000), range(2000), GROUPS, DECISIONS)
    pop = default_population(law)
    assert pop.context_labels is law.context_labels and pop.group_labels is law.group_labels
    assert law.context_labels._tuple is None  # nothing needed the tuple
    assert population_for(law, pop) is pop
    given_ = Population.uniform(list(range(2000)), list(GROUPS))  # a list: compared as tuples
    assert population_for(law, given_) is given_
    with pytest.raises(InputError, match=r"population contexts: must match the law's contexts"):
        population_for(law, Population.uniform(np.arange(1, 2001), GROUPS))
    pop_repr = repr(Population.uniform(["x"], ["a"]))
    assert pop_repr == (
        "Population(probabilities=array([[1.]]), contexts=('x',), groups=('a',), source='given', records=None)"
    )


# --------------------------------------------------------------------------- building a law: copies and checks


def test_a_read_only_table_is_used_as_it_is_and_a_writable_one_is_copied_once():
    q = dirichlet(300)
    frozen = q.copy()
    frozen.setflags(write=False)
    law = Law(frozen, range(300), GROUPS, DECISIONS)
    assert law.probabilities is frozen
    law = Law(q, range(300), GROUPS, DECISIONS)
    assert not np.shares_memory(law.probabilities, q) and np.array_equal(law.probabilities, q)
    assert q.flags.writeable and not law.probabilities.flags.writeable
    q[0, 0] = [1.0, 0.0, 0.0, 0.0]  # the caller's later write does not reach the law
    assert law.probabilities[0, 0].tolist() != [1.0, 0.0, 0.0, 0.0]
    base = dirichlet(300)
    view = base.view()
    view.setflags(write=False)  # read-only, but its memory is writable through ``base``
    assert not np.shares_memory(Law(view, range(300), GROUPS, DECISIONS).probabilities, base)
    kernel = Kernel(dirichlet(5), range(5), GROUPS, DECISIONS)
    assert Law.from_kernel(kernel).probabilities is kernel.probabilities


def test_empty_cells_of_a_read_only_table_are_set_on_a_copy():
    q = dirichlet(4)
    frozen = q.copy()
    frozen.setflags(write=False)
    counts = np.ones((4, 3, 4))
    counts[2, 1] = 0
    law = Law(frozen, range(4), GROUPS, DECISIONS, counts=counts)
    assert np.isnan(law.probabilities[2, 1]).all() and np.array_equal(frozen, q)
    assert law.empty_cells == ((2, "b"),)
    kernel = Kernel.from_counts(counts, range(4), GROUPS, DECISIONS)
    assert Law.from_kernel(kernel).probabilities is kernel.probabilities  # its empty rows hold NaN already


BAD = [
    ((150, 1, 2), np.nan, r"law: entry at \(context='150', group='b', decision='u2'\) is not finite \(got nan\)"),
    ((151, 2, 0), np.inf, r"law: entry at \(context='151', group='c', decision='u0'\) is not finite \(got inf\)"),
    ((152, 0, 3), -0.25, r"law: entry at \(context='152', group='a', decision='u3'\) is negative \(got -0.25\)"),
]


@pytest.mark.parametrize("block", [4, 7, 64, 1 << 16])
@pytest.mark.parametrize("frozen", [False, True])
def test_the_block_check_finds_what_the_exact_check_finds(block, frozen, monkeypatch):
    monkeypatch.setattr(_arrays, "CHECK_BLOCK", block)
    for (x, a, u), value, message in BAD:
        q = dirichlet(200)
        q[x, a, u] = value
        q[190, 1, 1] = value  # a later culprit of the same kind: the first in table order is named
        if frozen:
            q.setflags(write=False)
        with pytest.raises(InputError, match=message):
            Law(q, range(200), GROUPS, DECISIONS)
    q = dirichlet(200)
    q[120, 2] *= 1.0 + 2e-9  # the row sums to 1 + 2e-9
    with pytest.raises(InputError, match=r"law: row \(context='120', group='c'\) sums to 1.000000002, not 1"):
        Law(q, range(200), GROUPS, DECISIONS)
    q = dirichlet(200)
    q[77, 0, 0] += 1e-9 - 5e-15  # within the tolerance, inside the band the exact check decides
    q[78, 0, 0] += 5e-10
    law = Law(q, range(200), GROUPS, DECISIONS)
    assert np.array_equal(law.probabilities, q)


def test_a_population_is_checked_in_blocks_too(monkeypatch):
    monkeypatch.setattr(_arrays, "CHECK_BLOCK", 5)
    p = np.full((40, 3), 1 / 120)
    p[33, 2] = -1e-3
    with pytest.raises(InputError, match=r"population: entry at \(context='33', group='c', -='None'\) is negative"):
        Population(p, range(40), GROUPS)
    p[33, 2] = np.inf
    with pytest.raises(InputError, match=r"entry at \(context='33', group='c', -='None'\) is not finite"):
        Population(p, range(40), GROUPS)


# --------------------------------------------------------------------------- the metrics against loops


def _ratio(hi: float, lo: float) -> float:
    return 1.0 if hi == 0 else math.inf if lo == 0 else hi / lo


def expected(q: np.ndarray, g: np.ndarray) -> np.ndarray:
    """E[g | x, a] = Σ_u Q[x, a, u] g(u), added in the order of the decisions, cell by cell (NaN rows stay NaN)."""
    X, A, K = q.shape
    e = np.empty((X, A))
    for x, a in itertools.product(range(X), range(A)):
        gx = g if g.ndim == 1 else g[x, a]
        total = 0.0
        for u in range(K):
            total += float(q[x, a, u]) * float(gx[u])
        e[x, a] = total
    return e


def reference(q: np.ndarray, g: np.ndarray, p_xa: np.ndarray) -> dict:
    """Every metric with its cells, by loops over contexts and groups (first maximiser in table order).

    NaN rows are empty cells; contexts with P(x) = 0 and groups with P(a) = 0 are left out.
    """
    X, A, K = q.shape
    present = ~np.isnan(q[..., 0])
    px, pa = p_xa.sum(1), p_xa.sum(0)
    e = expected(q, g)
    out: dict = {"e": e}
    local = (-1.0, None)
    sup = (-1.0, None)
    eo = (-1.0, None)
    for x in range(X):
        groups = [a for a in range(A) if present[x, a]]
        if px[x] == 0 or len(groups) < 2:
            continue
        hi = max(groups, key=lambda a: (e[x, a], -a))  # the first largest
        lo = min(groups, key=lambda a: (e[x, a], a))  # the first smallest
        r = _ratio(e[x, hi], e[x, lo])
        if r > local[0]:
            local = (r, (x, hi, lo))
        for u in range(K):
            top = max(groups, key=lambda a: (q[x, a, u], -a))
            bot = min(groups, key=lambda a: (q[x, a, u], a))
            r = _ratio(q[x, top, u], q[x, bot, u])
            if r > sup[0]:
                sup = (r, (x, top, bot, u))
        for a, b in itertools.combinations(groups, 2):
            tv = float(np.clip(q[x, a] - q[x, b], 0.0, None).sum())
            if tv > eo[0] + 1e-12:  # the next context must beat it by more than rounding
                eo = (tv, (x, a, b))
    out["local"], out["sup_local"], out["equalized_odds"] = local, sup, eo
    w = np.where(pa > 0, p_xa / np.where(pa > 0, pa, 1.0), 0.0)
    eg = np.zeros(A)
    for x in range(X):  # context after context
        eg = eg + w[x] * np.where(present[x], e[x], 0.0)
    out["eg"] = eg
    dist = np.zeros((A, K))
    for x in range(X):  # context after context
        dist = dist + w[x][:, None] * np.where(present[x][:, None], q[x], 0.0)
    out["dist"] = dist
    live = [a for a in range(A) if pa[a] > 0]
    if len(live) >= 2:
        hi = max(live, key=lambda a: (eg[a], -a))
        lo = min(live, key=lambda a: (eg[a], a))
        out["global"] = (_ratio(eg[hi], eg[lo]), (hi, lo))
    return out


def check(law: Law, g: fa.Utility, pop: Population) -> None:
    want = reference(np.asarray(law.probabilities), np.asarray(g.values), pop.probabilities)
    got = metrics.all_metrics(law, g, pop)
    xs, gs, us = law.contexts, law.groups, law.decisions
    assert np.array_equal(got["local"].expected_utility, want["e"], equal_nan=True)  # to the last bit
    if len(gs) < 2:  # nothing to compare: every metric is 0
        assert all(r.value == 0.0 and r.group is None for r in got.values())
        return
    ratio, cells = want["local"]
    loc = got["local"]
    if cells is None:
        assert math.isnan(loc.value)
    else:
        x, a, b = cells
        assert loc.ratio == ratio and (loc.context, loc.group, loc.other_group) == (xs[x], gs[a], gs[b])
        assert loc.value == float(np.log(ratio))
    glob = got["global"]
    eg = np.where(pop.p_group > 0, want["eg"], np.nan)
    assert np.array_equal(glob.expected_utility, eg, equal_nan=True)  # the sum in context order, to the last bit
    dist = np.where(pop.p_group[:, None] > 0, want["dist"], np.nan)
    assert np.array_equal(reductions.group_decision_law(law, pop), dist, equal_nan=True)  # the same, per decision
    if "global" in want:
        ratio, (a, b) = want["global"]
        assert glob.ratio == ratio and (glob.group, glob.other_group) == (gs[a], gs[b])
    ratio, cells = want["sup_local"]
    sup = got["sup_local"]
    if cells is None:
        assert math.isnan(sup.value)
    else:
        x, a, b, u = cells
        assert sup.ratio == ratio
        assert (sup.context, sup.group, sup.other_group, sup.decision) == (xs[x], gs[a], gs[b], us[u])
    check_equalized_odds(law, pop, got["equalized_odds"], *want["equalized_odds"])
    for name, r in got.items():  # one function at a time: the same numbers
        single = {
            "local": lambda: fa.local_fairness(law, g, pop),
            "global": lambda: fa.global_fairness(law, g, pop),
            "demographic_parity": lambda: fa.demographic_parity(law, pop),
            "equalized_odds": lambda: fa.equalized_odds(law, pop),
            "sup_local": lambda: fa.sup_local_fairness(law, pop),
            "sup_global": lambda: fa.sup_global_fairness(law, pop),
        }[name]()
        assert single.value == r.value or (math.isnan(single.value) and math.isnan(r.value)), name
        assert (single.context, single.group, single.other_group) == (r.context, r.group, r.other_group), name


def check_equalized_odds(law: Law, pop: Population, eo, largest: float, cells) -> None:
    """L_eo against the loop's largest TV; its context is the first maximum of the per-context TV of every
    context (the events route on the whole law, no bound), and its value the pairwise TV there."""
    if cells is None:
        assert math.isnan(eo.value)
        return
    q = np.asarray(law.probabilities)
    per_context = tv_chunk(np.ascontiguousarray(q.transpose(2, 1, 0)), nan=not law.complete)
    per_context[pop.p_context == 0] = np.nan
    x = law.contexts.index(eo.context)
    assert x == int(np.nanargmax(per_context))
    present = [a for a in range(q.shape[1]) if not np.isnan(q[x, a, 0])]
    pairwise = max(float(np.clip(q[x, a] - q[x, b], 0.0, None).sum()) for a, b in itertools.combinations(present, 2))
    assert eo.value == pairwise and eo.value == pytest.approx(largest, abs=1e-12)


@st.composite
def laws(draw):
    """A law of up to 300 contexts (several chunks of 64), with zeros, ties, maybe empty cells, and g, P(X, A)."""
    X, A, K = draw(st.integers(1, 300)), draw(st.integers(1, 4)), draw(st.integers(1, 5))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    counts = rng.choice([0, 0, 1, 2, 5], size=(X, A, K))  # zeros: c/0 and 0/0 ratios; few values: ties
    counted = draw(st.booleans())
    if counted:
        counts = counts * (rng.random((X, A, 1)) < 0.8)
        counts[0, :, 0] += 1  # one context with every group
        law = Law.from_counts(counts, range(X), [f"a{i}" for i in range(A)], [f"u{i}" for i in range(K)])
    else:
        counts[counts.sum(-1) == 0, 0] = 1
        q = counts / counts.sum(-1, keepdims=True)
        law = Law(q, np.arange(X) * 3, [f"a{i}" for i in range(A)], [f"u{i}" for i in range(K)])
    kind = draw(st.sampled_from(["indicator", "vector", "zeros", "table"]))
    if kind == "indicator":
        g = fa.indicator(law.decisions[rng.integers(K)], law.decisions)
    elif kind == "vector":
        g = fa.from_table(rng.choice([0.0, 1.0, 0.3, 2.5], size=K), law.decisions)
    elif kind == "zeros":
        g = fa.from_table(np.zeros(K), law.decisions)
    else:
        g = fa.from_table(rng.choice([0.0, 1.0, 0.7], size=(X, A, K)), law.decisions, law.contexts, law.groups)
    p = rng.random((X, A)) * law.observed * (rng.random((X, 1)) < 0.9)
    if A > 1 and draw(st.booleans()):
        p[:, rng.integers(A)] = 0.0  # a group with P(a) = 0
    if p.sum() == 0:
        p = law.observed.astype(float)
    return law, g, Population(p / p.sum(), law.context_labels, law.group_labels)


@pytest.mark.slow
@given(laws())
def test_every_metric_against_loops_over_contexts_in_chunks_of_64(case):
    law, g, pop = case
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(reductions, "_CHUNK_BYTES", 1)  # 64 contexts per chunk
        check(law, g, pop)


def test_infinite_and_undefined_ratios_and_the_first_of_ties():
    # x0: 0/0 in every decision (ratio 1); x1: 0.5/0.5; x2: E[g | b] = 0 < E[g | a] (inf); x3: inf again (tie:
    # x2 is the first); x4, x5: the groups are equal.
    q = np.array(
        [
            [[0.0, 1.0], [0.0, 1.0]],
            [[0.5, 0.5], [0.5, 0.5]],
            [[0.4, 0.6], [0.0, 1.0]],
            [[0.9, 0.1], [0.0, 1.0]],
            [[0.3, 0.7], [0.3, 0.7]],
            [[0.3, 0.7], [0.3, 0.7]],
        ]
    )
    law = Law(np.repeat(q, 100, axis=0), range(600), ["a", "b"], ["yes", "no"])  # every 100th is a new kind
    g = fa.indicator("yes", law.decisions)
    pop = Population.uniform(law.context_labels, law.group_labels)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(reductions, "_CHUNK_BYTES", 1)
        check(law, g, pop)
        loc = fa.local_fairness(law, g, pop)
    assert loc.value == math.inf and (loc.context, loc.group, loc.other_group) == (200, "a", "b")
    assert loc.per_context[:100].tolist() == [0.0] * 100 and loc.per_context[300] == math.inf
    sup = fa.sup_local_fairness(law, pop)
    assert (sup.value, sup.context, sup.decision) == (math.inf, 200, "yes")
    # every context excluded but one equal pair: L = 0 there; none left: NaN
    p = np.zeros((600, 2))
    p[450] = 0.5
    only = Population(p, law.context_labels, law.group_labels)
    assert fa.local_fairness(law, g, only).value == 0.0 and fa.local_fairness(law, g, only).context == 450
    assert fa.sup_local_fairness(law, only).context == 450 and fa.equalized_odds(law, only).context == 450


def test_a_context_with_one_group_of_records_is_left_out():
    counts = np.zeros((200, 3, 2))
    counts[:, :, 0] = 1
    counts[150, 1] = [0, 4]  # the largest gap, in the third chunk
    counts[100, 1:] = 0  # one group with records: no ratio there
    law = Law.from_counts(counts, range(200), GROUPS, ["y", "n"])
    g = fa.indicator("y", law.decisions)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(reductions, "_CHUNK_BYTES", 1)
        check(law, g, default_population(law))
        loc = fa.local_fairness(law, g)
    assert math.isnan(loc.per_context[100]) and loc.context == 150 and loc.value == math.inf
    assert "context '100': fewer than two groups with records" in loc.excluded


@pytest.mark.parametrize("route", ["events", "pairs"])
def test_the_largest_tv_is_found_where_the_bounds_leave_many_contexts(route, monkeypatch):
    """Deterministic rows: TV = 1 in many contexts (every bound reaches it); the first is reported."""
    rng = np.random.default_rng(8)
    X, A, K = 500, 4, 3
    q = np.eye(K)[rng.integers(0, K, size=(X, A))]
    q[:37] = q[:37, :1]  # the first contexts are fair (TV 0)
    q[200:300] *= 1.0 - 9e-10  # rows summing to 1 − 9e-10 ...
    q[300:] *= 1.0 + 9e-10  # ... and 1 + 9e-10: the bounds near the tolerance
    law = Law(q, range(X), [f"a{i}" for i in range(A)], [f"u{i}" for i in range(K)])
    monkeypatch.setattr(reductions, "_CHUNK_BYTES", 1)
    if route == "pairs":
        monkeypatch.setattr(total_variation, "use_events", lambda A, K: False)
    eo = fa.equalized_odds(law)
    per_context = tv_chunk(np.ascontiguousarray(q.transpose(2, 1, 0)), nan=False)
    assert eo.context == int(np.argmax(per_context)) and eo.value == pytest.approx(1.0, abs=1e-8)


def test_near_ties_of_tv_between_chunks_pick_the_first_maximum(monkeypatch):
    rng = np.random.default_rng(4)
    q = rng.dirichlet(np.ones(4), size=(400, 3)) * 0.5
    q[:, :, 3] += 0.5  # every TV below 0.5 ...
    for x, eps in ((70, 0.0), (130, 1e-15), (330, -1e-15), (390, 0.0)):  # ... but these four, within 1e-15
        q[x] = [[0.7 + eps, 0.1, 0.1, 0.1 - eps], [0.1, 0.1, 0.1, 0.7], [0.25, 0.25, 0.25, 0.25]]
    law = Law(q, range(400), GROUPS, DECISIONS)
    monkeypatch.setattr(reductions, "_CHUNK_BYTES", 1)
    per_context = tv_chunk(np.ascontiguousarray(q.transpose(2, 1, 0)), nan=False)
    assert fa.equalized_odds(law).context == int(np.argmax(per_context))


@pytest.mark.parametrize("chunk", [1, 1 << 12, 1 << 19])
def test_group_means_are_the_whole_arrays_einsum(chunk, monkeypatch):
    """E[g | a] adds the contexts one after the other: the sum einsum makes on the whole arrays."""
    rng = np.random.default_rng(chunk)
    law = Law(dirichlet(3000, 5, 6, seed=1), range(3000), list("abcde"), list("uvwxyz"))
    g = fa.from_table(rng.random(6), law.decisions)
    pop = Population(rng.dirichlet(np.ones(15000)).reshape(3000, 5), law.context_labels, law.group_labels)
    monkeypatch.setattr(reductions, "_CHUNK_BYTES", chunk)
    got = fa.global_fairness(law, g, pop).expected_utility
    e = fa.expected_utility(law, g)
    assert np.array_equal(got, np.einsum("xa,xa->a", pop.context_given_group(), e))
    assert np.array_equal(e, expected(law.probabilities, g.values))


# --------------------------------------------------------------------------- helpers


def _two_wheres(vmax, vmin, count):
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(vmax == 0, 1.0, np.where(vmin == 0, np.inf, vmax / vmin))
    return np.where(count >= 2, ratio, np.nan)


def test_ratio_of_extremes_gives_what_its_definition_gives():
    rng = np.random.default_rng(0)
    values = np.array([0.0, -0.0, 1.0, 2.5, np.inf, np.nan, 1e-320, 3.0])
    for dtype in (np.float64, np.float32, np.int64):
        for _ in range(100):
            n = int(rng.integers(1, 6))
            a, b = rng.choice(values, size=n), rng.choice(values, size=n)
            if dtype is np.int64:
                a, b = np.nan_to_num(a, nan=0, posinf=9), np.nan_to_num(b, nan=0, posinf=9)
            a, b = a.astype(dtype), b.astype(dtype)
            for count in (2, 1, np.int64(3), True, rng.integers(0, 4, size=n), rng.integers(0, 4, size=(2, n))):
                for x, y in ((a, b), (a[0], b[0]), (a, b[:1])):
                    with np.errstate(over="ignore"):
                        want, got = _two_wheres(x, y, count), ratio_of_extremes(x, y, count)
                    assert type(got) is type(want) and got.dtype == want.dtype and got.shape == want.shape
                    assert np.array_equal(got, want, equal_nan=True)


def test_first_max_is_nanargmax():
    rng = np.random.default_rng(1)
    for _ in range(400):
        v = rng.choice([np.nan, 1.0, 2.0, np.inf, -np.inf, 0.0, -0.0], size=int(rng.integers(1, 9)))
        want = None if np.isnan(v).all() else int(np.nanargmax(v))
        assert first_max(v) == want
    assert first_max(np.array([])) is None


def test_the_pass_keeps_no_temporary_of_the_tables_size():
    n = 100_000
    law = Law(dirichlet(n, 8, 4), range(n), [f"g{i}" for i in range(8)], DECISIONS)
    pop = Population.uniform(law.context_labels, law.group_labels)
    g = fa.from_table([0.3, 1.0, 0.2, 0.5], DECISIONS)
    for fn, bound in (
        (lambda: (fa.local_fairness(law, g, pop), fa.global_fairness(law, g, pop)), 0.85),
        (lambda: observe(law, g, pop), 0.7),
        (lambda: Law(law.probabilities, law.context_labels, law.group_labels, law.decision_labels), 0.1),
    ):
        fn()
        tracemalloc.start()
        try:
            fn()
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        # E (n x 8, a quarter of the table) is kept by a local result; L-bar holds E and P(x | a) (a quarter each)
        # while it adds them up; the rest is per chunk or per context (L's ratios: 1/32 of the table; the extremes
        # of every metric: 3/32)
        assert peak <= bound * law.probabilities.nbytes, (peak, law.probabilities.nbytes)


def test_e_and_the_per_context_logs_are_the_definitions_numbers():
    import copy
    import dataclasses
    import pickle

    n = 300
    q = dirichlet(n, 3, 4, seed=7)
    q[5, 1] = [0.0, 0.0, 0.5, 0.5]  # E = 0 for one group: an infinite ratio
    law = Law(q, range(n), GROUPS, DECISIONS)
    g = fa.from_table([0.3, 1.0, 0.0, 0.0], DECISIONS)
    e = q @ np.array([0.3, 1.0, 0.0, 0.0])
    with np.errstate(divide="ignore"):
        want = np.log(e.max(axis=1) / e.min(axis=1))  # an independent route: the definition
    for r in (fa.local_fairness(law, g), observe(law, g, None).local_fairness):
        np.testing.assert_allclose(r.per_context, want, rtol=1e-14)
        assert r.per_context[5] == math.inf
        assert np.array_equal(r.expected_utility, expected(q, g.values))  # the loop's E, bit for bit
        assert np.array_equal(r.expected_utility, fa.expected_utility(law, g)) and r.expected_utility.shape == (n, 3)
        for other in (pickle.loads(pickle.dumps(r)), copy.deepcopy(r), dataclasses.replace(r, value=1.0)):
            assert other.per_context.tolist() == r.per_context.tolist()
            assert np.array_equal(other.expected_utility, r.expected_utility)
        with pytest.raises(dataclasses.FrozenInstanceError):
            r.per_context = np.zeros(n)  # type: ignore[misc]
    assert fa.global_fairness(law, g).per_context is None
