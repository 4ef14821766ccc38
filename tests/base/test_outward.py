"""Outward rounding: each function lands on its stated side of the exact value, against 60-digit mpmath."""

from __future__ import annotations

import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fairaudit.base.outward import (
    down,
    exp_bounds,
    exp_down,
    exp_up,
    fraction_down,
    fraction_up,
    ln_bounds,
    log_down,
    log_up,
    product_ends,
    product_roundings,
    rounding_error,
    sum_ends,
    up,
    widen_down,
    widen_up,
)

mpmath.mp.dps = 60

positive = st.one_of(
    st.floats(min_value=5e-324, max_value=1.7e308, allow_nan=False, allow_infinity=False),
    st.floats(min_value=1 - 1e-9, max_value=1 + 1e-9).filter(lambda x: x > 0),
)
rationals = st.fractions(min_value=Fraction(1, 10**30), max_value=10**30, max_denominator=10**40)


@given(st.one_of(positive, rationals))
def test_log_brackets_the_exact_log_within_two_ulps(x):
    exact = mpmath.log(mpmath.mpf(x.numerator) / x.denominator if isinstance(x, Fraction) else mpmath.mpf(x))
    lo, hi = log_down(x), log_up(x)
    assert lo <= exact <= hi
    assert hi - lo <= 2 * math.ulp(max(abs(lo), abs(hi)))


@given(st.one_of(st.floats(min_value=-800, max_value=800), st.fractions(min_value=-800, max_value=800)))
def test_exp_brackets_the_exact_exp(x):
    exact = mpmath.exp(mpmath.mpf(x.numerator) / x.denominator if isinstance(x, Fraction) else mpmath.mpf(x))
    lo, hi = exp_down(x), exp_up(x)
    assert lo <= exact <= hi
    if 0 < lo and hi < math.inf:
        assert hi - lo <= 2 * math.ulp(hi)


def test_known_values_and_edges():
    # Exact points need no rounding; far arguments saturate on the right side.
    assert (log_up(1), log_down(1), exp_up(0), exp_down(0)) == (0.0, 0.0, 1.0, 1.0)
    assert log_up(0) == log_down(0) == -math.inf
    assert exp_up(1000) == math.inf and exp_down(1000) == np.finfo(float).max
    assert exp_up(-1000) == 5e-324 and exp_down(-1000) == 0.0
    assert log_down(math.e) < 1 == log_up(math.e)  # math.e is just below e: ln of it is just below 1
    with pytest.raises(ValueError, match="negative"):
        log_up(-1.0)


@given(st.fractions(max_denominator=10**30))
def test_fractions_round_to_the_neighbouring_floats(q):
    lo, hi = fraction_down(q), fraction_up(q)
    assert Fraction(lo) <= q <= Fraction(hi)
    assert lo == hi if Fraction(lo) == q else math.nextafter(lo, math.inf) == hi


def test_fractions_beyond_the_floats():
    big = Fraction(10**400)
    assert fraction_up(big) == math.inf and fraction_down(big) == np.finfo(float).max
    assert fraction_up(-big) == -np.finfo(float).max and fraction_down(-big) == -math.inf


@given(st.floats(min_value=-1e300, max_value=1e300), st.floats(0, 1e-6), st.floats(0, 1e-6))
def test_widening_covers_the_stated_error(x, rel, abs_):
    hi, lo = widen_up(x, rel, abs_), widen_down(x, rel, abs_)
    err = Fraction(abs(x)) * Fraction(rel) + Fraction(abs_)
    assert Fraction(lo) <= Fraction(x) - err and Fraction(x) + err <= Fraction(hi)
    assert up(x) > x > down(x)


def test_arrays_round_elementwise():
    a = np.array([0.1, 1.0, -2.0])
    assert (up(a) > a).all() and (down(a) < a).all()
    assert widen_up(a, 0.0).tolist() == up(a).tolist()


@given(
    st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=3, max_size=3),
    st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=3, max_size=3),
    st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=3, max_size=3),
)
def test_product_ends_enclose_a_sum_of_products(a, b, c):
    # Σ_i a_i b_i c_i, computed in floats: its ends (roundings counted as documented) enclose the exact rational
    x, y, z = (np.array(v) for v in (a, b, c))
    value = float((x * y * z).sum())
    terms = product_roundings(x, y, z)
    k = int(terms.max()) + 2  # a sum of three non-negative terms adds two
    nonzero = bool(np.any((x != 0) & (y != 0) & (z != 0)))
    low, high = product_ends(value, k, nonzero)
    exact = sum(Fraction(p) * Fraction(q) * Fraction(r) for p, q, r in zip(a, b, c))
    assert Fraction(float(low)) <= exact <= Fraction(float(high))
    assert float(high) - float(low) <= 1e-14 * value + 1e-300


def test_product_roundings_and_rounding_error_by_hand():
    # 0 and 1 multiply exactly: 0.5 · 1 · 0.3 rounds once at most (0.5 is a power of two, but only 0 and 1 are
    # counted exact), 1 · 1 · 0.3 never
    assert product_roundings(
        np.array([0.5, 1.0, 0.0]), np.array([1.0, 1.0, 0.7]), np.array([0.3, 0.3, 0.3])
    ).tolist() == [
        1,
        0,
        0,
    ]
    assert rounding_error(0) == 0.0
    assert Fraction(rounding_error(2)) >= Fraction(2, 2**53) / (1 - Fraction(4, 2**53))
    low, high = product_ends(np.array([0.0, 0.3]), np.array([1, 0]), np.array([False, True]))
    assert low.tolist() == [0.0, 0.3] and high.tolist() == [0.0, 0.3]  # an exact value is its own two ends


@pytest.mark.parametrize("gap", [Fraction(1, 10**60), Fraction(3, 10**26), Fraction(1, 2**200)])
@pytest.mark.parametrize("side", [1, -1])
def test_ln_bounds_next_to_one_are_rationals_around_it(gap, side):
    # within 1e-25 of 1 the 50-digit argument rounds to 1: next_plus(ln 1) was 1e-(10^18), which hung Fraction()
    q = 1 + side * gap
    lo, hi = ln_bounds(q)
    assert _encloses(lo, hi, mpmath.log, q)
    assert 0 < hi - lo <= gap**2 / min(q, Fraction(1))
    assert log_down(q) <= log_up(q) and (log_up(q) <= 0 if side < 0 else log_down(q) >= 0)


@pytest.mark.parametrize("x", [4.053062555617706e-56, 5e-324, -1e-300, 2.0**-21, -(2.0**-21), 3e-7, 1e-6, 0.5])
def test_exp_and_ln_bounds_near_zero_hold_50_digits_of_the_small_quantity(x):
    # e^x − 1 and ln(1 + y) are small there: the decimals' 50 digits held x, not them (a randomized response at
    # 4e-56 nats had e^epsilon in [1, 1 + 1e-49]); below 2^-20 the Taylor series with its remainder bound holds them
    # to 48 digits of themselves, above it the decimals to 42 at least (x = 1e-6 and 0.5: 2^-20 < |x|)
    q = Fraction(x)
    digits = 48 if abs(q) < 2**-20 else 42
    lo, hi = exp_bounds(q)
    assert _encloses(lo, hi, mpmath.exp, q)
    assert hi - lo <= Fraction(1, 10**digits) * abs(q)
    lo, hi = ln_bounds(1 + q)  # ln(1 + y) for y = x, 1 + y the rational next to 1
    assert _encloses(lo, hi, mpmath.log, 1 + q)
    assert hi - lo <= Fraction(1, 10**digits) * abs(q)


def _encloses(lo: Fraction, hi: Fraction, f, q: Fraction) -> bool:
    """lo ≤ f(q) ≤ hi, with mpmath at enough digits to tell them apart (their width and the rationals' sizes)."""
    width = hi - lo
    dps = 60 + max(len(str(width.denominator)) - len(str(width.numerator)), 0)
    dps += max(len(str(q.denominator)), len(str(lo.denominator)), len(str(hi.denominator)))
    with mpmath.workdps(dps):
        value = f(mpmath.mpf(q.numerator) / mpmath.mpf(q.denominator))
        return bool(
            mpmath.mpf(lo.numerator) / mpmath.mpf(lo.denominator)
            <= value
            <= mpmath.mpf(hi.numerator) / mpmath.mpf(hi.denominator)
        )


@given(st.integers(1, 6).flatmap(lambda n: st.lists(st.lists(st.floats(0, 1), min_size=n, max_size=n), min_size=1,
                                                     max_size=4)))  # fmt: skip
def test_sum_ends_are_the_floats_next_to_the_exact_sums(rows):
    # against the sums in fractions: the ends enclose them, and each is the nearest float on its side
    high, low = sum_ends(rows)
    for row, hi, lo in zip(rows, high, low):
        exact = sum(map(Fraction, row), Fraction(0))
        assert Fraction(float(lo)) <= exact <= Fraction(float(hi))
        assert (hi, lo) == (fraction_up(exact), fraction_down(exact))
