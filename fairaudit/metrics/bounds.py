"""Fairness certificates from the privacy of the sensitive attribute (paper SI C).

The main theorem (paper SI C, Theorem "main"): if X ⊥ A, g ≤ γ,
E[g | x, a] ≥ τ > 0 for every (x, a), and M_A is (ε, δ)-DP, then for *any*
decision kernel behind M_A

    L̄ ≤ L ≤ ε + log(1 + (L_A·diam(A) + δγ) / τ)              ("paper")

Its proof gives the never-larger form log(e^ε + (L_A·diam(A) + δγ)/τ), and works
one pair of groups at a time, so with the pair's own hockey-stick divergence
δ_aa'(ε) and distance d(a, a')

    L ≤ max over a ≠ a' of min over ε ≥ 0 of log(e^ε + (L_A·d(a, a') + δ_aa'(ε)γ) / τ)   ("tight")

A mechanism satisfies (ε, δ(ε))-DP at every ε, so both forms are minimised
over its whole privacy profile:

* paper: min over t = e^ε ≥ 1 of log t + log(1 + (L_A·diam + γ δ(t)) / τ).
  δ(t) = max over pairs and over prefix sets S of Σ_{o∈S} (M[a,o] − t M[a',o])
  is the upper envelope of finitely many lines in t, and on each piece of
  the envelope the objective is concave in t, so the minimum is at t = 1 or
  at a breakpoint of the envelope: a pair's likelihood ratio *or* a point
  where two pairs' δ curves cross. The envelope is computed exactly
  (convex-hull trick), so no crossing is missed.
* tight: for each pair, t + (L_A d + γ δ_aa'(t)) / τ is convex and piecewise
  linear in t, so its minimum is at t = 1 or at one of the pair's ratios.

The corollary (paper SI C, Theorem "cor"): g independent of a and δ = 0 give
L̄ ≤ L ≤ ε, attained by k-ary randomized response and a model that outputs Ã.
It is also the paper and tight forms when their extra term is zero (L_A = 0,
δ = 0 at ε = ε(M)): log(1 + 0/τ) = 0 for every τ, so ``paper_bound`` and
``tight_bound`` need no τ then and return ε(M). For k-ary randomized
response both forms are closed forms (the minimum at t = 1 or t = e^ε).

For a general mechanism the minimisation over the profile is in
:mod:`fairaudit.metrics.privacy_profile`; the hypotheses each bound carries,
checked on the data given, in :mod:`fairaudit.metrics.assumptions`.

Proofs: ``proofs/main_theorem.md`` (both forms, the profile minimisation) and
``proofs/corollary.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, ratio_extremes
from fairaudit.base.checks import epsilon as check_epsilon
from fairaudit.base.checks import nonnegative
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.outward import exp_up, fraction_up, log_up
from fairaudit.laws.closed_forms import RandomizedResponse, RandomizedResponseParameters, rr_total_variation_up
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Law, Population
from fairaudit.laws.utilities import Utility, UtilityClass, check_metric
from fairaudit.metrics.assumptions import Assumption, assumptions_for

__all__ = [
    "Bound",
    "corollary_bound",
    "main_theorem",
    "main_theorem_tight",
    "paper_bound",
    "tight_bound",
]


@dataclass(frozen=True, eq=False, kw_only=True)
class Bound:
    """An upper bound on local (and, with X ⊥ A, global) g-fairness.

    Attributes
    ----------
    form : {"paper", "tight", "corollary", "black_box"}
    value : float
        The bound on L, in nats (+inf when nothing can be certified).
    epsilon : float
        The ε (nats) of the privacy profile at which the minimum is attained.
    delta : float
        δ(ε) there (for "tight", the binding pair's δ_aa'(ε)).
    group, other_group : hashable or None
        The binding pair of groups (tight and black_box), else None.
    gamma, tau, lipschitz, diameter : float
        The constants used; ``tau`` is NaN for forms that do not use it.
    mechanism : Mechanism
        M_A.
    assumptions : tuple of Assumption
        The hypotheses and whether each was checked or vouched for.
    """

    form: str
    value: float
    epsilon: float
    delta: float
    gamma: float
    tau: float
    lipschitz: float
    diameter: float
    mechanism: Mechanism
    group: Hashable | None = None
    other_group: Hashable | None = None
    assumptions: tuple[Assumption, ...] = field(default=())

    @property
    def holds(self) -> bool:
        """False when some assumption of the bound on L is violated by the data given.

        X ⊥ A (scope ``"global"``) concerns only L̄ ≤ L and does not void it.
        """
        return all(a.status != "violated" for a in self.assumptions if a.scope != "global")

    def __repr__(self) -> str:
        return f"Bound({self.form}, value={self.value:.6g} nats at epsilon={self.epsilon:.6g}, delta={self.delta:.6g})"

    def to_dict(self) -> Report:
        """The report dictionary: value, ε, δ, the binding pair of groups and whether the bound holds."""
        return {
            "value": number(self.value),
            "epsilon": number(self.epsilon),
            "delta": number(self.delta),
            "group": label(self.group),
            "other_group": label(self.other_group),
            "holds": self.holds,
        }


def _constants(gamma: float, tau: float, lipschitz: float, diameter: float) -> tuple[float, float, float, float]:
    gamma = nonnegative(gamma, "gamma")
    tau = nonnegative(tau, "tau")
    if tau <= 0:
        raise InputError("tau", "must be positive (the main theorem needs E[g | x, a] >= tau > 0)", tau)
    if tau > gamma:
        raise InputError("tau", f"cannot exceed gamma = {gamma:g} (E[g | x, a] <= max g)", tau)
    return gamma, tau, nonnegative(lipschitz, "lipschitz"), nonnegative(diameter, "diameter")


def main_theorem(
    epsilon: float, delta: float, *, gamma: float, tau: float, lipschitz: float = 0.0, diameter: float = 1.0
) -> float:
    """The paper's bound ε + log(1 + (L_A·diam(A) + δγ) / τ), in nats.

    Parameters
    ----------
    epsilon : float
        ε ≥ 0 of M_A, nats.
    delta : float
        δ in [0, 1].
    gamma : float
        Upper bound γ ≥ τ of g.
    tau : float
        Lower bound τ > 0 of every E[g | x, a].
    lipschitz, diameter : float
        L_A ≥ 0 and diam(A) ≥ 0 (1 under the discrete metric).

    Raises
    ------
    InputError
        On a negative constant, τ ≤ 0 or τ > γ.

    Notes
    -----
    Paper SI C, Theorem (main); ``proofs/main_theorem.md``.

    Examples
    --------
    >>> round(main_theorem(1.0, 0.01, gamma=1.0, tau=0.1), 12) == round(1 + math.log(1.1), 12)
    True
    """
    gamma, tau, lipschitz, diameter = _constants(gamma, tau, lipschitz, diameter)
    eps = check_epsilon(epsilon)
    delta = nonnegative(delta, "delta")
    return _paper_value(eps, _extra(lipschitz, diameter, delta, gamma, tau))


def main_theorem_tight(
    epsilon: float, delta: float, *, gamma: float, tau: float, lipschitz: float = 0.0, diameter: float = 1.0
) -> float:
    """The main theorem as its proof gives it: log(e^ε + (L_A·diam(A) + δγ) / τ), nats.

    Proof: ``proofs/tight_bound.md`` (the per-pair form; never above the paper form).

    Never larger than :func:`main_theorem`, since e^ε ≥ 1.

    Examples
    --------
    >>> main_theorem_tight(0.0, 0.0, gamma=1.0, tau=0.5)
    0.0
    >>> main_theorem_tight(1.0, 0.01, gamma=1.0, tau=0.1) <= main_theorem(1.0, 0.01, gamma=1.0, tau=0.1)
    True
    """
    gamma, tau, lipschitz, diameter = _constants(gamma, tau, lipschitz, diameter)
    eps = check_epsilon(epsilon)
    delta = nonnegative(delta, "delta")
    if math.isinf(eps):
        return math.inf
    return _tight_value(eps, _extra(lipschitz, diameter, delta, gamma, tau))


def _extra(lipschitz: float, diameter: float, delta: float, gamma: float, tau: float) -> Fraction:
    """(L_A·diam + δγ)/τ, the main theorem's extra term, as an exact rational (every float is one)."""
    if math.isinf(delta) or math.isinf(lipschitz) or math.isinf(diameter) or math.isinf(gamma):
        raise InputError("gamma", "the extra term (L_A*diam + delta*gamma)/tau must be finite")
    return (Fraction(lipschitz) * Fraction(diameter) + Fraction(delta) * Fraction(gamma)) / Fraction(tau)


def _paper_value(eps: float, x: Fraction) -> float:
    """ε + ln(1 + x), rounded up: ln of the exact rational rounded up, then the sum (proofs/outward.md §5)."""
    if math.isinf(eps):
        return math.inf
    return fraction_up(Fraction(eps) + Fraction(log_up(1 + x)))


def _tight_value(eps: float, x: Fraction) -> float:
    """ln(e^ε + x) = ε + ln(1 + x e^−ε), rounded up: e^−ε rounded up, ln rounded up, the sum rounded up."""
    if math.isinf(eps):
        return math.inf
    if x == 0:
        return eps
    return fraction_up(Fraction(eps) + Fraction(log_up(1 + x * Fraction(exp_up(-eps)))))


def _resolve(
    mechanism: Mechanism, utility_class: UtilityClass | None, utility: Utility | None
) -> tuple[float, float | None, float, npt.ArrayLike | None]:
    """(γ, τ, L_A, metric) of the class, γ and L_A taken from ``utility`` when the class leaves them out."""
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    c = UtilityClass() if utility_class is None else utility_class
    if not isinstance(c, UtilityClass):
        raise InputError("utility_class", "must be a UtilityClass", type(c).__name__)
    gamma = c.gamma
    if gamma is None:
        if utility is None:
            raise InputError("gamma", "give gamma or a utility to take it from")
        gamma = utility.gamma
    lipschitz = c.lipschitz
    if lipschitz is None:
        lipschitz = 0.0 if utility is None else utility.lipschitz(c.metric)
    return gamma, c.tau, lipschitz, c.metric


def _without_tau(
    form: str, mechanism: Mechanism, lipschitz: float, diameter: float, utility: Utility | None
) -> Assumption:
    """The τ-free case of the main theorem: its extra term is 0, so the bound is ε(M) and τ is not needed.

    With L_A·diam = 0 and δ = 0 (pure DP: δ(ε(M)) = 0 with ε(M) finite), the extra
    term log(1 + (L_A·diam + δγ)/τ) is log 1 = 0 for every τ > 0: the bound is
    ε(M), the corollary's. Otherwise τ is needed; the error says which term is
    not zero. Returns the assumption that records why τ is not needed.
    """
    why = []
    if utility is not None and utility.depends_on_group:
        why.append("the utility depends on the group")
    if lipschitz * diameter > 0:
        why.append(f"L_A*diam = {lipschitz:g}*{diameter:g} > 0")
    if math.isinf(mechanism.epsilon) and len(mechanism.inputs) > 1:
        why.append("epsilon(M) = inf: delta(epsilon) > 0 at every finite epsilon")
    if why:
        raise InputError("tau", f"the {form} bound needs tau (a lower bound on E[g | x, a]): {'; '.join(why)}")
    eps = mechanism.epsilon
    return Assumption(
        "E[g | x, a] >= tau for every model",
        "not applicable",
        f"no tau needed: L_A = 0 and delta = 0 at epsilon = {eps:.6g}, so the extra term "
        "log(1 + (L_A*diam + delta*gamma)/tau) is 0 for every tau > 0",
    )


def _bound(
    form: str,
    mechanism: Mechanism,
    constants: tuple[float, float | None, float, float],
    checked_on: tuple[Utility | None, Population | None, Law | None],
    solve: Callable[[float, float, float, float], tuple[float, float, float, tuple[Hashable, Hashable] | None]],
) -> Bound:
    """The paper or tight :class:`Bound` of constants (γ, τ, L_A, diam), checked, with its assumptions.

    Without τ it is ε(M), when the extra term is 0 (else :func:`_without_tau` raises): both forms are ε(M) then
    (0 with one input), and the tight form also names a pair attaining it. With τ, ``solve(γ, τ, L_A, diam)`` gives
    (value, ε, δ, the binding pair or None) for two inputs or more; one input gives 0.
    """
    gamma, tau, lipschitz, diameter = constants
    utility, population, law = checked_on
    n = len(mechanism.inputs)
    if tau is None:
        gamma, lipschitz = nonnegative(gamma, "gamma"), nonnegative(lipschitz, "lipschitz")
        diameter = nonnegative(diameter, "diameter")
        free = _without_tau(form, mechanism, lipschitz, diameter, utility)
        assumptions = (*assumptions_for(mechanism, None, gamma, utility, population, law), free)
        value = eps = mechanism.epsilon if n > 1 else 0.0  # the tight form: max over pairs of ε_aa', where δ_aa' = 0
        delta, tau = 0.0, math.nan
        pair = _epsilon_pair(mechanism) if form == "tight" and n > 1 else None
    else:
        gamma, tau, lipschitz, diameter = _constants(gamma, tau, lipschitz, diameter)
        assumptions = assumptions_for(mechanism, tau, gamma, utility, population, law)
        value, eps, delta, pair = (0.0, 0.0, 0.0, None) if n < 2 else solve(gamma, tau, lipschitz, diameter)
    return Bound(
        form=form,
        value=value,
        epsilon=eps,
        delta=delta,
        group=None if pair is None else pair[0],
        other_group=None if pair is None else pair[1],
        gamma=gamma,
        tau=tau,
        lipschitz=lipschitz,
        diameter=diameter,
        mechanism=mechanism,
        assumptions=assumptions,
    )


def _epsilon_pair(mechanism: Mechanism) -> tuple[Hashable, Hashable]:
    """A pair of inputs (a, a') attaining ε(M) = log max_o M[a, o] / M[a', o]."""
    if isinstance(mechanism, RandomizedResponse) or len(mechanism.inputs) < 2:
        return mechanism.inputs[0], mechanism.inputs[min(1, len(mechanism.inputs) - 1)]
    ratio, hi, lo = ratio_extremes(mechanism.matrix, axis=0)  # per output: the largest row over the smallest
    o = int(np.nanargmax(np.where(np.isnan(ratio), -np.inf, ratio)))
    a, b = int(hi[o]), int(lo[o])
    if a == b:  # every row equal on that output (ε = 0): any pair
        a, b = 0, 1
    return mechanism.inputs[a], mechanism.inputs[b]


def paper_bound(
    mechanism: Mechanism,
    *,
    utility_class: UtilityClass | None = None,
    utility: Utility | None = None,
    population: Population | None = None,
    law: Law | None = None,
) -> Bound:
    """The paper's main theorem, minimised over the mechanism's privacy profile.

    value = min over ε ≥ 0 of ε + log(1 + (L_A·diam(A) + δ(ε)γ) / τ), in nats.

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released_groups).
    utility_class : UtilityClass, optional
        The constants (``lower`` is not used):

        - ``tau``: τ > 0, the lower bound on every E[g | x, a] of the model
          behind the filter (vouched for by the caller unless ``law`` shows
          it). Not needed when the extra term is zero: with L_A = 0 (a
          utility free of the group) and a pure-DP M_A (ε(M) finite,
          δ(ε(M)) = 0) the bound without τ is ε(M), the corollary's
          (log(1 + 0/τ) = 0 for every τ > 0).
        - ``gamma``: γ ≥ max g; default ``utility.gamma``.
        - ``lipschitz``: L_A; default from ``utility`` under ``metric`` (0 for
          g independent of a, and without a utility).
        - ``diameter``: diam(A); default the largest distance of ``metric``,
          1 under the discrete metric.
    utility, population, law : optional
        When given, the assumptions are checked on them (see
        :func:`~fairaudit.metrics.assumptions.check_assumptions`).

    Returns
    -------
    Bound
        ``form = "paper"`` with the minimising ε and δ(ε) (``tau`` NaN and an
        assumption "not applicable" saying why when τ was not needed).

    Raises
    ------
    InputError
        On invalid constants (τ ≤ 0, τ > γ, negative values); without τ when
        the extra term is not zero (L_A > 0, a utility that depends on the
        group, or ε(M) = inf).

    Notes
    -----
    Paper SI C, Theorem (main); the minimisation over the profile and its
    candidate set: ``proofs/main_theorem.md``. For a general mechanism the
    envelope is that of a few pairs, checked against every pair at its
    minimiser by one pass over the pairs (``proofs/black_box.md`` §7). For
    k-ary randomized response the profile is δ(t) = [p − tq]₊ and the
    objective is concave on [1, e^ε], so the minimum is at t = 1 or t = e^ε
    (closed form, no k x k matrix).

    Examples
    --------
    Binary randomized response keeping with p = 0.7, g ∈ [0, 1]: the pure
    bound ε = ln(7/3) is the minimum here.

    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> from fairaudit.laws.utilities import UtilityClass
    >>> b = paper_bound(randomized_response(["a", "b"], keep=0.7), utility_class=UtilityClass(gamma=1.0, tau=0.2))
    >>> round(b.value, 9), round(b.epsilon, 9), b.delta
    (0.84729786, 0.84729786, 0.0)

    Without τ (L_A = 0, pure DP) the extra term is 0: the bound is ε(M).

    >>> round(paper_bound(randomized_response(["a", "b"], keep=0.7), utility_class=UtilityClass(gamma=1.0)).value, 9)
    0.84729786
    """
    gamma, tau, lipschitz, metric = _resolve(mechanism, utility_class, utility)
    diameter = utility_class.diameter if utility_class is not None else None
    if diameter is None:
        n = len(mechanism.inputs)
        diameter = 1.0 if metric is None else float(check_metric(metric, n).max()) if n > 1 else 0.0

    def solve(gamma: float, tau: float, lipschitz: float, diameter: float) -> tuple[float, float, float, None]:
        c = fraction_up(Fraction(lipschitz) * Fraction(diameter))  # L_A·diam rounded up
        if isinstance(mechanism, RandomizedResponse):
            return (*_randomized_response_minimum(mechanism.rr, _paper_value, c, 1.0, gamma, tau), None)
        from fairaudit.metrics.privacy_profile import paper_minimum  # (a matrix's: not loaded for randomized response)

        return (*paper_minimum(mechanism.matrix, gamma, tau, c), None)

    return _bound("paper", mechanism, (gamma, tau, lipschitz, diameter), (utility, population, law), solve)


def _randomized_response_minimum(
    rr: RandomizedResponseParameters,
    form: Callable[[float, Fraction], float],
    c: float,
    d: float,
    gamma: float,
    tau: float,
) -> tuple[float, float, float]:
    """(value, ε, δ) of the paper or the tight form (``form``: :func:`_paper_value` or :func:`_tight_value`) for
    k-ary randomized response, in closed form, with c·d = L_A·diam (or L_A·d(a, a')): the better of t = 1 and
    t = e^ε, t = 1 on a tie.

    Paper: δ(t) = p − tq on [1, e^ε], 0 after: log t + log(1 + (c + γ(p − tq))/τ) is concave there
    (``proofs/main_theorem.md``). Tight: every pair's h(t) = t + (L_A d + γ[p − tq]₊)/τ is convex, with kinks at e^ε
    only. Both values are rounded up, p − q from ε itself (``proofs/outward.md`` §5).
    """
    tv = rr_total_variation_up(rr.epsilon, rr.k)
    at_one = form(0.0, _extra(c, d, tv, gamma, tau))  # t = 1: δ = p − q, the total variation
    at_eps = form(rr.epsilon, _extra(c, d, 0.0, gamma, tau))  # t = e^ε: δ = 0 (the tight log(e^ε + c): no overflow)
    return (at_eps, rr.epsilon, 0.0) if at_eps < at_one else (at_one, 0.0, tv)


def tight_bound(
    mechanism: Mechanism,
    *,
    utility_class: UtilityClass | None = None,
    utility: Utility | None = None,
    population: Population | None = None,
    law: Law | None = None,
) -> Bound:
    """The main theorem's proof, pair by pair: never larger than :func:`paper_bound`.

    value = max over a ≠ a' of min over ε ≥ 0 of
    log(e^ε + (L_A·d(a, a') + δ_aa'(ε)γ) / τ), in nats, where δ_aa'(ε) =
    Σ_o [M[a, o] − e^ε M[a', o]]₊.

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released_groups).
    utility_class : UtilityClass, optional
        ``tau``, ``gamma`` and ``lipschitz`` as in :func:`paper_bound`; without
        τ (L_A = 0, pure DP: the extra term is 0) the bound is max over pairs
        of ε_aa' = ε(M). ``metric``: d(a, a'), shape (n_groups, n_groups);
        default the discrete metric (``diameter`` and ``lower`` are not used).
    utility, population, law
        As in :func:`paper_bound`.

    Returns
    -------
    Bound
        ``form = "tight"``; ``group``/``other_group`` is the binding pair,
        ``epsilon`` and ``delta`` its minimising ε and δ_aa'(ε).

    Notes
    -----
    docs/design.md "Mathematics beyond the paper"; ``proofs/tight_bound.md``. For a
    general mechanism one pass over the pairs (O(n²m) time, O(nm) memory) sets
    aside every pair that cannot reach the maximum, by an exact upper bound,
    and only the others are solved (``proofs/black_box.md`` §7). For k-ary
    randomized response every pair has δ_aa'(t) = [p − tq]₊, and the minimum
    is at t = 1 or t = e^ε, for the pair of largest d(a, a') (closed form).

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> from fairaudit.laws.utilities import UtilityClass
    >>> m, c = randomized_response(["a", "b", "c"], epsilon=1.0), UtilityClass(gamma=1.0, tau=0.2)
    >>> tight_bound(m, utility_class=c).value <= paper_bound(m, utility_class=c).value
    True
    >>> tight_bound(m, utility_class=UtilityClass(gamma=1.0)).value  # no τ needed: L_A = 0, pure DP
    1.0
    """
    gamma, tau, lipschitz, metric = _resolve(mechanism, utility_class, utility)
    n = len(mechanism.inputs)
    rr = mechanism.rr if isinstance(mechanism, RandomizedResponse) else None
    d: FloatArray | None = None
    if metric is not None:
        d = check_metric(metric, n)
        diameter = float(d.max()) if n > 1 else 0.0
    else:
        diameter = 1.0 if n > 1 else 0.0  # the discrete metric, without its n x n matrix

    def solve(gamma: float, tau: float, lipschitz: float, diameter: float) -> tuple[float, float, float, tuple]:
        if rr is not None:  # h(t) increases in d: the binding pair has the largest d (the first, as the general route)
            far = (0, 1) if d is None or lipschitz == 0 else np.unravel_index(int(np.argmax(d)), d.shape)
            a, b = int(far[0]), int(far[1])
            value, eps, delta = _randomized_response_minimum(rr, _tight_value, lipschitz, diameter, gamma, tau)
        else:
            from fairaudit.metrics.privacy_profile import tight_maximum  # (a matrix's)

            value, eps, delta, a, b = tight_maximum(mechanism.matrix, d, gamma, tau, lipschitz)
        return value, eps, delta, (mechanism.inputs[a], mechanism.inputs[b])

    return _bound("tight", mechanism, (gamma, tau, lipschitz, diameter), (utility, population, law), solve)


def corollary_bound(
    mechanism: Mechanism,
    *,
    utility: Utility | None = None,
    population: Population | None = None,
    law: Law | None = None,
) -> Bound:
    """The corollary: g independent of a and δ = 0 give L̄ ≤ L ≤ ε(M_A), in nats.

    Needs no τ: the pure-DP ratio bound holds for every expectation. When the
    utility is given and depends on the group, the corresponding assumption is
    marked violated.

    Notes
    -----
    Paper SI C, Theorem (cor); ``proofs/corollary.md``. Attained by k-ary
    randomized response and a model that outputs Ã with g = 1{u = a₀}.

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> round(corollary_bound(randomized_response(["a", "b"], keep=0.7)).value, 9)
    0.84729786
    """
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    assumptions = list(assumptions_for(mechanism, None, None, utility, population, law))
    if utility is None:
        status, detail = "vouched", "no utility table given"
    elif utility.depends_on_group:
        status, detail = "violated", "g(u, x, a) differs between groups"
    else:
        status, detail = "checked", "g does not depend on a"
    assumptions.append(Assumption("g independent of the group", status, detail))
    eps = mechanism.epsilon
    return Bound(
        form="corollary",
        value=eps,
        epsilon=eps,
        delta=0.0,
        gamma=math.nan,
        tau=math.nan,
        lipschitz=0.0,
        diameter=1.0,
        mechanism=mechanism,
        assumptions=tuple(assumptions),
    )
