"""The known-utility certificate by the pair search: linear-fractional programs over the decision models.

:func:`local_search` (L, one program per live context and ordered pair) and :func:`global_search` (L̄, one per
ordered pair; E[g | a] = Σ_x P(x | a) E[g | x, a] is linear in the kernel too) maximise over the polytope of
reachable kernels, in G-space G[x̃, ã] = Σ_u K[x̃, ã, u] g(u) when g depends on the decision only, in kernel space
otherwise; programs are solved in decreasing order of valid upper bounds (the box values, γ/τ, the closed-form
relaxation) and the Charnes–Cooper LP runs only where the relaxation does not decide. ``proofs/black_box.md`` §6.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Callable
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any, SupportsIndex

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import BoolArray, FloatArray, IntArray
from fairaudit.base.linear_fractional import CROSSOVER_TOLERANCE, FractionalProgram, FractionalResult
from fairaudit.base.outward import (
    down,
    fraction_up,
    gap_between,
    product_ends,
    product_roundings,
    rounding_error,
    up,
    widen_up,
)
from fairaudit.base.table_relaxation import relaxation_bounds
from fairaudit.worstcase.known_utility_exact import ExactPrograms
from fairaudit.worstcase.known_utility_problem import ModelProblem, coefficient_factors
from fairaudit.worstcase.pair_search import (
    STOP,
    TIE,
    InnerProgram,
    SearchResult,
    inner_witness,
    pairwise_box,
    relaxed_first,
    search,
)
from fairaudit.worstcase.worst_cases import ProgramDual, WorstCase


def local_search(
    problem: ModelProblem,
    MA: FloatArray,
    pairs: IntArray,
    boxes: tuple[FloatArray, IntArray, FloatArray] | None,
) -> WorstCase:
    """max L by the search over (context, pair) programs, in decreasing order of their upper bounds."""
    g, live, tau, floor = problem.g, problem.live, problem.tau, problem.floor
    nA = g.shape[1]
    space = _problem_space(problem, MA)
    xs = np.flatnonzero(live)
    pairs = np.asarray(pairs).reshape(-1, 2)
    triples = np.column_stack([np.repeat(xs, len(pairs)), np.tile(pairs, (len(xs), 1))])  # (x, a, b), x-major
    x, a, b = triples.T
    if problem.group_free:
        assert boxes is not None  # (computed for g free of the group)
        _, range_of, box_by_range = boxes
        upper = box_by_range[range_of[x], a, b]
    else:
        upper = np.full(len(triples), np.inf)
    reach_hi, reach_lo = problem.reach
    closed = np.full(len(triples), np.inf)  # the closed-form bounds, each rounded up from E[g | x, a]'s bounds
    if tau is not None and tau > 0:
        closed = up(reach_hi[x, a] / tau)
    coefficients = [[_Coefficients.of(space, c, d) for d in range(nA)] if live[c] else [] for c in range(g.shape[0])]

    def pair(i: int) -> tuple[_Coefficients, _Coefficients]:
        return coefficients[x[i]][a[i]], coefficients[x[i]][b[i]]

    if not problem.group_free:
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            closed = np.minimum(closed, np.where(reach_lo[x, b] > 0, up(reach_hi[x, a] / reach_lo[x, b]), np.inf))
    upper = np.minimum(upper, closed)
    inexact = max((c.roundings for row in coefficients for c in row), default=0)
    screens = np.full(len(triples), np.nan)  # each program's one-floor threshold θ, for the certificate
    relaxed = np.full(len(triples), np.inf)
    for context in xs:
        P = np.stack([c.value for c in coefficients[context]])
        at = x == context
        if space.lo is not None and space.hi is not None and problem.method != "lp" and space.rows is not None:
            # closed-form relaxation (only the denominator's τ; τ rows: floor = τ): an upper bound per triple
            upper[at] = np.minimum(upper[at], _relaxation(P, space.lo, space.hi, floor, inexact)[a[at], b[at]])
        # every program's proof over the model's table, which verify checks: its one-floor threshold θ
        v, theta = _table_relaxation(*_as_table(P, space, g), tau, inexact + (space.lo is not None))
        relaxed[at], screens[at] = v[a[at], b[at]], theta[a[at], b[at]]
    screens = _screens(screens, relaxed, tau, reach_hi[x, a])
    if space.lo is None and problem.method != "lp":  # over the model's table: its one-floor relaxation, exactly
        upper = _lowered(upper, relaxed)
    return _searched(_Batch(problem, "local", triples, space, pair, inexact), upper, closed, screens)


def global_search(problem: ModelProblem, MA: FloatArray, pairs: IntArray) -> WorstCase:
    """max L̄ by the search over pair programs (E[g | a] = Σ_x P(x | a) E[g | x, a] is linear in the kernel too)."""
    g, live, tau, floor = problem.g, problem.live, problem.tau, problem.floor
    p_context_given_group = np.nan_to_num(problem.population.context_given_group(), nan=0.0)  # P(x | a), (nX, nA)
    space = _problem_space(problem, MA)

    def coef_global(a: int) -> _Coefficients:
        xs = np.flatnonzero(live & (p_context_given_group[:, a] > 0))
        assert xs.size  # (a group of the pairs has P(A = a) > 0: some live context meets it)
        single = np.count_nonzero(problem.population.probabilities[:, a]) == 1  # P(x | a) = 1 exactly
        return _Coefficients.weighted(space, xs, a, p_context_given_group[xs, a], single)

    # the groups of the pairs (L-bar compares the groups with P(A = a) > 0 only: the caller's pairs), in order
    present = np.unique(pairs)
    a, b = np.searchsorted(present, pairs).T  # (each pair's rows of P: its groups' places among them)
    coefficients = [coef_global(int(c)) for c in present]
    closed = np.full(len(pairs), np.inf)
    if tau is not None and tau > 0:
        # E[g | a] ≤ Σ_x P(x | a) E[g | x, a] ≤ the largest of its terms, over E[g | a'] ≥ τ (E[g | x, a] at most
        # ModelProblem.reach); P(x | a) carries 2 n_x roundings, the products and the sum n_x + 1 more
        top = problem.reach[0]
        average = (p_context_given_group * top).sum(axis=0)
        largest = np.where(problem.population.probabilities > 0, top, 0.0).max(axis=0)
        reach = np.minimum(largest, np.asarray(widen_up(average, rounding_error(3 * g.shape[0] + 1))))
        closed = up(reach[pairs[:, 0]] / tau)
    upper = closed.copy()

    def pair(i: int) -> tuple[_Coefficients, _Coefficients]:
        return coefficients[a[i]], coefficients[b[i]]

    inexact = max(c.roundings for c in coefficients)
    P = np.stack([c.value for c in coefficients])
    if space.lo is not None and space.hi is not None and problem.method != "lp":
        v = _relaxation(P, space.lo, space.hi, floor if space.rows is not None else None, inexact)
        upper = np.minimum(upper, v[a, b])
    # every program's proof over the model's table (as local_search)
    v, theta = _table_relaxation(*_as_table(P, space, g), tau, inexact + (space.lo is not None))
    relaxed = v[a, b]
    screens = _screens(theta[a, b], relaxed, tau, reach[pairs[:, 0]]) if tau else np.full(len(pairs), np.nan)
    if space.lo is None and problem.method != "lp":  # (E[g | a'] ≥ τ: P(x | a') sums to 1)
        upper = _lowered(upper, relaxed)
    global_triples = np.column_stack([np.full(len(pairs), -1), pairs])
    return _searched(_Batch(problem, "global", global_triples, space, pair, inexact), upper, closed, screens)


@dataclass(frozen=True, eq=False)
class _Batch:
    """The programs of one search: ``triples[i]`` = (x, a, b) of program i (x = -1 for L̄) over ``space``, and ``pair(i)``,
    the coefficients of its numerator and denominator, each entry computed with at most ``inexact`` roundings."""

    problem: ModelProblem
    kind: str
    triples: IntArray
    space: _ModelSpace
    pair: Callable[[int], tuple[_Coefficients, _Coefficients]]
    inexact: int


def _searched(batch: _Batch, upper: FloatArray, closed: FloatArray, screens: FloatArray) -> WorstCase:
    """The search over the programs ``batch.triples[i]`` = (x, a, b), in decreasing order of ``upper``; each solved by
    :func:`_solver`, exactly where its rounded form does not settle it, its proofs kept in :class:`_Evidence` (none
    without floors: no ν to keep)."""
    exact_programs = ExactPrograms(batch.problem, batch.space.lo is not None, batch.space.floors)

    def exact(i: int, rounded: FractionalResult) -> FractionalResult | None:
        x, a, b = (int(v) for v in batch.triples[i])
        data = exact_programs.local(x, a, b) if batch.kind == "local" else exact_programs.global_(a, b)
        return exact_programs.solve(data, rounded)

    evidence = _Evidence(batch, screens) if batch.space.floors else None
    return _model_case(batch, search(upper, _solver(batch, exact, evidence, closed)), evidence)


def _relaxation(P: FloatArray, lo: float, hi: float, floor: float | None, roundings: int) -> FloatArray:
    """Upper bounds on every pair's program from the box (or its floor relaxation) of the computed coefficients.

    With coefficients that carry k roundings, P ≤ (1 + γ)P̂ and P ≥ (1 − γ)P̂ entrywise (γ = ``rounding_error(k)``): the
    exact ratio is at most (1 + γ)/(1 − γ) ≤ 1 + 3γ times the computed one, and a point with P[b]·h ≥ τ has
    P̂[b]·h ≥ (1 − γ)τ, the floor the relaxation keeps.
    """
    box, relaxed = pairwise_box(P, lo, hi, None if floor is None else _kept_floor(floor, roundings))
    return _widened(box if relaxed is None else relaxed, roundings)


def _kept_floor(floor: float, roundings: int) -> float:
    """The floor a relaxation on coefficients computed with ``roundings`` roundings keeps: (1 − γ)·``floor`` rounded
    down, γ = ``rounding_error(roundings)`` (P̂[b]·h ≥ (1 − γ)τ where P[b]·h ≥ τ); ``floor`` itself when exact."""
    return float(down(floor * (1 - float(rounding_error(roundings))))) if roundings else floor


def _widened(v: FloatArray, roundings: int) -> FloatArray:
    """Upper bounds ``v`` on the computed coefficients' ratios widened to the exact ones': times 1 + 3γ (the ratio's
    error (1 + γ)/(1 − γ) ≤ 1 + 3γ, γ = ``rounding_error(roundings)``), rounded up; ``v`` itself when exact."""
    return np.asarray(widen_up(v, 3 * float(rounding_error(roundings)))) if roundings else v


def _as_table(P: FloatArray, space: _ModelSpace, g: FloatArray) -> tuple[FloatArray, int]:
    """The coefficients ``P`` (one row per group) over the model's table's cells, and the decisions per row: in
    G-space each variable h in [lo, hi] is a row of two "decisions", h = lo and h = hi (P·lo, P·hi; one more
    rounding, which the caller counts in :func:`_table_relaxation`'s widening)."""
    if space.lo is None or space.hi is None:
        return P, g.shape[-1]
    return np.stack([P * space.lo, P * space.hi], axis=-1).reshape(len(P), -1), 2


def _table_relaxation(P: FloatArray, n_u: int, tau: float | None, roundings: int) -> tuple[FloatArray, FloatArray]:
    """Upper bounds on every pair's program over the model's table, indexed [a, b] (rows of ``P``, the computed
    coefficients of E[g | x, a] or E[g | a] over the table's cells, decision fastest): the one-floor relaxation's
    (the denominator's E ≥ τ, which every table meeting the floors keeps), exactly
    (:func:`~fairaudit.base.table_relaxation.relaxation_bounds`) on the computed coefficients, then widened as
    :func:`_relaxation`'s for their roundings (the floor kept is (1 − γ)τ, rounded down); and the threshold θ that
    proves each (to nearest; NaN without a floor), which the certificate records (``screens``)."""
    t = None if not tau else Fraction(_kept_floor(tau, roundings))
    forms = {a: [[Fraction(v) for v in row] for row in P[a].reshape(-1, n_u).tolist()] for a in range(len(P))}
    v, theta = np.full((len(P), len(P)), np.inf), np.full((len(P), len(P)), np.nan)
    for (a, b), (bound, at) in relaxation_bounds(forms, dict.fromkeys(forms, t)).items():
        v[a, b] = fraction_up(bound) if bound != math.inf else np.inf
        theta[a, b] = np.nan if at is None else float(at)
    return _widened(v, roundings), theta


def _lowered(upper: FloatArray, relaxed: FloatArray) -> FloatArray:
    """``upper`` lowered to the relaxations' bounds, except at the programs whose bound is within the search's
    :data:`~fairaudit.worstcase.pair_search.STOP` of the largest: those keep theirs and are solved, so that a tie at
    the top is the LP's certified value, not a bound a few ulps above it."""
    near = relaxed >= relaxed.max(initial=-np.inf) * (1 - STOP)
    return np.where(near, upper, np.minimum(upper, relaxed))


def _screens(theta: FloatArray, relaxed: FloatArray, tau: float | None, reach: FloatArray) -> FloatArray:
    """Each program's threshold θ for the certificate: the relaxation's, or 0 where the bound E[g | numerator] ≤
    ``reach`` over the floor τ is smaller (θ = 0 proves R(0)/τ, the largest numerator over τ); NaN without τ."""
    if not tau:
        return np.full(len(theta), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isnan(theta) | (up(reach / tau) < relaxed), 0.0, theta)


def _solver(
    batch: _Batch,
    exact: Callable[[int, FractionalResult], FractionalResult | None],
    evidence: _Evidence | None,
    closed: FloatArray,
) -> Callable[[int], FractionalResult]:
    """Solve program i: in G-space the closed-form relaxation first (unless the LP is asked for), else the LP; its
    dual is kept in ``evidence`` (the certificate's, :class:`_Evidence`).

    Its value is certified on the outer coefficients (numerator rounded up, denominator and τ rows down, then up:
    ``_Coefficients``), which contain the exact program; where they are not exact its witness is the ratio at the
    maximiser with the inner ones (numerator down, denominator up) and the τ rows rounded down, a lower end. Where
    the witness does not meet the value (within :data:`CROSSOVER_TOLERANCE`), or the outer program has no finite
    maximum, ``exact(i, result)`` solves the program on exact coefficients
    (:class:`~fairaudit.worstcase.known_utility_exact.ExactPrograms`, whose exact multipliers the certificate records;
    None beyond its size). A certified value above
    ``closed[i]``, program i's closed-form bound (E[g | x, a]'s largest over τ or over E[g | x, a']'s smallest, rounded
    up), is lowered to it: both hold, and where the denominator's floor binds the bound is the optimum while the
    solver's dual, beyond the exact size, can leave its value 1e-10 above it.

    The solve returned serves one :func:`~fairaudit.worstcase.pair_search.search`, which takes the programs in turn;
    it follows the search's maximiser by the search's own tie rule (:data:`~fairaudit.worstcase.pair_search.TIE`).
    Each LP starts at ``below`` = the largest value found so far, widened by :data:`CROSSOVER_TOLERANCE`. A program
    whose value comes back certified within that tolerance of ``below`` (HiGHS's duals, checked exactly, prove it at
    once) and no higher than the search's maximiser allows is left there: it cannot become the maximiser, so its
    witness is never read; its value, which the search may take as the largest found, lies within twice that
    tolerance of a value whose witness is checked, and it does not raise the largest value found (no drift). Its
    witness is then NaN where the coefficients are not exact (the solver's is on the outer ones). 18 groups behind a
    product of randomized responses, near ties at 1/τ: all but a few of about 250 programs so.
    """
    problem, space, pair, roundings = batch.problem, batch.space, batch.pair, batch.inexact

    def num(i: int) -> FloatArray:
        return pair(i)[0].high

    def den(i: int) -> FloatArray:
        return pair(i)[1].low

    if space.lo is not None and space.hi is not None and problem.method != "lp":
        tau = None if space.rows is None or problem.tau is None else _kept_floor(problem.tau, roundings)
        inner = relaxed_first(num, den, space.lo, space.hi, tau, space.rows, space.program)
    else:

        def inner(i: int, below: float) -> FractionalResult:
            return space.program().solve(num(i), den(i), below=below)

    best = largest = -math.inf  # (the search's maximiser's value; the largest value of a program not left there)

    def solve(i: int) -> FractionalResult:
        nonlocal best, largest
        below = largest * (1 + CROSSOVER_TOLERANCE)  # (a tie proves itself at once: λ₀ at or above its maximum)
        r = inner(i, below)
        tie = (
            r.status == "optimal"
            and r.certified
            and r.value <= min(below * (1 + CROSSOVER_TOLERANCE), best * (1 + TIE))
        )
        if tie:
            r = replace(r, witness=math.nan, gap=math.nan) if roundings else r  # (left there: see above)
        elif roundings:
            r = inner_witness(r, pair(i)[0].low, pair(i)[1].high, space.inner)  # (numerator down, denominator up)
            settled = (
                r.status == "optimal" and r.certified and r.value - r.witness <= CROSSOVER_TOLERANCE * max(1.0, r.value)
            )
            r = r if settled else (exact(i, r) or r)
        if r.status == "optimal" and r.certified and r.value > closed[i]:
            r = replace(r, value=float(closed[i]), gap=gap_between(float(closed[i]), r.witness))
        if evidence is not None:
            evidence.keep(i, r)
        if not tie and r.status == "optimal" and r.certified:
            largest = max(largest, r.value)
        if best == -math.inf or r.value > best * (1 + TIE):  # (the search's tie rule)
            best = r.value
        return r

    return solve


@dataclass(frozen=True, eq=False)
class _Coefficients:
    """The coefficients of E[g | x, b] (or of E[g | b]) in the program's variables: computed, and enclosed."""

    value: FloatArray  # as computed, to nearest
    low: FloatArray  # ≤ the exact coefficients
    high: FloatArray  # ≥ them
    roundings: int  # the most roundings of an entry (0: exact)

    @classmethod
    def of(cls, space: _ModelSpace, x: int, b: int) -> _Coefficients:
        value, roundings, nonzero = space.cells(x, b)
        return cls(value, *product_ends(value, roundings, nonzero), int(roundings.max(initial=0)))

    @classmethod
    def weighted(cls, space: _ModelSpace, xs: IntArray, b: int, weights: FloatArray, single: bool) -> _Coefficients:
        """Σ_x w_x · coef(x, b): a weight is P(x | b), computed with n_x roundings; the products and the sum add
        one and n_x − 1 more (none when one context has P(x, b) > 0: its weight is exactly 1)."""
        parts = [space.cells(x, b) for x in xs]
        value = functools.reduce(operator.add, [w * v for w, (v, _, _) in zip(weights, parts)])
        roundings = np.max([r for _, r, _ in parts], axis=0)
        if not single:
            roundings = roundings + 2 * space.n_contexts + 1
        nonzero = functools.reduce(operator.or_, [nz for _, _, nz in parts])
        return cls(value, *product_ends(value, roundings, nonzero), int(roundings.max(initial=0)))


@dataclass(frozen=True, eq=False, kw_only=True)
class _ModelSpace:
    """The polytope of reachable kernels in G-space (g depends on u only) or kernel space."""

    # (x, b) -> the coefficients of E[g | x, b], the roundings of each, and whether each is exactly positive
    cells: Callable[[SupportsIndex, SupportsIndex], tuple[FloatArray, IntArray, BoolArray]]
    n_contexts: int
    to_kernel: Callable[[npt.NDArray[Any]], npt.NDArray[Any]]  # (exact for Fractions)
    program: Callable[[], FractionalProgram]  # built on first use, on the τ rows rounded up
    lo: float | None  # box of the variables (G-space only)
    hi: float | None
    rows: npt.NDArray[np.floating[Any]] | None  # τ rows (G-space only): rows @ h >= τ
    inner: InnerProgram  # the variables' bounds and the τ rows rounded down: a point meeting them is feasible
    floors: bool  # whether the program has the τ rows


def _problem_space(problem: ModelProblem, MA: FloatArray) -> _ModelSpace:
    """The polytope of the problem's programs, each product of an entry of M_A or M_X carrying the roundings the
    mechanism's floats carry relative to its exact law (randomized response's, computed from e^ε; a matrix is its own
    law)."""
    import scipy.sparse as sp

    MX, g, live, tau = problem.context_mechanism.matrix, problem.g, problem.live, problem.tau
    u_only = problem.decision_only
    entries = (problem.mechanism.matrix_roundings, problem.context_mechanism.matrix_roundings)
    nX, nA, nU = g.shape
    nXr, nAr = MX.shape[1], MA.shape[1]
    xs = np.flatnonzero(live)
    shape = (nXr, nAr) if u_only else (nXr, nAr, nU)
    width = math.prod(shape)

    def cells(x: SupportsIndex, b: SupportsIndex) -> tuple[FloatArray, IntArray, BoolArray]:
        """The coefficients of E[g | x, b]; the roundings of each (its product's, plus those its entries of M_X and
        M_A carry); whether each is exactly positive."""
        f = coefficient_factors(MA, MX, g, u_only, x, b)
        extra = entries[1] * (f[0] != 0) + entries[0] * (f[1] != 0)
        roundings = np.broadcast_to(product_roundings(*f) + extra, shape).ravel()
        nonzero = functools.reduce(operator.and_, [v != 0 for v in f]).ravel()
        return functools.reduce(operator.mul, f).ravel(), roundings, nonzero

    if u_only:
        g_row = g[xs[0], 0] if xs.size else g[0, 0]
        lo, hi = float(g_row.min()), float(g_row.max())
        hi_u, lo_u = int(g_row.argmax()), int(g_row.argmin())

        def to_kernel(G: npt.NDArray[Any]) -> npt.NDArray[Any]:  # (exactly for an exact G, Fractions)
            G = G.reshape(nXr, nAr)
            low: Any = Fraction(lo) if G.dtype == object else lo
            span: Any = Fraction(hi) - low if G.dtype == object else hi - lo
            high = np.clip((G - low) / span, 0, 1) if hi > lo else np.ones_like(G)
            table = np.zeros((nXr, nAr, nU), dtype=G.dtype)
            table[..., hi_u] += high
            table[..., lo_u] += 1 - high
            return table

        equalities: list[Any] = []
    else:
        lo, hi = 0.0, 1.0

        def to_kernel(G: npt.NDArray[Any]) -> npt.NDArray[Any]:
            return G.reshape(shape)

        a_eq = sp.kron(sp.identity(nXr * nAr, format="csr"), np.ones((1, nU)), format="csr")
        equalities = [(a_eq, np.ones(nXr * nAr), "eq")]
    # the τ rows (G-space: τ above E[g]'s least, ``problem.binding``), rounded up for the program (a relaxation) and
    # down for the witness's constraint
    rows: FloatArray | None = None
    outer: FloatArray | None = None
    below: list[Any] = []
    if problem.binding and tau is not None and (u_only or tau > 0):
        parts = [cells(x, b) for x in xs for b in range(nA)]
        rows, counts, nonzero = (np.array([part[i] for part in parts]).reshape(len(parts), width) for i in range(3))
        low, outer = product_ends(rows, counts, nonzero)
        below = [(-low, np.full(len(rows), -float(tau)), "le")]

    def build() -> FractionalProgram:
        a_ub = None if outer is None else -outer
        b_ub = None if outer is None else np.full(outer.shape[0], -float(tau or 0.0))
        eq = {} if u_only else {"A_eq": equalities[0][0], "b_eq": equalities[0][1]}
        return FractionalProgram(width, lower=lo, upper=hi, A_ub=a_ub, b_ub=b_ub, **eq)

    return _ModelSpace(
        cells=cells,
        n_contexts=nX,
        to_kernel=to_kernel,
        program=functools.cache(build),  # (built once, at the first LP)
        lo=lo if u_only else None,
        hi=hi if u_only else None,
        rows=rows if u_only else None,
        inner=InnerProgram(np.full(width, lo), np.full(width, hi), below + equalities),
        floors=outer is not None,
    )


class _Evidence:
    """The proofs of a search's programs, kept for the certificate, which ``fairaudit verify`` checks over the model's
    table (``proofs/verification.md`` §4f): each program's one-floor threshold θ, and the floors' multipliers ν of the
    programs an LP bounded, where floors bind (without them the LP's rows are the simplex's, whose multipliers are
    no floors' ν). The floors' rows are ordered (live context, group), in G-space and in kernel space alike; L keeps
    its context's only behind the identity on the context (every context's floors bind its rows otherwise).
    None without floors (the bound without them is the value)."""

    def __init__(self, batch: _Batch, screens: FloatArray) -> None:
        self.problem, self.kind, self.triples = batch.problem, batch.kind, batch.triples
        self.live = np.flatnonzero(batch.problem.live)
        self.duals: list[ProgramDual] = []
        self.screens = screens  # each program's one-floor threshold θ (NaN: none)

    def keep(self, i: int, r: FractionalResult) -> None:
        """Program i's dual, when an LP's dual certified its value."""
        n_a = len(self.problem.groups)
        size = self.live.size * n_a
        exact = r.exact_dual is not None and len(r.exact_dual[0]) == size
        if r.method != "lp" or not r.certified or not (exact or (r.dual and r.dual[0].size == size)):
            return
        if exact:  # (the rounded multipliers prove less, or the program was solved exactly: the exact ones)
            assert r.exact_dual is not None
            floors = np.full((len(self.problem.contexts), n_a), Fraction(0), dtype=object)
            floors[self.live] = np.array(r.exact_dual[0], dtype=object).reshape(self.live.size, n_a)
        else:
            floors = np.zeros((len(self.problem.contexts), n_a))
            floors[self.live] = np.maximum(np.asarray(r.dual[0], dtype=float), 0.0).reshape(self.live.size, n_a)
        x, a, b = (int(v) for v in self.triples[i])
        local = self.kind == "local"
        own = local and self.problem.same_x  # (L at x binds the rows of x alone)
        self.duals.append(self.problem.dual(x if local else None, a, b, floors=floors[x] if own else floors))

    def all(self) -> tuple[ProgramDual, ...]:
        """The LP's multipliers kept, then every program's screen threshold θ (verify takes the least bound of the
        two: a value lowered to its closed-form bound, below what the LP's multipliers prove, rests on θ)."""
        local = self.kind == "local"
        screens = [
            self.problem.dual(x if local else None, a, b, theta=float(self.screens[i]))
            for i, (x, a, b) in enumerate(self.triples.tolist())
            if not math.isnan(self.screens[i])
        ]
        return (*self.duals, *screens)


def _model_case(batch: _Batch, found: SearchResult, evidence: _Evidence | None) -> WorstCase:
    """The worst case of a search over (context, pair) programs. The maximiser's point the certificate records
    (``witness_point``) is its basis's vertex on the inner program, exactly, where that attains the witness
    (:func:`_exact_witness`); else the float maximiser, clipped."""
    problem, kind, space = batch.problem, batch.kind, batch.space
    r = found.result
    if found.index < 0:
        reason = found.reason or "the constraints are inconsistent"
        return WorstCase.unmet(kind, found, "no decision model meets E[g | x, a] >= tau in every cell: " + reason)
    assert r is not None  # a maximiser was found
    x, a, b = batch.triples[found.index]
    kern = problem.kernel(space.to_kernel(r.argmax)) if r.argmax is not None else None
    duals = () if evidence is None else evidence.all()
    point: npt.NDArray[Any] | None = None
    if r.argmax is not None and (bool(duals) or space.lo is None):  # (recorded over the model's table: always)
        r, vertex = _exact_witness(r, *batch.pair(found.index), space)
        argmax = np.asarray(r.argmax, dtype=float)
        n_x = len(problem.contexts)
        if not problem.same_x:  # the table over every released context
            point = np.clip(space.to_kernel(argmax), 0.0, 1.0) if vertex is None else space.to_kernel(vertex)
        elif space.lo is not None and space.hi is not None:  # h[x, ã] = E[g | x, released ã]: the variables
            point = (vertex if vertex is not None else np.clip(argmax, space.lo, space.hi)).reshape(n_x, -1)
        else:  # or Σ_u K[x, ã, u] g(u, x)
            cells = (np.clip(argmax, 0.0, 1.0) if vertex is None else vertex).reshape(
                n_x, problem.n_released_groups, -1
            )
            # a utility by group weighs one table differently per group: the table itself is the point
            g = problem.g[:, 0, :] if vertex is None else np.vectorize(Fraction, otypes=[object])(problem.g[:, 0, :])
            point = cells if not problem.group_free else (cells * g[:, None, :]).sum(axis=2)
        if problem.same_x and kind == "local":
            point = point[x]
    return WorstCase.searched(
        kind,
        replace(found, result=r),
        context=problem.contexts[x] if kind == "local" else None,
        group=problem.groups[a],
        other_group=problem.groups[b],
        kernel=kern,
        expected_utility=problem.audit(kern, kind) if kern is not None else None,
        duals=duals,
        witness_point=point,
    )


def _exact_witness(
    r: FractionalResult, num: _Coefficients, den: _Coefficients, space: _ModelSpace
) -> tuple[FractionalResult, npt.NDArray[np.object_] | None]:
    """The maximiser's basis's vertex on the inner program (numerator down, denominator up, τ rows down), exactly,
    where its ratio there is at least the witness: ``r`` with that ratio as its witness, and the vertex (Fractions,
    shape (n,)), which a certificate records so that ``fairaudit verify`` reads the lower end off it, solving
    nothing; else ``r`` and None (``proofs/verification.md`` §4f). A maximiser the closed-form relaxation gave has
    no basis: its program is solved by the LP once for one (the maximiser's only)."""
    if r.status != "optimal" or not r.certified:
        return r, None
    basis = r.basis if r.basis is not None else space.program().solve(num.high, den.low).basis
    if basis is None:
        return r, None
    ratio, h = space.inner.program.vertex_ratio(basis, num.low, den.high)
    if h is None or math.isnan(ratio) or ratio < r.witness:
        return r, None
    witness = ratio if math.isnan(r.witness) else max(ratio, r.witness)
    return replace(r, witness=witness, gap=gap_between(r.value, witness)), np.array(h, dtype=object)
