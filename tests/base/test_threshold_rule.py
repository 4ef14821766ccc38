"""The threshold rule over boxes, batched, and a box plus one floor: against the validated solution and the LP."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fairaudit.base.linear_fractional import lp_max, threshold_max
from fairaudit.base.threshold_rule import box_point, floor_max_many, threshold_max_many


def _instance(seed: int, n: int):
    rng = np.random.default_rng(seed)
    p, q = rng.dirichlet(np.ones(n)), rng.dirichlet(np.ones(n))
    lo = rng.uniform(0, 0.5, n) * rng.integers(0, 2)
    return p, q, lo, lo + rng.uniform(0.01, 1.0, n)


@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.integers(1, 5))
def test_a_batch_is_each_program_alone(seed, n, batch):
    # threshold_max_many over a batch of boxes gives each program's own value and point (threshold_max, validated).
    boxes = [_instance(seed + i, n) for i in range(batch)]
    p, q, lo, hi = (np.stack(column) for column in zip(*boxes))
    values, k, order = threshold_max_many(p, q, lo, hi)
    for i in range(batch):
        alone = threshold_max(p[i], q[i], lo[i], hi[i])
        assert values[i] == alone.value
        assert box_point(lo[i], hi[i], order[i], int(k[i])).tolist() == alone.argmax.tolist()


@given(st.integers(0, 2**32 - 1), st.integers(1, 20), st.floats(0.01, 1.0))
def test_floor_closed_form_equals_lp(seed, n, share):
    # max p·h / q·h over the box with q·h >= floor: closed form (fractional knapsack at the floor) vs the LP.
    p, q, lo, hi = _instance(seed, n)
    floor = q @ lo + share * (q @ hi - q @ lo)
    if floor <= 0:
        return
    v, k, frac, order = floor_max_many(p, q, lo, hi, floor)
    lp = lp_max(p, q, lower=lo, upper=hi, A_ub=-q[None, :], b_ub=[-floor])
    assert float(v) == pytest.approx(lp.value, rel=1e-7)
    h = box_point(lo, hi, order, int(k), float(frac))
    assert q @ h >= floor * (1 - 1e-12) and (p @ h) / (q @ h) == pytest.approx(float(v), rel=1e-12)
