"""`laws.independence`: X ⊥ A exactly in the floats of a table, and the factor F of a table independent within
rounding, against exact fractions."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fairaudit.laws.independence import exactly_independent, independence_factor


def _exact_factor(p: np.ndarray) -> Fraction:
    """max r / min r, r = P(x, a)/(P(x) P(a)) over P(x), P(a) > 0, in fractions."""
    e = [[Fraction(v) for v in row] for row in p.tolist()]
    px, pa = [sum(row) for row in e], [sum(col) for col in zip(*e)]
    r = [e[x][a] / (px[x] * pa[a]) for x in range(len(px)) if px[x] for a in range(len(pa)) if pa[a]]
    return max(r) / min(r)


def test_hand_values():
    # max r = 0.2/(0.6 * 0.3) = 10/9, min r = 0.1/(0.4 * 0.3) = 5/6: F = 4/3
    assert independence_factor([[0.1, 0.3], [0.2, 0.4]]) >= 4 / 3
    assert independence_factor([[0.1, 0.3], [0.2, 0.4]]) - 4 / 3 < 1e-14
    # powers of two: the products are exact, the table exactly independent
    assert exactly_independent(np.outer([0.25, 0.75], [0.5, 0.5]))
    assert independence_factor(np.outer([0.25, 0.75], [0.5, 0.5])) == 1.0
    # 0.75 * 0.4 rounds: independent only within rounding
    p = np.outer([0.25, 0.75], [0.4, 0.6])
    assert not exactly_independent(p)
    assert 1.0 < float(_exact_factor(p)) <= independence_factor(p) < 1 + 1e-14


def test_absent_groups_and_dead_contexts_are_left_out():
    p = np.array([[0.0, 0.125, 0.375], [0.0, 0.0, 0.0], [0.0, 0.125, 0.375]])
    assert exactly_independent(p) and independence_factor(p) == 1.0
    # a context of positive probability that a present group never meets: no finite factor
    assert independence_factor([[0.5, 0.0], [0.25, 0.25]]) == math.inf


@given(
    px=st.lists(st.integers(1, 9), min_size=1, max_size=4),
    pa=st.lists(st.integers(0, 9), min_size=2, max_size=4).filter(lambda v: sum(v) > 0),
    noise=st.floats(0.0, 1e-6),
)
def test_the_factor_is_an_upper_end_of_the_exact_one(px, pa, noise):
    x = np.array(px, float) / sum(px)
    a = np.array(pa, float) / sum(pa)
    p = np.outer(x, a)
    p[0, int(np.argmax(a))] += noise
    exact = _exact_factor(p)
    assert exactly_independent(p) == (exact == 1)
    f = independence_factor(p)
    assert Fraction(f) >= exact
    assert f - float(exact) <= 1e-14 * float(exact)


@pytest.mark.parametrize("n", [1, 3, 7])
def test_uniform_tables_are_exactly_independent(n):
    assert independence_factor(np.full((n, 3), 1 / (3 * n))) == 1.0
