"""Counting records and simultaneous Clopper-Pearson intervals, against pandas and scipy."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binomtest

import fairaudit as fa
from fairaudit import IntervalOptions
from fairaudit.data.counts import count_records
from fairaudit.statistics.intervals import fairness_intervals


def test_counts_match_pandas_crosstab():
    rng = np.random.default_rng(3)
    df = pd.DataFrame(
        {
            "x": rng.choice(["p", "q", "r"], 1000),
            "a": rng.choice([3, 1, 2], 1000),
            "b": rng.choice(["M", "W"], 1000),
            "u": rng.choice([0, 1, 2], 1000),
        }
    )
    t = count_records(df, sensitive=["a", "b"], outcome="u", context=["x"])
    ref = df.groupby(["x", "a", "b", "u"]).size()
    assert t.groups == ((1, "M"), (1, "W"), (2, "M"), (2, "W"), (3, "M"), (3, "W"))
    for (x, a, b, u), n in ref.items():
        assert t.counts[t.contexts.index(x), t.groups.index((a, b)), t.decisions.index(u)] == n
    assert t.n == 1000 and t.counts.sum() == ref.sum()


def test_clopper_pearson_matches_scipy_binomtest():
    df = pd.DataFrame({"g": ["a"] * 40 + ["b"] * 25, "y": [1] * 13 + [0] * 27 + [1] * 20 + [0] * 5})
    t = count_records(df, sensitive=["g"], outcome="y")
    iv = fairness_intervals(
        t, fa.indicator(1, t.decisions), intervals=IntervalOptions(confidence=0.9, method="clopper-pearson")
    )
    # one context: the groups are the cells, 2 intervals, each at level 1 - 0.1/2 (Bonferroni)
    level = 1 - 0.1 / 2
    ref_a = binomtest(13, 40).proportion_ci(confidence_level=level, method="exact")
    ref_b = binomtest(20, 25).proportion_ci(confidence_level=level, method="exact")
    assert iv.cell_lower[0].tolist() == pytest.approx([ref_a.low, ref_b.low], rel=1e-10)
    assert iv.cell_upper[0].tolist() == pytest.approx([ref_a.high, ref_b.high], rel=1e-10)
    # L interval: [log(lo_b / hi_a), log(hi_b / lo_a)] (b is the larger group here)
    assert iv.local_fairness.lower == pytest.approx(math.log(ref_b.low / ref_a.high), rel=1e-10)
    assert iv.local_fairness.upper == pytest.approx(math.log(ref_b.high / ref_a.low), rel=1e-10)
    assert (iv.local_fairness.group, iv.local_fairness.other_group, iv.n_sets) == ("b", "a", 2)


@pytest.mark.slow
def test_interval_coverage_small_simulation():
    # Known law: two contexts, three groups; the simultaneous 90% interval must cover L in >= 90% of 300 draws.
    rng = np.random.default_rng(11)
    p = np.array([[0.3, 0.5, 0.4], [0.6, 0.6, 0.2]])
    true_l = math.log(max((row.max() / row.min()) for row in p))
    hits = 0
    for _ in range(300):
        rows = []
        for i in range(2):
            for j in range(3):
                k = rng.binomial(60, p[i, j])
                rows += [(i, j, 1)] * k + [(i, j, 0)] * (60 - k)
        df = pd.DataFrame(rows, columns=["x", "a", "y"])
        t = count_records(df, sensitive=["a"], outcome="y", context=["x"])
        lo, hi = fairness_intervals(
            t, fa.indicator(1, t.decisions), IntervalOptions(confidence=0.9, method="clopper-pearson")
        ).local_fairness
        hits += lo <= true_l <= hi
    assert hits / 300 >= 0.9


def test_zero_cells_give_infinite_upper_end():
    # a: 0 of 100 positive, b: 30 of 100. The data cannot exclude E[g | a] = 0 (upper end +inf) but do
    # exclude parity: lower end log(lo_b / hi_a) > 0 with the Bonferroni level 1 - 0.05/2.
    df = pd.DataFrame({"g": ["a"] * 100 + ["b"] * 100, "y": [0] * 100 + [1] * 30 + [0] * 70})
    t = count_records(df, sensitive=["g"], outcome="y")
    iv = fairness_intervals(t, fa.indicator(1, t.decisions), IntervalOptions(confidence=0.95, method="clopper-pearson"))
    assert iv.local_fairness.upper == math.inf and 0 < iv.local_fairness.lower < math.inf
    level = 1 - 0.05 / 2
    hi_a = binomtest(0, 100).proportion_ci(confidence_level=level, method="exact").high
    lo_b = binomtest(30, 100).proportion_ci(confidence_level=level, method="exact").low
    assert iv.local_fairness.lower == pytest.approx(math.log(lo_b / hi_a), rel=1e-10)
