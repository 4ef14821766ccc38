"""Impact ratios, as bias audits of automated employment decision tools publish them (NYC Local Law 144).

The rules of the New York City Department of Consumer and Worker Protection
(6 RCNY § 5-301, "Bias Audit") define, for each category of a category type
(sex, race/ethnicity, and their intersection):

* the **selection rate**: the share of the category's applicants selected
  (a binary outcome), or, for a tool that scores, the **scoring rate**: the
  share of the category's applicants scoring above the median score of the
  whole sample;
* the **impact ratio**: the category's rate divided by the highest rate
  among the categories of its type;
* a category under 2% of the data may be left out of the impact ratios (it
  is still listed, with its number of applicants and its rate), and the
  number of applicants of unknown category is reported.

:func:`impact_ratios` computes them from a :class:`~fairaudit.estimate.CountTable`
(contexts pooled), one category type per sensitive column and, with two
columns or more, their intersection; each ratio gets an interval, all of them
simultaneous (Clopper–Pearson with Bonferroni over every rate of the report).
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from ._arrays import FloatArray, format_label
from ._confidence_sets import clopper_pearson
from ._errors import InputError
from ._json import Report, label, number
from ._validation import level
from .estimate import CountTable
from .utility import Utility, from_table

__all__ = ["ImpactRatio", "ImpactRatios", "impact_ratios", "median_score", "scoring_utility"]

SMALL_SHARE = 0.02
"""Categories with less than this share of the data are listed but left out of the impact ratios (6 RCNY 5-301)."""


@dataclass(frozen=True)
class ImpactRatio:
    """One category of one category type.

    Attributes
    ----------
    type : str
        The category type: a sensitive column, or the columns joined with ``" x "`` for their intersection.
    category : hashable
        The category (a tuple for an intersection).
    n : float
        Applicants in the category (records; with weights, the sum of their weights).
    rate : float
        Selection or scoring rate, in [0, 1] (NaN with no applicant).
    impact_ratio : float or None
        ``rate`` / the highest rate of the type's included categories; None when excluded.
    interval : tuple of float or None
        Simultaneous interval (lower, upper) on ``impact_ratio``, within [0, 1]; None when excluded.
    excluded : bool
        The category holds less than 2% of the data: left out of the ratios.
    """

    type: str
    category: Hashable
    n: float
    rate: float
    impact_ratio: float | None
    interval: tuple[float, float] | None
    excluded: bool

    def to_dict(self) -> Report:
        """The JSON object: ``type``, ``category``, ``n``, ``rate``, ``impact_ratio``, ``interval``, ``excluded``."""
        return {
            "type": self.type,
            "category": label(self.category),
            "n": number(self.n),
            "rate": number(self.rate),
            "impact_ratio": number(self.impact_ratio),
            "interval": None if self.interval is None else [number(v) for v in self.interval],
            "excluded": self.excluded,
        }


@dataclass(frozen=True)
class ImpactRatios:
    """The impact-ratio report of :func:`impact_ratios`; repeats its inputs.

    Attributes
    ----------
    rows : tuple of ImpactRatio
        Per category type (each sensitive column, then the intersection), its categories in label order.
    rate : {"selection", "scoring"}
        Which rate: of a 0/1 utility, or the share above the whole sample's ``median`` score.
    median : float or None
        The median score of the whole sample (scoring rates only).
    unknown : dict of str to float
        Per category type, the records with an unknown (missing) category, left out of everything.
    confidence : float
        Level of the simultaneous intervals.
    table : CountTable
    utility : Utility or None
    """

    rows: tuple[ImpactRatio, ...]
    rate: str
    median: float | None
    unknown: dict[str, float]
    confidence: float
    table: CountTable
    utility: Utility | None

    def to_dict(self) -> Report:
        """``{"impact_ratios": [...], "impact_ratio_details": {...}}``, the keys of ``fairaudit audit``'s JSON."""
        return {
            "impact_ratios": [r.to_dict() for r in self.rows],
            "impact_ratio_details": {
                "rate": self.rate,
                "median": number(self.median),
                "unknown": {k: number(v) for k, v in self.unknown.items()},
                "confidence": self.confidence,
                "small_share": SMALL_SHARE,
            },
        }


def impact_ratios(table: CountTable, utility: Utility | None = None, *, confidence: float = 0.95) -> ImpactRatios:
    """Selection (or scoring) rates and impact ratios per category, for each sensitive column and their intersection.

    Parameters
    ----------
    table : CountTable
        Counts of shape (n_contexts, n_groups, n_decisions); contexts are pooled.
    utility : Utility, optional
        A 0/1 utility: the selection rate is E[g] per category. None: the outcome
        must be numeric, and the scoring rate is the share of records scoring
        above the median of the whole sample (the weighted median with weights).
    confidence : float
        Level of the simultaneous intervals on every ratio (default 0.95).

    Returns
    -------
    ImpactRatios

    Raises
    ------
    InputError
        ``utility`` not 0/1 (``utility``), no utility with a non-numeric
        outcome (``utility``), ``confidence`` outside (0, 1).

    Notes
    -----
    Definitions: 6 RCNY § 5-301 (selection rate, scoring rate, impact ratio,
    the 2% exclusion). Intervals: each category's rate gets a Clopper–Pearson
    interval at level 1 − α/m, m the number of included categories in the
    report (with weights, on Kish's effective counts); the highest rate of a
    type then lies in [max lower, max upper], so the ratio lies in
    [lower / max upper, upper / max lower], all ratios at once with
    probability ≥ 1 − α.

    Examples
    --------
    >>> import pandas as pd
    >>> from fairaudit import count_records, indicator
    >>> df = pd.DataFrame({"sex": ["F"] * 50 + ["M"] * 50, "hired": [1] * 20 + [0] * 30 + [1] * 25 + [0] * 25})
    >>> t = count_records(df, sensitive="sex", outcome="hired")
    >>> [(r.category, r.rate, r.impact_ratio) for r in impact_ratios(t, indicator(1, t.decisions)).rows]
    [('F', 0.4, 0.8), ('M', 0.5, 1.0)]
    """
    confidence = level(confidence, "confidence")
    pooled = table.counts.sum(axis=0)  # (groups, decisions)
    g, median, kind = _indicator(table, utility, pooled)
    effective = table.effective_counts(pooled=True)
    types = _category_types(table)
    total = float(pooled.sum())
    shares, rates, trials, positives = [], [], [], []
    for _, categories, members in types:
        n = np.array([pooled[m].sum() for m in members])
        k = np.array([(pooled[m] * g).sum() for m in members])
        ne = np.array([effective[m].sum() for m in members])
        ke = np.array([(effective[m] * g).sum() for m in members])
        shares.append(n)
        with np.errstate(invalid="ignore", divide="ignore"):
            rates.append(k / n)
        trials.append(ne)
        positives.append(ke)
    included = [n >= SMALL_SHARE * total for n in shares]
    m = max(1, sum(int(i.sum()) for i in included))
    rows = []
    for (name, categories, _), n, rate, ne, ke, keep in zip(types, shares, rates, trials, positives, included):
        lo, hi = clopper_pearson(np.minimum(ke, ne), ne, (1.0 - confidence) / m)
        rows += _type_rows(name, categories, n, rate, lo, hi, keep)
    unknown = {name: float(dict(table.missing).get(name, 0.0)) for name, _, _ in types}
    return ImpactRatios(tuple(rows), kind, median, unknown, confidence, table, utility)


def _indicator(table: CountTable, utility: Utility | None, pooled: FloatArray) -> tuple[FloatArray, float | None, str]:
    """g over the decisions: the utility (0/1), or 1{score > the whole sample's median}."""
    if utility is None:
        scoring = scoring_utility(table)
        return scoring.values, median_score(table), "scoring"
    g = np.asarray(utility.table(table.contexts[:1], table.groups[:1], table.decisions)[0, 0], dtype=float)
    if not np.all((g == 0) | (g == 1)):
        raise InputError("utility", "impact ratios need a 0/1 utility (a selection), or none for scores", utility.name)
    return g, None, "selection"


def median_score(table: CountTable) -> float:
    """The median score of the whole sample (weighted with weights), from the counts of each score.

    The smallest score with more than half of the records at or below it; when exactly half lie at or below a
    score, the mean of it and the next one (the sample median of an even number of records).

    Raises
    ------
    InputError
        Field ``utility``: the outcome is not numeric (say which value is a selection with ``positive``).
    """
    if not all(isinstance(d, (int, float, np.number)) and not isinstance(d, bool) for d in table.decisions):
        raise InputError("utility", "say which outcome is a selection (`positive`): the outcome is not a score")
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
    return int(x) if float(x).is_integer() else x


def _category_types(table: CountTable) -> list[tuple[str, tuple, list[list[int]]]]:
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


def _type_rows(
    name: str, categories: tuple, n: FloatArray, rate: FloatArray, lo: FloatArray, hi: FloatArray, keep: np.ndarray
) -> list[ImpactRatio]:
    """The rows of one category type: ratios to its highest included rate, with their simultaneous intervals."""
    best = float(np.max(rate[keep])) if keep.any() else math.nan
    top_lo, top_hi = (float(np.max(lo[keep])), float(np.max(hi[keep]))) if keep.any() else (math.nan, math.nan)
    rows = []
    for c, nc, r, lc, hc, k in zip(categories, n, rate, lo, hi, keep):
        if not k:
            rows.append(ImpactRatio(name, c, float(nc), float(r), None, None, True))
            continue
        ratio = float(r / best) if best > 0 else (1.0 if best == 0 else math.nan)  # (0 / 0: every rate is 0)
        # r_c in [lc, hc] and r_max in [top_lo, top_hi] with r_max >= r_c: the ratio lies in [lc / top_hi, min(1, hc / top_lo)]
        lower = float(lc) / top_hi if top_hi > 0 else 0.0
        upper = 1.0 if top_lo == 0 else min(1.0, float(hc) / top_lo)
        rows.append(ImpactRatio(name, c, float(nc), float(r), ratio, (lower, upper), False))
    return rows
