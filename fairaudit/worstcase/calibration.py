"""Calibration: the largest privacy budget ε whose certificate meets a fairness target.

:func:`calibrate` moves along a one-parameter family ε ↦ M_ε of mechanisms on
the sensitive attribute (:class:`~fairaudit.laws.families.MechanismFamily`; k-ary
randomized response by default) and returns the largest ε whose certificate on
local g-fairness L (or global L̄) is at most the target, with the mechanism
that realises it and its price, the keep probability (how often the true
attribute reaches the model). Four methods, from the loosest:

* ``paper`` and ``tight`` — closed forms of the main theorem (paper SI C,
  Theorem "main"; docs/design.md "Mathematics beyond the paper"). With c = L_A·diam(A) + δγ,

      paper:  ε = target − log(1 + c/τ)
      tight:  ε = log(e^target − c/τ)

  The paper's form is L ≤ ε + log(1 + c/τ) (paper SI C), the tight one
  L ≤ log(e^ε + c/τ) (the theorem's proof), so the tight ε is at least the
  paper's. They certify *every* (ε, δ)-DP mechanism on the groups, not only the
  family's, so they are looser than ``black_box`` for a known family. Both
  need τ when c > 0 (with c = 0, L_A = 0 and δ = 0, the extra term is 0 for
  every τ and ε = target without τ); no ε meets a target below the floor
  log(1 + c/τ). They bound L̄ only through L̄ ≤ L under X ⊥ A: on L̄ with X
  and A dependent in the population they are infeasible. A population
  independent only within rounding (P(x) P(a) in floats; max |P(x, a) −
  P(x) P(a)| ≤ 1e-9 but not 0 exactly) uses L̄ ≤ L + ln F
  (:func:`fairaudit.laws.independence.independence_factor`,
  ``proofs/black_box.md`` §6): L is held to the target less ln F, and the
  bound on L̄ is L's plus ln F, as ``black_box`` does too.
* ``black_box`` — the exact worst case over every decision model
  (:func:`fairaudit.worstcase.black_box.black_box_bound`) of the family member M_ε:
  the largest ε with ``black_box_bound(family(ε), utility_class=).value`` ≤ target. It
  is non-decreasing in ε along the family (a smaller ε is a post-processing of
  a larger one: ``proofs/calibration.md`` §3), so the largest ε is found by
  a bracketing root finder (bisection safeguarded regula falsi) to 1e-11
  relative; for k-ary randomized response with τ ≤ lower and L_A = 0 the
  closed form of ``proofs/black_box.md`` §3 is used directly, and otherwise
  the bracketing evaluates the black-box value of randomized response in
  closed form (O(1) per ε, no k x k matrix). On L̄ with X and A dependent in
  the population it calibrates the exact worst case on L̄ over every model
  (:func:`~fairaudit.worstcase.known_utility.worst_model`, what ``certify``
  reports; for the utility given, else the class [lower, γ]), whose floor at
  ε = 0 is then positive.
* ``white_box`` — a known (or estimated) decision kernel: the exact L (or L̄)
  of ``compose(kernel, M_ε, M_X)``. It need not be monotone in ε, so the
  result is the largest ε such that *every* ε' in [0, ε] meets the target,
  found by scanning a grid of 64 points and refining the first crossing
  (exact behind randomized response, where L is quasiconvex in ε); a target
  below L at ε = 0 is infeasible even if larger ε meet it. With
  ``unparsed_decision`` the same search runs on the upper end of L (L̄) over
  every utility of that decision (a reply that parses as no option) in
  [min g, max g], so every such utility meets the target: the answer is the
  smallest white-box ε over every assignment of that utility
  (``proofs/unparsed.md`` §5).

Proofs: ``proofs/calibration.md``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Hashable, Sequence
from dataclasses import replace
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.checks import choice, real
from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label
from fairaudit.base.outward import fraction_down, log_up, up
from fairaudit.laws.families import MechanismFamily, randomized_response_family
from fairaudit.laws.independence import exactly_independent, independence_factor
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Population
from fairaudit.laws.utilities import Utility, UtilityClass, check_metric
from fairaudit.worstcase.calibration_methods import (
    Found,
    black_box,
    black_box_global,
    closed_form,
    infeasible,
    white_box,
)
from fairaudit.worstcase.calibration_result import Calibration, Common

__all__ = ["METHODS", "calibrate", "calibrate_randomized_response", "impact_ratio_target"]

METHODS = ("paper", "tight", "black_box", "white_box")
KINDS = ("local", "global")


# -- input checks --------------------------------------------------------------------------------------


def impact_ratio_target(ratio: float) -> float:
    """The target on L (or L̄) in nats that a worst impact ratio means for a selection indicator: −ln ``ratio``.

    For g = 1{selected}, E[g | x, a] is group a's selection rate and L is the
    log of the largest ratio of two groups' rates, so L = −ln (the lowest
    impact ratio, each group's rate over the highest), within a context for L
    and pooled over contexts for L̄. A target L ≤ −ln r is the same as every
    impact ratio ≥ r: the four-fifths rule, r = 0.8, is L ≤ ln 1.25 =
    0.2231 nats, and 1 nat is an impact ratio of e^−1 = 0.3679.

    ``ratio`` is read as the decimal it is written as (``0.8`` is 4/5) and
    ln(1/ratio) is taken of its exact reciprocal, so 0.8 gives exactly
    ``math.log(1.25)``.

    Parameters
    ----------
    ratio : float
        The worst impact ratio to meet, in (0, 1] (1: equal rates, 0 nats).

    Returns
    -------
    float
        The target in nats, ≥ 0.

    Raises
    ------
    InputError
        Field ``target_impact_ratio``: a ratio that is not a number in (0, 1].

    Examples
    --------
    >>> impact_ratio_target(0.8) == math.log(1.25), impact_ratio_target(1.0)
    (True, 0.0)
    >>> round(math.exp(-impact_ratio_target(0.5)), 12)
    0.5
    """
    ratio = real(ratio, "target_impact_ratio", low=0.0, high=1.0, low_open=True, what="an impact ratio in (0, 1]")
    return math.log(float(1 / Fraction(repr(ratio))))


def _check_selection(gamma: float, lower: float, utility: Utility | None) -> None:
    """A target impact ratio needs a selection indicator: the class g in {0, 1} (γ = 1, lower = 0), a 0/1 utility."""
    if utility is not None and not isinstance(utility, Utility):
        raise InputError("utility", "must be a Utility", type(utility).__name__)
    why = "a target impact ratio is for a selection indicator, g in {0, 1}"
    if utility is not None:
        values = np.asarray(utility.values, dtype=float)
        bad = values[(values != 0) & (values != 1)]
        if bad.size:
            raise InputError(
                "utility", f"{why}; this utility takes the value {float(bad[0]):g}: give `target` in nats", utility.name
            )
    if gamma != 1.0:
        raise InputError("gamma", f"{why}: gamma must be 1; give `target` in nats for another utility", gamma)
    if lower != 0.0:
        raise InputError("lower", f"{why}: lower must be 0; give `target` in nats for another utility", lower)


def _target(target: float | None, target_impact_ratio: float | None) -> float:
    """The target in nats: ``target`` itself, or −ln ``target_impact_ratio``; exactly one of them."""
    if target is not None and target_impact_ratio is not None:
        raise InputError(
            "target_impact_ratio", "give `target` (nats) or `target_impact_ratio`, not both", target_impact_ratio
        )
    if target_impact_ratio is not None:
        return impact_ratio_target(target_impact_ratio)
    if target is None:
        raise InputError("target", "give a target on L in nats, or `target_impact_ratio`")
    return real(target, "target", low=0.0, what="a finite non-negative number of nats")


def _resolve_family(family: MechanismFamily | None, kernel: Kernel | None) -> MechanismFamily:
    """``family`` checked, or the default: randomized response on the kernel's groups, else on 2 groups."""
    if family is None:
        return randomized_response_family(kernel.groups if kernel is not None else (0, 1))
    if not isinstance(family, MechanismFamily):
        raise InputError("family", "must be a MechanismFamily", type(family).__name__)
    if len(family.inputs) < 2:
        raise InputError("family", "needs at least 2 groups", family.name)
    return family


def _groups_family(groups: int | Sequence[Hashable]) -> MechanismFamily:
    """k-ary randomized response on k groups (labels 0 to k − 1) or on the group labels given; errors name ``groups``."""
    labels: Sequence[Hashable]
    if isinstance(groups, numbers.Integral) and not isinstance(groups, bool):
        if groups < 2:
            raise InputError("groups", "randomized response needs at least 2 groups", int(groups))
        labels = range(int(groups))  # (distinct by construction: the family skips the check)
    elif isinstance(groups, (str, bytes)) or not isinstance(groups, Sequence):
        raise InputError("groups", "must be a number of groups k >= 2 or a list of group labels", groups)
    else:
        labels = tuple(groups)
        if len(labels) < 2:
            raise InputError("groups", "randomized response needs at least 2 groups", len(labels))
    return randomized_response_family(labels)


def _diameter(diameter: float | None, metric: npt.ArrayLike | None, k: int) -> float:
    if diameter is not None:  # (non-negative: UtilityClass checked it)
        return diameter
    if metric is None:
        return 1.0
    try:
        return float(check_metric(metric, k).max())
    except InputError as exc:
        raise InputError("metric", exc.problem, exc.value if exc.value is not InputError._missing else None) from None


def _check_constants(
    gamma: float, lower: float, tau: float | None, delta: float
) -> tuple[float, float, float | None, float]:
    """γ > 0, lower in [0, γ], τ in (0, γ] (or None) and δ in [0, 1], as floats (each of the class's numbers already
    checked non-negative by :class:`~fairaudit.laws.utilities.UtilityClass`)."""
    gamma = real(gamma, "gamma", low=0.0, low_open=True, what="a finite positive number")
    lower = real(lower, "lower", low=0.0, high=gamma, what=f"a number in [0, gamma = {gamma:g}]")
    if tau is not None:
        tau = real(tau, "tau", low=0.0, high=gamma, low_open=True, what=f"a number in (0, gamma = {gamma:g}]")
    delta = real(delta, "delta", low=0.0, high=1.0, what="a number in [0, 1]")
    return gamma, lower, tau, delta


def _check_method(method: str, common: Common, utility: Utility | None) -> None:
    """δ only for the closed forms; without τ they need a zero extra term (L_A·diam = 0, δ = 0, g free of a)."""
    delta, lipschitz, diam = common.delta, common.lipschitz, common.diameter
    if delta > 0 and method in ("black_box", "white_box"):
        raise InputError(
            "delta",
            f"describes an arbitrary (epsilon, delta)-DP mechanism; the {method} method "
            "calibrates the family itself (delta = 0): use `method` tight or paper",
            delta,
        )
    if method in ("paper", "tight") and math.isnan(common.tau):
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
            raise InputError("tau", f"the {method} bound needs tau (a lower bound on E[g | x, a]): {'; '.join(why)}")


def _dependence(kind: str, population: Population | None) -> str | None:
    """For L̄ with X and A dependent in ``population``: the dependence in words; else None."""
    if kind != "global" or population is None:
        return None
    check = population.independence()
    if check.independent:
        return None
    return (
        "X and A are not independent in the population "
        f"(max |P(x, a) - P(x) P(a)| = {check.max_deviation:.3g} at context "
        f"{format_label(check.context)!r}, group {format_label(check.group)!r})"
    )


def _result(
    common: Common,
    method: str,
    found: Found,
    family: MechanismFamily,
    target_impact_ratio: float | None,
) -> Calibration:
    """The :class:`Calibration` of what ``method`` found, with the family's member and keep probability at ε.

    ``target_impact_ratio``: the target as given, when given as a worst impact ratio.
    """
    feasible, epsilon, unparsed = found.feasible, found.epsilon, found.unparsed
    return Calibration(
        epsilon=float(epsilon) if feasible else math.nan,
        keep_probability=float(family.keep_probability(epsilon)) if feasible else math.nan,
        method=method,
        bound=float(found.bound),
        feasible=bool(feasible),
        reason=found.reason,
        family=family.name,
        mechanism=family(epsilon) if feasible else None,
        unparsed_decision=None if unparsed is None else unparsed[0],
        unparsed_range=None if unparsed is None else unparsed[1],
        target_impact_ratio=target_impact_ratio,
        **vars(common),
    )


def _arguments(
    target: float | None,
    target_impact_ratio: float | None,
    kind: str,
    method: str | None,
    family: MechanismFamily | None,
    utility_class: UtilityClass | None,
    delta: float,
    kernel: Kernel | None,
    utility: Utility | None,
    population: Population | None,
) -> tuple[Common, str, MechanismFamily, npt.ArrayLike | None]:
    """Check the arguments of :func:`calibrate` and resolve the defaults: its inputs, the method, family and metric."""
    target = _target(target, target_impact_ratio)
    kind = choice(kind, "kind", KINDS)
    if method is not None:
        method = choice(method, "method", METHODS)
    uc = UtilityClass() if utility_class is None else utility_class
    if not isinstance(uc, UtilityClass):
        raise InputError("utility_class", "must be a UtilityClass", type(uc).__name__)
    gamma, lower, tau, delta = _check_constants(
        1.0 if uc.gamma is None else uc.gamma, 0.0 if uc.lower is None else uc.lower, uc.tau, delta
    )
    if target_impact_ratio is not None:
        _check_selection(gamma, lower, utility)
    if kernel is not None and not isinstance(kernel, Kernel):
        raise InputError("kernel", "must be a Kernel", type(kernel).__name__)
    if population is not None and not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    fam = _resolve_family(family, kernel)
    common = Common(
        target=target,
        kind=kind,
        groups=len(fam.inputs),
        gamma=gamma,
        lower=lower,
        tau=math.nan if tau is None else tau,
        delta=delta,
        lipschitz=0.0 if uc.lipschitz is None else uc.lipschitz,
        diameter=_diameter(uc.diameter, uc.metric, len(fam.inputs)),
    )
    if method is None:
        method = "white_box" if kernel is not None else ("tight" if delta > 0 else "black_box")
    _check_method(method, common, utility)
    return common, method, fam, uc.metric


def _certificate(
    common: Common,
    method: str,
    family: MechanismFamily,
    metric: npt.ArrayLike | None,
    utility: Utility | None,
    population: Population | None,
    context_mechanism: Mechanism | None,
) -> Found:
    """The ``paper``, ``tight`` and ``black_box`` methods; on L̄ with X and A dependent, black_box over every model."""
    dependence = _dependence(common.kind, population)
    if dependence is None:
        factor = 1.0
        if common.kind == "global" and population is not None and not exactly_independent(population.probabilities):
            factor = independence_factor(population.probabilities)
        # X and A independent only within rounding (F > 1): L-bar <= L + ln F (proofs/black_box.md §6), so L is held
        # to the target less ln F, rounded down, and the certificate on L-bar is L's plus ln F, rounded up
        inner, shift = common, 0.0
        if factor != 1.0:
            shift = log_up(factor)
            inner = replace(common, target=fraction_down(Fraction(common.target) - Fraction(shift)))
        found = (
            closed_form(inner, method) if method in ("paper", "tight") else black_box(inner, family, metric, population)
        )
        if factor == 1.0:
            return found
        return Found(
            found.epsilon,
            up(found.bound + shift),
            f"{found.reason}; X and A are independent only within rounding (F = {factor:.17g}): L-bar <= L + ln F, "
            f"so L is held to the target less ln F = {shift:.3g}",
            found.feasible,
        )
    if method == "black_box":
        assert population is not None  # (a dependence was found in it)
        return black_box_global(common, family, utility, population, context_mechanism, dependence)
    return infeasible(
        math.inf,
        f"{dependence}: the {method} certificate bounds L-bar only through L-bar <= L under "
        "X independent of A; use black_box (exact for any population) or a model (white_box)",
    )


# -- public ---------------------------------------------------------------------------------------------


def calibrate(
    target: float | None = None,
    *,
    target_impact_ratio: float | None = None,
    kind: str = "local",
    method: str | None = None,
    family: MechanismFamily | None = None,
    utility_class: UtilityClass | None = None,
    delta: float = 0.0,
    kernel: Kernel | None = None,
    utility: Utility | None = None,
    population: Population | None = None,
    context_mechanism: Mechanism | None = None,
    unparsed_decision: int | None = None,
) -> Calibration:
    """The largest privacy budget ε of a mechanism family whose certificate meets ``target``.

    The methods, and how each finds ε, are those of this module's docstring (:mod:`fairaudit.worstcase.calibration`;
    ``docs/calibrate.md`` "Methods", with examples of white-box calibration, of a reply that parses as no option and
    of a target impact ratio). Proofs and the tests that check them: ``proofs/calibration.md``.

    Parameters
    ----------
    target : float
        Target on local g-fairness L (or global L̄), nats, finite and ≥ 0.
        Required unless ``target_impact_ratio`` is given.
    target_impact_ratio : float, optional
        The target as the worst impact ratio r ∈ (0, 1] that every pair of
        groups must meet (:func:`impact_ratio_target`: ``target`` = −ln r nats;
        the four-fifths rule, r = 0.8, is ln 1.25 = 0.2231 nats). Only for a
        selection indicator: g ∈ {0, 1} (γ = 1, lower = 0, and ``utility``,
        if given, 0/1). Not with ``target``.
    kind : {"local", "global"}
        ``"global"``: the target is on L̄ (what each method then certifies, with X and A dependent in
        ``population`` or not: this module's docstring).
    method : {"paper", "tight", "black_box", "white_box"}, optional
        Default: ``white_box`` with a kernel; else ``tight`` when δ > 0
        (an arbitrary (ε, δ)-DP mechanism); else ``black_box``.
    family : MechanismFamily, optional
        The mechanisms ε ↦ M_ε on the groups, k ≥ 2 of them; default k-ary randomized response
        (:func:`~fairaudit.laws.families.randomized_response_family`) on the kernel's groups, else on 2 groups.
        For randomized response on k groups, ``family=randomized_response_family(range(k))`` (or on the group
        labels), or :func:`calibrate_randomized_response`.
    utility_class : UtilityClass, optional
        The class of utilities (:class:`~fairaudit.laws.utilities.UtilityClass` documents its fields); by
        default γ = 1, lower = 0, no τ, L_A = 0, the discrete metric, diam(A) = max d(a, a'). ``tau`` is needed by
        ``paper`` and ``tight`` when L_A·diam > 0 or δ > 0 (or the utility depends on the group): otherwise
        their extra term is 0 and ε = target without τ; it is optional for ``black_box``.
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
    unparsed_decision : int, optional
        ``white_box`` only, g of the decision only: the index of a decision whose utility is known only within
        [min g, max g] (−1 for an experiment's ``"unparsed"``, the last). The target is then met at every ε' ≤ ε by
        the upper end of L (L̄) over every utility of it (:func:`fairaudit.metrics.utility_range.fairness_range`;
        ``Calibration.unparsed_decision``); a kernel that puts no mass on it gives the answer without it.

    Returns
    -------
    Calibration
        ε, its keep probability and the bound there, ``feasible``, ``reason`` and the inputs (see the class).

    Raises
    ------
    InputError
        Naming the parameter: a negative or non-finite ``target``, neither
        or both of ``target`` and ``target_impact_ratio``, a ratio outside
        (0, 1] or with a utility that is not a 0/1 selection indicator
        (``utility`` with another value, ``gamma`` ≠ 1, ``lower`` ≠ 0), an
        unknown ``method`` or ``kind``, a ``family`` that is not a
        MechanismFamily or has fewer than 2 groups, ``gamma`` ≤ 0, ``lower`` outside
        [0, γ], ``tau`` outside (0, γ] or missing for paper/tight when
        L_A·diam > 0 or δ > 0, ``delta`` outside [0, 1] or given to
        black_box/white_box, a negative ``lipschitz``, white_box without a
        ``kernel`` or ``utility`` (the command line names ``--spec``, its
        source of both), or ``unparsed_decision`` with another method, out
        of range, or with a utility that depends on the context or group.

    Examples
    --------
    Two groups, g ∈ [0, 1]: the worst model's L is ε itself. The tight closed form with L_A = 0.2 and τ = 0.5 is
    ε = log(e − 0.4); below the floor log(1 + 0.4) = 0.336 nats nothing works.

    >>> c = calibrate(0.5)
    >>> c.method, round(c.epsilon, 12), round(c.keep_probability, 6)
    ('black_box', 0.5, 0.622459)
    >>> from fairaudit.laws.utilities import UtilityClass
    >>> c = calibrate(1.0, method="tight", utility_class=UtilityClass(tau=0.5, lipschitz=0.2))
    >>> round(c.epsilon, 12) == round(math.log(math.e - 0.4), 12), round(c.bound, 12)
    (True, 1.0)
    >>> c = calibrate(0.3, method="paper", utility_class=UtilityClass(tau=0.5, lipschitz=0.2))
    >>> c.feasible, math.isnan(c.epsilon), round(c.bound, 6)
    (False, True, 0.336472)
    >>> calibrate(0.3, method="tight").epsilon   # L_A = 0 and δ = 0: the extra term is 0, no τ needed
    0.3
    """
    common, method, fam, metric = _arguments(
        target, target_impact_ratio, kind, method, family, utility_class, delta, kernel, utility, population
    )
    if method == "white_box":
        found = white_box(common, fam, kernel, utility, population, context_mechanism, unparsed_decision)
    elif unparsed_decision is not None:
        raise InputError(
            "unparsed_decision", f"is for the white_box method (a kernel), not {method}", unparsed_decision
        )
    else:
        found = _certificate(common, method, fam, metric, utility, population, context_mechanism)
    ratio = None if target_impact_ratio is None else float(target_impact_ratio)
    return _result(common, method, found, fam, ratio)


def calibrate_randomized_response(
    target: float,
    groups: int | Sequence[Hashable],
    *,
    method: str = "black_box",
    utility_class: UtilityClass | None = None,
) -> Calibration:
    """The largest ε of k-ary randomized response whose certificate on L meets ``target``.

    Proof: ``proofs/calibration.md``.

    A thin wrapper of :func:`calibrate` (``kind="local"``,
    ``family=randomized_response_family(...)`` on the groups) that raises
    instead of returning an infeasible result.

    Parameters
    ----------
    target : float
        Target on local g-fairness, nats, ≥ 0.
    groups : int or list
        k ≥ 2 (the groups 0 to k − 1), or the list of group labels.
    method : {"black_box", "tight", "paper"}
        Which certificate; ``black_box`` is the tightest and needs no τ.
    utility_class : UtilityClass, optional
        As in :func:`calibrate`: the class of utilities g ∈ [lower, γ], τ
        (needed by ``tight`` and ``paper`` when L_A > 0) and L_A.

    Returns
    -------
    Calibration

    Raises
    ------
    InputError
        As :func:`calibrate`; ``groups`` that is not a whole number ≥ 2 or a
        list of at least 2 labels; and ``target`` (with the reason) when no ε
        meets the target, e.g. below the floor log(1 + L_A/τ).

    Examples
    --------
    >>> c = calibrate_randomized_response(math.log(7 / 3), 2)
    >>> round(c.epsilon, 12) == round(math.log(7 / 3), 12), round(c.keep_probability, 12)
    (True, 0.7)
    """
    c = calibrate(target, family=_groups_family(groups), method=method, utility_class=utility_class)
    if not c.feasible:
        raise InputError("target", c.reason, target)
    return c
