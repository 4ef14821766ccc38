"""One simultaneous set projected onto every metric: the engine of :func:`fairaudit.statistics.intervals.fairness_intervals`.

A set maker (:func:`fairaudit.statistics.confidence_sets.binomial_sets`, or the
Bayesian band of :func:`fairaudit.statistics.bayes.band_sets`) gives a box for each
cell's decision distribution (and each pooled group's). :func:`project_sets`
turns that set into the ends of L, L̄, the sups over g, L_dp and L_eo: per
context for the local metrics, one map for the global ones. Without a filter
the groups' boxes are disjoint (closed forms of :mod:`fairaudit.metrics.box_extremes`);
behind one every group mixes the kernel cells (linear-fractional programs).
Proofs: ``proofs/intervals.md``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, TypeAlias

import numpy as np

from fairaudit.base.arrays import BoolArray, FloatArray, IntArray
from fairaudit.base.progress import progress_bar
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Population
from fairaudit.metrics.box_extremes import (
    MAX_EVENT_DECISIONS,
    Extremes,
    MinMaxRatio,
    disjoint_ratio,
    disjoint_tv,
    max_over,
    mixed_ratio,
    mixed_tv,
)
from fairaudit.statistics.confidence_sets import (
    SetMaker,
    binomial_sets,
    decision_events,
    event_extremes,
    linear_extremes,
    sum_last,
)

__all__ = ["MetricEnds", "Projection", "ProjectionOptions", "project_sets"]

MetricEnds: TypeAlias = tuple[Extremes, "IntArray | list[int]"]
"""One metric's ends per map, and the maps' context indices (``[0]`` for a global metric)."""


@dataclass(frozen=True)
class ProjectionOptions:
    """What :func:`project_sets` needs besides the counts and the utility.

    Attributes
    ----------
    method : {"clopper-pearson", "multinomial", "bayes"}
        ``"clopper-pearson"`` makes the sets for the event g = 1 only.
    alpha : float
        1 − the level of the simultaneous set.
    context_keep : numpy.ndarray of bool, shape (n_contexts,)
        The audited law's contexts the local metrics look at (P(x) > 0).
    population : Population or None
        P(X, A) of the audited law; None to pool each group's records.
    sensitive_mechanism, context_mechanism : Mechanism or None
        Behind a filter both are set (an identity for the unfiltered
        attribute); without one both are None.
    sets : SetMaker
        Makes the simultaneous set from the counts.
    cell_scale, group_scale : numpy.ndarray or None
        With sample weights: the factor n_eff / W of each cell (n_contexts,
        n_groups) and of each group pooled over contexts (n_groups,) that
        turns weighted counts into effective ones (Kish's n_eff = (Σ w)² /
        Σ w²); None for counts of records.
    """

    method: str
    alpha: float
    context_keep: BoolArray
    population: Population | None
    sensitive_mechanism: Mechanism | None = None
    context_mechanism: Mechanism | None = None
    sets: SetMaker = binomial_sets
    cell_scale: FloatArray | None = None
    group_scale: FloatArray | None = None


class Projection(NamedTuple):
    """The ends of every metric over one simultaneous set, with the bounds on cells and groups.

    Attributes
    ----------
    ends : dict of str to MetricEnds
        By metric name (``"local"``, ``"global"``, ``"sup_local"``,
        ``"sup_global"``, ``"demographic_parity"``, ``"equalized_odds"``);
        a metric left out was not computed (see ``notes``).
    cell_lower, cell_upper : numpy.ndarray, shape (n_contexts, n_groups)
        Bounds on E[g | x, a] of the audited law.
    group_lower, group_upper : numpy.ndarray, shape (n_groups,)
        Bounds on E[g | a].
    kernel_lower, kernel_upper : numpy.ndarray or None
        Behind a filter: bounds on E[g | x̃, ã] of the counted kernel.
    n_sets : int
        Bonferroni's m.
    notes : tuple of str
        What was not computed or is conservative, and why.
    """

    ends: dict[str, MetricEnds]
    cell_lower: FloatArray
    cell_upper: FloatArray
    group_lower: FloatArray
    group_upper: FloatArray
    kernel_lower: FloatArray | None
    kernel_upper: FloatArray | None
    n_sets: int
    notes: tuple[str, ...]


class _Categories(NamedTuple):
    """The counts the sets are made for, and the utility of each of their categories."""

    cells: FloatArray  # (X, A, K'): per cell, counts of the decisions (or of g = 0, g = 1)
    g_cells: FloatArray  # (X, A, K'): the utility of each category
    groups: FloatArray  # (A, C): pooled counts per group (of the joint (x, u) when g depends on the context)
    g_groups: FloatArray  # (A, C) or (C,)
    whole_u: bool  # the categories carry U's whole distribution (not only the event g = 1)
    joint: bool  # the groups' categories are the joint (x, u)


class _Boxes(NamedTuple):
    """The simultaneous set and its projections onto each cell's expectation and decision events."""

    cell_lower: FloatArray  # (X, A, K')
    cell_upper: FloatArray
    group_lower: FloatArray | None  # (A, C); None when the groups are not pooled
    group_upper: FloatArray | None
    e_lower: FloatArray  # (X, A): E[g | x, a]
    e_upper: FloatArray
    events: FloatArray  # (S, K')
    event_lower: FloatArray  # (S, X, A)
    event_upper: FloatArray
    n_sets: int


class _GroupBoxes(NamedTuple):
    """Bounds on each group's expectation, event probabilities and decision probabilities."""

    lower: FloatArray  # (A,)
    upper: FloatArray
    event_lower: FloatArray  # (S, A)
    event_upper: FloatArray
    u_lower: FloatArray  # (K', A)
    u_upper: FloatArray


def project_sets(counts: FloatArray, g: FloatArray, options: ProjectionOptions) -> Projection:
    """Make the simultaneous set of ``options.sets`` for ``counts`` and project it onto every metric.

    Parameters
    ----------
    counts : numpy.ndarray, shape (X, A, K)
        Whole counts: of the law, or behind a filter of the kernel on released values; or sums of
        sample weights with ``options.cell_scale`` and ``options.group_scale``.
    g : numpy.ndarray
        The utility over the table's decisions (shape (K,)) or cells (shape (X, A, K)).
    options : ProjectionOptions

    Returns
    -------
    Projection
    """
    cats = _categories(counts, g, options.method)
    if options.cell_scale is not None and options.group_scale is not None:  # weighted counts to effective ones
        cats = cats._replace(
            cells=cats.cells * options.cell_scale[..., None], groups=cats.groups * options.group_scale[:, None]
        )
    boxes = _boxes(cats, options)
    with_u = options.method != "clopper-pearson" or cats.whole_u
    local_keys = np.flatnonzero(options.context_keep)
    kernel: tuple[FloatArray | None, FloatArray | None]
    if options.sensitive_mechanism is None:
        ends, groups = _disjoint_ends(boxes, cats, options.population, local_keys, with_u)
        cells, kernel = (boxes.e_lower, boxes.e_upper), (None, None)
    else:
        ends, cells, groups = _mixed_ends(boxes, options, local_keys, with_u)
        kernel = (boxes.e_lower, boxes.e_upper)
    group_lower, group_upper = (np.asarray(v, float) for v in groups)
    notes = _notes(with_u, cats.cells.shape[-1])
    return Projection(ends, cells[0], cells[1], group_lower, group_upper, kernel[0], kernel[1], boxes.n_sets, notes)


def _categories(counts: FloatArray, g: FloatArray, method: str) -> _Categories:
    """The categories of each cell and pooled group: U's decisions, or (g = 0, g = 1) for ``"clopper-pearson"``."""
    X, A, K = counts.shape
    if method == "clopper-pearson":
        k = sum_last(counts * g)
        cells = np.stack([sum_last(counts) - k, k], -1)
        whole_u = K == 2 and not np.all(g == g[..., :1])
        return _Categories(
            cells, np.broadcast_to(np.array([0.0, 1.0]), (X, A, 2)), cells.sum(0), np.array([0.0, 1.0]), whole_u, False
        )
    gf = np.broadcast_to(g, (X, A, K))
    if bool(g.ndim == 3 and X > 1 and not np.all(g == g[:1])):  # g depends on the context
        groups = counts.transpose(1, 0, 2).reshape(A, X * K)  # joint (x, u) per group
        g_groups = g.transpose(1, 0, 2).reshape(A, X * K) if g.ndim == 3 else np.tile(g, X)
        return _Categories(counts, gf, groups, g_groups, True, True)
    return _Categories(counts, gf, counts.sum(0), gf[0], True, False)


def _boxes(cats: _Categories, options: ProjectionOptions) -> _Boxes:
    """The set of ``options.sets`` (pooled groups too when there is no population) and its linear projections."""
    X, A, kc = cats.cells.shape
    pooled = options.population is None  # unfiltered, records' own groups
    shared = pooled and X == 1 and cats.groups.shape[-1] == kc  # one context: groups are cells
    c_lo, c_hi, gc_lo, gc_hi, m = options.sets(cats.cells, cats.groups, pooled and not shared, options.alpha)
    if shared:
        gc_lo, gc_hi = c_lo[0], c_hi[0]
    e_lo, e_hi = linear_extremes(cats.g_cells, c_lo, c_hi)  # (X, A)
    events = decision_events(kc)
    ev_lo, ev_hi = (
        event_extremes(events, c_lo, c_hi) if len(events) else (np.zeros((0, X, A)), np.zeros((0, X, A)))
    )  # (S, X, A)
    return _Boxes(c_lo, c_hi, gc_lo, gc_hi, e_lo, e_hi, events, ev_lo, ev_hi, m)


def _notes(with_u: bool, kc: int) -> tuple[str, ...]:
    notes = []
    if not with_u:
        notes.append(
            "clopper-pearson bounds the event g = 1 only: the sups over g, L_dp and L_eo need U's whole "
            "distribution (use multinomial or bayes)"
        )
    if kc > MAX_EVENT_DECISIONS:
        notes.append(f"{kc} decisions: the upper ends of L_dp and L_eo use the coarser bound ½ Σ_u max |ΔP(u)|")
    return tuple(notes)


def _disjoint_ends(
    b: _Boxes, cats: _Categories, population: Population | None, keys: IntArray, with_u: bool
) -> tuple[dict[str, MetricEnds], tuple[FloatArray, FloatArray]]:
    """Without a filter: every metric's ends over disjoint group boxes, and the bounds on E[g | a]."""
    kc = b.cell_lower.shape[-1]
    ends: dict[str, MetricEnds] = {"local": (disjoint_ratio(b.e_lower[keys], b.e_upper[keys]), keys)}
    if with_u:
        sup = [disjoint_ratio(b.cell_lower[keys, :, u], b.cell_upper[keys, :, u]) for u in range(kc)]
        ends["sup_local"] = (max_over(sup), keys)
        ev_lo, ev_hi = b.event_lower[:, keys].transpose(1, 2, 0), b.event_upper[:, keys].transpose(1, 2, 0)
        ends["equalized_odds"] = (disjoint_tv(ev_lo, ev_hi, b.events, b.cell_lower[keys], b.cell_upper[keys]), keys)
    gb = _pooled_groups(b, cats) if population is None else _population_groups(b, population)
    ends["global"] = (disjoint_ratio(gb.lower[None], gb.upper[None]), [0])
    if with_u:
        sup = [disjoint_ratio(gb.u_lower[u][None], gb.u_upper[u][None]) for u in range(kc)]
        ends["sup_global"] = (max_over(sup), [0])
        ends["demographic_parity"] = (
            disjoint_tv(
                gb.event_lower.T[None], gb.event_upper.T[None], b.events, gb.u_lower.T[None], gb.u_upper.T[None]
            ),
            [0],
        )
    return ends, (gb.lower, gb.upper)


def _pooled_groups(b: _Boxes, cats: _Categories) -> _GroupBoxes:
    """Group bounds from the pooled groups' own sets (categories folded back into decisions when joint)."""
    assert b.group_lower is not None and b.group_upper is not None  # the group sets were asked for, or are the cells'
    X, _, kc = b.cell_lower.shape
    lower, upper = linear_extremes(cats.g_groups, b.group_lower, b.group_upper)
    fold = np.tile(np.eye(kc), (1, X)) if cats.joint else None  # (K, X·K): joint (x, u) categories -> decisions u
    gev = b.events @ fold if fold is not None else b.events  # (S, C)
    gev_lo, gev_hi = event_extremes(gev, b.group_lower, b.group_upper)  # (S, A)
    gu = fold if fold is not None else np.eye(kc)  # (K, C)
    gu_lo, gu_hi = event_extremes(gu, b.group_lower, b.group_upper)  # (K, A)
    return _GroupBoxes(lower, upper, gev_lo, gev_hi, gu_lo, gu_hi)


def _population_groups(b: _Boxes, population: Population) -> _GroupBoxes:
    """Group bounds as the population's mixtures E[g | a] = Σ_x P(x | a) E[g | x, a] of the cell bounds."""
    w = np.nan_to_num(population.context_given_group(), nan=0.0)  # (X, A); a group with P(a) = 0 weighs nothing
    absent = population.p_group <= 0
    lower, upper = (w * b.e_lower).sum(0), (w * b.e_upper).sum(0)
    gev_lo, gev_hi = np.einsum("xa,sxa->sa", w, b.event_lower), np.einsum("xa,sxa->sa", w, b.event_upper)
    gu_lo, gu_hi = np.einsum("xa,xak->ka", w, b.cell_lower), np.einsum("xa,xak->ka", w, b.cell_upper)
    lower, upper = np.where(absent, np.nan, lower), np.where(absent, np.nan, upper)
    return _GroupBoxes(lower, upper, gev_lo, gev_hi, gu_lo, gu_hi)


def _mixed_ends(
    b: _Boxes, options: ProjectionOptions, keys: IntArray, with_u: bool
) -> tuple[dict[str, MetricEnds], tuple[FloatArray, FloatArray], tuple[FloatArray, FloatArray]]:
    """Behind a filter: every metric's ends over the kernel box, and the bounds on E[g | x, a] and E[g | a]."""
    m_a, m_x, population = options.sensitive_mechanism, options.context_mechanism, options.population
    assert m_a is not None and m_x is not None and population is not None  # behind a filter all are set
    X, A, kc = b.cell_lower.shape
    mix = np.einsum("xy,ab->xayb", m_x.matrix, m_a.matrix)
    n_contexts, n_groups = mix.shape[0], mix.shape[1]
    Wl = mix.reshape(n_contexts, n_groups, X * A)
    w = np.nan_to_num(population.context_given_group(), nan=0.0)
    Wg = np.einsum("xa,xayb->ayb", w, mix).reshape(n_groups, X * A)
    flat_lo, flat_hi = b.e_lower.reshape(-1), b.e_upper.reshape(-1)
    Wsel = Wl[keys]
    solver: dict[tuple[int, int], MinMaxRatio] = {}
    steps = 2 * (len(keys) + 1) * (1 + kc if with_u else 1)  # each map's two ends (mixed_ratio), per ratio metric
    # drawn at once (no delay): its first step alone takes seconds on a large table; on a small one it is cleared
    # within milliseconds (and it runs once or twice per certify, not as often as the searches)
    with progress_bar(steps, "intervals", unit="step") as bar:
        ends: dict[str, MetricEnds] = {
            "local": (mixed_ratio(Wsel, flat_lo, flat_hi, solver, progress=bar.update), keys),
            "global": (mixed_ratio(Wg[None], flat_lo, flat_hi, solver, progress=bar.update), [0]),
        }
        if with_u:
            cl, ch = b.cell_lower.reshape(X * A, kc), b.cell_upper.reshape(X * A, kc)
            per_u = [mixed_ratio(Wsel, cl[:, u], ch[:, u], solver, progress=bar.update) for u in range(kc)]
            ends["sup_local"] = (max_over(per_u), keys)
            per_u = [mixed_ratio(Wg[None], cl[:, u], ch[:, u], solver, progress=bar.update) for u in range(kc)]
            ends["sup_global"] = (max_over(per_u), [0])
            n_events = len(b.events)
            el, eh = b.event_lower.reshape(n_events, X * A), b.event_upper.reshape(n_events, X * A)
            ends["equalized_odds"] = (mixed_tv(Wsel, el, eh, b.events, cl, ch), keys)
            ends["demographic_parity"] = (mixed_tv(Wg[None], el, eh, b.events, cl, ch), [0])
    cells = (np.einsum("xan,n->xa", Wl, flat_lo), np.einsum("xan,n->xa", Wl, flat_hi))
    return ends, cells, (Wg @ flat_lo, Wg @ flat_hi)
