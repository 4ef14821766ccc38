"""Four-fifths with significance: an interval on the ratio of two selection rates, a test of equal rates, and the
multiplicity adjustments a bias audit states.

An impact ratio compares a category's selection rate p₁ = x₁/n₁ with the comparator's p₂ = x₂/n₂ (the highest
rate of its category type). The EEOC's Uniform Guidelines (29 CFR 1607.4(D)) read a ratio below four-fifths
together with whether the difference is statistically significant; this module gives both, and they agree:

* :func:`ratio_interval`: the melded interval on p₁/p₂ of Fay, Proschan and Brittain (2015, "Combining one-sample
  confidence procedures for inference in the two-sample case", Biometrics 71), the ratio of the two rates'
  Clopper–Pearson confidence distributions; its coverage is at least its level wherever it has been computed
  exactly (``benchmarks/bench_impact_ratio.py``); counts may be any nonnegative reals (weights, scaled counts);
* :func:`equal_rates_test`: the two-sided test of p₁ = p₂, Fisher's exact test (central: twice the smaller
  one-sided p-value, which the melded interval inverts: it excludes 1 exactly when the test rejects) or the pooled
  two-proportion z test;
* :func:`ratio_range`: the exact range of every impact ratio p_i / max_j p_j over a box of simultaneous intervals on
  the rates (proofs/impact_ratio.md);
* :func:`adjusted`: the p-values and per-interval level of an adjustment: ``"none"``, ``"holm"`` (Holm 1979 for
  the p-values; the intervals at Bonferroni's α/m, which hold simultaneously) or ``"bonferroni"``.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray
from fairaudit.base.checks import choice, level
from fairaudit.base.errors import InputError

__all__ = ["ADJUSTMENTS", "TESTS", "adjusted", "equal_rates_test", "ratio_interval", "ratio_range"]

ADJUSTMENTS = ("none", "holm", "bonferroni")
"""The multiplicity adjustments over the m ratios of a report (:func:`adjusted`)."""

TESTS = ("fisher", "z")
"""The tests of equal rates (:func:`equal_rates_test`)."""


def _below(rho: float, a1: float, b1: float, a2: float, b2: float) -> float:
    """P(W₁ ≤ ρ W₂) for independent W₁ ~ Beta(a₁, b₁), W₂ ~ Beta(a₂, b₂) (a parameter 0 is the point mass at 0,
    b = 0 at 1): the integral of W₂'s density times F₁(ρ w) up to w = min(1, 1/ρ), plus P(W₂ > 1/ρ).

    The adaptive rule is told where the mass is: its breakpoints are both betas' quantiles at the probabilities
    ``_PROBES`` (W₁'s divided by ρ). A density that is infinite at an end (a parameter below 1, from counts that are
    not whole) is integrated in s = w^a (or (1 − w)^b) there, which cancels the singular factor."""
    from scipy import integrate, special

    if a1 == 0 or (b2 == 0 and rho >= 1):  # W₁ = 0, or W₂ = 1 and ρ ≥ 1 ≥ W₁
        return 1.0
    if a2 == 0:  # W₂ = 0: W₁ ≤ 0 only at W₁ = 0, which has no mass
        return 0.0
    if b2 == 0:
        return float(special.betainc(a1, b1, rho))
    if b1 == 0:  # W₁ = 1: P(W₂ ≥ 1/ρ)
        return float(special.betaincc(a2, b2, min(1.0, 1.0 / rho)))
    end = min(1.0, 1.0 / rho)
    points = np.concatenate([special.betaincinv(a2, b2, _PROBES), special.betaincinv(a1, b1, _PROBES) / rho])
    points = np.unique(points[(points > 0) & (points < end)])
    log_norm = special.betaln(a2, b2)
    middle = float(special.betaincinv(a2, b2, 0.5)) if end == 1.0 else end / 2

    def f(w: float) -> float:  # F₁(ρ w)
        return float(special.betainc(a1, b1, rho * w))

    def piece(lo: float, hi: float, power: float, other: float, left: bool) -> float:
        """The integral over [lo, hi] of f(w) w^(a₂−1) (1 − w)^(b₂−1) / B(a₂, b₂); at a singular end (power < 1 at 0 if left,
        at 1 if not) in s = w^power (or (1 − w)^power): ds = power · w^(power−1) dw."""
        if hi <= lo:
            return 0.0
        inner = points[(points > lo) & (points < hi)]
        if power >= 1 or (not left and end < 1.0):
            return integrate.quad(
                lambda w: f(w) * math.exp((a2 - 1) * math.log(w) + (b2 - 1) * math.log1p(-w) - log_norm) if 0 < w < 1 else 0.0,
                lo, hi, points=inner, epsabs=1e-15, epsrel=1e-11, limit=400,
            )[0]  # fmt: skip
        to_w = (lambda t: t ** (1 / power)) if left else (lambda t: 1 - t ** (1 / power))
        ends = sorted(((lo if left else 1 - hi) ** power, (hi if left else 1 - lo) ** power))
        breaks = np.unique((inner if left else 1 - inner) ** power)
        return integrate.quad(
            lambda t: f(to_w(t)) * math.exp((other - 1) * math.log(1 - to_w(t) if left else to_w(t)) - log_norm) / power
            if 0 < t < 1 else 0.0,
            ends[0], ends[1], points=breaks[(breaks > ends[0]) & (breaks < ends[1])], epsabs=1e-15, epsrel=1e-11,
            limit=400,
        )[0]  # fmt: skip

    inner = piece(0.0, middle, a2, b2, True) + piece(middle, end, b2, a2, False)
    return min(1.0, inner + float(special.betaincc(a2, b2, end)))


_PROBES = np.array([1e-15, 1e-10, 1e-6, 1e-3, 0.05, 0.5, 0.95, 1 - 1e-3, 1 - 1e-6, 1 - 1e-10, 1 - 1e-15])
"""Where :func:`_below` breaks its integral: the betas' quantiles at these probabilities."""


def ratio_interval(x1: float, n1: float, x2: float, n2: float, confidence: float = 0.95) -> tuple[float, float]:
    """The melded interval on p₁/p₂ (Fay, Proschan and Brittain 2015): the ratio of two Clopper–Pearson intervals.

    Each rate's exact (Clopper–Pearson) confidence limits are the quantiles of a beta confidence distribution:
    W⁻ ~ Beta(x, n − x + 1) for the lower, W⁺ ~ Beta(x + 1, n − x) for the upper. The lower end is the α/2
    quantile of W₁⁻ / W₂⁺, the upper end the 1 − α/2 quantile of W₁⁺ / W₂⁻ (α = 1 − ``confidence``). The interval
    excludes 1 exactly when Fisher's exact test (:func:`equal_rates_test`, central) rejects p₁ = p₂ at α: the
    probability that W₁⁺ ≥ W₂⁻ is Fisher's one-sided p-value (Fay, Proschan and Brittain, §4). Its exact coverage
    is at least ``confidence`` at every pair of rates the benchmark computes (n = 20 to 2,000 per category, rates
    0.05 to 0.95, ``benchmarks/bench_impact_ratio.py``; the authors' numeric studies likewise). Counts may be any
    nonnegative reals (the betas take real parameters).

    Parameters
    ----------
    x1, n1, x2, n2 : float
        Selected and applicants of the category and of the comparator: 0 ≤ x ≤ n, n > 0 (reals allowed).
    confidence : float
        In (0, 1).

    Returns
    -------
    (lower, upper) : tuple of float
        0 ≤ lower ≤ upper ≤ inf: lower is 0 when x₁ = 0, upper is inf when x₂ = 0. Not capped at 1. The ends are
        roots found to 1e-12 relative, of integrals computed to about 1e-12 absolute (checked against Fisher's
        one-sided p-values, which are the same probabilities at ratio 1).

    Raises
    ------
    InputError
        A count outside 0 ≤ x ≤ n, n > 0, or not finite; ``confidence`` outside (0, 1).

    Examples
    --------
    3 of 10 against 8 of 10: Fisher's central p-value 0.0698 is above 0.05, so the interval holds 1; at 0.90 it
    does not (0.0698 < 0.10).

    >>> [round(v, 4) for v in ratio_interval(3, 10, 8, 10)]
    [0.0805, 1.0586]
    >>> ratio_interval(3, 10, 8, 10, confidence=0.9)[1] < 1
    True
    """
    from scipy.optimize import brentq

    for name, x, n in (("x1", x1, n1), ("x2", x2, n2)):
        if not (math.isfinite(x) and math.isfinite(n) and 0 <= x <= n and n > 0):
            raise InputError(name, f"must satisfy 0 <= selected <= applicants, applicants > 0 (applicants {n})", x)
    alpha = 1.0 - level(confidence)
    lower = (x1, n1 - x1 + 1, x2 + 1, n2 - x2)  # W₁⁻ / W₂⁺
    upper = (x1 + 1, n1 - x1, x2, n2 - x2 + 1)  # W₁⁺ / W₂⁻
    if x1 == 0 and x2 == 0:
        return 0.0, math.inf
    centre = math.log((x1 + 0.5) / (n1 + 1) / ((x2 + 0.5) / (n2 + 1)))
    ends = []
    for params, target, open_end in ((lower, alpha / 2, x1 == 0), (upper, 1 - alpha / 2, x2 == 0)):
        if open_end:  # W₁⁻ = 0: every ratio down to 0 is accepted; W₂⁻ = 0: every ratio up to inf
            ends.append(0.0 if target < 0.5 else math.inf)
            continue

        def f(log_rho: float, params: tuple[float, ...] = params, target: float = target) -> float:
            return _below(math.exp(log_rho), *params) - target

        lo, hi = centre - 1.0, centre + 1.0
        while f(lo) > 0:  # P(W₁ ≤ ρ W₂) increases with ρ from 0 to 1: widen until it brackets the target
            lo -= 2 * (centre - lo)
        while f(hi) < 0:
            hi += 2 * (hi - centre)
        ends.append(math.exp(brentq(f, lo, hi, xtol=1e-13, rtol=1e-12)))
    return ends[0], ends[1]


def equal_rates_test(x1: float, n1: float, x2: float, n2: float, test: str = "fisher") -> float:
    """The two-sided p-value of p₁ = p₂.

    Parameters
    ----------
    x1, n1, x2, n2 : float
        Selected and applicants of the two categories.
    test : {"fisher", "z"}
        Fisher's exact test (conditional on the margins; whole counts only: the caller uses ``"z"`` otherwise),
        two-sided by the central rule: twice the smaller of P(X₁ ≤ x₁) and P(X₁ ≥ x₁) under the hypergeometric law
        given the margins, capped at 1 (Fay 2010, "Confidence intervals that match Fisher's exact or Blaker's exact
        tests", Biostatistics 11; the rule :func:`ratio_interval` inverts), or the pooled two-proportion z test
        (any nonnegative counts).

    Returns
    -------
    float
        In [0, 1].

    Raises
    ------
    InputError
        ``test`` unknown, or Fisher's test on counts that are not whole.

    Examples
    --------
    >>> round(equal_rates_test(3, 10, 8, 10), 4), round(equal_rates_test(3, 10, 8, 10, "z"), 4)
    (0.0698, 0.0246)
    """
    from scipy.stats import fisher_exact, norm

    choice(test, "test", TESTS)
    if test == "fisher":
        if any(v != int(v) for v in (x1, n1, x2, n2)):
            raise InputError("test", "Fisher's exact test needs whole counts (use the z test)", (x1, n1, x2, n2))
        table = [[int(x1), int(n1 - x1)], [int(x2), int(n2 - x2)]]
        tails = (fisher_exact(table, alternative=side).pvalue for side in ("less", "greater"))
        return min(1.0, 2 * float(min(tails)))
    pooled = (x1 + x2) / (n1 + n2)
    se = math.sqrt(pooled * (1 - pooled) * (1 / n1 + 1 / n2))
    if se == 0:
        return 1.0
    return float(2 * norm.sf(abs(x1 / n1 - x2 / n2) / se))


def adjusted(p_values: npt.ArrayLike, adjustment: str = "holm") -> FloatArray:
    """The p-values adjusted for the m tests of a report.

    Parameters
    ----------
    p_values : array_like, shape (m,)
    adjustment : {"none", "holm", "bonferroni"}
        Holm's step-down (1979): the k-th smallest p-value times m − k + 1, made monotone, capped at 1; Bonferroni:
        times m, capped at 1. Both control the family-wise error rate; an interval of a report under either is at
        level 1 − α/m (Bonferroni's), so that the intervals hold simultaneously.

    Returns
    -------
    numpy.ndarray, shape (m,)

    Examples
    --------
    >>> adjusted([0.01, 0.04, 0.03], "holm").round(4).tolist()
    [0.03, 0.06, 0.06]
    """
    p = np.asarray(p_values, dtype=float)
    choice(adjustment, "adjustment", ADJUSTMENTS)
    m = p.size
    if adjustment == "none" or m == 0:
        return p.copy()
    if adjustment == "bonferroni":
        return np.minimum(p * m, 1.0)
    order = np.argsort(p, kind="stable")
    stepped = np.minimum(np.maximum.accumulate(p[order] * (m - np.arange(m))), 1.0)
    return stepped[np.argsort(order)]  # (back in the order given)


def ratio_range(lower: npt.ArrayLike, upper: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The exact range of each impact ratio p_i / max_j p_j when every rate p_j lies in [lower_j, upper_j] at once.

    With L_i = max_{j≠i} lower_j and U_i = max_{j≠i} upper_j (0 for a single category), ratio i ranges over
    [lower_i / max(lower_i, U_i), upper_i / max(upper_i, L_i)], 0/0 read as 1 (every rate 0: parity).
    proofs/impact_ratio.md proves it; linear in the number of categories (the two largest ends).

    Parameters
    ----------
    lower, upper : array_like of float, shape (k,)
        The rates' simultaneous intervals, 0 <= lower <= upper <= 1.

    Returns
    -------
    low, high : numpy.ndarray
        Each ratio's smallest and largest value over the box.

    Examples
    --------
    The highest rate, surely the highest on the box (its lower end above every other upper end), has ratio 1:

    >>> low, high = ratio_range([0.6, 0.2, 0.1], [0.8, 0.5, 0.4])
    >>> low.round(4).tolist(), high.round(4).tolist()
    ([1.0, 0.25, 0.125], [1.0, 0.8333, 0.6667])
    """
    lo, hi = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    others_lo, others_hi = _max_of_others(lo), _max_of_others(hi)
    return _parity_ratio(lo, np.maximum(lo, others_hi)), _parity_ratio(hi, np.maximum(hi, others_lo))


def _max_of_others(v: FloatArray) -> FloatArray:
    """out[i] = max over j != i of v[j] (0 for a single value), from the two largest values: linear time."""
    if v.size < 2:
        return np.zeros_like(v)
    second, top = np.partition(v, -2)[-2:]
    return np.where(np.arange(v.size) == np.argmax(v), second, top)


def _parity_ratio(num: FloatArray, den: FloatArray) -> FloatArray:
    """num / den with 0 / 0 = 1 (den >= num >= 0 here)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0)
