"""Small cells in an audit: a minimum cell size, the per-context table, and whether a cell can carry the headline.

On intersectional data the headline L is often +inf, driven by a (context,
group) cell of a few dozen records with no positive decision. These helpers
of :func:`fairaudit.audit` leave out cells below ``min_count`` (reported, not
silent), give L within each context with its pair of groups, and say when the
cell that drives L is smaller than the sample size at which the planner
(:func:`fairaudit.plan`) certifies L ≤ log 2 for a fair model at that
context's rate: such a cell cannot support the headline, and the evidence
lower bound of the intervals is the number to quote.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass, replace

import numpy as np

from fairaudit.base.checks import whole
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import format_label
from fairaudit.data.counts import CountTable
from fairaudit.metrics.fairness import Fairness

__all__ = ["LeftOut", "SmallCell", "by_context_rows", "leave_out_small", "small_cell", "small_cell_sentence"]

SUPPORT_TARGET = math.log(2.0)
"""The L (nats) the planner is asked to certify for a fair model: a ratio of 2 between groups."""


@dataclass(frozen=True)
class LeftOut:
    """A (context, group) cell left out of an audit for having fewer than ``min_count`` records."""

    context: Hashable
    group: Hashable
    n: float

    def to_dict(self) -> Report:
        return {"context": label(self.context), "group": label(self.group), "n": number(self.n)}

    def __str__(self) -> str:
        return f"cell (context {format_label(self.context)!r}, group {format_label(self.group)!r}): {self.n:g} records"


def leave_out_small(table: CountTable, min_count: int | None) -> tuple[CountTable, tuple[LeftOut, ...]]:
    """The table with every cell of fewer than ``min_count`` records (but some) emptied, and those cells.

    Raises
    ------
    InputError
        ``min_count`` not a whole number >= 1, or a group left with no records.
    """
    if min_count is None:
        return table, ()
    min_count = whole(min_count, "min_count", low=1)
    cells = table.cell_counts
    small = (cells > 0) & (cells < min_count)
    if not small.any():
        return table, ()
    left = tuple(LeftOut(table.contexts[i], table.groups[j], float(cells[i, j])) for i, j in np.argwhere(small))
    counts = np.where(small[..., None], 0, table.counts)
    squares = None if table.squares is None else np.where(small[..., None], 0.0, table.squares)
    reduced = replace(table, counts=counts, squares=squares)
    empty = [table.groups[j] for j in np.flatnonzero(reduced.group_counts == 0)]
    if empty:
        raise InputError("min_count", f"leaves group {format_label(empty[0])!r} with no records", min_count)
    return reduced, left


def by_context_rows(local: Fairness, table: CountTable, json: bool = False) -> list[Report]:
    """L within each context: ``context``, ``n`` (records), ``value`` (nats), ``ratio``, ``group``, ``other_group``.

    The pair is the groups of the largest and the smallest E[g | x, a] in the context (two groups with records
    at least; None otherwise). With ``json`` the values as the JSON report writes them (``"inf"``, labels).
    """
    as_label, as_number = (label, number) if json else ((lambda v: v), (lambda v: v))
    e = np.asarray(local.expected_utility, dtype=float)
    per = local.per_context if local.per_context is not None else np.full(len(e), np.nan)
    rows = []
    for i, x in enumerate(table.contexts):
        row = e[i]
        known = ~np.isnan(row)
        pair = known.sum() >= 2  # (a pair needs two groups with records)
        hi, lo = (int(np.nanargmax(row)), int(np.nanargmin(row))) if pair else (None, None)
        value = float(per[i])
        rows.append(
            {
                "context": as_label(x),
                "n": as_number(table.context_counts[i].item()),
                "value": as_number(value),
                "ratio": as_number(math.exp(value) if not math.isnan(value) else value),
                "group": None if hi is None else as_label(table.groups[hi]),
                "other_group": None if lo is None else as_label(table.groups[lo]),
            }
        )
    return rows


@dataclass(frozen=True)
class SmallCell:
    """The cell that drives L when it is too small to support it (see :func:`small_cell`)."""

    context: Hashable
    group: Hashable
    n: float
    needed: int
    rate: float

    def to_dict(self) -> Report:
        return {
            "context": label(self.context),
            "group": label(self.group),
            "n": number(self.n),
            "needed": self.needed,
            "rate": number(self.rate),
            "target": number(SUPPORT_TARGET),
        }

    def __str__(self) -> str:
        return small_cell_sentence(self.to_dict())


def small_cell_sentence(c: Report) -> str:
    """The headline's note from a :class:`SmallCell`'s dictionary: where L comes from, why it cannot carry it."""
    return (
        f"L is driven by cell (context {c['context']}, group {c['group']}) of {number_text(c['n'])} records, fewer "
        f"than the {c['needed']} per cell at which the planner certifies L <= log 2 for a fair model at the "
        f"context's rate {c['rate']:.3g} (power 0.8): that cell cannot support the headline; the evidence lower "
        "bound of L (with a confidence level) is the number to quote"
    )


def number_text(v: object) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def small_cell(local: Fairness, table: CountTable, binary: bool, confidence: float | None) -> SmallCell | None:
    """The cell of L's pair with the smaller E[g] in L's context, when it holds fewer records than the planner needs.

    Only for a 0/1 utility with a maximising pair (the planner counts positive decisions); the rate is the
    larger group's E[g | x, a] in that context (clipped to [0.01, 0.99]); the planner's defaults otherwise. The
    planner runs only when L is infinite or the cell holds fewer than 1000 records (else None).
    """
    if not binary or local.context is None or local.other_group is None or local.group is None:
        return None
    i = list(table.contexts).index(local.context)
    j_low, j_high = list(table.groups).index(local.other_group), list(table.groups).index(local.group)
    n = float(table.cell_counts[i, j_low])
    if math.isfinite(local.value) and n >= 1000:  # (a finite L from a cell this large: no plan)
        return None
    rate = float(np.clip(np.asarray(local.expected_utility)[i, j_high], 0.01, 0.99))
    from fairaudit.statistics.sample_size import plan  # (simulation: imported when an audit has a pair to check)

    needed = plan(
        SUPPORT_TARGET, groups=2, base_rate=rate, confidence=0.95 if confidence is None else confidence
    ).n_per_cell
    if needed is None or n >= needed:
        return None
    return SmallCell(local.context, local.other_group, n, int(needed), rate)
