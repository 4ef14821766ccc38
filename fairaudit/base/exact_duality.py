"""Weak duality checked exactly: a certified upper bound on max (p·h)/(q·h) from any dual point.

Over the polytope P = {lower ≤ h ≤ upper, A_ub h ≤ b_ub, A_eq h = b_eq} with finite bounds, for a ratio λ and
duals ν ≥ 0 (rows of A_ub) and η (rows of A_eq), with r = p − λq − A_ubᵀν − A_eqᵀη,

    B(λ) = ν·b_ub + η·b_eq + Σ_i max(r_i·lower_i, r_i·upper_i) ≥ max over h in P of (p − λq)·h,

so B(λ) ≤ 0 proves p·h ≤ λ·(q·h) on all of P: the ratio is at most λ wherever q·h > 0, and no h has q·h = 0 < p·h.
:func:`certify_ratio` evaluates B exactly (every float is a dyadic rational; the sums are Python integers scaled by a
power of two, λ a :class:`fractions.Fraction`) and raises λ by exact Newton steps until B(λ) ≤ 0; :func:`point_ratio`
checks a primal point exactly and gives its ratio rounded down, the witness of the lower end. Proof:
``proofs/linear_fractional.md`` (§6, the certified value).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray
from fairaudit.base.outward import fraction_down, fraction_up, up

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = [
    "ACTIVE_TOLERANCES",
    "NEWTON_STEPS",
    "REFINE_LIMIT",
    "RatioBound",
    "certify_ratio",
    "check_dual",
    "dual_value",
    "on_one_denominator",
    "point_ratio",
    "rational_point_ratio",
    "refine_duals",
    "smallest_root",
    "smallest_root_of_integers",
    "vertex_ratio",
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


def _dyadic(x: npt.ArrayLike, e: int | None = None) -> Dyadic:
    """Finite floats as exact integers over one power of two: (object array of int, exponent ``e``, by default the
    largest that works)."""
    a = np.asarray(x, dtype=float).ravel()
    if e is None:
        e = _exponent(a)
    mant, ex = np.frexp(a)
    ints = (mant * 2.0**53).astype(np.int64)  # exact: a 53-bit significand
    shifts = np.where(ints != 0, ex.astype(np.int64) - 53 - e, 0)
    return np.left_shift(ints.astype(object), shifts.astype(object)), e


def _align(x: Dyadic, e: int) -> Any:
    """The integers of ``x`` rescaled to the smaller exponent ``e`` ≤ x's."""
    return x[0] * (1 << (x[1] - e)) if x[1] > e else x[0]


def _add(x: Dyadic, y: Dyadic, sign: int = 1) -> Dyadic:
    """x + sign·y, exactly."""
    e = min(x[1], y[1])
    return _align(x, e) + sign * _align(y, e), e


CHUNK = 1 << 14
"""Nonzeros of a constraint matrix turned into Python integers at a time (their memory is several times a float's)."""


def _transpose_times(a: FloatArray | sp.csr_matrix, v: Dyadic, n: int) -> Dyadic:
    """Aᵀv exactly, shape (n,), for a dense or scipy.sparse A (shape (m, n)), by chunks of nonzeros."""
    import scipy.sparse as sp

    coo = sp.coo_matrix(a)
    keep = coo.data != 0
    rows, cols, data = coo.row[keep], coo.col[keep], coo.data[keep]
    del coo, keep
    out = np.zeros(n, dtype=object)
    out[:] = 0
    if rows.size == 0:
        return out, 0
    e = _exponent(data)
    order = np.argsort(cols, kind="stable")
    rows, cols, data = rows[order], cols[order], data[order]
    for s in range(0, rows.size, CHUNK):
        c = cols[s : s + CHUNK]
        products = _dyadic(data[s : s + CHUNK], e)[0] * v[0][rows[s : s + CHUNK]]
        starts = np.flatnonzero(np.r_[True, c[1:] != c[:-1]])
        out[c[starts]] += np.add.reduceat(products, starts)
    return out, e + v[1]


def _dot(x: Dyadic, y: Dyadic) -> Dyadic:
    """x·y exactly (a scalar)."""
    return int(np.sum(x[0] * y[0])) if len(x[0]) else 0, x[1] + y[1]


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
        total = Fraction(int(np.sum(terms)) if len(terms) else 0, b) * Fraction(2) ** (e + eb)
        value = _fraction(self.c) + total
        # right derivative: −q_i upper_i where r_i > 0, −q_i lower_i where r_i < 0, −min(q_i lower_i, q_i upper_i) at 0
        qs = _align(self.q, self.q[1])
        zero_low = (qs <= 0).astype(bool)  # q_i ≤ 0: min(q lower, q upper) = q upper
        at = np.where(positive, hi, np.where(negative, lo, np.where(zero_low, hi, lo)))
        slope = -Fraction(int(np.sum(qs * at)) if len(qs) else 0) * Fraction(2) ** (self.q[1] + eb)
        return value, slope


def _pieces(
    p: FloatArray, q: FloatArray, lower: FloatArray, upper: FloatArray, rows: Rows, duals: list[FloatArray]
) -> _Pieces:
    """The exact data of B: c = Σ duals·b, d = p − Σ Aᵀ duals."""
    n = p.size
    d = _dyadic(p)
    c: Dyadic = (0, 0)
    for (a, b, _), y in zip(rows, duals, strict=True):
        dy = _dyadic(y)
        d = _add(d, _transpose_times(a, dy, n), -1)
        c = _add(c, _dot(dy, _dyadic(b)))
    return _Pieces(c=c, d=d, q=_dyadic(q), lower=_dyadic(lower), upper=_dyadic(upper))


def dual_value(
    lam: Fraction,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
    duals: list[FloatArray],
) -> Fraction:
    """B(λ) exactly: an upper bound on max over P of (p − λq)·h, for any duals (ν ≥ 0 on "le" rows is the caller's).

    Parameters
    ----------
    lam : fractions.Fraction
        λ.
    p, q, lower, upper : numpy.ndarray, shape (n,)
        The program; finite bounds.
    rows : list of (A, b, kind)
        Constraint blocks A h ≤ b (kind "le") or A h = b ("eq").
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


def check_dual(
    lam: Fraction,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
    duals: list[FloatArray],
) -> bool:
    """Whether the duals prove the ratio ≤ λ on the polytope: every "le" dual ≥ 0 and B(λ) ≤ 0, exactly.

    What a verifier runs on a recorded dual point (``FractionalResult.dual``).

    Examples
    --------
    >>> import numpy as np
    >>> one = np.ones(1)
    >>> check_dual(Fraction(2), np.array([2.0]), one, 0 * one, one, [], []), check_dual(Fraction(1), np.array([2.0]), one, 0 * one, one, [], [])
    (True, False)
    """
    for (_, _, kind), y in zip(rows, duals, strict=True):
        y = np.asarray(y, dtype=float)
        if not np.all(np.isfinite(y)) or (kind == "le" and np.any(y < 0)):
            return False
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        return False
    return dual_value(lam, p, q, lower, upper, rows, duals) <= 0


def certify_ratio(
    start: float,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
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
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        return RatioBound(value=math.nan, certified=False, steps=0, reason="a bound of h is infinite")
    if not math.isfinite(start):
        return RatioBound(value=math.nan, certified=False, steps=0, reason=f"the solver's value is {start}")
    clean = []
    for (_, _, kind), y in zip(rows, duals, strict=True):
        y = np.asarray(y, dtype=float)
        if not np.all(np.isfinite(y)):
            return RatioBound(value=math.nan, certified=False, steps=0, reason="the solver's dual is not finite")
        clean.append(np.maximum(y, 0.0) if kind == "le" else y)
    pieces = _pieces(p, q, lower, upper, rows, clean)
    lam = Fraction(up(float(start)))
    for step in range(NEWTON_STEPS + 1):
        value, slope = pieces.at(lam)
        if value <= 0:
            return RatioBound(value=fraction_up(lam), certified=True, steps=step, reason="")
        if slope >= 0:
            return RatioBound(
                value=math.nan,
                certified=False,
                steps=step,
                reason="the dual bound does not decrease in the ratio: it proves no finite value",
            )
        lam -= value / slope
    return RatioBound(value=math.nan, certified=False, steps=NEWTON_STEPS, reason="the Newton steps did not converge")


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
    if not np.all(np.isfinite(h)):
        return math.nan
    if lower is not None and np.any(h < lower):
        return math.nan
    if upper is not None and np.any(h > upper):
        return math.nan
    return _ratio_at(_dyadic(h), 1, p, q, rows)


def rational_point_ratio(
    point: list[Fraction], p: FloatArray, q: FloatArray, lower: FloatArray, upper: FloatArray, rows: Rows
) -> float:
    """:func:`point_ratio` at a point of rationals (a vertex solved exactly): (p·h)/(q·h) rounded down when ``point``
    lies in P exactly and q·h > 0; NaN otherwise. The rows are checked in integers over the point's common
    denominator.

    Examples
    --------
    >>> import numpy as np
    >>> rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    >>> h = [Fraction(1), (Fraction(0.5) - Fraction(0.3)) / Fraction(0.7)]  # on the row, in the floats' rationals
    >>> w = rational_point_ratio(h, np.array([0.7, 0.3]), np.array([0.3, 0.7]), np.zeros(2), np.ones(2), rows)
    >>> w <= 11 / 7 < w + 1e-15
    True
    """
    if any(x < Fraction(float(lo)) or x > Fraction(float(hi)) for x, lo, hi in zip(point, lower, upper, strict=True)):
        return math.nan
    scale = math.lcm(*(x.denominator for x in point))
    numerators = np.empty(len(point), dtype=object)
    numerators[:] = [x.numerator * (scale // x.denominator) for x in point]
    return _ratio_at((numerators, 0), scale, p, q, rows)


def _ratio_at(x: Dyadic, scale: int, p: FloatArray, q: FloatArray, rows: Rows) -> float:
    """(p·h)/(q·h) rounded down at h = x/``scale`` when h meets every row exactly and q·h > 0; NaN otherwise."""
    import scipy.sparse as sp

    for a, b, kind in rows:
        lhs = _transpose_times(sp.csr_matrix(a).T, x, b.size)  # A x = (Aᵀ)ᵀ x
        b_ints, b_exponent = _dyadic(b)
        diff = _add(lhs, (b_ints * scale, b_exponent), -1)  # A x − b·scale
        bad = diff[0] > 0 if kind == "le" else diff[0] != 0
        if np.any(bad.astype(bool)):
            return math.nan
    num, den = _fraction(_dot(_dyadic(p), x)), _fraction(_dot(_dyadic(q), x))
    if den <= 0:
        return math.nan
    return fraction_down(num / den)


REFINE_LIMIT = 4_000_000
"""Largest (interior cells × active rows) system :func:`refine_duals` solves densely; larger ones keep the solver's."""


ACTIVE_TOLERANCES = (1e-9, 1e-7, 1e-5)
"""Distances (relative to max(1, max |h|)) within which a cell counts as at its bound and a row as active, when the
duals are repaired: an interior-point solver stops a little inside the box, by 1e-12 to 1e-8 on a degenerate
program, so each is tried and the smallest value certified kept."""


def _repair_system(
    h: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
    duals: list[FloatArray],
    tolerance: float = ACTIVE_TOLERANCES[0],
) -> tuple[Any, list[Any], Any, Any] | None:
    """The cells strictly inside the box, the active rows, their columns (interior cells × active rows) and the
    solver's duals on them; None when the system is larger than :data:`REFINE_LIMIT`."""
    import scipy.sparse as sp

    tol = tolerance * max(1.0, float(np.abs(h).max(initial=0.0)))
    interior = (h > lower + tol) & (h < upper - tol)
    blocks, active = [], []
    for (a, b, kind), _ in zip(rows, duals, strict=True):
        a = sp.csr_matrix(a)
        on = np.ones(b.size, dtype=bool) if kind == "eq" else (a @ h - b) > -tol * (1.0 + np.abs(b))
        blocks.append(a)
        active.append(on)
    if int(interior.sum()) * int(sum(int(on.sum()) for on in active)) > REFINE_LIMIT:
        return None
    if not any(on.any() for on in active):
        return interior, active, np.zeros((int(interior.sum()), 0)), np.zeros(0)
    columns = sp.hstack([a[on].T for a, on in zip(blocks, active, strict=True)], format="csr")[interior].toarray()
    current = np.concatenate([np.asarray(y, dtype=float)[on] for y, on in zip(duals, active, strict=True)])
    return interior, active, columns, current


def _spread(rows: Rows, active: list[Any], values: Any) -> list[FloatArray]:
    """The active rows' duals ``values`` (concatenated) as one array per block, 0 off the active rows."""
    out, start = [], 0
    for (_, b, _), on in zip(rows, active, strict=True):
        y = np.zeros(b.size)
        y[on] = values[start : start + int(on.sum())]
        start += int(on.sum())
        out.append(y)
    return out


def refine_duals(
    h: FloatArray,
    lam: float,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
    duals: list[FloatArray],
    tolerance: float = ACTIVE_TOLERANCES[0],
) -> list[FloatArray] | None:
    """The solver's duals repaired at the point ``h``: r_i = 0 on the cells strictly inside the box, ν = 0 off the
    active rows (complementary slackness), by least squares in floating point.

    Any result is only a candidate: :func:`certify_ratio` checks it exactly. None when the system is too large.
    ``tolerance``: a cell within it of a bound counts as at the bound, a row within it as active
    (:data:`ACTIVE_TOLERANCES`).
    """
    system = _repair_system(h, lower, upper, rows, duals, tolerance)
    if system is None:
        return None
    interior, active, columns, current = system
    if columns.size:
        target = (p - lam * q)[interior] - columns @ current
        current = current + np.linalg.lstsq(columns, target, rcond=None)[0]
    out = _spread(rows, active, current)
    return [np.maximum(y, 0.0) if kind == "le" else y for y, (_, _, kind) in zip(out, rows, strict=True)]


def vertex_ratio(
    h: FloatArray,
    p: FloatArray,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    rows: Rows,
    duals: list[FloatArray],
    tolerance: float = ACTIVE_TOLERANCES[0],
) -> float | None:
    """The λ at which the duals repaired at ``h`` (:func:`refine_duals`) make B(λ) vanish: a candidate at which to
    repair them, in floating point.

    The repaired duals are affine in λ, ν(λ) = ν_p − λ·ν_q, and so is B(λ) = ν(λ)·b + Σ r_i(λ)·(the bound h_i is
    at), summed over the cells at a bound (r_i = 0 inside the box). When ``h`` is near an optimal vertex its root is
    the optimum up to rounding, however inexact the solver's value: repairing at the solver's value instead leaves
    its error, and Newton from there contracts it only by 1 − (the denominator's share of the bound rows), 0.99 per
    step with τ = 0.01. Used by :class:`~fairaudit.base.linear_fractional.FractionalProgram` before issue 80, no
    longer (``proofs/linear_fractional.md`` §6, "History").

    Parameters
    ----------
    h : numpy.ndarray, shape (n,)
        The solver's primal point, in the box.
    p, q, lower, upper, rows, duals
        As in :func:`dual_value` (finite bounds; ``duals`` the solver's, one array per block of rows).
    tolerance : float, optional
        As in :func:`refine_duals`.

    Returns
    -------
    float or None
        The root, a candidate only (:func:`certify_ratio` checks the duals repaired near it exactly); None when the
        system is larger than :data:`REFINE_LIMIT` or B does not decrease in λ.

    Examples
    --------
    The docstring program of :class:`~fairaudit.base.linear_fractional.FractionalProgram`: at its vertex
    h = (1, 2/7) the row is active and the root is 11/7, whatever the solver's dual.

    >>> import numpy as np
    >>> p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    >>> rows = [(np.array([[-0.3, -0.7]]), np.array([-0.5]), "le")]
    >>> vertex_ratio(np.array([1.0, 2 / 7]), p, q, np.zeros(2), np.ones(2), rows, [np.array([1.1])]) == 11 / 7
    True
    """
    system = _repair_system(h, lower, upper, rows, duals, tolerance)
    if system is None:
        return None
    interior, active, columns, current = system
    nu_p, nu_q = current, np.zeros_like(current)
    if columns.size:
        nu_p = current + np.linalg.lstsq(columns, p[interior] - columns @ current, rcond=None)[0]
        nu_q = np.linalg.lstsq(columns, q[interior], rcond=None)[0]
    at = np.where(h - lower <= upper - h, lower, upper)
    pull = [np.zeros(h.size), np.zeros(h.size)]  # Aᵀν_p and Aᵀν_q
    constant = slope = 0.0
    for (a, b, _), yp, yq in zip(rows, _spread(rows, active, nu_p), _spread(rows, active, nu_q), strict=True):
        pull[0] += np.asarray(a.T @ yp).ravel()
        pull[1] += np.asarray(a.T @ yq).ravel()
        constant += float(yp @ b)
        slope += float(yq @ b)
    outside = ~interior
    constant += float(((p - pull[0]) * at)[outside].sum())
    slope += float(((q - pull[1]) * at)[outside].sum())
    if not slope > 0 or not math.isfinite(constant / slope):
        return None
    return constant / slope


def smallest_root(
    c: Sequence[Sequence[Fraction]], bottoms: Sequence[Sequence[Fraction]], constant: Fraction
) -> Fraction | None:
    """The smallest λ ≥ 0 with B(λ) = Σ_rows max_u (c − λq)[row, u] + ``constant`` ≤ 0, exactly; None when there is
    none.

    B is convex, piecewise linear and non-increasing in λ (q ≥ 0): Newton's method from λ = 0 with the right
    derivative (−Σ_rows q at each row's maximiser with the largest q) never passes the smallest root and lands on a
    later piece at each step, so it reaches the root exactly in finitely many steps; a zero slope with B > 0 means
    no root. With c = p + Σ_f ν_f F_f and constant = −τ Σ_f ν_f (ν ≥ 0) it bounds max (p·K)/(q·K) over tables K
    whose rows are distributions and which meet the floors F_f·K ≥ τ (weak duality with the rows' simplices kept in
    the inner maximum: ``proofs/verification.md`` §4f).

    Parameters
    ----------
    c, bottoms : sequence of sequence of Fraction, shape (n_rows, n_decisions)
        The rows' coefficients of the Lagrangian's numerator and of q, q ≥ 0.
    constant : Fraction
        Added to the rows' maxima.

    Returns
    -------
    Fraction or None

    Examples
    --------
    >>> F = Fraction
    >>> smallest_root([[F(3, 4), F(0)], [F(1, 4), F(0)]], [[F(1, 8), F(0)], [F(3, 8), F(0)]], F(0))
    Fraction(6, 1)
    """
    if not c:
        return Fraction(0) if constant <= 0 else None
    top, d = on_one_denominator(c)
    q, e = on_one_denominator(bottoms)
    return smallest_root_of_integers(np.array(top, dtype=object), d, np.array(q, dtype=object), e, constant)


def smallest_root_of_integers(top: Any, d: int, q: Any, e: int, constant: Fraction) -> Fraction | None:
    """:func:`smallest_root` with c and q as integers over one denominator each: the same Newton steps, each row's
    maximum and its steepest maximiser taken over the whole array at once, in integers (B at λ = a/b times d·e·b).

    Parameters
    ----------
    top, q : numpy.ndarray of int (dtype object), shape (n_rows, n_decisions)
        c·d and q·e: the rows' coefficients of the Lagrangian's numerator and of q (q ≥ 0), at least one row.
    d, e : int
        Their denominators, > 0.
    constant : Fraction
        Added to the rows' maxima.

    Returns
    -------
    Fraction or None
        The smallest λ ≥ 0 with B(λ) ≤ 0 (a ratio; its log is in nats); None when there is none.

    Notes
    -----
    Newton's method on the convex, piecewise-linear B, and the weak-duality bound it gives:
    ``proofs/verification.md`` §4f.

    Examples
    --------
    :func:`smallest_root`'s example, c and q over 8:

    >>> top, q = np.array([[6, 0], [2, 0]], dtype=object), np.array([[1, 0], [3, 0]], dtype=object)
    >>> smallest_root_of_integers(top, 8, q, 8, Fraction(0))
    Fraction(6, 1)
    """
    lam = Fraction(0)
    while True:
        a, b = lam.numerator, lam.denominator
        values = top * (e * b) - q * (d * a)  # (c − λq)·d·e·b, exactly
        best = values.max(axis=1)
        total = Fraction(int(best.sum())) + constant * (d * e * b)
        if total <= 0:
            return lam
        steep = int(np.where(values == best[:, None], q, -1).max(axis=1).sum())  # (e times the right derivative)
        if steep == 0:
            return None
        lam += total / (d * b * steep)  # the tangent's root: at most the smallest root (the function is convex)


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
