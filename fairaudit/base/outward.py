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
  evaluate ln and exp of an exact rational (a float is one) in 50-digit
  decimal arithmetic, whose ``ln`` and ``exp`` are correctly rounded (the
  General Decimal Arithmetic specification; Python's :mod:`decimal`), then
  round outward: the float returned is on the stated side of the exact value.

OpenDP rounds every privacy quantity the same way (its ``inf_ln``,
``inf_exp``, ``inf_add``). Proof that each function is on its side:
``proofs/outward.md``.
"""

from __future__ import annotations

import decimal
import functools
import math
import sys
from fractions import Fraction
from typing import overload

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray

__all__ = [
    "DIGITS",
    "Exact",
    "down",
    "exp_bounds",
    "exp_down",
    "exp_up",
    "fraction_down",
    "fraction_up",
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

DIGITS = 50
"""Significant digits of the decimal arithmetic behind :func:`log_up` and its kin."""

NEAR = Fraction(1, 2**20)
"""Below this distance from 0 (for e^x) or from 1 (for ln x), :func:`exp_bounds` and :func:`ln_bounds` sum the Taylor
series with its remainder bound: e^x − 1 and ln x are then small, and the decimals' 50 digits would hold only x."""

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


def _fraction(x: Exact) -> Fraction:
    """``x`` as an exact rational (a float exactly, never through its decimal string)."""
    return x if isinstance(x, Fraction) else Fraction(x)


def fraction_up(x: Exact) -> float:
    """The smallest float ≥ the rational ``x`` (+inf beyond the largest float).

    Examples
    --------
    >>> fraction_up(Fraction(1, 3)) > 1 / 3, fraction_up(Fraction(1, 2))
    (True, 0.5)
    """
    q = _fraction(x)
    try:
        f = float(q)  # correctly rounded to nearest (Fraction.__float__ divides integers exactly)
    except OverflowError:
        return math.inf if q > 0 else -sys.float_info.max
    if math.isfinite(f) and Fraction(f) < q:
        f = math.nextafter(f, math.inf)
    return f


def fraction_down(x: Exact) -> float:
    """The largest float ≤ the rational ``x`` (−inf below the most negative float).

    Examples
    --------
    >>> third = Fraction(1, 3)
    >>> fraction_down(third) <= third < fraction_up(third), fraction_down(Fraction(-1, 2))
    (True, -0.5)
    """
    return -fraction_up(-_fraction(x))


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


_NEAR_ONE = Fraction(1, 10**25)
"""Within this of 1, ln q is enclosed by the rationals 1 − 1/q and q − 1 (:func:`_ln_decimal`)."""


def _context(rounding: str) -> decimal.Context:
    """A decimal context of :data:`DIGITS` digits that rounds as ``rounding``, with every exponent allowed."""
    return decimal.Context(prec=DIGITS, rounding=rounding, Emax=decimal.MAX_EMAX, Emin=decimal.MIN_EMIN)


def _decimal(x: Exact, rounding: str) -> decimal.Decimal:
    """The rational ``x`` as a :data:`DIGITS`-digit decimal rounded as ``rounding`` (exact when it fits)."""
    q = _fraction(x)
    ctx = _context(rounding)
    return ctx.divide(decimal.Decimal(q.numerator), decimal.Decimal(q.denominator))


def _float_above(d: decimal.Decimal | Fraction) -> float:
    """The smallest float ≥ the decimal ``d`` (exact: a decimal is a rational)."""
    return fraction_up(Fraction(d))


def _float_below(d: decimal.Decimal | Fraction) -> float:
    """The largest float ≤ the decimal ``d``."""
    return fraction_down(Fraction(d))


def _ln_decimal(q: Fraction, upward: bool) -> decimal.Decimal | Fraction:
    """ln of a rational q > 0, q ≠ 1, as a :data:`DIGITS`-digit decimal on the stated side of the exact value; within
    10^-25 of 1, the rational 1 − 1/q ≤ ln q ≤ q − 1 (at most (q − 1)² apart: the decimal argument would round to 1
    and ``next_plus(0)`` is the smallest decimal of the unbounded context, which no rational can hold)."""
    if abs(q - 1) < _NEAR_ONE:
        return q - 1 if upward else 1 - 1 / q
    ctx = _context(decimal.ROUND_HALF_EVEN)
    if upward:
        return ctx.next_plus(ctx.ln(_decimal(q, decimal.ROUND_CEILING)))
    return ctx.next_minus(ctx.ln(_decimal(q, decimal.ROUND_FLOOR)))


def _exp_decimal(q: Fraction, upward: bool) -> decimal.Decimal:
    """e^q for a rational q ≠ 0 with |q| at most the floats' range, as a :data:`DIGITS`-digit decimal on the stated
    side of the exact value."""
    ctx = _context(decimal.ROUND_HALF_EVEN)
    if upward:
        return ctx.next_plus(ctx.exp(_decimal(q, decimal.ROUND_CEILING)))
    return ctx.next_minus(ctx.exp(_decimal(q, decimal.ROUND_FLOOR)))


def _ln(x: Exact, upward: bool) -> float:
    """ln ``x`` rounded to a float on the stated side (:func:`log_up` and :func:`log_down`)."""
    if isinstance(x, float) and (math.isnan(x) or x == math.inf):
        if math.isnan(x):
            raise ValueError(f"ln of NaN: {x!r}")
        return math.inf
    q = _fraction(x)
    if q < 0:
        raise ValueError(f"ln of a negative number: {x!r}")
    if q == 0:
        return -math.inf
    if q == 1:
        return 0.0
    d = _ln_decimal(q, upward)
    return _float_above(d) if upward else _float_below(d)


def _exp(x: Exact, upward: bool) -> float:
    """e^``x`` rounded to a float on the stated side (:func:`exp_up` and :func:`exp_down`)."""
    if isinstance(x, float) and not math.isfinite(x):
        if math.isnan(x):
            raise ValueError(f"exp of NaN: {x!r}")
        return math.inf if x > 0 else 0.0
    q = _fraction(x)
    if q == 0:
        return 1.0
    if abs(q) > _EXP_FAR:  # beyond the floats either way: no need for 50 digits
        if upward:
            return math.inf if q > 0 else _TINY
        return sys.float_info.max if q > 0 else 0.0
    d = _exp_decimal(q, upward)
    return _float_above(d) if upward else _float_below(d)


def ln_bounds(x: Exact) -> tuple[Fraction, Fraction]:
    """Rationals lo ≤ ln ``x`` ≤ hi, :data:`DIGITS` digits apart, for a rational ``x`` > 0 (exact at 1).

    What a verifier needs beyond a float's precision: the decimals of :func:`log_up` and :func:`log_down`
    (``proofs/outward.md`` §4), not rounded to floats; within :data:`NEAR` of 1, the Taylor series of ln(1 + y) with
    its remainder bound, at most 10^-48·|x − 1| apart.

    Raises
    ------
    ValueError
        When ``x`` ≤ 0 or not finite.

    Examples
    --------
    >>> import math
    >>> lo, hi = ln_bounds(2)
    >>> abs(lo - Fraction(math.log(2))) < Fraction(1, 10**16) and 0 < hi - lo < Fraction(1, 10**48)
    True
    """
    if isinstance(x, float) and not math.isfinite(x):
        raise ValueError(f"ln_bounds of {x!r}")
    q = _fraction(x)
    if q <= 0:
        raise ValueError(f"ln_bounds of a number <= 0: {x!r}")
    if q == 1:
        return Fraction(0), Fraction(0)
    if abs(q - 1) < NEAR:  # the decimals hold x to 50 digits, not ln x: its series, to 50 digits of ln x itself
        y = q - 1
        series = sum(Fraction((-1) ** (n + 1), n) * y**n for n in range(1, 11))
        rest = 2 * abs(y) ** 11 / 11  # Σ_{n > 10} |y|^n/n ≤ |y|^11/(11 (1 − |y|))
        return series - rest, series + rest
    return Fraction(_ln_decimal(q, False)), Fraction(_ln_decimal(q, True))


def exp_bounds(x: Exact) -> tuple[Fraction, Fraction]:
    """Rationals lo ≤ e^``x`` ≤ hi, :data:`DIGITS` digits apart, for a rational ``x`` with |x| ≤ 10^6 (exact at 0).

    The decimals of :func:`exp_up` and :func:`exp_down`, not rounded to floats; within :data:`NEAR` of 0, the Taylor
    series with Lagrange's remainder bound, at most 10^-48·|x| apart (``proofs/outward.md`` §4).

    Raises
    ------
    ValueError
        When ``x`` is not finite or |x| > 10^6.

    Examples
    --------
    >>> lo, hi = exp_bounds(1)
    >>> Fraction(2718281828459045235360287, 10**24) < lo < hi < Fraction(2718281828459045235360288, 10**24)   # e
    True
    >>> hi - lo < Fraction(1, 10**48)
    True
    """
    if isinstance(x, float) and not math.isfinite(x):
        raise ValueError(f"exp_bounds of {x!r}")
    q = _fraction(x)
    if abs(q) > 10**6:
        raise ValueError(f"exp_bounds of a number beyond 1e6 in size: {x!r}")
    if q == 0:
        return Fraction(1), Fraction(1)
    if abs(q) < NEAR:  # the decimals hold e^x to 50 digits, not e^x − 1: its series, to 50 digits of e^x − 1
        series = sum(q**n / math.factorial(n) for n in range(9))
        rest = 2 * abs(q) ** 9 / math.factorial(9)  # Lagrange's remainder, e^|x| ≤ 2
        return series - rest, series + rest
    return Fraction(_exp_decimal(q, False)), Fraction(_exp_decimal(q, True))


def log_up(x: Exact) -> float:
    """A float ≥ ln ``x`` for a rational ``x`` ≥ 0 (ln 0 = −inf; +inf for ``x`` = +inf).

    ln is evaluated on ``x`` rounded up to 50 digits; the decimal ``ln`` is
    correctly rounded, so one step up in the last digit bounds the exact
    value; that decimal is then rounded up to a float (``proofs/outward.md`` §4).

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

    Evaluated as :func:`log_up` is, with the decimal ``exp`` (``proofs/outward.md`` §4).

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
