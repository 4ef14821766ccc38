"""The rational example of the metrics' tests (exact ``Fraction`` arithmetic, hand calculations in the tests) and
random laws: shared by the tests of L and L̄, of the gaps and of the sups over g (``tests/metrics/``)."""

from __future__ import annotations

from fractions import Fraction as F

import numpy as np
from hypothesis import strategies as st

import fairaudit as fa

# --------------------------------------------------------------------------- the rational example

CONTEXTS = ("x0", "x1")
GROUPS = ("a", "b", "c")
DECISIONS = ("u0", "u1", "u2")
Q = [
    [[F(1, 2), F(1, 4), F(1, 4)], [F(1, 3), F(1, 3), F(1, 3)], [F(3, 5), F(1, 5), F(1, 5)]],
    [[F(1, 10), F(3, 10), F(3, 5)], [F(1, 4), F(1, 2), F(1, 4)], [F(1, 8), F(5, 8), F(1, 4)]],
]
G = [F(0), F(1), F(3)]
P_X = [F(1, 3), F(2, 3)]
P_A = [F(1, 2), F(1, 3), F(1, 6)]


def rational_law() -> fa.Law:
    return fa.Law(np.array(Q, dtype=float), CONTEXTS, GROUPS, DECISIONS)


def rational_population() -> fa.Population:
    return fa.Population.independent([float(p) for p in P_X], [float(p) for p in P_A], CONTEXTS, GROUPS)


def argmax_set(candidates):
    """(best value, set of keys attaining it) from (value, key) pairs in exact arithmetic."""
    best = max(v for v, _ in candidates)
    return best, {k for v, k in candidates if v == best}


def tv(p, q):
    return sum(max(F(0), pi - qi) for pi, qi in zip(p, q))


def fr_expected():
    return [[sum(Q[x][a][u] * G[u] for u in range(3)) for a in range(3)] for x in range(2)]


def fr_group_law():
    # Independent population: P(x | a) = P(x).
    return [[sum(P_X[x] * Q[x][a][u] for x in range(2)) for u in range(3)] for a in range(3)]


# --------------------------------------------------------------------------- random laws (and an independent population)


@st.composite
def laws(draw, zeros: bool = False):
    nx = draw(st.integers(1, 3))
    na = draw(st.integers(2, 4))
    nu = draw(st.integers(2, 4))
    lo = 0.0 if zeros else 0.01
    w = np.array(
        draw(st.lists(st.floats(lo, 1.0, allow_subnormal=False), min_size=nx * na * nu, max_size=nx * na * nu))
    ).reshape(nx, na, nu)
    w[w.sum(-1) == 0] = 1.0
    q = w / w.sum(-1, keepdims=True)
    px = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=nx, max_size=nx)))
    pa = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=na, max_size=na)))
    g = np.array(draw(st.lists(st.floats(0.0, 5.0), min_size=nu, max_size=nu)))
    law = fa.Law(q, list(range(nx)), list(range(na)), list(range(nu)))
    pop = fa.Population.independent(px / px.sum(), pa / pa.sum(), list(range(nx)), list(range(na)))
    return law, pop, fa.from_table(g, list(range(nu)))
