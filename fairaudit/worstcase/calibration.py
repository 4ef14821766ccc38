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

  They certify *every* (ε, δ)-DP mechanism on the groups, not only the
  family's, so they are looser than ``black_box`` for a known family. Both
  need τ when c > 0 (with c = 0, L_A = 0 and δ = 0, the extra term is 0 for
  every τ and ε = target without τ); no ε meets a target below the floor
  log(1 + c/τ).
* ``black_box`` — the exact worst case over every decision model
  (:func:`fairaudit.worstcase.black_box.black_box_bound`) of the family member M_ε. It
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
  found by scanning a grid and refining the first crossing. With
  ``unparsed_decision`` the same search runs on the upper end of L (L̄) over
  every utility of that decision (a reply that parses as no option) in
  [min g, max g], so every such utility meets the target
  (``proofs/unparsed.md`` §5).

Proofs: ``proofs/calibration.md``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Hashable, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.checks import choice, nonnegative, real
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.laws.families import MechanismFamily, randomized_response_family
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Population
from fairaudit.laws.utilities import Utility, UtilityClass, check_metric
from fairaudit.worstcase.calibration_methods import (
    Common,
    Found,
    black_box,
    black_box_global,
    closed_form,
    infeasible,
    white_box,
)

__all__ = ["METHODS", "Calibration", "calibrate", "calibrate_randomized_response", "impact_ratio_target"]

METHODS = ("paper", "tight", "black_box", "white_box")
KINDS = ("local", "global")


@dataclass(frozen=True, eq=False, kw_only=True)
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
    unparsed_decision : hashable or None
        ``white_box`` with ``unparsed_decision``: that decision's label. ε and
        ``bound`` are then the upper end over every utility of it in
        ``unparsed_range``, chosen per kernel cell. None otherwise.
    unparsed_range : tuple of float or None
        (min g, max g), the interval of that decision's utility; None without it.
    target_impact_ratio : float or None
        The target given as a worst impact ratio r (``target_impact_ratio``):
        ``target`` is then −ln r nats (:func:`impact_ratio_target`). None
        when the target was given in nats.
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
    unparsed_decision: Hashable | None = None
    unparsed_range: tuple[float, float] | None = None
    target_impact_ratio: float | None = None

    def __repr__(self) -> str:
        ratio = "" if self.target_impact_ratio is None else f" (impact ratio {self.target_impact_ratio:.6g})"
        if not self.feasible:
            return (
                f"Calibration({self.method}, {self.kind}, target={self.target:.6g}{ratio}: infeasible, {self.reason})"
            )
        return (
            f"Calibration({self.method}, {self.kind}, target={self.target:.6g}{ratio}: epsilon={self.epsilon:.6g} nats, "
            f"keep={self.keep_probability:.6g}, bound={self.bound:.6g})"
        )

    def to_dict(self) -> Report:
        """The report dictionary (the JSON of ``fairaudit calibrate``).

        Contract keys: ``epsilon`` (``"inf"`` when every ε meets the target,
        ``null`` when none does), ``keep_probability``, ``method``, ``bound``;
        then ``feasible``, ``reason``, ``target``, ``kind``, ``mechanism`` (the
        family member's name, or the family's when infeasible), ``family`` and
        the inputs ``groups``, ``gamma``, ``lower``, ``tau`` (``null`` when not
        given), ``delta``, ``lipschitz``, ``diameter``; ``target_impact_ratio``
        (the target as a worst impact ratio, ``target`` = −ln of it; ``null``
        when the target was given in nats); with an unparsed
        decision, ``unparsed``: its ``decision`` and ``range`` [min g, max g]
        (ε and ``bound`` are the upper end over its utility).

        Examples
        --------
        >>> c = calibrate_randomized_response(0.5, groups=2)
        >>> {k: c.to_dict()[k] for k in ("epsilon", "method", "feasible")}
        {'epsilon': 0.5, 'method': 'black_box', 'feasible': True}
        """
        return {
            "epsilon": number(self.epsilon),
            "keep_probability": number(self.keep_probability),
            "method": self.method,
            "bound": number(self.bound),
            "feasible": bool(self.feasible),
            "reason": self.reason,
            "target": number(self.target),
            "kind": self.kind,
            "mechanism": self.mechanism.name if self.mechanism is not None else self.family,
            "family": self.family,
            "groups": self.groups,
            "gamma": number(self.gamma),
            "lower": number(self.lower),
            "tau": number(self.tau),
            "delta": number(self.delta),
            "lipschitz": number(self.lipschitz),
            "diameter": number(self.diameter),
            "target_impact_ratio": number(self.target_impact_ratio),
        } | self._unparsed_dict()

    def _unparsed_dict(self) -> Report:
        """``{"unparsed": {"decision": ..., "range": [min g, max g]}}`` with an unparsed decision, else empty."""
        if self.unparsed_decision is None or self.unparsed_range is None:
            return {}
        return {
            "unparsed": {"decision": label(self.unparsed_decision), "range": [number(v) for v in self.unparsed_range]}
        }


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


def _resolve_family(
    family: MechanismFamily | None, groups: int | Sequence[Hashable] | None, kernel: Kernel | None
) -> MechanismFamily:
    if family is not None:
        if not isinstance(family, MechanismFamily):
            raise InputError("family", "must be a MechanismFamily", type(family).__name__)
        k = len(family.inputs)
        if k < 2:
            raise InputError("groups", "needs at least 2 groups", k)
        if groups is not None:
            given = groups if isinstance(groups, (int, numbers.Integral)) else len(list(groups))
            if int(given) != k:
                raise InputError("groups", f"must match the family's {k} groups ({family.name})", given)
        return family
    if groups is None:
        labels: Sequence[Hashable] = kernel.groups if kernel is not None else (0, 1)
    elif isinstance(groups, numbers.Integral) and not isinstance(groups, bool):
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
    if diameter is not None:
        return nonnegative(diameter, "diameter")
    if metric is None:
        return 1.0
    try:
        return float(check_metric(metric, k).max())
    except InputError as exc:
        raise InputError("metric", exc.problem, exc.value if exc.value is not InputError._missing else None) from None


def _check_constants(
    gamma: float, lower: float, tau: float | None, lipschitz: float, delta: float
) -> tuple[float, float, float | None, float, float]:
    """γ > 0, lower in [0, γ], τ in (0, γ] (or None), L_A ≥ 0 and δ in [0, 1], as floats."""
    gamma = real(gamma, "gamma", low=0.0, low_open=True, what="a finite positive number")
    lower = real(lower, "lower", low=0.0, high=gamma, what=f"a number in [0, gamma = {gamma:g}]")
    if tau is not None:
        tau = real(tau, "tau", low=0.0, high=gamma, low_open=True, what=f"a number in (0, gamma = {gamma:g}]")
    lipschitz = nonnegative(lipschitz, "lipschitz")
    delta = real(delta, "delta", low=0.0, high=1.0, what="a number in [0, 1]")
    return gamma, lower, tau, lipschitz, delta


def _check_method(method: str, common: Common, utility: Utility | None) -> None:
    """δ only for the closed forms; without τ they need a zero extra term (L_A·diam = 0, δ = 0, g free of a)."""
    delta, lipschitz, diam = common["delta"], common["lipschitz"], common["diameter"]
    if delta > 0 and method in ("black_box", "white_box"):
        raise InputError(
            "delta",
            f"describes an arbitrary (epsilon, delta)-DP mechanism; the {method} method "
            "calibrates the family itself (delta = 0): use `method` tight or paper",
            delta,
        )
    if method in ("paper", "tight") and math.isnan(common["tau"]):
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
    unparsed: tuple[Hashable, tuple[float, float]] | None = None,
) -> Calibration:
    """The :class:`Calibration` of what ``method`` found, with the family's member and keep probability at ε.

    ``unparsed``: the unparsed decision's label and the interval of its utility, when calibrated on the upper end.
    """
    mech: Mechanism | None
    if found.feasible:
        epsilon, keep, mech = found.epsilon, family.keep_probability(found.epsilon), family(found.epsilon)
    else:
        epsilon, keep, mech = math.nan, math.nan, None
    return Calibration(
        epsilon=float(epsilon),
        keep_probability=float(keep),
        method=method,
        bound=float(found.bound),
        feasible=bool(found.feasible),
        reason=found.reason,
        family=family.name,
        mechanism=mech,
        unparsed_decision=None if unparsed is None else unparsed[0],
        unparsed_range=None if unparsed is None else unparsed[1],
        **common,
    )


# -- public ---------------------------------------------------------------------------------------------


def calibrate(
    target: float | None = None,
    *,
    target_impact_ratio: float | None = None,
    kind: str = "local",
    method: str | None = None,
    family: MechanismFamily | None = None,
    groups: int | Sequence[Hashable] | None = None,
    utility_class: UtilityClass | None = None,
    delta: float = 0.0,
    kernel: Kernel | None = None,
    utility: Utility | None = None,
    population: Population | None = None,
    context_mechanism: Mechanism | None = None,
    unparsed_decision: int | None = None,
) -> Calibration:
    """The largest privacy budget ε of a mechanism family whose certificate meets ``target``.

    Parameters
    ----------
    target : float
        Target on local g-fairness L (or global L̄), nats, finite and ≥ 0.
        Required unless ``target_impact_ratio`` is given.
    target_impact_ratio : float, optional
        The target as the worst impact ratio r ∈ (0, 1] that every pair of
        groups must meet (their selection rates' ratio, within each context
        for L, pooled for L̄): ``target`` = −ln r nats
        (:func:`impact_ratio_target`; the four-fifths rule, r = 0.8, is
        ln 1.25 = 0.2231 nats). Only for a selection indicator: g ∈ {0, 1}
        (γ = 1, lower = 0, and ``utility``, if given, 0/1). Not with
        ``target``.
    kind : {"local", "global"}
        ``"global"``: the target is on L̄. The paper and tight certificates
        bound L̄ only under X ⊥ A (L̄ ≤ L); with a dependent ``population``
        they are infeasible. Black-box then calibrates the exact worst case on
        L̄ over every model (:func:`~fairaudit.worstcase.known_utility.worst_model`, what
        ``certify`` reports; for ``utility``, else the class [lower, γ]), whose
        floor at ε = 0 is positive when X and A are dependent. White-box
        computes L̄ exactly.
    method : {"paper", "tight", "black_box", "white_box"}, optional
        Default: ``white_box`` with a kernel; else ``tight`` when δ > 0
        (an arbitrary (ε, δ)-DP mechanism); else ``black_box``.
    family : MechanismFamily, optional
        The mechanisms ε ↦ M_ε on the groups; default k-ary randomized
        response (:func:`~fairaudit.laws.families.randomized_response_family`).
    groups : int or sequence of hashable, optional
        k, or the group labels (default: the kernel's groups, else 2).
    utility_class : UtilityClass, optional
        The class of utilities, each field by default:

        - ``gamma``, ``lower``: g ∈ [lower, γ], 0 ≤ lower ≤ γ, γ > 0; 1 and 0.
        - ``tau``: τ ∈ (0, γ], a lower bound on every E[g | x, a]; needed by
          ``paper`` and ``tight`` when L_A·diam > 0 or δ > 0 (or the utility
          depends on the group): otherwise their extra term is 0 and
          ε = target without τ. Optional for ``black_box``; none by default.
        - ``lipschitz``: L_A ≥ 0; 0 (g does not depend on the group).
        - ``metric``: d(a, a'), shape (k, k); the discrete metric.
        - ``diameter``: diam(A) for the closed forms; max d(a, a') (1 when
          discrete).
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
        ``white_box`` only: the index of a decision whose utility is known only within [min g, max g] (−1 for
        an experiment's ``"unparsed"``, the last). The target is then met by the upper end of L (L̄) over every
        utility of that decision, chosen per kernel cell (:func:`fairaudit.metrics.utility_range.fairness_range`), at
        every ε' ≤ ε, and ``bound`` is that upper end; a kernel that puts no mass on it gives the answer without
        it. Needs g of the decision only.

    Returns
    -------
    Calibration
        ε (+inf when every ε meets the target, NaN when none does), the keep
        probability, the method, the bound at ε, ``feasible`` and ``reason``.

    Raises
    ------
    InputError
        Naming the parameter: a negative or non-finite ``target``, neither
        or both of ``target`` and ``target_impact_ratio``, a ratio outside
        (0, 1] or with a utility that is not a 0/1 selection indicator
        (``utility`` with another value, ``gamma`` ≠ 1, ``lower`` ≠ 0), an
        unknown ``method`` or ``kind``, fewer than 2 ``groups`` (or a count
        that differs from the family's), ``gamma`` ≤ 0, ``lower`` outside
        [0, γ], ``tau`` outside (0, γ] or missing for paper/tight when
        L_A·diam > 0 or δ > 0, ``delta`` outside [0, 1] or given to
        black_box/white_box, a negative ``lipschitz``, white_box without a
        ``kernel`` or ``utility`` (the command line names ``--spec``, its
        source of both), or ``unparsed_decision`` with another method, out
        of range, or with a utility that depends on the context or group.

    Notes
    -----
    * paper (paper SI C, Theorem "main"): L ≤ ε + log(1 + c/τ) with
      c = L_A·diam(A) + δγ, so ε = target − log(1 + c/τ).
    * tight (docs/design.md "Mathematics beyond the paper", the theorem's proof): L ≤
      log(e^ε + c/τ), so ε = log(e^target − c/τ) ≥ the paper's ε.
    * black_box: the largest ε with ``black_box_bound(family(ε),
      utility_class=).value ≤ target``.
    * white_box: the largest ε such that every ε' ∈ [0, ε] has L (L̄) of
      ``compose(kernel, family(ε'), context_mechanism)`` ≤ target (a 64-point
      scan, then the first crossing refined; exact behind randomized
      response, where L is quasiconvex in ε). Not necessarily monotone: a
      target below L at ε = 0 is infeasible even if larger ε meet it.
    * white_box with ``unparsed_decision``: the same with L replaced by the upper end of its range over
      the decision's utility; the answer is the smallest white-box ε over every assignment of that utility
      (``proofs/unparsed.md`` §5).

    Proofs and the tests that check them: ``proofs/calibration.md``.

    Examples
    --------
    Two groups, g ∈ [0, 1]: the worst model's L is ε itself.

    >>> c = calibrate(0.5)
    >>> c.method, round(c.epsilon, 12), round(c.keep_probability, 6)
    ('black_box', 0.5, 0.622459)

    The tight closed form with L_A = 0.2 and τ = 0.5: ε = log(e − 0.4).

    >>> from fairaudit.laws.utilities import UtilityClass
    >>> c = calibrate(1.0, method="tight", utility_class=UtilityClass(tau=0.5, lipschitz=0.2))
    >>> round(c.epsilon, 12) == round(math.log(math.e - 0.4), 12), round(c.bound, 12)
    (True, 1.0)

    Below the floor log(1 + 0.4) = 0.336 nats nothing works:

    >>> c = calibrate(0.3, method="paper", utility_class=UtilityClass(tau=0.5, lipschitz=0.2))
    >>> c.feasible, math.isnan(c.epsilon), round(c.bound, 6)
    (False, True, 0.336472)

    With L_A = 0 and δ = 0 the extra term is 0: no τ needed, ε = target.

    >>> calibrate(0.3, method="tight").epsilon
    0.3

    A model that outputs the released group (g = 1{U = Ã}) behind binary
    randomized response has L = ε exactly, so white-box gives the target.

    >>> from fairaudit.laws.tables import Kernel
    >>> from fairaudit.laws.utilities import indicator
    >>> k = Kernel([[[1.0, 0.0], [0.0, 1.0]]], ["all"], ["a", "b"], ["a", "b"])
    >>> c = calibrate(0.7, kernel=k, utility=indicator("a", ["a", "b"]))
    >>> c.method, round(c.epsilon, 9)
    ('white_box', 0.7)

    A model that picks the released group with 0.5, the other with 0.3, and gives a reply that parses as no option
    ("unparsed", stated g = 0, known only within [0, 1]) with 0.2. Behind keep p ≥ 1/2, L is
    log((0.3 + 0.2p)/(0.5 − 0.2p)); its upper end, unparsed counted 1 in the released group's cell and 0 in the
    other's, is log((0.3 + 0.4p)/(0.7 − 0.4p)). For the target 0.5 the stated answer keeps p up to
    (0.5e^0.5 − 0.3)/(0.2(1 + e^0.5)), the upper end only up to (0.7e^0.5 − 0.3)/(0.4(1 + e^0.5)):

    >>> k = Kernel([[[0.5, 0.3, 0.2], [0.3, 0.5, 0.2]]], ["all"], ["a", "b"], ["a", "b", "unparsed"])
    >>> g = indicator("a", ["a", "b", "unparsed"])
    >>> stated, upper = calibrate(0.5, kernel=k, utility=g), calibrate(0.5, kernel=k, utility=g, unparsed_decision=-1)
    >>> T = math.exp(0.5)
    >>> [round(c.keep_probability, 9) for c in (stated, upper)], round(upper.bound, 9)
    ([0.989837325, 0.806148328], 0.5)
    >>> [round(x, 9) for x in ((0.5 * T - 0.3) / (0.2 * (1 + T)), (0.7 * T - 0.3) / (0.4 * (1 + T)))]
    [0.989837325, 0.806148328]

    The four-fifths rule as the target: every impact ratio ≥ 0.8 is L ≤ ln 1.25 nats. For two groups the
    worst model's L is ε, so ε = ln 1.25 and the keep probability is 1.25 / 2.25 = 5/9:

    >>> c = calibrate(target_impact_ratio=0.8)
    >>> c.target == math.log(1.25), c.epsilon == math.log(1.25), round(c.keep_probability, 12), c.target_impact_ratio
    (True, True, 0.555555555556, 0.8)
    """
    target = _target(target, target_impact_ratio)
    kind = choice(kind, "kind", KINDS)
    if method is not None:
        method = choice(method, "method", METHODS)
    uc = UtilityClass() if utility_class is None else utility_class
    if not isinstance(uc, UtilityClass):
        raise InputError("utility_class", "must be a UtilityClass", type(uc).__name__)
    gamma, lower, tau, lipschitz, delta = _check_constants(
        1.0 if uc.gamma is None else uc.gamma,
        0.0 if uc.lower is None else uc.lower,
        uc.tau,
        0.0 if uc.lipschitz is None else uc.lipschitz,
        delta,
    )
    metric = uc.metric
    if target_impact_ratio is not None:
        if utility is not None and not isinstance(utility, Utility):
            raise InputError("utility", "must be a Utility", type(utility).__name__)
        _check_selection(gamma, lower, utility)
        result = calibrate(
            target,
            kind=kind,
            method=method,
            family=family,
            groups=groups,
            utility_class=utility_class,
            delta=delta,
            kernel=kernel,
            utility=utility,
            population=population,
            context_mechanism=context_mechanism,
            unparsed_decision=unparsed_decision,
        )
        return dataclasses.replace(result, target_impact_ratio=float(target_impact_ratio))
    if kernel is not None and not isinstance(kernel, Kernel):
        raise InputError("kernel", "must be a Kernel", type(kernel).__name__)
    if population is not None and not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    fam = _resolve_family(family, groups, kernel)
    common = Common(
        target=target,
        kind=kind,
        groups=len(fam.inputs),
        gamma=gamma,
        lower=lower,
        tau=math.nan if tau is None else tau,
        delta=delta,
        lipschitz=lipschitz,
        diameter=_diameter(uc.diameter, metric, len(fam.inputs)),
    )
    if method is None:
        method = "white_box" if kernel is not None else ("tight" if delta > 0 else "black_box")
    _check_method(method, common, utility)
    if method == "white_box":
        if kernel is None:
            raise InputError(
                "kernel", "the white_box method needs a decision model (a [model] in the spec, or kernel=)"
            )
        if utility is None:
            raise InputError("utility", "the white_box method needs the utility g")
        if unparsed_decision is not None and np.ndim(utility.values) != 1:
            raise InputError(
                "utility", "must depend on the decision only (g(u)) for unparsed_decision", np.shape(utility.values)
            )
        found = white_box(common, fam, kernel, utility, population, context_mechanism, unparsed_decision)
        unparsed = None
        if unparsed_decision is not None:  # (a valid index: white_box checked it)
            unparsed = (kernel.decisions[unparsed_decision], (utility.lower, utility.gamma))
        return _result(common, method, found, fam, unparsed)
    if unparsed_decision is not None:
        raise InputError(
            "unparsed_decision", f"is for the white_box method (a kernel), not {method}", unparsed_decision
        )
    dependence = _dependence(kind, population)
    if dependence is None:
        found = (
            closed_form(common, method) if method in ("paper", "tight") else black_box(common, fam, metric, population)
        )
    elif method == "black_box":
        assert population is not None  # (a dependence was found in it)
        found = black_box_global(common, fam, utility, population, context_mechanism, dependence)
    else:
        found = infeasible(
            math.inf,
            f"{dependence}: the {method} certificate bounds L-bar only through L-bar <= L under "
            "X independent of A; use black_box (exact for any population) or a model (white_box)",
        )
    return _result(common, method, found, fam)


def calibrate_randomized_response(
    target: float,
    groups: int | Sequence[Hashable],
    *,
    method: str = "black_box",
    utility_class: UtilityClass | None = None,
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
    utility_class : UtilityClass, optional
        As in :func:`calibrate`: the class of utilities g ∈ [lower, γ], τ
        (needed by ``tight`` and ``paper`` when L_A > 0) and L_A.

    Returns
    -------
    Calibration

    Raises
    ------
    InputError
        As :func:`calibrate`; and ``target`` (with the reason) when no ε
        meets the target, e.g. below the floor log(1 + L_A/τ).

    Examples
    --------
    >>> c = calibrate_randomized_response(math.log(7 / 3), 2)
    >>> round(c.epsilon, 12) == round(math.log(7 / 3), 12), round(c.keep_probability, 12)
    (True, 0.7)
    """
    c = calibrate(target, groups=groups, method=method, utility_class=utility_class)
    if not c.feasible:
        raise InputError("target", c.reason, target)
    return c
