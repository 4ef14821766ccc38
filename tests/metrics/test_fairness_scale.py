"""The core at scale: one chunked pass over a law, the lazy identity, deduplicated beta quantiles.

Every fast route is checked against an independent slow one on the same
input: metrics against a per-context, per-pair loop written here from the
definitions (paper SI A and B), TV by events against TV by pairs, several
chunks against one, the lazy identity against a dense identity matrix, and
the deduplicated Clopper–Pearson quantiles against scipy called per cell.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

import fairaudit as fa
from fairaudit import IntervalOptions
from fairaudit.base.errors import InputError
from fairaudit.base.labels import as_labels
from fairaudit.data.counts import CountTable
from fairaudit.laws.closed_forms import randomized_response
from fairaudit.laws.composition import compose
from fairaudit.laws.mechanisms import from_matrix, identity
from fairaudit.laws.tables import Kernel, Law, Population
from fairaudit.metrics import fairness as metrics
from fairaudit.metrics import reductions, total_variation
from fairaudit.metrics.observed import observe
from fairaudit.metrics.total_variation import tv_chunk, use_events
from fairaudit.statistics.confidence_sets import clopper_pearson
from fairaudit.statistics.intervals import fairness_intervals
from fairaudit.worstcase.known_utility import worst_model

# --------------------------------------------------------------------------- a reference from the definitions


def _ratio(hi: float, lo: float) -> float:
    return 1.0 if hi == 0 else math.inf if lo == 0 else hi / lo


def reference(q: np.ndarray, g: np.ndarray, p_xa: np.ndarray) -> dict:
    """Every metric by loops over contexts and ordered pairs of groups; NaN rows are empty cells."""
    X, A, K = q.shape
    present = ~np.isnan(q[..., 0])
    px, pa = p_xa.sum(1), p_xa.sum(0)
    e = np.array([[sum(q[x, a, u] * g[u] for u in range(K)) for a in range(A)] for x in range(X)])
    local = sup_local = eo = -math.inf
    for x in range(X):
        if px[x] == 0:
            continue
        for a, b in itertools.permutations(range(A), 2):
            if not (present[x, a] and present[x, b]):
                continue
            local = max(local, _ratio(e[x, a], e[x, b]))
            for u in range(K):
                sup_local = max(sup_local, _ratio(q[x, a, u], q[x, b, u]))
            eo = max(eo, sum(max(0.0, q[x, a, u] - q[x, b, u]) for u in range(K)))
    w = np.where(pa > 0, p_xa / np.where(pa > 0, pa, 1), 0.0)
    eg = [sum(w[x, a] * e[x, a] for x in range(X) if present[x, a]) for a in range(A)]
    dist = [[sum(w[x, a] * q[x, a, u] for x in range(X) if present[x, a]) for u in range(K)] for a in range(A)]
    glob = sup_glob = dp = -math.inf
    for a, b in itertools.permutations(range(A), 2):
        if pa[a] == 0 or pa[b] == 0:
            continue
        glob = max(glob, _ratio(eg[a], eg[b]))
        for u in range(K):
            sup_glob = max(sup_glob, _ratio(dist[a][u], dist[b][u]))
        dp = max(dp, sum(max(0.0, dist[a][u] - dist[b][u]) for u in range(K)))
    log = lambda r: math.log(r) if r > -math.inf else math.nan  # noqa: E731
    return {
        "local": log(local),
        "global": log(glob),
        "sup_local": log(sup_local),
        "sup_global": log(sup_glob),
        "equalized_odds": eo if eo > -math.inf else math.nan,
        "demographic_parity": dp,
    }


def _close(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b or math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


@st.composite
def counted_laws(draw):
    """A law estimated from counts (some cells empty) and a population that weighs no empty cell."""
    X, A, K = draw(st.integers(1, 40)), draw(st.integers(2, 5)), draw(st.integers(1, 6))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, 4, size=(X, A, K)) * (rng.random((X, A, 1)) < 0.85)
    counts[0, :, 0] += 1  # at least one full context
    law = Law.from_counts(counts, range(X), [f"a{i}" for i in range(A)], [f"u{i}" for i in range(K)])
    p = rng.random((X, A)) * (counts.sum(-1) > 0) * (rng.random((X, 1)) < 0.9)
    p[0] += 0.1
    g = np.round(rng.random(K) * draw(st.sampled_from([1.0, 3.0])), 1)
    return law, fa.from_table(g, law.decisions), Population(p / p.sum(), law.contexts, law.groups)


@pytest.mark.slow
@given(counted_laws())
def test_every_metric_matches_the_definitions(case):
    law, g, pop = case
    want = reference(np.asarray(law.probabilities), np.asarray(g.values), pop.probabilities)
    got = metrics.all_metrics(law, g, pop)
    for name, value in want.items():
        assert _close(got[name].value, value), (name, got[name].value, value)
    one_by_one = {
        "local": fa.local_fairness(law, g, pop),
        "global": fa.global_fairness(law, g, pop),
        "demographic_parity": fa.demographic_parity(law, pop),
        "equalized_odds": fa.equalized_odds(law, pop),
        "sup_local": fa.sup_local_fairness(law, pop),
        "sup_global": fa.sup_global_fairness(law, pop),
    }
    for name, r in one_by_one.items():  # the same code: equal to the last bit, the same cells
        assert r.value == got[name].value or (math.isnan(r.value) and math.isnan(got[name].value)), name
        assert (r.context, r.group, r.other_group) == (got[name].context, got[name].group, got[name].other_group)


def test_many_chunks_give_the_one_chunk_answer(monkeypatch):
    rng = np.random.default_rng(3)
    q = rng.dirichlet(np.ones(4), size=(5000, 6))
    q[1234, 2] = [0.0, 0.0, 0.0, 1.0]  # the most unfair context sits inside a middle chunk
    q[1234, 4] = [0.97, 0.01, 0.01, 0.01]  # TV = 1 - 0.01 = 0.99 on the event {z}
    law = Law(q, range(5000), list("abcdef"), list("wxyz"))
    g = fa.from_table([1.0, 0.0, 0.2, 0.5], law.decisions)
    one = metrics.all_metrics(law, g)
    monkeypatch.setattr(reductions, "_CHUNK_BYTES", 1)  # 64 contexts per chunk: 79 chunks
    many = metrics.all_metrics(law, g)
    for name in one:
        assert math.isclose(one[name].value, many[name].value, rel_tol=1e-14, abs_tol=1e-15), name
        assert one[name].context == many[name].context
    assert many["equalized_odds"].context == 1234 and many["equalized_odds"].value == pytest.approx(0.99, abs=1e-15)
    assert (many["equalized_odds"].group, many["equalized_odds"].other_group) == ("c", "e")


@pytest.mark.parametrize("K", [1, 2, 3, 5, 9])
def test_tv_by_events_equals_tv_by_pairs(K, monkeypatch):
    rng = np.random.default_rng(K)
    q = rng.dirichlet(np.ones(K), size=(300, 4))
    q[7, 1] = np.nan  # an empty cell: ignored by both routes
    ct = np.ascontiguousarray(q.transpose(2, 1, 0))
    by_events = tv_chunk(ct, nan=True) if use_events(4, K) else None
    monkeypatch.setattr(total_variation, "use_events", lambda A, K: False)
    by_pairs = tv_chunk(ct, nan=True)
    monkeypatch.setattr(total_variation, "use_events", lambda A, K: True)
    forced = tv_chunk(ct, nan=True)
    direct = np.array(
        [
            max(
                np.clip(q[x, a] - q[x, b], 0, None).sum()
                for a in range(4)
                for b in range(4)
                if a != b and not np.isnan(q[x, a, 0]) and not np.isnan(q[x, b, 0])
            )
            for x in range(300)
        ]
    )
    np.testing.assert_allclose(by_pairs, direct, rtol=0, atol=1e-15)
    np.testing.assert_allclose(forced, direct, rtol=0, atol=1e-15)
    if by_events is not None:
        np.testing.assert_allclose(by_events, direct, rtol=0, atol=1e-15)


def test_a_fair_law_is_exactly_fair():
    """Equal rows and P(x | a) the same numbers for every group: every gap is exactly 0, not a rounding crumb."""
    rng = np.random.default_rng(5)
    rows = rng.dirichlet(np.ones(3), size=(1000, 1))
    law = Law(np.repeat(rows, 4, axis=1), range(1000), list("abcd"), ["u0", "u1", "u2"])
    pop = Population(np.repeat(rng.dirichlet(np.ones(1000))[:, None] / 4, 4, axis=1), law.contexts, law.groups)
    m = metrics.all_metrics(law, fa.from_table([0.3, 1.0, 0.7], law.decisions), pop)
    assert {k: r.value for k, r in m.items()} == dict.fromkeys(m, 0.0)


# --------------------------------------------------------------------------- the lazy identity


@pytest.mark.slow
def test_identity_on_a_million_contexts_is_never_materialised():
    contexts = range(10**6)
    ident = identity(contexts)
    assert ident.is_identity and ident.epsilon == math.inf and len(ident.outputs) == 10**6
    rr = randomized_response(["a", "b"], keep=0.75)
    k = np.zeros((10**6, 2, 2))
    k[:, 0, 0] = k[:, 1, 1] = 1.0  # answers the released group
    law = compose(Kernel(k, ident.outputs, ["a", "b"], ["yes", "no"]), rr, ident)
    assert "matrix" not in ident.__dict__
    assert law.probabilities[123456].tolist() == [[0.75, 0.25], [0.25, 0.75]]
    w = worst_model(rr, fa.indicator("yes", ["yes", "no"]), context_mechanism=ident)
    assert "matrix" not in ident.__dict__
    assert w.local_fairness.ratio == pytest.approx(3.0, rel=1e-14) and w.global_fairness.ratio == pytest.approx(
        3.0, rel=1e-14
    )
    assert w.local_fairness.context == 0 and w.local_fairness.kernel.shape == (10**6, 2, 2)


def test_lazy_identity_agrees_with_a_dense_identity_matrix():
    contexts, groups = ["x0", "x1", "x2"], ["a", "b", "c"]
    rng = np.random.default_rng(11)
    kernel = Kernel(rng.dirichlet(np.ones(3), size=(3, 3)), contexts, groups, ["u0", "u1", "u2"])
    dense = from_matrix(np.eye(3), contexts, name="dense")
    mech = randomized_response(groups, epsilon=0.8)
    assert dense.is_identity and np.array_equal(identity(contexts).matrix, np.eye(3))
    np.testing.assert_array_equal(
        compose(kernel, mech, identity(contexts)).probabilities, compose(kernel, mech, dense).probabilities
    )
    g = fa.from_table(
        [[[1.0, 0.2, 0.5]] * 3, [[0.4, 0.9, 0.1]] * 3, [[1.0, 0.2, 0.5]] * 3], ["u0", "u1", "u2"], contexts, groups
    )
    pop = Population(rng.dirichlet(np.ones(9)).reshape(3, 3), contexts, groups)
    for kw in ({}, {"tau": 0.3}):
        lazy = worst_model(mech, g, context_mechanism=identity(contexts), population=pop, **kw)
        full = worst_model(mech, g, context_mechanism=from_matrix(np.eye(3), contexts), population=pop, **kw)
        for case in ("local_fairness", "global_fairness"):
            a, b = getattr(lazy, case), getattr(full, case)
            assert a.ratio == pytest.approx(b.ratio, rel=1e-9) and (a.context, a.group, a.other_group) == (
                b.context,
                b.group,
                b.other_group,
            )


# --------------------------------------------------------------------------- labels and beta quantiles


def test_labels_from_numpy_and_repeats():
    assert as_labels(np.arange(3), "f") == (0, 1, 2) and type(as_labels(np.arange(3), "f")[0]) is int
    assert as_labels(np.array([[1, 2], [3, 4]]), "f") == ((1, 2), (3, 4))
    big = tuple(range(5000))
    assert as_labels(big, "f") is big and as_labels(big, "f") is big  # remembered: checked once
    with pytest.raises(InputError, match=r"repeated label \(got 7\)|repeated label.*7"):
        as_labels(list(range(5000)) + [7], "contexts")


def test_deduplicated_clopper_pearson_equals_scipy_per_cell():
    rng = np.random.default_rng(2)
    n = rng.integers(0, 30, size=2000)
    k = (rng.random(2000) * (n + 1)).astype(int)
    lo, hi = clopper_pearson(k, n, 0.05)
    for i in range(0, 2000, 97):
        want_lo = 0.0 if k[i] == 0 else stats.beta.ppf(0.025, k[i], n[i] - k[i] + 1)
        want_hi = 1.0 if k[i] == n[i] else stats.beta.isf(0.025, k[i] + 1, n[i] - k[i])
        if n[i] == 0:
            assert np.isnan(lo[i]) and np.isnan(hi[i])
        else:
            assert lo[i] == want_lo and hi[i] == want_hi


def test_intervals_on_many_contexts_contain_the_estimate():
    rng = np.random.default_rng(9)
    q = rng.dirichlet(np.ones(3), size=(20000, 3))
    counts = rng.multinomial(30, q.reshape(-1, 3)).reshape(q.shape)
    table = CountTable(counts, tuple(range(20000)), ("a", "b", "c"), ("u0", "u1", "u2"), ("x",), ("s",), "u")
    iv = fairness_intervals(table, fa.indicator("u1", table.decisions), IntervalOptions(confidence=0.9))
    obs = observe(table.law(), fa.indicator("u1", table.decisions), table.population())
    assert iv.global_fairness.lower <= obs.global_fairness.value <= iv.global_fairness.upper
    assert iv.global_fairness.estimate == pytest.approx(obs.global_fairness.value, rel=1e-12)


@given(st.integers(1, 30), st.integers(1, 6), st.integers(0, 2**32 - 1))
def test_disjoint_ratio_equals_the_search_over_every_pair(M, A, seed):
    """The upper end and its pair against the (M, A, A) search over ordered pairs it replaced (ties included)."""
    from fairaudit.metrics.box_extremes import disjoint_ratio as _disjoint_ratio
    from fairaudit.metrics.box_extremes import div as _div

    rng = np.random.default_rng(seed)
    lo = rng.choice([0.0, 0.1, 0.2, 0.5], size=(M, A))  # few values: many ties and zeros
    hi = lo + rng.choice([0.0, 0.1, 0.3], size=(M, A))
    lo[rng.random((M, A)) < 0.2] = np.nan
    valid = ~np.isnan(lo)
    R = _div(np.nan_to_num(hi)[:, :, None], np.nan_to_num(lo)[:, None, :])
    R = np.where(valid[:, :, None] & valid[:, None, :] & ~np.eye(A, dtype=bool), R, -np.inf).reshape(M, -1)
    idx = R.argmax(-1)
    want = np.where(valid.sum(-1) >= 2, R[np.arange(M), idx], np.nan)
    lower, upper, fav, oth = _disjoint_ratio(lo, hi)
    np.testing.assert_array_equal(upper, want)
    ok = valid.sum(-1) >= 2
    np.testing.assert_array_equal((fav * A + oth)[ok], idx[ok])
