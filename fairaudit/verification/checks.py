"""One recorded number of a certificate against its re-derived value: :class:`Check`, :func:`judge`, :func:`equal`.

A number **holds** when it lies on its certified side of the exact value (an upper bound at or above it) and within
the tolerance of it, relative to max(1, |value|) (so that a number moved by twice the tolerance fails); a measured
value holds within the tolerance on either side. The tolerance is the one the certificate states (its
``tolerance``, 1e-9 as certify writes it), which :func:`~fairaudit.verification.rederive.verify` sets with
:func:`stated_tolerance` for the time of its checks; elsewhere it is :data:`TOLERANCE`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from decimal import ROUND_CEILING, Decimal
from fractions import Fraction
from typing import Any

from fairaudit.verification.enclosures import INF, Enclosure, exact

__all__ = ["TOLERANCE", "Check", "equal", "judge", "stated_tolerance", "tolerance"]

LARGEST = Fraction(1.7976931348623157e308)
"""The largest finite float: an exact value above it rounds to +inf (up, or to nearest)."""

TOLERANCE = 1e-9
"""How far (relative to max(1, |value|)) a recorded number may sit from its exact value on its allowed side, where no
certificate states it (a direct call of :func:`judge`): certify's contract, 1e-9. ``verify`` judges a certificate's
numbers to the ``tolerance`` the certificate states (:func:`stated_tolerance`)."""

_TOLERANCE: ContextVar[Fraction] = ContextVar("fairaudit_verify_tolerance", default=Fraction(TOLERANCE))
"""The tolerance numbers are judged to now, exactly (the float's value): :data:`TOLERANCE` unless set."""


@dataclass(frozen=True, kw_only=True)
class Check:
    """One recorded number against its re-derived value.

    Attributes
    ----------
    name : str
        The number's JSON path (``bounds.tight``).
    reported : float or str or bool or None
        The recorded value.
    derived_low, derived_high : float
        The exact value's enclosure, rounded outward to floats (equal for an exact value).
    side : {"upper", "lower", "estimate", "equal", "at most", "at least", "met", "largest"}
        An upper bound (≥ the exact value, within the tolerance), a lower bound, a measured value (either side), an
        identity, a value attained (≤ the exact maximum: a witness), a target a certified value meets (≥ the exact
        value, however far), a target a measured value meets (≥ it less the tolerance), or a calibrated ε shown the
        largest (:mod:`~fairaudit.verification.calibration_check`).
    holds : bool
    fails_by : float
        How far outside the allowed range the reported value is (0 when it holds; NaN for a label or verdict that
        is not the one re-derived).
    detail : str
        What was re-derived, or why it fails.
    """

    name: str
    reported: Any
    derived_low: float
    derived_high: float
    side: str
    holds: bool
    fails_by: float
    detail: str

    def to_dict(self) -> dict[str, Any]:
        """The report dictionary (NaN as None, ±inf as ``"inf"``, ``"-inf"``)."""
        return {
            "name": self.name,
            "reported": self.reported,
            "derived": [_json(self.derived_low), _json(self.derived_high)],
            "side": self.side,
            "holds": self.holds,
            "fails_by": _json(self.fails_by),
            "detail": self.detail,
        }

    def line(self) -> str:
        """One line: the name, the reported number and ``holds``, ``fails by X`` (X the distance by which it misses,
        rounded up to two significant digits) or, for a label or verdict, ``fails``."""
        verdict = "holds" if self.holds else "fails"
        if not self.holds and not math.isnan(self.fails_by):
            verdict += f" by {distance(self.fails_by)}"
        shown = self.reported if not isinstance(self.reported, float) else f"{self.reported!r}"
        return f"{self.name} = {shown}: {verdict}" + (f" ({self.detail})" if self.detail and not self.holds else "")


def _json(x: float) -> float | str | None:
    """A float as JSON, as certify writes it: NaN as None, ±inf as ``"inf"``, ``"-inf"``."""
    return None if math.isnan(x) else ("inf" if x > 0 else "-inf") if math.isinf(x) else x


def distance(x: float) -> str:
    """A distance rounded up to two significant digits, as ``fails by`` prints it.

    Examples
    --------
    >>> distance(0.1), distance(1.8e-15), distance(9.99e-10), distance(1.01e-9), distance(math.inf), distance(0.0)
    ('0.1', '1.8e-15', '1e-09', '1.1e-09', 'inf', '0')
    """
    if not math.isfinite(x) or x <= 0:
        return f"{x:.2g}"
    d = Decimal(repr(x))  # the float's shortest decimal (0.1, not 0.1000000000000000055...)
    step = Decimal(1).scaleb(d.adjusted() - 1)  # a unit in the second significant digit
    return f"{float((d / step).to_integral_value(ROUND_CEILING) * step):.2g}"


def _numeric(value: Any) -> Fraction | float | None:
    """A recorded number (or ``"inf"``, ``"-inf"``) as an exact value; None for anything else (a label, a bool)."""
    if value in ("inf", "-inf") and isinstance(value, str):
        return math.inf if value == "inf" else -math.inf
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        return None
    return value if math.isinf(value) else Fraction(value)


def _float(x: Fraction | float, upward: bool) -> float:
    """An exact value as the nearest float on the stated side (beyond the floats: ±inf outward, the largest float
    inward).

    Examples
    --------
    >>> third = Fraction(1, 3)
    >>> _float(third, False) == 1 / 3 and third < Fraction(_float(third, True)), _float(Fraction(-1, 2), True)
    (True, -0.5)
    >>> _float(Fraction(2) ** 1024, True), _float(Fraction(2) ** 1024, False) == LARGEST, _float(-(Fraction(2) ** 1024), False)
    (inf, True, -inf)
    """
    if isinstance(x, float):
        return x
    sign = 1 if upward else -1  # rounded up: x, rounded down: -x rounded up, negated
    q = sign * x
    try:
        f = float(q)  # (to nearest: Fraction divides its integers correctly rounded)
    except OverflowError:
        f = math.inf if q > 0 else -sys.float_info.max
    return sign * (math.nextafter(f, math.inf) if math.isfinite(f) and Fraction(f) < q else f)


def _outward(x: Fraction | float, upward: bool) -> Fraction | float:
    """The float next to ``x`` on the stated side, as an exact number (``x`` itself when infinite or beyond the floats'
    range)."""
    if isinstance(x, float) or abs(x) > LARGEST:
        return x
    return Fraction(_float(x, upward))


def tolerance() -> Fraction:
    """The tolerance numbers are judged to now, exactly: the one :func:`stated_tolerance` set, else :data:`TOLERANCE`.

    Examples
    --------
    >>> tolerance() == Fraction(1e-9)
    True
    """
    return _TOLERANCE.get()


@contextmanager
def stated_tolerance(value: float) -> Iterator[Fraction]:
    """Judge numbers to ``value`` (a certificate's stated ``tolerance``) inside the ``with`` block, and to the
    tolerance before it after the block, however it ends.

    Parameters
    ----------
    value : float
        The relative tolerance, > 0 (the certificate's schema bounds it: at most 1e-6).

    Yields
    ------
    Fraction
        The tolerance, exactly (the float's value).

    Examples
    --------
    >>> third = Enclosure(Fraction(1, 3), Fraction(1, 3))
    >>> moved = 0.33333334333333337  # 1/3 + 1e-8
    >>> judge("x", moved, third, "upper").line()
    'x = 0.33333334333333337: fails by 9e-09'
    >>> with stated_tolerance(1e-7):
    ...     judge("x", moved, third, "upper").line()
    'x = 0.33333334333333337: holds'
    >>> tolerance() == Fraction(TOLERANCE)
    True
    """
    token = _TOLERANCE.set(Fraction(value))
    try:
        yield _TOLERANCE.get()
    finally:
        _TOLERANCE.reset(token)


def judge(name: str, reported: Any, derived: Enclosure, side: str, detail: str = "") -> Check:
    """The check of a reported number against the enclosure of its exact value, on ``side``.

    Parameters
    ----------
    name : str
        The number's JSON path, for the report.
    reported : float, str or None
        The recorded number (a float, or "inf"); None fails ("no value recorded").
    derived : Enclosure
        lo ≤ exact value ≤ hi.
    side : {"upper", "lower", "estimate", "equal", "at most", "at least", "met"}
        "upper": the number must be ≥ hi and ≤ hi + t·max(1, |hi|), t the tolerance (:func:`tolerance`: the
        certificate's, else :data:`TOLERANCE`); "lower": ≤ lo and within the tolerance below it; "estimate": within
        the tolerance of [lo, hi]; "equal": in [lo, hi]; "at most": ≤ lo (a value attained, a witness); "at least":
        ≥ hi (a target the exact value meets); "met": ≥ lo less the tolerance (a target a measured value meets, to
        its rounding).
    detail : str
        What was re-derived.

    Returns
    -------
    Check
        ``holds``, and ``fails_by`` (the distance outside the allowed range, rounded up).

    Examples
    --------
    >>> third = Enclosure(Fraction(1, 3), Fraction(1, 3))
    >>> judge("x", 0.3333333333333333, third, "upper").holds, judge("x", 0.33333333333333337, third, "upper").holds
    (False, True)
    >>> judge("x", 0.3333333338333334, third, "upper").holds  # 1/3 + 5e-10: within the tolerance, 1e-9
    True
    >>> judge("x", 0.3333333353333334, third, "upper").line()  # 1/3 + 2e-9: 1e-9 beyond it (rounded up)
    'x = 0.3333333353333334: fails by 1.1e-09'
    >>> judge("target", 0.5, third, "at least").holds, judge("target", 0.3, third, "at least").holds
    (True, False)
    >>> judge("x", "inf", third, "upper").holds  # +inf bounds 1/3, but it is not the bound re-derived
    False
    >>> beyond = Fraction(2) ** 1024  # above the largest float: its upper end in floats is +inf
    >>> judge("x", "inf", Enclosure(beyond, beyond), "upper").holds, judge("x", "inf", Enclosure(beyond, beyond), "lower").holds
    (True, False)
    """
    low, high = _float(derived.lo, False), _float(derived.hi, True)
    value = exact(reported, name) if reported is not None else None
    if value is None:
        return Check(name=name, reported=reported, derived_low=low, derived_high=high, side=side, holds=False,
                     fails_by=math.inf, detail="no value recorded")  # fmt: skip
    scale = max(Fraction(1), abs(derived.hi)) if isinstance(derived.hi, Fraction) else Fraction(1)
    slack = tolerance() * scale
    if value == INF or derived.hi == INF:
        # +inf bounds everything, but as an upper bound of a finite exact value it is not the number re-derived,
        # unless no float is as large (e^800): then +inf is that value rounded up (or to nearest)
        beyond = side not in ("lower", "at most") and (
            derived.lo > LARGEST or (side == "upper" and derived.hi > LARGEST)
        )
        ok = value == INF and (derived.lo == INF or side == "at least" or beyond)
        by = 0.0 if ok else math.inf
    else:
        # the tolerance's ends, rounded outward to the floats: a recorded float cannot lie between two of them
        allowed_low = _outward(derived.lo - slack, False)
        if side in ("upper", "at least", "at most"):
            allowed_low = derived.hi if side != "at most" else -INF
        allowed_high = derived.lo if side in ("lower", "at most") else _outward(derived.hi + slack, True)
        if side in ("at least", "met"):
            allowed_high = INF
        if side == "equal":
            allowed_low, allowed_high = derived.lo, derived.hi
        below, above = allowed_low - value, value - allowed_high
        ok = below <= 0 and above <= 0
        by = 0.0 if ok else _float(max(below, above), True)
    return Check(name=name, reported=reported, derived_low=low, derived_high=high, side=side, holds=ok,
                 fails_by=by, detail=detail)  # fmt: skip


def equal(name: str, reported: Any, expected: Any, detail: str = "") -> Check:
    """A recorded value that must equal the re-derived one exactly (a label, a verdict, a digest, a repeated number).

    Where both are numbers, ``fails_by`` is their distance (rounded up); else it is NaN and the line says ``fails``.

    Examples
    --------
    >>> equal("targets.local.met", True, False).line()
    'targets.local.met = True: fails (expected False)'
    >>> equal("bound_details.tight.value", 0.6, 0.5, "bounds.tight").line()
    'bound_details.tight.value = 0.6: fails by 0.1 (bounds.tight)'
    """
    ok = reported == expected and isinstance(reported, bool) == isinstance(expected, bool)  # (True == 1 in Python)
    by = 0.0 if ok else math.nan
    r, e = _numeric(reported), _numeric(expected)
    if not ok and r is not None and e is not None:
        by = math.inf if math.inf in (abs(r), abs(e)) else _float(abs(Fraction(r) - Fraction(e)), True)
    return Check(name=name, reported=reported, derived_low=math.nan, derived_high=math.nan, side="equal", holds=ok,
                 fails_by=by, detail=detail or f"expected {expected!r}")  # fmt: skip
