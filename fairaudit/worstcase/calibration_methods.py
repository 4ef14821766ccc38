"""The four calibration methods behind :func:`fairaudit.worstcase.calibration.calibrate`: what each finds along a family.

Each method takes the checked inputs (:class:`~fairaudit.worstcase.calibration_result.Common`) and returns a :class:`Found`: the largest ε meeting the
target (NaN when none does), the certificate there and the reason; :func:`fairaudit.worstcase.calibration.calibrate` turns it
into a :class:`~fairaudit.worstcase.calibration_result.Calibration` with the family's member and keep probability.

* :func:`closed_form` — ``paper`` and ``tight``, closed forms of the main theorem.
* :func:`black_box` — the exact worst case over every model, non-decreasing along the family: bracketed and
  refined, or the closed form of ``proofs/black_box.md`` §3 for k-ary randomized response;
  :func:`black_box_global` on L̄ when X and A are dependent.
* :func:`white_box` — a known decision kernel: the exact L (L̄), scanned on a grid and refined; or the upper end of
  its range over the utility of one decision known only within [min g, max g] (the unparsed reply).

Proofs: ``proofs/calibration.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import EXP_SAFE, FloatArray
from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label
from fairaudit.base.outward import exp_down, exp_up, fraction_down, log_down, log_up
from fairaudit.laws.closed_forms import RandomizedResponse, randomized_response
from fairaudit.laws.composition import compose
from fairaudit.laws.families import MechanismFamily
from fairaudit.laws.mechanisms import Mechanism, identity
from fairaudit.laws.tables import Kernel, Law, Population
from fairaudit.laws.utilities import Utility, UtilityClass, check_metric
from fairaudit.metrics.bounds import main_theorem, main_theorem_tight
from fairaudit.metrics.fairness import global_fairness, local_fairness
from fairaudit.worstcase.calibration_result import Common
from fairaudit.worstcase.calibration_search import EPS_MAX, bracket, keep_grid, largest_meeting
from fairaudit.worstcase.randomized_response import rr_class_value, rr_law

__all__ = [
    "Found",
    "black_box",
    "black_box_global",
    "closed_form",
    "infeasible",
    "rr_black_box_epsilon",
    "white_box",
]


@dataclass(frozen=True)
class Found:
    """What a method finds: the largest ε meeting the target, the certificate there, and why.

    Attributes
    ----------
    epsilon : float
        Nats; +inf when every ε meets the target, NaN when none does.
    bound : float
        The certificate at ε; when infeasible the floor (or +inf when nothing is certified).
    reason : str
    feasible : bool
    unparsed : tuple or None
        ``white_box`` with an unparsed decision: its label and the interval [min g, max g] of its utility.
    """

    epsilon: float
    bound: float
    reason: str
    feasible: bool = True
    unparsed: tuple[Hashable, tuple[float, float]] | None = None


def infeasible(bound: float, reason: str) -> Found:
    """No ε meets the target: ``bound`` is the least any ε reaches (+inf when nothing is certified)."""
    return Found(math.nan, bound, reason, feasible=False)


# -- paper and tight ------------------------------------------------------------------------------------


def closed_form(common: Common, method: str) -> Found:
    """``paper`` (ε = target − log(1 + c/τ)) or ``tight`` (ε = log(e^target − c/τ)), c = L_A·diam + δγ."""
    target, gamma, tau = common.target, common.gamma, common.tau
    lip, diam, delta = common.lipschitz, common.diameter, common.delta
    c = lip * diam + delta * gamma
    if math.isnan(tau):  # (calibrate checked that the extra term is 0: L_A*diam = 0 and delta = 0)
        return Found(
            target,
            target,
            f"closed form of the {method} bound without tau: L_A*diam = 0 and delta = 0, so the extra term "
            "log(1 + (L_A*diam + delta*gamma)/tau) is 0 for every tau > 0 and epsilon = target; it certifies every "
            "pure epsilon-DP mechanism on the groups (looser than black_box for a known family)",
        )
    floor = math.log1p(c / tau)
    terms = f"log(1 + (L_A*diam + delta*gamma)/tau) = log(1 + ({lip:g}*{diam:g} + {delta:g}*{gamma:g})/{tau:g})"
    if target < floor * (1 - 1e-14):  # (a few ulps of rounding in the floor itself are not a violation)
        return infeasible(
            floor,
            f"the target {target:.6g} nats is below the floor {terms} = "
            f"{floor:.6g} nats, the {method} bound at epsilon = 0: no privacy budget meets it",
        )
    # ε is a lower end (every ε' ≤ it meets the target): the extra term's ln rounded up, e^−target rounded up,
    # ln rounded down, the differences in exact rationals rounded down (proofs/outward.md §5)
    x = (Fraction(lip) * Fraction(diam) + Fraction(delta) * Fraction(gamma)) / Fraction(tau)
    if method == "paper":
        eps = max(0.0, fraction_down(Fraction(target) - Fraction(log_up(1 + x))))
        form = f"epsilon = target - log(1 + (L_A*diam + delta*gamma)/tau) = {target:.6g} - {floor:.6g}"
    else:
        inside = 1 - x * Fraction(exp_up(-target))  # e^target − x = e^target (1 − x e^−target)
        eps = max(0.0, fraction_down(Fraction(target) + Fraction(log_down(inside)))) if inside > 0 else 0.0
        form = f"epsilon = log(e^target - (L_A*diam + delta*gamma)/tau) = log(e^{target:.6g} - {c / tau:.6g})"
    theorem = main_theorem if method == "paper" else main_theorem_tight
    return Found(
        eps,
        theorem(eps, delta, gamma=gamma, tau=tau, lipschitz=lip, diameter=diam),
        f"closed form of the {method} bound, {form}; it certifies every "
        f"(epsilon, {delta:g})-DP mechanism on the groups (looser than black_box for a known family)",
    )


# -- black-box ------------------------------------------------------------------------------------------


def rr_black_box_epsilon(target: float, k: int, lower: float, gamma: float) -> float:
    """Closed form of ``proofs/black_box.md`` §3: the largest ε of k-ary RR with black-box value ≤ target.

    Any target ≥ 0, however large: e^target is never formed above 700 nats (the same formula in logarithms;
    with lower = 0 it is ε = target). A lower end: t increases in T = e^target, so T is rounded down and t,
    exact in rationals, goes through ln rounded down (``proofs/outward.md`` §5); above 700 nats, the same formula
    in logarithms, each term rounded down.
    """
    rho = lower / gamma if gamma > 0 else 1.0
    if rho == 0.0:
        return target
    if target <= EXP_SAFE:
        big = Fraction(exp_down(target))
        r = Fraction(lower) / Fraction(gamma)
        if big * r >= 1:
            return math.inf
        exact = (big * r * (k - 1) + big * (1 - r) - r * (k - 1)) / (1 - big * r)
        return _meeting(log_down(max(exact, Fraction(1))), target, k, lower, gamma)
    eps = _rr_black_box_epsilon_large(target, k, Fraction(lower) / Fraction(gamma))
    return eps if math.isinf(eps) else _meeting(eps, target, k, lower, gamma)


def _meeting(eps: float, target: float, k: int, lower: float, gamma: float) -> float:
    """``eps`` moved down a float at a time (at most 16) until the certified value at it, rounded up as a certificate
    rounds it (:func:`~fairaudit.worstcase.randomized_response.rr_class_value`), meets the target: the certificate
    at the calibrated ε then says met."""
    for _ in range(16):
        m = randomized_response(range(k), eps)
        if eps <= 0.0 or not isinstance(m, RandomizedResponse):
            return eps
        if rr_class_value(m.rr, lower, gamma, None, 0.0, 1.0) <= target:
            return eps
        eps = math.nextafter(eps, 0.0)
    return eps


def _rr_black_box_epsilon_large(target: float, k: int, r: Fraction) -> float:
    """:func:`rr_black_box_epsilon` above 700 nats (e^target overflows a double), a lower end, in logarithms:
    ln t = y + ln(1 + r(k − 2) − r(k − 1)e^−y) − ln(1 − r e^y) for y = target and r = lower/γ > 0, each term rounded
    down in rationals (``proofs/outward.md`` §5); +inf when r e^y ≥ 1 surely (y + ln r ≥ 0, ln r rounded down)."""
    y = Fraction(target)
    log_r = Fraction(log_down(r))
    if y + log_r >= 0:  # r e^y >= 1: the worst ratio never exceeds e^target, every epsilon meets it
        return math.inf
    head = Fraction(log_down(1 + r * (k - 2) - r * (k - 1) * Fraction(exp_up(-target))))
    z = Fraction(exp_down(fraction_down(y + log_r)))  # at most r e^y
    tail = Fraction(log_down(1 / (1 - z))) if z < 1 else Fraction(0)  # −ln(1 − r e^y) >= 0
    return max(0.0, fraction_down(y + head + tail))


def _is_randomized_response(family: MechanismFamily, eps: float) -> RandomizedResponse | None:
    """The family's member at ``eps`` when it is k-ary randomized response on the family's inputs, else None.

    An isinstance check (:func:`~fairaudit.laws.closed_forms.randomized_response` makes them): no k x k matrix.
    """
    m = family(eps)
    if not isinstance(m, RandomizedResponse) or not (m.inputs is family.inputs or m.inputs == family.inputs):
        return None
    return m


def _black_box_class(common: Common, metric: npt.ArrayLike | None) -> tuple[UtilityClass, str, str]:
    """The class of utilities of ``black_box_bound``, the class in words, and a note for the reason."""
    gamma, lower, tau, lip = common.gamma, common.lower, common.tau, common.lipschitz
    utility_class = UtilityClass(
        lower=lower,
        gamma=gamma,
        tau=None if math.isnan(tau) else tau,
        lipschitz=lip if lip > 0 else None,
        metric=metric if lip > 0 else None,
    )
    cls = (
        f"utilities in [{lower:g}, {gamma:g}]"
        + ("" if math.isnan(tau) else f", E[g | x, a] >= {tau:g}")
        + (f", L_A = {lip:g}" if lip > 0 else ", independent of the group")
    )
    vouched = not math.isnan(tau) and tau > lower
    note = "; tau is vouched for: it must hold behind the calibrated mechanism too" if vouched else ""
    return utility_class, cls, note


def _rr_bound(common: Common, family: MechanismFamily, metric: npt.ArrayLike | None) -> Callable[[float], float] | None:
    """The black-box value along k-ary randomized response in closed form (O(1) per ε, no k x k matrix).

    None when the family is not randomized response, or when τ binds under a metric whose distances differ
    (then the value needs the LP, ``proofs/black_box.md`` §5).
    """
    if _is_randomized_response(family, 1.0) is None:
        return None
    lower, gamma, tau, lip = common.lower, common.gamma, common.tau, common.lipschitz
    k = len(family.inputs)
    d = None if lip == 0 or metric is None else check_metric(metric, k)
    off = None if d is None else d[~np.eye(k, dtype=bool)]
    binds = not math.isnan(tau) and tau > lower
    if not (off is None or bool(np.all(off == off[0])) or not binds):
        return None
    diam = 1.0 if off is None else float(off.max())
    tau_ = None if math.isnan(tau) else tau

    def bound(eps: float) -> float:
        member = family(eps)
        assert isinstance(member, RandomizedResponse)  # (the family is randomized response)
        return rr_class_value(member.rr, lower, gamma, tau_, lip, diam)

    return bound


def black_box(
    common: Common, family: MechanismFamily, metric: npt.ArrayLike | None, population: Population | None
) -> Found:
    """The largest ε whose exact worst case over every model of the class meets the target (on L)."""
    target, gamma, lower = common.target, common.gamma, common.lower
    tau, lip = common.tau, common.lipschitz
    utility_class, cls, note = _black_box_class(common, metric)
    bound = _rr_bound(common, family, metric)
    if bound is None:
        from fairaudit.worstcase.black_box import black_box_bound  # (randomized response's closed form needs none)

        def bound(eps: float) -> float:
            return black_box_bound(family(eps), utility_class=utility_class, population=population).value

    top = bound(math.inf)
    if target >= top:
        return _every_epsilon(top, f"of {top:.6g} nats over every model, {cls}{note}")
    if (math.isnan(tau) or tau <= lower) and lip == 0:
        guess = rr_black_box_epsilon(target, len(family.inputs), lower, gamma)
        if math.isfinite(guess) and _is_randomized_response(family, guess) is not None:
            # exact in real arithmetic; the bound recomputed in floating point may exceed the target by an ulp
            return Found(
                guess,
                bound(guess),
                "exact worst case over every model, "
                f"{cls}; closed form for k-ary randomized response (proofs/black_box.md section 3){note}",
            )
    # The bound is non-decreasing along the family (post-processing): bracket, then refine.
    if lip > 0:
        f0 = bound(0.0)
        if f0 > target:
            return infeasible(
                f0,
                f"the target {target:.6g} nats is below the black-box "
                f"bound at epsilon = 0 (the attribute fully randomized), {f0:.6g} nats: a utility that "
                f"depends on the group (L_A = {lip:g}) differs across groups whatever the mechanism; no "
                "privacy budget meets it",
            )
    else:
        f0 = 0.0  # every member at ε = 0 has equal rows: all groups see the same law, L = 0
    lo, f_lo, start = 0.0, f0, max(target, 1e-3)
    if lip == 0 and target > 0:
        f_t = bound(target)  # black-box ≤ ε(M_ε) = ε for g independent of the group, so ε = target meets it
        if f_t <= target:
            lo, f_lo, start = target, f_t, 2 * target
        else:
            start = target
    return bracketed(target, bound, lo, f_lo, start, f"over every model, {cls}", note)


def _every_epsilon(top: float, worst_case: str) -> Found:
    """Every ε meets the target: even the identity (ε = inf) has the black-box worst case ``top``, ``worst_case``."""
    return Found(
        math.inf,
        top,
        f"every epsilon meets the target: even the identity (epsilon = inf) gives a worst case {worst_case}",
    )


def bracketed(
    target: float,
    bound: Callable[[float], float],
    lo: float,
    f_lo: float,
    start: float,
    what: str,
    note: str = "",
) -> Found:
    """The largest ε with ``bound(ε) ≤ target``, for a bound non-decreasing along the family (black-box).

    ``bound(lo) = f_lo ≤ target``; the bracket grows from ``start``
    (:func:`~fairaudit.worstcase.calibration_search.bracket`) and is refined
    (:func:`~fairaudit.worstcase.calibration_search.largest_meeting`). ``what`` says which worst case the bound is,
    for the reason.
    """
    found = bracket(bound, target, lo, f_lo, start)
    if found is None:
        return Found(
            EPS_MAX,
            bound(EPS_MAX),
            f"the bound stays below the target up to "
            f"epsilon = {EPS_MAX:g} nats (the largest tried); the largest epsilon is at least this{note}",
        )
    eps, value = largest_meeting(bound, target, *found)
    return Found(
        eps,
        value,
        f"exact worst case {what}; largest epsilon by bracketing (the bound is non-decreasing along the family){note}",
    )


def black_box_global(
    common: Common,
    family: MechanismFamily,
    utility: Utility | None,
    population: Population,
    context_mechanism: Mechanism | None,
    dependence: str,
) -> Found:
    """Black-box calibration on L̄ when X and A are dependent: the exact worst case over every model.

    The bound at ε is ``worst_model(family(ε), g, population=, tau=).global_fairness`` (what ``certify`` reports
    on L̄): a Charnes–Cooper LP per pair of groups, exact for any population. It is non-decreasing along
    the family (a smaller ε is a post-processing of a larger one: every model behind it is a model behind
    the larger one), so the largest ε is bracketed and refined as for L. It does not vanish at ε = 0:
    groups that live in different contexts differ whatever the mechanism, and that floor is the least any
    ε reaches. Without a utility, the class [lower, γ] of utilities of the decision is its two-decision
    extreme g ∈ {γ, lower} (the worst model's per-cell utility ranges over [lower, γ] either way).
    """
    from fairaudit.laws.utilities import from_table
    from fairaudit.worstcase.known_utility import worst_model

    target, tau, lip = common.target, common.tau, common.lipschitz
    if utility is None:
        if lip > 0:
            raise InputError(
                "utility",
                "black-box calibration on L-bar with X and A dependent and L_A > 0 needs the utility itself "
                "(a spec with [utility])",
            )
        g = from_table([common.gamma, common.lower], ("high", "low"), name="class [lower, gamma]")
    else:
        g = utility
    floor = None if math.isnan(tau) else tau

    def bound(eps: float) -> float:
        model = worst_model(family(eps), g, population=population, context_mechanism=context_mechanism, tau=floor)
        v = model.global_fairness.value
        return math.inf if math.isnan(v) else v

    cls = f"{g.name}" + ("" if math.isnan(tau) else f", E[g | x, a] >= {tau:g}")
    top = bound(math.inf)
    if target >= top:
        return _every_epsilon(top, f"on L-bar of {top:.6g} nats over every model, {cls}; {dependence}")
    f0 = bound(0.0)
    if not f0 <= target:
        return infeasible(
            f0,
            f"the target {target:.6g} nats is below the floor {f0:.6g} nats, the black-box bound on L-bar at "
            f"epsilon = 0 (the attribute fully randomized): {dependence}, so groups differ through their "
            "contexts whatever the mechanism; no privacy budget meets it",
        )
    what = f"on L-bar over every model, {cls}, with the population's dependence of X and A ({dependence})"
    return bracketed(target, bound, 0.0, f0, max(target, 1e-3), what)


# -- white-box ------------------------------------------------------------------------------------------


def white_box(
    common: Common,
    family: MechanismFamily,
    kernel: Kernel | None,
    utility: Utility | None,
    population: Population | None,
    context_mechanism: Mechanism | None,
    unparsed_decision: int | None = None,
) -> Found:
    """The largest ε such that every ε' in [0, ε] gives the model an L (L̄) that meets the target.

    The model's fairness need not be monotone in ε: a target missed at ε = 0 is infeasible
    (:func:`_white_box_floor`); otherwise a grid is scanned and its first crossing refined (:func:`_scan`).

    With ``unparsed_decision`` (an index of the kernel's decisions) the function of ε scanned and refined is the upper
    end of L (L̄) over every utility of that decision in [min g, max g], per kernel cell
    (:func:`fairaudit.metrics.utility_range.fairness_range`; ``proofs/unparsed.md`` §5); when the kernel puts no mass on
    that decision the range is a point and the function is L (L̄) itself, as without it; ``Found.unparsed`` names it.
    """
    from fairaudit.metrics.utility_range import fairness_range

    if kernel is None:
        raise InputError("kernel", "the white_box method needs a decision model (a [model] in the spec, or kernel=)")
    if utility is None:
        raise InputError("utility", "the white_box method needs the utility g")
    if unparsed_decision is not None and np.ndim(utility.values) != 1:
        raise InputError(
            "utility", "must depend on the decision only (g(u)) for unparsed_decision", np.shape(utility.values)
        )
    target, kind = common.target, common.kind
    limit = target + 1e-13 * max(1.0, target)  # rounding in the computed L (a few ulps) is not a violation
    measure = local_fairness if kind == "local" else global_fairness
    name = "L" if kind == "local" else "L-bar"

    unparsed = None if unparsed_decision is None else _decision_index(kernel, unparsed_decision)
    given = None if unparsed is None else (kernel.decisions[unparsed], (utility.lower, utility.gamma))
    if unparsed is not None and np.any(np.nan_to_num(kernel.probabilities[..., unparsed], nan=0.0) > 0):
        label = format_label(kernel.decisions[unparsed])
        name = f"upper end of {name} over every utility of {label!r} in [min g, max g]"
    else:
        unparsed = None  # (no mass on it: its utility's range is a point, the value is L itself)

    def value(eps: float) -> float:
        """L (L̄) behind ``family(eps)``, or its upper end over every utility of the unparsed decision."""
        try:
            if unparsed is None:
                law = _law(kernel, family(eps), context_mechanism)
            else:
                r = fairness_range(
                    kernel, utility, unparsed, sensitive_mechanism=family(eps), context_mechanism=context_mechanism,
                    population=population, lower_end=False,
                )  # fmt: skip
        except InputError as exc:
            raise exc.under("kernel", keep_own=True) from None
        if unparsed is None:
            v = measure(law, utility, population).value
        else:
            v = (r.local_fairness if kind == "local" else r.global_fairness).upper
        return math.inf if math.isnan(v) else v

    monotone = (
        family.mixing
        and unparsed is None
        and not utility.depends_on_group
        and (kind == "local" or population is None or _independent_and_whole(population))
    )
    f0 = value(0.0)
    if not f0 <= limit:
        why = []
        if utility.depends_on_group:
            why.append("the utility depends on the group")
        if kind == "global" and population is not None and not population.independence().independent:
            why.append("X and A are dependent in the population")
        found = _white_box_floor(target, limit, keep_grid(family), value, f0, name, why)
    else:
        found = _scan(target, limit, keep_grid(family), value, f0, name, monotone)
    return replace(found, unparsed=given)


def _independent_and_whole(population: Population) -> bool:
    """X and A exactly independent and every group with P(A = a) > 0: L̄ is then non-decreasing along a mixing
    family for a utility free of the group (``proofs/calibration.md``, Proposition 5b)."""
    from fairaudit.laws.independence import exactly_independent

    p = population.probabilities
    return bool(np.all(p.sum(axis=0) > 0)) and exactly_independent(p)


def _decision_index(kernel: Kernel, decision: int) -> int:
    """``decision`` as an index of the kernel's decisions (negative from the end), or an InputError."""
    n = len(kernel.decisions)
    if isinstance(decision, bool) or not isinstance(decision, (int, np.integer)) or not -n <= decision < n:
        raise InputError("unparsed_decision", f"must index one of the kernel's {n} decisions", decision)
    return int(decision) % n


RR_COMPOSE_LIMIT = 512  # groups; above, white-box calibration behind randomized response never builds its matrix


def _law(kernel: Kernel, member: Mechanism, context_mechanism: Mechanism | None) -> Law:
    """compose(kernel, member, M_X); behind k-ary randomized response with k > 512, without its k x k matrix.

    The closed form ``rr_law`` and the matrix product agree to rounding (a last-digit difference is possible, tested
    to 1e-12); up to :data:`RR_COMPOSE_LIMIT` groups the product is kept, so no calibration of a smaller model
    changes in its last digit.
    """
    m_x = context_mechanism if context_mechanism is not None else identity(kernel.contexts)
    if (
        len(kernel.groups) > RR_COMPOSE_LIMIT
        and isinstance(member, RandomizedResponse)
        and kernel.complete
        and tuple(member.outputs) == tuple(kernel.groups)
        and tuple(m_x.outputs) == tuple(kernel.contexts)
    ):
        return rr_law(kernel, member.rr, member.inputs, m_x)
    return compose(kernel, member, context_mechanism)


def _white_box_floor(
    target: float,
    limit: float,
    grid: FloatArray,
    value: Callable[[float], float],
    f0: float,
    name: str,
    why: list[str],
) -> Found:
    """Infeasible: the model misses the target at ε = 0; says why, and whether some larger ε meets it."""
    cause = f" ({'; '.join(why)})" if why else ""
    later = next((float(e) for e in grid[1:] if value(float(e)) <= limit), None)
    also = ""
    if later is not None:
        also = (
            f"; some larger epsilon meets it (e.g. {later:.6g} nats) but not every "
            "smaller one: the model's fairness is not monotone in epsilon"
        )
    return infeasible(
        f0,
        f"the model's {name} is {f0:.6g} nats > target "
        f"{target:.6g} already at epsilon = 0, where the attribute is fully randomized{cause}: no "
        f"privacy budget [0, epsilon] meets it{also}",
    )


def _scan(
    target: float,
    limit: float,
    grid: FloatArray,
    value: Callable[[float], float],
    f0: float,
    name: str,
    monotone: bool = False,
) -> Found:
    """The first crossing of ``limit`` on the grid (then beyond it, doubling), refined; ``value(0) = f0`` meets it.

    ``monotone``: ``value`` is proved non-decreasing in ε (``proofs/calibration.md``, Proposition 5b), so every ε
    below the crossing meets the target, and every ε does when ε = +inf does; the reason says which it rests on. The
    grid's first crossing is then found by bisection over its points (about log₂ of their number evaluated, not
    each up to it): for a non-decreasing function it is the same point.
    """
    rising = f"{name} is non-decreasing in epsilon along the family, for a utility free of the group"
    how = rising if monotone else f"first crossing of a {len(grid)}-point scan, refined"
    found: tuple[float, float, float, float] | None = None
    seen = {0: f0}  # grid index -> value
    if monotone:  # grid[meets] meets the limit; grid[fails] does not (len(grid): none seen to)
        meets, fails = 0, len(grid)
        while fails - meets > 1:
            mid = (meets + fails) // 2
            seen[mid] = value(float(grid[mid]))
            meets, fails = (mid, fails) if seen[mid] <= limit else (meets, mid)
    else:  # (the first crossing of the grid, point by point)
        fails = len(grid)
        for i in range(1, len(grid)):
            seen[i] = value(float(grid[i]))
            if not seen[i] <= limit:
                fails = i
                break
        meets = fails - 1
    lo, f_lo = float(grid[meets]), seen[meets]
    if fails < len(grid):
        found = (lo, f_lo, float(grid[fails]), seen[fails])
    else:  # no crossing on the grid: beyond it
        top = value(math.inf)
        if top <= limit:
            why_every = rising if monotone else f"no point of the {len(grid)}-point scan exceeds it"
            return Found(
                math.inf,
                top,
                f"every epsilon meets the target: the model's {name} without privacy is {top:.6g} nats and {why_every}",
            )
        found = bracket(value, limit, lo, f_lo, 2 * lo)
        if found is None:
            return Found(
                EPS_MAX,
                value(EPS_MAX),
                f"the model's {name} stays below the target "
                f"up to epsilon = {EPS_MAX:g} nats (the largest tried); the largest epsilon is at least this",
            )
        how = how if monotone else "scan, then refined"
    eps_star, reached = largest_meeting(value, target if found[1] <= target else limit, *found)
    return Found(
        eps_star,
        reached,
        f"exact {name} of the model behind the family; every epsilon in [0, {eps_star:.6g}] meets the target ({how})",
    )
