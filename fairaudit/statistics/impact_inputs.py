"""What :func:`~fairaudit.statistics.ll144.impact_ratios` counts: the table of records, the rate's 0/1 utility and the
category types.

The rate of 6 RCNY § 5-301 is a **selection rate** (the share of a category selected: a 0/1 utility of the outcome)
or, for a tool that scores, a **scoring rate**: the share of the category scoring above the median score of the whole
sample (:func:`median_score`, :func:`scoring_utility`). The category types are each sensitive column and, with two or
more, their intersection (:func:`category_types`).
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label
from fairaudit.data.counts import CountTable
from fairaudit.laws.utilities import Utility, from_table

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["category_types", "counted", "median_score", "rate_utility", "scoring_utility"]


def counted(
    data: CountTable | pd.DataFrame,
    sensitive: str | Sequence[str] | None,
    outcome: str | None,
    dropna: bool,
    weights: str | None,
) -> CountTable:
    """The CountTable of ``data``: itself, or a DataFrame's records counted."""
    if isinstance(data, CountTable):
        for name, given in (("sensitive", sensitive), ("outcome", outcome), ("weights", weights)):
            if given is not None:
                raise InputError(name, "goes with a DataFrame of records: a CountTable is already counted", given)
        return data
    if type(data).__name__ != "DataFrame" or not type(data).__module__.startswith("pandas"):
        raise InputError("data", "must be a CountTable or a pandas DataFrame of records", type(data).__name__)
    if sensitive is None:
        raise InputError("sensitive", "name at least one column")
    if outcome is None:
        raise InputError("outcome", "name the outcome column")
    from fairaudit.data.counts import count_records

    columns = [sensitive] if isinstance(sensitive, str) else list(sensitive)
    return count_records(data, sensitive=columns, outcome=outcome, dropna=dropna, weights=weights)


def rate_utility(
    table: CountTable, utility: Utility | str | None, positive: Hashable | None
) -> tuple[Utility, float | None, str]:
    """g over the decisions: the utility (0/1), 1{U = positive}, a 0/1 outcome's 1, or 1{score > the median}."""
    from fairaudit.statistics.record_audit import audit_utility

    binary = {str(d) for d in table.decisions} <= {"0", "1", "True", "False"}
    numeric = all(isinstance(d, (int, float, np.number)) and not isinstance(d, bool) for d in table.decisions)
    if utility is None and positive is None and not binary and numeric:
        return scoring_utility(table), median_score(table), "scoring"
    g = audit_utility(table, positive, utility)
    values = np.asarray(g.table(table.contexts[:1], table.groups[:1], table.decisions)[0, 0], dtype=float)
    if not np.all((values == 0) | (values == 1)):
        raise InputError("utility", "impact ratios need a 0/1 utility (a selection), or none for scores", g.name)
    return from_table(values, tuple(table.decisions), name=g.name), None, "selection"


def median_score(table: CountTable) -> float:
    """The median score of the whole sample (weighted with weights), from the counts of each score.

    The smallest score with more than half of the records at or below it; when exactly half lie at or below a
    score, the mean of it and the next one (the sample median of an even number of records).

    Raises
    ------
    InputError
        Field ``positive``: the outcome is not numeric (say which value is a selection with ``positive``).
    """
    if not all(isinstance(d, (int, float, np.number)) and not isinstance(d, bool) for d in table.decisions):
        raise InputError("positive", "say which outcome is a selection: the outcome is not a score")
    scores = np.array(table.decisions, dtype=float)
    weight = table.counts.sum(axis=(0, 1)).astype(float)
    cumulative = np.cumsum(weight) / weight.sum()
    j = int(np.searchsorted(cumulative, 0.5))
    return float(scores[j]) if cumulative[j] > 0.5 or j + 1 == len(scores) else float((scores[j] + scores[j + 1]) / 2)


def scoring_utility(table: CountTable) -> Utility:
    """g = 1{score > the whole sample's median score}: the event of the scoring rate (6 RCNY 5-301).

    Examples
    --------
    >>> import pandas as pd
    >>> from fairaudit import count_records
    >>> t = count_records(pd.DataFrame({"g": list("aabbb"), "score": [1, 5, 3, 9, 4]}), sensitive="g", outcome="score")
    >>> g = scoring_utility(t)
    >>> g.name, g.values.tolist()
    ('1{score > median 4}', [0.0, 0.0, 0.0, 1.0, 1.0])
    """
    median = median_score(table)
    values = np.array([float(d) > median for d in table.decisions], dtype=float)
    return from_table(values, tuple(table.decisions), name=f"1{{score > median {format_label(_plain(median))}}}")


def _plain(x: float) -> float | int:
    """``x`` as an int when it is a whole number (a median printed as 4, not 4.0)."""
    return int(x) if float(x).is_integer() else x


def category_types(table: CountTable) -> list[tuple[str, tuple, list[list[int]]]]:
    """(type name, its categories, for each category the groups of ``table`` it pools)."""
    columns = table.sensitive_columns
    types = []
    if len(columns) > 1:
        for i, column in enumerate(columns):
            categories = tuple(sorted({g[i] for g in table.groups}, key=_order))
            members = [[j for j, g in enumerate(table.groups) if g[i] == c] for c in categories]
            types.append((column, categories, members))
    types.append((" x ".join(columns), tuple(table.groups), [[j] for j in range(len(table.groups))]))
    return types


def _order(value: object) -> tuple[int, object]:
    return (0, value) if isinstance(value, (int, float)) else (1, str(value))
