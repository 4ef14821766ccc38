"""Passes over the ordered pairs of rows of a matrix, tile by tile: the pairs of groups of bounds and worst cases."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator

import numpy as np

from fairaudit.base.arrays import FloatArray, IntArray

PAIR_BLOCK = 1 << 18
"""Elements of the one (rows, other rows, m) temporary of a :class:`PairPass` (2 MiB of doubles)."""


CANDIDATES = 32
"""How many pairs of smallest Bhattacharyya coefficient :func:`pair_candidates` proposes (both orders of each)."""


PRUNE = 1e-6
"""Relative margin of the prunings: a pair is set aside only when an upper bound puts it below (1 − PRUNE) × best."""


ROUNDING = 2.3e-16  # a little more than the unit roundoff of a double


class PairPass:
    """Σ_u max(M[a, u], λ·M[b, u]) for every ordered pair of rows, a tile at a time, in one preallocated buffer.

    This sum minus λ·Σ_u M[b, u] is the hockey-stick divergence δ_ab(λ) = Σ_u [M[a, u] − λ M[b, u]]₊, whose
    value at one λ bounds each pair's linear-fractional program (``proofs/black_box.md``, §7). A pass costs
    n²m operations and max(m, PAIR_BLOCK) + n·m doubles of memory, however large n is.
    """

    def __init__(self, matrix: FloatArray) -> None:
        self.matrix = matrix
        n, m = matrix.shape
        self.sums = matrix.sum(axis=1)
        per = max(1, PAIR_BLOCK // max(1, m))  # pairs per tile
        self.cols = max(1, min(n, per))
        self.rows = max(1, min(n, per // self.cols))
        self._buffer: FloatArray | None = None  # (rows, cols, m), made on first use
        self._lam = math.nan
        self._scaled = matrix

    def tiles(self, rows: slice | None = None) -> Iterator[tuple[slice, slice]]:
        """(rows a, rows b) covering the ordered pairs with a in ``rows`` (default all n) and any b, row-major by
        tile."""
        n = self.matrix.shape[0]
        start, stop = (0, n) if rows is None else (rows.start, rows.stop)
        for a0 in range(start, stop, self.rows):
            for b0 in range(0, n, self.cols):
                yield slice(a0, min(stop, a0 + self.rows)), slice(b0, min(n, b0 + self.cols))

    def sums_at(self, rows: slice, cols: slice, lam: float) -> FloatArray:
        """Σ_u max(M[a, u], λ M[b, u]) for a in ``rows``, b in ``cols``: shape (len(rows), len(cols))."""
        with np.errstate(over="ignore", invalid="ignore"):
            if lam != self._lam:
                self._scaled, self._lam = lam * self.matrix, lam
            p, q = self.matrix[rows], self._scaled[cols]
            if self._buffer is None:
                self._buffer = np.empty((self.rows, self.cols, p.shape[1]))
            out = self._buffer[: p.shape[0], : q.shape[0]]
            np.maximum(p[:, None, :], q[None, :, :], out=out)
            return out.sum(axis=-1)

    def error(self, rows: slice, cols: slice, lam: float) -> FloatArray:
        """A bound on the rounding error of :meth:`sums_at` (m + 8 roundings of the largest sum, Σ p + λ Σ q)."""
        m = self.matrix.shape[1]
        return (m + 8) * ROUNDING * (self.sums[rows, None] + lam * self.sums[None, cols])

    def run(self, lam: Callable[[], float], visit: Callable[[slice, slice, FloatArray, float], None]) -> None:
        """For every band of rows, ``visit(rows, all columns, sums, λ)``, λ = ``lam()`` read afresh for each band.

        A band is a few tiles' rows against every row (n·PAIR_BLOCK/(8n) sums at most), so that the callers'
        per-pair work runs on arrays of some thousands of pairs, and λ may change between bands.
        """
        n = self.matrix.shape[0]
        band = max(self.rows, min(n, PAIR_BLOCK // (8 * n)) // self.rows * self.rows)
        for a0 in range(0, n, band):
            at = lam()
            rows = slice(a0, min(n, a0 + band))
            sums = np.empty((rows.stop - a0, n))
            for sub, cols in self.tiles(rows):
                sums[sub.start - a0 : sub.stop - a0, cols] = self.sums_at(sub, cols, at)
            visit(rows, slice(0, n), sums, at)


_CANDIDATES_CACHE: dict[tuple, tuple[IntArray, IntArray]] = {}


def matrix_digest(matrix: FloatArray) -> tuple:
    """A key for a matrix's contents: its shape and a hash of its bytes (for the small caches of the pair passes)."""
    import hashlib

    data = np.ascontiguousarray(matrix, dtype=float)
    return data.shape, hashlib.blake2b(data.view(np.uint8).data, digest_size=16).digest()


def pair_candidates(matrix: FloatArray, count: int = CANDIDATES) -> tuple[IntArray, IntArray]:
    """Ordered pairs of distinct rows likely to be far apart, row-major, without duplicates.

    The ``count`` pairs of smallest Bhattacharyya coefficient Σ_u √(M[a, u] M[b, u]) (one matrix product, a
    block of rows at a time), in both orders, and the pair of the column with the largest ratio max/min. A
    heuristic only: the pruned passes start from the best of these and stay exact whatever it proposes.

    Examples
    --------
    >>> a, b = pair_candidates(np.array([[0.5, 0.5], [0.5, 0.5], [0.9, 0.1]]), count=1)
    >>> list(zip(a.tolist(), b.tolist()))
    [(0, 2), (2, 0)]
    """
    n, m = matrix.shape
    if n < 2:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    key = (matrix_digest(matrix), count)
    if key not in _CANDIDATES_CACHE:
        while len(_CANDIDATES_CACHE) >= 8:
            del _CANDIDATES_CACHE[next(iter(_CANDIDATES_CACHE))]
        _CANDIDATES_CACHE[key] = _candidates(matrix, count)
    a, b = _CANDIDATES_CACHE[key]
    return a.copy(), b.copy()


def _candidates(matrix: FloatArray, count: int) -> tuple[IntArray, IntArray]:
    """:func:`pair_candidates` without its cache."""
    n, m = matrix.shape
    root = np.sqrt(matrix)
    kept_v, kept_i = np.zeros(0), np.zeros(0, dtype=np.intp)
    step = max(1, PAIR_BLOCK // n)
    for a0 in range(0, n, step):
        coef = root[a0 : a0 + step] @ root.T
        own = np.arange(coef.shape[0])
        coef[own, own + a0] = np.inf
        flat = coef.ravel()
        take = min(count, flat.size)
        idx = np.argpartition(flat, take - 1)[:take]
        kept_v, kept_i = np.concatenate([kept_v, flat[idx]]), np.concatenate([kept_i, idx + a0 * n])
        if kept_v.size > count:
            sel = np.argpartition(kept_v, count - 1)[:count]
            kept_v, kept_i = kept_v[sel], kept_i[sel]
    a, b = np.divmod(kept_i[np.isfinite(kept_v)], n)
    hi, lo = matrix.argmax(axis=0), matrix.argmin(axis=0)
    top, bottom = matrix[hi, np.arange(m)], matrix[lo, np.arange(m)]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(bottom > 0, top / np.where(bottom > 0, bottom, 1.0), np.where(top > 0, np.inf, 0.0))
    u = int(np.argmax(ratio))
    extra = [hi[u] * n + lo[u]] if hi[u] != lo[u] else []
    flat_pairs = np.unique(np.concatenate([a * n + b, b * n + a, np.asarray(extra, dtype=np.intp)]))
    return np.divmod(flat_pairs, n)
