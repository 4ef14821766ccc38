"""The minimum over a general mechanism's privacy profile, for the paper and the tight form of the main theorem.

* paper: min over t = e^ε ≥ 1 of log t + log(1 + (c + γ δ(t)) / τ), with δ(t) the upper envelope of every
  pair's lines t ↦ P_k − t Q_k (prefix sums in likelihood-ratio order): the minimum is at t = 1 or at a
  breakpoint of the envelope (:func:`paper_minimum`);
* tight: max over pairs of min over t ≥ 1 of t + (L_A d + γ δ_aa'(t)) / τ, convex and piecewise linear in t,
  so each pair's minimum is at t = 1 or at one of its ratios (:func:`tight_maximum`).

Both work on a few pairs first and check the others by one pass over the pairs (``proofs/black_box.md`` §7),
so that no pair is missed and none is solved that cannot matter. Proofs: ``proofs/main_theorem.md`` (the
profile minimisation and its candidate set) and ``proofs/tight_bound.md``.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from fairaudit.base.arrays import FloatArray, IntArray, first_max
from fairaudit.base.outward import fraction_up, log_up, up, widen_up
from fairaudit.base.pairs import CANDIDATES, PAIR_BLOCK, PRUNE, PairPass, pair_candidates
from fairaudit.laws.mechanisms import EXACT_PAIRS, Mechanism, exact_hockey_stick, largest_hockey_stick

__all__ = ["paper_minimum", "tight_maximum"]


def _sorted(p: FloatArray, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """For pairs of rows (p[..., :], q[..., :]), the outputs sorted by p/q descending: (ratio, p, q), same shapes.

    Ratios follow the conventions c/0 = inf and 0/0 = 0 (such outputs add nothing to any hockey-stick divergence).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(q > 0, p / np.where(q > 0, q, 1.0), np.where(p > 0, np.inf, 0.0))
    order = np.argsort(-ratio, axis=-1, kind="stable")
    take = np.take_along_axis
    return take(ratio, order, -1), take(np.broadcast_to(p, ratio.shape), order, -1), take(q, order, -1)


def _pair_lines(p: FloatArray, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The lines t ↦ P_k − t Q_k (prefix sums in likelihood-ratio order) of pairs of rows: δ_pq(t) is their max."""
    _, ps, qs = _sorted(p, q)
    zeros = np.zeros(ps.shape[:-1] + (1,))
    big_p = np.concatenate([zeros, np.cumsum(ps, axis=-1)], axis=-1).ravel()
    big_q = np.concatenate([zeros, np.cumsum(qs, axis=-1)], axis=-1).ravel()
    return -big_q, big_p


def _upper_envelope(slopes: FloatArray, intercepts: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Upper envelope of lines y = s·t + c over t ∈ ℝ: (slopes, intercepts, breakpoints).

    Lines are kept in increasing slope; breakpoint i is where line i hands
    over to line i + 1.
    """
    order = np.lexsort((-intercepts, slopes))
    s, c = slopes[order], intercepts[order]
    first = np.ones(len(s), dtype=bool)
    first[1:] = s[1:] != s[:-1]  # equal slopes: keep the largest intercept (sorted first)
    s, c = s[first], c[first]
    hull_s: list[float] = []
    hull_c: list[float] = []
    for sk, ck in zip(s.tolist(), c.tolist()):
        while len(hull_s) >= 2:
            s1, c1, s2, c2 = hull_s[-2], hull_c[-2], hull_s[-1], hull_c[-1]
            # line 2 is useless when its crossing with line 1 is not left of its crossing with line k
            if (c1 - c2) * (sk - s2) >= (c2 - ck) * (s2 - s1):
                hull_s.pop()
                hull_c.pop()
            else:
                break
        hull_s.append(sk)
        hull_c.append(ck)
    hs, hc = np.array(hull_s), np.array(hull_c)
    breaks = (hc[:-1] - hc[1:]) / (hs[1:] - hs[:-1])
    return hs, hc, breaks


def _profile_candidates(mechanism: Mechanism) -> tuple[FloatArray, FloatArray]:
    """Candidate t = e^ε ≥ 1 for the paper form and δ(t) there (the exact envelope of every pair's lines)."""
    m = mechanism.matrix
    n = m.shape[0]
    a, b = np.nonzero(~np.eye(n, dtype=bool))
    return _envelope_candidates(m, a, b)


def _envelope_candidates(matrix: FloatArray, a: IntArray, b: IntArray) -> tuple[FloatArray, FloatArray]:
    """Candidate t ≥ 1 (1 and the breakpoints of the envelope) and max over the pairs (a[i], b[i]) of δ(t) there.

    The envelope of a union of lines is the envelope of the blocks' envelopes: a block of pairs at a time.
    """
    step = max(1, PAIR_BLOCK // (4 * max(1, matrix.shape[1])))
    slopes, intercepts = [], []
    for s in range(0, a.size, step):
        lines_s, lines_c = _pair_lines(matrix[a[s : s + step]], matrix[b[s : s + step]])
        if a.size > step:
            lines_s, lines_c, _ = _upper_envelope(lines_s, lines_c)
        slopes.append(lines_s)
        intercepts.append(lines_c)
    hs, hc, breaks = _upper_envelope(np.concatenate(slopes), np.concatenate(intercepts))
    t = np.unique(np.concatenate([[1.0], breaks[np.isfinite(breaks) & (breaks > 1.0)]]))
    delta = np.clip((hc[None, :] + hs[None, :] * t[:, None]).max(axis=1), 0.0, 1.0)
    return t, delta


def paper_minimum(matrix: FloatArray, gamma: float, tau: float, c: float) -> tuple[float, float, float]:
    """(value, ε, δ) of the paper form for a general mechanism, without the envelope of every pair.

    The envelope of a set S of pairs gives δ_S ≤ δ and its minimiser t_S; one pass checks δ_ab(t_S) ≤ δ_S(t_S)
    for every pair (to rounding), and then min_t of the objective with δ equals that with δ_S
    (``proofs/black_box.md`` §7). Otherwise the pairs above it join S and the check is repeated.
    """
    n = matrix.shape[0]
    a, b = pair_candidates(matrix)
    passer = PairPass(matrix)
    checked, complete = math.nan, False  # the t of the last pass; whether every pair above there joined S
    while True:
        t, deltas = _envelope_candidates(matrix, a, b)
        values = np.log(t) + np.log1p((c + gamma * deltas) / tau)
        k = int(np.argmin(values))
        at, level = float(t[k]), float(deltas[k])
        if at == checked and complete:  # (the pairs left out were below the old level there, ≤ the new one)
            return _paper_at(matrix, at, gamma, tau, c)
        above: list[tuple[FloatArray, IntArray]] = []

        def visit(rows: slice, cols: slice, sums: FloatArray, lam: float) -> None:
            # above δ_S(t_S) beyond the rounding of both (the pass's sums and the envelope's prefix sums)
            delta = sums - lam * passer.sums[None, cols] - 2 * passer.error(rows, cols, lam) - 1e-15
            delta[np.arange(rows.stop - rows.start), np.arange(rows.start, rows.stop)] = -np.inf
            i, j = np.nonzero(delta > level)
            above.append((delta[i, j], (i + rows.start) * n + j))

        passer.run(lambda: at, visit)
        gaps = np.concatenate([x[0] for x in above])
        flat = np.concatenate([x[1] for x in above])
        new = ~np.isin(flat, a * n + b)  # (a pair of S is never above its own envelope but by rounding)
        if not new.any():
            return _paper_at(matrix, at, gamma, tau, c)
        gaps, flat = gaps[new], flat[new]
        a, b = np.divmod(np.union1d(a * n + b, flat[np.argsort(-gaps, kind="stable")[: 4 * CANDIDATES]]), n)
        checked, complete = at, gaps.size <= 4 * CANDIDATES


def _paper_at(matrix: FloatArray, t: float, gamma: float, tau: float, c: float) -> tuple[float, float, float]:
    """(value, ε, δ) of the paper form at the float t = e^ε ≥ 1, certified: any t gives a valid bound, so the
    minimiser found in floating point is evaluated again with δ(t) over every pair rounded up
    (:func:`~fairaudit.laws.mechanisms.largest_hockey_stick`) and ln(t (1 + (c + γδ)/τ)) of the exact rational
    rounded up (``proofs/outward.md`` §5). ε is ln t rounded up, so that δ(ε) ≤ δ(t): the value is ε + ln(1 + (c +
    γδ)/τ), rounded up, at the (ε, δ) recorded, as a verifier re-derives it."""
    delta = largest_hockey_stick(matrix, t)
    above = t
    for _ in range(4 if 0.0 < delta < 1e-12 else 0):  # t just below the ratio the minimum sits on: δ = 0 just above
        above = float(np.nextafter(above, np.inf))
        if largest_hockey_stick(matrix, above) == 0.0:
            t, delta = above, 0.0
            break
    x = (Fraction(c) + Fraction(gamma) * Fraction(delta)) / Fraction(tau)
    eps = log_up(t)  # ≥ ln t, so δ(ε) ≤ δ(t): the pair (ε, δ) recorded is itself a valid one
    return fraction_up(Fraction(eps) + Fraction(log_up(1 + x))), eps, delta


def _tight_objective(
    p: FloatArray, q: FloatArray, dist: FloatArray, gamma: float, tau: float, lipschitz: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """min over t ≥ 1 of t + (L_A d + γ δ_pq(t))/τ for pairs of rows, and its t and δ: convex and piecewise
    linear in t, so the minimum is at t = 1 or at one of the pair's ratios (the first such, on ties)."""
    ratio, ps, qs = _sorted(p, q)
    # δ at t = ratio_k: mass of the outputs strictly before k (ties add 0).
    p_before = np.cumsum(ps, axis=-1) - ps
    q_before = np.cumsum(qs, axis=-1) - qs
    with np.errstate(invalid="ignore"):
        delta_k = np.clip(p_before - ratio * q_before, 0.0, None)
    valid = np.isfinite(ratio) & (ratio >= 1.0)
    delta_1 = np.clip(ps - qs, 0.0, None).sum(axis=-1)  # t = 1 (ε = 0): total variation
    t = np.concatenate([np.ones(ratio.shape[:-1] + (1,)), np.where(valid, ratio, np.inf)], axis=-1)
    dl = np.concatenate([delta_1[..., None], np.where(valid, delta_k, 0.0)], axis=-1)
    objective = t + (lipschitz * dist[..., None] + gamma * dl) / tau
    best_k = objective.argmin(axis=-1)[..., None]
    take = np.take_along_axis
    return take(objective, best_k, -1)[..., 0], take(t, best_k, -1)[..., 0], take(dl, best_k, -1)[..., 0]


def tight_maximum(
    matrix: FloatArray, d: FloatArray | None, gamma: float, tau: float, lipschitz: float
) -> tuple[float, float, float, int, int]:
    """(value, ε, δ, a, a') of the tight form for a general mechanism (``d`` None: the discrete metric).

    Every pair's minimum is at most its objective at one t = λ, so one pass over the pairs at λ (the best pair's
    minimiser) sets aside every pair that cannot reach the best value found; the rest are solved exactly
    (``proofs/black_box.md`` §7). The maximum and its first row-major maximiser are those of all pairs.
    """
    n = matrix.shape[0]

    def dist(a: IntArray | slice, b: IntArray | slice) -> FloatArray:
        if d is None:
            return np.asarray(1.0) if isinstance(a, slice) else np.ones(np.shape(a))
        return d[a, b]

    parts: list[tuple[IntArray, IntArray, FloatArray, FloatArray, FloatArray]] = []
    state = {"best": -math.inf, "lam": 1.0}

    def offer(a: IntArray, b: IntArray) -> None:
        step = max(1, PAIR_BLOCK // (8 * max(1, matrix.shape[1])))
        for s in range(0, a.size, step):
            at, bt = a[s : s + step], b[s : s + step]
            parts.append((at, bt, *_tight_objective(matrix[at], matrix[bt], dist(at, bt), gamma, tau, lipschitz)))
            i = int(np.argmax(parts[-1][2]))
            if parts[-1][2][i] > state["best"]:
                state["best"], state["lam"] = float(parts[-1][2][i]), min(float(parts[-1][3][i]), 1e300)

    def visit(rows: slice, cols: slice, sums: FloatArray, lam: float) -> None:
        delta = sums - lam * passer.sums[None, cols] + passer.error(rows, cols, lam)
        with np.errstate(over="ignore"):
            bound = (lam + (lipschitz * dist(rows, cols) + gamma * delta) / tau) * (1 + 1e-12)
        bound[np.arange(rows.stop - rows.start), np.arange(rows.start, rows.stop)] = -np.inf
        i, j = np.nonzero(bound >= state["best"] * (1 - PRUNE))
        if i.size:
            offer(i + rows.start, j + cols.start)

    def certified(pa: IntArray, pb: IntArray, obj: FloatArray, ts: FloatArray) -> float:
        """The tight value max over pairs of ln(objective at the pair's t), rounded up (``proofs/outward.md`` §5).

        Each float objective t + (L_A d + γδ)/τ is within e = (m + 4)·2u·(1 + t)·γ/τ + 8u·obj of the exact one at
        the same float t (δ from prefix sums of m terms); the pairs whose objective plus e reaches the largest
        objective minus e are evaluated again exactly (up to ``EXACT_PAIRS``; beyond, the widened maximum).
        """
        if not np.all(np.isfinite(obj)):
            return math.inf
        m = matrix.shape[1]
        u = 2.0**-53
        with np.errstate(over="ignore"):
            err = (m + 4) * 2 * u * (1.0 + ts) * (gamma / tau) + 8 * u * obj
        err = up(up(err) * (1 + 8 * u))
        near = np.flatnonzero(obj + err >= np.max(obj - err))
        near = near[np.unique(pa[near] * n + pb[near], return_index=True)[1]]  # (a pair offered twice)
        if near.size > EXACT_PAIRS:
            return log_up(float(widen_up(np.max(obj + err), 4 * u)))
        g, t_, lip, dists = Fraction(gamma), Fraction(tau), Fraction(lipschitz), dist(pa, pb)
        best = Fraction(0)
        for i in near.tolist():
            ra, rb, fixed = matrix[pa[i]], matrix[pb[i]], lip * Fraction(float(dists[i]))
            best = max(
                best, min(t + (fixed + g * exact_hockey_stick(ra, rb, t)) / t_ for t in _exact_ts(ra, rb, ts[i]))
            )
        return log_up(best)

    a, b = pair_candidates(matrix)
    if d is not None and lipschitz > 0:  # the pair of largest distance, the first row-major
        far = np.unravel_index(int(np.argmax(np.where(np.eye(n, dtype=bool), -np.inf, d))), d.shape)
        a, b = np.divmod(np.union1d(a * n + b, [far[0] * n + far[1]]), n)
    offer(a, b)
    passer = PairPass(matrix)
    passer.run(lambda: state["lam"], visit)
    pa, pb, obj, ts, ds = (np.concatenate([x[i] for x in parts]) for i in range(5))
    i = first_max(obj, order=pa * n + pb)
    assert i is not None  # the pass visits every pair: obj holds no NaN
    return certified(pa, pb, obj, ts), float(np.log(ts[i])), float(ds[i]), int(pa[i]), int(pb[i])


def _exact_ts(ra: FloatArray, rb: FloatArray, t: float) -> set[Fraction]:
    """The float minimiser ``t`` and the exact ratios ra_o/rb_o ≥ 1 it rounds (within 1e-12): the pair's exact
    minimum sits at one of these, not at the float (with γ/τ = 1e6, an ulp of t moves the objective by 1e-10)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = ra / rb
    near = np.flatnonzero((rb > 0) & (np.abs(ratio - t) <= 1e-12 * t))
    exact = {Fraction(float(ra[o])) / Fraction(float(rb[o])) for o in near.tolist()}
    return {Fraction(float(t))} | {x for x in exact if x >= 1}
