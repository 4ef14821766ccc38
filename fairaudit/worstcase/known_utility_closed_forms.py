"""The known-utility certificate where no LP is needed: closed forms and the threshold solution.

* Behind k-ary randomized response, for a utility free of the group: :func:`randomized_response_cases`, both
  maxima in closed form (``proofs/black_box.md`` §3 Propositions 3 and 3b per context, §6 Proposition 10), without
  the k x k matrix.
* Behind any mechanism, for a utility free of the group and no binding τ: :func:`local_threshold` and
  :func:`global_threshold` (the box program over the range of g, M_X drops out; for L̄ under X ⊥ A), from the box
  values of :func:`boxes_by_range` (also the upper bounds of the local search).

Each returns the :class:`~fairaudit.worstcase.worst_cases.WorstCase` with its worst kernel; the routes are chosen
by :func:`~fairaudit.worstcase.known_utility.worst_model`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction
from typing import Any

import numpy as np

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.labels import format_label
from fairaudit.base.outward import fraction_down, product_ends
from fairaudit.base.threshold_rule import threshold_max_many
from fairaudit.laws.closed_forms import RandomizedResponseParameters
from fairaudit.laws.tables import Kernel
from fairaudit.worstcase.known_utility_problem import ModelProblem, onehot, weighted_utility
from fairaudit.worstcase.randomized_response import RRWorst, rr_box, rr_theta, rr_witness_point
from fairaudit.worstcase.worst_cases import WorstCase, nats_up


def _threshold_case(
    problem: ModelProblem,
    kind: str,
    ratio: float,
    value: float,
    x: int | None,
    a: int,
    b: int,
    kern: Kernel,
    **fields: Any,
) -> WorstCase:
    """A maximum decided without an LP: ``ratio`` (``value`` nats) at context x (local), pair (a, b), kernel ``kern``;
    ``fields``, its ``solver_status`` and ``reason`` (:meth:`~fairaudit.worstcase.worst_cases.WorstCase.threshold`)."""
    return WorstCase.threshold(
        kind,
        ratio,
        value,
        context=None if x is None else problem.contexts[x],
        group=problem.groups[a],
        other_group=problem.groups[b],
        kernel=kern,
        expected_utility=problem.audit(kern, kind),
        **fields,
    )


# ------------------------------------------------------------------------------ k-ary randomized response
def randomized_response_cases(
    problem: ModelProblem, rr: RandomizedResponseParameters
) -> tuple[WorstCase | None, WorstCase | None]:
    """The local and global maxima behind k-ary randomized response for g free of the group, in closed form.

    Every pair of groups is alike, so one pair decides. None for a maximum that has no closed form here (the
    general route solves it).
    """
    g, live, binding = problem.g, problem.live, problem.binding
    floor = _floor_behind(problem)
    decision_only, same_x, independent = problem.decision_only, problem.same_x, problem.independent
    nU = g.shape[2]
    lo_x, hi_x = g[:, 0, :].min(-1), g[:, 0, :].max(-1)  # the range of g(., x) per context
    over = np.flatnonzero(live & (floor > hi_x))
    if binding and over.size and (decision_only or same_x):
        local = _rr_infeasible(problem, "local", int(over[0]), hi_x)
        global_ = _rr_infeasible(problem, "global", int(over[0]), hi_x) if decision_only and independent else None
        return local, global_
    if binding and not (decision_only or same_x):
        return None, None
    local = _rr_local(problem, rr, lo_x, hi_x, floor)
    # global under X independent of A (Proposition 10 (b); with τ and g(u): H-bar meets every floor)
    if independent and not binding:
        weighted_g, lo_g, hi_g = weighted_box(problem)
        w = rr_box(rr, lo_g, hi_g, -math.inf)
        high, low = onehot(weighted_g.argmax(-1), nU), onehot(weighted_g.argmin(-1), nU)
        return local, _rr_case(problem, "global", w, None, _rr_kernel(problem, w, lo_g, hi_g, None, high, low))
    if independent and decision_only:
        lo, hi = float(lo_x[0]), float(hi_x[0])
        w = rr_box(rr, lo, hi, floor)
        high, low = onehot(g[0, 0].argmax(), nU), onehot(g[0, 0].argmin(), nU)
        kern = _rr_kernel(problem, replace(w, prefix=False), lo, hi, None, high, low)
        case = _rr_case(problem, "global", w, None, kern)
        pair = (problem.groups.index(case.group), problem.groups.index(case.other_group))
        h = rr_witness_point(rr.k, rr.epsilon, lo, hi, floor, *pair) if same_x else None
        point = None if h is None else np.array([h] * len(problem.contexts), dtype=object)
        theta = rr_theta(rr, lo, hi, floor)  # (the one-floor threshold of the pair's program, for the certificate)
        duals = () if theta is None else (problem.dual(None, *pair, theta=theta),)
        return local, replace(case, duals=duals, witness_point=point)
    return local, None


def _rr_local(
    problem: ModelProblem, rr: RandomizedResponseParameters, lo_x: FloatArray, hi_x: FloatArray, floor: float
) -> WorstCase:
    """The local maximum behind k-ary RR: the best context's box (proofs/black_box.md §6, Proposition 10 (a)).

    With a binding τ, §3 Proposition 3b per context, on the floor :func:`_floor_behind` gives. ``lo_x``/``hi_x``: the
    range of g per context.
    """
    live, g = problem.live, problem.g[:, 0, :]
    hot_hi, hot_lo = onehot(g.argmax(-1), g.shape[1]), onehot(g.argmin(-1), g.shape[1])  # per context
    ranges, range_of = np.unique(np.stack([lo_x, hi_x], axis=1), axis=0, return_inverse=True)
    range_of = range_of.ravel()
    candidates = []  # (some context is live)
    for index, (lo, hi) in enumerate(ranges.tolist()):
        at = np.flatnonzero(live & (range_of == index))
        if at.size:
            candidates.append((rr_box(rr, lo, hi, floor), int(at[0])))
    best_w, best_x = max(candidates, key=lambda c: (c[0].value, -c[1]))  # (of equal values, the first context)
    lo, hi = float(lo_x[best_x]), float(hi_x[best_x])
    if not problem.binding:  # the threshold kernel of the maximising context, in every released context
        kern = _rr_kernel(problem, best_w, lo, hi, None, hot_hi[best_x], hot_lo[best_x])
    elif problem.same_x:
        kern = _rr_kernel(problem, best_w, lo, hi, best_x, hot_hi, hot_lo)
    else:  # g(u) behind a context filter: the same h in every released context
        kern = _rr_kernel(problem, replace(best_w, prefix=False), lo, hi, None, hot_hi[0], hot_lo[0])
    case = _rr_case(problem, "local", best_w, best_x, kern)
    # each live context's proof for the pair (0, 1), which stands for every pair (``proofs/verification.md`` §4), and
    # the maximiser's point, exactly, where the floor binds (verify reads the lower end off it)
    thetas = [(x, rr_theta(rr, float(lo_x[x]), float(hi_x[x]), floor)) for x in np.flatnonzero(live).tolist()]
    duals = tuple(problem.dual(x, 0, 1, theta=theta) for x, theta in thetas if theta is not None)
    h = rr_witness_point(rr.k, rr.epsilon, lo, hi, floor) if problem.binding and problem.same_x else None
    return replace(case, duals=duals, witness_point=None if h is None else np.array(h, dtype=object))


def _floor_behind(problem: ModelProblem) -> float:
    """The floor the box programs put on (M_A h)(b), for τ behind a context mechanism whose rows sum to 1 only in
    floats (s_x, the exact sum of M_X's row x, the floats read as rationals, as ``verify`` reads them).

    Any model's h[x̃, ·] mixes, at context x, into h̄_x = Σ_x̃ M_X[x, x̃] h[x̃, ·]/s_x, a point of the box, with
    E[g | x, b] = s_x (M_A h̄_x)(b): the ratio at x is h̄_x's, and the floors E[g | x, b] ≥ τ say (M_A h̄_x)(b) ≥ τ/s_x
    ≥ τ/max s. So the box program on the floor τ/max_x s_x (over the live contexts), rounded down, bounds every
    model; it is τ when the rows sum to 1 exactly (and under the identity).
    """
    if problem.same_x or not math.isfinite(problem.floor) or problem.floor <= 0:
        return problem.floor
    rows = problem.context_mechanism.matrix[problem.live]
    largest = max((sum(map(Fraction, row.tolist()), Fraction(0)) for row in rows), default=Fraction(1))
    return problem.floor if largest == 1 else fraction_down(Fraction(problem.floor) / largest)


def _rr_kernel(
    problem: ModelProblem, w: RRWorst, lo: float, hi: float, x: int | None, high: FloatArray, low: FloatArray
) -> Kernel:
    """The worst kernel behind k-ary RR.

    At context x (every context when None) the mix of the decisions ``high``/``low`` (one-hot rows per released
    context, or one row for all of them) that gives h; every other context all ``high`` (so it meets τ); a threshold
    h as one-hot rows.
    """
    nXr, nAr, nU = problem.n_released_contexts, problem.n_released_groups, problem.g.shape[2]
    high, low = np.broadcast_to(high, (nXr, nU)), np.broadcast_to(low, (nXr, nU))
    h = w.vector(nAr)
    frac = np.clip((h - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.ones(nAr)
    if w.prefix and x is None:
        return _prefix_kernel(problem, w.released(nAr, hi), high, low)
    table = np.zeros((nXr, nAr, nU))
    rows = np.arange(nXr) if x is None else np.array([x])
    table[:] = high[:, None, :]
    table[rows] = frac[None, :, None] * high[rows, None, :] + (1 - frac)[None, :, None] * low[rows, None, :]
    return problem.kernel(table)


def _rr_case(problem: ModelProblem, kind: str, w: RRWorst, x: int | None, kern: Kernel) -> WorstCase:
    """A maximum behind k-ary RR in closed form at context x (local); every pair is alike: the first two groups (for
    L̄, the first two with P(A = a) > 0)."""
    reason = "a released group is possible for one group and impossible for another" if math.isinf(w.value) else ""
    solver_status = "threshold" if w.prefix else "closed form"
    present = [int(i) for i in np.flatnonzero(problem.population.p_group > 0)]
    a, b = present[:2] if kind == "global" and len(present) >= 2 else (0, 1)  # (fewer: worst_model's trivial L-bar)
    return _threshold_case(problem, kind, w.ratio, w.value, x, a, b, kern, solver_status=solver_status, reason=reason)


def _rr_infeasible(problem: ModelProblem, kind: str, x: int, hi_x: FloatArray) -> WorstCase:
    return WorstCase.infeasible(
        kind,
        "closed form",
        "no decision model meets E[g | x, a] >= tau in every cell: "
        f"tau = {problem.tau:g} exceeds max g = {hi_x[x]:g} in context {format_label(problem.contexts[x])!r}",
        0,
    )


# ------------------------------------------------------------------------------ general mechanisms
def boxes_by_range(problem: ModelProblem, MA: FloatArray) -> tuple[FloatArray, IntArray, FloatArray]:
    """The box value of every (x, a, b) for g free of the group: an upper bound always, exact without a binding τ.

    The box depends on x only through [min_u g(u, x), max_u g(u, x)]: solved once per distinct range (one for
    g(u)). Returns the ranges (n_ranges, 2), the range of each context, and the values (n_ranges, nA, nA), so
    that box[x] = values[range_of[x]]; -inf on the diagonal. (Only the local search uses them.)
    """
    g = problem.g
    nX, nA = g.shape[:2]
    if problem.utility.values.ndim == 1:  # (g[x, a] is g(u) in every cell)
        ranges, range_of = np.array([[g[0, 0].min(), g[0, 0].max()]]), np.zeros(nX, dtype=np.intp)
    else:
        ranges, range_of = np.unique(
            np.stack([g[:, 0, :].min(-1), g[:, 0, :].max(-1)], axis=1), axis=0, return_inverse=True
        )
        range_of = range_of.ravel()
    from fairaudit.worstcase.pair_search import pairwise_box  # (not loaded where the closed forms answer)

    # (n_ranges, nA, nA), a block of pairs at a time
    box_by_range = np.stack([pairwise_box(MA, low, high, None)[0] for low, high in ranges.tolist()])
    box_by_range[:, np.arange(nA), np.arange(nA)] = -np.inf
    return ranges, range_of, box_by_range


def local_threshold(problem: ModelProblem, MA: FloatArray, boxes: tuple[FloatArray, IntArray, FloatArray]) -> WorstCase:
    """max L without a binding τ, g free of the group: the best box over live contexts and pairs, its threshold kernel."""
    ranges, range_of, box_by_range = boxes
    g, live = problem.g, problem.live
    nA, nU = g.shape[1:]
    best_by_range = box_by_range.reshape(len(box_by_range), -1).max(axis=1)
    best_by_range[~np.isin(np.arange(len(box_by_range)), range_of[live])] = -np.inf  # ranges of no live context
    x = int(np.argmax(live & (best_by_range[range_of] == best_by_range.max())))  # the first live maximiser
    best_range = range_of[x]
    a, b = np.unravel_index(int(box_by_range[best_range].argmax()), (nA, nA))
    high, low = onehot(g[x, 0].argmax(), nU), onehot(g[x, 0].argmin(), nU)
    kern = _threshold_kernel(problem, MA, int(a), int(b), ranges[best_range, 0], ranges[best_range, 1], high, low)
    r = float(box_by_range[best_range, a, b])
    reason = "a released group is possible for one group and impossible for another" if math.isinf(r) else ""
    return _threshold_case(problem, "local", r, nats_up(r), x, int(a), int(b), kern, reason=reason)


def weighted_box(problem: ModelProblem) -> tuple[FloatArray, float, float]:
    """w[x̃, u] = Σ_x P(x) M_X[x, x̃] g(u, x) and the box [Σ_x̃ min_u w, Σ_x̃ max_u w] of L̄'s fast path, outward.

    The box program's value grows as the box widens (it depends on hi/lo only, ``proofs/black_box.md`` §6): the
    lower end is rounded down and the upper end up by their roundings, P(x) (n_groups − 1), the products (2), the
    sums over x (n_x − 1) and over x̃ (n_x̃ − 1).
    """
    weighted_g = weighted_utility(problem)
    n_x, n_a, _ = problem.g.shape
    k = n_a + n_x + problem.n_released_contexts
    lo_g, hi_g = weighted_g.min(-1).sum(), weighted_g.max(-1).sum()
    return weighted_g, float(product_ends(lo_g, k, lo_g > 0)[0]), float(product_ends(hi_g, k, hi_g > 0)[1])


def global_threshold(problem: ModelProblem, MA: FloatArray) -> WorstCase:
    """max L̄ without a binding τ, g free of the group, X ⊥ A: the box over [Σ min w, Σ max w] and its kernel."""
    nU = problem.g.shape[2]
    weighted_g, lo_g, hi_g = weighted_box(problem)
    # L-bar compares the groups with P(A = a) > 0 only: the pairs of the others are not offered (pairwise_box fills
    # the pairs that cannot be the largest with one upper bound of them all, which an absent pair may set)
    from fairaudit.worstcase.pair_search import pairwise_box

    present = np.flatnonzero(problem.population.p_group > 0)
    vals = pairwise_box(MA[present], lo_g, hi_g, None)[0]
    np.fill_diagonal(vals, -np.inf)
    i, j = np.unravel_index(int(vals.argmax()), vals.shape)
    a, b = int(present[i]), int(present[j])
    high, low = onehot(weighted_g.argmax(-1), nU), onehot(weighted_g.argmin(-1), nU)
    kern = _threshold_kernel(problem, MA, a, b, lo_g, hi_g, high, low)
    r = float(vals[i, j])
    return _threshold_case(problem, "global", r, nats_up(r), None, a, b, kern)


def _threshold_kernel(
    problem: ModelProblem, MA: FloatArray, a: int, b: int, lo: float, hi: float, high: FloatArray, low: FloatArray
) -> Kernel:
    """The threshold kernel of the pair (a, b) over the box [lo, hi]: the decisions ``high`` on the released groups of
    its prefix, ``low`` on the others (one-hot rows, per released context or one row for all of them)."""
    _, k, order = threshold_max_many(MA[a], MA[b], lo, hi)
    return _prefix_kernel(problem, order[: int(k)], high, low)


def _prefix_kernel(problem: ModelProblem, top: IntArray, high: FloatArray, low: FloatArray) -> Kernel:
    """The decisions ``high`` on the released groups ``top``, ``low`` on the others (one-hot rows, per released context
    or one row for all of them): a threshold kernel, exact."""
    shape = (problem.n_released_contexts, problem.g.shape[2])
    table = np.repeat(np.broadcast_to(low, shape)[:, None, :], problem.n_released_groups, axis=1)
    table[:, top, :] = np.broadcast_to(high, shape)[:, None, :]
    return problem.kernel(table, exact=True)
