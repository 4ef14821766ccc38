"""Counting decision records held in a Spark DataFrame.

Counting is the only step of an audit whose cost grows with the number of
records. :func:`count_spark` runs it in Spark (one ``groupBy(...).count()``)
and brings back to the driver only the count table: at most
n_contexts × n_groups × n_decisions rows. Everything after (laws, metrics,
intervals, certificates) works on that table as usual.

pyspark is imported inside :func:`count_spark` only, so fairaudit imports
without it; install it with ``pip install 'fairness-certify[spark]'``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from fairaudit.base.errors import InputError, echo, optional_modules
from fairaudit.data.columns import check_roles, roles
from fairaudit.data.counts import CountTable, tally
from fairaudit.data.key_values import ROWS_SHOWN, Locate

if TYPE_CHECKING:
    from pyspark.sql import DataFrame

__all__ = ["count_spark"]


def count_spark(
    frame: DataFrame,
    *,
    sensitive: Sequence[str],
    outcome: str,
    context: Sequence[str] = (),
    dropna: bool = False,
    mixed_outcome: bool = False,
) -> CountTable:
    """Count the decision records of a Spark DataFrame per (context, group, outcome).

    The group-by runs in Spark; only its result, one row per (context, group,
    outcome) that occurs, comes back to the driver (through ``toPandas``).
    The result is the :class:`~fairaudit.data.counts.CountTable` that
    :func:`~fairaudit.data.counts.count_records` gives on ``frame.toPandas()``:
    the same counts, the same labels in the same order and of the same
    Python types, the same errors.

    Parameters
    ----------
    frame : pyspark.sql.DataFrame
        One row per decision (or per candidate); a classic or a Spark Connect
        DataFrame. Only the used columns are read, in one Spark job.
    sensitive : sequence of str
        Column(s) of the sensitive attribute A; several give intersectional
        groups with tuple labels.
    outcome : str
        Column of the decision U (all its values are kept).
    context : sequence of str, optional
        Column(s) of the context X; none gives one context ``"all"``.
    dropna : bool
        Drop the records with a missing value in any used column instead of
        failing. Missing means a Spark null or a floating-point NaN (Spark
        keeps NaN apart from null; pandas treats both as missing).
    mixed_outcome : bool
        Accept an outcome column that mixes numbers and text (as in
        :func:`~fairaudit.data.counts.count_records`).

    Returns
    -------
    CountTable
        ``counts`` of shape (n_contexts, n_groups, n_decisions), int64,
        indexed [x, a, u]; labels sorted as ``pandas.factorize(sort=True)``
        sorts them: Python scalars for one column, tuples for several. As in
        pandas, an integer column that holds nulls comes back as floats
        (labels ``1.0``, ``2.0``, ... after ``dropna``).

    Raises
    ------
    InputError
        If pyspark is not installed; if ``frame`` is not a Spark DataFrame;
        on an unknown column (naming ``sensitive``, ``outcome`` or
        ``context`` and listing the frame's columns), a column name the
        frame holds twice, or a column that is not of a scalar type (array,
        map, struct, binary); on missing values when ``dropna`` is False (the
        first used column with any, and their exact number); or when no
        record is left to count; a control character in a key value, or an
        outcome that mixes numbers and text, as in
        :func:`~fairaudit.data.counts.count_records`: the data rows are those of
        the DataFrame's own order (``monotonically_increasing_id``), found by
        a second Spark job only then.

    Notes
    -----
    The Spark side is equivalent to the SQL query
    ``SELECT x..., a..., u, COUNT(*) FROM records GROUP BY x..., a..., u``;
    the missing values are counted from that result (the null and NaN
    groups), so the records are scanned once. See docs/spark.md.

    Examples
    --------
    Not run here (it needs a Spark session)::

        from pyspark.sql import SparkSession
        from fairaudit.data.spark import count_spark
        spark = SparkSession.builder.master("local[2]").getOrCreate()
        records = spark.read.parquet("decisions.parquet")
        table = count_spark(records, sensitive=["race"], outcome="hired", context=["job"])
        table.law(), table.population()
    """
    optional_modules(
        "pyspark", "is needed to count a Spark DataFrame: pip install 'fairness-certify[spark]'", "pyspark.sql"
    )
    if not all(hasattr(frame, name) for name in ("groupBy", "toDF", "toPandas", "schema", "columns")):
        raise InputError("frame", "must be a Spark DataFrame (pyspark.sql.DataFrame)", type(frame).__name__)
    sensitive, outcome, context = roles(sensitive, outcome, context)
    names = list(frame.columns)
    check_roles(names, sensitive, outcome, context)
    used = list(dict.fromkeys(context + sensitive + [outcome]))
    _check_scalar_columns(frame, names, used)
    # Rename every column by position: the group-by then never trips over
    # dots, backticks or names that differ only in case.
    keys = [f"c{names.index(col)}" for col in used]
    renamed = frame.toDF(*(f"c{i}" for i in range(len(names))))
    agg = renamed.groupBy(*keys).count().toPandas()
    n = agg.pop("count").to_numpy(dtype=np.int64)  # (the keys are c0, c1, ...: no clash with Spark's "count")
    agg.columns = pd.Index(used)
    values = {c: agg[c].reset_index(drop=True) for c in used}
    missing = {c: values[c].isna().to_numpy() for c in used}
    locate = _spark_locate(renamed, names, agg)
    return tally(values, missing, sensitive, outcome, context, dropna, n=n, locate=locate, mixed_outcome=mixed_outcome)


def _spark_locate(frame: DataFrame, names: list[str], agg: pd.DataFrame) -> Locate:
    """The :data:`~fairaudit.data.key_values.Locate` of a Spark DataFrame (its columns renamed ``c0``, ``c1``, ...
    by position; ``names`` their own names): its rows in its own order, from 1.

    Each row gets ``monotonically_increasing_id`` (increasing in the
    DataFrame's order); the first rows holding the refused values are taken
    by that id, and the number of a row is 1 + the rows of smaller id.
    """

    def locate(column: str, mask: np.ndarray) -> list[tuple[str, object]]:
        from pyspark.sql import functions as F

        wanted = sorted({str(v) for v in agg[column].to_numpy(dtype=object)[mask]})
        c = f"c{names.index(column)}"
        rows = frame.select(F.col(c).alias("v"), F.monotonically_increasing_id().alias("i"))
        hits = rows.filter(F.col("v").cast("string").isin(wanted)).orderBy("i").limit(ROWS_SHOWN).collect()
        return [(str(rows.filter(F.col("i") < h["i"]).count() + 1), h["v"]) for h in hits]

    return locate


def _check_scalar_columns(frame: DataFrame, names: list[str], used: list[str]) -> None:
    """Each used column is named once in ``frame`` (whose columns are ``names``) and holds scalars."""
    from pyspark.sql import types

    fields = frame.schema.fields
    for col in used:
        if names.count(col) > 1:
            raise InputError(
                f"column {echo(col)}", f"is ambiguous: the frame has {names.count(col)} columns of that name"
            )
        kind = fields[names.index(col)].dataType
        if not isinstance(kind, (types.AtomicType, types.NullType)) or isinstance(kind, types.BinaryType):
            raise InputError(
                f"column {echo(col)}",
                "must hold scalar values (string, number, boolean, date or time)",
                kind.simpleString(),
            )
