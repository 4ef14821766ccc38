"""Weak duality checked exactly: a certified upper bound on max (p·h)/(q·h) from any dual point.

Over the polytope P = {lower ≤ h ≤ upper, A_ub h ≤ b_ub, A_eq h = b_eq} with finite bounds, for a ratio λ and
duals ν ≥ 0 (rows of A_ub) and η (rows of A_eq), with r = p − λq − A_ubᵀν − A_eqᵀη,

    B(λ) = ν·b_ub + η·b_eq + Σ_i max(r_i·lower_i, r_i·upper_i) ≥ max over h in P of (p − λq)·h,

so B(λ) ≤ 0 proves p·h ≤ λ·(q·h) on all of P: the ratio is at most λ wherever q·h > 0, and no h has q·h = 0 < p·h.
:func:`certify_ratio` evaluates B exactly (every float is a dyadic rational; the sums are Python integers scaled by a
power of two, λ a :class:`fractions.Fraction`) and raises λ by exact Newton steps until B(λ) ≤ 0 (the rows read once
by :func:`prepare_rows` where many checks share a polytope); :func:`point_ratio` checks a primal point exactly and
gives its ratio rounded down, the witness of the lower end. Proof: ``proofs/linear_fractional.md`` (§6, the certified
value).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.outward import fraction_down, fraction_up, up

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = [
    "NEWTON_STEPS",
    "PreparedRows",
    "RatioBound",
    "certify_ratio",
    "dual_value",
    "on_one_denominator",
    "point_ratio",
    "prepare_rows",
]

NEWTON_STEPS = 64
"""At most this many exact Newton steps on λ (each lands on a new linear piece of B; B has at most n + 1)."""

Dyadic = tuple[Any, int]
"""Exact dyadic numbers: (Python integers, as an object array or one int, exponent e), the value ints·2^e."""

Rows = list[tuple["FloatArray | sp.csr_matrix", FloatArray, str]]
"""Constraint rows (A, b, "le" or "eq"), as :class:`fairaudit.base.linear_fractional.FractionalProgram` keeps them."""


@dataclass(frozen=True, kw_only=True)
class RatioBound:
    """The outcome of :func:`certify_ratio`.

    Attributes
    ----------
    value : float
        A float ≥ the exact λ with B(λ) ≤ 0 (so ≥ the maximum ratio); NaN when not certified.
    certified : bool
        Whether B(λ) ≤ 0 was reached.
    steps : int
        Newton steps taken.
    reason : str
        Why the dual does not certify a finite value; empty when certified.
    """

    value: float
    certified: bool
    steps: int
    reason: str


def _exponent(a: FloatArray) -> int:
    """The smallest exponent e with every float of ``a`` an integer times 2^e (0 when all are 0)."""
    mant, ex = np.frexp(a)
    nonzero = mant != 0
    return int((ex[nonzero].astype(np.int64) - 53).min()) if nonzero.any() else 0


def _dyadic(x: npt.ArrayLike) -> Dyadic:
    """Finite floats as exact integers over one power of two: (object array of int, the largest exponent that
    works)."""
    a = np.asarray(x, dtype=float).ravel()
    e = _exponent(a)
    ints, shifts = _significands(a, e)
    return np.left_shift(ints.astype(object), shifts.astype(object)), e


def _significands(a: FloatArray, e: int) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Finite floats as 53-bit integers and the left shifts that put them over 2^``e`` (e ≤ :func:`_exponent`'s)."""
    mant, ex = np.frexp(a)
    ints = (mant * 2.0**53).astype(np.int64)  # exact: a 53-bit significand
    return ints, np.where(ints != 0, ex.astype(np.int64) - 53 - e, 0)


def _align(x: Dyadic, e: int) -> Any:
    """The integers of ``x`` rescaled to the smaller exponent ``e`` ≤ x's."""
    return x[0] * (1 << (x[1] - e)) if x[1] > e else x[0]


def _add(x: Dyadic, y: Dyadic, sign: int = 1) -> Dyadic:
    """x + sign·y, exactly."""
    e = min(x[1], y[1])
    return _align(x, e) + sign * _align(y, e), e


CHUNK = 1 << 14
"""Nonzeros of a constraint matrix turned into Python integers at a time (their memory is several times a float's)."""


@dataclass(frozen=True, eq=False)
class _Block:
    """One block of constraint rows read exactly: A's nonzeros in column order (their rows and columns, and each as a
    53-bit integer shifted left, over 2^``exponent``: compact, turned into Python integers only where used), b as
    exact integers, and the block's kind ("le" or "eq")."""

    rows: IntArray
    cols: IntArray
    mantissas: npt.NDArray[np.int64]
    shifts: npt.NDArray[np.int64]
    exponent: int
    b: Dyadic
    kind: str

    @classmethod
    def read(cls, a: FloatArray | sp.csr_matrix, b: FloatArray, kind: str) -> _Block:
        import scipy.sparse as sp

        coo = sp.coo_matrix(a)
        keep = coo.data != 0
        order = np.argsort(coo.col[keep], kind="stable")
        rows, cols, data = coo.row[keep][order], coo.col[keep][order], coo.data[keep][order]
        e = _exponent(data)
        ints, shifts = _significands(data, e)
        return cls(rows.astype(np.intp), cols.astype(np.intp), ints, shifts, e, _dyadic(b), kind)

    def transpose_times(self, v: Dyadic, n: int) -> Dyadic:
        """Aᵀv exactly, shape (n,): the nonzeros of the rows where v ≠ 0 only, by chunks."""
        out = np.zeros(n, dtype=object)  # (Python's int 0)
        live = np.flatnonzero(np.asarray(v[0] != 0, dtype=bool)[self.rows])
        for s in range(0, live.size, CHUNK):
            k = live[s : s + CHUNK]
            c = self.cols[k]
            ints = np.left_shift(self.mantissas[k].astype(object), self.shifts[k].astype(object))
            starts = np.flatnonzero(np.r_[True, c[1:] != c[:-1]])
            out[c[starts]] += np.add.reduceat(ints * v[0][self.rows[k]], starts)
        return out, self.exponent + v[1]


@dataclass(frozen=True, eq=False)
class PreparedRows:
    """A polytope's constraint rows read once, exactly, for the weak-duality checks of many programs over it.

    What :func:`certify_ratio` and :func:`dual_value` take in place of the rows themselves, made by
    :func:`prepare_rows`: every program over a fixed polytope (a :class:`~fairaudit.base.linear_fractional.
    FractionalProgram`'s) has the same rows, so their nonzeros are sorted and read as integers once, and each check
    computes Aᵀν from the rows where ν ≠ 0 alone (a few floors bind at a time).

    Attributes
    ----------
    rows : list of (A, b, kind)
        The rows as given.
    n : int
        The dimension of h.
    """

    rows: Rows
    n: int
    _blocks: tuple[_Block, ...]


def prepare_rows(rows: Rows, n: int) -> PreparedRows:
    """The rows read once for every weak-duality check over their polytope (:class:`PreparedRows`).

    Parameters
    ----------
    rows : list of (A, b, kind)
        Constraint blocks A h ≤ b (kind "le") or A h = b ("eq"), A dense or scipy.sparse of shape (m, n).
    n : int
        The dimension of h.

    Returns
    -------
    PreparedRows

    Examples
    --------
    The rows of :func:`certify_ratio`'s example, prepared once and checked for two duals:

    >>> rows = prepare_rows([(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")], 2)
    >>> p, q, one = np.array([0.7, 0.3]), np.array([0.3, 0.7]), np.ones(2)
    >>> [dual_value(Fraction(11, 7), p, q, 0 * one, one, rows, [np.array([y])]) <= 0 for y in (8 / 7, 1.0)]
    [True, False]
    """
    return PreparedRows(rows, n, tuple(_Block.read(a, b, kind) for a, b, kind in rows))


def _dot(x: Dyadic, y: Dyadic) -> Dyadic:
    """x·y exactly (a scalar)."""
    return int(np.sum(x[0] * y[0])), x[1] + y[1]


def _fraction(x: Dyadic) -> Fraction:
    """One dyadic scalar as a Fraction."""
    ints, e = x
    return Fraction(int(ints)) * Fraction(2) ** e


@dataclass(frozen=True)
class _Pieces:
    """B(λ) = c + Σ_i max(r_i lower_i, r_i upper_i) with r = d − λq, everything exact."""

    c: Dyadic
    d: Dyadic
    q: Dyadic
    lower: Dyadic
    upper: Dyadic

    def at(self, lam: Fraction) -> tuple[Fraction, Fraction]:
        """(B(λ), its right derivative), exactly."""
        a, b = lam.numerator, lam.denominator
        e = min(self.d[1], self.q[1])
        r = _align(self.d, e) * b - _align(self.q, e) * a  # r_i = r[i]·2^e / b
        eb = min(self.lower[1], self.upper[1])
        lo, hi = _align(self.lower, eb), _align(self.upper, eb)
        positive, negative = (r > 0).astype(bool), (r < 0).astype(bool)
        terms = np.where(positive, r * hi, np.where(negative, r * lo, 0))
        total = Fraction(int(np.sum(terms)), b) * Fraction(2) ** (e + eb)
        value = _fraction(self.c) + total
        # right derivative: −q_i upper_i where r_i > 0, −q_i lower_i where r_i < 0, −min(q_i lower_i, q_i upper_i) at 0
        qs = _align(self.q, self.q[1])
        zero_low = (qs <= 0).astype(bool)  # q_i ≤ 0: min(q lower, q upper) = q upper
        at = np.where(positive, hi, np.where(negative, lo, np.where(zero_low, hi, lo)))
        slope = -Fraction(int(np.sum(qs * at))) * Fraction(2) ** (self.q[1] + eb)
        return value, slope


def _pieces(
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows | PreparedRows,
    duals: list[FloatArray],
) -> _Pieces:
    """The exact data of B: c = Σ duals·b, d = p − Σ Aᵀ duals."""
    n = p.size
    prepared = rows if isinstance(rows, PreparedRows) else prepare_rows(rows, n)
    d = _dyadic(p)
    c: Dyadic = (0, 0)
    for block, y in zip(prepared._blocks, duals, strict=True):
        dy = _dyadic(y)
        d = _add(d, block.transpose_times(dy, n), -1)
        c = _add(c, _dot(dy, block.b))
    return _Pieces(c=c, d=d, q=_dyadic(q), lower=_dyadic(lower), upper=_dyadic(upper))


def dual_value(
    lam: Fraction,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows | PreparedRows,
    duals: list[FloatArray],
) -> Fraction:
    """B(λ) exactly: an upper bound on max over P of (p − λq)·h, for any duals (ν ≥ 0 on "le" rows is the caller's).

    Parameters
    ----------
    lam : fractions.Fraction
        λ.
    p, q, lower, upper : numpy.ndarray, shape (n,)
        The program; finite bounds.
    rows : list of (A, b, kind), or PreparedRows
        Constraint blocks A h ≤ b (kind "le") or A h = b ("eq"), or the same read once (:func:`prepare_rows`: many
        checks over one polytope).
    duals : list of numpy.ndarray
        One dual vector per block, shape (m_block,).

    Returns
    -------
    fractions.Fraction

    Examples
    --------
    >>> import numpy as np
    >>> one = np.ones(1)
    >>> dual_value(Fraction(2), np.array([2.0]), one, 0 * one, one, [], [])   # (2 − 2·1)·h ≤ 0 on [0, 1]
    Fraction(0, 1)
    """
    return _pieces(p, q, lower, upper, rows, duals).at(lam)[0]


def certify_ratio(
    start: float,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows | PreparedRows,
    duals: list[FloatArray],
) -> RatioBound:
    """The smallest λ ≥ ``start`` with B(λ) ≤ 0, by exact Newton steps, rounded up: a certified max of the ratio.

    ``proofs/linear_fractional.md`` §6. The "le" duals are clipped at 0 (any ν ≥ 0 is a valid dual; the clip only
    removes a solver's tiny negative noise).

    Parameters
    ----------
    start : float
        The solver's value; λ starts at it (finite).
    p, q, lower, upper, rows, duals
        As in :func:`dual_value`.

    Returns
    -------
    RatioBound
        ``certified`` False (value NaN) with a reason when the bounds are not finite, the start is not finite,
        B does not decrease (the dual proves nothing at any larger λ), or the steps run out.

    Examples
    --------
    >>> import numpy as np
    >>> p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    >>> rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    >>> r = certify_ratio(1.5, p, q, np.zeros(2), np.ones(2), rows, [np.array([8 / 7])])
    >>> r.certified, r.value >= 11 / 7, r.value - 11 / 7 < 1e-15
    (True, True, True)
    """
    failed = functools.partial(RatioBound, value=math.nan, certified=False)
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        return failed(steps=0, reason="a bound of h is infinite")
    if not math.isfinite(start):
        return failed(steps=0, reason=f"the solver's value is {start}")
    ys = [np.asarray(y, dtype=float) for y in duals]
    if not all(np.all(np.isfinite(y)) for y in ys):
        return failed(steps=0, reason="the solver's dual is not finite")
    given = rows.rows if isinstance(rows, PreparedRows) else rows
    clean = [np.maximum(y, 0.0) if kind == "le" else y for (_, _, kind), y in zip(given, ys, strict=True)]
    pieces = _pieces(p, q, lower, upper, rows, clean)
    lam = Fraction(up(float(start)))
    for step in range(NEWTON_STEPS + 1):
        value, slope = pieces.at(lam)
        if value <= 0:
            return RatioBound(value=fraction_up(lam), certified=True, steps=step, reason="")
        if slope >= 0:
            return failed(steps=step, reason="the dual bound does not decrease in the ratio: it proves no finite value")
        lam -= value / slope
    return failed(steps=NEWTON_STEPS, reason="the Newton steps did not converge")


def point_ratio(
    h: FloatArray,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray | None,
    upper: FloatArray | None,
    rows: Rows,
) -> float:
    """(p·h)/(q·h) rounded down when ``h`` lies in P exactly and q·h > 0; NaN otherwise (no witness).

    Parameters
    ----------
    h : numpy.ndarray, shape (n,)
        A primal point (clip it into the box first).
    p, q, lower, upper, rows
        As in :func:`dual_value` (a bound may be None or infinite: no constraint).

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> w = point_ratio(np.array([1.0, 0.5]), np.array([0.7, 0.3]), np.array([0.3, 0.7]), None, None, [])
    >>> w <= Fraction(85, 65) < w + 1e-15
    True
    """
    outside = (lower is not None and np.any(h < lower)) or (upper is not None and np.any(h > upper))
    if outside or not np.all(np.isfinite(h)):
        return math.nan
    import scipy.sparse as sp

    x = _dyadic(h)
    for a, b, kind in rows:
        block = _Block.read(sp.csr_matrix(a).T, b, kind)  # Aᵀ read exactly: (Aᵀ)ᵀ h = A h
        diff = _add(block.transpose_times(x, b.size), block.b, -1)  # A h − b
        bad = diff[0] > 0 if kind == "le" else diff[0] != 0
        if np.any(bad.astype(bool)):
            return math.nan
    num, den = _fraction(_dot(_dyadic(p), x)), _fraction(_dot(_dyadic(q), x))
    if den <= 0:
        return math.nan
    return fraction_down(num / den)


def on_one_denominator(rows: Sequence[Sequence[Fraction]]) -> tuple[list[list[int]], int]:
    """Rational rows as integers over one common denominator.

    Parameters
    ----------
    rows : sequence of sequences of Fraction, shape (m, n)
        Exact rationals (rows of any lengths).

    Returns
    -------
    (list of list of int, int)
        The integers, same shape as ``rows``, and the denominator d > 0 (the least common multiple of the entries'
        denominators): ``rows[i][j] == ints[i][j] / d`` exactly.

    Examples
    --------
    >>> on_one_denominator([[Fraction(1, 2), Fraction(1, 3)], [Fraction(1)]])
    ([[3, 2], [6]], 6)
    """
    den = math.lcm(*(x.denominator for row in rows for x in row))
    return [[x.numerator * (den // x.denominator) for x in row] for row in rows], den
