"""Outward rounding: certified upper bounds rounded up, lower bounds down.

A certified number is a promise about a real number: an upper bound must be
≥ it, a lower bound ≤ it. Floating point rounds to nearest, so a number
computed in it may land a unit in the last place on the wrong side. This
module is the one place that turns exact or enclosed values into floats on
the right side:

* :func:`up` and :func:`down` move a float one unit in the last place
  outward (``numpy.nextafter``), for a value whose only error is one rounding
  to nearest;
* :func:`widen_up` and :func:`widen_down` move it by an error bound, for a
  closed form evaluated in floating point whose error is bounded (relative
  and absolute parts);
* :func:`product_ends` encloses non-negative products (and sums of them) computed
  with a counted number of roundings, :func:`product_roundings` counts them;
* :func:`fraction_up` and :func:`fraction_down` round an exact rational;
  :func:`quotient_nearest` rounds one to nearest, for what a float only chooses (never a certified number);
* :func:`log_up`, :func:`log_down`, :func:`exp_up` and :func:`exp_down`
  evaluate ln and exp of an exact rational (a float is one) in python-flint's
  ``arb`` ball arithmetic, whose every result is a ball (midpoint and radius)
  that contains the exact value (Johansson, "Arb: efficient arbitrary-precision
  midpoint-radius interval arithmetic", IEEE Transactions on Computers 66(8),
  2017), then round the ball's ends outward: the float returned is on the
  stated side of the exact value; :func:`ln_bounds` and :func:`exp_bounds`
  return those ends as rationals, at most 2^-:data:`BITS` of the quantity apart.

The balls are computed at :data:`BITS` + 32 working bits, doubled while
their ends are more than 2^-:data:`BITS` of the quantity apart, up to 2^14
bits, where a ball still that wide is returned as it is (its ends still hold
the value) and one not finite raises ArithmeticError. No argument these
functions accept comes near: arb's balls are a few units of the working
precision wide, and an exponent's |x| ≤ 10^6 costs 20 of the 32 spare bits.
python-flint's precision is one per process (``flint.ctx.prec``): it is set
under a lock and restored after each evaluation, so that neither the caller
nor another thread calling this module sees it changed (code using ``arb`` on
another thread at that moment would compute at it meanwhile, still soundly:
arb's balls hold at every precision).

OpenDP rounds every privacy quantity the same way (its ``inf_ln``,
``inf_exp``, ``inf_add``). Proof that each function is on its side:
``proofs/outward.md``.
"""

from __future__ import annotations

import functools
import math
import sys
import threading
from fractions import Fraction
from typing import TYPE_CHECKING, overload

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray

if TYPE_CHECKING:
    import flint

__all__ = [
    "BITS",
    "Exact",
    "down",
    "exp_bounds",
    "exp_down",
    "exp_up",
    "fraction_down",
    "fraction_up",
    "gap_between",
    "ln_bounds",
    "log_down",
    "log_up",
    "product_ends",
    "product_roundings",
    "quotient_nearest",
    "rounding_error",
    "sum_ends",
    "up",
    "widen_down",
    "widen_up",
]

BITS = 200
"""Relative width of the enclosures of :func:`ln_bounds` and :func:`exp_bounds`: their ends are at most 2^-200 (about
10^-60) times the quantity apart, |ln x| for ln x, min(e^x, |e^x − 1|) for e^x (so that near 0 and 1 the small e^x − 1
and ln x keep their own 60 digits)."""

Exact = Fraction | int | float
"""An exact real: a rational, an integer, or a float (every finite float is a rational)."""


@overload
def up(x: float) -> float: ...
@overload
def up(x: npt.NDArray[np.floating]) -> FloatArray: ...
def up(x: float | npt.NDArray[np.floating]) -> float | FloatArray:
    """The next float above ``x`` (+inf stays +inf; NaN stays NaN).

    The upper end of a value computed with one rounding to nearest.

    Examples
    --------
    >>> up(1.0) - 1.0 == 2.0**-52
    True
    """
    out = np.nextafter(x, np.inf)
    return float(out) if np.ndim(out) == 0 else out


@overload
def down(x: float) -> float: ...
@overload
def down(x: npt.NDArray[np.floating]) -> FloatArray: ...
def down(x: float | npt.NDArray[np.floating]) -> float | FloatArray:
    """The next float below ``x`` (−inf stays −inf; NaN stays NaN).

    Examples
    --------
    >>> 1.0 - down(1.0) == 2.0**-53
    True
    """
    out = np.nextafter(x, -np.inf)
    return float(out) if np.ndim(out) == 0 else out


def _error(a: FloatArray, relative: npt.ArrayLike, absolute: npt.ArrayLike) -> FloatArray:
    """``relative·|a| + absolute`` rounded up (each of its two operations moved one unit up)."""
    return np.nextafter(np.nextafter(np.abs(a) * relative, np.inf) + absolute, np.inf)


def widen_up(x: npt.ArrayLike, relative: npt.ArrayLike, absolute: npt.ArrayLike = 0.0) -> float | FloatArray:
    """``x`` plus an error bound ``relative·|x| + absolute``, rounded up.

    Parameters
    ----------
    x : float or array_like
        A value computed in floating point.
    relative, absolute : float or array_like
        Its error bound, ``|x − exact| ≤ relative·|x| + absolute``; ≥ 0 (arrays broadcast against ``x``).

    Returns
    -------
    float or numpy.ndarray
        A float ≥ the exact value (+inf and NaN unchanged). Each operation
        is rounded to nearest and then moved one unit up, which covers its
        own rounding: the error bound first, then the sum.

    Examples
    --------
    >>> widen_up(1.0, 2.0**-50) > 1.0 + 2.0**-50
    True
    """
    a = np.asarray(x, dtype=float)
    return up(a + _error(a, relative, absolute))


def widen_down(x: npt.ArrayLike, relative: npt.ArrayLike, absolute: npt.ArrayLike = 0.0) -> float | FloatArray:
    """``x`` minus an error bound ``relative·|x| + absolute``, rounded down (the mirror of :func:`widen_up`).

    Examples
    --------
    >>> widen_down(1.0, 2.0**-50) < 1.0 - 2.0**-50
    True
    """
    a = np.asarray(x, dtype=float)
    return down(a - _error(a, relative, absolute))


def product_roundings(*factors: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """How many roundings the product of ``factors`` (broadcast together) may carry, entry by entry.

    A product with a factor 0 is exactly 0; a multiplication by 1 is exact and every other one rounds at most once,
    so a product of factors of which j are neither 0 nor 1 carries at most max(j − 1, 0) roundings, in any order.

    Examples
    --------
    >>> product_roundings(np.array([1.0, 0.3, 0.3]), np.array([0.7, 1.0, 0.7])).tolist()
    [0, 0, 1]
    """
    arrays = [np.asarray(f) for f in factors]
    general = sum(((f != 0) & (f != 1)).astype(np.int64) for f in arrays)
    zero = functools.reduce(np.logical_or, [f == 0 for f in arrays])
    return np.where(zero, 0, np.maximum(np.asarray(general, dtype=np.int64) - 1, 0))


def rounding_error(roundings: npt.ArrayLike) -> float | FloatArray:
    """k·u/(1 − 2k·u) rounded up, u = 2^-53: the error bound, relative to the computed value, of a value carrying at
    most k roundings to nearest (|x − exact| ≤ γ_k·|exact| with γ_k = k·u/(1 − k·u); Higham, *Accuracy and Stability
    of Numerical Algorithms*, 2nd ed., Lemma 3.1).

    Examples
    --------
    >>> rounding_error(0), rounding_error(1) > 2.0**-53
    (0.0, True)
    """
    k = np.asarray(roundings, dtype=float) * 2.0**-53
    out = np.where(k == 0, 0.0, up(up(k) / down(1.0 - 2.0 * k)))
    return float(out) if np.ndim(out) == 0 else np.asarray(out)


def product_ends(x: npt.ArrayLike, roundings: npt.ArrayLike, nonzero: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Lower and upper ends of non-negative reals computed in floating point with a counted number of roundings.

    Parameters
    ----------
    x : array_like
        The computed values, each a product or a sum of products of non-negative floats, ≥ 0.
    roundings : array_like of int
        For each value, an upper bound k on the roundings to nearest behind it (a sum of n non-negative
        terms adds n − 1 to its terms' largest count; :func:`product_roundings` counts a product's).
        0 means exact: the value is its own two ends.
    nonzero : array_like of bool
        Whether the exact value is positive (a product is 0 exactly when one of its factors is): a zero
        value's ends are 0, a positive one's lower end is not below 0 and its upper end covers underflow.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``(low, high)``, broadcast together, with low ≤ exact ≤ high: the value widened by
        :func:`rounding_error` (k) relative to it, plus k·2^-1074 for gradual underflow.

    Examples
    --------
    >>> low, high = product_ends(np.array([0.3 * 0.7, 0.5, 0.0]), np.array([1, 0, 1]), np.array([True, True, False]))
    >>> bool(low[0] < 0.3 * 0.7 < high[0]), float(low[1]), float(high[1]), float(high[2])
    (True, 0.5, 0.5, 0.0)
    """
    value = np.asarray(x, dtype=float)
    k = np.asarray(roundings, dtype=float)
    live = np.asarray(nonzero, dtype=bool)
    relative = rounding_error(k)
    absolute = k * 2.0**-1074
    exact = k == 0
    high = np.where(exact, value, widen_up(value, relative, absolute))
    low = np.where(exact, value, np.maximum(widen_down(value, relative, absolute), 0.0))
    return np.where(live, low, 0.0), np.where(live, high, 0.0)


def sum_ends(rows: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The exact sums of the floats along the last axis, enclosed: (upper, lower) ends, each a float, equal where the
    sum is one.

    Parameters
    ----------
    rows : array_like, shape (..., n)
        Finite floats.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        ``(high, low)``, shape (...): ``math.fsum`` of each row (correctly rounded), stepped up or down where the
        exact sum lies beyond it (the sign of the remainder, itself summed by ``math.fsum``, is exact).

    Examples
    --------
    >>> high, low = sum_ends([[0.7, 0.3], [0.5, 0.5]])
    >>> float(high[0]), float(low[0]) < 1.0, float(high[1]), float(low[1])
    (1.0, True, 1.0, 1.0)
    """
    a = np.asarray(rows, dtype=float)
    flat = a.reshape(-1, a.shape[-1]) if a.ndim else a.reshape(1, 1)
    high, low = np.empty(len(flat)), np.empty(len(flat))
    for i, row in enumerate(flat.tolist()):  # (a row at a time: fsum is exact, numpy's sum is not)
        total = math.fsum(row)
        rest = math.fsum([*row, -total])
        high[i] = total if rest <= 0 else math.nextafter(total, math.inf)
        low[i] = total if rest >= 0 else math.nextafter(total, -math.inf)
    return high.reshape(a.shape[:-1]), low.reshape(a.shape[:-1])


def fraction_up(x: Exact) -> float:
    """The smallest float ≥ the rational ``x`` (+inf beyond the largest float).

    Examples
    --------
    >>> fraction_up(Fraction(1, 3)) > 1 / 3, fraction_up(Fraction(1, 2))
    (True, 0.5)
    """
    q = Fraction(x)
    try:
        f = float(q)  # correctly rounded to nearest (Fraction.__float__ divides integers exactly)
    except OverflowError:
        return math.inf if q > 0 else -sys.float_info.max
    if math.isfinite(f) and Fraction(f) < q:
        f = math.nextafter(f, math.inf)
    return f


def gap_between(value: float, witness: float) -> float:
    """``value − witness`` rounded up: the certified width of the interval [witness, value] (NaN without both).

    Examples
    --------
    >>> gap_between(2.0, 1.0), gap_between(math.inf, math.inf)
    (1.0, 0.0)
    """
    if math.isnan(value) or math.isnan(witness):
        return math.nan
    if value == witness:
        return 0.0
    return up(value - witness)


def fraction_down(x: Exact) -> float:
    """The largest float ≤ the rational ``x`` (−inf below the most negative float).

    Examples
    --------
    >>> third = Fraction(1, 3)
    >>> fraction_down(third) <= third < fraction_up(third), fraction_down(Fraction(-1, 2))
    (True, -0.5)
    """
    return -fraction_up(-Fraction(x))


_EXP_FAR = 1000
"""|x| beyond which e^x is above every float (x > 0) or below the smallest positive one (x < 0)."""


def quotient_nearest(n: int, m: int) -> float:
    """n/m (m > 0) to the nearest float, ±inf beyond the largest (where ``float`` and ``/`` raise OverflowError).

    For a float that only chooses (a threshold to try, a decision to keep), never for a certified number: a
    rational x reads as ``quotient_nearest(x.numerator, x.denominator)``.

    Examples
    --------
    >>> quotient_nearest(1, 3) == 1 / 3, quotient_nearest(-(10**400), 1)
    (True, -inf)
    """
    try:
        return n / m  # (correctly rounded: int true division)
    except OverflowError:
        return math.inf if n > 0 else -math.inf  # (copysign would convert n to a float, and raise)


_TINY = math.ulp(0.0)
"""The smallest positive float."""


_GUARD = 32
"""Working bits beyond :data:`BITS`: room for the rounding of the argument to a ball and of the ball's ends."""

_MOST_BITS = 2**14
"""The working precision at which :func:`_ball_ends` stops doubling."""

_PRECISION = threading.Lock()
"""Held while python-flint's precision (one per process, ``flint.ctx.prec``) is set for this module."""


def _wide(ball: flint.arb, ends: flint.arb, ln: bool, near: bool) -> bool:
    """Whether ``ball``'s ends, ``ends`` apart, may be more than 2^-:data:`BITS` times the quantity apart (|v| for
    v = ln q, min(v, |v − 1|) for v = e^q), judged by arb's comparisons, true only when true for every point of the two
    balls compared (a ball not finite is wide)."""
    width = ends * 2**BITS
    if ln:
        return not width <= ball.abs_lower()
    value, excess = (ball + 1, ball) if near else (ball, ball - 1)  # balls around v and v − 1
    return not (width <= value.lower() and width <= excess.abs_lower())


def _ball_ends(q: Fraction, ln: bool) -> tuple[flint.arb, flint.arb, int]:
    """The ends of arb's ball around ln q for q > 0, q ≠ 1 (``ln``) or around e^q for q ≠ 0 with |q| ≤ 10^6: (lower,
    upper, offset), exact balls, v between offset + lower and offset + upper.

    Within 1/2 of 1 (ln) or of 0 (exp) the ball is of ln(1 + y) at y = q − 1 (arb's ``log1p``) or of e^q − 1
    (``expm1``; offset 1, 0 otherwise), which keep their relative accuracy however small the quantity. It is computed
    at :data:`BITS` + :data:`_GUARD` working bits, doubled while :func:`_wide` (arb's balls are a few units of the
    working precision wide, so no argument accepted here needs a second try; the doubling is there so that the width
    promised does not rest on that); at :data:`_MOST_BITS` a ball still wide is returned as it is (its ends still hold
    v), one not finite raises ArithmeticError.
    """
    n, d = q.numerator, q.denominator
    near = 2 * abs(n - d if ln else n) < d  # |q − 1| < 1/2 (ln) or |q| < 1/2 (exp)
    import flint  # (here, not at import: `import fairaudit` loads no solver library)

    argument = flint.fmpq(n - d if ln and near else n, d)  # y = q − 1 for log1p, else q
    bits = BITS + _GUARD
    with _PRECISION:
        saved = flint.ctx.prec
        try:
            while True:
                flint.ctx.prec = bits
                x = flint.arb(argument)  # a ball around the rational (exact when it is a short dyadic)
                ball = (x.log1p() if near else x.log()) if ln else (x.expm1() if near else x.exp())
                if bits >= _MOST_BITS and not ball.is_finite():
                    raise ArithmeticError(
                        f"{'ln' if ln else 'exp'} of {quotient_nearest(n, d)}: no finite ball at {bits} bits"
                    )
                lower, upper = ball.lower(), ball.upper()  # (exact, rounded outward to these bits)
                if bits >= _MOST_BITS or not _wide(ball, upper - lower, ln, near):  # (a ball around their distance)
                    return lower, upper, int(near and not ln)
                bits *= 2
        finally:
            flint.ctx.prec = saved


def _rational(a: flint.arb, offset: int = 0) -> Fraction:
    """``offset`` plus the exact value of an exact, finite ball (an end of a ball: m·2^e), as a rational."""
    man, exp = a.man_exp()
    m, e = int(man), int(exp)
    value = Fraction(m << e) if e >= 0 else Fraction(m, 1 << -e)
    return value + offset if offset else value


def _ends(q: Fraction, ln: bool) -> tuple[Fraction, Fraction]:
    """Rationals lo ≤ v ≤ hi around v = ln q or e^q (:func:`_ball_ends`), at most 2^-:data:`BITS` of the quantity
    apart."""
    lower, upper, offset = _ball_ends(q, ln)
    return _rational(lower, offset), _rational(upper, offset)


def _outward(ends: tuple[Fraction, Fraction], upward: bool) -> float:
    """The upper end of ``ends`` rounded up (:func:`fraction_up`), or the lower end rounded down (``upward`` False):
    a float on the stated side of the value they enclose."""
    return fraction_up(ends[1]) if upward else fraction_down(ends[0])


def _ln(x: Exact, upward: bool) -> float:
    """ln ``x`` rounded to a float on the stated side (:func:`log_up` and :func:`log_down`)."""
    if isinstance(x, float) and math.isnan(x):
        raise ValueError(f"ln of NaN: {x!r}")
    if x == math.inf:
        return math.inf
    q = Fraction(x)
    if q < 0:
        raise ValueError(f"ln of a negative number: {x!r}")
    if q == 0:
        return -math.inf
    return _outward(ln_bounds(q), upward)


def _exp(x: Exact, upward: bool) -> float:
    """e^``x`` rounded to a float on the stated side (:func:`exp_up` and :func:`exp_down`)."""
    if isinstance(x, float) and not math.isfinite(x):
        if math.isnan(x):
            raise ValueError(f"exp of NaN: {x!r}")
        return math.inf if x > 0 else 0.0
    q = Fraction(x)
    if abs(q) > _EXP_FAR:  # beyond the floats either way: no ball needed
        if upward:
            return math.inf if q > 0 else _TINY
        return sys.float_info.max if q > 0 else 0.0
    return _outward(exp_bounds(q), upward)


def ln_bounds(x: Exact) -> tuple[Fraction, Fraction]:
    """Rationals lo ≤ ln ``x`` ≤ hi for a rational ``x`` > 0, at most 2^-:data:`BITS`·|ln x| apart (exact at 1).

    What a verifier needs beyond a float's precision: the ends of arb's ball around ln ``x`` (around ln(1 + y) for
    y = x − 1 near 1, so that a small ln x keeps its own 60 digits), not rounded to floats (``proofs/outward.md`` §4);
    the working precision is raised until they are that close (the module's docstring).

    Parameters
    ----------
    x : Fraction, int or float
        The argument, an exact rational (a float counts as its binary value).

    Returns
    -------
    (Fraction, Fraction)
        ``(lo, hi)``, in nats, dyadic rationals (m·2^e); ``(0, 0)`` at ``x`` = 1.

    Raises
    ------
    ValueError
        When ``x`` ≤ 0 or not finite.

    Examples
    --------
    >>> import math
    >>> lo, hi = ln_bounds(2)
    >>> abs(lo - Fraction(math.log(2))) < Fraction(1, 10**16) and 0 < hi - lo < Fraction(1, 10**60)
    True
    """
    if isinstance(x, float) and not math.isfinite(x):
        raise ValueError(f"ln_bounds of {x!r}")
    q = Fraction(x)
    if q <= 0:
        raise ValueError(f"ln_bounds of a number <= 0: {x!r}")
    if q == 1:
        return Fraction(0), Fraction(0)
    return _ends(q, ln=True)


def exp_bounds(x: Exact) -> tuple[Fraction, Fraction]:
    """Rationals lo ≤ e^``x`` ≤ hi for a rational ``x`` with |x| ≤ 10^6, at most 2^-:data:`BITS`·min(e^x, |e^x − 1|)
    apart (exact at 0).

    The ends of arb's ball around e^``x`` (around e^x − 1 near 0, plus 1, so that a small e^x − 1 keeps its own 60
    digits), not rounded to floats (``proofs/outward.md`` §4); the working precision is raised until they are that
    close (the module's docstring).

    Parameters
    ----------
    x : Fraction, int or float
        The exponent, in nats, an exact rational.

    Returns
    -------
    (Fraction, Fraction)
        ``(lo, hi)``, dyadic rationals (m·2^e; beyond the floats' range too: the ends of e^(10^6) are integers
        of 1.44 million bits); ``(1, 1)`` at ``x`` = 0.

    Raises
    ------
    ValueError
        When ``x`` is not finite or |x| > 10^6.

    Examples
    --------
    >>> lo, hi = exp_bounds(1)
    >>> Fraction(2718281828459045235360287, 10**24) < lo < hi < Fraction(2718281828459045235360288, 10**24)   # e
    True
    >>> hi - lo < Fraction(1, 10**60)
    True
    """
    if isinstance(x, float) and not math.isfinite(x):
        raise ValueError(f"exp_bounds of {x!r}")
    q = Fraction(x)
    if abs(q) > 10**6:
        raise ValueError(f"exp_bounds of a number beyond 1e6 in size: {x!r}")
    if q == 0:
        return Fraction(1), Fraction(1)
    return _ends(q, ln=False)


def log_up(x: Exact) -> float:
    """A float ≥ ln ``x`` for a rational ``x`` ≥ 0 (ln 0 = −inf; +inf for ``x`` = +inf).

    The upper end of :func:`ln_bounds` (the ball arb computes around ln ``x``)
    rounded up to a float (:func:`fraction_up`; ``proofs/outward.md`` §4).

    Parameters
    ----------
    x : Fraction, int or float
        The argument, an exact rational (a float counts as its binary value).

    Returns
    -------
    float
        An upper end of ln ``x`` (nats), at most two units in the last place above it.

    Raises
    ------
    ValueError
        When ``x`` < 0 or NaN.

    Examples
    --------
    >>> import math
    >>> log_up(2) >= math.log(2) and log_up(2) - math.log(2) <= 2.0**-52
    True
    >>> log_up(1), log_up(0)
    (0.0, -inf)
    """
    return _ln(x, upward=True)


def log_down(x: Exact) -> float:
    """A float ≤ ln ``x`` for a rational ``x`` ≥ 0: the mirror of :func:`log_up` (same parameters and errors).

    Examples
    --------
    >>> import math
    >>> log_down(2) <= math.log(2), log_down(1)
    (True, 0.0)
    """
    return _ln(x, upward=False)


def exp_up(x: Exact) -> float:
    """A float ≥ e^``x`` for a rational ``x`` (+inf beyond the largest float; e^0 = 1).

    The upper end of :func:`exp_bounds` rounded up to a float, as in :func:`log_up`;
    beyond 1000 nats either way no ball is computed (``proofs/outward.md`` §4).

    Parameters
    ----------
    x : Fraction, int or float
        The exponent, in nats, an exact rational; ±inf allowed.

    Returns
    -------
    float
        An upper end of e^``x``: +inf above about 709.78, the smallest positive float far below 0.

    Raises
    ------
    ValueError
        When ``x`` is NaN.

    Examples
    --------
    >>> import math
    >>> exp_up(1) >= math.e, exp_up(0), exp_up(1000)
    (True, 1.0, inf)
    """
    return _exp(x, upward=True)


def exp_down(x: Exact) -> float:
    """A float ≤ e^``x`` for a rational ``x``: the mirror of :func:`exp_up` (the largest float far above 0, 0.0 far
    below; same parameters and errors).

    Examples
    --------
    >>> import math
    >>> exp_down(1) <= math.e, exp_down(0), exp_down(-1000)
    (True, 1.0, 0.0)
    """
    return _exp(x, upward=False)
