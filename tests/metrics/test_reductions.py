"""The reductions behind the metrics: E[g | x, a] against exact ``Fraction`` arithmetic (the rational example).

P(U | A) is checked with the demographic-parity gap (``test_parity.py``); the chunked reductions against loops over
contexts in ``test_fairness_one_pass.py`` and ``test_fairness_scale.py``.
"""

from __future__ import annotations

from fractions import Fraction as F

import numpy as np
import pytest
from _rational_law import DECISIONS, G, fr_expected, rational_law

import fairaudit as fa


def test_expected_utility_by_fractions():
    e = fr_expected()
    # Hand: x0: a 1/4 + 3/4 = 1, b 1/3 + 1 = 4/3, c 1/5 + 3/5 = 4/5; x1: a 3/10 + 9/5 = 21/10, b 1/2 + 3/4 = 5/4,
    # c 5/8 + 3/4 = 11/8.
    assert e == [[F(1), F(4, 3), F(4, 5)], [F(21, 10), F(5, 4), F(11, 8)]]
    got = fa.expected_utility(rational_law(), fa.from_table([float(v) for v in G], DECISIONS))
    assert got == pytest.approx(np.array(e, dtype=float), rel=1e-12)
