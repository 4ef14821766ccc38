"""Finite-sample intervals: one simultaneous confidence set for a law estimated from counts, every metric over it.

A table of counts ``n[x, a, u]`` (decision records per context, group and
decision) estimates each cell's decision distribution P(U | x, a). Every
method here builds **one** confidence set C for all of those distributions at
once, with P(C contains the true law) ≥ 1 − α, and reports for each metric
the interval [min over C, max over C] (the projection of C). All the
intervals of one result therefore hold *simultaneously*: the maximum over
cells is never treated as a single cell.

Methods (``method=``):

``"clopper-pearson"``
    For an indicator utility g ∈ {0, 1}: each cell's probability of g = 1 gets
    an exact binomial (Clopper–Pearson 1934) interval at level 1 − α/m, with m
    the number of non-empty cells (plus groups, see below): Bonferroni. Exact
    coverage ≥ 1 − α whatever the counts. L_dp, L_eo and the sups over g are
    about U's whole distribution, so they are given only when U is binary.
``"multinomial"``
    For any bounded utility: each cell's distribution lies in the polytope
    {p in the simplex : lo_u ≤ p_u ≤ hi_u}, with Clopper–Pearson bounds at
    level 1 − α/(m K) per decision (K decisions; K = 2 needs one interval per
    cell since the two coincide). Coverage ≥ 1 − α by Bonferroni, whatever
    the counts. E[g | x, a] ranges over an interval found in closed form (a
    fractional knapsack, checked against the LP in the tests); ratios of
    groups are extremised by the linear-fractional engine
    (:mod:`fairaudit.base.linear_fractional`; an exact LP where the groups share cells).
``"bayes"``
    Each cell's distribution has the posterior Dirichlet(n[x, a, :] + c/K)
    (``concentration`` c; c = 1 gives the posterior mean that AIF360's
    ``smoothed_empirical_differential_fairness`` uses). ``draws`` samples with
    ``seed``; the simultaneous credible set is the rank-based band of Besag
    et al. (1995) over every cell probability: a box per cell, projected onto
    the metrics like the polytopes above. A credible set, not a confidence
    set: its frequentist coverage is measured (``benchmarks/bench_coverage.py``),
    not guaranteed.

Global metrics (L̄, L_dp, sup over g of L̄): without a population, records
are taken to be i.i.d. draws of (X, A, U), so within group a the records are
i.i.d. with law P(U | a) (or P(X, U | a) when g depends on the context);
those pooled per-group distributions get their own sets, counted in m. With
a population P(X, A) (as in a spec), E[g | a] = Σ_x P(x | a) E[g | x, a] is
a fixed linear map of the cells.

Behind a privacy filter (``sensitive_mechanism`` M_A, ``context_mechanism``
M_X): the counts are those of the decision model's kernel K[x̃, ã, u] (its
decisions on released values), and the audited law is
Q[x, a, u] = Σ M_X[x, x̃] M_A[a, ã] K[x̃, ã, u]. Groups then share kernel
cells, and the extremes of each ratio over C are linear-fractional programs:
the upper end by the threshold solution over the box of kernel cells
(:func:`fairaudit.base.threshold_rule.threshold_max_many`), the lower end by the
Charnes–Cooper LP of min over the box of max_a E_a / min_a E_a. The upper end
of L is the white-box certificate at level 1 − α; a lower end above 0 is
evidence of unfairness.

Zero counts give a finite lower end and an honest upper end (+inf where the
data cannot exclude a zero expected utility). An empty cell constrains
nothing: its distribution may be anything.

Proof of the projection argument and the LP: ``proofs/intervals.md``.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from fairaudit.base.arrays import FloatArray, safe_log
from fairaudit.base.checks import choice, level, real, whole
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.data.counts import CountTable
from fairaudit.laws.composition import compose
from fairaudit.laws.mechanisms import Mechanism, identity
from fairaudit.laws.tables import Kernel, Law, Population
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.observed import observe
from fairaudit.statistics.confidence_sets import binomial_sets, sum_last
from fairaudit.statistics.projection import MetricEnds, Projection, ProjectionOptions, project_sets

__all__ = [
    "METHODS",
    "FairnessIntervals",
    "Interval",
    "IntervalOptions",
    "fairness_intervals",
    "interval_options",
]

METHODS = ("clopper-pearson", "multinomial", "bayes")


@dataclass(frozen=True, kw_only=True)
class IntervalOptions:
    """How simultaneous intervals are made: their level, their method and the Bayesian band's settings.

    One object for the settings that :func:`fairness_intervals`,
    :func:`~fairaudit.audit` and :func:`~fairaudit.certify` share (given as
    ``intervals``).

    Parameters
    ----------
    confidence : float
        1 − α, strictly between 0 and 1 (default 0.95): every interval of a
        result holds at once with at least this probability.
    method : {"auto", "clopper-pearson", "multinomial", "bayes"}
        "auto" (default) is "clopper-pearson" for a 0/1 utility (exact binomial
        intervals per cell, Clopper and Pearson 1934, Biometrika 26), and
        "multinomial" otherwise (per-cell multinomial sets); "bayes" is a
        simultaneous band of the Dirichlet posterior (Besag, Green, Higdon and
        Mengersen 1995, Statist. Sci. 10, sec. 4.3). ``proofs/intervals.md``.
    concentration : float
        ``method="bayes"``: the total mass c > 0 of the Dirichlet prior
        Dirichlet(c/K, ..., c/K) over the K decisions (default 1).
    draws : int
        ``method="bayes"``: the number of posterior draws, ≥ 100 (default 4000).
    seed : int
        ``method="bayes"``: the seed of its random draws, ≥ 0 (default 0).

    Raises
    ------
    InputError
        Naming the field: a confidence outside (0, 1), an unknown method, a
        concentration that is not a finite positive number, fewer than 100
        draws, or a negative or non-integer seed.

    Examples
    --------
    >>> IntervalOptions()
    IntervalOptions(confidence=0.95, method='auto', concentration=1.0, draws=4000, seed=0)
    >>> IntervalOptions(confidence=0.9, method="bayes", seed=3).confidence
    0.9
    >>> IntervalOptions(confidence=1.0)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: confidence: must be a number strictly between 0 and 1 (got 1.0)
    """

    confidence: float = 0.95
    method: str = "auto"
    concentration: float = 1.0
    draws: int = 4000
    seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "confidence", level(self.confidence, "confidence"))
        object.__setattr__(self, "method", choice(self.method, "method", ("auto", *METHODS)))
        concentration = real(self.concentration, "concentration", low=0.0, low_open=True)
        object.__setattr__(self, "concentration", concentration)
        object.__setattr__(self, "draws", whole(self.draws, "draws", low=100))
        object.__setattr__(self, "seed", whole(self.seed, "seed"))


METRIC_ATTRIBUTES = {
    "local": "local_fairness",
    "global": "global_fairness",
    "sup_local": "sup_local_fairness",
    "sup_global": "sup_global_fairness",
    "demographic_parity": "demographic_parity",
    "equalized_odds": "equalized_odds",
}
"""Each metric's key in the report dictionaries -> its attribute in the results (:class:`FairnessIntervals`,
:class:`~fairaudit.metrics.observed.Observed`)."""
_LOCAL = ("local", "sup_local", "equalized_odds")  # one interval per context, the widest reported


@dataclass(frozen=True)
class Interval:
    """An interval for one metric, with how it was made.

    Attributes
    ----------
    lower, upper : float
        The ends, in the metric's units (nats for L, L̄ and the sups; a
        probability for L_dp and L_eo). ``upper`` may be +inf.
    estimate : float
        The point estimate (plug-in of the empirical law; for ``"bayes"``,
        of the posterior mean).
    confidence : float
        1 − α, shared by every interval of one :class:`FairnessIntervals`.
    method : str
        One of :data:`METHODS`.
    context, group, other_group : hashable or None
        Where the upper end is attained: the context (None for global
        metrics) and the pair of groups, ``group`` the favoured one.

    Examples
    --------
    >>> iv = Interval(0.1, 0.7, 0.3, 0.95, "multinomial")
    >>> lo, hi = iv
    >>> (lo, hi), iv.width, 0.5 in iv
    ((0.1, 0.7), 0.6, True)
    """

    lower: float
    upper: float
    estimate: float
    confidence: float
    method: str
    context: Hashable | None = None
    group: Hashable | None = None
    other_group: Hashable | None = None

    def __iter__(self) -> Iterator[float]:
        return iter((self.lower, self.upper))

    def __contains__(self, value: float) -> bool:
        return bool(self.lower <= value <= self.upper)

    @property
    def width(self) -> float:
        """upper − lower (+inf when the upper end is)."""
        return self.upper - self.lower

    def to_dict(self) -> Report:
        """The report dictionary: lower, upper, estimate, context and the pair of groups."""
        ends = {name: number(getattr(self, name)) for name in ("lower", "upper", "estimate")}
        return ends | {name: label(getattr(self, name)) for name in ("context", "group", "other_group")}


@dataclass(frozen=True, eq=False, kw_only=True)
class FairnessIntervals:
    """Simultaneous intervals for every metric of a law estimated from counts.

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    confidence : float
        1 − α: all intervals hold together with probability ≥ 1 − α (for
        ``"bayes"``, posterior probability).
    local_fairness, global_fairness : Interval
        L and L̄ in nats.
    sup_local_fairness, sup_global_fairness : Interval or None
        Sups over g of L and L̄ (Lemma 1), nats; None with
        ``"clopper-pearson"`` when U is not binary.
    demographic_parity, equalized_odds : Interval or None
        L_dp and L_eo (total variation, in [0, 1]); None as above.
    cell_lower, cell_upper : numpy.ndarray, shape (n_contexts, n_groups)
        Simultaneous bounds on E[g | x, a] of the audited law (the filtered
        law behind a privacy filter).
    group_lower, group_upper : numpy.ndarray, shape (n_groups,)
        Bounds on E[g | a].
    kernel_lower, kernel_upper : numpy.ndarray or None, shape (n_released_contexts, n_released_groups)
        Behind a filter: bounds on E[g | x̃, ã] of the counted kernel.
    n_sets : int
        How many per-cell (and per-group) sets share α (Bonferroni's m);
        0 for ``"bayes"``.
    table, utility, sensitive_mechanism, context_mechanism, population
        The inputs (mechanisms None when not filtered; population None when
        the records' own, pooled, was used).
    concentration, draws, seed : float, int, int or None
        The Bayesian settings (None for the other methods).
    notes : tuple of str
        What was not computed or is conservative, and why.
    """

    method: str
    confidence: float
    local_fairness: Interval
    global_fairness: Interval
    sup_local_fairness: Interval | None
    sup_global_fairness: Interval | None
    demographic_parity: Interval | None
    equalized_odds: Interval | None
    cell_lower: FloatArray
    cell_upper: FloatArray
    group_lower: FloatArray
    group_upper: FloatArray
    kernel_lower: FloatArray | None
    kernel_upper: FloatArray | None
    n_sets: int
    table: CountTable
    utility: Utility
    sensitive_mechanism: Mechanism | None
    context_mechanism: Mechanism | None
    population: Population | None
    concentration: float | None = None
    draws: int | None = None
    seed: int | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    def intervals(self) -> dict[str, Interval | None]:
        """The metric intervals by name (None where not computed)."""
        return {key: getattr(self, name) for key, name in METRIC_ATTRIBUTES.items()}

    def to_dict(self) -> Report:
        """The report dictionary: method, level, number of sets, filtered, notes and one entry per metric.

        The Bayesian settings (``concentration``, ``draws``, ``seed``) follow
        for ``"bayes"``; a metric not computed is None.
        """
        out: Report = {
            "method": self.method,
            "confidence": number(self.confidence),
            "sets": self.n_sets,
            "filtered": self.sensitive_mechanism is not None or self.context_mechanism is not None,
            "notes": list(self.notes),
        }
        if self.method == "bayes":
            out.update(concentration=number(self.concentration), draws=self.draws, seed=self.seed)
        out.update({k: None if v is None else v.to_dict() for k, v in self.intervals().items()})
        return out


class _AuditedLaw(NamedTuple):
    """The law the intervals are about: its labels, the filter in front of it and its population."""

    contexts: tuple
    groups: tuple
    sensitive_mechanism: Mechanism | None  # both set behind a filter (an identity for the unfiltered attribute)
    context_mechanism: Mechanism | None
    population: Population | None  # None: the records' own groups, pooled


def _check(table: object, utility: object, intervals: object) -> IntervalOptions:
    """Validate the arguments of :func:`fairness_intervals`; returns the options (the defaults for None)."""
    if not isinstance(table, CountTable):
        raise InputError("table", "must be a CountTable (fairaudit.count_records or count_table)", type(table).__name__)
    if not isinstance(utility, Utility):
        raise InputError("utility", "must be a Utility", type(utility).__name__)
    options = interval_options(intervals) or IntervalOptions()
    counts = np.asarray(table.counts, dtype=float)
    if table.squares is None and np.any(counts != np.round(counts)):
        bad = counts[counts != np.round(counts)].flat[0]
        raise InputError(
            "counts", "intervals need whole numbers of records (the table holds probabilities or weights)", float(bad)
        )
    return options


def interval_options(intervals: object) -> IntervalOptions | None:
    """``intervals`` checked: None or an :class:`IntervalOptions`, returned as it is.

    Raises
    ------
    InputError
        Field ``intervals`` for anything else, quoting its type.
    """
    if intervals is not None and not isinstance(intervals, IntervalOptions):
        raise InputError("intervals", "must be an IntervalOptions", type(intervals).__name__)
    return intervals


def fairness_intervals(
    table: CountTable,
    utility: Utility,
    intervals: IntervalOptions | None = None,
    *,
    sensitive_mechanism: Mechanism | None = None,
    context_mechanism: Mechanism | None = None,
    population: Population | None = None,
) -> FairnessIntervals:
    """Simultaneous (1 − α) intervals for E[g | x, a], E[g | a], L, L̄, the sups over g, L_dp and L_eo.

    Parameters
    ----------
    table : CountTable
        Counts, shape (n_contexts, n_groups, n_decisions): of the law itself,
        or, with a mechanism, of the decision model's kernel on released
        values (n_released_contexts, n_released_groups, n_decisions).
    utility : Utility
        g ≥ 0 over the table's decisions (and contexts and groups). Behind a
        filter it must depend on the decision only.
    intervals : IntervalOptions, optional
        The level 1 − α, the method ("auto" is "clopper-pearson" for a 0/1
        utility, "multinomial" otherwise) and the Bayesian band's settings;
        default ``IntervalOptions()``: 95%, "auto".
    sensitive_mechanism, context_mechanism : Mechanism, optional
        M_A (n_groups × n_released_groups) and M_X; their outputs must be the
        table's groups and contexts.
    population : Population, optional
        P(X, A) for global metrics (and to leave out contexts with P(x) = 0).
        Default: the records' own groups, pooled (unfiltered); uniform and
        independent behind a filter.

    Returns
    -------
    FairnessIntervals

    Raises
    ------
    InputError
        On ``intervals`` that is not an :class:`IntervalOptions`, a
        non-indicator utility with "clopper-pearson", counts that are not
        whole numbers, mechanisms that do not match the table, or a utility
        that depends on the context or group behind a filter.

    Notes
    -----
    Sources: the projection argument, the sets and the programs are proved in
    ``proofs/intervals.md``; exact binomial intervals from Clopper and
    Pearson (1934, Biometrika 26); the Bayesian band from Besag, Green,
    Higdon and Mengersen (1995, Statist. Sci. 10, sec. 4.3); the metrics are
    those of the paper's SI A and B (:mod:`fairaudit.metrics.fairness`,
    :mod:`~fairaudit.metrics.parity`, :mod:`~fairaudit.metrics.sup_fairness`).
    Lower ends of the sups over g and of L_dp, L_eo are valid but may be below
    the exact minimum over the set (a max of minima); every upper end is exact.

    Examples
    --------
    Two groups, 30/50 and 20/50 selected: L = log 1.5 lies inside.

    >>> import pandas as pd
    >>> from fairaudit import count_records, indicator
    >>> t = count_records(pd.DataFrame({"g": ["a"] * 50 + ["b"] * 50,
    ...                                 "y": [1] * 30 + [0] * 20 + [1] * 20 + [0] * 30}), sensitive=["g"], outcome="y")
    >>> iv = fairness_intervals(t, indicator(1, t.decisions), IntervalOptions(confidence=0.95))
    >>> iv.method, round(iv.local_fairness.estimate, 6), iv.local_fairness.lower < iv.local_fairness.estimate < iv.local_fairness.upper
    ('clopper-pearson', 0.405465, True)
    >>> iv.local_fairness.group, iv.local_fairness.other_group
    ('a', 'b')
    """
    options = _check(table, utility, intervals)
    method, concentration, draws, seed = options.method, options.concentration, options.draws, options.seed
    counts = np.asarray(table.counts, dtype=float)
    g = np.asarray(utility.table(table.contexts, table.groups, table.decisions), dtype=float)
    indicator = bool(np.all((g == 0.0) | (g == 1.0)))
    if method == "auto":
        method = "clopper-pearson" if indicator else "multinomial"
    if method == "clopper-pearson" and not indicator:
        raise InputError(
            "method", "clopper-pearson needs a 0/1 utility; use multinomial or bayes for this utility", utility.name
        )
    law = _audited_law(table, utility, sensitive_mechanism, context_mechanism, population)
    prior = concentration / counts.shape[-1] if method == "bayes" else 0.0  # bayes: the plug-in of the posterior mean
    plugin = table.effective_counts() if method == "bayes" else counts  # (the posterior's counts: effective ones)
    estimate = _estimates(table, plugin + prior, utility, law)
    if method == "bayes":  # (its module loaded only for its sets)
        from fairaudit.statistics.bayes import band_sets
    bayes: dict[str, Any] = (
        {"concentration": float(concentration), "draws": int(draws), "seed": int(seed)} if method == "bayes" else {}
    )
    projection = ProjectionOptions(
        method=method,
        alpha=1.0 - options.confidence,
        context_keep=(np.ones(len(law.contexts), bool) if law.population is None else law.population.p_context > 0),
        population=law.population,
        sensitive_mechanism=law.sensitive_mechanism,
        context_mechanism=law.context_mechanism,
        sets=band_sets(concentration, int(draws), int(seed)) if bayes else binomial_sets,
        **_kish_scales(table),
    )
    made = _assemble(project_sets(counts, g, projection), projection, law, estimate)
    return FairnessIntervals(**made, table=table, utility=utility, **bayes)


def _kish_scales(table: CountTable) -> dict[str, FloatArray]:
    """With sample weights, n_eff / W per cell and per pooled group (:meth:`CountTable.effective_counts`)."""
    if table.squares is None:
        return {}
    scales = {}
    for key, pooled in (("cell_scale", False), ("group_scale", True)):
        w = table.counts.sum(axis=0) if pooled else table.counts
        effective = table.effective_counts(pooled).sum(axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            scales[key] = np.where(w.sum(axis=-1) > 0, effective / w.sum(axis=-1), 0.0)
    return scales


def _identity(mech: Mechanism | None, labels: tuple) -> bool:
    return mech is None or (tuple(mech.inputs) == tuple(labels) and mech.is_identity)


def _audited_law(
    table: CountTable,
    utility: Utility,
    sensitive_mechanism: Mechanism | None,
    context_mechanism: Mechanism | None,
    population: Population | None,
) -> _AuditedLaw:
    """The audited law's labels, filter and population, checked against the table and the utility.

    Without a filter (no mechanism, or identities on the table's labels) the law is the table's own, the
    mechanisms are None and the population stays as given. Behind one both mechanisms are set (an identity for the
    unfiltered attribute), their outputs must be the table's labels, the utility must be of the decision only, and
    the population defaults to uniform and independent over the mechanisms' inputs.
    """
    if _identity(sensitive_mechanism, table.groups) and _identity(context_mechanism, table.contexts):
        law = _AuditedLaw(table.contexts, table.groups, None, None, population)
    else:
        m_a = sensitive_mechanism if sensitive_mechanism is not None else identity(table.groups)
        m_x = context_mechanism if context_mechanism is not None else identity(table.contexts)
        filters = (("sensitive", m_a, "groups", table.groups), ("context", m_x, "contexts", table.contexts))
        for what, mech, axis, labels in filters:
            if tuple(mech.outputs) != tuple(labels):
                shown, given = list(map(format_label, labels)), list(map(format_label, mech.outputs))
                raise InputError(f"{what} mechanism", f"outputs must be the table's {axis} {shown}", given)
        if utility.depends_on_context or utility.depends_on_group:
            raise InputError(
                "utility", "behind a privacy filter intervals need a utility of the decision only", utility.name
            )
        if population is None:
            population = Population.uniform(m_x.inputs, m_a.inputs, source="assumed")
        law = _AuditedLaw(tuple(m_x.inputs), tuple(m_a.inputs), m_a, m_x, population)
    if law.population is not None and (
        tuple(law.population.groups) != law.groups or tuple(law.population.contexts) != law.contexts
    ):
        raise InputError(
            "population",
            "labels must be the audited law's contexts and groups",
            (list(map(format_label, law.population.contexts)), list(map(format_label, law.population.groups))),
        )
    return law


def _estimates(table: CountTable, counts: FloatArray, utility: Utility, law: _AuditedLaw) -> dict[str, float]:
    """Plug-in values of every metric for the law ``counts`` / their row sums (NaN where empty cells matter).

    ``counts`` are the table's, plus the prior's pseudo-counts c/K for the posterior mean of ``"bayes"``
    ((n + c/K) / (N + c), AIF360's smoothing). The population defaults to the records' own.
    """
    if law.sensitive_mechanism is not None:
        if np.any(sum_last(counts) == 0):
            return {}
        kernel = Kernel.from_counts(counts, table.contexts, table.groups, table.decisions)
        plugin = compose(kernel, law.sensitive_mechanism, law.context_mechanism)
    else:
        plugin = Law.from_counts(counts, table.contexts, table.groups, table.decisions)
    o = observe(plugin, utility, law.population if law.population is not None else table.population())
    return {key: getattr(o, name).value for key, name in METRIC_ATTRIBUTES.items()}


def _assemble(
    projection: Projection, options: ProjectionOptions, law: _AuditedLaw, estimate: dict[str, float]
) -> dict[str, Any]:
    """The fields of :class:`FairnessIntervals` but the inputs counted: each metric's interval, the boxes, the sets
    and the notes the projection gives, and the filter and population of the audited law."""
    confidence = 1.0 - options.alpha
    made: dict[str, Any] = {"method": options.method, "confidence": confidence}
    made |= {name: getattr(law, name) for name in ("sensitive_mechanism", "context_mechanism", "population")}
    for key, name in METRIC_ATTRIBUTES.items():
        ends = projection.ends.get(key)
        made[name] = (
            None if ends is None else _interval(key, ends, law, estimate.get(key, math.nan), confidence, options.method)
        )
    assert made["local_fairness"] is not None and made["global_fairness"] is not None  # always computed
    return made | {name: value for name, value in projection._asdict().items() if name != "ends"}  # boxes, sets, notes


def _interval(
    name: str, ends: MetricEnds, law: _AuditedLaw, estimate: float, confidence: float, method: str
) -> Interval:
    """One metric's Interval from its ends per map (contexts for local metrics, one map for global ones).

    The interval is the widest over the maps: the largest lower end and the largest upper end, with the context
    and pair of groups where the upper end is attained. Ratios are reported in nats.
    """
    (lower, upper, fav, oth), keys = ends
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    if np.all(np.isnan(upper)):
        return Interval(math.nan, math.nan, estimate, confidence, method)
    m = int(np.nanargmax(upper))
    lo, hi = float(np.nanmax(lower)), float(upper[m])
    if name not in ("demographic_parity", "equalized_odds"):
        lo, hi = safe_log(max(lo, 1.0)), safe_log(max(hi, 1.0))
    return Interval(
        lo,
        hi,
        float(estimate),
        confidence,
        method,
        law.contexts[list(keys)[m]] if name in _LOCAL else None,
        law.groups[int(fav[m])],
        law.groups[int(oth[m])],
    )
