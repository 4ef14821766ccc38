"""The known-utility certificate: the decision models that maximise L and L̄ for a given utility.

:func:`worst_model`, its result :class:`WorstModel`, and :class:`WorstCase` (the maximiser of one search, also
returned by :func:`~fairaudit.worstcase.known_law.worst_utility`). ``proofs/black_box.md`` §6.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Callable, Hashable
from dataclasses import dataclass, replace
from typing import Any, SupportsIndex

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import BoolArray, FloatArray, IntArray, safe_log
from fairaudit.base.checks import nonnegative
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, pair_dict
from fairaudit.base.labels import format_label
from fairaudit.base.linear_fractional import FractionalProgram, FractionalResult
from fairaudit.base.threshold_rule import threshold_max_many
from fairaudit.laws.closed_forms import RandomizedResponse, RandomizedResponseParameters
from fairaudit.laws.mechanisms import Mechanism, identity
from fairaudit.laws.tables import Kernel, Population, compose
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.bounds import Assumption, check_assumptions
from fairaudit.worstcase.pair_search import SearchResult, check_method, pairwise_box, relaxed_first, search
from fairaudit.worstcase.randomized_response import RRWorst, rr_box, rr_law


@dataclass(frozen=True, eq=False, kw_only=True)
class WorstCase:
    """The maximiser of one worst-case search (local or global).

    Attributes
    ----------
    kind : {"local", "global"}
    value : float
        The maximum, in nats (+inf when unbounded; NaN when no model or
        utility meets the constraints).
    ratio : float
        exp(value).
    context : hashable or None
        The maximising context (local only).
    group, other_group : hashable or None
        The maximising pair; ``group`` gets more utility.
    kernel : Kernel or None
        The worst decision model (from :func:`worst_model`).
    utility : Utility or None
        The worst utility (from :func:`worst_utility`).
    expected_utility : numpy.ndarray or None
        E[g | x, a] of the worst case, shape (n_contexts, n_groups) (local),
        or E[g | a], shape (n_groups,) (global).
    method : {"threshold", "lp"}
    status : {"optimal", "unbounded", "infeasible", "trivial"}
    solver_status : str
    reason : str
    programs_solved : int
    """

    kind: str
    value: float
    ratio: float
    context: Hashable | None
    group: Hashable | None
    other_group: Hashable | None
    kernel: Kernel | None
    utility: Utility | None
    expected_utility: FloatArray | None
    method: str
    status: str
    solver_status: str
    reason: str
    programs_solved: int

    @classmethod
    def infeasible(cls, kind: str, solver_status: str, reason: str, programs_solved: int) -> WorstCase:
        """No model (or utility) of the class meets the constraints: NaN value, no maximiser, status "infeasible"."""
        return cls(
            kind=kind,
            value=math.nan,
            ratio=math.nan,
            context=None,
            group=None,
            other_group=None,
            kernel=None,
            utility=None,
            expected_utility=None,
            method="lp",
            status="infeasible",
            solver_status=solver_status,
            reason=reason,
            programs_solved=programs_solved,
        )

    @classmethod
    def trivial(cls, kind: str, *, kernel: Kernel | None, reason: str) -> WorstCase:
        """Nothing to compare (fewer than two groups, no live context): value 0, ratio 1, no pair, status "trivial"."""
        return cls(
            kind=kind,
            value=0.0,
            ratio=1.0,
            context=None,
            group=None,
            other_group=None,
            kernel=kernel,
            utility=None,
            expected_utility=None,
            method="threshold",
            status="trivial",
            solver_status="threshold",
            reason=reason,
            programs_solved=0,
        )

    def __repr__(self) -> str:
        where = f", context={format_label(self.context)!r}" if self.context is not None else ""
        return (
            f"WorstCase({self.kind}, value={self.value:.6g} nats{where}, groups "
            f"{format_label(self.group)!r} vs {format_label(self.other_group)!r}, method={self.method})"
        )

    def to_dict(self) -> Report:
        """The report dictionary: value, ratio, (context,) the pair, method, status, programs solved (and reason)."""
        d = pair_dict(self.kind, self.value, self.ratio, self.context, self.group, self.other_group)
        d.update(method=self.method, status=self.status, programs_solved=int(self.programs_solved))
        if self.reason:
            d["reason"] = self.reason
        return d


@dataclass(frozen=True, eq=False, kw_only=True)
class WorstModel:
    """The exact maxima of L and L̄ over every decision model, for one utility (:func:`worst_model`).

    Attributes
    ----------
    local_fairness, global_fairness : WorstCase
        The maxima of L and L̄, each with its maximising kernel.
    mechanism, context_mechanism : Mechanism
        M_A and M_X.
    utility : Utility
    tau : float or None
    population : Population
    excluded : tuple of str
        Contexts left out (P(X = x) = 0).
    assumptions : tuple of Assumption
    """

    local_fairness: WorstCase
    global_fairness: WorstCase
    mechanism: Mechanism
    context_mechanism: Mechanism
    utility: Utility
    tau: float | None
    population: Population
    excluded: tuple[str, ...]
    assumptions: tuple[Assumption, ...]

    def to_dict(self, reason: str = "") -> Report:
        """The report dictionary: the worst case for L, ``global`` for L̄ and ``worst_model``, the kernel for L.

        Parameters
        ----------
        reason : str
            Why this bound is reported as it is (a certificate's
            ``omitted["black_box"]``, or what its bound is); replaces the local worst case's own ``reason``.
        """
        out = self.local_fairness.to_dict()
        out["reason"] = reason
        out["global"] = self.global_fairness.to_dict()
        out["worst_model"] = None if self.local_fairness.kernel is None else self.local_fairness.kernel.to_dict()
        return out


def worst_model(
    mechanism: Mechanism,
    utility: Utility,
    *,
    context_mechanism: Mechanism | None = None,
    population: Population | None = None,
    tau: float | None = None,
    method: str = "auto",
) -> WorstModel:
    """The decision models behind M_A (and M_X) that maximise L and L̄, for a known utility.

    Over every kernel K[x̃, ã, u] (rows on the probability simplex of the
    utility's decisions) with E[g | x, a] ≥ τ in every context of positive
    probability and every group: maximise
    E[g | x, a] / E[g | x, a'] (local) and E[g | a] / E[g | a'] (global, with
    E[g | a] = Σ_x P(x | a) E[g | x, a]).

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released_groups).
    utility : Utility
        g(u) (shape (n_decisions,)) or g[x, a, u] labelled with the true
        contexts and groups.
    context_mechanism : Mechanism, optional
        M_X, shape (n_contexts, n_released_contexts); default the identity on
        the contexts of ``population`` (or of the utility; one context
        ``"all"`` when neither has any).
    population : Population, optional
        P(X, A); default uniform and independent.
    tau : float, optional
        Lower bound on E[g | x, a] that the models must meet.
    method : {"auto", "threshold", "lp"}
        ``auto`` uses the threshold solution where it applies (g does not
        depend on the group and τ ≤ min_u g(u, x); for L̄ also X ⊥ A), the
        Charnes–Cooper LP elsewhere; ``lp`` forces the LP.

    Returns
    -------
    WorstModel
        ``local_fairness`` and ``global_fairness``, each with the maximising pair (and context)
        and the worst kernel; composing the kernel with the mechanisms and
        auditing it reproduces the value.

    Raises
    ------
    InputError
        On mismatched labels, a negative or non-finite τ, or an unknown method.

    Notes
    -----
    The variables are G[x̃, ã] = Σ_u K[x̃, ã, u] g(u) ∈ [min g, max g] when
    g depends on the decision only, the kernel itself otherwise. Without a
    binding τ and for g free of the group, the local program at x is the box
    program over [min_u g(u, x), max_u g(u, x)]^{n_released} (M_X drops out).
    ``proofs/black_box.md`` (known utility). Behind k-ary randomized
    response, for a utility free of the group, both maxima are closed forms
    (§3 Propositions 3 and 3b per context; with a binding τ when M_X is the
    identity or g depends on the decision only), without the k x k matrix.

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> from fairaudit.laws.utilities import indicator
    >>> m = randomized_response(["Tom", "Mary"], keep=0.7)
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]))
    >>> round(w.local_fairness.ratio, 12), w.local_fairness.group, w.local_fairness.kernel.probabilities[0, :, 0].tolist()
    (2.333333333333, 'Tom', [1.0, 0.0])
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5)   # 11/7, as black_box_bound
    >>> round(w.local_fairness.ratio, 12), w.local_fairness.method, w.local_fairness.kernel.probabilities[0, :, 0].round(6).tolist()
    (1.571428571429, 'threshold', [1.0, 0.285714])
    >>> round(worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5, method="lp").local_fairness.ratio, 7)
    1.5714286
    """
    problem = _model_problem(mechanism, utility, context_mechanism, population, tau, method)
    g, live, binding, group_free = problem.g, problem.live, problem.binding, problem.group_free
    nX, nA, nU = g.shape
    if nA < 2 or not live.any():
        uniform = problem.kernel(np.ones((problem.n_released_contexts, problem.n_released_groups, nU)) / nU)
        reason = "fewer than two groups" if nA < 2 else "no context has positive probability"
        local = WorstCase.trivial("local", kernel=uniform, reason=reason)
        global_ = WorstCase.trivial("global", kernel=uniform, reason=reason)
        return problem.result(local, global_)
    method = problem.method
    if method == "threshold" and (not group_free or binding):
        raise InputError("method", "the threshold solution needs a utility free of the group and tau <= min g", method)

    # k-ary randomized response: closed forms, one pair of groups decides (every pair is alike)
    rr_local: WorstCase | None = None
    rr_global: WorstCase | None = None
    if isinstance(mechanism, RandomizedResponse) and method != "lp" and group_free:
        rr_local, rr_global = _randomized_response_cases(problem, mechanism.rr)
    general = rr_local is None or rr_global is None
    MA = mechanism.matrix if general else np.zeros((0, 0))
    pairs = np.argwhere(~np.eye(nA, dtype=bool)) if general else np.zeros((0, 2), dtype=np.intp)  # (a, b), a != b
    boxes = _boxes_by_range(problem, MA) if group_free and rr_local is None else None
    if rr_local is not None:
        local = rr_local
    elif group_free and not binding and method != "lp":
        assert boxes is not None  # (g is free of the group)
        local = _local_threshold(problem, MA, boxes)
    else:
        local = _local_search(problem, MA, pairs, boxes)
    if rr_global is not None:
        global_ = rr_global
    elif group_free and not binding and problem.independent and method != "lp":
        global_ = _global_threshold(problem, MA)
    else:
        global_ = _global_search(problem, MA, pairs)
    return problem.result(local, global_)


@dataclass(frozen=True, eq=False, kw_only=True)
class _ModelProblem:
    """The checked inputs of :func:`worst_model` and what every route of it needs."""

    mechanism: Mechanism  # M_A
    context_mechanism: Mechanism  # M_X
    utility: Utility
    population: Population
    tau: float | None
    method: str
    g: FloatArray  # g[x, a, u], (n_contexts, n_groups, n_decisions)
    live: BoolArray  # P(X = x) > 0
    excluded: tuple[str, ...]
    floor: float  # τ, or -inf without one
    group_free: bool  # g does not depend on the group
    decision_only: bool  # g depends on the decision only
    gmin: FloatArray  # min and max of g per context
    gmax: FloatArray
    binding: bool  # τ > min g in some live context
    independent: bool  # X ⊥ A in the population
    assumptions: tuple[Assumption, ...]

    @property
    def groups(self) -> tuple:
        return self.mechanism.inputs

    @property
    def contexts(self) -> tuple:
        return self.context_mechanism.inputs

    @property
    def same_x(self) -> bool:
        """M_X is the identity (then it is never materialised: a million contexts would be 10^12 cells)."""
        return self.context_mechanism.is_identity

    @property
    def n_released_contexts(self) -> int:
        return len(self.context_mechanism.outputs)

    @property
    def n_released_groups(self) -> int:
        return len(self.mechanism.outputs)

    def kernel(self, table: FloatArray, exact: bool = False) -> Kernel:
        """The worst model of a table K[x̃, ã, u]; ``exact``: a table of one-hot rows made here, no rounding to clean."""
        released_contexts, released_groups = self.context_mechanism.outputs, self.mechanism.outputs
        decisions = self.utility.decisions
        if exact:
            return Kernel(table, released_contexts, released_groups, decisions, name="worst model", _owned=True)
        t = np.clip(table, 0.0, None)
        t = t / t.sum(axis=-1, keepdims=True)
        return Kernel(t, released_contexts, released_groups, decisions, name="worst model", _owned=True)

    def audit(self, kernel: Kernel, kind: str) -> FloatArray:
        """E[g | x, a] (local) or E[g | a] (global) of the law behind ``kernel``."""
        from fairaudit.metrics.fairness import expected_utility, global_fairness

        if isinstance(self.mechanism, RandomizedResponse):  # (no k x k matrix)
            law = rr_law(kernel, self.mechanism.rr, self.groups, self.context_mechanism)
        else:
            law = compose(kernel, self.mechanism, self.context_mechanism)
        if kind == "local":
            return expected_utility(law, self.utility)
        with np.errstate(over="ignore"):  # (ratios of utilities as small as e^-710 overflow; only E[g | a] is kept)
            return global_fairness(law, self.utility, self.population).expected_utility

    def result(self, local: WorstCase, global_: WorstCase) -> WorstModel:
        return WorstModel(
            local_fairness=local,
            global_fairness=global_,
            mechanism=self.mechanism,
            context_mechanism=self.context_mechanism,
            utility=self.utility,
            tau=self.tau,
            population=self.population,
            excluded=self.excluded,
            assumptions=self.assumptions,
        )


def _model_problem(
    mechanism: Mechanism,
    utility: Utility,
    context_mechanism: Mechanism | None,
    population: Population | None,
    tau: float | None,
    method: str,
) -> _ModelProblem:
    """Check the arguments of :func:`worst_model`, fill in the defaults, and tabulate g."""
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    if not isinstance(utility, Utility):
        raise InputError("utility", "must be a Utility", type(utility).__name__)
    method = check_method(method)
    if tau is not None:
        tau = nonnegative(tau, "tau")
    groups = mechanism.inputs
    if context_mechanism is None:
        contexts = (
            population.contexts
            if population is not None
            else utility.contexts
            if utility.contexts is not None
            else ("all",)
        )
        context_mechanism = identity(contexts, name="identity on contexts")
    if not isinstance(context_mechanism, Mechanism):
        raise InputError("context_mechanism", "must be a Mechanism", type(context_mechanism).__name__)
    contexts = context_mechanism.inputs
    if population is None:
        population = Population.uniform(contexts, groups, source="assumed")
    if not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    if population.contexts != contexts or population.groups != groups:
        raise InputError(
            "population",
            "must have the context mechanism's inputs as contexts and M_A's inputs as groups",
            (list(map(format_label, population.contexts)), list(map(format_label, population.groups))),
        )
    g = np.asarray(utility.table(contexts, groups, utility.decisions), dtype=float)  # (nX, nA, nU), a view for g(u)
    nX = g.shape[0]
    live = population.p_context > 0
    floor = -math.inf if tau is None else tau
    if utility.values.ndim == 1:
        gmin, gmax = np.full(nX, float(utility.values.min())), np.full(nX, float(utility.values.max()))
    else:
        gmin, gmax = g.min(axis=(1, 2)), g.max(axis=(1, 2))  # per context
    assumptions = check_assumptions(mechanism, population=population) + (
        Assumption("g is the given utility", "checked", f"{utility!r}"),
    )
    if tau is not None:
        assumptions += (Assumption("E[g | x, a] >= tau for every model", "vouched", f"tau = {tau:g}"),)
    return _ModelProblem(
        mechanism=mechanism,
        context_mechanism=context_mechanism,
        utility=utility,
        population=population,
        tau=tau,
        method=method,
        g=g,
        live=live,
        excluded=tuple(f"context {format_label(contexts[i])!r}: P(X = x) = 0" for i in np.flatnonzero(~live)),
        floor=floor,
        group_free=not utility.depends_on_group,
        decision_only=utility.values.ndim == 1 or not (utility.depends_on_group or utility.depends_on_context),
        gmin=gmin,
        gmax=gmax,
        binding=bool(np.any(floor > gmin[live])) if live.any() else False,
        independent=population.independence().independent,
        assumptions=assumptions,
    )


def _onehot(idx: IntArray, n: int) -> FloatArray:
    out = np.zeros(idx.shape + (n,))
    np.put_along_axis(out, idx[..., None], 1.0, axis=-1)
    return out


def _weighted_utility(problem: _ModelProblem) -> FloatArray:
    """w[x̃, u] = Σ_x P(x) M_X[x, x̃] g(u, x), shape (n_released_contexts, n_decisions) (g free of the group)."""
    p_context, g = problem.population.p_context, problem.g
    if problem.same_x:
        return p_context[:, None] * g[:, 0, :]
    return np.einsum("x,xy,xu->yu", p_context, problem.context_mechanism.matrix, g[:, 0, :])


# ------------------------------------------------------------------------------ k-ary randomized response
def _randomized_response_cases(
    problem: _ModelProblem, rr: RandomizedResponseParameters
) -> tuple[WorstCase | None, WorstCase | None]:
    """The local and global maxima behind k-ary randomized response for g free of the group, in closed form.

    Every pair of groups is alike, so one pair decides. None for a maximum that has no closed form here (the
    general route solves it).
    """
    g, live, floor, binding = problem.g, problem.live, problem.floor, problem.binding
    decision_only, same_x, independent = problem.decision_only, problem.same_x, problem.independent
    nU = g.shape[2]
    lo_x, hi_x = g[:, 0, :].min(-1), g[:, 0, :].max(-1)  # the range of g(., x) per context
    hot_hi, hot_lo = _onehot(g[:, 0, :].argmax(-1), nU), _onehot(g[:, 0, :].argmin(-1), nU)  # per context
    over = np.flatnonzero(live & (floor > hi_x))
    if binding and over.size and (decision_only or same_x):
        local = _rr_infeasible(problem, "local", int(over[0]), hi_x)
        global_ = _rr_infeasible(problem, "global", int(over[0]), hi_x) if decision_only and independent else None
        return local, global_
    if binding and not (decision_only or same_x):
        return None, None
    local = _rr_local(problem, rr, lo_x, hi_x, hot_hi, hot_lo)
    # global under X independent of A (Proposition 10 (b); with τ and g(u): H-bar meets every floor)
    if independent and not binding:
        weighted_g = _weighted_utility(problem)
        lo_g, hi_g = float(weighted_g.min(-1).sum()), float(weighted_g.max(-1).sum())
        w = rr_box(rr, lo_g, hi_g, -math.inf)
        high, low = _onehot(weighted_g.argmax(-1), nU), _onehot(weighted_g.argmin(-1), nU)
        return local, _rr_case(problem, "global", w, None, _rr_kernel(problem, w, lo_g, hi_g, None, high, low))
    if independent and decision_only:
        lo, hi = float(lo_x[0]), float(hi_x[0])
        w = rr_box(rr, lo, hi, floor)
        n_released_contexts = problem.n_released_contexts
        high, low = hot_hi[:1].repeat(n_released_contexts, 0), hot_lo[:1].repeat(n_released_contexts, 0)
        kern = _rr_kernel(problem, replace(w, prefix=False), lo, hi, None, high, low)
        return local, _rr_case(problem, "global", w, None, kern)
    return local, None


def _rr_local(
    problem: _ModelProblem,
    rr: RandomizedResponseParameters,
    lo_x: FloatArray,
    hi_x: FloatArray,
    hot_hi: FloatArray,
    hot_lo: FloatArray,
) -> WorstCase:
    """The local maximum behind k-ary RR: the best context's box (proofs/black_box.md §6, Proposition 10 (a)).

    With a binding τ, §3 Proposition 3b per context. ``hot_hi``/``hot_lo``: the one-hot rows of the decisions of
    largest and smallest g per context.
    """
    live, floor, n_released_contexts = problem.live, problem.floor, problem.n_released_contexts
    ranges, range_of = np.unique(np.stack([lo_x, hi_x], axis=1), axis=0, return_inverse=True)
    range_of = range_of.ravel()
    best_x, best_w = -1, None
    for index, (lo, hi) in enumerate(ranges.tolist()):
        at = np.flatnonzero(live & (range_of == index))
        if at.size:
            w = rr_box(rr, lo, hi, floor)
            if best_w is None or w.value > best_w.value or (w.value == best_w.value and at[0] < best_x):
                best_x, best_w = int(at[0]), w
    assert best_w is not None  # (some context is live)
    lo, hi = float(lo_x[best_x]), float(hi_x[best_x])
    if not problem.binding:  # the threshold kernel of the maximising context, in every released context
        high = np.repeat(hot_hi[best_x][None], n_released_contexts, 0)
        low = np.repeat(hot_lo[best_x][None], n_released_contexts, 0)
        kern = _rr_kernel(problem, best_w, lo, hi, None, high, low)
    elif problem.same_x:
        kern = _rr_kernel(problem, best_w, lo, hi, best_x, hot_hi, hot_lo)
    else:  # g(u) behind a context filter: the same h in every released context
        high, low = hot_hi[:1].repeat(n_released_contexts, 0), hot_lo[:1].repeat(n_released_contexts, 0)
        kern = _rr_kernel(problem, replace(best_w, prefix=False), lo, hi, None, high, low)
    return _rr_case(problem, "local", best_w, best_x, kern)


def _rr_kernel(
    problem: _ModelProblem, w: RRWorst, lo: float, hi: float, x: int | None, high: FloatArray, low: FloatArray
) -> Kernel:
    """The worst kernel behind k-ary RR.

    At context x (every context when None) the mix of the decisions ``high``/``low`` that gives h; every other
    context all ``high`` (so it meets τ); a threshold h as one-hot rows.
    """
    nXr, nAr, nU = problem.n_released_contexts, problem.n_released_groups, problem.g.shape[2]
    h = w.vector(nAr)
    frac = np.clip((h - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.ones(nAr)
    table = np.zeros((nXr, nAr, nU))
    if w.prefix and x is None:
        top = w.released(nAr, hi)
        table[:] = low[:, None, :]
        table[:, top, :] = high[:, None, :]
        return problem.kernel(table, exact=True)
    rows = np.arange(nXr) if x is None else np.array([x])
    table[:] = high[:, None, :]
    table[rows] = frac[None, :, None] * high[rows, None, :] + (1 - frac)[None, :, None] * low[rows, None, :]
    return problem.kernel(table)


def _rr_case(problem: _ModelProblem, kind: str, w: RRWorst, x: int | None, kern: Kernel) -> WorstCase:
    inf = math.isinf(w.value)
    return WorstCase(
        kind=kind,
        value=w.value,
        ratio=w.ratio,
        context=None if x is None else problem.contexts[x],
        group=problem.groups[0],
        other_group=problem.groups[1],
        kernel=kern,
        utility=None,
        expected_utility=problem.audit(kern, kind),
        method="threshold",
        status="unbounded" if inf else "optimal",
        solver_status="threshold" if w.prefix else "closed form",
        reason="a released group is possible for one group and impossible for another" if inf else "",
        programs_solved=0,
    )


def _rr_infeasible(problem: _ModelProblem, kind: str, x: int, hi_x: FloatArray) -> WorstCase:
    return WorstCase.infeasible(
        kind,
        "closed form",
        "no decision model meets E[g | x, a] >= tau in every cell: "
        f"tau = {problem.tau:g} exceeds max g = {hi_x[x]:g} in context {format_label(problem.contexts[x])!r}",
        0,
    )


# ------------------------------------------------------------------------------ general mechanisms
def _boxes_by_range(problem: _ModelProblem, MA: FloatArray) -> tuple[FloatArray, IntArray, FloatArray]:
    """The box value of every (x, a, b) for g free of the group: an upper bound always, exact without a binding τ.

    The box depends on x only through [min_u g(u, x), max_u g(u, x)]: solved once per distinct range (one for
    g(u)). Returns the ranges (n_ranges, 2), the range of each context, and the values (n_ranges, nA, nA), so
    that box[x] = values[range_of[x]]; -inf on the diagonal. (Only the local search uses them.)
    """
    g, gmin, gmax = problem.g, problem.gmin, problem.gmax
    nX, nA = g.shape[:2]
    if problem.utility.values.ndim == 1:
        ranges, range_of = np.array([[gmin[0], gmax[0]]]), np.zeros(nX, dtype=np.intp)
    else:
        ranges, range_of = np.unique(
            np.stack([g[:, 0, :].min(-1), g[:, 0, :].max(-1)], axis=1), axis=0, return_inverse=True
        )
        range_of = range_of.ravel()
    # (n_ranges, nA, nA), a block of pairs at a time
    box_by_range = np.stack([pairwise_box(MA, low, high, None)[0] for low, high in ranges.tolist()])
    box_by_range[:, np.arange(nA), np.arange(nA)] = -np.inf
    return ranges, range_of, box_by_range


def _threshold_case(
    problem: _ModelProblem, kind: str, r: float, x: int | None, a: int, b: int, kern: Kernel, reason: str
) -> WorstCase:
    """A maximum decided by the threshold solution: ratio ``r`` at context x (local), pair (a, b), kernel ``kern``."""
    return WorstCase(
        kind=kind,
        value=safe_log(r),
        ratio=r,
        context=None if x is None else problem.contexts[x],
        group=problem.groups[a],
        other_group=problem.groups[b],
        kernel=kern,
        utility=None,
        expected_utility=problem.audit(kern, kind),
        method="threshold",
        status="unbounded" if math.isinf(r) else "optimal",
        solver_status="threshold",
        reason=reason,
        programs_solved=0,
    )


def _local_threshold(
    problem: _ModelProblem, MA: FloatArray, boxes: tuple[FloatArray, IntArray, FloatArray]
) -> WorstCase:
    """max L without a binding τ, g free of the group: the best box over live contexts and pairs, its threshold kernel."""
    ranges, range_of, box_by_range = boxes
    g, live = problem.g, problem.live
    nA, nU = g.shape[1:]
    best_by_range = box_by_range.reshape(len(box_by_range), -1).max(axis=1)
    best_by_range[~np.isin(np.arange(len(box_by_range)), range_of[live])] = -np.inf  # ranges of no live context
    x = int(np.argmax(live & (best_by_range[range_of] == best_by_range.max())))  # the first live maximiser
    best_range = range_of[x]
    a, b = np.unravel_index(int(box_by_range[best_range].argmax()), (nA, nA))
    _, k_top, order_top = threshold_max_many(MA[a], MA[b], ranges[best_range, 0], ranges[best_range, 1])
    top = order_top[: int(k_top)]
    hi_u, lo_u = int(g[x, 0].argmax()), int(g[x, 0].argmin())
    table = np.zeros((problem.n_released_contexts, problem.n_released_groups, nU))
    table[..., lo_u] = 1.0
    table[:, top, lo_u] = 0.0
    table[:, top, hi_u] = 1.0
    kern = problem.kernel(table, exact=True)
    r = float(box_by_range[best_range, a, b])
    reason = "a released group is possible for one group and impossible for another" if math.isinf(r) else ""
    return _threshold_case(problem, "local", r, x, int(a), int(b), kern, reason)


def _local_search(
    problem: _ModelProblem,
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
    if space.lo is not None and space.hi is not None and problem.method != "lp":
        # closed-form relaxation (only the denominator's τ): an upper bound per triple, exact where feasible
        if space.rows is not None:  # (τ rows: floor = τ)
            for context in xs:
                P = np.stack([space.coef(context, a) for a in range(nA)])
                v = pairwise_box(P, space.lo, space.hi, floor)[1]
                assert v is not None  # (a floor was given)
                at = triples[:, 0] == context
                upper[at] = np.minimum(upper[at], v[triples[at, 1], triples[at, 2]])
        solve = relaxed_first(
            num, den, space.lo, space.hi, None if space.rows is None else tau, space.rows, space.program
        )
    else:

        def solve(i: int) -> FractionalResult:
            return space.program().solve(num(i), den(i))

    return _model_case(problem, "local", search(upper, solve), triples, space.to_kernel)


def _global_threshold(problem: _ModelProblem, MA: FloatArray) -> WorstCase:
    """max L̄ without a binding τ, g free of the group, X ⊥ A: the box over [Σ min w, Σ max w] and its kernel."""
    nU = problem.g.shape[2]
    weighted_g = _weighted_utility(problem)
    lo_g, hi_g = weighted_g.min(-1).sum(), weighted_g.max(-1).sum()
    vals = pairwise_box(MA, lo_g, hi_g, None)[0]
    np.fill_diagonal(vals, -np.inf)
    a, b = np.unravel_index(int(vals.argmax()), vals.shape)
    _, k_top, order_top = threshold_max_many(MA[a], MA[b], lo_g, hi_g)
    top = order_top[: int(k_top)]
    table = np.repeat(_onehot(weighted_g.argmin(-1), nU)[:, None, :], problem.n_released_groups, axis=1)
    table[:, top, :] = _onehot(weighted_g.argmax(-1), nU)[:, None, :]
    kern = problem.kernel(table, exact=True)
    return _threshold_case(problem, "global", float(vals[a, b]), None, int(a), int(b), kern, "")


def _global_search(problem: _ModelProblem, MA: FloatArray, pairs: IntArray) -> WorstCase:
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
        solve = relaxed_first(
            num, den, space.lo, space.hi, None if space.rows is None else tau, space.rows, space.program
        )
    else:

        def solve(i: int) -> FractionalResult:
            return space.program().solve(num(i), den(i))

    global_triples = np.column_stack([np.full(len(pairs), -1), pairs])
    return _model_case(problem, "global", search(upper, solve), global_triples, space.to_kernel)


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
    problem: _ModelProblem,
    kind: str,
    found: SearchResult,
    triples: IntArray,
    to_kernel: Callable[[FloatArray], FloatArray],
) -> WorstCase:
    """The worst case of a search over (context, pair) programs; ``triples[i]`` = (x, a, b) of program i."""
    r = found.result
    if found.index < 0:
        return WorstCase.infeasible(
            kind,
            r.solver_status if r else "",
            "no decision model meets E[g | x, a] >= tau in every cell: "
            + (found.reason or "the constraints are inconsistent"),
            found.solved,
        )
    assert r is not None  # a maximiser was found
    x, a, b = triples[found.index]
    kern = problem.kernel(to_kernel(r.argmax)) if r.argmax is not None else None
    eu = problem.audit(kern, kind) if kern is not None else None
    return WorstCase(
        kind=kind,
        value=safe_log(r.value),
        ratio=r.value,
        context=problem.contexts[x] if kind == "local" else None,
        group=problem.groups[a],
        other_group=problem.groups[b],
        kernel=kern,
        utility=None,
        expected_utility=eu,
        method="lp" if found.solved else "threshold",
        status=r.status,
        solver_status=r.solver_status,
        reason=r.reason,
        programs_solved=found.solved,
    )
