"""Calibration of randomized response: closed form against a second algorithm."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

import fairaudit as fa


@given(st.integers(2, 16), st.floats(0.0, 0.9), st.floats(0.01, 3.0))
def test_closed_form_equals_bisection_on_black_box(k, rho, target):
    # Second algorithm: bisection on the exact threshold worst case of randomized response.
    c = fa.calibrate_randomized_response(target, k, lower=rho, gamma=1.0)
    if math.isinf(c.epsilon):
        assert rho > 0 and math.exp(target) * rho >= 1 - 1e-12
        return

    def bound(eps):
        return fa.black_box_bound(fa.randomized_response(list(range(k)), eps), lower=rho, gamma=1.0).value

    lo, hi = 0.0, 60.0
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if bound(mid) <= target else (lo, mid)
    assert c.epsilon == pytest.approx(lo, rel=1e-9, abs=1e-12)
    assert c.bound == pytest.approx(target, rel=1e-9)


def test_tight_with_lipschitz_has_a_floor():
    # g depending on the group with L_A = 0.2, tau = 0.5: at epsilon = 0 the bound is log(1 + 0.2/0.5 + ...) > 0.
    with pytest.raises(fa.InputError, match="below the tight bound at epsilon = 0"):
        fa.calibrate_randomized_response(0.1, 2, method="tight", tau=0.5, lipschitz=0.2)
    c = fa.calibrate_randomized_response(1.0, 2, method="tight", tau=0.5, lipschitz=0.2)
    assert fa.tight_bound(fa.randomized_response([0, 1], c.epsilon), gamma=1.0, tau=0.5, lipschitz=0.2).value == \
        pytest.approx(1.0, rel=1e-9)


def test_paper_and_tight_reduce_to_target_without_lipschitz():
    # delta = 0 at epsilon for randomized response and L_A = 0: both bounds are min(...) <= epsilon, equal to it here.
    for method in ("paper", "tight"):
        c = fa.calibrate_randomized_response(0.7, 3, method=method, tau=0.05)
        assert c.epsilon == pytest.approx(0.7, rel=1e-9)
