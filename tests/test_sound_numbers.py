"""Every certified number against its 50-digit value (issue 41): upper ends ≥ it and within 1e-9 of it.

The references are computed here from first principles with mpmath at 50 digits, on a seeded generator's
laws and mechanisms, near-degenerate ones included (cells of 1e-12, ties, ε from 1e-9 to 700); none of them
calls fairaudit's helpers.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest

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


@pytest.mark.slow
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
            for method in ("paper", "tight"):
                c = fa.calibrate(
                    target,
                    family=fa.randomized_response_family(range(k)),
                    method=method,
                    utility_class=fa.UtilityClass(gamma=1.0, tau=tau, lipschitz=0.05),
                )
                lx = _mp(0.05) / _mp(tau)
                exact = (
                    _mp(target) - mpmath.log1p(lx) if method == "paper" else mpmath.log(mpmath.exp(_mp(target)) - lx)
                )
                if exact > 0:
                    _lower(c.epsilon, exact, f"case {case}: calibrated {method}")
            lower = float(rng.uniform(0.01, 0.3))
            c = fa.calibrate(
                target,
                family=fa.randomized_response_family(range(k)),
                method="black_box",
                utility_class=fa.UtilityClass(lower=lower),
            )
            if math.isfinite(c.epsilon):
                # the black-box value at the calibrated ε is ≤ the target
                p, q = _rr_reference(_mp(c.epsilon), k)
                r = (_mp(lower) + (1 - _mp(lower)) * p) / (_mp(lower) + (1 - _mp(lower)) * q)
                assert mpmath.log(r) <= _mp(target), f"case {case}: black-box calibration"


def _box_reference(matrix, lower: float) -> Fraction | float:
    """max over ordered pairs (a, b) and h ∈ [lower, 1]^m of M[a]·h / M[b]·h, exactly (inf where a denominator is 0
    and its numerator is not): a linear-fractional program on a box is maximised at a vertex, h ∈ {lower, 1}^m."""
    rows = [[v if isinstance(v, Fraction) else Fraction(float(v)) for v in row] for row in matrix]
    best: Fraction | float = Fraction(1)
    for h in itertools.product((Fraction(lower), Fraction(1)), repeat=len(rows[0])):
        sums = [sum(p * v for p, v in zip(row, h)) for row in rows]
        if min(sums) == 0:
            if max(sums) > 0:
                return math.inf
            continue
        best = max(best, max(sums) / min(sums))
    return best


def _dinkelbach(top: dict, bottom: dict, cells: list, decisions: int) -> Fraction:
    """max over kernels K (a row on the simplex per cell) of Σ K[c, u] top[c, u] / Σ K[c, u] bottom[c, u], exactly.

    A second algorithm to the LP: the maximum is at a vertex of the product of simplices, a decision per cell, and
    Dinkelbach's iteration (per cell, the decision maximising top − λ bottom) reaches it in finitely many steps.
    """
    ratio = sum(top[c, 0] for c in cells) / sum(bottom[c, 0] for c in cells)
    while True:
        pick = {c: max(range(decisions), key=lambda u, c=c: top[c, u] - ratio * bottom[c, u]) for c in cells}
        n, d = sum(top[c, pick[c]] for c in cells), sum(bottom[c, pick[c]] for c in cells)
        if n - ratio * d <= 0 or n / d <= ratio:  # (the second: a 50-digit ratio that no longer rises)
            return max(ratio, n / d)
        ratio = n / d


def _model_reference(ma, mx: np.ndarray, g: np.ndarray, population: np.ndarray) -> tuple[Fraction, Fraction]:
    """The known-utility worst cases (L, L̄ as ratios) over every kernel K[x̃, ã, u], without τ, exactly (or at 50
    digits where ``ma`` holds mpmath numbers).

    E[g | x, a] = Σ_x̃ M_X[x, x̃] Σ_ã M_A[a, ã] Σ_u K[x̃, ã, u] g[x, a, u] and E[g | a] = Σ_x P(x | a) E[g | x, a].
    """
    real = _mp if isinstance(ma[0][0], mpmath.mpf) else _frac  # 50 digits, or exact rationals
    MX, G, P = ([[real(v) for v in row] for row in m] for m in (mx, g.reshape(len(g), -1), population))
    MA = [[v if isinstance(v, mpmath.mpf) else real(v) for v in row] for row in ma]
    n_x, n_a, n_u = g.shape
    cells = list(itertools.product(range(mx.shape[1]), range(len(MA[0]))))
    col = [sum(P[x][a] for x in range(n_x)) for a in range(n_a)]

    def coefficients(a: int, weight: list[Fraction]) -> dict:
        return {
            ((xt, at), u): sum(w * MX[x][xt] * MA[a][at] * G[x][a * n_u + u] for x, w in enumerate(weight))
            for (xt, at) in cells
            for u in range(n_u)
        }

    local = glob = real(1.0)
    for a, b in itertools.permutations(range(n_a), 2):
        for x in range(n_x):
            one = [real(float(y == x)) for y in range(n_x)]
            local = max(local, _dinkelbach(coefficients(a, one), coefficients(b, one), cells, n_u))
        given = [[P[x][c] / col[c] for x in range(n_x)] for c in (a, b)]
        glob = max(glob, _dinkelbach(coefficients(a, given[0]), coefficients(b, given[1]), cells, n_u))
    return local, glob


def _frac(v: float) -> Fraction:
    return Fraction(float(v))


def _log(r) -> mpmath.mpf:
    if isinstance(r, mpmath.mpf):
        return mpmath.log(r)
    return mpmath.log(mpmath.mpf(r.numerator) / r.denominator)


@pytest.mark.slow
def test_black_box_bound_of_general_mechanisms_against_50_digits():
    """The black-box route on a general M_A (the threshold solution, and the LP forced): ≥ the exact box program."""
    rng = np.random.default_rng(17)
    with mpmath.workdps(50):
        for case in range(CASES // 10):
            matrix = _matrix(rng)
            mech = fa.from_matrix(matrix, list(range(matrix.shape[0])), list(range(matrix.shape[1])))
            lower = float(rng.choice([0.01, 0.125, 0.3, float(rng.uniform(0.001, 0.5))]))
            exact = _log(_box_reference(matrix, lower))
            for method in ("auto", "lp"):
                got = fa.black_box_bound(mech, utility_class=fa.UtilityClass(lower=lower), method=method)
                assert got.certified, f"case {case} ({method}): not certified ({got.reason})"
                _upper(got.value, exact, f"case {case}: black box ({method})")


@pytest.mark.slow
def test_known_utility_worst_case_by_the_lp_against_50_digits():
    """The general LP route (worst_model, method="lp"): a utility that depends on the group, M_X not the identity,
    a dependent population; every value ≥ the exact maximum (Dinkelbach over the vertices, in rationals)."""
    rng = np.random.default_rng(23)
    with mpmath.workdps(50):
        for case in range(CASES // 20):
            ma = _matrix(rng)
            n_a, n_x, n_u = ma.shape[0], int(rng.integers(1, 3)), int(rng.integers(2, 4))
            mx = np.eye(n_x) if case % 3 == 0 else rng.dirichlet(np.ones(n_x), size=n_x)
            g = np.round(rng.uniform(0.05, 1.0, size=(n_x, n_a, n_u)) * 64) / 64  # ties between cells
            population = rng.dirichlet(np.ones(n_x * n_a)).reshape(n_x, n_a)
            if case % 2:  # g free of the group and X ⊥ A: the closed forms of method="auto" (M_X stays in L-bar's)
                g[:] = g[:, :1]
                population = np.outer(rng.dirichlet(np.ones(n_x)), rng.dirichlet(np.ones(n_a)))
            groups, contexts, decisions = list(range(n_a)), [f"x{i}" for i in range(n_x)], [f"u{i}" for i in range(n_u)]
            local, glob = _model_reference(ma, mx, g, population)
            for method in ("lp", "auto"):
                w = fa.worst_model(
                    fa.from_matrix(ma, groups, list(range(ma.shape[1]))),
                    fa.from_table(g, decisions, contexts, groups),
                    context_mechanism=fa.from_matrix(mx, contexts, [f"r{i}" for i in range(n_x)]),
                    population=fa.Population(population, contexts, groups),
                    method=method,
                )
                for got, exact, what in ((w.local_fairness, local, "L"), (w.global_fairness, glob, "L-bar")):
                    assert got.certified, f"case {case} ({method}): {what} not certified ({got.reason})"
                    _upper(got.value, _log(exact), f"case {case}: worst model {what} ({method}, {got.method})")


def test_observed_fairness_against_50_digits():
    """Observed L and L̄ of a law (exact values, not bounds): within 1e-9 of the 50-digit value, ratios near 1 included."""
    rng = np.random.default_rng(29)
    with mpmath.workdps(50):
        for case in range(CASES // 4):
            n_x, n_a, n_u = int(rng.integers(1, 4)), int(rng.integers(2, 5)), int(rng.integers(2, 4))
            law = rng.dirichlet(np.ones(n_u), size=(n_x, n_a))
            if case % 2:  # nearly equal groups: ratios of 1 + 1e-12
                law[:, 1:] = law[:, :1] + rng.uniform(-1e-12, 1e-12, size=(n_x, n_a - 1, n_u))
                law = np.abs(law) / np.abs(law).sum(axis=2, keepdims=True)
            g = rng.uniform(0.01, 1.0, size=n_u)
            population = rng.dirichlet(np.ones(n_x * n_a)).reshape(n_x, n_a)
            contexts, groups, decisions = list(range(n_x)), list(range(n_a)), list(range(n_u))
            table = fa.Law(law, contexts, groups, decisions)
            utility = fa.from_table(g, decisions)
            pop = fa.Population(population, contexts, groups)
            e = [[mpmath.fsum(_mp(p) * _mp(v) for p, v in zip(law[x, a], g)) for a in range(n_a)] for x in range(n_x)]
            local = max(mpmath.log(max(row) / min(row)) for row in e)
            by_group = [mpmath.fsum(_mp(population[x, a]) * e[x][a] for x in range(n_x)) for a in range(n_a)]
            by_group = [v / mpmath.fsum(_mp(population[x, a]) for x in range(n_x)) for a, v in enumerate(by_group)]
            glob = mpmath.log(max(by_group) / min(by_group))
            for got, exact, what in (
                (fa.local_fairness(table, utility).value, local, "L"),
                (fa.global_fairness(table, utility, population=pop).value, glob, "L-bar"),
            ):
                assert abs(_mp(got) - exact) <= TOL * max(1, abs(exact)), (
                    f"case {case}: observed {what} {got!r} {exact}"
                )


@pytest.mark.slow
def test_known_utility_worst_case_with_a_binding_tau_against_the_exact_simplex():
    """G-space with a binding τ and M_X not the identity (coefficients with roundings): each route's value ≥ the exact
    maximum of the same program solved in rationals by the bounded simplex and Dinkelbach (a second algorithm)."""
    from _rational_simplex import maximize_ratio

    rng = np.random.default_rng(31)
    with mpmath.workdps(50):
        for case in range(CASES // 25):
            ma = _matrix(rng)
            n_a, n_x = ma.shape[0], int(rng.integers(2, 3))
            mx = rng.dirichlet(np.ones(n_x), size=n_x)
            g = np.array([1.0, 0.1])
            tau = float(rng.uniform(0.15, 0.5))
            groups, contexts = list(range(n_a)), [f"x{i}" for i in range(n_x)]
            pop = fa.Population.uniform(contexts, groups)
            try:
                w = [
                    fa.worst_model(
                        fa.from_matrix(ma, groups, list(range(ma.shape[1]))),
                        fa.from_table(g, ["yes", "no"]),
                        context_mechanism=fa.from_matrix(mx, contexts, [f"r{i}" for i in range(n_x)]),
                        population=pop,
                        tau=tau,
                        method=method,
                    ).local_fairness
                    for method in ("auto", "lp")
                ]
            except fa.InputError:
                continue
            rows = [[_frac(a) * _frac(b) for a in mx[x] for b in ma[c]] for x in range(n_x) for c in range(n_a)]
            n = mx.shape[1] * ma.shape[1]
            best = None
            for x in range(n_x):
                for a, b in itertools.permutations(range(n_a), 2):
                    out = maximize_ratio(
                        rows[x * n_a + a], rows[x * n_a + b], [Fraction(0.1)] * n, [Fraction(1)] * n,
                        [[-v for v in row] for row in rows], [-Fraction(tau)] * len(rows),
                    )  # fmt: skip
                    if out.status == "optimal":
                        best = out.value if best is None else max(best, out.value)
            if best is None:
                assert all(math.isnan(r.value) for r in w), f"case {case}: infeasible, yet {w[0].value}"
                continue
            for r, method in zip(w, ("auto", "lp")):
                assert r.certified, f"case {case} ({method}): not certified"
                _upper(r.value, _log(best), f"case {case}: worst model with tau ({method})")


@pytest.mark.slow
def test_worst_utility_of_a_law_against_50_digits():
    """The known-law worst case (worst_utility): L on the law's rows, L̄ on P(u | a) = Σ_x P(x | a) Q[x, a, u] under a
    dependent population (computed with roundings); both ≥ the exact box programs (vertices of [lower, 1]^n_u)."""
    rng = np.random.default_rng(37)
    with mpmath.workdps(50):
        for case in range(CASES // 10):
            n_x, n_a, n_u = int(rng.integers(1, 4)), int(rng.integers(2, 4)), int(rng.integers(2, 5))
            q = np.stack([_matrix_of(rng, n_a, n_u) for _ in range(n_x)])
            population = rng.dirichlet(np.ones(n_x * n_a)).reshape(n_x, n_a)
            lower = float(rng.choice([0.0, 0.05, float(rng.uniform(0.001, 0.5))]))
            contexts, groups, decisions = list(range(n_x)), list(range(n_a)), list(range(n_u))
            for method in ("auto", "lp"):
                w = fa.worst_utility(
                    fa.Law(q, contexts, groups, decisions),
                    utility_class=fa.UtilityClass(lower=lower),
                    population=fa.Population(population, contexts, groups),
                    method=method,
                )
                local = max(_box_reference(q[x], lower) for x in range(n_x))
                P = [[_frac(v) for v in row] for row in population]
                by_group = [
                    [sum(P[x][a] * _frac(q[x, a, u]) for x in range(n_x)) / sum(P[x][a] for x in range(n_x)) for u in range(n_u)]
                    for a in range(n_a)
                ]  # fmt: skip
                glob = _box_reference(by_group, lower)
                for got, exact, what in ((w.local_fairness, local, "L"), (w.global_fairness, glob, "L-bar")):
                    if math.isinf(got.value):
                        assert exact == math.inf, f"case {case} ({method}): {what} is inf"
                        continue
                    assert got.certified, f"case {case} ({method}): {what} not certified"
                    _upper(got.value, _log(exact), f"case {case}: worst utility {what} ({method})")


def _matrix_of(rng: np.random.Generator, n: int, m: int) -> np.ndarray:
    x = rng.dirichlet(np.ones(m), size=n)
    x[rng.random((n, m)) < 0.2] = 1e-12
    return x / x.sum(axis=1, keepdims=True)


@pytest.mark.slow
def test_known_utility_worst_case_behind_randomized_response_against_50_digits():
    """worst_model behind k-ary randomized response (its closed forms, with M_X and a population): ≥ the worst case
    over the kernels, by Dinkelbach at 50 digits on the mechanism's exact law p = e^ε/(e^ε + k − 1)."""
    rng = np.random.default_rng(43)
    with mpmath.workdps(50):
        for case in range(CASES // 40):
            k, n_x, n_u = int(rng.integers(2, 4)), int(rng.integers(1, 3)), int(rng.integers(2, 4))
            eps = float(rng.uniform(0.05, 4.0))
            t = mpmath.exp(_mp(eps))
            ma = [[t / (t + k - 1) if a == b else 1 / (t + k - 1) for b in range(k)] for a in range(k)]
            mx = np.eye(n_x) if case % 2 else rng.dirichlet(np.ones(n_x), size=n_x)
            g = np.repeat((np.round(rng.uniform(0.05, 1.0, size=(n_x, 1, n_u)) * 64) / 64), k, axis=1)
            population = np.outer(rng.dirichlet(np.ones(n_x)), rng.dirichlet(np.ones(k)))
            groups, contexts, decisions = list(range(k)), [f"x{i}" for i in range(n_x)], [f"u{i}" for i in range(n_u)]
            local, glob = _model_reference(ma, mx, g, population)
            w = fa.worst_model(
                fa.randomized_response(groups, eps),
                fa.from_table(g, decisions, contexts, groups),
                context_mechanism=fa.from_matrix(mx, contexts, [f"r{i}" for i in range(n_x)]),
                population=fa.Population(population, contexts, groups),
            )
            for got, exact, what in ((w.local_fairness, local, "L"), (w.global_fairness, glob, "L-bar")):
                assert got.certified, f"case {case}: {what} not certified ({got.reason})"
                _upper(got.value, _log(exact), f"case {case}: randomized response, {what} ({got.method})")
