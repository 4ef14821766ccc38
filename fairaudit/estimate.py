"""From decision records to counts to an estimated law.

A record is one decision (or one candidate of a decision among several, see
DESIGN.md "Decisions among several candidates") with its context X, its
sensitive attribute(s) A and its outcome U. Counting is vectorised
(``pandas.factorize`` and ``numpy.bincount``), never a loop over records.

Labels: one column gives scalar labels; several columns give tuples
(intersectional groups, or a compound context). Without context columns
there is one context, labelled ``"all"``. Intervals for what the counts
estimate: :mod:`fairaudit.intervals`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ._arrays import format_label
from ._errors import InputError
from .laws import Law, Population

__all__ = ["CountTable", "read_records", "count_records", "count_table"]


@dataclass(frozen=True, eq=False)
class CountTable:
    """Counts of decisions per context and group, shape (n_contexts, n_groups, n_decisions).

    Attributes
    ----------
    counts : numpy.ndarray of int64
        ``counts[x, a, u]`` = number of records with context x, group a, outcome u.
    contexts, groups, decisions : tuple
        Axis labels (sorted as pandas sorts them).
    context_columns, sensitive_columns : tuple of str
        The columns they came from.
    outcome_column : str
    """

    counts: np.ndarray
    contexts: tuple
    groups: tuple
    decisions: tuple
    context_columns: tuple
    sensitive_columns: tuple
    outcome_column: str

    @property
    def n(self) -> int:
        """Total number of records."""
        return int(self.counts.sum())

    @property
    def cell_counts(self) -> np.ndarray:
        """Records per (context, group), shape (n_contexts, n_groups)."""
        return self.counts.sum(axis=-1)

    @property
    def group_counts(self) -> np.ndarray:
        """Records per group, shape (n_groups,)."""
        return self.counts.sum(axis=(0, 2))

    @property
    def context_counts(self) -> np.ndarray:
        """Records per context, shape (n_contexts,)."""
        return self.counts.sum(axis=(1, 2))

    def law(self) -> Law:
        """The empirical law P(U | X, A); empty cells are NaN and reported."""
        return Law.from_counts(self.counts, self.contexts, self.groups, self.decisions)

    def population(self) -> Population:
        """The empirical population P(X, A) = n(x, a) / n."""
        return Population.from_counts(self.cell_counts, self.contexts, self.groups)


def read_records(path: str | Path) -> pd.DataFrame:
    """Read decision records from a CSV or Parquet file (by extension).

    Raises
    ------
    InputError
        If the file is missing, its extension is unknown, or it cannot be parsed.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("DATA", "no such file", str(path))
    suffix = p.suffix.lower()
    try:
        if suffix in {".parquet", ".pq"}:
            try:
                return pd.read_parquet(p)
            except ImportError:
                raise InputError("DATA", "reading Parquet needs pyarrow: pip install 'fairaudit[parquet]'", str(path)) from None
        if suffix in {".csv", ".txt", ".gz"}:
            return pd.read_csv(p, low_memory=False)
    except InputError:
        raise
    except Exception as exc:  # pandas raises many parser errors; report one line
        raise InputError("DATA", f"cannot be read ({type(exc).__name__}: {str(exc).splitlines()[0]})", str(path)) from None
    raise InputError("DATA", "must be a .csv or .parquet file", str(path))


def _codes(frame: pd.DataFrame, columns: Sequence[str], role: str):
    """Factorize one or several columns into (codes, labels); labels sorted."""
    if not columns:
        return np.zeros(len(frame), dtype=np.int64), ("all",)
    if len(columns) == 1:
        codes, uniques = pd.factorize(frame[columns[0]], sort=True)
        labels = tuple(v.item() if isinstance(v, np.generic) else v for v in uniques)
        return codes.astype(np.int64), labels
    sub = frame[list(columns)]
    idx = pd.MultiIndex.from_frame(sub)
    codes, uniques = pd.factorize(idx, sort=True)
    labels = tuple(tuple(x.item() if isinstance(x, np.generic) else x for x in t) for t in uniques)
    return codes.astype(np.int64), labels


def _check_columns(frame: pd.DataFrame, columns: Sequence[str], field: str) -> None:
    for c in columns:
        if c not in frame.columns:
            shown = ", ".join(map(str, list(frame.columns)[:12])) + (", ..." if len(frame.columns) > 12 else "")
            raise InputError(field, f"unknown column; the data has: {shown}", c)


def count_records(
    data: pd.DataFrame,
    *,
    sensitive: Sequence[str],
    outcome: str,
    context: Sequence[str] = (),
    dropna: bool = False,
) -> CountTable:
    """Count decision records per (context, group, outcome).

    Parameters
    ----------
    data : pandas.DataFrame
        One row per decision (or per candidate).
    sensitive : sequence of str
        Column(s) of the sensitive attribute A; several give intersectional
        groups with tuple labels.
    outcome : str
        Column of the decision U (all its values are kept).
    context : sequence of str, optional
        Column(s) of the context X; none gives one context "all".
    dropna : bool
        Drop rows with a missing value in any used column instead of failing.

    Returns
    -------
    CountTable

    Raises
    ------
    InputError
        On an unknown column, missing values (naming the column and count)
        when ``dropna`` is False, or no records.

    Examples
    --------
    >>> df = pd.DataFrame({"race": ["a", "a", "b", "b", "b"], "hired": [1, 0, 1, 1, 0]})
    >>> t = count_records(df, sensitive=["race"], outcome="hired")
    >>> t.counts.tolist(), t.groups, t.decisions
    ([[[1, 1], [1, 2]]], ('a', 'b'), (0, 1))
    """
    sensitive = [sensitive] if isinstance(sensitive, str) else list(sensitive)
    context = [context] if isinstance(context, str) else list(context)
    if not sensitive:
        raise InputError("--sensitive", "name at least one column", sensitive)
    _check_columns(data, sensitive, "--sensitive")
    _check_columns(data, [outcome], "--outcome")
    _check_columns(data, context, "--context")
    used = list(dict.fromkeys(context + sensitive + [outcome]))
    frame = data[used]
    missing = frame.isna().sum()
    if missing.any():
        if not dropna:
            col = missing[missing > 0].index[0]
            raise InputError(f"column {col!r}", f"has {int(missing[col])} missing values (drop those rows: --dropna, or dropna=True)")
        frame = frame.dropna()
    if len(frame) == 0:
        raise InputError("DATA", "has no records to count")
    cx, contexts = _codes(frame, context, "context")
    ca, groups = _codes(frame, sensitive, "sensitive")
    cu, decisions = _codes(frame, [outcome], "outcome")
    shape = (len(contexts), len(groups), len(decisions))
    flat = (cx * shape[1] + ca) * shape[2] + cu
    counts = np.bincount(flat, minlength=int(np.prod(shape))).reshape(shape)
    return CountTable(counts, contexts, groups, decisions, tuple(context), tuple(sensitive), outcome)


def count_table(
    data: pd.DataFrame,
    *,
    sensitive: Sequence[str],
    outcome: str,
    context: Sequence[str] = (),
    count: str = "count",
    contexts: Sequence | None = None,
    groups: Sequence | None = None,
    decisions: Sequence | None = None,
) -> CountTable:
    """A CountTable from an aggregated table: one row per (context, group, outcome) with a count.

    Parameters
    ----------
    data : pandas.DataFrame
        Columns for context(s), sensitive attribute(s), outcome and ``count``.
    contexts, groups, decisions : sequence, optional
        Expected labels in their order; the data's values are matched to them
        by their text (``str``), and a value not among them is an error that
        names the column and the value. Default: the sorted values found.

    Raises
    ------
    InputError
        On unknown columns, unknown labels, negative or non-integer counts,
        or a (context, group, outcome) given twice.
    """
    sensitive = [sensitive] if isinstance(sensitive, str) else list(sensitive)
    context = [context] if isinstance(context, str) else list(context)
    _check_columns(data, sensitive + [outcome] + context + [count], "table")
    values = pd.to_numeric(data[count], errors="coerce")
    if values.isna().any() or (values < 0).any():
        bad = data[count][values.isna() | (values < 0)].iloc[0]
        raise InputError(f"column {count!r}", "must hold non-negative numbers", bad)

    def codes(columns, expected, role):
        if expected is None:
            return _codes(data, columns, role)
        expected = tuple(expected)
        lookup = {format_label(v): i for i, v in enumerate(expected)}
        if len(columns) == 0:
            return np.zeros(len(data), dtype=np.int64), expected
        keys = data[columns].astype(str).agg(" & ".join, axis=1) if len(columns) > 1 else data[columns[0]].astype(str)
        mapped = keys.map(lookup)
        if mapped.isna().any():
            bad = keys[mapped.isna()].iloc[0]
            raise InputError(f"column {columns[0]!r}" if len(columns) == 1 else f"columns {columns}",
                             f"value not among the {role} values {[format_label(v) for v in expected]}", bad)
        return mapped.to_numpy(dtype=np.int64), expected

    cx, contexts = codes(context, contexts, "context")
    ca, groups = codes(sensitive, groups, "sensitive")
    cu, decisions = codes([outcome], decisions, "decision")
    shape = (len(contexts), len(groups), len(decisions))
    flat = (cx * shape[1] + ca) * shape[2] + cu
    dup = pd.Series(flat).duplicated()
    if dup.any():
        i = int(np.flatnonzero(dup.to_numpy())[0])
        raise InputError("count table", "lists the same (context, group, decision) twice", data.iloc[i].to_dict())
    counts = np.bincount(flat, weights=values.to_numpy(dtype=float), minlength=int(np.prod(shape))).reshape(shape)
    return CountTable(counts, contexts, groups, decisions, tuple(context), tuple(sensitive), outcome)
