"""Exact worst cases by linear-fractional programming: every decision model, every utility.

Behind M_A (and any M_X), a decision kernel K and a utility g give

    E[g | x, b] = Σ_{x̃, ã, u} M_X[x, x̃] M_A[b, ã] K[x̃, ã, u] g(u, x, b),

linear in K (and, for a fixed K, linear in g). Each maximum below is, for one
ordered pair of groups (a, a') (and one context x for local g-fairness), a
linear-fractional program max (p·h)/(q·h) over a polytope, solved by
:mod:`fairaudit.lfp`: the likelihood-ratio threshold when only per-cell bounds
constrain h, the Charnes–Cooper LP (cvxpy + Clarabel) otherwise.

* :func:`black_box_bound` — the **class certificate**: the exact maximum of L
  over every kernel and every utility in the class g ∈ [lower, γ],
  E[g | x, a] ≥ τ, |g(u, x, a) − g(u, x, a')| ≤ L_A d(a, a'). The reachable
  vectors are h[b, ã] (the expected utility of a group-b member released as
  ã) in the polytope {lower ≤ h ≤ γ, Lipschitz in b, M_A[b]·h[b] ≥ τ}; with
  L_A = 0, h[b] = h for every b, and without a binding τ the polytope is the
  box [lower, γ]^n (threshold solution). M_X drops out; under X ⊥ A the same
  value is the exact maximum of L̄.
* :func:`worst_model` — the **known-utility certificate**: the exact maximum
  of L and of L̄ over every kernel, for the utility table given, with τ; it
  returns the maximising kernel, a concrete worst decision model.
* :func:`worst_utility` — the **worst-case utility** of a known law: the
  utility g(u) ∈ [lower, γ] (with E[g | x, a] ≥ τ) that shows the largest
  local or global disparity. Without constraints it equals Lemma 1's sup.

Pairs are searched in decreasing order of an upper bound (the box value
without τ, γ/τ, and the per-pair tight form) and the search stops when no
remaining pair can beat the best value found, so the LP runs only where the
fast path does not decide. Proofs: ``proofs/black_box.md``,
``proofs/linear_fractional.md``, ``proofs/worst_case_utility.md``.
"""

from __future__ import annotations

import functools
import itertools
import math
import operator
from collections.abc import Callable, Hashable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, SupportsIndex

import numpy as np
import numpy.typing as npt

from ._arrays import BoolArray, FloatArray, IntArray, format_label
from ._errors import InputError
from .bounds import Assumption, _nonneg, check_assumptions
from .laws import Kernel, Law, Population, compose
from .lfp import FractionalProgram, FractionalResult, box_point, floor_max_many, threshold_max_many
from .privacy import _RR, Mechanism, _RandomizedResponse, _row_blocks, identity
from .utility import Utility, check_metric

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = [
    "BlackBoxCertificate",
    "WorstCase",
    "WorstModel",
    "WorstUtility",
    "black_box_bound",
    "worst_model",
    "worst_utility",
]

METHODS = ("auto", "threshold", "lp")


# ----------------------------------------------------------------------------------------------------
# shared machinery
# ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Search:
    index: int  # flat index of the maximising problem (-1 when none)
    result: FractionalResult | None
    solved: int  # LPs solved
    reason: str


def _search(upper: FloatArray, solve: Callable[[int], FractionalResult]) -> _Search:
    """Maximise over problems i by LP, in decreasing order of the upper bounds ``upper[i]`` (ratios).

    Stops when the best value found is at least every remaining upper bound
    (exact: the bounds are valid). An infeasible program means the common
    polytope is empty, which ends the search.
    """
    order = np.argsort(-upper, kind="stable")
    best_i, best, best_v, solved = -1, None, -math.inf, 0
    for i in order:
        if best is not None and best_v >= upper[i] * (1 - 1e-9):
            break
        r = solve(int(i))
        solved += r.method == "lp"
        if r.status == "infeasible":
            return _Search(-1, r, solved, r.reason)
        if best is None or r.value > best_v * (1 + 1e-9):  # ties (to solver accuracy) keep the earlier pair
            best_i, best, best_v = int(i), r, r.value
        if math.isinf(best_v):
            break
    return _Search(best_i, best, solved, "")


def _relaxed_first(
    num: Callable[[int], FloatArray],
    den: Callable[[int], FloatArray],
    lower: float,
    upper: float,
    floor: float | None,
    rows: npt.NDArray[np.floating[Any]] | None,
    program: Callable[[], FractionalProgram],
) -> Callable[[int], FractionalResult]:
    """Solve problem i by the closed-form floor relaxation when its point is feasible, by the LP otherwise.

    The relaxation keeps the box and only the denominator's constraint q·h ≥ floor
    (:func:`fairaudit.lfp.floor_max_many`); its point is optimal for the full
    program whenever it meets every row of ``rows @ h ≥ floor``. With no
    floor the program is the box program and the threshold solves it.
    """

    def solve(i: int) -> FractionalResult:
        p, q = num(i), den(i)
        frac: float | FloatArray
        if floor is None:
            v, k, order = threshold_max_many(p, q, lower, upper)
            frac = 0.0
        else:
            v, k, frac, order = floor_max_many(p, q, lower, upper, floor)
        if not np.isnan(v):
            h = box_point(lower, upper, order, int(k), float(frac))
            free = (p == 0) & (q == 0)  # cells outside the objective: the top of the box helps every τ row
            h[free] = np.broadcast_to(np.asarray(upper, dtype=float), h.shape)[free]
            if rows is None or floor is None or np.all(rows @ h >= floor * (1 - 1e-12) - 1e-15):
                status = "unbounded" if math.isinf(v) else "optimal"
                return FractionalResult(float(v), h, status, "threshold", "closed form", "", p, q, None, None)
        return program().solve(p, q)

    return solve


def _check_method(method: str) -> str:
    if method not in METHODS:
        raise InputError("method", f"must be one of {', '.join(METHODS)}", method)
    return method


def _check_class(lower: float, gamma: float, tau: float | None) -> tuple[float, float, float | None]:
    """Validate a utility class [lower, γ] with floor τ ≤ γ (τ may be None)."""
    lower, gamma = _nonneg("lower", lower), _nonneg("gamma", gamma)
    if lower > gamma:
        raise InputError("lower", f"cannot exceed gamma = {gamma:g}", lower)
    if tau is not None:
        tau = _nonneg("tau", tau)
        if tau > gamma:
            raise InputError(
                "tau", f"exceeds gamma = {gamma:g}: no utility in [lower, gamma] has E[g | x, a] >= tau", tau
            )
    return lower, gamma, tau


def _log(r: float) -> float:
    return math.inf if math.isinf(r) else math.log(r) if r > 0 else -math.inf


def _pair_epsilon(matrix: FloatArray) -> FloatArray:
    """max_o M[a, o] / M[b, o] for every ordered pair, shape (n, n) (c/0 = inf, 0/0 ignored)."""
    n = matrix.shape[0]
    out = np.empty((n, n))
    q = matrix[None, :, :]
    for rows in _row_blocks(n, n * matrix.shape[1]):  # (block, n, m) at a time
        p = matrix[rows, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(q > 0, p / np.where(q > 0, q, 1.0), np.where(p > 0, np.inf, 0.0))
        out[rows] = r.max(axis=-1)
    return out


def _pairwise_box(
    matrix: FloatArray, lower: float, upper: float, floor: float | None
) -> tuple[FloatArray, FloatArray | None]:
    """The box program of every ordered pair (rows a, b of ``matrix``), and with ``floor`` its floor relaxation.

    The threshold and relaxation values, shape (n, n), computed a block of rows at a time, so the
    (n, n, m) sorts and prefix sums never exist all at once.
    """
    n = matrix.shape[0]
    box = np.empty((n, n))
    relaxed = None if floor is None else np.empty((n, n))
    q = matrix[None, :, :]
    for rows in _row_blocks(n, 4 * n * matrix.shape[1]):
        p = matrix[rows, None, :]
        solution = threshold_max_many(p, q, lower, upper)
        box[rows] = solution[0]
        if relaxed is not None and floor is not None:
            relaxed[rows] = floor_max_many(p, q, lower, upper, floor, threshold=solution)[0]
    return box, relaxed


# ----------------------------------------------------------------------------------------------------
# k-ary randomized response in closed form (proofs/black_box.md §3)
# ----------------------------------------------------------------------------------------------------
_TIE = 1e-12  # relative tolerance of the threshold solution's ties (as lfp.threshold_max_many)


@dataclass(frozen=True)
class _RRWorst:
    """The worst case of the pair (a, a') = (first group, second group) behind k-ary randomized response.

    Every ordered pair is alike (the mechanism is symmetric), so one pair decides. The maximiser h over the
    released values is h[a] = ``h_a``, h[a'] = ``h_b``, the first ``first`` other values (in index order)
    ``h_first``, the next one ``h_next``, the rest ``h_rest``. ``prefix``: h is a threshold prefix (released
    values listed in the likelihood-ratio order a, others, a'), else a floor point (listed in index order).
    """

    ratio: float
    value: float  # log ratio, exact also where the ratio overflows (lower = 0: ε itself)
    h_a: float
    h_b: float
    first: int
    h_first: float
    h_next: float
    h_rest: float
    prefix: bool

    def vector(self, k: int) -> FloatArray:
        h = np.full(k, self.h_rest)
        j = min(self.first, k - 2)
        h[2 : 2 + j] = self.h_first
        if 2 + j < k:
            h[2 + j] = self.h_next
        h[0], h[1] = self.h_a, self.h_b
        return h

    def released(self, k: int, hi: float) -> IntArray:
        """Indices of the released values where h is at the top of the box (``hi``)."""
        at_top = np.flatnonzero(self.vector(k) >= hi - 1e-9 * max(1.0, hi))
        if self.prefix and at_top.size and at_top[0] == 0 and 1 in at_top[:2]:
            at_top = np.concatenate([at_top[at_top != 1], [1]])  # a' comes last in the ratio order
        return at_top


def _rr_box(rr: _RR, lo: float, hi: float, floor: float) -> _RRWorst:
    """max (M[a]·h)/(M[a']·h) over lo ≤ h ≤ hi with M[a']·h ≥ floor, M = k-ary RR, in O(1).

    Without a binding floor (floor ≤ lo) the threshold solution: h = hi on the released value a, lo elsewhere,
    ratio (lo + (hi − lo)p)/(lo + (hi − lo)q) (proofs/black_box.md, Proposition 3), with the longest prefix tied
    to 1e-12 (as the general route). With a binding floor the relaxation that keeps only M[a']·h ≥ floor
    (lfp.floor_max_many): raise a, then the other values, then a', until M[a']·h = floor; for randomized response
    its point meets every group's floor, so it is the optimum of the whole class (proofs/black_box.md, §3,
    Proposition 3b). ``floor`` must be ≤ hi.
    """
    k, p, q = rr.k, rr.p, rr.q
    span = hi - lo
    if span <= 0 or p <= q:  # every prefix ties at ratio 1: the longest one, h = hi everywhere (index order)
        return _RRWorst(1.0, 0.0, hi, hi, k, hi, hi, hi, False)
    num, den = lo + span * p, lo + span * q
    if lo > 0:
        ratio = num / den
        if den > 1e-290:
            value = math.log(ratio)
        else:  # (q underflows: log(lo + span q) from log q, which does not)
            value = math.log(num) - float(np.logaddexp(math.log(lo), math.log(span) + rr.log_q))
            ratio = math.exp(value) if value < 709.0 else math.inf
    else:  # (p/q = e^ε; its log is ε even where p/q overflows)
        ratio = math.inf if q == 0 else p / q
        value = rr.log_p - rr.log_q
    first = 0
    c = span * q
    tied = ratio * (1 - _TIE)
    if tied <= 1:  # the ratio is 1 to rounding: every prefix ties, the longest is all of them
        return _RRWorst(ratio, value, hi, hi, k, hi, hi, hi, True)
    if c > 0 and math.isfinite(tied):  # others add c to both sides: tied while (num + jc)/(den + jc) >= tied
        first = min(k - 2, int(math.floor(_TIE * num / (c * (tied - 1)))))
    if floor <= lo or den + first * c >= floor * (1 - 1e-12):
        return _RRWorst(ratio, value, hi, lo, first, hi, lo, lo, True)
    need = floor - lo
    if q > 0 and need <= c * (k - 1):  # a and x other values raised: value (floor + span (p − q))/floor
        x = need / c - 1.0
        first = min(k - 2, int(math.floor(x)))
        frac = min(1.0, max(0.0, x - first))
        ratio = (floor + span * (p - q)) / floor
        return _RRWorst(ratio, math.log(ratio), hi, lo, first, hi, lo + frac * span, lo, False)
    s = min(span, (need - c * (k - 1)) / p)  # a and every other value raised, a' partly
    ratio = (lo + span * (p + (k - 2) * q) + q * s) / floor
    return _RRWorst(ratio, math.log(ratio), hi, lo + s, k - 2, hi, hi, hi, False)


def _rr_lipschitz(
    rr: _RR, lo: float, hi: float, floor: float, lam: float
) -> tuple[float, FloatArray, FloatArray] | None:
    """The class with L_A > 0 behind k-ary RR, discrete metric (λ = L_A d): (ratio, g, f) in O(1), or None if unbounded.

    By symmetry (averaging a maximiser over the permutations of the other groups keeps it feasible and, the
    objective being linear-fractional, optimal) the worst case has h[a'] = g = (x at a, z at a', y at each other
    value) and every other group, a included, at the largest vector the Lipschitz condition allows,
    f = min(g + λ, hi) (proofs/black_box.md, §5, "Randomized response"). Its value is a linear-fractional program
    in (x, z, y) on each of the 8 pieces where f is affine; the maximum is at a vertex of one piece, so every
    vertex (3 of the ≤ 9 planes) is tried. Returns the ratio and the vectors g, f of the three cells (a, a', other).
    """
    k, p, q = rr.k, rr.p, rr.q
    m = k - 2  # other released values
    binding = floor > lo
    if lo == 0 and not binding:
        return None  # g = 0, f = λ: λ/0
    cut = hi - lam
    pieces = []  # per cell: (low, high, slope of f, intercept of f)
    if cut >= lo:
        pieces.append((lo, min(hi, cut), 1.0, lam))
    pieces.append((max(lo, cut), hi, 0.0, hi))
    n_vec = np.array([p, q, m * q])  # numerator: M[a]·f
    d_vec = np.array([q, p, m * q])  # denominator: M[a']·g
    b_vec = np.array([q, q, p + (m - 1) * q]) if m >= 1 else None  # another group's floor: M[b]·f
    best, best_g = -math.inf, None
    for cells in itertools.product(pieces, repeat=3):
        low = np.array([c[0] for c in cells])
        high = np.array([c[1] for c in cells])
        slope = np.array([c[2] for c in cells])
        icpt = np.array([c[3] for c in cells])
        rows = [np.eye(3)[i] * sign for sign in (-1.0, 1.0) for i in range(3)]
        rhs = [-low[i] for i in range(3)] + [high[i] for i in range(3)]
        if binding:
            rows.append(-d_vec)
            rhs.append(-floor)
            rows.append(-n_vec * slope)
            rhs.append(n_vec @ icpt - floor)
            if b_vec is not None:
                rows.append(-b_vec * slope)
                rhs.append(b_vec @ icpt - floor)
        a_ub, b_ub = np.array(rows), np.array(rhs)
        combos = np.array(list(itertools.combinations(range(len(rows)), 3)))
        mats = a_ub[combos]
        ok = np.abs(np.linalg.det(mats)) > 1e-12
        if not ok.any():
            continue
        pts = np.linalg.solve(mats[ok], b_ub[combos[ok]][..., None])[..., 0]
        feas = np.all(pts @ a_ub.T <= b_ub + 1e-12 * (1.0 + np.abs(b_ub)), axis=1)
        pts = pts[feas]
        if not pts.size:
            continue
        num = (pts * slope + icpt) @ n_vec
        den = pts @ d_vec
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 1.0))
        i = int(np.argmax(ratio))
        if ratio[i] > best:
            best, best_g = float(ratio[i]), pts[i]
    if best_g is None:
        return math.nan, np.full(3, math.nan), np.full(3, math.nan)
    g = np.clip(best_g, lo, hi)
    return best, g, np.minimum(g + lam, hi)


def _rr_class_ratio(rr: _RR, lower: float, gamma: float, tau: float | None, lipschitz: float, diameter: float) -> float:
    """The black-box ratio of k-ary RR for the class [lower, γ], E ≥ τ, L_A (discrete metric scaled to ``diameter``).

    O(1): what :func:`black_box_bound` returns for a :class:`~fairaudit.privacy._RandomizedResponse`, without
    the worst model (calibration evaluates it along the family).
    """
    if rr.k < 2 or gamma == 0 or lower == gamma:
        return 1.0
    lo, floor = lower / gamma, (lower if tau is None else max(tau, lower)) / gamma
    lam = lipschitz * diameter / gamma
    if lam > 0:
        out = _rr_lipschitz(rr, lo, 1.0, floor, lam)
        return math.inf if out is None else out[0]
    return _rr_box(rr, lo, 1.0, floor).ratio


def _rr_class_value(rr: _RR, lower: float, gamma: float, tau: float | None, lipschitz: float, diameter: float) -> float:
    """log of :func:`_rr_class_ratio`, exact where the ratio overflows (lower = 0, L_A = 0: ε)."""
    if rr.k >= 2 and gamma > 0 and lower < gamma and lipschitz * diameter == 0:
        lo, floor = lower / gamma, (lower if tau is None else max(tau, lower)) / gamma
        return _rr_box(rr, lo, 1.0, floor).value
    return _log(_rr_class_ratio(rr, lower, gamma, tau, lipschitz, diameter))


def _rr_law(kernel: Kernel, rr: _RR, groups: tuple, context_mechanism: Mechanism) -> Law:
    """compose(kernel, RR, M_X) without the k x k matrix: Q[x, a] = Σ_x̃ M_X[x, x̃] (q Σ_ã K[x̃, ã] + (p − q) K[x̃, a])."""
    k = kernel.probabilities
    behind = rr.q * k.sum(axis=1, keepdims=True) + (rr.p - rr.q) * k  # (x̃, a, u)
    law = behind if context_mechanism.is_identity else np.tensordot(context_mechanism.matrix, behind, axes=1)
    law = law / law.sum(axis=-1, keepdims=True)
    return Law(law, context_mechanism.inputs, groups, kernel.decisions, name="law", _owned=True)


# ----------------------------------------------------------------------------------------------------
# the class certificate
# ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class BlackBoxCertificate:
    """The exact maximum of L over every decision model and every utility in a class.

    Attributes
    ----------
    value : float
        max L in nats (+inf when the class allows E[g | x, a'] → 0 with
        E[g | x, a] > 0; NaN when the class is empty).
    ratio : float
        exp(value).
    group, other_group : hashable or None
        The maximising pair of true groups (``group`` gets more utility).
    released : tuple
        The released values ã on which the worst model gives utility γ.
    utility_by_release : numpy.ndarray
        The worst case's expected utility given the release: shape
        (n_released,) when g does not depend on the group (L_A = 0),
        (n_groups, n_released) otherwise (row b for a member of group b).
    lower, gamma : float
        The class of utilities [lower, γ].
    tau : float or None
        The lower bound on E[g | x, a] (None: only lower).
    lipschitz : float
        L_A (0: g does not depend on the group).
    mechanism : Mechanism
        M_A.
    method : {"threshold", "lp"}
        ``threshold``: decided in closed form (the threshold solution, or
        with a binding τ the floor relaxation whose point met every
        constraint); ``lp``: at least one Charnes–Cooper LP was solved.
    status : {"optimal", "unbounded", "infeasible", "trivial"}
    solver_status : str
    reason : str
        Why the value is +inf or NaN, or which shortcut decided it.
    programs_solved : int
        LPs solved (0 on the threshold path).
    assumptions : tuple of Assumption
    """

    value: float
    ratio: float
    group: Hashable | None
    other_group: Hashable | None
    released: tuple
    utility_by_release: FloatArray
    lower: float
    gamma: float
    tau: float | None
    lipschitz: float
    mechanism: Mechanism
    method: str
    status: str
    solver_status: str
    reason: str
    programs_solved: int
    assumptions: tuple[Assumption, ...]

    @property
    def form(self) -> str:
        """Always ``"black_box"``, like :attr:`fairaudit.bounds.Bound.form`."""
        return "black_box"

    def worst_model(self) -> tuple[Kernel, Utility]:
        """A concrete decision model and utility that attain the value.

        Returns
        -------
        kernel : Kernel
            One context ``"any"``, the mechanism's outputs as groups,
            decisions ``("high", "low")``: P(high | ã) = (h(ã) − lower)/(γ − lower).
        utility : Utility
            g(high) = γ, g(low) = lower.

        Raises
        ------
        InputError
            When g depends on the group (L_A > 0: the worst model then needs
            a utility per group) or when there is no maximiser.
        """
        h = self.utility_by_release
        if h.ndim != 1 or self.status not in ("optimal", "trivial"):
            raise InputError(
                "worst_model",
                "is available for utilities that do not depend on the group, with a finite optimum",
                self.status,
            )
        span = self.gamma - self.lower
        high = np.clip((h - self.lower) / span, 0.0, 1.0) if span > 0 else np.ones_like(h)
        table = np.stack([high, 1.0 - high], axis=-1)[None, :, :]
        kernel = Kernel(table, ["any"], self.mechanism.outputs, ["high", "low"], name="worst model")
        return kernel, Utility([self.gamma, self.lower], ["high", "low"], name="worst utility")

    def __repr__(self) -> str:
        tau = "" if self.tau is None else f", tau={self.tau:g}"
        return (
            f"BlackBoxCertificate(value={self.value:.6g} nats, ratio={self.ratio:.6g}, "
            f"pair={self.group!r} vs {self.other_group!r}, class [{self.lower:g}, {self.gamma:g}]{tau}, "
            f"method={self.method})"
        )


def black_box_bound(
    mechanism: Mechanism,
    *,
    lower: float = 0.0,
    gamma: float = 1.0,
    tau: float | None = None,
    lipschitz: float = 0.0,
    metric: npt.ArrayLike | None = None,
    population: Population | None = None,
    method: str = "auto",
) -> BlackBoxCertificate:
    """Exact max of local g-fairness over every decision model behind M_A, for a class of utilities.

    The class: g(u, x, a) ∈ [lower, γ]; E[g | x, a] ≥ τ for every context and
    group; |g(u, x, a) − g(u, x, a')| ≤ L_A d(a, a'). The value is
    max over ordered pairs (a, a') of max (M_A[a]·h[a]) / (M_A[a']·h[a']) over
    h ∈ R^{n_groups × n_released} with lower ≤ h ≤ γ, |h[b] − h[c]| ≤ L_A d(b, c)
    and M_A[b]·h[b] ≥ τ for every b (h[b] = h for all b when L_A = 0).

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released).
    lower, gamma : float
        The range of g, 0 ≤ lower ≤ γ.
    tau : float, optional
        Lower bound on E[g | x, a], ≤ γ. E ≥ lower always holds, so τ ≤ lower
        changes nothing.
    lipschitz : float
        L_A ≥ 0; 0 means g does not depend on the group.
    metric : array_like, shape (n_groups, n_groups), optional
        d(a, a') for the Lipschitz condition; default the discrete metric.
    population : Population, optional
        When given, X ⊥ A is checked on it (needed for the bound on L̄ only).
    method : {"auto", "threshold", "lp"}
        ``auto``: the threshold solution when τ ≤ lower and L_A = 0; with a
        binding τ, the closed-form relaxation that keeps only the denominator
        group's constraint, checked against the others, and the LP where it
        fails; the LP when L_A > 0. Pairs are searched in decreasing order of
        that relaxation (an upper bound) and the search stops when no pair
        left can win. ``lp`` forces the LP (a cross-check); ``threshold``
        raises when τ binds or L_A > 0.

    Returns
    -------
    BlackBoxCertificate
        The value in nats, the maximising pair, and the worst model's
        expected utility per released value.

    Raises
    ------
    InputError
        If ``lower``, ``gamma``, ``tau`` or ``lipschitz`` is negative or not
        finite, lower > γ, τ > γ (the class is empty), the metric is invalid,
        or the method is unknown or does not apply.

    Notes
    -----
    M_X drops out, and under X ⊥ A the value also bounds L̄ exactly. It is
    never larger than the tight and paper bounds with the same τ, L_A and
    metric; with lower = 0, no τ and L_A = 0 it is ε(M_A) (the corollary is
    attained). ``proofs/black_box.md``.

    For k-ary randomized response (the mechanism
    :func:`~fairaudit.privacy.randomized_response` returns) every pair is
    alike and the value is a closed form, O(1) with the worst h in O(k):
    the threshold and the floor relaxation (``proofs/black_box.md`` §3,
    Propositions 3 and 3b) and, with L_A > 0 and the discrete metric (or
    without a binding τ, any metric), a 3-variable program solved at its
    vertices (§5, Proposition 7b; ``utility_by_release`` is then the
    k x k table). ``method="lp"`` forces the general route.

    Examples
    --------
    >>> from fairaudit.privacy import randomized_response
    >>> m = randomized_response(["a", "b"], keep=0.7)
    >>> round(black_box_bound(m).ratio, 12)                       # 0.7 / 0.3
    2.333333333333
    >>> c = black_box_bound(m, lower=0.5, gamma=1.0)               # (0.5 + 0.5·0.7) / (0.5 + 0.5·0.3)
    >>> round(c.ratio, 12), c.group, c.released
    (1.307692307692, 'a', ('a',))
    >>> c = black_box_bound(m, tau=0.5)                            # (0.7 + 0.3·2/7) / 0.5 = 11/7
    >>> round(c.ratio, 12), c.method, c.utility_by_release.round(7).tolist()
    (1.571428571429, 'threshold', [1.0, 0.2857143])
    >>> round(black_box_bound(m, tau=0.5, method="lp").ratio, 7)  # the Charnes–Cooper LP agrees
    1.5714286
    """
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    method = _check_method(method)
    lower, gamma, tau = _check_class(lower, gamma, tau)
    lip = _nonneg("lipschitz", lipschitz)
    n, m = len(mechanism.inputs), len(mechanism.outputs)
    rr = mechanism.rr if isinstance(mechanism, _RandomizedResponse) and method != "lp" else None
    # (k-ary randomized response with the discrete metric never needs the n x n metric)
    d = check_metric(metric, n) if n >= 1 and (metric is not None or rr is None) else None
    floor = lower if tau is None else max(tau, lower)  # E[g | x, a] >= floor
    binding = floor > lower
    lip_on = lip > 0 and n >= 2 and gamma > lower
    if method == "threshold" and (binding or lip_on):
        raise InputError("method", "the threshold solution needs tau <= lower and lipschitz = 0", method)

    assumptions = check_assumptions(mechanism, tau=None, gamma=None, population=population) + (
        Assumption("g in [lower, gamma]", "vouched", f"class [{lower:g}, {gamma:g}]"),
        Assumption(
            "g Lipschitz in the group" if lip_on else "g depends on the decision (and context) only",
            "vouched",
            f"L_A = {lip:g}" if lip_on else "L_A = 0",
        ),
    )
    if tau is not None:
        assumptions += (Assumption("E[g | x, a] >= tau for every model", "vouched", f"tau = {tau:g}"),)

    if gamma > 0 and gamma != 1.0:
        # Only the shape of the class matters: solve it on the scale gamma = 1 (well-conditioned LPs), scale back.
        unit = black_box_bound(
            mechanism,
            lower=lower / gamma,
            gamma=1.0,
            tau=None if tau is None else tau / gamma,
            lipschitz=lip / gamma,
            metric=metric,
            population=population,
            method=method,
        )
        return replace(
            unit,
            utility_by_release=unit.utility_by_release * gamma,
            lower=lower,
            gamma=gamma,
            tau=tau,
            lipschitz=unit.lipschitz * gamma,
            assumptions=assumptions,
        )

    def make(
        value_ratio: float,
        a: Hashable | None,
        b: Hashable | None,
        released: tuple,
        h: FloatArray,
        meth: str,
        status: str,
        solver: str,
        reason: str,
        solved: int,
    ) -> BlackBoxCertificate:
        value = _log(value_ratio) if not math.isnan(value_ratio) else math.nan
        return BlackBoxCertificate(
            value,
            value_ratio,
            a,
            b,
            released,
            h,
            lower,
            gamma,
            tau,
            lip if lip_on else 0.0,
            mechanism,
            meth,
            status,
            solver,
            reason,
            solved,
            assumptions,
        )

    if n < 2 or gamma == 0 or lower == gamma:
        reason = "fewer than two groups" if n < 2 else "every utility in the class is constant"
        return make(1.0, None, None, (), np.full(m, gamma), "threshold", "trivial", "threshold", reason, 0)

    if rr is not None:
        # k-ary randomized response: every ordered pair is alike, closed forms (proofs/black_box.md §3 and §5)
        outputs, inputs = mechanism.outputs, mechanism.inputs
        if not lip_on:
            w = _rr_box(rr, lower, gamma, floor)
            inf = math.isinf(w.value)
            return BlackBoxCertificate(
                w.value,
                w.ratio,
                inputs[0],
                inputs[1],
                tuple(outputs[o] for o in w.released(n, gamma)),
                w.vector(n),
                lower,
                gamma,
                tau,
                0.0,
                mechanism,
                "threshold",
                "unbounded" if inf else "optimal",
                "threshold" if w.prefix else "closed form",
                "some released value is possible for one group and impossible for another" if inf else "",
                0,
                assumptions,
            )
        off = None if d is None else d[~np.eye(n, dtype=bool)]
        discrete = off is None or bool(np.all(off == off[0]))
        if discrete or not binding:
            # (without a binding τ any metric: the other groups extend the pair's h, McShane; the pair of diameter)
            a, b = (0, 1) if d is None or discrete else np.unravel_index(int(np.argmax(d)), d.shape)
            lam = lip * (1.0 if off is None else float(off.max()))
            closed = _rr_lipschitz(rr, lower, gamma, floor, lam)
            if closed is None:
                return make(
                    math.inf,
                    inputs[a],
                    inputs[b],
                    (),
                    np.full((n, m), math.nan),
                    "threshold",
                    "unbounded",
                    "closed form",
                    "the ratio is unbounded: feasible h approach q·h = 0 with p·h > 0 (lower = 0 and no tau: "
                    "g = 0 for one group and L_A d(a, a') for the other)",
                    0,
                )
            ratio, g3, f3 = closed
            cells = np.full(m, 2)
            cells[a], cells[b] = 0, 1
            f, g = f3[cells], g3[cells]
            if d is None or discrete:
                h = np.broadcast_to(f, (n, m)).copy()
            else:  # the largest Lipschitz extension of (f at a, g at b) to the other groups
                h = np.clip(
                    np.minimum(f[None, :] + lip * d[:, a, None], g[None, :] + lip * d[:, b, None]), lower, gamma
                )
            h[a], h[b] = f, g
            top = np.flatnonzero(f >= gamma - 1e-9 * max(1.0, gamma))
            return make(
                ratio,
                inputs[a],
                inputs[b],
                tuple(outputs[o] for o in top),
                h,
                "threshold",
                "optimal",
                "closed form",
                "",
                0,
            )
    if d is None:
        d = check_metric(metric, n)
    M = mechanism.matrix
    outputs = mechanism.outputs
    # the box programs of every ordered pair, and with a binding τ their floor relaxations, a block of rows at a time
    box, relaxed = _pairwise_box(M, lower, gamma, floor if binding and not lip_on else None)
    np.fill_diagonal(box, -np.inf)

    if not binding and not lip_on and method != "lp":
        a, b = np.unravel_index(int(box.argmax()), box.shape)
        _, k_ab, order_ab = threshold_max_many(M[a], M[b], lower, gamma)  # the maximising pair's prefix
        top = order_ab[: int(k_ab)]
        h = np.full(m, lower)
        h[top] = gamma
        ratio = float(box[a, b])
        status = "unbounded" if math.isinf(ratio) else "optimal"
        reason = "some released value is possible for one group and impossible for another" if math.isinf(ratio) else ""
        return make(
            ratio,
            mechanism.inputs[a],
            mechanism.inputs[b],
            tuple(outputs[o] for o in top),
            h,
            "threshold",
            status,
            "threshold",
            reason,
            0,
        )

    # ---- LP: τ binds, the utility may depend on the group, or the LP was asked for ----
    pairs = np.argwhere(~np.eye(n, dtype=bool))  # the ordered pairs a != b, row-major
    # valid upper bounds per pair (ratios): the box without τ (L_A = 0), γ/τ, and the tight form at t = e^ε_aa'
    upper = box[pairs[:, 0], pairs[:, 1]].copy() if not lip_on else np.full(len(pairs), np.inf)
    if floor > 0:
        t = _pair_epsilon(M)[pairs[:, 0], pairs[:, 1]]
        slack = lip * d[pairs[:, 0], pairs[:, 1]] / floor if lip_on else 0.0
        upper = np.minimum(upper, np.minimum(gamma / floor, t + slack))

    if not lip_on:
        progs: list[FractionalProgram] = []

        def program() -> FractionalProgram:
            if not progs:
                a_ub = -M if binding else None
                progs.append(
                    FractionalProgram(
                        m, lower=lower, upper=gamma, A_ub=a_ub, b_ub=None if a_ub is None else -floor * np.ones(n)
                    )
                )
            return progs[0]

        if binding:
            assert relaxed is not None  # (computed above for a binding τ without L_A)
            upper = np.minimum(upper, relaxed[pairs[:, 0], pairs[:, 1]])
        if binding and method != "lp":
            solve = _relaxed_first(lambda i: M[pairs[i, 0]], lambda i: M[pairs[i, 1]], lower, gamma, floor, M, program)
        else:

            def solve(i: int) -> FractionalResult:
                a, b = pairs[i]
                return program().solve(M[a], M[b])
    else:
        prog = _lipschitz_program(M, lower, gamma, floor if binding else None, lip, d)

        def solve(i: int) -> FractionalResult:
            a, b = pairs[i]
            p = np.zeros(n * m)
            q = np.zeros(n * m)
            p[a * m : (a + 1) * m] = M[a]
            q[b * m : (b + 1) * m] = M[b]
            return prog.solve(p, q)

    found = _search(upper, solve)
    r = found.result
    if found.index < 0:
        return make(
            math.nan,
            None,
            None,
            (),
            np.full(m, math.nan),
            "lp",
            "infeasible",
            r.solver_status if r else "",
            found.reason or "the class is empty",
            found.solved,
        )
    assert r is not None  # a maximising pair was found
    a, b = pairs[found.index]
    if r.argmax is None:
        h = np.full(m if not lip_on else (n, m), math.nan)
        released: tuple = ()
    else:
        h = r.argmax if not lip_on else r.argmax.reshape(n, m)
        h = np.clip(h, lower, gamma)
        row = h if not lip_on else h[a]
        released = tuple(outputs[o] for o in np.flatnonzero(row >= gamma - 1e-9 * max(1.0, gamma)))
    meth = "lp" if found.solved else "threshold"
    return make(
        r.value,
        mechanism.inputs[a],
        mechanism.inputs[b],
        released,
        h,
        meth,
        r.status,
        r.solver_status,
        r.reason,
        found.solved,
    )


def _lipschitz_program(
    M: FloatArray, lower: float, gamma: float, floor: float | None, lip: float, d: FloatArray
) -> FractionalProgram:
    """The class polytope with a utility per group: h (n, m) flattened row-major."""
    import scipy.sparse as sp

    n, m = M.shape
    rows: list[sp.csr_matrix] = []
    b_ub: list[FloatArray] = []
    bi, ci = np.triu_indices(n, 1)
    limit = lip * d[bi, ci]
    keep = limit < gamma - lower  # looser pairs are implied by the box
    bi, ci, limit = bi[keep], ci[keep], limit[keep]
    if bi.size:
        k = bi.size * m
        r = np.arange(k)
        o = np.tile(np.arange(m), bi.size)
        col_b = np.repeat(bi, m) * m + o
        col_c = np.repeat(ci, m) * m + o
        diff = sp.csr_matrix(
            (np.concatenate([np.ones(k), -np.ones(k)]), (np.concatenate([r, r]), np.concatenate([col_b, col_c]))),
            shape=(k, n * m),
        )
        rows += [diff, -diff]
        b_ub += [np.repeat(limit, m), np.repeat(limit, m)]
    if floor is not None:
        # −M[b]·h[b] ≤ −τ: block-diagonal rows
        tau_rows = sp.block_diag([-M[b][None, :] for b in range(n)], format="csr")
        rows.append(tau_rows)
        b_ub.append(np.full(n, -floor))
    a_ub = sp.vstack(rows, format="csr") if rows else None
    return FractionalProgram(
        n * m, lower=lower, upper=gamma, A_ub=a_ub, b_ub=None if a_ub is None else np.concatenate(b_ub)
    )


# ----------------------------------------------------------------------------------------------------
# known utility: the worst decision model
# ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class WorstCase:
    """The maximiser of one worst-case search (local or global).

    Attributes
    ----------
    kind : {"local", "global"}
    value : float
        The maximum, in nats (+inf when unbounded; NaN when no model or
        utility meets the constraints).
    ratio : float
        exp(value).
    context : hashable or None
        The maximising context (local only).
    group, other_group : hashable or None
        The maximising pair; ``group`` gets more utility.
    kernel : Kernel or None
        The worst decision model (from :func:`worst_model`).
    utility : Utility or None
        The worst utility (from :func:`worst_utility`).
    expected_utility : numpy.ndarray or None
        E[g | x, a] of the worst case, shape (n_contexts, n_groups) (local),
        or E[g | a], shape (n_groups,) (global).
    method : {"threshold", "lp"}
    status : {"optimal", "unbounded", "infeasible", "trivial"}
    solver_status : str
    reason : str
    programs_solved : int
    """

    kind: str
    value: float
    ratio: float
    context: Hashable | None
    group: Hashable | None
    other_group: Hashable | None
    kernel: Kernel | None
    utility: Utility | None
    expected_utility: FloatArray | None
    method: str
    status: str
    solver_status: str
    reason: str
    programs_solved: int

    @classmethod
    def infeasible(cls, kind: str, solver_status: str, reason: str, programs_solved: int) -> WorstCase:
        """No model (or utility) of the class meets the constraints: NaN value, no maximiser, status "infeasible"."""
        return cls(
            kind=kind,
            value=math.nan,
            ratio=math.nan,
            context=None,
            group=None,
            other_group=None,
            kernel=None,
            utility=None,
            expected_utility=None,
            method="lp",
            status="infeasible",
            solver_status=solver_status,
            reason=reason,
            programs_solved=programs_solved,
        )

    def __repr__(self) -> str:
        where = f", context={format_label(self.context)!r}" if self.context is not None else ""
        return (
            f"WorstCase({self.kind}, value={self.value:.6g} nats{where}, groups "
            f"{format_label(self.group)!r} vs {format_label(self.other_group)!r}, method={self.method})"
        )


@dataclass(frozen=True, eq=False)
class WorstModel:
    """The exact maxima of L and L̄ over every decision model, for one utility (:func:`worst_model`).

    Attributes
    ----------
    local, global_ : WorstCase
        Each with its maximising kernel.
    mechanism, context_mechanism : Mechanism
        M_A and M_X.
    utility : Utility
    tau : float or None
    population : Population
    excluded : tuple of str
        Contexts left out (P(X = x) = 0).
    assumptions : tuple of Assumption
    """

    local: WorstCase
    global_: WorstCase
    mechanism: Mechanism
    context_mechanism: Mechanism
    utility: Utility
    tau: float | None
    population: Population
    excluded: tuple[str, ...]
    assumptions: tuple[Assumption, ...]


def _onehot(idx: IntArray, n: int) -> FloatArray:
    out = np.zeros(idx.shape + (n,))
    np.put_along_axis(out, idx[..., None], 1.0, axis=-1)
    return out


def worst_model(
    mechanism: Mechanism,
    utility: Utility,
    *,
    context_mechanism: Mechanism | None = None,
    population: Population | None = None,
    tau: float | None = None,
    method: str = "auto",
) -> WorstModel:
    """The decision models behind M_A (and M_X) that maximise L and L̄, for a known utility.

    Over every kernel K[x̃, ã, u] (rows on the probability simplex of the
    utility's decisions) with E[g | x, a] ≥ τ in every context of positive
    probability and every group: maximise
    E[g | x, a] / E[g | x, a'] (local) and E[g | a] / E[g | a'] (global, with
    E[g | a] = Σ_x P(x | a) E[g | x, a]).

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released_groups).
    utility : Utility
        g(u) (shape (n_decisions,)) or g[x, a, u] labelled with the true
        contexts and groups.
    context_mechanism : Mechanism, optional
        M_X, shape (n_contexts, n_released_contexts); default the identity on
        the contexts of ``population`` (or of the utility; one context
        ``"all"`` when neither has any).
    population : Population, optional
        P(X, A); default uniform and independent.
    tau : float, optional
        Lower bound on E[g | x, a] that the models must meet.
    method : {"auto", "threshold", "lp"}
        ``auto`` uses the threshold solution where it applies (g does not
        depend on the group and τ ≤ min_u g(u, x); for L̄ also X ⊥ A), the
        Charnes–Cooper LP elsewhere; ``lp`` forces the LP.

    Returns
    -------
    WorstModel
        ``local`` and ``global_``, each with the maximising pair (and context)
        and the worst kernel; composing the kernel with the mechanisms and
        auditing it reproduces the value.

    Raises
    ------
    InputError
        On mismatched labels, a negative or non-finite τ, or an unknown method.

    Notes
    -----
    The variables are G[x̃, ã] = Σ_u K[x̃, ã, u] g(u) ∈ [min g, max g] when
    g depends on the decision only, the kernel itself otherwise. Without a
    binding τ and for g free of the group, the local program at x is the box
    program over [min_u g(u, x), max_u g(u, x)]^{n_released} (M_X drops out).
    ``proofs/black_box.md`` (known utility). Behind k-ary randomized
    response, for a utility free of the group, both maxima are closed forms
    (§3 Propositions 3 and 3b per context; with a binding τ when M_X is the
    identity or g depends on the decision only), without the k x k matrix.

    Examples
    --------
    >>> from fairaudit.privacy import randomized_response
    >>> from fairaudit.utility import indicator
    >>> m = randomized_response(["Tom", "Mary"], keep=0.7)
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]))
    >>> round(w.local.ratio, 12), w.local.group, w.local.kernel.probabilities[0, :, 0].tolist()
    (2.333333333333, 'Tom', [1.0, 0.0])
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5)   # 11/7, as black_box_bound
    >>> round(w.local.ratio, 12), w.local.method, w.local.kernel.probabilities[0, :, 0].round(6).tolist()
    (1.571428571429, 'threshold', [1.0, 0.285714])
    >>> round(worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5, method="lp").local.ratio, 7)
    1.5714286
    """
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    if not isinstance(utility, Utility):
        raise InputError("utility", "must be a Utility", type(utility).__name__)
    method = _check_method(method)
    if tau is not None:
        tau = _nonneg("tau", tau)
    groups = mechanism.inputs
    if context_mechanism is None:
        contexts = (
            population.contexts
            if population is not None
            else utility.contexts
            if utility.contexts is not None
            else ("all",)
        )
        context_mechanism = identity(contexts, name="identity on contexts")
    if not isinstance(context_mechanism, Mechanism):
        raise InputError("context_mechanism", "must be a Mechanism", type(context_mechanism).__name__)
    contexts = context_mechanism.inputs
    if population is None:
        population = Population.uniform(contexts, groups, source="assumed")
    if not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    if population.contexts != contexts or population.groups != groups:
        raise InputError(
            "population",
            "must have the context mechanism's inputs as contexts and M_A's inputs as groups",
            (list(map(format_label, population.contexts)), list(map(format_label, population.groups))),
        )
    decisions = utility.decisions
    g = np.asarray(utility.table(contexts, groups, decisions), dtype=float)  # (nX, nA, nU), a view for g(u)
    nX, nA, nU = g.shape
    nXr, nAr = len(context_mechanism.outputs), len(mechanism.outputs)
    same_x = context_mechanism.is_identity  # then M_X is never materialised (a million contexts: 10^12 cells)
    live = population.p_context > 0
    excluded = tuple(f"context {format_label(contexts[i])!r}: P(X = x) = 0" for i in np.flatnonzero(~live))
    floor = -math.inf if tau is None else tau
    indep_a = not utility.depends_on_group
    u_only = utility.values.ndim == 1 or not (utility.depends_on_group or utility.depends_on_context)
    if utility.values.ndim == 1:
        gmin, gmax = np.full(nX, float(utility.values.min())), np.full(nX, float(utility.values.max()))
    else:
        gmin, gmax = g.min(axis=(1, 2)), g.max(axis=(1, 2))  # per context
    binding = bool(np.any(floor > gmin[live])) if live.any() else False
    independent = population.independence().independent
    assumptions = check_assumptions(mechanism, tau=None, gamma=None, population=population) + (
        Assumption("g is the given utility", "checked", f"{utility!r}"),
    )
    if tau is not None:
        assumptions += (Assumption("E[g | x, a] >= tau for every model", "vouched", f"tau = {tau:g}"),)
    released_groups, released_contexts = mechanism.outputs, context_mechanism.outputs

    def kernel_of(table: FloatArray, exact: bool = False) -> Kernel:
        if exact:  # a table of one-hot rows made here: no rounding to clean
            return Kernel(table, released_contexts, released_groups, decisions, name="worst model", _owned=True)
        t = np.clip(table, 0.0, None)
        t = t / t.sum(axis=-1, keepdims=True)
        return Kernel(t, released_contexts, released_groups, decisions, name="worst model", _owned=True)

    def audit(kernel: Kernel, kind: str) -> FloatArray:
        from .metrics import expected_utility, global_fairness

        if isinstance(mechanism, _RandomizedResponse):  # (no k x k matrix)
            law = _rr_law(kernel, mechanism.rr, groups, context_mechanism)
        else:
            law = compose(kernel, mechanism, context_mechanism)
        if kind == "local":
            return expected_utility(law, utility)
        with np.errstate(over="ignore"):  # (ratios of utilities as small as e^-710 overflow; only E[g | a] is kept)
            return global_fairness(law, utility, population).expected_utility

    if nA < 2 or not live.any():
        ones = np.ones((nXr, nAr, nU)) / nU
        k0 = kernel_of(ones)
        loc = WorstCase(
            "local",
            0.0,
            1.0,
            None,
            None,
            None,
            k0,
            None,
            None,
            "threshold",
            "trivial",
            "threshold",
            "fewer than two groups" if nA < 2 else "no context has positive probability",
            0,
        )
        glo = WorstCase(
            "global", 0.0, 1.0, None, None, None, k0, None, None, "threshold", "trivial", "threshold", loc.reason, 0
        )
        return WorstModel(loc, glo, mechanism, context_mechanism, utility, tau, population, excluded, assumptions)

    if method == "threshold" and (not indep_a or binding):
        raise InputError("method", "the threshold solution needs a utility free of the group and tau <= min g", method)

    # k-ary randomized response: closed forms, one pair of groups decides (every pair is alike)
    rr_local: WorstCase | None = None
    rr_global: WorstCase | None = None
    if isinstance(mechanism, _RandomizedResponse) and method != "lp" and indep_a:
        rr = mechanism.rr
        lo_x, hi_x = g[:, 0, :].min(-1), g[:, 0, :].max(-1)  # the range of g(., x) per context

        def rr_kernel(w: _RRWorst, lo: float, hi: float, x: int | None, high: FloatArray, low: FloatArray) -> Kernel:
            """The worst kernel: at context x (every context when None) the mix of the decisions ``high``/``low``
            that gives h; every other context all ``high`` (so it meets τ); a threshold h as one-hot rows."""
            h = w.vector(nAr)
            frac = np.clip((h - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.ones(nAr)
            table = np.zeros((nXr, nAr, nU))
            if w.prefix and x is None:
                top = w.released(nAr, hi)
                table[:] = low[:, None, :]
                table[:, top, :] = high[:, None, :]
                return kernel_of(table, exact=True)
            rows = np.arange(nXr) if x is None else np.array([x])
            table[:] = high[:, None, :]
            table[rows] = frac[None, :, None] * high[rows, None, :] + (1 - frac)[None, :, None] * low[rows, None, :]
            return kernel_of(table)

        def rr_case(kind: str, w: _RRWorst, x: int | None, kern: Kernel) -> WorstCase:
            inf = math.isinf(w.value)
            return WorstCase(
                kind,
                w.value,
                w.ratio,
                None if x is None else contexts[x],
                groups[0],
                groups[1],
                kern,
                None,
                audit(kern, kind),
                "threshold",
                "unbounded" if inf else "optimal",
                "threshold" if w.prefix else "closed form",
                "a released group is possible for one group and impossible for another" if inf else "",
                0,
            )

        def infeasible(kind: str, x: int) -> WorstCase:
            return WorstCase.infeasible(
                kind,
                "closed form",
                "no decision model meets E[g | x, a] >= tau in every cell: "
                f"tau = {tau:g} exceeds max g = {hi_x[x]:g} in context {format_label(contexts[x])!r}",
                0,
            )

        hot_hi, hot_lo = _onehot(g[:, 0, :].argmax(-1), nU), _onehot(g[:, 0, :].argmin(-1), nU)  # per context
        over = np.flatnonzero(live & (floor > hi_x))
        if binding and over.size and (u_only or same_x):
            rr_local = infeasible("local", int(over[0]))
            rr_global = infeasible("global", int(over[0])) if u_only and independent else None
        elif not binding or u_only or same_x:
            # local (proofs/black_box.md §6, Proposition 10 (a); with a binding τ, §3 Proposition 3b per context)
            ranges, cls = np.unique(np.stack([lo_x, hi_x], axis=1), axis=0, return_inverse=True)
            cls = cls.ravel()
            best_x, best_w = -1, None
            for c, (lo, hi) in enumerate(ranges.tolist()):
                at = np.flatnonzero(live & (cls == c))
                if at.size:
                    w = _rr_box(rr, lo, hi, floor)
                    if best_w is None or w.value > best_w.value or (w.value == best_w.value and at[0] < best_x):
                        best_x, best_w = int(at[0]), w
            assert best_w is not None  # (some context is live)
            lo, hi = float(lo_x[best_x]), float(hi_x[best_x])
            if not binding:  # the threshold kernel of the maximising context, in every released context
                kern = rr_kernel(
                    best_w,
                    lo,
                    hi,
                    None,
                    np.repeat(hot_hi[best_x][None], nXr, 0),
                    np.repeat(hot_lo[best_x][None], nXr, 0),
                )
            elif same_x:
                kern = rr_kernel(best_w, lo, hi, best_x, hot_hi, hot_lo)
            else:  # g(u) behind a context filter: the same h in every released context
                kern = rr_kernel(
                    replace(best_w, prefix=False), lo, hi, None, hot_hi[:1].repeat(nXr, 0), hot_lo[:1].repeat(nXr, 0)
                )
            rr_local = rr_case("local", best_w, best_x, kern)
            # global under X independent of A (Proposition 10 (b); with τ and g(u): H-bar meets every floor)
            if independent and not binding:
                px = population.p_context
                wx = (
                    px[:, None] * g[:, 0, :]
                    if same_x
                    else np.einsum("x,xy,xu->yu", px, context_mechanism.matrix, g[:, 0, :])
                )
                lo_g, hi_g = float(wx.min(-1).sum()), float(wx.max(-1).sum())
                w = _rr_box(rr, lo_g, hi_g, -math.inf)
                kern = rr_kernel(w, lo_g, hi_g, None, _onehot(wx.argmax(-1), nU), _onehot(wx.argmin(-1), nU))
                rr_global = rr_case("global", w, None, kern)
            elif independent and u_only:
                lo, hi = float(lo_x[0]), float(hi_x[0])
                w = _rr_box(rr, lo, hi, floor)
                kern = rr_kernel(
                    replace(w, prefix=False), lo, hi, None, hot_hi[:1].repeat(nXr, 0), hot_lo[:1].repeat(nXr, 0)
                )
                rr_global = rr_case("global", w, None, kern)
    general = rr_local is None or rr_global is None
    MA = mechanism.matrix if general else np.zeros((0, 0))
    pairs = np.argwhere(~np.eye(nA, dtype=bool)) if general else np.zeros((0, 2), dtype=np.intp)  # (a, b), a != b
    # box values per (x, a, b) when g is free of the group: an upper bound always, exact without a binding τ
    # The box depends on x only through [min_u g(u, x), max_u g(u, x)]: solved once per distinct range (one for
    # g(u)), box[x] = box_c[cls[x]]. (Only the local search uses them.)
    if indep_a and rr_local is None:
        if utility.values.ndim == 1:
            ranges, cls = np.array([[gmin[0], gmax[0]]]), np.zeros(nX, dtype=np.intp)
        else:
            ranges, cls = np.unique(
                np.stack([g[:, 0, :].min(-1), g[:, 0, :].max(-1)], axis=1), axis=0, return_inverse=True
            )
            cls = cls.ravel()
        # (n_ranges, nA, nA), a block of pairs at a time
        box_c = np.stack([_pairwise_box(MA, lo_c, hi_c, None)[0] for lo_c, hi_c in ranges.tolist()])
        box_c[:, np.arange(nA), np.arange(nA)] = -np.inf
    # ------------------------------------------------------------------ local
    if rr_local is not None:
        local = rr_local
    elif indep_a and not binding and method != "lp":
        best_c = box_c.reshape(len(box_c), -1).max(axis=1)
        best_c[~np.isin(np.arange(len(box_c)), cls[live])] = -np.inf  # ranges of no live context
        x = int(np.argmax(live & (best_c[cls] == best_c.max())))  # the first live maximiser
        c = cls[x]
        a, b = np.unravel_index(int(box_c[c].argmax()), (nA, nA))
        _, k_top, order_top = threshold_max_many(MA[a], MA[b], ranges[c, 0], ranges[c, 1])
        top = order_top[: int(k_top)]
        hi_u, lo_u = int(g[x, 0].argmax()), int(g[x, 0].argmin())
        table = np.zeros((nXr, nAr, nU))
        table[..., lo_u] = 1.0
        table[:, top, lo_u] = 0.0
        table[:, top, hi_u] = 1.0
        kern = kernel_of(table, exact=True)
        r = float(box_c[c, a, b])
        local = WorstCase(
            "local",
            _log(r),
            r,
            contexts[x],
            groups[a],
            groups[b],
            kern,
            None,
            audit(kern, "local"),
            "threshold",
            "unbounded" if math.isinf(r) else "optimal",
            "threshold",
            "a released group is possible for one group and impossible for another" if math.isinf(r) else "",
            0,
        )
    else:
        MX = context_mechanism.matrix
        sp_ = _model_program(MA, MX, g, live, tau, u_only, binding)
        xs = np.flatnonzero(live)
        triples = np.array([(x, a, b) for x in xs for a, b in pairs])
        if indep_a:
            upper = box_c[cls[triples[:, 0]], triples[:, 1], triples[:, 2]]
        else:
            upper = np.full(len(triples), np.inf)
        if tau is not None and tau > 0:
            upper = np.minimum(upper, g[triples[:, 0], triples[:, 1]].max(-1) / tau)
        num = lambda i: sp_.coef(triples[i, 0], triples[i, 1])  # noqa: E731
        den = lambda i: sp_.coef(triples[i, 0], triples[i, 2])  # noqa: E731
        if not indep_a:
            gmax_xa, gmin_xa = g.max(-1), g.min(-1)
            with np.errstate(divide="ignore", invalid="ignore"):
                crude = np.where(
                    gmin_xa[triples[:, 0], triples[:, 2]] > 0,
                    gmax_xa[triples[:, 0], triples[:, 1]] / gmin_xa[triples[:, 0], triples[:, 2]],
                    np.inf,
                )
            upper = np.minimum(upper, crude)
        if sp_.lo is not None and sp_.hi is not None and method != "lp":
            # closed-form relaxation (only the denominator's τ): an upper bound per triple, exact where feasible
            if sp_.rows is not None:  # (τ rows: floor = τ)
                for xc in xs:
                    P = np.stack([sp_.coef(xc, a) for a in range(nA)])
                    v = _pairwise_box(P, sp_.lo, sp_.hi, floor)[1]
                    assert v is not None  # (a floor was given)
                    at = triples[:, 0] == xc
                    upper[at] = np.minimum(upper[at], v[triples[at, 1], triples[at, 2]])
            solve = _relaxed_first(num, den, sp_.lo, sp_.hi, None if sp_.rows is None else tau, sp_.rows, sp_.program)
        else:

            def solve(i: int) -> FractionalResult:
                return sp_.program().solve(num(i), den(i))

        found = _search(upper, solve)
        local = _model_case("local", found, triples, contexts, groups, sp_.to_kernel, kernel_of, audit)
    # ------------------------------------------------------------------ global
    if rr_global is not None:
        global_ = rr_global
    elif indep_a and not binding and independent and method != "lp":
        px = population.p_context
        w = px[:, None] * g[:, 0, :] if same_x else np.einsum("x,xy,xu->yu", px, context_mechanism.matrix, g[:, 0, :])
        lo_g, hi_g = w.min(-1).sum(), w.max(-1).sum()
        vals = _pairwise_box(MA, lo_g, hi_g, None)[0]
        np.fill_diagonal(vals, -np.inf)
        a, b = np.unravel_index(int(vals.argmax()), vals.shape)
        _, k_top, order_top = threshold_max_many(MA[a], MA[b], lo_g, hi_g)
        top = order_top[: int(k_top)]
        table = np.repeat(_onehot(w.argmin(-1), nU)[:, None, :], nAr, axis=1)
        table[:, top, :] = _onehot(w.argmax(-1), nU)[:, None, :]
        kern = kernel_of(table, exact=True)
        r = float(vals[a, b])
        global_ = WorstCase(
            "global",
            _log(r),
            r,
            None,
            groups[a],
            groups[b],
            kern,
            None,
            audit(kern, "global"),
            "threshold",
            "unbounded" if math.isinf(r) else "optimal",
            "threshold",
            "",
            0,
        )
    else:
        w_xa = np.nan_to_num(population.context_given_group(), nan=0.0)  # P(x | a), (nX, nA)
        sp_ = _model_program(MA, context_mechanism.matrix, g, live, tau, u_only, binding)

        def coef_global(a: int) -> FloatArray:
            terms = [w_xa[x, a] * sp_.coef(x, a) for x in np.flatnonzero(live & (w_xa[:, a] > 0))]
            if not terms:
                raise InputError(
                    "population",
                    f"group {format_label(groups[a])!r} has P(A = a) = 0: the worst model for L-bar needs "
                    "every group to have positive probability",
                )
            return functools.reduce(operator.add, terms)

        upper = np.full(len(pairs), np.inf)
        if tau is not None and tau > 0:
            upper = np.minimum(upper, gmax.max() / tau)
        num = lambda i: coef_global(pairs[i, 0])  # noqa: E731
        den = lambda i: coef_global(pairs[i, 1])  # noqa: E731
        if sp_.lo is not None and sp_.hi is not None and method != "lp":
            P = np.stack([coef_global(a) for a in range(nA)])
            if sp_.rows is not None:  # (τ rows: floor = τ)
                v = _pairwise_box(P, sp_.lo, sp_.hi, floor)[1]
            else:
                v = _pairwise_box(P, sp_.lo, sp_.hi, None)[0]
            assert v is not None  # (a floor was given)
            upper = np.minimum(upper, v[pairs[:, 0], pairs[:, 1]])
            solve = _relaxed_first(num, den, sp_.lo, sp_.hi, None if sp_.rows is None else tau, sp_.rows, sp_.program)
        else:

            def solve(i: int) -> FractionalResult:
                return sp_.program().solve(num(i), den(i))

        found = _search(upper, solve)
        trip = np.column_stack([np.full(len(pairs), -1), pairs])
        global_ = _model_case("global", found, trip, contexts, groups, sp_.to_kernel, kernel_of, audit)
    return WorstModel(local, global_, mechanism, context_mechanism, utility, tau, population, excluded, assumptions)


@dataclass(frozen=True, eq=False)
class _ModelSpace:
    """The polytope of reachable kernels in G-space (g depends on u only) or kernel space."""

    coef: Callable[[SupportsIndex, SupportsIndex], FloatArray]  # (x, b) -> coefficients of E[g | x, b]
    to_kernel: Callable[[FloatArray], FloatArray]
    program: Callable[[], FractionalProgram]  # built on first use
    lo: float | None  # box of the variables (G-space only)
    hi: float | None
    rows: npt.NDArray[np.floating[Any]] | None  # τ rows (G-space only): rows @ h >= τ


def _model_program(
    MA: FloatArray, MX: FloatArray, g: FloatArray, live: BoolArray, tau: float | None, u_only: bool, with_tau: bool
) -> _ModelSpace:
    import scipy.sparse as sp

    nX, nA, nU = g.shape
    nXr, nAr = MX.shape[1], MA.shape[1]
    xs = np.flatnonzero(live)
    cache: list[FractionalProgram] = []

    def lazy(build: Callable[[], FractionalProgram]) -> Callable[[], FractionalProgram]:
        def program() -> FractionalProgram:
            if not cache:
                cache.append(build())
            return cache[0]

        return program

    if u_only:
        gv = g[xs[0], 0] if xs.size else g[0, 0]
        lo, hi = float(gv.min()), float(gv.max())
        hi_u, lo_u = int(gv.argmax()), int(gv.argmin())

        def coef_g(x: SupportsIndex, b: SupportsIndex) -> FloatArray:
            return np.outer(MX[x], MA[b]).ravel()

        def g_to_kernel(G: FloatArray) -> FloatArray:
            G = G.reshape(nXr, nAr)
            high = np.clip((G - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.ones_like(G)
            table = np.zeros((nXr, nAr, nU))
            table[..., hi_u] += high
            table[..., lo_u] += 1.0 - high
            return table

        rows = np.kron(MX[xs], MA) if with_tau and tau is not None and tau > lo else None
        b_rows = None if rows is None or tau is None else np.full(rows.shape[0], -tau)
        return _ModelSpace(
            coef_g,
            g_to_kernel,
            lazy(
                lambda: FractionalProgram(
                    nXr * nAr,
                    lower=lo,
                    upper=hi,
                    A_ub=None if rows is None else -rows,
                    b_ub=b_rows,
                )
            ),
            lo,
            hi,
            rows,
        )

    def coef(x: SupportsIndex, b: SupportsIndex) -> FloatArray:
        return (MX[x][:, None, None] * MA[b][None, :, None] * g[x, b][None, None, :]).ravel()

    def to_kernel(K: FloatArray) -> FloatArray:
        return K.reshape(nXr, nAr, nU)

    def build() -> FractionalProgram:
        a_eq = sp.kron(sp.identity(nXr * nAr, format="csr"), np.ones((1, nU)), format="csr")
        a_ub = b_ub = None
        if with_tau and tau is not None and tau > 0:
            a_ub = -np.stack([coef(x, b) for x in xs for b in range(nA)])
            b_ub = np.full(a_ub.shape[0], -tau)
        return FractionalProgram(
            nXr * nAr * nU, lower=0.0, upper=1.0, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=np.ones(nXr * nAr)
        )

    return _ModelSpace(coef, to_kernel, lazy(build), None, None, None)


def _model_case(
    kind: str,
    found: _Search,
    triples: IntArray,
    contexts: tuple,
    groups: tuple,
    to_kernel: Callable[[FloatArray], FloatArray],
    kernel_of: Callable[[FloatArray], Kernel],
    audit: Callable[[Kernel, str], FloatArray],
) -> WorstCase:
    r = found.result
    if found.index < 0:
        return WorstCase.infeasible(
            kind,
            r.solver_status if r else "",
            "no decision model meets E[g | x, a] >= tau in every cell: "
            + (found.reason or "the constraints are inconsistent"),
            found.solved,
        )
    assert r is not None  # a maximiser was found
    x, a, b = triples[found.index]
    kern = kernel_of(to_kernel(r.argmax)) if r.argmax is not None else None
    eu = audit(kern, kind) if kern is not None else None
    return WorstCase(
        kind,
        _log(r.value),
        r.value,
        contexts[x] if kind == "local" else None,
        groups[a],
        groups[b],
        kern,
        None,
        eu,
        "lp" if found.solved else "threshold",
        r.status,
        r.solver_status,
        r.reason,
        found.solved,
    )


# ----------------------------------------------------------------------------------------------------
# worst-case utility of a known law
# ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class WorstUtility:
    """The utilities g(u) ∈ [lower, γ] that maximise L and L̄ for a known law (:func:`worst_utility`).

    Attributes
    ----------
    local, global_ : WorstCase
        Each with its maximising utility (``.utility``, a vector over the
        law's decisions) and pair (and context).
    law : Law
    lower, gamma : float
    tau : float or None
    population : Population
    excluded : tuple of str
    """

    local: WorstCase
    global_: WorstCase
    law: Law
    lower: float
    gamma: float
    tau: float | None
    population: Population
    excluded: tuple[str, ...]


def worst_utility(
    law: Law,
    *,
    lower: float = 0.0,
    gamma: float = 1.0,
    tau: float | None = None,
    population: Population | None = None,
    method: str = "auto",
) -> WorstUtility:
    """The utility g(u) ∈ [lower, γ] that shows the largest disparity of a known law.

    Per context x and ordered pair (a, a'), maximise (Q[x, a]·g) / (Q[x, a']·g)
    (local) or (P(U | a)·g) / (P(U | a')·g) (global) over g ∈ [lower, γ]^{n_decisions},
    with E[g | x, b] = Q[x, b]·g ≥ τ in every observed cell of a context of
    positive probability (τ couples the contexts, as g is shared).

    Parameters
    ----------
    law : Law
        Q[x, a, u], shape (n_contexts, n_groups, n_decisions); empty cells are skipped.
    lower, gamma : float
        The range of g, 0 ≤ lower ≤ γ.
    tau : float, optional
        Lower bound on E[g | x, a], ≤ γ.
    population : Population, optional
        P(X, A) for L̄ and to skip contexts with P(X = x) = 0; default uniform.
    method : {"auto", "threshold", "lp"}
        ``auto``: the threshold solution when τ ≤ lower, the LP otherwise.

    Returns
    -------
    WorstUtility
        ``local`` and ``global_`` with the maximising utility, context and pair.

    Raises
    ------
    InputError
        On a bad range, τ > γ, mismatched population labels, or an unknown method.

    Notes
    -----
    With lower = 0 and no τ the value is Lemma 1's sup over g
    (:func:`fairaudit.metrics.sup_local_fairness`): the threshold keeps the
    single decision of largest likelihood ratio. ``proofs/worst_case_utility.md``.

    Examples
    --------
    >>> law = Law([[[0.5, 0.3, 0.2], [0.2, 0.3, 0.5]]], ["x"], ["a", "b"], ["hire", "wait", "reject"])
    >>> w = worst_utility(law)
    >>> round(w.local.ratio, 12), w.local.group, w.local.utility.values.tolist()   # Lemma 1: 0.5 / 0.2
    (2.5, 'a', [1.0, 0.0, 0.0])
    >>> w = worst_utility(law, lower=0.5)                  # (0.5 + 0.5·0.5) / (0.5 + 0.5·0.2)
    >>> round(w.local.ratio, 12)
    1.25
    """
    from .metrics import _check_population, group_decision_law

    if not isinstance(law, Law):
        raise InputError("law", "must be a Law", type(law).__name__)
    method = _check_method(method)
    lower, gamma, tau = _check_class(lower, gamma, tau)
    population = _check_population(population, law)
    binding = tau is not None and tau > lower
    if method == "threshold" and binding:
        raise InputError("method", "the threshold solution needs tau <= lower", method)
    Q = law.probabilities
    nX, nA, nU = Q.shape
    live_x = population.p_context > 0
    cell = law.observed & live_x[:, None]
    excluded = tuple(
        f"context {format_label(law.contexts[i])!r}: P(X = x) = 0" for i in np.flatnonzero(~live_x)
    ) + tuple(f"cell (context {format_label(x)!r}, group {format_label(a)!r}): no records" for x, a in law.empty_cells)
    decisions = law.decisions

    def util(h: FloatArray) -> Utility:
        return Utility(np.clip(h, lower, gamma), decisions, name="worst utility")

    Qz = np.nan_to_num(Q, nan=0.0)
    a_ub = -Qz[cell] if binding else None
    b_ub = None if a_ub is None or tau is None else np.full(a_ub.shape[0], -tau)
    prog: FractionalProgram | None = None

    def program() -> FractionalProgram:
        nonlocal prog
        if prog is None:
            prog = FractionalProgram(nU, lower=lower, upper=gamma, A_ub=a_ub, b_ub=b_ub)
        return prog

    def case(kind: str, P: FloatArray, valid: BoolArray, label_x: Callable[[int | None], Hashable]) -> WorstCase:
        """P: (..., nA, nU) numerators per leading index; valid: (..., nA, nA) pairs to consider."""
        vals, k, order = threshold_max_many(P[..., :, None, :], P[..., None, :, :], lower, gamma)
        vals = np.where(valid, vals, -np.inf)
        if not valid.any():
            return WorstCase(
                kind,
                math.nan,
                math.nan,
                None,
                None,
                None,
                None,
                None,
                None,
                "threshold",
                "trivial",
                "threshold",
                "no two groups can be compared",
                0,
            )
        if not binding and method != "lp":
            idx = np.unravel_index(int(vals.argmax()), vals.shape)
            top = order[idx][: int(k[idx])]
            h = np.full(nU, lower)
            h[top] = gamma
            ratio = float(vals[idx])
            x = int(idx[0]) if kind == "local" else None
            return WorstCase(
                kind,
                _log(ratio),
                ratio,
                label_x(x),
                law.groups[idx[-2]],
                law.groups[idx[-1]],
                None,
                util(h),
                None,
                "threshold",
                "unbounded" if math.isinf(ratio) else "optimal",
                "threshold",
                "a decision is possible for one group and impossible for another" if math.isinf(ratio) else "",
                0,
            )
        flat = np.argwhere(valid)
        upper = vals[tuple(flat.T)]
        if tau is not None and tau > 0:
            upper = np.minimum(upper, gamma / tau)

        def solve(i: int) -> FractionalResult:
            *lead, a, b = flat[i]
            return program().solve(P[tuple(lead) + (a,)], P[tuple(lead) + (b,)])

        found = _search(upper, solve)
        r = found.result
        if found.index < 0:
            return WorstCase.infeasible(
                kind,
                r.solver_status if r else "",
                "no utility in the class meets E[g | x, a] >= tau: " + (found.reason or ""),
                found.solved,
            )
        assert r is not None  # a maximising pair was found
        *lead, a, b = flat[found.index]
        x = lead[0] if kind == "local" else None
        return WorstCase(
            kind,
            _log(r.value),
            r.value,
            label_x(x),
            law.groups[a],
            law.groups[b],
            None,
            util(r.argmax) if r.argmax is not None else None,
            None,
            "lp" if found.solved else "threshold",
            r.status,
            r.solver_status,
            r.reason,
            found.solved,
        )

    valid_local = cell[:, :, None] & cell[:, None, :] & ~np.eye(nA, dtype=bool)[None]
    local = case("local", Qz, valid_local, lambda x: None if x is None else law.contexts[x])
    pu = np.nan_to_num(group_decision_law(law, population), nan=0.0)
    has = population.p_group > 0
    valid_global = has[:, None] & has[None, :] & ~np.eye(nA, dtype=bool)
    global_ = case("global", pu, valid_global, lambda x: None)
    return WorstUtility(local, global_, law, lower, gamma, tau, population, excluded)
