"""Exact fairness metrics: L and L̄, their exclusions and conventions, and every metric against fairlearn.

Expected values: exact ``Fraction`` arithmetic with explicit loops over every
pair of groups (the package takes max/min per context instead), hand
calculations in comments, fairlearn (selection-rate ratios and differences).
The gaps L_dp and L_eo are tested in ``test_parity.py``, the sups over g
(Lemma 1, and AIF360's smoothed empirical differential fairness) in
``test_sup_fairness.py``, E[g | x, a] in ``test_reductions.py``.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction as F

import numpy as np
import pandas as pd
import pytest
from _rational_law import (
    CONTEXTS,
    DECISIONS,
    GROUPS,
    P_X,
    G,
    Q,
    argmax_set,
    fr_expected,
    laws,
    rational_law,
    rational_population,
)
from hypothesis import given

import fairaudit as fa


def test_local_fairness_by_fractions():
    e = fr_expected()
    best, keys = argmax_set(
        [(e[x][a] / e[x][b], (x, a, b)) for x in range(2) for a, b in itertools.permutations(range(3), 2)]
    )
    # Hand: x0: (4/3)/(4/5) = 5/3; x1: (21/10)/(5/4) = 42/25 = 1.68 > 5/3. L = log(42/25) at x1, a over b.
    assert best == F(42, 25) and keys == {(1, 0, 1)}
    r = fa.local_fairness(rational_law(), fa.from_table([float(v) for v in G], DECISIONS), rational_population())
    assert r.value == pytest.approx(math.log(F(42, 25)), rel=1e-12)
    assert r.ratio == pytest.approx(float(best), rel=1e-12)
    assert (r.context, r.group, r.other_group) == ("x1", "a", "b")
    assert r.per_context == pytest.approx(np.array([math.log(5 / 3), math.log(42 / 25)]), rel=1e-12)
    assert r.excluded == ()


def test_global_fairness_by_fractions():
    e = fr_expected()
    eg = [sum(P_X[x] * e[x][a] for x in range(2)) for a in range(3)]
    # Hand: E[g|a] = 1/3·1 + 2/3·21/10 = 26/15; E[g|b] = 1/3·4/3 + 2/3·5/4 = 23/18; E[g|c] = 1/3·4/5 + 2/3·11/8 = 71/60.
    assert eg == [F(26, 15), F(23, 18), F(71, 60)]
    best, keys = argmax_set([(eg[a] / eg[b], (a, b)) for a, b in itertools.permutations(range(3), 2)])
    assert best == F(104, 71) and keys == {(0, 2)}
    r = fa.global_fairness(rational_law(), fa.from_table([float(v) for v in G], DECISIONS), rational_population())
    assert r.value == pytest.approx(math.log(F(104, 71)), rel=1e-12)
    assert (r.context, r.group, r.other_group) == (None, "a", "c")
    assert r.expected_utility == pytest.approx(np.array(eg, dtype=float), rel=1e-12)
    # The population matters: uniform weights give E[g|a] = (1 + 21/10)/2 = 31/20, E[g|c] = (4/5 + 11/8)/2 = 87/80.
    uni = fa.global_fairness(rational_law(), fa.from_table([float(v) for v in G], DECISIONS))
    eg_u = [sum(e[x][a] for x in range(2)) / 2 for a in range(3)]
    best_u, _ = argmax_set([(eg_u[a] / eg_u[b], (a, b)) for a, b in itertools.permutations(range(3), 2)])
    assert uni.value == pytest.approx(math.log(best_u), rel=1e-12)
    assert uni.value != pytest.approx(r.value, rel=1e-6)


def test_group_dependent_utility_by_fractions():
    # g[x, a, u] = (u index + 1) · (1 + a index): depends on the group.
    gt = [[[F(u + 1) * (1 + a) for u in range(3)] for a in range(3)] for _ in range(2)]
    e = [[sum(Q[x][a][u] * gt[x][a][u] for u in range(3)) for a in range(3)] for x in range(2)]
    best, keys = argmax_set(
        [(e[x][a] / e[x][b], (x, a, b)) for x in range(2) for a, b in itertools.permutations(range(3), 2)]
    )
    g = fa.from_table(np.array(gt, dtype=float), DECISIONS, CONTEXTS, GROUPS)
    r = fa.local_fairness(rational_law(), g)
    assert r.value == pytest.approx(math.log(best), rel=1e-12)
    assert (CONTEXTS.index(r.context), GROUPS.index(r.group), GROUPS.index(r.other_group)) in keys


# --------------------------------------------------------------------------- zero conventions and exclusions


def test_zero_over_zero_is_parity_and_c_over_zero_is_inf():
    g = fa.indicator("y", ["y", "n"])
    # Context x0: nobody gets y (0/0 -> ratio 1, value 0). Context x1: a gets y with 0.5, b never (c/0 -> inf).
    law = fa.Law([[[0.0, 1.0], [0.0, 1.0]], [[0.5, 0.5], [0.0, 1.0]]], ["x0", "x1"], ["a", "b"], ["y", "n"])
    r = fa.local_fairness(law, g)
    assert r.per_context[0] == 0.0 and r.per_context[1] == math.inf
    assert r.value == math.inf and (r.context, r.group, r.other_group) == ("x1", "a", "b")
    only_x0 = fa.Law([[[0.0, 1.0], [0.0, 1.0]]], ["x0"], ["a", "b"], ["y", "n"])
    assert fa.local_fairness(only_x0, g).value == 0.0
    assert fa.global_fairness(only_x0, g).value == 0.0
    assert fa.sup_local_fairness(law).value == math.inf
    # sup over g of the all-zero-on-y context: decision n has 1/1, decision y has 0/0 = parity.
    assert fa.sup_local_fairness(only_x0).value == 0.0


def test_empty_cells_are_excluded_and_listed():
    counts = [[[3, 1], [0, 0], [1, 1]], [[2, 2], [1, 3], [0, 4]]]
    law = fa.Law.from_counts(counts, ["x0", "x1"], ["a", "b", "c"], ["y", "n"])
    g = fa.indicator("y", ["y", "n"])
    r = fa.local_fairness(law, g)
    # Hand: x0 (b empty): a 3/4, c 1/2 -> 3/2; x1: a 1/2, b 1/4, c 0 -> inf (a over c).
    assert r.per_context[0] == pytest.approx(math.log(1.5), rel=1e-12)
    assert r.value == math.inf and (r.context, r.group, r.other_group) == ("x1", "a", "c")
    assert "cell (context 'x0', group 'b'): no records" in r.excluded
    assert np.isnan(r.expected_utility[0, 1])
    # A population that weights the empty cell is an error; the empirical one gives it weight 0.
    with pytest.raises(fa.InputError, match=r"empty cell \(context 'x0', group 'b'\)"):
        fa.global_fairness(law, g, fa.Population.uniform(["x0", "x1"], ["a", "b", "c"]))
    pop = fa.Population.from_counts(np.array(counts).sum(-1), ["x0", "x1"], ["a", "b", "c"])
    glob = fa.global_fairness(law, g, pop)
    # Hand: E[g|a] = (3 + 2)/8 = 5/8, E[g|b] = 1/4 (x1 only), E[g|c] = (1 + 0)/6 = 1/6 -> ratio (5/8)/(1/6) = 15/4.
    assert glob.expected_utility == pytest.approx(np.array([5 / 8, 1 / 4, 1 / 6]), rel=1e-12)
    assert glob.value == pytest.approx(math.log(15 / 4), rel=1e-12)
    # A law from counts stands for its records: with no population given, the records' own (issue 19)
    default = fa.global_fairness(law, g)
    assert default.population.source == "records" and default.value == pytest.approx(math.log(15 / 4), rel=1e-12)
    assert fa.sup_local_fairness(law).excluded == r.excluded
    assert "cell (context 'x0', group 'b'): no records" in fa.equalized_odds(law).excluded


def test_context_with_zero_probability_is_excluded():
    law = fa.Law([[[0.9, 0.1], [0.1, 0.9]], [[0.5, 0.5], [0.4, 0.6]]], ["x0", "x1"], ["a", "b"], ["y", "n"])
    g = fa.indicator("y", ["y", "n"])
    pop = fa.Population([[0.0, 0.0], [0.5, 0.5]], ["x0", "x1"], ["a", "b"])
    r = fa.local_fairness(law, g, pop)
    # Without x0 the worst context is x1: 0.5 / 0.4 = 5/4.
    assert r.value == pytest.approx(math.log(1.25), rel=1e-12) and r.context == "x1"
    assert "context 'x0': P(X = x) = 0" in r.excluded
    assert fa.local_fairness(law, g).value == pytest.approx(math.log(9), rel=1e-12)
    assert fa.equalized_odds(law, pop).value == pytest.approx(0.1, rel=1e-12)


def test_label_mismatch_errors():
    law = rational_law()
    with pytest.raises(fa.InputError, match="population groups"):
        fa.global_fairness(law, fa.indicator("u0", DECISIONS), fa.Population.uniform(CONTEXTS, ["a", "b", "z"]))
    with pytest.raises(fa.InputError, match="utility decisions"):
        fa.local_fairness(law, fa.indicator("u0", ["u0", "u2", "u1"]))
    with pytest.raises(fa.InputError, match="must be a Law"):
        fa.local_fairness(
            fa.Kernel(np.array(Q, dtype=float), CONTEXTS, GROUPS, DECISIONS), fa.indicator("u0", DECISIONS)
        )


# --------------------------------------------------------------------------- property: L̄ ≤ L under X ⊥ A


@pytest.mark.slow
@given(laws())
def test_global_below_local_under_independence(data):
    # Under X ⊥ A, E[g|a] = Σ_x P(x) E[g|x,a] is a mixture with the same weights for every a.
    law, pop, g = data
    glob = fa.global_fairness(law, g, pop).value
    loc = fa.local_fairness(law, g, pop).value
    if math.isnan(loc):
        return
    assert glob <= loc + 1e-12


# --------------------------------------------------------------------------- peer: fairlearn


def law_from_records(context, group, decision, contexts, groups, decisions):
    """Law.from_counts and the empirical Population.from_counts from three label columns."""
    counts = np.zeros((len(contexts), len(groups), len(decisions)))
    for x, a, u in zip(context, group, decision):
        counts[contexts.index(x), groups.index(a), decisions.index(u)] += 1
    law = fa.Law.from_counts(counts, contexts, groups, decisions)
    pop = fa.Population.from_counts(counts.sum(-1), contexts, groups)
    return law, pop


def check_against_fairlearn(y_true, y_pred, group):
    fm = pytest.importorskip("fairlearn.metrics")
    groups = sorted(set(group))
    sel = fa.indicator(1, [1, 0])
    # Demographic parity: one context; L̄ with g = 1{pred = 1} is log(max rate / min rate).
    law, pop = law_from_records(["all"] * len(group), group, y_pred, ["all"], groups, [1, 0])
    ratio = fm.demographic_parity_ratio(y_true, y_pred, sensitive_features=group)
    assert fa.global_fairness(law, sel, pop).value == pytest.approx(-math.log(ratio), rel=1e-12)
    # For a binary decision the TV between two groups is the difference of selection rates.
    diff = fm.demographic_parity_difference(y_true, y_pred, sensitive_features=group)
    assert fa.demographic_parity(law, pop).value == pytest.approx(diff, rel=1e-12)
    # Equalized odds: X = y_true; local L with g = 1{pred = 1} is log max over y of max/min rate within y,
    # and fairlearn's equalized_odds_ratio = min(TPR ratio, FPR ratio), each min/max over groups.
    law, pop = law_from_records(y_true, group, y_pred, [0, 1], groups, [1, 0])
    ratio = fm.equalized_odds_ratio(y_true, y_pred, sensitive_features=group)
    assert fa.local_fairness(law, sel, pop).value == pytest.approx(-math.log(ratio), rel=1e-12)
    diff = fm.equalized_odds_difference(y_true, y_pred, sensitive_features=group)
    assert fa.equalized_odds(law, pop).value == pytest.approx(diff, rel=1e-12)


def test_fairlearn_synthetic():
    rng = np.random.default_rng(11)
    n = 600
    group = rng.choice(["g1", "g2", "g3"], size=n, p=[0.5, 0.3, 0.2]).tolist()
    y_true = rng.integers(0, 2, size=n)
    bias = np.array([{"g1": 0.55, "g2": 0.4, "g3": 0.3}[g] for g in group])
    y_pred = (rng.uniform(size=n) < bias + 0.2 * y_true).astype(int)
    check_against_fairlearn(y_true.tolist(), y_pred.tolist(), group)


def test_fairlearn_compas(shared_data):
    path = shared_data / "compas" / "compas-scores-two-years.csv"
    if not path.exists():
        pytest.skip(f"COMPAS file not found at {path}")
    df = pd.read_csv(path)
    df = df[df["race"].isin(["African-American", "Caucasian"])]
    y_pred = (df["decile_score"] >= 5).astype(int).tolist()
    y_true = df["two_year_recid"].astype(int).tolist()
    check_against_fairlearn(y_true, y_pred, df["race"].tolist())


def test_short_reprs_name_the_value_and_where():
    # by hand: P(hire | day) = 0.6 vs 0.3, night 0.5 vs 0.5; uniform population: 0.55 vs 0.4
    law = fa.Law([[[0.6, 0.4], [0.3, 0.7]], [[0.5, 0.5], [0.5, 0.5]]], ["day", "night"], ["a", "b"], ["hire", "no"])
    assert (
        repr(fa.demographic_parity(law))
        == "TotalVariation(demographic_parity, value=0.15, groups 'a' vs 'b', event=('hire',))"
    )
    assert repr(fa.equalized_odds(law)) == (
        "TotalVariation(equalized_odds, value=0.3, context='day', groups 'a' vs 'b', event=('hire',))"
    )
    assert repr(fa.sup_global_fairness(law)) == (
        "SupFairness(global, value=0.318454 nats, ratio=1.375, groups 'a' vs 'b', decision='hire')"
    )
    assert "law=" not in repr(fa.sup_local_fairness(law))  # the inputs stay out of the repr
