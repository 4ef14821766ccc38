"""Exact enclosures of a certificate's quantities: rationals, and intervals of rationals where e^ε enters.

Every float a certificate records is a dyadic rational, read exactly (:class:`fractions.Fraction`). A recorded
mechanism is either exact rows (``identity``, ``matrix``) or k-ary randomized response at ε, whose rows hold the
irrational t = e^ε: t is enclosed by rationals 2^-200 of it apart (:func:`exp_of`, python-flint's ``arb`` balls), and
each quantity by the interval its monotonicity in t gives. A logarithm is enclosed likewise (:func:`ln`). No
floating-point operation decides a result here (``proofs/outward.md`` §4).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from fairaudit.verification.schema import CertificateError

__all__ = [
    "INF",
    "Enclosure",
    "RecordedMechanism",
    "below_epsilon",
    "exact",
    "exp_of",
    "group_free",
    "independence",
    "integers",
    "ln",
    "ln_of",
    "recorded_array",
    "rr_matrix",
]

INF = math.inf
"""+inf, as the certificate writes it (``"inf"``)."""


@dataclass(frozen=True)
class Enclosure:
    """A closed interval [lo, hi] of extended reals holding an exact quantity (floats ±inf or Fractions)."""

    lo: Fraction | float
    hi: Fraction | float

    @classmethod
    def point(cls, x: Fraction | float) -> Enclosure:
        """The exact value ``x``."""
        return cls(x, x)

    def __add__(self, other: Enclosure) -> Enclosure:
        return Enclosure(self.lo + other.lo, self.hi + other.hi)


RATIONAL_DIGITS = 4_000
"""The longest exact rational ``"n/d"`` read, in characters: below Python's limit on integers read from decimal text
(4,300 digits, ``sys.get_int_max_str_digits``), as certify writes them."""

_RATIONAL = re.compile(r"-?[0-9]+/[0-9]+")


def exact(value: Any, field: str) -> Fraction | float:
    """A recorded JSON number as an exact rational (``"inf"`` as +inf; an exact rational written ``"n/d"``, as a
    certificate writes a multiplier that is not a float, as itself).

    Raises
    ------
    CertificateError
        Naming ``field`` when the value is not a finite number, ``"inf"`` or ``"n/d"`` (at most
        :data:`RATIONAL_DIGITS` digits).

    Examples
    --------
    >>> exact(0.1, "x") == Fraction(3602879701896397, 36028797018963968), exact("inf", "x"), exact("-1/3", "x")
    (True, inf, Fraction(-1, 3))
    """
    if value == "inf":
        return INF
    if isinstance(value, str) and len(value) <= RATIONAL_DIGITS and _RATIONAL.fullmatch(value):
        n, d = value.split("/")
        if int(d):
            return Fraction(int(n), int(d))
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise CertificateError(field, 'must be a finite number or "inf"', value)
    return Fraction(value)


def recorded_array(value: Any, field: str) -> list[Any]:
    """Nested lists of recorded numbers as nested lists of exact rationals, any shape, axes kept in order.

    None stays None (an empty cell of an estimated table); ``"inf"`` is +inf.

    Raises
    ------
    CertificateError
        Naming ``field`` and the index (``field[0][2]``) of an entry that is not a finite number or ``"inf"``.

    Examples
    --------
    >>> recorded_array([[0.5, None], ["inf", 1]], "kernel")
    [[Fraction(1, 2), None], [inf, Fraction(1, 1)]]
    """
    if isinstance(value, list):
        return [recorded_array(v, f"{field}[{i}]") for i, v in enumerate(value)]
    return None if value is None else exact(value, field)  # type: ignore[return-value]


def integers(tables: Sequence[Sequence[Sequence[Fraction]]]) -> tuple[np.ndarray, int]:
    """Tables of rationals as integers over one common denominator: an object array of shape (n_tables, n_rows,
    n_decisions), and the denominator.

    Examples
    --------
    >>> a, d = integers([[[Fraction(1, 2), Fraction(1, 3)]]])
    >>> a.tolist(), d
    ([[[3, 2]]], 6)
    """
    d = math.lcm(1, *(v.denominator for t in tables for row in t for v in row))
    out = np.array([[[v.numerator * (d // v.denominator) for v in row] for row in t] for t in tables], dtype=object)
    return out, d


def group_free(values: Any) -> bool:
    """Whether a recorded utility's values (``inputs.utility.values``: g(u), or a table g(u, x, a) indexed ``[x][a][u]``)
    are the same for every group (``Utility.depends_on_group`` is its negation).

    Examples
    --------
    >>> group_free([1.0, 0.0]), group_free([[[1.0, 0.0], [1.0, 0.0]]]), group_free([[[1.0, 0.0], [0.5, 0.0]]])
    (True, True, False)
    """
    return not isinstance(values[0], list) or all(row == table[0] for table in values for row in table)


INDEPENDENCE = Fraction(1e-9)
"""max |P(x, a) − P(x) P(a)| up to which certify calls X and A independent (``Population.independence``)."""


def independence(probabilities: Any) -> tuple[list[list[Fraction]], Fraction | float]:
    """The recorded population's departure from independence, exactly: |P(x, a) − P(x) P(a)| indexed ``[x][a]``, and
    F = max r / min r over r(x, a) = P(x, a)/(P(x) P(a)) where P(x), P(a) > 0 (1 when X and A are independent, +inf
    where some r is 0; ``proofs/black_box.md`` §6).

    Examples
    --------
    >>> deviation, spread = independence([[0.5, 0.0], [0.25, 0.25]])
    >>> deviation[0], spread
    ([Fraction(1, 8), Fraction(1, 8)], inf)
    """
    p = recorded_array(probabilities, "inputs.population.probabilities")
    p_x, p_a = [sum(row) for row in p], [sum(col) for col in zip(*p)]
    r = [p[x][a] / (p_x[x] * p_a[a]) for x in range(len(p_x)) if p_x[x] for a in range(len(p_a)) if p_a[a]]
    deviation = [[abs(p[x][a] - p_x[x] * p_a[a]) for a in range(len(p_a))] for x in range(len(p_x))]
    return deviation, INF if min(r) == 0 else max(r) / min(r)


BITS = 200
"""The relative width of :func:`ln`'s and :func:`exp_of`'s enclosures: their ends are at most 2^-200 (about 1e-60)
times the quantity apart (ln x; e^x − 1 within 1/2 of 0, else e^x), far inside the tolerance verify judges to."""


def ln(x: Fraction | float) -> Enclosure:
    """Rationals around ln x for a rational x ≥ 0, at most 2^-:data:`BITS`·|ln x| apart (ln 0 = −inf, ln 1 = 0,
    ln +inf = +inf; nats).

    Examples
    --------
    >>> e = ln(Fraction(7, 3))
    >>> abs(e.lo - Fraction(math.log(7 / 3))) < Fraction(1, 10**15) and e.hi - e.lo < Fraction(1, 10**59)
    True
    """
    if x == INF or x == 0:
        return Enclosure.point(INF if x == INF else -INF)
    return Enclosure.point(Fraction(0)) if x == 1 else _arb_ends(Fraction(x), log=True)


def exp_of(x: Fraction) -> Enclosure:
    """Rationals [lo, hi] around e^x for a rational x (nats), at most 2^-:data:`BITS`·min(e^x, |e^x − 1|) apart;
    beyond 10^6, [2^1000, +inf] (e^x > 2^(1.44·10^6) there; a finite lower end, so that randomized response's
    q = 1/(e^ε + k − 1) keeps a positive upper end, and a small one: its arithmetic stays cheap), below −10^6,
    [0, 2^-1000].

    Examples
    --------
    >>> e = exp_of(Fraction(0))
    >>> e.lo == e.hi == 1
    True
    >>> e = exp_of(Fraction(2 * 10**6))
    >>> e.lo == 2**1000 and e.hi == INF
    True
    """
    if abs(x) > 10**6:
        return Enclosure(Fraction(2**1000), INF) if x > 0 else Enclosure(Fraction(0), Fraction(1, 2**1000))
    return Enclosure.point(Fraction(1)) if x == 0 else _arb_ends(Fraction(x), log=False)


def _arb_ends(q: Fraction, log: bool) -> Enclosure:
    """Rationals around ln q (``log``; q > 0, q ≠ 1) or e^q (q ≠ 0), at most 2^-:data:`BITS` of the quantity apart.

    python-flint's ``arb`` computes a ball, a midpoint and a radius, that contains the exact value (Johansson, "Arb:
    efficient arbitrary-precision midpoint-radius interval arithmetic", IEEE Transactions on Computers 66(8), 2017);
    its ends (``lower``, ``upper``: mid ∓ rad rounded outward) are dyadic rationals, read exactly, so they hold the
    value. Within 1/2 of 1 (ln) or of 0
    (exp) the ball is of ln(1 + y) at y = q − 1 (``log1p``) or of e^q − 1 (``expm1``, then 1 added), which keep their
    relative accuracy however small the quantity. The working precision starts 64 bits above :data:`BITS` and grows
    while the ends are farther apart than that (arb's balls are a few units of it wide: no argument verify meets
    needs a second try); the last ball is returned as it is.
    """
    import flint  # (here, not at import: `import fairaudit` loads no python-flint)

    near = 2 * abs(q - 1 if log else q) < 1
    y = q - 1 if log and near else q
    for bits in (BITS + 64, 4 * BITS, 16 * BITS, 64 * BITS):
        with flint.ctx.workprec(bits):  # (the ends are rounded outward to the working precision)
            x = flint.arb(flint.fmpq(y.numerator, y.denominator))
            ball = (x.log1p() if near else x.log()) if log else (x.expm1() if near else x.exp())
            lower, upper = ball.lower(), ball.upper()
            if ball.is_finite() and (upper - lower) * 2**BITS <= ball.abs_lower():  # (true only when sure)
                break
    if not ball.is_finite():
        raise ArithmeticError(f"{'ln' if log else 'exp'} of {q}: no finite ball")
    offset = int(near and not log)
    ends = (end.fmpq() for end in (lower, upper))  # (a ball's ends are exact dyadic rationals: fmpq reads them)
    return Enclosure(*(Fraction(int(q.p), int(q.q)) + offset for q in ends))


def ln_of(e: Enclosure) -> Enclosure:
    """The enclosure of ln over an enclosure [lo, hi] of a quantity ≥ 0 (ln is increasing: the lower end of ln lo's
    enclosure, the upper end of ln hi's; ln 0 = −inf).

    Examples
    --------
    >>> e = ln_of(Enclosure(Fraction(1), Fraction(1)))
    >>> e.lo == e.hi == 0
    True
    """
    return Enclosure(ln(e.lo).lo, ln(e.hi).hi)


def below_epsilon(ratio: Enclosure, eps: Enclosure | None) -> Enclosure:
    """ln of a worst ratio, enclosed, its upper end at most ε(M_A) where given: under pure ε-DP no model's ratio
    exceeds e^ε (post-processing), which decides the ties where the worst case is ε itself (None: ln only, where the
    worst case may exceed ε, a utility that depends on the group).

    Examples
    --------
    >>> below_epsilon(Enclosure(Fraction(1), Fraction(4)), Enclosure.point(Fraction(1))).hi
    Fraction(1, 1)
    """
    logs = ln_of(ratio)
    return logs if eps is None else Enclosure(logs.lo, min(logs.hi, eps.hi))


def rr_matrix(t: Fraction | float, k: int) -> tuple[tuple[Fraction, ...], ...]:
    """k-ary randomized response's rows at e^ε = t: t/(t + k − 1) kept, 1/(t + k − 1) to each other value (the
    identity's at t = +inf).

    Examples
    --------
    >>> rr_matrix(Fraction(3), 2), rr_matrix(INF, 2)[0]
    (((Fraction(3, 4), Fraction(1, 4)), (Fraction(1, 4), Fraction(3, 4))), (Fraction(1, 1), Fraction(0, 1)))
    """
    p, q = (t / (t + k - 1), 1 / (t + k - 1)) if isinstance(t, Fraction) else (Fraction(1), Fraction(0))
    return tuple(tuple(p if i == j else q for j in range(k)) for i in range(k))


@dataclass(frozen=True)
class RecordedMechanism:
    """A mechanism as a certificate records it (``inputs.sensitive_mechanism``): its kind and exact parameters.

    Attributes
    ----------
    kind : {"identity", "randomized_response", "matrix"}
    inputs, outputs : tuple
        The labels.
    epsilon : Fraction or None
        Randomized response's ε (nats).
    rows : tuple of tuple of Fraction, or None
        A matrix's rows P(output | input), shape (n_inputs, n_outputs).
    """

    kind: str
    inputs: tuple
    outputs: tuple
    epsilon: Fraction | float | None = None
    rows: tuple[tuple[Fraction, ...], ...] | None = None

    @classmethod
    def from_record(cls, data: Mapping[str, Any], field: str) -> RecordedMechanism:
        """Read ``data`` (already checked against the schema); ``field`` names it in errors."""
        inputs, outputs = tuple(data["inputs"]), tuple(data["outputs"])
        kind = data["kind"]
        if kind == "randomized_response":
            return cls(kind, inputs, outputs, epsilon=exact(data["epsilon"], f"{field}.epsilon"))
        if kind == "matrix":
            rows = tuple(tuple(r) for r in recorded_array(data["matrix"], f"{field}.matrix"))
            if len(rows) != len(inputs) or any(len(r) != len(outputs) for r in rows):
                raise CertificateError(f"{field}.matrix", f"must have shape ({len(inputs)}, {len(outputs)})", "")
            return cls(kind, inputs, outputs, rows=rows)
        return cls(kind, inputs, outputs)

    @property
    def k(self) -> int:
        """The number of inputs."""
        return len(self.inputs)

    def t(self) -> Enclosure:
        """Randomized response's e^ε, enclosed, never below 1 (ε ≥ 0: a lower end below 1 would be a randomized
        response with its roles swapped)."""
        if self.epsilon == INF:
            return Enclosure.point(INF)
        t = exp_of(self.epsilon)  # type: ignore[arg-type]
        return Enclosure(max(Fraction(1), t.lo), t.hi)

    def rr_ends(self) -> tuple[tuple[Fraction, Fraction], tuple[Fraction, Fraction]]:
        """Randomized response's exact (p, q) at the lower and at the upper end of its e^ε; beyond ε = 10^6, where
        e^ε has no finite upper end, the upper end is the identity's (1, 0), the limit as e^ε → ∞.

        A worst case over models behind randomized response is non-decreasing in e^ε, and the identity followed by
        randomized response at any e^ε is randomized response there, so the identity's worst case bounds it from
        above (post-processing; ``proofs/verification.md`` §4d).

        >>> m = RecordedMechanism("randomized_response", ("a", "b"), ("a", "b"), epsilon=Fraction(2 * 10**6))
        >>> m.rr_ends()[1]
        (Fraction(1, 1), Fraction(0, 1))
        """
        t, m = self.t(), self.k - 1
        ends = [(t / (t + m), 1 / (t + m)) if t != INF else (Fraction(1), Fraction(0)) for t in (t.lo, t.hi)]
        return ends[0], ends[1]  # type: ignore[return-value]

    def rr_rows(self) -> tuple[Enclosure, Enclosure]:
        """Randomized response's (p, q) = (t/(t + k − 1), 1/(t + k − 1)), enclosed (p increases in t, q decreases)."""
        (p_lo, q_hi), (p_hi, q_lo) = self.rr_ends()
        return Enclosure(p_lo, p_hi), Enclosure(q_lo, q_hi)

    def epsilon_enclosure(self) -> Enclosure:
        """ε(M) = max over outputs and pairs of ln M[a, o]/M[a', o] (+inf when one input reaches an output another
        cannot), enclosed; exact for randomized response."""
        if self.kind == "identity":
            return Enclosure.point(INF if self.k >= 2 else Fraction(0))
        if self.kind == "randomized_response":
            return Enclosure.point(self.epsilon if self.k >= 2 else Fraction(0))  # type: ignore[arg-type]
        assert self.rows is not None
        reached = [(max(column), min(column)) for column in zip(*self.rows) if max(column) > 0]
        if any(bottom == 0 for _, bottom in reached):
            return Enclosure.point(INF)
        return ln(max([Fraction(1), *(top / bottom for top, bottom in reached)]))

    def matrix_rows(self) -> tuple[tuple[Fraction, ...], ...] | None:
        """Exact rows: a matrix's, the identity's; None for randomized response (irrational)."""
        if self.kind == "matrix":
            return self.rows
        if self.kind == "identity":
            return tuple(tuple(Fraction(int(i == j)) for j in range(self.k)) for i in range(self.k))
        return None

    def largest_delta(self, epsilon: Fraction) -> Enclosure:
        """δ(ε) = max over a ≠ a' of Σ_o [M[a, o] − e^ε M[a', o]]₊, enclosed (it decreases in e^ε)."""
        # (one group: no pair; randomized response at ε ≥ ε_M: p − e^ε q = (e^ε_M − e^ε)/(e^ε_M + k − 1) ≤ 0, exactly 0)
        if self.k < 2 or (self.kind == "randomized_response" and epsilon >= self.epsilon):  # type: ignore[operator]
            return Enclosure.point(Fraction(0))
        t = exp_of(epsilon)
        low = high = self.matrix_rows()
        if low is None:  # randomized response: the rows of a pair on its own two columns (elsewhere both q: no mass
            low, high = (((p, q), (q, p)) for p, q in self.rr_ends())  # at e^ε ≥ 1), at each end of e^ε_M (δ rises)
        return Enclosure(_largest_hockey_stick(low, t.hi), _largest_hockey_stick(high, t.lo))  # type: ignore[arg-type]

    def tight_pair_log(
        self, lipschitz: Fraction, gamma: Fraction, tau: Fraction, metric: Sequence[Sequence[Any]] | None
    ) -> tuple[Enclosure, int, int]:
        """The tight bound, enclosed, and its pair (indices): max over pairs (a, a') of min over t = e^ε ≥ 1 of
        ln(t + (L_A d(a, a') + γ δ_aa'(t))/τ) (``proofs/tight_bound.md``).

        For each pair the function of t is convex and piecewise linear (δ_aa' is), so its minimum is at t = 1 or at
        a ratio M[a, o]/M[a', o] ≥ 1: each is evaluated exactly. Randomized response's pairs are alike but for
        d(a, a'), and the bound increases in d: the pair at the largest distance, at t = 1 or t = e^ε, where the value
        is ε + ln(1 + L_A d/(τ e^ε)) (exactly ε when L_A = 0).
        """
        if self.kind == "randomized_response":
            # every pair is alike but for d(a, a'), and the bound increases in d: the pair at the largest distance
            pairs = itertools.permutations(range(self.k), 2)
            a, b = (0, 1) if metric is None else max(pairs, key=lambda ab: Fraction(metric[ab[0]][ab[1]]))
            d = Fraction(1) if metric is None else Fraction(metric[a][b])
            c = lipschitz * d / tau
            t, m = self.t(), self.k - 1
            if t.hi == INF:  # the identity: δ = 1 at every ε, the minimum at t = 1
                return ln(1 + c + gamma / tau), a, b
            # at t = 1: 1 + c + (γ/τ)(t − 1)/(t + k − 1), increasing in t
            one = ln_of(Enclosure(*(1 + c + gamma / tau * (end - 1) / (end + m) for end in (t.lo, t.hi))))
            at_eps = Enclosure.point(self.epsilon) + ln_of(Enclosure(1 + c / t.hi, 1 + c / t.lo))  # type: ignore[arg-type]
            return Enclosure(min(one.lo, at_eps.lo), min(one.hi, at_eps.hi)), a, b
        rows = self.matrix_rows()
        assert rows is not None
        (ints,), den = integers([rows])
        scale = gamma / tau

        def shift(a: int, b: int) -> Fraction:
            return lipschitz * (Fraction(1) if metric is None else Fraction(metric[a][b])) / tau

        # the value at t = 1 bounds each pair's minimum above: pairs in decreasing order of it, until none can pass
        sticks = _hockey_sticks(ints, Fraction(1))
        bounds: Iterator[tuple[Fraction, int, int]]
        if (metric is None or lipschitz == 0) and scale > 0:  # (one shift: the sums order the pairs, in integers)
            bounds = ((1 + shift(a, b) - scale * Fraction(minus, den), a, b)
                      for minus, a, b in sorted((-stick, a, b) for a, b, stick in sticks))  # fmt: skip
        else:
            bounds = iter(sorted(((1 + shift(a, b) + scale * Fraction(stick, den), a, b) for a, b, stick in sticks),
                                 key=lambda c: (-c[0], c[1], c[2])))  # fmt: skip
        best_value: Fraction | float = -INF
        pair = (0, 1)
        for bound, a, b in bounds:
            if bound <= best_value:
                break
            value = _pair_minimum(ints[a], ints[b], den, shift(a, b), scale)
            if value > best_value:
                best_value, pair = value, (a, b)
        return ln(best_value), pair[0], pair[1]


def _largest_hockey_stick(rows: Sequence[Sequence[Fraction]], t: Fraction | float) -> Fraction:
    """max over ordered pairs of distinct rows of Σ_o [ra_o − t rb_o]₊, exactly (t may be +inf: the mass of ra where
    rb is 0), in integers over one denominator."""
    ints, den = integers([rows])
    best = max((stick for _, _, stick in _hockey_sticks(ints[0], t)), default=0)
    return Fraction(best, den * (t.denominator if isinstance(t, Fraction) else 1))


def _hockey_sticks(ints: Sequence[Sequence[int]], t: Fraction | float) -> Iterator[tuple[int, int, int]]:
    """(a, b, Σ_o [ra_o − t rb_o]₊ times t's denominator) for every ordered pair of distinct integer rows (t = +inf:
    the sum of ra where rb is 0), exactly: object arrays, one row against all the others at a time."""
    matrix = np.array(ints, dtype=object)
    for a, row in enumerate(matrix):
        others = np.delete(matrix, a, axis=0)
        if isinstance(t, Fraction):
            gap = np.maximum(row * t.denominator - others * t.numerator, 0)
        else:
            gap = np.where(others == 0, row, 0)
        for b, stick in enumerate(gap.sum(axis=1).tolist()):
            yield a, b + (b >= a), stick


def _pair_minimum(ra: Sequence[int], rb: Sequence[int], den: int, shift: Fraction, scale: Fraction) -> Fraction:
    """min over t ≥ 1 of t + shift + scale·Σ_o [ra_o − t rb_o]₊/den (rows as integers over ``den``), exactly.

    The function is convex and piecewise linear in t, so its minimum is at t = 1 or at a breakpoint ra_o/rb_o ≥ 1;
    the breakpoints are visited in increasing order, each cell leaving the sum as t passes its own (O(n log n)).

    Examples
    --------
    Rows (3/4, 1/4) and (1/4, 3/4) over 4, no shift, scale 2: at t = 1, 1 + 2·(1/2) = 2; at t = 3, 3.

    >>> _pair_minimum([3, 1], [1, 3], 4, Fraction(0), Fraction(2))
    Fraction(2, 1)
    """
    always = sum(x for x, y in zip(ra, rb) if y == 0)  # the cells a' never reaches stay in the sum
    cells = sorted((Fraction(x, y), x, y) for x, y in zip(ra, rb) if y > 0 and x > y)  # (breakpoint, ra, rb)
    top, bottom = sum(c[1] for c in cells), sum(c[2] for c in cells)  # Σ ra, Σ rb over the cells with ratio > t
    best = 1 + shift + scale * Fraction(always + top - bottom, den)
    for ratio, x, y in cells:
        top, bottom = top - x, bottom - y  # at t = ratio this cell's term is 0: drop it (and any tied before it)
        best = min(best, ratio + shift + scale * (Fraction(always + top, den) - ratio * Fraction(bottom, den)))
    return best
