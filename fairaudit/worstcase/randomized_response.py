"""k-ary randomized response in closed form: every ordered pair of groups is alike, one pair decides.

The box and floor-relaxation values (``proofs/black_box.md`` §3, Propositions 3 and 3b), the class with a
Lipschitz utility under the discrete metric (§5, Proposition 7b), and the law behind the mechanism without its
k x k matrix. Used by :func:`~fairaudit.worstcase.black_box.black_box_bound`, :func:`~fairaudit.worstcase.known_utility.worst_model` and
:mod:`fairaudit.worstcase.calibration`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np

from fairaudit.base.arrays import BoolArray, FloatArray, IntArray
from fairaudit.base.outward import exp_bounds, exp_down, exp_up, fraction_down, fraction_up, log_up
from fairaudit.laws.closed_forms import RandomizedResponseParameters
from fairaudit.laws.composition import check_representable
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Law

_TIE = 1e-12  # relative tolerance of the threshold solution's ties (as threshold_rule.threshold_max_many)


@dataclass(frozen=True, kw_only=True)
class RRWorst:
    """The worst case of the pair (a, a') = (first group, second group) behind k-ary randomized response.

    Every ordered pair is alike (the mechanism is symmetric), so one pair decides. The maximiser h over the
    released values is h[a] = ``h_a``, h[a'] = ``h_b``, the first ``first`` other values (in index order)
    ``h_first``, the next one ``h_next``, the rest ``h_rest``. ``prefix``: h is a threshold prefix (released
    values listed in the likelihood-ratio order a, others, a'), else a floor point (listed in index order).
    """

    ratio: float
    value: float  # log ratio, exact also where the ratio overflows (lower = 0: ε itself)
    h_a: float
    h_b: float
    first: int
    h_first: float
    h_next: float
    h_rest: float
    prefix: bool

    def vector(self, k: int) -> FloatArray:
        h = np.full(k, self.h_rest)
        j = min(self.first, k - 2)
        h[2 : 2 + j] = self.h_first
        if 2 + j < k:
            h[2 + j] = self.h_next
        h[0], h[1] = self.h_a, self.h_b
        return h

    def released(self, k: int, hi: float) -> IntArray:
        """Indices of the released values where h is at the top of the box (``hi``)."""
        at_top = np.flatnonzero(self.vector(k) >= hi - 1e-9 * max(1.0, hi))
        if self.prefix and at_top.size and at_top[0] == 0 and 1 in at_top[:2]:
            at_top = np.concatenate([at_top[at_top != 1], [1]])  # a' comes last in the ratio order
        return at_top


def rr_box(rr: RandomizedResponseParameters, lo: float, hi: float, floor: float) -> RRWorst:
    """max (M[a]·h)/(M[a']·h) over lo ≤ h ≤ hi with M[a']·h ≥ floor, M = k-ary RR, in O(1), its value certified.

    The point (the kernel's h) is :func:`rr_box_point`'s, in floating point; the ratio and its log are the exact
    closed form at t = ``exp_up`` (ε), a rational ≥ e^ε, rounded up: the worst case is non-decreasing in e^ε
    (randomized response at a smaller ε is the larger one followed by more randomized response), so this is an
    upper end (``proofs/outward.md`` §5).
    """
    w = rr_box_point(rr, lo, hi, floor)
    if w.ratio == 1.0 and w.value == 0.0 and (hi <= lo or rr.epsilon == 0.0):  # span 0 or p = q: exactly 1
        return w  # (below ε ≈ 1e-16 the floats p and q are equal, but p > q: the exact ratio below)
    if lo == 0 and w.prefix:  # h = hi on a alone: the ratio is p/q = e^ε, its log ε exactly
        return replace(w, ratio=exp_up(rr.epsilon), value=rr.epsilon)
    ratio = _rr_box_ratio(rr.k, rr.epsilon, Fraction(lo), Fraction(hi), floor)
    if ratio == math.inf:
        return replace(w, ratio=math.inf, value=math.inf)
    return replace(w, ratio=fraction_up(ratio), value=log_up(ratio))


RATIONAL_LIMIT = 10**4
"""Above this ε (nats) the closed forms take randomized response at its limit t → ∞ (p = 1, q = 0); below it, at a
rational t ≥ e^ε: ``exp_up`` (ε), or beyond the floats (about 709.78 nats) the 50-digit upper end of e^ε."""


def rr_exact_rows(k: int, epsilon: float, end: int) -> tuple[Fraction, Fraction] | None:
    """k-ary randomized response's (p, q) = (t/(t + k − 1), 1/(t + k − 1)), exactly, at a rational end t of e^ε.

    Parameters
    ----------
    k : int
        The number of values, ≥ 2.
    epsilon : float
        ε ≥ 0, nats.
    end : {0, 1}
        0: t ≤ e^ε, ``exp_down`` (ε); 1: t ≥ e^ε, ``exp_up`` (ε). Beyond the floats (about 709.78 nats), the 50-digit
        end of :func:`~fairaudit.base.outward.exp_bounds` (``proofs/outward.md`` §4); t is never below 1.

    Returns
    -------
    (Fraction, Fraction) or None
        p and q, each row summing to 1 exactly; None above :data:`RATIONAL_LIMIT` (ε = +inf included).

    Notes
    -----
    A worst case over the models behind randomized response is non-decreasing in e^ε (a smaller ε is a larger one
    followed by more randomized response, ``proofs/calibration.md`` §3): the upper end bounds it from above, the lower
    end from below.

    Examples
    --------
    >>> import math
    >>> rr_exact_rows(2, math.log(3), 1)[0] >= Fraction(3, 4) >= rr_exact_rows(2, math.log(3), 0)[0]
    True
    >>> rr_exact_rows(2, 2e4, 1) is None
    True
    """
    t_float = exp_up(epsilon) if end else exp_down(epsilon)
    if math.isfinite(t_float):
        t = Fraction(t_float)
    elif epsilon <= RATIONAL_LIMIT:
        t = exp_bounds(epsilon)[end]
    else:
        return None
    t = max(Fraction(1), t)
    return t / (t + k - 1), 1 / (t + k - 1)


def _rows_up(k: int, epsilon: float) -> tuple[Fraction, Fraction]:
    """:func:`rr_exact_rows` at the upper end; (1, 0), the limit t → ∞, above :data:`RATIONAL_LIMIT`."""
    return rr_exact_rows(k, epsilon, 1) or (Fraction(1), Fraction(0))


def _rr_box_ratio(k: int, epsilon: float, lo: Fraction, hi: Fraction, floor: float) -> Fraction | float:
    """The box-with-floor optimum behind k-ary RR at t = exp_up(ε), exactly (the cases of :func:`rr_box_point`)."""
    p, q = _rows_up(k, epsilon)
    span = hi - lo
    num, den = lo + span * p, lo + span * q
    f = Fraction(floor) if math.isfinite(floor) else None
    if f is None or den >= f:  # the floor does not bind: the threshold solution
        return num / den if den > 0 else (math.inf if num > 0 else Fraction(1))
    need, c = f - lo, span * q
    if need <= c * (k - 1):  # a and some other values raised: (floor + span (p − q))/floor
        return (f + span * (p - q)) / f
    s = min(span, (need - c * (k - 1)) / p)  # a and every other value raised, a' partly
    return (lo + span * (p + (k - 2) * q) + q * s) / f


def rr_theta(rr: RandomizedResponseParameters, lo: float, hi: float, floor: float) -> Fraction | None:
    """The threshold θ that proves :func:`rr_box`'s value where the floor binds: the multiplier λ − θ on
    M[a']·h ≥ floor bounds the ratio by θ + max(R(θ), 0)/floor, R(θ) = max over the box of (M[a] − θ M[a'])·h, and at
    θ = the ratio p_i/q_i of the cell the knapsack fills last (1 for another value, q/p for a' itself) that bound
    is the value (``proofs/verification.md`` §4f; the one-floor relaxation is the optimum behind randomized
    response, ``proofs/black_box.md`` §3, Proposition 3b). Exact, at the rational upper end of e^ε
    :func:`rr_box`'s value is taken at (:func:`rr_exact_rows`): at a smaller e^ε, as ``verify`` may take, the same
    θ proves at most that value (p smaller, q larger). None where the threshold solution meets the floor (the bound
    without floors is the value).

    Examples
    --------
    Three values at ε = ln 3 (p = 3/5, q = 1/5), h in [0, 1]: the floor 0.3 is met by raising a and part of the other
    value (θ = 1), 0.5 by raising a' too (θ = q/p = 1/t, t = exp_up(ln 3) ≥ 3, the rational upper end); a floor of
    0.1 is met without (None). (0.2 binds: at t just above 3, q = 1/(t + 2) is just below 1/5, decided exactly.)

    >>> from fairaudit.laws.closed_forms import RandomizedResponse
    >>> rr = RandomizedResponse(("a", "b", "c"), math.log(3), "A").rr
    >>> theta = rr_theta(rr, 0.0, 1.0, 0.5)
    >>> rr_theta(rr, 0.0, 1.0, 0.3), theta == 1 / Fraction(exp_up(math.log(3))), rr_theta(rr, 0.0, 1.0, 0.1)
    (Fraction(1, 1), True, None)
    >>> rr_theta(rr, 0.0, 1.0, 0.2)
    Fraction(1, 1)
    """
    cells = _cells(rr.k, rr.epsilon, lo, hi, floor)
    if cells is None or cells[0] == "threshold":
        return None
    p, q = _rows_up(rr.k, rr.epsilon)
    return Fraction(1) if cells[0] == "others" else q / p


def _cells(
    k: int, epsilon: float, lo: float, hi: float, floor: float
) -> tuple[str, Fraction, Fraction, Fraction] | None:
    """Which values :func:`rr_box`'s optimum raises at the rational upper end of e^ε, decided exactly: "threshold"
    (a alone: the floor does not bind), "others" (a and part of the other values) or "second" (a, every other value
    and part of a'); with lo, the span hi − lo and the floor as rationals. None where no value is raised (hi ≤ lo,
    p = q) or without a finite floor."""
    if not math.isfinite(floor) or hi <= lo:
        return None
    p, q = _rows_up(k, epsilon)
    low, span, f = Fraction(lo), Fraction(hi) - Fraction(lo), Fraction(floor)
    if p <= q:
        return None
    if low + span * q >= f:
        return "threshold", low, span, f
    return ("others" if f - low <= span * q * (k - 1) else "second"), low, span, f


def rr_witness_point(
    k: int, epsilon: float, lo: float, hi: float, floor: float, a: int = 0, b: int = 1
) -> list[Fraction] | None:
    """:func:`rr_box`'s maximiser h over the released values, exactly, at the rational upper end t of e^ε
    (:func:`rr_exact_rows`): h[a] = hi; then, where the floor binds, the other values raised by the same share
    (together Σ w = (floor − lo)/(span·q) − 1 of the span) or, beyond, to hi, with h[a'] raised just to meet
    floor = (M h)[a']; lo elsewhere. It meets every group's floor at t and at every smaller e^ε ≥ 1: h[a'] is the
    least value, so (M h)[c] ≥ (M h)[a'], which is non-increasing in t (``proofs/verification.md`` §4f); so
    ``fairaudit verify`` reads a lower end off it at its own end of e^ε. None where
    no floor point exists (the floor above every (M h)[a'], or ε beyond :data:`RATIONAL_LIMIT`).

    Parameters
    ----------
    k : int
        The number of values, ≥ 2.
    epsilon : float
        ε ≥ 0, nats.
    lo, hi : float
        The box of h (the utility's least and largest value).
    floor : float
        The floor on (M h)[c] for every c (τ), -inf for none.
    a, b : int
        The pair's released values (a ≠ b).

    Returns
    -------
    list of Fraction or None
        h, length k, in the utility's units, each in [lo, hi]; None as above.

    Notes
    -----
    ``proofs/black_box.md`` §3, Proposition 3b (the floor point), ``proofs/verification.md`` §4f (why it holds at
    verify's end of e^ε).

    Examples
    --------
    Three values at ε = ln 3, h in [0, 1], floor 0.3: a at 1 and the third value raised until (M h)[b] = 0.3, about
    1/2 at t = 3 (q = 1/5: (1 + w)/5 = 0.3).

    >>> h = rr_witness_point(3, math.log(3), 0.0, 1.0, 0.3)
    >>> h[:2], abs(h[2] - Fraction(1, 2)) < 1e-15
    ([Fraction(1, 1), Fraction(0, 1)], True)
    """
    cells = _cells(k, epsilon, lo, hi, floor)
    rows = rr_exact_rows(k, epsilon, 1)
    if cells is None or rows is None:
        return None
    (kind, low, span, f), (p, q) = cells, rows
    others = [c for c in range(k) if c not in (a, b)]
    h = [low] * k
    h[a] = low + span
    if kind == "others":
        share = ((f - low) / (span * q) - 1) / len(others)
        for c in others:
            h[c] = low + span * share
    elif kind == "second":
        s = (f - low - span * q * (k - 1)) / p
        if s > span:
            return None
        for c in others:
            h[c] = low + span
        h[b] = low + s
    return h


def rr_box_point(rr: RandomizedResponseParameters, lo: float, hi: float, floor: float) -> RRWorst:
    """max (M[a]·h)/(M[a']·h) over lo ≤ h ≤ hi with M[a']·h ≥ floor, M = k-ary RR, in O(1).

    Without a binding floor (floor ≤ lo) the threshold solution: h = hi on the released value a, lo elsewhere,
    ratio (lo + (hi − lo)p)/(lo + (hi − lo)q) (proofs/black_box.md, Proposition 3), with the longest prefix tied
    to 1e-12 (as the general route). With a binding floor the relaxation that keeps only M[a']·h ≥ floor
    (threshold_rule.floor_max_many): raise a, then the other values, then a', until M[a']·h = floor; for randomized response
    its point meets every group's floor, so it is the optimum of the whole class (proofs/black_box.md, §3,
    Proposition 3b). ``floor`` must be ≤ hi.
    """
    k, p, q = rr.k, rr.p, rr.q
    span = hi - lo
    if span <= 0 or p <= q:  # every prefix ties at ratio 1: the longest one, h = hi everywhere (index order)
        return RRWorst(ratio=1.0, value=0.0, h_a=hi, h_b=hi, first=k, h_first=hi, h_next=hi, h_rest=hi, prefix=False)
    num, den = lo + span * p, lo + span * q
    if lo > 0:
        ratio = num / den
        if den > 1e-290:
            value = math.log(ratio)
        else:  # (q underflows: log(lo + span q) from log q, which does not)
            value = math.log(num) - float(np.logaddexp(math.log(lo), math.log(span) + rr.log_q))
            ratio = math.exp(value) if value < 709.0 else math.inf
    else:  # (p/q = e^ε; its log is ε even where p/q overflows)
        ratio = math.inf if q == 0 else p / q
        value = rr.log_p - rr.log_q
    first = 0
    c = span * q
    tied = ratio * (1 - _TIE)
    if tied <= 1:  # the ratio is 1 to rounding: every prefix ties, the longest is all of them
        return RRWorst(ratio=ratio, value=value, h_a=hi, h_b=hi, first=k, h_first=hi, h_next=hi, h_rest=hi, prefix=True)
    if c > 0 and math.isfinite(tied):  # others add c to both sides: tied while (num + jc)/(den + jc) >= tied
        first = min(k - 2, int(math.floor(_TIE * num / (c * (tied - 1)))))
    if floor <= lo or den + first * c >= floor * (1 - 1e-12):
        return RRWorst(
            ratio=ratio, value=value, h_a=hi, h_b=lo, first=first, h_first=hi, h_next=lo, h_rest=lo, prefix=True
        )
    need = floor - lo
    if q > 0 and need <= c * (k - 1):  # a and x other values raised: value (floor + span (p − q))/floor
        x = need / c - 1.0
        first = min(k - 2, int(math.floor(x)))
        frac = min(1.0, max(0.0, x - first))
        ratio = (floor + span * (p - q)) / floor
        h_b, h_next, h_rest = lo, lo + frac * span, lo
    else:  # a and every other value raised, a' partly
        s = min(span, (need - c * (k - 1)) / p)
        ratio = (lo + span * (p + (k - 2) * q) + q * s) / floor
        first, h_b, h_next, h_rest = k - 2, lo + s, hi, hi
    return RRWorst(ratio=ratio, value=math.log(ratio), h_a=hi, h_b=h_b, first=first, h_first=hi, h_next=h_next,
                   h_rest=h_rest, prefix=False)  # fmt: skip


def rr_lipschitz_ratio(
    k: int, epsilon: float, lo: Fraction, hi: Fraction, floor: Fraction, lam: Fraction
) -> tuple[Fraction | float, tuple[Fraction, ...] | None]:
    """The class with L_A > 0 behind k-ary RR, discrete metric (λ = L_A d): its worst ratio, exactly, at t = ``exp_up``
    (ε) ≥ e^ε (an upper end; +inf when unbounded), and the worst g = (x at a, z at a', y at each other value).

    By symmetry (averaging a maximiser over the permutations of the other groups keeps it feasible and, the
    objective being linear-fractional, optimal) the worst case has h[a'] = g and every other group, a included, at
    the largest vector the Lipschitz condition allows, f = min(g + λ, hi) (``proofs/black_box.md`` §5, Proposition
    7b). On each of the 8 pieces of [lo, hi]^3 where f is affine its value is a linear-fractional program in
    (x, z, y) with rational data, solved exactly (:class:`~fairaudit.base.exact_ratio.Polytope`; the affine
    numerator through a fourth variable fixed at 1). The worst case is non-decreasing in
    e^ε (a smaller ε is a post-processing of a larger one, ``proofs/calibration.md`` §3), so its value at t bounds the
    value at e^ε from above (``proofs/outward.md`` §5).

    Parameters
    ----------
    k : int
        The number of groups, ≥ 2.
    epsilon : float
        Randomized response's ε, nats (+inf: the identity).
    lo, hi, floor, lam : fractions.Fraction
        The box [lo, hi] of g, the floor (≥ lo; binding when > lo) and λ = L_A·d (> 0), exactly.

    Returns
    -------
    ratio : fractions.Fraction or float
        The exact maximum at t, or +inf when g = 0 is allowed for a' and f = λ > 0 for a (lo = 0, no binding floor);
        -inf when no piece is feasible.
    g : tuple of 3 fractions.Fraction, or None
        A vertex attaining it (None with ±inf).
    """
    from fairaudit.base.exact_ratio import Polytope

    p, q = _rows_up(k, epsilon)
    m = k - 2
    binding = floor > lo
    if lo == 0 and not binding:
        return math.inf, None
    cut = hi - lam
    pieces = [(lo, min(hi, cut), Fraction(1), lam)] if cut >= lo else []
    pieces.append((max(lo, cut), hi, Fraction(0), hi))
    n_vec, d_vec = (p, q, m * q), (q, p, m * q)
    b_vec = (q, q, p + (m - 1) * q) if m >= 1 else None
    best: Fraction | float = -math.inf
    point = None
    for cells in itertools.product(pieces, repeat=3):
        slope, icpt = [c[2] for c in cells], [c[3] for c in cells]
        # variables (x, z, y, s), s = 1: numerator Σ n_i (slope_i x_i + icpt_i s), denominator d·(x, z, y)
        numerator = [n * a for n, a in zip(n_vec, slope, strict=True)] + [sum(n * c for n, c in zip(n_vec, icpt))]
        rows, rhs = [], []
        if binding:
            rows += [[-d for d in d_vec] + [Fraction(0)]]
            rhs += [-floor]
            for vec in (n_vec,) if b_vec is None else (n_vec, b_vec):
                rows += [[-v * a for v, a in zip(vec, slope, strict=True)] + [Fraction(0)]]
                rhs += [sum(v * c for v, c in zip(vec, icpt, strict=True)) - floor]
        lower = [c[0] for c in cells] + [Fraction(1)]
        upper = [c[1] for c in cells] + [Fraction(1)]
        found = Polytope(lower, upper, rows, rhs, 4).maximize_ratio(numerator, [*d_vec, Fraction(0)])
        if found.status == "zero_denominator":
            return math.inf, None
        if found.status == "optimal" and found.value is not None and found.value > best:
            best, point = found.value, found.point
    return best, None if point is None else point[:3]


def unit_class(lower: float, gamma: float, tau: float | None, lipschitz: float) -> tuple[float, float, float]:
    """The class [lower, γ], E ≥ τ, L_A on the scale γ = 1, rounded outward: (lower/γ and max(τ, lower)/γ rounded
    down, L_A/γ rounded up), so the worst case over the scaled class is at least the exact one (a higher floor or a
    smaller box or Lipschitz constant only shrinks the class; ``proofs/outward.md`` §5).

    >>> unit_class(2.0, 2.5, None, 0.0)[0] < 0.8  # the float 0.8 is above 4/5
    True
    """
    g = Fraction(gamma)
    floor = lower if tau is None else max(tau, lower)
    return fraction_down(Fraction(lower) / g), fraction_down(Fraction(floor) / g), fraction_up(Fraction(lipschitz) / g)


def rr_class_value(
    rr: RandomizedResponseParameters, lower: float, gamma: float, tau: float | None, lipschitz: float, diameter: float
) -> float:
    """The black-box value of k-ary RR for the class [lower, γ], E ≥ τ, L_A (discrete metric scaled to ``diameter``),
    in nats, exact where the ratio overflows (lower = 0, L_A = 0: ε); rounded up. O(1): calibration evaluates it
    along the family.

    With L_A = 0, :func:`rr_box`'s value: the exact closed form at a rational t ≥ e^ε, rounded up; with L_A > 0,
    :func:`rr_lipschitz_ratio` (every piece's program exactly, at the same t), ``log_up`` of it
    (``proofs/outward.md`` §5).
    """
    if rr.k < 2 or gamma == 0 or lower == gamma:
        return 0.0
    if lipschitz * diameter == 0:
        lo, floor, _ = unit_class(lower, gamma, tau, 0.0)
        return rr_box(rr, lo, 1.0, floor).value
    g = Fraction(gamma)
    bottom = Fraction(lower) / g
    top = bottom if tau is None else max(Fraction(tau) / g, bottom)  # the floor
    ratio = rr_lipschitz_ratio(
        rr.k, rr.epsilon, bottom, Fraction(1), top, Fraction(lipschitz) * Fraction(diameter) / g
    )[0]
    return math.inf if ratio == math.inf else log_up(ratio)


def rr_law(kernel: Kernel, rr: RandomizedResponseParameters, groups: tuple, context_mechanism: Mechanism) -> Law:
    """compose(kernel, RR, M_X) without the k x k matrix: Q[x, a] = Σ_x̃ M_X[x, x̃] (q Σ_ã K[x̃, ã] + (p − q) K[x̃, a])."""
    k = kernel.probabilities
    behind = rr.q * k.sum(axis=1, keepdims=True) + (rr.p - rr.q) * k  # (x̃, a, u)
    law = behind if context_mechanism.is_identity else np.tensordot(context_mechanism.matrix, behind, axes=1)

    def support() -> BoolArray:  # for a finite ε, q > 0 exactly: a cell is reached from every released group
        s = k > 0 if math.isinf(rr.epsilon) else np.broadcast_to(np.any(k > 0, axis=1, keepdims=True), k.shape)
        if context_mechanism.is_identity:
            return s
        return np.tensordot(context_mechanism.support.astype(float), s.astype(float), axes=1) > 0

    smallest = rr.p if math.isinf(rr.epsilon) else rr.q
    filters = (context_mechanism, (f"{rr.k}-ary randomized response", rr.epsilon, smallest))
    check_representable(law, support, filters, (context_mechanism.inputs, groups, kernel.decisions))
    law = law / law.sum(axis=-1, keepdims=True)
    return Law(law, context_mechanism.inputs, groups, kernel.decisions, name="law", _owned=True)
