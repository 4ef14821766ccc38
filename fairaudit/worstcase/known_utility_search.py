"""The known-utility certificate by the pair search: linear-fractional programs over the decision models.

:func:`local_search` (L, one program per live context and ordered pair) and :func:`global_search` (L̄, one per
ordered pair; E[g | a] = Σ_x P(x | a) E[g | x, a] is linear in the kernel too) maximise over the polytope of
reachable kernels, in G-space G[x̃, ã] = Σ_u K[x̃, ã, u] g(u) when g depends on the decision only, in kernel space
otherwise; programs are solved in decreasing order of valid upper bounds (the box values, γ/τ, the closed-form
relaxation) and the Charnes–Cooper LP runs only where the relaxation does not decide. ``proofs/black_box.md`` §6.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, SupportsIndex

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import BoolArray, FloatArray, IntArray
from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label
from fairaudit.base.linear_fractional import FractionalProgram, FractionalResult
from fairaudit.worstcase.known_utility_problem import ModelProblem
from fairaudit.worstcase.pair_search import SearchResult, pairwise_box, relaxed_first, search
from fairaudit.worstcase.worst_cases import WorstCase


def local_search(
    problem: ModelProblem,
    MA: FloatArray,
    pairs: IntArray,
    boxes: tuple[FloatArray, IntArray, FloatArray] | None,
) -> WorstCase:
    """max L by the search over (context, pair) programs, in decreasing order of their upper bounds."""
    g, live, tau, floor = problem.g, problem.live, problem.tau, problem.floor
    nA = g.shape[1]
    space = _model_program(MA, problem.context_mechanism.matrix, g, live, tau, problem.decision_only, problem.binding)
    xs = np.flatnonzero(live)
    pairs = np.asarray(pairs).reshape(-1, 2)
    triples = np.column_stack([np.repeat(xs, len(pairs)), np.tile(pairs, (len(xs), 1))])  # (x, a, b), x-major
    if problem.group_free:
        assert boxes is not None  # (computed for g free of the group)
        _, range_of, box_by_range = boxes
        upper = box_by_range[range_of[triples[:, 0]], triples[:, 1], triples[:, 2]]
    else:
        upper = np.full(len(triples), np.inf)
    if tau is not None and tau > 0:
        upper = np.minimum(upper, g[triples[:, 0], triples[:, 1]].max(-1) / tau)
    num = lambda i: space.coef(triples[i, 0], triples[i, 1])  # noqa: E731
    den = lambda i: space.coef(triples[i, 0], triples[i, 2])  # noqa: E731
    if not problem.group_free:
        gmax_xa, gmin_xa = g.max(-1), g.min(-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            crude = np.where(
                gmin_xa[triples[:, 0], triples[:, 2]] > 0,
                gmax_xa[triples[:, 0], triples[:, 1]] / gmin_xa[triples[:, 0], triples[:, 2]],
                np.inf,
            )
        upper = np.minimum(upper, crude)
    if space.lo is not None and space.hi is not None and problem.method != "lp" and space.rows is not None:
        # closed-form relaxation (only the denominator's τ; τ rows: floor = τ): an upper bound per triple
        for context in xs:
            P = np.stack([space.coef(context, a) for a in range(nA)])
            v = pairwise_box(P, space.lo, space.hi, floor)[1]
            assert v is not None  # (a floor was given)
            at = triples[:, 0] == context
            upper[at] = np.minimum(upper[at], v[triples[at, 1], triples[at, 2]])
    return _model_case(problem, "local", search(upper, _solver(problem, space, num, den)), triples, space.to_kernel)


def global_search(problem: ModelProblem, MA: FloatArray, pairs: IntArray) -> WorstCase:
    """max L̄ by the search over pair programs (E[g | a] = Σ_x P(x | a) E[g | x, a] is linear in the kernel too)."""
    g, live, tau, floor, groups = problem.g, problem.live, problem.tau, problem.floor, problem.groups
    nA = g.shape[1]
    p_context_given_group = np.nan_to_num(problem.population.context_given_group(), nan=0.0)  # P(x | a), (nX, nA)
    space = _model_program(MA, problem.context_mechanism.matrix, g, live, tau, problem.decision_only, problem.binding)

    def coef_global(a: int) -> FloatArray:
        terms = [
            p_context_given_group[x, a] * space.coef(x, a)
            for x in np.flatnonzero(live & (p_context_given_group[:, a] > 0))
        ]
        if not terms:
            raise InputError(
                "population",
                f"group {format_label(groups[a])!r} has P(A = a) = 0: the worst model for L-bar needs "
                "every group to have positive probability",
            )
        return functools.reduce(operator.add, terms)

    upper = np.full(len(pairs), np.inf)
    if tau is not None and tau > 0:
        upper = np.minimum(upper, problem.gmax.max() / tau)
    num = lambda i: coef_global(pairs[i, 0])  # noqa: E731
    den = lambda i: coef_global(pairs[i, 1])  # noqa: E731
    if space.lo is not None and space.hi is not None and problem.method != "lp":
        P = np.stack([coef_global(a) for a in range(nA)])
        if space.rows is not None:  # (τ rows: floor = τ)
            v = pairwise_box(P, space.lo, space.hi, floor)[1]
        else:
            v = pairwise_box(P, space.lo, space.hi, None)[0]
        assert v is not None  # (a floor was given)
        upper = np.minimum(upper, v[pairs[:, 0], pairs[:, 1]])
    global_triples = np.column_stack([np.full(len(pairs), -1), pairs])
    found = search(upper, _solver(problem, space, num, den))
    return _model_case(problem, "global", found, global_triples, space.to_kernel)


def _solver(
    problem: ModelProblem,
    space: _ModelSpace,
    num: Callable[[int], FloatArray],
    den: Callable[[int], FloatArray],
) -> Callable[[int], FractionalResult]:
    """Solve program i: in G-space the closed-form relaxation first (unless the LP is asked for), else the LP."""
    if space.lo is not None and space.hi is not None and problem.method != "lp":
        tau = None if space.rows is None else problem.tau
        return relaxed_first(num, den, space.lo, space.hi, tau, space.rows, space.program)

    def solve(i: int) -> FractionalResult:
        return space.program().solve(num(i), den(i))

    return solve


@dataclass(frozen=True, eq=False, kw_only=True)
class _ModelSpace:
    """The polytope of reachable kernels in G-space (g depends on u only) or kernel space."""

    coef: Callable[[SupportsIndex, SupportsIndex], FloatArray]  # (x, b) -> coefficients of E[g | x, b]
    to_kernel: Callable[[FloatArray], FloatArray]
    program: Callable[[], FractionalProgram]  # built on first use
    lo: float | None  # box of the variables (G-space only)
    hi: float | None
    rows: npt.NDArray[np.floating[Any]] | None  # τ rows (G-space only): rows @ h >= τ


def _model_program(
    MA: FloatArray, MX: FloatArray, g: FloatArray, live: BoolArray, tau: float | None, u_only: bool, with_tau: bool
) -> _ModelSpace:
    import scipy.sparse as sp

    nX, nA, nU = g.shape
    nXr, nAr = MX.shape[1], MA.shape[1]
    xs = np.flatnonzero(live)
    cache: list[FractionalProgram] = []

    def lazy(build: Callable[[], FractionalProgram]) -> Callable[[], FractionalProgram]:
        def program() -> FractionalProgram:
            if not cache:
                cache.append(build())
            return cache[0]

        return program

    if u_only:
        g_row = g[xs[0], 0] if xs.size else g[0, 0]
        lo, hi = float(g_row.min()), float(g_row.max())
        hi_u, lo_u = int(g_row.argmax()), int(g_row.argmin())

        def coef_g(x: SupportsIndex, b: SupportsIndex) -> FloatArray:
            return np.outer(MX[x], MA[b]).ravel()

        def g_to_kernel(G: FloatArray) -> FloatArray:
            G = G.reshape(nXr, nAr)
            high = np.clip((G - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.ones_like(G)
            table = np.zeros((nXr, nAr, nU))
            table[..., hi_u] += high
            table[..., lo_u] += 1.0 - high
            return table

        rows = np.kron(MX[xs], MA) if with_tau and tau is not None and tau > lo else None
        b_rows = None if rows is None or tau is None else np.full(rows.shape[0], -tau)
        return _ModelSpace(
            coef=coef_g,
            to_kernel=g_to_kernel,
            program=lazy(
                lambda: FractionalProgram(
                    nXr * nAr,
                    lower=lo,
                    upper=hi,
                    A_ub=None if rows is None else -rows,
                    b_ub=b_rows,
                )
            ),
            lo=lo,
            hi=hi,
            rows=rows,
        )

    def coef(x: SupportsIndex, b: SupportsIndex) -> FloatArray:
        return (MX[x][:, None, None] * MA[b][None, :, None] * g[x, b][None, None, :]).ravel()

    def to_kernel(K: FloatArray) -> FloatArray:
        return K.reshape(nXr, nAr, nU)

    def build() -> FractionalProgram:
        a_eq = sp.kron(sp.identity(nXr * nAr, format="csr"), np.ones((1, nU)), format="csr")
        a_ub = b_ub = None
        if with_tau and tau is not None and tau > 0:
            a_ub = -np.stack([coef(x, b) for x in xs for b in range(nA)])
            b_ub = np.full(a_ub.shape[0], -tau)
        return FractionalProgram(
            nXr * nAr * nU, lower=0.0, upper=1.0, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=np.ones(nXr * nAr)
        )

    return _ModelSpace(coef=coef, to_kernel=to_kernel, program=lazy(build), lo=None, hi=None, rows=None)


def _model_case(
    problem: ModelProblem,
    kind: str,
    found: SearchResult,
    triples: IntArray,
    to_kernel: Callable[[FloatArray], FloatArray],
) -> WorstCase:
    """The worst case of a search over (context, pair) programs; ``triples[i]`` = (x, a, b) of program i."""
    r = found.result
    if found.index < 0:
        reason = found.reason or "the constraints are inconsistent"
        return WorstCase.unmet(kind, found, "no decision model meets E[g | x, a] >= tau in every cell: " + reason)
    assert r is not None  # a maximiser was found
    x, a, b = triples[found.index]
    kern = problem.kernel(to_kernel(r.argmax)) if r.argmax is not None else None
    return WorstCase.searched(
        kind,
        found,
        context=problem.contexts[x] if kind == "local" else None,
        group=problem.groups[a],
        other_group=problem.groups[b],
        kernel=kern,
        expected_utility=problem.audit(kern, kind) if kern is not None else None,
    )
