"""Linear-fractional programs: maximise (p·h) / (q·h) over a polytope, exactly.

Two routes to the same optimum:

* :func:`threshold_max` — when only per-cell bounds lower ≤ h ≤ upper
  constrain h. At the optimum λ*, h maximises Σ_i (p_i − λ* q_i) h_i over the
  box, so h_i = upper_i where p_i / q_i > λ* and lower_i elsewhere: a threshold
  in likelihood-ratio order. Sorting once and scanning the n + 1 prefixes
  finds it exactly (Dinkelbach 1967; Charnes and Cooper 1962).
* :func:`lp_max` — any polytope {lower ≤ h ≤ upper, A_ub h ≤ b_ub, A_eq h = b_eq}.
  The Charnes–Cooper transform y = s·h, s = 1 / (q·h) turns the program into
  the linear program max p·y subject to q·y = 1, A_ub y ≤ b_ub s,
  A_eq y = b_eq s, lower s ≤ y ≤ upper s, s ≥ 0, solved with cvxpy and the
  Clarabel interior-point solver. An unbounded LP means the ratio is
  unbounded (+inf); an infeasible one that no feasible h has q·h > 0.

Conventions as elsewhere: c/0 = +inf for c > 0, 0/0 = 1. Proof of the
transform and of the threshold solution: ``proofs/black_box.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._arrays import as_float_array
from ._errors import InputError

__all__ = ["FractionalResult", "threshold_max", "lp_max"]


@dataclass(frozen=True, eq=False)
class FractionalResult:
    """The optimum of max (p·h) / (q·h).

    Attributes
    ----------
    value : float
        The optimal ratio (+inf when unbounded; NaN when infeasible).
    argmax : numpy.ndarray or None
        An h attaining it, shape (n,); None when unbounded or infeasible.
    status : {"optimal", "unbounded", "infeasible"}
    method : {"threshold", "lp"}
    solver_status : str
        The solver's own status ("threshold" for the fast path).
    reason : str
        Why the value is +inf or NaN; empty when optimal.
    p, q, lower, upper : numpy.ndarray
        The inputs.
    """

    value: float
    argmax: np.ndarray | None
    status: str
    method: str
    solver_status: str
    reason: str
    p: np.ndarray
    q: np.ndarray
    lower: np.ndarray | None
    upper: np.ndarray | None


def _vectors(p, q):
    p = as_float_array(p, "p", ndim=1)
    q = as_float_array(q, "q", ndim=1)
    if p.shape != q.shape:
        raise InputError("q", f"must have the shape of p {p.shape}", q.shape)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise InputError("p", "p and q must be finite")
    return p, q


def _bounds(lower, upper, n: int, required: bool):
    if lower is None or upper is None:
        if required:
            raise InputError("lower", "the threshold solution needs finite lower and upper bounds")
        return (None if lower is None else np.broadcast_to(as_float_array(lower, "lower"), (n,)).copy(),
                None if upper is None else np.broadcast_to(as_float_array(upper, "upper"), (n,)).copy())
    lo = np.broadcast_to(as_float_array(lower, "lower"), (n,)).copy()
    hi = np.broadcast_to(as_float_array(upper, "upper"), (n,)).copy()
    if np.any(lo > hi):
        i = int(np.argmax(lo > hi))
        raise InputError("lower", f"exceeds upper at cell {i} ({hi[i]:g})", float(lo[i]))
    return lo, hi


def _ratio(num: float, den: float) -> float:
    if den > 0:
        return num / den
    return math.inf if num > 0 else 1.0


def threshold_max(p, q, lower, upper) -> FractionalResult:
    """max (p·h)/(q·h) over the box lower ≤ h ≤ upper, exactly, in O(n log n).

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
    if np.any(lo < 0):
        # With a negative lower bound q·h can approach 0 from inside the box; the threshold argument
        # needs q·h > 0 on the whole box. Use lp_max for such programs.
        raise InputError("lower", "the threshold solution needs lower >= 0 (use lp_max)", float(lo.min()))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(q > 0, p / np.where(q > 0, q, 1.0), np.where(p > 0, np.inf, 0.0))
    order = np.argsort(-r, kind="stable")
    span = hi - lo
    num = p @ lo + np.concatenate([[0.0], np.cumsum((p * span)[order])])
    den = q @ lo + np.concatenate([[0.0], np.cumsum((q * span)[order])])
    with np.errstate(divide="ignore", invalid="ignore"):
        values = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 1.0))
    k = int(np.argmax(values))
    h = lo.copy()
    h[order[:k]] = hi[order[:k]]
    value = float(values[k])
    if math.isinf(value):
        return FractionalResult(value, h, "unbounded", "threshold", "threshold",
                                "some h in the box has q·h = 0 and p·h > 0", p, q, lo, hi)
    return FractionalResult(value, h, "optimal", "threshold", "threshold", "", p, q, lo, hi)


def lp_max(p, q, *, lower=None, upper=None, A_ub=None, b_ub=None, A_eq=None, b_eq=None) -> FractionalResult:
    """max (p·h)/(q·h) over a polytope, by the Charnes–Cooper transform and an LP.

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
    import cvxpy as cp

    p, q = _vectors(p, q)
    n = p.size
    lo, hi = _bounds(lower, upper, n, required=False)
    y = cp.Variable(n)
    s = cp.Variable(nonneg=True)
    cons = [q @ y == 1]
    if lo is not None:
        fin = np.isfinite(lo)
        if fin.any():
            cons.append(y[fin] >= lo[fin] * s)
    if hi is not None:
        fin = np.isfinite(hi)
        if fin.any():
            cons.append(y[fin] <= hi[fin] * s)
    for name, a, b, op in (("A_ub", A_ub, b_ub, "le"), ("A_eq", A_eq, b_eq, "eq")):
        if a is None:
            continue
        a = as_float_array(a, name, ndim=2)
        b = as_float_array(b, name.replace("A", "b"), ndim=1)
        if a.shape != (b.size, n):
            raise InputError(name, f"shape must be ({b.size}, {n})", a.shape)
        cons.append(a @ y <= b * s if op == "le" else a @ y == b * s)
    prob = cp.Problem(cp.Maximize(p @ y), cons)
    try:
        prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-11, tol_gap_rel=1e-11, tol_feas=1e-11, tol_ktratio=1e-9)
    except cp.error.SolverError as exc:  # pragma: no cover - solver failure is reported, not raised
        return FractionalResult(math.nan, None, "infeasible", "lp", "solver_error", str(exc), p, q, lo, hi)
    status = prob.status
    if status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
        return FractionalResult(math.inf, None, "unbounded", "lp", status,
                                "the ratio is unbounded: feasible h approach q·h = 0 with p·h > 0", p, q, lo, hi)
    if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        return FractionalResult(math.nan, None, "infeasible", "lp", status,
                                "no feasible h has q·h > 0 (or the constraints are inconsistent)", p, q, lo, hi)
    if s.value is None or s.value <= 1e-12:
        return FractionalResult(math.inf, None, "unbounded", "lp", status,
                                "the optimum is approached only as q·h -> 0", p, q, lo, hi)
    h = np.asarray(y.value, dtype=float) / float(s.value)
    return FractionalResult(float(prob.value), h, "optimal", "lp", status, "", p, q, lo, hi)
