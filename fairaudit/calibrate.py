"""Calibration: the largest privacy budget ε whose certificate meets a fairness target.

This release calibrates k-ary randomized response on the sensitive attribute:

* ``black_box`` (default): the exact worst case over every decision model for
  utilities in [lower, γ] (:func:`fairaudit.worstcase.black_box_bound`). For
  k-ary randomized response the worst pair's ratio is, with t = e^ε and
  ρ = lower / γ,

      R(t) = (ρ (t + k − 1) + (1 − ρ) t) / (ρ (t + k − 1) + 1 − ρ),

  increasing in t, so R(t) = e^target solves in closed form:
  t = (T ρ (k − 1) + T (1 − ρ) − ρ (k − 1)) / (1 − T ρ) with T = e^target;
  when T ρ ≥ 1 every ε meets the target (γ / lower ≤ T).
* ``paper`` and ``tight``: the main theorem (needs τ); the bound is
  continuous and non-decreasing in ε for randomized response, so the largest
  ε is found by bisection to 1e-12.

Its price is the keep probability e^ε / (e^ε + k − 1): how often the true
attribute reaches the model. Proof of the closed form: ``proofs/black_box.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ._errors import InputError
from .bounds import paper_bound, tight_bound
from .privacy import Mechanism, keep_probability, randomized_response
from .worstcase import black_box_bound

__all__ = ["Calibration", "calibrate_randomized_response"]

METHODS = ("black_box", "tight", "paper")


@dataclass(frozen=True, eq=False)
class Calibration:
    """The largest ε of k-ary randomized response meeting a target.

    Attributes
    ----------
    target : float
        The target on local g-fairness L, in nats.
    epsilon : float
        The largest ε (nats) that meets it; +inf when every ε does.
    keep_probability : float
        e^ε / (e^ε + k − 1).
    method : {"black_box", "tight", "paper"}
    bound : float
        The certificate at that ε (equal to the target unless every ε meets it).
    groups : int
        k.
    gamma, lower, tau, delta : float
        The utility class and (for paper/tight) τ; δ is 0 for randomized response.
    mechanism : Mechanism or None
        The randomized response that realises it (None when ε is +inf).
    """

    target: float
    epsilon: float
    keep_probability: float
    method: str
    bound: float
    groups: int
    gamma: float
    lower: float
    tau: float
    delta: float
    mechanism: Mechanism | None


def _rr_black_box_epsilon(target: float, k: int, lower: float, gamma: float) -> float:
    rho = lower / gamma if gamma > 0 else 1.0
    big_t = math.exp(target)
    if big_t * rho >= 1.0:
        return math.inf
    t = (big_t * rho * (k - 1) + big_t * (1 - rho) - rho * (k - 1)) / (1 - big_t * rho)
    return math.log(max(t, 1.0))


def calibrate_randomized_response(
    target: float,
    groups: int | list,
    *,
    method: str = "black_box",
    gamma: float = 1.0,
    lower: float = 0.0,
    tau: float | None = None,
    lipschitz: float = 0.0,
) -> Calibration:
    """The largest ε of k-ary randomized response whose certificate on L meets ``target``.

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
        Needed by ``tight`` and ``paper``.
    lipschitz : float
        L_A for ``tight`` and ``paper``.

    Returns
    -------
    Calibration

    Raises
    ------
    InputError
        On a negative target, fewer than 2 groups, an unknown method, or a
        missing τ for paper/tight; or when the target is below what ε = 0
        certifies (the floor log(1 + L_A/τ) of the theorem).

    Examples
    --------
    >>> c = calibrate_randomized_response(math.log(7 / 3), 2)
    >>> round(c.epsilon, 12) == round(math.log(7 / 3), 12), round(c.keep_probability, 12)
    (True, 0.7)
    """
    if not isinstance(target, (int, float)) or math.isnan(target) or target < 0:
        raise InputError("--target", "must be a non-negative number of nats", target)
    labels = list(range(groups)) if isinstance(groups, int) else list(groups)
    k = len(labels)
    if k < 2:
        raise InputError("--groups", "randomized response needs at least 2 groups", k)
    if method not in METHODS:
        raise InputError("--method", f"must be one of {', '.join(METHODS)}", method)
    if not (0 <= lower <= gamma) or gamma <= 0:
        raise InputError("--lower", f"must satisfy 0 <= lower <= gamma = {gamma:g} and gamma > 0", lower)
    if method == "black_box":
        eps = _rr_black_box_epsilon(float(target), k, lower, gamma)
        mech = None if math.isinf(eps) else randomized_response(labels, eps)
        bound = black_box_bound(mech, lower=lower, gamma=gamma).value if mech is not None else math.log(gamma / lower) if lower > 0 else math.inf
        return Calibration(float(target), eps, keep_probability(eps, k), method, bound, k, gamma, lower,
                           math.nan if tau is None else tau, 0.0, mech)
    if tau is None:
        raise InputError("--tau", f"the {method} bound needs tau (a lower bound on E[g | x, a])")
    fn = paper_bound if method == "paper" else tight_bound

    def bound_at(eps: float) -> float:
        return fn(randomized_response(labels, eps), gamma=gamma, tau=tau, lipschitz=lipschitz).value

    floor = bound_at(0.0)
    if floor > target + 1e-12:
        raise InputError("--target", f"is below the {method} bound at epsilon = 0, {floor:.6g} nats "
                                     "(log(1 + L_A/tau)); no privacy budget meets it", target)
    lo, hi = 0.0, max(1.0, float(target))
    while bound_at(hi) <= target:
        lo, hi = hi, 2 * hi
        if hi > 700:
            return Calibration(float(target), math.inf, 1.0, method, bound_at(lo), k, gamma, lower, tau, 0.0, None)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if bound_at(mid) <= target:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * max(1.0, hi):
            break
    mech = randomized_response(labels, lo)
    return Calibration(float(target), lo, keep_probability(lo, k), method, bound_at(lo), k, gamma, lower, tau, 0.0, mech)
