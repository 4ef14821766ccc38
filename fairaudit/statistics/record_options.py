"""How :func:`fairaudit.audit` reads and counts records: missing values, weights, count tables, small cells.

:class:`RecordOptions` holds them in one object (given as ``records``), as
:class:`~fairaudit.statistics.intervals.IntervalOptions` holds how intervals are made.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from fairaudit.base.checks import whole
from fairaudit.base.errors import InputError
from fairaudit.data.frames import ArrayLike

__all__ = ["RecordOptions", "as_record_options"]


@dataclass(frozen=True, kw_only=True, eq=False)
class RecordOptions:
    """How records are read and counted: missing values, weights, a count column, small cells, mixed outcomes.

    One object for the settings of :func:`~fairaudit.audit` about its records (given as ``records``).

    Parameters
    ----------
    dropna : bool
        Drop records with missing values in the used columns instead of
        failing (default False; records only: a CountTable is already counted).
    weights : str or array_like, optional
        Sample (survey) weights: the name of a column of a DataFrame ``data``,
        or, for records given as arrays (``y_pred``, ``sensitive_features``),
        one weight per record (a list, numpy array or pandas Series, matched
        by position; kept as a copy, a float array), as pandas'
        ``DataFrame.sample(weights=...)`` takes a column name or an array.
        Point estimates use weighted counts, intervals Kish's effective sample
        size per cell (:meth:`~fairaudit.data.counts.CountTable.effective_counts`,
        an approximation). A missing weight (NaN) is a missing value.
    count : str, optional
        ``data`` is a count table, one row per (context, group, outcome) as
        SQL ``GROUP BY`` gives it, and this column holds each row's number of
        records (finite and non-negative; integers give integer counts), as
        ``fairaudit audit --count COL`` reads a file
        (:func:`~fairaudit.data.counts.count_table`): the audit is that of the
        records the rows stand for. A (context, group, outcome) listed twice is
        an error. Not with ``weights``, a CountTable or arrays.
    min_count : int, optional
        Leave out every (context, group) cell with fewer records than this
        (but some), a whole number ≥ 1: its records are removed from the
        metrics, the population and the intervals, and the cells are listed in
        the audit's ``left_out``.
    mixed_outcome : bool
        Count an outcome column of records that mixes numbers and text (ranks
        ``1`` to ``8`` and ``"unranked"``) as it is, each value an outcome of
        its own (read as text); by default (False) that is an error naming the
        rows (see :func:`~fairaudit.data.counts.count_records`).

    Raises
    ------
    InputError
        Naming the field: ``dropna`` or ``mixed_outcome`` that is not True or
        False; ``weights`` that is neither a column name nor a non-empty list
        or array of one number per record, or holds a negative or infinite
        weight; ``count`` that is not a column name, or given with
        ``weights``; ``min_count`` that is not a whole number ≥ 1.

    Examples
    --------
    >>> RecordOptions()
    RecordOptions(dropna=False, weights=None, count=None, min_count=None, mixed_outcome=False)
    >>> RecordOptions(weights=[1, 2.5, 1]).weights
    array([1. , 2.5, 1. ])
    >>> RecordOptions(min_count=5) == RecordOptions(min_count=5)
    True
    >>> RecordOptions(min_count=0)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: min_count: must be a whole number >= 1 (got 0)
    >>> RecordOptions(weights=[1.0, -2.0])
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: weights: must be finite non-negative numbers; record 2 is not (got -2.0)
    """

    dropna: bool = False
    weights: str | ArrayLike | None = None
    count: str | None = None
    min_count: int | None = None
    mixed_outcome: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "dropna", _flag(self.dropna, "dropna"))
        object.__setattr__(self, "weights", _weights(self.weights))
        if self.count is not None and not isinstance(self.count, str):
            raise InputError(
                "count", "must be the name of the column that holds each row's number of records", self.count
            )
        if self.count is not None and self.weights is not None:
            raise InputError("weights", "a count table (`count`) is counted already: give its counts, not weights")
        if self.min_count is not None:
            object.__setattr__(self, "min_count", whole(self.min_count, "min_count", low=1))
        object.__setattr__(self, "mixed_outcome", _flag(self.mixed_outcome, "mixed_outcome"))

    def _key(self) -> tuple[Any, ...]:
        w = self.weights
        weights = ("array", w.tobytes()) if isinstance(w, np.ndarray) else w
        return (self.dropna, weights, self.count, self.min_count, self.mixed_outcome)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RecordOptions):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())


def as_record_options(records: object) -> RecordOptions:
    """``records`` checked: a :class:`RecordOptions` returned as it is, None as the defaults.

    Raises
    ------
    InputError
        Field ``records`` for anything else, quoting its type.
    """
    if records is None:
        return RecordOptions()
    if not isinstance(records, RecordOptions):
        raise InputError("records", "must be a RecordOptions", type(records).__name__)
    return records


def _flag(value: object, name: str) -> bool:
    """``value`` as a bool: True or False (a numpy bool too), nothing else."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(name, "must be True or False", value)
    return bool(value)


def _weights(value: object) -> str | np.ndarray | None:
    """A column name as it is, or one weight per record as a new read-only float array (NaN: missing)."""
    if value is None or isinstance(value, str):
        return value
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iufO":  # not text, booleans or dates
            raise TypeError
        array = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(
            "weights", "must be the name of a column, or a list or array of one number per record", type(value).__name__
        ) from None
    if array.ndim != 1 or len(array) == 0:
        raise InputError("weights", "must be a non-empty list or array of one number per record", array.shape)
    bad = np.flatnonzero(np.isinf(array) | (array < 0))
    if bad.size:
        i = int(bad[0])
        raise InputError("weights", f"must be finite non-negative numbers; record {i + 1} is not", float(array[i]))
    array.flags.writeable = False
    return array
