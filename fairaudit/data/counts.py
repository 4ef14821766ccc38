"""From decision records to counts to an estimated law.

A record is one decision (or one candidate of a decision among several, see
docs/design.md "Decisions among several candidates") with its context X, its
sensitive attribute(s) A and its outcome U. Counting is vectorised
(``pandas.factorize`` and ``numpy.bincount``), never a loop over records.

Labels: one column gives scalar labels; several columns give tuples
(intersectional groups, or a compound context). Without context columns
there is one context, labelled ``"all"``. Intervals for what the counts
estimate: :mod:`fairaudit.statistics.intervals`.

Files: :func:`count_file` counts a Parquet or text file with DuckDB (one
``GROUP BY`` of the used columns in fairaudit's own in-memory database,
:mod:`fairaudit.data.record_files`), so memory grows with the number of
(context, group, decision) combinations, not with the records; it also reads
count tables made by any engine (SQL ``GROUP BY``, Spark, DuckDB), and
:func:`~fairaudit.data.record_files.read_records` reads a file whole, also with DuckDB. See docs/scale.md.

pandas and DuckDB are imported by the functions that use them, not with this
module (``import fairaudit`` stays fast).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.checks import columns
from fairaudit.base.errors import InputError, echo
from fairaudit.base.labels import format_label, label_list
from fairaudit.data.columns import check_roles, missing_values, roles
from fairaudit.data.csv_format import CsvFormat
from fairaudit.data.key_values import Locate, check_key_values
from fairaudit.data.record_files import source
from fairaudit.laws.tables import Law, Population

if TYPE_CHECKING:
    import pandas as pd

Counts: TypeAlias = npt.NDArray[np.int64 | np.float64]
"""Counts of records: int64, or float64 for a table of weights or probabilities."""
Codes: TypeAlias = npt.NDArray[np.integer[Any]]
"""Integer codes (positions in a tuple of labels), or integer weights."""

__all__ = ["CountTable", "CsvFormat", "count_file", "count_records", "count_table"]


@dataclass(frozen=True, eq=False)
class CountTable:
    """Counts of decisions per context and group, shape (n_contexts, n_groups, n_decisions).

    Attributes
    ----------
    counts : numpy.ndarray of int64
        ``counts[x, a, u]`` = number of records with context x, group a, outcome u.
    contexts, groups, decisions : tuple
        Axis labels, sorted: numbers numerically, text by code point, a DataFrame's categorical in its
        categories' order, tuples lexicographically.
    context_columns, sensitive_columns : tuple of str
        The columns they came from.
    outcome_column : str
    weight_column : str or None
        The column of sample (survey) weights; then ``counts[x, a, u]`` is the
        sum of the weights of those records (float64), not their number.
    squares : numpy.ndarray or None
        With weights, the sum of the squared weights per (x, a, u), for the
        effective sample sizes of :meth:`effective_counts`.
    missing : tuple of (str, float)
        With ``dropna``, the records dropped for a missing value, per used
        column (with weights, their weight), and for several sensitive
        columns under their names joined by ``" x "`` (a value missing in
        any of them); empty when nothing was dropped.
    unknown_outcomes : tuple of (str, tuple of (label, float))
        With ``dropna``, per sensitive column (and their intersection) with
        records of unknown category, those records' outcomes and their
        number (weight): what the impact ratios' missing-data bounds need.
        Records whose outcome is missing too are not in it.
    """

    counts: Counts
    contexts: tuple
    groups: tuple
    decisions: tuple
    context_columns: tuple[str, ...]
    sensitive_columns: tuple[str, ...]
    outcome_column: str
    weight_column: str | None = None
    squares: Counts | None = None
    missing: tuple[tuple[str, float], ...] = ()
    unknown_outcomes: tuple[tuple[str, tuple[tuple[Hashable, float], ...]], ...] = ()

    @property
    def whole(self) -> bool:
        """The counts are numbers of records: no weights, and every count a whole number (a count table may hold
        scaled or weighted counts)."""
        return self.squares is None and bool(np.all(self.counts == np.round(self.counts)))

    @property
    def n(self) -> int | float:
        """Total number of records (an int), or with weights or counts that are not whole their total (a float)."""
        total = self.counts.sum()
        return int(total) if self.whole else float(total)

    def effective_counts(self, pooled: bool = False) -> Counts:
        """Counts scaled to Kish's effective sample size: what intervals treat as numbers of records.

        Without weights, the counts themselves. With weights, each (context,
        group) cell's weighted counts times n_eff / W, where W = Σ w and
        n_eff = (Σ w)² / Σ w² over the cell's records (Kish 1965): the
        weighted proportions, on n_eff records. ``pooled`` gives the groups
        pooled over contexts, shape (n_groups, n_decisions), scaled by each
        group's own n_eff. An approximation (it ignores how the weights were
        made); ``benchmarks/bench_weights.py`` measures the coverage it gives.

        Returns
        -------
        numpy.ndarray
            Shape (n_contexts, n_groups, n_decisions), or (n_groups,
            n_decisions) with ``pooled``; float64 with weights.
        """
        counts = self.counts.sum(axis=0) if pooled else self.counts
        if self.squares is None:
            return counts
        squares = self.squares.sum(axis=0) if pooled else self.squares
        w, s = counts.sum(axis=-1, keepdims=True), squares.sum(axis=-1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(s > 0, w / s, 0.0)  # n_eff / W = W / S
        return counts * scale

    @property
    def cell_counts(self) -> Counts:
        """Records per (context, group), shape (n_contexts, n_groups)."""
        return self.counts.sum(axis=-1)

    @property
    def group_counts(self) -> Counts:
        """Records per group, shape (n_groups,)."""
        return self.counts.sum(axis=(0, 2))

    @property
    def context_counts(self) -> Counts:
        """Records per context, shape (n_contexts,)."""
        return self.counts.sum(axis=(1, 2))

    def law(self) -> Law:
        """The empirical law P(U | X, A); empty cells are NaN and reported."""
        return Law.from_counts(self.counts, self.contexts, self.groups, self.decisions)

    def population(self) -> Population:
        """The empirical population P(X, A) = n(x, a) / n."""
        return Population.from_counts(self.cell_counts, self.contexts, self.groups)


def _codes(columns: Sequence[Any], n: int) -> tuple[Codes, tuple]:
    """(codes, labels) of ``n`` rows of one or several complete columns: labels sorted (tuples lexicographically).

    A pandas Series is factorized by pandas (any values: a categorical in its categories' order); a numpy array (a
    file's keys, of one type) by numpy, without importing pandas.
    """
    if not columns:
        return np.zeros(n, dtype=np.int64), ("all",)
    pd = sys.modules.get("pandas")
    factorized = []
    for column in columns:
        if pd is not None and isinstance(column, pd.Series):
            codes, uniques = pd.factorize(column, sort=True)
            factorized.append((codes, [v.item() if isinstance(v, np.generic) else v for v in uniques]))
        else:
            uniques, codes = np.unique(column, return_inverse=True)
            factorized.append((codes.reshape(-1), uniques.tolist()))
    if len(columns) == 1:
        return np.asarray(factorized[0][0], dtype=np.int64), tuple(factorized[0][1])
    rows, inverse = np.unique(np.stack([c for c, _ in factorized], axis=1), axis=0, return_inverse=True)
    labels = tuple(tuple(factorized[j][1][i] for j, i in enumerate(row)) for row in rows.tolist())
    return inverse.reshape(-1).astype(np.int64), labels


def tally(
    columns: dict[str, Any],
    missing: dict[str, npt.NDArray[np.bool_]],
    sensitive: list[str],
    outcome: str,
    context: list[str],
    dropna: bool,
    *,
    n: Codes | None = None,
    sample_weight: str | None = None,
    locate: Locate | None = None,
    mixed_outcome: bool = False,
) -> CountTable:
    """The counts of rows: records (pandas Series, :func:`count_records`), a file's grouped keys (numpy arrays,
    :func:`count_file`) or a Spark DataFrame's (:func:`~fairaudit.data.spark.count_spark`), each row ``n[i]`` records (default 1) and missing where ``missing[column]``.

    The one counting path: the key values are checked first (:func:`~fairaudit.data.key_values.check_key_values`;
    ``locate`` finds a refused value's data rows), then missing values are dropped or refused, then the labels are the
    sorted distinct values (:func:`_codes`). With ``sample_weight`` (a column of ``columns``, one row per record) the
    counts are sums of those weights.

    Parameters
    ----------
    columns : dict of str to array-like, each of length n_rows
        The columns by name (pandas Series, numpy arrays or a Spark frame's collected keys).
    missing : dict of str to bool array of shape (n_rows,)
        Where each column's value is missing.
    sensitive, outcome, context : list of str, str, list of str
        The columns of the groups A, the outcome U and the contexts X.
    dropna : bool
        Drop rows with a missing key value (counted in ``CountTable.missing``), else refuse them.
    n : array of shape (n_rows,), optional
        Records per row (a grouped file's counts); default one each.
    sample_weight : str, optional
        A column of weights summed in place of counts.
    locate : callable, optional
        Finds the data rows of a refused value, for the error.
    mixed_outcome : bool
        Accept an outcome column that mixes numbers and text.

    Returns
    -------
    CountTable
        Counts of shape (n_contexts, n_groups, n_outcomes), labels sorted.

    Raises
    ------
    InputError
        A key value no count may trust (:func:`~fairaudit.data.key_values.check_key_values`), or a missing value
        without ``dropna``, naming the column and the value.
    """
    keys = list(dict.fromkeys(context + sensitive + [outcome]))
    check_key_values({c: columns[c] for c in keys}, outcome, weights=n, locate=locate, mixed_outcome=mixed_outcome)
    used = list(dict.fromkeys(keys + ([sample_weight] if sample_weight else [])))
    lost = {c: int(missing[c].sum() if n is None else n[missing[c]].sum()) for c in used}
    dropped: list[tuple[str, float]] = []
    if any(lost.values()):
        first = next(c for c in used if lost[c])
        if not dropna:
            raise missing_values(first, lost[first])
        dropped = [(c, float(lost[c])) for c in used if lost[c]]
        any_sensitive = np.logical_or.reduce([missing[c] for c in sensitive])
        k = int(any_sensitive.sum() if n is None else n[any_sensitive].sum())
        dropped += [(" x ".join(sensitive), float(k))] if len(sensitive) > 1 and k else []
        unknown = _unknown_outcomes(columns, missing, sensitive, outcome, n, sample_weight)
        keep = ~np.logical_or.reduce([missing[c] for c in used])
        columns, n = {c: columns[c][keep] for c in used}, None if n is None else n[keep]
    rows = len(columns[outcome])
    if rows == 0:
        raise InputError("DATA", "has no records to count")
    cx, contexts = _codes([columns[c] for c in context], rows)
    ca, groups = _codes([columns[c] for c in sensitive], rows)
    cu, decisions = _codes([columns[outcome]], rows)
    shape = (len(contexts), len(groups), len(decisions))
    flat, size = (cx * shape[1] + ca) * shape[2] + cu, int(np.prod(shape))
    counts, squares = np.bincount(flat, minlength=size), None
    if n is not None:  # exact integer sums (a float bincount would round above 2**53)
        counts = np.zeros(size, dtype=np.int64)
        np.add.at(counts, flat, n)
    if sample_weight is not None:
        w = _numbers(columns[sample_weight], sample_weight, _row_of(columns, keys)).to_numpy(dtype=np.float64)
        counts, squares = (np.bincount(flat, weights=v, minlength=size).reshape(shape) for v in (w, w * w))
    return CountTable(
        counts.reshape(shape),
        contexts,
        groups,
        decisions,
        tuple(context),
        tuple(sensitive),
        outcome,
        weight_column=sample_weight,
        squares=squares,
        missing=tuple(dropped),
        unknown_outcomes=unknown if dropped else (),
    )


def _unknown_outcomes(
    columns: dict[str, Any],
    missing: dict[str, npt.NDArray[np.bool_]],
    sensitive: list[str],
    outcome: str,
    n: Codes | None,
    sample_weight: str | None,
) -> tuple[tuple[str, tuple[tuple[Hashable, float], ...]], ...]:
    """Per sensitive column (and their intersection), the outcomes of the records of unknown category there and
    their number (weight), the records with a known outcome (and weight) only."""
    known = ~missing[outcome] & (~missing[sample_weight] if sample_weight else True)
    if sample_weight:
        column = np.asarray(columns[sample_weight])[known]
        each = _numbers(column, sample_weight, lambda i: "a record").to_numpy(dtype=np.float64)
    else:
        each = np.ones(int(known.sum())) if n is None else np.asarray(n)[known]
    types = [(c, missing[c]) for c in sensitive]
    if len(sensitive) > 1:
        types.append((" x ".join(sensitive), np.logical_or.reduce([missing[c] for c in sensitive])))
    values = np.asarray(columns[outcome])[known]
    out = []
    for name, mask in types:
        where = np.asarray(mask)[known]
        if not where.any():
            continue
        by_value: dict[Hashable, float] = {}
        for v, x in zip(values[where].tolist(), each[where].tolist(), strict=True):
            by_value[v] = by_value.get(v, 0.0) + float(x)
        out.append((name, tuple(by_value.items())))
    return tuple(out)


def _numbers(values: Any, name: str, row: Callable[[int], str]) -> pd.Series:
    """A column of counts or weights as numbers, whatever their notation (``1``, ``"1.0"``, ``"1e5"``, ``"2.50"``):
    each finite and non-negative, else one line naming the column, the data row (``row(i)``) and the value."""
    import pandas as pd

    column = pd.Series(values)
    flags = pd.api.types.is_bool_dtype(column) or (
        column.dtype == object and any(isinstance(v, (bool, np.bool_)) for v in column)
    )
    numbers = pd.to_numeric(column, errors="coerce") if not flags else pd.Series(np.full(len(column), np.nan))
    w = numbers.to_numpy(dtype=np.float64, na_value=np.nan)
    bad = ~np.isfinite(w) | (w < 0)
    if bad.any():
        i = int(np.argmax(bad))
        value = column.iloc[i]
        value = float("nan") if pd.isna(value) else value.item() if isinstance(value, np.generic) else value
        raise InputError(f"column {echo(name)}", f"must hold finite non-negative numbers; {row(i)} is not", value)
    return numbers


def _row_of(columns: dict[str, Any], labels: list[str]) -> Callable[[int], str]:
    """How an error names data row i: its number and its labels."""
    return lambda i: f"data row {i + 1} ({', '.join(f'{c}={echo(str(columns[c][i]))}' for c in labels)})"


def count_records(
    data: pd.DataFrame,
    *,
    sensitive: Sequence[str],
    outcome: str,
    context: Sequence[str] = (),
    dropna: bool = False,
    weights: str | None = None,
    mixed_outcome: bool = False,
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
    weights : str, optional
        Column of sample (survey) weights, finite and >= 0: each record
        counts its weight (``counts`` are then float64 sums of weights, with
        the sums of squared weights in ``squares`` for intervals).
    mixed_outcome : bool
        Count an outcome column that mixes numbers and text (``1``, ``"0"``,
        ``"yes"``) as it is, each text value an outcome of its own; by
        default it is an error. Mixed means: among the non-missing values,
        some are numbers (numbers, booleans, text that reads as a finite
        number or as ``true``/``false``) and some are other text.

    Returns
    -------
    CountTable

    Raises
    ------
    InputError
        On an unknown column, missing values (naming the column and count)
        when ``dropna`` is False, weights that are not finite numbers >= 0,
        or no records; a control character (Unicode category Cc, the tab and
        line breaks included) in a value of a key column, or an outcome column
        that mixes numbers and text (without ``mixed_outcome``): naming the
        column, the first data rows (counted from 1 by position) and the
        value (:mod:`fairaudit.data.key_values`).

    See Also
    --------
    count_file : the same counts of a file (Parquet or CSV), counted out of core by DuckDB.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"race": ["a", "a", "b", "b", "b"], "hired": [1, 0, 1, 1, 0]})
    >>> t = count_records(df, sensitive=["race"], outcome="hired")
    >>> t.counts.tolist(), t.groups, t.decisions
    ([[[1, 1], [1, 2]]], ('a', 'b'), (0, 1))
    >>> df["w"] = [2.0, 1.0, 0.5, 0.5, 1.0]
    >>> count_records(df, sensitive=["race"], outcome="hired", weights="w").counts.tolist()
    [[[1.0, 2.0], [1.0, 1.0]]]
    """
    sensitive, outcome, context = roles(sensitive, outcome, context)
    check_roles(data.columns, sensitive, outcome, context)
    if weights is not None:
        columns([weights], "weights", data.columns)
    used = list(dict.fromkeys(context + sensitive + [outcome] + ([weights] if weights else [])))
    columns_ = {c: data[c] for c in used}
    missing = {c: column.isna().to_numpy() for c, column in columns_.items()}
    return tally(
        columns_, missing, sensitive, outcome, context, dropna, sample_weight=weights, mixed_outcome=mixed_outcome
    )


def count_table(
    data: pd.DataFrame,
    *,
    sensitive: Sequence[str],
    outcome: str,
    context: Sequence[str] = (),
    count: str = "count",
    contexts: Sequence[Hashable] | None = None,
    groups: Sequence[Hashable] | None = None,
    decisions: Sequence[Hashable] | None = None,
    dropna: bool = False,
    mixed_outcome: bool = False,
) -> CountTable:
    """A CountTable from an aggregated table: one row per (context, group, outcome) with a count.

    Such a table is what ``SELECT ctx, grp, decision, COUNT(*) AS n FROM
    records GROUP BY ctx, grp, decision`` returns in any engine
    (docs/scale.md).

    Parameters
    ----------
    data : pandas.DataFrame
        Columns for context(s), sensitive attribute(s), outcome and ``count``.
    sensitive, outcome, context, count : str or sequence of str
        The columns, as in :func:`count_records`; ``count`` holds the number
        of records of each row (or, for a spec's model table, a probability).
    contexts, groups, decisions : sequence, optional
        Expected labels in their order; the data's values are matched to them
        by their text (``str``), and a value not among them is an error that
        names the column and the value. Default: the sorted values found, as
        :func:`count_records` sorts them.
    dropna : bool
        Drop rows with a missing label (a ``NULL`` group of ``GROUP BY``) in a
        column whose labels are not given, instead of failing.
    mixed_outcome : bool
        Accept an outcome column that mixes numbers and text, as in
        :func:`count_records` (never refused when ``decisions`` are given:
        each value is then matched to one of them).

    Returns
    -------
    CountTable
        ``counts`` has shape (n_contexts, n_groups, n_decisions); int64 when
        the count column is of an integer type, else float64.

    Raises
    ------
    InputError
        On unknown columns, unknown labels, negative, infinite or non-numeric counts,
        a (context, group, outcome) given twice, or missing labels when
        ``dropna`` is False: ``column 'x': has N missing values`` where N is
        the sum of the counts of the rows with no label, the number of records
        :func:`count_records` would report; a control character in a key
        value, or an outcome that mixes numbers and text, as in
        :func:`count_records` (the data rows are the table's rows).

    Examples
    --------
    >>> import pandas as pd
    >>> agg = pd.DataFrame({"race": ["a", "a", "b", "b"], "hired": [0, 1, 0, 1], "n": [1, 1, 1, 2]})
    >>> t = count_table(agg, sensitive="race", outcome="hired", count="n")
    >>> t.counts.tolist(), t.groups, t.decisions
    ([[[1, 1], [1, 2]]], ('a', 'b'), (0, 1))
    """
    import pandas as pd

    sensitive = [sensitive] if isinstance(sensitive, str) else list(sensitive)
    context = [context] if isinstance(context, str) else list(context)
    columns(sensitive + [outcome] + context + [count], "table", data.columns)
    keys = list(dict.fromkeys(context + sensitive + [outcome]))
    values = _numbers(data[count].reset_index(drop=True), count, _row_of({c: data[c].to_numpy() for c in keys}, keys))
    integer = pd.api.types.is_integer_dtype(values.dtype)
    mixed_outcome = mixed_outcome or decisions is not None
    check_key_values(
        {c: data[c] for c in keys}, outcome, weights=values.to_numpy() if integer else None, mixed_outcome=mixed_outcome
    )
    axes = ((context, contexts, "context"), (sensitive, groups, "sensitive"), ([outcome], decisions, "decision"))
    free = [c for cols, expected, _ in axes if expected is None for c in cols]
    data, values = _drop_unlabelled(data, values, list(dict.fromkeys(free)), dropna)
    (cx, context_labels), (ca, group_labels), (cu, decision_labels) = (
        _label_codes(data, cols, expected, role) for cols, expected, role in axes
    )
    shape = (len(context_labels), len(group_labels), len(decision_labels))
    flat = (cx * shape[1] + ca) * shape[2] + cu
    dup = pd.Series(flat).duplicated()
    if dup.any():
        i = int(np.flatnonzero(dup.to_numpy())[0])
        raise InputError("count table", "lists the same (context, group, decision) twice", data.iloc[i].to_dict())
    counts = np.zeros(int(np.prod(shape)), dtype=np.int64 if integer else float)
    counts[flat] = values.to_numpy(dtype=counts.dtype)  # each cell at most once (checked above)
    return CountTable(
        counts.reshape(shape),
        context_labels,
        group_labels,
        decision_labels,
        tuple(context),
        tuple(sensitive),
        outcome,
    )


def counts_of_table(
    data: pd.DataFrame,
    *,
    sensitive: str | Sequence[str],
    outcome: str,
    context: str | Sequence[str],
    count: str,
    dropna: bool,
    mixed_outcome: bool = False,
) -> CountTable:
    """The CountTable of a count table held as records with a count column: ``count_file(count=)`` and ``audit(count=)``.

    The columns are checked by role first (an unknown column names ``sensitive``, ``outcome``, ``context`` or
    ``count``), then :func:`count_table` reads the counts with its own checks.
    """
    sensitive, outcome, context = roles(sensitive, outcome, context)
    check_roles(data.columns, sensitive, outcome, context)
    columns([count], "count", data.columns)
    return count_table(
        data,
        sensitive=sensitive,
        outcome=outcome,
        context=context,
        count=count,
        dropna=dropna,
        mixed_outcome=mixed_outcome,
    )


def _drop_unlabelled(
    data: pd.DataFrame, values: pd.Series, free: list[str], dropna: bool
) -> tuple[pd.DataFrame, pd.Series]:
    """The rows with a label in every column of ``free``; without ``dropna`` a missing label is an error.

    A row with no label stands for ``values[i]`` records with a missing value,
    so the error counts those records, as :func:`count_records` would.
    """
    isna = data[free].isna()
    if not isna.to_numpy().any():
        return data, values
    missing = isna.mul(values.to_numpy(), axis=0).sum()
    if missing.any() and not dropna:
        col = missing[missing > 0].index[0]
        raise missing_values(col, missing[col])
    keep = ~isna.any(axis=1).to_numpy()
    return data[keep], values[keep]


def _label_codes(
    data: pd.DataFrame, columns: list[str], expected: Sequence[Hashable] | None, role: str
) -> tuple[Codes, tuple]:
    """Codes of the rows' labels in ``expected`` (matched by text), or, without it, the sorted labels found."""
    if expected is None:
        return _codes([data[c] for c in columns], len(data))
    labels = tuple(expected)
    lookup = {format_label(v): i for i, v in enumerate(labels)}
    if len(columns) == 0:
        return np.zeros(len(data), dtype=np.int64), labels
    keys = data[columns].astype(str).agg(" & ".join, axis=1) if len(columns) > 1 else data[columns[0]].astype(str)
    mapped = keys.map(lookup)
    if mapped.isna().any():
        bad = keys[mapped.isna()].iloc[0]
        raise InputError(
            f"column {echo(columns[0])}" if len(columns) == 1 else f"columns {echo(columns)}",
            f"value not among the {role} values {label_list(labels)}",
            bad,
        )
    return mapped.to_numpy(dtype=np.int64), labels


def count_file(
    path: str | Path,
    *,
    sensitive: Sequence[str],
    outcome: str,
    context: Sequence[str] = (),
    dropna: bool = False,
    count: str | None = None,
    csv: CsvFormat | None = None,
    weights: str | None = None,
    mixed_outcome: bool = False,
) -> CountTable:
    """Count the decision records of a file (Parquet or text) with DuckDB, out of core.

    DuckDB counts the file, in fairaudit's own in-memory database (as many threads as cores): one
    ``SELECT <used columns>, count(*) ... GROUP BY`` that reads only the used columns and gives the number of records
    of each distinct (context, group, decision), null keys included. Peak memory is bounded by that count table and DuckDB's buffers, not
    by the number of records. numpy counts the small grouped table (pandas is not imported), with the checks, missing
    values and errors of :func:`count_records`; ``count_records(read_records(path), ...)`` gives the same table.

    **Labels** are the values DuckDB reads, sorted (numbers numerically, text by code point, tuples of several columns
    lexicographically); how a Parquet column's types and a text file's fields become labels, and which fields are
    missing, is in the module docstring of :mod:`fairaudit.data.record_files`.

    Nothing but DuckDB reads the file: text compressed with bzip2, xz or zip is refused (decompress it first), a file
    DuckDB cannot parse (a byte that is not UTF-8, an unclosed quote) names the line and DuckDB's reason, and running
    out of memory names DuckDB's ``memory_limit``, which the environment variable ``FAIRAUDIT_DUCKDB_MEMORY_LIMIT``
    (``8GB``, ``500MB``, ``50%``) sets (unset: 80% of the machine's memory).

    Parameters
    ----------
    path : str or Path
        A ``.parquet``/``.pq`` file or folder of Parquet files, or a text file: ``.csv``, ``.tsv``, ``.txt`` or
        ``.data``, optionally compressed (``.gz``, ``.zst``).
    sensitive, outcome, context, dropna
        As in :func:`count_records`. Missing values are counted exactly from the grouped table.
    count : str, optional
        The file is already a count table, one row per (context, group, decision) with its number of records in column
        ``count``, as made by any engine (SQL ``GROUP BY``, Spark, DuckDB); it is read whole
        (:func:`~fairaudit.data.record_files.read_records`) and turned into counts by :func:`count_table`.
    csv : CsvFormat, optional
        How a text file is read (:class:`CsvFormat`); an error for Parquet.
    weights : str, optional
        Column of sample weights (as in :func:`count_records`); the file is then read whole
        (:func:`~fairaudit.data.record_files.read_records`).
    mixed_outcome : bool
        Accept an outcome column that mixes numbers and text (as in :func:`count_records`).

    Returns
    -------
    CountTable
        ``counts`` of shape (n_contexts, n_groups, n_decisions), int64.

    Raises
    ------
    InputError
        A missing or unreadable file (DuckDB's reason, in one line); an unknown column (naming ``sensitive``,
        ``outcome``, ``context``, ``count`` or ``weights`` and listing the file's columns); a used column that a text
        file's header names twice with different values; ``csv`` options for a Parquet file, or ``csv.names`` not one
        per field; missing values without ``dropna``; no records; the errors of :func:`count_table` for a count table; a
        control character in a key value, or an outcome that mixes numbers and text, as in :func:`count_records`, naming
        the data rows of the file (from 1 after the header; in a folder of Parquet files, the row of the file named).

    Examples
    --------
    >>> import os, tempfile
    >>> import pandas as pd
    >>> df = pd.DataFrame({"race": ["a", "a", "b", "b", "b"], "hired": [1, 0, 1, 1, 0]})
    >>> folder = tempfile.mkdtemp()
    >>> df.to_parquet(os.path.join(folder, "records.parquet"))
    >>> t = count_file(os.path.join(folder, "records.parquet"), sensitive=["race"], outcome="hired")
    >>> t.counts.tolist(), t.groups, t.decisions
    ([[[1, 1], [1, 2]]], ('a', 'b'), (0, 1))
    >>> df.to_csv(os.path.join(folder, "records.csv"), index=False)
    >>> count_file(os.path.join(folder, "records.csv"), sensitive=["race"], outcome="hired").counts.tolist()
    [[[1, 1], [1, 2]]]
    """
    sensitive, outcome, context = roles(sensitive, outcome, context)
    if count is not None and weights is not None:
        raise InputError("weights", "a count table (`count`) is counted already: give its counts, not weights")
    records = source(path, csv)
    check_roles(records.names, sensitive, outcome, context)
    used = list(dict.fromkeys(context + sensitive + [outcome]))
    if weights is None and count is None:  # out of core: DuckDB's GROUP BY of the used columns, tallied by numpy
        g = records.group_by(used)
        kw: dict[str, Any] = {"n": g.weights, "locate": g.locate, "mixed_outcome": mixed_outcome}
        return tally(g.values, g.missing, sensitive, outcome, context, dropna, **kw)
    # read whole and counted: weighted records (`weights`), or a count table (`count`)
    extra, role = (weights, "weights") if weights is not None else (count, "count")
    assert extra is not None  # (one of them is given)
    columns([extra], role, records.names)
    frame = records.read(list(dict.fromkeys([*used, extra])))
    options: dict[str, Any] = {
        "sensitive": sensitive,
        "outcome": outcome,
        "context": context,
        "dropna": dropna,
        "mixed_outcome": mixed_outcome,
    }
    if weights is not None:
        return count_records(frame, weights=weights, **options)
    return counts_of_table(frame, count=extra, **options)
