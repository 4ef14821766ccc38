"""The verifier's tight bound and largest δ over a matrix's pairs, against a direct evaluation of their definitions;
its ln and exp enclosures against mpmath at 1,000 bits."""

from __future__ import annotations

import math
from fractions import Fraction as F

import mpmath
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from fairaudit.verification.enclosures import RecordedMechanism, exp_of, ln


def _pair_value(ra, rb, shift, scale):
    """min over t >= 1 of t + shift + scale * sum_o [ra_o - t rb_o]_+, evaluated at t = 1 and at every ratio >= 1."""
    candidates = {F(1)} | {x / y for x, y in zip(ra, rb) if y > 0 and x >= y}
    return min(t + shift + scale * sum(max(F(0), x - t * y) for x, y in zip(ra, rb)) for t in candidates)


@st.composite
def matrices(draw):
    """Row-stochastic matrices of 2 to 6 rows and 1 to 5 columns, cells multiples of 1/8 (ties, zeros) or small."""
    k, n = draw(st.integers(2, 6)), draw(st.integers(1, 5))
    rows = []
    for _ in range(k):
        weights = [draw(st.integers(0, 8)) for _ in range(n)]
        if not any(weights):
            weights[0] = 1
        rows.append([w / sum(weights) for w in weights])
    return rows


@given(matrices(), st.integers(0, 3), st.integers(1, 10), st.booleans())
@settings(max_examples=100, deadline=None)
def test_the_tight_bound_is_the_largest_pair_minimum(rows, lipschitz, gamma_tenths, with_metric):
    # the pruned sweep (pairs in decreasing order of their value at t = 1, each minimum by one pass over its sorted
    # breakpoints) against every pair's minimum evaluated at every candidate t
    k = len(rows)
    record = {"inputs": list(range(k)), "outputs": list(range(len(rows[0]))), "kind": "matrix", "matrix": rows}
    m = RecordedMechanism.from_record(record, "m")
    metric = [[abs(a - b) / k for b in range(k)] for a in range(k)] if with_metric else None
    tau, gamma = F(3, 10), F(gamma_tenths, 10)
    exact = [[F(v) for v in row] for row in rows]
    values = {
        (a, b): _pair_value(exact[a], exact[b], lipschitz * F(1 if metric is None else metric[a][b]) / tau, gamma / tau)
        for a in range(k)
        for b in range(k)
        if a != b
    }
    enclosure, a, b = m.tight_pair_log(F(lipschitz), gamma, tau, metric)
    best = max(values.values())
    assert values[(a, b)] == best  # the pair it names attains the largest minimum
    assert enclosure == ln(best)


@given(matrices(), st.integers(0, 40))
@settings(max_examples=100, deadline=None)
def test_the_largest_delta_is_the_largest_hockey_stick(rows, eps_tenths):
    # delta(eps) = max over ordered pairs of sum_o [M[a, o] - e^eps M[a', o]]_+, evaluated directly in fractions at
    # each end of e^eps, against the verifier's integers over one denominator
    k = len(rows)
    record = {"inputs": list(range(k)), "outputs": list(range(len(rows[0]))), "kind": "matrix", "matrix": rows}
    m = RecordedMechanism.from_record(record, "m")
    exact = [[F(v) for v in row] for row in rows]
    t = exp_of(F(eps_tenths, 10))

    def largest(at):
        return max(
            sum(max(F(0), x - at * y) for x, y in zip(exact[a], exact[b])) for a in range(k) for b in range(k) if a != b
        )

    delta = m.largest_delta(F(eps_tenths, 10))
    assert (delta.lo, delta.hi) == (largest(t.hi), largest(t.lo))


def _exact(value: mpmath.mpf) -> F:
    """An mpmath number as the rational it is (m·2^e)."""
    man, exp = value.man_exp  # (|mantissa|, exponent)
    magnitude = F(int(man) * 2 ** int(exp)) if exp >= 0 else F(int(man), 2 ** -int(exp))
    return -magnitude if value < 0 else magnitude


def _reference(f, x: F) -> tuple[F, F]:
    """f(x) at 1,000 bits by mpmath, widened by 2^-900 of it: rationals around the exact value, fixed independently of
    python-flint (mpmath's result is within a few units of 2^-1000 of it)."""
    with mpmath.workprec(1000):
        v = _exact(f(mpmath.mpf(x.numerator) / x.denominator))
    slack = abs(v) / 2**900
    return v - slack, v + slack


def test_ln_and_exp_at_known_values():
    assert (ln(F(1)).lo, ln(F(1)).hi) == (0, 0) and (exp_of(F(0)).lo, exp_of(F(0)).hi) == (1, 1)
    assert ln(F(0)).hi == -math.inf and ln(math.inf).lo == math.inf
    assert (exp_of(F(-(10**7))).lo, exp_of(F(-(10**7))).hi) == (0, F(1, 2**1000))  # e^(-10^7) < 2^-(1.4·10^7)
    e = ln(F(2))
    assert F(math.log(2)) - F(1, 2**52) < e.lo <= e.hi < F(math.log(2)) + F(1, 2**52)  # math.log's float, 1 ulp away


@given(
    st.one_of(
        st.fractions(min_value=F(1, 10**30), max_value=10**30, max_denominator=10**40),
        st.floats(min_value=1e-300, max_value=1e300),
        st.integers(1, 200).map(lambda k: 1 + F(1, 2**k)),  # near 1: ln x ≈ 2^-k, its relative width kept
        st.integers(1, 200).map(lambda k: 1 - F(1, 3**k)),
    )
)
@settings(max_examples=200, deadline=None)
def test_ln_encloses_the_exact_value_within_2_to_minus_200(x):
    x = F(x)
    assume(x != 1)
    e, (low, high) = ln(x), _reference(mpmath.log, x)
    assert e.lo <= high and low <= e.hi  # mpmath's value is inside: lo <= ln x <= hi
    assert e.hi - e.lo <= abs(high) / 2**200  # 2^-200 (1e-60) of |ln x| wide


@given(
    st.one_of(
        st.fractions(min_value=-1000, max_value=1000, max_denominator=10**20),
        st.floats(min_value=-(10**6), max_value=10**6),
        st.integers(1, 300).map(lambda k: F((-1) ** k, 2**k)),  # near 0: e^x − 1 ≈ ±2^-k, its relative width kept
    )
)
@settings(max_examples=200, deadline=None)
def test_exp_encloses_the_exact_value_within_2_to_minus_200(x):
    x = F(x)
    assume(x != 0)
    e, (low, high) = exp_of(x), _reference(mpmath.exp, x)
    assert e.lo <= high and low <= e.hi
    assert e.hi - e.lo <= min(low, abs(low - 1)) / 2**200
