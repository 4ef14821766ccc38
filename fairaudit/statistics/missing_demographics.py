"""Impact ratios when some applicants did not give their category: sharp bounds over every way they could belong to
the categories, and the ACLU's two published variants for comparison.

A bias audit (6 RCNY § 5-301) reports the number of applicants of unknown category apart from the categories. Each
of them belongs to some category, so each category's rate and impact ratio lies in the range they take over every
allocation of the unknown applicants (N of them, S selected) to the categories. The bounds are sharp: each is
reached by an allocation (:attr:`MissingDataBounds.lower_comparator` names the highest-rate category there), and the
highest-rate comparator moves with the allocation. The derivation is ``proofs/impact_ratio.md`` §4:

* a rate is highest with every selected unknown in its category and lowest with every unselected one there:
  (s + S)/(n + S) and s/(n + U), U = N − S (with one category, all of them are in it);
* the lowest impact ratio puts the U unselected unknowns in the category and the S selected ones in the single
  other category whose rate that raises most;
* the highest puts the S selected ones in the category and spreads the U unselected ones over the others so that
  their highest rate is least (water-filling: in whole applicants when every count is whole, exactly).

The ACLU's study of published audits (Gerchick et al., "Auditing the Audits", FAccT 2025; their ``calc_audit_bounds``)
bounds each row instead with all N unknowns in the row's category (all selected, or none), or N times the
category's share of the known applicants, and the comparator rate held at its published value:
:func:`aclu_bounds`.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import TYPE_CHECKING, cast

import numpy as np

from fairaudit.base.errors import InputError

if TYPE_CHECKING:
    from fairaudit.laws.utilities import Utility
    from fairaudit.statistics.ll144 import ImpactRatio

__all__ = ["MissingDataBounds", "aclu_bounds", "missing_data_bounds", "unknown_ranges"]


@dataclass(frozen=True)
class MissingDataBounds:
    """Sharp bounds on each category's rate and impact ratio over every allocation of the unknown applicants.

    Attributes
    ----------
    categories : tuple of hashable
        The categories, in the order given.
    applicants, selected : tuple of Fraction
        n and s per category (the counts as given, exactly).
    unknown_applicants, unknown_selected : Fraction
        N and S of the unknown category.
    whole : bool
        Allocations in whole applicants (every count whole) rather than in shares of one.
    rate_lower, rate_upper : tuple of Fraction
        Each category's least and greatest rate, in [0, 1].
    ratio_lower, ratio_upper : tuple of Fraction
        Each category's least and greatest impact ratio, in [0, 1] (0/0 = 1: every rate 0).
    lower_comparator, upper_comparator : tuple of hashable
        The highest-rate category at the allocation that reaches ``ratio_lower`` (``ratio_upper``); the category
        itself where its ratio is 1 there.
    """

    categories: tuple[Hashable, ...]
    applicants: tuple[Fraction, ...]
    selected: tuple[Fraction, ...]
    unknown_applicants: Fraction
    unknown_selected: Fraction
    whole: bool
    rate_lower: tuple[Fraction, ...]
    rate_upper: tuple[Fraction, ...]
    ratio_lower: tuple[Fraction, ...]
    ratio_upper: tuple[Fraction, ...]
    lower_comparator: tuple[Hashable, ...]
    upper_comparator: tuple[Hashable, ...]

    def can_flip(self, threshold: float = 0.8) -> tuple[bool, ...]:
        """Per category, whether some allocation puts its impact ratio below ``threshold`` and another at or
        above it: its mark against the threshold depends on the unknowns."""
        t = Fraction(threshold)
        return tuple(lo < t <= hi for lo, hi in zip(self.ratio_lower, self.ratio_upper, strict=True))


def missing_data_bounds(
    categories: Sequence[Hashable],
    applicants: Sequence[float],
    selected: Sequence[float],
    unknown_applicants: float,
    unknown_selected: float,
) -> MissingDataBounds:
    """Sharp bounds on every category's rate and impact ratio over every allocation of the unknown applicants.

    Parameters
    ----------
    categories : sequence of hashable, length k ≥ 1
        The categories of one category type that the impact ratios compare (the included ones).
    applicants, selected : sequence of float, length k
        Per category, n > 0 applicants and 0 ≤ s ≤ n selected (for scoring rates: scoring above the median); any
        nonnegative reals (weights, scaled counts), read exactly.
    unknown_applicants, unknown_selected : float
        N ≥ 0 applicants of unknown category, 0 ≤ S ≤ N of them selected.

    Returns
    -------
    MissingDataBounds
        In whole applicants when every count is whole, else in shares (each unknown split over the categories).

    Raises
    ------
    InputError
        A count that is negative, not finite, or selected above applicants (naming it); lengths that differ.

    Notes
    -----
    ``proofs/impact_ratio.md`` §4; ``tests/statistics/test_missing_demographics.py`` checks every bound against a
    brute force over every allocation.

    Examples
    --------
    Two categories, 10 of 20 and 8 of 20 selected, 5 unknown of whom 2 were selected. B's ratio is 0.8 without
    them; with them it lies between 8/23 / 12/22 and 10/22 / 10/23 (capped at 1):

    >>> b = missing_data_bounds(["A", "B"], [20, 20], [10, 8], 5, 2)
    >>> [str(v) for v in (b.ratio_lower[1], b.ratio_upper[1])], b.lower_comparator[1], b.upper_comparator[1]
    (['44/69', '1'], 'A', 'B')
    >>> b.can_flip(0.8)
    (False, True)
    """
    n, s = _counts(applicants, "applicants"), _counts(selected, "selected")
    (big_n,) = _counts([unknown_applicants], "unknown_applicants")
    (big_s,) = _counts([unknown_selected], "unknown_selected")
    if not len(n) == len(s) == len(categories) >= 1:
        raise InputError("applicants", "needs one count per category, as selected does", len(n))
    for name, tops, lows in (("selected", n, s), ("unknown_selected", [big_n], [big_s])):
        for i, (high, value) in enumerate(zip(tops, lows, strict=True)):
            if value > high:
                raise InputError(name, f"exceeds its applicants ({float(high):g}) at position {i}", float(value))
    if any(v == 0 for v in n):
        raise InputError("applicants", "must be positive for every compared category", [float(v) for v in n])
    whole = all(v.denominator == 1 for v in (*n, *s, big_n, big_s))
    unselected = big_n - big_s
    if len(n) == 1:  # every unknown is in the one category
        rate_lo = rate_hi = [(s[0] + big_s) / (n[0] + big_n)]
    else:
        rate_lo = [si / (ni + unselected) for ni, si in zip(n, s, strict=True)]
        rate_hi = [(si + big_s) / (ni + big_s) for ni, si in zip(n, s, strict=True)]
    ratio_lo, ratio_hi, comp_lo, comp_hi = [], [], [], []
    for j in range(len(n)):
        others = [k for k in range(len(n)) if k != j]
        top = max(others, key=lambda k: rate_hi[k], default=j)  # every selected unknown in one other category
        value, at = _ratio(rate_lo[j], rate_hi[top] if others else rate_lo[j])
        ratio_lo.append(value)
        comp_lo.append(categories[top if at else j])
        level, where = _least_top([n[k] for k in others], [s[k] for k in others], unselected, whole)
        value, at = _ratio(rate_hi[j], level if others else rate_hi[j])
        ratio_hi.append(value)
        comp_hi.append(categories[others[where] if at else j])
    return MissingDataBounds(
        tuple(categories), tuple(n), tuple(s), big_n, big_s, whole, tuple(rate_lo), tuple(rate_hi),
        tuple(ratio_lo), tuple(ratio_hi), tuple(comp_lo), tuple(comp_hi),
    )  # fmt: skip


def aclu_bounds(
    applicants: Sequence[float],
    selected: Sequence[float],
    unknown_applicants: float,
    comparator_rate: float,
    proportional: bool = False,
) -> tuple[list[float], list[float]]:
    """The ACLU's bounds on each row's impact ratio (Gerchick et al., FAccT 2025, ``calc_audit_bounds``): the
    row's rate with the N unknowns added to its category, all selected (upper) or none (lower), over the comparator
    rate held fixed.

    Parameters
    ----------
    applicants, selected : sequence of float, length k
        n and s per category.
    unknown_applicants : float
        N.
    comparator_rate : float
        The rate the ratios divide by (the published highest rate), > 0.
    proportional : bool
        Their second variant: add N times the category's share of the known applicants instead of N.

    Returns
    -------
    (lower, upper) : two lists of float, length k
        ``(s)/(n + m) / comparator_rate`` and ``(s + m)/(n + m) / comparator_rate``, m = N or N·n/Σn. Not capped at
        1 and not sharp: the comparator does not move (:func:`missing_data_bounds` gives the sharp range).

    Examples
    --------
    >>> aclu_bounds([20, 20], [10, 8], 5, 0.5)
    ([0.8, 0.64], [1.2, 1.04])
    """
    total = math.fsum(applicants)
    added = [unknown_applicants * n / total if proportional else unknown_applicants for n in applicants]
    counts = list(zip(applicants, selected, added, strict=True))
    lower = [s / (n + m) / comparator_rate for n, s, m in counts]
    upper = [(s + m) / (n + m) / comparator_rate for n, s, m in counts]
    return lower, upper


def unknown_ranges(
    rows: list[ImpactRatio],
    outcomes: tuple[tuple[Hashable, float], ...],
    decisions: tuple,
    g: Utility,
    median: float | None,
) -> list[ImpactRatio]:
    """The rows of one category type of :func:`~fairaudit.statistics.ll144.impact_ratios` with each included
    category's ratio range over every allocation of its unknown records (their outcomes and numbers ``outcomes``; g
    of each from the decisions, or 1{score > median} for scores): :func:`missing_data_bounds`, sharp, and the ACLU's
    two variants (:func:`aclu_bounds`).

    Parameters
    ----------
    rows : list of ImpactRatio
        One category type's rows, as :func:`~fairaudit.statistics.ll144.impact_ratios` computes them.
    outcomes : tuple of (outcome, number) pairs
        The unknown records' outcomes and how many have each.
    decisions : tuple
        The outcome values, in the order of ``g.values``.
    g : Utility
        The 0/1 utility of a selection (or of a score above ``median``).
    median : float, optional
        The scores' median, for a scoring rate; None for a selection rate.

    Returns
    -------
    list of ImpactRatio
        ``rows`` with each included category's ratio range set; unchanged when there is no unknown record or fewer
        than two included categories.
    """
    included = [i for i, r in enumerate(rows) if not r.excluded]
    if not outcomes or len(included) < 2:
        return rows
    at = {d: v for d, v in zip(decisions, np.asarray(g.values, dtype=float).tolist(), strict=True)}
    if median is not None:
        at = {v: float(float(cast(float, v)) > median) for v, _ in outcomes}  # (scores)
    if any(v not in at for v, _ in outcomes):
        return rows  # an outcome no known record has: g is not known there
    total = math.fsum(w for _, w in outcomes)
    chosen = math.fsum(w * at[v] for v, w in outcomes)
    bounds = missing_data_bounds(
        [rows[i].category for i in included], [rows[i].n for i in included], [rows[i].selected for i in included],
        total, chosen,
    )  # fmt: skip
    n, k = [rows[i].n for i in included], [rows[i].selected for i in included]
    top = max(rows[i].rate for i in included)
    (low, high), (low_p, high_p) = (aclu_bounds(n, k, total, top or 1.0, p) for p in (False, True))
    out = list(rows)
    for j, (i, lo, hi) in enumerate(zip(included, bounds.ratio_lower, bounds.ratio_upper, strict=True)):
        aclu = ((low[j], high[j]), (low_p[j], high_p[j])) if top > 0 else None
        out[i] = replace(rows[i], unknown_range=(float(lo), float(hi)), aclu_ranges=aclu)
    return out


def _counts(values: Sequence[float], name: str) -> list[Fraction]:
    """The counts as exact Fractions: finite and nonnegative, else an InputError naming the first offender."""
    out = []
    for i, v in enumerate(values):
        if isinstance(v, (bool, str, bytes)):
            raise InputError(name, f"must be numbers (position {i})", v)
        try:
            x = Fraction(v) if isinstance(v, (int, Fraction)) else Fraction(float(v))
        except (TypeError, ValueError, OverflowError):
            raise InputError(name, f"must be finite nonnegative numbers (position {i})", v) from None
        if x < 0:
            raise InputError(name, f"must be nonnegative (position {i})", v)
        out.append(x)
    return out


def _ratio(rate: Fraction, other: Fraction) -> tuple[Fraction, bool]:
    """rate / max(rate, other) with 0/0 = 1, and whether ``other`` is the larger (the comparator)."""
    top = max(rate, other)
    return (Fraction(1) if top == 0 else rate / top), other > rate


def _least_top(n: list[Fraction], s: list[Fraction], extra: Fraction, whole: bool) -> tuple[Fraction, int]:
    """The least highest rate s_k/(n_k + c_k) over every spread c ≥ 0 of ``extra`` unselected applicants (whole
    ones when ``whole``), and the category that holds it; (0, 0) with no category.

    A level t is reachable when the applicants it needs, Σ max(0, s_k/t − n_k) (rounded up to whole ones), are at
    most ``extra``. In shares the least level fills the highest rates down to one water level; in whole applicants
    it is one of the values s_k/(n_k + c), found per k by bisection on c (reachability is monotone in t).
    """
    if all(v == 0 for v in s):  # (no other category, or none selected)
        return Fraction(0), 0

    def need(t: Fraction) -> Fraction:
        return sum((_spread(nk, sk, t, whole) for nk, sk in zip(n, s, strict=True)), Fraction(0))

    best: tuple[Fraction, int] | None = None
    for k, (nk, sk) in enumerate(zip(n, s, strict=True)):
        if sk == 0:
            continue
        if whole:  # the largest c ≤ extra whose level s_k/(n_k + c) is reachable
            lo, hi = 0, int(extra)
            while lo < hi:
                mid = (lo + hi + 1) // 2
                lo, hi = (mid, hi) if need(sk / (nk + mid)) <= extra else (lo, mid - 1)
            level = sk / (nk + lo)
        else:  # the water level if k is among the filled: Σ_top s / (Σ_top n + extra) over the rates ≥ s_k/n_k
            top = [i for i in range(len(n)) if s[i] * nk >= sk * n[i]]
            level = sum((s[i] for i in top), Fraction(0)) / (sum((n[i] for i in top), Fraction(0)) + extra)
            if need(level) > extra or level > sk / nk:
                continue
        if need(level) <= extra and (best is None or level < best[0]):
            best = (level, k)
    assert best is not None  # (the largest rate's own level is reachable)
    level, _ = best
    holder = max(range(len(n)), key=lambda k: s[k] / (n[k] + _spread(n[k], s[k], level, whole)))
    return level, holder


def _spread(nk: Fraction, sk: Fraction, level: Fraction, whole: bool) -> Fraction:
    """The unselected applicants category k needs to reach ``level`` (none at or below it)."""
    if level == 0:
        return Fraction(0)
    need = sk / level - nk
    return Fraction(max(0, math.ceil(need))) if whole else max(Fraction(0), need)
