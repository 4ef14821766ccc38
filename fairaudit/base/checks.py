"""The one place where arguments are checked: numbers, whole numbers, levels, privacy budgets, choices, columns;
and command-line options as numbers (:func:`number_type`, an argparse ``type`` over :func:`real` and :func:`whole`).

Every checker takes the value and the name of the Python parameter (or spec
field) it came from, returns the value converted (``float``, ``int``, ``str``)
and raises :class:`~fairaudit.InputError` naming that parameter and quoting
the value otherwise. Library errors name Python parameters
(``confidence``, ``sensitive``); the command line maps them to its flags in one
place (:func:`fairaudit.cli._common.flag_error`), so no core module mentions a
flag.

Booleans are never numbers here (``True`` is not a count of groups), NaN is
never accepted, and +inf only where ``finite=False`` says so.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Hashable, Iterable, Sequence
from numbers import Integral, Real
from typing import Any

import numpy as np

from fairaudit.base.errors import InputError, cut

__all__ = ["choice", "columns", "epsilon", "level", "nonnegative", "number_type", "real", "whole"]


def _describe(low: float, high: float, low_open: bool, high_open: bool, finite: bool) -> str:
    """'a finite number >= 0', 'a number > 0 and <= 1', ..."""
    parts = []
    if low > -math.inf:
        parts.append(f"{'>' if low_open else '>='} {low:g}")
    if high < math.inf:
        parts.append(f"{'<' if high_open else '<='} {high:g}")
    head = "a finite number" if finite else "a number"
    return head + (" " + " and ".join(parts) if parts else "")


def real(
    value: Any,
    name: str,
    *,
    low: float = -math.inf,
    high: float = math.inf,
    low_open: bool = False,
    high_open: bool = False,
    finite: bool = True,
    what: str | None = None,
) -> float:
    """``value`` as a float in the interval from ``low`` to ``high``.

    Parameters
    ----------
    value : object
        A real number (Python or NumPy); not a bool, not NaN; not ±inf
        unless ``finite`` is False.
    name : str
        The parameter or field named in the error.
    low, high : float
        The interval's ends; ``low_open``/``high_open`` exclude them.
    what : str, optional
        The message's description ("must be {what}"); by default built from
        the interval, e.g. "a finite number >= 0".

    Raises
    ------
    InputError
        ``value`` is not such a number.

    Examples
    --------
    >>> real("0.5", "tau", low=0, low_open=True)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: tau: must be a finite number > 0 (got '0.5')
    >>> real(2, "gamma", low=0)
    2.0
    """
    description = what or _describe(low, high, low_open, high_open, finite)
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, Real):
        raise InputError(name, f"must be {description}", value)
    v = float(value)
    inside = (low < v if low_open else low <= v) and (v < high if high_open else v <= high)  # (False for NaN)
    if not inside or (finite and math.isinf(v)):
        raise InputError(name, f"must be {description}", value)
    return v


def nonnegative(value: Any, name: str, *, what: str | None = None) -> float:
    """``value`` as a finite float >= 0 (:func:`real` with ``low=0``).

    Examples
    --------
    >>> nonnegative(0.25, "lipschitz")
    0.25
    """
    return real(value, name, low=0.0, what=what or "a finite non-negative number")


def epsilon(value: Any, name: str = "epsilon") -> float:
    """A privacy budget ε in nats: a number >= 0, +inf allowed (no privacy).

    Examples
    --------
    >>> epsilon(float("inf"))
    inf
    """
    return real(value, name, low=0.0, finite=False, what="a non-negative number of nats")


def level(value: Any, name: str = "confidence") -> float:
    """A probability strictly between 0 and 1 (a confidence level, α).

    Examples
    --------
    >>> level(0.95)
    0.95
    """
    return real(value, name, low=0.0, high=1.0, low_open=True, high_open=True, what="a number strictly between 0 and 1")


def whole(value: Any, name: str, *, low: int = 0, high: int | None = None) -> int:
    """``value`` as an int in [low, high]: an integer (Python or NumPy), not a bool, not a float.

    Examples
    --------
    >>> whole(3, "groups", low=2)
    3
    >>> whole(2.0, "groups", low=2)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: groups: must be a whole number >= 2 (got 2.0)
    """
    not_integer = isinstance(value, bool) or not isinstance(value, Integral)
    if not_integer or not low <= int(value) <= (int(value) if high is None else high):
        what = f"a whole number >= {low}" + (f" and <= {high}" if high is not None else "")
        raise InputError(name, f"must be {what}", value)
    return int(value)


def choice(value: Any, name: str, choices: Iterable[str]) -> str:
    """``value`` if it is one of ``choices`` (strings).

    Examples
    --------
    >>> choice("exact", "method", ("exact", "lp"))
    'exact'
    """
    options = tuple(choices)
    if not isinstance(value, str) or value not in options:
        raise InputError(name, f"must be one of {', '.join(options)}", value)
    return value


def columns(value: Sequence[str], name: str, available: Iterable[Hashable]) -> list[str]:
    """``value`` as a list of column names, each one of ``available`` (the data's columns).

    The error quotes the first unknown column and lists the data's columns
    (the first 12).

    Examples
    --------
    >>> columns(["race"], "sensitive", ["race", "hired"])
    ['race']
    >>> columns(["sex"], "sensitive", ["race", "hired"])
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: sensitive: unknown column; the data has: race, hired (got 'sex')
    """
    names = list(available)
    for c in value:
        if c not in names:
            shown = ", ".join(map(cut, names[:12])) + (", ..." if len(names) > 12 else "")
            raise InputError(name, f"unknown column; the data has: {shown}", c)
    return list(value)


def number_type(
    expected: str,
    *,
    low: float = -float("inf"),
    high: float = float("inf"),
    low_open: bool = False,
    high_open: bool = False,
    integer: bool = False,
    unparsed: str | None = None,
) -> Callable[[str], Any]:
    """An argparse ``type``: the text of a command-line option as a number checked by :func:`real` or :func:`whole`.

    What the ``fairaudit`` command and its plug-ins' commands parse numbers with, so that a bad option says
    ``argument --flag: expected ..., got 'text'`` in every command.

    Parameters
    ----------
    expected : str
        What the message says is expected ("a number in (0, 1)"): ``expected ..., got 'text'``.
    low, high, low_open, high_open
        The interval, as :func:`real` takes it (``low`` only for ``integer``).
    integer : bool
        A whole number (``int(text)``, :func:`whole`) instead of a finite float.
    unparsed : str, optional
        What the message says is expected when the text is not a number at all (default ``expected``).

    Examples
    --------
    >>> half_open = number_type("a number >= 0", low=0)
    >>> half_open("0.5")
    0.5
    >>> half_open("-1")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected a number >= 0, got '-1'
    """

    def convert(text: str) -> Any:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {unparsed or expected}, got {text!r}") from None
        try:
            if integer:
                return whole(value, "value", low=int(low))
            return real(value, "value", low=low, high=high, low_open=low_open, high_open=high_open)
        except InputError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None

    return convert
