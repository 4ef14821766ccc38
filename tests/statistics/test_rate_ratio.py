"""The ratio interval, the test of equal rates and the adjustments, against hand calculations and a peer."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit.base.errors import InputError
from fairaudit.statistics.rate_ratio import _below, adjusted, equal_rates_test, ratio_interval


@settings(max_examples=60)
@given(st.integers(1, 400), st.integers(1, 400), st.floats(0, 1), st.floats(0, 1))
def test_at_ratio_one_the_melded_probabilities_are_fishers_one_sided_p_values(n1, n2, f1, f2):
    # Fay, Proschan and Brittain (2015) §4: P(W₁⁺ ≥ W₂⁻) = P(X₁ ≤ x₁ | margins), P(W₁⁻ ≤ W₂⁺) = P(X₁ ≥ x₁ | margins)
    from scipy.stats import fisher_exact

    x1, x2 = round(f1 * n1), round(f2 * n2)
    table = [[x1, n1 - x1], [x2, n2 - x2]]
    less, greater = (float(fisher_exact(table, alternative=a).pvalue) for a in ("less", "greater"))
    assert 1 - _below(1.0, x1 + 1, n1 - x1, x2, n2 - x2 + 1) == pytest.approx(less, rel=1e-6, abs=1e-12)
    assert _below(1.0, x1, n1 - x1 + 1, x2 + 1, n2 - x2) == pytest.approx(greater, rel=1e-6, abs=1e-12)


@pytest.mark.parametrize(("x1", "n1", "x2", "n2"), [(3, 10, 8, 10), (30, 100, 45, 90), (1, 7, 6, 9), (40, 50, 2, 9)])
def test_the_interval_excludes_one_exactly_where_fishers_test_rejects(x1, n1, x2, n2):
    p = equal_rates_test(x1, n1, x2, n2)
    for confidence in (1 - p * 0.999, 1 - p * 1.001):  # just above p: 1 is out; just below: 1 is in
        lo, hi = ratio_interval(x1, n1, x2, n2, confidence)
        assert (lo <= 1 <= hi) == (1 - confidence < p)


def test_a_rate_of_one_gives_the_other_rates_clopper_pearson_end():
    # x₁ = n₁: W₁⁺ = 1, so the upper end is 1 / (the comparator's Clopper–Pearson lower end at α/2); swapped, x₂ = n₂
    from scipy.stats import beta

    assert ratio_interval(20, 20, 7, 30)[1] == pytest.approx(1 / beta.ppf(0.025, 7, 24), rel=1e-9)
    assert ratio_interval(7, 30, 20, 20)[0] == pytest.approx(beta.ppf(0.025, 7, 24), rel=1e-9)


def test_swapping_the_categories_inverts_the_interval():
    lo, hi = ratio_interval(30, 100, 45, 90, 0.99)
    lo2, hi2 = ratio_interval(45, 90, 30, 100, 0.99)
    assert (lo, hi) == pytest.approx((1 / hi2, 1 / lo2), rel=1e-9)


def test_non_integer_counts_against_monte_carlo():
    # the lower end of 12.5 of 25 against 20 of 25: the α/2 quantile of W₁⁻ / W₂⁺, W₁⁻ ~ Beta(12.5, 13.5),
    # W₂⁺ ~ Beta(21, 5); 4 million draws put it within 0.003 of the quantile (its standard error ~6e-4)
    rng = np.random.default_rng(81)
    ratio = rng.beta(12.5, 13.5, 4_000_000) / rng.beta(21, 5, 4_000_000)
    lo, hi = ratio_interval(12.5, 25.0, 20.0, 25.0)
    assert lo == pytest.approx(float(np.quantile(ratio, 0.025)), abs=3e-3)
    lo2, hi2 = ratio_interval(5, 10, 8, 10)  # the same rates from fewer applicants: a wider interval
    assert lo2 < lo < 0.625 < hi < hi2


def test_exact_coverage_at_least_the_level_at_twelve_applicants():
    # every outcome of two samples of 12: the interval holds p1/p2 with probability at least 0.95 at each pair
    from scipy.stats import binom

    x = np.arange(13)
    ends = {(a, b): ratio_interval(a, 12, b, 12) for a in x for b in x}
    for p1, p2 in [(0.05, 0.5), (0.3, 0.3), (0.5, 0.9), (0.9, 0.2), (0.7, 0.75)]:
        w1, w2 = binom.pmf(x, 12, p1), binom.pmf(x, 12, p2)
        cover = sum(w1[a] * w2[b] for (a, b), (lo, hi) in ends.items() if lo <= p1 / p2 <= hi)
        assert 0.95 <= cover < 1


def test_open_ends():
    assert ratio_interval(0, 50, 10, 50)[0] == 0.0
    assert ratio_interval(10, 50, 0, 50)[1] == math.inf
    assert ratio_interval(0, 50, 0, 50) == (0.0, math.inf)
    lo, hi = ratio_interval(50, 50, 50, 50)  # both rates 1: the ratio 1 inside, finite ends
    assert 0 < lo < 1 < hi < math.inf


def _fisher_by_hand(a: int, b: int, c: int, d: int) -> Fraction:
    """Two-sided Fisher p by the central rule: twice the smaller hypergeometric tail given the margins, in
    fractions."""
    row, col, n = a + b, a + c, a + b + c + d

    def prob(x: int) -> Fraction:
        return Fraction(math.comb(col, x) * math.comb(n - col, row - x), math.comb(n, row))

    support = range(max(0, row + col - n), min(row, col) + 1)
    below = sum((prob(x) for x in support if x <= a), Fraction(0))
    above = sum((prob(x) for x in support if x >= a), Fraction(0))
    return min(Fraction(1), 2 * min(below, above))


@pytest.mark.parametrize(("x1", "n1", "x2", "n2"), [(3, 10, 8, 10), (0, 5, 5, 5), (40, 200, 60, 180), (7, 7, 7, 9)])
def test_fisher_is_the_hypergeometric_sum(x1, n1, x2, n2):
    want = _fisher_by_hand(x1, n1 - x1, x2, n2 - x2)
    assert equal_rates_test(x1, n1, x2, n2) == pytest.approx(float(want), rel=1e-9)


def test_the_z_test_by_hand():
    # 3/10 vs 8/10: pooled 11/20, z = 0.5 / sqrt(0.55 · 0.45 · 0.2) = 2.2473, p = 2 Φ(−z)
    z = 0.5 / math.sqrt(0.55 * 0.45 * 0.2)
    assert equal_rates_test(3, 10, 8, 10, "z") == pytest.approx(math.erfc(z / math.sqrt(2)), rel=1e-12)
    assert equal_rates_test(0, 10, 0, 10, "z") == 1.0


def test_fisher_refuses_counts_that_are_not_whole():
    with pytest.raises(InputError, match="^test: Fisher's exact test needs whole counts"):
        equal_rates_test(2.5, 10, 3, 10)
    with pytest.raises(InputError, match="^test: must be one of fisher, z"):
        equal_rates_test(2, 10, 3, 10, "t")


def test_holm_and_bonferroni_by_hand():
    p = [0.01, 0.04, 0.03, 0.5]
    # Holm: sorted 0.01·4, 0.03·3, 0.04·2, 0.5·1 = 0.04, 0.09, 0.08 → 0.09 (monotone), 0.5
    assert adjusted(p, "holm").tolist() == pytest.approx([0.04, 0.09, 0.09, 0.5])
    assert adjusted(p, "bonferroni").tolist() == pytest.approx([0.04, 0.16, 0.12, 1.0])
    assert adjusted(p, "none").tolist() == p
    assert adjusted([], "holm").size == 0
    with pytest.raises(InputError, match="^adjustment:"):
        adjusted(p, "sidak")


def test_bad_counts_name_the_category():
    with pytest.raises(InputError, match="^x2:"):
        ratio_interval(1, 10, 11, 10)
    with pytest.raises(InputError, match="^x1:"):
        ratio_interval(float("nan"), 10, 1, 10)
    with pytest.raises(InputError, match="^confidence:"):
        ratio_interval(1, 10, 1, 10, confidence=1.5)
    assert np.isfinite(ratio_interval(1, 10, 1, 10)).all()
