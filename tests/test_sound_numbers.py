"""Every certified number against its 50-digit value (issue 41): upper ends ≥ it and within 1e-9 of it.

The references are computed here from first principles with mpmath at 50 digits, on a seeded generator's
laws and mechanisms, near-degenerate ones included (cells of 1e-12, ties, ε from 1e-9 to 700); none of them
calls fairaudit's helpers.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np

import fairaudit as fa
from fairaudit.worstcase.randomized_response import rr_class_value

mp = mpmath.mp
TOL = 1e-9
CASES = 1000


def _mp(x: float) -> mpmath.mpf:
    return mpmath.mpf(float(x))  # a float is exact in mpmath's binary floats


def _upper(got: float, exact: mpmath.mpf, what: str) -> None:
    assert _mp(got) >= exact, f"{what}: {got!r} below the 50-digit value {exact}"
    assert _mp(got) <= exact + TOL * max(1, abs(exact)), f"{what}: {got!r} too far above {exact}"


def _lower(got: float, exact: mpmath.mpf, what: str) -> None:
    assert _mp(got) <= exact, f"{what}: {got!r} above the 50-digit value {exact}"
    assert _mp(got) >= exact - TOL * max(1, abs(exact)), f"{what}: {got!r} too far below {exact}"


def _epsilon(rng: np.random.Generator) -> float:
    kind = rng.integers(4)
    if kind == 0:
        return float(10.0 ** rng.uniform(-9, -6))
    if kind == 1:
        return float(rng.uniform(690, 700))
    return float(rng.uniform(0.01, 5.0))


def _matrix(rng: np.random.Generator) -> np.ndarray:
    n, m = int(rng.integers(2, 4)), int(rng.integers(2, 5))
    kind = rng.integers(3)
    if kind == 0:  # tiny cells
        x = rng.dirichlet(np.ones(m), size=n)
        x[rng.random((n, m)) < 0.3] = 1e-12
    elif kind == 1:  # ties: repeated rows and entries
        x = rng.dirichlet(np.ones(m), size=1).repeat(n, axis=0)
        x[0] = x[0][::-1]
    else:
        x = rng.dirichlet(np.ones(m) * 0.7, size=n) + 1e-9
    return x / x.sum(axis=1, keepdims=True)


def _delta(matrix: np.ndarray, t: mpmath.mpf) -> tuple[mpmath.mpf, list]:
    n = matrix.shape[0]
    per = {}
    for a in range(n):
        for b in range(n):
            if a != b:
                per[a, b] = mpmath.fsum(max(mpmath.mpf(0), _mp(p) - t * _mp(q)) for p, q in zip(matrix[a], matrix[b]))
    return max(per.values()), per


def _tight_reference(matrix: np.ndarray, gamma: float, tau: float) -> mpmath.mpf:
    n = matrix.shape[0]
    best = mpmath.mpf(-1)
    for a in range(n):
        for b in range(n):
            if a == b:
                continue
            ts = [mpmath.mpf(1)] + [
                _mp(p) / _mp(q) for p, q in zip(matrix[a], matrix[b]) if q > 0 and _mp(p) / _mp(q) > 1
            ]
            objective = min(
                t
                + _mp(gamma)
                * mpmath.fsum(max(mpmath.mpf(0), _mp(p) - t * _mp(q)) for p, q in zip(matrix[a], matrix[b]))
                / _mp(tau)
                for t in ts
            )
            best = max(best, objective)
    return mpmath.log(best)


def test_general_mechanisms_against_50_digits():
    rng = np.random.default_rng(41)
    with mpmath.workdps(50):
        for case in range(CASES // 4):
            matrix = _matrix(rng)
            mech = fa.from_matrix(matrix, list(range(matrix.shape[0])), list(range(matrix.shape[1])))
            eps_true = max(mpmath.log(_mp(p) / _mp(q)) for col in matrix.T for p in col for q in col if q > 0 and p > 0)
            _upper(mech.epsilon, eps_true, f"case {case}: epsilon")
            e = _epsilon(rng) if case % 2 else float(eps_true) * 0.5
            d_true, _ = _delta(matrix, mpmath.exp(_mp(e)))
            _upper(mech.delta(e), d_true, f"case {case}: delta({e})")
            tau = float(rng.uniform(0.05, 0.5))
            _upper(
                fa.tight_bound(mech, utility_class=fa.UtilityClass(gamma=1.0, tau=tau)).value,
                _tight_reference(matrix, 1.0, tau),
                f"case {case}: tight",
            )
            _upper(fa.corollary_bound(mech).value, eps_true, f"case {case}: corollary")
            paper = fa.paper_bound(mech, utility_class=fa.UtilityClass(gamma=1.0, tau=tau))
            t = mpmath.exp(_mp(paper.epsilon))  # the paper value is certified at its own ε (any ε is valid)
            at = mpmath.log(t) + mpmath.log1p(_delta(matrix, t)[0] / _mp(tau))
            assert _mp(paper.value) >= at - mpmath.mpf(2) ** -50 * (1 + at)  # ε is ln t to nearest


def _rr_reference(eps: mpmath.mpf, k: int) -> tuple[mpmath.mpf, mpmath.mpf]:
    t = mpmath.exp(eps)
    return t / (t + k - 1), 1 / (t + k - 1)


def test_randomized_response_closed_forms_against_50_digits():
    rng = np.random.default_rng(7)
    with mpmath.workdps(50):
        for case in range(CASES // 2):
            k = int(rng.integers(2, 9))
            eps = _epsilon(rng)
            m = fa.randomized_response(list(range(k)), eps)
            p, q = _rr_reference(_mp(eps), k)
            assert abs(_mp(m.keep_probability) - p) <= 1e-15 * p, f"case {case}: keep"
            keep = float(rng.uniform(1.0 / k + 1e-3, 1 - 1e-9))
            _upper(
                fa.epsilon_from_keep_probability(keep, k),
                mpmath.log(_mp(keep) * (k - 1) / (1 - _mp(keep))),
                f"case {case}: epsilon from keep",
            )
            e2 = eps * float(rng.uniform(0, 1))
            _upper(m.delta(e2), max(mpmath.mpf(0), p - mpmath.exp(_mp(e2)) * q), f"case {case}: delta")
            dl = float(rng.uniform(0, 0.5)) * float(p - q)
            if dl > 0:
                _upper(
                    m.epsilon_for_delta(dl),
                    max(mpmath.mpf(0), mpmath.log((p - _mp(dl)) / q)),
                    f"case {case}: eps for delta",
                )
            tau = float(rng.uniform(0.05, 1.0))
            c = fa.UtilityClass(gamma=1.0, tau=tau)
            x_one = (p - q) / _mp(tau)
            paper = min(mpmath.log1p(x_one), _mp(eps))
            tight = min(mpmath.log(1 + x_one), _mp(eps))
            _upper(fa.paper_bound(m, utility_class=c).value, paper, f"case {case}: paper")
            _upper(fa.tight_bound(m, utility_class=c).value, tight, f"case {case}: tight")
            lower = float(rng.uniform(0.01, 0.5))
            value = rr_class_value(m.rr, lower, 1.0, None, 0.0, 1.0)
            ratio = (_mp(lower) + (1 - _mp(lower)) * p) / (_mp(lower) + (1 - _mp(lower)) * q)
            _upper(value, mpmath.log(ratio), f"case {case}: black box closed form")


def test_black_box_bound_of_randomized_response_against_50_digits():
    """The black-box route (worstcase/black_box.py) on randomized response: its closed form rounded up."""
    rng = np.random.default_rng(5)
    with mpmath.workdps(50):
        for case in range(CASES // 10):
            k, eps = int(rng.integers(2, 9)), _epsilon(rng)
            m = fa.randomized_response(list(range(k)), eps)
            p, q = _rr_reference(_mp(eps), k)
            lower = float(rng.uniform(0.01, 0.5))
            value = fa.black_box_bound(m, utility_class=fa.UtilityClass(gamma=1.0, lower=lower)).value
            ratio = (_mp(lower) + (1 - _mp(lower)) * p) / (_mp(lower) + (1 - _mp(lower)) * q)
            _upper(value, mpmath.log(ratio), f"case {case}: black box")


def test_calibrated_epsilon_is_a_lower_end():
    rng = np.random.default_rng(11)
    with mpmath.workdps(50):
        for case in range(CASES // 4):
            k = int(rng.integers(2, 6))
            target = float(rng.uniform(0.05, 3.0))
            tau = float(rng.uniform(0.05, 0.5))
            x = _mp(0.0) / _mp(tau)
            for method in ("paper", "tight"):
                c = fa.calibrate(
                    target, groups=k, method=method, utility_class=fa.UtilityClass(gamma=1.0, tau=tau, lipschitz=0.05)
                )
                lx = _mp(0.05) / _mp(tau)
                exact = (
                    _mp(target) - mpmath.log1p(lx) if method == "paper" else mpmath.log(mpmath.exp(_mp(target)) - lx)
                )
                if exact > 0:
                    _lower(c.epsilon, exact, f"case {case}: calibrated {method}")
            del x
            lower = float(rng.uniform(0.01, 0.3))
            c = fa.calibrate(target, groups=k, method="black_box", utility_class=fa.UtilityClass(lower=lower))
            if math.isfinite(c.epsilon):
                # the black-box value at the calibrated ε is ≤ the target
                p, q = _rr_reference(_mp(c.epsilon), k)
                r = (_mp(lower) + (1 - _mp(lower)) * p) / (_mp(lower) + (1 - _mp(lower)) * q)
                assert mpmath.log(r) <= _mp(target), f"case {case}: black-box calibration"
