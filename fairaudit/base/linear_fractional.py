"""Linear-fractional programs: maximise (p·h) / (q·h) over a polytope, exactly.

:class:`FractionalProgram` solves max (p·h)/(q·h) over a bounded polytope {lower ≤ h ≤ upper, A_ub h ≤ b_ub,
A_eq h = b_eq} by Dinkelbach's method (Dinkelbach 1967): each step a linear program max (p − λq)·h solved by HiGHS's
simplex and proved optimal from its basis in exact arithmetic (:mod:`fairaudit.base.exact_lp`), λ the ratio at the
last step's vertex, until that maximum is 0: then λ is the exact maximum, the vertex attains it and the last basis's
duals prove it. It is built once per polytope and re-solved for many (p, q) from the last basis, which is how the
worst-case searches of :mod:`fairaudit.worstcase` loop over pairs of groups. Over a box alone (and a box plus one
floor on q·h) the maximum is a threshold in likelihood-ratio order, found by one sort: that rule, vectorised, is
:mod:`fairaudit.base.threshold_rule`, the inner loop of the searches.

Conventions as elsewhere: c/0 = +inf for c > 0, 0/0 = 1. Proofs: ``proofs/linear_fractional.md`` and
``proofs/black_box.md``.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, as_float_array
from fairaudit.base.errors import InputError
from fairaudit.base.exact_duality import PreparedRows, certify_ratio, prepare_rows
from fairaudit.base.exact_lp import ExactProgram
from fairaudit.base.exact_ratio import dot
from fairaudit.base.outward import fraction_down, fraction_up, gap_between

__all__ = [
    "EXACT_BASIS",
    "FractionalProgram",
    "FractionalResult",
]


if TYPE_CHECKING:
    import scipy.sparse as sp

ConstraintMatrix: TypeAlias = "npt.ArrayLike | sp.sparray | sp.spmatrix"
"""A constraint matrix: dense (array_like) or a scipy.sparse matrix."""


@dataclass(frozen=True, eq=False, kw_only=True)
class FractionalResult:
    """The optimum of max (p·h)/(q·h).

    Attributes
    ----------
    value : float
        The optimal ratio as an upper bound: ≥ the exact maximum whenever ``certified`` (+inf when
        unbounded; NaN when infeasible). The threshold route rounds it up by a proven error bound; the LP
        route (Dinkelbach's method over linear programs proved optimal exactly from HiGHS's basis,
        :mod:`fairaudit.base.exact_lp`) gives the exact maximum rounded up (``proofs/linear_fractional.md`` §6);
        a caller that solved the program on exact coefficients gives its exact optimum rounded up.
        When not ``certified``, ``reason`` says why.
    argmax : numpy.ndarray or None
        An h attaining it, shape (n,): on the LP route the exact vertex rounded to nearest; None when unbounded
        without a vertex to show, or infeasible.
    status : {"optimal", "unbounded", "infeasible", "error"}
        "error": the LP route met a vertex with q·h < 0, which its method does not handle; the value is NaN, not
        certified, and nothing is claimed about the program (``reason`` says so).
    method : {"threshold", "lp"}
    solver_status : str
        How the value was found: on the LP route "HiGHS simplex, exact basis (k Dinkelbach steps, m exact
        pivots)", followed by :data:`EXACT_BASIS` where the recorded duals prove less, or the caller's
        :data:`EXACT_CROSSOVER` note; "threshold" or "closed form" for the fast paths.
    reason : str
        Why the value is +inf or NaN, or why it is not certified; empty when optimal and certified.
    certified : bool
        Whether ``value`` is proven ≥ the exact maximum (an exact basis, also on exact coefficients, or the threshold
        rule's error bound); +inf always is. False for NaN (and where a caller put in a value of its own that it
        could not prove).
    witness : float
        (p·h)/(q·h) at ``argmax`` computed exactly and rounded down, when that point lies in the polytope
        exactly: a certified lower end of the maximum. NaN when there is no such point.
    gap : float
        ``value − witness`` rounded up (NaN without a witness; 0 when both are +inf).
    dual : tuple of numpy.ndarray
        The LP route's last step's exact duals, rounded to nearest: one array per block of rows (ν ≥ 0 for
        A_ub, η for A_eq, in that order; shape (m,) and (k,)); where the bound they prove by weak duality
        (:func:`~fairaudit.base.exact_duality.certify_ratio`) is beyond :data:`CROSSOVER_TOLERANCE` of ``value``,
        ``solver_status`` ends with :data:`EXACT_BASIS` (the exact basis is the proof). Empty on the threshold route
        and when the program was solved on exact coefficients (its exact last step is the proof).
    exact_dual : tuple of tuple of Fraction, or None
        Where ``solver_status`` ends with :data:`EXACT_BASIS`: the same duals exactly, which prove ``value`` by weak
        duality (a certificate records them as exact rationals); else None.
    basis : tuple of str or None
        The LP route's last basis (a status per column, then per row: "basic", "lower", "upper" or "zero"), whose
        vertex on a program with other data (:meth:`FractionalProgram.vertex_ratio`) is a witness there; None
        elsewhere.
    """

    value: float
    argmax: FloatArray | None
    status: str
    method: str
    solver_status: str
    reason: str
    certified: bool = False
    witness: float = math.nan
    gap: float = math.nan
    dual: tuple[FloatArray, ...] = ()
    exact_dual: tuple[tuple[Fraction, ...], ...] | None = None
    basis: tuple[str, ...] | None = None


CROSSOVER_TOLERANCE = 1e-13
"""How far (relative to max(1, |value|)) a certified value may lie above its witness before the worst-case searches
solve a program with rounded coefficients exactly (:mod:`fairaudit.worstcase.known_utility_search`)."""

EXACT_BASIS = "proved by its exact basis (the rounded duals prove less)"
"""What ``solver_status`` adds when a program's value is proved by the exact basis of its last step and not, within
:data:`CROSSOVER_TOLERANCE`, by its duals read to nearest (which ``dual`` still holds)."""


class FractionalProgram:
    """max (p·h)/(q·h) over a fixed bounded polytope, solved exactly for many (p, q) by Dinkelbach's method.

    Proof: ``proofs/linear_fractional.md`` (Dinkelbach's method over an exact simplex; ``proofs/exact_lp.md``).

    The polytope is P = {lower ≤ h ≤ upper, A_ub h ≤ b_ub, A_eq h = b_eq} in R^n, its data taken exactly (a float at
    its binary value). Each :meth:`solve` runs Dinkelbach's method (Dinkelbach 1967): λ₀ the ratio at the maximiser of
    p·h, then λ_{k+1} the ratio at the maximiser h_k of (p − λ_k q)·h, until that maximum is 0. Each maximum is a linear
    program solved by HiGHS's simplex, warm-started from the last basis, and proved optimal from its basis in exact
    arithmetic (:class:`~fairaudit.base.exact_lp.ExactProgram`). The λ_k increase strictly over vertices of P, so the
    method ends, at λ* = max (p·h)/(q·h) exactly, attained at the last vertex; the last basis's exact duals ν ≥ 0 (on
    A_ub) and η (on A_eq) prove it: max over the box of (p − λ*q − ν·A_ub − η·A_eq)·h + ν·b_ub + η·b_eq = 0.

    Parameters
    ----------
    n : int
        Dimension of h.
    lower, upper : float or array_like, shape (n,)
        Finite per-cell bounds, lower ≤ upper.
    A_ub, b_ub : array_like or scipy.sparse matrix, shapes (m, n) and (m,), optional
    A_eq, b_eq : array_like or scipy.sparse matrix, shapes (k, n) and (k,), optional

    Raises
    ------
    InputError
        On inconsistent shapes, non-finite constraint data or bounds, or lower > upper.

    Examples
    --------
    >>> prog = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=[[-0.7, -0.3], [-0.3, -0.7]], b_ub=[-0.5, -0.5])
    >>> r = prog.solve([0.7, 0.3], [0.3, 0.7])   # τ = 0.5 forces 0.3 + 0.7 h_2 >= 0.5: h = (1, 2/7), ratio 11/7
    >>> round(r.value, 12), r.argmax.round(12).tolist(), r.status, r.certified, r.gap <= 1e-15
    (1.571428571429, [1.0, 0.285714285714], 'optimal', True, True)
    """

    def __init__(
        self,
        n: int,
        *,
        lower: npt.ArrayLike | None = None,
        upper: npt.ArrayLike | None = None,
        A_ub: ConstraintMatrix | None = None,
        b_ub: npt.ArrayLike | None = None,
        A_eq: ConstraintMatrix | None = None,
        b_eq: npt.ArrayLike | None = None,
    ) -> None:
        import scipy.sparse as sp

        self.n = int(n)
        finite = "the bounds of h must be finite (the programs of fairaudit are over boxes)"
        if lower is None or upper is None:
            raise InputError("lower", finite)
        self.lower = np.broadcast_to(as_float_array(lower, "lower"), (self.n,)).copy()
        self.upper = np.broadcast_to(as_float_array(upper, "upper"), (self.n,)).copy()
        if not (np.all(np.isfinite(self.lower)) and np.all(np.isfinite(self.upper))):
            raise InputError("lower", finite)
        if np.any(self.lower > self.upper):
            i = int(np.argmax(self.lower > self.upper))
            raise InputError("lower", f"exceeds upper at cell {i} ({self.upper[i]:g})", float(self.lower[i]))
        self._rows: list[tuple[FloatArray, FloatArray, str]] = []  # A h <= b ("le") or A h = b ("eq"), checked
        for name, a, b, op in (("A_ub", A_ub, b_ub, "le"), ("A_eq", A_eq, b_eq, "eq")):
            if a is None:
                continue
            dense = as_float_array(sp.csr_array(a).toarray() if sp.issparse(a) else a, name, ndim=2)
            if not np.all(np.isfinite(dense)):
                raise InputError(name, "must be finite")
            rhs = as_float_array(b, name.replace("A", "b"), ndim=1)
            if dense.shape != (rhs.size, self.n):
                raise InputError(name, f"shape must be ({rhs.size}, {self.n})", dense.shape)
            if not np.all(np.isfinite(rhs)):
                raise InputError(name.replace("A", "b"), "must be finite")
            self._rows.append((dense, rhs, op))
        matrix = np.vstack([a for a, _, _ in self._rows]) if self._rows else np.zeros((0, self.n))
        row_lower = [v if op == "eq" else -math.inf for _, b, op in self._rows for v in b.tolist()]
        row_upper = [v for _, b, _ in self._rows for v in b.tolist()]
        self._program = ExactProgram(matrix, row_lower, row_upper, self.lower.tolist(), self.upper.tolist())

    @functools.cached_property
    def prepared_rows(self) -> PreparedRows:
        """The program's constraint rows read once, exactly, for the weak-duality check of every solve's duals
        (:func:`~fairaudit.base.exact_duality.prepare_rows`): the rows are the same for every (p, q).

        Examples
        --------
        >>> prog = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=[[-0.7, -0.3], [-0.3, -0.7]], b_ub=[-0.5, -0.5])
        >>> prog.prepared_rows is prog.prepared_rows, prog.prepared_rows.n
        (True, 2)
        """
        return prepare_rows(self._rows, self.n)

    def solve(self, p: npt.ArrayLike, q: npt.ArrayLike, *, below: float = -math.inf) -> FractionalResult:
        """The exact optimum for numerator ``p`` and denominator ``q`` (shape (n,) each), rounded outward.

        Parameters
        ----------
        p, q : array_like, shape (n,)
            The numerator and the denominator; q·h ≥ 0 on the polytope.
        below : float, optional
            A value the caller already holds (a ratio): the method starts at λ₀ = ``below``, and where a step proves
            max (p − below·q)·h ≤ 0 the maximum is at most ``below``, returned at once, certified, with that step's
            duals (which prove ``below``, not the program's own maximum). The first step tries HiGHS's own duals
            first, in floating point: where their bound by weak duality, checked exactly, is within
            :data:`CROSSOVER_TOLERANCE` of ``below``, that bound comes back with no witness (NaN) and no exact solve;
            otherwise the basis is solved exactly, its vertex the witness. A search passes the largest value it has
            found: a program that cannot beat it costs one HiGHS solve and one exact check.
            Default -inf: never.

        Returns
        -------
        FractionalResult
            ``method = "lp"``, certified: the exact maximum rounded up, its witness rounded down at the vertex
            attaining it; +inf where a vertex has q·h = 0 < p·h (exactly); NaN with status "infeasible" and a reason
            where the polytope is empty or q·h = 0 on all of it; status "error" where q·h < 0 at a vertex (the
            method needs q·h ≥ 0). ``dual`` holds the last step's ν (on A_ub) and η (on A_eq), to nearest (ν stays
            ≥ 0). ``solver_status`` counts the steps and the exact pivots.
        """
        p, q = _vectors(p, q)
        if p.size != self.n:
            raise InputError("p", f"must have length {self.n}", p.size)
        result = functools.partial(FractionalResult, method="lp")
        self._pq = (p, q)
        lam = Fraction(below) if math.isfinite(below) else None
        if lam is not None:  # HiGHS's own duals may prove ``below`` at once, before anything exact
            basis, duals = self._program.solver_duals(below * q - p)
            early = self._bounded_by_duals(result, lam, None, duals, None, [], [], 1)
            if early is not None:
                return replace(early, basis=tuple(basis))
        top, bottom = [Fraction(v) for v in p.tolist()], [Fraction(v) for v in q.tolist()]
        at: FloatArray | None = None  # the vertex whose ratio is λ
        steps = pivots = 0
        while True:
            cost = top if lam is None else [a - lam * b for a, b in zip(top, bottom, strict=True)]
            negated = [-c for c in cost]
            found = self._program.minimize(negated, pivot=False)
            steps += 1
            if found.status == "unproved":  # HiGHS's basis is not optimal exactly: its duals may bound the ratio
                early = self._bounded_by_duals(result, lam, at, found.duals, found.point, top, bottom, steps)
                if early is not None:
                    return replace(early, basis=found.basis)
                if found.point is not None:  # its vertex, feasible exactly, moves λ up where it beats it
                    num, den = dot(top, found.point), dot(bottom, found.point)
                    if den > 0 and (lam is None or num > lam * den):
                        lam, at = num / den, np.array(found.point, dtype=float)
                        continue
                found = self._program.minimize(negated, found.basis)  # exact pivots from that basis
                pivots += found.pivots
            status = f"HiGHS simplex, exact basis ({steps} Dinkelbach steps, {pivots} exact pivots)"
            if found.status != "optimal" or found.point is None or found.value is None:
                why = "the constraints are inconsistent: no feasible h"  # (a bounded polytope: only empty)
                return result(value=math.nan, argmax=None, status="infeasible", solver_status=status, reason=why)
            h = found.point
            num, den = dot(top, h), dot(bottom, h)
            point = np.array(h, dtype=float)
            if lam is not None and -found.value <= 0:  # max (p − λq)·h ≤ 0: the ratio is at most λ
                if at is not None:  # λ is the ratio at a vertex, which attains it
                    num, den, point = lam, Fraction(1), at
                return replace(self._proved(result, lam, num, den, point, found.duals, status), basis=found.basis)
            if den < 0:
                why = "q·h < 0 at a vertex of the polytope: the ratio needs q·h >= 0"
                return result(value=math.nan, argmax=point, status="error", solver_status=status, reason=why)
            if den == 0 and num > 0:
                why = "the ratio is unbounded: a feasible h has q·h = 0 < p·h (c/0, exactly)"
                return result(value=math.inf, argmax=point, status="unbounded", solver_status=status, reason=why,
                              certified=True)  # fmt: skip
            if den == 0:  # p·h <= 0 = q·h at the maximiser of p·h (lam None): start from the maximiser of q·h
                found = self._program.minimize([-c for c in bottom])
                assert found.point is not None
                if dot(bottom, found.point) <= 0:  # q·h = 0 on all of P, and p·h ≤ 0: 0/0 = 1 at most
                    why = "p·h <= 0 = q·h on every feasible h (0/0 counts as parity)"
                    witness = 1.0 if num == 0 else math.nan
                    return result(value=1.0, argmax=point, status="optimal", solver_status=status, reason=why,
                                  certified=True, witness=witness, gap=gap_between(1.0, witness))  # fmt: skip
                num, den = dot(top, found.point), dot(bottom, found.point)
                point = np.array(found.point, dtype=float)
            lam, at = num / den, point if den > 0 else None

    def vertex_ratio(
        self, basis: Sequence[str] | None, p: npt.ArrayLike, q: npt.ArrayLike
    ) -> tuple[float, tuple[Fraction, ...] | None]:
        """(p·h)/(q·h) rounded down at the vertex h of ``basis`` (:attr:`FractionalResult.basis`, from a program with
        the same shape) over this polytope, solved exactly: a witness, a certified lower end of the maximum here; and
        h, exactly. (NaN, None) where that vertex leaves the polytope, the basis is singular or not one of this
        program; (NaN, h) where q·h ≤ 0.

        Examples
        --------
        The basis of the class's outer program (floors on 0.7 and 0.3), on the inner one (floors on 0.69 and 0.29):

        >>> outer = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=[[-0.7, -0.3], [-0.3, -0.7]], b_ub=[-0.5, -0.5])
        >>> r = outer.solve([0.7, 0.3], [0.3, 0.7])
        >>> inner = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=[[-0.69, -0.29], [-0.29, -0.69]], b_ub=[-0.5, -0.5])
        >>> w, h = inner.vertex_ratio(r.basis, [0.69, 0.29], [0.31, 0.71])
        >>> h[0], abs(h[1] - Fraction(7, 23)) < 1e-15   # h = (1, 7/23) for the decimals; exact for their floats
        (Fraction(1, 1), True)
        >>> w <= r.value, w <= 179 / 121 < w + 1e-15   # (0.69 + 0.29·7/23)/(0.31 + 0.71·7/23)
        (True, True)
        """
        h = None if basis is None else self._program.vertex(basis)  # type: ignore[arg-type]
        if h is None:
            return math.nan, None
        p_arr, q_arr = _vectors(p, q)
        den = dot([Fraction(v) for v in q_arr.tolist()], h)
        return (fraction_down(dot([Fraction(v) for v in p_arr.tolist()], h) / den) if den > 0 else math.nan), h

    def _bounded_by_duals(
        self,
        result: Callable[..., FractionalResult],
        lam: Fraction | None,
        at: FloatArray | None,
        duals: Sequence[Any] | npt.NDArray[np.float64] | None,
        vertex: Sequence[Fraction] | None,
        top: list[Fraction],
        bottom: list[Fraction],
        steps: int,
    ) -> FractionalResult | None:
        """The result where the row duals y of a basis (HiGHS's in floating point, or the exact ones of a basis that
        is not optimal exactly), read to nearest, prove by weak duality
        (:func:`~fairaudit.base.exact_duality.certify_ratio`) a bound within :data:`CROSSOVER_TOLERANCE` of λ: that
        bound, with λ (the ratio at ``at``) or the ratio at the basis's feasible vertex (``vertex``, exact) as the
        witness; else None, as without λ or duals (``proofs/exact_lp.md`` §4, "A bound from the duals")."""
        if lam is None or duals is None:
            return None
        dual = self._multipliers(duals)
        bound = self._near_bound(lam, dual)
        if bound is None:
            return None
        witness, point = math.nan, at
        if at is not None:
            witness = fraction_down(lam)
        elif vertex is not None and (den := dot(bottom, vertex)) > 0:
            witness, point = fraction_down(dot(top, vertex) / den), np.array(vertex, dtype=float)
        status = f"HiGHS simplex, exact basis ({steps} Dinkelbach steps; the last bounded by its duals)"
        return result(value=bound, argmax=point, status="optimal", solver_status=status, reason="",
                      certified=True, witness=witness, gap=gap_between(bound, witness), dual=dual)  # fmt: skip

    def _proved(
        self,
        result: Callable[..., FractionalResult],
        lam: Fraction,
        num: Fraction,
        den: Fraction,
        point: FloatArray,
        duals: tuple[Fraction, ...] | None,
        status: str,
    ) -> FractionalResult:
        """The result once max (p − λq)·h ≤ 0 is proved, the ratio num/den at ``point``: λ rounded up, proved by the
        exact basis of the last step; the witness is the ratio at the point, rounded down. ``dual`` holds that basis's
        duals read to nearest, as a certificate records them (any ν ≥ 0 bounds the program; ``fairaudit verify``
        re-derives a bound from them beyond its exact size). Where the bound they prove by weak duality
        (:func:`~fairaudit.base.exact_duality.certify_ratio`) is not within :data:`CROSSOVER_TOLERANCE` of the value
        (a flat B(λ), where every box maximiser has q·h near 0), ``solver_status`` ends with :data:`EXACT_BASIS`."""
        dual = self._multipliers(duals)
        witness = fraction_down(num / den) if den > 0 else math.nan
        value = fraction_up(lam)
        exact = None
        if self._near_bound(lam, dual) is None:
            status, exact = f"{status}; {EXACT_BASIS}", self._blocks(duals)
        return result(value=value, argmax=point, status="optimal", solver_status=status, reason="", certified=True,
                      witness=witness, gap=gap_between(value, witness), dual=dual, exact_dual=exact)  # fmt: skip

    def _near_bound(self, lam: Fraction, dual: tuple[FloatArray, ...]) -> float | None:
        """The bound the rounded duals prove by weak duality (:func:`~fairaudit.base.exact_duality.certify_ratio`,
        rounded up), where it lies within :data:`CROSSOVER_TOLERANCE` of λ rounded up; else None."""
        p, q = self._pq
        bound = certify_ratio(fraction_down(lam), p, q, self.lower, self.upper, self.prepared_rows, list(dual))
        exact = fraction_up(lam)
        near = bound.certified and bound.value - exact <= CROSSOVER_TOLERANCE * max(1.0, abs(exact))
        return bound.value if near else None

    def _multipliers(self, duals: Sequence[Any] | npt.NDArray[np.float64] | None) -> tuple[FloatArray, ...]:
        """The exact row duals of the last step as (ν on A_ub, η on A_eq), to nearest; ν = −y ≥ 0."""
        return tuple(np.array(block, dtype=float) for block in self._blocks(duals))

    def _blocks(self, duals: Sequence[Any] | npt.NDArray[np.float64] | None) -> tuple[tuple[Any, ...], ...]:
        """The exact row duals of the last step as (ν on A_ub, η on A_eq), exactly; ν = −y ≥ 0."""
        assert duals is not None
        ends = list(itertools.accumulate(a.shape[0] for a, _, _ in self._rows))
        return tuple(tuple(-v for v in duals[start:end]) for start, end in zip([0, *ends], ends))


def _vectors(p: npt.ArrayLike, q: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The numerator ``p`` and the denominator ``q`` as 1-D float arrays of one shape, every entry finite.

    Examples
    --------
    >>> _vectors([1, 2], [3, 4])[1].tolist()
    [3.0, 4.0]
    >>> _vectors([1, 2], [3])
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: q: must have the shape of p (2,) (got (1,))
    """
    p = as_float_array(p, "p", ndim=1)
    q = as_float_array(q, "q", ndim=1)
    if p.shape != q.shape:
        raise InputError("q", f"must have the shape of p {p.shape}", q.shape)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise InputError("p", "p and q must be finite")
    return p, q
