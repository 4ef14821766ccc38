"""The verifier's tight bound and largest δ over a matrix's pairs, against a direct evaluation of their definitions."""

from __future__ import annotations

from fractions import Fraction as F

from hypothesis import given, settings
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
