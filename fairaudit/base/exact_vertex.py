"""The vertex a solver's point stands for, solved exactly: the witness of a ratio's lower end when the point itself
misses a row by rounding.

A float point h stands a little off the vertex it stands for: an exact vertex rounded to nearest, taken over to a
program whose rows are tightened by their rounding (the worst-case searches' inner programs), or an interior-point
solver's point (a cell 1e-12 inside its bound); an equality row (the rows of a decision table summing to 1) is met
only to rounding. :func:`point_ratio
<fairaudit.base.exact_duality.point_ratio>` then finds h outside the polytope P = {lower ≤ h ≤ upper, A_ub h ≤ b_ub,
A_eq h = b_eq} and gives no witness. :func:`vertex_witness` reads the active set off h instead (a cell within a
tolerance of a bound is at it, a row within it of its bound is active, every equality is), puts those cells at their
bounds, solves the active rows exactly for one cell each (Gauss–Jordan elimination over the rationals, in integers,
on the cells the elimination pivots on, chosen in floating point; every other cell keeps its float value), and checks
the point it finds against every bound and row of P exactly. A point that passes lies in P, so its ratio, rounded
down, is at most max_P (p·h)/(q·h): a certified lower end. The active set and the cells solved for are only read off
h; a wrong reading gives a point outside P, which is refused (NaN), never a wrong witness.
``proofs/linear_fractional.md`` §6 ("The witness").
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np

from fairaudit.base.arrays import BoolArray, FloatArray, IntArray
from fairaudit.base.exact_duality import ACTIVE_TOLERANCES, Rows, rational_point_ratio

__all__ = ["DENSE_LIMIT", "ELIMINATION_LIMIT", "gauss_jordan", "improve_witness", "vertex_witness"]

DENSE_LIMIT = 1 << 22
"""The most entries (active rows × interior cells they touch, of one connected set of them; 8 bytes each) of a block
whose pivots are chosen in floating point; a larger one gets no vertex."""

ELIMINATION_LIMIT = 1024
"""The most nonzeros of one connected set of the system solved exactly (the active rows over the cells solved for,
the other cells' terms moved to the right-hand side); a larger one gets no vertex. The elimination's integers grow
with it: over the model's table at 27 groups behind a product, systems of 500 to 1,024 nonzeros took 0.03 s each
and those of 1,024 to 1,766 0.1 s (0.23 s at most); without the limit, certify solved 217 of the larger ones, 22 s
of its 149 s (124 s with it), for witnesses higher by 2e-12 and 8e-11 relative. The program's other nonzeros do
not count: its rows outside the system are only checked, in integers (0.35 s at 2.2 million)."""

PIVOT_TOLERANCE = 1e-9
"""Relative to a row's largest coefficient: what is left of it after elimination, below this, is taken as rounding
(the row as decided by the ones before it)."""

_Row = dict[int, Fraction]


def _sparse_rows(rows: Rows) -> list[tuple[Any, FloatArray, str]]:
    import scipy.sparse as sp

    return [(sp.csr_matrix(a), np.asarray(b, dtype=float), kind) for a, b, kind in rows]


def _entries(a: Any, r: int) -> zip[tuple[int, float]]:
    start, stop = a.indptr[r], a.indptr[r + 1]
    return zip(a.indices[start:stop].tolist(), a.data[start:stop].tolist(), strict=True)


def gauss_jordan(equations: list[tuple[_Row, Fraction, bool]]) -> dict[int, tuple[_Row, Fraction]] | None:
    """Gauss–Jordan elimination over rationals: each pivot cell as its right-hand side less the free cells' terms;
    None when an equality is inconsistent with the others. An active inequality the others already decide is dropped
    (the point is checked against it after).

    Each row is kept in integers, d·x_c + Σ t·x = b with d > 0 and the row divided by the gcd of its entries (a row
    of :class:`~fractions.Fraction` is this row over d): an elimination step is integer products and one gcd per row,
    where fractions would take a gcd per entry and operation. The pivot of a row is its cell of largest absolute
    coefficient once the rows before it are eliminated (the first such cell, in the order of the row's terms).

    Parameters
    ----------
    equations : list of (dict of int to Fraction, Fraction, bool)
        Each row as {cell: coefficient}, its right-hand side, and whether it is an equality.

    Returns
    -------
    dict of int to (dict of int to Fraction, Fraction), or None
        pivot cell -> (its terms in the free cells, its right-hand side): cell = rhs − Σ terms·free cells.

    Examples
    --------
    >>> F = Fraction
    >>> gauss_jordan([({0: F(1), 1: F(1)}, F(1), True), ({0: F(1), 1: F(-1)}, F(0), True)])
    {0: ({}, Fraction(1, 2)), 1: ({}, Fraction(1, 2))}
    """
    from gmpy2 import mpz  # (GMP's integers: the rows' entries grow to thousands of bits)

    pivots: dict[int, tuple[int, dict[int, int], int]] = {}  # pivot cell -> (d > 0, terms, b)
    for equation, rhs, equality in equations:
        scale = mpz(math.lcm(rhs.denominator, *(v.denominator for v in equation.values())))
        ints = {c: v.numerator * (scale // v.denominator) for c, v in equation.items()}
        used = [(c, pivots[c]) for c in ints if c in pivots]
        # every pivot row the equation uses is brought to one coefficient, lead, before it is subtracted
        lead = mpz(math.lcm(1, *(d for _, (d, _, _) in used)))
        row = {c: v * lead for c, v in ints.items() if c not in pivots}
        b = rhs.numerator * (scale // rhs.denominator) * lead
        for c, (d, terms, other_b) in used:
            f = ints[c] * (lead // d)
            for cc, v in terms.items():
                row[cc] = row.get(cc, 0) - f * v
            b -= f * other_b
        row = {c: v for c, v in row.items() if v}
        if not row:
            if b and equality:
                return None
            continue
        c = max(row, key=lambda k: abs(row[k]))
        d, row, b = _primitive(row.pop(c), row, b)
        for pc, (other_d, other, other_b) in list(pivots.items()):
            h = other.pop(c, None)
            if h is not None:
                other = {cc: v * d for cc, v in other.items()}
                for cc, v in row.items():
                    other[cc] = other.get(cc, 0) - h * v
                pivots[pc] = _primitive(other_d * d, {k: v for k, v in other.items() if v}, other_b * d - h * b)
        pivots[c] = (d, row, b)
    return {
        c: ({cc: Fraction(int(v), int(d)) for cc, v in terms.items()}, Fraction(int(b), int(d)))
        for c, (d, terms, b) in pivots.items()
    }


def _primitive(d: Any, terms: dict[int, Any], b: Any) -> tuple[Any, dict[int, Any], Any]:
    """The row d·x + Σ t·x = b (integers, d ≠ 0) divided by the gcd of its entries, its sign turned so that d > 0."""
    from gmpy2 import gcd

    common = gcd(d, b, *terms.values()) * (1 if d > 0 else -1)
    return d // common, {c: v // common for c, v in terms.items()}, b // common


def _pivot_cells(active: list[Any], interior: BoolArray) -> BoolArray | None:
    """The cells the active rows are solved for: in each row, in turn, the interior cell of largest coefficient left
    after the rows before it are eliminated (the pivot :func:`gauss_jordan` takes, ties aside), chosen in floating
    point (elimination on the dense block of each connected set of active rows and the interior cells they touch,
    :data:`DENSE_LIMIT`); a row left with nothing above rounding takes none. Every other cell keeps its value, so the
    exact solve is over these cells only, not over the fill the free cells would bring. None beyond the limit.

    Only the choice is in floats: a wrong one leaves an equality the exact solve cannot meet (no witness) or an
    inequality it does not meet (refused by the check), never a wrong witness.
    """
    import scipy.sparse as sp

    unknown = np.zeros(interior.size, dtype=bool)
    if not active:
        return unknown
    cells = np.flatnonzero(interior)
    block = sp.vstack(active, format="csr")[:, cells]
    rows = block.shape[0]
    label = _connected(block)
    by_label = np.argsort(label, kind="stable")
    starts = np.flatnonzero(np.diff(label[by_label], prepend=-1))
    for part in np.split(by_label, starts[1:]):
        r, c = part[part < rows], part[part >= rows] - rows
        if r.size * c.size > DENSE_LIMIT:
            return None
        if r.size and c.size:
            unknown[cells[c[_pivots(block[r][:, c].toarray())]]] = True
    return unknown


def _connected(block: Any) -> IntArray:
    """The connected set of each row of the sparse ``block``, then of each of its cells, as labels: rows and cells
    as one graph, a row joined to the cells it touches (Gauss–Jordan elimination never leaves a set)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    return connected_components(sp.bmat([[None, block], [block.T, None]]), directed=False)[1]


def _largest_system(blocks: list[Any]) -> int:
    """The most nonzeros of one connected set of the rows of ``blocks`` (sparse, over the same cells) and the cells
    they touch: the largest system the exact elimination solves at once."""
    import scipy.sparse as sp

    if not blocks:
        return 0
    block = sp.vstack(blocks, format="coo")
    if block.nnz == 0:
        return 0
    return int(np.bincount(_connected(block)[block.row]).max())


def _pivots(dense: FloatArray) -> list[int]:
    """The pivot columns of Gauss–Jordan elimination on ``dense`` (rows in order, the largest entry left in each;
    none where it is below :data:`PIVOT_TOLERANCE` of the row's largest), in floating point; ``dense`` is
    overwritten."""
    scale = np.abs(dense).max(axis=1)
    chosen = []
    for r in range(dense.shape[0]):
        row = dense[r]
        j = int(np.argmax(np.abs(row)))
        if not abs(row[j]) > PIVOT_TOLERANCE * scale[r]:
            continue
        chosen.append(j)
        below, terms = r + 1 + np.flatnonzero(dense[r + 1 :, j]), np.flatnonzero(row)  # (what the step changes)
        dense[np.ix_(below, terms)] -= np.outer(dense[below, j] / row[j], row[terms])
        dense[below, j] = 0.0
    return chosen


def vertex_witness(
    h: FloatArray,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
    tolerance: float = ACTIVE_TOLERANCES[0],
) -> float:
    """(p·v)/(q·v) rounded down at the point v of P that ``h``'s active set defines, solved exactly; NaN when v is not
    in P, q·v ≤ 0, or its active block is beyond :data:`DENSE_LIMIT` or the system solved beyond
    :data:`ELIMINATION_LIMIT`.

    Parameters
    ----------
    h : numpy.ndarray, shape (n,)
        The solver's primal point, clipped into the box.
    p, q : numpy.ndarray, shape (n,)
        The ratio's numerator and denominator.
    lower, upper : numpy.ndarray, shape (n,)
        Finite bounds of h, lower ≤ upper.
    rows : list of (A, b, kind)
        A of shape (m, n) (dense or scipy.sparse), b of shape (m,), kind "le" (A h ≤ b) or "eq" (A h = b).
    tolerance : float, optional
        Relative to max(1, max |h|): a cell within it of a bound is put at the bound, an "le" row within it
        (times 1 + |b|) of b is solved as an equality (:data:`~fairaudit.base.exact_duality.ACTIVE_TOLERANCES`).

    Returns
    -------
    float
        A certified lower end of max over P of (p·h)/(q·h), or NaN.

    Examples
    --------
    The solver's point of ``FractionalProgram``'s docstring program misses its row by rounding; the vertex
    h = (1, 2/7) it stands for has the ratio 11/7 (the floats of 0.7 and 0.3 put it an ulp below).

    >>> p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    >>> rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    >>> h = np.array([1.0 - 1e-12, 2 / 7 - 1e-12])
    >>> w = vertex_witness(h, p, q, np.zeros(2), np.ones(2), rows)
    >>> w <= 11 / 7, 11 / 7 - w < 1e-15
    (True, True)
    """
    n = h.size
    blocks = _sparse_rows(rows)
    if not np.all(np.isfinite(h)):
        return math.nan
    tol = tolerance * max(1.0, float(np.abs(h).max(initial=0.0)))
    interior = (h > lower + tol) & (h < upper - tol)
    point: list[Fraction] = [
        Fraction(float(h[i]))
        if interior[i]
        else Fraction(float(lower[i] if h[i] - lower[i] <= upper[i] - h[i] else upper[i]))
        for i in range(n)
    ]
    active = [
        np.ones(b.size, dtype=bool) if kind == "eq" else (a @ h - b) > -tol * (1.0 + np.abs(b)) for a, b, kind in blocks
    ]
    unknown = _pivot_cells([a[on] for (a, _, _), on in zip(blocks, active, strict=True)], interior)
    if (
        unknown is None
        or _largest_system([a[on][:, unknown] for (a, _, _), on in zip(blocks, active)]) > ELIMINATION_LIMIT
    ):
        return math.nan
    equations: list[tuple[_Row, Fraction, bool]] = []
    for (a, b, kind), on in zip(blocks, active, strict=True):
        for r in np.flatnonzero(on).tolist():
            row: _Row = {}
            rhs = Fraction(float(b[r]))
            for c, v in _entries(a, r):
                if unknown[c]:
                    row[c] = row.get(c, Fraction(0)) + Fraction(v)
                else:
                    rhs -= Fraction(v) * point[c]
            equations.append((row, rhs, kind == "eq"))
    pivots = gauss_jordan(equations)
    if pivots is None:
        return math.nan
    for c, (row, rhs) in pivots.items():  # the free cells keep their float values
        point[c] = rhs - sum((v * point[cc] for cc, v in row.items()), Fraction(0))
    return rational_point_ratio(point, p, q, lower, upper, rows)


def improve_witness(
    witness: float,
    value: float,
    close: float,
    h: FloatArray,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
    solved: dict[float, float] | None = None,
) -> float:
    """The larger of ``witness`` (NaN: none) and the vertex witnesses of ``h`` at each of
    :data:`~fairaudit.base.exact_duality.ACTIVE_TOLERANCES`, tried until one lies within ``close`` (relative to
    max(1, |value|)) of the certified ``value``; arguments as in :func:`vertex_witness`. ``solved`` holds the vertex
    witnesses of this ``h`` and program already found, by tolerance, and takes the new ones: a second call (the value
    lowered since) solves no vertex twice.

    Examples
    --------
    >>> p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    >>> rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    >>> h = np.array([1.0 - 1e-12, 2 / 7 - 1e-12])
    >>> w = improve_witness(float("nan"), 11 / 7, 1e-13, h, p, q, np.zeros(2), np.ones(2), rows)
    >>> w <= 11 / 7 < w + 1e-15
    True
    """
    solved = {} if solved is None else solved
    for tolerance in ACTIVE_TOLERANCES:
        if math.isfinite(witness) and value - witness <= close * max(1.0, abs(value)):
            break
        if tolerance not in solved:
            solved[tolerance] = vertex_witness(h, p, q, lower, upper, rows, tolerance)
        at_vertex = solved[tolerance]
        if math.isfinite(at_vertex) and not witness >= at_vertex:  # it replaces no witness, or a lower one
            witness = at_vertex
    return witness
