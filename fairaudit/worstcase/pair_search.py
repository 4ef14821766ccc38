"""The pair search shared by the worst cases: LPs in decreasing order of valid upper bounds, and its helpers.

Every maximum of :mod:`fairaudit.worstcase` is a maximum over problems (ordered pairs of groups, and contexts)
of a linear-fractional program. :func:`search` solves them in decreasing order of an upper bound and stops when
no problem left can win; :func:`relaxed_first` tries the closed-form floor relaxation before the LP;
:func:`pairwise_box` gives the box (threshold) value of every pair at once; :func:`check_class` checks the class the
worst cases share (:func:`~fairaudit.worstcase.worst_cases.check_method` their method). ``proofs/black_box.md`` §1–2 and §5,
``proofs/linear_fractional.md``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.errors import InputError
from fairaudit.base.exact_duality import Rows, point_ratio
from fairaudit.base.linear_fractional import CROSSOVER_TOLERANCE, FractionalProgram, FractionalResult
from fairaudit.base.outward import down, fraction_up, gap_between
from fairaudit.base.pairs import CANDIDATES, PAIR_BLOCK, PRUNE, ROUNDING, PairPass, matrix_digest, pair_candidates
from fairaudit.base.progress import STEP_DELAY, ProgressBar, progress_bar
from fairaudit.base.threshold_rule import box_point, floor_max_many, threshold_max_many
from fairaudit.laws.utilities import UtilityClass

STOP = 1e-12
"""Relative margin of :func:`search`'s stop: problems whose bound is within it of the best value are not solved
(their bound, when above, is the value returned)."""

TIE = 1e-9
"""Relative margin of :func:`search`'s tie rule: a problem becomes the maximiser only where its value exceeds the
maximiser's by more than it (the solver's accuracy), so near-ties keep the earlier problem."""

SEARCH_BAR = "{desc}: {n}/{total} {unit}s [{elapsed}{postfix}]"
"""The format of :func:`search`'s progress bar: no time left, as the search usually stops long before its last
problem."""


@dataclass(frozen=True, kw_only=True)
class SearchResult:
    """The outcome of :func:`search`: the maximising problem and its solution, or why there is none."""

    index: int  # flat index of the maximising problem (-1 when none)
    result: FractionalResult | None
    solved: int  # LPs solved
    reason: str


def search(upper: FloatArray, solve: Callable[[int], FractionalResult]) -> SearchResult:
    """Maximise over problems i by LP, in decreasing order of the upper bounds ``upper[i]`` (ratios).

    Stops when the best value found is within :data:`STOP` of every remaining upper bound (the bounds are valid,
    rounded up); an infeasible program means the common polytope is empty, which ends the search, and so does a
    program the LP route could not solve (status "error": the maximum over every program is then not known). Near-ties (within
    1e-9, the solver's accuracy) keep the earlier problem as the maximiser, but the value returned is an upper end
    of the maximum over every problem: the largest value solved, or the largest bound left unsolved where that is
    larger; it is certified only when every value solved is.

    Inside :func:`~fairaudit.base.progress.progress_shown` (``certify(progress=True)``) a bar on stderr counts the
    problems taken out of all, with the largest value found and the next problem's bound, in nats: the search stops
    where they meet.
    """
    with progress_bar(len(upper), "worst case", unit="program", delay=STEP_DELAY, bar_format=SEARCH_BAR) as bar:
        return _search(upper, solve, bar)


def _search(upper: FloatArray, solve: Callable[[int], FractionalResult], bar: ProgressBar) -> SearchResult:
    order = np.argsort(-upper, kind="stable")
    best_i, best, best_v, top, certified, solved = -1, None, -math.inf, -math.inf, True, 0
    ranked = None if bar.disable else -upper[order]  # (the bar's: the bounds in order, ascending)
    for k, i in enumerate(order):
        if best is not None and top >= upper[i] * (1 - STOP):
            top = max(top, float(upper[i]))  # the largest bound left unsolved
            break
        r = solve(int(i))
        solved += r.method == "lp"
        if r.status in ("infeasible", "error"):  # an empty polytope, or a program not solved: no maximum to give
            return SearchResult(index=-1, result=r, solved=solved, reason=r.reason)
        certified = certified and r.certified
        if best is None or r.value > best_v * (1 + TIE):  # ties (to solver accuracy) keep the earlier pair
            best_i, best, best_v = int(i), r, r.value
        top = max(top, r.value)
        if ranked is not None:
            bar.set_postfix_str(_closing(top, ranked, k), False)
        bar.update()
        if math.isinf(top):
            break
    if best is not None and (top > best.value or certified != best.certified):
        best = replace(best, value=top, certified=certified, gap=gap_between(top, best.witness))
    return SearchResult(index=best_i, result=best, solved=solved, reason="")


def _closing(top: float, ranked: FloatArray, k: int) -> str:
    """The bar's postfix after problem ``k`` of the order: the largest value found, the next problem's bound, and how
    many problems left have a bound above that value (the search takes at most those), the values in nats.

    ``ranked``: the bounds in the search's order, negated (ascending), ratios.

    Examples
    --------
    >>> _closing(2.0, -np.array([4.0, 3.0, 2.5, 1.5]), 0), _closing(math.inf, -np.array([4.0]), 0)
    ('best 0.6931 nats, next bound 1.0986 nats (2 left above best)', 'best inf nats')
    """

    def nats(v: float) -> float:
        return math.log(v) if v > 0 else -math.inf

    text = f"best {nats(top):.4f} nats"
    if k + 1 >= len(ranked):
        return text
    left = max(0, int(np.searchsorted(ranked, -top / (1 - STOP))) - (k + 1))
    return f"{text}, next bound {nats(-float(ranked[k + 1])):.4f} nats ({left} left above best)" if left else text


def relaxed_first(
    num: Callable[[int], FloatArray],
    den: Callable[[int], FloatArray],
    lower: float,
    upper: float,
    floor: float | None,
    rows: npt.NDArray[np.floating[Any]] | None,
    program: Callable[[], FractionalProgram],
) -> Callable[..., FractionalResult]:
    """Solve problem i by the closed-form floor relaxation when its point is feasible, by the LP otherwise (given
    ``below``, :meth:`~fairaudit.base.linear_fractional.FractionalProgram.solve`'s: a value the caller holds).

    The relaxation keeps the box and only the denominator's constraint q·h ≥ floor
    (:func:`fairaudit.base.threshold_rule.floor_max_many`); its point is optimal for the full
    program whenever it meets every row of ``rows @ h ≥ floor``. With no
    floor the program is the box program and the threshold solves it.
    """

    def solve(i: int, below: float = -math.inf) -> FractionalResult:
        p, q = num(i), den(i)
        frac: float | FloatArray
        if floor is None:
            v, k, order = threshold_max_many(p, q, lower, upper)
            frac = 0.0
        else:
            v, k, frac, order = floor_max_many(p, q, lower, upper, floor)
        if not np.isnan(v):
            h = box_point(lower, upper, order, int(k), float(frac))
            h[(p == 0) & (q == 0)] = upper  # cells outside the objective: the top of the box helps every τ row
            if rows is None or floor is None or np.all(rows @ h >= floor * (1 - 1e-12) - 1e-15):
                status = "unbounded" if math.isinf(v) else "optimal"
                constraints = [] if rows is None or floor is None else [(-rows, -floor * np.ones(len(rows)), "le")]
                witness = point_ratio(np.asarray(h, dtype=float), p, q, None, None, constraints)
                return FractionalResult(
                    value=float(v),
                    argmax=h,
                    status=status,
                    method="threshold",
                    solver_status="closed form",
                    reason="",
                    certified=True,  # the rule's values are rounded up by their error bound
                    witness=witness,
                    gap=gap_between(float(v), witness),
                )
        return program().solve(p, q, below=below)

    return solve


PULLS = (2.0**-50, 2.0**-44, 2.0**-38, 2.0**-30)
"""The steps θ tried by :func:`inner_witness` toward a point inside the exact polytope, smallest first."""


@dataclass(frozen=True, eq=False)
class InnerProgram:
    """The inner program a witness is taken on: the bounds of h, shape (n,), and the rows (A, b, "le" or "eq") tightened
    by their rounding, so that a point meeting them meets the exact ones; in the order of the outer program's rows,
    the "le" blocks first, so that the outer program's basis is one of it."""

    lower: FloatArray
    upper: FloatArray
    rows: Rows

    @functools.cached_property
    def program(self) -> FractionalProgram:
        """The rows as a :class:`~fairaudit.base.linear_fractional.FractionalProgram`, built at the first use."""

        def stacked(kind: str) -> tuple[FloatArray | None, FloatArray | None]:
            blocks = [(a.toarray() if hasattr(a, "toarray") else a, b) for a, b, k in self.rows if k == kind]
            if not blocks:
                return None, None
            return np.vstack([a for a, _ in blocks]), np.concatenate([b for _, b in blocks])

        (a_ub, b_ub), (a_eq, b_eq) = stacked("le"), stacked("eq")
        n = self.lower.size
        return FractionalProgram(n, lower=self.lower, upper=self.upper, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=b_eq)


def inner_witness(
    r: FractionalResult, p: FloatArray, q: FloatArray, inner: InnerProgram, inside: FloatArray | None = None
) -> FractionalResult:
    """``r``, solved on coefficients that enclose the exact ones (its value certified on the outer program), with its
    witness taken on the inner program: the ratio (p·h)/(q·h) at a point h of it, with p the numerator's lower end, q
    the denominator's upper end and the rows tightened by their rounding, so that a point meeting them meets the
    exact ones. NaN without a maximiser or a feasible point.

    The point is the outer maximiser; where it misses a row by rounding, or its ratio is not within
    :data:`~fairaudit.base.linear_fractional.CROSSOVER_TOLERANCE` of the value, the vertex of the outer program's
    last basis on the inner rows, solved exactly (:meth:`FractionalProgram.vertex_ratio
    <fairaudit.base.linear_fractional.FractionalProgram.vertex_ratio>`); where that vertex misses one too (a
    degenerate vertex, whose active rows the tightening makes inconsistent: the Lipschitz rows of three groups on a
    line), the point (1 − θ)·h + θ·``inside`` for the steps θ of :data:`PULLS`, ``inside`` a point that meets every
    row with room to spare. Every candidate is checked exactly, so a wrong one is refused, never a wrong witness.

    Parameters
    ----------
    r : FractionalResult
        The outer program's result (its ``value`` and ``certified`` are kept); ``r.argmax`` shape (n,).
    p, q : numpy.ndarray, shape (n,)
        The inner program's numerator (lower ends) and denominator (upper ends), ≥ 0.
    inner : InnerProgram
        The bounds of h and the inner program's rows.
    inside : numpy.ndarray, shape (n,), optional
        A point strictly inside the inner rows (the top of the box for the class programs); None: no pull.

    Returns
    -------
    FractionalResult
        ``r`` with ``witness`` (a ratio, rounded down; NaN when no candidate meets every row exactly) and ``gap``
        (``value − witness`` rounded up). ``proofs/black_box.md`` §5 and §6, ``proofs/linear_fractional.md`` §6.

    Examples
    --------
    Binary randomized response keeping 0.7 with floors 1/2 (``FractionalProgram``'s example), taken as exact on both
    sides: the maximum is 11/7, and the witness within rounding of it.

    >>> p, q = np.array([0.7, 0.3]), np.array([0.3, 0.7])
    >>> rows = [(-np.array([[0.7, 0.3], [0.3, 0.7]]), -np.full(2, 0.5), "le")]
    >>> r = FractionalProgram(2, lower=0.0, upper=1.0, A_ub=rows[0][0], b_ub=rows[0][1]).solve(p, q)
    >>> w = inner_witness(r, p, q, InnerProgram(np.zeros(2), np.ones(2), rows))
    >>> w.witness <= 11 / 7 <= w.value, 11 / 7 - w.witness < 1e-12
    (True, True)
    """
    if r.argmax is None:
        return r
    lower, upper, rows = inner.lower, inner.upper, inner.rows
    h = np.clip(np.asarray(r.argmax, dtype=float), lower, upper)
    w = point_ratio(h, p, q, lower, upper, rows)
    close = math.isfinite(w) and r.value - w <= CROSSOVER_TOLERANCE * max(1.0, abs(r.value))
    if r.certified and not close and r.basis is not None:
        w = max((v for v in (w, inner.program.vertex_ratio(r.basis, p, q)[0]) if math.isfinite(v)), default=math.nan)
    if inside is not None and not math.isfinite(w):
        for theta in PULLS:
            w = point_ratio(np.clip((1 - theta) * h + theta * inside, lower, upper), p, q, lower, upper, rows)
            if math.isfinite(w):
                break
    return replace(r, witness=w, gap=gap_between(r.value, w))


def check_class(utility_class: UtilityClass | None) -> tuple[float, float, float | None]:
    """(lower, γ, τ) of a utility class [lower, γ] with floor τ ≤ γ (τ may be None); lower 0 and γ 1 by default (each
    number already checked non-negative by :class:`~fairaudit.laws.utilities.UtilityClass`)."""
    c = UtilityClass() if utility_class is None else utility_class
    if not isinstance(c, UtilityClass):
        raise InputError("utility_class", "must be a UtilityClass", type(c).__name__)
    lower = 0.0 if c.lower is None else c.lower
    gamma = 1.0 if c.gamma is None else c.gamma
    tau = c.tau
    if lower > gamma:
        raise InputError("lower", f"cannot exceed gamma = {gamma:g}", lower)
    if tau is not None and tau > gamma:
        raise InputError("tau", f"exceeds gamma = {gamma:g}: no utility in [lower, gamma] has E[g | x, a] >= tau", tau)
    return lower, gamma, tau


def implied_floor(lower: float, least: float) -> float:
    """The least E[g | x, a] = Σ_ã M[a, ã] h_ã can be over h ≥ ``lower``, rounded down.

    Parameters
    ----------
    lower : float
        The utility's least value (g ≥ lower ≥ 0), in the utility's units.
    least : float
        The least exact row sum of the law (at most its true value: 1 for a stochastic law, just below 1 for rows
        that sum to 1 only within rounding).

    Returns
    -------
    float
        ``lower`` where ``least`` ≥ 1, else lower × least rounded down: at most every E[g | x, a], so a floor τ at or
        below it binds no model.

    Notes
    -----
    ``proofs/black_box.md`` §5 (S_min, the least exact row sum rounded down).

    Examples
    --------
    >>> implied_floor(0.5, 1.0), implied_floor(0.5, 1 - 2.0**-53) < 0.5
    (0.5, True)
    """
    return lower if least >= 1.0 else float(down(lower * least))


def ratio_ceiling(gamma: float, reach: float, tau: float) -> float:
    """γ·max(1, reach)/τ, rounded up: an upper bound on every pair's ratio E[g | x, a]/E[g | x, a'].

    Parameters
    ----------
    gamma : float
        The utility's largest value (g ≤ γ).
    reach : float
        The largest exact row sum of the law (at least its true value), so E[g | x, a] ≤ γ·max(1, reach).
    tau : float
        The floor E[g | x, a'] ≥ τ, > 0.

    Returns
    -------
    float
        The smallest float at or above γ·max(1, reach)/τ, computed exactly (a ratio, dimensionless; its log is in
        nats).

    Raises
    ------
    ZeroDivisionError
        When ``tau`` is 0 (the callers pass a positive floor only).

    Notes
    -----
    ``proofs/black_box.md`` §5 (the numerator at most γS, the denominator at least the floor).

    Examples
    --------
    >>> ratio_ceiling(1.0, 1.0, 0.1) >= 10, ratio_ceiling(1.0, 0.5, 0.25)
    (True, 4.0)
    """
    return fraction_up(Fraction(gamma) * Fraction(max(1.0, reach)) / Fraction(tau))


def _ratios(p: FloatArray, q: FloatArray) -> FloatArray:
    """p / q elementwise with the conventions c/0 = inf (c > 0) and 0/0 = 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(q > 0, p / np.where(q > 0, q, 1.0), np.where(p > 0, np.inf, 0.0))


def pair_ratio(matrix: FloatArray, a: IntArray, b: IntArray) -> FloatArray:
    """max_o M[a[i], o] / M[b[i], o] for the pairs given (c/0 = inf, 0/0 ignored), a chunk at a time."""
    out = np.empty(a.size)
    step = max(1, PAIR_BLOCK // max(1, matrix.shape[1]))
    for s in range(0, a.size, step):
        out[s : s + step] = _ratios(matrix[a[s : s + step]], matrix[b[s : s + step]]).max(axis=-1, initial=0.0)
    return out


@dataclass(frozen=True, kw_only=True)
class BoxPairs:
    """The ordered pairs of rows that can reach the largest box value (or floor relaxation), solved exactly.

    ``a``, ``b``: those pairs, row-major; ``box`` their threshold values and ``relaxed`` their floor relaxations
    (:func:`fairaudit.base.threshold_rule.threshold_max_many`, :func:`~fairaudit.base.threshold_rule.floor_max_many`, computed as for every pair
    at once). Every other pair's box value is below ``box_fill`` (and its relaxation below ``relaxed_fill``), which
    is the largest upper bound of a pair set aside, below (1 − PRUNE) × the largest value found (with a floor: the
    largest relaxation whose point meets every row's floor; +inf for the box values then; -inf when no pair was
    set aside).
    """

    a: IntArray
    b: IntArray
    box: FloatArray
    relaxed: FloatArray | None
    box_fill: float
    relaxed_fill: float


_CACHE: dict[tuple, BoxPairs] = {}  # the last few results (small ones only), by the matrix's bytes and the box


def box_pairs(matrix: FloatArray, lower: float, upper: float, floor: float | None = None) -> BoxPairs:
    """The pairs of rows (a, b) whose box program max (M[a]·h)/(M[b]·h), lower ≤ h ≤ upper, can be the largest.

    With ``floor``, the same for the floor relaxations (only M[b]·h ≥ floor added), the best one counted only
    where its point meets every row of M h ≥ floor. Pruned by upper bounds that are exact (``proofs/black_box.md``
    §7): with lower = 0 and no floor by the pair's largest likelihood ratio, a row at a time; otherwise by one
    pass over the pairs at a single λ (:class:`fairaudit.base.pairs.PairPass`), O(n²m) time and O(nm) memory; only
    the pairs that survive are sorted and solved. ``lower`` and ``upper`` are numbers. The same arguments again
    (``worst_model`` asks twice for one context) give the same result from a small cache.
    """
    lo, hi = float(lower), float(upper)
    key = (matrix_digest(matrix), lo, hi, floor)
    if key in _CACHE:
        return _CACHE[key]
    if matrix.shape[0] < 2 or not hi > lo:
        found = _all_pairs(matrix, lo, hi, floor)
    elif floor is None and lo == 0:
        found = _ratio_pairs(matrix, hi)
    else:
        found = _HockeyPairs(matrix, lo, hi, floor).run()
    if found.a.size <= 4 * matrix.shape[0] + 4 * CANDIDATES:
        while len(_CACHE) >= 4:
            del _CACHE[next(iter(_CACHE))]
        _CACHE[key] = found
    return found


def pair_values(
    matrix: FloatArray, a: IntArray, b: IntArray, lo: float, hi: float, floor: float | None
) -> tuple[FloatArray, FloatArray | None]:
    """Exact threshold values (and floor relaxations) of the pairs of rows (a[i], b[i]), a chunk of pairs at a time.

    Parameters
    ----------
    matrix : numpy.ndarray, shape (n, m)
        The rows (non-negative).
    a, b : numpy.ndarray of int, shape (k,)
        The pairs' rows: numerator ``matrix[a[i]]``, denominator ``matrix[b[i]]``.
    lo, hi : float
        The box lo ≤ h ≤ hi.
    floor : float or None
        The floor of the relaxation matrix[b[i]]·h ≥ floor; None: no relaxation.

    Returns
    -------
    box : numpy.ndarray, shape (k,)
        :func:`~fairaudit.base.threshold_rule.threshold_max_many`'s values (ratios).
    relaxed : numpy.ndarray, shape (k,), or None
        :func:`~fairaudit.base.threshold_rule.floor_max_many`'s values; None without ``floor``.
    """
    box = np.empty(a.size)
    relaxed = None if floor is None else np.empty(a.size)
    step = max(1, PAIR_BLOCK // (8 * max(1, matrix.shape[1])))  # (the solutions make ~10 (pairs, m) temporaries)
    for s in range(0, a.size, step):
        p, q = matrix[a[s : s + step]], matrix[b[s : s + step]]
        solution = threshold_max_many(p, q, lo, hi)
        box[s : s + step] = solution[0]
        if relaxed is not None and floor is not None:
            relaxed[s : s + step] = floor_max_many(p, q, lo, hi, floor, threshold=solution)[0]
    return box, relaxed


Parts = list[tuple[IntArray, IntArray, FloatArray, FloatArray | None]]


def _finish(n: int, parts: Parts, box_fill: float, relaxed_fill: float) -> BoxPairs:
    """Merge the exactly solved pairs (duplicates dropped, row-major)."""
    flat, first = np.unique(np.concatenate([x[0].astype(np.intp) * n + x[1] for x in parts]), return_index=True)
    box = np.concatenate([x[2] for x in parts])[first]
    rel = None if parts[0][3] is None else np.concatenate([x[3] for x in parts if x[3] is not None])[first]
    a, b = np.divmod(flat, n)
    for array in (a, b, box, rel):  # (shared through the cache: read-only)
        if array is not None:
            array.setflags(write=False)
    return BoxPairs(a=a, b=b, box=box, relaxed=rel, box_fill=box_fill, relaxed_fill=relaxed_fill)


def _all_pairs(matrix: FloatArray, lo: float, hi: float, floor: float | None) -> BoxPairs:
    """Every ordered pair solved (a box of zero width, or fewer than two rows)."""
    n = matrix.shape[0]
    a, b = np.nonzero(~np.eye(n, dtype=bool))
    box, rel = pair_values(matrix, a, b, lo, hi, floor)
    return _finish(n, [(a, b, box, rel)], -math.inf, -math.inf)


def _ratio_pairs(matrix: FloatArray, hi: float) -> BoxPairs:
    """lower = 0, no floor: the box value of (a, b) is max(1, max_o M[a, o]/M[b, o]), at most max(1, max_o
    M[a, o]/min_c M[c, o]) for every b; only the rows that can reach the largest are compared with every row."""
    n, m = matrix.shape
    colmin = matrix.min(axis=0)
    rowbest = np.empty(n)
    step = max(1, PAIR_BLOCK // max(1, m))
    for s in range(0, n, step):
        rowbest[s : s + step] = _ratios(matrix[s : s + step], colmin[None, :]).max(axis=-1)
    rowbest = np.maximum(rowbest, 1.0) * (1 + 1e-12)
    threshold = rowbest.max() * (1 - PRUNE)
    parts: Parts = []
    fill = float(rowbest[rowbest < threshold].max(initial=-np.inf))  # the largest bound of a pair set aside
    for a in np.flatnonzero(rowbest >= threshold):
        ratio = np.maximum(pair_ratio(matrix, np.full(n, a), np.arange(n)), 1.0) * (1 + 1e-12)
        ratio[a] = -np.inf
        bs = np.flatnonzero(ratio >= threshold)
        fill = max(fill, float(ratio[ratio < threshold].max(initial=-np.inf)))
        at = np.full(bs.size, a)
        parts.append((at, bs, *pair_values(matrix, at, bs, 0.0, hi, None)))
    return _finish(n, parts, fill, -math.inf)


class _HockeyPairs:
    """One pass over the pairs at λ: (M[a] − λ M[b])·h ≤ W(λ) on the box bounds every pair's value (§7)."""

    def __init__(self, matrix: FloatArray, lo: float, hi: float, floor: float | None) -> None:
        self.matrix, self.lo, self.hi, self.floor = matrix, lo, hi, floor
        self.passer = PairPass(matrix)
        self.best, self.lam = -math.inf, math.nan
        self.fill = -math.inf  # the largest bound of a pair set aside
        self.parts: Parts = []

    def run(self) -> BoxPairs:
        a, b = pair_candidates(self.matrix)
        self._offer(a, b)
        if math.isnan(self.lam):  # (no candidate's relaxation meets every floor: start from the largest box value)
            self.lam = min(float(np.nanmax(self.parts[0][2], initial=1.0)), 1e300)
        self.passer.run(lambda: self.lam, self._visit)
        n, fill = self.matrix.shape[0], self.fill
        if self.floor is None:
            return _finish(n, self.parts, fill, -math.inf)
        return _finish(n, self.parts, math.inf if fill > -math.inf else -math.inf, fill)

    def _offer(self, a: IntArray, b: IntArray) -> None:
        """Solve the pairs exactly, keep them, and raise the best value (and λ) when one beats it."""
        box, rel = pair_values(self.matrix, a, b, self.lo, self.hi, self.floor)
        self.parts.append((a, b, box, rel))
        if rel is None:
            top = float(np.nanmax(box, initial=-np.inf))
            if top > self.best:  # (λ stays finite: an infinite best is tied only by infinite values)
                self.best, self.lam = top, min(top * (1 - PRUNE), 1e300)
            return
        order = np.argsort(-np.where(np.isnan(rel), -np.inf, rel), kind="stable")
        for i in order[:8]:
            if not rel[i] > self.best:
                break
            lam = self._feasible(int(a[i]), int(b[i]))
            if lam is not None:
                self.best, self.lam = float(rel[i]), lam
                break

    def _feasible(self, a: int, b: int) -> float | None:
        """The λ of the pair's relaxation (its boundary ratio) when its point meets every row's floor, else None."""
        p, q, floor = self.matrix[a], self.matrix[b], self.floor
        assert floor is not None  # (only with a floor)
        v, k, frac, order = floor_max_many(p, q, self.lo, self.hi, floor)
        if np.isnan(v):
            return None
        h = box_point(self.lo, self.hi, order, int(k), float(frac))
        h[(p == 0) & (q == 0)] = self.hi
        if not np.all(self.matrix @ h >= floor * (1 - 1e-12) - 1e-15):
            return None
        o = order[min(int(k), p.size - 1)]
        ratio = p[o] / q[o] if q[o] > 0 else math.inf
        return float(ratio) if q @ h <= floor * (1 + 1e-9) and 0 < ratio < math.inf else float(v) * (1 - PRUNE)

    def _visit(self, rows: slice, cols: slice, sums: FloatArray, lam: float) -> None:
        """Bound every pair of the band (Lemma 11); solve those that may reach the best."""
        s, lo, hi, floor = self.passer.sums, self.lo, self.hi, self.floor
        sa, sb = s[rows, None], s[None, cols]
        low_den = lo * sb if floor is None else np.maximum(lo * sb, floor)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            w = lo * (sa - lam * sb) + (hi - lo) * (sums - lam * sb)
            w = w + (hi - lo) * self.passer.error(rows, cols, lam) + 4 * ROUNDING * (lo * sa + lam * hi * sb)
            bound = np.where(w >= 0, lam + w / low_den, lam + w / (hi * sb)) * (1 + 1e-12)
        bound = np.where(np.isnan(bound), np.inf, bound)
        a0, b0 = rows.start, cols.start
        own = np.arange(max(a0, b0), min(rows.stop, cols.stop))
        bound[own - a0, own - b0] = -np.inf
        keep = bound >= self.best * (1 - PRUNE)
        if floor is not None:
            keep |= hi * sb < floor * (1 + 1e-9)
        self.fill = max(self.fill, float(bound[~keep].max(initial=-np.inf)))
        i, j = np.nonzero(keep)
        if i.size:
            self._offer(i + a0, j + b0)


def pairwise_box(
    matrix: FloatArray, lower: float, upper: float, floor: float | None
) -> tuple[FloatArray, FloatArray | None]:
    """The box program of every ordered pair (rows a, b of ``matrix``), and with ``floor`` its floor relaxation.

    Shape (n, n) each (diagonal 1). Exact (the values of :func:`fairaudit.base.threshold_rule.threshold_max_many` and
    :func:`~fairaudit.base.threshold_rule.floor_max_many`) for every pair that can be the largest; elsewhere one valid upper bound
    of them all, below (1 − PRUNE) × the largest, so the maximum, its first row-major maximiser, and a search in
    decreasing order of these bounds are unchanged (:func:`box_pairs`; ``proofs/black_box.md`` §7). With
    ``floor`` the box entries away from the relaxation's maximisers are +inf (upper bounds only).
    """
    n = matrix.shape[0]
    found = box_pairs(matrix, lower, upper, floor)
    box = np.full((n, n), found.box_fill)
    box[found.a, found.b] = found.box
    np.fill_diagonal(box, 1.0)
    if floor is None or found.relaxed is None:
        return box, None
    relaxed = np.full((n, n), found.relaxed_fill)
    relaxed[found.a, found.b] = found.relaxed
    np.fill_diagonal(relaxed, 1.0)
    return box, relaxed
