"""The threshold rule over boxes, batched, and a box plus one floor: against each program alone and the LP."""

from __future__ import annotations

import itertools
import math
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fairaudit.base.linear_fractional import FractionalProgram
from fairaudit.base.threshold_rule import box_point, floor_max_many, threshold_max_many

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "proofs"))
from _exact import box, vertex_max  # noqa: E402


def _instance(seed: int, n: int):
    rng = np.random.default_rng(seed)
    p, q = rng.dirichlet(np.ones(n)), rng.dirichlet(np.ones(n))
    lo = rng.uniform(0, 0.5, n) * rng.integers(0, 2)
    return p, q, lo, lo + rng.uniform(0.01, 1.0, n)


@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.integers(1, 5))
def test_a_batch_is_each_program_alone(seed, n, batch):
    # threshold_max_many over a batch of boxes gives each program's own value and point (the program alone).
    boxes = [_instance(seed + i, n) for i in range(batch)]
    p, q, lo, hi = (np.stack(column) for column in zip(*boxes))
    values, k, order = threshold_max_many(p, q, lo, hi)
    for i in range(batch):
        value, k_alone, order_alone = threshold_max_many(p[i], q[i], lo[i], hi[i])
        assert values[i] == value
        point = box_point(lo[i], hi[i], order_alone, int(k_alone))
        assert box_point(lo[i], hi[i], order[i], int(k[i])).tolist() == point.tolist()


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.integers(1, 20), st.floats(0.01, 1.0))
def test_floor_closed_form_equals_lp(seed, n, share):
    # max p·h / q·h over the box with q·h >= floor: closed form (fractional knapsack at the floor) vs the LP.
    p, q, lo, hi = _instance(seed, n)
    floor = q @ lo + share * (q @ hi - q @ lo)
    if floor <= 0:
        return
    v, k, frac, order = floor_max_many(p, q, lo, hi, floor)
    lp = FractionalProgram(n, lower=lo, upper=hi, A_ub=-q[None, :], b_ub=[-floor]).solve(p, q)
    if Fraction(floor) > sum((Fraction(a) * Fraction(b) for a, b in zip(q, hi, strict=True)), Fraction(0)):
        # share = 1: the floor, rounded in floats, above q·hi exactly: no h meets it, which the exact LP says
        assert lp.status == "infeasible" and math.isnan(lp.value)
        return
    assert float(v) == pytest.approx(lp.value, rel=1e-7)
    h = box_point(lo, hi, order, int(k), float(frac))
    assert q @ h >= floor * (1 - 1e-12) and (p @ h) / (q @ h) == pytest.approx(float(v), rel=1e-12)


def _exact_box_max(p, q, lo, hi) -> Fraction:
    """max over the 2^n vertices of the box, in Fractions (0/0 = 1, c/0 = inf)."""
    best = None
    for mask in itertools.product([0, 1], repeat=len(p)):
        h = [Fraction(hi[i]) if m else Fraction(lo[i]) for i, m in enumerate(mask)]
        num = sum((Fraction(p[i]) * h[i] for i in range(len(p))), Fraction(0))
        den = sum((Fraction(q[i]) * h[i] for i in range(len(p))), Fraction(0))
        v = (Fraction(10**400) if num > 0 else Fraction(1)) if den == 0 else num / den
        best = v if best is None or v > best else best
    return best


@pytest.mark.slow
@given(st.integers(0, 2**32 - 1), st.integers(1, 7), st.sampled_from(["tiny", "ties", "ulp", "plain"]))
def test_threshold_values_are_upper_bounds_on_near_degenerate_boxes(seed, n, kind):
    rng = np.random.default_rng(seed)
    q = rng.dirichlet(np.ones(n))
    if kind == "ties":  # equal likelihood ratios
        p = q * 1.5
    elif kind == "ulp":  # ratios that differ in the last bit
        p = np.array([np.nextafter(1.3 * v, np.inf) if i % 2 else 1.3 * v for i, v in enumerate(q)])
    else:
        p = rng.dirichlet(np.ones(n))
    lo = rng.uniform(0, 1e-12 if kind == "tiny" else 0.5, n) * rng.integers(0, 2)
    hi = lo + (rng.uniform(1e-12, 2e-12, n) if kind == "tiny" else rng.uniform(0.01, 1.0, n))
    exact = _exact_box_max(p, q, lo, hi)
    v = float(threshold_max_many(p, q, lo, hi)[0])
    assert Fraction(v) >= exact
    assert Fraction(v) <= exact * (1 + Fraction(1, 10**12))
    if n >= 2:  # the floor program too, against its exact optimum (vertex enumeration in Fractions)
        floor = float(q @ lo + 0.5 * (q @ (hi - lo)))
        fv = float(floor_max_many(p, q, lo, hi, floor)[0])
        A, b = box([Fraction(v) for v in lo], [Fraction(v) for v in hi])
        exact_floor = vertex_max(
            [Fraction(v) for v in p], [Fraction(v) for v in q], [*A, [-Fraction(v) for v in q]], [*b, -Fraction(floor)]
        )[0]
        assert Fraction(fv) >= exact_floor
        assert Fraction(fv) <= exact_floor * (1 + Fraction(1, 10**12))


def test_equal_weights_give_exactly_one():
    # p = q: (p·h)/(q·h) = 1 for every h, with no rounding to add (randomized response at epsilon = 0)
    p = np.full((3, 64), 1 / 64)
    values, _, _ = threshold_max_many(p, p.copy(), 0.0, 1.0)
    assert values.tolist() == [1.0, 1.0, 1.0]
    q = p.copy()
    q[:, 0] *= 2  # max ratio still exactly 1 (any h on the other cells), but p != q: rounded up past it
    values, _, _ = threshold_max_many(p, q, 0.0, 1.0)
    assert np.all((values > 1.0) & (values < 1.0 + 1e-13))


@pytest.mark.parametrize("floor", [1.0, 1.0 - 2**-52, 0.75])
def test_floor_max_decides_the_floor_at_the_shortest_optimal_prefix(floor):
    # randomized response at 1e-12 as a matrix: the prefixes {0} (ratio 1 + 1e-12) and {0, 1} (ratio 1) tie to 1e-12;
    # the longest meets a floor near 1, the maximiser does not, and the value was the unconstrained 1 + 1e-12, above
    # the exact optimum with the floor (the rational simplex's) by 1e-12 relative
    from _rational_simplex import maximize_ratio

    from fairaudit.base.threshold_rule import floor_max_many

    p = np.array([0.50000000000025, 0.49999999999975])
    q = p[::-1].copy()
    value = float(floor_max_many(p, q, 0.0, 1.0, floor)[0])
    exact = maximize_ratio(
        [Fraction(x) for x in p],
        [Fraction(x) for x in q],
        [0, 0],
        [1, 1],
        [[-Fraction(x) for x in q]],
        [-Fraction(floor)],
    ).value
    assert exact is not None
    assert Fraction(value) >= exact and value - float(exact) <= 1e-14 * float(exact)
