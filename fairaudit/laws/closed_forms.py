"""k-ary randomized response in closed form: keep probabilities, budgets and the mechanism.

k-ary randomized response keeps its value with probability p = e^ε / (e^ε + k − 1) and moves to each other value
with q = 1 / (e^ε + k − 1) (Warner 1965; Kairouz, Oh and Viswanath 2014). Its ε, δ(ε), pairwise divergences and
keep probability are closed forms (:class:`RandomizedResponse`), and so is the split of a profile's budget among
attributes that keep their values with one probability (:func:`split_by_keep`).

Proof of the facts used here: ``proofs/privacy.md``.
"""

from __future__ import annotations

import functools
import math
import sys
from collections.abc import Hashable, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fairaudit.base.arrays import EXP_SAFE, BoolArray, FloatArray
from fairaudit.base.checks import epsilon as check_epsilon
from fairaudit.base.checks import real, whole
from fairaudit.base.errors import InputError
from fairaudit.base.labels import as_labels
from fairaudit.base.outward import exp_bounds, exp_down, fraction_up, log_up, rounding_error
from fairaudit.laws.mechanisms import Mechanism

__all__ = [
    "RandomizedResponse",
    "RandomizedResponseParameters",
    "epsilon_from_keep_probability",
    "keep_probability",
    "randomized_response",
    "rr_total_variation_up",
    "split_by_keep",
]


def keep_probability(epsilon: float, k: int) -> float:
    """Keep probability e^ε / (e^ε + k − 1) of k-ary randomized response.

    It describes the mechanism, rounded to nearest (within a few units in the last place); no certified number
    is computed from it: the bounds use ε itself (:func:`rr_total_variation_up`).

    Examples
    --------
    >>> round(keep_probability(math.log(7 / 3), 2), 12)
    0.7
    """
    return keep_of_checked(check_epsilon(epsilon), whole(k, "k", low=1))


def keep_of_checked(eps: float, k: int) -> float:
    """:func:`keep_probability` of a checked ε ≥ 0 (+inf allowed) and k ≥ 1: what a family's keep evaluates
    thousands of times in a calibration scan, without validating again."""
    if eps == math.inf:
        return 1.0
    return 1.0 / (1.0 + (k - 1) * math.exp(-eps))


def epsilon_from_keep_probability(keep: float, k: int) -> float:
    """ε = log(p (k − 1) / (1 − p)) of k-ary randomized response keeping with p, rounded up.

    ``keep`` is read both as its binary value and as the decimal it prints as (0.7 as 7/10, as a spec's reader
    and ``fairaudit filter --spec`` read it); ε is the larger, so that randomized response deployed from either
    is within the certified budget (``fairaudit verify --filter``).

    Not ``p / (1 − p)`` (the seed paper's error 1): for k = 2 and p = 0.7 the
    budget is ln(7/3) = 0.847 nats.

    Raises
    ------
    InputError
        If ``keep`` is not in [1/k, 1] (below 1/k the mechanism favours
        other values and is not randomized response).

    Examples
    --------
    >>> round(epsilon_from_keep_probability(0.7, 2), 6), epsilon_from_keep_probability(1.0, 3)
    (0.847298, inf)
    >>> round(keep_probability(epsilon_from_keep_probability(0.6, 3), 3), 12)
    0.6
    """
    k = whole(k, "k", low=2)
    keep = real(
        keep, "keep", low=1.0 / k - 1e-15, high=1.0, what=f"a keep probability in [1/k, 1] = [{1.0 / k:.6g}, 1]"
    )
    if keep >= 1.0:
        return math.inf
    # an upper bound on the ε of both readings of ``keep``: its binary value, and the decimal it prints as (0.7 is
    # 7/10 to a spec's reader and to `fairaudit filter --spec`): ln of the larger exact ratio, rounded up
    ratio = max(_keep_ratio(Fraction(keep), k), _keep_ratio(Fraction(repr(keep)), k))
    return math.inf if ratio == math.inf else max(0.0, log_up(ratio))


def _keep_ratio(p: Fraction, k: int) -> Fraction | float:
    """p (k − 1)/(1 − p), +inf at p = 1."""
    return math.inf if p >= 1 else p * (k - 1) / (1 - p)


def rr_total_variation_up(epsilon: float, k: int) -> float:
    """An upper end of p − q = (e^ε − 1)/(e^ε + k − 1), the δ(0) of k-ary randomized response, for ε ≥ 0.

    p − q = (1 − s)/(1 + (k − 1)s) with s = e^−ε decreases in s, so s rounded down gives an upper end, for
    every ε (no overflow); below ε = 1e-5, 1 − s ≤ ε − ε²/2 + ε³/6 (the alternating series), exact rationals
    (``proofs/outward.md`` §5).

    Parameters
    ----------
    epsilon : float
        ε in nats, ≥ 0 (+inf gives 1).
    k : int
        The number of values.

    Returns
    -------
    float
        An upper end of p − q (a probability).

    Examples
    --------
    >>> rr_total_variation_up(math.log(3), 2) >= 0.5
    True
    """
    if k < 2 or epsilon == 0.0:
        return 0.0
    if math.isinf(epsilon):
        return 1.0
    s = Fraction(exp_down(-epsilon))
    e = Fraction(epsilon)
    one_minus = 1 - s if epsilon >= 1e-5 else e - e * e / 2 + e**3 / 6
    return fraction_up(one_minus / (1 + (k - 1) * s))


def split_by_keep(epsilon: float, sizes: Sequence[int]) -> FloatArray:
    """Each attribute's ε when a profile's budget ``epsilon`` is split so that every attribute keeps its value
    with the same probability p.

    Attribute i, with k_i values, gets k_i-ary randomized response at
    ε_i = max(0, ln(p (k_i − 1) / (1 − p))), so it keeps its value with
    probability p (never less than 1/k_i: an attribute that p would keep less
    often than uniformly is shown uniformly at random, ε_i = 0), and p is the
    one keep probability with Σ_i ε_i = ``epsilon`` (the product's ε, every
    pair of profiles adjacent). With ℓ = ln(p / (1 − p)) and c_i = ln(k_i − 1),
    ε_i = max(0, ℓ + c_i): the sum is piecewise linear and increasing in ℓ,
    so ℓ is found in closed form on the piece where the m attributes with
    the largest c_i are active, ℓ = (ε − Σ_{j ≤ m} c_(j)) / m.

    Proof: ``proofs/privacy.md`` ("A shared keep probability"). Attributes of
    equal size get ε / n each; a keep probability p on an attribute with k
    values is ε = ln(p (k − 1) / (1 − p)), whatever the other attributes' sizes.

    Parameters
    ----------
    epsilon : float
        The profile's privacy budget (nats, ≥ 0; +inf: every attribute shown as is).
    sizes : sequence of int
        k_i ≥ 2, the number of values of each attribute.

    Returns
    -------
    numpy.ndarray, shape (n_attributes,)
        ε_i in nats, in the order of ``sizes``, summing to ``epsilon``.

    Raises
    ------
    InputError
        If ``epsilon`` is negative or NaN, ``sizes`` is empty, or a size is not a whole number ≥ 2.

    Examples
    --------
    Age (3 values), gender (2) and race (3), each kept with p = 0.6: ln 3, ln 1.5 and ln 3.

    >>> eps = split_by_keep(2 * math.log(3) + math.log(1.5), [3, 2, 3])
    >>> [round(float(e), 6) for e in eps]
    [1.098612, 0.405465, 1.098612]
    >>> [round(keep_probability(float(e), k), 12) for e, k in zip(eps, [3, 2, 3])]
    [0.6, 0.6, 0.6]

    A small budget leaves the binary attribute uniform (p would be below 1/2):

    >>> [round(float(e), 6) for e in split_by_keep(0.3, [3, 2])]
    [0.3, 0.0]
    """
    eps = check_epsilon(epsilon)
    if not len(sizes):
        raise InputError("sizes", "needs at least one attribute", list(sizes))
    k = np.array([whole(s, f"sizes[{i}]", low=2) for i, s in enumerate(sizes)], dtype=float)
    if eps == 0.0 or eps == math.inf:
        return np.full(k.size, eps)
    c = np.log(k - 1.0)
    top = np.sort(c)[::-1]
    total = np.cumsum(top)
    # the sum of the ε_i at ℓ = −top[m] (only the m attributes above it active); non-decreasing in m, 0 at m = 0
    breaks = total - np.arange(1, k.size + 1) * top
    m = int(np.searchsorted(breaks, eps, side="left"))  # the active attributes: every break below ε
    ell = (eps - total[m - 1]) / m
    return np.maximum(0.0, ell + c)


def randomized_response(
    values: Sequence[Hashable],
    epsilon: float | None = None,
    *,
    keep: float | None = None,
    name: str | None = None,
) -> Mechanism:
    """k-ary randomized response on ``values``.

    Proof: ``proofs/privacy.md`` (ε = ln(p(k − 1)/(1 − p)); the paper's error 1).

    Keeps the value with probability p = e^ε / (e^ε + k − 1) and moves to each
    of the k − 1 other values with probability 1 / (e^ε + k − 1) (Warner 1965;
    Kairouz, Oh and Viswanath 2014). Give exactly one of ``epsilon`` (nats) and
    ``keep`` (p).

    Parameters
    ----------
    values : sequence of hashable, length k ≥ 1
        The alphabet; inputs and outputs are the same labels. A ``range`` of
        integers is kept as it is (O(1) memory: k may be a billion).
    epsilon : float, optional
        Privacy budget ε ≥ 0 in nats; +inf gives the identity.
    keep : float, optional
        Keep probability p in [1/k, 1].
    name : str, optional
        Name in reports.

    Returns
    -------
    Mechanism
        Square, shape (k, k); ε(M) = ``epsilon`` exactly, δ(M, ε(M)) = 0.
        Its matrix is built only when asked for: ε, δ(ε), the keep
        probability and the certificates of :mod:`fairaudit.metrics.bounds`,
        :mod:`fairaudit.worstcase` and :mod:`fairaudit.worstcase.calibration` are closed
        forms, so k may be a million. Any ε in [0, +inf] works (above
        700 nats, where e^ε overflows, q = e^−ε/(1 + (k − 1)e^−ε)).

    Raises
    ------
    InputError
        If neither or both of ``epsilon`` and ``keep`` are given, or either is
        out of range.

    Examples
    --------
    >>> m = randomized_response(["a", "b", "c"], epsilon=math.log(4))
    >>> m.matrix.round(6).tolist()
    [[0.666667, 0.166667, 0.166667], [0.166667, 0.666667, 0.166667], [0.166667, 0.166667, 0.666667]]
    """
    # a range of integers is distinct by construction, and kept as it is: O(1) memory, whatever k
    labels = (
        values if isinstance(values, range) and len(values) > 0 else as_labels(values, "randomized_response values")
    )
    k = len(labels)
    if (epsilon is None) == (keep is None):
        raise InputError(
            "randomized_response", "give exactly one of epsilon and keep", {"epsilon": epsilon, "keep": keep}
        )
    if keep is not None:
        epsilon = 0.0 if k == 1 else epsilon_from_keep_probability(keep, k)
    assert epsilon is not None  # exactly one of epsilon and keep was given
    eps = check_epsilon(epsilon)
    return RandomizedResponse(labels, eps, name or f"{k}-ary randomized response")


def _rr_probabilities(eps: float, k: int) -> tuple[float, float, float, float]:
    """(p, q, log p, log q) of k-ary randomized response: p = t/(t + k − 1), q = 1/(t + k − 1), t = e^ε.

    No overflow for any ε ≥ 0 (+inf gives p = 1, q = 0); p without cancellation for any k.
    """
    if k < 2 or math.isinf(eps):
        return 1.0, 0.0, 0.0, -math.inf
    if eps <= EXP_SAFE:
        q = 1.0 / (math.exp(eps) + k - 1)
    else:
        small = math.exp(-eps)
        q = small / (1.0 + (k - 1) * small)
    rest = (k - 1) * q
    # 1 − (k − 1) q is exact to an ulp when it is ≥ 1/2; below that, t·q avoids the cancellation
    p = 1.0 - rest if rest <= 0.5 else q * math.exp(eps)
    log_p = -math.log1p((k - 1) * math.exp(-eps))  # −log(1 + (k − 1) e^−ε)
    return p, q, log_p, log_p - eps


def _rr_roundings(rr: RandomizedResponseParameters) -> int:
    """:attr:`RandomizedResponse.matrix_roundings`: the smallest R with γ_R ≥ |x̂/x − 1| for x = p and q (a normal
    x̂) and R·2^-1074 ≥ |x̂ − x| (a subnormal one, whose products' ends carry that absolute error)."""
    if rr.k < 2 or math.isinf(rr.epsilon):
        return 0
    if rr.epsilon > 10**4:  # (k − 1) e^-ε < 2^-53: p̂ = 1 is within one rounding; q̂ = 0 is a product's factor 0
        return 1
    lo, hi = exp_bounds(rr.epsilon)
    lo = max(lo, Fraction(1))
    m = rr.k - 1
    relative, absolute = Fraction(0), Fraction(0)
    # |x̂ − x| and |x̂/x − 1| over x between two ends are largest at an end
    for computed, ends in ((rr.p, (lo / (lo + m), hi / (hi + m))), (rr.q, (1 / (hi + m), 1 / (lo + m)))):
        if computed >= sys.float_info.min:
            relative = max(relative, *(abs(Fraction(computed) / end - 1) for end in ends))
        elif computed > 0:
            absolute = max(absolute, *(abs(Fraction(computed) - end) for end in ends))
    r = max(1, math.ceil(relative * 2**53), math.ceil(absolute * 2**1074))
    while Fraction(float(rounding_error(r))) < relative:  # (γ_r ≥ r·u: at most a step or two)
        r += 1
    return r


class RandomizedResponse(Mechanism):
    """k-ary randomized response in closed form: its k x k matrix is made only when asked for.

    Every row keeps its value with p = e^ε/(e^ε + k − 1) and moves to each other
    value with q = 1/(e^ε + k − 1), so ε, δ(ε), the pairwise divergences, the
    keep probability and (in :mod:`fairaudit.metrics.bounds`, :mod:`fairaudit.worstcase`
    and :mod:`fairaudit.worstcase.calibration`) the certificates have closed forms: a
    million groups cost their labels, not 10^12 cells. ``proofs/privacy.md`` §5.
    Made by :func:`randomized_response`; ``rr`` holds its parameters.

    Examples
    --------
    >>> m = randomized_response(["a", "b"], epsilon=math.log(3))
    >>> isinstance(m, RandomizedResponse), round(m.keep_probability, 12), m.rr.k
    (True, 0.75, 2)
    """

    rr: RandomizedResponseParameters

    def __init__(self, labels: tuple | range, epsilon: float, name: str) -> None:
        k = len(labels)
        p, q, log_p, log_q = _rr_probabilities(epsilon, k)
        rr = RandomizedResponseParameters(k, epsilon if k > 1 else 0.0, p, q, log_p, log_q)
        vars(self).update(inputs=labels, outputs=labels, name=name, rr=rr)  # (frozen: as object.__setattr__ would)

    @functools.cached_property
    def matrix(self) -> FloatArray:
        k, rr = len(self.inputs), self.rr
        m = np.full((k, k), rr.q)
        np.fill_diagonal(m, rr.p)
        m.setflags(write=False)
        return m

    @functools.cached_property
    def matrix_roundings(self) -> int:
        """How far :attr:`matrix`'s floats may lie from the exact p and q, as a count of roundings R: each positive
        entry is its exact value times 1 + θ with |θ| ≤ γ_R (:func:`~fairaudit.base.outward.rounding_error`), so a
        product of it carries R roundings more. 0 for the identity; checked in exact arithmetic against e^ε's
        rational ends (:func:`~fairaudit.base.outward.exp_bounds`, 50 digits; beyond 10^4 nats p is 1.0 and q 0.0
        in floats, and e^-ε < 2^-14000 makes R = 1).

        Examples
        --------
        >>> randomized_response(["a", "b"], epsilon=math.log(3)).matrix_roundings  # p = 3/4 and q = 1/4, one ulp off
        1
        >>> randomized_response(["a", "b"], epsilon=math.inf).matrix_roundings
        0
        """
        return _rr_roundings(self.rr)

    @property
    def support(self) -> BoolArray:
        """Every entry is positive for a finite ε (q > 0 exactly, even where its float underflows above ~708 nats)."""
        k = len(self.inputs)
        return np.eye(k, dtype=bool) if self.is_identity else np.ones((k, k), dtype=bool)

    @property
    def epsilon(self) -> float:
        return self.rr.epsilon

    @property
    def is_identity(self) -> bool:
        return self.rr.k < 2 or math.isinf(self.rr.epsilon)

    @property
    def keep_probability(self) -> float:
        return self.rr.p

    def _largest_delta(self, epsilon: float) -> float:
        """δ_aa'(ε) = [p − e^ε q]₊, the same for every pair a ≠ a' (proofs/privacy.md, Proposition 5)."""
        eps = check_epsilon(epsilon)
        rr = self.rr
        if rr.k < 2:
            return 0.0
        if math.isinf(rr.epsilon):  # the identity: a puts all its mass where a' puts none
            return rr.p
        if eps >= rr.epsilon:
            return 0.0
        # p − e^ε q = (1 − e^(ε − ε_M)) / (1 + (k − 1) e^−ε_M): decreasing in both exponentials, which are
        # rounded down (exact rationals from there): an upper end (proofs/outward.md §5)
        s = Fraction(exp_down(-rr.epsilon))
        top = 1 - Fraction(exp_down(Fraction(eps) - Fraction(rr.epsilon)))
        return max(0.0, fraction_up(top / (1 + (rr.k - 1) * s)))

    def pairwise_delta(self, epsilon: float) -> FloatArray:
        k = len(self.inputs)
        out = np.full((k, k), self._largest_delta(epsilon))
        np.fill_diagonal(out, 0.0)
        return out

    def _epsilon_for_positive_delta(self, delta: float) -> float:
        """Smallest ε ≥ 0 with δ(ε) ≤ ``delta``: log((p − δ)/q) in closed form (0 when δ ≥ p − q), rounded up.

        (p − δ)/q = e^ε_M (1 − δ) − δ(k − 1) increases in e^ε_M: ε_M + ln(1 − δ − δ(k − 1)e^−ε_M) with
        e^−ε_M rounded down and ln rounded up, the sum rounded up (exact rationals; proofs/outward.md §5).
        """
        rr = self.rr
        if math.isinf(rr.epsilon):  # the identity: δ = 1 at every ε
            return math.inf
        d = Fraction(delta)
        inside = 1 - d - d * (rr.k - 1) * Fraction(exp_down(-rr.epsilon))
        if inside <= 0:
            return 0.0
        return max(0.0, fraction_up(Fraction(rr.epsilon) + Fraction(log_up(inside))))


@dataclass(frozen=True)
class RandomizedResponseParameters:
    """The closed-form parameters of k-ary randomized response (see :class:`RandomizedResponse`)."""

    k: int
    epsilon: float
    p: float  # keep probability e^ε/(e^ε + k − 1)
    q: float  # probability of each other value, 1/(e^ε + k − 1)
    log_p: float
    log_q: float  # −ε − log(1 + (k − 1) e^−ε): finite for every finite ε, even where q underflows
