"""The known-utility certificate: the decision models that maximise L and L̄ for a given utility.

:func:`worst_model`, its result :class:`WorstModel`, and :class:`WorstCase` (the maximiser of one search, also
returned by :func:`~fairaudit.worstcase.worst_utility`). ``proofs/black_box.md`` §6.
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

from .._arrays import BoolArray, FloatArray, IntArray, format_label
from .._errors import InputError
from ..bounds import Assumption, _nonneg, check_assumptions
from ..laws import Kernel, Population, compose
from ..lfp import FractionalProgram, FractionalResult, threshold_max_many
from ..privacy import Mechanism, RandomizedResponse, identity
from ..utility import Utility
from ._randomized_response import _rr_box, _rr_law, _RRWorst
from ._search import _check_method, _log, _pairwise_box, _relaxed_first, _Search, _search


@dataclass(frozen=True, eq=False)
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


@dataclass(frozen=True, eq=False)
class WorstModel:
    """The exact maxima of L and L̄ over every decision model, for one utility (:func:`worst_model`).

    Attributes
    ----------
    local, global_ : WorstCase
        Each with its maximising kernel.
    mechanism, context_mechanism : Mechanism
        M_A and M_X.
    utility : Utility
    tau : float or None
    population : Population
    excluded : tuple of str
        Contexts left out (P(X = x) = 0).
    assumptions : tuple of Assumption
    """

    local: WorstCase
    global_: WorstCase
    mechanism: Mechanism
    context_mechanism: Mechanism
    utility: Utility
    tau: float | None
    population: Population
    excluded: tuple[str, ...]
    assumptions: tuple[Assumption, ...]


def _onehot(idx: IntArray, n: int) -> FloatArray:
    out = np.zeros(idx.shape + (n,))
    np.put_along_axis(out, idx[..., None], 1.0, axis=-1)
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
        ``local`` and ``global_``, each with the maximising pair (and context)
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
    >>> from fairaudit.privacy import randomized_response
    >>> from fairaudit.utility import indicator
    >>> m = randomized_response(["Tom", "Mary"], keep=0.7)
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]))
    >>> round(w.local.ratio, 12), w.local.group, w.local.kernel.probabilities[0, :, 0].tolist()
    (2.333333333333, 'Tom', [1.0, 0.0])
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5)   # 11/7, as black_box_bound
    >>> round(w.local.ratio, 12), w.local.method, w.local.kernel.probabilities[0, :, 0].round(6).tolist()
    (1.571428571429, 'threshold', [1.0, 0.285714])
    >>> round(worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5, method="lp").local.ratio, 7)
    1.5714286
    """
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    if not isinstance(utility, Utility):
        raise InputError("utility", "must be a Utility", type(utility).__name__)
    method = _check_method(method)
    if tau is not None:
        tau = _nonneg("tau", tau)
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
    decisions = utility.decisions
    g = np.asarray(utility.table(contexts, groups, decisions), dtype=float)  # (nX, nA, nU), a view for g(u)
    nX, nA, nU = g.shape
    nXr, nAr = len(context_mechanism.outputs), len(mechanism.outputs)
    same_x = context_mechanism.is_identity  # then M_X is never materialised (a million contexts: 10^12 cells)
    live = population.p_context > 0
    excluded = tuple(f"context {format_label(contexts[i])!r}: P(X = x) = 0" for i in np.flatnonzero(~live))
    floor = -math.inf if tau is None else tau
    indep_a = not utility.depends_on_group
    u_only = utility.values.ndim == 1 or not (utility.depends_on_group or utility.depends_on_context)
    if utility.values.ndim == 1:
        gmin, gmax = np.full(nX, float(utility.values.min())), np.full(nX, float(utility.values.max()))
    else:
        gmin, gmax = g.min(axis=(1, 2)), g.max(axis=(1, 2))  # per context
    binding = bool(np.any(floor > gmin[live])) if live.any() else False
    independent = population.independence().independent
    assumptions = check_assumptions(mechanism, tau=None, gamma=None, population=population) + (
        Assumption("g is the given utility", "checked", f"{utility!r}"),
    )
    if tau is not None:
        assumptions += (Assumption("E[g | x, a] >= tau for every model", "vouched", f"tau = {tau:g}"),)
    released_groups, released_contexts = mechanism.outputs, context_mechanism.outputs

    def kernel_of(table: FloatArray, exact: bool = False) -> Kernel:
        if exact:  # a table of one-hot rows made here: no rounding to clean
            return Kernel(table, released_contexts, released_groups, decisions, name="worst model", _owned=True)
        t = np.clip(table, 0.0, None)
        t = t / t.sum(axis=-1, keepdims=True)
        return Kernel(t, released_contexts, released_groups, decisions, name="worst model", _owned=True)

    def audit(kernel: Kernel, kind: str) -> FloatArray:
        from ..metrics import expected_utility, global_fairness

        if isinstance(mechanism, RandomizedResponse):  # (no k x k matrix)
            law = _rr_law(kernel, mechanism.rr, groups, context_mechanism)
        else:
            law = compose(kernel, mechanism, context_mechanism)
        if kind == "local":
            return expected_utility(law, utility)
        with np.errstate(over="ignore"):  # (ratios of utilities as small as e^-710 overflow; only E[g | a] is kept)
            return global_fairness(law, utility, population).expected_utility

    if nA < 2 or not live.any():
        uniform = kernel_of(np.ones((nXr, nAr, nU)) / nU)
        reason = "fewer than two groups" if nA < 2 else "no context has positive probability"
        local = WorstCase.trivial("local", kernel=uniform, reason=reason)
        global_ = WorstCase.trivial("global", kernel=uniform, reason=reason)
        return WorstModel(local, global_, mechanism, context_mechanism, utility, tau, population, excluded, assumptions)

    if method == "threshold" and (not indep_a or binding):
        raise InputError("method", "the threshold solution needs a utility free of the group and tau <= min g", method)

    # k-ary randomized response: closed forms, one pair of groups decides (every pair is alike)
    rr_local: WorstCase | None = None
    rr_global: WorstCase | None = None
    if isinstance(mechanism, RandomizedResponse) and method != "lp" and indep_a:
        rr = mechanism.rr
        lo_x, hi_x = g[:, 0, :].min(-1), g[:, 0, :].max(-1)  # the range of g(., x) per context

        def rr_kernel(w: _RRWorst, lo: float, hi: float, x: int | None, high: FloatArray, low: FloatArray) -> Kernel:
            """The worst kernel: at context x (every context when None) the mix of the decisions ``high``/``low``
            that gives h; every other context all ``high`` (so it meets τ); a threshold h as one-hot rows."""
            h = w.vector(nAr)
            frac = np.clip((h - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.ones(nAr)
            table = np.zeros((nXr, nAr, nU))
            if w.prefix and x is None:
                top = w.released(nAr, hi)
                table[:] = low[:, None, :]
                table[:, top, :] = high[:, None, :]
                return kernel_of(table, exact=True)
            rows = np.arange(nXr) if x is None else np.array([x])
            table[:] = high[:, None, :]
            table[rows] = frac[None, :, None] * high[rows, None, :] + (1 - frac)[None, :, None] * low[rows, None, :]
            return kernel_of(table)

        def rr_case(kind: str, w: _RRWorst, x: int | None, kern: Kernel) -> WorstCase:
            inf = math.isinf(w.value)
            return WorstCase(
                kind,
                w.value,
                w.ratio,
                None if x is None else contexts[x],
                groups[0],
                groups[1],
                kern,
                None,
                audit(kern, kind),
                "threshold",
                "unbounded" if inf else "optimal",
                "threshold" if w.prefix else "closed form",
                "a released group is possible for one group and impossible for another" if inf else "",
                0,
            )

        def infeasible(kind: str, x: int) -> WorstCase:
            return WorstCase.infeasible(
                kind,
                "closed form",
                "no decision model meets E[g | x, a] >= tau in every cell: "
                f"tau = {tau:g} exceeds max g = {hi_x[x]:g} in context {format_label(contexts[x])!r}",
                0,
            )

        hot_hi, hot_lo = _onehot(g[:, 0, :].argmax(-1), nU), _onehot(g[:, 0, :].argmin(-1), nU)  # per context
        over = np.flatnonzero(live & (floor > hi_x))
        if binding and over.size and (u_only or same_x):
            rr_local = infeasible("local", int(over[0]))
            rr_global = infeasible("global", int(over[0])) if u_only and independent else None
        elif not binding or u_only or same_x:
            # local (proofs/black_box.md §6, Proposition 10 (a); with a binding τ, §3 Proposition 3b per context)
            ranges, range_of = np.unique(np.stack([lo_x, hi_x], axis=1), axis=0, return_inverse=True)
            range_of = range_of.ravel()
            best_x, best_w = -1, None
            for index, (lo, hi) in enumerate(ranges.tolist()):
                at = np.flatnonzero(live & (range_of == index))
                if at.size:
                    w = _rr_box(rr, lo, hi, floor)
                    if best_w is None or w.value > best_w.value or (w.value == best_w.value and at[0] < best_x):
                        best_x, best_w = int(at[0]), w
            assert best_w is not None  # (some context is live)
            lo, hi = float(lo_x[best_x]), float(hi_x[best_x])
            if not binding:  # the threshold kernel of the maximising context, in every released context
                kern = rr_kernel(
                    best_w,
                    lo,
                    hi,
                    None,
                    np.repeat(hot_hi[best_x][None], nXr, 0),
                    np.repeat(hot_lo[best_x][None], nXr, 0),
                )
            elif same_x:
                kern = rr_kernel(best_w, lo, hi, best_x, hot_hi, hot_lo)
            else:  # g(u) behind a context filter: the same h in every released context
                kern = rr_kernel(
                    replace(best_w, prefix=False), lo, hi, None, hot_hi[:1].repeat(nXr, 0), hot_lo[:1].repeat(nXr, 0)
                )
            rr_local = rr_case("local", best_w, best_x, kern)
            # global under X independent of A (Proposition 10 (b); with τ and g(u): H-bar meets every floor)
            if independent and not binding:
                p_context = population.p_context
                weighted_g = (
                    p_context[:, None] * g[:, 0, :]
                    if same_x
                    else np.einsum("x,xy,xu->yu", p_context, context_mechanism.matrix, g[:, 0, :])
                )
                lo_g, hi_g = float(weighted_g.min(-1).sum()), float(weighted_g.max(-1).sum())
                w = _rr_box(rr, lo_g, hi_g, -math.inf)
                kern = rr_kernel(
                    w, lo_g, hi_g, None, _onehot(weighted_g.argmax(-1), nU), _onehot(weighted_g.argmin(-1), nU)
                )
                rr_global = rr_case("global", w, None, kern)
            elif independent and u_only:
                lo, hi = float(lo_x[0]), float(hi_x[0])
                w = _rr_box(rr, lo, hi, floor)
                kern = rr_kernel(
                    replace(w, prefix=False), lo, hi, None, hot_hi[:1].repeat(nXr, 0), hot_lo[:1].repeat(nXr, 0)
                )
                rr_global = rr_case("global", w, None, kern)
    general = rr_local is None or rr_global is None
    MA = mechanism.matrix if general else np.zeros((0, 0))
    pairs = np.argwhere(~np.eye(nA, dtype=bool)) if general else np.zeros((0, 2), dtype=np.intp)  # (a, b), a != b
    # box values per (x, a, b) when g is free of the group: an upper bound always, exact without a binding τ
    # The box depends on x only through [min_u g(u, x), max_u g(u, x)]: solved once per distinct range (one for
    # g(u)), box[x] = box_by_range[range_of[x]]. (Only the local search uses them.)
    if indep_a and rr_local is None:
        if utility.values.ndim == 1:
            ranges, range_of = np.array([[gmin[0], gmax[0]]]), np.zeros(nX, dtype=np.intp)
        else:
            ranges, range_of = np.unique(
                np.stack([g[:, 0, :].min(-1), g[:, 0, :].max(-1)], axis=1), axis=0, return_inverse=True
            )
            range_of = range_of.ravel()
        # (n_ranges, nA, nA), a block of pairs at a time
        box_by_range = np.stack([_pairwise_box(MA, low, high, None)[0] for low, high in ranges.tolist()])
        box_by_range[:, np.arange(nA), np.arange(nA)] = -np.inf
    # ------------------------------------------------------------------ local
    if rr_local is not None:
        local = rr_local
    elif indep_a and not binding and method != "lp":
        best_by_range = box_by_range.reshape(len(box_by_range), -1).max(axis=1)
        best_by_range[~np.isin(np.arange(len(box_by_range)), range_of[live])] = -np.inf  # ranges of no live context
        x = int(np.argmax(live & (best_by_range[range_of] == best_by_range.max())))  # the first live maximiser
        best_range = range_of[x]
        a, b = np.unravel_index(int(box_by_range[best_range].argmax()), (nA, nA))
        _, k_top, order_top = threshold_max_many(MA[a], MA[b], ranges[best_range, 0], ranges[best_range, 1])
        top = order_top[: int(k_top)]
        hi_u, lo_u = int(g[x, 0].argmax()), int(g[x, 0].argmin())
        table = np.zeros((nXr, nAr, nU))
        table[..., lo_u] = 1.0
        table[:, top, lo_u] = 0.0
        table[:, top, hi_u] = 1.0
        kern = kernel_of(table, exact=True)
        r = float(box_by_range[best_range, a, b])
        local = WorstCase(
            "local",
            _log(r),
            r,
            contexts[x],
            groups[a],
            groups[b],
            kern,
            None,
            audit(kern, "local"),
            "threshold",
            "unbounded" if math.isinf(r) else "optimal",
            "threshold",
            "a released group is possible for one group and impossible for another" if math.isinf(r) else "",
            0,
        )
    else:
        MX = context_mechanism.matrix
        space = _model_program(MA, MX, g, live, tau, u_only, binding)
        xs = np.flatnonzero(live)
        triples = np.array([(x, a, b) for x in xs for a, b in pairs])
        if indep_a:
            upper = box_by_range[range_of[triples[:, 0]], triples[:, 1], triples[:, 2]]
        else:
            upper = np.full(len(triples), np.inf)
        if tau is not None and tau > 0:
            upper = np.minimum(upper, g[triples[:, 0], triples[:, 1]].max(-1) / tau)
        num = lambda i: space.coef(triples[i, 0], triples[i, 1])  # noqa: E731
        den = lambda i: space.coef(triples[i, 0], triples[i, 2])  # noqa: E731
        if not indep_a:
            gmax_xa, gmin_xa = g.max(-1), g.min(-1)
            with np.errstate(divide="ignore", invalid="ignore"):
                crude = np.where(
                    gmin_xa[triples[:, 0], triples[:, 2]] > 0,
                    gmax_xa[triples[:, 0], triples[:, 1]] / gmin_xa[triples[:, 0], triples[:, 2]],
                    np.inf,
                )
            upper = np.minimum(upper, crude)
        if space.lo is not None and space.hi is not None and method != "lp":
            # closed-form relaxation (only the denominator's τ): an upper bound per triple, exact where feasible
            if space.rows is not None:  # (τ rows: floor = τ)
                for context in xs:
                    P = np.stack([space.coef(context, a) for a in range(nA)])
                    v = _pairwise_box(P, space.lo, space.hi, floor)[1]
                    assert v is not None  # (a floor was given)
                    at = triples[:, 0] == context
                    upper[at] = np.minimum(upper[at], v[triples[at, 1], triples[at, 2]])
            solve = _relaxed_first(
                num, den, space.lo, space.hi, None if space.rows is None else tau, space.rows, space.program
            )
        else:

            def solve(i: int) -> FractionalResult:
                return space.program().solve(num(i), den(i))

        found = _search(upper, solve)
        local = _model_case("local", found, triples, contexts, groups, space.to_kernel, kernel_of, audit)
    # ------------------------------------------------------------------ global
    if rr_global is not None:
        global_ = rr_global
    elif indep_a and not binding and independent and method != "lp":
        p_context = population.p_context
        weighted_g = (
            p_context[:, None] * g[:, 0, :]
            if same_x
            else np.einsum("x,xy,xu->yu", p_context, context_mechanism.matrix, g[:, 0, :])
        )
        lo_g, hi_g = weighted_g.min(-1).sum(), weighted_g.max(-1).sum()
        vals = _pairwise_box(MA, lo_g, hi_g, None)[0]
        np.fill_diagonal(vals, -np.inf)
        a, b = np.unravel_index(int(vals.argmax()), vals.shape)
        _, k_top, order_top = threshold_max_many(MA[a], MA[b], lo_g, hi_g)
        top = order_top[: int(k_top)]
        table = np.repeat(_onehot(weighted_g.argmin(-1), nU)[:, None, :], nAr, axis=1)
        table[:, top, :] = _onehot(weighted_g.argmax(-1), nU)[:, None, :]
        kern = kernel_of(table, exact=True)
        r = float(vals[a, b])
        global_ = WorstCase(
            "global",
            _log(r),
            r,
            None,
            groups[a],
            groups[b],
            kern,
            None,
            audit(kern, "global"),
            "threshold",
            "unbounded" if math.isinf(r) else "optimal",
            "threshold",
            "",
            0,
        )
    else:
        p_context_given_group = np.nan_to_num(population.context_given_group(), nan=0.0)  # P(x | a), (nX, nA)
        space = _model_program(MA, context_mechanism.matrix, g, live, tau, u_only, binding)

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
            upper = np.minimum(upper, gmax.max() / tau)
        num = lambda i: coef_global(pairs[i, 0])  # noqa: E731
        den = lambda i: coef_global(pairs[i, 1])  # noqa: E731
        if space.lo is not None and space.hi is not None and method != "lp":
            P = np.stack([coef_global(a) for a in range(nA)])
            if space.rows is not None:  # (τ rows: floor = τ)
                v = _pairwise_box(P, space.lo, space.hi, floor)[1]
            else:
                v = _pairwise_box(P, space.lo, space.hi, None)[0]
            assert v is not None  # (a floor was given)
            upper = np.minimum(upper, v[pairs[:, 0], pairs[:, 1]])
            solve = _relaxed_first(
                num, den, space.lo, space.hi, None if space.rows is None else tau, space.rows, space.program
            )
        else:

            def solve(i: int) -> FractionalResult:
                return space.program().solve(num(i), den(i))

        found = _search(upper, solve)
        global_triples = np.column_stack([np.full(len(pairs), -1), pairs])
        global_ = _model_case("global", found, global_triples, contexts, groups, space.to_kernel, kernel_of, audit)
    return WorstModel(local, global_, mechanism, context_mechanism, utility, tau, population, excluded, assumptions)


@dataclass(frozen=True, eq=False)
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
            coef_g,
            g_to_kernel,
            lazy(
                lambda: FractionalProgram(
                    nXr * nAr,
                    lower=lo,
                    upper=hi,
                    A_ub=None if rows is None else -rows,
                    b_ub=b_rows,
                )
            ),
            lo,
            hi,
            rows,
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

    return _ModelSpace(coef, to_kernel, lazy(build), None, None, None)


def _model_case(
    kind: str,
    found: _Search,
    triples: IntArray,
    contexts: tuple,
    groups: tuple,
    to_kernel: Callable[[FloatArray], FloatArray],
    kernel_of: Callable[[FloatArray], Kernel],
    audit: Callable[[Kernel, str], FloatArray],
) -> WorstCase:
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
    kern = kernel_of(to_kernel(r.argmax)) if r.argmax is not None else None
    eu = audit(kern, kind) if kern is not None else None
    return WorstCase(
        kind,
        _log(r.value),
        r.value,
        contexts[x] if kind == "local" else None,
        groups[a],
        groups[b],
        kern,
        None,
        eu,
        "lp" if found.solved else "threshold",
        r.status,
        r.solver_status,
        r.reason,
        found.solved,
    )
