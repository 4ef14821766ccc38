"""Linear-fractional programs: maximise (p·h) / (q·h) over a polytope, exactly.

Two routes to the same optimum:

* :func:`threshold_max` — when only per-cell bounds lower ≤ h ≤ upper
  constrain h. At the optimum λ*, h maximises Σ_i (p_i − λ* q_i) h_i over the
  box, so h_i = upper_i where p_i / q_i > λ* and lower_i elsewhere: a threshold
  in likelihood-ratio order. Sorting once and scanning the n + 1 prefixes
  finds it exactly (Dinkelbach 1967; Charnes and Cooper 1962). The rule itself,
  vectorised over batches of boxes and with one floor on q·h, is
  :mod:`fairaudit.base.threshold_rule`, the inner loop of the worst-case searches.
* :func:`lp_max` — any polytope {lower ≤ h ≤ upper, A_ub h ≤ b_ub, A_eq h = b_eq}.
  The Charnes–Cooper transform y = s·h, s = 1 / (q·h) turns the program into
  the linear program max p·y subject to q·y = 1, A_ub y ≤ b_ub s,
  A_eq y = b_eq s, lower s ≤ y ≤ upper s, s ≥ 0, solved with cvxpy and the
  Clarabel interior-point solver, its value certified from the repaired dual
  (:mod:`fairaudit.base.exact_duality`) or, on a small program near a
  degenerate vertex, by the rational simplex (:mod:`fairaudit.base.exact_programs`).
  An unbounded LP means the ratio is unbounded (+inf); an infeasible one that
  no feasible h has q·h > 0.

* :class:`FractionalProgram` — the same LP compiled once for a fixed
  polytope and re-solved for many (p, q) (cvxpy parameters), which is how the
  worst-case searches of :mod:`fairaudit.worstcase` loop over pairs of groups.
* :func:`fractional_max` — the single entry point: the threshold fast path
  whenever only per-cell bounds constrain h, the LP otherwise.

Conventions as elsewhere: c/0 = +inf for c > 0, 0/0 = 1. Proofs of the
transform and of the threshold solution: ``proofs/linear_fractional.md`` and
``proofs/black_box.md``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import operator
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any, Literal, TypeAlias, overload

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, as_float_array
from fairaudit.base.errors import InputError
from fairaudit.base.exact_duality import (
    ACTIVE_TOLERANCES,
    RatioBound,
    certify_ratio,
    dual_value,
    point_ratio,
    refine_duals,
    vertex_ratio,
)
from fairaudit.base.exact_vertex import improve_witness
from fairaudit.base.outward import fraction_down, fraction_up, up
from fairaudit.base.threshold_rule import threshold_max_many

if TYPE_CHECKING:
    import cvxpy as cp
    import scipy.sparse as sp

    from fairaudit.base.exact_programs import RatioOptimum

ConstraintMatrix: TypeAlias = "npt.ArrayLike | sp.sparray | sp.spmatrix"
"""A constraint matrix: dense (array_like) or a scipy.sparse matrix."""

__all__ = [
    "EXACT_CROSSOVER",
    "FractionalProgram",
    "FractionalResult",
    "exact_result",
    "fractional_max",
    "gap_between",
    "lp_max",
    "threshold_max",
]


@dataclass(frozen=True, eq=False, kw_only=True)
class FractionalResult:
    """The optimum of max (p·h)/(q·h).

    Attributes
    ----------
    value : float
        The optimal ratio as an upper bound: ≥ the exact maximum whenever ``certified`` (+inf when
        unbounded; NaN when infeasible). The threshold route rounds it up by a proven error bound; the LP
        route takes it from a dual point checked in exact arithmetic (the transformed LP's, repaired, or the
        parametric LP's), or, on a small program whose repaired dual is not tight, from the rational simplex's exact
        optimum (``proofs/linear_fractional.md`` §6).
        When not ``certified`` it is the solver's primal value, and ``reason`` says why it is not certified.
    argmax : numpy.ndarray or None
        An h attaining it (to the solver's accuracy), shape (n,); None when unbounded or infeasible.
    status : {"optimal", "unbounded", "infeasible", "error"}
        "error": the solver failed on a program too large for the rational simplex; the value is NaN, not
        certified, and nothing is claimed about the program (``reason`` holds the solver's message).
    method : {"threshold", "lp"}
    solver_status : str
        The solver's own status ("optimal", "optimal_inaccurate", ...; "threshold" or "closed form" for the
        fast paths).
    reason : str
        Why the value is +inf or NaN, or why it is not certified; empty when optimal and certified.
    p, q, lower, upper : numpy.ndarray
        The inputs.
    certified : bool
        Whether ``value`` is proven ≥ the exact maximum (an exactly checked dual, or the threshold rule's error
        bound); +inf always is. False for NaN and for the solver's word alone (an infeasible LP, a value with
        no dual that checks).
    witness : float
        (p·h)/(q·h) at ``argmax`` computed exactly and rounded down, when that point lies in the polytope
        exactly: a certified lower end of the maximum. NaN when there is no such point.
    gap : float
        ``value − witness`` rounded up (NaN without a witness; 0 when both are +inf).
    dual : tuple of numpy.ndarray
        The LP route's dual point that certified ``value``: one array per block of rows (ν ≥ 0 for A_ub,
        η for A_eq, in that order; shape (m,) and (k,)); empty on the threshold route and when the rational
        simplex solved the program (its exact last step is the proof). Where ``value`` is not certified, the
        solver's dual point as it returned it (a caller may certify another bound from it).
    """

    value: float
    argmax: FloatArray | None
    status: str
    method: str
    solver_status: str
    reason: str
    p: FloatArray
    q: FloatArray
    lower: FloatArray | None
    upper: FloatArray | None
    certified: bool = False
    witness: float = math.nan
    gap: float = math.nan
    dual: tuple[FloatArray, ...] = ()


def _proves_less(tight: RatioBound, bound: RatioBound) -> bool:
    """Whether ``tight`` is certified and smaller than ``bound`` (or ``bound`` is not certified): the one to keep."""
    return tight.certified and not (bound.certified and bound.value <= tight.value)


def gap_between(value: float, witness: float) -> float:
    """``value − witness`` rounded up: the certified width of the interval [witness, value] (NaN without both).

    Examples
    --------
    >>> gap_between(2.0, 1.0), gap_between(math.inf, math.inf)
    (1.0, 0.0)
    """
    if math.isnan(value) or math.isnan(witness):
        return math.nan
    if value == witness:
        return 0.0
    return up(value - witness)


def _vectors(p: npt.ArrayLike, q: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    p = as_float_array(p, "p", ndim=1)
    q = as_float_array(q, "q", ndim=1)
    if p.shape != q.shape:
        raise InputError("q", f"must have the shape of p {p.shape}", q.shape)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise InputError("p", "p and q must be finite")
    return p, q


@overload
def _bounds(
    lower: npt.ArrayLike | None, upper: npt.ArrayLike | None, n: int, required: Literal[True]
) -> tuple[FloatArray, FloatArray]: ...
@overload
def _bounds(
    lower: npt.ArrayLike | None, upper: npt.ArrayLike | None, n: int, required: bool
) -> tuple[FloatArray | None, FloatArray | None]: ...
def _bounds(
    lower: npt.ArrayLike | None, upper: npt.ArrayLike | None, n: int, required: bool
) -> tuple[FloatArray | None, FloatArray | None]:
    if required and (lower is None or upper is None):
        raise InputError("lower", "the threshold solution needs finite lower and upper bounds")
    lo = None if lower is None else np.broadcast_to(as_float_array(lower, "lower"), (n,)).copy()
    hi = None if upper is None else np.broadcast_to(as_float_array(upper, "upper"), (n,)).copy()
    if lo is not None and hi is not None and np.any(lo > hi):
        i = int(np.argmax(lo > hi))
        raise InputError("lower", f"exceeds upper at cell {i} ({hi[i]:g})", float(lo[i]))
    return lo, hi


def threshold_max(p: npt.ArrayLike, q: npt.ArrayLike, lower: npt.ArrayLike, upper: npt.ArrayLike) -> FractionalResult:
    """max (p·h)/(q·h) over the box lower ≤ h ≤ upper, exactly, in O(n log n).

    Proof: ``proofs/linear_fractional.md`` (the threshold solution).

    Parameters
    ----------
    p, q : array_like, shape (n,)
        Non-negative weights of the numerator and denominator.
    lower, upper : float or array_like, shape (n,)
        Finite bounds, lower ≤ upper.

    Returns
    -------
    FractionalResult
        ``method = "threshold"``; ``argmax`` is upper on the cells with the
        largest ratios p_i / q_i and lower on the others.

    Raises
    ------
    InputError
        On shapes that differ, non-finite entries, negative weights, a negative
        lower bound, or lower > upper.

    Examples
    --------
    >>> r = threshold_max([0.7, 0.3], [0.3, 0.7], 0.5, 1.0)
    >>> round(r.value, 12), r.argmax.tolist()
    (1.307692307692, [1.0, 0.5])
    """
    p, q = _vectors(p, q)
    if np.any(p < 0) or np.any(q < 0):
        raise InputError("p", "the threshold solution needs non-negative p and q")
    lo, hi = _bounds(lower, upper, p.size, required=True)
    result = functools.partial(FractionalResult, method="threshold", p=p, q=q, lower=lo, upper=hi)
    if np.any(lo < 0):
        # With a negative lower bound q·h can approach 0 from inside the box; the threshold argument
        # needs q·h > 0 on the whole box. Use lp_max for such programs.
        raise InputError("lower", "the threshold solution needs lower >= 0 (use lp_max)", float(lo.min()))
    values, k, order = threshold_max_many(p, q, lo, hi)
    h = lo.copy()
    top = order[: int(k)]
    h[top] = hi[top]
    value = float(values)
    witness = point_ratio(h, p, q, lo, hi, [])
    if math.isnan(witness):  # q·h = 0 at the point: c/0 = +inf, 0/0 = 1
        witness = math.inf if p @ h > 0 else 1.0
    found = functools.partial(result, certified=True, witness=witness, gap=gap_between(value, witness))
    if math.isinf(value):
        return found(
            value=value,
            argmax=h,
            status="unbounded",
            solver_status="threshold",
            reason="some h in the box has q·h = 0 and p·h > 0",
        )
    return found(value=value, argmax=h, status="optimal", solver_status="threshold", reason="")


CLARABEL_TOLERANCES = {"tol_gap_abs": 1e-11, "tol_gap_rel": 1e-11, "tol_feas": 1e-11, "tol_ktratio": 1e-9}


def solve_clarabel(problem: cp.Problem, options: Mapping[str, Any] | None = None) -> str:
    """Solve a cvxpy problem with Clarabel at tight tolerances; return the solver's status.

    cvxpy's "Solution may be inaccurate" warning is not printed: its information is the status returned
    (``optimal_inaccurate``, ...), which every caller keeps (``FractionalResult.solver_status``) and which
    :class:`FractionalProgram` never certifies from the primal value alone.

    Parameters
    ----------
    problem : cvxpy.Problem
    options : mapping, optional
        Clarabel settings that replace or extend :data:`CLARABEL_TOLERANCES`.

    Returns
    -------
    str
        ``problem.status``.
    """
    import warnings

    import cvxpy as cp

    settings = {**CLARABEL_TOLERANCES, **(options or {})}
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Solution may be inaccurate", category=UserWarning)
        problem.solve(solver=cp.CLARABEL, **settings)
    return str(problem.status)


REPAIR_OFFSETS = (0.0, 1e-13, 1e-11, 1e-9)
"""λ − the solver's value (relative) at which the solver's dual is repaired (:func:`~fairaudit.base.exact_duality.refine_duals`); the smallest value certified is kept."""

VERTEX_OFFSETS = (0.0, 1e-15, 1e-13, 1e-11)
"""λ − the root of the repaired duals' B (relative; :func:`~fairaudit.base.exact_duality.vertex_ratio`) at which
they are repaired, smallest first: where B is flat beyond the optimum the duals need λ a little above it."""

PARAMETRIC_OFFSETS = (1e-11, 1e-9, 1e-7)
"""λ − the solver's value (relative to max(1, |value|)) at which the parametric LP is solved, smallest first, when the
transformed LP's dual proves nothing or a loose value beyond :data:`CROSSOVER_SIZE`
(:meth:`FractionalProgram._parametric`). An inexact solve's duals are off by about 1e-9 relative: below that the
margin is lost in them, above it the bound is as far above the optimum."""

REPAIRS = 4
"""Further repairs at the last certified λ, while the value decreases."""

CROSSOVER_TOLERANCE = 1e-13
"""How far (relative to max(1, |value|)) the value the repaired duals certify may lie above the witness (the point's,
or the vertex's it stands for, :func:`~fairaudit.base.exact_vertex.improve_witness`) before a small program is solved
exactly instead."""

EXACT_CROSSOVER = "then the rational simplex"
"""What ``solver_status`` adds when the rational simplex solved the program (``dual`` is then empty), followed by why:
"(exact: the repaired dual was not tight)" or "(exact: the solver failed)"."""

CROSSOVER_SIZE = (64, 128)
"""The largest program (variables, rows; an equality counts twice) solved exactly by the rational simplex when its
repaired duals are not tight."""

_INCONSISTENT = "the constraints are inconsistent: no feasible h"
"""The reason of an empty polytope."""


def _tight(bound: RatioBound, witness: float) -> bool:
    """Whether the dual's certified value lies within :data:`CROSSOVER_TOLERANCE` of the ``witness``, a certified
    lower end: only then is the value known to be within it of the maximum."""
    scale = max(1.0, abs(bound.value))
    return bound.certified and math.isfinite(witness) and bound.value - witness <= CROSSOVER_TOLERANCE * scale


def _no_solution(result: Callable[..., FractionalResult], solver_status: str, reason: str) -> FractionalResult:
    """The result without a point: NaN, status "infeasible", and why."""
    return result(value=math.nan, argmax=None, status="infeasible", solver_status=solver_status, reason=reason)


def _unbounded(
    result: Callable[..., FractionalResult], argmax: FloatArray | None, solver_status: str, reason: str
) -> FractionalResult:
    """+inf, status "unbounded", certified (+inf bounds every ratio), and why the ratio is unbounded."""
    return result(
        value=math.inf, argmax=argmax, status="unbounded", solver_status=solver_status, reason=reason, certified=True
    )


def _failed(result: Callable[..., FractionalResult], solver_status: str, reason: str) -> FractionalResult:
    """The solver failed and nothing exact stood in: NaN, status "error" (not "infeasible": nothing is proved)."""
    return result(value=math.nan, argmax=None, status="error", solver_status=solver_status, reason=reason)


def exact_result(
    result: Callable[..., FractionalResult],
    optimum: RatioOptimum,
    p: Sequence[Fraction],
    q: Sequence[Fraction],
    solver_status: str,
    report_empty: bool = False,
) -> FractionalResult | None:
    """The :class:`FractionalResult` of a program the rational simplex solved exactly, or None.

    Parameters
    ----------
    result : callable
        Makes the result from its remaining fields (``method``, ``p``, ``q``, ``lower`` and ``upper`` given).
    optimum : RatioOptimum
        :func:`~fairaudit.base.exact_programs.maximize_ratio`'s (or ``maximize_ratio_over_product``'s) outcome.
    p, q : sequences of Fraction, shape (n,)
        The exact numerator and denominator it was solved for.
    solver_status : str
        The result's ``solver_status``.
    report_empty : bool
        Whether an empty polytope is reported (else None: a dual's bound holds vacuously there).

    Returns
    -------
    FractionalResult or None
        "optimal": the maximum rounded up (the witness rounded down, the gap between them) at the vertex reached,
        certified; "infeasible" with ``report_empty``; "unbounded" (+inf, certified) at a vertex with q·h = 0 < p·h
        exactly. None where the simplex gives no finite maximum and no proof of +inf.

    Notes
    -----
    ``proofs/linear_fractional.md`` §6 ("An exact crossover"); rounding outward, ``proofs/outward.md`` §3.
    """
    if optimum.status == "infeasible" and report_empty:  # proved exactly: the polytope is empty
        return _no_solution(result, solver_status, _INCONSISTENT)
    if optimum.status == "zero_denominator" and optimum.point is not None:
        at = optimum.point  # a vertex of the polytope, exactly
        if sum(map(operator.mul, q, at)) == 0 < sum(map(operator.mul, p, at)):
            point = np.array([float(x) for x in at])
            reason = "the ratio is unbounded: a feasible h has q·h = 0 < p·h (exactly)"
            return _unbounded(result, point, solver_status, reason)
    if optimum.status != "optimal" or optimum.value is None or optimum.point is None:
        return None
    value, witness = fraction_up(optimum.value), fraction_down(optimum.value)
    return result(
        value=value,
        argmax=np.array([float(x) for x in optimum.point]),
        status="optimal",
        solver_status=solver_status,
        reason="",
        certified=True,
        witness=witness,
        gap=gap_between(value, witness),
    )


class FractionalProgram:
    """max (p·h)/(q·h) over a fixed polytope, compiled once, solved for many (p, q).

    Proof: ``proofs/linear_fractional.md`` (Charnes–Cooper; what each LP status means).

    The polytope is {lower ≤ h ≤ upper, A_ub h ≤ b_ub, A_eq h = b_eq} in R^n.
    The Charnes–Cooper transform y = s·h, s = 1/(q·h) ≥ 0 gives the LP

        max p·y  s.t.  q·y = 1,  A_ub y ≤ b_ub s,  A_eq y = b_eq s,  lower s ≤ y ≤ upper s,

    built once with p and q as cvxpy parameters (disciplined parametrized
    programming), so each :meth:`solve` only re-runs the Clarabel
    interior-point solver.

    Parameters
    ----------
    n : int
        Dimension of h.
    lower, upper : float or array_like, shape (n,), optional
        Per-cell bounds (None or ±inf: unbounded on that side).
    A_ub, b_ub : array_like or scipy.sparse matrix, shapes (m, n) and (m,), optional
    A_eq, b_eq : array_like or scipy.sparse matrix, shapes (k, n) and (k,), optional
    solver_options : mapping, optional
        Clarabel settings over :data:`CLARABEL_TOLERANCES` (tests use a small ``max_iter`` to get an
        inaccurate solve).

    Raises
    ------
    InputError
        On inconsistent shapes, non-finite constraint data, or lower > upper.

    Examples
    --------
    >>> prog = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=[[-0.7, -0.3], [-0.3, -0.7]], b_ub=[-0.5, -0.5])
    >>> r = prog.solve([0.7, 0.3], [0.3, 0.7])   # τ = 0.5 forces 0.3 + 0.7 h_2 >= 0.5: h = (1, 2/7), ratio 11/7
    >>> round(r.value, 7), r.argmax.round(7).tolist(), r.status
    (1.5714286, [1.0, 0.2857143], 'optimal')
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
        solver_options: Mapping[str, Any] | None = None,
    ) -> None:
        import cvxpy as cp

        self.n = int(n)
        self.lower, self.upper = _bounds(lower, upper, self.n, required=False)
        self._p = cp.Parameter(self.n)
        self._q = cp.Parameter(self.n)
        self._y = cp.Variable(self.n)
        self._s = cp.Variable(nonneg=True)
        self._rows: list[tuple[FloatArray | sp.csr_matrix, FloatArray, str]] = []
        for name, a, b, op in (("A_ub", A_ub, b_ub, "le"), ("A_eq", A_eq, b_eq, "eq")):
            if a is None:
                continue
            a = _matrix(a, name)
            b = as_float_array(b, name.replace("A", "b"), ndim=1)
            if a.shape != (b.size, self.n):
                raise InputError(name, f"shape must be ({b.size}, {self.n})", a.shape)
            self._rows.append((a, b, op))
        y = self._y
        constraints = self._constraints(y, self._s)
        self._row_constraints = constraints[len(constraints) - len(self._rows) :]  # their duals are ν and η
        self._problem = cp.Problem(cp.Maximize(self._p @ y), [self._q @ y == 1, *constraints])
        self._options = dict(solver_options or {})
        self._bounded = (
            self.lower is not None
            and self.upper is not None
            and bool(np.all(np.isfinite(self.lower)) and np.all(np.isfinite(self.upper)))
        )
        self._primal: tuple[cp.Problem, cp.Variable, cp.Parameter] | None = None

    def _constraints(self, x: cp.Variable, scale: cp.Variable | None = None) -> list[cp.Constraint]:
        """The polytope's constraints on ``x``: its finite bounds, then its rows; right-hand sides times ``scale``."""
        cons = []
        for bound, op in ((self.lower, "ge"), (self.upper, "le")):
            if bound is not None and np.isfinite(bound).any():
                idx = np.flatnonzero(np.isfinite(bound))
                side = bound[idx] if scale is None else bound[idx] * scale
                cons.append(x[idx] >= side if op == "ge" else x[idx] <= side)
        for a, b, op in self._rows:
            side = b if scale is None else b * scale
            cons.append(a @ x <= side if op == "le" else a @ x == side)
        return cons

    def _result(self, p: FloatArray, q: FloatArray) -> Callable[..., FractionalResult]:
        """A :class:`FractionalResult` of the LP for ``p`` and ``q``, given the rest."""
        return functools.partial(FractionalResult, method="lp", p=p, q=q, lower=self.lower, upper=self.upper)

    def solve(self, p: npt.ArrayLike, q: npt.ArrayLike, *, below: float = -math.inf) -> FractionalResult:
        """The optimum for numerator ``p`` and denominator ``q`` (shape (n,) each).

        Parameters
        ----------
        p, q : array_like, shape (n,)
            The numerator and the denominator.
        below : float, optional
            A value the caller already holds (a ratio): where the solver's own dual certifies a value at most it,
            that value is returned at once, certified, with the ratio at the solver's point as the witness; its dual
            is not repaired, and neither the vertex witness nor the exact or parametric steps run, which only tighten
            a value the caller does not need. Beyond the exact size, a value left above it by no more than the
            parametric offsets' window, with no witness above it, is tried at λ = ``below`` by the parametric LP
            (``_parametric``): a near tie an inexact solve left above the value held is proved at most it there.
            Default -inf: never.

        Returns
        -------
        FractionalResult
            ``method = "lp"``; +inf with a reason when the ratio is unbounded,
            NaN with a reason when no feasible h has q·h > 0. Never raises for
            an infeasible or unbounded program. A box program (no rows, finite bounds ≥ 0, p and q ≥ 0) that the
            solver calls unbounded or whose value its dual cannot certify (badly scaled data: cells of 1e-11) is
            solved by the threshold rule instead, exact on a box (:func:`threshold_max`); ``solver_status`` says so.
            A program with rows that the solver calls unbounded is solved by the rational simplex where it is within
            :data:`CROSSOVER_SIZE` (+inf only where a vertex has q·h = 0 < p·h exactly); beyond it, +inf stands, an
            upper bound of every ratio. Beyond that size, a value whose dual proves nothing, or a value its dual
            proves loosely, is also bounded from the duals of the parametric LP max (p − λq)·h just above the
            solver's value (:data:`PARAMETRIC_OFFSETS`), and the smaller certified value is kept.
        """
        p, q = _vectors(p, q)
        if p.size != self.n:
            raise InputError("p", f"must have length {self.n}", p.size)
        r = self._solve_lp(p, q, below)
        said_unbounded = r.solver_status in ("unbounded", "unbounded_inaccurate")  # cvxpy's statuses
        if r.certified and not said_unbounded or self._rows or not self._bounded:
            return r
        if self.lower is None or self.upper is None or np.any(self.lower < 0) or np.any(p < 0) or np.any(q < 0):
            return r
        exact = threshold_max(p, q, self.lower, self.upper)
        return dataclasses.replace(exact, solver_status=f"{r.solver_status}; then the threshold rule (exact on a box)")

    def _solve_lp(self, p: FloatArray, q: FloatArray, below: float = -math.inf) -> FractionalResult:
        """The LP route of :meth:`solve`."""
        import cvxpy as cp

        result = self._result(p, q)
        self._p.value, self._q.value = p, q
        prob = self._problem
        try:
            solve_clarabel(prob, self._options)
        except cp.error.SolverError as exc:  # a failure is solved exactly when small, else reported, never raised
            exact = self._crossover(result, p, q, "solver_error", "the solver failed", report_empty=True)
            return exact if exact is not None else _failed(result, "solver_error", f"the solver failed: {exc}")
        status = prob.status
        if status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
            # the solver's word is checked where the program is small: on badly scaled data (e^30 beside 1) Clarabel
            # called a ratio unbounded whose exact maximum is finite (a box program goes to the threshold rule, solve)
            if self._rows and self._bounded:
                exact = self._crossover(result, p, q, status, "the solver called the ratio unbounded")
                if exact is not None:
                    return exact
            return _unbounded(result, None, status, "the ratio is unbounded: feasible h approach q·h = 0 with p·h > 0")
        if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
            return self._zero_denominator(p, q, status)
        s = self._s.value
        if s is None:  # pragma: no cover - the solver returned no point
            return _failed(result, status, "the solver returned no solution")
        if self._bounded and s > 0:
            # On a bounded nonempty polytope every feasible (y, s) has s > 0 (s = 0 forces y = 0, and q·y = 1).
            h = np.asarray(self._y.value, dtype=float) / float(s)
            return self._certified(result, p, q, float(prob.value), h, status, below)
        if self._bounded:  # s <= 0 is no point of a bounded polytope: the solve failed (solved exactly when small)
            why = "the solver's point had s <= 0 on a bounded polytope"
            exact = self._crossover(result, p, q, status, why, report_empty=True)
            return exact if exact is not None else _failed(result, status, why)
        y = np.asarray(self._y.value, dtype=float)
        if s <= 1e-12 * max(1.0, float(np.abs(y).max())):
            # s = 0: y is a recession direction. The polytope itself may still be empty; check it.
            try:
                primal_status, _, _ = self._primal_max(p)
            except cp.error.SolverError as exc:
                return _failed(result, status, f"the solver failed: {exc}")
            if primal_status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
                return _no_solution(result, status, _INCONSISTENT)
            return result(
                value=float(prob.value),
                argmax=None,
                status="optimal",
                solver_status=status,
                reason="the supremum is approached only as h grows without bound along a recession "
                "direction of the polytope (q·h -> +inf); it is not attained",
            )
        return self._certified(result, p, q, float(prob.value), y / float(s), status, below)

    def _certified(
        self,
        result: Callable[..., FractionalResult],
        p: FloatArray,
        q: FloatArray,
        value: float,
        h: FloatArray,
        status: str,
        below: float = -math.inf,
    ) -> FractionalResult:
        """The solver's optimum certified from its dual, checked exactly (proofs/linear_fractional.md §6).

        The value is the smallest λ ≥ the solver's value with B(λ) ≤ 0, rounded up; the witness is the ratio at the
        primal point clipped into the box, when it meets every row exactly. Without a dual that checks, the solver's
        value is returned uncertified, with the reason. Where the solver's own dual certifies a value at most
        ``below``, that value is returned as it is (:meth:`solve`).
        """
        duals = [np.atleast_1d(np.asarray(c.dual_value, dtype=float)) for c in self._row_constraints]
        duals = [d if op == "le" else -d for d, (_, _, op) in zip(duals, self._rows)]
        if self.lower is not None or self.upper is not None:
            h = np.clip(h, self.lower, self.upper)
        witness = point_ratio(h, p, q, self.lower, self.upper, self._rows)
        # Newton from the left reaches the smallest λ with B(λ) ≤ 0 for the duals: start below the optimum
        start = min(witness, value - 1e-9 * abs(value)) if math.isfinite(witness) else value - 1e-9 * abs(value)
        bound = certify_ratio(start, p, q, self.lower, self.upper, self._rows, duals)  # type: ignore[arg-type]
        if bound.certified and bound.value <= below:  # (the caller holds as much: no need to tighten it)
            return self._proved(result, bound, h, status, witness, duals)
        candidates: list[tuple[float, float, bool]] = []  # (λ, the active tolerance, whether at a root)
        roots: list[float] = []
        if self._bounded and math.isfinite(value):
            # just above the root of B for the duals repaired at h (the optimum, up to rounding, when h is near an
            # optimal vertex and its cells at a bound are told from those inside), then just above the solver's value:
            # there the best dual has B(λ) < 0 with a margin
            for tolerance in ACTIVE_TOLERANCES:
                root = vertex_ratio(h, p, q, self.lower, self.upper, self._rows, duals, tolerance)  # type: ignore[arg-type]
                if root is not None and root not in roots:
                    roots.append(root)
                    candidates += [(root + offset * max(1.0, abs(root)), tolerance, True) for offset in VERTEX_OFFSETS]
            candidates += [
                (value + offset * max(1.0, abs(value)), ACTIVE_TOLERANCES[0], False) for offset in REPAIR_OFFSETS
            ]
        done: set[float] = set()  # the tolerances whose root certified: a larger offset only loosens it
        best = ACTIVE_TOLERANCES[0]
        for lam, tolerance, at_root in candidates:
            if at_root and tolerance in done:
                continue
            repaired = refine_duals(h, lam, p, q, self.lower, self.upper, self._rows, duals, tolerance)  # type: ignore[arg-type]
            if repaired is None:
                break
            tight = certify_ratio(start, p, q, self.lower, self.upper, self._rows, repaired)  # type: ignore[arg-type]
            if at_root and tight.certified:
                done.add(tolerance)
            if _proves_less(tight, bound):
                bound, duals, best = tight, repaired, tolerance
        for _ in range(REPAIRS if bound.certified and self._bounded else 0):
            # each repair at the last certified λ contracts its distance to the optimum (proofs/linear_fractional.md §6)
            repaired = refine_duals(h, bound.value, p, q, self.lower, self.upper, self._rows, duals, best)  # type: ignore[arg-type]
            tight = certify_ratio(start, p, q, self.lower, self.upper, self._rows, repaired) if repaired else bound  # type: ignore[arg-type]
            if not tight.certified or tight.value >= bound.value:
                break
            bound, duals = tight, repaired  # type: ignore[assignment]

        vertices: dict[float, float] = {}  # the vertex witnesses of h, by tolerance, once each

        def improved(witness: float) -> float:
            """Where the point misses a row by rounding, the witness of the vertex it stands for."""
            if not (self._bounded and bound.certified):
                return witness
            lower, upper = self.lower, self.upper  # finite on a bounded program
            assert lower is not None and upper is not None
            rows = self._rows
            return improve_witness(witness, bound.value, CROSSOVER_TOLERANCE, h, p, q, lower, upper, rows, vertices)

        witness = improved(witness)
        if self._bounded and not _tight(bound, witness):
            crossover = self._crossover(result, p, q, status)
            if crossover is not None:
                return crossover
            if math.isfinite(value):  # beyond the exact size: the parametric LP's duals, where they prove more
                bound, duals = self._parametric(p, q, start, value, bound, duals, below, witness)
                witness = improved(witness)
        if not bound.certified:
            why = f"not certified (solver status {status}): {bound.reason}"
            raw = tuple(np.asarray(d, dtype=float) for d in duals)
            return result(
                value=value, argmax=h, status="optimal", solver_status=status, reason=why, witness=witness, dual=raw
            )
        return self._proved(result, bound, h, status, witness, duals)

    def _proved(
        self,
        result: Callable[..., FractionalResult],
        bound: RatioBound,
        h: FloatArray,
        status: str,
        witness: float,
        duals: list[FloatArray],
    ) -> FractionalResult:
        """The result certified by ``bound`` from ``duals`` (ν ≥ 0 on the "le" rows, clipped at 0 there)."""
        cleaned = tuple(np.maximum(d, 0.0) if op == "le" else d for d, (_, _, op) in zip(duals, self._rows))
        return result(
            value=bound.value,
            argmax=h,
            status="optimal",
            solver_status=status,
            reason="",
            certified=True,
            witness=witness,
            gap=gap_between(bound.value, witness),
            dual=cleaned,
        )

    def _parametric(
        self,
        p: FloatArray,
        q: FloatArray,
        start: float,
        value: float,
        bound: RatioBound,
        duals: list[FloatArray],
        below: float = -math.inf,
        witness: float = math.nan,
    ) -> tuple[RatioBound, list[FloatArray]]:
        """The better of ``bound`` (with its ``duals``) and the bounds certified from the duals of the parametric LP
        max (p − λq)·h over the polytope itself, at λ a little above the solver's ``value``
        (:data:`PARAMETRIC_OFFSETS`): there its optimum is negative by a margin, so its duals prove B(λ) ≤ 0 where
        the solver's error is below that margin (Dinkelbach). Checked exactly as any dual
        (``proofs/linear_fractional.md`` §6, "The parametric dual").

        For when the transformed LP's dual proves nothing (an inexact solve whose floors' multipliers leave B above 0
        where q·h = 0) or proves a loose value, on a program beyond the rational simplex's size. First, at λ =
        ``below`` (the value the caller holds, :meth:`solve`) where it lies under ``bound`` but not under the
        ``witness``, and no further below the solver's value than its largest offset above it: an inexact solve's
        value can lie that far above the optimum, and a near tie the caller holds is proved at most its value there.
        """
        import cvxpy as cp

        scale = max(1.0, abs(value))
        offsets = [offset * scale for offset in PARAMETRIC_OFFSETS]
        near = value - offsets[-1] <= below < bound.value and not witness > below  # (NaN: no witness)
        for lam in [below] * near + [value + offset for offset in offsets]:
            if bound.certified and bound.value <= lam:
                break  # a larger λ gives no smaller root
            try:
                status, _, _ = self._primal_max(p - lam * q)
            except cp.error.SolverError:
                continue
            if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
                continue
            for found in self._primal_duals():
                tight = certify_ratio(start, p, q, self.lower, self.upper, self._rows, found)  # type: ignore[arg-type]
                if _proves_less(tight, bound):
                    bound, duals = tight, found
        return bound, duals

    def _crossover(
        self,
        result: Callable[..., FractionalResult],
        p: FloatArray,
        q: FloatArray,
        status: str,
        why: str = "the repaired dual was not tight",
        report_empty: bool = False,
    ) -> FractionalResult | None:
        """The exact optimum of a small program by the rational simplex (:func:`~fairaudit.base.exact_programs.
        maximize_ratio`), for when the duals repaired at the solver's point are not tight, or the solver failed
        (``why`` says which, in ``solver_status``); None when the program is larger than :data:`CROSSOVER_SIZE` or the
        simplex finds no finite maximum. An empty polytope (in the floats' rationals) is reported as such with
        ``report_empty`` (no solve to fall back on), else None: a dual's bound holds vacuously there.

        Near a degenerate vertex (two rows that differ by rounding, both active at the solver's point) the optimal
        basis is not the one the solver's point suggests: its repaired duals have mixed signs, and the bound
        certified from them is loose. The simplex pivots to the optimal vertex exactly
        (``proofs/linear_fractional.md`` §6, "An exact crossover").
        """
        from fairaudit.base.exact_programs import maximize_ratio

        blocks = [(np.asarray(a.toarray() if hasattr(a, "toarray") else a), b, op) for a, b, op in self._rows]
        size = sum(b.size * (2 if op == "eq" else 1) for _, b, op in blocks)
        if self.n > CROSSOVER_SIZE[0] or size > CROSSOVER_SIZE[1] or self.lower is None or self.upper is None:
            return None

        def exact(v: Any) -> list[Fraction]:
            return [Fraction(float(x)) for x in v]

        a_ub, b_ub = [], []
        for a, b, op in blocks:
            for sign in (1, -1) if op == "eq" else (1,):
                a_ub += [exact(sign * row) for row in a]
                b_ub += exact(sign * b)
        top, bottom = exact(p), exact(q)
        optimum = maximize_ratio(top, bottom, exact(self.lower), exact(self.upper), a_ub, b_ub)
        return exact_result(result, optimum, top, bottom, f"{status}; {EXACT_CROSSOVER} (exact: {why})", report_empty)

    def _zero_denominator(self, p: FloatArray, q: FloatArray, status: str) -> FractionalResult:
        """The transformed LP is infeasible: the polytope is empty, or q·h = 0 on all of it.

        Tells the two apart with the LP max p·h over the polytope itself: empty
        gives NaN; otherwise the ratio is +inf when some feasible h has
        p·h > 0 (c/0) and 1 when p·h = 0 too (0/0, parity).
        """
        import cvxpy as cp

        result = self._result(p, q)
        if self._bounded:  # a small program is told exactly: empty, or +inf at a vertex with q·h = 0 < p·h
            why = "the solver called the transformed program infeasible"
            exact = self._crossover(result, p, q, status, why, report_empty=True)
            if exact is not None:
                return exact
        try:
            primal_status, value, h = self._primal_max(p)
        except cp.error.SolverError as exc:  # pragma: no cover
            return _failed(result, "solver_error", f"the solver failed: {exc}")

        if primal_status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
            return _no_solution(result, status, _INCONSISTENT)
        if self._bounded and primal_status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
            # max p·h over a bounded polytope is finite: the solver's word and its point (a ray of 1e38) are wrong
            return _failed(
                result, f"{status}; {primal_status}", "the solver called max p·h over a bounded box unbounded"
            )
        if primal_status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE) or value > 1e-12 * max(1.0, np.abs(p).sum()):
            return _unbounded(result, h, status, "q·h = 0 on every feasible h and some has p·h > 0 (c/0)")
        parity = "p·h = q·h = 0 on every feasible h (0/0 counts as parity)"
        certified = h is not None and self._parity_holds(p, q, h)
        return result(value=1.0, argmax=h, status="optimal", solver_status=status, certified=certified,
                      reason=parity if certified else f"{parity}; not certified: no dual of max p·h checks B(1) <= 0")  # fmt: skip

    def _parity_holds(self, p: FloatArray, q: FloatArray, h: FloatArray) -> bool:
        """Whether p·h ≤ q·h on all of the (bounded) polytope, proven by the duals of :meth:`_primal_max`'s rows
        (as the solver gives them, then repaired at its point h at each active tolerance): B(1) ≤ 0 exactly. Then the
        ratio is at most 1 wherever q·h > 0, and q·h = 0 forces p·h ≤ 0, so no c/0: the value 1 is an upper bound
        (``proofs/linear_fractional.md`` §6, "The value 1 of 0/0")."""
        if not self._bounded or self._primal is None:
            return False
        lower, upper = self.lower, self.upper
        assert lower is not None and upper is not None  # (bounded)
        found = self._primal_duals()
        if not found:
            return False
        h = np.clip(h, lower, upper)
        candidates = found + [
            refine_duals(h, 1.0, p, q, lower, upper, self._rows, duals, t) for duals in found for t in ACTIVE_TOLERANCES
        ]
        for candidate in candidates:
            if candidate is not None and dual_value(Fraction(1), p, q, lower, upper, self._rows, candidate) <= 0:
                return True
        return False

    def _primal_duals(self) -> list[list[FloatArray]]:
        """The duals of the rows of :meth:`_primal_max`'s last solve, as candidates for an exact check: ν clipped at 0,
        η as cvxpy gives it and negated (its sign for an equality differs between this program and the transformed
        one; any η is a dual, so both are tried). Empty when the solver gave none, or not finite."""
        assert self._primal is not None
        constraints = self._primal[0].constraints[len(self._primal[0].constraints) - len(self._rows) :]
        duals = [np.atleast_1d(np.asarray(c.dual_value, dtype=float)) for c in constraints]
        if any(d.size != b.size or not np.all(np.isfinite(d)) for d, (_, b, _) in zip(duals, self._rows)):
            return []
        signs = (1.0, -1.0) if any(op == "eq" for _, _, op in self._rows) else (1.0,)
        return [[np.maximum(d, 0.0) if op == "le" else sign * d for d, (_, _, op) in zip(duals, self._rows)]
                for sign in signs]  # fmt: skip

    def _primal_max(self, p: FloatArray) -> tuple[str, float, FloatArray | None]:
        """max p·h over the polytope itself (built on first use): (status, value, h or None)."""
        import cvxpy as cp

        if self._primal is None:
            h = cp.Variable(self.n)
            c = cp.Parameter(self.n)
            self._primal = (cp.Problem(cp.Maximize(c @ h), self._constraints(h)), h, c)
        prob, h, c = self._primal
        c.value = p
        solve_clarabel(prob, self._options)
        return prob.status, prob.value, None if h.value is None else np.asarray(h.value, dtype=float)


def _matrix(a: ConstraintMatrix, name: str) -> FloatArray | sp.csr_matrix:
    import scipy.sparse as sp

    if sp.issparse(a):
        a = sp.csr_matrix(a, dtype=float)
        if not np.all(np.isfinite(a.data)):
            raise InputError(name, "must be finite")
        return a
    return as_float_array(a, name, ndim=2)


def lp_max(
    p: npt.ArrayLike,
    q: npt.ArrayLike,
    *,
    lower: npt.ArrayLike | None = None,
    upper: npt.ArrayLike | None = None,
    A_ub: ConstraintMatrix | None = None,
    b_ub: npt.ArrayLike | None = None,
    A_eq: ConstraintMatrix | None = None,
    b_eq: npt.ArrayLike | None = None,
) -> FractionalResult:
    """max (p·h)/(q·h) over a polytope, by the Charnes–Cooper transform and an LP.

    Proof: ``proofs/linear_fractional.md`` (Charnes–Cooper; statuses).

    Parameters
    ----------
    p, q : array_like, shape (n,)
    lower, upper : float or array_like, shape (n,), optional
        Per-cell bounds (None: unbounded on that side).
    A_ub, b_ub : array_like, shapes (m, n) and (m,), optional
        A_ub h ≤ b_ub.
    A_eq, b_eq : array_like, shapes (k, n) and (k,), optional
        A_eq h = b_eq.

    Returns
    -------
    FractionalResult
        ``method = "lp"`` with the solver's status; +inf with a reason when
        the ratio is unbounded, NaN with a reason when no feasible h has
        q·h > 0. Never raises for an infeasible or unbounded program.

    Raises
    ------
    InputError
        On inconsistent shapes or non-finite data.

    Examples
    --------
    >>> r = lp_max([0.7, 0.3], [0.3, 0.7], lower=0.5, upper=1.0)
    >>> round(r.value, 7), r.status
    (1.3076923, 'optimal')
    """
    p, q = _vectors(p, q)
    prog = FractionalProgram(p.size, lower=lower, upper=upper, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq)
    return prog.solve(p, q)


def fractional_max(
    p: npt.ArrayLike,
    q: npt.ArrayLike,
    *,
    lower: npt.ArrayLike | None = None,
    upper: npt.ArrayLike | None = None,
    A_ub: ConstraintMatrix | None = None,
    b_ub: npt.ArrayLike | None = None,
    A_eq: ConstraintMatrix | None = None,
    b_eq: npt.ArrayLike | None = None,
    method: str = "auto",
) -> FractionalResult:
    """max (p·h)/(q·h) over a polytope: the threshold fast path when it applies, else the LP.

    Proof: ``proofs/linear_fractional.md``.

    The fast path (:func:`threshold_max`) applies when only finite per-cell
    bounds 0 ≤ lower ≤ upper constrain h and p, q ≥ 0; otherwise the
    Charnes–Cooper LP (:func:`lp_max`) solves it.

    Parameters
    ----------
    p, q, lower, upper, A_ub, b_ub, A_eq, b_eq
        As in :func:`lp_max`.
    method : {"auto", "threshold", "lp"}
        Force a route (``"threshold"`` raises when it does not apply).

    Returns
    -------
    FractionalResult

    Raises
    ------
    InputError
        On bad input, an unknown method, or ``method="threshold"`` where it
        does not apply.

    Examples
    --------
    >>> fractional_max([0.7, 0.3], [0.3, 0.7], lower=0.5, upper=1.0).method
    'threshold'
    >>> fractional_max([0.7, 0.3], [0.3, 0.7], lower=0.0, upper=1.0, A_ub=[[-0.3, -0.7]], b_ub=[-0.5]).method
    'lp'
    """
    if method not in ("auto", "threshold", "lp"):
        raise InputError("method", "must be 'auto', 'threshold' or 'lp'", method)
    p_arr, q_arr = _vectors(p, q)
    boxed = (
        A_ub is None
        and A_eq is None
        and lower is not None
        and upper is not None
        and np.all(np.isfinite(np.asarray(lower, dtype=float)))
        and np.all(np.isfinite(np.asarray(upper, dtype=float)))
        and np.all(np.asarray(lower, dtype=float) >= 0)
        and np.all(p_arr >= 0)
        and np.all(q_arr >= 0)
    )
    if method == "threshold" and not boxed:
        raise InputError(
            "method", "the threshold solution needs only finite bounds 0 <= lower <= upper and p, q >= 0", method
        )
    if method == "threshold" or (method == "auto" and boxed):
        assert lower is not None and upper is not None  # boxed
        return threshold_max(p_arr, q_arr, lower, upper)
    return lp_max(p_arr, q_arr, lower=lower, upper=upper, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq)
