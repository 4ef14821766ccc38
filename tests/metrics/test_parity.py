"""The total-variation gaps L_dp and L_eo: exact ``Fraction`` arithmetic with explicit loops over every pair of
groups (the rational example), and the links theorem as a property.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction as F

import numpy as np
import pytest
from _rational_law import (
    CONTEXTS,
    DECISIONS,
    GROUPS,
    Q,
    argmax_set,
    fr_group_law,
    laws,
    rational_law,
    rational_population,
    tv,
)
from hypothesis import given

import fairaudit as fa
from fairaudit.metrics.reductions import group_decision_law


def test_demographic_parity_by_fractions():
    pu = fr_group_law()
    # Hand: P(U | a) = 1/3 (1/2, 1/4, 1/4) + 2/3 (1/10, 3/10, 3/5) = (7/30, 17/60, 29/60).
    assert pu[0] == [F(7, 30), F(17, 60), F(29, 60)]
    best, keys = argmax_set([(tv(pu[a], pu[b]), (a, b)) for a, b in itertools.permutations(range(3), 2)])
    assert best == F(1, 4)
    got = group_decision_law(rational_law(), rational_population())
    assert got == pytest.approx(np.array(pu, dtype=float), rel=1e-12)
    r = fa.demographic_parity(rational_law(), rational_population())
    assert r.value == pytest.approx(float(best), rel=1e-12)
    a, b = GROUPS.index(r.group), GROUPS.index(r.other_group)
    assert (a, b) in keys
    # The event is where the group puts more mass than the other group, and it carries the whole TV.
    ev = [DECISIONS.index(u) for u in r.event]
    assert sum(pu[a][u] - pu[b][u] for u in ev) == best


def test_equalized_odds_by_fractions():
    best, keys = argmax_set(
        [(tv(Q[x][a], Q[x][b]), (x, a, b)) for x in range(2) for a, b in itertools.permutations(range(3), 2)]
    )
    # Hand: x1, c vs a: [1/8 − 1/10]₊ + [5/8 − 3/10]₊ + [1/4 − 3/5]₊ = 1/40 + 13/40 = 7/20; the pair (a, b) in x1
    # ties with x1, a vs b: [3/5 − 1/4]₊ = 7/20 (and TV is symmetric): the maximisers are {a, c} and {a, b} in x1,
    # in either order; the package may return any of them.
    assert best == F(7, 20) and keys == {(1, 0, 1), (1, 1, 0), (1, 0, 2), (1, 2, 0)}
    r = fa.equalized_odds(rational_law(), rational_population())
    assert r.value == pytest.approx(0.35, rel=1e-12)
    x, a, b = CONTEXTS.index(r.context), GROUPS.index(r.group), GROUPS.index(r.other_group)
    assert (x, a, b) in keys
    ev = [DECISIONS.index(u) for u in r.event]
    assert sum(Q[x][a][u] - Q[x][b][u] for u in ev) == best


# --------------------------------------------------------------------------- property: the links theorem


@given(laws(zeros=True))
def test_links_theorem(data):
    # Paper SI B: L_eo ≤ exp(sup_g L) − 1 and L_dp ≤ exp(sup_g L̄) − 1.
    law, pop, _ = data
    eo = fa.equalized_odds(law, pop).value
    dp = fa.demographic_parity(law, pop).value
    assert eo <= math.expm1(fa.sup_local_fairness(law, pop).value) + 1e-12
    assert dp <= math.expm1(fa.sup_global_fairness(law, pop).value) + 1e-12
