"""Calibration: the largest privacy budget ε whose certificate meets a fairness target.

:func:`calibrate` moves along a one-parameter family ε ↦ M_ε of mechanisms on
the sensitive attribute (:class:`~fairaudit.privacy.MechanismFamily`; k-ary
randomized response by default) and returns the largest ε whose certificate on
local g-fairness L (or global L̄) is at most the target, with the mechanism
that realises it and its price, the keep probability (how often the true
attribute reaches the model). Four methods, from the loosest:

* ``paper`` and ``tight`` — closed forms of the main theorem (paper SI C,
  Theorem "main"; docs/design.md "Mathematics beyond the paper"). With c = L_A·diam(A) + δγ,

      paper:  ε = target − log(1 + c/τ)
      tight:  ε = log(e^target − c/τ)

  They certify *every* (ε, δ)-DP mechanism on the groups, not only the
  family's, so they are looser than ``black_box`` for a known family. Both
  need τ when c > 0 (with c = 0, L_A = 0 and δ = 0, the extra term is 0 for
  every τ and ε = target without τ); no ε meets a target below the floor
  log(1 + c/τ).
* ``black_box`` — the exact worst case over every decision model
  (:func:`fairaudit.worstcase.black_box_bound`) of the family member M_ε. It
  is non-decreasing in ε along the family (a smaller ε is a post-processing of
  a larger one: ``proofs/calibration.md`` §3), so the largest ε is found by
  a bracketing root finder (bisection safeguarded regula falsi) to 1e-11
  relative; for k-ary randomized response with τ ≤ lower and L_A = 0 the
  closed form of ``proofs/black_box.md`` §3 is used directly, and otherwise
  the bracketing evaluates the black-box value of randomized response in
  closed form (O(1) per ε, no k x k matrix).
* ``white_box`` — a known (or estimated) decision kernel: the exact L (or L̄)
  of ``compose(kernel, M_ε, M_X)``. It need not be monotone in ε, so the
  result is the largest ε such that *every* ε' in [0, ε] meets the target,
  found by scanning a grid and refining the first crossing.

Proofs: ``proofs/calibration.md``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any, TypedDict

import numpy as np
import numpy.typing as npt

from ._arrays import EXP_SAFE, FloatArray, format_label
from ._errors import InputError
from .bounds import main_theorem, main_theorem_tight
from .laws import Kernel, Population, compose
from .metrics import global_fairness, local_fairness
from .privacy import Mechanism, MechanismFamily, RandomizedResponse, randomized_response_family
from .utility import Utility, check_metric
from .worstcase import _rr_class_value, black_box_bound

__all__ = ["Calibration", "calibrate", "calibrate_randomized_response", "METHODS"]

METHODS = ("paper", "tight", "black_box", "white_box")
KINDS = ("local", "global")

_RTOL = 1e-11  # relative tolerance in ε of the root finder
_ATOL = 1e-13  # absolute tolerance (for answers at or near ε = 0)
_EPS_MAX = 500.0  # largest finite ε tried (e^500 is a finite double)
_GRID = 64  # white-box scan: number of grid points
_GRID_CAP = 50.0  # white-box scan: largest ε of the grid (or where keep ≥ 1 − 1e-12)


@dataclass(frozen=True, eq=False)
class Calibration:
    """The largest ε of a family of mechanisms meeting a fairness target; repeats its inputs.

    Attributes
    ----------
    target : float
        The target on L (``kind="local"``) or L̄ (``"global"``), nats.
    kind : {"local", "global"}
    epsilon : float
        The largest ε (nats) that meets the target: +inf when every ε does,
        NaN when no ε does (``feasible`` is False).
    keep_probability : float
        The family's keep probability at ε (e^ε / (e^ε + k − 1) for k-ary
        randomized response): the price of the guarantee. NaN when infeasible.
    method : {"paper", "tight", "black_box", "white_box"}
    bound : float
        The certificate (``white_box``: the exact L or L̄ of the model) at ε,
        nats; equal to the target (up to rounding: the RR closed form may
        land 1e-16 above it, white-box allows 1e-13) unless every ε meets
        it. When infeasible,
        the smallest value any ε reaches (the floor), or +inf when nothing is
        certified.
    feasible : bool
    reason : str
        Why the target cannot be met, or which form gives ε.
    family : str
        The family's name, e.g. ``"8-ary randomized response"``.
    mechanism : Mechanism or None
        The family's member at ε (the identity when ε = +inf); None when infeasible.
    groups : int
        k, the number of groups.
    gamma, lower : float
        The utility class [lower, γ].
    tau : float
        τ, or NaN when not given.
    delta : float
        δ of an arbitrary (ε, δ)-DP mechanism (``paper`` and ``tight``); 0 otherwise.
    lipschitz, diameter : float
        L_A and diam(A) (1 under the discrete metric).
    """

    target: float
    kind: str
    epsilon: float
    keep_probability: float
    method: str
    bound: float
    feasible: bool
    reason: str
    family: str
    mechanism: Mechanism | None
    groups: int
    gamma: float
    lower: float
    tau: float
    delta: float
    lipschitz: float
    diameter: float

    def __repr__(self) -> str:
        if not self.feasible:
            return f"Calibration({self.method}, {self.kind}, target={self.target:.6g}: infeasible, {self.reason})"
        return (
            f"Calibration({self.method}, {self.kind}, target={self.target:.6g}: epsilon={self.epsilon:.6g} nats, "
            f"keep={self.keep_probability:.6g}, bound={self.bound:.6g})"
        )


class _Common(TypedDict):
    """The fields of a :class:`Calibration` that repeat its inputs, the same whatever the method finds."""

    target: float
    kind: str
    groups: int
    gamma: float
    lower: float
    tau: float
    delta: float
    lipschitz: float
    diameter: float


# -- input checks --------------------------------------------------------------------------------------


def _number(
    flag: str,
    value: float,
    *,
    low: float = 0.0,
    high: float = math.inf,
    low_open: bool = False,
    what: str = "a finite non-negative number",
) -> float:
    if isinstance(value, bool):
        raise InputError(flag, f"must be {what}", value)
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(flag, f"must be {what}", value) from None
    if not math.isfinite(v) or v < low or (low_open and v == low) or v > high:
        raise InputError(flag, f"must be {what}", value)
    return v


def _resolve_family(
    family: MechanismFamily | None, groups: int | Sequence[Hashable] | None, kernel: Kernel | None
) -> MechanismFamily:
    if family is not None:
        if not isinstance(family, MechanismFamily):
            raise InputError("family", "must be a MechanismFamily", type(family).__name__)
        k = len(family.inputs)
        if k < 2:
            raise InputError("--groups", "needs at least 2 groups", k)
        if groups is not None:
            given = groups if isinstance(groups, (int, numbers.Integral)) else len(list(groups))
            if int(given) != k:
                raise InputError("--groups", f"must match the family's {k} groups ({family.name})", given)
        return family
    if groups is None:
        labels: Sequence[Hashable] = kernel.groups if kernel is not None else (0, 1)
    elif isinstance(groups, numbers.Integral) and not isinstance(groups, bool):
        if groups < 2:
            raise InputError("--groups", "randomized response needs at least 2 groups", int(groups))
        labels = tuple(range(int(groups)))
    elif isinstance(groups, (str, bytes)) or not isinstance(groups, Sequence):
        raise InputError("--groups", "must be a number of groups k >= 2 or a list of group labels", groups)
    else:
        labels = tuple(groups)
        if len(labels) < 2:
            raise InputError("--groups", "randomized response needs at least 2 groups", len(labels))
    return randomized_response_family(labels)


def _diameter(diameter: float | None, metric: npt.ArrayLike | None, k: int) -> float:
    if diameter is not None:
        return _number("diameter", diameter)
    if metric is None:
        return 1.0
    try:
        return float(check_metric(metric, k).max())
    except InputError as exc:
        raise InputError("metric", exc.problem, exc.value if exc.value is not InputError._missing else None) from None


# -- root finding along a non-decreasing function -------------------------------------------------------


def _largest_meeting(
    f: Callable[[float], float], target: float, lo: float, f_lo: float, hi: float, f_hi: float
) -> tuple[float, float]:
    """Largest ε in [lo, hi) with f(ε) ≤ target, for f non-decreasing on [lo, hi], f(lo) ≤ target < f(hi).

    Keeps the bracket f(lo) ≤ target < f(hi) and stops when
    hi − lo ≤ 1e-11·lo + 1e-13: Illinois regula falsi, with a bisection step
    whenever two steps did not halve the bracket (so never much slower than
    bisection). Returns (lo, f(lo)).
    """
    g_lo, g_hi = f_lo - target, f_hi - target  # g_lo <= 0 < g_hi
    last = 0  # +1: the last step moved lo, -1: it moved hi
    checkpoint, count, probed = hi - lo, 0, False
    while hi - lo > _RTOL * lo + _ATOL:
        tol = _RTOL * lo + _ATOL
        bisect = False
        if count >= 2:
            bisect = hi - lo > 0.5 * checkpoint
            checkpoint, count = hi - lo, 0
        count += 1
        if g_lo == 0.0 and not probed:  # lo meets the target exactly: is it the end already?
            x, probed = lo + 0.5 * tol, True
        elif bisect or g_lo == 0.0 or not math.isfinite(g_hi):
            x = 0.5 * (lo + hi)
        else:
            x = lo + (hi - lo) * (-g_lo) / (g_hi - g_lo)
            x = min(max(x, lo + 0.25 * tol), hi - 0.25 * tol)
        fx = f(x)
        if fx <= target:
            lo, f_lo, g_lo = x, fx, fx - target
            if last == 1:
                g_hi *= 0.5  # Illinois: the same end moved twice
            last = 1
        else:
            hi, g_hi = x, fx - target
            if last == -1:
                g_lo *= 0.5
            last = -1
    return lo, f_lo


def _bracket(
    f: Callable[[float], float], target: float, lo: float, f_lo: float, start: float
) -> tuple[float, float, float, float] | None:
    """Grow hi from ``start`` (doubling) until f(hi) > target; None when f stays ≤ target up to ε = 500."""
    hi = max(start, lo + 1.0 if lo == 0 else 2 * lo)
    while True:
        f_hi = f(hi)
        if not f_hi <= target:
            return lo, f_lo, hi, f_hi
        lo, f_lo = hi, f_hi
        if hi >= _EPS_MAX:
            return None
        hi = min(2 * hi, _EPS_MAX)


# -- the four methods -----------------------------------------------------------------------------------


def _result(
    common: _Common,
    method: str,
    epsilon: float,
    bound: float,
    reason: str,
    family: MechanismFamily,
    feasible: bool = True,
) -> Calibration:
    mech: Mechanism | None
    if feasible:
        keep = family.keep_probability(epsilon)
        mech = family(epsilon)
    else:
        keep, mech, epsilon = math.nan, None, math.nan
    return Calibration(
        epsilon=float(epsilon),
        keep_probability=float(keep),
        method=method,
        bound=float(bound),
        feasible=bool(feasible),
        reason=reason,
        family=family.name,
        mechanism=mech,
        **common,
    )


def _closed_form(common: _Common, method: str, family: MechanismFamily) -> Calibration:
    target, gamma, tau = common["target"], common["gamma"], common["tau"]
    lip, diam, delta = common["lipschitz"], common["diameter"], common["delta"]
    c = lip * diam + delta * gamma
    if math.isnan(tau):  # (calibrate checked that the extra term is 0: L_A*diam = 0 and delta = 0)
        return _result(
            common,
            method,
            target,
            target,
            f"closed form of the {method} bound without tau: L_A*diam = 0 and delta = 0, so the extra term "
            "log(1 + (L_A*diam + delta*gamma)/tau) is 0 for every tau > 0 and epsilon = target; it certifies every "
            "pure epsilon-DP mechanism on the groups (looser than black_box for a known family)",
            family,
        )
    floor = math.log1p(c / tau)
    terms = f"log(1 + (L_A*diam + delta*gamma)/tau) = log(1 + ({lip:g}*{diam:g} + {delta:g}*{gamma:g})/{tau:g})"
    if target < floor * (1 - 1e-14):  # (a few ulps of rounding in the floor itself are not a violation)
        return _result(
            common,
            method,
            math.nan,
            floor,
            f"the target {target:.6g} nats is below the floor {terms} = "
            f"{floor:.6g} nats, the {method} bound at epsilon = 0: no privacy budget meets it",
            family,
            feasible=False,
        )
    if method == "paper":
        eps = max(0.0, target - floor)
        bound = main_theorem(eps, delta, gamma=gamma, tau=tau, lipschitz=lip, diameter=diam)
        form = f"epsilon = target - log(1 + (L_A*diam + delta*gamma)/tau) = {target:.6g} - {floor:.6g}"
    else:
        eps = max(0.0, target + math.log1p(-(c / tau) * math.exp(-target)))
        bound = main_theorem_tight(eps, delta, gamma=gamma, tau=tau, lipschitz=lip, diameter=diam)
        form = f"epsilon = log(e^target - (L_A*diam + delta*gamma)/tau) = log(e^{target:.6g} - {c / tau:.6g})"
    return _result(
        common,
        method,
        eps,
        bound,
        f"closed form of the {method} bound, {form}; it certifies every "
        f"(epsilon, {delta:g})-DP mechanism on the groups (looser than black_box for a known family)",
        family,
    )


def _rr_black_box_epsilon(target: float, k: int, lower: float, gamma: float) -> float:
    """Closed form of ``proofs/black_box.md`` §3: the largest ε of k-ary RR with black-box value ≤ target.

    Any target ≥ 0, however large: e^target is never formed above 700 nats (the same formula in logarithms;
    with lower = 0 it is ε = target).
    """
    rho = lower / gamma if gamma > 0 else 1.0
    if target > EXP_SAFE:  # e^target overflows a double; T0·rho < 1 needs rho < e^-700 (or 0)
        if rho == 0.0:
            return target
        if target + math.log(rho) >= 0.0:
            return math.inf
        # log t = target + log(1 + rho(k − 2) − rho(k − 1) e^-target) − log(1 − rho e^target)
        head = math.log1p(rho * (k - 2) - rho * (k - 1) * math.exp(-target))
        return max(0.0, target + head - math.log1p(-math.exp(target + math.log(rho))))
    big_t = math.exp(target)
    if big_t * rho >= 1.0:
        return math.inf
    t = (big_t * rho * (k - 1) + big_t * (1 - rho) - rho * (k - 1)) / (1 - big_t * rho)
    return math.log(max(t, 1.0))


def _is_randomized_response(family: MechanismFamily, eps: float) -> RandomizedResponse | None:
    """The family's member at ``eps`` when it is k-ary randomized response on the family's inputs, else None.

    An isinstance check (:func:`~fairaudit.privacy.randomized_response` makes them): no k x k matrix.
    """
    m = family(eps)
    if not isinstance(m, RandomizedResponse) or tuple(m.inputs) != tuple(family.inputs):
        return None
    return m


def _black_box(
    common: _Common, family: MechanismFamily, metric: npt.ArrayLike | None, population: Population | None
) -> Calibration:
    target, gamma, lower, tau, lip = (
        common["target"],
        common["gamma"],
        common["lower"],
        common["tau"],
        common["lipschitz"],
    )
    kwargs: dict[str, Any] = {"lower": lower, "gamma": gamma, "population": population}
    notes = []
    if not math.isnan(tau):
        kwargs["tau"] = tau
    if lip > 0:
        kwargs["lipschitz"] = lip
        if metric is not None:
            kwargs["metric"] = metric
    cls = (
        f"utilities in [{lower:g}, {gamma:g}]"
        + ("" if math.isnan(tau) else f", E[g | x, a] >= {tau:g}")
        + (f", L_A = {lip:g}" if lip > 0 else ", independent of the group")
    )
    if not math.isnan(tau) and tau > lower:
        notes.append("tau is vouched for: it must hold behind the calibrated mechanism too")
    note = "".join(f"; {n}" for n in notes)

    def bound(eps: float) -> float:
        return black_box_bound(family(eps), **kwargs).value

    if _is_randomized_response(family, 1.0) is not None:
        # k-ary randomized response: the black-box value in closed form, O(1) per epsilon (no k x k matrix)
        k = len(family.inputs)
        d = None if lip == 0 or metric is None else check_metric(metric, k)
        off = None if d is None else d[~np.eye(k, dtype=bool)]
        binds = not math.isnan(tau) and tau > lower
        if off is None or bool(np.all(off == off[0])) or not binds:  # (else: the LP, proofs/black_box.md §5)
            diam = 1.0 if off is None else float(off.max())
            tau_ = None if math.isnan(tau) else tau

            def bound(eps: float) -> float:
                member = family(eps)
                assert isinstance(member, RandomizedResponse)  # (the family is randomized response)
                return _rr_class_value(member.rr, lower, gamma, tau_, lip, diam)

    top = bound(math.inf)
    if target >= top:
        return _result(
            common,
            "black_box",
            math.inf,
            top,
            f"every epsilon meets the target: even the identity "
            f"(epsilon = inf) gives a worst case of {top:.6g} nats over every model, {cls}{note}",
            family,
        )
    simple = (math.isnan(tau) or tau <= lower) and lip == 0
    if simple:
        guess = _rr_black_box_epsilon(target, len(family.inputs), lower, gamma)
        if math.isfinite(guess) and _is_randomized_response(family, guess) is not None:
            # exact in real arithmetic; the bound recomputed in floating point may exceed the target by an ulp
            return _result(
                common,
                "black_box",
                guess,
                bound(guess),
                "exact worst case over every model, "
                f"{cls}; closed form for k-ary randomized response (proofs/black_box.md section 3){note}",
                family,
            )
    # The bound is non-decreasing along the family (post-processing): bracket, then refine.
    if lip > 0:
        f0 = bound(0.0)
        if f0 > target:
            return _result(
                common,
                "black_box",
                math.nan,
                f0,
                f"the target {target:.6g} nats is below the black-box "
                f"bound at epsilon = 0 (the attribute fully randomized), {f0:.6g} nats: a utility that "
                f"depends on the group (L_A = {lip:g}) differs across groups whatever the mechanism; no "
                "privacy budget meets it",
                family,
                feasible=False,
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
    return _bracketed(common, family, bound, lo, f_lo, start, f"over every model, {cls}", note)


def _bracketed(
    common: _Common,
    family: MechanismFamily,
    bound: Callable[[float], float],
    lo: float,
    f_lo: float,
    start: float,
    what: str,
    note: str = "",
) -> Calibration:
    """The largest ε with ``bound(ε) ≤ target``, for a bound non-decreasing along the family (black-box).

    ``bound(lo) = f_lo ≤ target``; the bracket grows from ``start`` (:func:`_bracket`) and is refined
    (:func:`_largest_meeting`). ``what`` says which worst case the bound is, for the reason.
    """
    target = common["target"]
    found = _bracket(bound, target, lo, f_lo, start)
    if found is None:
        return _result(
            common,
            "black_box",
            _EPS_MAX,
            bound(_EPS_MAX),
            f"the bound stays below the target up to "
            f"epsilon = {_EPS_MAX:g} nats (the largest tried); the largest epsilon is at least this{note}",
            family,
        )
    eps, value = _largest_meeting(bound, target, *found)
    return _result(
        common,
        "black_box",
        eps,
        value,
        f"exact worst case {what}; largest epsilon by bracketing (the bound is non-decreasing along the family){note}",
        family,
    )


def _black_box_global(
    common: _Common,
    family: MechanismFamily,
    utility: Utility | None,
    population: Population,
    context_mechanism: Mechanism | None,
    dependence: str,
) -> Calibration:
    """Black-box calibration on L̄ when X and A are dependent: the exact worst case over every model.

    The bound at ε is ``worst_model(family(ε), g, population=, tau=).global_`` (what ``certify`` reports
    on L̄): a Charnes–Cooper LP per pair of groups, exact for any population. It is non-decreasing along
    the family (a smaller ε is a post-processing of a larger one: every model behind it is a model behind
    the larger one), so the largest ε is bracketed and refined as for L. It does not vanish at ε = 0:
    groups that live in different contexts differ whatever the mechanism, and that floor is the least any
    ε reaches. Without a utility, the class [lower, γ] of utilities of the decision is its two-decision
    extreme g ∈ {γ, lower} (the worst model's per-cell utility ranges over [lower, γ] either way).
    """
    from .utility import from_table
    from .worstcase import worst_model

    target, tau, lip = common["target"], common["tau"], common["lipschitz"]
    if utility is None:
        if lip > 0:
            raise InputError(
                "--spec",
                "black-box calibration on L-bar with X and A dependent and L_A > 0 needs the utility itself "
                "(a spec with [utility])",
            )
        g = from_table([common["gamma"], common["lower"]], ("high", "low"), name="class [lower, gamma]")
    else:
        g = utility
    kwargs: dict[str, Any] = {"population": population, "context_mechanism": context_mechanism}
    if not math.isnan(tau):
        kwargs["tau"] = tau

    def bound(eps: float) -> float:
        v = worst_model(family(eps), g, **kwargs).global_.value
        return math.inf if math.isnan(v) else v

    cls = f"{g.name}" + ("" if math.isnan(tau) else f", E[g | x, a] >= {tau:g}")
    top = bound(math.inf)
    if target >= top:
        return _result(
            common,
            "black_box",
            math.inf,
            top,
            f"every epsilon meets the target: even the identity (epsilon = inf) gives a worst case on L-bar of "
            f"{top:.6g} nats over every model, {cls}; {dependence}",
            family,
        )
    f0 = bound(0.0)
    if not f0 <= target:
        return _result(
            common,
            "black_box",
            math.nan,
            f0,
            f"the target {target:.6g} nats is below the floor {f0:.6g} nats, the black-box bound on L-bar at "
            f"epsilon = 0 (the attribute fully randomized): {dependence}, so groups differ through their "
            "contexts whatever the mechanism; no privacy budget meets it",
            family,
            feasible=False,
        )
    what = f"on L-bar over every model, {cls}, with the population's dependence of X and A ({dependence})"
    return _bracketed(common, family, bound, 0.0, f0, max(target, 1e-3), what)


def _keep_grid(family: MechanismFamily) -> FloatArray:
    """The white-box scan: 32 values of ε evenly spaced in [0, cap], 32 more evenly spaced in keep probability.

    cap is 50 nats, or less: where the keep probability reaches 1 − 1e-12.
    """

    def keep(e: float) -> float:
        return family.keep_probability(e)

    cap = _GRID_CAP
    if keep(cap) >= 1 - 1e-12:
        lo, hi = 0.0, cap
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if keep(mid) < 1 - 1e-12 else (lo, mid)
        cap = hi
    half = _GRID // 2
    points = set(np.linspace(0.0, cap, half).tolist())
    k0, k1 = keep(0.0), keep(cap)
    for p in np.linspace(k0, k1, half + 2)[1:-1]:
        lo, hi = 0.0, cap
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if keep(mid) < p else (lo, mid)
        points.add(hi)
    return np.array(sorted(points))


def _white_box(
    common: _Common,
    family: MechanismFamily,
    kernel: Kernel,
    utility: Utility,
    population: Population | None,
    context_mechanism: Mechanism | None,
) -> Calibration:
    target, kind = common["target"], common["kind"]
    limit = target + 1e-13 * max(1.0, target)  # rounding in the computed L (a few ulps) is not a violation
    measure = local_fairness if kind == "local" else global_fairness
    name = "L" if kind == "local" else "L-bar"

    def value(eps: float) -> float:
        try:
            law = compose(kernel, family(eps), context_mechanism)
        except InputError as exc:
            raise exc.under("kernel", keep_own=True) from None
        v = measure(law, utility, population).value
        return math.inf if math.isnan(v) else v

    f0 = value(0.0)
    if not f0 <= limit:
        why = []
        if utility.depends_on_group:
            why.append("the utility depends on the group")
        if kind == "global" and population is not None and not population.independence().independent:
            why.append("X and A are dependent in the population")
        cause = f" ({'; '.join(why)})" if why else ""
        later = next((float(e) for e in _keep_grid(family)[1:] if value(float(e)) <= limit), None)
        also = (
            ""
            if later is None
            else (
                f"; some larger epsilon meets it (e.g. {later:.6g} nats) but not every "
                "smaller one: the model's fairness is not monotone in epsilon"
            )
        )
        return _result(
            common,
            "white_box",
            math.nan,
            f0,
            f"the model's {name} is {f0:.6g} nats > target "
            f"{target:.6g} already at epsilon = 0, where the attribute is fully randomized{cause}: no "
            f"privacy budget [0, epsilon] meets it{also}",
            family,
            feasible=False,
        )
    grid = _keep_grid(family)
    lo, f_lo = 0.0, f0
    for eps in grid[1:]:
        v = value(float(eps))
        if not v <= limit:
            eps_star, reached = _largest_meeting(value, target if f_lo <= target else limit, lo, f_lo, float(eps), v)
            return _result(
                common,
                "white_box",
                eps_star,
                reached,
                f"exact {name} of the model behind the family; "
                f"every epsilon in [0, {eps_star:.6g}] meets the target (first crossing of a "
                f"{len(grid)}-point scan, refined)",
                family,
            )
        lo, f_lo = float(eps), v
    top = value(math.inf)
    if top <= limit:
        return _result(
            common,
            "white_box",
            math.inf,
            top,
            f"every epsilon meets the target: the model's {name} "
            f"without privacy is {top:.6g} nats and no point of the {len(grid)}-point scan exceeds it",
            family,
        )
    found = _bracket(value, limit, lo, f_lo, 2 * lo)
    if found is None:
        return _result(
            common,
            "white_box",
            _EPS_MAX,
            value(_EPS_MAX),
            f"the model's {name} stays below the target "
            f"up to epsilon = {_EPS_MAX:g} nats (the largest tried); the largest epsilon is at least this",
            family,
        )
    eps_star, reached = _largest_meeting(value, target if found[1] <= target else limit, *found)
    return _result(
        common,
        "white_box",
        eps_star,
        reached,
        f"exact {name} of the model behind the family; every "
        f"epsilon in [0, {eps_star:.6g}] meets the target (scan, then refined)",
        family,
    )


# -- public ---------------------------------------------------------------------------------------------


def calibrate(
    target: float,
    *,
    kind: str = "local",
    method: str | None = None,
    family: MechanismFamily | None = None,
    groups: int | Sequence[Hashable] | None = None,
    gamma: float = 1.0,
    lower: float = 0.0,
    tau: float | None = None,
    lipschitz: float = 0.0,
    metric: npt.ArrayLike | None = None,
    diameter: float | None = None,
    delta: float = 0.0,
    kernel: Kernel | None = None,
    utility: Utility | None = None,
    population: Population | None = None,
    context_mechanism: Mechanism | None = None,
) -> Calibration:
    """The largest privacy budget ε of a mechanism family whose certificate meets ``target``.

    Parameters
    ----------
    target : float
        Target on local g-fairness L (or global L̄), nats, finite and ≥ 0.
    kind : {"local", "global"}
        ``"global"``: the target is on L̄. The paper and tight certificates
        bound L̄ only under X ⊥ A (L̄ ≤ L); with a dependent ``population``
        they are infeasible. Black-box then calibrates the exact worst case on
        L̄ over every model (:func:`~fairaudit.worstcase.worst_model`, what
        ``certify`` reports; for ``utility``, else the class [lower, γ]), whose
        floor at ε = 0 is positive when X and A are dependent. White-box
        computes L̄ exactly.
    method : {"paper", "tight", "black_box", "white_box"}, optional
        Default: ``white_box`` with a kernel; else ``tight`` when δ > 0
        (an arbitrary (ε, δ)-DP mechanism); else ``black_box``.
    family : MechanismFamily, optional
        The mechanisms ε ↦ M_ε on the groups; default k-ary randomized
        response (:func:`~fairaudit.privacy.randomized_response_family`).
    groups : int or sequence of hashable, optional
        k, or the group labels (default: the kernel's groups, else 2).
    gamma, lower : float
        The utility class g ∈ [lower, γ], 0 ≤ lower ≤ γ, γ > 0.
    tau : float, optional
        τ ∈ (0, γ], a lower bound on every E[g | x, a]; needed by ``paper``
        and ``tight`` when L_A·diam > 0 or δ > 0 (or the utility depends on
        the group): otherwise their extra term is 0 and ε = target without
        τ. Optional for ``black_box``.
    lipschitz : float
        L_A ≥ 0 (0: g does not depend on the group).
    metric : array_like, shape (k, k), optional
        d(a, a'); default the discrete metric.
    diameter : float, optional
        diam(A) for the closed forms; default max d(a, a') (1 when discrete).
    delta : float
        δ ∈ [0, 1] of an arbitrary (ε, δ)-DP mechanism, for ``paper`` and
        ``tight`` only.
    kernel : Kernel, optional
        P(U | X̃, Ã) over the family's inputs as groups, for ``white_box``.
    utility : Utility, optional
        g, for ``white_box``, and for ``black_box`` on L̄ with a dependent population.
    population : Population, optional
        P(X, A): excludes empty contexts, weighs L̄, and is checked for X ⊥ A.
    context_mechanism : Mechanism, optional
        M_X in front of the kernel (``white_box``, and ``black_box`` on L̄ with a dependent
        population); default the identity.

    Returns
    -------
    Calibration
        ε (+inf when every ε meets the target, NaN when none does), the keep
        probability, the method, the bound at ε, ``feasible`` and ``reason``.

    Raises
    ------
    InputError
        Naming the command-line flag: a negative or non-finite ``--target``,
        an unknown ``--method``, fewer than 2 ``--groups`` (or a count that
        differs from the family's), ``--gamma`` ≤ 0, ``--lower`` outside
        [0, γ], ``--tau`` outside (0, γ] or missing for paper/tight when
        L_A·diam > 0 or δ > 0,
        ``--delta`` outside [0, 1] or given to black_box/white_box, a negative
        ``--lipschitz``, or white_box without a kernel (``--spec``) or utility.

    Notes
    -----
    * paper (paper SI C, Theorem "main"): L ≤ ε + log(1 + c/τ) with
      c = L_A·diam(A) + δγ, so ε = target − log(1 + c/τ).
    * tight (docs/design.md "Mathematics beyond the paper", the theorem's proof): L ≤
      log(e^ε + c/τ), so ε = log(e^target − c/τ) ≥ the paper's ε.
    * black_box: the largest ε with ``black_box_bound(family(ε), lower=,
      gamma=, tau=, lipschitz=, metric=).value ≤ target``.
    * white_box: the largest ε such that every ε' ∈ [0, ε] has L (L̄) of
      ``compose(kernel, family(ε'), context_mechanism)`` ≤ target (a 64-point
      scan, then the first crossing refined; exact behind randomized
      response, where L is quasiconvex in ε). Not necessarily monotone: a
      target below L at ε = 0 is infeasible even if larger ε meet it.

    Proofs and the tests that check them: ``proofs/calibration.md``.

    Examples
    --------
    Two groups, g ∈ [0, 1]: the worst model's L is ε itself.

    >>> c = calibrate(0.5)
    >>> c.method, round(c.epsilon, 12), round(c.keep_probability, 6)
    ('black_box', 0.5, 0.622459)

    The tight closed form with L_A = 0.2 and τ = 0.5: ε = log(e − 0.4).

    >>> c = calibrate(1.0, method="tight", tau=0.5, lipschitz=0.2)
    >>> round(c.epsilon, 12) == round(math.log(math.e - 0.4), 12), round(c.bound, 12)
    (True, 1.0)

    Below the floor log(1 + 0.4) = 0.336 nats nothing works:

    >>> c = calibrate(0.3, method="paper", tau=0.5, lipschitz=0.2)
    >>> c.feasible, math.isnan(c.epsilon), round(c.bound, 6)
    (False, True, 0.336472)

    With L_A = 0 and δ = 0 the extra term is 0: no τ needed, ε = target.

    >>> calibrate(0.3, method="tight").epsilon
    0.3

    A model that outputs the released group (g = 1{U = Ã}) behind binary
    randomized response has L = ε exactly, so white-box gives the target.

    >>> from fairaudit.laws import Kernel
    >>> from fairaudit.utility import indicator
    >>> k = Kernel([[[1.0, 0.0], [0.0, 1.0]]], ["all"], ["a", "b"], ["a", "b"])
    >>> c = calibrate(0.7, kernel=k, utility=indicator("a", ["a", "b"]))
    >>> c.method, round(c.epsilon, 9)
    ('white_box', 0.7)
    """
    target = _number("--target", target, what="a finite non-negative number of nats")
    if kind not in KINDS:
        raise InputError("--global", "kind must be 'local' or 'global'", kind)
    if method is not None and method not in METHODS:
        raise InputError("--method", f"must be one of {', '.join(METHODS)}", method)
    gamma = _number("--gamma", gamma, low_open=True, what="a finite positive number")
    lower = _number("--lower", lower, high=gamma, what=f"a number in [0, gamma = {gamma:g}]")
    if tau is not None:
        tau = _number("--tau", tau, high=gamma, low_open=True, what=f"a number in (0, gamma = {gamma:g}]")
    lipschitz = _number("--lipschitz", lipschitz)
    delta = _number("--delta", delta, high=1.0, what="a number in [0, 1]")
    if kernel is not None and not isinstance(kernel, Kernel):
        raise InputError("kernel", "must be a Kernel", type(kernel).__name__)
    if population is not None and not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    fam = _resolve_family(family, groups, kernel)
    k = len(fam.inputs)
    diam = _diameter(diameter, metric, k)
    if method is None:
        method = "white_box" if kernel is not None else ("tight" if delta > 0 else "black_box")
    if delta > 0 and method in ("black_box", "white_box"):
        raise InputError(
            "--delta",
            f"describes an arbitrary (epsilon, delta)-DP mechanism; the {method} method "
            "calibrates the family itself (delta = 0): use --method tight or paper",
            delta,
        )
    if method in ("paper", "tight") and tau is None:
        # Without tau the extra term log(1 + (L_A*diam + delta*gamma)/tau) must be 0: L_A*diam = 0 and delta = 0
        why = [
            text
            for bad, text in (
                (lipschitz * diam > 0, f"L_A*diam = {lipschitz:g}*{diam:g} > 0"),
                (delta > 0, f"delta = {delta:g} > 0"),
                (utility is not None and utility.depends_on_group, "the utility depends on the group"),
            )
            if bad
        ]
        if why:
            raise InputError("--tau", f"the {method} bound needs tau (a lower bound on E[g | x, a]): {'; '.join(why)}")
    common = _Common(
        target=target,
        kind=kind,
        groups=k,
        gamma=gamma,
        lower=lower,
        tau=math.nan if tau is None else tau,
        delta=delta,
        lipschitz=lipschitz,
        diameter=diam,
    )
    if method == "white_box":
        if kernel is None:
            raise InputError(
                "--spec", "the white_box method needs a decision model (a [model] in the spec, or kernel=)"
            )
        if utility is None:
            raise InputError("utility", "the white_box method needs the utility g")
        return _white_box(common, fam, kernel, utility, population, context_mechanism)
    if kind == "global" and population is not None:
        check = population.independence()
        if not check.independent:
            dependence = (
                "X and A are not independent in the population "
                f"(max |P(x, a) - P(x) P(a)| = {check.max_deviation:.3g} at context "
                f"{format_label(check.context)!r}, group {format_label(check.group)!r})"
            )
            if method == "black_box":
                return _black_box_global(common, fam, utility, population, context_mechanism, dependence)
            return _result(
                common,
                method,
                math.nan,
                math.inf,
                f"{dependence}: the {method} certificate bounds L-bar only through L-bar <= L under "
                "X independent of A; use black_box (exact for any population) or a model (white_box)",
                fam,
                feasible=False,
            )
    if method in ("paper", "tight"):
        return _closed_form(common, method, fam)
    return _black_box(common, fam, metric, population)


def calibrate_randomized_response(
    target: float,
    groups: int | Sequence[Hashable],
    *,
    method: str = "black_box",
    gamma: float = 1.0,
    lower: float = 0.0,
    tau: float | None = None,
    lipschitz: float = 0.0,
) -> Calibration:
    """The largest ε of k-ary randomized response whose certificate on L meets ``target``.

    Proof: ``proofs/calibration.md``.

    A thin wrapper of :func:`calibrate` (``kind="local"``, the default
    family) that raises instead of returning an infeasible result.

    Parameters
    ----------
    target : float
        Target on local g-fairness, nats, ≥ 0.
    groups : int or list
        k, or the list of group labels.
    method : {"black_box", "tight", "paper"}
        Which certificate; ``black_box`` is the tightest and needs no τ.
    gamma, lower : float
        The class of utilities g(u) ∈ [lower, γ].
    tau : float, optional
        Needed by ``tight`` and ``paper`` when L_A > 0.
    lipschitz : float
        L_A.

    Returns
    -------
    Calibration

    Raises
    ------
    InputError
        As :func:`calibrate`; and ``--target`` (with the reason) when no ε
        meets the target, e.g. below the floor log(1 + L_A/τ).

    Examples
    --------
    >>> c = calibrate_randomized_response(math.log(7 / 3), 2)
    >>> round(c.epsilon, 12) == round(math.log(7 / 3), 12), round(c.keep_probability, 12)
    (True, 0.7)
    """
    c = calibrate(target, groups=groups, method=method, gamma=gamma, lower=lower, tau=tau, lipschitz=lipschitz)
    if not c.feasible:
        raise InputError("--target", c.reason, target)
    return c
