"""The class certificate: the exact maximum of L over every decision model and every utility of a class.

:func:`black_box_bound` (``proofs/black_box.md`` §1–5); its result is
:class:`~fairaudit.worstcase.black_box_result.BlackBoxCertificate`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.errors import InputError
from fairaudit.base.exact_duality import Rows
from fairaudit.base.linear_fractional import FractionalProgram, FractionalResult
from fairaudit.base.outward import down, fraction_up, gap_between, log_up, product_ends, rounding_error, up, widen_up
from fairaudit.base.resources import check_memory, memory_limit
from fairaudit.base.threshold_rule import threshold_max_many
from fairaudit.laws.closed_forms import RandomizedResponse, RandomizedResponseParameters
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Population
from fairaudit.laws.utilities import UtilityClass, check_metric
from fairaudit.metrics.assumptions import Assumption, check_assumptions
from fairaudit.worstcase.black_box_result import BlackBoxCertificate
from fairaudit.worstcase.pair_search import (
    BoxPairs,
    InnerProgram,
    SearchResult,
    box_pairs,
    check_class,
    implied_floor,
    inner_witness,
    pair_ratio,
    ratio_ceiling,
    relaxed_first,
    search,
)
from fairaudit.worstcase.randomized_response import rr_box, rr_class_value, rr_lipschitz_ratio, unit_class
from fairaudit.worstcase.worst_cases import check_method, nats_up

WITNESS_BYTES = 40
"""Bytes per group of the certificate of k-ary randomized response (per group and released value with a Lipschitz
class): its witness and released vectors and the row sums, 28 measured (tracemalloc, 10^6 and 10^7 groups), rounded
up; checked against the memory limit before they are made."""


def black_box_bound(
    mechanism: Mechanism,
    *,
    utility_class: UtilityClass | None = None,
    population: Population | None = None,
    method: str = "auto",
    max_memory: int | str | None = None,
) -> BlackBoxCertificate:
    """Exact max of local g-fairness over every decision model behind M_A, for a class of utilities.

    The class: g(u, x, a) ∈ [lower, γ]; E[g | x, a] ≥ τ for every context and
    group; |g(u, x, a) − g(u, x, a')| ≤ L_A d(a, a'). The value is
    max over ordered pairs (a, a') of max (M_A[a]·h[a]) / (M_A[a']·h[a']) over
    h ∈ R^{n_groups × n_released} with lower ≤ h ≤ γ, |h[b] − h[c]| ≤ L_A d(b, c)
    and M_A[b]·h[b] ≥ τ for every b (h[b] = h for all b when L_A = 0).

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released).
    utility_class : UtilityClass, optional
        The class (``diameter`` is not used), each field by default:

        - ``lower``, ``gamma``: the range of g, 0 ≤ lower ≤ γ; 0 and 1.
        - ``tau``: lower bound on E[g | x, a], ≤ γ; none. E ≥ lower times
          M_A[a]'s row sum always holds, so τ ≤ lower changes nothing where
          the rows sum to at least 1 (a matrix's sum to 1 only within 1e-9:
          below 1, a τ at lower binds).
        - ``lipschitz``: L_A ≥ 0; 0, which means g does not depend on the group.
        - ``metric``: d(a, a') for the Lipschitz condition, shape
          (n_groups, n_groups); the discrete metric.
    population : Population, optional
        When given, X ⊥ A is checked on it (needed for the bound on L̄ only).
    method : {"auto", "threshold", "lp"}
        ``auto``: the threshold solution when τ ≤ lower and L_A = 0; with a
        binding τ, the closed-form relaxation that keeps only the denominator
        group's constraint, checked against the others, and the LP where it
        fails; the LP when L_A > 0. Pairs are searched in decreasing order of
        that relaxation (an upper bound) and the search stops when no pair
        left can win. ``lp`` forces the LP (a cross-check); ``threshold``
        raises when τ binds or L_A > 0.
    max_memory : int or str, optional
        Bytes (or ``"4G"``) the witness may take, estimated first (k-ary RR: 40 bytes a group, k² with L_A > 0);
        default :func:`~fairaudit.base.resources.memory_limit`'s.

    Returns
    -------
    BlackBoxCertificate
        The value in nats, the maximising pair, and the worst model's
        expected utility per released value.

    Raises
    ------
    InputError
        If ``lower``, ``gamma``, ``tau`` or ``lipschitz`` is negative or not finite, lower > γ, τ > γ (the class is
        empty), the metric is invalid, or the method is unknown or does not apply; field ``memory``: the witness
        would exceed ``max_memory``.

    Notes
    -----
    M_X drops out, and under X ⊥ A the value also bounds L̄ exactly. It is never larger than the tight and paper bounds
    with the same τ, L_A and metric; with lower = 0, no τ and L_A = 0 it is ε(M_A) (the corollary is attained).
    ``proofs/black_box.md``.

    With L_A = 0 only the pairs of groups that can reach the maximum are solved: with lower = 0 and no τ the rows
    that can reach ε(M_A), found in O(nm); otherwise one pass over the pairs (O(n²m) time, O(nm) memory) sets the
    others aside by exact upper bounds (``proofs/black_box.md`` §7). The result is that of solving every pair.

    For k-ary randomized response (the mechanism
    :func:`~fairaudit.laws.closed_forms.randomized_response` returns) every pair is
    alike and the value is a closed form, O(1) with the worst h in O(k):
    the threshold and the floor relaxation (``proofs/black_box.md`` §3,
    Propositions 3 and 3b) and, with L_A > 0 and the discrete metric (or
    without a binding τ, any metric), a 3-variable program solved at its
    vertices (§5, Proposition 7b; ``utility_by_release`` is then the
    k x k table). ``method="lp"`` forces the general route.

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> from fairaudit.laws.utilities import UtilityClass
    >>> m = randomized_response(["a", "b"], keep=0.7)
    >>> round(black_box_bound(m).ratio, 12)                       # 0.7 / 0.3
    2.333333333333
    >>> c = black_box_bound(m, utility_class=UtilityClass(lower=0.5, gamma=1.0))  # (0.5 + 0.5·0.7) / (0.5 + 0.5·0.3)
    >>> round(c.ratio, 12), c.group, c.released
    (1.307692307692, 'a', ('a',))
    >>> c = black_box_bound(m, utility_class=UtilityClass(tau=0.5))              # (0.7 + 0.3·2/7) / 0.5 = 11/7
    >>> round(c.ratio, 12), c.method, c.utility_by_release.round(7).tolist()
    (1.571428571429, 'threshold', [1.0, 0.2857143])
    >>> round(black_box_bound(m, utility_class=UtilityClass(tau=0.5), method="lp").ratio, 7)  # the LP agrees
    1.5714286
    """
    problem, rr, metric, d = _class_problem(mechanism, utility_class, population, method, max_memory)
    if problem.gamma > 0 and problem.gamma != 1.0:
        return _on_unit_scale(problem, metric, population)
    lower, gamma, n = problem.lower, problem.gamma, len(mechanism.inputs)
    if n < 2 or gamma == 0 or lower == gamma:
        reason = "fewer than two groups" if n < 2 else "every utility in the class is constant"
        m = len(mechanism.outputs)
        return problem.certificate(
            1.0, None, (), np.full(m, gamma), status="trivial", solver_status="threshold", reason=reason
        )
    if rr is not None:
        closed = _randomized_response_certificate(problem, rr, d)
        if closed is not None:
            return closed
    if problem.lipschitz_on:
        return _lipschitz_certificate(problem, check_metric(metric, n) if d is None else d)
    if isinstance(mechanism, RandomizedResponse):  # (the LP forced) every ordered pair is alike: (0, 1) stands for all
        pairs = np.array([[0, 1]])
        return _searched_certificate(problem, search(np.array([math.inf]), _box_solver(problem, pairs)), pairs)
    # the pairs whose box program (with a binding τ, floor relaxation) can be the largest, solved exactly;
    # the others are set aside by exact upper bounds, one pass over the pairs (proofs/black_box.md §7)
    M = mechanism.matrix
    found = box_pairs(M, lower, gamma, problem.floor if problem.binding else None)
    if not problem.binding and problem.method != "lp":
        return _threshold_certificate(problem, M, found)
    return _lp_certificate(problem, M, found)


def _class_problem(
    mechanism: Mechanism,
    utility_class: UtilityClass | None,
    population: Population | None,
    method: str,
    max_memory: int | str | None,
) -> tuple[_ClassProblem, RandomizedResponseParameters | None, npt.ArrayLike | None, FloatArray | None]:
    """Check the arguments of :func:`black_box_bound`: the problem, the RR parameters, the metric and its table.

    The RR parameters are None unless the mechanism is k-ary randomized response and the LP is not forced; the
    table is None without a metric (the discrete metric is never built: k-ary RR and L_A = 0 do not need it).
    """
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    method = check_method(method)
    lower, gamma, tau = check_class(utility_class)
    assert utility_class is None or isinstance(utility_class, UtilityClass)  # (check_class refuses the rest)
    lip = 0.0 if utility_class is None or utility_class.lipschitz is None else utility_class.lipschitz
    metric = None if utility_class is None else utility_class.metric
    n = len(mechanism.inputs)
    rr = mechanism.rr if isinstance(mechanism, RandomizedResponse) and method != "lp" else None
    if isinstance(mechanism, RandomizedResponse):  # (its matrix is never built: the witness is what grows with k)
        witness = "a table over the groups and released values" if lip > 0 else "a point over the released values"
        need = WITNESS_BYTES * n * (len(mechanism.outputs) if lip > 0 else 1)
        instead = "give fewer groups" if lip > 0 else "calibrate it instead (calibrate: closed forms, no witness)"
        check_memory(need, f"the certificate's witness ({witness})", f"{n} groups", instead, memory_limit(max_memory))
    d = check_metric(metric, n) if n >= 1 and metric is not None else None
    implied = implied_floor(lower, float(mechanism.row_sums[1].min(initial=1.0)))  # (rows summing to 1 within 1e-9)
    floor = implied if tau is None else max(tau, implied)  # E[g | x, a] >= floor
    binding = floor > implied
    lip_on = lip > 0 and n >= 2 and gamma > lower
    if method == "threshold" and (binding or lip_on):
        raise InputError(
            "method", "the threshold solution needs tau <= lower (times M_A's least row sum) and lipschitz = 0", method
        )
    # the mechanism's assumptions (and X ⊥ A on ``population``), then the class vouched for
    assumptions = check_assumptions(mechanism, population=population) + (
        Assumption("g in [lower, gamma]", "vouched", f"class [{lower:g}, {gamma:g}]"),
        Assumption(
            "g Lipschitz in the group" if lip_on else "g depends on the decision (and context) only",
            "vouched",
            f"L_A = {lip:g}" if lip_on else "L_A = 0",
        ),
    )
    if tau is not None:
        assumptions += (Assumption("E[g | x, a] >= tau for every model", "vouched", f"tau = {tau:g}"),)
    problem = _ClassProblem(
        mechanism=mechanism,
        lower=lower,
        gamma=gamma,
        tau=tau,
        lipschitz=lip,
        floor=floor,
        binding=binding,
        lipschitz_on=lip_on,
        method=method,
        assumptions=assumptions,
    )
    return problem, rr, metric, d


def _on_unit_scale(
    problem: _ClassProblem, metric: npt.ArrayLike | None, population: Population | None
) -> BlackBoxCertificate:
    """Only the shape of the class matters: solve it on the scale γ = 1 (well-conditioned LPs), and scale back."""
    lower, gamma, tau = problem.lower, problem.gamma, problem.tau
    unit_lower, unit_floor, unit_lipschitz = unit_class(lower, gamma, tau, problem.lipschitz)
    scaled = UtilityClass(
        lower=unit_lower,
        gamma=1.0,
        tau=None if tau is None else unit_floor,
        lipschitz=unit_lipschitz,
        metric=metric,
    )
    unit = black_box_bound(problem.mechanism, utility_class=scaled, population=population, method=problem.method)
    # the scaled class contains the given one (rounded outward), so its value bounds it; its witness is a point of the
    # given class only when the scaling is exact (γ a power of two, say): otherwise none
    g = Fraction(gamma)
    exact = all(
        Fraction(unit_value) == Fraction(value) / g
        for unit_value, value in ((unit_lower, lower), (unit_floor, problem.floor), (unit_lipschitz, problem.lipschitz))
    )
    return replace(
        unit,
        utility_by_release=unit.utility_by_release * gamma,
        lower=lower,
        gamma=gamma,
        tau=tau,
        lipschitz=unit.lipschitz * gamma,
        assumptions=problem.assumptions,
        witness=unit.witness if exact else math.nan,
        gap=unit.gap if exact else math.nan,
    )


@dataclass(frozen=True, kw_only=True)
class _ClassProblem:
    """A checked class of utilities on the scale γ = 1 (or γ = 0), and what every route of the certificate needs."""

    mechanism: Mechanism
    lower: float
    gamma: float
    tau: float | None
    lipschitz: float  # L_A as given
    floor: float  # E[g | x, a] >= floor: max(τ, lower)
    binding: bool  # τ above the floor every h ≥ lower meets (implied_floor)
    lipschitz_on: bool  # L_A > 0 matters: two groups or more, and lower < γ
    method: str
    assumptions: tuple[Assumption, ...]

    def certificate(
        self,
        ratio: float,
        pair: tuple[int, int] | None,
        top: IntArray | Sequence[int],
        utility_by_release: FloatArray,
        method: str = "threshold",
        status: str | None = None,
        solver_status: str = "closed form",
        reason: str | None = None,
        programs_solved: int = 0,
        *,
        value: float | None = None,
        result: FractionalResult | None = None,
    ) -> BlackBoxCertificate:
        """The certificate of a maximiser: the ordered ``pair`` of groups (indices; None without one), the released
        values (indices ``top``) where h is γ; ``value`` (nats) defaults to the log of ``ratio`` rounded up (NaN stays
        NaN).

        The defaults are a closed form's: no program solved, "unbounded" (with why) where ``value`` is +inf, else
        "optimal". ``result``: the maximiser's program, whose certification, witness and gap the certificate repeats.
        """
        if value is None:
            value = nats_up(ratio)
        if status is None:
            status = "unbounded" if value == math.inf else "optimal"
        if reason is None:
            reason = (
                "some released value is possible for one group and impossible for another" if value == math.inf else ""
            )
        inputs, outputs = self.mechanism.inputs, self.mechanism.outputs
        return BlackBoxCertificate(
            value=value,
            ratio=ratio,
            group=None if pair is None else inputs[pair[0]],
            other_group=None if pair is None else inputs[pair[1]],
            released=tuple(outputs[o] for o in top),
            utility_by_release=utility_by_release,
            lower=self.lower,
            gamma=self.gamma,
            tau=self.tau,
            lipschitz=self.lipschitz if self.lipschitz_on else 0.0,
            mechanism=self.mechanism,
            method=method,
            status=status,
            solver_status=solver_status,
            reason=reason,
            programs_solved=programs_solved,
            assumptions=self.assumptions,
            certified=(not math.isnan(ratio)) if result is None else result.certified,
            witness=math.nan if result is None else result.witness,
            gap=math.nan if result is None else result.gap,
        )


def _randomized_response_certificate(
    problem: _ClassProblem, rr: RandomizedResponseParameters, d: FloatArray | None
) -> BlackBoxCertificate | None:
    """k-ary randomized response: every ordered pair is alike, closed forms (proofs/black_box.md §3 and §5).

    None where no closed form applies (L_A > 0, a binding τ and a metric other than the discrete one).
    """
    lower, gamma, floor, lip = problem.lower, problem.gamma, problem.floor, problem.lipschitz
    n, m = len(problem.mechanism.inputs), len(problem.mechanism.outputs)
    if not problem.lipschitz_on:
        w = rr_box(rr, lower, gamma, floor)
        return problem.certificate(
            w.ratio,
            (0, 1),
            w.released(n, gamma),
            w.vector(n),
            solver_status="threshold" if w.prefix else "closed form",
            value=w.value if math.isinf(w.value) else rr_class_value(rr, lower, gamma, floor, 0.0, 1.0),  # rounded up
        )
    off_diagonal = None if d is None else d[~np.eye(n, dtype=bool)]
    discrete = off_diagonal is None or bool(np.all(off_diagonal == off_diagonal[0]))
    if not discrete and problem.binding:
        return None
    # (without a binding τ any metric: the other groups extend the pair's h, McShane; the pair of diameter)
    a, b = (0, 1) if d is None or discrete else map(int, np.unravel_index(int(np.argmax(d)), d.shape))
    dmax = 1.0 if off_diagonal is None else float(off_diagonal.max())
    g = Fraction(gamma)  # every piece's program exactly, at t = exp_up(ε), on the scale γ = 1
    exact, point = rr_lipschitz_ratio(rr.k, rr.epsilon, Fraction(lower) / g, Fraction(1), Fraction(floor) / g,
                                      Fraction(lip) * Fraction(dmax) / g)  # fmt: skip
    if exact == math.inf:
        return problem.certificate(
            math.inf,
            (a, b),
            (),
            np.full((n, m), math.nan),
            reason="the ratio is unbounded: feasible h approach q·h = 0 with p·h > 0 (lower = 0 and no tau: "
            "g = 0 for one group and L_A d(a, a') for the other)",
        )
    # its maximiser g (cells a, a', other) back on the scale γ, and f = min(g + λ, γ)
    g3 = np.full(3, math.nan) if point is None else np.clip([float(v) * gamma for v in point], lower, gamma)
    f3 = np.minimum(g3 + lip * dmax, gamma)
    ratio = fraction_up(exact)
    cells = np.full(m, 2)
    cells[a], cells[b] = 0, 1
    f, g = f3[cells], g3[cells]
    if d is None or discrete:
        h = np.broadcast_to(f, (n, m)).copy()
    else:  # the largest Lipschitz extension of (f at a, g at b) to the other groups
        h = np.clip(np.minimum(f[None, :] + lip * d[:, a, None], g[None, :] + lip * d[:, b, None]), lower, gamma)
    h[a], h[b] = f, g
    top = np.flatnonzero(f >= gamma - 1e-9 * max(1.0, gamma))
    return problem.certificate(ratio, (a, b), top, h, value=log_up(exact))


def _threshold_certificate(problem: _ClassProblem, M: FloatArray, found: BoxPairs) -> BlackBoxCertificate:
    """No binding τ and L_A = 0: the largest box value over the pairs (the first row-major), and its threshold prefix."""
    lower, gamma = problem.lower, problem.gamma
    i = int(np.argmax(found.box))  # (the pairs are row-major: ties keep the first, as over the whole n x n table)
    a, b = int(found.a[i]), int(found.b[i])
    _, k_ab, order_ab = threshold_max_many(M[a], M[b], lower, gamma)  # the maximising pair's prefix
    top = order_ab[: int(k_ab)]
    h = np.full(M.shape[1], lower)
    h[top] = gamma
    return problem.certificate(float(found.box[i]), (a, b), top, h, solver_status="threshold")


def _lp_certificate(problem: _ClassProblem, M: FloatArray, found: BoxPairs) -> BlackBoxCertificate:
    """τ binds or the LP was asked for (L_A = 0): the pair search over the pairs that can win, by LP where needed.

    The pairs :func:`box_pairs` set aside have upper bounds below (1 − PRUNE) × a value the search reaches first,
    so it would stop before them: searching the others only gives the same result (proofs/black_box.md §7).
    """
    pairs = np.column_stack([found.a, found.b])
    upper = found.box.copy()
    if problem.floor > 0:  # γ/τ, and the tight form at t = e^ε_aa' (δ = 0 there), each rounded up
        upper = np.minimum(upper, np.minimum(_ceiling(problem), up(pair_ratio(M, found.a, found.b))))
    if problem.binding:
        assert found.relaxed is not None  # (computed for a binding τ)
        upper = np.minimum(upper, found.relaxed)
    return _searched_certificate(problem, search(upper, _at_most_ceiling(problem, _box_solver(problem, pairs))), pairs)


def _ceiling(problem: _ClassProblem) -> float:
    """γ/τ times the largest row sum of M_A's exact law (where it exceeds 1: a matrix's rows sum to 1 within 1e-9),
    rounded up: E[g | x, a] = M_A[a]·h ≤ γ Σ_ã M_A[a, ã] over E[g | x, a'] ≥ τ bounds every pair's ratio."""
    return ratio_ceiling(problem.gamma, float(problem.mechanism.row_sums[0].max()), problem.floor)


def _at_most_ceiling(
    problem: _ClassProblem, solve: Callable[[int], FractionalResult]
) -> Callable[[int], FractionalResult]:
    """``solve``, its certified values lowered to :func:`_ceiling` where above it (both bound the program; where the
    floor binds and g reaches γ, the ceiling is the value, which the LP's dual may overshoot)."""
    if problem.floor <= 0:
        return solve
    ceiling = _ceiling(problem)

    def at_most(i: int) -> FractionalResult:
        r = solve(i)
        if r.status == "optimal" and r.certified and r.value > ceiling:
            r = replace(r, value=ceiling, gap=gap_between(ceiling, r.witness))
        return r

    return at_most


def _matrix_ends(mechanism: Mechanism) -> tuple[FloatArray, FloatArray]:
    """(low, high): M_A's rows enclosing its exact law entry by entry, low ≤ M ≤ high; both the matrix itself when its
    floats are the law, else its floats widened by the roundings they carry (randomized response's, computed from
    e^ε: :attr:`~fairaudit.laws.mechanisms.Mechanism.matrix_roundings`)."""
    M, roundings = mechanism.matrix, mechanism.matrix_roundings
    return (M, M) if roundings == 0 else product_ends(M, roundings, mechanism.support)


def _lipschitz_certificate(problem: _ClassProblem, d: FloatArray) -> BlackBoxCertificate:
    """The utility may depend on the group (L_A > 0): the pair search over LPs in (n, m) variables, every pair.

    Upper bounds per pair (ratios, rounded up): γ/τ and the tight form at t = e^ε_aa'. Each program is solved on
    its outer form (:func:`_lipschitz_program`), the witness taken on the inner one.
    """
    mechanism = problem.mechanism
    low, high = _matrix_ends(mechanism)
    n, m = high.shape
    pairs = np.argwhere(~np.eye(n, dtype=bool))  # the ordered pairs a != b, row-major
    upper = np.full(len(pairs), np.inf)
    floor = problem.floor
    if floor > 0:  # the ratio of two entries, each carrying R roundings, and the division: 2R + 1
        roundings = rounding_error(2 * mechanism.matrix_roundings + 1)
        t = np.asarray(widen_up(pair_ratio(mechanism.matrix, pairs[:, 0], pairs[:, 1]), roundings))
        slack = up(up(problem.lipschitz * d) / floor)
        tight = up(t + slack[pairs[:, 0], pairs[:, 1]])
        upper = np.minimum(upper, np.minimum(_ceiling(problem), tight))
    prog, inner = _lipschitz_program(problem, low, high, d)

    def solve(i: int) -> FractionalResult:
        a, b = pairs[i]
        p, q = np.zeros((2, n * m)), np.zeros((2, n * m))  # (outer, inner)
        p[:, a * m : (a + 1) * m] = high[a], low[a]
        q[:, b * m : (b + 1) * m] = low[b], high[b]
        return inner_witness(prog.solve(p[0], q[0]), p[1], q[1], inner, inside=inner.upper)

    return _searched_certificate(problem, search(upper, _at_most_ceiling(problem, solve)), pairs)


def _box_solver(problem: _ClassProblem, pairs: IntArray) -> Callable[[int], FractionalResult]:
    """Solve the program of pair i (L_A = 0): by the floor relaxation where it is feasible, else by the LP.

    The program is solved on M_A's ends (:func:`_matrix_ends`): the numerator's upper end over the denominator's
    lower end, with the floors on the upper ends (a relaxation: every model of the exact program is in it), which
    bounds the exact program from above; where the matrix is not exact the witness is taken on the inner program
    (the numerator's lower end, the denominator's upper end, the floors on the lower ends), a lower end.
    """
    lower, gamma, floor, binding = problem.lower, problem.gamma, problem.floor, problem.binding
    low, high = _matrix_ends(problem.mechanism)
    n, m = high.shape

    @functools.cache  # (built once, at the first LP)
    def program() -> FractionalProgram:
        a_ub = -high if binding else None
        return FractionalProgram(
            m, lower=lower, upper=gamma, A_ub=a_ub, b_ub=None if a_ub is None else -floor * np.ones(n)
        )

    if binding and problem.method != "lp":
        outer = relaxed_first(
            lambda i: high[pairs[i, 0]], lambda i: low[pairs[i, 1]], lower, gamma, floor, high, program
        )
    else:

        def outer(i: int) -> FractionalResult:
            a, b = pairs[i]
            return program().solve(high[a], low[b])

    if low is high:
        return outer
    inner = InnerProgram(np.full(m, lower), np.full(m, gamma), [(-low, np.full(n, -floor), "le")] if binding else [])

    def solve(i: int) -> FractionalResult:
        a, b = pairs[i]
        return inner_witness(outer(i), low[a], high[b], inner, inside=inner.upper)

    return solve


def _searched_certificate(problem: _ClassProblem, found: SearchResult, pairs: IntArray) -> BlackBoxCertificate:
    """The certificate of the pair search's maximiser (NaN, "infeasible", when the class is empty; "error" when the
    solver failed on a program)."""
    lower, gamma, lip_on = problem.lower, problem.gamma, problem.lipschitz_on
    n, m = len(problem.mechanism.inputs), len(problem.mechanism.outputs)
    r = found.result
    if found.index < 0:
        return problem.certificate(
            math.nan,
            None,
            (),
            np.full(m, math.nan),
            method="lp",
            status="error" if r is not None and r.status == "error" else "infeasible",
            solver_status=r.solver_status if r else "",
            reason=(f"not solved: {found.reason}" if r is not None and r.status == "error" else found.reason)
            or "the class is empty",
            programs_solved=found.solved,
        )
    assert r is not None  # a maximising pair was found
    a, b = (int(v) for v in pairs[found.index])
    shape = (n, m) if lip_on else (m,)
    h = np.full(shape, math.nan) if r.argmax is None else np.clip(r.argmax.reshape(shape), lower, gamma)
    top = np.flatnonzero((h[a] if lip_on else h) >= gamma - 1e-9 * max(1.0, gamma))  # (none where h is NaN)
    method = "lp" if found.solved else "threshold"
    return problem.certificate(
        r.value, (a, b), top, h, method, r.status, r.solver_status, r.reason, found.solved, result=r
    )


def _lipschitz_program(
    problem: _ClassProblem, low: FloatArray, high: FloatArray, d: FloatArray
) -> tuple[FractionalProgram, InnerProgram]:
    """The class polytope with a utility per group, h (n, m) flattened row-major: the outer program (the floors, where
    they bind, on M_A's upper ends ``high``, the Lipschitz limits L_A·d rounded up), and the inner program (the floors
    on the lower ends ``low``, the limits rounded down), which a witness meets only where it meets the exact ones."""
    import scipy.sparse as sp

    lower, gamma, floor = problem.lower, problem.gamma, problem.floor if problem.binding else None
    n, m = high.shape
    group_b, group_c = np.triu_indices(n, 1)
    product = problem.lipschitz * d[group_b, group_c]
    keep = down(product) < up(gamma - lower)  # the others are implied by the box: L_A·d ≥ γ − lower exactly
    group_b, group_c, product = group_b[keep], group_c[keep], product[keep]
    outer = _class_rows(n, m, group_b, group_c, up(product), -high, floor)
    a_ub = sp.vstack([a for a, _, _ in outer], format="csr") if outer else None
    b_ub = np.concatenate([b for _, b, _ in outer]) if outer else None
    program = FractionalProgram(n * m, lower=lower, upper=gamma, A_ub=a_ub, b_ub=b_ub)
    inner = _class_rows(n, m, group_b, group_c, down(product), -low, floor)
    return program, InnerProgram(np.full(n * m, lower), np.full(n * m, gamma), inner)


def _class_rows(
    n: int, m: int, group_b: IntArray, group_c: IntArray, limit: FloatArray, floors: FloatArray, floor: float | None
) -> Rows:
    """The rows ``h[b] − h[c] ≤ limit`` and ``h[c] − h[b] ≤ limit`` of each pair (b, c), and ``floors[b]·h[b] ≤
    −floor`` of each group b (``floors`` the negated rows of M_A; none when ``floor`` is None)."""
    import scipy.sparse as sp

    rows: Rows = []
    if group_b.size:
        k = group_b.size * m
        r = np.arange(k)
        released = np.tile(np.arange(m), group_b.size)
        col_b = np.repeat(group_b, m) * m + released
        col_c = np.repeat(group_c, m) * m + released
        diff = sp.csr_matrix(
            (np.concatenate([np.ones(k), -np.ones(k)]), (np.concatenate([r, r]), np.concatenate([col_b, col_c]))),
            shape=(k, n * m),
        )
        rows += [(diff, np.repeat(limit, m), "le"), (-diff, np.repeat(limit, m), "le")]
    if floor is not None:  # −M[b]·h[b] ≤ −τ: block-diagonal rows
        rows.append((sp.block_diag([floors[b][None, :] for b in range(n)], format="csr"), np.full(n, -floor), "le"))
    return rows
