"""The largest total variation between the decision distributions of two groups, by chunks of contexts."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from fairaudit.base.arrays import FloatArray, IntArray


def max_tv_pairs(dist: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
    """Largest TV over pairs of rows along axis -2 of ``dist`` (..., n_groups, n_decisions), pair by pair.

    The route for many decisions (:func:`use_events` false): a loop over pairs of groups, each step vectorised
    over the leading axes. Returns (value, a, a') with the leading shape: the first pair (a < a') in loop order
    with the largest TV, NaN rows (absent groups) ignored.
    """
    n = dist.shape[-2]
    lead = dist.shape[:-2]
    if math.prod(lead) * n * n * dist.shape[-1] <= 1 << 14:  # few cells: every pair at once, the same numbers
        return _max_tv_all_pairs(dist)
    best = np.full(lead, np.nan)
    arg_a = np.zeros(lead, dtype=int)
    arg_b = np.zeros(lead, dtype=int)
    for a in range(n):
        for b in range(a + 1, n):  # TV is symmetric: each unordered pair once, reported in label order
            tv = np.clip(dist[..., a, :] - dist[..., b, :], 0.0, None).sum(axis=-1)
            tv = np.where(np.isnan(dist[..., a, 0]) | np.isnan(dist[..., b, 0]), np.nan, tv)
            better = ~np.isnan(tv) & (np.isnan(best) | (tv > best))
            best = np.where(better, tv, best)
            arg_a = np.where(better, a, arg_a)
            arg_b = np.where(better, b, arg_b)
    return best, arg_a, arg_b


def _max_tv_all_pairs(dist: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
    """:func:`max_tv_pairs` with the pairs as one axis: each TV summed as there (over the decisions of one row),
    the first pair in the loop's order (a, then b) with the largest, NaN ignored."""
    a, b = np.triu_indices(dist.shape[-2], 1)
    tv = np.clip(dist[..., a, :] - dist[..., b, :], 0.0, None).sum(axis=-1)
    tv = np.where(np.isnan(dist[..., a, 0]) | np.isnan(dist[..., b, 0]), np.nan, tv)
    best = np.fmax.reduce(tv, axis=-1) if tv.shape[-1] else np.full(tv.shape[:-1], np.nan)
    first = np.argmax(tv == best[..., None], axis=-1) if tv.shape[-1] else np.zeros(tv.shape[:-1], dtype=int)
    found = ~np.isnan(best)
    return best, np.where(found, a[first] if a.size else 0, 0), np.where(found, b[first] if b.size else 0, 0)


def use_events(n_groups: int, n_decisions: int) -> bool:
    """TV by events (2^(K-1) - 1 sums per group) when cheaper than by pairs of groups."""
    events = (1 << max(n_decisions - 1, 0)) - 1
    return n_decisions <= 24 and events * n_groups <= n_groups * (n_groups - 1) // 2 * n_decisions


def event_sums(ct: FloatArray) -> Iterator[tuple[int, FloatArray]]:
    """(m, P(S_m)) for every non-empty subset S_m of the first K − 1 decisions of ``ct`` (n_decisions, ...).

    m is the subset's bit mask; P(S_m) = Σ_{u in S_m} ct[u], added from the largest decision down (the same
    number for the same subset in every caller). Depth first: at most K − 1 partial sums are alive at once,
    whatever the number of subsets (a subset and its complement give the same range, so the last decision is
    never needed).
    """
    K = ct.shape[0]

    def below(mask: int, total: FloatArray, top: int) -> Iterator[tuple[int, FloatArray]]:
        for u in range(top - 1, -1, -1):
            s = total + ct[u]
            yield mask | 1 << u, s
            yield from below(mask | 1 << u, s, u)

    for v in range(K - 2, -1, -1):
        yield 1 << v, ct[v]
        yield from below(1 << v, ct[v], v)


def max_tv_pair(rows: FloatArray) -> tuple[float, int | None, int | None]:
    """The largest TV between two rows of ``rows`` (n_groups, n_decisions), and its pair, in linear time.

    TV(P, P') = max over events S of P(S) − P'(S), so the largest TV over pairs of groups is the largest range
    over groups of P(S), S over the subsets of :func:`event_sums`: O(n_groups · 2^(K − 1)) when
    :func:`use_events`, no pair of groups enumerated (otherwise, many decisions, :func:`max_tv_pairs`).
    Rows with NaN (absent groups) are left out.

    Ties are named by one rule: S is the first subset (by bit mask) with the largest range, and the pair is
    the first group (in row order) with the largest P(S) and the first with the smallest, given in row order
    (a < a'). When every row is the same (TV 0), the first two present rows; by pairs, the first pair
    (a < a') with the largest TV. The value is the pair's TV as Σ_u (P_a − P_a')⁺.
    Returns (value, a, a'): NaN and None when fewer than two rows are present.

    Examples
    --------
    >>> max_tv_pair(np.array([[0.5, 0.5], [0.9, 0.1], [np.nan, np.nan], [0.1, 0.9], [0.9, 0.1]]))
    (0.8, 1, 3)
    """
    present = np.flatnonzero(~np.isnan(rows[:, 0]))
    if present.size < 2:
        return math.nan, None, None
    r = rows[present]
    K = r.shape[1]
    if not use_events(len(present), K):
        tv, a, b = max_tv_pairs(r)
        return float(tv), int(present[int(a)]), int(present[int(b)])
    best, mask, ai, bi = -1.0, 0, 0, 1
    for m, s in event_sums(np.ascontiguousarray(r.T)):
        hi, lo = int(np.argmax(s)), int(np.argmin(s))
        spread = float(s[hi] - s[lo])
        if spread > best or (spread == best and m < mask):
            best, mask, ai, bi = spread, m, hi, lo
    ai, bi = (min(ai, bi), max(ai, bi)) if best > 0.0 else (0, 1)
    value = float(np.clip(r[ai] - r[bi], 0.0, None).sum())
    return value, int(present[ai]), int(present[bi])


def tv_chunk(ct: FloatArray, nan: bool) -> FloatArray:
    """Largest TV over pairs of groups per context of a chunk ``ct`` (n_decisions, n_groups, chunk).

    The largest range over groups of P(S) over the subsets S of :func:`event_sums` (a subset and its
    complement give the same range). Otherwise (many decisions) :func:`max_tv_pairs`. NaN where fewer than
    two groups are present.
    """
    K, A, C = ct.shape
    big, small = (np.fmax, np.fmin) if nan else (np.maximum, np.minimum)
    if use_events(A, K):
        best = np.zeros(C)
        for _, s in event_sums(ct):
            np.maximum(best, big.reduce(s, axis=0) - small.reduce(s, axis=0), out=best)
        if nan:
            best[(~np.isnan(ct[0])).sum(axis=0) < 2] = np.nan
        return best
    return max_tv_pairs(ct.transpose(2, 1, 0))[0]
