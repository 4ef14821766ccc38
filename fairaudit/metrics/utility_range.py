"""L and L̄ over every value of a decision whose utility is known only within [low, high]: the unparsed reply.

A model's reply that parses as no option is a decision ("unparsed") whose
utility nobody stated; a default (such as the expected g of a uniformly random
reply) is a convention, not a measurement. :func:`fairness_range` gives L and
L̄ behind the filter as the exact range over every assignment of that
decision's utility in [low, high], chosen independently for every cell of the
kernel, next to the value under the stated utility.

Each kernel cell's expected utility then ranges over an interval, and the
cells are independent: a box. Behind the filter every group's expectation is a
fixed mixture of kernel cells, so the ends are those of
:func:`fairaudit.metrics.box_extremes.mixed_ratio` (the upper end by the threshold rule of
each pair's linear-fractional program, the lower end by a Charnes–Cooper LP), the
same machinery as the confidence intervals. Proof: ``proofs/unparsed.md``.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number
from fairaudit.laws.composition import compose
from fairaudit.laws.mechanisms import Mechanism, identity
from fairaudit.laws.tables import Kernel, Law, Population, population_for
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.box_extremes import MinMaxRatio, mixed_ratio, pair_floors
from fairaudit.metrics.fairness import global_fairness, local_fairness

__all__ = ["FairnessRange", "UtilityRange", "fairness_range"]


@dataclass(frozen=True, eq=False, kw_only=True)
class FairnessRange:
    """L (or L̄) under the stated utility and its range over the box of the unknown decision's utility.

    Attributes
    ----------
    kind : {"local", "global"}
    value : float
        Under the utility as stated (nats): the value the certificate reports.
    lower, upper : float
        The ends of the range (nats; +inf when a group can have expected utility 0 while another's is
        positive; NaN with fewer than two groups; ``lower`` NaN, and its cells None, when
        :func:`fairness_range` was asked for the upper end only).
    exact : bool
        Whether ``lower`` is the exact minimum. The upper end is always exact; the local lower end is
        exact when the context mechanism is the identity (contexts use disjoint kernel cells), otherwise
        it is the largest per-context minimum, a valid lower end (an outer range).
    lower_context, upper_context : hashable or None
        The context of each end (local only): the context whose own range attains it.
    upper_group, upper_other_group : hashable or None
        The pair attaining the upper end (``upper_group`` has the larger expected utility).
    lower_group, lower_other_group : hashable or None
        In ``lower_context``: the pair whose own smallest ratio over the box is the largest, a floor that
        no assignment goes below (equal to ``lower`` when the groups use disjoint kernel cells, as without
        a filter).
    """

    kind: str
    value: float
    lower: float
    upper: float
    exact: bool
    lower_context: Hashable | None
    upper_context: Hashable | None
    lower_group: Hashable | None
    lower_other_group: Hashable | None
    upper_group: Hashable | None
    upper_other_group: Hashable | None

    def to_dict(self) -> Report:
        """``{"range": [lower, upper], "exact": ..., "lower": {...}, "upper": {...}}``: the ends with their cells."""

        def end(context: Hashable | None, group: Hashable | None, other: Hashable | None) -> Report:
            d: Report = {"context": label(context)} if self.kind == "local" else {}
            return d | {"group": label(group), "other_group": label(other)}

        return {
            "range": [number(self.lower), number(self.upper)],
            "exact": self.exact,
            "lower": end(self.lower_context, self.lower_group, self.lower_other_group),
            "upper": end(self.upper_context, self.upper_group, self.upper_other_group),
        }


@dataclass(frozen=True, eq=False, kw_only=True)
class UtilityRange:
    """The result of :func:`fairness_range`: its inputs, the box of kernel-cell expectations and both ranges.

    Attributes
    ----------
    kernel : Kernel or Law
    utility : Utility
    decision : hashable
        The decision whose utility is known only within [low, high] (its label).
    low, high : float
        The interval of its utility.
    sensitive_mechanism, context_mechanism : Mechanism
        M_A and M_X (identities when none was given).
    population : Population
    kernel_lower, kernel_upper : numpy.ndarray, shape (n_released_contexts, n_released_groups)
        The box: each kernel cell's expected utility with the decision's utility at ``low`` and ``high``.
    local_fairness, global_fairness : FairnessRange

    Examples
    --------
    Group b's kernel cell puts 0.2 on the unparsed reply, whose utility (stated 0) lies anywhere in [0, 1]:

    >>> from fairaudit import Kernel, Utility
    >>> k = Kernel([[[0.5, 0.5, 0.0], [0.2, 0.6, 0.2]]], ["x"], ["a", "b"], ["yes", "no", "unparsed"])
    >>> r = fairness_range(k, Utility([1.0, 0.0, 0.0], ["yes", "no", "unparsed"]))
    >>> r.decision, (r.low, r.high), r.kernel_lower.tolist(), r.kernel_upper.tolist()
    ('unparsed', (0.0, 1.0), [[0.5, 0.2]], [[0.5, 0.4]])
    >>> [round(math.exp(v), 6) for v in (r.local_fairness.lower, r.local_fairness.upper)]  # 0.5/0.4 and 0.5/0.2
    [1.25, 2.5]
    """

    kernel: Kernel | Law
    utility: Utility
    decision: Hashable
    low: float
    high: float
    sensitive_mechanism: Mechanism
    context_mechanism: Mechanism
    population: Population
    kernel_lower: FloatArray
    kernel_upper: FloatArray
    local_fairness: FairnessRange
    global_fairness: FairnessRange


def _log(r: float) -> float:
    return math.log(r) if r > 0 else (math.nan if math.isnan(r) else -math.inf)


def _lower_pair(W: FloatArray, lo: FloatArray, hi: FloatArray) -> tuple[int, int]:
    """The pair (a, a') of the largest min over the box of (W_a·e)/(W_a'·e) (:func:`pair_floors`)."""
    return divmod(int(pair_floors(W, lo, hi).argmax()), len(W))


def fairness_range(
    kernel: Kernel | Law,
    utility: Utility,
    decision: int = -1,
    *,
    low: float | None = None,
    high: float | None = None,
    sensitive_mechanism: Mechanism | None = None,
    context_mechanism: Mechanism | None = None,
    population: Population | None = None,
    lower_end: bool = True,
) -> UtilityRange:
    """L and L̄ behind the filter over every utility of one decision in [low, high], per kernel cell.

    Proof: ``proofs/unparsed.md``.

    Every cell (x̃, ã) of the kernel gets its own value v(x̃, ã) ∈ [low, high] for decision ``decision``;
    the other decisions keep g(u). A cell's expected utility then spans
    ``[Σ_{u ≠ d} K[x̃, ã, u] g(u) + K[x̃, ã, d]·low, ... + K[x̃, ã, d]·high]``, independently of the other
    cells. Over that box, with Q = compose(K, M_A, M_X): the upper end of L is the max over contexts and
    pairs of the threshold solution of each pair's linear-fractional program; its lower end is, per
    context, min over the box of max_a E_a / min_a E_a (a Charnes–Cooper LP), maxed over contexts (exact
    when M_X is the identity, otherwise a valid lower end); L̄ mixes the cells by P(x | a) the same way.

    Parameters
    ----------
    kernel : Kernel or Law
        P(U | X̃, Ã), shape (n_released_contexts, n_released_groups, n_decisions). A :class:`~fairaudit.laws.tables.Law`
        is the law behind the filter observed directly (the experiments' paper design): its cells are the kernel's
        with identity mechanisms, no mechanism may be given, the values are its own metrics', and its empty cells
        are left out as the metrics leave them out.
    utility : Utility
        g(u), shape (n_decisions,), over the kernel's decisions (a utility that depends on the context or the
        group is refused).
    decision : int
        Index of the decision whose utility is unknown; default the last (``"unparsed"``).
    low, high : float, optional
        Its utility's interval; default min g and max g over all decisions.
    sensitive_mechanism, context_mechanism : Mechanism, optional
        M_A (outputs the kernel's groups) and M_X (outputs its contexts); default identities.
    population : Population, optional
        P(X, A) over the mechanisms' inputs (default as :func:`fairaudit.metrics.fairness.global_fairness`).
    lower_end : bool
        False: the upper ends only, without the lower ends' LPs (``lower`` is NaN, its cells None), for a caller
        that needs the upper end at many ε (white-box calibration on the upper end,
        :func:`fairaudit.worstcase.calibration.calibrate` with ``unparsed_decision``). The upper ends are the same either way.

    Returns
    -------
    UtilityRange
        In nats, with the value under ``utility`` as stated and the cells attaining each end.

    Raises
    ------
    InputError
        On a utility that depends on context or group, a decision index out of range, low > high, or a mechanism
        given with a Law.

    Examples
    --------
    Two groups, no filter; "unparsed" counts 0.5 by default and is known only within [0, 1]. Group a's
    expected utility spans [0.5, 0.8], b's [0.2, 0.7]: the ratio ranges over [max(1, 0.5/0.7), 0.8/0.2].

    >>> from fairaudit import Kernel, Utility
    >>> k = Kernel([[[0.5, 0.2, 0.3], [0.2, 0.3, 0.5]]], ["x"], ["a", "b"], ["yes", "no", "unparsed"])
    >>> r = fairness_range(k, Utility([1.0, 0.0, 0.5], ["yes", "no", "unparsed"]))
    >>> [round(math.exp(v), 6) for v in (r.local_fairness.value, r.local_fairness.lower, r.local_fairness.upper)]
    [1.444444, 1.0, 4.0]
    >>> r.local_fairness.upper_group, r.local_fairness.upper_other_group
    ('a', 'b')
    """
    g, d, lo_g, hi_g = _unknown_decision(kernel, utility, decision, low, high, sensitive_mechanism, context_mechanism)
    m_a = sensitive_mechanism if sensitive_mechanism is not None else identity(kernel.groups)
    m_x = context_mechanism if context_mechanism is not None else identity(kernel.contexts)
    law = kernel if isinstance(kernel, Law) else compose(kernel, m_a, m_x)
    pop = population_for(law, population)
    local, glob = local_fairness(law, utility, pop), global_fairness(law, utility, pop)

    k = np.nan_to_num(kernel.probabilities, nan=0.0)
    rest = k @ np.where(np.arange(len(g)) == d, 0.0, g)  # (X̃, Ã): the known decisions' part
    e_lo, e_hi = rest + k[..., d] * lo_g, rest + k[..., d] * hi_g
    attained = lo_g <= g[d] <= hi_g  # the stated value is one assignment: the range holds it
    # no mass on the decision: every utility of it gives the stated law, the range is a point
    point = not k[..., d].any()
    solver: dict[tuple[int, int], MinMaxRatio] = {}
    keys = np.flatnonzero(pop.p_context > 0)
    nan = FairnessRange(
        kind="local", value=local.value, lower=math.nan, upper=math.nan, exact=True, lower_context=None,
        upper_context=None, lower_group=None, lower_other_group=None, upper_group=None, upper_other_group=None,
    )  # fmt: skip
    global_nan = FairnessRange(**{**nan.__dict__, "kind": "global", "value": glob.value})
    local_range, global_range = nan, global_nan
    if len(m_a.inputs) >= 2 and len(keys) > 0:
        found = _local_range(kernel, m_a, m_x, keys, e_lo, e_hi, solver, lower_end)
        local_range = nan if found is None else _range("local", local.value, found, attained, point)
        found = _global_range(pop, m_a, m_x, e_lo, e_hi, solver, lower_end)
        global_range = global_nan if found is None else _range("global", glob.value, found, attained, point)
    return UtilityRange(
        kernel=kernel, utility=utility, decision=kernel.decisions[d], low=lo_g, high=hi_g, sensitive_mechanism=m_a,
        context_mechanism=m_x, population=pop, kernel_lower=e_lo, kernel_upper=e_hi, local_fairness=local_range,
        global_fairness=global_range,
    )  # fmt: skip


def _unknown_decision(
    kernel: Kernel | Law,
    utility: Utility,
    decision: int,
    low: float | None,
    high: float | None,
    sensitive_mechanism: Mechanism | None,
    context_mechanism: Mechanism | None,
) -> tuple[FloatArray, int, float, float]:
    """g(u) over the kernel's decisions, the unknown decision's index and its utility's interval [low, high], checked."""
    if not isinstance(kernel, (Kernel, Law)):
        raise InputError("kernel", "must be a Kernel or a Law", type(kernel).__name__)
    if isinstance(kernel, Law) and (sensitive_mechanism is not None or context_mechanism is not None):
        which = "sensitive_mechanism" if sensitive_mechanism is not None else "context_mechanism"
        raise InputError(which, "must not be given with a Law: it is the law behind the filter already")
    if np.ndim(utility.values) != 1:
        raise InputError("utility", "must depend on the decision only (g(u))", np.shape(utility.values))
    g = np.asarray(utility.table((kernel.context_labels[0],), kernel.groups[:1], kernel.decisions)[0, 0], float)
    n_d = len(g)
    if not -n_d <= decision < n_d:
        raise InputError("decision", f"must index one of the {n_d} decisions", decision)
    lo_g = float(g.min()) if low is None else float(low)
    hi_g = float(g.max()) if high is None else float(high)
    if not lo_g <= hi_g:
        raise InputError("low", f"must be at most high = {hi_g:g}", lo_g)
    return g, decision % n_d, lo_g, hi_g


_End = tuple[float, Hashable | None, Hashable | None, Hashable | None]  # a ratio and its (context, group, other group)
_Ends = tuple[_End, _End, bool]  # the lower end (ratio NaN when not computed), the upper end, whether it is exact


def _local_range(
    kernel: Kernel | Law,
    m_a: Mechanism,
    m_x: Mechanism,
    keys: IntArray,
    e_lo: FloatArray,
    e_hi: FloatArray,
    solver: dict[tuple[int, int], MinMaxRatio],
    lower_end: bool,
) -> _Ends | None:
    """The ends of the range of L: the largest of the contexts'; None when no context has two groups with records.

    Per context x of ``keys``: the smallest and the largest ratio over the box (the smallest NaN without
    ``lower_end``), the pair attaining the largest, the context's program, and its groups' positions in M_A's.
    """
    Wa = m_a.matrix
    if m_x.is_identity:  # context x mixes its own cells only: per-context programs
        # a Law's empty cells (identity M_A: compose refuses them behind a filter) are left out of their context,
        # as the metrics leave them out; a context with fewer than two groups with records has no ratio
        subs = [slice(None) if kernel.complete else np.flatnonzero(kernel.observed[x]) for x in keys]
        maps = [(Wa[s][:, s], e_lo[x, s], e_hi[x, s]) for x, s in zip(keys, subs)]
        none = (np.array([math.nan]), np.array([math.nan]), np.array([0]), np.array([0]))
        per = [mixed_ratio(w[None], lo, hi, solver, lower_end) if len(w) >= 2 else none for w, lo, hi in maps]
        lows, ups = np.array([p[0][0] for p in per]), np.array([p[1][0] for p in per])
        index = [np.arange(len(Wa))[s] for s in subs]  # a context's own group positions, in the kernel's
        favs, oths = [int(i[p[2][0]]) for i, p in zip(index, per)], [int(i[p[3][0]]) for i, p in zip(index, per)]
    else:
        X, A = len(m_x.inputs), len(m_a.inputs)
        Wl = np.einsum("xy,ab->xayb", m_x.matrix, Wa).reshape(X, A, -1)[keys]
        flat_lo, flat_hi = e_lo.reshape(-1), e_hi.reshape(-1)
        lows, ups, fav_a, oth_a = mixed_ratio(Wl, flat_lo, flat_hi, solver, lower_end)
        favs, oths = [int(v) for v in fav_a], [int(v) for v in oth_a]
        maps = [(Wl[i], flat_lo, flat_hi) for i in range(len(keys))]
        index = [np.arange(len(m_a.inputs))] * len(keys)
    groups, contexts = m_a.inputs, m_x.inputs
    if np.isnan(ups).all():  # (a Law in which no context has two groups with records)
        return None
    iu = int(np.nanargmax(ups))
    low_end: _End = (math.nan, None, None, None)
    if lower_end:
        il = int(np.nanargmax(lows))
        lg, lo_other = _lower_pair(*maps[il])
        low_end = (float(lows[il]), contexts[keys[il]], groups[index[il][lg]], groups[index[il][lo_other]])
    return low_end, (float(ups[iu]), contexts[keys[iu]], groups[favs[iu]], groups[oths[iu]]), m_x.is_identity


def _global_range(
    pop: Population,
    m_a: Mechanism,
    m_x: Mechanism,
    e_lo: FloatArray,
    e_hi: FloatArray,
    solver: dict[tuple[int, int], MinMaxRatio],
    lower_end: bool,
) -> _Ends | None:
    """The ends of the range of L̄: each group mixes the kernel cells by P(x | a); None with under two groups of P(a) > 0."""
    groups = m_a.inputs
    w = pop.context_given_group()
    w = np.where(np.isnan(w), 0.0, w)
    # groups with P(A = a) = 0 have no E[g | a] (the metrics' NaN): left out
    gk = slice(None) if (pop.p_group > 0).all() else np.flatnonzero(pop.p_group > 0)
    Wg = np.einsum("xa,xy,ab->ayb", w, m_x.matrix, m_a.matrix).reshape(len(groups), -1)[gk]
    gi = np.arange(len(groups))[gk]
    flat_lo, flat_hi = e_lo.reshape(-1), e_hi.reshape(-1)
    if len(gi) < 2:
        return None
    gl, gu, gf, go = mixed_ratio(Wg[None], flat_lo, flat_hi, solver, lower_end)
    low_end: _End = (math.nan, None, None, None)
    if lower_end:
        a, b = _lower_pair(Wg, flat_lo, flat_hi)
        low_end = (float(gl[0]), None, groups[gi[a]], groups[gi[b]])
    return low_end, (float(gu[0]), None, groups[gi[int(gf[0])]], groups[gi[int(go[0])]]), True


def _range(kind: str, value: float, ends: _Ends, attained: bool, point: bool) -> FairnessRange:
    """Ratios to nats; the stated value, when it is one assignment of the box, lies in the range (rounding).

    ``ends``: the lower and the upper end, each a ratio and its (context, group, other group) (the lower ratio NaN
    when not computed), and whether the upper end is exact.
    ``point``: the box is one law (no mass on the decision), so both ends are the stated value itself, as the
    metrics compute it, not the same number by another sum.
    """
    (lower_ratio, *lower_cells), (upper_ratio, *upper_cells), exact = ends
    lower, upper = _log(lower_ratio), _log(upper_ratio)
    if point and not math.isnan(value):
        lower, upper = (lower if math.isnan(lower_ratio) else value), value
    elif attained and not math.isnan(value):
        upper = max(upper, value)
        if not math.isnan(lower_ratio):
            lower = min(lower, value)
    return FairnessRange(
        kind=kind, value=value, lower=lower, upper=upper, exact=exact, lower_context=lower_cells[0],
        upper_context=upper_cells[0], lower_group=lower_cells[1], lower_other_group=lower_cells[2],
        upper_group=upper_cells[1], upper_other_group=upper_cells[2],
    )  # fmt: skip
