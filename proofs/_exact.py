"""Exact arithmetic for the proofs: a linear-fractional maximum by vertex enumeration, in Fractions.

Independent of fairaudit (no floating point, no solver). Used by the Python
blocks of proofs/linear_fractional.md, proofs/black_box.md and
proofs/worst_case_utility.md, which run from the repository root with
``import sys; sys.path.insert(0, "proofs"); from _exact import vertex_max``.

Why vertex enumeration is exact: on a bounded nonempty polytope where the
denominator is positive, max (p·h)/(q·h) is attained at a vertex
(proofs/linear_fractional.md, Proposition 3), and every vertex of
{h : A h ≤ b} in R^n is the unique solution of n linearly independent rows of
A h = b that also satisfies all the other rows.
"""

from __future__ import annotations

import itertools
from fractions import Fraction


def solve(rows, rhs):
    """The unique solution of the square system rows·h = rhs (Fractions), or None if it is singular."""
    n = len(rows)
    m = [[Fraction(v) for v in r] + [Fraction(b)] for r, b in zip(rows, rhs)]
    for c in range(n):
        piv = next((r for r in range(c, n) if m[r][c] != 0), None)
        if piv is None:
            return None
        m[c], m[piv] = m[piv], m[c]
        m[c] = [v / m[c][c] for v in m[c]]
        for r in range(n):
            if r != c and m[r][c] != 0:
                f = m[r][c]
                m[r] = [a - f * e for a, e in zip(m[r], m[c])]
    return [m[r][n] for r in range(n)]


def dot(u, v):
    return sum((Fraction(x) * Fraction(y) for x, y in zip(u, v)), Fraction(0))


def vertices(A, b):
    """Every vertex of {h : A h ≤ b}, exactly: the unique solutions of n rows taken as equalities that meet all rows."""
    n = len(A[0])
    out = []
    for rows in itertools.combinations(range(len(A)), n):
        h = solve([A[i] for i in rows], [b[i] for i in rows])
        if h is not None and all(dot(A[i], h) <= b[i] for i in range(len(A))) and h not in out:
            out.append(h)
    return out


def vertex_max(p, q, A, b):
    """max over the vertices h of {h : A h ≤ b} of (p·h)/(q·h), as (value, h); None if there is no vertex.

    Assumes q·h > 0 at every vertex (raises ZeroDivisionError otherwise).
    """
    best = None
    for h in vertices(A, b):
        r = dot(p, h) / dot(q, h)
        if best is None or r > best[0]:
            best = (r, h)
    return best


def box(lower, upper):
    """Rows (A, b) of lower ≤ h ≤ upper, for vectors lower and upper of Fractions."""
    n = len(lower)
    eye = [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]
    return eye + [[-v for v in r] for r in eye], [Fraction(u) for u in upper] + [-Fraction(lo) for lo in lower]
