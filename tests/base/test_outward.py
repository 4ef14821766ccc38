"""Outward rounding: each function lands on its stated side of the exact value, against 60-digit mpmath and
mpmath's interval arithmetic (a route independent of python-flint's arb)."""

from __future__ import annotations

import math
import threading
from fractions import Fraction

import flint
import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from mpmath import iv

from fairaudit.base.outward import (
    BITS,
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
    # (the 50-digit decimal route before arb: within 1e-25 of 1 the argument rounded to 1, and next_plus(ln 1) was
    # 1e-(10^18), which hung Fraction())
    q = 1 + side * gap
    lo, hi = ln_bounds(q)
    assert _encloses(lo, hi, mpmath.log, q)
    assert 0 < hi - lo <= gap**2 / min(q, Fraction(1))
    assert log_down(q) <= log_up(q) and (log_up(q) <= 0 if side < 0 else log_down(q) >= 0)


@pytest.mark.parametrize("x", [4.053062555617706e-56, 5e-324, -1e-300, 2.0**-21, -(2.0**-21), 3e-7, 1e-6, 0.5])
def test_exp_and_ln_bounds_near_zero_hold_50_digits_of_the_small_quantity(x):
    # e^x − 1 and ln(1 + y) are small there: the 50-digit decimals of the route before arb held x, not them (a
    # randomized response at 4e-56 nats had e^epsilon in [1, 1 + 1e-49]); arb's expm1 and log1p hold them to 2^-200
    # of themselves (test_bounds_hold_the_exact_value_bits_apart asserts that width)
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


def _interval(f, q: Fraction) -> tuple[Fraction, Fraction]:
    """Rationals a ≤ f(q) ≤ b from mpmath's interval arithmetic, at 450 bits beyond the bits of q (so that ln q near
    1 and e^q − 1 near 0, at least 2^-bits(q) in size, keep 450 bits of their own): each end an exact mpf."""
    saved = iv.prec
    iv.prec = 450 + q.numerator.bit_length() + q.denominator.bit_length()
    try:
        a, b = f(iv.mpf(q.numerator) / iv.mpf(q.denominator))._mpi_
    finally:
        iv.prec = saved
    return _mpf_rational(a), _mpf_rational(b)


def _mpf_rational(value: tuple) -> Fraction:
    """An mpf's raw (sign, mantissa, exponent, bits) as the rational it is."""
    sign, man, exp, _ = value
    x = Fraction(int(man) << exp) if exp >= 0 else Fraction(int(man), 1 << -exp)
    return -x if sign else x


def _size(a: Fraction, b: Fraction, ln: bool) -> Fraction:
    """A lower bound over a ≤ v ≤ b of what the enclosures' width is relative to: |v| (ln), min(v, |v − 1|) (exp)."""
    if ln:
        return a if a > 0 else -b if b < 0 else Fraction(0)
    return min(a, a - 1 if a > 1 else 1 - b if b < 1 else Fraction(0))


every_float = st.builds(math.ldexp, st.integers(1, 2**53 - 1), st.integers(-1126, 971))  # 5e-324 to the largest
near_one = st.builds(
    lambda k, n: 1 + Fraction(k, 2**n), st.integers(1 - 2**20, 2**20 - 1).filter(bool), st.integers(20, 1200)
)
ln_arguments = st.one_of(
    every_float.filter(lambda x: 0 < x < math.inf),
    st.sampled_from([5e-324, 2.0**-1022, 1e-300, 1e300, 1.7976931348623157e308, 1 + 2.0**-52, 1 - 2.0**-53, 0.5, 1.5]),
    st.floats(min_value=1 - 1e-15, max_value=1 + 1e-15).filter(lambda x: x != 1),
    near_one,
    st.fractions(min_value=Fraction(1, 10**300), max_value=10**300, max_denominator=10**300).filter(lambda q: q > 0),
)
exp_arguments = st.one_of(
    st.floats(min_value=-1100, max_value=1100).filter(bool),
    st.sampled_from([5e-324, -5e-324, 1e-300, -1e-300, 0.5, -0.5, 709.78, 709.79, -745.1, -745.2, 1000, -1000]),
    every_float.filter(lambda x: x < 1),
    near_one.map(lambda q: q - 1),
    st.fractions(min_value=-(10**6), max_value=10**6, max_denominator=10**40).filter(bool),
)


@given(ln_arguments)
def test_log_ends_are_on_their_sides_against_mpmath_intervals(x):
    # exactly, as rationals: log_down(x) ≤ a ≤ ln x ≤ b ≤ log_up(x) for mpmath's interval [a, b], and the ends at most
    # two floats outside it as documented; ln_bounds holds [a, b] too, its ends at most 2^-BITS·|ln x| apart
    q = Fraction(x)
    a, b = _interval(iv.log, q)
    lo, hi = log_down(x), log_up(x)
    assert Fraction(lo) <= a and b <= Fraction(hi)
    assert lo >= down(fraction_down(a)) and hi <= up(fraction_up(b))
    low, high = ln_bounds(x)
    assert low <= a and b <= high
    assert (high - low) * 2**BITS <= _size(a, b, ln=True)


@given(exp_arguments)
def test_exp_ends_are_on_their_sides_against_mpmath_intervals(x):
    # the same for exp: saturated beyond the floats (+inf or the largest float, the smallest positive float or 0),
    # exp_bounds up to 10^6 nats with its ends at most 2^-BITS·min(e^x, |e^x − 1|) apart
    q = Fraction(x)
    a, b = _interval(iv.exp, q)
    lo, hi = exp_down(x), exp_up(x)
    assert Fraction(lo) <= a and b <= (Fraction(hi) if hi < math.inf else b)
    assert lo >= down(fraction_down(a)) and hi <= up(fraction_up(b))
    if abs(q) <= 1000:  # (beyond it the floats saturate without a ball, on their sides: test_known_values_and_edges)
        low, high = exp_bounds(x)
        assert low <= a and b <= high
        assert (high - low) * 2**BITS <= _size(a, b, ln=False)


def test_flint_precision_is_left_as_it_was():
    # the working precision is set for each evaluation and restored, also after an error
    saved = flint.ctx.prec
    try:
        flint.ctx.prec = 77
        assert (log_up(3), exp_down(Fraction(-7, 3)), ln_bounds(10**40)[0] > 0, exp_bounds(2)[1] > 7) == (
            fraction_up(ln_bounds(3)[1]),
            fraction_down(exp_bounds(Fraction(-7, 3))[0]),
            True,
            True,
        )
        with pytest.raises(ValueError):
            ln_bounds(-1)
        assert flint.ctx.prec == 77
    finally:
        flint.ctx.prec = saved


def test_threads_get_the_same_ends():
    # python-flint's precision is one per process: evaluations on several threads at once agree with one at a time
    xs = [Fraction(k, 7) for k in range(1, 400)]
    alone = [(log_down(x), log_up(x), exp_down(x), exp_up(x), ln_bounds(x), exp_bounds(-x)) for x in xs]
    together: list[list[tuple]] = [[] for _ in range(4)]

    def work(i: int) -> None:
        together[i] = [(log_down(x), log_up(x), exp_down(x), exp_up(x), ln_bounds(x), exp_bounds(-x)) for x in xs]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert together == [alone] * 4
