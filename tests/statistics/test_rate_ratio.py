"""The ratio interval, the test of equal rates and the adjustments, against hand calculations and a peer."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit.base.errors import InputError
from fairaudit.statistics.rate_ratio import adjusted, equal_rates_test, ratio_interval, score_statistic


def test_koopmans_example():
    # Koopman (1984): 36 of 40 against 16 of 80, 95% interval (2.94, 7.15) on the ratio
    lo, hi = ratio_interval(36, 40, 16, 80, correction=False)
    assert (round(lo, 2), round(hi, 2)) == (2.94, 7.15)


def test_the_statistic_at_the_point_estimate_is_zero_and_by_hand_at_one():
    assert float(score_statistic(0.9 / 0.2, 36, 40, 16, 80)) == pytest.approx(0.0, abs=1e-12)
    # at θ = 1 the constrained estimate is the pooled rate 52/120, and Koopman's z is the pooled z test's
    pooled = 52 / 120
    z = (0.9 - 0.2) / math.sqrt(pooled * (1 - pooled) * (1 / 40 + 1 / 80))
    assert float(score_statistic(1.0, 36, 40, 16, 80, correction=False)) == pytest.approx(z, rel=1e-12)


@settings(max_examples=60)
@given(st.integers(2, 400), st.integers(2, 400), st.floats(0.001, 0.999), st.floats(0.001, 0.999), st.booleans())
def test_the_interval_is_statsmodels_score_interval(n1, n2, f1, f2, correction):
    sm = pytest.importorskip("statsmodels.stats.proportion")
    x1, x2 = max(1, min(n1 - 1, round(f1 * n1))), max(1, min(n2 - 1, round(f2 * n2)))
    ours = ratio_interval(x1, n1, x2, n2, correction=correction)
    peer = sm.confint_proportions_2indep(x1, n1, x2, n2, method="score", compare="ratio", correction=correction)
    assert ours == pytest.approx(tuple(float(v) for v in peer), rel=1e-6)  # the peer's root finder: ~1e-8


def test_the_interval_inverts_the_test():
    lo, hi = ratio_interval(30, 100, 45, 90)
    z = 1.959963984540054
    assert float(score_statistic(lo, 30, 100, 45, 90)) == pytest.approx(z, rel=1e-9)
    assert float(score_statistic(hi, 30, 100, 45, 90)) == pytest.approx(-z, rel=1e-9)
    assert lo < (30 / 100) / (45 / 90) < hi


def test_open_ends():
    assert ratio_interval(0, 50, 10, 50)[0] == 0.0
    assert ratio_interval(10, 50, 0, 50)[1] == math.inf
    assert ratio_interval(0, 50, 0, 50) == (0.0, math.inf)
    lo, hi = ratio_interval(50, 50, 50, 50)  # both rates 1: the ratio 1 inside, finite ends
    assert 0 < lo < 1 < hi < math.inf


def test_non_integer_counts_are_used_as_given():
    # scaling every count by 2.5 is the same rates with more weight: the interval narrows about the same ratio
    lo, hi = ratio_interval(12.5, 25.0, 20.0, 25.0)
    lo2, hi2 = ratio_interval(5, 10, 8, 10)
    assert lo2 < lo < 0.625 < hi < hi2


def _fisher_by_hand(a: int, b: int, c: int, d: int) -> Fraction:
    """Two-sided Fisher p: the hypergeometric tables with the margins, as likely or less likely, in fractions."""
    row, col, n = a + b, a + c, a + b + c + d

    def prob(x: int) -> Fraction:
        return Fraction(math.comb(col, x) * math.comb(n - col, row - x), math.comb(n, row))

    here = prob(a)
    return sum((prob(x) for x in range(max(0, row + col - n), min(row, col) + 1) if prob(x) <= here), Fraction(0))


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
