"""The one-floor relaxation's threshold over the model's table (``base.table_relaxation``), against a second route: f and
R evaluated in Fractions at every breakpoint of every row and at R's root, found by hand on the linear pieces between
them (a convex piecewise-linear function is least at one of its kinks)."""

from __future__ import annotations

import math
import sys
from fractions import Fraction as F

from hypothesis import example, given
from hypothesis import strategies as st

from fairaudit.base.table_relaxation import relaxation_bounds

_VALUES = st.sampled_from([F(0), F(1), F(1, 3), F(2, 7), F(1, 2**1000), F(5, 3**40), F(1, 10**12), F(1) + F(1, 2**52)])


@st.composite
def _forms(draw):
    """E per group over 1 to 4 rows and 1 to 5 decisions (zeros, tiny cells, near-ties), some decisions the same cell
    as another in every group (a utility with fewer values than decisions); a floor or none."""
    k, rows, cells = draw(st.integers(2, 3)), draw(st.integers(1, 4)), draw(st.integers(1, 3))
    decisions = draw(st.lists(st.integers(0, cells - 1), min_size=1, max_size=5))  # (each decision's cell)
    forms = {}
    for a in range(k):
        table = [draw(st.lists(_VALUES, min_size=cells, max_size=cells)) for _ in range(rows)]
        forms[a] = [[row[c] for c in decisions] for row in table]
    return forms, draw(st.sampled_from([F(1, 10), F(1, 4), F(1, 2), F(1, 10**9), None]))


def _r(top, bottom, theta):
    return sum(max(p - theta * q for p, q in zip(pr, qr, strict=True)) for pr, qr in zip(top, bottom, strict=True))


def _kinks(top, bottom):
    """Every θ where a row's maximiser may change (the slopes between its decisions), and 0, sorted."""
    out = {F(0)}
    for pr, qr in zip(top, bottom, strict=True):
        out |= {(pr[u] - pr[v]) / (qr[u] - qr[v]) for u in range(len(pr)) for v in range(u) if qr[u] != qr[v]}
    return sorted(out)


def _least_root(top, bottom, kinks, start):
    """R's least root ≥ ``start`` (a kink, or below every kink), R linear between kinks and beyond them; None if none."""
    points = [x for x in kinks if x >= start] if start in kinks else [start, *kinks]
    if _r(top, bottom, points[0]) <= 0:
        if start in kinks:
            return start
        slope = _r(top, bottom, points[0]) - _r(top, bottom, points[0] - 1)  # (below every kink: linear)
        return points[0] - _r(top, bottom, points[0]) / slope if slope else None
    for x, y in zip(points, points[1:]):
        rx, ry = _r(top, bottom, x), _r(top, bottom, y)
        if ry <= 0:
            return x + rx * (y - x) / (rx - ry)
    last = points[-1]
    slope = _r(top, bottom, last + 1) - _r(top, bottom, last)  # (beyond every kink: linear)
    return last - _r(top, bottom, last) / slope if slope < 0 else None


def _by_hand(top, bottom, t):
    """The pair's bound by the second route: with a floor, the least f over the kinks and R's root (None where no
    table meets the floor: f has no least value); without, R's least root ≥ 0, 0/0 = 1 where every row allows
    q = 0, +inf where R has no root."""
    kinks = _kinks(top, bottom)
    if t is None:
        root = _least_root(top, bottom, kinks, F(0))
        if root is None:
            return math.inf
        return max(root, F(1)) if all(0 in row for row in bottom) else root
    if sum(max(row) for row in bottom) < t:
        return None
    candidates = [*kinks, _least_root(top, bottom, kinks, kinks[0] - 1)]
    return min(theta + max(_r(top, bottom, theta), 0) / t for theta in candidates if theta is not None)


@given(_forms())
@example(({0: [[F(3, 4), F(0)], [F(1, 4), F(0)]], 1: [[F(1, 8), F(0)], [F(3, 8), F(0)]]}, F(1, 4)))  # (§4g: 10/3)
@example(({0: [[F(3, 14), F(3, 2), F(2), F(9, 17)]], 1: [[F(6, 5), F(3), F(1, 4), F(1, 2)]]}, F(1, 3)))  # (θ < 0)
def test_the_threshold_found_is_the_least_bound_over_every_kink(program):
    # f(θ) = θ + max(R(θ), 0)/t is convex and piecewise linear, its kinks at the rows' breakpoints and at R's root:
    # its least value, computed at every one of them in Fractions, is the bound returned, exactly, and f at the θ
    # returned is that bound. Without a floor the bound is R's least root ≥ 0, found on R's linear pieces. Where no
    # table meets the floor f has no least value: θ is the least float
    forms, t = program
    screens = relaxation_bounds(forms, dict.fromkeys(forms, t))
    for (a, b), (screen, theta) in screens.items():
        expected = _by_hand(forms[a], forms[b], t)
        if t is None:
            assert theta is None and screen == expected, (a, b)
        elif expected is None:
            assert theta == F(-sys.float_info.max), (a, b)
        else:
            assert screen == expected == theta + max(_r(forms[a], forms[b], theta), 0) / t, (a, b)


def test_a_row_s_equal_decisions_tie_everywhere_and_are_no_near_tie_by_hand():
    # one row, its first two decisions the same cell in both groups: group 1's (1/2, 1/2, 1/3), group 0's (1/4, 1/4,
    # 1/2). Pair (1, 0) at t = 1/3: the table on the first two, ratio 2, has q = 1/4 < 1/3, so f is least at the hull
    # edge (q, p) = (1/4, 1/2) -> (1/2, 1/3), slope -2/3: R(-2/3) = 1/2 + 1/6 = 2/3 and f = -2/3 + 2 = 4/3 (the row
    # moved 1/3 of the way to the third decision: p = 4/9, q = 1/3)
    forms = {0: [[F(1, 4), F(1, 4), F(1, 2)]], 1: [[F(1, 2), F(1, 2), F(1, 3)]]}
    assert relaxation_bounds(forms, {0: F(1, 3), 1: F(1, 3)})[(1, 0)] == (F(4, 3), F(-2, 3))
