"""Sample-size planning: how many queries per cell certify L ≤ target at level 1 − α.

The planned experiment queries a binary decision model n times in every cell
(x, a) (every released cell (x, ã) behind a privacy filter), counts the
positive decisions (an indicator utility g = 1{decision = 1}) and computes
the simultaneous intervals of :func:`fairaudit.statistics.intervals.fairness_intervals`.
The certificate is the upper end of the interval on L (or L̄); it *meets the
target* when that upper end is ≤ target. The planner simulates the
experiment under an assumed model and finds the smallest n whose simulated
probability of meeting the target (the power) is at least ``power``.

The assumed model: every cell has E[g | x, a] = ``base_rate``, except group 0,
which has ``base_rate · exp(disparity)`` (``disparity`` in nats; the true L
and L̄ are then |disparity|). With ``epsilon``, the model is queried on
released groups behind k-ary randomized response at that ε
(:func:`fairaudit.laws.closed_forms.randomized_response`): the rates above are those of
the model's kernel on released groups, the counts are of the kernel, and the
certificate is for the filtered law Q[x, a] = Σ_ã M[a, ã] K[x, ã] (whose true
L is smaller than |disparity|).

The exact power: for L without a filter by a frequentist method (:func:`exact_route`), a table's certificate
depends on each context's smallest and largest count alone, whose law is that of order statistics of independent
binomials: the power at n is computed from it (:func:`_order_power`), to within 1e-12, and no table is simulated
(``datasets`` is unused, None in the result). A plan of 10^6 cells takes about a second.

The simulation, for L̄, behind a filter and for ``"bayes"``: power at n is the fraction of ``datasets`` simulated count
tables whose certificate (the upper end of the simultaneous interval on L, or
on L̄ with ``kind="global"``, from :func:`fairaudit.statistics.intervals.fairness_intervals`
with a uniform independent population) is ≤ ``target``. The tables at n are
drawn afresh from ``numpy.random.default_rng(seed)`` as
``rng.binomial(n, rates, size=(datasets, contexts, groups))`` (positive
decisions; n − k negative), so every n uses the same random stream. They are
drawn and certified in chunks of tables that fit the memory limit
(``max_memory``) and :data:`CHUNK_BYTES`, one after the other along the first
axis: the same numbers as one draw, so the plan does not depend on the limit.
Inside :func:`~fairaudit.base.progress.progress_shown` (``fairaudit plan``
unless ``--no-progress``) each n shows a bar of its tables; Ctrl-C ends the
plan between two chunks.

The search: n = 1, 2, 4, ... until the power reaches ``power`` (or ``max_n``),
then bisection over the integers between the last failing and the first
passing n. The power is monotone in n only approximately (discreteness of the counts, and Monte
Carlo noise where simulated), so the result is the smallest n
*found*, and it is verified: the returned n has power ≥ ``power``
and n − 1 (always evaluated, unless n = 1) has less; a smaller n elsewhere
could pass by chance.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, safe_log
from fairaudit.base.checks import choice, level, real, whole
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, number
from fairaudit.base.progress import STEP_DELAY, progress_bar
from fairaudit.base.resources import MemoryLimit, check_memory, memory_limit
from fairaudit.metrics.box_extremes import disjoint_ratio, div
from fairaudit.statistics.confidence_sets import category_bounds, linear_extremes
from fairaudit.statistics.intervals import METHODS, IntervalOptions, fairness_intervals

if TYPE_CHECKING:
    from fairaudit.laws.mechanisms import Mechanism

__all__ = ["BAYES_DATASETS", "DEFAULT_DATASETS", "SamplePlan", "plan"]

_Inputs: TypeAlias = dict[str, Any]
"""The fields of a :class:`SamplePlan` that repeat its inputs, by name."""

DEFAULT_DATASETS = 200
BAYES_DATASETS = 40  # "bayes" draws 4000 posterior samples per table: about 10 ms a table


_REPORTED = tuple(
    "target confidence power kind groups contexts base_rate disparity epsilon seed max_n true_value".split()
)
"""The fields of a :class:`SamplePlan` its report dictionary holds, in order, before ``feasible`` and ``plans``."""
_PLANNED = tuple("method n_per_cell n_total achieved_power expected_upper datasets reason".split())
"""The fields of each plan of ``plans``: what a method gives."""


@dataclass(frozen=True, kw_only=True)
class SamplePlan:
    """The result of :func:`plan`: every input, the planned sample size and how it does.

    Attributes
    ----------
    target, groups, contexts, base_rate, disparity, confidence, method, power, epsilon, kind, datasets, seed, max_n
        The inputs (``datasets`` resolved from its default; None where the power is exact and nothing is simulated:
        L without a filter by a frequentist method, :func:`exact_route`).
    n_per_cell : int or None
        The smallest n (queries per cell, released cells behind a filter)
        found with power ≥ ``power``; None when infeasible.
    n_total : int or None
        n_per_cell × contexts × groups.
    achieved_power : float or None
        The power at ``n_per_cell``, exact or simulated (at ``max_n`` when the target is
        not reached there; None when the target is below the true value).
    expected_upper : float or None
        The median of the certificate's upper end at that n (of its exact distribution, or over the simulated
        tables), nats (``inf`` possible).
    true_value : float
        L (= L̄ here) of the assumed law, behind the filter when ``epsilon``
        is given, nats.
    reason : str
        Why there is no plan ("" when there is one).
    """

    target: float
    groups: int
    contexts: int
    base_rate: float
    disparity: float
    confidence: float
    method: str
    power: float
    epsilon: float | None
    kind: str
    datasets: int | None
    seed: int
    max_n: int
    n_per_cell: int | None
    n_total: int | None
    achieved_power: float | None
    expected_upper: float | None
    true_value: float
    reason: str = ""

    @property
    def feasible(self) -> bool:
        """Whether a sample size was found."""
        return self.n_per_cell is not None

    def to_dict(self) -> Report:
        """The report dictionary: the inputs, ``true_value``, ``feasible`` and ``plans``, a list of this one plan.

        ``fairaudit plan --method all`` joins plans of several methods
        (same inputs) into one dictionary of this shape.
        """

        def value(name: str) -> Any:
            v = getattr(self, name)
            return v if isinstance(v, str) else number(v)

        inputs = {name: value(name) for name in _REPORTED}
        return inputs | {"feasible": self.feasible, "plans": [{name: value(name) for name in _PLANNED}]}


@dataclass(frozen=True)
class _Certifier:
    """Upper ends of the certificate for a stack of count tables (D, X, A) with n records per cell."""

    groups: int
    contexts: int
    confidence: float
    method: str
    mechanism: Mechanism | None
    kind: str
    seed: int

    def exact(self, k: npt.NDArray[np.integer[Any]], n: int) -> FloatArray:
        """By :func:`fairness_intervals`, one table at a time."""
        from fairaudit.data.counts import CountTable
        from fairaudit.laws.tables import Population
        from fairaudit.laws.utilities import indicator

        contexts, groups = tuple(range(self.contexts)), tuple(range(self.groups))
        population, utility = Population.uniform(contexts, groups), indicator(1, (1, 0))
        options = IntervalOptions(confidence=self.confidence, method=self.method, seed=self.seed)
        out = np.empty(k.shape[0])
        for i, ki in enumerate(k):
            table = CountTable(
                np.stack([ki, n - ki], -1), contexts, groups, (1, 0), ("context",), ("group",), "decision"
            )
            iv = fairness_intervals(table, utility, options, sensitive_mechanism=self.mechanism, population=population)
            out[i] = (iv.local_fairness if self.kind == "local" else iv.global_fairness).upper
        return out

    def fast(self, k: npt.NDArray[np.integer[Any]], n: int) -> FloatArray:
        """The frequentist upper ends, vectorised over the stack (the same steps as fairness_intervals)."""
        D, X, A = k.shape
        a_cell = (1.0 - self.confidence) / (X * A)  # every cell non-empty; population given
        # a cell's bounds on E[g] depend on its count k alone: those of the n + 1 possible counts, read at each cell
        seen = np.arange(n + 1) if n + 1 < k.size else k  # (the distinct counts, where fewer than the cells)
        counts = np.stack([seen, n - seen], -1).astype(float)  # decisions (1, 0); g = (1, 0)
        e_lo, e_hi = linear_extremes(np.array([1.0, 0.0]), *category_bounds(counts, a_cell))
        if seen is not k:
            e_lo, e_hi = e_lo[k], e_hi[k]  # (D, X, A)
        if self.mechanism is None:
            if self.kind == "local":
                up = disjoint_ratio(e_lo.reshape(D * X, A), e_hi.reshape(D * X, A))[1].reshape(D, X).max(-1)
            else:
                up = disjoint_ratio(e_lo.mean(1), e_hi.mean(1))[1]  # uniform population: P(x | a) = 1/X
        else:
            from fairaudit.base.threshold_rule import threshold_max_many

            M = self.mechanism.matrix
            W = np.einsum("xy,ab->xayb", np.eye(X), M).reshape(X, A, X * A)  # (maps, groups, kernel cells)
            if self.kind == "global":
                W = W.mean(0, keepdims=True)
            lo, hi = e_lo.reshape(D, 1, 1, 1, X * A), e_hi.reshape(D, 1, 1, 1, X * A)
            vals, _, _ = threshold_max_many(W[None, :, :, None, :], W[None, :, None, :, :], lo, hi)
            vals = np.where(~np.eye(A, dtype=bool), vals, -np.inf)
            up = vals.reshape(D, -1).max(-1)
        return np.array([safe_log(max(float(v), 1.0)) for v in up])

    def __call__(self, k: npt.NDArray[np.integer[Any]], n: int) -> FloatArray:
        return self.exact(k, n) if self.method == "bayes" else self.fast(k, n)


def plan(
    target: float,
    *,
    groups: int = 2,
    contexts: int = 1,
    base_rate: float = 0.5,
    disparity: float = 0.0,
    confidence: float = 0.95,
    method: str = "clopper-pearson",
    power: float = 0.8,
    epsilon: float | None = None,
    kind: str = "local",
    datasets: int | None = None,
    seed: int = 0,
    max_n: int = 1_000_000,
    progress: Callable[[int, float], None] | None = None,
    max_memory: int | str | None = None,
) -> SamplePlan:
    """The number of queries per cell needed to certify L ≤ target at level 1 − α with a given power.

    Power at n is the fraction of ``datasets`` simulated count tables whose certificate (the upper end of the
    simultaneous interval on L, or on L̄ with ``kind="global"``) is ≤ ``target``; the simulation and the search over n
    are described in the module docstring (:mod:`fairaudit.statistics.sample_size`).

    Parameters
    ----------
    target : float
        The target on L (or L̄), nats, ≥ 0.
    groups, contexts : int
        k ≥ 2 groups and ≥ 1 contexts; n queries in each of the contexts × groups cells.
    base_rate : float
        E[g | x, a] in (0, 1) of every group but group 0.
    disparity : float
        log of group 0's rate over the others' (nats; the true L without a filter is |disparity|);
        base_rate · exp(disparity) must be ≤ 1.
    confidence : float
        1 − α in (0, 1).
    method : {"clopper-pearson", "multinomial", "bayes"}
        The interval method (for a binary decision the first two coincide).
    power : float
        The required probability of meeting the target, in (0, 1).
    epsilon : float, optional
        With ε ≥ 0, the model sees the groups through k-ary randomized response at ε, the counts are of its kernel on
        released groups and the certificate is for the filtered law.
    kind : {"local", "global"}
        Certify L or L̄.
    datasets : int, optional
        Simulated tables per n: default 200, and 40 for ``"bayes"``, which computes 4000 posterior draws per table
        (about 10 ms each) and is not vectorised over tables; the frequentist methods are. Unused where the power is
        exact (L without a filter by a frequentist method).
    seed : int
        Seed of the simulation (and of the Bayesian posterior draws).
    max_n : int
        The largest n tried.
    progress : callable, optional
        Called as ``progress(n, power)`` after each n evaluated.
    max_memory : int or str, optional
        The memory the simulation may take: bytes, or a size such as ``"4G"``
        (:func:`fairaudit.base.resources.parse_size`); default the environment variable ``FAIRAUDIT_MAX_MEMORY``, else
        one half of the memory available (:func:`fairaudit.base.resources.memory_limit`).

    Returns
    -------
    SamplePlan
        With ``n_per_cell = None`` and a ``reason`` when the target is not above the true value of L (nothing can
        certify it) or ``max_n`` does not reach the power.

    Raises
    ------
    InputError
        On an invalid argument, naming it and its value.
    MemoryLimitError
        An ``InputError``, before anything large is allocated, when even one simulated table (and what is computed from
        it) would not fit the memory limit: with the need, the inputs that drive it and the limit.

    Notes
    -----
    Source: the certificate is the upper end of :func:`fairaudit.statistics.intervals.fairness_intervals`
    (``proofs/intervals.md``). For L without a filter by a frequentist method the power is exact, from the order
    statistics of the counts (module docstring); otherwise it is estimated by simulation, so the plan is exact only
    up to Monte Carlo error (``datasets`` tables per n, seeded).

    Examples
    --------
    Two groups of a fair model (E[g] = 0.5): queries per group to certify
    L ≤ 0.5 nats at 95% with power 80%.

    >>> p = plan(0.5)
    >>> p.n_per_cell, p.n_total, p.achieved_power >= 0.8, p.datasets  # (exact: no table simulated)
    (171, 342, True, None)
    >>> round(p.expected_upper, 3) <= 0.5
    True
    >>> plan(0.1, disparity=0.2).reason
    'the target 0.1 nats is not above the true L of the model, 0.2 nats: no sample size certifies it'
    """
    unit: dict[str, Any] = {"low": 0.0, "high": 1.0, "low_open": True, "high_open": True, "what": "a number in (0, 1)"}
    method = choice(method, "method", METHODS)
    inputs: _Inputs = {
        "target": real(target, "target", low=0.0, what="a finite number >= 0 (nats)"),
        "groups": whole(groups, "groups", low=2, high=1000),
        "contexts": whole(contexts, "contexts", low=1, high=100_000),
        "base_rate": real(base_rate, "base_rate", **unit),
        "disparity": real(disparity, "disparity", what="a finite number (nats)"),
        "confidence": level(confidence, "confidence"),
        "method": method,
        "power": real(power, "power", **unit),
        "epsilon": None if epsilon is None else real(epsilon, "epsilon", low=0.0, what="a finite number >= 0 (nats)"),
        "kind": choice(kind, "kind", ("local", "global")),
        "datasets": (BAYES_DATASETS if method == "bayes" else DEFAULT_DATASETS)
        if datasets is None
        else whole(datasets, "datasets", low=1, high=1_000_000),
        "seed": whole(seed, "seed"),
        "max_n": whole(max_n, "max_n", low=1),
    }
    if progress is not None and not callable(progress):
        raise InputError("progress", "must be callable", progress)
    limit = memory_limit(max_memory)
    rates, mechanism, true_value = _assumed_model(inputs)
    return _search(inputs, true_value, rates, mechanism, progress, limit)


CELL_BYTES = 256
"""Bytes per simulated cell of the vectorised certificate (counts, their bounds, the extremes): 226 measured
(tracemalloc's peak over ``rng.binomial`` and :meth:`_Certifier.fast`, 10^4 to 3 · 10^4 cells a table), rounded up."""

PAIR_BYTES = 96
"""Bytes per entry (map, group, group, kernel cell) of the threshold rule behind a filter: 67 to 85 measured,
rounded up."""

CHUNK_BYTES = 2**26
"""Most bytes a chunk of tables takes when more than one table fits (64 MiB: about 0.2 s of work per chunk on one
core, at :data:`CELL_BYTES`), so that Ctrl-C, checked between chunks, is answered within a second."""

DRAW_BYTES = 96
"""Bytes per posterior draw and cell of one ``"bayes"`` table: 80 measured (4000 draws, 2 to 400 cells), rounded up."""


def _memory(inputs: _Inputs) -> tuple[int, int]:
    """Bytes the simulation needs whatever the chunk (its fixed part) and per simulated table.

    Without a filter: :data:`CELL_BYTES` per cell of a table. Behind the filter, the vectorised path builds the
    maps W (X, A, X·A) once (twice over: the product and its reshaped copy) and per table the threshold rule's
    (maps, A, A, X·A) entries, where the maps are the X contexts (one map with ``kind="global"``). ``"bayes"``
    certifies one table at a time: its 4000 posterior draws per cell are fixed, a table's counts are 8 bytes a cell.
    """
    X, A, D = inputs["contexts"], inputs["groups"], inputs["datasets"]
    fixed = 32 * D  # the upper ends, their chunks and the comparisons with the target
    if inputs["method"] == "bayes":
        return fixed + DRAW_BYTES * 4000 * X * A, 16 * X * A
    if inputs["epsilon"] is None:
        return fixed, CELL_BYTES * X * A
    maps = X if inputs["kind"] == "local" else 1
    return fixed + 16 * X * A * X * A, CELL_BYTES * X * A + PAIR_BYTES * maps * A * A * X * A


def _chunk(inputs: _Inputs, limit: MemoryLimit) -> int:
    """How many simulated tables to draw and certify at once within ``limit``; refuses when not even one fits."""
    fixed, per_table = _memory(inputs)
    driver = f"`groups` {inputs['groups']} x `contexts` {inputs['contexts']}"
    if inputs["method"] == "bayes":
        what, instead = "certifying one table with 4000 posterior draws per cell", "use another `method` or fewer cells"
    elif inputs["epsilon"] is None:
        what, instead = "one simulated table", "give fewer `groups` or `contexts`"
    else:
        X, A = inputs["contexts"], inputs["groups"]
        driver = f"`groups`^3 x `contexts`^2 = {A}^3 x {X}^2" if inputs["kind"] == "local" else f"`groups`^3 = {A}^3"
        driver += " behind `epsilon`"
        what, instead = "one simulated table behind the filter", "give fewer `groups` or `contexts`"
    check_memory(fixed + per_table, what, driver, instead, limit)
    room = CHUNK_BYTES if limit.nbytes is None else min(CHUNK_BYTES, limit.nbytes - fixed)
    return max(1, min(inputs["datasets"], room // per_table))


def _assumed_model(inputs: _Inputs) -> tuple[FloatArray, Mechanism | None, float]:
    """The model the plan assumes: the kernel's rates (1, groups), the same in every context, the filter (None without ``epsilon``) and
    the true L of the filtered law, in nats (every context has the same rates: L̄ is the same).

    The kernel's E[g | x̃, ã] is ``base_rate`` but for group 0's ``base_rate · exp(disparity)``; an InputError
    (``disparity``) when that is over 1.
    """
    top = inputs["base_rate"] * math.exp(inputs["disparity"])
    if top > 1:
        problem = f"gives group 0 the rate base_rate * exp(disparity) = {top:.6g} > 1"
        raise InputError("disparity", problem, inputs["disparity"])
    rates = np.full((1, inputs["groups"]), inputs["base_rate"])  # (every context alike: broadcast over them)
    rates[:, 0] = top
    mechanism: Mechanism | None = None
    filtered = rates
    if inputs["epsilon"] is not None:
        from fairaudit.laws.closed_forms import randomized_response

        mechanism = randomized_response(tuple(range(inputs["groups"])), inputs["epsilon"])
        filtered = rates @ mechanism.matrix.T  # Q[x, a] = sum_ã M[a, ã] K[x, ã]
    return rates, mechanism, float(np.log(filtered.max(-1) / filtered.min(-1)).max())


TAIL = 1e-18
"""The probability each group's count may have outside the window of counts the exact power reads (binomial
quantiles at ``TAIL`` and 1 − ``TAIL``): what it leaves out is at most 2 · ``TAIL`` · groups · contexts, below
1e-12 for every plan ``plan`` takes (10^3 groups x 10^5 contexts)."""


def exact_route(inputs: _Inputs) -> bool:
    """Whether the power is computed exactly (:func:`_order_power`), not simulated.

    Parameters
    ----------
    inputs : dict
        A plan's checked inputs (``kind``, ``epsilon``, ``method`` are read).

    Returns
    -------
    bool
        True for L (``kind="local"``), no filter (``epsilon`` None) and a frequentist method (``"clopper-pearson"``,
        or ``"multinomial"``, the same for a binary decision); then ``plan`` simulates no table.

    Examples
    --------
    >>> exact_route({"kind": "local", "epsilon": None, "method": "clopper-pearson"})
    True
    >>> exact_route({"kind": "global", "epsilon": None, "method": "clopper-pearson"})
    False
    """
    return inputs["kind"] == "local" and inputs["epsilon"] is None and inputs["method"] != "bayes"


def _order_power(n: int, inputs: _Inputs, rates: FloatArray) -> tuple[float, float]:
    """The power at ``n`` and the median of the certificate's upper end, from the order statistics of the counts.

    Without a filter a cell's interval on E[g] depends on its count k alone, [lo(k), hi(k)], both non-decreasing in
    k, so the upper end on L of a table is max over x of ln(hi(max_a k_xa) / lo(min_a k_xa)) (the largest hi over
    the smallest lo of another group: :func:`~fairaudit.metrics.box_extremes.disjoint_ratio`), and it is at most t in
    context x exactly when max_a k_xa ≤ M_t(min_a k_xa), M_t(m) the largest count with ln(hi(M)/lo(m)) ≤ t. The
    counts are independent binomials, so with F_a(i, j) = P(i ≤ k_xa ≤ j)

        P(upper end ≤ t in context x) = Σ_m [Π_a F_a(m, M_t(m)) − Π_a F_a(m + 1, M_t(m))]

    (the minimum is m and the maximum at most M_t(m)), and the contexts, alike and independent, multiply: the power
    is its X-th power at t = ``target``, the median the smallest t where that reaches 1/2 (by bisection). The
    decisions ln(hi/lo) ≤ t are the floating-point ones the simulation makes (:meth:`_Certifier.fast`); m and M run
    over the window of counts :data:`TAIL` leaves. Proof: ``proofs/intervals.md`` §7.
    """
    from scipy.stats import binom

    X, A = inputs["contexts"], inputs["groups"]
    a_cell = (1.0 - inputs["confidence"]) / (X * A)
    # (the upper quantile as n less the lower one of n - k: scipy's isf returns n at such tails)
    low = int(min(binom.ppf(TAIL, n, r) for r in (rates[0, 0], rates[0, 1])))
    high = n - int(min(binom.ppf(TAIL, n, 1.0 - r) for r in (rates[0, 0], rates[0, 1])))
    k = np.arange(low, high + 1)
    e_lo, e_hi = linear_extremes(np.array([1.0, 0.0]), *category_bounds(np.stack([k, n - k], -1).astype(float), a_cell))
    cdf = [np.concatenate([[0.0], binom.cdf(k, n, r)]) for r in (rates[0, 0], rates[0, 1])]  # P(k_a <= low - 1 + i)

    def within(i: npt.NDArray[np.intp], j: npt.NDArray[np.intp]) -> FloatArray:
        """Π_a F_a(k[i], k[j]) (0 where i > j)."""
        f0, f1 = (np.where(j >= i, c[j + 1] - c[i], 0.0) for c in cdf)
        return f0 * f1 ** (A - 1)

    def context_power(t: float) -> float:
        ratio = lambda m, big: div(e_hi[big], e_lo[m])  # noqa: E731
        m = np.arange(len(k))
        lo_j, hi_j = m - 1, np.full(len(k), len(k) - 1)  # the largest j with ln(hi(j)/lo(m)) <= t, in [m - 1, end]
        with np.errstate(divide="ignore"):
            while np.any(hi_j > lo_j):
                mid = (lo_j + hi_j + 1) // 2
                ok = np.log(np.maximum(ratio(m, np.maximum(mid, 0)), 1.0)) <= t
                lo_j, hi_j = np.where(ok, mid, lo_j), np.where(ok, hi_j, mid - 1)
        return float(np.clip(np.sum(within(m, lo_j) - within(m + 1, lo_j)), 0.0, 1.0)) if len(k) else 0.0

    power = context_power(inputs["target"]) ** X
    half = 0.5 ** (1.0 / X)  # the median: the smallest t with P(upper <= t)^X >= 1/2
    with np.errstate(divide="ignore"):
        ends = np.log(np.maximum(div(e_hi[-1], e_lo), 1.0))  # each m's largest value: with the largest count
    top = float(ends[np.isfinite(ends)].max(initial=0.0))
    if context_power(top) < half:  # (then only the tables whose ratio is c/0 = +inf reach it)
        return power, math.inf
    if context_power(0.0) >= half:
        return power, 0.0
    # a step function of t: bisection over the floats in [0, top] in order (their bit patterns, at most 64 steps)
    bits = lambda t: int(np.float64(t).view(np.int64))  # noqa: E731
    lo_b, hi_b = bits(0.0), bits(top)
    while hi_b - lo_b > 1:
        mid_b = (lo_b + hi_b) // 2
        if context_power(float(np.int64(mid_b).view(np.float64))) >= half:
            hi_b = mid_b
        else:
            lo_b = mid_b
    return power, float(np.int64(hi_b).view(np.float64))


def _search(
    inputs: _Inputs,
    true_value: float,
    rates: FloatArray,
    mechanism: Mechanism | None,
    progress: Callable[[int, float], None] | None,
    limit: MemoryLimit,
) -> SamplePlan:
    """The smallest n found with simulated power >= ``power``: doubling, then bisection (see :func:`plan`).

    ``n_per_cell = None`` and a ``reason`` for a target not above the true value (no n certifies it) or when
    ``max_n`` falls short. The tables at each n are drawn and certified in chunks that fit ``limit`` (:func:`_chunk`).
    """
    target, power, max_n, seed = inputs["target"], inputs["power"], inputs["max_n"], inputs["seed"]

    exact = exact_route(inputs)

    def planned(n: int | None, at: tuple[float, float] | tuple[None, None], reason: str = "") -> SamplePlan:
        """The plan of ``n`` queries per cell (None: none found), with its (power, median upper end)."""
        total = None if n is None else n * inputs["contexts"] * inputs["groups"]
        power_at, upper = at
        return SamplePlan(
            n_per_cell=n,
            n_total=total,
            achieved_power=power_at,
            expected_upper=upper,
            true_value=true_value,
            reason=reason,
            **(inputs | {"datasets": None} if exact else inputs),  # (an exact power simulates no table)
        )

    if target <= true_value:
        name = "L" if inputs["kind"] == "local" else "L-bar"
        reason = f"the target {target:.6g} nats is not above the true {name} of the model, {true_value:.6g} nats"
        return planned(None, (None, None), reason + ": no sample size certifies it")
    chunk = 0 if exact else _chunk(inputs, limit)
    fields = ("groups", "contexts", "confidence", "method", "kind", "seed")
    certifier = _Certifier(mechanism=mechanism, **{name: inputs[name] for name in fields})
    seen: dict[int, tuple[float, float]] = {}  # n -> (power, median upper end)

    def evaluate(n: int) -> tuple[float, float]:
        if n in seen:
            return seen[n]
        if exact:
            seen[n] = _order_power(n, inputs, rates)
        else:
            rng = np.random.default_rng(seed)
            D, shape = inputs["datasets"], (inputs["contexts"], inputs["groups"])
            parts = []
            with progress_bar(D, f"plan: n = {n}", unit="table", delay=STEP_DELAY) as bar:
                for i in range(0, D, chunk):  # along the first axis: the same numbers as one draw of (D, X, A)
                    parts.append(certifier(rng.binomial(n, rates, size=(min(chunk, D - i), *shape)), n))
                    bar.update(len(parts[-1]))
            up = np.concatenate(parts)
            seen[n] = (float(np.mean(up <= target)), float(np.median(up)))
        if progress is not None:
            progress(n, seen[n][0])
        return seen[n]

    lo, hi = 0, 1
    while evaluate(hi)[0] < power:
        if hi >= max_n:
            return planned(
                None, seen[hi], f"max_n = {max_n} queries per cell give power {seen[hi][0]:.3g} < {power:.3g}"
            )
        lo, hi = hi, min(2 * hi, max_n)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if evaluate(mid)[0] >= power:
            hi = mid
        else:
            lo = mid
    return planned(hi, seen[hi])
