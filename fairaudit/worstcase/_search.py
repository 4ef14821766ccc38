"""The pair search shared by the worst cases: LPs in decreasing order of valid upper bounds, and its helpers.

Every maximum of :mod:`fairaudit.worstcase` is a maximum over problems (ordered pairs of groups, and contexts)
of a linear-fractional program. :func:`search` solves them in decreasing order of an upper bound and stops when
no problem left can win; :func:`relaxed_first` tries the closed-form floor relaxation before the LP;
:func:`pairwise_box` gives the box (threshold) value of every pair at once; :func:`check_method` and
:func:`check_class` check the arguments the worst cases share. ``proofs/black_box.md`` §1–2 and §5,
``proofs/linear_fractional.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .._arrays import FloatArray, row_blocks
from .._errors import InputError
from .._validation import choice, nonnegative
from ..lfp import FractionalProgram, FractionalResult, box_point, floor_max_many, threshold_max_many

METHODS = ("auto", "threshold", "lp")


@dataclass(frozen=True, kw_only=True)
class SearchResult:
    """The outcome of :func:`search`: the maximising problem and its solution, or why there is none."""

    index: int  # flat index of the maximising problem (-1 when none)
    result: FractionalResult | None
    solved: int  # LPs solved
    reason: str


def search(upper: FloatArray, solve: Callable[[int], FractionalResult]) -> SearchResult:
    """Maximise over problems i by LP, in decreasing order of the upper bounds ``upper[i]`` (ratios).

    Stops when the best value found is at least every remaining upper bound
    (exact: the bounds are valid). An infeasible program means the common
    polytope is empty, which ends the search.
    """
    order = np.argsort(-upper, kind="stable")
    best_i, best, best_v, solved = -1, None, -math.inf, 0
    for i in order:
        if best is not None and best_v >= upper[i] * (1 - 1e-9):
            break
        r = solve(int(i))
        solved += r.method == "lp"
        if r.status == "infeasible":
            return SearchResult(index=-1, result=r, solved=solved, reason=r.reason)
        if best is None or r.value > best_v * (1 + 1e-9):  # ties (to solver accuracy) keep the earlier pair
            best_i, best, best_v = int(i), r, r.value
        if math.isinf(best_v):
            break
    return SearchResult(index=best_i, result=best, solved=solved, reason="")


def relaxed_first(
    num: Callable[[int], FloatArray],
    den: Callable[[int], FloatArray],
    lower: float,
    upper: float,
    floor: float | None,
    rows: npt.NDArray[np.floating[Any]] | None,
    program: Callable[[], FractionalProgram],
) -> Callable[[int], FractionalResult]:
    """Solve problem i by the closed-form floor relaxation when its point is feasible, by the LP otherwise.

    The relaxation keeps the box and only the denominator's constraint q·h ≥ floor
    (:func:`fairaudit.lfp.floor_max_many`); its point is optimal for the full
    program whenever it meets every row of ``rows @ h ≥ floor``. With no
    floor the program is the box program and the threshold solves it.
    """

    def solve(i: int) -> FractionalResult:
        p, q = num(i), den(i)
        frac: float | FloatArray
        if floor is None:
            v, k, order = threshold_max_many(p, q, lower, upper)
            frac = 0.0
        else:
            v, k, frac, order = floor_max_many(p, q, lower, upper, floor)
        if not np.isnan(v):
            h = box_point(lower, upper, order, int(k), float(frac))
            free = (p == 0) & (q == 0)  # cells outside the objective: the top of the box helps every τ row
            h[free] = np.broadcast_to(np.asarray(upper, dtype=float), h.shape)[free]
            if rows is None or floor is None or np.all(rows @ h >= floor * (1 - 1e-12) - 1e-15):
                status = "unbounded" if math.isinf(v) else "optimal"
                return FractionalResult(
                    value=float(v),
                    argmax=h,
                    status=status,
                    method="threshold",
                    solver_status="closed form",
                    reason="",
                    p=p,
                    q=q,
                    lower=None,
                    upper=None,
                )
        return program().solve(p, q)

    return solve


def check_method(method: str) -> str:
    """``method`` if it is one of :data:`METHODS` ("auto", "threshold", "lp")."""
    return choice(method, "method", METHODS)


def check_class(lower: float, gamma: float, tau: float | None) -> tuple[float, float, float | None]:
    """Validate a utility class [lower, γ] with floor τ ≤ γ (τ may be None)."""
    lower, gamma = nonnegative(lower, "lower"), nonnegative(gamma, "gamma")
    if lower > gamma:
        raise InputError("lower", f"cannot exceed gamma = {gamma:g}", lower)
    if tau is not None:
        tau = nonnegative(tau, "tau")
        if tau > gamma:
            raise InputError(
                "tau", f"exceeds gamma = {gamma:g}: no utility in [lower, gamma] has E[g | x, a] >= tau", tau
            )
    return lower, gamma, tau


def pair_epsilon(matrix: FloatArray) -> FloatArray:
    """max_o M[a, o] / M[b, o] for every ordered pair, shape (n, n) (c/0 = inf, 0/0 ignored)."""
    n = matrix.shape[0]
    out = np.empty((n, n))
    q = matrix[None, :, :]
    for rows in row_blocks(n, n * matrix.shape[1]):  # (block, n, m) at a time
        p = matrix[rows, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(q > 0, p / np.where(q > 0, q, 1.0), np.where(p > 0, np.inf, 0.0))
        out[rows] = r.max(axis=-1)
    return out


def pairwise_box(
    matrix: FloatArray, lower: float, upper: float, floor: float | None
) -> tuple[FloatArray, FloatArray | None]:
    """The box program of every ordered pair (rows a, b of ``matrix``), and with ``floor`` its floor relaxation.

    The threshold and relaxation values, shape (n, n), computed a block of rows at a time, so the
    (n, n, m) sorts and prefix sums never exist all at once.
    """
    n = matrix.shape[0]
    box = np.empty((n, n))
    relaxed = None if floor is None else np.empty((n, n))
    q = matrix[None, :, :]
    for rows in row_blocks(n, 4 * n * matrix.shape[1]):
        p = matrix[rows, None, :]
        solution = threshold_max_many(p, q, lower, upper)
        box[rows] = solution[0]
        if relaxed is not None and floor is not None:
            relaxed[rows] = floor_max_many(p, q, lower, upper, floor, threshold=solution)[0]
    return box, relaxed
