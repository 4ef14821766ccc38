"""Audit decision records: counts, the empirical law, every exact metric, intervals.

:func:`audit` is the Python side of ``fairaudit audit``. U is the outcome
column with all its values; the utility g (``positive`` or ``utility``)
defines L and L̄, while L_dp, L_eo and the sups over g are about U's whole
distribution (docs/design.md "Command-line contract").
"""

from __future__ import annotations

import sys
from collections.abc import Hashable, Sequence
from contextlib import suppress
from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING, Any, SupportsFloat, SupportsIndex, TypeAlias, TypeGuard, cast

import numpy as np

from fairaudit.base.errors import InputError, cut, echo
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.data.counts import CountTable, count_records, counts_of_table
from fairaudit.data.frames import ArrayLike, records_from_arrays
from fairaudit.laws.tables import Law, Population
from fairaudit.laws.utilities import Utility, from_table, indicator
from fairaudit.laws.utility_expression import evaluate_utility_expression
from fairaudit.metrics.gaps import UtilityGaps, utility_gaps
from fairaudit.metrics.observed import Observed, observe  # (what fairaudit.certify re-exports: no spec, no pydantic)
from fairaudit.statistics.intervals import (
    METRIC_ATTRIBUTES,
    FairnessIntervals,
    IntervalOptions,
    fairness_intervals,
    interval_options,
)
from fairaudit.statistics.record_options import RecordOptions, as_record_options
from fairaudit.statistics.small_cells import LeftOut, SmallCell, by_context_rows, leave_out_small, small_cell

if TYPE_CHECKING:
    import pandas as pd
    import pyspark.sql

__all__ = [
    # auditing records
    "Audit",
    "audit",
    # the utility of an audit
    "utility_from_expression",
]


_Data: TypeAlias = "pd.DataFrame | CountTable | pyspark.sql.DataFrame | None"
"""What :func:`audit` counts: records (pandas or Spark), a table of counts, or none (records given as arrays)."""
_Roles: TypeAlias = "tuple[str | Sequence[str] | None, str | None, str | Sequence[str] | None]"
"""The (sensitive, outcome, context) columns, as given."""

_FRAME_ORDER = ("local", "global", "demographic_parity", "equalized_odds", "sup_local", "sup_global")
"""The rows of :meth:`Audit.to_frame`."""


@dataclass(frozen=True, eq=False)
class Audit:
    """The result of :func:`audit`; repeats its inputs.

    Attributes
    ----------
    table : CountTable
        Counts, shape (n_contexts, n_groups, n_decisions), and the columns.
    law : Law
        The empirical law P(U | X, A) of the metrics, shape (n_contexts,
        n_groups, n_decisions) (a property: :attr:`law`).
    utility : Utility
    observed : Observed
        Every exact metric of the empirical law under the empirical population.
    intervals : FairnessIntervals or None
        Simultaneous intervals for every metric when ``intervals`` was given
        (:func:`fairaudit.statistics.intervals.fairness_intervals`).
    confidence : float or None
        Their level 1 − α (None without intervals).
    """

    table: CountTable
    utility: Utility
    observed: Observed
    intervals: FairnessIntervals | None
    confidence: float | None
    min_count: int | None = None
    left_out: tuple[LeftOut, ...] = ()

    @cached_property
    def small_cell(self) -> SmallCell | None:
        """The cell that drives L when it holds fewer records than the planner needs to support it, else None.

        For a 0/1 utility: the cell of L's pair with the smaller E[g], in L's context, when it has fewer
        records than :func:`fairaudit.plan` needs to certify L ≤ log 2 for a fair model at the context's rate
        (the planner runs only when L is infinite or that cell holds fewer than 1000 records).
        """
        g = self.utility.values
        return small_cell(self.observed.local_fairness, self.table, bool(np.all((g == 0) | (g == 1))), self.confidence)

    @property
    def by_context(self) -> pd.DataFrame:
        """L within each context: one row per context (``n``, ``value`` in nats, ``ratio``, ``group``, ``other_group``).

        The pair: the groups with the largest and the smallest E[g | x, a] in the context.
        """
        import pandas as pd

        rows = by_context_rows(self.observed.local_fairness, self.table)
        name = " x ".join(self.table.context_columns) or "context"
        return pd.DataFrame(rows).set_index("context").rename_axis(name)

    @property
    def law(self) -> Law:
        """The empirical law P(U | X, A) that every metric of the audit is computed on.

        ``law.probabilities`` has shape (n_contexts, n_groups, n_decisions),
        in the order of the axes [x, a, u] (docs/design.md "Array layout"),
        labelled by ``law.contexts``, ``law.groups`` and ``law.decisions``
        (those of :attr:`table`); each row sums to 1 over the decisions. A
        (context, group) cell without records is a row of NaN, listed in
        ``law.empty_cells`` (and in the report's ``excluded``). With
        ``min_count``, the cells left out have no records here either.

        Examples
        --------
        >>> import pandas as pd
        >>> df = pd.DataFrame({"race": list("aaaabbbb"), "hired": [1, 1, 1, 0, 1, 0, 0, 0]})
        >>> law = audit(df, sensitive=["race"], outcome="hired").law
        >>> law.probabilities.shape, law.groups, law.decisions
        ((1, 2, 2), ('a', 'b'), (0, 1))
        >>> law.probabilities[0].tolist()                # P(hired = 0 | a), P(hired = 1 | a); then b
        [[0.25, 0.75], [0.75, 0.25]]
        """
        return self.observed.law

    @property
    def population(self) -> Population:
        """P(X, A) of the metrics: the records' own, n(x, a) / n (``source="records"``)."""
        population = self.observed.global_fairness.population
        assert population is not None  # (audit passes the records' own)
        return population

    @property
    def gaps_on_g(self) -> UtilityGaps:
        """Demographic parity and equalized odds of g: differences of E[g] between groups, as fairlearn means them.

        ``observed.demographic_parity`` and ``observed.equalized_odds`` are
        total-variation gaps of U's whole distribution; these are the
        differences of E[g | a] (pooled) and of E[g | x, a] (within a
        context), the selection-rate differences for a 0/1 g
        (:func:`fairaudit.metrics.gaps.utility_gaps`).
        """
        return utility_gaps(self.observed.local_fairness, self.observed.global_fairness)

    @property
    def by_group(self) -> pd.DataFrame:
        """One row per (context, group): what fairlearn's ``MetricFrame.by_group`` shows, and more.

        Index (context, group), named after their columns (``context`` when
        there is none). Columns: ``n`` (records, or the sum of their weights),
        ``expected_utility`` E[g | x, a], ``rate`` (the same for a 0/1
        utility, the selection rate; NaN for another utility),
        ``ratio_to_best`` E[g | x, a] / max over groups of E[g | x, a'] in
        the context (the impact ratio), and ``lower``, ``upper``: the
        simultaneous interval on E[g | x, a] (NaN without ``confidence``).
        A cell without records has n = 0 and NaN elsewhere.

        Examples
        --------
        >>> r = audit(y_pred=[1, 1, 1, 0, 1, 0, 0, 0], sensitive_features=list("aaaabbbb"))
        >>> r.by_group[["n", "rate", "ratio_to_best"]].to_dict("index")
        {('all', 'a'): {'n': 4, 'rate': 0.75, 'ratio_to_best': 1.0}, ('all', 'b'): {'n': 4, 'rate': 0.25, 'ratio_to_best': 0.3333333333333333}}
        """
        import pandas as pd

        t, e = self.table, self.observed.local_fairness.expected_utility
        best = np.fmax.reduce(e, axis=1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(best > 0, e / best, np.where(best == 0, 1.0, np.nan))
        g = self.utility.values
        binary = bool(np.all((g == 0) | (g == 1)))
        iv = self.intervals
        nan = np.full(e.shape, np.nan)
        columns = {
            "n": t.cell_counts,
            "expected_utility": e,
            "rate": e if binary else nan,
            "ratio_to_best": ratio,
            "lower": nan if iv is None else iv.cell_lower,
            "upper": nan if iv is None else iv.cell_upper,
        }
        index = pd.MultiIndex.from_product(
            [list(t.contexts), list(t.groups)],
            names=[" x ".join(t.context_columns) or "context", " x ".join(t.sensitive_columns)],
        )
        return pd.DataFrame({k: np.asarray(v).reshape(-1) for k, v in columns.items()}, index=index)

    def to_frame(self) -> pd.DataFrame:
        """Every metric as one row: ``value`` (nats for L, L̄ and the sups; a probability for the gaps),
        ``ratio``, ``context``, ``group``, ``other_group`` and the interval ``lower``, ``upper`` (NaN without one).

        Index: ``local``, ``global``, ``demographic_parity``, ``equalized_odds``, ``sup_local``, ``sup_global``.
        """
        import pandas as pd

        o, iv = self.observed, self.intervals
        rows = {}
        for name in _FRAME_ORDER:
            metric = getattr(o, METRIC_ATTRIBUTES[name])
            interval = None if iv is None else iv.intervals()[name]
            rows[name] = {
                "value": metric.value,
                "ratio": getattr(metric, "ratio", np.nan),
                "context": getattr(metric, "context", None),
                "group": metric.group,
                "other_group": metric.other_group,
                "lower": np.nan if interval is None else interval.lower,
                "upper": np.nan if interval is None else interval.upper,
            }
        return pd.DataFrame.from_dict(rows, orient="index")

    def _outcome_values(self) -> list[dict[str, object]]:
        """Each outcome value with its records (with weights, their total weight) and g(u) (None where g
        depends on the context or group too)."""
        t, g = self.table, self.utility.values
        count = int if t.whole else float
        per_value = g.ndim == 1
        return [
            {"label": label(d), "n": count(n), "g": number(g[k]) if per_value else None}
            for k, (d, n) in enumerate(zip(t.decisions, t.counts.sum(axis=(0, 1))))
        ]

    def to_dict(self) -> Report:
        """The report dictionary (the JSON of ``fairaudit audit``; its contract is in docs/design.md).

        Counts per group, per context and per cell (with E[g | x, a] and, with
        ``confidence``, its interval), the population, then every metric as in
        :meth:`~fairaudit.metrics.observed.Observed.to_dict`.
        """
        t = self.table
        e = self.observed.local_fairness.expected_utility
        cells = t.cell_counts
        iv = self.intervals
        count = int if t.whole else float  # weighted or scaled: sums of weights
        out: Report = {
            "n": t.n,
            "sensitive": list(t.sensitive_columns),
            "outcome": t.outcome_column,
            "context_columns": list(t.context_columns),
            "weight_column": t.weight_column,
            "utility": {
                "name": self.utility.name,
                "gamma": number(self.utility.gamma),
                "lower": number(self.utility.lower),
            },
            "groups": [{"label": label(g), "n": count(n)} for g, n in zip(t.groups, t.group_counts)],
            "contexts": [{"label": label(c), "n": count(n)} for c, n in zip(t.contexts, t.context_counts)],
            "cells": [
                {
                    "context": label(c),
                    "group": label(g),
                    "n": count(cells[i, j]),
                    "expected_utility": number(e[i, j]),
                    **({} if iv is None else {"interval": [number(iv.cell_lower[i, j]), number(iv.cell_upper[i, j])]}),
                }
                for i, c in enumerate(t.contexts)
                for j, g in enumerate(t.groups)
            ],
            "decisions": [label(d) for d in t.decisions],
            "outcome_values": self._outcome_values(),
            "population": self.population.to_dict(),
            "confidence": number(self.confidence),
            "interval_method": iv.method if iv is not None else None,
            "min_count": self.min_count,
            "left_out": [c.to_dict() for c in self.left_out],
            "small_cell": None if self.small_cell is None else self.small_cell.to_dict(),
        }
        out.update(self.observed.to_dict(iv))
        for cell in self.left_out:  # the law has no records there because they were left out: say so
            empty = f"cell (context {format_label(cell.context)!r}, group {format_label(cell.group)!r}): no records"
            said = f"{cell}, fewer than min_count {self.min_count}: left out"  # (LeftOut reads "cell (...): N records")
            out["excluded"] = [said if e == empty else e for e in out["excluded"]]
        return out


def utility_from_expression(expression: str, decisions: Sequence[Hashable]) -> Utility:
    """g(u) from an arithmetic or comparison expression in ``u`` (for example ``"u >= 5"``).

    ``u`` is each decision value in turn: a number when every decision is a
    number, else text. The expression language is a small allowlist (see
    :func:`fairaudit.laws.utility_expression.evaluate_utility_expression`): ``u``, numbers,
    ``+ - * / // % **``, comparisons (chained too), ``and``/``or``/``not``,
    ``u in [1, 2]``, ``a if c else b``, text literals compared with a text
    ``u`` (``u == "high"``) and the functions ``min``, ``max``, ``abs``,
    ``log`` and ``exp``. Nothing else (attributes, subscripts, other names or
    calls) is accepted, and the expression is checked before anything is
    evaluated. At most 2000 characters and 60 levels of nesting; a power or
    ``exp`` too large for a float is refused at once. Booleans become 0/1.

    Raises
    ------
    InputError
        Field ``utility``: if the expression uses anything outside the
        language (the message names it), is empty, too long or not valid
        syntax, fails at some decision (division by zero, log of a
        non-positive number, overflow, text in arithmetic), or does not give
        one finite non-negative number per decision.

    Examples
    --------
    >>> utility_from_expression("u >= 5", [1, 4, 5, 10]).values.tolist()
    [0.0, 0.0, 1.0, 1.0]
    >>> utility_from_expression("11 - u", [1, 10]).values.tolist()
    [10.0, 1.0]
    >>> utility_from_expression('u in ["high", "medium"]', ["low", "medium", "high"]).values.tolist()
    [0.0, 1.0, 1.0]
    """
    arr = evaluate_utility_expression(expression, decisions)
    if arr.shape != (len(decisions),):
        raise InputError("utility", "must give one value per outcome value", expression)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        bad = [format_label(d) for d, v in zip(decisions, arr) if not np.isfinite(v) or v < 0]
        raise InputError("utility", f"must be finite and non-negative; it is not at u = {bad[0]}", expression)
    return from_table(arr, tuple(decisions), name=expression)


def _positive_utility(positive: Hashable, decisions: tuple) -> Utility:
    for d in decisions:
        if d == positive or format_label(d) == str(positive):
            return indicator(d, decisions, name=f"1{{outcome = {format_label(d)}}}")
    with suppress(TypeError, ValueError):
        if isinstance(positive, (str, bytes, SupportsFloat, SupportsIndex)):  # what float() takes
            num = float(positive)
            for d in decisions:
                if isinstance(d, (int, float, np.number)) and float(d) == num:
                    return indicator(d, decisions, name=f"1{{outcome = {format_label(d)}}}")
    shown = ", ".join(_shown(d) for d in decisions[:20]) + (", ..." if len(decisions) > 20 else "")
    raise InputError("positive", f"is not a value of the outcome column; it has {shown}", positive)


def _shown(label: Hashable) -> str:
    """A label in a message: text quoted (its spaces seen), anything else as reports show it."""
    return echo(label) if isinstance(label, str) else cut(format_label(label))


def _is_spark_frame(data: object) -> bool:
    """A pyspark DataFrame (classic or Spark Connect), recognised without importing pyspark."""
    return any(c.__module__.startswith("pyspark.") and c.__name__ == "DataFrame" for c in type(data).__mro__)


def _is_pandas_frame(data: object) -> TypeGuard[pd.DataFrame]:
    """A pandas DataFrame, recognised without importing pandas (a DataFrame exists only once pandas is imported)."""
    pd = sys.modules.get("pandas")
    return pd is not None and isinstance(data, pd.DataFrame)


def _table(data: _Data, columns: _Roles, records: RecordOptions, mixed_outcome: bool) -> CountTable:
    """The CountTable to audit: ``data`` itself, checked against the columns given, or its records counted."""
    sensitive, outcome, context = columns
    count, weights, dropna = records.count, records.weights, records.dropna
    if data is None:
        raise InputError("data", "give the records: a DataFrame, a CountTable, or arrays (y_pred, sensitive_features)")
    if isinstance(weights, np.ndarray):
        raise InputError(
            "weights",
            "one weight per record is for records given as arrays (y_pred, sensitive_features); "
            "with `data` name its weight column",
            type(data).__name__,
        )
    if isinstance(data, CountTable):
        if count is not None:
            raise InputError("count", "is for a DataFrame of counts; a CountTable is counted already", count)
        if weights is not None and weights != data.weight_column:
            raise InputError("weights", "does not match the count table's weight column", weights)

        def names(c: str | Sequence[str] | None) -> tuple[str, ...] | None:
            return None if c is None else (c,) if isinstance(c, str) else tuple(c)

        for name, given, have in (
            ("sensitive", names(sensitive), data.sensitive_columns),
            ("outcome", names(outcome), (data.outcome_column,)),
            ("context", names(context), data.context_columns),
        ):
            if given is not None and given != have:
                raise InputError(
                    name,
                    f"does not match the count table, whose column(s) are [{', '.join(have)}]",
                    ",".join(map(str, given)),
                )
        return data
    if not (_is_spark_frame(data) or _is_pandas_frame(data)):
        raise InputError(
            "data", "must be a pandas DataFrame of records, a Spark DataFrame or a CountTable", type(data).__name__
        )
    if sensitive is None:
        raise InputError("sensitive", "name at least one column")
    if outcome is None:
        raise InputError("outcome", "name the outcome column")
    context = () if context is None else context
    common: dict[str, Any] = {
        "sensitive": sensitive,
        "outcome": outcome,
        "context": context,
        "dropna": dropna,
        "mixed_outcome": mixed_outcome,
    }
    if _is_pandas_frame(data):
        if count is not None:  # a count table: as `fairaudit audit --count` reads one
            return counts_of_table(data, count=count, **common)
        return count_records(data, weights=weights, **common)
    if weights is not None:
        raise InputError("weights", "are not supported for a Spark DataFrame yet: count it with weights in Spark")
    if count is not None:
        raise InputError("count", "is not supported for a Spark DataFrame yet: sum the counts in Spark", count)
    from fairaudit.data.spark import count_spark  # a Spark DataFrame (checked above)

    return count_spark(cast("pyspark.sql.DataFrame", data), **common)


def audit(
    data: pd.DataFrame | CountTable | pyspark.sql.DataFrame | None = None,
    *,
    sensitive: Sequence[str] | None = None,
    outcome: str | None = None,
    context: Sequence[str] | None = None,
    positive: Hashable | None = None,
    utility: str | Utility | None = None,
    intervals: IntervalOptions | None = None,
    records: RecordOptions | None = None,
    y_pred: ArrayLike | None = None,
    sensitive_features: ArrayLike | None = None,
    control_features: ArrayLike | None = None,
    y_true: ArrayLike | None = None,
) -> Audit:
    """Audit decision records: exact metrics of the empirical law, and intervals.

    Parameters
    ----------
    data : pandas.DataFrame, pyspark.sql.DataFrame or CountTable
        One row per decision (or per candidate), or the counts already made
        (:func:`~fairaudit.data.counts.count_file` streams them out of a Parquet
        file; :func:`~fairaudit.data.counts.count_table` reads a count table). A
        Spark DataFrame is counted in Spark (:func:`fairaudit.data.spark.count_spark`):
        only the count table reaches the driver.
    sensitive : sequence of str
        Sensitive column(s); several give intersectional groups. Required for
        a DataFrame; for a CountTable optional, and if given it must be the
        table's ``sensitive_columns``.
    outcome : str
        Outcome column U. Required for a DataFrame; for a CountTable
        optional, and if given it must be the table's ``outcome_column``.
    context : sequence of str, optional
        Context column(s) X; none gives a single context. For a CountTable,
        if given it must be the table's ``context_columns``.
    positive : optional
        g = 1{U = positive}. With neither ``positive`` nor ``utility`` an
        outcome with values {0, 1} (or booleans) uses positive = 1.
    utility : str or Utility, optional
        An expression in ``u`` (see :func:`utility_from_expression`) or a Utility.
        An outcome column that mixes numbers and text (``1``, ``"yes"``) is
        refused unless a ``utility`` says what each value is worth (an
        expression sees every value as text then: ``u in ["1", "yes"]``) or
        ``records`` sets ``mixed_outcome``.
    intervals : IntervalOptions, optional
        Simultaneous intervals for every metric, at the level, by the method
        and with the Bayesian settings given
        (:func:`fairaudit.statistics.intervals.fairness_intervals`; "auto" is
        Clopper–Pearson for a 0/1 utility, multinomial otherwise). None (the
        default): no intervals.
    records : RecordOptions, optional
        How the records are read and counted
        (:class:`~fairaudit.statistics.record_options.RecordOptions`): ``dropna``
        (drop records with missing values instead of failing), ``weights`` (a
        weight column of ``data``, or one weight per record with the arrays:
        weighted counts, Kish's effective sample sizes for the intervals),
        ``count`` (``data`` is a count table and this column holds each row's
        number of records), ``min_count`` (leave out the cells with fewer
        records, listed in ``left_out``) and ``mixed_outcome`` (an outcome
        column that mixes numbers and text, each value an outcome of its own).
        None (the default): ``RecordOptions()``, none of them.
    y_pred, sensitive_features, control_features : array_like, optional
        Records as arrays instead of ``data``, named as in fairlearn's
        ``MetricFrame``: ``y_pred`` the decisions (n,) (the outcome U), ``sensitive_features`` the
        sensitive attribute(s) (n,) or (n, k), ``control_features`` the
        context(s). Each may be a list, a
        numpy array, a pandas Series or DataFrame (its names become the
        columns') or a dict of columns; unnamed columns are ``y_pred``,
        ``sensitive_feature_0``, ... and ``control_feature_0``, .... Their
        weights (fairlearn's ``sample_weight``) are
        ``records=RecordOptions(weights=w)``, one per record.
    y_true : array_like, optional
        With the arrays, the true labels (n,), fairlearn's ``y_true``: a
        context (column ``y_true``, ahead of the control features), so that L
        compares the groups within each true label (equalized odds: the
        demographic-parity gap within a label is fairlearn's
        ``equalized_odds_difference`` part for that label).

    Raises
    ------
    InputError
        Unknown columns, missing values, a control character in a key value
        or an outcome column that mixes numbers and text (naming the column,
        the data rows and the value; see
        :func:`~fairaudit.data.counts.count_records`), columns that are not a CountTable's
        (naming ``sensitive``, ``outcome`` or ``context``), data that is
        neither a DataFrame nor a CountTable, both ``positive`` and ``utility``,
        an outcome value that is not there, a non-binary outcome with no g,
        ``intervals`` that is not an :class:`~fairaudit.statistics.intervals.IntervalOptions`,
        ``records`` that is not a :class:`~fairaudit.statistics.record_options.RecordOptions`;
        arrays given with ``data``, or of lengths other than ``y_pred``'s
        (naming the parameter, ``weights`` for the weights); ``weights`` as an
        array with ``data``, or as a column name with the arrays; a ``count``
        column that is unknown, holds a negative, infinite or non-numeric
        value, lists a (context, group, outcome) twice, or comes with arrays,
        a CountTable or a Spark DataFrame.

    Examples
    --------
    In docs/audit.md: the same from a CountTable, a count table (``count``), arrays, and with intervals.

    >>> import pandas as pd
    >>> df = pd.DataFrame({"race": list("aaaabbbb"), "hired": [1, 1, 1, 0, 1, 0, 0, 0]})
    >>> r = audit(df, sensitive=["race"], outcome="hired")
    >>> round(r.observed.global_fairness.ratio, 12), r.observed.global_fairness.group
    (3.0, 'a')

    Weights and small cells go in ``records``:

    >>> df["w"] = [1.0, 1.0, 1.0, 1.0, 3.0, 1.0, 1.0, 1.0]
    >>> r = audit(df, sensitive=["race"], outcome="hired", records=RecordOptions(weights="w", min_count=2))
    >>> r.by_group["rate"].tolist(), r.min_count
    ([0.75, 0.5], 2)
    """
    interval_options(intervals)
    options = as_record_options(records)
    arrays = (y_pred, sensitive_features, control_features, y_true)
    data, columns, options = _records(data, (sensitive, outcome, context), options, arrays)
    table = _table(data, columns, options, options.mixed_outcome or utility is not None)
    return _audited(table, audit_utility(table, positive, utility), intervals, options.min_count)


def _records(
    data: _Data, columns: _Roles, records: RecordOptions, arrays: tuple[ArrayLike | None, ...]
) -> tuple[_Data, _Roles, RecordOptions]:
    """``data``, its (sensitive, outcome, context) columns and the record options; or the records of the arrays,
    theirs, and the options with the weights as the records' weight column."""
    y_pred, sensitive_features, control_features, y_true = arrays
    if y_pred is not None or sensitive_features is not None:
        if data is not None:
            raise InputError("data", "give records as data or as arrays (y_pred, sensitive_features), not both")
        if records.count is not None:
            raise InputError(
                "count", "is the count column of a DataFrame `data`; arrays are one record each", records.count
            )
        if isinstance(records.weights, str):
            raise InputError(
                "weights",
                "names a column of a DataFrame `data`; with arrays give one weight per record",
                records.weights,
            )
        frame, (sensitive, outcome, context, weight) = records_from_arrays(
            y_pred, sensitive_features, control_features, records.weights, y_true
        )
        return frame, (sensitive, outcome, context), replace(records, weights=weight)
    for name, given in (("control_features", control_features), ("y_true", y_true)):
        if given is not None:
            raise InputError(name, "goes with y_pred and sensitive_features")
    return data, columns, records


def _audited(table: CountTable, g: Utility, intervals: IntervalOptions | None, min_count: int | None) -> Audit:
    """The audit of the counts: every group with records, small cells left out, the metrics, the intervals."""
    empty = [table.groups[j] for j in np.flatnonzero(table.group_counts == 0)]
    if empty:
        raise InputError("sensitive", "group has no records", format_label(empty[0]))
    table, left_out = leave_out_small(table, min_count)
    observed = observe(table.law(), g, table.population())
    made = None if intervals is None else fairness_intervals(table, g, intervals)
    return Audit(
        table=table,
        utility=g,
        observed=observed,
        intervals=made,
        confidence=None if intervals is None else intervals.confidence,
        min_count=min_count,
        left_out=left_out,
    )


def audit_utility(table: CountTable, positive: Hashable | None, utility: str | Utility | None) -> Utility:
    """The g of an audit: the Utility or expression given, else 1{U = positive}, else for a 0/1 (or boolean) outcome 1{U = 1}.

    Raises
    ------
    InputError
        Both ``positive`` and ``utility`` given (``positive``), ``positive`` not a value of the outcome, an
        expression that does not parse (``utility``), or an outcome that is not 0/1 with neither (``positive``).
    """
    if positive is not None and utility is not None:
        raise InputError("positive", "give positive or utility, not both", positive)
    if isinstance(utility, Utility):
        return utility
    if utility is not None:
        return utility_from_expression(utility, table.decisions)
    if positive is not None:
        return _positive_utility(positive, table.decisions)
    labels = set(map(str, table.decisions))
    if labels <= {"0", "1", "True", "False"}:
        if labels & {"1", "True"}:
            return _positive_utility(True if "True" in labels else 1, table.decisions)
        # a 0/1 outcome with no positive record: g is 0 on every outcome there is, so every group gets 0
        name = "1{outcome = True}" if "False" in labels else "1{outcome = 1}"
        return from_table(np.zeros(len(table.decisions)), tuple(table.decisions), name=name)
    if len(table.decisions) == 2:
        first, second = (_shown(d) for d in table.decisions)
        raise InputError(
            "positive",
            f"the outcome {echo(table.outcome_column)} has two values, {first} and {second}: say which one is "
            f"positive with `positive` (for example {second}), or give a `utility`",
        )
    raise InputError(
        "positive",
        f"the outcome {echo(table.outcome_column)} has {len(table.decisions)} values, not 0/1; say which value is "
        "positive (`positive`) or give a `utility`",
    )
