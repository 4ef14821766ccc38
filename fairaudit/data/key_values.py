"""The values of the key columns of records (context, sensitive, outcome) that no count may trust.

Every way of counting records (:mod:`fairaudit.data.counts` for DataFrames,
CSV and Parquet files, :mod:`fairaudit.data.spark`) checks the values it is about
to count with :func:`check_key_values`, and refuses two kinds, naming the
column, the data rows and the value:

* **a control character** (Unicode category Cc: U+0000 to U+001F, which
  includes the tab, the line feed and the carriage return, and U+007F to
  U+009F) in a text value of a key column. Such a value is a group, context
  or outcome of its own that prints like another one, or not at all: a NUL
  byte in one value makes a new group of one record, whose rate then drives
  L. A tab or a line break inside a quoted CSV field is refused too: a label
  a reader cannot see is not a label.
* **an outcome column that mixes numbers and text**: among its values
  (missing ones aside), some are *numbers* (a number, a boolean, or text that
  reads as a finite number, such as ``"1"`` or ``" 2.5"``, or as a boolean,
  ``"true"`` or ``"False"`` in any case) and some are *other text* (such as
  ``"yes"``). Each text value would be one more outcome value, silently
  apart from the number it probably means. The error lists the rows of the
  smaller kind (by records). Counting them anyway, every value an outcome of
  its own, is ``mixed_outcome=True`` (``--mixed-outcome``: ranks and
  ``"unranked"``), which :func:`fairaudit.audit` also sets when a ``utility``
  says what each value is worth (an expression sees every value as text
  then: ``u in ["1", "yes"]``).

Rows: **data row** N is the N-th record, counted from 1: in a file, the
N-th record after the header (blank lines not counted; a record whose quoted
field spans lines counts once); in a DataFrame, its N-th row by position
(not its index label); in a folder of Parquet files, the N-th row of the file
named; in Spark, the N-th row in the DataFrame's own order. The counting
itself is vectorised (distinct values only, then numpy masks); the rows are
looked for only when a value is refused (a second query, for a file or a
Spark DataFrame).
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from numbers import Number
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.errors import InputError, echo

__all__ = ["CONTROL", "ROWS_SHOWN", "Locate", "check_key_values", "control_name", "records_locate"]

CONTROL = "[\x00-\x1f\x7f-\x9f]"
"""A regular expression for one control character (Unicode category Cc), for Python's ``re``."""

_CONTROL = re.compile(CONTROL)

ROWS_SHOWN = 5
"""How many data rows an error names (then how many records in all)."""

Locate: TypeAlias = Callable[[str, npt.NDArray[np.bool_]], list[tuple[str, Any]]]
"""Where values are in the data: given a column and a mask over the rows checked (records, or distinct
combinations), the first :data:`ROWS_SHOWN` data rows that hold the masked values, in the data's order, each
as (its number as the error says it, e.g. ``"6"`` or ``"6 of part-1.parquet"``; the value there)."""

_Distinct: TypeAlias = tuple[npt.NDArray[np.intp], npt.NDArray[np.object_]]
"""A column's distinct values: each row's code (-1 where missing) and the values (object array)."""

_CONVENTION = "data rows count from 1, the first record after the header"


def control_name(char: str) -> str:
    """A character as ``U+0000``.

    Examples
    --------
    >>> control_name("\\x00"), control_name("\\t")
    ('U+0000', 'U+0009')
    """
    return f"U+{ord(char):04X}"


def records_locate(columns: Mapping[str, Any]) -> Locate:
    """:data:`Locate` for records held in memory: data row i + 1 is the row at position i."""

    def locate(column: str, mask: npt.NDArray[np.bool_]) -> list[tuple[str, Any]]:
        values = columns[column]
        hits = np.flatnonzero(mask)[:ROWS_SHOWN]
        return [(str(i + 1), values.iloc[i] if hasattr(values, "iloc") else values[i]) for i in hits]

    return locate


def check_key_values(
    columns: Mapping[str, Any],
    outcome: str,
    *,
    weights: npt.ArrayLike | None = None,
    locate: Locate | None = None,
    mixed_outcome: bool = False,
) -> None:
    """Refuse control characters in any key column, and an outcome column that mixes numbers and text.

    Parameters
    ----------
    columns : mapping of str to array_like
        Each key column's values, one per row checked: records, or distinct
        combinations of the keys (then ``weights`` says how many records each
        stands for).
    outcome : str
        The outcome column (a key of ``columns``), checked for mixed numbers and text too.
    weights : array_like, optional
        Records per row (default one).
    locate : Locate, optional
        Where the refused values are in the data; default: the rows are the
        records, in order (:func:`records_locate`).
    mixed_outcome : bool
        Accept an outcome column that mixes numbers and text.

    Raises
    ------
    InputError
        Field ``column 'NAME'``: the control character (as ``U+0000``) and the
        first data row that holds one, with the value quoted (escaped, cut
        around the character); or, for the outcome, how many records are text
        among numbers (or numbers among text), their first data rows, and the
        fix.

    Examples
    --------
    >>> check_key_values({"race": ["a", "b"], "hired": [1, 0]}, "hired")
    >>> try:
    ...     check_key_values({"race": ["a", "b\\x00"], "hired": [1, 0]}, "hired")
    ... except InputError as e:
    ...     print(e)
    column 'race': holds the control character U+0000 in data row 2 (data rows count from 1, the first record after the header); 1 record in all: remove control characters (tabs and line breaks too) from the values (got 'b\\x00')
    >>> try:
    ...     check_key_values({"race": ["a", "b", "b"], "hired": ["1", "0", "yes"]}, "hired")
    ... except InputError as e:
    ...     print(e)
    column 'hired': mixes numbers and text: 1 of 3 records is text ('yes') where the others are numbers, in data row 3 (data rows count from 1, the first record after the header): fix the data, give `utility` as an expression of the values read as text (e.g. u in ["1", "yes"]), or, if the text values are outcomes of their own (a rank and 'unranked'), say so with `mixed_outcome` (got 'yes')
    """
    locate = records_locate(columns) if locate is None else locate
    n = None if weights is None else np.asarray(weights)
    distinct = {name: _distinct(values) for name, values in columns.items()}
    for name, found in distinct.items():
        if found is not None:
            _check_control(name, found, n, locate)
            _check_spellings(name, found, n, locate)
    found = distinct.get(outcome)
    if found is not None and not mixed_outcome:
        _check_mixed(outcome, found, n, locate)


def _distinct(values: Any) -> _Distinct | None:
    """Codes of the rows (-1 where missing) and the distinct values, for a column that may hold text; else None.

    A pandas Series is factorized by pandas; a numpy array (a file's grouped keys: text with None where missing)
    by numpy, without importing pandas.
    """
    pd = sys.modules.get("pandas")
    if pd is not None and isinstance(values, pd.Series):
        kind = values.dtype
        if not (pd.api.types.is_object_dtype(kind) or pd.api.types.is_string_dtype(kind) or kind == "category"):
            return None  # numbers, booleans, dates: no text in them
        codes, uniques = pd.factorize(values)
        return np.asarray(codes, dtype=np.intp), np.asarray(uniques, dtype=object)
    array = values if isinstance(values, np.ndarray) else np.asarray(values)
    if array.dtype.kind == "U" and not isinstance(values, np.ndarray):
        array = np.asarray(values, dtype=object)  # numpy's str dtype drops trailing NUL characters
    if array.dtype.kind not in "OUT":
        return None
    array = array.reshape(-1)
    present = np.fromiter((v is not None for v in array), dtype=bool, count=array.size)  # (a file's: None missing)
    if array.dtype.kind == "O" and not all(isinstance(v, str) for v in array[present][:1]):
        import pandas

        return _distinct(pandas.Series(array, dtype=object))
    uniques, inverse = np.unique(array[present], return_inverse=True)
    codes = np.full(array.size, -1, dtype=np.intp)
    codes[present] = inverse.reshape(-1)
    return codes, np.asarray(uniques, dtype=object)


def _text(uniques: npt.NDArray[np.object_]) -> npt.NDArray[np.bool_]:
    return np.fromiter((isinstance(v, str) for v in uniques), dtype=bool, count=len(uniques))


def _matches(pattern: re.Pattern[str], texts: npt.NDArray[np.object_]) -> npt.NDArray[np.bool_]:
    """Which of ``texts`` hold a match of ``pattern`` (one that cannot span two of them, as a control character).

    One scan of the texts joined by a character outside the pattern (vectorised by the regular expression
    engine), each match placed in its text by the texts' cumulative lengths.
    """
    found = np.zeros(len(texts), dtype=bool)
    if not len(texts):
        return found
    ends = np.cumsum(np.fromiter((len(t) + 1 for t in texts), dtype=np.int64, count=len(texts)))
    starts = np.fromiter((m.start() for m in pattern.finditer(" ".join(texts))), dtype=np.int64)
    found[np.searchsorted(ends, starts, side="right")] = True
    return found


def _records(mask: npt.NDArray[np.bool_], n: npt.NDArray[Any] | None) -> int:
    return int(mask.sum()) if n is None else int(np.asarray(n[mask], dtype=np.float64).sum())


def _rows(hits: list[tuple[str, Any]]) -> str:
    return ("data row " if len(hits) == 1 else "data rows ") + ", ".join(row for row, _ in hits)


def _check_control(name: str, found: _Distinct, n: npt.NDArray[Any] | None, locate: Locate) -> None:
    codes, uniques = found
    text = _text(uniques)
    if not text.any():
        return
    bad = np.zeros(len(uniques), dtype=bool)
    bad[text] = _matches(_CONTROL, uniques[text])
    if not bad.any():
        return
    mask = bad[codes] & (codes >= 0)
    hits = locate(name, mask)
    row, value = hits[0]
    value = str(value)
    char = _CONTROL.search(value)
    at = char.start() if char is not None else 0
    total = _records(mask, n)
    raise InputError(
        f"column {echo(name)}",
        f"holds the control character {control_name(value[at]) if char else 'U+????'} in data row {row} "
        f"({_CONVENTION}); {total} record{'s' if total != 1 else ''} in all: remove control characters "
        "(tabs and line breaks too) from the values",
        _excerpt(value, at),
    )


def _excerpt(value: str, at: int, width: int = 30) -> str:
    """``value`` around position ``at``: at most ``width`` characters each side, cuts marked by ``...``."""
    start, end = max(at - width, 0), at + width + 1
    return ("..." if start else "") + value[start:end] + ("..." if end < len(value) else "")


_NUMBER = re.compile(r"\s*[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\s*|\s*(?:true|false)\s*", re.I)
"""Text that reads as a finite number (``"1"``, ``" 2.5"``, ``"-3e2"``) or as a boolean (``"true"``, ``"False"``)."""


def _numbers(uniques: npt.NDArray[np.object_], text: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """Which distinct values are numbers: numbers and booleans, and text that reads as a finite number or a boolean."""
    number = np.fromiter(
        (isinstance(v, Number) and not (isinstance(v, float) and not math.isfinite(v)) for v in uniques),
        dtype=bool,
        count=len(uniques),
    )
    number[text] = np.fromiter((_NUMBER.fullmatch(v) is not None for v in uniques[text]), dtype=bool)
    return number


def _check_mixed(name: str, found: _Distinct, n: npt.NDArray[Any] | None, locate: Locate) -> None:
    codes, uniques = found
    text = _text(uniques)
    number = _numbers(uniques, text)
    other = text & ~number
    if not (number.any() and other.any()):
        return
    present = codes >= 0
    number_rows, other_rows = number[codes] & present, other[codes] & present
    n_number, n_other = _records(number_rows, n), _records(other_rows, n)
    odd_text = n_other <= n_number
    mask, odd = (other_rows, other) if odd_text else (number_rows, number)
    k, total = (n_other if odd_text else n_number), n_number + n_other
    odd_values = sorted(str(v) for v in uniques[odd])
    shown = [echo(v) for v in odd_values[:3]] + (["..."] if len(odd_values) > 3 else [])
    kind, others = ("text", "numbers") if odd_text else ("numbers", "text")
    hits = locate(name, mask)
    more = f" (the first {len(hits)})" if k > len(hits) else ""
    numbers = sorted(str(v) for v in uniques[number])
    word = min((str(v) for v in uniques[other]), key=lambda v: (len(v), v))  # the shortest text, if short
    example = ["1" if "1" in numbers else numbers[0], word if len(word) <= 40 else "<text value>"]
    raise InputError(
        f"column {echo(name)}",
        f"mixes numbers and text: {k} of {total} records {'is' if k == 1 else 'are'} {kind} ({', '.join(shown)}) "
        f"where the others are {others}, in {_rows(hits)}{more} ({_CONVENTION}): fix the data, give `utility` "
        f"as an expression of the values read as text (e.g. u in {_list(example)}), or, if the text values are "
        "outcomes of their own (a rank and 'unranked'), say so with `mixed_outcome`",
        str(hits[0][1]),
    )


def _check_spellings(name: str, found: _Distinct, n: npt.NDArray[Any] | None, locate: Locate) -> None:
    """Refuse one number (or boolean) written two ways in a column of text: ``1`` and ``1.0``, ``01`` and ``1``,
    ``True`` and ``true``. Each distinct text is a label of its own, so they would be two groups, or two outcomes
    of which one misses ``positive``: a silent wrong number."""
    codes, uniques = found
    text = _text(uniques)
    number = _numbers(uniques, text)
    if number.sum() < 2 or not text.any():
        return
    values = uniques[number]
    meaning = [_meaning(v) for v in values]
    first: dict[object, int] = {}  # the first value of each meaning; the first meaning met again is refused
    repeated = next((m for i, m in enumerate(meaning) if first.setdefault(m, i) != i), None)
    if repeated is None:
        return
    same = sorted({str(v) for v, m in zip(values, meaning) if m == repeated})
    bad = np.isin(np.asarray([str(v) for v in uniques], dtype=object), same) & number
    mask = bad[codes] & (codes >= 0)
    hits = locate(name, mask)
    shown = ", ".join(echo(v) for v in same[:3]) + (", ..." if len(same) > 3 else "")
    raise InputError(
        f"column {echo(name)}",
        f"writes one value several ways ({shown}), in {_rows(hits)} ({_CONVENTION}): each text is a label of its "
        "own, so they would count as different groups or outcomes; write each value one way",
        str(hits[0][1]),
    )


def _meaning(value: object) -> object:
    """What a number or boolean (or text reading as one) stands for: the float, or the boolean."""
    if isinstance(value, str):
        word = value.strip().lower()
        return ("boolean", word == "true") if word in {"true", "false"} else ("number", float(word))
    return ("boolean", value) if isinstance(value, bool) else ("number", float(value))  # type: ignore[arg-type]


def _list(values: Sequence[str]) -> str:
    """Text values as an expression's list literal (double quotes)."""
    return "[" + ", ".join('"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"' for v in values) + "]"
