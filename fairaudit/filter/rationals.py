"""Exact probabilities: numbers read as rationals, rows as integer numerators over one integer denominator.

A probability is a :class:`~fractions.Fraction`, an integer, a string such as
``"1/3"`` or ``"0.25"`` (read exactly), or a float, read as the exact binary
rational it is (0.1 is 3602879701896397/36028797018963968, not 1/10).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from fractions import Fraction

import numpy as np

from fairaudit.base.errors import InputError

__all__ = [
    "Rows",
    "as_rows",
    "exact_number",
]

Rows = tuple[tuple[int, ...], ...]
"""Rows of integer numerators (one tuple per input row)."""

_FLOAT_HINT = " (floats count as their exact binary values: give fractions or strings such as '1/3' or '0.1')"


def exact_number(value: object, field: str) -> Fraction:
    """``value`` as an exact rational.

    Raises
    ------
    InputError
        Naming ``field``, for a boolean, NaN, an infinity, or text that is not a rational.

    Examples
    --------
    >>> exact_number("1/3", "p"), exact_number(0.75, "p"), exact_number(2, "p")
    (Fraction(1, 3), Fraction(3, 4), Fraction(2, 1))
    """
    if isinstance(value, (bool, np.bool_)):
        raise InputError(field, "must be a number (a fraction, an integer, a string like '1/3' or a float)", value)
    if isinstance(value, str):
        try:
            return Fraction(value.strip())
        except (ValueError, ZeroDivisionError):
            raise InputError(field, "is not a rational number such as '1/3' or '0.25'", value) from None
    if isinstance(value, Fraction):
        return value
    if isinstance(value, numbers.Integral):
        return Fraction(int(value))
    if isinstance(value, numbers.Real):
        f = float(value)
        if not math.isfinite(f):
            raise InputError(field, "must be a finite number", value)
        return Fraction(f)
    raise InputError(field, "must be a number (a fraction, an integer, a string like '1/3' or a float)", value)


def as_rows(rows: Sequence[Sequence[object]], field: str) -> tuple[Rows, int]:
    """Rows of probabilities as integer numerators over their one common denominator, each row summing to it.

    Parameters
    ----------
    rows : sequence of sequences, shape (n_inputs, n_outputs)
        P(output | input); entries as :func:`exact_number` reads them.
    field : str
        The parameter named in errors.

    Returns
    -------
    (tuple of tuple of int, int)
        The numerators and the denominator D (the least common one): ``rows[i][o] = numerators[i][o] / D``.

    Raises
    ------
    InputError
        For a ragged or empty matrix, a negative entry, or a row whose exact sum is not 1 (the error says the sum
        and that floats count as their exact binary values).

    Examples
    --------
    >>> as_rows([["1/3", "2/3"], [1, 0]], "rows")
    (((1, 2), (3, 0)), 3)
    """
    exact = [[exact_number(v, f"{field}[{i}][{j}]") for j, v in enumerate(row)] for i, row in enumerate(rows)]
    if not exact or not exact[0]:
        raise InputError(field, "must have at least one row and one column", rows)
    width = len(exact[0])
    for i, row in enumerate(exact):
        if len(row) != width:
            raise InputError(f"{field}[{i}]", f"has {len(row)} entries, the first row {width}", list(rows[i]))
        negative = [v for v in row if v < 0]
        if negative:
            raise InputError(f"{field}[{i}]", "has a negative probability", str(negative[0]))
        total = sum(row, Fraction(0))
        if total != 1:
            hint = _FLOAT_HINT if any(isinstance(v, float) for v in rows[i]) else ""
            raise InputError(f"{field}[{i}]", f"must sum to exactly 1, not {total}{hint}", list(rows[i]))
    denominator = math.lcm(*(v.denominator for row in exact for v in row))
    numerators = tuple(tuple(v.numerator * (denominator // v.denominator) for v in row) for row in exact)
    return numerators, denominator
