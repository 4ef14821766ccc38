"""The known-utility programs in exact rationals, for the programs their rounded form does not settle.

The pair search (:mod:`~fairaudit.worstcase.known_utility_search`) solves programs whose coefficients are products
of floats: its value is certified on their outer ends, its witness on their inner ends. Where the two do not meet
(within :data:`~fairaudit.base.linear_fractional.CROSSOVER_TOLERANCE`), the rounding itself may be what moves the
optimum: a floor E[g | x, a] ≥ τ with τ = max g holds on a face of the polytope only, and a rounded coefficient turns
that face into a slab. Such a program, within :data:`CROSSOVER_SIZE`, is solved again here exactly (HiGHS's basis
solved and finished in rationals) on exact data: g, τ, P(x | a) and a matrix mechanism's entries as the floats they
are (their exact values), and randomized response's rows at the two ends of its e^ε (float ends, or 50-digit ones
beyond the floats). The worst case is non-decreasing in e^ε (randomized response at a smaller ε is the one at a
larger ε followed by more randomized response), so the maximum at the upper end bounds it from above and the one at
the lower end from below.
``proofs/black_box.md`` §6.
"""

from __future__ import annotations

import functools
import itertools
import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.exact_ratio import Polytope, RatioOptimum, maximize_ratio_over_product
from fairaudit.base.linear_fractional import FractionalResult
from fairaudit.base.outward import fraction_down, fraction_up, gap_between
from fairaudit.laws.closed_forms import RandomizedResponse
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.worstcase.known_utility_problem import ModelProblem, coefficient_factors
from fairaudit.worstcase.randomized_response import rr_exact_rows
from fairaudit.worstcase.worst_cases import EXACT_CROSSOVER

ObjectArray = npt.NDArray[np.object_]

CROSSOVER_SIZE = (64, 128)
"""The largest program (variables, rows; an equality counts twice) the worst-case searches solve again exactly on
exact coefficients when its rounded form leaves a gap."""

WHY = "its rounded coefficients' witness did not meet the value: solved on exact ones"
"""What ``solver_status`` says after :data:`EXACT_CROSSOVER` for these programs."""


def exact_result(
    result: Callable[..., FractionalResult],
    optimum: RatioOptimum,
    p: Sequence[Fraction],
    q: Sequence[Fraction],
) -> FractionalResult | None:
    """The :class:`FractionalResult` of a program solved exactly, or None.

    Parameters
    ----------
    result : callable
        Makes the result from its remaining fields (``method`` and ``solver_status`` given).
    optimum : RatioOptimum
        :func:`~fairaudit.base.exact_ratio.maximize_ratio_over_product`'s outcome.
    p, q : sequences of Fraction, shape (n,)
        The exact numerator and denominator it was solved for.

    Returns
    -------
    FractionalResult or None
        "optimal": the maximum rounded up (the witness rounded down, the gap between them) at the vertex reached,
        certified; "infeasible" where the polytope is empty (proved exactly); "unbounded" (+inf, certified) at a
        vertex with q·h = 0 < p·h exactly. None where the exact solve gives no finite maximum and no proof of +inf.

    Notes
    -----
    ``proofs/black_box.md`` §6 (the known-utility programs solved on exact coefficients); rounding outward,
    ``proofs/outward.md`` §3.
    """
    if optimum.status == "infeasible":  # proved exactly: the polytope is empty
        reason = "the constraints are inconsistent: no feasible h"
        return result(value=math.nan, argmax=None, status="infeasible", reason=reason)
    if optimum.status == "zero_denominator" and optimum.point is not None:
        at = optimum.point  # a vertex of the polytope, exactly
        if sum(map(operator.mul, q, at)) == 0 < sum(map(operator.mul, p, at)):
            point = np.array([float(x) for x in at])
            reason = "the ratio is unbounded: a feasible h has q·h = 0 < p·h (exactly)"
            return result(value=math.inf, argmax=point, status="unbounded", reason=reason, certified=True)
    if optimum.status != "optimal" or optimum.value is None or optimum.point is None:
        return None
    value, witness = fraction_up(optimum.value), fraction_down(optimum.value)
    return result(
        value=value,
        argmax=np.array([float(x) for x in optimum.point]),
        status="optimal",
        reason="",
        certified=True,
        witness=witness,
        gap=gap_between(value, witness),
    )


def _rationals(values: npt.ArrayLike) -> ObjectArray:
    """An array of floats as exact Fractions (an object array of the same shape)."""
    return np.vectorize(Fraction, otypes=[object])(np.asarray(values, dtype=float))


def _rows(mechanism: Mechanism, end: int) -> ObjectArray | None:
    """A mechanism's rows in exact rationals: its floats; randomized response's at the lower (``end`` 0) or upper (1)
    end of e^ε (:func:`~fairaudit.worstcase.randomized_response.rr_exact_rows`), None where it has none."""
    if not isinstance(mechanism, RandomizedResponse) or mechanism.is_identity:
        return _rationals(mechanism.matrix)
    k = mechanism.rr.k
    rows = rr_exact_rows(k, mechanism.rr.epsilon, end)
    if rows is None:
        return None
    out = np.full((k, k), rows[1], dtype=object)
    np.fill_diagonal(out, rows[0])
    return out


@dataclass(frozen=True, eq=False)
class _End:
    """The programs at one end of e^ε: the coefficients' factors and the polytope, a product of blocks (one per
    released context when M_X is the identity, whose rows and floors are each context's own; else one), phase 1 run
    once per block."""

    MA: ObjectArray  # (n_groups, n_released_groups)
    MX: ObjectArray  # (n_contexts, n_released_contexts)
    g: ObjectArray  # (n_contexts, n_groups, n_decisions)
    u_only: bool
    blocks: list[Polytope]
    width: int  # the variables of a block

    def coef(self, x: int, b: int) -> ObjectArray:
        """The coefficients of E[g | x, b] in the program's variables, laid out as the float program's."""
        return _coefficients(self.MA, self.MX, self.g, self.u_only, x, b)

    def split(self, v: ObjectArray) -> list[list[Fraction]]:
        """A vector over the program's variables as the blocks' parts."""
        return [list(v[i * self.width : (i + 1) * self.width]) for i in range(len(self.blocks))]


def _coefficients(MA: ObjectArray, MX: ObjectArray, g: ObjectArray, u_only: bool, x: int, b: int) -> ObjectArray:
    """The coefficients of E[g | x, b], exactly: the product of :func:`coefficient_factors`."""
    return functools.reduce(operator.mul, coefficient_factors(MA, MX, g, u_only, x, b)).ravel()


MAX_BLOCKS = 256
"""The most blocks (released contexts behind the identity) an exact program is solved over."""


class ExactPrograms:
    """The pair search's programs in exact rationals, at each end of e^ε (one end without randomized response).

    Parameters
    ----------
    problem : ModelProblem
    u_only : bool
        The programs are in G-space (g depends on the decision only: variables G[x̃, ã] ∈ [min g, max g]); else in
        kernel space (K[x̃, ã, u] ∈ [0, 1], each row summing to 1).
    floors : bool
        Whether the programs have the rows E[g | x, a] ≥ τ (every live context and group), as the float ones do.
    """

    def __init__(self, problem: ModelProblem, u_only: bool, floors: bool) -> None:
        self._problem, self._u_only, self._floors = problem, u_only, floors
        nXr, nAr = problem.n_released_contexts, problem.n_released_groups
        nU = problem.g.shape[2]
        contexts = 1 if problem.same_x else nXr  # the released contexts of a block
        floor_rows = (1 if problem.same_x else int(np.count_nonzero(problem.live))) * problem.g.shape[1]
        n = contexts * nAr * (1 if u_only else nU)
        rows = (0 if u_only else 2 * contexts * nAr) + (floor_rows if floors else 0)
        self._size = (n, rows, nXr if problem.same_x else 1)

    @functools.cached_property
    def _ends(self) -> list[_End] | None:
        """The programs at each end of e^ε (built at the first exact solve); None where an end has no rows."""
        problem = self._problem
        two = any(isinstance(m, RandomizedResponse) and not m.is_identity
                  for m in (problem.mechanism, problem.context_mechanism))  # fmt: skip
        ends = []
        for end in (0, 1) if two else (1,):
            MA, MX = _rows(problem.mechanism, end), _rows(problem.context_mechanism, end)
            if MA is None or MX is None:
                return None
            ends.append(self._end(MA, MX))
        return ends

    def _end(self, MA: ObjectArray, MX: ObjectArray) -> _End:
        problem = self._problem
        g = _rationals(problem.g)
        live = problem.live
        tau = Fraction(problem.tau or 0.0)
        nA, nU, nAr = g.shape[1], g.shape[2], MA.shape[1]
        per_cell = 1 if self._u_only else nU
        groups = [list(range(MX.shape[1]))] if not problem.same_x else [[j] for j in range(MX.shape[1])]
        width = len(groups[0]) * nAr * per_cell
        if self._u_only:
            row = g[np.flatnonzero(live)[0], 0] if live.any() else g[0, 0]
            lower, upper = [min(row)] * width, [max(row)] * width
        else:
            lower, upper = [Fraction(0)] * width, [Fraction(1)] * width
        sums: list[list[Fraction]] = []  # Σ_u K[x̃, ã, u] = 1 as two rows a cell, the same in every block
        for c in range(0 if self._u_only else width // nU):
            ones = [Fraction(int(c * nU <= j < (c + 1) * nU)) for j in range(width)]
            sums += [ones, [-v for v in ones]]
        blocks = []
        for i, released in enumerate(groups):
            # −E[g | x, b] ≤ −τ for the live contexts whose rows the block holds (all of them in one block)
            xs = [x for x in (released if problem.same_x else range(g.shape[0])) if live[x]] if self._floors else []
            floors = [
                [-v for v in _coefficients(MA, MX, g, self._u_only, x, b)[i * width : (i + 1) * width]]
                for x, b in itertools.product(xs, range(nA))
            ]
            b_ub = [Fraction(1), Fraction(-1)] * (len(sums) // 2) + [-tau] * len(floors)
            blocks.append(Polytope(lower, upper, sums + floors, b_ub, width))
        return _End(MA, MX, g, self._u_only, blocks, width)

    def _floor_multipliers(self, end: _End, y: tuple[Fraction, ...]) -> tuple[Fraction, ...]:
        """The multipliers of the floors E[g | x, b] ≥ τ among the blocks' rows (each block's rows in turn),
        laid out as the float program's floor rows: (live context, group), flat."""
        problem = self._problem
        live, n_a = np.flatnonzero(problem.live).tolist(), problem.g.shape[1]
        cells = 0 if self._u_only else 2 * (end.width // problem.g.shape[2])
        out = dict.fromkeys(((x, b) for x in live for b in range(n_a)), Fraction(0))
        start = 0
        for i in range(len(end.blocks)):
            xs = [x for x in ([i] if problem.same_x else range(problem.g.shape[0])) if problem.live[x]]
            start += cells
            for x, b in itertools.product(xs, range(n_a)):
                out[(x, b)] = y[start]
                start += 1
        return tuple(out.values())

    def local(self, x: int, a: int, b: int) -> Callable[[_End], tuple[ObjectArray, ObjectArray]]:
        """The data of L's program at context x for the ordered pair (a, b), at an end."""
        return lambda end: (end.coef(x, a), end.coef(x, b))

    def global_(self, a: int, b: int) -> Callable[[_End], tuple[ObjectArray, ObjectArray]]:
        """The data of L̄'s program for the ordered pair (a, b), at an end: E[g | a] = Σ_x P(x | a) E[g | x, a]."""
        joint = _rationals(self._problem.population.probabilities)
        live = np.flatnonzero(self._problem.live)

        def weighted(end: _End, c: int) -> ObjectArray:
            xs = [int(x) for x in live if joint[x, c]]
            mass = sum((joint[x, c] for x in xs), Fraction(0))
            return functools.reduce(operator.add, [joint[x, c] / mass * end.coef(x, c) for x in xs])

        return lambda end: (weighted(end, a), weighted(end, b))

    def solve(
        self, data: Callable[[_End], tuple[ObjectArray, ObjectArray]], rounded: FractionalResult
    ) -> FractionalResult | None:
        """The program exactly, in place of ``rounded`` (its float form's result), over the product of the blocks
        (:func:`~fairaudit.base.exact_ratio.maximize_ratio_over_product`: a block without objective only has to
        be feasible). None where a block is beyond :data:`CROSSOVER_SIZE` or there are
        more than :data:`MAX_BLOCKS`, where randomized response's e^ε has no finite float end, or where the exact solve
        gives no finite maximum and no proof of +inf. The value is the maximum at the upper end rounded up, the
        witness the one at the lower end rounded down."""
        limit = CROSSOVER_SIZE  # (read at each call: the tests shrink it)
        if self._size[0] > limit[0] or self._size[1] > limit[1] or self._size[2] > MAX_BLOCKS:
            return None
        ends = self._ends
        if ends is None:
            return None
        status = f"{rounded.solver_status}; {EXACT_CROSSOVER} (exact: {WHY})"
        result = functools.partial(FractionalResult, method="lp", solver_status=status)

        def optimum(end: _End) -> tuple[RatioOptimum, list[Fraction], list[Fraction]]:
            p, q = data(end)
            return maximize_ratio_over_product(end.blocks, end.split(p), end.split(q)), list(p), list(q)

        high, p, q = optimum(ends[-1])
        found = exact_result(result, high, p, q)
        if found is not None and found.status == "optimal" and high.multipliers is not None and self._floors:
            found = replace(found, exact_dual=(self._floor_multipliers(ends[-1], high.multipliers),))
        if found is None or len(ends) == 1 or found.status != "optimal":
            return found
        low = optimum(ends[0])[0]
        witness = fraction_down(low.value) if low.status == "optimal" and low.value is not None else math.nan
        return replace(found, witness=witness, gap=gap_between(found.value, witness))
