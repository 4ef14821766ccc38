"""Missing demographics: the sharp bounds against a brute force over every allocation of the unknowns."""

from __future__ import annotations

import itertools
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit.base.errors import InputError
from fairaudit.statistics.missing_demographics import _least_top, aclu_bounds, missing_data_bounds


def _spreads(total: int, k: int):
    """Every way to put ``total`` whole applicants into k categories."""
    for cut in itertools.combinations_with_replacement(range(k), total):
        yield [cut.count(i) for i in range(k)]


def _brute(n, s, big_n, big_s):
    """Least and greatest rate and impact ratio of each category over every allocation (S selected, N − S not)."""
    k = len(n)
    best = [[None, None, None, None] for _ in range(k)]
    for b in _spreads(big_s, k):
        for c in _spreads(big_n - big_s, k):
            rates = [Fraction(s[i] + b[i], n[i] + b[i] + c[i]) for i in range(k)]
            top = max(rates)
            for i, r in enumerate(rates):
                ratio = Fraction(1) if top == 0 else r / top
                row = best[i]
                for slot, value, pick in ((0, r, min), (1, r, max), (2, ratio, min), (3, ratio, max)):
                    row[slot] = value if row[slot] is None else pick(row[slot], value)
    return best


@settings(max_examples=150)
@given(
    st.lists(st.tuples(st.integers(1, 6), st.integers(0, 6)), min_size=1, max_size=3),
    st.integers(0, 4),
    st.integers(0, 4),
)
def test_the_bounds_are_those_of_every_allocation(rows, big_n, big_s):
    n = [a for a, _ in rows]
    s = [min(a, b) for a, b in rows]
    big_s = min(big_s, big_n)
    got = missing_data_bounds(list(range(len(n))), n, s, big_n, big_s)
    assert got.whole
    for i, (r_lo, r_hi, q_lo, q_hi) in enumerate(_brute(n, s, big_n, big_s)):
        assert (got.rate_lower[i], got.rate_upper[i], got.ratio_lower[i], got.ratio_upper[i]) == (
            r_lo,
            r_hi,
            q_lo,
            q_hi,
        )


def test_a_hand_worked_table():
    # A 10 of 20, B 8 of 20, 5 unknown of whom 2 selected (U = 3 unselected).
    b = missing_data_bounds(["A", "B"], [20, 20], [10, 8], 5, 2)
    assert b.rate_lower == (Fraction(10, 23), Fraction(8, 23))
    assert b.rate_upper == (Fraction(12, 22), Fraction(10, 22))
    # B lowest: B gets the 3 unselected (8/23), A the 2 selected (12/22): (8/23)/(12/22) = 44/69
    assert b.ratio_lower == (Fraction(10, 23) / Fraction(10, 22), Fraction(44, 69))
    # B highest: B gets the 2 selected (10/22), A the 3 unselected (10/23 < 10/22): B is the top
    assert b.ratio_upper == (1, 1)
    assert b.lower_comparator == ("B", "A") and b.upper_comparator == ("A", "B")


def test_the_unselected_fill_the_highest_rates_to_one_level():
    # rates 9/10, 8/10, 1/10 and 5 unselected in whole ones, c1 + c2 = 5: (4, 1) gives 9/14, 8/11; (3, 2) gives
    # 9/13, 8/12; (2, 3) gives 9/12: the least top is 9/13, held by the first
    n, s = [Fraction(10)] * 3, [Fraction(9), Fraction(8), Fraction(1)]
    assert _least_top(n, s, Fraction(5), whole=True) == (Fraction(9, 13), 0)
    # in shares: the water level over the two top rates, 17 / 25 (9/(10+c1) = 8/(10+c2) = 17/25, c1 + c2 = 5)
    level, holder = _least_top(n, s, Fraction(5), whole=False)
    assert level == Fraction(17, 25) and holder in (0, 1)


def test_shares_are_used_when_a_count_is_not_whole():
    b = missing_data_bounds(["A", "B"], [20, 20.5], [10, 8], 5, 2)
    assert not b.whole
    # A highest in shares: A gets the 2 selected (12/22); B's 8/20.5 is already below it
    assert b.ratio_upper[0] == 1 and b.rate_upper[1] == Fraction(10) / Fraction(45, 2)


@pytest.mark.parametrize(
    ("args", "field"),
    [
        ((["A"], [-1], [0], 0, 0), "applicants"),
        ((["A"], [2], [3], 0, 0), "selected"),
        ((["A"], [2], [1], 1, 2), "unknown_selected"),
        ((["A"], [2], [1], float("nan"), 0), "unknown_applicants"),
        ((["A"], [2], ["1"], 0, 0), "selected"),
        ((["A", "B"], [2], [1], 0, 0), "applicants"),
        ((["A"], [0], [0], 0, 0), "applicants"),
    ],
)
def test_bad_counts_name_their_field(args, field):
    with pytest.raises(InputError, match=f"^{field}:"):
        missing_data_bounds(*args)


def test_the_aclu_variants_hold_the_comparator_and_add_every_unknown():
    # their formula: (s + m)/(n + m) / comparator and s/(n + m) / comparator, m = N or N·n/Σn
    assert aclu_bounds([20, 20], [10, 8], 5, 0.5) == ([0.8, 0.64], [1.2, 1.04])
    lower, upper = aclu_bounds([30, 10], [15, 4], 8, 0.5, proportional=True)  # m = 6 and 2
    assert lower == pytest.approx([15 / 36 / 0.5, 4 / 12 / 0.5], rel=1e-15)
    assert upper == pytest.approx([21 / 36 / 0.5, 6 / 12 / 0.5], rel=1e-15)


@settings(max_examples=100)
@given(
    st.lists(st.tuples(st.floats(0.5, 50), st.floats(0, 1)), min_size=1, max_size=5),
    st.floats(0, 40),
)
def test_the_water_level_in_shares_is_the_least_reachable_level(rows, extra):
    # second route: bisection on the level t of Σ max(0, s/t − n) ≤ extra, in floats
    n = [Fraction(a) for a, _ in rows]
    s = [Fraction(a) * Fraction(f) for a, f in rows]
    level, holder = _least_top(n, s, Fraction(extra), whole=False)
    if all(v == 0 for v in s):
        assert level == 0
        return
    lo, hi = 0.0, max(float(b / a) for a, b in zip(n, s, strict=True))
    for _ in range(200):
        mid = (lo + hi) / 2
        need = sum(max(0.0, float(b) / mid - float(a)) for a, b in zip(n, s, strict=True))
        lo, hi = (lo, mid) if need <= extra else (mid, hi)
    assert float(level) == pytest.approx(hi, rel=1e-9)
    assert s[holder] / n[holder] >= level  # the holder is filled down to the level (or sits at it)
