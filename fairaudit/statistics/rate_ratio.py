"""Four-fifths with significance: an interval on the ratio of two selection rates, a test of equal rates, and the
multiplicity adjustments a bias audit states.

An impact ratio compares a category's selection rate p₁ = x₁/n₁ with the comparator's p₂ = x₂/n₂ (the highest
rate of its category type). The EEOC's Uniform Guidelines (29 CFR 1607.4(D)) read a ratio below four-fifths
together with whether the difference is statistically significant; this module gives both:

* :func:`ratio_interval`: the score interval on p₁/p₂ of Miettinen and Nurminen (1985), inverting the score test of
  p₁ = θ p₂ at the constrained maximum-likelihood estimates (Koopman 1984's interval is the same without the
  variance factor N/(N − 1), ``correction=False``). Accurate at audit sizes (Fagerland, Lydersen and Laake 2015,
  "Recommended confidence intervals for two independent binomial proportions", recommend it for the ratio);
  counts may be any nonnegative reals (weights, scaled counts);
* :func:`equal_rates_test`: the two-sided test of p₁ = p₂, Fisher's exact test (whole counts) or the pooled
  two-proportion z test;
* :func:`adjusted`: the p-values and per-interval level of an adjustment: ``"none"``, ``"holm"`` (Holm 1979 for
  the p-values; the intervals at Bonferroni's α/m, which hold simultaneously) or ``"bonferroni"``.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray
from fairaudit.base.checks import level
from fairaudit.base.errors import InputError

__all__ = ["ADJUSTMENTS", "TESTS", "adjusted", "equal_rates_test", "ratio_interval", "score_statistic"]

ADJUSTMENTS = ("none", "holm", "bonferroni")
"""The multiplicity adjustments over the m ratios of a report (:func:`adjusted`)."""

TESTS = ("fisher", "z")
"""The tests of equal rates (:func:`equal_rates_test`)."""


def score_statistic(
    theta: npt.ArrayLike,
    x1: npt.ArrayLike,
    n1: npt.ArrayLike,
    x2: npt.ArrayLike,
    n2: npt.ArrayLike,
    correction: bool = True,
) -> FloatArray:
    """The score statistic z of H₀: p₁/p₂ = θ (Miettinen and Nurminen 1985, eq. 7; Koopman 1984 without ``correction``).

    z = (p̂₁ − θ p̂₂) / sqrt((p̃₁(1 − p̃₁)/n₁ + θ² p̃₂(1 − p̃₂)/n₂) · N/(N − 1)), with p̃₂ the maximum-likelihood
    estimate of p₂ under H₀ (the smaller root of N θ p² − (n₁θ + x₁ + n₂ + x₂θ) p + x₁ + x₂ = 0) and p̃₁ = θ p̃₂;
    N = n₁ + n₂. Decreasing in θ. Broadcasts; ±inf where the variance is 0 and the numerator is not, 0 where both are.

    Parameters
    ----------
    theta : array_like, > 0
        The ratio under test.
    x1, n1, x2, n2 : array_like
        Selected and applicants of the two categories: 0 ≤ x ≤ n, n > 0 (reals allowed).
    correction : bool
        Miettinen and Nurminen's variance factor N/(N − 1) (False: Koopman's statistic, whose square is his χ²).

    Returns
    -------
    numpy.ndarray of float

    Examples
    --------
    >>> round(float(score_statistic(1.0, 36, 40, 16, 80, correction=False)), 4)  # 0.9 vs 0.2: the pooled z test
    7.2947
    """
    t, a, m, b, n = (np.asarray(v, dtype=float) for v in (theta, x1, n1, x2, n2))
    big = m + n
    qa = big * t
    qb = -(m * t + a + n + b * t)
    qc = a + b
    root = np.sqrt(np.maximum(qb * qb - 4 * qa * qc, 0.0))
    p2 = np.clip((-qb - root) / (2 * qa), 0.0, 1.0)
    p1 = np.clip(t * p2, 0.0, 1.0)
    variance = p1 * (1 - p1) / m + t * t * p2 * (1 - p2) / n
    if correction:
        variance = variance * big / (big - 1)
    diff = a / m - t * b / n
    with np.errstate(divide="ignore", invalid="ignore"):
        z = diff / np.sqrt(variance)
        return np.where(variance > 0, z, np.where(diff == 0, 0.0, np.sign(diff) * np.inf))


def ratio_interval(
    x1: float, n1: float, x2: float, n2: float, confidence: float = 0.95, correction: bool = True
) -> tuple[float, float]:
    """The score interval on p₁/p₂ (Miettinen and Nurminen 1985; Koopman 1984 with ``correction=False``).

    The θ whose two-sided score test (:func:`score_statistic`) does not reject at level 1 − ``confidence``.

    Parameters
    ----------
    x1, n1, x2, n2 : float
        Selected and applicants of the category and of the comparator: 0 ≤ x ≤ n, n > 0 (reals allowed).
    confidence : float
        In (0, 1).
    correction : bool
        Miettinen and Nurminen's N/(N − 1) (the default) or Koopman's interval.

    Returns
    -------
    (lower, upper) : tuple of float
        0 ≤ lower ≤ upper ≤ inf: lower is 0 when x₁ = 0, upper is inf when x₂ = 0. Not capped at 1.

    Raises
    ------
    InputError
        A count outside 0 ≤ x ≤ n, n > 0, or not finite; ``confidence`` outside (0, 1).

    Examples
    --------
    Koopman's (1984) example, 36 of 40 against 16 of 80: his interval (2.94, 7.15).

    >>> [round(v, 4) for v in ratio_interval(36, 40, 16, 80, correction=False)]
    [2.9396, 7.1522]
    """
    from scipy.optimize import brentq
    from scipy.stats import norm

    for name, x, n in (("x1", x1, n1), ("x2", x2, n2)):
        if not (math.isfinite(x) and math.isfinite(n) and 0 <= x <= n and n > 0):
            raise InputError(name, f"must satisfy 0 <= selected <= applicants, applicants > 0 (applicants {n})", x)
    z = float(norm.isf((1 - level(confidence)) / 2))

    def f(log_theta: float, target: float) -> float:
        return float(score_statistic(math.exp(log_theta), x1, n1, x2, n2, correction)) - target

    if x1 == 0 and x2 == 0:
        return 0.0, math.inf
    centre = math.log(x1 / n1 / (x2 / n2)) if x1 > 0 and x2 > 0 else 0.0
    ends = []
    for target, open_end in ((z, x1 == 0), (-z, x2 == 0)):
        if open_end:  # x₁ = 0: every θ down to 0 is accepted; x₂ = 0: every θ up to inf
            ends.append(0.0 if target > 0 else math.inf)
            continue
        lo = hi = centre
        for width in 2.0 ** np.arange(12):  # z decreases in θ: widen until f changes sign (e^4095 is far enough)
            if f(lo, target) > 0 and f(hi, target) < 0:
                break
            lo, hi = (lo - width if f(lo, target) <= 0 else lo), (hi + width if f(hi, target) >= 0 else hi)
        ends.append(math.exp(brentq(f, lo, hi, args=(target,), xtol=1e-14, rtol=1e-12)))
    return ends[0], ends[1]


def equal_rates_test(x1: float, n1: float, x2: float, n2: float, test: str = "fisher") -> float:
    """The two-sided p-value of p₁ = p₂.

    Parameters
    ----------
    x1, n1, x2, n2 : float
        Selected and applicants of the two categories.
    test : {"fisher", "z"}
        Fisher's exact test (conditional on the margins; whole counts only: the caller uses ``"z"`` otherwise) or
        the pooled two-proportion z test (any nonnegative counts).

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

    if test not in TESTS:
        raise InputError("test", f"must be one of {', '.join(TESTS)}", test)
    if test == "fisher":
        if any(v != int(v) for v in (x1, n1, x2, n2)):
            raise InputError("test", "Fisher's exact test needs whole counts (use the z test)", (x1, n1, x2, n2))
        table = [[int(x1), int(n1 - x1)], [int(x2), int(n2 - x2)]]
        return float(fisher_exact(table, alternative="two-sided").pvalue)
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
    if adjustment not in ADJUSTMENTS:
        raise InputError("adjustment", f"must be one of {', '.join(ADJUSTMENTS)}", adjustment)
    m = p.size
    if adjustment == "none" or m == 0:
        return p.copy()
    if adjustment == "bonferroni":
        return np.minimum(p * m, 1.0)
    order = np.argsort(p, kind="stable")
    stepped = np.minimum(np.maximum.accumulate(p[order] * (m - np.arange(m))), 1.0)
    out = np.empty_like(p)
    out[order] = stepped
    return out
