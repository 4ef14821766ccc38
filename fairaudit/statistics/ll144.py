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

:func:`impact_ratios` computes them from a :class:`~fairaudit.data.counts.CountTable`
(contexts pooled) or from a DataFrame of records, one category type per
sensitive column and, with two columns or more, their intersection. Each ratio is
read as the EEOC's Uniform Guidelines read it (29 CFR 1607.4(D)): against the
four-fifths threshold and with the significance of the difference from the
highest rate (:class:`FourFifths`): a two-sided test of equal rates (Fisher's
exact test; the z test on request or where counts are not whole) and an interval
on the ratio (the melded interval, which inverts Fisher's test; :mod:`~fairaudit.statistics.rate_ratio`),
both adjusted for the ratios of the report (Holm by default, none, or the
simultaneous box of every rate: proofs/impact_ratio.md); the verdict is one of
:data:`VERDICTS`. :meth:`ImpactRatios.to_frame` gives the tidy table.

For a 0/1 utility, the global g-fairness of the intersection's included
categories (under the records' own population) is L̄ = −ln(its lowest impact
ratio): an impact ratio of at least t for every category is L̄ ≤ −ln t nats
(0.8: ln 1.25 = 0.223 nats).

The tests and intervals: each included category but its type's highest (the
comparator) is tested against it (:func:`~fairaudit.statistics.rate_ratio.equal_rates_test`)
and its ratio gets the melded interval of Fay, Proschan and Brittain
(:func:`~fairaudit.statistics.rate_ratio.ratio_interval`; on Kish's
effective counts with weights), whose exact coverage is at least its level
wherever it has been computed (docs/ll144.md); with ``"simultaneous"``, each
rate gets a Clopper–Pearson interval at level 1 − α/m, m the number of
included categories in the report, and ratio i lies in the exact range of
p_i / max_j p_j over that box (:func:`~fairaudit.statistics.rate_ratio.ratio_range`,
proofs/impact_ratio.md), all at once with probability ≥ 1 − α.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from dataclasses import asdict, dataclass, replace
from fractions import Fraction
from typing import TYPE_CHECKING

import numpy as np

from fairaudit.base.arrays import FloatArray
from fairaudit.base.checks import choice, level, real, whole
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number
from fairaudit.data.counts import CountTable
from fairaudit.laws.utilities import Utility
from fairaudit.statistics.confidence_sets import clopper_pearson
from fairaudit.statistics.impact_inputs import category_types, counted, rate_utility
from fairaudit.statistics.missing_demographics import unknown_ranges
from fairaudit.statistics.rate_ratio import adjusted, equal_rates_test, ratio_interval, ratio_range

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "ADJUSTMENTS",
    "DATA_SOURCES",
    "VERDICTS",
    "AuditFacts",
    "FourFifths",
    "ImpactRatio",
    "ImpactRatios",
    "impact_ratios",
    "round_half_up",
]

SMALL_SHARE = 0.02
"""Categories with less than this share of the data are listed but left out of the impact ratios (6 RCNY 5-301)."""

THRESHOLD = 0.8
"""The default threshold: the four-fifths rule of thumb (29 CFR 1607.4(D))."""

VERDICTS = ("below, significant", "below, inconclusive", "not below")
"""A category's verdict: its impact ratio below the threshold and its rate significantly different from the
highest (adjusted p-value below α = 1 − confidence); below and not significantly different; at or above it."""

ADJUSTMENTS = ("holm", "none", "simultaneous")
"""How a report's tests and intervals share α (:class:`FourFifths`)."""


DATA_SOURCES = ("historical", "test")
"""Where a bias audit's data come from (6 RCNY § 5-301: historical data of the employer's use, or test data)."""


@dataclass(frozen=True)
class AuditFacts:
    """What a published bias audit states besides its tables (6 RCNY § 5-303): the data's source and the dates.

    Attributes
    ----------
    data_source : {"historical", "test"} or None
        Historical data (the tool's use by the employer or others) or test data (when historical data are too few).
    audit_date : str or None
        The date of the audit, ISO 8601 (``YYYY-MM-DD``).
    distribution_date : str or None
        The date the employer began using the tool, ISO 8601.

    Raises
    ------
    InputError
        A data source not among :data:`DATA_SOURCES`, or a date that is not ``YYYY-MM-DD`` (naming it).

    Examples
    --------
    >>> AuditFacts("historical", "2026-11-29").audit_date
    '2026-11-29'
    """

    data_source: str | None = None
    audit_date: str | None = None
    distribution_date: str | None = None

    def __post_init__(self) -> None:
        import datetime

        if self.data_source is not None and self.data_source not in DATA_SOURCES:
            raise InputError("data_source", f"must be one of {', '.join(DATA_SOURCES)}", self.data_source)
        for name in ("audit_date", "distribution_date"):
            value = getattr(self, name)
            if value is None:
                continue
            try:
                datetime.date.fromisoformat(str(value))
            except ValueError:
                raise InputError(name, "must be a date YYYY-MM-DD", value) from None

    def to_dict(self) -> Report:
        """``data_source``, ``audit_date``, ``distribution_date`` (None where not given)."""
        return asdict(self)


@dataclass(frozen=True)
class FourFifths:
    """How :func:`impact_ratios` reads each ratio against the four-fifths rule.

    Attributes
    ----------
    threshold : float
        In (0, 1]; default 0.8.
    confidence : float
        In (0, 1): α = 1 − confidence is the level of the tests and 1 − α the intervals' coverage; default 0.95.
    adjustment : {"holm", "none", "simultaneous"}
        Over the m tested ratios of the report (every included category but its type's highest): ``"holm"``
        (default): Holm's p-values, each interval at 1 − α/m (Bonferroni's, so that they hold at once);
        ``"none"``: each test and interval at α alone; ``"simultaneous"``: Bonferroni's p-values and every ratio's
        exact range over the box of Clopper–Pearson intervals on every rate at 1 − α/(rates) (proofs/impact_ratio.md
        §1; the comparator's ratio gets an interval too).
    test : {"fisher", "z"}
        Fisher's exact test (default) or the pooled two-proportion z test, each two-sided against the highest rate;
        counts that are not whole (weights) always take the z test on Kish's effective counts.

    Raises
    ------
    InputError
        A value out of range, naming it.
    """

    threshold: float = THRESHOLD
    confidence: float = 0.95
    adjustment: str = "holm"
    test: str = "fisher"

    def __post_init__(self) -> None:
        real(self.threshold, "threshold", low=0.0, high=1.0, low_open=True)
        level(self.confidence, "confidence")
        choice(self.adjustment, "adjustment", ADJUSTMENTS)
        if self.test not in ("fisher", "z"):
            raise InputError("test", "must be fisher or z", self.test)


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
        Selection or scoring rate, in [0, 1] (NaN with no applicant): ``selected / n``.
    impact_ratio : float or None
        ``rate`` / the highest rate of the type's included categories; None when excluded. From whole counts it is
        the exact fraction rounded once to a float.
    interval : tuple of float or None
        Interval (lower, upper) on ``rate`` / the comparator's rate, as :class:`FourFifths` ``adjustment`` makes it
        (not capped at 1: the comparator is the highest rate in the data, not surely in truth); None when excluded,
        and for the comparator itself but with ``"simultaneous"``.
    excluded : bool
        The category holds less than 2% of the data: left out of the ratios.
    selected : float
        Applicants selected (for scoring rates: scoring above the median); with weights, their weight.
    verdict : str or None
        One of :data:`VERDICTS`; None when excluded.
    p_value : float or None
        The adjusted two-sided p-value of equal rates with the comparator; None when excluded and for the
        comparator.
    comparator : hashable or None
        The category of the type's highest included rate; None when excluded.
    unknown_range : tuple of float or None
        The least and greatest impact ratio over every way the type's records of unknown category could belong to
        its included categories (:func:`~fairaudit.statistics.missing_demographics.missing_data_bounds`: sharp; the
        highest rate moves with them); None when excluded, with no unknown record, or when an unknown record's
        outcome is one no known record has.
    aclu_ranges : pair of (float, float) or None
        For comparison, the ACLU's two published variants (Gerchick et al. 2025,
        :func:`~fairaudit.statistics.missing_demographics.aclu_bounds`): every unknown record in the category (all
        selected, or none), then that many times the category's share of the known records, over the highest rate
        held fixed; not capped at 1, not sharp.
    """

    type: str
    category: Hashable
    n: float
    rate: float
    impact_ratio: float | None
    interval: tuple[float, float] | None
    excluded: bool
    selected: float
    verdict: str | None
    p_value: float | None = None
    comparator: Hashable | None = None
    unknown_range: tuple[float, float] | None = None
    aclu_ranges: tuple[tuple[float, float], tuple[float, float]] | None = None

    def to_dict(self) -> Report:
        """The JSON object: ``type``, ``category``, ``n``, ``selected``, ``rate``, ``impact_ratio``, ``interval``,
        ``p_value``, ``verdict``, ``comparator``, ``excluded``."""
        return {
            "type": self.type,
            "category": label(self.category),
            "n": number(self.n),
            "selected": number(self.selected),
            "rate": number(self.rate),
            "impact_ratio": number(self.impact_ratio),
            "interval": None if self.interval is None else [number(v) for v in self.interval],
            "p_value": number(self.p_value),
            "verdict": self.verdict,
            "comparator": None if self.comparator is None else label(self.comparator),
            "unknown_range": None if self.unknown_range is None else [number(v) for v in self.unknown_range],
            "aclu_ranges": None if self.aclu_ranges is None else [[number(v) for v in r] for r in self.aclu_ranges],
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
    four_fifths : FourFifths
        How the ratios were read: threshold, confidence, adjustment, test.
    table : CountTable
    utility : Utility
        The 0/1 utility of the rates (for scoring rates, 1{score > median}).
    test : {"fisher", "z"}
        The test run: ``four_fifths.test``, or the z test where the counts are not whole.
    tested : int
        m, the ratios tested (the adjustment's m).
    facts : AuditFacts
        The data's source and the dates the audit states.
    """

    rows: tuple[ImpactRatio, ...]
    rate: str
    median: float | None
    unknown: dict[str, float]
    four_fifths: FourFifths
    table: CountTable
    utility: Utility
    test: str
    tested: int
    facts: AuditFacts = AuditFacts()

    @property
    def intersection(self) -> str:
        """The name of the last category type: the intersection of the sensitive columns (or the one column)."""
        return " x ".join(self.table.sensitive_columns)

    def headline_table(self) -> tuple[CountTable, tuple[tuple[Hashable, float], ...]]:
        """The table of the headline metrics: the records of the intersection's included categories.

        Returns the table without the groups (categories of the intersection) under 2% of the data, and those
        groups with their records, so that L and L̄ of :func:`fairaudit.audit` are over the categories of the
        impact ratios. When fewer than two categories hold 2% of the data, the whole table and no group.

        Examples
        --------
        >>> import pandas as pd
        >>> df = pd.DataFrame({"g": ["a"] * 60 + ["b"] * 39 + ["c"], "y": [1, 0] * 50})
        >>> table, left_out = impact_ratios(df, sensitive="g", outcome="y").headline_table()
        >>> table.groups, table.n, left_out
        (('a', 'b'), 99, (('c', 1.0),))
        """
        rows = [r for r in self.rows if r.type == self.intersection]
        keep = [not r.excluded for r in rows]
        if sum(keep) < 2 or all(keep):
            return self.table, ()
        index = np.flatnonzero(keep)
        squares = None if self.table.squares is None else self.table.squares[:, index]
        table = replace(
            self.table,
            counts=self.table.counts[:, index],
            groups=tuple(self.table.groups[j] for j in index),
            squares=squares,
        )
        return table, tuple((r.category, r.n) for r in rows if r.excluded)

    def headline_dict(self) -> Report:
        """What the headline metrics over :meth:`headline_table` cover, for the reports.

        ``type`` (the intersection), ``left_out`` (its categories under 2% of the data left out of the metrics, each
        ``{category, n}``) and ``includes_small`` (True when they stay in: fewer than two categories hold 2%).
        """
        _, left_out = self.headline_table()
        small = [r for r in self.rows if r.type == self.intersection and r.excluded]
        return {
            "type": self.intersection,
            "left_out": [{"category": label(c), "n": number(n)} for c, n in left_out],
            "includes_small": bool(small) and not left_out,
        }

    def to_dict(self) -> Report:
        """``{"impact_ratios": [...], "impact_ratio_details": {...}}``, the keys of ``fairaudit audit``'s JSON."""
        return {
            "impact_ratios": [r.to_dict() for r in self.rows],
            "impact_ratio_details": {
                "rate": self.rate,
                "median": number(self.median),
                "unknown": {k: number(v) for k, v in self.unknown.items()},
                "confidence": self.four_fifths.confidence,
                "small_share": SMALL_SHARE,
                "threshold": self.four_fifths.threshold,
                "adjustment": self.four_fifths.adjustment,
                "test": self.test,
                "tested": self.tested,
                **self.facts.to_dict(),
                "intersection": self.intersection,
            },
        }

    def to_frame(self, digits: int | None = None) -> pd.DataFrame:
        """The report as a tidy DataFrame, one row per category of each category type.

        Columns: ``type``, ``category`` (text, as the command line prints it), ``n`` and ``selected`` (integers;
        floats with weights; for scoring rates ``selected`` is named ``above_median``), ``selection_rate`` (or
        ``scoring_rate``), ``impact_ratio``, ``ci_low`` and ``ci_high`` (the interval; NaN without one), ``p_value``
        (NaN without one), ``verdict`` (None when excluded), ``comparator``, ``unknown_low`` and ``unknown_high`` (the
        ratio's range with the records of unknown category; NaN without it) and ``excluded``. ``attrs`` holds
        ``rate``, ``median``, ``confidence``, ``threshold``, ``adjustment``, ``test`` and ``unknown``.

        Parameters
        ----------
        digits : int, optional
            Round the rates and ratios to this many decimals as published audits print them (half up:
            :func:`round_half_up`), and the interval outwards (``ci_low`` down, ``ci_high`` up). The verdicts are
            those of the exact values.

        Examples
        --------
        >>> import pandas as pd
        >>> df = pd.DataFrame({"sex": ["F"] * 50 + ["M"] * 50, "hired": [1] * 20 + [0] * 30 + [1] * 25 + [0] * 25})
        >>> frame = impact_ratios(df, sensitive="sex", outcome="hired").to_frame()
        >>> frame[["category", "n", "selected", "selection_rate", "impact_ratio", "verdict"]]
          category   n  selected  selection_rate  impact_ratio    verdict
        0        F  50        20             0.4           0.8  not below
        1        M  50        25             0.5           1.0  not below
        >>> frame.round(2)[["ci_low", "ci_high", "p_value"]].values.tolist()[0]
        [0.49, 1.29, 0.42]
        >>> impact_ratios(df.iloc[:-1], sensitive="sex", outcome="hired").to_frame(digits=3)["impact_ratio"].tolist()
        [0.784, 1.0]
        """
        import pandas as pd

        if digits is not None:
            digits = whole(digits, "digits")

        integral = self.table.whole
        count = "int64" if integral else "float64"
        rate, selected = (
            ("selection_rate", "selected") if self.rate == "selection" else ("scoring_rate", "above_median")
        )

        def floats(values: list[float | None]) -> pd.Series:
            return pd.Series(values, dtype="float64")  # (None: NaN)

        def ends(pairs: list[tuple[float, float] | None], i: int) -> pd.Series:
            return floats([None if p is None else p[i] for p in pairs])

        def text(values: list[Hashable | None]) -> pd.Series:
            return pd.Series([None if v is None else str(label(v)) for v in values], dtype=object)

        rows = self.rows
        frame = pd.DataFrame(
            {
                "type": pd.Series([r.type for r in rows], dtype=object),
                "category": text([r.category for r in rows]),
                "n": pd.Series([round(r.n) if integral else r.n for r in rows], dtype=count),
                selected: pd.Series([round(r.selected) if integral else r.selected for r in rows], dtype=count),
                rate: floats([r.rate for r in rows]),
                "impact_ratio": floats([r.impact_ratio for r in rows]),
                "ci_low": ends([r.interval for r in rows], 0),
                "ci_high": ends([r.interval for r in rows], 1),
                "p_value": floats([r.p_value for r in rows]),
                "verdict": pd.Series([r.verdict for r in rows], dtype=object),
                "comparator": text([r.comparator for r in rows]),
                "unknown_low": ends([r.unknown_range for r in rows], 0),
                "unknown_high": ends([r.unknown_range for r in rows], 1),
                "excluded": pd.Series([r.excluded for r in rows], dtype=bool),
            }
        )
        if digits is not None:
            for column, how in ((rate, "half up"), ("impact_ratio", "half up"), ("ci_low", "down"), ("ci_high", "up")):
                frame[column] = [round_half_up(v, digits, how) for v in frame[column]]
        frame.attrs.update(
            rate=self.rate,
            median=self.median,
            confidence=self.four_fifths.confidence,
            threshold=self.four_fifths.threshold,
            adjustment=self.four_fifths.adjustment,
            test=self.test,
            unknown=dict(self.unknown),
        )
        return frame


def impact_ratios(
    data: CountTable | pd.DataFrame,
    utility: Utility | str | None = None,
    *,
    sensitive: str | Sequence[str] | None = None,
    outcome: str | None = None,
    positive: Hashable | None = None,
    dropna: bool = False,
    weights: str | None = None,
    four_fifths: FourFifths | None = None,
    facts: AuditFacts | None = None,
) -> ImpactRatios:
    """Selection (or scoring) rates and impact ratios per category, for each sensitive column and their intersection.

    Parameters
    ----------
    data : CountTable or pandas.DataFrame
        Counts of shape (n_contexts, n_groups, n_decisions), contexts pooled; or one record per applicant, counted
        with ``sensitive``, ``outcome``, ``dropna`` and ``weights`` (:func:`~fairaudit.data.counts.count_records`).
    utility : Utility or str, optional
        A 0/1 utility (or an expression in ``u``, :func:`~fairaudit.statistics.record_audit.utility_from_expression`): the selection
        rate is E[g] per category.
    sensitive, outcome : str or sequence of str, str
        The columns of a DataFrame: the category types (each column, then their intersection) and the outcome.
    positive : optional
        The outcome value that is a selection: g = 1{U = positive}.
    dropna : bool
        Drop records with a missing value in a used column (a DataFrame; counted as of unknown category).
    weights : str, optional
        Column of sample weights of a DataFrame: weighted rates, intervals on Kish's effective counts.
    four_fifths : FourFifths, optional
        Threshold (0.8), confidence (0.95), adjustment (Holm) and test (Fisher's) of the verdicts
        (:data:`VERDICTS`).
    facts : AuditFacts, optional
        The data's source and the dates, repeated in the report.

    Returns
    -------
    ImpactRatios

    Raises
    ------
    InputError
        ``utility`` not 0/1 (``utility``), no utility with a non-numeric, non-0/1 outcome (``utility``), both
        ``utility`` and ``positive`` (``positive``), ``positive`` not an outcome value (``positive``), ``data``
        neither a CountTable nor a DataFrame (``data``), and the errors of
        :func:`~fairaudit.data.counts.count_records`.

    Notes
    -----
    With neither ``utility`` nor ``positive``: an outcome of 0/1 (or booleans) is a selection of 1 (True); any
    other numeric outcome is a score, and the rate is the share of records scoring above the median of the whole
    sample (the weighted median with weights).

    Source: 6 RCNY § 5-301 (selection rate, scoring rate, impact ratio, the 2% exclusion); the tests and intervals
    are those of the module docstring (:mod:`fairaudit.statistics.ll144`; docs/ll144.md, proofs/impact_ratio.md).

    Examples
    --------
    >>> import pandas as pd
    >>> from fairaudit import count_records, indicator
    >>> df = pd.DataFrame({"sex": ["F"] * 50 + ["M"] * 50, "hired": [1] * 20 + [0] * 30 + [1] * 25 + [0] * 25})
    >>> t = count_records(df, sensitive="sex", outcome="hired")
    >>> [(r.category, r.rate, r.impact_ratio) for r in impact_ratios(t, indicator(1, t.decisions)).rows]
    [('F', 0.4, 0.8), ('M', 0.5, 1.0)]
    >>> [(r.category, r.impact_ratio, r.verdict) for r in impact_ratios(df, sensitive="sex", outcome="hired").rows]
    [('F', 0.8, 'not below'), ('M', 1.0, 'not below')]
    """
    rule = FourFifths() if four_fifths is None else four_fifths
    table = counted(data, sensitive, outcome, dropna, weights)
    g, median, kind = rate_utility(table, utility, positive)
    pooled = table.counts.sum(axis=0)  # (groups, decisions)
    effective = table.effective_counts(pooled=True)
    types = category_types(table)
    total = float(pooled.sum())

    def by_category(values: np.ndarray) -> list[FloatArray]:
        """Per category type, each category's total of ``values`` (per group, or per group and decision)."""
        return [np.array([values[m].sum() for m in members]) for _, _, members in types]

    shares, selected = by_category(pooled), by_category(pooled @ g.values)
    trials, positives = by_category(effective), by_category(effective @ g.values)
    included = [n >= SMALL_SHARE * total for n in shares]
    whole = table.whole
    test = rule.test if whole else "z"
    # the comparator of each type (its highest included rate), and every other included category's raw p-value
    best, raw, tested = [], [], []
    for t, (n, k, ne, ke, keep) in enumerate(zip(shares, selected, trials, positives, included)):
        index = np.flatnonzero(keep)
        with np.errstate(invalid="ignore", divide="ignore"):
            b = int(index[np.argmax((k / n)[index])]) if index.size else -1
        best.append(b)
        for i in index[index != b]:
            raw.append(equal_rates_test(float(ke[i]), float(ne[i]), float(ke[b]), float(ne[b]), test))
            tested.append((t, int(i)))
    p_values = dict(zip(tested, adjusted(raw, "bonferroni" if rule.adjustment == "simultaneous" else rule.adjustment)))
    alpha = 1.0 - rule.confidence
    m = max(1, sum(int(i.sum()) for i in included))  # the rates of the simultaneous box
    level_each = rule.confidence if rule.adjustment == "none" else 1.0 - alpha / max(1, len(raw))
    rows = []
    for t, ((name, categories, _), n, k, ne, ke, keep) in enumerate(
        zip(types, shares, selected, trials, positives, included)
    ):
        if rule.adjustment == "simultaneous":
            lo, hi = clopper_pearson(np.minimum(ke, ne), ne, alpha / m)
            index = np.flatnonzero(keep)
            low, high = ratio_range(lo[index], hi[index])
            intervals = {int(i): (float(a), float(c)) for i, a, c in zip(index, low, high)}
        else:
            b = best[t]
            intervals = {
                i: ratio_interval(float(ke[i]), float(ne[i]), float(ke[b]), float(ne[b]), level_each)
                for (u, i) in tested
                if u == t
            }
        p_type = {i: p for (u, i), p in p_values.items() if u == t}
        typed = _type_rows(name, categories, n, k, keep, whole, best[t], intervals, p_type, rule)
        rows += unknown_ranges(typed, dict(table.unknown_outcomes).get(name, ()), table.decisions, g, median)
    unknown = {name: float(dict(table.missing).get(name, 0.0)) for name, _, _ in types}
    return ImpactRatios(tuple(rows), kind, median, unknown, rule, table, g, test, len(raw), facts or AuditFacts())


def round_half_up(value: float, digits: int, how: str = "half up") -> float:
    """``value`` rounded to ``digits`` decimals as a person rounds it (0.3125 -> 0.313), or down or up.

    Rounds the shortest decimal that reads back as ``value`` (its ``repr``), so a rate or ratio that is exactly
    halfway at ``digits`` decimals (5/16 = 0.3125) goes up, as published audits (and spreadsheets) round, where
    Python's ``round`` of the binary float may go either way. ``how``: ``"half up"``, ``"down"`` or ``"up"``
    (for an interval's ends, rounded outwards). NaN and infinities are returned as they are.

    Parameters
    ----------
    value : float
        A rate or ratio (any float).
    digits : int
        Decimals kept, ≥ 0.
    how : {"half up", "down", "up"}
        Half up (ties away from zero), toward −∞ (a lower end) or toward +∞ (an upper end).

    Returns
    -------
    float
        The decimal rounded, as the nearest float.

    Raises
    ------
    InputError
        ``how`` not one of the three.

    Examples
    --------
    >>> round(0.3125, 3), round_half_up(0.3125, 3), round_half_up(2030 / 2464, 2), round_half_up(0.3715, 2, "down")
    (0.312, 0.313, 0.82, 0.37)
    """
    from decimal import ROUND_CEILING, ROUND_FLOOR, ROUND_HALF_UP, Decimal

    if not math.isfinite(value):
        return value
    modes = {"half up": ROUND_HALF_UP, "down": ROUND_FLOOR, "up": ROUND_CEILING}
    if how not in modes:
        raise InputError("how", "must be 'half up', 'down' or 'up'", how)
    return float(Decimal(repr(float(value))).quantize(Decimal(1).scaleb(-digits), rounding=modes[how]))


def _type_rows(
    name: str,
    categories: tuple,
    n: FloatArray,
    k: FloatArray,
    keep: np.ndarray,
    whole: bool,
    best: int,
    intervals: dict[int, tuple[float, float]],
    p_values: dict[int, float],
    rule: FourFifths,
) -> list[ImpactRatio]:
    """The rows of one category type: ratios to its highest included rate (``best``), intervals, p-values, verdicts.

    ``whole``: the counts are numbers of records, and each ratio is its exact fraction rounded once.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = k / n
    rows = []
    for c, nc, kc, r in zip(categories, n, k, rate):
        rows.append(ImpactRatio(name, c, float(nc), float(r), None, None, True, float(kc), None))
    for i in np.flatnonzero(keep):
        if whole:  # (k_i / n_i) / (k_b / n_b) = k_i n_b / (n_i k_b), one rounding
            num, den = round(k[i]) * round(n[best]), round(n[i]) * round(k[best])
            ratio = float(Fraction(num, den)) if den else 1.0  # (0 / 0: every rate is 0, parity)
        else:
            ratio = float(rate[i] / rate[best]) if rate[best] > 0 else 1.0
        p = p_values.get(int(i))
        verdict = (
            VERDICTS[2] if ratio >= rule.threshold else VERDICTS[0 if p is not None and p < 1 - rule.confidence else 1]
        )
        rows[i] = replace(
            rows[i], impact_ratio=ratio, interval=intervals.get(int(i)), excluded=False, verdict=verdict, p_value=p,
            comparator=categories[best],
        )  # fmt: skip
    return rows
