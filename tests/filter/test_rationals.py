"""Probabilities read exactly: fractions, integers, strings, floats as their binary values; rows over one denominator."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from fairaudit.base.errors import InputError
from fairaudit.filter.rationals import as_rows, exact_number


def test_numbers_are_read_exactly():
    assert exact_number("1/3", "p") == Fraction(1, 3)
    assert exact_number("0.1", "p") == Fraction(1, 10)
    assert exact_number(0.1, "p") == Fraction(3602879701896397, 2**55)  # the float's own value
    assert exact_number(np.int64(2), "p") == 2
    assert exact_number(np.float64(0.5), "p") == Fraction(1, 2)


@pytest.mark.parametrize("bad", [True, float("nan"), float("inf"), "one third", "1/0", None])
def test_what_is_not_a_rational_is_refused(bad):
    with pytest.raises(InputError, match="^p: "):
        exact_number(bad, "p")


def test_rows_over_their_least_common_denominator():
    assert as_rows([["1/4", "3/4"], [Fraction(1, 6), Fraction(5, 6)]], "rows") == (((3, 9), (2, 10)), 12)


def test_rows_that_do_not_sum_to_one_say_why():
    with pytest.raises(InputError, match=r"rows\[0\]: must sum to exactly 1, not .*exact binary values"):
        as_rows([[0.9, 0.1], [0.7, 0.3]], "rows")
    with pytest.raises(InputError, match=r"rows\[1\]: must sum to exactly 1, not 9/10 \(got"):
        as_rows([["1/2", "1/2"], ["1/2", "2/5"]], "rows")
    with pytest.raises(InputError, match=r"rows\[0\]: has a negative probability"):
        as_rows([["3/2", "-1/2"]], "rows")
    with pytest.raises(InputError, match=r"rows\[1\]: has 1 entries, the first row 2"):
        as_rows([["1/2", "1/2"], [1]], "rows")
