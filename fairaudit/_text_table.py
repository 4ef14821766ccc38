"""A spec's small count table read from CSV without pandas, where that is provably what pandas would read.

``fairaudit certify`` reads a spec's model table (``[model] table``) with
:func:`fairaudit.estimate.read_records` (pandas) and matches each field to the
spec's labels by its text. Importing pandas costs more than the rest of a
certificate of a small spec. :func:`count_table_text` reads the file with the
standard library's :mod:`csv` module instead, and answers only when every
field it uses has, in the frame pandas would build, the very text it has in
the file; otherwise it returns None and the caller takes the pandas route,
which also reports every error. It answers when:

- the file is an uncompressed ``.csv`` or ``.txt`` in UTF-8 with a header of
  distinct names, every record as many fields as the header, and no used
  field holding a quote or a line break;
- no used field is one of pandas' missing-value markers (nor blank);
- each used column either holds a field that cannot be a number, a boolean or
  a missing value (pandas keeps the whole column as text), or holds only
  integers written as pandas writes them back (``0``, ``-12``; pandas reads
  int64, whose text is the field's);
- the counts are such integers, none negative;
- every field matches a label of the spec, the ``where`` filters select rows,
  and no (context, group, decision) is listed twice.

So the counts, labels and values are those of the pandas route whenever this
module answers (``tests/test_spec_table_text.py`` compares the two routes on
generated files).
"""

from __future__ import annotations

import csv
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ._arrays import format_label

__all__ = ["count_table_text"]

# pandas' default missing-value markers (pandas._libs.parsers.STR_NA_VALUES), compared after stripping.
_NA = frozenset(
    {"", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN", "<NA>", "N/A", "NA"}
    | {"NULL", "NaN", "None", "n/a", "nan", "null"}
)
# Fields that might be a number, a boolean or a missing value to pandas: only these characters, or a word below.
_MAYBE_NUMBER = re.compile(r"[0-9+\-.eE\s]*")
_WORDS = frozenset(
    {"inf", "+inf", "-inf", "infinity", "+infinity", "-infinity", "nan", "+nan", "-nan", "true", "false"}
)
_INT64 = re.compile(r"0|-?[1-9][0-9]{0,17}")  # as int64 prints it; 18 digits stay below 2**63


def _is_text(field: str) -> bool:
    """True when pandas cannot read ``field`` as a number, a boolean or a missing value."""
    return not _MAYBE_NUMBER.fullmatch(field) and field.strip().lower() not in _WORDS


def _same_text(column: Sequence[str]) -> bool:
    """Whether pandas' values of this column, as text, are the fields themselves."""
    if any(f.strip() in _NA for f in column):
        return False
    return any(_is_text(f) for f in column) or all(_INT64.fullmatch(f) for f in column)


def _read(path: Path) -> tuple[list[str], list[list[str]]] | None:
    """Header and records of a regular CSV file, or None."""
    if path.suffix.lower() not in {".csv", ".txt"}:
        return None
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            rows = [r for r in csv.reader(f) if r]  # pandas skips blank lines
    except (OSError, UnicodeDecodeError, csv.Error):
        return None
    if not rows or len(set(rows[0])) < len(rows[0]) or any(len(r) != len(rows[0]) for r in rows):
        return None
    return rows[0], rows[1:]


def count_table_text(
    path: Path,
    *,
    where: Mapping[str, object],
    roles: tuple[str | None, str, str],
    count: str | None,
    labels: tuple[tuple, tuple, tuple],
) -> npt.NDArray[np.int64] | None:
    """The counts [x, a, u] of a spec's CSV count table, or None to leave it to the pandas route.

    Parameters
    ----------
    path : pathlib.Path
        The table.
    where : mapping
        Column -> value: the rows kept (the field's text equals ``str(value)``).
    roles : (str or None, str, str)
        The context column (None: one context), the sensitive column and the decision column.
    count : str or None
        The count column; None: ``count`` when the header has it, else None is returned.
    labels : (tuple, tuple, tuple)
        The spec's contexts, groups and decisions; fields match them by text (:func:`format_label`).

    Returns
    -------
    numpy.ndarray of int64, shape (contexts, groups, decisions), or None
        The counts; None wherever this route cannot vouch for the pandas route's result.
    """
    read = _read(path)
    if read is None:
        return None
    header, rows = read
    column = count if count is not None else ("count" if "count" in header else None)
    keys = [c for c in roles if c is not None]
    if column is None or not set(keys) | {column} | set(where) <= set(header) or not rows:
        return None
    used = list(dict.fromkeys([*keys, column, *where]))
    at = {name: i for i, name in enumerate(header)}
    fields = {name: [r[at[name]] for r in rows] for name in used}  # pandas types a column by all its fields
    if any('"' in f or "\n" in f or "\r" in f for values in fields.values() for f in values):
        return None
    if not all(_same_text(fields[name]) for name in used if name != column):
        return None
    if not all(_INT64.fullmatch(f) and not f.startswith("-") for f in fields[column]):
        return None
    keep = np.ones(len(rows), dtype=bool)
    for name, want in where.items():
        keep &= np.array(fields[name]) == str(want)
        if not keep.any():
            return None
    fields = {name: [f for f, k in zip(values, keep) if k] for name, values in fields.items()}
    codes = []
    for role, wanted in zip(roles, labels):
        if role is None:
            codes.append(np.zeros(int(keep.sum()), dtype=np.int64))
            continue
        lookup: dict[str, int] = {format_label(v): i for i, v in enumerate(wanted)}
        found = [lookup.get(f, -1) for f in fields[role]]
        if not found or min(found) < 0:
            return None
        codes.append(np.array(found, dtype=np.int64))
    shape = tuple(len(x) for x in labels)
    flat = (codes[0] * shape[1] + codes[1]) * shape[2] + codes[2]
    if np.unique(flat).size < flat.size:
        return None
    counts = np.zeros(int(np.prod(shape)), dtype=np.int64)
    counts[flat] = np.array([int(f) for f in fields[column]], dtype=np.int64)
    return counts.reshape(shape)
